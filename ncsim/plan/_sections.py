"""Every ramp under the limits of the blocks it runs through (compiled loops, ``ncsim.jit``).

A *section* of the feed law (the blocks between two knots, ``ncsim.plan.lookahead``) may join
blocks whose path jerk and acceleration differ: an arc, whose centripetal part takes its share
of the axes' acceleration (paper eq. 1), and the line it enters tangentially. The section's
law is still the paper's (§5.5 stage 3): ramp A from its start knot, steady B at the set
point, ramp C to its end knot. Each ramp obeys the limits of the blocks it actually crosses,
never the least of the whole section: ramp C of a line entered from an arc brakes with the
line's own acceleration when it lies within the line. A ramp that crosses blocks of
different limits takes the least of those (one ramp of constant-jerk pieces keeps the
acceleration continuous, and no block's limits are exceeded).

*Runs.* Walking from a knot into its section, block by block, the least jerk and acceleration
met so far change at a few blocks; a *run* is the stretch up to the next change. A ramp is
*valid* under run m's limits (J_m, A_m) when its length under them is at most d_m, the
distance from the knot to the end of run m: it then lies in runs 1..m, whose least limits are
J_m and A_m. A ramp takes the first run it is valid under (the highest limits it can have).
Blocks without motion cover nothing and limit nothing.

*Reach* (the knot passes): the highest feed from which one ramp comes down to v within the
section is max_m reach(v, d_m, J_m, A_m) over the runs from the end knot back (a ramp valid
under run m fits; one that fits is valid under some run): one cube root per run, and a
section of one set of limits is one run.

*Peak* (eq. 16 with the two ramps under different limits): a ramp's length grows with its
peak feed and jumps where the ramp leaves a run. The highest peak whose two ramps fit is
found run by run (:func:`peak_cover`): solve eq. 16 under the current runs' limits; if a ramp
is longer than its run, the feed at which it just fills that run is feasible, and that ramp's
next run is tried; the answer is the first solution valid under its runs, or the last such
feed if that is higher.
"""
from __future__ import annotations

import math

import numpy as np

from ncsim.jit import njit
from ncsim.plan._kernels import peak_feed_pair, ramp_distance_scalar, ramp_reach_scalar

FIT = 1e-12      # relative slack when a ramp's length is compared with its run's


@njit(cache=True)
def _run_forward(q, end, jm, am, jerk, accel, length):
    """Extend the blocks a ramp from a knot covers: take block ``q``, then every next block
    (before ``end``) that lowers neither the least jerk ``jm`` nor the least acceleration
    ``am``. Returns the first block past the run and the least limits (inf: no block moved)."""
    while True:
        if length[q] > 0.0:
            jm = min(jm, jerk[q])
            am = min(am, accel[q])
        q += 1
        if q >= end or (length[q] > 0.0 and jm < math.inf
                        and (jerk[q] < jm or accel[q] < am)):
            return q, jm, am


@njit(cache=True)
def _run_backward(q, start, jm, am, jerk, accel, length):
    """:func:`_run_forward` towards the start knot: the run ends (backwards) at block
    ``q - 1``; returns the first block of the extended run and the least limits."""
    while True:
        q -= 1
        if length[q] > 0.0:
            jm = min(jm, jerk[q])
            am = min(am, accel[q])
        if q <= start or (length[q - 1] > 0.0 and jm < math.inf
                          and (jerk[q - 1] < jm or accel[q - 1] < am)):
            return q, jm, am


@njit(cache=True)
def reach_cover(v_end, ka, kb, target, down, j_sec, a_sec, jerk, accel, length, s_junction):
    """min(target, the highest feed at one knot from which one ramp comes to ``v_end`` at the
    other), each ramp under the limits of the blocks it crosses (module docstring): with
    ``down`` the ramp comes down to ``v_end`` at knot ``kb`` from knot ``ka``, else it rises
    from ``v_end`` at ``ka`` (the same feed, read the other way) and the runs are walked
    from ``ka``. ``j_sec``, ``a_sec``: the section's limits, for a section without motion."""
    best = v_end
    q, jm, am = (kb if down else ka), math.inf, math.inf
    while (q > ka) if down else (q < kb):
        if down:
            q, jm, am = _run_backward(q, ka, jm, am, jerk, accel, length)
        else:
            q, jm, am = _run_forward(q, kb, jm, am, jerk, accel, length)
        if jm == math.inf:
            jm, am = j_sec, a_sec
        room = s_junction[kb] - s_junction[q] if down else s_junction[q] - s_junction[ka]
        r = ramp_reach_scalar(v_end, room, jm, am)
        if r > best:
            best = r
        if best >= target:
            return target
    return best


@njit(cache=True)
def knot_feeds_cover(caps, knots, uniform, sec_len, sec_jerk, sec_accel, jerk, accel, length,
                     s_junction):
    """Backward then forward pass over knots (``ncsim.plan.lookahead``): each knot's feed is
    at most its cap, at most what one ramp brings down to the next knot's feed, at most what
    one ramp brings up from the previous one -- each ramp under the limits of the blocks it
    crosses. A ramp never ends below its start, so a knot no higher than the one its ramp
    starts from keeps its feed without the ramp being solved."""
    m = caps.shape[0]
    v = caps.copy()
    for i in range(m - 2, -1, -1):
        if v[i] <= v[i + 1]:
            continue
        if uniform[i]:
            r = ramp_reach_scalar(v[i + 1], sec_len[i], sec_jerk[i], sec_accel[i])
        else:
            r = reach_cover(v[i + 1], knots[i], knots[i + 1], v[i], True, sec_jerk[i],
                            sec_accel[i], jerk, accel, length, s_junction)
        if r < v[i]:
            v[i] = r
    for i in range(m - 1):
        if v[i + 1] <= v[i]:
            continue
        if uniform[i]:
            r = ramp_reach_scalar(v[i], sec_len[i], sec_jerk[i], sec_accel[i])
        else:
            r = reach_cover(v[i], knots[i], knots[i + 1], v[i + 1], False, sec_jerk[i],
                            sec_accel[i], jerk, accel, length, s_junction)
        if r < v[i + 1]:
            v[i + 1] = r
    return v


@njit(cache=True)
def peak_cover(va, vb, ka, kb, sec_len, cap, j_sec, a_sec, jerk, accel, length, s_junction,
               out):
    """The highest feed of a section between knots ``ka`` and ``kb`` (feeds ``va``, ``vb``,
    at most ``cap``) whose ramps A and C fit, each under the limits of the blocks it crosses
    (module docstring); writes the ramps' limits (J_A, A_A, J_C, A_C) to ``out``."""
    qu, ju, au = _run_forward(ka, kb, math.inf, math.inf, jerk, accel, length)
    qd, jd, ad = _run_backward(kb, ka, math.inf, math.inf, jerk, accel, length)
    if ju == math.inf:                      # no block of the section moves
        ju, au, jd, ad = j_sec, a_sec, j_sec, a_sec
    lo = max(va, vb)
    best = -1.0
    bju, bau, bjd, bad = ju, au, jd, ad
    while True:
        v = peak_feed_pair(va, vb, sec_len, ju, au, jd, ad, cap)
        room_up = s_junction[qu] - s_junction[ka]
        room_down = s_junction[kb] - s_junction[qd]
        # a ramp over the whole section has nowhere to go (the passes make it fit)
        up_ok = qu >= kb or ramp_distance_scalar(va, v, ju, au) <= room_up * (1.0 + FIT)
        down_ok = qd <= ka or ramp_distance_scalar(v, vb, jd, ad) <= room_down * (1.0 + FIT)
        if up_ok and down_ok:
            if v > best:        # at a tie the earlier runs' (higher) limits stay
                best, bju, bau, bjd, bad = v, ju, au, jd, ad
            break
        # the feed at which the first ramp to outgrow its run just fills it is feasible
        b_up = math.inf if up_ok else ramp_reach_scalar(va, room_up, ju, au)
        b_down = math.inf if down_ok else ramp_reach_scalar(vb, room_down, jd, ad)
        b = min(b_up, b_down)
        if b >= lo * (1.0 - FIT) and b > best:     # (lo itself, up to rounding)
            best, bju, bau, bjd, bad = max(b, lo), ju, au, jd, ad
        if b_up <= b_down:
            qu, ju, au = _run_forward(qu, kb, ju, au, jerk, accel, length)
        else:
            qd, jd, ad = _run_backward(qd, ka, jd, ad, jerk, accel, length)
    out[0], out[1], out[2], out[3] = bju, bau, bjd, bad
    return best


@njit(cache=True)
def _section_peak(i, v_knot, knots, uniform, sec_len, sec_jerk, sec_accel, sec_cap, jerk,
                  accel, length, s_junction, ramp_limits):
    J, A = sec_jerk[i], sec_accel[i]
    if uniform[i]:
        ramp_limits[i, 0], ramp_limits[i, 1], ramp_limits[i, 2], ramp_limits[i, 3] = J, A, J, A
        return peak_feed_pair(v_knot[i], v_knot[i + 1], sec_len[i], J, A, J, A, sec_cap[i])
    return peak_cover(v_knot[i], v_knot[i + 1], knots[i], knots[i + 1], sec_len[i],
                      sec_cap[i], J, A, jerk, accel, length, s_junction, ramp_limits[i])


@njit(cache=True)
def peak_feeds_cover(v_knot, knots, uniform, sec_len, sec_jerk, sec_accel, sec_cap, jerk,
                     accel, length, s_junction):
    """Peak feed of every section and its ramps' limits, an (n_sec, 4) array of J_A, A_A,
    J_C, A_C (:func:`peak_cover`; one eq. 16 solve for a section of one set of limits)."""
    ns = sec_len.shape[0]
    peak = np.empty(ns)
    ramp_limits = np.empty((ns, 4))
    for i in range(ns):
        peak[i] = _section_peak(i, v_knot, knots, uniform, sec_len, sec_jerk, sec_accel,
                                sec_cap, jerk, accel, length, s_junction, ramp_limits)
    return peak, ramp_limits


@njit(cache=True)
def peak_feeds_cover_reusing(v_knot, knots, uniform, sec_len, sec_jerk, sec_accel, sec_cap,
                             jerk, accel, length, s_junction, prev_knots, prev_v, prev_cap,
                             prev_peak, prev_limits):
    """:func:`peak_feeds_cover`, taking the peak and limits of the previous knot set's
    (``prev_*``) where a section is the same -- the same two knots (so the same blocks) and
    the same end feeds and set point to the last bit, so the same result -- and solving the
    others: the knot sets of successive refinements differ in a few places."""
    ns = sec_len.shape[0]
    m = prev_peak.shape[0]
    peak = np.empty(ns)
    ramp_limits = np.empty((ns, 4))
    j = 0
    for i in range(ns):
        while j < m and prev_knots[j] < knots[i]:
            j += 1
        if (j < m and prev_knots[j] == knots[i] and prev_knots[j + 1] == knots[i + 1]
                and _same_bits(prev_v[j], v_knot[i]) and _same_bits(prev_v[j + 1], v_knot[i + 1])
                and _same_bits(prev_cap[j], sec_cap[i])):
            peak[i] = prev_peak[j]
            for c in range(4):
                ramp_limits[i, c] = prev_limits[j, c]
        else:
            peak[i] = _section_peak(i, v_knot, knots, uniform, sec_len, sec_jerk, sec_accel,
                                    sec_cap, jerk, accel, length, s_junction, ramp_limits)
    return peak, ramp_limits


@njit(cache=True)
def _same_bits(x, y):
    """x and y are the same double (zeros of one sign; NaN never is)."""
    return x == y and math.copysign(1.0, x) == math.copysign(1.0, y)


@njit(cache=True)
def block_section_values(knots, ramp_limits, v_knot, v_peak, sec_len, s_junction, v_j, jerk,
                         accel):
    """Per block: the jerk and acceleration in force -- the highest of the ramps that run
    through it (its own limits where no ramp does: steady throughout, or no motion) -- and
    the highest
    feed inside it: its end feeds, or the section's peak if the peak (or the steady phase)
    lies in the block."""
    n = s_junction.shape[0] - 1
    j_out = np.empty(n)
    a_out = np.empty(n)
    feed_max = np.empty(n)
    for i in range(knots.shape[0] - 1):
        a, b = knots[i], knots[i + 1]
        ju, au, jd, ad = ramp_limits[i, 0], ramp_limits[i, 1], ramp_limits[i, 2], ramp_limits[i, 3]
        s0 = s_junction[a]
        tol = 1e-9 * sec_len[i] + 1e-12
        peak_from = s0 + ramp_distance_scalar(v_knot[i], v_peak[i], ju, au)
        peak_to = s0 + sec_len[i] - ramp_distance_scalar(v_peak[i], v_knot[i + 1], jd, ad)
        rises = v_peak[i] > v_knot[i]
        falls = v_peak[i] > v_knot[i + 1]
        for blk in range(a, b):
            lo, hi = s_junction[blk], s_junction[blk + 1]
            moves = hi > lo
            in_up = moves and rises and lo < peak_from - tol
            in_down = moves and falls and hi > peak_to + tol
            if in_up and in_down:
                j_out[blk], a_out[blk] = max(ju, jd), max(au, ad)
            elif in_up:
                j_out[blk], a_out[blk] = ju, au
            elif in_down:
                j_out[blk], a_out[blk] = jd, ad
            else:
                j_out[blk], a_out[blk] = jerk[blk], accel[blk]
            f = max(v_j[blk], v_j[blk + 1])
            if lo <= peak_to + 1e-9 and hi >= peak_from - 1e-9:
                f = max(f, v_peak[i])
            feed_max[blk] = f
    return j_out, a_out, feed_max
