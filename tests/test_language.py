"""The 840D language of real shop programs and Siemens cycle sources: subprograms found as the
control finds them, arrays, VAR, CASE, REPEAT, IF chains, reused labels, system variables, GUD,
G95, polar coordinates, MCALL and SAVE. Expected values are worked out by hand from the
program text and the Programming Manual's rules (cited in the interpreter's docstrings)."""
from __future__ import annotations

import math

import pytest

from ncsim.errors import NcSemanticError, NcUnsupportedError
from ncsim.machine import load_machine, machine_from_dict
from ncsim.nc import interpret
from ncsim.nc.interpret import interpret_file, interpret_text


def ends(r) -> list[list[float]]:
    return [[round(float(c), 9) for c in s.end_mm] for s in r.path.segments()]


def xs(r) -> list[float]:
    return [round(float(s.end_mm[0]), 9) for s in r.path.segments()]


def run(text: str, **kw):
    return interpret_text(text, "t.mpf", **kw)


# ---- subprograms as the control finds them --------------------------------------------------

def test_proc_after_a_comment_header_with_a_blank_before_its_parameters(tmp_path):
    (tmp_path / "sub.spf").write_text("; ====\n; SUB: moves to (UA, UB)\n; ====\n\n"
                                      "%_N_SUB_SPF\nN10 PROC SUB (REAL UA, REAL UB) SAVE DISPLOF\n"
                                      "G1 X=UA Y=UB F100\nRET\n")
    (tmp_path / "main.mpf").write_text("EXTERN SUB(REAL, REAL)\nSUB(3, 4)\nSub(5, 6)\nM30\n")
    r = interpret_file(tmp_path / "main.mpf")
    assert ends(r) == [[3, 4, 0], [5, 6, 0]]


def test_a_file_named_like_a_standard_cycle_is_executed_not_skipped(tmp_path):
    (tmp_path / "CYCLE81.SPF").write_text("PROC CYCLE81(REAL RTP, REAL DP)\nG1 Z=DP F100\nG0 Z=RTP\nRET\n")
    (tmp_path / "main.mpf").write_text("G0 X1\nCYCLE81(5, -3)\nCYCLE82(5, -3)\nM30\n")
    r = interpret_file(tmp_path / "main.mpf")
    assert ends(r) == [[1, 0, 0], [1, 0, -3], [1, 0, 5]]
    assert [w.message for w in r.warnings if "CYCLE82" in w.message] == [
        "CYCLE82: machining cycle not simulated (no CYCLE82.SPF found, no motion generated)"]
    assert [(k, n) for k, n, _ in r.approximations] == [("cycle", 1)]


def test_subprogram_folders_in_order_and_names_without_case(tmp_path):
    own, lib, other = tmp_path / "own", tmp_path / "lib", tmp_path / "other"
    for d in (own, lib, other):
        d.mkdir()
    (own / "main.mpf").write_text("G1 F100\nSUBA\nSUBB\nM30\n")
    (own / "suba.spf").write_text("X1\nSubC\nM17\n")       # SUBC is called from SUBA: found in lib
    (lib / "SUBA.SPF").write_text("X100\nM17\n")            # shadowed by the caller's folder
    (lib / "subc.Spf").write_text("X2\nM17\n")
    (other / "_N_SUBB_SPF").write_text("X3\nM17\n")        # the control's archive name
    r = interpret_file(own / "main.mpf", subprograms=(lib, other))
    assert xs(r) == [1, 2, 3]


def test_main_program_file_before_subprogram_file(tmp_path):
    (tmp_path / "PART1.MPF").write_text("G1 X1 F100\nM17\n")
    (tmp_path / "PART1.SPF").write_text("G1 X2 F100\nM17\n")
    (tmp_path / "main.mpf").write_text("PART1\nM30\n")
    assert xs(interpret_file(tmp_path / "main.mpf")) == [1]


def test_missing_subprogram_is_an_error_naming_the_folders_or_a_warning(tmp_path):
    lib = tmp_path / "lib"
    lib.mkdir()
    (tmp_path / "main.mpf").write_text("G1 X1 F100\nL140(2)\nX2\nL140(3)\nM30\n")
    with pytest.raises(NcSemanticError) as info:
        interpret_file(tmp_path / "main.mpf", subprograms=(lib,))
    assert (info.value.line, info.value.column) == (2, 1)
    assert info.value.message.startswith(f"subprogram L140 not found: no PROC L140 and no "
                                         f"L140.MPF/L140.SPF in {tmp_path}, {lib}")
    r = interpret_file(tmp_path / "main.mpf", missing_subprograms="warn")
    assert xs(r) == [1, 2]
    assert r.approximate and [(k, n) for k, n, _ in r.approximations] == [("missing subprogram", 2)]
    assert [w.line for w in r.warnings] == [2, 4]


def test_a_word_longer_than_a_file_name_is_a_missing_subprogram(tmp_path):
    (tmp_path / "main.mpf").write_text("G1 F100\n" + "B" * 300 + "\n")
    with pytest.raises(NcSemanticError, match="subprogram B+ not found"):
        interpret_file(tmp_path / "main.mpf")


def test_save_restores_modal_g_functions_and_frames_at_the_return():
    prog = ("G90 G1 F100\nSUB\nX1\nM30\nPROC SUB SAVE\nG91 TRANS X10\nX5\nRET\n")
    # in SUB: G91 and TRANS X10: X5 -> 5 (incremental from 0, frame moves WCS not MCS); back
    # in the main: G90 and no TRANS again, X1 -> 1
    assert xs(run(prog)) == [5, 1]


def test_var_parameters_are_the_callers_variables():
    prog = ("DEF REAL _V=1\nDEF REAL _A[3]\nINC(_V, _A)\nINC(_V, _A)\nG1 X=_V Y=_A[2] F100\nM30\n"
            "PROC INC(VAR REAL _X, VAR REAL _ARR[3])\n_X=_X+1\n_ARR[2]=_ARR[2]+10\nRET\n")
    assert ends(run(prog)) == [[3, 20, 0]]


def test_missing_arguments_take_the_types_default():
    prog = "SUB(5)\nM30\nPROC SUB(REAL UA, REAL UB, INT UC)\nG1 X=UA Y=UB Z=UC+1 F100\nRET\n"
    assert ends(run(prog)) == [[5, 0, 1]]


# ---- arrays ---------------------------------------------------------------------------------

def test_arrays_init_lists_set_rep_and_indirect_r():
    prog = ("DEF REAL _A[2,3]=(1,2,3,4,5,6)\nDEF INT _B[4]=REP(7)\nDEF REAL _C[5]\n"
            "_C[1]=SET(10,20)\n_C[3]=REP(-1)\nR[_B[0]]=_A[1,0]+_A[0,2]\nG1 F100\n"
            "X=_A[1,2] Y=_C[2] Z=R7\nX=_C[4] Y=_C[0] Z=_B[3]\n")
    # _A row-major: _A[1,0]=4, _A[0,2]=3, _A[1,2]=6; R7 = 4 + 3
    assert ends(run(prog)) == [[6, 20, 7], [-1, 0, 7]]


def test_array_element_assigned_in_a_loop():
    prog = ("DEF INT _I\nDEF REAL _Q[4]\nFOR _I=0 TO 3\n_Q[_I]=_I*_I\nENDFOR\n"
            "G1 F100 X=_Q[3] Y=_Q[2]\n")
    assert ends(run(prog)) == [[9, 4, 0]]


# ---- control flow ----------------------------------------------------------------------------

def test_several_conditional_jumps_in_one_block_the_first_true_one_jumps():
    prog = ("R1={}\nG1 F100\nIF R1==1 GOTOF ONE IF R1==2 GOTOF TWO\nX9\nGOTOF END\n"
            "ONE: X1\nGOTOF END\nTWO: X2\nEND: M30\n")
    assert xs(run(prog.format(1))) == [1]
    assert xs(run(prog.format(2))) == [2]
    assert xs(run(prog.format(3))) == [9]


def test_case_of_default():
    prog = ("R1={}\nG1 F100\nCASE R1 OF 1 GOTOF AA -2 GOTOF BB DEFAULT GOTOF CC\nAA: X1\n"
            "GOTOF EE\nBB: X2\nGOTOF EE\nCC: X3\nEE: M30\n")
    assert [xs(run(prog.format(v))) for v in (1, -2, 7)] == [[1], [2], [3]]
    # without DEFAULT an unmatched value goes on with the next block
    assert xs(run("R1=5\nG1 F100\nCASE R1 OF 1 GOTOF AA\nX4\nAA: X5\n")) == [4, 5]


def test_reused_labels_gotof_finds_the_next_gotob_the_previous():
    # two sections with the same labels, as in the shop program 123.mpf
    section = ("R6=0\nSTART: G91 X1\nR6=R6+1\nIF R6>=2 GOTOF DONE\nGOTOB START\nDONE: G90 Y{}\n")
    r = run("G1 F100\n" + section.format(10) + section.format(20))
    assert ends(r) == [[1, 0, 0], [2, 0, 0], [2, 10, 0], [3, 10, 0], [4, 10, 0], [4, 20, 0]]


def test_repeat_section_p_times_after_its_first_pass():
    # the Programming Manual's example: the section from BEGIN to the REPEAT block runs once,
    # then P=3 more times, each pass one step wider
    prog = ("N5 R10=15 G1 F200\nN10 BEGIN: R10=R10+1\nN20 Z=10-R10\nN30 X=R10\nN40 Y=R10\n"
            "N80 Z10\nN100 REPEAT BEGIN P=3\nN110 X0\n")
    r = run(prog)
    zs = [e[2] for e in ends(r)]
    assert zs == [-6, -6, -6, 10, -7, -7, -7, 10, -8, -8, -8, 10, -9, -9, -9, 10, 10]
    assert xs(r)[-1] == 0 and max(xs(r)) == 19


def test_repeatb_repeat_between_two_labels_and_to_endlabel():
    assert xs(run("G91 G1 F100\nSTEP: X1\nREPEATB STEP P=2\nX10\n")) == [1, 2, 3, 13]
    prog = "G91 G1 F100\nAA: X1\nBB: X2\nX100\nREPEAT AA BB P=2\nX1000\n"
    assert xs(run(prog)) == [1, 3, 103, 104, 106, 107, 109, 1109]
    prog = "G91 G1 F100\nREPEAT AA\nX100\nAA: X1\nX2\nENDLABEL: X3\nX4\n"
    # REPEAT before its section: the section AA..ENDLABEL runs once there, then from X100 on
    assert xs(run(prog)) == [1, 3, 6, 106, 107, 109, 112, 116]


def test_repeat_sections_nest():
    prog = "G91 G1 F100\nIN: X1\nREPEATB IN P=1\nOUT: Y1\nREPEAT IN P=1\n"
    # IN, IN again; OUT; then IN..REPEAT once more: IN, IN, OUT
    assert len(run(prog).path) == 6


# ---- words and procedures of the cycles ------------------------------------------------------

def test_indirect_axes_follow_the_plane():
    prog = ("DEF AXIS _Z\nG1 F100\nG17\n_Z=$P_AXN3\nAX[_Z]=-5\nG18\n_Z=$P_AXN3\nAX[_Z]=7\n"
            "G19\n_Z=$P_AXN1\nAX[_Z]=9\n")
    # G17 applicate Z; G18 (Z X Y) applicate Y; G19 (Y Z X) abscissa Y
    assert ends(run(prog)) == [[0, 0, -5], [0, 7, -5], [0, 9, -5]]


def test_p_gg_p_mc_p_f_p_ep_and_actframe():
    setup = "G18 G91 G64 G602 SOFT FFWON G700 G1 F200 X2\nSCALE Z3\n"

    def value(expr):
        r = run(setup + f"R1={expr}\nG90 G710 G1 F100 X=R1+1000\n")
        return xs(r)[-1] - 1000

    # positions in the manual's G group lists: G18 2, G91 2, G64 2, G602 2, SOFT 2, FFWON 2,
    # G700 3, G1 2; no modal call; F as programmed; X2 inch; the SCALE of Z
    assert [value(f"$P_GG[{g}]") for g in (6, 14, 10, 12, 21, 24, 13, 1)] == [2, 2, 2, 2, 2, 2, 3, 2]
    assert [value(e) for e in ("$P_MC", "$P_F", "$P_EP[X]", "$P_ACTFRAME[Z,SC]")] == [0, 200, 2, 3]
    assert value("$P_GG[8]") == 1 and value("$P_DRYRUN") == 0
    assert value("$MN_SCALING_VALUE_INCH") == pytest.approx(25.4, abs=1e-9)


def test_system_variables_from_the_machine_file_or_a_located_error(mikron):
    with pytest.raises(NcUnsupportedError, match=r't.mpf:1:4: system variable \$AN_NCK_VERSION is '
                                                 r'not simulated: give its value in the machine file'):
        run("R1=$AN_NCK_VERSION\n", machine=mikron)
    data = {"machine": {"name": "m"}, "axes": {a: {"max_velocity_m_min": 30, "max_accel_m_s2": 2,
                                                   "max_jerk_m_s3": 5} for a in "XYZ"},
            "ncu": {"ipo_cycle_ms": 12, "curvilinear_jerk_m_s3": 10, "tangential_jerk_share": 0.6,
                    "central_jerk_share": 0.4, "transition_time_ms": 12, "lookahead_blocks": 100},
            "system_variables": {"$AN_NCK_VERSION": 450000, "$MA_RATIO[1,Z]": 3,
                                 "$mc_roundaxis": 7}}
    m = machine_from_dict(data)
    r = run("DEF AXIS _Z=\"Z\"\nG1 F100 X=$AN_NCK_VERSION/100000 Y=$MA_RATIO[1,_Z] "
            "Z=$MC_ROUNDAXIS[4]\n", machine=m)
    assert ends(r) == [[4.5, 3, 7]]
    bad = dict(data, system_variables={"P_F": 1})
    with pytest.raises(Exception, match='system_variables."P_F": expected a system variable name'):
        machine_from_dict(bad)


def test_setal_stops_on_cycle_alarms_and_warns_on_messages_setms_sblof_msg():
    r = run('SETMS(2)\nR1=$P_MSNUM\nSBLOF DISPLOF\nSETAL(62100)\nMSG ("RADIUS " << R1)\nSBLON\n'
            'SETMS\nG1 F100 X=R1+$P_MSNUM\nM30\n')
    assert xs(r) == [3] and [m.args for m in r.messages] == [("RADIUS 2",)]
    assert [w.message for w in r.warnings] == ["cycle alarm 62100 set by T (a message: the program "
                                               "goes on)"]
    assert not r.approximate


def test_gud_definitions_file(tmp_path):
    gud = tmp_path / "MGUD.DEF"
    gud.write_text("%_N_MGUD_DEF\n;$PATH=/_N_DEF_DIR\nDEF NCK REAL _DEPTH=2.5\n"
                   "DEF CHAN INT _HOLES[3]=SET(4,5,6)\nM30\n")
    prog = "SUB\nG1 F100 X=_DEPTH Y=_HOLES[2]\nM30\nPROC SUB\n_DEPTH=_DEPTH*2 _HOLES[2]=9\nRET\n"
    assert ends(run(prog, definitions=(gud,))) == [[5, 9, 0]]
    bad = tmp_path / "UGUD.DEF"
    bad.write_text("DEF NCK REAL _X\nG1 X1\n")
    with pytest.raises(NcSemanticError, match=f"{bad}:2:1: a definitions file holds DEF lines"):
        run("M30\n", definitions=(bad,))


# ---- feed per revolution, polar coordinates ---------------------------------------------------

def test_g95_feed_is_f_times_s_and_g97_g971():
    r = run("G95 S1000 M3 F0.2\nG1 X10\nS500\nX20\nG971 F300\nX30\nG97 F0.1\nX40\n")
    feeds = [round(s.feed_mm_s * 60, 9) for s in r.path.segments()]
    # 0.2 mm/rev x 1000 rpm; x 500 rpm; G971 feed per minute; G97 per revolution again
    assert feeds == [200, 100, 300, 50]
    with pytest.raises(NcSemanticError, match="t.mpf:3:1: G1 with feed per revolution"):
        run("G95 F0.2 S1000 M3\nM5\nX10\n")


def test_polar_coordinates_about_the_pole():
    r = run("G17 G1 F100\nG111 X10 Y0\nAP=90 RP=5\nAP=IC(90)\nG3 AP=270\nG0 X20 Y20\n"
            "G110 X-20 Y0\nG1 AP=0 RP=2\nG112 AP=90 RP=1\nG1 AP=180 RP=3 Z4\n")
    e = ends(r)
    assert e[0] == [10, 5, 0] and e[1] == [5, 0, 0] and e[2] == [10, -5, 0]   # about (10, 0)
    arc = r.path.segment(2)
    assert arc.center_mm.tolist() == pytest.approx([10, 0, 0])
    assert arc.sweep_rad == pytest.approx(math.pi / 2)      # counter-clockwise from 180 to 270 deg
    assert e[4] == [2, 20, 0]                  # G110: pole (0, 20) from the last position (20, 20)
    assert e[5] == [-3, 21, 4]                 # G112: pole (0, 21) from the last pole (0, 20)


# ---- MCALL ------------------------------------------------------------------------------------

def test_mcall_calls_after_every_motion_block_but_not_inside_itself():
    prog = ("G0 X1\nMCALL DRILL(-2)\nX2\nY3\nR1=1\nMCALL\nX4\nM30\n"
            "PROC DRILL(REAL DEPTH)\nG1 Z=DEPTH F100\nG0 Z0\nRET\n")
    assert ends(run(prog)) == [[1, 0, 0], [2, 0, 0], [2, 0, -2], [2, 0, 0], [2, 3, 0], [2, 3, -2],
                               [2, 3, 0], [4, 3, 0]]


@pytest.mark.parametrize("chunk", [3, 1 << 16])
def test_mcall_inside_a_plain_run_is_the_same_on_both_paths(chunk, monkeypatch):
    """Also when the run is interpreted in chunks of 3 rows (``interpret.COLUMN_CHUNK``)."""
    monkeypatch.setattr(interpret, "COLUMN_CHUNK", chunk)
    holes = "".join(f"X{i} Y{2 * i}\n" for i in range(1, 12))
    prog = "G0 Z5\nMCALL DR\n" + holes + "MCALL\nX20\nY1\nX21\nY2\nX22\nY3\nX23\nY4\nM30\n" \
        "PROC DR\nG1 Z-1 F100\nG0 Z5\nRET\n"
    fast, slow = run(prog), run(prog, fast=False)
    assert ends(fast) == ends(slow) and len(fast.path) == 1 + 3 * 11 + 8


def test_mcall_of_a_cycle_without_source_is_a_warning():
    r = run("MCALL CYCLE81(10, 0, 3, -6)\nG0 X1\nMCALL\n")
    assert xs(r) == [1] and [(k, n) for k, n, _ in r.approximations] == [("MCALL", 1)]


def test_the_bundled_machine_has_no_system_variables():
    assert load_machine("mikron").system_variables == ()
