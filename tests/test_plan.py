"""Planner invariants on synthetic limits: feasibility, continuity, look-ahead, optimality.

These tests feed ``plan`` hand-made per-block limits (the ``limits=`` argument), so they test
the feed-law construction alone; the paper's set points are tested through limits.py.
"""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from ruckig import ControlInterface, InputParameter, Result, Ruckig, Trajectory

from ncsim.motion import Limit, ModelOptions, Phase
from ncsim.path import LINE, PathBuilder
from ncsim.plan.lookahead import plan

NO_LOOKAHEAD = ModelOptions(lookahead=False)


def collinear_path(lengths_mm, feed_mm_s=100.0):
    xs = np.concatenate([[0.0], np.cumsum(lengths_mm)])
    n = len(lengths_mm)
    b = PathBuilder()
    zeros = np.zeros(n)
    b.extend(kind=np.full(n, LINE, np.int8), start_mm=np.c_[xs[:-1], zeros, zeros],
             end_mm=np.c_[xs[1:], zeros, zeros], length_mm=np.asarray(lengths_mm, float),
             line=np.arange(1, n + 1), feed_mm_s=feed_mm_s)
    return b.build()


def synthetic_limits(n, cap, jerk, accel, junction_cap=None, dwell=None):
    jcap = np.full(n + 1, np.inf) if junction_cap is None else np.array(junction_cap, float)
    jcap[0] = jcap[-1] = 0.0
    jlim = np.full(n + 1, Limit.NONE, np.int8)
    jlim[np.isfinite(jcap)] = Limit.CORNER
    jlim[[0, -1]] = Limit.PROGRAM_END
    return SimpleNamespace(
        cap_mm_s=np.broadcast_to(np.asarray(cap, float), (n,)).copy(),
        cap_limit=np.zeros(n, np.int8),
        jerk_mm_s3=np.broadcast_to(np.asarray(jerk, float), (n,)).copy(),
        accel_mm_s2=np.broadcast_to(np.asarray(accel, float), (n,)).copy(),
        junction_cap_mm_s=jcap, junction_limit=jlim,
        junction_dwell_s=np.zeros(n + 1) if dwell is None else np.asarray(dwell, float))


def evaluate(motion, t):
    """s, v, a, j at times t from the pieces (independent of ncsim.plan.sample)."""
    k = np.clip(np.searchsorted(motion.piece_t_s, t, side="right") - 1, 0, len(motion.piece_s_mm) - 1)
    tau = t - motion.piece_t_s[k]
    s0, v0, a0, j = (motion.piece_s_mm[k], motion.piece_v_mm_s[k], motion.piece_a_mm_s2[k],
                     motion.piece_j_mm_s3[k])
    return (s0 + tau * (v0 + tau * (a0 / 2 + tau * j / 6)), v0 + tau * (a0 + tau * j / 2),
            a0 + tau * j, j)


def ruckig_rest_to_rest(length, vmax, amax, jmax):
    inp = InputParameter(1)
    inp.current_position, inp.current_velocity, inp.current_acceleration = [0.0], [0.0], [0.0]
    inp.target_position, inp.target_velocity, inp.target_acceleration = [length], [0.0], [0.0]
    inp.max_velocity, inp.max_acceleration, inp.max_jerk = [vmax], [amax], [jmax]
    traj = Trajectory(1)
    assert Ruckig(1).calculate(inp, traj) in (Result.Working, Result.Finished)
    return traj.duration


def assert_feasible(motion, lim, s_junction, tol=1e-6):
    """Every limit holds along the whole law; the law is continuous."""
    t = motion.piece_t_s
    if len(t) < 2:  # nothing moves
        assert s_junction[-1] == 0.0
        return
    # continuity of s, v, a from piece to piece
    dt = np.diff(t)
    s_end = motion.piece_s_mm + dt * (motion.piece_v_mm_s + dt * (motion.piece_a_mm_s2 / 2 + dt * motion.piece_j_mm_s3 / 6))
    v_end = motion.piece_v_mm_s + dt * (motion.piece_a_mm_s2 + dt * motion.piece_j_mm_s3 / 2)
    a_end = motion.piece_a_mm_s2 + dt * motion.piece_j_mm_s3
    np.testing.assert_allclose(s_end[:-1], motion.piece_s_mm[1:], atol=1e-7)
    np.testing.assert_allclose(v_end[:-1], motion.piece_v_mm_s[1:], atol=1e-6)
    np.testing.assert_allclose(a_end[:-1], motion.piece_a_mm_s2[1:], atol=1e-5)
    assert s_end[-1] == pytest.approx(s_junction[-1], abs=1e-6)
    assert abs(v_end[-1]) < 1e-6 and abs(a_end[-1]) < 1e-5
    # dense samples: caps, acceleration and jerk in force
    ts = np.linspace(0, t[-1], 20001)
    s, v, a, j = evaluate(motion, ts)
    n = len(lim.cap_mm_s)
    # a sample on a junction may obey either adjacent block's limits; "on" up to the rounding
    # of s (the last sample lands 1e-14 mm past the end: with a block without motion last, an
    # exact comparison judged the final ramp by that block's limits, about once in 3000 paths)
    right = np.clip(np.searchsorted(s_junction, s + 1e-9, side="right") - 1, 0, n - 1)
    left = np.clip(np.searchsorted(s_junction, s - 1e-9, side="left") - 1, 0, n - 1)

    def allowed(per_block):
        return np.maximum(per_block[right], per_block[left]) * (1 + tol) + 1e-9

    assert np.all(v >= -1e-9)
    assert np.all(v <= allowed(lim.cap_mm_s))
    assert np.all(np.abs(a) <= allowed(motion.accel_mm_s2))
    assert np.all(np.abs(j) <= allowed(motion.jerk_mm_s3))
    assert np.all(motion.jerk_mm_s3 <= lim.jerk_mm_s3 * (1 + 1e-12))
    assert np.all(motion.accel_mm_s2 <= lim.accel_mm_s2 * (1 + 1e-12))
    # junction crossing feeds
    assert np.all(motion.v_junction_mm_s <= np.minimum(motion.junction_cap_mm_s, np.inf) * (1 + tol) + 1e-9)
    assert np.all(np.diff(motion.t_start_s) >= -1e-12)


def test_rest_to_rest_line_equals_ruckig(mikron):
    p = collinear_path([100.0])
    mo = plan(p, mikron, NO_LOOKAHEAD, limits=synthetic_limits(1, 100.0, 5000.0, 2500.0))
    assert mo.total_time_s == pytest.approx(ruckig_rest_to_rest(100.0, 100.0, 2500.0, 5000.0), rel=1e-9)
    assert list(mo.piece_phase) == [Phase.A, Phase.A, Phase.B, Phase.C, Phase.C]


def test_many_collinear_blocks_form_one_section(mikron):
    """Ramps run across short blocks with a common set point (no zero-acceleration crawl)."""
    p = collinear_path(np.full(1000, 0.1))
    mo = plan(p, mikron, NO_LOOKAHEAD, limits=synthetic_limits(1000, 100.0, 5000.0, 2500.0))
    assert mo.total_time_s == pytest.approx(ruckig_rest_to_rest(100.0, 100.0, 2500.0, 5000.0), rel=1e-9)
    assert mo.knot.sum() == 2
    assert np.all(np.diff(mo.t_end_s) > 0)


def test_corner_is_a_zero_acceleration_knot(mikron):
    p = collinear_path([50.0, 50.0])
    jc = np.array([0.0, 20.0, 0.0])
    mo = plan(p, mikron, NO_LOOKAHEAD, limits=synthetic_limits(2, 100.0, 5000.0, 2500.0, jc))
    assert mo.v_junction_mm_s[1] == pytest.approx(20.0)
    assert mo.a_junction_mm_s2[1] == 0.0
    assert mo.knot[1]
    assert_feasible(mo, synthetic_limits(2, 100.0, 5000.0, 2500.0, jc), np.array([0, 50, 100.0]))


@settings(max_examples=40, deadline=None)
@given(st.integers(2, 60), st.integers(0, 2**31 - 1), st.booleans())
def test_random_programs_respect_every_limit(n, seed, lookahead):
    from ncsim.machine import load_machine

    rng = np.random.default_rng(seed)
    lengths = rng.choice([0.05, 0.3, 2.0, 15.0], size=n) * rng.uniform(0.5, 1.5, n)
    lengths[rng.random(n) < 0.05] = 0.0  # blocks without motion
    cap = rng.choice([30.0, 80.0, 150.0], n) * rng.uniform(0.8, 1.0, n)
    jerk = rng.choice([2000.0, 5000.0, 50000.0], n)
    accel = rng.choice([300.0, 2500.0], n)
    jc = np.where(rng.random(n + 1) < 0.3, rng.uniform(0, 120, n + 1), np.inf)
    jc[rng.random(n + 1) < 0.05] = 0.0
    lim = synthetic_limits(n, cap, jerk, accel, jc)
    machine = load_machine("mikron").with_ncu(lookahead_blocks=int(rng.integers(1, 6)))
    p = collinear_path(lengths)
    mo = plan(p, machine, ModelOptions(lookahead=lookahead), limits=lim)
    s_j = np.concatenate([[0.0], np.cumsum(lengths)])
    lim_after = SimpleNamespace(**{**vars(lim), "cap_mm_s": mo.cap_mm_s})
    assert_feasible(mo, lim_after, s_j)
    assert np.all(mo.cap_mm_s <= np.where(lengths > 0, cap, np.inf) * (1 + 1e-12))


def stopping_distance(v, a, amax, jmax):
    """Shortest distance to rest from (v, a), by ruckig's velocity interface."""
    inp = InputParameter(1)
    inp.control_interface = ControlInterface.Velocity
    inp.current_position, inp.current_velocity, inp.current_acceleration = [0.0], [v], [a]
    inp.target_velocity, inp.target_acceleration = [0.0], [0.0]
    inp.max_velocity, inp.max_acceleration, inp.max_jerk = [1e9], [amax], [jmax]
    traj = Trajectory(1)
    assert Ruckig(1).calculate(inp, traj) in (Result.Working, Result.Finished)
    return traj.at_time(traj.duration)[0][0]


@pytest.mark.parametrize("depth", [1, 3, 10])
def test_deceleration_never_cut_short_by_the_lookahead_window(mikron, depth):
    """At every junction the tool can stop before the end of the prepared blocks."""
    lengths = np.full(40, 5.0)
    machine = mikron.with_ncu(lookahead_blocks=depth)
    lim = synthetic_limits(40, 300.0, 5000.0, 2500.0)
    mo = plan(collinear_path(lengths), machine, ModelOptions(lookahead=True), limits=lim)
    s_j = np.concatenate([[0.0], np.cumsum(lengths)])
    for k in range(len(lengths)):
        # junction k is crossed while block k-1 runs, with blocks up to k-1+depth prepared
        window_end = s_j[min(k + depth, len(lengths))]
        d = stopping_distance(mo.v_junction_mm_s[k], mo.a_junction_mm_s2[k], 2500.0, 5000.0)
        assert d <= window_end - s_j[k] + 1e-6
    lim_after = SimpleNamespace(**{**vars(lim), "cap_mm_s": mo.cap_mm_s})
    assert_feasible(mo, lim_after, s_j)


def test_short_lookahead_gives_a_sawtooth_and_costs_time(mikron):
    lengths = np.full(30, 10.0)
    lim = synthetic_limits(30, 300.0, 5000.0, 2500.0)
    short = plan(collinear_path(lengths), mikron.with_ncu(lookahead_blocks=1), ModelOptions(), limits=lim)
    long_ = plan(collinear_path(lengths), mikron.with_ncu(lookahead_blocks=50), ModelOptions(), limits=lim)
    assert short.total_time_s > 1.2 * long_.total_time_s
    inner = short.v_junction_mm_s[5:25]
    peaks = short.feed_max_mm_s[5:25]
    assert np.all(peaks > inner * 1.01)               # the feed rises inside every block ...
    assert np.allclose(inner, inner.mean(), rtol=1e-6)  # ... and falls back at each junction
    assert (short.cap_limit[5:25] == Limit.LOOKAHEAD).all()


def test_dwell_is_standstill_time(mikron):
    lengths = np.array([10.0, 10.0])
    dwell = np.array([0.0, 0.5, 0.0])
    jc = np.array([0.0, 0.0, 0.0])
    lim = synthetic_limits(2, 100.0, 5000.0, 2500.0, jc, dwell)
    mo = plan(collinear_path(lengths), mikron, NO_LOOKAHEAD, limits=lim)
    one = ruckig_rest_to_rest(10.0, 100.0, 2500.0, 5000.0)
    assert mo.total_time_s == pytest.approx(2 * one + 0.5, rel=1e-9)
    assert mo.t_start_s[1] - mo.t_end_s[0] == pytest.approx(0.5)
    assert Phase.STOP in set(mo.piece_phase)


@settings(max_examples=200, deadline=None)
@given(st.floats(0.0, 300.0), st.floats(-1.0, 1.0), st.floats(500.0, 50000.0), st.floats(100.0, 5000.0))
def test_stopping_distance_matches_ruckig(v, a_share, jerk, accel):
    from ncsim.plan.lookahead import stopping_distance_mm

    a = a_share * accel
    if a < 0 and v - a * a / (2 * jerk) < 0:
        return  # the feed would reverse before the deceleration is undone: not a path state
    ours = float(stopping_distance_mm(v, a, jerk, accel))
    assert ours == pytest.approx(stopping_distance(v, a, accel, jerk), rel=1e-6, abs=1e-7)


@settings(max_examples=200, deadline=None)
@given(st.floats(0.0, 300.0), st.floats(-1.0, 1.0), st.floats(500.0, 50000.0), st.floats(100.0, 5000.0))
def test_stopping_distance_scalar_twin(v, a_share, jerk, accel):
    from ncsim.plan._kernels import stopping_distance_scalar
    from ncsim.plan.lookahead import stopping_distance_mm

    a = a_share * accel
    assert stopping_distance_scalar(v, a, jerk, accel) == pytest.approx(
        float(stopping_distance_mm(v, a, jerk, accel)), rel=1e-12, abs=1e-12)


@settings(max_examples=100, deadline=None)
@given(st.integers(0, 40), st.integers(0, 12), st.integers(0, 2**32 - 1))
def test_lookahead_caps_equal_window_slicing(n, depth, seed):
    """The compiled look-ahead (monotone-queue window minima) against slicing and the
    vectorised ramp reach of ncsim.plan.ramps: caps, and which ones the look-ahead lowered."""
    from ncsim.plan._kernels import lookahead_caps
    from ncsim.plan.ramps import ramp_reach_mm_s

    rng = np.random.default_rng(seed)
    s = np.concatenate([[0.0], np.cumsum(rng.uniform(0.0, 5.0, n))])
    jerk = rng.choice([1000.0, 5000.0, 7000.0], n)     # ties in the windows on purpose
    accel = rng.choice([500.0, 2500.0], n)
    cap = rng.uniform(10.0, 500.0, n)
    jcap = np.append(rng.uniform(10.0, 500.0, n), 0.0)
    cap_limit = np.zeros(n, np.int8)
    jlimit = np.zeros(n + 1, np.int8)
    want_cap, want_jcap = cap.copy(), jcap.copy()
    for k in range(n - depth - 1):
        e = k + depth + 1
        jw, aw = jerk[k:e].min(), accel[k:e].min()
        want_cap[k] = min(cap[k], float(ramp_reach_mm_s(0.0, s[e] - s[k], jw, aw)))
        want_jcap[k + 1] = min(jcap[k + 1], float(ramp_reach_mm_s(0.0, s[e] - s[k + 1], jw, aw)))
    lowered, jlowered = want_cap < cap, want_jcap < jcap
    lookahead_caps(cap, cap_limit, jcap, jlimit, s, jerk, accel, depth, int(Limit.LOOKAHEAD))
    np.testing.assert_allclose(cap, want_cap, rtol=1e-12)
    np.testing.assert_allclose(jcap, want_jcap, rtol=1e-12)
    np.testing.assert_array_equal(cap_limit == Limit.LOOKAHEAD, lowered)
    np.testing.assert_array_equal(jlimit == Limit.LOOKAHEAD, jlowered)


@settings(max_examples=100, deadline=None)
@given(st.lists(st.floats(-1e6, 1e6), min_size=0, max_size=60), st.integers(1, 12))
def test_window_min_equals_slicing(values, width):
    from ncsim.plan.lookahead import window_min

    x = np.array(values, dtype=float)
    expected = np.array([x[k:k + width].min() for k in range(len(x))])
    np.testing.assert_array_equal(window_min(x, width), expected)


def test_blocks_without_motion_at_the_end_never_start_early(mikron):
    """Two blocks without motion after the last one: the junction between them lies at the
    same s as the knot before it, where inverting s(t) near rest is off by microseconds. Its
    time stays between the knots' (a block once started 1.5 us before the one ahead ended;
    hypothesis found it about twice in 3000 random paths)."""
    lengths = np.array([1.9616899144, 1.8560661862, 0.03442857, 0.0, 0.0])
    cap = np.array([28.2332053596, 27.3294682111, 25.4938585707, 64.7771196532, 131.9297303226])
    lim = synthetic_limits(5, cap, [5000.0, 2000.0, 50000.0, 5000.0, 2000.0],
                           [2500.0, 300.0, 2500.0, 300.0, 2500.0],
                           [0.0, np.inf, np.inf, 0.0, 75.4202363878, 0.0])
    mo = plan(collinear_path(lengths), mikron, NO_LOOKAHEAD, limits=lim)
    assert np.all(np.diff(mo.t_start_s) >= 0.0) and np.all(mo.duration_s >= 0.0)
    assert mo.t_end_s[-1] == mo.total_time_s
    lim_after = SimpleNamespace(**{**vars(lim), "cap_mm_s": mo.cap_mm_s})
    assert_feasible(mo, lim_after, np.concatenate([[0.0], np.cumsum(lengths)]))


def test_a_block_without_motion_before_a_dwell_has_no_negative_duration(mikron):
    """A block without motion just before a dwell (G4 after a move that rounds to nothing):
    the junction between them is reached when the tool arrives, not after the dwell (a block
    once lasted -0.1 s, the dwell)."""
    lengths = np.array([4.6, 0.0, 0.0, 8.0])
    dwell = np.zeros(5)
    dwell[3] = 0.1
    jcap = [0.0, 0.0, np.inf, 0.0, 0.0]   # stops around the two blocks, none between them
    lim = synthetic_limits(4, 40.0, 5000.0, 2500.0, jcap, dwell=dwell)
    mo = plan(collinear_path(lengths), mikron, NO_LOOKAHEAD, limits=lim)
    assert np.all(mo.duration_s >= 0.0), mo.duration_s
    assert np.all(np.diff(mo.t_start_s) >= 0.0)
    assert mo.t_start_s[3] - mo.t_end_s[2] == pytest.approx(0.1)   # the dwell, where it belongs


@pytest.mark.parametrize("seed", range(12))
def test_inner_states_equal_the_states_read_off_the_pieces(seed):
    """The braking check's junction states, computed section by section without building the
    pieces, are those junction_states reads off the full piece list (to rounding: durations
    come from section-local times)."""
    from ncsim.plan import lookahead as la

    rng = np.random.default_rng(seed)
    n = 400
    lengths = rng.choice([0.05, 0.3, 2.0, 15.0], size=n) * rng.uniform(0.5, 1.5, n)
    s_j = np.concatenate([[0.0], np.cumsum(lengths)])
    cap = rng.choice([30.0, 80.0, 150.0], n)
    jerk = rng.choice([2000.0, 5000.0, 50000.0], n)
    accel = rng.choice([300.0, 2500.0], n)
    p = np.where(rng.random(n + 1) < 0.3, rng.uniform(0, 120, n + 1), np.inf)
    p[[0, n]] = 0.0
    knots = np.unique(np.concatenate([[0, n], rng.choice(n, 60)]))
    blocks = la._Blocks(jerk, accel, lengths, s_j)
    sol = la._solve_knots(knots, np.minimum(p, np.append(cap, np.inf)), cap, blocks)
    zeros = np.zeros(n + 1, dtype=np.int8)
    _, _, v_ref, a_ref = la._pieces_and_junctions(sol, s_j, zeros, zeros, zeros,
                                                  np.zeros(n + 1))
    v_j, a_j = la._inner_states(sol, s_j)
    np.testing.assert_allclose(v_j, v_ref, rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(a_j, a_ref, rtol=1e-9, atol=1e-6)
    assert np.count_nonzero(a_ref) > 20            # states inside ramps are compared
