"""`ncsim gap` on recordings as they come: a circle recorded from its own start after a G0
approach, work offsets from the command line, refusals that name what to check, the fuzzing
reproducers of wrong units, fast reading and thinning of long traces, and the progress of the
fits.

Truths come from the independent RK4 loop simulation (``ncsim.gap.truth``) with planted
parameters and offsets; the fuzzing files are those of ``../shared/data/fuzz-repro``.
"""
from __future__ import annotations

import json
import math

import click
import numpy as np
import pytest
from click.testing import CliRunner

from ncsim.cli.gap import gap
from ncsim.cli.main import NcsimGroup
from ncsim.errors import MeasuredDataError
from ncsim.gap.diagnose import ModelCache
from ncsim.gap.effects import make_base
from ncsim.gap.measured import MeasuredTrace, load_measured_csv, write_measured_csv
from ncsim.gap.pipeline import diagnose
from ncsim.gap.truth.cases import Case, truth_trace
from ncsim.gap.truth.synth import ScopeConfig
from ncsim.machine import load_machine
from ncsim.nc.interpret import interpret_text


@click.group(cls=NcsimGroup)
def cli():
    """test group: renders ncsim errors as the real one does"""


cli.add_command(gap)


def run(*args):
    """``ncsim gap ARGS`` on the MIKRON unless ARGS name a machine (gap requires --machine)."""
    args = [*map(str, args)]
    if "--machine" not in args:
        args += ["--machine", "mikron"]
    return CliRunner().invoke(cli, ["gap", *args], catch_exceptions=False)


CIRCLE = """N10 G17 G90 G64 SOFT
N20 G0 X30 Y0 Z0
N30 G2 X30 Y0 I-30 J0 F12000
N40 M30
"""
OFFSET = (12.5, -7.25, 3.0)


@pytest.fixture(scope="module")
def circle_case(tmp_path_factory):
    """A full circle R 30 at 12 m/min after a 30 mm G0 approach, run with an NCU path jerk of
    3 m/s^3 (withheld from the base model), recorded by a scope triggered at the circle's
    block change: the recording starts where the circle starts."""
    d = tmp_path_factory.mktemp("circle")
    prog = d / "circle.mpf"
    prog.write_text(CIRCLE)
    m = load_machine("mikron")
    path = interpret_text(CIRCLE, str(prog), m).path
    case = Case(index=0, effect="ncu_path_jerk", params={"j_tcurv_m_s3": 3.0},
                base="full-minus-ncu_path_jerk",
                scope=ScopeConfig(period_s=4e-3, noise_um=1.0, quant_um=0.5, time_offset_s=0.8,
                                  pos_offset_mm=OFFSET), lead_s=0.2, seed=5)
    meas = truth_trace(path, m, case)
    t, sp, _, _ = ModelCache(path, dt_s=1e-3, settle_s=0.0).setpoint(make_base(m, "full"))
    t_circle = t[np.argmax(sp.block == 1)] + case.lead_s
    rec = meas.select(meas.extra["truth_t_s"] >= t_circle)
    csv = d / "circle.csv"
    write_measured_csv(rec, csv)
    return prog, csv


def test_a_circle_recorded_from_its_start_aligns_to_the_circle(circle_case):
    prog, csv = circle_case
    r = run(prog, "--measured", csv, "--base", "full-minus-ncu_path_jerk",
            "--effects", "ncu_path_jerk,servo_lag,transition", "--json", "--no-combine")
    assert r.exit_code == 0, r.output
    data = json.loads(r.output)
    reg = data["registration"]
    assert reg["status"] == "ok"
    assert np.allclose(reg["offset_mm"], OFFSET, atol=5e-3)
    # the first sample is where the circle starts (the actual trails the command by a few
    # tenths of a millimetre), the last where it ends: not on the 30 mm G0 approach
    assert 30.0 - 1.0 <= reg["first"]["s_mm"] <= 30.0 + 1e-6
    assert (reg["last"]["line"], round(reg["last"]["fraction"], 3)) == (3, 1.0)
    d = data["diagnosis"]
    assert d["gap_before"]["contour_rms_um"] < 10.0            # not 37 mm
    best = d["effects"][0]
    assert best["effect"] == "ncu_path_jerk"
    assert math.isclose(best["params"]["j_tcurv_m_s3"], 3.0, rel_tol=0.05)
    assert best["shrink_percent"] > 90


def test_work_offset_option_and_its_errors(circle_case):
    prog, csv = circle_case
    r = run(prog, "--measured", csv, "--base", "full-minus-ncu_path_jerk",
            "--effects", "ncu_path_jerk", "--json", "--no-combine",
            "--work-offset", "G54=12.5,-7.25,3")
    assert r.exit_code == 0, r.output
    reg = json.loads(r.output)["registration"]
    assert reg["offset_mm"] == [12.5, -7.25, 3.0] and reg["offset_source"].startswith("G54 given")
    r = run(prog, "--measured", csv, "--work-offset", "G54=12.5,-7.25,5")   # 2 mm off in Z
    assert r.exit_code == 2 and r.output.count("\n") == 1
    assert "given work offset" in r.output and "--work-offset" in r.output
    r = run("--measured", csv, "--work-offset", "G54=12.5,-7.25,3")   # no program to place on
    assert r.exit_code == 2 and "give the program" in r.output
    for bad, words in (("G54=1,2", "three finite numbers"), ("G99=1,2,3", "not a settable"),
                       ("G54", "KEY=VALUE"), ("G54=1,2,nan", "three finite numbers")):
        r = run(prog, "--measured", csv, "--work-offset", bad)
        assert r.exit_code == 2 and words in r.output and r.output.count("\n") == 1


def test_a_program_that_selects_g54_is_interpreted_with_it(circle_case, tmp_path):
    """The program selects G54 itself: with its offset given, the path is in machine
    coordinates and the recording must follow it there; without, the offset is fitted."""
    prog, csv = circle_case
    g54 = tmp_path / "circle_g54.mpf"
    g54.write_text(CIRCLE.replace("SOFT\n", "SOFT G54\n", 1))
    r = run(g54, "--measured", csv, "--effects", "transition", "--json", "--no-combine",
            "--work-offset", "G54=12.5,-7.25,3")
    assert r.exit_code == 0, r.output
    reg = json.loads(r.output)["registration"]
    assert reg["offset_mm"] == [0.0, 0.0, 0.0] and reg["offset_source"] == "G54 applied by the program"
    r = run(g54, "--measured", csv, "--effects", "transition", "--json", "--no-combine")
    assert r.exit_code == 0, r.output
    assert np.allclose(json.loads(r.output)["registration"]["offset_mm"], OFFSET, atol=5e-3)


def test_a_recording_that_does_not_move_is_refused(tmp_path, repo_root):
    f = tmp_path / "still.csv"
    f.write_text("t_s,x_mm,y_mm\n" + "".join(f"{k * 0.01:.2f},1,2\n" for k in range(50)))
    r = run(repo_root / "programs/circle_r30_f6000.mpf", "--measured", f)
    assert r.exit_code == 2 and "does not move" in r.output and r.output.count("\n") == 1


def test_setup_file_gives_the_offset(circle_case, tmp_path):
    prog, csv = circle_case
    setup = tmp_path / "setup.toml"
    setup.write_text("[work_offsets]\nG54 = [12.5, -7.25, 3.0]\n")
    r = run(prog, "--measured", csv, "--setup", setup, "--effects", "transition", "--json",
            "--no-combine")
    assert r.exit_code == 0, r.output
    assert json.loads(r.output)["registration"]["offset_source"].startswith("G54 given")


def test_recordings_that_do_not_fit_are_refused_in_one_line(circle_case, tmp_path, repo_root):
    prog, csv = circle_case
    rec = load_measured_csv(csv)
    um = tmp_path / "in_um.csv"                    # the positions written in um, read as mm
    write_measured_csv(MeasuredTrace(t_s=rec.t_s, pos_mm=rec.pos_mm * 1000.0), um)
    r = run(prog, "--measured", um)
    assert r.exit_code == 2 and r.output.count("\n") == 1 and r.output.startswith(str(um))
    assert "--unit pos=um" in r.output
    r = run(repo_root / "programs/diagnosis_mix.mpf", "--measured", csv)   # another program
    assert r.exit_code == 2 and r.output.count("\n") == 1
    assert "do not follow the program" in r.output and "--column" in r.output


def test_missing_column_hint_names_the_option(tmp_path, repo_root):
    f = tmp_path / "t.csv"
    f.write_text("time,X1,Y1\n0,1,2\n0.1,1,2\n")
    r = run(repo_root / "programs/circle_r30_f6000.mpf", "--measured", f)
    assert r.exit_code == 2 and "--column x=NAME" in r.output and r.output.count("\n") == 1
    f.write_text("x_mm,y_mm\n1,2\n1,2\n")
    r = run(repo_root / "programs/circle_r30_f6000.mpf", "--measured", f)
    assert r.exit_code == 2 and "--column t=NAME" in r.output


@pytest.mark.parametrize("name, words", [
    ("G1_trace_time_in_ms_no_unit.csv", "--unit t=ms"),
    ("G1_trace_pos_in_um_no_unit.csv", "--unit pos=um"),
    ("G3_trace_decimal_comma_cell.csv", "the header has 9 (a decimal comma?)"),
    ("G3_trace_underscore_number.csv", "is not a number: '1_000'"),
])
def test_fuzz_reproducers_are_refused_with_the_cause(shared, name, words):
    folder = shared / "data/fuzz-repro"
    r = run(folder / "bore.mpf", "--measured", folder / name)
    assert r.exit_code == 2, r.output
    assert r.output.count("\n") == 1 and words in r.output and "Traceback" not in r.output


def test_the_fuzz_reference_trace_is_diagnosed(shared):
    folder = shared / "data/fuzz-repro"
    r = run(folder / "bore.mpf", "--measured", folder / "G0_bore_trace_ok.csv",
            "--effects", "transition", "--json", "--no-combine")
    assert r.exit_code == 0, r.output
    reg = json.loads(r.output)["registration"]
    assert reg["status"] == "ok" and reg["residual_rms_um"] < 1.0
    assert (reg["first"]["line"], reg["last"]["line"]) == (12, 19)


def test_progress_reports_every_stage(circle_case):
    prog, csv = circle_case
    calls = []
    diagnose([prog], csv, "mikron", effects=["ncu_path_jerk", "transition"], combine=True,
             base="full-minus-ncu_path_jerk", progress=lambda *a: calls.append(a))
    names = [c[0] for c in calls]
    assert names[:3] == ["read", "interpret", "register"]
    assert "fit ncu_path_jerk" in names and "fit transition" in names
    # after the fits: the combined model, then the more plausible of equally good hypotheses
    assert names[-2:] == ["combine", "plausible hypotheses"]
    assert [c[1] for c in calls] == list(range(1, len(calls) + 1))
    assert calls[-1][2] == len(calls)


def test_thinned_averages_bins_within_pieces():
    t = np.concatenate([np.arange(0.0, 0.01, 1e-4), 0.02 + np.arange(0.0, 0.005, 1e-4)])
    pos = np.column_stack([t * 100.0, np.zeros_like(t), np.zeros_like(t)])
    tr = MeasuredTrace(t_s=t, pos_mm=pos, line=np.arange(len(t)))
    th = tr.thinned(1e-3)                       # bins of 10 samples; the gap starts a new piece
    assert len(th) == 10 + 5
    assert th.t_s[0] == pytest.approx(4.5e-4) and th.t_s[10] == pytest.approx(0.02045)
    assert np.allclose(th.pos_mm[:, 0], th.t_s * 100.0)
    assert list(th.line[:2]) == [0, 10]          # integers keep the bin's first value
    assert tr.thinned(1e-4) is tr


def test_long_traces_are_read_in_one_pass(tmp_path):
    """A 100,000-row trace with a bad row at the end: the compiled reader reads the good file,
    and the bad one is reported at its line."""
    n = 100_000
    t = np.arange(n) * 1e-3
    f = tmp_path / "big.csv"
    np.savetxt(f, np.column_stack([t, t, np.ones(n), np.full(n, 2.0)]), fmt="%.4f",
               delimiter=",", header="t_s,x_mm,y_mm,z_mm", comments="")
    body = f.read_text().split("\n", 1)[1].rstrip("\n")
    tr = load_measured_csv(f)
    assert len(tr) == n and tr.pos_mm[-1, 0] == pytest.approx(t[-1])
    f.write_text("t_s,x_mm,y_mm,z_mm\n" + body + "\n200.0,1,2\n")
    with pytest.raises(MeasuredDataError, match=f":{n + 2}: row has 3 fields"):
        load_measured_csv(f)
    f.write_text("t_s;x_mm;y_mm\r0;1,5;2\r")          # CR line ends, a decimal comma cell
    with pytest.raises(MeasuredDataError, match=":2: column 'x_mm' is not a number"):
        load_measured_csv(f)
