"""Time lost by cause and by block (``ncsim.report.losses``, ``ncsim run``).

Expected values are closed forms, not ncsim output. A rest-to-rest jerk-limited ramp from 0 to
v whose acceleration peak sqrt(v j) stays below A lasts T = 2 sqrt(v / j) and covers v T / 2
(the acceleration profile is symmetric), so against the feed v it loses T / 2. On the MIKRON a
line along X or Y ramps at j = min(J_tcurv, J_mi) = min(6, 5) = 5 m/s^3 (paper eq. 10, Table 1).
An exact stop (G60) between two blocks therefore loses two half ramps plus the settle time of
the G601 window (machine file ``exact_stop_fine_settle_ms``).
"""
from __future__ import annotations

import json
import math

import pytest
from click.testing import CliRunner

from ncsim.cli.main import cli
from ncsim.pipeline import simulate
from ncsim.report.losses import losses
from ncsim.report.summary import summary

J = 5_000.0          # mm/s^3, min(J_tcurv = 6, J_X = J_Y = 5) m/s^3
A_MIN = 2_500.0      # mm/s^2, A_X
V_RAPID = 500.0      # mm/s, 30 m/min along X (paper Table 1)


def half_ramp_loss_s(v_mm_s: float) -> float:
    assert math.sqrt(v_mm_s * J) < A_MIN      # the ramp never reaches the acceleration limit
    return math.sqrt(v_mm_s / J)              # T / 2 with T = 2 sqrt(v / j)


def run_json(path, *args) -> dict:
    r = CliRunner().invoke(cli, ["run", str(path), "-m", "mikron", "--json", *args])
    assert r.exit_code == 0, r.output
    return json.loads(r.stdout)


def causes(s: dict, moves: str) -> dict[str, dict]:
    return {r["cause"]: r for r in s["lost_by_cause"] if r["moves"] == moves}


@pytest.fixture
def g60_square(tmp_path):
    """Three blocks at F6000 (100 mm/s) with modal exact stop G60 G601."""
    p = tmp_path / "g60.mpf"
    p.write_text("G17 G90 G60 G601 SOFT\nN10 G1 X100 F6000\nN20 X200\nN30 Y50\nM30\n")
    return p


def test_exact_stops_are_ranked_as_a_cause_with_the_closed_form_loss(g60_square, mikron):
    s = run_json(g60_square)
    half = half_ramp_loss_s(100.0)
    settle = mikron.ncu.exact_stop_fine_settle_s
    feed = causes(s, "feed")
    # 4 half ramps at the two inner stops, the settle at the end of each of the 3 blocks
    assert feed["exact_stop"]["time_lost_s"] == pytest.approx(4 * half + 3 * settle, rel=1e-6)
    assert feed["exact_stop"]["settle_s"] == pytest.approx(3 * settle, rel=1e-9)
    assert feed["exact_stop"]["blocks"] == 3
    # the start and the end of the program: one half ramp each
    assert feed["program_end"]["time_lost_s"] == pytest.approx(2 * half, rel=1e-6)
    assert set(feed) == {"exact_stop", "program_end"} and causes(s, "rapid") == {}
    assert s["lost_by_cause"][0]["cause"] == "exact_stop"          # largest first
    # the books balance: cycle time = ideal + lost, and the blocks' losses add up
    assert s["ideal_time_s"] == pytest.approx(250.0 / 100.0, rel=1e-12)
    assert s["cycle_time_s"] == pytest.approx(s["ideal_time_s"] + s["lost_time_s"], rel=1e-12)
    assert sum(b["time_lost_s"] for b in s["blocks_detail"]) == pytest.approx(s["lost_time_s"], rel=1e-9)
    for b in s["blocks_detail"]:   # each block: two half ramps and its settle, mostly the stop
        assert b["time_lost_s"] == pytest.approx(2 * half + settle, rel=1e-6)
        assert b["lost_to"] == "exact_stop"
        assert b["limit"] == "programmed"        # the feed is reached: the stop is the loss


def test_without_exact_stop_the_corner_takes_its_place(tmp_path):
    p = tmp_path / "g64.mpf"
    p.write_text("G17 G90 G64 SOFT\nN10 G1 X100 F6000\nN20 X200\nN30 Y50\nM30\n")
    s = run_json(p)
    feed = causes(s, "feed")
    assert "exact_stop" not in feed
    assert set(feed) == {"corner", "program_end"}     # X -> Y corner; X100 is no corner at all
    assert feed["corner"]["worst_line"] in (3, 4)
    assert feed["program_end"]["time_lost_s"] == pytest.approx(2 * half_ramp_loss_s(100.0), rel=1e-6)


def test_rapids_are_apart_and_lose_against_the_traverse_speed(tmp_path):
    """G0 X400 then G1 X500 F6000: the rapid ramps from rest to 30 m/min and down to the G0/G1
    change (aux_stop); the ideal rapid time is 400 mm / 500 mm/s."""
    p = tmp_path / "rapid.mpf"
    p.write_text("G17 G90 G64 SOFT\nG0 X400\nG1 X500 F6000\nM30\n")
    s = run_json(p, "--top", "5")
    rapid, feed = causes(s, "rapid"), causes(s, "feed")
    h_rapid, h_feed = half_ramp_loss_s(V_RAPID), half_ramp_loss_s(100.0)
    assert rapid["program_end"]["time_lost_s"] == pytest.approx(h_rapid, rel=1e-6)
    assert rapid["aux_stop"]["time_lost_s"] == pytest.approx(h_rapid, rel=1e-6)
    assert feed["aux_stop"]["time_lost_s"] == pytest.approx(h_feed, rel=1e-6)
    assert feed["program_end"]["time_lost_s"] == pytest.approx(h_feed, rel=1e-6)
    assert s["ideal_time_s"] == pytest.approx(400.0 / V_RAPID + 100.0 / 100.0, rel=1e-12)
    assert [b["line"] for b in s["slowest_blocks"]] == [3]
    assert [b["line"] for b in s["slowest_rapids"]] == [2]
    assert s["slowest_rapids"][0]["time_lost_s"] == pytest.approx(2 * h_rapid, rel=1e-6)


def test_text_ranks_causes_then_blocks_and_keeps_rapids_apart(g60_square):
    r = CliRunner().invoke(cli, ["run", str(g60_square), "-m", "mikron"])
    out = r.stdout
    head = out.index("time lost by cause")
    assert head < out.index("feed blocks losing the most time")
    table = out[head:out.index("feed blocks losing the most time")].splitlines()
    assert table[2].strip() == "feed moves"
    assert table[3].split()[0] == "exact_stop" and "settling" in table[3]
    assert "rapids losing the most time" not in out            # there are none


def test_feed_unit_applies_to_every_feed_of_the_text(g60_square):
    r = CliRunner().invoke(cli, ["run", str(g60_square), "-m", "mikron", "--feed-unit", "m/min"])
    assert r.exit_code == 0, r.output
    assert "programmed vs reached feed (m/min)" in r.stdout
    assert "feeds in m/min" in r.stdout and "mm/min" not in r.stdout
    row = next(line for line in r.stdout.splitlines() if line.strip().startswith("6.000"))
    assert row.split()[:3] == ["6.000", "6.000", "6.000"]
    bad = CliRunner().invoke(cli, ["run", str(g60_square), "-m", "mikron", "--json",
                                   "--feed-unit", "m/min"])
    assert bad.exit_code == 2 and "JSON keeps mm/min" in bad.stderr


# ---------------------------------------------------------------------------------------------
# Real programs (../shared): structure only, the numbers change as the 840D model grows
# ---------------------------------------------------------------------------------------------

REAL = ["thws-spinner-u5-620-nc-programs/Keychain_Schluesselanhaenger.mpf",
        "thws-spinner-u5-620-nc-programs/Bottle_opener_Flaschenoeffner.txt",
        "programs-840d/hadielnemr/1_I.MPF", "programs-840d/hadielnemr/MILL_PROJECT.MPF"]


@pytest.mark.parametrize("name", REAL)
def test_real_programs_rank_exact_stops_where_g60_is_active(shared, name):
    sim = simulate(shared / "data" / "real" / name, "mikron")
    path = sim.motion.path
    s = summary(sim, top=10)
    loss = losses(sim.motion)
    feed = causes(s, "feed")
    g60_feed_blocks = int((path.exact_stop & ~path.rapid & (path.length_mm > 0)).sum())
    if g60_feed_blocks:
        settle = float(loss.settle_s[~path.rapid].sum())
        assert feed["exact_stop"]["time_lost_s"] >= settle > 0
        assert feed["exact_stop"]["blocks"] >= 0.9 * g60_feed_blocks
    else:
        assert "exact_stop" not in feed
    # the books balance and both lists keep to their kind of move
    assert s["cycle_time_s"] == pytest.approx(s["ideal_time_s"] + s["lost_time_s"] + s["dwell_time_s"],
                                              rel=1e-9)
    assert sum(r["time_lost_s"] for r in s["lost_by_cause"]) == pytest.approx(s["lost_time_s"], rel=1e-9)
    assert all(b["feed_programmed_mm_min"] is not None for b in s["slowest_blocks"])
    assert all(b["feed_programmed_mm_min"] is None for b in s["slowest_rapids"])
    for moves in ("feed", "rapid"):
        lost = [r["time_lost_s"] for r in s["lost_by_cause"] if r["moves"] == moves]
        assert lost == sorted(lost, reverse=True)
    assert all(r["time_lost_s"] > 0 for r in s["lost_by_cause"])


def test_a_failed_max_time_check_names_the_cause_first(g60_square):
    r = CliRunner().invoke(cli, ["check", str(g60_square), "-m", "mikron", "--max-time", "1"])
    assert r.exit_code == 1
    where = r.stdout.splitlines()[2].strip()
    assert where.startswith("exact_stop loses") and "over 3 feed blocks" in where
