"""``ncsim plot --trace`` (report.csvio) and ``ncsim gap --measured`` (gap.measured) read CSV
through one reader (``ncsim.config.read_table``): they accept the same dialects, with the same
numbers, and reject the same bad rows at the same line with the same message."""
from __future__ import annotations

import numpy as np
import pytest

from ncsim.errors import MeasuredDataError
from ncsim.gap.measured import load_measured_csv
from ncsim.report.csvio import read_trace_csv

ROWS = [("0", "0.5", "-1.25"), ("0.012", "1.5", "2e-3"), ("0.024", "2.5", "3")]


def _write(path, text: str, encoding="utf-8") -> None:
    path.write_bytes(text.encode(encoding))


def _csv(delim=",", quote="", eol="\n", head="", index=False):
    lines = [delim.join(([""] if index else []) + [f"{quote}{n}{quote}" for n in ("t_s", "x_mm", "y_mm")])]
    for k, row in enumerate(ROWS):
        lines.append(delim.join(([str(k)] if index else []) + [f"{quote}{v}{quote}" for v in row]))
    return head + eol.join(lines) + eol


DIALECTS = {
    "comma": _csv(),
    "semicolon": _csv(";"),
    "tab": _csv("\t"),
    "quoted": _csv(quote='"'),
    "CR LF": _csv(eol="\r\n"),
    "CR only": _csv(eol="\r"),
    "byte-order mark": "\ufeff" + _csv(),
    "comments and blank lines": "# exported by the NC\n\n" + _csv().replace("\n0.012", "\n# pause\n\n0.012"),
    "spaces around fields": _csv(", "),
    "a line of spaces": _csv().replace("\n0.024", "\n   \n0.024"),
    "unnamed index column (pandas)": _csv(index=True),
}


@pytest.mark.parametrize("text", DIALECTS.values(), ids=DIALECTS.keys())
def test_both_readers_accept_the_dialect_with_the_same_numbers(tmp_path, text):
    f = tmp_path / "trace.csv"
    _write(f, text)
    expected = np.array([[float(v) for v in row] for row in ROWS])
    plot = read_trace_csv(f)
    gap = load_measured_csv(f)
    np.testing.assert_array_equal(np.column_stack([plot["t_s"], plot["x_mm"], plot["y_mm"]]), expected)
    np.testing.assert_array_equal(np.column_stack([gap.t_s, gap.pos_mm[:, 0], gap.pos_mm[:, 1]]), expected)


BAD = {
    # a decimal comma in a comma-separated file: read shifted before, one field too many now
    "decimal comma": ("t_s,x_mm,y_mm\n0,0.5,1\n0.012,1,5,2\n",
                      ":3: row has 4 fields, the header has 3 (a decimal comma?)"),
    "missing field": ("t_s,x_mm,y_mm\n0,0.5,1\n0.012,1\n", ":3: row has 2 fields, no column 'y_mm'"),
    "decimal comma, semicolons": ("t_s;x_mm;y_mm\n0;0,5;1\n", ":2: column 'x_mm' is not a number: '0,5'"),
    "digit-group underscore": ("t_s,x_mm,y_mm\n0,1_000,1\n", ":2: column 'x_mm' is not a number: '1_000'"),
    "text": ("t_s,x_mm,y_mm\n0,0.5,1\n0.012,abc,2\n", ":3: column 'x_mm' is not a number: 'abc'"),
    "empty": ("# nothing but a comment\n", ": empty file"),
    "not UTF-8": ("t_s,x_mm,y_mm\n0,0.5,1 ; Fr\xe4ser\n", ": cannot read "),
}


@pytest.mark.parametrize("text, message", BAD.values(), ids=BAD.keys())
def test_both_readers_reject_the_same_rows_at_the_same_line(tmp_path, text, message):
    f = tmp_path / "bad.csv"
    _write(f, text, "latin-1" if "\xe4" in text else "utf-8")
    for read in (read_trace_csv, load_measured_csv):
        with pytest.raises(MeasuredDataError) as info:
            read(f)
        rendered = info.value.render()
        assert rendered.startswith(f"{f}{message}") and "\n" not in rendered, (read.__name__, rendered)
