"""Sequential inner loops of the planner, compiled with numba (``ncsim.jit``: plain Python on
small programs).

The look-ahead's backward/forward passes are recurrences over knots (each knot's feed
depends on its neighbour's), which numpy cannot vectorise; a compiled loop does a million
knots in milliseconds. ``tests/test_ramps.py`` checks these scalars against
``ncsim.plan.ramps``.
"""
from __future__ import annotations

import math

import numpy as np

from ncsim.jit import njit


@njit(cache=True, python=math.cbrt)
def cbrt(x):
    """The real cube root (libm's ``cbrt`` both ways)."""
    return np.cbrt(x)


@njit(cache=True)
def ramp_reach_scalar(v0, distance, jerk, accel):
    """Scalar twin of :func:`ncsim.plan.ramps.ramp_reach_mm_s` (same closed forms)."""
    if not math.isfinite(distance) or not math.isfinite(v0):
        return math.inf if distance > 0.0 else v0
    return v0 + reach_gain_scalar(v0, distance, jerk, accel)


@njit(cache=True)
def reach_gain_scalar(v0, distance, jerk, accel):
    """The feed gain ``v1 - v0`` of :func:`ramp_reach_scalar`, without forming ``v1``
    (no rounding when the gain is tiny against v0)."""
    if distance <= 0.0:
        return 0.0
    p = 2.0 * v0
    q = distance * math.sqrt(jerk)
    # Cardano for y^3 + p y - q = 0 (p >= 0: one real root), written c - (p/3)/c to avoid a
    # second cube root; one Newton step polishes the rounding of the difference.
    c = cbrt(0.5 * q + math.sqrt(0.25 * q * q + p * p * p / 27.0))
    y = c - (p / 3.0) / c
    y = y - (y * y * y + p * y - q) / (3.0 * y * y + p + 1e-300)
    x = y * y
    if x * jerk <= accel * accel:
        return x
    b = 2.0 * v0 + accel * accel / jerk
    c = 2.0 * v0 * accel * accel / jerk - 2.0 * distance * accel
    disc = math.sqrt(max(b * b - 4.0 * c, 0.0))
    x = -2.0 * c / (b + disc) if c < 0.0 else 0.0
    return max(x, 0.0)


@njit(cache=True)
def ramp_time_scalar(dv, jerk, accel):
    """Scalar twin of :func:`ncsim.plan.ramps.ramp_time_s`."""
    dv = abs(dv)
    if dv * jerk <= accel * accel:
        return 2.0 * math.sqrt(dv / jerk)
    return dv / accel + accel / jerk


@njit(cache=True)
def ramp_distance_scalar(v0, v1, jerk, accel):
    """Scalar twin of :func:`ncsim.plan.ramps.ramp_distance_mm`."""
    return 0.5 * (v0 + v1) * ramp_time_scalar(v1 - v0, jerk, accel)


@njit(cache=True)
def _rise_distance(v_low, dv, jerk, accel):
    """Distance of a ramp between v_low and v_low + dv, from dv itself (no cancellation)."""
    return 0.5 * (2.0 * v_low + dv) * ramp_time_scalar(dv, jerk, accel)


@njit(cache=True)
def _rise_distance_slope(v_low, dv, jerk, accel):
    """d/d(dv) of :func:`_rise_distance`."""
    if dv <= 0.0:
        return math.inf
    if dv * jerk <= accel * accel:
        t, dt = 2.0 * math.sqrt(dv / jerk), 1.0 / math.sqrt(jerk * dv)
    else:
        t, dt = dv / accel + accel / jerk, 1.0 / accel
    return 0.5 * t + 0.5 * (2.0 * v_low + dv) * dt


@njit(cache=True)
def _peak_excess(va, vb, ga, gb, u2, length, ju, au, jd, ad):
    return (_rise_distance(va, ga + u2, ju, au) + _rise_distance(vb, gb + u2, jd, ad)
            - length)


@njit(cache=True)
def peak_feed_scalar(va, vb, length, jerk, accel, cap):
    """Scalar twin of :func:`ncsim.plan.ramps.peak_feed_mm_s` (generalised eq. 16): both
    ramps with the same limits (:func:`peak_feed_pair`)."""
    return peak_feed_pair(va, vb, length, jerk, accel, jerk, accel, cap)


@njit(cache=True)
def peak_feed_pair(va, vb, length, ju, au, jd, ad, cap):
    """Generalised eq. 16 with the rising ramp under jerk ``ju`` and acceleration ``au`` and
    the falling one under ``jd``, ``ad`` (each ramp takes the limits of the blocks it runs
    through: ``ncsim.plan._sections``).

    Solved for u = sqrt(V - lo), lo = max(va, vb): the equation is smooth in u (in V it has a
    square-root end) and each ramp's distance is computed from its own feed change
    (lo - v_end) + u^2, never from V - v_end, which would cancel when V is close to lo.
    """
    lo = max(va, vb)
    if cap <= lo:
        return cap
    ga, gb = lo - va, lo - vb          # the ramps' feed change already due at V = lo
    if (math.isfinite(cap)
            and _peak_excess(va, vb, ga, gb, cap - lo, length, ju, au, jd, ad) <= 0.0):
        return cap
    if length <= 0.0 or _peak_excess(va, vb, ga, gb, 0.0, length, ju, au, jd, ad) >= 0.0:
        return lo
    # the weaker ramp's limits bound the start; the stronger ones bound the answer above
    jw, aw = min(ju, jd), min(au, ad)
    hi = (cap - lo if math.isfinite(cap)
          else reach_gain_scalar(lo, length, max(ju, jd), max(au, ad)))
    u_lo, u_hi = 0.0, math.sqrt(max(hi, 0.0))
    # start from the exact answer for equal end feeds and limits: one ramp over half the
    # free length
    free = length - (_rise_distance(va, ga, ju, au) + _rise_distance(vb, gb, jd, ad))
    u = math.sqrt(reach_gain_scalar(lo, 0.5 * free, jw, aw)) if free > 0.0 else u_hi
    u = min(u, u_hi) if u > 0.0 else u_hi
    for _ in range(100):
        f = _peak_excess(va, vb, ga, gb, u * u, length, ju, au, jd, ad)
        if abs(f) <= 1e-14 * length:
            break
        if f < 0.0:
            u_lo = u
        else:
            u_hi = u
        slope = 2.0 * u * (_rise_distance_slope(va, ga + u * u, ju, au)
                           + _rise_distance_slope(vb, gb + u * u, jd, ad))
        nu = u - f / slope if slope > 0.0 and math.isfinite(slope) else 0.5 * (u_lo + u_hi)
        if not (u_lo < nu < u_hi):
            nu = 0.5 * (u_lo + u_hi)
        if abs(nu - u) <= 1e-14 * max(nu, 1e-300) or u_hi - u_lo <= 1e-14 * u_hi:
            u = nu
            break
        u = nu
    if _peak_excess(va, vb, ga, gb, u * u, length, ju, au, jd, ad) > 1e-12 * max(length, 1e-300):
        u = u_lo                       # never return a feed whose ramps do not fit
    return lo + u * u


@njit(cache=True)
def peak_feeds(va, vb, length, jerk, accel, cap):
    out = np.empty(va.shape[0])
    for i in range(va.shape[0]):
        out[i] = peak_feed_scalar(va[i], vb[i], length[i], jerk[i], accel[i], cap[i])
    return out


@njit(cache=True)
def _ramp_segments(v0, v1, jerk, accel):
    """Durations t1, t2 and signed jerk of a ramp (see ncsim.plan.ramps.ramp_pieces)."""
    dv = abs(v1 - v0)
    a_peak = min(accel, math.sqrt(dv * jerk))
    t1 = a_peak / jerk
    t2 = max(dv / accel - accel / jerk, 0.0) if a_peak >= accel else 0.0
    sign = 1.0 if v1 >= v0 else -1.0
    return t1, t2, sign * jerk


@njit(cache=True)
def _emit_ramp(v_from, v_to, J, A, s, t, m, phase, limit, t0, s0, v0, a0, jj, ph, lim, write):
    """Append the (up to three) constant-jerk pieces of one ramp starting at path length s
    and time t; returns the new time and piece count (``write`` False: count only)."""
    v, a = v_from, 0.0
    t1, t2, jsig = _ramp_segments(v_from, v_to, J, A)
    for dur, jk in ((t1, jsig), (t2, 0.0), (t1, -jsig)):
        if dur > 0.0:
            if write:
                t0[m], s0[m], v0[m], a0[m], jj[m] = t, s, v, a, jk
                ph[m], lim[m] = phase, limit
            s = s + dur * (v + dur * (a / 2.0 + dur * jk / 6.0))
            v = v + dur * (a + dur * jk / 2.0)
            a = a + dur * jk
            t += dur
            m += 1
    return t, m


@njit(cache=True)
def _emit_section(va, vp, vb, length, ju, au, jd, ad, s_start, dwell, reason_up, reason_down,
                  reason_steady, phase_a, phase_b, phase_c, phase_stop, limit_dwell, t, m,
                  t0, s0, v0, a0, jj, ph, lim, write):
    """The pieces of one section (knot feeds va, vb, peak vp) from time t and piece index m:
    dwell at the start knot, ramp A (up to three pieces; jerk ``ju``, acceleration ``au``),
    steady B, ramp C (``jd``, ``ad``). Returns the new time and piece count."""
    if dwell > 0.0:
        if write:
            t0[m], s0[m], v0[m], a0[m], jj[m] = t, s_start, 0.0, 0.0, 0.0
            ph[m], lim[m] = phase_stop, limit_dwell
        t += dwell
        m += 1
    # ramp A: v_a -> v_peak
    t, m = _emit_ramp(va, vp, ju, au, s_start, t, m, phase_a, reason_up,
                      t0, s0, v0, a0, jj, ph, lim, write)
    up = ramp_distance_scalar(va, vp, ju, au)
    down = ramp_distance_scalar(vp, vb, jd, ad)
    steady = length - up - down
    if steady > 0.0 and vp > 0.0:
        if write:
            t0[m], s0[m], v0[m], a0[m], jj[m] = t, s_start + up, vp, 0.0, 0.0
            ph[m], lim[m] = phase_b, reason_steady
        t += steady / vp
        m += 1
    # ramp C: v_peak -> v_b
    return _emit_ramp(vp, vb, jd, ad, s_start + length - down, t, m, phase_c, reason_down,
                      t0, s0, v0, a0, jj, ph, lim, write)


@njit(cache=True)
def _emit_sections(v_knot, v_peak, sec_len, ramp_limits, sec_s0, start_dwell,
                   final_dwell, reason_up, reason_down, reason_steady,
                   phase_a, phase_b, phase_c, phase_stop, limit_dwell,
                   t0, s0, v0, a0, jj, ph, lim, sec_end_t, write):
    """The pieces of every section (see :func:`section_pieces`); returns the piece count and
    the end time. With ``write`` False nothing is stored: the same walk counts the pieces."""
    n_sec = v_peak.shape[0]
    m = 0
    t = 0.0
    for i in range(n_sec):
        t, m = _emit_section(v_knot[i], v_peak[i], v_knot[i + 1], sec_len[i],
                             ramp_limits[i, 0], ramp_limits[i, 1], ramp_limits[i, 2],
                             ramp_limits[i, 3], sec_s0[i], start_dwell[i], reason_up[i],
                             reason_down[i], reason_steady[i], phase_a, phase_b, phase_c,
                             phase_stop, limit_dwell, t, m, t0, s0, v0, a0, jj, ph, lim, write)
        if write:
            sec_end_t[i] = t
    if final_dwell > 0.0:
        if write:
            t0[m], s0[m], v0[m], a0[m], jj[m] = (t, sec_s0[n_sec - 1] + sec_len[n_sec - 1], 0.0,
                                                 0.0, 0.0)
            ph[m], lim[m] = phase_stop, limit_dwell
        t += final_dwell
        m += 1
    return m, t


@njit(cache=True)
def inner_junction_states(v_knot, v_peak, sec_len, ramp_limits, knots, s_junction):
    """Feed and acceleration at every junction of a solved knot set without dwells, without
    materialising the pieces: the pieces of each section with inner junctions (at most seven)
    go to a small buffer, timed from the section's start, and its inner junctions are read
    off them as :func:`junction_states` reads the whole piece list (same pieces, same Newton
    solve; durations from section-local instead of absolute times, equal to rounding)."""
    n1 = s_junction.shape[0]
    n_sec = v_peak.shape[0]
    v_j = np.zeros(n1)
    a_j = np.zeros(n1)
    t0 = np.empty(8)
    s0 = np.empty(8)
    v0 = np.empty(8)
    a0 = np.empty(8)
    jj = np.empty(8)
    ph = np.empty(8, dtype=np.int8)
    lim = np.empty(8, dtype=np.int8)
    for i in range(n_sec):
        v_j[knots[i]] = v_knot[i]
        if knots[i + 1] - knots[i] < 2:
            continue                      # no inner junction
        t_end, m = _emit_section(v_knot[i], v_peak[i], v_knot[i + 1], sec_len[i],
                                 ramp_limits[i, 0], ramp_limits[i, 1], ramp_limits[i, 2],
                                 ramp_limits[i, 3], s_junction[knots[i]], 0.0, 0, 0, 0, 0, 1,
                                 2, 3, 0, 0.0, 0, t0, s0, v0, a0, jj, ph, lim, True)
        k = 0
        for j in range(knots[i] + 1, knots[i + 1]):
            target = s_junction[j]
            while k + 1 < m and s0[k + 1] <= target:
                k += 1
            dt = (t0[k + 1] if k + 1 < m else t_end) - t0[k]
            tau = _piece_time(s0[k], v0[k], a0[k], jj[k], dt, target)
            t = t0[k] + tau
            if t <= 0.0:                  # clamped to the knots' times, as junction_states
                v_j[j] = v_knot[i]
            elif t >= t_end:
                v_j[j] = v_knot[i + 1]
            else:
                v_j[j] = v0[k] + tau * (a0[k] + tau * jj[k] / 2.0)
                a_j[j] = a0[k] + tau * jj[k]
    v_j[knots[n_sec]] = v_knot[n_sec]
    return v_j, a_j


@njit(cache=True)
def section_pieces(v_knot, v_peak, sec_len, ramp_limits, sec_s0, start_dwell,
                   final_dwell, reason_up, reason_down, reason_steady,
                   phase_a, phase_b, phase_c, phase_stop, limit_dwell):
    """Constant-jerk pieces of every section: dwell at the start knot, ramp A (up to three
    pieces), steady B, ramp C. Returns piece arrays and each section's end time. The arrays
    are views of buffers sized for the most pieces a section can have (eight): the pages
    past the last piece are never written, so they take no memory."""
    n_sec = v_peak.shape[0]
    size = 8 * n_sec + 1
    sec_end_t = np.empty(n_sec)
    times = np.empty(size + 1)
    s0 = np.empty(size)
    v0 = np.empty(size)
    a0 = np.empty(size)
    jj = np.empty(size)
    ph = np.empty(size, dtype=np.int8)
    lim = np.empty(size, dtype=np.int8)
    m, t = _emit_sections(v_knot, v_peak, sec_len, ramp_limits, sec_s0, start_dwell,
                          final_dwell, reason_up, reason_down, reason_steady, phase_a, phase_b,
                          phase_c, phase_stop, limit_dwell, times, s0, v0, a0, jj, ph, lim,
                          sec_end_t, True)
    times[m] = t
    return times[:m + 1], s0[:m], v0[:m], a0[:m], jj[:m], ph[:m], lim[:m], sec_end_t


@njit(cache=True)
def _piece_time(s0, v0, a0, j, dt, target):
    """tau in [0, dt] with s0 + v0 tau + a0 tau^2/2 + j tau^3/6 = target (safeguarded Newton)."""
    lo, hi = 0.0, dt
    s_end = s0 + dt * (v0 + dt * (a0 / 2.0 + dt * j / 6.0))
    span = s_end - s0
    tau = dt * (target - s0) / span if span > 0.0 else 0.5 * dt
    tau = min(max(tau, 0.0), dt)
    for _ in range(60):
        f = s0 + tau * (v0 + tau * (a0 / 2.0 + tau * j / 6.0)) - target
        if f < 0.0:
            lo = tau
        else:
            hi = tau
        vel = v0 + tau * (a0 + tau * j / 2.0)
        nt = tau - f / vel if vel > 0.0 else 0.5 * (lo + hi)
        if not (lo <= nt <= hi):
            nt = 0.5 * (lo + hi)
        if abs(nt - tau) <= 1e-13 * dt:
            return nt
        tau = nt
    return tau


@njit(cache=True)
def junction_states(piece_t, piece_s, piece_v, piece_a, piece_j, piece_phase, phase_stop,
                    s_junction, is_knot, knot_time, knot_feed, knot_dwell):
    """Arrival time, feed and acceleration at every junction, in one merge-like pass over
    junctions and pieces (both ordered along the path).

    A junction between two knots is passed after the tool leaves the first (its arrival
    plus its dwell) and before it reaches the second. Inverting s(t) cannot guarantee that
    where the junction lies at the same s as a knot (blocks without motion next to it): near
    rest, a rounding of s moves t by microseconds to either side, and a block would start
    before the one ahead of it ends. Such times are clamped to the knot's, with its state."""
    n1 = s_junction.shape[0]
    t_arr = np.empty(n1)
    v_j = np.empty(n1)
    a_j = np.empty(n1)
    m = piece_s.shape[0]
    k = 0
    ki = 0
    for i in range(n1):
        if is_knot[i]:
            t_arr[i] = knot_time[ki]
            v_j[i] = knot_feed[ki]
            a_j[i] = 0.0
            ki += 1
            continue
        leave = knot_time[ki - 1] + knot_dwell[ki - 1]   # junction 0 is a knot: ki >= 1
        if m == 0:                                        # nothing moves anywhere
            t_arr[i], v_j[i], a_j[i] = leave, knot_feed[ki - 1], 0.0
            continue
        target = s_junction[i]
        # the last piece starting at or before the target, backing off standstill pieces
        while k + 1 < m and piece_s[k + 1] <= target:
            k += 1
        kk = k
        while kk > 0 and piece_phase[kk] == phase_stop:
            kk -= 1
        dt = piece_t[kk + 1] - piece_t[kk]
        tau = _piece_time(piece_s[kk], piece_v[kk], piece_a[kk], piece_j[kk], dt, target)
        t = piece_t[kk] + tau
        if t <= leave:
            t_arr[i], v_j[i] = leave, knot_feed[ki - 1]
        elif t >= knot_time[ki]:                          # the last junction is a knot
            t_arr[i], v_j[i] = knot_time[ki], knot_feed[ki]
        else:
            t_arr[i] = t
            v_j[i] = piece_v[kk] + tau * (piece_a[kk] + tau * piece_j[kk] / 2.0)
            a_j[i] = piece_a[kk] + tau * piece_j[kk]
    return t_arr, v_j, a_j


@njit(cache=True)
def approach_stop_distance_scalar(v_start, v_peak, jerk, accel):
    """Longest stopping distance met on a ramp from v_start up to v_peak: from the start of
    its last -J piece (acceleration a_p, duration a_p/J, covering V a_p/J - a_p^3/6J^2) the
    stop finishes that piece and ramps from V to rest (see ncsim.plan.lookahead._pin_unstoppable)."""
    dv = max(v_peak - v_start, 0.0)
    a_p = min(accel, math.sqrt(jerk * dv))
    t1 = a_p / jerk
    return v_peak * t1 - a_p * a_p * a_p / (6.0 * jerk * jerk) + ramp_distance_scalar(v_peak, 0.0, jerk, accel)


@njit(cache=True)
def approach_feed_scalar(v_start, room, jerk, accel):
    """Highest V >= v_start whose approach ramp can always stop within ``room`` (bisection)."""
    if approach_stop_distance_scalar(v_start, v_start, jerk, accel) > room:
        return v_start
    lo = v_start
    hi = max(ramp_reach_scalar(0.0, room, jerk, accel), lo)
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        if approach_stop_distance_scalar(v_start, mid, jerk, accel) <= room:
            lo = mid
        else:
            hi = mid
        if hi - lo <= 1e-12 * max(hi, 1.0):
            break
    return lo


@njit(cache=True)
def creep_caps(p, keep, s_junction, start, end, v_start, room, jerk, accel, cap, tol):
    """Look-ahead creep (see ``ncsim.plan.lookahead._pin_unstoppable``): for each section, successive
    approach ramps towards its set point, each ending at a junction made a knot; within
    ``tol`` of the set point the feed holds. Lowers ``p`` and sets ``keep`` in place."""
    for i in range(start.shape[0]):
        a, e = start[i], end[i]
        v = v_start[i]
        pos = a
        while True:
            target = approach_feed_scalar(v, room[i], jerk[i], accel[i])
            if target >= cap[i] * (1.0 - tol) or target <= v * (1.0 + 1e-12):
                # hold: nothing after the last knot may exceed the reached feed
                hold = target if target <= v * (1.0 + 1e-12) else target
                for k in range(pos + 1, e):
                    if p[k] > hold:
                        p[k] = hold
                if target <= v * (1.0 + 1e-12) and pos + 1 < e:
                    keep[pos + 1] = True
                break
            ramp_end = s_junction[pos] + ramp_distance_scalar(v, target, jerk[i], accel[i])
            q = pos + 1
            while q < e and s_junction[q] < ramp_end * (1.0 - 1e-12):
                q += 1
            for k in range(pos + 1, q + 1):
                if k < e and p[k] > target:
                    p[k] = target
            if q >= e:
                break
            keep[q] = True
            pos = q
            v = target
    return p


@njit(cache=True)
def reach_array(v0, distance, jerk, accel):
    """``ramp_reach_scalar`` over arrays (v0 may be a 0-length broadcast: pass full arrays)."""
    out = np.empty(distance.shape[0])
    for i in range(distance.shape[0]):
        out[i] = ramp_reach_scalar(v0[i], distance[i], jerk[i], accel[i])
    return out


@njit(cache=True)
def removable_knots(peaks, caps, knot_caps, keep):
    """Which inner knots to remove (ncsim.plan.lookahead._refine_knots): walking along the path, a knot
    goes when the group of sections it joins keeps its highest peak at or below its lowest set
    point (section set points and the removed knots' caps), so merging never slows a section:
    a section steady at its set point merges with a neighbour of a higher set point that
    never rises above it (the zero acceleration at the knot between them would only cost
    time).
    ``knot_caps``/``keep`` are indexed by knot (0 and the last are never removed)."""
    n_sec = peaks.shape[0]
    remove = np.zeros(n_sec + 1, dtype=np.bool_)
    group_cap = caps[0]
    group_peak = peaks[0]
    for i in range(1, n_sec):
        new_cap = min(group_cap, caps[i], knot_caps[i])
        new_peak = max(group_peak, peaks[i])
        if not keep[i] and new_peak <= new_cap * (1.0 + 1e-12):
            remove[i] = True
            group_cap, group_peak = new_cap, new_peak
        else:
            group_cap, group_peak = caps[i], peaks[i]
    return remove


# ---------------------------------------------------------------------------------------------
# Look-ahead, knots and sections (ncsim.plan.lookahead): one pass each, no full-size temporaries
# ---------------------------------------------------------------------------------------------

@njit(cache=True)
def lookahead_caps(cap, cap_limit, jcap, jlimit, s_junction, jerk, accel, depth, code):
    """840D dynamic look-ahead, in place (see ``lookahead._apply_lookahead``): block k, whose
    window k..k+depth ends inside the path, is capped at the feed one ramp can brake to rest
    from within that window (jerk and acceleration: the window's least), and so is its end
    junction. Window minima by monotone queues (ring buffers of depth + 2 entries)."""
    n = cap.shape[0]
    w = depth + 1
    last = n - w                     # blocks k < last: the window end k + w is inside the path
    if last <= 0:
        return
    size = w + 1
    qj = np.empty(size, dtype=np.int64)
    qa = np.empty(size, dtype=np.int64)
    hj, nj, ha, na = 0, 0, 0, 0
    for i in range(last + w - 1):
        while nj > 0 and jerk[qj[(hj + nj - 1) % size]] >= jerk[i]:
            nj -= 1
        qj[(hj + nj) % size] = i
        nj += 1
        while na > 0 and accel[qa[(ha + na - 1) % size]] >= accel[i]:
            na -= 1
        qa[(ha + na) % size] = i
        na += 1
        k = i - w + 1
        if k < 0:
            continue
        while qj[hj] < k:
            hj = (hj + 1) % size
            nj -= 1
        while qa[ha] < k:
            ha = (ha + 1) % size
            na -= 1
        jw, aw = jerk[qj[hj]], accel[qa[ha]]
        e = k + w
        block_cap = ramp_reach_scalar(0.0, s_junction[e] - s_junction[k], jw, aw)
        if block_cap < cap[k]:
            cap[k] = block_cap
            cap_limit[k] = code
        junction_cap = ramp_reach_scalar(0.0, s_junction[e] - s_junction[k + 1], jw, aw)
        if junction_cap < jcap[k + 1]:
            jcap[k + 1] = junction_cap
            jlimit[k + 1] = code


@njit(cache=True)
def knots_and_reasons(p, cap, cap_limit, jcap, jlimit, rel, none_code, end_code):
    """Knots (see ``lookahead._find_knots``) and, per junction, the limit a ramp heads to or
    leaves it for. Junction k joins block k-1 (set point ``left``) and block k (``right``)."""
    n = cap.shape[0]
    knot = np.zeros(n + 1, dtype=np.bool_)
    reason = np.empty(n + 1, dtype=np.int8)
    for k in range(n + 1):
        left = cap[k - 1] if k > 0 else math.inf
        right = cap[k] if k < n else math.inf
        lower = min(left, right)
        if math.isinf(left) or math.isinf(right):
            close = left == right
        else:
            close = abs(left - right) <= rel * abs(right) or left == right
        knot[k] = p[k] < lower * (1.0 - rel) or not close or k == 0 or k == n
        if left <= right:
            r = cap_limit[k - 1] if k > 0 else 0
        else:
            r = cap_limit[k] if k < n else 0
        if jcap[k] <= lower * (1.0 + rel):
            r = jlimit[k]
        reason[k] = r
    reason[0] = jlimit[0] if jcap[0] < 0.5 else end_code
    if jlimit[0] == none_code:
        reason[0] = end_code
    reason[n] = end_code if jlimit[n] == none_code else jlimit[n]
    return np.flatnonzero(knot), reason


@njit(cache=True)
def section_minima(knots, p, cap, jerk, accel, s_junction):
    """Per section (blocks knots[i]..knots[i+1]-1): its length, least jerk and acceleration
    of its blocks, whether all its blocks share them (``uniform``), its set point -- the
    least set point of its blocks and crossing cap of its inner junctions -- and where that
    comes from: the first block holding the least set point, or -(b + 2) for the end
    junction of block b when an inner junction's cap is lower."""
    ns = knots.shape[0] - 1
    sec_len = np.empty(ns)
    sec_jerk = np.empty(ns)
    sec_accel = np.empty(ns)
    sec_cap = np.empty(ns)
    uniform = np.empty(ns, dtype=np.bool_)
    cap_from = np.empty(ns, dtype=np.int64)
    for i in range(ns):
        a, b = knots[i], knots[i + 1]
        jm, am, bm, fb = jerk[a], accel[a], cap[a], a
        jx, ax = jerk[a], accel[a]
        jn, fj = math.inf, a
        for blk in range(a, b):
            jm = min(jm, jerk[blk])
            am = min(am, accel[blk])
            jx = max(jx, jerk[blk])
            ax = max(ax, accel[blk])
            if cap[blk] < bm:
                bm, fb = cap[blk], blk
            if blk + 1 < b and p[blk + 1] < jn:
                jn, fj = p[blk + 1], blk
        sec_len[i] = s_junction[b] - s_junction[a]
        sec_jerk[i], sec_accel[i] = jm, am
        uniform[i] = jx == jm and ax == am
        sec_cap[i] = math.nan if bm != bm or jn != jn else min(bm, jn)   # np.minimum
        cap_from[i] = -(fj + 2) if jn < bm else fb
    return sec_len, sec_jerk, sec_accel, uniform, sec_cap, cap_from


@njit(cache=True)
def stopping_distance_scalar(v, a, jerk, accel):
    """Scalar twin of :func:`ncsim.plan.lookahead.stopping_distance_mm`."""
    ap = max(a, 0.0)
    t = ap / jerk
    if a >= 0.0:
        return (v * t + ap * t * t / 2.0 - jerk * t * t * t / 6.0
                + ramp_distance_scalar(v + ap * ap / (2.0 * jerk), 0.0, jerk, accel))
    if -a < accel * (1.0 - 1e-12):
        an = -a
        t = an / jerk
        v_s = v + an * an / (2.0 * jerk)
        return ramp_distance_scalar(v_s, 0.0, jerk, accel) - (v_s * t - jerk * t * t * t / 6.0)
    v_f = accel * accel / (2.0 * jerk)
    return max(v * v - v_f * v_f, 0.0) / (2.0 * accel) + accel * accel * accel / (6.0 * jerk * jerk)


@njit(cache=True)
def unstoppable_junctions(v_j, a_j, knots, sec_jerk, sec_accel, s_junction, lookahead_end):
    """Junctions (not knots, whose look-ahead window ``lookahead_end`` ends before the path
    does) from whose feed and acceleration the tool cannot stop within the window: returns
    their indices, sections and braking room (see ``lookahead._pin_unstoppable``)."""
    n1 = s_junction.shape[0]
    n = n1 - 1
    ns = knots.shape[0] - 1
    bad = np.empty(n1, dtype=np.int64)
    sec_of = np.empty(n1, dtype=np.int64)
    room_of = np.empty(n1)
    m = 0
    sec = 0
    ki = 0
    for i in range(n1):
        while sec + 1 < ns and knots[sec + 1] <= i:
            sec += 1
        if ki < knots.shape[0] and knots[ki] == i:
            ki += 1
            continue
        if lookahead_end[i] >= n:
            continue
        room = s_junction[lookahead_end[i]] - s_junction[i]
        stop = stopping_distance_scalar(v_j[i], a_j[i], sec_jerk[sec], sec_accel[sec])
        if stop > room * (1.0 + 1e-9) + 1e-9:
            bad[m], sec_of[m], room_of[m] = i, sec, room
            m += 1
    return bad[:m].copy(), sec_of[:m].copy(), room_of[:m].copy()
