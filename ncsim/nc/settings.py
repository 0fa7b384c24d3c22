"""Steps 2 and 3 of a block: modal G functions, frame instructions, F S T D M H and settings.

840D semantics (Programming Guide Fundamentals: "Fundamental principles of NC programming",
"Path action", "Frames", "Feedrate control and spindle motion", "Miscellaneous functions"):

* G54..G57, G505.. select a settable work offset (machine file ``[work_offsets]`` or the setup
  file; a missing one is 0 with a warning), G500 deselects it;
* TRANS ROT SCALE MIRROR replace the programmable frame, ATRANS AROT ASCALE AMIRROR add to it;
  the block's X Y Z are their arguments, so a frame block makes no motion (:mod:`ncsim.nc.frames`);
* F is mm/min (inch/min under G700), positive; S the spindle speed; D a tool offset (its
  compensation is not simulated, a warning when it changes); every M and H output stops the path
  (M0 M1 with a warning, their time is not simulated; M6 stands still for the machine file's
  tool-change time ``[tool_change] time_s``, and without it is a warning);
* feed type (group 15): G94 feed per minute; G95 feed per revolution, the path feed is F x S
  (mm/rev x rev/min) while the spindle turns (M3/M4), G97 as G95 and G971 as G94 without a G96
  before (Programming Manual Fundamentals, "Feedrate (G93, G94, G95, F)"); F keeps its value
  when the feed type changes and is read in the new unit;
* SBLOF/SBLON/DISPLOF/DISPLON (single block, display), SETMS, RTLION (G0 with linear
  interpolation, as simulated) and DRFOF (deletes handwheel offsets, which ncsim has none of)
  change nothing that takes time;
* DIAMOF/DIAMON/DIAM90/DIAMCYCOF select diameter programming of the transverse axis (G group
  29, :mod:`ncsim.nc.diameter`);
* ADIS/ADISPOS are the G641 rounding distances, CTOL the contour tolerance of the compressor
  and of G642-G645 rounding, OTOL the orientation tolerance (recorded); a negative value deletes
  them (Job Planning "CTOL, OTOL, ATOL"); SOFT/BRISK/DRIVE change the acceleration mode (and
  stop the path when they change); FFWON/FFWOF the feed-forward; STOPRE stops;
* COMPON/COMPCURV/COMPCAD/COMPSURF/COMPOF select the compressor (:mod:`ncsim.plan.compressor`;
  COMPSURF is simulated as COMPCAD); G644 is simulated as G642 (warned);
* :meth:`Settings.cycle832` is what CYCLE832 switches (the machine file's ``[cycle832]`` table);
* DYNNORM..DYNPREC select the technology group whose axis dynamics apply (the machine file's
  ``[dynamics]``; a group it does not define is warned); TRAORI and the like are recorded with
  a warning: they are not simulated.

A new command word (a name without ``=``) is handled in :meth:`Settings.commands` and added to
:data:`HANDLED_COMMANDS`, or it would be taken for a subprogram call.
"""
from __future__ import annotations

import math

from ncsim.nc.context import MIN_PROGRAMMED_F
from ncsim.nc.diameter import DIAMETER_COMMANDS
from ncsim.nc.expr import format_value
from ncsim.nc.frames import Frame, mirroring, rotation_in_plane, rotation_rpy, scaling, translation
from ncsim.nc.modal import (ACCEL_COMMANDS, COMMANDS_NOT_SIMULATED, COMPRESSOR_CODES,
                            COMPRESSOR_COMMANDS, DYNAMIC_COMMANDS, M_OPTIONAL_STOP, M_SPINDLE_CCW,
                            M_SPINDLE_CW, M_SPINDLE_STOP, M_STOP, M_TOOL_CHANGE, PER_REVOLUTION,
                            UNSUPPORTED_MOTION)
from ncsim.nc.words import AXES
from ncsim.units import mm_min_to_mm_s

_ZERO3 = (0.0, 0.0, 0.0)
_FRAME_COMMANDS = ("TRANS", "ATRANS", "ROT", "AROT", "SCALE", "ASCALE", "MIRROR", "AMIRROR")
_TRANSFORMATIONS = ("TRAORI", "TRANSMIT", "TRACYL", "TRAANG")
# DRFOF deletes the handwheel (DRF) offsets (Fundamentals, "Frames": "Deselecting the frame
# (G53, G153, SUPA, G500)", DRFOF): ncsim has none to delete
_NO_TIME_COMMANDS = ("SBLOF", "SBLON", "DISPLOF", "DISPLON", "SETMS", "DRFOF", "RTLION")

# Command words a block handles itself; any other name is a subprogram call.
HANDLED_COMMANDS = frozenset(
    set(ACCEL_COMMANDS) | set(COMPRESSOR_COMMANDS) | set(DYNAMIC_COMMANDS) | set(_TRANSFORMATIONS)
    | set(_FRAME_COMMANDS)
    | set(COMMANDS_NOT_SIMULATED) | set(UNSUPPORTED_MOTION)
    | set(_NO_TIME_COMMANDS) | set(DIAMETER_COMMANDS)
    | {"FFWON", "FFWOF", "STOPRE", "TRAFOOF", "FNORM", "CFC", "MCALL", "SUPA", "RET", "GOTOS"})


def _tolerance_deleted(ctx, word: str, value: float, col: int, restored: str) -> None:
    """A negative CTOL/OTOL deletes the programmed tolerance (Job Planning "CTOL, OTOL, ATOL":
    "deleted by means of the assignment of a negative value"; its example ``CTOL=-1``): said at
    the word, as nothing changes its meaning without a word."""
    ctx.warn("tolerance deleted", f"{word}={format_value(value)}: a negative value deletes the "
             f"programmed tolerance (Job Planning \"CTOL, OTOL, ATOL\"); {restored} applies "
             f"again", col)


def compressible(ctx) -> bool:
    """A block of the simple form the compressor takes: ``N.. G1 X.. Y.. Z.. F..`` (positions
    may be expressions, R parameters may be assigned, CTOL/OTOL "do not interrupt compression";
    SINUMERIK Job Planning "NC block compression": "It is interrupted by any other type of NC
    instruction": the next segment starts a new run, ``Path.compressor`` negated)."""
    return (not ctx.m and not ctx.h and not ctx.commands and not ctx.calls
            and all(g == "motion" for g in ctx.gcodes)
            and all(v in ("F", "CTOL", "OTOL") for v in ctx.values))


class Settings:
    """Applies a block's modal words to the modal state (nothing here moves the tool)."""

    def __init__(self, state) -> None:
        self.state = state
        self.st = state.st

    # ---- modal G functions -------------------------------------------------------------------

    def modal_gcodes(self, ctx) -> None:
        st = self.st
        g = ctx.gcodes
        if "units" in g:
            st.units = g["units"][0]
        if "plane" in g:
            st.plane = g["plane"][0]
        if "distance" in g:
            st.incremental = g["distance"][0] == 91
        if "cp_mode" in g:
            code, col = g["cp_mode"]
            if code == 644 and st.cp_mode != 644:
                ctx.warn("G644", "G644 (rounding with the greatest possible dynamics, MD20480) is "
                         "simulated as G642 (rounding within the tolerances)", col)
            st.cp_mode = code
        if "stop_window" in g:
            st.stop_window = g["stop_window"][0]
        if "settable" in g:
            self._settable_frame(ctx, g["settable"])
        if "feed_type" in g:
            self.state.feed_type = g["feed_type"][0]
        if "radius_comp" in g:
            code, col = g["radius_comp"]
            if code != 40 and st.radius_comp != code:
                ctx.warn("cutter compensation", f"G{code} cutter radius compensation is not "
                         f"simulated (the path is the programmed contour)", col)
            st.radius_comp = code
        if "limits" in g:
            code, col = g["limits"]
            ctx.warn("limits", f"G{code} limits are not simulated", col)

    def _settable_frame(self, ctx, word) -> None:
        code, col = word
        st = self.st
        self.state.settable_code = code
        if code == 500:
            st.settable_mm = _ZERO3
        else:
            name = f"G{code}"
            offset = self.state.offsets.get(name)
            machine = self.state.machine
            if offset is None and machine is not None:
                found = machine.work_offset_mm(name)
                offset = None if found is None else tuple(float(v) for v in found)
            if offset is None:
                ctx.warn("work offset", f"{name} work offset not given (machine file "
                         f"[work_offsets] or setup file): taken as 0", col)
                offset = _ZERO3
            st.settable_mm = tuple(offset)
        st.set_frames()

    # ---- frames ------------------------------------------------------------------------------

    def frame_instruction(self, ctx) -> str | None:
        """TRANS, AROT, ... of the block (the frame becomes active at once), else None."""
        found = [(n, c) for n, c in ctx.commands if n in _FRAME_COMMANDS]
        if not found:
            return None
        name, col = found[0]
        if len(found) > 1:
            raise ctx.error(f"{found[1][0]} after {name}: one frame instruction per block",
                            found[1][1])
        if "motion" in ctx.gcodes or ctx.centre or ctx.inter:
            raise ctx.error(f"{name} must be programmed in a block without motion", col)
        for axis, (value, mode, acol) in ctx.axes.items():
            if mode is not None:
                raise ctx.error(f"{mode}() is not allowed in a {name} block", acol)
        values = {a: v for a, (v, _, _) in ctx.axes.items()}
        st = self.st
        g = self._frame_of(ctx, name, values, col)
        st.prog_frame = st.prog_frame.then(g) if name.startswith("A") else g
        st.set_frames()
        return name

    def _frame_of(self, ctx, name: str, values: dict, col: int) -> Frame:
        base = name[1:] if name.startswith("A") else name
        if base == "TRANS":
            s = self.st.length_scale
            return translation([values.get(a, 0.0) * s for a in AXES])
        if base == "ROT":
            if "RPL" in ctx.values:
                if values:
                    raise ctx.error(f"{name}: RPL= together with axis angles", col)
                return rotation_in_plane(self.st.plane, ctx.values["RPL"][0])
            return rotation_rpy(values)
        if base == "SCALE":
            for a, v in values.items():
                if v == 0.0:
                    raise ctx.error(f"{name}: scale factor of {a} is 0", col)
            return scaling(values)
        return mirroring(set(values))

    # ---- F S T D M H -------------------------------------------------------------------------

    def feed_spindle_tool(self, ctx) -> None:
        st = self.st
        if not compressible(ctx):   # any other instruction interrupts the compressor
            st.compress_break = True
        values = ctx.values
        dwell = "dwell" in ctx.gcodes
        state = self.state
        if "F" in values and not dwell:
            value, col = values["F"]
            if not value > 0.0:
                raise ctx.error(f"feed F must be positive, got {format_value(value)}", col)
            if value < MIN_PROGRAMMED_F:
                raise ctx.error(f"feed F{format_value(value)} is below the smallest the 840D "
                                f"accepts, F{format_value(MIN_PROGRAMMED_F)} (Programming Manual "
                                "Fundamentals, list of addresses: 0.001 <= F <= 999 999.999)", col)
            state.f_value = value
            st.feed_mm_s = mm_min_to_mm_s(value * st.feed_scale)
        if "S" in values and not dwell:
            value, col = values["S"]
            if value < 0.0:
                raise ctx.error("spindle speed S must not be negative", col)
            st.spindle_rpm = value
        if "T" in values:
            ctx.record("T", (values["T"][0],))
        if "D" in values:
            value, col = values["D"]
            d = ctx.whole_number(value, "D", col)
            if d != 0 and d != st.d_number:
                ctx.warn("tool offset", f"D{d} tool length and radius compensation is not "
                         f"simulated (the path is the programmed X/Y/Z)", col)
            st.d_number = d
        for code, col in ctx.m:
            self._m_function(ctx, code, col)
        if ctx.h:
            st.pending_stop = True
        for key, attr in (("ADIS", "adis_mm"), ("ADISPOS", "adispos_mm")):
            if key in values:
                value, col = values[key]
                if value < 0.0:
                    raise ctx.error(f"{key} must not be negative", col)
                setattr(st, attr, value * st.length_scale)
        if "CTOL" in values:   # a negative value deletes it: the machine data apply again
            value, col = values["CTOL"]
            st.ctol_mm = value * st.length_scale if value >= 0.0 else math.nan
            if value < 0.0:
                _tolerance_deleted(ctx, "CTOL", value, col, "the machine data's contour "
                                   "tolerance (MD33100 per axis, or SD42465 per MD20480)")
        if "OTOL" in values:
            value, col = values["OTOL"]
            st.otol_deg = value if value >= 0.0 else math.nan
            if value < 0.0:
                _tolerance_deleted(ctx, "OTOL", value, col, "the machine data's "
                                   "orientation tolerance (SD42466)")
        if state.feed_type in PER_REVOLUTION or "feed_type" in ctx.gcodes:
            self._path_feed()

    def _path_feed(self) -> None:
        """The path feed of the feed type: F mm/min (G94, G971), or F mm/rev x S rev/min while
        the spindle turns (G95, G97); NaN when there is none (the move is then an error)."""
        st, state = self.st, self.state
        if state.f_value <= 0.0:
            st.feed_mm_s = math.nan
        elif state.feed_type in PER_REVOLUTION:
            rpm = st.spindle_rpm if st.spindle_on and st.spindle_rpm else 0.0
            st.feed_mm_s = mm_min_to_mm_s(state.f_value * st.feed_scale * rpm) if rpm else math.nan
        else:
            st.feed_mm_s = mm_min_to_mm_s(state.f_value * st.feed_scale)

    def _m_function(self, ctx, code: int, col: int) -> None:
        st = self.st
        st.pending_stop = True   # an auxiliary function output stops the path
        if code in (M_SPINDLE_CW, M_SPINDLE_CCW):
            st.spindle_on = True
        elif code == M_SPINDLE_STOP:
            st.spindle_on = False
        elif code == M_STOP:
            ctx.warn("M0", "M0 programmed stop: the wait for the operator is not simulated", col)
        elif code == M_OPTIONAL_STOP:
            ctx.warn("M1", "M1 optional stop is not active in ncsim (ignored)", col)
        elif code == M_TOOL_CHANGE:
            ctx.record("M6", ())
            machine = self.state.machine
            change_s = machine.tool_change_s if machine is not None else 0.0
            if change_s > 0.0:    # the machine file's chip-to-chip time, standing still
                st.pending_dwell_s += change_s
            else:
                ctx.warn("M6", "M6 tool change: its time is not simulated (no [tool_change] "
                         "time_s in the machine file)", col)

    # ---- command words -----------------------------------------------------------------------

    def commands(self, ctx) -> None:
        """SOFT/BRISK/DRIVE, FFWON/FFWOF, STOPRE, COMP*, DYN*, transformations, MCALL, ..."""
        st = self.st
        for name, col in ctx.commands:
            if name in ACCEL_COMMANDS:
                if ACCEL_COMMANDS[name] != st.accel_mode:
                    st.pending_stop = True
                st.accel_mode = ACCEL_COMMANDS[name]
            elif name in ("FFWON", "FFWOF"):
                st.ffw = name == "FFWON"
            elif name == "STOPRE":
                st.pending_stop = True
            elif name in COMPRESSOR_COMMANDS:
                ctx.record(name, ())
                st.compressor = COMPRESSOR_CODES[name]
            elif name in DYNAMIC_COMMANDS:
                ctx.record(name, ())
                self.technology_group(ctx, DYNAMIC_COMMANDS.index(name), col)
            elif name in _TRANSFORMATIONS:
                ctx.record(name, ())
                ctx.warn("transformation", f"{name} kinematic transformation is not simulated "
                         f"(X/Y/Z are used as programmed)", col)
            elif name in COMMANDS_NOT_SIMULATED:
                ctx.warn(name, f"{name} ({COMMANDS_NOT_SIMULATED[name]}) is not simulated", col)
            elif name in UNSUPPORTED_MOTION:
                raise ctx.unsupported(f"{name} ({UNSUPPORTED_MOTION[name]}) is not simulated", col)
            elif name == "SETMS":
                self.state.master_spindle = 1
            elif name in DIAMETER_COMMANDS:   # group 29: nc.diameter
                st.diameter = DIAMETER_COMMANDS[name]

    def technology_group(self, ctx, group: int, col: int, what: str = "") -> None:
        """Select technology group ``group`` (G group 59, DYNNORM..DYNPREC): its axis dynamics
        apply from the next block on (``Path.dyn_group``, ``machine.TECHNOLOGY_GROUPS``). A group the
        machine file does not define runs with its ``[axes]`` values, warned (the result is
        approximate)."""
        self.st.dyn_group = group
        machine = self.state.machine
        name = DYNAMIC_COMMANDS[group]
        if group == 0 or (machine is not None and machine.defines_group(group)):
            return
        ctx.warn(name, f"{what}{name}: the machine file defines no dynamics for this "
                 f"technology group ([dynamics.{name}.X] ... or [dynamics] "
                 f"same_for_all_groups = true): its [axes] values are used", col)

    # ---- CYCLE832 -----------------------------------------------------------------------------

    def cycle832(self, ctx, expansion, tolerance_mm: float) -> None:
        """Switch what CYCLE832 switches for one machining type: the path mode, the compressor,
        the acceleration mode and the feed-forward of ``expansion``
        (``machine.Cycle832Expansion``; ``None`` = the reset value), and the contour tolerance
        CTOL (NaN: deleted). A change of the acceleration mode stops the path, as SOFT/BRISK
        written in the program do."""
        st = self.st
        reset_cp, reset_accel, reset_ffw = self.state.reset_values
        st.cp_mode = reset_cp if expansion.path_mode is None else expansion.path_mode
        st.compressor = expansion.compressor
        accel = reset_accel if expansion.accel_mode is None else expansion.accel_mode
        if accel != st.accel_mode:
            st.pending_stop = True
        st.accel_mode = accel
        st.ffw = reset_ffw if expansion.feed_forward is None else expansion.feed_forward
        st.ctol_mm = tolerance_mm
