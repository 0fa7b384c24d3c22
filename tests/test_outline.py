"""Each segment's N number, tool and operation (``ncsim.nc.outline``), from the conventions
CAM posts write (the THWS files are real NX output; the Fusion and hyperMILL forms follow
their posts), and the machine file's tool-change time."""
from __future__ import annotations

import numpy as np
import pytest

from ncsim.machine import load_machine, machine_from_dict
from ncsim.nc.interpret import interpret_file, interpret_text
from ncsim.nc.outline import operation_comments, tool_name
from ncsim.pipeline import simulate

THWS = "data/real/thws-spinner-u5-620-nc-programs"


@pytest.mark.parametrize("line, name", [
    ("N150 ;Operation : PLANFLAECHE", "PLANFLAECHE"),        # NX, 840D sl post (THWS)
    (";OPERATION: FACE MILL", "FACE MILL"),
    ("; OP 10 - ROUGH POCKET", "ROUGH POCKET"),
    (";* JOB 3 : 3D optimized roughing ", "3D optimized roughing"),   # hyperMILL job list
    ("  N20 ; Operation no. 4 = Finish", "Finish"),
    ("/N30 ;Toolpath: Contour1", "Contour1"),
    (";Arbeitsgang: Schruppen", "Schruppen"),
])
def test_operation_comment_forms(line, name):
    assert operation_comments(f"G0 X0\n{line}\nG1 X1\n") == ((2, name),)


@pytest.mark.parametrize("line", [
    "G1 X1 ;Operation : A",          # a block with a comment, not a comment line
    "; operational note: check the clamp",
    ";Operation :",                  # no name
    "; OPTION: 3",
    "MSG(\"Operation : A\")",
])
def test_not_an_operation_comment(line):
    assert operation_comments(f"{line}\n") == ()


def test_tool_names():
    assert tool_name("SCHAFT_D8_N_AP20") == "SCHAFT_D8_N_AP20"
    assert tool_name(12.0) == "T12"


def test_thws_bottle_opener_operations_tools_and_numbers(shared, mikron):
    """The real NX program: its five ``;Operation :`` comments and three ``T=".." M6``, read
    off the file; a segment of line L carries the N of line L (N = 10 L in this file)."""
    path = interpret_file(shared / THWS / "Bottle_opener_Flaschenoeffner.txt", mikron).path
    assert path.operations == ("PLANFLAECHE", "3D_ADAPTIVE_ROUGHING", "3D_ADAPTIVE_ROUGHING_1",
                               "WALL_PROFILING", "CURVE_DRIVE")
    assert path.tools == ("SCHAFT_D8_N_AP20", "SCHAFT_D4_N_AP20", "ENTFRAESER_D8_90GRAD")
    np.testing.assert_array_equal(path.block_number, 10 * path.line)

    def at(line):
        i = int(np.flatnonzero(path.line == line)[0])
        return path.tool_of(i), path.operation_of(i)
    assert at(18) == (None, "PLANFLAECHE")                       # SUPA G0 before the first T/M6
    assert at(33) == ("SCHAFT_D8_N_AP20", "PLANFLAECHE")         # after N220 M6
    assert at(64) == ("SCHAFT_D8_N_AP20", "3D_ADAPTIVE_ROUGHING")    # no tool change there
    assert at(1581) == ("SCHAFT_D4_N_AP20", "3D_ADAPTIVE_ROUGHING_1")
    assert at(2390) == ("SCHAFT_D4_N_AP20", "WALL_PROFILING")
    assert at(2784) == ("ENTFRAESER_D8_90GRAD", "CURVE_DRIVE")


def test_fusion_msg_operations_and_preselected_tool():
    """Fusion's 840D post: ``MSG ("name")`` opens each operation, ``T1 M6`` loads a tool and the
    next tool is preselected right after (``T2``): it is not in the spindle before its M6."""
    text = ("N10 G90 G64 F1000\nMSG (\"Face1\")\nN20 T1\nN30 M6\nN40 T2\nN50 G1 X10\n"
            "MSG (\"Pocket2\")\nN60 G1 Y10\nN70 T2\nN80 M6\nN90 G1 X0\nMSG()\nN100 G1 Y0\nM30\n")
    path = interpret_text(text, "fusion.mpf").path
    assert [path.block_number[i] for i in range(path.n)] == [50, 60, 90, 100]
    assert [path.tool_of(i) for i in range(path.n)] == ["T1", "T1", "T2", "T2"]
    assert [path.operation_of(i) for i in range(path.n)] == ["Face1", "Pocket2", "Pocket2", None]


def test_nx_comments_name_operations_and_msg_types_do_not():
    text = ("N10 ;Operation : ROUGH\nN20 MSG(\"MILL_ROUGH\")\nN30 G1 X1 F100\n"
            "N40 ;Operation : FINISH\nN50 MSG(\"MILL_FINISH\")\nN60 G1 X2\nM30\n")
    path = interpret_text(text, "nx.mpf").path
    assert path.operations == ("ROUGH", "FINISH")
    assert [path.operation_of(i) for i in range(path.n)] == ["ROUGH", "FINISH"]


def test_without_m6_the_t_word_changes_the_tool():
    path = interpret_text("G90 F100\nT3\nG1 X1\nT=\"DRILL\"\nG1 X2\nM30\n", "t.mpf").path
    assert [path.tool_of(i) for i in range(path.n)] == ["T3", "DRILL"]


def test_loop_passes_keep_their_line_and_number_and_a_subprogram_its_callers_operation(tmp_path):
    """A loop's passes carry the N of their line; a subprogram that names no operation runs
    in the operation of the motion before its call, one that names its own uses it."""
    (tmp_path / "SIDE.SPF").write_text("G1 Y5\nG1 Y0\nM17\n")
    (tmp_path / "OWN.SPF").write_text(";Operation : DEBURR\nG1 Z-1\nM17\n")
    main = tmp_path / "main.mpf"
    main.write_text("N10 ;Operation : CONTOUR\nN20 G90 G1 F500 X1\nN30 R1=0\nLOOP1:\n"
                    "N40 G1 X=R1+2\nN50 R1=R1+1\nN60 IF R1<3 GOTOB LOOP1\nN70 SIDE\nN80 OWN\n"
                    "N90 G1 X0\nM30\n")
    path = interpret_file(main).path
    numbers = [int(v) for v in path.block_number]
    assert numbers == [20, 40, 40, 40, -1, -1, -1, 90]
    assert [path.operation_of(i) for i in range(path.n)] == ["CONTOUR"] * 6 + ["DEBURR", "CONTOUR"]
    assert path.file_of(4).endswith("SIDE.SPF")


def test_block_path_and_column_path_label_alike():
    text = "".join(f"N{10 * k} G1 X{k} Y{k % 3} F800\n" for k in range(1, 40))
    text = "T5 M6\n;Operation : RASTER\n" + text + "M30\n"
    fast, slow = (interpret_text(text, "raster.mpf", fast=f).path for f in (True, False))
    for name in ("block_number", "tool", "operation"):
        np.testing.assert_array_equal(getattr(fast, name), getattr(slow, name))
    assert fast.tools == slow.tools == ("T5",) and fast.operations == ("RASTER",)


def test_rounding_block_carries_the_block_it_rounds_out_of(mikron):
    """G642 inserts a rounding block at the corner: it belongs to the block before it. (A
    machine whose G64 corner stops, MD32310 = 1, and CTOL 0.05 at F600: there the rounding
    saves time; ``plan.blend`` keeps G64 corners where it would not.)"""
    stops = mikron.with_axes(max_accel_ovl_factor=1.0)
    sim = simulate("corner.mpf", stops, text="N10 G90 G642 CTOL=0.05 SOFT F600\nN20 G1 X50\n"
                   "N30 G1 Y50\nN40 G1 X0\nM30\n")
    path = sim.motion.path
    assert path.n > sim.interpreted.path.n                      # rounding blocks inserted
    assert set(path.block_number.tolist()) == {20, 30, 40}
    assert list(path.block_number) == sorted(path.block_number)


def _machine(tool_change_s=None):
    base = load_machine("mikron")
    from ncsim.machine import dump_machine_toml
    import tomllib
    data = tomllib.loads(dump_machine_toml(base))
    if tool_change_s is not None:
        data["tool_change"] = {"time_s": tool_change_s}
    return machine_from_dict(data, "test.toml")


def test_tool_change_time_from_the_machine_file():
    """[tool_change] time_s: each M6 stands still that long (0 by default, then a warning and
    the time is approximate)."""
    text = "G90 G60 F1000\nT1 M6\nG1 X10\nT2\nM6\nG1 X0\nM30\n"
    plain = simulate("tc.mpf", _machine(), text=text)
    timed = simulate("tc.mpf", _machine(6.5), text=text)
    assert timed.cycle_time_s == pytest.approx(plain.cycle_time_s + 2 * 6.5, abs=1e-9)
    assert "M6" in dict((k, n) for k, n, _ in plain.interpreted.approximations)
    assert not timed.interpreted.approximations
    assert _machine(6.5).tool_change_s == 6.5 and _machine().tool_change_s == 0.0
