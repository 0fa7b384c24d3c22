"""Stage 1 and 2 inputs of the planner: per-block feed set points and per-junction crossing caps.

:func:`path_limits` reads a :class:`~ncsim.path.Path` and a :class:`~ncsim.machine.MachineSpec`
and returns a :class:`PathLimits`: for every block the feed set point (paper eq. 12 and
§5.2.4), the tangential jerk and acceleration the A/C ramps may use, and for every junction the
highest crossing feed (eq. 13/15, corners, stops) and the time spent standing there. The
planner (:mod:`ncsim.plan`) turns these into the feed law; this module never plans time.

Everything is vectorised over blocks and junctions. The axis limits V_mi, A_mi, J_mi are those
of each block's technology group (``Path.dyn_group``, G group 59: the machine file's
``[dynamics]``, ``machine.TECHNOLOGY_GROUPS``): the blocks are taken in runs of one group. On arcs, every extremum over the arc's
angle range (least V_t, A_n, J_t and tangential acceleration, alpha_c, largest J_t) is a closed
form evaluated at a few known angles -- the range ends, the axis directions, the crossings of
two axes' ratios (45 deg, ``tan alpha = J_mx / J_my``) -- by the compiled per-arc loops of
:mod:`ncsim.plan.arc_extrema`, in any plane and for helices. The tangent direction of a helix
repeats every turn, so at most one turn is considered.

Lines (and rapid moves)
-----------------------
With ``u`` the unit direction::

    cap   = min(F x feed override [programmed; G0: +inf, or the rapid override x
                  min_i V_mi/|u_i| below 100 %],  min_i V_mi/|u_i| [axis_velocity],
                L / t_cy [cycle_time, eq. 6, if options.cycle_time_limit])
    accel = min_i A_mi / |u_i|
    jerk  = min(J_tcurv [if options.ncu_path_jerk],  min_i J_mi / |u_i|)

A block of zero length has no direction: it is not limited by the axes or the cycle time
(the planner makes it transparent) and takes accel = min_i A_mi, jerk = min(J_tcurv, min_i J_mi).

Arcs and helices: the set point (paper §5.2.4, the Fig. 12 flowchart being unavailable)
---------------------------------------------------------------------------------------
R is the radius of curvature (``geometry.curvature_radius_mm``). At each angle of the arc the
tangent t and principal normal n give (``kinematics``) J_t = min_i J_mi/|t_i| (eq. 9),
V_t (eq. 7), A_n (eq. 8), V_An = sqrt(R A_n) (eq. 2) and V_Jt = (J_t R^2)^(1/3) (eq. 4).

*alpha_c*, "the angular position when the feed rate becomes constant" (§5.2.4): the first
position along the travel where the axes can carry the NCU's tangential jerk,
J_t(alpha) >= J_tcurv (eq. 10) -- the earliest point from which the steady feed V_Jtcurv can be
held: the arc's start, or the first angle where J_t reaches J_tcurv (solved in closed form).
If no point of the arc reaches J_tcurv, or ``options.ncu_path_jerk`` is off, alpha_c is the
first point where J_t is largest. This
reproduces the paper's worked example: on the R 2.5 circle leaving along +X (tangent angle 0),
alpha_c = 33.5 deg (acos(5/6) = 33.56 deg) where J_t(alpha_c) = J_tcurv = 6 m/s^3, so
V_Jt(alpha_c) = V_Jtcurv = 2.01 m/min, V_An(alpha_c) = 5.7 m/min, V_t(alpha_c) = 36 m/min.
(Choosing instead the carrying point with the largest static look-ahead V_s, eq. 5, would put
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
Tangential acceleration in force: the least over the arc of
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
other value is treated as 601); junction n also gets ``path.end_dwell_s``. At a G0<->G1 change
(where the planner always stops, above) the settle of the window MD20552
``$MC_EXACT_POS_MODE_G0_TO_G1`` names is added when block k-1 has no exact stop of its own
(``ncu.exact_pos_mode_g0_to_g1``: 1 G601 fine, 2 G602 coarse; 0 and 3 stop without waiting for
a window, B1 §2.2 "exact stop at G0-G1 change").

Overrides (``ncu.feed_override``, ``ncu.rapid_override``: what the operator panel held while a
recording was made) scale the programmed feed of G1/G2/G3 blocks and the G0 velocity, which is
the axis-velocity limit along the line (MD32000, eq. 7) times the rapid override; the axis
limits still apply to the overridden feed.

``options.lookahead`` does not affect these limits (the planner applies the look-ahead).
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace

import numpy as np

from ncsim.plan import kinematics as kin
from ncsim.plan.arc_extrema import arc_capacities, arc_end_frames, arc_tangential_accel
from ncsim.machine import MachineSpec
from ncsim.motion import FULL_MODEL, Limit, ModelOptions
from ncsim.path import ARC, DRIVE, SOFT, Path

CHUNK_BLOCKS = 1 << 16              # blocks (and junctions) per chunk of work
TANGENT_TOL_RAD = 1e-4              # deflection above which a junction is a corner
CURVATURE_TOL_REL = 1e-6            # relative curvature-vector jump that counts as a transition

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
    candidates: Mapping[str, np.ndarray]  # Limit label -> that limit per block (+inf: n/a);
                                          # from path_limits: computed when first read
    # -- per junction (n + 1) -------------------------------------------------------------------
    junction_cap_mm_s: np.ndarray  # crossing cap: +inf unconstrained, 0 stop
    junction_limit: np.ndarray     # int8 Limit of the junction cap
    junction_dwell_s: np.ndarray   # time standing still at the junction
    # -- the path these limits belong to: the programmed one prepared by ncsim.plan.hsm --------
    path: Path | None = None       # (rounding blocks inserted); None: the caller's path
    nc_block: np.ndarray | None = None  # NC block of each row (compressed rows share one), for
                                        # the look-ahead; None: every row is a block
    row_of: np.ndarray | None = None    # row of ``path`` of each programmed row (rounding
                                        # blocks inserted between); None: the same rows

    def __post_init__(self) -> None:
        for name in ("cap_mm_s", "cap_limit", "jerk_mm_s3", "accel_mm_s2", "alpha_c_rad",
                     "junction_cap_mm_s", "junction_limit", "junction_dwell_s"):
            getattr(self, name).setflags(write=False)
        if isinstance(self.candidates, dict):
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
    limits = _path_limits(path, machine, options, candidates=False)
    return replace(limits, candidates=LazyCandidates(
        lambda: _path_limits(path, machine, options, candidates=True).candidates))


def _path_limits(path: Path, machine: MachineSpec, options: ModelOptions, *,
                 candidates: bool) -> PathLimits:
    """:func:`path_limits`; the candidates are made only if asked for or needed (the
    compressor's and the rounding's closed forms start from them)."""
    from ncsim.plan.hsm import prepare

    prepared = prepare(path, machine, options)
    limits = block_limits(prepared.path, machine, options,
                          candidates=candidates or prepared.changed)
    return prepared.apply(limits, machine, options)


class LazyCandidates(Mapping):
    """The eq. 12 candidates of :func:`path_limits`, computed again when first read (the same
    computation, so the same values): the planner needs only their minimum, and six arrays
    the size of the path would stay in memory for nothing (46 MiB at a million blocks)."""

    def __init__(self, compute) -> None:
        self._compute = compute
        self._values: dict[str, np.ndarray] | None = None

    def _get(self) -> dict[str, np.ndarray]:
        if self._values is None:
            values = self._compute()
            for arr in values.values():
                arr.setflags(write=False)
            self._values, self._compute = dict(values), None
        return self._values

    def __getitem__(self, key: str) -> np.ndarray:
        return self._get()[key]

    def __iter__(self):
        return iter(self._get())

    def __len__(self) -> int:
        return len(self._get())


def block_limits(path: Path, machine: MachineSpec, options: ModelOptions = FULL_MODEL, *,
                 candidates: bool = True) -> PathLimits:
    """The limits of every block and junction of ``path`` as programmed (module docstring),
    without the compressor and rounding of :func:`path_limits`. Blocks and junctions are
    processed in chunks of ``CHUNK_BLOCKS``, so that the temporaries stay small next to the
    results. ``candidates=False`` keeps no eq. 12 candidates (an empty dict)."""
    n = path.n
    ncu = machine.ncu
    j_ncu = ncu.tangential_jerk_mm_s3 if options.ncu_path_jerk else np.inf

    kept = {label: np.empty(n) for label in CANDIDATE_LABELS} if candidates else {}
    chunk = {label: np.empty(min(n, CHUNK_BLOCKS)) for label in CANDIDATE_LABELS}
    cap = np.empty(n)
    limit = np.empty(n, dtype=np.int8)
    accel = np.empty(n)
    jerk = np.empty(n)
    alpha_c = np.full(n, np.nan)
    jcap = np.full(n + 1, np.inf)
    jlimit = np.full(n + 1, int(Limit.NONE), dtype=np.int8)
    jdwell = np.zeros(n + 1)
    for lo, hi, group_machine in _group_chunks(path, machine):
        cand = {label: v[:hi - lo] for label, v in chunk.items()}
        _block_limits(path, lo, hi, group_machine, options, j_ncu, cand, cap, limit, accel, jerk,
                      alpha_c)
        for label, v in kept.items():
            v[lo:hi] = cand[label]
        _junction_limits(path, lo, hi, group_machine, options, jcap, jlimit)
        _junction_dwell(path, lo, hi, ncu, jdwell)
    jcap[0] = jcap[n] = 0.0
    jlimit[0] = jlimit[n] = int(Limit.PROGRAM_END)
    jdwell[n] += path.end_dwell_s
    return PathLimits(cap_mm_s=cap, cap_limit=limit, jerk_mm_s3=jerk, accel_mm_s2=accel,
                      alpha_c_rad=alpha_c, candidates=kept, junction_cap_mm_s=jcap,
                      junction_limit=jlimit, junction_dwell_s=jdwell)


def _group_chunks(path: Path, machine: MachineSpec):
    """``(lo, hi, machine of the group)`` over the runs of blocks of one technology group
    (``Path.dyn_group``: DYNNORM..DYNPREC, ``MachineSpec.for_group``), in chunks of at most
    ``CHUNK_BLOCKS``: each run's limits are computed with its group's axis arrays. A junction
    takes the group of the block after it (the group a block selects applies from it on)."""
    n = path.n
    group = path.dyn_group
    bounds = [0, n]
    if n and group.any():
        bounds = [0, *(np.flatnonzero(group[1:] != group[:-1]) + 1).tolist(), n]
    machines: dict[int, MachineSpec] = {}
    for start, stop in zip(bounds[:-1], bounds[1:]):
        g = int(group[start]) if n else 0
        m = machines.setdefault(g, machine.for_group(g))
        for lo in range(start, stop, CHUNK_BLOCKS):
            yield lo, min(lo + CHUNK_BLOCKS, stop), m


# ---------------------------------------------------------------------------------------------
# Blocks
# ---------------------------------------------------------------------------------------------

def _block_limits(path, lo, hi, machine, options, j_ncu, cand, cap, limit, accel, jerk,
                  alpha_c) -> None:
    """Set points and ramp limits of blocks lo..hi-1, written into the result arrays; their
    eq. 12 candidates into ``cand`` (arrays of the chunk's hi - lo blocks)."""
    ncu = machine.ncu
    blocks = slice(lo, hi)
    for v in cand.values():
        v.fill(np.inf)
    cand["programmed"][:] = np.where(path.rapid[blocks], np.inf,
                                     kin.overridden_feed_mm_s(path.feed_mm_s[blocks],
                                                              ncu.feed_override))
    if options.cycle_time_limit:
        cand["cycle_time"][:] = kin.cycle_time_feed_limit_mm_s(path.length_mm[blocks],
                                                               ncu.ipo_cycle_s)
    jerk_axis = np.empty(hi - lo)
    vmax = np.empty(hi - lo)     # axis-velocity limit along the block (DRIVE)
    is_arc = path.kind[blocks] == ARC
    local = np.flatnonzero(~is_arc)
    if len(local):
        lines = lo + local
        v_axis, accel[lines], jerk_axis[local] = _line_limits(path, lines, machine)
        cand["axis_velocity"][local] = vmax[local] = v_axis
        rapid = local[path.rapid[lines]]
        if ncu.rapid_override < 1.0 and len(rapid):
            cand["programmed"][rapid] = kin.rapid_feed_mm_s(cand["axis_velocity"][rapid],
                                                            ncu.rapid_override)
        cap[lines], limit[lines] = _set_point(cand, local)
    local = np.flatnonzero(is_arc)
    if len(local):
        arcs = lo + local               # the kernels' rows; the arrays' through ``rows``
        rows, local = ((arcs, local) if len(local) < hi - lo        # a run of arcs (CAM arc
                       else (blocks, slice(None)))                  # fitting): views
        (cap[rows], limit[rows], accel[rows], jerk_axis[local], vmax[local],
         alpha_c[rows]) = _arc_limits(path, arcs, local, machine, options, j_ncu, cand)

    mode = (np.full(hi - lo, options.accel_mode, dtype=np.int8) if options.accel_mode is not None
            else path.accel_mode[blocks])
    drive = mode == DRIVE
    a = accel[blocks]
    if np.any(drive):
        a[drive] = kin.drive_accel_mm_s2(a[drive], cap[blocks][drive], vmax[drive],
                                         ncu.drive_speed_point_ratio,
                                         ncu.drive_accel_reduction_ratio)
    soft = (mode == SOFT) & options.jerk_limited_ramps
    jerk[blocks] = np.where(soft, np.minimum(jerk_axis, j_ncu), kin.brisk_jerk_mm_s3(a, ncu.ipo_cycle_s))


def _set_point(cand: dict[str, np.ndarray], idx) -> tuple[np.ndarray, np.ndarray]:
    """Eq. 12 over the candidates of blocks ``idx``: the value and its Limit (int8)."""
    value, which = kin.feed_set_point_mm_s(*[cand[label][idx] for label in CANDIDATE_LABELS])
    codes = np.array([int(lim) for lim in CANDIDATE_LIMITS], dtype=np.int8)
    return value, codes[which]


def _line_limits(path, idx, machine):
    """Axis limits along the direction of lines ``idx`` (eq. 7 and its accel/jerk analogues):
    ``(V_t, tangential accel, J_t)``; a line without length takes the weakest axis."""
    length = path.length_mm[idx]
    d = path.end_mm[idx] - path.start_mm[idx]
    u = np.divide(d, length[:, None], out=d, where=length[:, None] > 0.0)
    u[length <= 0.0] = 0.0
    moving = length > 0.0
    v_axis = kin.axis_velocity_feed_limit_mm_s(u, machine.max_velocity_mm_s)
    accel = np.where(moving, kin.axis_tangential_accel_limit_mm_s2(u, machine.max_accel_mm_s2),
                     machine.max_accel_mm_s2.min())
    jerk = np.where(moving, kin.axis_tangential_jerk_limit_mm_s3(u, machine.max_jerk_mm_s3),
                    machine.max_jerk_mm_s3.min())
    return v_axis, accel, jerk


def _arc_limits(path, arcs, local, machine, options, j_ncu, cand):
    """Set points of the arcs ``arcs`` (module docstring), from the closed-form extrema of
    eq. 7-9 over each arc's angle range (:mod:`ncsim.plan.arc_extrema`); writes their eq. 12
    candidates into ``cand`` at ``local`` (their rows in the chunk: an index array, or a
    slice when they are the whole chunk) and returns ``(cap, limit, tangential accel, least
    J_t, least V_t, alpha_c)``."""
    ncu = machine.ncu
    columns = (arcs, path.start_mm, path.center_mm, path.normal, path.radius_mm, path.sweep_rad,
               path.helix_mm)
    (radius, _, alpha_c, _, j_t_c, v_t_c, a_n_c, v_t_min, a_n_min,
     j_t_min) = arc_capacities(*columns, machine.max_velocity_mm_s, machine.max_accel_mm_s2,
                               machine.max_jerk_mm_s3, float(j_ncu))
    v_an_guard = kin.normal_accel_feed_limit_mm_s(radius, ncu.normal_accel_share * a_n_min)
    if np.isfinite(j_ncu):
        cand["ncu_path_jerk"][local] = kin.ncu_path_jerk_feed_limit_mm_s(j_ncu, radius)  # eq. 11
    if options.axis_jerk_setpoint:
        cand["axis_jerk"][local] = kin.tangential_jerk_feed_limit_mm_s(j_t_c, radius)    # eq. 4
    cand["axis_accel"][local] = np.minimum(
        kin.normal_accel_feed_limit_mm_s(radius, a_n_c), v_an_guard)                    # eq. 2
    cand["axis_velocity"][local] = np.minimum(v_t_c, v_t_min)                           # eq. 7
    cap, limit = _set_point(cand, local)                                                 # eq. 12
    a_normal = cap ** 2 / radius                                                        # eq. 1
    accel = arc_tangential_accel(*columns, machine.max_accel_mm_s2, a_normal)
    return cap, limit, accel, j_t_min, v_t_min, alpha_c


# ---------------------------------------------------------------------------------------------
# Junctions
# ---------------------------------------------------------------------------------------------

def _settle_s(stop_window: np.ndarray, ncu) -> np.ndarray:
    """Time to enter the exact-stop window: G601 fine, G602 coarse, G603 none (else fine)."""
    return np.select([stop_window == 602, stop_window == 603],
                     [ncu.exact_stop_coarse_settle_s, 0.0], ncu.exact_stop_fine_settle_s)


def _junction_dwell(path, lo, hi, ncu, dwell) -> None:
    """Standing time at the junctions of blocks lo..hi-1: each block's dwell at its start, and
    the exact-stop settle at the end of a block that stops exactly; at a G0<->G1 change (where
    the planner always stops) the settle of the window MD20552 names, when the block has no
    exact stop of its own."""
    dwell[lo:hi] += path.dwell_before_s[lo:hi]
    stop = path.exact_stop[lo:hi]
    if np.any(stop):
        dwell[lo + 1:hi + 1] += np.where(stop, _settle_s(path.stop_window[lo:hi], ncu), 0.0)
    if ncu.exact_pos_mode_g0_to_g1 in (1, 2):
        last = min(hi, path.n - 1)
        if last > lo:
            g0g1 = (path.rapid[lo:last] != path.rapid[lo + 1:last + 1]) & ~path.exact_stop[lo:last]
            window = np.full(last - lo, 600 + ncu.exact_pos_mode_g0_to_g1, dtype=np.int16)
            dwell[lo + 1:last + 1] += np.where(g0g1, _settle_s(window, ncu), 0.0)


def _block_frames(path, lo, hi):
    """Unit tangents and curvature vectors (1/mm) of blocks lo..hi-1 at their start and at
    their end: ``(start tangent, start curvature, end tangent, end curvature)``. A line's are
    its chord direction and zero at both ends (the same arrays); an arc's come from
    :func:`~ncsim.plan.arc_extrema.arc_end_frames`, written in place."""
    is_arc = path.kind[lo:hi] == ARC
    arcs = lo + np.flatnonzero(is_arc)
    if not len(arcs):
        tangent = _line_tangents(path, lo, hi)
        curvature = np.zeros_like(tangent)
        return tangent, curvature, tangent, curvature
    m = hi - lo
    tangent, curvature = np.empty((m, 3)), np.empty((m, 3))
    tangent_end, curvature_end = np.empty((m, 3)), np.empty((m, 3))
    if len(arcs) < m:
        lines = np.flatnonzero(~is_arc)
        tangent[lines] = tangent_end[lines] = _line_tangents(path, lo + lines)
        curvature[lines] = curvature_end[lines] = 0.0
    arc_end_frames(arcs, path.start_mm, path.center_mm, path.normal, path.radius_mm,
                   path.sweep_rad, path.helix_mm, lo, tangent, curvature, tangent_end,
                   curvature_end)
    return tangent, curvature, tangent_end, curvature_end


def _line_tangents(path, rows, hi=None):
    """Chord directions of the blocks ``rows`` (an index array, or lo..hi-1); zero for a block
    without length."""
    if hi is not None:
        rows = slice(rows, hi)
    d = path.end_mm[rows] - path.start_mm[rows]
    length = path.length_mm[rows]
    tangent = np.divide(d, length[:, None], out=d, where=length[:, None] > 0.0)
    tangent[length <= 0.0] = 0.0
    return tangent


def _junction_limits(path, lo, hi, machine, options, cap, lim) -> None:
    """Crossing caps of the inner junctions max(lo, 1)..hi-1 (junction k joins block k-1 to
    block k), written into ``cap`` and ``lim``."""
    first = max(lo, 1)
    if hi <= first:
        return
    ncu = machine.ncu
    before, after, inner = slice(first - 1, hi - 1), slice(first, hi), slice(first, hi)
    t_start, k_start, t_end, k_end = _block_frames(path, first - 1, hi)
    t1, k1 = t_end[:-1], k_end[:-1]          # block k-1 at its end
    t2, k2 = t_start[1:], k_start[1:]        # block k at its start
    deflection = kin.deflection_angle_rad(t1, t2)
    corner = deflection > TANGENT_TOL_RAD

    # corners: the G64 axis velocity jump (rounded corners are ncsim.plan.blend's)
    v_corner = kin.corner_feed_g64_mm_s(t1, t2, machine.max_accel_mm_s2, ncu.ipo_cycle_s,
                                        machine.max_accel_ovl_factor)

    # curvature jumps with a continuous tangent: eq. 13 / 15
    jump = kin.curvature_jump_1_mm(k1, k2)
    scale = np.maximum(np.linalg.norm(k1, axis=1), np.linalg.norm(k2, axis=1))
    transition = ~corner & (jump > CURVATURE_TOL_REL * scale) & options.transition_crossing
    j_t = kin.axis_tangential_jerk_limit_mm_s3(t1, machine.max_jerk_mm_s3)       # eq. 15
    v_fr = kin.transition_feed_mm_s(j_t, ncu.transition_time_s, jump)            # eq. 13

    cap[inner] = np.where(corner, v_corner, np.where(transition, v_fr, np.inf))
    lim[inner] = np.select([corner, transition], [int(Limit.CORNER), int(Limit.TRANSITION)],
                           int(Limit.NONE))

    stops = [  # (mask over the junctions, limit); later entries win the label
        (path.rapid[before] != path.rapid[after], Limit.AUX_STOP),
        (path.stop_before[after], Limit.AUX_STOP),
        (path.exact_stop[before], Limit.EXACT_STOP),
        (path.dwell_before_s[after] > 0.0, Limit.DWELL),
    ]
    for mask, why in stops:
        cap[inner][mask] = 0.0
        lim[inner][mask] = int(why)
