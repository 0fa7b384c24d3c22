"""G641/G642/G643/G645 corner rounding (ncsim.plan.blend) against independent computations.

The clothoid pair is integrated numerically here (no Fresnel integrals), the feeds are the
paper's closed forms written out with the MIKRON's numbers typed in (Table 1, J_tcurv =
6 m/s^3, t_cy = 12 ms, normal-acceleration share 0.75), and the rules (when a corner is
rounded, how far the rounding reaches) are the 840D manual's (B1, continuous-path mode).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from ncsim.machine import load_machine
from ncsim.motion import Limit, ModelOptions
from ncsim.path import ARC, BRISK, LINE, SOFT, PathBuilder
from ncsim.pipeline import simulate
from ncsim.plan.blend import clothoid_pair_shape
from ncsim.plan.crosscheck import crosscheck
from ncsim.plan.limits import block_limits, path_limits
from ncsim.plan.sample import sample_motion

T_CY = 0.012
J_TCURV = 6000.0
LINE_COLS = dict(center_mm=np.full(3, np.nan), normal=np.zeros(3))


@pytest.fixture(scope="module")
def m12():
    """The MIKRON with the usual overload factor 1.2: a G64 corner allows 6 mm/s on X."""
    return load_machine("mikron").with_axes(max_accel_ovl_factor=1.2)


@pytest.fixture(scope="module")
def m10():
    """The MIKRON with MD32310 = 1: G64 crosses a corner at rest ("only tangential transitions
    at finite velocity"), so a rounding saves time and is inserted (``blend`` keeps a G64
    corner where the rounding would be slower than it)."""
    return load_machine("mikron").with_axes(max_accel_ovl_factor=1.0)


def clothoid_pair_numeric(phi, steps=200_000):
    """(d, e) per unit length of the symmetric clothoid pair turning by phi, by integrating
    x' = cos(theta), y' = sin(theta), theta' = kappa(s) (triangular kappa) with the midpoint
    rule, then intersecting the end tangents: d = distance of the ends from the corner, e =
    distance of the middle point from it."""
    s = (np.arange(steps) + 0.5) / steps
    kappa = 2.0 * phi * (1.0 - np.abs(2.0 * s - 1.0))           # peak 2 phi / L at s = 1/2
    theta = np.concatenate([[0.0], np.cumsum(kappa) / steps])
    mid_theta = 0.5 * (theta[:-1] + theta[1:])
    x = np.concatenate([[0.0], np.cumsum(np.cos(mid_theta)) / steps])
    y = np.concatenate([[0.0], np.cumsum(np.sin(mid_theta)) / steps])
    end = np.array([x[-1], y[-1]])
    # the corner: (c, 0) on the start tangent, on the end tangent through `end`
    c = end[0] - end[1] / math.tan(phi)
    middle = np.array([x[steps // 2], y[steps // 2]])
    return c, math.hypot(*(middle - [c, 0.0])), math.hypot(*(end - [c, 0.0]))


@pytest.mark.parametrize("phi_deg", [2.0, 30.0, 90.0, 150.0])
def test_clothoid_pair_shape_matches_numerical_integration(phi_deg):
    phi = math.radians(phi_deg)
    d_start, e, d_end = clothoid_pair_numeric(phi)
    g, h = clothoid_pair_shape(phi)
    assert d_start == pytest.approx(d_end, rel=1e-6)              # symmetric
    assert g == pytest.approx(d_start, rel=1e-6)
    assert h == pytest.approx(e, rel=1e-5)


def test_clothoid_pair_small_angles():
    """phi -> 0: the ends are L/2 from the corner, the middle phi L / 12 from it."""
    g, h = clothoid_pair_shape(np.array([0.0, 1e-4]))
    np.testing.assert_allclose(g, [0.5, 0.5], rtol=1e-6)
    np.testing.assert_allclose(h, [0.0, 1e-4 / 12], rtol=1e-5)


def corner_path(direction, length=20.0, feed_mm_s=100.0, cp_mode=642, **modal):
    """Two lines from the origin along +X, then along ``direction``."""
    a = np.array([length, 0.0, 0.0])
    b = a + length * np.asarray(direction, float) / np.linalg.norm(direction)
    pb = PathBuilder()
    common = dict(cp_mode=cp_mode, accel_mode=SOFT) | modal
    pb.add_line([0, 0, 0], a, line=1, feed_mm_s=feed_mm_s, **LINE_COLS, **common)
    pb.add_line(a, b, line=2, feed_mm_s=feed_mm_s, **LINE_COLS, **common)
    return pb.build()


def expected_rounding(phi, tol, jerk=True, ncu=True):
    """The rounding of a corner turning by phi in XY from +X within ``tol`` along its bisector:
    clothoid pair from the numerical integration, feeds from eq. 2/8, 11, 4/9 and the eq. 13
    spread, eq. 6 on the rounding distance (closed forms typed in here)."""
    d_unit, e_unit, _ = clothoid_pair_numeric(phi)
    length = tol / e_unit
    d = d_unit * length
    kappa = 2.0 * phi / length
    n_mid = np.array([math.cos(phi) - 1.0, math.sin(phi)])
    n_mid /= np.linalg.norm(n_mid)
    a_n = 0.75 * min(2500.0 / abs(n_mid[0]) if n_mid[0] else np.inf,
                     3000.0 / abs(n_mid[1]) if n_mid[1] else np.inf)
    feeds = [math.sqrt(a_n / kappa), d / T_CY]
    if jerk:
        t_mid = np.array([1.0 + math.cos(phi), math.sin(phi)])
        t_mid /= np.linalg.norm(t_mid)
        j_mid = min(5000.0 / abs(t_mid[0]) if t_mid[0] else np.inf,
                    5000.0 / abs(t_mid[1]) if t_mid[1] else np.inf)
        j_t = min(5000.0, 5000.0 / max(abs(math.cos(phi)), abs(math.sin(phi))))
        feeds += [(j_mid / kappa ** 2) ** (1 / 3),
                  max(math.sqrt(j_t * T_CY / kappa), (j_t * length / 2 / kappa) ** (1 / 3))]
        if ncu:
            feeds.append((J_TCURV / kappa ** 2) ** (1 / 3))
    return min(feeds), d, length


def test_g642_corner_becomes_a_rounding_block_within_tolerance(m10):
    """90 deg corner, CTOL 0.1: a rounding block inserted, the lines shortened, its deviation
    from the corner = the tolerance, its feed the clothoid's (here eq. 11, the NCU path jerk).
    F just above that feed: the rounding takes less time than G64's stop at the corner (at F
    100 mm/s it would take longer: planned at its peak-curvature feed over its 0.84 mm, it is
    kept as a G64 corner then, ``test_hsm_properties``)."""
    v, d, _ = expected_rounding(math.pi / 2, 0.1)
    path = corner_path([0, 1, 0], ctol_mm=0.1, feed_mm_s=1.1 * v)
    lim = path_limits(path, m10)
    p = lim.path
    assert p.n == 3 and list(p.kind) == [LINE, ARC, LINE] and list(p.line) == [1, 1, 2]
    assert lim.cap_mm_s[1] == pytest.approx(v, rel=1e-4)
    assert v == pytest.approx((J_TCURV / (math.pi / (0.1 / clothoid_pair_numeric(math.pi / 2)[1])) ** 2) ** (1 / 3), rel=1e-6)
    assert lim.cap_limit[1] == Limit.CORNER
    # the junctions of the rounding are smooth (curvature-continuous: no corner, no eq. 13)
    assert np.all(np.isinf(lim.junction_cap_mm_s[1:3]))
    # the stand-in arc: tangent to both lines, its middle 0.1 from the corner, inside the rounding
    arc = p.segment(1)
    corner = np.array([20.0, 0.0, 0.0])
    mid = arc.center_mm + arc.radius_mm * (corner - arc.center_mm) / np.linalg.norm(corner - arc.center_mm)
    assert np.linalg.norm(mid - corner) == pytest.approx(0.1, rel=1e-9)
    tangent_length = 20.0 - p.length_mm[0]
    assert tangent_length < d
    assert p.end_mm[0].tolist() == pytest.approx([20.0 - tangent_length, 0, 0])
    assert p.start_mm[2].tolist() == pytest.approx([20.0, tangent_length, 0])
    # the path is shortened by 2 x tangent length - arc length
    r = tangent_length / math.tan(math.pi / 4)
    assert p.total_length_mm == pytest.approx(40.0 - 2 * tangent_length + r * math.pi / 2)


def test_rounding_feed_under_the_axis_limits(m10):
    """Without the NCU jerk and with a loose tolerance the axes decide; under BRISK only the
    acceleration limits (no jerk limit in the smoothing range, MD20480)."""
    no_ncu = ModelOptions(ncu_path_jerk=False)
    for phi_deg in (30.0, 90.0, 135.0):
        phi = math.radians(phi_deg)
        v, _, _ = expected_rounding(phi, 0.05, ncu=False)
        path = corner_path([math.cos(phi), math.sin(phi), 0], ctol_mm=0.05, feed_mm_s=1.1 * v)
        lim = path_limits(path, m10, no_ncu)
        assert lim.path.n == 3 and lim.cap_mm_s[1] == pytest.approx(v, rel=1e-4), phi_deg
    # BRISK: eq. 2/8 and d / t_cy only
    v, _, _ = expected_rounding(math.pi / 2, 0.1, jerk=False)
    path = corner_path([0, 1, 0], ctol_mm=0.1, accel_mode=BRISK, feed_mm_s=1.1 * v)
    lim = path_limits(path, m10)
    assert lim.cap_mm_s[1] == pytest.approx(v, rel=1e-4)


def test_g641_rounds_by_adis_and_the_ipo_cycle_bounds_it(m10, m12):
    """G641: the rounding ends ADIS from the corner; ADIS / t_cy bounds its feed (B1 G641)."""
    adis = 2.0
    g, h = clothoid_pair_shape(math.pi / 2)
    kappa = 2 * (math.pi / 2) / (adis / g)
    v = (J_TCURV / kappa ** 2) ** (1 / 3)
    lim = path_limits(corner_path([0, 1, 0], cp_mode=641, adis_mm=adis, feed_mm_s=1.1 * v), m10)
    assert lim.path.n == 3
    assert lim.cap_mm_s[1] == pytest.approx(v, rel=1e-6)
    # a tiny ADIS: d / t_cy = 0.05 / 0.012 = 4.17 mm/s, reported as cycle_time (F just above:
    # at a high F this rounding would take longer than G64's stop and is not inserted)
    axes_only = ModelOptions(ncu_path_jerk=False, axis_jerk_setpoint=False,
                             transition_crossing=False)
    lim = path_limits(corner_path([1, 1, 0], cp_mode=641, adis_mm=0.05, feed_mm_s=4.5), m10,
                      axes_only)
    assert lim.cap_mm_s[1] == pytest.approx(0.05 / T_CY) and lim.cap_limit[1] == Limit.CYCLE_TIME
    # G641 without ADIS behaves like G64
    lim = path_limits(corner_path([0, 1, 0], cp_mode=641, adis_mm=0.0), m12)
    assert lim.path.n == 2 and lim.junction_cap_mm_s[1] == pytest.approx(6.0)


def test_rounding_only_where_g64_would_slow_down(m12):
    """B1: no rounding block "if a block transition with G64 can be traversed without a
    reduction in velocity" -- MD32310 decides; G643 rounds regardless. (CTOL 0.1: a rounding
    that is faster than the G64 corner; a 0.01 mm rounding of 10 deg, at 29 mm/s by eq. 11, is
    slower than G64's 41.5 mm/s and stays a G64 corner in every case.)"""
    # 10 deg at 100 mm/s: the G64 jump allows 0.2*2500*0.012 / sin(10deg)... per axis
    phi = math.radians(10)
    dt = np.array([math.cos(phi) - 1, math.sin(phi)])
    v64 = min(6.0 / abs(dt[0]), 7.2 / abs(dt[1]))
    assert v64 < 100.0
    turn = [math.cos(phi), math.sin(phi), 0]
    slow = path_limits(corner_path(turn, feed_mm_s=100.0, ctol_mm=0.1), m12)
    assert slow.path.n == 3
    fast = path_limits(corner_path(turn, feed_mm_s=0.9 * v64, ctol_mm=0.1), m12)
    assert fast.path.n == 2 and fast.junction_cap_mm_s[1] == pytest.approx(v64)
    g643 = path_limits(corner_path(turn, feed_mm_s=0.9 * v64, cp_mode=643, ctol_mm=0.1), m12)
    assert g643.path.n == 3
    # MD20490 IGNORE_OVL_FACTOR_FOR_ADIS makes G642 do the same
    ignore = m12.with_ncu(ignore_ovl_factor_for_adis=True)
    assert path_limits(corner_path(turn, feed_mm_s=0.9 * v64, ctol_mm=0.1), ignore).path.n == 3
    tight = path_limits(corner_path(turn, feed_mm_s=100.0), m12)     # MD33100 0.01 mm
    assert tight.path.n == 2 and tight.junction_cap_mm_s[1] == pytest.approx(v64)


def test_no_rounding_between_very_short_blocks_nor_across_stops(m12):
    """Blocks shorter than their feed covers in one IPO cycle (100 mm/s x 12 ms = 1.2 mm) keep a
    G64 corner (implicit G64); a stop (G60/G9, M output) is never rounded."""
    short = path_limits(corner_path([0, 1, 0], length=1.0, feed_mm_s=100.0), m12)
    assert short.path.n == 2 and short.junction_cap_mm_s[1] == pytest.approx(6.0)
    stop = corner_path([0, 1, 0], exact_stop=True)
    assert path_limits(stop, m12).path.n == 2


def test_rounding_distance_keeps_60_percent_of_short_blocks(m12):
    """B1 G641: "ADIS is reduced to the remaining 40 %" of the distance to be traversed: on
    3-mm blocks with ADIS 5 the first corner rounds 0.4 x 3 = 1.2 mm, the second 0.4 x the
    1.8 mm left of the shared block = 0.72 mm (at F 10 mm/s, where both roundings take less
    time than G64's stops)."""
    pb = PathBuilder()
    pts = [[0, 0, 0], [3, 0, 0], [3, 3, 0], [0, 3, 0]]
    for i in range(3):
        pb.add_line(pts[i], pts[i + 1], line=i + 1, feed_mm_s=10.0, cp_mode=641, adis_mm=5.0,
                    accel_mode=SOFT, **LINE_COLS)
    lim = path_limits(pb.build(), load_machine("mikron").with_axes(max_accel_ovl_factor=1.0))
    p = lim.path
    assert list(p.kind) == [LINE, ARC, LINE, ARC, LINE]
    g, h = clothoid_pair_shape(math.pi / 2)
    # the stand-in arc's tangent length is e / tan(phi / 4) with e = h L, L = d / g
    for row, d in ((1, 1.2), (3, 0.72)):
        e = h * d / g
        arc = p.segment(row)
        assert arc.radius_mm * math.tan(math.pi / 4) == pytest.approx(e / math.tan(math.pi / 8))
    assert p.length_mm[2] > 0.0


def test_g645_smooths_tangential_curvature_jumps(m12):
    """G645: a line -> arc transition (curvature 0 -> 1/R) spread over l = sqrt(24 tol / dk)
    (a curvature step smoothed linearly over l moves the path by dk l^2 / 24), MD33120 0.005:
    crossed at max(eq. 13, (J l / dk)^(1/3)) instead of eq. 13."""
    radius = 10.0
    pb = PathBuilder()
    pb.add_line([-20, -radius, 0], [0, -radius, 0], line=1, feed_mm_s=200.0, cp_mode=645,
                accel_mode=SOFT, **LINE_COLS)
    pb.add_arc([0, -radius, 0], [radius, 0, 0], [0, 0, 0], [0, 0, 1], radius, math.pi / 2,
               line=2, feed_mm_s=200.0, cp_mode=645, accel_mode=SOFT)
    path = pb.build()
    dk = 1 / radius
    ell = math.sqrt(24 * 0.005 / dk)
    j_t = 5000.0                                          # tangent +X: J_mx
    eq13 = math.sqrt(j_t * T_CY / dk)
    lim = path_limits(path, m12)
    assert lim.path.n == 2
    assert block_limits(path, m12).junction_cap_mm_s[1] == pytest.approx(eq13)
    assert lim.junction_cap_mm_s[1] == pytest.approx(max(eq13, (j_t * ell / dk) ** (1 / 3)))
    g642 = path.replace_columns(cp_mode=642)
    assert path_limits(g642, m12).junction_cap_mm_s[1] == pytest.approx(eq13)


def test_corner_with_an_arc_is_rounded_in_time_only(m10):
    """A line meeting an arc at an angle: the crossing feed is the rounding's, the geometry stays
    (the Path has no curvature-continuous element to put there)."""
    radius, phi = 5.0, math.radians(60)
    t2 = np.array([math.cos(phi), math.sin(phi), 0.0])
    start = np.array([20.0, 0.0, 0.0])
    center = start + radius * np.array([-t2[1], t2[0], 0.0])      # CCW arc leaving along t2
    end = center + radius * (start - center) @ np.array([[0, 1, 0], [-1, 0, 0], [0, 0, 1.0]])
    pb = PathBuilder()
    pb.add_line([0, 0, 0], start, line=1, feed_mm_s=100.0, cp_mode=642, accel_mode=SOFT,
                ctol_mm=0.05, **LINE_COLS)
    pb.add_arc(start, end, center, [0, 0, 1], radius, math.pi / 2, line=2, feed_mm_s=100.0,
               cp_mode=642, accel_mode=SOFT, ctol_mm=0.05)
    lim = path_limits(pb.build(), m10)
    v, _, _ = expected_rounding(phi, 0.05)
    assert lim.path.n == 2
    assert lim.junction_cap_mm_s[1] == pytest.approx(v, rel=1e-4)
    assert lim.junction_limit[1] == Limit.CORNER


def program(mode_words: str, feed_mm_min: float = 6000) -> str:
    """A zig-zag of 20 mm lines with 60 and 120 degree corners."""
    lines = [f"G17 G90 G71 {mode_words}", f"G1 X0 Y0 F{feed_mm_min:g}"]
    x, y = 0.0, 0.0
    for i in range(12):
        x += 20.0
        y += 10.0 if i % 2 else -10.0
        lines.append(f"X{x:.3f} Y{y:.3f}")
    return "\n".join(lines + ["M30"]) + "\n"


def test_rounded_plan_is_checked_by_ruckig_and_stays_within_the_tolerance(m10):
    """The sampled path stays within CTOL of the programmed corners, and ruckig finds no block
    of the plan breaking its limits (F1200: there the roundings beat G64's stops; at F6000
    they would take longer and the corners stay G64 corners)."""
    sim = simulate("zigzag.mpf", m10, text=program("G642 CTOL=0.03 SOFT", 1200))
    assert np.sum(sim.path.kind == ARC) == 11
    report = crosscheck(sim.motion)
    assert report.summary()["violations"] == 0 and report.summary()["faster_than_optimum"] == 0
    trace = sample_motion(sim.motion, 0.001)
    # distance of every sample to the programmed polyline
    pts = np.array([[0.0, 0.0]] + [[20.0 * (i + 1), (-10.0 if i % 2 == 0 else 0.0)]
                                   for i in range(12)])
    xy = trace.pos_mm[:, :2]
    dist = np.full(len(xy), np.inf)
    for p, q in zip(pts[:-1], pts[1:]):
        d = q - p
        t = np.clip(((xy - p) @ d) / (d @ d), 0.0, 1.0)
        dist = np.minimum(dist, np.linalg.norm(xy - (p + t[:, None] * d), axis=1))
    assert dist.max() <= 0.03 + 1e-9
    assert dist.max() > 0.02            # the rounding does cut the corners
    g64 = simulate("zigzag.mpf", m10, text=program("G64 SOFT", 1200))
    assert sim.cycle_time_s < g64.cycle_time_s
    assert g64.path.n == 12 and sim.path.total_length_mm < g64.path.total_length_mm
