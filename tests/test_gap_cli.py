"""`ncsim gap` through click's CliRunner: JSON schema, plots, corrected machine file, the
command/actual split, and one-line errors for bad measured files."""
from __future__ import annotations

import json
import math

import click
import pytest
from click.testing import CliRunner

from ncsim.cli.main import NcsimGroup
from ncsim.cli.gap import gap
from ncsim.gap.truth.cases import Case, truth_trace
from ncsim.nc.interpret import interpret_text
from ncsim.machine import load_machine
from ncsim.gap.measured import write_measured_csv
from ncsim.gap.truth.synth import ScopeConfig


@click.group(cls=NcsimGroup)
def cli():
    """test group: renders ncsim errors as the real one does"""


cli.add_command(gap)

SPIRAL = """N10 G17 G90 G64 SOFT
N20 G0 X0 Y-10 Z0
N30 G3 X10 Y0 I0 J10 F12000
N40 G3 X-2 Y12 I-12 J0
N50 G3 X-16 Y-2 I0 J-14
N60 G3 X0 Y-18 I16 J0
N70 G3 X18 Y0 I0 J18
N80 M30
"""


def run(args):
    """``ncsim gap ARGS`` on the MIKRON unless ARGS name a machine (gap requires --machine)."""
    if "--machine" not in args:
        args = [*args, "--machine", "mikron"]
    return CliRunner().invoke(cli, ["gap", *args], catch_exceptions=False)


@pytest.fixture(scope="module")
def spiral_case(tmp_path_factory):
    """A quarter-circle spiral measured with a transition time of 6 ms (withheld from the base)."""
    d = tmp_path_factory.mktemp("gapcli")
    prog = d / "spiral.mpf"
    prog.write_text(SPIRAL)
    m = load_machine("mikron")
    path = interpret_text(SPIRAL, str(prog), m).path
    case = Case(index=0, effect="transition", params={"transition_time_ms": 6.0},
                base="full-minus-transition",
                scope=ScopeConfig(period_s=4e-3, noise_um=0.5, quant_um=0.1, time_offset_s=0.25,
                                  pos_offset_mm=(1.0, -2.0, 0.5)), lead_s=0.2, seed=2)
    meas = truth_trace(path, m, case)
    csv = d / "scope.csv"
    write_measured_csv(meas, csv)
    return d, prog, csv


def test_trace_json_plot_and_machine(spiral_case):
    d, prog, csv = spiral_case
    out_machine = d / "corrected.toml"
    r = run([str(prog), "--measured", str(csv), "--base", "full-minus-transition",
             "--effects", "transition,ncu_path_jerk,compliance", "--json",
             "--plot", str(d / "fig"), "--write-machine", str(out_machine)])
    assert r.exit_code == 0, r.output
    data = json.loads(r.output)
    effects = data["diagnosis"]["effects"]
    assert effects[0]["effect"] == "transition"
    for e in effects:
        assert {"effect", "params", "gap_before", "gap_after", "shrink_percent"} <= set(e)
        assert e["gap_before"]["gap"] == effects[0]["gap_before"]["gap"]
    assert math.isclose(effects[0]["params"]["transition_time_ms"], 6.0, rel_tol=0.05)
    assert effects[0]["shrink_percent"] > 80
    assert (d / "fig-gap.png").stat().st_size > 10_000
    spec = load_machine(out_machine)
    # the machine file holds the corrected model: the combined one when there is one (its
    # effects are re-fitted together), else the best single fit
    final = data["diagnosis"]["combined"] or effects[0]
    assert math.isclose(spec.ncu.transition_time_s * 1000, final["params"]["transition_time_ms"],
                        rel_tol=1e-6)
    assert "Calibrated by `ncsim gap`" in out_machine.read_text()


def test_trace_text_with_column_mapping(spiral_case, tmp_path):
    d, prog, csv = spiral_case
    # the same trace with other column names and units: time in ms, positions in um
    lines = [ln for ln in csv.read_text().splitlines() if not ln.startswith("#")]
    rows = [list(map(float, ln.split(","))) for ln in lines[1:]]
    other = tmp_path / "other.csv"
    other.write_text("Time;PosX;PosY;PosZ\n" + "\n".join(
        f"{r[0] * 1e3!r};{r[1] * 1e3!r};{r[2] * 1e3!r};{r[3] * 1e3!r}" for r in rows) + "\n")
    r = run([str(prog), "--measured", str(other), "--base", "full-minus-transition",
             "--effects", "transition", "--column", "t=Time", "--column", "x=PosX",
             "--column", "y=PosY", "--column", "z=PosZ", "--unit", "t=ms", "--unit", "pos=um"])
    assert r.exit_code == 0, r.output
    assert "1 transition" in r.output and "where the base model departs" in r.output


def test_summary_json(repo_root):
    r = run([str(repo_root / "programs/circle_r2p5_f6000.mpf"),
             str(repo_root / "programs/circle_r30_f9000.mpf"),
             "--measured", str(repo_root / "measured/paper_table3.toml"),
             "--effects", "ncu_path_jerk,compliance", "--json", "--no-combine"])
    assert r.exit_code == 0, r.output
    data = json.loads(r.output)
    assert data["kind"] == "summary" and data["base"] == "axis-only"
    assert data["best_kinematics"]["effect"] == "ncu_path_jerk"
    assert data["best_radial"]["effect"] == "compliance"
    for e in data["effects"]:
        assert {"effect", "params", "gap_before", "gap_after", "shrink_percent"} <= set(e)


def test_command_and_actual_split(tmp_path, shared):
    """UMich run without a program: the servo part alone."""
    experiment = shared / "data/real/umich-smart-cnc-mill-tool-wear/experiment_09.csv"
    r = run(["--measured", str(experiment), "--json"])
    assert r.exit_code == 0, r.output
    data = json.loads(r.output)
    assert "servo_part" in data and data["servo_part"]["best"] in ("servo_delay", "servo_lag")
    assert 5.0 <= data["servo_part"]["effects"][0]["lag_ms"] <= 10.0
    r = run(["--measured", str(experiment), "--plot", str(tmp_path / "u")])
    assert r.exit_code == 0 and "servo part" in r.output
    assert (tmp_path / "u-servo.png").exists()


@pytest.mark.parametrize("text, words", [
    ("", "empty file"),
    ("t_s,x_mm\n0,1\n", "column 'y_mm'"),
    ("t_s,x_mm,y_mm\n0,1,2\n0.1,nan,2\n", ":3: column 'x_mm' is nan"),
    ("t_s,x_mm,y_mm\n0,1,2\n0.2,1,2\n0.1,1,2\n", ":4:"),
    ("t_s,x_mm,y_mm\n0,1,2\n0.1,1,2\n0.1,1,2\n", ":4:"),
])
def test_bad_measured_files_give_one_line(tmp_path, repo_root, text, words):
    f = tmp_path / "bad.csv"
    f.write_text(text)
    r = CliRunner().invoke(cli, ["gap", str(repo_root / "programs/circle_r30_f6000.mpf"),
                                 "--machine", "mikron", "--measured", str(f)])
    assert r.exit_code == 2
    msg = r.output.strip()
    assert "\n" not in msg and msg.startswith(str(f)) and words in msg


@pytest.mark.parametrize("args, words", [
    (["--base", "nope"], "unknown base model 'nope'"),
    (["--effects", "wobble"], "unknown effect 'wobble'"),
    (["--column", "tx"], "--column must be KEY=VALUE"),
    (["--sample-period-ms", "-1"], "'--sample-period-ms': -1.0 is not in the range x>0"),
    (["--sample-period-ms", "nan"], "'--sample-period-ms': 'nan' is not a finite number"),
    (["--sample-period-ms", "2"], "has a time column 't_s'"),
])
def test_bad_options(spiral_case, args, words):
    d, prog, csv = spiral_case
    r = CliRunner().invoke(cli, ["gap", str(prog), "--machine", "mikron", "--measured", str(csv),
                                 *args])
    assert r.exit_code == 2 and words in r.output and r.output.count("\n") == 1


def test_trace_without_program_or_command(spiral_case):
    d, prog, csv = spiral_case
    r = CliRunner().invoke(cli, ["gap", "--machine", "mikron", "--measured", str(csv)])
    assert r.exit_code == 2 and "nothing to compare with" in r.output
    r = CliRunner().invoke(cli, ["gap", "--machine", "mikron", "--measured", str(d / "missing.csv")])
    assert r.exit_code == 2 and "missing.csv" in r.output


def test_split_planner_and_servo_parts(tmp_path):
    """Command and actual recorded: the planner part names the withheld transition crossing
    from the command, the servo part the position loop (FFWOF, Kv 40 1/s) of the RK4 truth."""
    from ncsim.gap.effects import get_effect, make_base
    from ncsim.gap.diagnose import ModelCache
    from ncsim.gap.truth.servo import ServoParams, simulate_servo
    from ncsim.gap.truth.synth import degrade
    prog = tmp_path / "spiral.mpf"
    prog.write_text(SPIRAL)
    m = load_machine("mikron")
    path = interpret_text(SPIRAL, str(prog), m).path
    model = get_effect("transition").apply(make_base(m, "full"), {"transition_time_ms": 5.0})
    t, sp, _, _ = ModelCache(path, dt_s=1e-3, settle_s=0.3).setpoint(model)
    r = simulate_servo(t, sp.pos_mm, ServoParams(kv_1_s=40.0), cmd_vel_mm_s=sp.vel_mm_s, dt_s=2.5e-4)
    meas = degrade(r.t_s, r.pos_mm, ScopeConfig(period_s=2e-3, noise_um=0.3, record_command=True),
                   seed=4, cmd_pos_mm=r.cmd_pos_mm)
    csv = tmp_path / "split.csv"
    write_measured_csv(meas, csv)
    out_machine = tmp_path / "m.toml"
    res = run([str(prog), "--measured", str(csv), "--base", "full-minus-transition",
               "--effects", "transition,ncu_path_jerk,servo_lag,servo_delay", "--json",
               "--write-machine", str(out_machine)])
    assert res.exit_code == 0, res.output
    data = json.loads(res.output)
    planner = data["planner_part"]["effects"][0]
    assert planner["effect"] == "transition"
    assert math.isclose(planner["params"]["transition_time_ms"], 5.0, rel_tol=0.05)
    servo = data["servo_part"]
    assert servo["best"] == "servo_lag"
    assert math.isclose(servo["effects"][0]["params"]["kv_1_s"], 40.0, rel_tol=0.05)
    spec = load_machine(out_machine)
    # the file keeps seven significant digits of a fitted value
    assert math.isclose(spec.ncu.transition_time_s * 1000, planner["params"]["transition_time_ms"],
                        rel_tol=1e-6)
    assert math.isclose(float(spec.position_gain_1_s[0]), servo["effects"][0]["params"]["kv_1_s"],
                        rel_tol=1e-6)
