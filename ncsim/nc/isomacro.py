"""ISO dialect macro variables and expressions (``#1 = #2 * SIN[30.]``).

SINUMERIK ISO Milling, chapter "Macro programs" (the Fanuc custom macro language the ISO mode
reads): "Variables", "Arithmetic commands and functions", "Control commands":

* ``#1``..``#33`` are local to a macro level: the main program and each ``G65`` call have their
  own; an ``M98`` subprogram uses its caller's (:func:`locals_of`); ``#100``..``#199`` and
  ``#500``..``#999`` are common to every level; ``#0`` is always vacant;
* a variable never assigned is *vacant*: 0 in arithmetic, but ``#1 EQ 0`` is false while
  ``#1 EQ #0`` is true; an address whose variable is vacant is not programmed (``X#1`` with
  ``#1`` vacant moves no axis);
* ``SIN COS TAN`` take degrees, ``ASIN ACOS`` and ``ATAN[a]/[b]`` give degrees (the last in
  0..360); ``ROUND`` rounds half away from zero, ``FIX`` and ``FUP`` drop or raise the fraction
  of the absolute value; ``AND OR XOR`` are bitwise on whole numbers (1/0 for conditions);
  comparisons give 1 or 0; division by zero stops the program;
* system variables read: ``#4001``..``#4022`` the modal G codes of the groups ncsim keeps,
  ``#4109`` F, ``#4119`` S, ``#5001``..``#5003`` the end point of the last block and
  ``#5041``..``#5043`` the current position (workpiece coordinates), ``#5021``..``#5023`` the
  machine position; ``#3000 = n`` raises macro alarm n (the program stops). Others are errors.

Local variables are stored in the call frame's variables as ``"#n"`` and common ones among the
global user variables, so the interpreter's endless-loop watch sees them.
"""
from __future__ import annotations

import math

from ncsim.nc import program as P
from ncsim.nc.expr import format_value
from ncsim.nc.isoparse import IsoVar
from ncsim.units import mm_s_to_mm_min

LOCALS = range(1, 34)
COMMONS = (range(100, 200), range(500, 1000))
ALARM = 3000
_KEY = "#locals"


def _degrees_atan(y: float, x: float) -> float:
    return math.degrees(math.atan2(y, x)) % 360.0


def _round(x: float) -> float:
    return float(math.floor(abs(x) + 0.5)) * (1.0 if x >= 0 else -1.0)


def _checked(check, fn, what: str):
    def f(*args):
        if not check(*args):
            raise ValueError(what)
        return fn(*args)
    return f


FUNCTIONS = {
    "SIN": (1, lambda x: math.sin(math.radians(x))),
    "COS": (1, lambda x: math.cos(math.radians(x))),
    "TAN": (1, lambda x: math.tan(math.radians(x))),
    "ASIN": (1, _checked(lambda x: -1.0 <= x <= 1.0, lambda x: math.degrees(math.asin(x)),
                         "argument outside [-1, 1]")),
    "ACOS": (1, _checked(lambda x: -1.0 <= x <= 1.0, lambda x: math.degrees(math.acos(x)),
                         "argument outside [-1, 1]")),
    "ATAN": ((1, 2), lambda y, x=None: math.degrees(math.atan(y)) if x is None
             else _degrees_atan(y, x)),
    "SQRT": (1, _checked(lambda x: x >= 0.0, math.sqrt, "square root of a negative number")),
    "ABS": (1, abs),
    "ROUND": (1, _round),
    "FIX": (1, lambda x: float(math.floor(abs(x))) * (1.0 if x >= 0 else -1.0)),
    "FUP": (1, lambda x: float(math.ceil(abs(x))) * (1.0 if x >= 0 else -1.0)),
    "LN": (1, _checked(lambda x: x > 0.0, math.log, "logarithm of a number <= 0")),
    "EXP": (1, math.exp),
    "POW": (2, lambda x, y: math.pow(x, y)),
}
_COMPARE = {"EQ": lambda a, b: a == b, "NE": lambda a, b: a != b,
            "GT": lambda a, b: a > b, "GE": lambda a, b: a >= b,
            "LT": lambda a, b: a < b, "LE": lambda a, b: a <= b}


def locals_of(stack: list) -> dict:
    """The local variables of the current macro level: the dict an ``M98`` or ``G65`` call
    passed in its frame's ``refs`` (``"#locals"``), else the frame's own variables."""
    fr = stack[-1]
    refs = fr.refs
    if refs and _KEY in refs:
        shared = refs[_KEY]
        if fr.variables is not shared:       # a repetition (L) pushed a fresh frame
            fr.variables = shared
        return shared
    return fr.variables


def level_refs(variables: dict) -> dict:
    """The ``refs`` of a call frame whose locals are ``variables``."""
    return {_KEY: variables}


class Macro:
    """Reads and writes macro variables and evaluates ISO expressions for one interpretation."""

    def __init__(self, state) -> None:
        self.state = state

    # ---- variables ---------------------------------------------------------------------------

    def _number(self, ctx, var: IsoVar) -> int:
        n = self.value(ctx, var.index)
        if n is None or n != int(n) or n < 0:
            shown = "vacant" if n is None else format_value(n)
            raise ctx.error(f"#{shown} is no variable number", var.col)
        return int(n)

    def _table(self, ctx, n: int, col: int, writing: bool):
        if n in LOCALS:
            return locals_of(self.state.stack)
        if any(n in r for r in COMMONS):
            return self.state.vars.globals
        if n == 0 and not writing:
            return None
        if n == 0:
            raise ctx.error("#0 is always vacant: it cannot be assigned", col)
        return False

    def read(self, ctx, var: IsoVar):
        n = self._number(ctx, var)
        table = self._table(ctx, n, var.col, False)
        if table is None:
            return None
        if table is False:
            return self._system(ctx, n, var.col)
        entry = table.get(f"#{n}")
        return None if entry is None else entry[1]

    def write(self, ctx, var: IsoVar, value) -> None:
        n = self._number(ctx, var)
        table = self._table(ctx, n, var.col, True)
        if table is False:
            if n == ALARM and value is not None:
                raise ctx.error(f"#3000 = {format_value(value)}: macro alarm {int(value)}, the "
                                f"control stops the program here", var.col)
            raise ctx.unsupported(f"writing system variable #{n} is not simulated", var.col)
        if value is not None and not math.isfinite(value):
            raise ctx.error("arithmetic overflow (result is not a finite number)", var.col)
        table[f"#{n}"] = ["REAL", value]

    def _system(self, ctx, n: int, col: int):
        state, st = self.state, self.state.st
        scale = st.length_scale
        modal = {4001: st.motion, 4002: st.plane, 4003: 91 if st.incremental else 90,
                 4005: state.feed_type, 4006: 20 if scale != 1.0 else 21,
                 4007: st.radius_comp, 4014: state.settable_code,
                 4015: 61 if st.cp_mode == 60 else 64}
        if n in modal:
            return float(modal[n])
        if n == 4109:
            return mm_s_to_mm_min(st.feed_mm_s) if not math.isnan(st.feed_mm_s) else 0.0
        if n == 4119:
            return float(st.spindle_rpm or 0.0)
        if 5001 <= n <= 5003 or 5041 <= n <= 5043:
            return st.pos_wcs[(n - 1) % 20] / scale
        if 5021 <= n <= 5023:
            return st.pos_mcs[n - 5021] / scale
        raise ctx.unsupported(f"system variable #{n} is not simulated", col)

    # ---- expressions -------------------------------------------------------------------------

    def value(self, ctx, expr):
        """The value of an ISO expression: a float, or None (vacant)."""
        if isinstance(expr, P.Num):
            return expr.value
        if isinstance(expr, IsoVar):
            return self.read(ctx, expr)
        if isinstance(expr, P.Unary):
            v = self.value(ctx, expr.operand)
            if v is None:
                return None
            return -v if expr.op == "-" else v
        if isinstance(expr, P.BinOp):
            return self._binop(ctx, expr)
        if isinstance(expr, P.Func):
            return self._call(ctx, expr)
        raise ctx.error(f"cannot evaluate {type(expr).__name__}", getattr(expr, "col", 0))

    def number(self, ctx, expr) -> float:
        """A value where vacant counts as 0 (arithmetic)."""
        v = self.value(ctx, expr)
        return 0.0 if v is None else v

    def truth(self, ctx, expr) -> bool:
        v = self.value(ctx, expr)
        return v is not None and v != 0.0

    def _binop(self, ctx, e: P.BinOp):
        op = e.op
        if op in ("EQ", "NE"):
            a, b = self.value(ctx, e.left), self.value(ctx, e.right)
            return 1.0 if _COMPARE[op](a, b) else 0.0
        a, b = self.number(ctx, e.left), self.number(ctx, e.right)
        if op in _COMPARE:
            return 1.0 if _COMPARE[op](a, b) else 0.0
        if op in ("AND", "OR", "XOR"):
            ia, ib = int(a), int(b)
            return float({"AND": ia & ib, "OR": ia | ib, "XOR": ia ^ ib}[op])
        if op in ("/", "MOD") and b == 0.0:
            raise ctx.error(f"division by zero ({op})", e.col)
        result = {"+": a + b, "-": a - b, "*": a * b}.get(op)
        if result is None:
            result = a / b if op == "/" else math.fmod(a, b)
        if not math.isfinite(result):
            raise ctx.error(f"result of {format_value(a)} {op} {format_value(b)} is out of "
                            f"range", e.col)
        return result

    def _call(self, ctx, e: P.Func):
        n_args, fn = FUNCTIONS[e.name]
        allowed = n_args if isinstance(n_args, tuple) else (n_args,)
        if len(e.args) not in allowed:
            raise ctx.error(f"{e.name}[..] takes {' or '.join(map(str, allowed))} "
                            f"argument(s), got {len(e.args)}", e.col)
        args = [self.number(ctx, a) for a in e.args]
        try:
            result = float(fn(*args))
        except (ValueError, OverflowError) as exc:
            raise ctx.error(f"{e.name}[..]: {exc}", e.col) from None
        if not math.isfinite(result):
            raise ctx.error(f"{e.name}[..]: result out of range", e.col)
        return result
