"""Syntax of an 840D program: what the parser produces and the interpreter consumes.

These types carry no semantics and do not import Lark. A program is a sequence of *items*,
each a :class:`Block` (one line, any construct) or a :class:`PlainRun` (consecutive plain
lines ``N.. G0..G3 X.. Y.. Z.. I.. J.. K.. F.. ;comment`` read by the fast path, held as
columns). ``PlainRun.block(i)`` gives exactly the :class:`Block` the Lark parser builds for
row ``i``; a property test holds the two paths to that.

Every node keeps the 1-based column of its first character; the line is the block's.
Expression nodes: :class:`Num`, :class:`Str`, :class:`Var` (user variable), :class:`RParam`
(``R12``), :class:`Elem` (array element ``A[I,J]``, indirect ``R[I]``), :class:`SysVar`
(``$...``), :class:`Unary`, :class:`BinOp` (arithmetic, comparison, logic, ``<<``),
:class:`Func` (``SIN(..)``, ``AC(..)``), :class:`InitList` (``DEF REAL A[3]=(1,2,3)``).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Union

import numpy as np


# ---- expressions ----------------------------------------------------------------------------

@dataclass(frozen=True, slots=True)
class Num:
    value: float
    col: int


@dataclass(frozen=True, slots=True)
class Str:
    value: str
    col: int


@dataclass(frozen=True, slots=True)
class Var:
    name: str
    col: int


@dataclass(frozen=True, slots=True)
class RParam:
    index: int
    col: int


@dataclass(frozen=True, slots=True)
class Elem:
    """An element of a user array ``A[I]``/``A[I,J]`` (or ``R[I]``, an indirect R parameter)."""

    name: str
    index: tuple     # of Expr
    col: int


@dataclass(frozen=True, slots=True)
class InitList:
    """``(v1, v2, ...)``: the values of an array definition ``DEF REAL A[3]=(1,2,3)``."""

    values: tuple
    col: int


@dataclass(frozen=True, slots=True)
class SysVar:
    name: str
    index: tuple
    col: int


@dataclass(frozen=True, slots=True)
class Unary:
    op: str          # "-", "+", "NOT", "B_NOT"
    operand: "Expr"
    col: int


@dataclass(frozen=True, slots=True)
class BinOp:
    op: str          # + - * / DIV MOD B_AND B_OR B_XOR AND OR XOR << == <> < > <= >=
    left: "Expr"
    right: "Expr"
    col: int         # column of the operator


@dataclass(frozen=True, slots=True)
class Func:
    name: str
    args: tuple      # of Expr or None (an omitted argument)
    col: int


Expr = Union[Num, Str, Var, RParam, Elem, SysVar, Unary, BinOp, Func]


# ---- block items ----------------------------------------------------------------------------

@dataclass(frozen=True, slots=True)
class Word:
    """An address with a value: ``X10`` (value Num), ``X=R1+2``, ``X=AC(5)`` (value Func AC),
    ``CR=5``, ``I1=2``, ``T="MILL"``."""

    address: str
    value: Expr
    col: int


@dataclass(frozen=True, slots=True)
class IndexedWord:
    """An address with an index: ``AX[_Z]=..`` (indirect axis), ``IP[_Z]=..`` (its interpolation
    parameter), ``SPOS[2]=..``, ``LIMS[1]=..`` (spindle n)."""

    address: str
    index: tuple     # of Expr
    value: Expr
    col: int


@dataclass(frozen=True, slots=True)
class Assign:
    """``R1=..``, ``_VAR=..``, ``A[I]=..`` or ``$SYSVAR=..``: a variable assignment."""

    target: Union[Var, RParam, Elem, SysVar]
    value: Expr
    col: int


@dataclass(frozen=True, slots=True)
class Command:
    """A name alone: ``SOFT``, ``CIP``, ``STOPRE``, ``TRANS``, a subprogram name."""

    name: str
    col: int


@dataclass(frozen=True, slots=True)
class Call:
    """A name with arguments in item position: ``CYCLE832(0.02,1,1)``, ``MSG("x")``, ``SUB(1)``."""

    name: str
    args: tuple
    col: int


Item = Union[Word, IndexedWord, Assign, Command, Call]


# ---- control statements (alone in their block) ----------------------------------------------

@dataclass(frozen=True, slots=True)
class Target:
    """A jump destination: a label or a block number."""

    label: str | None
    number: int | None
    col: int

    def __str__(self) -> str:
        return self.label if self.label is not None else f"N{self.number}"


@dataclass(frozen=True, slots=True)
class Goto:
    kind: str        # GOTOF, GOTOB, GOTO, GOTOC
    target: Target
    col: int


@dataclass(frozen=True, slots=True)
class IfGoto:
    cond: Expr
    goto: Goto
    col: int


@dataclass(frozen=True, slots=True)
class IfGotos:
    """Several conditional jumps in one block: the first whose condition holds jumps."""

    jumps: tuple     # of IfGoto
    col: int


@dataclass(frozen=True, slots=True)
class Case:
    """``CASE expr OF 1 GOTOF A 2 GOTOF B DEFAULT GOTOF C``: jump to the first equal constant's
    destination, else to DEFAULT's (none: go on with the next block)."""

    expr: "Expr"
    cases: tuple     # of (value, Goto)
    default: "Goto | None"
    col: int


@dataclass(frozen=True, slots=True)
class RepeatSection:
    """``REPEAT START P=n`` (from START to this block), ``REPEAT START END P=n`` (between two
    labels, or from START to ``ENDLABEL:`` when END is None and no section ends here),
    ``REPEATB START P=n`` (the block START alone, ``block`` True)."""

    start: Target
    end: Target | None
    count: "Expr | None"
    block: bool
    col: int


@dataclass(frozen=True, slots=True)
class If:
    cond: Expr
    col: int


@dataclass(frozen=True, slots=True)
class While:
    cond: Expr
    col: int


@dataclass(frozen=True, slots=True)
class For:
    var: Union[Var, RParam]
    start: Expr
    end: Expr
    col: int


@dataclass(frozen=True, slots=True)
class Until:
    cond: Expr
    col: int


@dataclass(frozen=True, slots=True)
class Keyword:
    """ELSE, ENDIF, ENDWHILE, ENDFOR, REPEAT, LOOP, ENDLOOP."""

    name: str
    col: int


@dataclass(frozen=True, slots=True)
class DefVar:
    name: str
    dims: tuple      # () for a scalar
    init: Expr | None
    col: int


@dataclass(frozen=True, slots=True)
class Def:
    type_name: str   # REAL, INT, BOOL, CHAR, STRING, AXIS, FRAME
    variables: tuple  # of DefVar
    col: int
    scope: str | None = None   # NCK or CHAN: a global user variable (GUD definitions file)


@dataclass(frozen=True, slots=True)
class Param:
    type_name: str
    name: str
    by_reference: bool
    dims: tuple
    col: int


@dataclass(frozen=True, slots=True)
class Proc:
    name: str
    params: tuple    # of Param
    attributes: tuple  # SAVE, DISPLOF, ...
    col: int


@dataclass(frozen=True, slots=True)
class Extern:
    name: str
    col: int


Statement = Union[Goto, IfGoto, IfGotos, Case, RepeatSection, If, While, For, Until, Keyword,
                  Def, Proc, Extern]


# ---- blocks and programs --------------------------------------------------------------------

@dataclass(frozen=True, slots=True)
class Block:
    """One line. ``skip_level`` is None without ``/``, 0 for ``/``, n for ``/n``.
    A block holds either words (``items``) or one control ``statement``, never both."""

    line: int
    number: int | None = None
    skip_level: int | None = None
    label: str | None = None
    items: tuple = ()
    statement: Statement | None = None


# Column order of PlainRun.values; PlainRun.cols holds N, G, then these.
PLAIN_AXES = ("X", "Y", "Z", "I", "J", "K", "F")


@dataclass(frozen=True, slots=True, eq=False)
class PlainRun:
    """Consecutive plain lines as columns: row ``i`` is line ``first_line + i``.

    ``numbers`` (int64, -1 if no N), ``g`` (int8 0..3, -1 if no G), ``values`` (n, 7) float64
    for X Y Z I J K F (NaN where the word is absent), ``cols`` (n, 9) int32 1-based columns of
    N G X Y Z I J K F (0 where absent).
    """

    first_line: int
    numbers: np.ndarray
    g: np.ndarray
    values: np.ndarray
    cols: np.ndarray
    iso: bool = False    # read in ISO dialect mode (ncsim.nc.isoparse): the same words, its modes

    def __len__(self) -> int:
        return len(self.g)

    def block(self, i: int) -> Block:
        """Row ``i`` as the Block the Lark parser builds for the same line."""
        items = []
        if self.g[i] >= 0:
            c = int(self.cols[i, 1])
            items.append(Word("G", Num(float(self.g[i]), c), c))
        for k, address in enumerate(PLAIN_AXES):
            c = int(self.cols[i, 2 + k])
            if c:
                items.append(Word(address, Num(float(self.values[i, k]), c), c))
        number = int(self.numbers[i])
        return Block(line=self.first_line + i, number=None if number < 0 else number,
                     items=tuple(items))

    def slice(self, start: int) -> "PlainRun":
        """The rows from ``start`` on (a jump into the middle of a run)."""
        return self.rows(start, len(self))

    def rows(self, start: int, stop: int) -> "PlainRun":
        """The rows ``start:stop`` (views, no copy)."""
        return PlainRun(self.first_line + start, self.numbers[start:stop], self.g[start:stop],
                        self.values[start:stop], self.cols[start:stop], self.iso)


@dataclass(frozen=True, slots=True, eq=False)
class Program:
    """A parsed file: ``items`` in line order (Blocks and PlainRuns), ``n_lines`` lines, and
    the comment lines naming CAM operations, ``(line, name)`` (``ncsim.nc.outline``)."""

    file: str
    items: tuple
    n_lines: int
    operation_comments: tuple = ()

    def blocks(self):
        """Every line as a Block (PlainRuns expanded), for tests and tools."""
        for item in self.items:
            if isinstance(item, PlainRun):
                for i in range(len(item)):
                    yield item.block(i)
            else:
                yield item
