"""A whole program at a glance (``ncsim plot`` of a program with more blocks than can be drawn
one by one): where it is slow, in which operation, and why.

Four panels, chosen for a CAM programmer reading a real program:

1. ``feed_time``   the feeds against time (programmed F, reached) over the limit holding the
   feed, shaded in runs a reader can see (``view.dominant_runs``); each CAM operation's start
   is a dashed line with its number and name (labels stagger in rows, never overlap).
   Over thousands of blocks the feed itself is a band from 0 to F and back: each of
   ``view.SHADE_BINS`` slices shows the mean feed reached within its range, and the shading is
   the limit that loses the most time in the slice (``programmed`` where under 15 % is lost);
2. ``operations``  the time of each operation (or tool, or the N numbers losing most when the
   program names neither): at the programmed feeds and lost, side by side in one bar, in
   program order, with the share lost and what it is lost to;
3. ``xy_path``     the XY path coloured by the share of the programmed feed reached (red where
   the program runs far below its F words, green where it reaches them), framed on the
   cutting moves, the operations' starts numbered;
4. ``side_path``   the same seen from the side (the longer of X and Y against Z).

Acceleration and jerk are left out: over thousands of blocks a BRISK program's steps make them
a solid band; a zoom (``--range``) draws them block by block (``report.plot``).
"""
from __future__ import annotations

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.ticker import FuncFormatter, MaxNLocator

from ncsim.motion import Limit, Trace
from ncsim.report import view
from ncsim.report.breakdown import hms, structure_tables
from ncsim.report.drawing import (HIDDEN_CODE, RAPID_CODE, footer, frame, legend_above,
                                  limit_legend, path_view, ratio_colorbar, shade_limits)
from ncsim.report.losses import losses
from ncsim.units import feed_from_mm_s

PANELS = ("feed_time", "operations", "xy_path", "side_path")
MAX_BARS = 12              # operations drawn as bars at most (the rest are named in a note)
LABEL_ROWS = 3             # rows of operation labels above the feeds ...
LABEL_HEADROOM = 1.33      # ... in the top of the feed axis (above 1.15 x the highest F)
IDEAL_COLOR = "#9ccb86"
LOST_COLOR = "#d6604d"


def _bars(motion) -> tuple[str, list[dict]]:
    """What the bar panel shows: the operations when the program names two or more, else
    its tools, else the N numbers losing the most time."""
    tables = structure_tables(motion, losses(motion), top=MAX_BARS)
    for key, what in (("by_operation", "operation"), ("by_tool", "tool")):
        named = [r for r in tables[key] if r["name"] is not None]
        if len(named) >= 2:
            return what, tables[key]
    return "N number", [{**r, "name": f"N{r['n']}", "n_ranges": [[r["n"], r["n"]]]}
                        for r in tables["by_n"]]


def _time_tick(seconds, _pos=None) -> str:
    return hms(seconds)[:-2]


def overview_figure(trace: Trace, motion, *, title: str | None = None, rapids: str = "show",
                    feed_unit: str = "mm/min", notes: list[str] | None = None):
    """The overview figure of ``motion`` sampled as ``trace`` (module docstring), as a
    ``report.plot.RunFigure``."""
    from ncsim.report.plot import DPI, FIGSIZE_IN, RunFigure

    notes = list(notes or [])
    show = rapids == "show"
    rapid = view.rapid_mask(trace)
    fig = Figure(figsize=FIGSIZE_IN, dpi=DPI)
    FigureCanvasAgg(fig)
    axes = {"feed_time": fig.add_axes((0.055, 0.56, 0.89, 0.29)),
            "operations": fig.add_axes((0.17, 0.07, 0.25, 0.39)),
            "xy_path": fig.add_axes((0.475, 0.07, 0.2, 0.39)),
            "side_path": fig.add_axes((0.735, 0.07, 0.18, 0.39))}
    spans = view.operation_spans(motion)
    numbered = _numbered(spans)
    drawn = _feed_panel(axes["feed_time"], trace, _shading_codes(trace, motion, rapid, show),
                        rapid, feed_unit, spans, numbered)
    what, rows = _bars(motion)
    _bar_panel(axes["operations"], what, rows, numbered, motion.total_time_s)
    ratio = _block_ratio(trace, motion)
    lc = path_view(axes["xy_path"], trace.pos_mm[:, :2], rapid, ratio, show_rapids=show)
    horizontal = 0 if np.ptp(trace.pos_mm[~rapid, 0]) >= np.ptp(trace.pos_mm[~rapid, 1]) else 1 \
        if (~rapid).any() else 0
    side = trace.pos_mm[:, [horizontal, 2]]
    path_view(axes["side_path"], side, rapid, ratio, show_rapids=show)
    for name, points, xlabel, ylabel in (("xy_path", trace.pos_mm[:, :2], "X (mm)", "Y (mm)"),
                                         ("side_path", side, "XYZ"[horizontal] + " (mm)", "Z (mm)")):
        ax = axes[name]
        frame(fig, ax, _box(points, ~rapid))
        ax.set_xlabel(xlabel)
        ax.set_ylabel(ylabel)
        ax.grid(True, color="0.88", lw=0.5)
        _mark_starts(ax, trace, points, spans, numbered)
    axes["xy_path"].set_title("XY: where the feed is reached (green) or not (red)", fontsize=10,
                              loc="left")
    axes["side_path"].set_title(f"side view ({'XYZ'[horizontal]}Z)", fontsize=10, loc="left")
    cb = ratio_colorbar(fig, lc, [axes["xy_path"], axes["side_path"]], pad=0.015, fraction=0.02)
    cb.set_label("reached / programmed feed, mean over each block")
    limit_legend(fig, drawn)
    s = motion.total_time_s
    tables = structure_tables(motion, losses(motion), top=1)
    ideal = sum(r["ideal_time_s"] for r in tables["by_tool"])
    lost = sum(r["lost_time_s"] for r in tables["by_tool"])
    fig.suptitle(f"{title or 'ncsim run'}   cycle time {hms(s)} = {hms(ideal)} at the programmed "
                 f"feeds + {hms(lost)} lost", fontsize=13, y=0.985)
    notes.append(f"{motion.path.n} blocks: acceleration and jerk shown when zoomed (--range)")
    footer(fig, notes)
    return RunFigure(figure=fig, panels=PANELS, missing={}, notes=tuple(notes), axes=axes,
                     clipped={})


def _block_ratio(trace, motion) -> np.ndarray:
    """At each sample, its block's mean reached feed over the programmed one (the time at the
    programmed feed over the time taken, exact-stop settle included): a whole program's
    colour says which blocks run slow, not where each one ramps (NaN on rapids)."""
    loss = losses(motion)
    taken = loss.ideal_s + loss.lost_s
    eff = np.divide(loss.ideal_s, taken, out=np.ones_like(taken), where=taken > 0)
    eff[motion.path.rapid] = np.nan
    return eff[np.clip(trace.block, 0, motion.path.n - 1)]


def _shading_codes(trace, motion, rapid, show) -> np.ndarray:
    """The limit of each sample for the shading, a standstill at an exact stop counted as
    ``exact_stop`` (the settle in the G601/G602 window, as ``report.losses`` counts it) unless
    a G4 dwell or a tool change is programmed there."""
    code = trace.limit.astype(np.int64)
    path = motion.path
    block = np.clip(trace.block, 0, path.n - 1)
    after = np.minimum(block + 1, path.n - 1)
    settle = (code == int(Limit.DWELL)) & (path.dwell_before_s[block] == 0) \
        & (path.dwell_before_s[after] == 0) & (path.exact_stop[block] | path.exact_stop[after])
    code[settle] = int(Limit.EXACT_STOP)
    return np.where(rapid, RAPID_CODE if show else HIDDEN_CODE, code)


def _numbered(spans) -> dict[str, int]:
    """Operation name -> its number (1, 2, ... in order of first appearance)."""
    out: dict[str, int] = {}
    for _, _, name in spans:
        out.setdefault(name, len(out) + 1)
    return out


def _feed_panel(ax, trace, shade, rapid, unit, spans, numbered) -> set[int]:
    """Feeds per slice of the panel (``view.slice_feeds``: the mean reached feed within its
    range, the mean programmed F) over the limit losing the most time there."""
    t = trace.t_s
    prog = np.asarray(trace.programmed_mm_s, dtype=np.float64)
    v = np.asarray(trace.feed_mm_s, dtype=np.float64)
    ok = np.isfinite(prog) & (prog > 0)
    share = np.ones(len(t))                       # standing and rapids: counted whole
    np.subtract(1.0, v / np.where(ok, prog, 1.0), out=share, where=ok)
    lost = np.diff(t) * np.clip(share[:-1], 0.0, 1.0)
    drawn = set()
    if len(trace.limit) and not np.all(trace.limit == Limit.NONE):
        drawn = shade_limits(ax, t, shade, weights=lost, floor=(int(Limit.PROGRAMMED), 0.15))
    cut = ~rapid
    mid, mean, low, high = (feed_from_mm_s(a, unit) if k else a for k, a in enumerate(
        view.slice_feeds(t, np.where(cut, v, np.nan))))
    mean_prog = feed_from_mm_s(view.slice_feeds(t, np.where(cut & ok, prog, np.nan))[1], unit)
    handles = [ax.fill_between(mid, low, high, step="mid", color="#6baed6", alpha=0.3, lw=0,
                               label="reached feed: range"),
               *ax.plot(mid, mean_prog, drawstyle="steps-mid", color="0.2", lw=1.0, ls=":",
                        label="programmed F: mean"),
               *ax.plot(mid, mean, drawstyle="steps-mid", color="k", lw=1.3,
                        label="reached feed: mean")]
    ax.set_xlim(t[0], t[-1])
    headroom = LABEL_HEADROOM
    ax.set_ylim(0.0, float(feed_from_mm_s(view.feed_top_mm_s(trace, cut), unit)) * headroom)
    if spans:
        starts = np.array([a for a, _, _ in spans])
        ax.vlines(starts, 0.0, 1.0, transform=ax.get_xaxis_transform(), colors="0.2",
                  linestyles="--", linewidths=0.8, zorder=3)
        handles.append(Line2D([], [], color="0.2", ls="--", lw=0.8, label="operation start"))
        _operation_labels(ax, spans, numbered, headroom)
    ax.set_xlabel("time (h:mm:ss)")
    ax.xaxis.set_major_formatter(FuncFormatter(_time_tick))
    ax.set_ylabel(f"feed ({unit})")
    ax.set_title(f"feed against time ({view.SHADE_BINS} slices), by CAM operation",
                 fontsize=10, loc="left")
    ax.grid(True, color="0.85", lw=0.5)
    legend_above(ax, handles)
    return drawn


def _operation_labels(ax, spans, numbered, headroom: float) -> None:
    """``n NAME`` at each operation's start, in up to LABEL_ROWS rows above the feeds; a label
    with no room is left out (its dashed line stays, its number is in the bar panel)."""
    fig = ax.figure
    width_px = ax.get_position().width * fig.get_size_inches()[0] * fig.dpi
    t0, t1 = ax.get_xlim()
    per_px = (t1 - t0) / width_px
    seen, x, text = set(), [], []
    for a, _, name in spans:
        if name not in seen:      # an operation entered again keeps its first label
            seen.add(name)
            x.append(a)
            text.append(f"{numbered[name]} {name}")
    widths = np.array([(len(s) * 6.2 + 10) * per_px for s in text])
    rows = view.label_rows(np.array(x), widths, LABEL_ROWS)
    for xi, s, r in zip(x, text, rows.tolist()):
        if r < 0:
            continue
        y = 1.0 - (r + 0.5) * (1.0 - 1.0 / headroom) / LABEL_ROWS
        ax.text(xi, y, f" {s}", transform=ax.get_xaxis_transform(), ha="left", va="center",
                fontsize=8, zorder=7, bbox=dict(facecolor="white", edgecolor="none", alpha=0.8, pad=1))


def _bar_panel(ax, what: str, rows: list[dict], numbered: dict[str, int], total_s: float) -> None:
    shown = rows if what != "operation" else sorted(
        rows, key=lambda r: numbered.get(r["name"], len(numbered) + 1))
    shown = shown[:MAX_BARS]
    y = np.arange(len(shown))[::-1]
    ideal = np.array([r["ideal_time_s"] + r["dwell_time_s"] for r in shown])
    lost = np.array([r["lost_time_s"] for r in shown])
    ax.barh(y, ideal, color=IDEAL_COLOR, label="at the programmed feeds")
    ax.barh(y, lost, left=ideal, color=LOST_COLOR, label="lost")
    top = float((ideal + lost).max()) if len(shown) else 1.0
    for yi, r, a, b in zip(y, shown, ideal, lost):
        share = 100.0 * b / (a + b) if a + b > 0 else 0.0
        ax.text(a + b + 0.01 * top, yi, f"{hms(a + b)[:-2]}  {share:.0f} % lost: {r['lost_to']}",
                va="center", fontsize=7.5)
    labels = []
    for r in shown:
        name = r["name"] or f"(no {what})"
        number = numbered.get(r["name"]) if what == "operation" else None
        name = name if len(name) <= 22 else name[:20] + ".."
        labels.append(f"{number} {name}" if number else name)
    ax.set_yticks(y, labels, fontsize=8)
    ax.set_xlim(0.0, 1.75 * top)
    ax.xaxis.set_major_locator(MaxNLocator(4))
    ax.xaxis.set_major_formatter(FuncFormatter(_time_tick))
    ax.set_xlabel("time (h:mm:ss)")
    ax.grid(True, axis="x", color="0.88", lw=0.5)
    ax.legend(loc="lower right", fontsize=8, framealpha=0.85)
    more = len(rows) - len(shown)
    ax.set_title(f"time by {what}" + (f" ({more} more in `ncsim run`)" if more > 0 else "")
                 + (", losing the most first" if what != "operation" else ""),
                 fontsize=10, loc="left")


def _box(points: np.ndarray, cut: np.ndarray):
    sel = points[cut] if cut.any() else points
    sel = sel[np.all(np.isfinite(sel), axis=1)]
    if not len(sel):
        return None
    lo, hi = sel.min(axis=0), sel.max(axis=0)
    pad = max(view.XY_MARGIN * float((hi - lo).max()), 0.05)
    return (float(lo[0] - pad), float(hi[0] + pad)), (float(lo[1] - pad), float(hi[1] + pad))


def _mark_starts(ax, trace, points, spans, numbered) -> None:
    """The operations' numbers where each first cuts."""
    seen = set()
    for a, b, name in spans:
        if name in seen:
            continue
        seen.add(name)
        inside = np.flatnonzero((trace.t_s >= a) & (trace.t_s <= b) & ~view.rapid_mask(trace))
        if not len(inside):
            continue
        px, py = points[inside[0]]
        ax.annotate(str(numbered[name]), (px, py), fontsize=7.5, ha="center", va="center",
                    zorder=6, bbox=dict(boxstyle="circle,pad=0.15", facecolor="white",
                                        edgecolor="0.2", lw=0.6))
