"""Independent estimates of the servo lag from a trace with commanded and actual signals.

Two model-free readings of how far the actual motion trails the command, used by the servo
part of the gap diagnosis (``ncsim.gap.servo_part``) as a check on its fitted effects:

* the **ramp delay**: inside a ramp at constant commanded acceleration ``a``, an actual velocity
  that is the command delayed by ``d`` reads ``v_act = v_cmd - a d``;
* the **position lag**: the steady following error of a position loop with gain ``Kv`` and
  velocity feed-forward weight ``k_ff`` is ``e = (1 - k_ff) v / Kv`` (840D MD32200
  ``POSCTRL_GAIN``, MD32610 ``VELO_FFW_WEIGHT``), so ``x_cmd - x_act`` against ``v_cmd`` has
  the slope ``(1 - k_ff) / Kv``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ncsim.errors import UsageError
from ncsim.gap.measured import MeasuredTrace


@dataclass(frozen=True)
class LagEstimate:
    """Equivalent lag of the actual behind the commanded motion, per axis X Y Z and pooled (s).

    ``ramp_*``: delay of the actual velocity behind the command inside constant-acceleration
    ramps; ``position_*``: following-error slope ``(x_cmd - x_act) / v_cmd``."""

    ramp_delay_s: np.ndarray          # (3,) median per axis
    ramp_delay_iqr_s: np.ndarray      # (3,) inter-quartile range per axis
    n_ramp_samples: np.ndarray        # (3,)
    pooled_ramp_delay_s: float        # median over all axes' samples
    pooled_ramp_delay_iqr_s: float
    position_lag_s: np.ndarray        # (3,) weighted least-squares slope
    position_lag_se_s: np.ndarray     # (3,) its standard error
    n_moving_samples: np.ndarray      # (3,)
    pooled_position_lag_s: float      # one slope fitted to all axes
    pooled_position_lag_se_s: float

    @property
    def kv_if_ffw_off_1_s(self) -> float:
        """``1 / pooled position lag``: the Kv a loop without feed-forward would need to
        show that following error (``e = v / Kv``)."""
        lag = self.pooled_position_lag_s
        return 1.0 / lag if lag > 0 else math.inf


def three_significant_figures_step_mm(pos_mm) -> np.ndarray:
    """Rounding step of values printed with 3 significant figures (the UMich files):
    ``10^(floor(log10|x|) - 2)``, e.g. 1 mm for 100..999 mm, 0.1 mm for 10..99.9 mm."""
    a = np.abs(np.asarray(pos_mm, dtype=np.float64))
    return 10.0 ** (np.floor(np.log10(np.where(a > 0, a, 1e-3))) - 2)


def _wls_slope(y, x, w):
    """Weighted least-squares slope through the origin and its standard error."""
    sxx = float(np.sum(w * x * x))
    b = float(np.sum(w * x * y)) / sxx
    r = y - b * x
    dof = max(len(y) - 1, 1)
    s2 = float(np.sum(w * r * r)) / dof
    return b, math.sqrt(s2 / sxx)


def estimate_lag(trace: MeasuredTrace, *, accel_limit_mm_s2: float | None = None,
                 saturation: float = 0.9, plateau_tol_mm_s: float = 0.15,
                 min_speed_mm_s: float = 0.5, position_step_mm=None) -> LagEstimate:
    """Two estimates of the servo lag from a trace with commanded and actual signals.

    1. **Ramp delay** (needs commanded velocity and acceleration and actual velocity): in a
       ramp at constant commanded acceleration ``a``, an actual velocity that is the command
       delayed by ``d`` reads ``v_act = v_cmd - a d``, so ``d = (v_cmd - v_act) / a``. Used at
       samples whose ``|a_cmd|`` is at least ``saturation`` times the acceleration limit
       (``accel_limit_mm_s2``, default the largest ``|a_cmd|``), in one recording with both
       neighbours, and whose actual velocity is not already on the neighbouring samples'
       plateau (within ``plateau_tol_mm_s``: then the actual may be before the ramp and the
       value is only a bound). One sample per ramp suffices, so coarse sampling works.
       A first-order lag of time constant ``T`` shows ``d -> T`` once the ramp is longer than
       a few ``T`` (less early in a ramp); a pure delay shows itself.
    2. **Position lag**: the weighted least-squares slope of ``x_cmd - x_act`` against
       ``v_cmd`` over moving samples; the steady following error ``e = (1 - k_ff) v / Kv``
       makes it ``(1 - k_ff) / Kv``. ``position_step_mm`` (scalar or (m, 3)) is the rounding
       step of the recorded positions: weights ``1 / step^2``. Rounding is unbiased on moving
       samples (uniform fractional parts), so many samples resolve lags below ``step / v``.
    Both include any skew between the instants at which command and actual were recorded.
    """
    if trace.cmd_pos_mm is None:
        raise UsageError(f"{trace.source}: the trace has no commanded positions")
    m = len(trace)
    ramp = np.full(3, np.nan)
    iqr = np.full(3, np.nan)
    nramp = np.zeros(3, dtype=np.int64)
    pooled: list[np.ndarray] = []
    if trace.cmd_vel_mm_s is not None and trace.vel_mm_s is not None and m >= 3:
        vc, va = trace.cmd_vel_mm_s, trace.vel_mm_s
        ac = (trace.cmd_acc_mm_s2 if trace.cmd_acc_mm_s2 is not None
              else np.gradient(vc, trace.t_s, axis=0))
        inner = np.zeros(m, dtype=bool)
        inner[1:-1] = True
        if trace.segment is not None:
            sg = trace.segment
            inner[1:-1] = (sg[:-2] == sg[1:-1]) & (sg[1:-1] == sg[2:])
        limit = accel_limit_mm_s2 or float(np.max(np.abs(ac)))
        for k in range(3):
            if limit <= 0:
                break
            prev = np.roll(vc[:, k], 1)
            nxt = np.roll(vc[:, k], -1)
            off_plateau = ((np.abs(va[:, k] - prev) > plateau_tol_mm_s)
                           & (np.abs(va[:, k] - nxt) > plateau_tol_mm_s))
            sel = inner & off_plateau & (np.abs(ac[:, k]) >= saturation * limit)
            if not np.any(sel):
                continue
            d = (vc[sel, k] - va[sel, k]) / ac[sel, k]
            pooled.append(d)
            ramp[k] = float(np.median(d))
            q1, q3 = np.percentile(d, [25, 75])
            iqr[k] = float(q3 - q1)
            nramp[k] = int(sel.sum())
    allr = np.concatenate(pooled) if pooled else np.zeros(0)
    p_ramp = float(np.median(allr)) if len(allr) else math.nan
    p_iqr = float(np.subtract(*np.percentile(allr, [75, 25]))) if len(allr) else math.nan

    vcmd = (trace.cmd_vel_mm_s if trace.cmd_vel_mm_s is not None
            else np.gradient(trace.cmd_pos_mm, trace.t_s, axis=0))
    err = trace.cmd_pos_mm - trace.pos_mm
    step = (np.ones((m, 3)) if position_step_mm is None
            else np.broadcast_to(np.asarray(position_step_mm, dtype=float), (m, 3)))
    w = 1.0 / step ** 2
    lag = np.full(3, np.nan)
    lag_se = np.full(3, np.nan)
    nmov = np.zeros(3, dtype=np.int64)
    ys, xs, ws = [], [], []
    for k in range(3):
        sel = np.abs(vcmd[:, k]) >= min_speed_mm_s
        if sel.sum() >= 3:
            lag[k], lag_se[k] = _wls_slope(err[sel, k], vcmd[sel, k], w[sel, k])
            nmov[k] = int(sel.sum())
            ys.append(err[sel, k]), xs.append(vcmd[sel, k]), ws.append(w[sel, k])
    if ys:
        p_lag, p_se = _wls_slope(np.concatenate(ys), np.concatenate(xs), np.concatenate(ws))
    else:
        p_lag = p_se = math.nan
    return LagEstimate(ramp_delay_s=ramp, ramp_delay_iqr_s=iqr, n_ramp_samples=nramp,
                       pooled_ramp_delay_s=p_ramp, pooled_ramp_delay_iqr_s=p_iqr,
                       position_lag_s=lag, position_lag_se_s=lag_se, n_moving_samples=nmov,
                       pooled_position_lag_s=p_lag, pooled_position_lag_se_s=p_se)
