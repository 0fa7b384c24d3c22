"""Machine description: a TOML file loaded into a frozen, validated :class:`MachineSpec`.

TOML keys carry their units (``max_accel_m_s2``, ``ipo_cycle_ms``); the spec holds mm and s.
Every problem in a file (missing, unknown, mistyped or out-of-range key) is collected and
reported in one :class:`~ncsim.errors.MachineSpecError` naming the file and the key.
See ``machines/mikron.toml`` for the reference file and README "Machine file" for the schema.
"""
from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field, replace
from importlib import resources
from pathlib import Path as FsPath
from typing import Any, Callable

import numpy as np

from ncsim.errors import MachineSpecError
from ncsim.units import m_min_to_mm_s, m_s2_to_mm_s2, m_s3_to_mm_s3, mm_s2_to_m_s2, mm_s3_to_m_s3, mm_s_to_m_min, ms_to_s, s_to_ms

AXIS_NAMES = ("X", "Y", "Z")
WORK_OFFSET_NAMES = ("G54", "G55", "G56", "G57")


@dataclass(frozen=True, slots=True)
class AxisSpec:
    name: str
    max_velocity_mm_s: float   # MD32000 $MA_MAX_AX_VELO
    max_accel_mm_s2: float     # MD32300 $MA_MAX_AX_ACCEL
    max_jerk_mm_s3: float      # MD32431 $MA_MAX_AX_JERK
    position_gain_1_s: float | None = None  # MD32200 $MA_POSCTRL_GAIN (Kv), as 1/s


@dataclass(frozen=True, slots=True)
class NcuSpec:
    ipo_cycle_s: float                 # t_cy (paper §3.2, §5.3.2)
    curvilinear_jerk_mm_s3: float      # J_curv (paper §5.2.4)
    tangential_jerk_share: float       # r_jct (paper §5.2.4)
    central_jerk_share: float          # r_jcc (paper §5.2.4)
    transition_time_s: float           # delta t of eq. 13 (paper §5.3.2)
    lookahead_blocks: int              # dynamic look-ahead depth (blocks prepared ahead)
    normal_accel_share: float = 0.75   # share of axis acceleration the normal (centripetal) part may use
    corner_velocity_jump_factor: float = 1.0  # axis velocity jump allowed at a G64 corner, x accel x t_cy
    exact_stop_fine_settle_s: float = 0.0     # time to enter the G601 window after the set point stops
    exact_stop_coarse_settle_s: float = 0.0   # same for G602
    drive_speed_point_ratio: float = 1.0      # DRIVE: share of max velocity above which accel is reduced
    drive_accel_reduction_ratio: float = 0.0  # DRIVE: accel reduction at max velocity
    circle_error_const_mm: float = 0.01       # MD21000 $MC_CIRCLE_ERROR_CONST
    circle_error_factor: float = 0.001        # MD21010 $MC_CIRCLE_ERROR_FACTOR

    @property
    def tangential_jerk_mm_s3(self) -> float:
        """J_tcurv = J_curv * r_jct (paper eq. 10)."""
        return self.curvilinear_jerk_mm_s3 * self.tangential_jerk_share


@dataclass(frozen=True, slots=True)
class StructureSpec:
    radial_compliance_mm_per_mm_s2: float = 0.0  # outward radial deviation per unit normal acceleration


@dataclass(frozen=True, slots=True)
class MachineSpec:
    name: str
    axes: tuple[AxisSpec, ...]
    ncu: NcuSpec
    description: str = ""
    source: str = "<machine>"
    work_offsets_mm: tuple[tuple[str, tuple[float, float, float]], ...] = ()
    structure: StructureSpec = field(default_factory=StructureSpec)

    def axis(self, name: str) -> AxisSpec:
        for a in self.axes:
            if a.name == name:
                return a
        raise KeyError(name)

    @property
    def max_velocity_mm_s(self) -> np.ndarray:
        return _ro(np.array([a.max_velocity_mm_s for a in self.axes]))

    @property
    def max_accel_mm_s2(self) -> np.ndarray:
        return _ro(np.array([a.max_accel_mm_s2 for a in self.axes]))

    @property
    def max_jerk_mm_s3(self) -> np.ndarray:
        return _ro(np.array([a.max_jerk_mm_s3 for a in self.axes]))

    @property
    def position_gain_1_s(self) -> np.ndarray:
        """Kv per axis (NaN where the file gives none)."""
        return _ro(np.array([np.nan if a.position_gain_1_s is None else a.position_gain_1_s
                             for a in self.axes]))

    def work_offset_mm(self, name: str) -> np.ndarray | None:
        for key, value in self.work_offsets_mm:
            if key == name:
                return np.array(value)
        return None

    def with_ncu(self, **changes) -> "MachineSpec":
        return replace(self, ncu=replace(self.ncu, **changes))

    def with_axes(self, **changes_per_field) -> "MachineSpec":
        """Set a field on every axis, e.g. ``with_axes(max_jerk_mm_s3=[5000, 5000, 50000])``."""
        axes = list(self.axes)
        for fname, values in changes_per_field.items():
            vals = np.broadcast_to(np.asarray(values, dtype=float), (len(axes),))
            axes = [replace(a, **{fname: float(v)}) for a, v in zip(axes, vals)]
        return replace(self, axes=tuple(axes))


def _ro(a: np.ndarray) -> np.ndarray:
    a.setflags(write=False)
    return a


# ---------------------------------------------------------------------------------------------
# Loading and validation
# ---------------------------------------------------------------------------------------------

def _positive(v: float) -> str | None:
    return None if v > 0 and math.isfinite(v) else "must be a positive number"


def _non_negative(v: float) -> str | None:
    return None if v >= 0 and math.isfinite(v) else "must be zero or positive"


def _share(v: float) -> str | None:
    return None if 0.0 < v <= 1.0 else "must be in (0, 1]"


def _share0(v: float) -> str | None:
    return None if 0.0 <= v <= 1.0 else "must be in [0, 1]"


def _open_share(v: float) -> str | None:
    return None if 0.0 < v < 1.0 else "must be in (0, 1), exclusive"


# (toml key, spec field, required, check, converter to internal units)
_AXIS_KEYS: tuple[tuple[str, str, bool, Callable, Callable], ...] = (
    ("max_velocity_m_min", "max_velocity_mm_s", True, _positive, m_min_to_mm_s),
    ("max_accel_m_s2", "max_accel_mm_s2", True, _positive, m_s2_to_mm_s2),
    ("max_jerk_m_s3", "max_jerk_mm_s3", True, _positive, m_s3_to_mm_s3),
    ("position_gain_1_s", "position_gain_1_s", False, _positive, float),
)

_NCU_KEYS: tuple[tuple[str, str, bool, Callable, Callable], ...] = (
    ("ipo_cycle_ms", "ipo_cycle_s", True, _positive, ms_to_s),
    ("curvilinear_jerk_m_s3", "curvilinear_jerk_mm_s3", True, _positive, m_s3_to_mm_s3),
    ("tangential_jerk_share", "tangential_jerk_share", True, _share, float),
    ("central_jerk_share", "central_jerk_share", True, _share0, float),
    ("transition_time_ms", "transition_time_s", True, _positive, ms_to_s),
    ("lookahead_blocks", "lookahead_blocks", True, None, int),
    ("normal_accel_share", "normal_accel_share", False, _open_share, float),
    ("corner_velocity_jump_factor", "corner_velocity_jump_factor", False, _positive, float),
    ("exact_stop_fine_settle_ms", "exact_stop_fine_settle_s", False, _non_negative, ms_to_s),
    ("exact_stop_coarse_settle_ms", "exact_stop_coarse_settle_s", False, _non_negative, ms_to_s),
    ("drive_speed_point_ratio", "drive_speed_point_ratio", False, _share, float),
    ("drive_accel_reduction_ratio", "drive_accel_reduction_ratio", False, _share0, float),
    ("circle_error_const_mm", "circle_error_const_mm", False, _positive, float),
    ("circle_error_factor", "circle_error_factor", False, _non_negative, float),
)

_STRUCTURE_KEYS = (
    ("radial_compliance_um_per_m_s2", "radial_compliance_mm_per_mm_s2", False, _non_negative,
     lambda v: v * 1e-3 / 1e3),  # um per (m/s^2) -> mm per (mm/s^2)
)


class _Collector:
    def __init__(self, file: str):
        self.file = file
        self.problems: list[tuple[str, str]] = []

    def add(self, key: str, message: str) -> None:
        self.problems.append((key, message))

    def raise_if_any(self) -> None:
        if not self.problems:
            return
        key, message = self.problems[0]
        extra = ""
        if len(self.problems) > 1:
            others = "; ".join(f"{k}: {m}" for k, m in self.problems[1:])
            extra = f" (and {len(self.problems) - 1} more: {others})"
        raise MachineSpecError(message + extra, file=self.file, key=key)


def _number(c: _Collector, table: dict, prefix: str, key: str, required: bool, check, convert,
            integer: bool = False):
    full = f"{prefix}.{key}"
    if key not in table:
        if required:
            c.add(full, "missing key")
        return None
    v = table[key]
    if integer:
        if isinstance(v, bool) or not isinstance(v, int):
            c.add(full, f"must be an integer, got {type(v).__name__} {v!r}")
            return None
        if v < 1:
            c.add(full, "must be an integer >= 1")
            return None
        return v
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        c.add(full, f"must be a number, got {type(v).__name__} {v!r}")
        return None
    v = float(v)
    if check is not None:
        problem = check(v)
        if problem:
            c.add(full, f"{problem}, got {v:g}")
            return None
    return convert(v)


def _unknown(c: _Collector, table: dict, prefix: str, known) -> None:
    for key in table:
        if key not in known:
            c.add(f"{prefix}.{key}" if prefix else key, "unknown key")


def _table(c: _Collector, data: dict, key: str, required: bool) -> dict:
    if key not in data:
        if required:
            c.add(key, "missing table")
        return {}
    v = data[key]
    if not isinstance(v, dict):
        c.add(key, f"must be a table, got {type(v).__name__}")
        return {}
    return v


def machine_from_dict(data: dict[str, Any], file: str = "<machine>") -> MachineSpec:
    c = _Collector(file)
    _unknown(c, data, "", {"machine", "axes", "ncu", "work_offsets", "structure"})

    mtab = _table(c, data, "machine", True)
    _unknown(c, mtab, "machine", {"name", "description"})
    name = mtab.get("name")
    if "machine" in data and not isinstance(name, str):
        c.add("machine.name", "missing key" if name is None else "must be a string")
    description = mtab.get("description", "")
    if not isinstance(description, str):
        c.add("machine.description", "must be a string")

    atab = _table(c, data, "axes", True)
    axes = []
    _unknown(c, atab, "axes", set(AXIS_NAMES))
    for ax in AXIS_NAMES:
        prefix = f"axes.{ax}"
        if "axes" in data and ax not in atab:
            c.add(prefix, "missing table (ncsim simulates X, Y and Z)")
            continue
        t = atab.get(ax, {})
        if not isinstance(t, dict):
            c.add(prefix, "must be a table")
            continue
        _unknown(c, t, prefix, {k for k, *_ in _AXIS_KEYS})
        values = {f: _number(c, t, prefix, k, req, chk, conv) for k, f, req, chk, conv in _AXIS_KEYS}
        if all(values[f] is not None for _, f, req, *_ in _AXIS_KEYS if req):
            axes.append(AxisSpec(name=ax, **values))

    ntab = _table(c, data, "ncu", True)
    _unknown(c, ntab, "ncu", {k for k, *_ in _NCU_KEYS})
    ncu_values = {}
    for k, f, req, chk, conv in _NCU_KEYS:
        v = _number(c, ntab, "ncu", k, req and "ncu" in data, chk, conv,
                    integer=(k == "lookahead_blocks"))
        if v is not None:
            ncu_values[f] = v

    wtab = _table(c, data, "work_offsets", False)
    _unknown(c, wtab, "work_offsets", set(WORK_OFFSET_NAMES))
    offsets = []
    for key in WORK_OFFSET_NAMES:
        if key in wtab:
            v = wtab[key]
            if (not isinstance(v, list) or len(v) != 3
                    or not all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in v)):
                c.add(f"work_offsets.{key}", "must be a list of three numbers [x_mm, y_mm, z_mm]")
            else:
                offsets.append((key, tuple(float(x) for x in v)))

    stab = _table(c, data, "structure", False)
    _unknown(c, stab, "structure", {k for k, *_ in _STRUCTURE_KEYS})
    svalues = {}
    for k, f, req, chk, conv in _STRUCTURE_KEYS:
        v = _number(c, stab, "structure", k, req, chk, conv)
        if v is not None:
            svalues[f] = v

    c.raise_if_any()
    return MachineSpec(name=name, description=description, axes=tuple(axes),
                       ncu=NcuSpec(**ncu_values), source=file,
                       work_offsets_mm=tuple(offsets), structure=StructureSpec(**svalues))


def bundled_machines() -> dict[str, str]:
    """Name -> description of the machines shipped with ncsim."""
    out = {}
    for entry in sorted(resources.files("ncsim.machines").iterdir(), key=lambda p: p.name):
        if entry.name.endswith(".toml"):
            try:
                spec = machine_from_dict(tomllib.loads(entry.read_text()), entry.name)
                out[entry.name[:-5]] = spec.description or spec.name
            except (MachineSpecError, tomllib.TOMLDecodeError):
                out[entry.name[:-5]] = "(invalid)"
    return out


def load_machine(name_or_path: str | FsPath) -> MachineSpec:
    """Load a machine from a TOML path, or by the name of a bundled machine (``mikron``)."""
    p = FsPath(name_or_path)
    if p.suffix == ".toml" or p.exists():
        file = str(p)
        try:
            text = p.read_text(encoding="utf-8")
        except OSError as exc:
            raise MachineSpecError(f"cannot read machine file: {exc.strerror}", file=file) from None
    else:
        entry = resources.files("ncsim.machines") / f"{p.name}.toml"
        if not entry.is_file():
            names = ", ".join(bundled_machines()) or "none"
            raise MachineSpecError(f"no machine file and no bundled machine named {str(name_or_path)!r} "
                                   f"(bundled: {names})", file=str(name_or_path))
        file = f"{p.name}.toml (bundled)"
        text = entry.read_text(encoding="utf-8")
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise MachineSpecError(f"not valid TOML: {exc}", file=file) from None
    return machine_from_dict(data, file)


def dump_machine_toml(spec: MachineSpec, header: str = "") -> str:
    """The spec as a machine TOML file (round-trips through :func:`load_machine`)."""
    lines = []
    if header:
        lines += [f"# {h}" if h else "#" for h in header.splitlines()]
        lines.append("")
    lines += ["[machine]", f"name = {_q(spec.name)}"]
    if spec.description:
        lines.append(f"description = {_q(spec.description)}")
    for a in spec.axes:
        lines += ["", f"[axes.{a.name}]",
                  f"max_velocity_m_min = {_f(mm_s_to_m_min(a.max_velocity_mm_s))}  # MD32000 $MA_MAX_AX_VELO",
                  f"max_accel_m_s2 = {_f(mm_s2_to_m_s2(a.max_accel_mm_s2))}  # MD32300 $MA_MAX_AX_ACCEL",
                  f"max_jerk_m_s3 = {_f(mm_s3_to_m_s3(a.max_jerk_mm_s3))}  # MD32431 $MA_MAX_AX_JERK"]
        if a.position_gain_1_s is not None:
            lines.append(f"position_gain_1_s = {_f(a.position_gain_1_s)}  # MD32200 $MA_POSCTRL_GAIN (Kv) in 1/s")
    n = spec.ncu
    lines += ["", "[ncu]",
              f"ipo_cycle_ms = {_f(s_to_ms(n.ipo_cycle_s))}",
              f"curvilinear_jerk_m_s3 = {_f(mm_s3_to_m_s3(n.curvilinear_jerk_mm_s3))}",
              f"tangential_jerk_share = {_f(n.tangential_jerk_share)}",
              f"central_jerk_share = {_f(n.central_jerk_share)}",
              f"transition_time_ms = {_f(s_to_ms(n.transition_time_s))}",
              f"lookahead_blocks = {n.lookahead_blocks}",
              f"normal_accel_share = {_f(n.normal_accel_share)}",
              f"corner_velocity_jump_factor = {_f(n.corner_velocity_jump_factor)}",
              f"exact_stop_fine_settle_ms = {_f(s_to_ms(n.exact_stop_fine_settle_s))}",
              f"exact_stop_coarse_settle_ms = {_f(s_to_ms(n.exact_stop_coarse_settle_s))}",
              f"drive_speed_point_ratio = {_f(n.drive_speed_point_ratio)}",
              f"drive_accel_reduction_ratio = {_f(n.drive_accel_reduction_ratio)}",
              f"circle_error_const_mm = {_f(n.circle_error_const_mm)}",
              f"circle_error_factor = {_f(n.circle_error_factor)}"]
    if spec.work_offsets_mm:
        lines += ["", "[work_offsets]"]
        for key, (x, y, z) in spec.work_offsets_mm:
            lines.append(f"{key} = [{_f(x)}, {_f(y)}, {_f(z)}]")
    if spec.structure.radial_compliance_mm_per_mm_s2:
        lines += ["", "[structure]",
                  f"radial_compliance_um_per_m_s2 = {_f(spec.structure.radial_compliance_mm_per_mm_s2 * 1e6)}"]
    return "\n".join(lines) + "\n"


def _f(v: float) -> str:
    return repr(float(v))


def _q(s: str) -> str:
    return '"' + s.replace("\\", "\\\\").replace('"', '\\"') + '"'
