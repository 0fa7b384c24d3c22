"""The gap diagnosis on HSM programs: corner rounding (G642) and the compressor.

Consistency checks: the recordings are made from ncsim's own plan of our programs (a model
diagnosed against its own trace must leave no gap and name the programmed blocks); the
expected lengths are the programmed legs summed by hand."""
from __future__ import annotations

import math

import numpy as np
import pytest

from ncsim.gap.diagnose import Evaluator, ModelCache, localise
from ncsim.gap.effects import make_base
from ncsim.gap.measured import MeasuredTrace
from ncsim.machine import load_machine
from ncsim.nc.interpret import interpret_text
from ncsim.plan.limits import path_limits


@pytest.fixture(scope="module")
def mikron():
    return load_machine("mikron")


@pytest.fixture(scope="module")
def stopping(mikron):
    """MD32310 = 1: G64 stops at a corner, so G642 rounds them (CTOL 0.05-0.1 below F1000):
    ``plan.blend`` keeps a G64 corner where its rounding would be slower, as it is against the
    MIKRON's 30 mm/s G64 jump."""
    return mikron.with_axes(max_accel_ovl_factor=1.0)


def _corner_contour(mode: str):
    """An irregular meander of 25 lines with 24 right-angle corners (no two passes alike, so
    the registration is unambiguous) and its programmed length, leg by leg."""
    lines = [f"N10 G90 G17 {mode} SOFT", "N20 G0 X0 Y0 Z0", "N30 G1 X10 Y0 F3000"]
    x, y, length = 10, 0, 10.0
    for i in range(12):
        y_new = 10 + i if i % 2 == 0 else 0
        length += abs(y_new - y)
        y = y_new
        lines.append(f"N{40 + 10 * i} Y{y}")
        x += 4 + i
        length += 4 + i
        lines.append(f"N{45 + 10 * i} X{x}")
    lines.append("N999 M30")
    return "\n".join(lines) + "\n", length


def test_rounded_corners_are_reported_on_the_programmed_blocks(stopping):
    """G642 inserts a rounding block at every corner (more rows, a shorter path): the model
    trace must still speak of the programmed blocks and of places along the programmed path,
    as the registration of a recording does. The recording covers the middle of the program,
    its clock runs 0.3 s late."""
    text, length_mm = _corner_contour("G642 CTOL=0.1")
    text = text.replace("F3000", "F900")        # where the roundings beat G64's stops
    path = interpret_text(text, "meander.mpf", stopping).path
    model = make_base(stopping, "full")
    rounded = path_limits(path, stopping).path
    assert rounded.n > path.n + 20                       # the corners are rounded
    t, tr, _, _ = ModelCache(path, dt_s=1e-3, settle_s=0.3).setpoint(model)
    assert tr.s_mm[-1] == pytest.approx(length_mm, abs=1e-6)
    assert set(np.unique(tr.block)) <= set(range(path.n))

    n = len(t)
    part = slice(n // 2, 9 * n // 10, 2)                 # 500 Hz, mid-program
    meas = MeasuredTrace(t_s=t[part] + 0.3, pos_mm=tr.pos_mm[part])
    ev = Evaluator(path, meas)
    g, al, mt = ev.evaluate(model, full=True)
    assert g.gap < 0.01
    assert al.time_shift_s == pytest.approx(0.3, abs=1e-4)
    ok = al.valid
    assert np.mean(al.block[ok] == ev.registration.segment[ok]) > 0.99
    loc = localise(al, mt, path, ev.scales, meas)
    covered = set(np.unique(ev.registration.segment))
    assert loc["n_blocks"] == len(covered)
    for row in loc["blocks"]:
        assert row["block"] in covered and row["line"] == path.line[row["block"]]
        assert abs(row["duration_error_ms"]) < 0.1


def test_programmed_places_of_a_rounded_square(stopping):
    """A square run under G642: the ends of the rounded path are the programmed ones (80 mm),
    a rounding block's middle is its corner (20, 40, 60 mm) and its halves belong to the
    blocks before and after the corner."""
    from ncsim.plan.blend import ProgrammedPlaces

    text = "N10 G90 G17 G642 CTOL=0.05 SOFT\nN20 G1 X20 Y0 F600\nN30 Y20\nN40 X0\nN50 Y0\nN60 M30\n"
    path = interpret_text(text, "square.mpf", stopping).path
    limits = path_limits(path, stopping)
    rounded = limits.path
    places = ProgrammedPlaces.of(path, rounded, limits.row_of)
    blends = np.nonzero(places.programmed_row < 0)[0]
    assert path.n == 4 and len(blends) == 3 and rounded.length_mm.sum() < path.length_mm.sum() - 1e-3
    assert places.programmed_s_mm(rounded.length_mm.sum()) == pytest.approx(path.length_mm.sum())
    s_start = np.concatenate([[0.0], np.cumsum(rounded.length_mm)])
    mid = s_start[blends] + 0.5 * rounded.length_mm[blends]
    assert places.programmed_s_mm(mid) == pytest.approx([20.0, 40.0, 60.0])
    eps = 1e-6
    before = places.programmed_block(blends, places.programmed_s_mm(mid - eps))
    after = places.programmed_block(blends, places.programmed_s_mm(mid + eps))
    assert list(before) == [0, 1, 2] and list(after) == [1, 2, 3]
    assert places.rounded_s_mm(places.programmed_s_mm(mid)) == pytest.approx(mid)


# --- the compressor effect ----------------------------------------------------------------------

def _cam_raster(step_mm=0.05, length_mm=12.0, feed=3000, r_mm=1.5, arcs=10):
    """CAM-like finishing: two passes of tiny G1 blocks (step_mm) along a gentle wave, turned
    round by a semicircle of short arcs (arcs are never compressed, MD20482 hundreds digit 0).
    No compressor is selected: the machine's reset value decides."""
    lines = ["N10 G90 G17 G64 SOFT", "N20 G0 X0 Y0 Z0", f"N30 G1 F{feed}"]
    xs = np.arange(int(round(length_mm / step_mm)) + 1) * step_mm
    for x in xs[1:]:
        lines.append(f"X{x:.4f} Y{0.3 * math.sin(x / 3.0):.4f}")
    xe = xs[-1]
    lines.append("Y0")
    for i in range(1, arcs + 1):                    # centre (xe, r), counter-clockwise
        a = -math.pi / 2 + math.pi * i / arcs
        a0 = -math.pi / 2 + math.pi * (i - 1) / arcs
        lines.append(f"G3 X{xe + r_mm * math.cos(a):.4f} Y{r_mm + r_mm * math.sin(a):.4f} "
                     f"I{-r_mm * math.cos(a0):.4f} J{-r_mm * math.sin(a0):.4f}")
    for x in xs[::-1][1:]:
        lines.append(f"G1 X{x:.4f} Y{2 * r_mm + 0.3 * math.sin(x / 3.0):.4f}")
    lines.append("M30")
    return "\n".join(lines) + "\n"


def test_compressor_on_is_found_on_a_cam_raster(mikron):
    """A raster of 0.05 mm G1 blocks at F3000 on a machine whose reset compressor is COMPCAD
    (the recording) against a model without it: without the compressor every 0.05 mm block
    takes at least an interpolation cycle (eq. 6: 0.05 mm / 12 ms = 4.2 mm/s), with it the run
    is one polynomial block at F. The diagnosis must name the compressor, and COMPCAD, whose
    joined run is not capped like COMPON's 10 blocks (0.5 mm / 12 ms = 42 mm/s), rather than
    a shorter interpolation cycle, which would also speed up the short arcs."""
    from ncsim.gap.diagnose import diagnose
    from ncsim.gap.effects import get_effect
    from ncsim.gap.truth.synth import ScopeConfig, degrade

    text = _cam_raster()
    reinterpret = lambda m: interpret_text(text, "raster.mpf", m).path   # noqa: E731
    path = reinterpret(mikron)
    assert mikron.ncu.reset_compressor == 0 and path.n > 400
    truth = get_effect("compressor").apply(make_base(mikron), {"compressor_mode": "COMPCAD"})
    t, tr, _, _ = ModelCache(reinterpret(truth.machine), dt_s=1e-3,
                             settle_s=0.3).setpoint(truth)
    meas = degrade(t, tr.pos_mm, ScopeConfig(period_s=2e-3, noise_um=0.5), seed=2)
    d = diagnose(path, mikron, meas, reinterpret=reinterpret, do_combine=False,
                 localisation=False)
    best = d.fits[0]
    assert best.effect == "compressor" and best.params == {"compressor_mode": "COMPCAD"}
    assert best.shrink_percent >= 80.0
    runner_up = d.fits[1]
    assert runner_up.gap_after.gap > 10 * best.gap_after.gap


def test_compressor_is_inert_without_short_blocks(mikron):
    """A rectangle of blocks longer than MD20170 (20 mm): no block is compressed, so the
    compressor changes nothing -- it neither shrinks the gap of a recording made at 80 % feed
    override nor counts as sensitive -- while the override explains it."""
    from ncsim.gap.effects import get_effect
    from ncsim.gap.fit import fit_effect
    from ncsim.gap.truth.synth import ScopeConfig, degrade

    text = ("N10 G90 G17 G64 SOFT\nN20 G0 X0 Y0 Z0\nN30 G1 X60 F6000\nN40 Y40\nN50 X0\n"
            "N60 Y0\nN70 M30\n")
    reinterpret = lambda m: interpret_text(text, "rect.mpf", m).path   # noqa: E731
    path = reinterpret(mikron)
    base = make_base(mikron)
    truth = get_effect("feed_override").apply(base, {"feed_override_percent": 80.0})
    t, tr, _, _ = ModelCache(path, dt_s=1e-3, settle_s=0.3).setpoint(truth)
    meas = degrade(t, tr.pos_mm, ScopeConfig(period_s=2e-3, noise_um=0.5), seed=4)
    ev = Evaluator(path, meas, reinterpret=reinterpret,
                   path_key=(mikron.ncu.reset_path_mode, mikron.ncu.reset_compressor))
    before = ev.evaluate(base)
    comp = fit_effect(ev, base, "compressor", gap_before=before)
    assert not comp.sensitive and comp.gap_after.gap == pytest.approx(before.gap, rel=1e-12)
    override = fit_effect(ev, base, "feed_override", gap_before=before)
    assert override.shrink_percent >= 80.0


def test_reset_compressor_is_the_start_of_group_30(mikron):
    """``[ncu] reset_compressor`` (MD20150, group 30) is the compressor of a program that
    selects none; COMPOF in the program still switches it off; the key round-trips through the
    machine file and a wrong value is named."""
    import tomllib

    from ncsim.errors import MachineSpecError
    from ncsim.machine import dump_machine_toml, machine_from_dict

    text = "N10 G1 X0.1 F3000\nN20 X0.2\nN30 COMPOF\nN40 X0.3\nN50 M30\n"
    cad = mikron.with_ncu(reset_compressor=3)
    comp = interpret_text(text, "c.mpf", cad).path.compressor
    assert list(np.abs(comp)) == [3, 3, 0]
    assert list(interpret_text(text, "c.mpf", mikron).path.compressor) == [0, 0, 0]
    back = machine_from_dict(tomllib.loads(dump_machine_toml(cad)))
    assert back.ncu.reset_compressor == 3
    data = tomllib.loads(dump_machine_toml(mikron))
    bad = {**data, "ncu": {**data["ncu"], "reset_compressor": "COMPFOO"}}
    with pytest.raises(MachineSpecError) as err:
        machine_from_dict(bad, "m.toml")
    assert "m.toml: ncu.reset_compressor: must be one of COMPOF" in str(err.value)
