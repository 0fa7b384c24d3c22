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


def test_rounded_corners_are_reported_on_the_programmed_blocks(mikron):
    """G642 inserts a rounding block at every corner (more rows, a shorter path): the model
    trace must still speak of the programmed blocks and of places along the programmed path,
    as the registration of a recording does. The recording covers the middle of the program,
    its clock runs 0.3 s late."""
    text, length_mm = _corner_contour("G642")
    path = interpret_text(text, "meander.mpf", mikron).path
    model = make_base(mikron, "full")
    rounded = path_limits(path, mikron).path
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


def test_programmed_places_of_a_rounded_square(mikron):
    """A square run under G642: the ends of the rounded path are the programmed ones (80 mm),
    a rounding block's middle is its corner (20, 40, 60 mm) and its halves belong to the
    blocks before and after the corner."""
    from ncsim.plan.blend import ProgrammedPlaces

    text = "N10 G90 G17 G642 SOFT\nN20 G1 X20 Y0 F3000\nN30 Y20\nN40 X0\nN50 Y0\nN60 M30\n"
    path = interpret_text(text, "square.mpf", mikron).path
    limits = path_limits(path, mikron)
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
