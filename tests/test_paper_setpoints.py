"""The paper's set points and crossing feeds, from path_limits on the paper's test paths.

Every expected number below is printed in the paper (Table 3, §5.2.4, §5.3.1, §5.4.1) or is a
closed form written here; the tolerance is 0.5 % unless the paper gives fewer digits. Values the
paper withholds (Fig. 17 surveys, §6 feed limits and crossing feeds, Table 5) are not tested.
The paths are built here with PathBuilder, with the geometry of programs/*.mpf; the programs
themselves are checked at the end, through the interpreter once it exists.
"""
from __future__ import annotations

import math
import re
from pathlib import Path as FsPath

import numpy as np
import pytest

from ncsim.nc.interpret import interpret_file

from ncsim.plan.limits import path_limits
from ncsim.motion import Limit
from ncsim.path import Path, PathBuilder

M_MIN = 1000.0 / 60.0
T_CY = 0.012
PROGRAMS = FsPath(__file__).resolve().parent.parent / "programs"


def rel(a, b):
    return abs(a - b) / abs(b)


def m_min(v_mm_s):
    return v_mm_s / M_MIN


def tangent_arcs(start_xy, alpha0_rad, radii, sweep_rad, feed_m_min, rotation_rad=0.0):
    """CCW arcs, each tangent to the next, leaving ``start_xy`` at tangent angle alpha0, the
    whole figure rotated by ``rotation_rad`` about the origin (the inclined spirals)."""
    def rot(v, a):
        c, s = math.cos(a), math.sin(a)
        return np.array([c * v[0] - s * v[1], s * v[0] + c * v[1], 0.0])

    b = PathBuilder()
    p = rot(start_xy, rotation_rad)
    t = rot((math.cos(alpha0_rad), math.sin(alpha0_rad)), rotation_rad)
    for i, r in enumerate(radii):
        c = p + r * np.array([-t[1], t[0], 0.0])
        e = c + rot(p - c, sweep_rad)
        b.add_arc(p, e, c, [0.0, 0.0, 1.0], r, sweep_rad, line=i + 1,
                  feed_mm_s=feed_m_min * M_MIN, cp_mode=64, ffw=True)
        t, p = rot(t, sweep_rad), e
    return b.build()


def circle(radius, feed_m_min):
    """The simple circle: from (0, -R) along +X, one full CCW turn."""
    return tangent_arcs((0.0, -radius), 0.0, [radius], 2 * math.pi, feed_m_min)


SEMI_RADII = [10, 15, 20, 25, 30]            # Table 2: 10 to 30 in steps of 5
QUARTER_RADII = list(range(10, 31, 2))       # Table 2: 10 to 30 in steps of 2


def semi_spiral(feed_m_min):
    return tangent_arcs((0.0, -10.0), 0.0, SEMI_RADII, math.pi, feed_m_min)


def quarter_spiral(feed_m_min, inclination_deg=0.0):
    return tangent_arcs((0.0, -10.0), 0.0, QUARTER_RADII, math.pi / 2, feed_m_min,
                        math.radians(inclination_deg))


# ---- Table 3 and §5.2.4: simple circles ------------------------------------------------------------

TABLE3 = {  # programmed m/min -> measured m/min (Table 3)
    2.5: {6: 2.01, 9: 2.01, 12: 2.01, 24: 2.01},
    30.0: {6: 6.01, 9: 9.01, 12: 10.53, 24: 10.53},
}


@pytest.mark.parametrize("radius", [2.5, 30.0])
@pytest.mark.parametrize("feed", [6, 9, 12, 24])
def test_table3_circle_set_points(mikron, radius, feed):
    lim = path_limits(circle(radius, feed), mikron)
    paper = TABLE3[radius][feed]
    assert rel(m_min(lim.cap_mm_s[0]), paper) < 0.005
    # why: the programmed feed when it is below V_Jtcurv, else the NCU path jerk (§5.2.4)
    expected = Limit.PROGRAMMED if feed < paper + 0.5 else Limit.NCU_PATH_JERK
    assert lim.cap_limit[0] == expected


def test_5_2_4_worked_example_r2_5(mikron):
    """R 2.5 at 6 m/min: alpha_c = 33.5 deg, V_Jt(alpha_c) = V_Jtcurv = 2.01, V_tcy = 78.5,
    V_st = V_Jtcurv = 2.01 m/min; jerk of phases A/C = min J_t = 5 m/s^3 (§5.2.2)."""
    lim = path_limits(circle(2.5, 6), mikron)
    assert np.rad2deg(lim.alpha_c_rad[0]) == pytest.approx(33.5, abs=0.1)
    # the axis limits at that position (eq. 2, 7, 8 at alpha_c): 5.7 and 36 m/min
    a_c = lim.alpha_c_rad[0]
    a_n = min(2500.0 / abs(math.sin(a_c)), 3000.0 / abs(math.cos(a_c)))
    assert rel(m_min(math.sqrt(2.5 * a_n)), 5.7) < 0.005
    assert rel(m_min(min(500.0 / abs(math.cos(a_c)), 500.0 / abs(math.sin(a_c)))), 36.0) < 0.005
    cand = {k: m_min(v[0]) for k, v in lim.candidates.items()}
    assert rel(cand["ncu_path_jerk"], 2.01) < 0.005
    assert rel(cand["axis_jerk"], 2.01) < 0.005                 # V_Jt(alpha_c) = V_Jtcurv
    assert rel(cand["cycle_time"], 78.5) < 0.005
    assert cand["programmed"] == pytest.approx(6.0)
    assert rel(m_min(lim.cap_mm_s[0]), 2.01) < 0.005
    assert lim.jerk_mm_s3[0] == pytest.approx(5000.0)


def test_5_2_1_r30_holds_more_than_min_v_jt(mikron):
    """Table 3 vs Fig. 9: R 30 holds 10.53 m/min although min over alpha of V_Jt is 9.9."""
    lim = path_limits(circle(30.0, 24), mikron)
    min_v_jt = m_min((5000.0 * 30.0 ** 2) ** (1 / 3))
    assert rel(min_v_jt, 9.9) < 0.005
    assert m_min(lim.cap_mm_s[0]) > min_v_jt


# ---- §5.3: non-inclined spirals at 6 m/min ------------------------------------------------------------

def test_5_3_1_semicircular_spiral_set_points(mikron):
    """First arc R 10: 5.06 m/min (programmed 6 not reached); 6 m/min on the next radii."""
    lim = path_limits(semi_spiral(6), mikron)
    assert rel(m_min(lim.cap_mm_s[0]), 5.06) < 0.005
    np.testing.assert_allclose(m_min(lim.cap_mm_s[1:]), 6.0, rtol=1e-9)


def test_5_3_1_quarter_spiral_set_points(mikron):
    lim = path_limits(quarter_spiral(6), mikron)
    for i, paper in enumerate((5.06, 5.71, 6.0)):               # R 10, 12, 14
        assert rel(m_min(lim.cap_mm_s[i]), paper) < 0.005
    np.testing.assert_allclose(m_min(lim.cap_mm_s[2:]), 6.0, rtol=1e-9)


def test_5_3_2_semicircular_transitions(mikron):
    """Transitions drop the feed (eq. 13, J_t = 5 m/s^3 at tangent 0/180 deg); the second
    (15 -> 20) is higher than the first (10 -> 15) for the same 5 mm jump."""
    lim = path_limits(semi_spiral(6), mikron)
    assert lim.junction_limit[1:-1].tolist() == [Limit.TRANSITION] * 4
    v = lim.junction_cap_mm_s[1:-1]
    for (r1, r2), got in zip(zip(SEMI_RADII, SEMI_RADII[1:]), v):
        assert got == pytest.approx(math.sqrt(r1 * r2 * 5000.0 * T_CY / abs(r1 - r2)))
    assert v[1] > v[0]


def test_5_3_2_quarter_spiral_transitions_stop_costing_after_r16(mikron):
    """Fig. 15: from the R 18 arc on, the crossing feed is above the programmed 6 m/min
    (V_fr >= V_prog: no feed loss)."""
    lim = path_limits(quarter_spiral(6), mikron)
    v = m_min(lim.junction_cap_mm_s[1:-1])
    after_r18 = v[QUARTER_RADII.index(18):]
    assert np.all(after_r18 > 6.0)
    assert np.all(v[:QUARTER_RADII.index(16)] < 6.0)


# ---- §5.4: inclined quarter spirals at 12 m/min ---------------------------------------------------------

@pytest.mark.parametrize("inclination, paper", [(0, 4.92), (30, 5.29), (45, 5.85)])
def test_5_4_1_transition_14_to_16(mikron, inclination, paper):
    lim = path_limits(quarter_spiral(12, inclination), mikron)
    k = QUARTER_RADII.index(16)                 # junction k: start of the R 16 arc
    assert lim.junction_limit[k] == Limit.TRANSITION
    assert rel(m_min(lim.junction_cap_mm_s[k]), paper) < 0.002


def test_5_4_crossing_feeds_grow_with_the_inclination(mikron):
    """§5.4.1 / 5.4.3: V_fr(0) < V_fr(30) < V_fr(45) at every transition (incl. around R 18)."""
    v = np.array([path_limits(quarter_spiral(12, a), mikron).junction_cap_mm_s[1:-1]
                  for a in (0, 30, 45)])
    assert np.all(v[0] < v[1]) and np.all(v[1] < v[2])
    # the set points do not depend on the inclination (V_Jtcurv, Table 3's mechanism)
    caps = [path_limits(quarter_spiral(12, a), mikron).cap_mm_s for a in (0, 30, 45)]
    np.testing.assert_allclose(caps[1], caps[0], rtol=1e-9)
    np.testing.assert_allclose(caps[2], caps[0], rtol=1e-9)


# ---- the programs -----------------------------------------------------------------------------------

EXPECTED_PROGRAMS = (
    [f"circle_r{r}_f{f}.mpf" for r in ("2p5", "30") for f in (6000, 9000, 12000, 24000)]
    + [f"spiral_{k}_f{f}.mpf" for k in ("semi", "quarter") for f in (6000, 9000, 12000, 24000)]
    + ["spiral_quarter_rot30_f12000.mpf", "spiral_quarter_rot45_f12000.mpf"]
    + [f"bore_d25_f{f}.mpf" for f in (5984, 7385, 8531)]
    + [f"bore_d80_f{f}.mpf" for f in (6748, 9549, 11968)]
)


def test_every_program_exists_and_names_its_figure():
    names = sorted(p.name for p in PROGRAMS.glob("*.mpf"))
    assert set(EXPECTED_PROGRAMS) <= set(names)
    for name in names:  # every bundled program says what it is for in its first line
        assert (PROGRAMS / name).read_text(encoding="ascii").startswith(";"), name
    for name in sorted(EXPECTED_PROGRAMS):
        text = (PROGRAMS / name).read_text(encoding="ascii")   # plain ASCII for the 840D
        first = text.splitlines()[0]
        assert first.startswith("; Paper:") and re.search(r"(Fig\.|Table) \d", first), name
        assert "G17 G90 G64 SOFT FFWON" in text and text.rstrip().endswith("M30"), name


def _interpret(name, machine) -> Path:
    return interpret_file(PROGRAMS / name, machine).path


def _feed_arcs(path: Path) -> np.ndarray:
    return np.nonzero(path.kind == 1)[0]


@pytest.mark.parametrize("radius, rname", [(2.5, "2p5"), (30.0, "30")])
@pytest.mark.parametrize("feed", [6, 9, 12, 24])
def test_circle_programs(mikron, radius, rname, feed):
    path = _interpret(f"circle_r{rname}_f{feed * 1000}.mpf", mikron)
    arcs = _feed_arcs(path)
    assert len(arcs) == 1 and path.sweep_rad[arcs[0]] == pytest.approx(2 * math.pi)
    assert path.radius_mm[arcs[0]] == pytest.approx(radius)
    lim = path_limits(path, mikron)
    assert rel(m_min(lim.cap_mm_s[arcs[0]]), TABLE3[radius][feed]) < 0.005
    assert lim.junction_cap_mm_s[arcs[0]] == 0.0               # started from rest


@pytest.mark.parametrize("feed", [6, 9, 12, 24])
def test_spiral_programs(mikron, feed):
    for name, radii, sweep in ((f"spiral_semi_f{feed * 1000}.mpf", SEMI_RADII, math.pi),
                               (f"spiral_quarter_f{feed * 1000}.mpf", QUARTER_RADII, math.pi / 2)):
        path = _interpret(name, mikron)
        arcs = _feed_arcs(path)
        np.testing.assert_allclose(path.radius_mm[arcs], radii, atol=1e-6)
        np.testing.assert_allclose(path.sweep_rad[arcs], sweep, atol=1e-6)
        lim = path_limits(path, mikron)
        inner = arcs[1:]                                  # junctions between consecutive arcs
        assert lim.junction_limit[inner].tolist() == [Limit.TRANSITION] * len(inner), name
        assert rel(m_min(lim.cap_mm_s[arcs[0]]), min(5.06, feed)) < 0.005


@pytest.mark.parametrize("inclination, paper", [(0, 4.92), (30, 5.29), (45, 5.85)])
def test_inclined_spiral_programs(mikron, inclination, paper):
    name = ("spiral_quarter_f12000.mpf" if inclination == 0
            else f"spiral_quarter_rot{inclination}_f12000.mpf")
    path = _interpret(name, mikron)
    arcs = _feed_arcs(path)
    lim = path_limits(path, mikron)
    assert lim.junction_limit[arcs[1:]].tolist() == [Limit.TRANSITION] * (len(arcs) - 1)
    k = arcs[QUARTER_RADII.index(16)]
    assert rel(m_min(lim.junction_cap_mm_s[k]), paper) < 0.002


@pytest.mark.parametrize("diameter, feeds", [(25, (5984, 7385, 8531)), (80, (6748, 9549, 11968))])
def test_bore_programs(mikron, diameter, feeds):
    """§6: corners line <-> quarter arc, curvature jumps quarter arc <-> bore circle. §6.1: on
    the small bore every programmed feed is limited, to the same set point; §6.2: on the large
    bore the first two programmed feeds are reached, the third is limited."""
    caps = []
    for f in feeds:
        path = _interpret(f"bore_d{diameter}_f{f}.mpf", mikron)
        arcs = _feed_arcs(path)
        assert len(arcs) == 3
        bore = arcs[1]
        assert path.sweep_rad[bore] == pytest.approx(2 * math.pi)
        lim = path_limits(path, mikron)
        assert lim.junction_limit[arcs[0]] == Limit.CORNER          # segment -> approach arc
        assert lim.junction_limit[arcs[2] + 1] == Limit.CORNER      # clearance arc -> segment
        assert lim.junction_limit[bore] == Limit.TRANSITION
        assert lim.junction_limit[bore + 1] == Limit.TRANSITION
        caps.append((lim.cap_mm_s[bore], f / 60.0))
    if diameter == 25:
        assert all(cap < prog for cap, prog in caps)
        assert caps[0][0] == pytest.approx(caps[1][0]) == pytest.approx(caps[2][0])
    else:
        assert [cap == pytest.approx(prog) for cap, prog in caps] == [True, True, False]
        assert caps[2][0] < caps[2][1]
