"""The command line of the program-reading options and of honest results: --subprograms,
--missing-subprograms, --definitions, --block-budget, ``approximate`` in the summary, check
--strict, and the warnings printed before the one error line of a failing run."""
from __future__ import annotations

import json
import math

import pytest
from click.testing import CliRunner

from ncsim.cli.main import cli


def invoke(*args):
    return CliRunner().invoke(cli, [str(a) for a in args])


def test_subprograms_folder_and_missing_ones(tmp_path):
    lib = tmp_path / "lib"
    lib.mkdir()
    (lib / "drill.spf").write_text("PROC DRILL(REAL DEPTH)\nG1 Z=DEPTH F200\nG0 Z2\nRET\n")
    prog = tmp_path / "part.mpf"
    prog.write_text("G0 X10 Z2\nDRILL(-5)\nL140(1)\nM30\n")
    r = invoke("run", prog, "-m", "mikron", "--subprograms", lib)
    assert r.exit_code == 2
    assert r.stderr.splitlines()[-1].startswith(f"{prog}:3:1: subprogram L140 not found: no PROC "
                                                f"L140 and no L140.MPF/L140.SPF in {tmp_path}, {lib}")
    r = invoke("run", prog, "-m", "mikron", "--subprograms", lib, "--missing-subprograms", "warn",
               "--json")
    assert r.exit_code == 0, r.stderr
    s = json.loads(r.stdout)
    # to X10 Z2, down 7, up 7 (L140 makes no motion)
    assert s["path_length_mm"] == pytest.approx(math.hypot(10, 2) + 7 + 7)
    assert s["approximate"] and s["approximations"]["missing subprogram"]["count"] == 1
    assert f"{prog}:3:1: warning: subprogram L140 not found" in r.stderr


def test_definitions_and_block_budget(tmp_path):
    gud = tmp_path / "UGUD.DEF"
    gud.write_text("DEF NCK REAL _PITCH=2.5\nM30\n")
    prog = tmp_path / "p.mpf"
    prog.write_text("G1 F100 X=_PITCH*4\nM30\n")
    r = invoke("run", prog, "-m", "mikron", "--definitions", gud, "--json")
    assert r.exit_code == 0 and json.loads(r.stdout)["path_length_mm"] == 10.0
    r = invoke("run", prog, "-m", "mikron")
    assert r.exit_code == 2 and r.stderr.strip() == f"{prog}:1:11: undefined variable _PITCH (DEF it first)"
    loop = tmp_path / "loop.mpf"
    loop.write_text("R1=0\nG1 F100\nTOP: R1=R1+1\nX=R1\nIF R1>0 GOTOB TOP\n")
    r = invoke("parse", loop, "--block-budget", "100")
    assert r.exit_code == 2 and r.stderr.strip().startswith(
        f"{loop}:5:9: block budget of 100 blocks exceeded: endless loop? this jump back was taken")


def test_a_failing_run_prints_the_warnings_before_its_error(tmp_path):
    prog = tmp_path / "p.mpf"
    prog.write_text("G1 X1 F100\nB30\nM6\nCYCLE83(1)\nG1 X=1/0\nM30\n")
    r = invoke("run", prog, "-m", "mikron")
    lines = r.stderr.splitlines()
    assert r.exit_code == 2 and lines[-1] == f"{prog}:5:7: division by zero (/)"
    assert [ln.split(": warning: ")[0] for ln in lines[:-1]] == [f"{prog}:2:1", f"{prog}:3:1",
                                                                 f"{prog}:4:1"]


def test_approximate_summary_and_check_strict(tmp_path):
    exact = tmp_path / "exact.mpf"
    exact.write_text("G1 X10 F1000\nM30\n")
    rough = tmp_path / "rough.mpf"
    rough.write_text("G1 X10 F1000\nT2 M6\nCYCLE81(2, 0, 1, -5)\nG1 X20 B90\nM30\n")
    r = invoke("run", rough, "-m", "mikron")
    assert "approximate: the time leaves out what ncsim does not simulate" in r.stdout
    r = invoke("run", exact, "-m", "mikron", "--json")
    assert json.loads(r.stdout)["approximate"] is False
    r = invoke("check", exact, "-m", "mikron", "--strict")
    assert r.exit_code == 0 and "PASS  the time is exact" in r.stdout
    r = invoke("check", rough, "-m", "mikron", "--strict", "--json")
    assert r.exit_code == 1
    check = json.loads(r.stdout)["checks"][-1]
    assert check["name"] == "strict" and not check["ok"] and check["measured"] == 3
    assert sorted(w.split(":")[0] for w in check["where"]) == ["M6", "cycle", "rotary axis"]
