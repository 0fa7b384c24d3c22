"""Interpreter: each construct gives the segments computed here by hand.

Geometry conventions (ncsim.path): normal = axis about which the arc turns counter-clockwise,
centre in the arc plane through the start point, sweep > 0, helix = rise along the normal.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from ncsim.nc.interpret import interpret_text
from ncsim.path import ARC, BRISK, DRIVE, SOFT

PI = math.pi


def run(text, **kw):
    return interpret_text(text, "t.mpf", **kw)


def seg(result, i):
    return result.path.segment(i)


def close(a, b, tol=1e-9):
    return np.allclose(np.asarray(a, dtype=float), np.asarray(b, dtype=float), atol=tol, rtol=0)


# ---- lines, feeds, units ----------------------------------------------------------------------

def test_lines_rapid_and_feed_conversion():
    r = run("G90 G0 X10 Y0 Z0\nG1 X10 Y20 F600\nX13 Y24\n")
    assert len(r.path) == 3
    s0, s1, s2 = (seg(r, i) for i in range(3))
    assert s0.rapid and s0.feed_mm_s == math.inf and s0.length_mm == 10.0
    assert not s1.rapid and s1.feed_mm_s == 10.0 and s1.length_mm == 20.0   # 600 mm/min = 10 mm/s
    assert close(s2.start_mm, [10, 20, 0]) and close(s2.end_mm, [13, 24, 0]) and s2.length_mm == 5.0
    assert (s0.line, s1.line, s2.line) == (1, 2, 3)
    assert r.blocks_executed == 3


def test_incremental_and_ac_ic():
    r = run("G91 G1 X10 F100\nX5 Y=AC(2)\nG90 X=IC(-3) Y7\n")
    ends = [seg(r, i).end_mm.tolist() for i in range(3)]
    assert ends == [[10, 0, 0], [15, 2, 0], [12, 7, 0]]


def test_block_without_movement_makes_no_segment():
    r = run("G1 X5 F100\nX5\nG0 X5 Y0\n")
    assert len(r.path) == 1 and r.blocks_executed == 3


def test_g70_inch_geometry_keeps_metric_feed():
    r = run("G70 G1 X1 F254\n")
    s = seg(r, 0)
    assert s.end_mm[0] == pytest.approx(25.4) and s.feed_mm_s == pytest.approx(254 / 60)


def test_g700_inch_geometry_and_feed():
    r = run("G700 G1 X2 F10\nG710 X30\n")
    assert seg(r, 0).end_mm[0] == pytest.approx(50.8)
    assert seg(r, 0).feed_mm_s == pytest.approx(10 * 25.4 / 60)     # 10 in/min
    assert seg(r, 1).end_mm[0] == pytest.approx(30.0)
    assert seg(r, 1).feed_mm_s == pytest.approx(10 * 25.4 / 60)     # F keeps its value in mm/s


def test_feed_set_in_a_rapid_block_is_kept():
    r = run("G0 X1 F1200\nG1 X2\n")
    assert seg(r, 1).feed_mm_s == 20.0


# ---- arcs --------------------------------------------------------------------------------------

def test_g2_g3_centre_incremental_in_g17():
    r = run("G1 X10 F100\nG3 X20 Y0 I5 J0\nG2 X30 I5\n")
    a, b = seg(r, 1), seg(r, 2)
    assert a.kind == ARC and close(a.center_mm, [15, 0, 0]) and close(a.normal, [0, 0, 1])
    assert a.radius_mm == 5.0 and a.sweep_rad == pytest.approx(PI) and a.length_mm == pytest.approx(5 * PI)
    assert close(b.center_mm, [25, 0, 0]) and close(b.normal, [0, 0, -1]) and b.clockwise_in_plane


def test_full_circle_and_turn_helix():
    r = run("G1 X5 F100\nG3 I-5\nG2 Z3 I-5 TURN=1\n")
    full, helix = seg(r, 1), seg(r, 2)
    assert full.sweep_rad == pytest.approx(2 * PI) and close(full.end_mm, [5, 0, 0])
    assert helix.sweep_rad == pytest.approx(4 * PI) and helix.helix_mm == pytest.approx(-3.0)
    assert helix.length_mm == pytest.approx(math.hypot(5 * 4 * PI, 3))
    assert close(helix.normal, [0, 0, -1])


@pytest.mark.parametrize("plane, words, center, normal", [
    ("G18", "G3 X10 Z0 I5", [5, 0, 0], [0, 1, 0]),     # G18: abscissa Z, ordinate X, normal +Y
    ("G19", "G3 Y10 Z0 J5", [0, 5, 0], [1, 0, 0]),
    ("G18", "G2 X10 Z0 I5", [5, 0, 0], [0, -1, 0]),
])
def test_arc_planes(plane, words, center, normal):
    r = run(f"{plane} G1 F100\n{words}\n")
    s = seg(r, 0)
    assert close(s.center_mm, center) and close(s.normal, normal) and s.sweep_rad == pytest.approx(PI)


def test_g18_g3_turns_counter_clockwise_about_plus_y():
    # from (0,0,5) around (0,0,0): G3 in G18 moves from +Z towards +X (Z x X = Y)
    r = run("G18 G0 Z5\nG1 F100\nG3 X5 Z0 K-5\n")
    s = seg(r, 1)
    assert close(s.center_mm, [0, 0, 0]) and s.sweep_rad == pytest.approx(PI / 2)


def test_radius_cr_short_and_long_arc():
    r = run("G1 F100\nG2 X10 CR=5\nG0 X0\nG3 X10 CR=-7.0710678118654755\n")
    short, long_ = seg(r, 0), seg(r, 2)
    assert close(short.center_mm, [5, 0, 0]) and short.sweep_rad == pytest.approx(PI)
    # CR < 0: more than a half circle; chord 10 at r = sqrt(50) subtends 90 degrees
    assert close(long_.center_mm, [5, -5, 0]) and long_.sweep_rad == pytest.approx(1.5 * PI)


def test_opening_angle_ar_with_end_and_with_centre():
    r = run("G1 F100\nG3 X10 AR=90\nG0 X0 Y0\nG3 I5 AR=90\n")
    a, b = seg(r, 0), seg(r, 2)
    assert close(a.center_mm, [5, 5, 0]) and a.sweep_rad == pytest.approx(PI / 2)
    assert a.radius_mm == pytest.approx(math.sqrt(50))
    assert close(b.center_mm, [5, 0, 0]) and close(b.end_mm, [5, -5, 0]) and b.sweep_rad == pytest.approx(PI / 2)


def test_cip_circle_through_intermediate_point():
    r = run("G1 F100\nCIP X10 Y0 I1=5 J1=5\n")
    s = seg(r, 0)
    assert close(s.center_mm, [5, 0, 0]) and s.radius_mm == pytest.approx(5)
    assert close(s.normal, [0, 0, -1]) and s.sweep_rad == pytest.approx(PI)   # clockwise seen from +Z


def test_cip_intermediate_point_incremental_in_g91():
    r = run("G0 X10\nG91 G1 F100\nCIP X-10 Y0 I1=-5 J1=5\n")
    assert close(seg(r, 1).center_mm, [5, 0, 0])


def test_ct_tangential_circle():
    r = run("G1 X10 F100\nCT X20 Y10\n")
    s = seg(r, 1)
    assert close(s.center_mm, [10, 10, 0]) and close(s.normal, [0, 0, 1])
    assert s.radius_mm == pytest.approx(10) and s.sweep_rad == pytest.approx(PI / 2)


def test_helix_in_g17():
    r = run("G1 X5 F100\nG3 X-5 Y0 Z4 I-5\n")
    s = seg(r, 1)
    assert s.helix_mm == pytest.approx(4) and s.length_mm == pytest.approx(math.hypot(5 * PI, 4))


def test_circle_end_point_check_tolerances():
    # MD21000 0.01 mm absolute for small radii: 0.009 passes
    run("G1 X5 F100\nG2 X-5.009 Y0 I-5\n")
    # MD21010 0.001 * r for large radii: r = 100 allows 0.1 mm
    run("G1 X100 F100\nG2 X-100.09 Y0 I-100\n")


def test_circle_tolerances_from_the_machine(mikron):
    strict = mikron.with_ncu(circle_error_const_mm=0.001, circle_error_factor=0.0)
    from ncsim.errors import NcSemanticError
    with pytest.raises(NcSemanticError, match="circle end point"):
        run("G1 X5 F100\nG2 X-5.005 Y0 I-5\n", machine=strict)


# ---- modal columns ------------------------------------------------------------------------------

def test_reset_state_is_840d_default():
    s = seg(run("G1 X1 F100\n"), 0)
    assert (s.cp_mode, s.exact_stop, s.stop_window, s.accel_mode, s.ffw) == (60, True, 601, BRISK, False)


def test_continuous_path_exact_stop_and_windows():
    r = run("G64 G1 X1 F100\nG9 X2\nG60 G602 X3\nG603 X4\nG641 ADIS=0.5 ADISPOS=2 X5\nG0 X6\nG642 G1 X7\n")
    cols = [(s.cp_mode, s.exact_stop, s.stop_window, s.adis_mm) for s in r.path.segments()]
    assert cols == [(64, False, 601, 0.0), (64, True, 601, 0.0), (60, True, 602, 0.0),
                    (60, True, 603, 0.0), (641, False, 603, 0.5), (641, False, 603, 2.0),
                    (642, False, 603, 0.5)]


def test_accel_mode_ffw_and_stops():
    r = run("G64 G1 X1 F100\nSOFT\nX2\nX3 M8\nFFWON DRIVE\nX4\nSTOPRE\nX5\nS2000 T1 D0 F200\nX6\nG0 X7\nG1 X8\n")
    s = list(r.path.segments())
    assert [x.accel_mode for x in s] == [BRISK, SOFT, SOFT, DRIVE, DRIVE, DRIVE, DRIVE, DRIVE]
    assert [x.ffw for x in s] == [False, False, False, True, True, True, True, True]
    # SOFT change, M8 in block, DRIVE change, STOPRE, G1->G0 and G0->G1; S/T/D/F do not stop
    assert [x.stop_before for x in s] == [False, True, True, True, True, False, True, True]


def test_dwell_seconds_revolutions_and_end_dwell():
    r = run("G1 X1 F100\nG4 F1.5\nM3 S600\nG4 S10\nX2\nG4 F0.5\n")
    s = seg(r, 1)
    assert s.dwell_before_s == pytest.approx(1.5 + 1.0) and s.stop_before   # 10 rev at 600 rev/min = 1 s
    assert s.feed_mm_s == pytest.approx(100 / 60)                             # G4's F is not the feed
    assert r.path.end_dwell_s == 0.5


def test_dwell_with_unknown_spindle_speed_warns():
    r = run("G1 X1 F100\nG4 S10\nX2\nM30\n")
    assert seg(r, 1).dwell_before_s == 0.0
    assert [(w.line, "spindle speed unknown" in w.message) for w in r.warnings] == [(2, True)]


# ---- parameters and expressions -------------------------------------------------------------

def test_r_parameters_and_functions():
    r = run("R1=SIN(30)*4 R2=SQRT(POT(3)+POT(4)) R3=ATAN2(1,1)\n"
            "G1 X=R1 Y=R2 Z=R3 F100\n"
            "R4=ROUND(2.5)+TRUNC(-1.7)+ABS(-2)+(7 DIV 2)+(7 MOD 4)+COS(60)+TAN(45)+ACOS(0)-ASIN(1)\n"
            "X=R4\n")
    assert close(seg(r, 0).end_mm, [2.0, 5.0, 45.0])
    # 3 - 1 + 2 + 3 + 3 + 0.5 + 1 + 90 - 90
    assert seg(r, 1).end_mm[0] == pytest.approx(11.5)


def test_assignment_in_the_same_block_takes_effect_at_once():
    assert seg(run("R1=5 G1 X=R1 F100\n"), 0).end_mm[0] == 5.0


def test_def_real_int_and_bool():
    r = run("DEF REAL _A=1.25\nDEF INT _N\n_N=2.5\nDEF BOOL _B=7\nG1 X=_A+_N+_B F100\n")
    assert seg(r, 0).end_mm[0] == pytest.approx(1.25 + 3 + 1)   # INT rounds half away from zero


def test_lower_case_and_crlf():
    r = run("g1 x10 f100\r\ng2 x20 i5\r\n")
    assert len(r.path) == 2 and seg(r, 1).kind == ARC and seg(r, 1).line == 2


# ---- recorded settings -----------------------------------------------------------------------

def test_cycle832_and_modes_recorded_with_lines():
    r = run("DEF REAL _TOL=0.02\nCYCLE832(_TOL,1,1)\nG1 X1 F100\nCOMPCAD\nDYNFINISH\nMSG(\"finish\")\nX2\n"
            "COMPOF DYNNORM\nM30\n")
    assert [(c.name, c.args, c.line, c.segment_index) for c in r.cycle832_calls] == [("CYCLE832", (0.02, 1.0, 1.0), 2, 0)]
    # CYCLE832 finishing selects DYNFINISH (technology group 59); COMPCAD is simulated
    assert [(c.name, c.line, c.segment_index) for c in r.mode_changes] == [
        ("DYNFINISH", 2, 0), ("COMPCAD", 4, 1), ("DYNFINISH", 5, 1), ("COMPOF", 8, 2),
        ("DYNNORM", 8, 2)]
    assert [(m.args, m.line) for m in r.messages] == [(("finish",), 6)]
    warned = {(w.line, w.message.split(":")[0]) for w in r.warnings}
    # no machine file: the default expansion is said; no [dynamics] for the technology group
    assert warned == {(2, "CYCLE832"), (2, "CYCLE832 selects DYNFINISH"), (5, "DYNFINISH")}
    assert not any("not simulated" in w.message and "CYCLE832(" in w.message for w in r.warnings)


def test_not_simulated_constructs_warn_with_their_line():
    r = run("G17 G41 D1 G1 X1 F100\nG0 B0 C90\nTRAORI\nCYCLE800()\nM6\nMCALL CYCLE81(10,0,3,-6)\nX5\nMCALL\n"
            "CFIN\n")
    lines = sorted({w.line for w in r.warnings})
    assert lines == [1, 2, 3, 4, 5, 6, 9]
    text = " ".join(w.message for w in r.warnings)
    for fragment in ("G41", "D1", "rotary axis B", "rotary axis C", "TRAORI", "CYCLE800", "M6", "MCALL CYCLE81"):
        assert fragment in text
    assert len(r.path) == 2


def test_arc_kernel_agrees_with_geometry():
    """moves.arc_columns vs geometry.sweep_angle_rad / in_plane_radius_mm / point_at."""
    from ncsim.geometry import in_plane_radius_mm, point_at, sweep_angle_rad
    from ncsim.nc.moves import arc_columns
    rng = np.random.default_rng(3)
    n = 200
    normal = rng.normal(size=(n, 3))
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    center = rng.normal(size=(n, 3)) * 10
    start = center + rng.normal(size=(n, 3)) * 5
    end = center + rng.normal(size=(n, 3)) * 5
    geo = arc_columns(start, end, center, normal, 1.0)
    assert np.allclose(geo["radius_mm"], in_plane_radius_mm(start, center, normal))
    assert np.allclose(geo["radius_end_mm"], in_plane_radius_mm(end, center, normal))
    assert np.allclose(geo["sweep_rad"], sweep_angle_rad(start, end, center, normal, 1))
    r = interpret_text("G1 X5 F100\nG3 X-5 Y0 Z4 I-5\nCIP X0 Y3 Z0 I1=2 J1=2 K1=1\n")
    ends = point_at(r.path, np.arange(len(r.path)), r.path.length_mm.copy())
    assert np.allclose(ends, r.path.end_mm, atol=1e-9)
