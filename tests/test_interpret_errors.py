"""Every kind of bad input: one typed NcError at FILE:LINE:COL with a message that says what."""
from __future__ import annotations

import pytest

from ncsim.errors import NcError, NcSemanticError, NcSyntaxError, NcUnsupportedError, shown
from ncsim.nc.interpret import interpret_text

CASES = [
    # (id, program, error class, line, column, message fragment)
    ("syntax", "G1 X1 F100\nN20 G1 X=(1+2\n", NcSyntaxError, 2, 14, "unexpected end of block"),
    ("syntax char", "G1 X1 F100\nG1 X1 # 3\n", NcSyntaxError, 2, 7, "unexpected character '#'"),
    ("unknown word", "G1 X1 F100\nG1 Q5\n", NcSemanticError, 2, 4, "unknown word Q"),
    ("unknown command", "G1 X1 F100\nFOO\n", NcSemanticError, 2, 1, "subprogram FOO not found"),
    ("unknown G", "G123 X1\n", NcSemanticError, 1, 1, "unknown G function G123"),
    ("unknown function", "R1=FOO(2)\n", NcSemanticError, 1, 4, "unknown function FOO()"),
    ("no feed", "G0 X5\nN20 G1 X10\n", NcSemanticError, 2, 5, "G1 without a feed: no F programmed yet"),
    ("no feed modal", "G1\nX10\n", NcSemanticError, 2, 1, "G1 without a feed"),
    ("no feed arc", "G2 X10 I5\n", NcSemanticError, 1, 1, "G2 without a feed"),
    ("arc no centre", "G1 F100\nG2 X10 Y0\n", NcSemanticError, 2, 1,
     "G2 without centre (I J K), radius (CR=) or opening angle (AR=)"),
    ("radius mismatch", "G1 X5 F100\nG3 X-5.02 Y0 I-5\n", NcSemanticError, 2, 1,
     "circle end point error: start radius 5.0000 mm and end radius 5.0200 mm differ by 0.0200 mm > 0.0100 mm"),
    ("radius mismatch large", "G1 X100 F100\nG2 X-100.2 I-100\n", NcSemanticError, 2, 1,
     "differ by 0.2000 mm > 0.1000 mm"),
    ("division by zero", "R2=0\nR1=5/R2\n", NcSemanticError, 2, 5, "division by zero (/)"),
    ("division by zero DIV", "R1=5 DIV 0\n", NcSemanticError, 1, 6, "division by zero (DIV)"),
    ("missing label", "G1 F100\nGOTOF NIRVANA\n", NcSemanticError, 2, 7,
     "jump destination NIRVANA not found (GOTOF searches forward)"),
    ("label only backwards", "BACK: G1 F100\nGOTOF BACK\n", NcSemanticError, 2, 7, "BACK not found"),
    ("missing block number", "G1 F100\nGOTOB N5\n", NcSemanticError, 2, 7, "jump destination N5 not found"),
    # a loop that decides nothing stops at its second pass, moving or not; the budget error
    # names the jump back that closes the loop
    ("endless loop", "G1 F100\nTOP: G91 X1\nGOTOB TOP\n", NcSemanticError, 3, 1,
     "endless loop: nothing between two passes of this jump back decides anything"),
    ("endless while", "WHILE 1\nENDWHILE\n", NcSemanticError, 2, 1,
     "endless loop: nothing between two passes of this jump back decides anything"),
    ("endless loop with a condition", "G1 F100\nR1=0\nTOP: R1=R1+1\nX=R1\nIF R1>0 GOTOB TOP\n",
     NcSemanticError, 5, 9,
     "block budget of 101 blocks exceeded: endless loop? this jump back was taken 33 times"),
    ("endif without if", "G1 F100\nENDIF\n", NcSemanticError, 2, 1, "ENDIF without IF"),
    ("if without endif", "IF R1==0\nG1 F100\n", NcSemanticError, 1, 1, "IF without ENDIF"),
    ("crossed structures", "WHILE 1\nIF 1\nENDWHILE\n", NcSemanticError, 3, 1, "ENDWHILE closes IF of line 2"),
    ("else without if", "ELSE\n", NcSemanticError, 1, 1, "ELSE without IF"),
    ("undefined variable", "G1 F100\nX=_NOPE\n", NcSemanticError, 2, 3, "undefined variable _NOPE"),
    ("assign undefined", "_NOPE=1\n", NcSemanticError, 1, 1, "unknown word or undefined variable _NOPE"),
    ("g95 without spindle", "G95 G1 X1 F0.1\n", NcSemanticError, 1, 5,
     "G1 with feed per revolution (G95) needs the spindle turning: S and M3/M4"),
    ("g96", "G96 S200 M3\n", NcUnsupportedError, 1, 1, "constant cutting rate G96 (turning) is not simulated"),
    ("g93", "G1 F100\nG93\n", NcUnsupportedError, 2, 1, "inverse-time feed G93 is not simulated"),
    ("non-uniform scale arc", "G1 F100\nSCALE X2 Y1\nG2 X10 I5\n", NcUnsupportedError, 3, 1,
     "non-uniform SCALE"),
    ("cr too small", "G1 F100\nG2 X10 CR=4\n", NcSemanticError, 2, 8,
     "CR=4 is smaller than half the distance between start and end point"),
    ("cr full circle", "G1 F100\nG2 CR=4\n", NcSemanticError, 2, 4, "a full circle cannot be programmed with CR="),
    ("cip collinear", "G1 F100\nCIP X10 I1=5\n", NcSemanticError, 2, 1, "lie on one line"),
    ("ct first", "G1 F100\nCT X10 Y5\n", NcSemanticError, 2, 1, "CT needs a previous path segment"),
    ("same group", "G1 G0 X1\n", NcSemanticError, 1, 4, "G1 and G0 in one block (both in the motion group)"),
    ("cip and g", "CIP G1 X1\n", NcSemanticError, 1, 5, "CIP and G1 in one block (both in the motion group)"),
    ("g and ct", "G2 CT X1\n", NcSemanticError, 1, 4, "G2 and CT in one block"),
    ("twice", "G1 X1 X2 F100\n", NcSemanticError, 1, 7, "X programmed twice in one block"),
    ("keyword mid block", "N10 G1 X1 F100 ELSE\n", NcSemanticError, 1, 16, "ELSE must begin a block of its own"),
    ("sqrt negative", "R1=SQRT(-4)\n", NcSemanticError, 1, 4, "SQRT of a negative number"),
    ("no subprogram", "G1 F100\nPOCKETX(1)\n", NcSemanticError, 2, 1, "subprogram POCKETX not found"),
    ("negative feed", "G1 X1 F=-5\n", NcSemanticError, 1, 7, "feed F must be positive"),
    # 0.001 <= F (Fundamentals, list of addresses): a plain CAM line, so the columnar fast path
    # must hand it to the checking path rather than time 10 mm at 1e-22 mm/min (6e24 s)
    ("feed below 0.001", "G1 X10 F0.0000000000000000000001\n", NcSemanticError, 1, 8,
     "below the smallest the 840D accepts, F0.001"),
    ("string as number", "G1 X=\"A\"\n", NcSemanticError, 1, 6, "X needs a number"),
    ("ijk with g1", "G1 X1 I2 F100\n", NcSemanticError, 1, 7, "I is only allowed with a circle"),
    ("block number mid", "G1 X1 N20\n", NcSemanticError, 1, 7, "a block number N must begin the block"),
    ("frame with motion", "G1 TRANS X1\n", NcSemanticError, 1, 4, "TRANS must be programmed in a block without motion"),
    ("g4 without time", "G4\n", NcSemanticError, 1, 1, "G4 needs either F (seconds) or S (spindle revolutions)"),
    ("huge value", "R1=99999*99999\nG1 X=R1 F100\n", NcSemanticError, 2, 4, "out of range"),
    # a REAL overflows: 1e9^34 = 1e306 is still one, 1e310 no more (DIV once gave a traceback)
    ("DIV overflow", "R1=1000000000\nR2=" + "*".join(["R1"] * 34) + " DIV 0.0001\n", NcSemanticError,
     2, 106, "result of 1e+306 DIV 0.0001 is out of the range of a REAL"),
    ("product overflow", "R1=1000000000\nR2=" + "*".join(["R1"] * 35) + "\n", NcSemanticError,
     2, 105, "result of 1e+306 * 1000000000 is out of the range of a REAL"),
    ("system variable", "R1=$AA_IM[X]\n", NcUnsupportedError, 1, 4,
     "system variable $AA_IM is not simulated: give its value in the machine file"),
    ("polar and x", "G1 X1 AP=45 RP=10 F100\n", NcSemanticError, 1, 4, "X together with polar coordinates"),
    ("negative rp", "G1 AP=45 RP=-1 F100\n", NcSemanticError, 1, 10, "RP= must not be negative"),
    ("jump into for", "G1 F100\nGOTOF IN\nFOR R1=1 TO 2\nIN: X1\nENDFOR\n", NcSemanticError, 5, 1,
     "ENDFOR reached without its FOR"),
    ("duplicate proc", "A\nM30\nPROC A\nM17\nPROC A\nRET\n", NcSemanticError, 5, 1,
     "PROC A defined twice (first in bad.mpf line 3)"),
    ("spline", "G1 F100\nBSPLINE X1 Y2\n", NcUnsupportedError, 2, 1, "BSPLINE (B spline) is not simulated"),
    ("turn without centre", "G1 F100\nG2 X1 CR=5 TURN=1\n", NcSemanticError, 2, 12, "TURN= needs the centre"),
    ("cr with centre", "G1 F100\nG2 X1 I1 CR=5\n", NcSemanticError, 2, 10, "CR= together with I J K"),
    ("turn negative", "G1 F100\nG2 I5 TURN=-1\n", NcSemanticError, 2, 7, "TURN= must be a whole number"),
    ("array index", "DEF REAL _A[3]\n_A[3]=1\n", NcSemanticError, 2, 1, "index 3 of _A is outside 0..2"),
    ("array dims", "DEF REAL _A[3,2]\nR1=_A[1]\n", NcSemanticError, 2, 4, "array _A has 2 dimensions, got 1 indices"),
    ("array bare", "DEF REAL _A[3]\nR1=_A+1\n", NcSemanticError, 2, 4, "array _A needs an index"),
    ("array too many values", "DEF REAL _A[2]=(1,2,3)\n", NcSemanticError, 1, 17, "3 values do not fit _A"),
    ("frame type", "DEF FRAME _F\n", NcUnsupportedError, 1, 1, "variables of type FRAME are not simulated"),
    ("cycle alarm", "G1 F100\nSETAL(61101)\n", NcSemanticError, 2, 1,
     "cycle alarm 61101 set by BAD (SETAL): the control stops the program here"),
    ("repeat no label", "G1 F100\nREPEAT NOPE P=2\n", NcSemanticError, 2, 8, "REPEAT: label NOPE not found"),
    ("repeat bad count", "AA: G1 F100\nREPEAT AA P=0\n", NcSemanticError, 2, 13, "P (repetitions) must be at least 1"),
    ("repeat count word", "AA: G1 F100\nREPEAT AA Q=2\n", NcSyntaxError, 2, 11, "Q= after REPEAT: the count is P="),
    ("case no label", "R1=2\nBB:\nCASE R1 OF 1 GOTOF AA 2 GOTOF BB\n", NcSemanticError, 3, 31,
     "jump destination BB not found (GOTOF searches forward)"),
    ("gud in program", "DEF NCK REAL _G\n", NcSemanticError, 1, 1, "DEF NCK defines a global user variable"),
    ("var of an expression", "SUB(1+2)\nM30\nPROC SUB(VAR REAL _A)\nRET\n", NcUnsupportedError, 1, 6,
     "VAR parameter _A of SUB needs a variable"),
    ("long word", "G1 F100\n" + "A" * 300 + "\n", NcSemanticError, 2, 1, "not found"),
    ("string into real", "DEF REAL _A\n_A=\"x\"\n", NcSemanticError, 2, 1, "_A is REAL"),
    ("call and return", "G1 F100\nSUB M17\nPROC SUB\nRET\n", NcSemanticError, 2, 1,
     "subprogram call SUB together with the end of the program or a return"),
]


@pytest.mark.parametrize("program, cls, line, col, fragment",
                         [c[1:] for c in CASES], ids=[c[0] for c in CASES])
def test_error_is_typed_and_located(program, cls, line, col, fragment):
    with pytest.raises(NcError) as info:
        interpret_text(program, "bad.mpf", block_budget=101)
    err = info.value
    assert type(err) is cls
    assert (err.file, err.line, err.column) == ("bad.mpf", line, col)
    assert fragment in err.message
    assert err.render() == f"bad.mpf:{line}:{col}: {err.message}"


@pytest.mark.parametrize("fast", [True, False])
def test_errors_in_plain_runs_are_located_the_same_way(fast):
    prog = "G1 F100\n" + "".join(f"N{i} X{i}\n" for i in range(1, 30)) + "G2 X40 Y1\n" + "X41\n" * 20
    with pytest.raises(NcSemanticError) as info:
        interpret_text(prog, "run.mpf", fast=fast)
    assert (info.value.line, info.value.column) == (31, 1)
    prog = "G0 X1\n" + "".join(f"N{i} G1 X{i}\n" for i in range(1, 30))
    with pytest.raises(NcSemanticError, match="run.mpf:2:4: G1 without a feed"):
        interpret_text(prog, "run.mpf", fast=fast)


@pytest.mark.parametrize("fast", [True, False])
def test_budget_inside_a_plain_run_names_the_loop(fast):
    # 42 lines; passes 2 and 3 restart at line 2 (block 43 and 84): block 101 is line 19, in the
    # third pass, after the GOTOB of line 42 was taken twice
    prog = "G1 F100\nTOP:\n" + "".join(f"X{i}\n" for i in range(1, 40)) + "IF R1==0 GOTOB TOP\n"
    with pytest.raises(NcSemanticError, match=r"run.mpf:42:10: block budget of 100 blocks exceeded: "
                                              r"endless loop\? this jump back was taken 2 times"):
        interpret_text(prog, "run.mpf", block_budget=100, fast=fast)


def test_a_word_too_long_for_a_file_name_is_an_unknown_word(tmp_path):
    """A 300-character word is looked up as a subprogram file; the file system refuses such a
    name (ENAMETOOLONG), which was a traceback."""
    word = "POCKET" + "Q" * 300
    with pytest.raises(NcSemanticError) as info:
        interpret_text(f"G1 X1 F100\n{word}\nM30\n", "long.mpf", search_dir=tmp_path)
    assert (info.value.line, info.value.column) == (2, 1)
    assert info.value.message.startswith(f"subprogram {shown(word)} not found")
