"""A figure a machinist reads at a glance (``ncsim plot``, ``ncsim.report.view``).

The program below is ours: a 10 mm square cut at F1200 (plunge F500), reached by rapids from
and back to a tool-change position 360 mm away. Expected scales follow from the program alone:
the feed axis tops at 1.15 x the largest programmed cutting feed, the XY view frames the square
with a 6 % margin, and the rapids (30 m/min and more) set neither.
"""
from __future__ import annotations

import dataclasses

import matplotlib.image as matplotlib_image
import numpy as np
import pytest
from click.testing import CliRunner
from matplotlib.collections import LineCollection

from ncsim.cli.main import cli
from ncsim.pipeline import simulate
from ncsim.plan.sample import sample_motion
from ncsim.report import view
from ncsim.report.plot import RAPID_COLOR, run_figure

SQUARE = """N10 G17 G90 G64 {mode}
N20 G0 X-300 Y200 Z50
N30 G0 X0 Y0 Z1
N40 G1 Z0 F500
N50 G1 X10 F1200
N60 Y10
N70 X0
N80 Y0
N90 G0 Z50
N100 G0 X-300 Y200
N110 M30
"""
F_MAX_MM_MIN = 1200.0


@pytest.fixture(scope="module")
def square(tmp_path_factory):
    d = tmp_path_factory.mktemp("square")
    for mode in ("SOFT", "BRISK"):
        (d / f"{mode.lower()}.mpf").write_text(SQUARE.format(mode=mode))
    return d


@pytest.fixture(scope="module")
def soft_sim(square):
    return simulate(square / "soft.mpf", "mikron")


def figure(sim, *, window=None, **kw):
    motion = sim.motion
    numbers = view.block_numbers(motion.path)
    t0, t1 = (0.0, motion.total_time_s) if window is None else (window.t0_s, window.t1_s)
    trace = sample_motion(motion, t_s=np.linspace(t0, t1, 4000))
    return run_figure(trace, motion=motion, window=window, numbers=numbers, **kw)


def test_feed_axis_is_scaled_to_the_programmed_cutting_feeds(soft_sim):
    result = figure(soft_sim)
    feed = result.axes["feed_time"]
    assert feed.get_ylim() == pytest.approx((0.0, 1.15 * F_MAX_MM_MIN))
    assert result.axes["feed_path"].get_ylim()[1] == pytest.approx(1.15 * F_MAX_MM_MIN)
    # the rapids are there, thin and grey, and run off the top (the panel says how fast)
    rapid = [ln for ln in feed.get_lines() if ln.get_label() == "rapid (G0)"]
    assert len(rapid) == 1 and rapid[0].get_color() == RAPID_COLOR and rapid[0].get_linewidth() < 1
    assert np.nanmax(rapid[0].get_ydata()) > 20_000
    assert any("off scale" in t.get_text() for t in feed.texts)
    # another unit scales the axis, not the picture
    m_min = figure(soft_sim, feed_unit="m/min")
    assert m_min.axes["feed_time"].get_ylim()[1] == pytest.approx(1.15 * F_MAX_MM_MIN / 1000)
    assert m_min.axes["feed_time"].get_ylabel() == "feed (m/min)"


def test_xy_view_frames_the_cutting_moves_not_the_rapids(soft_sim):
    ax = figure(soft_sim).axes["xy_path"]
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    assert x0 < 0 < 10 < x1 and y0 < 0 < 10 < y1          # the whole square ...
    assert min(x1 - x0, y1 - y0) == pytest.approx(10 * 1.12)   # ... with a 6 % margin
    assert x0 > -300 and y1 < 200                         # the tool-change position is outside
    assert ax.get_aspect() == 1.0
    bbox = ax.get_window_extent()                         # equal scale: mm per pixel alike
    assert (x1 - x0) / bbox.width == pytest.approx((y1 - y0) / bbox.height, rel=1e-3)


def test_rapids_hide_draws_no_rapid(soft_sim):
    shown, hidden = figure(soft_sim, rapids="show"), figure(soft_sim, rapids="hide")
    def rapid_artists(result):
        feed = [ln for ln in result.axes["feed_time"].get_lines() if ln.get_label() == "rapid (G0)"]
        xy = [c for c in result.axes["xy_path"].collections
              if isinstance(c, LineCollection) and c.get_array() is None]
        return feed, xy
    assert all(rapid_artists(shown)) and not any(rapid_artists(hidden))
    assert "rapids hidden" in hidden.notes
    # the cutting feed is the same curve either way
    cut = lambda r: next(ln for ln in r.axes["feed_time"].get_lines() if ln.get_label() == "reached feed")  # noqa: E731
    np.testing.assert_array_equal(cut(shown).get_ydata(), cut(hidden).get_ydata())


def test_blocks_are_labelled_by_their_n_numbers(soft_sim, tmp_path):
    labels = [t.get_text().strip() for t in figure(soft_sim).axes["feed_time"].texts if "N" in t.get_text()]
    assert labels == ["N30", "N40", "N50", "N60", "N70", "N80", "N90", "N100"]
    plain = tmp_path / "plain.mpf"
    plain.write_text("G17 G90 G64 SOFT\nG1 X10 F1200\nY10\nM30\n")
    sim = simulate(plain, "mikron")
    assert [t.get_text().strip() for t in figure(sim).axes["feed_time"].texts] == ["line 3"]


def test_brisk_jerk_is_clipped_and_marked_soft_is_not(square, soft_sim, mikron):
    brisk = figure(simulate(square / "brisk.mpf", "mikron"))
    jerk = brisk.axes["jerk"]
    j_ref = max(5.0, 6.0)        # m/s^3: J_mi of X, Y and the NCU's J_tcurv (eq. 10)
    assert brisk.clipped["jerk"] > 0
    assert jerk.get_ylim()[1] == pytest.approx(1.12 * 2.5 * j_ref)
    marks = [ln for ln in jerk.get_lines() if ln.get_marker() in ("^", "v") and len(ln.get_xdata())]
    assert marks and all(abs(abs(y) - 2.5 * j_ref * 0.965) < 1e-9 for m in marks for y in m.get_ydata())
    note = "\n".join(t.get_text() for t in brisk.figure.texts)
    assert "clipped" in note and "BRISK" in note
    # BRISK steps the acceleration within one IPO cycle: jerk = A / t_cy with the line's
    # A = min_i A_mi / |u_i| (paper Table 1, t_cy = 12 ms); the largest is the rapid N30 from
    # (-300, 200, 50) to (0, 0, 1) (the square's Y side gives 3 / 0.012 = 250 m/s^3)
    u = np.array([300.0, -200.0, -49.0]) / np.linalg.norm([300.0, -200.0, -49.0])
    a_rapid = min(2.5 / abs(u[0]), 3.0 / abs(u[1]), 2.1 / abs(u[2]))
    assert f"(up to {max(a_rapid, 3.0) / 0.012:.3g} m/s³)" in note
    soft = figure(soft_sim)
    assert soft.clipped["jerk"] == 0
    peak = max(np.nanmax(np.abs(ln.get_ydata())) for ln in soft.axes["jerk"].get_lines()
               if ln.get_label() in ("X axis", "Y axis", "Z axis", "tangential jerk"))
    assert soft.axes["jerk"].get_ylim()[1] >= peak


def test_axis_jerk_above_its_limit_is_explained_by_the_papers_rule(repo_root, mikron, soft_sim):
    """The bore's arcs: at the steady feed V_Jtcurv the direction change alone gives V^3/R^2 =
    J_tcurv = 6 m/s^3 > J_mi = 5 m/s^3 (paper eq. 3, 10, 11)."""
    sim = simulate(repo_root / "programs" / "bore_d25_f5984.mpf", "mikron")
    trace = sample_motion(sim.motion, 0.001)
    moving = [True, True, False]
    notes = view.jerk_notes(trace, sim.motion, mikron, moving)
    assert len(notes) == 1 and "on arcs" in notes[0] and "eq. 10" in notes[0]
    assert "J_tcurv = J_curv·r_jct = 6 m/s³ > J_mi" in notes[0]
    text = "\n".join(t.get_text() for t in figure(sim).figure.texts)
    assert "axis jerk above J_mi = 5 m/s³ on arcs" in text and "not a fault" in text
    # a machine whose path jerk stays below the axis jerk: the eq. 10 clause is not claimed
    low = dataclasses.replace(mikron, ncu=dataclasses.replace(mikron.ncu, curvilinear_jerk_mm_s3=6000.0))
    assert low.ncu.tangential_jerk_mm_s3 == pytest.approx(3600.0)        # 6 x 0.6 < J_mi = 5
    other = view.jerk_notes(trace, sim.motion, low, moving)
    assert other and "eq. 10" not in other[0] and "V³/R²" in other[0]
    # lines in SOFT keep their axis jerk within J_mi (jerk min(J_tcurv, J_mi/|u_i|) along the
    # line): nothing to explain on the square
    square = sample_motion(soft_sim.motion, 0.001)
    assert view.jerk_notes(square, soft_sim.motion, mikron, [True, True, True]) == []


# ---------------------------------------------------------------------------------------------
# --range
# ---------------------------------------------------------------------------------------------

@pytest.mark.parametrize("text, first, last", [("N50:N80", 3, 6), ("5:8", 3, 6), ("N60:", 4, 8)])
def test_range_by_n_number_or_line_zooms_to_those_blocks(soft_sim, text, first, last):
    motion = soft_sim.motion
    numbers = view.block_numbers(motion.path)
    window = view.window_for(view.parse_range(text), None, motion, numbers)
    # blocks (0-based) 3..6 are N50..N80, on file lines 5..8; block 8 is the last, N100
    assert list(motion.path.line[first:last + 1]) == [int(n) // 10 for n in numbers[first:last + 1]]
    assert (window.t0_s, window.t1_s) == pytest.approx((motion.t_start_s[first], motion.t_end_s[last]))
    result = figure(soft_sim, window=window)
    assert result.axes["feed_time"].get_xlim() == pytest.approx((window.t0_s, window.t1_s), abs=1e-9)
    assert f"view: {window.label}" in result.figure._suptitle.get_text()


def test_range_in_seconds_and_the_cli(square, tmp_path):
    sim = simulate(square / "soft.mpf", "mikron")
    window = view.window_for(view.parse_range("1.5s:2.5s"), None, sim.motion)
    assert (window.t0_s, window.t1_s) == (1.5, 2.5)
    out = tmp_path / "zoom.png"
    r = CliRunner().invoke(cli, ["plot", str(square / "soft.mpf"), "-m", "mikron", "-o", str(out),
                                 "--range", "N50:N80", "--rapids", "hide"])
    assert r.exit_code == 0, r.output
    assert matplotlib_image.imread(out).shape[:2] == (1000, 1600)


@pytest.mark.parametrize("text, expected", [
    ("8:5", "the end comes before the start"),
    ("N5000:N6000", "no block of the program on N"),
    ("abc", "expected LINE1:LINE2"),
    ("N5:8", "expected LINE1:LINE2"),
    ("900s:1000s", "the run lasts"),
])
def test_bad_range_is_one_line_exit_2(square, tmp_path, text, expected):
    out = tmp_path / "x.png"
    r = CliRunner().invoke(cli, ["plot", str(square / "soft.mpf"), "-m", "mikron", "-o", str(out),
                                 "--range", text])
    assert r.exit_code == 2 and len(r.stderr.splitlines()) == 1 and expected in r.stderr, r.stderr
    assert not out.exists()


# ---------------------------------------------------------------------------------------------
# A real program (../shared): structure only
# ---------------------------------------------------------------------------------------------

def test_real_thws_program_is_framed_on_its_cutting_moves(shared):
    prog = shared / "data/real/thws-spinner-u5-620-nc-programs/Keychain_Schluesselanhaenger.mpf"
    sim = simulate(prog, "mikron")
    path = sim.motion.path
    result = figure(sim)
    cut = ~path.rapid & (path.length_mm > 0)
    f_max = float(np.max(path.feed_mm_s[cut])) * 60.0
    from ncsim.report.overview import LABEL_HEADROOM
    assert result.panels == ("feed_time", "operations", "xy_path", "side_path")   # the overview
    assert result.axes["feed_time"].get_ylim()[1] == pytest.approx(1.15 * f_max * LABEL_HEADROOM)
    ends = np.concatenate([path.start_mm[cut, :2], path.end_mm[cut, :2]])
    lo, hi = ends.min(axis=0), ends.max(axis=0)
    ax = result.axes["xy_path"]
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    assert x0 <= lo[0] and x1 >= hi[0] and y0 <= lo[1] and y1 >= hi[1]
    # the home position of the tool change (X-365 Y224 in the program) is outside the view
    assert not (x0 <= -365 <= x1 and y0 <= 224 <= y1)
    assert (y1 - y0) < 1.2 * (hi[1] - lo[1]) or (x1 - x0) < 1.2 * (hi[0] - lo[0])


def test_range_on_a_saved_trace(repo_root, tmp_path):
    """A trace keeps source lines (and the programmed feed with --trace-columns all), not N
    numbers: lines and seconds zoom, N numbers are a clear error."""
    csv = tmp_path / "bore.csv"
    r = CliRunner().invoke(cli, ["run", str(repo_root / "programs" / "bore_d25_f5984.mpf"), "-m",
                                 "mikron", "--trace", str(csv), "--trace-columns", "all"])
    assert r.exit_code == 0, r.output
    for text in ("14:18", "0.7s:1.5s"):
        r = CliRunner().invoke(cli, ["plot", "--trace", str(csv), "-o", str(tmp_path / "z.png"),
                                     "--range", text])
        assert r.exit_code == 0, r.output
    r = CliRunner().invoke(cli, ["plot", "--trace", str(csv), "-o", str(tmp_path / "n.png"),
                                 "--range", "N40:N50"])
    assert r.exit_code == 2 and "a trace has no N numbers" in r.stderr
    from ncsim.report.csvio import read_trace_csv, trace_from_columns
    trace = trace_from_columns(read_trace_csv(csv))
    window = view.window_for(view.parse_range("14:18"), trace)
    inside = trace.t_s[(trace.line >= 14) & (trace.line <= 18)]
    assert window.t0_s == pytest.approx(inside.min()) and window.t1_s == pytest.approx(inside.max())
    result = run_figure(trace, window=window)
    assert result.axes["feed_time"].get_xlim()[0] <= window.t0_s
    assert "cycle time 2.121 s" in result.figure._suptitle.get_text()   # the run's, not the view's
