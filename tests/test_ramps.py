"""Controlled-jerk ramps and eq. 16, checked against independent calculations."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from ruckig import InputParameter, Result, Ruckig, Trajectory

from ncsim.plan import _kernels as K
from ncsim.plan.ramps import peak_feed_mm_s, ramp_distance_mm, ramp_pieces, ramp_reach_mm_s, ramp_time_s

feeds = st.floats(0.0, 500.0)
jerks = st.floats(100.0, 100_000.0)
accels = st.floats(50.0, 10_000.0)


def integrate_pieces(v0, durations, jerks_):
    """Exact integration of constant-jerk pieces from (v0, a=0): returns t, s, v, a at the end."""
    t = s = a = 0.0
    v = v0
    for dt, j in zip(durations, jerks_):
        s += dt * (v + dt * (a / 2 + dt * j / 6))
        v += dt * (a + dt * j / 2)
        a += dt * j
        t += dt
    return t, s, v, a


@settings(max_examples=300, deadline=None)
@given(feeds, feeds, jerks, accels)
def test_ramp_pieces_reach_the_target_with_zero_acceleration(v0, v1, j, a):
    d, jk = ramp_pieces(v0, v1, j, a)
    t, s, v, acc = integrate_pieces(v0, d.ravel(), jk.ravel())
    assert v == pytest.approx(v1, abs=1e-9 * max(1.0, v1))
    assert acc == pytest.approx(0.0, abs=1e-9 * a)
    assert t == pytest.approx(float(ramp_time_s(v1 - v0, j, a)), rel=1e-12, abs=1e-15)
    assert s == pytest.approx(float(ramp_distance_mm(v0, v1, j, a)), rel=1e-9, abs=1e-12)
    # the acceleration never exceeds its limit
    peak_acc = abs(jk[0] * d[0])
    assert peak_acc <= a * (1 + 1e-12)


@settings(max_examples=300, deadline=None)
@given(feeds, feeds, jerks, accels)
def test_reach_inverts_distance(v0, v1, j, a):
    v0, v1 = min(v0, v1), max(v0, v1)
    distance = float(ramp_distance_mm(v0, v1, j, a))
    got = float(ramp_reach_mm_s(v0, distance, j, a))
    assert got == pytest.approx(v1, rel=1e-9, abs=1e-9)
    for reach in (K.ramp_reach_scalar.py, K.ramp_reach_scalar.compiled):  # plain and numba
        assert reach(v0, distance, j, a) == pytest.approx(v1, rel=1e-9, abs=1e-9)


def test_eq16_paper_form_jerk_only():
    """With no acceleration limit the peak solves the paper's eq. 16 literally."""
    J = 5000.0
    v_frs, v_fre, L = 10.0, 42.43, 20.0
    vf = float(peak_feed_mm_s(v_frs, v_fre, L, J, np.inf))
    lhs = np.sqrt(vf - v_fre) * (vf + v_fre) + np.sqrt(vf - v_frs) * (vf + v_frs)
    assert lhs == pytest.approx(L * np.sqrt(J), rel=1e-10)


@settings(max_examples=150, deadline=None)
@given(feeds, feeds, st.floats(0.01, 200.0), jerks, accels, st.floats(1.0, 800.0))
def test_peak_fills_the_block_or_reaches_the_cap(va, vb, length, j, a, cap):
    lo = max(va, vb)
    if cap < lo or float(ramp_distance_mm(min(va, vb), lo, j, a)) > length:
        return  # infeasible inputs are the look-ahead's job
    vp = float(peak_feed_mm_s(va, vb, length, j, a, cap))
    used = float(ramp_distance_mm(va, vp, j, a) + ramp_distance_mm(vp, vb, j, a))
    assert lo - 1e-9 <= vp <= cap * (1 + 1e-12)
    # Lengths are checked to 1 nm: recomputing a ramp from the float feeds (vp - va) costs
    # up to v / sqrt(J dv) x ulp(v) of length when the feed change dv is tiny (1e-9 mm for
    # dv = 4e-6 mm/s at 359 mm/s and J = 100 mm/s^3).
    assert used <= length * (1 + 1e-9) + 1e-6
    if vp < cap * (1 - 1e-9):
        # phase B vanishes: eq. 16 holds
        assert used == pytest.approx(length, rel=1e-6, abs=1e-6)
    for peak in (K.peak_feed_scalar.py, K.peak_feed_scalar.compiled):  # plain and numba
        assert peak(va, vb, length, j, a, cap) == pytest.approx(vp, rel=1e-9, abs=1e-9)


def ruckig_duration(length, v0, v1, vmax, amax, jmax):
    inp = InputParameter(1)
    inp.current_position, inp.current_velocity, inp.current_acceleration = [0.0], [v0], [0.0]
    inp.target_position, inp.target_velocity, inp.target_acceleration = [length], [v1], [0.0]
    inp.max_velocity, inp.max_acceleration, inp.max_jerk = [vmax], [amax], [jmax]
    traj = Trajectory(1)
    assert Ruckig(1).calculate(inp, traj) in (Result.Working, Result.Finished)
    return traj.duration


@pytest.mark.parametrize("length,va,vb,cap,jerk,accel", [
    (100.0, 0.0, 0.0, 100.0, 5000.0, 2500.0),   # plateau reached (phase B)
    (10.0, 0.0, 0.0, 100.0, 5000.0, 2500.0),    # B vanishes: eq. 16
    (31.4, 0.0, 42.4, 84.3, 5000.0, 2500.0),    # paper: semicircle R10 from rest, end at V_fr
    (15.7, 0.0, 60.0, 84.3, 5000.0, 2500.0),    # quarter circle R10: set point not reached
    (50.0, 20.0, 5.0, 300.0, 5000.0, 400.0),    # acceleration limit reached
])
def test_section_law_is_time_optimal_like_ruckig(length, va, vb, cap, jerk, accel):
    """Model notes: under these limits the paper's law is the time-optimal one."""
    vp = float(peak_feed_mm_s(va, vb, length, jerk, accel, cap))
    up = float(ramp_distance_mm(va, vp, jerk, accel))
    down = float(ramp_distance_mm(vp, vb, jerk, accel))
    ours = float(ramp_time_s(vp - va, jerk, accel) + ramp_time_s(vp - vb, jerk, accel)) \
        + (length - up - down) / vp
    assert ours == pytest.approx(ruckig_duration(length, va, vb, cap, accel, jerk), rel=1e-6)
