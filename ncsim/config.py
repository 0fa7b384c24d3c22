"""One reader for ncsim's files: the TOML of machine files, setup files and published values,
and the CSV tables of traces and recordings (:func:`read_table`).

Every TOML file goes through :func:`read_toml`, and every key through a :class:`Problems`
collector, so all three formats fail the same way: one line per file, never a traceback::

    FILE: cannot read machine file: No such file or directory
    FILE: cannot read setup file: not UTF-8 text (byte 0xe9 at line 3, column 7)
    FILE: not valid TOML: Expected '=' after a key in a key/value pair (at line 2, column 5)
    FILE: key.path: message (and 2 more: other.key: message; ...)

Problems with keys (missing, unknown, mistyped, out of range) are all collected before the
file is rejected, so one run names every mistake. Each format raises its own error class
(:class:`~ncsim.errors.MachineSpecError` for machine and setup files,
:class:`~ncsim.errors.MeasuredDataError` for published values); all render as above. Values
keep their unit in the key (``max_accel_m_s2``); converters from ``ncsim.units`` turn them into
mm and s as they are read.

The schemas live with what they describe: the machine file in ``ncsim.machine``, the
published values in ``ncsim.gap.measured``; the setup file, which is only work offsets, here
(:func:`load_setup`).

**CSV tables** (:class:`CsvTable`): a header, a dialect and numeric columns, read fast. The one
CSV reader of ncsim: ``ncsim gap --measured`` (``gap.measured``) and ``ncsim plot --trace``
(``report.csvio``) read through it, so they accept the same files.

The dialect ``ncsim gap --measured`` accepts: UTF-8 (a byte-order mark is dropped), any line
ends, one header row, blank lines and lines starting with ``#`` skipped, delimiter ``,`` ``;``
or tab (the one the header uses most), fields optionally in double quotes. Every data row has
as many fields as the header: a row with one field more (``1,5`` written with a decimal comma)
is an error, never a shifted row. Numbers are what ``float`` reads without ``_`` digit
separators; NaN and infinities are errors (unless the reader allows them: a written trace
holds ``inf`` for a rapid's programmed feed), and a column of labels is read by the reader's
converter.

Numeric columns are parsed in one call of numpy's compiled ``np.loadtxt`` (about 0.5 s for a
million rows of four columns); only when that fails, or the field count does not add up, are
the rows walked one by one to name the first bad line (:meth:`CsvTable.floats`). Errors are
one-line :class:`~ncsim.errors.MeasuredDataError` naming the file and the line or column.
"""
from __future__ import annotations

import csv
import io
import math
import os
import re
import stat
import tomllib
import warnings
from dataclasses import dataclass, field
from importlib.resources.abc import Traversable
from pathlib import Path as FsPath
from typing import Any, Callable

import numpy as np

from ncsim.errors import ConfigError, ConfigWarning, MachineSpecError, MeasuredDataError

ErrorClass = Callable[..., Exception]   # called as cls(message, file=..., key=...)


# ---------------------------------------------------------------------------------------------
# Reading
# ---------------------------------------------------------------------------------------------

#: what a path that is not a regular file is, for the message refusing it
_FILE_KINDS = ((stat.S_ISDIR, "a directory"), (stat.S_ISFIFO, "a named pipe (FIFO)"),
               (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
               (stat.S_ISSOCK, "a socket"))
#: the largest TOML file read (machine, setup and published-value files are kilobytes)
MAX_TOML_BYTES = 16 * 1024 * 1024


def not_regular(mode: int) -> str | None:
    """What a file of ``st_mode`` is when it is not a regular file (None for a regular file)."""
    if stat.S_ISREG(mode):
        return None
    return next((kind for test, kind in _FILE_KINDS if test(mode)), "not a regular file")


def read_bytes(path: str | os.PathLike, what: str, *, name: str | None = None,
               error: ErrorClass = ConfigError, max_bytes: int | None = None) -> bytes:
    """The bytes of a user's file ``path``, refused before reading unless it is a regular
    file: a named pipe would block the reader until something writes to it (forever in a
    batch), a device such as ``/dev/zero`` never ends. ``what`` names the file in messages
    (``"program"``), ``name`` is the ``FILE`` they start with; a file over ``max_bytes`` is
    refused too. The file is opened without blocking and checked again once open."""
    file = str(path) if name is None else name
    try:
        kind = not_regular(os.stat(path).st_mode)
        if kind is None:
            fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_BINARY", 0))
            with open(fd, "rb") as fh:
                info = os.fstat(fh.fileno())
                kind = not_regular(info.st_mode)
                if kind is None and (max_bytes is None or info.st_size <= max_bytes):
                    return fh.read()
    except OSError as exc:
        raise error(f"cannot read {what}: {exc.strerror or exc}", file=file) from None
    if kind is not None:
        raise error(f"cannot read {what}: {kind}, not a regular file", file=file)
    raise error(f"cannot read {what}: {info.st_size:,} bytes, more than a {what} can be "
                f"(at most {max_bytes:,})", file=file)


def read_text(source: str | FsPath | Traversable, what: str, *, name: str | None = None,
              error: ErrorClass = ConfigError, max_bytes: int | None = None) -> str:
    """The UTF-8 text of ``source`` (a path, read by :func:`read_bytes`, or a resource of an
    installed package; a byte-order mark is dropped). ``what`` names the file in messages
    (``"machine file"``), ``name`` is the ``FILE`` they start with (default: ``source``
    itself)."""
    file = str(source) if name is None else name
    if isinstance(source, (str, os.PathLike)):
        data = read_bytes(source, what, name=file, error=error, max_bytes=max_bytes)
    else:
        try:
            data = source.read_bytes()
        except OSError as exc:
            raise error(f"cannot read {what}: {exc.strerror or exc}", file=file) from None
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = data.count(b"\n", 0, exc.start) + 1
        column = exc.start - (data.rfind(b"\n", 0, exc.start) + 1) + 1
        raise error(f"cannot read {what}: not UTF-8 text (byte 0x{data[exc.start]:02x} at line "
                    f"{line}, column {column})", file=file) from None


def parse_toml(text: str, file: str, *, error: ErrorClass = ConfigError) -> dict[str, Any]:
    """The parsed ``text``; a syntax error, or arrays and tables nested deeper than Python's
    recursive parser (``tomllib``) goes, is ``FILE: not valid TOML: ...``."""
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise error(f"not valid TOML: {exc}", file=file) from None
    except RecursionError:
        raise error("not valid TOML: arrays or inline tables nested too deeply (Python's TOML "
                    "reader goes to a few hundred levels)", file=file) from None


def read_toml(source: str | FsPath | Traversable, what: str, *, name: str | None = None,
              error: ErrorClass = ConfigError) -> dict[str, Any]:
    """The parsed TOML of ``source`` (see :func:`read_text`), at most ``MAX_TOML_BYTES``."""
    file = str(source) if name is None else name
    return parse_toml(read_text(source, what, name=file, error=error, max_bytes=MAX_TOML_BYTES),
                      file, error=error)


# ---------------------------------------------------------------------------------------------
# Checking keys
# ---------------------------------------------------------------------------------------------

def positive(v: float) -> str | None:
    return None if v > 0 and math.isfinite(v) else "must be a positive number"


def non_negative(v: float) -> str | None:
    return None if v >= 0 and math.isfinite(v) else "must be zero or positive"


@dataclass(frozen=True, slots=True)
class Range:
    """A check for a value in ``[lo, hi]`` (an end excluded when ``lo_open`` / ``hi_open``), in
    the file's ``unit``: the physically possible range of a key, wide enough for any real
    machine, narrow enough that no arithmetic on it overflows or divides by (almost) zero.
    Called with a value, it returns the problem or None; its ends are there for tests that draw
    values across the whole accepted range."""

    lo: float
    hi: float
    unit: str = ""
    lo_open: bool = False
    hi_open: bool = False

    def __call__(self, v: float) -> str | None:
        above = v > self.lo if self.lo_open else v >= self.lo
        below = v < self.hi if self.hi_open else v <= self.hi
        if above and below:
            return None
        if self.unit:
            return f"must be between {self.lo:g} and {self.hi:g} {self.unit}"
        left, right = "(" if self.lo_open else "[", ")" if self.hi_open else "]"
        exclusive = ", exclusive" if self.lo_open and self.hi_open else ""
        return f"must be in {left}{self.lo:g}, {self.hi:g}{right}{exclusive}"


share = Range(0.0, 1.0, lo_open=True)               # (0, 1]
share0 = Range(0.0, 1.0)                            # [0, 1]
open_share = Range(0.0, 1.0, lo_open=True, hi_open=True)   # (0, 1)


def finite(v: float) -> str | None:
    return None if math.isfinite(v) else "must be a finite number"


def between(lo: float, hi: float, unit: str) -> Range:
    """A check for ``lo <= v <= hi`` in the file's ``unit`` (:class:`Range`)."""
    return Range(lo, hi, unit)


#: |coordinate| of a work offset: the 840D's input range for positions (+-999 999 999.9999)
MAX_OFFSET_MM = 1e9


def is_number(v: object) -> bool:
    """An int or a float, but not a bool (TOML ``true`` is no number)."""
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def key_path(prefix: str, key: str) -> str:
    return f"{prefix}.{key}" if prefix else key


class Problems:
    """Collects the problems of one file and raises them together (module docstring).

    The typed getters return the converted value, or None when the key is absent (after
    noting it if ``required``) or wrong (after noting the problem)."""

    def __init__(self, file: str, error: ErrorClass = ConfigError):
        self.file = file
        self.error = error
        self.items: list[tuple[str, str]] = []
        self.warnings: list[ConfigWarning] = []

    def __bool__(self) -> bool:
        return bool(self.items)

    def add(self, key: str, message: str) -> None:
        self.items.append((key, message))

    def raise_if_any(self) -> None:
        if not self.items:
            return
        key, message = self.items[0]
        if len(self.items) > 1:
            others = "; ".join(f"{k}: {m}" for k, m in self.items[1:])
            message += f" (and {len(self.items) - 1} more: {others})"
        raise self.error(message, file=self.file, key=key)

    def unknown(self, table: dict, prefix: str, known, message: str = "unknown key") -> None:
        """Note every key of ``table`` not in ``known``."""
        for key in table:
            if key not in known:
                self.add(key_path(prefix, key), message)

    def table(self, data: dict, key: str, *, prefix: str = "", required: bool = False) -> dict:
        """The table ``data[key]`` ({} when absent or not a table)."""
        full = key_path(prefix, key)
        if key not in data:
            if required:
                self.add(full, "missing table")
            return {}
        value = data[key]
        if not isinstance(value, dict):
            self.add(full, f"must be a table, got {type(value).__name__}")
            return {}
        return value

    def _lookup(self, table: dict, prefix: str, key: str, required: bool):
        """``(key path, value)`` of ``table[key]``, or None when absent (noted if required)."""
        if key in table:
            return key_path(prefix, key), table[key]
        if required:
            self.add(key_path(prefix, key), "missing key")
        return None

    def number(self, table: dict, prefix: str, key: str, *, required: bool = False,
               check: Callable[[float], str | None] | None = finite,
               convert: Callable[[float], Any] = float):
        """A number (int or float), checked (``check`` returns a problem or None) in the file's
        unit, then converted (e.g. ``units.m_s2_to_mm_s2``)."""
        found = self._lookup(table, prefix, key, required)
        if found is None:
            return None
        full, value = found
        if not is_number(value):
            self.add(full, f"must be a number, got {type(value).__name__} {value!r}")
            return None
        value = float(value)
        problem = check(value) if check is not None else None
        if problem:
            self.add(full, f"{problem}, got {value:g}")
            return None
        return convert(value)

    def numbers(self, data: dict, name: str, keys) -> dict[str, Any]:
        """The numbers of table ``name`` of ``data``, as {field: value}: ``keys`` are tuples
        (toml key, field, required, check, convert) as :meth:`number` takes them; a key not
        among them is a problem."""
        table = self.table(data, name)
        self.unknown(table, name, {k for k, *_ in keys})
        return {f: v for k, f, req, chk, conv in keys
                if (v := self.number(table, name, k, required=req, check=chk, convert=conv))
                is not None}

    def integer(self, table: dict, prefix: str, key: str, *, required: bool = False,
                minimum: int = 1, maximum: int | None = None) -> int | None:
        found = self._lookup(table, prefix, key, required)
        if found is None:
            return None
        full, value = found
        if isinstance(value, bool) or not isinstance(value, int):
            self.add(full, f"must be an integer, got {type(value).__name__} {value!r}")
        elif value < minimum or (maximum is not None and value > maximum):
            self.add(full, f"must be an integer >= {minimum}" if maximum is None else
                     f"must be an integer from {minimum} to {maximum}, got {value}")
        else:
            return value
        return None

    def string(self, table: dict, prefix: str, key: str, *, required: bool = False,
               non_empty: bool = False) -> str | None:
        found = self._lookup(table, prefix, key, required)
        if found is None:
            return None
        full, value = found
        if isinstance(value, str) and (value or not non_empty):
            return value
        self.add(full, "must be a non-empty string" if non_empty else "must be a string")
        return None

    def boolean(self, table: dict, prefix: str, key: str) -> bool | None:
        found = self._lookup(table, prefix, key, False)
        if found is None or isinstance(found[1], bool):
            return None if found is None else found[1]
        self.add(found[0], "must be true or false")
        return None

    def xyz_mm(self, table: dict, prefix: str, key: str) -> tuple[float, float, float] | None:
        """A point ``[x_mm, y_mm, z_mm]`` of three finite numbers within ``MAX_OFFSET_MM``."""
        value = table.get(key)
        if not isinstance(value, list) or len(value) != 3 or not all(is_number(v) for v in value):
            self.add(key_path(prefix, key), "must be a list of three numbers [x_mm, y_mm, z_mm]")
            return None
        if not all(abs(v) < MAX_OFFSET_MM for v in value):   # also NaN and inf
            shown = ", ".join(f"{float(v):g}" for v in value)
            self.add(key_path(prefix, key), f"must be three finite numbers of magnitude below "
                     f"{MAX_OFFSET_MM:g} mm (the 840D's position range), got [{shown}]")
            return None
        return tuple(float(v) for v in value)

    def warn(self, key: str, message: str) -> None:
        """Note a value that is accepted but looks wrong (:class:`ConfigWarning`)."""
        self.warnings.append(ConfigWarning(message, self.file, key))


# ---------------------------------------------------------------------------------------------
# Setup files
# ---------------------------------------------------------------------------------------------

def is_settable_offset(name: str) -> bool:
    """G54..G57 and the extended settable frames G505..G599 (840D settable zero offsets),
    spelled as the interpreter names them (``G054`` would never be applied)."""
    match = re.fullmatch(r"G([1-9][0-9]*)", name)
    if match is None:
        return False
    code = int(match.group(1))
    return 54 <= code <= 57 or 505 <= code <= 599


def setup_from_dict(data: dict[str, Any], file: str = "<setup>") -> dict[str, tuple[float, float, float]]:
    """Work offsets of a parsed setup file (see :func:`load_setup`)."""
    problems = Problems(file, MachineSpecError)
    problems.unknown(data, "", {"work_offsets"}, "unknown key (a setup file has only [work_offsets])")
    table = problems.table(data, "work_offsets")
    offsets = {}
    for key in table:
        if not is_settable_offset(key):
            canonical = re.fullmatch(r"[Gg]0*([1-9][0-9]*)", key)
            hint = f"write G{canonical.group(1)}; " if canonical and is_settable_offset(
                f"G{canonical.group(1)}") else ""
            problems.add(f"work_offsets.{key}", f"unknown work offset ({hint}use G54..G57 or "
                         "G505..G599)")
            continue
        value = problems.xyz_mm(table, "work_offsets", key)
        if value is not None:
            offsets[key] = value
    problems.raise_if_any()
    return offsets


def load_setup(file: str | FsPath) -> dict[str, tuple[float, float, float]]:
    """Work offsets from a setup TOML file: ``[work_offsets]`` ``G54 = [x_mm, y_mm, z_mm]``.

    Accepts G54..G57 and G505..G599; they override the machine file's offsets. Any problem is a
    :class:`~ncsim.errors.MachineSpecError` naming the file and the key."""
    return setup_from_dict(read_toml(file, "setup file", error=MachineSpecError), str(file))


# ---------------------------------------------------------------------------------------------
# CSV tables (traces and recordings)
# ---------------------------------------------------------------------------------------------

DELIMITERS = (",", ";", "\t")


def sniff_delimiter(header_line: str) -> str:
    """The delimiter the header uses most (``,`` when it uses none)."""
    counts = {d: header_line.count(d) for d in DELIMITERS}
    best = max(counts, key=counts.get)
    return best if counts[best] > 0 else ","


def _is_skipped(line: str) -> bool:
    text = line.strip()
    return not text or text.startswith("#")


@dataclass
class CsvTable:
    """A CSV file split into its header and its body (module docstring). ``body`` is the text
    after the header line, ``first_line`` the 1-based file line it starts on."""

    file: str
    header: list[str]
    delimiter: str
    body: str
    first_line: int
    _rows: list | None = field(default=None, repr=False)

    def find(self, name: str) -> int | None:
        """Index of the column ``name`` (exact, else case-insensitive), or None."""
        if name in self.header:
            return self.header.index(name)
        low = [h.lower() for h in self.header]
        return low.index(name.lower()) if name.lower() in low else None

    # -- the slow, locating path ----------------------------------------------------------------

    def rows(self) -> list[tuple[int, list[str]]]:
        """Every data row as ``(file line, fields)`` (blank and ``#`` lines skipped)."""
        if self._rows is None:
            lines = self.body.splitlines()
            keep = [i for i, ln in enumerate(lines) if not _is_skipped(ln)]
            data = [lines[i] for i in keep]
            if '"' in self.body:
                parsed = list(csv.reader(data, delimiter=self.delimiter))
            else:  # no quoting: a plain split is the same and several times faster
                parsed = [ln.split(self.delimiter) for ln in data]
            self._rows = list(zip([self.first_line + i for i in keep], parsed))
        return self._rows

    def line_of(self, row: int) -> int:
        """The file line of data row ``row`` (0-based)."""
        return self.rows()[row][0]

    def n_rows(self) -> int:
        return len(self.rows())

    def text_column(self, index: int) -> list[str]:
        """One column as stripped strings ('' where a row is short)."""
        return [r[index].strip() if index < len(r) else "" for _, r in self.rows()]

    def _located_error(self, indices, names, finite: bool = True,
                       converters=None) -> MeasuredDataError | None:
        """The first bad cell or row of the columns ``indices`` (after the fast path failed),
        or None when every row is fine (a line of spaces, which loadtxt refuses)."""
        width = len(self.header)
        converters = converters or {}
        for lineno, row in self.rows():
            short = [name for index, name in zip(indices, names) if index >= len(row)]
            if short:
                return MeasuredDataError(f"row has {len(row)} fields, no column '{short[0]}' "
                                         f"(the header has {width})", file=self.file, line=lineno)
            if len(row) != width:
                return MeasuredDataError(f"row has {len(row)} fields, the header has {width} "
                                         "(a decimal comma?)", file=self.file, line=lineno)
            for index, name in zip(indices, names):
                if index in converters:
                    try:
                        converters[index](row[index].strip().strip('"').strip())
                        problem = None
                    except ValueError as exc:
                        problem = f"column '{name}': {exc}"
                else:
                    problem = cell_problem(row[index], name, finite)
                if problem:
                    return MeasuredDataError(problem, file=self.file, line=lineno)
        return None

    # -- the fast path --------------------------------------------------------------------------

    def floats(self, indices, names=None, *, finite: bool = True, converters=None) -> np.ndarray:
        """The columns ``indices`` as an (m, k) float array (module docstring). ``finite=False``
        lets NaN and infinities through; ``converters`` maps a column index to a function of
        the cell's text giving its number (a label's code), raising ValueError with the
        problem for a bad cell."""
        indices = [int(i) for i in indices]
        names = list(names) if names is not None else [self.header[i] for i in indices]
        if not indices:
            return np.zeros((self.n_rows(), 0))
        quoted = '"' in self.body

        def load(body: str) -> np.ndarray:
            with warnings.catch_warnings():  # a body of comments only: no rows, no warning
                warnings.simplefilter("ignore", UserWarning)
                return np.loadtxt(io.StringIO(body), delimiter=self.delimiter, comments="#",
                                  usecols=indices, ndmin=2, dtype=np.float64,
                                  quotechar='"' if quoted else None, converters=converters)

        def located() -> MeasuredDataError:
            error = self._located_error(indices, names, finite, converters)
            return error or MeasuredDataError("cannot parse the numeric columns", file=self.file)

        try:
            out = load(self.body)
        except ValueError:
            if self._located_error(indices, names, finite, converters) is not None:
                raise located() from None
            try:                             # every row is fine: lines of spaces only
                out = load("\n".join(self.delimiter.join(r) for _, r in self.rows()))
            except ValueError:
                raise located() from None
        numeric = [i for i in indices if i not in (converters or {})]
        if not self._field_count_ok(len(out), quoted) or (finite and not np.all(np.isfinite(out))) \
                or (converters is None and "_" in self.body and self._has_separator(numeric)):
            raise located()
        return out

    def _field_count_ok(self, n_rows: int, quoted: bool) -> bool:
        """Does every data row have the header's field count? Checked by counting delimiters
        in the body when no quote or comment can hide one, else row by row."""
        width = len(self.header)
        if quoted or "#" in self.body:
            rows = self.rows()
            return len(rows) == n_rows and all(len(r) == width for _, r in rows)
        return self.body.count(self.delimiter) == n_rows * (width - 1)

    def _has_separator(self, indices) -> bool:
        """Does a numeric cell hold a ``_`` digit separator (read by ``float``, not by ncsim)?
        (numpy's compiled loadtxt refuses them already; with label columns, whose names hold
        ``_``, this walk of every row is skipped)"""
        return any("_" in row[i] for _, row in self.rows() for i in indices if i < len(row))


def cell_problem(cell: str, name: str, finite: bool = True) -> str | None:
    """Why a cell is not a finite number (or, unless ``finite``, a number; None if it is)."""
    text = cell.strip().strip('"').strip()
    if not text:
        return f"column '{name}' is empty"
    if "_" in text:
        return f"column '{name}' is not a number: {text!r}"
    try:
        v = float(text)
    except ValueError:
        return f"column '{name}' is not a number: {text!r}"
    if not finite:
        return None
    if math.isnan(v):
        return f"column '{name}' is {text}"
    if not math.isfinite(v):
        return f"column '{name}' is {text} (not a finite number)"
    return None


def read_table(file, what: str = "file") -> CsvTable:
    """Read a CSV file's header and body (module docstring); ``what`` names the file in a read
    error (``FILE: cannot read trace file: ...``)."""
    name = str(file)
    return table_from_text(read_text(file, what, error=MeasuredDataError), name)


def table_from_text(text: str, name: str) -> CsvTable:
    """:func:`read_table` of a text already read (``name`` is the file errors name)."""
    pos, lineno = 0, 1
    n = len(text)
    while pos < n:
        end = _line_end(text, pos)
        line = text[pos:end]
        if not _is_skipped(line):
            delim = sniff_delimiter(line)
            header = [h.strip() for h in next(csv.reader([line], delimiter=delim))]
            body = text[_next_line(text, end):]
            if "\r" in body:  # one line end for the compiled reader (line numbers unchanged)
                body = body.replace("\r\n", "\n").replace("\r", "\n")
            return CsvTable(name, header, delim, body, lineno + 1)
        pos, lineno = _next_line(text, end), lineno + 1
    raise MeasuredDataError("empty file (no header row)", file=name)


def _line_end(text: str, pos: int) -> int:
    ends = [i for i in (text.find("\n", pos), text.find("\r", pos)) if i >= 0]
    return min(ends) if ends else len(text)


def _next_line(text: str, end: int) -> int:
    if text.startswith("\r\n", end):
        return end + 2
    return min(end + 1, len(text))
