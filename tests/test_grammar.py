"""grammars/sinumerik.lark through ncsim.nc.parse.parse_block: each construct, and located syntax errors."""
from __future__ import annotations

import pytest

from ncsim.nc import program as P
from ncsim.errors import NcSyntaxError
from ncsim.nc.parse import parse_block, upper_code


def items(text):
    return parse_block(text).items


def word(address, value, col, vcol=None):
    return P.Word(address, P.Num(value, col if vcol is None else vcol), col)


def test_block_number_skip_and_comment():
    b = parse_block("/N20 G1 X-1.5 ; feed in", line=7)
    assert (b.line, b.number, b.skip_level, b.label) == (7, 20, 0, None)
    assert b.items == (word("G", 1.0, 6), word("X", -1.5, 9))


def test_skip_level_and_label():
    b = parse_block("/3 N5 LOOP_1: G0 Z5")
    assert (b.skip_level, b.number, b.label) == (3, 5, "LOOP_1")
    assert b.items == (word("G", 0.0, 15), word("Z", 5.0, 18))


def test_empty_comment_and_header_lines_are_empty_blocks():
    for text in ("", "   ", "; only a comment", "N10 ;Start of Program", "%_N_PART_MPF"):
        assert parse_block(text).items == ()
        assert parse_block(text).statement is None


def test_words_without_spaces_and_lower_case():
    assert items("g1x10y.5") == (word("G", 1.0, 1), word("X", 10.0, 3), word("Y", 0.5, 6))


def test_number_forms():
    assert [w.value.value for w in items("X10. Y-.009 Z+3 I0.0 F2069.")] == [10.0, -0.009, 3.0, 0.0, 2069.0]


def test_paren_comment_where_a_word_may_start():
    assert items("G1 X10 (move to the wall) Y5") == (word("G", 1.0, 1), word("X", 10.0, 4), word("Y", 5.0, 27))
    assert items("SOFT (jerk limited)") == (P.Command("SOFT", 1),)


def test_address_with_expression_ac_ic_and_extended_addresses():
    its = items("G2 X=AC(5) Y=IC(-2) CR=-5 TURN=2 ADIS=0.1 ADISPOS=.2")
    x, y, cr, turn, adis, adispos = its[1:]
    assert x == P.Word("X", P.Func("AC", (P.Num(5.0, 9),), 6), 4)
    assert y == P.Word("Y", P.Func("IC", (P.Unary("-", P.Num(2.0, 18), 17),), 14), 12)
    assert cr.address == "CR" and cr.value == P.Unary("-", P.Num(5.0, 25), 24)
    assert [w.address for w in (turn, adis, adispos)] == ["TURN", "ADIS", "ADISPOS"]


def test_cip_intermediate_point_and_r_parameters():
    its = items("CIP X10 Y10 I1=5 J1=R2 K1=0")
    assert its[0] == P.Command("CIP", 1)
    assert its[3] == P.Word("I1", P.Num(5.0, 16), 13)
    assert its[4] == P.Word("J1", P.RParam(2, 21), 18)
    assert items("R1=5 R12=R1*2") == (P.Assign(P.RParam(1, 1), P.Num(5.0, 4), 1),
                                      P.Assign(P.RParam(12, 6), P.BinOp("*", P.RParam(1, 10), P.Num(2.0, 13), 12), 6))


def test_user_variable_assignment_versus_address():
    its = items("_X_HOME=-365. X=_X_HOME")
    assert its[0] == P.Assign(P.Var("_X_HOME", 1), P.Unary("-", P.Num(365.0, 10), 9), 1)
    assert its[1] == P.Word("X", P.Var("_X_HOME", 17), 15)


def test_operator_priority_840d():
    # * before +, comparison binds weakest, AND between comparisons needs parentheses
    (a,) = items("R1=1+2*3")
    assert a.value == P.BinOp("+", P.Num(1.0, 4), P.BinOp("*", P.Num(2.0, 6), P.Num(3.0, 8), 7), 5)
    s = parse_block("IF (R1>0) AND (R2<=3) GOTOF END_1").statement
    assert isinstance(s, P.IfGoto) and s.cond.op == "AND" and s.goto.target.label == "END_1"


def test_functions_and_strings():
    (a,) = items("R1=SQRT(POT(3)+POT(4))")
    assert a.value.name == "SQRT" and a.value.args[0].op == "+"
    (msg,) = items('MSG("Mill finish; ok" << R1)')
    assert msg == P.Call("MSG", (P.BinOp("<<", P.Str("Mill finish; ok", 5), P.RParam(1, 26), 23),), 1)


def test_cycle_call_keeps_empty_arguments():
    (c,) = items('CYCLE800(1,"TABLE",,57)')
    assert c.name == "CYCLE800" and c.args == (P.Num(1.0, 10), P.Str("TABLE", 12), None, P.Num(57.0, 21))
    assert items("CYCLE832()") == (P.Call("CYCLE832", (), 1),)


def test_control_statements():
    assert parse_block("IF R1==1").statement == P.If(P.BinOp("==", P.RParam(1, 4), P.Num(1.0, 8), 6), 1)
    assert parse_block("ELSE").statement == P.Keyword("ELSE", 1)
    assert isinstance(parse_block("WHILE R1<10").statement, P.While)
    f = parse_block("FOR R2=1 TO R3").statement
    assert f == P.For(P.RParam(2, 5), P.Num(1.0, 8), P.RParam(3, 13), 1)
    assert isinstance(parse_block("UNTIL R1>5").statement, P.Until)
    for kw in ("ENDIF", "ENDWHILE", "ENDFOR", "REPEAT", "LOOP", "ENDLOOP"):
        assert parse_block(kw).statement == P.Keyword(kw, 1)
    g = parse_block("N30 GOTOB N10").statement
    assert g == P.Goto("GOTOB", P.Target(None, 10, 11), 5)


def test_def_and_proc():
    d = parse_block("DEF REAL _A, _B=2").statement
    assert d == P.Def("REAL", (P.DefVar("_A", (), None, 10), P.DefVar("_B", (), P.Num(2.0, 17), 14)), 1)
    p = parse_block("PROC POCKET(REAL DEPTH, VAR INT N) SAVE").statement
    assert p.name == "POCKET" and p.attributes == ("SAVE",)
    assert [(q.type_name, q.name, q.by_reference) for q in p.params] == [("REAL", "DEPTH", False), ("INT", "N", True)]


def test_subprogram_calls():
    assert items("L10 P3") == (word("L", 10.0, 1), word("P", 3.0, 5))
    assert items("CONTOUR P2") == (P.Command("CONTOUR", 1), word("P", 2.0, 9))


def test_frames_words():
    assert items("AROT Z-90.") == (P.Command("AROT", 1), word("Z", -90.0, 6))
    assert items("TRANS X0 Y0 Z0")[0] == P.Command("TRANS", 1)


def test_upper_code_keeps_strings_and_comments():
    assert upper_code('msg("Hallo ß") ; grüße') == 'MSG("Hallo ß") ; grüße'
    assert upper_code("g1 x1") == "G1 X1"


@pytest.mark.parametrize("text, col, fragment", [
    ("G1 X=(1+2", 10, "end of block"),
    ("X1.5.5", 5, "'.5'"),
    ("G1 @ X1", 4, "'@'"),
    ("IF R1==1 OR R2==2", 15, "'=='"),
    ("X 10", 3, "10"),
    ("DEF REAL", 9, "end of block"),
    ("X" + "9" * 400, 2, "too large"),
])
def test_syntax_errors_are_located(text, col, fragment):
    with pytest.raises(NcSyntaxError) as info:
        parse_block(text, line=42, file="part.mpf")
    err = info.value
    assert (err.file, err.line, err.column) == ("part.mpf", 42, col)
    assert fragment in err.message
    assert err.render().startswith(f"part.mpf:42:{col}: ")
