"""Fitting an effect's parameters to minimise a gap, and the record of one fit.

The search (:func:`fit_values`) works on any objective of a parameter dictionary: for a float
a grid (log-spaced where the parameter is), then around each of its two best local minima a
finer grid between the neighbours (a limit that stops binding beyond some value leaves a
plateau next to a narrow valley) and bounded Brent; for an integer a geometric scan then
golden-section on the integers; every value of a discrete parameter; and a Nelder-Mead polish
when two floats are free together. :func:`fit_effect` applies it to one effect on top of a
base model against an evaluator (``diagnose.Evaluator`` for traces,
``published.SummaryEvaluator`` for published values).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Iterable, Mapping, Sequence

import numpy as np
from scipy.optimize import minimize_scalar

from ncsim.gap.effects import EFFECTS, Model, get_effect, jsonable
from ncsim.gap.metrics import shrink_percent

N_GRID = 7                   # float parameters: log-spaced grid points before Brent
MAX_STARTS = 2               # float parameters: local minima of the grid refined
INT_GRID = (1, 2, 3, 4, 5, 6, 7, 8, 10, 12, 14, 16, 20, 24, 32, 48, 64, 96, 128)
COARSE_GRID = 4              # coarse fits (screening): grid points of a float
COARSE_INT_GRID = (1, 2, 4, 8, 16, 32, 64, 128)


@dataclass
class EffectFit:
    """One candidate effect fitted on top of a base model."""

    effect: str
    params: dict
    model: Model
    gap_before: object          # diagnose.GapMetrics (or the published values' gap)
    gap_after: object
    added: bool                 # True: the base lacked the effect; False: re-fitted
    n_evals: int = 0
    seconds: float = 0.0
    effects: tuple[str, ...] = ()   # for a combined model: the effects in it
    sensitive: bool = True          # some parameter value changed the gap (False: inert here)

    @property
    def shrink_percent(self) -> float:
        return shrink_percent(self.gap_before.gap, self.gap_after.gap)

    def metric_shrink(self) -> dict:
        b, a = self.gap_before.metric_values(), self.gap_after.metric_values()
        return {k: shrink_percent(b[k], a[k]) for k in b if k in a}

    def as_dict(self) -> dict:
        return {"effect": self.effect, "title": EFFECTS[self.effect].title if self.effect in EFFECTS else "",
                "added": self.added, "params": jsonable(self.params),
                "gap_before": self.gap_before.as_dict(), "gap_after": self.gap_after.as_dict(),
                "shrink_percent": self.shrink_percent, "metric_shrink_percent": self.metric_shrink(),
                "n_evals": self.n_evals, "seconds": self.seconds,
                **({"effects": list(self.effects)} if self.effects else {})}


def _float_search(objective, p, x0: float | None, n_grid: int = N_GRID, xtol_rel: float = 4e-3,
                  coarse: bool = False):
    """Minimise ``objective(x)`` over ``[p.low, p.high]``: a grid (log-spaced if ``p.log``)
    including ``x0``, then :func:`_refine` around its ``MAX_STARTS`` best local minima
    (``coarse``: the grid alone)."""
    lo, hi = float(p.low), float(p.high)
    fwd = (np.log if p.log else (lambda v: v))
    inv = (np.exp if p.log else (lambda v: v))
    grid = np.linspace(fwd(lo), fwd(hi), COARSE_GRID if coarse else n_grid)
    if x0 is not None and lo <= x0 <= hi:
        grid = np.unique(np.append(grid, fwd(x0)))
    if coarse:
        # the ends first: a parameter that changes nothing there is not looked at further
        ends = [objective(float(inv(g))) for g in (grid[0], grid[-1])]
        if ends[0] == ends[1]:
            mid = objective(float(inv(grid[len(grid) // 2])))
            if mid == ends[0]:
                return float(inv(grid[0])), ends[0]
    values = np.array([objective(float(inv(g))) for g in grid])
    best_x, best_f = float(inv(grid[int(np.argmin(values))])), float(np.min(values))
    if coarse or np.ptp(values) <= 1e-12 * max(float(np.max(np.abs(values))), 1e-300):
        return best_x, best_f            # the parameter changes nothing here: no refinement
    # refine around each of the (at most MAX_STARTS) best local minima of the grid: the gap can
    # have a narrow valley between coarse points (a BRISK acceleration, a transition time)
    # while a broad, shallower dip elsewhere holds the grid's best point
    interior = [k for k in range(len(grid))
                if (k == 0 or values[k] <= values[k - 1]) and (k == len(grid) - 1 or values[k] <= values[k + 1])]
    for k in sorted(interior, key=lambda i: values[i])[:MAX_STARTS]:
        x, f = _refine(objective, grid, values, k, inv, p.log, xtol_rel)
        if f < best_f:
            best_x, best_f = x, f
    return best_x, best_f


def _refine(objective, grid, values, k, inv, log: bool, xtol_rel: float):
    """A finer grid between grid point ``k``'s neighbours (a narrow valley next to a plateau --
    a limit that stops binding beyond some value -- is not missed), then bounded Brent between
    the neighbours of the best point of both."""
    a, b = grid[max(k - 1, 0)], grid[min(k + 1, len(grid) - 1)]
    fine = np.linspace(a, b, 6)[1:-1]
    fine = fine[np.min(np.abs(fine[:, None] - grid[None, :]), axis=1) > 1e-12]
    g2, v2 = grid, values
    if len(fine):
        g2 = np.concatenate([grid, fine])
        v2 = np.concatenate([values, [objective(float(inv(g))) for g in fine]])
        order = np.argsort(g2)
        g2, v2 = g2[order], v2[order]
        inside = np.nonzero((g2 >= a) & (g2 <= b))[0]
        k = int(inside[np.argmin(v2[inside])])
        a, b = g2[max(k - 1, 0)], g2[min(k + 1, len(g2) - 1)]
    if b - a <= 0:
        return float(inv(g2[k])), float(v2[k])
    tol = xtol_rel if log else 0.05 * xtol_rel * max(abs(b - a), 1e-12)
    res = minimize_scalar(lambda g: objective(float(inv(g))), bounds=(a, b), method="bounded",
                          options={"xatol": tol})
    if res.fun <= v2[k]:
        return float(inv(res.x)), float(res.fun)
    return float(inv(g2[k])), float(v2[k])


def _int_search(objective, p, x0: int | None, coarse: bool = False):
    """Integer parameter: a geometric scan, then every integer between the best point's
    neighbours in the scan (``coarse``: the scan alone)."""
    cand = sorted({v for v in (COARSE_INT_GRID if coarse else INT_GRID) if p.low <= v <= p.high}
                  | {int(p.low), int(p.high)}
                  | ({int(x0)} if x0 is not None and p.low <= x0 <= p.high else set()))
    values = {v: objective(v) for v in cand}
    best = min(values, key=values.get)
    if coarse:
        return best, values[best]
    i = cand.index(best)
    lo, hi = cand[max(i - 1, 0)], cand[min(i + 1, len(cand) - 1)]

    def f(v):
        if v not in values:
            values[v] = objective(v)
        return values[v]

    # golden-section on the integers of [lo, hi] (unimodal near the scan's best), then +-1
    a, b = lo, hi
    while b - a > 3:
        c = a + int(round(0.382 * (b - a)))
        d = a + int(round(0.618 * (b - a)))
        if c == d:
            break
        if f(c) <= f(d):
            b = d
        else:
            a = c
    for v in range(a, b + 1):
        f(v)
    best = min(values, key=values.get)
    for v in (best - 1, best + 1):
        if p.low <= v <= p.high:
            f(v)
    best = min(values, key=values.get)
    return best, values[best]


def fit_values(objective, params: Sequence, start: Mapping[str, object], free: Iterable[str],
               coarse: bool = False, polish: bool = True, sweeps: int | None = None):
    """Minimise ``objective(values)`` over the ``free`` parameters (others held at
    ``start``). Choices are enumerated; for each, integers are scanned and floats searched one
    at a time (coordinate search, two sweeps when more than one is free). ``coarse``: one sweep
    of the grids alone, no refinement (a cheap screen of many candidates). ``polish``: the
    Nelder-Mead polish of two or more floats (off: the coordinate search alone). ``sweeps``:
    the coordinate sweeps when several parameters are free (default two; one where a later
    re-fit refines, as the forward selection's back-fit does)."""
    free = [p for p in params if p.name in set(free)]
    choices = [p for p in free if p.kind == "choice"]
    numeric = [p for p in free if p.kind != "choice"]
    best_vals, best_f = dict(start), math.inf
    combos = [{}]
    for p in choices:
        combos = [dict(c, **{p.name: ch}) for c in combos for ch in p.choices]
    for combo in combos:
        vals = dict(start, **combo)
        f = None
        n_sweeps = (2 if sweeps is None else sweeps) if len(numeric) > 1 and not coarse else 1
        # a parameter whose every value left the same objective in a sweep changes nothing
        # under this combination (a SOFT jerk under BRISK): not searched again nor polished
        inert: set[str] = set()
        for _ in range(n_sweeps):
            for p in numeric:
                if p.name in inert:
                    continue
                seen: list[float] = []

                def obj1(x, p=p, vals=vals, seen=seen):
                    seen.append(objective(dict(vals, **{p.name: x})))
                    return seen[-1]
                if p.kind == "int":
                    x, f = _int_search(obj1, p, vals.get(p.name), coarse=coarse)
                else:
                    x0 = vals.get(p.name)
                    x, f = _float_search(obj1, p, None if x0 is None else float(x0), coarse=coarse)
                vals[p.name] = x
                if len(seen) > 1 and max(seen) == min(seen):
                    inert.add(p.name)
        floats = [p for p in numeric if p.kind == "float" and p.name not in inert]
        if len(floats) >= 2 and not coarse and polish:
            vals, f = _polish(objective, floats, vals)
        if f is None:
            f = objective(vals)
        if f < best_f:
            best_vals, best_f = vals, f
    return best_vals, best_f


def _polish(objective, floats, vals):
    """Nelder-Mead over several float parameters together (log-scaled where the parameter is),
    from the coordinate-search result: coordinate steps stall in a curved valley (e.g. Kv and
    the feed-forward weight, which trade off along (1 - k_ff)/Kv)."""
    from scipy.optimize import minimize

    def to_x(v):
        return np.array([math.log(v[p.name]) if p.log else v[p.name] for p in floats])

    def to_vals(x):
        out = dict(vals)
        for p, xi in zip(floats, x):
            lo, hi = float(p.low), float(p.high)
            out[p.name] = min(max(math.exp(xi) if p.log else float(xi), lo), hi)
        return out

    x0 = to_x(vals)
    f0 = objective(vals)
    span = np.array([0.1 if p.log else 0.1 * (p.high - p.low) for p in floats])
    simplex = np.vstack([x0] + [x0 + np.eye(len(floats))[i] * span[i] for i in range(len(floats))])
    # converged when the simplex spans 0.1 % of a log-scaled value (a quarter of the 1-D
    # search's tolerance) and its objectives agree to 1e-6 of the objective
    res = minimize(lambda x: objective(to_vals(x)), x0, method="Nelder-Mead",
                   options={"initial_simplex": simplex, "xatol": 1e-3,
                            "fatol": 1e-6 * max(abs(f0), 1e-300), "maxfev": 300})
    best = to_vals(res.x)
    f = objective(best)
    return (best, f) if f <= f0 else (vals, f0)


def choice_variants(effect_name: str) -> list[dict]:
    """Every combination of the effect's discrete (choice) parameters, ``[{}]`` if it has
    none: the structural hypotheses a search may keep apart (G60 or G64, SOFT or BRISK)."""
    combos: list[dict] = [{}]
    for p in get_effect(effect_name).params:
        if p.kind == "choice":
            combos = [dict(c, **{p.name: ch}) for c in combos for ch in p.choices]
    return combos


def free_params(effect, command: bool) -> list[str]:
    return [p.name for p in effect.params if command or not p.fixed_unless_command]


def fit_effect(evaluator, base: Model, effect_name: str, *,
               gap_before=None, command: bool = False, coarse: bool = False,
               fixed: Mapping[str, object] | None = None, polish: bool = True,
               sweeps: int | None = None) -> EffectFit:
    """Add (or re-fit) one effect on ``base`` and fit its parameters to minimise the gap.

    ``evaluator`` is anything with ``evaluate(model)`` returning an object with a ``gap``
    (``diagnose.Evaluator`` for traces, ``published.SummaryEvaluator`` for published values)
    and an ``n_evals`` counter. ``coarse``: grids only, ``polish``: with the Nelder-Mead
    polish (see :func:`fit_values`). ``fixed``: parameters held at given values (e.g. one
    choice of a discrete parameter)."""
    t0 = time.perf_counter()
    effect = get_effect(effect_name)
    n0 = evaluator.n_evals
    if gap_before is None:
        gap_before = evaluator.evaluate(base)
    start = effect.check({**effect.current(base), **(fixed or {})})
    cache: dict = {}

    def objective(values):
        key = tuple(sorted((k, round(v, 12) if isinstance(v, float) else v) for k, v in values.items()))
        if key not in cache:
            cache[key] = evaluator.evaluate(effect.apply(base, values)).gap ** 2
        return cache[key]

    free = [n for n in free_params(effect, command) if n not in (fixed or {})]
    values, _ = fit_values(objective, effect.params, start, free, coarse=coarse, polish=polish,
                           sweeps=sweeps)
    model = effect.apply(base, values)
    after = evaluator.evaluate(model)
    seen = np.array(list(cache.values()))
    return EffectFit(effect=effect_name, params=effect.check(values), model=model,
                     gap_before=gap_before, gap_after=after, added=not effect.is_active(base),
                     n_evals=evaluator.n_evals - n0, seconds=time.perf_counter() - t0,
                     sensitive=bool(seen.size and np.ptp(seen) > 1e-12 * max(float(np.max(seen)), 1e-300)))
