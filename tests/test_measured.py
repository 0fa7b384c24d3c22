"""Measured traces (CSV), the UMich loader and published summaries (TOML)."""
from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest

from ncsim.errors import MeasuredDataError, UsageError
from ncsim.gap.measured import (MeasuredTrace, derived_speed_mm_s, load_measured_csv,
                            load_measured_summary, load_umich_csv, summary_from_dict,
                            write_measured_csv)

REPO = Path(__file__).resolve().parent.parent


def write(tmp_path, text, name="trace.csv"):
    p = tmp_path / name
    p.write_text(text)
    return p


# --- default convention ----------------------------------------------------------------------

def test_default_columns_and_units(tmp_path):
    p = write(tmp_path, "# oscilloscope export\n"
                        "t_s,x_mm,y_mm,z_mm,feed_mm_min,line\n"
                        "0.000,1.0,2.0,3.0,600,10\n"
                        "0.004,1.5,2.0,3.0,6000,10\n"
                        "0.012,2.0,2.5,3.0,6000,11\n")   # a dropped sample at 0.008 is fine
    tr = load_measured_csv(p)
    assert np.allclose(tr.t_s, [0, 0.004, 0.012])
    assert tr.pos_mm.shape == (3, 3) and np.allclose(tr.pos_mm[2], [2.0, 2.5, 3.0])
    assert np.allclose(tr.feed_mm_s, [10.0, 100.0, 100.0])       # mm/min -> mm/s
    assert list(tr.line) == [10, 10, 11]
    assert tr.vel_mm_s is None and tr.cmd_pos_mm is None and not tr.has_command
    assert tr.source == str(p)
    assert tr.period_s == pytest.approx(0.006)


def test_suffix_units_semicolon_and_missing_z(tmp_path):
    p = write(tmp_path, "t_ms;x_um;y_um;feed_m_min;vx_mm_s;vy_mm_s;x_cmd_mm;y_cmd_mm\n"
                        "0;1000;-2000;6;1;2;1.01;-2\n"
                        "2;1500;-2000;6;1;2;1.51;-2\n")
    tr = load_measured_csv(p)
    assert np.allclose(tr.t_s, [0.0, 0.002])
    assert np.allclose(tr.pos_mm, [[1.0, -2.0, 0.0], [1.5, -2.0, 0.0]])   # z absent -> 0
    assert np.allclose(tr.feed_mm_s, 100.0)                                 # 6 m/min
    assert np.allclose(tr.vel_mm_s, [[1, 2, 0], [1, 2, 0]])
    assert np.allclose(tr.cmd_pos_mm[:, 0], [1.01, 1.51])


def test_quoted_fields_and_bom(tmp_path):
    p = tmp_path / "q.csv"
    p.write_text('\ufeff"t_s","x_mm","y_mm"\n"0","1","2"\n"0.5","1.5","2"\n', encoding="utf-8")
    tr = load_measured_csv(p)
    assert np.allclose(tr.t_s, [0, 0.5]) and np.allclose(tr.pos_mm[1], [1.5, 2, 0])


def test_column_mapping_with_units(tmp_path):
    p = write(tmp_path, "Time,X1_ActualPosition,Y1_ActualPosition,Z,PathFeed\n"
                        "10,100,200,0,1.2\n"
                        "20,300,200,0,1.2\n")
    tr = load_measured_csv(p, columns={"t": "Time", "x": "X1_ActualPosition",
                                       "y": "Y1_ActualPosition", "z": "Z", "feed": "PathFeed"},
                           units={"t": "ms", "pos": "um", "feed": "m/min"})
    assert np.allclose(tr.t_s, [0.010, 0.020])
    assert np.allclose(tr.pos_mm[:, 0], [0.1, 0.3]) and np.allclose(tr.pos_mm[:, 1], 0.2)
    assert np.allclose(tr.feed_mm_s, 20.0)


def test_generated_time_and_index_column(tmp_path):
    p = write(tmp_path, ",x_mm,y_mm\n0,0,0\n1,1,0\n3,3,0\n")   # row 2 missing
    tr = load_measured_csv(p, sample_period_s=0.1)
    assert np.allclose(tr.t_s, [0.0, 0.1, 0.2])
    tr = load_measured_csv(p, sample_period_s=0.1, index_column="")
    assert np.allclose(tr.t_s, [0.0, 0.1, 0.3])


def test_roundtrip(tmp_path):
    rng = np.random.default_rng(0)
    t = np.cumsum(rng.uniform(0.001, 0.003, 50))
    tr = MeasuredTrace(t_s=t, pos_mm=rng.normal(size=(50, 3)), feed_mm_s=rng.uniform(0, 100, 50),
                       vel_mm_s=rng.normal(size=(50, 3)), cmd_pos_mm=rng.normal(size=(50, 3)),
                       line=np.arange(50))
    p = tmp_path / "rt.csv"
    write_measured_csv(tr, p, header_comment="written by a test")
    back = load_measured_csv(p)
    for name in ("t_s", "pos_mm", "feed_mm_s", "vel_mm_s", "cmd_pos_mm"):
        assert np.allclose(getattr(back, name), getattr(tr, name), rtol=1e-12, atol=1e-12)
    assert list(back.line) == list(range(50))


# --- errors: one line naming the file and the line or column ----------------------------------

@pytest.mark.parametrize("text, where, words", [
    ("", ":", "empty file"),
    ("# only a comment\n", ":", "empty file"),
    ("t_s,x_mm,y_mm\n", ":", "no data rows"),
    ("t_s,x_mm\n0,1\n", "column 'y_mm'", "missing column for 'y'"),
    ("x_mm,y_mm\n0,1\n", "column 't_s'", "missing time column"),
    ("t_s,x_mm,y_mm\n0,1,2\n0.1,nan,2\n", ":3:", "column 'x_mm' is nan"),
    ("t_s,x_mm,y_mm\n0,1,2\n0.1,,2\n", ":3:", "column 'x_mm' is empty"),
    ("t_s,x_mm,y_mm\n0,1,2\n0.1,1,abc\n", ":3:", "not a number"),
    ("t_s,x_mm,y_mm\n0,1,2\n0.1,1\n", ":3:", "no column 'y_mm'"),
    ("t_s,x_mm,y_mm\n0,1,2\n0.1,1,2\n0.1,1,2\n", ":4:", "repeats"),
    ("t_s,x_mm,y_mm\n0,1,2\n0.2,1,2\n0.1,1,2\n", ":4:", "goes back"),
    ("t_s,x_mm,y_mm\n0,1,2\n0.1,inf,2\n", ":3:", "not a finite number"),
    ("t_s,x_mm,y_mm,vx_mm_s\n0,1,2,3\n", "column 'vy_mm_s'", "need both vx and vy"),
])
def test_bad_files_give_one_line_errors(tmp_path, text, where, words):
    p = write(tmp_path, text)
    with pytest.raises(MeasuredDataError) as exc:
        load_measured_csv(p)
    msg = str(exc.value)
    assert "\n" not in msg
    assert msg.startswith(str(p))
    assert where in msg and words in msg


def test_bad_mapping(tmp_path):
    p = write(tmp_path, "T,X,Y\n0,1,2\n")
    with pytest.raises(MeasuredDataError, match="column 'Xpos': no such column"):
        load_measured_csv(p, columns={"t": "T", "x": "Xpos", "y": "Y"})
    with pytest.raises(MeasuredDataError, match="column 'T': unknown time unit 'fortnight'"):
        load_measured_csv(p, columns={"t": "T", "x": "X", "y": "Y"}, units={"t": "fortnight"})
    with pytest.raises(UsageError, match="unknown trace key 'w'"):
        load_measured_csv(p, columns={"w": "T"})
    with pytest.raises(UsageError):
        load_measured_csv(p, columns={"t": "T", "x": "X", "y": "Y"}, sample_period_s=0.1)
    with pytest.raises(MeasuredDataError, match="cannot read file"):
        load_measured_csv(p.parent / "missing.csv")


def test_trace_validation():
    with pytest.raises(MeasuredDataError, match="not after the previous"):
        MeasuredTrace(t_s=[0.0, 0.0], pos_mm=np.zeros((2, 3)))
    with pytest.raises(MeasuredDataError, match="shape"):
        MeasuredTrace(t_s=[0.0, 1.0], pos_mm=np.zeros((2, 2)))
    with pytest.raises(MeasuredDataError, match="not finite"):
        MeasuredTrace(t_s=[0.0, 1.0], pos_mm=[[0, 0, 0], [np.nan, 0, 0]])


def test_derived_speed_of_a_line():
    t = np.arange(0, 1, 0.004)
    p = np.column_stack([30.0 * t, 40.0 * t, 0 * t])   # 50 mm/s
    assert np.allclose(derived_speed_mm_s(t, p, smooth_s=0.02), 50.0)
    tr = MeasuredTrace(t_s=t, pos_mm=p)
    assert np.allclose(tr.speed_mm_s(0.02), 50.0)
    assert np.allclose(tr.shifted(0.5, (1, 2, 3)).pos_mm[0], [-1, -2, -3])


# --- UMich SMART mill ---------------------------------------------------------------------------

@pytest.fixture(scope="module")
def umich(shared) -> Path:
    return shared / "data" / "real" / "umich-smart-cnc-mill-tool-wear"


def _umich_rows(file):
    with open(file, newline="") as fh:
        rows = list(csv.reader(fh))
    return rows[0], rows[1:]


def test_umich_experiment_01(umich):
    header, rows = _umich_rows(umich / "experiment_01.csv")
    i_f, i_x = header.index("M1_CURRENT_FEEDRATE"), header.index("X1_ActualPosition")
    kept = [k for k, r in enumerate(rows) if float(r[i_f]) != 50.0 and float(r[i_x]) != 198.0]
    tr = load_umich_csv(umich / "experiment_01.csv")
    assert len(tr) == len(kept) == 991
    assert np.allclose(tr.t_s, 0.1 * np.array(kept))
    assert tr.has_command and tr.cmd_vel_mm_s is not None and tr.cmd_acc_mm_s2 is not None
    assert np.all(tr.extra["programmed_feed_mm_s"] == 6.0)
    assert not np.any(tr.pos_mm[:, 0] == 198.0)
    # kept rows form 3 runs: the three layers, separated by the rapid repositioning moves
    assert tr.segment[-1] == 2
    r0 = rows[kept[0]]
    assert tr.pos_mm[0, 1] == float(r0[header.index("Y1_ActualPosition")])
    assert tr.cmd_vel_mm_s[0, 0] == float(r0[header.index("X1_CommandVelocity")])
    assert tr.line[0] == int(float(r0[header.index("M1_sequence_number")]))
    full = load_umich_csv(umich / "experiment_01.csv", drop_unreliable=False)
    assert len(full) == len(rows) and full.segment[-1] == 0


def test_umich_bad_file(tmp_path):
    p = write(tmp_path, ",X1_ActualPosition\n0,1\n")
    with pytest.raises(MeasuredDataError, match="column 'Y1_ActualPosition'"):
        load_umich_csv(p)


# --- published summary values ---------------------------------------------------------------------

def test_paper_table3_summary():
    s = load_measured_summary(REPO / "measured" / "paper_table3.toml")
    c = s["circle_R30_F9"]
    assert (c.G_um, c.Fmax_um, c.Fmin_um) == (57.0, 101.0, -17.0)
    assert c.radius_mm == 30.0
    assert c.steady_feed_mm_s == pytest.approx(9.01 * 1000 / 60)
    assert c.programmed_feed_mm_s == pytest.approx(150.0)
    assert s["circle_R30_F24"].steady_feed_mm_s == pytest.approx(10.53 * 1000 / 60)
    assert s["circle_R30_F24"].G_um is None            # not published
    assert s["circle_R2.5_F6"].normal_accel_mm_s2 == pytest.approx(444.0)
    assert s["semi_spiral_F6_R10"].steady_feed_mm_s == pytest.approx(5.06 * 1000 / 60)
    assert s["quarter_spiral_F6_R16"].flags["has_steady_phase"] is True
    assert len(s.circles) == 8 and s.machine == "mikron"
    # circles whose published indexes are complete
    assert {e.id for e in s.circles if e.G_um is not None} == {
        "circle_R2.5_F6", "circle_R2.5_F9", "circle_R30_F6", "circle_R30_F9"}


@pytest.mark.parametrize("data, words", [
    ({"circle": [{"id": "a", "radius_mm": 1, "Gx_um": 3}]}, "circle[0].Gx_um: unknown key"),
    ({"circle": [{"id": "a", "radius_mm": 1, "G_furlong": 3}]}, "circle[0].G_furlong: unknown unit"),
    ({"circle": [{"id": "a", "G_um": 3}]}, "circle[0].radius_mm: missing key"),
    ({"circle": [{"id": "a", "radius_mm": "ten"}]}, "circle[0].radius_mm: must be a number"),
    ({"circle": [{"radius_mm": 1}]}, "circle[0].id: missing key"),
    ({"block": [{"id": "a"}, {"id": "a"}]}, "block[1].id: duplicate id"),
    ({"block": [{"id": "a", "steady_feed_m_min": 1, "steady_feed_mm_s": 2}]}, "given twice"),
    ({"block": [{"id": "a", "reaches_programmed": 1}]}, "block[0].reaches_programmed: must be true"),
    ({"cycle": [{"id": "a"}]}, "cycle[0].time_s: missing key"),
    ({"circles": []}, "circles: unknown table"),
    ({"summary": {"author": "x"}}, "summary.author: unknown key"),
    ({"circle": [{"id": "a", "radius_mm": 1, "Fmax_um": -5, "Fmin_um": 3}]}, "Fmax is below Fmin"),
])
def test_summary_validation(data, words):
    with pytest.raises(MeasuredDataError) as exc:
        summary_from_dict(data, "s.toml")
    assert str(exc.value).startswith("s.toml: ") and words in str(exc.value)


def test_summary_units_and_bad_toml(tmp_path):
    s = summary_from_dict({"transition": [{"id": "t", "radius_before_mm": 14, "radius_after_mm": 16,
                                           "angle_deg": 30, "feed_mm_min": 5290}],
                           "cycle": [{"id": "c", "time_ms": 1500, "program": "p.mpf"}]})
    assert s["t"].feed_mm_s == pytest.approx(5290 / 60)
    assert s["c"].time_s == pytest.approx(1.5) and s["c"].program == "p.mpf"
    p = write(tmp_path, "[[circle]\nid=1", "bad.toml")
    with pytest.raises(MeasuredDataError, match="bad.toml: not valid TOML"):
        load_measured_summary(p)


def test_derived_speed_of_a_sample_alone_between_gaps():
    # samples every 10 ms along X at 100 mm/s; two gaps longer than 3 periods leave the sample
    # at 0.5 s alone: it gets the speed across its neighbours, not zero
    t = np.concatenate([np.arange(0, 0.45, 0.01), [0.5], np.arange(0.55, 1.0, 0.01)])
    pos = np.column_stack([100 * t, 0 * t, 0 * t])
    v = derived_speed_mm_s(t, pos)
    assert np.allclose(v, 100.0)
