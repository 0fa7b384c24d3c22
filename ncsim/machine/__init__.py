"""Machine description: a TOML file loaded into a frozen, validated :class:`MachineSpec`.

TOML keys carry their units (``max_accel_m_s2``, ``ipo_cycle_ms``); the spec holds mm and s.
Keys for 840D machine and setting data are named after them (``max_accel_ovl_factor`` is
MD32310 ``$MA_MAX_ACCEL_OVL_FACTOR``); a key whose 840D default could not be confirmed in the
manuals has a documented default that a user should check against their machine.
Every problem in a file (missing, unknown, mistyped or out-of-range key) is collected and
reported in one :class:`~ncsim.errors.MachineSpecError` naming the file and the key.
See ``machines/mikron.toml`` for the reference file and README "Machine file" for the schema.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass, field, fields, replace
from importlib import resources
from pathlib import Path as FsPath
from typing import Any, Callable

import numpy as np

from ncsim.config import (MAX_TOML_BYTES, Problems, between, open_share, read_text, read_toml,
                          share, share0)
from ncsim.errors import ConfigWarning, MachineSpecError
# the plausibility checks and the [dynamics] table live in submodules; their public names are
# ncsim.machine's too
from ncsim.machine.checks import (MIN_DERIVED_ACCEL_M_S2, MIN_DERIVED_JERK_M_S3, derived_limits,
                                  unusual_values)
from ncsim.machine.dynamics import (ALL_GROUPS_KEY, TECHNOLOGY_GROUPS, GroupDynamics, dump_dynamics,
                                    group_limits, read_dynamics)
from ncsim.machine.iso import IsoSpec, dump_iso, iso_spec
from ncsim.path import BRISK, COMPCAD, COMPOF, COMPRESSOR_NAMES, DRIVE, SOFT
from ncsim.units import (deg_to_rad, m_min_to_mm_s, m_s2_to_mm_s2, m_s3_to_mm_s3, mm_min_to_mm_s,
                         mm_s2_to_m_s2, mm_s3_to_m_s3, mm_s_to_m_min, mm_s_to_mm_min, ms_to_s,
                         percent_to_share, rad_to_deg, s2_to_um_per_m_s2, s_to_ms, share_to_percent,
                         um_per_m_s2_to_s2)

AXIS_NAMES = ("X", "Y", "Z")
#: group-10 G functions a machine may reset to (MD20150 $MC_GCODE_RESET_VALUES)
PATH_MODES = {"G60": 60, "G64": 64, "G641": 641, "G642": 642, "G643": 643, "G644": 644,
              "G645": 645}
#: MD20552 $MC_EXACT_POS_MODE_G0_TO_G1: the stop window at a G0<->G1 change
G0_TO_G1_MODES = (0, 1, 2, 3)
#: operator-panel overrides a machine file may hold (what a recording was made with), percent
MAX_OVERRIDE_PERCENT = 200.0
WORK_OFFSET_NAMES = ("G54", "G55", "G56", "G57")
#: ``[machine] type`` -> its MD20150 reset values of G groups 6 and 29 unless ``[ncu]`` gives
#: them: a lathe G18 and DIAMON on its transverse axis X (MD20100), a milling machine G17 and
#: DIAMOF (Fundamentals, "Dimensions for turning and milling"; "Plane selection: G17 to G19")
MACHINE_TYPES = {"milling": {"reset_plane": 17, "reset_diameter_mode": 0},
                 "turning": {"reset_plane": 18, "reset_diameter_mode": 1}}
PLANES = {"G17": 17, "G18": 18, "G19": 19}
DIAMETER_MODES = {"DIAMOF": 0, "DIAMON": 1, "DIAM90": 2}
#: G group 21, the acceleration profile (840D B2 "Acceleration": BRISK, SOFT, DRIVE)
ACCEL_MODES = {"BRISK": BRISK, "SOFT": SOFT, "DRIVE": DRIVE}


@dataclass(frozen=True, slots=True)
class AxisSpec:
    name: str
    max_velocity_mm_s: float   # MD32000 $MA_MAX_AX_VELO
    max_accel_mm_s2: float     # MD32300 $MA_MAX_AX_ACCEL
    max_jerk_mm_s3: float      # MD32431 $MA_MAX_AX_JERK
    position_gain_1_s: float | None = None  # MD32200 $MA_POSCTRL_GAIN (Kv), as 1/s
    # MD32310 $MA_MAX_ACCEL_OVL_FACTOR: at a G64 corner the axis velocity may jump by
    # A (factor - 1) t_IPO (840D B1 "Continuous-path mode", overload factor); 1.2 is the value
    # usually delivered (not confirmed in the manuals found)
    max_accel_ovl_factor: float = 1.2
    # MD33100 $MA_COMPRESS_POS_TOL: axis tolerance of the compressor and of G642 rounding;
    # 0.01 mm is the value B1 (08/2005, section 2.5) calls suitable for most applications
    compress_pos_tol_mm: float = 0.01
    # MD33120 $MA_PATH_TRANS_POS_TOL: G645 tolerance at tangential transitions with a curvature
    # jump (840D B1 "G645"); default not confirmed
    path_trans_pos_tol_mm: float = 0.005


@dataclass(frozen=True, slots=True)
class NcuSpec:
    ipo_cycle_s: float                 # t_cy (paper §3.2, §5.3.2)
    curvilinear_jerk_mm_s3: float      # J_curv (paper §5.2.4)
    tangential_jerk_share: float       # r_jct (paper §5.2.4)
    central_jerk_share: float          # r_jcc (paper §5.2.4)
    transition_time_s: float           # delta t of eq. 13 (paper §5.3.2)
    lookahead_blocks: int              # dynamic look-ahead depth (blocks prepared ahead)
    normal_accel_share: float = 0.75   # share of axis acceleration the normal (centripetal) part may use
    exact_stop_fine_settle_s: float = 0.0     # time to enter the G601 window after the set point stops
    exact_stop_coarse_settle_s: float = 0.0   # same for G602
    drive_speed_point_ratio: float = 1.0      # DRIVE: share of max velocity above which accel is reduced
    drive_accel_reduction_ratio: float = 0.0  # DRIVE: accel reduction at max velocity
    circle_error_const_mm: float = 0.01       # MD21000 $MC_CIRCLE_ERROR_CONST
    circle_error_factor: float = 0.001        # MD21010 $MC_CIRCLE_ERROR_FACTOR
    smooth_contur_tol_mm: float = 0.05        # SD42465 $SC_SMOOTH_CONTUR_TOL (default not confirmed)
    smoothing_mode: int = 0                   # MD20480 $MC_SMOOTHING_MODE (tens digit simulated)
    ignore_ovl_factor_for_adis: bool = False  # MD20490 $MC_IGNORE_OVL_FACTOR_FOR_ADIS
    compress_block_path_limit_mm: float = 20.0  # MD20170 $MC_COMPRESS_BLOCK_PATH_LIMIT (B1's recommendation)
    crit_spline_angle_rad: float = deg_to_rad(36.0)  # SD42470 $SC_CRIT_SPLINE_ANGLE (B1 recommends 36 deg)
    reset_path_mode: int = 60                 # MD20150 $MC_GCODE_RESET_VALUES, group 10 (60, 64, 641..645)
    reset_compressor: int = COMPOF            # MD20150 $MC_GCODE_RESET_VALUES, group 30 (COMPOF..COMPSURF)
    reset_accel_mode: int = BRISK             # MD20150 $MC_GCODE_RESET_VALUES, group 21 (BRISK as delivered)
    exact_pos_mode_g0_to_g1: int = 0          # MD20552: stop window at G0<->G1 changes (0 none, 1 G601, 2 G602, 3 G603)
    rapid_override: float = 1.0               # rapid-traverse override in force (share of the G0 velocity)
    feed_override: float = 1.0                # path-feed override in force (share of the programmed F)
    # SD42110 $SC_DEFAULT_FEED: the path feed before any F (0 as delivered: a G1/G2/G3 before
    # any F is then alarm 10860 "no feed programmed"); see InterpreterState
    default_feed_mm_s: float = 0.0
    reset_plane: int = 17                     # MD20150 $MC_GCODE_RESET_VALUES, group 6 (17, 18, 19)
    reset_diameter_mode: int = 0              # MD20150, group 29: 0 DIAMOF, 1 DIAMON, 2 DIAM90
    diameter_axis: int = 0                    # MD20100 $MC_DIAMETER_AX_DEF: the transverse axis (X)

    @property
    def g642_contour_tolerance(self) -> bool:
        """MD20480 tens digit 1: G642 rounds the geometry axes within the contour tolerance
        SD42465, else (0) within the axis tolerances MD33100 (840D B1, G642)."""
        return (self.smoothing_mode // 10) % 10 == 1

    @property
    def tangential_jerk_mm_s3(self) -> float:
        """J_tcurv = J_curv * r_jct (paper eq. 10)."""
        return self.curvilinear_jerk_mm_s3 * self.tangential_jerk_share


#: CYCLE832 machining types (SINUMERIK NC programming manual, "High speed settings - CYCLE832":
#: S_TOLM units digit 0 deselection, 1 finishing, 2 rough-finishing, 3 roughing, 4 smooth finishing)
CYCLE832_TYPES = ("off", "finish", "semifinish", "rough", "precision")
#: group-10 path modes a CYCLE832 expansion may select
PATH_MODE_CODES = {"G60": 60, "G64": 64, "G641": 641, "G642": 642, "G643": 643, "G644": 644,
                   "G645": 645}
COMPRESSOR_CODES = {name: code for code, name in COMPRESSOR_NAMES.items()}
ACCEL_MODE_CODES = {"SOFT": SOFT, "BRISK": BRISK, "DRIVE": DRIVE}
RESET = "reset"   # an expansion value meaning: back to the reset value (MD20150)


@dataclass(frozen=True, slots=True)
class Cycle832Expansion:
    """What CYCLE832 switches for one machining type (its CUST_832 G codes). ``None`` means the
    reset value of the group (MD20150 $MC_GCODE_RESET_VALUES)."""

    path_mode: int | None = 642          # G642 (group 10)
    compressor: int = COMPCAD            # COMPCAD (group 30)
    accel_mode: int | None = SOFT        # SOFT (group 21)
    feed_forward: bool | None = True     # FFWON (group 24)


_SELECT = Cycle832Expansion()
_DESELECT = Cycle832Expansion(path_mode=None, compressor=COMPOF, accel_mode=None, feed_forward=None)


@dataclass(frozen=True, slots=True)
class Cycle832Spec:
    """The ``[cycle832]`` table: the expansion per machining type. The defaults are the usual
    CUST_832 settings -- G642, COMPCAD, SOFT and FFWON for every machining type, deselection
    back to the reset values and COMPOF -- which the manuals found do not state as a table
    (CUST_832 is the machine builder's): ``from_file`` says whether the machine file gave it."""

    off: Cycle832Expansion = _DESELECT
    finish: Cycle832Expansion = _SELECT
    semifinish: Cycle832Expansion = _SELECT
    rough: Cycle832Expansion = _SELECT
    precision: Cycle832Expansion = _SELECT
    from_file: bool = False

    def expansion(self, machining_type: int) -> Cycle832Expansion:
        """The expansion of S_TOLM units digit 0..4."""
        return getattr(self, CYCLE832_TYPES[machining_type])


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
    #: values accepted but unusual (likely in the wrong unit), from the file's reader
    warnings: tuple[ConfigWarning, ...] = field(default=(), compare=False)
    cycle832: Cycle832Spec = field(default_factory=Cycle832Spec)
    #: values of system variables programs read (``"$AN_NCK_VERSION"``, ``"$MA_X[Z]"``)
    system_variables: tuple[tuple[str, float | str], ...] = ()
    #: how ISO dialect programs run (``[iso]``, :mod:`ncsim.machine.iso`)
    iso: IsoSpec = field(default_factory=IsoSpec)
    #: ``[machine] type``: "milling" or "turning" (a lathe: G18 and DIAMON at reset, MACHINE_TYPES)
    kind: str = "milling"
    #: ``[dynamics]``: per technology group (TECHNOLOGY_GROUPS) axis limits
    dynamics: GroupDynamics | None = field(default=None, compare=False)
    tool_change_s: float = 0.0   # an M6 tool change, chip to chip ([tool_change] time_s; 0: none)

    def defines_group(self, group: int) -> bool:
        """Whether the file says how technology group ``group`` (G group 59) runs."""
        return group == 0 or (self.dynamics is not None and self.dynamics.defines(group))

    def group_limits(self) -> np.ndarray:
        """(group, [velocity, accel, jerk], axis) in mm and s (``[dynamics]``, below)."""
        return group_limits(self.axes, self.dynamics)

    def for_group(self, group: int) -> "MachineSpec":
        """This machine with the axis limits of technology group ``group`` in ``[axes]``."""
        if group == 0 or self.dynamics is None or not self.dynamics.given[group]:
            return self
        v, a, j = self.group_limits()[group]
        return self.with_axes(max_velocity_mm_s=v, max_accel_mm_s2=a, max_jerk_mm_s3=j)

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

    @property
    def max_accel_ovl_factor(self) -> np.ndarray:
        """MD32310 per axis."""
        return _ro(np.array([a.max_accel_ovl_factor for a in self.axes]))

    @property
    def compress_pos_tol_mm(self) -> np.ndarray:
        """MD33100 per axis."""
        return _ro(np.array([a.compress_pos_tol_mm for a in self.axes]))

    @property
    def path_trans_pos_tol_mm(self) -> np.ndarray:
        """MD33120 per axis."""
        return _ro(np.array([a.path_trans_pos_tol_mm for a in self.axes]))

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
# Loading and validation (through ncsim.config: one reader, one error policy)
# ---------------------------------------------------------------------------------------------

def overload_factor(v: float) -> str | None:
    """MD32310: 1.0 (only tangential transitions at speed) or more."""
    return None if 1.0 <= v <= 1000.0 else ("must be >= 1 (MD32310 overload factor; 1 stops at "
                                             "every corner) and at most 1000")


# (toml key, spec field, required, check, converter to internal units). The ranges are what
# is physically possible, with a wide margin around every real machine; inside them no
# arithmetic of the planner overflows or divides by (almost) zero. What is possible but
# unusual (often a value in the wrong unit) is a warning: see ``checks._USUAL``.
#: the least acceleration and jerk of an axis (the lower ends of their ranges)
MIN_ACCEL_M_S2 = 1e-3
MIN_JERK_M_S3 = 1e-3


_AXIS_KEYS: tuple[tuple[str, str, bool, Callable, Callable], ...] = (
    ("max_velocity_m_min", "max_velocity_mm_s", True, between(1e-3, 1e6, "m/min"), m_min_to_mm_s),
    ("max_accel_m_s2", "max_accel_mm_s2", True, between(MIN_ACCEL_M_S2, 1e6, "m/s^2"),
     m_s2_to_mm_s2),
    ("max_jerk_m_s3", "max_jerk_mm_s3", True, between(MIN_JERK_M_S3, 1e9, "m/s^3"),
     m_s3_to_mm_s3),
    ("position_gain_1_s", "position_gain_1_s", False, between(1e-2, 1e4, "1/s"), float),
    ("max_accel_ovl_factor", "max_accel_ovl_factor", False, overload_factor, float),
    ("compress_pos_tol_mm", "compress_pos_tol_mm", False, between(1e-6, 100.0, "mm"), float),
    ("path_trans_pos_tol_mm", "path_trans_pos_tol_mm", False, between(1e-6, 100.0, "mm"), float),
)

MAX_LOOKAHEAD_BLOCKS = 100_000   # MD28060 $MC_MM_IPO_BUFFER_SIZE is in the hundreds

_NCU_KEYS: tuple[tuple[str, str, bool, Callable, Callable], ...] = (
    ("ipo_cycle_ms", "ipo_cycle_s", True, between(1e-3, 1e5, "ms"), ms_to_s),
    ("curvilinear_jerk_m_s3", "curvilinear_jerk_mm_s3", True, between(1e-3, 1e9, "m/s^3"),
     m_s3_to_mm_s3),
    ("tangential_jerk_share", "tangential_jerk_share", True, share, float),
    ("central_jerk_share", "central_jerk_share", True, share0, float),
    ("transition_time_ms", "transition_time_s", True, between(1e-3, 1e5, "ms"), ms_to_s),
    ("lookahead_blocks", "lookahead_blocks", True, None, int),   # 1..MAX_LOOKAHEAD_BLOCKS
    ("normal_accel_share", "normal_accel_share", False, open_share, float),
    ("exact_stop_fine_settle_ms", "exact_stop_fine_settle_s", False, between(0.0, 1e5, "ms"),
     ms_to_s),
    ("exact_stop_coarse_settle_ms", "exact_stop_coarse_settle_s", False,
     between(0.0, 1e5, "ms"), ms_to_s),
    ("drive_speed_point_ratio", "drive_speed_point_ratio", False, share, float),
    ("drive_accel_reduction_ratio", "drive_accel_reduction_ratio", False, share0, float),
    ("circle_error_const_mm", "circle_error_const_mm", False, between(1e-9, 1000.0, "mm"), float),
    ("circle_error_factor", "circle_error_factor", False, share0, float),
    ("smooth_contur_tol_mm", "smooth_contur_tol_mm", False, between(1e-6, 100.0, "mm"), float),
    ("compress_block_path_limit_mm", "compress_block_path_limit_mm", False,
     between(1e-6, 1e9, "mm"), float),
    ("crit_spline_angle_deg", "crit_spline_angle_rad", False, between(0.0, 180.0, "degrees"),
     deg_to_rad),
    ("rapid_override_percent", "rapid_override", False,
     between(1e-3, MAX_OVERRIDE_PERCENT, "%"), percent_to_share),
    ("feed_override_percent", "feed_override", False,
     between(1e-3, MAX_OVERRIDE_PERCENT, "%"), percent_to_share),
    ("default_feed_mm_min", "default_feed_mm_s", False, between(0.0, 1e9, "mm/min"),
     mm_min_to_mm_s),
)
#: [ncu] keys that are not plain numbers (read in machine_from_dict)
_NCU_OTHER_KEYS = ("smoothing_mode", "ignore_ovl_factor_for_adis", "reset_path_mode",
                   "exact_pos_mode_g0_to_g1", "reset_compressor", "reset_plane",
                   "reset_diameter_mode", "diameter_axis", "reset_accel_mode")
#: the key of earlier versions that MD32310 replaced: the G64 velocity jump was
#: ``corner_velocity_jump_factor`` x A t_IPO, it is A (max_accel_ovl_factor - 1) t_IPO per axis
_OLD_CORNER_KEY = "corner_velocity_jump_factor"
_CYCLE832_KEYS = ("path_mode", "compressor", "accel_mode", "feed_forward")

_STRUCTURE_KEYS = (
    ("radial_compliance_um_per_m_s2", "radial_compliance_mm_per_mm_s2", False,
     between(0.0, 1e4, "um/(m/s^2)"), um_per_m_s2_to_s2),
)
#: ``[tool_change]``: the machine builder's tool-change time (no 840D machine data holds it)
_TOOL_CHANGE_KEYS = (("time_s", "tool_change_s", False, between(0.0, 1e4, "s"), float),)

def _read_old_corner_key(data: dict[str, Any], c: Problems) -> dict[str, Any]:
    """``[ncu] corner_velocity_jump_factor = k`` of earlier versions, read as
    ``max_accel_ovl_factor = 1 + k`` on every axis that does not set it (MD32310: the same G64
    jump), with a warning; an error next to axis values (which one holds?)."""
    ncu, axes = data.get("ncu"), data.get("axes")
    if not isinstance(ncu, dict) or _OLD_CORNER_KEY not in ncu:
        return data
    key, old = f"ncu.{_OLD_CORNER_KEY}", ncu[_OLD_CORNER_KEY]
    axes = axes if isinstance(axes, dict) else {}
    given = [a for a, t in axes.items() if isinstance(t, dict) and "max_accel_ovl_factor" in t]
    if given or isinstance(old, bool) or not isinstance(old, (int, float)) or not old >= 0:
        c.add(key, "replaced by max_accel_ovl_factor in [axes.X], [axes.Y], [axes.Z] (MD32310: "
                   "the G64 velocity jump is A (factor - 1) t_IPO, so the new value is 1 + the "
                   "old one)" + (f"; axes {', '.join(given)} already set it" if given else ""))
        return data
    c.warn(key, f"a key of earlier versions: read as max_accel_ovl_factor = {1 + old:g} on every "
                f"axis (MD32310: the G64 velocity jump is A (factor - 1) t_IPO); write that "
                f"instead")
    ncu = {k: v for k, v in ncu.items() if k != _OLD_CORNER_KEY}
    axes = {a: ({**t, "max_accel_ovl_factor": 1.0 + old} if isinstance(t, dict) else t)
            for a, t in axes.items()}
    return {**data, "ncu": ncu, "axes": axes}


_NCU_DEFAULTS = {f.name: f.default for f in fields(NcuSpec)}


def machine_from_dict(data: dict[str, Any], file: str = "<machine>") -> MachineSpec:
    """Validate a parsed machine file; every problem is collected into one
    :class:`~ncsim.errors.MachineSpecError`."""
    c = Problems(file, MachineSpecError)
    c.unknown(data, "", {"machine", "axes", "ncu", "work_offsets", "structure", "cycle832",
                         "system_variables", "dynamics", "iso", "tool_change"})
    data = _read_old_corner_key(data, c)

    mtab = c.table(data, "machine", required=True)
    c.unknown(mtab, "machine", {"name", "description", "type"})
    name = c.string(mtab, "machine", "name", required="machine" in data)
    description = c.string(mtab, "machine", "description") or ""
    kind = (c.string(mtab, "machine", "type") or "milling").lower()
    if kind not in MACHINE_TYPES:
        c.add("machine.type", f"must be one of {', '.join(MACHINE_TYPES)}, got {kind!r}")
        kind = "milling"

    atab = c.table(data, "axes", required=True)
    axes = []
    c.unknown(atab, "axes", set(AXIS_NAMES))
    for ax in AXIS_NAMES:
        prefix = f"axes.{ax}"
        if "axes" in data and ax not in atab:
            c.add(prefix, "missing table (ncsim simulates X, Y and Z)")
            continue
        t = atab.get(ax, {})
        if not isinstance(t, dict):
            c.add(prefix, "must be a table")
            continue
        c.unknown(t, prefix, {k for k, *_ in _AXIS_KEYS})
        values = {f: c.number(t, prefix, k, required=req, check=chk, convert=conv)
                  for k, f, req, chk, conv in _AXIS_KEYS}
        values = {f: v for f, v in values.items() if v is not None or f == "position_gain_1_s"}
        if all(values.get(f) is not None for _, f, req, *_ in _AXIS_KEYS if req):
            axes.append(AxisSpec(name=ax, **values))

    ntab = c.table(data, "ncu", required=True)
    c.unknown(ntab, "ncu", {k for k, *_ in _NCU_KEYS} | set(_NCU_OTHER_KEYS)
              | {_OLD_CORNER_KEY})
    ncu_values = {}
    for k, f, req, chk, conv in _NCU_KEYS:
        if conv is int:
            v = c.integer(ntab, "ncu", k, required=req and "ncu" in data,
                          maximum=MAX_LOOKAHEAD_BLOCKS)
        else:
            v = c.number(ntab, "ncu", k, required=req and "ncu" in data, check=chk, convert=conv)
        if v is not None:
            ncu_values[f] = v
    mode = c.integer(ntab, "ncu", "smoothing_mode", minimum=0)
    if mode is not None:
        if mode in (0, 10):
            ncu_values["smoothing_mode"] = mode
        else:
            c.add("ncu.smoothing_mode", "MD20480: ncsim simulates the tens digit (0: G642 within the "
                  "axis tolerances MD33100, 10: within the contour tolerance SD42465); give 0 or 10")
    ignore = c.boolean(ntab, "ncu", "ignore_ovl_factor_for_adis")
    if ignore is not None:
        ncu_values["ignore_ovl_factor_for_adis"] = ignore
    reset = c.string(ntab, "ncu", "reset_path_mode")
    if reset is not None:
        if reset.upper() in PATH_MODES:
            ncu_values["reset_path_mode"] = PATH_MODES[reset.upper()]
        else:
            c.add("ncu.reset_path_mode", f"must be one of {', '.join(PATH_MODES)}, got {reset!r}")
    comp = c.string(ntab, "ncu", "reset_compressor")
    if comp is not None:
        if comp.upper() in COMPRESSOR_CODES:
            ncu_values["reset_compressor"] = COMPRESSOR_CODES[comp.upper()]
        else:
            c.add("ncu.reset_compressor", f"must be one of {', '.join(COMPRESSOR_CODES)}, got {comp!r}")
    ncu_values.update(MACHINE_TYPES[kind])
    for key, choices in (("reset_plane", PLANES), ("reset_diameter_mode", DIAMETER_MODES),
                         ("reset_accel_mode", ACCEL_MODES),
                         ("diameter_axis", {a: i for i, a in enumerate(AXIS_NAMES)})):
        text = c.string(ntab, "ncu", key)
        if text is not None:
            if text.upper() in choices:
                ncu_values[key] = choices[text.upper()]
            else:
                c.add(f"ncu.{key}", f"must be one of {', '.join(choices)}, got {text!r}")
    g0g1 = c.integer(ntab, "ncu", "exact_pos_mode_g0_to_g1", minimum=0, maximum=3)
    if g0g1 is not None:
        ncu_values["exact_pos_mode_g0_to_g1"] = g0g1
    cycle832 = _cycle832_spec(c, data)

    wtab = c.table(data, "work_offsets")
    c.unknown(wtab, "work_offsets", set(WORK_OFFSET_NAMES))
    offsets = []
    for key in WORK_OFFSET_NAMES:
        if key in wtab:
            v = c.xyz_mm(wtab, "work_offsets", key)
            if v is not None:
                offsets.append((key, v))

    svalues = c.numbers(data, "structure", _STRUCTURE_KEYS)

    sysvars = _system_variables(c, c.table(data, "system_variables"))
    iso = iso_spec(c, data)
    dynamics = read_dynamics(c, c.table(data, "dynamics"), axes)
    if len(axes) == len(AXIS_NAMES) and not c:
        least_accel_mm_s2 = float(group_limits(axes, dynamics)[:, 1, :].min())
        derived_limits(c, least_accel_mm_s2, ncu_values, _NCU_DEFAULTS)
    tool_change = c.numbers(data, "tool_change", _TOOL_CHANGE_KEYS)
    c.raise_if_any()
    unusual_values(c, {f"axes.{a}": atab[a] for a in AXIS_NAMES} | {"ncu": ntab})
    return MachineSpec(name=name, description=description, axes=tuple(axes),
                       ncu=NcuSpec(**ncu_values), source=file,
                       work_offsets_mm=tuple(offsets), structure=StructureSpec(**svalues),
                       warnings=tuple(c.warnings), cycle832=cycle832,
                       system_variables=sysvars, kind=kind, dynamics=dynamics, iso=iso,
                       **tool_change)


_SYSVAR_KEY = re.compile(r"^\$[A-Z_][A-Z0-9_]*(\[[A-Z0-9_]+(,[A-Z0-9_]+)*\])?$")


def _system_variables(c: Problems, table: dict) -> tuple:
    """``[system_variables]``: ``"$NAME" = value`` or ``"$NAME[I,J]" = value`` (a number or a
    string), the values programs read (README "Machine file")."""
    out = []
    for key, value in table.items():
        name = key.replace(" ", "").upper()
        where = f'system_variables."{key}"'
        if not _SYSVAR_KEY.match(name):
            c.add(where, "expected a system variable name such as \"$MN_SCALING_VALUE_INCH\" or "
                         "\"$MA_PARAMSET_CHANGE_ENABLE[Z]\"")
        elif isinstance(value, bool) or not isinstance(value, (int, float, str)) or \
                (isinstance(value, float) and not math.isfinite(value)):
            c.add(where, "must be a finite number or a string")
        else:
            out.append((name, value if isinstance(value, str) else float(value)))
    return tuple(out)


def _cycle832_spec(c: Problems, data: dict) -> Cycle832Spec:
    """The ``[cycle832.<type>]`` tables: ``path_mode`` (G60, G64, G641..G645 or "reset"),
    ``compressor`` (COMPOF, COMPON, COMPCURV, COMPCAD, COMPSURF), ``accel_mode`` (SOFT, BRISK,
    DRIVE or "reset"), ``feed_forward`` (FFWON, FFWOF or "reset")."""
    table = c.table(data, "cycle832")
    if "cycle832" not in data:
        return Cycle832Spec()
    c.unknown(table, "cycle832", set(CYCLE832_TYPES))
    types = {}
    choices = (("path_mode", {**PATH_MODE_CODES, RESET.upper(): None}),
               ("compressor", COMPRESSOR_CODES),
               ("accel_mode", {**ACCEL_MODE_CODES, RESET.upper(): None}),
               ("feed_forward", {"FFWON": True, "FFWOF": False, RESET.upper(): None}))
    for name in CYCLE832_TYPES:
        prefix = f"cycle832.{name}"
        t = c.table(table, name, prefix="cycle832")
        c.unknown(t, prefix, set(_CYCLE832_KEYS))
        default = getattr(Cycle832Spec(), name)
        values = {}
        for key, allowed in choices:
            text = c.string(t, prefix, key)
            if text is None:
                continue
            if text.upper() not in allowed:
                c.add(f"{prefix}.{key}", f"must be one of {', '.join(k for k in allowed)}, got {text!r}")
                continue
            values[key] = allowed[text.upper()]
        types[name] = replace(default, **values)
    return Cycle832Spec(**types, from_file=True)


def bundled_machines() -> dict[str, str]:
    """Name -> description of the machines shipped with ncsim."""
    out = {}
    for entry in sorted(resources.files("ncsim.machines").iterdir(), key=lambda p: p.name):
        if entry.name.endswith(".toml"):
            try:
                data = read_toml(entry, "machine file", name=entry.name, error=MachineSpecError)
                spec = machine_from_dict(data, entry.name)
                out[entry.name[:-5]] = spec.description or spec.name
            except MachineSpecError:
                out[entry.name[:-5]] = "(invalid)"
    return out


def machine_file(name_or_path: str | FsPath):
    """Where a machine is read from: ``(source, name)``, a TOML path or the file of a bundled
    machine (``mikron``), and its name in messages."""
    p = FsPath(name_or_path)
    if p.suffix == ".toml" or p.exists():
        return p, str(p)
    source = resources.files("ncsim.machines") / f"{p.name}.toml"
    if not source.is_file():
        names = ", ".join(bundled_machines()) or "none"
        raise MachineSpecError(f"no machine file and no bundled machine named {str(name_or_path)!r} "
                               f"(bundled: {names})", file=str(name_or_path))
    return source, f"{p.name}.toml (bundled)"


def load_machine(name_or_path: str | FsPath) -> MachineSpec:
    """Load a machine from a TOML path, or by the name of a bundled machine (``mikron``)."""
    source, file = machine_file(name_or_path)
    return machine_from_dict(read_toml(source, "machine file", name=file, error=MachineSpecError), file)


def machine_file_text(name_or_path: str | FsPath) -> str:
    """The text of the file :func:`load_machine` reads for ``name_or_path`` (what a calibrated
    file is edited from, ``ncsim.gap.calibration``)."""
    source, file = machine_file(name_or_path)
    return read_text(source, "machine file", name=file, error=MachineSpecError,
                     max_bytes=MAX_TOML_BYTES)


def dump_machine_toml(spec: MachineSpec, header: str = "") -> str:
    """The spec as a machine TOML file (round-trips through :func:`load_machine`)."""
    lines = []
    if header:
        lines += [f"# {h}" if h else "#" for h in header.splitlines()]
        lines.append("")
    lines += ["[machine]", f"name = {_q(spec.name)}", f"type = {_q(spec.kind)}"]
    if spec.description:
        lines.append(f"description = {_q(spec.description)}")
    for a in spec.axes:
        lines += ["", f"[axes.{a.name}]",
                  f"max_velocity_m_min = {_f(mm_s_to_m_min(a.max_velocity_mm_s))}  # MD32000 $MA_MAX_AX_VELO",
                  f"max_accel_m_s2 = {_f(mm_s2_to_m_s2(a.max_accel_mm_s2))}  # MD32300 $MA_MAX_AX_ACCEL",
                  f"max_jerk_m_s3 = {_f(mm_s3_to_m_s3(a.max_jerk_mm_s3))}  # MD32431 $MA_MAX_AX_JERK",
                  f"max_accel_ovl_factor = {_f(a.max_accel_ovl_factor)}  # MD32310 $MA_MAX_ACCEL_OVL_FACTOR",
                  f"compress_pos_tol_mm = {_f(a.compress_pos_tol_mm)}  # MD33100 $MA_COMPRESS_POS_TOL",
                  f"path_trans_pos_tol_mm = {_f(a.path_trans_pos_tol_mm)}  # MD33120 $MA_PATH_TRANS_POS_TOL"]
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
              f"exact_stop_fine_settle_ms = {_f(s_to_ms(n.exact_stop_fine_settle_s))}",
              f"exact_stop_coarse_settle_ms = {_f(s_to_ms(n.exact_stop_coarse_settle_s))}",
              f"drive_speed_point_ratio = {_f(n.drive_speed_point_ratio)}",
              f"drive_accel_reduction_ratio = {_f(n.drive_accel_reduction_ratio)}",
              f"circle_error_const_mm = {_f(n.circle_error_const_mm)}",
              f"circle_error_factor = {_f(n.circle_error_factor)}",
              f"smooth_contur_tol_mm = {_f(n.smooth_contur_tol_mm)}  # SD42465 $SC_SMOOTH_CONTUR_TOL",
              f"smoothing_mode = {n.smoothing_mode}  # MD20480 $MC_SMOOTHING_MODE",
              f"ignore_ovl_factor_for_adis = {'true' if n.ignore_ovl_factor_for_adis else 'false'}"
              f"  # MD20490 $MC_IGNORE_OVL_FACTOR_FOR_ADIS",
              f"compress_block_path_limit_mm = {_f(n.compress_block_path_limit_mm)}  # MD20170",
              f"crit_spline_angle_deg = {_f(rad_to_deg(n.crit_spline_angle_rad))}  # SD42470",
              f"reset_path_mode = {_q(path_mode_name(n.reset_path_mode))}  # MD20150 $MC_GCODE_RESET_VALUES (group 10)",
              f"reset_compressor = {_q(COMPRESSOR_NAMES[n.reset_compressor])}  # MD20150 $MC_GCODE_RESET_VALUES (group 30)",
              f"reset_accel_mode = {_q(_name_of(ACCEL_MODES, n.reset_accel_mode))}  # MD20150 $MC_GCODE_RESET_VALUES (group 21)",
              f"exact_pos_mode_g0_to_g1 = {n.exact_pos_mode_g0_to_g1}  # MD20552 $MC_EXACT_POS_MODE_G0_TO_G1",
              f"rapid_override_percent = {_f(share_to_percent(n.rapid_override))}  # rapid-traverse override in force",
              f"feed_override_percent = {_f(share_to_percent(n.feed_override))}  # feed override in force",
              f"default_feed_mm_min = {_f(mm_s_to_mm_min(n.default_feed_mm_s))}  # SD42110 $SC_DEFAULT_FEED",
              f"reset_plane = \"G{n.reset_plane}\"  # MD20150 (group 6)",
              f"reset_diameter_mode = {_q(_name_of(DIAMETER_MODES, n.reset_diameter_mode))}  # MD20150 (group 29)",
              f"diameter_axis = {_q(AXIS_NAMES[n.diameter_axis])}  # MD20100 $MC_DIAMETER_AX_DEF"]
    lines += dump_dynamics(spec.dynamics)
    if spec.work_offsets_mm:
        lines += ["", "[work_offsets]"]
        for key, (x, y, z) in spec.work_offsets_mm:
            lines.append(f"{key} = [{_f(x)}, {_f(y)}, {_f(z)}]")
    if spec.cycle832.from_file:
        names = {"path_mode": lambda v: RESET if v is None else f"G{v}",
                 "compressor": lambda v: COMPRESSOR_NAMES[v],
                 "accel_mode": lambda v: RESET if v is None else {SOFT: "SOFT", BRISK: "BRISK",
                                                                   DRIVE: "DRIVE"}[v],
                 "feed_forward": lambda v: RESET if v is None else ("FFWON" if v else "FFWOF")}
        for t in CYCLE832_TYPES:
            e = spec.cycle832.expansion(CYCLE832_TYPES.index(t))
            lines += ["", f"[cycle832.{t}]"]
            lines += [f"{k} = {_q(fmt(getattr(e, k)))}" for k, fmt in names.items()]
    lines += dump_iso(spec.iso)
    if spec.system_variables:
        lines += ["", "[system_variables]"]
        for key, value in spec.system_variables:
            lines.append(f"{_q(key)} = {_q(value) if isinstance(value, str) else _f(value)}")
    if spec.tool_change_s:
        lines += ["", "[tool_change]", f"time_s = {_f(spec.tool_change_s)}  # M6, chip to chip"]
    if spec.structure.radial_compliance_mm_per_mm_s2:
        lines += ["", "[structure]",
                  f"radial_compliance_um_per_m_s2 = {_f(s2_to_um_per_m_s2(spec.structure.radial_compliance_mm_per_mm_s2))}"]
    return "\n".join(lines) + "\n"


def path_mode_name(code: int) -> str:
    """``60`` -> ``"G60"`` (a group-10 code as the program writes it)."""
    return f"G{int(code)}"


def accel_mode_name(code: int) -> str:
    """``SOFT`` (a group-21 code, :data:`ACCEL_MODES`, by its name)."""
    return _name_of(ACCEL_MODES, code)


def _name_of(choices: dict, code: int) -> str:
    return next(k for k, v in choices.items() if v == code)


def _f(v: float) -> str:
    return repr(float(v))


def _q(s: str) -> str:
    return '"' + s.replace("\\", "\\\\").replace('"', '\\"') + '"'
