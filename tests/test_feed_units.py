"""One feed unit per output: mm/min in `run`, `explain` and `gap` alike, another on request.

The numbers themselves are checked elsewhere; here every feed of a text output must be in the
unit it names, and asking for another unit must scale every one of them by the same factor
(m/min = mm/min / 1000, mm/s = mm/min / 60).
"""
from __future__ import annotations

import re

import numpy as np
import pytest
from click.testing import CliRunner

from ncsim.cli.main import cli
from ncsim.plan.sample import sample_motion
from ncsim.pipeline import simulate



def invoke(*args) -> str:
    r = CliRunner().invoke(cli, [*map(str, args)])
    assert r.exit_code == 0, r.output
    return r.stdout


def units_named(text: str) -> set[str]:
    """Velocity units a text names (mm/s^2 and mm/s^3 are not velocities)."""
    return set(re.findall(r"\b(mm/min|m/min|in/min|um/s|mm/s|m/s)(?![\^²³0-9])", text))


@pytest.fixture(scope="module")
def scope_csv(tmp_path_factory, repo_root):
    """A measured trace of the R 30 circle: ncsim's own samples every 4 ms (t, x, y, z)."""
    prog = repo_root / "programs" / "circle_r30_f6000.mpf"
    trace = sample_motion(simulate(prog, "mikron").motion, 0.004)
    f = tmp_path_factory.mktemp("units") / "scope.csv"
    rows = np.column_stack([trace.t_s, trace.pos_mm])
    f.write_text("t_s,x_mm,y_mm,z_mm\n" + "\n".join(",".join(repr(float(v)) for v in r) for r in rows))
    return prog, f


def test_run_and_explain_print_mm_min_only(repo_root):
    run = invoke("run", repo_root / "programs" / "bore_d25_f5984.mpf", "-m", "mikron")
    explain = invoke("explain", "-m", "mikron")
    assert units_named(run) == {"mm/min"}
    assert units_named(explain) == {"mm/min"}


def test_gap_trace_text_is_in_mm_min_and_scales_with_feed_unit(scope_csv):
    prog, csv = scope_csv
    args = ("gap", prog, "--machine", "mikron", "--measured", csv, "--effects", "transition", "--no-combine")
    default = invoke(*args)
    per_s = invoke(*args, "--feed-unit", "mm/s")
    assert units_named(default) == {"mm/min"}
    assert units_named(per_s) == {"mm/s"}
    rms = [float(re.search(r"base gap \S+: feed ([0-9.]+) " + re.escape(u) + " rms", t).group(1))
           for t, u in ((default, "mm/min"), (per_s, "mm/s"))]
    assert rms[0] == pytest.approx(60 * rms[1], rel=0.01, abs=0.1)


def test_gap_published_values_in_the_asked_unit(repo_root):
    args = ("gap", repo_root / "programs" / "circle_r2p5_f6000.mpf", "--machine", "mikron", "--measured",
            repo_root / "measured" / "paper_table3.toml", "--effects", "ncu_path_jerk", "--no-combine")
    default = invoke(*args)
    m_min = invoke(*args, "--feed-unit", "m/min")
    row = lambda text: next(ln for ln in text.splitlines() if "steady_feed" in ln and "circle_R2.5_F6 " in ln)  # noqa: E731
    assert row(default).split()[2:4] == ["2010", "mm/min"]            # paper Table 3: 2.01 m/min
    assert row(m_min).split()[2:4] == ["2.010", "m/min"]
    assert units_named(default) == {"mm/min"}


@pytest.mark.parametrize("command", [["run", "PROGRAM", "-m", "mikron"], ["explain", "-m", "mikron"]])
def test_feed_unit_with_json_is_an_error_not_ignored(repo_root, command):
    args = [str(repo_root / "programs" / "bore_d25_f5984.mpf") if a == "PROGRAM" else a for a in command]
    r = CliRunner().invoke(cli, [*args, "--json", "--feed-unit", "m/min"])
    assert r.exit_code == 2 and len(r.stderr.splitlines()) == 1
