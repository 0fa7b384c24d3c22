"""ISO dialect mode (G291): Fanuc-style milling blocks run on the 840D's interpreter state.

SINUMERIK 840D sl ISO Milling programming manual (ISO dialects function manual); the sections
each part follows are named where it is done. An ISO block (:mod:`ncsim.nc.isoparse`) is turned
into the same :class:`~ncsim.nc.context.WordContext` a Siemens block fills, so that the modal
state, the feeds, the work offsets, the circle checks and the segments of the Path are those of
:mod:`ncsim.nc.settings` and :mod:`ncsim.nc.moves`; what only ISO mode has is done here:

* G functions ("G code table"; the group 01..17 names of the manual): G00-G03 (R is the radius,
  negative: more than a half circle), G04 dwell (P milliseconds, X seconds), G09, G17-G19,
  G20/G21 (inch/metric lengths and feeds, as G700/G710), G28 (rapid through the programmed
  point to the reference point, "Reference point return"), G30 P2..P4 (the second to fourth
  reference points), G40-G42 and G43/G44/G49 (accepted, the path is the programmed one), G52
  (local coordinate system, a translation), G53 (machine coordinates for one block), G54-G59
  (the settable frames G54-G57, G505, G506) and G54.1 Pn (G506+n), G61 (exact stop mode, as
  G60), G64 (cutting mode, continuous path), G65 (macro call), G73-G89 and G98/G99 (canned
  cycles, :mod:`ncsim.nc.isocycles`), G90/G91, G92 (the workpiece system set so that the
  position reads the programmed values), G94/G95;
* G05.1 Q1 (AI contour control) and G08 P1 (look-ahead): the 840D has no separate mode for them;
  they select its continuous-path mode G64 (with the planner's look-ahead) when exact stop is in
  force, Q0/P0 return to the mode before;
* M98 P<n> L<k> calls program O<n> k times (``P`` of more than four digits without L: the first
  digits are the count, the last four the number), M99 returns (in the main program it starts
  it again); a program is an ``O<n>`` section of a loaded file or a file named ``O<n>``/``<n>``
  (.MPF, .SPF, .NC, .TXT or no extension) in the subprogram folders ("Subprogram call");
  G65 P<n> L<k> A.. Z.. calls it as a macro with the arguments in #1..#26 (argument
  specification I) and its own local variables ("Macro programs");
* macro statements: ``#n = expr``, ``IF [..] GOTO n``, ``IF [..] THEN #n = ..``, ``GOTO n``
  (searched forward, then from the program's start), ``WHILE [..] DO m`` .. ``END m``
  (:mod:`ncsim.nc.isomacro` for the variables and values);
* Siemens code in ISO mode is an error that names the switch (the ISO reader does not know
  it; "Switchover modes"), ISO code in Siemens mode likewise (:mod:`ncsim.nc.dialect`).

Not simulated, each an error at its word: G02.2/G03.2 (involute), G07.1 (cylindrical
interpolation), G12.1/G13.1 (polar coordinate interpolation), G15/G16 polar coordinates, G31
(skip), G33 (threads), G50/G51 scaling, G50.1/G51.1 mirroring, G66 (modal macro), G68 rotation,
G87/G88 cycles, G93 inverse time, G96 constant surface speed, ``,R``/``,C`` corner rounding.
"""
from __future__ import annotations

from ncsim.machine.iso import IsoSpec
from ncsim.nc import program as P
from ncsim.nc.context import WordContext
from ncsim.nc.expr import format_value
from ncsim.nc.flow import reads_state
from ncsim.nc.frames import translation
from ncsim.nc.isocycles import CYCLE_CODES, NOT_SIMULATED, Cycles
from ncsim.nc.isocalls import IsoCalls, find_number
from ncsim.nc.isomacro import Macro
from ncsim.nc.isoparse import (IsoAssign, IsoBlock, IsoEnd, IsoGoto, IsoIf,
                               IsoWhile, IsoWord, ModeSwitch)

_AXES = ("X", "Y", "Z")
_CENTRE = ("I", "J", "K")
_EXTRA = ("R", "P", "Q", "K", "L", "H", "D", "E", ",R", ",C")
_INCREMENT = {True: 0.0001, False: 0.001}   # standard notation: IS-B input increment, inch/mm

# ISO G code (tenths: G54.1 is 541) -> (group, the Siemens code it selects, or None)
G_TABLE: dict[int, tuple[str, int | None]] = {
    0: ("motion", 0), 10: ("motion", 1), 20: ("motion", 2), 30: ("motion", 3),
    40: ("dwell", 4), 90: ("block_exact_stop", 9),
    170: ("plane", 17), 180: ("plane", 18), 190: ("plane", 19),
    200: ("units", 700), 210: ("units", 710),
    400: ("radius_comp", 40), 410: ("radius_comp", 41), 420: ("radius_comp", 42),
    430: ("length_comp", 43), 440: ("length_comp", 44), 490: ("length_comp", 49),
    540: ("settable", 54), 550: ("settable", 55), 560: ("settable", 56), 570: ("settable", 57),
    580: ("settable", 505), 590: ("settable", 506), 541: ("settable", None),
    610: ("cp_mode", 60), 640: ("cp_mode", 64),
    900: ("distance", 90), 910: ("distance", 91), 940: ("feed_type", 94), 950: ("feed_type", 95),
    980: ("return", 98), 990: ("return", 99), 800: ("cycle", None),
    280: ("reference", 28), 300: ("reference", 30), 530: ("suppress", 53),
    920: ("preset", 92), 520: ("preset", 52), 650: ("macro", 65),
    51: ("lookahead", 5), 50: ("lookahead", 5), 80: ("lookahead", 8),
    150: ("cancel", None), 500: ("cancel", None), 501: ("cancel", None), 670: ("cancel", None),
    690: ("cancel", None), 970: ("cancel", None), 230: ("cancel", None),
}
G_TABLE.update({code * 10: ("cycle", code) for code in CYCLE_CODES})
G_TABLE.update({code * 10: ("cycle", code) for code in NOT_SIMULATED})
G_UNSUPPORTED = {
    22: "involute interpolation G02.2", 32: "involute interpolation G03.2",
    71: "cylindrical interpolation G07.1", 121: "polar coordinate interpolation G12.1",
    131: "polar coordinate interpolation G13.1", 160: "polar coordinates G16",
    310: "skip function G31", 330: "thread cutting G33", 510: "scaling G51",
    511: "programmable mirroring G51.1", 660: "modal macro call G66", 680: "coordinate rotation G68",
    930: "inverse time feed G93", 960: "constant surface speed G96", 270: "reference point "
    "check G27", 290: "return from the reference point G29", 100: "data setting G10",
    600: "single-direction positioning G60", 620: "automatic corner override G62",
    630: "tapping mode G63", 220: "stored stroke check G22",
}


def g_name(tenths: int) -> str:
    return f"G{tenths // 10:02d}" + (f".{tenths % 10}" if tenths % 10 else "")


class IsoExec:
    """Executes ISO blocks and ISO runs of plain blocks for the interpreter (one per run)."""

    def __init__(self, interp) -> None:
        self.interp = interp
        self.state = state = interp.state
        self.st = state.st
        self.moves = interp.moves
        self.settings = interp.settings
        machine = state.machine
        self.spec = machine.iso if machine is not None else IsoSpec()
        self.macro = Macro(state)
        self.cycles = Cycles(self)
        self.calls = IsoCalls(self)
        self.loops: dict = {}                 # id(unit) -> {WHILE index <-> END index}
        self.jumps: dict = {}                 # (id(unit), here, number) -> (index, row)
        self.lookahead_before: int | None = None
        self.length_comp = 49

    # ---- entry points ------------------------------------------------------------------------

    def run(self, fr, run: P.PlainRun) -> None:
        """An ISO run of plain blocks: as the Siemens path does (the same words mean the same),
        unless a canned cycle is active (each block with a position is a hole)."""
        if self.cycles.data is None:
            self.interp.exec_run(fr, run)
            return
        for i in range(len(run)):
            block = run.block(i)
            self.state.count(fr.unit.file, block.line)
            words = tuple(IsoWord(w.address, w.value, w.col) for w in block.items)
            self.block(fr, IsoBlock(block.line, block.number, items=words))

    def block(self, fr, block: IsoBlock) -> None:
        """One ISO block (already counted)."""
        s = block.statement
        ctx = WordContext(self.state, fr, block.line)
        if s is None:
            self._words(ctx, block)
        elif isinstance(s, IsoAssign):
            self.macro.write(ctx, s.target, self.macro.value(ctx, s.value))
        elif isinstance(s, IsoIf):
            if self._decide(ctx, s.cond):
                if isinstance(s.then, IsoGoto):
                    self._goto(ctx, s.then)
                else:
                    self.macro.write(ctx, s.then.target, self.macro.value(ctx, s.then.value))
        elif isinstance(s, IsoGoto):
            self._goto(ctx, s)
        elif isinstance(s, IsoWhile):
            loops = self._loops(ctx, fr.unit)       # paired when first reached, as a whole
            if s.cond is not None and not self._decide(ctx, s.cond):
                fr.pc = loops[fr.pc - 1] + 1
        elif isinstance(s, IsoEnd):
            fr.pc = self._loops(ctx, fr.unit)[fr.pc - 1]
            self.state.jumped_back(ctx.file, ctx.line, s.col)
        elif isinstance(s, ModeSwitch):
            ctx.record(f"G{s.code}", ())

    # ---- control -----------------------------------------------------------------------------

    def _decide(self, ctx, cond) -> bool:
        """The truth of an IF or WHILE condition, counted as a decision when it reads the
        program's state (``InterpreterState.decisions``: a loop whose passes decide nothing is
        an endless one, ``flow.reads_state``)."""
        if reads_state(cond):
            self.state.decisions += 1
        return self.macro.truth(ctx, cond)

    def _loops(self, ctx, unit) -> dict:
        """WHILE [..] DO m / END m pairs of ``unit`` (nested loops close innermost first)."""
        found = self.loops.get(id(unit))
        if found is not None:
            return found
        pairs, stack = {}, []
        for idx, item in enumerate(unit.items):
            s = getattr(item, "statement", None)
            if isinstance(s, IsoWhile):
                stack.append((s.label, idx, item.line))
            elif isinstance(s, IsoEnd):
                if not stack or stack[-1][0] != s.label:
                    what = (f"END {s.label} closes DO {stack[-1][0]} of line {stack[-1][2]}"
                            if stack else f"END {s.label} without WHILE .. DO {s.label}")
                    raise ctx.error(what, s.col) if item.line == ctx.line else \
                        _at(ctx, item.line).error(what, s.col)
                _, start, _ = stack.pop()
                pairs[start], pairs[idx] = idx, start
        if stack:
            label, idx, line = stack[-1]
            raise _at(ctx, line).error(f"DO {label} without END {label}",
                                       unit.items[idx].statement.col)
        self.loops[id(unit)] = pairs
        return pairs

    def _goto(self, ctx, s: IsoGoto) -> None:
        value = self.macro.value(ctx, s.target)
        if value is None or value != int(value) or value < 0:
            raise ctx.error(f"GOTO needs a block number, got "
                            f"{'vacant' if value is None else format_value(value)}", s.col)
        fr = ctx.frame
        here = fr.pc - 1
        key = (id(fr.unit), here, int(value))
        dest = self.jumps.get(key)
        if dest is None:
            dest = self.jumps[key] = find_number(fr.unit.items, int(value), here)
        if dest is None:
            raise ctx.error(f"jump destination N{int(value)} not found", s.col)
        if dest[0] <= here:
            self.state.jumped_back(ctx.file, ctx.line, s.col)
        fr.pc, fr.row = dest

    # ---- words -------------------------------------------------------------------------------

    def _words(self, ctx, block: IsoBlock) -> None:
        if not block.items:
            return
        ctx.first_col = block.items[0].col
        words = []
        for w in block.items:
            value = self.macro.value(ctx, w.value)
            if value is not None:                    # a vacant variable: the word is omitted
                words.append((w.address, ctx.in_range(value, w.address, w.col), w.col, w.point))
        groups = self._gcodes(ctx, [(v, c) for a, v, c, _ in words if a == "G"])
        if "macro" in groups:                       # G65: every other word is an argument
            self.calls.macro_call(ctx, groups["macro"][1], words)
            return
        extra: dict = {}
        calls = []
        dwell = "dwell" in groups
        in_cycle = "cycle" in groups or (self.cycles.data is not None and "motion" not in groups)
        inch = groups.get("units", (self.st.units,))[0] in (70, 700)
        for a, v, col, point in words:
            if a == "G":
                continue
            if a in extra or a in ctx.axes or a in ctx.centre or (a in ("F", "S", "T") and
                                                                     a in ctx.values):
                raise ctx.error(f"{a} programmed twice in one block", col)
            if dwell and a == "X":
                extra["X"] = (v, col, point)
            elif a in _AXES:
                ctx.axes[a] = (self._length(v, point, inch), None, col)
            elif a == "K" and in_cycle:                 # the repetitions of a hole
                extra["K"] = (v, col, point)
            elif a in _CENTRE:
                ctx.centre[a] = (self._length(v, point, inch), None, col)
            elif a in ("F", "S", "T"):
                ctx.values[a] = (v, col)
            elif a == "M":
                code = ctx.whole_number(v, "M", col)
                if code in (98, 99):
                    calls.append((code, col))
                else:
                    ctx.m.append((code, col))
            elif a in _EXTRA:
                length = a in ("R", "Q") and not dwell
                extra[a] = (self._length(v, point, inch) if length else v, col, point)
            elif a in "ABCUVW":
                self.interp.words.word(ctx, P.Word(a, P.Num(v, col), col))
            else:
                raise ctx.error(f"unknown word {a} in ISO mode", col)
        self._execute(ctx, groups, extra, calls)

    def _length(self, value: float, point: bool, inch: bool) -> float:
        """A length word in program units: under standard notation (MD10884 = 0) a number
        without decimal point counts input increments (ISO Milling, "Decimal point
        programming")."""
        if point or not self.spec.standard_notation:
            return value
        return value * _INCREMENT[inch]

    def _gcodes(self, ctx, codes: list) -> dict:
        groups: dict = {}
        for value, col in codes:
            tenths = round(value * 10)
            if abs(tenths - value * 10) > 1e-6 or tenths < 0:
                raise ctx.error(f"G{format_value(value)} is no G function", col)
            if tenths in G_UNSUPPORTED:
                raise ctx.unsupported(f"{G_UNSUPPORTED[tenths]} is not simulated", col)
            if tenths in (2900, 2910):
                raise ctx.error(f"{g_name(tenths)} must be programmed alone in its block (ISO "
                                f"dialects, 'Switchover modes')", col)
            if tenths not in G_TABLE:
                raise ctx.error(f"unknown ISO dialect G function {g_name(tenths)}", col)
            group, _ = G_TABLE[tenths]
            if group in groups and group != "cancel":
                raise ctx.error(f"{g_name(groups[group][0])} and {g_name(tenths)} in one block "
                                f"(both in the {group} group)", col)
            groups[group] = (tenths, col)
        if "cycle" in groups and "motion" in groups:
            raise ctx.error(f"{g_name(groups['motion'][0])} and {g_name(groups['cycle'][0])} "
                            f"in one block", groups["cycle"][1])
        return groups

    # ---- the block ---------------------------------------------------------------------------

    def _execute(self, ctx, groups: dict, extra: dict, calls: list) -> None:
        st = self.st
        used = set()
        for group, (tenths, col) in groups.items():
            code = G_TABLE[tenths][1]
            if group in ("motion", "plane", "distance", "feed_type", "units", "radius_comp",
                         "cp_mode", "block_exact_stop", "suppress", "dwell"):
                ctx.gcodes[group] = (code, col)
            elif group == "settable":
                if code is None:
                    used.add("P")
                    code = 506 + self.p_word(ctx, extra, "G54.1", 1, 93)
                ctx.gcodes["settable"] = (code, col)
        self.settings.modal_gcodes(ctx)
        self._iso_modes(ctx, groups, extra, used)
        self.settings.feed_spindle_tool(ctx)
        if "dwell" in groups:
            if ctx.axes or ctx.centre or "motion" in groups:
                raise ctx.error("G04 must be programmed in a block without motion",
                                groups["dwell"][1])
            self.dwell(ctx, self._dwell_s(ctx, extra, used))
        elif "reference" in groups:
            self._reference(ctx, groups["reference"], extra, used)
        elif "preset" in groups:
            self._preset(ctx, *groups["preset"])
        elif self.cycles.data is not None and "motion" not in groups:
            used.update(("R", "Q", "P", "K", "L"))
            self.cycles.block(ctx, extra)
        else:
            if "motion" in ctx.gcodes:
                st.motion = ctx.gcodes["motion"][0]
            if "R" in extra and st.motion in (2, 3):
                used.add("R")
                ctx.values["CR"] = (extra["R"][0], extra["R"][1])
                ctx.centre.clear()                 # R is the radius (and wins over I J K)
            self.moves.motion(ctx)
        for code, col in calls:
            self.calls.m_call(ctx, code, col, extra, used)
        leftover = [k for k in extra if k not in used and k not in ("H", "D")]
        if leftover:
            value, col, _ = extra[leftover[0]]
            if leftover[0] in (",R", ",C"):
                raise ctx.unsupported(f"corner rounding/chamfer {leftover[0]} is not "
                                      f"simulated", col)
            raise ctx.error(f"{leftover[0]}{format_value(value)} has no meaning in this block",
                            col)
        self.interp.calls.program_end(ctx)

    def _iso_modes(self, ctx, groups: dict, extra: dict, used: set) -> None:
        """What only ISO mode has: tool length compensation, look-ahead, the canned cycles."""
        st = self.st
        if "length_comp" in groups:
            tenths, col = groups["length_comp"]
            if tenths != 490 and self.length_comp != tenths:
                ctx.warn("tool offset", f"{g_name(tenths)} tool length compensation is not "
                         f"simulated (the path is the programmed Z)", col)
            self.length_comp = tenths
        if "lookahead" in groups:
            tenths, col = groups["lookahead"]
            key = "P" if tenths == 80 or "P" in extra else "Q"
            used.add(key)
            on = self.p_word(ctx, extra, g_name(tenths), 0, 10000, key) != 0
            if on and self.lookahead_before is None:
                self.lookahead_before = st.cp_mode
                if st.cp_mode == 60:
                    st.cp_mode = 64
                ctx.warn("ISO look-ahead", f"{g_name(tenths)} {key}1 (look-ahead, AI contour "
                         f"control) is simulated as the 840D's continuous-path mode with "
                         f"look-ahead (G64 where exact stop was in force)", col)
            elif not on and self.lookahead_before is not None:
                st.cp_mode, self.lookahead_before = self.lookahead_before, None
        if "return" in groups:
            self.cycles.return_initial = groups["return"][0] == 980
        if "motion" in groups or ("cycle" in groups and groups["cycle"][0] == 800):
            self.cycles.cancel()
        elif "cycle" in groups:
            tenths, col = groups["cycle"]
            self.cycles.select(ctx, tenths // 10, col)

    def p_word(self, ctx, extra: dict, what: str, low: int, high: int, key: str = "P") -> int:
        if key not in extra:
            raise ctx.error(f"{what} needs {key}", ctx.first_col)
        value, col, _ = extra[key]
        n = ctx.whole_number(value, key, col)
        if not low <= n <= high:
            raise ctx.error(f"{what}: {key}{n} outside {low}..{high}", col)
        return n

    # ---- dwell, reference points, presets --------------------------------------------------------

    def _dwell_s(self, ctx, extra: dict, used: set) -> float:
        """G04 P<ms> or X<s> (ISO Milling, "Dwell (G04)"; X without decimal point in standard
        notation counts milliseconds)."""
        if ("P" in extra) == ("X" in extra):
            raise ctx.error("G04 needs either P (milliseconds) or X (seconds)", ctx.first_col)
        if "P" in extra:
            used.add("P")
            value, col, _ = extra["P"]
            seconds = value / 1000.0
        else:
            used.add("X")
            value, col, point = extra["X"]
            seconds = value if point or not self.spec.standard_notation else value / 1000.0
        if seconds < 0.0:
            raise ctx.error("G04 dwell must not be negative", col)
        return seconds

    def dwell(self, ctx, seconds: float) -> None:
        st = self.st
        st.pending_dwell_s += seconds
        st.pending_stop = True

    def _reference(self, ctx, word: tuple, extra: dict, used: set) -> None:
        """G28/G30: rapid to the programmed (intermediate) point, then to the reference point
        in the programmed axes (ISO Milling, "Reference point return")."""
        tenths, col = word
        k = 0
        if tenths == 300:
            used.add("P")
            k = self.p_word(ctx, extra, "G30", 2, 4) - 1 if "P" in extra else 1
        st = self.st
        scale = st.length_scale
        wcs = list(st.pos_wcs)
        for i, a in enumerate(_AXES):
            if a in ctx.axes:
                value = ctx.axes[a][0] * scale
                wcs[i] = wcs[i] + value if st.incremental else value
        st.pending_stop = True
        self.moves.line_to(ctx, wcs, list(st.frame.apply(*wcs)), True)
        mcs = list(st.pos_mcs)
        for i, a in enumerate(_AXES):
            if a in ctx.axes:
                mcs[i] = self.spec.reference_points_mm[k][i]
        st.pending_stop = True
        self.moves.line_to(ctx, list(st.frame.inverse_apply(*mcs)), mcs, True)

    def _preset(self, ctx, tenths: int, col: int) -> None:
        """G92: the workpiece system moved so that the position reads the programmed values
        ("Setting a workpiece coordinate system (G92)"); G52: the local coordinate system, a
        translation of the workpiece system ("Local coordinate system (G52)")."""
        st = self.st
        if not st.prog_frame.linear_identity:
            raise ctx.unsupported(f"{g_name(tenths)} under a rotated or scaled frame is not "
                                  f"simulated", col)
        scale = st.length_scale
        if tenths == 920:
            offset = list(st.settable_mm)
            for i, a in enumerate(_AXES):
                if a in ctx.axes:
                    offset[i] += st.pos_wcs[i] - ctx.axes[a][0] * scale
            st.settable_mm = tuple(offset)
        else:
            shift = list(st.prog_frame.t)
            for i, a in enumerate(_AXES):
                if a in ctx.axes:
                    shift[i] = ctx.axes[a][0] * scale
            st.prog_frame = translation(shift)
        st.set_frames()
        ctx.axes.clear()

def _at(ctx, line: int):
    from ncsim.nc.expr import Where
    return Where(ctx.file, line)

