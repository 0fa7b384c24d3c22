"""Parse 840D program text into a :class:`~ncsim.nc.program.Program`.

The language is defined by ``grammars/sinumerik.lark`` (one block per line), run with Lark's
LALR parser and an inline transformer that builds :mod:`ncsim.nc.program` nodes. Before Lark,
ASCII letters outside strings and ``;`` comments are upper-cased: the 840D does not
distinguish case there.

Before Lark, a blank between a name and its ``(`` is moved inside the parenthesis for the PROC
statement (``PROC CYCLE82 (REAL RTP, ...)``, as Siemens' own cycles write it) and for the calls
real programs write that way (``MSG ("...")``, ``SETAL (61101)``, ``CYCLE82 (...)``): column
numbers stay those of the text, and elsewhere ``NAME (text)`` keeps meaning a word and a comment.

``parse_text(text, fast=True)`` first lets :mod:`ncsim.nc.fastparse` read the plain lines
(``N.. G0..G3 X Y Z I J K F``) as columns and gives only the other lines to Lark;
``fast=False`` gives every line to Lark. Both yield the same blocks (property-tested).

Every syntax error is one :class:`~ncsim.errors.NcSyntaxError` at ``FILE:LINE:COL``.
"""
from __future__ import annotations

import codecs
import re
from functools import lru_cache
from importlib import resources
from dataclasses import replace
from pathlib import Path as FsPath

from lark import Lark, Token, Transformer
from lark.exceptions import (LarkError, UnexpectedCharacters, UnexpectedEOF, UnexpectedInput,
                             UnexpectedToken)

from ncsim.config import read_bytes
from ncsim.nc import program as P
from ncsim.errors import NcError, NcSyntaxError, shown
from ncsim.nc.isoparse import parse_dialect_text, switches_dialect
from ncsim.nc.outline import operation_comments

# Words whose name is an 840D address (``X=..`` is a word, not a variable assignment).
ADDRESSES = frozenset({
    "X", "Y", "Z", "A", "B", "C", "U", "V", "W", "I", "J", "K", "F", "S", "T", "D", "M", "H",
    "L", "P", "N", "G", "E", "Q", "CR", "AR", "TURN", "ADIS", "ADISPOS", "RPL", "AP", "RP", "SF",
    "CTOL", "OTOL", "SPOS", "SPOSA", "LIMS",
})
# Addresses that take an index: ``AX[_Z]=`` (indirect axis), ``IP[_Z]=`` (its interpolation
# parameter), ``SPOS[2]=``, ``LIMS[1]=``, ``FGREF[C]=`` ...; any other ``NAME[i]=`` is an array element.
INDEXED_ADDRESSES = frozenset({"AX", "IP", "SPOS", "SPOSA", "LIMS", "S", "M", "T", "H", "FGREF"})

# "NAME (" that is a call, not a word and a comment: the PROC statement and the calls that real
# programs write with a blank (Siemens' cycle sources, CYCLE_KONUS-like shop cycles).
_CALL_GAP = re.compile(r"(?<![A-Z0-9_$])(PROC[ \t]+[A-Z_][A-Z0-9_]*|MSG|SETAL|SETMS|"
                       r"CYCLE[0-9]+|POCKET[0-9]|SLOT[0-9]|HOLES[0-9]|LONGHOLE)([ \t]+)\(")

_UPPER = {c: c - 32 for c in range(ord("a"), ord("z") + 1)}


def upper_code(line: str) -> str:
    """Upper-case ASCII letters outside ``"strings"`` and after a ``;`` comment start."""
    if '"' not in line and ";" not in line:
        return line.translate(_UPPER)
    out = []
    in_string = False
    for i, ch in enumerate(line):
        if ch == '"':
            in_string = not in_string
        elif ch == ";" and not in_string:
            out.append(line[i:])
            break
        out.append(ch if in_string else ch.translate(_UPPER))
    return "".join(out)


def join_call_gaps(code: str) -> str:
    """``MSG ("x")`` -> ``MSG( "x")``: the blank moves inside the parenthesis (same length, so
    every column stays), for the names of :data:`_CALL_GAP`, outside strings and comments."""
    if "(" not in code:
        return code
    out = code
    for m in _CALL_GAP.finditer(code):
        before = code[:m.start()]
        if before.count('"') % 2 or _in_comment(before):
            continue
        gap = m.group(2)
        out = out[:m.end(1)] + "(" + gap + out[m.end():]
    return out


def _in_comment(before: str) -> bool:
    """Whether a ``;`` outside strings precedes the end of ``before``."""
    in_string = False
    for ch in before:
        if ch == '"':
            in_string = not in_string
        elif ch == ";" and not in_string:
            return True
    return False


class _NumberTooLarge(Exception):
    def __init__(self, text: str, col: int):
        super().__init__(text)
        self.text = text
        self.col = col


def _number(text: str, col: int) -> float:
    """The value of a number token (at column ``col``); beyond the float range is an error."""
    value = float(text)
    if value == float("inf"):
        raise _NumberTooLarge(text, col)
    return value


class _ToProgram(Transformer):
    """Inline LALR transformer: grammar rules -> ncsim.nc.program nodes (columns from tokens)."""

    # ---- expressions ----
    def number(self, children):
        (tok,) = children
        return P.Num(_number(tok, tok.column), tok.column)

    def string(self, children):
        (tok,) = children
        return P.Str(tok[1:-1], tok.column)

    def variable(self, children):
        (tok,) = children
        return P.Var(str(tok), tok.column)

    def rparam(self, children):
        (tok,) = children
        return P.RParam(int(tok[1:]), tok.column)

    def sysvar(self, children):
        tok = children[0]
        index = children[1] if len(children) > 1 else ()
        return P.SysVar(str(tok), index, tok.column)

    def element(self, children):
        tok, index = children
        return P.Elem(str(tok), index, tok.column)

    def init_list(self, children):
        return P.InitList(tuple(children), _col(children[0]))

    def index(self, children):
        (args,) = children
        return args

    def func(self, children):
        tok, args = children
        return P.Func(str(tok[:-1]), args, tok.column)

    def args(self, children):
        if children == [None]:
            return ()
        return tuple(children)

    def unary(self, children):
        op, operand = children
        return P.Unary(str(op), operand, op.column)

    def binop(self, children):
        left, op, right = children
        return P.BinOp(str(op), left, right, op.column)

    # ---- items ----
    def word_num(self, children):
        (tok,) = children
        return P.Word(tok[0], P.Num(_number(tok[1:], tok.column + 1), tok.column), tok.column)

    def word_indexed(self, children):
        tok, value = children
        if tok[0] == "R":
            return P.Assign(P.RParam(int(tok[1:]), tok.column), value, tok.column)
        return P.Word(str(tok), value, tok.column)

    def word_assign(self, children):
        tok, value = children
        name = str(tok)
        if name in ADDRESSES:
            return P.Word(name, value, tok.column)
        return P.Assign(P.Var(name, tok.column), value, tok.column)

    def word_index_assign(self, children):
        tok, index, value = children
        name = str(tok)
        if name in INDEXED_ADDRESSES:
            return P.IndexedWord(name, index, value, tok.column)
        return P.Assign(P.Elem(name, index, tok.column), value, tok.column)

    def sysvar_assign(self, children):
        tok = children[0]
        index = children[1] if len(children) == 3 else ()
        return P.Assign(P.SysVar(str(tok), index, tok.column), children[-1], tok.column)

    def command(self, children):
        (tok,) = children
        return P.Command(str(tok), tok.column)

    def call(self, children):
        tok, args = children
        return P.Call(str(tok[:-1]), args, tok.column)

    def paren_comment(self, children):
        return None

    def items(self, children):
        return tuple(c for c in children if c is not None)

    # ---- control ----
    def target(self, children):
        (tok,) = children
        if tok.type == "BLOCKNUM":
            return P.Target(None, int(tok[1:]), tok.column)
        return P.Target(str(tok), None, tok.column)

    def goto_kind(self, children):
        return children[0]

    def goto(self, children):
        kind, target = children
        return P.Goto(str(kind), target, kind.column)

    def if_goto(self, children):
        kw, cond, kind, target = children
        return P.IfGoto(cond, P.Goto(str(kind), target, kind.column), kw.column)

    def if_gotos(self, children):
        if len(children) == 1:
            return children[0]
        return P.IfGotos(tuple(children), children[0].col)

    def repeat_count(self, children):
        name, value = children
        if name != "P":
            raise _BadWord(f"{name}= after REPEAT: the count is P=", name.column)
        return value

    def repeat_section(self, children):
        kw = children[0]
        targets = [c for c in children[1:] if isinstance(c, P.Target)]
        count = next((c for c in children[1:] if c is not None and not isinstance(c, P.Target)),
                     None)
        end = targets[1] if len(targets) > 1 else None
        return P.RepeatSection(targets[0], end, count, False, kw.column)

    def repeat_block(self, children):
        kw, target = children[0], children[1]
        count = children[2] if len(children) > 2 else None
        return P.RepeatSection(target, None, count, True, kw.column)

    def case_value(self, children):
        if len(children) == 1 and children[0] is not None and children[0].type == "STRING":
            return str(children[0])[1:-1]
        sign, number = (children if len(children) == 2 else (None, children[-1]))
        value = _number(number, number.column)
        return -value if sign is not None and sign == "-" else value

    def case_item(self, children):
        value, kind, target = children
        return (value, P.Goto(str(kind), target, kind.column))

    def case_default(self, children):
        _kw, kind, target = children
        return P.Goto(str(kind), target, kind.column)

    def case(self, children):
        kw, expr, _of, *rest = children
        cases = tuple(c for c in rest if isinstance(c, tuple))
        default = next((c for c in rest if isinstance(c, P.Goto)), None)
        return P.Case(expr, cases, default, kw.column)

    def if_(self, children):
        kw, cond = children
        return P.If(cond, kw.column)

    def while_(self, children):
        kw, cond = children
        return P.While(cond, kw.column)

    def until(self, children):
        kw, cond = children
        return P.Until(cond, kw.column)

    def for_(self, children):
        kw, name, start, _to, end = children
        var = P.RParam(int(name[1:]), name.column) if _is_rparam(name) else P.Var(str(name), name.column)
        return P.For(var, start, end, kw.column)

    def _keyword(self, children):
        (kw,) = children
        return P.Keyword(str(kw), kw.column)

    else_ = endif = endwhile = endfor = repeat = loop = endloop = _keyword

    def dims(self, children):
        return tuple(int(float(c)) for c in children)

    def scope(self, children):
        return str(children[0])

    def def_var(self, children):
        name = children[0]
        dims, init = (), None
        for c in children[1:]:
            if isinstance(c, tuple):
                dims = c
            else:
                init = c
        return P.DefVar(str(name), dims, init, name.column)

    def def_(self, children):
        kw, rest = children[0], children[1:]
        scope = next((c for c in rest if isinstance(c, str) and not isinstance(c, Token)), None)
        type_tok = next(c for c in rest if isinstance(c, Token) and c.type == "NAME")
        variables = tuple(c for c in rest if isinstance(c, P.DefVar))
        return P.Def(str(type_tok), variables, kw.column, scope)

    def param(self, children):
        by_ref = isinstance(children[0], Token) and children[0].type == "VAR"
        rest = children[1:] if by_ref else children
        type_tok, name_tok = [c for c in rest if isinstance(c, Token)]
        after_name = rest[rest.index(name_tok) + 1:]
        dims = after_name[0] if after_name else ()
        return P.Param(str(type_tok), str(name_tok), by_ref, dims, name_tok.column)

    def param_type(self, children):
        return None

    def proc(self, children):
        kw, name, *attrs = children
        return P.Proc(str(name), (), tuple(str(a) for a in attrs), kw.column)

    def proc_params(self, children):
        kw, name, *rest = children
        params = tuple(c for c in rest if isinstance(c, P.Param))
        attrs = tuple(str(c) for c in rest if isinstance(c, Token))
        return P.Proc(str(name[:-1]), params, attrs, kw.column)

    def extern(self, children):
        kw, name = children[0], children[1]
        return P.Extern(str(name).rstrip("("), kw.column)

    # ---- line ----
    def line(self, children):
        number = skip = label = None
        items: tuple = ()
        statement = None
        for c in children:
            if isinstance(c, Token):
                if c.type == "BLOCKNUM":
                    number = int(c[1:])
                elif c.type == "SKIP":
                    skip = int(c[1:]) if len(c) > 1 else 0
                elif c.type == "LABEL":
                    label = str(c[:-1])
            elif isinstance(c, tuple):
                items = c
            elif c is not None:
                statement = c
        return (number, skip, label, items, statement)

    def header(self, children):
        return (None, None, None, (), None)

    def start(self, children):
        return children[0]


class _BadWord(Exception):
    def __init__(self, message: str, col: int):
        super().__init__(message)
        self.message = message
        self.col = col


def _col(node) -> int:
    return getattr(node, "col", 0) or getattr(node, "column", 0)


def _is_rparam(tok: str) -> bool:
    return len(tok) > 1 and tok[0] == "R" and tok[1:].isdigit()


@lru_cache(maxsize=1)
def _lark() -> Lark:
    grammar = (resources.files("ncsim.nc.grammars") / "sinumerik.lark").read_text(encoding="utf-8")
    options = dict(parser="lalr", lexer="contextual", transformer=_ToProgram(),
                   maybe_placeholders=True)
    try:  # Lark keeps the LALR tables in a temp file keyed by the grammar's hash: 7x faster start
        return Lark(grammar, cache=True, **options)
    except OSError:  # no writable temp directory: build the tables every time
        return Lark(grammar, cache=False, **options)


_TOKEN_NAMES = {
    "ADDR_NUM": "word", "NAME": "name", "NUMBER": "number", "CALL_OPEN": "call",
    "INDEXED": "indexed address", "BLOCKNUM": "block number", "LABEL": "label",
    "STRING": "string", "COMMENT": "comment", "RPARAM": "R parameter", "SYSVAR": "system variable",
    "$END": "end of block",
}


def _describe(token: Token) -> str:
    if token.type == "$END":
        return "end of block"
    kind = _TOKEN_NAMES.get(token.type)
    return f"{kind} '{shown(str(token))}'" if kind else f"'{shown(str(token))}'"


def _syntax_error(exc: UnexpectedInput, text: str, file: str, line: int) -> NcSyntaxError:
    if isinstance(exc, UnexpectedCharacters):
        ch = text[exc.pos_in_stream] if exc.pos_in_stream < len(text) else ""
        return NcSyntaxError(f"unexpected character {ch!r}", file, line, exc.column)
    if isinstance(exc, UnexpectedToken):
        tok = exc.token
        column = tok.column if tok.type != "$END" else len(text.rstrip()) + 1
        return NcSyntaxError(f"unexpected {_describe(tok)}", file, line, column)
    if isinstance(exc, UnexpectedEOF):
        return NcSyntaxError("unexpected end of block", file, line, len(text.rstrip()) + 1)
    return NcSyntaxError(str(exc).splitlines()[0], file, line, getattr(exc, "column", 0) or 0)


def parse_block(text: str, line: int = 1, file: str = "<string>") -> P.Block:
    """Parse one line with the Lark grammar into a Block (NcSyntaxError on bad input)."""
    code = join_call_gaps(upper_code(text))
    try:
        number, skip, label, items, statement = _lark().parse(code)
    except UnexpectedInput as exc:
        raise _syntax_error(exc, code, file, line) from None
    except _NumberTooLarge as exc:
        raise NcSyntaxError(f"number {exc.text[:20]}... is too large", file, line, exc.col) from None
    except _BadWord as exc:
        raise NcSyntaxError(exc.message, file, line, exc.col) from None
    except LarkError as exc:
        raise NcSyntaxError(f"cannot read block: {exc}", file, line, 1) from None
    return P.Block(line=line, number=number, skip_level=skip, label=label, items=items,
                   statement=statement)


def normalize_newlines(text: str) -> str:
    """CR LF and a lone CR (old Mac editors, some DNC links) -> LF: every one ends a block.
    A leading byte-order mark (Windows editors) is dropped."""
    if text.startswith("\ufeff"):
        text = text[1:]
    return text.replace("\r\n", "\n").replace("\r", "\n") if "\r" in text else text


def parse_text(text: str, file: str = "<string>", *, fast: bool = True,
               macros: dict[str, str] | None = None, dialect: str = "siemens",
               iso_plain: bool = True) -> P.Program:
    """Parse a whole program. ``fast`` reads plain lines with :mod:`ncsim.nc.fastparse`;
    ``macros`` (of a definitions file) and the program's own DEFINEs are expanded first
    (:mod:`ncsim.nc.macros`). ``dialect`` is the language the program starts in (``"iso"``:
    ISO dialect mode, G291); a program that switches with G290/G291 is read by
    :mod:`ncsim.nc.isoparse` (``iso_plain``: its ISO plain lines may be read as columns)."""
    from ncsim.nc.macros import expand_macros
    text, _ = expand_macros(normalize_newlines(text), file, macros, upper_code)
    comments = operation_comments(text)
    if dialect != "siemens" or switches_dialect(text):
        program = parse_dialect_text(text, file, parse_block, fast=fast, dialect=dialect,
                                     iso_plain=iso_plain)
        return replace(program, operation_comments=comments)
    if fast:
        from ncsim.nc.fastparse import scan_program
        return replace(scan_program(text, file, parse_block), operation_comments=comments)
    lines = text.split("\n")
    if lines and lines[-1] == "":
        lines.pop()
    items = tuple(parse_block(t, i + 1, file) for i, t in enumerate(lines))
    return P.Program(file, items, len(lines), comments)


def read_program_text(path: str | FsPath, what: str = "program") -> str:
    """The text of a program file (or of another file in the 840D language, ``what`` it is
    named in messages): UTF-8, or Latin-1 (840D files often are) if not UTF-8. A path that is no
    regular file (a FIFO, a device) is refused before reading (``config.read_bytes``)."""
    data = read_bytes(path, what, error=NcError)
    if data.startswith(codecs.BOM_UTF8):
        data = data[len(codecs.BOM_UTF8):]
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        return data.decode("latin-1")


def parse_file(path: str | FsPath, *, fast: bool = True) -> P.Program:
    return parse_text(read_program_text(path), str(path), fast=fast)
