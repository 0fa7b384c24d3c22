"""Controlled-jerk feed ramps (paper §5.2.2 phases A and C, §5.5 stage 3, eq. 16).

A *ramp* changes the feed from ``v0`` to ``v1`` starting and ending at zero tangential
acceleration, with jerk ``+-J`` and acceleration at most ``A`` (the paper's phase A: the
acceleration rises linearly, then falls linearly, the feed follows two parabolas; phase C is
its mirror). For ``dv = |v1 - v0|``:

* if ``dv <= A^2/J`` the acceleration peaks at ``sqrt(J dv)`` and the ramp lasts
  ``T = 2 sqrt(dv / J)``;
* otherwise it holds ``A`` in the middle and lasts ``T = dv/A + A/J``.

Either way the ramp is point-symmetric about its middle, so it covers ``D = (v0 + v1) T / 2``.
With ``T = 2 sqrt(dv/J)`` this is the distance of the paper's eq. 16, which fills a block of
length L with ramp A from ``V_frs`` up to ``V_f`` and ramp C down to ``V_fre``::

    sqrt(V_f - V_fre) (V_f + V_fre) + sqrt(V_f - V_frs) (V_f + V_frs) = L sqrt(J)

:func:`peak_feed_mm_s` solves the general form (with the acceleration limit) for ``V_f``.
Everything is vectorised; arguments broadcast.
"""
from __future__ import annotations

import numpy as np

_TINY = 1e-300


def ramp_time_s(dv_mm_s, jerk_mm_s3, accel_mm_s2):
    """Duration of a zero-to-zero-acceleration ramp changing the feed by ``dv`` (phase A or C)."""
    dv = np.abs(np.asarray(dv_mm_s, dtype=np.float64))
    j = np.asarray(jerk_mm_s3, dtype=np.float64)
    a = np.asarray(accel_mm_s2, dtype=np.float64)
    jerk_only = dv * j <= a * a
    return np.where(jerk_only, 2.0 * np.sqrt(dv / j), dv / a + a / j)


def ramp_distance_mm(v0_mm_s, v1_mm_s, jerk_mm_s3, accel_mm_s2):
    """Path length of the ramp from ``v0`` to ``v1`` (each term of eq. 16 divided by sqrt(J))."""
    v0 = np.asarray(v0_mm_s, dtype=np.float64)
    v1 = np.asarray(v1_mm_s, dtype=np.float64)
    return 0.5 * (v0 + v1) * ramp_time_s(v1 - v0, jerk_mm_s3, accel_mm_s2)


def ramp_reach_mm_s(v0_mm_s, distance_mm, jerk_mm_s3, accel_mm_s2):
    """Highest feed ``v1 >= v0`` that one ramp can reach from ``v0`` within ``distance_mm``.

    By symmetry it is also the highest feed from which one ramp can come down to ``v0``
    within that distance. Inverts :func:`ramp_distance_mm` in closed form: with
    ``x = v1 - v0``, the jerk-only case is the cubic ``y^3 + 2 v0 y - d sqrt(J) = 0`` in
    ``y = sqrt(x)``; the acceleration-limited case is the quadratic
    ``x^2 + (2 v0 + A^2/J) x + 2 v0 A^2/J - 2 d A = 0``.
    """
    v0, d, j, a = np.broadcast_arrays(*(np.asarray(x, dtype=np.float64) for x in
                                        (v0_mm_s, distance_mm, jerk_mm_s3, accel_mm_s2)))
    d = np.maximum(d, 0.0)
    out = np.array(v0, dtype=np.float64, copy=True)
    finite = np.isfinite(d) & np.isfinite(v0)
    out[~finite] = np.inf
    pos = finite & (d > 0)
    if not np.any(pos):
        return out
    v0p, dp, jp, ap = v0[pos], d[pos], j[pos], a[pos]
    # Jerk-only branch: depressed cubic y^3 + p y + q = 0, p = 2 v0 >= 0, q = -d sqrt(J).
    p = 2.0 * v0p
    q = dp * np.sqrt(jp)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        # Hyperbolic form for p > 0 (no cancellation), plain cube root for p == 0.
        arg = (1.5 * q / np.maximum(p, _TINY)) * np.sqrt(3.0 / np.maximum(p, _TINY))
        y_h = 2.0 * np.sqrt(p / 3.0) * np.sinh(np.arcsinh(arg) / 3.0)
    y = np.where((p > 0) & np.isfinite(y_h), y_h, np.cbrt(q))
    # One Newton step polishes rounding (the cubic is increasing and convex for y > 0).
    y = y - (y ** 3 + p * y - q) / (3.0 * y * y + p + _TINY)
    x_jerk = y * y
    # Acceleration-limited branch (stable root of the quadratic).
    b = 2.0 * v0p + ap * ap / jp
    c = 2.0 * v0p * ap * ap / jp - 2.0 * dp * ap
    disc = np.sqrt(np.maximum(b * b - 4.0 * c, 0.0))
    x_acc = np.where(c < 0, -2.0 * c / (b + disc), 0.0)
    x = np.where(x_jerk * jp <= ap * ap, x_jerk, x_acc)
    out[pos] = v0p + np.maximum(x, 0.0)
    return out


def peak_feed_mm_s(v_start_mm_s, v_end_mm_s, length_mm, jerk_mm_s3, accel_mm_s2,
                   cap_mm_s=np.inf):
    """Highest feed of a block (or section) of length L between two zero-acceleration points.

    Returns ``min(cap, V_f)`` where ``V_f`` solves the generalised eq. 16::

        ramp_distance(v_start, V_f) + ramp_distance(V_f, v_end) = L

    (phase B vanishes). If ``cap`` fits with room to spare, phase B exists at ``cap``. The
    caller guarantees ``ramp_distance(v_start, v_end) <= L`` (the look-ahead's job); if not,
    the larger end feed is returned. The root is found by safeguarded Newton iteration in
    ``u = sqrt(V_f - max(v_start, v_end))``, where the equation is smooth
    (``_kernels.peak_feed_scalar``); the result never makes the ramps longer than L.
    """
    from ncsim.plan._kernels import peak_feeds

    args = np.broadcast_arrays(*(np.asarray(x, dtype=np.float64) for x in
                                 (v_start_mm_s, v_end_mm_s, length_mm, jerk_mm_s3,
                                  accel_mm_s2, cap_mm_s)))
    shape = args[0].shape
    out = peak_feeds(*(np.ascontiguousarray(np.atleast_1d(a).ravel()) for a in args))
    return out.reshape(shape) if shape else float(out[0])


def ramp_pieces(v0_mm_s, v1_mm_s, jerk_mm_s3, accel_mm_s2):
    """The three constant-jerk pieces of a ramp: durations (3, n) and jerks (3, n).

    Rising ramp: jerk +J, 0, -J; falling: -J, 0, +J. Durations t1, t2, t1 with
    ``t1 = a_peak / J`` and ``t2 = dv/A - A/J`` when the acceleration limit is reached.
    """
    v0 = np.asarray(v0_mm_s, dtype=np.float64)
    v1 = np.asarray(v1_mm_s, dtype=np.float64)
    j = np.asarray(jerk_mm_s3, dtype=np.float64)
    a = np.asarray(accel_mm_s2, dtype=np.float64)
    dv = np.abs(v1 - v0)
    a_peak = np.minimum(a, np.sqrt(dv * j))
    t1 = a_peak / j
    t2 = np.where(a_peak >= a, np.maximum(dv / a - a / j, 0.0), 0.0)
    sign = np.where(v1 >= v0, 1.0, -1.0)
    durations = np.stack([t1, t2, t1])
    jerks = np.stack([sign * j, np.zeros_like(j), -sign * j])
    return durations, jerks
