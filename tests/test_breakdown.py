"""Time by operation, tool, N number and source line (``ncsim.report.breakdown``)."""
from __future__ import annotations

import math

import pytest
from click.testing import CliRunner

from ncsim.cli.main import cli
from ncsim.pipeline import simulate
from ncsim.report.breakdown import hms, range_text
from ncsim.report.summary import format_text, summary

THWS = "data/real/thws-spinner-u5-620-nc-programs/Bottle_opener_Flaschenoeffner.txt"

#: a loop of three passes over two 10 mm lines at F600, exact stop (G60) and BRISK
LOOP = ("N10 G90 G60 G17 BRISK F600\nN20 R1=0\nN30 LABEL1:\nN40 G1 X10\nN50 G1 X0\n"
        "N60 R1=R1+1\nN70 IF R1<3 GOTOB LABEL1\nN80 M30\n")


def test_a_loops_passes_sum_on_its_line_closed_form(mikron):
    """Each pass of N40 moves 10 mm at v = 10 mm/s from rest to rest under BRISK: the
    acceleration steps within one IPO cycle (jerk J = A_X / t_cy) and peaks below A_X, so the
    ramps add 2 sqrt(v / J) to L / v; then the G601 window's settle (the machine file's
    exact_stop_fine_settle_ms). Three passes on one line and one N number."""
    s = summary(simulate("loop.mpf", mikron, text=LOOP), top=5)
    a_x = mikron.axis("X").max_accel_mm_s2
    t_cy = mikron.ncu.ipo_cycle_s
    one = 10.0 / 10.0 + 2 * math.sqrt(10.0 * t_cy / a_x) + mikron.ncu.exact_stop_fine_settle_s
    for table, key, value in (("by_n", "n", 40), ("by_line", "line", 4)):
        row = next(r for r in s[table] if r[key] == value)
        assert row["blocks"] == 3
        assert row["time_s"] == pytest.approx(3 * one, rel=1e-9)
        assert row["ideal_time_s"] == pytest.approx(3.0, rel=1e-12)
        assert row["lost_time_s"] == pytest.approx(3 * one - 3.0, rel=1e-7)
        assert row["lost_to"] == "exact_stop"
    assert next(r for r in s["by_line"] if r["line"] == 4)["n"] == 40
    assert s["cycle_time_s"] == pytest.approx(6 * one, rel=1e-9)


def test_tables_add_up_to_the_cycle_time_on_a_real_program(shared, mikron):
    s = summary(simulate(shared / THWS, mikron), top=5, include_blocks=False)
    for table in ("by_operation", "by_tool"):
        rows = s[table]
        assert sum(r["time_s"] for r in rows) == pytest.approx(s["cycle_time_s"], rel=1e-9)
        assert sum(r["ideal_time_s"] for r in rows) == pytest.approx(s["ideal_time_s"], rel=1e-9)
        assert sum(r["lost_time_s"] for r in rows) == pytest.approx(s["lost_time_s"], rel=1e-9)
        losses = [r["lost_time_s"] for r in rows]
        assert losses == sorted(losses, reverse=True)
    ops = {r["name"]: r for r in s["by_operation"]}
    assert set(ops) == {"PLANFLAECHE", "3D_ADAPTIVE_ROUGHING", "3D_ADAPTIVE_ROUGHING_1",
                        "WALL_PROFILING", "CURVE_DRIVE"}
    # each operation runs between its own ;Operation comment and the next one (N = 10 x line)
    assert ops["PLANFLAECHE"]["n_ranges"][0][0] > 150 and ops["PLANFLAECHE"]["n_ranges"][-1][1] < 550
    assert ops["CURVE_DRIVE"]["n_ranges"] == [[24430, 27840]]
    text = format_text(s)
    assert "time by operation" in text and "time by tool" in text
    assert "0 s each, the machine file gives no [tool_change] time_s" in text


def test_lines_and_numbers_of_a_shop_program_with_loops(shared, mikron):
    """kanavka: three loops of F1000 moves (N32, N40, N48) run ~150,000 times."""
    sim = simulate(shared / "data/real/programs-840d/dubovikov/kanavka_vint_sector.mpf", mikron)
    s = summary(sim, top=200, include_blocks=False)
    path = sim.motion.path
    lines = {r["line"]: r for r in s["by_line"]}
    for line, n in ((42, 32), (52, 40), (62, 48)):
        assert lines[line]["n"] == n
        assert lines[line]["blocks"] == int((path.line == line).sum())
    assert {r["n"] for r in s["by_n"][:3]} == {32, 40, 48}
    assert sum(r["time_s"] for r in s["by_line"]) == pytest.approx(s["cycle_time_s"], rel=1e-9)


def test_an_n_number_on_two_lines_sums_both(mikron):
    s = summary(simulate("dup.mpf", mikron, text="N10 G90 G1 X5 F600\nN10 G1 X10\nN20 G1 X0\nM30\n"))
    n10 = next(r for r in s["by_n"] if r["n"] == 10)
    assert n10["blocks"] == 2
    assert n10["time_s"] == pytest.approx(sum(r["time_s"] for r in s["by_line"] if r["n"] == 10))


def test_a_tool_used_twice_has_two_n_ranges_and_its_change_time(mikron):
    from tests.test_outline import _machine
    text = ("N10 G90 G60 F2000\nN20 T1 M6\nN30 G1 X10\nN40 T2 M6\nN50 G1 Y10\nN60 T1 M6\n"
            "N70 G1 X0\nN80 G1 Y0\nN90 M30\n")
    s = summary(simulate("two.mpf", _machine(7.0), text=text))
    tools = {r["name"]: r for r in s["by_tool"]}
    assert tools["T1"]["n_ranges"] == [[30, 30], [70, 80]]
    assert tools["T2"]["n_ranges"] == [[50, 50]]
    assert tools["T1"]["dwell_time_s"] == pytest.approx(14.0) and tools["T2"]["dwell_time_s"] == pytest.approx(7.0)
    assert s["tool_changes"] == 3 and s["tool_change_s"] == 7.0
    assert "tool changes: 3 x 7 s = 0:00:21.0" in format_text(s)


def test_run_text_names_operations_and_tools_with_n_ranges(shared):
    r = CliRunner().invoke(cli, ["run", str(shared / THWS), "--machine", "mikron", "--quiet"])
    assert r.exit_code == 0, r.output
    assert r.stderr == ""
    section = r.stdout.split("time by operation")[1].split("\n\n")[0].splitlines()
    assert section[2].split()[0] == "3D_ADAPTIVE_ROUGHING" and "N640-N15600" in section[2]
    tools = r.stdout.split("time by tool")[1].split("\n\n")[0].splitlines()
    assert tools[2].split()[0] == "SCHAFT_D8_N_AP20"


def test_formats():
    assert hms(154.27) == "0:02:34.3" and hms(3 * 3600 + 59.96) == "3:01:00.0"
    assert range_text([[10, 20], [40, 40], [60, 90]]) == "N10-N20, N40 +1"
    assert range_text([]) == "-"
