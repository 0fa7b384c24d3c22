"""Gap diagnosis against published measured values (a ``MeasuredSummary`` TOML) instead of a
trace: the paper's Table 3 feeds and radial deviations, its spiral feeds and phase-A jerks.

Each summary entry is matched to a block of one of the given programs (:func:`match_entries`):

* ``[[circle]]`` (radius R, programmed feed F): a full-circle arc of radius R programmed at F;
* ``[[block]]`` (``block`` k, radius R, feed F): the k-th arc (0-based, arcs only) of a program
  whose k-th arc has radius R and feed F, and the sweep its ``trajectory`` names (quarter-circle
  spiral: 90 degrees, semicircular: 180); entries that name no radius match nothing.

Entries that match no program are listed in the notes and not used. For a model the matched
blocks give the *predictions*, each compared to the published value as a residual in units of
its resolution (:data:`SCALES`):

* kinematics -- ``steady_feed`` (the block's highest feed: its phase-B feed when it has one),
  relative, 0.5 % (the paper gives feeds to 0.01 m/min); ``max_feed_below`` (one-sided: only
  a model feed above the bound counts) and ``reaches_programmed`` (one-sided: a model that
  reaches the programmed feed when the paper says it does not, or the reverse) on the same
  scale; ``normal_accel`` (``V^2/R`` at that feed, paper eq. 1), relative, 2 %;
  ``tangential_jerk`` (the jerk of phases A/C), relative, 5 % (slopes read from figures);
* radial deviations -- ``G``, ``Fmax``, ``Fmin`` (ISO 230-4, ``ncsim.gap.iso230``) of the model's
  circle (set point after the model's trace effects, nominal centre and radius from the
  program), absolute, 2 um.

``gap^2 = mean(kinematic residuals^2) + mean(radial residuals^2)``. Effects are fitted on this
gap (``diagnose.fit_effect``) and ranked three ways: on the whole gap, on the kinematics alone and
on the radial deviations alone. The *share of the radial deviations explained* by a model is
``1 - rms(model - measured) / rms(measured)`` over the published G, Fmax and Fmin values (the
base model, whose circles are exact, explains none of them).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Mapping, Sequence

import numpy as np

from ncsim.gap.effects import Model, jsonable, get_effect, make_base, model_description
from ncsim.errors import UsageError
from ncsim.gap.diagnose import ModelCache, RankedFits, combine, default_candidates
from ncsim.gap.fit import EffectFit, fit_effect
from ncsim.gap.metrics import shrink_percent
from ncsim.nc.interpret import interpret_file
from ncsim.gap.iso230 import circular_deviation
from ncsim.machine import MachineSpec
from ncsim.gap.summaryfile import MeasuredSummary
from ncsim.path import ARC, Path

RADIUS_TOL_MM = 1e-6
FEED_TOL_REL = 5e-3
SCALES = {"steady_feed": 0.005, "max_feed_below": 0.005, "reaches_programmed": 0.005,
          "normal_accel": 0.02, "tangential_jerk": 0.05, "G": 2.0, "Fmax": 2.0, "Fmin": 2.0}
RADIAL = ("G", "Fmax", "Fmin")
REACH_TOL = 2e-3   # "reaches the programmed feed": within 0.2 %


@dataclass(frozen=True)
class Match:
    entry: object          # measured.SummaryEntry
    program: str
    block: int


def _arcs(path: Path) -> np.ndarray:
    return np.nonzero(path.kind == ARC)[0]


def _expected_sweep_rad(trajectory: str | None) -> float | None:
    """Sweep of the arcs of a named trajectory: quarter-circle spirals pi/2, semicircular
    spirals pi (paper Fig. 13); None when the name says neither."""
    t = (trajectory or "").lower()
    if "quarter" in t:
        return np.pi / 2
    if "semi" in t or "half" in t:
        return np.pi
    return None


def match_entries(summary: MeasuredSummary, paths: Mapping[str, Path]):
    """``(matches, unmatched_entries)`` (module docstring)."""
    matches, unmatched = [], []
    for e in summary.entries:
        if e.kind not in ("circle", "block") or e.radius_mm is None:
            unmatched.append(e)
            continue
        found = None
        for name, path in paths.items():
            arcs = _arcs(path)
            ok = (np.abs(path.radius_mm[arcs] - e.radius_mm) <= RADIUS_TOL_MM)
            if e.programmed_feed_mm_s is not None:
                ok &= np.abs(path.feed_mm_s[arcs] / e.programmed_feed_mm_s - 1.0) <= FEED_TOL_REL
            if e.kind == "circle":
                ok &= path.sweep_rad[arcs] >= 2.0 * np.pi - 1e-6
                hit = arcs[ok]
            else:
                sweep = _expected_sweep_rad(e.trajectory)
                if sweep is not None:
                    ok &= np.abs(path.sweep_rad[arcs] - sweep) <= 1e-6
                k = e.ints.get("block")
                hit = arcs[ok] if k is None else [arcs[k]] if k < len(arcs) and ok[k] else []
            if len(hit):
                found = Match(e, name, int(hit[0]))
                break
        (matches.append(found) if found is not None else unmatched.append(e))
    return matches, unmatched


@dataclass(frozen=True)
class SummaryGap:
    """The gap between a model and published values (module docstring)."""

    gap: float
    kinematics: float          # rms of the kinematic residuals (in resolution units)
    radial_rms_um: float       # rms of model minus measured G, Fmax, Fmin
    radial_measured_rms_um: float
    feed_rms_percent: float    # rms relative steady-feed error
    rows: tuple = ()           # (entry id, quantity, measured, model, residual in scale units);
    #                            internal units (mm/s, mm/s^2, mm/s^3, um); reaches_programmed:
    #                            measured 1/0 (yes/no), model its highest feed / programmed feed
    parts: Mapping[str, float] = field(default_factory=dict)

    @property
    def radial_share_explained(self) -> float:
        """``1 - rms(model - measured) / rms(measured)`` over the radial indexes."""
        if self.radial_measured_rms_um <= 0:
            return math.nan
        return 1.0 - self.radial_rms_um / self.radial_measured_rms_um

    def metric_values(self) -> dict:
        return {"gap": self.gap, "kinematics": self.kinematics,
                "radial_rms_um": self.radial_rms_um, "feed_rms_percent": self.feed_rms_percent}

    def as_dict(self) -> dict:
        return {**self.metric_values(), "radial_share_explained": self.radial_share_explained,
                "parts": dict(self.parts),
                "rows": [{"id": r[0], "quantity": r[1], "measured": r[2], "model": r[3],
                          "residual": r[4]} for r in self.rows]}


class SummaryEvaluator:
    """Predictions of models for the matched entries of a summary (caches the plans)."""

    def __init__(self, paths: Mapping[str, Path], matches: Sequence[Match]):
        if not matches:
            raise UsageError("no entry of the measured summary matches a block of the given "
                             "programs (circles: radius, full turn and programmed feed; blocks: "
                             "the k-th arc's radius and feed)")
        self.matches = list(matches)
        self.caches = {name: ModelCache(p) for name, p in paths.items()
                       if any(m.program == name for m in matches)}
        self.n_evals = 0

    def predictions(self, model: Model) -> list[tuple[Match, dict]]:
        out = []
        for m in self.matches:
            cache = self.caches[m.program]
            motion = cache.motion(model)
            b = m.block
            path = cache.path
            r = float(path.radius_mm[b])
            feed = float(motion.feed_max_mm_s[b])
            pred = {"steady_feed": feed, "max_feed_below": feed,
                    "reaches_programmed": feed, "normal_accel": feed * feed / r,
                    "tangential_jerk": float(motion.jerk_mm_s3[b]),
                    "programmed": float(path.feed_mm_s[b])}
            if m.entry.kind == "circle" and any(m.entry.get(f"{q}_um") is not None for q in RADIAL):
                mt = cache.trace(model)
                sel = mt.block == b
                ci = circular_deviation(mt.pos_mm[sel][:, :2], path.center_mm[b][:2], r)
                pred.update(G=ci.G_um, Fmax=ci.Fmax_um, Fmin=ci.Fmin_um)
            out.append((m, pred))
        return out

    def evaluate(self, model: Model) -> SummaryGap:
        self.n_evals += 1
        kin, rad, feed_rel, rows = [], [], [], []
        rad_meas = []
        for m, pred in self.predictions(model):
            e = m.entry
            for q, stored in (("steady_feed", "steady_feed_mm_s"), ("normal_accel", "normal_accel_mm_s2"),
                              ("tangential_jerk", "tangential_jerk_mm_s3")):
                meas = e.get(stored)
                if meas is not None:
                    rel = pred[q] / meas - 1.0
                    kin.append(rel / SCALES[q])
                    rows.append((e.id, q, meas, pred[q], kin[-1]))
                    if q == "steady_feed":
                        feed_rel.append(rel)
            bound = e.get("max_feed_below_mm_s")
            if bound is not None:
                kin.append(max(pred["max_feed_below"] / bound - 1.0, 0.0) / SCALES["max_feed_below"])
                rows.append((e.id, "max_feed_below", bound, pred["max_feed_below"], kin[-1]))
            if "reaches_programmed" in e.flags:
                prog = pred["programmed"]
                short = 1.0 - pred["reaches_programmed"] / prog
                if e.flags["reaches_programmed"]:
                    res = max(short - REACH_TOL, 0.0)
                else:
                    res = max(REACH_TOL - short, 0.0)
                kin.append(res / SCALES["reaches_programmed"])
                rows.append((e.id, "reaches_programmed", float(e.flags["reaches_programmed"]),
                             pred["reaches_programmed"] / prog, kin[-1]))
            for q in RADIAL:
                meas = e.get(f"{q}_um")
                if meas is not None and q in pred:
                    rad.append(pred[q] - meas)
                    rad_meas.append(meas)
                    rows.append((e.id, q, meas, pred[q], rad[-1] / SCALES[q]))
        kin = np.array(kin)
        rad = np.array(rad)
        parts = {"kinematics": float(np.mean(kin ** 2)) if kin.size else 0.0,
                 "radial": float(np.mean((rad / SCALES["G"]) ** 2)) if rad.size else 0.0}
        return SummaryGap(gap=math.sqrt(sum(parts.values())),
                          kinematics=math.sqrt(parts["kinematics"]),
                          radial_rms_um=float(np.sqrt(np.mean(rad ** 2))) if rad.size else 0.0,
                          radial_measured_rms_um=float(np.sqrt(np.mean(np.square(rad_meas))))
                          if rad_meas else 0.0,
                          feed_rms_percent=100.0 * float(np.sqrt(np.mean(np.square(feed_rel))))
                          if feed_rel else 0.0,
                          rows=tuple(rows), parts=parts)


@dataclass
class SummaryDiagnosis(RankedFits):
    """Attribution of the gap to published values (module docstring)."""

    base: str
    base_model: Model
    gap_before: SummaryGap
    fits: list[EffectFit]               # ranked on the whole gap
    combined: EffectFit | None
    matches: list[Match]
    unmatched: list
    seconds: float
    source: str = ""

    def ranked(self, on: str) -> list[EffectFit]:
        """Fits ranked on ``"gap"``, ``"kinematics"`` or ``"radial"`` (the radial deviations:
        by the share explained)."""
        if on == "gap":
            return list(self.fits)
        if on == "kinematics":
            return sorted(self.fits, key=lambda f: f.gap_after.kinematics)
        if on == "radial":
            return sorted(self.fits, key=lambda f: f.gap_after.radial_rms_um)
        raise UsageError(f"unknown ranking {on!r}")

    def _fit_dict(self, f: EffectFit) -> dict:
        d = f.as_dict()
        d["kinematics_shrink_percent"] = shrink_percent(self.gap_before.kinematics, f.gap_after.kinematics)
        d["radial_share_explained"] = f.gap_after.radial_share_explained
        return d

    def as_dict(self) -> dict:
        best_radial = self.ranked("radial")[0]
        best_kin = self.ranked("kinematics")[0]
        return {"kind": "summary", "source": self.source, "base": self.base,
                "base_model": model_description(self.base_model),
                "gap_before": self.gap_before.as_dict(),
                "effects": [self._fit_dict(f) for f in self.fits],
                "ranking_kinematics": [f.effect for f in self.ranked("kinematics")],
                "ranking_radial": [f.effect for f in self.ranked("radial")],
                "best_kinematics": {"effect": best_kin.effect, "params": jsonable(best_kin.params),
                                    "shrink_percent": shrink_percent(self.gap_before.kinematics,
                                                                     best_kin.gap_after.kinematics)},
                "best_radial": {"effect": best_radial.effect,
                                "params": jsonable(best_radial.params),
                                "share_explained": best_radial.gap_after.radial_share_explained},
                "combined": self._fit_dict(self.combined) if self.combined is not None else None,
                "matched": [{"id": m.entry.id, "program": m.program, "block": m.block}
                            for m in self.matches],
                "unmatched": [e.id for e in self.unmatched], "seconds": self.seconds}


def combination_order(fits: Sequence[EffectFit], before: SummaryGap) -> list[EffectFit]:
    """Set point first, then what the axes and the structure make of it: the planner effects
    that shrink the kinematic gap (best first), then the trace effects that explain part of the
    radial deviations (best first). Fitting a planner effect against radial deviations would
    trade the precise published feeds (0.5 %) for the crude ones (the radial model is
    quasi-static)."""
    kin = sorted((f for f in fits if get_effect(f.effect).kind == "planner"
                  and f.gap_after.kinematics < before.kinematics * 0.995),
                 key=lambda f: f.gap_after.kinematics)
    rad = sorted((f for f in fits if get_effect(f.effect).kind == "trace"
                  and f.gap_after.radial_rms_um < before.radial_rms_um * 0.995),
                 key=lambda f: f.gap_after.radial_rms_um)
    # the best of each side first: ``combine`` tries only a few, and the planner effects that
    # all explain the same feeds (axis jerk, acceleration, velocity) must not crowd out the
    # radial side
    return kin[:1] + rad[:1] + kin[1:] + rad[1:]


def load_programs(programs: Sequence[str], machine: MachineSpec) -> dict[str, Path]:
    return {str(p): interpret_file(p, machine).path for p in programs}


def diagnose_summary(programs: Mapping[str, Path] | Sequence[str], machine: MachineSpec,
                     summary: MeasuredSummary, *, base: str = "axis-only",
                     candidates: Sequence[str] | None = None,
                     do_combine: bool = True) -> SummaryDiagnosis:
    """Rank the effects that explain the published values of ``summary`` (module docstring).
    ``programs``: interpreted paths by name, or program files."""
    t0 = time.perf_counter()
    paths = programs if isinstance(programs, Mapping) else load_programs(programs, machine)
    matches, unmatched = match_entries(summary, paths)
    ev = SummaryEvaluator(paths, matches)
    base_model = make_base(machine, base)
    before = ev.evaluate(base_model)
    cands = tuple(candidates) if candidates is not None else default_candidates()
    for c in cands:
        get_effect(c)
    fits = [fit_effect(ev, base_model, c, gap_before=before) for c in cands]
    fits.sort(key=lambda f: f.gap_after.gap)
    comb = combine(ev, combination_order(fits, before), before) if do_combine else None
    return SummaryDiagnosis(base=base, base_model=base_model, gap_before=before, fits=fits,
                            combined=comb, matches=matches, unmatched=unmatched,
                            seconds=time.perf_counter() - t0, source=summary.source)
