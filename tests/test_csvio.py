"""Trace CSV writing and reading (ncsim.report.csvio).

Expected text comes from Python's own fixed-point formatting (``f"{x:.{d}f}"``), an
implementation independent of the vectorised writer; round trips are checked within the
written precision.
"""
from __future__ import annotations

import io
import math
from dataclasses import fields

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from ncsim.report.csvio import (ALL_COLUMNS, DEFAULT_COLUMNS, FLOAT, INT, LABEL, LIMIT_LABELS,
                         format_rows, read_trace_csv, trace_from_columns, write_trace_csv)
from ncsim.errors import MeasuredDataError, UsageError
from ncsim.motion import Limit, Phase
from ncsim.motion import Trace


def random_trace(n: int, seed: int = 0, scale: float = 100.0) -> Trace:
    rng = np.random.default_rng(seed)
    f = lambda s=scale: rng.normal(size=n) * s  # noqa: E731
    v3 = lambda s=scale: rng.normal(size=(n, 3)) * s  # noqa: E731
    return Trace(
        t_s=np.cumsum(rng.uniform(0, 0.02, n)), s_mm=np.cumsum(rng.uniform(0, 1, n)),
        feed_mm_s=np.abs(f()), accel_t_mm_s2=f(), jerk_t_mm_s3=f(1e4), accel_n_mm_s2=np.abs(f()),
        jerk_n_mm_s3=np.abs(f(1e4)), pos_mm=v3(), vel_mm_s=v3(), acc_mm_s2=v3(), jerk_mm_s3=v3(1e4),
        block=rng.integers(0, 10 ** 6, n).astype(np.int32), line=rng.integers(1, 10 ** 7, n).astype(np.int32),
        limit=rng.integers(0, len(Limit), n).astype(np.int8), phase=rng.integers(0, 4, n).astype(np.int8),
        setpoint_mm_s=np.abs(f()), programmed_mm_s=np.abs(f()))


# ---------------------------------------------------------------------------------------------
# Formatting, against Python's formatter
# ---------------------------------------------------------------------------------------------

def python_text(x: float, d: int) -> str:
    """Reference: Python's correctly rounded fixed-point text, without the sign of -0."""
    text = f"{x:.{d}f}"
    return text[1:] if text.startswith("-") and float(text) == 0 else text


EDGE = [0.0, -0.0, 1.0, -1.0, 0.5, -0.5, 9.9996, -9.9996, 99.99999, 1e-9, -1e-9, 123456789.125,
        -987654.3210987, 1e15, -1e15, 9.999e16, 2.5e17, 1e18, -3e18, 1e300, -1e300,
        float("inf"), float("-inf"), float("nan"), 5e-324, 0.1, 0.7, 1 / 3]


@pytest.mark.parametrize("d", [0, 1, 3, 6, 9])
def test_fixed_point_text_equals_python(d):
    x = np.array(EDGE)
    got = format_rows([x], [FLOAT], [d]).decode().splitlines()
    for value, text in zip(EDGE, got):
        expected = python_text(value, d)
        if text != expected:  # halfway cases may round either way; the value must still agree
            assert abs(float(text) - value) <= 0.5 * 10 ** -d * (1 + 1e-9) + 1e-15 * abs(value), (value, text)
    by_value = dict(zip(map(repr, EDGE), got))
    assert by_value["inf"] == "inf" and by_value["-inf"] == "-inf" and by_value["nan"] == "nan"
    assert by_value["-1.0"].startswith("-1")
    assert by_value["-0.0"] == "0" + ("." + "0" * d if d else "")


def test_integers_labels_and_separators():
    ints = np.array([0, 7, -7, 10, 99, 100, -12345678901, 2 ** 62])
    codes = np.array([0, 1, 2, 3, 4, 13, 9, 5])
    text = format_rows([ints, codes, ints.astype(float) / 8], [INT, LABEL, FLOAT], [0, 0, 2],
                       [(), LIMIT_LABELS, ()]).decode()
    expected = "".join(f"{i},{LIMIT_LABELS[c]},{python_text(i / 8, 2)}\n" for i, c in zip(ints, codes))
    assert text == expected


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(values=st.lists(st.floats(allow_nan=True, allow_infinity=True, width=64), min_size=1, max_size=40),
       d=st.integers(0, 9))
def test_random_floats_match_python_within_half_a_unit(values, d):
    got = format_rows([np.array(values)], [FLOAT], [d]).decode().splitlines()
    assert len(got) == len(values)
    for value, text in zip(values, got):
        if math.isnan(value):
            assert text == "nan"
        elif math.isinf(value):
            assert text == ("inf" if value > 0 else "-inf")
        else:
            assert text == python_text(value, d) or \
                abs(float(text) - value) <= 0.5 * 10 ** -d * (1 + 1e-9) + 4e-16 * abs(value)
            assert (d == 0) == ("." not in text)


# ---------------------------------------------------------------------------------------------
# Round trips
# ---------------------------------------------------------------------------------------------

def _check_round_trip(trace: Trace, cols: dict, decimals: dict) -> None:
    tol = lambda name, x: 0.5 * 10 ** -decimals[name] * (1 + 1e-9) + 4e-16 * np.abs(x)  # noqa: E731
    getters = {
        "t_s": trace.t_s, "s_mm": trace.s_mm, "x_mm": trace.pos_mm[:, 0], "y_mm": trace.pos_mm[:, 1],
        "z_mm": trace.pos_mm[:, 2], "feed_mm_min": trace.feed_mm_s * 60.0,
        "vx_mm_s": trace.vel_mm_s[:, 0], "az_mm_s2": trace.acc_mm_s2[:, 2],
        "jy_mm_s3": trace.jerk_mm_s3[:, 1], "jerk_n_mm_s3": trace.jerk_n_mm_s3,
        "setpoint_mm_min": trace.setpoint_mm_s * 60.0, "programmed_mm_min": trace.programmed_mm_s * 60.0,
    }
    for name, x in getters.items():
        if name in cols:
            got = cols[name]
            finite = np.isfinite(x)
            assert np.all(np.abs(got[finite] - x[finite]) <= tol(name, x[finite])), name
            np.testing.assert_array_equal(got[~finite], x[~finite])
    np.testing.assert_array_equal(cols["block"], trace.block)
    np.testing.assert_array_equal(cols["line"], trace.line)
    np.testing.assert_array_equal(cols["limit"], trace.limit)
    if "phase" in cols:
        np.testing.assert_array_equal(cols["phase"], trace.phase)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(n=st.integers(1, 150), seed=st.integers(0, 2 ** 32 - 1),
       scale=st.sampled_from([1e-6, 1.0, 1e3, 1e9]), d=st.integers(0, 9),
       chunk=st.sampled_from([3, 64, 8192]))
def test_round_trip_random_traces(tmp_path_factory, n, seed, scale, d, chunk):
    """Random traces (negative, zero, large values, some inf) survive write + read within
    half a unit of the last written decimal, whatever the chunking."""
    trace = random_trace(n, seed, scale)
    rng = np.random.default_rng(seed)
    trace.pos_mm[rng.integers(0, n, 3), 0] = 0.0
    trace.programmed_mm_s[rng.integers(0, n, 2)] = np.inf  # rapid blocks
    trace.jerk_mm_s3[rng.integers(0, n, 2), 1] = -5e13      # very large, still fixed point
    file = tmp_path_factory.mktemp("csv") / "trace.csv"
    decimals = {name: d for name in ALL_COLUMNS}
    write_trace_csv(trace, file, columns="all", decimals=d, chunk_rows=chunk)
    cols = read_trace_csv(file)
    assert list(cols) == list(ALL_COLUMNS)
    _check_round_trip(trace, cols, decimals)


def test_default_columns_and_units(tmp_path):
    trace = random_trace(50, 1)
    file = tmp_path / "t.csv"
    assert write_trace_csv(trace, file) == 50
    lines = file.read_text().splitlines()
    assert lines[0] == ",".join(DEFAULT_COLUMNS)
    assert lines[0] == "t_s,s_mm,x_mm,y_mm,z_mm,feed_mm_min,block,line,limit"
    assert len(lines) == 51
    first = lines[1].split(",")
    assert float(first[5]) == pytest.approx(trace.feed_mm_s[0] * 60.0, abs=1e-3)
    assert first[8] == Limit(trace.limit[0]).label
    cols = read_trace_csv(file)
    _check_round_trip(trace, cols, {"t_s": 6, "s_mm": 5, "x_mm": 5, "y_mm": 5, "z_mm": 5,
                                    "feed_mm_min": 3})


def test_text_and_binary_streams_and_chosen_columns():
    trace = random_trace(20, 2)
    text, binary = io.StringIO(), io.BytesIO()
    cols = ["t_s", "phase", "jerk_n_mm_s3", "block", "line", "limit"]
    write_trace_csv(trace, text, columns=cols, decimals={"jerk_n_mm_s3": 1})
    write_trace_csv(trace, binary, columns=",".join(cols), decimals={"jerk_n_mm_s3": 1})
    assert text.getvalue().encode() == binary.getvalue()
    assert text.getvalue().splitlines()[1].split(",")[1] == Phase(trace.phase[0]).name
    back = read_trace_csv(io.BytesIO(binary.getvalue()))
    _check_round_trip(trace, back, {"t_s": 6, "jerk_n_mm_s3": 1})


def test_sampled_motion_round_trips_through_trace_from_columns(tmp_path, mikron):
    from test_sample import circle_path, single_block_motion

    from ncsim.plan.sample import sample_motion

    motion = single_block_motion(mikron, circle_path(30.0, 100.0), 100.0, 2500.0, 5000.0)
    trace = sample_motion(motion)
    file = tmp_path / "circle.csv"
    write_trace_csv(trace, file, columns="all", decimals=9)
    back = trace_from_columns(read_trace_csv(file))
    for f in fields(Trace):
        a, b = getattr(back, f.name), getattr(trace, f.name)
        if a.dtype.kind == "f":
            np.testing.assert_allclose(a, b, rtol=1e-12, atol=6e-10 * (60 if "feed" in f.name
                                                                       or "point" in f.name else 1))
        else:
            np.testing.assert_array_equal(a, b)


def test_trace_from_columns_fills_missing_columns():
    tr = trace_from_columns({"t_s": np.array([0.0, 0.1]), "feed_mm_min": np.array([600.0, 1200.0])})
    np.testing.assert_allclose(tr.feed_mm_s, [10.0, 20.0])
    assert np.all(np.isnan(tr.pos_mm)) and list(tr.block) == [-1, -1]
    assert list(tr.limit) == [Limit.NONE] * 2 and list(tr.phase) == [Phase.STOP] * 2


def test_empty_trace_writes_a_header_only(tmp_path):
    trace = random_trace(0)
    file = tmp_path / "empty.csv"
    assert write_trace_csv(trace, file) == 0
    assert file.read_text() == ",".join(DEFAULT_COLUMNS) + "\n"
    cols = read_trace_csv(file)
    assert all(len(v) == 0 for v in cols.values())


def test_reader_accepts_comments_blank_lines_crlf_and_extra_columns(tmp_path):
    file = tmp_path / "m.csv"
    file.write_bytes(b"# measured on the MIKRON\r\n\r\nt_s,x_mm,spindle_rpm,limit\r\n"
                     b"0.0,1.5,12000,programmed\r\n\r\n0.012,-1.25,1.2e4,AXIS_JERK\r\n")
    cols = read_trace_csv(file)
    np.testing.assert_allclose(cols["x_mm"], [1.5, -1.25])
    np.testing.assert_allclose(cols["spindle_rpm"], [12000, 12000])
    np.testing.assert_array_equal(cols["limit"], [Limit.PROGRAMMED, Limit.AXIS_JERK])


# ---------------------------------------------------------------------------------------------
# Bad input
# ---------------------------------------------------------------------------------------------

HEADER = "t_s,x_mm,block,line,limit\n"


@pytest.mark.parametrize("content, where, message", [
    ("", None, "empty file"),
    ("# only a comment\n", None, "empty file"),
    ("x_mm,y_mm\n1,2\n", "column 't_s'", "missing column"),
    ("t_s,x_mm,x_mm\n", "column 'x_mm'", "named twice"),
    (HEADER + "0,1,0,1,programmed\n0.1,2,0,1\n", ":3:", "row has 4 fields, no column 'limit' (the header has 5)"),
    (HEADER + "0,1,0,1,programmed\n0.1,abc,0,1,programmed\n", ":3:", "column 'x_mm' is not a number: 'abc'"),
    (HEADER + "0,1,0,1,fast\n", ":2:", "column 'limit': unknown label 'fast'"),
    (HEADER + "0,1,0.5,1,programmed\n", ":2:", "column 'block': expected an integer"),
    (HEADER + "0.2,1,0,1,programmed\n0.1,1,0,1,programmed\n", ":3:", "time goes backwards"),
    (HEADER + "0,1,0,1,programmed\n\nnan,1,0,1,programmed\n", ":4:", "finite"),
    ("t_s,x_mm\n0,1\n0.1,1,2\n", ":3:", "row has 3 fields, the header has 2 (a decimal comma?)"),
])
def test_bad_files_raise_one_line_errors(tmp_path, content, where, message):
    file = tmp_path / "bad.csv"
    file.write_text(content)
    with pytest.raises(MeasuredDataError) as info:
        read_trace_csv(file)
    text = info.value.render()
    assert "\n" not in text and message in text and str(file) in text
    if where:
        assert where in text


def test_unreadable_file(tmp_path):
    with pytest.raises(MeasuredDataError, match="cannot read trace file"):
        read_trace_csv(tmp_path / "missing.csv")


@pytest.mark.parametrize("kwargs, match", [
    (dict(columns=["t_s", "speed"]), "unknown trace column 'speed'"),
    (dict(columns=["t_s", "t_s"]), "requested twice"),
    (dict(columns=[]), "no trace columns"),
    (dict(decimals=-1), "decimals"),
    (dict(decimals=2.5), "decimals"),
    (dict(decimals={"t_s": 99}), "decimals"),
    (dict(decimals={"nope": 1}), "unknown column 'nope'"),
    (dict(chunk_rows=0), "chunk_rows"),
])
def test_bad_write_options(kwargs, match):
    with pytest.raises(UsageError, match=match) as info:
        write_trace_csv(random_trace(3), io.BytesIO(), **kwargs)
    assert "\n" not in info.value.render()


def test_bad_codes_and_unwritable_path(tmp_path):
    trace = random_trace(3)
    trace.limit[1] = 99
    with pytest.raises(UsageError, match="code 99 has no label"):
        write_trace_csv(trace, io.BytesIO())
    with pytest.raises(UsageError, match="cannot write trace file"):
        write_trace_csv(random_trace(3), tmp_path / "no" / "such" / "dir.csv")


@settings(max_examples=50, deadline=None)
@given(st.integers(0, 2**31 - 1), st.integers(1, 300))
def test_compiled_writer_is_byte_identical_to_the_numpy_formatter(seed, m):
    """The compiled row writer and the vectorised numpy formatter give the same bytes."""
    from ncsim.report import csvio

    rng = np.random.default_rng(seed)
    cols = [rng.normal(0, 10.0 ** rng.integers(-3, 8), m), rng.integers(-10**9, 10**9, m),
            rng.integers(0, len(csvio.LIMIT_LABELS), m), np.round(rng.normal(0, 1, m), 1),
            rng.integers(0, len(csvio.PHASE_LABELS), m)]
    kinds = [csvio.FLOAT, csvio.INT, csvio.LABEL, csvio.FLOAT, csvio.LABEL]
    decimals = [int(rng.integers(0, 9)), 0, 0, int(rng.integers(0, 4)), 0]
    labels = [(), (), csvio.LIMIT_LABELS, (), csvio.PHASE_LABELS]
    compiled = csvio._format_rows_compiled(cols, kinds, decimals, labels, list("abcde"))
    assert compiled is not None
    import unittest.mock as mock
    with mock.patch.object(csvio, "_format_rows_compiled", lambda *a: None):
        vectorised = csvio.format_rows(cols, kinds, decimals, labels, list("abcde"))
    assert compiled == vectorised
