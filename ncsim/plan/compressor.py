"""The NC block compressor (COMPON, COMPCURV, COMPCAD, COMPSURF): runs of short G1 blocks
planned as one smooth curve.

What the 840D does (SINUMERIK 840D sl Job Planning "NC block compression (COMPON, COMPCURV,
COMPCAD, COMPOF)"; Basic Functions B1 "Compressor functions"; 808D Function Manual 01/2017):

* it compresses linear blocks of the simple form ``N.. G1 X.. Y.. Z.. F..`` (positions may be
  expressions); every other instruction -- an auxiliary function output, a stop, a change of
  the acceleration mode, any block that is not of that form -- interrupts it. The interpreter
  marks the segment after such an instruction with a negated ``Path.compressor``, and stops
  already end a run here;
* a block longer than MD20170 ``$MC_COMPRESS_BLOCK_PATH_LIMIT`` is not compressed;
* the curve deviates from the programmed end points by at most the tolerance: per axis
  MD33100 ``$MA_COMPRESS_POS_TOL``, or the programmed contour tolerance CTOL (CYCLE832);
* COMPON (3rd-order polynomial, continuous velocity) and COMPCURV (5th order, continuous
  acceleration) join up to 10 consecutive blocks into one polynomial block; COMPCAD joins any
  number and keeps corners whose angle exceeds SD42470 ``$SC_CRIT_SPLINE_ANGLE``; COMPSURF
  (Advanced Surface) is simulated as COMPCAD;
* circles and G0 are not compressed (MD20482 ``$MC_COMPRESSOR_MODE`` hundreds digit 0);
* feed (NC programming manual, Job Planning "Feedrate characteristic (FNORM, FLIN, FCUB,
  FPO)", boundary conditions "for active compressor"): under FNORM "the F word of the last
  block in the group applies to the spline segment"; only FCUB lets the feed deviate from the
  programmed points, by at most MD20172 ``$MC_COMPRESS_VELO_TOL`` ("the maximum permissible
  deviation of the path feedrate", B1, and not under COMPCAD). FLIN and FCUB are not simulated
  (the interpreter warns), so under FNORM no deviation is permitted: a polynomial block ends
  where the programmed F changes, and its last block's F is every block's own (a block
  programmed F95 never runs at a neighbour's F5122, a whole run never at its last F).

Representation. The polyline stays the path that is sampled (positions are the programmed
points), but each run is *planned* as the smooth curve the compressor would make:

* eq. 6 (one block per interpolation cycle) applies to the joined polynomial block, whose
  length is the group's, not to the programmed 0.05 mm blocks;
* the set-point limits that depend on the curvature (eq. 2/8, 4/9, 11) use the curvature of a
  fitted smooth curve through the points, and its change along a block is crossed like a
  transition spread over the block (eq. 13 generalised,
  :func:`~ncsim.plan.kinematics.curvature_change_feed_mm_s`);
* inside a run there are no corners (the junctions are smooth); COMPON's polynomials join
  with continuous velocity only, but the curvature jumps at their joins are not modelled
  (COMPON is planned like COMPCURV, with its groups of 10 blocks).

The fitted curve. Each run is smoothed by a kernel in arc length made of two triangles,
K = (4/3) K_W - (1/3) K_2W (K_a: the triangle of half-width a and area 1). A triangle alone
(a moving average taken twice) would pull a circle of radius R inward by W^2 / (12 R); the
combination (Richardson's extrapolation) has no second moment, so curves keep their curvature
up to terms in W^4 while noise in the points (CAM output is rounded to 1 um) is averaged out.
With P(s) the polyline and I, J its first and second antiderivatives (piecewise polynomial,
exact), each triangle is a closed form::

    P_a(s)   = (J(s + a) - 2 J(s) + J(s - a)) / a^2      the smoothed point
    P_a'(s)  = (I(s + a) - 2 I(s) + I(s - a)) / a^2
    P_a''(s) = (P(s + a) - 2 P(s) + P(s - a)) / a^2      (the curvature, once normalised)

A kink of angle theta becomes a curvature profile theta K(s): continuous and piecewise linear
(a clothoid-like rounding, like the corner rounding of :mod:`ncsim.plan.blend`), whose point
next to the kink lies theta W / 9 from it. At every programmed point W is searched over
W_MAX, W_MAX/2, ... (starting from the neighbour's) as the widest level for which the
smoothed point stays within the tolerance of the programmed one (each axis within MD33100,
or the distance within CTOL), so the deviation of the planned curve from the programmed points
never exceeds the tolerance (``tests/test_compressor.py`` checks it by integrating the kernel
numerically). A W also fails where the smoothed curve is a (near) cusp: |P'(s)| < 1/2
(``CUSP_SPEED``), i.e. the unit tangents inside the kernel turn back on themselves by more
than 120 deg (a reversal of a raster): the curvature there, |P''| / |P'|^2, is not the points'
turn spread over the kernel but grows without bound as |P'| -> 0 -- curvature the points do not
have (a 3rd- or 5th-order polynomial within the tolerance cannot turn back either). With
|P'| >= 1/2 the fitted curvature |P''_perp| / |P'|^2 is at most 4 |P''| <= (14/3) Theta / W,
Theta the points' total turn within the kernel's reach (P'' is the kernel times the tangent
jumps |t_k+1 - t_k| <= theta_k, and |K| <= 7 / (6 W)): bounded by the points' own turning
(``tests/test_compressor.py`` checks it on rasters with reversals). When no W at least as long as the point's adjoining blocks passes, the point is a
corner the compressor keeps: the run is split there and the corner is crossed as a corner
(G64 jump or a G642 rounding block). ``ncsim.plan.hsm`` keeps a corner also where the fitted
curve would be slower than the programmed blocks (corner detection by speed, see there): the
runs that lose a point are fitted again, and only they (``compress(..., previous=)``: a
point's fit reaches no further than its run). Runs are extended by straight lines along their
end directions so that the kernel never leaves the run. The search and the closed forms run
in a kernel (``ncsim.jit``: compiled by numba above ``FIT_PYTHON_BELOW`` points, plain Python
below), the rest is numpy over all runs at once.

Look-ahead: the rows of one polynomial block count as one block of the 840D's look-ahead
(``PathLimits.nc_block``, :mod:`ncsim.plan.lookahead`).

Everything is linear in the number of blocks (a refit costs the runs it refits).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ncsim.geometry import line_directions
from ncsim.jit import njit
from ncsim.machine import MachineSpec
from ncsim.path import COMPCAD, COMPSURF, LINE, Path
from ncsim.plan.kinematics import deflection_angle_rad

W_MAX_MM = 8.0             # widest smoothing half-width W tried (the kernel reaches 2 W)
W_LEVELS = 12              # W_MAX, W_MAX/2, ... W_MAX/2^11 (4 um)
MAX_GROUP_BLOCKS = 10      # COMPON/COMPCURV: blocks per polynomial (840D B1)
_SPLIT_ROUNDS = 4          # refits after splitting runs at kept corners
CUSP_SPEED = 0.5           # least |P'| of the smoothed curve at a point: no cusps (docstring)
_RUN_GAP_MM = 1.0          # arc-length gap between runs in the joint arrays (never evaluated)
FIT_PYTHON_BELOW = 2_000   # points below which the fit runs as plain Python (ncsim.jit): its
                           # work per point is some 50 times a scanner kernel's


@dataclass(frozen=True, slots=True)
class Compression:
    """The compressed runs of a path: per block (n) and per junction (n + 1)."""

    in_run: np.ndarray             # bool: the block is part of a compressed run
    joined: np.ndarray             # bool: the junction lies inside a run (no corner)
    group_length_mm: np.ndarray    # length of the polynomial block the block belongs to
    group_feed_mm_s: np.ndarray    # its feed: the F of its last block (FNORM)
    group_first: np.ndarray        # its first block (-1 outside the runs)
    curvature_1_mm: np.ndarray     # largest |kappa| of the fitted curve over the block
    normal: np.ndarray             # (n, 3) principal normal where |kappa| is largest
    curvature_change_1_mm: np.ndarray  # |kappa_vec(end) - kappa_vec(start)| over the block
    deviation_mm: np.ndarray       # (n + 1,) distance of the fitted curve from a joined junction
    window_mm: np.ndarray          # (n + 1,) the half-width W used at a joined junction
    junction_curvature_1_mm: np.ndarray  # (n + 1,) |kappa| of the fitted curve at a joined junction
    kappa_start: np.ndarray        # (n, 3) curvature vector of the fitted curve at the block start
    kappa_end: np.ndarray          # (n, 3) ... and at its end (0 outside the runs)


def compress(path: Path, machine: MachineSpec, kept: np.ndarray | None = None,
             previous: Compression | None = None) -> Compression | None:
    """The compressed runs of ``path`` (module docstring), or None when no block qualifies.

    ``kept`` (n + 1, bool) marks junctions that must stay corners (``ncsim.plan.hsm`` keeps
    those where the fitted curve would be slower than the programmed blocks). With
    ``previous`` (the compression of the same path without those corners kept) only the runs
    that lose a junction are fitted again: a point's fit reaches no further than its run."""
    n = path.n
    if n < 2 or not np.any(path.compressor != 0):
        return None
    joined = _joinable(path, machine) if previous is None else previous.joined.copy()
    if kept is not None:
        joined &= ~kept
    if previous is None:
        fit = _FitState.empty(n)
        dirty = joined.copy()
    else:
        fit = _FitState.of(previous)
        dirty = _runs_losing(previous.joined, joined)
    if not joined.any():
        return None

    vertex_tol = _vertex_tolerance(path)
    for split in range(_SPLIT_ROUNDS + 1):
        fit.clear(dirty)
        failed = _fit_runs(path, joined & dirty, vertex_tol, machine.compress_pos_tol_mm, fit)
        if failed is None or not failed.any() or split == _SPLIT_ROUNDS:
            break                       # (the last fit keeps what failed: it passed before)
        before = joined.copy()
        joined[failed] = False          # a corner the compressor keeps: its runs are refitted
        dirty = _runs_losing(before, joined)
    if not joined.any():
        return None
    return _per_block(path, joined, fit)


def _joinable(path: Path, machine: MachineSpec) -> np.ndarray:
    """Junctions (n + 1) the compressor may join (module docstring): between two eligible G1
    blocks of the same compressor, no interrupting instruction, no stop, no dwell, and under
    COMPCAD/COMPSURF no corner above SD42470."""
    n = path.n
    ncu = machine.ncu
    length = path.length_mm
    comp = np.abs(path.compressor)
    eligible = ((path.kind == LINE) & ~path.rapid & (comp > 0) & (length > 0.0)
                & (length <= ncu.compress_block_path_limit_mm))
    joined = np.zeros(n + 1, dtype=bool)
    u = line_directions(path)
    deflection = deflection_angle_rad(u[:-1], u[1:])
    keeps_corners = np.isin(comp[1:], (COMPCAD, COMPSURF))
    joined[1:n] = (eligible[:-1] & eligible[1:] & (comp[:-1] == comp[1:])
                   & (path.compressor[1:] > 0) & ~path.stop_before[1:]
                   & ~path.exact_stop[:-1] & (path.dwell_before_s[1:] <= 0.0)
                   & ~(keeps_corners & (deflection > ncu.crit_spline_angle_rad)))
    return joined


@dataclass(slots=True)
class _FitState:
    """The fit of every block and joined junction, written run by run (``_fit_runs``)."""

    kappa_start: np.ndarray     # (n, 3)
    kappa_end: np.ndarray       # (n, 3)
    deviation: np.ndarray       # (n + 1,)
    window: np.ndarray          # (n + 1,)

    @classmethod
    def empty(cls, n: int) -> "_FitState":
        return cls(np.zeros((n, 3)), np.zeros((n, 3)), np.zeros(n + 1), np.zeros(n + 1))

    @classmethod
    def of(cls, c: Compression) -> "_FitState":
        return cls(c.kappa_start.copy(), c.kappa_end.copy(), c.deviation_mm.copy(),
                   c.window_mm.copy())

    def clear(self, junctions: np.ndarray) -> None:
        """Forget the fit of the runs whose inner junctions are ``junctions`` (and their
        blocks): they are fitted again."""
        self.deviation[junctions] = 0.0
        self.window[junctions] = 0.0
        blocks = junctions[:-1] | junctions[1:]
        self.kappa_start[blocks] = 0.0
        self.kappa_end[blocks] = 0.0


def _runs_losing(old: np.ndarray, new: np.ndarray) -> np.ndarray:
    """The inner junctions (n + 1, bool) of the runs of ``old`` that hold a junction no
    longer joined in ``new``."""
    first, last = _runs(old)
    lost = np.nonzero(old & ~new)[0]
    out = np.zeros(len(old), dtype=bool)
    if lost.size == 0:
        return out
    r = np.unique(np.searchsorted(first, lost - 1, side="right") - 1)
    edge = np.zeros(len(old) + 1, dtype=np.int64)
    np.add.at(edge, first[r] + 1, 1)
    np.add.at(edge, last[r] + 1, -1)
    return np.cumsum(edge[:-1]) > 0


def _vertex_tolerance(path: Path) -> np.ndarray:
    """CTOL at each junction (n + 1): the smaller of its blocks' finite CTOL, NaN if none."""
    ctol = path.ctol_mm
    before = np.concatenate([[np.nan], ctol])
    after = np.concatenate([ctol, [np.nan]])
    return np.fmin(before, after)


def _runs(joined: np.ndarray):
    """(first block, last block) of every run of blocks joined by ``joined`` junctions."""
    inner = joined[1:-1].astype(np.int8)
    edges = np.diff(np.concatenate([[0], inner, [0]]))
    first = np.nonzero(edges == 1)[0]          # junction k = first + 1 joins blocks first, first+1
    last = np.nonzero(edges == -1)[0]          # last joined junction is last, so last block = last
    return first, last


def _fit_runs(path, joined, vertex_tol, axis_tol, state: _FitState):
    """Fit the runs of ``joined`` into ``state``; returns the junctions whose point no W kept
    within the tolerance (corners to keep), or None without runs."""
    first, last = _runs(joined)
    if len(first) == 0:
        return None
    n_vert = last - first + 2                   # junctions first .. last + 1
    vert = _ranges(first, n_vert)               # junction indices, run after run
    run_of = np.repeat(np.arange(len(first)), n_vert)
    pts = np.empty((len(vert), 3))
    is_start = vert == np.repeat(first, n_vert)
    pts[is_start] = path.start_mm[vert[is_start]]
    pts[~is_start] = path.end_mm[vert[~is_start] - 1]
    seg_len = path.length_mm
    # adjoining block lengths of every vertex (the smallest W a curve through it may have)
    before = np.where(is_start, np.inf, seg_len[np.maximum(vert - 1, 0)])
    is_end = vert == np.repeat(last + 1, n_vert)
    after = np.where(is_end, np.inf, seg_len[np.minimum(vert, len(seg_len) - 1)])
    w_floor = np.minimum(before, after)
    inner = ~is_start & ~is_end
    fit = smooth_polyline(pts, run_of, n_vert, w_floor, vertex_tol[vert], axis_tol)
    failed = np.zeros(len(joined), dtype=bool)
    failed[vert[inner & ~fit["ok"]]] = True
    # each block's start and end point within its own run (a point ending one run and starting
    # the next has a fit in each)
    count = last - first + 1
    rows = _ranges(first, count)
    entry = rows + np.repeat(np.cumsum(n_vert) - n_vert - first, count)
    state.kappa_start[rows] = fit["kappa"][entry]
    state.kappa_end[rows] = fit["kappa"][entry + 1]
    dev = fit["deviation"][inner]
    state.deviation[vert[inner]] = np.sqrt(np.einsum("ij,ij->i", dev, dev))
    state.window[vert[inner]] = fit["window"][inner]
    return failed


def _ranges(start: np.ndarray, count: np.ndarray) -> np.ndarray:
    """Concatenated ``arange(start[i], start[i] + count[i])``."""
    total = int(count.sum())
    offsets = np.repeat(start - np.concatenate([[0], np.cumsum(count)[:-1]]), count)
    return np.arange(total) + offsets


def smooth_polyline(points, run_of, n_vert, w_floor, ctol, axis_tol):
    """The smoothing of the module docstring for polylines, all runs at once.

    ``points`` (m, 3) are the vertices of the runs one after the other (``n_vert`` per run,
    ``run_of`` the run of each). Returns per vertex the curvature vector ``kappa`` (1/mm), the
    deviation vector of the smoothed point from the programmed one, the half-width ``window``
    used and ``ok``: whether a W >= ``w_floor`` kept it within the tolerance (``ctol`` when
    finite, else each axis within ``axis_tol``)."""
    m = len(points)
    n_runs = len(n_vert)
    first = np.concatenate([[0], np.cumsum(n_vert)[:-1]])
    last = first + n_vert - 1
    d_start = _unit(points[first + 1] - points[first])
    d_end = _unit(points[last] - points[last - 1])
    # padded runs: a straight extension of 2 W_MAX before and after each run, in run-local
    # coordinates (relative to the run's first padded point) to keep the sums small
    pos = np.arange(m) + 2 * run_of + 1                   # vertex -> padded index
    q = np.empty((m + 2 * n_runs, 3))
    q[pos] = points
    q[first + 2 * np.arange(n_runs)] = points[first] - 2.0 * W_MAX_MM * d_start
    q[last + 2 * np.arange(n_runs) + 2] = points[last] + 2.0 * W_MAX_MM * d_end
    padded_run = np.repeat(np.arange(n_runs), n_vert + 2)
    run_first = first + 2 * np.arange(n_runs)             # padded index of each run's first point
    anchor = q[run_first]
    q -= anchor[padded_run]

    seg = np.diff(q, axis=0)                              # segment k: q[k] -> q[k + 1]
    seg_len = np.sqrt(np.einsum("ij,ij->i", seg, seg))
    crossing = padded_run[:-1] != padded_run[1:]          # dummy segments between runs
    seg_len[crossing] = _RUN_GAP_MM
    s = np.concatenate([[0.0], np.cumsum(seg_len)])       # global, strictly increasing
    inv_len = 1.0 / seg_len
    # first and second antiderivatives at the points, restarted at each run
    c_i = 0.5 * (q[:-1] + q[1:]) * seg_len[:, None]
    c_i[crossing] = 0.0
    i_pts = _segmented_cumsum(c_i, crossing)
    c_j = (i_pts[:-1] * seg_len[:, None] + q[:-1] * (seg_len ** 2 / 2.0)[:, None]
           + seg * (seg_len ** 2 / 6.0)[:, None])
    c_j[crossing] = 0.0
    j_pts = _segmented_cumsum(c_j, crossing)

    widths = W_MAX_MM * 0.5 ** np.arange(W_LEVELS)
    # the narrowest level a point may use: W >= its adjoining blocks (else it is a corner)
    last_level = np.clip(np.searchsorted(-widths, -w_floor, side="right") - 1, 0, W_LEVELS - 1)
    run_lo = run_first[run_of]                            # padded point range of each vertex's run
    run_hi = run_lo + n_vert[run_of] + 1
    kappa = np.empty((m, 3))
    deviation = np.empty((m, 3))
    window = np.empty(m)
    ok = np.empty(m, dtype=np.bool_)
    _fit_kernel(s, q, i_pts, j_pts, seg * inv_len[:, None], pos, run_lo, run_hi, widths,
                last_level, np.asarray(ctol, dtype=np.float64),
                np.asarray(axis_tol, dtype=np.float64), kappa, deviation, window, ok)
    return dict(kappa=kappa, deviation=deviation, window=window, ok=ok)


@njit(cache=True, nogil=True)
def _segment_at(s, lo, hi, x):
    """The segment k in [lo, hi) of the points ``s`` with s[k] <= x (binary search)."""
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if s[mid] <= x:
            lo = mid
        else:
            hi = mid
    return lo


@njit(cache=True, nogil=True)
def _window_sums(s, q, i_pts, j_pts, unit, lo, hi, sv, w, out_q, out_i, out_j):
    """Q, I and J of the padded polyline at sv + w plus at sv - w (sums per axis)."""
    for c in range(3):
        out_q[c] = 0.0
        out_i[c] = 0.0
        out_j[c] = 0.0
    for sign in (1.0, -1.0):
        x = sv + sign * w
        k = _segment_at(s, lo, hi, x)
        tau = x - s[k]
        for c in range(3):
            d = unit[k, c]
            out_q[c] += q[k, c] + d * tau
            out_i[c] += i_pts[k, c] + tau * (q[k, c] + d * tau / 2.0)
            out_j[c] += j_pts[k, c] + tau * (i_pts[k, c] + tau * (q[k, c] / 2.0 + d * tau / 6.0))


@njit(cache=True, nogil=True)
def _smoothed(s, q, i_pts, j_pts, unit, lo, hi, p, w, pos_out, d1_out, d2_out, tmp_q, tmp_i,
              tmp_j):
    """The smoothed point, its first and its second derivative at padded point ``p`` for the
    kernel (4/3) K_W - (1/3) K_2W (triangles of half-width W and 2 W)."""
    sv = s[p]
    for c in range(3):
        pos_out[c] = 0.0
        d1_out[c] = 0.0
        d2_out[c] = 0.0
    for width, weight in ((w, 4.0 / 3.0), (2.0 * w, -1.0 / 3.0)):
        _window_sums(s, q, i_pts, j_pts, unit, lo, hi, sv, width, tmp_q, tmp_i, tmp_j)
        scale = weight / (width * width)
        for c in range(3):
            pos_out[c] += scale * (tmp_j[c] - 2.0 * j_pts[p, c])
            d1_out[c] += scale * (tmp_i[c] - 2.0 * i_pts[p, c])
            d2_out[c] += scale * (tmp_q[c] - 2.0 * q[p, c])


@njit(cache=True, nogil=True)
def _within(s, q, i_pts, j_pts, unit, lo, hi, p, w, ctol, axis_tol, sm, d1, d2, tmp_q, tmp_i,
            tmp_j):
    """Whether the smoothed point at half-width ``w`` lies within the tolerance (CTOL when not
    NaN, else every axis within its tolerance) and is no cusp (``CUSP_SPEED``); fills sm, d1,
    d2."""
    _smoothed(s, q, i_pts, j_pts, unit, lo, hi, p, w, sm, d1, d2, tmp_q, tmp_i, tmp_j)
    dist2 = 0.0
    speed2 = 0.0
    inside = True
    for c in range(3):
        dev = sm[c] - q[p, c]
        dist2 += dev * dev
        speed2 += d1[c] * d1[c]
        if abs(dev) > axis_tol[c]:
            inside = False
    if not np.isnan(ctol):
        inside = dist2 <= ctol * ctol
    return inside and speed2 >= CUSP_SPEED * CUSP_SPEED


@njit(cache=True, nogil=True, python_below=FIT_PYTHON_BELOW)
def _fit_kernel(s, q, i_pts, j_pts, unit, pos, run_lo, run_hi, widths, last_level, ctol,
                axis_tol, kappa, deviation, window, ok):
    """Per vertex: the widest level W whose smoothed point stays within the tolerance (the
    levels after ``last_level`` are too narrow), then the curvature vector of the smoothed
    curve there (:func:`smooth_polyline`). The search starts from the previous vertex's level
    (neighbours mostly share it): widen while the next wider level passes, else narrow until
    one passes; the level taken always passed (or is the narrowest allowed, ``ok`` False)."""
    tmp_q = np.empty(3)
    tmp_i = np.empty(3)
    tmp_j = np.empty(3)
    sm = np.empty(3)
    d1 = np.empty(3)
    d2 = np.empty(3)
    keep = np.empty(9)
    prev = 0
    for v in range(len(pos)):
        p = pos[v]
        lo_pt, hi_pt = run_lo[v], run_hi[v]
        if v == 0 or run_lo[v] != run_lo[v - 1]:
            prev = 0
        last = last_level[v]
        level = min(prev, last)
        passed = _within(s, q, i_pts, j_pts, unit, lo_pt, hi_pt, p, widths[level], ctol[v],
                         axis_tol, sm, d1, d2, tmp_q, tmp_i, tmp_j)
        if passed:
            for c in range(3):
                keep[c], keep[3 + c], keep[6 + c] = sm[c], d1[c], d2[c]
            while level > 0 and _within(s, q, i_pts, j_pts, unit, lo_pt, hi_pt, p,
                                        widths[level - 1], ctol[v], axis_tol, sm, d1, d2,
                                        tmp_q, tmp_i, tmp_j):
                level -= 1
                for c in range(3):
                    keep[c], keep[3 + c], keep[6 + c] = sm[c], d1[c], d2[c]
            for c in range(3):
                sm[c], d1[c], d2[c] = keep[c], keep[3 + c], keep[6 + c]
        else:
            while level < last and not passed:
                level += 1
                passed = _within(s, q, i_pts, j_pts, unit, lo_pt, hi_pt, p, widths[level],
                                 ctol[v], axis_tol, sm, d1, d2, tmp_q, tmp_i, tmp_j)
        ok[v] = passed
        prev = level
        window[v] = widths[level]
        d1_2 = 0.0
        d12 = 0.0
        for c in range(3):
            deviation[v, c] = sm[c] - q[p, c]
            d1_2 += d1[c] * d1[c]
            d12 += d1[c] * d2[c]
        for c in range(3):      # (d2 - (d2.T) T) / |d1|^2, T = d1 / |d1|
            kappa[v, c] = (d2[c] - d12 / d1_2 * d1[c]) / d1_2 if d1_2 > 0.0 else 0.0


def _segmented_cumsum(c: np.ndarray, reset: np.ndarray) -> np.ndarray:
    """Values at the points (len(c) + 1) of the running sum of ``c`` over segments, restarted
    at 0 after every segment where ``reset`` is True (those segments contribute nothing).
    Each reset segment takes minus the sum of its run (``np.add.reduceat``, one run at a
    time), so the running sum returns to zero there and rounding stays at the scale of one
    run instead of growing with the whole program."""
    c = c.copy()
    c[reset] = 0.0
    r = np.nonzero(reset)[0]
    if r.size:
        starts = np.concatenate([[0], r + 1])        # run k: segments starts[k] .. r[k]
        c[r] = -np.add.reduceat(c, starts, axis=0)[:len(r)]
    out = np.empty((len(c) + 1, c.shape[1]))
    out[0] = 0.0
    np.cumsum(c, axis=0, out=out[1:])
    return out


def _unit(v: np.ndarray) -> np.ndarray:
    norm = np.sqrt(np.einsum("ij,ij->i", v, v))
    return np.divide(v, norm[:, None], out=np.zeros_like(v), where=norm[:, None] > 0.0)


def _per_block(path: Path, joined: np.ndarray, fit: _FitState) -> Compression:
    n = path.n
    in_run = np.zeros(n, dtype=bool)
    first, last = _runs(joined)
    count = last - first + 1
    rows = _ranges(first, count)
    in_run[rows] = True
    # polynomial blocks: within a run, the blocks of one programmed F (FNORM, docstring), all of
    # them (COMPCAD, COMPSURF) or chunks of MAX_GROUP_BLOCKS
    run_of = np.repeat(np.arange(len(first)), count)
    feed = path.feed_mm_s[rows]
    feed_start = np.ones(len(rows), dtype=bool)      # a run or a programmed F begins
    feed_start[1:] = (run_of[1:] != run_of[:-1]) | (feed[1:] != feed[:-1])
    feed_first = np.nonzero(feed_start)[0]
    rank = np.arange(len(rows)) - feed_first[np.cumsum(feed_start) - 1]
    chunked = ~np.isin(np.abs(path.compressor[rows]), (COMPCAD, COMPSURF))
    group_key = np.where(chunked, rank // MAX_GROUP_BLOCKS, 0)
    new_group = feed_start.copy()
    new_group[1:] |= group_key[1:] != group_key[:-1]
    group_id = np.cumsum(new_group) - 1
    group_start = np.nonzero(new_group)[0]
    group_len = np.add.reduceat(path.length_mm[rows], group_start)
    group_last = np.append(group_start[1:], len(rows)) - 1
    group_length = np.full(n, np.nan)
    group_length[rows] = group_len[group_id]
    group_feed = np.full(n, np.nan)
    group_feed[rows] = path.feed_mm_s[rows[group_last]][group_id]
    group_first = np.full(n, -1, dtype=np.int64)
    group_first[rows] = rows[group_start][group_id]

    k_start, k_end = fit.kappa_start, fit.kappa_end
    m_start = np.sqrt(np.einsum("ij,ij->i", k_start, k_start))
    m_end = np.sqrt(np.einsum("ij,ij->i", k_end, k_end))
    curvature = np.where(in_run, np.maximum(m_start, m_end), 0.0)
    normal = np.where((m_end > m_start)[:, None], k_end, k_start)
    normal = _unit(normal)
    change = k_end - k_start
    change = np.where(in_run, np.sqrt(np.einsum("ij,ij->i", change, change)), 0.0)
    m_junction = np.zeros(n + 1)
    m_junction[:-1] = np.where(joined[:-1], m_start, 0.0)   # a joined junction starts block k
    return Compression(in_run=in_run, joined=joined.copy(), group_length_mm=group_length,
                       group_feed_mm_s=group_feed, group_first=group_first,
                       curvature_1_mm=curvature, normal=normal, curvature_change_1_mm=change,
                       deviation_mm=fit.deviation, window_mm=fit.window,
                       junction_curvature_1_mm=m_junction, kappa_start=k_start,
                       kappa_end=k_end)
