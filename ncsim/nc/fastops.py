"""Compiled blocks: the fast path of control flow and R-parameter arithmetic.

Shop programs make their motion with loops: a few blocks (R assignments, a G1 with computed
words, an ``IF .. GOTOB``) executed hundreds of thousands of times. Evaluating them node by node
(:func:`ncsim.nc.expr.evaluate`, a :class:`~ncsim.nc.context.WordContext` and the four steps of
:meth:`ncsim.nc.interpret.Interpreter.exec_block` per block) costs ~8 us a block. Here each
block is compiled once, when first executed, into an *op*: a Python closure that does what the
block path does for that kind of block, with its expressions compiled to Python code objects
and its jump destinations looked up once.

Semantics stay those of the block path, by construction and by test
(``tests/test_fastops.py`` runs random loop programs both ways):

* an expression is compiled only when every leaf is a number, an R parameter or a numeric
  scalar variable of its unit and every operator and function is numeric; the code computes
  the same IEEE operations in the same order as :mod:`ncsim.nc.expr` (the same function
  objects, both operands of AND/OR evaluated). Where the evaluator would raise (division by
  zero, a domain error, an overflow to inf or NaN, which it checks after every operator) the
  compiled code raises or yields a non-finite number, and the block falls back to the block
  path, which raises the located error. Intermediate overflows that a later operator would hide
  (``x / inf``, a comparison, a function) are checked where they can be hidden;
* an op decides before it changes anything whether it can do the block (a G1 without feed, a
  value out of range, G95, an active MCALL, the transverse axis under diameter programming ...
  send the block to the block path), except an assignment block, whose assignments take
  effect one by one as on the control: an assignment
  the compiled code cannot do is done by the block path's evaluator and ``assign``;
* blocks that are none of: empty (labels, comments), R and numeric variable assignments,
  G0/G1 with X Y Z F, a jump (GOTO*, IF .. GOTO*, several of them), IF/ELSE/ENDIF, WHILE/
  ENDWHILE, LOOP/ENDLOOP, REPEAT/UNTIL, ENDFOR, run through the block path unchanged.

``interpret_text(..., fast=False)`` never compiles a block.
"""
from __future__ import annotations

import math

from ncsim.nc import program as P
from ncsim.nc.context import MIN_PROGRAMMED_F, WORD_VALUE_LIMIT, BlockContext
from ncsim.nc.expr import FUNCTIONS, evaluate
from ncsim.nc.flow import find_destination, reads_state
from ncsim.units import mm_min_to_mm_s

_NUMERIC_TYPES = ("REAL", "INT", "BOOL")
_COMPARE = {"==": "==", "<>": "!=", "<": "<", ">": ">", "<=": "<=", ">=": ">="}
_MAX_SOURCE = 4000           # longer expressions stay with the evaluator


class Fallback(Exception):
    """The compiled op cannot do this block (this time): the block path does it."""


def _bad():
    raise Fallback


def _round_half_away(x: float) -> float:
    return float(math.floor(x + 0.5)) if x >= 0 else -float(math.floor(-x + 0.5))


_NAMESPACE = {"_bad": _bad, "_trunc": math.trunc, "_fmod": math.fmod, "_sin": math.sin,
              "_cos": math.cos, "_tan": math.tan, "_rad": math.radians, "_deg": math.degrees,
              "_atan2": math.atan2, "_asin": math.asin, "_acos": math.acos, "_sqrt": math.sqrt}
#: functions whose ``expr.FUNCTIONS`` entry is these math calls (a domain error raises the same
#: ValueError, and the block path then reports it); their results are floats already
_INLINE = {"SIN": "_sin(_rad({}))", "COS": "_cos(_rad({}))", "TAN": "_tan(_rad({}))",
           "ATAN2": "_deg(_atan2({}))", "ASIN": "_deg(_asin({}))", "ACOS": "_deg(_acos({}))",
           "SQRT": "_sqrt({})", "ABS": "abs({})", "TRUNC": "float(_trunc({}))"}
_NAMESPACE.update({f"_f_{name}": fn for name, (_, fn) in FUNCTIONS.items()})


# =============================================================================================
# Expressions
# =============================================================================================

class ExprCompiler:
    """Python source for the numeric expressions of one unit (None: not compilable)."""

    def __init__(self, numeric_vars: frozenset) -> None:
        self.numeric_vars = numeric_vars

    def function(self, expr):
        """``f(r, v)``: the value of ``expr`` with R parameters ``r`` and variables ``v``, or
        None. ``f`` raises (or returns a non-finite number) where the evaluator would raise."""
        src = self.source(expr)
        if src is None or len(src) > _MAX_SOURCE:
            return None
        code = f"def _e(r, v):\n    return {src}\n"
        try:
            namespace = dict(_NAMESPACE)
            exec(compile(code, "<ncsim block>", "exec"), namespace)
        except (SyntaxError, RecursionError, MemoryError, ValueError):
            return None
        return namespace["_e"]

    def source(self, e) -> str | None:
        try:
            return self._src(e)
        except (_NotNumeric, RecursionError):
            return None

    def _leaf(self, e) -> bool:
        return isinstance(e, (P.Num, P.RParam, P.Var))

    def _checked(self, e) -> str:
        """``e`` where an overflow in it could be hidden by the operator using it."""
        s = self._src(e)
        if self._leaf(e):
            return s
        return f"(_t if (_t := {s}) - _t == 0.0 else _bad())"

    def _src(self, e) -> str:
        if isinstance(e, P.Num):
            return repr(e.value)
        if isinstance(e, P.RParam):
            return f"r[{e.index}]"
        if isinstance(e, P.Var):
            if e.name not in self.numeric_vars:
                raise _NotNumeric
            return f"v[{e.name!r}][1]"
        if isinstance(e, P.Unary):
            if e.op == "-":
                return f"(-{self._src(e.operand)})"
            if e.op == "+":
                return self._src(e.operand)
            if e.op == "NOT":
                return f"(0.0 if {self._checked(e.operand)} != 0.0 else 1.0)"
            if e.op == "B_NOT":
                return f"float(~int({self._src(e.operand)}))"
            raise _NotNumeric
        if isinstance(e, P.BinOp):
            return self._binop(e)
        if isinstance(e, P.Func):
            return self._func(e)
        raise _NotNumeric

    def _binop(self, e: P.BinOp) -> str:
        op = e.op
        if op in ("+", "-", "*"):
            return f"({self._src(e.left)} {op} {self._src(e.right)})"
        if op == "/":
            return f"({self._src(e.left)} / {self._checked(e.right)})"
        if op == "DIV":
            return f"float(_trunc({self._src(e.left)} / {self._checked(e.right)}))"
        if op == "MOD":
            return f"_fmod({self._src(e.left)}, {self._checked(e.right)})"
        if op in _COMPARE:
            return (f"(1.0 if {self._checked(e.left)} {_COMPARE[op]} {self._checked(e.right)} "
                    f"else 0.0)")
        if op in ("AND", "OR", "XOR"):
            a = f"({self._checked(e.left)} != 0.0)"
            b = f"({self._checked(e.right)} != 0.0)"
            joined = {"AND": "&", "OR": "|", "XOR": "!="}[op]
            return f"(1.0 if {a} {joined} {b} else 0.0)"
        if op in ("B_AND", "B_OR", "B_XOR"):
            joined = {"B_AND": "&", "B_OR": "|", "B_XOR": "^"}[op]
            return f"float(int({self._src(e.left)}) {joined} int({self._src(e.right)}))"
        raise _NotNumeric                            # <<: strings

    def _func(self, e: P.Func) -> str:
        if e.name not in FUNCTIONS:
            raise _NotNumeric
        n_args, _ = FUNCTIONS[e.name]
        if len(e.args) != n_args or any(a is None for a in e.args):
            raise _NotNumeric
        args = ", ".join(self._checked(a) for a in e.args)
        inline = _INLINE.get(e.name)
        if inline is not None:      # the same math calls as expr.FUNCTIONS, without a wrapper
            return inline.format(args)
        return f"float(_f_{e.name}({args}))"


class _NotNumeric(Exception):
    pass


def numeric_variables(unit) -> frozenset:
    """Names declared in ``unit`` only as numeric scalars (DEF REAL/INT/BOOL, PROC params)."""
    numeric, other = set(), set()
    for p in unit.params:
        (numeric if p.type_name in _NUMERIC_TYPES and not p.dims else other).add(p.name)
    for item in unit.items:
        s = getattr(item, "statement", None)
        if isinstance(s, P.Def):
            for v in s.variables:
                (numeric if s.type_name in _NUMERIC_TYPES and not v.dims else other).add(v.name)
    return frozenset(numeric - other)


# =============================================================================================
# Blocks
# =============================================================================================

class _MoveCtx:
    """What ``Moves._emit`` reads of a block context, for a compiled G0/G1 block."""

    __slots__ = ("line", "frame", "gcodes")

    def __init__(self, line: int) -> None:
        self.line = line
        self.frame = None
        self.gcodes = {}


class _FlowOps:
    """The ops of control statements (a mixin of :class:`OpCompiler`, which gives ``state``,
    ``interp``, ``_expr``, ``_head``, ``_generate`` and ``_counter``)."""

    # ---- control statements --------------------------------------------------------------------

    def _statement(self, unit, pc: int, block: P.Block, s):
        ec = self._expr(unit)
        if isinstance(s, P.Goto):
            return self._jumps(unit, pc, block, [(None, s, False)])
        if isinstance(s, P.IfGoto):
            cond = ec.source(s.cond)
            return None if cond is None else self._jumps(unit, pc, block,
                                                         [(cond, s.goto, reads_state(s.cond))])
        if isinstance(s, P.IfGotos):
            conds = [(ec.source(j.cond), j.goto, reads_state(j.cond)) for j in s.jumps]
            if any(c is None for c, *_ in conds):
                return None
            return self._jumps(unit, pc, block, conds)
        if isinstance(s, (P.If, P.While, P.Until)):
            cond = ec.source(s.cond)
            return None if cond is None else self._condition(unit, pc, block, s, cond)
        if isinstance(s, P.Keyword):
            return self._keyword(unit, pc, block, s, ec)
        return None

    def _jumps(self, unit, pc: int, block: P.Block, conds):
        """GOTO*/IF .. GOTO* (one or several): the first true condition jumps. ``conds`` are
        ``(source or None, Goto, decides)``: a condition that reads the program's state counts
        as a decision (``InterpreterState.decisions``, as in ``flow.Flow._decide``)."""
        src, ns = self._head(unit, block)
        src += "    try:\n"
        for k, (cond, goto, decides) in enumerate(conds):
            dest = find_destination(unit, goto, pc)
            if dest is None:
                return None                      # the block path raises or goes on (GOTOC)
            back = f"        count_jump(BACK{k})\n" if dest[0] <= pc else ""
            ns[f"BACK{k}"] = (unit.file, block.line, goto.col)
            jump = f"{back}        fr.pc = {dest[0]}\n        fr.row = {dest[1]}\n        return\n"
            if cond is None:
                src += jump
                break
            src += ("        state.decisions += 1\n" if decides else "") + (
                    f"        c = {cond}\n        if c - c != 0.0:\n            raise Fallback\n"
                    f"        if c != 0.0:\n" + "".join("    " + ln + "\n"
                                                   for ln in jump.rstrip("\n").split("\n")))
        src += (f"    except Exception:\n        return generic(fr, {pc})\n"
                f"    fr.pc = {pc + 1}\n")
        ns.update(count_jump=self.state.count_jump, generic=self.interp.generic_uncounted)
        return self._generate(src, ns)

    def _condition(self, unit, pc: int, block: P.Block, s, cond: str):
        """IF (false: to ELSE/ENDIF), WHILE (false: after ENDWHILE), UNTIL (false: back); a
        condition that reads the program's state counts as a decision."""
        if isinstance(s, P.If):
            on_false, back = unit.else_of.get(pc, unit.pairs[pc]) + 1, False
        elif isinstance(s, P.While):
            on_false, back = unit.pairs[pc] + 1, False
        else:
            on_false, back = unit.pairs[pc] + 1, True
        src, ns = self._head(unit, block)
        if reads_state(s.cond):
            src += "    state.decisions += 1\n"
        src += (f"    try:\n        c = {cond}\n        if c - c != 0.0:\n"
                f"            raise Fallback\n    except Exception:\n"
                f"        return generic(fr, {pc})\n    if c == 0.0:\n")
        if back:
            src += "        count_jump(BACK)\n"
        src += f"        fr.pc = {on_false}\n    else:\n        fr.pc = {pc + 1}\n"
        ns.update(count_jump=self.state.count_jump, generic=self.interp.generic_uncounted,
                  BACK=(unit.file, block.line, s.col))
        return self._generate(src, ns)

    def _keyword(self, unit, pc: int, block: P.Block, s: P.Keyword, ec):
        name = s.name
        state = self.state
        line = block.line
        file = unit.file
        count = self._counter(unit, line)
        col = s.col
        if name in ("ENDIF", "REPEAT", "LOOP"):
            target, back = pc + 1, False
        elif name == "ELSE":
            target, back = unit.pairs[pc] + 1, False
        elif name == "ENDWHILE":
            target, back = unit.pairs[pc], True
        elif name == "ENDLOOP":
            target, back = unit.pairs[pc] + 1, True
        elif name == "ENDFOR":
            return self._endfor(unit, pc, block, s, ec)
        else:
            return None

        def op(fr):
            count()
            if back:
                state.jumped_back(file, line, col)
            fr.pc = target
        return op

    def _endfor(self, unit, pc: int, block: P.Block, s: P.Keyword, ec):
        start = unit.pairs[pc]
        var = unit.items[start].statement.var
        if isinstance(var, P.Var) and var.name not in ec.numeric_vars:
            return None
        state = self.state
        r = state.vars.r
        line = block.line
        file = unit.file
        count = self._counter(unit, line)
        generic = self.interp.generic_uncounted
        col = s.col
        after = pc + 1
        is_r = isinstance(var, P.RParam)
        key = (file, line, col)

        def op(fr):
            count()
            end = fr.for_end.get(start)
            if end is None:                          # the block path raises
                return generic(fr, pc)
            if is_r:
                value = r[var.index] + 1.0
                r[var.index] = value
            else:
                entry = fr.variables.get(var.name)
                if entry is None or entry[0] not in ("REAL", "INT") or type(entry[1]) is not float:
                    return generic(fr, pc)
                value = entry[1] + 1.0
                entry[1] = value if entry[0] == "REAL" else _round_half_away(value)
            if value <= end:
                fr.pc = start + 1
                state.for_jump_back(fr, start, value, key)
            else:
                fr.pc = after
        return op


class OpCompiler(_FlowOps):
    """Compiles the items of a unit into ops ``op(frame)`` for the interpreter's loop."""

    def __init__(self, interp) -> None:
        self.interp = interp
        self.state = interp.state
        self._exprs: dict[int, ExprCompiler] = {}

    # ---- entry ---------------------------------------------------------------------------------

    def compile(self, unit, pc: int):
        """The op of item ``pc``: the block path the first time it runs, compiled the second
        (a block that runs once is not worth its compilation)."""
        ops = unit.ops
        generic = self.interp.generic_op

        def second(fr):
            op = ops[pc] = self.compiled(unit, pc)
            op(fr)

        def first(fr):
            ops[pc] = second
            generic(fr)
        return first

    def compiled(self, unit, pc: int):
        item = unit.items[pc]
        generic = self.interp.generic_op
        if isinstance(item, P.PlainRun):
            return (None if item.iso else self._plain_run(unit, pc, item)) or generic
        if not isinstance(item, P.Block):       # ISO blocks (ncsim.nc.iso) run as they are
            return generic
        if self.state.skip_blocks and item.skip_level is not None:
            return generic
        try:
            op = self._block(unit, pc, item)
        except RecursionError:
            op = None
        return op or generic

    def _expr(self, unit) -> ExprCompiler:
        found = self._exprs.get(id(unit))
        if found is None:
            found = self._exprs[id(unit)] = ExprCompiler(numeric_variables(unit))
        return found

    def _block(self, unit, pc: int, block: P.Block):
        s = block.statement
        if s is not None:
            return self._statement(unit, pc, block, s)
        if not block.items:
            return self._empty(pc)
        if all(isinstance(i, P.Assign) for i in block.items):
            return self._assignments(unit, pc, block)
        return self._move(unit, pc, block)

    # ---- shared pieces -------------------------------------------------------------------------

    def _counter(self, unit, line: int):
        """``count()``: one more block executed (the budget stops endless loops)."""
        state = self.state
        file = unit.file

        def count():
            state.blocks += 1
            if state.blocks > state.budget:
                raise state.budget_error(file, line)
        return count

    def _empty(self, pc: int):
        state = self.state
        after = pc + 1

        def op(fr):
            state.blocks += 1
            if state.blocks > state.budget:
                raise state.budget_error(fr.unit.file, fr.unit.items[pc].line)
            fr.pc = after
        return op

    def _plain_run(self, unit, pc: int, run: P.PlainRun):
        """A run of comment or blank lines (no word): counted, nothing else. A short run of
        plain blocks (the block path runs it block by block): its rows compiled as G0/G1
        blocks, the others (circles) by the block path, each row counted."""
        state = self.state
        n = len(run)
        if (run.g < 0).all() and (run.cols[:, 2:] == 0).all():
            def op(fr):
                rows = n - fr.row
                if state.blocks + rows > state.budget:   # the block path locates the overrun
                    return self.interp.generic_op(fr)
                state.blocks += rows
                fr.row = 0
                fr.pc += 1
            return op
        if n >= self.interp.vector_min_rows:
            return None
        blocks = [run.block(i) for i in range(n)]
        rows = [self._move(unit, pc, b, row=True) or _row_fallback(self.interp, b) for b in blocks]
        lines = [b.line for b in blocks]
        stack = state.stack
        file = unit.file

        def op(fr):
            start = fr.row
            fr.row = 0
            fr.pc = pc + 1
            for i in range(start, n):
                state.blocks += 1
                if state.blocks > state.budget:
                    raise state.budget_error(file, lines[i])
                rows[i](fr)
                if stack[-1] is not fr and i + 1 < n:   # a modal call: the rest of the run after it
                    fr.pc = pc
                    fr.row = i + 1
                    return
        return op

    # ---- generated ops -------------------------------------------------------------------------

    def _generate(self, source: str, namespace: dict):
        """``op`` from the Python ``source`` of a block op (None if it does not compile)."""
        ns = dict(_NAMESPACE)
        ns.update(namespace)
        try:
            exec(compile(source, "<ncsim block>", "exec"), ns)
        except (SyntaxError, RecursionError, MemoryError, ValueError):
            return None
        return ns["op"]

    def _head(self, unit, block: P.Block) -> tuple[str, dict]:
        """Source and namespace shared by generated ops: count the block, read its variables."""
        src = ("def op(fr):\n"
               "    state.blocks += 1\n"
               "    if state.blocks > state.budget:\n"
               "        raise state.budget_error(FILE, LINE)\n"
               "    v = fr.variables\n")
        return src, {"state": self.state, "st": self.state.st, "r": self.state.vars.r,
                     "FILE": unit.file, "LINE": block.line, "Fallback": Fallback}

    # ---- assignments ---------------------------------------------------------------------------

    def _assign_steps(self, unit, block: P.Block, items) -> tuple[str, dict] | None:
        """Source (inside ``op``) and namespace of assignments done one after the other; an
        assignment the compiled code cannot do (and every one after it) is done by the block
        path's evaluator and ``assign`` (``slow``)."""
        ec = self._expr(unit)
        body, compiled = [], 0
        for k, item in enumerate(items):
            target = item.target
            if not isinstance(target, (P.RParam, P.Var)):
                return None
            if isinstance(target, P.Var) and target.name not in ec.numeric_vars:
                return None
            src = ec.source(item.value)
            if src is None:
                body.append("        raise Fallback\n")
                break
            compiled += 1
            body.append(f"        _t = {src}\n        if _t - _t != 0.0:\n"
                        f"            raise Fallback\n")
            if isinstance(target, P.RParam):
                body.append(f"        r[{target.index}] = _t\n")
            else:
                body.append(f"        store(v, T{k}, _t, fr)\n")
            body.append(f"        k = {k + 1}\n")
        if not compiled:
            return None
        state = self.state
        vars_ = state.vars
        line = block.line

        def slow(fr, k):
            for item in items[k:]:
                ctx = BlockContext(state, fr, line)
                vars_.assign(ctx, item.target, evaluate(item.value, vars_, ctx))

        def store(v, target, value, fr):
            _store(v, target, value, vars_, state, fr, line)

        src = ("    k = 0\n    try:\n" + "".join(body) +
               "    except Exception:\n        slow(fr, k)\n")
        ns = dict(slow=slow, store=store, **{f"T{k}": i.target for k, i in enumerate(items)})
        return src, ns

    def _assignments(self, unit, pc: int, block: P.Block):
        """R and numeric variable assignments, one after the other (:meth:`_assign_steps`)."""
        steps = self._assign_steps(unit, block, block.items)
        if steps is None:
            return None
        src, ns = self._head(unit, block)
        src += steps[0] + f"    fr.pc = {pc + 1}\n"
        ns.update(steps[1])
        return self._generate(src, ns)

    # ---- G0/G1 X Y Z F -------------------------------------------------------------------------

    def _move(self, unit, pc: int, block: P.Block, row: bool = False):
        """G0/G1 with computed X Y Z and F: what the block path does for such a block
        (``Settings.feed_spindle_tool``, ``Moves._linear``), or the block path itself when
        anything is unusual. ``row``: a row of a plain run (counted and advanced by its run's
        op; the fallback is ``exec_block`` of that row)."""
        ec = self._expr(unit)
        g = None
        axes: dict[int, str] = {}
        feed = None
        items = block.items
        n_assign = 0
        while n_assign < len(items) and isinstance(items[n_assign], P.Assign):
            n_assign += 1
        pre = None
        if n_assign:                     # R1=R1+1 G1 X=R1: the assignments first, then the move
            if row or n_assign == len(items):
                return None
            pre = self._assign_steps(unit, block, items[:n_assign])
            if pre is None:
                return None
        for item in items[n_assign:]:
            if not isinstance(item, P.Word):
                return None
            a = item.address
            if a == "G":
                if g is not None or not isinstance(item.value, P.Num) or \
                        item.value.value not in (0.0, 1.0):
                    return None
                g = int(item.value.value)
            elif a in ("X", "Y", "Z"):
                i = "XYZ".index(a)
                if isinstance(item.value, P.Func) and item.value.name in ("AC", "IC"):
                    return None
                src = ec.source(item.value)
                if src is None or i in axes:
                    return None
                axes[i] = src
            elif a == "F":
                if feed is not None:
                    return None
                feed = ec.source(item.value)
                if feed is None:
                    return None
            else:
                return None
        src, ns = self._head(unit, block)
        if row:
            src = "def op(fr):\n    v = fr.variables\n"
            ns["generic"] = _row_fallback(self.interp, block, with_pc=True)
        if pre is not None:
            src += pre[0]
            ns.update(pre[1])
            rest = P.Block(line=block.line, number=block.number, skip_level=block.skip_level,
                           label=block.label, items=items[n_assign:])
            ns["generic"] = _rest_fallback(self.interp, rest)
        src += "    try:\n"
        for i, e in axes.items():
            src += (f"        a{i} = {e}\n"
                    f"        if type(a{i}) is not float or not abs(a{i}) < LIMIT:\n"
                    f"            raise Fallback\n")
        if feed is not None:
            src += (f"        fv = {feed}\n"
                    f"        if type(fv) is not float or not abs(fv) < LIMIT or not fv >= MIN_F:\n"
                    f"            raise Fallback\n")
        src += (f"    except Exception:\n        return generic(fr, {pc})\n"
                f"    motion = {'st.motion' if g is None else g}\n"
                f"    if motion > 1 or state.modal_call is not None or "
                f"state.feed_type not in (94, 971)"
                + (" or st.diameter" if self.state.diameter_axis in axes else "") +
                f":\n        return generic(fr, {pc})\n")
        if feed is not None:
            src += "    feed = mm_min_to_mm_s(fv * st.feed_scale)\n"
        if axes:
            have = "feed" if feed is not None else "st.feed_mm_s"
            src += (f"    if motion == 1 and {have} != {have}:\n"
                    f"        return generic(fr, {pc})\n")
        if feed is not None:
            src += "    state.f_value = fv\n    st.feed_mm_s = feed\n"
        src += "    st.motion = motion\n" + ("" if row else f"    fr.pc = {pc + 1}\n")
        if axes:
            src += "    scale = st.length_scale\n    p = st.pos_wcs\n    if st.incremental:\n"
            for i in range(3):
                src += (f"        w{i} = p[{i}] + a{i} * scale\n" if i in axes
                        else f"        w{i} = p[{i}] + 0.0\n")
            src += "    else:\n"
            for i in range(3):
                src += (f"        w{i} = a{i} * scale\n" if i in axes else f"        w{i} = p[{i}]\n")
            src += ("    mctx.frame = fr\n"
                    "    line_to(mctx, [w0, w1, w2], list(st.frame.apply(w0, w1, w2)), "
                    "motion == 0)\n")
        ns.setdefault("generic", self.interp.generic_uncounted)
        ns.update(LIMIT=WORD_VALUE_LIMIT, MIN_F=MIN_PROGRAMMED_F, mm_min_to_mm_s=mm_min_to_mm_s,
                  line_to=self.interp.moves.line_to, mctx=_MoveCtx(block.line))
        return self._generate(src, ns)


def _rest_fallback(interp, rest: P.Block):
    """The words of a block whose leading assignments are done: the block path for the rest."""
    state = interp.state
    exec_block = interp.exec_block

    def fallback(fr, pc):
        state.line = rest.line
        fr.pc = pc + 1
        exec_block(fr, rest)
    return fallback


def _row_fallback(interp, block: P.Block, with_pc: bool = False):
    """A row of a plain run by the block path (``exec_block``; its run's op counts it)."""
    exec_block = interp.exec_block
    if with_pc:
        return lambda fr, pc: exec_block(fr, block)
    return lambda fr: exec_block(fr, block)


def _store(v: dict, target: P.Var, value: float, vars_, state, fr, line: int) -> None:
    """``target = value`` for a numeric scalar variable, as ``Variables.assign`` does it."""
    entry = v.get(target.name)
    if entry is None or type(entry[1]) is not float:
        vars_.assign(BlockContext(state, fr, line), target, value)
        return
    kind = entry[0]
    if kind == "REAL":
        entry[1] = value
    elif kind == "INT":
        entry[1] = _round_half_away(value)
    elif kind == "BOOL":
        entry[1] = 1.0 if value != 0.0 else 0.0
    else:
        vars_.assign(BlockContext(state, fr, line), target, value)
