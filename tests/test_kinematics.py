"""The paper's equations (ncsim.plan.kinematics) against the paper's worked values and closed forms.

Expected values are the paper's (m/min, m/s^2, m/s^3, converted here) or closed forms written
in the test. The MIKRON of Table 1 / §5.2.4 is typed in here, not read from ncsim.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from ncsim.plan import kinematics as kin

M_MIN = 1000.0 / 60.0   # mm/s per m/min
V_AX = np.array([30.0, 30.0, 30.0]) * M_MIN        # Table 1, V_mi
A_AX = np.array([2.5, 3.0, 2.1]) * 1000.0          # Table 1, A_mi
J_AX = np.array([5.0, 5.0, 50.0]) * 1000.0         # Table 1, J_mi
J_TCURV = 10.0 * 1000.0 * 0.6                      # §5.2.4: J_curv * r_jct
T_CY = 0.012                                       # §5.3.2


def deg(a):
    return np.deg2rad(a)


def rel(a, b):
    return abs(a - b) / abs(b)


# ---- eq. 7 ------------------------------------------------------------------------------------

def test_eq7_axis_velocity_is_42_4_m_min_at_45_deg_and_30_on_the_axes():
    v45 = kin.axis_velocity_feed_limit_mm_s(kin.tangent_from_angle(deg(45)), V_AX) / M_MIN
    assert rel(v45, 42.4) < 0.001
    for a in (0, 90, 180, 270):
        v = kin.axis_velocity_feed_limit_mm_s(kin.tangent_from_angle(deg(a)), V_AX) / M_MIN
        assert v == pytest.approx(30.0)


def test_eq7_is_min_over_alpha_of_the_paper_formula():
    a = deg(np.linspace(0.5, 359.5, 719))
    paper = np.minimum(V_AX[0] / np.abs(np.cos(a)), V_AX[1] / np.abs(np.sin(a)))
    ours = kin.axis_velocity_feed_limit_mm_s(kin.tangent_from_angle(a), V_AX)
    np.testing.assert_allclose(ours, paper, rtol=1e-12)


# ---- eq. 8 ------------------------------------------------------------------------------------

def test_eq8_normal_accel_is_largest_at_tan_alpha_2_5_over_3():
    a = deg(np.linspace(0.0, 90.0, 90001))
    an = kin.axis_normal_accel_limit_mm_s2(kin.normal_from_angle(a), A_AX)
    best = np.rad2deg(a[np.argmax(an)])
    assert best == pytest.approx(math.degrees(math.atan(2.5 / 3.0)), abs=0.01)
    assert best == pytest.approx(39.8, abs=0.05)           # §5.2.1
    # there both axes saturate: A_n = A_mx / sin = A_my / cos
    assert an.max() == pytest.approx(2500.0 / math.sin(math.atan(2.5 / 3.0)), rel=1e-4)


def test_eq8_minima_are_the_axis_accelerations():
    # §5.2.1: 2.5 m/s^2 (A_mx) at 90 and 270 deg, 3 m/s^2 (A_my) at 0 and 180 deg
    an = kin.axis_normal_accel_limit_mm_s2(kin.normal_from_angle(deg(np.array([0, 90, 180, 270]))),
                                           A_AX)
    np.testing.assert_allclose(an / 1000.0, [3.0, 2.5, 3.0, 2.5])


# ---- eq. 9 / 15 -------------------------------------------------------------------------------

def test_eq9_tangential_jerk_7_07_at_45_deg_and_5_on_the_axes():
    j = kin.axis_tangential_jerk_limit_mm_s3(kin.tangent_from_angle(deg(45)), J_AX) / 1000.0
    assert rel(j, 7.07) < 0.001
    jx = kin.axis_tangential_jerk_limit_mm_s3(kin.tangent_from_angle(deg(np.array([0, 90, 180, 270]))),
                                              J_AX)
    np.testing.assert_allclose(jx, 5000.0)


def test_eq15_jerk_at_30_deg_is_2_jmy_over_sqrt3():
    j = kin.axis_tangential_jerk_limit_mm_s3(kin.tangent_from_angle(deg(30)), J_AX)
    assert j == pytest.approx(2 * 5000.0 / math.sqrt(3))


def test_alpha_33_5_deg_worked_values_of_5_2_4():
    """§5.2.4, R 2.5: alpha_c = 33.5 deg gives V_An = 5.7 m/min, V_t = 36 m/min, J_t = 6."""
    a = deg(33.5)
    t, n = kin.tangent_from_angle(a), kin.normal_from_angle(a)
    v_an = kin.normal_accel_feed_limit_mm_s(2.5, kin.axis_normal_accel_limit_mm_s2(n, A_AX)) / M_MIN
    v_t = kin.axis_velocity_feed_limit_mm_s(t, V_AX) / M_MIN
    j_t = kin.axis_tangential_jerk_limit_mm_s3(t, J_AX) / 1000.0
    assert rel(v_an, 5.7) < 0.005
    assert rel(v_t, 36.0) < 0.005
    assert rel(j_t, 6.0) < 0.005


def test_3d_generalisation_uses_the_axes_along_the_vector():
    # a tangent in the XZ plane: Z's jerk (50 m/s^3) and X's
    a = deg(60)
    t = np.array([math.cos(a), 0.0, math.sin(a)])
    assert kin.axis_tangential_jerk_limit_mm_s3(t, J_AX) == pytest.approx(
        min(5000.0 / math.cos(a), 50000.0 / math.sin(a)))
    # batch shape is kept
    tt = kin.tangent_from_angle(deg(np.zeros((4, 5))))
    assert kin.axis_velocity_feed_limit_mm_s(tt, V_AX).shape == (4, 5)


# ---- eq. 2, 3, 4, 5, 6 -------------------------------------------------------------------------

def test_eq3_and_eq4_are_inverse_and_match_2_01_m_min_at_6_m_s3():
    v = kin.tangential_jerk_feed_limit_mm_s(6000.0, 2.5)
    assert kin.tangential_jerk_on_circle_mm_s3(v, 2.5) == pytest.approx(6000.0)
    assert rel(v / M_MIN, 2.01) < 0.005                      # §5.2.2
    # eq. 3 with the measured 2.01 m/min gives the 6 m/s^3 of §5.2.2
    assert rel(kin.tangential_jerk_on_circle_mm_s3(2.01 * M_MIN, 2.5) / 1000.0, 6.0) < 0.01


def test_eq4_minimum_over_the_circle_is_1_9_and_9_9_m_min():
    # §5.2.1 / 5.2.2: min(V_Jt) = 1.9 m/min at R 2.5 and 9.9 m/min at R 30 (J_t = 5 m/s^3)
    assert rel(kin.tangential_jerk_feed_limit_mm_s(5000.0, 2.5) / M_MIN, 1.9) < 0.006
    assert rel(kin.tangential_jerk_feed_limit_mm_s(5000.0, 30.0) / M_MIN, 9.9) < 0.005


def test_eq2_phase_b_normal_acceleration_is_v2_over_r():
    # §5.2.2: the steady 6 m/min on R 30 has A_n = 0.333 m/s^2, i.e. eq. 2 solved for A_n
    v = kin.normal_accel_feed_limit_mm_s(30.0, 333.33)
    assert rel(v / M_MIN, 6.0) < 0.001


def test_eq5_static_lookahead_is_the_minimum():
    np.testing.assert_array_equal(kin.static_lookahead_mm_s([3, 1, 2], [2, 3, 1], [1, 2, 3]), [1, 1, 1])
    assert kin.static_lookahead_mm_s(5.0, 4.0, 6.0) == 4.0


def test_eq6_cycle_time_limit_of_the_r2_5_circle_is_78_5_m_min():
    v = kin.cycle_time_feed_limit_mm_s(2.0 * math.pi * 2.5, T_CY) / M_MIN
    assert rel(v, 78.5) < 0.001
    assert kin.cycle_time_feed_limit_mm_s(0.0, T_CY) == np.inf


# ---- eq. 10, 11, 12 ------------------------------------------------------------------------------

def test_eq10_eq11_ncu_jerk_and_feed_limits():
    assert kin.ncu_tangential_jerk_mm_s3(10000.0, 0.6) == pytest.approx(6000.0)
    for radius, paper in ((2.5, 2.01), (30.0, 10.53), (10.0, 5.06), (12.0, 5.71)):
        assert rel(kin.ncu_path_jerk_feed_limit_mm_s(6000.0, radius) / M_MIN, paper) < 0.002


def test_eq12_set_point_is_the_minimum_with_its_index():
    v, i = kin.feed_set_point_mm_s([100.0, 50.0], [80.0, 60.0], [90.0, 50.0])
    np.testing.assert_array_equal(v, [80.0, 50.0])
    np.testing.assert_array_equal(i, [1, 0])     # a tie goes to the earlier candidate


# ---- eq. 13 and its generalisation ----------------------------------------------------------------

@pytest.mark.parametrize("angle, paper", [(0, 4.92), (30, 5.29), (45, 5.85)])
def test_eq13_transition_14_to_16_mm(angle, paper):
    j_t = kin.axis_tangential_jerk_limit_mm_s3(kin.tangent_from_angle(deg(angle)), J_AX)
    v = kin.transition_feed_from_radii_mm_s(14.0, 16.0, j_t, T_CY) / M_MIN
    assert rel(v, paper) < 0.002


def test_generalised_eq13_special_cases():
    j, dt = 5000.0, T_CY
    up = np.array([0.0, 1.0, 0.0])
    # same-side arcs: the paper's formula
    dk = kin.curvature_jump_1_mm(up / 14.0, up / 16.0)
    assert kin.transition_feed_mm_s(j, dt, dk) == pytest.approx(math.sqrt(14 * 16 * j * dt / 2))
    # line -> arc: sqrt(R J dt)
    dk = kin.curvature_jump_1_mm(np.zeros(3), up / 10.0)
    assert kin.transition_feed_mm_s(j, dt, dk) == pytest.approx(math.sqrt(10 * j * dt))
    # reversal (S-bend): R1 R2 / (R1 + R2)
    dk = kin.curvature_jump_1_mm(up / 14.0, -up / 16.0)
    assert kin.transition_feed_mm_s(j, dt, dk) == pytest.approx(math.sqrt(14 * 16 / 30 * j * dt))
    # no jump: unconstrained
    assert kin.transition_feed_mm_s(j, dt, 0.0) == np.inf
    assert kin.transition_feed_from_radii_mm_s(15.0, 15.0, j, dt) == np.inf


# ---- eq. 1 split: tangential acceleration left by the normal part ------------------------------------

def test_tangential_accel_left_on_a_circle_is_sqrt_a2_minus_an2():
    """min over alpha of min_i (A_i - a_n |n_i|)/|t_i| = sqrt(A_min^2 - a_n^2) (closed form:
    for one axis, f(a) = (A - a_n sin a)/cos a is smallest where sin a = a_n / A)."""
    a = deg(np.linspace(0.0, 360.0, 360001))
    a_n = 600.0
    at = kin.tangential_accel_available_mm_s2(kin.tangent_from_angle(a), kin.normal_from_angle(a),
                                              a_n, A_AX)
    assert at.min() == pytest.approx(math.sqrt(2500.0 ** 2 - a_n ** 2), rel=1e-6)
    # without normal acceleration it is the line limit
    t = kin.tangent_from_angle(deg(20))
    assert kin.tangential_accel_available_mm_s2(t, kin.normal_from_angle(deg(20)), 0.0, A_AX) == \
        pytest.approx(kin.axis_tangential_accel_limit_mm_s2(t, A_AX))
    assert kin.axis_tangential_accel_limit_mm_s2(t, A_AX) == pytest.approx(
        min(2500 / math.cos(deg(20)), 3000 / math.sin(deg(20))))


# ---- corners and acceleration modes ---------------------------------------------------------------

def test_g64_corner_feed_is_the_overload_factors_velocity_jump():
    """840D B1: velocity jump = axis acceleration x (MD32310 - 1) x interpolator cycle."""
    x, y = np.array([1.0, 0, 0]), np.array([0, 1.0, 0])
    # MD32310 = 2: 90 deg X -> Y, both axes jump by V; X allows 2500*1*0.012 = 30 mm/s, Y 36
    assert kin.corner_feed_g64_mm_s(x, y, A_AX, T_CY, 2.0) == pytest.approx(30.0)
    # MD32310 = 1.2 (the usual delivery value): 2500 * 0.2 * 0.012 = 6 mm/s
    assert kin.corner_feed_g64_mm_s(x, y, A_AX, T_CY, 1.2) == pytest.approx(6.0)
    # per axis: Y's factor 1.1 gives 3000 * 0.1 * 0.012 = 3.6 < X's 6
    assert kin.corner_feed_g64_mm_s(x, y, A_AX, T_CY, np.array([1.2, 1.1, 1.2])) == pytest.approx(3.6)
    # factor 1: "only tangential transitions with finite velocity": the corner stops
    assert kin.corner_feed_g64_mm_s(x, y, A_AX, T_CY, 1.0) == 0.0
    # reversal along X: the jump is 2V
    assert kin.corner_feed_g64_mm_s(x, -x, A_AX, T_CY, 2.0) == pytest.approx(15.0)
    assert kin.corner_feed_g64_mm_s(x, x, A_AX, T_CY, 2.0) == np.inf


def test_deflection_angle():
    x = np.array([1.0, 0, 0])
    t30 = kin.tangent_from_angle(deg(30))
    assert kin.deflection_angle_rad(x, t30) == pytest.approx(deg(30))
    assert kin.deflection_angle_rad(x, -x) == pytest.approx(math.pi)


def test_curvature_change_spread_over_a_length():
    """eq. 13 when the change is a jump (length 0), (J l / dk)^(1/3) when it is spread wider
    than the feed covers in dt; the jerk V^2 dk / max(l / V, dt) equals J at the result."""
    j, dt = 5000.0, 0.012
    dk = 1.0 / 14.0 - 1.0 / 16.0                     # the paper's 14 -> 16 mm transition
    jump = math.sqrt(j * dt / dk)
    assert kin.curvature_change_feed_mm_s(j, dt, dk, 0.0) == pytest.approx(jump)
    assert jump * 60 / 1000 == pytest.approx(4.92, abs=0.005)      # paper 5.4.1: 4.92 m/min
    for length in (0.1, 1.0, 5.0, 50.0):
        v = float(kin.curvature_change_feed_mm_s(j, dt, dk, length))
        assert v >= jump - 1e-9
        assert v * v * dk / max(length / v, dt) == pytest.approx(j)
    assert kin.curvature_change_feed_mm_s(j, dt, 0.0, 1.0) == np.inf


def test_brisk_and_drive():
    assert kin.brisk_jerk_mm_s3(2400.0, T_CY) == pytest.approx(200000.0)
    # DRIVE: p = 0.5, r = 0.3, Vmax = 500: untouched below 250, -30 % at 500, -15 % at 375
    got = kin.drive_accel_mm_s2(2000.0, np.array([100.0, 250.0, 375.0, 500.0]), 500.0, 0.5, 0.3)
    np.testing.assert_allclose(got, [2000.0, 2000.0, 1700.0, 1400.0])
    assert kin.drive_accel_mm_s2(2000.0, 500.0, 500.0, 1.0, 0.3) == pytest.approx(2000.0)
