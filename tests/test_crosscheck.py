"""Cross-check against ruckig (ncsim.plan.crosscheck).

Hand-built motions whose answer is known: the rest-to-rest jerk-limited line is closed-form
and equals ruckig's optimum; deliberately slow or too fast feed laws must be classified and
flagged. Expected durations come from closed forms written out here.
"""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from ncsim.plan.crosscheck import (EXCEEDED_ACCEL, EXCEEDED_FEED, EXCEEDED_JERK, Reason,
                              _ruckig_durations, block_piece_stats, crosscheck, select_blocks)
from ncsim.errors import UsageError
from ncsim.motion import Limit, Phase
from test_sample import (circle_path, line_path, make_motion, rest_to_rest, single_block_motion,
                         two_lines_with_dwell)

A, J = 1000.0, 5000.0


def t_rest_to_rest(L, V, A, J):
    """Closed-form duration of the time-optimal rest-to-rest move (textbook cases).

    A ramp 0 -> v lasts T(v) = 2 sqrt(v/J) (jerk only, v J <= A^2) or v/A + A/J, and covers
    v T(v) / 2. With a plateau: L/V + T(V). Otherwise the peak vp solves vp T(vp) = L."""
    def ramp(v):
        return 2 * math.sqrt(v / J) if v * J <= A * A else v / A + A / J

    if L >= V * ramp(V):
        return L / V + ramp(V)
    vp = (L * L * J / 4) ** (1 / 3)          # jerk only: L = 2 vp sqrt(vp/J)
    if vp * J > A * A:                        # acceleration-limited: vp^2/A + vp A/J = L
        vp = A / 2 * (-A / J + math.sqrt((A / J) ** 2 + 4 * L / A))
    return 2 * ramp(vp)


@pytest.mark.parametrize("L, V, A_", [(100.0, 100.0, A), (100.0, 400.0, A), (2.0, 100.0, A),
                                      (50.0, 400.0, 600.0), (5.0, 400.0, 600.0)])
def test_rest_to_rest_line_is_time_optimal(mikron, L, V, A_):
    motion = single_block_motion(mikron, line_path([[0, 0, 0], [0, 0, L]]), V, A_, J)
    T = t_rest_to_rest(L, V, A_, J)
    rep = crosscheck(motion)
    assert rep.ncsim_duration_s[0] == pytest.approx(T, rel=1e-12)
    assert rep.ruckig_duration_s[0] == pytest.approx(T, rel=1e-9)
    assert rep.ratio[0] == pytest.approx(1.0, abs=1e-9)
    assert rep.reason[0] == Reason.OPTIMAL and rep.exceeded[0] == 0
    assert not rep.ruckig_overshoot[0] and not rep.ruckig_reverses[0]
    s = rep.summary()
    assert (s["violations"], s["faster_than_optimum"], s["reasons"]["optimal"]) == (0, 0, 1)
    json.dumps(s), json.dumps(rep.rows())


def test_dwell_is_not_part_of_a_block(mikron):
    motion, _ = two_lines_with_dwell(mikron, 0.25)
    rep = crosscheck(motion)
    expected = [t_rest_to_rest(10.0, 100.0, A, J), t_rest_to_rest(5.0, 100.0, A, J)]
    np.testing.assert_allclose(rep.ncsim_duration_s, expected, rtol=1e-12)
    np.testing.assert_allclose(rep.reference_duration_s, expected, rtol=1e-9)
    assert list(rep.reason) == [Reason.OPTIMAL, Reason.OPTIMAL]
    np.testing.assert_array_equal(rep.line, [10, 20])


def _slow_line(mikron, L, v_run, cap, cap_limit=Limit.PROGRAMMED, j_run=J, feed=None):
    d, j, ph = rest_to_rest(L, v_run, A, j_run)
    lim = [Limit.PROGRAM_END] * 3 + [cap_limit] + [Limit.PROGRAM_END] * 3
    return make_motion(mikron, line_path([[0, 0, 0], [L, 0, 0]]), d, j, ph, lim,
                       t_start=[0.0], t_end=[sum(d)], cap=cap, cap_limit=cap_limit, jerk=J,
                       accel=A, feed=feed)


def test_steady_below_the_set_point_is_a_section_limit(mikron):
    """The feed is held at 60 while the block's set point is 100: slower by the closed-form
    difference, reason SECTION."""
    motion = _slow_line(mikron, 100.0, 60.0, 100.0)
    rep = crosscheck(motion)
    t_ncsim, t_opt = t_rest_to_rest(100.0, 60.0, A, J), t_rest_to_rest(100.0, 100.0, A, J)
    assert rep.reference_duration_s[0] == pytest.approx(t_opt, rel=1e-9)
    assert rep.ratio[0] == pytest.approx(t_ncsim / t_opt, rel=1e-9)
    assert rep.slower_s[0] == pytest.approx(t_ncsim - t_opt, rel=1e-6)
    assert rep.reason[0] == Reason.SECTION and rep.exceeded[0] == 0
    assert rep.summary()["worst_ratio"] == pytest.approx(t_ncsim / t_opt, rel=1e-9)
    assert "section limits" in rep.describe(0)


def test_lookahead_comes_first(mikron):
    rep = crosscheck(_slow_line(mikron, 100.0, 60.0, 100.0, cap_limit=Limit.LOOKAHEAD))
    assert rep.reason[0] == Reason.LOOKAHEAD


def test_zero_acceleration_point_inside_a_ramp(mikron):
    """Ramp 0 -> 50 to zero acceleration, then 50 -> 100, plateau, ramp down: slower than one
    ramp 0 -> 100 (reason ZERO_ACCEL)."""
    V = 100.0
    t_half = math.sqrt(50.0 / J)       # jerk-only ramp of dv = 50: two pieces of sqrt(dv/J)
    t_full = math.sqrt(V / J)
    durations = [t_half, t_half, t_half, t_half, 0.5, t_full, t_full]
    jerks = [J, -J, J, -J, 0.0, -J, J]
    phases = [Phase.A] * 4 + [Phase.B] + [Phase.C] * 2
    # length travelled, closed form: ramp 0->50 covers 25 * 2 t_half, ramp 50->100 covers
    # 75 * 2 t_half, plateau 0.5 V, ramp down 50 * 2 t_full
    L = 25 * 2 * t_half + 75 * 2 * t_half + 0.5 * V + 50 * 2 * t_full
    motion = make_motion(mikron, line_path([[0, 0, 0], [L, 0, 0]]), durations, jerks, phases,
                         [Limit.PROGRAMMED] * 7, t_start=[0.0], t_end=[sum(durations)],
                         cap=V, cap_limit=Limit.PROGRAMMED, jerk=J, accel=A)
    rep = crosscheck(motion)
    assert rep.reference_duration_s[0] == pytest.approx(t_rest_to_rest(L, V, A, J), rel=1e-9)
    assert rep.ratio[0] > 1.001
    assert rep.reason[0] == Reason.ZERO_ACCEL


def test_ramps_below_the_jerk_in_force_are_other(mikron):
    motion = _slow_line(mikron, 100.0, 100.0, 100.0, j_run=J / 2)
    rep = crosscheck(motion)
    assert rep.ratio[0] == pytest.approx(t_rest_to_rest(100.0, 100.0, A, J / 2)
                                         / t_rest_to_rest(100.0, 100.0, A, J), rel=1e-9)
    assert rep.reason[0] == Reason.OTHER


def test_too_fast_laws_are_flagged(mikron):
    """Feed above the set point, or jerk above the jerk in force: faster than ruckig."""
    over_feed = crosscheck(_slow_line(mikron, 100.0, 120.0, 100.0))
    assert over_feed.reason[0] == Reason.FASTER
    assert over_feed.exceeded[0] == EXCEEDED_FEED
    assert over_feed.feed_max_mm_s[0] == pytest.approx(120.0, rel=1e-12)

    over_jerk = crosscheck(_slow_line(mikron, 100.0, 100.0, 100.0, j_run=4 * J))
    assert over_jerk.reason[0] == Reason.FASTER
    assert over_jerk.exceeded[0] == EXCEEDED_JERK
    assert over_jerk.jerk_max_mm_s3[0] == 4 * J
    s = over_jerk.summary()
    assert s["violations"] == 1 and s["faster_than_optimum"] == 1 and s["worst_ratio"] < 1
    assert "exceeded: jerk" in over_jerk.describe(0)


def test_braking_too_short_makes_ruckig_overshoot(mikron):
    """Entering at V and stopping with 4x the jerk in force: ruckig (at the allowed jerk) must
    overshoot the block and come back; there is no forward-only solution; ncsim is faster
    and exceeds jerk and acceleration."""
    V = 100.0
    t = math.sqrt(V / (4 * J))
    L = V * t  # symmetric jerk-only ramp V -> 0 over 2t, mean feed V/2
    motion = make_motion(mikron, line_path([[0, 0, 0], [L, 0, 0]]), [t, t], [-4 * J, 4 * J],
                         [Phase.C] * 2, [Limit.EXACT_STOP] * 2, t_start=[0.0], t_end=[2 * t],
                         cap=V, cap_limit=Limit.PROGRAMMED, jerk=J, accel=A, v0=V)
    rep = crosscheck(motion)
    assert rep.v_start_mm_s[0] == V and rep.v_end_mm_s[0] == 0
    assert rep.ruckig_overshoot[0] and rep.ruckig_reverses[0]
    assert np.isnan(rep.ruckig_path_duration_s[0])
    assert rep.reference_duration_s[0] == rep.ruckig_duration_s[0] > 2 * t
    assert rep.reason[0] == Reason.FASTER
    assert rep.exceeded[0] == EXCEEDED_JERK | EXCEEDED_ACCEL  # a_peak = sqrt(4 J V) = 1414 > A
    assert "overshoots" in rep.describe(0)


def test_ruckig_missing_the_optimum_is_not_blamed_on_ncsim(mikron):
    """One constant-jerk piece between two accelerating states (a block inside a ramp, seen
    in programs/diagnosis_mix.mpf): the closed-form motion takes tau = (a0 - a1)/J and is
    within every limit, yet ruckig answers a much longer, overshooting motion. ncsim's own
    motion becomes the reference: reason RUCKIG_MISSED, ratio 1, no violation."""
    J5, v0, a0, a1 = 5000.0, 32.816045286321206, 297.49993916546373, 225.62398979870392
    tau = (a0 - a1) / J5
    L = v0 * tau + a0 * tau ** 2 / 2 - J5 * tau ** 3 / 6
    motion = make_motion(mikron, line_path([[0, 0, 0], [L, 0, 0]]), [tau], [-J5], [Phase.A],
                         [Limit.PROGRAMMED], t_start=[0.0], t_end=[tau], cap=41.666666666666664,
                         cap_limit=Limit.PROGRAMMED, jerk=J5, accel=2500.0, v0=v0, a0=a0)
    rep = crosscheck(motion)
    assert rep.a_end_mm_s2[0] == pytest.approx(a1, rel=1e-12)
    assert rep.ncsim_duration_s[0] == pytest.approx(tau, rel=1e-12)
    if rep.ruckig_duration_s[0] <= tau * (1 + 1e-6):  # a fixed ruckig finds it: nothing to see
        assert rep.reason[0] == Reason.OPTIMAL
        return
    assert rep.reason[0] == Reason.RUCKIG_MISSED and rep.exceeded[0] == 0
    assert rep.reference_duration_s[0] == rep.ncsim_duration_s[0] and rep.ratio[0] == 1.0
    s = rep.summary()
    assert s["faster_than_optimum"] == 0 and s["ruckig_missed_optimum"] == 1


def test_ruckig_time_precision_on_tiny_blocks(mikron):
    """A 0.017 mm stop from 1.2 mm/s (a planned program's last block): ncsim's ramp lasts
    2 sqrt(v/J) and covers v sqrt(v/J); the planner's block length is 2.8e-14 mm shorter
    (rounding), and ruckig, which hits the target within 1e-8, answers with a spurious
    2.6e-8 s phase (1.8e-6 relative): inside RUCKIG_ATOL_S, so still time-optimal."""
    J6, v = 6000.0, 1.200777139874834
    t = math.sqrt(v / J6)
    L = 0.016987051043514705  # as planned; v * t = 0.016987051043543037
    motion = make_motion(mikron, line_path([[0, 0, 0], [L, 0, 0]]), [t, t], [-J6, J6],
                         [Phase.C] * 2, [Limit.PROGRAM_END] * 2, t_start=[0.0], t_end=[2 * t],
                         cap=1.4155875869595587, cap_limit=Limit.PROGRAMMED, jerk=J6,
                         accel=3003.032062618967, v0=v)
    rep = crosscheck(motion)
    assert rep.ncsim_duration_s[0] == pytest.approx(2 * math.sqrt(v / J6), rel=1e-12)
    assert rep.reason[0] == Reason.OPTIMAL
    assert rep.ratio[0] == pytest.approx(1.0, abs=1e-5)


def test_invalid_unconstrained_optimum_falls_back_to_the_path_optimum():
    """A state seen on a real plan: near the velocity limit ruckig's unconstrained answer runs
    backwards (and is slower); the min_velocity = 0 rerun is the reference."""
    a = lambda x: np.array([x])  # noqa: E731
    dur, dur_path, dur_prog, over, back, err = _ruckig_durations(
        a(0.06813383960899824), a(4.445747855267024), a(121.12869790462088),
        a(5.530869006859366), a(40.62890149832765), a(5.67781996741652), a(3011.0638370283805),
        a(6000.0), a(5.67781996741652))
    assert over[0] and back[0] and err[0] == ""
    assert 0 < dur_path[0] < dur[0]


def test_ruckig_failure_is_reported(mikron):
    motion = _slow_line(mikron, 10.0, 100.0, 100.0)
    from dataclasses import replace
    broken = replace(motion, jerk_mm_s3=np.zeros(1))
    rep = crosscheck(broken)
    assert rep.reason[0] == Reason.RUCKIG_FAILED
    assert "zero limits" in rep.ruckig_error[0] and "\n" not in rep.ruckig_error[0]
    assert np.isnan(rep.ratio[0])
    assert rep.summary()["ruckig_failed"] == 1


def test_set_point_cost_is_priced_at_the_programmed_feed(mikron):
    """Set point 60 (NCU) under a programmed 100: the optimum at 60 equals ncsim, and the
    optimum at the programmed feed is the closed form at 100."""
    motion = _slow_line(mikron, 100.0, 60.0, 60.0, cap_limit=Limit.NCU_PATH_JERK, feed=100.0)
    rep = crosscheck(motion)
    t60, t100 = t_rest_to_rest(100.0, 60.0, A, J), t_rest_to_rest(100.0, 100.0, A, J)
    assert rep.reason[0] == Reason.OPTIMAL
    assert rep.ruckig_programmed_duration_s[0] == pytest.approx(t100, rel=1e-9)
    assert rep.setpoint_cost_s[0] == pytest.approx(t60 - t100, rel=1e-6)
    assert rep.summary()["setpoint_cost_s"] == pytest.approx(t60 - t100, rel=1e-6)


# ---------------------------------------------------------------------------------------------
# Piece statistics per block, max_blocks
# ---------------------------------------------------------------------------------------------

def test_block_piece_stats_split_inside_a_ramp(mikron):
    """Two collinear blocks joined where the first jerk piece is at time tau: block 0 sees
    feed J tau^2/2 and acceleration J tau at most (closed forms)."""
    V, L = 100.0, 100.0
    d, j, ph = rest_to_rest(L, V, A, J)
    tau = 0.6 * d[0]
    s_split = J * tau ** 3 / 6
    path = line_path([[0, 0, 0], [s_split, 0, 0], [L, 0, 0]])
    lim = [Limit.PROGRAM_END] * 3 + [Limit.PROGRAMMED] + [Limit.PROGRAM_END] * 3
    motion = make_motion(mikron, path, d, j, ph, lim, t_start=[0.0, tau], t_end=[tau, sum(d)],
                         cap=V, cap_limit=Limit.PROGRAMMED, jerk=J, accel=A)
    st = block_piece_stats(motion)
    np.testing.assert_allclose(st["feed_max_mm_s"], [J * tau ** 2 / 2, V], rtol=1e-12)
    np.testing.assert_allclose(st["feed_min_mm_s"], [0.0, 0.0], atol=1e-9)
    np.testing.assert_allclose(st["accel_max_mm_s2"], [J * tau, math.sqrt(V * J)], rtol=1e-12)
    np.testing.assert_array_equal(st["jerk_max_mm_s3"], [J, J])
    np.testing.assert_array_equal(st["steady_min_mm_s"], [np.inf, V])
    rep = crosscheck(motion)
    assert list(rep.reason) == [Reason.OPTIMAL, Reason.OPTIMAL]
    assert rep.a_end_mm_s2[0] == pytest.approx(J * tau, rel=1e-12)


def test_max_blocks_is_a_deterministic_sample(mikron):
    pts = [[i, 0, 0] for i in range(51)]
    d, j, ph = rest_to_rest(50.0, 100.0, A, J)
    path = line_path(pts)
    t_ramp = d[0] + d[1] + d[2]
    s_ramp = 100.0 * t_ramp / 2
    # all junctions lie on the plateau except the first and last few: only use block times
    # for the ones on the plateau, which is enough for the sampling check
    t_j = np.clip(t_ramp + (np.arange(51) - s_ramp) / 100.0, 0, sum(d))
    motion = make_motion(mikron, path, d, j, ph, [Limit.PROGRAMMED] * 7, t_start=t_j[:-1],
                         t_end=t_j[1:], cap=100.0, cap_limit=Limit.PROGRAMMED, jerk=J, accel=A)
    a = crosscheck(motion, max_blocks=10)
    b = crosscheck(motion, max_blocks=10)
    assert len(a) == 10 and a.n_blocks_total == 50
    np.testing.assert_array_equal(a.block, b.block)
    assert np.all(np.diff(a.block) > 0)
    assert len(crosscheck(motion, max_blocks=100)) == 50
    np.testing.assert_array_equal(select_blocks(5, None), np.arange(5))
    with pytest.raises(UsageError, match="max_blocks"):
        select_blocks(50, 0)


# ---------------------------------------------------------------------------------------------
# The planner (integration): never faster than ruckig
# ---------------------------------------------------------------------------------------------

@pytest.mark.parametrize("radius_mm", [2.5, 30.0])
def test_planned_paper_circles_are_never_faster_than_ruckig(mikron, radius_mm):
    from ncsim.plan.lookahead import plan
    motion = plan(circle_path(radius_mm, 100.0), mikron)  # 6 m/min, paper §5.2.2
    rep = crosscheck(motion)
    s = rep.summary()
    assert s["violations"] == 0 and s["faster_than_optimum"] == 0
    assert s["worst_ratio"] == pytest.approx(1.0, abs=1e-3)
