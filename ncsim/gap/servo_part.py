"""The servo part of the gap: commanded against actual.

When a measured trace holds both the commanded (set-point) and the actual positions, the gap
between ncsim and the actual motion splits in two:

* the **planner part** -- ncsim against the commanded path: ``diagnose.diagnose`` run on
  ``measured.command()`` with the planner effects as candidates;
* the **servo part** -- commanded against actual: what the axes do to the set point, fitted
  here with the trace effects ``servo_lag`` (Kv with a feed-forward weight), ``servo_delay``
  (a pure delay) and, on positions, ``compliance``.

The servo part needs no program: each effect's model maps the recorded command to a predicted
actual signal, compared with the recorded actual signal at the recorded instants.

* **Signal**: velocities when both the commanded and the actual axis velocities are recorded
  (``"velocity"``; e.g. the UMich files, whose positions are rounded to 1 mm above 100 mm),
  else positions. The effects are linear, so they act on velocities as on positions
  (compliance excepted: it needs the path's acceleration, so it is a position-only candidate).
* **Command between samples**: a cubic Hermite interpolation through the recorded command with
  its recorded derivative (commanded acceleration for velocities, commanded velocity for
  positions; ``np.gradient`` when absent), on a grid of ``min(period / 10, 1 ms)``, per
  contiguous recording piece (breaks at ``segment`` changes and at gaps over 3 periods). The
  filters start at rest on the first command value of each piece, whose first
  ``SKIP_S`` are left out of the residual.
* **Gap**: residuals ``r = actual - model`` over all axes and kept samples, in units of the
  robust scale ``s`` of the command-as-actual residual (1.4826 x its median absolute value,
  at least ``MIN_SCALE`` of the signal's resolution), through the Huber function (quadratic
  within 3 s, linear beyond: a few samples caught in the middle of a 6 ms reversal must not
  decide the fit): ``gap = sqrt(mean(huber(r / s)))``. ``rms`` is reported too.

On sampling much slower than the servo (10 Hz against ~8 ms), a first-order lag of time
constant ``T = (1 - k_ff)/Kv`` and a pure delay ``d = T`` predict the same samples to first
order (``v_cmd - a_cmd T``); the report says which fits better and by how much, and calls the
two indistinguishable when their gaps differ by less than ``DISTINGUISH_REL``.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Callable, Sequence

import numpy as np
from scipy.interpolate import CubicHermiteSpline

from ncsim.gap.closedforms import compliance_offset_mm, servo_lag_mm
from ncsim.gap.effects import EFFECTS, Model, jsonable
from ncsim.errors import UsageError
from ncsim.gap.fit import fit_values, free_params
from ncsim.gap.metrics import shrink_percent
from ncsim.machine import MachineSpec
from ncsim.gap.measured import MeasuredTrace
from ncsim.gap.lag import LagEstimate, estimate_lag, three_significant_figures_step_mm
from ncsim.units import ms_to_s, s_to_ms, um_per_m_s2_to_s2

SKIP_S = 0.1
HUBER_K = 3.0
MIN_SCALE = 1e-6
DISTINGUISH_REL = 0.02
SERVO_CANDIDATES = ("servo_lag", "servo_delay", "compliance")


def huber(x: np.ndarray, k: float = HUBER_K) -> np.ndarray:
    a = np.abs(x)
    return np.where(a <= k, a * a, 2.0 * k * a - k * k)


@dataclass(frozen=True)
class _Piece:
    t_fine: np.ndarray        # uniform fine grid
    u_fine: np.ndarray        # (n, 3) command on the grid
    a_fine: np.ndarray        # (n, 3) its second derivative (positions) for compliance
    idx: np.ndarray           # measured sample indices of this piece used in the residual
    t_meas: np.ndarray        # their times


@dataclass(frozen=True)
class ServoGap:
    gap: float
    rms: float
    n_samples: int
    signal: str

    def metric_values(self) -> dict:
        return {"gap": self.gap, "rms": self.rms}

    def as_dict(self) -> dict:
        return {"gap": self.gap, "rms": self.rms, "n_samples": self.n_samples,
                "signal": self.signal}


class ServoEvaluator:
    """Predicted actual signal of trace effects from the recorded command (module docstring)."""

    def __init__(self, measured: MeasuredTrace, signal: str = "auto"):
        if measured.cmd_pos_mm is None:
            raise UsageError(f"{measured.source}: the servo part needs commanded positions "
                             "(columns x_cmd_mm, y_cmd_mm)")
        if signal == "auto":
            signal = ("velocity" if measured.cmd_vel_mm_s is not None and measured.vel_mm_s is not None
                      else "position")
        if signal not in ("velocity", "position"):
            raise UsageError(f"signal must be auto, velocity or position, got {signal!r}")
        if signal == "velocity" and (measured.cmd_vel_mm_s is None or measured.vel_mm_s is None):
            raise UsageError(f"{measured.source}: velocity signal needs commanded and actual velocities")
        self.measured = measured
        self.signal = signal
        t = measured.t_s
        if signal == "velocity":
            cmd, act = measured.cmd_vel_mm_s, measured.vel_mm_s
            deriv = (measured.cmd_acc_mm_s2 if measured.cmd_acc_mm_s2 is not None else None)
        else:
            cmd, act = measured.cmd_pos_mm, measured.pos_mm
            deriv = measured.cmd_vel_mm_s
        self.cmd, self.act = cmd, act
        period = measured.period_s if len(measured) > 1 else 1e-3
        self.period_s = period
        self.dt_s = min(period / 10.0, 1e-3)
        pieces = self._pieces(t, period)
        self.pieces: list[_Piece] = []
        for lo, hi in pieces:
            if hi - lo < 2:
                continue
            tt = t[lo:hi]
            u = cmd[lo:hi]
            du = deriv[lo:hi] if deriv is not None else np.gradient(u, tt, axis=0)
            spline = CubicHermiteSpline(tt, u, du, axis=0)
            n = int(math.floor((tt[-1] - tt[0]) / self.dt_s)) + 1
            tf = tt[0] + np.arange(n) * self.dt_s
            keep = np.nonzero(tt - tt[0] >= SKIP_S - 1e-12)[0] + lo
            keep = keep[t[keep] <= tf[-1] + 1e-12]
            acc = spline.derivative(2)(tf) if signal == "position" else np.zeros((n, 3))
            self.pieces.append(_Piece(tf, spline(tf), acc, keep, t[keep]))
        if not self.pieces or sum(len(p.idx) for p in self.pieces) < 10:
            raise UsageError(f"{measured.source}: too few samples in contiguous recordings "
                             "for the servo part")
        self.idx = np.concatenate([p.idx for p in self.pieces])
        base = self._residual(None)
        mad = float(np.median(np.abs(base))) * 1.4826
        resolution = self._resolution()
        self.scale = max(mad, resolution, MIN_SCALE)
        self.n_evals = 0

    def _pieces(self, t, period):
        m = len(t)
        brk = np.diff(t) > 3.0 * period
        if self.measured.segment is not None:
            brk |= np.diff(self.measured.segment) != 0
        edges = np.concatenate([[0], np.nonzero(brk)[0] + 1, [m]])
        return list(zip(edges[:-1], edges[1:]))

    def _resolution(self) -> float:
        """Rounding step of the recorded actual signal: 3 significant figures (UMich style)
        when every value is printed so, else 0."""
        a = np.abs(self.act[np.abs(self.act) > 0])
        if a.size == 0:
            return 0.0
        step = three_significant_figures_step_mm(a)
        on_grid = np.all(np.abs(a / step - np.round(a / step)) < 1e-6)
        return float(np.median(step)) / math.sqrt(12.0) if on_grid else 0.0

    def predict(self, model: Model | None) -> np.ndarray:
        """Predicted actual signal at the kept samples (``model`` None: the command itself)."""
        out = []
        for p in self.pieces:
            y = p.u_fine
            if model is not None:
                for name, values in model.post:
                    v = dict(values)
                    if name == "servo_lag":
                        y = servo_lag_mm(p.t_fine, y, float(v["kv_1_s"]), float(v["ffw_weight"]))
                    elif name == "servo_delay":
                        d = ms_to_s(float(v["delay_ms"]))
                        y = np.column_stack([np.interp(p.t_fine - d, p.t_fine, y[:, k]) for k in range(3)])
                    elif name == "compliance":
                        if self.signal != "position":
                            raise UsageError("compliance acts on positions only")
                        y = y + compliance_offset_mm(p.a_fine, um_per_m_s2_to_s2(float(v["compliance_um_per_m_s2"])))
                    else:
                        raise UsageError(f"{name} is not a servo-part effect")
            out.append(np.column_stack([np.interp(p.t_meas, p.t_fine, y[:, k]) for k in range(3)]))
        return np.vstack(out)

    def _residual(self, model) -> np.ndarray:
        return self.act[self.idx] - self.predict(model)

    def evaluate(self, model: Model | None) -> ServoGap:
        self.n_evals += 1
        r = self._residual(model) / self.scale
        return ServoGap(gap=math.sqrt(float(np.mean(huber(r)))),
                        rms=float(np.sqrt(np.mean(np.square(r)))) * self.scale,
                        n_samples=int(r.size), signal=self.signal)


@dataclass
class ServoFit:
    effect: str
    params: dict
    gap_before: ServoGap
    gap_after: ServoGap
    n_evals: int

    @property
    def shrink_percent(self) -> float:
        return shrink_percent(self.gap_before.gap, self.gap_after.gap)

    @property
    def lag_s(self) -> float | None:
        """Equivalent lag: (1 - k_ff)/Kv for servo_lag, d for servo_delay."""
        if self.effect == "servo_lag":
            return (1.0 - float(self.params["ffw_weight"])) / float(self.params["kv_1_s"])
        if self.effect == "servo_delay":
            return ms_to_s(float(self.params["delay_ms"]))
        return None

    def as_dict(self) -> dict:
        return {"effect": self.effect, "params": jsonable(self.params),
                "gap_before": self.gap_before.as_dict(), "gap_after": self.gap_after.as_dict(),
                "shrink_percent": self.shrink_percent,
                "lag_ms": None if self.lag_s is None else s_to_ms(self.lag_s),
                "n_evals": self.n_evals}


@dataclass
class ServoDiagnosis:
    """Ranked servo-part effects of one trace, with the independent lag estimates."""

    source: str
    signal: str
    gap_before: ServoGap
    fits: list[ServoFit]
    lag_estimate: LagEstimate | None
    seconds: float
    notes: tuple[str, ...] = ()

    @property
    def best(self) -> ServoFit:
        return self.fits[0]

    def fit(self, effect: str) -> ServoFit:
        return next(f for f in self.fits if f.effect == effect)

    @property
    def distinguishable(self) -> bool:
        """Do the two best lag models (servo_lag, servo_delay) differ by more than
        ``DISTINGUISH_REL`` in gap?"""
        lags = [f for f in self.fits if f.effect in ("servo_lag", "servo_delay")]
        if len(lags) < 2:
            return True
        a, b = sorted(f.gap_after.gap for f in lags)
        return b > a * (1.0 + DISTINGUISH_REL)

    def as_dict(self) -> dict:
        le = self.lag_estimate
        return {"kind": "servo", "source": self.source, "signal": self.signal,
                "gap_before": self.gap_before.as_dict(),
                "effects": [f.as_dict() for f in self.fits],
                "best": self.best.effect, "lag_models_distinguishable": self.distinguishable,
                "lag_estimate": None if le is None else {
                    "ramp_delay_ms": s_to_ms(le.pooled_ramp_delay_s),
                    "ramp_delay_iqr_ms": s_to_ms(le.pooled_ramp_delay_iqr_s),
                    "ramp_samples": int(np.sum(le.n_ramp_samples)),
                    "position_lag_ms": s_to_ms(le.pooled_position_lag_s)},
                "notes": list(self.notes), "seconds": self.seconds}


def diagnose_servo(measured: MeasuredTrace, *, candidates: Sequence[str] | None = None,
                   signal: str = "auto", machine: MachineSpec | None = None,
                   progress: Callable[[str], None] | None = None) -> ServoDiagnosis:
    """Fit the servo-part effects to commanded-against-actual data (module docstring);
    ``progress`` is called with the name of each fit as it begins."""
    t0 = time.perf_counter()
    ev = ServoEvaluator(measured, signal)
    cands = list(candidates) if candidates is not None else [
        c for c in SERVO_CANDIDATES if not (c == "compliance" and ev.signal != "position")]
    before = ev.evaluate(None)
    fits = []
    for name in cands:
        if progress is not None:
            progress(f"fit {name}")
        effect = EFFECTS[name]
        if effect.kind != "trace":
            raise UsageError(f"{name} is a planner effect, not a servo-part candidate")
        start = effect.check(effect.current(Model(machine=machine)) if machine is not None
                             else _START_VALUES[name])
        n0 = ev.n_evals

        def objective(values, effect=effect):
            return ev.evaluate(single_effect_model(effect.name, values)).gap ** 2

        values, _ = fit_values(objective, effect.params, start, free_params(effect, True))
        after = ev.evaluate(single_effect_model(name, values))
        fits.append(ServoFit(name, effect.check(values), before, after, ev.n_evals - n0))
    fits.sort(key=lambda f: f.gap_after.gap)
    le = None
    if measured.cmd_vel_mm_s is not None and measured.vel_mm_s is not None:
        le = estimate_lag(measured, position_step_mm=three_significant_figures_step_mm(measured.pos_mm))
    d = ServoDiagnosis(source=measured.source, signal=ev.signal, gap_before=before, fits=fits,
                       lag_estimate=le, seconds=time.perf_counter() - t0)
    notes = []
    if not d.distinguishable:
        notes.append("a first-order lag and a pure delay fit these samples equally well (the "
                     "sampling is too slow to see the lag's shape): only the equivalent lag is "
                     "determined")
    d.notes = tuple(notes)
    return d


#: where the fit of each servo-part effect starts when no machine file gives a value
_START_VALUES = {"servo_lag": {"kv_1_s": 30.0, "ffw_weight": 0.0}, "servo_delay": {"delay_ms": 5.0},
                 "compliance": {"compliance_um_per_m_s2": 50.0}}


@dataclass(frozen=True)
class TraceEffectModel:
    """Trace effects alone (what :meth:`ServoEvaluator.predict` reads of a model): the servo
    part needs no machine or planner."""

    post: tuple = field(default=())


def single_effect_model(name: str, values: dict) -> TraceEffectModel:
    """The model made of the one trace effect ``name`` at ``values``."""
    return TraceEffectModel(post=((name, tuple(sorted(values.items()))),))


# ---------------------------------------------------------------------------------------------
# The split
# ---------------------------------------------------------------------------------------------

@dataclass
class SplitDiagnosis:
    """The gap of a trace with commanded and actual positions, in its two parts."""

    planner: object            # gap.Diagnosis of ncsim against the command
    servo: ServoDiagnosis      # the command against the actual

    def as_dict(self) -> dict:
        return {"planner_part": self.planner.as_dict(), "servo_part": self.servo.as_dict()}


def diagnose_split(path, machine: MachineSpec, measured: MeasuredTrace, *, base: str = "full",
                   planner_candidates: Sequence[str] | None = None,
                   servo_candidates: Sequence[str] | None = None, program: str = "",
                   **diagnose_options) -> SplitDiagnosis:
    """Planner part (``diagnose.diagnose`` of the commanded positions with the planner effects as
    candidates) and servo part (:func:`diagnose_servo`) of a trace that has both."""
    from ncsim.gap.effects import COMMAND_EFFECTS, REINTERPRETING
    from ncsim.gap.diagnose import diagnose
    if not measured.has_command:
        raise UsageError(f"{measured.source}: splitting the gap needs commanded positions")
    if planner_candidates is not None:
        cands = list(planner_candidates)
    else:
        cands = [c for c in COMMAND_EFFECTS
                 if diagnose_options.get("reinterpret") is not None or c not in REINTERPRETING]
    bad = [c for c in cands if c not in COMMAND_EFFECTS] if all(c in EFFECTS for c in cands) else []
    if bad:
        raise UsageError(f"{bad[0]} is not a planner effect: the command holds no servo effect")
    planner = diagnose(path, machine, measured.command(), base=base, candidates=cands,
                       program=program, **diagnose_options)
    servo = diagnose_servo(measured, candidates=servo_candidates, machine=machine,
                           progress=diagnose_options.get("progress"))
    return SplitDiagnosis(planner=planner, servo=servo)
