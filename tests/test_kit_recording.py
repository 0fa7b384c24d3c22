"""The real SINUMERIK recording of ``../shared/data/real/kit-dmc60h-notch-sinumerik``: a DMC 60H
with an 840D, 50 Hz, commanded and actual positions in machine coordinates, part of the first
of three passes of its program, filtered and resampled by the recorder.

Expected values come from its SOURCE.md: the program origin in machine coordinates
(X -38.648045, Y 249.499981, Z 404.94), the run being pass 1 (Z -6), and the actual position
trailing the command by about 13 ms. The alignment half of the acceptance: the commanded
positions follow the program to <= 5 um rms over the recording, the work offset is found
within 5 um, the covered blocks are named, the servo part reports the lag; wrong units and
another program's trace exit 2 with one line.
"""
from __future__ import annotations

import json

import click
import numpy as np
import pytest
from click.testing import CliRunner

from ncsim.cli.gap import gap
from ncsim.cli.main import NcsimGroup

KNOWN_OFFSET_MM = (-38.648045, 249.499981, 404.94)     # SOURCE.md, "Coordinates"


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


@pytest.fixture(scope="module")
def kit(shared):
    folder = shared / "data/real/kit-dmc60h-notch-sinumerik"
    return folder / "AL_2007_T4_Notch_Normal.mpf", folder / "DMC60H_AL2007T4_Notch_Normal_1.csv"


@pytest.fixture(scope="module")
def result(kit, repo_root):
    prog, csv = kit
    r = run(prog, "--measured", csv, "--machine", repo_root / "machines/dmc60h.toml",
            "--effects", "cycle_time,servo_lag,servo_delay", "--no-combine", "--json")
    assert r.exit_code == 0, r.output
    return json.loads(r.output)


def test_commanded_positions_follow_the_program(result):
    reg = result["registration"]
    assert reg["status"] == "ok" and reg["signal"] == "command"
    assert reg["residual_rms_um"] <= 5.0
    assert reg["offset_source"] == "fitted"


def test_work_offset_found(result):
    err_um = (np.array(result["registration"]["offset_mm"]) - KNOWN_OFFSET_MM) * 1000.0
    assert np.all(np.abs(err_um) <= 5.0), err_um


def test_covered_blocks_named(result):
    reg = result["registration"]
    first, last = reg["first"], reg["last"]
    assert (first["line"], first["block"]) == (15, "G0 Z-6.0")
    assert (last["line"], last["block"]) == (20, "G1 X-10.0 Y60")
    assert (reg["pass"], reg["passes"]) == (1, 3)
    assert "AL_2007_T4_Notch_Normal.mpf:15 (G0 Z-6.0)" in reg["covered"]
    assert "pass 1 of 3" in reg["covered"]


def test_model_time_over_the_covered_places(kit):
    """Each sample's place gives a model's time over what the recording covers: a model that
    runs the covered path exactly as recorded (its own samples) takes the recorded time."""
    from ncsim.gap.measured import load_measured_csv
    from ncsim.gap.pipeline import register_trace
    from ncsim.machine import load_machine
    from ncsim.nc.interpret import interpret_file
    prog, csv = kit
    m = load_machine("mikron")
    trace = load_measured_csv(csv)
    path = interpret_file(prog, m).path
    reg = register_trace(trace, path, m, {})
    t = reg.model_time_s(trace.t_s, np.maximum.accumulate(reg.s_mm))
    assert t[-1] - t[0] == pytest.approx(trace.t_s[-1] - trace.t_s[0], abs=0.02)


def test_at_a_high_rate(kit):
    """The recording interpolated to 1,000,000 rows (30 kHz): averaged down to 1 ms, it still
    registers on pass 1 at the known offset."""
    from ncsim.gap.measured import MeasuredTrace, load_measured_csv
    from ncsim.gap.pipeline import MIN_PERIOD_S, register_trace
    from ncsim.machine import load_machine
    from ncsim.nc.interpret import interpret_file
    prog, csv = kit
    m = load_machine("mikron")
    rec = load_measured_csv(csv)
    t = np.linspace(rec.t_s[0], rec.t_s[-1], 1_000_000)

    def at(p):
        return np.column_stack([np.interp(t, rec.t_s, p[:, k]) for k in range(3)])

    fast = MeasuredTrace(t_s=t, pos_mm=at(rec.pos_mm), cmd_pos_mm=at(rec.cmd_pos_mm),
                         source="kit at 30 kHz").thinned(MIN_PERIOD_S)
    assert len(fast) == -(-1_000_000 // 30)          # bins of 30 rows (0.99 ms each)
    reg = register_trace(fast, interpret_file(prog, m).path, m, {})
    assert np.all(np.abs(reg.offset_mm - KNOWN_OFFSET_MM) <= 5e-3)
    assert (reg.first.line, reg.last.line, reg.pass_index) == (15, 20, 1)


def test_servo_part_reports_the_lag(result):
    servo = result["servo_part"]
    lags = {e["effect"]: e["lag_ms"] for e in servo["effects"] if e["lag_ms"] is not None}
    assert set(lags) == {"servo_lag", "servo_delay"}
    for lag in lags.values():
        assert 12.0 <= lag <= 14.0                      # SOURCE.md: about 13 ms


def test_text_names_the_recording(kit, repo_root):
    prog, csv = kit
    r = run(prog, "--measured", csv, "--machine", repo_root / "machines/dmc60h.toml",
            "--effects", "cycle_time,servo_delay", "--no-combine")
    assert r.exit_code == 0, r.output
    head = r.output.splitlines()[:2]
    assert head[0].startswith("recording: commanded positions cover AL_2007_T4_Notch_Normal.mpf:15")
    assert "(fitted); residual 0.1" in head[1]


def test_the_wrong_pass_offset_is_refused(kit):
    prog, csv = kit
    r = run(prog, "--measured", csv, "--work-offset", "G54=-38.648045,249.499981,410.94")
    assert r.exit_code == 2 and r.output.count("\n") == 1
    assert "given work offset" in r.output and "--work-offset" in r.output


def test_um_read_as_mm_is_refused(kit, tmp_path):
    """The same recording written in um (its KIT header kept) and read as mm."""
    prog, csv = kit
    lines = csv.read_text().splitlines()
    header = lines[0].split(",")
    cols = [header.index(c) for c in ("pos_x", "pos_y", "pos_z", "cmd_pos_x", "cmd_pos_y",
                                      "cmd_pos_z")]
    out = [lines[0]]
    for ln in lines[1:]:
        cells = ln.split(",")
        for c in cols:
            cells[c] = repr(float(cells[c]) * 1000.0)
        out.append(",".join(cells))
    um = tmp_path / "kit_um.csv"
    um.write_text("\n".join(out) + "\n")
    r = run(prog, "--measured", um)
    assert r.exit_code == 2 and r.output.count("\n") == 1 and r.output.startswith(str(um))
    assert "--unit pos=um" in r.output


def test_another_programs_trace_is_refused(kit, repo_root):
    _, csv = kit
    r = run(repo_root / "programs/diagnosis_mix.mpf", "--measured", csv)
    assert r.exit_code == 2 and r.output.count("\n") == 1
    assert "do not follow the program" in r.output
