"""Step 1 of a block: evaluate its words left to right into a :class:`~ncsim.nc.context.WordContext`.

840D semantics (Programming Guide Fundamentals, "Fundamental principles of NC programming",
"Positional data"):

* words are evaluated in their order, and an assignment takes effect at once, so ``R1=5 X=R1``
  moves to 5;
* X Y Z, I J K and I1 J1 K1 may be ``AC(..)``/``IC(..)`` (absolute/incremental for this word),
  the transverse axis also ``DAC DIC RAC RIC(..)`` (:mod:`ncsim.nc.diameter`);
  each address once per block, each value |v| < 1e9;
* two G functions of one group in a block are an error (CIP and CT are motion commands);
* ``AX[axis]=`` is the word of the axis an AXIS value names (``AX[_Z]`` with ``_Z=$P_AXN3``),
  ``IP[axis]=`` its interpolation parameter (I, J or K) (Job planning, "Indirect programming");
* A B C and U V W are read but not simulated (a warning); AP= RP= are polar coordinates
  (:mod:`ncsim.nc.moves`);
* M, H, M<n>=, S<n>= are auxiliary functions (S<n>= is the speed of spindle n); SPOS= positions
  the spindle (its time is not simulated: a warning); LIMS= limits the speed under G96;
* ``A[i]=SET(...)``/``REP(v)`` fill an array from element i on (:mod:`ncsim.nc.variables`);
* ``FGROUP(X, Y, Z)`` names the axes of the path feed (others than the geometry axes: a
  warning), ``FGREF[C]=r`` the reference radius of a rotary axis (recorded, warned);
* a control keyword (IF, GOTOF, ...) must begin its own block; an unknown address is an error.

A new NC word is read in :meth:`Words.word` (into one of the context's tables: ``gcodes``,
``axes``, ``values``, ``commands`` ...) and takes effect in :mod:`ncsim.nc.settings` (a modal
setting) or :mod:`ncsim.nc.moves` (a motion); a new G function is an entry of
:data:`ncsim.nc.modal.G_CODES`.
"""
from __future__ import annotations

from ncsim.nc import program as P
from ncsim.nc.dialect import SIEMENS_MODE_ISO, iso_hint, siemens_mode_iso_code
from ncsim.nc.diameter import VALUE_MODES
from ncsim.nc.expr import evaluate_arg, format_value
from ncsim.nc.modal import CIP, CT, G_CODES, G_UNSUPPORTED, MOTION_NAMES

AXES = ("X", "Y", "Z")
CENTRE = ("I", "J", "K")
INTER = ("I1", "J1", "K1")
_ROTARY = ("A", "B", "C")
_EXTRA_AXES = ("U", "V", "W")
_VALUE_WORDS = ("CR", "AR", "TURN", "F", "S", "T", "D", "ADIS", "ADISPOS", "RPL", "L", "P", "CTOL",
                "OTOL")
_POLAR = ("AP", "RP")
_INDIRECT_AXES = {"X": "X", "Y": "Y", "Z": "Z"}
_INTERPOLATION = {"X": "I", "Y": "J", "Z": "K"}
_KEYWORDS = ("IF", "ELSE", "ENDIF", "WHILE", "ENDWHILE", "FOR", "TO", "ENDFOR", "REPEAT", "UNTIL",
             "LOOP", "ENDLOOP", "GOTO", "GOTOF", "GOTOB", "GOTOC", "DEF", "PROC", "EXTERN")
_AXIS_MODES = ("AC", "IC", *VALUE_MODES)   # DAC DIC RAC RIC: nc.diameter
_ROTARY_MODES = ("AC", "IC", "DC", "ACP", "ACN")


def _g_name(group: str, code: int) -> str:
    """G1, or CIP/CT for the motion codes that are commands."""
    return MOTION_NAMES[code] if group == "motion" else f"G{code}"


def _axis_mode(expr, rotary: bool = False):
    """(mode, expression) of an axis value: ``AC(e)``/``IC(e)`` (and DC/ACP/ACN for rotary)."""
    modes = _ROTARY_MODES if rotary else _AXIS_MODES
    if isinstance(expr, P.Func) and expr.name in modes and len(expr.args) == 1 and expr.args[0] is not None:
        return expr.name, expr.args[0]
    return None, expr


class Words:
    """Evaluates a block's items into its context (assignments are done at once)."""

    def __init__(self, state) -> None:
        self.state = state
        self.vars = state.vars

    def collect(self, ctx, block: P.Block) -> None:
        if block.items:
            ctx.first_col = block.items[0].col
        for item in block.items:
            if isinstance(item, P.Assign):
                self._assign_item(ctx, item)
            elif isinstance(item, P.Word):
                self.word(ctx, item)
            elif isinstance(item, P.Command):
                self._command_word(ctx, item)
            elif isinstance(item, P.IndexedWord):
                self._indexed_word(ctx, item)
            elif item.name == "FGROUP":
                self._fgroup(ctx, item)
            else:
                scope = self.vars
                args = tuple(None if a is None else evaluate_arg(a, scope, ctx) for a in item.args)
                ctx.calls.append((item.name, args, item.col))
                ctx.call_exprs.append(item.args)

    def _assign_item(self, ctx, item: P.Assign) -> None:
        if isinstance(item.target, P.SysVar):
            value = ctx.eval(item.value)
            ctx.warn("system variable", f"assignment to system variable {item.target.name} is "
                     f"not simulated", item.col)
            ctx.record(item.target.name, (value,))
            return
        if isinstance(item.target, P.Elem) and isinstance(item.value, P.Func) and \
                item.value.name in ("SET", "REP"):
            self.vars.assign_elem(ctx, item.target, None, item.value)
            return
        self.vars.assign_expr(ctx, item.target, item.value)

    def _indexed_word(self, ctx, item: P.IndexedWord) -> None:
        """AX[axis]= and IP[axis]= as the axis or centre word; SPOS[n]=, LIMS[n]=, S[n]=, ..."""
        a = item.address
        if a in ("AX", "IP"):
            if len(item.index) != 1:
                raise ctx.error(f"{a}[...] takes one axis", item.col)
            axis = self._axis_name(ctx, item.index[0], a, item.col)
            address = axis if a == "AX" else _INTERPOLATION.get(axis)
            if address is None:
                raise ctx.unsupported(f"{a}[{axis}]: only the geometry axes X, Y, Z are "
                                      f"simulated", item.col)
            self.word(ctx, P.Word(address, item.value, item.col))
            return
        if a == "FGREF":
            axis = self._axis_name(ctx, item.index[0], a, item.col) if len(item.index) == 1 else ""
            value = ctx.number(item.value, a)
            ctx.record(f"FGREF[{axis}]", (value,))
            ctx.warn("FGREF", f"FGREF[{axis}]={format_value(value)} (the reference radius of a "
                     f"rotary axis in the path feed) is recorded: rotary axes are not simulated",
                     item.col)
            return
        for e in item.index:
            ctx.eval(e)
        self.word(ctx, P.Word(a, item.value, item.col))

    def _fgroup(self, ctx, item: P.Call) -> None:
        """FGROUP(axes): the axes the path feed F applies to (Programming Manual Fundamentals,
        "Traversing axes with path feed (FGROUP, FGREF)"); FGROUP() and FGROUP(X, Y, Z) are the
        geometry axes, what ncsim simulates; another group changes the time (a warning)."""
        axes = [self._axis_name(ctx, a, "FGROUP", item.col) for a in item.args if a is not None]
        ctx.record("FGROUP", tuple(axes))
        if axes and sorted(axes) != list(AXES):
            ctx.warn("FGROUP", f"FGROUP({', '.join(axes)}): the path feed of these axes is not "
                     f"simulated (F is taken along the X, Y, Z path)", item.col)

    def _axis_name(self, ctx, expr, what: str, col: int) -> str:
        """The axis an index names: an AXIS variable's value or a bare X/Y/Z/A/B/C/U/V/W."""
        if isinstance(expr, P.Var) and self.vars.entry(expr.name) is None and len(expr.name) == 1:
            return expr.name
        value = ctx.eval(expr)
        if not isinstance(value, str) or not value:
            raise ctx.error(f"{what}[...] needs an axis (an AXIS variable or X, Y, Z)", col)
        return value

    def word(self, ctx, word: P.Word) -> None:
        a = word.address
        if a in AXES or a in CENTRE or a in INTER:
            mode, expr = self._mode(ctx, word)
            value = ctx.in_range(ctx.number(expr, a), a, word.col)
            table = ctx.axes if a in AXES else ctx.centre if a in CENTRE else ctx.inter
            if a in table:
                raise ctx.error(f"{a} programmed twice in one block", word.col)
            table[a] = (value, mode, word.col)
            return
        if a in _ROTARY or a in _EXTRA_AXES:
            ctx.eval(_axis_mode(word.value, rotary=True)[1])
            kind = "rotary axis" if a in _ROTARY else "additional axis"
            ctx.warn(kind, f"{kind} {a} is not simulated (the path uses X, Y, Z as programmed)",
                     word.col)
            return
        if a == "G":
            code = ctx.whole_number(ctx.number(word.value, "G"), "G", word.col)
            self._gcode(ctx, code, word.col)
            return
        if a in ("M", "H") or (len(a) > 1 and a[0] in "MS" and a[1:].isdigit()):
            self._aux_word(ctx, word)
            return
        if a == "N":
            raise ctx.error("a block number N must begin the block", word.col)
        if a in _POLAR:
            mode, expr = self._mode(ctx, word)
            if a in ctx.polar:
                raise ctx.error(f"{a} programmed twice in one block", word.col)
            ctx.polar[a] = (ctx.in_range(ctx.number(expr, a), a, word.col), mode, word.col)
            return
        if a in ("SPOS", "SPOSA"):
            ctx.eval(_axis_mode(word.value, rotary=True)[1])
            ctx.warn("spindle positioning", f"{a}: the time of spindle positioning is not "
                     f"simulated", word.col)
            ctx.record(a, ())
            return
        if a == "LIMS":
            ctx.record("LIMS", (ctx.number(word.value, a),))
            return
        if a in _VALUE_WORDS:
            value = ctx.eval(word.value)
            if isinstance(value, str) and a != "T":
                raise ctx.error(f"{a} needs a number, got the string {value!r}", word.col)
            if not isinstance(value, str):
                ctx.in_range(value, a, word.col)
            if a in ctx.values:
                raise ctx.error(f"{a} programmed twice in one block", word.col)
            ctx.values[a] = (value, word.col)
            return
        raise ctx.error(f"unknown word {a}", word.col)

    def _mode(self, ctx, word: P.Word):
        """(mode, expression) of a position word; DAC DIC RAC RIC only on the transverse axis."""
        mode, expr = _axis_mode(word.value)
        transverse = AXES[self.state.diameter_axis]
        if mode in VALUE_MODES and word.address != transverse:
            raise ctx.error(f"{mode}() is diameter/radius programming of the transverse axis "
                            f"{transverse} (MD20100), not of {word.address}", word.col)
        return mode, expr

    def _aux_word(self, ctx, word: P.Word) -> None:
        a = word.address
        value = ctx.number(word.value, a)
        if a[0] == "S":   # S1=..: speed of spindle 1, taken as the spindle speed
            ctx.values["S"] = (value, word.col)
            return
        code = ctx.whole_number(value, a[0], word.col)
        (ctx.h if a == "H" else ctx.m).append((code, word.col))

    def _gcode(self, ctx, code: int, col: int) -> None:
        if code in G_UNSUPPORTED:
            raise ctx.unsupported(f"{G_UNSUPPORTED[code]} is not simulated", col)
        if code in SIEMENS_MODE_ISO:
            code = siemens_mode_iso_code(ctx, code, col)
        if code not in G_CODES:
            raise ctx.error(f"unknown G function G{code}{iso_hint(code)}", col)
        group, _ = G_CODES[code]
        if group in ctx.gcodes:
            other = _g_name(group, ctx.gcodes[group][0])
            raise ctx.error(f"{other} and G{code} in one block (both in the {group} group)", col)
        ctx.gcodes[group] = (code, col)

    def _command_word(self, ctx, item: P.Command) -> None:
        name = item.name
        if name in ("CIP", "CT") and "motion" in ctx.gcodes:
            other = _g_name("motion", ctx.gcodes["motion"][0])
            raise ctx.error(f"{other} and {name} in one block (both in the motion group)", item.col)
        if name in ("CIP", "CT"):
            ctx.gcodes["motion"] = (CIP if name == "CIP" else CT, item.col)
            return
        if name in _KEYWORDS:
            raise ctx.error(f"{name} must begin a block of its own", item.col)
        ctx.commands.append((name, item.col))
