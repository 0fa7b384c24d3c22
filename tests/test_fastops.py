"""Compiled blocks (``ncsim.nc.fastops``) against the reference interpreter (``fast=False``).

The property test draws loop programs (label loops, WHILE, FOR, REPEAT/UNTIL, IF chains, R and
variable arithmetic with random expressions, G0/G1 with computed words, short plain runs,
subprogram calls) and requires both ways to give the same path, warnings and block count, or
the same located error: the reference is the node-by-node evaluator, which is also what the
compiled code falls back to. Endless loops: a loop that comes back to the same state is stopped
at its jump; one that does not is stopped by the block budget, naming the jump taken most.
"""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from ncsim.errors import NcError, NcSemanticError
from ncsim.nc.context import ROWS_PER_FLUSH
from ncsim.nc.interpret import Interpreter, InterpretOptions, interpret_file, interpret_text
from ncsim.nc.parse import parse_text

COLUMNS = ("kind", "start_mm", "end_mm", "center_mm", "normal", "radius_mm", "sweep_rad",
           "helix_mm", "length_mm", "line", "file_index", "feed_mm_s", "rapid", "exact_stop",
           "stop_window", "cp_mode", "accel_mode", "stop_before", "dwell_before_s")


def outcome(text: str, fast: bool, **kw):
    try:
        r = interpret_text(text, "loop.mpf", fast=fast, **kw)
    except NcError as exc:
        return ("error", type(exc).__name__, exc.render())
    return ("ok", {c: np.asarray(getattr(r.path, c)) for c in COLUMNS}, r.warnings,
            r.blocks_executed, r.approximations)


def same(a, b) -> bool:
    if a[0] != b[0]:
        return False
    if a[0] == "error":
        return a == b
    cols_a, cols_b = a[1], b[1]
    return (all(np.array_equal(cols_a[c], cols_b[c], equal_nan=True) for c in COLUMNS)
            and a[2:] == b[2:])


# ---- random loop programs -----------------------------------------------------------------------

LEAVES = st.one_of(
    st.sampled_from(["R1", "R2", "R3", "R4", "_A", "_B", "_I", "0", "1", "2.5", "-3", "90",
                     "1000000", "0.001", "100000000", "0.0000000001", "0.00000000000001"]),
    st.integers(-50, 50).map(str))
UNARY = ["-", "NOT ", "ABS", "SIN", "COS", "SQRT", "TRUNC", "ROUND", "POT", "EXP", "LN", "ACOS"]
BINARY = ["+", "-", "*", "/", " DIV ", " MOD ", "<", "==", "<>", ">=", " AND ", " OR ", " XOR ",
          " B_AND "]


def expressions(depth: int = 3):
    if depth == 0:
        return LEAVES

    sub = expressions(depth - 1)

    @st.composite
    def node(draw):
        kind = draw(st.integers(0, 5))
        if kind == 0:
            return draw(LEAVES)
        if kind == 1:
            op = draw(st.sampled_from(UNARY))
            a = draw(sub)
            return f"{op}({a})" if op not in ("-", "NOT ") else f"{op}({a})"
        if kind == 2:
            return f"ATAN2({draw(sub)},{draw(sub)})" if draw(st.booleans()) else \
                f"MINVAL({draw(sub)},{draw(sub)})"
        return f"({draw(sub)}{draw(st.sampled_from(BINARY))}{draw(sub)})"
    return node()


EXPR = expressions()


@st.composite
def loop_bodies(draw, depth: int = 0):
    lines = []
    for _ in range(draw(st.integers(1, 5))):
        kind = draw(st.integers(0, 9))
        if kind <= 2:
            target = draw(st.sampled_from(["R1", "R2", "R3", "R4", "_A", "_B", "_I"]))
            lines.append(f"{target}={draw(EXPR)}")
            if draw(st.booleans()):
                lines[-1] += f" R{draw(st.integers(1, 4))}={draw(EXPR)}"
        elif kind <= 4:
            g = draw(st.sampled_from(["G0", "G1", ""]))
            words = [f"{a}={draw(EXPR)}" for a in "XYZ" if draw(st.booleans())]
            if draw(st.integers(0, 3)) == 0:
                words.append(f"F={draw(EXPR)}")
            lines.append(" ".join([g, *words]).strip() or "G1")
        elif kind == 5:
            lines.append(f"G1 X{draw(st.integers(-9, 9))}.5 Y{draw(st.integers(-9, 9))}")
        elif kind == 6:
            lines.append(f"IF {draw(EXPR)} GOTOF SKIP{depth} IF {draw(EXPR)} GOTOF SKIP{depth}")
            lines.append(f"G1 Z={draw(EXPR)}")
            lines.append(f"SKIP{depth}:")
        elif kind == 7 and depth < 1:
            inner = draw(loop_bodies(depth + 1))
            lines += ["R5=0", "WHILE R5<3", "R5=R5+1", *inner, "ENDWHILE"]
        elif kind == 8 and depth < 1:
            inner = draw(loop_bodies(depth + 1))
            lines += ["FOR _J=1 TO 3", *inner, "ENDFOR"]
        else:
            lines.append(f"SUB({draw(EXPR)})")
    return lines


@st.composite
def loop_programs(draw):
    body = draw(loop_bodies())
    n = draw(st.integers(3, 6))
    style = draw(st.sampled_from(["label", "repeat", "loop"]))
    head = ["DEF REAL _A=1.5, _B", "DEF INT _I, _J", "G17 G90 G64 F1000", "R1=2 R2=-1 R3=7 R4=0",
            "R9=0"]
    if style == "label":
        loop = ["TOP:", *body, "R9=R9+1", f"IF R9<{n} GOTOB TOP"]
    elif style == "repeat":
        loop = ["REPEAT", *body, "R9=R9+1", f"UNTIL R9>={n}"]
    else:
        loop = ["LOOP", *body, "R9=R9+1", f"IF R9>={n} GOTOF OUT", "ENDLOOP", "OUT:"]
    tail = ["M30", "PROC SUB(REAL _P)", "G1 X=_P*0.001 Y=R9", "RET"]
    return "\n".join(head + loop + tail) + "\n"


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(loop_programs())
def test_compiled_blocks_do_what_the_reference_does(text):
    assert same(outcome(text, True, block_budget=20_000), outcome(text, False, block_budget=20_000))


# ---- the cases the property test might draw rarely ------------------------------------------

LOOP = "R1=0\nG1 F100\nTOP: R1=R1+1\n{body}\nIF R1<6 GOTOB TOP\nM30\n"


@pytest.mark.parametrize("body, fragment", [
    ("R2=7/(R1-4)", "division by zero (/)"),                           # at the 4th pass
    ("R2=1000000*1000000 R3=R2*R2*R2*R2*R2*R2*R2*R2*R2*R2\nR4=1/(R3*R3*R3)", "is out of the range of a REAL"),
    ("R2=SQRT(3-R1)", "SQRT of a negative number"),
    ("X=R1*1000000000", "out of range"),
    ("G1 X=R1 F=4-R1", "feed F must be positive"),
    ("G1 X=R1 F=(4-R1)*0.0004", "below the smallest the 840D accepts"),  # 0.0008 at the 2nd pass
    ("DEF REAL _Q\n_Q=R1", "undefined variable"),                         # DEF reached later
    ("R2=ACOS(R1/4)", "ACOS argument outside [-1, 1]"),
    ("R2=R1 DIV (R1-3)", "division by zero (DIV)"),
])
def test_errors_in_compiled_blocks_are_the_reference_errors(body, fragment):
    text = LOOP.format(body=body) if "DEF" not in body else \
        "R1=0\nG1 F100\nTOP: R1=R1+1\nIF R1>3 GOTOF LATE\n_Q=R1\nLATE: DEF REAL _Q\nIF R1<6 GOTOB TOP\n"
    fast, ref = outcome(text, True), outcome(text, False)
    assert fast[0] == "error" and fragment in fast[2] and fast == ref


def test_loops_run_compiled_code():
    text = LOOP.format(body="R2=R1*2 G1 X=R2 Y=SIN(R1)")
    interp = Interpreter(None, InterpretOptions())
    interp.run(parse_text(text, "loop.mpf"))
    compiled = [op for op in interp.main_unit.ops
                if getattr(getattr(op, "__code__", None), "co_filename", "") == "<ncsim block>"]
    assert len(compiled) == 3                 # the R1 step, the assignment + move, the jump


def test_return_from_the_main_program_inside_a_loop():
    text = "PROC MAIN\nR1=0\nTOP: R1=R1+1\nG1 X=R1 F100\nIF R1==3 GOTOF DONE\nGOTOB TOP\nDONE: RET\n"
    assert same(outcome(text, True), outcome(text, False))
    assert outcome(text, True)[1]["end_mm"][-1].tolist() == [3, 0, 0]


# ---- endless loops ------------------------------------------------------------------------------

@pytest.mark.parametrize("text, line", [
    ("G1 F100\nLOOP\nENDLOOP\n", 3),
    ("G1 F100\nLOOP\nG1 X0\nG1 X1\nENDLOOP\nM30\n", 5),
    ("WHILE 1\nR1=R1*0\nENDWHILE\n", 3),
    ("G1 F100\nTOP: X1\nX2\nGOTOB TOP\n", 4),
    # moving endless loops: the position and R1 grow, no state repeats, nothing decides
    ("G91 G1 F1000\nLOOP\nX1 Y0.5\nENDLOOP\nM30\n", 4),
    ("R1=0\nG1 F100\nLOOP\nR1=R1+1\nX=R1\nENDLOOP\n", 6),
    ("R1=0\nG1 F100\nWHILE 1==1\nR1=R1+1\nX=R1 Y=SIN(R1)\nENDWHILE\n", 6),
])
@pytest.mark.parametrize("fast", [True, False])
def test_a_loop_that_decides_nothing_stops_at_its_second_pass(text, line, fast):
    """Between two passes of its jump back no condition on the program's state is evaluated:
    the same blocks run again forever (the 840D would run it until the operator stops it)."""
    with pytest.raises(NcSemanticError) as info:
        interpret_text(text, "loop.mpf", fast=fast)
    err = info.value
    assert err.line == line and err.message.startswith(
        "endless loop: nothing between two passes of this jump back decides anything")
    assert err.message.endswith("(taken 2 times)")


@pytest.mark.parametrize("fast", [True, False])
def test_a_loop_back_in_the_same_state_stops_at_its_jump(fast):
    text = "G1 F100\nR1=0\nTOP: R1=R1+1\nIF R1>=3 GOTOF RESET\nX=R1\nGOTOB TOP\nRESET: R1=0\nGOTOB TOP\n"
    with pytest.raises(NcSemanticError) as info:
        interpret_text(text, "loop.mpf", fast=fast)
    err = info.value
    assert err.line == 6 and err.message.startswith(
        "endless loop: at this jump back the program returns to the same state")
    taken = int(err.message.split("taken ")[1].split(" ")[0])
    assert taken <= 1024 + 64                    # stopped after about a thousand passes


@pytest.mark.parametrize("text", [
    "R1=0\nG1 F100\nLOOP\nR1=R1+1\nIF R1<0 GOTOF OUT\nX=R1\nENDLOOP\nOUT: M30\n",
    "R1=0\nG1 F100\nLOOP\nR1=R1+1\nIF R1<0\nGOTOF OUT\nENDIF\nX=R1\nENDLOOP\nOUT: M30\n",
])
@pytest.mark.parametrize("fast", [True, False])
def test_loops_that_may_end_are_not_taken_for_endless_ones(text, fast):
    """A loop whose passes test a condition (here one that never holds) is left to the block
    budget: the interpreter cannot know that R1 < 0 never holds. Blocks: 3 before the loop,
    then 4 a pass (the false IF skips its GOTOF and ENDIF); the 3001st block is in pass 750:
    749 jumps back."""
    jump = text.split("\n").index("ENDLOOP") + 1
    with pytest.raises(NcSemanticError, match=rf"loop.mpf:{jump}:1: block budget of 3000 blocks "
                                              r"exceeded: endless loop\? this jump back was taken "
                                              r"749 times"):
        interpret_text(text, "loop.mpf", block_budget=3000, fast=fast)


def test_a_passing_condition_of_a_subprogram_is_no_proof(tmp_path):
    """Between two takings of the GOTOB in SUB nothing decides, but they are in two calls of
    SUB (returned to different places of MAIN): the program ends, it is no endless loop."""
    text = ("G1 F100\nSUB\nSUB\nM30\nPROC SUB\nGOTOF MB\nMA: X=IC(1)\nRET\nMB: GOTOB MA\n")
    result = interpret_text(text, "main.mpf")
    assert result.path.n == 2


# ---- FOR loops: bounded, so their passes are not charged to the automatic budget -------------

@pytest.fixture
def small_budget(monkeypatch):
    """An automatic budget of the program's lines + 1,000 blocks (2,000,000 by default)."""
    from ncsim.nc import context
    monkeypatch.setattr(context, "DEFAULT_LOOP_BUDGET", 1000)


@pytest.mark.parametrize("fast", [True, False])
def test_a_for_loop_longer_than_the_budget_runs(small_budget, fast):
    """1,900 passes of 2 blocks against a budget of 1,005 (a FOR loop of 1.9 million passes
    against the default one): each pass raises the counter towards the end fixed at the FOR,
    so the loop is bounded and its passes are given back."""
    text = "G1 F100\nFOR R1=1 TO 1900\nX=R1\nENDFOR\nM30\n"
    result = interpret_text(text, "for.mpf", fast=fast)
    assert result.path.n == 1900 and result.blocks_executed == 2 + 2 * 1900 + 1


@pytest.mark.parametrize("fast", [True, False])
def test_nested_for_loops_longer_than_the_budget_run(small_budget, fast):
    """30 x 40 passes (2,463 blocks): the inner passes are given back once, not again as part
    of the outer pass that holds them."""
    text = "G1 F100\nFOR R1=1 TO 30\nFOR R2=1 TO 40\nX=R2 Y=R1\nENDFOR\nENDFOR\nM30\n"
    result = interpret_text(text, "for.mpf", fast=fast)
    assert result.path.n == 30 * 40
    assert result.blocks_executed == 2 + 30 * (1 + 40 * 2 + 1) + 1


@pytest.mark.parametrize("fast", [True, False])
def test_a_for_loop_whose_body_sets_its_counter_back_is_charged(small_budget, fast):
    """The counter never gets past 2: no pass brings the end nearer, every pass is charged
    (the moving position keeps the state from repeating)."""
    text = "G1 F100\nR2=0\nFOR R1=1 TO 10\nR1=1\nR2=R2+1\nX=R2\nENDFOR\nM30\n"
    with pytest.raises(NcSemanticError, match=r"for.mpf:7:1: block budget of 1008 blocks "
                                              r"exceeded: endless loop\? this jump back was taken"):
        interpret_text(text, "for.mpf", fast=fast)


@pytest.mark.parametrize("fast", [True, False])
def test_an_endless_loop_inside_a_for_loop_is_stopped(small_budget, fast):
    """The FOR's own passes are given back; the WHILE inside never lets one end."""
    text = ("G1 F100\nR2=0\nFOR R1=1 TO 500\nX=R1\nENDFOR\nFOR R1=1 TO 5\nWHILE R1>0\n"
            "R2=R2+1\nY=R2\nENDWHILE\nENDFOR\nM30\n")
    with pytest.raises(NcSemanticError, match=r"for.mpf:10:1: block budget of 1012 blocks "
                                              r"exceeded: endless loop\? this jump back was taken"):
        interpret_text(text, "for.mpf", fast=fast)


def test_an_explicit_block_budget_counts_every_block():
    """--block-budget N stops after N executed blocks, FOR passes included."""
    text = "G1 F100\nFOR R1=1 TO 1900\nX=R1\nENDFOR\nM30\n"
    with pytest.raises(NcSemanticError, match=r"for.mpf:4:1: block budget of 1000 blocks exceeded"):
        interpret_text(text, "for.mpf", block_budget=1000)


def test_rows_become_columns_while_a_loop_runs(monkeypatch):
    """Memory stays bounded: the block path never holds more than ROWS_PER_FLUSH Python rows."""
    from ncsim.nc import context
    seen = []
    real = context.PathOutput.append

    def append(self, row):
        real(self, row)
        seen.append(len(self.rows))
    monkeypatch.setattr(context.PathOutput, "append", append)
    text = "R1=0\nG1 F100\nLOOP\nR1=R1+1\nIF R1<0 GOTOF OUT\nX=R1\nENDLOOP\nOUT: M30\n"
    with pytest.raises(NcSemanticError, match="block budget"):
        interpret_text(text, "loop.mpf", block_budget=30_000)
    assert len(seen) > ROWS_PER_FLUSH and max(seen) < ROWS_PER_FLUSH


@pytest.mark.parametrize("name, line", [("H1a_loop_empty.mpf", 3), ("H1b_loop_motion.mpf", 5)])
def test_fuzz_reproducers_of_endless_loops(shared, name, line):
    path = shared / "data" / "fuzz-repro" / name
    with pytest.raises(NcSemanticError) as info:
        interpret_file(path)
    assert (info.value.file, info.value.line) == (str(path), line)
    assert "endless loop" in info.value.message
