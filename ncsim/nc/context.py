"""What the interpreter's parts share: the state of one interpretation and the per-block context.

:class:`InterpreterState` is the one mutable state of an interpretation (the 840D's modal state,
the call stack, the block counter, the warnings, the recorded settings and the
:class:`~ncsim.path.Path` being built). The interpreter's collaborators (:mod:`ncsim.nc.flow`,
:mod:`ncsim.nc.calls`, :mod:`ncsim.nc.words`, :mod:`ncsim.nc.settings`, :mod:`ncsim.nc.moves`,
:mod:`ncsim.nc.columns`) each hold a reference to it.

:class:`BlockContext` is made once per executed block (in the spirit of Klipper's
``GCodeCommand``): it knows where the block is (file and line; the column is given per word)
and raises errors and warnings there, ``raise ctx.error("message", col)`` and
``ctx.warn(kind, "message", col)``. It is also the ``Where`` of :func:`ncsim.nc.expr.evaluate`,
so evaluating a word costs no extra object. :class:`WordContext` adds the block's evaluated
words, sorted by role (step 1 of the block order in :mod:`ncsim.nc.interpret`).

The column path (:mod:`ncsim.nc.columns`) makes no context per block: a run that would raise
or warn is executed block by block instead.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from operator import itemgetter
from pathlib import Path as FsPath

import numpy as np

from ncsim.errors import NcError, NcSemanticError, NcUnsupportedError, NcWarning
from ncsim.nc.expr import evaluate, evaluate_number, format_value
from ncsim.nc.modal import COMMANDS_NOT_SIMULATED, ModalState
from ncsim.nc.sysvars import SystemVariables
from ncsim.nc.variables import Variables
from ncsim.path import PathBuilder
from ncsim.units import mm_s_to_mm_min

WARNING_CAP = 20             # warnings of one kind shown before they are only counted
WORD_VALUE_LIMIT = 1e9       # |value| of a word: the 840D accepts +-999 999 999.9999
#: the smallest programmable feed F, in the programmed unit (Programming Manual Fundamentals, list
#: of addresses: 0.001 <= F <= 999 999.999); a smaller F would give years of cycle time
MIN_PROGRAMMED_F = 0.001
DEFAULT_CIRCLE_ERROR_CONST_MM = 0.01   # MD21000 $MC_CIRCLE_ERROR_CONST (840D default)
DEFAULT_CIRCLE_ERROR_FACTOR = 0.001    # MD21010 $MC_CIRCLE_ERROR_FACTOR (840D default)
#: blocks a program may execute beyond the lines of its files before it is taken for an endless
#: loop (``--block-budget`` changes it): the shop programs that generate their motion in loops
#: execute up to ~1.2 million blocks
DEFAULT_LOOP_BUDGET = 2_000_000
LOOP_WATCH_FROM = 1024       # jumps back at one place before the loop's state is watched
LOOP_WATCH_WINDOW = 64       # passes compared with a kept state (the longest cycle found)
ROWS_PER_FLUSH = 4096        # block-path segments kept as Python rows before they become columns
MISSING_SUBPROGRAMS = ("error", "warn")

#: warning kinds that make the cycle time approximate (something that can change the time is
#: not simulated), with the reason the summary gives; other warnings (a work offset taken as 0,
#: a tool offset, M0) do not change the time ncsim can know
APPROXIMATE_KINDS = {
    "cycle": "machining cycles without their source are not simulated (no motion)",
    "missing subprogram": "missing subprograms are skipped (no motion)",
    "MCALL": "modal calls of cycles without their source are not executed",
    "CYCLE832": "parts of CYCLE832 are not simulated (higher digits of an old code)",
    "G644": "G644 is simulated as G642",
    "CYCLE800": "CYCLE800 swivelling is not simulated",
    "rotary axis": "rotary axis motion is not simulated",
    "additional axis": "additional axes (U V W) are not simulated",
    "transformation": "kinematic transformations (TRAORI, ...) are not simulated",
    "M6": "tool change times are not simulated",
    "cutter compensation": "cutter radius compensation is not simulated (programmed contour)",
    "dwell": "a G4 S dwell without spindle speed is taken as 0 s",
    "spindle positioning": "spindle positioning (SPOS) times are not simulated",
    "system variable": "assignments to system variables are not simulated",
    "FGROUP": "a path feed of other axes than X, Y, Z (FGROUP) is not simulated",
    "ISO cycle": "spindle reversal and orientation in ISO canned cycles take no time here",
    **{name: "technology groups the machine file does not define run with its [axes] dynamics"
       for name in ("DYNPOS", "DYNROUGH", "DYNSEMIFIN", "DYNFINISH", "DYNPREC")},
    **{name: f"{what} ({name}) is not simulated" for name, what in COMMANDS_NOT_SIMULATED.items()},
}


@dataclass(frozen=True, slots=True)
class InterpretOptions:
    """How a program is interpreted (the CLI's ``--subprograms``, ``--missing-subprograms``,
    ``--definitions`` and ``--block-budget``).

    ``subprogram_dirs``: folders searched for subprogram and cycle files after the caller's own
    folder (names compared without case); ``missing_subprograms``: ``"error"`` (a call of a
    subprogram that is nowhere is an error naming the folders searched) or ``"warn"`` (a warning,
    the call makes no motion, the result is approximate); ``definitions``: GUD definition files
    (``MGUD.DEF``, ``UGUD.DEF``: ``DEF NCK|CHAN type name``) read before the program;
    ``block_budget``: executed blocks before the run is stopped as an endless loop (None: the
    lines of the program files plus :data:`DEFAULT_LOOP_BUDGET`)."""

    subprogram_dirs: tuple = ()
    missing_subprograms: str = "error"
    definitions: tuple = ()
    block_budget: int | None = None
    fast: bool = True
    skip_blocks: bool = False

@dataclass(frozen=True, slots=True)
class RecordedCall:
    """A setting parsed and kept but not simulated (CYCLE832, COMPCAD, DYNFINISH, MSG, T, ...).

    ``segment_index`` is the index of the next segment when it was executed (it applies from
    there on)."""

    name: str
    args: tuple
    file: str
    line: int
    segment_index: int


class Warnings:
    """Warnings in order, each site once; beyond WARNING_CAP of one kind only counted. Every
    execution of a warning of an :data:`APPROXIMATE_KINDS` kind is counted in ``approximate``."""

    def __init__(self) -> None:
        self.items: list[NcWarning] = []
        self._seen: set = set()
        self._counts: dict[str, int] = {}
        self._hidden: dict[str, list] = {}
        self.approximate: dict[str, int] = {}

    def add(self, kind: str, message: str, file: str, line: int, col: int = 0) -> None:
        if kind in APPROXIMATE_KINDS:
            self.approximate[kind] = self.approximate.get(kind, 0) + 1
        key = (file, line, col, message)
        if key in self._seen:
            return
        self._seen.add(key)
        n = self._counts[kind] = self._counts.get(kind, 0) + 1
        if n <= WARNING_CAP:
            self.items.append(NcWarning(message, file, line, col, kind))
        else:
            hidden = self._hidden.setdefault(kind, [0, file, line])
            hidden[0] += 1

    def result(self) -> tuple[NcWarning, ...]:
        tail = [NcWarning(f"{n} more {kind} warnings not shown (the first of them here)", file, line,
                          kind=kind, more=n)
                for kind, (n, file, line) in self._hidden.items()]
        return tuple(self.items + tail)

    def approximations(self) -> tuple[tuple[str, int, str], ...]:
        """(kind, times, reason) of what makes the time approximate, most frequent first."""
        return tuple(sorted(((k, n, APPROXIMATE_KINDS[k]) for k, n in self.approximate.items()),
                            key=lambda t: (-t[1], t[0])))


@dataclass(slots=True)
class CallFrame:
    """One level of the call stack: the unit (main program or PROC, see :mod:`ncsim.nc.flow`)
    being executed and where in it."""

    unit: object                 # ncsim.nc.flow.Unit
    file_index: int
    pc: int = 0
    row: int = 0                 # row to resume at inside a PlainRun (after a jump)
    variables: dict = field(default_factory=dict)   # name -> [type, value]
    args: tuple = ()
    repeats_left: int = 1
    for_end: dict = field(default_factory=dict)
    #: FOR block -> [highest counter value a pass went back with, blocks executed and
    #: blocks refunded at the last pass]: what :meth:`InterpreterState.for_jump_back` refunds
    for_marks: dict = field(default_factory=dict)
    repeats: dict = field(default_factory=dict)      # REPEAT block -> repetitions left
    section_ends: list = field(default_factory=list)  # (last item of a section, its REPEAT)
    saved: object = None         # the modal state a SAVE subprogram restores at its return
    modal_call: bool = False     # this frame runs a modal call (MCALL): no modal call inside
    refs: dict | None = None     # VAR parameters: name -> the caller's variable


class PathOutput:
    """The :class:`~ncsim.path.Path` being built: rows from the block path, columns from runs.

    Rows are buffered and turned into columns before every column chunk, so the segments stay
    in execution order."""

    def __init__(self, file: str, capacity: int = 0) -> None:
        self.builder = PathBuilder((file,), capacity)
        self.rows: list[dict] = []
        self.n_segments = 0

    def append(self, row: dict) -> None:
        self.rows.append(row)
        self.n_segments += 1
        if len(self.rows) >= ROWS_PER_FLUSH:   # bounded memory: rows become columns
            self.flush()

    def extend(self, n: int, **columns) -> None:
        """Add ``n`` segments given as columns (after the buffered rows)."""
        self.flush()
        self.builder.extend(**columns)
        self.n_segments += n

    def flush(self) -> None:
        if not self.rows:
            return
        names = tuple(self.rows[0])
        columns = zip(*map(itemgetter(*names), self.rows))
        self.builder.extend(**{name: np.array(v) for name, v in zip(names, columns)})
        self.rows = []


class InterpreterState:
    """Everything an interpretation changes, shared by the interpreter's collaborators.

    ``machine`` gives the work offsets (overridden by ``setup_offsets``), the circle end-point
    tolerances MD21000/MD21010 and the values of system variables; ``options`` the subprogram
    folders, the block budget and the rest of :class:`InterpretOptions`; ``search_dir`` is the
    main program's folder (None for a text)."""

    def __init__(self, machine, options: InterpretOptions, setup_offsets, search_dir) -> None:
        self.machine = machine
        self.options = options
        self.auto_budget = options.block_budget is None
        self.budget = DEFAULT_LOOP_BUDGET if self.auto_budget else options.block_budget
        self.offsets = dict(setup_offsets or {})
        self.fast = options.fast
        self.skip_blocks = options.skip_blocks
        self.search_dir = FsPath(search_dir) if search_dir is not None else None
        ncu = machine.ncu if machine is not None else None
        self.circle_const_mm = ncu.circle_error_const_mm if ncu else DEFAULT_CIRCLE_ERROR_CONST_MM
        self.circle_factor = ncu.circle_error_factor if ncu else DEFAULT_CIRCLE_ERROR_FACTOR
        # never replaced: collaborators keep a reference; groups 10 (path mode), 30
        # (compressor), 6 (plane), 29 (diameter programming) and 21 (BRISK/SOFT/DRIVE) start
        # at the machine's reset values (MD20150 $MC_GCODE_RESET_VALUES)
        self.st = (ModalState(cp_mode=ncu.reset_path_mode, compressor=ncu.reset_compressor,
                              plane=ncu.reset_plane, diameter=ncu.reset_diameter_mode,
                              accel_mode=ncu.reset_accel_mode)
                   if ncu else ModalState())
        #: MD20100 $MC_DIAMETER_AX_DEF: the transverse axis (0 = X), :mod:`ncsim.nc.diameter`
        self.diameter_axis = ncu.diameter_axis if ncu else 0
        # the reset values CYCLE832's deselection returns to (MD20150 $MC_GCODE_RESET_VALUES)
        self.reset_values = (self.st.cp_mode, self.st.accel_mode, self.st.ffw)
        self.cycle832_notes: set = set()   # one-time CYCLE832 warnings already given
        self.stack: list[CallFrame] = []
        self.vars = Variables(self.stack)
        given = getattr(machine, "system_variables", ()) if machine is not None else ()
        self.vars.sysvars = SystemVariables(self, dict(given))
        self.blocks = 0
        self.refunded = 0                  # blocks of FOR passes given back to the budget
        self.decisions = 0                 # conditions on the program's state evaluated
        #: (file, line, col) of a jump back -> [times taken, FOR passes refunded, decisions
        #: and frame when last taken]
        self.jumps_back: dict = {}
        self._loop_states: dict = {}       # jump back -> (last pass to compare, kept state)
        self.f_value = 0.0                 # the last F as programmed ($P_F)
        self.feed_type = 94                # G93/G94/G95/G97/G971 (group 15)
        self._default_feed(ncu)
        self.settable_code = 500           # G500, G54.. (group 8)
        self.master_spindle = 1            # SETMS
        self.modal_call = None             # (Unit, args, name) of an active MCALL
        self.pole_wcs = None               # polar coordinates: pole (G110-G112), None: origin
        self.polar = [0.0, 0.0]            # AP (deg), RP (mm) as last programmed
        self.warnings = Warnings()
        self.recorded: list[RecordedCall] = []
        self.units: dict = {}              # name -> ncsim.nc.flow.Unit (PROCs and files)
        self.macros: dict = {}             # DEFINE ... AS of the definitions files
        self.programs: dict = {}           # file -> its parsed Program (ncsim.nc.outline)
        self.out: PathOutput | None = None
        self.ended = False
        self.line = 0                      # line of the block being executed

    def _default_feed(self, ncu) -> None:
        """SD42110 ``$SC_DEFAULT_FEED`` (840D sl parameter manual "Detailed machine data
        description", setting data 42110 DEFAULT_FEED): the path feed a program starts with,
        in force until its first F, read at the program start in the feed type then active
        (G94 at reset here, so mm/min). As delivered it is 0, and a G1/G2/G3 before any F is
        alarm 10860 "no feed programmed" (:meth:`ncsim.nc.moves.Moves._require_feed`)."""
        feed_mm_s = ncu.default_feed_mm_s if ncu is not None else 0.0
        if feed_mm_s > 0.0:
            self.f_value = mm_s_to_mm_min(feed_mm_s)
            self.st.feed_mm_s = feed_mm_s

    def count(self, file: str, line: int) -> None:
        """One more block executed; the budget stops endless loops."""
        self.blocks += 1
        if self.blocks > self.budget:
            raise self.budget_error(file, line)

    def add_lines(self, n: int) -> None:
        """A program file of ``n`` lines was loaded: the automatic budget grows by as much."""
        if self.auto_budget:
            self.budget += n

    def jumped_back(self, file: str, line: int, col: int) -> None:
        """A jump back (GOTOB, ENDWHILE, ENDLOOP, ...) was taken: what a budget error names."""
        self.count_jump((file, line, col))

    def count_jump(self, key: tuple) -> None:
        """Count a jump back at ``key`` (file, line, col); stop a pass that decided nothing
        (:meth:`_decided_nothing`); from the 1024th on, watch whether the program comes back
        to the same state there (:meth:`_watch`)."""
        seen = self.jumps_back.get(key)
        frame = self.stack[-1]
        if seen is None:
            self.jumps_back[key] = [1, 0, self.decisions, frame]
            return
        if seen[2] == self.decisions and seen[3] is frame:
            raise self._decided_nothing(key, seen[0] + 1)
        n = seen[0] + 1
        if n >= LOOP_WATCH_FROM:
            self._watch(key, n)
        seen[0] = n         # counted once it did not raise (a compiled op that raised runs
        seen[2] = self.decisions    # its block again by the block path, which counts it)
        seen[3] = frame

    def _decided_nothing(self, key: tuple, n: int) -> NcError:
        """An endless loop for certain, moving or not: between two takings of the same jump
        back, in the same call of its unit, no condition on the program's state was evaluated
        (no IF, WHILE, UNTIL, CASE, conditional jump, FOR or REPEAT count: ``decisions`` did
        not change). Every jump destination is fixed, so what ran between the two takings runs
        again, and again: nothing in the loop can end it (a LOOP without exit, WHILE 1, an
        unconditional GOTOB). Found on the second pass, however much the loop moves."""
        return NcSemanticError(f"endless loop: nothing between two passes of this jump back "
                               f"decides anything (no condition on R parameters, variables or "
                               f"counters), so nothing can end it (taken {n} times)", *key)

    def for_jump_back(self, fr, start: int, value: float, key: tuple) -> None:
        """The ENDFOR of the FOR block ``start`` goes back for another pass, its counter at
        ``value`` (a decision: the counter against its end). A FOR loop is bounded: its end was
        fixed when it began, and each pass that raises the counter by a whole step above every
        pass before brings that end nearer. The automatic budget gets back the blocks of such
        a pass (those not refunded already, by a FOR loop inside), so that a long FOR loop
        runs however many passes it has, while a pass that does not advance the counter (the
        body setting it back) is charged like any other loop's."""
        self.decisions += 1
        self.count_jump(key)
        mark = fr.for_marks.get(start)
        if mark is None:                    # a jump into the loop: no FOR began it here
            mark = fr.for_marks[start] = [math.inf, self.blocks, self.refunded]
        if value >= mark[0] + 1.0:
            mark[0] = value
            if self.auto_budget:
                back = (self.blocks - mark[1]) - (self.refunded - mark[2])
                self.budget += back
                self.refunded += back
                self.jumps_back[key][1] += 1
        mark[1] = self.blocks
        mark[2] = self.refunded

    def for_begins(self, fr, start: int, value: float) -> None:
        """The FOR block ``start`` begins with its counter at ``value``: the mark the passes
        of :meth:`for_jump_back` are measured from."""
        fr.for_marks[start] = [value, self.blocks, self.refunded]

    def _watch(self, key: tuple, n: int) -> None:
        """An endless loop for certain: at the same jump back, the whole state that decides what
        the program does next (R parameters, variables, call stack, modal state, position) is
        the same as before. The interpreter is deterministic, so it would repeat forever. At
        every power of two of the jump's count the state is kept, and the next
        LOOP_WATCH_WINDOW passes are compared with it (cycles up to that length are found)."""
        if n & (n - 1) == 0:
            self._loop_states[key] = (n + LOOP_WATCH_WINDOW, self.loop_state())
            return
        kept = self._loop_states.get(key)
        if kept is None or n > kept[0] or self.loop_state() != kept[1]:
            return
        period = n - (kept[0] - LOOP_WATCH_WINDOW)
        every = "after every pass" if period == 1 else f"every {period} passes"
        raise NcSemanticError(f"endless loop: at this jump back the program returns to the same "
                              f"state (R parameters, variables, position) {every} (taken {n} "
                              f"times)", *key)

    def loop_state(self) -> tuple:
        """What decides the program's future: R parameters, variables, the call stack (the top
        frame's position is the jump's own), the modal state and the other settings."""
        frames = tuple(_frame_state(fr, top=(k == len(self.stack) - 1))
                       for k, fr in enumerate(self.stack))
        st = self.st
        modal = tuple(tuple(v) if isinstance(v, list) else v
                      for v in (getattr(st, f) for f in st.__slots__ if f not in _OUTPUT_ONLY))
        globals_ = tuple(sorted((k, _value_state(e)) for k, e in self.vars.globals.items()))
        return (tuple(sorted(self.vars.r.items())), frames, modal, globals_, self.f_value,
                self.feed_type, self.settable_code, self.master_spindle, self.modal_call,
                None if self.pole_wcs is None else tuple(self.pole_wcs), tuple(self.polar))

    def budget_error(self, file: str, line: int) -> NcError:
        """The block budget is exhausted: the error names the jump back taken most often
        (FOR passes given back to the budget not counted)."""
        what = f"block budget of {self.budget - self.refunded} blocks exceeded"
        hint = "(--block-budget N allows more)"
        if not self.jumps_back:
            return NcSemanticError(f"{what}: endless loop? {hint}", file, line, 1)
        seen = self.jumps_back          # the passes the budget gave back do not count
        key = max(seen, key=lambda k: seen[k][0] - seen[k][1])
        (lfile, lline, lcol), n = key, seen[key][0]
        return NcSemanticError(f"{what}: endless loop? this jump back was taken {n} times "
                               f"{hint}", lfile, lline, lcol)


class BlockContext:
    """One executed block: its location, for errors, warnings, records and evaluation."""

    __slots__ = ("state", "frame", "file", "line")

    def __init__(self, state: InterpreterState, frame: CallFrame, line: int) -> None:
        self.state = state
        self.frame = frame
        self.file = frame.unit.file
        self.line = line

    def error(self, message: str, col: int = 0, cls: type[NcError] = NcSemanticError) -> NcError:
        """The error to raise at this block's column ``col``: ``raise ctx.error(...)``."""
        return cls(message, self.file, self.line, col)

    def unsupported(self, message: str, col: int = 0) -> NcError:
        """Something real on an 840D that ncsim does not simulate (and would get wrong)."""
        return NcUnsupportedError(message, self.file, self.line, col)

    def warn(self, kind: str, message: str, col: int = 0) -> None:
        self.state.warnings.add(kind, message, self.file, self.line, col)

    def record(self, name: str, args: tuple) -> None:
        """Keep a setting that is not simulated; it applies from the next segment on."""
        state = self.state
        state.recorded.append(RecordedCall(name, args, self.file, self.line, state.out.n_segments))

    def eval(self, expr):
        return evaluate(expr, self.state.vars, self)

    def number(self, expr, what: str) -> float:
        return evaluate_number(expr, self.state.vars, self, what)

    def in_range(self, value: float, what: str, col: int) -> float:
        """``value`` if it fits an 840D word (|value| < 1e9), else the error at ``col``."""
        if not abs(value) < WORD_VALUE_LIMIT:
            raise self.error(f"{what}{format_value(value)} is out of range (|value| < 1e9)", col)
        return value

    def whole_number(self, value: float, what: str, col: int) -> int:
        """A whole, non-negative number (G, M, D, L, P values)."""
        if not (0.0 <= value < 1e9) or value != int(value):
            raise self.error(f"{what} needs a whole number, got {format_value(value)}", col)
        return int(value)


class WordContext(BlockContext):
    """A block of words: its context and its evaluated words, by role."""

    __slots__ = ("gcodes", "axes", "centre", "inter", "values", "m", "h", "commands", "calls",
                 "call_exprs", "first_col", "polar")

    def __init__(self, state: InterpreterState, frame: CallFrame, line: int) -> None:
        self.state = state           # the base fields set here, not by super(): a call less per block
        self.frame = frame
        self.file = frame.unit.file
        self.line = line
        self.gcodes: dict = {}       # group -> (code, col)
        self.axes: dict = {}         # X/Y/Z -> (value, mode, col)
        self.centre: dict = {}       # I/J/K -> (value, mode, col)
        self.inter: dict = {}        # I1/J1/K1 -> (value, mode, col)
        self.values: dict = {}       # CR AR TURN F S T D ADIS ADISPOS RPL L P -> (value, col)
        self.m: list = []            # (code, col)
        self.h: list = []
        self.commands: list = []     # (name, col)
        self.calls: list = []        # (name, args, col)
        self.call_exprs: list = []   # the argument expressions of each call (VAR parameters)
        self.first_col = 1
        self.polar: dict = {}        # AP/RP -> (value, mode, col)


#: modal-state fields that shape the output (stops, dwells, tangents) but not what runs next
_OUTPUT_ONLY = ("last_rapid", "last_segment", "pending_stop", "pending_dwell_s")


def _value_state(entry):
    value = entry[1]
    data = getattr(value, "data", None)
    return (entry[0], tuple(data) if data is not None else value)


def _frame_state(fr, top: bool) -> tuple:
    variables = tuple(sorted((k, _value_state(e)) for k, e in fr.variables.items()))
    where = None if top else (fr.pc, fr.row)
    return (id(fr.unit), where, fr.repeats_left, tuple(sorted(fr.for_end.items())),
            tuple(sorted(fr.repeats.items())), tuple(fr.section_ends), variables)
