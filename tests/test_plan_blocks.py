"""Every ramp under the limits of the blocks it runs through, not the least of its section.

The truths are independent of ``ncsim.plan``: ruckig's time-optimal 1-D motion, and the plain
planner of ``ncsim.gap.truth.plain`` (zero acceleration at every junction, each block its own
limits, ruckig in every block), fed the per-block limits ncsim computed for the same path.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st
from ruckig import ControlInterface, InputParameter, Result, Ruckig, Trajectory

from ncsim.gap.truth.plain import plan_plain_limits, ramp_distance_mm
from ncsim.motion import FULL_MODEL, ModelOptions
from ncsim.nc.interpret import interpret_text
from ncsim.plan.limits import path_limits
from ncsim.plan.lookahead import plan

SETTINGS = settings(max_examples=30, deadline=None, derandomize=True,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
NO_LOOKAHEAD = ModelOptions(lookahead=False)


@st.composite
def arc_line_chains(draw, long_blocks=False):
    """An 840D program: a lead-in line from rest, then arcs and lines alternating (tangent,
    or a line turned by a corner), at one feed, SOFT or BRISK, G64; ends at rest."""
    mode = draw(st.sampled_from(["SOFT", "BRISK"]))
    feed = draw(st.sampled_from([1500, 4000, 9000, 15000]))
    lengths = [20.0, 80.0] if long_blocks else [0.5, 2.0, 8.0, 40.0]
    lines = [f"G17 G90 G64 {mode}", "G0 X0 Y0 Z0",
             f"G1 X{draw(st.sampled_from(lengths)):.4f} F{feed}"]
    x, y, heading = float(lines[-1].split()[1][1:]), 0.0, 0.0
    for i in range(draw(st.integers(2, 5))):
        if i % 2 == 0:
            radius = draw(st.floats(5.0, 60.0) if long_blocks else st.floats(1.0, 60.0))
            side = draw(st.sampled_from([-1.0, 1.0]))
            sweep = draw(st.floats(0.6, 2.5) if long_blocks else st.floats(0.1, 2.5))
            cx, cy = x - side * radius * math.sin(heading), y + side * radius * math.cos(heading)
            a1 = math.atan2(y - cy, x - cx) + side * sweep
            nx, ny = cx + radius * math.cos(a1), cy + radius * math.sin(a1)
            lines.append(f"{'G3' if side > 0 else 'G2'} X{nx:.4f} Y{ny:.4f} "
                         f"I{cx - x:.4f} J{cy - y:.4f}")
            heading += side * sweep
            x, y = nx, ny
        else:
            heading += draw(st.sampled_from([0.0, 0.0, 0.6, -1.2]))       # tangent or a corner
            length = draw(st.sampled_from(lengths)) * draw(st.floats(0.7, 1.3))
            x, y = x + length * math.cos(heading), y + length * math.sin(heading)
            lines.append(f"G1 X{x:.4f} Y{y:.4f}")
    return "\n".join(lines + ["M30"]) + "\n"


def planned(text, machine, options):
    path = interpret_text(text, "chain.mpf", machine).path
    limits = path_limits(path, machine, options)
    return limits, plan(path, machine, options, limits=limits)


def ruckig_ramp(v0, v1, jerk, accel):
    """ruckig's time-optimal change of velocity from (v0, 0) to (v1, 0) (its velocity
    interface): the duration and the distance covered."""
    inp = InputParameter(1)
    inp.control_interface = ControlInterface.Velocity
    inp.current_position, inp.current_velocity, inp.current_acceleration = [0.0], [v0], [0.0]
    inp.target_velocity, inp.target_acceleration = [v1], [0.0]
    inp.max_velocity, inp.max_acceleration, inp.max_jerk = [1e9], [accel], [jerk]
    traj = Trajectory(1)
    assert Ruckig(1).calculate(inp, traj) in (Result.Working, Result.Finished)
    return traj.duration, traj.at_time(traj.duration)[0][0]


def ramps(motion):
    """The ramps of the feed law: runs of pieces from zero acceleration back to zero
    acceleration with the feed changing, as (t0, t1, s0, s1, v0, v1)."""
    t, s, v, a, j = (motion.piece_t_s, motion.piece_s_mm, motion.piece_v_mm_s,
                     motion.piece_a_mm_s2, motion.piece_j_mm_s3)
    out, start = [], None
    for k in range(len(s)):
        dt = t[k + 1] - t[k]
        a_end = a[k] + dt * j[k]
        if start is None and j[k] != 0.0 and abs(a[k]) <= 1e-9 * max(abs(j[k]) * dt, 1.0):
            start = k
        if start is not None and abs(a_end) <= 1e-6 * max(abs(j[k]) * dt, 1e-9):
            s_end = s[k] + dt * (v[k] + dt * (a[k] / 2 + dt * j[k] / 6))
            v_end = v[k] + dt * (a[k] + dt * j[k] / 2)
            out.append((t[start], t[k + 1], s[start], s_end, v[start], v_end))
            start = None
    return out


@SETTINGS
@given(arc_line_chains())
def test_every_ramp_is_ruckigs_under_the_least_limits_of_the_blocks_it_crosses(mikron, text):
    """A ramp inside one block is time-optimal under that block's own jerk and acceleration
    (ruckig); a ramp across blocks under the least limits of those it crosses, never above
    any of them."""
    limits, motion = planned(text, mikron, NO_LOOKAHEAD)
    s_junction = np.concatenate([[0.0], np.cumsum(motion.path.length_mm)])
    checked = 0
    for t0, t1, s0, s1, v0, v1 in ramps(motion):
        inside = np.flatnonzero((s_junction[:-1] < s1 - 1e-9) & (s_junction[1:] > s0 + 1e-9)
                                & (motion.path.length_mm > 0))
        duration, distance = ruckig_ramp(v0, v1, limits.jerk_mm_s3[inside].min(),
                                         limits.accel_mm_s2[inside].min())
        assert t1 - t0 == pytest.approx(duration, rel=1e-6, abs=1e-9)
        assert s1 - s0 == pytest.approx(distance, rel=1e-6, abs=1e-9)
        checked += 1
    assert checked >= 2


def cruises_everywhere(plain, vmax, accel, jerk):
    """Every block of the plain planner's motion reaches its velocity cap (it has room for
    both its ramps at its own limits): no ramp of the law crosses a junction."""
    v, length = plain.v_junction_mm_s, plain.path.length_mm
    return all(ramp_distance_mm(v[k], vmax[k], accel[k], jerk[k])
               + ramp_distance_mm(vmax[k], v[k + 1], accel[k], jerk[k]) <= length[k] * (1 - 1e-9)
               for k in range(plain.path.n) if length[k] > 0)


@SETTINGS
@given(arc_line_chains(long_blocks=True))
def test_long_arc_line_chains_equal_the_plain_per_block_planner(mikron, text):
    """Where every block has room to reach its set point, no ramp crosses a junction: then
    ncsim's feed law is the plain planner's (each block its own limits, ruckig in every
    block) to the microsecond -- in particular a line entered tangentially from an arc brakes
    under the line's own limits, not the arc's."""
    limits, motion = planned(text, mikron, FULL_MODEL)
    plain = plan_plain_limits(motion.path, motion.cap_mm_s, limits.accel_mm_s2,
                              limits.jerk_mm_s3, motion.junction_cap_mm_s,
                              limits.junction_dwell_s)
    assume(cruises_everywhere(plain, motion.cap_mm_s, limits.accel_mm_s2, limits.jerk_mm_s3))
    assert motion.total_time_s == pytest.approx(plain.total_s, rel=1e-7, abs=1e-6)
    np.testing.assert_allclose(motion.duration_s, plain.duration_s, rtol=1e-6, atol=1e-6)


def test_a_line_entered_from_an_arc_brakes_with_the_lines_own_acceleration(mikron):
    """BRISK (the acceleration limit binds): an R 50 quarter arc, whose path acceleration is
    below the axes' by its centripetal part (eq. 1), flows into the tangent line along Y (its
    own acceleration: the Y axis's 3 m/s^2), which brakes to a stop: the braking lies in the
    line and takes ruckig's time under the line's own limits, not the arc's."""
    text = ("G17 G90 G64 BRISK\nG0 X0 Y0 Z0\nG1 X40 F3000\nG3 X90 Y50 I0 J50\n"
            "G1 Y150\nM30\n")
    limits, motion = planned(text, mikron, NO_LOOKAHEAD)
    arc, line = 1, 2
    assert limits.accel_mm_s2[arc] < limits.accel_mm_s2[line] * 0.99
    t0, t1, s0, s1, v0, v1 = ramps(motion)[-1]
    assert not motion.knot[2]                                     # no stop between them
    assert s0 > 40.0 + 25 * math.pi and abs(v1) < 1e-9            # inside the line
    duration, distance = ruckig_ramp(v0, 0.0, limits.jerk_mm_s3[line], limits.accel_mm_s2[line])
    assert (t1 - t0, s1 - s0) == pytest.approx((duration, distance), rel=1e-9)
    assert motion.accel_mm_s2[line] == limits.accel_mm_s2[line]


def test_doubling_the_feed_of_an_arc_and_a_short_line_is_never_slower(mikron):
    """A short line after an arc that reaches its set point: at the higher feed the line's
    set point exceeds the arc's, but the line cannot rise in its length; the arc's braking
    runs on into it (no zero-acceleration stop at the change of set point)."""
    def total(feed):
        text = (f"G17 G90 G64 SOFT FFWON\nG0 X-20 Y-90 Z-3\n"
                f"G2 X-10 Y-38.4 I5 J25.8 F{feed}\nG1 X0.7 Y-40.47 Z-2.8\nM30\n")
        return planned(text, mikron, FULL_MODEL)[1].total_time_s

    assert total(19000.0) <= total(9500.0)
