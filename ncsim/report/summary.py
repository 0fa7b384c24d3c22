"""Summaries of a simulation: cycle time, where and why the feed is limited, lost time.

``summary(sim)`` returns a JSON-able dict (schema in README "JSON summary"); ``format_text``
renders it for a terminal. Both work from the planned motion alone (no sampling).

Definitions (all over the moving time, standstills excluded unless said otherwise):

* ``feed_efficiency``: ideal time at the programmed feeds (times the feed override the machine
  file holds) over the real time, on feed moves (G1/G2/G3): 1.0 would mean the programmed
  feed held everywhere, ramps included.
* ``limited_fraction``: share of the feed-move time during which something other than the
  programmed feed holds the feed (ramps included).
* ``time_by_limit_s``: time during which each limit holds the feed (``motion.Limit`` labels);
  ``dwell`` is standstill time.
* per block ``limit``: the block's set-point limit when the set point is below the
  programmed feed; otherwise what holds the feed in the middle of the block (a ramp towards
  a transition, a corner...), or ``programmed`` when the programmed feed is reached.
* time lost (``report.losses``): the real time minus the time at the programmed feeds (rapids
  at their traverse speed), by cause over the program (``lost_by_cause``) and per block
  (``time_lost_s`` and ``lost_to``), feed moves and rapids apart: the slowest feed blocks
  (``slowest_blocks``) and the slowest rapids (``slowest_rapids``) are listed separately.

Feeds are in mm/min in the JSON (the unit is in the key names); :func:`format_text` prints
them in the unit asked for (``units.FEED_UNITS``).
"""
from __future__ import annotations

import os
from collections import OrderedDict

import numpy as np

from ncsim import __version__
from ncsim.motion import LIMIT_LABELS, Limit, Phase
from ncsim.plan.sample import block_table, limit_labels
from ncsim.report.breakdown import structure_lines, structure_tables
from ncsim.report.losses import cause_rows, losses
from ncsim.report.tally import piece_tally, top_order
from ncsim.units import feed_from_mm_s, mm_min_to_mm_s, mm_s_to_mm_min

SCHEMA_VERSION = 1


def piece_blocks(motion) -> np.ndarray:
    """Block index of every piece: the block running when it starts (a standstill belongs to
    the block it waits for). Found by time, not by path length: a piece starts exactly when
    its block does (both come from the same sums), while a tolerance on s would give the
    last ramp pieces of a block shorter than it to the next block -- a rapid's time counted
    as feed time."""
    t = motion.piece_t_s
    when = np.where(motion.piece_phase == Phase.STOP, t[1:], t[:-1])
    blk = np.searchsorted(motion.t_start_s, when, side="right") - 1
    return np.clip(blk, 0, max(motion.path.n - 1, 0))


def time_by_limit_s(motion) -> dict[str, dict[str, float]]:
    """Seconds during which each limit holds the feed, split into feed moves and rapids (a
    piece counts for the block of :func:`piece_blocks`: ``tally.piece_tally``)."""
    out = {"feed": {}, "rapid": {}}
    sums = np.zeros((2, len(LIMIT_LABELS)))
    stops = np.empty(int(np.count_nonzero(motion.piece_phase == Phase.STOP)))
    piece_tally(np.ascontiguousarray(motion.piece_t_s, dtype=np.float64), motion.piece_phase,
                motion.piece_limit, np.ascontiguousarray(motion.t_start_s, dtype=np.float64),
                motion.path.rapid, int(Phase.STOP), sums, stops)
    out["standstill_s"] = float(stops.sum())
    if motion.path.n == 0:
        return out
    for k, key in enumerate(("feed", "rapid")):
        out[key] = {LIMIT_LABELS[i]: float(s) for i, s in enumerate(sums[k]) if s > 0}
    return out


def block_rows(motion, loss=None, index=None) -> dict[str, np.ndarray]:
    """``sample.block_table`` plus the refined per-block limit, the lost time against the
    programmed feed (a rapid: its traverse speed) and the cause losing the block most time
    (``report.losses``; ``loss`` may be given when already computed), for the blocks
    ``index`` (all by default; ``block`` says which)."""
    path = motion.path
    if index is None:
        rows = block_table(motion)
        idx = slice(None)
    else:
        idx = np.asarray(index, dtype=np.int64)
        rows = _table_rows(motion, idx)
    if path.n == 0:
        rows["limit"] = np.zeros(0, dtype=object)
        rows["lost_to"] = np.zeros(0, dtype=object)
        rows["tables"] = ((), ())
        return rows
    loss = losses(motion) if loss is None else loss
    reference = loss.reference_mm_s[idx]
    rows["time_lost_s"] = loss.lost_s[idx]
    rows["lost_to"] = limit_labels(loss.cause[idx])
    # what holds the feed in the middle of the block, as Limit codes (labels made once, last)
    mid = np.add(motion.t_start_s[idx], motion.t_end_s[idx])
    mid *= 0.5
    k = np.searchsorted(motion.piece_t_s, mid, side="right")
    del mid
    if len(motion.piece_limit):
        k -= 1
        np.clip(k, 0, len(motion.piece_limit) - 1, out=k)
        code = motion.piece_limit[k]
    else:
        code = np.full(len(k), int(Limit.NONE), dtype=np.int8)
    del k
    cap, cap_limit = motion.cap_mm_s[idx], motion.cap_limit[idx]
    set_point_binds = cap < reference * (1 - 1e-9)
    reached = motion.feed_max_mm_s[idx] >= reference * (1 - 1e-3)
    code[reached] = int(Limit.PROGRAMMED)
    code[set_point_binds] = cap_limit[set_point_binds]
    # a rapid that reaches its speed is held by its set-point limit (the axis velocity)
    held = path.rapid[idx] & reached
    code[held] = cap_limit[held]
    rows["limit"] = limit_labels(code)
    rows["file_index"] = path.file_index[idx].astype(np.int64)
    for name in ("block_number", "tool", "operation"):     # where it is in the program
        rows[name] = getattr(path, name)[idx]
    rows["tables"] = (path.tools, path.operations)
    return rows


def _table_rows(motion, idx: np.ndarray) -> dict[str, np.ndarray]:
    """The columns of ``sample.block_table`` that :func:`block_dicts` shows, for blocks
    ``idx`` only."""
    path = motion.path
    return {
        "block": idx,
        "line": path.line[idx].astype(np.int64),
        "t_start_s": motion.t_start_s[idx],
        "duration_s": motion.t_end_s[idx] - motion.t_start_s[idx],
        "feed_programmed_mm_s": path.feed_mm_s[idx],
        "feed_max_mm_s": motion.feed_max_mm_s[idx],
        "cap_mm_s": motion.cap_mm_s[idx],
    }


def feed_table(motion) -> list[dict]:
    """Programmed against reached feed, per programmed feed value (feed moves only)."""
    path = motion.path
    out = []
    if path.n == 0:
        return out
    feed_moves = ~path.rapid & (path.length_mm > 0)
    dur = motion.duration_s
    for f in np.unique(path.feed_mm_s[feed_moves]):
        sel = feed_moves & (path.feed_mm_s == f)
        length = float(path.length_mm[sel].sum())
        t = float(dur[sel].sum())
        out.append(OrderedDict(
            feed_programmed_mm_min=float(mm_s_to_mm_min(f)),
            blocks=int(sel.sum()), length_mm=length, time_s=t,
            feed_mean_mm_min=float(mm_s_to_mm_min(length / t)) if t > 0 else 0.0,
            feed_max_mm_min=float(mm_s_to_mm_min(motion.feed_max_mm_s[sel].max())),
            setpoint_min_mm_min=float(mm_s_to_mm_min(motion.cap_mm_s[sel].min())),
        ))
    return out


def summary(sim, *, top: int = 10, include_blocks: bool = True, loss=None) -> dict:
    """The documented JSON summary of a :class:`~ncsim.pipeline.Simulation` (``loss``: its
    ``losses.losses`` when already computed)."""
    motion = sim.motion
    path = motion.path
    tbl = time_by_limit_s(motion)
    loss = losses(motion) if loss is None else loss
    dur = motion.duration_s if path.n else np.zeros(0)
    feed_moves = ~path.rapid & (path.length_mm > 0) if path.n else np.zeros(0, bool)
    feed_time = float(dur[feed_moves].sum()) if path.n else 0.0
    ideal = float(loss.ideal_s[feed_moves].sum()) if path.n else 0.0
    limited = sum(v for k, v in tbl["feed"].items() if k != Limit.PROGRAMMED.label)
    files = path.files
    order = top_order(loss.lost_s, path.rapid, False, top)
    rapid_order = top_order(loss.lost_s, path.rapid, True, top)
    if include_blocks:
        rows = block_rows(motion, loss)
        slowest, slowest_rapids = order, rapid_order
    else:   # only the rows listed
        rows = block_rows(motion, loss, np.concatenate([order, rapid_order]))
        slowest, slowest_rapids = np.arange(len(order)), len(order) + np.arange(len(rapid_order))

    out = OrderedDict(
        schema=SCHEMA_VERSION, ncsim_version=__version__,
        program=sim.program, machine=sim.machine.name,
        model={k: getattr(sim.options, k) for k in sim.options.__slots__},
        cycle_time_s=motion.total_time_s,
        moving_time_s=float(dur.sum()) if path.n else 0.0,
        standstill_time_s=tbl["standstill_s"],
        rapid_time_s=float(dur[path.rapid].sum()) if path.n else 0.0,
        feed_time_s=feed_time,
        path_length_mm=path.total_length_mm,
        blocks=path.n,
        reached_program_end=sim.interpreted.complete if sim.interpreted is not None else True,
        feed_efficiency=ideal / feed_time if feed_time > 0 else 1.0,
        limited_fraction=limited / feed_time if feed_time > 0 else 0.0,
        time_by_limit_s=tbl["feed"], rapid_time_by_limit_s=tbl["rapid"],
        ideal_time_s=float(loss.ideal_s.sum()), lost_time_s=loss.total_lost_s,
        dwell_time_s=loss.dwell_s,
        lost_by_cause=cause_rows(loss, files, path),
        **structure_tables(motion, loss, top), **tool_changes(sim),
        feeds=feed_table(motion),
        slowest_blocks=block_dicts(rows, files, slowest),
        slowest_rapids=block_dicts(rows, files, slowest_rapids),
        warnings=[w.render() for w in sim.warnings],
        **approximations(sim),
    )
    if include_blocks:
        out["blocks_detail"] = block_dicts(rows, files, np.arange(path.n))
    return out


def tool_changes(sim) -> dict:
    """``tool_changes`` (M6 executed) and ``tool_change_s`` (the machine file's time of each,
    0 when it gives none)."""
    recorded = sim.interpreted.recorded if sim.interpreted is not None else ()
    return {"tool_changes": sum(1 for r in recorded if r.name == "M6"),
            "tool_change_s": float(sim.machine.tool_change_s)}


def approximations(sim) -> dict:
    """``approximate`` (bool) and ``approximations`` ({kind: {"count", "reason"}}): what was
    not simulated although it can change the time (ignored cycles, rotary axes, TRAORI, tool
    changes, missing subprograms, ...), each kind with how often it was executed."""
    found = sim.interpreted.approximations if sim.interpreted is not None else ()
    return {"approximate": bool(found),
            "approximations": {kind: {"count": n, "reason": reason} for kind, n, reason in found}}


def block_dicts(rows: dict, files, index) -> list[dict]:
    """One dict per row ``index`` of ``rows`` (:func:`block_rows`; keys in README "JSON
    summary"), built column-wise: a million blocks take about a second (per-element numpy
    indexing took ~40 us a block)."""
    idx = np.asarray(index, dtype=np.int64)
    if len(idx) == 0:
        return []
    file_names = np.asarray(files, dtype=object)[rows["file_index"][idx]].tolist()
    columns = {
        "block": rows["block"][idx].tolist(), "file": file_names, "line": rows["line"][idx].tolist(),
        "t_start_s": rows["t_start_s"][idx].astype(np.float64).tolist(),
        "duration_s": rows["duration_s"][idx].astype(np.float64).tolist(),
        "feed_programmed_mm_min": _feeds(rows["feed_programmed_mm_s"][idx]),
        "feed_setpoint_mm_min": _feeds(rows["cap_mm_s"][idx]),
        "feed_max_mm_min": _feeds(rows["feed_max_mm_s"][idx]),
        "limit": [str(v) for v in rows["limit"][idx].tolist()],
        "time_lost_s": rows["time_lost_s"][idx].astype(np.float64).tolist(),
        "lost_to": [str(v) for v in rows["lost_to"][idx].tolist()],
        "n": _numbers(rows["block_number"][idx]),
        "tool": _names(rows["tool"][idx], rows["tables"][0]),
        "operation": _names(rows["operation"][idx], rows["tables"][1]),
    }
    keys = tuple(columns)
    return [dict(zip(keys, values)) for values in zip(*columns.values())]


def _numbers(n: np.ndarray) -> list:
    """N numbers as Python ints, None where a block has none (-1)."""
    return np.where(n >= 0, n, None).tolist() if (n < 0).any() else n.tolist()


def _names(codes: np.ndarray, names: tuple[str, ...]) -> list:
    """The names a tool or operation column indexes, None where there is none (-1)."""
    return np.asarray((*names, None), dtype=object)[codes].tolist()


def _feeds(v_mm_s: np.ndarray) -> list:
    """mm/min as Python floats, None where not finite (a rapid's programmed feed)."""
    v = mm_s_to_mm_min(np.asarray(v_mm_s, dtype=np.float64))
    out = v.tolist()
    for k in np.flatnonzero(~np.isfinite(v)).tolist():
        out[k] = None
    return out


#: decimals a feed is printed with, per unit (``units.FEED_UNITS``)
FEED_DECIMALS = {"mm/min": 0, "m/min": 3, "mm/s": 2, "in/min": 1}
TEXT_RAPIDS = 5     # rapids listed at most in the text (all --top of them in the JSON)


def format_text(s: dict, feed_unit: str = "mm/min") -> str:
    """A terminal rendering of :func:`summary`, feeds in ``feed_unit`` (mm/min by default)."""
    def feed(v_mm_min, width: int) -> str:
        if v_mm_min is None:
            return f"{'-':>{width}}"
        value = feed_from_mm_s(mm_min_to_mm_s(v_mm_min), feed_unit)
        return f"{value:{width}.{FEED_DECIMALS.get(feed_unit, 1)}f}"

    lines = [
        f"program     {s['program']}",
        f"machine     {s['machine']}",
        f"cycle time  {s['cycle_time_s']:.3f} s   (feed moves {s['feed_time_s']:.3f} s, rapids "
        f"{s['rapid_time_s']:.3f} s, standing {s['standstill_time_s']:.3f} s)",
        f"            = {s['ideal_time_s']:.3f} s at the programmed feeds and rapid traverse + "
        f"{s['lost_time_s']:.3f} s lost" + (f" + {s['dwell_time_s']:.3f} s dwell (G4)"
                                              if s["dwell_time_s"] > 0 else ""),
        f"path        {s['path_length_mm']:.1f} mm in {s['blocks']} blocks",
        f"feed        efficiency {100 * s['feed_efficiency']:.1f} %  "
        f"(ideal time at programmed feed / real time); limited {100 * s['limited_fraction']:.1f} % of feed time",
    ]
    if s["feeds"]:
        lines.append("")
        lines.append(f"programmed vs reached feed ({feed_unit})")
        lines.append(f"  {'programmed':>10} {'set point':>10} {'reached max':>11} {'mean':>10} {'blocks':>8} {'time s':>9}")
        for f in s["feeds"]:
            lines.append(f"  {feed(f['feed_programmed_mm_min'], 10)} {feed(f['setpoint_min_mm_min'], 10)} "
                         f"{feed(f['feed_max_mm_min'], 11)} {feed(f['feed_mean_mm_min'], 10)} "
                         f"{f['blocks']:8d} {f['time_s']:9.3f}")
    lines += _cause_lines(s)
    lines += structure_lines(s, _where)
    for key, title, most in (("slowest_blocks", "feed blocks losing the most time", None),
                             ("slowest_rapids", "rapids losing the most time", TEXT_RAPIDS)):
        blocks = s.get(key) or []
        if not blocks:
            continue
        lines.append("")
        lines.append(f"{title} (feeds in {feed_unit})")
        lines.append(f"  {'file:line':<28} {'block':>7} {'prog':>8} {'set':>8} {'reached':>8} "
                     f"{'limit':<14} {'lost to':<14} {'time s':>8} {'lost s':>8}")
        for b in blocks[:most]:
            where = _where(b["file"], b["line"])
            prog = f"{'rapid':>8}" if b["feed_programmed_mm_min"] is None else feed(b["feed_programmed_mm_min"], 8)
            lines.append(f"  {where:<28} {b['block']:>7} {prog} {feed(b['feed_setpoint_mm_min'], 8)} "
                         f"{feed(b['feed_max_mm_min'], 8)} {b['limit']:<14} {b['lost_to']:<14} "
                         f"{b['duration_s']:8.3f} {b['time_lost_s']:8.3f}")
    if s.get("approximate"):
        lines.append("")
        lines.append("approximate: the time leaves out what ncsim does not simulate")
        for kind, a in s["approximations"].items():
            lines.append(f"  {kind:<20} {a['count']:>6} x  {a['reason']}")
    if s["warnings"]:
        lines.append("")
        lines.append(f"{len(s['warnings'])} warning(s) (see stderr)")
    return "\n".join(lines) + "\n"


def _cause_lines(s: dict) -> list[str]:
    """Time lost by cause over the program, feed moves then rapids, with the worst block."""
    rows = [r for r in s.get("lost_by_cause", []) if r["time_lost_s"] >= 5e-4]  # no slivers
    if not rows:
        return []
    total = s["cycle_time_s"] or 1.0
    out = ["", "time lost by cause (against the programmed feeds; rapids: their traverse speed)",
           f"  {'':<16} {'lost s':>9} {'of cycle':>8} {'blocks':>7}  worst block (its loss)"]
    for moves, title in (("feed", "feed moves"), ("rapid", "rapids")):
        part = [r for r in rows if r["moves"] == moves]
        if not part:
            continue
        out.append(f"  {title}")
        for r in part:
            worst = "-" if r["worst_file"] is None else \
                f"{_where(r['worst_file'], r['worst_line'])} ({r['worst_time_lost_s']:.3f} s)"
            settle = f"; settling {r['settle_s']:.3f} s" if r["settle_s"] >= 5e-4 else ""
            out.append(f"    {r['cause']:<14} {r['time_lost_s']:9.3f} {100 * r['time_lost_s'] / total:6.1f} % "
                       f"{r['blocks']:7d}  {worst}{settle}")
    return out


def _where(file: str, line: int, width: int = 28) -> str:
    """``name:line`` in at most ``width`` characters (a long file name loses its middle)."""
    tail = f":{line}"
    name = os.path.basename(file)
    room = width - len(tail)
    if len(name) > room:
        keep = max(room - 2, 2)
        name = name[:keep - keep // 2] + ".." + name[len(name) - keep // 2:]
    return name + tail
