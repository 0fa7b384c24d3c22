"""The 840D interpreter: a parsed program -> a :class:`~ncsim.path.Path` plus warnings.

Block execution follows a fixed order (grbl's, adapted to the 840D):

1. evaluate the words left to right (assignments take effect at once, so ``R1=5 X=R1`` moves
   to 5); reject unknown words and two G functions of one group;
2. modal G functions (settable frame, units, plane, G90/G91, feed type, G60/G64.., G601..);
3. frame instructions (TRANS ROT SCALE MIRROR and their A-forms; the block's X Y Z are their
   arguments), F S T D H M, ADIS/ADISPOS, SOFT/BRISK/DRIVE, FFWON/FFWOF, STOPRE, recorded
   settings (CYCLE832, COMP*, DYN*, MSG);
4. the motion (G0 G1 G2 G3 CIP CT) or the dwell (G4), then subprogram calls, then M17/RET and
   M2/M30.

840D semantics implemented: G70/G71 scale geometry only (feeds stay mm/min), G700/G710 scale
geometry and feed; X=AC(..)/X=IC(..) per axis; I J K incremental to the start point unless
I=AC(..); CR= (negative: more than a half circle), AR=, TURN=, CIP with I1= J1= K1= (G90/G91
apply to the intermediate point), CT tangential to the previous segment; the circle end-point
check |r_end - r_start| <= max(MD21000, MD21010 * r_start); the frame chain of
:mod:`ncsim.frames` with SUPA/G53/G153 suppressing frames for one block and MIRROR reversing
arcs. Internal units: mm, s, rad (F mm/min -> mm/s and inch -> mm happen here, once).

The tool starts at the machine origin (0, 0, 0). A motion block whose end equals its start
makes no segment (a full circle G2/G3 does). ``stop_before`` marks: an M or H output in the
block or since the last segment, STOPRE, a change of SOFT/BRISK/DRIVE, a G4 dwell, and a
change between rapid and feed motion; S, T, D and F changes do not stop.

Fast path: consecutive plain lines (:mod:`ncsim.fastparse`) are interpreted as whole columns
(forward fill of modal words, cumulative sums for G91, one affine frame per run, vectorised
arcs). Whenever a run needs anything else (an error, a warning, a budget overrun, CIP/CT
modal, a short run) it is executed block by block instead, so both ways give the same Path,
warnings and errors; ``interpret_text(..., fast=False)`` parses every line with Lark and never
takes the fast path (``tests/test_fastpath.py`` compares the two).
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path as FsPath

import numpy as np

from ncsim.nc import program as P
from ncsim.errors import NcSemanticError, NcUnsupportedError, NcWarning
from ncsim.nc.expr import Where, evaluate, evaluate_number, format_value, truthy
from ncsim.nc.frames import (Frame, arc_normal, mirroring, rotation_in_plane, rotation_rpy, scaling,
                     translation)
from ncsim.geometry import (PLANE_AXES, center_from_opening_angle, center_from_radius, center_tangential,
                       circle_through_points, plane_normal)
from ncsim.machine import MachineSpec
from ncsim.nc.modal import (ACCEL_COMMANDS, CIP, COMMANDS_NOT_SIMULATED, COMPRESSOR_COMMANDS, CT,
                    DYNAMIC_COMMANDS, G_CODES, G_UNSUPPORTED, UNSUPPORTED_MOTION, M_END, M_END_RESET, M_OPTIONAL_STOP, M_RETURN, M_SPINDLE_CCW,
                    M_SPINDLE_CW, M_SPINDLE_STOP, M_STOP, M_TOOL_CHANGE, MOTION_NAMES, ModalState)
from ncsim.nc.parse import parse_text, read_program_text
from ncsim.path import ARC, LINE, Path, PathBuilder
from ncsim.units import mm_min_to_mm_s

VECTOR_MIN_ROWS = 8          # shorter plain runs are cheaper block by block
WARNING_CAP = 20             # warnings of one kind shown before they are only counted
MAX_CALL_DEPTH = 16          # subprogram nesting (the 840D allows 16 levels with its default MD)
FULL_CIRCLE_TOL_MM = 1e-9    # an arc whose end is this close to its start is a full circle
DEFAULT_CIRCLE_ERROR_CONST_MM = 0.01   # MD21000 $MC_CIRCLE_ERROR_CONST (840D default)
DEFAULT_CIRCLE_ERROR_FACTOR = 0.001    # MD21010 $MC_CIRCLE_ERROR_FACTOR (840D default)
TWO_PI = 2.0 * math.pi

_AXES = ("X", "Y", "Z")
_CENTRE = ("I", "J", "K")
_INTER = ("I1", "J1", "K1")
_ROTARY = ("A", "B", "C")
_EXTRA_AXES = ("U", "V", "W")
_FRAME_COMMANDS = ("TRANS", "ATRANS", "ROT", "AROT", "SCALE", "ASCALE", "MIRROR", "AMIRROR")
_TRANSFORMATIONS = ("TRAORI", "TRANSMIT", "TRACYL", "TRAANG")
_KEYWORDS = ("IF", "ELSE", "ENDIF", "WHILE", "ENDWHILE", "FOR", "TO", "ENDFOR", "REPEAT", "UNTIL",
             "LOOP", "ENDLOOP", "GOTO", "GOTOF", "GOTOB", "GOTOC", "DEF", "PROC", "EXTERN")
_VAR_TYPES = {"REAL": 0.0, "INT": 0.0, "BOOL": 0.0, "STRING": "", "CHAR": ""}
_SUBPROGRAM_SUFFIXES = (".SPF", ".spf", ".MPF", ".mpf")
_NAN3 = (math.nan, math.nan, math.nan)
_ZERO3 = (0.0, 0.0, 0.0)


# =============================================================================================
# Public API
# =============================================================================================

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


@dataclass(frozen=True, slots=True)
class InterpretResult:
    path: Path
    warnings: tuple[NcWarning, ...]
    blocks_executed: int
    recorded: tuple[RecordedCall, ...] = ()

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
                   block_budget: int = 10_000_000,
                   setup_offsets: dict[str, tuple[float, float, float]] | None = None,
                   fast: bool = True, skip_blocks: bool = False,
                   search_dir: str | FsPath | None = None) -> InterpretResult:
    """Interpret program text. ``fast=False`` sends every line through the Lark grammar.

    ``machine`` gives work offsets and circle tolerances; ``setup_offsets`` (``{"G54": (x, y,
    z)}``) override its offsets. ``skip_blocks`` activates block skip (``/`` blocks are not
    executed). Subprograms called by name are looked up as PROCs in the same text, then as
    ``NAME.SPF``/``NAME.MPF`` files in ``search_dir``.
    """
    program = parse_text(text, file, fast=fast)
    interp = _Interpreter(machine, block_budget, setup_offsets, fast, skip_blocks, search_dir)
    return interp.run(program)


def interpret_file(path: str | FsPath, machine: MachineSpec | None = None, *,
                   block_budget: int = 10_000_000,
                   setup_offsets: dict[str, tuple[float, float, float]] | None = None,
                   fast: bool = True, skip_blocks: bool = False) -> InterpretResult:
    """Interpret a program file; subprogram files are looked up next to it."""
    p = FsPath(path)
    return interpret_text(read_program_text(p), str(path), machine, block_budget=block_budget,
                          setup_offsets=setup_offsets, fast=fast, skip_blocks=skip_blocks,
                          search_dir=p.parent)


# =============================================================================================
# Pure geometry kernels (shared by the block-by-block and the vectorised path)
# =============================================================================================

def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise dot product of (n, 3) arrays, written out so every row is computed alike."""
    return a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1] + a[:, 2] * b[:, 2]


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.stack([a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1],
                     a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2],
                     a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]], axis=1)


def arc_columns(start_mm: np.ndarray, end_mm: np.ndarray, center_mm: np.ndarray,
                normal: np.ndarray, turns) -> dict[str, np.ndarray]:
    """Arcs (rows of (n, 3) arrays) turning counter-clockwise about the unit ``normal``.

    Returns the centre projected into the plane through the start, the start and end radii
    (in-plane distances to the centre), the sweep in (0, 2 pi] plus 2 pi * turns (a full
    circle when the in-plane end coincides with the start), the helix rise along the normal
    and the length sqrt((r_start * sweep)^2 + rise^2).
    """
    ds = start_mm - center_mm
    de = end_mm - center_mm
    hs = _dot(ds, normal)
    he = _dot(de, normal)
    ps = ds - hs[:, None] * normal
    pe = de - he[:, None] * normal
    r_start = np.sqrt(_dot(ps, ps))
    r_end = np.sqrt(_dot(pe, pe))
    ang = np.arctan2(_dot(_cross(ps, pe), normal), _dot(ps, pe))
    chord = pe - ps
    full = np.sqrt(_dot(chord, chord)) <= FULL_CIRCLE_TOL_MM
    sweep = np.where(full, TWO_PI, np.where(ang > 0.0, ang, ang + TWO_PI)) + TWO_PI * turns
    helix = he - hs
    arc_len = r_start * sweep
    return {"center_mm": center_mm + hs[:, None] * normal, "radius_mm": r_start,
            "radius_end_mm": r_end, "sweep_rad": sweep, "helix_mm": helix,
            "length_mm": np.sqrt(arc_len * arc_len + helix * helix)}


def circle_error_mm(r_start, r_end):
    """|r_end - r_start|: what the 840D's circle end-point monitoring checks."""
    return np.abs(r_end - r_start)


def circle_tolerance_mm(r_start, const_mm: float, factor: float):
    """max(MD21000, MD21010 * r_start): the allowed difference of start and end radius."""
    return np.maximum(const_mm, factor * r_start)


def end_tangent(segment: tuple) -> np.ndarray:
    """Unit tangent at the end of a segment given as the state's ``last_segment`` tuple."""
    kind, start, end, center, normal, radius, sweep, helix = segment
    if kind == LINE:
        d = np.subtract(end, start)
        return d / np.linalg.norm(d)
    w = np.asarray(normal)
    d = np.subtract(start, center)
    u = (d - np.dot(d, w) * w) / radius
    v = np.cross(w, u)
    t = radius * (-math.sin(sweep) * u + math.cos(sweep) * v) + (helix / sweep) * w
    return t / np.linalg.norm(t)


def _ffill(values: np.ndarray, present: np.ndarray, init):
    """``values`` with absent entries replaced by the last present one (``init`` before any)."""
    idx = np.where(present, np.arange(len(values)), -1)
    np.maximum.accumulate(idx, out=idx)
    return np.where(idx >= 0, values[np.maximum(idx, 0)], init)


# =============================================================================================
# Program units and control structures
# =============================================================================================

@dataclass(slots=True)
class _Unit:
    """A main program or a PROC: its items, labels and paired control statements."""

    name: str
    file: str
    items: list
    params: tuple = ()
    labels: dict = field(default_factory=dict)
    pairs: dict = field(default_factory=dict)      # opener <-> closer (and ELSE -> ENDIF)
    else_of: dict = field(default_factory=dict)    # IF -> ELSE


_OPENERS = {"IF": "ENDIF", "WHILE": "ENDWHILE", "FOR": "ENDFOR", "REPEAT": "UNTIL", "LOOP": "ENDLOOP"}
_CLOSERS = {v: k for k, v in _OPENERS.items()}


def _structure_word(block) -> str | None:
    s = block.statement if isinstance(block, P.Block) else None
    if isinstance(s, P.If):
        return "IF"
    if isinstance(s, P.While):
        return "WHILE"
    if isinstance(s, P.For):
        return "FOR"
    if isinstance(s, P.Until):
        return "UNTIL"
    if isinstance(s, P.Keyword):
        return s.name
    return None


def _compile_unit(unit: _Unit) -> _Unit:
    """Pair IF/ELSE/ENDIF, WHILE, FOR, REPEAT/UNTIL, LOOP and collect labels (errors located)."""
    stack: list[tuple[str, int]] = []
    for idx, item in enumerate(unit.items):
        if not isinstance(item, P.Block):
            continue
        if item.label is not None:
            if item.label in unit.labels:
                first = unit.items[unit.labels[item.label]].line
                raise NcSemanticError(f"label {item.label} defined twice (first at line {first})",
                                      unit.file, item.line, 1)
            unit.labels[item.label] = idx
        word = _structure_word(item)
        if word is None:
            continue
        col = item.statement.col
        if word in _OPENERS:
            stack.append((word, idx))
        elif word == "ELSE":
            if not stack or stack[-1][0] != "IF" or stack[-1][1] in unit.else_of:
                raise NcSemanticError("ELSE without IF", unit.file, item.line, col)
            unit.else_of[stack[-1][1]] = idx
        else:
            opener = _CLOSERS[word]
            if not stack or stack[-1][0] != opener:
                what = (f"{word} closes {stack[-1][0]} of line {unit.items[stack[-1][1]].line}"
                        if stack else f"{word} without {opener}")
                raise NcSemanticError(what, unit.file, item.line, col)
            _, start = stack.pop()
            unit.pairs[start] = idx
            unit.pairs[idx] = start
            if start in unit.else_of:
                unit.pairs[unit.else_of[start]] = idx
    if stack:
        word, idx = stack[-1]
        block = unit.items[idx]
        raise NcSemanticError(f"{word} without {_OPENERS[word]}", unit.file, block.line,
                              block.statement.col)
    return unit


def _split_units(program: P.Program, main_name: str) -> list[_Unit]:
    """The program's units: the main part, then one per PROC (a PROC runs to the next PROC)."""
    units: list[_Unit] = []
    current = _Unit(main_name, program.file, [])
    for item in program.items:
        if isinstance(item, P.Block) and isinstance(item.statement, P.Proc):
            if current.items or units:
                units.append(current)
            current = _Unit(item.statement.name, program.file, [item], item.statement.params)
        else:
            current.items.append(item)
    units.append(current)
    return [_compile_unit(u) for u in units]


# =============================================================================================
# Interpreter
# =============================================================================================

class _Warnings:
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
class _CallFrame:
    unit: _Unit
    file_index: int
    pc: int = 0
    row: int = 0                 # row to resume at inside a PlainRun (after a jump)
    variables: dict = field(default_factory=dict)   # name -> [type, value]
    args: tuple = ()
    repeats_left: int = 1
    for_end: dict = field(default_factory=dict)


@dataclass(slots=True)
class _Words:
    """A block's evaluated words, by role."""

    gcodes: dict = field(default_factory=dict)     # group -> (code, col)
    axes: dict = field(default_factory=dict)       # X/Y/Z -> (value, mode, col)
    centre: dict = field(default_factory=dict)     # I/J/K -> (value, mode, col)
    inter: dict = field(default_factory=dict)      # I1/J1/K1 -> (value, mode, col)
    values: dict = field(default_factory=dict)     # CR AR TURN F S T D ADIS ADISPOS RPL L P -> (value, col)
    m: list = field(default_factory=list)          # (code, col)
    h: list = field(default_factory=list)
    commands: list = field(default_factory=list)   # (name, col)
    calls: list = field(default_factory=list)      # (name, args, col)
    first_col: int = 1


class _Interpreter:
    def __init__(self, machine, budget, setup_offsets, fast, skip_blocks, search_dir):
        self.machine = machine
        self.budget = budget
        self.offsets = dict(setup_offsets or {})
        self.fast = fast
        self.skip_blocks = skip_blocks
        self.search_dir = FsPath(search_dir) if search_dir is not None else None
        ncu = machine.ncu if machine is not None else None
        self.circle_const_mm = ncu.circle_error_const_mm if ncu else DEFAULT_CIRCLE_ERROR_CONST_MM
        self.circle_factor = ncu.circle_error_factor if ncu else DEFAULT_CIRCLE_ERROR_FACTOR
        self.st = ModalState()
        self.r: dict[int, float] = {}
        self.blocks = 0
        self.warnings = _Warnings()
        self.recorded: list[RecordedCall] = []
        self.units: dict[str, _Unit] = {}
        self.builder: PathBuilder | None = None
        self.rows: list[dict] = []
        self.n_segments = 0
        self.stack: list[_CallFrame] = []
        self.ended = False
        self.line = 0                      # line of the block being executed

    # ---- driver -----------------------------------------------------------------------------

    def run(self, program: P.Program) -> InterpretResult:
        self.builder = PathBuilder((program.file,))
        units = _split_units(program, FsPath(program.file).stem.upper() or "MAIN")
        self._add_units(units[1:])
        main = units[0]
        self._push(main, (), 1)
        try:
            while self.stack and not self.ended:
                self._step(self.stack[-1])
        except RecursionError:
            raise NcSemanticError("expression nested too deeply", self.stack[-1].unit.file,
                                  self.line, 1) from None
        self._flush_rows()
        self.builder.end_dwell_s = self.st.pending_dwell_s
        return InterpretResult(self.builder.build(), self.warnings.result(), self.blocks,
                               tuple(self.recorded))

    def _step(self, fr: _CallFrame) -> None:
        if fr.pc >= len(fr.unit.items):
            self._return()
            return
        item = fr.unit.items[fr.pc]
        if isinstance(item, P.PlainRun):
            run = item.slice(fr.row) if fr.row else item
            fr.row = 0
            fr.pc += 1
            self._exec_run(fr, run)
            return
        self.line = item.line
        self._count(fr, item.line)
        fr.pc += 1
        if self.skip_blocks and item.skip_level is not None:
            return
        if item.statement is not None:
            self._exec_statement(fr, item, item.statement)
        else:
            self._exec_block(fr, item)

    def _count(self, fr: _CallFrame, line: int) -> None:
        self.blocks += 1
        if self.blocks > self.budget:
            raise NcSemanticError(f"block budget of {self.budget} blocks exceeded (endless loop?)",
                                  fr.unit.file, line, 1)

    def _return(self) -> None:
        fr = self.stack.pop()
        if fr.repeats_left > 1:
            self._push(fr.unit, fr.args, fr.repeats_left - 1)

    # ---- helpers for errors, warnings, scopes --------------------------------------------

    def _where(self, fr: _CallFrame, line: int) -> Where:
        return Where(fr.unit.file, line)

    def _warn(self, fr: _CallFrame, kind: str, message: str, line: int, col: int = 0) -> None:
        self.warnings.add(kind, message, fr.unit.file, line, col)

    def _record(self, fr: _CallFrame, name: str, args: tuple, line: int) -> None:
        self.recorded.append(RecordedCall(name, args, fr.unit.file, line, self.n_segments))

    def read_r(self, index: int) -> float:
        return self.r.get(index, 0.0)

    def read_var(self, name: str):
        entry = self.stack[-1].variables.get(name)
        return None if entry is None else entry[1]

    def _eval(self, fr, expr, line):
        return evaluate(expr, self, self._where(fr, line))

    def _eval_number(self, fr, expr, line, what):
        return evaluate_number(expr, self, self._where(fr, line), what)

    # ---- control statements -------------------------------------------------------------

    def _exec_statement(self, fr: _CallFrame, block: P.Block, s) -> None:
        unit, here = fr.unit, fr.pc - 1
        if isinstance(s, P.Goto):
            self._jump(fr, s, block)
        elif isinstance(s, P.IfGoto):
            if truthy(self._eval(fr, s.cond, block.line)):
                self._jump(fr, s.goto, block)
        elif isinstance(s, P.If):
            if not truthy(self._eval(fr, s.cond, block.line)):
                fr.pc = unit.else_of.get(here, unit.pairs[here]) + 1
        elif isinstance(s, P.While):
            if not truthy(self._eval(fr, s.cond, block.line)):
                fr.pc = unit.pairs[here] + 1
        elif isinstance(s, P.For):
            self._for(fr, s, block, here)
        elif isinstance(s, P.Until):
            if not truthy(self._eval(fr, s.cond, block.line)):
                fr.pc = unit.pairs[here] + 1
        elif isinstance(s, P.Keyword):
            self._keyword(fr, s, block, here)
        elif isinstance(s, P.Def):
            self._define(fr, s, block)
        elif isinstance(s, P.Proc):
            raise NcSemanticError(f"PROC {s.name} inside a program: a PROC must be the first block "
                                  f"of its unit", unit.file, block.line, s.col)
        # Extern: a declaration only

    def _keyword(self, fr: _CallFrame, s: P.Keyword, block: P.Block, here: int) -> None:
        unit = fr.unit
        if s.name == "ELSE":
            fr.pc = unit.pairs[here] + 1          # end of the true branch: skip the else branch
        elif s.name == "ENDWHILE":
            fr.pc = unit.pairs[here]               # back to WHILE (re-evaluated)
        elif s.name == "ENDLOOP":
            fr.pc = unit.pairs[here] + 1
        elif s.name == "ENDFOR":
            start = unit.pairs[here]
            if start not in fr.for_end:
                raise NcSemanticError("ENDFOR reached without its FOR (a jump into the loop)",
                                      unit.file, block.line, s.col)
            var = unit.items[start].statement.var
            value = self._read_target(fr, var, block.line) + 1.0
            self._assign(fr, var, value, block.line)
            if value <= fr.for_end[start]:
                fr.pc = start + 1
        # ENDIF, REPEAT, LOOP: nothing to do

    def _for(self, fr: _CallFrame, s: P.For, block: P.Block, here: int) -> None:
        start = self._eval_number(fr, s.start, block.line, "FOR")
        end = self._eval_number(fr, s.end, block.line, "FOR")
        self._assign(fr, s.var, start, block.line)
        fr.for_end[here] = end
        if start > end:
            fr.pc = fr.unit.pairs[here] + 1

    def _read_target(self, fr: _CallFrame, var, line: int) -> float:
        if isinstance(var, P.RParam):
            return self.read_r(var.index)
        value = self.read_var(var.name)
        if value is None:
            raise NcSemanticError(f"undefined variable {var.name} (DEF it first)", fr.unit.file,
                                  line, var.col)
        return value

    def _define(self, fr: _CallFrame, s: P.Def, block: P.Block) -> None:
        if s.type_name not in _VAR_TYPES:
            raise NcUnsupportedError(f"variables of type {s.type_name} are not simulated",
                                     fr.unit.file, block.line, s.col)
        for v in s.variables:
            if v.dims:
                raise NcUnsupportedError(f"array variable {v.name} is not simulated", fr.unit.file,
                                         block.line, v.col)
            fr.variables[v.name] = [s.type_name, _VAR_TYPES[s.type_name]]
            if v.init is not None:
                self._assign(fr, P.Var(v.name, v.col), self._eval(fr, v.init, block.line), block.line)

    def _assign(self, fr: _CallFrame, target, value, line: int) -> None:
        if isinstance(target, P.RParam):
            if isinstance(value, str):
                raise NcSemanticError(f"R{target.index} needs a number, got a string", fr.unit.file,
                                      line, target.col)
            self.r[target.index] = value
            return
        entry = fr.variables.get(target.name)
        if entry is None:
            raise NcSemanticError(f"unknown word or undefined variable {target.name}", fr.unit.file,
                                  line, target.col)
        kind = entry[0]
        if (kind in ("STRING", "CHAR")) != isinstance(value, str):
            raise NcSemanticError(f"{target.name} is {kind}: cannot assign {format_value(value)!r}",
                                  fr.unit.file, line, target.col)
        if kind == "INT":
            value = float(math.floor(value + 0.5)) if value >= 0 else -float(math.floor(-value + 0.5))
        elif kind == "BOOL":
            value = 1.0 if value != 0.0 else 0.0
        entry[1] = value

    def _jump(self, fr: _CallFrame, goto: P.Goto, block: P.Block) -> None:
        here = fr.pc - 1
        dest = _find_destination(fr.unit, goto, here)
        if dest is None:
            if goto.kind == "GOTOC":
                return
            direction = {"GOTOF": "forward", "GOTOB": "backward", "GOTO": "forward and backward"}
            raise NcSemanticError(f"jump destination {goto.target} not found ({goto.kind} searches "
                                  f"{direction[goto.kind]})", fr.unit.file, block.line, goto.target.col)
        fr.pc, fr.row = dest

    # ---- subprograms -------------------------------------------------------------------------

    def _push(self, unit: _Unit, args: tuple, repeats: int) -> None:
        if len(self.stack) >= MAX_CALL_DEPTH:
            raise NcSemanticError(f"subprogram nesting deeper than {MAX_CALL_DEPTH} levels",
                                  unit.file, 0, 0)
        fr = _CallFrame(unit, self.builder.file_index(unit.file), pc=1 if _is_proc(unit) else 0,
                        args=args, repeats_left=repeats)
        for param, value in zip(unit.params, args):
            fr.variables[param.name] = [param.type_name, _VAR_TYPES.get(param.type_name, 0.0)]
            if value is not None:
                fr.variables[param.name][1] = value
        self.stack.append(fr)

    def _find_unit(self, name: str) -> _Unit | None:
        if name in self.units:
            return self.units[name]
        if self.search_dir is None:
            return None
        for suffix in _SUBPROGRAM_SUFFIXES:
            candidate = self.search_dir / f"{name}{suffix}"
            if candidate.is_file():
                program = parse_text(read_program_text(candidate), str(candidate), fast=self.fast)
                units = _split_units(program, name)
                self._add_units(units[1:])
                self.units.setdefault(name, units[0])
                return units[0]
        return None

    def _add_units(self, units: list[_Unit]) -> None:
        for u in units:
            if u.name in self.units:
                first = self.units[u.name]
                raise NcSemanticError(f"PROC {u.name} defined twice (first in {first.file} line "
                                      f"{first.items[0].line})", u.file, u.items[0].line, 1)
            self.units[u.name] = u

    def _call(self, fr: _CallFrame, name: str, args: tuple, repeats: int, line: int, col: int) -> None:
        unit = self._find_unit(name)
        if unit is None:
            raise NcSemanticError(f"unknown word {name} (no such command, PROC or subprogram file)",
                                  fr.unit.file, line, col)
        if len(args) > len(unit.params):
            raise NcSemanticError(f"{name} takes {len(unit.params)} arguments, got {len(args)}",
                                  fr.unit.file, line, col)
        for param in unit.params:
            if param.by_reference:
                raise NcUnsupportedError(f"call-by-reference parameter {param.name} (VAR) of {name} "
                                         f"is not simulated", fr.unit.file, line, col)
        if len(self.stack) >= MAX_CALL_DEPTH:
            raise NcSemanticError(f"subprogram nesting deeper than {MAX_CALL_DEPTH} levels",
                                  fr.unit.file, line, col)
        self._push(unit, args, repeats)

    # ---- one block ----------------------------------------------------------------------------

    def _exec_block(self, fr: _CallFrame, block: P.Block) -> None:
        w = self._collect(fr, block)
        st = self.st
        line = block.line
        self._modal_gcodes(fr, w, line)
        frame_cmd = self._frame_instruction(fr, w, line)
        self._feed_spindle_tool(fr, w, line)
        self._settings(fr, w, line)
        if "motion" in w.gcodes:
            st.motion = w.gcodes["motion"][0]
        if "dwell" in w.gcodes:
            self._dwell(fr, w, line)
        elif frame_cmd is None:
            self._motion(fr, w, line)
        self._calls(fr, w, line)
        self._program_flow(fr, w, line)

    def _collect(self, fr: _CallFrame, block: P.Block) -> _Words:
        """Evaluate the block's items in order into a _Words (assignments are done at once)."""
        w = _Words()
        if block.items:
            w.first_col = block.items[0].col
        for item in block.items:
            if isinstance(item, P.Assign):
                self._assign_item(fr, item, block.line)
            elif isinstance(item, P.Word):
                self._word(fr, w, item, block.line)
            elif isinstance(item, P.Command):
                self._command_word(fr, w, item, block.line)
            else:
                args = tuple(None if a is None else self._eval(fr, a, block.line) for a in item.args)
                w.calls.append((item.name, args, item.col))
        return w

    def _assign_item(self, fr: _CallFrame, item: P.Assign, line: int) -> None:
        if isinstance(item.target, P.SysVar):
            value = self._eval(fr, item.value, line)
            self._warn(fr, "system variable", f"assignment to system variable {item.target.name} "
                       f"is not simulated", line, item.col)
            self._record(fr, item.target.name, (value,), line)
            return
        self._assign(fr, item.target, self._eval(fr, item.value, line), line)

    def _word(self, fr: _CallFrame, w: _Words, word: P.Word, line: int) -> None:
        a = word.address
        file = fr.unit.file
        if a in _AXES or a in _CENTRE or a in _INTER:
            mode, expr = _axis_mode(word.value)
            value = _in_range(self._eval_number(fr, expr, line, a), a, file, line, word.col)
            table = w.axes if a in _AXES else w.centre if a in _CENTRE else w.inter
            if a in table:
                raise NcSemanticError(f"{a} programmed twice in one block", file, line, word.col)
            table[a] = (value, mode, word.col)
            return
        if a in _ROTARY or a in _EXTRA_AXES:
            self._eval(fr, _axis_mode(word.value, rotary=True)[1], line)
            kind = "rotary axis" if a in _ROTARY else "additional axis"
            self._warn(fr, kind, f"{kind} {a} is not simulated (the path uses X, Y, Z as programmed)",
                       line, word.col)
            return
        if a == "G":
            code = _integer(self._eval_number(fr, word.value, line, "G"), "G", file, line, word.col)
            self._gcode(fr, w, code, line, word.col)
            return
        if a in ("M", "H") or (len(a) > 1 and a[0] in "MS" and a[1:].isdigit()):
            self._aux_word(fr, w, word, line)
            return
        if a == "N":
            raise NcSemanticError("a block number N must begin the block", file, line, word.col)
        if a in ("AP", "RP"):
            raise NcUnsupportedError(f"polar coordinates ({a}=) are not simulated", file, line, word.col)
        if a in ("CR", "AR", "TURN", "F", "S", "T", "D", "ADIS", "ADISPOS", "RPL", "L", "P"):
            value = self._eval(fr, word.value, line)
            if isinstance(value, str) and a != "T":
                raise NcSemanticError(f"{a} needs a number, got the string {value!r}", file, line, word.col)
            if not isinstance(value, str):
                _in_range(value, a, file, line, word.col)
            if a in w.values:
                raise NcSemanticError(f"{a} programmed twice in one block", file, line, word.col)
            w.values[a] = (value, word.col)
            return
        raise NcSemanticError(f"unknown word {a}", file, line, word.col)

    def _aux_word(self, fr: _CallFrame, w: _Words, word: P.Word, line: int) -> None:
        a = word.address
        value = self._eval_number(fr, word.value, line, a)
        if a[0] == "S":   # S1=..: speed of spindle 1, taken as the spindle speed
            w.values["S"] = (value, word.col)
            return
        code = _integer(value, a[0], fr.unit.file, line, word.col)
        (w.h if a == "H" else w.m).append((code, word.col))

    def _gcode(self, fr: _CallFrame, w: _Words, code: int, line: int, col: int) -> None:
        file = fr.unit.file
        if code in G_UNSUPPORTED:
            raise NcUnsupportedError(f"{G_UNSUPPORTED[code]} is not simulated", file, line, col)
        if code not in G_CODES:
            raise NcSemanticError(f"unknown G function G{code}", file, line, col)
        group, _ = G_CODES[code]
        if group in w.gcodes:
            other = _g_name(group, w.gcodes[group][0])
            raise NcSemanticError(f"{other} and G{code} in one block (both in the {group} group)",
                                  file, line, col)
        w.gcodes[group] = (code, col)

    def _command_word(self, fr: _CallFrame, w: _Words, item: P.Command, line: int) -> None:
        name = item.name
        if name in ("CIP", "CT") and "motion" in w.gcodes:
            other = _g_name("motion", w.gcodes["motion"][0])
            raise NcSemanticError(f"{other} and {name} in one block (both in the motion group)",
                                  fr.unit.file, line, item.col)
        if name in ("CIP", "CT"):
            w.gcodes["motion"] = (CIP if name == "CIP" else CT, item.col)
            return
        if name in _KEYWORDS:
            raise NcSemanticError(f"{name} must begin a block of its own", fr.unit.file, line, item.col)
        w.commands.append((name, item.col))

    # ---- modal G functions -----------------------------------------------------------------

    def _modal_gcodes(self, fr: _CallFrame, w: _Words, line: int) -> None:
        st = self.st
        g = w.gcodes
        if "units" in g:
            st.units = g["units"][0]
        if "plane" in g:
            st.plane = g["plane"][0]
        if "distance" in g:
            st.incremental = g["distance"][0] == 91
        if "cp_mode" in g:
            st.cp_mode = g["cp_mode"][0]
        if "stop_window" in g:
            st.stop_window = g["stop_window"][0]
        if "settable" in g:
            self._settable_frame(fr, g["settable"], line)
        if "radius_comp" in g:
            code, col = g["radius_comp"]
            if code != 40 and st.radius_comp != code:
                self._warn(fr, "cutter compensation", f"G{code} cutter radius compensation is not "
                           f"simulated (the path is the programmed contour)", line, col)
            st.radius_comp = code
        if "limits" in g:
            code, col = g["limits"]
            self._warn(fr, "limits", f"G{code} limits are not simulated", line, col)

    def _settable_frame(self, fr: _CallFrame, word, line: int) -> None:
        code, col = word
        st = self.st
        if code == 500:
            st.settable_mm = _ZERO3
        else:
            name = f"G{code}"
            offset = self.offsets.get(name)
            if offset is None and self.machine is not None:
                found = self.machine.work_offset_mm(name)
                offset = None if found is None else tuple(float(v) for v in found)
            if offset is None:
                self._warn(fr, "work offset", f"{name} work offset not given (machine file "
                           f"[work_offsets] or setup file): taken as 0", line, col)
                offset = _ZERO3
            st.settable_mm = tuple(offset)
        st.set_frames()

    # ---- frames ------------------------------------------------------------------------------

    def _frame_instruction(self, fr: _CallFrame, w: _Words, line: int) -> str | None:
        found = [(n, c) for n, c in w.commands if n in _FRAME_COMMANDS]
        if not found:
            return None
        name, col = found[0]
        file = fr.unit.file
        if len(found) > 1:
            raise NcSemanticError(f"{found[1][0]} after {name}: one frame instruction per block",
                                  file, line, found[1][1])
        if "motion" in w.gcodes or w.centre or w.inter:
            raise NcSemanticError(f"{name} must be programmed in a block without motion", file, line, col)
        for axis, (value, mode, acol) in w.axes.items():
            if mode is not None:
                raise NcSemanticError(f"{mode}() is not allowed in a {name} block", file, line, acol)
        values = {a: v for a, (v, _, _) in w.axes.items()}
        st = self.st
        g = self._frame_of(name, values, w, fr, line, col)
        st.prog_frame = st.prog_frame.then(g) if name.startswith("A") else g
        st.set_frames()
        return name

    def _frame_of(self, name: str, values: dict, w: _Words, fr, line: int, col: int) -> Frame:
        base = name[1:] if name.startswith("A") else name
        if base == "TRANS":
            s = self.st.length_scale
            return translation([values.get(a, 0.0) * s for a in _AXES])
        if base == "ROT":
            if "RPL" in w.values:
                if values:
                    raise NcSemanticError(f"{name}: RPL= together with axis angles", fr.unit.file,
                                          line, col)
                return rotation_in_plane(self.st.plane, w.values["RPL"][0])
            return rotation_rpy(values)
        if base == "SCALE":
            for a, v in values.items():
                if v == 0.0:
                    raise NcSemanticError(f"{name}: scale factor of {a} is 0", fr.unit.file, line, col)
            return scaling(values)
        return mirroring(set(values))

    # ---- F S T D M H and settings -----------------------------------------------------------

    def _feed_spindle_tool(self, fr: _CallFrame, w: _Words, line: int) -> None:
        st = self.st
        dwell = "dwell" in w.gcodes
        if "F" in w.values and not dwell:
            value, col = w.values["F"]
            if not value > 0.0:
                raise NcSemanticError(f"feed F must be positive, got {format_value(value)}",
                                      fr.unit.file, line, col)
            st.feed_mm_s = mm_min_to_mm_s(value * st.feed_scale)
        if "S" in w.values and not dwell:
            value, col = w.values["S"]
            if value < 0.0:
                raise NcSemanticError("spindle speed S must not be negative", fr.unit.file, line, col)
            st.spindle_rpm = value
        if "T" in w.values:
            self._record(fr, "T", (w.values["T"][0],), line)
        if "D" in w.values:
            value, col = w.values["D"]
            d = _integer(value, "D", fr.unit.file, line, col)
            if d != 0 and d != st.d_number:
                self._warn(fr, "tool offset", f"D{d} tool length and radius compensation is not "
                           f"simulated (the path is the programmed X/Y/Z)", line, col)
            st.d_number = d
        for code, col in w.m:
            self._m_function(fr, code, line, col)
        if w.h:
            st.pending_stop = True
        for key, attr in (("ADIS", "adis_mm"), ("ADISPOS", "adispos_mm")):
            if key in w.values:
                value, col = w.values[key]
                if value < 0.0:
                    raise NcSemanticError(f"{key} must not be negative", fr.unit.file, line, col)
                setattr(st, attr, value * st.length_scale)

    def _m_function(self, fr: _CallFrame, code: int, line: int, col: int) -> None:
        st = self.st
        st.pending_stop = True   # an auxiliary function output stops the path
        if code in (M_SPINDLE_CW, M_SPINDLE_CCW):
            st.spindle_on = True
        elif code == M_SPINDLE_STOP:
            st.spindle_on = False
        elif code == M_STOP:
            self._warn(fr, "M0", "M0 programmed stop: the wait for the operator is not simulated",
                       line, col)
        elif code == M_OPTIONAL_STOP:
            self._warn(fr, "M1", "M1 optional stop is not active in ncsim (ignored)", line, col)
        elif code == M_TOOL_CHANGE:
            self._warn(fr, "M6", "M6 tool change: its time is not simulated", line, col)
            self._record(fr, "M6", (), line)

    def _settings(self, fr: _CallFrame, w: _Words, line: int) -> None:
        st = self.st
        for name, col in w.commands:
            if name in ACCEL_COMMANDS:
                if ACCEL_COMMANDS[name] != st.accel_mode:
                    st.pending_stop = True
                st.accel_mode = ACCEL_COMMANDS[name]
            elif name in ("FFWON", "FFWOF"):
                st.ffw = name == "FFWON"
            elif name == "STOPRE":
                st.pending_stop = True
            elif name in COMPRESSOR_COMMANDS or name in DYNAMIC_COMMANDS:
                self._record(fr, name, (), line)
                if name not in ("COMPOF", "DYNNORM"):
                    what = "compressor" if name.startswith("COMP") else "dynamic response mode"
                    self._warn(fr, name, f"{name}: the {what} is recorded but not simulated", line, col)
            elif name in _TRANSFORMATIONS:
                self._record(fr, name, (), line)
                self._warn(fr, "transformation", f"{name} kinematic transformation is not simulated "
                           f"(X/Y/Z are used as programmed)", line, col)
            elif name in COMMANDS_NOT_SIMULATED:
                self._warn(fr, name, f"{name} ({COMMANDS_NOT_SIMULATED[name]}) is not simulated",
                           line, col)
            elif name in UNSUPPORTED_MOTION:
                raise NcUnsupportedError(f"{name} ({UNSUPPORTED_MOTION[name]}) is not simulated",
                                         fr.unit.file, line, col)
            elif name == "MCALL":
                self._modal_call(fr, w, line, col)

    def _modal_call(self, fr: _CallFrame, w: _Words, line: int, col: int) -> None:
        if not w.calls:
            self._record(fr, "MCALL", (), line)
            return
        name, args, _ = w.calls.pop(0)
        self._record(fr, f"MCALL {name}", args, line)
        self._warn(fr, "MCALL", f"MCALL {name}: the modal call is not executed after the following "
                   f"positioning blocks (only the positioning moves are simulated)", line, col)

    # ---- dwell ---------------------------------------------------------------------------------

    def _dwell(self, fr: _CallFrame, w: _Words, line: int) -> None:
        st = self.st
        _, gcol = w.gcodes["dwell"]
        file = fr.unit.file
        if w.axes or w.centre or w.inter or "motion" in w.gcodes:
            raise NcSemanticError("G4 must be programmed in a block without motion", file, line, gcol)
        has_f, has_s = "F" in w.values, "S" in w.values
        if has_f == has_s:
            raise NcSemanticError("G4 needs either F (seconds) or S (spindle revolutions)", file,
                                  line, gcol)
        value, col = w.values["F" if has_f else "S"]
        if value < 0.0:
            raise NcSemanticError("G4 dwell must not be negative", file, line, col)
        if has_f:
            seconds = value
        elif st.spindle_on and st.spindle_rpm:
            seconds = value * 60.0 / st.spindle_rpm
        else:
            self._warn(fr, "dwell", f"G4 S{format_value(value)}: spindle speed unknown or spindle "
                       f"stopped, dwell taken as 0 s", line, col)
            seconds = 0.0
        st.pending_dwell_s += seconds
        st.pending_stop = True

    # ---- motion ------------------------------------------------------------------------------

    def _motion(self, fr: _CallFrame, w: _Words, line: int) -> None:
        st = self.st
        file = fr.unit.file
        arc_words = [k for k in ("CR", "AR", "TURN") if k in w.values]
        motion = st.motion
        if motion in (0, 1):
            extra = list(w.centre) + list(w.inter) + arc_words
            if extra:
                col = (w.centre.get(extra[0]) or w.inter.get(extra[0]) or w.values[extra[0]])[-1]
                raise NcSemanticError(f"{extra[0]} is only allowed with a circle (G2/G3/CIP)",
                                      file, line, col)
            if w.axes:
                self._linear(fr, w, line, motion == 0)
            return
        if motion in (2, 3):
            if w.inter:
                key = next(iter(w.inter))
                raise NcSemanticError(f"{key}= is only allowed with CIP", file, line, w.inter[key][2])
            if w.axes or w.centre or arc_words:
                self._arc(fr, w, line)
            return
        if w.axes or w.inter or w.centre or arc_words:
            if motion == CIP:
                self._cip(fr, w, line)
            else:
                self._ct(fr, w, line)

    def _motion_col(self, w: _Words) -> int:
        if "motion" in w.gcodes:
            return w.gcodes["motion"][1]
        cols = [c for *_, c in w.axes.values()] + [c for *_, c in w.centre.values()]
        return min(cols) if cols else w.first_col

    def _require_feed(self, fr: _CallFrame, w: _Words, line: int) -> None:
        if math.isnan(self.st.feed_mm_s):
            name = MOTION_NAMES[self.st.motion]
            raise NcSemanticError(f"{name} without a feed: no F programmed yet", fr.unit.file, line,
                                  self._motion_col(w))

    def _suppressed(self, w: _Words) -> bool:
        return "suppress" in w.gcodes or any(n == "SUPA" for n, _ in w.commands)

    def _targets(self, w: _Words, suppressed: bool):
        """End point of the block in WCS and MCS (lists of 3 floats)."""
        st = self.st
        scale = st.length_scale
        if suppressed:
            mcs = list(st.pos_mcs)
            for i, a in enumerate(_AXES):
                if a in w.axes:
                    value, mode, _ = w.axes[a]
                    inc = mode == "IC" or (mode is None and st.incremental)
                    mcs[i] = mcs[i] + value * scale if inc else value * scale
            return list(st.frame.inverse_apply(*mcs)), mcs
        wcs = []
        for i, a in enumerate(_AXES):
            base = st.pos_wcs[i]
            if a in w.axes:
                value, mode, _ = w.axes[a]
                inc = mode == "IC" or (mode is None and st.incremental)
                wcs.append(base + value * scale if inc else value * scale)
            else:
                wcs.append(base + 0.0 if st.incremental else base)
        return wcs, list(st.frame.apply(*wcs))

    def _linear(self, fr: _CallFrame, w: _Words, line: int, rapid: bool) -> None:
        if not rapid:
            self._require_feed(fr, w, line)
        wcs, mcs = self._targets(w, self._suppressed(w))
        start = self.st.pos_mcs
        dx, dy, dz = mcs[0] - start[0], mcs[1] - start[1], mcs[2] - start[2]
        length = math.sqrt(dx * dx + dy * dy + dz * dz)
        if length > 0.0:
            self._emit(fr, LINE, start, mcs, _NAN3, _ZERO3, math.nan, 0.0, 0.0, length, line,
                       rapid, "block_exact_stop" in w.gcodes)
        self.st.pos_wcs, self.st.pos_mcs = wcs, mcs

    def _arc_normal(self, fr: _CallFrame, w: _Words, line: int) -> np.ndarray:
        n = arc_normal(self.st.frame, self.st.plane)
        if n is None:
            raise NcUnsupportedError("a circle under a non-uniform SCALE (an ellipse) is not "
                                     "simulated", fr.unit.file, line, self._motion_col(w))
        return n

    def _arc(self, fr: _CallFrame, w: _Words, line: int) -> None:
        """G2/G3 with I J K (optionally TURN=), CR= or AR=."""
        st = self.st
        file = fr.unit.file
        col = self._motion_col(w)
        self._require_feed(fr, w, line)
        if self._suppressed(w):
            raise NcUnsupportedError("a circle with SUPA/G53 is not simulated", file, line, col)
        has_cr, has_ar = "CR" in w.values, "AR" in w.values
        if not (w.centre or has_cr or has_ar):
            raise NcSemanticError(f"G{st.motion} without centre (I J K), radius (CR=) or opening "
                                  f"angle (AR=)", file, line, col)
        if has_cr and (w.centre or has_ar):
            raise NcSemanticError("CR= together with I J K or AR=", file, line, w.values["CR"][1])
        turns = self._turns(fr, w, line)
        sign = 1.0 if st.motion == 3 else -1.0
        n_ccw = self._arc_normal(fr, w, line)
        start_wcs = list(st.pos_wcs)
        perp = PLANE_AXES[st.plane][2]
        if _CENTRE[perp] in w.centre:
            self._warn(fr, "centre", f"{_CENTRE[perp]} is perpendicular to the G{st.plane} plane: "
                       f"ignored (the centre lies in the plane)", line, w.centre[_CENTRE[perp]][2])
        if has_ar and not w.axes:
            center_wcs = self._centre_wcs(w, start_wcs)
            end_wcs = self._rotate_in_plane(start_wcs, center_wcs, sign * w.values["AR"][0])
        else:
            end_wcs, _ = self._targets(w, False)
            if has_cr:
                center_wcs = self._centre_from_cr(fr, w, line, start_wcs, end_wcs, sign)
            elif has_ar:
                if w.centre:
                    raise NcSemanticError("AR= with both centre (I J K) and end point", file, line,
                                          w.values["AR"][1])
                center_wcs = self._centre_from_ar(fr, w, line, start_wcs, end_wcs, sign)
            else:
                center_wcs = self._centre_wcs(w, start_wcs)
        end_mcs = list(st.frame.apply(*end_wcs))
        center_mcs = list(st.frame.apply(*center_wcs))
        self._emit_arc(fr, w, line, end_wcs, end_mcs, center_mcs, sign * n_ccw, turns)

    def _turns(self, fr: _CallFrame, w: _Words, line: int) -> float:
        if "TURN" not in w.values:
            return 0.0
        value, col = w.values["TURN"]
        if value < 0 or value != int(value):
            raise NcSemanticError(f"TURN= must be a whole number >= 0, got {format_value(value)}",
                                  fr.unit.file, line, col)
        if not w.centre:
            raise NcSemanticError("TURN= needs the centre (I J K)", fr.unit.file, line, col)
        return float(value)

    def _centre_wcs(self, w: _Words, start_wcs: list) -> list:
        """I J K: incremental to the start point (AC: absolute), in-plane components only."""
        scale = self.st.length_scale
        e1, e2, _ = PLANE_AXES[self.st.plane]
        center = list(start_wcs)
        for axis in (e1, e2):
            word = w.centre.get(_CENTRE[axis])
            if word is None:
                center[axis] = start_wcs[axis] + 0.0
            else:
                value, mode, _ = word
                center[axis] = value * scale if mode == "AC" else start_wcs[axis] + value * scale
        return center

    def _rotate_in_plane(self, start: list, center: list, angle_deg: float) -> list:
        e1, e2, _ = PLANE_AXES[self.st.plane]
        a = math.radians(angle_deg)
        u, v = start[e1] - center[e1], start[e2] - center[e2]
        end = list(start)
        end[e1] = center[e1] + math.cos(a) * u - math.sin(a) * v
        end[e2] = center[e2] + math.sin(a) * u + math.cos(a) * v
        return end

    def _centre_from_cr(self, fr, w: _Words, line: int, start: list, end: list, sign: float) -> list:
        value, col = w.values["CR"]
        normal = sign * plane_normal(self.st.plane)
        chord = np.subtract(end, start)
        chord -= np.dot(chord, normal) * normal
        if np.linalg.norm(chord) <= FULL_CIRCLE_TOL_MM:
            raise NcSemanticError("a full circle cannot be programmed with CR= (use I J K)",
                                  fr.unit.file, line, col)
        if value == 0.0:
            raise NcSemanticError("CR=0 is not a circle", fr.unit.file, line, col)
        center = center_from_radius(start, end, normal, value * self.st.length_scale)
        if center is None:
            raise NcSemanticError(f"CR={format_value(value)} is smaller than half the distance "
                                  f"between start and end point", fr.unit.file, line, col)
        return [float(c) for c in center]

    def _centre_from_ar(self, fr, w: _Words, line: int, start: list, end: list, sign: float) -> list:
        value, col = w.values["AR"]
        if not 0.0 < value < 360.0:
            raise NcSemanticError(f"AR= must be between 0 and 360 degrees, got {format_value(value)}",
                                  fr.unit.file, line, col)
        center = center_from_opening_angle(start, end, sign * plane_normal(self.st.plane),
                                           math.radians(value))
        if center is None:
            raise NcSemanticError("AR= with the end point equal to the start point", fr.unit.file,
                                  line, col)
        return [float(c) for c in center]

    def _cip(self, fr: _CallFrame, w: _Words, line: int) -> None:
        """CIP: circle through the start, the intermediate point I1 J1 K1 and the end."""
        st = self.st
        col = self._motion_col(w)
        self._require_feed(fr, w, line)
        if w.centre or any(k in w.values for k in ("CR", "AR", "TURN")):
            raise NcSemanticError("CIP takes an end point and I1= J1= K1=, not I J K/CR/AR/TURN",
                                  fr.unit.file, line, col)
        if not w.axes or not w.inter:
            raise NcSemanticError("CIP needs an end point and an intermediate point (I1= J1= K1=)",
                                  fr.unit.file, line, col)
        end_wcs, end_mcs = self._targets(w, self._suppressed(w))
        scale = st.length_scale
        inter = list(st.pos_wcs)
        for i, key in enumerate(_INTER):
            if key in w.inter:
                value, mode, _ = w.inter[key]
                inc = mode == "IC" or (mode is None and st.incremental)
                inter[i] = st.pos_wcs[i] + value * scale if inc else value * scale
        found = circle_through_points(st.pos_mcs, st.frame.apply(*inter), end_mcs)
        if found is None:
            raise NcSemanticError("CIP: start, intermediate and end point lie on one line",
                                  fr.unit.file, line, col)
        center, normal = found
        self._emit_arc(fr, w, line, end_wcs, end_mcs, [float(c) for c in center], normal, 0.0)

    def _ct(self, fr: _CallFrame, w: _Words, line: int) -> None:
        """CT: circle tangential to the previous segment, ending at the programmed point."""
        st = self.st
        col = self._motion_col(w)
        self._require_feed(fr, w, line)
        if w.centre or w.inter or any(k in w.values for k in ("CR", "AR", "TURN")):
            raise NcSemanticError("CT takes only an end point", fr.unit.file, line, col)
        if st.last_segment is None:
            raise NcSemanticError("CT needs a previous path segment to be tangential to",
                                  fr.unit.file, line, col)
        end_wcs, end_mcs = self._targets(w, self._suppressed(w))
        n_plane = self._arc_normal(fr, w, line)
        found = center_tangential(st.pos_mcs, end_mcs, end_tangent(st.last_segment), n_plane)
        if found is None:
            raise NcSemanticError("CT: the end point lies on the tangent (a straight line, not a "
                                  "circle)", fr.unit.file, line, col)
        center, normal = found
        self._emit_arc(fr, w, line, end_wcs, end_mcs, [float(c) for c in center], normal, 0.0)

    def _emit_arc(self, fr, w: _Words, line: int, end_wcs, end_mcs, center_mcs, normal, turns) -> None:
        st = self.st
        geo = arc_columns(np.array([st.pos_mcs], dtype=np.float64),
                          np.array([end_mcs], dtype=np.float64),
                          np.array([center_mcs], dtype=np.float64),
                          np.array([normal], dtype=np.float64), turns)
        r_start, r_end = float(geo["radius_mm"][0]), float(geo["radius_end_mm"][0])
        col = self._motion_col(w)
        if not r_start > 0.0:
            raise NcSemanticError("circle centre coincides with the start point", fr.unit.file,
                                  line, col)
        err = float(circle_error_mm(r_start, r_end))
        tol = float(circle_tolerance_mm(r_start, self.circle_const_mm, self.circle_factor))
        if err > tol:
            raise NcSemanticError(f"circle end point error: start radius {r_start:.4f} mm and end "
                                  f"radius {r_end:.4f} mm differ by {err:.4f} mm > {tol:.4f} mm "
                                  f"(MD21000/MD21010)", fr.unit.file, line, col)
        self._emit(fr, ARC, st.pos_mcs, end_mcs, tuple(geo["center_mm"][0].tolist()),
                   tuple(float(v) for v in normal), r_start, float(geo["sweep_rad"][0]),
                   float(geo["helix_mm"][0]), float(geo["length_mm"][0]), line, False,
                   "block_exact_stop" in w.gcodes)
        st.pos_wcs, st.pos_mcs = list(end_wcs), list(end_mcs)

    # ---- segments ----------------------------------------------------------------------------

    def _emit(self, fr, kind, start, end, center, normal, radius, sweep, helix, length, line,
              rapid: bool, g9: bool) -> None:
        st = self.st
        stop = st.pending_stop or (st.last_rapid is not None and st.last_rapid != rapid)
        self.rows.append({
            "kind": kind, "start_mm": tuple(start), "end_mm": tuple(end), "center_mm": center,
            "normal": normal, "radius_mm": radius, "sweep_rad": sweep, "helix_mm": helix,
            "length_mm": length, "line": line, "file_index": fr.file_index,
            "feed_mm_s": math.inf if rapid else st.feed_mm_s, "rapid": rapid,
            "exact_stop": st.cp_mode == 60 or g9, "stop_window": st.stop_window,
            "cp_mode": st.cp_mode, "adis_mm": st.adispos_mm if rapid else st.adis_mm,
            "accel_mode": st.accel_mode, "ffw": st.ffw, "stop_before": stop,
            "dwell_before_s": st.pending_dwell_s})
        self.n_segments += 1
        st.pending_stop = False
        st.pending_dwell_s = 0.0
        st.last_rapid = rapid
        st.last_segment = (kind, tuple(start), tuple(end), center, normal, radius, sweep, helix)

    def _flush_rows(self) -> None:
        if not self.rows:
            return
        cols = {name: [r[name] for r in self.rows] for name in self.rows[0]}
        self.builder.extend(**{name: np.array(v) for name, v in cols.items()})
        self.rows = []

    # ---- calls and program flow ----------------------------------------------------------

    def _calls(self, fr: _CallFrame, w: _Words, line: int) -> None:
        repeats = 1
        if "P" in w.values:
            value, col = w.values["P"]
            repeats = _integer(value, "P", fr.unit.file, line, col)
            if repeats < 1:
                raise NcSemanticError("P (repetitions) must be at least 1", fr.unit.file, line, col)
        targets = []
        if "L" in w.values:
            value, col = w.values["L"]
            targets.append((f"L{_integer(value, 'L', fr.unit.file, line, col)}", (), col))
        for name, col in w.commands:
            if name not in _HANDLED_COMMANDS:
                targets.append((name, (), col))
        for name, args, col in w.calls:
            if self._builtin_call(fr, name, args, line, col):
                continue
            targets.append((name, args, col))
        if not targets and "P" in w.values:
            raise NcSemanticError("P (repetitions) without a subprogram call", fr.unit.file, line,
                                  w.values["P"][1])
        if len(targets) > 1:
            name, _, col = targets[1]
            raise NcSemanticError(f"second subprogram call {name} in one block", fr.unit.file,
                                  line, col)
        if targets and (any(code in (M_END, M_END_RESET, M_RETURN) for code, _ in w.m)
                        or any(name == "RET" for name, _ in w.commands)):
            raise NcSemanticError(f"subprogram call {targets[0][0]} together with the end of the "
                                  f"program or a return in one block", fr.unit.file, line, targets[0][2])
        for name, args, col in targets:
            self._call(fr, name, args, repeats, line, col)

    def _builtin_call(self, fr: _CallFrame, name: str, args: tuple, line: int, col: int) -> bool:
        """CYCLE832, MSG and the standard cycles: recorded (with a warning when it matters)."""
        if name == "MSG":
            self._record(fr, "MSG", args, line)
            return True
        if name == "CYCLE832":
            self._record(fr, name, args, line)
            shown = ", ".join("" if a is None else format_value(a) for a in args)
            self._warn(fr, "CYCLE832", f"CYCLE832({shown}): the high-speed settings (tolerance, "
                       f"compressor, G64x, dynamic mode) are recorded but not simulated", line, col)
            return True
        if name == "CYCLE800":
            self._record(fr, name, args, line)
            self._warn(fr, "CYCLE800", "CYCLE800 swivel plane (5-axis) is not simulated: X/Y/Z are "
                       "used as programmed", line, col)
            return True
        if _is_standard_cycle(name) and name not in self.units:
            self._record(fr, name, args, line)
            self._warn(fr, "cycle", f"{name}: machining cycle not simulated (no motion generated)",
                       line, col)
            return True
        return False

    def _program_flow(self, fr: _CallFrame, w: _Words, line: int) -> None:
        codes = {code for code, _ in w.m}
        if M_END in codes or M_END_RESET in codes:
            self.ended = True
        elif M_RETURN in codes or any(name == "RET" for name, _ in w.commands):
            self._return()
        elif any(name == "GOTOS" for name, _ in w.commands):
            fr.pc, fr.row = (1 if _is_proc(fr.unit) else 0), 0

    # ---- plain runs ----------------------------------------------------------------------------

    def _exec_run(self, fr: _CallFrame, run: P.PlainRun) -> None:
        if len(run) >= VECTOR_MIN_ROWS and self._vector_run(fr, run):
            return
        for i in range(len(run)):
            block = run.block(i)
            self._count(fr, block.line)
            self._exec_block(fr, block)

    def _vector_run(self, fr: _CallFrame, run: P.PlainRun) -> bool:
        """Interpret a run of plain blocks as columns. Returns False, having changed nothing,
        when the run needs the block-by-block path (errors, warnings, budget, CIP/CT)."""
        st = self.st
        n = len(run)
        if self.blocks + n > self.budget:
            return False
        vals = run.values
        present = ~np.isnan(vals)
        if not (np.abs(vals[present]) < WORD_VALUE_LIMIT).all():
            return False
        has_g = run.g >= 0
        has_xyz = present[:, 0:3].any(axis=1)
        has_ijk = present[:, 3:6].any(axis=1)
        if st.motion not in (0, 1, 2, 3):
            first_g = int(np.argmax(has_g)) if has_g.any() else n
            if (has_xyz[:first_g] | has_ijk[:first_g]).any():
                return False
        motion = _ffill(run.g.astype(np.int16), has_g, st.motion)
        linear = motion <= 1
        arc = (motion == 2) | (motion == 3)
        perp = PLANE_AXES[st.plane][2]
        if (linear & has_ijk).any() or (arc & has_xyz & ~has_ijk).any() or (arc & present[:, 3 + perp]).any():
            return False
        f_present = present[:, 6]
        if not (vals[f_present, 6] > 0.0).all():
            return False
        feed = _ffill(mm_min_to_mm_s(vals[:, 6] * st.feed_scale), f_present, st.feed_mm_s)
        moving = (linear & has_xyz) | (arc & (has_xyz | has_ijk))
        if (moving & (motion >= 1) & np.isnan(feed)).any():
            return False
        rows = np.flatnonzero(moving)
        if len(rows):
            built = self._run_segments(fr, run, rows, motion, arc, feed, present)
            if built is None:
                return False
            self._commit_run(fr, *built)
        self.blocks += n
        st.motion = int(motion[-1])
        st.feed_mm_s = float(feed[-1])
        return True

    def _run_segments(self, fr, run, rows, motion, arc, feed, present):
        st = self.st
        vals = run.values
        scale = st.length_scale
        m = len(rows)
        wcs_end = np.empty((m, 3))
        for a in range(3):
            v = vals[rows, a] * scale
            p = present[rows, a]
            if st.incremental:
                d = np.where(p, v, 0.0)
                wcs_end[:, a] = np.cumsum(np.concatenate(([st.pos_wcs[a]], d)))[1:]
            else:
                wcs_end[:, a] = _ffill(v, p, st.pos_wcs[a])
        wcs_start = np.vstack([np.array([st.pos_wcs]), wcs_end[:-1]])
        mcs_end = st.frame.apply_rows(wcs_end)
        mcs_start = np.vstack([np.array([st.pos_mcs]), mcs_end[:-1]])
        d = mcs_end - mcs_start
        cols = {"kind": np.zeros(m, dtype=np.int8), "start_mm": mcs_start, "end_mm": mcs_end,
                "center_mm": np.full((m, 3), np.nan), "normal": np.zeros((m, 3)),
                "radius_mm": np.full(m, np.nan), "sweep_rad": np.zeros(m), "helix_mm": np.zeros(m),
                "length_mm": np.sqrt(d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1] + d[:, 2] * d[:, 2])}
        is_arc = arc[rows]
        if is_arc.any():
            if not self._run_arcs(run, rows, motion, is_arc, present, wcs_start, mcs_start, mcs_end, cols):
                return None
        keep = is_arc | (cols["length_mm"] > 0.0)
        rapid = motion[rows] == 0
        return run.first_line + rows, keep, cols, rapid, feed[rows], wcs_end, mcs_end

    def _run_arcs(self, run, rows, motion, is_arc, present, wcs_start, mcs_start, mcs_end, cols) -> bool:
        st = self.st
        n_ccw = arc_normal(st.frame, st.plane)
        if n_ccw is None:
            return False
        ai = np.flatnonzero(is_arc)
        arc_rows = rows[ai]
        scale = st.length_scale
        center_wcs = wcs_start[ai].copy()
        e1, e2, _ = PLANE_AXES[st.plane]
        for axis in (e1, e2):
            v = run.values[arc_rows, 3 + axis] * scale
            center_wcs[:, axis] = wcs_start[ai, axis] + np.where(present[arc_rows, 3 + axis], v, 0.0)
        sign = np.where(motion[arc_rows] == 3, 1.0, -1.0)
        normals = sign[:, None] * n_ccw[None, :]
        geo = arc_columns(mcs_start[ai], mcs_end[ai], st.frame.apply_rows(center_wcs), normals, 0.0)
        r_start = geo["radius_mm"]
        if not (r_start > 0.0).all():
            return False
        if (circle_error_mm(r_start, geo["radius_end_mm"])
                > circle_tolerance_mm(r_start, self.circle_const_mm, self.circle_factor)).any():
            return False
        cols["kind"][ai] = ARC
        cols["normal"][ai] = normals
        for name in ("center_mm", "radius_mm", "sweep_rad", "helix_mm", "length_mm"):
            cols[name][ai] = geo[name]
        return True

    def _commit_run(self, fr, lines, keep, cols, rapid, feed, wcs_end, mcs_end) -> None:
        st = self.st
        st.pos_wcs = wcs_end[-1].tolist()
        st.pos_mcs = mcs_end[-1].tolist()
        idx = np.flatnonzero(keep)
        k = len(idx)
        if k == 0:
            return
        if k < len(keep):  # zero-length lines make no segment
            cols = {name: np.take(col, idx, axis=0) for name, col in cols.items()}
            lines, rapid, feed = lines[idx], rapid[idx], feed[idx]
        stop = np.zeros(k, dtype=bool)
        stop[1:] = rapid[1:] != rapid[:-1]
        stop[0] = st.pending_stop or (st.last_rapid is not None and st.last_rapid != bool(rapid[0]))
        dwell = np.zeros(k)
        dwell[0] = st.pending_dwell_s
        self._flush_rows()
        self.builder.extend(
            **cols, line=lines,
            file_index=fr.file_index, feed_mm_s=np.where(rapid, np.inf, feed), rapid=rapid,
            exact_stop=st.cp_mode == 60, stop_window=st.stop_window, cp_mode=st.cp_mode,
            adis_mm=np.where(rapid, st.adispos_mm, st.adis_mm), accel_mode=st.accel_mode,
            ffw=st.ffw, stop_before=stop, dwell_before_s=dwell)
        self.n_segments += k
        last = k - 1
        st.pending_stop = False
        st.pending_dwell_s = 0.0
        st.last_rapid = bool(rapid[-1])
        st.last_segment = (int(cols["kind"][last]), tuple(cols["start_mm"][last].tolist()),
                           tuple(cols["end_mm"][last].tolist()), tuple(cols["center_mm"][last].tolist()),
                           tuple(cols["normal"][last].tolist()), float(cols["radius_mm"][last]),
                           float(cols["sweep_rad"][last]), float(cols["helix_mm"][last]))


# =============================================================================================
# Small helpers
# =============================================================================================

_HANDLED_COMMANDS = frozenset(
    set(ACCEL_COMMANDS) | set(COMPRESSOR_COMMANDS) | set(DYNAMIC_COMMANDS) | set(_TRANSFORMATIONS)
    | set(_FRAME_COMMANDS)
    | set(COMMANDS_NOT_SIMULATED) | set(UNSUPPORTED_MOTION)
    | {"FFWON", "FFWOF", "STOPRE", "TRAFOOF", "FNORM", "CFC", "MCALL", "SUPA", "RET", "GOTOS"})

_AXIS_MODES = ("AC", "IC")
_ROTARY_MODES = ("AC", "IC", "DC", "ACP", "ACN")
_STANDARD_CYCLES = re.compile(r"^(CYCLE\d+|POCKET\d|SLOT\d|LONGHOLE|HOLES\d|E_[A-Z_]+|F_[A-Z_]+)$")


def _g_name(group: str, code: int) -> str:
    """G1, or CIP/CT for the motion codes that are commands."""
    return MOTION_NAMES[code] if group == "motion" else f"G{code}"


def _is_proc(unit: _Unit) -> bool:
    return bool(unit.items) and isinstance(unit.items[0], P.Block) and isinstance(
        unit.items[0].statement, P.Proc)


def _is_standard_cycle(name: str) -> bool:
    return _STANDARD_CYCLES.match(name) is not None


def _axis_mode(expr, rotary: bool = False):
    """(mode, expression) of an axis value: ``AC(e)``/``IC(e)`` (and DC/ACP/ACN for rotary)."""
    modes = _ROTARY_MODES if rotary else _AXIS_MODES
    if isinstance(expr, P.Func) and expr.name in modes and len(expr.args) == 1 and expr.args[0] is not None:
        return expr.name, expr.args[0]
    return None, expr


WORD_VALUE_LIMIT = 1e9   # |value| of a word: the 840D accepts +-999 999 999.9999


def _in_range(value: float, what: str, file: str, line: int, col: int) -> float:
    if not abs(value) < WORD_VALUE_LIMIT:
        raise NcSemanticError(f"{what}{format_value(value)} is out of range (|value| < 1e9)", file,
                              line, col)
    return value


def _integer(value: float, what: str, file: str, line: int, col: int) -> int:
    """A whole, non-negative number (G, M, D, L, P values)."""
    if not (0.0 <= value < 1e9) or value != int(value):
        raise NcSemanticError(f"{what} needs a whole number, got {format_value(value)}", file,
                              line, col)
    return int(value)


def _find_destination(unit: _Unit, goto: P.Goto, here: int):
    """(item index, row) of a jump destination, or None. GOTOF searches forward from the next
    block, GOTOB backward from this block, GOTO and GOTOC forward then backward."""
    target = goto.target
    forward = goto.kind != "GOTOB"
    backward = goto.kind != "GOTOF"
    if target.label is not None:
        idx = unit.labels.get(target.label)
        if idx is None or (idx > here and not forward) or (idx <= here and not backward):
            return None
        return idx, 0
    items = unit.items
    if forward:
        found = _find_number(items, target.number, range(here + 1, len(items)), last=False)
        if found is not None:
            return found
    if backward:
        return _find_number(items, target.number, range(here, -1, -1), last=True)
    return None


def _find_number(items: list, number: int, order, last: bool):
    for idx in order:
        item = items[idx]
        if isinstance(item, P.PlainRun):
            hits = np.flatnonzero(item.numbers == number)
            if len(hits):
                return idx, int(hits[-1] if last else hits[0])
        elif item.number == number:
            return idx, 0
    return None
