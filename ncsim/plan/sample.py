"""Sampling a planned :class:`~ncsim.motion.Motion` into a :class:`~ncsim.motion.Trace`.

The feed law is a sequence of constant-jerk pieces along the path (``motion.py``); geometry maps
arc length to position (``geometry.py``). A sample at time ``t`` therefore takes:

1. the piece ``k`` with ``piece_t_s[k] <= t < piece_t_s[k+1]`` (``searchsorted``), and with
   ``tau = t - piece_t_s[k]`` the path state of the piece polynomial::

       s = s0 + v0 tau + a0 tau^2/2 + j tau^3/6,   V = v0 + a0 tau + j tau^2/2,   A_t = a0 + j tau

2. the block from ``s`` (cumulative block lengths): a sample exactly at a junction belongs to the
   block starting there, a dwell sample (standing at a junction) to the block about to start, the
   last sample to the last block;
3. the axis quantities from the Frenet frame (tangent ``t``, curvature vector ``kappa n``)::

       V_vec = V t                                                       (paper eq. 1)
       A_vec = A_t t + V^2 kappa n                                       (paper eq. 1)
       J_vec = J_t t + 3 V A_t kappa n + V^3 d(kappa n)/ds               (derivative of eq. 1, eq. 3)

   with ``d(kappa n)/ds = (w x kappa n) / rho`` on a circular helix of radius ``r``, normal
   ``w`` and ``rho = sqrt(r^2 + p^2)`` (``p`` the rise per radian): for a circle (``p = 0``)
   this is ``-kappa^2 t``; on a helix it is ``kappa (-kappa t + tau_h b)`` with the torsion
   ``tau_h = p / rho^2`` (Frenet-Serret). Lines have ``kappa n = 0``.

   The scalar normal terms are ``A_n = V^2 kappa`` (eq. 1, 2) and ``J_n = V^3 kappa^2`` (eq. 3,
   the jerk of the direction change at constant feed, the paper's ``J_t = V_f^3 / R_r^2``; on a
   helix the direction-change jerk is larger, ``V^3 kappa sqrt(kappa^2 + tau_h^2)``, and is in
   ``J_vec``).

Positions and the frame use the geometry of ``geometry.point_at`` / ``tangent_at`` /
``curvature_at`` in one form for lines and helices, with coefficients computed once per block
(:func:`segment_coefficients`; the tests check it against those functions): calling them per
sample would rebuild each arc's basis for every sample (several times slower). Samples are
computed in fixed-size chunks written into preallocated columns: a million samples take about
0.4 s and ~180 MB (the trace itself), with no temporary larger than one chunk.
"""
from __future__ import annotations

import numpy as np

from ncsim.errors import UsageError
from ncsim.geometry import arc_basis
from ncsim.motion import Limit, Motion, Phase
from ncsim.path import ARC, Path
from ncsim.motion import Trace

CHUNK_SAMPLES = 1 << 16          # samples evaluated at once (bounds temporary memory)
MAX_SAMPLES = 50_000_000         # refuse grids that would not fit in memory (~9 GB of trace)
_S_SNAP_REL = 1e-10              # relative tolerance on s when assigning samples to blocks
_T_GRID_REL = 1e-9               # a grid point this close to the end (in dt) is the end


# ---------------------------------------------------------------------------------------------
# Pure pieces
# ---------------------------------------------------------------------------------------------

def time_grid_s(total_time_s: float, dt_s: float) -> np.ndarray:
    """Sample times ``0, dt, 2 dt, ...`` up to ``total_time_s``, plus the end time itself when
    it is not on the grid (so the trace ends where the motion ends, at rest)."""
    if not (np.isfinite(dt_s) and dt_s > 0):
        raise UsageError(f"sampling period must be a positive number of seconds, got {dt_s!r}")
    total = float(total_time_s)
    if total <= 0:
        return np.zeros(1)
    n_steps = int(np.floor(total / dt_s * (1 + _T_GRID_REL)))
    if n_steps + 2 > MAX_SAMPLES:
        raise UsageError(f"sampling {total:g} s every {dt_s:g} s gives {n_steps + 1} samples, "
                         f"more than {MAX_SAMPLES}: use a larger period")
    t = np.arange(n_steps + 1, dtype=np.float64) * dt_s
    if total - t[-1] > _T_GRID_REL * dt_s:
        t = np.append(t, total)
    else:
        t[-1] = total
    return t


def piece_state(t0_s, s0_mm, v0_mm_s, a0_mm_s2, j_mm_s3, t_s):
    """Path length, feed and tangential acceleration of constant-jerk pieces at time ``t_s``
    (ruckig's ``integrate``): ``s = s0 + v0 tau + a0 tau^2/2 + j tau^3/6``, ``tau = t - t0``."""
    tau = t_s - t0_s
    s = s0_mm + tau * (v0_mm_s + tau * (0.5 * a0_mm_s2 + tau * (j_mm_s3 / 6.0)))
    v = v0_mm_s + tau * (a0_mm_s2 + tau * (0.5 * j_mm_s3))
    a = a0_mm_s2 + tau * j_mm_s3
    return s, v, a


def piece_index(piece_t_s: np.ndarray, t_s: np.ndarray) -> np.ndarray:
    """Index of the piece holding each time: the last piece starting at or before it (a time
    on a piece boundary belongs to the piece starting there; the end time to the last piece)."""
    m = len(piece_t_s) - 1
    k = np.searchsorted(piece_t_s, t_s, side="right") - 1
    return np.clip(k, 0, m - 1)


def block_index(s_start_mm: np.ndarray, s_mm: np.ndarray, tol_mm: float = 0.0) -> np.ndarray:
    """Block holding each path length: the last block starting at or before ``s + tol`` (a
    point on a junction belongs to the block starting there), clipped to the valid range."""
    b = np.searchsorted(s_start_mm, s_mm + tol_mm, side="right") - 1
    return np.clip(b, 0, len(s_start_mm) - 1)


def helix_rho_mm(path: Path) -> np.ndarray:
    """ds/dphi of each segment: ``sqrt(r^2 + p^2) = length / sweep`` on arcs, inf on lines."""
    rho = np.full(path.n, np.inf)
    arc = (path.kind == ARC) & (path.sweep_rad > 0)
    rho[arc] = path.length_mm[arc] / path.sweep_rad[arc]
    return rho


def segment_coefficients(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Per segment, the coefficients of ``P(s) = C + cos(k s) U + sin(k s) V + s W``.

    The geometry of ``geometry.point_at`` in one form for lines and helices: a line has
    ``C = start``, ``U = V = 0``, ``W`` its unit direction and ``k = 0``; an arc has ``C`` its
    centre, ``U = r u``, ``V = r v`` (``u, v, w`` from ``geometry.arc_basis``),
    ``W = (p / rho) w`` and ``k = 1 / rho``. Every arc-length derivative has the same form::

        t             = P'   = k (-sin U + cos V) + W
        kappa n       = P''  = -k^2 (cos U + sin V)
        d(kappa n)/ds = P''' = -k^3 (-sin U + cos V)     (= -kappa^2 t on a circle, eq. 3)

    Returns ``(coef, k)``: ``coef`` (12, n) holds the rows Cx Cy Cz Ux .. Wz (axis-major, so
    that per-sample gathers and arithmetic run on contiguous 1-D arrays); ``k`` (n,) is 1/rho,
    0 on lines. Computed once per block, gathered per sample: this makes sampling cheap.
    """
    n = path.n
    coef = np.zeros((12, n))
    k = np.zeros(n)
    line = path.kind != ARC
    d = path.end_mm[line] - path.start_mm[line]
    ln = path.length_mm[line][:, None]
    coef[0:3, line] = path.start_mm[line].T
    coef[9:12, line] = np.divide(d, ln, out=np.zeros_like(d), where=ln > 0).T
    arc = ~line
    if np.any(arc):
        u, v, w = arc_basis(path.center_mm[arc], path.normal[arc], path.start_mm[arc])
        r = path.radius_mm[arc]
        rho = helix_rho_mm(path)[arc]
        ok = np.isfinite(rho) & (rho > 0)
        with np.errstate(divide="ignore", invalid="ignore"):
            rise_per_mm = np.where(ok, path.helix_mm[arc] / path.sweep_rad[arc] / rho, 0.0)
            k[arc] = np.where(ok, 1.0 / rho, 0.0)
        coef[0:3, arc] = path.center_mm[arc].T
        coef[3:6, arc] = (r[:, None] * u).T
        coef[6:9, arc] = (r[:, None] * v).T
        coef[9:12, arc] = (rise_per_mm[:, None] * w).T
    return coef, k


def frenet_at(coef: np.ndarray, k: np.ndarray, s_local_mm: np.ndarray):
    """Position, unit tangent, curvature vector ``kappa n`` and ``d(kappa n)/ds``, each (3, m),
    at ``s_local_mm`` (m,) from gathered :func:`segment_coefficients` columns ``coef`` (12, m)
    and ``k`` (m,)."""
    phi = k * s_local_mm
    arc = k != 0.0
    if arc.all():
        c = np.cos(phi)
        sn = np.sin(phi)
    else:                            # lines: phi = 0, no trigonometry for their samples
        c = np.ones_like(phi)
        sn = np.zeros_like(phi)
        if arc.any():
            c[arc] = np.cos(phi[arc])
            sn[arc] = np.sin(phi[arc])
    U, V, W = coef[3:6], coef[6:9], coef[9:12]
    radial = c * U + sn * V          # r (cos u + sin v)
    along = c * V - sn * U           # r (-sin u + cos v)
    k2 = k * k
    pos = coef[0:3] + radial + s_local_mm * W
    tangent = k * along + W
    kappa_n = radial * -k2
    dkappa_n = along * -(k2 * k)
    return pos, tangent, kappa_n, dkappa_n


def axis_derivatives(tangent, kappa_n, dkappa_n_ds, v_mm_s, a_t_mm_s2, j_t_mm_s3):
    """Per-axis velocity, acceleration and jerk (each (3, m)) from the feed law (m,) and the
    Frenet frame (3, m): ``V t``, ``A_t t + V^2 kappa n`` (eq. 1) and
    ``J_t t + 3 V A_t kappa n + V^3 d(kappa n)/ds`` (time derivative of eq. 1, cf. eq. 3)."""
    v, a, j = v_mm_s, a_t_mm_s2, j_t_mm_s3
    v2 = v * v
    vel = v * tangent
    acc = a * tangent + v2 * kappa_n
    jerk = j * tangent + (3.0 * v * a) * kappa_n + (v2 * v) * dkappa_n_ds
    return vel, acc, jerk


# ---------------------------------------------------------------------------------------------
# Sampling
# ---------------------------------------------------------------------------------------------

def _empty_trace() -> Trace:
    f = lambda: np.zeros(0)  # noqa: E731
    v3 = lambda: np.zeros((0, 3))  # noqa: E731
    return Trace(t_s=f(), s_mm=f(), feed_mm_s=f(), accel_t_mm_s2=f(), jerk_t_mm_s3=f(),
                 accel_n_mm_s2=f(), jerk_n_mm_s3=f(), pos_mm=v3(), vel_mm_s=v3(),
                 acc_mm_s2=v3(), jerk_mm_s3=v3(), block=np.zeros(0, np.int32),
                 line=np.zeros(0, np.int32), limit=np.zeros(0, np.int8),
                 phase=np.zeros(0, np.int8), setpoint_mm_s=f(), programmed_mm_s=f())


def _check_times(motion: Motion, t_s) -> np.ndarray:
    t = np.asarray(t_s, dtype=np.float64)
    if t.ndim != 1:
        raise UsageError(f"sample times must be a 1-D array, got shape {t.shape}")
    if len(t) > MAX_SAMPLES:
        raise UsageError(f"{len(t)} sample times, more than {MAX_SAMPLES}")
    if not np.all(np.isfinite(t)):
        raise UsageError("sample times must be finite numbers")
    total = motion.total_time_s
    tol = 1e-9 * max(total, 1e-3)
    if len(t) and (t.min() < -tol or t.max() > total + tol):
        raise UsageError(f"sample times must lie in [0, {total:g}] s (the motion), "
                         f"got [{t.min():g}, {t.max():g}] s")
    return np.clip(t, 0.0, total)


def sample_motion(motion: Motion, dt_s: float | None = None, *, t_s: np.ndarray | None = None) -> Trace:
    """Sample ``motion`` every ``dt_s`` seconds (default: the NCU's interpolation cycle) from 0
    to its end (the end time is always the last sample), or at the given times ``t_s`` (any
    order, within the motion). See the module docstring for what each column holds.
    """
    if dt_s is not None and t_s is not None:
        raise UsageError("give either a sampling period or sample times, not both")
    path = motion.path
    if path.n == 0 or len(motion.piece_t_s) < 2:
        if t_s is not None and len(np.asarray(t_s)):
            raise UsageError("cannot sample an empty motion at given times")
        return _empty_trace()
    if t_s is None:
        if dt_s is None:
            dt_s = motion.machine.ncu.ipo_cycle_s
        t = time_grid_s(motion.total_time_s, float(dt_s))
    else:
        t = _check_times(motion, t_s)

    m = len(t)
    out = dict(
        t_s=t, s_mm=np.empty(m), feed_mm_s=np.empty(m), accel_t_mm_s2=np.empty(m),
        jerk_t_mm_s3=np.empty(m), accel_n_mm_s2=np.empty(m), jerk_n_mm_s3=np.empty(m),
        pos_mm=np.empty((m, 3)), vel_mm_s=np.empty((m, 3)), acc_mm_s2=np.empty((m, 3)),
        jerk_mm_s3=np.empty((m, 3)), block=np.empty(m, np.int32), line=np.empty(m, np.int32),
        limit=np.empty(m, np.int8), phase=np.empty(m, np.int8), setpoint_mm_s=np.empty(m),
        programmed_mm_s=np.empty(m))

    s_start = path.s_start_mm
    snap = _S_SNAP_REL * max(path.total_length_mm, 1.0)
    coef, k_phi = segment_coefficients(path)
    kappa = np.where(path.kind == ARC, np.nan_to_num(path.radius_mm) * k_phi * k_phi, 0.0)  # r/rho^2
    piece_t0 = motion.piece_t_s[:-1]
    steady = motion.piece_phase == Phase.B
    take = np.take
    g = np.empty((12, min(CHUNK_SAMPLES, m)))
    for lo in range(0, m, CHUNK_SAMPLES):
        hi = min(lo + CHUNK_SAMPLES, m)
        tc = t[lo:hi]
        k = piece_index(motion.piece_t_s, tc)
        j = take(motion.piece_j_mm_s3, k)
        s, v, a = piece_state(take(piece_t0, k), take(motion.piece_s_mm, k),
                              take(motion.piece_v_mm_s, k), take(motion.piece_a_mm_s2, k), j, tc)
        b = block_index(s_start, s, snap)
        s_local = np.clip(s - take(s_start, b), 0.0, take(path.length_mm, b))
        gc = g[:, :hi - lo]
        for row in range(12):
            take(coef[row], b, out=gc[row])
        pos, tangent, kappa_n, dkn = frenet_at(gc, take(k_phi, b), s_local)
        vel, acc, jerk = axis_derivatives(tangent, kappa_n, dkn, v, a, j)

        out["s_mm"][lo:hi] = s
        out["feed_mm_s"][lo:hi] = v
        out["accel_t_mm_s2"][lo:hi] = a
        out["jerk_t_mm_s3"][lo:hi] = j
        for name, value in (("pos_mm", pos), ("vel_mm_s", vel), ("acc_mm_s2", acc),
                            ("jerk_mm_s3", jerk)):
            col = out[name]
            for axis in range(3):
                col[lo:hi, axis] = value[axis]
        kap = take(kappa, b)
        v2k = v * v * kap
        out["accel_n_mm_s2"][lo:hi] = v2k                 # V^2 kappa (eq. 1, 2)
        out["jerk_n_mm_s3"][lo:hi] = v2k * v * kap        # V^3 kappa^2 (eq. 3)
        out["phase"][lo:hi] = take(motion.piece_phase, k)
        out["limit"][lo:hi] = np.where(take(steady, k), take(motion.cap_limit, b),
                                       take(motion.piece_limit, k))
        out["block"][lo:hi] = b
        out["line"][lo:hi] = take(path.line, b)
        out["setpoint_mm_s"][lo:hi] = take(motion.cap_mm_s, b)
        out["programmed_mm_s"][lo:hi] = take(path.feed_mm_s, b)
    return Trace(**out)


# ---------------------------------------------------------------------------------------------
# Per-block summary
# ---------------------------------------------------------------------------------------------

def limit_labels(codes: np.ndarray) -> np.ndarray:
    """Public names (``ncu_path_jerk`` ...) of an array of :class:`~ncsim.motion.Limit` codes,
    as an object array of shared strings (8 bytes a row)."""
    table = np.array([m.label for m in Limit], dtype=object)
    return table[np.asarray(codes, dtype=np.int64)]


def _read_only(a: np.ndarray) -> np.ndarray:
    view = a.view()
    view.flags.writeable = False
    return view


def block_table(motion: Motion) -> dict[str, np.ndarray]:
    """One row per block, for reports and ``--json``: where it is, when it runs, how fast and
    why, and the time lost against the programmed feed (``duration - length / F``; a rapid
    block, programmed at infinite feed, loses its whole duration). Columns taken from the
    path and the motion are read-only views, not copies (a million blocks stay cheap)."""
    path = motion.path
    duration = motion.duration_s
    ideal = np.divide(path.length_mm, path.feed_mm_s, out=np.full(path.n, np.nan),
                      where=path.feed_mm_s > 0)
    return {
        "block": np.arange(path.n, dtype=np.int64),
        "line": path.line.astype(np.int64),
        "length_mm": _read_only(path.length_mm),
        "t_start_s": _read_only(motion.t_start_s),
        "duration_s": duration,
        "feed_programmed_mm_s": _read_only(path.feed_mm_s),
        "feed_max_mm_s": _read_only(motion.feed_max_mm_s),
        "cap_mm_s": _read_only(motion.cap_mm_s),
        "limit": limit_labels(motion.cap_limit),
        "time_lost_s": np.subtract(duration, ideal, out=ideal),
    }
