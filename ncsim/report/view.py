"""What a run figure shows: the cutting moves, the zoom window, the scales and the notes.

Pure decisions that :func:`ncsim.report.plot.run_figure` draws; each works from a
:class:`~ncsim.motion.Trace` and, when there is one, the planned :class:`~ncsim.motion.Motion`.

* **Cutting moves first.** A sample is a rapid when its programmed feed is infinite (G0); a
  trace read from CSV without the ``programmed_mm_min`` column cannot tell, and every sample
  counts as cutting. Scales come from the cutting moves: the feed axis from the programmed
  feeds (``feed_top_mm_s``), the XY view from the cutting samples (``xy_limits``); rapids are
  drawn thin and grey over them (``--rapids show``) or not at all (``hide``).
* **Zoom.** ``--range`` takes source lines ``120:340``, N numbers ``N1200:N3400`` or seconds
  ``12.5s:20s`` (a side may be left open, ``all`` is the whole run); :func:`window_for` turns it
  into a time window from the blocks it names (the first one's start to the last one's end).
* **Block labels** are the blocks' N numbers when the program has them (read from the source
  line of each block, :func:`block_numbers`), else their line numbers.
* **Robust dynamics scale** (:func:`robust_span`): BRISK blocks step the acceleration within
  one interpolation cycle (jerk A / t_cy, some 200-300 m/s^3 on the MIKRON), which would make
  the jerk panel a solid block; beyond a few times the jerk the machine allows, the values are
  clipped at the panel's edge and marked there.
* **Why an axis jerk exceeds its limit** (:func:`jerk_notes`): on arcs, the NCU sets the steady
  feed by its path jerk J_tcurv = J_curv x r_jct (paper eq. 10-11), at which the direction
  change alone gives each axis up to V^3/R^2 = J_tcurv (eq. 3) -- 6 m/s^3 on the MIKRON, above
  its 5 m/s^3 axis jerk J_mi, as the paper measured (section 5.2.4); while the feed ramps on an
  arc, the ramp's tangential jerk adds to it. That is the model, not a fault, and the figure
  says so; an excess anywhere else is reported as unexpected.
"""
from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from ncsim.errors import UsageError
from ncsim.motion import Trace
from ncsim.units import mm_s3_to_m_s3

RAPIDS = ("show", "hide")
FEED_HEADROOM = 1.15      # feed axis top = this x the largest programmed (or reached) cutting feed
XY_MARGIN = 0.06          # XY view margin, share of the cutting moves' larger extent
CLIP_FACTOR = 3.0         # dynamics beyond this x the reference scale are clipped ...
CLIP_SPAN = 2.5           # ... at this x the reference scale
_EXCESS_REL = 1e-6        # an axis jerk above J_mi (1 + this) exceeds it


# ---------------------------------------------------------------------------------------------
# Cutting moves and rapids
# ---------------------------------------------------------------------------------------------

def rapid_mask(trace: Trace) -> np.ndarray:
    """True on G0 samples (infinite programmed feed); a NaN programmed feed (unknown) is not
    a rapid."""
    return np.isinf(np.asarray(trace.programmed_mm_s, dtype=np.float64))


def rapids_known(trace: Trace) -> bool:
    """Whether the trace can tell rapids from cutting moves (it has programmed feeds)."""
    return bool(len(trace)) and not np.all(np.isnan(trace.programmed_mm_s))


def feed_top_mm_s(trace: Trace, cut: np.ndarray) -> float:
    """Top of the feed axis: FEED_HEADROOM x the largest programmed feed or reached feed of the
    cutting samples (all samples when none cuts); 1 mm/min at least."""
    sel = cut if np.any(cut) else np.ones(len(trace), dtype=bool)
    values = np.concatenate([trace.programmed_mm_s[sel], trace.feed_mm_s[sel]])
    values = values[np.isfinite(values)]
    top = float(values.max()) if len(values) else 0.0
    return FEED_HEADROOM * max(top, 1.0 / 60.0)


def xy_limits(trace: Trace, cut: np.ndarray) -> tuple[tuple[float, float], tuple[float, float]] | None:
    """X and Y ranges around the cutting samples (all samples when none cuts), with a margin
    of XY_MARGIN of the larger extent; None when there is no finite position."""
    sel = cut if np.any(cut) else np.ones(len(trace), dtype=bool)
    xy = trace.pos_mm[sel, :2]
    xy = xy[np.all(np.isfinite(xy), axis=1)]
    if not len(xy):
        return None
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    pad = max(XY_MARGIN * float((hi - lo).max()), 0.05)
    return (float(lo[0] - pad), float(hi[0] + pad)), (float(lo[1] - pad), float(hi[1] + pad))


def cutting_length_mm(trace: Trace, motion=None) -> np.ndarray:
    """Path length travelled on cutting moves only, at every sample (rapids add nothing):
    exact from the blocks when the motion is known, else summed over the samples."""
    if motion is not None and motion.path.n:
        path = motion.path
        cut_len = np.where(path.rapid, 0.0, path.length_mm)
        knots = np.concatenate([[0.0], np.cumsum(path.length_mm)])
        return np.interp(trace.s_mm, knots, np.concatenate([[0.0], np.cumsum(cut_len)]))
    s = np.asarray(trace.s_mm, dtype=np.float64)
    if not len(s):
        return s
    cut = ~rapid_mask(trace)
    ds = np.where(cut[1:] & np.isfinite(np.diff(s)), np.diff(s), 0.0)
    return np.concatenate([[0.0], np.cumsum(ds)])


def part_outline_xy(motion, samples: int = 20_000) -> np.ndarray:
    """The XY of every cutting move of the whole run (rapids as NaN breaks), about ``samples``
    points: the part drawn faintly behind a zoomed view."""
    from ncsim.plan.sample import sample_motion

    total = motion.total_time_s
    if not motion.path.n or total <= 0:
        return np.zeros((0, 2))
    trace = sample_motion(motion, total / samples)
    xy = trace.pos_mm[:, :2].copy()
    xy[rapid_mask(trace)] = np.nan
    return xy


# ---------------------------------------------------------------------------------------------
# Block labels and the zoom window
# ---------------------------------------------------------------------------------------------

_N_WORD = re.compile(r"^\s*(?:/\d?\s*)?N(\d+)\b", re.IGNORECASE)


def block_numbers(path) -> np.ndarray:
    """The N number of each block's source line (-1 where the line has none or the file
    cannot be read again), e.g. 1230 for ``N1230 G1 X10``."""
    from ncsim.nc.parse import read_program_text

    out = np.full(path.n, -1, dtype=np.int64)
    for k, name in enumerate(path.files):
        sel = np.flatnonzero(path.file_index == k)
        if not len(sel):
            continue
        try:
            lines = read_program_text(name).replace("\r\n", "\n").replace("\r", "\n").split("\n")
        except Exception:  # noqa: BLE001 - a file given as text, or gone: no N labels
            continue
        numbers = np.full(len(lines) + 2, -1, dtype=np.int64)
        for i, text in enumerate(lines, 1):
            m = _N_WORD.match(text)
            if m:
                numbers[i] = int(m.group(1))
        line = np.clip(path.line[sel].astype(np.int64), 0, len(numbers) - 1)
        out[sel] = numbers[line]
    return out


def block_labels(lines: np.ndarray, numbers: np.ndarray | None) -> list[str]:
    """``N1230`` where the block has an N number, else ``line 123``."""
    if numbers is None:
        return [f"line {int(v)}" for v in lines]
    return [f"N{int(n)}" if n >= 0 else f"line {int(v)}" for v, n in zip(lines, numbers)]


@dataclass(frozen=True, slots=True)
class RangeSpec:
    kind: str                 # "all", "line", "n" or "time"
    lo: float | None
    hi: float | None
    text: str


_SIDE = re.compile(r"^\s*(?:(?P<n>[Nn])(?P<nv>\d+)|(?P<t>\d+(?:\.\d*)?|\.\d+)\s*s|(?P<l>\d+))\s*$")


def parse_range(text: str) -> RangeSpec:
    """``--range``: ``LINE1:LINE2``, ``N1:N2`` (N numbers), ``T1s:T2s`` (seconds) or ``all``;
    either side may be empty (open). A bad value is one UsageError line."""
    raw = text.strip()
    if raw.lower() == "all":
        return RangeSpec("all", None, None, raw)
    bad = UsageError(f"--range {text!r}: expected LINE1:LINE2, N1:N2 (N numbers), T1s:T2s "
                     f"(seconds) or all, e.g. 120:340, N1200:N3400, 12.5s:20s")
    if raw.count(":") != 1:
        raise bad
    kinds, values = set(), []
    for side in raw.split(":"):
        if not side.strip():
            values.append(None)
            continue
        m = _SIDE.match(side)
        if not m:
            raise bad
        kind = "n" if m.group("n") else "time" if m.group("t") else "line"
        kinds.add(kind)
        values.append(float(m.group("nv") or m.group("t") or m.group("l")))
    if len(kinds) != 1:
        raise bad
    lo, hi = values
    if lo is not None and hi is not None and hi < lo:
        raise UsageError(f"--range {text!r}: the end comes before the start")
    return RangeSpec(kinds.pop(), lo, hi, raw)


@dataclass(frozen=True, slots=True)
class Window:
    t0_s: float
    t1_s: float
    label: str                # what the title says, e.g. "lines 120-340, t = 4.20-9.81 s"


def _blocks(motion, trace: Trace):
    """Per block: start time, end time, line, file index (from the motion, else the trace)."""
    if motion is not None and motion.path.n:
        p = motion.path
        return (np.asarray(motion.t_start_s), np.asarray(motion.t_end_s), p.line.astype(np.int64),
                p.file_index.astype(np.int64))
    block = trace.block
    ok = block >= 0
    if not np.any(ok):
        raise UsageError("--range by line needs the trace's block and line columns (or use seconds)")
    b, t, line = block[ok], trace.t_s[ok], trace.line[ok]
    start = np.concatenate([[0], np.flatnonzero(np.diff(b) != 0) + 1])
    end = np.concatenate([start[1:], [len(b)]]) - 1
    return t[start], t[end], line[start].astype(np.int64), np.zeros(len(start), dtype=np.int64)


def window_for(spec: RangeSpec | None, trace: Trace | None, motion=None,
               numbers: np.ndarray | None = None) -> Window | None:
    """The time window ``spec`` names (None: the whole run), from the motion's blocks, or from
    the trace's block and line columns when there is no motion. Lines and N numbers select the
    blocks of the main program (file 0) when it has any in the range, else of any file."""
    if spec is None or spec.kind == "all":
        return None
    if motion is not None:
        t_end = motion.total_time_s
    else:
        t_end = float(trace.t_s[-1]) if len(trace) else 0.0
    if spec.kind == "time":
        t0 = 0.0 if spec.lo is None else spec.lo
        t1 = t_end if spec.hi is None else min(spec.hi, t_end)
        if t0 >= t1:
            raise UsageError(f"--range {spec.text}: the run lasts {t_end:.3f} s")
        return Window(t0, t1, f"t = {t0:.2f}-{t1:.2f} s")
    t_start, t_stop, line, file_index = _blocks(motion, trace)
    if spec.kind == "n":
        if motion is None:
            raise UsageError(f"--range {spec.text}: a trace has no N numbers (give source lines "
                             f"or seconds, or plot the PROGRAM)")
        if numbers is None or not np.any(numbers >= 0):
            raise UsageError(f"--range {spec.text}: the program has no N numbers (give lines or seconds)")
        key, what = numbers, "N"
    else:
        key, what = line, "lines"
    lo = -np.inf if spec.lo is None else spec.lo
    hi = np.inf if spec.hi is None else spec.hi
    hit = (key >= lo) & (key <= hi)
    main = hit & (file_index == 0)
    hit = main if np.any(main) else hit
    if not np.any(hit):
        raise UsageError(f"--range {spec.text}: no block of the program on {what} {spec.text}")
    t0, t1 = float(t_start[hit].min()), float(t_stop[hit].max())
    if t1 <= t0:   # zero-length blocks only: show the moment with a little room
        t0, t1 = max(t0 - 0.05, 0.0), t1 + 0.05
    name = spec.text if spec.kind == "n" else f"lines {spec.text}"
    return Window(t0, t1, f"{name}, t = {t0:.2f}-{t1:.2f} s")


def window_samples(trace: Trace, window: Window | None) -> np.ndarray:
    """Indices of the samples inside the window (with one sample either side, so lines run
    to the edges)."""
    if window is None:
        return np.arange(len(trace))
    t = trace.t_s
    i0 = max(int(np.searchsorted(t, window.t0_s, side="left")) - 1, 0)
    i1 = min(int(np.searchsorted(t, window.t1_s, side="right")) + 1, len(t))
    return np.arange(i0, i1)


# ---------------------------------------------------------------------------------------------
# Dynamics panels
# ---------------------------------------------------------------------------------------------

def robust_span(peak: float, reference: float | None, shown_limits=()) -> tuple[float, bool]:
    """Half-height of a dynamics panel, and whether values beyond it are clipped.

    The data set the scale unless they exceed CLIP_FACTOR x ``reference`` (the limit a reader
    compares them with); then the panel spans CLIP_SPAN x ``reference`` (and the limits shown
    within it) and what lies beyond is clipped and marked."""
    shown = [v for v in shown_limits if np.isfinite(v)]
    if reference is None or not reference > 0 or not peak > CLIP_FACTOR * reference:
        return 1.12 * max([peak, *shown]), False
    span = max([CLIP_SPAN * reference, *[v for v in shown if v <= CLIP_SPAN * reference]])
    return 1.12 * span, True


def jerk_reference_mm_s3(machine, moving) -> float | None:
    """The jerk a reader compares the jerk panel with: the smallest jerk limit of the moving
    axes, or the NCU's path jerk J_tcurv (eq. 10) if larger."""
    if machine is None:
        return None
    limits = [float(j) for j, mv in zip(machine.max_jerk_mm_s3, moving) if mv]
    if not limits:
        return None
    return max(min(limits), float(machine.ncu.tangential_jerk_mm_s3))


def jerk_notes(trace: Trace, motion, machine, moving) -> list[str]:
    """Why axis jerks exceed their limits J_mi, in the paper's terms (module docstring)."""
    if machine is None or not len(trace):
        return []
    from ncsim.path import ARC, SOFT

    jerk = np.abs(np.asarray(trace.jerk_mm_s3, dtype=np.float64))
    limit = np.asarray(machine.max_jerk_mm_s3, dtype=np.float64)
    excess = np.isfinite(jerk) & (jerk > limit * (1 + _EXCESS_REL)) & np.asarray(moving)[None, :]
    if not excess.any():
        return []
    j_tcurv = float(machine.ncu.tangential_jerk_mm_s3)
    names = ("X", "Y", "Z")
    arc = soft = None
    if motion is not None and motion.path.n:
        block = np.clip(trace.block, 0, motion.path.n - 1)
        arc = motion.path.kind[block] == ARC
        mode = motion.path.accel_mode[block] if motion.options.accel_mode is None \
            else np.full(len(block), motion.options.accel_mode)
        soft = mode == SOFT
    notes = []
    if arc is None:   # a trace without its program: the rule, without telling arcs apart
        axes = [i for i in range(3) if excess[:, i].any()]
        if any(j_tcurv > limit[i] for i in axes):
            notes.append(_rule_note(axes, jerk, excess, limit, j_tcurv, names, "on arcs"))
        return notes
    on_arcs = excess & (arc & soft)[:, None]
    if on_arcs.any():
        axes = [i for i in range(3) if on_arcs[:, i].any()]
        notes.append(_rule_note(axes, jerk, on_arcs, limit, j_tcurv, names, "on arcs"))
    brisk = excess & ~soft[:, None]
    if brisk.any():
        notes.append("BRISK/DRIVE blocks step the acceleration within one IPO cycle "
                     "(jerk = A / t_cy): their jerk is not limited")
    other = excess & (soft & ~arc)[:, None]
    if other.any():
        k = int(np.flatnonzero(other.any(axis=1))[0])
        axes = ", ".join(names[i] for i in range(3) if other[:, i].any())
        notes.append(f"unexpected: {axes} jerk above J_mi on a line at t = {trace.t_s[k]:.3f} s "
                     f"(line {int(trace.line[k])})")
    return notes


def _rule_note(axes, jerk, mask, limit, j_tcurv, names, where: str) -> str:
    peaks = ", ".join(f"{names[i]} {mm_s3_to_m_s3(jerk[mask[:, i], i].max()):.3g}" for i in axes)
    lim = ", ".join(sorted({f"{mm_s3_to_m_s3(limit[i]):g}" for i in axes}))
    text = f"axis jerk above J_mi = {lim} m/s³ {where} (up to {peaks} m/s³): "
    if any(j_tcurv > limit[i] for i in axes):
        text += (f"the NCU's path jerk J_tcurv = J_curv·r_jct = {mm_s3_to_m_s3(j_tcurv):g} m/s³ "
                 f"> J_mi (paper eq. 10) sets the steady feed, where V³/R² = J_tcurv (eq. 3, 11); "
                 f"ramps add their own jerk. The 840D model, not a fault")
    else:
        text += "while the feed ramps on an arc its tangential jerk adds to V³/R² (eq. 3)"
    return text


# ---------------------------------------------------------------------------------------------
# Whole programs: shading, operations, labels
# ---------------------------------------------------------------------------------------------

SHADE_BINS = 360          # slices of a panel's width: a shaded run is at least one slice wide


def _slices(x: np.ndarray, bins: int) -> tuple[float, float, np.ndarray]:
    """The slice (0 .. bins-1) of each sample interval of ``x`` (by its middle), the span's
    start and the slice width."""
    lo, width = float(x[0]), (float(x[-1]) - float(x[0])) / bins
    mid = 0.5 * (x[:-1] + x[1:])
    return lo, width, np.clip(((mid - lo) // width).astype(np.int64), 0, bins - 1)


def _carry(values: np.ndarray, filled: np.ndarray) -> np.ndarray:
    """``values`` with the unfilled entries taken from the filled one before (the first
    filled one at the start)."""
    idx = np.where(filled, np.arange(len(values)), -1)
    np.maximum.accumulate(idx, out=idx)
    first = int(np.argmax(filled)) if filled.any() else 0
    return values[np.where(idx >= 0, idx, first)]


def dominant_runs(x: np.ndarray, codes: np.ndarray, bins: int = SHADE_BINS,
                  weights: np.ndarray | None = None, floor: tuple[int, float] | None = None
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(x_lo, x_hi, code)`` of the background shading: the span of ``x`` cut into ``bins``
    equal slices, each given the code that holds it longest (each sample interval ``i`` counts
    its length in ``x``, or ``weights[i]``: e.g. the time it loses), then equal neighbours
    joined. A whole program's thousands of short limit changes become runs a reader can see
    (a slice without samples keeps the code before it). With ``floor = (code, share)`` a slice
    whose weights add to less than ``share`` of its length gets ``code`` (e.g. ``programmed``
    where little time is lost)."""
    x = np.asarray(x, dtype=np.float64)
    codes = np.asarray(codes, dtype=np.int64)
    if len(x) < 2 or not x[-1] > x[0]:
        return np.zeros(0), np.zeros(0), np.zeros(0, dtype=np.int64)
    lo, width, slot = _slices(x, bins)
    dx = np.diff(x)
    w = dx if weights is None else np.asarray(weights, dtype=np.float64)[:len(dx)]
    kinds, code_index = np.unique(codes[:-1], return_inverse=True)
    held = np.bincount(slot * len(kinds) + code_index, weights=w,
                       minlength=bins * len(kinds)).reshape(bins, len(kinds))
    win = kinds[held.argmax(axis=1)]
    if floor is not None:
        length = np.bincount(slot, weights=dx, minlength=bins)
        win = np.where(held.sum(axis=1) < floor[1] * length, floor[0], win)
    win = _carry(win, np.bincount(slot, minlength=bins) > 0)
    change = np.flatnonzero(np.diff(win) != 0) + 1
    start = np.concatenate([[0], change])
    end = np.concatenate([change, [bins]])
    return lo + start * width, lo + end * width, win[start]


def slice_feeds(t: np.ndarray, feed: np.ndarray, bins: int = SHADE_BINS):
    """Per slice of the time span (``bins`` of them): its middle time, the mean feed (path
    length over time) and the lowest and highest feed reached (NaN feeds, e.g. rapids, left
    out; a slice without any gives NaN). A whole program's feed, block after block from 0
    to F and back, reads as its mean within its range."""
    t = np.asarray(t, dtype=np.float64)
    f = np.asarray(feed, dtype=np.float64)
    nan = np.full(bins, np.nan)
    if len(t) < 2 or not t[-1] > t[0]:
        return nan, nan, nan, nan
    lo, width, slot = _slices(t, bins)
    mid_f = 0.5 * (f[:-1] + f[1:])
    ok = np.isfinite(mid_f)
    dt = np.diff(t)[ok]
    covered = np.bincount(slot[ok], weights=dt, minlength=bins)
    path = np.bincount(slot[ok], weights=mid_f[ok] * dt, minlength=bins)
    mean = np.divide(path, covered, out=nan.copy(), where=covered > 0)
    low, high = nan.copy(), nan.copy()
    fs = np.where(np.isfinite(f), f, np.nan)
    idx = np.clip(((t - lo) // width).astype(np.int64), 0, bins - 1)
    valid = np.isfinite(fs)
    np.fmin.at(low, idx[valid], fs[valid])
    np.fmax.at(high, idx[valid], fs[valid])
    return lo + (np.arange(bins) + 0.5) * width, mean, low, high


def operation_spans(motion) -> list[tuple[float, float, str]]:
    """``(t_start, t_end, name)`` of each stretch of consecutive blocks in one CAM operation,
    in execution order (blocks outside any operation left out)."""
    path = motion.path
    if not path.n or not path.operations:
        return []
    op = path.operation
    change = np.flatnonzero(np.diff(op) != 0) + 1
    starts = np.concatenate([[0], change])
    ends = np.concatenate([change, [path.n]])
    return [(float(motion.t_start_s[a]), float(motion.t_end_s[b - 1]), path.operations[int(op[a])])
            for a, b in zip(starts.tolist(), ends.tolist()) if op[a] >= 0]


def label_rows(x: np.ndarray, widths: np.ndarray, rows: int) -> np.ndarray:
    """The row (0 .. rows-1) of each label starting at ``x`` and ``widths`` wide, so that no
    two overlap; -1 for a label with no room in any row (it is left out)."""
    out = np.full(len(x), -1, dtype=np.int64)
    free = [-np.inf] * rows
    for i in np.argsort(x, kind="stable").tolist():
        for r in range(rows):
            if x[i] >= free[r]:
                out[i] = r
                free[r] = x[i] + widths[i]
                break
    return out


def feed_ratio(trace: Trace) -> np.ndarray:
    """Reached over programmed feed at each sample (NaN on rapids and where none is
    programmed): where the program runs slower than its F words say."""
    prog = np.asarray(trace.programmed_mm_s, dtype=np.float64)
    ok = np.isfinite(prog) & (prog > 0)
    out = np.full(len(trace), np.nan)
    np.divide(trace.feed_mm_s, prog, out=out, where=ok)
    return out
