"""The effects real machines differ by (rapid and feed override, axis velocity and
acceleration, reset path mode with settle, G64 corner velocity, recorder filter), the search
that combines them, the transition-loss measure, and the independent plain planner.

Expected numbers are closed forms and hand computations (sinc gain of a moving average, the
G64 corner law, ramp distances of a jerk-limited speed change, a BRISK stop's time loss).
"""
from __future__ import annotations

import ast
import math
from dataclasses import dataclass, field

import numpy as np
import pytest

from ncsim.errors import UsageError
from ncsim.gap.diagnose import ModelCache, forward_select, interpretation_key, rank_fits
from ncsim.gap.closedforms import corner_jumps_mm_s, overload_factors_for, sample_mean_mm
from ncsim.gap.effects import corrected_machine, get_effect, make_base
from ncsim.gap.fit import fit_effect
from ncsim.gap.transitions import junction_loss_s, time_at_length_s
from ncsim.gap.truth.plain import (PlainMachine, plan_plain, ramp_distance_mm, reachable_mm_s,
                                   sample_plain)
from ncsim.machine import dump_machine_toml
from ncsim.nc.interpret import interpret_text

SQUARE = "G90 G17 G94\nG0 X0 Y0 Z2\nG1 Z0 F600\nG1 X20\nG1 X40\nG1 Y20\nG1 X0\nG0 Z5\nM30\n"


# ---------------------------------------------------------------------------------------------
# Physics of the new effects
# ---------------------------------------------------------------------------------------------

def test_recorder_mean_of_n_samples():
    t = np.arange(0.0, 2.0, 5e-4)
    h = 2e-3
    for f_hz, n in ((10.0, 10), (22.0, 10), (50.0, 10), (7.0, 7)):
        x = np.column_stack([np.sin(2 * np.pi * f_hz * t), np.zeros_like(t), t])
        y = sample_mean_mm(t, x, n, h)
        inner = (t > 0.2) & (t < 1.8)
        # the mean of n samples h apart, centred: gain sin(pi f n h) / (n sin(pi f h)), no delay
        gain = abs(math.sin(math.pi * f_hz * n * h) / (n * math.sin(math.pi * f_hz * h)))
        # (x linear between the 0.5 ms grid points: errors of order (2 pi f dt)^2 / 8)
        assert np.max(np.abs(y[inner, 0] - gain * x[inner, 0])) < 1e-3, f_hz
        assert np.allclose(y[inner, 2], t[inner], atol=1e-12)    # a ramp passes unchanged
    # before the start the first position is held: a constant stays
    step = np.column_stack([np.ones_like(t), np.zeros_like(t), np.zeros_like(t)])
    assert np.allclose(sample_mean_mm(t, step, 10)[:, 0], 1.0)
    assert sample_mean_mm(t, step, 1) is not step and np.allclose(sample_mean_mm(t, step, 1), step)


def test_corner_jump_is_a_times_md32310_minus_one_times_t_ipo():
    # jump = A (MD32310 - 1) t_IPO: 1.7 mm/s at A 2.5 m/s^2 and 12 ms is MD32310 = 1.0567
    f = overload_factors_for([1.7], [2500.0], 0.012)
    assert f[0] == pytest.approx(1.0 + 1.7 / 30.0) and f[0] == pytest.approx(1.0567, abs=1e-4)
    assert corner_jumps_mm_s([2500.0, 3000.0], [2.0, 1.5], 0.012) == pytest.approx([30.0, 18.0])


def test_machine_value_effects_apply_remove_and_hold_the_corner_jump(mikron):
    base = make_base(mikron)
    ro = get_effect("rapid_override")
    m = ro.apply(base, {"rapid_override_percent": 10.0})
    assert m.machine.ncu.rapid_override == pytest.approx(0.1) and ro.is_active(m)
    assert not ro.is_active(base) and ro.remove(m).machine.ncu.rapid_override == 1.0
    fo = get_effect("feed_override").apply(base, {"feed_override_percent": 80.0})
    assert fo.machine.ncu.feed_override == pytest.approx(0.8)
    av = get_effect("axis_velocity").apply(base, {"axis_velocity_m_min": 3.0})
    assert np.allclose(av.machine.max_velocity_mm_s, 50.0)              # 3 m/min on every axis

    cj = get_effect("corner_jump")
    m = cj.apply(base, {"corner_jump_mm_s": 1.7})
    assert cj.current(m)["corner_jump_mm_s"] == pytest.approx(1.7)
    # the acceleration and the IPO cycle may be fitted after the jump: the jump stays
    m = get_effect("axis_accel").apply(m, {"xy_accel_m_s2": 0.25, "z_accel_m_s2": 1.4})
    assert np.allclose(m.machine.max_accel_mm_s2, [250.0, 300.0, 1400.0])   # Y keeps 1.2 x X
    assert cj.current(m)["corner_jump_mm_s"] == pytest.approx(1.7)
    m = get_effect("cycle_time").apply(m, {"ipo_cycle_ms": 4.0})
    assert cj.current(m)["corner_jump_mm_s"] == pytest.approx(1.7)

    rm = get_effect("reset_mode")
    m = rm.apply(base, {"path_mode": "G64", "settle_ms": 12.5, "corner_jump_mm_s": 1.7})
    ncu = m.machine.ncu
    assert (ncu.reset_path_mode, ncu.exact_pos_mode_g0_to_g1) == (64, 1)
    assert ncu.exact_stop_fine_settle_s == pytest.approx(0.0125) and rm.is_active(m)
    assert not rm.is_active(base)
    g642 = make_base(mikron.with_ncu(reset_path_mode=642))
    assert cj.current(m)["corner_jump_mm_s"] == pytest.approx(1.7)   # continuous path with its corners
    assert rm.apply(g642, {"path_mode": "G64", "settle_ms": 0, "corner_jump_mm_s": 30.0}
                    ).machine.ncu.reset_path_mode == 642


def test_corrected_machine_file_holds_the_fitted_settings(mikron):
    m = make_base(mikron)
    for name, values in (("rapid_override", {"rapid_override_percent": 10.0}),
                         ("reset_mode", {"path_mode": "G64", "settle_ms": 12.5,
                                         "corner_jump_mm_s": 1.5}),
                         ("axis_accel", {"xy_accel_m_s2": 0.3, "z_accel_m_s2": 1.4}),
                         ("recorder", {"samples": 10})):
        m = get_effect(name).apply(m, values)
    text = dump_machine_toml(corrected_machine(m))
    for line in ('reset_path_mode = "G64"', "exact_pos_mode_g0_to_g1 = 1",
                 "rapid_override_percent = 10.0", "exact_stop_fine_settle_ms = 12.5",
                 "max_accel_m_s2 = 0.3", "max_accel_m_s2 = 1.4"):
        assert line in text, line
    # the jump 1.5 mm/s at A_x 0.3 m/s^2 and t_IPO 12 ms: MD32310 = 1 + 1.5 / 3.6
    import tomllib
    data = tomllib.loads(text)
    assert data["axes"]["X"]["max_accel_ovl_factor"] == pytest.approx(1.0 + 1.5 / (300.0 * 0.012))
    # the other axes keep their ratio to X (mikron: equal MD32310, so jumps in proportion to A)
    assert data["axes"]["Y"]["max_accel_ovl_factor"] == pytest.approx(1.0 + 1.5 / (300.0 * 0.012))


# ---------------------------------------------------------------------------------------------
# Re-interpretation for the reset mode
# ---------------------------------------------------------------------------------------------

def test_model_cache_interprets_again_for_another_reset_mode(mikron):
    path = interpret_text(SQUARE, "<sq>", mikron).path
    g64 = get_effect("reset_mode").apply(make_base(mikron), {"path_mode": "G64", "settle_ms": 0.0,
                                                          "corner_jump_mm_s": 30.0})
    fixed = ModelCache(path, path_key=interpretation_key(mikron))
    with pytest.raises(UsageError, match="needs the program"):
        fixed.motion(g64)
    calls = []

    def reinterpret(m):
        calls.append(m.ncu.reset_path_mode)
        return interpret_text(SQUARE, "<sq>", m).path

    cache = ModelCache(path, reinterpret=reinterpret, path_key=interpretation_key(mikron))
    g60 = cache.motion(make_base(mikron))
    cont = cache.motion(g64)
    cache.motion(get_effect("reset_mode").apply(make_base(mikron), {"path_mode": "G64", "settle_ms": 5.0,
                                                                  "corner_jump_mm_s": 30.0}))
    assert calls == [64]                                      # interpreted once per reset mode
    # the collinear junction X20: G60 stops there, G64 keeps the feed (10 mm/s)
    assert g60.v_junction_mm_s[3] == 0.0 and cont.v_junction_mm_s[3] == pytest.approx(10.0)
    assert cont.total_time_s < g60.total_time_s


# ---------------------------------------------------------------------------------------------
# Forward selection: a structural choice that only pays off with a second effect
# ---------------------------------------------------------------------------------------------

@dataclass
class _Gap:
    gap: float
    parts: dict = field(default_factory=dict)

    def metric_values(self):
        return {"gap": self.gap}


class _ToyEvaluator:
    """A gap shaped like the KIT recording's: the rapid ran at 10 % override; exact stop with
    no settle fits better than continuous path on the nominal ramps, but continuous path with
    a 12.5 ms settle, a 2 mm/s corner jump and slow X/Y ramps (0.3 m/s^2) fits best; lowering
    the acceleration under exact stop only makes it worse."""

    def __init__(self):
        self.n_evals = 0

    def evaluate(self, model):
        self.n_evals += 1
        ncu = model.machine.ncu
        a_x = float(model.machine.max_accel_mm_s2[0])
        g = 10.0 * abs(math.log(ncu.rapid_override / 0.1)) + 0.05
        if ncu.reset_path_mode == 60:
            g += 1.0 + 0.02 * ncu.exact_stop_fine_settle_s * 1e3 + 0.3 * abs(math.log(a_x / 2500.0))
        else:
            jump = get_effect("corner_jump").current(model)["corner_jump_mm_s"]
            g += (0.5 * abs(math.log(jump / 2.0)) + 0.02 * abs(ncu.exact_stop_fine_settle_s * 1e3 - 12.5)
                  + 2.0 * abs(math.log(a_x / 300.0)))
        return _Gap(g)


def test_forward_selection_keeps_the_continuous_path_hypothesis(mikron):
    ev = _ToyEvaluator()
    base = make_base(mikron)
    before = ev.evaluate(base)
    names = ("rapid_override", "reset_mode", "axis_accel")
    fits = rank_fits([fit_effect(ev, base, n, gap_before=before) for n in names])
    assert fits[0].effect == "rapid_override"
    single = next(f for f in fits if f.effect == "reset_mode")
    assert single.params["path_mode"] == "G60"                  # alone, exact stop fits better
    comb = forward_select(ev, fits, before, base)
    assert set(comb.effects) == set(names)
    assert comb.params["path_mode"] == "G64"
    assert comb.params["corner_jump_mm_s"] == pytest.approx(2.0, rel=0.01)
    assert comb.params["settle_ms"] == pytest.approx(12.5, abs=0.1)
    assert comb.params["xy_accel_m_s2"] == pytest.approx(0.3, rel=0.01)
    assert comb.gap_after.gap == pytest.approx(0.05, abs=0.01)


# ---------------------------------------------------------------------------------------------
# Time lost at a transition
# ---------------------------------------------------------------------------------------------

def test_junction_loss_of_a_brisk_stop_is_v_over_a_plus_the_settle():
    v, a, settle, s_c = 10.0, 250.0, 0.0125, 50.0
    t = np.arange(0.0, 12.0, 1e-3)
    t_stop = (s_c - v * v / (2 * a)) / v                        # decelerate from here
    t1 = t_stop + v / a                                           # at rest on the junction
    t2 = t1 + settle
    s = np.where(t < t_stop, v * t,
                 np.where(t < t1, s_c - 0.5 * a * (t1 - t) ** 2,
                          np.where(t < t2, s_c,
                                   np.where(t < t2 + v / a, s_c + 0.5 * a * (t - t2) ** 2,
                                            s_c + v * v / (2 * a) + v * (t - t2 - v / a)))))
    loss = junction_loss_s(t, s, s_c)
    assert loss == pytest.approx(v / a + settle, abs=1e-6)
    # a recorder's centred mean of 10 samples (20 ms) leaves the straight stretches, so the
    # loss, unchanged
    box = sample_mean_mm(t, np.column_stack([s, 0 * s, 0 * s]), 10)[:, 0]
    assert junction_loss_s(t, box, s_c) == pytest.approx(v / a + settle, abs=1e-6)
    assert time_at_length_s(t, s, s_c) == pytest.approx(t1, abs=1e-3)


# ---------------------------------------------------------------------------------------------
# The independent plain planner
# ---------------------------------------------------------------------------------------------

def test_plain_planner_does_not_use_ncsim_plan(repo_root):
    for name in ("plain.py", "independent.py"):
        tree = ast.parse((repo_root / "ncsim" / "gap" / "truth" / name).read_text())
        mods = {n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)}
        mods |= {a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names}
        assert not any(m and (m.startswith("ncsim.plan") or m.startswith("ncsim.gap.diagnose")
                              or m.startswith("ncsim.gap.effects")) for m in mods), (name, mods)


def test_ramp_distance_closed_forms():
    a, j = 2500.0, 2500.0 / 0.012
    # the acceleration is reached (dv >= A^2 / J = 30 mm/s): (v0 + v1) / 2 (dv / A + A / J)
    assert ramp_distance_mm(0.0, 100.0, a, j) == pytest.approx(50.0 * (0.04 + 0.012))
    # it is not: (v0 + v1) sqrt(dv / J)
    assert ramp_distance_mm(10.0, 20.0, a, j) == pytest.approx(30.0 * math.sqrt(10.0 / j))
    v = reachable_mm_s(0.0, 1.0, a, j, 500.0)
    assert ramp_distance_mm(0.0, v, a, j) == pytest.approx(1.0, rel=1e-9)


def test_plain_planner_stops_under_g60_and_keeps_the_feed_under_g64(mikron):
    a = np.array(mikron.max_accel_mm_s2)
    common = dict(v_max_mm_s=tuple(mikron.max_velocity_mm_s), a_max_mm_s2=tuple(a),
                  ipo_cycle_s=0.012, jump_mm_s=tuple(a * 0.012))
    g60 = interpret_text(SQUARE, "<sq>", mikron).path
    g64 = interpret_text(SQUARE, "<sq>", mikron.with_ncu(reset_path_mode=64)).path
    stop = plan_plain(g60, PlainMachine(**common, settle_s=0.024))
    flow = plan_plain(g64, PlainMachine(**common, continuous_path=True))
    assert np.all(stop.v_junction_mm_s == 0.0)
    assert stop.dwell_s[3] == pytest.approx(0.024)
    # collinear X20: full feed; 90 deg corner X40 -> Y: min_i A_i t_cy / |dt_i| = 30 mm/s > F
    assert flow.v_junction_mm_s[3] == pytest.approx(10.0)
    assert flow.v_junction_mm_s[4] == pytest.approx(10.0)
    # G1 X20 of 20 mm at 10 mm/s from rest to full feed: ruckig's duration is the hand value
    # L / v + (ramp time - ramp distance / v) = 2 + (v/A + A/J... not reached) -> compare ends
    p = sample_plain(flow, np.array([flow.t_start_s[2], flow.t_start_s[3], flow.total_s]))
    assert np.allclose(p[0], [0, 0, 0]) and np.allclose(p[1], [20, 0, 0]) and np.allclose(p[2], [0, 20, 5])
