"""The NC block compressor (ncsim.plan.compressor) on CAM rasters of short G1 blocks.

Truths: the fitted curve is checked by brute-force numerical integration of the triangular
kernel (not the closed form), the curvature against the circle the points were taken from,
the feeds against the paper's closed forms (eq. 6, 11; Table 3 for a 30-mm circle), and the
interrupters against the 840D's rules (B1 "Compressor functions", Job Planning "NC block
compression").
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from ncsim.machine import load_machine
from ncsim.motion import Limit
from ncsim.nc.interpret import interpret_text
from ncsim.pipeline import simulate
from ncsim.plan.compressor import compress
from ncsim.plan.crosscheck import crosscheck
from ncsim.plan.limits import block_limits, path_limits
from ncsim.report.summary import summary

T_CY = 0.012
F_MM_S = 100.0


def raster(words: str, passes=4, length=60.0, seed=3, wave_mm=0.0) -> str:
    """A zig-zag raster as CAM writes it: passes along X cut into G1 blocks of random length
    0.05..0.5 mm, positions rounded to 1 um, Z = wave_mm sin(x / 10) (0: a flat, straight
    stretch), 0.6 mm step-over moves between passes, F6000."""
    rng = np.random.default_rng(seed)
    out = ["G17 G90 G71 G94 G64 SOFT " + words, "G0 X0 Y0 Z1", "G1 Z0 F6000"]
    x_now = 0.0
    for k in range(passes):
        steps = np.cumsum(rng.uniform(0.05, 0.5, int(length / 0.05)))
        x = x_now - steps if k % 2 else x_now + steps
        x = x[(x > 0.0) & (x < length)]
        x_now = float(x[-1])
        for xi in x:
            out.append(f"X{xi:.3f} Z{wave_mm * math.sin(xi / 10.0):.3f}")
        out.append(f"Y{0.6 * (k + 1):.3f}")
    return "\n".join(out + ["G0 Z5", "M30"]) + "\n"


@pytest.fixture(scope="module")
def mikron_module():
    return load_machine("mikron")


def test_compcad_lifts_the_cycle_time_limit_and_reaches_f(mikron_module):
    """Without the compressor the 0.05-0.5 mm blocks are held by eq. 6 (at most L / 12 ms =
    4..42 mm/s); with COMPCAD the joined run is one block and the feed reaches F = 100 mm/s on
    the straight passes. Without the word nothing changes."""
    plain = simulate("raster.mpf", mikron_module, text=raster(""))
    cad = simulate("raster.mpf", mikron_module, text=raster("COMPCAD"))
    share = {}
    for name, sim in (("plain", plain), ("cad", cad)):
        s = summary(sim, include_blocks=False)
        share[name] = s["time_by_limit_s"].get("cycle_time", 0.0) / s["feed_time_s"]
    assert share["plain"] > 0.9 and share["cad"] < 0.05
    assert cad.cycle_time_s < 0.25 * plain.cycle_time_s
    # on the straight passes the set point is F (the plain blocks: at most L / t_cy)
    straight = (cad.path.end_mm[:, 1] == cad.path.start_mm[:, 1]) & (cad.path.length_mm < 0.5)
    assert np.all(cad.motion.cap_mm_s[straight] == pytest.approx(F_MM_S))
    assert plain.motion.cap_mm_s[straight].max() <= 0.5 / T_CY + 1e-9
    assert cad.motion.feed_max_mm_s.max() == pytest.approx(F_MM_S)
    # the middle of every 60 mm pass is at F: a ramp 0 -> F at J_tcurv = 6 m/s^3 takes
    # 2 sqrt(F / J) = 0.26 s and F x 0.13 s = 12.9 mm
    middle = straight & (np.minimum(cad.path.start_mm[:, 0], cad.path.end_mm[:, 0]) > 20.0) \
        & (np.maximum(cad.path.start_mm[:, 0], cad.path.end_mm[:, 0]) < 40.0)
    assert middle.sum() > 100
    assert np.all(cad.motion.feed_max_mm_s[middle] == pytest.approx(F_MM_S))
    assert np.all(plain.motion.feed_max_mm_s[middle] <= 0.5 / T_CY + 1e-9)
    # nothing changes without a compressor: COMPOF or no word plan exactly the programmed path
    off = simulate("raster.mpf", mikron_module, text=raster("COMPOF"))
    assert off.cycle_time_s == plain.cycle_time_s and off.path.n == plain.path.n
    lim = path_limits(plain.interpreted.path, mikron_module)
    raw = block_limits(plain.interpreted.path, mikron_module)
    np.testing.assert_array_equal(lim.cap_mm_s, raw.cap_mm_s)
    np.testing.assert_array_equal(lim.junction_cap_mm_s, raw.junction_cap_mm_s)


def test_fitted_curve_stays_within_the_tolerance(mikron_module):
    """At every programmed point of a run the fitted (triangular-kernel smoothed) curve lies
    within MD33100 = 0.01 mm per axis, or within CTOL; checked by integrating the kernel
    numerically over the polyline (independent of the closed form)."""
    for words, check in (("COMPCAD", "axes"), ("COMPCAD CTOL=0.004", "ctol")):
        path = interpret_text(raster(words, wave_mm=3.0), "raster.mpf", mikron_module).path
        c = compress(path, mikron_module)
        assert c is not None and c.in_run.sum() > 0.95 * (path.kind == 0).sum()
        pts = np.vstack([path.start_mm[:1], path.end_mm])
        s = np.concatenate([[0.0], np.cumsum(path.length_mm)])
        d_first = (pts[1] - pts[0]) / path.length_mm[0]
        d_last = (pts[-1] - pts[-2]) / path.length_mm[-1]

        def end_dir(x, inside, i):
            return np.where(x < inside, d_first[i], d_last[i])

        inner = np.nonzero(c.joined)[0]
        rng = np.random.default_rng(0)
        # points whose kernel (2 W either side) lies inside their run
        reach = np.searchsorted(s, s[inner] + 2 * c.window_mm[inner] + 0.5)
        start = np.searchsorted(s, s[inner] - 2 * c.window_mm[inner] - 0.5) - 1
        cum = np.concatenate([[0], np.cumsum(~c.joined)])
        interior = inner[(start >= 0) & (reach <= path.n)
                         & (cum[np.minimum(reach, path.n) + 1] - cum[np.maximum(start, 0)] == 0)]
        assert len(interior) > 0.5 * len(inner)
        for k in rng.choice(interior, 60, replace=False):
            w = c.window_mm[k]
            u = np.linspace(-2 * w, 2 * w, 8001)
            # (4/3) K_W - (1/3) K_2W, K_a the triangle of half-width a and area 1
            weight = (4 / 3 * np.maximum(1 - np.abs(u) / w, 0) / w
                      - 1 / 3 * np.maximum(1 - np.abs(u) / (2 * w), 0) / (2 * w))
            x = s[k] + u
            inside = np.clip(x, s[0], s[-1])       # beyond the ends: the end lines go on
            smoothed = np.array([np.trapezoid(weight * (np.interp(inside, s, pts[:, i])
                                                        + (x - inside) * end_dir(x, inside, i)), u)
                                 for i in range(3)])
            dev = smoothed - pts[k]
            if check == "axes":
                assert np.all(np.abs(dev) <= 0.01 + 1e-6), (k, dev)
            else:
                assert np.linalg.norm(dev) <= 0.004 + 1e-6
            assert np.linalg.norm(dev) == pytest.approx(c.deviation_mm[k], abs=2e-6)


def polyline_circle(radius, step, feed_mm_min, words="COMPCAD"):
    """A full circle written as G1 chords of ~``step`` mm (points on the circle, 1 um)."""
    n = int(round(2 * math.pi * radius / step))
    a = -math.pi / 2 + 2 * math.pi * np.arange(n + 1) / n
    pts = [f"X{radius * math.cos(t):.3f} Y{radius * math.sin(t):.3f}" for t in a]
    return "\n".join([f"G17 G90 G71 G64 SOFT {words}", f"G0 {pts[0]}", f"G1 {pts[1]} F{feed_mm_min}"]
                     + pts[2:] + ["M30"]) + "\n"


def test_compressed_circle_has_the_circles_curvature_and_the_papers_feed(mikron_module):
    """A 30 mm circle of 0.2 mm chords: the fitted curvature is 1/30, and the set point is the
    NCU path-jerk limit of the arc, (J_tcurv R^2)^(1/3) = 10.53 m/min -- the feed the paper
    measured on the R 30 circle at F 12 and 24 m/min (Table 3, eq. 11)."""
    sim = simulate("circle.mpf", mikron_module, text=polyline_circle(30.0, 0.2, 24000))
    c = compress(sim.interpreted.path, mikron_module)
    # away from the ends of the run, where the fit continues along the end directions
    inner = c.in_run & (np.arange(sim.path.n) > 100) & (np.arange(sim.path.n) < sim.path.n - 100)
    assert np.allclose(c.curvature_1_mm[inner], 1 / 30, rtol=0.01)
    caps = sim.motion.cap_mm_s[inner] * 60 / 1000
    assert np.median(caps) == pytest.approx(10.53, abs=0.1)
    assert np.all(sim.motion.cap_limit[inner] == Limit.NCU_PATH_JERK)
    assert crosscheck(sim.motion, max_blocks=400).summary()["violations"] == 0


def test_compon_joins_ten_blocks_and_the_last_feed_applies(mikron_module):
    """COMPON/COMPCURV: one polynomial per 10 blocks, so eq. 6 applies to 10 blocks (10 x 0.1 mm
    / 12 ms = 83.3 mm/s below F 100); COMPCAD joins the whole run. FNORM: the F of a polynomial's
    last block applies to all of it, and a polynomial ends where the programmed F changes, so
    that F is every block's own (no block runs faster or slower than its F)."""
    text = ("G17 G90 G71 G64 SOFT {}\nG1 X0 Y0 F6000\n" + "\n".join(f"X{0.1 * i:.1f}" for i in range(1, 41))
            + "\nM30\n")
    for word, expected in (("COMPON", 1.0 / T_CY), ("COMPCURV", 1.0 / T_CY), ("COMPCAD", F_MM_S)):
        lim = path_limits(interpret_text(text.format(word), "t.mpf", mikron_module).path,
                          mikron_module)
        assert lim.cap_mm_s[1:39] == pytest.approx(expected), word
    two_feeds = text.format("COMPON").replace("X0.5\n", "X0.5 F3000\n")
    path = interpret_text(two_feeds, "t.mpf", mikron_module).path
    c = compress(path, mikron_module)
    assert path.feed_mm_s[3] == 100.0 and path.feed_mm_s[4] == 50.0   # X0.5 F3000 is row 4
    np.testing.assert_array_equal(c.group_feed_mm_s[c.in_run], path.feed_mm_s[c.in_run])
    assert c.group_first[3] == 0 and c.group_first[4] == 4 and c.group_first[13] == 4
    assert c.group_length_mm[4] == pytest.approx(1.0)      # rows 4..13: ten 0.1 mm blocks
    assert c.group_first[14] == 14                          # then the next ten


def test_interrupters_end_a_run(mikron_module):
    """Runs end at an auxiliary function, a block that is not plain G1 (a circle, G0, other
    words), a block longer than MD20170 (20 mm), COMPOF, and under COMPCAD at a corner above
    SD42470 (36 deg); a corner the tolerance cannot smooth within its blocks is kept too."""
    def run_breaks(body):
        text = "G17 G90 G71 G64 SOFT COMPCAD\nG1 X0 Y0 F6000\n" + body + "M30\n"
        path = interpret_text(text, "t.mpf", mikron_module).path
        c = compress(path, mikron_module)
        return path, c

    straight = "".join(f"X{0.2 * i:.1f}\n" for i in range(1, 11))
    path, c = run_breaks(straight)
    assert c.joined[1:path.n].all()
    # R parameters and CTOL between the blocks do not interrupt it
    path, c = run_breaks(straight[:20] + "R1=0.5\nCTOL=0.02\n" + straight[20:])
    assert c.joined[1:path.n].all()
    for interrupter in ("M8\n", "X2.2 S1000\n", "S1000\n", "T2\n", "G0 X2.4\nG1 X2.6\n", "X30\n",
                        "COMPOF\n", "G2 X2.4 Y0 I0.2 J0\n"):
        body = straight + interrupter + "G1 " + "".join(f"X{40 + 0.2 * i:.1f}\n" for i in range(1, 6))
        path, c = run_breaks(body)
        first = int(np.argmax(path.line > 12))        # the first segment after the straight run
        assert not c.joined[first] or not c.in_run[first], interrupter
    # corner limit angle: 30 deg joined, 40 deg kept under COMPCAD
    for angle, joined in ((30.0, True), (40.0, False)):
        t = math.radians(angle)
        corner = straight + "".join(f"X{2 + 0.2 * i * math.cos(t):.4f} Y{0.2 * i * math.sin(t):.4f}\n"
                                    for i in range(1, 11))
        path, c = run_breaks(corner.replace("X0.2\n", "X0.2 CTOL=0.05\n", 1))
        assert bool(c.joined[10]) == joined, angle
    # COMPCURV has no angle limit, but a 40 deg kink on 0.2 mm blocks does not fit 0.01 mm
    text = ("G17 G90 G71 G64 SOFT COMPCURV\nG1 X0 Y0 F6000\n" + corner + "M30\n")
    path = interpret_text(text, "t.mpf", mikron_module).path
    c = compress(path, mikron_module)
    assert not c.joined[10] and c.joined[5] and c.joined[15]


def test_compressed_raster_is_checked_by_ruckig(mikron_module):
    sim = simulate("raster.mpf", mikron_module, text=raster("COMPCAD", passes=2, wave_mm=3.0))
    s = crosscheck(sim.motion, max_blocks=600).summary()
    assert s["violations"] == 0 and s["faster_than_optimum"] == 0


def test_plain_and_compiled_fits_agree(mikron_module):
    """The fit kernel runs as plain Python on small runs and compiled above (ncsim.jit): both
    give the same windows, deviations and curvatures."""
    from ncsim import jit

    path = interpret_text(raster("COMPCAD", passes=2, wave_mm=3.0), "r.mpf", mikron_module).path
    with jit.forced("python"):
        plain = compress(path, mikron_module)
    with jit.forced("compiled"):
        compiled = compress(path, mikron_module)
    for name in ("joined", "window_mm", "deviation_mm", "curvature_1_mm", "curvature_change_1_mm"):
        np.testing.assert_array_equal(getattr(plain, name), getattr(compiled, name), err_msg=name)
