"""Alignment of measured traces to a simulated one (time shift, zero offset, path parameter).

The "simulation" here is built by hand (no planner): a line then a full circle, driven by a
smooth feed law with phases A/B/C, sampled at 1 ms. The "measured" traces are degraded copies
(ncsim.gap.truth.synth) whose true simulated instant is known, so every expected value is exact.
"""
from __future__ import annotations

import numpy as np
import pytest

from ncsim.gap.align import AlignPhase, align, motion_onset_s, xcorr_shift_s
from ncsim.errors import UsageError
from ncsim.gap.measured import MeasuredTrace
from ncsim.gap.truth.synth import ScopeConfig, degrade

R = 30.0      # circle radius
L0 = 10.0     # line length before the circle


def feed_law(L, V, ramp_s, dt=1e-3, rest_s=0.2, dwell_at_mm=None, dwell_s=0.0):
    """s(t) with raised-cosine ramps of ramp_s (phases A, C), steady V (B), rest at both ends
    (STOP), and optionally a standstill of dwell_s at path length dwell_at_mm."""
    s_ramp = 0.5 * V * ramp_s
    t_b = (L - 2 * s_ramp) / V
    T = 2 * rest_s + 2 * ramp_s + t_b + dwell_s
    t = np.arange(0.0, T + dt / 2, dt)
    x = t - rest_s
    v = np.zeros_like(t)
    phase = np.full(len(t), 3)
    up = (x >= 0) & (x < ramp_s)
    st = (x >= ramp_s) & (x < ramp_s + t_b + dwell_s)
    dn = (x >= ramp_s + t_b + dwell_s) & (x < 2 * ramp_s + t_b + dwell_s)
    v[up] = 0.5 * V * (1 - np.cos(np.pi * x[up] / ramp_s))
    v[st] = V
    v[dn] = 0.5 * V * (1 + np.cos(np.pi * (x[dn] - ramp_s - t_b - dwell_s) / ramp_s))
    phase[up], phase[st], phase[dn] = 0, 1, 2
    s = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * dt)])
    if dwell_at_mm is not None:
        # stand still at dwell_at_mm for dwell_s, then go on
        i = int(np.searchsorted(s, dwell_at_mm))
        k = int(round(dwell_s / dt))
        s = np.concatenate([s[:i], np.full(k, s[i]), s[i:len(s) - k]])
        v = np.concatenate([v[:i], np.zeros(k), v[i:len(v) - k]])
        phase = np.concatenate([phase[:i], np.full(k, 3), phase[i:len(phase) - k]])
    s = np.minimum(s * L / s[-1], L) if dwell_at_mm is None else np.minimum(s, L)
    return t, s, v, phase


def path_pos(s, grow_mm=0.0):
    """Line along +Y ending at (R, 0), then a full CCW circle of radius R (+ grow_mm)."""
    p = np.zeros((len(s), 3))
    ln = s < L0
    p[ln, 0] = R
    p[ln, 1] = s[ln] - L0
    a = (s[~ln] - L0) / R
    p[~ln, 0] = (R + grow_mm) * np.cos(a)
    p[~ln, 1] = (R + grow_mm) * np.sin(a)
    return p


def sim(V=150.0, ramp_s=0.1, **kw):
    L = L0 + 2 * np.pi * R
    t, s, v, phase = feed_law(L, V, ramp_s, **kw)
    return dict(t=t, s=s, v=v, phase=phase, pos=path_pos(s), block=(s >= L0).astype(int))


def run_align(S, tr, **kw):
    return align(tr, S["pos"], S["t"], S["s"], sim_block=S["block"], sim_phase=S["phase"],
                 sim_feed_mm_s=S["v"], **kw)


SCOPE = ScopeConfig(period_s=4e-3, noise_um=2.0, quant_um=1.0, time_offset_s=1.234,
                    pos_offset_mm=(0.5, -0.2, 0.1), dropout_fraction=0.05, dropout_burst=3)


def test_identical_motion_is_recovered_exactly():
    S = sim()
    tr = degrade(S["t"], S["pos"], SCOPE, seed=7, vel_mm_s=None)
    al = run_align(S, tr)
    assert al.shift_method == "onset" and al.offset_method == "start"
    # onset timing noise: speed noise (~0.2 mm/s) over the speed slope at the threshold
    assert al.time_shift_s == pytest.approx(1.234, abs=1e-3)
    assert np.allclose(al.offset_mm, [0.5, -0.2, 0.1], atol=2e-3)
    true_s = np.interp(tr.extra["truth_t_s"], S["t"], S["s"])
    assert np.max(np.abs(al.s_mm - true_s)) < 0.02          # noise 2 um + offset error
    assert np.all(np.diff(al.s_mm) >= 0)
    # at rest the place does not tell the time (a sample within the noise of a standstill is
    # taken as standing there): time errors are checked where the simulation moves
    moving = np.interp(tr.extra["truth_t_s"], S["t"], S["v"]) > 20.0
    assert np.max(np.abs(al.time_error_s[moving])) < 1e-3
    assert np.max(al.distance_mm) < 0.02
    assert al.valid.all()
    # labels: compare with the simulation at the true instant, away from the junction
    true_block = np.interp(tr.extra["truth_t_s"], S["t"], S["block"]).round()
    assert np.mean(al.block == true_block) > 0.99
    true_phase = S["phase"][np.searchsorted(S["t"], tr.extra["truth_t_s"]).clip(0, len(S["t"]) - 1)]
    plain = al.phase != AlignPhase.TRANSITION
    assert np.mean(al.phase[plain] == true_phase[plain]) > 0.97
    # the flying junction line -> circle at s = L0 is labelled TRANSITION within +-12 ms
    t_junction = S["t"][np.argmax(S["s"] >= L0)]
    trans = al.phase == AlignPhase.TRANSITION
    assert trans.any() and np.all(np.abs(al.t_sim_s[trans] - t_junction) <= 0.012 + 1e-9)


def test_xcorr_when_the_recording_starts_in_motion():
    S = sim()
    cfg = ScopeConfig(period_s=8e-3, noise_um=3.0, time_offset_s=-2.5, pos_offset_mm=(0, 0, 0.3))
    tr = degrade(S["t"], S["pos"], cfg, seed=3)
    late = tr.extra["truth_t_s"] > 0.5                            # the recorder started late
    tr = tr.select(late)
    al = run_align(S, tr)
    assert al.shift_method == "xcorr" and al.offset_method == "lsq"
    assert al.time_shift_s == pytest.approx(-2.5, abs=1e-3)
    assert np.allclose(al.offset_mm, [0, 0, 0.3], atol=5e-3)
    true_s = np.interp(tr.extra["truth_t_s"], S["t"], S["s"])
    assert np.max(np.abs(al.s_mm - true_s)) < 0.05


def test_a_slower_machine_shows_growing_time_error():
    # the machine's steady feed is 10 % lower: same path, same ramps. On the circle (block 1)
    # the extra time is (length at steady feed) (1/0.9V - 1/V); time errors grow along the path
    V = 150.0
    S = sim(V=V)
    M = sim(V=0.9 * V)
    tr = degrade(M["t"], M["pos"], ScopeConfig(period_s=2e-3, noise_um=1.0, time_offset_s=0.5),
                 seed=11)
    al = run_align(S, tr)
    assert al.time_shift_s == pytest.approx(0.5, abs=1e-3)         # same onset
    L = L0 + 2 * np.pi * R
    total_extra = (M["t"][-1] - S["t"][-1])
    assert al.time_error_s[-1] == pytest.approx(total_extra, abs=5e-3)
    summary = al.block_summary()
    assert list(summary["block"]) == [0, 1]
    assert np.all(summary["duration_error_s"] > 0)
    # feed error in the steady phase of the circle: -0.1 V
    steady = (al.block == 1) & (al.phase == AlignPhase.B)
    assert np.median(al.feed_error_mm_s[steady]) == pytest.approx(-0.1 * V, rel=0.05)
    # the place, not the clock, is matched: s follows the machine's own law
    true_s = np.interp(tr.extra["truth_t_s"], M["t"], M["s"])
    assert np.max(np.abs(al.s_mm - true_s)) < 0.01
    assert L == pytest.approx(S["s"][-1])


def test_contour_error_on_the_circle():
    # the machine's circle is 50 um larger: distance to the simulated path is 50 um there
    S = sim()
    grown = path_pos(S["s"], grow_mm=0.050)
    tr = degrade(S["t"], grown, ScopeConfig(period_s=1e-3), seed=5)
    al = run_align(S, tr)
    on_circle = (al.block == 1) & (al.s_mm > L0 + 1.0) & (al.s_mm < al.s_mm.max() - 1.0)
    assert np.allclose(al.distance_mm[on_circle], 0.050, atol=1e-3)
    radial = np.sum(al.deviation_mm[on_circle, :2] * tr.pos_mm[on_circle, :2], axis=1) / R
    assert np.all(radial > 0.049)


def test_dwell_keeps_time_error_flat_and_s_monotone():
    S = sim(dwell_at_mm=L0 + 20.0, dwell_s=0.3)
    tr = degrade(S["t"], S["pos"], ScopeConfig(period_s=2e-3, noise_um=2.0, time_offset_s=3.0),
                 seed=2)
    al = run_align(S, tr)
    assert np.all(np.diff(al.s_mm) >= 0)
    moving = np.interp(tr.extra["truth_t_s"], S["t"], S["v"]) > 20.0
    assert np.max(np.abs(al.time_error_s[moving])) < 1e-3
    assert np.max(np.abs(al.time_error_s)) < 0.01        # the start of the ramp, see above
    s_dwell = S["s"][np.argmax(S["s"] >= L0 + 20.0)]
    in_dwell = np.abs(al.s_mm - s_dwell) < 1e-3
    assert np.count_nonzero(in_dwell) > 100
    assert np.all(al.phase[in_dwell][5:-5] == AlignPhase.STOP)


def test_given_shift_and_offset_and_command_alignment():
    S = sim()
    cfg = ScopeConfig(period_s=4e-3, time_offset_s=0.7, record_command=True,
                      pos_offset_mm=(1.0, 2.0, 3.0))
    tr = degrade(S["t"], S["pos"], cfg, seed=9, cmd_pos_mm=S["pos"])
    al = run_align(S, tr, time_shift_s=0.7, offset_mm=(1.0, 2.0, 3.0), use_command=True)
    assert al.shift_method == "given" and al.offset_method == "given"
    assert np.max(al.distance_mm) < 1e-6


def test_recording_breaks_restart_the_matching():
    S = sim()
    tr = degrade(S["t"], S["pos"], ScopeConfig(period_s=4e-3), seed=4)
    keep = (tr.extra["truth_t_s"] < 0.6) | (tr.extra["truth_t_s"] > 1.2)
    seg = (tr.extra["truth_t_s"][keep] > 1.2).astype(int)
    cut = MeasuredTrace(t_s=tr.t_s[keep], pos_mm=tr.pos_mm[keep], segment=seg,
                        extra={"truth_t_s": tr.extra["truth_t_s"][keep]})
    al = run_align(S, cut, time_shift_s=0.0, offset_mm=(0, 0, 0))
    true_s = np.interp(cut.extra["truth_t_s"], S["t"], S["s"])
    assert np.max(np.abs(al.s_mm - true_s)) < 1e-3


def test_pieces():
    t = np.arange(0, 1, 0.01)
    v = np.where(t > 0.305, 10.0, 0.0)
    assert motion_onset_s(t, v, 5.0) == pytest.approx(0.305, abs=0.01)
    assert motion_onset_s(t, v + 10, 5.0) is None
    v = np.exp(-((t - 0.4) / 0.05) ** 2)
    assert xcorr_shift_s(t + 0.123, v, t, v, 0.01, 1.0) == pytest.approx(0.123, abs=2e-3)
    S = sim()
    with pytest.raises(UsageError):
        align(MeasuredTrace(t_s=[0, 1], pos_mm=np.zeros((2, 3))), S["pos"], S["t"][::-1], S["s"])


def test_servo_truth_end_to_end():
    # truth from the time-stepping servo (FFWOF, Kv = 40 1/s), recorded with a 3.7 s clock
    # offset. On the steady part of the circle the actual radius is R / sqrt(1 + (W/Kv)^2), so
    # the contour distance to the simulated circle is R (1 - 1/sqrt(1 + (W/Kv)^2)) = 0.2314 mm.
    from ncsim.gap.truth.servo import ServoParams, simulate_servo
    V, kv = 150.0, 40.0
    S = sim(V=V)
    r = simulate_servo(S["t"], S["pos"], ServoParams(kv_1_s=kv))
    tr = degrade(r.t_s, r.pos_mm, ScopeConfig(period_s=3e-3, noise_um=1.0, time_offset_s=3.7,
                                              pos_offset_mm=(0.2, 0.0, 0.0)), seed=8)
    expected = R * (1 - 1 / np.sqrt(1 + (V / R / kv) ** 2))
    for method in ("auto", "xcorr"):
        al = run_align(S, tr, shift_method=method)
        assert al.time_shift_s == pytest.approx(3.7, abs=0.05)          # plus the servo lag
        steady = (al.block == 1) & (al.phase == AlignPhase.B) & (al.t_sim_s > 0.5)
        steady &= al.t_sim_s < S["t"][S["phase"] == 1].max() - 0.02
        assert np.count_nonzero(steady) > 100
        assert np.allclose(al.distance_mm[steady], expected, atol=5e-3)


def test_align_trace_reads_the_trace_columns():
    from ncsim.gap.align import align_trace
    from ncsim.motion import Trace
    S = sim()
    n = len(S["t"])
    z = np.zeros(n)
    z3 = np.zeros((n, 3))
    tr = Trace(t_s=S["t"], s_mm=S["s"], feed_mm_s=S["v"], accel_t_mm_s2=z, jerk_t_mm_s3=z,
               accel_n_mm_s2=z, jerk_n_mm_s3=z, pos_mm=S["pos"], vel_mm_s=z3, acc_mm_s2=z3,
               jerk_mm_s3=z3, block=S["block"].astype(np.int32), line=z.astype(np.int32),
               limit=z.astype(np.int8), phase=S["phase"].astype(np.int8), setpoint_mm_s=z,
               programmed_mm_s=z)
    meas = degrade(S["t"], S["pos"], ScopeConfig(period_s=6e-3, time_offset_s=0.3), seed=1)
    a = align_trace(meas, tr)
    b = run_align(S, meas)
    assert np.array_equal(a.s_mm, b.s_mm) and np.array_equal(a.phase, b.phase)


def test_full_circle_start_equals_end():
    # a closed path visits its start twice: the clock prior must pick the start, not the end
    V = 100.0
    L = 2 * np.pi * R
    t, s, v, phase = feed_law(L, V, 0.1, rest_s=0.0)   # at rest only at the first instant
    a = s / R
    pos = np.column_stack([R * np.cos(a), R * np.sin(a), 0 * a])
    tr = degrade(t, pos, ScopeConfig(period_s=4e-3, noise_um=2.0, time_offset_s=0.4), seed=6)
    al = align(tr, pos, t, s, sim_phase=phase, sim_feed_mm_s=v)
    true_s = np.interp(tr.extra["truth_t_s"], t, s)
    assert al.s_mm[0] < 0.01 and al.s_mm[-1] > L - 0.01
    assert np.max(np.abs(al.s_mm - true_s)) < 0.02


def test_clock_prior_tells_twice_visited_places_apart():
    from ncsim.gap.align import project_on_path
    a = np.linspace(0, 2 * np.pi, 2001)
    pts = np.column_stack([R * np.cos(a), R * np.sin(a), 0 * a])
    s = R * a
    t = a / 5.0
    q = np.array([[R + 1e-3, 0.0, 0.0]])                     # at the start = the end
    for prior, expected in ((0.5, 0.0), (s[-1] - 0.5, s[-1])):
        j, u = project_on_path(q, pts, s, t, [0.0], [prior], [True], [0.0], 200.0, 0.01,
                               1000.0, 1e-4, 0.05, 21.0)
        j1 = min(j[0] + 1, len(s) - 1)
        assert s[j[0]] + u[0] * (s[j1] - s[j[0]]) == pytest.approx(expected, abs=1e-6)


def test_start_offset_without_a_rest_lead_in():
    """The recording starts with the motion (no rest before it): the samples before the onset
    threshold have already moved (J t^3/6 with a jerk-limited start), so the zero offset is
    taken against the simulated start motion at the aligned instants, not its start point."""
    dt = 1e-3
    J = 5000.0                                  # jerk-limited start along +X, then cruise
    t = np.arange(0.0, 0.6, dt)
    v = np.where(t < 0.1, J * t ** 2 / 2, np.where(t < 0.2, 50 - J * (0.2 - t) ** 2 / 2, 50.0))
    s = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * dt)])
    pos = np.column_stack([s, 0 * s, 0 * s])
    off = np.array([1.0, 2.0, 3.0])
    meas = MeasuredTrace(t_s=t + 0.3, pos_mm=pos + off)
    al = align(meas, pos, t, s, sim_feed_mm_s=v)
    assert al.offset_method == "start"
    assert np.allclose(al.offset_mm, off, atol=2e-5)
    assert abs(al.time_shift_s - 0.3) < 1e-4
