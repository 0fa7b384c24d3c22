"""Technology-group dynamics (G group 59): the machine file's ``[dynamics]`` table.

Job planning, "Dynamic response mode for path interpolation (DYNNORM ... DYNPREC)"; B2
"Acceleration": MD32300 $MA_MAX_AX_ACCEL[n] and MD32431 $MA_MAX_AX_JERK[n] are arrays indexed
by the group n (0 DYNNORM = [axes], 1 DYNPOS, 2 DYNROUGH, 3 DYNSEMIFIN, 4 DYNFINISH, 5
DYNPREC); the DYN... words and CYCLE832's machining type select it. ncsim also takes a velocity
per group (MD32000 is one value on the 840D: for a machine builder's per-group override).
[dynamics.<GROUP>.<axis>] keys default to the [axes] value; [dynamics] same_for_all_groups =
true declares one set for every group. A group given neither way runs with [axes], warned.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ncsim.config import Problems, between
from ncsim.units import m_min_to_mm_s, m_s2_to_mm_s2, m_s3_to_mm_s3, mm_s2_to_m_s2, mm_s3_to_m_s3, mm_s_to_m_min

TECHNOLOGY_GROUPS = ("DYNNORM", "DYNPOS", "DYNROUGH", "DYNSEMIFIN", "DYNFINISH", "DYNPREC")
ALL_GROUPS_KEY = "same_for_all_groups"
_GROUP_KEYS = (("max_velocity_m_min", 0, between(1e-3, 1e6, "m/min"), m_min_to_mm_s),
               ("max_accel_m_s2", 1, between(1e-3, 1e6, "m/s^2"), m_s2_to_mm_s2),
               ("max_jerk_m_s3", 2, between(1e-3, 1e9, "m/s^3"), m_s3_to_mm_s3))


@dataclass(frozen=True, slots=True)
class GroupDynamics:
    """``limits[g]``: (velocity mm/s, accel mm/s^2, jerk mm/s^3) x (X, Y, Z) of group g where
    ``given[g]``; ``same_for_all``: the explicit one-set declaration."""

    limits: np.ndarray            # (len(TECHNOLOGY_GROUPS), 3 quantities, the axes)
    given: tuple[bool, ...]
    same_for_all: bool = False
    axis_names: tuple[str, ...] = ("X", "Y", "Z")

    def defines(self, group: int) -> bool:
        return group == 0 or self.same_for_all or self.given[group]


def group_limits(axes, dynamics: GroupDynamics | None) -> np.ndarray:
    """(group, quantity, axis): the given groups' values, every other group the ``[axes]``."""
    one = [[getattr(a, f) for a in axes]
           for f in ("max_velocity_mm_s", "max_accel_mm_s2", "max_jerk_mm_s3")]
    table = np.repeat(np.array(one)[None], len(TECHNOLOGY_GROUPS), axis=0)
    if dynamics is not None:
        given = np.array(dynamics.given)
        table[given] = dynamics.limits[given]
    return table


def read_dynamics(c: Problems, table: dict, axes) -> GroupDynamics | None:
    """The ``[dynamics]`` table over the ``[axes]`` values; None without one."""
    names = tuple(a.name for a in axes)
    if not table or len(names) != 3:
        return None
    c.unknown(table, "dynamics", {ALL_GROUPS_KEY, *TECHNOLOGY_GROUPS[1:]},
              "unknown key (the groups are DYNPOS, DYNROUGH, DYNSEMIFIN, DYNFINISH, DYNPREC; "
              "DYNNORM is [axes])")
    same = bool(c.boolean(table, "dynamics", ALL_GROUPS_KEY))
    limits, given = group_limits(axes, None), [False] * len(TECHNOLOGY_GROUPS)
    for g, group in enumerate(TECHNOLOGY_GROUPS[1:], start=1):
        gtab = c.table(table, group, prefix="dynamics")
        if group not in table:
            continue
        if same:
            c.add(f"dynamics.{group}", f"{ALL_GROUPS_KEY} = true says every group runs with the "
                  f"[axes] values: give either it or per-group values")
        c.unknown(gtab, f"dynamics.{group}", set(names))
        given[g] = True
        for i, axis in enumerate(names):
            prefix = f"dynamics.{group}.{axis}"
            atab = c.table(gtab, axis, prefix=f"dynamics.{group}")
            c.unknown(atab, prefix, {k for k, *_ in _GROUP_KEYS})
            for key, q, check, convert in _GROUP_KEYS:
                v = c.number(atab, prefix, key, check=check, convert=convert)
                if v is not None:
                    limits[g, q, i] = v
    limits.setflags(write=False)
    return GroupDynamics(limits, tuple(given), same, names)


def dump_dynamics(dyn: GroupDynamics | None) -> list[str]:
    if dyn is None:
        return []
    lines = ["", "[dynamics]", f"{ALL_GROUPS_KEY} = true"] if dyn.same_for_all else []
    for g in (g for g in range(1, len(TECHNOLOGY_GROUPS)) if dyn.given[g]):
        for i, axis in enumerate(dyn.axis_names):
            v, a, j = dyn.limits[g, :, i]
            lines += ["", f"[dynamics.{TECHNOLOGY_GROUPS[g]}.{axis}]",
                      f"max_velocity_m_min = {_number(mm_s_to_m_min(v))}",
                      f"max_accel_m_s2 = {_number(mm_s2_to_m_s2(a))}  # MD32300 $MA_MAX_AX_ACCEL[{g}]",
                      f"max_jerk_m_s3 = {_number(mm_s3_to_m_s3(j))}  # MD32431 $MA_MAX_AX_JERK[{g}]"]
    return lines


def _number(v: float) -> str:
    return repr(float(v))
