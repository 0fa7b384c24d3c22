"""Drawing pieces shared by the run figures (``report.plot``: a zoomed or short run in detail;
``report.overview``: a whole program at a glance): the limit colours and the background
shading, the feed curves, the path views coloured by how much of the programmed feed is
reached, legends. Matplotlib's object API only."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from matplotlib.collections import LineCollection, PolyCollection
from matplotlib.colors import Normalize
from matplotlib.patches import Patch
from matplotlib.ticker import PercentFormatter

from ncsim.motion import LIMIT_LABELS, Trace
from ncsim.report import view
from ncsim.units import feed_from_mm_s

RAPID_COLOR = "0.55"             # rapids: thin and grey
RAPID_SHADE = "#e4e4e4"          # background where a rapid runs
RAPID_CODE = -1                  # limit code of a rapid sample in the shading
HIDDEN_CODE = -2                 # not shaded (a hidden rapid)

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
RATIO_CMAP = "RdYlGn"            # reached / programmed feed: red slow, green at F


def finite_any(a: np.ndarray) -> bool:
    return bool(len(a)) and bool(np.isfinite(a).any())



def runs(codes: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Maximal runs of equal codes: (first index, end index exclusive, code)."""
    if len(codes) == 0:
        return np.zeros(0, int), np.zeros(0, int), np.zeros(0, codes.dtype)
    change = np.flatnonzero(np.diff(codes) != 0) + 1
    start = np.concatenate([[0], change])
    end = np.concatenate([change, [len(codes)]])
    return start, end, codes[start]


def shade_limits(ax, x: np.ndarray, limit: np.ndarray, **dominance) -> set[int]:
    """Shade the background of ``ax`` by ``limit`` code over ``x``; returns the codes drawn
    (RAPID_CODE is shaded grey, HIDDEN_CODE not at all). The runs are those a reader can
    see: each slice of the panel takes the limit that holds it longest
    (``view.dominant_runs``, with its ``weights`` and ``floor``)."""
    x_lo, x_hi, code = view.dominant_runs(x, limit, **dominance)
    if len(code) == 0:
        return set()
    drawn = set()
    for c in np.unique(code):
        sel = (code == c) & (x_hi > x_lo)
        if int(c) == HIDDEN_CODE or not np.any(sel):
            continue
        verts = [((a, 0.0), (a, 1.0), (b, 1.0), (b, 0.0)) for a, b in zip(x_lo[sel], x_hi[sel])]
        if int(c) == RAPID_CODE:
            color = RAPID_SHADE
        else:
            label = LIMIT_LABELS[int(c)] if 0 <= int(c) < len(LIMIT_LABELS) else "none"
            color = LIMIT_COLORS.get(label, "#ffffff")
        coll = PolyCollection(verts, facecolors=color, edgecolors="none", alpha=0.55, zorder=0,
                              transform=ax.get_xaxis_transform())
        ax.add_collection(coll, autolim=False)
        drawn.add(int(c))
    return drawn


def legend_above(ax, handles=None) -> None:
    """A one-row legend above the axes, right-aligned (the title is on the left)."""
    kwargs = {} if handles is None else {"handles": handles}
    n = len(handles) if handles is not None else len(ax.get_legend_handles_labels()[0])
    ax.legend(loc="lower right", bbox_to_anchor=(1.0, 1.0), ncol=max(n, 1), fontsize=8,
              frameon=False, borderaxespad=0.1, handlelength=1.8, columnspacing=1.0, **kwargs)


@dataclass(frozen=True)
class Feeds:
    """The feed curves in the figure's unit, rapids apart."""
    programmed: np.ndarray
    setpoint: np.ndarray
    cutting: np.ndarray       # reached feed, NaN on rapids
    rapid: np.ndarray         # reached feed, NaN on cutting moves
    top: float                # feed axis top
    rapid_max: float          # fastest rapid in view (0 if none)


def feeds_of(trace: Trace, rapid: np.ndarray, unit: str) -> Feeds:
    def conv(v):
        v = feed_from_mm_s(np.asarray(v, dtype=np.float64), unit)
        return np.where(np.isfinite(v), v, np.nan)
    reached = conv(trace.feed_mm_s)
    rapid_feed = np.where(rapid, reached, np.nan)
    return Feeds(programmed=np.where(rapid, np.nan, conv(trace.programmed_mm_s)),
                  setpoint=np.where(rapid, np.nan, conv(trace.setpoint_mm_s)),
                  cutting=np.where(rapid, np.nan, reached), rapid=rapid_feed,
                  top=float(feed_from_mm_s(view.feed_top_mm_s(trace, ~rapid), unit)),
                  rapid_max=float(np.nanmax(rapid_feed)) if np.any(rapid & np.isfinite(reached)) else 0.0)


def feed_lines(ax, x, f: Feeds, show_rapids: bool, unit: str, lw: float = 1.0) -> list:
    handles = []
    if finite_any(f.programmed):
        handles += ax.plot(x, f.programmed, color="0.25", lw=1.2, ls=":", label="programmed F")
    if finite_any(f.setpoint):   # dashes drown in many short blocks: solid and faint there
        handles += ax.plot(x, f.setpoint, color="C3", lw=1.2 * lw, ls="--" if lw >= 1 else "-",
                           alpha=1.0 if lw >= 1 else 0.6, label="set point (eq. 12)")
    if show_rapids and finite_any(f.rapid):
        handles += ax.plot(x, f.rapid, color=RAPID_COLOR, lw=0.7, label="rapid (G0)")
    handles += ax.plot(x, f.cutting, color="k", lw=1.4 * lw, label="reached feed")
    ax.set_ylim(0.0, f.top)
    if show_rapids and f.rapid_max > f.top:
        digits = 0 if unit in ("mm/min",) else 2
        ax.text(0.995, 0.97, f"rapids up to {f.rapid_max:.{digits}f} {unit}, off scale",
                transform=ax.transAxes, ha="right", va="top", fontsize=7.5, color="0.35", zorder=6,
                bbox=dict(facecolor="white", edgecolor="none", alpha=0.7, pad=1.5))
    return handles


def equal_aspect(box, height_over_width: float):
    """Widen the shorter side of an XY box about its centre so that 1 mm is as long on both
    axes of a panel ``height_over_width`` high per unit width."""
    (x0, x1), (y0, y1) = box
    w, h = x1 - x0, y1 - y0
    if h / w < height_over_width:
        grow = (w * height_over_width - h) / 2
        return (x0, x1), (y0 - grow, y1 + grow)
    grow = (h / height_over_width - w) / 2
    return (x0 - grow, x1 + grow), (y0, y1)




def limit_legend(fig, drawn: set[int], y: float = 0.935) -> None:
    """The legend of the background shading, centred above the panels."""
    if not drawn:
        return
    order = sorted(drawn)
    patches = [Patch(facecolor=RAPID_SHADE if c == RAPID_CODE else LIMIT_COLORS.get(LIMIT_LABELS[c], "#fff"),
                     alpha=0.55, edgecolor="0.6", label="rapid (G0)" if c == RAPID_CODE else LIMIT_LABELS[c])
               for c in [c for c in order if c != RAPID_CODE] + [c for c in order if c == RAPID_CODE]]
    fig.legend(handles=patches, loc="upper center", bbox_to_anchor=(0.5, y),
               ncol=min(len(patches), 8), fontsize=9, frameon=False,
               title="background: the limit holding the feed", title_fontsize=9)


def path_view(ax, points: np.ndarray, rapid: np.ndarray, ratio: np.ndarray,
              show_rapids: bool = True) -> LineCollection:
    """A 2-D projection of the path (``points`` (m, 2)): cutting moves coloured by the share
    of the programmed feed reached (``view.feed_ratio``; red slow, green at F), rapids as
    thin dashed grey lines. Returns the coloured collection (for a colour bar)."""
    seg = np.stack([points[:-1], points[1:]], axis=1)
    seg_rapid = rapid[:-1] | rapid[1:]
    value = np.fmin(0.5 * (ratio[:-1] + ratio[1:]), 1.0)
    lc = LineCollection(seg[~seg_rapid], cmap=RATIO_CMAP, norm=Normalize(0.0, 1.0),
                        linewidths=1.6, zorder=2)
    lc.set_array(value[~seg_rapid])
    ax.add_collection(lc)
    rapid_seg = seg[seg_rapid]
    if show_rapids and len(rapid_seg) and np.nanmax(np.abs(rapid_seg[:, 1] - rapid_seg[:, 0])) > 0:
        ax.add_collection(LineCollection(rapid_seg, colors=RAPID_COLOR, linewidths=0.7,
                                         linestyles="--", zorder=1), autolim=False)
    return lc


def ratio_colorbar(fig, mappable, axes, **kwargs):
    """The colour bar of :func:`path_view`, in percent of the programmed feed."""
    cb = fig.colorbar(mappable, ax=axes, format=PercentFormatter(1.0), **kwargs)
    cb.set_label("reached / programmed feed")
    return cb


def frame(fig, ax, box) -> None:
    """Frame ``ax`` on ``box`` ((x0, x1), (y0, y1)) at equal scale on both axes (after any
    colour bar took its share of the panel)."""
    if box is not None:
        pos = ax.get_position()
        fig_w, fig_h = fig.get_size_inches()
        (x0, x1), (y0, y1) = equal_aspect(box, pos.height * fig_h / (pos.width * fig_w))
        ax.set_xlim(x0, x1)
        ax.set_ylim(y0, y1)
    ax.set_aspect("equal", adjustable="box")


def footer(fig, notes: list[str]) -> None:
    """What the reader should know about the drawing itself (thinning, what is left out),
    small, at the bottom right (the bottom left holds a panel's own notes)."""
    if notes:
        import textwrap
        fig.text(0.945, 0.006, "\n".join(textwrap.wrap("; ".join(notes), 90)), ha="right",
                 va="bottom", fontsize=8, color="0.35")
