"""A slow, plain reference implementation of ncsim's feed-law model, used only as a test oracle.

It follows the rules written in ncsim/plan/lookahead.py's and ncsim/plan/_sections.py's
docstrings, but computes everything with scalar Python loops and bisection (no numpy
vectorisation, no numba, no closed-form inverses, no runs): ramp reach by bisection on the ramp
distance, eq. 16 peaks by bisection, the limits of a ramp by growing the set of blocks it
covers until it is stable, stopping distances by integrating the braking profile, junction
times by bisection on the section's s(t). The
fast planner must agree with it (tests/test_plan_reference.py).
"""
from __future__ import annotations

import math


# ---- ramps (paper §5.2.2): zero-to-zero-acceleration feed change -----------------------------

def ramp_time(dv, J, A):
    dv = abs(dv)
    return 2.0 * math.sqrt(dv / J) if dv * J <= A * A else dv / A + A / J


def ramp_distance(v0, v1, J, A):
    return 0.5 * (v0 + v1) * ramp_time(v1 - v0, J, A)


def bisect(f, lo, hi, n=200):
    """Largest x in [lo, hi] with f(x) true (f monotone: true then false)."""
    for _ in range(n):
        mid = 0.5 * (lo + hi)
        if f(mid):
            lo = mid
        else:
            hi = mid
    return lo


def reach(v0, d, J, A):
    if d <= 0:
        return v0
    if not math.isfinite(d):
        return math.inf
    hi = v0 + 1.0
    while ramp_distance(v0, hi, J, A) < d:
        hi = v0 + 2 * (hi - v0)
    return bisect(lambda v: ramp_distance(v0, v, J, A) <= d, v0, hi)


def peak(va, vb, L, J, A, cap):
    lo = max(va, vb)
    if cap <= lo:
        return cap
    if ramp_distance(va, cap, J, A) + ramp_distance(cap, vb, J, A) <= L:
        return cap
    return bisect(lambda v: ramp_distance(va, v, J, A) + ramp_distance(v, vb, J, A) <= L, lo, cap)


# ---- each ramp under the least limits of the blocks it runs through ---------------------------

def ramp_cover(walk, v0, v1, fallback):
    """(J, A) of the ramp v0 -> v1 laid from a knot over ``walk`` = [(distance from the knot
    to the block's near end, J, A)] of the moving blocks in the order the ramp meets them: the
    least over the blocks it reaches, found by growing the covered set until it is stable."""
    if not walk:
        return fallback
    J, A = walk[0][1], walk[0][2]
    while True:
        D = ramp_distance(v0, v1, J, A)
        cov = [w for w in walk if w[0] < D / (1 + 1e-12)] or walk[:1]
        J2, A2 = min(w[1] for w in cov), min(w[2] for w in cov)
        if (J2, A2) == (J, A):
            return J, A
        J, A = J2, A2


def reach_cover(v_end, walk, L, fallback):
    """Highest feed from which one ramp (limits by :func:`ramp_cover`) reaches ``v_end``
    within L (bisection: the ramp's length grows with the feed)."""
    def fits(v):
        return ramp_distance(v, v_end, *ramp_cover(walk, v, v_end, fallback)) <= L * (1 + 1e-12)

    if L <= 0:
        return v_end
    hi = v_end + 1.0
    while fits(hi):
        hi = v_end + 2 * (hi - v_end)
    return bisect(fits, v_end, hi)


def peak_cover(sc):
    """Eq. 16 with each ramp under the limits it covers (bisection on the peak)."""
    va, vb, L, cap = sc["va"], sc["vb"], sc["L"], sc["cap"]

    def used(v):
        up = ramp_distance(va, v, *ramp_cover(sc["fwd"], va, v, sc["JA"]))
        down = ramp_distance(v, vb, *ramp_cover(sc["bwd"], v, vb, sc["JA"]))
        return up + down

    lo = max(va, vb)
    if cap <= lo or used(cap) <= L:
        return cap
    return bisect(lambda v: used(v) <= L * (1 + 1e-12), lo, cap)


def ramp_phases(v0, v1, J, A):
    """[(duration, jerk)] of the ramp."""
    dv = abs(v1 - v0)
    ap = min(A, math.sqrt(dv * J))
    t1 = ap / J
    t2 = max(dv / A - A / J, 0.0) if ap >= A else 0.0
    sgn = 1.0 if v1 >= v0 else -1.0
    return [(t1, sgn * J), (t2, 0.0), (t1, -sgn * J)]


def integrate(state, dt, j):
    s, v, a = state
    return (s + dt * (v + dt * (a / 2 + dt * j / 6)), v + dt * (a + dt * j / 2), a + dt * j)


def stop_distance(v, a, J, A):
    """Distance to rest from (v, a) by simulating the optimal brake: drive the acceleration
    down to -x at jerk -J, x the largest deceleration <= A that does not reverse the feed
    (bisection), hold -A if x = A until the closing +J piece ends exactly at rest."""
    def after_drive(x):
        return integrate((0.0, v, a), (a + x) / J, -J) if a > -x else (0.0, v, a)

    def slack(x):  # feed left over after the drive, minus what the closing +J piece removes
        return after_drive(x)[1] - x * x / (2 * J)

    lo = max(-a, 0.0)
    if slack(lo) < 0:  # already braking too hard: close with +J at once (the feed reverses)
        return integrate((0.0, v, a), -a / J, J)[0]
    x = A if slack(A) >= 0 else bisect(lambda x: slack(x) >= 0, lo, A)
    st = after_drive(x)
    v_close = x * x / (2 * J)
    if st[1] > v_close and x > 0:
        st = integrate(st, (st[1] - v_close) / x, 0.0)
    return integrate(st, x / J, J)[0]


# ---- the planner --------------------------------------------------------------------------

def plan_reference(path, machine, options, limits, creep_tol=0.01):
    """Total cycle time (s) and junction feeds of ``path`` under ncsim's model."""
    n = path.n
    L = [float(x) for x in path.length_mm]
    S = [0.0]
    for x in L:
        S.append(S[-1] + x)
    cap = [float(x) for x in limits.cap_mm_s]
    J = [float(x) for x in limits.jerk_mm_s3]
    A = [float(x) for x in limits.accel_mm_s2]
    jcap = [float(x) for x in limits.junction_cap_mm_s]
    dwell = [float(x) for x in limits.junction_dwell_s]
    # blocks without motion are transparent: they take the set point before (or after) them
    real = [i for i in range(n) if L[i] > 0]
    for i in range(n):
        if L[i] <= 0:
            before = [k for k in real if k < i]
            cap[i] = cap[before[-1]] if before else (cap[real[0]] if real else math.inf)
    D = machine.ncu.lookahead_blocks
    if options.lookahead:
        for k in range(n):
            e = k + D + 1
            if e >= n:
                continue
            jw, aw = min(J[k:e]), min(A[k:e])
            cap[k] = min(cap[k], reach(0.0, S[e] - S[k], jw, aw))
            jcap[k + 1] = min(jcap[k + 1], reach(0.0, S[e] - S[k + 1], jw, aw))
    p = []
    for k in range(n + 1):
        v = jcap[k]
        if k > 0:
            v = min(v, cap[k - 1])
        if k < n:
            v = min(v, cap[k])
        p.append(max(v, 0.0))
    p[0] = p[n] = 0.0

    def is_knot(k):
        if k in (0, n):
            return True
        left, right = cap[k - 1], cap[k]
        if p[k] < min(left, right) * (1 - 1e-9):
            return True
        return not math.isclose(left, right, rel_tol=1e-9, abs_tol=0.0)

    knots = [k for k in range(n + 1) if is_knot(k)]
    keep = {k for k in range(n + 1) if p[k] <= 0} | {0, n}

    def solve(knots, p):
        secs = []
        for a, b in zip(knots[:-1], knots[1:]):
            c = min(min(cap[a:b]), min([p[k] for k in range(a + 1, b)], default=math.inf))
            moving = [k for k in range(a, b) if L[k] > 0]
            fwd = [(S[k] - S[a], J[k], A[k]) for k in moving]
            bwd = [(S[b] - S[k + 1], J[k], A[k]) for k in reversed(moving)]
            secs.append(dict(a=a, b=b, L=S[b] - S[a], J=min(J[a:b]), A=min(A[a:b]), cap=c,
                             fwd=fwd, bwd=bwd, JA=(min(J[a:b]), min(A[a:b]))))
        w = [p[k] for k in knots]
        for i, sc in enumerate(secs):
            w[i] = min(w[i], sc["cap"])
            w[i + 1] = min(w[i + 1], sc["cap"])
        for i in range(len(secs) - 1, -1, -1):
            if w[i] > w[i + 1]:
                w[i] = min(w[i], reach_cover(w[i + 1], secs[i]["bwd"], secs[i]["L"], secs[i]["JA"]))
        for i in range(len(secs)):
            if w[i + 1] > w[i]:
                w[i + 1] = min(w[i + 1], reach_cover(w[i], secs[i]["fwd"], secs[i]["L"], secs[i]["JA"]))
        for i, sc in enumerate(secs):
            sc["va"], sc["vb"] = w[i], w[i + 1]
            sc["peak"] = peak_cover(sc)
            sc["up"] = ramp_cover(sc["fwd"], sc["va"], sc["peak"], sc["JA"])
            sc["down"] = ramp_cover(sc["bwd"], sc["peak"], sc["vb"], sc["JA"])
        return secs

    secs = solve(knots, p)
    for _ in range(8):
        # walk along the path growing groups of sections while the group's highest peak
        # stays below its lowest set point (the joined knots' caps included)
        remove = set()
        group_cap, group_peak = secs[0]["cap"], secs[0]["peak"]
        for i in range(1, len(secs)):
            new_cap = min(group_cap, secs[i]["cap"], p[knots[i]])
            new_peak = max(group_peak, secs[i]["peak"])
            if knots[i] not in keep and new_peak <= new_cap * (1 + 1e-12):
                remove.add(knots[i])
                group_cap, group_peak = new_cap, new_peak
            else:
                group_cap, group_peak = secs[i]["cap"], secs[i]["peak"]
        if not remove:
            break
        knots = [k for k in knots if k not in remove]
        secs = solve(knots, p)

    if options.lookahead:
        p = list(p)
        room = [S[min(k + D, n)] - S[k] for k in range(n + 1)]
        for _ in range(8):
            bad = {}
            for i, sc in enumerate(secs):
                for k in range(sc["a"] + 1, sc["b"]):
                    if min(k + D, n) >= n:
                        continue
                    _, v, a = state_at(sc, S[k] - S[sc["a"]])
                    if stop_distance(v, a, sc["J"], sc["A"]) > room[k] * (1 + 1e-9) + 1e-9:
                        bad.setdefault(i, []).append(k)
            if not bad:
                break
            for i, ks in bad.items():
                sc = secs[i]
                creep(p, keep, S, sc, min(room[k] for k in ks), ks[0], creep_tol)
            knots = sorted(set(knots) | keep)
            secs = solve(knots, p)
    total = sum(dwell[k] for k in knots[:-1]) + dwell[n]
    for sc in secs:
        total += section_time(sc)
    return total, secs


def section_profile(sc):
    """[(duration, jerk)] of the section's law, and the steady length."""
    up = ramp_distance(sc["va"], sc["peak"], *sc["up"])
    down = ramp_distance(sc["peak"], sc["vb"], *sc["down"])
    steady = max(sc["L"] - up - down, 0.0)
    phases = ramp_phases(sc["va"], sc["peak"], *sc["up"])
    phases.append((steady / sc["peak"] if sc["peak"] > 0 else 0.0, 0.0))
    phases += ramp_phases(sc["peak"], sc["vb"], *sc["down"])
    return phases


def section_time(sc):
    return sum(dt for dt, _ in section_profile(sc))


def state_at(sc, x):
    """(t, v, a) where the section's law reaches distance x from its start."""
    st, t = (0.0, sc["va"], 0.0), 0.0
    for dt, j in section_profile(sc):
        end = integrate(st, dt, j)
        if end[0] >= x or dt == 0.0 and st[0] >= x:
            tau = bisect(lambda u: integrate(st, u, j)[0] <= x, 0.0, dt)
            s, v, a = integrate(st, tau, j)
            return t + tau, v, a
        st, t = end, t + dt
    return t, st[1], st[2]


def creep(p, keep, S, sc, room, first_bad, tol):
    """Successive approach ramps towards the section's set point (ncsim.plan.lookahead._pin_unstoppable)."""
    J, A = sc["J"], sc["A"]

    def approach_stop(v0, V):
        dv = max(V - v0, 0.0)
        ap = min(A, math.sqrt(J * dv))
        return V * ap / J - ap ** 3 / (6 * J * J) + ramp_distance(V, 0.0, J, A)

    pos, v, end = sc["a"], sc["va"], sc["b"]
    while True:
        if approach_stop(v, v) > room:
            target = v
        else:
            hi = max(reach(0.0, room, J, A), v)
            target = bisect(lambda V: approach_stop(v, V) <= room, v, hi)
        if target <= v * (1 + 1e-12):
            for k in range(pos + 1, end):
                p[k] = min(p[k], target)
            if pos + 1 < end:
                keep.add(pos + 1)
            return
        if target >= sc["cap"] * (1 - tol):
            for k in range(pos + 1, end):
                p[k] = min(p[k], target)
            return
        ramp_end = S[pos] + ramp_distance(v, target, J, A)
        q = pos + 1
        while q < end and S[q] < ramp_end * (1 - 1e-12):
            q += 1
        for k in range(pos + 1, min(q + 1, end)):
            p[k] = min(p[k], target)
        if q >= end:
            return
        keep.add(q)
        pos, v = q, target
