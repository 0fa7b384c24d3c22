"""The machine file's ``[iso]`` table: how the control runs ISO dialect (Fanuc-style) programs.

SINUMERIK ISO dialects (Function Manual "ISO dialects", "Data descriptions"; ISO Milling,
"Switchover modes", "Decimal point programming", "Reference point return", "Fixed cycles"):

================================  ===============================================================
key                               meaning
================================  ===============================================================
``dialect``                       the language a program starts in: ``"siemens"`` (G290) or
                                  ``"iso"`` (G291); MD20150 ``$MC_GCODE_RESET_VALUES`` of G group
                                  47 (``--dialect`` overrides it)
``decimal_point``                 ``"calculator"`` (a number without decimal point is mm, inch or
                                  degrees; MD10884 ``$MN_EXTERN_FLOATINGPOINT_PROG`` = 1, the
                                  delivered value) or ``"standard"`` (it counts input increments:
                                  X1000 = 1 mm; MD10884 = 0)
``reference_points_mm``           the reference points in machine coordinates, G28's first, then
                                  G30 P2, P3, P4 (MD34100 ``$MA_REFP_SET_POS``; default the
                                  machine origin, where the tool starts)
``peck_retract_mm``               G73's retraction d after each peck (Fanuc parameter 5114; 1 mm)
``peck_clearance_mm``             G83's clearance d above the last depth (parameter 5115; 1 mm)
================================  ===============================================================
"""
from __future__ import annotations

from dataclasses import dataclass

DIALECTS = ("siemens", "iso")
DECIMAL_POINT = ("calculator", "standard")
_ZERO = (0.0, 0.0, 0.0)
_KEYS = {"dialect", "decimal_point", "reference_points_mm", "peck_retract_mm",
         "peck_clearance_mm"}


@dataclass(frozen=True, slots=True)
class IsoSpec:
    dialect: str = "siemens"
    decimal_point: str = "calculator"
    reference_points_mm: tuple = (_ZERO, _ZERO, _ZERO, _ZERO)
    peck_retract_mm: float = 1.0
    peck_clearance_mm: float = 1.0
    from_file: bool = False

    @property
    def standard_notation(self) -> bool:
        return self.decimal_point == "standard"


def _length(v: float) -> str | None:
    return None if 0.0 <= v < 1000.0 else "must be a length in mm in [0, 1000)"


def iso_spec(c, data: dict) -> IsoSpec:
    """The ``[iso]`` table of a machine file (problems collected in ``c``, a config.Problems)."""
    table = c.table(data, "iso")
    if not table:
        return IsoSpec()
    c.unknown(table, "iso", _KEYS)
    values = {}
    for key, choices in (("dialect", DIALECTS), ("decimal_point", DECIMAL_POINT)):
        value = c.string(table, "iso", key)
        if value is not None:
            if value.lower() in choices:
                values[key] = value.lower()
            else:
                c.add(f"iso.{key}", f"must be one of {', '.join(choices)}, got {value!r}")
    for key in ("peck_retract_mm", "peck_clearance_mm"):
        value = c.number(table, "iso", key, check=_length)
        if value is not None:
            values[key] = value
    points = table.get("reference_points_mm")
    if points is not None:
        if not isinstance(points, list) or not 1 <= len(points) <= 4:
            c.add("iso.reference_points_mm", "must be a list of 1 to 4 [x, y, z] points")
        else:
            found = [c.xyz_mm({str(k + 1): p}, "iso.reference_points_mm", str(k + 1))
                     for k, p in enumerate(points)]
            if all(p is not None for p in found):
                values["reference_points_mm"] = tuple(found) + (_ZERO,) * (4 - len(found))
    return IsoSpec(**values, from_file=True)


def dump_iso(spec: IsoSpec) -> list[str]:
    """The ``[iso]`` table as TOML lines (none when the file had none)."""
    if not spec.from_file:
        return []
    points = ", ".join(f"[{x!r}, {y!r}, {z!r}]" for x, y, z in spec.reference_points_mm)
    return ["", "[iso]", f'dialect = "{spec.dialect}"  # MD20150 group 47 (G290/G291)',
            f'decimal_point = "{spec.decimal_point}"  # MD10884 $MN_EXTERN_FLOATINGPOINT_PROG',
            f"reference_points_mm = [{points}]  # G28, G30 P2..P4",
            f"peck_retract_mm = {spec.peck_retract_mm!r}  # G73 d",
            f"peck_clearance_mm = {spec.peck_clearance_mm!r}  # G83 d"]
