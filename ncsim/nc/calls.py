"""Subprogram calls, the built-in cycles and the end of a program or subprogram.

840D semantics (Programming Guide Fundamentals, "Subprograms and repetition of program
sections"; Programming Guide Advanced, "Subprogram technique"):

* a subprogram is called by its name (``NAME``, ``NAME(args)``) or as ``L<n>``; ``P<n>`` in the
  same block repeats it n times; one call per block, and never with M2/M30/M17/RET;
* a name is looked up as a PROC of the same text, then as ``NAME.SPF``/``NAME.MPF`` next to the
  calling program (:meth:`Calls.find_unit`); call-by-reference (VAR) parameters are not
  simulated; nesting is limited to 16 levels (the default of the 840D's machine data);
* M17/RET return, M2/M30 end the program, GOTOS jumps to its start.

Cycles: ``CYCLE832`` (high speed settings) is simulated (:meth:`Calls._cycle832`); ``MSG`` is
recorded, ``CYCLE800`` recorded with a warning (it changes the geometry); any other standard
cycle name (``CYCLE81``, ``POCKET3``, ...) without a PROC of that name is recorded with a
warning and makes no motion. A new built-in cycle is one handler in :attr:`Calls.builtins`.
"""
from __future__ import annotations

import math
import re

from ncsim.nc.context import CallFrame
from ncsim.nc.expr import Where, format_value
from ncsim.nc.flow import Unit, is_proc, split_units
from ncsim.nc.modal import (CYCLE832_DYNAMICS, CYCLE832_TYPE_NAMES, M_END, M_END_RESET,
                            M_RETURN)
from ncsim.nc.parse import parse_text, read_program_text
from ncsim.nc.settings import HANDLED_COMMANDS, Settings

MAX_CALL_DEPTH = 16          # subprogram nesting (the 840D allows 16 levels with its default MD)
SUBPROGRAM_SUFFIXES = (".SPF", ".spf", ".MPF", ".mpf")
_STANDARD_CYCLES = re.compile(r"^(CYCLE\d+|POCKET\d|SLOT\d|LONGHOLE|HOLES\d|E_[A-Z_]+|F_[A-Z_]+)$")


def is_standard_cycle(name: str) -> bool:
    return _STANDARD_CYCLES.match(name) is not None


class Calls:
    """The call stack: pushing units, calling subprograms and cycles, returning and ending."""

    def __init__(self, state) -> None:
        self.state = state
        self.builtins = {"MSG": self._msg, "CYCLE832": self._cycle832, "CYCLE800": self._cycle800}
        self.settings = Settings(state)

    # ---- the stack ---------------------------------------------------------------------------

    def push(self, unit: Unit, args: tuple, repeats: int) -> None:
        state = self.state
        if len(state.stack) >= MAX_CALL_DEPTH:
            raise Where(unit.file, 0).error(f"subprogram nesting deeper than {MAX_CALL_DEPTH} "
                                            f"levels", 0)
        fr = CallFrame(unit, state.out.builder.file_index(unit.file),
                       pc=1 if is_proc(unit) else 0, args=args, repeats_left=repeats)
        state.vars.bind_params(fr, unit.params, args)
        state.stack.append(fr)

    def return_(self) -> None:
        """Leave the current unit (its end, M17 or RET); a repeated call (P) runs it again."""
        fr = self.state.stack.pop()
        if fr.repeats_left > 1:
            self.push(fr.unit, fr.args, fr.repeats_left - 1)

    # ---- finding units -----------------------------------------------------------------------

    def add_units(self, units: list[Unit]) -> None:
        known = self.state.units
        for u in units:
            if u.name in known:
                first = known[u.name]
                raise Where(u.file, u.items[0].line).error(
                    f"PROC {u.name} defined twice (first in {first.file} line "
                    f"{first.items[0].line})", 1)
            known[u.name] = u

    def find_unit(self, name: str) -> Unit | None:
        state = self.state
        if name in state.units:
            return state.units[name]
        if state.search_dir is None:
            return None
        for suffix in SUBPROGRAM_SUFFIXES:
            candidate = state.search_dir / f"{name}{suffix}"
            if _is_file(candidate):
                program = parse_text(read_program_text(candidate), str(candidate), fast=state.fast)
                units = split_units(program, name)
                self.add_units(units[1:])
                state.units.setdefault(name, units[0])
                return units[0]
        return None

    # ---- calls in a block --------------------------------------------------------------------

    def block_calls(self, ctx) -> None:
        """The block's subprogram call (L, P, a name, a name with arguments) or its cycles."""
        repeats = 1
        if "P" in ctx.values:
            value, col = ctx.values["P"]
            repeats = ctx.whole_number(value, "P", col)
            if repeats < 1:
                raise ctx.error("P (repetitions) must be at least 1", col)
        targets = []
        if "L" in ctx.values:
            value, col = ctx.values["L"]
            targets.append((f"L{ctx.whole_number(value, 'L', col)}", (), col))
        for name, col in ctx.commands:
            if name not in HANDLED_COMMANDS:
                targets.append((name, (), col))
        for name, args, col in ctx.calls:
            if self._builtin_call(ctx, name, args, col):
                continue
            targets.append((name, args, col))
        if not targets and "P" in ctx.values:
            raise ctx.error("P (repetitions) without a subprogram call", ctx.values["P"][1])
        if len(targets) > 1:
            name, _, col = targets[1]
            raise ctx.error(f"second subprogram call {name} in one block", col)
        if targets and (any(code in (M_END, M_END_RESET, M_RETURN) for code, _ in ctx.m)
                        or any(name == "RET" for name, _ in ctx.commands)):
            raise ctx.error(f"subprogram call {targets[0][0]} together with the end of the "
                            f"program or a return in one block", targets[0][2])
        for name, args, col in targets:
            self._call(ctx, name, args, repeats, col)

    def _call(self, ctx, name: str, args: tuple, repeats: int, col: int) -> None:
        unit = self.find_unit(name)
        if unit is None:
            raise ctx.error(f"unknown word {name} (no such command, PROC or subprogram file)", col)
        if len(args) > len(unit.params):
            raise ctx.error(f"{name} takes {len(unit.params)} arguments, got {len(args)}", col)
        for param in unit.params:
            if param.by_reference:
                raise ctx.unsupported(f"call-by-reference parameter {param.name} (VAR) of {name} "
                                      f"is not simulated", col)
        if len(self.state.stack) >= MAX_CALL_DEPTH:
            raise ctx.error(f"subprogram nesting deeper than {MAX_CALL_DEPTH} levels", col)
        self.push(unit, args, repeats)

    # ---- built-in cycles ---------------------------------------------------------------------

    def _builtin_call(self, ctx, name: str, args: tuple, col: int) -> bool:
        """CYCLE832, MSG and the standard cycles: recorded (with a warning when it matters)."""
        handler = self.builtins.get(name)
        if handler is not None:
            handler(ctx, name, args, col)
            return True
        if is_standard_cycle(name) and name not in self.state.units:
            ctx.record(name, args)
            ctx.warn("cycle", f"{name}: machining cycle not simulated (no motion generated)", col)
            return True
        return False

    def _msg(self, ctx, name: str, args: tuple, col: int) -> None:
        ctx.record("MSG", args)

    def _cycle832(self, ctx, name: str, args: tuple, col: int) -> None:
        """CYCLE832(S_TOL, S_TOLM, S_OTOL) "High speed settings" (SINUMERIK NC programming manual
        12/2019, "Programming cycles externally"; Operate commissioning "High speed settings").

        S_TOL is the contour tolerance (CTOL); S_TOLM's units digit the machining type (0
        deselection, 1 finishing, 2 rough-finishing, 3 roughing, 4 smooth finishing; the
        predefined names _OFF, _FINISH, _SEMIFIN, _ROUGH and the _ORI_ forms), its tens digit 1
        makes S_OTOL the orientation tolerance (OTOL, recorded); ``CYCLE832()`` deselects. What a
        machining type switches -- G642/G645, COMPCAD..., SOFT, FFWON -- is the machine
        builder's CUST_832: the machine file's ``[cycle832]`` table (:meth:`Settings.cycle832`).
        Higher digits (old packed codes such as 102001, the Top Surface digit) are not decoded:
        the machining type is simulated and a warning says so. Tolerance 0 deselects (a
        secondary source, warned)."""
        ctx.record(name, args)
        state = self.state
        tol, mode, otol = (tuple(args) + (None, None, None))[:3]
        shown = ", ".join("" if a is None else format_value(a) for a in args)
        if not args:
            units, tol = 0, 0.0
        else:
            if tol is None or isinstance(tol, str) or tol < 0.0:
                raise ctx.error(f"CYCLE832({shown}): the tolerance S_TOL must be a number >= 0", col)
            if mode is None:
                ctx.warn("CYCLE832", f"CYCLE832({shown}) without a machining type: taken as "
                         f"finishing (_FINISH)", col)
                mode = 1.0
            if isinstance(mode, str):
                raise ctx.error(f"CYCLE832({shown}): the machining type must be a number", col)
            code = ctx.whole_number(mode, "CYCLE832 machining type ", col)
            units = code % 10
            if units >= len(CYCLE832_TYPE_NAMES):
                raise ctx.error(f"CYCLE832({shown}): machining type digit {units} is not defined "
                                f"(0 deselection .. 4 smooth finishing)", col)
            if code >= 100:
                ctx.warn("CYCLE832", f"CYCLE832({shown}): only the machining type of code {code} "
                         f"is simulated (units digit {units}: {CYCLE832_TYPE_NAMES[units]}); its "
                         f"higher digits (old packed code or Top Surface) are not decoded, the "
                         f"machine file's [cycle832] table applies", col)
            if tol == 0.0 and units != 0:
                ctx.warn("CYCLE832", f"CYCLE832({shown}): tolerance 0 taken as deselection", col)
                units = 0
            st = state.st
            st.otol_deg = (otol if (code // 10) % 10 == 1 and isinstance(otol, float) and otol >= 0
                           else math.nan)
        machine = state.machine
        spec = machine.cycle832 if machine is not None else None
        if spec is None:
            from ncsim.machine import Cycle832Spec
            spec = Cycle832Spec()
        tolerance = math.nan if units == 0 else tol * state.st.length_scale
        self.settings.cycle832(ctx, spec.expansion(units), tolerance)
        if units == 0:
            state.st.otol_deg = math.nan
        ctx.record(CYCLE832_DYNAMICS[units], ())
        notes = state.cycle832_notes
        if units != 0 and "dynamics" not in notes:
            notes.add("dynamics")
            ctx.warn("CYCLE832", f"CYCLE832 selects {CYCLE832_DYNAMICS[units]}: the dynamic "
                     f"response of this technology group (MD20600 ff. per group) is not "
                     f"simulated, the machine file's one set of dynamics is used", col)
        if not spec.from_file and "defaults" not in notes:
            notes.add("defaults")
            ctx.warn("CYCLE832", "CYCLE832: the machine file has no [cycle832] table; the usual "
                     "CUST_832 settings are used (G642, COMPCAD, SOFT, FFWON; deselection to the "
                     "reset values)", col)

    def _cycle800(self, ctx, name: str, args: tuple, col: int) -> None:
        ctx.record(name, args)
        ctx.warn("CYCLE800", "CYCLE800 swivel plane (5-axis) is not simulated: X/Y/Z are used "
                 "as programmed", col)

    # ---- end of the block --------------------------------------------------------------------

    def program_end(self, ctx) -> None:
        """M2/M30 end the program, M17/RET return from a subprogram, GOTOS restarts it."""
        codes = {code for code, _ in ctx.m}
        if M_END in codes or M_END_RESET in codes:
            self.state.ended = True
        elif M_RETURN in codes or any(name == "RET" for name, _ in ctx.commands):
            self.return_()
        elif any(name == "GOTOS" for name, _ in ctx.commands):
            fr = ctx.frame
            fr.pc, fr.row = (1 if is_proc(fr.unit) else 0), 0


def _is_file(path) -> bool:
    """Whether ``path`` is a readable file; a name the file system cannot hold (longer than
    its limit, e.g. a 300-character word taken as a subprogram name) is no file."""
    try:
        return path.is_file()
    except OSError:
        return False
