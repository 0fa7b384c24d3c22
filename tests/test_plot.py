"""`ncsim plot` and ncsim.report.plot: the written files are real images with the expected panels."""
from __future__ import annotations

import xml.etree.ElementTree as ET

import matplotlib.image as matplotlib_image
import numpy as np
import pytest
from click.testing import CliRunner

from ncsim.cli.main import cli

FULL_PANELS = ("feed_time", "accel", "jerk", "xy_path", "feed_path")
YLABELS = {"feed_time": "feed (mm/min)", "feed_path": "feed (mm/min)", "xy_path": "Y (mm)",
           "accel": "acceleration (m/s²)", "jerk": "jerk (m/s³)"}
XLABELS = {"feed_time": "time (s)", "feed_path": "cutting path length (mm)", "xy_path": "X (mm)",
           "accel": "time (s)", "jerk": "time (s)"}


def invoke(*args):
    return CliRunner().invoke(cli, ["plot", *map(str, args)])


@pytest.fixture(scope="module")
def bore_sim(repo_root):
    from ncsim.pipeline import simulate
    return simulate(repo_root / "programs" / "bore_d25_f5984.mpf", "mikron")


@pytest.fixture(scope="module")
def bore_trace(bore_sim):
    from ncsim.plan.sample import sample_motion
    return sample_motion(bore_sim.motion, 0.002)


def _panel_axes(fig):
    """The panels' axes (the colorbar's axes has no title)."""
    return {ax.get_title(loc="left"): ax for ax in fig.axes if ax.get_title(loc="left")}


def test_figure_has_five_labelled_panels_limit_legend_and_boundaries(bore_sim, bore_trace):
    from ncsim.report.plot import run_figure
    result = run_figure(bore_trace, motion=bore_sim.motion, title="bore")
    fig = result.figure
    assert result.panels == FULL_PANELS and result.missing == {}
    assert len(fig.axes) == 6                                   # 5 panels + the feed colorbar
    by_title = _panel_axes(fig)
    titles = {"feed against time": "feed_time",
              "feed along the cutting path (rapids take no length)": "feed_path",
              "XY path: reached / programmed feed": "xy_path", "acceleration": "accel", "jerk": "jerk"}
    assert set(by_title) == set(titles)
    for title, panel in titles.items():
        ax = by_title[title]
        assert ax.get_ylabel() == YLABELS[panel] and ax.get_xlabel() == XLABELS[panel]
    colorbar = next(ax for ax in fig.axes if not ax.get_title(loc="left"))
    assert colorbar.get_ylabel() == "reached / programmed feed"
    # legend of the feed panel: programmed, set point, rapids, reached, block boundary
    feed = by_title["feed against time"]
    assert [t.get_text() for t in feed.get_legend().get_texts()] == [
        "programmed F", "set point (eq. 12)", "rapid (G0)", "reached feed", "block boundary"]
    # the figure legend names the limits shading the background; the bore's circle is held by
    # the NCU path jerk (paper: 2.01 m/min on R 2.5) and its arcs meet at transitions (eq. 13)
    limits = [t.get_text() for t in fig.legends[0].get_texts()]
    assert {"ncu_path_jerk", "transition"} <= set(limits)
    # 8 blocks: 7 boundaries as vertical lines, each labelled with its source line
    labels = [t.get_text().strip() for t in feed.texts]
    assert labels == [f"line {n}" for n in (13, 14, 15, 16, 17, 18, 19)]
    assert by_title["XY path: reached / programmed feed"].get_aspect() == 1.0


def test_csv_without_dynamics_columns_gives_three_panels(bore_trace):
    from ncsim.report.csvio import DEFAULT_COLUMNS
    from ncsim.report.plot import available_panels
    from ncsim.motion import Trace
    nan = np.full(len(bore_trace), np.nan)
    thin = Trace(**{**{f: getattr(bore_trace, f) for f in Trace.__slots__},
                    "accel_t_mm_s2": nan, "jerk_t_mm_s3": nan,
                    "acc_mm_s2": np.full((len(nan), 3), np.nan), "jerk_mm_s3": np.full((len(nan), 3), np.nan)})
    panels, missing = available_panels(thin)
    assert panels == ["feed_time", "feed_path", "xy_path"]
    assert set(missing) == {"accel", "jerk"} and "ax_mm_s2" in missing["accel"]
    assert "feed_mm_min" in DEFAULT_COLUMNS


def test_cli_png_decodes_with_the_expected_size(repo_root, tmp_path):
    out = tmp_path / "bore.png"
    r = invoke(repo_root / "programs" / "bore_d25_f5984.mpf", "--machine", "mikron", "-o", out)
    assert r.exit_code == 0, r.output
    assert r.stdout.strip() == f"wrote {out}: panels {', '.join(FULL_PANELS)}"
    img = matplotlib_image.imread(out)
    assert img.shape[:2] == (1000, 1600)
    # not blank: the background shading and curves give many distinct colours
    assert len(np.unique(img.reshape(-1, img.shape[2])[::97], axis=0)) > 50


def test_cli_plots_a_saved_trace_as_svg_and_says_what_is_missing(repo_root, tmp_path):
    csv = tmp_path / "trace.csv"
    runner = CliRunner()
    r = runner.invoke(cli, ["run", str(repo_root / "programs" / "circle_r30_f24000.mpf"), "-m", "mikron",
                            "--trace", str(csv)])
    assert r.exit_code == 0, r.output
    svg = tmp_path / "trace.svg"
    r = invoke("--trace", csv, "-o", svg)
    assert r.exit_code == 0, r.output
    assert r.stdout.strip() == f"wrote {svg}: panels feed_time, xy_path, feed_path"
    assert r.stderr.startswith("note: left out accel (needs accel_t_mm_s2") and "--trace-columns all" in r.stderr
    text = svg.read_text()
    root = ET.fromstring(text)                           # well-formed XML
    assert root.tag.endswith("svg") and "<svg" in text
    assert "<dc:date>" not in text                       # reproducible: no date written
    # the same trace gives the same file
    again = tmp_path / "again.svg"
    invoke("--trace", csv, "-o", again)
    assert again.read_text() == text


@pytest.mark.parametrize("args, expected", [
    (["-o", "out.gif", "PROGRAM", "-m", "mikron"], "out.gif: cannot tell the figure format"),
    (["-o", "out.png", "PROGRAM"], "--machine is required with a PROGRAM"),
    (["-o", "out.png"], "give either a PROGRAM (with --machine) or --trace FILE.csv"),
    (["-o", "out.png", "PROGRAM", "--trace", "t.csv", "-m", "mikron"], "give either a PROGRAM"),
    (["-o", "out.png", "--trace", "missing.csv"], "missing.csv: cannot read trace file"),
    (["PROGRAM", "-m", "mikron"], "ncsim plot: error: Missing option '--output'"),
    (["-o", "out.png", "--trace", "t.csv", "--no-lookahead"], "apply to a PROGRAM, not to --trace"),
])
def test_bad_input_exits_2_in_one_line(repo_root, tmp_path, monkeypatch, args, expected):
    monkeypatch.chdir(tmp_path)
    prog = str(repo_root / "programs" / "circle_r30_f6000.mpf")
    r = invoke(*[prog if a == "PROGRAM" else a for a in args])
    assert r.exit_code == 2
    assert len(r.stderr.splitlines()) == 1 and expected in r.stderr, r.stderr
    assert not list(tmp_path.iterdir())                  # nothing written


def test_bad_trace_line_is_located(tmp_path):
    csv = tmp_path / "bad.csv"
    csv.write_text("t_s,feed_mm_min\n0.0,0\n0.1,abc\n")
    r = invoke("--trace", csv, "-o", tmp_path / "x.png")
    assert r.exit_code == 2 and r.stderr.strip() == f"{csv}:3: column 'feed_mm_min' is not a number: 'abc'"
