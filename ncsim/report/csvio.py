"""Trace CSV files: fast fixed-point writing, and reading back.

A trace CSV has one header line of column names (units in the names) and one row per sample::

    t_s,s_mm,x_mm,y_mm,z_mm,feed_mm_min,block,line,limit
    0.012000,0.00004,30.00000,0.00004,0.00000,0.611,0,7,program_end

Feeds are written in mm/min (the unit of F and of the 840D's displays), converted here at the
edge; everything else is in ncsim's internal mm and s. ``limit`` and ``phase`` are written as
their labels (``ncu_path_jerk``, ``A``...).

Writing never formats numbers with Python. Per chunk of rows (memory stays bounded) each
value becomes the integer ``round(x * 10^d)`` (numpy), and a compiled loop
(``csvformat.format_csv_rows``) writes the rows' bytes: sign, digits two at a time from a
100-entry table, point, labels. A pure-numpy formatter (:func:`format_rows`) does the same
with vectorised scatters; it is used for the rare chunks with values outside the integer path
(inf, nan, |x| 10^d >= 1e18, formatted by Python one by one), and for small chunks as long
as numba is not loaded (``ncsim.jit``), and tests hold the two to byte-identical output. About 2.5 million rows per second for the default columns on a 2-core
machine, against ~0.15 million for ``np.savetxt`` (``benchmarks/bench_trace_io.py``).

Reading takes the file in the dialect of :mod:`ncsim.config` (the one ``ncsim gap`` reads
too), parses it with ``np.loadtxt``, then checks it: any problem is one
:class:`~ncsim.errors.MeasuredDataError` line naming the file and the line or column.
"""
from __future__ import annotations

import io
import os
from dataclasses import dataclass
from typing import Callable, Iterable, Mapping

import numpy as np

from ncsim.errors import MeasuredDataError, UsageError
from ncsim.config import read_table, table_from_text
from ncsim.motion import Limit, Phase
from ncsim.motion import Trace
from ncsim.units import mm_min_to_mm_s, mm_s_to_mm_min

CHUNK_ROWS = 1 << 16
MAX_DECIMALS = 12
_SPECIAL_ABS = 1e18           # |x| 10^d at or above this is formatted by Python
_LUT4 = np.frombuffer("".join(f"{i:04d}" for i in range(10000)).encode("ascii"),
                      dtype=np.uint32)  # 4 ASCII digits per entry, in memory order
_POW10 = [10 ** k for k in range(19)]

FLOAT, INT, LABEL = "float", "int", "label"
PHASE_LABELS = tuple(p.name for p in Phase)
LIMIT_LABELS = tuple(m.label for m in Limit)


@dataclass(frozen=True, slots=True)
class Column:
    """One CSV column: how to get it from a Trace and how many decimals by default."""

    name: str
    kind: str                                    # FLOAT, INT or LABEL
    get: Callable[[Trace, slice], np.ndarray]    # values for rows ``sl`` (file units)
    decimals: int = 0
    labels: tuple[str, ...] = ()                 # LABEL: code -> text


def _axis(attr: str, i: int):
    return lambda tr, sl: getattr(tr, attr)[sl, i]


def _attr(attr: str):
    return lambda tr, sl: getattr(tr, attr)[sl]


def _per_min(attr: str):
    return lambda tr, sl: mm_s_to_mm_min(getattr(tr, attr)[sl])


_COLUMN_LIST = [
    Column("t_s", FLOAT, _attr("t_s"), 6),
    Column("s_mm", FLOAT, _attr("s_mm"), 5),
    *(Column(f"{a}_mm", FLOAT, _axis("pos_mm", i), 5) for i, a in enumerate("xyz")),
    Column("feed_mm_min", FLOAT, _per_min("feed_mm_s"), 3),
    Column("block", INT, _attr("block")),
    Column("line", INT, _attr("line")),
    Column("limit", LABEL, _attr("limit"), labels=LIMIT_LABELS),
    *(Column(f"v{a}_mm_s", FLOAT, _axis("vel_mm_s", i), 4) for i, a in enumerate("xyz")),
    *(Column(f"a{a}_mm_s2", FLOAT, _axis("acc_mm_s2", i), 3) for i, a in enumerate("xyz")),
    *(Column(f"j{a}_mm_s3", FLOAT, _axis("jerk_mm_s3", i), 2) for i, a in enumerate("xyz")),
    Column("accel_t_mm_s2", FLOAT, _attr("accel_t_mm_s2"), 3),
    Column("jerk_t_mm_s3", FLOAT, _attr("jerk_t_mm_s3"), 2),
    Column("accel_n_mm_s2", FLOAT, _attr("accel_n_mm_s2"), 3),
    Column("jerk_n_mm_s3", FLOAT, _attr("jerk_n_mm_s3"), 2),
    Column("phase", LABEL, _attr("phase"), labels=PHASE_LABELS),
    Column("setpoint_mm_min", FLOAT, _per_min("setpoint_mm_s"), 3),
    Column("programmed_mm_min", FLOAT, _per_min("programmed_mm_s"), 3),
]
COLUMNS: dict[str, Column] = {c.name: c for c in _COLUMN_LIST}
DEFAULT_COLUMNS = ("t_s", "s_mm", "x_mm", "y_mm", "z_mm", "feed_mm_min", "block", "line", "limit")
ALL_COLUMNS = tuple(COLUMNS)


# ---------------------------------------------------------------------------------------------
# Vectorised fixed-point formatting
# ---------------------------------------------------------------------------------------------

_LUT_CHAR = [np.ascontiguousarray(_LUT4.view(np.uint8).reshape(10000, 4)[:, c]) for c in range(4)]


def _digit_rows(q: np.ndarray, n: int) -> list[np.ndarray]:
    """The last ``n`` decimal digits of non-negative int64 ``q`` as ASCII, most significant
    first, each a contiguous (m,) uint8 array (zero-padded). Four digits per integer division:
    ``r = q - (q // 10^4) 10^4`` (numpy divides by a constant much faster than it takes ``%``),
    then one lookup per digit in a 10,000-entry table."""
    out: list[np.ndarray] = []
    while len(out) < n:
        hi = q // 10000
        r = q - hi * 10000
        first = max(0, 4 - (n - len(out)))   # the top group may need fewer than 4 digits
        out = [_LUT_CHAR[c].take(r) for c in range(first, 4)] + out
        q = hi
    return out


class _Slots:
    """The characters of one column in one chunk of rows, as slots from left to right.

    A slot is ``(chars, keep)``: the byte each row writes there (a number, or (m,) contiguous
    uint8) and which rows have it (None: every row, else a bool (m,)). A row's text is its
    kept characters in slot order; ``length`` is how many that is.
    """

    __slots__ = ("slots", "length")

    def __init__(self, length: np.ndarray):
        self.length = length
        self.slots: list[tuple] = []


def _numeric_slots(values: np.ndarray, decimals: int, integer: bool) -> _Slots:
    """A fixed-point column: the sign, the digits of 10^p for p >= 1 only where significant,
    the units digit, the point and ``decimals`` digits. Values that do not fit an int64 once
    scaled (inf, nan, |x| 10^d >= 1e18) are formatted by Python, in extra leading slots."""
    m = len(values)
    special = None
    if integer:
        v = np.asarray(values).astype(np.int64, copy=False)
        y, neg = np.abs(v), v < 0
    else:
        with np.errstate(over="ignore", invalid="ignore"):  # huge values become special
            yf = np.multiply(values, float(10 ** decimals), dtype=np.float64)
        np.rint(yf, out=yf)
        neg = yf < 0                      # -0.0 is not negative: "-0.000" is never written
        np.abs(yf, out=yf)
        if not yf.max() < _SPECIAL_ABS:   # also when there is a nan
            special = np.flatnonzero(~(yf < _SPECIAL_ABS))
            yf[special] = 0.0
            neg[special] = False
        y = yf.astype(np.int64)
    d = decimals
    n_int = max(1, len(str(int(y.max()) // _POW10[d])))
    digits = _digit_rows(y, n_int + d)
    length = np.full(m, 1 + (1 + d if d else 0), dtype=np.int64)  # units, point, decimals
    out = _Slots(length)
    always = None
    if special is not None:               # Python-formatted rows first (right-aligned text)
        always = np.ones(m, dtype=bool)
        always[special] = False
        texts = [f"{x:.{d}f}".encode("ascii") for x in np.asarray(values)[special].tolist()]
        width = max(len(t) for t in texts)
        for k in range(width):
            chars = np.zeros(m, dtype=np.uint8)
            keep = np.zeros(m, dtype=bool)
            for row, t in zip(special, texts):
                if k >= width - len(t):
                    chars[row] = t[k - (width - len(t))]
                    keep[row] = True
            out.slots.append((chars, keep))
        length[special] = [len(t) for t in texts]
    if neg.any():
        out.slots.append((ord("-"), neg))
        length += neg
    for k in range(n_int - 1):            # digit of 10^(n_int - 1 - k)
        sig = y >= _POW10[d + n_int - 1 - k]
        if always is None and sig.all():
            out.slots.append((digits[k], None))
            length += 1
        else:
            out.slots.append((digits[k], sig))
            length += sig
    out.slots.append((digits[n_int - 1], always))
    if d:
        out.slots.append((ord("."), always))
        out.slots.extend((digits[k], always) for k in range(n_int, n_int + d))
    return out


def _label_slots(codes: np.ndarray, labels: tuple[str, ...], name: str) -> _Slots:
    """A label column, right-aligned: the first characters only where the label is long
    enough."""
    codes = np.asarray(codes).astype(np.intp, copy=False)
    if len(codes) and (codes.min() < 0 or codes.max() >= len(labels)):
        bad = int(codes[(codes < 0) | (codes >= len(labels))][0])
        raise UsageError(f"column {name!r}: code {bad} has no label (valid: 0..{len(labels) - 1})")
    width = max(len(s) for s in labels)
    shortest = min(len(s) for s in labels)
    table = np.zeros((width, len(labels)), dtype=np.uint8)  # right-aligned, zero-padded
    for i, s in enumerate(labels):
        table[width - len(s):, i] = np.frombuffer(s.encode("ascii"), dtype=np.uint8)
    sizes = np.array([len(s) for s in labels], dtype=np.int64)
    length = np.take(sizes, codes)
    out = _Slots(length)
    for k in range(width):
        keep = None if k >= width - shortest else length >= width - k
        out.slots.append((np.take(table[k], codes), keep))
    return out


def format_rows(columns: list[np.ndarray], kinds: list[str], decimals: list[int],
                labels: list[tuple[str, ...]] | None = None, names: list[str] | None = None) -> bytes:
    """CSV rows (no header) for equal-length value arrays, one per column: FLOAT columns with
    their fixed number of decimals, INT columns as integers, LABEL columns as ``labels[code]``.

    Each column is a list of character slots (:class:`_Slots`). Row lengths are known before
    any byte is written, so each row's start is known; every slot is then written for all rows
    at once (one scatter at each row's current position), and a row's position advances only
    where it keeps the slot. A character a row does not keep is overwritten by the row's next
    kept one (every row ends with a kept newline): nothing needs squeezing out afterwards.
    """
    labels = labels or [()] * len(columns)
    names = names or [f"#{i}" for i in range(len(columns))]
    m = len(columns[0]) if columns else 0
    if m == 0:
        return b""
    from ncsim.report.csvformat import format_csv_rows
    if format_csv_rows.runs_compiled(m):  # small chunks: numpy, without starting numba
        fast = _format_rows_compiled(columns, kinds, decimals, labels, names)
        if fast is not None:
            return fast
    fields = [_label_slots(v, lab, nm) if kind == LABEL else _numeric_slots(v, d, kind == INT)
              for v, kind, d, lab, nm in zip(columns, kinds, decimals, labels, names)]
    row_len = sum(f.length for f in fields) + len(fields)
    pos = np.empty(m, dtype=np.int64)
    pos[0] = 0
    np.cumsum(row_len[:-1], out=pos[1:])
    buf = np.empty(int(pos[-1] + row_len[-1]), dtype=np.uint8)
    for i, f in enumerate(fields):
        for chars, keep in f.slots:
            buf[pos] = chars
            if keep is None:
                pos += 1
            else:
                pos += keep
        buf[pos] = ord(",") if i < len(fields) - 1 else ord("\n")
        pos += 1
    return buf.tobytes()


def _format_rows_compiled(columns, kinds, decimals, labels, names) -> bytes | None:
    """The same rows as the numpy path, written by a compiled loop (``csvformat.format_csv_rows``);
    None when a value needs Python's formatting (inf, nan, |x| 10^d >= 1e18)."""
    from ncsim.report.csvformat import format_csv_rows

    m, k = len(columns[0]), len(columns)
    ints = np.empty((m, k), dtype=np.int64)
    neg = np.zeros((m, k), dtype=np.bool_)
    kind = np.empty(k, dtype=np.int8)
    width = max([max((len(s) for s in lab), default=1) for lab in labels] + [1])
    n_lab = max([len(lab) for lab in labels] + [1])
    table = np.zeros((k, n_lab, width), dtype=np.uint8)
    table_len = np.zeros((k, n_lab), dtype=np.int64)
    room = 0
    for c, (v, kd, d, lab, nm) in enumerate(zip(columns, kinds, decimals, labels, names)):
        if kd == LABEL:
            codes = np.asarray(v).astype(np.int64, copy=False)
            if codes.min() < 0 or codes.max() >= len(lab):
                return None  # the numpy path reports the bad code
            ints[:, c] = codes
            for i, s in enumerate(lab):
                table[c, i, :len(s)] = np.frombuffer(s.encode("ascii"), dtype=np.uint8)
                table_len[c, i] = len(s)
            kind[c] = 2
            room += width
        else:
            if kd == INT:
                iv = np.asarray(v).astype(np.int64, copy=False)
                neg[:, c] = iv < 0
                ints[:, c] = np.abs(iv)
                kind[c] = 1
            else:
                with np.errstate(over="ignore", invalid="ignore"):
                    y = np.rint(np.multiply(v, float(10 ** d), dtype=np.float64))
                if not np.abs(y).max() < _SPECIAL_ABS:
                    return None
                neg[:, c] = y < 0
                ints[:, c] = np.abs(y).astype(np.int64)
                kind[c] = 0
            room += 21 + d
    out = np.empty(m * (room + k), dtype=np.uint8)
    used = format_csv_rows(ints, neg, kind, np.asarray(decimals, dtype=np.int64), table,
                           table_len, out)
    return out[:used].tobytes()


# ---------------------------------------------------------------------------------------------
# Writing
# ---------------------------------------------------------------------------------------------

def _resolve_columns(columns) -> list[Column]:
    if columns is None:
        names = list(DEFAULT_COLUMNS)
    elif isinstance(columns, str):
        names = list(ALL_COLUMNS) if columns == "all" else [c.strip() for c in columns.split(",")]
    else:
        names = list(columns)
    unknown = [n for n in names if n not in COLUMNS]
    if unknown:
        raise UsageError(f"unknown trace column {unknown[0]!r} (known: {', '.join(ALL_COLUMNS)})")
    if len(set(names)) != len(names):
        dup = next(n for n in names if names.count(n) > 1)
        raise UsageError(f"trace column {dup!r} requested twice")
    if not names:
        raise UsageError("no trace columns requested")
    return [COLUMNS[n] for n in names]


def _resolve_decimals(cols: list[Column], decimals) -> list[int]:
    if decimals is None:
        decimals = {}
    if isinstance(decimals, Mapping):
        unknown = [k for k in decimals if k not in COLUMNS]
        if unknown:
            raise UsageError(f"decimals given for unknown column {unknown[0]!r}")
        out = [decimals.get(c.name, c.decimals) if c.kind == FLOAT else 0 for c in cols]
    else:
        out = [decimals if c.kind == FLOAT else 0 for c in cols]
    for c, d in zip(cols, out):
        if isinstance(d, bool) or not isinstance(d, (int, np.integer)) or not 0 <= d <= MAX_DECIMALS:
            raise UsageError(f"decimals for column {c.name!r} must be an integer in "
                             f"0..{MAX_DECIMALS}, got {d!r}")
    return [int(d) for d in out]


class _Sink:
    """Binary writes to a path, a binary file or a text file (decoded as ASCII)."""

    def __init__(self, file):
        self.close_after = False
        self.name = os.fspath(file) if isinstance(file, (str, os.PathLike)) else getattr(file, "name", "<trace>")
        if isinstance(file, (str, os.PathLike)):
            try:
                self.f = open(file, "wb")
            except OSError as exc:
                raise self._error(exc) from None
            self.close_after = True
            self.text = False
        else:
            self.f = file
            self.text = isinstance(file, io.TextIOBase)

    def _error(self, exc: OSError) -> UsageError:
        """A full disk, a closed pipe...: one line naming the file, never a traceback."""
        return UsageError(f"{self.name}: cannot write trace file: {exc.strerror or exc}")

    def write(self, data: bytes) -> None:
        try:
            self.f.write(data.decode("ascii") if self.text else data)
        except OSError as exc:
            self.close(failed=True)
            raise self._error(exc) from None

    def close(self, failed: bool = False) -> None:
        if not self.close_after:
            return
        self.close_after = False
        try:
            self.f.close()          # flushes: a full disk may show only here
        except OSError as exc:
            if not failed:
                raise self._error(exc) from None


def write_trace_csv(trace: Trace, file, *, columns: Iterable[str] | str | None = None,
                    decimals: int | Mapping[str, int] | None = None,
                    chunk_rows: int = CHUNK_ROWS) -> int:
    """Write ``trace`` as CSV to ``file`` (a path, or a binary or text file object).

    ``columns``: names from :data:`COLUMNS` (default :data:`DEFAULT_COLUMNS`; ``"all"`` for
    every column, or a comma-separated string). ``decimals``: one number for every float
    column, or a mapping from column name to decimals overriding the per-column defaults.
    Returns the number of rows written.
    """
    cols = _resolve_columns(columns)
    decs = _resolve_decimals(cols, decimals)
    if chunk_rows < 1:
        raise UsageError(f"chunk_rows must be at least 1, got {chunk_rows}")
    sink = _Sink(file)
    try:
        sink.write((",".join(c.name for c in cols) + "\n").encode("ascii"))
        n = len(trace)
        for lo in range(0, n, chunk_rows):
            sl = slice(lo, min(lo + chunk_rows, n))
            sink.write(format_rows([c.get(trace, sl) for c in cols], [c.kind for c in cols],
                                   decs, [c.labels for c in cols], [c.name for c in cols]))
    finally:
        sink.close()
    return len(trace)


# ---------------------------------------------------------------------------------------------
# Reading
# ---------------------------------------------------------------------------------------------

_LABEL_CODES = {"limit": {s: i for i, s in enumerate(LIMIT_LABELS)},
                "phase": {s: i for i, s in enumerate(PHASE_LABELS)}}


def _label_code(text: str, column: str) -> int:
    table = _LABEL_CODES[column]
    code = table.get(text)
    if code is None:
        code = table.get(text.lower() if column == "limit" else text.upper(), -1)
    return code


def _label_converter(column: str):
    """A cell of a label column -> its code (ValueError naming the labels for another)."""
    labels = LIMIT_LABELS if column == "limit" else PHASE_LABELS

    def convert(text: str) -> float:
        code = _label_code(text.strip().strip('"').strip(), column)
        if code < 0:
            raise ValueError(f"unknown label {text.strip()!r} (expected one of {', '.join(labels)})")
        return float(code)
    return convert


def read_trace_csv(file) -> dict[str, np.ndarray]:
    """Read a trace CSV (as written by :func:`write_trace_csv`, or any CSV with a ``t_s``
    column) into columns, in the units of their names: ``block``/``line`` as int64,
    ``limit``/``phase`` as their int8 codes (:class:`~ncsim.motion.Limit`,
    :class:`~ncsim.motion.Phase`), everything else float64 (``inf`` and ``nan`` allowed: a
    rapid's programmed feed is ``inf``). The file is read in the dialect of
    :func:`ncsim.config.read_table`, as ``ncsim gap --measured`` reads it. Any problem raises a
    one-line :class:`~ncsim.errors.MeasuredDataError` naming the file and line or column.
    """
    if isinstance(file, (str, os.PathLike)):
        table = read_table(file, "trace file")
    else:                                    # a file object
        data = file.read()
        name = str(getattr(file, "name", "<trace>"))
        try:
            text = data.decode("utf-8-sig") if isinstance(data, bytes) else data
        except UnicodeDecodeError as exc:
            raise MeasuredDataError(f"cannot read trace file: not UTF-8 text (byte {exc.start})",
                                    file=name) from None
        table = table_from_text(text.lstrip("\ufeff"), name)
    names, name = table.header, table.file
    twice = next((n for i, n in enumerate(names) if n and names.index(n) != i), None)
    if twice is not None:
        raise MeasuredDataError("column named twice in the header", file=name, column=twice)
    if "t_s" not in names:
        raise MeasuredDataError("missing column (every trace needs a time column)", file=name,
                                column="t_s")
    converters = {i: _label_converter(n) for i, n in enumerate(names) if n in _LABEL_CODES}
    named = [i for i, n in enumerate(names) if n]    # an unnamed column (pandas' index) is left
    values = table.floats(named, finite=False, converters=converters or None)
    out: dict[str, np.ndarray] = {}
    for k, i in enumerate(named):
        col, column = names[i], values[:, k]
        if i in converters:
            out[col] = column.astype(np.int8)
        elif col in ("block", "line"):
            bad = ~np.isfinite(column) | (column != np.round(column))
            if bad.any():
                raise MeasuredDataError(f"column '{col}': expected an integer", file=name,
                                        line=table.line_of(int(np.flatnonzero(bad)[0])))
            out[col] = column.astype(np.int64)
        else:
            out[col] = np.ascontiguousarray(column)
    t = out["t_s"]
    bad = np.flatnonzero(~np.isfinite(t))
    if len(bad):
        raise MeasuredDataError("column 't_s': time must be a finite number", file=name,
                                line=table.line_of(int(bad[0])))
    back = np.flatnonzero(np.diff(t) < 0)
    if len(back):
        row = int(back[0]) + 1
        raise MeasuredDataError(f"column 't_s': time goes backwards ({t[row]:g} s after "
                                f"{t[row - 1]:g} s)", file=name, line=table.line_of(row))
    return out


def trace_from_columns(columns: Mapping[str, np.ndarray]) -> Trace:
    """A :class:`Trace` from CSV columns (``read_trace_csv``): feeds back to mm/s; columns not
    in the file are NaN (numbers), -1 (block, line), ``Limit.NONE`` or ``Phase.STOP``."""
    t = np.asarray(columns["t_s"], dtype=np.float64)
    m = len(t)

    def num(key, convert=None):
        if key not in columns:
            return np.full(m, np.nan)
        v = np.asarray(columns[key], dtype=np.float64)
        return convert(v) if convert else v

    def vec(keys):
        return np.stack([num(k) for k in keys], axis=1) if m else np.zeros((0, 3))

    return Trace(
        t_s=t, s_mm=num("s_mm"), feed_mm_s=num("feed_mm_min", mm_min_to_mm_s),
        accel_t_mm_s2=num("accel_t_mm_s2"), jerk_t_mm_s3=num("jerk_t_mm_s3"),
        accel_n_mm_s2=num("accel_n_mm_s2"), jerk_n_mm_s3=num("jerk_n_mm_s3"),
        pos_mm=vec(["x_mm", "y_mm", "z_mm"]), vel_mm_s=vec(["vx_mm_s", "vy_mm_s", "vz_mm_s"]),
        acc_mm_s2=vec(["ax_mm_s2", "ay_mm_s2", "az_mm_s2"]),
        jerk_mm_s3=vec(["jx_mm_s3", "jy_mm_s3", "jz_mm_s3"]),
        block=np.asarray(columns.get("block", np.full(m, -1)), dtype=np.int32),
        line=np.asarray(columns.get("line", np.full(m, -1)), dtype=np.int32),
        limit=np.asarray(columns.get("limit", np.full(m, Limit.NONE)), dtype=np.int8),
        phase=np.asarray(columns.get("phase", np.full(m, Phase.STOP)), dtype=np.int8),
        setpoint_mm_s=num("setpoint_mm_min", mm_min_to_mm_s),
        programmed_mm_s=num("programmed_mm_min", mm_min_to_mm_s),
    )
