"""Servo/structure time-stepping simulation against closed forms of the loop equations."""
from __future__ import annotations

import numpy as np
import pytest

from ncsim.errors import UsageError
from ncsim.gap.measured import MeasuredTrace
from ncsim.gap.lag import estimate_lag, three_significant_figures_step_mm
from ncsim.gap.truth.servo import ServoParams, simulate_servo, transfer_function


def line_command(v_mm_s, duration_s, dt=1e-3):
    t = np.arange(0.0, duration_s + dt / 2, dt)
    return t, np.outer(t, v_mm_s)


def circle_command(R, feed, duration_s, dt=1e-3):
    w = feed / R
    t = np.arange(0.0, duration_s + dt / 2, dt)
    pos = np.column_stack([R * np.cos(w * t), R * np.sin(w * t), 0 * t])
    vel = np.column_stack([-feed * np.sin(w * t), feed * np.cos(w * t), 0 * t])
    return t, pos, vel, w


def radius(pos):
    return np.hypot(pos[:, 0], pos[:, 1])


def test_following_error_ffw_off_is_v_over_kv():
    # P position loop, ideal speed loop: de/dt = v - Kv e  ->  e = v / Kv (1 - exp(-Kv t))
    v = np.array([100.0, -50.0, 10.0])
    kv = np.array([20.0, 30.0, 40.0])
    t, cmd = line_command(v, 1.5)
    r = simulate_servo(t, cmd, ServoParams(kv_1_s=tuple(kv)))
    expected = v / kv * (1 - np.exp(-kv * r.t_s[-1]))
    assert np.allclose(r.following_error_mm[-1], expected, rtol=1e-6, atol=1e-9)
    mid = np.searchsorted(r.t_s, 0.05)
    assert np.allclose(r.following_error_mm[mid], v / kv * (1 - np.exp(-kv * r.t_s[mid])), rtol=1e-6)
    assert np.allclose(r.deflection_mm, 0.0)                     # rigid by default
    assert np.allclose(r.pos_mm, r.drive_pos_mm)


def test_following_error_with_feed_forward_is_zero():
    v = np.array([100.0, -50.0, 0.0])
    t, cmd = line_command(v, 1.0)
    ideal = simulate_servo(t, cmd, ServoParams(kv_1_s=25.0, ffw_weight=1.0), initial="steady")
    assert np.max(np.abs(ideal.following_error_mm)) < 1e-9
    # with a lagging speed loop: steady state u = v, so Kv e = (1 - k_ff) v = 0 again
    lag = simulate_servo(t, cmd, ServoParams(kv_1_s=25.0, ffw_weight=1.0,
                                             velocity_loop_time_s=0.004))
    assert np.max(np.abs(lag.following_error_mm[-1])) < 1e-9
    # partial feed-forward: e = (1 - k_ff) v / Kv
    half = simulate_servo(t, cmd, ServoParams(kv_1_s=25.0, ffw_weight=0.5), initial="steady")
    assert np.allclose(half.following_error_mm[-1], 0.5 * v / 25.0, atol=1e-9)


def test_circle_radius_under_first_order_lag():
    # FFWOF + ideal speed loop: X/Xc = Kv / (s + Kv): steady circle radius R / sqrt(1 + (W/Kv)^2)
    R, F, kv = 30.0, 150.0, 20.0
    t, pos, vel, w = circle_command(R, F, 3.0)
    r = simulate_servo(t, pos, ServoParams(kv_1_s=kv), cmd_vel_mm_s=vel, initial="steady")
    late = r.t_s > 1.5                                        # transients exp(-Kv t) gone
    dR = R - radius(r.pos_mm[late])
    expected = R * (1 - 1 / np.sqrt(1 + (w / kv) ** 2))       # 0.8957 mm
    assert np.allclose(dR, expected, rtol=1e-6)
    # the lag is a rotation by atan(W / Kv) behind the command
    ang_cmd = np.arctan2(r.cmd_pos_mm[late, 1], r.cmd_pos_mm[late, 0])
    ang = np.arctan2(r.pos_mm[late, 1], r.pos_mm[late, 0])
    assert np.allclose(np.mod(ang_cmd - ang, 2 * np.pi), np.arctan(w / kv), atol=1e-7)


def test_circle_radius_with_feed_forward_and_speed_loop():
    # H(s) = (s + Kv) / (T s^2 + s + Kv): radius R |H(jW)| (grows slightly: FFW with a slow
    # speed loop overshoots)
    R, F, kv, T = 10.0, 100.0, 30.0, 0.005
    t, pos, vel, w = circle_command(R, F, 2.0)
    r = simulate_servo(t, pos, ServoParams(kv_1_s=kv, ffw_weight=1.0, velocity_loop_time_s=T),
                       cmd_vel_mm_s=vel, initial="steady")
    s = 1j * w
    gain = abs((s + kv) / (T * s * s + s + kv))
    late = r.t_s > 1.0
    assert np.allclose(radius(r.pos_mm[late]), R * gain, rtol=1e-6)
    assert abs(transfer_function(r.params, s)[0]) == pytest.approx(gain)


def test_compliance_pushes_the_tool_outward_by_m_a_over_k():
    # rigid ideal drive (FFWON, T_v = 0) following the circle exactly; a tool mass on a spring
    # (f_s = 15 Hz, zeta = 0.1) sees the centripetal drive acceleration A_n = F^2 / R and
    # deflects outward by m A_n / k = A_n / w_s^2 (quasi-static); exactly, the radius is
    # R |(w_s^2 + 2 j zeta w_s W) / (w_s^2 - W^2 + 2 j zeta w_s W)|.
    R, F, fs, zeta = 30.0, 150.0, 15.0, 0.1
    ws = 2 * np.pi * fs
    t, pos, vel, w = circle_command(R, F, 4.0)
    p = ServoParams(kv_1_s=50.0, ffw_weight=1.0, structure_freq_hz=fs, structure_damping=zeta)
    r = simulate_servo(t, pos, p, cmd_vel_mm_s=vel, initial="steady")
    late = r.t_s > 3.0                                        # free vibration decayed
    an = F * F / R                                            # 750 mm/s^2
    exact = R * abs((ws ** 2 + 2j * zeta * ws * w) / (ws ** 2 - w ** 2 + 2j * zeta * ws * w))
    assert np.allclose(radius(r.pos_mm[late]), exact, atol=2e-6)
    growth = radius(r.pos_mm[late]) - R
    assert np.all(growth > 0)
    assert np.mean(growth) == pytest.approx(an / ws ** 2, rel=0.01)   # 0.0844 mm
    outward = np.sum(r.deflection_mm[late, :2] * r.cmd_pos_mm[late, :2], axis=1) / R
    assert np.all(outward > 0.9 * an / ws ** 2)
    assert np.allclose(p.compliance_mm_per_mm_s2, [1 / ws ** 2] * 3)


def test_compliance_under_constant_acceleration_on_a_line():
    # x_c = a t^2 / 2 along X: the drive follows (FFWON, ideal), the tool lags by a / w_s^2
    a, fs, zeta = 1000.0, 20.0, 0.3
    t = np.arange(0.0, 1.5, 1e-3)
    cmd = np.column_stack([0.5 * a * t * t, 0 * t, 0 * t])
    vel = np.column_stack([a * t, 0 * t, 0 * t])
    p = ServoParams(kv_1_s=50.0, ffw_weight=1.0, structure_freq_hz=fs, structure_damping=zeta)
    r = simulate_servo(t, cmd, p, cmd_vel_mm_s=vel)
    # the drive has a transient (ramp of acceleration from rest), wait for it
    assert r.deflection_mm[-1, 0] == pytest.approx(-a / (2 * np.pi * fs) ** 2, rel=1e-4)


def test_friction_offsets_the_following_error():
    # P speed loop on an inertia with Coulomb friction: steady T_v dv/dt = u - v - T_v f sgn(v)
    # = 0 and u = k_ff v + Kv e  ->  e = ((1 - k_ff) v + T_v f sgn(v)) / Kv
    kv, T, f = 30.0, 0.004, 2000.0
    v = np.array([60.0, -40.0, 0.0])
    t, cmd = line_command(v, 1.5)
    r = simulate_servo(t, cmd, ServoParams(kv_1_s=kv, ffw_weight=1.0, velocity_loop_time_s=T,
                                           friction_mm_s2=f))
    expected = T * f * np.sign(v) / kv
    # friction is applied by operator splitting (first order in dt): allow 1e-3 relative
    assert np.allclose(r.following_error_mm[-1], expected, rtol=1e-3, atol=1e-9)
    # back and forth along X (x = A sin(W t)): the friction error flips with the direction of
    # motion, from +e_f to -e_f (a lost motion of 2 e_f at each reversal: the quadrant glitch)
    A, W = 20.0, np.pi
    t = np.arange(0.0, 4.0, 1e-3)
    cmd = np.column_stack([A * np.sin(W * t), 0 * t, 0 * t])
    vel = np.column_stack([A * W * np.cos(W * t), 0 * t, 0 * t])
    r = simulate_servo(t, cmd, ServoParams(kv_1_s=kv, ffw_weight=1.0, velocity_loop_time_s=T,
                                           friction_mm_s2=f), cmd_vel_mm_s=vel)
    e_f = T * f / kv
    vc = A * W * np.cos(W * r.t_s)
    fast = (r.t_s > 1.0) & (np.abs(vc) > 0.95 * A * W)        # mid-stroke, far from reversals
    assert np.allclose(r.following_error_mm[fast, 0], e_f * np.sign(vc[fast]), rtol=0.05)


def test_long_run_crosses_chunks_and_resampling():
    v = np.array([10.0, 0.0, 0.0])
    t, cmd = line_command(v, 10.0, dt=4e-3)          # 40000 steps > one chunk of 32768
    p = ServoParams(kv_1_s=20.0)
    r = simulate_servo(t, cmd, p, initial="steady")
    assert np.allclose(r.following_error_mm[:, 0], 0.5, atol=1e-9)
    assert np.all(np.diff(r.t_s) > 0) and r.t_s[-1] == pytest.approx(10.0)
    out_t = np.linspace(0.0, 10.0, 777)
    s = simulate_servo(t, cmd, p, initial="steady", output_t_s=out_t)
    assert np.allclose(s.t_s, out_t) and np.allclose(s.following_error_mm[:, 0], 0.5, atol=1e-9)
    assert np.allclose(r.at(out_t).pos_mm, s.pos_mm, atol=1e-9)
    m = r.as_measured()
    assert isinstance(m, MeasuredTrace) and m.has_command


def test_parameters_and_checks():
    p = ServoParams.from_compliance(1e-4, kv_1_s=40.0)
    assert p.structure_freq_hz[0] == pytest.approx(1 / (2 * np.pi * 1e-2))
    assert np.allclose(ServoParams(kv_1_s=40.0).equivalent_lag_s, 0.025)
    # holding the end point: with FFWOF the error obeys de/dt = v_c - Kv e, so once the command
    # stands still it decays as exp(-Kv t)
    t = np.arange(0.0, 1.0 + 5e-4, 1e-3)
    x = 10.0 * (t - np.sin(2 * np.pi * t) / (2 * np.pi))           # ends at rest at t = 1
    v = 10.0 * (1 - np.cos(2 * np.pi * t))
    cmd, vel = np.column_stack([x, 0 * t, 0 * t]), np.column_stack([v, 0 * t, 0 * t])
    r = simulate_servo(t, cmd, ServoParams(kv_1_s=20.0), cmd_vel_mm_s=vel, extend_s=0.5)
    assert r.t_s[-1] == pytest.approx(1.5)
    e_end = r.following_error_mm[np.argmin(np.abs(r.t_s - 1.0)), 0]
    assert r.following_error_mm[-1, 0] == pytest.approx(e_end * np.exp(-20.0 * 0.5), rel=1e-4)
    with pytest.raises(UsageError, match="end at rest"):
        simulate_servo(*line_command([1.0, 0, 0], 0.1), ServoParams(), extend_s=0.1)
    t, cmd = line_command([1.0, 0, 0], 0.1)
    with pytest.raises(UsageError, match="integration step"):
        simulate_servo(t, cmd, ServoParams(), dt_s=2e-3)
    with pytest.raises(UsageError, match="too coarse"):
        simulate_servo(t, cmd, ServoParams(velocity_loop_time_s=1e-4), dt_s=1e-3)
    with pytest.raises(UsageError, match="friction"):
        simulate_servo(t, cmd, ServoParams(friction_mm_s2=10.0))
    with pytest.raises(UsageError, match="kv_1_s"):
        ServoParams(kv_1_s=-1.0)
    with pytest.raises(UsageError, match="3 numbers"):
        ServoParams(kv_1_s=(1.0, 2.0))


def accel_limited_moves(speeds, accel, hold_s, dt=1e-3):
    """Axis X command: rest, then moves at the given speeds, each reached with a constant
    acceleration ramp and held for hold_s, back to rest between moves."""
    v = [0.0] * 200
    for V in speeds:
        for target in (V, 0.0):
            cur = v[-1]
            n = int(round(abs(target - cur) / accel / dt))
            v += list(np.linspace(cur, target, n + 1)[1:])
            v += [target] * int(hold_s / dt)
    v = np.array(v)
    t = np.arange(len(v)) * dt
    x = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * dt)])
    return t, x, v


def test_estimate_lag_recovers_one_over_kv_from_coarse_data():
    # truth: FFWOF, Kv = 125 1/s (lag 8 ms); recorded every 100 ms, positions rounded to
    # 3 significant figures like the UMich files. Expected: position lag = 1/Kv = 8 ms; ramp
    # delay -> 1/Kv for ramps much longer than 1/Kv (here 100 ms ramps at 1000 mm/s^2).
    kv = 125.0
    t, x, v = accel_limited_moves([100.0, -100.0] * 6, 1000.0, 0.6)
    cmd = np.column_stack([x + 150.0, 0 * x + 50.0, 0 * x + 20.0])
    vel = np.column_stack([v, 0 * v, 0 * v])
    r = simulate_servo(t, cmd, ServoParams(kv_1_s=kv), cmd_vel_mm_s=vel)
    rng = np.random.default_rng(3)
    tk = np.sort(rng.choice(len(r.t_s) - 2, 400, replace=False)) + 1
    acc_cmd = np.gradient(vel[:, 0], t)
    acc = np.interp(r.t_s[tk], t, acc_cmd)
    tr = MeasuredTrace(
        t_s=r.t_s[tk],
        pos_mm=np.round(r.pos_mm[tk], 0) * [1, 1, 1],
        vel_mm_s=r.drive_vel_mm_s[tk],
        cmd_pos_mm=np.round(r.cmd_pos_mm[tk], 0),
        cmd_vel_mm_s=np.interp(r.t_s[tk], t, v)[:, None] * [1, 0, 0],
        cmd_acc_mm_s2=acc[:, None] * [1, 0, 0])
    # (1 mm rounding: X near 150 mm has 3 significant figures)
    est = estimate_lag(tr, position_step_mm=three_significant_figures_step_mm(tr.cmd_pos_mm))
    assert est.n_moving_samples[0] > 100
    assert abs(est.position_lag_s[0] - 1 / kv) < 3 * est.position_lag_se_s[0] + 5e-4
    assert est.n_ramp_samples[0] >= 5
    assert est.ramp_delay_s[0] == pytest.approx(1 / kv, rel=0.1)
    assert est.kv_if_ffw_off_1_s == pytest.approx(kv, rel=0.3)


def test_three_significant_figures_step():
    assert np.allclose(three_significant_figures_step_mm([150.0, 89.5, 5.25, -120.0]),
                       [1.0, 0.1, 0.01, 1.0])


def test_from_machine(mikron):
    from dataclasses import replace
    from ncsim.machine import StructureSpec
    p = ServoParams.from_machine(mikron)                 # no Kv in the file: the default
    assert p.kv_1_s == (30.0, 30.0, 30.0) and p.ffw_weight == (1.0, 1.0, 1.0)
    assert p.structure_freq_hz[0] == np.inf
    m = replace(mikron, structure=StructureSpec(radial_compliance_mm_per_mm_s2=1.2e-4))
    p = ServoParams.from_machine(m.with_axes(position_gain_1_s=[40, 45, 50]), ffw_weight=0.0)
    assert p.kv_1_s == (40.0, 45.0, 50.0) and p.ffw_weight == (0.0, 0.0, 0.0)
    assert np.allclose(p.compliance_mm_per_mm_s2, 1.2e-4)
