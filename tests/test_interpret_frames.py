"""Frames: programmable (TRANS ROT SCALE MIRROR and A-forms), settable (G54.., G500), SUPA/G53."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from ncsim.config import load_setup
from ncsim.nc.frames import Frame, axis_rotation, cos_sin_deg, rotation_rpy
from ncsim.errors import MachineSpecError
from ncsim.nc.interpret import interpret_text


def ends(text, **kw):
    r = interpret_text(text, "f.mpf", **kw)
    return [s.end_mm.tolist() for s in r.path.segments()], r


def close(a, b):
    return np.allclose(np.asarray(a, dtype=float), np.asarray(b, dtype=float), atol=1e-12, rtol=0)


def test_trans_and_absolute_trans_replaces():
    e, _ = ends("G1 F100\nTRANS X10 Y5\nX1 Y1\nTRANS Z2\nX1 Y1 Z0\nTRANS\nX1 Y1 Z0\n")
    assert e == [[11, 6, 0], [1, 1, 2], [1, 1, 0]]


def test_unprogrammed_axes_keep_their_machine_position_after_a_frame_change():
    e, _ = ends("G1 X11 Y6 F100\nTRANS Z2\nX1 Y1\n")
    assert e == [[11, 6, 0], [1, 1, 0]]


def test_arot_turns_about_the_translated_origin():
    e, _ = ends("G1 F100\nTRANS X10\nAROT Z90\nX1 Y0\n")
    assert close(e[0], [10, 1, 0])


def test_atrans_after_arot_moves_along_rotated_axes():
    e, _ = ends("G1 F100\nTRANS X10\nAROT Z90\nATRANS X5\nX0 Y0\n")
    assert close(e[0], [10, 5, 0])


def test_rot_rpy_order_z_then_y_then_x():
    # R = Rz(90) Rx(90): (0, 1, 0) -> (0, 0, 1) -> (0, 0, 1); (1, 0, 0) -> (1, 0, 0) -> (0, 1, 0)
    e, _ = ends("G1 F100\nROT X90 Z90\nX0 Y1 Z0\nX1 Y0 Z0\n")
    assert close(e[0], [0, 0, 1]) and close(e[1], [0, 1, 0])


def test_rot_rpl_in_the_active_plane():
    e, _ = ends("G18 G1 F100\nROT RPL=90\nX1 Y0 Z0\n")   # G18: about Y, X -> -Z
    assert close(e[0], [0, 0, -1])


def test_exact_quarter_turn_matrices():
    assert cos_sin_deg(-90.0) == (0.0, -1.0) and cos_sin_deg(180.0) == (-1.0, 0.0)
    assert axis_rotation(1, -90.0).tolist() == [[0.0, 0.0, -1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]]
    c, s = cos_sin_deg(30.0)
    assert c == pytest.approx(math.sqrt(3) / 2) and s == pytest.approx(0.5)


def test_frame_apply_is_the_same_for_floats_and_arrays():
    f = rotation_rpy({"Z": 33.0, "X": 12.0}).offset_by((1.0, 2.0, 3.0))
    pts = np.random.default_rng(0).normal(size=(50, 3)) * 100
    rows = f.apply_rows(pts)
    for p, q in zip(pts, rows):
        assert list(f.apply(float(p[0]), float(p[1]), float(p[2]))) == q.tolist()
    back = [f.inverse_apply(*q) for q in rows.tolist()]
    assert np.allclose(back, pts, atol=1e-9)


def test_uniform_scale_scales_arcs():
    r = interpret_text("G1 F100\nSCALE X2 Y2 Z2\nX3\nG2 I-3\n")
    arc = r.path.segment(1)
    assert arc.end_mm.tolist() == [6, 0, 0] and arc.radius_mm == 6.0 and arc.center_mm.tolist() == [0, 0, 0]


def test_ascale_multiplies_and_scales_later_atrans():
    e, _ = ends("G1 F100\nSCALE X2 Y2\nASCALE X3 Y3\nATRANS X1\nX0 Y0\n")
    assert close(e[0], [6, 0, 0])   # the translation 1 is given in the scaled system


def test_mirror_flips_the_arc_direction():
    r = interpret_text("G1 X10 F100\nMIRROR X0\nG3 X-20 Y0 I-5 J0\n")
    arc = r.path.segment(1)
    assert close(arc.start_mm, [10, 0, 0]) and close(arc.end_mm, [20, 0, 0])
    assert close(arc.center_mm, [15, 0, 0]) and close(arc.normal, [0, 0, -1])   # G3 became clockwise


def test_amirror_twice_cancels():
    e, _ = ends("G1 F100\nAMIRROR X0\nAMIRROR X0\nX4\n")
    assert e == [[4, 0, 0]]


def test_rotated_arc_keeps_its_direction_in_its_rotated_plane():
    r = interpret_text("G1 F100\nROT X90\nG3 X10 Y0 I5\n")
    arc = r.path.segment(0)
    assert close(arc.center_mm, [5, 0, 0]) and close(arc.normal, [0, -1, 0])


def test_g54_offsets_from_setup_override_machine(mikron):
    machine = dataclasses.replace(mikron, work_offsets_mm=(("G54", (1.0, 2.0, 3.0)), ("G55", (7.0, 0.0, 0.0))))
    e, r = ends("G54 G1 X1 Y0 Z0 F100\nG55 X1 Y0 Z0\nG500 X1 Y0 Z0\nM30\n", machine=machine,
                setup_offsets={"G55": (0.0, 9.0, 0.0)})
    assert e == [[2, 2, 3], [1, 9, 0], [1, 0, 0]]
    assert r.warnings == ()


def test_missing_work_offset_warns_and_uses_zero():
    e, r = ends("G54 G1 X1 F100\nM30\n")
    assert e == [[1, 0, 0]]
    assert [(w.line, w.column) for w in r.warnings] == [(1, 1)] and "G54" in r.warnings[0].message


def test_supa_and_g53_suppress_frames_for_one_block():
    e, _ = ends("G54 G1 F100\nTRANS X5\nG0 X0 Y0 Z0\nSUPA G0 X0 Y0 Z0\nG1 X1\nG53 G0 Z7\nG1 Y1\n",
                setup_offsets={"G54": (100.0, 0.0, 0.0)})
    assert e == [[105, 0, 0], [0, 0, 0], [106, 0, 0], [106, 0, 7], [106, 1, 7]]


def test_inch_trans():
    e, _ = ends("G70 G1 F100\nTRANS X1\nX0\n")
    assert e == [[25.4, 0, 0]]


def test_frame_change_keeps_the_machine_position():
    # after AROT the unprogrammed axes keep their machine position
    e, _ = ends("G1 X10 Y0 F100\nAROT Z90\nZ5\n")
    assert close(e[1], [10, 0, 5])


def test_load_setup(tmp_path):
    good = tmp_path / "setup.toml"
    good.write_text("[work_offsets]\nG54 = [1, 2.5, -3]\nG505 = [0, 0, 0]\n")
    assert load_setup(good) == {"G54": (1.0, 2.5, -3.0), "G505": (0.0, 0.0, 0.0)}
    bad = tmp_path / "bad.toml"
    bad.write_text("[work_offsets]\nG54 = [1, 2]\n")
    with pytest.raises(MachineSpecError, match="work_offsets.G54: must be a list of three numbers"):
        load_setup(bad)
    bad.write_text("[work_offsets]\nG99 = [1, 2, 3]\n")
    with pytest.raises(MachineSpecError, match="work_offsets.G99: unknown work offset"):
        load_setup(bad)
    bad.write_text("offsets = 1\n")
    with pytest.raises(MachineSpecError, match="offsets: unknown key"):
        load_setup(bad)
    with pytest.raises(MachineSpecError, match="cannot read setup file"):
        load_setup(tmp_path / "missing.toml")


def test_frame_then_composes_in_the_new_system():
    f = Frame().then(Frame(((0.0, -1.0, 0.0), (1.0, 0.0, 0.0), (0.0, 0.0, 1.0)), (0.0, 0.0, 0.0)))
    g = f.then(Frame(t=(5.0, 0.0, 0.0)))
    assert g.t == (0.0, 5.0, 0.0)
