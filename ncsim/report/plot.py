"""Figures: a simulated run (``ncsim plot``) and a machine's feed limits (``ncsim explain --plot``).

:func:`run_figure` draws a :class:`~ncsim.motion.Trace` (plus the planned
:class:`~ncsim.motion.Motion` when there is one) as up to five panels:

1. ``feed_time``  feed (mm/min) against time: programmed F, set point (eq. 12), reached feed;
   the background is shaded by the limit holding the feed (``motion.Limit`` labels, legend at
   the top of the figure); thin grey vertical lines mark block boundaries (with the source
   line of each block when there are few);
2. ``feed_path``  the same feeds against the path length s (mm), same shading and boundaries;
3. ``xy_path``    the XY projection of the path coloured by the reached feed (colorbar in
   mm/min, equal aspect), block boundaries as dots;
4. ``accel``      tangential and per-axis acceleration (m/s^2) against time, with the axes'
   limits dashed (when the machine is known);
5. ``jerk``       tangential and per-axis jerk (m/s^3) against time, limits dashed likewise.

A trace read from CSV may lack columns; the panels that need them are left out and
:attr:`RunFigure.missing` says which columns each one needs. Only matplotlib's object API and
the Agg canvas are used (no pyplot, no global state), and files are written without dates, so
the same input gives the same file.
"""
from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np
from matplotlib import rc_context
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import LineCollection, PolyCollection
from matplotlib.figure import Figure
from matplotlib.gridspec import GridSpec
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from ncsim.errors import UsageError
from ncsim.motion import LIMIT_LABELS, Limit
from ncsim.motion import Trace
from ncsim.units import feed_from_mm_s, mm_min_to_mm_s, mm_s2_to_m_s2, mm_s3_to_m_s3, mm_s_to_mm_min

FIGSIZE_IN = (16.0, 10.0)
DPI = 100                        # so a PNG is 1600 x 1000 pixels
MAX_BOUNDARIES = 400             # block boundaries drawn at most (else a note says so)
MAX_LINE_LABELS = 30             # source lines written at the boundaries at most
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

# a fixed colour per limit (shading), so that figures compare at a glance
LIMIT_COLORS = {
    "programmed": "#d9f0d3",
    "ncu_path_jerk": "#fdb863",
    "axis_jerk": "#e08214",
    "axis_accel": "#b2abd2",
    "axis_velocity": "#8073ac",
    "cycle_time": "#f4a582",
    "transition": "#92c5de",
    "corner": "#4393c3",
    "exact_stop": "#d6604d",
    "lookahead": "#c2a5cf",
    "program_end": "#e0e0e0",
    "dwell": "#bababa",
    "aux_stop": "#f6e8c3",
    "none": "#ffffff",
}
AXIS_COLORS = ("C0", "C1", "C2")
AXIS_NAMES = ("X", "Y", "Z")


@dataclass(frozen=True)
class RunFigure:
    figure: Figure
    panels: tuple[str, ...]          # drawn, in PANELS order
    missing: dict[str, str]          # panel left out -> the columns it needs
    notes: tuple[str, ...]           # anything else the reader should know (thinning...)


# ---------------------------------------------------------------------------------------------
# What can be drawn
# ---------------------------------------------------------------------------------------------

def _finite_any(a: np.ndarray) -> bool:
    return bool(len(a)) and bool(np.isfinite(a).any())


def available_panels(trace: Trace) -> tuple[list[str], dict[str, str]]:
    """The panels ``trace`` has data for, and for the others the columns they need."""
    has = {
        "feed_time": _finite_any(trace.t_s) and _finite_any(trace.feed_mm_s),
        "feed_path": _finite_any(trace.s_mm) and _finite_any(trace.feed_mm_s),
        "xy_path": (_finite_any(trace.pos_mm[:, 0]) and _finite_any(trace.pos_mm[:, 1])
                    and _finite_any(trace.feed_mm_s)),
        "accel": _finite_any(trace.accel_t_mm_s2) or _finite_any(trace.acc_mm_s2),
        "jerk": _finite_any(trace.jerk_t_mm_s3) or _finite_any(trace.jerk_mm_s3),
    }
    if len(trace) == 0:
        has = dict.fromkeys(has, False)
    return [p for p in PANELS if has[p]], {p: PANEL_NEEDS[p] for p in PANELS if not has[p]}


# ---------------------------------------------------------------------------------------------
# Helpers
# ---------------------------------------------------------------------------------------------

def _runs(codes: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Maximal runs of equal codes: (first index, end index exclusive, code)."""
    if len(codes) == 0:
        return np.zeros(0, int), np.zeros(0, int), np.zeros(0, codes.dtype)
    change = np.flatnonzero(np.diff(codes) != 0) + 1
    start = np.concatenate([[0], change])
    end = np.concatenate([change, [len(codes)]])
    return start, end, codes[start]


def _shade_limits(ax, x: np.ndarray, limit: np.ndarray) -> set[int]:
    """Shade the background of ``ax`` by ``limit`` code over ``x``; returns the codes drawn.

    A run of samples [i, j) is shaded from x[i] to x[j] (x[-1] for the last run)."""
    start, end, code = _runs(limit)
    if len(start) == 0:
        return set()
    x_lo = x[start]
    x_hi = x[np.minimum(end, len(x) - 1)]
    drawn = set()
    for c in np.unique(code):
        sel = (code == c) & (x_hi > x_lo)
        if not np.any(sel):
            continue
        verts = [((a, 0.0), (a, 1.0), (b, 1.0), (b, 0.0)) for a, b in zip(x_lo[sel], x_hi[sel])]
        label = LIMIT_LABELS[int(c)] if 0 <= int(c) < len(LIMIT_LABELS) else "none"
        coll = PolyCollection(verts, facecolors=LIMIT_COLORS.get(label, "#ffffff"),
                              edgecolors="none", alpha=0.55, zorder=0,
                              transform=ax.get_xaxis_transform())
        ax.add_collection(coll, autolim=False)
        drawn.add(int(c))
    return drawn


def _boundaries(ax, x: np.ndarray, lines: np.ndarray | None, label_lines: bool) -> None:
    if len(x) == 0:
        return
    ax.vlines(x, 0.0, 1.0, transform=ax.get_xaxis_transform(), colors="0.45", linewidths=0.6,
              alpha=0.7, zorder=1)
    if label_lines and lines is not None and len(x) <= MAX_LINE_LABELS:
        for xi, line in zip(x, lines):
            ax.text(xi, 0.99, f" line {int(line)}", transform=ax.get_xaxis_transform(),
                    rotation=90, va="top", ha="left", fontsize=7, color="0.3", zorder=5)


def _legend_above(ax, handles=None) -> None:
    """A one-row legend above the axes, right-aligned (the title is on the left)."""
    kwargs = {} if handles is None else {"handles": handles}
    n = len(handles) if handles is not None else len(ax.get_legend_handles_labels()[0])
    ax.legend(loc="lower right", bbox_to_anchor=(1.0, 1.0), ncol=max(n, 1), fontsize=8,
              frameon=False, borderaxespad=0.1, handlelength=1.8, columnspacing=1.0, **kwargs)


def _thin(trace: Trace, max_samples: int) -> tuple[Trace, int]:
    if len(trace) <= max_samples:
        return trace, 1
    step = int(np.ceil(len(trace) / max_samples))
    idx = np.arange(0, len(trace), step)
    if idx[-1] != len(trace) - 1:
        idx = np.append(idx, len(trace) - 1)
    return trace.select(idx), step


def _block_starts(trace: Trace, motion) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Block boundaries: times, path lengths, XY points and source lines of block starts
    (from the motion when there is one, else where the trace's block column changes)."""
    if motion is not None and motion.path.n:
        path = motion.path
        return (np.asarray(motion.t_start_s), np.asarray(path.s_start_mm),
                np.asarray(path.start_mm[:, :2]), np.asarray(path.line))
    block = trace.block
    if len(block) == 0 or np.all(block < 0):
        empty = np.zeros(0)
        return empty, empty, np.zeros((0, 2)), empty
    i = np.concatenate([[0], np.flatnonzero(np.diff(block) != 0) + 1])
    return trace.t_s[i], trace.s_mm[i], trace.pos_mm[i, :2], trace.line[i]


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
                  left=0.055, right=0.945, bottom=0.06, top=0.85, hspace=1.5, wspace=0.16)
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


def _feed_lines(ax, x, trace: Trace, motion) -> list:
    handles = []
    prog = mm_s_to_mm_min(trace.programmed_mm_s)
    prog = np.where(np.isfinite(prog), prog, np.nan)      # rapids have no programmed feed
    if _finite_any(prog):
        handles += ax.plot(x, prog, color="0.25", lw=1.2, ls=":", label="programmed F")
    setpoint = mm_s_to_mm_min(trace.setpoint_mm_s)
    setpoint = np.where(np.isfinite(setpoint), setpoint, np.nan)
    if _finite_any(setpoint):
        handles += ax.plot(x, setpoint, color="C3", lw=1.2, ls="--", label="set point (eq. 12)")
    reached = mm_s_to_mm_min(trace.feed_mm_s)
    handles += ax.plot(x, reached, color="k", lw=1.4, label="reached feed")
    # scale to the reached and programmed feeds: a rapid's set point (the axis velocity) would
    # squash the feed moves; it runs off the top instead
    top = np.nanmax(np.concatenate([reached[np.isfinite(reached)], prog[np.isfinite(prog)], [1.0]]))
    ax.set_ylim(0.0, 1.15 * top)
    return handles


def _axis_limit_lines(ax, peak: float, limits, moving) -> bool:
    """Dashed +-limit lines of the moving axes, and a symmetric y range showing the data and
    the limits near it (a limit far above the data, e.g. Z jerk 10x X's, is left off-scale)."""
    shown = []
    if limits is not None:
        near = [lim for lim, mv in zip(limits, moving) if mv]
        reach = 1.6 * max([peak] + ([min(near)] if near else []))
        for i, lim in enumerate(limits):
            if moving[i] and lim <= reach:
                ax.axhline(lim, color=AXIS_COLORS[i], lw=0.8, ls="--", alpha=0.6)
                ax.axhline(-lim, color=AXIS_COLORS[i], lw=0.8, ls="--", alpha=0.6)
                shown.append(lim)
    span = 1.12 * max([peak] + shown)
    if span > 0 and np.isfinite(span):
        ax.set_ylim(-span, span)
    return bool(shown)


def _dynamics(ax, t, tangential, per_axis, limits, convert, what: str) -> None:
    per_axis = convert(per_axis)
    tangential = convert(tangential)
    moving = [_finite_any(per_axis[:, i]) and np.nanmax(np.abs(per_axis[:, i])) > 0
              for i in range(3)]
    for i in range(3):
        if _finite_any(per_axis[:, i]):
            ax.plot(t, per_axis[:, i], color=AXIS_COLORS[i], lw=0.9, label=f"{AXIS_NAMES[i]} axis")
    if _finite_any(tangential):
        ax.plot(t, tangential, color="k", lw=1.2, label=f"tangential {what}")
    peak = max(float(np.nanmax(np.abs(a))) if _finite_any(a) else 0.0
               for a in (per_axis, tangential))
    if _axis_limit_lines(ax, peak, None if limits is None else convert(limits), moving):
        ax.plot([], [], color="0.4", ls="--", lw=0.8, label="axis limits ±")
    ax.axhline(0.0, color="0.6", lw=0.5)
    _legend_above(ax)


def run_figure(trace: Trace, *, motion=None, machine=None, title: str | None = None,
               max_samples: int = MAX_PLOT_SAMPLES) -> RunFigure:
    """The figure of a run (module docstring). ``motion`` gives exact block boundaries;
    ``machine`` (default: the motion's) the axis limits drawn on the dynamics panels."""
    panels, missing = available_panels(trace)
    if not panels:
        raise UsageError("nothing to plot: the trace has no samples with time and feed")
    if machine is None and motion is not None:
        machine = motion.machine
    notes = []
    trace, step = _thin(trace, max_samples)
    if step > 1:
        notes.append(f"1 sample in {step} drawn")

    fig = Figure(figsize=FIGSIZE_IN, dpi=DPI)
    FigureCanvasAgg(fig)
    axes = _layout(fig, panels)
    t = trace.t_s
    bt, bs, bxy, bline = _block_starts(trace, motion)
    inner = slice(1, None)  # the first block starts at 0: no line there
    draw_bounds = len(bt) <= MAX_BOUNDARIES
    if not draw_bounds:
        notes.append(f"{len(bt)} blocks: boundaries not drawn")
    limits_drawn: set[int] = set()
    has_limit = bool(len(trace.limit)) and not np.all(trace.limit == Limit.NONE)

    if "feed_time" in axes:
        ax = axes["feed_time"]
        if has_limit:
            limits_drawn |= _shade_limits(ax, t, trace.limit)
        handles = _feed_lines(ax, t, trace, motion)
        if draw_bounds:
            _boundaries(ax, bt[inner], bline[inner], label_lines=True)
            handles.append(Line2D([], [], color="0.45", lw=0.6, label="block boundary"))
        ax.set_xlabel("time (s)")
        ax.set_title("feed against time", fontsize=10, loc="left")
        _legend_above(ax, handles)
    if "feed_path" in axes:
        ax = axes["feed_path"]
        s = trace.s_mm
        if has_limit:
            limits_drawn |= _shade_limits(ax, s, trace.limit)
        handles = _feed_lines(ax, s, trace, motion)
        if draw_bounds:
            _boundaries(ax, bs[inner], bline[inner], label_lines=False)
        ax.set_xlabel("path length s (mm)")
        ax.set_title("feed along the path", fontsize=10, loc="left")
    if "xy_path" in axes:
        ax = axes["xy_path"]
        xy = trace.pos_mm[:, :2]
        feed = mm_s_to_mm_min(trace.feed_mm_s)
        seg = np.stack([xy[:-1], xy[1:]], axis=1)
        lc = LineCollection(seg, cmap="viridis", linewidths=2.0, zorder=2)
        lc.set_array(0.5 * (feed[:-1] + feed[1:]))
        ax.add_collection(lc)
        ax.autoscale_view()
        cb = fig.colorbar(lc, ax=ax, pad=0.02, fraction=0.05)
        cb.set_label("reached feed (mm/min)")
        handles = [Line2D([], [], color="k", marker="^", ls="", label="start")]
        ax.plot(xy[0, 0], xy[0, 1], "k^", ms=7, zorder=4)
        if draw_bounds and len(bxy) > 1:
            ax.plot(bxy[1:, 0], bxy[1:, 1], "o", color="k", ms=3, zorder=3)
            handles.append(Line2D([], [], color="k", marker="o", ms=3, ls="", label="block boundary"))
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_xlabel("X (mm)")
        ax.set_title("XY path coloured by feed", fontsize=10, loc="left")
        _legend_above(ax, handles)
    if "accel" in axes:
        ax = axes["accel"]
        _dynamics(ax, t, trace.accel_t_mm_s2, trace.acc_mm_s2,
                  None if machine is None else machine.max_accel_mm_s2, mm_s2_to_m_s2, "acceleration")
        ax.set_xlabel("time (s)")
        ax.set_title("acceleration", fontsize=10, loc="left")
    if "jerk" in axes:
        ax = axes["jerk"]
        _dynamics(ax, t, trace.jerk_t_mm_s3, trace.jerk_mm_s3,
                  None if machine is None else machine.max_jerk_mm_s3, mm_s3_to_m_s3, "jerk")
        ax.set_xlabel("time (s)")
        ax.set_title("jerk", fontsize=10, loc="left")
    for name, ax in axes.items():
        ax.set_ylabel(PANEL_YLABELS[name])
        ax.grid(True, color="0.85", lw=0.5)
        if draw_bounds and name in ("accel", "jerk"):
            _boundaries(ax, bt[inner], None, label_lines=False)

    if limits_drawn:
        order = sorted(limits_drawn)
        patches = [Patch(facecolor=LIMIT_COLORS.get(LIMIT_LABELS[c], "#fff"), alpha=0.55,
                         edgecolor="0.6", label=LIMIT_LABELS[c]) for c in order]
        fig.legend(handles=patches, loc="upper center", bbox_to_anchor=(0.5, 0.935),
                   ncol=min(len(patches), 7), fontsize=9, frameon=False,
                   title="background: the limit holding the feed", title_fontsize=9)
    if missing:
        notes.append("left out: " + "; ".join(f"{p} (needs {need})" for p, need in missing.items()))
    head = title or "ncsim run"
    if len(t):
        head += f"   cycle time {t[-1]:.3f} s"
    fig.suptitle(head, fontsize=13, y=0.985)
    if notes:
        fig.text(0.5, 0.005, "; ".join(notes), ha="center", va="bottom", fontsize=8, color="0.35")
    return RunFigure(figure=fig, panels=tuple(axes), missing=missing, notes=tuple(notes))


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
