"""Program flow: labels and jumps, IF/ELSE, WHILE, FOR, REPEAT, LOOP, subprograms, block skip."""
from __future__ import annotations

import pytest

from ncsim.nc.interpret import interpret_file, interpret_text


def xs(text, **kw):
    r = interpret_text(text, "c.mpf", **kw)
    return [float(s.end_mm[0]) for s in r.path.segments()], r


def test_if_else_endif():
    prog = "R1={}\nG1 F100\nIF R1==1\nX1\nELSE\nX2\nENDIF\nX3\n"
    assert xs(prog.format(1))[0] == [1, 3]
    assert xs(prog.format(0))[0] == [2, 3]


def test_if_without_else():
    assert xs("G1 F100\nIF 0\nX1\nENDIF\nX3\n")[0] == [3]


def test_while_loop():
    x, r = xs("R1=0\nG91 G1 F100\nWHILE R1<3\nX1\nR1=R1+1\nENDWHILE\n")
    assert x == [1, 2, 3]
    assert r.blocks_executed == 2 + 4 * 3 + 1   # the WHILE is evaluated four times


def test_for_loop_and_its_counter():
    x, _ = xs("DEF INT _I\nG1 F100\nFOR _I=1 TO 3\nX=_I*10\nENDFOR\nX=_I\n")
    assert x == [10, 20, 30, 4]


def test_for_loop_not_entered():
    assert xs("G1 F100\nFOR R1=5 TO 1\nX1\nENDFOR\nX2\n")[0] == [2]


def test_repeat_until_runs_at_least_once():
    assert xs("R1=10\nG91 G1 F100\nREPEAT\nX1\nR1=R1+1\nUNTIL R1>5\n")[0] == [1]


def test_loop_left_with_gotof():
    x, _ = xs("R1=0\nG91 G1 F100\nLOOP\nX1\nR1=R1+1\nIF R1>=2 GOTOF DONE\nENDLOOP\nDONE: X5\n")
    assert x == [1, 2, 7]


def test_nested_structures():
    prog = ("G91 G1 F100\nFOR R1=1 TO 2\nR2=0\nWHILE R2<2\nIF R1==2\nY1\nELSE\nX1\nENDIF\n"
            "R2=R2+1\nENDWHILE\nENDFOR\n")
    r = interpret_text(prog)
    assert [s.end_mm.tolist() for s in r.path.segments()] == [[1, 0, 0], [2, 0, 0], [2, 1, 0], [2, 2, 0]]


def test_gotob_loop_with_label_and_gotof_block_number():
    x, _ = xs("R1=0\nG91 G1 F100\nAGAIN: X1\nR1=R1+1\nIF R1<3 GOTOB AGAIN\nGOTOF N99\nX100\nN99 X10\n")
    assert x == [1, 2, 3, 13]


def test_goto_searches_forward_then_backward_and_gotoc_tolerates_missing():
    x, _ = xs("R1=0\nG91 G1 F100\nTOP: X1\nR1=R1+1\nIF R1==2 GOTOF OUT\nGOTO TOP\nOUT: GOTOC NOWHERE\nX5\n")
    assert x == [1, 2, 7]


def test_jump_target_in_a_plain_run_and_backwards_into_it():
    prog = "G91 G1 F100\nR1=0\nN10 X1\nN20 X1\nN30 X1\nR1=R1+1\nIF R1<2 GOTOB N20\n"
    assert xs(prog)[0] == [1, 2, 3, 4, 5]


def test_gotos_restarts_the_program():
    assert xs("R1=R1+1\nG91 G1 X1 F100\nIF R1<3 GOTOF AGAIN\nM30\nAGAIN: GOTOS\n")[0] == [1, 2, 3]


def test_proc_in_the_same_file_with_parameters_and_repetitions():
    prog = ("G90 G1 F100\nSTEP(2.5)\nSTEP(1) P2\nM30\n"
            "PROC STEP(REAL DX)\nG91 X=DX\nG90\nRET\n")
    x, r = xs(prog)
    assert x == [2.5, 3.5, 4.5]
    assert r.path.files == ("c.mpf",) and r.path.line.tolist() == [6, 6, 6]


def test_subprogram_files_by_name_and_by_l_number(tmp_path):
    (tmp_path / "L10.SPF").write_text("G91 G1 Y1\nG90\nM17\n")
    (tmp_path / "CONTOUR.spf").write_text("PROC CONTOUR\nG1 X5 F200\nL10 P2\nRET\n")
    main = tmp_path / "MAIN.MPF"
    main.write_text("G1 F100\nCONTOUR\nX0\nM30\n")
    r = interpret_file(main)
    assert [s.end_mm.tolist() for s in r.path.segments()] == [[5, 0, 0], [5, 1, 0], [5, 2, 0], [0, 2, 0]]
    files = [r.path.file_of(i) for i in range(len(r.path))]
    assert [f.rsplit("/", 1)[-1] for f in files] == ["CONTOUR.spf", "L10.SPF", "L10.SPF", "MAIN.MPF"]
    assert r.path.line.tolist() == [2, 1, 1, 3]
    assert r.path.segment(0).feed_mm_s == pytest.approx(200 / 60)   # modal state is shared


def test_subprogram_variables_are_local():
    prog = "DEF REAL _A=1\nG1 F100\nSUB\nX=_A\nM30\nPROC SUB\nDEF REAL _A=7\nX=_A\nM17\n"
    assert xs(prog)[0] == [7, 1]


def test_main_program_given_as_proc():
    assert xs("PROC MAIN\nG1 X2 F100\nM30\n")[0] == [2]


def test_m30_ends_even_inside_a_subprogram():
    x, r = xs("G1 F100\nSUB\nX9\nPROC SUB\nX1\nM30\n")
    assert x == [1]


def test_block_skip():
    prog = "G1 F100\n/X1\nX2\n"
    assert xs(prog)[0] == [1, 2]
    assert xs(prog, skip_blocks=True)[0] == [2]
