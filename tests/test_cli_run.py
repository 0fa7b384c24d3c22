"""`ncsim run`: cycle time, programmed against reached feed, where time is lost; --json, --trace.

Expected values come from the paper or from closed forms, not from ncsim's own output:

* circle R 30 at 24 m/min: the MIKRON holds V_Jtcurv = (J_tcurv R^2)^(1/3) = 10.53 m/min
  (paper Table 3, eq. 10-11, J_tcurv = 10 m/s^3 x 60 %);
* a rest-to-rest line of length L at feed v with jerk-limited ramps that do not reach the
  acceleration limit: T = L / v + 2 sqrt(v / j) (each S ramp lasts 2 sqrt(v/j) and covers
  v sqrt(v/j)); with BRISK (j = A / t_cy) the acceleration is reached: T = L / v + v / A + A / j.
"""
from __future__ import annotations

import io
import json
import math
import os

import pytest
from click.testing import CliRunner

from ncsim.cli.main import Progress, cli

# MIKRON (paper Table 1, sec. 5.2.4, 5.3.2) in mm and s
J_TCURV = 10_000.0 * 0.6      # mm/s^3, eq. 10
J_X = 5_000.0                 # mm/s^3
A_X = 2_500.0                 # mm/s^2
T_CY = 0.012                  # s


def invoke(*args):
    return CliRunner().invoke(cli, ["run", *map(str, args)])


@pytest.fixture(scope="module")
def programs(repo_root):
    return repo_root / "programs"


@pytest.fixture
def line_program(tmp_path):
    p = tmp_path / "line.mpf"
    p.write_text("G17 G90 G64 SOFT\nG1 X100 F6000\nM30\n")
    return p


def test_text_names_cycle_time_feeds_and_the_limit_holding_the_circle(programs):
    prog = programs / "circle_r30_f24000.mpf"
    r = invoke(prog, "--machine", "mikron")
    assert r.exit_code == 0, r.output
    assert r.stderr == ""                      # no warnings, no progress bar (not a terminal)
    out = r.stdout
    assert "cycle time" in out and " s " in out
    # programmed against reached feed: 24000 programmed, 10526 mm/min held (paper: 10.53 m/min)
    row = next(line for line in out.splitlines() if line.strip().startswith("24000"))
    programmed, setpoint, reached = (float(v) for v in row.split()[:3])
    v_jtcurv_mm_min = (J_TCURV * 30.0 ** 2) ** (1 / 3) * 60
    assert programmed == 24000
    assert setpoint == pytest.approx(v_jtcurv_mm_min, abs=1) and setpoint == pytest.approx(10530, abs=5)
    assert reached == pytest.approx(10530, abs=5)
    # the G3 block (file line 10) is among the blocks losing time, held by the NCU path jerk
    block = next(line for line in out.splitlines() if "circle_r30_f24000.mpf:10" in line)
    assert "ncu_path_jerk" in block


def test_json_summary_documented_keys_and_paper_setpoint(programs):
    r = invoke(programs / "circle_r30_f24000.mpf", "--machine", "mikron", "--json")
    assert r.exit_code == 0, r.output
    s = json.loads(r.stdout, parse_constant=lambda c: pytest.fail(f"non-JSON constant {c}"))
    assert s["schema"] == 1 and s["machine"] == "mikron"
    for key in ("cycle_time_s", "feed_efficiency", "limited_fraction", "time_by_limit_s",
                "feeds", "slowest_blocks", "blocks_detail", "warnings"):
        assert key in s
    assert len(s["blocks_detail"]) == s["blocks"] == 2
    circle = s["blocks_detail"][1]
    for key in ("line", "t_start_s", "duration_s", "feed_programmed_mm_min", "feed_max_mm_min", "limit"):
        assert key in circle
    assert circle["line"] == 10 and circle["limit"] == "ncu_path_jerk"
    assert circle["feed_programmed_mm_min"] == 24000
    assert circle["feed_setpoint_mm_min"] / 1000 == pytest.approx(10.53, abs=0.005)
    assert s["blocks_detail"][0]["feed_programmed_mm_min"] is None     # the rapid
    assert circle["t_start_s"] == pytest.approx(s["blocks_detail"][0]["duration_s"])


def test_rest_to_rest_line_matches_the_closed_form(line_program):
    """v = 100 mm/s, j = min(J_tcurv, J_X) = 5 m/s^3: the S ramps peak at sqrt(v j) = 707 mm/s^2
    < A_X, so T = L/v + 2 sqrt(v/j) = 1 + 0.2828 s."""
    s = json.loads(invoke(line_program, "-m", "mikron", "--json").stdout)
    v, j = 100.0, min(J_TCURV, J_X)
    assert math.sqrt(v * j) < A_X
    assert s["cycle_time_s"] == pytest.approx(100.0 / v + 2 * math.sqrt(v / j), rel=1e-6)
    assert s["blocks_detail"][0]["limit"] == "programmed"
    assert s["feed_efficiency"] == pytest.approx(1.0 / s["cycle_time_s"], rel=1e-6)


@pytest.mark.parametrize("flag", [("--accel-mode", "brisk"), ("--no-jerk-limited-ramps",)])
def test_acceleration_limited_ramps_closed_form(line_program, flag):
    """BRISK (or no jerk limitation): j = A / t_cy, the ramps reach A: T = L/v + v/A + A/j."""
    s = json.loads(invoke(line_program, "-m", "mikron", "--json", *flag).stdout)
    v, a = 100.0, A_X
    j = a / T_CY
    assert s["cycle_time_s"] == pytest.approx(100.0 / v + v / a + a / j, rel=1e-6)
    assert s["model"]["jerk_limited_ramps"] is ("--no-jerk-limited-ramps" not in flag)


def test_model_flag_switches_the_ncu_path_jerk_off(programs):
    """Without J_tcurv the circle's set point is the axis jerk at alpha_c = 45 deg (the first
    largest J_t, eq. 9): J_t = 5 / cos 45 = 7.07 m/s^3, V_Jt = (J_t R^2)^(1/3) = 11.12 m/min."""
    s = json.loads(invoke(programs / "circle_r30_f24000.mpf", "-m", "mikron", "--json",
                          "--no-ncu-path-jerk").stdout)
    circle = s["blocks_detail"][1]
    assert s["model"]["ncu_path_jerk"] is False
    assert circle["limit"] == "axis_jerk"
    v = (J_X / math.cos(math.radians(45)) * 30.0 ** 2) ** (1 / 3) * 60
    assert circle["feed_setpoint_mm_min"] == pytest.approx(v, rel=1e-4)


def test_top_limits_the_listed_blocks(programs):
    s = json.loads(invoke(programs / "bore_d25_f5984.mpf", "-m", "mikron", "--json", "--top", 2).stdout)
    assert len(s["slowest_blocks"]) == 2
    lost = [b["time_lost_s"] for b in s["slowest_blocks"]]
    assert lost == sorted(lost, reverse=True)
    out = invoke(programs / "bore_d25_f5984.mpf", "-m", "mikron", "--top", 0).stdout
    assert "blocks losing the most time" not in out


def test_trace_csv_columns_and_sampling(line_program, tmp_path):
    csv = tmp_path / "trace.csv"
    r = invoke(line_program, "-m", "mikron", "--trace", csv, "--dt", 0.01)
    assert r.exit_code == 0, r.output
    assert f"written to {csv}" in r.stdout
    lines = csv.read_text().splitlines()
    assert lines[0] == "t_s,s_mm,x_mm,y_mm,z_mm,feed_mm_min,block,line,limit"
    t = [float(row.split(",")[0]) for row in lines[1:]]
    assert t[1] - t[0] == pytest.approx(0.01)
    assert t[-1] == pytest.approx(1.282842712, rel=1e-6)          # ends with the motion
    mid = lines[1 + len(t) // 2].split(",")
    assert float(mid[5]) == pytest.approx(6000.0) and mid[7] == "2" and mid[8] == "programmed"
    assert float(lines[-1].split(",")[2]) == pytest.approx(100.0)  # x at the end
    # default --dt: the IPO cycle (12 ms); --trace-columns all
    invoke(line_program, "-m", "mikron", "--trace", csv, "--trace-columns", "all")
    lines = csv.read_text().splitlines()
    assert float(lines[2].split(",")[0]) == pytest.approx(T_CY)
    header = lines[0].split(",")
    assert {"ax_mm_s2", "jerk_t_mm_s3", "setpoint_mm_min", "programmed_mm_min", "phase"} <= set(header)


def test_crosscheck_summary(line_program):
    r = invoke(line_program, "-m", "mikron", "--crosscheck")
    assert r.exit_code == 0, r.output
    assert "cross-check against ruckig" in r.stdout and "worst ratio ncsim/ruckig" in r.stdout
    s = json.loads(invoke(line_program, "-m", "mikron", "--crosscheck", "--json").stdout)
    c = s["crosscheck"]
    assert c["blocks_checked"] == 1 and c["violations"] == 0
    # a rest-to-rest S curve that never reaches A is time-optimal under (v, A, j)
    assert c["worst_ratio"] == pytest.approx(1.0, abs=1e-3)


def test_interpreter_warnings_go_to_stderr_with_location(tmp_path):
    p = tmp_path / "warn.mpf"
    p.write_text("G1 X10 F1000\nB30\nM30\n")
    r = invoke(p, "-m", "mikron")
    assert r.exit_code == 0
    assert r.stderr.splitlines()[0].startswith(f"{p}:2:1: warning: ")
    assert "1 warning(s)" in r.stdout
    s = json.loads(invoke(p, "-m", "mikron", "--json").stdout)
    assert len(s["warnings"]) == 1 and s["warnings"][0].startswith(f"{p}:2:1: warning:")


def test_setup_file_moves_the_work_offset(tmp_path):
    p = tmp_path / "offset.mpf"
    p.write_text("G54 G1 X10 F600\nM30\n")
    setup = tmp_path / "setup.toml"
    setup.write_text("[work_offsets]\nG54 = [90.0, 0.0, 0.0]\n")
    s = json.loads(invoke(p, "-m", "mikron", "--setup", setup, "--json").stdout)
    assert s["path_length_mm"] == pytest.approx(100.0)


@pytest.mark.parametrize("args, expected", [
    (["--machine", "nosuch"], "nosuch: no machine file and no bundled machine named 'nosuch'"),
    (["--machine", "mikron", "--dt", "0"], "ncsim run: error: Invalid value for '--dt'"),
    (["--machine", "mikron", "--trace-columns", "x_mm,bogus"], "unknown trace column 'bogus'"),
    (["--machine", "mikron", "--accel-mode", "fast"], "ncsim run: error: Invalid value for '--accel-mode'"),
    ([], "ncsim run: error: Missing option '--machine'"),
    (["--machine", "mikron", "--dt", "0.1"], "ncsim run: error: --dt and --trace-columns apply to the trace"),
    (["--machine", "mikron", "--trace", ""], "Invalid value for '--trace': the file name is empty"),
    (["--machine", "mikron", "--setup", ""], "Invalid value for '--setup': the file name is empty"),
    (["--machine", "mikron", "--trace", "t.csv", "--dt", "nan"], "'--dt': 'nan' is not a finite number"),
])
def test_bad_options_exit_2_in_one_line(line_program, tmp_path, args, expected):
    extra = ["--trace", tmp_path / "t.csv"] if "--trace-columns" in args else []
    r = invoke(line_program, *args, *extra)
    assert r.exit_code == 2
    assert r.stdout == ""
    assert len(r.stderr.splitlines()) == 1 and expected in r.stderr
    assert "Traceback" not in r.stderr


def test_bad_program_exits_2_at_its_line(tmp_path):
    p = tmp_path / "bad.mpf"
    p.write_text("G1 X1 F100\nG2 X5 Y5\n")
    r = invoke(p, "-m", "mikron")
    assert r.exit_code == 2 and r.stdout == ""
    assert r.stderr.startswith(f"{p}:2:1: G2 without centre")
    assert len(r.stderr.splitlines()) == 1
    r = invoke(tmp_path / "missing.mpf", "-m", "mikron")
    assert r.exit_code == 2 and len(r.stderr.splitlines()) == 1
    # the whole file is missing: no line and column to name (not FILE:0:0)
    assert r.stderr == f"{tmp_path / 'missing.mpf'}: cannot read program: No such file or directory\n"


def test_unwritable_trace_exits_2(line_program, tmp_path):
    r = invoke(line_program, "-m", "mikron", "--trace", tmp_path / "no" / "dir" / "t.csv")
    assert r.exit_code == 2 and "cannot write trace file" in r.stderr
    assert len(r.stderr.splitlines()) == 1


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="needs Linux's /dev/full")
def test_a_full_disk_while_writing_the_trace_exits_2(line_program):
    r = invoke(line_program, "-m", "mikron", "--trace", "/dev/full")
    assert r.exit_code == 2 and "Traceback" not in r.output
    assert r.stderr == "ncsim run: error: /dev/full: cannot write trace file: No space left on device\n"


def test_per_limit_times_add_up_on_blocks_shorter_than_a_ramp(tmp_path):
    """A 1 um feed move then a 1 um rapid: each lasts about one IPO cycle (eq. 6). Pieces are
    given to blocks by time: found by path length with a 1e-9 mm tolerance, the last ramp
    pieces of the feed move counted as rapid time (the sums missed by up to an IPO cycle)."""
    p = tmp_path / "tiny.mpf"
    p.write_text("G17 G90 G64 F1000\nG1 X0.000001\nG0 X0\nM30\n")
    s = json.loads(invoke(p, "-m", "mikron", "--json").stdout)
    assert s["blocks"] == 2 and s["feed_time_s"] > 0 and s["rapid_time_s"] > 0
    assert sum(s["time_by_limit_s"].values()) == pytest.approx(s["feed_time_s"], rel=1e-12)
    assert sum(s["rapid_time_by_limit_s"].values()) == pytest.approx(s["rapid_time_s"], rel=1e-12)


def test_a_move_that_rounds_to_nothing_makes_no_block(tmp_path):
    """AROT then ``G0 X=IC(0)``: the rotated point differs from the start by 4e-16 mm. It made
    a rapid block, which stopped the feed moves around it (+24 ms) and lost negative time."""
    program = "G17 G90 G60\nG1 F6000 X1 Y-2.07486 Z3.356451\nAROT Z=63.418\n{}G1 Y-1 Z0.002\nM30\n"
    with_rapid, without = tmp_path / "phantom.mpf", tmp_path / "reference.mpf"
    with_rapid.write_text(program.format("G0 X=IC(0)\n"))
    without.write_text(program.format(""))
    a = json.loads(invoke(with_rapid, "-m", "mikron", "--json").stdout)
    b = json.loads(invoke(without, "-m", "mikron", "--json").stdout)
    assert a["blocks"] == b["blocks"] == 2
    assert a["cycle_time_s"] == b["cycle_time_s"]
    assert min(blk["time_lost_s"] for blk in a["blocks_detail"]) >= 0.0


@pytest.mark.parametrize("text, warnings", [
    ("", ["{p}: warning: the program ends without M30, M2 or M17 (truncated?)",
          "{p}: warning: no motion: the program moves no axis"]),
    ("; CAM output cut short\n", ["{p}:1:1: warning: the program ends without M30, M2 or M17 (truncated?)",
                                   "{p}: warning: no motion: the program moves no axis"]),
    ("G1 X10 F1000\nG1 Y10\n", ["{p}:2:1: warning: the program ends without M30, M2 or M17 (truncated?)"]),
    ("G1 X10 F1000\nM17\n", []),
    ("G4 F1\nM30\n", ["{p}: warning: no motion: the program moves no axis"]),
    # a subprogram file run on its own (real ones start with comments): not a truncated export
    ("; pocket\nPROC POCKET\nG1 X1 F100\nRET\n",
     ["{p}: warning: the file only defines PROC POCKET: nothing here calls it (run the program that does)",
      "{p}: warning: no motion: the program moves no axis"]),
])
def test_an_empty_or_truncated_program_is_a_warning(tmp_path, text, warnings):
    p = tmp_path / "cut.mpf"
    p.write_text(text)
    r = invoke(p, "-m", "mikron")
    assert r.exit_code == 0
    assert r.stderr.splitlines() == [w.format(p=p) for w in warnings]
    s = json.loads(invoke(p, "-m", "mikron", "--json").stdout)
    assert s["reached_program_end"] is ("truncated" not in " ".join(warnings))


def test_ctrl_c_exits_130_not_1(line_program, monkeypatch):
    """1 means a failed check: an interrupted CI job must not read as one."""
    import ncsim.pipeline

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(ncsim.pipeline, "simulate", interrupted)
    for args in (["run"], ["check", "--max-time", "9"]):
        r = CliRunner().invoke(cli, [*args, str(line_program), "-m", "mikron"])
        assert r.exit_code == 130 and r.stderr == "ncsim: interrupted\n", r.output


def test_an_unknown_option_of_ncsim_itself_is_one_line():
    r = CliRunner().invoke(cli, ["--badopt"])
    assert r.exit_code == 2
    assert r.stderr == "ncsim: error: No such option '--badopt'. (see 'ncsim --help')\n"


def test_progress_draws_stages_on_a_terminal_only():
    class Tty(io.StringIO):
        def isatty(self):
            return True

    tty = Tty()
    progress = Progress(["interpret", "plan"], stream=tty)
    with progress.stage("interpret"):
        pass
    with progress.stage("plan"):
        pass
    progress.close()
    text = tty.getvalue()
    assert "1/2 interpret" in text and "2/2 plan" in text and text.endswith("\r\033[K")
    pipe = io.StringIO()                 # not a terminal: nothing at all
    progress = Progress(["interpret"], stream=pipe)
    with progress.stage("interpret"):
        pass
    progress.close()
    assert pipe.getvalue() == ""
