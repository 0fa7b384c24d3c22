"""ISO dialect canned cycles (G73, G74, G76, G81..G89 with G98/G99), expanded into their moves.

SINUMERIK ISO Milling, chapter "Additional functions", "Program support functions": "Fixed
cycles" (the 840D runs them through its ISO shell cycles; the motion is the Fanuc one):

* the cycle is modal from its G code to G80 or a G code of the motion group (G00..G03); each
  later block with a position (X, Y, Z or R) machines one hole; the cycle data Z, R, Q, P and F
  stay until changed, K (or L) repeats the hole in that block only (K0: the data are stored, no
  hole; under G91 each repetition moves by the programmed X Y increment);
* the hole: positioning in the plane at rapid, rapid to the R level, the drilling move to the
  bottom Z, the bottom action, the return to the R level (G99) or to the initial level (G98: the
  height of the drilling axis when the cycle was selected). Under G91, R is the distance from
  the initial level and Z from the R level;
* the drilling move and the bottom per code: G81 feed in, rapid out; G82 feed in, dwell P,
  rapid out; G83 peck drilling (feed Q, rapid back to R, rapid down to d above the last depth,
  d = ``[iso] peck_clearance_mm``); G73 high-speed peck (feed Q, rapid back d =
  ``[iso] peck_retract_mm``); G84/G74 tapping (feed in, dwell P, spindle reversal, feed out to
  R); G85 feed in and out; G86 feed in, spindle stop, rapid out; G89 feed in, dwell P, feed out;
  G76 fine boring (feed in, dwell P, spindle orientation, shift Q along the plane's first axis,
  rapid out, shift back). G87 (back boring) and G88 (manual retract) are not simulated;
* P is the dwell in milliseconds. Each move of a hole starts and ends at rest, as the shell
  cycles position in exact stop.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from ncsim.geometry import PLANE_AXES

CYCLE_CODES = (73, 74, 76, 81, 82, 83, 84, 85, 86, 89)
NOT_SIMULATED = {87: "G87 back boring (spindle orientation under the part)",
                 88: "G88 boring with a manual retract"}
_TAPPING = (74, 84)


@dataclass(slots=True)
class CycleData:
    """The modal data of the active cycle (program units, as programmed)."""

    code: int
    initial: float               # initial level of the drilling axis (WCS mm)
    bottom: float | None = None  # Z as programmed
    r_level: float | None = None  # R as programmed
    q: float = 0.0
    p_ms: float = 0.0


class Cycles:
    """Executes the holes of the active canned cycle (the ISO executor holds one)."""

    def __init__(self, iso) -> None:
        self.iso = iso
        self.state = iso.state
        self.st = iso.state.st
        self.data: CycleData | None = None
        self.return_initial = True          # G98 (reset value), G99: to the R level

    def select(self, ctx, code: int, col: int) -> None:
        if code in NOT_SIMULATED:
            raise ctx.unsupported(f"{NOT_SIMULATED[code]} is not simulated", col)
        _, _, axis = PLANE_AXES[self.st.plane]
        if self.data is None:
            self.data = CycleData(code, self.st.pos_wcs[axis])
        else:
            self.data.code = code

    def cancel(self) -> None:
        self.data = None

    def block(self, ctx, extra: dict) -> bool:
        """Take the cycle words of the block and machine its holes; False when the block has
        no position (nothing to machine)."""
        d = self.data
        st = self.st
        scale = st.length_scale
        e1, e2, axis = PLANE_AXES[st.plane]
        names = "XYZ"
        drilling_axis = names[axis] in ctx.axes
        if drilling_axis:
            d.bottom = ctx.axes.pop(names[axis])[0]
        if "R" in extra:
            d.r_level = extra["R"][0]
        if "Q" in extra:
            d.q = abs(extra["Q"][0])
        if "P" in extra:
            d.p_ms = extra["P"][0]
        repeats = 1
        if "K" in extra or "L" in extra:
            value, col, _ = extra.get("K") or extra["L"]
            repeats = ctx.whole_number(value, "K", col)
        positioned = any(names[a] in ctx.axes for a in (e1, e2))
        if not (positioned or drilling_axis or "R" in extra):
            return False
        if d.bottom is None or d.r_level is None:
            raise ctx.error(f"G{d.code} needs the hole bottom {names[axis]} and the R level",
                            ctx.first_col)
        if d.code in (73, 83) and d.q <= 0.0:
            raise ctx.error(f"G{d.code} needs the peck depth Q > 0", ctx.first_col)
        if math.isnan(st.feed_mm_s):
            raise ctx.error(f"G{d.code} without a feed: no F programmed yet (840D alarm 10860)",
                            ctx.first_col)
        if d.code in _TAPPING:
            ctx.warn("ISO cycle", f"G{d.code} tapping: the spindle reversal at the bottom is "
                     f"simulated as a stop (its time is not)", ctx.first_col)
        elif d.code == 76:
            ctx.warn("ISO cycle", "G76 fine boring: the spindle orientation is simulated as a "
                     "stop (its time is not); the shift is along the plane's first axis",
                     ctx.first_col)
        for _ in range(repeats):
            hole = list(st.pos_wcs)
            for a in (e1, e2):
                if names[a] in ctx.axes:
                    value = ctx.axes[names[a]][0] * scale
                    hole[a] = hole[a] + value if st.incremental else value
            self._hole(ctx, hole, axis, scale)
        return True

    def _levels(self, axis: int, scale: float) -> tuple[float, float, float]:
        """(initial, R, bottom) of the drilling axis in workpiece mm."""
        d = self.data
        if self.st.incremental:
            r = d.initial + d.r_level * scale
            return d.initial, r, r + d.bottom * scale
        return d.initial, d.r_level * scale, d.bottom * scale

    def _hole(self, ctx, hole: list, axis: int, scale: float) -> None:
        d = self.data
        initial, r, bottom = self._levels(axis, scale)
        down = math.copysign(1.0, bottom - r) if bottom != r else -1.0
        hole[axis] = self.st.pos_wcs[axis]
        self._move(ctx, hole, True)                      # positioning in the plane
        self._to(ctx, axis, r, True)                     # rapid to the R level
        code = d.code
        if code in (73, 83):
            self._pecks(ctx, axis, r, bottom, down, code)
        else:
            self._to(ctx, axis, bottom, False)
        if d.p_ms > 0.0 and code in (74, 76, 82, 84, 89):
            self.iso.dwell(ctx, d.p_ms / 1000.0)
        top = initial if self.return_initial else r
        if code in (74, 84, 85, 89):                    # feed out to R, then rapid
            self._to(ctx, axis, r, False)
            self._to(ctx, axis, top, True)
        elif code == 76:
            e1 = PLANE_AXES[self.st.plane][0]
            shift = list(self.st.pos_wcs)
            shift[e1] += d.q * scale
            self._move(ctx, shift, True)
            self._to(ctx, axis, top, True)
            shift[axis] = top
            shift[e1] -= d.q * scale
            self._move(ctx, shift, True)
        else:
            self._to(ctx, axis, top, True)

    def _pecks(self, ctx, axis: int, r: float, bottom: float, down: float, code: int) -> None:
        spec = self.iso.spec
        q = self.data.q * self.st.length_scale
        depth = r
        while (bottom - depth) * down > 1e-12:
            target = depth + down * q
            if (bottom - target) * down < 0.0:
                target = bottom
            self._to(ctx, axis, target, False)
            depth = target
            if (bottom - depth) * down <= 1e-12:
                break
            if code == 83:
                self._to(ctx, axis, r, True)
                self._to(ctx, axis, depth - down * spec.peck_clearance_mm, True)
            else:
                self._to(ctx, axis, depth - down * spec.peck_retract_mm, True)

    def _to(self, ctx, axis: int, level: float, rapid: bool) -> None:
        point = list(self.st.pos_wcs)
        point[axis] = level
        self._move(ctx, point, rapid)

    def _move(self, ctx, wcs: list, rapid: bool) -> None:
        st = self.st
        if wcs == st.pos_wcs:
            return
        st.pending_stop = True
        self.iso.moves.line_to(ctx, wcs, list(st.frame.apply(*wcs)), rapid)
