"""Aligning a measured trace to a simulated one: clock, zero, and place along the path.

A measured trace (oscilloscope, or the benchmark's synthetic "truth") differs from the
simulation by things that are not machine behaviour: the recording starts at another instant
(a time shift), the positions have another zero (a start-position offset), samples are missing.
:func:`align` removes those, then maps every measured sample to the place on the simulated path
it corresponds to (its path length ``s``), and from there to the simulated block and phase.
Everything it reports is a function of the place, not of the clock, so a feed-law gap shows up
as a time error that grows along the path instead of being hidden in a misalignment.

Steps (all on plain arrays, so it does not need the planner; a ``Trace`` provides them):

1. **Time shift** ``tau`` (measured clock = simulated clock + tau). ``"onset"``: when both start
   at rest, the instants the speed first exceeds a threshold are matched; ``"xcorr"``: the
   speed profiles (zero outside the recordings, i.e. at rest) are cross-correlated on a common
   grid (FFT), with a parabolic sub-sample peak. Either is refined by least squares on the
   positions (bounded 1-D search) near the estimate.
2. **Start-position offset** ``o`` (measured = simulated + o): the median of the measured rest
   positions before the motion minus the simulated start (``"start"``), or, when the recording
   does not start at rest, the least-squares offset of the time-aligned positions (``"lsq"``).
3. **Path parameter**: each sample is projected on the simulated path (the polyline of the
   simulated positions), within a window of path length that starts where the previous sample
   was matched and extends by what the fastest feed can cover in the time step (monotone by
   construction; re-initialised from the time-aligned estimate at recording breaks).
   Samples before the simulated start or after its end map to its ends.
4. **Labels**: block and phase of the simulated sample at that place; phase TRANSITION when the
   place is within ``transition_half_width_s`` (simulated time) of a flying block change.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from enum import IntEnum

import numpy as np
from scipy.ndimage import maximum_filter1d
from scipy.optimize import minimize_scalar
from scipy.signal import correlate, correlation_lags

from ncsim.errors import UsageError
from ncsim.gap.measured import MeasuredTrace, derived_speed_mm_s
from ncsim.jit import njit

#: the matching window of a sample follows the largest measured speed this many samples
#: either side of it (``align``, step 3)
LOCAL_SPEED_SAMPLES = 2


class AlignPhase(IntEnum):
    """Phase label of an aligned sample: the values of ``motion.Phase`` plus TRANSITION."""

    A = 0           # acceleration (jerk-limited ramp up)
    B = 1           # steady feed
    C = 2           # deceleration
    STOP = 3        # standing still
    TRANSITION = 4  # crossing a block junction in flight (paper §5.3.2)


@dataclass(frozen=True, eq=False)
class Alignment:
    """Measured samples mapped onto the simulation (all arrays have one row per sample)."""

    time_shift_s: float          # tau: measured time = simulated time + tau
    offset_mm: np.ndarray        # (3,) o: measured position = simulated position + o
    shift_method: str            # "onset", "xcorr" or "given"
    offset_method: str           # "start", "lsq" or "given"
    t_s: np.ndarray              # (m,) measured time on the simulated clock (t - tau)
    s_mm: np.ndarray             # (m,) path length of the matched place (non-decreasing)
    sim_index: np.ndarray        # (m,) simulated sample j with the place in [j, j+1]
    sim_frac: np.ndarray         # (m,) position of the place between samples j and j+1
    block: np.ndarray            # (m,) int block of the place (-1 without block labels)
    phase: np.ndarray            # (m,) int AlignPhase (-1 without phase labels)
    t_sim_s: np.ndarray          # (m,) simulated time at the place
    time_error_s: np.ndarray     # (m,) t_s - t_sim_s: > 0 the machine is late there
    feed_mm_s: np.ndarray        # (m,) measured path speed
    sim_feed_mm_s: np.ndarray    # (m,) simulated feed at the place
    deviation_mm: np.ndarray     # (m, 3) measured (offset removed) minus the matched place
    valid: np.ndarray            # (m,) inside the simulated span and within max distance
    residual_rms_mm: float       # RMS position residual after shift and offset (time-aligned)
    covered_s_mm: tuple | None = None  # (first, last) place of a registered recording

    @property
    def feed_error_mm_s(self) -> np.ndarray:
        return self.feed_mm_s - self.sim_feed_mm_s

    @property
    def distance_mm(self) -> np.ndarray:
        """Distance from each measured sample to the simulated path (contour error)."""
        return np.linalg.norm(self.deviation_mm, axis=1)

    def block_summary(self, moving_mm_s: float | None = None) -> dict[str, np.ndarray]:
        """Per block seen: sample count, mean feed error, time error on entry and exit (their
        difference is the block's duration error), max contour distance. Valid samples only;
        entry and exit are the first and last samples where the simulated feed exceeds
        ``moving_mm_s`` (default 2 % of the top simulated feed): at rest the place does not
        tell the time."""
        ok = self.valid & (self.block >= 0)
        thr = (0.02 * float(np.max(self.sim_feed_mm_s)) if moving_mm_s is None else moving_mm_s)
        moving = self.sim_feed_mm_s > thr
        blocks = np.unique(self.block[ok])
        out = {k: np.full(len(blocks), np.nan) for k in
               ("feed_error_mm_s", "time_error_in_s", "time_error_out_s", "duration_error_s",
                "max_distance_mm")}
        out["block"] = blocks
        out["n"] = np.zeros(len(blocks), dtype=np.int64)
        for i, b in enumerate(blocks):
            sel = np.nonzero(ok & (self.block == b))[0]
            out["n"][i] = len(sel)
            out["feed_error_mm_s"][i] = float(np.mean(self.feed_error_mm_s[sel]))
            mov = sel[moving[sel]]
            if len(mov):
                out["time_error_in_s"][i] = float(self.time_error_s[mov[0]])
                out["time_error_out_s"][i] = float(self.time_error_s[mov[-1]])
            out["max_distance_mm"][i] = float(self.distance_mm[sel].max())
        out["duration_error_s"] = out["time_error_out_s"] - out["time_error_in_s"]
        return out


# ---------------------------------------------------------------------------------------------
# Pure pieces
# ---------------------------------------------------------------------------------------------

def motion_onset_s(t_s, speed_mm_s, threshold_mm_s) -> float | None:
    """First time the speed exceeds ``threshold_mm_s``, linearly interpolated between samples;
    None if it never does or if the first sample is already above it (not at rest)."""
    v = np.asarray(speed_mm_s, dtype=np.float64)
    above = np.nonzero(v > threshold_mm_s)[0]
    if len(above) == 0 or above[0] == 0:
        return None
    i = int(above[0])
    t = np.asarray(t_s, dtype=np.float64)
    f = (threshold_mm_s - v[i - 1]) / (v[i] - v[i - 1])
    return float(t[i - 1] + f * (t[i] - t[i - 1]))


def xcorr_shift_s(t_meas_s, speed_meas, t_sim_s, speed_sim, grid_s: float,
                  max_shift_s: float | None = None) -> float:
    """Time shift ``tau`` that best matches ``speed_meas(t)`` with ``speed_sim(t - tau)``.

    Both are resampled on grids of step ``grid_s``; the simulated speed is zero outside its
    span (the machine is at rest before and after the program); the measured one exists only
    where recorded. The least-squares mismatch over the recorded window,
    ``sum_i (m_i - s(t_i - tau))^2 = sum m^2 - 2 (m * s)(tau) + (w * s^2)(tau)``
    (``*`` cross-correlation, ``w`` the recorded window), is evaluated for all grid shifts at
    once by FFT; its minimum is refined by a parabola through the neighbouring shifts. A
    recording that starts or ends in the middle of the motion is thus placed where its
    plateaus and ramps fit, not where it overlaps most."""
    tm = np.arange(t_meas_s[0], t_meas_s[-1] + 0.5 * grid_s, grid_s)
    ts = np.arange(t_sim_s[0], t_sim_s[-1] + 0.5 * grid_s, grid_s)
    vm = np.interp(tm, t_meas_s, speed_meas)
    vs = np.interp(ts, t_sim_s, speed_sim)
    cost = (-2.0 * correlate(vm, vs, mode="full", method="fft")
            + correlate(np.ones_like(vm), vs * vs, mode="full", method="fft"))
    lags = correlation_lags(len(vm), len(vs), mode="full")
    tau = tm[0] - ts[0] + lags * grid_s
    if max_shift_s is not None:
        cost = np.where(np.abs(tau) <= max_shift_s + grid_s, cost, np.inf)
    k = int(np.argmin(cost))
    if 0 < k < len(cost) - 1 and np.all(np.isfinite(cost[k - 1:k + 2])):
        c0, c1, c2 = cost[k - 1], cost[k], cost[k + 1]
        den = c0 - 2 * c1 + c2
        frac = 0.5 * (c0 - c2) / den if den > 0 else 0.0
        return float(tau[k] + np.clip(frac, -0.5, 0.5) * grid_s)
    return float(tau[k])


def estimate_noise_mm(pos_mm, speed_mm_s, rest_threshold_mm_s) -> float:
    """Position noise (per-axis standard deviation, mm) of a trace: from the scatter of the
    samples at rest (speed below the threshold, at least 5 of them in one stretch) about their
    median, else from second differences ``p[i+1] - 2 p[i] + p[i-1]`` (noise x sqrt(6) plus
    ``a dt^2``, so an upper bound), robustly (median absolute value / 0.6745)."""
    p = np.asarray(pos_mm, dtype=np.float64)
    rest = np.asarray(speed_mm_s) <= rest_threshold_mm_s
    if np.count_nonzero(rest) >= 5:
        idx = np.nonzero(rest)[0]
        runs = np.split(idx, np.nonzero(np.diff(idx) > 1)[0] + 1)
        run = max(runs, key=len)
        if len(run) >= 5:
            r = p[run] - np.median(p[run], axis=0)
            return float(np.median(np.abs(r)) / 0.6745)
    if len(p) < 3:
        return 0.0
    d2 = p[2:] - 2 * p[1:-1] + p[:-2]
    return float(np.median(np.abs(d2)) / 0.6745 / math.sqrt(6.0))


def first_time_at_s(place_s_mm, sim_t_s, sim_s_mm) -> np.ndarray:
    """The first instant a simulation (times ``sim_t_s``, non-decreasing path lengths
    ``sim_s_mm``) reaches each path length of ``place_s_mm`` (linear between samples; a
    standstill's repeated lengths are skipped, so a place where it stops maps to its arrival)."""
    ss = np.asarray(sim_s_mm, dtype=np.float64)
    first = np.concatenate([[True], np.diff(ss) > 0])
    return np.interp(place_s_mm, ss[first], np.asarray(sim_t_s, dtype=np.float64)[first])


def place_time_shift_s(t_meas_s, speed_meas, place_s_mm, sim_t_s, sim_s_mm, sim_feed_mm_s,
                       threshold_mm_s) -> float:
    """Time shift of a recording whose samples have known places on the path: the median, over
    samples moving in both, of the measured time minus the simulated time at the place (the
    first instant the simulation reaches it). At rest a place does not tell the time; if no
    sample moves, the first sample is matched with the simulation's first visit of its place."""
    ts = np.asarray(sim_t_s, dtype=np.float64)
    t_at = first_time_at_s(place_s_mm, ts, sim_s_mm)
    v_sim = np.interp(t_at, ts, sim_feed_mm_s)
    moving = (np.asarray(speed_meas) > threshold_mm_s) & (v_sim > threshold_mm_s)
    if not np.any(moving):
        return float(t_meas_s[0] - t_at[0])
    return float(np.median(np.asarray(t_meas_s)[moving] - t_at[moving]))


def interp_rows(t, tp, fp) -> np.ndarray:
    """Linear interpolation of each column of ``fp`` (n, k) at ``t`` (held at the ends)."""
    return np.column_stack([np.interp(t, tp, fp[:, k]) for k in range(fp.shape[1])])


@njit(cache=True)
def _project_window(q, pts, s, ts, lo, hi, t_want, tol, s_prior, sigma_d, sigma_s):
    """Nearest place to ``q`` on the polyline ``pts`` between vertices ``lo`` and ``hi``.

    A standstill (consecutive equal vertices) is one place for a whole time span: if it is
    within ``tol`` of the nearest moving place, the sample is taken as standing there, at the
    simulated time closest to ``t_want``. With ``sigma_s > 0`` (a fresh start, no previous
    match) "nearest" means the least ``(d / sigma_d)^2 + ((s - s_prior) / sigma_s)^2``, so that
    a place the path visits twice (the start and end of a full circle) is told apart by the
    clock."""
    n = pts.shape[0]
    use_prior = sigma_s > 0.0
    best_c = np.inf
    best_d2 = np.inf
    best_j = lo
    best_u = 0.0
    stand_c = np.inf
    stand_d2 = np.inf
    stand_dt = np.inf
    stand_j = -1
    stand_u = 0.0
    for j in range(lo, max(hi, lo + 1)):
        j1 = min(j + 1, n - 1)
        e0 = pts[j1, 0] - pts[j, 0]
        e1 = pts[j1, 1] - pts[j, 1]
        e2 = pts[j1, 2] - pts[j, 2]
        ee = e0 * e0 + e1 * e1 + e2 * e2
        w0 = q[0] - pts[j, 0]
        w1 = q[1] - pts[j, 1]
        w2 = q[2] - pts[j, 2]
        if ee > 0.0:
            u = (w0 * e0 + w1 * e1 + w2 * e2) / ee
            u = min(1.0, max(0.0, u))
            d0 = w0 - u * e0
            d1 = w1 - u * e1
            d2 = w2 - u * e2
            dd = d0 * d0 + d1 * d1 + d2 * d2
            c = dd
            if use_prior:
                ds = (s[j] + u * (s[j1] - s[j]) - s_prior) / sigma_s
                c = dd / (sigma_d * sigma_d) + ds * ds
            if c < best_c:
                best_c, best_d2, best_j, best_u = c, dd, j, u
        elif j1 > j:
            # standing still between samples j and j1: the time closest to t_want
            u = 0.0
            if ts[j1] > ts[j]:
                u = min(1.0, max(0.0, (t_want - ts[j]) / (ts[j1] - ts[j])))
            dd = w0 * w0 + w1 * w1 + w2 * w2
            c = dd
            if use_prior:
                ds = (s[j] - s_prior) / sigma_s
                c = dd / (sigma_d * sigma_d) + ds * ds
            tdiff = abs(ts[j] + u * (ts[j1] - ts[j]) - t_want)
            if c < stand_c - 1e-15 or (c <= stand_c + 1e-15 and tdiff < stand_dt):
                stand_c, stand_d2, stand_dt, stand_j, stand_u = c, dd, tdiff, j, u
    if stand_j >= 0:
        if use_prior:
            if stand_c <= best_c or np.sqrt(stand_d2) <= np.sqrt(best_d2) + tol and \
                    abs(s[stand_j] - (s[best_j] + best_u * (s[min(best_j + 1, n - 1)] - s[best_j]))) <= 3 * sigma_s:
                return stand_j, stand_u
        elif np.sqrt(stand_d2) <= np.sqrt(best_d2) + tol:
            return stand_j, stand_u
    return best_j, best_u


#: always compiled (unless ``NCSIM_KERNELS=python``): the gap's model search aligns every
#: candidate model, hundreds of calls whose plain-Python cost (about 70 us a sample) adds up
#: to far more than numba's start-up, whatever the length of one call
@njit(cache=True, python_below=0)
def _track(q, pts, s, ts, t_al, s_prior, restart, reach, init_window, tol,
           sigma_d, sigma_s, out_j, out_u):
    """Sequential monotone projection of the measured points ``q`` on the polyline; sample
    ``i`` is searched up to ``reach[i]`` beyond the previous match."""
    n = pts.shape[0]
    s_prev = s[0]
    lag = 0.0  # current time error, carried through standstills
    for i in range(q.shape[0]):
        if restart[i]:
            s_lo = s_prior[i] - init_window
            s_hi = s_prior[i] + init_window
            sig = sigma_s
        else:
            s_lo = s_prev
            s_hi = s_prev + reach[i]
            sig = 0.0
        lo = np.searchsorted(s, s_lo, side="left") - 1
        hi = np.searchsorted(s, s_hi, side="right")
        lo = max(0, min(lo, n - 1))
        hi = max(lo, min(hi, n - 1))
        j, u = _project_window(q[i], pts, s, ts, lo, hi, t_al[i] - lag, tol, s_prior[i],
                               sigma_d, sig)
        j1 = min(j + 1, n - 1)
        s_here = s[j] + u * (s[j1] - s[j])
        if not restart[i] and s_here < s_prev:
            if s[j1] > s[j]:
                u = min(1.0, (s_prev - s[j]) / (s[j1] - s[j]))
        out_j[i] = j
        out_u[i] = u
        s_new = s[j] + u * (s[j1] - s[j])
        s_prev = s_new if restart[i] else max(s_prev, s_new)
        if s[j1] > s[j]:
            lag = t_al[i] - (ts[j] + u * (ts[j1] - ts[j]))


def project_on_path(q_mm, sim_pos_mm, sim_s_mm, sim_t_s, t_aligned_s, s_prior_mm, restart,
                    dt_s, v_max_mm_s, slack_mm, init_window_mm, standstill_tol_mm,
                    sigma_d_mm, sigma_s_mm):
    """Monotone nearest-place matching (step 3 of the module docstring); returns the simulated
    sample index ``j`` and fraction ``u`` of each matched place. ``v_max_mm_s`` and
    ``slack_mm`` (one value, or one per sample) bound how far along the path a sample is
    searched beyond the previous match: ``v_max dt + slack``."""
    m = len(q_mm)
    out_j = np.zeros(m, dtype=np.int64)
    out_u = np.zeros(m)
    f64 = lambda a: np.ascontiguousarray(a, dtype=np.float64)  # noqa: E731
    reach = np.broadcast_to(np.asarray(v_max_mm_s, dtype=np.float64) * f64(dt_s)
                            + np.asarray(slack_mm, dtype=np.float64), (m,))
    _track(f64(q_mm), f64(sim_pos_mm), f64(sim_s_mm), f64(sim_t_s), f64(t_aligned_s),
           f64(s_prior_mm), np.ascontiguousarray(restart, dtype=np.bool_), f64(reach),
           float(init_window_mm), float(standstill_tol_mm),
           float(sigma_d_mm), float(sigma_s_mm), out_j, out_u)
    return out_j, out_u


# ---------------------------------------------------------------------------------------------
# align
# ---------------------------------------------------------------------------------------------

def align(measured: MeasuredTrace, sim_pos_mm, sim_t_s, sim_s_mm, *, sim_block=None,
          sim_phase=None, sim_feed_mm_s=None, time_shift_s: float | None = None,
          offset_mm=None, shift_method: str = "auto", max_time_shift_s: float | None = None,
          onset_threshold_mm_s: float | None = None,
          speed_smoothing_s: float = 0.02, transition_half_width_s: float = 0.012,
          max_distance_mm: float = math.inf, noise_mm: float | None = None,
          use_command: bool = False, measured_speed_mm_s=None,
          sim_speed_mm_s=None, place_s_mm=None) -> Alignment:
    """Align ``measured`` to the simulated samples (see the module docstring).

    ``sim_pos_mm`` (n, 3), ``sim_t_s`` (n,), ``sim_s_mm`` (n,, non-decreasing) describe the
    simulation densely (e.g. a ``Trace`` at 1 ms); ``sim_block``/``sim_phase`` (``Trace.block``,
    ``Trace.phase``) and ``sim_feed_mm_s`` (``Trace.feed_mm_s``) are optional. A known
    ``time_shift_s`` or ``offset_mm`` skips its estimation. ``shift_method``: ``"auto"``
    (onset when both start at rest, else cross-correlation), ``"onset"`` or ``"xcorr"``.
    ``noise_mm`` is the position noise (default: estimated, :func:`estimate_noise_mm`); a sample
    within 3 noise of a simulated standstill is taken as standing there.
    ``use_command`` aligns the measured COMMANDED positions instead of the actual ones (the
    planner part of a command/actual split).
    ``measured_speed_mm_s`` and ``sim_speed_mm_s`` may give the speeds this function would
    derive (the measured speed, and the simulated speed through the same operator when the
    measured one is derived from positions): fitting loops align many models to one trace.
    ``place_s_mm`` is the place of every sample on the path (``ncsim.gap.register``, in the
    path length of ``sim_s_mm``): the recording may then start and end anywhere; the time
    shift is the median over moving samples of the measured time minus the simulated time at
    the place (``"place"``), and the matching starts from the place.
    """
    pts = np.asarray(sim_pos_mm, dtype=np.float64)
    ts = np.asarray(sim_t_s, dtype=np.float64)
    ss = np.asarray(sim_s_mm, dtype=np.float64)
    n = len(ts)
    if pts.shape != (n, 3) or ss.shape != (n,) or n < 2:
        raise UsageError(f"simulation arrays must be (n, 3), (n,), (n,) with n >= 2; got "
                         f"{pts.shape}, {ts.shape}, {ss.shape}")
    if np.any(np.diff(ts) <= 0) or np.any(np.diff(ss) < 0):
        raise UsageError("simulated time must increase and path length must not decrease")
    if use_command:
        measured = measured.command()
    q_raw = measured.pos_mm
    tm = measured.t_s
    m = len(tm)
    sim_feed = (np.gradient(ss, ts) if sim_feed_mm_s is None
                else np.asarray(sim_feed_mm_s, dtype=np.float64))
    period = measured.period_s if m > 1 else 1e-3
    derived = measured.feed_mm_s is None and measured.vel_mm_s is None
    if derived:
        # speed from positions: a central difference over +-k samples; the simulated speed used
        # to find the shift goes through the same operator (same half-width in seconds), so
        # that the smoothing biases both alike
        k = max(1, int(round(0.5 * speed_smoothing_s / period)))
        width_s = 2 * k * period
        v_meas = (measured.speed_mm_s(width_s) if measured_speed_mm_s is None
                  else np.asarray(measured_speed_mm_s, dtype=np.float64))
        v_sim_cmp = (derived_speed_mm_s(ts, pts, width_s) if sim_speed_mm_s is None
                     else np.asarray(sim_speed_mm_s, dtype=np.float64))
    else:
        v_meas = (measured.speed_mm_s() if measured_speed_mm_s is None
                  else np.asarray(measured_speed_mm_s, dtype=np.float64))
        v_sim_cmp = sim_feed
    v_max_sim = float(np.max(sim_feed)) if n else 0.0
    threshold = onset_threshold_mm_s or max(0.02 * v_max_sim, 1e-6)

    place_s = None
    if place_s_mm is not None:
        place_s = np.asarray(place_s_mm, dtype=np.float64)
        if place_s.shape != (m,):
            raise UsageError(f"place_s_mm has shape {place_s.shape}, expected ({m},)")

    # 1. time shift -----------------------------------------------------------------------
    if time_shift_s is not None:
        tau, shift_used = float(time_shift_s), "given"
    elif place_s is not None:
        tau = place_time_shift_s(tm, v_meas, place_s, ts, ss, sim_feed, threshold)
        shift_used = "place"
    else:
        on_sim = motion_onset_s(ts, v_sim_cmp, threshold)
        on_meas = motion_onset_s(tm, v_meas, threshold) if shift_method != "xcorr" else None
        if shift_method == "onset" and (on_sim is None or on_meas is None):
            raise UsageError("onset alignment needs both traces to start at rest")
        if shift_method not in ("auto", "onset", "xcorr"):
            raise UsageError(f"shift_method must be auto, onset or xcorr, got {shift_method!r}")
        if on_sim is not None and on_meas is not None:
            tau, shift_used = on_meas - on_sim, "onset"
        else:
            grid = max(measured.period_s if m > 1 else 1e-3, float(np.median(np.diff(ts))), 1e-3)
            tau = xcorr_shift_s(tm, v_meas, ts, v_sim_cmp, grid, max_time_shift_s)
            shift_used = "xcorr"

    # 2. start-position offset ------------------------------------------------------------
    def sim_at(t):
        return interp_rows(t, ts, pts)

    offset_used = "given"
    if offset_mm is not None:
        off = np.broadcast_to(np.asarray(offset_mm, dtype=np.float64), (3,)).copy()
    else:
        rest = (tm - tau < ts[0] + 1e-9) & (v_meas <= threshold)
        on_meas_rest = motion_onset_s(tm, v_meas, threshold)
        if on_meas_rest is not None and sim_feed[0] <= threshold:
            rest = (tm < on_meas_rest) & (v_meas <= threshold)
            # before the onset threshold is crossed a jerk-limited start has already moved
            # (J t^3 / 6: 0.2 mm at 5 m/s^3 and 10 mm/s): keep the samples whose speed is
            # within the derived-speed noise of rest, when there are enough of them
            noise0 = (estimate_noise_mm(q_raw, v_meas, threshold) if noise_mm is None
                      else float(noise_mm))
            width = 2 * max(1, int(round(0.5 * speed_smoothing_s / period))) * period
            still = rest & (v_meas <= max(4.0 * math.sqrt(2.0) * noise0 / width, 1e-3 * threshold))
            if np.count_nonzero(still) >= 3:
                rest = still
        if np.count_nonzero(rest) >= 1 and sim_feed[0] <= threshold:
            # against the simulated start motion at the aligned instants (= its start point
            # for samples truly at rest)
            off = np.median(q_raw[rest] - sim_at(tm[rest] - tau), axis=0)
            offset_used = "start"
        else:
            inside = (tm - tau >= ts[0]) & (tm - tau <= ts[-1])
            sel = inside if np.any(inside) else np.ones(m, dtype=bool)
            off = np.mean(q_raw[sel] - sim_at(tm[sel] - tau), axis=0)
            offset_used = "lsq"

    # refine a cross-correlation shift by least squares on the positions (the onset is
    # already sub-sample, and a refinement there would absorb part of a real feed-law gap)
    if shift_used == "xcorr":
        grid = max(measured.period_s if m > 1 else 1e-3, float(np.median(np.diff(ts))))
        win = (tm - tau >= ts[0]) & (tm - tau <= ts[-1])
        if np.count_nonzero(win) >= 3:
            qw, tw = q_raw[win], tm[win]
            lsq_offset = offset_used == "lsq"

            def cost(x):
                r = qw - sim_at(tw - x)
                r = r - (r.mean(axis=0) if lsq_offset else off)
                return float(np.sum(r * r))

            span = 2.0 * grid
            res = minimize_scalar(cost, bounds=(tau - span, tau + span), method="bounded",
                                  options={"xatol": 1e-6})
            if res.success and res.fun <= cost(tau):
                tau = float(res.x)
            if lsq_offset:
                off = np.mean(qw - sim_at(tw - tau), axis=0)

    q = q_raw - off
    t_al = tm - tau
    inside = (t_al >= ts[0] - 1e-9) & (t_al <= ts[-1] + 1e-9)
    r_time = q[inside] - sim_at(t_al[inside]) if np.any(inside) else np.zeros((1, 3))
    residual_rms = float(np.sqrt(np.mean(np.sum(r_time ** 2, axis=1))))

    # 3. path parameter ---------------------------------------------------------------------
    s_prior = np.interp(t_al, ts, ss) if place_s is None else place_s
    dt = np.zeros(m)
    dt[1:] = np.diff(tm)
    restart = np.zeros(m, dtype=bool)
    restart[0] = True
    if measured.segment is not None:
        restart[1:] |= np.diff(measured.segment) != 0
    # the measured samples advance along the path at the measured speed: a model much faster
    # (a rapid not yet fitted) widens the search window by no more than twice that
    v_meas_max = float(np.max(v_meas)) if m else 0.0
    v_max = 1.5 * max(min(v_max_sim, 2.0 * v_meas_max) if v_meas_max > 0 else v_max_sim,
                      v_meas_max) + 1e-9
    noise = estimate_noise_mm(q, v_meas, threshold) if noise_mm is None else float(noise_mm)
    slack = 5.0 * noise + 0.01 + v_max * 0.5 * period
    init_window = max(1.0, v_max * max(1.0, 10 * period)) + slack
    # each sample is searched as far as the measured speed around it (its largest over
    # +-LOCAL_SPEED_SAMPLES, with the margin of v_max) carries it: on a recording that rapids
    # at 50 mm/s and mills at 6, a milling sample needs a window of 0.3 mm, not 2
    v_local = np.minimum(1.5 * maximum_filter1d(v_meas, 2 * LOCAL_SPEED_SAMPLES + 1,
                                                mode="nearest") + 1e-9, v_max) if m else v_max
    slack_local = 5.0 * noise + 0.01 + v_local * 0.5 * period
    # at a fresh start the clock prior s(t - tau) picks among places the path visits twice:
    # distance measured against sigma_d (noise and contour errors), path length against
    # sigma_s (what the fastest feed covers in 0.1 s of clock uncertainty)
    sigma_d = max(3.0 * noise, 0.05)
    sigma_s = v_max * 0.1 + 1.0
    j, u = project_on_path(q, pts, ss, ts, t_al, s_prior, restart, dt, v_local, slack_local,
                           init_window, 3.0 * noise + 1e-4, sigma_d, sigma_s)
    j1 = np.minimum(j + 1, n - 1)
    s_match = ss[j] + u * (ss[j1] - ss[j])
    place = pts[j] + u[:, None] * (pts[j1] - pts[j])
    t_sim = ts[j] + u * (ts[j1] - ts[j])
    feed_sim = sim_feed[j] + u * (sim_feed[j1] - sim_feed[j])
    nearest = np.where(u < 0.5, j, j1)
    block = (np.asarray(sim_block)[nearest].astype(np.int64) if sim_block is not None
             else np.full(m, -1, dtype=np.int64))
    phase = (np.asarray(sim_phase)[nearest].astype(np.int64) if sim_phase is not None
             else np.full(m, -1, dtype=np.int64))
    if sim_block is not None and transition_half_width_s > 0:
        sb = np.asarray(sim_block)
        change = np.nonzero(np.diff(sb) != 0)[0] + 1
        flying = change[sim_feed[change] > threshold]
        if len(flying):
            t_junction = ts[flying]
            k = np.searchsorted(t_junction, t_sim)
            d_next = np.abs(t_junction[np.minimum(k, len(t_junction) - 1)] - t_sim)
            d_prev = np.abs(t_junction[np.maximum(k - 1, 0)] - t_sim)
            near = np.minimum(d_next, d_prev) <= transition_half_width_s
            phase = np.where(near, int(AlignPhase.TRANSITION), phase)
    deviation = q - place
    valid = inside & (np.linalg.norm(deviation, axis=1) <= max_distance_mm)
    return Alignment(time_shift_s=float(tau), offset_mm=off, shift_method=shift_used,
                     offset_method=offset_used, t_s=t_al, s_mm=s_match, sim_index=j, sim_frac=u,
                     block=block, phase=phase, t_sim_s=t_sim, time_error_s=t_al - t_sim,
                     feed_mm_s=v_meas, sim_feed_mm_s=feed_sim, deviation_mm=deviation,
                     valid=valid, residual_rms_mm=residual_rms,
                     covered_s_mm=None if place_s is None
                     else (float(place_s[0]), float(place_s.max())))


def align_trace(measured: MeasuredTrace, trace, **kwargs) -> Alignment:
    """:func:`align` against a simulated :class:`~ncsim.motion.Trace` (its ``pos_mm``, ``t_s``,
    ``s_mm``, ``block``, ``phase`` and ``feed_mm_s`` columns)."""
    return align(measured, trace.pos_mm, trace.t_s, trace.s_mm, sim_block=trace.block,
                 sim_phase=trace.phase, sim_feed_mm_s=trace.feed_mm_s, **kwargs)
