"""ISO codes in Siemens mode (the KIT programs' ``G21``), foreign code recognised as such, and the
840D words real programs use (RTLIOF/RTLION, FGROUP/FGREF)."""
from __future__ import annotations

import tomllib

import pytest

from ncsim.errors import MachineSpecError, NcError
from ncsim.machine import dump_machine_toml, load_machine, machine_from_dict
from ncsim.nc.interpret import interpret_file, interpret_text

#: the head of the KIT program AL_2007_T4_Gear_Normal.mpf (EnKJneer/Masters-thesis, run on the
#: DMC 60H's 840D), rewritten here: the licence of the original forbids copying it
KIT_STYLE = """;**** Gear ****
G21 ; all dimensions metric (mm)
G710 ;Metric system [mm] and [mm/min]
G54 ; work offset
G90 ;absolute
G94 ;feed in mm/min
F350 S3800 M3
G0 X0 Y0 Z5.000
G0 X-15.000 Y34.982
G1 Z-6.000
G1 X7.488 Y34.982 Z-6.000
G2 X7.542 Y36.512 Z-6.000 I23.434 J-0.057
G0 Z5.000
M5
M30
"""


def test_a_siemens_program_with_g21_runs_with_a_warning():
    r = interpret_text(KIT_STYLE, "gear.mpf", load_machine("dmc60h"))
    assert r.path.n == 6 and r.complete
    g21 = [w for w in r.warnings if "G21" in w.message]
    assert len(g21) == 1 and g21[0].line == 2
    assert "taken as G710 (metric lengths and feeds)" in g21[0].message
    assert r.approximations == ()              # metric is what the program means anyway


def test_g20_is_inch_in_siemens_mode_too():
    r = interpret_text("G20\nG1 X1 F10\nM30\n")
    assert r.path.end_mm[0][0] == pytest.approx(25.4)
    assert r.path.feed_mm_s[0] == pytest.approx(254.0 / 60.0)   # G700: inch/min


def test_the_kit_notch_recording_program_runs(shared):
    r = interpret_file(shared / "data/real/kit-dmc60h-notch-sinumerik/AL_2007_T4_Notch_Normal.mpf",
                       load_machine("dmc60h"))
    assert r.complete and r.path.n == 20


def test_iso_only_g_functions_in_siemens_mode_name_the_switch(tmp_path):
    sub = tmp_path / "SUB.SPF"
    sub.write_text("PROC SUB\nG81 X1 Z-1 R1\nRET\n")
    main = tmp_path / "MAIN.MPF"
    main.write_text("SUB\nM30\n")
    with pytest.raises(NcError, match=r"SUB.SPF:2:1: unknown G function G81 \(an ISO dialect code: "
                                      r"G291 or --dialect iso runs ISO code\)"):
        interpret_file(main)


@pytest.mark.parametrize("text, line, col, message", [
    ("%\nO0010\nG0 X0 Y0\nG83 X1 Y1 Z-5 R1 Q1 F100\nM30\n", 2, 1,
     "looks like ISO/Fanuc code (O0010, G83): run with --dialect iso"),
    ("G0 X0\n#100=5\nG1 X#100 F100\nM30\n", 2, 1, "looks like ISO/Fanuc code (#100): run with "
     "--dialect iso"),
    ("G90\nM98 P1000\nM30\n", 2, 1, "looks like ISO/Fanuc code (M98 P): run with --dialect iso"),
    ("G1 X1 F100\n(MSG, hello)\nG1 X#<x>\nM2\n", 2, 1,
     "looks like LinuxCNC/RS274NGC code ((MSG,, #<x>): not an 840D program"),
])
def test_foreign_code_gets_one_located_line(text, line, col, message):
    with pytest.raises(NcError) as info:
        interpret_text(text, "p.nc")
    e = info.value
    assert (e.line, e.column, e.message) == (line, col, message)


def test_an_ordinary_siemens_error_is_not_called_foreign():
    with pytest.raises(NcError, match=r"p.mpf:2:1: unknown G function G7000"):
        interpret_text("G1 X1 F100 ; (a comment)\nG7000\nM30\n", "p.mpf")


def test_the_machine_file_selects_the_dialect():
    data = tomllib.loads(dump_machine_toml(load_machine("mikron")))
    data["iso"] = {"dialect": "iso"}
    machine = machine_from_dict(data, "m.toml")
    r = interpret_text("O1\n#1=3.\nG1 X#1 F100\nM30\n", machine=machine)
    assert r.path.end_mm[0][0] == 3.0
    assert "[iso]" in dump_machine_toml(machine)
    assert machine_from_dict(tomllib.loads(dump_machine_toml(machine))).iso == machine.iso
    r = interpret_text("R1=2\nG1 X=R1 F100\nM30\n", machine=machine, dialect="siemens")
    assert r.path.end_mm[0][0] == 2.0
    data["iso"] = {"dialect": "fanuc", "peck_retract_mm": -1, "reference_points_mm": [[0, 0]]}
    with pytest.raises(MachineSpecError) as info:
        machine_from_dict(data, "m.toml")
    text = str(info.value)
    assert "iso.dialect: must be one of siemens, iso, got 'fanuc'" in text
    assert "iso.peck_retract_mm" in text and "iso.reference_points_mm.1" in text


def test_rtliof_rtlion_fgroup_fgref():
    r = interpret_text("RTLIOF\nG0 X10 Y5\nRTLION\nFGROUP(X, Y, Z)\nFGROUP()\n"
                       "G1 X0 F100\nM30\n")
    assert r.path.n == 2
    assert [k for k, *_ in r.approximations] == ["RTLIOF"]
    r = interpret_text("FGROUP(X, Y)\nFGREF[C]=57.3\nG1 X1 Z1 F100\nM30\n")
    messages = [w.message for w in r.warnings]
    assert any(m.startswith("FGROUP(X, Y): the path feed of these axes") for m in messages)
    assert any(m.startswith("FGREF[C]=57.3") for m in messages)
    assert [k for k, *_ in r.approximations] == ["FGROUP"]
