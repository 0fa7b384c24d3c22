"""Variables of an 840D program: R parameters and the user variables of DEF and PROC.

840D semantics (Programming Guide Fundamentals, "Arithmetic parameters and program jumps";
Programming Guide Advanced, "Flexible NC programming", variable definition):

* R parameters are global, exist from the start and read 0 until assigned; they hold numbers;
* a user variable is local to its unit (main program or PROC) and must be DEFined before use;
  a PROC's parameters are its first variables (a missing argument keeps the type's default);
* REAL INT BOOL hold numbers, STRING CHAR strings; INT rounds half away from zero, BOOL is 1 or
  0; arrays and other types are not simulated (an error, never a silent value).

:class:`Variables` is the ``Scope`` of :func:`ncsim.nc.expr.evaluate` (it reads) and the one
place that writes. New variable kinds (arrays, system variables that matter, VAR parameters)
go here.
"""
from __future__ import annotations

import math

from ncsim.nc import program as P
from ncsim.nc.expr import format_value
from ncsim.nc.modal import CYCLE832_CONSTANTS

VAR_TYPES = {"REAL": 0.0, "INT": 0.0, "BOOL": 0.0, "STRING": "", "CHAR": ""}   # type -> default


class Variables:
    """R parameters and the user variables of the current call frame (the top of ``stack``)."""

    def __init__(self, stack: list) -> None:
        self.r: dict[int, float] = {}
        self.stack = stack                 # the interpreter's call stack (CallFrames)

    def read_r(self, index: int) -> float:
        return self.r.get(index, 0.0)

    def read_var(self, name: str):
        entry = self.stack[-1].variables.get(name)
        if entry is None:   # the cycle package's predefined names (_FINISH, ...): CYCLE832
            return CYCLE832_CONSTANTS.get(name)
        return entry[1]

    def bind_params(self, frame, params: tuple, args: tuple) -> None:
        """A PROC's parameters as its first variables, with the call's arguments."""
        for param, value in zip(params, args):
            frame.variables[param.name] = [param.type_name, VAR_TYPES.get(param.type_name, 0.0)]
            if value is not None:
                frame.variables[param.name][1] = value

    def define(self, ctx, s: P.Def) -> None:
        """DEF type name[=value], ...: new variables of the current unit."""
        if s.type_name not in VAR_TYPES:
            raise ctx.unsupported(f"variables of type {s.type_name} are not simulated", s.col)
        variables = ctx.frame.variables
        for v in s.variables:
            if v.dims:
                raise ctx.unsupported(f"array variable {v.name} is not simulated", v.col)
            variables[v.name] = [s.type_name, VAR_TYPES[s.type_name]]
            if v.init is not None:
                self.assign(ctx, P.Var(v.name, v.col), ctx.eval(v.init))

    def read_target(self, ctx, var) -> float:
        """The value of an assignment target (R parameter or variable) that must exist."""
        if isinstance(var, P.RParam):
            return self.read_r(var.index)
        value = self.read_var(var.name)
        if value is None:
            raise ctx.error(f"undefined variable {var.name} (DEF it first)", var.col)
        return value

    def assign(self, ctx, target, value) -> None:
        if isinstance(target, P.RParam):
            if isinstance(value, str):
                raise ctx.error(f"R{target.index} needs a number, got a string", target.col)
            self.r[target.index] = value
            return
        entry = ctx.frame.variables.get(target.name)
        if entry is None:
            raise ctx.error(f"unknown word or undefined variable {target.name}", target.col)
        kind = entry[0]
        if (kind in ("STRING", "CHAR")) != isinstance(value, str):
            raise ctx.error(f"{target.name} is {kind}: cannot assign {format_value(value)!r}",
                            target.col)
        if kind == "INT":
            value = float(math.floor(value + 0.5)) if value >= 0 else -float(math.floor(-value + 0.5))
        elif kind == "BOOL":
            value = 1.0 if value != 0.0 else 0.0
        entry[1] = value
