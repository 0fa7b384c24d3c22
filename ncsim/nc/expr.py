"""Evaluation of 840D arithmetic expressions (R parameters, user variables, functions).

840D semantics implemented here:

* values are REAL (Python float) or STRING; comparisons and logic give 1.0 / 0.0 (BOOL);
* ``/`` is real division, ``DIV`` integer division (truncated), ``MOD`` the remainder with the
  sign of the dividend; division by zero is an error at the operator;
* ``SIN COS TAN`` take degrees, ``ASIN ACOS ATAN2`` return degrees (ATAN2(y, x));
  ``SQRT ABS``; ``POT(x)`` is x squared; ``TRUNC`` cuts the fraction; ``ROUND`` rounds half
  away from zero;
* ``<<`` concatenates strings (numbers are formatted like the 840D: no trailing zeros);
* R parameters exist from the start with the value 0; a user variable must be DEFined; array
  elements ``A[i]`` and system variables ``$...`` are read through the scope
  (:mod:`ncsim.nc.variables`, :mod:`ncsim.nc.sysvars`); a bare array name is only an argument
  (for a VAR parameter), anything else done with it is an error;
* ``ISAXIS(n)`` is 1 for the geometry axes 1..3; ``LN EXP MINVAL MAXVAL`` as their names say,
  ``BOUND(min, max, x)`` limits x to [min, max];
* ``AXNAME("X")`` is the axis a string names and ``AXSTRING(axis)`` the string of an axis
  (Job planning, "Axis functions (AXNAME, AX, SPI, AXTOSPI, ISAXIS, AXSTRING, MODAXVAL)"): an
  axis value is its name; a call argument that is a bare axis identifier and no variable is
  that axis (``FGROUP(X, Y)``, ``SUB(Z)``).

Every error is an :class:`~ncsim.errors.NcSemanticError` at the column of the offending node.
"""
from __future__ import annotations

import math
import re
from typing import Callable, Protocol

from ncsim.nc import program as P
from ncsim.errors import NcSemanticError

Value = float | str
#: an axis identifier of the channel (X, Y, Z, A, B, C, U, V, W, optionally with digits: X1)
_AXIS_IDENTIFIER = re.compile(r"^[XYZABCUVW][0-9]*$")


class Scope(Protocol):
    """What an expression can read: R parameters, user variables, array elements, system
    variables (the last two get the block's context to evaluate indices and locate errors)."""

    def read_r(self, index: int) -> float: ...

    def read_var(self, name: str) -> Value | None: ...  # None: not defined

    def read_elem(self, ctx, node) -> Value: ...

    def read_sysvar(self, ctx, node) -> Value: ...


class ArrayRef(str):
    """What a bare array name reads as: good only as a VAR argument."""

    def __new__(cls, name: str):
        obj = super().__new__(cls, name)
        return obj


class Where:
    """File and line of the block being evaluated, to locate errors."""

    __slots__ = ("file", "line")

    def __init__(self, file: str, line: int):
        self.file = file
        self.line = line

    def error(self, message: str, col: int, cls=NcSemanticError):
        return cls(message, self.file, self.line, col)


def _deg_sin(x: float) -> float:
    return math.sin(math.radians(x))


def _deg_cos(x: float) -> float:
    return math.cos(math.radians(x))


def _deg_tan(x: float) -> float:
    return math.tan(math.radians(x))


def _round_half_away(x: float) -> float:
    return float(math.floor(x + 0.5)) if x >= 0 else -float(math.floor(-x + 0.5))


def _domain(check: Callable[[float], bool], fn: Callable[[float], float], what: str):
    def f(x: float) -> float:
        if not check(x):
            raise ValueError(f"{what} (argument {x:g})")
        return fn(x)
    return f


# name -> (number of arguments, function of floats)
FUNCTIONS: dict[str, tuple[int, Callable[..., float]]] = {
    "SIN": (1, _deg_sin),
    "COS": (1, _deg_cos),
    "TAN": (1, _deg_tan),
    "ASIN": (1, _domain(lambda x: -1.0 <= x <= 1.0, lambda x: math.degrees(math.asin(x)),
                        "ASIN argument outside [-1, 1]")),
    "ACOS": (1, _domain(lambda x: -1.0 <= x <= 1.0, lambda x: math.degrees(math.acos(x)),
                        "ACOS argument outside [-1, 1]")),
    "ATAN2": (2, lambda y, x: math.degrees(math.atan2(y, x))),
    "SQRT": (1, _domain(lambda x: x >= 0.0, math.sqrt, "SQRT of a negative number")),
    "ABS": (1, abs),
    "POT": (1, lambda x: x * x),
    "TRUNC": (1, lambda x: float(math.trunc(x))),
    "ROUND": (1, _round_half_away),
    "LN": (1, _domain(lambda x: x > 0.0, math.log, "LN of a number <= 0")),
    "EXP": (1, math.exp),
    "MINVAL": (2, min),
    "MAXVAL": (2, max),
    "BOUND": (3, lambda lo, hi, x: max(lo, min(hi, x))),
    "ISAXIS": (1, lambda n: 1.0 if n in (1.0, 2.0, 3.0) else 0.0),
}


def format_value(v: Value) -> str:
    """A value as ``<<`` shows it: strings as they are, numbers without trailing zeros."""
    if isinstance(v, str):
        return v
    return f"{v:.10g}"


def truthy(v: Value) -> bool:
    return v != "" if isinstance(v, str) else v != 0.0


def evaluate(expr, scope: Scope, where: Where) -> Value:
    """The value of ``expr`` (an ncsim.nc.program expression node)."""
    if isinstance(expr, P.Num):
        return expr.value
    if isinstance(expr, P.Str):
        return expr.value
    if isinstance(expr, P.RParam):
        return scope.read_r(expr.index)
    if isinstance(expr, P.Var):
        value = scope.read_var(expr.name)
        if value is None:
            raise where.error(f"undefined variable {expr.name} (DEF it first)", expr.col)
        if isinstance(value, ArrayRef):
            raise where.error(f"array {expr.name} needs an index here ({expr.name}[i])", expr.col)
        return value
    if isinstance(expr, P.Elem):
        return scope.read_elem(where, expr)
    if isinstance(expr, P.SysVar):
        return scope.read_sysvar(where, expr)
    if isinstance(expr, P.Unary):
        return _unary(expr, evaluate(expr.operand, scope, where), where)
    if isinstance(expr, P.BinOp):
        left = evaluate(expr.left, scope, where)
        right = evaluate(expr.right, scope, where)
        return _finite(_binop(expr, left, right, where), expr.col, where)
    if isinstance(expr, P.Func):
        return _finite(_call(expr, scope, where), expr.col, where)
    raise where.error(f"cannot evaluate {type(expr).__name__}", getattr(expr, "col", 0))


def evaluate_arg(expr, scope: Scope, where: Where) -> Value:
    """A call argument: like ``evaluate``, but a bare array name gives its ArrayRef (it can
    only be bound to a VAR parameter)."""
    if isinstance(expr, P.Var):
        value = scope.read_var(expr.name)
        if isinstance(value, ArrayRef):
            return value
        if value is None and _AXIS_IDENTIFIER.match(expr.name):
            return expr.name
    return evaluate(expr, scope, where)


def evaluate_number(expr, scope: Scope, where: Where, what: str) -> float:
    """``evaluate`` for a place that needs a number (axis value, F, argument)."""
    value = evaluate(expr, scope, where)
    if isinstance(value, str):
        raise where.error(f"{what} needs a number, got the string {value!r}", _col(expr))
    return value


def _col(expr) -> int:
    return getattr(expr, "col", 0)


def _finite(value: Value, col: int, where: Where) -> Value:
    if isinstance(value, float) and not math.isfinite(value):
        raise where.error("arithmetic overflow (result is not a finite number)", col)
    return value


def _number_operand(v: Value, op: str, col: int, where: Where) -> float:
    if isinstance(v, str):
        raise where.error(f"operator {op} needs numbers, got the string {v!r}", col)
    return v


def _unary(expr: P.Unary, v: Value, where: Where) -> Value:
    if expr.op == "NOT":
        return 0.0 if truthy(v) else 1.0
    x = _number_operand(v, expr.op, expr.col, where)
    if expr.op == "-":
        return -x
    if expr.op == "B_NOT":
        return float(~int(x))
    return x


_COMPARE = {
    "==": lambda a, b: a == b, "<>": lambda a, b: a != b, "<": lambda a, b: a < b,
    ">": lambda a, b: a > b, "<=": lambda a, b: a <= b, ">=": lambda a, b: a >= b,
}


def _binop(expr: P.BinOp, a: Value, b: Value, where: Where) -> Value:
    op = expr.op
    if op == "<<":
        return format_value(a) + format_value(b)
    if op in _COMPARE:
        if isinstance(a, str) != isinstance(b, str):
            raise where.error(f"cannot compare a string with a number ({op})", expr.col)
        return 1.0 if _COMPARE[op](a, b) else 0.0
    if op in ("AND", "OR", "XOR"):
        ta, tb = truthy(a), truthy(b)
        result = {"AND": ta and tb, "OR": ta or tb, "XOR": ta != tb}[op]
        return 1.0 if result else 0.0
    x = _number_operand(a, op, expr.col, where)
    y = _number_operand(b, op, expr.col, where)
    if op in ("B_AND", "B_OR", "B_XOR"):
        ix, iy = int(x), int(y)
        return float({"B_AND": ix & iy, "B_OR": ix | iy, "B_XOR": ix ^ iy}[op])
    if op in ("/", "DIV", "MOD") and y == 0.0:
        raise where.error(f"division by zero ({op})", expr.col)
    result = _ARITHMETIC[op](x, y)
    if not math.isfinite(result):  # a REAL overflows (the 840D stops with an alarm too)
        raise where.error(f"result of {format_value(x)} {op} {format_value(y)} is out of the "
                          "range of a REAL", expr.col)
    return float(result)


_ARITHMETIC = {
    "+": lambda x, y: x + y, "-": lambda x, y: x - y, "*": lambda x, y: x * y,
    "/": lambda x, y: x / y, "MOD": math.fmod,
    "DIV": lambda x, y: q if not math.isfinite(q := x / y) else math.trunc(q),
}


def _call(expr: P.Func, scope: Scope, where: Where) -> Value:
    name = expr.name
    if name in ("AC", "IC"):
        raise where.error(f"{name}() is only allowed as the whole value of an axis or centre word",
                          expr.col)
    if name in ("AXNAME", "AXSTRING"):
        return _axis_function(expr, scope, where)
    if name not in FUNCTIONS:
        raise where.error(f"unknown function {name}()", expr.col)
    n_args, fn = FUNCTIONS[name]
    if len(expr.args) != n_args or any(a is None for a in expr.args):
        raise where.error(f"{name}() takes {n_args} argument{'s' if n_args > 1 else ''}, "
                          f"got {len(expr.args)}", expr.col)
    args = [evaluate_number(a, scope, where, f"{name}()") for a in expr.args]
    try:
        return float(fn(*args))
    except (ValueError, OverflowError) as exc:
        raise where.error(f"{name}(): {exc}", expr.col) from None


def _axis_function(expr: P.Func, scope: Scope, where: Where) -> str:
    """``AXNAME("X")``: the axis a string names; ``AXSTRING(X)``: an axis as a string. Axis
    values are their names, so both give the name, checked to be an axis identifier."""
    if len(expr.args) != 1 or expr.args[0] is None:
        raise where.error(f"{expr.name}() takes 1 argument, got {len(expr.args)}", expr.col)
    arg = expr.args[0]
    value = evaluate_arg(arg, scope, where) if expr.name == "AXSTRING" else evaluate(arg, scope, where)
    if not isinstance(value, str) or not _AXIS_IDENTIFIER.match(value.strip().upper()):
        raise where.error(f"{expr.name}(): {format_value(value)!r} is no axis name of the "
                          f"channel (X, Y, Z, A, B, C, U, V, W)", _col(arg))
    return value.strip().upper()
