"""The 840D interpreter: a parsed program -> a :class:`~ncsim.path.Path` plus warnings.

Block execution follows a fixed order (grbl's, adapted to the 840D; SINUMERIK Programming
Guide Fundamentals, "Fundamental principles of NC programming"):

0. control statements (GOTO, IF/ELSE/ENDIF, WHILE, FOR, REPEAT/UNTIL, LOOP, CASE, REPEAT/
   REPEATB sections, DEF) stand alone in their block and run instead of the steps below
   (:mod:`ncsim.nc.flow`);
1. evaluate the words left to right (assignments take effect at once, so ``R1=5 X=R1`` moves
   to 5); reject unknown words and two G functions of one group (:mod:`ncsim.nc.words`);
2. modal G functions (settable frame, units, plane, G90/G91, feed type, G60/G64.., G601..);
3. frame instructions (TRANS ROT SCALE MIRROR and their A-forms; the block's X Y Z are their
   arguments), F S T D H M, ADIS/ADISPOS, CTOL/OTOL, SOFT/BRISK/DRIVE, FFWON/FFWOF, STOPRE,
   the compressor (COMPON..COMPOF), recorded settings (DYN*) (steps 2 and 3:
   :mod:`ncsim.nc.settings`);
4. the motion (G0 G1 G2 G3 CIP CT, polar AP/RP) or the dwell (G4) or a pole (G110-G112)
   (:mod:`ncsim.nc.moves`), then MCALL, subprogram calls and cycles (found as PROCs, beside the
   caller or in the ``--subprograms`` folders; CYCLE832 switches path mode, compressor, SOFT,
   FFWON and CTOL per the machine file's ``[cycle832]`` table), then M17/RET and M2/M30, then
   the active modal call after a block with path motion (:mod:`ncsim.nc.calls`).

840D semantics implemented: G70/G71 scale geometry only (feeds stay mm/min), G700/G710 scale
geometry and feed; X=AC(..)/X=IC(..) per axis; I J K incremental to the start point unless
I=AC(..); CR= (negative: more than a half circle), AR=, TURN=, CIP with I1= J1= K1= (G90/G91
apply to the intermediate point), CT tangential to the previous segment; the circle end-point
check |r_end - r_start| <= max(MD21000, MD21010 * r_start); the frame chain of
:mod:`ncsim.nc.frames` with SUPA/G53/G153 suppressing frames for one block and MIRROR reversing
arcs. Internal units: mm, s, rad (F mm/min -> mm/s and inch -> mm happen here, once).

The tool starts at the machine origin (0, 0, 0). A motion block whose end equals its start
makes no segment (a full circle G2/G3 does; nor does a line that only rounding makes,
``moves.MIN_LINE_MM``). A main program that runs off its last line without M30/M2/M17 is
``complete=False`` and warns (truncated?), as does a program without motion. ``stop_before`` marks: an M or H output in the
block or since the last segment, STOPRE, a change of SOFT/BRISK/DRIVE, a G4 dwell, and a
change between rapid and feed motion; S, T, D and F changes do not stop.

Fast paths: consecutive plain lines (:mod:`ncsim.nc.fastparse`) are interpreted as whole columns
(:mod:`ncsim.nc.columns`: forward fill of modal words, cumulative sums for G91, one affine
frame per run, vectorised arcs). Whenever a run needs anything else (an error, a warning, a
budget overrun, CIP/CT modal, a short run) it is executed block by block instead, so both ways
give the same Path, warnings and errors. A block executed a second time (a loop) is compiled
to Python code (:mod:`ncsim.nc.fastops`), which does what the block path does or hands the
block to it. ``interpret_text(..., fast=False)`` parses every line with Lark and takes neither
fast path (``tests/test_fastpath.py`` and ``tests/test_fastops.py`` compare the two).

Endless loops: the blocks executed are counted against a budget (``--block-budget``; by
default the lines of the program files plus 2,000,000, the passes of FOR loops that advance
their counter given back: a FOR loop is bounded); the error names the jump back taken most
often. A loop whose passes decide nothing (between two takings of its jump back, in one call,
no condition on the program's state is evaluated) is stopped at its second pass, however it
moves; one that returns to the same state at its jump (R parameters, variables, position,
modal state: the interpreter is deterministic) is stopped there after 1024 passes (cycles of
up to 64 passes are recognised). See ``context.InterpreterState.count_jump``.

The parts, each a small class holding the shared :class:`~ncsim.nc.context.InterpreterState`:

================  ==========================================================================
``interpret``     this entry point and :class:`Interpreter`, the driver: the call-stack loop,
                  and the block order above in :meth:`Interpreter.exec_block`
``context``       the shared state, and the per-block context that locates every error and
                  warning (``raise ctx.error("message", col)``, ``ctx.warn(kind, "message", col)``)
``flow``          program units (main part, PROCs), labels, paired control structures, jumps
``variables``     R parameters, DEF and PROC variables (the ``Scope`` of expressions)
``calls``         subprogram calls and lookup, built-in cycles, M17/RET/M2/M30
``words``         step 1; ``settings``: steps 2 and 3; ``moves``: step 4 and the segments
``columns``       the column path for runs of plain blocks
``fastops``       blocks compiled to Python code once they run a second time
``sysvars``       the system variables programs read (``$P_GG[n]``, ``$P_AXN3``, ...)
================  ==========================================================================

Where new features go:

* a new NC word or address: read it in :meth:`ncsim.nc.words.Words.word`; a modal effect goes
  in :class:`ncsim.nc.settings.Settings`, a motion in :meth:`ncsim.nc.moves.Moves.motion`; a new
  G function is an entry of ``ncsim.nc.modal.G_CODES``; a new command word (a bare name such as
  ``COMPCAD``) is handled in :meth:`ncsim.nc.settings.Settings.commands` and listed in
  ``HANDLED_COMMANDS`` (any other name is a subprogram call);
* a new control-flow statement (CASE, ...): its node in :mod:`ncsim.nc.program` and the
  grammar, its pairing in :func:`ncsim.nc.flow.compile_unit` if it opens or closes a structure,
  and a handler in the table of :class:`ncsim.nc.flow.Flow`;
* a new cycle (CYCLE832 simulated, ...): a handler in ``Calls.builtins``
  (:mod:`ncsim.nc.calls`); it reads the modal state and changes it like a setting does;
* new variable kinds: :mod:`ncsim.nc.variables` and :meth:`ncsim.nc.calls.Calls.push`; a
  system variable: a handler in :mod:`ncsim.nc.sysvars`;
* a kind of block that loops run often and the block path runs slowly: an op in
  :class:`ncsim.nc.fastops.OpCompiler` (the property test of ``tests/test_fastops.py`` must
  draw it);
* anything the column path cannot do exactly like the block path: make
  :meth:`ncsim.nc.columns.ColumnPath.run` decline the run (return False).
"""
from __future__ import annotations

import gc
from dataclasses import dataclass
from pathlib import Path as FsPath

from ncsim.errors import NcError, NcWarning
from ncsim.machine import MachineSpec
from ncsim.nc import program as P
from ncsim.nc.calls import Calls
from ncsim.nc.columns import ColumnPath
from ncsim.nc.dialect import foreign_code
from ncsim.nc.context import (BlockContext, InterpreterState, InterpretOptions, PathOutput,
                              RecordedCall, WordContext)
from ncsim.nc.expr import Where
from ncsim.nc.fastops import OpCompiler
from ncsim.nc.flow import Flow, split_units
from ncsim.nc.iso import IsoExec
from ncsim.nc.isocalls import split_programs
from ncsim.nc.isoparse import IsoBlock
from ncsim.nc.macros import definition_macros
from ncsim.nc.modal import COMPRESSOR_COMMANDS, DYNAMIC_COMMANDS
from ncsim.nc.moves import Moves
from ncsim.nc.outline import label_path
from ncsim.nc.parse import parse_text, read_program_text
from ncsim.nc.settings import Settings
from ncsim.nc.variables import load_definitions
from ncsim.nc.words import Words
from ncsim.path import Path

__all__ = ["InterpretOptions", "InterpretResult", "Interpreter", "RecordedCall",
           "interpret_file", "interpret_text"]

VECTOR_MIN_ROWS = 8          # shorter plain runs are cheaper block by block
COLUMN_CHUNK = 1 << 16       # rows of a plain run interpreted as columns at once


@dataclass(frozen=True, slots=True)
class InterpretResult:
    path: Path
    warnings: tuple[NcWarning, ...]
    blocks_executed: int
    recorded: tuple[RecordedCall, ...] = ()
    complete: bool = True   # ended by M2/M30 (or M17/RET), not by running off its last line
    approximations: tuple[tuple[str, int, str], ...] = ()   # (kind, times, reason)

    @property
    def approximate(self) -> bool:
        """Whether something that can change the time was not simulated (see approximations)."""
        return bool(self.approximations)

    @property
    def cycle832_calls(self) -> tuple[RecordedCall, ...]:
        return tuple(r for r in self.recorded if r.name == "CYCLE832")

    @property
    def mode_changes(self) -> tuple[RecordedCall, ...]:
        """COMPON/COMPCURV/COMPCAD/COMPOF and DYNNORM..DYNFINISH, in execution order."""
        names = COMPRESSOR_COMMANDS + DYNAMIC_COMMANDS
        return tuple(r for r in self.recorded if r.name in names)

    @property
    def messages(self) -> tuple[RecordedCall, ...]:
        return tuple(r for r in self.recorded if r.name == "MSG")


def interpret_text(text: str, file: str = "<string>", machine: MachineSpec | None = None, *,
                   block_budget: int | None = None,
                   setup_offsets: dict[str, tuple[float, float, float]] | None = None,
                   fast: bool = True, skip_blocks: bool = False,
                   search_dir: str | FsPath | None = None, subprograms=(),
                   missing_subprograms: str = "error", definitions=(),
                   dialect: str | None = None) -> InterpretResult:
    """Interpret program text. ``fast=False`` sends every line through the Lark grammar and
    evaluates every block with the reference interpreter. ``dialect`` is the language the
    program starts in, ``"siemens"`` or ``"iso"`` (ISO dialect mode, :mod:`ncsim.nc.iso`;
    None: the machine file's ``[iso] dialect``); a program that fails and looks like other
    code gets an error saying so (:mod:`ncsim.nc.dialect`).

    ``machine`` gives work offsets, circle tolerances and system variables; ``setup_offsets``
    (``{"G54": (x, y, z)}``) override its offsets. ``skip_blocks`` activates block skip (``/``
    blocks are not executed). Subprograms called by name are looked up as PROCs in the same
    text, then as files in ``search_dir`` and the ``subprograms`` folders (see
    :class:`~ncsim.nc.context.InterpretOptions` for these and the other options).
    """
    options = InterpretOptions(subprogram_dirs=tuple(FsPath(d) for d in subprograms),
                               missing_subprograms=missing_subprograms,
                               definitions=tuple(FsPath(d) for d in definitions),
                               block_budget=block_budget, fast=fast, skip_blocks=skip_blocks)
    interp = Interpreter(machine, options, setup_offsets, search_dir)
    spec = interp.iso.spec
    start = dialect or spec.dialect
    interp.state.macros = definition_macros(options.definitions)
    try:
        program = parse_text(text, file, fast=fast, macros=interp.state.macros, dialect=start,
                             iso_plain=not spec.standard_notation)
        return interp.run(program)
    except NcError as exc:
        foreign = foreign_code(text, file, start == "siemens") if exc.file == file else None
        if foreign is None:
            raise
        foreign.warnings = getattr(exc, "warnings", ())
        raise foreign from None
    finally:
        interp.close()


def interpret_file(path: str | FsPath, machine: MachineSpec | None = None, **options
                   ) -> InterpretResult:
    """Interpret a program file; subprogram files are looked up next to it first (the keyword
    options are those of :func:`interpret_text`)."""
    p = FsPath(path)
    return interpret_text(read_program_text(p), str(path), machine, search_dir=p.parent,
                          **options)


class Interpreter:
    """Runs a parsed program: the call-stack loop and the order of one block."""

    def __init__(self, machine, options: InterpretOptions, setup_offsets=None,
                 search_dir=None) -> None:
        self.state = state = InterpreterState(machine, options, setup_offsets, search_dir)
        self.flow = Flow(state)
        self.calls = Calls(state)
        self.words = Words(state)
        self.settings = Settings(state)
        self.moves = Moves(state)
        self.columns = ColumnPath(state)
        self.ran_off_end = False     # the main program ran past its last line
        self.main_unit = None
        self.ops = OpCompiler(self)
        self.iso = IsoExec(self)
        self.vector_min_rows = VECTOR_MIN_ROWS

    def run(self, program: P.Program) -> InterpretResult:
        """Interpret ``program``. An error raised on the way carries the warnings collected
        until then (``error.warnings``), so that a caller can show what led to it."""
        state = self.state
        state.out = PathOutput(program.file, capacity=program.n_lines)   # one segment a line
        state.programs[program.file] = program
        self.calls.main_file = program.file
        state.add_lines(program.n_lines)
        try:
            for definitions in state.options.definitions:
                load_definitions(state, definitions)
            units = split_programs(split_units(program, FsPath(program.file).stem.upper() or
                                               "MAIN"))
            self.main_unit = units[0]
            self.calls.add_units(units[1:])
            self.calls.push(units[0], (), 1)
            self._loop()
        except NcError as exc:
            exc.warnings = state.warnings.result()
            raise
        state.out.flush()
        state.stack.clear()
        builder = state.out.builder
        builder.end_dwell_s = state.st.pending_dwell_s
        path = label_path(builder.build(), state.programs, state.recorded)
        procs_only = len(units) > 1 and not any(_has_content(i) for i in units[0].items)
        complete = state.ended or not self.ran_off_end or procs_only
        self._warn_empty(program, path.n, complete, [u.name for u in units[1:]] * procs_only)
        return InterpretResult(path, state.warnings.result(), state.blocks, tuple(state.recorded),
                               complete, state.warnings.approximations())

    def close(self) -> None:
        """Let go of the parsed program. The compiled ops refer back to the interpreter, a
        reference cycle that only a later run of the cyclic garbage collector would free, with
        the program's columns in it (about 100 bytes per block): a caller done with the
        interpreter breaks it here."""
        state = self.state
        for unit in (self.main_unit, *state.units.values()):
            if unit is not None:
                unit.ops.clear()
                unit.items = []
        state.units.clear()
        state.programs.clear()
        state.stack.clear()
        self.main_unit = None

    def _warn_empty(self, program: P.Program, n_segments: int, complete: bool,
                    procs: list[str]) -> None:
        """An export cut short or empty is a warning, never a silent zero cycle time; so is a
        file of PROCs that nothing calls (a subprogram run on its own)."""
        warnings = self.state.warnings
        if procs:
            warnings.add("end", f"the file only defines PROC {', '.join(procs)}: nothing here "
                         "calls it (run the program that does)", program.file, 0)
        if not complete:
            warnings.add("end", "the program ends without M30, M2 or M17 (truncated?)",
                         program.file, program.n_lines)
        if n_segments == 0:
            warnings.add("motion", "no motion: the program moves no axis", program.file, 0)

    def _loop(self) -> None:
        """Execute items until the program ends: each item's op, compiled when first reached
        (:mod:`ncsim.nc.fastops`; with ``fast=False`` always :meth:`generic_op`). The cyclic
        garbage collector is paused meanwhile: the loop makes no reference cycles, and the
        collections that millions of small objects trigger cost a fifth of the time."""
        collecting = gc.isenabled()
        gc.disable()
        try:
            self._run_items()
        finally:
            if collecting:
                gc.enable()

    def _run_items(self) -> None:
        state = self.state
        stack = state.stack
        compile_op = self.ops.compile if state.fast else None
        generic = self.generic_op
        try:
            while stack and not state.ended:
                fr = stack[-1]
                unit = fr.unit
                ops = unit.ops
                n = len(ops)
                while True:                            # the items of this frame
                    pc = fr.pc
                    if pc >= n:
                        self.ran_off_end = self.ran_off_end or len(stack) == 1
                        self.calls.return_()
                        break
                    op = ops[pc]
                    if op is None:
                        op = ops[pc] = compile_op(unit, pc) if compile_op else generic
                    op(fr)
                    if fr.section_ends and fr.section_ends[-1][0] == pc and fr.pc == pc + 1:
                        fr.pc = fr.section_ends.pop()[1]   # end of a REPEAT section: its REPEAT
                    if not stack or stack[-1] is not fr or state.ended:   # call, return, end
                        break
        except RecursionError:
            raise Where(state.stack[-1].unit.file, state.line).error(
                "expression nested too deeply", 1) from None

    def generic_op(self, fr) -> None:
        """Execute the next item of the frame ``fr`` by the block path: a block (counted), or a
        run of plain blocks (each row counted)."""
        pc = fr.pc
        item = fr.unit.items[pc]
        if isinstance(item, P.PlainRun):
            run = item.slice(fr.row) if fr.row else item
            fr.row = 0
            fr.pc += 1
            if run.iso:
                self.iso.run(fr, run)
            else:
                self.exec_run(fr, run)
            return
        self.state.count(fr.unit.file, item.line)
        self.generic_uncounted(fr, pc)

    step = generic_op

    def generic_uncounted(self, fr, pc: int) -> None:
        """The block at ``pc`` by the block path, already counted (a compiled op's fallback)."""
        state = self.state
        item = fr.unit.items[pc]
        state.line = item.line
        fr.pc = pc + 1
        if state.skip_blocks and item.skip_level is not None:
            return
        if type(item) is IsoBlock:
            self.iso.block(fr, item)
        elif item.statement is not None:
            self.flow.execute(BlockContext(state, fr, item.line), item.statement)
        else:
            self.exec_block(fr, item)

    def exec_run(self, fr, run: P.PlainRun) -> None:
        """A run of plain blocks: as columns when it can, in chunks of ``COLUMN_CHUNK`` rows
        (their temporaries stay small however long the run), else block by block."""
        n = len(run)
        if n < VECTOR_MIN_ROWS:
            self._run_blocks(fr, run, 0, n)
            return
        for start in range(0, n, COLUMN_CHUNK):
            stop = min(start + COLUMN_CHUNK, n)
            chunk = run if stop - start == n else run.rows(start, stop)
            if (stop - start < VECTOR_MIN_ROWS or not self.columns.run(fr, chunk)) and \
                    not self._run_blocks(fr, run, start, stop):
                return

    def _run_blocks(self, fr, run: P.PlainRun, start: int, stop: int) -> bool:
        """Rows ``start:stop`` of ``run`` by the block path. False when a modal call (MCALL)
        was pushed: it runs first, then the rest of the run (``fr.row``)."""
        count = self.state.count
        file = fr.unit.file
        stack = self.state.stack
        n = len(run)
        for i in range(start, stop):
            block = run.block(i)
            count(file, block.line)
            self.exec_block(fr, block)
            if stack[-1] is not fr and i + 1 < n:
                item = fr.unit.items[fr.pc - 1]
                fr.pc -= 1
                fr.row = len(item) - n + i + 1
                return False
        return True

    def exec_block(self, fr, block: P.Block) -> None:
        """One block of words, in the order of steps 1 to 4 (module docstring)."""
        ctx = WordContext(self.state, fr, block.line)
        self.words.collect(ctx, block)                 # 1. words, assignments
        settings = self.settings
        settings.modal_gcodes(ctx)                     # 2. modal G functions
        frame_cmd = settings.frame_instruction(ctx)    # 3. frames, F S T D M H, settings
        settings.feed_spindle_tool(ctx)
        settings.commands(ctx)
        gcodes = ctx.gcodes
        if "motion" in gcodes:                         # 4. motion or dwell, calls, end
            self.state.st.motion = gcodes["motion"][0]
        moved = False
        if "dwell" in gcodes:
            self.moves.dwell(ctx)
        elif "pole" in gcodes:
            self.moves.pole(ctx)
        elif frame_cmd is None:
            moved = self.moves.motion(ctx)
        calls = self.calls
        if any(name == "MCALL" for name, _ in ctx.commands):
            calls.set_modal_call(ctx, next(c for n, c in ctx.commands if n == "MCALL"))
        calls.block_calls(ctx)
        calls.program_end(ctx)
        if moved and self.state.modal_call is not None:
            calls.modal_call_after_motion(ctx)


def _has_content(item) -> bool:
    """Whether a program item does anything (not only comments and empty lines)."""
    if isinstance(item, P.PlainRun):
        return any(_has_content(item.block(i)) for i in range(len(item)))
    return bool(item.items) or item.statement is not None
