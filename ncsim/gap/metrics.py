"""Gap metrics: how far a measured trace is from a model trace, once aligned.

The definitions (``ncsim.gap.diagnose`` module docstring, step 3): the RMS feed error at the
same place, the time error at the same place counted from its median, the duration error of
the compared motion (:func:`motion_span_s`), the contour error, and the combined gap
``gap^2 = mean(feed_err^2) / s_v^2 + mean(time_err^2) / s_t^2 + mean(dist^2) / s_d^2`` with
the resolution scales of :func:`gap_scales`. A model trace is anything with ``t_s``,
``pos_mm``, ``s_mm``, ``feed_mm_s`` and ``compare_speed_mm_s`` (``diagnose.ModelTrace``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Mapping

import numpy as np

from ncsim.gap.align import Alignment, estimate_noise_mm, motion_onset_s
from ncsim.gap.measured import MeasuredTrace, derived_speed_mm_s
from ncsim.units import mm_to_um, s_to_ms, um_to_mm

SPEED_WINDOW_S = 0.02        # central-difference window of derived speeds
TIME_SCALE_S = 2e-3          # s_t
MIN_CONTOUR_SCALE_UM = 1.0   # lower bound of s_d
FEED_SCALE_SHARE = 0.002     # s_v includes 0.2 % of the top measured feed
MOVING_SHARE = 0.02          # "moving": feed above 2 % of the top feed ...
SLOWEST_FEED_SHARE = 0.5     # ... and never above half the slowest programmed feed compared


@dataclass(frozen=True)
class GapScales:
    """Resolution scales of the combined gap (module docstring, step 3)."""

    feed_mm_s: float
    time_s: float
    contour_mm: float
    noise_mm: float
    speed_window_s: float
    moving_cap_mm_s: float = math.inf   # the "moving" threshold never exceeds this

    def moving_mm_s(self, top_mm_s: float) -> float:
        """Speed above which a sample counts as moving: ``MOVING_SHARE`` of the top speed, but
        at most ``moving_cap_mm_s`` (half the slowest programmed feed compared), so that
        cutting at F350 is not taken for rest next to rapids at 30 m/min."""
        return min(MOVING_SHARE * top_mm_s, self.moving_cap_mm_s)


def gap_scales(measured: MeasuredTrace, speed_window_s: float = SPEED_WINDOW_S,
               moving_cap_mm_s: float = math.inf) -> GapScales:
    """Scales from the measured trace alone (so every model is judged on the same scale):
    position noise from the standstill scatter (``align.estimate_noise_mm``); a central
    difference over ``W`` turns it into a speed noise of ``sqrt(2) noise / W``."""
    period = measured.period_s if len(measured) > 1 else 1e-3
    k = max(1, int(round(0.5 * speed_window_s / period)))
    width = 2 * k * period
    speed = measured.speed_mm_s(width)
    top = float(np.max(speed)) if len(speed) else 0.0
    noise = estimate_noise_mm(measured.pos_mm, speed,
                              max(min(MOVING_SHARE * top, moving_cap_mm_s), 1e-6))
    speed_noise = math.sqrt(2.0) * noise / width
    return GapScales(feed_mm_s=max(2.0 * speed_noise + FEED_SCALE_SHARE * top, 1e-3),
                     time_s=TIME_SCALE_S,
                     contour_mm=max(2.0 * noise, um_to_mm(MIN_CONTOUR_SCALE_UM)),
                     noise_mm=noise, speed_window_s=width, moving_cap_mm_s=moving_cap_mm_s)


@dataclass(frozen=True)
class GapMetrics:
    """The gap between a measured trace and a model (module docstring, step 3)."""

    gap: float
    feed_rms_mm_s: float
    time_rms_ms: float
    cycle_time_error_s: float
    contour_rms_um: float
    contour_max_um: float
    n_samples: int
    parts: Mapping[str, float] = field(default_factory=dict)  # normalised squared contributions
    n_unmatched: int = 0         # measured samples in motion outside the model's span

    def metric_values(self) -> dict:
        return {k: getattr(self, k) for k in METRIC_NAMES}

    def as_dict(self) -> dict:
        return {"gap": self.gap, "feed_rms_mm_s": self.feed_rms_mm_s,
                "time_rms_ms": self.time_rms_ms, "cycle_time_error_s": self.cycle_time_error_s,
                "contour_rms_um": self.contour_rms_um, "contour_max_um": self.contour_max_um,
                "n_samples": self.n_samples, "n_unmatched": self.n_unmatched,
                "parts": dict(self.parts)}


METRIC_NAMES = ("gap", "feed_rms_mm_s", "time_rms_ms", "cycle_time_error_s", "contour_rms_um")


def rms(x) -> float:
    x = np.asarray(x, dtype=np.float64)
    return float(np.sqrt(np.mean(x * x))) if x.size else 0.0


def _end_of_motion_s(t_s, speed, threshold) -> float:
    moving = np.nonzero(np.asarray(speed) > threshold)[0]
    return float(t_s[moving[-1]]) if len(moving) else float(t_s[-1])


def compare_speed_mm_s(mt, scales: GapScales) -> np.ndarray:
    """The model speed compared with the measured one: through the same operator (a central
    difference over the speed window) unless the model trace already carries it."""
    if mt.compare_speed_mm_s is not None:
        return mt.compare_speed_mm_s
    return derived_speed_mm_s(mt.t_s, mt.pos_mm, scales.speed_window_s)


def motion_span_s(al: Alignment, mt, model_speed: np.ndarray,
                  thr: float) -> tuple[float, float, float, float]:
    """``(measured start, measured end, model start, model end)`` of the motion compared, on the
    model clock. A whole recording: from the motion onset (crossing ``thr``) to the last moving
    sample, in both. A registered recording (``al.covered_s_mm``) that starts or ends in motion
    is compared from its first to its last sample with the model between the places of those
    samples; one that starts or ends at rest, from the onset (end) of its motion with the
    model's motion onset (end) within the places it covers."""
    moving_model = model_speed > thr
    t_model_start = float(mt.t_s[np.argmax(moving_model)]) if np.any(moving_model) else 0.0
    t_model_end = _end_of_motion_s(mt.t_s, model_speed, thr)
    onset = motion_onset_s(al.t_s, al.feed_mm_s, thr)
    t_meas_start = onset if onset is not None else float(al.t_s[0])
    t_meas_end = _end_of_motion_s(al.t_s, al.feed_mm_s, thr)
    if al.covered_s_mm is None:   # the clock alignment matched the starts: ends only
        return t_model_start, t_meas_end, t_model_start, t_model_end
    s_a, s_b = al.covered_s_mm
    tol = 1e-6 + 1e-9 * max(abs(s_b), 1.0)
    if al.feed_mm_s[0] > thr:
        t_model_start = float(al.t_sim_s[0])
    else:
        sel = np.nonzero(moving_model & (mt.s_mm >= s_a - tol))[0]
        if len(sel):
            k = int(sel[0])
            t_model_start = (motion_onset_s(mt.t_s[max(k - 1, 0):], model_speed[max(k - 1, 0):], thr)
                             or float(mt.t_s[k]))
    if al.feed_mm_s[-1] > thr:
        t_meas_end, t_model_end = float(al.t_s[-1]), float(al.t_sim_s[-1])
    else:
        sel = np.nonzero(moving_model & (mt.s_mm <= s_b + tol))[0]
        if len(sel):
            t_model_end = float(mt.t_s[sel[-1]])
    return t_meas_start, t_meas_end, t_model_start, t_model_end


def centred_mask(t_s: np.ndarray, window_s: float) -> np.ndarray:
    """Samples whose derived speed is a centred difference over ``window_s``: all but the
    ``k = round(window / 2 period)`` (at least 1) first and last samples of every contiguous
    piece of the recording (breaks at gaps over 3 periods), where ``derived_speed_mm_s``
    differences one-sidedly. A one-sided difference is late or early by half its span (its
    error is ``a k h``, 13 mm/s in a 2 m/s^2 ramp at 6 ms), the model's centred one is not:
    such samples are not compared for feed."""
    t = np.asarray(t_s, dtype=np.float64)
    m = len(t)
    if m < 3:
        return np.ones(m, dtype=bool)
    h = float(np.median(np.diff(t)))
    k = max(1, int(round(0.5 * window_s / h)))
    piece = np.concatenate([[0], np.cumsum(np.diff(t) > 3.0 * h)])
    idx = np.arange(m)
    first = np.zeros(piece[-1] + 1, dtype=np.int64)
    last = np.zeros(piece[-1] + 1, dtype=np.int64)
    first[piece[::-1]] = idx[::-1]
    last[piece] = idx
    return (idx - first[piece] >= k) & (last[piece] - idx >= k)


@dataclass(frozen=True)
class ComparedSamples:
    """Which samples of an alignment a gap compares, and with what (:func:`compared_samples`).

    ``model_speed`` (on the model's grid) is the model speed through the measured speed's
    operator and ``v_model`` that at the measured samples; ``moving``: placed on the model path
    and in motion in either (their feed and time errors count); ``unmatched``: in motion but
    not placed (the model ended or started too early, or the alignment failed); ``outside_s``:
    each sample's time outside the model's motion; ``span_s``: :func:`motion_span_s`."""

    model_speed: np.ndarray
    v_model: np.ndarray
    moving: np.ndarray
    unmatched: np.ndarray
    outside_s: np.ndarray
    span_s: tuple[float, float, float, float]


def compared_samples(al: Alignment, mt, scales: GapScales) -> ComparedSamples:
    """The samples :func:`gap_metrics` compares (``ComparedSamples``); the gap's figure draws
    the same ones (``gap.plot.trace_series``)."""
    top = max(float(np.max(mt.feed_mm_s)), float(np.max(al.feed_mm_s)), 1e-9)
    thr = scales.moving_mm_s(top)
    model_speed = compare_speed_mm_s(mt, scales)
    v_model = np.interp(al.t_sim_s, mt.t_s, model_speed)
    moving = al.valid & ((al.feed_mm_s > thr) | (v_model > thr))
    # a sample in motion outside the model's span: the model stands still there, so its feed
    # error is the measured speed and its time error at least the time outside the model's motion
    span = motion_span_s(al, mt, model_speed, thr)
    unmatched = ~al.valid & (al.feed_mm_s > thr)
    outside = np.maximum(np.maximum(span[2] - al.t_s, al.t_s - span[3]), 0.0)
    return ComparedSamples(model_speed, v_model, moving, unmatched, outside, span)


def gap_metrics(al: Alignment, mt, scales: GapScales) -> GapMetrics:
    """Gap metrics of an alignment of a measured trace to a model trace."""
    valid = al.valid
    c = compared_samples(al, mt, scales)
    moving, unmatched, outside, v_model = c.moving, c.unmatched, c.outside_s, c.v_model
    t_meas_start, t_meas_end, t_model_start, t_model_end = c.span_s
    centred = centred_mask(al.t_s, scales.speed_window_s)
    feed_err = np.concatenate([(al.feed_mm_s - v_model)[moving & centred], al.feed_mm_s[unmatched]])
    # the clock offset is the alignment's own freedom (any constant is a different time
    # shift): the time error counts from its median, so only its growth along the path is gap
    te = al.time_error_s[moving]
    te = te - np.median(te) if te.size else te
    time_err = np.concatenate([te, outside[unmatched]])
    dist = al.distance_mm[valid]
    # duration of the compared motion: measured minus model (on the covered places)
    cycle_error = (t_meas_end - t_meas_start) - (t_model_end - t_model_start)
    parts = {"feed": (rms(feed_err) / scales.feed_mm_s) ** 2,
             "time": (rms(time_err) / scales.time_s) ** 2,
             "contour": (rms(dist) / scales.contour_mm) ** 2}
    return GapMetrics(gap=math.sqrt(sum(parts.values())), feed_rms_mm_s=rms(feed_err),
                      time_rms_ms=s_to_ms(rms(time_err)),
                      cycle_time_error_s=cycle_error,
                      contour_rms_um=mm_to_um(rms(dist)),
                      contour_max_um=mm_to_um(float(np.max(dist))) if dist.size else 0.0,
                      n_samples=int(np.count_nonzero(valid)), parts=parts,
                      n_unmatched=int(np.count_nonzero(unmatched)))


def shrink_percent(before: float, after: float) -> float:
    """How much of a gap closed: ``100 (1 - |after| / |before|)`` (negative: it grew)."""
    b, a = abs(before), abs(after)
    if b <= 0:
        return 0.0
    return 100.0 * (1.0 - a / b)
