"""Sampling a Motion into a Trace (ncsim.plan.sample).

Motions are built by hand from closed-form jerk-limited profiles; expected values come from
ruckig (the same rest-to-rest problem), closed forms on circles/helices and finite differences
of the sampled positions -- never from the sampler itself.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
import ruckig

from ncsim.errors import UsageError
from ncsim.motion import FULL_MODEL, Limit, Motion, Phase
from ncsim.path import PathBuilder
from ncsim.plan.sample import block_table, sample_motion, time_grid_s


# ---------------------------------------------------------------------------------------------
# Hand-built motions
# ---------------------------------------------------------------------------------------------

def rest_to_rest(length, v_max, a_max, j_max):
    """Closed-form time-optimal rest-to-rest profile: 7 constant-jerk phases (durations, jerks)."""
    def ramp(v):
        if v * j_max >= a_max * a_max:
            return a_max / j_max, v / a_max - a_max / j_max
        return math.sqrt(v / j_max), 0.0

    t1, t2 = ramp(v_max)
    d_ramp = v_max * (2 * t1 + t2) / 2
    if 2 * d_ramp <= length:
        t4 = (length - 2 * d_ramp) / v_max
    else:  # the feed never reaches v_max: peak from the ramp-distance equation
        t4 = 0.0
        vp = (length * length * j_max / 4) ** (1 / 3)
        if vp * j_max > a_max * a_max:
            vp = a_max / 2 * (-a_max / j_max + math.sqrt((a_max / j_max) ** 2 + 4 * length / a_max))
        t1, t2 = ramp(vp)
    durations = [t1, t2, t1, t4, t1, t2, t1]
    jerks = [j_max, 0, -j_max, 0, -j_max, 0, j_max]
    phases = [Phase.A] * 3 + [Phase.B] + [Phase.C] * 3
    return durations, jerks, phases


def integrate_pieces(durations, jerks, s0=0.0, v0=0.0, a0=0.0):
    """Start states of constant-jerk pieces (test-side integrator) and their start times."""
    t, s, v, a = [0.0], [], [], []
    for d, j in zip(durations, jerks):
        s.append(s0), v.append(v0), a.append(a0)
        s0 += v0 * d + a0 * d * d / 2 + j * d ** 3 / 6
        v0 += a0 * d + j * d * d / 2
        a0 += j * d
        t.append(t[-1] + d)
    return np.array(t), np.array(s), np.array(v), np.array(a)


def make_motion(machine, path, durations, jerks, phases, limits, *, t_start, t_end,
                cap, cap_limit, jerk, accel, v0=0.0, a0=0.0, feed=None):
    """A Motion over ``path`` whose feed law is the given constant-jerk pieces from rest (or
    from feed ``v0`` and acceleration ``a0``); junction states are evaluated at the given
    block times."""
    n = path.n
    if feed is not None:
        path = path.replace_columns(feed_mm_s=feed)
    t, s, v, a = integrate_pieces(durations, jerks, v0=v0, a0=a0)
    j = np.asarray(jerks, dtype=float)

    def state(tt):
        k = min(max(np.searchsorted(t, tt, side="right") - 1, 0), len(durations) - 1)
        tau = tt - t[k]
        return v[k] + a[k] * tau + j[k] * tau * tau / 2, a[k] + j[k] * tau

    jt = [t_start[0]] + list(t_end)
    vj, aj = zip(*(state(x) for x in jt))
    arr = lambda x, dt=float: np.asarray(x, dtype=dt)  # noqa: E731
    return Motion(
        path=path, machine=machine, options=FULL_MODEL,
        cap_mm_s=arr(np.broadcast_to(cap, n)), cap_limit=arr(np.broadcast_to(cap_limit, n), np.int8),
        jerk_mm_s3=arr(np.broadcast_to(jerk, n)), accel_mm_s2=arr(np.broadcast_to(accel, n)),
        t_start_s=arr(t_start), t_end_s=arr(t_end), feed_max_mm_s=arr(np.broadcast_to(cap, n)),
        junction_cap_mm_s=np.zeros(n + 1), junction_limit=np.zeros(n + 1, np.int8),
        junction_dwell_s=np.zeros(n + 1), v_junction_mm_s=arr(vj), a_junction_mm_s2=arr(aj),
        knot=np.ones(n + 1, bool), piece_t_s=t, piece_s_mm=s, piece_v_mm_s=v, piece_a_mm_s2=a,
        piece_j_mm_s3=j, piece_phase=arr(phases, np.int8), piece_limit=arr(limits, np.int8))


def single_block_motion(machine, path, v_max, a_max, j_max, limit=Limit.PROGRAMMED):
    d, j, ph = rest_to_rest(path.total_length_mm, v_max, a_max, j_max)
    lim = [Limit.PROGRAM_END] * 3 + [limit] + [Limit.PROGRAM_END] * 3
    return make_motion(machine, path, d, j, ph, lim, t_start=[0.0], t_end=[sum(d)],
                       cap=v_max, cap_limit=limit, jerk=j_max, accel=a_max)


def circle_path(radius, feed, helix_mm=0.0, turns=1.0):
    b = PathBuilder()
    start = np.array([radius, 0.0, 0.0])
    sweep = 2 * math.pi * turns
    end = np.array([radius * math.cos(sweep), radius * math.sin(sweep), helix_mm])
    b.add_arc(start, end, [0, 0, 0], [0, 0, 1], radius, sweep, helix_mm, line=7, feed_mm_s=feed)
    return b.build()


def line_path(points, feed=100.0):
    b = PathBuilder()
    for i, (p, q) in enumerate(zip(points[:-1], points[1:])):
        b.add_line(p, q, line=10 * (i + 1), feed_mm_s=feed)
    return b.build()


def ruckig_rest_to_rest(length, v_max, a_max, j_max):
    inp = ruckig.InputParameter(1)
    inp.current_position, inp.current_velocity, inp.current_acceleration = [0.0], [0.0], [0.0]
    inp.target_position, inp.target_velocity, inp.target_acceleration = [length], [0.0], [0.0]
    inp.max_velocity, inp.max_acceleration, inp.max_jerk = [v_max], [a_max], [j_max]
    traj = ruckig.Trajectory(1)
    ruckig.Ruckig(1).calculate(inp, traj)
    return traj


# ---------------------------------------------------------------------------------------------
# Feed law along the path
# ---------------------------------------------------------------------------------------------

@pytest.mark.parametrize("length, v_max", [(100.0, 100.0), (5.0, 100.0), (100.0, 300.0)])
def test_line_feed_law_matches_ruckig(mikron, length, v_max):
    """s, feed and tangential acceleration equal ruckig's rest-to-rest optimum at every sample
    (plateau, acceleration-limited and jerk-only peak cases)."""
    a_max, j_max = 1000.0, 5000.0
    path = line_path([[0, 0, 0], [length * 0.6, length * 0.8, 0]])
    motion = single_block_motion(mikron, path, v_max, a_max, j_max)
    traj = ruckig_rest_to_rest(length, v_max, a_max, j_max)
    assert motion.total_time_s == pytest.approx(traj.duration, rel=1e-12)

    tr = sample_motion(motion, 1e-3)
    expected = np.array([[x[0] for x in traj.at_time(t)] for t in tr.t_s])
    np.testing.assert_allclose(tr.s_mm, expected[:, 0], atol=1e-9 * length)
    np.testing.assert_allclose(tr.feed_mm_s, expected[:, 1], atol=1e-9 * v_max)
    np.testing.assert_allclose(tr.accel_t_mm_s2, expected[:, 2], atol=1e-9 * a_max)
    # along a line: positions, axis velocity and acceleration are the feed law times the direction
    u = np.array([0.6, 0.8, 0.0])
    np.testing.assert_allclose(tr.pos_mm, expected[:, :1] * u, atol=1e-9 * length)
    np.testing.assert_allclose(tr.vel_mm_s, expected[:, 1:2] * u, atol=1e-9 * v_max)
    np.testing.assert_allclose(tr.acc_mm_s2, expected[:, 2:3] * u, atol=1e-9 * a_max)
    assert np.all(tr.accel_n_mm_s2 == 0) and np.all(tr.jerk_n_mm_s3 == 0)


def test_default_grid_is_the_ipo_cycle_and_ends_at_the_end(mikron):
    path = line_path([[0, 0, 0], [10, 0, 0]])
    motion = single_block_motion(mikron, path, 100.0, 1000.0, 5000.0)
    tr = sample_motion(motion)
    dt = mikron.ncu.ipo_cycle_s
    T = motion.total_time_s
    assert len(tr) == math.floor(T / dt) + 2  # 0, dt, ..., plus the end itself (off the grid here)
    np.testing.assert_allclose(np.diff(tr.t_s[:-1]), dt, rtol=1e-12)
    assert tr.t_s[-1] == T and tr.s_mm[-1] == pytest.approx(10.0, abs=1e-12)
    assert tr.feed_mm_s[-1] == pytest.approx(0.0, abs=1e-9)
    assert tr.block[-1] == 0 and tr.line[-1] == 10


def test_time_grid_on_the_end_adds_nothing():
    t = time_grid_s(1.0, 0.25)
    np.testing.assert_array_equal(t, [0, 0.25, 0.5, 0.75, 1.0])
    assert time_grid_s(1.0 - 1e-13, 0.25)[-1] == 1.0 - 1e-13
    assert len(time_grid_s(1.0 - 1e-13, 0.25)) == 5


# ---------------------------------------------------------------------------------------------
# Circles and helices: eq. 1 and eq. 3
# ---------------------------------------------------------------------------------------------

def _finite_differences(motion, t, h):
    """Central differences of the sampled positions: velocity, acceleration, jerk."""
    offsets = np.array([-2, -1, 0, 1, 2]) * h
    p = [sample_motion(motion, t_s=t + o).pos_mm for o in offsets]
    vel = (p[3] - p[1]) / (2 * h)
    acc = (p[3] - 2 * p[2] + p[1]) / (h * h)
    jerk = (p[4] - 2 * p[3] + 2 * p[1] - p[0]) / (2 * h ** 3)
    return vel, acc, jerk


def _interior_times(motion, n, margin):
    """Times strictly inside pieces (derivatives are discontinuous at piece boundaries)."""
    t = np.linspace(0, motion.total_time_s, n)[1:-1]
    edge = np.min(np.abs(t[:, None] - motion.piece_t_s[None, :]), axis=1)
    return t[edge > margin]


def test_circle_positions_and_plateau_closed_forms(mikron):
    """On a circle: pos = R (cos s/R, sin s/R); at steady feed |A| = V^2/R (eq. 1-2) and
    |J| = V^3/R^2 (eq. 3), all normal; A_n and J_n columns equal those closed forms."""
    R, V = 30.0, 100.0
    path = circle_path(R, V)
    motion = single_block_motion(mikron, path, V, 2500.0, 5000.0)
    traj = ruckig_rest_to_rest(2 * math.pi * R, V, 2500.0, 5000.0)
    tr = sample_motion(motion, 2e-3)
    s = np.array([traj.at_time(t)[0][0] for t in tr.t_s])
    np.testing.assert_allclose(tr.pos_mm[:, 0], R * np.cos(s / R), atol=1e-9)
    np.testing.assert_allclose(tr.pos_mm[:, 1], R * np.sin(s / R), atol=1e-9)
    np.testing.assert_allclose(tr.pos_mm[:, 2], 0.0, atol=1e-12)

    steady = tr.phase == Phase.B
    assert steady.sum() > 100
    np.testing.assert_allclose(np.linalg.norm(tr.vel_mm_s[steady], axis=1), V, rtol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(tr.acc_mm_s2[steady], axis=1), V * V / R, rtol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(tr.jerk_mm_s3[steady], axis=1), V ** 3 / R ** 2, rtol=1e-9)
    np.testing.assert_allclose(tr.accel_n_mm_s2[steady], V * V / R, rtol=1e-12)
    np.testing.assert_allclose(tr.jerk_n_mm_s3[steady], V ** 3 / R ** 2, rtol=1e-12)
    # acceleration points to the centre, jerk is opposite to the velocity at steady feed
    radial = -tr.pos_mm[steady] / R
    np.testing.assert_allclose(tr.acc_mm_s2[steady], (V * V / R) * radial, atol=1e-9)
    np.testing.assert_allclose(tr.jerk_mm_s3[steady], -(V * V / R ** 2) * tr.vel_mm_s[steady], atol=1e-8)


@pytest.mark.parametrize("helix_mm, turns", [(0.0, 1.0), (12.0, 1.5), (-40.0, 0.75)])
def test_axis_derivatives_match_finite_differences(mikron, helix_mm, turns):
    """Axis velocity, acceleration and jerk (Frenet form of eq. 1 and its derivative, with the
    helix torsion term) equal central differences of the sampled positions in ramps and plateau."""
    R, V = 20.0, 150.0
    path = circle_path(R, V, helix_mm, turns)
    motion = single_block_motion(mikron, path, V, 1500.0, 8000.0)
    h = 2e-4
    t = _interior_times(motion, 60, 3 * h)
    tr = sample_motion(motion, t_s=t)
    vel, acc, jerk = _finite_differences(motion, t, h)
    np.testing.assert_allclose(tr.vel_mm_s, vel, atol=1e-6 * V)
    np.testing.assert_allclose(tr.acc_mm_s2, acc, atol=1e-5 * V * V / R)
    np.testing.assert_allclose(tr.jerk_mm_s3, jerk, atol=2e-3 * V ** 3 / R ** 2)
    assert np.any(tr.phase == Phase.A) and np.any(tr.phase == Phase.B)


def test_helix_steady_jerk_magnitude_closed_form(mikron):
    """At steady feed on a helix |J| = V^3 kappa sqrt(kappa^2 + tau^2) = V^3 r / rho^3
    (Frenet-Serret), with rho^2 = r^2 + p^2, p the rise per radian."""
    R, V, rise, turns = 10.0, 80.0, 25.0, 2.0
    path = circle_path(R, V, rise, turns)
    motion = single_block_motion(mikron, path, V, 2000.0, 20000.0)
    tr = sample_motion(motion, 1e-3)
    steady = tr.phase == Phase.B
    p = rise / (2 * math.pi * turns)
    rho = math.hypot(R, p)
    np.testing.assert_allclose(np.linalg.norm(tr.jerk_mm_s3[steady], axis=1), V ** 3 * R / rho ** 3, rtol=1e-9)
    np.testing.assert_allclose(tr.accel_n_mm_s2[steady], V * V * R / rho ** 2, rtol=1e-12)
    np.testing.assert_allclose(tr.vel_mm_s[steady, 2], V * p / rho, rtol=1e-12)


def mixed_path():
    """Line, quarter circle (G3), helix (G2 with a rise), a YZ-plane arc and a line again."""
    from ncsim.geometry import sweep_angle_rad
    from ncsim.path import ARC, LINE, arc_length_mm

    rows = [  # kind, start, end, center, normal, helix
        (LINE, [0, 0, 0], [10, 0, 0], None, None, 0.0),
        (ARC, [10, 0, 0], [15, 5, 0], [10, 5, 0], [0, 0, 1], 0.0),
        (ARC, [15, 5, 0], [15, 15, -3], [15, 10, 0], [0, 0, -1], 3.0),  # rises 3 along -Z
        (ARC, [15, 15, -3], [15, 19, -3], [15, 17, -3], [1, 0, 0], 0.0),
        (LINE, [15, 19, -3], [0, 0, 0], None, None, 0.0),
    ]
    cols = {k: [] for k in ("kind", "start_mm", "end_mm", "center_mm", "normal", "radius_mm",
                            "sweep_rad", "helix_mm", "length_mm")}
    for kind, p, q, c, w, h in rows:
        p, q = np.array(p, float), np.array(q, float)
        if kind == LINE:
            c, w, r, sweep, length = [np.nan] * 3, [0, 0, 0], np.nan, 0.0, np.linalg.norm(q - p)
        else:
            c, w = np.array(c, float), np.array(w, float)
            r = float(np.linalg.norm((p - c) - np.dot(p - c, w) * w))
            sweep = float(sweep_angle_rad(p, q - h * w, c, w))
            length = float(arc_length_mm(r, sweep, h))
        for key, val in zip(cols, (kind, p, q, c, w, r, sweep, h, length)):
            cols[key].append(val)
    b = PathBuilder()
    b.extend(**{k: np.array(v) for k, v in cols.items()}, line=np.arange(1, 6), feed_mm_s=50.0)
    return b.build()


def test_frenet_form_agrees_with_geometry_and_closed_forms():
    """The per-block coefficient form gives the positions, tangents and curvature vectors of
    ncsim.geometry; on the circle d(kappa n)/ds = -kappa^2 t (the eq. 3 term), on the
    helix (w x kappa n) / rho (Frenet-Serret with torsion)."""
    from ncsim.geometry import curvature_at, point_at, tangent_at
    from ncsim.plan.sample import frenet_at, segment_coefficients

    path = mixed_path()
    rng = np.random.default_rng(1)
    blk = np.repeat(np.arange(path.n), 40)
    s = rng.uniform(0, 1, len(blk)) * path.length_mm[blk]
    s[::40] = 0.0
    s[39::40] = path.length_mm
    coef, k = segment_coefficients(path)
    pos, t, kn, dkn = frenet_at(coef[:, blk], k[blk], s)
    np.testing.assert_allclose(pos.T, point_at(path, blk, s), atol=1e-12)
    np.testing.assert_allclose(t.T, tangent_at(path, blk, s), atol=1e-12)
    np.testing.assert_allclose(kn.T, curvature_at(path, blk, s), atol=1e-12)
    np.testing.assert_allclose(pos[:, 39::40].T, path.end_mm, atol=1e-12)

    circle = blk == 1
    kappa = 1 / 5.0
    np.testing.assert_allclose(dkn[:, circle], -kappa ** 2 * t[:, circle], atol=1e-15)
    helix = blk == 2
    rho = path.length_mm[2] / path.sweep_rad[2]
    expected = np.cross(path.normal[2], kn[:, helix].T) / rho
    np.testing.assert_allclose(dkn[:, helix].T, expected, atol=1e-15)
    lines = (blk == 0) | (blk == 4)
    assert np.all(kn[:, lines] == 0) and np.all(dkn[:, lines] == 0)


def test_mixed_path_sampled_axis_jerk_matches_finite_differences(mikron):
    """A motion over lines and arcs (a steady piece crossing junctions): axis derivatives
    still match finite differences of the positions away from the junctions."""
    path = mixed_path()
    motion = make_motion(mikron, path, *rest_to_rest(path.total_length_mm, 40.0, 500.0, 2000.0),
                         [Limit.PROGRAMMED] * 7, t_start=[0.0] * 5, t_end=[0.0] * 5,
                         cap=40.0, cap_limit=Limit.PROGRAMMED, jerk=2000.0, accel=500.0)
    h = 5e-5
    t = _interior_times(motion, 400, 3 * h)
    tr = sample_motion(motion, t_s=t)
    near_junction = np.min(np.abs(tr.s_mm[:, None] - path.s_start_mm[None, 1:]), axis=1) < 3 * h * 40
    t, tr = t[~near_junction], tr.select(~near_junction)
    vel, acc, jerk = _finite_differences(motion, t, h)
    np.testing.assert_allclose(tr.vel_mm_s, vel, atol=1e-6 * 40)
    np.testing.assert_allclose(tr.acc_mm_s2, acc, atol=1e-4 * 40 ** 2 / 2)
    np.testing.assert_allclose(tr.jerk_mm_s3, jerk, atol=2e-3 * 40 ** 3 / 4)
    assert set(np.unique(tr.block)) == {0, 1, 2, 3, 4}


# ---------------------------------------------------------------------------------------------
# Blocks, limits, junctions and dwells
# ---------------------------------------------------------------------------------------------

def two_lines_with_dwell(machine, dwell_s=0.05):
    """Line A (10 mm, +X) rest-to-rest, dwell at the junction, line B (5 mm, +Y) rest-to-rest."""
    path = line_path([[0, 0, 0], [10, 0, 0], [10, 5, 0]])
    d1, j1, p1 = rest_to_rest(10.0, 100.0, 1000.0, 5000.0)
    d2, j2, p2 = rest_to_rest(5.0, 100.0, 1000.0, 5000.0)
    lim = lambda ph: [Limit.EXACT_STOP if p != Phase.B else Limit.PROGRAMMED for p in ph]  # noqa: E731
    durations = d1 + [dwell_s] + d2
    jerks = j1 + [0.0] + j2
    phases = p1 + [Phase.STOP] + p2
    limits = lim(p1) + [Limit.DWELL] + lim(p2)
    t1 = sum(d1)
    motion = make_motion(machine, path, durations, jerks, phases, limits,
                         t_start=[0.0, t1 + dwell_s], t_end=[t1, t1 + dwell_s + sum(d2)],
                         cap=[100.0, 80.0], cap_limit=[Limit.NCU_PATH_JERK, Limit.AXIS_ACCEL],
                         jerk=5000.0, accel=1000.0)
    return motion, t1


def test_junction_and_dwell_samples_belong_to_the_next_block(mikron):
    motion, t1 = two_lines_with_dwell(mikron, 0.05)
    t = np.array([0.0, t1 - 1e-3, t1, t1 + 0.02, t1 + 0.05, t1 + 0.06, motion.total_time_s])
    tr = sample_motion(motion, t_s=t)
    np.testing.assert_array_equal(tr.block, [0, 0, 1, 1, 1, 1, 1])
    np.testing.assert_array_equal(tr.line, [10, 10, 20, 20, 20, 20, 20])
    np.testing.assert_allclose(tr.pos_mm[2:5], [[10, 0, 0]] * 3, atol=1e-12)
    np.testing.assert_allclose(tr.pos_mm[-1], [10, 5, 0], atol=1e-12)
    assert list(tr.phase[2:4]) == [Phase.STOP, Phase.STOP]
    assert list(tr.limit[2:4]) == [Limit.DWELL, Limit.DWELL]
    np.testing.assert_array_equal(tr.setpoint_mm_s, [100, 100, 80, 80, 80, 80, 80])
    np.testing.assert_array_equal(tr.programmed_mm_s, 100.0)


def test_steady_samples_take_the_cap_limit_of_their_block(mikron):
    """One steady piece crossing a junction: its samples take each block's cap_limit, ramp
    samples the piece's limit; the block changes where s passes the junction."""
    path = line_path([[0, 0, 0], [30, 0, 0], [30, 40, 0]])  # 30 + 40 mm
    d, j, ph = rest_to_rest(70.0, 100.0, 1000.0, 5000.0)
    lim = [Limit.PROGRAM_END] * 3 + [Limit.PROGRAMMED] + [Limit.PROGRAM_END] * 3
    t_ramp = d[0] + d[1] + d[2]
    s_ramp = 100.0 * t_ramp / 2  # symmetric ramp: mean feed V/2
    t_junction = t_ramp + (30.0 - s_ramp) / 100.0
    motion = make_motion(mikron, path, d, j, ph, lim, t_start=[0.0, t_junction],
                         t_end=[t_junction, sum(d)], cap=100.0,
                         cap_limit=[Limit.NCU_PATH_JERK, Limit.TRANSITION], jerk=5000.0, accel=1000.0)
    t = np.array([0.01, t_junction - 1e-6, t_junction, t_junction + 1e-6, sum(d) - 0.01])
    tr = sample_motion(motion, t_s=t)
    np.testing.assert_array_equal(tr.block, [0, 0, 1, 1, 1])
    np.testing.assert_array_equal(tr.limit, [Limit.PROGRAM_END, Limit.NCU_PATH_JERK,
                                             Limit.TRANSITION, Limit.TRANSITION, Limit.PROGRAM_END])
    np.testing.assert_allclose(tr.pos_mm[2], [30, 0, 0], atol=1e-9)
    np.testing.assert_allclose(tr.pos_mm[3], [30, 1e-4, 0], atol=1e-9)
    np.testing.assert_allclose(tr.vel_mm_s[1], [100, 0, 0], atol=1e-9)
    np.testing.assert_allclose(tr.vel_mm_s[3], [0, 100, 0], atol=1e-9)


def test_sample_times_in_any_order_and_chunking(mikron, monkeypatch):
    """Chunked evaluation gives the same columns as one pass; unsorted times work."""
    import ncsim.plan.sample as sample

    motion, _ = two_lines_with_dwell(mikron)
    t = np.random.default_rng(3).uniform(0, motion.total_time_s, 1000)
    whole = sample_motion(motion, t_s=t)
    monkeypatch.setattr(sample, "CHUNK_SAMPLES", 7)
    chunked = sample_motion(motion, t_s=t)
    for name in ("s_mm", "pos_mm", "jerk_mm_s3", "block", "limit"):
        np.testing.assert_array_equal(getattr(whole, name), getattr(chunked, name))
    order = np.argsort(t)
    np.testing.assert_array_equal(sample_motion(motion, t_s=t[order]).pos_mm, whole.pos_mm[order])


# ---------------------------------------------------------------------------------------------
# Block table
# ---------------------------------------------------------------------------------------------

def test_block_table(mikron):
    motion, t1 = two_lines_with_dwell(mikron, 0.05)
    table = block_table(motion)
    d1 = sum(rest_to_rest(10.0, 100.0, 1000.0, 5000.0)[0])
    d2 = sum(rest_to_rest(5.0, 100.0, 1000.0, 5000.0)[0])
    np.testing.assert_array_equal(table["line"], [10, 20])
    np.testing.assert_allclose(table["t_start_s"], [0.0, d1 + 0.05])
    np.testing.assert_allclose(table["duration_s"], [d1, d2])
    np.testing.assert_allclose(table["time_lost_s"], [d1 - 10.0 / 100.0, d2 - 5.0 / 100.0])
    assert list(table["limit"]) == ["ncu_path_jerk", "axis_accel"]
    np.testing.assert_allclose(table["cap_mm_s"], [100.0, 80.0])
    assert {len(v) for v in table.values()} == {2}


# ---------------------------------------------------------------------------------------------
# Bad input
# ---------------------------------------------------------------------------------------------

@pytest.mark.parametrize("kwargs, match", [
    (dict(dt_s=0.0), "positive"),
    (dict(dt_s=float("nan")), "positive"),
    (dict(dt_s=1e-12), "more than"),
    (dict(t_s=np.array([-1.0])), "must lie in"),
    (dict(t_s=np.array([1e9])), "must lie in"),
    (dict(t_s=np.array([np.nan])), "finite"),
    (dict(t_s=np.zeros((2, 2))), "1-D"),
    (dict(dt_s=0.01, t_s=np.array([0.0])), "not both"),
])
def test_bad_sampling_requests(mikron, kwargs, match):
    motion, _ = two_lines_with_dwell(mikron)
    with pytest.raises(UsageError, match=match) as info:
        sample_motion(motion, **kwargs)
    assert "\n" not in info.value.render()


def test_empty_motion_gives_an_empty_trace(mikron):
    from ncsim.path import Path

    path = Path.empty()
    motion = Motion(path=path, machine=mikron, options=FULL_MODEL,
                    **{name: np.zeros(0) for name in (
                        "cap_mm_s", "cap_limit", "jerk_mm_s3", "accel_mm_s2", "t_start_s",
                        "t_end_s", "feed_max_mm_s")},
                    junction_cap_mm_s=np.zeros(1), junction_limit=np.zeros(1, np.int8),
                    junction_dwell_s=np.zeros(1), v_junction_mm_s=np.zeros(1),
                    a_junction_mm_s2=np.zeros(1), knot=np.ones(1, bool), piece_t_s=np.zeros(1),
                    piece_s_mm=np.zeros(0), piece_v_mm_s=np.zeros(0), piece_a_mm_s2=np.zeros(0),
                    piece_j_mm_s3=np.zeros(0), piece_phase=np.zeros(0, np.int8),
                    piece_limit=np.zeros(0, np.int8))
    assert len(sample_motion(motion)) == 0


def test_planned_paper_circle_samples(mikron):
    """Integration with the planner (paper §5.2.2: R = 2.5 mm at 6 m/min): positions stay on
    the circle, the steady feed is the set point (V_Jtcurv = 2.01 m/min, eq. 11), the steady
    normal acceleration is V^2/R and axis velocities match finite differences."""
    from ncsim.plan.lookahead import plan
    motion = plan(circle_path(2.5, 100.0), mikron)
    tr = sample_motion(motion, 1e-3)
    np.testing.assert_allclose(np.hypot(tr.pos_mm[:, 0], tr.pos_mm[:, 1]), 2.5, atol=1e-12)
    v_st = (6000.0 * 2.5 ** 2) ** (1 / 3)  # (J_tcurv R^2)^(1/3), J_tcurv = 6 m/s^3
    steady = tr.phase == Phase.B
    np.testing.assert_allclose(tr.feed_mm_s[steady], v_st, rtol=1e-9)
    np.testing.assert_allclose(tr.accel_n_mm_s2[steady], v_st ** 2 / 2.5, rtol=1e-9)
    assert np.all(tr.limit[steady] == Limit.NCU_PATH_JERK)
    h = 1e-5
    t = _interior_times(motion, 50, 3 * h)
    vel, _, _ = _finite_differences(motion, t, h)
    np.testing.assert_allclose(sample_motion(motion, t_s=t).vel_mm_s, vel, atol=1e-6)
