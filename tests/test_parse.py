"""ncsim.nc.parse: whole programs, files and encodings; the Program/PlainRun structure."""
from __future__ import annotations

import numpy as np
import pytest

from ncsim.nc import program as P
from ncsim.errors import NcError, NcSyntaxError
from ncsim.nc.parse import parse_file, parse_text

MIXED = "G17 G90\nN10 G1 X1 F100\nN20 X2\nN30 X3 CR=5\n\nX4\nLBL: X5\n"


def test_plain_lines_become_runs_and_the_rest_blocks():
    prog = parse_text(MIXED, "m.mpf")
    kinds = [type(i).__name__ for i in prog.items]
    assert kinds == ["Block", "PlainRun", "Block", "PlainRun", "Block"]
    run = prog.items[1]
    assert (run.first_line, len(run)) == (2, 2) and run.numbers.tolist() == [10, 20]
    assert prog.n_lines == 7


def test_runs_expand_to_the_blocks_lark_builds():
    assert list(parse_text(MIXED).blocks()) == list(parse_text(MIXED, fast=False).blocks())
    assert all(isinstance(i, P.Block) for i in parse_text(MIXED, fast=False).items)


def test_plain_run_block_and_slice():
    run = parse_text("N5 G2 X1 Y2 I3 J4 K5 F6\nN6 Z7\n").items[0]
    b = run.block(0)
    assert b.number == 5 and [w.address for w in b.items] == ["G", "X", "Y", "I", "J", "K", "F"]
    assert [w.col for w in b.items] == [4, 7, 10, 13, 16, 19, 22]
    tail = run.slice(1)
    assert tail.first_line == 2 and tail.block(0) == P.Block(2, 6, items=(P.Word("Z", P.Num(7.0, 4), 4),))
    assert np.isnan(tail.values[0, 0])


def test_crlf_and_missing_final_newline():
    assert parse_text("G1 X1\r\nX2").n_lines == 2
    assert list(parse_text("G1 X1\r\nX2").blocks()) == list(parse_text("G1 X1\nX2").blocks())


def test_a_lone_cr_ends_a_block_too():
    """Old Mac editors and some DNC links end lines with CR alone: four blocks, not one."""
    cr = parse_text("N10 G1 X10 F1000 ; first cut\rN20 G1 X0 Y50\rN30 G1 Z-5\rM30\r")
    assert cr.n_lines == 4
    assert list(cr.blocks()) == list(parse_text("N10 G1 X10 F1000 ; first cut\nN20 G1 X0 Y50\n"
                                                "N30 G1 Z-5\nM30\n").blocks())
    assert parse_text("G1 X1\r\rX2\r\n").n_lines == 3      # CR CR: an empty line between


def test_a_byte_order_mark_is_not_a_character_of_the_program(tmp_path):
    bom = tmp_path / "bom.mpf"
    bom.write_bytes(b"\xef\xbb\xbfG1 X10 F1000\nM30\n")
    latin = tmp_path / "latin.mpf"     # a BOM before Latin-1 text (no UTF-8 after all)
    latin.write_bytes(b"\xef\xbb\xbfG1 X10 F1000 ; Sp\xe4ne\nM30\n")
    plain = list(parse_text("G1 X10 F1000\nM30\n").blocks())
    assert list(parse_file(bom).blocks()) == plain
    assert list(parse_file(latin).blocks()) == plain
    assert list(parse_text("\ufeffG1 X10 F1000\nM30\n").blocks()) == plain


def test_syntax_error_line_in_a_long_program():
    with pytest.raises(NcSyntaxError, match=r"^p.mpf:5:4: unexpected"):
        parse_text("X1\nX2\nX3\nX4\nX5 )\n", "p.mpf")


def test_files_utf8_latin1_and_missing(tmp_path):
    utf = tmp_path / "u.mpf"
    utf.write_text('MSG("Spülung")\nG1 X1\n', encoding="utf-8")
    latin = tmp_path / "l.mpf"
    latin.write_bytes('MSG("Spülung") ; Späne\nG1 X1\n'.encode("latin-1"))
    for p in (utf, latin):
        prog = parse_file(p)
        assert prog.file == str(p)
        assert list(prog.blocks())[0].items[0].args[0].value == "Spülung"
    with pytest.raises(NcError, match="cannot read program"):
        parse_file(tmp_path / "none.mpf")
