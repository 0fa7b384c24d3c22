"""A measured CSV table: its header, its dialect and its numeric columns, read fast. The one
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
import warnings
from dataclasses import dataclass, field

import numpy as np

from ncsim.config import read_text
from ncsim.errors import MeasuredDataError

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
