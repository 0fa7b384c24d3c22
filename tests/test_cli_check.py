"""`ncsim check`: exit 0 when every threshold holds, 1 with what failed where, 2 on bad input.

Thresholds are set on either side of values known independently of ncsim:

* circle R 30 at 6 m/min (paper Table 3: the programmed feed is reached): the feed moves take
  L / v + 2 sqrt(v / j) with L = 2 pi 30 mm, v = 100 mm/s and the least tangential jerk on the
  circle j = 5 m/s^3 (paper sec. 5.2.2, phases A/C), so the feed ratio (ideal / real time) is
  (L/v) / (L/v + 2 sqrt(v/j)) = 0.8695;
* circle R 30 at 24 m/min: held at V_Jtcurv = 10.53 m/min for the whole circle, so every
  second of feed is limited (limited fraction 1); the rapid to (0, -30) before it is a
  rest-to-rest jerk-limited move of 30 mm on Y (j = 5 m/s^3, A never reached):
  4 (L / 2j)^(1/3) = 0.577 s, the circle (L/V + 2 sqrt(V/j)) 1.449 s: 2.026 s in all.
"""
from __future__ import annotations

import json
import math

import pytest
from click.testing import CliRunner

from ncsim.cli.main import cli

J = 5_000.0                                   # mm/s^3
L_CIRCLE = 2 * math.pi * 30.0                 # mm
V_JTCURV = (6_000.0 * 30.0 ** 2) ** (1 / 3)   # mm/s, eq. 11
RATIO_R30_F6000 = (L_CIRCLE / 100.0) / (L_CIRCLE / 100.0 + 2 * math.sqrt(100.0 / J))
TIME_R30_F24000 = 4 * (30.0 / (2 * J)) ** (1 / 3) + L_CIRCLE / V_JTCURV + 2 * math.sqrt(V_JTCURV / J)


def check(*args):
    return CliRunner().invoke(cli, ["check", *map(str, args)])


@pytest.fixture(scope="module")
def slow_circle(repo_root):
    return repo_root / "programs" / "circle_r30_f24000.mpf"


@pytest.fixture(scope="module")
def easy_circle(repo_root):
    return repo_root / "programs" / "circle_r30_f6000.mpf"


def test_closed_forms():
    assert RATIO_R30_F6000 == pytest.approx(0.8695, abs=1e-4)
    assert TIME_R30_F24000 == pytest.approx(2.026, abs=1e-3)


def test_all_thresholds_hold_exit_0(easy_circle):
    r = check(easy_circle, "-m", "mikron", "--max-time", 3, "--min-feed-ratio", RATIO_R30_F6000 - 0.005)
    assert r.exit_code == 0, r.output
    lines = r.stdout.splitlines()
    assert lines[0].endswith("cycle time 2.745 s")
    assert lines[1].startswith("PASS  cycle time 2.745 s <= 3.000 s")
    assert lines[2].startswith("PASS  feed ratio 0.870 >= 0.865")
    assert lines[-1] == "all 2 checks passed"
    assert r.stderr == ""


def test_feed_ratio_fails_exit_1_naming_the_block(easy_circle):
    r = check(easy_circle, "-m", "mikron", "--min-feed-ratio", RATIO_R30_F6000 + 0.005)
    assert r.exit_code == 1
    assert "FAIL  feed ratio 0.870 < 0.875" in r.stdout
    assert f"{easy_circle}:10: programmed holds the feed (F6000 mm/min" in r.stdout
    assert r.stdout.splitlines()[-1] == "1 of 1 check failed"


def test_max_time_either_side_of_the_closed_form(slow_circle):
    assert check(slow_circle, "-m", "mikron", "--max-time", TIME_R30_F24000 * 1.002).exit_code == 0
    r = check(slow_circle, "-m", "mikron", "--max-time", TIME_R30_F24000 * 0.998)
    assert r.exit_code == 1
    assert "FAIL  cycle time 2.026 s > 2.022 s" in r.stdout
    # where: the circle, held by the NCU path jerk, with its file:line
    assert f"{slow_circle}:10: ncu_path_jerk holds the feed (F24000 mm/min, reached 10526 mm/min)" in r.stdout


def test_limited_fraction_fails_and_names_the_limit(slow_circle):
    r = check(slow_circle, "-m", "mikron", "--max-limited-fraction", 0.5, "--max-time", 10)
    assert r.exit_code == 1
    out = r.stdout
    assert "PASS  cycle time" in out
    assert "FAIL  limited fraction 1.000 > 0.500 of feed-move time (held by ncu_path_jerk" in out
    assert f"{slow_circle}:10: ncu_path_jerk" in out


def test_baseline_regression(slow_circle, tmp_path):
    """A baseline saved with a faster model (BRISK) makes the SOFT run a regression; the
    failure names the block that got slower. Against itself the run passes at 0 %."""
    base = tmp_path / "base.json"
    r = CliRunner().invoke(cli, ["run", str(slow_circle), "-m", "mikron", "--json", "--accel-mode", "brisk"])
    base.write_text(r.stdout)
    r = check(slow_circle, "-m", "mikron", "--baseline", base, "--max-regression", 5)
    assert r.exit_code == 1
    assert f"against {base}" in r.stdout and "(> +5 % allowed)" in r.stdout
    assert f"{slow_circle}:10: +" in r.stdout and "s against the baseline (ncu_path_jerk" in r.stdout
    same = tmp_path / "same.json"
    same.write_text(CliRunner().invoke(cli, ["run", str(slow_circle), "-m", "mikron", "--json"]).stdout)
    r = check(slow_circle, "-m", "mikron", "--baseline", same, "--max-regression", 0)
    assert r.exit_code == 0, r.output
    assert "is +0.00 % against" in r.stdout


def test_json_results(slow_circle):
    r = check(slow_circle, "-m", "mikron", "--max-time", 1, "--json")
    assert r.exit_code == 1
    data = json.loads(r.stdout)
    assert data["ok"] is False and data["checks"][0]["name"] == "max_time"
    assert data["checks"][0]["measured"] == pytest.approx(TIME_R30_F24000, rel=1e-3)
    assert data["checks"][0]["where"]


@pytest.mark.parametrize("setup, args, expected", [
    (None, [], "ncsim check: error: no threshold given"),
    (None, ["--max-regression", "5"], "ncsim check: error: --baseline and --max-regression go together"),
    ("{", ["--max-regression", "5"], "base.json: baseline summary is not valid JSON (line 1, column 2)"),
    ("[1, 2]", ["--max-regression", "5"], "base.json: baseline summary must be a JSON object"),
    ('{"schema": 1, "cycle_time_s": "long"}', ["--max-regression", "5"],
     "base.json: key 'cycle_time_s': expected a number of seconds"),
    ('{"cycle_time_s": 1.0}', ["--max-regression", "5"], "base.json: key 'schema': expected 1"),
    ("missing", ["--max-regression", "5"], "cannot read baseline summary"),
    (None, ["--min-feed-ratio", "1.5"], "ncsim check: error: Invalid value for '--min-feed-ratio'"),
    (None, ["--max-time", "-1"], "ncsim check: error: Invalid value for '--max-time'"),
])
def test_bad_input_exits_2_in_one_line(easy_circle, tmp_path, setup, args, expected):
    base = tmp_path / "base.json"
    extra = []
    if setup is not None:
        if setup != "missing":
            base.write_text(setup)
        extra = ["--baseline", base]
    r = check(easy_circle, "-m", "mikron", *args, *extra)
    assert r.exit_code == 2
    assert r.stdout == ""
    assert len(r.stderr.splitlines()) == 1 and expected in r.stderr, r.stderr


def test_bad_program_exits_2(tmp_path):
    p = tmp_path / "bad.mpf"
    p.write_text("G1 X1\n")
    r = check(p, "-m", "mikron", "--max-time", 10)
    assert r.exit_code == 2 and r.stderr.strip().startswith(f"{p}:1:1: G1 without a feed")


def test_one_check_is_singular(easy_circle):
    r = check(easy_circle, "-m", "mikron", "--max-time", 3)
    assert r.exit_code == 0 and r.stdout.splitlines()[-1] == "1 check passed"


@pytest.mark.parametrize("text, reason", [
    ("", "program: no motion and no M30, M2 or M17 at the end (truncated?)"),
    ("; CAM post-processor output truncated\n", "program: no motion and no M30, M2 or M17 at the end"),
    ("; header only\nM30\n", "program: no motion;"),
    ("G17 G90 G64\nG1 X10 F1000\nG1 Y10\n", "program: no M30, M2 or M17 at the end (truncated?);"),
])
def test_an_empty_or_truncated_export_fails_with_the_reason(tmp_path, text, reason):
    """Every threshold holds on nothing (cycle time 0, feed ratio 1): CI must not go green."""
    p = tmp_path / "export.mpf"
    p.write_text(text)
    r = check(p, "-m", "mikron", "--max-time", 100, "--min-feed-ratio", 0.0)
    assert r.exit_code == 1, r.output
    fails = [line for line in r.stdout.splitlines() if line.startswith("FAIL")]
    assert len(fails) == 1 and fails[0].startswith(f"FAIL  {reason}")
    assert "--allow-empty" in fails[0]
    data = json.loads(check(p, "-m", "mikron", "--max-time", 100, "--json").stdout)
    assert data["ok"] is False and data["checks"][0]["name"] == "program"
    r = check(p, "-m", "mikron", "--max-time", 100, "--allow-empty")
    assert r.exit_code == 0 and r.stdout.splitlines()[-1] == "1 check passed"


@pytest.mark.parametrize("option", ["--max-time", "--min-feed-ratio", "--max-limited-fraction",
                                    "--max-regression"])
@pytest.mark.parametrize("value", ["nan", "inf", "-inf"])
def test_a_threshold_that_is_not_a_number_is_bad_input(easy_circle, option, value):
    """NaN compares false with everything: ``--max-time nan`` failed the check (exit 1)."""
    r = check(easy_circle, "-m", "mikron", option, value)
    assert r.exit_code == 2 and r.stdout == ""
    assert len(r.stderr.splitlines()) == 1 and f"Invalid value for '{option}'" in r.stderr
