"""Subprogram calls, modal calls, the built-in cycles and the end of a program or subprogram.

840D semantics (Programming Manual Fundamentals, "Subprograms"; Programming Manual Job
planning, "Subprogram technique", "Modal subprogram call (MCALL)"):

* a subprogram is called by its name (``NAME``, ``NAME(args)``) or as ``L<n>``; ``P<n>`` in the
  same block repeats it n times; one call per block, and never with M2/M30/M17/RET;
* the control finds a subprogram (:class:`SubprogramFinder`) as a PROC of a loaded text, else
  as a file ``NAME.MPF``/``NAME.SPF`` (or ``_N_NAME_MPF``/``_N_NAME_SPF``, names compared without
  case) in the caller's folder, the main program's folder and the ``--subprograms`` folders,
  in this order. A cycle that looks standard (``CYCLE82``, ``HOLES2``) is executed from its
  file when there is one; without a file it is recorded with a warning and makes no motion.
  A subprogram that is nowhere is an error naming the folders searched, or with
  ``--missing-subprograms warn`` a warning (no motion, the result is approximate);
* a PROC's parameters are passed by value, ``VAR`` ones by reference (the caller's variable or
  array itself); a parameter named like an NC address (``B``, ``X1``) is rejected at the PROC
  line (:func:`ncsim.nc.variables.check_name`); ``SAVE`` restores the modal G functions and frames at the return; nesting is
  limited to 16 levels (the default of the 840D's machine data);
* ``MCALL NAME(args)`` calls NAME after every later block with path motion, except inside the
  modal subprogram and what it calls; ``MCALL`` alone ends it;
* ``SETAL(n)`` sets a cycle alarm: 62000-62999 are messages (a warning, the program goes on),
  every other alarm stops the program (an error at the SETAL); ``SETMS(n)``/``SETMS`` select
  the master spindle; ``MSG`` is recorded;
* M17/RET return, M2/M30 end the program, GOTOS jumps to its start.

Built-in cycles: ``CYCLE832`` (high speed settings) is simulated (:meth:`Calls._cycle832`; a
file of that name does not replace it); ``CYCLE800`` is recorded with a warning (it changes the
geometry). A new built-in cycle is one handler in :attr:`Calls.builtins`.
"""
from __future__ import annotations

import math
import os
import re
from pathlib import Path as FsPath

from ncsim.nc import program as P
from ncsim.nc.context import CallFrame
from ncsim.nc.expr import Where, format_value
from ncsim.nc.flow import Unit, is_proc, split_units
from ncsim.nc.modal import (CYCLE832_DYNAMICS, CYCLE832_TYPE_NAMES, DYNAMIC_COMMANDS, M_END,
                            M_END_RESET, M_RETURN)
from ncsim.nc.parse import parse_text, read_program_text
from ncsim.nc.settings import HANDLED_COMMANDS, Settings
from ncsim.nc.variables import check_name

MAX_CALL_DEPTH = 16          # subprogram nesting (the 840D allows 16 levels with its default MD)
MAX_NAME_CHARS = 255         # longer words are no file name (the 840D allows 24 characters)
_STANDARD_CYCLES = re.compile(r"^(CYCLE\d+|POCKET\d|SLOT\d|LONGHOLE|HOLES\d|E_[A-Z_]+|F_[A-Z_]+)$")
#: cycles ncsim simulates itself even when a file of that name is found
SIMULATED_CYCLES = frozenset({"CYCLE832"})
#: built-in procedures of the language (never looked up as files)
LANGUAGE_PROCEDURES = frozenset({"MSG", "SETAL", "SETMS"})
CYCLE_ALARM_MESSAGES = range(62000, 63000)   # display-only cycle alarms: the program goes on


def is_standard_cycle(name: str) -> bool:
    return _STANDARD_CYCLES.match(name) is not None


class SubprogramFinder:
    """Finds subprogram files by name, without case, in an ordered list of folders."""

    def __init__(self, dirs) -> None:
        self.dirs: list[FsPath] = []
        for d in dirs:
            self.add(d)
        self._listings: dict[FsPath, dict[str, FsPath]] = {}

    def add(self, folder) -> None:
        if folder is None:
            return
        folder = FsPath(folder)
        if folder not in self.dirs:
            self.dirs.append(folder)

    def _listing(self, folder: FsPath) -> dict[str, FsPath]:
        found = self._listings.get(folder)
        if found is None:
            found = {}
            try:
                for entry in sorted(os.scandir(folder), key=lambda e: e.name):
                    if entry.is_file():
                        found.setdefault(entry.name.upper(), FsPath(entry.path))
            except OSError:
                pass
            self._listings[folder] = found
        return found

    def find(self, name: str, first: FsPath | None = None, extensions=()) -> FsPath | None:
        """The file of subprogram ``name``: in ``first`` (the caller's folder), then the folders.
        ``NAME.MPF`` before ``NAME.SPF`` (the control looks for a main program first), then
        ``NAME`` with one of ``extensions`` (ISO programs: ``.NC``, none, ...)."""
        if len(name) > MAX_NAME_CHARS:
            return None
        keys = (f"{name}.MPF", f"{name}.SPF", f"_N_{name}_MPF", f"_N_{name}_SPF",
                *(f"{name}{ext}" for ext in extensions))
        folders = ([first] if first is not None else []) + [d for d in self.dirs if d != first]
        for folder in folders:
            listing = self._listing(folder)
            for key in keys:
                if key in listing:
                    return listing[key]
        return None

    def searched(self, first: FsPath | None) -> list[str]:
        folders = ([first] if first is not None else []) + [d for d in self.dirs if d != first]
        return [str(f) for f in folders]


class Calls:
    """The call stack: pushing units, calling subprograms and cycles, returning and ending."""

    def __init__(self, state) -> None:
        self.state = state
        self.builtins = {"CYCLE832": self._cycle832, "CYCLE800": self._cycle800}
        self.procedures = {"MSG": self._msg, "SETAL": self._setal, "SETMS": self._setms}
        self.settings = Settings(state)
        self.finder = SubprogramFinder([state.search_dir, *state.options.subprogram_dirs])
        self.file_dirs: dict[str, FsPath] = {}     # file of a loaded unit -> its folder
        self.main_file: str | None = None

    # ---- the stack ---------------------------------------------------------------------------

    def push(self, unit: Unit, args: tuple, repeats: int, refs: dict | None = None,
             modal_call: bool = False) -> None:
        state = self.state
        if len(state.stack) >= MAX_CALL_DEPTH:
            raise Where(unit.file, 0).error(f"subprogram nesting deeper than {MAX_CALL_DEPTH} "
                                            f"levels", 0)
        if unit.params:   # a parameter named like an address (B, X1) is no identifier
            where = Where(unit.file, unit.items[0].line)
            for param in unit.params:
                check_name(where, param.name, param.col, f"PROC {unit.name}: parameter")
        inside_modal = modal_call or (bool(state.stack) and state.stack[-1].modal_call)
        fr = CallFrame(unit, state.out.builder.file_index(unit.file),
                       pc=1 if is_proc(unit) else 0, args=args, repeats_left=repeats,
                       modal_call=inside_modal)
        if "SAVE" in unit.attributes:
            fr.saved = self._save()
        fr.refs = refs
        state.vars.bind_params(fr, unit.params, args, refs)
        state.stack.append(fr)

    def return_(self) -> None:
        """Leave the current unit (its end, M17 or RET); a repeated call (P) runs it again."""
        fr = self.state.stack.pop()
        if fr.saved is not None:
            self._restore(fr.saved)
        if fr.repeats_left > 1:
            self.push(fr.unit, fr.args, fr.repeats_left - 1, fr.refs, fr.modal_call)

    def _save(self):
        """What SAVE restores at the return: the modal G functions and the frames
        (Job planning, "Subprograms with SAVE mechanism"); F and S are not restored."""
        st = self.state.st
        return ((st.motion, st.plane, st.incremental, st.units, st.cp_mode, st.stop_window,
                 st.accel_mode, st.ffw, st.radius_comp, st.settable_mm, st.prog_frame,
                 st.diameter, st.dyn_group),
                (self.state.feed_type, self.state.settable_code))

    def _restore(self, saved) -> None:
        state, st = self.state, self.state.st
        (st.motion, st.plane, st.incremental, st.units, st.cp_mode, st.stop_window,
         st.accel_mode, st.ffw, st.radius_comp, st.settable_mm, st.prog_frame,
         st.diameter, st.dyn_group) = saved[0]
        state.feed_type, state.settable_code = saved[1]
        st.set_frames()

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

    def find_unit(self, name: str, caller_file: str | None = None) -> Unit | None:
        """The unit called ``name``: a PROC of a loaded text, else a subprogram file."""
        state = self.state
        unit = state.units.get(name)
        if unit is not None:
            return unit
        path = self.finder.find(name, self._caller_dir(caller_file))
        if path is None:
            return None
        text = read_program_text(path)
        program = parse_text(text, str(path), fast=state.fast, macros=state.macros)
        state.programs[str(path)] = program
        self.file_dirs[str(path)] = path.parent
        state.add_lines(program.n_lines)
        units = split_units(program, name, subprogram=True)
        self.add_units(units[1:])
        state.units.setdefault(name, units[0])
        return units[0]

    def _caller_dir(self, caller_file: str | None) -> FsPath | None:
        """The folder of the calling program's file (None for a program given as text)."""
        found = self.file_dirs.get(caller_file)
        if found is None and caller_file == self.main_file:
            return self.state.search_dir
        return found

    def _missing(self, ctx, name: str, col: int) -> None:
        """A subprogram that is nowhere: an error, or with --missing-subprograms warn a warning."""
        folders = self.finder.searched(self._caller_dir(ctx.file))
        where = ", ".join(folders) if folders else "no folder (a program given as text)"
        if self.state.options.missing_subprograms == "warn":
            ctx.record(name, ())
            ctx.warn("missing subprogram", f"subprogram {name} not found (searched {where}): "
                     f"skipped, no motion", col)
            return
        raise ctx.error(f"subprogram {name} not found: no PROC {name} and no {name}.MPF/"
                        f"{name}.SPF in {where} (--subprograms DIR adds a folder, "
                        f"--missing-subprograms warn skips the call)", col)

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
            targets.append((f"L{ctx.whole_number(value, 'L', col)}", (), col, ()))
        for name, col in ctx.commands:
            if name not in HANDLED_COMMANDS:
                targets.append((name, (), col, ()))
        for k, (name, args, col) in enumerate(ctx.calls):
            if name in self.procedures:
                self.procedures[name](ctx, name, args, col)
                continue
            exprs = ctx.call_exprs[k] if k < len(ctx.call_exprs) else ()
            targets.append((name, args, col, exprs))
        if not targets and "P" in ctx.values:
            raise ctx.error("P (repetitions) without a subprogram call", ctx.values["P"][1])
        if len(targets) > 1:
            name, _, col, _ = targets[1]
            raise ctx.error(f"second subprogram call {name} in one block", col)
        if targets and (any(code in (M_END, M_END_RESET, M_RETURN) for code, _ in ctx.m)
                        or any(name == "RET" for name, _ in ctx.commands)):
            raise ctx.error(f"subprogram call {targets[0][0]} together with the end of the "
                            f"program or a return in one block", targets[0][2])
        for name, args, col, exprs in targets:
            self.call(ctx, name, args, repeats, col, exprs)

    def call(self, ctx, name: str, args: tuple, repeats: int, col: int, exprs: tuple = (),
             modal_call: bool = False) -> None:
        """Call ``name``: its source if there is one, else a built-in cycle, else a standard
        cycle's warning, else a missing subprogram."""
        handler = self.builtins.get(name)
        if handler is not None and name in SIMULATED_CYCLES:
            handler(ctx, name, args, col)
            return
        unit = self.find_unit(name, ctx.file)
        if unit is None:
            if handler is not None:
                handler(ctx, name, args, col)
            elif is_standard_cycle(name):
                ctx.record(name, args)
                ctx.warn("cycle", f"{name}: machining cycle not simulated (no {name}.SPF found, "
                         f"no motion generated)", col)
            else:
                self._missing(ctx, name, col)
            return
        if len(args) > len(unit.params):
            raise ctx.error(f"{name} takes {len(unit.params)} arguments, got {len(args)}", col)
        refs = self._references(ctx, name, unit, exprs, col)
        if len(self.state.stack) >= MAX_CALL_DEPTH:
            raise ctx.error(f"subprogram nesting deeper than {MAX_CALL_DEPTH} levels", col)
        self.push(unit, args, repeats, refs, modal_call)

    def _references(self, ctx, name: str, unit: Unit, exprs: tuple, col: int) -> dict | None:
        """The caller's variables bound to the VAR parameters of ``unit``."""
        refs = None
        for k, param in enumerate(unit.params):
            if not param.by_reference or k >= len(exprs) or exprs[k] is None:
                continue
            expr = exprs[k]
            entry = (self.state.vars.entry(expr.name) if isinstance(expr, P.Var) else None)
            if entry is None:
                raise ctx.unsupported(f"VAR parameter {param.name} of {name} needs a variable "
                                      f"(DEF ...) as its argument", getattr(expr, "col", col))
            refs = refs or {}
            refs[param.name] = entry
        return refs

    # ---- modal calls (MCALL) -----------------------------------------------------------------

    def modal_call_after_motion(self, ctx) -> None:
        """After a block with path motion: call the active modal subprogram."""
        state = self.state
        if state.modal_call is None or ctx.frame.modal_call or state.ended:
            return
        name, args, col = state.modal_call
        self.call(ctx, name, args, 1, col, modal_call=True)

    def set_modal_call(self, ctx, col: int) -> None:
        """MCALL NAME(args): NAME becomes the modal call (a standard cycle without its file is
        only recorded, with a warning); MCALL alone ends it."""
        state = self.state
        named = [(n, c) for n, c in ctx.commands if n not in HANDLED_COMMANDS]
        if ctx.calls:
            name, args, _ = ctx.calls.pop(0)
            if ctx.call_exprs:
                ctx.call_exprs.pop(0)
        elif named:
            name, args = named[0][0], ()
            ctx.commands.remove(named[0])
        else:
            ctx.record("MCALL", ())
            state.modal_call = None
            return
        ctx.record(f"MCALL {name}", args)
        if name not in SIMULATED_CYCLES and self.find_unit(name, ctx.file) is not None:
            state.modal_call = (name, args, col)
            return
        state.modal_call = None
        if is_standard_cycle(name) or name in self.builtins:
            ctx.warn("MCALL", f"MCALL {name}: the modal call is not executed after the following "
                     f"positioning blocks (no {name}.SPF found; only the positioning moves are "
                     f"simulated)", col)
        else:
            self._missing(ctx, name, col)

    # ---- built-in procedures and cycles ------------------------------------------------------

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
        builder's CUST_832: the machine file's ``[cycle832]`` table (:meth:`Settings.cycle832`);
        its technology group (DYNNORM, DYNFINISH, DYNSEMIFIN, DYNROUGH, DYNPREC by type) runs
        with the machine file's ``[dynamics]`` (:meth:`Settings.technology_group`).
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
        self.settings.technology_group(ctx, DYNAMIC_COMMANDS.index(CYCLE832_DYNAMICS[units]),
                                       col, "CYCLE832 selects ")
        if not spec.from_file and "defaults" not in notes:
            notes.add("defaults")
            ctx.warn("CYCLE832", "CYCLE832: the machine file has no [cycle832] table; the usual "
                     "CUST_832 settings are used (G642, COMPCAD, SOFT, FFWON; deselection to the "
                     "reset values)", col)

    def _cycle800(self, ctx, name: str, args: tuple, col: int) -> None:
        ctx.record(name, args)
        ctx.warn("CYCLE800", "CYCLE800 swivel plane (5-axis) is not simulated: X/Y/Z are used "
                 "as programmed", col)

    def _setal(self, ctx, name: str, args: tuple, col: int) -> None:
        """SETAL(n): a cycle alarm (Diagnostics Manual: cycle alarms 61000-61999 stop the
        program, 62000-62999 are messages)."""
        if len(args) < 1 or isinstance(args[0], str) or args[0] is None:
            raise ctx.error("SETAL needs an alarm number", col)
        number = ctx.whole_number(args[0], "SETAL", col)
        unit = ctx.frame.unit.name
        if number in CYCLE_ALARM_MESSAGES:
            ctx.warn("cycle alarm", f"cycle alarm {number} set by {unit} (a message: the program "
                     f"goes on)", col)
            ctx.record("SETAL", args)
            return
        raise ctx.error(f"cycle alarm {number} set by {unit} (SETAL): the control stops the "
                        f"program here", col)

    def _setms(self, ctx, name: str, args: tuple, col: int) -> None:
        """SETMS(n) makes spindle n the master spindle; SETMS() returns to the MD default."""
        if args and args[0] is not None:
            self.state.master_spindle = ctx.whole_number(args[0], "SETMS", col)
        else:
            self.state.master_spindle = 1
        ctx.record("SETMS", args)

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
            self.state.jumped_back(ctx.file, ctx.line, 1)
