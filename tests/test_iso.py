"""ISO dialect mode (G291, ``--dialect iso``): the programs of ``programs/iso`` timed by hand, and
the ISO words, cycles, subprograms and macro statements checked against the ISO Milling
manual's definitions (expected positions and times written out here, not taken from ncsim).

The hand times use a machine whose three axes are alike (30 m/min, 10 m/s^2) with no exact-stop
settling. The programs run in exact stop (G61) and ncsim's reset acceleration mode BRISK, so
every move is a rest-to-rest move along one axis with the acceleration A and the jerk
j = A / t_ipo (README, BRISK): its time is the closed form of :func:`rest_to_rest_s`.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from ncsim.cli.main import cli
from ncsim.errors import NcError, NcSyntaxError, NcUnsupportedError
from ncsim.machine import machine_from_dict
from ncsim.nc.interpret import interpret_file, interpret_text

PROGRAMS = Path(__file__).resolve().parent.parent / "programs" / "iso"
V_RAPID = 500.0          # mm/s: 30 m/min
A = 10_000.0             # mm/s^2
T_IPO = 0.004            # s
J = A / T_IPO            # BRISK: the jerk of one interpolation cycle

HAND_MACHINE = f"""[machine]
name = "hand"
{''.join(f'''[axes.{a}]
max_velocity_m_min = 30.0
max_accel_m_s2 = 10.0
max_jerk_m_s3 = 100.0
''' for a in "XYZ")}[ncu]
ipo_cycle_ms = 4.0
curvilinear_jerk_m_s3 = 100.0
tangential_jerk_share = 0.6
central_jerk_share = 0.4
transition_time_ms = 4.0
lookahead_blocks = 100
exact_stop_fine_settle_ms = 0.0
exact_stop_coarse_settle_ms = 0.0
"""


def rest_to_rest_s(length: float, v: float, a: float = A, j: float = J) -> float:
    """Time of a jerk-limited rest-to-rest move: the speed u it reaches is v, or what the length
    allows; the ramp to u lasts 2 sqrt(u/j) (u <= a^2/j) or u/a + a/j, and covers u t / 2."""
    def ramp(u):
        return 2.0 * math.sqrt(u / j) if u <= a * a / j else u / a + a / j
    if length >= v * ramp(v):
        return length / v + ramp(v)
    u = (length * length * j / 4.0) ** (1.0 / 3.0)
    if u > a * a / j:                      # u^2 / a + u a / j = length
        b = a / j
        u = a * (-b + math.sqrt(b * b + 4.0 * length / a)) / 2.0
    return 2.0 * ramp(u)


@pytest.fixture(scope="module")
def hand_machine(tmp_path_factory):
    path = tmp_path_factory.mktemp("iso") / "hand.toml"
    path.write_text(HAND_MACHINE)
    return path


def _run(program, machine, *more):
    r = CliRunner().invoke(cli, ["run", str(program), "--machine", str(machine), "--json",
                                 "--dialect", "iso", *more])
    assert r.exit_code == 0, r.output
    return json.loads(r.stdout)


def _rapid(length):
    return rest_to_rest_s(length, V_RAPID)


def _feed(length, f_mm_min):
    return rest_to_rest_s(length, f_mm_min / 60.0)


def test_canned_cycles_in_a_while_loop_and_an_m98_subprogram_timed_by_hand(hand_machine):
    """O0100: G81 holes at X40 and X80 (the X of the hole from #1 * [#2 + 1]), G98 back to the
    initial level Z50, then M98 P200 L2 (each G91 Y40 at rapid), then G28 Z to the reference
    point Z0 (the machine origin, the file has no [iso] table)."""
    hole = _rapid(40) + _rapid(48) + _feed(12, 600) + _rapid(60)
    expected = _rapid(50) + 2 * hole + 2 * _rapid(40) + _rapid(50)
    s = _run(PROGRAMS / "O0100.nc", hand_machine)
    assert s["cycle_time_s"] == pytest.approx(expected, rel=1e-6)
    assert s["warnings"] == [] and not s.get("approximate")


def test_contour_subprogram_with_depth_variables_and_dwells_timed_by_hand(hand_machine):
    """O0200: three passes at Z = #10 * #11 (-2, -4, -6), each a G91 80 x 60 rectangle at
    F1200 in O201; then G04 P1500 and one G82 hole with P500 and G99 (back to R2)."""
    square = 2 * _feed(80, 1200) + 2 * _feed(60, 1200)
    passes = sum(_rapid(abs(start - 2.0)) + _feed(2.0 + 2.0 * k, 300) + square
                 for k, start in ((1, 50.0), (2, -2.0), (3, -4.0)))
    g82 = _rapid(100) + _rapid(48) + _feed(12, 300) + 0.5 + _rapid(12)
    expected = _rapid(50) + passes + _rapid(56) + 1.5 + g82 + _rapid(48)
    s = _run(PROGRAMS / "O0200.nc", hand_machine)
    assert s["cycle_time_s"] == pytest.approx(expected, rel=1e-6)
    assert s["dwell_time_s"] == pytest.approx(2.0)


def test_peck_drilling_with_g91_repeats_timed_by_hand(hand_machine):
    """O0300: three G83 holes (X30, then two more 30 apart by G91 K2, with R and Z reprogrammed
    as increments): pecks of Q4 from R1 to Z-9, back to R and down to 1 mm (``[iso]
    peck_clearance_mm``) above the last depth; G98 back to Z20."""
    pecks = (_feed(4, 240) + _rapid(4) + _rapid(3) + _feed(5, 240) + _rapid(8) + _rapid(7)
             + _feed(3, 240))
    hole = _rapid(30) + _rapid(19) + pecks + _rapid(29)
    expected = _rapid(20) + 3 * hole
    s = _run(PROGRAMS / "O0300.nc", hand_machine)
    assert s["cycle_time_s"] == pytest.approx(expected, rel=1e-6)


def test_the_cam_style_program_runs_on_the_bundled_machines():
    """O0400: G05.1 Q1 is the continuous-path mode (warned once), R arcs, G43, G28."""
    for machine in ("mikron", "dmc60h"):
        s = _run(PROGRAMS / "O0400.nc", machine)
        assert s["cycle_time_s"] > 0 and math.isfinite(s["cycle_time_s"])
        assert any("G05.1 Q1" in w for w in s["warnings"])


# ---- geometry of the ISO words ------------------------------------------------------------------

def _path(text, **options):
    r = interpret_text(text, "t.nc", dialect="iso", **options)
    p = r.path
    return r, [(tuple(np.round(p.start_mm[i], 6)), tuple(np.round(p.end_mm[i], 6)),
                bool(p.rapid[i])) for i in range(p.n)]


def test_g83_and_g73_peck_positions_and_return_levels():
    _, segs = _path("G0 Z10.\nG99 G73 X0 Y0 Z-5. R2. Q2. F100\nG80\nM30\n")
    zs = [(s[0][2], s[1][2], s[2]) for s in segs[1:]]
    # G73: feed 2, rapid back 1 (peck_retract_mm), feed on; G99: back to R
    assert zs == [(10.0, 2.0, True), (2.0, 0.0, False), (0.0, 1.0, True), (1.0, -2.0, False),
                  (-2.0, -1.0, True), (-1.0, -4.0, False), (-4.0, -3.0, True),
                  (-3.0, -5.0, False), (-5.0, 2.0, True)]


def test_cycle_data_stay_until_g80_and_a_motion_code_cancels():
    _, segs = _path("G0 X0 Y0 Z20.\nG98 G81 X10. Z-1. R1. F100\nX20.\nG0 X30.\nM30\n")
    ends = [s[1] for s in segs]
    assert (20.0, 0.0, -1.0) in ends            # the second hole, same Z and R
    assert ends[-1] == (30.0, 0.0, 20.0)        # G0 ended the cycle: a plain move


def test_g85_g89_feed_out_and_g86_rapid_out():
    _, segs = _path("G0 Z5.\nG99 G85 X0 Z-2. R1. F60\nG89 X5. P250\nG86 X9.\nM30\n")
    outs = [s for s in segs if s[0][2] == -2.0]
    assert [s[2] for s in outs] == [False, False, True]
    r, _ = _path("G0 Z5.\nG89 X0 Z-2. R1. P250 F60\nM30\n")
    assert r.path.dwell_before_s.sum() == pytest.approx(0.25)


def test_r_arcs_and_radius_sign():
    # a chord of 10 on a radius of 10: 60 deg, or 300 deg with a negative R
    r = interpret_text("G1 X10. F100\nG2 X10. Y-10. R-10.\nM30\n", dialect="iso").path
    assert r.sweep_rad[1] == pytest.approx(2 * math.pi - math.pi / 3)
    r = interpret_text("G1 X10. F100\nG2 X10. Y-10. R10.\nM30\n", dialect="iso").path
    assert r.sweep_rad[1] == pytest.approx(math.pi / 3)
    r = interpret_text("G1 X10. F100\nG3 X0 Y10. R10.\nM30\n", dialect="iso").path
    assert r.sweep_rad[1] == pytest.approx(0.5 * math.pi)


def test_g28_g30_use_the_machine_file_reference_points(hand_machine):
    import tomllib
    data = tomllib.loads(HAND_MACHINE)
    data["iso"] = {"reference_points_mm": [[0.0, 0.0, 100.0], [5.0, 6.0, 7.0]]}
    machine = machine_from_dict(data, "m.toml")
    r = interpret_text("G0 X10. Y10. Z10.\nG28 Z20.\nG30 X0 Y0\nM30\n", dialect="iso",
                       machine=machine)
    p = r.path
    assert tuple(p.end_mm[1]) == (10.0, 10.0, 20.0)      # the intermediate point
    assert tuple(p.end_mm[2]) == (10.0, 10.0, 100.0)     # reference point 1, Z only
    assert tuple(p.end_mm[-1]) == (5.0, 6.0, 100.0)      # G30 P2 (the default), X and Y


def test_g52_g92_g54_1_and_g53():
    r, segs = _path("G92 X100. Y0 Z0\nG1 X110. F100\nG52 X5.\nG1 X110.\nG53 G0 X0\nM30\n")
    assert segs[0][1][0] == pytest.approx(10.0)          # G92: the start reads X100
    assert segs[1][1][0] == pytest.approx(15.0)          # G52 shifts the local system
    assert segs[2][1] == (0.0, 0.0, 0.0)                 # G53: machine coordinates
    r = interpret_text("G54.1 P2\nG0 X1.\nM30\n", dialect="iso",
                       setup_offsets={"G508": (10.0, 0.0, 0.0)})
    assert r.path.end_mm[0][0] == pytest.approx(11.0)    # G54.1 P2 is G508


def test_macro_variables_functions_and_vacant_values():
    text = ("#1 = SQRT[16.] + ABS[-1.] * ROUND[1.5] + FIX[-1.7] + FUP[1.2]\n"   # 4+2-1+2 = 7
            "#2 = ATAN[1.]/[-1.]\n"                                          # 135
            "#3 = 7 MOD 4 + [3 AND 5] + [1 OR 2]\n"                          # 3 + 1 + 3
            "IF [#9 EQ #0] THEN #4 = 1\n"                                    # vacant
            "IF [#9 EQ 0] THEN #4 = 2\n"                                     # not taken
            "#101 = #1 + #2 / 135. + #3 + #4\n"                              # 7 + 1 + 7 + 1
            "G1 X#101 Y#9 F100\n"                                            # Y#9: no Y word
            "M30\n")
    r, segs = _path(text)
    assert segs[-1][1] == (16.0, 0.0, 0.0)


def test_goto_if_and_nested_while():
    text = ("#1 = 0\n#2 = 0\nWHILE [#1 LT 3] DO 1\n#3 = 0\nWHILE [#3 LT 2] DO 2\n"
            "#2 = #2 + 1\n#3 = #3 + 1\nEND 2\n#1 = #1 + 1\nEND 1\n"
            "IF [#2 EQ 6] GOTO 20\nG1 X1. F100\nN20 G1 Y#2 F100\nGOTO 40\nG1 Z5.\nN40 M30\n")
    _, segs = _path(text)
    assert [s[1] for s in segs] == [(0.0, 6.0, 0.0)]


def test_an_iso_loop_that_decides_nothing_is_endless_and_one_that_counts_is_not():
    """WHILE [1 EQ 1] reads no variable: its second pass proves the loop endless (as LOOP or
    WHILE 1 in Siemens mode); a WHILE on a # counter decides at every pass and runs out."""
    with pytest.raises(NcError, match=r"t.nc:4:1: endless loop"):
        _path("G91\nWHILE [1 EQ 1] DO 1\nG1 X1. F1000\nEND 1\nM30\n")
    _, segs = _path("#1 = 0\nG91\nWHILE [#1 LT 5] DO 1\nG1 X1. F1000\n#1 = #1 + 1\nEND 1\nM30\n")
    assert len(segs) == 5 and segs[-1][1] == (5.0, 0.0, 0.0)


def test_m98_with_four_digit_count_m99_p_and_g65_arguments(tmp_path):
    (tmp_path / "O7.nc").write_text("O7\nG91 G1 X1. F100\nG90\nM99\n")
    (tmp_path / "O8.nc").write_text("O8\nG1 Y#25 Z#1\nM99\n")
    main = tmp_path / "main.nc"
    main.write_text("M98 P30007\nG65 P8 A-2. Y4.\nM98 P9\nN50 M30\nO9\nM99 P50\n")
    r = interpret_file(main, dialect="iso")
    ends = [tuple(e) for e in r.path.end_mm.tolist()]
    assert ends == [(1.0, 0.0, 0.0), (2.0, 0.0, 0.0), (3.0, 0.0, 0.0), (3.0, 4.0, -2.0)]
    main.write_text("M98 P77\nM30\n")
    with pytest.raises(NcError, match=r"main.nc:1:1: program O77 not found"):
        interpret_file(main, dialect="iso")


def test_standard_notation_counts_increments():
    import tomllib
    data = tomllib.loads(HAND_MACHINE)
    data["iso"] = {"decimal_point": "standard"}
    machine = machine_from_dict(data, "m.toml")
    r = interpret_text("G1 X1000 Y2. F100\nG4 X1500\nG1 X0\nM30\n", dialect="iso",
                       machine=machine)
    assert tuple(r.path.end_mm[0]) == (1.0, 2.0, 0.0)
    assert r.path.dwell_before_s[1] == pytest.approx(1.5)


def test_g5_1_maps_to_continuous_path_and_back():
    r = interpret_text("G61\nG5.1 Q1\nG1 X1. F100\nG5.1 Q0\nG1 X2.\nM30\n", dialect="iso")
    assert list(r.path.cp_mode) == [64, 60]


def test_siemens_code_in_iso_mode_and_the_switch_lines():
    with pytest.raises(NcSyntaxError, match=r"t.nc:2:1: SOFT is not an ISO dialect word .*G290"):
        interpret_text("G1 X1 F100\nSOFT\nM30\n", "t.nc", dialect="iso")
    with pytest.raises(NcSyntaxError, match=r"t.nc:1:3: R..= is Siemens code"):
        interpret_text("R1=5\nM30\n", "t.nc", dialect="iso")
    text = "G1 X1 F100\nG291\n#1=2.\nG1 X#1\nG290\nR1=3\nG1 X=R1\nM30\n"
    r = interpret_text(text, "t.nc")                     # starts in Siemens mode
    assert [e[0] for e in r.path.end_mm.tolist()] == [1.0, 2.0, 3.0]
    with pytest.raises(NcError, match="G291 must be programmed alone"):
        interpret_text("G1 X1 F100 G291\nM30\n", "t.nc", dialect="iso")


def test_not_simulated_iso_functions_are_errors_at_their_word():
    for text, what in (("G68 X0 Y0 R30.\n", "coordinate rotation G68"),
                       ("G87 X0 Z-1. R1. Q1. F10\n", "G87 back boring"),
                       ("G1 X1. ,R2. F100\n", "corner rounding")):
        with pytest.raises(NcUnsupportedError, match=what):
            interpret_text(text + "M30\n", "t.nc", dialect="iso")


def test_iso_plain_runs_take_the_column_path_with_the_same_result():
    rows = "\n".join(f"G01 X{i * 0.5:.3f} Y{math.sin(i / 10):.4f}" for i in range(300))
    text = f"G21 G90 G17\nG00 X0 Y0 Z1.\nG01 F3000.\n{rows}\nG81 X1. Y1. Z-1. R1.\n" \
           f"X2.\nX3. Y2.\nG80\nM30\n"
    fast = interpret_text(text, "t.nc", dialect="iso")
    slow = interpret_text(text, "t.nc", dialect="iso", fast=False)
    assert fast.path.n == slow.path.n == 1 + 299 + 3 * 3     # the first row does not move
    assert np.array_equal(fast.path.end_mm, slow.path.end_mm)
