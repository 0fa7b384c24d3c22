"""The path as the 840D runs it in its HSM modes: compressor runs and rounding blocks.

:func:`prepare` runs before the limits (``ncsim.plan.limits.path_limits`` calls it):

1. the compressor (:mod:`ncsim.plan.compressor`) finds the runs of short G1 blocks it joins
   under COMPON/COMPCURV/COMPCAD/COMPSURF and fits their smooth curve; then *corner detection
   by speed*: where the fitted curve would hold a block below what the block allows as
   programmed (F, eq. 7, eq. 6 on its own length) -- its curvature limits (eq. 2/8, 4/9, 11)
   or its curvature change (eq. 13 spread) -- the compressor keeps a corner at the block's
   joined end where the curve bends most, and the runs that lose it are fitted again (up to
   ``_SPEED_ROUNDS`` times). B1 names the compressor's purpose, "to optimize the surface
   quality and machining speed", and says of COMPCAD that "corners that are desirable are
   identified as such" with SD42470 "only used as an approximate measure for corner
   detection"; a point the smooth curve would cross slower than the programmed blocks is such a
   corner (a tight turn of a noisy raster, where G64 crosses the corner with the MD32310 jump
   and the curve would have to honour the path jerk). So no block of a compressed run is
   slower than as programmed: COMPON/COMPCURV/COMPCAD are never slower than COMPOF on the same
   points (``tests/test_hsm_properties.py``);
2. the corner rounding (:mod:`ncsim.plan.blend`) inserts the rounding blocks of G641-G645 at
   the corners left (not inside compressed runs) and smooths G645 transitions.

:meth:`Prepared.apply` then replaces, in the limits computed on the prepared path, what the
programmed geometry cannot say:

* a compressed block: eq. 6 on its polynomial block (``group_length_mm / t_cy``), the F of the
  polynomial's last block (FNORM: its own F, polynomials end at a change of F), the curvature
  limits of the fitted curve (eq. 2/8 with the normal-acceleration share, eq. 11, and eq. 4/9
  with the axis jerk where it exceeds J_tcurv, as the paper's arcs take V_Jt at alpha_c) and
  its curvature change over the block (eq. 13 spread, TRANSITION), all from
  :func:`curve_candidates`; junctions inside a run are not corners;
* a rounding block: the closed-form feed of the clothoid rounding; its two junctions are
  smooth (no corner, no eq. 13 jump: the rounding is curvature-continuous);
* a corner rounded in time only (an arc on one side): its crossing feed is the rounding's;
* a G645 transition: the spread crossing feed replaces eq. 13;
* the look-ahead counts NC blocks: the rows of one polynomial block share ``nc_block``.

Without compressor and rounding modes the path and the limits are returned unchanged.

Technology groups (``Path.dyn_group``): a compressed block's closed forms take its group's axis
limits; the rounding takes those of the group of the rounded blocks when they share one (one
CYCLE832 for the whole contour), else the [axes] values (:func:`_rounding_machine`).
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ncsim.geometry import line_directions
from ncsim.machine import MachineSpec
from ncsim.motion import Limit, ModelOptions
from ncsim.path import Path
from ncsim.plan import kinematics as kin
from ncsim.plan.blend import Rounding, round_corners
from ncsim.plan.compressor import Compression, compress

_SPEED_ROUNDS = 8     # refits after keeping the corners where the fitted curve is slower
_SPEED_REL = 1e-9     # relative margin of "slower"

# eq. 12's candidates in plan.limits' order (ties go to the earlier one)
_CANDIDATES = (("programmed", Limit.PROGRAMMED), ("ncu_path_jerk", Limit.NCU_PATH_JERK),
               ("axis_jerk", Limit.AXIS_JERK), ("axis_accel", Limit.AXIS_ACCEL),
               ("axis_velocity", Limit.AXIS_VELOCITY), ("cycle_time", Limit.CYCLE_TIME))


@dataclass(frozen=True, slots=True)
class Prepared:
    """A path prepared for planning (module docstring)."""

    path: Path
    compression: Compression | None = None    # on the programmed path's rows
    rounding: Rounding | None = None

    @property
    def changed(self) -> bool:
        return self.compression is not None or self.rounding is not None

    def apply(self, limits, machine: MachineSpec, options: ModelOptions):
        """``limits`` (a ``plan.limits.PathLimits`` of :attr:`path`) with the compressor's and
        the rounding's closed forms; its ``path`` is :attr:`path`."""
        if not self.changed:
            return replace(limits, path=self.path)
        cap = np.array(limits.cap_mm_s)
        cap_limit = np.array(limits.cap_limit)
        accel = np.array(limits.accel_mm_s2)
        cand = {key: np.array(v) for key, v in limits.candidates.items()}
        jcap = np.array(limits.junction_cap_mm_s)
        jlimit = np.array(limits.junction_limit)
        n_new = self.path.n
        row_of = (self.rounding.row_of if self.rounding is not None
                  else np.arange(n_new))
        if self.compression is not None:
            self._apply_compression(row_of, machine, options, cap, cap_limit, accel, cand, jcap,
                                    jlimit)
        if self.rounding is not None:
            r = self.rounding
            rows = r.blend_row
            cap[rows] = r.blend_feed_mm_s
            cap_limit[rows] = r.blend_limit
            accel[rows] = r.blend_accel_mm_s2
            for key in cand:
                cand[key][rows] = np.inf
            cand["programmed"][rows] = np.where(self.path.rapid[rows], np.inf,
                                                self.path.feed_mm_s[rows])
            smooth = np.concatenate([rows, rows + 1])
            jcap[smooth] = np.inf
            jlimit[smooth] = Limit.NONE
            jcap[r.junction_row] = r.junction_feed_mm_s
            jlimit[r.junction_row] = r.junction_limit
            tr = r.transition_row
            better = r.transition_feed_mm_s > jcap[tr]
            jcap[tr[better]] = r.transition_feed_mm_s[better]
        nc_block = None
        if self.compression is not None:   # the rows of one polynomial block are one NC block
            nc_block = np.arange(n_new)
            grouped = np.nonzero(self.compression.group_first >= 0)[0]
            nc_block[row_of[grouped]] = row_of[self.compression.group_first[grouped]]
        return replace(limits, cap_mm_s=cap, cap_limit=cap_limit, accel_mm_s2=accel,
                       candidates=cand, junction_cap_mm_s=jcap, junction_limit=jlimit,
                       path=self.path, nc_block=nc_block,
                       row_of=self.rounding.row_of if self.rounding is not None else None)

    def _apply_compression(self, row_of, machine, options, cap, cap_limit, accel, cand, jcap,
                           jlimit) -> None:
        c = self.compression
        old = np.nonzero(c.in_run)[0]
        rows = row_of[old]
        path = self.path
        u = line_directions(path)[rows]
        groups = path.dyn_group[rows]
        curve = curve_candidates(c, old, u, path.length_mm[rows], groups, machine, options)
        for key, _ in _CANDIDATES:
            if key in curve:
                cand[key][rows] = curve[key]
        value, which = kin.feed_set_point_mm_s(*[cand[key][rows] for key, _ in _CANDIDATES])
        codes = np.array([int(lim) for _, lim in _CANDIDATES], dtype=np.int8)
        limit = codes[which]
        lower = curve["transition"] < value
        value = np.where(lower, curve["transition"], value)
        limit = np.where(lower, np.int8(Limit.TRANSITION), limit)
        cap[rows] = value
        cap_limit[rows] = limit
        normal_accel = value * value * c.curvature_1_mm[old]
        _, max_accel, _ = _group_axis_rows(machine, groups)
        available = kin.tangential_accel_available_mm_s2(u, c.normal[old], normal_accel, max_accel)
        accel[rows] = np.minimum(accel[rows], np.maximum(available, 1e-9 * accel[rows]))
        joined = np.nonzero(c.joined)[0]
        junction_of = np.append(row_of, path.n)
        jcap[junction_of[joined]] = np.inf
        jlimit[junction_of[joined]] = Limit.NONE


def curve_candidates(c: Compression, old, u, length_mm, groups, machine: MachineSpec,
                     options: ModelOptions) -> dict[str, np.ndarray]:
    """What the fitted curve of the compressed blocks ``old`` (rows of the programmed path;
    ``u`` their directions, ``length_mm`` their lengths, ``groups`` their technology groups,
    ``Path.dyn_group``) puts in eq. 12 (module docstring):
    ``programmed`` (the polynomial block's F, FNORM), ``cycle_time`` (eq. 6 on the polynomial
    block), ``ncu_path_jerk`` (eq. 11), ``axis_jerk`` (eq. 4/9), ``axis_accel`` (eq. 2/8) on
    the fitted curvature, and ``transition``: its curvature change over the block crossed as
    eq. 13 spread over the block (+inf where a limit is off)."""
    ncu = machine.ncu
    kappa = c.curvature_1_mm[old]
    radius = np.divide(1.0, kappa, out=np.full(kappa.shape, np.inf), where=kappa > 0.0)
    inf = np.full(len(old), np.inf)
    out = {"programmed": kin.overridden_feed_mm_s(c.group_feed_mm_s[old], ncu.feed_override),
           "cycle_time": inf, "ncu_path_jerk": inf, "axis_jerk": inf, "transition": inf}
    if options.cycle_time_limit:
        out["cycle_time"] = kin.cycle_time_feed_limit_mm_s(c.group_length_mm[old], ncu.ipo_cycle_s)
    if options.ncu_path_jerk:
        out["ncu_path_jerk"] = kin.ncu_path_jerk_feed_limit_mm_s(ncu.tangential_jerk_mm_s3, radius)
    _, max_accel, max_jerk = _group_axis_rows(machine, groups)
    j_t = kin.axis_tangential_jerk_limit_mm_s3(u, max_jerk)
    if options.axis_jerk_setpoint:
        # as on the paper's arcs, where the set point is taken where the axes carry J_tcurv
        # (alpha_c, §5.2.4: R 30 holds 10.53 m/min above the least V_Jt of 9.9)
        j_set = np.maximum(j_t, ncu.tangential_jerk_mm_s3) if options.ncu_path_jerk else j_t
        out["axis_jerk"] = kin.tangential_jerk_feed_limit_mm_s(j_set, radius)
    a_n = ncu.normal_accel_share * kin.axis_normal_accel_limit_mm_s2(c.normal[old], max_accel)
    out["axis_accel"] = kin.normal_accel_feed_limit_mm_s(radius, a_n)
    if options.transition_crossing:
        out["transition"] = kin.curvature_change_feed_mm_s(
            j_t, ncu.transition_time_s, c.curvature_change_1_mm[old], length_mm)
    return out


def _slower_junctions(c: Compression, path: Path, machine: MachineSpec, options: ModelOptions,
                      blocks: np.ndarray | None = None) -> np.ndarray:
    """Junctions (n + 1, bool) the compressor keeps as corners because its curve would be
    slower than the programmed blocks (module docstring, "corner detection by speed"): for
    every compressed block whose curve limits (eq. 2/8, 4/9, 11 and the curvature change) fall
    below what the block allows as programmed -- F, eq. 7, eq. 6 on its own length -- its
    joined end where the fitted curve bends most. ``blocks`` (n, bool): only those (the ones
    refitted since the last look)."""
    ncu = machine.ncu
    old = np.nonzero(c.in_run if blocks is None else c.in_run & blocks)[0]
    u = line_directions(path)[old]
    groups = path.dyn_group[old]
    curve = curve_candidates(c, old, u, path.length_mm[old], groups, machine, options)
    v_curve = np.minimum.reduce([curve[key] for key in
                                 ("ncu_path_jerk", "axis_jerk", "axis_accel", "transition")])
    v_programmed = np.minimum(
        kin.overridden_feed_mm_s(path.feed_mm_s[old], ncu.feed_override),
        kin.axis_velocity_feed_limit_mm_s(u, _group_axis_rows(machine, groups)[0]))
    if options.cycle_time_limit:
        v_programmed = np.minimum(v_programmed, kin.cycle_time_feed_limit_mm_s(
            path.length_mm[old], ncu.ipo_cycle_s))
    slow = old[v_curve < v_programmed * (1.0 - _SPEED_REL)]
    kept = np.zeros(path.n + 1, dtype=bool)
    if slow.size:
        k_start = np.where(c.joined[slow], c.junction_curvature_1_mm[slow], -1.0)
        k_end = np.where(c.joined[slow + 1], c.junction_curvature_1_mm[slow + 1], -1.0)
        kept[np.where(k_end > k_start, slow + 1, slow)] = True
    return kept


def _group_axis_rows(machine: MachineSpec, groups: np.ndarray):
    """(velocity, accel, jerk), each (rows, 3): the axis limits of each row's technology group
    (``Path.dyn_group``, ``machine.TECHNOLOGY_GROUPS``), for the vectorised kinematics."""
    table = machine.group_limits()[np.asarray(groups, dtype=np.intp)]
    return table[:, 0], table[:, 1], table[:, 2]


def _rounding_machine(path: Path, machine: MachineSpec) -> MachineSpec:
    """The machine the corner rounding works with: the technology group of the blocks in a
    rounding mode (G641-G645) when they share one (as after one CYCLE832), else DYNNORM's
    [axes] (the rounding of a path that changes group between rounded corners uses those)."""
    groups = np.unique(path.dyn_group[np.isin(path.cp_mode, (641, 642, 643, 644, 645))])
    return machine.for_group(int(groups[0])) if len(groups) == 1 else machine


def prepare(path: Path, machine: MachineSpec, options: ModelOptions) -> Prepared:
    """The compressor's runs and the rounding blocks of ``path`` (module docstring)."""
    compression = compress(path, machine)
    kept = np.zeros(path.n + 1, dtype=bool)
    refitted = None                                  # first round: every compressed block
    for _ in range(_SPEED_ROUNDS):
        if compression is None:
            break
        slower = _slower_junctions(compression, path, machine, options, refitted)
        if not slower.any():
            break
        kept |= slower
        before = compression
        compression = compress(path, machine, kept, previous=before)
        if compression is not None:
            refitted = (np.any(compression.kappa_start != before.kappa_start, axis=1)
                        | np.any(compression.kappa_end != before.kappa_end, axis=1))
    smooth = (compression.joined if compression is not None
              else np.zeros(path.n + 1, dtype=bool))
    rounding = round_corners(path, _rounding_machine(path, machine), options, smooth)
    return Prepared(path=rounding.path if rounding is not None else path,
                    compression=compression, rounding=rounding)
