"""Closed forms of the gap's effects: what the axes, the structure and the recorder do to the
commanded positions (servo lag, compliance, delay, the recorder's mean), and the G64 corner
law's axis velocity jump. Pure functions of arrays, used by :mod:`ncsim.gap.effects` (which
names the machine data they set) and by the servo part (:mod:`ncsim.gap.servo_part`); they
share no code with the time-stepping truth of :mod:`ncsim.gap.truth.servo`:

* ``servo_lag``: the exact first-order-hold discretisation of
  ``X/Xc = (k_ff s + Kv) / (s + Kv)`` (P position loop, ideal speed loop, velocity feed-forward
  weight k_ff), i.e. ``x = k_ff x_c + (1 - k_ff) L[x_c]`` with ``L`` the first-order low-pass of
  time constant 1/Kv, as a two-tap IIR filter (``scipy.signal.lfilter``);
* ``compliance``: the quasi-static deflection ``-c A`` of a structure of compliance
  ``c = m/k`` under the set point's acceleration; its normal part is the outward offset
  ``c a_n`` along the principal normal (``a_n = V^2 / R``, paper eq. 1), the paper's
  "centrifugation" (§5.2, §6.2);
* ``servo_delay``: a pure time delay (what a recording skew between command and actual, or a
  dead time in the drive, looks like);
* ``recorder``: the recorder's centred mean of N raw samples before it down-samples
  (:func:`sample_mean_mm`).
* the G64 corner law: the velocity jump an axis may make at a corner, ``A_i (f_i - 1) t_IPO``
  (MD32310), and its inverse.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.signal import lfilter, lfilter_zi

from ncsim.errors import UsageError


def first_order_lag_coefficients(kv_1_s: float, dt_s: float) -> tuple[np.ndarray, np.ndarray]:
    """IIR coefficients ``(b, a)`` of the exact discretisation of ``y' = Kv (u - y)`` for an
    input that is linear between samples (first-order hold)::

        y[k+1] = E y[k] + b0 u[k+1] + b1 u[k],   E = exp(-Kv h),
        b0 = 1 - (1 - E) / (Kv h),   b1 = (1 - E) / (Kv h) - E

    (integrate ``Kv exp(-Kv (h - tau)) u(tau)`` over one step with ``u`` linear). The DC gain
    ``(b0 + b1) / (1 - E)`` is 1 and a ramp ``u = v t`` is followed with the lag ``v / Kv``."""
    x = kv_1_s * dt_s
    e = math.exp(-x)
    g = -math.expm1(-x) / x  # (1 - E) / (Kv h), accurate for small x
    return np.array([1.0 - g, g - e]), np.array([1.0, -e])


def servo_lag_mm(t_s: np.ndarray, cmd_mm: np.ndarray, kv_1_s: float, ffw_weight: float = 0.0) -> np.ndarray:
    """Actual positions of axes with position-loop gain ``Kv`` and velocity feed-forward weight
    ``k_ff`` (ideal speed loop): ``X/Xc = (k_ff s + Kv)/(s + Kv) = k_ff + (1 - k_ff) Kv/(s + Kv)``.

    Steady following error at feed v: ``(1 - k_ff) v / Kv``; on a circle of angular rate W the
    radius shrinks to ``R sqrt((k_ff^2 W^2 + Kv^2) / (W^2 + Kv^2))``. ``t_s`` must be a uniform
    grid; the axes start at rest on the first command point."""
    t = np.asarray(t_s, dtype=np.float64)
    u = np.asarray(cmd_mm, dtype=np.float64)
    if len(t) < 2:
        return u.copy()
    dt = float(t[1] - t[0])
    if not np.allclose(np.diff(t), dt, rtol=1e-6, atol=1e-12):
        raise UsageError("servo_lag_mm needs a uniform time grid")
    b, a = first_order_lag_coefficients(kv_1_s, dt)
    zi = lfilter_zi(b, a)[:, None] * u[0][None, :]
    low, _ = lfilter(b, a, u, axis=0, zi=zi)
    return ffw_weight * u + (1.0 - ffw_weight) * low


def compliance_offset_mm(acc_mm_s2: np.ndarray, compliance_s2: float) -> np.ndarray:
    """Quasi-static structural deflection ``-c A`` under the set point's acceleration
    ``A = dV/dt t + V^2 kappa n`` (paper eq. 1), ``c = m/k = 1/w_s^2`` (s^2 = mm per mm/s^2).

    Its normal part ``-c V^2 kappa n`` points away from the centre of curvature: the tool runs
    OUTWARD by ``c V^2 / R``, the paper's Table 3 "centrifugation" (the radial deviation);
    its tangential part ``-c dV/dt`` only shifts the tool along the path during ramps (the
    tool lags while accelerating). Valid below the structure's resonance (quasi-static)."""
    return -compliance_s2 * np.asarray(acc_mm_s2, dtype=np.float64)


def delayed_mm(t_s: np.ndarray, pos_mm: np.ndarray, delay_s: float) -> np.ndarray:
    """``x(t - d)``: a pure delay (linear interpolation, held at the first value before it)."""
    t = np.asarray(t_s, dtype=np.float64)
    p = np.asarray(pos_mm, dtype=np.float64)
    return np.column_stack([np.interp(t - delay_s, t, p[:, k]) for k in range(p.shape[1])])


#: the raw sample period of the recorder's stream (an 840D trace or Edge capture at 500 Hz)
RECORDER_RAW_PERIOD_S = 2e-3


def sample_mean_mm(t_s: np.ndarray, pos_mm: np.ndarray, samples: int,
                   raw_period_s: float = RECORDER_RAW_PERIOD_S) -> np.ndarray:
    """What a recorder writes that averages ``N`` raw samples of period ``h`` and stamps the
    mean at the samples' mean time: ``y(t) = (1/N) sum_j x(t + (j - (N - 1)/2) h)``,
    ``j = 0..N-1`` (10 samples at 500 Hz for KIT's 50 Hz data). Zero group delay; gain
    ``|sin(pi f N h) / (N sin(pi f h))|``, first null at ``1 / (N h)``. ``x`` between the grid
    points ``t_s`` is linear, and held at its first and last values outside (the axes rest
    before and after)."""
    t = np.asarray(t_s, dtype=np.float64)
    x = np.asarray(pos_mm, dtype=np.float64)
    n = int(samples)
    if n <= 1 or len(t) < 2:
        return x.copy()
    shifts = _grid_shifts(t, n, raw_period_s)
    if shifts is not None:
        return _shifted_mean(x, shifts)
    out = np.zeros_like(x)
    for j in range(n):
        tq = t + (j - 0.5 * (n - 1)) * raw_period_s
        for k in range(x.shape[1]):
            out[:, k] += np.interp(tq, t, x[:, k])
    return out / n


def _grid_shifts(t: np.ndarray, n: int, raw_period_s: float) -> np.ndarray | None:
    """The offsets ``(j - (N - 1)/2) h`` of :func:`sample_mean_mm` in HALF steps of the grid
    ``t`` when ``t`` is uniform and every offset falls on a grid point or midway between two
    (the model grid of 2 ms and the 500 Hz raw period); None otherwise."""
    dt = (t[-1] - t[0]) / (len(t) - 1)
    if dt <= 0 or abs(t[1] - t[0] - dt) > 1e-9 * dt or abs(t[len(t) // 2] - t[0] - (len(t) // 2) * dt) > 1e-6 * dt:
        return None
    half = 2.0 * (np.arange(n) - 0.5 * (n - 1)) * raw_period_s / dt
    shifts = np.round(half)
    return shifts.astype(np.int64) if np.all(np.abs(half - shifts) < 1e-9) else None


def _shifted_mean(x: np.ndarray, half_shifts: np.ndarray) -> np.ndarray:
    """``mean_j x(i + half_shifts[j] / 2)`` on the grid, with ``x`` linear between its points
    and held at its ends (:func:`sample_mean_mm` without interpolating: a point midway between
    two samples is their mean)."""
    m = len(x)
    mid = 0.5 * (x[:-1] + x[1:])                  # x(i + 1/2)
    pad = int(np.max(np.abs(half_shifts))) // 2 + 1
    xp = np.concatenate([np.repeat(x[:1], pad, axis=0), x, np.repeat(x[-1:], pad, axis=0)])
    mp = np.concatenate([np.repeat(x[:1], pad, axis=0), mid, np.repeat(x[-1:], pad + 1, axis=0)])
    out = np.zeros_like(x)
    for h in half_shifts:
        k, odd = divmod(int(h), 2)                # x(i + k) or x(i + k + 1/2)
        src = mp if odd else xp
        out += src[pad + k: pad + k + m]
    return out / len(half_shifts)


def corner_jumps_mm_s(accel_mm_s2, overload_factor, ipo_cycle_s: float) -> np.ndarray:
    """G64 corner law (840D B1 "continuous-path mode G64", MD32310 $MA_MAX_ACCEL_OVL_FACTOR):
    the velocity jump axis i may make at a corner, ``A_i (f_i - 1) t_IPO``."""
    return (np.asarray(overload_factor, dtype=np.float64) - 1.0) \
        * np.asarray(accel_mm_s2, dtype=np.float64) * ipo_cycle_s


def overload_factors_for(jumps_mm_s, accel_mm_s2, ipo_cycle_s: float) -> np.ndarray:
    """MD32310 per axis that gives the axis velocity jumps ``jumps_mm_s``: the inverse of
    :func:`corner_jumps_mm_s`, ``f_i = 1 + jump_i / (A_i t_IPO)``."""
    return 1.0 + np.asarray(jumps_mm_s, dtype=np.float64) / (
        np.asarray(accel_mm_s2, dtype=np.float64) * ipo_cycle_s)
