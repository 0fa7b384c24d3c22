"""The path as the 840D runs it in its HSM modes: compressor runs and rounding blocks.

:func:`prepare` runs before the limits (``ncsim.plan.limits.path_limits`` calls it):

1. the compressor (:mod:`ncsim.plan.compressor`) finds the runs of short G1 blocks it joins
   under COMPON/COMPCURV/COMPCAD/COMPSURF and fits their smooth curve;
2. the corner rounding (:mod:`ncsim.plan.blend`) inserts the rounding blocks of G641-G645 at
   the corners left (not inside compressed runs) and smooths G645 transitions.

:meth:`Prepared.apply` then replaces, in the limits computed on the prepared path, what the
programmed geometry cannot say:

* a compressed block: eq. 6 on its polynomial block (``group_length_mm / t_cy``), the F of the
  polynomial's last block (FNORM), the curvature limits of the fitted curve (eq. 2/8 with the
  normal-acceleration share, eq. 11, and eq. 4/9 with the axis jerk where it exceeds J_tcurv,
  as the paper's arcs take V_Jt at alpha_c) and its curvature change over the block (eq. 13
  spread, TRANSITION); junctions inside a run are not corners;
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
        ncu = machine.ncu
        old = np.nonzero(c.in_run)[0]
        rows = row_of[old]
        path = self.path
        u = line_directions(path)[rows]
        kappa = c.curvature_1_mm[old]
        normal = c.normal[old]
        radius = np.divide(1.0, kappa, out=np.full(kappa.shape, np.inf), where=kappa > 0.0)
        cand["programmed"][rows] = c.group_feed_mm_s[old]
        if options.cycle_time_limit:
            cand["cycle_time"][rows] = kin.cycle_time_feed_limit_mm_s(c.group_length_mm[old],
                                                                      ncu.ipo_cycle_s)
        if options.ncu_path_jerk:
            cand["ncu_path_jerk"][rows] = kin.ncu_path_jerk_feed_limit_mm_s(
                ncu.tangential_jerk_mm_s3, radius)
        _, max_accel, max_jerk = _group_axis_rows(machine, path.dyn_group[rows])
        j_t = kin.axis_tangential_jerk_limit_mm_s3(u, max_jerk)
        if options.axis_jerk_setpoint:
            # as on the paper's arcs, where the set point is taken where the axes carry J_tcurv
            # (alpha_c, §5.2.4: R 30 holds 10.53 m/min above the least V_Jt of 9.9)
            j_set = np.maximum(j_t, ncu.tangential_jerk_mm_s3) if options.ncu_path_jerk else j_t
            cand["axis_jerk"][rows] = kin.tangential_jerk_feed_limit_mm_s(j_set, radius)
        a_n = ncu.normal_accel_share * kin.axis_normal_accel_limit_mm_s2(normal, max_accel)
        cand["axis_accel"][rows] = kin.normal_accel_feed_limit_mm_s(radius, a_n)
        value, which = kin.feed_set_point_mm_s(*[cand[key][rows] for key, _ in _CANDIDATES])
        codes = np.array([int(lim) for _, lim in _CANDIDATES], dtype=np.int8)
        limit = codes[which]
        if options.transition_crossing:
            v_change = kin.curvature_change_feed_mm_s(j_t, ncu.transition_time_s,
                                                      c.curvature_change_1_mm[old],
                                                      path.length_mm[rows])
            lower = v_change < value
            value = np.where(lower, v_change, value)
            limit = np.where(lower, np.int8(Limit.TRANSITION), limit)
        cap[rows] = value
        cap_limit[rows] = limit
        normal_accel = value * value * kappa
        available = kin.tangential_accel_available_mm_s2(u, normal, normal_accel, max_accel)
        accel[rows] = np.minimum(accel[rows], np.maximum(available, 1e-9 * accel[rows]))
        joined = np.nonzero(c.joined)[0]
        junction_of = np.append(row_of, path.n)
        jcap[junction_of[joined]] = np.inf
        jlimit[junction_of[joined]] = Limit.NONE


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
    smooth = (compression.joined if compression is not None
              else np.zeros(path.n + 1, dtype=bool))
    rounding = round_corners(path, _rounding_machine(path, machine), options, smooth)
    return Prepared(path=rounding.path if rounding is not None else path,
                    compression=compression, rounding=rounding)
