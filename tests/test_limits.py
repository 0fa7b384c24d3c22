"""path_limits: semantics of every block and junction rule, the ModelOptions switches, the
alpha-is-the-tangent reading on machines with unequal axes, and vectorisation.

Expected values are closed forms written here (the machine's numbers are typed in: Table 1 of the
paper, J_tcurv = 6 m/s^3, t_cy = delta t = 12 ms, normal_accel_share 0.75), never ncsim output.
The paper's own numbers are in test_paper_setpoints.py.
"""
from __future__ import annotations

import dataclasses
import math
import time

import numpy as np
import pytest

from ncsim.plan import limits as limits_mod
from ncsim.plan.limits import CANDIDATE_LABELS, PathLimits, path_limits
from ncsim.motion import FULL_MODEL, Limit, ModelOptions
from ncsim.path import BRISK, DRIVE, SOFT, PathBuilder

M_MIN = 1000.0 / 60.0
T_CY = 0.012
J_TCURV = 6000.0
SHARE = 0.75
# PathBuilder mixes scalar defaults and vectors when lines and arcs are added row by row:
# give lines their arc columns explicitly.
LINE_COLS = dict(center_mm=np.full(3, np.nan), normal=np.zeros(3))
NO_NCU = dataclasses.replace(FULL_MODEL, ncu_path_jerk=False)


def rot_z(v, a):
    c, s = math.cos(a), math.sin(a)
    return np.array([c * v[0] - s * v[1], s * v[0] + c * v[1], v[2]])


class Builder:
    """Paths for the tests: lines and chains of tangent arcs (CCW or CW) in G17."""

    def __init__(self, **modal):
        self.b = PathBuilder()
        self.modal = dict(cp_mode=64) | modal
        self.n = 0

    def _m(self, extra):
        self.n += 1
        return dict(line=self.n) | self.modal | extra

    def line(self, p, q, feed_mm_s=np.inf, **extra):
        self.b.add_line(np.asarray(p, float), np.asarray(q, float), feed_mm_s=feed_mm_s,
                        **LINE_COLS, **self._m(extra))
        return self

    def arcs(self, start, alpha0_rad, radii, sweep_rad, feed_mm_s, ccw=True, **extra):
        """Tangent arcs from ``start`` leaving at tangent angle alpha0; returns end, angle."""
        p = np.array([*start, 0.0][:3], float)
        t = np.array([math.cos(alpha0_rad), math.sin(alpha0_rad), 0.0])
        sgn = 1.0 if ccw else -1.0
        for r in radii:
            c = p + r * sgn * np.array([-t[1], t[0], 0.0])
            e = c + rot_z(p - c, sgn * sweep_rad)
            self.b.add_arc(p, e, c, [0.0, 0.0, sgn], r, sweep_rad, feed_mm_s=feed_mm_s,
                           **self._m(extra))
            t = rot_z(t, sgn * sweep_rad)
            p = e
        return p, math.atan2(t[1], t[0])

    def build(self):
        return self.b.build()


def circle(radius, feed_mm_s, **modal):
    """Full CCW circle from (0, -R) leaving along +X (tangent angle 0)."""
    b = Builder(**modal)
    b.arcs((0.0, -radius), 0.0, [radius], 2 * math.pi, feed_mm_s)
    return b.build()


def transition_path(r1, r2, junction_angle_rad, feed_mm_s=200.0):
    """Quarter arcs R r1 then r2 whose junction tangent is at ``junction_angle_rad``."""
    b = Builder()
    b.arcs((0.0, 0.0), junction_angle_rad - math.pi / 2, [r1, r2], math.pi / 2, feed_mm_s)
    return b.build()


# ---- structure ----------------------------------------------------------------------------------

def test_shapes_dtypes_and_read_only(mikron):
    path = Builder().line([0, 0, 0], [10, 0, 0], 100.0).build()
    lim = path_limits(path, mikron)
    assert isinstance(lim, PathLimits) and lim.n_blocks == 1
    assert lim.cap_limit.dtype == np.int8 and lim.junction_limit.dtype == np.int8
    assert lim.junction_cap_mm_s.shape == (2,) and lim.junction_dwell_s.shape == (2,)
    assert set(lim.candidates) == set(CANDIDATE_LABELS)
    assert set(CANDIDATE_LABELS) == {"programmed", "ncu_path_jerk", "axis_jerk", "axis_accel",
                                     "axis_velocity", "cycle_time"}
    with pytest.raises(ValueError):
        lim.cap_mm_s[0] = 1.0
    with pytest.raises(ValueError):
        lim.candidates["programmed"][0] = 1.0
    assert np.isnan(lim.alpha_c_rad[0])


def test_empty_path(mikron):
    lim = path_limits(PathBuilder().build(), mikron)
    assert lim.n_blocks == 0
    assert lim.junction_cap_mm_s.tolist() == [0.0]
    assert lim.junction_limit.tolist() == [Limit.PROGRAM_END]


# ---- lines --------------------------------------------------------------------------------------

def test_line_at_30_deg_closed_forms(mikron):
    u = np.array([math.cos(math.radians(30)), math.sin(math.radians(30)), 0.0])
    path = (Builder().line([0, 0, 0], 1000 * u, rapid=True)
            .line(1000 * u, 2000 * u, 100.0).build())
    lim = path_limits(path, mikron)
    c, s = u[0], u[1]
    assert lim.cap_mm_s[0] == pytest.approx(500.0 / c)              # rapid: axis velocity
    assert lim.cap_limit[0] == Limit.AXIS_VELOCITY
    assert lim.candidates["programmed"][0] == np.inf
    assert lim.cap_mm_s[1] == pytest.approx(100.0) and lim.cap_limit[1] == Limit.PROGRAMMED
    np.testing.assert_allclose(lim.accel_mm_s2, min(2500 / c, 3000 / s))
    np.testing.assert_allclose(lim.jerk_mm_s3, min(J_TCURV, 5000 / c))
    for key in ("ncu_path_jerk", "axis_jerk", "axis_accel"):
        assert np.all(lim.candidates[key] == np.inf)
    assert lim.candidates["cycle_time"][1] == pytest.approx(1000.0 / T_CY)


def test_zero_length_line_is_not_limited(mikron):
    path = Builder().line([0, 0, 0], [10, 0, 0], 100.0).line([10, 0, 0], [10, 0, 0], 100.0).build()
    lim = path_limits(path, mikron)
    assert lim.cap_mm_s[1] == pytest.approx(100.0)
    assert lim.accel_mm_s2[1] == pytest.approx(2100.0)     # weakest axis
    assert lim.jerk_mm_s3[1] == pytest.approx(5000.0)


# ---- the alpha-is-the-tangent reading on unequal axes ----------------------------------------------

@pytest.fixture()
def unequal(mikron):
    """J_mx = 5, J_my = 10 m/s^3; V_mx = 30, V_my = 20 m/min; A_mx = 2.5, A_my = 3 m/s^2."""
    return mikron.with_axes(max_jerk_mm_s3=[5000.0, 10000.0, 50000.0],
                            max_velocity_mm_s=[500.0, 20 * M_MIN, 500.0])


def test_line_along_x_vs_y_on_unequal_axes(unequal):
    path = (Builder().line([0, 0, 0], [500, 0, 0], rapid=True)
            .line([500, 0, 0], [500, 500, 0], rapid=True).build())
    lim = path_limits(path, unequal, NO_NCU)
    np.testing.assert_allclose(lim.cap_mm_s, [500.0, 20 * M_MIN])
    np.testing.assert_allclose(lim.jerk_mm_s3, [5000.0, 10000.0])
    np.testing.assert_allclose(lim.accel_mm_s2, [2500.0, 3000.0])
    # with the NCU path jerk the Y line is held to J_tcurv
    np.testing.assert_allclose(path_limits(path, unequal).jerk_mm_s3, [5000.0, J_TCURV])


def test_transition_uses_the_axis_along_the_junction_tangent(unequal):
    # eq. 13/15 with the tangent at the junction: along X -> J_mx, along Y -> J_my
    k = 14.0 * 16.0 / 2.0
    for angle, j in ((0.0, 5000.0), (math.pi / 2, 10000.0), (math.pi, 5000.0)):
        lim = path_limits(transition_path(14.0, 16.0, angle), unequal)
        assert lim.junction_limit[1] == Limit.TRANSITION
        assert lim.junction_cap_mm_s[1] == pytest.approx(math.sqrt(k * j * T_CY))


@pytest.mark.parametrize("centre_deg, axis", [(0.0, 1), (90.0, 0)])
def test_normal_accel_guard_uses_the_axis_along_the_normal(mikron, centre_deg, axis):
    """A 2-deg arc whose tangent turns through +X has its normal along Y there: the least A_n is
    A_my (eq. 8 with the tangent reading), and A_mx for an arc through +Y."""
    machine = mikron.with_axes(max_accel_mm_s2=[2500.0, 1000.0, 2100.0])
    b = Builder()
    radius = 50.0
    a0 = math.radians(centre_deg - 1.0)
    b.arcs((0.0, 0.0), a0, [radius], math.radians(2.0), 1e6)
    opts = ModelOptions(ncu_path_jerk=False, axis_jerk_setpoint=False, cycle_time_limit=False)
    lim = path_limits(b.build(), machine, opts)
    a_axis = [2500.0, 1000.0][axis]
    expected = math.sqrt(radius * SHARE * a_axis)    # least A_n: at the middle sample
    assert lim.cap_limit[0] == Limit.AXIS_ACCEL
    assert lim.cap_mm_s[0] == pytest.approx(expected, rel=1e-9)


# ---- arcs -------------------------------------------------------------------------------------------

def test_arc_tangential_accel_and_jerk_in_force(mikron):
    # R 30 at 6 m/min: a_n = v^2/R; least tangential accel = sqrt(A_mx^2 - a_n^2) (closed form of
    # min over alpha of (A - a_n |sin a|)/|cos a|); jerk = min J_t on the circle = 5 m/s^3 (§5.2.2)
    lim = path_limits(circle(30.0, 100.0), mikron)
    a_n = 100.0 ** 2 / 30.0
    assert lim.accel_mm_s2[0] == pytest.approx(math.sqrt(2500.0 ** 2 - a_n ** 2), rel=1e-4)
    assert lim.jerk_mm_s3[0] == pytest.approx(5000.0)


def test_alpha_c_follows_the_travel_and_the_plane(mikron):
    # G2 from (0, R) leaving along +X: the first tangent angle with J_t >= 6 is -33.56 deg
    b = Builder()
    b.arcs((0.0, 2.5), 0.0, [2.5], 2 * math.pi, 100.0, ccw=False)
    lim = path_limits(b.build(), mikron)
    a = np.rad2deg(lim.alpha_c_rad[0])
    assert a == pytest.approx(360.0 - math.degrees(math.acos(5.0 / 6.0)), abs=1e-4)
    # refined to J_t(alpha_c) = J_tcurv: V_Jt(alpha_c) = V_Jtcurv, and the NCU is named
    assert lim.candidates["axis_jerk"][0] == pytest.approx(lim.candidates["ncu_path_jerk"][0],
                                                           rel=1e-7)
    assert lim.cap_limit[0] == Limit.NCU_PATH_JERK
    # G18 (normal +Y, abscissa Z, ordinate X), tangent +Z at the start, Z as weak as X
    machine = mikron.with_axes(max_jerk_mm_s3=[5000.0, 5000.0, 5000.0])
    pb = PathBuilder()
    pb.add_arc([-2.5, 0, 0], [-2.5, 0, 0], [0, 0, 0], [0, 1.0, 0], 2.5, 2 * math.pi,
               line=1, feed_mm_s=100.0, cp_mode=64)
    a = np.rad2deg(path_limits(pb.build(), machine).alpha_c_rad[0])
    assert a == pytest.approx(math.degrees(math.acos(5.0 / 6.0)), abs=1e-4)
    # an arc that starts where the axes already carry J_tcurv: alpha_c is its start (40 deg)
    b = Builder()
    b.arcs((0.0, 0.0), math.radians(40.0), [2.5], math.radians(30.0), 100.0)
    assert np.rad2deg(path_limits(b.build(), mikron).alpha_c_rad[0]) == pytest.approx(40.0)


def test_helix_uses_its_curvature_radius_and_one_turn(mikron):
    r, rise = 10.0, 5.0
    p = rise / (2 * math.pi)
    r_curv = (r * r + p * p) / r
    paths = []
    for turns in (1, 3):
        pb = PathBuilder()
        pb.add_arc([r, 0, 0], [r, 0, turns * rise], [0, 0, 0], [0, 0, 1.0], r, turns * 2 * math.pi,
                   turns * rise, line=1, feed_mm_s=1e4, cp_mode=64)
        paths.append(path_limits(pb.build(), mikron))
    one, three = paths
    assert one.candidates["ncu_path_jerk"][0] == pytest.approx((J_TCURV * r_curv ** 2) ** (1 / 3))
    assert one.cap_limit[0] == Limit.NCU_PATH_JERK
    for key in ("cap_mm_s", "accel_mm_s2", "jerk_mm_s3", "alpha_c_rad"):
        assert getattr(three, key)[0] == pytest.approx(getattr(one, key)[0])
    # the tangent leans on Z: the least J_t is along the in-plane axes, scaled by the lean
    lean = r / math.hypot(r, p)
    assert one.jerk_mm_s3[0] == pytest.approx(min(J_TCURV, 5000.0 / lean), rel=1e-6)


def test_guards_never_let_the_axes_exceed_their_limits(mikron):
    """Random arcs on an unequal machine: cap <= min V_t and cap^2/R <= share * min A_n, checked
    by dense independent sampling (0.05 deg); accel and jerk positive."""
    machine = mikron.with_axes(max_velocity_mm_s=[300.0, 500.0, 400.0],
                               max_accel_mm_s2=[400.0, 3000.0, 2100.0])
    rng = np.random.default_rng(7)
    b = Builder()
    data = []
    for _ in range(40):
        r = rng.uniform(1.0, 400.0)
        a0 = rng.uniform(0, 2 * math.pi)
        sweep = rng.uniform(0.05, 2 * math.pi)
        ccw = bool(rng.integers(2))
        b.arcs(rng.uniform(-50, 50, 2), a0, [r], sweep, 1e6, ccw=ccw)
        data.append((r, a0, sweep if ccw else -sweep))
    lim = path_limits(b.build(), machine, ModelOptions(ncu_path_jerk=False,
                                                       axis_jerk_setpoint=False))
    for i, (r, a0, sweep) in enumerate(data):
        a = a0 + np.linspace(0, sweep, int(abs(sweep) / math.radians(0.05)) + 2)
        c, s = np.abs(np.cos(a)), np.abs(np.sin(a))
        with np.errstate(divide="ignore"):
            v_t = np.minimum(300.0 / c, 500.0 / s).min()
            a_n = np.minimum(400.0 / s, 3000.0 / c).min()
        cap = lim.cap_mm_s[i]
        assert cap <= v_t * (1 + 1e-4)
        assert cap ** 2 / r <= SHARE * a_n * (1 + 1e-4)
    assert np.all(lim.accel_mm_s2 > 0) and np.all(lim.jerk_mm_s3 > 0)


# ---- ModelOptions switches --------------------------------------------------------------------------

def test_option_ncu_path_jerk(mikron):
    on = path_limits(circle(30.0, 400.0), mikron)
    off = path_limits(circle(30.0, 400.0), mikron, NO_NCU)
    assert on.cap_limit[0] == Limit.NCU_PATH_JERK
    assert on.cap_mm_s[0] == pytest.approx((J_TCURV * 900.0) ** (1 / 3))
    # off: alpha_c where J_t is largest (45 deg), V_Jt there
    assert off.cap_limit[0] == Limit.AXIS_JERK
    assert off.cap_mm_s[0] == pytest.approx((5000.0 * math.sqrt(2) * 900.0) ** (1 / 3))
    assert np.rad2deg(off.alpha_c_rad[0]) == pytest.approx(45.0)
    assert off.candidates["ncu_path_jerk"][0] == np.inf
    # a 45-degree line: J_t = 7.07 m/s^3 from the axes, held to J_tcurv by the NCU
    d = np.array([1.0, 1.0, 0.0]) * 100
    line = Builder().line([0, 0, 0], d, 100.0).build()
    assert path_limits(line, mikron).jerk_mm_s3[0] == pytest.approx(J_TCURV)
    assert path_limits(line, mikron, NO_NCU).jerk_mm_s3[0] == pytest.approx(5000 * math.sqrt(2))


def test_option_axis_jerk_setpoint(mikron):
    # axes too weak to carry J_tcurv anywhere (J 3 m/s^3): alpha_c at the J_t maximum (45 deg)
    weak = mikron.with_axes(max_jerk_mm_s3=[3000.0, 3000.0, 50000.0])
    on = path_limits(circle(30.0, 400.0), weak)
    off = path_limits(circle(30.0, 400.0), weak, ModelOptions(axis_jerk_setpoint=False))
    assert on.cap_limit[0] == Limit.AXIS_JERK
    assert on.cap_mm_s[0] == pytest.approx((3000.0 * math.sqrt(2) * 900.0) ** (1 / 3))
    assert off.cap_limit[0] == Limit.NCU_PATH_JERK
    assert off.cap_mm_s[0] == pytest.approx((J_TCURV * 900.0) ** (1 / 3))
    assert off.candidates["axis_jerk"][0] == np.inf
    # both off: the normal-acceleration guard sqrt(R * share * A_mx)
    both = path_limits(circle(30.0, 400.0), mikron,
                       ModelOptions(ncu_path_jerk=False, axis_jerk_setpoint=False))
    assert both.cap_limit[0] == Limit.AXIS_ACCEL
    assert both.cap_mm_s[0] == pytest.approx(math.sqrt(30.0 * SHARE * 2500.0))


def test_option_transition_crossing(mikron):
    path = transition_path(14.0, 16.0, 0.0)
    on = path_limits(path, mikron)
    off = path_limits(path, mikron, ModelOptions(transition_crossing=False))
    assert on.junction_limit[1] == Limit.TRANSITION
    assert on.junction_cap_mm_s[1] == pytest.approx(math.sqrt(112.0 * 5000.0 * T_CY))
    assert off.junction_limit[1] == Limit.NONE and off.junction_cap_mm_s[1] == np.inf


def test_option_cycle_time_limit(mikron):
    b = Builder().line([0, 0, 0], [0.1, 0, 0], 400.0)
    b.arcs((0.1, 0.0), 0.0, [1.0], 0.01, 400.0)
    path = b.build()
    on = path_limits(path, mikron)
    off = path_limits(path, mikron, ModelOptions(cycle_time_limit=False))
    np.testing.assert_allclose(on.cap_mm_s, [0.1 / T_CY, 0.01 / T_CY])
    assert on.cap_limit.tolist() == [Limit.CYCLE_TIME, Limit.CYCLE_TIME]
    assert off.cap_mm_s[0] == pytest.approx(400.0)
    # the 0.57-deg arc never carries J_tcurv: alpha_c at its largest J_t (the end), eq. 4
    assert off.cap_limit[1] == Limit.AXIS_JERK
    assert off.cap_mm_s[1] == pytest.approx((5000.0 / math.cos(0.01) * 1.0) ** (1 / 3))
    assert np.all(off.candidates["cycle_time"] == np.inf)


def test_option_jerk_limited_ramps_and_accel_modes(mikron):
    path = circle(30.0, 100.0)
    soft = path_limits(path, mikron)
    accel = soft.accel_mm_s2[0]
    for opts in (ModelOptions(jerk_limited_ramps=False), ModelOptions(accel_mode=BRISK)):
        lim = path_limits(path, mikron, opts)
        assert lim.jerk_mm_s3[0] == pytest.approx(accel / T_CY)
        assert lim.accel_mm_s2[0] == pytest.approx(accel)
        assert lim.cap_mm_s[0] == pytest.approx(soft.cap_mm_s[0])
    brisk_path = path.replace_columns(accel_mode=BRISK)
    assert path_limits(brisk_path, mikron).jerk_mm_s3[0] == pytest.approx(accel / T_CY)
    assert path_limits(brisk_path, mikron, ModelOptions(accel_mode=SOFT)).jerk_mm_s3[0] == \
        pytest.approx(5000.0)


def test_option_drive_reduces_accel_near_axis_velocity(mikron):
    # p = 0.5, r = 0.3 (machine file): a rapid X line at V_mx loses 30 %, a slow one nothing
    m = mikron.with_ncu(drive_speed_point_ratio=0.5, drive_accel_reduction_ratio=0.3)
    path = (Builder(accel_mode=DRIVE).line([0, 0, 0], [500, 0, 0], rapid=True)
            .line([500, 0, 0], [1000, 0, 0], 100.0)
            .line([1000, 0, 0], [1500, 0, 0], 375.0).build())
    lim = path_limits(path, m)
    np.testing.assert_allclose(lim.accel_mm_s2, [1750.0, 2500.0, 2500.0 * 0.85])
    np.testing.assert_allclose(lim.jerk_mm_s3, lim.accel_mm_s2 / T_CY)
    soft = path_limits(path, m, ModelOptions(accel_mode=SOFT))
    np.testing.assert_allclose(soft.accel_mm_s2, 2500.0)


def test_option_lookahead_is_left_to_the_planner(mikron):
    b = Builder()
    b.arcs((0.0, -10.0), 0.0, [10, 12, 14, 16], math.pi / 2, 100.0)
    path = b.build()
    a = path_limits(path, mikron)
    c = path_limits(path, mikron, ModelOptions(lookahead=False))
    for f in dataclasses.fields(PathLimits):
        if f.name == "candidates":
            for k in a.candidates:
                np.testing.assert_array_equal(a.candidates[k], c.candidates[k])
        else:
            np.testing.assert_array_equal(getattr(a, f.name), getattr(c, f.name))


# ---- junctions ----------------------------------------------------------------------------------

def test_stops_dwells_and_settle(mikron):
    m = mikron.with_ncu(exact_stop_fine_settle_s=0.05, exact_stop_coarse_settle_s=0.02)
    x = lambda a: [a, 0.0, 0.0]  # noqa: E731  collinear lines: no corner, no curvature jump
    b = Builder()
    b.line(x(0), x(1), 100.0, exact_stop=True, stop_window=601)   # ends at junction 1: fine
    b.line(x(1), x(2), 100.0, exact_stop=True, stop_window=602)   # junction 2: coarse
    b.line(x(2), x(3), 100.0, exact_stop=True, stop_window=603)   # junction 3: IPO end
    b.line(x(3), x(4), 100.0)
    b.line(x(4), x(5), 100.0, stop_before=True)                   # junction 4: M function
    b.line(x(5), x(6), 100.0, stop_before=True, dwell_before_s=0.5)  # junction 5: G4
    b.line(x(6), x(7), rapid=True)                                # junction 6: G1 -> G0
    b.line(x(7), x(8), rapid=True)                                # junction 7: smooth G0
    b.line(x(8), x(9), 100.0, exact_stop=True, stop_window=601)   # junction 8: G0 -> G1
    b.b.end_dwell_s = 1.5                                         # junction 9: end + settle
    lim = path_limits(b.build(), m)
    L = Limit
    assert lim.junction_limit.tolist() == [L.PROGRAM_END, L.EXACT_STOP, L.EXACT_STOP, L.EXACT_STOP,
                                           L.AUX_STOP, L.DWELL, L.AUX_STOP, L.NONE, L.AUX_STOP,
                                           L.PROGRAM_END]
    np.testing.assert_array_equal(lim.junction_cap_mm_s, [0, 0, 0, 0, 0, 0, 0, np.inf, 0, 0])
    np.testing.assert_allclose(lim.junction_dwell_s,
                               [0, 0.05, 0.02, 0, 0, 0.5, 0, 0, 0, 0.05 + 1.5])


def test_g64_corner_and_tolerance(mikron):
    lim = path_limits(Builder().line([0, 0, 0], [10, 0, 0], 100.0)
                      .line([10, 0, 0], [10, 10, 0], 100.0).build(), mikron)
    assert lim.junction_limit[1] == Limit.CORNER
    assert lim.junction_cap_mm_s[1] == pytest.approx(2500.0 * T_CY)   # X's jump, 30 mm/s
    # deflections on either side of 1e-4 rad
    for angle, corner in ((0.5e-4, False), (2e-4, True)):
        q = 10.0 * np.array([1.0 + math.cos(angle), math.sin(angle), 0.0])
        lim = path_limits(Builder().line([0, 0, 0], [10, 0, 0], 100.0)
                          .line([10, 0, 0], q, 100.0).build(), mikron)
        assert (lim.junction_limit[1] == Limit.CORNER) == corner
        assert np.isfinite(lim.junction_cap_mm_s[1]) == corner


def test_g64_ignores_adis_and_g60_stops(mikron):
    """ADIS belongs to G641 (ncsim.plan.blend, tests/test_blend.py); under G64 the corner is
    the overload factor's jump, under G60 an exact stop."""
    lim = path_limits(Builder(cp_mode=64, adis_mm=5.0).line([0, 0, 0], [100, 0, 0], 1000.0)
                      .line([100, 0, 0], [100, 100, 0], 1000.0).build(), mikron)
    assert lim.path.n == 2 and lim.junction_cap_mm_s[1] == pytest.approx(30.0)
    g60 = path_limits(Builder(cp_mode=60).line([0, 0, 0], [10, 0, 0], 100.0, exact_stop=True)
                      .line([10, 0, 0], [10, 10, 0], 100.0).build(), mikron)
    assert g60.junction_cap_mm_s[1] == 0.0 and g60.junction_limit[1] == Limit.EXACT_STOP


def test_smooth_junctions(mikron):
    # line -> tangent arc: sqrt(R J_t dt) with the tangent along X
    b = Builder().line([-10, -10, 0], [0, -10, 0], 100.0)
    b.arcs((0.0, -10.0), 0.0, [10.0], math.pi / 2, 100.0)
    lim = path_limits(b.build(), mikron)
    assert lim.junction_limit[1] == Limit.TRANSITION
    assert lim.junction_cap_mm_s[1] == pytest.approx(math.sqrt(10.0 * 5000.0 * T_CY))
    # one circle split in two equal arcs, and collinear lines: nothing
    b = Builder()
    b.arcs((0.0, -10.0), 0.0, [10.0, 10.0], math.pi, 100.0)
    b.line([0.0, -10.0, 0.0], [5.0, -10.0, 0.0], 100.0)
    b.line([5.0, -10.0, 0.0], [9.0, -10.0, 0.0], 100.0)
    lim = path_limits(b.build(), mikron)
    assert lim.junction_limit[1:4].tolist() == [Limit.NONE, Limit.TRANSITION, Limit.NONE]
    assert lim.junction_cap_mm_s[1] == np.inf and lim.junction_cap_mm_s[3] == np.inf
    # S-bend (reversal of the curvature): R1 R2 / (R1 + R2)
    b = Builder()
    end, ang = b.arcs((0.0, 0.0), 0.0, [14.0], math.pi / 2, 100.0, ccw=True)
    b.arcs(end[:2], ang, [16.0], math.pi / 2, 100.0, ccw=False)
    lim = path_limits(b.build(), mikron)
    assert lim.junction_cap_mm_s[1] == pytest.approx(math.sqrt(14 * 16 / 30 * 5000.0 * T_CY))


# ---- vectorisation --------------------------------------------------------------------------------

def _mixed_path(rng, n_arcs=120):
    b = Builder()
    for i in range(n_arcs):
        kind = i % 4
        start = rng.uniform(-50, 50, 2)
        if kind == 3:
            p = np.array([*start, 0.0])
            b.line(p, p + rng.uniform(-20, 20, 3), rng.uniform(10, 500))
            continue
        sweep = [rng.uniform(1e-4, 0.05), rng.uniform(0.05, 3.0), rng.uniform(3.0, 6.28)][kind]
        b.arcs(start, rng.uniform(0, 2 * math.pi), [rng.uniform(0.5, 300)], sweep,
               rng.uniform(10, 500), ccw=bool(rng.integers(2)))
    pb = b.b  # a helix of 2.5 turns in G19 and one in G18
    pb.add_arc([0, 5, 0], [0, 5, 7.5], [0, 0, 0], [0, 0, 1.0], 5.0, 5 * math.pi, 7.5,
               line=900, feed_mm_s=300.0, cp_mode=64)
    pb.add_arc([0, 0, 4], [0, 0, 4], [0, 0, 0], [1.0, 0, 0], 4.0, 2 * math.pi, 0.0,
               line=901, feed_mm_s=300.0, cp_mode=64)
    pb.add_arc([0, 0, 4], [1, 0, 4], [0, 0, 0], [0, -1.0, 0], 4.0, 2 * math.pi, 1.0,
               line=902, feed_mm_s=300.0, cp_mode=64)
    return b.build()


def test_whole_path_equals_block_by_block(mikron, monkeypatch):
    """Chunking does not mix blocks up: every block's limits are those of the block alone, and
    a tiny chunk size gives the same arrays (junctions across chunk borders included)."""
    path = _mixed_path(np.random.default_rng(3))
    whole = path_limits(path, mikron)
    keys = ("cap_mm_s", "cap_limit", "jerk_mm_s3", "accel_mm_s2", "alpha_c_rad")
    for i in range(path.n):
        one = path_limits(path.select(slice(i, i + 1)), mikron)
        for key in keys:
            np.testing.assert_allclose(getattr(one, key)[0], getattr(whole, key)[i], rtol=1e-12,
                                       err_msg=f"{key} of block {i}")
        for label in CANDIDATE_LABELS:
            np.testing.assert_allclose(one.candidates[label][0], whole.candidates[label][i],
                                       rtol=1e-12)
    monkeypatch.setattr(limits_mod, "CHUNK_BLOCKS", 7)
    small = path_limits(path, mikron)
    for key in keys + ("junction_cap_mm_s", "junction_limit", "junction_dwell_s"):
        np.testing.assert_array_equal(getattr(small, key), getattr(whole, key))


def test_large_path_is_vectorised(mikron):
    """100 000 blocks (half arcs) in well under a second here: no per-block Python work (the
    bound is loose for shared machines)."""
    n = 50_000
    rng = np.random.default_rng(1)
    ang = np.cumsum(rng.uniform(-0.05, 0.05, n))
    step = np.stack([np.cos(ang), np.sin(ang), np.zeros(n)], 1) * 0.2
    pts = np.vstack([[0, 0, 0], np.cumsum(step, 0)])
    pb = PathBuilder()
    pb.extend(kind=np.zeros(n, np.int8), start_mm=pts[:-1], end_mm=pts[1:],
              length_mm=np.full(n, 0.2), line=np.arange(n), feed_mm_s=200.0, cp_mode=642,
              adis_mm=0.05)
    r = rng.uniform(1.0, 50.0, n)
    sweep = rng.uniform(0.001, 0.5, n)
    c = np.zeros((n, 3))
    start = np.stack([r, np.zeros(n), np.zeros(n)], 1)
    end = np.stack([r * np.cos(sweep), r * np.sin(sweep), np.zeros(n)], 1)
    pb.extend(kind=np.ones(n, np.int8), start_mm=start, end_mm=end, center_mm=c,
              normal=np.tile([0.0, 0.0, 1.0], (n, 1)), radius_mm=r, sweep_rad=sweep,
              length_mm=r * sweep, line=np.arange(n), feed_mm_s=200.0, cp_mode=64)
    path = pb.build()
    t0 = time.perf_counter()
    lim = path_limits(path, mikron)
    elapsed = time.perf_counter() - t0
    assert lim.n_blocks == 2 * n
    assert np.all(np.isfinite(lim.cap_mm_s)) and np.all(lim.accel_mm_s2 > 0)
    assert elapsed < 20.0
