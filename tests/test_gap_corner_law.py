"""The corner law (``corner_law``: SOFT/BRISK, the G64 axis velocity jump of MD32310 and the
ramp jerk of MD32431 fitted together) on a real SINUMERIK 840D: KIT's DMC 60H "Notch"
(../shared/data/real/kit-dmc60h-notch-sinumerik, read its SOURCE.md; used in place).

Hold-out: the law is fitted on one corner and must predict the time lost at the other within
5 ms. The fit sees only a window of the recording around the fitted corner (SOURCE.md's
excerpts ``window_B_corner90.csv`` and ``window_C_corner135.csv``, unmodified rows of the
recording); the truth of the predicted corner is the recording's own loss, measured without
ncsim's planner: the commanded positions mapped on the program by hand
(``test_gap_kit.pass1_length_mm``) and the difference of straight-line fits of s(t) before
and after the corner (``ncsim.gap.transitions``). The full benchmark, fitted on whole parts
of the recording, is ``benchmarks/bench_gap_holdout.py``.
"""
from __future__ import annotations

import numpy as np
import pytest

from ncsim.gap.diagnose import Evaluator, ModelCache, interpretation_key
from ncsim.gap.effects import get_effect, make_base
from ncsim.gap.fit import fit_effect
from ncsim.gap.measured import load_measured_csv
from ncsim.gap.pipeline import register_trace
from ncsim.gap.transitions import junction_loss_s
from ncsim.machine import load_machine
from ncsim.nc.interpret import interpret_file, interpret_text
from ncsim.path import BRISK, SOFT
from ncsim.plan.sample import sample_motion
from test_gap_kit import KIT, ORIGIN_MM, PASS1_S_MM, PROGRAM, TRACE, pass1_length_mm

#: the 90 and 135 deg corners are junctions 4 and 5 of pass 1 (G1 Y10 | G1 X40 | G1 X-10 Y60)
CORNERS = {"90": (4, "window_B_corner90.csv"), "135": (5, "window_C_corner135.csv")}
TOLERANCE_MS = 5.0


def corner_loss_ms(t_s, s_mm, corner: str) -> float:
    j = CORNERS[corner][0]
    return 1e3 * junction_loss_s(t_s, s_mm, PASS1_S_MM[j], before_s=(0.6, 0.12), after_s=(0.12, 0.6))


@pytest.fixture(scope="module")
def notch(shared, repo_root):
    folder = shared / KIT
    machine = load_machine(repo_root / "machines" / "dmc60h.toml")
    program = str(folder / PROGRAM)
    path = interpret_file(program, machine).path
    trace = load_measured_csv(str(folder / TRACE), preset="kit")
    s = pass1_length_mm(trace.cmd_pos_mm - ORIGIN_MM)
    measured = {c: corner_loss_ms(trace.t_s, s, c) for c in CORNERS}

    def reinterpret(m):
        return interpret_file(program, m).path

    def fit_on(corner: str):
        """corner_law fitted on the excerpt around ``corner`` (its commanded positions)."""
        window = load_measured_csv(str(folder / CORNERS[corner][1]), preset="kit")
        # a window of one pass fits all three passes: SOURCE.md's work offset places it
        reg = register_trace(window, path, machine, {"G54": tuple(ORIGIN_MM)})
        ev = Evaluator(path, window.command(), registration=reg, reinterpret=reinterpret,
                       path_key=interpretation_key(machine))
        # compared after the recorder's known 20 ms mean (10 samples at 500 Hz)
        base = get_effect("recorder").apply(make_base(machine), {"samples": 10})
        return fit_effect(ev, base, "corner_law")

    cache = ModelCache(path, reinterpret=reinterpret, path_key=interpretation_key(machine))
    s0 = float(np.sum(path.length_mm[:2]))       # pass 1 starts after G0 Z10, G0 X-10 Y60

    def predicted_ms(model, corner: str) -> float:
        sp = sample_motion(cache.motion(model), dt_s=1e-3)
        return corner_loss_ms(sp.t_s, sp.s_mm - s0, corner)

    return dict(machine=machine, measured=measured, fit_on=fit_on, predicted_ms=predicted_ms)


def test_recorded_corner_losses(notch):
    """The recording's own figures (no ncsim model): 20.3 ms at 90 deg, 14.1 ms at 135 deg."""
    assert notch["measured"]["90"] == pytest.approx(20.3, abs=0.3)
    assert notch["measured"]["135"] == pytest.approx(14.1, abs=0.3)


@pytest.mark.parametrize("fitted, held_out", [("90", "135"), ("135", "90")])
def test_corner_law_fitted_on_one_corner_predicts_the_other(notch, fitted, held_out):
    fit = notch["fit_on"](fitted)
    law = fit.params
    # SOFT ramps, and a law inside its search bounds (physically plausible, not a bound)
    assert law["mode"] == "SOFT", law
    e = get_effect("corner_law")
    for name in ("corner_jump_mm_s", "ramp_jerk_m_s3"):
        p = e.param(name)
        assert p.low * 1.05 < law[name] < p.high / 1.05, law
    assert fit.shrink_percent > 50.0
    error_ms = notch["predicted_ms"](fit.model, held_out) - notch["measured"][held_out]
    assert abs(error_ms) <= TOLERANCE_MS, (law, error_ms)
    # and it reproduces the corner it was fitted on
    own_ms = notch["predicted_ms"](fit.model, fitted) - notch["measured"][fitted]
    assert abs(own_ms) <= TOLERANCE_MS, (law, own_ms)


def test_corner_law_sets_the_g64_law(notch):
    """Applied values land in the machine data they name: G64 as the reset mode, the X jump
    A (MD32310 - 1) t_IPO, MD32431 of X (Y at its ratio, Z held), the NCU path jerk not
    below it, and the acceleration mode; under BRISK the jerk changes no ramp."""
    machine = notch["machine"]
    e = get_effect("corner_law")
    m = e.apply(make_base(machine), {"mode": "SOFT", "corner_jump_mm_s": 1.6,
                                     "ramp_jerk_m_s3": 20.0})
    spec = m.machine
    assert spec.ncu.reset_path_mode == 64 and spec.ncu.exact_pos_mode_g0_to_g1 == 1
    a_x, f_x = float(spec.max_accel_mm_s2[0]), float(spec.max_accel_ovl_factor[0])
    assert a_x * (f_x - 1.0) * spec.ncu.ipo_cycle_s == pytest.approx(1.6)
    assert list(spec.max_jerk_mm_s3) == pytest.approx([20000.0, 20000.0, 50000.0])
    assert spec.ncu.tangential_jerk_mm_s3 >= 50000.0
    assert m.options.accel_mode == SOFT and e.is_active(m) and not e.is_active(e.remove(m))
    assert e.current(m)["ramp_jerk_m_s3"] == pytest.approx(20.0)
    # pruned from a combined model, every value it set goes back to the base's
    base = make_base(machine)
    back = e.without(m, base)
    assert back.options == base.options and back.machine == base.machine

    # a 90 deg corner of two lines at F600 (10 mm/s): SOFT slows down under a lower jerk,
    # BRISK does not depend on it
    path = interpret_text("G90 G64 G1 F600 X20\nY20\nM30\n", "corner.mpf").path

    def duration_s(mode, jerk):
        model = e.apply(make_base(machine), {"mode": mode, "corner_jump_mm_s": 1.0,
                                             "ramp_jerk_m_s3": jerk})
        return ModelCache(path).motion(model).total_time_s

    assert duration_s("SOFT", 5.0) > duration_s("SOFT", 50.0) + 1e-3
    assert duration_s("BRISK", 5.0) == pytest.approx(duration_s("BRISK", 50.0), abs=1e-12)
    assert e.apply(make_base(machine), {"mode": "BRISK", "corner_jump_mm_s": 1.0,
                                        "ramp_jerk_m_s3": 5.0}).options.accel_mode == BRISK
