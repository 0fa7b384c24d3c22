"""Read-only system variables (``$P_...``, ``$M...``, ``$S...``, ``$A...``, ``$T...``) as programs read them.

A program, and above all the Siemens standard cycles, reads the control's state through system
variables (Programming Manual Job planning, "Flexible NC programming", "System variables";
List Manual System Variables). ncsim gives:

* the programmed state it simulates: ``$P_AXN1``/``$P_AXN2``/``$P_AXN3`` (abscissa, ordinate and
  applicate of the active plane: G17 X Y Z, G18 Z X Y, G19 Y Z X), ``$P_GG[n]`` (the active G
  function of group n, numbered as in the manual's list of G groups, :data:`G_GROUPS`),
  ``$P_MC`` (a modal call MCALL is active), ``$P_F`` (the programmed F), ``$P_S[n]`` (the
  programmed spindle speed), ``$P_EP[axis]`` (the programmed end point in the workpiece
  system), ``$P_ACTFRAME[axis, SC|TR]`` (scale and translation of the active frame),
  ``$P_MSNUM`` (the master spindle, SETMS), ``$P_SMODE[n]`` (1: speed mode);
* the state of a plain automatic run: ``$P_DRYRUN``, ``$P_ISTEST``, ``$P_SEARCH`` = 0 (no
  dry run, no program test, no block search);
* machine data with their documented defaults: ``$MN_SCALING_VALUE_INCH`` 25.4 (MD10250),
  ``$MN_SCALING_SYSTEM_IS_METRIC`` 1 (MD10240);
* any other one from the machine file's ``[system_variables]`` table (``"$AN_NCK_VERSION" =
  ...``, ``"$MA_PARAMSET_CHANGE_ENABLE[Z]" = 0``; a key without index applies to every index).

Anything else is an NcUnsupportedError at its column that says how to give the value: a
guessed value could change the path without a trace.
"""
from __future__ import annotations

import math

from ncsim.nc import program as P
from ncsim.nc.expr import format_value

PLANE_AXIS_NAMES = {17: ("X", "Y", "Z"), 18: ("Z", "X", "Y"), 19: ("Y", "Z", "X")}
AXIS_INDEX = {"X": 0, "Y": 1, "Z": 2}

#: $P_GG[n]: group n -> (the state's value -> 1-based position in the manual's group list)
#: (Programming Manual Fundamentals, "Lists of G functions / G groups"; the positions of groups
#: 6, 12, 13, 21 and 24 are the ones Siemens' own cycles CYCLE83/CYCLE84 rely on).
G_GROUPS = {
    1: ("motion", {0: 1, 1: 2, 2: 3, 3: 4, 10: 5, 11: 15}),          # G0 G1 G2 G3 CIP .. CT
    6: ("plane", {17: 1, 18: 2, 19: 3}),
    7: ("radius_comp", {40: 1, 41: 2, 42: 3}),
    8: ("settable", None),                                             # G500 1, G54 2 .. G57 5
    10: ("cp_mode", {60: 1, 64: 2, 641: 3, 642: 4, 643: 5, 644: 6, 645: 7}),
    12: ("stop_window", {601: 1, 602: 2, 603: 3}),
    13: ("units", {70: 1, 71: 2, 700: 3, 710: 4}),
    14: ("distance", {90: 1, 91: 2}),
    15: ("feed_type", {93: 1, 94: 2, 95: 3, 96: 4, 97: 5, 971: 8}),
    21: ("accel_mode", None),                                          # BRISK 1, SOFT 2, DRIVE 3
    24: ("ffw", None),                                                 # FFWOF 1, FFWON 2
}
FIXED = {"$P_DRYRUN": 0.0, "$P_ISTEST": 0.0, "$P_SEARCH": 0.0,
         "$MN_SCALING_VALUE_INCH": 25.4, "$MN_SCALING_SYSTEM_IS_METRIC": 1.0}


class SystemVariables:
    """Reads system variables from the interpreter's state (see the module docstring)."""

    def __init__(self, state, given: dict | None = None) -> None:
        self.state = state
        self.given = dict(given or {})     # "$NAME" or "$NAME[I,J]" -> value (machine file)

    def read(self, ctx, node):
        name = node.name
        handler = _HANDLERS.get(name)
        if handler is not None:
            return handler(self, ctx, node)
        if name in FIXED and not node.index:
            return self.given.get(name, FIXED[name])
        if node.index:
            key = f"{name}[{','.join(self._index_key(ctx, e) for e in node.index)}]"
            if key in self.given:
                return self.given[key]
        if name in self.given:
            return self.given[name]
        raise ctx.unsupported(f"system variable {name} is not simulated: give its value in the "
                              f"machine file, [system_variables] \"{name}\" = ...", node.col)

    def _index_key(self, ctx, expr) -> str:
        """An index as a key: an axis name (a bare X/Y/Z or an AXIS variable) or a number."""
        value = self._axis_or_value(ctx, expr)
        return value if isinstance(value, str) else format_value(value)

    def _axis_or_value(self, ctx, expr):
        if isinstance(expr, P.Var) and expr.name in AXIS_INDEX and \
                self.state.vars.entry(expr.name) is None:
            return expr.name
        return ctx.eval(expr)

    def _axis(self, ctx, node, k: int = 0) -> int:
        if len(node.index) <= k:
            raise ctx.error(f"{node.name} needs an axis index ({node.name}[X])", node.col)
        value = self._axis_or_value(ctx, node.index[k])
        if value not in AXIS_INDEX:
            raise ctx.unsupported(f"{node.name}[{value}]: only the geometry axes X, Y, Z are "
                                  f"simulated", node.col)
        return AXIS_INDEX[value]

    def _number_index(self, ctx, node, default: int | None = None) -> int:
        if not node.index:
            if default is None:
                raise ctx.error(f"{node.name} needs an index", node.col)
            return default
        value = ctx.number(node.index[0], node.name)
        return ctx.whole_number(value, node.name, node.col)


def _axn(k: int):
    def read(sv: SystemVariables, ctx, node):
        return PLANE_AXIS_NAMES[sv.state.st.plane][k]
    return read


def _p_gg(sv: SystemVariables, ctx, node):
    group = sv._number_index(ctx, node)
    if group not in G_GROUPS:
        raise ctx.unsupported(f"$P_GG[{group}]: G group {group} is not simulated", node.col)
    st = sv.state.st
    attr, positions = G_GROUPS[group]
    if group == 8:
        return _settable_position(sv.state.settable_code)
    if group == 15:
        return float(positions[sv.state.feed_type])
    if group == 21:
        from ncsim.path import BRISK, DRIVE, SOFT
        return float({BRISK: 1, SOFT: 2, DRIVE: 3}[st.accel_mode])
    if group == 24:
        return 2.0 if st.ffw else 1.0
    if group == 14:
        return 2.0 if st.incremental else 1.0
    return float(positions[getattr(st, attr)])


def _settable_position(code: int) -> float:
    """G500 1, G54..G57 2..5, G505..G599 6.. (the manual's order of group 8)."""
    if code == 500:
        return 1.0
    if 54 <= code <= 57:
        return float(code - 52)
    return float(code - 499)


def _p_mc(sv: SystemVariables, ctx, node):
    return 1.0 if sv.state.modal_call is not None else 0.0


def _p_f(sv: SystemVariables, ctx, node):
    return sv.state.f_value


def _p_s(sv: SystemVariables, ctx, node):
    rpm = sv.state.st.spindle_rpm
    return 0.0 if rpm is None else float(rpm)


def _p_ep(sv: SystemVariables, ctx, node):
    st = sv.state.st
    return st.pos_wcs[sv._axis(ctx, node)] / st.length_scale


def _p_actframe(sv: SystemVariables, ctx, node):
    if len(node.index) != 2:
        raise ctx.error("$P_ACTFRAME needs [axis, component]", node.col)
    axis = sv._axis(ctx, node)
    component = getattr(node.index[1], "name", None)
    frame = sv.state.st.frame
    if component == "SC":
        return math.sqrt(sum(frame.m[r][axis] ** 2 for r in range(3)))
    if component == "TR":
        return frame.t[axis] / sv.state.st.length_scale
    raise ctx.unsupported(f"$P_ACTFRAME[.., {component}] is not simulated (SC and TR are)",
                          node.col)


def _p_msnum(sv: SystemVariables, ctx, node):
    return float(sv.state.master_spindle)


def _p_smode(sv: SystemVariables, ctx, node):
    return 1.0          # speed control mode (SPOS positioning is not simulated)


_HANDLERS = {"$P_AXN1": _axn(0), "$P_AXN2": _axn(1), "$P_AXN3": _axn(2), "$P_GG": _p_gg,
             "$P_MC": _p_mc, "$P_F": _p_f, "$P_S": _p_s, "$P_EP": _p_ep,
             "$P_ACTFRAME": _p_actframe, "$P_MSNUM": _p_msnum, "$P_SMODE": _p_smode}
