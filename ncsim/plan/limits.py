"""Stage 1 and 2 inputs of the planner: per-block feed set points and per-junction crossing caps.

:func:`path_limits` reads a :class:`~ncsim.path.Path` and a :class:`~ncsim.machine.MachineSpec`
and returns a :class:`PathLimits`: for every block the feed set point (paper eq. 12 and
§5.2.4), the tangential jerk and acceleration the A/C ramps may use, and for every junction the
highest crossing feed (eq. 13/15, corners, stops) and the time spent standing there. The
planner (:mod:`ncsim.plan`) turns these into the feed law; this module never plans time.

Everything is vectorised over blocks and junctions. Arcs are sampled at ``SAMPLE_STEP_RAD``
(1 deg) plus their end points, as 2-D ``(arcs, samples)`` arrays processed in chunks of at
most ``SAMPLE_BUDGET`` samples (arcs grouped by their sample count -- exact up to 32, else
rounded up to a power of two and padded by repeating the end sample), so memory stays bounded
on million-block programs.
The tangent direction of a helix repeats every turn, so at most one turn is sampled.

Lines (and rapid moves)
-----------------------
With ``u`` the unit direction::

    cap   = min(F [programmed; G0: +inf],  min_i V_mi/|u_i| [axis_velocity],
                L / t_cy [cycle_time, eq. 6, if options.cycle_time_limit])
    accel = min_i A_mi / |u_i|
    jerk  = min(J_tcurv [if options.ncu_path_jerk],  min_i J_mi / |u_i|)

A block of zero length has no direction: it is not limited by the axes or the cycle time
(the planner makes it transparent) and takes accel = min_i A_mi, jerk = min(J_tcurv, min_i J_mi).

Arcs and helices: the set point (paper §5.2.4, the Fig. 12 flowchart being unavailable)
---------------------------------------------------------------------------------------
R is the radius of curvature (``geometry.curvature_radius_mm``). At each sample of the arc the
tangent t and principal normal n give (``kinematics``) J_t = min_i J_mi/|t_i| (eq. 9),
V_t (eq. 7), A_n (eq. 8), V_An = sqrt(R A_n) (eq. 2) and V_Jt = (J_t R^2)^(1/3) (eq. 4).

*alpha_c*, "the angular position when the feed rate becomes constant" (§5.2.4): the first
position along the travel where the axes can carry the NCU's tangential jerk,
J_t(alpha) >= J_tcurv (eq. 10) -- the earliest point from which the steady feed V_Jtcurv can be
held. It is located on the samples and, when it is not the arc's start, refined by bisection
inside the sampling step to where J_t = J_tcurv. If no sample reaches J_tcurv, or
``options.ncu_path_jerk`` is off, alpha_c is the first sample where J_t is largest. This
reproduces the paper's worked example: on the R 2.5 circle leaving along +X (tangent angle 0),
alpha_c = 33.5 deg (acos(5/6) = 33.56 deg) where J_t(alpha_c) = J_tcurv = 6 m/s^3, so
V_Jt(alpha_c) = V_Jtcurv = 2.01 m/min, V_An(alpha_c) = 5.7 m/min, V_t(alpha_c) = 36 m/min.
(Choosing instead the carrying sample with the largest static look-ahead V_s, eq. 5, would put
alpha_c at 45 deg, where V_An = 5.64 and V_t = 42.4 m/min, against the paper's example; the
set points are the same either way.) ``alpha_c_rad`` reports it as the tangent's direction
angle in the arc's working plane.

The set point is eq. 12 with the axis limits taken at alpha_c::

    cap = min(V_prog [programmed], V_Jtcurv [ncu_path_jerk, if options.ncu_path_jerk],
              V_Jt(alpha_c) [axis_jerk, if options.axis_jerk_setpoint],
              V_An(alpha_c) [axis_accel], V_t(alpha_c) [axis_velocity],
              arc length / t_cy [cycle_time, if options.cycle_time_limit])

This is what Table 3 shows: on R 30 the machine holds V_Jtcurv = 10.53 m/min although
min over alpha of V_Jt is 9.9 m/min. Two hard guards follow, which the paper's tests never
reach but which keep every trace within the axis limits, as a real 840D does:

* V_t guard = min over the arc of V_t(alpha)                          [axis_velocity]
* V_An guard = sqrt(R * normal_accel_share * min over the arc of A_n)  [axis_accel]
  (``machine.ncu.normal_accel_share``, cf. 840D MD20602 CURV_EFFECT_ON_PATH_ACCEL)

so the ``axis_velocity`` / ``axis_accel`` candidates are min(value at alpha_c, guard).
Tangential acceleration in force: the least over the samples of
min_i (A_mi - a_n |n_i|) / |t_i| with a_n = cap^2 / R (eq. 1; positive thanks to the guard).
Tangential jerk in force for phases A/C (§5.2.2: "the minimum tangential jerk available" on
the arc, 5 m/s^3 on the paper's machine): min(J_tcurv [if ncu option], min over the arc of J_t).
For a helix the jerk's binormal part (torsion) is not modelled.

Acceleration modes (``path.accel_mode``, or ``options.accel_mode`` when not None)
-----------------------------------------------------------------------------
SOFT as above. BRISK: jerk = accel / t_cy (an acceleration-limited law). DRIVE: as BRISK with
accel reduced by ``drive_accel_reduction_ratio`` x clip((cap - p Vmax)/(Vmax - p Vmax), 0, 1),
p = ``drive_speed_point_ratio``, Vmax the axis-velocity limit along the block (min_i V_mi/|u_i|
on a line, the V_t guard on an arc). ``options.jerk_limited_ramps`` False: jerk = accel / t_cy
on every block.

Junctions (n + 1; junction k is the start of block k, junction n the end of the path)
-------------------------------------------------------------------------------------
Zero caps, by increasing priority of the reported limit (the last that applies is reported):
rapid[k-1] != rapid[k] -> AUX_STOP; stop_before[k] -> AUX_STOP; exact_stop[k-1] -> EXACT_STOP;
dwell_before_s[k] > 0 -> DWELL; junctions 0 and n -> PROGRAM_END. Otherwise:

* tangent discontinuity (angle between the end tangent of k-1 and the start tangent of k above
  ``TANGENT_TOL_RAD`` = 1e-4 rad), crossed in continuous-path mode (G60 is carried by
  ``exact_stop``): the axis velocities may jump by A_mi (MD32310_i - 1) t_IPO (840D B1,
  overload factor), v = min_i A_mi (f_i - 1) t_cy / |t2_i - t1_i| [CORNER]. Under G641-G645
  the corners that the 840D rounds are rounding blocks of :mod:`ncsim.plan.blend` by then
  (:func:`path_limits` prepares the path with :mod:`ncsim.plan.hsm`).
* tangent continuous but curvature vector jump |kappa1 n1 - kappa2 n2| above
  ``CURVATURE_TOL_REL`` x the larger curvature: eq. 13 generalised,
  V_fr = sqrt(J_t dt / |delta kappa|), dt = ``machine.ncu.transition_time_s`` and
  J_t = min_i J_mi / |t_i| at the junction tangent (eq. 15) [TRANSITION], if
  ``options.transition_crossing``; else +inf [NONE].
* otherwise +inf [NONE].

``junction_dwell_s[k]`` = dwell_before_s[k] + the exact-stop settle time when block k-1 ends in
an exact stop (stop_window 601 -> ``exact_stop_fine_settle_s``, 602 -> coarse, 603 -> 0; any
other value is treated as 601); junction n also gets ``path.end_dwell_s``.

``options.lookahead`` does not affect these limits (the planner applies the look-ahead).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ncsim.plan import kinematics as kin
from ncsim.geometry import (arc_basis, curvature_radius_mm, end_curvatures, end_tangents,
                       start_curvatures, start_tangents)
from ncsim.machine import MachineSpec
from ncsim.motion import FULL_MODEL, Limit, ModelOptions
from ncsim.path import ARC, DRIVE, SOFT, Path

SAMPLE_STEP_RAD = np.deg2rad(1.0)   # arc sampling step (plus both end points)
SAMPLE_BUDGET = 1 << 20             # samples per chunk of arcs
TANGENT_TOL_RAD = 1e-4              # deflection above which a junction is a corner
CURVATURE_TOL_REL = 1e-6            # relative curvature-vector jump that counts as a transition
_J_REL = 1e-12                      # relative tolerance on J_t >= J_tcurv
_JMAX_REL = 1e-9                    # relative tolerance on "J_t is largest"

#: The candidate limits of a block's set point, in eq. 12's order (ties go to the earlier one).
CANDIDATE_LIMITS = (Limit.PROGRAMMED, Limit.NCU_PATH_JERK, Limit.AXIS_JERK, Limit.AXIS_ACCEL,
                    Limit.AXIS_VELOCITY, Limit.CYCLE_TIME)
CANDIDATE_LABELS = tuple(lim.label for lim in CANDIDATE_LIMITS)


@dataclass(frozen=True, slots=True)
class PathLimits:
    """Per-block set points and per-junction crossing caps of a path (module docstring).

    Shapes: ``n`` blocks, ``n + 1`` junctions. Arrays are read-only.
    """

    # -- per block (n) --------------------------------------------------------------------------
    cap_mm_s: np.ndarray        # feed set point V_st (eq. 12 + guards)
    cap_limit: np.ndarray       # int8 Limit that sets cap_mm_s
    jerk_mm_s3: np.ndarray      # tangential jerk in force for phases A/C
    accel_mm_s2: np.ndarray     # tangential acceleration in force (> 0)
    alpha_c_rad: np.ndarray     # tangent direction angle at alpha_c in the arc's plane; NaN: line
    candidates: dict[str, np.ndarray]  # Limit label -> that limit per block (+inf: n/a)
    # -- per junction (n + 1) -------------------------------------------------------------------
    junction_cap_mm_s: np.ndarray  # crossing cap: +inf unconstrained, 0 stop
    junction_limit: np.ndarray     # int8 Limit of the junction cap
    junction_dwell_s: np.ndarray   # time standing still at the junction
    # -- the path these limits belong to: the programmed one prepared by ncsim.plan.hsm --------
    path: Path | None = None       # (rounding blocks inserted); None: the caller's path
    nc_block: np.ndarray | None = None  # NC block of each row (compressed rows share one), for
                                        # the look-ahead; None: every row is a block

    def __post_init__(self) -> None:
        for name in ("cap_mm_s", "cap_limit", "jerk_mm_s3", "accel_mm_s2", "alpha_c_rad",
                     "junction_cap_mm_s", "junction_limit", "junction_dwell_s"):
            getattr(self, name).setflags(write=False)
        for arr in self.candidates.values():
            arr.setflags(write=False)

    @property
    def n_blocks(self) -> int:
        return len(self.cap_mm_s)


def path_limits(path: Path, machine: MachineSpec, options: ModelOptions = FULL_MODEL) -> PathLimits:
    """Feed set points, ramp jerk/acceleration and junction caps of ``path`` on ``machine``
    (semantics in the module docstring), on the path as the 840D runs it: compressed runs and
    G641-G645 rounding blocks (:mod:`ncsim.plan.hsm`). ``PathLimits.path`` is that path (the
    programmed one when no HSM mode changes it), the one the planner plans."""
    from ncsim.plan.hsm import prepare

    prepared = prepare(path, machine, options)
    return prepared.apply(block_limits(prepared.path, machine, options), machine, options)


def block_limits(path: Path, machine: MachineSpec, options: ModelOptions = FULL_MODEL) -> PathLimits:
    """The limits of every block and junction of ``path`` as programmed (module docstring),
    without the compressor and rounding of :func:`path_limits`."""
    n = path.n
    ncu = machine.ncu
    j_ncu = ncu.tangential_jerk_mm_s3 if options.ncu_path_jerk else np.inf

    cand = {label: np.full(n, np.inf) for label in CANDIDATE_LABELS}
    cand["programmed"] = np.where(path.rapid, np.inf, path.feed_mm_s).astype(np.float64)
    if options.cycle_time_limit:
        cand["cycle_time"] = kin.cycle_time_feed_limit_mm_s(path.length_mm, ncu.ipo_cycle_s)

    accel = np.empty(n)
    jerk_axis = np.empty(n)
    vmax = np.empty(n)           # axis-velocity limit along the block (DRIVE)
    alpha_c = np.full(n, np.nan)
    cap = np.empty(n)
    limit = np.empty(n, dtype=np.int8)

    is_arc = path.kind == ARC
    lines = np.nonzero(~is_arc)[0]
    if len(lines):
        _line_limits(path, lines, machine, cand, accel, jerk_axis, vmax)
        cap[lines], limit[lines] = _set_point(cand, lines)
    arcs = np.nonzero(is_arc)[0]
    if len(arcs):
        _arc_limits(path, arcs, machine, options, j_ncu, cand, cap, limit, accel, jerk_axis,
                    vmax, alpha_c)

    mode = (np.full(n, options.accel_mode, dtype=np.int8) if options.accel_mode is not None
            else path.accel_mode)
    drive = mode == DRIVE
    if np.any(drive):
        accel[drive] = kin.drive_accel_mm_s2(accel[drive], cap[drive], vmax[drive],
                                             ncu.drive_speed_point_ratio,
                                             ncu.drive_accel_reduction_ratio)
    soft = (mode == SOFT) & options.jerk_limited_ramps
    jerk = np.where(soft, np.minimum(jerk_axis, j_ncu), kin.brisk_jerk_mm_s3(accel, ncu.ipo_cycle_s))

    jcap, jlimit, jdwell = _junction_limits(path, machine, options)
    return PathLimits(cap_mm_s=cap, cap_limit=limit, jerk_mm_s3=jerk, accel_mm_s2=accel,
                      alpha_c_rad=alpha_c, candidates=cand, junction_cap_mm_s=jcap,
                      junction_limit=jlimit, junction_dwell_s=jdwell)


# ---------------------------------------------------------------------------------------------
# Blocks
# ---------------------------------------------------------------------------------------------

def _set_point(cand: dict[str, np.ndarray], idx) -> tuple[np.ndarray, np.ndarray]:
    """Eq. 12 over the candidates of blocks ``idx``: the value and its Limit (int8)."""
    value, which = kin.feed_set_point_mm_s(*[cand[label][idx] for label in CANDIDATE_LABELS])
    codes = np.array([int(lim) for lim in CANDIDATE_LIMITS], dtype=np.int8)
    return value, codes[which]


def _line_limits(path, idx, machine, cand, accel, jerk_axis, vmax) -> None:
    """Axis limits along the direction of lines ``idx`` (eq. 7 and its accel/jerk analogues)."""
    length = path.length_mm[idx]
    d = path.end_mm[idx] - path.start_mm[idx]
    u = np.divide(d, length[:, None], out=np.zeros_like(d), where=length[:, None] > 0.0)
    v_axis = kin.axis_velocity_feed_limit_mm_s(u, machine.max_velocity_mm_s)
    cand["axis_velocity"][idx] = v_axis
    vmax[idx] = v_axis
    moving = length > 0.0
    accel[idx] = np.where(moving, kin.axis_tangential_accel_limit_mm_s2(u, machine.max_accel_mm_s2),
                          machine.max_accel_mm_s2.min())
    jerk_axis[idx] = np.where(moving, kin.axis_tangential_jerk_limit_mm_s3(u, machine.max_jerk_mm_s3),
                              machine.max_jerk_mm_s3.min())


def _arc_sample_counts(sweep_rad: np.ndarray) -> np.ndarray:
    """Samples per arc: end points plus steps of at most SAMPLE_STEP_RAD over <= one turn."""
    sweep = np.minimum(sweep_rad, 2.0 * np.pi)
    return np.maximum(np.ceil(sweep / SAMPLE_STEP_RAD - 1e-9).astype(np.int64), 1) + 1


def _arc_limits(path, arcs, machine, options, j_ncu, cand, cap, limit, accel, jerk_axis, vmax,
                alpha_c) -> None:
    counts = _arc_sample_counts(path.sweep_rad[arcs])
    # buckets: the exact count up to 32 samples, then the next power of two (<= 2x padding)
    width = np.where(counts <= 32, counts, 1 << np.ceil(np.log2(counts)).astype(np.int64))
    radius = curvature_radius_mm(path)
    for w in np.unique(width):
        members = np.nonzero(width == w)[0]          # positions in ``arcs``
        rows = max(1, SAMPLE_BUDGET // int(w))
        for start in range(0, len(members), rows):
            pos = members[start:start + rows]
            chunk = arcs[pos]
            _arc_chunk(path, chunk, counts[pos], radius[chunk], int(w), machine, options, j_ncu,
                       cand, cap, limit, accel, jerk_axis, vmax, alpha_c)


def _arc_terms(path, idx):
    """Per arc: basis (u, v, w), tangent lean r/rho and rise p/rho, swept angle (<= one turn)."""
    r = path.radius_mm[idx]
    sweep = path.sweep_rad[idx]
    pitch = np.divide(path.helix_mm[idx], sweep, out=np.zeros_like(r), where=sweep > 0)
    rho = np.hypot(r, pitch)
    u, v, w = arc_basis(path.center_mm[idx], path.normal[idx], path.start_mm[idx])
    return u, v, w, (r / rho)[:, None], (pitch / rho)[:, None], np.minimum(sweep, 2.0 * np.pi)


def _frames_at(terms, phi):
    """Unit tangents and principal normals (a, m, 3) at angles ``phi`` (a, m) of the arcs."""
    u, v, w, lean, rise, _ = terms
    c, s = np.cos(phi), np.sin(phi)
    tangent = np.empty((*phi.shape, 3))
    normal = np.empty((*phi.shape, 3))
    for i in range(3):  # per component: (a, m) arrays, no (a, m, 3) temporaries
        ui, vi = u[:, i:i + 1], v[:, i:i + 1]
        tangent[..., i] = lean * (c * vi - s * ui) + rise * w[:, i:i + 1]
        normal[..., i] = -(c * ui + s * vi)
    return tangent, normal


def _sample_angles(sweep, counts, width):
    """(a, width) sample angles: ``counts`` evenly spaced from 0 to the sweep, then the end
    angle repeated up to ``width`` (padding that changes no min, max or first-match)."""
    frac = np.minimum(np.arange(width)[None, :] / (counts - 1)[:, None], 1.0)
    return sweep[:, None] * frac


def _subset(terms, mask):
    return tuple(t[mask] for t in terms)


def _first_crossing(terms, phi_lo, phi_hi, j_min, max_jerk, steps=20):
    """Bisection for the first angle in [phi_lo, phi_hi] where J_t (eq. 9) reaches ``j_min``,
    J_t(phi_lo) < j_min <= J_t(phi_hi); returns the upper bracket (J_t >= j_min holds there),
    within 2^-steps of the 1-degree step."""
    lo, hi = phi_lo.copy(), phi_hi.copy()
    for _ in range(steps):
        mid = 0.5 * (lo + hi)
        tangent, _ = _frames_at(terms, mid[:, None])
        ok = kin.axis_tangential_jerk_limit_mm_s3(tangent[:, 0], max_jerk) >= j_min
        hi = np.where(ok, mid, hi)
        lo = np.where(ok, lo, mid)
    return hi


def _plane_angle(tangent: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Direction angle in [0, 2 pi) of ``tangent`` in the working plane of an arc of axis ``w``
    (G17: X, Y; G18: Z, X; G19: Y, Z -- chosen by the largest component of w)."""
    plane = np.argmax(np.abs(w), axis=-1)            # 2 -> G17, 1 -> G18, 0 -> G19
    first = np.array([1, 2, 0])[plane]              # abscissa: X for G17, Z for G18, Y for G19
    second = np.array([2, 0, 1])[plane]             # ordinate: Y, X, Z
    rows = np.arange(len(tangent))
    return np.mod(np.arctan2(tangent[rows, second], tangent[rows, first]), 2.0 * np.pi)


def _arc_chunk(path, idx, counts, radius, width, machine, options, j_ncu, cand, cap, limit,
               accel, jerk_axis, vmax, alpha_c) -> None:
    """Limits of the arcs ``idx`` (curvature radii ``radius``), sampled ``width`` times each."""
    ncu = machine.ncu
    a_max = machine.max_accel_mm_s2
    terms = _arc_terms(path, idx)
    phi = _sample_angles(terms[5], counts, width)
    tangent, normal = _frames_at(terms, phi)

    j_t = kin.axis_tangential_jerk_limit_mm_s3(tangent, machine.max_jerk_mm_s3)   # eq. 9
    v_t = kin.axis_velocity_feed_limit_mm_s(tangent, machine.max_velocity_mm_s)   # eq. 7
    a_n = kin.axis_normal_accel_limit_mm_s2(normal, a_max)                        # eq. 8

    # alpha_c: first sample carrying J_tcurv, else first sample of largest J_t; when the first
    # carrying sample is not the start, the crossing J_t = J_tcurv inside the step is refined
    j_best = j_t.max(axis=1, keepdims=True)
    j_floor = j_ncu * (1.0 - _J_REL)
    carries = j_t >= j_floor
    use_ncu = np.isfinite(j_ncu) & carries.any(axis=1)
    chosen = np.where(use_ncu[:, None], carries, j_t >= j_best * (1.0 - _JMAX_REL))
    k = np.argmax(chosen, axis=1)
    rows = np.arange(len(idx))
    phi_c = phi[rows, k]
    refine = use_ncu & (k > 0)
    if np.any(refine):
        phi_c[refine] = _first_crossing(_subset(terms, refine), phi[rows, k - 1][refine],
                                        phi_c[refine], j_ncu, machine.max_jerk_mm_s3)
    t_c, n_c = (f[:, 0] for f in _frames_at(terms, phi_c[:, None]))
    alpha_c[idx] = _plane_angle(t_c, terms[2])
    j_t_c = kin.axis_tangential_jerk_limit_mm_s3(t_c, machine.max_jerk_mm_s3)
    j_t_c = np.where(use_ncu, np.maximum(j_t_c, j_ncu), j_t_c)   # carries J_tcurv by choice
    v_t_c = kin.axis_velocity_feed_limit_mm_s(t_c, machine.max_velocity_mm_s)
    a_n_c = kin.axis_normal_accel_limit_mm_s2(n_c, a_max)

    v_t_guard = v_t.min(axis=1)
    v_an_guard = kin.normal_accel_feed_limit_mm_s(radius, ncu.normal_accel_share * a_n.min(axis=1))
    if np.isfinite(j_ncu):
        cand["ncu_path_jerk"][idx] = kin.ncu_path_jerk_feed_limit_mm_s(j_ncu, radius)  # eq. 11
    if options.axis_jerk_setpoint:
        cand["axis_jerk"][idx] = kin.tangential_jerk_feed_limit_mm_s(j_t_c, radius)  # eq. 4
    cand["axis_accel"][idx] = np.minimum(
        kin.normal_accel_feed_limit_mm_s(radius, a_n_c), v_an_guard)                 # eq. 2
    cand["axis_velocity"][idx] = np.minimum(v_t_c, v_t_guard)
    cap[idx], limit[idx] = _set_point(cand, idx)                                     # eq. 12

    a_normal = cap[idx] ** 2 / radius                                                # eq. 1
    accel[idx] = kin.tangential_accel_available_mm_s2(
        tangent, normal, np.broadcast_to(a_normal[:, None], j_t.shape), a_max).min(axis=1)
    jerk_axis[idx] = j_t.min(axis=1)
    vmax[idx] = v_t_guard


# ---------------------------------------------------------------------------------------------
# Junctions
# ---------------------------------------------------------------------------------------------

def _settle_s(stop_window: np.ndarray, ncu) -> np.ndarray:
    """Time to enter the exact-stop window: G601 fine, G602 coarse, G603 none (else fine)."""
    return np.select([stop_window == 602, stop_window == 603],
                     [ncu.exact_stop_coarse_settle_s, 0.0], ncu.exact_stop_fine_settle_s)


def _junction_limits(path, machine, options):
    n = path.n
    ncu = machine.ncu
    cap = np.full(n + 1, np.inf)
    lim = np.full(n + 1, int(Limit.NONE), dtype=np.int8)

    if n >= 2:
        t1 = end_tangents(path)[:-1]
        t2 = start_tangents(path)[1:]
        deflection = kin.deflection_angle_rad(t1, t2)
        corner = deflection > TANGENT_TOL_RAD

        # corners: the G64 axis velocity jump (rounded corners are ncsim.plan.blend's)
        v_corner = kin.corner_feed_g64_mm_s(t1, t2, machine.max_accel_mm_s2, ncu.ipo_cycle_s,
                                            machine.max_accel_ovl_factor)

        # curvature jumps with a continuous tangent: eq. 13 / 15
        k1 = end_curvatures(path)[:-1]
        k2 = start_curvatures(path)[1:]
        jump = kin.curvature_jump_1_mm(k1, k2)
        scale = np.maximum(np.linalg.norm(k1, axis=1), np.linalg.norm(k2, axis=1))
        transition = ~corner & (jump > CURVATURE_TOL_REL * scale) & options.transition_crossing
        j_t = kin.axis_tangential_jerk_limit_mm_s3(t1, machine.max_jerk_mm_s3)       # eq. 15
        v_fr = kin.transition_feed_mm_s(j_t, ncu.transition_time_s, jump)            # eq. 13

        inner = slice(1, n)
        cap[inner] = np.where(corner, v_corner, np.where(transition, v_fr, np.inf))
        lim[inner] = np.select([corner, transition], [int(Limit.CORNER), int(Limit.TRANSITION)],
                               int(Limit.NONE))

        stops = [  # (mask over junctions 1..n-1, limit); later entries win the label
            (path.rapid[:-1] != path.rapid[1:], Limit.AUX_STOP),
            (path.stop_before[1:], Limit.AUX_STOP),
            (path.exact_stop[:-1], Limit.EXACT_STOP),
            (path.dwell_before_s[1:] > 0.0, Limit.DWELL),
        ]
        for mask, why in stops:
            cap[inner][mask] = 0.0
            lim[inner][mask] = int(why)

    cap[0] = cap[n] = 0.0
    lim[0] = lim[n] = int(Limit.PROGRAM_END)

    dwell = np.zeros(n + 1)
    dwell[:n] += path.dwell_before_s
    dwell[1:] += np.where(path.exact_stop, _settle_s(path.stop_window, ncu), 0.0)
    dwell[n] += path.end_dwell_s
    return cap, lim, dwell
