"""Step 4 of a block: the motion (G0 G1 G2 G3 CIP CT) or the dwell (G4), and the segments it makes.

840D semantics (Programming Guide Fundamentals, "Programming motion commands", "Positional
data", "Path action"):

* G0/G1 straight lines (G1 needs a feed); X=AC(..)/X=IC(..) per axis over G90/G91; the
  transverse axis in diameter (DIAMON, DIAM90, X=DAC(..) ...: :mod:`ncsim.nc.diameter`);
* G2/G3 circles with the centre I J K (incremental to the start point unless I=AC(..), only the
  in-plane components count; TURN= adds full turns), or the radius CR= (negative: more than a
  half circle), or the opening angle AR=; an axis perpendicular to the plane makes a helix;
* CIP: circle through an intermediate point I1= J1= K1= (G90/G91 apply to it); CT: circle
  tangential to the previous segment;
* circle end-point monitoring: |r_end - r_start| <= max(MD21000 $MC_CIRCLE_ERROR_CONST,
  MD21010 $MC_CIRCLE_ERROR_FACTOR * r_start);
* SUPA/G53/G153 suppress the frames for one block (:mod:`ncsim.nc.frames`), MIRROR reverses arcs;
* G4 F<s> dwells seconds, G4 S<n> spindle revolutions; it stops the path;
* polar coordinates (Programming Manual Fundamentals, "Polar coordinates (G110, G111, G112, AP,
  RP)"): ``G111 X Y`` sets the pole in the workpiece system, ``G110`` relative to the last
  programmed position, ``G112`` relative to the last pole (with ``AP= RP=`` instead of X Y, in
  polar coordinates about that reference); without a pole the workpiece origin is the pole.
  ``G0/G1 AP= RP=`` moves to the point at angle AP (degrees from the plane's first axis towards
  its second) and radius RP about the pole, ``G2/G3 AP= RP=`` along the circle about the pole;
  AP and RP are modal, ``AP=IC(..)``/``RP=IC(..)`` add to the last ones; the plane's third axis
  may be programmed with them.

A motion block whose end equals its start makes no segment (a full circle does); so does a
line shorter than ``MIN_LINE_MM`` (1e-9 mm, far below the 840D's position resolution MD10200
$MN_INT_INCR_PER_MM), which only rounding makes, e.g. ``AROT`` then ``X=IC(0)``. A segment
carries the compressor in force when it is a line, negated when another instruction came since
the last segment (``ModalState.compress_break``, :func:`ncsim.nc.settings.compressible`), and
the programmed contour tolerance CTOL. A segment
stops before it (``stop_before``) after an M or H output, STOPRE, a change of SOFT/BRISK/DRIVE
or a dwell since the last segment, or on a change between rapid and feed motion.

The arc kernels here (:func:`arc_columns`, :func:`circle_error_mm`,
:func:`circle_tolerance_mm`) work on rows of arrays and serve the block path and the column path
(:mod:`ncsim.nc.columns`) alike, so both give the same numbers. A new motion (polar coordinates,
splines) is a case of :meth:`Moves.motion`.
"""
from __future__ import annotations

import math

import numpy as np

from ncsim.geometry import (PLANE_AXES, center_from_opening_angle, center_from_radius, center_tangential,
                            circle_through_points, plane_normal)
from ncsim.nc.diameter import VALUE_MODES, diameter_applies, transverse_value
from ncsim.nc.expr import format_value
from ncsim.nc.frames import arc_normal
from ncsim.nc.modal import CIP, MOTION_NAMES
from ncsim.nc.words import AXES, CENTRE, INTER
from ncsim.path import ARC, LINE

FULL_CIRCLE_TOL_MM = 1e-9    # an arc whose end is this close to its start is a full circle
MIN_LINE_MM = 1e-9           # a shorter line is rounding (a frame applied to an unchanged point)
TWO_PI = 2.0 * math.pi
_NAN3 = (math.nan, math.nan, math.nan)
_ZERO3 = (0.0, 0.0, 0.0)
_ARC_WORDS = ("CR", "AR", "TURN")


# =============================================================================================
# Pure geometry kernels (shared by the block-by-block and the column path)
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


# =============================================================================================
# Moves of one block
# =============================================================================================

def _motion_col(ctx) -> int:
    """Where a motion error points: the motion word, else the first axis or centre word."""
    if "motion" in ctx.gcodes:
        return ctx.gcodes["motion"][1]
    cols = [c for *_, c in ctx.axes.values()] + [c for *_, c in ctx.centre.values()]
    return min(cols) if cols else ctx.first_col


def _suppressed(ctx) -> bool:
    return "suppress" in ctx.gcodes or any(n == "SUPA" for n, _ in ctx.commands)


class Moves:
    """Turns a block's motion words into segments of the Path (or a dwell)."""

    def __init__(self, state) -> None:
        self.state = state
        self.st = state.st

    def motion(self, ctx) -> bool:
        """The block's motion; True when it programs path motion (what MCALL follows)."""
        st = self.st
        if ctx.polar:
            self._polar_target(ctx)
        arc_words = [k for k in _ARC_WORDS if k in ctx.values]
        motion = st.motion
        programmed = bool(ctx.axes)
        if motion in (0, 1):
            extra = list(ctx.centre) + list(ctx.inter) + arc_words
            if extra:
                col = (ctx.centre.get(extra[0]) or ctx.inter.get(extra[0]) or ctx.values[extra[0]])[-1]
                raise ctx.error(f"{extra[0]} is only allowed with a circle (G2/G3/CIP)", col)
            if ctx.axes:
                self._linear(ctx, motion == 0)
            return programmed
        if motion in (2, 3):
            if ctx.inter:
                key = next(iter(ctx.inter))
                raise ctx.error(f"{key}= is only allowed with CIP", ctx.inter[key][2])
            if ctx.axes or ctx.centre or arc_words:
                self._arc(ctx)
            return programmed
        if ctx.axes or ctx.inter or ctx.centre or arc_words:
            if motion == CIP:
                self._cip(ctx)
            else:
                self._ct(ctx)
        return programmed

    # ---- polar coordinates ---------------------------------------------------------------------

    def _polar_values(self, ctx, base_ap: float, base_rp: float) -> tuple[float, float]:
        ap, rp = base_ap, base_rp
        if "AP" in ctx.polar:
            value, mode, _ = ctx.polar["AP"]
            ap = base_ap + value if mode == "IC" else value
        if "RP" in ctx.polar:
            value, mode, col = ctx.polar["RP"]
            rp = base_rp + value if mode == "IC" else value
            if rp < 0.0:
                raise ctx.error(f"RP= must not be negative, got {format_value(rp)}", col)
        return ap, rp

    def _plane_point(self, centre: list, ap: float, rp_mm: float) -> list:
        e1, e2, _ = PLANE_AXES[self.st.plane]
        point = list(centre)
        a = math.radians(ap)
        point[e1] = centre[e1] + rp_mm * math.cos(a)
        point[e2] = centre[e2] + rp_mm * math.sin(a)
        return point

    def _polar_target(self, ctx) -> None:
        """AP= RP=: the end point (and for G2/G3 the centre, the pole) as absolute words."""
        st, state = self.st, self.state
        e1, e2, _ = PLANE_AXES[st.plane]
        for axis in (e1, e2):
            if AXES[axis] in ctx.axes:
                raise ctx.error(f"{AXES[axis]} together with polar coordinates (AP=/RP=) in one "
                                f"block", ctx.axes[AXES[axis]][2])
        if st.motion not in (0, 1, 2, 3):
            col = next(iter(ctx.polar.values()))[2]
            raise ctx.error("polar coordinates need G0, G1, G2 or G3", col)
        ap, rp = self._polar_values(ctx, *state.polar)
        state.polar = [ap, rp]
        scale = st.length_scale
        pole = state.pole_wcs or [0.0, 0.0, 0.0]
        end = self._plane_point(pole, ap, rp * scale)
        col = next(iter(ctx.polar.values()))[2]
        for axis in (e1, e2):
            ctx.axes[AXES[axis]] = (end[axis] / scale, "AC", col)
        if st.motion in (2, 3):
            if ctx.centre or any(k in ctx.values for k in _ARC_WORDS):
                raise ctx.error("a circle in polar coordinates takes no I J K, CR= or AR= (its "
                                "centre is the pole)", col)
            for axis in (e1, e2):
                ctx.centre[CENTRE[axis]] = (pole[axis] / scale, "AC", col)

    def pole(self, ctx) -> None:
        """G110/G111/G112: a new pole (no motion)."""
        st, state = self.st, self.state
        code, col = ctx.gcodes["pole"]
        if "motion" in ctx.gcodes or ctx.centre or ctx.inter:
            raise ctx.error(f"G{code} sets the pole: no motion in its block", col)
        e1, e2, _ = PLANE_AXES[st.plane]
        scale = st.length_scale
        last_pole = state.pole_wcs or [0.0, 0.0, 0.0]
        reference = {110: list(st.pos_wcs), 111: [0.0, 0.0, 0.0], 112: list(last_pole)}[code]
        if ctx.polar:
            if ctx.axes:
                raise ctx.error(f"G{code}: the pole either in X Y Z or in AP= RP=", col)
            ap, rp = self._polar_values(ctx, 0.0, 0.0)
            pole = self._plane_point(reference, ap, rp * scale)
        else:
            pole = list(reference)
            for axis in (e1, e2):
                name = AXES[axis]
                if name in ctx.axes:
                    value, mode, acol = ctx.axes[name]
                    if mode is not None:
                        raise ctx.error(f"{mode}() is not allowed in a G{code} block", acol)
                    pole[axis] = reference[axis] + value * scale
        state.pole_wcs = pole

    def dwell(self, ctx) -> None:
        """G4 F<seconds> or G4 S<revolutions>, alone (without motion) in its block."""
        st = self.st
        _, gcol = ctx.gcodes["dwell"]
        if ctx.axes or ctx.centre or ctx.inter or "motion" in ctx.gcodes:
            raise ctx.error("G4 must be programmed in a block without motion", gcol)
        has_f, has_s = "F" in ctx.values, "S" in ctx.values
        if has_f == has_s:
            raise ctx.error("G4 needs either F (seconds) or S (spindle revolutions)", gcol)
        value, col = ctx.values["F" if has_f else "S"]
        if value < 0.0:
            raise ctx.error("G4 dwell must not be negative", col)
        if has_f:
            seconds = value
        elif st.spindle_on and st.spindle_rpm:
            seconds = value * 60.0 / st.spindle_rpm
        else:
            ctx.warn("dwell", f"G4 S{format_value(value)}: spindle speed unknown or spindle "
                     f"stopped, dwell taken as 0 s", col)
            seconds = 0.0
        st.pending_dwell_s += seconds
        st.pending_stop = True

    # ---- end points ----------------------------------------------------------------------------

    def _require_feed(self, ctx) -> None:
        """A G1/G2/G3 needs a path feed: the last F, or the machine's default feed SD42110
        ``$SC_DEFAULT_FEED`` the program started with (:class:`~ncsim.nc.context.InterpreterState`);
        without either the 840D stops with alarm 10860 "no feed programmed"."""
        if math.isnan(self.st.feed_mm_s):
            name = MOTION_NAMES[self.st.motion]
            state = self.state
            if state.feed_type in (95, 97) and state.f_value > 0.0:
                raise ctx.error(f"{name} with feed per revolution (G{state.feed_type}) needs the "
                                f"spindle turning: S and M3/M4", _motion_col(ctx))
            raise ctx.error(f"{name} without a feed: no F programmed yet (840D alarm 10860; a "
                            f"machine's default feed SD42110 is the machine-file key "
                            f"ncu.default_feed_mm_min)", _motion_col(ctx))

    def _axis_value(self, i: int, value: float, mode) -> tuple[bool, float]:
        """(incremental, mm) of a programmed value of axis ``i``: G90/G91 or AC/IC, and on the
        transverse axis diameter programming (:mod:`ncsim.nc.diameter`)."""
        st = self.st
        if i == self.state.diameter_axis and (st.diameter or mode in VALUE_MODES):
            inc, factor = transverse_value(mode, st.incremental, st.diameter)
            return inc, value * st.length_scale * factor
        return mode == "IC" or (mode is None and st.incremental), value * st.length_scale

    def _targets(self, ctx, suppressed: bool):
        """End point of the block in WCS and MCS (lists of 3 floats)."""
        st = self.st
        axes = ctx.axes
        if suppressed:
            mcs = list(st.pos_mcs)
            for i, a in enumerate(AXES):
                if a in axes:
                    value, mode, _ = axes[a]
                    inc, mm = self._axis_value(i, value, mode)
                    mcs[i] = mcs[i] + mm if inc else mm
            return list(st.frame.inverse_apply(*mcs)), mcs
        wcs = []
        for i, a in enumerate(AXES):
            base = st.pos_wcs[i]
            if a in axes:
                value, mode, _ = axes[a]
                inc, mm = self._axis_value(i, value, mode)
                wcs.append(base + mm if inc else mm)
            else:
                wcs.append(base + 0.0 if st.incremental else base)
        return wcs, list(st.frame.apply(*wcs))

    # ---- straight lines ------------------------------------------------------------------------

    def _linear(self, ctx, rapid: bool) -> None:
        if not rapid:
            self._require_feed(ctx)
        wcs, mcs = self._targets(ctx, _suppressed(ctx))
        self.line_to(ctx, wcs, mcs, rapid)

    def line_to(self, ctx, wcs: list, mcs: list, rapid: bool) -> None:
        """The straight segment from the current position to ``mcs`` (none when it is shorter
        than MIN_LINE_MM); the position becomes ``wcs``/``mcs``. Compiled G0/G1 blocks
        (:mod:`ncsim.nc.fastops`) end here too."""
        start = self.st.pos_mcs
        dx, dy, dz = mcs[0] - start[0], mcs[1] - start[1], mcs[2] - start[2]
        length = math.sqrt(dx * dx + dy * dy + dz * dz)
        if length > MIN_LINE_MM:
            self._emit(ctx, LINE, start, mcs, _NAN3, _ZERO3, math.nan, 0.0, 0.0, length, rapid)
        self.st.pos_wcs, self.st.pos_mcs = wcs, mcs

    # ---- circles -------------------------------------------------------------------------------

    def _arc_normal(self, ctx) -> np.ndarray:
        n = arc_normal(self.st.frame, self.st.plane)
        if n is None:
            raise ctx.unsupported("a circle under a non-uniform SCALE (an ellipse) is not "
                                  "simulated", _motion_col(ctx))
        return n

    def _arc(self, ctx) -> None:
        """G2/G3 with I J K (optionally TURN=), CR= or AR=."""
        st = self.st
        col = _motion_col(ctx)
        self._require_feed(ctx)
        if _suppressed(ctx):
            raise ctx.unsupported("a circle with SUPA/G53 is not simulated", col)
        values = ctx.values
        has_cr, has_ar = "CR" in values, "AR" in values
        if not (ctx.centre or has_cr or has_ar):
            raise ctx.error(f"G{st.motion} without centre (I J K), radius (CR=) or opening "
                            f"angle (AR=)", col)
        if has_cr and (ctx.centre or has_ar):
            raise ctx.error("CR= together with I J K or AR=", values["CR"][1])
        turns = self._turns(ctx)
        sign = 1.0 if st.motion == 3 else -1.0
        n_ccw = self._arc_normal(ctx)
        start_wcs = list(st.pos_wcs)
        perp = PLANE_AXES[st.plane][2]
        if CENTRE[perp] in ctx.centre:
            ctx.warn("centre", f"{CENTRE[perp]} is perpendicular to the G{st.plane} plane: "
                     f"ignored (the centre lies in the plane)", ctx.centre[CENTRE[perp]][2])
        if has_ar and not ctx.axes:
            center_wcs = self._centre_wcs(ctx, start_wcs)
            end_wcs = self._rotate_in_plane(start_wcs, center_wcs, sign * values["AR"][0])
        else:
            end_wcs, _ = self._targets(ctx, False)
            if has_cr:
                center_wcs = self._centre_from_cr(ctx, start_wcs, end_wcs, sign)
            elif has_ar:
                if ctx.centre:
                    raise ctx.error("AR= with both centre (I J K) and end point", values["AR"][1])
                center_wcs = self._centre_from_ar(ctx, start_wcs, end_wcs, sign)
            else:
                center_wcs = self._centre_wcs(ctx, start_wcs)
        end_mcs = list(st.frame.apply(*end_wcs))
        center_mcs = list(st.frame.apply(*center_wcs))
        self._emit_arc(ctx, end_wcs, end_mcs, center_mcs, sign * n_ccw, turns)

    def _turns(self, ctx) -> float:
        if "TURN" not in ctx.values:
            return 0.0
        value, col = ctx.values["TURN"]
        if value < 0 or value != int(value):
            raise ctx.error(f"TURN= must be a whole number >= 0, got {format_value(value)}", col)
        if not ctx.centre:
            raise ctx.error("TURN= needs the centre (I J K)", col)
        return float(value)

    def _centre_wcs(self, ctx, start_wcs: list) -> list:
        """I J K: incremental to the start point (AC: absolute), in-plane components only."""
        scale = self.st.length_scale
        e1, e2, _ = PLANE_AXES[self.st.plane]
        center = list(start_wcs)
        for axis in (e1, e2):
            word = ctx.centre.get(CENTRE[axis])
            if word is None:
                center[axis] = start_wcs[axis] + 0.0
            else:
                value, mode, _ = word
                if mode == "AC" and axis == self.state.diameter_axis and \
                        diameter_applies(self.st.diameter, False):
                    value *= 0.5       # I=AC(..) on the transverse axis is a diameter
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

    def _centre_from_cr(self, ctx, start: list, end: list, sign: float) -> list:
        value, col = ctx.values["CR"]
        normal = sign * plane_normal(self.st.plane)
        chord = np.subtract(end, start)
        chord -= np.dot(chord, normal) * normal
        if np.linalg.norm(chord) <= FULL_CIRCLE_TOL_MM:
            raise ctx.error("a full circle cannot be programmed with CR= (use I J K)", col)
        if value == 0.0:
            raise ctx.error("CR=0 is not a circle", col)
        center = center_from_radius(start, end, normal, value * self.st.length_scale)
        if center is None:
            raise ctx.error(f"CR={format_value(value)} is smaller than half the distance "
                            f"between start and end point", col)
        return [float(c) for c in center]

    def _centre_from_ar(self, ctx, start: list, end: list, sign: float) -> list:
        value, col = ctx.values["AR"]
        if not 0.0 < value < 360.0:
            raise ctx.error(f"AR= must be between 0 and 360 degrees, got {format_value(value)}", col)
        center = center_from_opening_angle(start, end, sign * plane_normal(self.st.plane),
                                           math.radians(value))
        if center is None:
            raise ctx.error("AR= with the end point equal to the start point", col)
        return [float(c) for c in center]

    def _cip(self, ctx) -> None:
        """CIP: circle through the start, the intermediate point I1 J1 K1 and the end."""
        st = self.st
        col = _motion_col(ctx)
        self._require_feed(ctx)
        if ctx.centre or any(k in ctx.values for k in _ARC_WORDS):
            raise ctx.error("CIP takes an end point and I1= J1= K1=, not I J K/CR/AR/TURN", col)
        if not ctx.axes or not ctx.inter:
            raise ctx.error("CIP needs an end point and an intermediate point (I1= J1= K1=)", col)
        end_wcs, end_mcs = self._targets(ctx, _suppressed(ctx))
        inter = list(st.pos_wcs)
        for i, key in enumerate(INTER):
            if key in ctx.inter:
                value, mode, _ = ctx.inter[key]
                inc, mm = self._axis_value(i, value, mode)
                inter[i] = st.pos_wcs[i] + mm if inc else mm
        found = circle_through_points(st.pos_mcs, st.frame.apply(*inter), end_mcs)
        if found is None:
            raise ctx.error("CIP: start, intermediate and end point lie on one line", col)
        center, normal = found
        self._emit_arc(ctx, end_wcs, end_mcs, [float(c) for c in center], normal, 0.0)

    def _ct(self, ctx) -> None:
        """CT: circle tangential to the previous segment, ending at the programmed point."""
        st = self.st
        col = _motion_col(ctx)
        self._require_feed(ctx)
        if ctx.centre or ctx.inter or any(k in ctx.values for k in _ARC_WORDS):
            raise ctx.error("CT takes only an end point", col)
        if st.last_segment is None:
            raise ctx.error("CT needs a previous path segment to be tangential to", col)
        end_wcs, end_mcs = self._targets(ctx, _suppressed(ctx))
        n_plane = self._arc_normal(ctx)
        found = center_tangential(st.pos_mcs, end_mcs, end_tangent(st.last_segment), n_plane)
        if found is None:
            raise ctx.error("CT: the end point lies on the tangent (a straight line, not a "
                            "circle)", col)
        center, normal = found
        self._emit_arc(ctx, end_wcs, end_mcs, [float(c) for c in center], normal, 0.0)

    def _emit_arc(self, ctx, end_wcs, end_mcs, center_mcs, normal, turns) -> None:
        st = self.st
        state = self.state
        geo = arc_columns(np.array([st.pos_mcs], dtype=np.float64),
                          np.array([end_mcs], dtype=np.float64),
                          np.array([center_mcs], dtype=np.float64),
                          np.array([normal], dtype=np.float64), turns)
        r_start, r_end = float(geo["radius_mm"][0]), float(geo["radius_end_mm"][0])
        col = _motion_col(ctx)
        if not r_start > 0.0:
            raise ctx.error("circle centre coincides with the start point", col)
        err = float(circle_error_mm(r_start, r_end))
        tol = float(circle_tolerance_mm(r_start, state.circle_const_mm, state.circle_factor))
        if err > tol:
            raise ctx.error(f"circle end point error: start radius {r_start:.4f} mm and end "
                            f"radius {r_end:.4f} mm differ by {err:.4f} mm > {tol:.4f} mm "
                            f"(MD21000/MD21010)", col)
        self._emit(ctx, ARC, st.pos_mcs, end_mcs, tuple(geo["center_mm"][0].tolist()),
                   tuple(float(v) for v in normal), r_start, float(geo["sweep_rad"][0]),
                   float(geo["helix_mm"][0]), float(geo["length_mm"][0]), False)
        st.pos_wcs, st.pos_mcs = list(end_wcs), list(end_mcs)

    # ---- segments ------------------------------------------------------------------------------

    def _emit(self, ctx, kind, start, end, center, normal, radius, sweep, helix, length,
              rapid: bool) -> None:
        """One segment with the modal state it runs under (G9 in the block: exact stop)."""
        st = self.st
        stop = st.pending_stop or (st.last_rapid is not None and st.last_rapid != rapid)
        self.state.out.append({
            "kind": kind, "start_mm": tuple(start), "end_mm": tuple(end), "center_mm": center,
            "normal": normal, "radius_mm": radius, "sweep_rad": sweep, "helix_mm": helix,
            "length_mm": length, "line": ctx.line, "file_index": ctx.frame.file_index,
            "feed_mm_s": math.inf if rapid else st.feed_mm_s, "rapid": rapid,
            "exact_stop": st.cp_mode == 60 or "block_exact_stop" in ctx.gcodes,
            "stop_window": st.stop_window,
            "cp_mode": st.cp_mode, "adis_mm": st.adispos_mm if rapid else st.adis_mm,
            "accel_mode": st.accel_mode, "ffw": st.ffw, "stop_before": stop,
            "dwell_before_s": st.pending_dwell_s,
            "compressor": 0 if kind != LINE else (-st.compressor if st.compress_break
                                                   else st.compressor),
            "ctol_mm": st.ctol_mm, "dyn_group": st.dyn_group})
        st.pending_stop = False
        st.pending_dwell_s = 0.0
        st.compress_break = False
        st.last_rapid = rapid
        st.last_segment = (kind, tuple(start), tuple(end), center, normal, radius, sweep, helix)
