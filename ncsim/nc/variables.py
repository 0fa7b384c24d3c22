"""Variables of an 840D program: R parameters, DEF and PROC variables, arrays and GUD variables.

840D semantics (Programming Manual Fundamentals, "Arithmetic parameters"; Programming Manual
Job planning, "Flexible NC programming": "Variables", "Definition and initialization of array
variables (DEF, SET, REP)", "Subprogram technique"):

* R parameters are global, exist from the start and read 0 until assigned; they hold numbers;
  ``R[expr]`` addresses one indirectly;
* a user variable is local to its unit (main program or PROC) and must be DEFined before use;
  a PROC's parameters are its first variables (a missing argument keeps the type's default);
  a ``VAR`` parameter is the caller's variable itself (call by reference), also a whole array;
* REAL INT BOOL hold numbers, STRING CHAR strings, AXIS an axis name (``_Z=$P_AXN3``); INT
  rounds half away from zero, BOOL is 1 or 0; FRAME and other types are not simulated;
* arrays ``DEF REAL A[n]``, ``A[n,m]`` (up to three dimensions) are indexed from 0; they are
  initialised with ``=SET(v, ...)`` or ``=(v, ...)`` (the last index running fastest) or
  ``=REP(v)`` (every element); ``A[i,j]=SET(...)``/``REP(v)`` fill from that element on;
  unset elements are 0 (or "");
* global user variables (GUD, ``DEF NCK``/``DEF CHAN`` in a definitions file such as
  ``MGUD.DEF``) are read and written like local ones, from every unit (:func:`load_definitions`);
  their initialisers may name the variables defined before them (``DEF CHAN REAL UB=UA+1``);
* a variable's name is an identifier: its first two characters are letters or underscores
  (Programming Manual Fundamentals, "Language elements of the programming language",
  "Identifiers"), and one identifier names one object ("Names": "the same identifier must not
  be used for different objects"). A name of one letter, or of a letter and digits (``B``,
  ``X1``, ``R10``), is an NC address: the control rejects such a DEF or PROC parameter, and
  so does :func:`check_name` (the address would otherwise silently become an axis word);
* an AXIS variable holds an axis name: ``_AX=Y``, ``DEF AXIS _AX=(Z)`` (an axis identifier
  where an AXIS value is expected), ``AXNAME("Y")`` (Job planning, "Axis functions (AXNAME,
  AX, SPI, AXTOSPI, ISAXIS, AXSTRING, MODAXVAL)").

:class:`Variables` is the ``Scope`` of :func:`ncsim.nc.expr.evaluate` (it reads) and the one
place that writes.
"""
from __future__ import annotations

import math
import re

from ncsim.nc import program as P
from ncsim.nc.expr import ArrayRef, format_value
from ncsim.nc.modal import CYCLE832_CONSTANTS

VAR_TYPES = {"REAL": 0.0, "INT": 0.0, "BOOL": 0.0, "STRING": "", "CHAR": "", "AXIS": ""}
STRING_TYPES = ("STRING", "CHAR", "AXIS")
MAX_ARRAY_ELEMENTS = 1_000_000      # a DEF larger than this is refused (memory)
#: what an identifier begins with (Fundamentals, "Identifiers": two letters or underscores)
_IDENTIFIER = re.compile(r"^[A-Z_][A-Z_]")
#: axis identifiers of a channel an AXIS value may name (geometry, rotary and additional axes,
#: with an optional numeric extension as machine axes are named: X1, Z2)
AXIS_IDENTIFIER = re.compile(r"^[XYZABCUVW][0-9]*$")


def check_name(where, name: str, col: int, what: str = "variable") -> None:
    """Reject a user variable or PROC parameter named like an NC address (``B``, ``X1``,
    ``R10``): Fundamentals, "Identifiers", the first two characters of an identifier are letters
    or underscores, and "Names", one identifier names one object (an axis, an address or a
    variable, never two of them)."""
    if _IDENTIFIER.match(name):
        return
    kind = ("the axis " + name.rstrip("0123456789") if AXIS_IDENTIFIER.match(name)
            else "an NC address")
    raise where.error(f"{what} name {name} is {kind}, not an identifier: the control rejects "
                      f"it (a name begins with two letters or underscores, e.g. _{name} or "
                      f"U{name})", col)


def axis_name(expr, entry) -> str | None:
    """The axis an expression names where an AXIS value is expected: a bare axis identifier
    (``_AX=Y``, ``DEF AXIS _AX=(Z)``) that is no variable (``entry`` None), else None."""
    if isinstance(expr, P.Var) and entry is None and AXIS_IDENTIFIER.match(expr.name):
        return expr.name
    return None


class RDict(dict):
    """R parameters: a dict that reads 0.0 for a parameter never assigned."""

    def __missing__(self, key):
        return 0.0


class ArrayValue:
    """The elements of an array variable, row-major (the last index runs fastest)."""

    __slots__ = ("dims", "data")

    def __init__(self, dims: tuple, default) -> None:
        self.dims = dims
        self.data = [default] * math.prod(dims)

    def offset(self, ctx, name: str, index: tuple, col: int) -> int:
        if len(index) != len(self.dims):
            raise ctx.error(f"array {name} has {len(self.dims)} dimension"
                            f"{'s' if len(self.dims) > 1 else ''}, got {len(index)} indices", col)
        k = 0
        for i, n in zip(index, self.dims):
            if isinstance(i, str) or i != int(i) or not 0 <= i < n:
                raise ctx.error(f"index {format_value(i)} of {name} is outside 0..{n - 1}", col)
            k = k * n + int(i)
        return k


class Variables:
    """R parameters, the user variables of the current call frame (the top of ``stack``) and
    the global user variables."""

    def __init__(self, stack: list) -> None:
        self.r: RDict = RDict()
        self.stack = stack                 # the interpreter's call stack (CallFrames)
        self.globals: dict = {}            # GUD: name -> [type, value]
        self.sysvars = None                # ncsim.nc.sysvars.SystemVariables

    # ---- reading (the Scope of expressions) ----------------------------------------------------

    def read_r(self, index: int) -> float:
        return self.r[index]

    def entry(self, name: str):
        """The [type, value] of a variable of the current unit or a global one, or None."""
        e = self.stack[-1].variables.get(name) if self.stack else None
        return self.globals.get(name) if e is None else e

    def read_var(self, name: str):
        entry = self.entry(name)
        if entry is None:   # the cycle package's predefined names (_FINISH, ...): CYCLE832
            return CYCLE832_CONSTANTS.get(name)
        value = entry[1]
        if isinstance(value, ArrayValue):
            return ArrayRef(name)
        return value

    def read_elem(self, ctx, node: P.Elem):
        """``A[i, j]`` or ``R[i]``."""
        index = tuple(ctx.eval(i) for i in node.index)
        if node.name == "R" and self.entry("R") is None:
            return self.read_r(self._r_index(ctx, index, node.col))
        array = self._array(ctx, node.name, node.col)
        return array.data[array.offset(ctx, node.name, index, node.col)]

    def read_sysvar(self, ctx, node):
        """``$...``: :mod:`ncsim.nc.sysvars` (set by the interpreter's state)."""
        return self.sysvars.read(ctx, node)

    def _array(self, ctx, name: str, col: int) -> ArrayValue:
        entry = self.entry(name)
        if entry is None:
            raise ctx.error(f"undefined variable {name} (DEF it first)", col)
        if not isinstance(entry[1], ArrayValue):
            raise ctx.error(f"{name} is not an array", col)
        return entry[1]

    @staticmethod
    def _r_index(ctx, index: tuple, col: int) -> int:
        if len(index) != 1 or isinstance(index[0], str) or index[0] != int(index[0]) or index[0] < 0:
            raise ctx.error("R[...] needs one whole number >= 0", col)
        return int(index[0])

    # ---- definitions ---------------------------------------------------------------------------

    def bind_params(self, frame, params: tuple, args: tuple, refs: dict | None = None) -> None:
        """A PROC's parameters as its first variables: the call's arguments, the type's default
        for a missing one, the caller's variable itself for a VAR parameter (``refs``)."""
        for k, param in enumerate(params):
            if refs and param.name in refs:
                frame.variables[param.name] = refs[param.name]
                continue
            if param.dims:
                frame.variables[param.name] = [param.type_name, ArrayValue(
                    param.dims, VAR_TYPES.get(param.type_name, 0.0))]
                continue
            entry = frame.variables[param.name] = [param.type_name,
                                                   VAR_TYPES.get(param.type_name, 0.0)]
            value = args[k] if k < len(args) else None
            if value is not None:
                entry[1] = _convert(param.type_name, value)

    def define(self, ctx, s: P.Def, into: dict | None = None) -> None:
        """DEF type name[=value], ...: new variables of the current unit (or of ``into``)."""
        if s.type_name not in VAR_TYPES:
            raise ctx.unsupported(f"variables of type {s.type_name} are not simulated", s.col)
        variables = ctx.frame.variables if into is None else into
        default = VAR_TYPES[s.type_name]
        for v in s.variables:
            check_name(ctx, v.name, v.col)
            if v.dims:
                if len(v.dims) > 3 or any(n < 1 for n in v.dims):
                    raise ctx.error(f"array {v.name}: 1 to 3 dimensions of at least 1 element",
                                    v.col)
                if math.prod(v.dims) > MAX_ARRAY_ELEMENTS:
                    raise ctx.unsupported(f"array {v.name} has more than {MAX_ARRAY_ELEMENTS} "
                                          f"elements", v.col)
                entry = variables[v.name] = [s.type_name, ArrayValue(v.dims, default)]
                if v.init is not None:
                    self._fill(ctx, v.name, entry, 0, v.init)
                continue
            entry = variables[v.name] = [s.type_name, default]
            if v.init is not None:
                if isinstance(v.init, P.InitList):
                    raise ctx.error(f"{v.name} is not an array: one value, not a list", v.col)
                entry[1] = self._checked(ctx, v.name, s.type_name, self.value_of(ctx, s.type_name,
                                                                                v.init), v.col)

    def value_of(self, ctx, kind: str, expr):
        """The value of ``expr`` assigned to a variable of type ``kind``: for AXIS a bare
        axis identifier is the axis name (:func:`axis_name`)."""
        if kind == "AXIS":
            name = axis_name(expr, self.entry(expr.name) if isinstance(expr, P.Var) else None)
            if name is not None:
                return name
        return ctx.eval(expr)

    def _fill(self, ctx, name: str, entry: list, start: int, expr) -> None:
        """SET(...), (...) or REP(v[, n]) into an array from the flat element ``start`` on."""
        kind, array = entry[0], entry[1]
        if isinstance(expr, P.InitList) or (isinstance(expr, P.Func) and expr.name == "SET"):
            values = expr.values if isinstance(expr, P.InitList) else expr.args
            if start + len(values) > len(array.data):
                raise ctx.error(f"{len(values)} values do not fit {name} from this element on",
                                _col(expr))
            for k, e in enumerate(values):
                if e is not None:
                    array.data[start + k] = self._checked(ctx, name, kind, ctx.eval(e), _col(e))
            return
        if isinstance(expr, P.Func) and expr.name == "REP":
            if not 1 <= len(expr.args) <= 2 or expr.args[0] is None:
                raise ctx.error("REP() takes a value and optionally a count", expr.col)
            value = self._checked(ctx, name, kind, ctx.eval(expr.args[0]), expr.col)
            n = len(array.data) - start
            if len(expr.args) == 2 and expr.args[1] is not None:
                n = ctx.whole_number(ctx.number(expr.args[1], "REP"), "REP", expr.col)
                if start + n > len(array.data):
                    raise ctx.error(f"REP: {n} elements do not fit {name}", expr.col)
            array.data[start:start + n] = [value] * n
            return
        raise ctx.error(f"array {name} is set with SET(...), REP(...) or (v1, v2, ...), or one "
                        f"element at a time ({name}[i]=...)", _col(expr))

    # ---- writing -------------------------------------------------------------------------------

    def read_target(self, ctx, var) -> float:
        """The value of an assignment target (R parameter or variable) that must exist."""
        if isinstance(var, P.RParam):
            return self.read_r(var.index)
        value = self.read_var(var.name)
        if value is None:
            raise ctx.error(f"undefined variable {var.name} (DEF it first)", var.col)
        return value

    def assign_expr(self, ctx, target, expr) -> None:
        """``target = expr``: the value as the target's type reads it (:meth:`value_of`)."""
        entry = self.entry(target.name) if isinstance(target, P.Var) else None
        kind = entry[0] if entry is not None else None
        self.assign(ctx, target, self.value_of(ctx, kind, expr) if kind == "AXIS"
                    else ctx.eval(expr))

    def assign(self, ctx, target, value) -> None:
        if isinstance(target, P.RParam):
            if isinstance(value, str):
                raise ctx.error(f"R{target.index} needs a number, got a string", target.col)
            self.r[target.index] = value
            return
        if isinstance(target, P.Elem):
            self.assign_elem(ctx, target, value)
            return
        entry = ctx.frame.variables.get(target.name) or self.globals.get(target.name)
        if entry is None:
            raise ctx.error(f"unknown word or undefined variable {target.name}", target.col)
        if isinstance(entry[1], ArrayValue):
            raise ctx.error(f"{target.name} is an array: assign its elements ({target.name}[i]=..)",
                            target.col)
        entry[1] = self._checked(ctx, target.name, entry[0], value, target.col)

    def assign_elem(self, ctx, target: P.Elem, value_or_expr, expr=None) -> None:
        index = tuple(ctx.eval(i) for i in target.index)
        if target.name == "R" and self.entry("R") is None:
            if isinstance(value_or_expr, str):
                raise ctx.error("R[...] needs a number, got a string", target.col)
            self.r[self._r_index(ctx, index, target.col)] = value_or_expr
            return
        entry = self.entry(target.name)
        array = self._array(ctx, target.name, target.col)
        k = array.offset(ctx, target.name, index, target.col)
        if expr is not None:
            self._fill(ctx, target.name, entry, k, expr)
            return
        array.data[k] = self._checked(ctx, target.name, entry[0], value_or_expr, target.col)

    @staticmethod
    def _checked(ctx, name: str, kind: str, value, col: int):
        if isinstance(value, ArrayRef):
            raise ctx.error(f"array {value} needs an index here", col)
        if (kind in STRING_TYPES) != isinstance(value, str):
            raise ctx.error(f"{name} is {kind}: cannot assign {format_value(value)!r}", col)
        return _convert(kind, value)


def _convert(kind: str, value):
    if kind == "INT":
        return float(math.floor(value + 0.5)) if value >= 0 else -float(math.floor(-value + 0.5))
    if kind == "BOOL":
        return 1.0 if value != 0.0 else 0.0
    return value


def _col(expr) -> int:
    return getattr(expr, "col", 0)


def load_definitions(state, path) -> None:
    """Read a GUD definitions file (``MGUD.DEF``, ``UGUD.DEF``, ``GUD4.DEF`` ...): its
    ``DEF NCK|CHAN type name[dims][=init], ...`` lines define global user variables
    (Job planning, "Global user data (GUD)"). Comments, ``%_N_..._DEF``/``;$PATH=`` headers and
    the closing M30/M17 are allowed; any other block is an error at its line."""
    from ncsim.nc.context import BlockContext, CallFrame
    from ncsim.nc.flow import Unit
    from ncsim.nc.parse import parse_text, read_program_text

    text = read_program_text(path, "definitions file")
    program = parse_text(text, str(path), fast=False)
    frame = CallFrame(Unit("DEFINITIONS", str(path), []), 0)
    for block in program.blocks():
        ctx = BlockContext(state, frame, block.line)
        s = block.statement
        if isinstance(s, P.Def):
            state.vars.define(ctx, s, into=state.vars.globals)
            continue
        if s is None and all(isinstance(i, P.Word) and i.address == "M" and
                             isinstance(i.value, P.Num) and i.value.value in (2.0, 17.0, 30.0)
                             for i in block.items):
            continue
        col = s.col if s is not None else block.items[0].col
        raise ctx.error("a definitions file holds DEF lines only (DEF NCK|CHAN type name ...)",
                        col)
