"""Effects library: closed forms of the trace effects, and what each planner effect changes,
checked against the paper's equations (eq. 6, 11, 13) and transfer functions, not against
ncsim's own output."""
from __future__ import annotations

import math

import numpy as np
import pytest

from ncsim.gap.closedforms import (compliance_offset_mm, delayed_mm, first_order_lag_coefficients,
                                   servo_lag_mm)
from ncsim.gap.effects import (EFFECTS, PLANNER_EFFECTS, Model, base_names, corrected_machine,
                               get_effect, make_base)
from ncsim.errors import UsageError
from ncsim.nc.interpret import interpret_text
from ncsim.machine import dump_machine_toml, load_machine
from ncsim.motion import FULL_MODEL
from ncsim.plan.lookahead import plan


def circle(R, v, t):
    w = v / R
    pos = np.column_stack([R * np.cos(w * t), R * np.sin(w * t), 0 * t])
    vel = np.column_stack([-v * np.sin(w * t), v * np.cos(w * t), 0 * t])
    acc = np.column_stack([-v * w * np.cos(w * t), -v * w * np.sin(w * t), 0 * t])
    return pos, vel, acc, w


# --- trace effects: closed forms ---------------------------------------------------------------

def test_first_order_lag_is_exact_for_a_ramp():
    # y' = Kv (v t - y), y(0) = 0:  y = v (t - (1 - exp(-Kv t)) / Kv)  (exact for linear input)
    kv, v, dt = 25.0, 120.0, 2e-3
    t = np.arange(0, 0.5, dt)
    u = np.column_stack([v * t, -0.5 * v * t, 0 * t])
    y = servo_lag_mm(t, u, kv)
    expected = v * (t - (1 - np.exp(-kv * t)) / kv)
    assert np.allclose(y[:, 0], expected, rtol=0, atol=1e-10)
    assert np.allclose(y[:, 1], -0.5 * expected, atol=1e-10)
    b, a = first_order_lag_coefficients(kv, dt)
    assert math.isclose(b.sum() / a.sum(), 1.0, rel_tol=1e-12)        # DC gain 1
    # feed-forward removes the steady following error: (1 - k_ff) v / Kv
    half = servo_lag_mm(t, u, kv, ffw_weight=0.5)
    assert math.isclose(u[-1, 0] - half[-1, 0], 0.5 * v / kv, rel_tol=1e-4)


@pytest.mark.parametrize("kff", [0.0, 0.6])
def test_servo_lag_circle_radius_is_the_transfer_function_gain(kff):
    # |H(jW)| with H = (k_ff s + Kv)/(s + Kv)
    R, v, kv = 10.0, 150.0, 30.0
    t = np.arange(0, 3.0, 1e-3)
    pos, _, _, w = circle(R, v, t)
    y = servo_lag_mm(t, pos - pos[0] + pos[0], kv, kff)
    late = t > 1.0
    r = np.hypot(y[late, 0], y[late, 1])
    gain = math.sqrt((kff ** 2 * w ** 2 + kv ** 2) / (w ** 2 + kv ** 2))
    assert np.allclose(r, R * gain, rtol=2e-4)


def normal_accel_vectors_mm_s2(vel_mm_s: np.ndarray, acc_mm_s2: np.ndarray) -> np.ndarray:
    """The normal part of the acceleration, ``A - (A . t) t`` with ``t = V/|V|`` (paper eq. 1:
    ``A = dV/dt t + V^2/R n``); zero where the tool stands still."""
    v = np.asarray(vel_mm_s, dtype=np.float64)
    a = np.asarray(acc_mm_s2, dtype=np.float64)
    speed = np.linalg.norm(v, axis=1, keepdims=True)
    t = np.divide(v, speed, out=np.zeros_like(v), where=speed > 1e-12)
    return a - np.sum(a * t, axis=1, keepdims=True) * t


def test_compliance_is_outward_c_times_normal_acceleration():
    R, v, c = 30.0, 150.0, 1.2e-4     # c in s^2 (120 um per m/s^2)
    t = np.linspace(0, 1, 50)
    pos, vel, acc, _ = circle(R, v, t)
    out = pos + compliance_offset_mm(acc, c)
    assert np.allclose(np.hypot(out[:, 0], out[:, 1]), R + c * v * v / R, rtol=1e-12)
    an = normal_accel_vectors_mm_s2(vel, acc)
    assert np.allclose(np.linalg.norm(an, axis=1), v * v / R)
    # on a straight ramp the deflection is -c a along the path (no contour error)
    a = np.array([[2000.0, 0.0, 0.0]])
    assert np.allclose(compliance_offset_mm(a, c), [[-c * 2000.0, 0, 0]])
    assert np.allclose(normal_accel_vectors_mm_s2(np.array([[5.0, 0, 0]]), a), 0.0)


def test_delay():
    t = np.arange(0, 1, 1e-3)
    x = np.column_stack([3 * t, t * 0 + 1, -t])
    y = delayed_mm(t, x, 0.0105)
    inside = t > 0.02
    assert np.allclose(y[inside, 0], 3 * (t[inside] - 0.0105))
    assert np.allclose(y[:, 1], 1.0)


# --- planner effects: the paper's closed forms ---------------------------------------------------

@pytest.fixture(scope="module")
def mikron():
    return load_machine("mikron")


PROG = """N10 G17 G90 G64 SOFT
N20 G0 X0 Y-2.5 Z0
N30 G3 X0 Y-2.5 I0 J2.5 F6000
N40 G0 X0 Y-14
N50 G3 X14 Y0 I0 J14 F12000
N60 G3 X-2 Y16 I-16 J0
N70 G0 X0 Y40
N80 G1 X0.5 F12000
N90 G1 X1
N100 G1 X1.5
N110 M30
"""


@pytest.fixture(scope="module")
def path(mikron):
    return interpret_text(PROG, "effects.mpf", mikron).path


def test_ncu_path_jerk_sets_eq11(mikron, path):
    e = get_effect("ncu_path_jerk")
    base = make_base(mikron, "axis-only")
    assert not e.is_active(base)
    for j in (3.0, 6.0):
        m = e.apply(base, {"j_tcurv_m_s3": j})
        assert e.is_active(m) and math.isclose(m.machine.ncu.tangential_jerk_mm_s3, j * 1000)
        mo = plan(path, m.machine, m.options)
        # eq. 11: V_Jtcurv = (J_tcurv R^2)^(1/3) on the R 2.5 circle (6 m/s^3: 2.01 m/min)
        assert math.isclose(mo.cap_mm_s[1], (j * 1000 * 2.5 ** 2) ** (1 / 3), rel_tol=1e-6)
    assert math.isclose(e.current(e.apply(base, {"j_tcurv_m_s3": 6.0}))["j_tcurv_m_s3"], 6.0)


def test_transition_sets_eq13(mikron, path):
    e = get_effect("transition")
    base = e.remove(make_base(mikron, "full"))
    for dt_ms in (6.0, 12.0):
        m = e.apply(base, {"transition_time_ms": dt_ms})
        mo = plan(path, m.machine, m.options)
        # eq. 13 at the R 14 -> R 16 junction (junction 4, at (14, 0), tangent +Y: eq. 15 gives
        # J_t = J_my = 5 m/s^3)
        v = math.sqrt(14 * 16 * 5000 * dt_ms / 1000 / 2)
        assert math.isclose(mo.junction_cap_mm_s[4], v, rel_tol=1e-9)
    assert math.isclose(math.sqrt(14 * 16 * 5000 * 0.012 / 2) * 0.06, 4.92, abs_tol=0.005)  # paper 5.4.1
    assert np.isinf(plan(path, base.machine, base.options).junction_cap_mm_s[4])


def test_cycle_time_sets_eq6(mikron, path):
    e = get_effect("cycle_time")
    m = e.apply(e.remove(make_base(mikron, "full")), {"ipo_cycle_ms": 8.0})
    mo = plan(path, m.machine, m.options)
    assert np.allclose(mo.cap_mm_s[-3:], 0.5 / 0.008)       # eq. 6: L / t_cy
    off = e.remove(m)
    assert np.all(plan(path, off.machine, off.options).cap_mm_s[-3:] > 0.5 / 0.008)


def test_axis_jerk_and_accel_mode_and_lookahead(mikron, path):
    aj = get_effect("axis_jerk")
    base = aj.remove(make_base(mikron, "full"))
    m = aj.apply(base, {"axis_jerk_m_s3": 2.5})
    assert np.allclose(m.machine.max_jerk_mm_s3, [2500, 2500, 25000])     # ratio to X kept
    mo = plan(path, m.machine, m.options)
    assert math.isclose(mo.jerk_mm_s3[1], 2500.0, rel_tol=1e-9)          # phase A/C jerk
    am = get_effect("accel_mode")
    b = am.apply(make_base(mikron, "full"), {"mode": "BRISK", "axis_accel_m_s2": 2.0})
    assert np.allclose(b.machine.max_accel_mm_s2, [2000, 2400, 1680])
    assert b.options.accel_mode == 1 and am.is_active(b) and not am.is_active(am.remove(b))
    la = get_effect("lookahead")
    m = la.apply(la.remove(make_base(mikron, "full")), {"lookahead_blocks": 3.4})
    assert m.machine.ncu.lookahead_blocks == 3 and m.options.lookahead


def test_bases(mikron):
    assert make_base(mikron, "full").options == FULL_MODEL
    ax = make_base(mikron, "axis-only").options
    assert not (ax.ncu_path_jerk or ax.transition_crossing or ax.cycle_time_limit or ax.lookahead)
    assert ax.jerk_limited_ramps and ax.axis_jerk_setpoint
    removable = [n for n in PLANNER_EFFECTS if n not in ("axis_velocity", "axis_accel", "corner_jump")]
    for name in removable:
        m = make_base(mikron, f"full-minus-{name.replace('_', '-')}")
        assert not EFFECTS[name].is_active(m)
    assert len(base_names()) == 2 + len(removable)
    with pytest.raises(UsageError, match="unknown base model 'nope'"):
        make_base(mikron, "nope")
    with pytest.raises(UsageError, match="unknown effect 'wobble'"):
        get_effect("wobble")


def test_parameter_checks(mikron):
    e = get_effect("accel_mode")
    with pytest.raises(UsageError, match="not one of SOFT, BRISK"):
        e.check({"mode": "DRIVE", "axis_accel_m_s2": 1.0})
    with pytest.raises(UsageError, match="unknown parameter 'x'"):
        get_effect("transition").check({"transition_time_ms": 5, "x": 1})
    with pytest.raises(UsageError, match="missing parameter"):
        get_effect("transition").check({})
    assert get_effect("transition").check({"transition_time_ms": 1e9})["transition_time_ms"] == 100.0
    assert get_effect("servo_lag").check({"kv_1_s": 40})["ffw_weight"] == 0.0
    with pytest.raises(UsageError, match="finite"):
        get_effect("servo_lag").check({"kv_1_s": float("nan")})


def test_corrected_machine_round_trips(mikron, tmp_path):
    m = Model(machine=mikron)
    m = get_effect("transition").apply(m, {"transition_time_ms": 7.5})
    m = get_effect("servo_lag").apply(m, {"kv_1_s": 42.0})
    m = get_effect("compliance").apply(m, {"compliance_um_per_m_s2": 120.0})
    assert [p[0] for p in m.post] == ["servo_lag", "compliance"]      # servo before structure
    spec = corrected_machine(m)
    f = tmp_path / "corrected.toml"
    f.write_text(dump_machine_toml(spec, "test"))
    back = load_machine(f)
    assert math.isclose(back.ncu.transition_time_s, 0.0075)
    assert np.allclose(back.position_gain_1_s, 42.0)
    assert math.isclose(back.structure.radial_compliance_mm_per_mm_s2, 120e-6)
