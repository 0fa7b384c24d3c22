"""Cross-check of the planned feed law against ruckig's time-optimal motion.

For every block (path segment) the feed law of ncsim is one degree of freedom along the path:
it leaves the block's start junction at ``(s, V, A_t) = (0, v_start, a_start)`` and reaches its
end at ``(L, v_end, a_end)``. ruckig solves the same boundary problem time-optimally under

* ``max_velocity``     = the block's feed set point ``V_st`` (paper eq. 12), raised to the
  boundary feeds if they are higher;
* ``max_acceleration`` = the tangential acceleration in force ``motion.accel_mm_s2``, raised to
  the boundary accelerations;
* ``max_jerk``         = the tangential jerk in force ``motion.jerk_mm_s3`` (phases A/C).

No motion between those states with those limits is faster than the true optimum, so ncsim's
duration must be at least ruckig's (``ratio = ncsim / ruckig >= 1``) -- up to ruckig's own
flaws, below. ruckig plans in one unconstrained
dimension: its optimum may overshoot the block end or run backwards, which no path motion
does; such blocks are flagged, and ruckig is run again with ``min_velocity = 0`` to get the
best *path* motion, which becomes the reference.

The report also lists, from ncsim's own pieces inside each block, any exceeded limit (feed
above the set point, |A_t| above the acceleration in force, |J_t| above the jerk in force) and
classifies why a block is slower than the optimum (:class:`Reason`). Separately, ruckig is run
at the programmed feed instead of the set point, which prices the NCU's set point reduction.

ruckig is not a perfect oracle. It reaches targets within ~1e-8 (pantor/ruckig#52), so on
tiny blocks a rounding-level inconsistency of the planned states costs it a spurious phase of
a few 1e-8 s (hence ``RUCKIG_ATOL_S``); and for some states (one constant-jerk piece between
two accelerating states, a start on the velocity limit) it returns a clearly longer motion
than the optimum. A block where ncsim is faster than ruckig is therefore only blamed on ncsim
(``Reason.FASTER``) when ncsim's own motion breaks a limit or reverses; otherwise ncsim's
motion is a feasible witness that ruckig missed the optimum (``Reason.RUCKIG_MISSED``) and
becomes the block's reference.
"""
from __future__ import annotations

from dataclasses import dataclass, fields
from enum import IntEnum

import numpy as np

from ncsim.errors import UsageError
from ncsim.motion import Limit, Motion, Phase

LIMIT_RTOL = 1e-6       # relative tolerance on limits (exceeded) and on "faster than ruckig"
RUCKIG_ATOL_S = 1e-7    # ruckig's own time precision: on tiny blocks (0.02 mm, 30 ms) its
                        # optimum can carry an extra phase of a few 1e-8 s
OPTIMAL_RTOL = 1e-3     # ncsim within 0.1 % of ruckig counts as time-optimal

EXCEEDED_FEED = 1       # bits of CrosscheckReport.exceeded
EXCEEDED_ACCEL = 2
EXCEEDED_JERK = 4


class Reason(IntEnum):
    """Why a block takes longer than ruckig's optimum (first that applies, in the order of
    :func:`crosscheck`)."""

    FASTER = 0          # ncsim is faster than the optimum and breaks a limit (or reverses)
    RUCKIG_FAILED = 1   # ruckig found no solution: no comparison
    OPTIMAL = 2         # within OPTIMAL_RTOL of the optimum
    LOOKAHEAD = 3       # the block is held by the look-ahead (stop planned at the window end)
    SECTION = 4         # steady below the block's own set point: a lower limit of its section
    ZERO_ACCEL = 5      # a zero-acceleration point inside a ramp (the paper's per-block law)
    OTHER = 6           # ramps not time-optimal for other reasons
    RUCKIG_MISSED = 7   # ncsim is faster yet within every limit: ruckig missed the optimum

    @property
    def label(self) -> str:
        return self.name.lower()

    @property
    def description(self) -> str:
        return _REASON_TEXT[self]


_REASON_TEXT = {
    Reason.FASTER: "faster than ruckig's optimum: a limit is exceeded or the feed reverses",
    Reason.RUCKIG_FAILED: "ruckig found no solution",
    Reason.OPTIMAL: "time-optimal",
    Reason.LOOKAHEAD: "look-ahead (stop planned at the end of the prepared blocks)",
    Reason.SECTION: "section limits lower than the block's own (steady below the set point)",
    Reason.ZERO_ACCEL: "zero-acceleration point inside a ramp (paper per-block law)",
    Reason.OTHER: "feed law not time-optimal within the block",
    Reason.RUCKIG_MISSED: "ruckig missed the optimum: ncsim's own motion is faster and within "
                          "every limit (it is the reference)",
}


@dataclass(frozen=True, slots=True)
class CrosscheckReport:
    """Per checked block (arrays of equal length) and a summary (:meth:`summary`)."""

    block: np.ndarray                  # block index
    line: np.ndarray                   # source line
    length_mm: np.ndarray
    v_start_mm_s: np.ndarray           # ncsim's boundary states given to ruckig
    v_end_mm_s: np.ndarray
    a_start_mm_s2: np.ndarray
    a_end_mm_s2: np.ndarray
    max_velocity_mm_s: np.ndarray      # the limits given to ruckig
    max_accel_mm_s2: np.ndarray
    max_jerk_mm_s3: np.ndarray
    ncsim_duration_s: np.ndarray
    ruckig_duration_s: np.ndarray      # unconstrained 1-DoF optimum (NaN: ruckig failed)
    ruckig_path_duration_s: np.ndarray  # optimum with min_velocity = 0 where the above is invalid
    reference_duration_s: np.ndarray   # the path optimum when valid, else ruckig_duration_s;
                                       # ncsim's own duration where ruckig missed the optimum
    ratio: np.ndarray                  # ncsim / reference
    ruckig_overshoot: np.ndarray       # bool: ruckig's optimum leaves [0, L]
    ruckig_reverses: np.ndarray        # bool: ruckig's optimum has a negative feed
    ruckig_error: np.ndarray           # str: why ruckig failed ('' when it did not)
    ruckig_programmed_duration_s: np.ndarray  # optimum at the programmed feed instead of V_st
    feed_max_mm_s: np.ndarray          # from ncsim's pieces inside the block
    accel_max_mm_s2: np.ndarray        # max |A_t|
    jerk_max_mm_s3: np.ndarray         # max |J_t|
    exceeded: np.ndarray               # bitmask EXCEEDED_FEED | EXCEEDED_ACCEL | EXCEEDED_JERK
    reason: np.ndarray                 # int8 Reason
    n_blocks_total: int = 0            # blocks in the motion (>= checked when sampled)

    def __len__(self) -> int:
        return len(self.block)

    @property
    def slower_s(self) -> np.ndarray:
        """Time ncsim takes beyond the optimum, per block."""
        return self.ncsim_duration_s - self.reference_duration_s

    @property
    def setpoint_cost_s(self) -> np.ndarray:
        """Time the set point costs the optimum: the reference duration minus ruckig's optimum
        at the programmed feed (never negative; NaN where ruckig failed)."""
        with np.errstate(invalid="ignore"):
            return np.maximum(self.reference_duration_s - self.ruckig_programmed_duration_s, 0.0)

    def reason_labels(self) -> np.ndarray:
        return np.array([r.label for r in Reason])[self.reason.astype(np.int64)]

    def summary(self) -> dict:
        """Plain-Python summary for reports and ``--json``."""
        ok = np.isfinite(self.ratio)
        worst = int(np.argmax(np.where(ok, self.ratio, -np.inf))) if np.any(ok) else None
        counts = {r.label: int(np.sum(self.reason == r)) for r in Reason}
        exceeded = self.exceeded != 0
        faster = self.reason == Reason.FASTER
        return {
            "blocks_total": int(self.n_blocks_total),
            "blocks_checked": int(len(self)),
            "ncsim_time_s": float(np.sum(self.ncsim_duration_s)),
            "optimal_time_s": float(np.sum(self.reference_duration_s[ok])),
            "slower_time_s": float(np.sum(self.slower_s[ok])),
            "setpoint_cost_s": float(np.nansum(self.setpoint_cost_s)),
            "worst_ratio": float(self.ratio[worst]) if worst is not None else None,
            "worst_block": int(self.block[worst]) if worst is not None else None,
            "worst_line": int(self.line[worst]) if worst is not None else None,
            "violations": int(np.sum(exceeded)),
            "faster_than_optimum": int(np.sum(faster)),
            "ruckig_missed_optimum": counts[Reason.RUCKIG_MISSED.label],
            "ruckig_invalid": int(np.sum(self.ruckig_overshoot | self.ruckig_reverses)),
            "ruckig_failed": counts[Reason.RUCKIG_FAILED.label],
            "reasons": counts,
        }

    def rows(self) -> list[dict]:
        """One dict per checked block (JSON-ready Python scalars)."""
        cols = {f.name: getattr(self, f.name) for f in fields(self) if f.name != "n_blocks_total"}
        cols["reason"] = self.reason_labels()
        out = []
        for i in range(len(self)):
            out.append({k: v[i].item() if hasattr(v[i], "item") else v[i] for k, v in cols.items()})
        return out

    def describe(self, i: int) -> str:
        """One line about checked block ``i``: durations, ratio, reason, exceeded limits."""
        r = Reason(int(self.reason[i]))
        text = (f"block {int(self.block[i])} (line {int(self.line[i])}): ncsim "
                f"{self.ncsim_duration_s[i]:.6g} s, optimum {self.reference_duration_s[i]:.6g} s, "
                f"ratio {self.ratio[i]:.6g}: {r.description}")
        bits = [name for bit, name in ((EXCEEDED_FEED, "feed"), (EXCEEDED_ACCEL, "acceleration"),
                                       (EXCEEDED_JERK, "jerk")) if self.exceeded[i] & bit]
        if bits:
            text += "; exceeded: " + ", ".join(bits)
        if self.ruckig_overshoot[i] or self.ruckig_reverses[i]:
            text += "; ruckig's 1-DoF optimum " + ("overshoots" if self.ruckig_overshoot[i] else "reverses")
        if self.ruckig_error[i]:
            text += f"; ruckig: {self.ruckig_error[i]}"
        return text


# ---------------------------------------------------------------------------------------------
# ncsim's own pieces, per block
# ---------------------------------------------------------------------------------------------

def _state(motion: Motion, k: np.ndarray, t: np.ndarray):
    tau = t - motion.piece_t_s[k]
    v0, a0, j = motion.piece_v_mm_s[k], motion.piece_a_mm_s2[k], motion.piece_j_mm_s3[k]
    return v0 + tau * (a0 + 0.5 * j * tau), a0 + j * tau


def block_piece_stats(motion: Motion) -> dict[str, np.ndarray]:
    """Exact extrema of ncsim's feed law inside each block's moving time
    ``[t_start_s, t_end_s]``, from the pieces (no sampling).

    Per block: ``feed_max_mm_s``, ``feed_min_mm_s``, ``accel_max_mm_s2`` (max |A_t|),
    ``jerk_max_mm_s3`` (max |J_t| over pieces overlapping the block for a positive time),
    ``steady_min_mm_s`` (lowest feed of a steady piece in the block, inf if none),
    ``lookahead`` (a piece in the block is held by the look-ahead) and ``interior_zero_accel``
    (strictly inside the block the acceleration comes back to zero and the jerk reverses: a
    ramp stopped and restarted, the paper's per-block law).

    Feed extrema of a constant-jerk piece lie at its ends or where ``A_t = 0`` inside
    (``V = v0 - a0^2 / (2 j)``); |A_t| is linear, so its ends suffice.
    """
    n = motion.n_blocks
    pt = motion.piece_t_s
    m = len(pt) - 1
    t0, t1 = motion.t_start_s, motion.t_end_s
    out = {
        "feed_max_mm_s": np.full(n, -np.inf), "feed_min_mm_s": np.full(n, np.inf),
        "accel_max_mm_s2": np.zeros(n), "jerk_max_mm_s3": np.zeros(n),
        "steady_min_mm_s": np.full(n, np.inf), "lookahead": np.zeros(n, dtype=bool),
        "interior_zero_accel": np.zeros(n, dtype=bool),
    }
    if n == 0 or m < 1:
        return out
    # block end points (covers zero-duration blocks too)
    for t in (t0, t1):
        k = np.clip(np.searchsorted(pt, t, side="right") - 1, 0, m - 1)
        v, a = _state(motion, k, t)
        np.maximum(out["feed_max_mm_s"], v, out=out["feed_max_mm_s"])
        np.minimum(out["feed_min_mm_s"], v, out=out["feed_min_mm_s"])
        np.maximum(out["accel_max_mm_s2"], np.abs(a), out=out["accel_max_mm_s2"])

    # elementary intervals between all piece and block boundaries
    edges = np.union1d(pt, np.concatenate([t0, t1]))
    lo, hi = edges[:-1], edges[1:]
    pos = hi > lo
    lo, hi = lo[pos], hi[pos]
    mid = 0.5 * (lo + hi)
    b = np.searchsorted(t0, mid, side="right") - 1
    inside = (b >= 0)
    inside[inside] = mid[inside] < t1[b[inside]]
    lo, hi, mid, b = lo[inside], hi[inside], mid[inside], b[inside]
    if len(b) == 0:
        return out
    k = np.clip(np.searchsorted(pt, mid, side="right") - 1, 0, m - 1)
    v_lo, a_lo = _state(motion, k, lo)
    v_hi, a_hi = _state(motion, k, hi)
    j = motion.piece_j_mm_s3[k]
    with np.errstate(divide="ignore", invalid="ignore"):
        tau_star = np.where(j != 0, -motion.piece_a_mm_s2[k] / j, -1.0) + pt[k]
    interior = (j != 0) & (tau_star > lo) & (tau_star < hi)
    v_star = np.where(interior, _state(motion, k, np.where(interior, tau_star, lo))[0], v_lo)
    vmax = np.maximum(np.maximum(v_lo, v_hi), v_star)
    vmin = np.minimum(np.minimum(v_lo, v_hi), v_star)
    np.maximum.at(out["feed_max_mm_s"], b, vmax)
    np.minimum.at(out["feed_min_mm_s"], b, vmin)
    np.maximum.at(out["accel_max_mm_s2"], b, np.maximum(np.abs(a_lo), np.abs(a_hi)))
    np.maximum.at(out["jerk_max_mm_s3"], b, np.abs(j))
    steady = motion.piece_phase[k] == Phase.B
    np.minimum.at(out["steady_min_mm_s"], b[steady], vmin[steady])
    la = motion.piece_limit[k] == Limit.LOOKAHEAD
    out["lookahead"][b[la]] = True
    # the acceleration touches zero strictly inside the block and turns back (the jerk changes
    # sign there): a ramp stopped and restarted, not a peak (a crosses 0, same jerk) nor the
    # edge of a steady phase (zero jerk on one side)
    a_scale = np.maximum(motion.accel_mm_s2[b], 1e-12)
    inner = np.zeros(len(b), dtype=bool)
    inner[1:] = b[1:] == b[:-1]
    j_before = np.concatenate([[0.0], j[:-1]])
    touch = inner & (np.abs(a_lo) <= 1e-9 * a_scale) & (j_before * j < 0)
    out["interior_zero_accel"][b[touch]] = True
    return out


# ---------------------------------------------------------------------------------------------
# ruckig
# ---------------------------------------------------------------------------------------------

def _profile_min_velocity(traj) -> float:
    """Lowest velocity of a 1-DoF ruckig trajectory, exactly from its constant-jerk phases
    (brake pre-phases included): phase ends, and ``v - a^2 / (2 j)`` where ``a`` crosses 0."""
    prof = traj.profiles[0][0]
    phases = [prof]
    brake = prof.brake
    if brake.duration > 0:
        phases.append(brake)
    vmin = np.inf
    for ph in phases:
        t, j, a, v = ph.t, ph.j, ph.a, ph.v
        vmin = min(vmin, min(v))
        for i in range(len(t)):  # a changes sign inside phase i: a velocity extremum there
            if t[i] > 0 and j[i] != 0 and a[i] * (a[i] + j[i] * t[i]) < 0:
                vmin = min(vmin, v[i] - a[i] * a[i] / (2 * j[i]))
    return float(vmin)


def _ruckig_message(text: str) -> str:
    """The one meaningful line of a ruckig exception (it appends a dump of the input)."""
    for line in text.splitlines():
        if "[ruckig]" in line:
            line = line.split("[ruckig]", 1)[1]
            return line.split(" input:")[0].strip().rstrip(".")
    return text.strip().splitlines()[0] if text.strip() else "ruckig error"


class _Ruckig1:
    """One reusable 1-DoF ruckig solver (objects are reused across blocks: cheaper)."""

    def __init__(self):
        import ruckig

        self.ruckig = ruckig
        self.solver = ruckig.Ruckig(1)
        self.inp = ruckig.InputParameter(1)
        self.traj = ruckig.Trajectory(1)
        self.inp.current_position = [0.0]

    def solve(self, length, v0, a0, v1, a1, vmax, amax, jmax, min_velocity=None, analyse=True):
        """Duration, position extrema (min, max) and min velocity (only the duration when not
        ``analyse``); or an error string."""
        inp = self.inp
        inp.current_velocity = [v0]
        inp.current_acceleration = [a0]
        inp.target_position = [length]
        inp.target_velocity = [v1]
        inp.target_acceleration = [a1]
        inp.max_velocity = [vmax]
        inp.max_acceleration = [amax]
        inp.max_jerk = [jmax]
        inp.min_velocity = [-vmax if min_velocity is None else min_velocity]
        try:
            result = self.solver.calculate(inp, self.traj)
        except self.ruckig.RuckigError as exc:
            return _ruckig_message(str(exc))
        except (RuntimeError, ValueError) as exc:  # pragma: no cover - older bindings
            return str(exc).strip() or type(exc).__name__
        if result not in (self.ruckig.Result.Working, self.ruckig.Result.Finished):
            return f"ruckig result {result.name}"
        if not analyse:
            return self.traj.duration
        ext = self.traj.position_extrema[0]
        return self.traj.duration, ext.min, ext.max, _profile_min_velocity(self.traj)


def select_blocks(n_blocks: int, max_blocks: int | None, seed: int = 0) -> np.ndarray:
    """All blocks, or a deterministic (seeded) sorted sample of ``max_blocks`` of them."""
    if max_blocks is not None and max_blocks < 1:
        raise UsageError(f"max_blocks must be at least 1, got {max_blocks}")
    if max_blocks is None or n_blocks <= max_blocks:
        return np.arange(n_blocks)
    rng = np.random.default_rng(seed)
    return np.sort(rng.choice(n_blocks, size=max_blocks, replace=False))


def ruckig_limits(v_start, v_end, a_start, a_end, cap, accel, jerk):
    """The limits handed to ruckig: the block's, raised just enough to admit the boundary
    states (ruckig rejects a target above its limits). A target arriving at ``v_end`` with
    ``a_end < 0`` was faster just before: at least ``v_end + a_end^2 / (2 J)``."""
    amax = np.maximum(accel, np.maximum(np.abs(a_start), np.abs(a_end)))
    with np.errstate(divide="ignore", invalid="ignore"):
        v_before_end = np.where(a_end < 0, v_end + a_end * a_end / (2.0 * jerk), v_end)
    vmax = np.maximum.reduce([cap, v_start, v_end, np.nan_to_num(v_before_end, nan=0.0)])
    return vmax, amax, jerk


def _ruckig_durations(L, v0, a0, v1, a1, vmax, amax, jmax, prog):
    """ruckig per block (Python loop over plain floats: ruckig has no batch API).

    Returns arrays: the unconstrained optimum, the path optimum (``min_velocity = 0`` rerun
    where the former overshoots or reverses), the optimum at the programmed feed ``prog``,
    the overshoot and reversal flags, and error strings.
    """
    c = len(L)
    dur = [np.nan] * c
    dur_path = [np.nan] * c
    dur_prog = [np.nan] * c
    overshoot = [False] * c
    reverses = [False] * c
    errors = [""] * c
    if c == 0:
        return (np.zeros(0), np.zeros(0), np.zeros(0), np.zeros(0, bool), np.zeros(0, bool),
                np.zeros(0, dtype=str))
    solver = _Ruckig1()
    cols = [x.tolist() for x in (L, v0, a0, v1, a1, vmax, amax, jmax, prog)]
    for i, (length, vs, as_, ve, ae, vm, am, jm, vp) in enumerate(zip(*cols)):
        args = (length, vs, as_, ve, ae)
        res = solver.solve(*args, vm, am, jm)
        if isinstance(res, str):
            errors[i] = res
            continue
        d, pmin, pmax, vlow = res
        dur[i] = dur_path[i] = dur_prog[i] = d
        tol = 1e-9 * max(length, 1.0)
        over = pmin < -tol or pmax > length + tol
        back = vlow < -1e-9 * max(vm, 1.0)
        if over or back:
            overshoot[i], reverses[i] = over, back
            res = solver.solve(*args, vm, am, jm, min_velocity=0.0, analyse=False)
            dur_path[i] = res if not isinstance(res, str) else np.nan
        if vp > vm * (1 + 1e-12):
            res = solver.solve(*args, vp, am, jm, analyse=False)
            dur_prog[i] = res if not isinstance(res, str) else np.nan
    return (np.array(dur), np.array(dur_path), np.array(dur_prog), np.array(overshoot),
            np.array(reverses), np.array(errors, dtype=str))


def crosscheck(motion: Motion, *, max_blocks: int | None = None, seed: int = 0) -> CrosscheckReport:
    """Compare every block (or a deterministic sample of ``max_blocks``) with ruckig's
    time-optimal 1-DoF motion between the same boundary states under the same limits
    (module docstring). Costs a few tens of microseconds per block.
    """
    path = motion.path
    n = motion.n_blocks
    idx = select_blocks(n, max_blocks, seed)
    stats = block_piece_stats(motion)
    L = path.length_mm[idx]
    v0 = motion.v_junction_mm_s[idx]
    v1 = motion.v_junction_mm_s[idx + 1]
    a0 = motion.a_junction_mm_s2[idx]
    a1 = motion.a_junction_mm_s2[idx + 1]
    cap = motion.cap_mm_s[idx]
    vmax, amax, jmax = ruckig_limits(v0, v1, a0, a1, cap, motion.accel_mm_s2[idx],
                                     motion.jerk_mm_s3[idx])
    prog = np.maximum(np.where(np.isfinite(path.feed_mm_s[idx]), path.feed_mm_s[idx], cap), vmax)
    ncsim = motion.duration_s[idx]

    c = len(idx)
    dur, dur_path, dur_prog, overshoot, reverses, errors = _ruckig_durations(
        L, v0, a0, v1, a1, vmax, amax, jmax, prog)

    ref = np.where(np.isfinite(dur_path), dur_path, dur)

    fmax = stats["feed_max_mm_s"][idx]
    amx = stats["accel_max_mm_s2"][idx]
    jmx = stats["jerk_max_mm_s3"][idx]
    exceeded = ((fmax > cap * (1 + LIMIT_RTOL)) * EXCEEDED_FEED
                | (amx > motion.accel_mm_s2[idx] * (1 + LIMIT_RTOL)) * EXCEEDED_ACCEL
                | (jmx > motion.jerk_mm_s3[idx] * (1 + LIMIT_RTOL)) * EXCEEDED_JERK).astype(np.int8)

    # ncsim's own block motion is a witness when it respects every limit and never reverses:
    # if it beats ruckig, ruckig missed the optimum (it happens: a single constant-jerk piece
    # between two accelerating states, or states on the velocity limit)
    feasible = (exceeded == 0) & (stats["feed_min_mm_s"][idx] >= -1e-9 * np.maximum(cap, 1.0))
    faster = ncsim < ref * (1 - LIMIT_RTOL) - RUCKIG_ATOL_S
    reason = np.full(c, Reason.OTHER, dtype=np.int8)
    rest = np.ones(c, dtype=bool)
    for code, cond in (
        (Reason.FASTER, faster & ~feasible),
        (Reason.RUCKIG_MISSED, faster & feasible),
        (Reason.RUCKIG_FAILED, ~np.isfinite(ref)),
        (Reason.OPTIMAL, ncsim <= ref * (1 + OPTIMAL_RTOL)),
        (Reason.LOOKAHEAD, stats["lookahead"][idx] | (motion.cap_limit[idx] == Limit.LOOKAHEAD)),
        (Reason.SECTION, stats["steady_min_mm_s"][idx] < cap * (1 - LIMIT_RTOL)),
        (Reason.ZERO_ACCEL, stats["interior_zero_accel"][idx]),
    ):
        hit = rest & cond
        reason[hit] = code
        rest &= ~hit
    ref = np.where(reason == Reason.RUCKIG_MISSED, ncsim, ref)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(ref > 0, ncsim / ref, np.where(ncsim > 0, np.inf, 1.0))
    ratio = np.where(np.isfinite(ref), ratio, np.nan)

    return CrosscheckReport(
        block=idx, line=path.line[idx].astype(np.int64), length_mm=L,
        v_start_mm_s=v0, v_end_mm_s=v1, a_start_mm_s2=a0, a_end_mm_s2=a1,
        max_velocity_mm_s=vmax, max_accel_mm_s2=amax, max_jerk_mm_s3=jmax,
        ncsim_duration_s=ncsim, ruckig_duration_s=dur, ruckig_path_duration_s=dur_path,
        reference_duration_s=ref, ratio=ratio, ruckig_overshoot=overshoot,
        ruckig_reverses=reverses, ruckig_error=errors,
        ruckig_programmed_duration_s=dur_prog, feed_max_mm_s=fmax, accel_max_mm_s2=amx,
        jerk_max_mm_s3=jmx, exceeded=exceeded, reason=reason, n_blocks_total=n)
