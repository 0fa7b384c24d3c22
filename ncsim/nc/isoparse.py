"""Reading ISO dialect (Fanuc-style) blocks, and programs that switch between the two languages.

SINUMERIK 840D sl ISO dialects (Function Manual "ISO dialects"; Programming Manual "ISO
Milling", chapter "Fundamental principles": "Switchover modes", "Decimal point programming",
"Comments", "Skip block"; chapter "Macro programs": "Variables", "Arithmetic commands and
functions", "Control commands"):

* ``G291`` selects ISO dialect mode, ``G290`` Siemens mode (G group 47); each is programmed
  alone in its block. The mode is followed here line by line as the program is read (the blocks
  after a ``G291`` are ISO blocks up to the next ``G290``), which is what the control does for
  programs that do not jump across a switch;
* an ISO block is ``[/n] [N..] words`` or one macro statement; a word is an address letter and
  a number (``X-1.5``, ``G01``, ``G54.1``), a variable (``X#24``, ``X-#1``) or a bracketed
  expression (``X[#1+2.]``); round brackets enclose comments, and ``;`` starts one as in
  Siemens mode; ``%`` lines and ``O1234`` / ``:1234`` program numbers head a program;
* macro statements: ``#n = expr`` (``#[expr] = ..`` indirect), ``IF [cond] GOTO n``,
  ``IF [cond] THEN #n = expr``, ``GOTO n``, ``WHILE [cond] DO m`` .. ``END m``;
  expressions with ``+ - * / MOD AND OR XOR``, ``EQ NE GT GE LT LE``, ``[ ]`` for grouping and
  the functions ``SIN COS TAN ASIN ACOS ATAN SQRT ABS ROUND FIX FUP LN EXP POW``
  (``ATAN[a]/[b]`` is the two-argument arc tangent);
* a number keeps whether it had a decimal point (:attr:`IsoWord.point`): without one it is read
  in the input increment under standard notation (MD10884 ``EXTERN_FLOATINGPOINT_PROG`` = 0);
* Siemens code in an ISO block (``SOFT``, ``CYCLE832(..)``, ``R1=5``, ``X=AC(..)``) is an error
  that says to switch with ``G290`` (the ISO reader does not know these words).

Plain lines (``N.. G0..G3 X Y Z I J K F``, :mod:`ncsim.nc.fastparse`) mean the same in both
modes, so an ISO program's plain lines are still read as columns; they become
:class:`~ncsim.nc.program.PlainRun` items marked ``iso``.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, replace

from ncsim.errors import NcSyntaxError
from ncsim.nc import program as P

ISO, SIEMENS = "iso", "siemens"
DIALECTS = (SIEMENS, ISO)
#: a G290/G291 block: the mode switch (group 47), alone in its block
_SWITCH = re.compile(r"^\s*(?:/\d?\s*)?(?:N\d+\s*)?G0*29([01])\s*(?:[;(].*)?$", re.IGNORECASE)
_HAS_291 = re.compile(r"G0*291(?![0-9.])", re.IGNORECASE)
_FUNCTIONS = ("SIN", "COS", "TAN", "ASIN", "ACOS", "ATAN", "SQRT", "SQR", "ABS", "ROUND", "FIX",
              "FUP", "LN", "EXP", "POW")
_COMPARE = ("EQ", "NE", "GT", "GE", "LT", "LE")
_WORD_LETTERS = frozenset("ABCDEFGHIJKLMPQRSTUVWXYZ")


@dataclass(frozen=True, slots=True)
class IsoVar:
    """``#n`` or ``#[expr]``: a macro variable (``index`` is an expression)."""

    index: object
    col: int


@dataclass(frozen=True, slots=True)
class IsoWord:
    """An address and its value (an expression); ``point``: the number had a decimal point (or
    the value is not a literal number)."""

    address: str
    value: object
    col: int
    point: bool = True


@dataclass(frozen=True, slots=True)
class IsoAssign:
    target: IsoVar
    value: object
    col: int


@dataclass(frozen=True, slots=True)
class IsoGoto:
    target: object           # expression: the block number
    col: int


@dataclass(frozen=True, slots=True)
class IsoIf:
    """``IF [cond] GOTO n`` (``then`` an IsoGoto) or ``IF [cond] THEN #n=..`` (an IsoAssign)."""

    cond: object
    then: object
    col: int


@dataclass(frozen=True, slots=True)
class IsoWhile:
    """``WHILE [cond] DO m`` (``cond`` None: ``DO m`` alone, an endless loop)."""

    cond: object
    label: int
    col: int


@dataclass(frozen=True, slots=True)
class IsoEnd:
    label: int
    col: int


@dataclass(frozen=True, slots=True)
class IsoProgramNumber:
    """``O1234`` (or ``:1234``): the start of program 1234."""

    number: int
    col: int


@dataclass(frozen=True, slots=True)
class ModeSwitch:
    """``G290`` (Siemens mode) or ``G291`` (ISO mode), alone in its block."""

    code: int
    col: int


@dataclass(frozen=True, slots=True)
class IsoBlock:
    """One ISO line, shaped like :class:`~ncsim.nc.program.Block` (``items`` are IsoWords,
    ``statement`` a macro statement, a program number or a mode switch)."""

    line: int
    number: int | None = None
    skip_level: int | None = None
    label: str | None = None
    items: tuple = ()
    statement: object = None


class _Error(Exception):
    def __init__(self, message: str, col: int):
        super().__init__(message)
        self.message = message
        self.col = col


def strip_comments(line: str) -> str:
    """The line with ``(comments)`` and a ``;`` comment blanked out (columns kept), upper-cased."""
    out = []
    depth = 0
    for ch in line:
        if ch == ";" and depth == 0:
            break
        if ch == "(":
            depth += 1
        if depth:
            out.append(" ")
            if ch == ")":
                depth -= 1
            continue
        out.append(ch)
    if depth:
        raise _Error("comment '(' not closed on its line", line.index("(") + 1)
    return "".join(out).upper()


class _Reader:
    """Recursive-descent reader of one upper-cased, comment-free ISO line."""

    def __init__(self, text: str) -> None:
        self.text = text
        self.pos = 0

    # ---- characters ----------------------------------------------------------------------------

    def skip(self) -> None:
        text = self.text
        while self.pos < len(text) and text[self.pos] in " \t\r":
            self.pos += 1

    def peek(self) -> str:
        self.skip()
        return self.text[self.pos] if self.pos < len(self.text) else ""

    def col(self) -> int:
        self.skip()
        return self.pos + 1

    def at_end(self) -> bool:
        return self.peek() == ""

    def keyword(self, *words: str) -> str | None:
        """The first of ``words`` that starts here (not followed by a letter), consumed."""
        self.skip()
        for w in words:
            end = self.pos + len(w)
            if self.text.startswith(w, self.pos) and not self.text[end:end + 1].isalpha():
                self.pos = end
                return w
        return None

    def expect(self, ch: str, what: str) -> None:
        if self.peek() != ch:
            found = self.peek() or "end of block"
            raise _Error(f"expected {ch!r} {what}, got {found!r}", self.col())
        self.pos += 1

    def name_here(self) -> str:
        m = re.match(r"[A-Z_][A-Z0-9_]*", self.text[self.pos:])
        return m.group(0) if m else ""

    # ---- numbers and expressions ---------------------------------------------------------------

    def number(self) -> tuple[float, bool]:
        self.skip()
        m = re.match(r"[0-9]*\.?[0-9]*", self.text[self.pos:])
        digits = m.group(0) if m else ""
        if not digits or digits == ".":
            found = self.text[self.pos:self.pos + 1] or "end of block"
            raise _Error(f"expected a number, got {found!r}", self.pos + 1)
        self.pos += len(digits)
        value = float(digits)
        if value == float("inf"):
            raise _Error(f"number {digits[:20]}... is too large", self.pos - len(digits) + 1)
        return value, "." in digits

    def variable(self) -> IsoVar:
        col = self.col()
        self.expect("#", "")
        if self.peek() == "[":
            self.pos += 1
            index = self.expr()
            self.expect("]", "closing #[..]")
            return IsoVar(index, col)
        number_col = self.col()
        value, point = self.number()
        if point:
            raise _Error("a variable number has no decimal point", number_col)
        return IsoVar(P.Num(value, number_col), col)

    def expr(self):
        left = self.sum()
        col = self.col()
        op = self.keyword(*_COMPARE)
        if op is None:
            return left
        return P.BinOp(op, left, self.sum(), col)

    def sum(self):
        return self.chain(self.term, ("+", "-"), ("OR", "XOR"))

    def term(self):
        return self.chain(self.unary, ("*", "/"), ("AND", "MOD"))

    def chain(self, operand, symbols: tuple, words: tuple):
        """``operand (op operand)*``, left-associative, for the operators of one priority."""
        left = operand()
        while True:
            col = self.col()
            ch = self.peek()
            if ch and ch in symbols:
                self.pos += 1
                op = ch
            else:
                op = self.keyword(*words)
                if op is None:
                    return left
            left = P.BinOp(op, left, operand(), col)

    def unary(self):
        col = self.col()
        ch = self.peek()
        if ch in ("+", "-"):
            self.pos += 1
            return P.Unary(ch, self.unary(), col)
        return self.atom()

    def atom(self):
        col = self.col()
        ch = self.peek()
        if ch == "#":
            return self.variable()
        if ch == "[":
            self.pos += 1
            inner = self.expr()
            self.expect("]", "closing '['")
            return inner
        if ch.isdigit() or ch == ".":
            value, _ = self.number()
            return P.Num(value, col)
        name = self.keyword(*sorted(_FUNCTIONS, key=len, reverse=True))
        if name is not None:
            return self.function(name, col)
        found = self.name_here() or ch or "end of block"
        raise _Error(f"unexpected {found!r} in an expression", col)

    def function(self, name: str, col: int):
        self.expect("[", f"after {name}")
        args = [self.expr()]
        while self.peek() == ",":
            self.pos += 1
            args.append(self.expr())
        self.expect("]", f"closing {name}[..]")
        if name == "ATAN" and len(args) == 1 and self.peek() == "/" and \
                self.text[self.pos + 1:].lstrip().startswith("["):
            self.pos += 1               # ATAN[a]/[b]: the two-argument form
            self.expect("[", "of ATAN[a]/[b]")
            args.append(self.expr())
            self.expect("]", "closing ATAN[a]/[b]")
        return P.Func("SQRT" if name == "SQR" else name, tuple(args), col)

    # ---- statements ----------------------------------------------------------------------------

    def condition(self, keyword: str):
        if self.peek() != "[":
            raise _Error(f"{keyword} needs its condition in brackets: {keyword} [..]", self.col())
        return self.atom()

    def label(self, keyword: str) -> int:
        col = self.col()
        value, point = self.number()
        if point or not 1 <= value <= 99:
            raise _Error(f"{keyword} needs a loop number 1..99", col)
        return int(value)

    def assignment(self) -> IsoAssign:
        col = self.col()
        target = self.variable()
        self.expect("=", "after the variable")
        return IsoAssign(target, self.expr(), col)

    def statement(self):
        """A macro statement, or None (then the block holds words)."""
        col = self.col()
        ch = self.peek()
        if ch == "#":
            return self.assignment()
        if self.keyword("IF"):
            cond = self.condition("IF")
            goto_col = self.col()
            if self.keyword("GOTO"):
                return IsoIf(cond, IsoGoto(self.expr(), goto_col), col)
            if self.keyword("THEN"):
                return IsoIf(cond, self.assignment(), col)
            raise _Error("IF [..] is followed by GOTO n or THEN #n=..", self.col())
        if self.keyword("GOTO"):
            return IsoGoto(self.expr(), col)
        if self.keyword("WHILE"):
            cond = self.condition("WHILE")
            if not self.keyword("DO"):
                raise _Error("WHILE [..] is followed by DO m", self.col())
            return IsoWhile(cond, self.label("DO"), col)
        if self.keyword("DO"):
            return IsoWhile(None, self.label("DO"), col)
        if self.keyword("END"):
            return IsoEnd(self.label("END"), col)
        if ch in ("O", ":") and self.text[self.pos + 1:self.pos + 2].isdigit():
            self.pos += 1
            value, _ = self.number()
            return IsoProgramNumber(int(value), col)
        return None

    def words(self) -> tuple:
        out = []
        while not self.at_end():
            col = self.col()
            ch = self.peek()
            if ch == "," and self.text[self.pos + 1:self.pos + 2] in ("R", "C"):
                address = "," + self.text[self.pos + 1]
                self.pos += 2
            elif ch in _WORD_LETTERS:
                name = self.name_here()
                if len(name) > 1 and not name[1:].isdigit():
                    raise _Error(f"{name} is not an ISO dialect word (Siemens code in ISO mode: "
                                 f"program G290 before it, G291 after it)", col)
                address = ch
                self.pos += 1
            elif ch == "N":
                raise _Error("a block number N must begin the block", col)
            else:
                raise _Error(f"unexpected {ch!r}", col)
            out.append(self.word_value(address, col))
        return tuple(out)

    def word_value(self, address: str, col: int) -> IsoWord:
        sign_col = self.col()
        ch = self.peek()
        negative = ch == "-"
        if ch in ("+", "-"):
            self.pos += 1
        ch = self.peek()
        if ch == "#":
            value, point = self.variable(), True
        elif ch == "[":
            value, point = self.atom(), True
        elif ch.isdigit() or ch == ".":
            number_col = self.col()
            number, point = self.number()
            value = P.Num(number, number_col)
        else:
            found = ch or "end of block"
            raise _Error(f"{address} needs a value, got {found!r}", self.col())
        if self.peek() == "=":
            raise _Error(f"{address}..= is Siemens code (an assignment) in ISO mode: program G290 "
                         f"before it, or #n = .. for a macro variable", self.col())
        if negative:
            value = P.Unary("-", value, sign_col)
        return IsoWord(address, value, col, point)


def parse_iso_block(text: str, line: int, file: str) -> IsoBlock:
    """One ISO line -> an :class:`IsoBlock` (NcSyntaxError at its column on bad input)."""
    try:
        reader = _Reader(strip_comments(text))
        skip = number = None
        if reader.peek() == "%":
            return IsoBlock(line)
        if reader.peek() == "/":
            reader.pos += 1
            skip = 0
            if reader.peek().isdigit():
                skip = int(reader.text[reader.pos])
                reader.pos += 1
        if reader.peek() == "N" and reader.text[reader.pos + 1:reader.pos + 2].isdigit():
            reader.pos += 1
            number = int(reader.number()[0])
        statement = reader.statement()
        if statement is not None:
            if not reader.at_end():
                raise _Error(f"unexpected {reader.peek()!r} after the statement", reader.col())
            return IsoBlock(line, number, skip, statement=statement)
        return IsoBlock(line, number, skip, items=reader.words())
    except _Error as exc:
        raise NcSyntaxError(exc.message, file, line, exc.col) from None


def mode_switch(text: str) -> int | None:
    """290 or 291 when the line is a G290/G291 block, else None."""
    m = _SWITCH.match(text)
    return 290 + int(m.group(1)) if m else None


def switches_dialect(text: str) -> bool:
    """Whether a program text may contain a G291 (cheap test before the switching parse)."""
    return _HAS_291.search(text) is not None


def parse_dialect_text(text: str, file: str, parse_block, *, fast: bool = True,
                       dialect: str = SIEMENS, iso_plain: bool = True) -> P.Program:
    """Parse a program whose lines are Siemens or ISO blocks, starting in ``dialect`` and
    switching at G290/G291 blocks. ``iso_plain``: ISO plain lines may be read as columns (not
    under standard notation, where a number without decimal point is in increments)."""
    mode = [dialect]

    def one_line(line_text: str, line: int, file_: str):
        code = mode_switch(line_text)
        if code is not None:
            mode[0] = ISO if code == 291 else SIEMENS
            col = line_text.upper().index("G") + 1
            return IsoBlock(line, statement=ModeSwitch(code, col))
        if mode[0] == ISO:
            return parse_iso_block(line_text, line, file_)
        return parse_block(line_text, line, file_)

    if fast:
        from ncsim.nc.fastparse import scan_program
        program = scan_program(text, file, one_line)
    else:
        lines = text.split("\n")
        if lines and lines[-1] == "":
            lines.pop()
        program = P.Program(file, tuple(one_line(t, i + 1, file) for i, t in enumerate(lines)),
                            len(lines))
    items: list = []
    lines: list = []
    current = dialect
    for item in program.items:
        if isinstance(item, IsoBlock) and isinstance(item.statement, ModeSwitch):
            current = ISO if item.statement.code == 291 else SIEMENS
        elif isinstance(item, P.PlainRun) and current == ISO:
            if not iso_plain:
                lines = lines or text.split("\n")
                items.extend(parse_iso_block(lines[item.first_line + i - 1], item.first_line + i,
                                             file) for i in range(len(item)))
                continue
            item = replace(item, iso=True)
        items.append(item)
    return P.Program(file, tuple(items), program.n_lines)
