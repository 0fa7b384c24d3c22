"""The fast path (ncsim.nc.fastparse + vectorised runs) gives exactly what the Lark path gives.

Property tests: random lines parse to the same blocks either way; random programs mixing plain
and non-plain lines give the same Path (every column, bit for bit), the same warnings and the
same errors whether plain runs are read by the scanner and interpreted as columns, or every line
goes through the Lark grammar and the block-by-block interpreter (``fast=False``).
"""
from __future__ import annotations

import math
from unittest import mock

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from ncsim.nc import columns, interpret
from ncsim.errors import NcError
from ncsim.nc.fastparse import scan_plain
from ncsim.nc.interpret import interpret_text
from ncsim.nc.parse import parse_text
from ncsim.path import path_columns

SETTINGS = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])


# ---- scanner units ----------------------------------------------------------------------------

@pytest.mark.parametrize("line, plain", [
    ("N10 G1 X1.5 Y-2 Z.5 F1000", True),
    ("X-14.354 Y-25.338 Z-.009", True),
    ("G3 X-15.843 Y-24.021 I0.0 J-1.3", True),
    ("N10G1X10", True),
    ("\tN10  G0 X1 ;comment with ümlaut", True),
    ("", True),
    ("; only a comment", True),
    ("X1 G1", False),            # order
    ("g1 x1", False),            # lower case goes to Lark
    ("G4 F2", False),            # not G0..G3
    ("G01 X1", True),            # leading zero of G00..G03 (ISO CAM output)
    ("G001 X1", False),          # two leading zeros: Lark's business
    ("G1.5 X1", False),
    ("X1.2.3", False),
    ("X1 X2", False),            # twice
    ("X" + "1" * 16, False),     # more than 15 significant digits
    ("X0." + "0" * 22 + "1", False),  # more than 22 decimals
    ("X1\r", False),
    ("N10 G1 X10 CR=5", False),
    ("X-", False),
    ("N", False),
])
def test_scanner_decides_plain(line, plain):
    _, mask, *_ = scan_plain(line + "\n")
    assert bool(mask[0]) is plain


def test_scanner_values_and_columns():
    _, mask, _, _, numbers, g, values, cols = scan_plain("N20 G2 X-1.5 J.25 F600.\n")
    assert mask[0] and numbers[0] == 20 and g[0] == 2
    np.testing.assert_array_equal(values[0], [-1.5, np.nan, np.nan, np.nan, 0.25, np.nan, 600.0])
    assert cols[0].tolist() == [1, 5, 8, 0, 0, 0, 14, 0, 19]


def test_scanner_reads_numbers_exactly_like_float():
    texts = ["0.1", "-.009", "123456789.123456", "0.000000000000000000001", "999999999999999",
             "2069.", "+3.14159265358979", "-0"]
    _, mask, _, _, _, _, values, _ = scan_plain("".join(f"X{t}\n" for t in texts))
    assert mask.all()
    for t, v in zip(texts, values[:, 0]):
        assert v == float(t) and math.copysign(1, v) == math.copysign(1, float(t))


def test_line_count_matches_split():
    for text in ["", "\n", "X1", "X1\n", "X1\n\nX2\n\n"]:
        lines = text.split("\n")
        if lines[-1] == "":
            lines.pop()
        assert parse_text(text).n_lines == len(lines) == len(list(parse_text(text).blocks()))


# ---- random lines: same blocks either way -------------------------------------------------

def _num_text(draw):
    x = draw(st.floats(-500, 500, allow_nan=False).map(lambda v: round(v, draw(st.integers(0, 5)))))
    form = draw(st.sampled_from(["plain", "dot", "lead", "int", "plus", "long"]))
    if form == "int":
        return str(int(x))
    if form == "dot":
        return f"{int(x)}."
    if form == "lead" and abs(x) < 1:
        return f"{x:.3f}".replace("0.", ".", 1)
    if form == "plus":
        return f"+{abs(x)}"
    if form == "long":
        return f"{x:.17f}"
    return repr(x)


@st.composite
def near_plain_lines(draw):
    parts = []
    if draw(st.booleans()):
        parts.append(f"N{draw(st.integers(0, 10**6))}")
    if draw(st.booleans()):
        parts.append(draw(st.sampled_from(["G0", "G1", "G2", "G3", "G01", "G4", "G17", "g1"])))
    for letter in "XYZIJKF":
        if draw(st.integers(0, 2)) == 0:
            parts.append(letter + _num_text(draw))
    if draw(st.integers(0, 6)) == 0:
        parts.append(draw(st.sampled_from(["CR=5", "TURN=1", "M3", "X1", "(c)", "R1=2", "T=\"A\""])))
    if draw(st.integers(0, 4)) == 0:
        draw(st.randoms()).shuffle(parts)
    sep = draw(st.sampled_from([" ", "", "  ", "\t", " \t"]))
    line = sep.join(parts)
    if draw(st.integers(0, 3)) == 0:
        line += draw(st.sampled_from([" ;comment", ";x", "; ümlaut", " ; X1"]))
    return draw(st.sampled_from(["", " ", "\t"])) + line


def _blocks_or_error(text, fast):
    try:
        return list(parse_text(text, "t.mpf", fast=fast).blocks())
    except NcError as exc:
        return exc.render()


@SETTINGS
@given(st.lists(near_plain_lines(), min_size=1, max_size=12))
def test_random_lines_parse_the_same_either_way(lines):
    text = "\n".join(lines) + "\n"
    assert _blocks_or_error(text, True) == _blocks_or_error(text, False)


# ---- random programs: same Path, warnings and errors either way ----------------------------

def _fmt(x: float) -> str:
    return f"{x:.4f}"


@st.composite
def programs(draw):
    """A program mixing plain runs with non-plain lines; arcs are made to close (mostly)."""
    lines = []
    incremental = draw(st.booleans())
    plane = draw(st.sampled_from([17, 17, 18, 19]))
    header = [f"G{plane}", "G91" if incremental else "G90", draw(st.sampled_from(["G71", "G70", "G700", "G710"]))]
    lines.append(" ".join(header))
    for extra in draw(st.lists(st.sampled_from([
            "SOFT", "BRISK", "G64", "G642 ADIS=0.05", "G641 ADIS=.2 ADISPOS=1", "FFWON", "G602",
            "TRANS X10 Y-5 Z2", "AROT Z30", "ROT X90", "MIRROR X0", "SCALE X2 Y2 Z2", "ATRANS X1",
            "G54", "AMIRROR Y0", "ROT RPL=45"]), max_size=3)):
        lines.append(extra)
    if draw(st.integers(0, 9)) > 0:
        lines.append(f"G1 F{draw(st.integers(100, 9000))}")
    pos = [0.0, 0.0, 0.0]   # programmed (WCS) position, in program units
    lines.append("G0 X=AC(0) Y=AC(0) Z=AC(0)")
    e1, e2, _ = {17: (0, 1, 2), 18: (2, 0, 1), 19: (1, 2, 0)}[plane]
    centre_letters = "IJK"
    label_no = 0
    arc_modal = False   # the last motion word was G2/G3: a following line must say G0/G1
    for _ in range(draw(st.integers(1, 40))):
        kind = draw(st.sampled_from(["line", "line", "line", "rapid", "arc", "arc", "circle", "other",
                                     "other", "bad", "feed", "jump", "blank"]))
        n = f"N{draw(st.integers(1, 99)) * 10} " if draw(st.booleans()) else ""
        if kind in ("line", "rapid"):
            explicit = arc_modal or draw(st.booleans())
            g = {"line": "G1 ", "rapid": "G0 "}[kind] if explicit else ""
            arc_modal = False
            words = []
            for a, letter in enumerate("XYZ"):
                if draw(st.booleans()):
                    v = round(draw(st.floats(-50, 50)), 3)
                    words.append(f"{letter}{_fmt(v)}")
                    pos[a] = pos[a] + v if incremental else v
            if not g and kind == "rapid":
                g = "G0 "
            lines.append(f"{n}{g}{' '.join(words)}".rstrip())
        elif kind in ("arc", "circle"):
            r = draw(st.floats(0.5, 20))
            phi0 = draw(st.floats(0, 2 * math.pi))
            ci, cj = -r * math.cos(phi0), -r * math.sin(phi0)
            ci, cj = float(_fmt(ci)), float(_fmt(cj))
            g = draw(st.sampled_from(["G2", "G3"]))
            words = [g]
            arc_modal = True
            centre = [pos[e1] + ci, pos[e2] + cj]
            if kind == "arc":
                theta = draw(st.floats(0.1, 6.0))
                u, v = pos[e1] - centre[0], pos[e2] - centre[1]
                c, s = math.cos(theta), math.sin(theta)
                end1 = float(_fmt(centre[0] + c * u - s * v))
                end2 = float(_fmt(centre[1] + s * u + c * v))
                for axis, end in ((e1, end1), (e2, end2)):
                    value = end - pos[axis] if incremental else end
                    words.append(f"{'XYZ'[axis]}{_fmt(value)}")
                    pos[axis] = pos[axis] + float(_fmt(value)) if incremental else end
            words.append(f"{centre_letters[e1]}{_fmt(ci)}")
            words.append(f"{centre_letters[e2]}{_fmt(cj)}")
            if draw(st.integers(0, 5)) == 0:
                words.append(f"F{draw(st.integers(50, 5000))}")
            lines.append(n + " ".join(words))
        elif kind == "feed":
            lines.append(f"{n}F{draw(st.integers(1, 20000))}.")
        elif kind == "blank":
            lines.append(draw(st.sampled_from(["", "; comment", "N5", "  "])))
        elif kind == "jump":
            label_no += 1
            target = f"LBL{label_no}"
            lines.append(f"GOTOF {target}")
            lines.append(f"G1 X{_fmt(draw(st.floats(-9, 9)))} Y7 F300")   # skipped
            lines.append(f"{target}: G1 F500")
        else:
            choices = (["G2 X5 Y5", "G1 X1 I1", "G1 X=1/0", "G3 X1 Y1 CR=3 F100", "G2 I3 J4 K5 F100"]
                       if kind == "bad" else
                       ["M3 S1000", "G4 F0.25", "SOFT", "BRISK", "G64", "G60", "STOPRE", "M7",
                        "R1=1.5 R2=R1*2", "G1 X=R2 F800", "G9 G1 Z3 F700", "MSG(\"x\")", "FFWOF",
                        "COMPCAD", "G4 S10", "TRANS X1", "G0 X1 C30", "SUPA G0 Z50", "G1 G91 X1 Y1 F90"])
            lines.append(draw(st.sampled_from(choices)))
            if lines[-1] not in ("M3 S1000", "G4 F0.25", "SOFT", "BRISK", "G64", "G60", "STOPRE", "M7",
                                 "R1=1.5 R2=R1*2", "MSG(\"x\")", "FFWOF", "COMPCAD", "G4 S10"):
                lines.append(f"G0 G{90 + incremental} X=AC(0) Y=AC(0) Z=AC(0)")
                pos = [0.0, 0.0, 0.0]
                arc_modal = False
    if draw(st.booleans()):
        lines.append("M30")
    return "\n".join(lines) + "\n"


def _outcome(text, fast):
    try:
        return interpret_text(text, "p.mpf", fast=fast, block_budget=5000,
                              setup_offsets={"G54": (100.0, -20.0, 5.5)})
    except NcError as exc:
        return exc.render()


def assert_same_outcome(a, b):
    if isinstance(a, str) or isinstance(b, str):
        assert a == b
        return
    for name in path_columns():
        x, y = getattr(a.path, name), getattr(b.path, name)
        assert x.dtype == y.dtype, name
        assert np.array_equal(x, y, equal_nan=True), name
    assert a.path.files == b.path.files and a.path.end_dwell_s == b.path.end_dwell_s
    assert a.warnings == b.warnings
    assert a.blocks_executed == b.blocks_executed
    assert a.recorded == b.recorded


@SETTINGS
@given(programs(), st.sampled_from([1, 4, interpret.VECTOR_MIN_ROWS]),
       st.sampled_from([2, 5, interpret.COLUMN_CHUNK]))
def test_fast_path_equals_lark_path(text, min_rows, chunk):
    """Also with plain runs cut into chunks of a few rows (each taken as columns or, when the
    column path declines it, block by block)."""
    with mock.patch.object(interpret, "VECTOR_MIN_ROWS", min_rows), \
            mock.patch.object(interpret, "COLUMN_CHUNK", chunk):
        fast = _outcome(text, True)
    assert_same_outcome(fast, _outcome(text, False))


def test_vectorised_runs_are_taken_and_agree():
    """A long plain run with lines and arcs: vectorised (checked), same as the Lark path."""
    lines = ["G17 G90 G64 SOFT", "G0 X0 Y0 Z1", "G1 Z0 F1200"]
    for k in range(40):
        lines += [f"N{k * 10} X{k + 1}.5 Y{k % 3}", f"G3 X{k + 1}.5 Y{k % 3 + 2} I0 J1", "G1"]
    text = "\n".join(lines) + "\nM30\n"
    calls = []
    original = columns.ColumnPath.run

    def spy(self, fr, run):
        ok = original(self, fr, run)
        calls.append((len(run), ok))
        return ok

    with mock.patch.object(columns.ColumnPath, "run", spy):
        fast = _outcome(text, True)
    assert calls and all(ok for _, ok in calls) and sum(n for n, _ in calls) >= 120
    assert_same_outcome(fast, _outcome(text, False))
    assert int((fast.path.kind == 1).sum()) == 40


def test_jump_into_the_middle_of_a_plain_run():
    text = ("G1 F100\nGOTOF N40\nN10 X1\nN20 X2\nN30 X3\nN40 X4\nN50 X5 Y1\nN60 X6\nN70 X7\nN80 X8\n"
            "N90 X9\nN100 X10\nN110 Y2\n")
    with mock.patch.object(interpret, "VECTOR_MIN_ROWS", 1):
        fast = _outcome(text, True)
    slow = _outcome(text, False)
    assert_same_outcome(fast, slow)
    assert fast.path.line[0] == 6 and fast.path.start_mm[0].tolist() == [0.0, 0.0, 0.0]
    assert fast.path.end_mm[0].tolist() == [4.0, 0.0, 0.0]
