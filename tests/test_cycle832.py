"""CYCLE832 (High speed settings) as the 840D applies it, and the THWS CAM programs that use it.

The forms and codes are those of the SINUMERIK NC programming manual ("CYCLE832(S_TOL, S_TOLM,
S_OTOL)", units digit = machining type); what each machining type switches is the machine
file's ``[cycle832]`` table (the machine builder's CUST_832).
"""
from __future__ import annotations

import tomllib

import numpy as np
import pytest

from ncsim.errors import MachineSpecError, NcError
from ncsim.machine import load_machine, machine_from_dict
from ncsim.nc.interpret import interpret_file, interpret_text
from ncsim.path import BRISK, COMPCAD, COMPCURV, COMPOF, SOFT, path_columns
from ncsim.pipeline import simulate, simulate_path

THWS = "data/real/thws-spinner-u5-620-nc-programs"
PROGRAMS = ["Keychain_Schluesselanhaenger.mpf", "Coordinate_system_representation_Achskreuz.mpf",
            "Bottle_opener_Flaschenoeffner.txt"]

BODY = ("G1 X0 Y0 F6000\n" + "".join(f"X{0.2 * i:.3f} Y{0.002 * i * i % 0.7:.3f}\n"
                                      for i in range(1, 120))
        + "G1 X24 Y10\nX0 Y12\nG2 X-6 Y6 I0 J-6\nG1 Y0\nM30\n")


def same_path(a, b) -> bool:
    return a.n == b.n and all(np.array_equal(getattr(a, c), getattr(b, c), equal_nan=True)
                              for c in path_columns())


def test_cycle832_finish_plans_as_its_settings_written_by_hand(mikron):
    """CYCLE832(0.01,_FINISH,1) = G642 COMPCAD SOFT FFWON with CTOL 0.01 (the mikron's
    [cycle832.finish]) and the technology group DYNFINISH: the same path, the same limits,
    the same plan."""
    head = "G17 G90 G71 G94 G60\n"
    cycle = simulate("c.mpf", mikron, text=head + "CYCLE832(0.01,_FINISH,1)\n" + BODY)
    hand = simulate("h.mpf", mikron,
                    text=head + "G642 COMPCAD SOFT FFWON CTOL=0.01 DYNFINISH\n" + BODY)
    assert same_path(cycle.interpreted.path, hand.interpreted.path)
    assert same_path(cycle.path, hand.path)
    np.testing.assert_array_equal(cycle.motion.cap_mm_s, hand.motion.cap_mm_s)
    np.testing.assert_array_equal(cycle.motion.piece_t_s, hand.motion.piece_t_s)
    assert cycle.cycle_time_s == hand.cycle_time_s
    # and it is what the table says, not the reset state
    p = cycle.interpreted.path
    assert set(p.cp_mode) == {642} and p.accel_mode[0] == SOFT and p.ffw.all()
    assert p.compressor[0] == -COMPCAD and p.compressor[1] == COMPCAD and np.all(p.ctol_mm == 0.01)
    reset = simulate("r.mpf", mikron, text=head + BODY)
    assert reset.interpreted.path.exact_stop.all() and reset.cycle_time_s > 2 * cycle.cycle_time_s


@pytest.mark.parametrize("call, units", [
    ("CYCLE832(0.02,_FINISH,1)", 1), ("CYCLE832(0.02,1,1)", 1), ("CYCLE832(0.02,_SEMIFIN,1)", 2),
    ("CYCLE832(0.02,2,1)", 2), ("CYCLE832(0.02,_ROUGH,1)", 3), ("CYCLE832(0.1,3,1)", 3),
    ("CYCLE832(0.02,_ORI_FINISH,0.1)", 1), ("CYCLE832(0.02,_ORI_ROUGH,0.1)", 3),
    ("CYCLE832(0.02,4,1)", 4), ("CYCLE832(0.02,102001)", 1), ("CYCLE832(0.02,1003)", 3)])
def test_machining_types_and_codes(call, units):
    """Each code selects its machining type's row of the table (here: distinct rows)."""
    table = {"finish": "G642", "semifinish": "G645", "rough": "G641", "precision": "G643"}
    data = tomllib.loads(_mikron_file().read_text())
    for name, mode in table.items():
        data["cycle832"][name]["path_mode"] = mode
    machine = machine_from_dict(data)
    r = interpret_text(f"G60\n{call}\nG1 X1 F100\n", "t.mpf", machine)
    expected = {1: 642, 2: 645, 3: 641, 4: 643}[units]
    assert r.path.cp_mode[0] == expected
    assert r.path.ctol_mm[0] == pytest.approx(float(call.split("(")[1].split(",")[0]))
    dyn = {1: "DYNFINISH", 2: "DYNSEMIFIN", 3: "DYNROUGH", 4: "DYNPREC"}[units]
    assert [c.name for c in r.mode_changes] == [dyn]
    packed = "102001" in call or "1003" in call
    assert any("only the machining type" in w.message for w in r.warnings) == packed
    assert not any("not simulated" in w.message and "CYCLE832(" in w.message for w in r.warnings)


def _mikron_file():
    from importlib import resources
    return resources.files("ncsim.machines") / "mikron.toml"


def test_deselection_returns_to_the_reset_values(mikron):
    """CYCLE832() and _OFF: the [cycle832.off] row -- reset path mode (G60), COMPOF, the reset
    BRISK and FFWOF -- and CTOL deleted (the machine data apply again)."""
    for off in ("CYCLE832()", "CYCLE832(0.02,_OFF,1)", "CYCLE832(0.02,0,1)"):
        r = interpret_text(f"CYCLE832(0.02,1,1)\nG1 X1 F100\n{off}\nG1 X2\n", "t.mpf", mikron)
        first, after = r.path.segment(0), r.path.segment(1)
        # (the compressor's sign says a run starts there: CYCLE832 came just before)
        assert (first.cp_mode, abs(first.compressor), first.accel_mode, first.ffw) == (642, COMPCAD, SOFT, True)
        assert (after.cp_mode, after.compressor, after.accel_mode, after.ffw) == (60, COMPOF, BRISK, False)
        assert np.isnan(after.ctol_mm) and after.exact_stop and after.stop_before   # SOFT -> BRISK
    # tolerance 0 deselects too (with a warning: a secondary source says so)
    r = interpret_text("CYCLE832(0.02,1,1)\nG1 X1 F100\nCYCLE832(0,1,1)\nG1 X2\n", "t.mpf", mikron)
    assert r.path.cp_mode[1] == 60 and any("tolerance 0" in w.message for w in r.warnings)


def test_the_table_comes_from_the_machine_file():
    data = tomllib.loads(_mikron_file().read_text())
    data["cycle832"]["finish"] = {"path_mode": "G645", "compressor": "COMPCURV",
                                  "accel_mode": "BRISK", "feed_forward": "FFWOF"}
    r = interpret_text("G60 SOFT\nCYCLE832(0.05,_FINISH,1)\nG1 X1 F100\n", "t.mpf",
                       machine_from_dict(data))
    s = r.path.segment(0)
    assert (s.cp_mode, abs(s.compressor), s.accel_mode, s.ffw, s.ctol_mm) == (645, COMPCURV, BRISK, False, 0.05)
    assert not any("no [cycle832] table" in w.message for w in r.warnings)
    # without the table: the usual CUST_832 values, said once
    del data["cycle832"]
    r = interpret_text("CYCLE832(0.05,1,1)\nG1 X1 F100\nCYCLE832(0.05,1,1)\nG1 X2\n", "t.mpf",
                       machine_from_dict(data))
    assert r.path.cp_mode[0] == 642
    assert sum("no [cycle832] table" in w.message for w in r.warnings) == 1
    # a bad entry is one clear line naming the key
    data["cycle832"] = {"rough": {"compressor": "COMPFAST"}}
    with pytest.raises(MachineSpecError, match="cycle832.rough.compressor: must be one of"):
        machine_from_dict(data, "m.toml")


@pytest.mark.parametrize("call, message", [
    ("CYCLE832(-0.01,1,1)", "S_TOL must be a number >= 0"),
    ("CYCLE832(0.01,7,1)", "machining type digit 7 is not defined"),
    ("CYCLE832(0.01,1.5,1)", "needs a whole number"),
    ("CYCLE832(\"x\",1,1)", "S_TOL must be a number")])
def test_bad_calls_are_located_errors(call, message, mikron):
    with pytest.raises(NcError, match=message) as info:
        interpret_text(f"G1 X1 F100\n{call}\n", "t.mpf", mikron)
    assert "t.mpf:2:" in str(info.value)


@pytest.fixture(scope="module")
def thws_results(shared):
    machine = load_machine("mikron")
    return {name: interpret_file(shared / THWS / name, machine) for name in PROGRAMS}


@pytest.mark.parametrize("name", PROGRAMS)
def test_thws_programs_run_with_the_modes_cycle832_selects(thws_results, shared, name):
    """Every CYCLE832(_camtolerance,1,1) / (…,3,1) of the NX programs switches G642, SOFT, FFWON
    and CTOL 0.02 (their COMPOF turns the compressor off again); CYCLE832() returns to the
    header's G60; no "CYCLE832 ... not simulated" warning is left."""
    r = thws_results[name]
    text = (shared / THWS / name).read_text().splitlines()
    assert not any("CYCLE832(" in w.message and "not simulated" in w.message for w in r.warnings)
    calls = r.cycle832_calls
    assert len(calls) >= 4
    p = r.path
    line_of = p.line
    for call, nxt in zip(calls, list(calls[1:]) + [None]):
        end = nxt.line if nxt is not None else len(text) + 1
        rows = (line_of > call.line) & (line_of < end)
        if not rows.any():
            continue
        if call.args:     # a selection: G642 SOFT FFWON CTOL 0.02, COMPOF from the next line
            assert set(p.cp_mode[rows]) == {642} and np.all(p.ctol_mm[rows] == 0.02)
            assert np.all(p.accel_mode[rows] == SOFT) and p.ffw[rows].all()
            assert np.all(p.compressor[rows] == COMPOF)
            assert "COMPOF" in text[call.line]            # the next program line
        else:             # CYCLE832(): the reset values until the next selection
            assert set(p.cp_mode[rows]) == {60} and np.isnan(p.ctol_mm[rows]).all()


def test_thws_programs_plan_with_rounding_blocks(thws_results):
    """Planned on the MIKRON, the G642 corners become rounding blocks where its G64 jump
    (A_x (2 - 1) t_cy = 30 mm/s at 90 deg) is below the feed; the plan is finite."""
    for name, r in thws_results.items():
        planned = simulate_path(r.path, "mikron")
        assert planned.path.n > r.path.n, name
        assert np.isfinite(planned.cycle_time_s) and planned.cycle_time_s > 0
