"""Program flow: units, labels, jumps and control structures of an 840D program.

840D semantics (Programming Guide Fundamentals, "Arithmetic parameters and program jumps";
Programming Guide Advanced, "Flexible NC programming", control structures):

* a file is a main part followed by PROCs, each PROC running to the next PROC
  (:func:`split_units`); in a subprogram file, comment, blank and ``%_N_..._SPF`` header lines
  before the first PROC are no main part (the file is that PROC);
* IF/ELSE/ENDIF, WHILE/ENDWHILE, FOR/ENDFOR, REPEAT/UNTIL and LOOP/ENDLOOP pair up before
  execution (:func:`compile_unit`), so an unpaired statement is an error at its line even if it
  is never reached;
* GOTOF searches forward from the next block, GOTOB backward from this block, GOTO forward then
  backward, GOTOC the same but an unknown destination is no error; a destination is a label or a
  block number N. A label may be defined more than once (real shop programs reuse METKA_START
  in every section): the search direction finds the nearest one;
* several conditional jumps may share a block, the first whose condition holds jumps
  (Programming Manual Job planning, "Program jumps"); ``CASE e OF c1 GOTOF l1 ... DEFAULT GOTOF
  l`` jumps to the destination of the first constant equal to e, else DEFAULT's, else goes on;
* FOR var = start TO end counts up by 1 and runs no time when start > end;
* program section repetition (Job planning, "Program section repetition (REPEAT, REPEATB,
  ENDLABEL, P)"): ``REPEATB L P=n`` runs the block labelled L n more times (L searched backward,
  then forward); ``REPEAT L P=n`` the section from L to the REPEAT block (or, when L follows the
  REPEAT, from L to the next ``ENDLABEL:``); ``REPEAT L1 L2 P=n`` the section from L1 to L2;
  without P once. The program then goes on after the REPEAT block. Sections may nest.

A new control-flow statement is a node in :mod:`ncsim.nc.program`, a rule in the grammar, its
pairing in :data:`OPENERS`/:func:`structure_word` when it opens or closes a structure, and a
handler in :meth:`Flow.execute`'s table.
"""
from __future__ import annotations

import bisect
from dataclasses import dataclass, field

import numpy as np

from ncsim.nc import program as P
from ncsim.nc.expr import FUNCTIONS, Where, truthy


@dataclass(slots=True)
class Unit:
    """A main program or a PROC: its items, labels and paired control statements."""

    name: str
    file: str
    items: list
    params: tuple = ()
    labels: dict = field(default_factory=dict)     # name -> item indices, ascending
    pairs: dict = field(default_factory=dict)      # opener <-> closer (and ELSE -> ENDIF)
    else_of: dict = field(default_factory=dict)    # IF -> ELSE
    attributes: tuple = ()                         # of the PROC: SAVE, DISPLOF, SBLOF, ...
    jumps: dict = field(default_factory=dict)      # (here, Goto) -> destination, once found
    ops: list = field(default_factory=list)        # compiled op per item (ncsim.nc.fastops)


OPENERS = {"IF": "ENDIF", "WHILE": "ENDWHILE", "FOR": "ENDFOR", "REPEAT": "UNTIL", "LOOP": "ENDLOOP"}
CLOSERS = {v: k for k, v in OPENERS.items()}


def structure_word(block) -> str | None:
    """The control-structure word a block opens, continues or closes (IF, ELSE, ENDIF, ...)."""
    s = block.statement if isinstance(block, P.Block) else None
    if isinstance(s, P.If):
        return "IF"
    if isinstance(s, P.While):
        return "WHILE"
    if isinstance(s, P.For):
        return "FOR"
    if isinstance(s, P.Until):
        return "UNTIL"
    if isinstance(s, P.Keyword):
        return s.name
    return None


def compile_unit(unit: Unit) -> Unit:
    """Pair IF/ELSE/ENDIF, WHILE, FOR, REPEAT/UNTIL, LOOP and collect labels (errors located)."""
    stack: list[tuple[str, int]] = []
    unit.ops = [None] * len(unit.items)
    for idx, item in enumerate(unit.items):
        if not isinstance(item, P.Block):
            continue
        if item.label is not None:
            unit.labels.setdefault(item.label, []).append(idx)
        word = structure_word(item)
        if word is None:
            continue
        where = Where(unit.file, item.line)
        col = item.statement.col
        if word in OPENERS:
            stack.append((word, idx))
        elif word == "ELSE":
            if not stack or stack[-1][0] != "IF" or stack[-1][1] in unit.else_of:
                raise where.error("ELSE without IF", col)
            unit.else_of[stack[-1][1]] = idx
        else:
            opener = CLOSERS[word]
            if not stack or stack[-1][0] != opener:
                what = (f"{word} closes {stack[-1][0]} of line {unit.items[stack[-1][1]].line}"
                        if stack else f"{word} without {opener}")
                raise where.error(what, col)
            _, start = stack.pop()
            unit.pairs[start] = idx
            unit.pairs[idx] = start
            if start in unit.else_of:
                unit.pairs[unit.else_of[start]] = idx
    if stack:
        word, idx = stack[-1]
        block = unit.items[idx]
        raise Where(unit.file, block.line).error(f"{word} without {OPENERS[word]}",
                                                 block.statement.col)
    return unit


def split_units(program: P.Program, main_name: str, subprogram: bool = False) -> list[Unit]:
    """The program's units: the main part, then one per PROC (a PROC runs to the next PROC).
    In a ``subprogram`` file (one called by name), comment and header lines before its first
    PROC are no main part: the file is that PROC. A main program keeps them as its (empty) main
    part, so that a file of PROCs run on its own is recognised as such."""
    units: list[Unit] = []
    current = Unit(main_name, program.file, [])
    for item in program.items:
        if isinstance(item, P.Block) and isinstance(item.statement, P.Proc):
            if units or current.items and not (subprogram and all(map(_is_empty, current.items))):
                units.append(current)
            s = item.statement
            current = Unit(s.name, program.file, [item], s.params, attributes=s.attributes)
        else:
            current.items.append(item)
    units.append(current)
    return [compile_unit(u) for u in units]


def _is_empty(item) -> bool:
    """Comment, blank or header lines (block numbers allowed): nothing to execute."""
    if isinstance(item, P.PlainRun):
        return bool((item.g < 0).all() and np.isnan(item.values).all())
    return not item.items and item.statement is None and item.label is None


def is_proc(unit: Unit) -> bool:
    """Whether the unit starts with its PROC statement (execution then starts after it)."""
    return bool(unit.items) and isinstance(unit.items[0], P.Block) and isinstance(
        unit.items[0].statement, P.Proc)


def find_destination(unit: Unit, goto: P.Goto, here: int):
    """(item index, row) of a jump destination, or None. GOTOF searches forward from the next
    block, GOTOB backward from this block, GOTO and GOTOC forward then backward; each finds the
    nearest block in its direction."""
    key = (here, goto.col)
    found = unit.jumps.get(key, False)
    if found is False:
        found = unit.jumps[key] = _search(unit, goto, here)
    return found


def _search(unit: Unit, goto: P.Goto, here: int):
    target = goto.target
    forward = goto.kind != "GOTOB"
    backward = goto.kind != "GOTOF"
    if target.label is not None:
        idx = find_label(unit, target.label, here, forward, backward)
        return None if idx is None else (idx, 0)
    items = unit.items
    if forward:
        found = _find_number(items, target.number, range(here + 1, len(items)), last=False)
        if found is not None:
            return found
    if backward:
        return _find_number(items, target.number, range(here, -1, -1), last=True)
    return None


def find_label(unit: Unit, label: str, here: int, forward: bool, backward: bool) -> int | None:
    """Index of the nearest block labelled ``label`` after ``here`` (``forward``), else at or
    before ``here`` (``backward``); None if there is none in the allowed directions."""
    hits = unit.labels.get(label)
    if not hits:
        return None
    k = bisect.bisect_right(hits, here)
    if forward and k < len(hits):
        return hits[k]
    if backward and k > 0:
        return hits[k - 1]
    return None


def _find_number(items: list, number: int, order, last: bool):
    for idx in order:
        item = items[idx]
        if isinstance(item, P.PlainRun):
            hits = np.flatnonzero(item.numbers == number)
            if len(hits):
                return idx, int(hits[-1] if last else hits[0])
        elif item.number == number:
            return idx, 0
    return None


def reads_state(e) -> bool:
    """Whether the expression ``e`` reads anything the program can change: an R parameter, a
    variable, a system variable (``WHILE 1`` reads nothing, so it decides nothing). A function
    other than the arithmetic ones counts as reading."""
    if isinstance(e, (P.Num, P.Str)) or e is None:
        return False
    if isinstance(e, P.Unary):
        return reads_state(e.operand)
    if isinstance(e, P.BinOp):
        return reads_state(e.left) or reads_state(e.right)
    if isinstance(e, P.Func) and e.name in FUNCTIONS:
        return any(reads_state(a) for a in e.args)
    return True


def _col(expr) -> int:
    return getattr(expr, "col", 0)


_DIRECTION = {"GOTOF": "forward", "GOTOB": "backward", "GOTO": "forward and backward"}


class Flow:
    """Executes the control statements (a block holding one statement instead of words)."""

    def __init__(self, state) -> None:
        self.state = state
        self.vars = state.vars
        self._reads: dict[int, tuple] = {}    # id(condition) -> (condition, reads_state)
        self._handlers = {
            P.Goto: self._goto, P.IfGoto: self._if_goto, P.IfGotos: self._if_gotos,
            P.Case: self._case, P.RepeatSection: self._repeat_section, P.If: self._if,
            P.While: self._while, P.For: self._for, P.Until: self._until,
            P.Keyword: self._keyword, P.Def: self._define, P.Proc: self._proc,
            P.Extern: self._extern,
        }

    def execute(self, ctx, s) -> None:
        """Run statement ``s`` of the block at ``ctx`` (the frame's pc is already past it)."""
        self._handlers[type(s)](ctx, s, ctx.frame.pc - 1)

    def _goto(self, ctx, s: P.Goto, here: int) -> None:
        self._jump(ctx, s, here)

    def _if_goto(self, ctx, s: P.IfGoto, here: int) -> None:
        if truthy(self._decide(ctx, s.cond)):
            self._jump(ctx, s.goto, here)

    def _if_gotos(self, ctx, s: P.IfGotos, here: int) -> None:
        for jump in s.jumps:
            if truthy(self._decide(ctx, jump.cond)):
                self._jump(ctx, jump.goto, here)
                return

    def _decide(self, ctx, cond):
        """The value of a condition that decides where the program goes, counted as a decision
        (``InterpreterState.decisions``, what tells a loop that can end from one that cannot)
        when it reads the program's state."""
        hit = self._reads.get(id(cond))
        if hit is None or hit[0] is not cond:
            hit = self._reads[id(cond)] = (cond, reads_state(cond))
        if hit[1]:
            self.state.decisions += 1
        return ctx.eval(cond)

    def _case(self, ctx, s: P.Case, here: int) -> None:
        value = self._decide(ctx, s.expr)
        for constant, goto in s.cases:
            if isinstance(constant, str) == isinstance(value, str) and constant == value:
                self._jump(ctx, goto, here)
                return
        if s.default is not None:
            self._jump(ctx, s.default, here)

    def _repeat_section(self, ctx, s: P.RepeatSection, here: int) -> None:
        """REPEAT/REPEATB: run the section again while repetitions are left, then go on."""
        fr = ctx.frame
        self.state.decisions += 1           # the repetitions left decide
        left = fr.repeats.get(here)
        if left is None:
            left = 1
            if s.count is not None:
                left = ctx.whole_number(ctx.number(s.count, "P"), "P", _col(s.count))
                if left < 1:
                    raise ctx.error("P (repetitions) must be at least 1", _col(s.count))
        if left == 0:
            del fr.repeats[here]
            return
        start, end = self._section(ctx, s, here)
        fr.repeats[here] = left - 1
        if start <= here:
            self.state.jumped_back(ctx.file, ctx.line, s.col)
        if end != here - 1:             # the section does not run into this block: come back
            fr.section_ends.append((end, here))
        fr.pc, fr.row = start, 0

    def _section(self, ctx, s: P.RepeatSection, here: int) -> tuple[int, int]:
        """(first, last) item index of the section a REPEAT/REPEATB statement repeats."""
        unit = ctx.frame.unit
        label = s.start.label
        if s.block:
            start = find_label(unit, label, here, forward=False, backward=True)
            if start is None:
                start = find_label(unit, label, here, forward=True, backward=False)
            if start is None:
                raise ctx.error(f"REPEATB: label {label} not found", s.start.col)
            return start, start
        before = find_label(unit, label, here - 1, forward=False, backward=True)
        if s.end is not None:
            start = before if before is not None else find_label(unit, label, here, True, False)
            if start is None:
                raise ctx.error(f"REPEAT: label {label} not found", s.start.col)
            end = find_label(unit, s.end.label, start - 1, forward=True, backward=False)
            if end is None:
                raise ctx.error(f"REPEAT: end label {s.end.label} not found after {label}",
                                s.end.col)
            return start, end
        if before is not None:
            return before, here - 1
        start = find_label(unit, label, here, forward=True, backward=False)
        if start is None:
            raise ctx.error(f"REPEAT: label {label} not found", s.start.col)
        end = find_label(unit, "ENDLABEL", start - 1, forward=True, backward=False)
        if end is None:
            raise ctx.error(f"REPEAT {label}: no ENDLABEL: after the label {label} (the section "
                            f"follows the REPEAT block)", s.start.col)
        return start, end

    def _if(self, ctx, s: P.If, here: int) -> None:
        if not truthy(self._decide(ctx, s.cond)):
            unit = ctx.frame.unit
            ctx.frame.pc = unit.else_of.get(here, unit.pairs[here]) + 1

    def _while(self, ctx, s: P.While, here: int) -> None:
        if not truthy(self._decide(ctx, s.cond)):
            ctx.frame.pc = ctx.frame.unit.pairs[here] + 1

    def _until(self, ctx, s: P.Until, here: int) -> None:
        if not truthy(self._decide(ctx, s.cond)):
            ctx.frame.pc = ctx.frame.unit.pairs[here] + 1
            self.state.jumped_back(ctx.file, ctx.line, s.col)

    def _for(self, ctx, s: P.For, here: int) -> None:
        fr = ctx.frame
        start = ctx.number(s.start, "FOR")
        end = ctx.number(s.end, "FOR")
        self.vars.assign(ctx, s.var, start)
        fr.for_end[here] = end
        self.state.for_begins(fr, here, start)
        if start > end:
            fr.pc = fr.unit.pairs[here] + 1

    def _keyword(self, ctx, s: P.Keyword, here: int) -> None:
        fr = ctx.frame
        unit = fr.unit
        if s.name == "ELSE":
            fr.pc = unit.pairs[here] + 1          # end of the true branch: skip the else branch
        elif s.name == "ENDWHILE":
            fr.pc = unit.pairs[here]               # back to WHILE (re-evaluated)
            self.state.jumped_back(ctx.file, ctx.line, s.col)
        elif s.name == "ENDLOOP":
            fr.pc = unit.pairs[here] + 1
            self.state.jumped_back(ctx.file, ctx.line, s.col)
        elif s.name == "ENDFOR":
            start = unit.pairs[here]
            if start not in fr.for_end:
                raise ctx.error("ENDFOR reached without its FOR (a jump into the loop)", s.col)
            var = unit.items[start].statement.var
            value = self.vars.read_target(ctx, var) + 1.0
            self.vars.assign(ctx, var, value)
            if value <= fr.for_end[start]:
                fr.pc = start + 1
                self.state.for_jump_back(fr, start, value, (ctx.file, ctx.line, s.col))
        # ENDIF, REPEAT, LOOP: nothing to do

    def _define(self, ctx, s: P.Def, here: int) -> None:
        if s.scope is not None:
            raise ctx.error(f"DEF {s.scope} defines a global user variable: it belongs in a "
                            f"definitions file (--definitions MGUD.DEF)", s.col)
        self.vars.define(ctx, s)

    def _proc(self, ctx, s: P.Proc, here: int) -> None:
        raise ctx.error(f"PROC {s.name} inside a program: a PROC must be the first block of its "
                        f"unit", s.col)

    def _extern(self, ctx, s: P.Extern, here: int) -> None:
        """EXTERN: a declaration only."""

    def _jump(self, ctx, goto: P.Goto, here: int) -> None:
        dest = find_destination(ctx.frame.unit, goto, here)
        if dest is None:
            if goto.kind == "GOTOC":
                return
            raise ctx.error(f"jump destination {goto.target} not found ({goto.kind} searches "
                            f"{_DIRECTION[goto.kind]})", goto.target.col)
        if dest[0] <= here:
            self.state.jumped_back(ctx.file, ctx.line, goto.col)
        ctx.frame.pc, ctx.frame.row = dest
