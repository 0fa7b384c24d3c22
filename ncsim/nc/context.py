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

from dataclasses import dataclass, field
from pathlib import Path as FsPath

import numpy as np

from ncsim.errors import NcError, NcSemanticError, NcUnsupportedError, NcWarning
from ncsim.nc.expr import evaluate, evaluate_number, format_value
from ncsim.nc.modal import ModalState
from ncsim.nc.variables import Variables
from ncsim.path import PathBuilder

WARNING_CAP = 20             # warnings of one kind shown before they are only counted
WORD_VALUE_LIMIT = 1e9       # |value| of a word: the 840D accepts +-999 999 999.9999
DEFAULT_CIRCLE_ERROR_CONST_MM = 0.01   # MD21000 $MC_CIRCLE_ERROR_CONST (840D default)
DEFAULT_CIRCLE_ERROR_FACTOR = 0.001    # MD21010 $MC_CIRCLE_ERROR_FACTOR (840D default)


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
    """Warnings in order, each site once; beyond WARNING_CAP of one kind only counted."""

    def __init__(self) -> None:
        self.items: list[NcWarning] = []
        self._seen: set = set()
        self._counts: dict[str, int] = {}
        self._hidden: dict[str, list] = {}

    def add(self, kind: str, message: str, file: str, line: int, col: int = 0) -> None:
        key = (file, line, col, message)
        if key in self._seen:
            return
        self._seen.add(key)
        n = self._counts[kind] = self._counts.get(kind, 0) + 1
        if n <= WARNING_CAP:
            self.items.append(NcWarning(message, file, line, col))
        else:
            hidden = self._hidden.setdefault(kind, [0, file, line])
            hidden[0] += 1

    def result(self) -> tuple[NcWarning, ...]:
        tail = [NcWarning(f"{n} more {kind} warnings not shown (the first of them here)", file, line)
                for kind, (n, file, line) in self._hidden.items()]
        return tuple(self.items + tail)


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


class PathOutput:
    """The :class:`~ncsim.path.Path` being built: rows from the block path, columns from runs.

    Rows are buffered and turned into columns before every column chunk, so the segments stay
    in execution order."""

    def __init__(self, file: str) -> None:
        self.builder = PathBuilder((file,))
        self.rows: list[dict] = []
        self.n_segments = 0

    def append(self, row: dict) -> None:
        self.rows.append(row)
        self.n_segments += 1

    def extend(self, n: int, **columns) -> None:
        """Add ``n`` segments given as columns (after the buffered rows)."""
        self.flush()
        self.builder.extend(**columns)
        self.n_segments += n

    def flush(self) -> None:
        if not self.rows:
            return
        cols = {name: [r[name] for r in self.rows] for name in self.rows[0]}
        self.builder.extend(**{name: np.array(v) for name, v in cols.items()})
        self.rows = []


class InterpreterState:
    """Everything an interpretation changes, shared by the interpreter's collaborators.

    ``machine`` gives the work offsets (overridden by ``setup_offsets``) and the circle
    end-point tolerances MD21000/MD21010; ``budget`` bounds the executed blocks."""

    def __init__(self, machine, budget: int, setup_offsets, fast: bool, skip_blocks: bool,
                 search_dir) -> None:
        self.machine = machine
        self.budget = budget
        self.offsets = dict(setup_offsets or {})
        self.fast = fast
        self.skip_blocks = skip_blocks
        self.search_dir = FsPath(search_dir) if search_dir is not None else None
        ncu = machine.ncu if machine is not None else None
        self.circle_const_mm = ncu.circle_error_const_mm if ncu else DEFAULT_CIRCLE_ERROR_CONST_MM
        self.circle_factor = ncu.circle_error_factor if ncu else DEFAULT_CIRCLE_ERROR_FACTOR
        self.st = ModalState()             # never replaced: collaborators keep a reference
        # the reset values CYCLE832's deselection returns to (MD20150 $MC_GCODE_RESET_VALUES)
        self.reset_values = (self.st.cp_mode, self.st.accel_mode, self.st.ffw)
        self.cycle832_notes: set = set()   # one-time CYCLE832 warnings already given
        self.stack: list[CallFrame] = []
        self.vars = Variables(self.stack)
        self.blocks = 0
        self.warnings = Warnings()
        self.recorded: list[RecordedCall] = []
        self.units: dict = {}              # name -> ncsim.nc.flow.Unit (PROCs and files)
        self.out: PathOutput | None = None
        self.ended = False
        self.line = 0                      # line of the block being executed

    def count(self, file: str, line: int) -> None:
        """One more block executed; the budget stops endless loops."""
        self.blocks += 1
        if self.blocks > self.budget:
            raise NcSemanticError(f"block budget of {self.budget} blocks exceeded (endless loop?)",
                                  file, line, 1)


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
                 "first_col")

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
        self.first_col = 1
