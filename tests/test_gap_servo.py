"""Servo part of the gap on synthetic command/actual traces: the actual comes from the RK4
closed-loop simulation of ncsim.gap.truth.servo (or an exact shift), the expected parameters are the ones
it was run with."""
from __future__ import annotations

import math

import numpy as np
import pytest

from ncsim.errors import UsageError
from ncsim.gap.servo_part import ServoEvaluator, diagnose_servo
from ncsim.gap.measured import MeasuredTrace
from ncsim.gap.truth.servo import ServoParams, simulate_servo
from ncsim.gap.truth.synth import ScopeConfig, degrade


def command(dt=1e-3):
    """Smooth there-and-back moves along a diagonal (s = 20 (1 - cos(pi t)) / 2 mm for 2 s),
    then a circle of 5 mm radius whose angular rate rises smoothly to 1.5 turns/s: ramps and
    curvature enough to see a loop's shape."""
    t = np.arange(0.0, 4.0, dt)
    s = np.where(t < 2.0, 10 * (1 - np.cos(np.pi * t)), 0.0)
    pos = np.column_stack([s, 0.5 * s, 0 * t])
    tau = np.maximum(t - 2.0, 0.0)
    w = 2 * np.pi * 1.5 * np.where(tau < 0.6, (1 - np.cos(np.pi * tau / 0.6)) / 2, 1.0)
    theta = np.concatenate([[0.0], np.cumsum(0.5 * (w[1:] + w[:-1]) * dt)])
    on = t >= 2.0
    pos[on, 0] = 5 * np.sin(theta[on])
    pos[on, 1] = 5 * (1 - np.cos(theta[on]))
    return t, pos


def measured_from(servo: ServoParams, period_s=2e-3, noise_um=0.3, seed=1):
    t, cmd = command()
    r = simulate_servo(t, cmd, servo, dt_s=1e-4)
    cfg = ScopeConfig(period_s=period_s, noise_um=noise_um, record_command=True, phase_s=0.0)
    return degrade(r.t_s, r.pos_mm, cfg, seed=seed, cmd_pos_mm=r.cmd_pos_mm)


def test_position_loop_without_feed_forward():
    m = measured_from(ServoParams(kv_1_s=40.0))
    d = diagnose_servo(m)
    assert d.signal == "position" and d.best.effect == "servo_lag"
    f = d.fit("servo_lag")
    assert math.isclose(f.lag_s, 1 / 40.0, rel_tol=0.03)
    assert math.isclose(f.params["kv_1_s"], 40.0, rel_tol=0.05) and f.params["ffw_weight"] < 0.05
    assert f.shrink_percent > 90.0
    assert d.distinguishable and d.fit("servo_delay").gap_after.gap > 2 * f.gap_after.gap


def test_partial_feed_forward_is_identified_from_the_command():
    m = measured_from(ServoParams(kv_1_s=30.0, ffw_weight=0.6))
    f = diagnose_servo(m, candidates=["servo_lag"]).fit("servo_lag")
    assert math.isclose(f.params["ffw_weight"], 0.6, abs_tol=0.05)
    assert math.isclose(f.params["kv_1_s"], 30.0, rel_tol=0.10)
    assert math.isclose(f.lag_s, 0.4 / 30.0, rel_tol=0.05)


def test_pure_delay():
    t, cmd = command()
    d_true = 0.012
    act = np.column_stack([np.interp(t - d_true, t, cmd[:, k]) for k in range(3)])
    m = MeasuredTrace(t_s=t[::3], pos_mm=act[::3], cmd_pos_mm=cmd[::3], source="<delay>")
    d = diagnose_servo(m)
    assert d.best.effect == "servo_delay"
    assert math.isclose(d.best.params["delay_ms"], 12.0, rel_tol=0.02)


def test_needs_a_command():
    m = MeasuredTrace(t_s=np.arange(20) * 0.01, pos_mm=np.zeros((20, 3)), source="x.csv")
    with pytest.raises(UsageError, match="x.csv: the servo part needs commanded positions"):
        ServoEvaluator(m)
    with pytest.raises(UsageError, match="velocity signal needs"):
        ServoEvaluator(MeasuredTrace(t_s=np.arange(20) * 0.01, pos_mm=np.zeros((20, 3)),
                                     cmd_pos_mm=np.zeros((20, 3))), signal="velocity")
