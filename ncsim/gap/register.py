"""Registering a recording on its program: which stretch of the path it covers, where the
program's zero lies in the recording's coordinates, and how closely the recording follows.

A real recording (840D trace, Edge "Capture", a data-acquisition export) starts and ends
anywhere in the program, is in machine coordinates (program zero plus a work offset, 840D
settable frame G54..), may be of a program whose contour repeats at several depths (passes),
and is sampled at any rate, often after a low-pass and resampling by the recorder. Before a
model can be compared with it, every sample needs its *place* on the program path: the path
length ``s`` of the nearest program point, found once, from geometry alone (no planner).

:func:`register` does it in three steps (vectorised numpy, one compiled loop):

1. **Shape signature** (rate- and offset-free): the recording and the program path are both
   resampled by arc length at a step ``h`` (standstills dropped) and given unit tangents from
   chords over +-``TANGENT_HALF_WIDTH_MM`` -- wide enough that the recorder's corner
   smoothing and resampling wiggles do not matter. The mean dot product of the two tangent
   sequences, ``C(k) = mean_j T_rec(j) . T_prog(k + j)``, for every shift ``k`` at once (FFT
   correlation), is 1 where the recorded shape runs along the program. A translation does not
   change tangents, so the peaks of ``C`` are the candidate placements -- one per pass of a
   repeated contour -- each with a seed offset (median of recorded minus program point).
2. **Refinement** of the candidates whose seed already places the samples close (screened on
   a subsample): the work offset ``o`` (recorded = program + ``o``) by robust Gauss-Newton
   point-to-curve fitting (Tukey weights on a MAD scale, annealed from the seed's residual;
   the normal-plane projector ``I - t t^T`` as Hessian). The nearest program point of a sample is searched on the
   exact lines, arcs and helices, only within a window of path length that starts where the
   previous sample was placed and reaches as far as a few times the chord to it (monotone: a
   pass below cannot be mixed in, a place visited twice is told apart by order). A recording
   at rest at the program's start (or end) point is pinned there (no following or contour
   error at rest). A given offset (machine or setup file, ``--work-offset``) is used as it is.
3. **Decision**: a candidate is *consistent* when its median distance is within the noise (or,
   for actual positions, within what a servo's contour error can be), its path position never
   sticks, goes back or skips (``continuity defect``: recorded chord against advance of the
   place). The best consistent one is the registration; another one with a different offset
   that fits as well makes it **ambiguous** (passes that are identical where recorded: a
   work offset must decide); none makes it **refused**, with a hint at the likely cause (unit,
   columns, offset, program) from trying the usual unit factors and axis swaps. Passes are
   numbered by the segment under the middle sample among the program's segments of the same
   geometry up to a translation (:func:`repeat_index`).
"""
from __future__ import annotations

import math
import os
from dataclasses import dataclass, field, replace
from functools import lru_cache
from itertools import permutations

import numpy as np
from scipy.signal import fftconvolve

from ncsim.errors import MeasuredDataError, UsageError
from ncsim.gap.align import first_time_at_s
from ncsim.gap.nearest import FORWARD_CHORDS, PathGeometry, path_geometry, track
from ncsim.geometry import point_at
from ncsim.path import Path
from ncsim.units import FACTORS, mm_s_to_mm_min, mm_to_um

SIGNATURE_STEP_MM = 0.02          # smallest arc-length step of the shape signature
SIGNATURE_POINTS = 200_000        # the step grows so that program + recording stay below this
TANGENT_HALF_WIDTH_MM = 0.5       # chord tangents over +-0.5 mm (at least 2 steps)
MIN_SIGNATURE = 0.8               # a placement's tangents must agree this well on average
SIGNATURE_DROP = 0.25             # candidates: peaks within this of the best
MAX_CANDIDATES = 32
SCREEN_SAMPLES = 2000             # candidates are screened on this many samples ...
SCREEN_FACTOR = 10.0              # ... kept within 10 x the best median distance (or within
SCREEN_FLOOR_MM = 0.1             # 0.1 mm: a seed's offset is only as good as its grid) ...
MAX_REFINED = 8                   # ... and at most 8 of them refined
MIN_SEPARATION_MM = 1.0           # two placements closer than this along the path are one
FIRST_WINDOW_MM = 3.0             # where the first sample may lie around its seed
MAX_FIT_SAMPLES = 50_000          # the offset is fitted on at most this many samples
MAX_ITERATIONS = 60
SCALE_FLOOR_MM = 1e-4             # robust scale at least 0.1 um (commanded positions are exact)
TUKEY_C = 4.685
COMMAND_TOL_MM = 5e-3             # commanded positions follow the program to this (rms 5 um)
NOISE_FACTOR = 4.0
ACTUAL_TOL_SHARE = 0.02           # actual positions: median distance within 2 % of the size
DEFECT_SHARE = 0.01               # continuity defect within 1 % of the covered length
MIN_DEFECT_MM = 0.2
DISTINCT_OFFSET_MM = 0.05         # offsets closer than this are the same registration
EQUAL_FIT = 1.5                   # "fits as well": rms and max within 1.5 x (plus the noise)


# ---------------------------------------------------------------------------------------------
# The result
# ---------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Place:
    """A place on the program path: segment, line, fraction of the block, path length."""

    s_mm: float
    segment: int
    file: str
    line: int
    fraction: float
    text: str = ""

    def label(self) -> str:
        block = f" ({self.text})" if self.text else ""
        return f"{os.path.basename(self.file)}:{self.line}{block} at {100.0 * self.fraction:.0f} %"

    def as_dict(self) -> dict:
        return {"file": self.file, "line": self.line, "block": self.text,
                "segment": self.segment, "fraction": self.fraction, "s_mm": self.s_mm}


@dataclass(frozen=True, eq=False)
class Candidate:
    """One placement of the recorded shape on the program, refined."""

    s_start_mm: float
    signature: float
    offset_mm: np.ndarray
    rms_mm: float
    max_mm: float
    median_mm: float
    defect_mm: float
    consistent: bool

    def as_dict(self) -> dict:
        return {"s_start_mm": self.s_start_mm, "signature": self.signature,
                "offset_mm": [float(v) for v in self.offset_mm],
                "rms_um": mm_to_um(self.rms_mm), "max_um": mm_to_um(self.max_mm),
                "defect_mm": self.defect_mm, "consistent": self.consistent}


@dataclass(frozen=True, eq=False)
class Registration:
    """Where a recording lies on its program (module docstring). Arrays have one row per
    sample of the registered positions."""

    status: str                  # "ok", "ambiguous" or "refused"
    message: str                 # one line: what was found, or why not
    signal: str                  # "command" or "actual": which positions were registered
    offset_mm: np.ndarray        # (3,) recorded = program + offset
    offset_source: str           # "fitted" or where the given offset came from
    s_mm: np.ndarray             # (m,) path length of each sample's place
    segment: np.ndarray          # (m,) path segment of the place
    distance_mm: np.ndarray      # (m,) distance of the sample to the path
    noise_mm: float
    first: Place | None
    last: Place | None
    pass_index: int              # 1-based, among the placements the recorded shape fits
    n_passes: int
    candidates: tuple[Candidate, ...] = ()
    ambiguous_passes: tuple[int, ...] = ()
    notes: tuple[str, ...] = field(default=())
    passes_spanned: tuple[int, int] | None = None   # first and last pass when it spans several

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    @property
    def residual_rms_mm(self) -> float:
        d = self.distance_mm
        return float(np.sqrt(np.mean(d * d))) if d.size else 0.0

    @property
    def residual_max_mm(self) -> float:
        return float(np.max(self.distance_mm)) if self.distance_mm.size else 0.0

    @property
    def s_first_mm(self) -> float:
        return float(self.s_mm[0])

    @property
    def s_last_mm(self) -> float:
        return float(np.max(self.s_mm))

    def model_time_s(self, t_s, s_mm) -> np.ndarray:
        """When a model (e.g. a sampled ``motion.Trace``: times ``t_s``, path lengths ``s_mm``)
        first reaches each sample's place; ``[-1] - [0]`` is its time over the places the
        recording covers."""
        return first_time_at_s(self.s_mm, t_s, s_mm)

    def covered(self) -> str:
        """``FILE:LINE (block) at N % to FILE:LINE at M %, pass k of n``."""
        if self.first is None or self.last is None:
            return ""
        passes = f", pass {self.pass_index} of {self.n_passes}" if self.n_passes > 1 else ""
        if self.passes_spanned is not None:
            passes = f", passes {self.passes_spanned[0]} to {self.passes_spanned[1]} of {self.n_passes}"
        return f"{self.first.label()} to {self.last.label()}{passes}"

    def as_dict(self) -> dict:
        return {"status": self.status, "message": self.message, "signal": self.signal,
                "offset_mm": [float(v) for v in self.offset_mm],
                "offset_source": self.offset_source,
                "residual_rms_um": mm_to_um(self.residual_rms_mm),
                "residual_max_um": mm_to_um(self.residual_max_mm),
                "noise_um": mm_to_um(self.noise_mm),
                "first": None if self.first is None else self.first.as_dict(),
                "last": None if self.last is None else self.last.as_dict(),
                "covered": self.covered(), "pass": self.pass_index, "passes": self.n_passes,
                "passes_spanned": (None if self.passes_spanned is None
                                   else list(self.passes_spanned)),
                "candidates": [c.as_dict() for c in self.candidates],
                "notes": list(self.notes)}

    def require(self, source: str) -> "Registration":
        """This registration, or a one-line :class:`MeasuredDataError` if it is not ok."""
        if not self.ok:
            raise MeasuredDataError(self.message, file=source)
        return self


# ---------------------------------------------------------------------------------------------
# Step 1: shape signature
# ---------------------------------------------------------------------------------------------

def noise_mm(q_mm: np.ndarray) -> float:
    """White position noise from second differences (zero on lines at constant speed):
    ``1.4826 MAD(p[i+1] - 2 p[i] + p[i-1]) / sqrt(6)`` over all axes."""
    q = np.asarray(q_mm, dtype=np.float64)
    if len(q) < 3:
        return 0.0
    d2 = q[2:] - 2.0 * q[1:-1] + q[:-2]
    return float(1.4826 * np.median(np.abs(d2)) / math.sqrt(6.0))


def arc_length_mm(q_mm: np.ndarray, min_step_mm: float) -> np.ndarray:
    """Cumulative chord length, counting only chords above ``min_step_mm`` (standstill
    jitter is not travel)."""
    c = np.linalg.norm(np.diff(q_mm, axis=0), axis=1)
    return np.concatenate([[0.0], np.cumsum(np.where(c > min_step_mm, c, 0.0))])


def chord_tangents(points: np.ndarray, half: int) -> np.ndarray:
    """Unit tangents from chords ``p[j + half] - p[j - half]`` (ends held); 0 where the chord
    is 0."""
    n = len(points)
    lo = np.clip(np.arange(n) - half, 0, n - 1)
    hi = np.clip(np.arange(n) + half, 0, n - 1)
    d = points[hi] - points[lo]
    norm = np.linalg.norm(d, axis=1)
    return np.divide(d, norm[:, None], out=np.zeros_like(d), where=norm[:, None] > 0)


def path_points(path: Path, s_mm: np.ndarray) -> np.ndarray:
    """Program points at path lengths ``s_mm`` (clipped to the path)."""
    s0 = path.s_start_mm
    s = np.clip(s_mm, 0.0, path.total_length_mm)
    k = np.clip(np.searchsorted(s0, s, side="right") - 1, 0, path.n - 1)
    return point_at(path, k, s - s0[k])


@dataclass(frozen=True)
class _Seed:
    s_start_mm: float
    signature: float
    offset_mm: np.ndarray


def signature_candidates(q_mm: np.ndarray, path: Path, noise: float) -> list[_Seed]:
    """Candidate placements of the recorded shape (module docstring, step 1), best first."""
    q = np.asarray(q_mm, dtype=np.float64)
    step = np.linalg.norm(np.diff(q, axis=0), axis=1)
    moving = step[step > 3.0 * noise + 1e-9]
    # noise inflates chords: thin the samples until a chord is ten times the noise
    stride = 1
    if moving.size and noise > 0:
        stride = max(1, int(math.ceil(10.0 * noise / max(float(np.median(moving)), 1e-12))))
    qs = q[::stride] if stride > 1 else q
    sigma = arc_length_mm(qs, 3.0 * noise + 1e-9)
    total_rec = float(sigma[-1])
    total_prog = path.total_length_mm
    if total_rec <= 0 or total_prog <= 0:
        return []
    h = max(SIGNATURE_STEP_MM, (total_rec + total_prog) / SIGNATURE_POINTS)
    half = max(2, int(round(TANGENT_HALF_WIDTH_MM / h)))
    g = np.arange(0.0, total_rec + 0.5 * h, h)
    keep = np.concatenate([[True], np.diff(sigma) > 0])
    rec = np.column_stack([np.interp(g, sigma[keep], qs[keep, a]) for a in range(3)])
    s_prog = np.arange(0.0, total_prog + 0.5 * h, h)
    prog = path_points(path, s_prog)
    t_rec = chord_tangents(rec, half)
    t_prog = chord_tangents(prog, half)
    n = len(t_rec)
    corr = sum(fftconvolve(t_prog[:, a], t_rec[::-1, a], mode="full") for a in range(3)) / n
    shift = np.arange(-(n - 1), len(t_prog))
    peaks = np.flatnonzero((corr[1:-1] >= corr[:-2]) & (corr[1:-1] >= corr[2:])) + 1
    if corr.size and corr[0] >= corr[min(1, corr.size - 1)]:
        peaks = np.concatenate([[0], peaks])
    if corr.size > 1 and corr[-1] >= corr[-2]:
        peaks = np.concatenate([peaks, [corr.size - 1]])
    best = float(corr.max()) if corr.size else 0.0
    peaks = peaks[corr[peaks] >= max(MIN_SIGNATURE, best - SIGNATURE_DROP)]
    peaks = peaks[np.argsort(-corr[peaks], kind="stable")]
    chosen: list[int] = []
    for p in peaks:
        if all(abs(shift[p] - shift[c]) * h > MIN_SEPARATION_MM for c in chosen):
            chosen.append(int(p))
        if len(chosen) >= MAX_CANDIDATES:
            break
    seeds = []
    for p in chosen:
        s_start = float(shift[p] * h)
        s_at = s_start + g
        inside = (s_at >= 0.0) & (s_at <= total_prog)
        if not np.any(inside):
            continue
        offset = np.median(rec[inside] - path_points(path, s_at[inside]), axis=0)
        seeds.append(_Seed(float(np.clip(s_start, 0.0, total_prog)), float(corr[p]), offset))
    return seeds


# ---------------------------------------------------------------------------------------------
# Step 2: refinement
# ---------------------------------------------------------------------------------------------

def _slack_mm(noise: float) -> float:
    return max(0.05, 10.0 * noise)


def fit_offset(q_mm: np.ndarray, geo: PathGeometry, offset_mm, s_seed_mm: float,
               noise: float) -> tuple[np.ndarray, float, np.ndarray]:
    """Robust Gauss-Newton fit of the translation (module docstring, step 2) on at most
    ``MAX_FIT_SAMPLES`` evenly spread samples. Returns the offset, the place of the first
    sample and the eigenvalues of the normalised Hessian (a zero one: a direction the
    recording does not fix)."""
    q = np.asarray(q_mm, dtype=np.float64)
    stride = max(1, int(math.ceil(len(q) / MAX_FIT_SAMPLES)))
    qf = q[::stride]
    o = np.asarray(offset_mm, dtype=np.float64).copy()
    s_seed = float(s_seed_mm)
    window = FIRST_WINDOW_MM
    slack = _slack_mm(noise)
    eig = np.ones(3)
    floor = max(noise, SCALE_FLOOR_MM)
    anneal = None
    for _ in range(MAX_ITERATIONS):
        tr = track(qf - o, geo, s_seed, first_window_mm=window, slack_mm=slack)
        d = tr.distance
        robust = max(1.4826 * float(np.median(d)), floor)
        # graduated robustness: the Tukey scale starts at the seed's rms residual and halves
        # each step down to the robust scale, so that a few samples that alone fix a direction
        # (a short plunge) are not rejected as outliers of a seed that is still off
        anneal = float(np.sqrt(np.mean(d * d))) if anneal is None else 0.5 * anneal
        scale = max(robust, anneal)
        x = d / (TUKEY_C * scale)
        wgt = np.where(x < 1.0, (1.0 - x * x) ** 2, 0.0)
        t = tr.tangent
        r = tr.residual
        rn = r - t * np.einsum("ij,ij->i", t, r)[:, None]
        hess = wgt.sum() * np.eye(3) - np.einsum("i,ij,ik->jk", wgt, t, t)
        grad = (wgt[:, None] * rn).sum(axis=0)
        trace = float(np.trace(hess))
        if trace <= 0:
            break
        eig = np.linalg.eigvalsh(hess / trace)
        step = np.linalg.solve(hess + 1e-9 * trace * np.eye(3), grad)
        norm = float(np.linalg.norm(step))
        if norm > 1.0:
            step /= norm
        o = o + step
        s_seed = float(tr.s[0])
        window = max(0.5, 3.0 * norm)
        if norm < 1e-8 and anneal <= robust:
            break
    return o, s_seed, eig


def continuity_defect_mm(q_mm: np.ndarray, s_mm: np.ndarray, noise: float) -> float:
    """How much the places stick, go back or skip: the sum over samples of the recorded chord
    not covered by the advance of the place, plus the advance beyond ``FORWARD_CHORDS``
    chords, both beyond a tolerance of 1 um + 5 noise per chord. Samples are thinned until the
    median moving chord is ten tolerances, so that the sum does not depend on the rate."""
    tol = 1e-3 + 5.0 * noise
    c = np.linalg.norm(np.diff(q_mm, axis=0), axis=1)
    moving = c[c > tol]
    stride = 1
    if moving.size:
        stride = max(1, int(10.0 * tol / max(float(np.median(moving)), 1e-12)))
    if stride > 1:
        idx = np.unique(np.concatenate([np.arange(0, len(s_mm), stride), [len(s_mm) - 1]]))
        q_mm, s_mm = q_mm[idx], s_mm[idx]
        c = np.linalg.norm(np.diff(q_mm, axis=0), axis=1)
    ds = np.diff(s_mm)
    return float(np.sum(np.clip(c - ds - tol, 0.0, None))
                 + np.sum(np.clip(ds - FORWARD_CHORDS * c - tol, 0.0, None)))


def screen_seeds(q, geo, seeds: list[_Seed], noise: float, tol_mm: float, given) -> list[_Seed]:
    """The seeds worth refining: each is placed once, at its seed (or the given) offset, on at
    most ``SCREEN_SAMPLES`` samples; those whose median distance is within ``SCREEN_FACTOR``
    of the best (or within ``SCREEN_FLOOR_MM`` and the tolerance: a seed offset is only as
    good as the signature's grid) are kept, at most ``MAX_REFINED``, closest first. A raster
    of a CAM program matches its neighbours' shape nearly as well, but not their place."""
    if len(seeds) <= 1:
        return seeds
    stride = max(1, len(q) // SCREEN_SAMPLES)
    qs = q[::stride]
    medians = []
    for seed in seeds:
        o = seed.offset_mm if given is None else given
        tr = track(qs - o, geo, seed.s_start_mm, first_window_mm=FIRST_WINDOW_MM,
                   slack_mm=_slack_mm(noise))
        medians.append(float(np.median(tr.distance)))
    best = min(medians)
    order = sorted(range(len(seeds)), key=lambda i: medians[i])
    keep = [i for i in order if medians[i] <= max(SCREEN_FACTOR * best, SCREEN_FLOOR_MM, tol_mm)]
    return [seeds[i] for i in keep[:MAX_REFINED]]


def _evaluate(q, geo, seed: _Seed, noise, tol_mm, offset=None):
    """Refine (unless ``offset`` is given) and score one placement on every sample: the
    candidate, its places and the Hessian's eigenvalues (None for a given offset)."""
    eig = None
    if offset is None:
        o, s_first, eig = fit_offset(q, geo, seed.offset_mm, seed.s_start_mm, noise)
    else:
        o, s_first = np.asarray(offset, dtype=np.float64), seed.s_start_mm
    tr = track(q - o, geo, s_first, first_window_mm=FIRST_WINDOW_MM, slack_mm=_slack_mm(noise))
    d = tr.distance
    covered = max(float(tr.s[-1] - tr.s[0]), 0.0)
    defect = continuity_defect_mm(q, tr.s, noise)
    median = float(np.median(d))
    consistent = median <= tol_mm and defect <= max(MIN_DEFECT_MM, DEFECT_SHARE * covered)
    cand = Candidate(s_start_mm=seed.s_start_mm, signature=seed.signature, offset_mm=o,
                     rms_mm=float(np.sqrt(np.mean(d * d))), max_mm=float(d.max()),
                     median_mm=median, defect_mm=defect, consistent=consistent)
    return cand, tr, eig


def rest_offset_mm(q_mm: np.ndarray, path: Path, s_mm: np.ndarray, noise: float):
    """The offset from a recording that starts (or else ends) at rest at the program's start
    (end) point: the median of those rest samples minus the point. At rest there is no
    following error, no filter lag and no contour error, so this pins the offset better than
    any fit to the moving samples (a circle recorded with a radial deviation, a servo that cuts
    corners). ``(offset, "start" or "end")``, or ``(None, "")`` when it does not rest there."""
    tol = max(3.0 * noise, SCALE_FLOOR_MM)
    for ends_at, idx in ((0.0, np.arange(len(q_mm))),
                         (path.total_length_mm, np.arange(len(q_mm))[::-1])):
        if abs(float(s_mm[idx[0]]) - ends_at) > max(0.05, 10 * noise):
            continue
        run = np.linalg.norm(q_mm[idx] - q_mm[idx[0]], axis=1) <= tol
        n_rest = int(np.argmin(run)) if not np.all(run) else len(run)
        if n_rest >= 3:
            point = path.start_mm[0] if ends_at == 0.0 else path.end_mm[-1]
            return (np.median(q_mm[idx[:n_rest]], axis=0) - point,
                    "start" if ends_at == 0.0 else "end")
    return None, ""


def segment_shapes(path: Path) -> np.ndarray:
    """Each segment's geometry up to a translation, one row per segment: kind, start-to-end
    vector, start-to-centre vector, normal, sweep (what :func:`repeat_index` compares)."""
    d = path.end_mm - path.start_mm
    c = np.nan_to_num(path.center_mm - path.start_mm)
    return np.column_stack([path.kind, d, c, path.normal, path.sweep_rad])


def repeat_index(path: Path, k: int, tol_mm: float = 1e-6,
                 shapes: np.ndarray | None = None) -> tuple[int, int]:
    """``(n, count)``: segment ``k`` is the ``n``-th of ``count`` segments of ``path`` with the
    same geometry up to a translation (:func:`segment_shapes`, given as ``shapes`` when asked
    for many segments) -- the passes of a repeated contour."""
    f = segment_shapes(path) if shapes is None else shapes
    same = np.all(np.abs(f - f[k]) <= tol_mm, axis=1)
    index = np.flatnonzero(same)
    return int(np.searchsorted(index, k)) + 1, int(len(index))


def passes_spanned(path: Path, segments: np.ndarray, pass_index: int, n_passes: int,
                   look: int = 64) -> tuple[int, int] | None:
    """``(first, last)`` pass of a repeated contour that a recording spans (``segments``: its
    samples' segments in recording order), when it spans more than one. Blocks that are not
    repeated as often (an approach, a plunge of another depth) are passed over: the first and
    last of the ``look`` blocks nearest each end that are repeated ``n_passes`` times decide."""
    if n_passes <= 1 or len(segments) == 0:
        return None
    _, first_seen = np.unique(segments, return_index=True)
    visited = segments[np.sort(first_seen)]
    shapes = segment_shapes(path)

    def pass_of_nearest(seq) -> int:
        for k in seq[:look]:
            i, n = repeat_index(path, int(k), shapes=shapes)
            if n == n_passes:
                return i
        return pass_index

    first, last = pass_of_nearest(visited), pass_of_nearest(visited[::-1])
    return (first, last) if first != last else None


def _fits_as_well(a: Candidate, b: Candidate, noise: float) -> bool:
    tol = 1e-4 + 3.0 * noise
    return (a.rms_mm <= EQUAL_FIT * b.rms_mm + tol and a.max_mm <= EQUAL_FIT * b.max_mm + tol
            and a.defect_mm <= b.defect_mm + MIN_DEFECT_MM)


# ---------------------------------------------------------------------------------------------
# Step 3: decision
# ---------------------------------------------------------------------------------------------

def tolerance_mm(q_mm: np.ndarray, signal: str, noise: float) -> float:
    """How far a consistent registration's median distance may be: the noise (and 5 um) for
    commanded positions; for actual ones also ``ACTUAL_TOL_SHARE`` of the recording's size
    (a servo's contour error, e.g. a circle's radial deviation, is physics, not misalignment)."""
    tol = max(COMMAND_TOL_MM, NOISE_FACTOR * noise)
    if signal == "actual":
        size = float(np.max(np.ptp(q_mm, axis=0))) if len(q_mm) else 0.0
        tol = max(tol, ACTUAL_TOL_SHARE * size)
    return tol


def register(q_mm, path: Path, *, signal: str = "actual", offset_mm=None,
             offset_source: str = "given", hints: bool = True,
             length_unit: str = "mm") -> Registration:
    """Register the recorded positions ``q_mm`` (m, 3) on ``path`` (module docstring).
    ``signal`` says whether they are commanded or actual positions (the tolerance);
    ``offset_mm`` is a known work offset (recorded = program + offset), used as given;
    ``length_unit`` is the unit the positions were read in (for the hint of a refusal)."""
    q = np.ascontiguousarray(q_mm, dtype=np.float64)
    if q.ndim != 2 or q.shape[1] != 3:
        raise UsageError(f"recorded positions must be (m, 3), got {q.shape}")
    if path.n == 0 or path.total_length_mm <= 0:
        return _refused(q, signal, "the program has no motion to register the recording on")
    noise = noise_mm(q)
    extent = float(np.max(np.ptp(q, axis=0))) if len(q) else 0.0
    if len(q) < 2 or extent <= max(10.0 * noise, SCALE_FLOOR_MM):
        return _refused(q, signal, f"the recording does not move ({len(q)} samples within "
                                   f"{mm_to_um(extent):.3g} um): nothing to place on the program")
    tol = tolerance_mm(q, signal, noise)
    geo = path_geometry(path)
    seeds = signature_candidates(q, path, noise)
    given = None if offset_mm is None else np.asarray(offset_mm, dtype=np.float64)
    unit = length_unit if hints else None
    if not seeds:
        return _refused(q, signal, _refusal(q, path, signal, given, None, unit), noise=noise)
    evaluated = [_evaluate(q, geo, s, noise, tol, offset=given)
                 for s in screen_seeds(q, geo, seeds, noise, tol, given)]
    cands = [c for c, _, _ in evaluated]
    order = sorted(range(len(cands)), key=lambda i: (not cands[i].consistent,
                                                     cands[i].rms_mm + 1e-3 * cands[i].defect_mm))
    best, tr, eig = evaluated[order[0]]
    if not best.consistent:
        return _refused(q, signal, _refusal(q, path, signal, given, best, unit), noise=noise,
                        candidates=tuple(cands))
    rivals = [i for i in order[1:] if cands[i].consistent
              and np.linalg.norm(cands[i].offset_mm - best.offset_mm) > DISTINCT_OFFSET_MM
              and _fits_as_well(cands[i], best, noise)]
    source = offset_source if given is not None else "fitted"
    if given is None:
        pinned, where = rest_offset_mm(q, path, tr.s, noise)
        if pinned is not None and np.linalg.norm(pinned - best.offset_mm) <= tol:
            best = replace(best, offset_mm=pinned)
            tr = track(q - pinned, geo, float(tr.s[0]), first_window_mm=FIRST_WINDOW_MM,
                       slack_mm=_slack_mm(noise))
            source = f"fitted, at rest at the program {where}"
    mid = len(q) // 2
    pass_index, n_passes = repeat_index(path, int(tr.segment[mid]))
    k_last = int(np.argmax(tr.s))
    at_junction = 1e-3 + 3.0 * noise
    first = _place(path, float(tr.s[0]), int(tr.segment[0]), at_junction, +1)
    last = _place(path, float(tr.s[k_last]), int(tr.segment[k_last]), at_junction, -1)
    spanned_segments = tr.segment[:k_last + 1]
    if first.fraction >= 0.999:           # at rest at the end of a block: not in that pass
        spanned_segments = spanned_segments[spanned_segments != spanned_segments[0]]
    if last.fraction <= 0.001 and len(spanned_segments):
        spanned_segments = spanned_segments[spanned_segments != spanned_segments[-1]]
    spanned = passes_spanned(path, spanned_segments, pass_index, n_passes)
    common = dict(signal=signal, offset_mm=best.offset_mm, offset_source=source, s_mm=tr.s,
                  segment=tr.segment, distance_mm=tr.distance, noise_mm=noise,
                  first=first, last=last,
                  pass_index=pass_index, n_passes=n_passes, candidates=tuple(cands),
                  passes_spanned=spanned)
    if rivals:
        found = sorted([(pass_index, best.offset_mm)]
                       + [(repeat_index(path, int(evaluated[i][1].segment[mid]))[0],
                           cands[i].offset_mm) for i in rivals], key=lambda x: x[0])
        numbers = [n for n, _ in found]
        listed = ", ".join(str(n) for n in numbers[:-1]) + f" and {numbers[-1]}"
        offsets = "; ".join(_xyz(o) for _, o in found)
        msg = (f"ambiguous: passes {listed} of the program fit the recording equally "
               f"(work offsets {offsets}); give --work-offset G54=X,Y,Z (or a setup file)")
        return Registration(status="ambiguous", message=msg,
                            ambiguous_passes=tuple(numbers), **common)
    notes = []
    if eig is not None and eig[0] < 1e-6:
        notes.append("the recording is straight: its offset along the path is not fixed by "
                     "the geometry (give --work-offset)")
    reg = Registration(status="ok", message="", notes=tuple(notes), **common)
    msg = (f"registered on {_xyz(best.offset_mm)} mm ({source}), residual "
           f"{mm_to_um(reg.residual_rms_mm):.3g} um rms: {reg.covered()}")
    return replace(reg, message=msg)


def _xyz(v) -> str:
    return "(" + ", ".join(f"{float(x):.6f}" for x in v) + ")"


def _place(path: Path, s: float, k: int, tol_mm: float = 0.0, side: int = 0) -> Place:
    """The place at path length ``s`` on segment ``k``; a place within ``tol_mm`` of a
    junction is given on the segment on ``side`` of it (+1: the one that starts there, for
    the first place of a recording; -1: the one that ends there, for the last)."""
    s0 = float(path.s_start_mm[k])
    if side > 0 and k + 1 < path.n and s >= s0 + float(path.length_mm[k]) - tol_mm:
        k, s0 = k + 1, s0 + float(path.length_mm[k])
        s = max(s, s0)
    elif side < 0 and k > 0 and s <= s0 + tol_mm:
        k, s0 = k - 1, s0 - float(path.length_mm[k - 1])
        s = min(s, s0 + float(path.length_mm[k]))
    length = float(path.length_mm[k])
    frac = (s - s0) / length if length > 0 else 1.0
    file = path.file_of(k)
    line = int(path.line[k])
    return Place(s_mm=float(s), segment=k, file=file, line=line,
                 fraction=float(min(max(frac, 0.0), 1.0)), text=block_text(file, line))


@lru_cache(maxsize=16)
def _source_lines(file: str) -> tuple[str, ...]:
    try:
        with open(file, encoding="utf-8-sig", errors="replace") as fh:
            return tuple(fh.read().splitlines())
    except OSError:
        return ()


def block_text(file: str, line: int) -> str:
    """The NC block at ``file:line`` without its comment ('' when the file cannot be read)."""
    lines = _source_lines(file)
    if not 1 <= line <= len(lines):
        return ""
    return lines[line - 1].split(";")[0].strip()


def _refused(q, signal, message, *, noise=0.0, candidates=()) -> Registration:
    m = len(q)
    return Registration(status="refused", message=message, signal=signal,
                        offset_mm=np.zeros(3), offset_source="", s_mm=np.zeros(m),
                        segment=np.zeros(m, dtype=np.int64), distance_mm=np.zeros(m),
                        noise_mm=noise, first=None, last=None, pass_index=0, n_passes=0,
                        candidates=tuple(candidates))


#: length units tried on refused positions, most likely first
HINT_UNITS = ("mm", "um", "in", "m", "nm")


def _refusal(q, path, signal, given, best: Candidate | None, unit) -> str:
    """The one-line reason a recording cannot be registered, with what to check (``unit``: the
    length unit the positions were read in, or None for no unit and axis trials)."""
    what = "commanded" if signal == "command" else "recorded"
    if given is not None:
        free = register(q, path, signal=signal, hints=False)
        if free.status != "refused":
            return (f"the {what} positions do not follow the program at the given work offset "
                    f"{_xyz(given)} (they do at {_xyz(free.offset_mm)}): check --work-offset "
                    "or the setup file")
    if unit:
        read = FACTORS["length"].get(unit, 1.0)
        for other in HINT_UNITS:
            factor = FACTORS["length"][other] / read
            if other == unit or not math.isfinite(factor):
                continue
            if register(q * factor, path, signal=signal, hints=False).status != "refused":
                return (f"the {what} positions do not follow the program as read ({unit}), but "
                        f"do when scaled by {factor:g}: they look like {other}, give "
                        f"--unit pos={other}")
        for perm in permutations(range(3)):
            if perm == (0, 1, 2):
                continue
            if register(q[:, perm], path, signal=signal, hints=False).status != "refused":
                names = "xyz"
                swapped = ", ".join(f"{names[i]} is the file's {names[p]} column"
                                    for i, p in enumerate(perm) if i != p)
                return (f"the {what} positions follow the program only with the axes swapped "
                        f"({swapped}): check --column x=/y=/z=")
    if best is None:
        detail = "its shape matches no stretch of the program"
    else:
        detail = (f"best fit {mm_to_um(best.median_mm):.4g} um median distance, "
                  f"{mm_to_um(best.rms_mm):.4g} um rms, at offset {_xyz(best.offset_mm)}")
    return (f"the {what} positions do not follow the program ({detail}): wrong program, unit "
            "(--unit pos=...), columns (--column x=...) or work offset (--work-offset)?")


# ---------------------------------------------------------------------------------------------
# Plausibility of the clock
# ---------------------------------------------------------------------------------------------

RATE_LIMIT = 100.0   # feeds 100 x slower or faster than programmed: a unit, not an override


def rate_problem(t_s, q_mm, path: Path, reg: Registration) -> str | None:
    """Why the recording's clock cannot be right, or None: on the feed (not rapid) blocks it
    covers, the recorded path speed (central differences of the positions) against the
    programmed feed. An override (840D: 0..120 %, at most 200 %) scales it by a factor of a
    few; a factor over ``RATE_LIMIT`` is a time column in another unit (ms read as s)."""
    t = np.asarray(t_s, dtype=np.float64)
    q = np.asarray(q_mm, dtype=np.float64)
    if len(t) < 5 or reg.first is None:
        return None
    seg = reg.segment
    feed = path.feed_mm_s[seg]
    on_feed = ~path.rapid[seg] & np.isfinite(feed) & (feed > 0)
    on_feed[[0, -1]] = False
    idx = np.nonzero(on_feed)[0]
    if len(idx) < 5:
        return None
    speed = np.linalg.norm(q[idx + 1] - q[idx - 1], axis=1) / (t[idx + 1] - t[idx - 1])
    ratio = speed / feed[idx]
    typical = float(np.percentile(ratio, 90))
    if 1.0 / RATE_LIMIT <= typical <= RATE_LIMIT:
        return None
    k = int(np.bincount(seg[idx]).argmax())
    where = f"{os.path.basename(path.file_of(k))}:{int(path.line[k])}"
    if typical <= 0:
        how = "does not move on the feed blocks it covers"
    else:
        how = (f"runs {1.0 / typical:.3g} times slower" if typical < 1
               else f"runs {typical:.3g} times faster") + (
            f" than the programmed feeds (F{mm_s_to_mm_min(float(path.feed_mm_s[k])):g} at "
            f"{where})")
    units = FACTORS["time"]
    best = min(units, key=lambda u: abs(math.log(units[u] / typical))) if typical > 0 else None
    if best is not None and best != "s" and abs(math.log(units[best] / typical)) < math.log(3.0):
        fix = f"the time looks like {best} read as s: give --unit t={best}"
    else:
        fix = "check the time unit (--unit t=...) or --sample-period-ms"
    return f"the recorded motion {how}: {fix}"
