"""Gap metrics, localisation, parameter search and the attribution engine.

Expected values come from closed forms (a time-stretched motion, an offset circle, functions with
known minima) or from the parameters a withheld-effect truth was built with (the truth comes from
the independent RK4 loop simulation of ncsim.gap.truth.servo, not from the diagnosis)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from ncsim.gap.effects import Param, get_effect, make_base
from ncsim.errors import UsageError
from ncsim.gap.diagnose import Evaluator, ModelCache, diagnose, localise
from ncsim.gap.fit import _float_search, _int_search, fit_values, shrink_percent
from ncsim.gap.truth.cases import Case, draw_case, truth_trace
from ncsim.nc.interpret import interpret_file, interpret_text
from ncsim.machine import load_machine
from ncsim.gap.measured import MeasuredTrace
from ncsim.gap.truth.servo import ServoParams, simulate_servo
from ncsim.gap.truth.synth import ScopeConfig, degrade

REPO_PROGRAM = "programs/diagnosis_mix.mpf"


@pytest.fixture(scope="module")
def mikron():
    return load_machine("mikron")


@pytest.fixture(scope="module")
def mix_path(mikron, repo_root):
    return interpret_file(repo_root / REPO_PROGRAM, mikron).path


# --- small pure pieces ------------------------------------------------------------------------

def test_shrink_percent():
    assert shrink_percent(10.0, 2.0) == pytest.approx(80.0)
    assert shrink_percent(10.0, 12.0) == pytest.approx(-20.0)
    assert shrink_percent(0.0, 1.0) == 0.0
    assert shrink_percent(-4.0, 1.0) == pytest.approx(75.0)   # magnitudes (signed cycle-time errors)


def test_float_search_finds_a_narrow_valley_next_to_a_plateau():
    # like a transition time above which no crossing binds: flat beyond ~26, valley at 17.4
    p = Param("x", "ms", 0.5, 100.0, "test")
    f = lambda x: min((math.log(x) - math.log(17.4)) ** 2, 0.17)   # noqa: E731
    x, fx = _float_search(f, p, 12.0)
    assert math.isclose(x, 17.4, rel_tol=5e-3) and fx < 1e-5
    lin = Param("d", "ms", 0.0, 200.0, "test", log=False)
    x, _ = _float_search(lambda d: (d - 8.3) ** 2, lin, None)
    assert abs(x - 8.3) < 0.01


def test_int_search_and_choices():
    p = Param("n", "blocks", 1, 128, "test", kind="int")
    calls = []
    best, _ = _int_search(lambda v: calls.append(v) or (v - 37) ** 2, p, 100)
    assert best == 37 and len(set(calls)) < 40
    params = (Param("mode", "", 0, 0, "m", kind="choice", choices=("A", "B")),
              Param("a", "", 0.1, 10.0, "a"))
    vals, f = fit_values(lambda v: (0.0 if v["mode"] == "B" else 1.0) + (math.log(v["a"]) - 1) ** 2,
                         params, {"mode": "A", "a": 1.0}, ["mode", "a"])
    assert vals["mode"] == "B" and math.isclose(vals["a"], math.e, rel_tol=5e-3)


# --- metrics against closed forms ---------------------------------------------------------------

LINE = """N10 G90 G64 SOFT
N20 G1 X60 Y0 Z0 F6000
N30 M30
"""


def test_metrics_of_a_time_stretched_motion(mikron):
    """The machine runs the same path k times slower: the cycle time is k times longer, the
    time error grows to (k - 1) T, the contour error is the noise across the line."""
    path = interpret_text(LINE, "line.mpf", mikron).path
    model = make_base(mikron, "full")
    t, tr, T, _ = ModelCache(path, dt_s=1e-3, settle_s=0.0).setpoint(model)
    k, sigma_um = 1.25, 1.0
    lead = np.arange(0.0, 0.2, 1e-3)
    t_meas = np.concatenate([lead, 0.2 + k * t])
    pos = np.vstack([np.repeat(tr.pos_mm[:1], len(lead), axis=0), tr.pos_mm])
    meas = degrade(t_meas, pos, ScopeConfig(period_s=2e-3, noise_um=sigma_um, time_offset_s=0.7),
                   seed=3)
    ev = Evaluator(path, meas)
    g = ev.evaluate(model)
    # motion is timed between crossings of 2 % of the top feed (100 mm/s): the model's jerk
    # ramp (J = 5 m/s^3 along X) crosses v_thr = 2 mm/s at t1 = sqrt(2 v_thr / J) from rest
    # and from the end, the stretched one (speed v(t/k)/k) at tk = k sqrt(2 k v_thr / J)
    J, v_thr = 5000.0, 2.0
    t1 = math.sqrt(2 * v_thr / J)
    tk = k * math.sqrt(2 * k * v_thr / J)
    assert math.isclose(g.cycle_time_error_s, (k - 1) * T - 2 * (tk - t1), rel_tol=0.02)
    # noise across the line (y, z): rms distance sqrt(2) sigma
    assert math.isclose(g.contour_rms_um, math.sqrt(2) * sigma_um, rel_tol=0.15)
    assert math.isclose(ev.scales.noise_mm * 1e3, sigma_um, rel_tol=0.25)
    # the model that is right: same stretch (a uniformly slower set point, here by a jerk and
    # acceleration k^-2 and k^-3 times smaller ... not in the library): the base gap is large
    assert g.gap > 50 and g.parts["time"] > g.parts["contour"]


def test_unmatched_motion_counts(mikron):
    """A model that ends long before the measurement cannot shrink the gap by leaving the
    measured samples unmatched."""
    path = interpret_text(LINE, "line.mpf", mikron).path
    fast = get_effect("axis_jerk").apply(make_base(mikron, "full"), {"axis_jerk_m_s3": 5.0})
    slow = get_effect("ncu_path_jerk").apply(fast, {"j_tcurv_m_s3": 0.5})   # 0.7 s slower
    t, tr, T, _ = ModelCache(path, dt_s=1e-3, settle_s=0.3).setpoint(slow)
    meas = degrade(t, tr.pos_mm, ScopeConfig(period_s=4e-3, noise_um=0.5), seed=1)
    ev = Evaluator(path, meas)
    g_fast, g_slow = ev.evaluate(fast), ev.evaluate(slow)
    assert g_fast.n_unmatched > 0 and g_fast.gap > 20 * g_slow.gap


def test_localise_circle_offset(mikron):
    """A measured circle of radius R + delta: every sector and Fmax/Fmin show +delta."""
    prog = """N10 G17 G90 G64 SOFT
N20 G0 X0 Y-30 Z0
N30 G3 X0 Y-30 I0 J30 F6000
N40 M30
"""
    path = interpret_text(prog, "c.mpf", mikron).path
    model = make_base(mikron, "full")
    t, tr, T, _ = ModelCache(path, dt_s=1e-3, settle_s=0.2).setpoint(model)
    delta = 0.012
    pos = tr.pos_mm.copy()
    on = tr.block == 1
    r = np.hypot(pos[on, 0], pos[on, 1])
    pos[on, :2] *= ((r + delta) / r)[:, None]
    meas = MeasuredTrace(t_s=t, pos_mm=pos)
    ev = Evaluator(path, meas)
    g, al, mt = ev.evaluate(model, full=True)
    loc = localise(al, mt, path, ev.scales, meas)
    arc = next(a for a in loc["arcs"] if a["block"] == 1)
    iso = arc["iso230"]["measured"]
    assert math.isclose(iso["Fmax_um"], 12.0, abs_tol=0.2)
    assert iso["Fmin_um"] > -0.5 and iso["G_um"] < 12.5
    sectors = [s["measured_dev_um"] for s in arc["sectors"]]
    assert len(sectors) == 12 and np.allclose(sectors, 12.0, atol=1.0)
    # the feed along the larger circle is (R + delta)/R higher at the same angular rate
    feeds = [s["feed_error_mm_s"] for s in arc["sectors"]]
    assert np.all(np.isfinite(feeds)) and abs(np.median(feeds) - 100.0 * delta / 30.0) < 0.02
    assert all(abs(s["time_error_ms"]) < 2.0 for s in arc["sectors"])
    assert {p["phase"] for p in loc["phases"]} >= {"A", "B", "C"}
    assert math.isclose(g.contour_rms_um, 12.0, rel_tol=0.15)


def test_evaluator_needs_samples(mikron):
    path = interpret_text(LINE, "line.mpf", mikron).path
    meas = MeasuredTrace(t_s=np.arange(5) * 0.01, pos_mm=np.zeros((5, 3)), source="short.csv")
    with pytest.raises(UsageError, match="short.csv: 5 samples, need at least 10"):
        Evaluator(path, meas)


# --- attribution on withheld-effect truths ------------------------------------------------------

@pytest.mark.parametrize("kind, seed", [("transition", 11), ("servo_lag", 4)])
def test_diagnosis_names_the_withheld_effect(mikron, mix_path, kind, seed):
    case = draw_case(np.random.default_rng(seed), 0, kind)
    meas = truth_trace(mix_path, mikron, case)
    d = diagnose(mix_path, mikron, meas, base=case.base, do_combine=False, localisation=False)
    assert d.best.effect == kind
    for name, true in case.params.items():
        if name in ("ffw_weight",):
            continue
        assert math.isclose(float(d.best.params[name]), float(true), rel_tol=0.10), name
    assert d.best.shrink_percent >= 80.0
    assert d.best.added


def test_combined_model_finds_two_effects(mikron, mix_path):
    """Transition crossing withheld from the planner AND a compliant structure in the truth."""
    case = Case(index=0, effect="transition", params={"transition_time_ms": 8.0},
                base="full-minus-transition", scope=ScopeConfig(period_s=3e-3, noise_um=0.8,
                                                               quant_um=0.1, time_offset_s=0.4),
                lead_s=0.2, seed=5)
    model = get_effect("transition").apply(make_base(mikron, "full"), case.params)
    t, sp, _, _ = ModelCache(mix_path, dt_s=1e-3, settle_s=0.0).setpoint(model)
    c_s2 = 150e-6
    servo = ServoParams(kv_1_s=50.0, ffw_weight=1.0, structure_freq_hz=1 / (2 * math.pi * math.sqrt(c_s2)),
                        structure_damping=0.2)
    n = 200
    tc = np.concatenate([np.arange(n) * 1e-3, t + n * 1e-3])
    pos = np.vstack([np.repeat(sp.pos_mm[:1], n, axis=0), sp.pos_mm])
    vel = np.vstack([np.zeros((n, 3)), sp.vel_mm_s])
    vel[-1] = 0
    r = simulate_servo(tc, pos, servo, cmd_vel_mm_s=vel, dt_s=2.5e-4, extend_s=0.4)
    meas = degrade(r.t_s, r.pos_mm, case.scope, seed=case.seed)
    d = diagnose(mix_path, mikron, meas, base=case.base,
                 candidates=["transition", "compliance", "ncu_path_jerk"], localisation=True)
    assert d.combined is not None and set(d.combined.effects) == {"transition", "compliance"}
    assert d.combined.gap_after.gap < 0.5 * min(f.gap_after.gap for f in d.fits)
    assert math.isclose(d.combined.params["transition_time_ms"], 8.0, rel_tol=0.05)
    assert math.isclose(d.combined.params["compliance_um_per_m_s2"], 150.0, rel_tol=0.10)
    # localisation: the circles' radial deviation is there in the measurement, and the
    # corrected model predicts it (Fmax within 25 %)
    for a in d.localisation_after["arcs"]:
        if "iso230" in a:
            m, s = a["iso230"]["measured"]["Fmax_um"], a["iso230"]["model"]["Fmax_um"]
            assert m > 10 and math.isclose(s, m, rel_tol=0.25)
    dd = d.as_dict()
    assert dd["combined"]["effects"] == list(d.combined.effects)
    assert {"effect", "params", "gap_before", "gap_after", "shrink_percent"} <= set(dd["effects"][0])
