"""The figure of `ncsim gap --plot` draws the model the text reports (issue 18, item 4): the
corrected model re-interpreted in the fitted reset mode (a G64 hypothesis plans the program as
continuous path, not as the G60 program the base interpreted), and the rms of the arrays drawn
is the rms the text prints."""
from __future__ import annotations

import math

import numpy as np
import pytest

from ncsim.gap import plot
from ncsim.gap.diagnose import Evaluator
from ncsim.gap.measured import write_measured_csv
from ncsim.gap.metrics import rms
from ncsim.gap.pipeline import diagnose
from ncsim.gap.truth.cases import Case, truth_trace
from ncsim.gap.truth.synth import ScopeConfig
from ncsim.machine import load_machine
from ncsim.nc.interpret import interpret_text

#: no path-mode word: the machine's reset value (MD20150 group 10) decides whether the
#: 30-degree corners of this 12-gon (R 20 mm) stop (G60) or are crossed at speed (G64)
POLYGON = "N10 G17 G90 SOFT\nN20 G0 X20 Y0 Z0\n" + "".join(
    f"N{30 + 10 * k} G1 X{20 * math.cos(math.radians(30 * (k + 1))):.4f} "
    f"Y{20 * math.sin(math.radians(30 * (k + 1))):.4f}" + (" F3000" if k == 0 else "") + "\n"
    for k in range(12)) + "N150 M30\n"


@pytest.fixture(scope="module")
def g64_result(tmp_path_factory):
    """Recorded on a MIKRON whose reset mode is G64 (its file: G60), diagnosed with the reset
    mode as the candidate."""
    d = tmp_path_factory.mktemp("gapplot")
    prog = d / "polygon.mpf"
    prog.write_text(POLYGON)
    # the program interpreted on the truth's machine: the reset mode acts in the interpreter
    truth = load_machine("mikron").with_ncu(reset_path_mode=64, exact_pos_mode_g0_to_g1=1)
    path = interpret_text(POLYGON, str(prog), truth).path
    case = Case(index=0, effect="rapid_override", params={"rapid_override_percent": 100.0},
                base="full", scope=ScopeConfig(period_s=4e-3, noise_um=0.5, quant_um=0.1,
                                               time_offset_s=0.25),
                lead_s=0.2, seed=7)
    write_measured_csv(truth_trace(path, truth, case), d / "polygon.csv")
    csv = d / "polygon.csv"
    result = diagnose([prog], csv, "mikron", effects=["reset_mode"], combine=False)
    return d, result


def test_the_fit_is_continuous_path(g64_result):
    _, result = g64_result
    assert result.planner.best.params["path_mode"] == "G64"      # planted


def test_the_plotted_corrected_trace_has_the_reported_rms(g64_result, monkeypatch):
    d, result = g64_result
    figures = []
    real_save = plot._save
    monkeypatch.setattr(plot, "_save", lambda fig, *a: (figures.append(fig), real_save(fig, *a))[1])
    assert result.plot(str(d / "fig")) == [str(d / "fig-gap.png")]
    (fig,) = figures
    feed_ax, contour_ax, time_ax = fig.axes
    reported = result.as_dict()["diagnosis"]["effects"][0]["gap_after"]
    # what the text prints of the corrected model (rank 1, the only fit)
    assert result.planner.combined is None

    def drawn(ax, prefix):
        return np.concatenate([np.asarray(ln.get_ydata(), dtype=float) for ln in ax.get_lines()
                               if ln.get_label().startswith(prefix)])
    assert rms(drawn(time_ax, "corrected")) == pytest.approx(reported["time_rms_ms"], rel=1e-9)
    assert rms(drawn(contour_ax, "measured to corrected")) == \
        pytest.approx(reported["contour_rms_um"], rel=1e-9)
    before = result.as_dict()["diagnosis"]["gap_before"]
    assert rms(drawn(time_ax, "base")) == pytest.approx(before["time_rms_ms"], rel=1e-9)


def test_without_reinterpreting_the_corrected_model_would_look_otherwise(g64_result):
    """The figure's former evaluator (the program as the G60 base interpreted it) draws
    another corrected trace: what the test above guards against."""
    _, result = g64_result
    target = result.measured
    stale = Evaluator(result.path, target, registration=result.registration)
    model = result.planner.corrected_model
    good = plot.trace_series(result.evaluator(), model)["time_rms_ms"]
    bad = plot.trace_series(stale, model)["time_rms_ms"]
    assert good == pytest.approx(result.planner.best.gap_after.time_rms_ms, rel=1e-9)
    assert bad > 3 * good + 1.0
