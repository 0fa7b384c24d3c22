"""Technology-group dynamics: the machine file's ``[dynamics]`` table.

The 840D keeps several sets of axis dynamics, one per technology group of G group 59
(Programming Manual Job planning, "Dynamic response mode for path interpolation (DYNNORM,
DYNPOS, DYNROUGH, DYNSEMIFIN, DYNFINISH, DYNPREC)"; Function Manual B2 "Acceleration",
"Technology-specific dynamic response"): the axis machine data MD32300 ``$MA_MAX_AX_ACCEL[n]``
and MD32431 ``$MA_MAX_AX_JERK[n]`` are arrays indexed by the group, n = 0 DYNNORM, 1 DYNPOS,
2 DYNROUGH, 3 DYNSEMIFIN, 4 DYNFINISH (5 DYNPREC on controls that have it). The program selects
a group with the DYN... word, and CYCLE832 with its machining type (SINUMERIK Operate
commissioning, "High speed settings": _FINISH DYNFINISH, _SEMIFIN DYNSEMIFIN, _ROUGH DYNROUGH,
deselection DYNNORM). ncsim also takes a velocity per group (MD32000 ``$MA_MAX_AX_VELO`` is one
value on the 840D: give it only where a machine builder limits the velocity per group, e.g. by
an override in CUST_832).

Schema (README "Machine file"): ``[axes]`` holds group 0, DYNNORM. ``[dynamics.<GROUP>.<axis>]``
gives ``max_accel_m_s2``, ``max_jerk_m_s3``, ``max_velocity_m_min`` of one axis in a group,
each defaulting to the axis's ``[axes]`` value; ``[dynamics] same_for_all_groups = true``
declares that the machine runs every group with the ``[axes]`` values (the machine data arrays
hold one set). A program that selects a group the file defines neither way is simulated with
the ``[axes]`` values and warned (the result is approximate).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ncsim.config import Problems, between
from ncsim.units import (m_min_to_mm_s, m_s2_to_mm_s2, m_s3_to_mm_s3, mm_s2_to_m_s2,
                         mm_s3_to_m_s3, mm_s_to_m_min)

#: G group 59 in index order (the Path's ``dyn_group``, the machine data's array index)
TECHNOLOGY_GROUPS = ("DYNNORM", "DYNPOS", "DYNROUGH", "DYNSEMIFIN", "DYNFINISH", "DYNPREC")
ALL_GROUPS_KEY = "same_for_all_groups"
#: (toml key, index in GroupDynamics.limits, check, converter to mm and s)
_KEYS = (("max_velocity_m_min", 0, between(1e-3, 1e6, "m/min"), m_min_to_mm_s),
         ("max_accel_m_s2", 1, between(1e-3, 1e6, "m/s^2"), m_s2_to_mm_s2),
         ("max_jerk_m_s3", 2, between(1e-3, 1e9, "m/s^3"), m_s3_to_mm_s3))


@dataclass(frozen=True, slots=True)
class GroupDynamics:
    """What the file gives: ``limits[g]`` is (velocity mm/s, accel mm/s^2, jerk mm/s^3) x
    (X, Y, Z) of group g where ``given[g]`` (its ``[dynamics.<GROUP>]`` table; keys it omits
    are the ``[axes]`` values), ``same_for_all`` the explicit one-set declaration."""

    limits: np.ndarray            # (len(TECHNOLOGY_GROUPS), 3 quantities, 3 axes)
    given: tuple[bool, ...]
    same_for_all: bool = False

    def defines(self, group: int) -> bool:
        """Whether the machine file says how group ``group`` runs (DYNNORM: the [axes])."""
        return group == 0 or self.same_for_all or self.given[group]


def axis_limits(axes) -> np.ndarray:
    """(velocity, accel, jerk) x axes of the ``[axes]`` values (``axes``: AxisSpec)."""
    return np.array([[a.max_velocity_mm_s for a in axes], [a.max_accel_mm_s2 for a in axes],
                     [a.max_jerk_mm_s3 for a in axes]])


def group_limits(axes, dynamics: GroupDynamics | None) -> np.ndarray:
    """(group, quantity, axis): the given groups' values, every other group the ``[axes]``."""
    table = np.repeat(axis_limits(axes)[None], len(TECHNOLOGY_GROUPS), axis=0)
    if dynamics is not None:
        given = np.array(dynamics.given)
        table[given] = dynamics.limits[given]
    return table


def read_dynamics(c: Problems, table: dict, axes, axis_names) -> GroupDynamics | None:
    """The ``[dynamics]`` table (module docstring) over the ``[axes]`` values ``axes``; None
    without one."""
    if not table or len(axes) != len(axis_names):
        return None
    c.unknown(table, "dynamics", {ALL_GROUPS_KEY, *TECHNOLOGY_GROUPS[1:]},
              "unknown key (the groups are DYNPOS, DYNROUGH, DYNSEMIFIN, DYNFINISH, DYNPREC; "
              "DYNNORM is [axes])")
    same = bool(c.boolean(table, "dynamics", ALL_GROUPS_KEY))
    limits = group_limits(axes, None)
    given = [False] * len(TECHNOLOGY_GROUPS)
    for g, group in enumerate(TECHNOLOGY_GROUPS[1:], start=1):
        gtab = c.table(table, group, prefix="dynamics")
        if group not in table:
            continue
        if same:
            c.add(f"dynamics.{group}", f"{ALL_GROUPS_KEY} = true says every group runs with the "
                  f"[axes] values: give either it or per-group values")
        c.unknown(gtab, f"dynamics.{group}", set(axis_names))
        given[g] = True
        for i, axis in enumerate(axis_names):
            atab = c.table(gtab, axis, prefix=f"dynamics.{group}")
            prefix = f"dynamics.{group}.{axis}"
            c.unknown(atab, prefix, {k for k, *_ in _KEYS})
            for key, q, check, convert in _KEYS:
                v = c.number(atab, prefix, key, check=check, convert=convert)
                if v is not None:
                    limits[g, q, i] = v
    limits.setflags(write=False)
    return GroupDynamics(limits, tuple(given), same)


def dump_dynamics(dyn: GroupDynamics | None, axis_names, fmt) -> list[str]:
    """The ``[dynamics]`` lines of a machine TOML file (``fmt`` formats a float)."""
    if dyn is None:
        return []
    lines = ["", "[dynamics]", f"{ALL_GROUPS_KEY} = true"] if dyn.same_for_all else []
    for g, group in enumerate(TECHNOLOGY_GROUPS[1:], start=1):
        if not dyn.given[g]:
            continue
        for i, axis in enumerate(axis_names):
            v, a, j = dyn.limits[g, :, i]
            lines += ["", f"[dynamics.{group}.{axis}]",
                      f"max_velocity_m_min = {fmt(mm_s_to_m_min(v))}",
                      f"max_accel_m_s2 = {fmt(mm_s2_to_m_s2(a))}  # MD32300 $MA_MAX_AX_ACCEL[{g}]",
                      f"max_jerk_m_s3 = {fmt(mm_s3_to_m_s3(j))}  # MD32431 $MA_MAX_AX_JERK[{g}]"]
    return lines
