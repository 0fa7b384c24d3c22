"""Sim-to-real gap diagnosis: where the simulation departs from a measured trace, which
unmodelled effect causes it, and how much of the gap closes once that effect is added.

Pipeline (:func:`diagnose`):

1. **Base model** (``effects.make_base``): e.g. ``full`` or ``axis-only``; its *model trace* is
   the planned motion sampled on a uniform grid (``MODEL_DT_S``, 2 ms; held at rest for
   ``SETTLE_S`` after the end so that lagging axes can settle, and preceded by ``LEAD_S`` of
   rest when the recorder's filter acts) and passed through the model's
   trace effects (servo, structure).
2. **Alignment**: the recording is registered on the program once (``ncsim.gap.register``:
   the blocks and pass it covers, the work offset, each sample's place on the path), then, per
   model, put on the model's clock and mapped to its place on the model path
   (``ncsim.gap.align``).
3. **Gap metrics** (``ncsim.gap.metrics``), over the aligned samples inside the model's span:

   * ``feed_rms_mm_s``: RMS of measured minus model path speed at the same place. Both speeds
     go through the same central difference over about ``SPEED_WINDOW_S`` (the measured one is
     derived from positions), so the operator's own bias cancels;
   * ``time_rms_ms``: RMS of the time error at the place (measured time minus model time at
     the same path length), counted from its median: a constant is only another clock offset
     (the alignment's freedom, e.g. a pure servo delay), while a feed law that differs makes it
     grow along the path;
   * ``cycle_time_error_s``: measured minus model duration of the motion compared (from the
     motion onset, or the first covered place, to the end of the motion, or the last covered
     place: a recording may cover part of the program);
   * ``contour_rms_um``: RMS distance from each measured sample to the model path (the contour
     error; on arcs it is the radial deviation);
   * ``gap``: the combined, dimensionless gap on which effects of every kind are ranked::

         gap^2 = mean(feed_err^2) / s_v^2 + mean(time_err^2) / s_t^2 + mean(dist^2) / s_d^2

     with resolution scales from the measured trace (:func:`gap_scales`): ``s_d`` = twice the
     position noise (at least ``MIN_CONTOUR_SCALE_UM``), ``s_v`` = twice the noise of the derived
     speed plus 0.2 % of the top feed, ``s_t`` = ``TIME_SCALE_S``. It is a chi-square-like sum:
     a group of residuals at the noise level contributes about 1/4.
4. **Localisation** (:func:`localise`): the gap per block (feed, time and contour error), per
   phase (A, B, C, standstill, transition) and, on arcs, per angular position (mean radial
   deviation of the measurement and of the model, feed error and time error in 30 degree
   sectors about the arc's centre; ISO 230-4 G, Fmax, Fmin on full circles, measured against
   model).
5. **Attribution**: every candidate effect is added to the base (or, if the base already has
   it, its parameters are re-fitted) and fitted by minimising ``gap^2`` (:func:`fit_effect`,
   :func:`fit_values`): for a float a grid (log-spaced where the parameter is), then around
   each of its two best local minima a finer grid between the neighbours (a limit that stops
   binding beyond some value leaves a plateau next to a narrow valley) and bounded Brent; for an integer a geometric scan then
   golden-section on the integers; every value of a discrete parameter; and a Nelder-Mead
   polish when two floats are free together (``ncsim.gap.fit``). Nested effects share their
   fitted values (:func:`share_values`); effects are ranked by the gap left, each parameter
   charged ``PARSIMONY_SHARE`` of it (:func:`rank_fits`; ``shrink_percent = 100 (1 -
   gap_after / gap_before)``), and fits within ``TIE_SHARE`` of the best are noted as
   indistinguishable. The combined model comes from forward selection over structural
   hypotheses (:func:`forward_select`): every step must shrink the gap by ``COMBINE_MIN_GAIN``.
   An effect that changes how the program is interpreted (the reset path mode, MD20150) plans
   on the program interpreted again (``reinterpret``, :class:`ModelCache`).

   Measured samples in motion that fall outside the model's span (a model that ends too early,
   or a failed alignment) count with the time outside the model's motion as time error and
   their speed as feed error, so no model gains by leaving samples unmatched.

Everything here works on an interpreted :class:`~ncsim.path.Path`; planning is cached per
(machine, options), so trace effects cost one filter and one alignment per evaluation.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace
from typing import Callable, Mapping, Sequence

import numpy as np

from ncsim.gap.align import AlignPhase, Alignment, align
from ncsim.gap.closedforms import RECORDER_RAW_PERIOD_S
from ncsim.gap.effects import (EFFECTS, PLANNER_EFFECTS, REINTERPRETING, TRACE_EFFECTS, Model,
                               apply_trace_effects, corrected_machine, get_effect, make_base,
                               model_description)
from ncsim.errors import UsageError
from ncsim.gap.fit import EffectFit, choice_variants, fit_effect
from ncsim.gap.iso230 import circular_deviation, deviation_profile, radial_deviation_um
from ncsim.plan.limits import path_limits
from ncsim.machine import MachineSpec
from ncsim.gap.measured import MeasuredTrace, derived_speed_mm_s
from ncsim.gap.metrics import (SLOWEST_FEED_SHARE, SPEED_WINDOW_S, GapMetrics, GapScales,
                               compare_speed_mm_s, gap_metrics, gap_scales, rms)
from ncsim.gap.register import Registration, register
from ncsim.path import ARC, Path
from ncsim.plan.blend import ProgrammedPlaces
from ncsim.plan.lookahead import plan
from ncsim.plan.sample import sample_motion
from ncsim.units import mm_to_um, s_to_ms

MODEL_DT_S = 2e-3            # model trace grid (chord error a dt^2/8: 0.5 um at 1 m/s^2)
SETTLE_S = 0.5               # model held at rest after the end (lagging axes settle)
WINDOW_MARGIN_S = 0.5        # model traces sampled this much beyond what a recording covers
LEAD_S = 0.1                 # rest before the motion of a model trace through the recorder
COMBINE_MIN_GAIN = 0.05      # combined model: an effect must shrink the gap by 5 % more
MAX_REMEMBERED = 20000       # gaps of models an evaluator keeps (a few hundred bytes each)


# ---------------------------------------------------------------------------------------------
# Model traces
# ---------------------------------------------------------------------------------------------

@dataclass(frozen=True, eq=False)
class ModelTrace:
    """A model's predicted positions on a uniform grid, with the planner's labels."""

    t_s: np.ndarray          # (n,) uniform grid (the motion starts at 0; from -LEAD_S with a recorder)
    pos_mm: np.ndarray       # (n, 3) set point after the model's trace effects
    s_mm: np.ndarray         # (n,) path length of the set point (non-decreasing)
    block: np.ndarray        # (n,) block of the set point
    phase: np.ndarray        # (n,) motion.Phase of the set point
    feed_mm_s: np.ndarray    # (n,) speed of pos_mm
    setpoint: object         # the planner's ncsim.motion.Trace on the same grid
    cycle_time_s: float      # end of the planned motion
    compare_speed_mm_s: np.ndarray | None = None  # speed through the measured's operator


def interpretation_key(machine: MachineSpec) -> tuple:
    """What the interpreter takes from the machine that an effect may change: the group-10 and
    group-30 reset values (MD20150, ``effects.ResetPathMode``, ``effects.CompressorMode``).
    Models that differ here need the program interpreted again."""
    return (machine.ncu.reset_path_mode, machine.ncu.reset_compressor)


class ModelCache:
    """Plans and samples a path under models, re-planning only when the planner's inputs
    (machine, options) change.

    ``path`` was interpreted on a machine with interpretation key ``path_key``
    (:func:`interpretation_key`; None: any). A model whose machine has another key is planned
    on ``reinterpret(machine)`` (the program interpreted again, cached); without
    ``reinterpret`` such a model is a :class:`~ncsim.errors.UsageError`.

    ``s_window_mm = (lo, hi)``: only the stretch of the motion from ``WINDOW_MARGIN_S`` before
    it reaches path length ``lo`` to as long after ``hi`` is sampled (a recording that covers
    part of a long program needs no more; sampling is most of an evaluation's cost).

    Traces speak of the programmed path: where G641-G645 insert rounding blocks, the samples'
    path length and block are mapped back onto the programmed blocks
    (``blend.ProgrammedPlaces``), the terms of the registration and of ``path.line``."""

    def __init__(self, path: Path, dt_s: float = MODEL_DT_S, settle_s: float = SETTLE_S,
                 max_plans: int = 64, *, reinterpret=None, path_key: tuple | None = None,
                 s_window_mm: tuple | None = None):
        self.path = path
        self.dt_s = dt_s
        self.settle_s = settle_s
        self._plans: dict = {}
        self._limits: dict = {}
        self.max_plans = max_plans
        self.reinterpret = reinterpret
        self._paths: dict = {} if path_key is None else {path_key: path}
        self.s_window_mm = s_window_mm

    def path_for(self, machine: MachineSpec) -> Path:
        """The path the model's machine makes of the program (see the class docstring)."""
        if not self._paths:
            return self.path
        key = interpretation_key(machine)
        hit = self._paths.get(key)
        if hit is None:
            if self.reinterpret is None:
                raise UsageError("this model changes how the program is interpreted (reset path "
                                 "mode): it needs the program, not only its path")
            hit = self._paths[key] = self.reinterpret(machine)
            if hit.n != self.path.n:
                raise UsageError(f"the program interpreted again has {hit.n} blocks, not "
                                 f"{self.path.n}")
        return hit

    def limits(self, model: Model):
        """Stage 1 of the planner (``limits.path_limits``), shared by models that differ only in
        the look-ahead, which the limits do not depend on."""
        key = (model.machine.with_ncu(lookahead_blocks=1), replace(model.options, lookahead=True))
        hit = self._limits.get(key)
        if hit is None:
            hit = path_limits(self.path_for(model.machine), model.machine, model.options)
            if len(self._limits) >= self.max_plans:
                self._limits.pop(next(iter(self._limits)))
            self._limits[key] = hit
        return hit

    def setpoint(self, model: Model):
        """``(t_s, Trace, cycle_time_s, Motion)`` of the model's set point on the grid."""
        key = model.planner_key
        hit = self._plans.get(key)
        if hit is not None:
            return hit
        path, limits = self.path_for(model.machine), self.limits(model)
        motion = plan(path, model.machine, model.options, limits=limits)
        # G641-G645 insert rounding blocks: the trace speaks of the programmed blocks and places
        places = (None if limits.row_of is None
                  else ProgrammedPlaces.of(path, motion.path, limits.row_of))
        total = motion.total_time_s
        n = int(math.ceil((total + self.settle_s) / self.dt_s)) + 1
        t = np.arange(n) * self.dt_s
        if self.s_window_mm is not None:
            # piece start times against piece start lengths: monotone, close enough for a
            # window with WINDOW_MARGIN_S to spare
            s_window = (self.s_window_mm if places is None
                        else places.rounded_s_mm(self.s_window_mm))
            t_lo, t_hi = np.interp(s_window, motion.piece_s_mm, motion.piece_t_s[:-1])
            t = t[(t >= t_lo - WINDOW_MARGIN_S) & (t <= t_hi + WINDOW_MARGIN_S + self.settle_s)]
        tr = sample_motion(motion, t_s=np.minimum(t, total))
        if places is not None:
            tr = programmed_trace(tr, places, path)
        if len(self._plans) >= self.max_plans:
            self._plans.pop(next(iter(self._plans)))
        self._plans[key] = (t, tr, total, motion)
        return self._plans[key]

    def trace(self, model: Model) -> ModelTrace:
        t, tr, total, _ = self.setpoint(model)
        if model.post_values("recorder") is not None and t[0] == 0.0:
            # LEAD_S of rest before the start: the recorder's centred filter reaches before
            # it, and a measured trace that starts at rest must meet a model that does too
            n_lead = int(round(LEAD_S / self.dt_s))
            tr = tr.select(np.r_[np.zeros(n_lead, dtype=np.int64), np.arange(len(t))])
            t = np.r_[t[0] - self.dt_s * np.arange(n_lead, 0, -1), t]
        pos = tr.pos_mm
        if model.post:
            pos = apply_trace_effects(model, tr, t, pos)
            # the grid is uniform (np.arange steps): the scalar spacing is np.gradient's
            # fast form, the same central differences
            feed = np.linalg.norm(np.gradient(pos, self.dt_s, axis=0), axis=1)
        else:
            feed = tr.feed_mm_s
        # s(t) from the constant-jerk pieces can step back by rounding (1e-14 mm) where a
        # ramp ends at rest: the place along the path never goes back
        s_mm = np.maximum.accumulate(tr.s_mm)
        return ModelTrace(t_s=t, pos_mm=pos, s_mm=s_mm, block=tr.block, phase=tr.phase,
                          feed_mm_s=feed, setpoint=tr, cycle_time_s=total)

    def motion(self, model: Model):
        return self.setpoint(model)[3]


def programmed_trace(trace, places: ProgrammedPlaces, path: Path):
    """A planner :class:`~ncsim.motion.Trace` of a path with rounding blocks, its path length,
    block and line in the programmed ``path``'s terms (``blend.ProgrammedPlaces``), as the
    registration places a recording."""
    s_mm = places.programmed_s_mm(trace.s_mm)
    block = places.programmed_block(trace.block, s_mm)
    return replace(trace, s_mm=s_mm, block=block.astype(trace.block.dtype),
                   line=path.line[block].astype(trace.line.dtype))


# ---------------------------------------------------------------------------------------------
# Evaluating models against a measured trace
# ---------------------------------------------------------------------------------------------

class Evaluator:
    """Gap of models against one measured trace on one path (caches the plans)."""

    def __init__(self, path: Path, measured: MeasuredTrace, *, dt_s: float = MODEL_DT_S,
                 align_options: Mapping | None = None, registration: Registration | None = None,
                 reinterpret=None, path_key: tuple | None = None):
        if len(measured) < 10:
            raise UsageError(f"{measured.source}: {len(measured)} samples, need at least 10 "
                             "to diagnose a gap")
        self.path = path
        self.measured = measured
        if registration is None:
            registration = register(measured.pos_mm, path, signal="actual").require(measured.source)
        if len(registration.s_mm) != len(measured):
            raise UsageError(f"{measured.source}: the registration has {len(registration.s_mm)} "
                             f"samples, the trace {len(measured)}")
        self.registration = registration
        covered = registration.s_mm
        self.cache = ModelCache(path, dt_s=dt_s, reinterpret=reinterpret, path_key=path_key,
                                s_window_mm=(float(np.min(covered)), float(np.max(covered))))
        seg = np.unique(registration.segment)
        feeds = path.feed_mm_s[seg][~path.rapid[seg] & np.isfinite(path.feed_mm_s[seg])]
        cap = SLOWEST_FEED_SHARE * float(feeds.min()) if feeds.size else math.inf
        self.scales = gap_scales(measured, moving_cap_mm_s=cap)
        self.align_options = dict(align_options or {})
        self.derived = measured.feed_mm_s is None and measured.vel_mm_s is None
        self.measured_speed = (measured.speed_mm_s(self.scales.speed_window_s) if self.derived
                               else measured.speed_mm_s())
        self.n_evals = 0
        self.n_computed = 0
        self._gaps: dict = {}

    def model_trace(self, model: Model) -> ModelTrace:
        """The model trace, with its speed through the same operator as the measured speed."""
        mt = self.cache.trace(model)
        speed = (derived_speed_mm_s(mt.t_s, mt.pos_mm, self.scales.speed_window_s)
                 if self.derived else mt.feed_mm_s)
        return replace(mt, compare_speed_mm_s=speed)

    def align(self, mt: ModelTrace) -> Alignment:
        top = max(float(np.max(mt.feed_mm_s)), 1e-9)
        opts = dict(noise_mm=self.scales.noise_mm, speed_smoothing_s=SPEED_WINDOW_S,
                    measured_speed_mm_s=self.measured_speed,
                    onset_threshold_mm_s=max(self.scales.moving_mm_s(top), 1e-6),
                    offset_mm=self.registration.offset_mm, place_s_mm=self.registration.s_mm)
        if self.derived:
            opts["sim_speed_mm_s"] = mt.compare_speed_mm_s
        opts.update(self.align_options)
        return align(self.measured, mt.pos_mm, mt.t_s, mt.s_mm, sim_block=mt.block,
                     sim_phase=mt.phase, sim_feed_mm_s=mt.feed_mm_s, **opts)

    def evaluate(self, model: Model, *, full: bool = False):
        """``GapMetrics`` of ``model`` (and, with ``full``, the alignment and model trace)."""
        self.n_evals += 1
        if not full and model in self._gaps:
            # the searches of a diagnosis meet the same model again (a grid point of one
            # effect's fit on the same parent, the parent itself): its gap is known
            return self._gaps[model]
        self.n_computed += 1
        mt = self.model_trace(model)
        al = self.align(mt)
        m = gap_metrics(al, mt, self.scales)
        if len(self._gaps) >= MAX_REMEMBERED:
            self._gaps.pop(next(iter(self._gaps)))
        self._gaps[model] = m
        return (m, al, mt) if full else m


# ---------------------------------------------------------------------------------------------
# Localisation
# ---------------------------------------------------------------------------------------------

PHASE_NAMES = {int(p): p.name for p in AlignPhase}
SECTOR_DEG = 30.0


def localise(al: Alignment, mt: ModelTrace, path: Path, scales: GapScales,
             measured: MeasuredTrace, *, top_blocks: int = 10) -> dict:
    """Where the gap is (module docstring, step 4): per block, per phase, per angular sector of
    arcs, and the ISO 230-4 indexes of full circles (measured and model)."""
    model_speed = compare_speed_mm_s(mt, scales)
    v_model = np.interp(al.t_sim_s, mt.t_s, model_speed)
    feed_err = al.feed_mm_s - v_model
    dist_um = mm_to_um(al.distance_mm)
    ok = al.valid & (al.block >= 0)
    # at rest the place does not tell the time: time errors from samples in motion only
    moving = v_model > scales.moving_mm_s(max(float(np.max(model_speed)), 1e-9))
    blocks = []
    for b in np.unique(al.block[ok]):
        sel = ok & (al.block == b)
        idx = np.nonzero(sel)[0]
        mov = np.nonzero(sel & moving)[0]
        te = al.time_error_s[mov] if len(mov) else np.zeros(1)
        blocks.append({"block": int(b), "line": int(path.line[b]), "n": int(len(idx)),
                       "kind": "arc" if path.kind[b] == ARC else "line",
                       "feed_error_mean_mm_s": float(np.mean(feed_err[idx])),
                       "feed_error_rms_mm_s": rms(feed_err[idx]),
                       "time_error_in_ms": s_to_ms(float(te[0])),
                       "time_error_out_ms": s_to_ms(float(te[-1])),
                       "duration_error_ms": s_to_ms(float(te[-1] - te[0])),
                       "contour_rms_um": rms(dist_um[idx]),
                       "contour_max_um": float(np.max(dist_um[idx]))})
    score = lambda r: (abs(r["duration_error_ms"]) / s_to_ms(scales.time_s)  # noqa: E731
                       + r["feed_error_rms_mm_s"] / scales.feed_mm_s
                       + r["contour_rms_um"] / mm_to_um(scales.contour_mm))
    ranked = sorted(blocks, key=score, reverse=True)[:top_blocks]

    phases = []
    for code, name in PHASE_NAMES.items():
        sel = al.valid & (al.phase == code)
        if np.any(sel):
            mov = sel & moving
            phases.append({"phase": name, "n": int(np.count_nonzero(sel)),
                           "feed_error_rms_mm_s": rms(feed_err[sel]),
                           "contour_rms_um": rms(dist_um[sel]),
                           "time_error_mean_ms": s_to_ms(float(np.mean(al.time_error_s[mov])))
                           if np.any(mov) else 0.0})

    q = measured.pos_mm - al.offset_mm
    arcs = []
    for b in np.unique(al.block[ok]):
        if path.kind[b] != ARC or abs(path.normal[b][2]) < 0.99:
            continue
        sel = ok & (al.block == b)
        if np.count_nonzero(sel) < 8:
            continue
        centre, radius = path.center_mm[b], float(path.radius_mm[b])
        ang, dev = radial_deviation_um(q[sel][:, :2], centre[:2], radius)
        in_model = mt.block == b
        ang_m, dev_m = radial_deviation_um(mt.pos_mm[in_model][:, :2], centre[:2], radius)
        n_bins = int(round(360.0 / SECTOR_DEG))
        c, mean, vmax, vmin, count = deviation_profile(ang, dev, n_bins)
        _, mean_m, _, _, _ = deviation_profile(ang_m, dev_m, n_bins)
        # feed and time errors per sector (time: samples in motion only)
        _, feed_s, _, _, _ = deviation_profile(ang, feed_err[sel], n_bins)
        mov = moving[sel]
        if np.any(mov):
            _, time_s, _, _, _ = deviation_profile(ang[mov], s_to_ms(al.time_error_s[sel][mov]), n_bins)
        else:
            time_s = np.full(n_bins, np.nan)
        row = {"block": int(b), "line": int(path.line[b]), "radius_mm": radius,
               "sweep_deg": float(np.degrees(path.sweep_rad[b])),
               "sectors": [{"angle_deg": float(np.degrees(ci)), "n": int(ni),
                            "measured_dev_um": _num(mi), "model_dev_um": _num(mm),
                            "gap_um": _num(mi - mm) if np.isfinite(mi) and np.isfinite(mm) else None,
                            "feed_error_mm_s": _num(fi), "time_error_ms": _num(ti)}
                           for ci, mi, mm, ni, fi, ti in zip(c, mean, mean_m, count, feed_s, time_s)
                           if ni > 0]}
        if path.sweep_rad[b] >= 2 * np.pi - 1e-6 and np.count_nonzero(sel) >= 16:
            meas = circular_deviation(q[sel][:, :2], centre[:2], radius)
            model = circular_deviation(mt.pos_mm[in_model][:, :2], centre[:2], radius)
            row["iso230"] = {"measured": _iso(meas), "model": _iso(model)}
        arcs.append(row)
    return {"blocks": ranked, "n_blocks": len(blocks), "phases": phases, "arcs": arcs}


def _num(v):
    return float(v) if v is not None and np.isfinite(v) else None


def _iso(ci) -> dict:
    return {"G_um": ci.G_um, "Fmax_um": ci.Fmax_um, "Fmin_um": ci.Fmin_um}


# ---------------------------------------------------------------------------------------------
# Diagnosis
# ---------------------------------------------------------------------------------------------

class RankedFits:
    """Shared by the diagnoses of a trace and of published values: the best fit, and the
    corrected model (the combined one when there is one) with its machine file."""

    fits: list
    combined: "EffectFit | None"

    @property
    def best(self) -> EffectFit:
        return self.fits[0]

    @property
    def corrected_model(self) -> Model:
        return self.combined.model if self.combined is not None else self.best.model

    def corrected_machine(self) -> MachineSpec:
        return corrected_machine(self.corrected_model)


@dataclass
class Diagnosis(RankedFits):
    """Ranked attribution of a measured gap (see :func:`diagnose`)."""

    base: str
    base_model: Model
    gap_before: GapMetrics
    fits: list[EffectFit]                # ranked, best first
    combined: EffectFit | None
    localisation_before: dict
    localisation_after: dict | None
    scales: GapScales
    alignment: dict
    seconds: float
    source: str = ""
    program: str = ""
    notes: tuple[str, ...] = ()

    def as_dict(self) -> dict:
        return {"kind": "trace", "source": self.source, "program": self.program,
                "base": self.base, "base_model": model_description(self.base_model),
                "gap_before": self.gap_before.as_dict(),
                "scales": {"feed_mm_s": self.scales.feed_mm_s, "time_ms": s_to_ms(self.scales.time_s),
                           "contour_um": mm_to_um(self.scales.contour_mm),
                           "noise_um": mm_to_um(self.scales.noise_mm)},
                "alignment": self.alignment,
                "effects": [f.as_dict() for f in self.fits],
                "combined": self.combined.as_dict() if self.combined is not None else None,
                "localisation": {"base": self.localisation_before,
                                 "corrected": self.localisation_after},
                "notes": list(self.notes), "seconds": self.seconds}


def default_candidates(command: bool = False) -> tuple[str, ...]:
    return PLANNER_EFFECTS + TRACE_EFFECTS + (("servo_delay",) if command else ())


#: ranking: a fit must beat a simpler one by this share of its gap per extra free parameter
#: (a fit with more parameters finds a slightly lower gap even where it is the same model)
PARSIMONY_SHARE = 0.01
#: fits whose gaps are within this share of the best one's are reported as indistinguishable
TIE_SHARE = 0.01


def rank_fits(fits: Sequence[EffectFit]) -> list[EffectFit]:
    """Best first by the gap after the fit; between fits that leave (nearly) the same gap the
    one with fewer free parameters first: each free parameter costs ``PARSIMONY_SHARE`` of the
    gap (a BRISK acceleration and an axis acceleration on a BRISK program are the same
    model, and the simpler name is the better answer)."""
    def key(f):
        n = len(get_effect(f.effect).params) if f.effect in EFFECTS else 1
        return f.gap_after.gap * (1.0 + PARSIMONY_SHARE * n)
    return sorted(fits, key=key)


def share_values(evaluator, fits: Sequence[EffectFit], base: Model) -> list[EffectFit]:
    """Effects that share parameters (``corner_jump_mm_s`` is also ``reset_mode``'s) are nested
    models: each fit is tried once more at the values another fit found for all of its
    parameters, and keeps them where they fit better (one search may stop a little off an
    optimum another reached), so that the simpler of two equal models is not ranked below by
    chance of the search."""
    out = []
    for f in fits:
        names = {p.name for p in get_effect(f.effect).params}
        best = f
        for g in fits:
            if g is f or not names <= set(g.params):
                continue
            values = {n: g.params[n] for n in names}
            model = get_effect(f.effect).apply(base, values)
            after = evaluator.evaluate(model)
            if after.gap < best.gap_after.gap:
                best = replace(f, params=get_effect(f.effect).check(values), model=model,
                               gap_after=after, n_evals=f.n_evals + 1)
        out.append(best)
    return out


def indistinguishable(fits: Sequence[EffectFit]) -> list[str]:
    """The effects (after the best) that leave a gap within ``TIE_SHARE`` of the best's."""
    if not fits or fits[0].shrink_percent <= 0:
        return []
    best = fits[0].gap_after.gap
    return [f.effect for f in fits[1:] if f.gap_after.gap <= best * (1.0 + TIE_SHARE)]


def combine(evaluator, fits: Sequence[EffectFit], gap_before,
            max_effects: int = 4, max_tries: int = 4) -> EffectFit | None:
    """Greedy combined model: start from the first fit (the best single effect); try the next
    ones that shrank the gap on their own (at most ``max_tries``), each re-fitted on top of the
    current model with the earlier effects held, and keep those that shrink the current gap by
    at least ``COMBINE_MIN_GAIN`` of its value. ``fits`` gives the order of the trials."""
    if not fits or fits[0].shrink_percent <= 0:
        return None
    t0 = time.perf_counter()
    n0 = evaluator.n_evals
    current = fits[0]
    chosen = [fits[0].effect]
    params = {fits[0].effect: fits[0].params}
    tried = 0
    for f in fits[1:]:
        if len(chosen) >= max_effects or tried >= max_tries or f.shrink_percent <= 0.5:
            continue
        tried += 1
        trial = fit_effect(evaluator, current.model, f.effect, gap_before=current.gap_after)
        if trial.gap_after.gap < current.gap_after.gap * (1.0 - COMBINE_MIN_GAIN):
            current = trial
            chosen.append(f.effect)
            params[f.effect] = trial.params
    return _combined(chosen, params, current, gap_before, evaluator.n_evals - n0,
                     time.perf_counter() - t0)


def _combined(chosen, params, fit: EffectFit, gap_before, n_evals: int,
              seconds: float) -> EffectFit | None:
    """The fit of the model ``fit`` as one that combines the effects ``chosen`` (whose
    parameters are ``params[effect]``); None for a single effect (no combination)."""
    if len(chosen) == 1:
        return None
    return EffectFit(effect="+".join(chosen), params={k: v for e in chosen for k, v in params[e].items()},
                     model=fit.model, gap_before=gap_before, gap_after=fit.gap_after,
                     added=True, n_evals=n_evals, seconds=seconds, effects=tuple(chosen))


def forward_select(evaluator, fits: Sequence[EffectFit], gap_before, base: Model, *,
                   max_effects: int = 4, n_full: int = 2, width: int = 1,
                   n_partners: int = 1, max_structures: int = 2) -> EffectFit | None:
    """Combined model by forward selection with a small beam: start from the best single fit;
    at each step, for each model kept so far, screen every candidate it lacks on top of it
    with a coarse fit (grids only, :func:`~ncsim.gap.fit.fit_values`), fit the ``n_full`` best
    and every choice of a discrete parameter fully, re-fit the effects already in
    (:func:`_backfit`), and keep the children that shrink their parent's gap by at least
    ``COMBINE_MIN_GAIN``. A discrete choice that does not pay off alone is tried once more
    together with the ``n_partners`` best other candidates: continuous path against exact
    stop only shows once the ramps that shape the corners are fitted too. The ``width`` best
    children go on, and with them the best child of each of the ``max_structures`` best other
    structural hypotheses (the discrete choices it makes, e.g. G60 or G64), so that a first
    choice that fits a little better does not lock the others out. Candidates whose
    parameters changed nothing at all in their single fit are left out (they do not act on
    this trace: a compressor on a program without short blocks, every choice the same).
    The best model seen is returned, without effects that no longer matter in it
    (:func:`_prune`, against the ``base`` model)."""
    if not fits or fits[0].shrink_percent <= 0:
        return None
    t0 = time.perf_counter()
    n0 = evaluator.n_evals
    names = [f.effect for f in fits if f.sensitive]
    # a node: (fit of its model, the effects in it, their parameters)
    beam = [(fits[0], (fits[0].effect,), {fits[0].effect: fits[0].params})]
    best = beam[0]
    for _ in range(max_effects - 1):
        children: dict = {}

        def keep(node, parent_gap):
            fit, chosen, params = node
            if fit.gap_after.gap >= parent_gap * (1.0 - COMBINE_MIN_GAIN):
                return
            key = frozenset(_labels(chosen, params))
            if key not in children or fit.gap_after.gap < children[key][0].gap_after.gap:
                children[key] = node

        for node in beam:
            current, chosen, params = node
            if len(chosen) >= max_effects:
                continue
            variants = [(n, v) for n in names if n not in chosen for v in choice_variants(n)]
            screen = sorted(((fit_effect(evaluator, current.model, n, gap_before=current.gap_after,
                                         coarse=True, fixed=v), v) for n, v in variants),
                            key=lambda fv: fv[0].gap_after.gap)
            plain = [f.effect for f, v in screen if not v][:n_partners]
            for f, v in screen[:n_full] + [fv for fv in screen[n_full:] if fv[1]]:
                if v and (f, v) not in screen[:n_full] and f.gap_after.gap >= current.gap_after.gap:
                    # a choice whose screen does not shrink the gap at all: its fit alone
                    # would not pay either; it goes on to its partners as screened
                    child = (f, chosen + (f.effect,), {**params, f.effect: f.params})
                else:
                    child = _extend(evaluator, node, f.effect, v)
                    keep(child, current.gap_after.gap)
                if v and child[0].gap_after.gap >= current.gap_after.gap * (1.0 - COMBINE_MIN_GAIN) \
                        and len(chosen) + 2 <= max_effects:
                    for partner in plain:
                        if partner != f.effect:
                            keep(_extend(evaluator, child, partner, {}), current.gap_after.gap)
        if not children:
            break
        ranked = sorted(children.values(), key=lambda n: n[0].gap_after.gap)
        beam = ranked[:width]
        seen = {_structure(n[1], n[2]) for n in beam}
        for n in ranked[width:]:
            sig = _structure(n[1], n[2])
            if sig not in seen and len(beam) < width + max_structures:
                seen.add(sig)
                beam.append(n)
        # only the children that go on are re-fitted as a whole (the costly part)
        beam = sorted((_backfit_node(evaluator, n) for n in beam), key=lambda n: n[0].gap_after.gap)
        if beam[0][0].gap_after.gap < best[0].gap_after.gap:
            best = beam[0]
    fit, chosen, params = _prune(evaluator, best, base)
    return _combined(chosen, params, fit, gap_before, evaluator.n_evals - n0, time.perf_counter() - t0)


def _prune(evaluator, node, base: Model):
    """Drop the effects of a combined model that no longer matter in it: back-fitting can
    leave one at its base value, or make it redundant. An effect goes when the model without
    it (its parameters back at their values in ``base``, or a trace effect removed) is within
    ``COMBINE_MIN_GAIN`` of the model's gap."""
    fit, chosen, params = node
    for name in list(chosen):
        if len(chosen) == 1:
            break
        without = get_effect(name).without(fit.model, base)
        g = evaluator.evaluate(without)
        if g.gap <= fit.gap_after.gap * (1.0 + COMBINE_MIN_GAIN):
            fit = replace(fit, model=without, gap_after=g)
            chosen = tuple(c for c in chosen if c != name)
            params = {k: v for k, v in params.items() if k != name}
    return fit, chosen, params


def _extend(evaluator, node, effect: str, fixed: Mapping):
    """The node with ``effect`` added (its discrete choices ``fixed``), fitted, and the
    effects already in re-fitted."""
    current, chosen, params = node
    # one coordinate sweep: the children that go on are back-fitted (_backfit_node)
    trial = fit_effect(evaluator, current.model, effect, gap_before=current.gap_after, fixed=fixed,
                       polish=False, sweeps=1)
    return trial, chosen + (effect,), {**params, effect: trial.params}


def _backfit_node(evaluator, node):
    """A node with its effects re-fitted one at a time on top of the others
    (:func:`_backfit`): first those already in, then the last one added, whose fit in
    :func:`_extend` was a single coordinate sweep."""
    fit, chosen, params = node
    fit, params = _backfit(evaluator, fit, chosen, params, fit.gap_before)
    return fit, chosen, params


def _backfit(evaluator, trial: EffectFit, chosen, params, gap_before):
    """Re-fit the effects already in the model, one at a time with the others held, once the
    new one (``trial``) is in: an earlier fit made without it may sit at a bound (a corner
    jump fitted before the acceleration that shapes the corner ramps). Discrete choices are
    kept (they are the node's hypothesis). Returns the improved fit and every effect's
    parameters."""
    params = {**params, trial.effect: trial.params}
    current = trial
    gap_before = trial.gap_before if gap_before is None else gap_before
    for name in chosen:
        fixed = {p.name: params[name][p.name] for p in get_effect(name).params if p.kind == "choice"}
        refit = fit_effect(evaluator, current.model, name, gap_before=gap_before, fixed=fixed,
                           polish=False, sweeps=1)
        if refit.gap_after.gap < current.gap_after.gap:
            current = refit
            params[name] = refit.params
    if current is not trial:
        current = replace(trial, model=current.model, gap_after=current.gap_after,
                          n_evals=trial.n_evals + current.n_evals)
    return current, params


def _label(effect: str, params: Mapping) -> str:
    """An effect with the values of its discrete parameters: ``reset_mode[G64]``."""
    choices = [str(params[p.name]) for p in get_effect(effect).params if p.kind == "choice"]
    return effect + (f"[{','.join(choices)}]" if choices else "")


def _labels(chosen, params) -> set:
    return {_label(e, params[e]) for e in chosen}


def _structure(chosen, params) -> frozenset:
    """The discrete choices a model makes (its structural hypothesis)."""
    return frozenset(label for label in _labels(chosen, params) if label.endswith("]"))


def diagnose(path: Path, machine: MachineSpec, measured: MeasuredTrace, *, base: str = "full",
             candidates: Sequence[str] | None = None, do_combine: bool = True,
             localisation: bool = True, align_options: Mapping | None = None,
             program: str = "", registration: Registration | None = None,
             progress: Callable[[str], None] | None = None, reinterpret=None,
             recorder_window_ms: float | None = None) -> Diagnosis:
    """Diagnose the gap between ``measured`` and the ``base`` model of ``path`` on ``machine``
    (module docstring). ``candidates`` defaults to every planner effect and the servo,
    structure and recorder effects. ``registration`` places the samples on the path
    (``ncsim.gap.register``; registered here when not given); ``progress`` is called with the
    name of each fit as it begins. ``reinterpret(machine) -> Path`` interprets the program
    again on another machine (``path`` is the program interpreted on ``machine``); without it
    the effects that change the interpretation (``reset_mode``, ``compressor``) are left out of
    the defaults.
    ``recorder_window_ms``: the recorder's moving average when it is known (e.g. 20 ms for 10
    samples at 500 Hz, ``effects.RECORDER_RAW_PERIOD_S``): the base model is compared after
    it, and ``recorder`` re-fits it."""
    t0 = time.perf_counter()
    base_model = make_base(machine, base)
    notes = []
    if recorder_window_ms is not None:
        base_model = get_effect("recorder").apply(
            base_model, {"samples": round(recorder_window_ms / s_to_ms(RECORDER_RAW_PERIOD_S))})
        notes.append(f"models compared after the recorder's {recorder_window_ms:g} ms mean "
                     "(the recording's known filter)")
    ev = Evaluator(path, measured, align_options=align_options, registration=registration,
                   reinterpret=reinterpret, path_key=interpretation_key(machine))
    before, al, mt = ev.evaluate(base_model, full=True)
    if candidates is not None:
        cands = tuple(candidates)
    else:
        cands = default_candidates()
        if reinterpret is None:
            cands = tuple(c for c in cands if c not in REINTERPRETING)
            notes.append(f"{', '.join(REINTERPRETING)} not tried: they need the program to "
                         "interpret it again")
    for c in cands:
        get_effect(c)
    fits = []
    for c in cands:
        if progress is not None:
            progress(f"fit {c}")
        fits.append(fit_effect(ev, base_model, c, gap_before=before))
    fits = rank_fits(share_values(ev, fits, base_model))
    if do_combine and progress is not None:
        progress("combine")
    comb = forward_select(ev, fits, before, base_model) if do_combine else None
    ties = indistinguishable(fits)
    if ties:
        notes.append(f"{fits[0].effect}: on this trace as good as " + ", ".join(ties)
                     + f" (gaps within {100 * TIE_SHARE:g} %)")
    loc_before = localise(al, mt, path, ev.scales, measured) if localisation else {}
    loc_after = None
    if localisation:
        final = comb.model if comb is not None else fits[0].model
        _, al2, mt2 = ev.evaluate(final, full=True)
        loc_after = localise(al2, mt2, path, ev.scales, measured)
    if not measured.has_command and "servo_lag" in cands:
        notes.append("servo_lag: without commanded positions only Kv/sqrt(1 - k_ff^2) is "
                     "identifiable; k_ff held at 0 (Kv is the FFWOF-equivalent gain)")
    return Diagnosis(base=base, base_model=base_model, gap_before=before, fits=fits,
                     combined=comb, localisation_before=loc_before,
                     localisation_after=loc_after, scales=ev.scales,
                     alignment={"time_shift_s": al.time_shift_s,
                                "offset_mm": [float(v) for v in al.offset_mm],
                                "shift_method": al.shift_method,
                                "offset_method": ev.registration.offset_source,
                                "covered": ev.registration.covered(),
                                "residual_rms_um": mm_to_um(ev.registration.residual_rms_mm),
                                "residual_max_um": mm_to_um(ev.registration.residual_max_mm)},
                     seconds=time.perf_counter() - t0, source=measured.source, program=program,
                     notes=tuple(notes))
