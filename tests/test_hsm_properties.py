"""The HSM modes against the programs they replace: metamorphic relations and the reproducers.

Relations (truth: the plain program itself, planned by the same planner -- a relation between
two runs, not a value copied from ncsim):

* the compressor (COMPON, COMPCURV, COMPCAD) on a raster or a CAM-like program is never slower
  than COMPOF on the same points by more than a few IPO cycles (``ncsim.plan.hsm``: corner
  detection by speed), no block runs above its F, and no run is faster than its ideal time;
* G642/G645 corner rounding is never slower than plain G64 on the same polyline, and a larger
  tolerance is never slower than a smaller one (``ncsim.plan.blend``);
* doubling every F never makes a program slower.

The reproducers of the fuzzing campaign are read in place from ``../shared`` (W1, M1, M2, M3,
S1 of its README's table), with the results its "expected" column asks for.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from ncsim.machine import load_machine
from ncsim.nc.interpret import interpret_text
from ncsim.pipeline import simulate
from ncsim.plan.compressor import compress
from ncsim.report.summary import summary

T_CY = 0.012
FEW_CYCLES_S = 3 * T_CY          # "a few IPO cycles"
SETTINGS = settings(max_examples=25, deadline=None, derandomize=True, database=None,
                    suppress_health_check=[HealthCheck.too_slow])
REPRO = "data/fuzz-repro-s3"
MIKRON = load_machine("mikron")


def run(text: str, name: str = "p.mpf"):
    return simulate(name, MIKRON, text=text)


def assert_feeds_within_f(sim) -> None:
    """No feed move above its programmed F; the run not faster than its ideal time, and
    cycle = ideal + lost + dwell (the README's accounting)."""
    feed = ~sim.path.rapid
    assert np.all(sim.motion.feed_max_mm_s[feed] <= sim.path.feed_mm_s[feed] * (1 + 1e-9))
    s = summary(sim, include_blocks=False)
    assert s["cycle_time_s"] >= s["ideal_time_s"] * (1 - 1e-9)
    assert s["cycle_time_s"] == pytest.approx(s["ideal_time_s"] + s["lost_time_s"]
                                              + s["dwell_time_s"], rel=1e-9, abs=1e-9)


# ---------------------------------------------------------------------------------------------
# random programs
# ---------------------------------------------------------------------------------------------

@st.composite
def rasters(draw):
    """A random raster as a fuzzer writes it: a random walk of 20-100 short G1 blocks whose
    direction drifts (gently to wildly), sometimes turning back on itself, in a random
    continuous-path mode and feed."""
    seed = draw(st.integers(0, 2 ** 32 - 1))
    rng = np.random.default_rng(seed)
    lo, hi = sorted(rng.uniform(0.02, 0.6, 2))
    turn = draw(st.sampled_from([0.05, 0.3, 1.0, 2.5]))
    n = draw(st.integers(20, 100))
    heading = rng.uniform(0, 2 * np.pi)
    point = np.zeros(2)
    body = []
    for _ in range(n):
        heading += rng.normal(0, turn) if rng.random() > 0.1 else np.pi * rng.uniform(0.8, 1.0)
        point = point + rng.uniform(lo, hi) * np.array([np.cos(heading), np.sin(heading)])
        body.append(f"X{point[0]:.4f} Y{point[1]:.4f}")
    mode = draw(st.sampled_from(["G64", "G641 ADIS=0.05", "G642", "G645", "G642 CTOL=0.02"]))
    feed = draw(st.sampled_from([500, 2224, 3617, 6000, 12000]))
    return mode, feed, body


@st.composite
def cam_passes(draw):
    """A CAM-like finishing program: zig-zag passes along X over a wavy surface, cut into G1
    blocks of random length, positions rounded to 1 um, 0.3 mm step-overs."""
    rng = np.random.default_rng(draw(st.integers(0, 2 ** 32 - 1)))
    length = rng.uniform(5, 30)
    wave = draw(st.sampled_from([0.0, 1.0, 3.0]))
    lo, hi = sorted(rng.uniform(0.03, 0.6, 2))
    body, x_now = [], 0.0
    for k in range(draw(st.integers(2, 4))):
        x = x_now + np.cumsum(rng.uniform(lo, hi, int(length / lo) + 2)) * (-1 if k % 2 else 1)
        x = x[(x > 0) & (x < length)]
        if len(x):
            x_now = float(x[-1])
        body += [f"X{xi:.3f} Z{wave * math.sin(xi / 3):.3f}" for xi in x]
        body.append(f"Y{0.3 * (k + 1):.3f}")
    mode = draw(st.sampled_from(["G64", "G642", "G645", "G641 ADIS=0.1"]))
    feed = draw(st.sampled_from([1000, 3000, 6000, 15000]))
    return mode, feed, body


def compressed_program(mode, feed, body, word) -> str:
    return "\n".join([f"G17 G90 {mode} SOFT FFWON", "G0 X0 Y0 Z0", word,
                      f"G1 X0 Y0 Z-1 F{feed}"] + body + ["M30"]) + "\n"


@st.composite
def polylines(draw):
    """3-24 lines of random length (0.05-30 mm) turning by random angles, at a random feed,
    SOFT or BRISK."""
    rng = np.random.default_rng(draw(st.integers(0, 2 ** 32 - 1)))
    lo, hi = sorted(rng.uniform(0.05, 30, 2))
    heading, point, body = 0.0, np.zeros(2), []
    for _ in range(draw(st.integers(3, 24))):
        heading += rng.uniform(-np.pi, np.pi) * draw(st.sampled_from([0.1, 0.5, 1.0]))
        point = point + rng.uniform(lo, hi) * np.array([np.cos(heading), np.sin(heading)])
        body.append(f"X{point[0]:.4f} Y{point[1]:.4f}")
    return (body, draw(st.sampled_from([300, 1000, 3000, 6000, 12000, 20000])),
            draw(st.sampled_from(["SOFT", "BRISK"])))


def corner_program(body, feed, accel_mode, mode) -> str:
    return "\n".join([f"G17 G90 {accel_mode} {mode}", f"G1 X0 Y0 F{feed}"] + body + ["M30"]) + "\n"


# ---------------------------------------------------------------------------------------------
# the compressor
# ---------------------------------------------------------------------------------------------

@SETTINGS
@given(program=st.one_of(rasters(), cam_passes()))
def test_compressor_is_never_slower_than_compof(program):
    mode, feed, body = program
    off = run(compressed_program(mode, feed, body, "COMPOF"))
    for word in ("COMPON", "COMPCURV", "COMPCAD"):
        sim = run(compressed_program(mode, feed, body, word))
        assert sim.cycle_time_s <= off.cycle_time_s + FEW_CYCLES_S, word
        assert_feeds_within_f(sim)


def assert_curvature_from_the_points(path, c) -> None:
    """No curvature the points do not have (``ncsim.plan.compressor``): at every joined point
    the fitted curvature is at most (14/3) Theta / W, Theta the total turn of the programmed
    points within the kernel's reach (+-2 W along the run), W the point's half-width -- the
    bound a kernel smoothing with |P'| >= 1/2 obeys. A near-cusp (|P'| -> 0 at a reversal)
    breaks it by orders of magnitude (M3: 273 times)."""
    d = path.end_mm - path.start_mm
    u = d / path.length_mm[:, None]
    turn = np.zeros(path.n + 1)
    turn[1:-1] = np.arccos(np.clip(np.einsum("ij,ij->i", u[:-1], u[1:]), -1.0, 1.0))
    s = np.concatenate([[0.0], np.cumsum(path.length_mm)])
    run_id = np.cumsum(~c.joined)              # junctions of one run share it with its start
    for k in np.nonzero(c.joined)[0]:
        w = c.window_mm[k]
        near = (np.abs(s - s[k]) < 2 * w) & (run_id == run_id[k])
        theta = turn[near].sum()
        assert c.junction_curvature_1_mm[k] <= 14 / 3 * theta / w * (1 + 1e-6) + 1e-9, k


@SETTINGS
@given(program=rasters())
def test_fitted_curvature_is_bounded_by_the_points_turn(program):
    mode, feed, body = program
    path = interpret_text(compressed_program(mode, feed, body, "COMPCURV"), "r.mpf", MIKRON).path
    c = compress(path, MIKRON)
    if c is not None:
        assert_curvature_from_the_points(path, c)


def test_no_near_cusp_on_the_m3_raster(shared):
    """M3's raster turns back on itself (line 89-90): the fit there had a curvature of
    136,000 /mm (a set point of 0.41 mm/min); the point is a corner now."""
    from ncsim.nc.interpret import interpret_file

    path = interpret_file(str(shared / REPRO / "M3_raster_COMPON.mpf"), MIKRON).path
    c = compress(path, MIKRON)
    assert c.joined.sum() > 0.5 * path.n
    assert_curvature_from_the_points(path, c)


def test_refitting_only_the_runs_that_lose_a_point_is_the_full_fit(mikron):
    """``compress(kept, previous=)`` refits only the runs that lose a junction: the same result
    as fitting everything again (up to rounding of the arc-length sums)."""
    body = [f"X{0.1 * i:.4f} Y{0.3 * math.sin(0.07 * i):.4f}" for i in range(1, 400)]
    path = interpret_text(compressed_program("G64", 6000, body, "COMPCAD"), "r.mpf", mikron).path
    first = compress(path, mikron)
    kept = np.zeros(path.n + 1, dtype=bool)
    kept[[50, 51, 200, 333]] = True
    again = compress(path, mikron, kept, previous=first)
    full = compress(path, mikron, kept)
    np.testing.assert_array_equal(again.joined, full.joined)
    assert not again.joined[[50, 51, 200, 333]].any() and again.joined[100]
    for name in ("curvature_1_mm", "curvature_change_1_mm", "deviation_mm", "window_mm",
                 "group_length_mm", "junction_curvature_1_mm"):
        np.testing.assert_allclose(getattr(again, name), getattr(full, name), rtol=1e-6,
                                   atol=1e-9, err_msg=name)


# ---------------------------------------------------------------------------------------------
# corner rounding
# ---------------------------------------------------------------------------------------------

@SETTINGS
@given(program=polylines(), mode=st.sampled_from(["G642", "G645"]))
def test_rounding_is_never_slower_than_g64_nor_a_larger_tolerance(program, mode):
    body, feed, accel_mode = program
    g64 = run(corner_program(body, feed, accel_mode, "G64")).cycle_time_s
    before = math.inf
    for tol in (0.001, 0.01, 0.05, 0.2, 1.0):
        sim = run(corner_program(body, feed, accel_mode, f"{mode} CTOL={tol}"))
        assert_feeds_within_f(sim)
        assert sim.cycle_time_s <= g64 + FEW_CYCLES_S, tol
        assert sim.cycle_time_s <= before + FEW_CYCLES_S, tol
        before = sim.cycle_time_s


def test_a_rounding_at_f_does_not_slow_the_lines_around_it():
    """BRISK at F12000: the first corner's 0.2 mm rounding is crossed at F (it does not limit
    the feed) and leaves 1.1 m/s^2 of tangential acceleration; the lines beside it ramp with
    their own 2.9 m/s^2 (the planner ramps under each block's own limits: with the least of
    the section, this program took 83 ms more than in G64)."""
    body = ["X16.0856 Y9.5456", "X28.2727 Y22.4672", "X29.2251 Y42.6091", "X28.7272 Y64.7459",
            "X45.6560 Y72.8187"]
    g64 = run(corner_program(body, 12000, "BRISK", "G64")).cycle_time_s
    rounded = run(corner_program(body, 12000, "BRISK", "G642 CTOL=0.2")).cycle_time_s
    assert rounded <= g64 + FEW_CYCLES_S


# ---------------------------------------------------------------------------------------------
# doubling F
# ---------------------------------------------------------------------------------------------

@st.composite
def line_arc_programs(draw):
    """G64 chains of lines and tangent or kinked G2/G3 arcs (radius 1-40 mm), feeds changing
    along the way."""
    rng = np.random.default_rng(draw(st.integers(0, 2 ** 32 - 1)))
    blocks = []                       # (text without F, feed)
    point, heading = np.zeros(2), rng.uniform(0, 2 * np.pi)
    feed = rng.uniform(300, 12000)
    for _ in range(draw(st.integers(2, 8))):
        if rng.random() < 0.5:
            heading += rng.choice([0.0, rng.uniform(-2, 2)])
            point = point + rng.uniform(0.5, 40) * np.array([np.cos(heading), np.sin(heading)])
            blocks.append((f"G1 X{point[0]:.4f} Y{point[1]:.4f}", feed))
        else:
            radius, sweep, ccw = rng.uniform(1, 40), rng.uniform(0.2, 3.0), rng.random() < 0.5
            side = 1.0 if ccw else -1.0
            centre = point + radius * side * np.array([-np.sin(heading), np.cos(heading)])
            a1 = math.atan2(*(point - centre)[::-1]) + side * sweep
            end = centre + radius * np.array([np.cos(a1), np.sin(a1)])
            blocks.append((f"{'G3' if ccw else 'G2'} X{end[0]:.4f} Y{end[1]:.4f} "
                           f"I{centre[0] - point[0]:.4f} J{centre[1] - point[1]:.4f}", feed))
            point, heading = end, heading + side * sweep
        if rng.random() < 0.3:
            feed = rng.uniform(300, 12000)
    return draw(st.sampled_from(["SOFT", "BRISK"])), blocks


@SETTINGS
@given(program=line_arc_programs())
def test_doubling_every_feed_is_never_slower(program):
    accel_mode, blocks = program

    def text(scale):
        return "\n".join([f"G17 G90 G64 {accel_mode} FFWON", "G0 X0 Y0"]
                         + [f"{b} F{f * scale:.4f}" for b, f in blocks] + ["M30"]) + "\n"

    assert run(text(2.0)).cycle_time_s <= run(text(1.0)).cycle_time_s + 1e-9


# ---------------------------------------------------------------------------------------------
# the reproducers (../shared/data/fuzz-repro-s3, README table)
# ---------------------------------------------------------------------------------------------

def repro(shared, name):
    return simulate(str(shared / REPRO / name), MIKRON)


def test_w1_compressor_keeps_every_block_at_its_feed(shared):
    """W1: COMPCAD over blocks programmed F88, F95.1, F5122.5 -- every block at most its F
    (the F95.1 block ran at 1969 mm/min), the cycle not below the ideal time and the identity
    cycle = ideal + lost + dwell; not slower than the same program under COMPOF."""
    sim = repro(shared, "W1_compressor_feed_above_F.mpf")
    assert_feeds_within_f(sim)
    line5 = sim.path.line == 5
    assert line5.any() and np.all(sim.motion.feed_max_mm_s[line5] * 60 <= 95.1 * (1 + 1e-9))
    off = repro(shared, "W1_compressor_off_reference.mpf")
    assert sim.cycle_time_s <= off.cycle_time_s + FEW_CYCLES_S


@pytest.mark.parametrize("compressed, plain", [
    ("M3_raster_COMPON.mpf", "M3_raster_COMPOF.mpf"),
    ("M3_raster2_COMPCAD.mpf", "M3_raster2_COMPOF.mpf")])
def test_m3_compressor_not_slower_than_compof_on_a_raster(shared, compressed, plain):
    """M3: COMPON took 13.4 s against 2.3 s (a near-cusp held at 0.41 mm/min), COMPCAD 2.94 s
    against 2.13 s; now within a few IPO cycles of COMPOF, no set point of a near-cusp."""
    sim, off = repro(shared, compressed), repro(shared, plain)
    assert sim.cycle_time_s <= off.cycle_time_s + FEW_CYCLES_S
    assert sim.motion.cap_mm_s.min() >= off.motion.cap_mm_s.min() * (1 - 1e-9)
    assert_feeds_within_f(sim)


def test_m1_rounding_not_slower_than_the_square_in_g64(shared):
    """M1: G642 with MD33100 (0.01 mm) or CTOL=0.01 took 1.540/1.545 s against 1.381 s in G64:
    a 0.01 mm rounding of a 90 deg corner at F6000 is held at d / t_cy = 4 mm/s, where G64
    crosses with the MD32310 jump at 30 mm/s; the corner stays a G64 corner then."""
    g64 = repro(shared, "M1_square_G64.mpf").cycle_time_s
    for name in ("M1_square_G642.mpf", "M1_square_G642_CTOL0.01.mpf", "M1_square_G642_CTOL0.mpf"):
        assert repro(shared, name).cycle_time_s <= g64 + FEW_CYCLES_S, name


def test_m2_doubling_f_is_not_slower(shared):
    """M2: an arc held at 9639 mm/min (eq. 11) followed by a short line at F19073 took 51 ms
    longer than both at F9536.5: a zero-acceleration knot stayed where the set point rises
    (arc -> line) although the feed falls through it, so the line braked from rest
    acceleration within its 11.5 mm (5436 instead of 7599 mm/min at its start)."""
    slow = repro(shared, "M2_doubleF_F.mpf")
    fast = repro(shared, "M2_doubleF_2F.mpf")
    assert fast.cycle_time_s <= slow.cycle_time_s
    assert not fast.motion.knot[2]                   # the arc -> line junction
    assert fast.motion.v_junction_mm_s[2] >= slow.motion.v_junction_mm_s[2] * (1 - 1e-9)


def test_s1_negative_ctol_deletes_the_programmed_tolerance_with_a_warning(shared):
    """S1: ``CTOL=-1`` is the 840D's way to delete a programmed tolerance (Job Planning "CTOL,
    OTOL, ATOL": "deleted by means of the assignment of a negative value", its example
    ``CTOL=-1 ; The machine and setting data is applied again``): not an error as ADIS=-1 is,
    but no longer silent -- a warning at the word; the machine data's tolerance applies."""
    from ncsim.errors import NcError
    from ncsim.nc.interpret import interpret_file

    r = interpret_file(str(shared / REPRO / "S1_ctol_negative.mpf"), MIKRON)
    (w,) = [w for w in r.warnings if "CTOL=-1" in w.message]
    assert (w.line, w.column) == (1, 14) and "deletes the programmed tolerance" in w.message
    assert np.all(np.isnan(r.path.ctol_mm))
    text = (shared / REPRO / "S1_ctol_negative.mpf").read_text()
    assert run(text).cycle_time_s == run(text.replace("CTOL=-1 ", "")).cycle_time_s
    otol = interpret_text("G17 G90 G642 OTOL=-2 G1 X0 Y0 F6000\nX20\nM30\n", "o.mpf", MIKRON)
    assert any("OTOL=-2" in w.message and w.column == 14 for w in otol.warnings)
    with pytest.raises(NcError, match="ADIS must not be negative"):
        interpret_file(str(shared / REPRO / "S1_adis_negative.mpf"), MIKRON)
