"""Path segments: the interpreter's output and the planner's input.

A :class:`Path` holds one row per motion segment (line, arc or helix) in execution order, as
columns (numpy arrays), so that million-block programs stay cheap. Geometry (``geometry.py``)
maps arc length to position; timing is the planner's business.

Arc convention: ``center_mm`` lies in the arc plane through the start point; ``normal`` is the
unit axis about which the tool travels counter-clockwise (right-hand rule), so a G2 in G17 has
``normal = (0, 0, -1)``; ``sweep_rad > 0`` is the angle travelled (2*pi per full turn);
``helix_mm`` is the rise along ``normal`` over the whole segment. For lines the arc columns are
NaN (``center_mm``, ``radius_mm``) or 0 (``normal``, ``sweep_rad``, ``helix_mm``).

Junction ``k`` is the start of segment ``k``; junction ``n`` is the end of the path. The
modal columns say how the NC treats the segment and its junctions:

* ``exact_stop``: the axes stop at the END of this segment (G60 modal or G9 in the block);
* ``stop_before``: the NC stops BEFORE this segment (auxiliary-function output, STOPRE,
  SOFT/BRISK/DRIVE change, G4 dwell, rapid/feed change) -- no rounding across it;
* ``dwell_before_s``: dwell time spent at the start of this segment (G4);
* ``stop_window``: the exact-stop criterion in force (601 fine, 602 coarse, 603 IPO end);
* ``cp_mode`` / ``adis_mm``: continuous-path mode (60, 64, 641, 642, ...) and its ADIS;
* ``compressor``: the NC block compressor in force for the block (COMPOF 0, COMPON 1, COMPCURV
  2, COMPCAD 3, COMPSURF 4; 0 for arcs), negated when another instruction than the simple
  ``N.. G1 X.. Y.. Z.. F..`` came since the last segment (SINUMERIK Job Planning "NC block
  compression": it interrupts the compressor, a new run starts with this block);
* ``ctol_mm``: the programmed contour tolerance in force (CTOL= or CYCLE832), NaN when none
  (the machine data MD33100/SD42465 apply);
* ``dyn_group``: the technology group (G group 59) whose axis dynamics apply: 0 DYNNORM,
  1 DYNPOS, 2 DYNROUGH, 3 DYNSEMIFIN, 4 DYNFINISH, 5 DYNPREC (``machine.TECHNOLOGY_GROUPS``;
  selected by the DYN... words and CYCLE832, resolved by ``plan.limits``).

Where a segment comes from in the program's structure (for reports; the planner ignores
them): ``block_number`` is the N number of its block (-1: none), ``tool`` and ``operation``
index the string tables ``tools`` and ``operations`` (-1: none), as ``file_index`` indexes
``files`` (``ncsim.nc.outline`` says how they are found).
"""
from __future__ import annotations

from dataclasses import dataclass, fields, replace
from typing import Iterable

import numpy as np

LINE = 0
ARC = 1

SOFT = 0
BRISK = 1
DRIVE = 2
ACCEL_MODE_NAMES = {SOFT: "SOFT", BRISK: "BRISK", DRIVE: "DRIVE"}

COMPOF = 0
COMPON = 1
COMPCURV = 2
COMPCAD = 3
COMPSURF = 4
COMPRESSOR_NAMES = {COMPOF: "COMPOF", COMPON: "COMPON", COMPCURV: "COMPCURV", COMPCAD: "COMPCAD",
                    COMPSURF: "COMPSURF"}

# Column name -> (dtype, shape suffix, default for a line row)
_COLUMNS: dict[str, tuple[type, tuple[int, ...], object]] = {
    "kind": (np.int8, (), LINE),
    "start_mm": (np.float64, (3,), None),
    "end_mm": (np.float64, (3,), None),
    "center_mm": (np.float64, (3,), np.nan),
    "normal": (np.float64, (3,), 0.0),
    "radius_mm": (np.float64, (), np.nan),
    "sweep_rad": (np.float64, (), 0.0),
    "helix_mm": (np.float64, (), 0.0),
    "length_mm": (np.float64, (), None),
    "line": (np.int32, (), 0),
    "file_index": (np.int16, (), 0),
    "feed_mm_s": (np.float64, (), np.inf),
    "rapid": (np.bool_, (), False),
    "exact_stop": (np.bool_, (), False),
    "stop_window": (np.int16, (), 601),
    "cp_mode": (np.int16, (), 60),
    "adis_mm": (np.float64, (), 0.0),
    "accel_mode": (np.int8, (), SOFT),
    "ffw": (np.bool_, (), False),
    "stop_before": (np.bool_, (), False),
    "dwell_before_s": (np.float64, (), 0.0),
    "compressor": (np.int8, (), COMPOF),
    "ctol_mm": (np.float64, (), np.nan),
    "dyn_group": (np.int8, (), 0),
    "block_number": (np.int32, (), -1),
    "tool": (np.int16, (), -1),
    "operation": (np.int16, (), -1),
}


@dataclass(frozen=True, slots=True)
class Segment:
    """One row of a :class:`Path`, as Python scalars (for tests, reports, the reference planner)."""

    index: int
    kind: int
    start_mm: np.ndarray
    end_mm: np.ndarray
    center_mm: np.ndarray
    normal: np.ndarray
    radius_mm: float
    sweep_rad: float
    helix_mm: float
    length_mm: float
    line: int
    file: str
    feed_mm_s: float
    rapid: bool
    exact_stop: bool
    stop_window: int
    cp_mode: int
    adis_mm: float
    accel_mode: int
    ffw: bool
    stop_before: bool
    dwell_before_s: float
    compressor: int = COMPOF
    ctol_mm: float = float("nan")
    dyn_group: int = 0
    block_number: int = -1
    tool: str | None = None
    operation: str | None = None

    @property
    def is_arc(self) -> bool:
        return self.kind == ARC

    @property
    def clockwise_in_plane(self) -> bool | None:
        """For an arc: True if it turns clockwise seen from +Z/+Y/+X of its plane (a G2)."""
        if self.kind != ARC:
            return None
        return bool(np.sum(self.normal) < 0)


@dataclass(frozen=True, slots=True)
class Path:
    """Columnar motion segments in execution order (see the module docstring)."""

    kind: np.ndarray
    start_mm: np.ndarray
    end_mm: np.ndarray
    center_mm: np.ndarray
    normal: np.ndarray
    radius_mm: np.ndarray
    sweep_rad: np.ndarray
    helix_mm: np.ndarray
    length_mm: np.ndarray
    line: np.ndarray
    file_index: np.ndarray
    feed_mm_s: np.ndarray
    rapid: np.ndarray
    exact_stop: np.ndarray
    stop_window: np.ndarray
    cp_mode: np.ndarray
    adis_mm: np.ndarray
    accel_mode: np.ndarray
    ffw: np.ndarray
    stop_before: np.ndarray
    dwell_before_s: np.ndarray
    compressor: np.ndarray
    ctol_mm: np.ndarray
    dyn_group: np.ndarray
    block_number: np.ndarray
    tool: np.ndarray
    operation: np.ndarray
    files: tuple[str, ...] = ("<program>",)
    end_dwell_s: float = 0.0  # dwell after the last segment (G4 at the end of the program)
    tools: tuple[str, ...] = ()        # names the ``tool`` column indexes
    operations: tuple[str, ...] = ()   # names the ``operation`` column indexes

    def __post_init__(self) -> None:
        n = len(self.kind)
        for name, (dtype, shape, _) in _COLUMNS.items():
            arr = getattr(self, name)
            if arr.shape != (n, *shape):
                raise ValueError(f"Path.{name} has shape {arr.shape}, expected {(n, *shape)}")
            if arr.dtype != dtype:
                raise ValueError(f"Path.{name} has dtype {arr.dtype}, expected {np.dtype(dtype)}")
            arr.setflags(write=False)

    def __len__(self) -> int:
        return len(self.kind)

    @property
    def n(self) -> int:
        return len(self.kind)

    @property
    def s_start_mm(self) -> np.ndarray:
        """Path length at the start of each segment (junctions 0..n-1)."""
        out = np.empty(self.n)
        if self.n:
            out[0] = 0.0
            np.cumsum(self.length_mm[:-1], out=out[1:])
        return out

    @property
    def total_length_mm(self) -> float:
        return float(self.length_mm.sum())

    def file_of(self, i: int) -> str:
        return self.files[int(self.file_index[i])]

    def tool_of(self, i: int) -> str | None:
        k = int(self.tool[i])
        return self.tools[k] if k >= 0 else None

    def operation_of(self, i: int) -> str | None:
        k = int(self.operation[i])
        return self.operations[k] if k >= 0 else None

    def segment(self, i: int) -> Segment:
        if not -self.n <= i < self.n:
            raise IndexError(i)
        i %= self.n
        return Segment(
            index=i,
            kind=int(self.kind[i]),
            start_mm=self.start_mm[i],
            end_mm=self.end_mm[i],
            center_mm=self.center_mm[i],
            normal=self.normal[i],
            radius_mm=float(self.radius_mm[i]),
            sweep_rad=float(self.sweep_rad[i]),
            helix_mm=float(self.helix_mm[i]),
            length_mm=float(self.length_mm[i]),
            line=int(self.line[i]),
            file=self.file_of(i),
            feed_mm_s=float(self.feed_mm_s[i]),
            rapid=bool(self.rapid[i]),
            exact_stop=bool(self.exact_stop[i]),
            stop_window=int(self.stop_window[i]),
            cp_mode=int(self.cp_mode[i]),
            adis_mm=float(self.adis_mm[i]),
            accel_mode=int(self.accel_mode[i]),
            ffw=bool(self.ffw[i]),
            stop_before=bool(self.stop_before[i]),
            dwell_before_s=float(self.dwell_before_s[i]),
            compressor=int(self.compressor[i]),
            ctol_mm=float(self.ctol_mm[i]),
            dyn_group=int(self.dyn_group[i]),
            block_number=int(self.block_number[i]),
            tool=self.tool_of(i),
            operation=self.operation_of(i),
        )

    def segments(self) -> Iterable[Segment]:
        for i in range(self.n):
            yield self.segment(i)

    def select(self, index) -> "Path":
        """A new Path with the rows ``index`` (slice, mask or index array)."""
        cols = {name: np.array(getattr(self, name)[index]) for name in _COLUMNS}
        return replace(self, **cols)

    def replace_columns(self, **columns) -> "Path":
        """A new Path with some columns replaced (arrays are copied and cast)."""
        cols = {name: getattr(self, name) for name in _COLUMNS}
        for name, value in columns.items():
            if name not in _COLUMNS:
                raise KeyError(name)
            dtype, shape, _ = _COLUMNS[name]
            cols[name] = np.array(np.broadcast_to(value, (self.n, *shape)), dtype=dtype)
        return replace(self, **cols)

    @staticmethod
    def empty(files: tuple[str, ...] = ("<program>",)) -> "Path":
        return PathBuilder(files).build()


def arc_length_mm(radius_mm, sweep_rad, helix_mm):
    """Length of a circular helix: sqrt((r * sweep)^2 + rise^2)."""
    return np.hypot(np.asarray(radius_mm) * np.asarray(sweep_rad), helix_mm)


class PathBuilder:
    """Accumulates segments, row by row or in vectorised chunks, then builds a :class:`Path`.

    ``add_line``/``add_arc`` take scalars; ``extend`` takes whole columns (used by the fast path
    for runs of plain blocks). Modal columns not given take the defaults of ``_COLUMNS``.

    Cost is linear in the rows, and the memory is the path's own: every column is one array
    written in place (``capacity`` rows, e.g. the program's line count, grown by half when
    full), rows given one by one are gathered as Python values and written every
    ``ROW_CHUNK`` rows, and ``build`` hands the arrays over, cut to length (``realloc``: no
    copy). Joining chunks at the end instead held the path twice, and the freed chunks stayed
    with the process (``malloc`` returns little of a fragmented heap). After ``build`` the
    builder writes to copies: the built path never changes.
    """

    ROW_CHUNK = 1 << 14  # rows gathered one by one before they are written
    MIN_CAPACITY = 1024

    def __init__(self, files: Iterable[str] = ("<program>",), capacity: int = 0):
        self.files: list[str] = list(files)
        self._columns: dict[str, np.ndarray] | None = None
        self._capacity = max(int(capacity), 0)
        self._written = 0          # rows in the columns
        self._shared = False       # the columns belong to a built Path
        self._rows: dict[str, list] = {name: [] for name in _COLUMNS}
        self.end_dwell_s = 0.0

    def __len__(self) -> int:
        return self._written + len(self._rows["kind"])

    def file_index(self, file: str) -> int:
        try:
            return self.files.index(file)
        except ValueError:
            self.files.append(file)
            return len(self.files) - 1

    def _reserve(self, k: int) -> None:
        """Room for ``k`` more rows in columns of the builder's own (not a built path's)."""
        need = self._written + k
        if self._columns is not None and need <= self._capacity and not self._shared:
            return
        capacity = self._capacity
        if need > capacity:
            capacity = max(need, capacity + capacity // 2, self.MIN_CAPACITY)
        old = self._columns
        self._columns = {}
        for name, (dtype, shape, _) in _COLUMNS.items():
            col = np.empty((capacity, *shape), dtype=dtype)
            if old is not None and self._written:
                col[:self._written] = old[name][:self._written]
            self._columns[name] = col
        self._capacity = capacity
        self._shared = False

    def _add_row(self, values: dict) -> None:
        for name, (_, shape, default) in _COLUMNS.items():
            if name in values:
                v = values[name]
            elif default is None:
                raise TypeError(f"segment column {name!r} is required")
            else:
                v = default
            if shape and np.ndim(v) == 0:  # a scalar default of a vector column
                v = np.full(shape, v, dtype=np.float64)
            self._rows[name].append(v)
        if len(self._rows["kind"]) >= self.ROW_CHUNK:
            self._flush_rows()

    def _flush_rows(self) -> None:
        k = len(self._rows["kind"])
        if not k:
            return
        self._reserve(k)
        a, b = self._written, self._written + k
        for name, (dtype, shape, _) in _COLUMNS.items():
            self._columns[name][a:b] = np.array(self._rows[name], dtype=dtype).reshape((-1, *shape))
            self._rows[name] = []
        self._written = b

    def add_line(self, start_mm, end_mm, *, line: int, feed_mm_s: float, **modal) -> None:
        start = np.asarray(start_mm, dtype=np.float64)
        end = np.asarray(end_mm, dtype=np.float64)
        self._add_row(dict(kind=LINE, start_mm=start, end_mm=end,
                           length_mm=float(np.linalg.norm(end - start)),
                           line=line, feed_mm_s=feed_mm_s, **modal))

    def add_arc(self, start_mm, end_mm, center_mm, normal, radius_mm: float, sweep_rad: float,
                helix_mm: float = 0.0, *, line: int, feed_mm_s: float, **modal) -> None:
        self._add_row(dict(kind=ARC, start_mm=np.asarray(start_mm, dtype=np.float64),
                           end_mm=np.asarray(end_mm, dtype=np.float64),
                           center_mm=np.asarray(center_mm, dtype=np.float64),
                           normal=np.asarray(normal, dtype=np.float64),
                           radius_mm=radius_mm, sweep_rad=sweep_rad, helix_mm=helix_mm,
                           length_mm=float(arc_length_mm(radius_mm, sweep_rad, helix_mm)),
                           line=line, feed_mm_s=feed_mm_s, **modal))

    def extend(self, **columns) -> None:
        """Append a chunk of rows. ``kind``, ``start_mm``, ``end_mm``, ``length_mm`` and ``line``
        are required arrays; other columns may be arrays or scalars (broadcast). The values
        are copied (cast to the column's dtype): the caller keeps its arrays."""
        self._flush_rows()
        k = len(columns["kind"])
        for name, (_, _, default) in _COLUMNS.items():
            if name not in columns and default is None:
                raise TypeError(f"segment column {name!r} is required")
        self._reserve(k)
        a, b = self._written, self._written + k
        for name, (dtype, shape, default) in _COLUMNS.items():
            v = columns.get(name, default)
            self._columns[name][a:b] = np.broadcast_to(np.asarray(v, dtype=dtype), (k, *shape))
        self._written = b

    def set_last(self, **values) -> None:
        """Change columns of the most recent segment (e.g. G9's exact stop set after the move)."""
        if len(self) == 0:
            raise IndexError("no segment yet")
        if self._rows["kind"]:
            for name, v in values.items():
                self._rows[name][-1] = v
        else:
            self._reserve(0)           # a built path keeps its values
            for name, v in values.items():
                self._columns[name][self._written - 1] = v

    def build(self) -> Path:
        """The Path of all rows so far: the columns themselves, cut to length."""
        self._flush_rows()
        n = self._written
        if self._columns is None:
            self._reserve(0)
        cols = {}
        for name, col in self._columns.items():
            if len(col) != n:
                if self._shared:
                    col = col[:n].copy()
                else:          # shrink in place (realloc), the rows past n were never used
                    col.resize((n, *col.shape[1:]), refcheck=False)
            cols[name] = col
        self._columns = cols
        self._capacity = n
        self._shared = True
        return Path(**cols, files=tuple(self.files), end_dwell_s=self.end_dwell_s)


def path_columns() -> tuple[str, ...]:
    return tuple(f.name for f in fields(Path) if f.name in _COLUMNS)
