"""`ncsim compare A B`: two runs side by side with their differences, and a CI exit status.

The real case: the THWS bottle opener as NX wrote it (each operation selects CYCLE832: G642
rounding, SOFT) against the same program with the CYCLE832 selections taken out, so that the
header's G60 holds: an exact stop at every block end of the roughings' ~1500 short blocks."""
from __future__ import annotations

import json
import re

import pytest
from click.testing import CliRunner

from ncsim.cli.main import cli
from ncsim.report.compare import compare

THWS = "data/real/thws-spinner-u5-620-nc-programs/Bottle_opener_Flaschenoeffner.txt"


@pytest.fixture(scope="module")
def versions(shared, tmp_path_factory):
    """(the real file, its G60 version made here: every CYCLE832(...) selection a comment)."""
    real = shared / THWS
    text = real.read_text(encoding="utf-8")
    g60, n = re.subn(r"CYCLE832\(_camtolerance,\d,1\)", ";CYCLE832 taken out", text)
    assert n == 5                                    # one per operation
    out = tmp_path_factory.mktemp("cmp") / "bottle_g60.mpf"
    out.write_text(g60, encoding="utf-8")
    return real, out


@pytest.fixture(scope="module")
def compared(versions):
    real, g60 = versions
    return CliRunner().invoke(cli, ["compare", str(real), str(g60), "--machine", "mikron",
                                    "--quiet", "--json", "--max-slower", "5"])


def test_g60_version_is_slower_per_operation_and_fails_the_gate(compared):
    assert compared.exit_code == 1, compared.output
    c = json.loads(compared.stdout)
    cycle = c["cycle_time_s"]
    assert cycle["diff_s"] > 0 and cycle["diff_pct"] > 5 and c["ok"] is False
    ops = {r["name"]: r for r in c["operations"]}
    assert set(ops) == {"PLANFLAECHE", "3D_ADAPTIVE_ROUGHING", "3D_ADAPTIVE_ROUGHING_1",
                        "WALL_PROFILING", "CURVE_DRIVE"}
    # the roughings' short blocks stop one by one under G60: slower there
    for name in ("3D_ADAPTIVE_ROUGHING", "3D_ADAPTIVE_ROUGHING_1"):
        assert ops[name]["diff_s"] > 5.0
        assert ops[name]["diff_pct"] == pytest.approx(
            100 * (ops[name]["b_time_s"] - ops[name]["a_time_s"]) / ops[name]["a_time_s"])
    # the operations (and the tools) share out the whole difference
    for key in ("operations", "tools"):
        assert sum(r["diff_s"] for r in c[key]) == pytest.approx(cycle["diff_s"], rel=1e-9)
    # the G60 run moves no faster anywhere it reaches F: its time at the programmed feeds is the same
    assert c["ideal_time_s"]["diff_s"] == pytest.approx(0.0, abs=0.5)


def test_threshold_passes_and_text_names_the_operations(versions):
    real, g60 = versions
    r = CliRunner().invoke(cli, ["compare", str(real), str(g60), "-m", "mikron", "-q",
                                 "--max-slower", "50"])
    assert r.exit_code == 0, r.output
    assert "PASS  B's cycle time is" in r.stdout and "% longer than A's" in r.stdout
    pct = float(re.search(r"is ([\d.]+) % longer", r.stdout).group(1))
    assert 5 < pct < 50
    assert "3D_ADAPTIVE_ROUGHING" in r.stdout and "by tool" in r.stdout


def test_saved_summary_against_a_program(versions, tmp_path, compared):
    """A summary saved by `ncsim run --json` (with or without its block list) compares as the
    program it came from."""
    real, g60 = versions
    saved = tmp_path / "before.json"
    r = CliRunner().invoke(cli, ["run", str(real), "-m", "mikron", "-q", "--json"])
    assert r.exit_code == 0
    saved.write_text(r.stdout)
    r = CliRunner().invoke(cli, ["compare", str(saved), str(g60), "-m", "mikron", "-q", "--json"])
    assert r.exit_code == 0, r.output
    mixed, direct = json.loads(r.stdout), json.loads(compared.stdout)
    assert mixed["cycle_time_s"] == direct["cycle_time_s"]
    assert mixed["operations"] == direct["operations"]


def test_bad_inputs_are_one_line_exit_2(versions, tmp_path):
    real, g60 = versions
    runner = CliRunner()
    r = runner.invoke(cli, ["compare", str(real), str(g60)])
    assert r.exit_code == 2 and "give --machine" in r.stderr
    bad = tmp_path / "bad.json"
    bad.write_text('{"schema": 1,\n "cycle_time_s": }')
    r = runner.invoke(cli, ["compare", str(bad), str(g60), "-m", "mikron", "-q"])
    assert r.exit_code == 2 and f"{bad}:2:" in r.stderr and len(r.stderr.splitlines()) == 1
    other = tmp_path / "other.json"
    other.write_text(json.dumps({"schema": 1, "machine": "dmc60h", "cycle_time_s": 1.0,
                                 "ideal_time_s": 1.0, "lost_time_s": 0.0, "by_operation": [],
                                 "by_tool": []}))
    r = runner.invoke(cli, ["compare", str(other), str(g60), "-m", "mikron", "-q"])
    assert r.exit_code == 2 and "compare runs on one machine" in r.stderr


def test_operations_in_one_run_only():
    def s(ops):
        rows = [{"name": n, "time_s": t, "lost_time_s": 0.0, "n_ranges": []} for n, t in ops]
        return {"schema": 1, "machine": "m", "cycle_time_s": sum(t for _, t in ops),
                "ideal_time_s": 1.0, "lost_time_s": 0.0, "by_operation": rows, "by_tool": []}
    c = compare(s([("A", 10.0), ("B", 5.0)]), s([("B", 6.0), ("C", 4.0)]), max_slower_pct=0.0)
    rows = {r["name"]: r for r in c["operations"]}
    assert rows["A"]["b_time_s"] is None and rows["A"]["diff_s"] == -10.0
    assert rows["C"]["a_time_s"] is None and rows["C"]["diff_s"] == 4.0
    assert rows["B"]["diff_pct"] == pytest.approx(20.0)
    assert c["ok"] is True                           # 15 s -> 10 s: faster
