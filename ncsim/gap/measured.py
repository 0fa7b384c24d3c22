"""Measured data: oscilloscope-like traces (CSV), the input side of the sim-to-real gap
diagnosis (published summary values, TOML, are read by ``ncsim.gap.summaryfile``; their names
are importable from here too).

Everything is converted to ncsim's internal units at load time (mm, s, mm/s, mm/s^2; factors
from ``ncsim.units``). Every problem with a file is a one-line
:class:`~ncsim.errors.MeasuredDataError` naming the file and the line or the column.

Trace CSV (the dialect of ``ncsim.config.read_table``), default column convention::

    t_s, x_mm, y_mm[, z_mm][, feed_mm_min][, vx_mm_s, vy_mm_s[, vz_mm_s]][, x_cmd_mm, y_cmd_mm[, z_cmd_mm]][, line]

Other unit suffixes are recognised on the default names (``t_ms``, ``x_um``, ``feed_m_min``,
``feed_mm_s`` ...). Other names are mapped with ``columns={"t": "Time", "x": "X1_Actual"}`` and
their units given with ``units={"t": "ms", "x": "um", "feed": "m/min"}`` (a unit is otherwise
taken from a recognised suffix of the mapped name, else: s, mm, mm/s, and mm/min for the path
feed, the 840D convention). Time may be generated from ``sample_period_s`` when the file has
no time column (optionally times a row-index column, so that missing rows show as gaps).

Known recorders' layouts are detected from the header (:data:`PRESETS`, e.g. the KIT wbk
SINUMERIK Edge datasets). Samples may be missing (non-uniform but increasing time is fine); a
repeated or decreasing time, an empty cell, a NaN or a missing column is an error, and so are
values no recording has: a sample period (the median time step) under 1 us, a value beyond
+-1e9 in mm and s (the 840D's position range).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, replace
from typing import Mapping

import numpy as np

from ncsim.errors import MeasuredDataError, UsageError
from ncsim.config import MAX_OFFSET_MM, CsvTable, read_table
# published values (TOML) are read by ncsim.gap.summaryfile; their names stay importable here
from ncsim.gap.summaryfile import (MeasuredSummary, SummaryEntry,  # noqa: F401
                                   load_measured_summary, summary_from_dict)
from ncsim.units import FACTORS, mm_s_to_mm_min

AXES = ("x", "y", "z")
#: the shortest sample period of a recording: 1 us (no drive's control cycle is that fast)
MIN_SAMPLE_PERIOD_S = 1e-6
#: the largest magnitude of a recorded value in mm and s: the 840D's position range
MAX_MAGNITUDE = MAX_OFFSET_MM

# ---------------------------------------------------------------------------------------------
# Units
# ---------------------------------------------------------------------------------------------

_UNIT_ALIASES = {"µm": "um", "μm": "um", "µs": "us", "μs": "us", "sec": "s", "inch": "in",
                 "mm_s": "mm/s", "mm_min": "mm/min", "m_min": "m/min", "m_s": "m/s", "um_s": "um/s",
                 "in_min": "in/min", "mm/s^2": "mm/s2", "mm/s²": "mm/s2", "mm_s2": "mm/s2",
                 "m/s^2": "m/s2", "m/s²": "m/s2", "m_s2": "m/s2", "um_s2": "um/s2"}

#: logical trace key -> quantity kind
KEY_KIND = {"t": "time", "x": "length", "y": "length", "z": "length", "feed": "velocity",
            "vx": "velocity", "vy": "velocity", "vz": "velocity",
            "x_cmd": "length", "y_cmd": "length", "z_cmd": "length", "line": None}

#: default candidate column names per logical key (first match in the header wins)
DEFAULT_COLUMNS: dict[str, tuple[str, ...]] = {
    "t": ("t_s", "t_ms", "time_s", "time_ms"),
    "x": ("x_mm", "x_um"), "y": ("y_mm", "y_um"), "z": ("z_mm", "z_um"),
    "feed": ("feed_mm_min", "feed_mm_s", "feed_m_min"),
    "vx": ("vx_mm_s", "vx_mm_min"), "vy": ("vy_mm_s", "vy_mm_min"), "vz": ("vz_mm_s", "vz_mm_min"),
    "x_cmd": ("x_cmd_mm", "x_cmd_um"), "y_cmd": ("y_cmd_mm", "y_cmd_um"),
    "z_cmd": ("z_cmd_mm", "z_cmd_um"),
    "line": ("line",),
}

#: column layouts of known recorders, detected from the header (``detect_preset``):
#: ``kit`` -- the KIT wbk SINUMERIK Edge datasets (e.g. ``DMC60H_AL2007T4_Notch_Normal_1.csv``):
#: ``time`` in s, ``pos_*`` actual and ``cmd_pos_*`` commanded positions in mm, machine
#: coordinates. Their ``cmd_v_*`` is the drive's speed set point (it includes Kv times the
#: contour deviation), not the derivative of ``cmd_pos_*``, so velocities are not mapped.
PRESETS: dict[str, dict[str, str]] = {
    "kit": {"t": "time", "x": "pos_x", "y": "pos_y", "z": "pos_z",
            "x_cmd": "cmd_pos_x", "y_cmd": "cmd_pos_y", "z_cmd": "cmd_pos_z"},
}


def detect_preset(header: list[str]) -> str | None:
    """The preset whose every column is in ``header`` (None if none)."""
    names = set(header)
    for name, columns in PRESETS.items():
        if set(columns.values()) <= names:
            return name
    return None


_DEFAULT_UNIT = {"time": "s", "length": "mm", "velocity": "mm/s"}
_GROUP_UNIT_KEYS = {"pos": ("x", "y", "z", "x_cmd", "y_cmd", "z_cmd"), "vel": ("vx", "vy", "vz")}


def normalise_unit(unit: str) -> str:
    u = unit.strip()
    return _UNIT_ALIASES.get(u, u)


def unit_factor(kind: str, unit: str) -> float:
    """Factor from ``unit`` to ncsim's internal unit of ``kind`` (raises ``KeyError``)."""
    return FACTORS[kind][normalise_unit(unit)]


def unit_from_suffix(name: str, kind: str) -> str | None:
    """The unit named by a column-name suffix (``t_ms`` -> ms, ``feed_m_min`` -> m/min), or None.

    Only units of the expected quantity ``kind`` are considered, longest suffix first."""
    lowered = name.strip().lower()
    candidates = []
    for unit in FACTORS[kind]:
        suffix = "_" + unit.replace("/", "_")
        if lowered.endswith(suffix):
            candidates.append((len(suffix), unit))
    return max(candidates)[1] if candidates else None


# ---------------------------------------------------------------------------------------------
# The trace
# ---------------------------------------------------------------------------------------------

@dataclass(frozen=True, eq=False)
class MeasuredTrace:
    """A measured (or synthetic "measured") trace: one row per recorded sample.

    ``pos_mm`` is the actual position (what the encoders saw); ``cmd_pos_mm``, when present, is
    the position set point the NC sent to the drives at the same instant, so that a gap can be
    split into its planner part (simulation vs command) and its servo part (command vs actual).
    ``segment`` numbers contiguous recordings (a trace stitched from several pieces, e.g. after
    trimming idle rows); None means one recording. ``extra`` holds other columns kept by a
    loader (e.g. the programmed feed), each with ``len(t_s)`` rows.
    """

    t_s: np.ndarray                          # (m,) strictly increasing
    pos_mm: np.ndarray                       # (m, 3) actual X Y Z
    feed_mm_s: np.ndarray | None = None      # (m,) recorded path feed
    vel_mm_s: np.ndarray | None = None       # (m, 3) actual axis velocities
    acc_mm_s2: np.ndarray | None = None      # (m, 3) actual axis accelerations
    cmd_pos_mm: np.ndarray | None = None     # (m, 3) commanded positions
    cmd_vel_mm_s: np.ndarray | None = None   # (m, 3) commanded axis velocities
    cmd_acc_mm_s2: np.ndarray | None = None  # (m, 3) commanded axis accelerations
    line: np.ndarray | None = None           # (m,) int NC line / sequence number reported
    segment: np.ndarray | None = None        # (m,) int contiguous-recording index
    source: str = "<measured>"
    extra: Mapping[str, np.ndarray] = field(default_factory=dict)
    length_unit: str = "mm"                  # the unit the file's positions were read in

    def __post_init__(self) -> None:
        t = np.asarray(self.t_s, dtype=np.float64)
        if t.ndim != 1 or len(t) == 0:
            raise MeasuredDataError("trace has no samples", file=self.source)
        m = len(t)
        object.__setattr__(self, "t_s", t)
        for f in fields(self):
            if f.name in ("t_s", "source", "extra", "length_unit"):
                continue
            v = getattr(self, f.name)
            if v is None:
                continue
            dtype = np.int64 if f.name in ("line", "segment") else np.float64
            arr = np.asarray(v, dtype=dtype)
            want = (m,) if f.name in ("feed_mm_s", "line", "segment") else (m, 3)
            if arr.shape != want:
                raise MeasuredDataError(f"{f.name} has shape {arr.shape}, expected {want}",
                                        file=self.source)
            if dtype is np.float64 and not np.all(np.isfinite(arr)):
                i = int(np.nonzero(~np.all(np.isfinite(arr.reshape(m, -1)), axis=1))[0][0])
                raise MeasuredDataError(f"{f.name} is not finite at sample {i}", file=self.source)
            object.__setattr__(self, f.name, arr)
        for k, v in self.extra.items():
            if len(v) != m:
                raise MeasuredDataError(f"extra column {k!r} has {len(v)} rows, expected {m}",
                                        file=self.source)
        if not np.all(np.isfinite(t)):
            i = int(np.nonzero(~np.isfinite(t))[0][0])
            raise MeasuredDataError(f"time is not finite at sample {i}", file=self.source)
        bad = np.nonzero(np.diff(t) <= 0)[0]
        if len(bad):
            i = int(bad[0]) + 1
            raise MeasuredDataError(f"time {t[i]:.9g} s at sample {i} is not after the previous "
                                    f"sample ({t[i - 1]:.9g} s)", file=self.source)

    def __len__(self) -> int:
        return len(self.t_s)

    @property
    def has_command(self) -> bool:
        return self.cmd_pos_mm is not None

    @property
    def period_s(self) -> float:
        """Nominal sampling period: the median time step (robust to dropped samples)."""
        return float(np.median(np.diff(self.t_s))) if len(self) > 1 else math.nan

    def select(self, index) -> "MeasuredTrace":
        """A new trace with the rows ``index`` (slice, mask or increasing index array)."""
        changes = {}
        for f in fields(self):
            v = getattr(self, f.name)
            if isinstance(v, np.ndarray):
                changes[f.name] = v[index]
        changes["extra"] = {k: np.asarray(v)[index] for k, v in self.extra.items()}
        return replace(self, **changes)

    def shifted(self, time_shift_s: float = 0.0, offset_mm=(0.0, 0.0, 0.0)) -> "MeasuredTrace":
        """The same samples with ``time_shift_s`` subtracted from the time and ``offset_mm``
        from the actual and commanded positions (undoing an estimated clock and zero offset)."""
        off = np.asarray(offset_mm, dtype=np.float64)
        return replace(self, t_s=self.t_s - time_shift_s, pos_mm=self.pos_mm - off,
                       cmd_pos_mm=None if self.cmd_pos_mm is None else self.cmd_pos_mm - off)

    def thinned(self, min_period_s: float) -> "MeasuredTrace":
        """The trace averaged over bins of ``k = floor(min_period_s / period)`` consecutive
        samples (itself when ``k`` < 2): what a recorder that samples more slowly after a
        moving-average filter would have written. A bin's time and values are the means of its
        samples; integer and object columns keep the bin's first value; bins never span a
        recording break (segment change or a gap over 3 periods). Over a window ``W`` the mean
        departs from the motion by at most ``a W^2 / 24`` (0.04 um at 1 m/s^2 and 1 ms)."""
        m = len(self)
        k = int(min_period_s / self.period_s) if m > 1 else 1
        if k < 2:
            return self
        brk = np.diff(self.t_s) > 3.0 * self.period_s
        if self.segment is not None:
            brk |= np.diff(self.segment) != 0
        piece = np.concatenate([[0], np.cumsum(brk)])
        first = np.concatenate([[0], np.nonzero(np.diff(piece))[0] + 1])
        in_piece = np.arange(m) - first[piece]
        key = piece * (m + 1) + in_piece // k
        starts = np.concatenate([[0], np.nonzero(np.diff(key))[0] + 1])
        counts = np.diff(np.concatenate([starts, [m]]))

        def mean(a):
            a = np.asarray(a)
            if a.dtype.kind != "f":
                return a[starts]
            sums = np.add.reduceat(a, starts, axis=0)
            return sums / (counts if a.ndim == 1 else counts[:, None])

        changes = {f.name: mean(getattr(self, f.name)) for f in fields(self)
                   if isinstance(getattr(self, f.name), np.ndarray)}
        changes["extra"] = {name: mean(v) for name, v in self.extra.items()}
        return replace(self, **changes)

    def command(self) -> "MeasuredTrace":
        """The commanded positions as a trace of their own (for the planner part of the gap)."""
        if self.cmd_pos_mm is None:
            raise MeasuredDataError("trace has no commanded positions", file=self.source)
        return MeasuredTrace(t_s=self.t_s, pos_mm=self.cmd_pos_mm, vel_mm_s=self.cmd_vel_mm_s,
                             acc_mm_s2=self.cmd_acc_mm_s2, line=self.line, segment=self.segment,
                             source=self.source + " (command)", extra=dict(self.extra),
                             length_unit=self.length_unit)

    def speed_mm_s(self, smooth_s: float = 0.0) -> np.ndarray:
        """Path speed at each sample: the recorded feed if any, else |axis velocity|, else a
        central difference of the positions over about ``smooth_s`` (at least one sample each
        side; differences never span a recording break or a gap longer than 3 periods)."""
        if self.feed_mm_s is not None:
            return self.feed_mm_s
        if self.vel_mm_s is not None:
            return np.linalg.norm(self.vel_mm_s, axis=1)
        return derived_speed_mm_s(self.t_s, self.pos_mm, smooth_s, self.segment)


def derived_speed_mm_s(t_s: np.ndarray, pos_mm: np.ndarray, smooth_s: float = 0.0,
                       segment: np.ndarray | None = None) -> np.ndarray:
    """Speed from positions: |p[i+k] - p[i-k]| / (t[i+k] - t[i-k]) with ``k`` samples such that
    ``2 k`` periods span about ``smooth_s`` (k >= 1), one-sided at the ends and at breaks; a
    sample alone between two breaks is differenced with its direct neighbours across them.

    A central difference over a window of width ``W`` divides white position noise of standard
    deviation sigma into a speed noise of about ``sqrt(2) sigma / W``."""
    t = np.asarray(t_s, dtype=np.float64)
    p = np.asarray(pos_mm, dtype=np.float64)
    m = len(t)
    if m < 2:
        return np.zeros(m)
    steps = np.diff(t)
    dt = float(np.median(steps))
    k = max(1, int(round(0.5 * smooth_s / dt))) if smooth_s > 0 else 1
    if segment is None and float(np.max(steps)) <= 3.0 * dt and float(np.min(steps)) > 0.0:
        return _central_speed_mm_s(t, p, k)
    idx = np.arange(m)
    # recording pieces: breaks at segment changes and at gaps longer than 3 nominal periods
    brk = np.zeros(m, dtype=np.int64)
    jumps = np.diff(t) > 3.0 * dt
    if segment is not None:
        jumps |= np.diff(np.asarray(segment)) != 0
    brk[1:] = np.cumsum(jumps)
    first = np.zeros(brk[-1] + 1, dtype=np.int64)
    last = np.zeros(brk[-1] + 1, dtype=np.int64)
    first[brk[::-1]] = idx[::-1]
    last[brk] = idx
    lo = np.maximum(idx - k, first[brk])
    hi = np.minimum(idx + k, last[brk])
    span = t[hi] - t[lo]
    d = np.linalg.norm(p[hi] - p[lo], axis=1)
    # a sample alone between two gaps (e.g. dropouts around it) has no neighbour in its piece:
    # difference it with its direct neighbours across the gaps rather than report rest
    alone = span <= 0
    if np.any(alone):
        a = idx[alone]
        lo2, hi2 = np.maximum(a - 1, 0), np.minimum(a + 1, m - 1)
        span[alone] = t[hi2] - t[lo2]
        d[alone] = np.linalg.norm(p[hi2] - p[lo2], axis=1)
    return np.divide(d, span, out=np.zeros(m), where=span > 0)


def _central_speed_mm_s(t: np.ndarray, p: np.ndarray, k: int) -> np.ndarray:
    """:func:`derived_speed_mm_s` of one piece without breaks (every step positive and at
    most 3 nominal periods): ``|p[i+k] - p[i-k]| / (t[i+k] - t[i-k])``, the indexes clipped to
    the ends; the interior by slices (the model traces of a fit, thousands of calls)."""
    m = len(t)
    edge = np.r_[np.arange(min(k, m)), np.arange(max(m - k, k), m)]   # clipped samples
    d = np.empty_like(p)
    span = np.empty(m)
    if m > 2 * k:
        d[k:m - k] = p[2 * k:] - p[:m - 2 * k]
        span[k:m - k] = t[2 * k:] - t[:m - 2 * k]
    lo, hi = np.maximum(edge - k, 0), np.minimum(edge + k, m - 1)
    d[edge] = p[hi] - p[lo]
    span[edge] = t[hi] - t[lo]
    return np.sqrt(np.einsum("ij,ij->i", d, d)) / span


# ---------------------------------------------------------------------------------------------
# CSV loading
# ---------------------------------------------------------------------------------------------

def _resolve_columns(table: CsvTable, columns: Mapping[str, str] | None,
                     units: Mapping[str, str] | None):
    """Logical key -> (column index, column name, factor to internal units)."""
    columns = dict(columns or {})
    units = dict(units or {})
    for key in list(units):
        if key in _GROUP_UNIT_KEYS:
            for k in _GROUP_UNIT_KEYS[key]:
                units.setdefault(k, units[key])
            del units[key]
    unknown = [k for k in list(columns) + list(units) if k not in KEY_KIND]
    if unknown:
        raise UsageError(f"unknown trace key {unknown[0]!r} in columns/units "
                         f"(known: {', '.join(KEY_KIND)}, and 'pos', 'vel' for units)")
    out: dict[str, tuple[int, str, float]] = {}
    for key, kind in KEY_KIND.items():
        if key in columns:
            name = columns[key]
            i = table.find(name)
            if i is None:
                raise MeasuredDataError(f"no such column (mapped for {key!r}; header has: "
                                        f"{', '.join(table.header)})", file=table.file,
                                        column=name)
        else:
            i, name = None, None
            for cand in DEFAULT_COLUMNS[key]:
                j = table.find(cand)
                if j is not None:
                    i, name = j, table.header[j]
                    break
            if i is None:
                continue
        if kind is None:
            out[key] = (i, name, 1.0)
            continue
        unit = units.get(key) or unit_from_suffix(name, kind)
        if unit is None:
            unit = "mm/min" if key == "feed" else _DEFAULT_UNIT[kind]
        try:
            factor = unit_factor(kind, unit)
        except KeyError:
            raise MeasuredDataError(f"unknown {kind} unit {unit!r} (known: "
                                    f"{', '.join(FACTORS[kind])})", file=table.file,
                                    column=name) from None
        out[key] = (i, name, factor)
    return out


def _check_time(table: CsvTable, t: np.ndarray) -> None:
    """Time increases, by a sample period (the median step) of at least
    ``MIN_SAMPLE_PERIOD_S``."""
    steps = np.diff(t)
    bad = np.nonzero(steps <= 0)[0]
    if len(bad):
        i = int(bad[0]) + 1
        what = "repeats" if t[i] == t[i - 1] else "goes back from"
        raise MeasuredDataError(f"time {t[i]:.9g} s {what} the previous sample's "
                                f"({t[i - 1]:.9g} s at line {table.line_of(i - 1)}): time must "
                                "increase", file=table.file, line=table.line_of(i))
    if len(steps) and float(np.median(steps)) < MIN_SAMPLE_PERIOD_S:
        raise MeasuredDataError(f"the samples are {float(np.median(steps)):.3g} s apart (the "
                                f"median time step), under {MIN_SAMPLE_PERIOD_S * 1e6:g} us: a "
                                "recorder at over 1 MHz, faster than any control cycle of a "
                                "drive (the time in another unit?)", file=table.file)


def _check_magnitudes(table: CsvTable, columns: Mapping[str, tuple[str, np.ndarray]]) -> None:
    """Every value, converted to mm and s, within ``MAX_MAGNITUDE`` (the 840D's position range
    +-999 999 999.9999; no speed, acceleration or time of a recording comes near it): a value
    of 1e300 is an export error, and arithmetic on it overflows."""
    for key, (name, v) in columns.items():
        bad = np.flatnonzero(~(np.abs(v) < MAX_MAGNITUDE))
        if len(bad):
            unit = {"length": "mm", "time": "s", "velocity": "mm/s", "acceleration": "mm/s^2"}
            kind = KEY_KIND.get(key, "")
            raise MeasuredDataError(f"column '{name}' holds {v[bad[0]]:g} {unit.get(kind, '')}"
                                    .rstrip() + f", beyond +-{MAX_MAGNITUDE:g} (the 840D's "
                                    "position range in mm; no recorded time, speed or "
                                    "acceleration comes near it either)",
                                    file=table.file, line=table.line_of(int(bad[0])))


def _data_table(file) -> CsvTable:
    table = read_table(file)
    if not table.body.strip():
        raise MeasuredDataError("no data rows after the header", file=table.file)
    return table


def load_measured_csv(file, *, columns: Mapping[str, str] | None = None,
                      units: Mapping[str, str] | None = None, time_column: str | None = None,
                      sample_period_s: float | None = None,
                      index_column: str | None = None, preset: str | None = "auto") -> MeasuredTrace:
    """Load a measured trace from CSV (see the module docstring for the conventions).

    ``columns`` maps logical keys (``t x y z feed vx vy vz x_cmd y_cmd z_cmd line``) to header
    names; ``time_column`` is a shorthand for ``columns["t"]``. ``units`` gives units per key
    (or ``pos`` / ``vel`` for all positions / velocities). With ``sample_period_s`` the time is
    generated as ``row * period`` (``row`` counting data rows from 0, or the value of
    ``index_column`` when given, so that missing rows appear as dropped samples); a file with a
    time column of a default name is then refused, never silently re-timed (a preset's time
    column is set aside). ``x`` and ``y`` are required; a missing ``z`` is zero. ``preset`` names
    a known recorder's column layout (:data:`PRESETS`; ``"auto"``: detected from the header;
    None: none), which ``columns`` override.
    """
    table = _data_table(file)
    name = table.file
    if preset == "auto":
        preset = detect_preset(table.header)
    if preset is not None and preset not in PRESETS:
        raise UsageError(f"unknown trace preset {preset!r} (known: {', '.join(PRESETS)})")
    columns = dict(columns or {})
    if time_column is not None:
        columns["t"] = time_column
    if sample_period_s is not None:
        if "t" in columns:
            raise UsageError("give either a time column or sample_period_s, not both")
        if not (math.isfinite(sample_period_s) and sample_period_s >= MIN_SAMPLE_PERIOD_S):
            raise UsageError(f"the sample period must be at least {MIN_SAMPLE_PERIOD_S * 1e6:g} "
                             f"us (a recorder at over 1 MHz, faster than any control cycle of a "
                             f"drive), got {sample_period_s:g} s")
    layout = {k: v for k, v in (PRESETS[preset] if preset else {}).items()
              if not (k == "t" and sample_period_s is not None)}
    columns = {**layout, **columns}
    resolved = _resolve_columns(table, columns, units)
    for key in ("x", "y"):
        if key not in resolved:
            raise MeasuredDataError(f"missing column for {key!r} (looked for "
                                    f"{', '.join(DEFAULT_COLUMNS[key])}; name yours with "
                                    f"--column {key}=NAME)", file=name,
                                    column=DEFAULT_COLUMNS[key][0])
    if sample_period_s is None and "t" not in resolved:
        raise MeasuredDataError("missing time column (looked for " +
                                ", ".join(DEFAULT_COLUMNS["t"]) +
                                "; name yours with --column t=NAME, or give the sampling "
                                "period with --sample-period-ms)",
                                file=name, column=DEFAULT_COLUMNS["t"][0])
    if sample_period_s is not None and "t" in resolved:   # never re-time a file silently
        raise UsageError(f"{name}: has a time column '{resolved['t'][1]}': a sample period is "
                         "for files without one")
    index_at = None
    if sample_period_s is not None and index_column is not None:
        index_at = table.find(index_column)
        if index_at is None:
            raise MeasuredDataError("no such index column", file=name, column=index_column)
    # every numeric column in one pass of the compiled reader
    keys = list(resolved)
    wanted = [resolved[k][0] for k in keys] + ([index_at] if index_at is not None else [])
    names = [resolved[k][1] for k in keys] + ([index_column] if index_at is not None else [])
    block = table.floats(wanted, names)
    if len(block) == 0:
        raise MeasuredDataError("no data rows after the header", file=name)
    values = {k: block[:, j] * resolved[k][2] for j, k in enumerate(keys)}
    m = len(block)
    _check_magnitudes(table, {k: (resolved[k][1], v) for k, v in values.items()})

    def col(key):
        return values[key]

    if sample_period_s is not None:
        if index_at is not None:
            idx = block[:, -1]
            if np.any(idx != np.round(idx)):
                k = int(np.nonzero(idx != np.round(idx))[0][0])
                raise MeasuredDataError(f"index column '{index_column}' is not an integer",
                                        file=name, line=table.line_of(k))
            t = (idx - idx[0]) * sample_period_s
        else:
            t = np.arange(m) * float(sample_period_s)
    else:
        t = col("t")
    _check_time(table, t)

    pos = np.column_stack([col(k) if k in resolved else np.zeros(m) for k in AXES])
    feed = col("feed") if "feed" in resolved else None

    def axis_group(keys, present, message):
        """The (m, 3) columns ``keys`` (z may be absent: 0), or None if none of ``present`` is
        given; X and Y must come together."""
        if not any(k in resolved for k in present):
            return None
        for k in keys[:2]:
            if k not in resolved:
                raise MeasuredDataError(f"{message} (no column for {k!r})", file=name,
                                        column=DEFAULT_COLUMNS[k][0])
        return np.column_stack([col(k) if k in resolved else np.zeros(m) for k in keys])

    vel = axis_group(("vx", "vy", "vz"), ("vx", "vy"), "axis velocities need both vx and vy")
    cmd = axis_group(("x_cmd", "y_cmd", "z_cmd"), ("x_cmd", "y_cmd", "z_cmd"),
                     "commanded positions need x_cmd and y_cmd")
    line = None
    if "line" in resolved:
        raw = col("line")
        if np.any(raw != np.round(raw)):
            k = int(np.nonzero(raw != np.round(raw))[0][0])
            raise MeasuredDataError(f"column '{resolved['line'][1]}' is not an integer line "
                                    "number", file=name, line=table.line_of(k))
        line = raw.astype(np.int64)
    pos_key = "x_cmd" if "x_cmd" in resolved else "x"
    unit = next((u for u, f in FACTORS["length"].items() if f == resolved[pos_key][2]), "mm")
    return MeasuredTrace(t_s=t, pos_mm=pos, feed_mm_s=feed, vel_mm_s=vel, cmd_pos_mm=cmd,
                         line=line, source=name, length_unit=unit)


def write_measured_csv(trace: MeasuredTrace, file, *, header_comment: str = "") -> None:
    """Write a trace in the default column convention (``t_s, x_mm, ...``, feed in mm/min);
    :func:`load_measured_csv` reads it back."""
    cols = [("t_s", trace.t_s)]
    cols += [(f"{a}_mm", trace.pos_mm[:, i]) for i, a in enumerate(AXES)]
    if trace.feed_mm_s is not None:
        cols.append(("feed_mm_min", mm_s_to_mm_min(trace.feed_mm_s)))
    if trace.vel_mm_s is not None:
        cols += [(f"v{a}_mm_s", trace.vel_mm_s[:, i]) for i, a in enumerate(AXES)]
    if trace.cmd_pos_mm is not None:
        cols += [(f"{a}_cmd_mm", trace.cmd_pos_mm[:, i]) for i, a in enumerate(AXES)]
    data = np.column_stack([c for _, c in cols])
    with open(file, "w", encoding="utf-8", newline="") as fh:
        for h in header_comment.splitlines():
            fh.write(f"# {h}\n")
        fh.write(",".join(n for n, _ in cols) + ("," + "line" if trace.line is not None else "")
                 + "\n")
        for r in range(len(trace)):
            cells = [repr(float(v)) for v in data[r]]
            if trace.line is not None:
                cells.append(str(int(trace.line[r])))
            fh.write(",".join(cells) + "\n")


# ---------------------------------------------------------------------------------------------
# University of Michigan SMART "CNC Mill Tool Wear" files
# ---------------------------------------------------------------------------------------------

UMICH_PERIOD_S = 0.1           # rows are nominally 100 ms apart (SOURCE.md); no time column
UMICH_IDLE_FEED_MM_S = 50.0    # M1_CURRENT_FEEDRATE reads 50 in rapids / preparation / idle
UMICH_IDLE_X_MM = 198.0        # X1_ActualPosition reads 198 at the idle (home) state


def load_umich_csv(file, *, drop_unreliable: bool = True) -> MeasuredTrace:
    """Load one UMich SMART mill file (``experiment_NN.csv``) as a :class:`MeasuredTrace`.

    Time is ``row index * 0.1 s`` (the files have no time column). Actual and commanded
    positions (mm), velocities (mm/s) and accelerations (mm/s^2) of X1/Y1/Z1 are kept;
    ``line`` is ``M1_sequence_number``; ``extra`` holds ``programmed_feed_mm_s``
    (``M1_CURRENT_FEEDRATE``, mm/s) and ``process`` (``Machining_Process`` labels).

    With ``drop_unreliable`` the rows the source calls unreliable are removed: feed reading 50
    or ``X1_ActualPosition`` reading 198 (idle, start and rapid states). The third condition of
    the source (``M1_CURRENT_PROGRAM_NUMBER`` not 0) is not applied: it reads 1 on every row of
    the copied files. The files are stitched from several recordings (positions and sequence
    numbers jump after idle stretches); ``segment`` numbers the contiguous runs of kept rows.
    Caveat (SOURCE.md): values have 3 significant figures, so positions above 100 mm have 1 mm
    resolution; use the velocities for servo analysis.
    """
    table = _data_table(file)
    name, header = table.file, table.header

    def col(cname, factor=1.0):
        i = table.find(cname)
        if i is None:
            raise MeasuredDataError("missing column (not a UMich SMART mill file?)", file=name,
                                    column=cname)
        return table.floats([i], [cname])[:, 0] * factor

    idx = col(header[0]) if header[0] == "" else np.arange(table.n_rows(), dtype=float)
    t = (idx - idx[0]) * UMICH_PERIOD_S
    _check_time(table, t)

    def axes3(signal):
        return np.column_stack([col(f"{a}1_{signal}") for a in ("X", "Y", "Z")])

    act_pos, cmd_pos = axes3("ActualPosition"), axes3("CommandPosition")
    act_vel, cmd_vel = axes3("ActualVelocity"), axes3("CommandVelocity")
    act_acc, cmd_acc = axes3("ActualAcceleration"), axes3("CommandAcceleration")
    feed_prog = col("M1_CURRENT_FEEDRATE")
    seq = col("M1_sequence_number").astype(np.int64)
    i_proc = table.find("Machining_Process")
    process = np.array(table.text_column(i_proc) if i_proc is not None else [""] * len(t),
                       dtype=object)

    keep = np.ones(len(t), dtype=bool)
    if drop_unreliable:
        keep = (feed_prog != UMICH_IDLE_FEED_MM_S) & (act_pos[:, 0] != UMICH_IDLE_X_MM)
        if not np.any(keep):
            raise MeasuredDataError("no reliable rows (all idle: feed 50 or X at 198)", file=name)
    kept = np.nonzero(keep)[0]
    seg = np.zeros(len(kept), dtype=np.int64)
    seg[1:] = np.cumsum(np.diff(kept) > 1)
    return MeasuredTrace(t_s=t[kept], pos_mm=act_pos[kept], vel_mm_s=act_vel[kept],
                         acc_mm_s2=act_acc[kept], cmd_pos_mm=cmd_pos[kept],
                         cmd_vel_mm_s=cmd_vel[kept], cmd_acc_mm_s2=cmd_acc[kept],
                         line=seq[kept], segment=seg, source=name,
                         extra={"programmed_feed_mm_s": feed_prog[kept],
                                "process": process[kept]})
