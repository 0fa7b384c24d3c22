"""Withheld-effect truths for validating the gap diagnosis.

A *case* draws one effect of the library and random parameters for it, builds a "measured"
trace in which that effect is present, and names the base model the diagnosis must start
from: the one that lacks the effect. The truth is never the planner with a flag flipped alone:

1. the **set point** is planned by ncsim with the effect on (planner effects) or by the full
   model (servo and structure effects), sampled every ``COMMAND_DT_S`` (1 ms) and preceded by a
   rest of ``lead_s`` (the recorder is started before the cycle start);
2. every axis follows it through the independent closed-loop time-stepping simulation of
   ``ncsim.gap.truth.servo`` (RK4 at ``SERVO_DT_S`` = 50 us: P position loop with feed-forward, speed
   loop, mass-spring structure), with fixed, mild baseline dynamics (:data:`BASELINE_SERVO`)
   for planner effects and random loop or structure parameters for the servo and structure
   effects, and ``SETTLE_S`` more of rest at the end;
3. ``ncsim.gap.truth.synth.degrade`` records it as an oscilloscope would: random period 1-12 ms,
   white noise 0.3-2 um, encoder increment, clock offset, zero offset, dropouts.

Parameter ranges (:data:`CASE_KINDS`) are where the effect shows on the test program
``programs/diagnosis_mix.mpf``: a curvilinear jerk J_tcurv above the axes' 7.07 m/s^3 never
binds; transition times above ~25 ms leave the spiral's crossings unlimited; an axis jerk above
the NCU's J_tcurv = 6 m/s^3 no longer shapes the ramps (eq. 10 caps them), so it only shows in
the transition feeds and is not identifiable from them alone.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ncsim.gap.effects import EFFECTS, Model, make_base
from ncsim.gap.diagnose import ModelCache
from ncsim.machine import MachineSpec
from ncsim.gap.measured import MeasuredTrace
from ncsim.path import Path
from ncsim.gap.truth.draw import EffectDraw
from ncsim.gap.truth.servo import ServoParams, simulate_servo
from ncsim.gap.truth.synth import ScopeConfig, degrade
from ncsim.units import s_to_ms, um_per_m_s2_to_s2

COMMAND_DT_S = 1e-3
SERVO_DT_S = 5e-5
SETTLE_S = 0.5

#: baseline loop of every truth: FFWON, Kv 50 1/s, 0.1 ms speed loop, a stiff 120 Hz mode
#: (outward deviation under FFW about (T_v/Kv + 1/w^2) a_n = 3.8 um per m/s^2)
BASELINE_SERVO = dict(kv_1_s=50.0, ffw_weight=1.0, velocity_loop_time_s=1e-4,
                      structure_freq_hz=120.0, structure_damping=0.2)
STRUCTURE_DAMPING = 0.2


@dataclass(frozen=True)
class CaseKind(EffectDraw):
    """How to draw one effect's truth (:class:`~ncsim.gap.truth.draw.EffectDraw`) and the base
    the diagnosis starts from."""

    base: str = "full"


CASE_KINDS: dict[str, CaseKind] = {k.effect: k for k in (
    CaseKind("ncu_path_jerk", {"j_tcurv_m_s3": (2.5, 6.5, "lin")}, base="full-minus-ncu_path_jerk"),
    CaseKind("transition", {"transition_time_ms": (3.0, 25.0, "log")}, base="full-minus-transition"),
    CaseKind("cycle_time", {"ipo_cycle_ms": (4.0, 30.0, "log")}, base="full-minus-cycle_time"),
    CaseKind("axis_jerk", {"axis_jerk_m_s3": (2.0, 5.8, "log")}, base="full-minus-axis_jerk"),
    CaseKind("lookahead", {"lookahead_blocks": (1, 10, "int")}, base="full-minus-lookahead"),
    CaseKind("accel_mode", {"axis_accel_m_s2": (1.2, 4.0, "log")}, fixed={"mode": "BRISK"}),
    CaseKind("servo_lag", {"kv_1_s": (15.0, 80.0, "log")}, fixed={"ffw_weight": 0.0}),
    CaseKind("compliance", {"compliance_um_per_m_s2": (40.0, 250.0, "log")}),
)}


@dataclass(frozen=True)
class Case:
    """One benchmark case: the withheld effect, its true parameters and the recording."""

    index: int
    effect: str
    params: dict
    base: str
    scope: ScopeConfig
    lead_s: float
    seed: int

    def as_dict(self) -> dict:
        s = self.scope
        return {"index": self.index, "effect": self.effect, "params": dict(self.params),
                "base": self.base, "lead_s": self.lead_s, "seed": self.seed,
                "scope": {"period_ms": s_to_ms(s.period_s), "noise_um": s.noise_um,
                          "quant_um": s.quant_um, "time_offset_s": s.time_offset_s,
                          "pos_offset_mm": list(s.pos_offset_mm),
                          "dropout_fraction": s.dropout_fraction,
                          "dropout_burst": s.dropout_burst}}


def random_scope(rng: np.random.Generator) -> ScopeConfig:
    """An oscilloscope: period log-uniform 1-12 ms, noise 0.3-2 um, increment 0.1/0.5/1 um (at
    most the noise), clock offset -1..1 s, zero offset -5..5 mm per axis, 0-5 % dropouts in
    bursts of 1-3."""
    noise = float(rng.uniform(0.3, 2.0))
    quant = float(rng.choice([q for q in (0.1, 0.5, 1.0) if q <= noise] or [0.1]))
    return ScopeConfig(period_s=float(np.exp(rng.uniform(math.log(1e-3), math.log(12e-3)))),
                       noise_um=noise, quant_um=quant,
                       time_offset_s=float(rng.uniform(-1.0, 1.0)),
                       pos_offset_mm=tuple(float(v) for v in rng.uniform(-5.0, 5.0, 3)),
                       dropout_fraction=float(rng.uniform(0.0, 0.05)),
                       dropout_burst=int(rng.integers(1, 4)))


def draw_case(rng: np.random.Generator, index: int, kind: str | None = None) -> Case:
    """A random case (the effect drawn uniformly among :data:`CASE_KINDS` unless given)."""
    kinds = list(CASE_KINDS)
    k = CASE_KINDS[kind if kind is not None else kinds[int(rng.integers(len(kinds)))]]
    return Case(index=index, effect=k.effect, params=k.draw(rng), base=k.base,
                scope=random_scope(rng), lead_s=float(rng.uniform(0.1, 0.4)),
                seed=int(rng.integers(2 ** 31)))


def truth_model(machine: MachineSpec, case: Case) -> tuple[Model, ServoParams]:
    """The set-point model and the axis loop of a case's truth."""
    effect = EFFECTS[case.effect]
    servo = dict(BASELINE_SERVO)
    if effect.kind == "planner":
        model = effect.apply(make_base(machine, "full"), case.params)
    else:
        model = make_base(machine, "full")
        if case.effect == "servo_lag":
            servo.update(kv_1_s=case.params["kv_1_s"], ffw_weight=case.params["ffw_weight"])
        elif case.effect == "compliance":
            c_s2 = um_per_m_s2_to_s2(case.params["compliance_um_per_m_s2"])
            servo.update(structure_freq_hz=1.0 / (2.0 * math.pi * math.sqrt(c_s2)),
                         structure_damping=STRUCTURE_DAMPING)
    return model, ServoParams(**servo)


def truth_trace(path: Path, machine: MachineSpec, case: Case) -> MeasuredTrace:
    """The degraded recording of a case (module docstring, steps 1-3)."""
    model, servo = truth_model(machine, case)
    cache = ModelCache(path, dt_s=COMMAND_DT_S, settle_s=0.0)
    t, sp, _, _ = cache.setpoint(model)
    n_lead = int(round(case.lead_s / COMMAND_DT_S))
    t_cmd = np.concatenate([np.arange(n_lead) * COMMAND_DT_S, t + n_lead * COMMAND_DT_S])
    pos = np.vstack([np.repeat(sp.pos_mm[:1], n_lead, axis=0), sp.pos_mm])
    vel = np.vstack([np.zeros((n_lead, 3)), sp.vel_mm_s])
    vel[-1] = 0.0
    r = simulate_servo(t_cmd, pos, servo, cmd_vel_mm_s=vel, dt_s=SERVO_DT_S, extend_s=SETTLE_S,
                       output_t_s=np.arange(0.0, t_cmd[-1] + SETTLE_S, 2.5e-4))
    return degrade(r.t_s, r.pos_mm, case.scope, seed=case.seed,
                   source=f"<case {case.index}: {case.effect}>")
