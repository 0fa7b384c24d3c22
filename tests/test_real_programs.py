"""The real CAM programs of the THWS data set (SINUMERIK 840D sl, CC BY 4.0), read in place from
``shared/data/real/thws-spinner-u5-620-nc-programs`` (see its SOURCE.md).

They must give a Path plus warnings for what ncsim does not simulate (B/C axes, TRAORI,
CYCLE800, D offsets, MCALL drilling), never an error; spot checks are computed by hand from
the program text.
"""
from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from ncsim.nc.interpret import interpret_file
from ncsim.path import ARC, SOFT, path_columns

KEYCHAIN = "Keychain_Schluesselanhaenger.mpf"
ACHSKREUZ = "Coordinate_system_representation_Achskreuz.mpf"
BOTTLE = "Bottle_opener_Flaschenoeffner.txt"
PROGRAMS = [KEYCHAIN, ACHSKREUZ, BOTTLE]


@pytest.fixture(scope="module")
def thws(shared) -> Path:
    return shared / "data" / "real" / "thws-spinner-u5-620-nc-programs"


@pytest.fixture(scope="module")
def results(thws):
    return {name: interpret_file(thws / name) for name in PROGRAMS}


def by_line(result, line):
    (idx,) = np.flatnonzero(result.path.line == line)
    return result.path.segment(int(idx))


def arc_lines(path: Path) -> int:
    """Lines with a centre word: each is one circle (counted from the text)."""
    return sum(1 for t in path.read_text().splitlines() if re.search(r" [IJ]-?[0-9.]", t))


@pytest.mark.parametrize("name", PROGRAMS, ids=lambda n: Path(n).stem)
def test_program_gives_a_path_and_warnings(results, thws, name):
    r, program = results[name], thws / name
    assert len(r.path) > 500 and r.path.total_length_mm > 0
    assert r.blocks_executed == len(program.read_text().splitlines())   # straight through, M30 last
    assert int((r.path.kind == ARC).sum()) == arc_lines(program)
    assert all(w.line > 0 for w in r.warnings)
    assert np.all(np.isfinite(r.path.length_mm)) and np.all(r.path.length_mm > 0)


def test_keychain_spot_checks(results):
    r = results[KEYCHAIN]
    plunge = by_line(r, 34)                       # N340 G1 Z0.0 F2069.
    assert plunge.start_mm.tolist() == [-10.46, -22.721, 16.0] and plunge.end_mm.tolist() == [-10.46, -22.721, 0.0]
    assert plunge.feed_mm_s == pytest.approx(2069 / 60) and plunge.stop_window == 601
    # N290 CYCLE832(_camtolerance,1,1) N300 COMPOF: G642, SOFT, FFWON, CTOL 0.02, no compressor
    # (the header's G60 no longer holds); the stop before it is the BRISK -> SOFT change + M3 M7
    assert not plunge.exact_stop and plunge.cp_mode == 642 and plunge.ctol_mm == 0.02
    assert plunge.accel_mode == SOFT and plunge.ffw and plunge.compressor == 0
    assert by_line(r, 630).cp_mode == 60 and by_line(r, 630).exact_stop   # after N6120 CYCLE832()
    arc = by_line(r, 36)                          # N360 G3 Y-24.021 I0.0 J-1.3 from
    assert arc.center_mm.tolist() == pytest.approx([-14.543, -24.021, 0.0])
    assert arc.radius_mm == pytest.approx(1.3) and arc.sweep_rad == pytest.approx(math.pi / 2)
    assert arc.normal.tolist() == [0, 0, 1] and arc.length_mm == pytest.approx(1.3 * math.pi / 2)
    cw = by_line(r, 71)                           # N710 G2 ... I-1.889 J-1.926 from (-9.525, -29.937)
    assert cw.radius_mm == pytest.approx(math.hypot(1.889, 1.926)) and cw.normal.tolist() == [0, 0, -1]


def test_keychain_warnings_and_records(results):
    r = results[KEYCHAIN]
    lines: dict[int, str] = {}
    for w in r.warnings:
        lines[w.line] = lines.get(w.line, "") + w.message + "|"
    assert "CYCLE800" in lines[9] and "MCALL CYCLE81" in lines[632] and "M6" in lines[22]
    assert "rotary axis B" in lines[19] and "rotary axis C" in lines[19] and "D1 tool" in lines[19]
    assert [(c.line, c.args) for c in r.cycle832_calls][:2] == [(29, (0.02, 1.0, 1.0)), (267, ())]
    assert ("MILL_FINISH",) in {m.args for m in r.messages}


def test_achskreuz_traori_is_a_warning(results):
    r = results[ACHSKREUZ]
    traori = [w for w in r.warnings if "TRAORI" in w.message]
    assert traori and traori[0].line == 1031


def test_bottle_opener_helical_turn_arcs(results):
    r = results[BOTTLE]
    helices = r.path.select(r.path.helix_mm != 0)
    assert len(helices) > 100 and np.all(helices.sweep_rad < 2 * math.pi)   # TURN=0
    assert (59, (0.02, 3.0, 1.0)) in [(c.line, c.args) for c in r.cycle832_calls]


@pytest.mark.parametrize("name", [KEYCHAIN, BOTTLE], ids=lambda n: Path(n).stem)
def test_fast_path_equals_lark_path_on_real_programs(results, thws, name):
    fast, lark = results[name], interpret_file(thws / name, fast=False)
    for name in path_columns():
        assert np.array_equal(getattr(fast.path, name), getattr(lark.path, name), equal_nan=True), name
    assert (fast.warnings, fast.recorded, fast.blocks_executed) == (lark.warnings, lark.recorded,
                                                                     lark.blocks_executed)
