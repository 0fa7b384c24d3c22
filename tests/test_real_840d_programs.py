"""The real SINUMERIK 840D/828D programs of ``shared/data/real/programs-840d`` (read in place;
see its SOURCE.md), every file of the folder through ``ncsim run --json``.

What each file should give, decided from SOURCE.md and the 840D manuals:

* every valid main program gives a cycle time; the lathe programs may instead stop at a
  turning-only feature with one "not simulated" line (G33 threads, G96 constant cutting rate);
* ``slot.mpf`` and ``while_test.mpf`` are marked invalid (a ``println("...")`` the repository's
  author added): one error line at that call, which the 840D reads as a call of a subprogram
  PRINTLN that does not exist;
* ``123.mpf`` and ``test.mpf`` are valid programs whose machine subprograms (L140 angle head,
  L143 table index, L106 tool) are not in the repository: one "subprogram not found" line
  naming the folder searched, and with ``--missing-subprograms warn`` a cycle time marked
  approximate, one approximation per call of them in the text;
* ``repeat_test.mpf`` moves Z under the reset G1 before any F is programmed (N20): on an 840D
  that is alarm 10860 "no feed programmed" (setting data SD42110 $SC_DEFAULT_FEED is 0 as
  delivered), so its right result is that one error line; its REPEAT is checked below with a
  feed added in front;
* subprograms run alone give a time or one located error, never a traceback.

Hand checks (from the program text, not from ncsim): the hole circle of ``holes2_test.mpf``
(HOLES2 with NUM=500 beside it, CYCLE82 drilling 30 mm from 2 mm above: 500 x 32 mm at F140),
the warm-up cycles of the syilx7 programs (13 moves of 67.21 inch per cycle, the number of
cycles from each call's duration) and the lathe program HRIADEL.MPF, its feed per revolution
(F0.3 x S600) and its path in diameter programming, on the bundled lathe machine file.
"""
from __future__ import annotations

import json
import math
import re

import pytest
from click.testing import CliRunner

from ncsim.cli.main import cli

TIME = "time"
MAIN = {
    # file: (TIME,) or (error line without its folder, line, column)
    "dubovikov/123.mpf": ("subprogram L140 not found", 13, 5),
    "dubovikov/test.mpf": ("subprogram L140 not found", 20, 5),
    "dubovikov/slot.mpf": ("subprogram PRINTLN not found", 50, 1),
    "dubovikov/while_test.mpf": ("subprogram PRINTLN not found", 23, 1),
    "dubovikov/repeat_test.mpf": ("G1 without a feed: no F programmed yet", 4, 5),
    "dubovikov/threadturn_test.mpf": ("thread cutting G33 is not simulated", 14, 1),   # in BAR_CENTR.SPF
    "hadielnemr/MAIN.MPF": ("constant cutting rate G96 (turning) is not simulated", 6, 5),
    "dubovikov/kanavka_vint_sector.mpf": (TIME,),
    "dubovikov/holes2_test.mpf": (TIME,),
    "hadielnemr/1_I.MPF": (TIME,),
    "hadielnemr/2.MPF": (TIME,),
    "hadielnemr/3.MPF": (TIME,),
    "hadielnemr/MILL_PROJECT.MPF": (TIME,),
    "syilx7/TEST.MPF": (TIME,),
    "syilx7/DAILY.MPF": (TIME,),
    "syilx7/FIRST_SPINDLE_RUN_IN.MPF": (TIME,),
    "syilx7/IDLE_72_HOURS.MPF": (TIME,),
    "tobosnap/HRIADEL.MPF": (TIME,),
    "tobosnap/sustruh_hriadel.mpf": (TIME,),
}
MISSING_MACHINE_SUBPROGRAMS = ("dubovikov/123.mpf", "dubovikov/test.mpf")
SUBPROGRAMS = ("dubovikov/BAR_CENTR.SPF", "dubovikov/KANAVKA_SFERA.spf", "dubovikov/CYCLE_KONUS.SPF",
               "dubovikov/CYCLE82.SPF", "dubovikov/CYCLE83.SPF", "dubovikov/CYCLE84.SPF",
               "dubovikov/HOLES2.SPF", "hadielnemr/SUB_MAIN.MPF", "syilx7/WARMUP_CYCLE.SPF",
               "tobosnap/L1.SPF", "tobosnap/L2.SPF", "tobosnap/L3.SPF", "tobosnap/L4.SPF")
INCH_MM = 25.4


@pytest.fixture(scope="module")
def folder(shared):
    return shared / "data" / "real" / "programs-840d"


#: the lathe programs (SOURCE.md) run on the bundled lathe, whose X is programmed as a diameter
#: (type = "turning": DIAMON and G18 at reset); the others on the milling machine of the paper
LATHE = ("tobosnap/HRIADEL.MPF", "tobosnap/sustruh_hriadel.mpf", "tobosnap/L1.SPF",
         "tobosnap/L2.SPF", "tobosnap/L3.SPF", "tobosnap/L4.SPF", "hadielnemr/MAIN.MPF",
         "hadielnemr/SUB_MAIN.MPF", "dubovikov/threadturn_test.mpf", "dubovikov/BAR_CENTR.SPF")


def run(path, *options, machine=None):
    if machine is None:
        machine = "lathe" if f"{path.parent.name}/{path.name}" in LATHE else "mikron"
    return CliRunner().invoke(cli, ["run", str(path), "--machine", machine, "--json", *options])


@pytest.fixture(scope="module")
def results(folder):
    return {name: run(folder / name) for name in MAIN}


def test_the_folder_is_the_one_described(folder):
    files = sorted(str(p.relative_to(folder)) for p in folder.glob("*/*") if p.suffix != ".md")
    assert files == sorted([*MAIN, *SUBPROGRAMS])


@pytest.mark.parametrize("name", sorted(MAIN))
def test_main_program_gives_a_time_or_its_one_error_line(results, folder, name):
    r = results[name]
    assert r.exception is None or isinstance(r.exception, SystemExit), r.exception
    expected = MAIN[name]
    errors = [line for line in r.stderr.splitlines() if ": warning: " not in line]
    if expected == (TIME,):
        assert r.exit_code == 0, r.stderr
        summary = json.loads(r.stdout)
        assert math.isfinite(summary["cycle_time_s"]) and summary["cycle_time_s"] > 0
        assert errors == []
        return
    message, line, col = expected
    assert r.exit_code == 2 and len(errors) == 1, r.stderr
    assert r.stderr.splitlines()[-1] == errors[0]          # after the warnings that led to it
    where = re.match(r"^(.*):(\d+):(\d+): (.*)$", errors[0])
    assert where and (int(where[2]), int(where[3])) == (line, col) and where[4].startswith(message)


@pytest.mark.parametrize("name", MISSING_MACHINE_SUBPROGRAMS)
def test_missing_machine_subprograms_name_the_folder_and_warn_gives_a_time(results, folder, name):
    assert f"in {folder / 'dubovikov'} (--subprograms DIR" in results[name].stderr
    r = run(folder / name, "--missing-subprograms", "warn")
    assert r.exit_code == 0, r.stderr
    summary = json.loads(r.stdout)
    calls = sum(len(re.findall(r"\bL1(?:40|43|06)\(", line.split(";")[0]))
                for line in (folder / name).read_text().splitlines())
    assert summary["cycle_time_s"] > 0 and summary["approximate"]
    assert summary["approximations"]["missing subprogram"]["count"] == calls


def test_invalid_files_stop_at_their_println(folder):
    for name in ("dubovikov/slot.mpf", "dubovikov/while_test.mpf"):
        text = (folder / name).read_text().splitlines()
        line = MAIN[name][1]
        assert text[line - 1].lower().startswith("println(")


def test_hole_circle_cycles_beside_the_program_are_executed(results):
    s = json.loads(results["dubovikov/holes2_test.mpf"].stdout)
    feed = [f for f in s["feeds"] if f["feed_programmed_mm_min"] == pytest.approx(140)]
    assert len(feed) == 1
    assert feed[0]["blocks"] == 500 and feed[0]["length_mm"] == pytest.approx(500 * 32)
    assert feed[0]["time_s"] == pytest.approx(500 * 32 / 140 * 60, rel=0.01)
    assert not s["approximate"]


def warmup_length_mm(cycles: int) -> float:
    """13 moves of one WARMUP_CYCLE.SPF pass, in inch (G70), from (0, 0, 0)."""
    d = math.hypot(5, 5)
    per_cycle_inch = 4 + 5 + 5 + 4 + 5 + 5 + d + 4 + d + 4 + 5 + d + 5
    return cycles * per_cycle_inch * INCH_MM


@pytest.mark.parametrize("name", ["syilx7/TEST.MPF", "syilx7/DAILY.MPF",
                                  "syilx7/FIRST_SPINDLE_RUN_IN.MPF", "syilx7/IDLE_72_HOURS.MPF"])
def test_warmup_cycles_by_hand(results, folder, name):
    """Each WARMUP_CYCLE(rpm, seconds) call runs INT(seconds / 15) passes, at least one."""
    calls = re.findall(r"WARMUP_CYCLE\(\s*[\d.]+\s*,\s*([\d.]+)\s*\)",
                       "\n".join(t.split(";")[0] for t in (folder / name).read_text().splitlines()))
    cycles = sum(max(1, math.floor(float(d) / 15 + 0.5)) for d in calls)
    s = json.loads(results[name].stdout)
    assert calls and s["path_length_mm"] == pytest.approx(warmup_length_mm(cycles), rel=1e-9)
    feed = s["feeds"][0]
    assert feed["feed_programmed_mm_min"] == pytest.approx(300 * INCH_MM)     # F300 under G700


def test_lathe_feed_per_revolution_in_diameter(results):
    """HRIADEL.MPF by hand, X a diameter (the control moves X by half of each programmed X).
    T1 (F0.3 x S600 = 180 mm/min), L1: Z2 -> Z-80, Z2 -> Z-30 twice = 146 mm.
    T2 (F0.12 x S1200 = 144 mm/min), L2: 82 + 32 + the step X28 Z-28 -> X45 Z-30
    (radial 8.5, axial 2); L3: chamfers X28 Z1 -> X30 Z0 (1, 1), Z-29 (29), X45 Z-31
    (7.5, 2), Z-79 (48), X50 Z-81 (2.5, 2). T3 (F0.05 x S500 = 25 mm/min), L4: X50 -> X26 and
    back, 12 mm each. At these feeds the ramps take milliseconds: time = length / feed."""
    s = json.loads(results["tobosnap/HRIADEL.MPF"].stdout)
    t2 = (82 + 32 + math.hypot(8.5, 2) + math.hypot(1, 1) + 29 + math.hypot(7.5, 2) + 48
          + math.hypot(2.5, 2))
    expected = {180: (3, 146.0), 144: (8, t2), 25: (2, 24.0)}
    feeds = {round(f["feed_programmed_mm_min"]): f for f in s["feeds"]}
    assert sorted(feeds) == sorted(expected)
    for feed, (blocks, length) in expected.items():
        assert feeds[feed]["blocks"] == blocks
        assert feeds[feed]["length_mm"] == pytest.approx(length, rel=1e-9)
        assert feeds[feed]["time_s"] == pytest.approx(length / feed * 60, rel=2e-3)
    cutting_s = 146 / 180 * 60 + t2 / 144 * 60 + 24 / 25 * 60 + 1.5     # and L4's G4 F1.5
    # the rapids (about 1.1 m of them) at 24-30 m/min with their ramps add seconds, not minutes
    assert cutting_s < s["cycle_time_s"] < cutting_s + 10
    assert s["approximations"] == {"M6": {"count": 3, "reason": "tool change times are not "
                                                                "simulated"}}


def test_lathe_programs_move_x_by_half_the_diameter(folder):
    from ncsim.machine import load_machine
    from ncsim.nc.interpret import interpret_file
    r = interpret_file(folder / "tobosnap" / "HRIADEL.MPF", load_machine("lathe"))
    x = [float(s.end_mm[0]) for s in r.path.segments()]
    assert max(x) == 60.0 and min(x) == 13.0            # G0 X120 at the end; L4's groove X26
    # CYCLE95 has no source: the stock removal is left out and says so
    s2 = json.loads(run(folder / "tobosnap" / "sustruh_hriadel.mpf").stdout)
    assert s2["approximations"]["cycle"]["count"] == 1


def test_repeat_test_with_a_feed_repeats_its_section_three_times(folder):
    from ncsim.nc.interpret import interpret_text
    text = (folder / "dubovikov" / "repeat_test.mpf").read_text()
    r = interpret_text("F200\n" + text, "repeat_test.mpf")
    z = [float(s.end_mm[2]) for s in r.path.segments() if s.line == 5]   # N20 Z=10-R10
    assert z == [-6, -7, -8, -9]               # R10 = 16, 17, 18, 19: one pass and P=3 repetitions


@pytest.mark.parametrize("name", SUBPROGRAMS)
def test_subprograms_alone_give_a_time_or_one_located_error(folder, name):
    r = run(folder / name)
    assert r.exit_code in (0, 2) and (r.exception is None or isinstance(r.exception, SystemExit))
    errors = [line for line in r.stderr.splitlines() if ": warning: " not in line]
    if r.exit_code == 0:
        assert json.loads(r.stdout)["cycle_time_s"] >= 0 and errors == []
    else:
        assert len(errors) == 1 and re.match(r"^.+:\d+:\d+: \S", errors[0]), r.stderr
