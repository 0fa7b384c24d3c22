"""Shop programs read as the control reads them: GUD initialisers that name what came before,
lathe diameter programming (DIAMON, DIAM90, DIAMOF, DAC/DIC/RAC/RIC) on the machine type's
reset values, DRFOF, DEFINE ... AS macros, AXNAME and axis names as AXIS values, and variable
names that are NC addresses. Every expected number is worked out by hand from the program text
and the Programming Manual's rules (cited in ``ncsim.nc.diameter``, ``ncsim.nc.macros`` and
``ncsim.nc.variables``)."""
from __future__ import annotations

import json
import re

import pytest
from click.testing import CliRunner

from ncsim.cli.main import cli
from ncsim.errors import MachineSpecError, NcSemanticError, NcSyntaxError
from ncsim.machine import dump_machine_toml, load_machine, machine_from_dict
from ncsim.nc.interpret import interpret_file, interpret_text

FACE = "G18 G90 G95 G0 X50 Z2\nS500 M3\nG1 X20 F0.1\nM30\n"


def ends(r) -> list[list[float]]:
    return [[round(float(c), 9) for c in s.end_mm] for s in r.path.segments()]


def cli_run(*args):
    return CliRunner().invoke(cli, [str(a) for a in args])


@pytest.fixture(scope="module")
def lathe():
    return load_machine("lathe")


# ---- GUD definitions whose initialisers name something ----------------------------------------

def test_a_gud_initialiser_reads_the_variables_defined_before_it(tmp_path):
    (tmp_path / "gud.def").write_text("DEF CHAN REAL UA = 1\nDEF CHAN REAL UB = UA+1\n"
                                      "Def Chan Axis UAX = (Z)\n")
    (tmp_path / "p.mpf").write_text("G1 X=UB F100\nAX[UAX]=5\nM30\n")
    r = cli_run("parse", tmp_path / "p.mpf", "--definitions", tmp_path / "gud.def")
    assert r.exit_code == 0, r.output
    r = interpret_file(tmp_path / "p.mpf", definitions=[tmp_path / "gud.def"])
    assert ends(r) == [[2, 0, 0], [2, 0, 5]]         # UB = 1 + 1; UAX names Z


def test_a_gud_initialiser_naming_nothing_is_one_located_line(tmp_path):
    (tmp_path / "gud.def").write_text("DEF CHAN REAL UB = UA+1\n")
    (tmp_path / "p.mpf").write_text("G1 X1 F100\nM30\n")
    r = cli_run("run", tmp_path / "p.mpf", "--machine", "mikron", "--definitions",
                tmp_path / "gud.def")
    assert r.exit_code == 2 and "Traceback" not in r.output
    assert r.stderr.strip().endswith("gud.def:1:20: undefined variable UA (DEF it first)")


# ---- diameter programming -------------------------------------------------------------------

def test_the_issue_facing_cut_takes_18_s_on_the_lathe(tmp_path):
    """X50 -> X20 is a 15 mm radial cut; F0.1 mm/rev x S500 rev/min = 50 mm/min: 18 s."""
    (tmp_path / "face.mpf").write_text(FACE)
    r = cli_run("run", tmp_path / "face.mpf", "--machine", "lathe", "--json")
    assert r.exit_code == 0, r.output
    s = json.loads(r.stdout)
    (cut,) = s["feeds"]
    assert cut["feed_programmed_mm_min"] == pytest.approx(50)
    assert cut["length_mm"] == pytest.approx(15)
    assert cut["time_s"] == pytest.approx(18.0, rel=2e-3)
    # plus the rapid approach from the origin to X25 (radius) Z2: 25 mm at 24 m/min is 62.5 ms
    # without ramps, and the ramps cost under a second at 4 m/s^2
    assert 18.06 < s["cycle_time_s"] < 19.0 and not s["approximate"]


def test_a_milling_machine_reads_radius_until_the_program_says_diamon(mikron):
    radius = interpret_text(FACE, "face.mpf", mikron)
    assert ends(radius)[-1] == [20, 0, 2]                    # X read as a radius: a 30 mm cut
    diameter = interpret_text("DIAMON\n" + FACE, "face.mpf", mikron)
    assert ends(diameter) == [[25, 0, 2], [10, 0, 2]]       # DIAMON switches it on there too


def test_diamon_diam90_diamof_under_g90_and_g91(lathe):
    """DIAMON: diameter for G90 and G91; DIAM90: diameter for G90, radius for G91; DIAMOF:
    radius (Fundamentals, "Dimensions for turning and milling")."""
    prog = ("G90 G0 X40 Z0\n"          # DIAMON (the lathe's reset): radius 20
            "G91 X-10\n"               # incremental diameter: -5 -> 15
            "DIAM90\nX-10\n"           # G91 under DIAM90: radius -> 5
            "G90 X30\n"                # G90 under DIAM90: diameter -> 15
            "DIAMOF\nX30\n"            # radius -> 30
            "DIAMCYCOF\nX12\n"         # radius while cycles run -> 12
            "M30\n")
    r = interpret_text(prog, "d.mpf", lathe)
    assert [e[0] for e in ends(r)] == [20, 15, 5, 15, 30, 12]


def test_dac_dic_rac_ric_per_value_whatever_the_mode(lathe, mikron):
    prog = "G90 G0 X=DAC(40)\nX=DIC(-10)\nX=RAC(30)\nX=RIC(-4)\nM30\n"
    for machine in (lathe, mikron):                 # DIAMON or DIAMOF in force: no difference
        assert [e[0] for e in ends(interpret_text(prog, "d.mpf", machine))] == [20, 15, 30, 26]
    with pytest.raises(NcSemanticError, match=r"transverse axis X \(MD20100\), not of Z"):
        interpret_text("G0 Z=DAC(4)\nM30\n", "d.mpf", lathe)


def test_circle_centre_in_diameter_only_when_absolute(lathe):
    """G18 (the lathe's reset plane): X45 Z-30 -> X45 Z-40 about a centre on the axis line
    Z-35; I=AC(25) is a diameter (radius 12.5), an incremental I a radius."""
    absolute = interpret_text("G0 X45 Z-30\nG1 F100\nG3 X45 Z-40 I=AC(25) K=AC(-35)\nM30\n",
                              "c.mpf", lathe)
    incremental = interpret_text("G0 X45 Z-30\nG1 F100\nG3 X45 Z-40 I-10 K-5\nM30\n",
                                 "c.mpf", lathe)
    for r in (absolute, incremental):
        arc = list(r.path.segments())[-1]
        assert [round(float(c), 9) for c in arc.center_mm] == [12.5, 0, -35]
        assert float(arc.radius_mm) == pytest.approx((10 ** 2 + 5 ** 2) ** 0.5)


def test_the_column_path_and_compiled_loops_read_diameters_as_the_block_path(lathe):
    plain = "".join(f"G1 X{40 - 2 * k} Z{-k}\n" for k in range(12))
    prog = "G18 G90 G94 F200\n" + plain + "G91\n" + plain + "M30\n"
    loop = ("G94 F200\nR1=0\nMARK:\nG1 X=40-R1 Z=-R1\nR1=R1+2\nIF R1<20 GOTOB MARK\n"
            "DIAMOF\nR1=0\nLOOP2:\nG1 X=R1\nR1=R1+2\nIF R1<10 GOTOB LOOP2\nM30\n")
    for text in (prog, loop):
        fast = interpret_text(text, "p.mpf", lathe)
        slow = interpret_text(text, "p.mpf", lathe, fast=False)
        assert ends(fast) == ends(slow)
    assert ends(interpret_text(loop, "p.mpf", lathe))[1] == [19, 0, -2]     # X38 -> radius 19


def test_save_restores_the_diameter_mode(lathe):
    prog = "SUB\nG0 X10\nM30\nPROC SUB SAVE\nDIAMOF\nG0 X10\nRET\n"
    assert [e[0] for e in ends(interpret_text(prog, "s.mpf", lathe))] == [10, 5]


def test_the_machine_type_sets_the_reset_plane_and_diameter_mode(lathe, mikron):
    assert lathe.kind == "turning" and mikron.kind == "milling"
    assert (lathe.ncu.reset_plane, lathe.ncu.reset_diameter_mode, lathe.ncu.diameter_axis) == (18, 1, 0)
    assert (mikron.ncu.reset_plane, mikron.ncu.reset_diameter_mode) == (17, 0)
    data = _lathe_dict(lathe)
    data["ncu"]["reset_diameter_mode"] = "DIAMOF"
    assert machine_from_dict(data).ncu.reset_diameter_mode == 0
    data["machine"]["type"] = "grinding"
    with pytest.raises(MachineSpecError, match="machine.type: must be one of milling, turning"):
        machine_from_dict(data)
    again = load_machine_text(dump_machine_toml(lathe))
    assert (again.kind, again.ncu.reset_plane, again.ncu.reset_diameter_mode) == ("turning", 18, 1)


def _lathe_dict(spec) -> dict:
    import tomllib
    return tomllib.loads(dump_machine_toml(spec))


def load_machine_text(text: str):
    import tomllib
    return machine_from_dict(tomllib.loads(text))


# ---- standard commands ----------------------------------------------------------------------

def test_drfof_and_the_diameter_commands_are_commands_not_subprograms(tmp_path):
    (tmp_path / "p.mpf").write_text("DRFOF\nDIAMON\nDIAM90\nDIAMOF\nG1 X1 F100\nM30\n")
    r = cli_run("run", tmp_path / "p.mpf", "--machine", "mikron", "--json")
    assert r.exit_code == 0 and r.stderr == "", r.output
    assert not json.loads(r.stdout)["approximate"]


def test_define_as_macros_in_the_program_and_in_a_definitions_file(tmp_path):
    """Job planning, "Macro technique (DEFINE ... AS)"."""
    (tmp_path / "umac.def").write_text("DEFINE M6 AS L6\n")
    (tmp_path / "L6.SPF").write_text("G0 Z100\nM17\n")
    (tmp_path / "p.mpf").write_text('DEFINE LINE AS G1\nDEFINE M13 AS M3 M8 ; spindle, coolant\n'
                                    'DEFINE UFEED AS 250\nT1 M6\nS1000 M13\n'
                                    'LINE X10 F=UFEED ; LINE stays in the comment\n'
                                    'MSG("LINE in a string stays")\nM30\n')
    r = interpret_file(tmp_path / "p.mpf", definitions=[tmp_path / "umac.def"])
    segs = list(r.path.segments())
    assert ends(r) == [[0, 0, 100], [10, 0, 100]]
    assert not segs[1].rapid and float(segs[1].feed_mm_s) == pytest.approx(250 / 60)
    assert r.messages[0].args == ("LINE in a string stays",)


def test_define_errors_are_located():
    with pytest.raises(NcSyntaxError, match="DEFINE needs a name and an instruction") as e:
        interpret_text("G1 X1 F100\nDEFINE LINE G1\nM30\n", "m.mpf")
    assert (e.value.line, e.value.column) == (2, 1)
    with pytest.raises(NcSyntaxError, match="macros cannot be nested"):
        interpret_text("DEFINE LINE AS G1\nDEFINE FAST AS LINE F1000\nM30\n", "m.mpf")


def test_axname_and_an_axis_name_assigned_to_an_axis_variable():
    prog = ('DEF AXIS _A1=AXNAME("y")\nDEF AXIS _A2\n_A2=Z\nDEF STRING[4] _S=AXSTRING(_A2)\n'
            'G1 F100 AX[_A1]=3\nAX[_A2]=4\nIF _S=="Z" GOTOF OK\nX1\nOK:\nM30\n')
    assert ends(interpret_text(prog, "a.mpf")) == [[0, 3, 0], [0, 3, 4]]
    with pytest.raises(NcSemanticError, match=r"AXNAME\(\): 'Q' is no axis name"):
        interpret_text('DEF AXIS _A1=AXNAME("Q")\nM30\n', "a.mpf")


# ---- names that are NC addresses ------------------------------------------------------------

def test_the_issue_proc_with_parameters_named_like_axes_is_rejected(tmp_path):
    """Fundamentals, "Identifiers": the first two characters are letters or underscores; a
    parameter B would otherwise be the B axis, and X=URES+1 would move to X1, not X11."""
    (tmp_path / "SUBB.SPF").write_text("PROC SUBB(REAL A, VAR REAL B)\nB=A*2\nRET\n")
    (tmp_path / "m.mpf").write_text("DEF REAL URES\nG90 G0 X0 Y0 Z0\nSUBB(5,URES)\n"
                                    "G1 X=URES+1 F100\nM30\n")
    r = cli_run("parse", tmp_path / "m.mpf")
    assert r.exit_code == 2 and "Traceback" not in r.output
    assert re.fullmatch(r".*SUBB\.SPF:1:16: PROC SUBB: parameter name A is the axis A, not an "
                        r"identifier: the control rejects it .*", r.stderr.strip())
    (tmp_path / "SUBB.SPF").write_text("PROC SUBB(REAL UA, VAR REAL UB)\nUB=UA*2\nRET\n")
    r = interpret_file(tmp_path / "m.mpf")
    assert ends(r)[-1] == [11, 0, 0]


@pytest.mark.parametrize("name", ["B", "X1", "R10", "F"])
def test_def_of_an_address_name_is_rejected(name):
    with pytest.raises(NcSemanticError, match=f"variable name {name} is"):
        interpret_text(f"DEF REAL {name}=1\nM30\n", "d.mpf")
