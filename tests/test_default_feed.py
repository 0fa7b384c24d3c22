"""The machine's default feed, setting data SD42110 ``$SC_DEFAULT_FEED`` (machine-file key
``ncu.default_feed_mm_min``): the path feed a program starts with until its first F. As
delivered it is 0, and a G1 before any F is alarm 10860 "no feed programmed".

Expected values are closed forms (as in test_cli_run): a rest-to-rest line of length L at feed
v whose jerk-limited ramps stay below the acceleration limit lasts T = L / v + 2 sqrt(v / j);
the MIKRON's X jerk 5 m/s^3 is below its tangential path jerk J_tcurv = 10 x 0.6 m/s^3.
"""
from __future__ import annotations

import json
import math

import pytest
from click.testing import CliRunner

from ncsim.cli.main import cli
from ncsim.errors import MachineSpecError
from ncsim.machine import dump_machine_toml, load_machine, machine_from_dict

J_X_MM_S3 = 5_000.0
A_X_MM_S2 = 2_500.0


def _run(program, machine, *options):
    return CliRunner().invoke(cli, ["run", str(program), "--machine", str(machine), "--json", *options])


@pytest.fixture(scope="module")
def mikron():
    return load_machine("mikron")


@pytest.fixture
def machine_with_default_feed(tmp_path, mikron):
    """The MIKRON with SD42110 = 600 mm/min, written as a user would: one key in [ncu]."""
    text = dump_machine_toml(mikron)
    assert "default_feed_mm_min = 0.0" in text
    path = tmp_path / "mikron_sd42110.toml"
    path.write_text(text.replace("default_feed_mm_min = 0.0", "default_feed_mm_min = 600"))
    return path


def test_a_line_before_any_f_runs_at_the_default_feed(tmp_path, machine_with_default_feed):
    program = tmp_path / "line.mpf"
    program.write_text("G17 G90 G64 SOFT\nG1 X100\nM30\n")
    r = _run(program, machine_with_default_feed)
    assert r.exit_code == 0, r.output
    s = json.loads(r.stdout)
    v, j = 600.0 / 60.0, J_X_MM_S3
    assert math.sqrt(v * j) < A_X_MM_S2
    assert s["cycle_time_s"] == pytest.approx(100.0 / v + 2 * math.sqrt(v / j), rel=1e-6)
    assert s["blocks_detail"][0]["feed_programmed_mm_min"] == pytest.approx(600.0)
    # the delivered setting (0) keeps the error, one line naming the block and the key
    r = _run(program, "mikron")
    assert r.exit_code == 2
    assert f"{program}:2:1: G1 without a feed: no F programmed yet (840D alarm 10860" in r.stderr
    assert "default_feed_mm_min" in r.stderr


def test_the_first_f_replaces_the_default_feed(tmp_path, machine_with_default_feed):
    program = tmp_path / "two.mpf"
    program.write_text("G17 G90 G64 SOFT\nG1 X100\nG1 X200 F1200\nX300\nM30\n")
    s = json.loads(_run(program, machine_with_default_feed).stdout)
    assert [b["feed_programmed_mm_min"] for b in s["blocks_detail"]] == pytest.approx([600, 1200, 1200])


def test_repeat_test_runs_with_a_default_feed_and_stops_without(shared, machine_with_default_feed):
    """``repeat_test.mpf`` moves Z under the reset G1 before its first F (N20, line 4): with
    SD42110 set that move runs at the default feed, every later one at the program's F200."""
    program = shared / "data" / "real" / "programs-840d" / "dubovikov" / "repeat_test.mpf"
    r = _run(program, machine_with_default_feed)
    assert r.exit_code == 0, r.output
    s = json.loads(r.stdout)
    assert math.isfinite(s["cycle_time_s"]) and s["cycle_time_s"] > 0
    first, *rest = s["blocks_detail"]
    assert first["line"] == 4 and first["feed_programmed_mm_min"] == pytest.approx(600.0)
    assert {b["feed_programmed_mm_min"] for b in rest} == {200.0}
    r = _run(program, "mikron")
    assert r.exit_code == 2 and ":4:5: G1 without a feed" in r.stderr


def test_the_key_round_trips_and_rejects_a_negative_feed(mikron):
    import tomllib
    m = mikron.with_ncu(default_feed_mm_s=10.0)
    assert machine_from_dict(tomllib.loads(dump_machine_toml(m))).ncu.default_feed_mm_s == 10.0
    data = tomllib.loads(dump_machine_toml(mikron))
    bad = {**data, "ncu": {**data["ncu"], "default_feed_mm_min": -5}}
    with pytest.raises(MachineSpecError, match=r"m\.toml: ncu\.default_feed_mm_min: must be between 0"):
        machine_from_dict(bad, "m.toml")
