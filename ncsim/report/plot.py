"""Figures: a simulated run (``ncsim plot``) and a machine's feed limits (``ncsim explain --plot``).

:func:`run_figure` draws a :class:`~ncsim.motion.Trace` (plus the planned
:class:`~ncsim.motion.Motion` when there is one) as up to five panels, built for a machinist
reading a real program: the cutting moves set every scale, rapids are thin and grey (or hidden),
and what is shown comes from ``report.view``:

1. ``feed_time``  feed against time: programmed F, set point (eq. 12), reached feed of the
   cutting moves; the axis goes to 1.15 x the largest programmed cutting feed (rapids run off
   the top, and the panel says how fast they go); the background is shaded by the limit
   holding the feed (``motion.Limit`` labels, legend at the top), grey where a rapid runs;
   thin grey vertical lines mark block boundaries, labelled by N number (or source line) when
   there are few;
2. ``feed_path``  the same feeds against the *cutting* path length (rapids take no length);
3. ``xy_path``    the XY projection coloured by the share of the programmed feed reached
   (``view.feed_ratio``: red far below F, green at F), the view framed on the cutting moves
   (equal aspect), rapids as thin grey lines, block boundaries as dots;
4. ``accel``      tangential and per-axis acceleration (m/s^2) against time, with the axes'
   limits dashed (when the machine is known);
5. ``jerk``       tangential and per-axis jerk (m/s^3) likewise, on a robust scale: values far
   beyond the machine's jerk (BRISK blocks) are clipped at the edge and marked there, and a
   note says why an axis jerk may exceed its limit (the paper's eq. 10 rule,
   ``view.jerk_notes``).

A whole program of more than MAX_BOUNDARIES blocks is drawn as an overview instead
(``report.overview``: feeds per slice by CAM operation, time by operation, XY and side views).
The background shading is merged into runs a reader can see (``view.dominant_runs``); notes
go under the bottom panel, below its axis label. Feeds are drawn in one unit (``feed_unit``,
mm/min by default). A window (``view.Window``,
from ``--range``) zooms every panel to a time span. A trace read from CSV may lack columns;
the panels that need them are left out and :attr:`RunFigure.missing` says which columns each
one needs. Only matplotlib's object API and the Agg canvas are used (no pyplot, no global
state), and files are written without dates, so the same input gives the same file.
"""
from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np
from matplotlib import rc_context
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.gridspec import GridSpec
from matplotlib.lines import Line2D

from ncsim.errors import UsageError
from ncsim.motion import Limit
from ncsim.motion import Trace
from ncsim.report import view
from ncsim.report.drawing import (AXIS_COLORS, AXIS_NAMES, HIDDEN_CODE, RAPID_CODE, RAPID_COLOR,
                                  feed_lines, feeds_of, finite_any, footer, frame, legend_above,
                                  limit_legend, path_view, ratio_colorbar, runs, shade_limits)
from ncsim.units import feed_from_mm_s, mm_min_to_mm_s, mm_s2_to_m_s2, mm_s3_to_m_s3

FIGSIZE_IN = (16.0, 10.0)
DPI = 100                        # so a PNG is 1600 x 1000 pixels
MAX_BOUNDARIES = 400             # block boundaries drawn at most (else a note says so)
MAX_LINE_LABELS = 30             # labels written at the boundaries at most
DENSE_BLOCKS = 100               # more blocks in view: thinner lines
MAX_PLOT_SAMPLES = 200_000       # longer traces are thinned (every k-th sample) for drawing
FORMATS = ("png", "svg", "pdf")
PANELS = ("feed_time", "feed_path", "xy_path", "accel", "jerk")
PANEL_YLABELS = {
    "feed_time": "feed (mm/min)",
    "feed_path": "feed (mm/min)",
    "xy_path": "Y (mm)",
    "accel": "acceleration (m/s²)",
    "jerk": "jerk (m/s³)",
}
PANEL_NEEDS = {   # CSV columns a panel needs (any one of a group in brackets)
    "feed_time": "t_s, feed_mm_min",
    "feed_path": "s_mm, feed_mm_min",
    "xy_path": "x_mm, y_mm, feed_mm_min",
    "accel": "accel_t_mm_s2 or ax_mm_s2/ay_mm_s2/az_mm_s2",
    "jerk": "jerk_t_mm_s3 or jx_mm_s3/jy_mm_s3/jz_mm_s3",
}



@dataclass(frozen=True)
class RunFigure:
    figure: Figure
    panels: tuple[str, ...]          # drawn, in PANELS order
    missing: dict[str, str]          # panel left out -> the columns it needs
    notes: tuple[str, ...]           # anything else the reader should know (thinning...)
    axes: dict | None = None         # panel name -> its matplotlib Axes (for tests and callers)
    clipped: dict | None = None      # panel -> number of samples clipped at its edge


# ---------------------------------------------------------------------------------------------
# What can be drawn
# ---------------------------------------------------------------------------------------------

def available_panels(trace: Trace) -> tuple[list[str], dict[str, str]]:
    """The panels ``trace`` has data for, and for the others the columns they need."""
    has = {
        "feed_time": finite_any(trace.t_s) and finite_any(trace.feed_mm_s),
        "feed_path": finite_any(trace.s_mm) and finite_any(trace.feed_mm_s),
        "xy_path": (finite_any(trace.pos_mm[:, 0]) and finite_any(trace.pos_mm[:, 1])
                    and finite_any(trace.feed_mm_s)),
        "accel": finite_any(trace.accel_t_mm_s2) or finite_any(trace.acc_mm_s2),
        "jerk": finite_any(trace.jerk_t_mm_s3) or finite_any(trace.jerk_mm_s3),
    }
    if len(trace) == 0:
        has = dict.fromkeys(has, False)
    return [p for p in PANELS if has[p]], {p: PANEL_NEEDS[p] for p in PANELS if not has[p]}


# ---------------------------------------------------------------------------------------------
# Helpers
# ---------------------------------------------------------------------------------------------

def _boundaries(ax, x: np.ndarray, labels: list[str] | None) -> None:
    if len(x) == 0:
        return
    ax.vlines(x, 0.0, 1.0, transform=ax.get_xaxis_transform(), colors="0.45", linewidths=0.6,
              alpha=0.7, zorder=1)
    if labels is not None and len(x) <= MAX_LINE_LABELS:
        for xi, text in zip(x, labels):
            ax.text(xi, 0.99, f" {text}", transform=ax.get_xaxis_transform(),
                    rotation=90, va="top", ha="left", fontsize=7, color="0.3", zorder=5)


def _thin(trace: Trace, max_samples: int) -> tuple[np.ndarray, int]:
    """Indices of the samples drawn (every k-th, and the last), and k."""
    if len(trace) <= max_samples:
        return np.arange(len(trace)), 1
    step = int(np.ceil(len(trace) / max_samples))
    idx = np.arange(0, len(trace), step)
    if idx[-1] != len(trace) - 1:
        idx = np.append(idx, len(trace) - 1)
    return idx, step


@dataclass(frozen=True)
class _Bounds:
    """Block starts inside the view: time, cutting length, XY, label, and whether it cuts."""
    t: np.ndarray
    s_cut: np.ndarray
    xy: np.ndarray
    labels: list[str]
    cutting: np.ndarray


def _block_starts(trace: Trace, motion, numbers, s_cut: np.ndarray) -> _Bounds:
    """Block boundaries inside the trace's time span, from the motion when there is one, else
    where the trace's block column changes. The first block of the view has no boundary."""
    if motion is not None and motion.path.n:
        path = motion.path
        t = np.asarray(motion.t_start_s)
        keep = (t > trace.t_s[0]) & (t < trace.t_s[-1]) if len(trace) else np.zeros(len(t), bool)
        knots = np.concatenate([[0.0], np.cumsum(np.where(path.rapid, 0.0, path.length_mm))])
        lines = path.line[keep]
        return _Bounds(t[keep], knots[:-1][keep], np.asarray(path.start_mm[keep, :2]),
                       view.block_labels(lines, None if numbers is None else numbers[keep]),
                       ~path.rapid[keep])
    block = trace.block
    if len(block) == 0 or np.all(block < 0):
        empty = np.zeros(0)
        return _Bounds(empty, empty, np.zeros((0, 2)), [], np.zeros(0, bool))
    i = np.flatnonzero(np.diff(block) != 0) + 1
    return _Bounds(trace.t_s[i], s_cut[i], trace.pos_mm[i, :2], view.block_labels(trace.line[i], None),
                   ~view.rapid_mask(trace)[i])


# ---------------------------------------------------------------------------------------------
# The run figure
# ---------------------------------------------------------------------------------------------

def _layout(fig: Figure, panels: list[str]) -> dict[str, object]:
    """Time panels stacked on the left (sharing the time axis), path panels on the right."""
    left = [p for p in ("feed_time", "accel", "jerk") if p in panels]
    right = [p for p in ("xy_path", "feed_path") if p in panels]
    rows = 6
    cols = 2 if left and right else 1
    gs = GridSpec(rows, cols, figure=fig, width_ratios=[3, 2] if cols == 2 else [1],
                  left=0.055, right=0.945, bottom=0.125, top=0.85, hspace=1.5, wspace=0.16)
    axes: dict[str, object] = {}
    share = None
    for column, names in ((0, left), (cols - 1, right)):
        if not names:
            continue
        span = rows // len(names)
        for k, name in enumerate(names):
            ax = fig.add_subplot(gs[k * span:(k + 1) * span, column],
                                 sharex=share if name in ("feed_time", "accel", "jerk") else None)
            if name in ("feed_time", "accel", "jerk") and share is None:
                share = ax
            axes[name] = ax
    return axes


def _axis_limit_lines(ax, peak: float, limits, moving, reference=None) -> tuple[bool, float, bool]:
    """Dashed +-limit lines of the moving axes and a symmetric y range (``view.robust_span``):
    the data and the limits near them, or, when the data go far beyond ``reference``, a range
    around it with the rest clipped. Returns (limits drawn, span, clipped)."""
    near = [lim for lim, mv in zip(limits, moving) if mv] if limits is not None else []
    reach = 1.6 * max([peak] + ([min(near)] if near else []))
    candidates = [lim for lim, mv in zip(limits, moving) if mv and lim <= reach] if limits is not None else []
    span, clipped = view.robust_span(peak, reference, candidates)
    shown = []
    if limits is not None:
        for i, lim in enumerate(limits):
            if moving[i] and lim <= min(reach, span):
                ax.axhline(lim, color=AXIS_COLORS[i], lw=0.8, ls="--", alpha=0.6)
                ax.axhline(-lim, color=AXIS_COLORS[i], lw=0.8, ls="--", alpha=0.6)
                shown.append(lim)
    if span > 0 and np.isfinite(span):
        ax.set_ylim(-span, span)
    return bool(shown), span, clipped


def _mark_clipped(ax, t, series, colors, span) -> int:
    """Triangles at the panel's edge where a series runs beyond +-span (one per run of
    clipped samples, at its extreme); returns the number of clipped samples."""
    count = 0
    for values, color in zip(series, colors):
        v = np.asarray(values, dtype=np.float64)
        for sign, marker in ((1.0, "^"), (-1.0, "v")):
            over = np.isfinite(v) & (sign * v > span)
            count += int(over.sum())
            if not over.any():
                continue
            start, end, code = runs(over.astype(np.int8))
            stretches = [(a, b) for a, b, c in zip(start, end, code) if c]
            peak = [a + int(np.argmax(sign * v[a:b])) for a, b in stretches]
            ax.plot(t[peak], np.full(len(peak), sign * span * 0.965), ls="", marker=marker, ms=4,
                    color=color, markeredgecolor="k", markeredgewidth=0.3, zorder=6, clip_on=False)
    return count


def _dynamics(ax, t, tangential, per_axis, limits, convert, what: str, moving,
              reference=None, lw: float = 1.0) -> tuple[int, float, float]:
    """One dynamics panel; returns (samples clipped, span, peak), in display units. Clipped
    values leave a gap in their curve (no stroke to the edge) and a mark at the edge."""
    per_axis = convert(per_axis)
    tangential = convert(tangential)
    peak = max(float(np.nanmax(np.abs(a))) if finite_any(a) else 0.0
               for a in (per_axis, tangential))
    lim = None if limits is None else convert(limits)
    ref = None if reference is None else convert(reference)
    drawn, span, clipped = _axis_limit_lines(ax, peak, lim, moving, ref)
    count = 0
    if clipped:
        edge = span / 1.12
        count = _mark_clipped(ax, t, [per_axis[:, i] for i in range(3)] + [tangential],
                              [*AXIS_COLORS, "k"], edge)
        per_axis = np.where(np.abs(per_axis) > edge, np.nan, per_axis)
        tangential = np.where(np.abs(tangential) > edge, np.nan, tangential)
    for i in range(3):
        if finite_any(per_axis[:, i]) or (clipped and moving[i]):
            ax.plot(t, per_axis[:, i], color=AXIS_COLORS[i], lw=0.8 * lw, label=f"{AXIS_NAMES[i]} axis")
    if finite_any(tangential) or clipped:
        ax.plot(t, tangential, color="k", lw=lw, label=f"tangential {what}")
    if drawn:
        ax.plot([], [], color="0.4", ls="--", lw=0.8, label="axis limits ±")
    if clipped:
        ax.plot([], [], ls="", marker="^", ms=4, color="0.5", markeredgecolor="k",
                markeredgewidth=0.3, label="clipped")
    ax.axhline(0.0, color="0.6", lw=0.5)
    legend_above(ax)
    return count, span / 1.12, peak


def _note_below(fig, ax, lines: list[str]) -> None:
    """Notes under a bottom panel, left-aligned with it (between its axis label and the
    figure's footer)."""
    if lines:
        fig.text(ax.get_position().x0, 0.006, "\n".join(lines), ha="left", va="bottom",
                 fontsize=7.5, color="0.15")


def _wrap(text: str, width: int) -> str:
    import textwrap
    return "\n".join(textwrap.wrap(text, width))


def run_figure(trace: Trace, *, motion=None, machine=None, title: str | None = None,
               max_samples: int = MAX_PLOT_SAMPLES, rapids: str = "show",
               window: view.Window | None = None, feed_unit: str = "mm/min",
               numbers: np.ndarray | None = None, outline_xy: np.ndarray | None = None) -> RunFigure:
    """The figure of a run (module docstring). ``motion`` gives exact block boundaries;
    ``machine`` (default: the motion's) the axis limits drawn on the dynamics panels;
    ``rapids`` ``show`` (thin, grey) or ``hide``; ``window`` a time span to zoom to; ``numbers``
    the N number of each block of the motion (``view.block_numbers``) for the labels;
    ``outline_xy`` the whole part (``view.part_outline_xy``), drawn faintly behind a zoom.
    A whole program of more than MAX_BOUNDARIES blocks is drawn as an overview
    (``report.overview``)."""
    if rapids not in view.RAPIDS:
        raise UsageError(f"rapids must be one of {', '.join(view.RAPIDS)}, got {rapids!r}")
    panels, missing = available_panels(trace)
    if not panels:
        raise UsageError("nothing to plot: the trace has no samples with time and feed")
    if machine is None and motion is not None:
        machine = motion.machine
    notes = []
    total = motion.total_time_s if motion is not None else float(np.nanmax(trace.t_s))
    s_cut_all = view.cutting_length_mm(trace, motion)
    inside = view.window_samples(trace, window)
    if len(inside) < 2:
        raise UsageError("nothing to plot in the chosen range: fewer than two samples")
    drawn_idx, step = _thin(trace.select(inside), max_samples)
    idx = inside[drawn_idx]
    trace, s_cut = trace.select(idx), s_cut_all[idx]
    if step > 1:
        notes.append(f"1 sample in {step} drawn")
    show = rapids == "show"
    rapid = view.rapid_mask(trace)
    if not view.rapids_known(trace):
        notes.append("rapids not told apart (the trace has no programmed_mm_min column)")
    elif not show and rapid.any():
        notes.append("rapids hidden")
    bounds = _block_starts(trace, motion, numbers, s_cut)
    if motion is not None and window is None and len(bounds.t) > MAX_BOUNDARIES:
        from ncsim.report.overview import overview_figure
        return overview_figure(trace, motion, title=title, rapids=rapids, feed_unit=feed_unit,
                               notes=notes)

    fig = Figure(figsize=FIGSIZE_IN, dpi=DPI)
    FigureCanvasAgg(fig)
    axes = _layout(fig, panels)
    t = trace.t_s
    draw_bounds = len(bounds.t) <= MAX_BOUNDARIES
    if not draw_bounds:
        notes.append(f"{len(bounds.t) + 1} blocks in view: boundaries not drawn (zoom with --range)")
    limits_drawn: set[int] = set()
    has_limit = bool(len(trace.limit)) and not np.all(trace.limit == Limit.NONE)
    shade = np.where(rapid, RAPID_CODE if show else HIDDEN_CODE, trace.limit.astype(np.int64))
    feeds = feeds_of(trace, rapid, feed_unit)
    clipped: dict[str, int] = {}
    lw = 1.0 if len(bounds.t) <= DENSE_BLOCKS else 0.5     # many blocks: thin lines

    if "feed_time" in axes:
        ax = axes["feed_time"]
        if has_limit or rapid.any():
            limits_drawn |= shade_limits(ax, t, shade if has_limit else np.where(rapid, shade, HIDDEN_CODE))
        handles = feed_lines(ax, t, feeds, show, feed_unit, lw)
        if draw_bounds:
            _boundaries(ax, bounds.t, bounds.labels)
            handles.append(Line2D([], [], color="0.45", lw=0.6, label="block boundary"))
        ax.set_xlabel("time (s)")
        ax.set_xlim(t[0], t[-1])
        ax.set_title("feed against time", fontsize=10, loc="left")
        legend_above(ax, handles)
    if "feed_path" in axes:
        ax = axes["feed_path"]
        if has_limit:
            limits_drawn |= shade_limits(ax, s_cut, np.where(rapid, HIDDEN_CODE, shade))
        feed_lines(ax, s_cut, feeds, False, feed_unit, lw)
        if draw_bounds:
            _boundaries(ax, bounds.s_cut[bounds.cutting], None)
        lo, hi = float(np.nanmin(s_cut)), float(np.nanmax(s_cut))
        if hi > lo:
            ax.set_xlim(lo, hi)
        known = view.rapids_known(trace)
        ax.set_xlabel("cutting path length (mm)" if known else "path length s (mm)")
        ax.set_title("feed along the cutting path (rapids take no length)" if known and rapid.any()
                     else "feed along the path", fontsize=10, loc="left")
    if "xy_path" in axes:
        _xy_panel(fig, axes["xy_path"], trace, rapid, show, outline_xy, bounds, draw_bounds)
    moving = [bool(finite_any(trace.vel_mm_s[:, i]) and np.nanmax(np.abs(trace.vel_mm_s[:, i])) > 0)
              or bool(finite_any(trace.jerk_mm_s3[:, i]) and np.nanmax(np.abs(trace.jerk_mm_s3[:, i])) > 0)
              or bool(finite_any(trace.acc_mm_s2[:, i]) and np.nanmax(np.abs(trace.acc_mm_s2[:, i])) > 0)
              for i in range(3)]
    hide = (lambda a: np.where(rapid[:, None] if a.ndim == 2 else rapid, np.nan, a)) if not show \
        else (lambda a: a)
    if "accel" in axes:
        ax = axes["accel"]
        _dynamics(ax, t, hide(trace.accel_t_mm_s2), hide(trace.acc_mm_s2),
                  None if machine is None else machine.max_accel_mm_s2, mm_s2_to_m_s2,
                  "acceleration", moving, lw=lw)
        ax.set_xlabel("time (s)")
        ax.set_title("acceleration", fontsize=10, loc="left")
    if "jerk" in axes:
        ax = axes["jerk"]
        n, span, peak = _dynamics(ax, t, hide(trace.jerk_t_mm_s3), hide(trace.jerk_mm_s3),
                                  None if machine is None else machine.max_jerk_mm_s3,
                                  mm_s3_to_m_s3, "jerk", moving,
                                  view.jerk_reference_mm_s3(machine, moving), lw=lw)
        clipped["jerk"] = n
        lines = []
        if n:
            lines.append(f"▲▼ jerk beyond ±{span:.3g} m/s³ clipped and marked at the edge (up to {peak:.3g} m/s³)")
        shown = trace if show else trace.select(~rapid)
        lines += view.jerk_notes(shown, motion, machine, moving)
        _note_below(fig, ax, [_wrap(x, 110) for x in lines][:3])
        ax.set_xlabel("time (s)")
        ax.set_title("jerk", fontsize=10, loc="left")
    for name, ax in axes.items():
        label = PANEL_YLABELS[name]
        ax.set_ylabel(label.replace("mm/min", feed_unit) if name.startswith("feed") else label)
        ax.grid(True, color="0.85", lw=0.5)
        if draw_bounds and name in ("accel", "jerk"):
            _boundaries(ax, bounds.t, None)

    limit_legend(fig, limits_drawn)
    if missing:
        notes.append("left out: " + "; ".join(f"{p} (needs {need})" for p, need in missing.items()))
    head = title or "ncsim run"
    head += f"   cycle time {total:.3f} s"
    if window is not None:
        head += f"   view: {window.label}"
    fig.suptitle(head, fontsize=13, y=0.985)
    footer(fig, notes)
    return RunFigure(figure=fig, panels=tuple(axes), missing=missing, notes=tuple(notes),
                     axes=dict(axes), clipped=clipped)


def _xy_panel(fig, ax, trace, rapid, show, outline_xy, bounds, draw_bounds) -> None:
    """The XY path coloured by the share of the programmed feed reached, framed on the
    cutting moves."""
    xy = trace.pos_mm[:, :2]
    lc = path_view(ax, xy, rapid, view.feed_ratio(trace), show_rapids=show)
    handles = []
    if outline_xy is not None and len(outline_xy):
        ax.plot(outline_xy[:, 0], outline_xy[:, 1], color="0.8", lw=0.8, zorder=0.5)
        handles.append(Line2D([], [], color="0.8", lw=0.8, label="rest of the part"))
    if show and rapid.any():
        handles.append(Line2D([], [], color=RAPID_COLOR, lw=0.7, ls="--", label="rapid (G0)"))
    ratio_colorbar(fig, lc, ax, pad=0.02, fraction=0.05)
    first_cut = int(np.argmax(~rapid)) if (~rapid).any() else 0
    ax.plot(xy[first_cut, 0], xy[first_cut, 1], "k^", ms=7, zorder=4)
    handles.insert(0, Line2D([], [], color="k", marker="^", ls="", label="start"))
    if draw_bounds and bounds.cutting.any():
        b = bounds.xy[bounds.cutting]
        ax.plot(b[:, 0], b[:, 1], "o", color="k", ms=3, zorder=3)
        handles.append(Line2D([], [], color="k", marker="o", ms=3, ls="", label="block boundary"))
    frame(fig, ax, view.xy_limits(trace, ~rapid))
    ax.set_xlabel("X (mm)")
    ax.set_title("XY path: reached / programmed feed", fontsize=10, loc="left")
    ax.legend(handles=handles, loc="best", fontsize=8, framealpha=0.85)


# ---------------------------------------------------------------------------------------------
# The machine's limits against radius
# ---------------------------------------------------------------------------------------------

def explain_figure(rows, machine_name: str, feed_unit: str = "mm/min") -> Figure:
    """Steady feed (in ``feed_unit``) each limit allows against arc radius
    (``explain.radius_table``, whose feeds are in mm/min)."""
    r = np.array([row.radius_mm for row in rows])
    def col(name):
        mm_min = np.array([getattr(row, name) for row in rows])
        return feed_from_mm_s(mm_min_to_mm_s(mm_min), feed_unit)
    fig = Figure(figsize=(10.0, 6.5), dpi=DPI)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(1, 1, 1)
    ax.fill_between(r, col("v_jt_min_mm_min"), col("v_jt_max_mm_min"), color="C1", alpha=0.25,
                    label="V_Jt axis jerk, eq. 4/9 (min–max over direction)")
    ax.fill_between(r, col("v_an_min_mm_min"), col("v_an_max_mm_min"), color="C4", alpha=0.25,
                    label="V_An axis acceleration, eq. 2/8 (min–max)")
    ax.fill_between(r, col("v_t_min_mm_min"), col("v_t_max_mm_min"), color="C0", alpha=0.2,
                    label="V_t axis velocity, eq. 7 (min–max)")
    ax.plot(r, col("v_jtcurv_mm_min"), color="C3", lw=1.5, zorder=4, label="V_Jtcurv NCU path jerk, eq. 11")
    ax.plot(r, col("v_tcy_mm_min"), color="C2", lw=1.2, ls="-.", label="V_tcy full circle per block, eq. 6")
    ax.plot(r, col("v_fr_line_mm_min"), color="C5", lw=1.2, ls=":", label="V_fr line → arc, eq. 13")
    ax.plot(r, col("setpoint_mm_min"), color="k", lw=4.0, alpha=0.45, zorder=3,
            label="set point planned by ncsim (eq. 12)")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("arc radius R (mm)")
    ax.set_ylabel(f"steady feed ({feed_unit})")
    ax.set_title(f"{machine_name}: steady feed each limit allows on an XY circle", fontsize=11)
    ax.grid(True, which="both", color="0.88", lw=0.5)
    ax.legend(loc="upper left", fontsize=8)
    fig.tight_layout()
    return fig


# ---------------------------------------------------------------------------------------------
# Saving
# ---------------------------------------------------------------------------------------------

def save_figure(fig: Figure, file: str | os.PathLike) -> None:
    """Write ``fig`` as PNG, SVG or PDF (by the file's suffix), without dates (reproducible)."""
    check_figure_file(file)
    name = os.fspath(file)
    fmt = os.path.splitext(name)[1].lower().lstrip(".")
    metadata = {"svg": {"Date": None}, "pdf": {"CreationDate": None, "ModDate": None}}.get(fmt)
    with rc_context({"svg.hashsalt": "ncsim", "svg.fonttype": "path"}):
        try:
            fig.savefig(name, format=fmt, dpi=DPI, metadata=metadata)
        except OSError as exc:
            raise UsageError(f"{name}: cannot write figure: {exc.strerror or exc}") from None


def check_figure_file(file: str | os.PathLike) -> None:
    """Fail early (before simulating) on an output name whose format is unknown."""
    fmt = os.path.splitext(os.fspath(file))[1].lower().lstrip(".")
    if fmt not in FORMATS:
        raise UsageError(f"{os.fspath(file)}: cannot tell the figure format from the suffix "
                         f"(use .{', .'.join(FORMATS)})")


__all__ = ["run_figure", "explain_figure", "save_figure", "available_panels", "RunFigure",
           "check_figure_file", "PANELS", "PANEL_YLABELS"]
