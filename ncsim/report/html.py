"""One self-contained HTML report of a run (``ncsim report PROGRAM -o report.html``).

Made with plotly (its JavaScript inlined once, so the file opens anywhere without network):

* the 3-D toolpath coloured by the reached feed (a menu switches to the share of the
  programmed feed reached, or to the limit holding the feed), rapids thin and grey; hovering
  a point names its block: ``file:line``, N number, tool, operation, the limit holding the
  feed and the feed reached against the programmed one;
* the feed against time (programmed F, set point, reached; rapids apart), with the same
  hover and each CAM operation's start marked;
* the tables by operation and tool (h:mm:ss, N ranges) and the source lines losing most time,
  from the JSON summary (``report.summary``).

Large programs are decimated sensibly: the samples are spread half evenly over the time and
half evenly over the path length (a long slow stretch and a long fast one both keep their
shape), at most ``max_points`` for each figure; every hover still names the block it is in.
"""
from __future__ import annotations

import html
import os

import numpy as np

from ncsim.motion import LIMIT_LABELS
from ncsim.report import view
from ncsim.report.breakdown import hms, range_text
from ncsim.report.drawing import LIMIT_COLORS
from ncsim.units import feed_from_mm_s

MAX_POINTS = 10_000
PLOTLY_CONFIG = {"displaylogo": False, "responsive": True,
                 "modeBarButtonsToRemove": ["sendDataToCloud"]}


def sample_times(motion, max_points: int) -> np.ndarray:
    """Sample times for the report: half evenly in time, half evenly along the path length
    (``s(t)`` inverted on the motion's pieces), plus the end; sorted, no repeats."""
    total = motion.total_time_s
    if total <= 0 or not motion.path.n:
        return np.zeros(1)
    half = max(max_points // 2, 2)
    by_time = np.linspace(0.0, total, half)
    s_end = float(motion.piece_s_mm[-1]) if len(motion.piece_s_mm) else 0.0
    t_knots = np.asarray(motion.piece_t_s[:-1], dtype=np.float64)
    s_knots = np.asarray(motion.piece_s_mm, dtype=np.float64)
    s_wanted = np.linspace(0.0, s_end, half)
    by_length = np.interp(s_wanted, s_knots, t_knots) if s_end > 0 else np.zeros(0)
    return np.unique(np.clip(np.concatenate([by_time, by_length, [total]]), 0.0, total))


def block_labels(path, blocks: np.ndarray, limits: np.ndarray) -> list[str]:
    """The hover text of each sample: ``file:line  N..``, ``tool | operation`` and the limit
    holding its feed, one line each (made once per block)."""
    names = {}
    for b in np.unique(blocks).tolist():
        n = int(path.block_number[b])
        where = f"{os.path.basename(path.file_of(b))}:{int(path.line[b])}" + (f"  N{n}" if n >= 0 else "")
        tool = path.tool_of(b) or "-"
        op = path.operation_of(b) or "-"
        names[b] = f"{html.escape(where)}<br>{html.escape(tool)} | {html.escape(op)}"
    return [f"{names[b]}<br>{LIMIT_LABELS[c] if 0 <= c < len(LIMIT_LABELS) else '-'}"
            for b, c in zip(blocks.tolist(), limits.tolist())]


def _pieces(mask: np.ndarray) -> np.ndarray:
    """The indices of the samples where ``mask`` holds, with -1 between the stretches (a
    plotly line breaks at a gap): each sample's data go into one trace only."""
    idx = np.flatnonzero(mask)
    if not len(idx):
        return idx
    breaks = np.flatnonzero(np.diff(idx) > 1) + 1
    return np.insert(idx, breaks, -1)


def _take(values, idx: np.ndarray, gap=np.nan):
    """``values`` at ``idx``, ``gap`` where idx is -1 (a list for text)."""
    if isinstance(values, list):
        return [values[i] if i >= 0 else None for i in idx.tolist()]
    out = np.asarray(values)[np.maximum(idx, 0)].astype(np.float64)
    out[idx < 0] = gap
    return out


def _figures(sim, summary: dict, feed_unit: str, max_points: int):
    import plotly.graph_objects as go

    from ncsim.plan.sample import sample_motion

    motion = sim.motion
    wanted = min(max_points, 400 + 40 * motion.path.n)    # a short program needs few samples
    trace = sample_motion(motion, t_s=sample_times(motion, wanted))
    rapid = view.rapid_mask(trace)
    feed = np.round(feed_from_mm_s(trace.feed_mm_s, feed_unit), 1)
    prog = np.round(feed_from_mm_s(np.where(rapid, 0.0, trace.programmed_mm_s), feed_unit), 1)
    ratio = np.round(100.0 * np.fmin(view.feed_ratio(trace), 1.0), 1)
    text = block_labels(motion.path, np.clip(trace.block, 0, motion.path.n - 1),
                        trace.limit.astype(np.int64))
    key = "<extra>file:line N<br>tool | operation<br>limit</extra>"
    hover = "%{text}<br>feed %{customdata[0]:.0f} of F %{customdata[1]:.0f} " + feed_unit + key
    rapid_hover = "%{text}<br>rapid (G0) at %{customdata[0]:.0f} " + feed_unit + key
    custom = np.stack([feed, prog], axis=1)
    cut_i, rapid_i = _pieces(~rapid), _pieces(rapid)
    top = float(np.nanmax(feed[~rapid])) if (~rapid).any() else 1.0
    pos = trace.pos_mm

    def line3d(idx, name, line, template=hover):
        return go.Scatter3d(x=_take(pos[:, 0], idx), y=_take(pos[:, 1], idx),
                            z=_take(pos[:, 2], idx), mode="lines", name=name,
                            text=_take(text, idx), customdata=np.stack(
                                [_take(custom[:, 0], idx), _take(custom[:, 1], idx)], axis=1),
                            hovertemplate=template, line=line)

    colour = {"reached feed": (_take(feed, cut_i), "Viridis", top, f"feed<br>{feed_unit}"),
              "reached / programmed feed": (_take(ratio, cut_i), "RdYlGn", 100.0, "% of F"),
              "limit holding the feed": (_take(trace.limit, cut_i),
                                         [[i / (len(LIMIT_LABELS) - 1), LIMIT_COLORS.get(lbl, "#fff")]
                                          for i, lbl in enumerate(LIMIT_LABELS)],
                                         float(len(LIMIT_LABELS) - 1), "limit")}
    values, scale, cmax, label = colour["reached feed"]
    fig3d = go.Figure([
        line3d(cut_i, "cutting", dict(width=5, color=values, colorscale=scale, cmin=0,
                                      cmax=cmax, colorbar=dict(title=label, len=0.75))),
        line3d(rapid_i, "rapid (G0)", dict(width=1.5, color="rgb(150,150,150)", dash="dash"),
               rapid_hover)])
    menu = [dict(label=name, method="restyle",
                 args=[{"line.color": [v], "line.colorscale": [sc], "line.cmin": [0],
                        "line.cmax": [cm], "line.colorbar.title.text": [lb]}, [0]])
            for name, (v, sc, cm, lb) in colour.items()]
    scene, stretched = _scene(pos, rapid)
    fig3d.update_layout(
        title="Toolpath: hover a point to name its block" + (" (Z stretched)" if stretched else ""),
        height=640, margin=dict(l=0, r=0, t=50, b=0), legend=dict(x=0.01, y=0.9),
        scene=scene,
        updatemenus=[dict(buttons=menu, direction="down", x=0.01, xanchor="left", y=0.99,
                          yanchor="top", showactive=True)])

    t = trace.t_s
    setpoint = np.round(feed_from_mm_s(np.where(rapid, np.nan, trace.setpoint_mm_s), feed_unit), 1)

    def line2d(idx, y, name, line, template=None):
        hovered = template is not None
        extra = dict(text=_take(text, idx), customdata=np.stack(
            [_take(custom[:, 0], idx), _take(custom[:, 1], idx)], axis=1),
            hovertemplate=template) if hovered else dict(hoverinfo="skip")
        return go.Scattergl(x=_take(t, idx), y=_take(y, idx), mode="lines", name=name,
                            line=line, visible=True if hovered or "dot" in str(line) else "legendonly",
                            **extra)

    feeds = go.Figure([
        line2d(cut_i, feed, "reached feed", dict(color="black", width=1.2), hover),
        line2d(cut_i, prog, "programmed F", dict(color="rgb(60,60,60)", width=1, dash="dot")),
        line2d(cut_i, setpoint, "set point (eq. 12)", dict(color="rgb(214,96,77)", width=1)),
        line2d(rapid_i, feed, "rapid (G0)", dict(color="rgb(170,170,170)", width=1), rapid_hover)])
    for a, _, name in _first_spans(view.operation_spans(motion)):
        feeds.add_vline(x=a, line=dict(color="rgb(50,50,50)", dash="dash", width=1))
        feeds.add_annotation(x=a, y=1.0, yref="paper", text=html.escape(name), showarrow=False,
                             xanchor="left", yanchor="bottom", textangle=-30, font=dict(size=10))
    feeds.update_layout(title="Feed against time (operations marked)", height=420,
                        xaxis_title="time (s)", yaxis_title=f"feed ({feed_unit})",
                        yaxis_range=[0, 1.15 * top], margin=dict(t=90), hovermode="closest")
    return fig3d, feeds, len(trace)


MIN_Z_ASPECT = 0.15     # a flat part's Z is drawn at least this share of its larger side


def _scene(pos: np.ndarray, rapid: np.ndarray) -> tuple[dict, bool]:
    """The 3-D scene framed on the cutting moves (rapids to a tool-change position far away
    run out of it), at equal scale on X and Y and on Z unless the part is flatter than
    MIN_Z_ASPECT (then Z is stretched, and the title says so)."""
    cut = pos[~rapid] if (~rapid).any() else pos
    lo, hi = cut.min(axis=0), cut.max(axis=0)
    span = np.maximum(hi - lo, 1e-3)
    pad = 0.05 * float(span.max())
    lo, hi = lo - pad, hi + pad
    aspect = (hi - lo) / float((hi - lo).max())
    stretched = bool(aspect[2] < MIN_Z_ASPECT)
    aspect[2] = max(aspect[2], MIN_Z_ASPECT)
    axis = {f"{a}axis": dict(title=f"{a.upper()} (mm)", range=[float(lo[i]), float(hi[i])])
            for i, a in enumerate("xyz")}
    return dict(aspectmode="manual", aspectratio=dict(x=aspect[0], y=aspect[1], z=aspect[2]),
                **axis), stretched


def _first_spans(spans):
    seen = set()
    for a, b, name in spans:
        if name not in seen:
            seen.add(name)
            yield a, b, name


def _table(rows: list[dict], what: str, total: float) -> str:
    head = (f"<tr><th>{what}</th><th>time</th><th>at programmed feeds</th><th>lost</th>"
            f"<th>lost % of cycle</th><th>lost most to</th><th>N</th></tr>")
    body = []
    for r in rows:
        name = r["name"] if r["name"] is not None else f"(no {what})"
        body.append(f"<tr><td>{html.escape(name)}</td><td>{hms(r['time_s'])}</td>"
                    f"<td>{hms(r['ideal_time_s'])}</td><td>{hms(r['lost_time_s'])}</td>"
                    f"<td>{100 * r['lost_time_s'] / (total or 1):.1f} %</td><td>{r['lost_to']}</td>"
                    f"<td>{html.escape(range_text(r['n_ranges'], r['n_ranges_more'], most=4))}</td></tr>")
    return f"<table>{head}{''.join(body)}</table>"


def _lines_table(rows: list[dict]) -> str:
    body = "".join(
        f"<tr><td>{html.escape(os.path.basename(r['file']))}:{r['line']}</td>"
        f"<td>{'' if r['n'] is None else 'N' + str(r['n'])}</td><td>{r['blocks']}</td>"
        f"<td>{r['time_s']:.3f}</td><td>{r['lost_time_s']:.3f}</td><td>{r['lost_to']}</td></tr>"
        for r in rows)
    return ("<table><tr><th>file:line</th><th>N</th><th>blocks</th><th>time s</th>"
            f"<th>lost s</th><th>lost most to</th></tr>{body}</table>")


STYLE = """
body { font-family: system-ui, sans-serif; margin: 1.5em; color: #222; }
h1 { font-size: 1.4em; margin-bottom: 0.2em; } h2 { font-size: 1.15em; margin-top: 1.6em; }
table { border-collapse: collapse; font-size: 0.9em; }
th, td { border: 1px solid #ccc; padding: 3px 8px; text-align: right; }
td:first-child, th:first-child { text-align: left; }
th { background: #f0f0f0; } .note { color: #666; font-size: 0.85em; }
"""


def report_html(sim, summary: dict, *, title: str | None = None, feed_unit: str = "mm/min",
                max_points: int = MAX_POINTS) -> str:
    """The report page (module docstring) as one HTML text."""
    import plotly.io as pio

    fig3d, feeds, n = _figures(sim, summary, feed_unit, max_points)
    s = summary
    head = title or f"{os.path.basename(s['program'])} on {s['machine']}"
    parts = [f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>{html.escape(head)}</title>"
             f"<style>{STYLE}</style></head><body>",
             f"<h1>{html.escape(head)}</h1>",
             f"<p>cycle time <b>{hms(s['cycle_time_s'])}</b> ({s['cycle_time_s']:.3f} s) = "
             f"{hms(s['ideal_time_s'])} at the programmed feeds and rapid traverse + "
             f"<b>{hms(s['lost_time_s'])} lost</b>"
             + (f" + {hms(s['dwell_time_s'])} dwell and tool changes" if s["dwell_time_s"] > 0 else "")
             + f"; {s['blocks']} blocks, {s['path_length_mm']:.1f} mm; feed efficiency "
             f"{100 * s['feed_efficiency']:.1f} %</p>"]
    if s.get("approximate"):
        what = ", ".join(f"{k} ({v['count']}x)" for k, v in s["approximations"].items())
        parts.append(f"<p class='note'>approximate: not simulated: {html.escape(what)}</p>")
    parts.append(pio.to_html(fig3d, include_plotlyjs=True, full_html=False,
                             include_mathjax=False, config=PLOTLY_CONFIG, div_id="toolpath"))
    parts.append(pio.to_html(feeds, include_plotlyjs=False, full_html=False,
                             include_mathjax=False, config=PLOTLY_CONFIG, div_id="feed"))
    total = s["cycle_time_s"]
    for key, what in (("by_operation", "operation"), ("by_tool", "tool")):
        if s.get(key):
            parts.append(f"<h2>Time by {what}</h2>" + _table(s[key], what, total))
    if s.get("tool_changes"):
        from ncsim.report.breakdown import tool_change_note
        parts.append(f"<p class='note'>{html.escape(tool_change_note(s))}</p>")
    if s.get("by_line"):
        parts.append("<h2>Source lines losing the most time</h2>"
                     "<p class='note'>a loop's passes summed on its line</p>"
                     + _lines_table(s["by_line"]))
    parts.append(f"<p class='note'>ncsim {html.escape(s['ncsim_version'])}; {n} samples drawn "
                 f"(half evenly in time, half along the path); machine {html.escape(s['machine'])}"
                 f"</p></body></html>")
    return "\n".join(parts)

