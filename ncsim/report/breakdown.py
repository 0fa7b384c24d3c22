"""Where the time goes in the program's own terms: by CAM operation, tool, N number and line.

The summary's causes say *why* time is lost; this module says *where*, in the units a CAM
programmer and a machinist look up: the operation (the CAM post's operation comments or MSG
texts), the tool, the N number and the source line, with a loop's passes summed onto its
line. Each segment of the planned path carries its N number, tool and operation
(``ncsim.nc.outline``; a G641-G645 rounding block carries those of the block it rounds out of).

Per block (``block_times``), from the planned motion and ``report.losses``::

    time = duration + standing before it (G4 dwell, tool change) + exact-stop settle at its end
         = ideal + lost + dwell

where ``ideal`` and ``lost`` are the block's ideal and lost time of ``report.losses`` (lost:
the settle included) and ``dwell`` its standstill that is not lost (G4 and the machine file's
tool-change time). The standstill after the last block goes to the last block, so the blocks'
times add up to the cycle time, and so do the rows of every table here. A group's ``lost_to``
is the cause its blocks lose most time to (each block's loss counted for its own main cause).

A group's ``n_ranges`` are the N numbers where it runs, in execution order: a run of
consecutive blocks of the group gives ``[first N, last N]`` (blocks without N skipped), so a
tool used twice has two ranges.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ncsim.motion import LIMIT_LABELS, Limit
from ncsim.report.losses import N_CAUSES, Losses

MAX_RANGES = 8       # N ranges listed per group at most (the JSON says how many more)


@dataclass(frozen=True, slots=True)
class BlockTimes:
    """Per block of the motion (module docstring); the arrays are ``n`` long. A block's time
    is ``ideal_s + lost_s + dwell_s`` (its duration, settle and standstill before it; the
    sum is not kept: a million-block summary needs one array less)."""

    ideal_s: np.ndarray
    lost_s: np.ndarray
    dwell_s: np.ndarray
    cause: np.ndarray      # int8 Limit the block loses most to (NONE: nothing)


def block_times(motion, loss: Losses) -> BlockTimes:
    """Each block's share of the cycle time (module docstring)."""
    n = motion.path.n
    dwell_j = np.asarray(motion.junction_dwell_s, dtype=np.float64)
    settle = loss.settle_s
    standing = dwell_j[:n].copy()
    if n > 1:
        standing[1:] -= settle[:-1]           # the settle is the previous block's
    np.maximum(standing, 0.0, out=standing)
    if n:
        standing[-1] += max(float(dwell_j[n]) - float(settle[-1]), 0.0)
    return BlockTimes(ideal_s=loss.ideal_s, lost_s=loss.lost_s, dwell_s=standing,
                      cause=loss.cause)


def _sums(key: np.ndarray, size: int, t: BlockTimes) -> dict[str, np.ndarray]:
    """Per group ``0..size-1`` of ``key`` (int64, no negative): blocks, time, ideal, lost and
    dwell."""
    out = {"blocks": np.bincount(key, minlength=size)}
    for name in ("ideal_s", "lost_s", "dwell_s"):
        out[name] = np.bincount(key, weights=getattr(t, name), minlength=size)
    out["time_s"] = out["ideal_s"] + out["lost_s"] + out["dwell_s"]
    return out


def _causes(key: np.ndarray, groups: np.ndarray, t: BlockTimes) -> np.ndarray:
    """The cause the blocks of each group of ``groups`` lose most time to (module docstring),
    as Limit codes; only the groups asked for are tallied (a table of every source line by
    every cause would be a hundred megabytes on a million-line program)."""
    slot = np.full(int(key.max()) + 1 if len(key) else 1, -1, dtype=np.int64)
    slot[groups] = np.arange(len(groups))
    k = slot[key]
    mine = k >= 0
    by_cause = np.bincount(k[mine] * N_CAUSES + t.cause[mine].astype(np.int64),
                           weights=t.lost_s[mine], minlength=len(groups) * N_CAUSES)
    by_cause = by_cause.reshape(len(groups), N_CAUSES)
    by_cause[:, int(Limit.NONE)] = 0.0
    return np.where(by_cause.max(axis=1) > 0.0, by_cause.argmax(axis=1), int(Limit.NONE))


def n_ranges(codes: np.ndarray, numbers: np.ndarray, size: int) -> list[list[list[int]]]:
    """Per group ``0..size-1`` of ``codes`` (-1: none), its ``[first N, last N]`` runs in
    execution order (module docstring)."""
    out: list[list[list[int]]] = [[] for _ in range(size)]
    if not len(codes):
        return out
    starts = np.concatenate([[0], np.flatnonzero(codes[1:] != codes[:-1]) + 1]).tolist()
    for a, b in zip(starts, starts[1:] + [len(codes)]):
        g = int(codes[a])
        has = numbers[a:b] >= 0
        if g < 0 or not has.any():
            continue
        first, last = a + int(np.argmax(has)), b - 1 - int(np.argmax(has[::-1]))
        out[g].append([int(numbers[first]), int(numbers[last])])
    return out


def by_label(codes: np.ndarray, names: tuple[str, ...], numbers: np.ndarray,
             t: BlockTimes) -> list[dict]:
    """One row per name of ``names`` that ``codes`` (an operation or tool column, -1: none)
    uses, and one named None for the blocks without one, by time lost (largest first)."""
    if not names:                                 # no operation (or tool) at all: one row
        return [] if not len(codes) else [_whole(numbers, t)]
    size = len(names) + 1
    key = codes.astype(np.int64)
    key += 1                                      # 0: none
    sums = _sums(key, size, t)
    ranges = n_ranges(key, numbers, size)
    order = np.array([g for g in np.argsort(-sums["lost_s"], kind="stable").tolist()
                      if sums["blocks"][g]], dtype=np.int64)
    causes = _causes(key, order, t) if len(order) else order
    rows = []
    for g, cause in zip(order.tolist(), causes.tolist()):
        r = ranges[g]
        rows.append({"name": (None, *names)[g], **_group(sums, g, cause),
                     "n_ranges": r[:MAX_RANGES], "n_ranges_more": max(len(r) - MAX_RANGES, 0)})
    return rows


def _whole(numbers: np.ndarray, t: BlockTimes) -> dict:
    """The one row of a program without operations (or tools): all its blocks."""
    sums = {"blocks": np.array([len(numbers)]),
            **{k: np.array([float(np.sum(getattr(t, k)))]) for k in ("ideal_s", "lost_s", "dwell_s")}}
    sums["time_s"] = sums["ideal_s"] + sums["lost_s"] + sums["dwell_s"]
    by_cause = np.bincount(t.cause.astype(np.int64), weights=t.lost_s, minlength=N_CAUSES)
    by_cause[int(Limit.NONE)] = 0.0
    cause = int(by_cause.argmax()) if by_cause.max() > 0 else int(Limit.NONE)
    r = n_ranges(np.zeros(len(numbers), dtype=np.int8), numbers, 1)[0]
    return {"name": None, **_group(sums, 0, cause), "n_ranges": r[:MAX_RANGES],
            "n_ranges_more": max(len(r) - MAX_RANGES, 0)}


def by_line_and_number(path, t: BlockTimes, top: int) -> tuple[list[dict], list[dict]]:
    """The ``top`` source lines losing the most time, each with its N number and the sums of
    all its blocks (a loop's passes together), and the ``top`` N numbers (per file; a number
    on several lines sums them all; blocks without N left out). Only the time lost is summed
    for every line; the other sums only for the lines and numbers listed (a million-line
    program's tables stay a few arrays of its lines)."""
    key, offsets = _line_keys(path)
    if not len(key):
        return [], []
    size = int(offsets[-1])
    blocks = np.bincount(key, minlength=size)
    lost = np.bincount(key, weights=t.lost_s, minlength=size)
    number = np.full(size, -1, dtype=np.int32)             # N of each (file, line)
    number[key] = path.block_number
    wanted = _top_numbers(number, blocks, lost, offsets, top)
    order = _top(blocks, lost, top)
    del blocks, lost
    sums, causes = _tally(key, order, t)
    file_of = np.searchsorted(offsets, order, side="right") - 1
    lines = [{"file": path.files[int(f)], "line": int(g - offsets[f]),
              "n": None if number[g] < 0 else int(number[g]), **_group(sums, k, causes[k])}
             for k, (g, f) in enumerate(zip(order.tolist(), file_of.tolist()))]
    del key, number
    if len(path.files) == 1:          # file 0: the key is the number (-1 matches none)
        block_key = path.block_number
    else:
        block_key = path.file_index.astype(np.int64)
        block_key <<= 32
        block_key |= path.block_number
        block_key[path.block_number < 0] = -1
    sums, causes = _tally(block_key, wanted, t)
    numbers = [{"file": path.files[int(w >> 32)], "n": int(w & 0xFFFFFFFF),
                **_group(sums, k, causes[k])} for k, w in enumerate(wanted.tolist())]
    return lines, numbers


def _top_numbers(number, blocks, lost, offsets, top: int) -> np.ndarray:
    """The ``top`` N numbers losing the most time, as keys ``file << 32 | N``: the lines'
    losses gathered by number."""
    used = (blocks > 0) & (number >= 0)
    if not used.any():
        return np.zeros(0, dtype=np.int64)
    if len(offsets) > 2:
        n_key = number[used].astype(np.int64)
        n_key |= (np.searchsorted(offsets, np.flatnonzero(used), side="right") - 1) << 32
    else:
        n_key = number[used]
    if len(n_key) < 2 or bool(np.all(n_key[1:] > n_key[:-1])):   # CAM output: each line
        return n_key[_top(blocks[used], lost[used], top)].astype(np.int64)   # its own N
    n_keys, n_group = np.unique(n_key, return_inverse=True)
    del n_key
    n_lost = np.bincount(n_group, weights=lost[used], minlength=len(n_keys))
    n_blocks = np.bincount(n_group, weights=blocks[used], minlength=len(n_keys))
    return n_keys[_top(n_blocks, n_lost, top)].astype(np.int64)


def _tally(key: np.ndarray, groups: np.ndarray, t: BlockTimes) -> tuple[dict, np.ndarray]:
    """The sums (:func:`_sums`) and causes (:func:`_causes`) of the few ``groups`` (key values,
    in the order given) over the blocks whose ``key`` is one of them."""
    if not len(groups):
        return _sums(np.zeros(0, dtype=np.int64), 0, t), np.zeros(0, dtype=np.int64)
    sort = np.argsort(groups)
    pos = np.searchsorted(groups[sort], key)
    np.minimum(pos, len(groups) - 1, out=pos)
    hit = groups[sort][pos] == key
    slot = sort[pos[hit]]                      # index into ``groups`` of each block hit
    sub = BlockTimes(*(getattr(t, f)[hit] for f in BlockTimes.__slots__))
    return _sums(slot, len(groups), sub), _causes(slot, np.arange(len(groups)), sub)


def _group(sums, g: int, cause: int) -> dict:
    return {"blocks": int(sums["blocks"][g]), "time_s": float(sums["time_s"][g]),
            "ideal_time_s": float(sums["ideal_s"][g]), "lost_time_s": float(sums["lost_s"][g]),
            "dwell_time_s": float(sums["dwell_s"][g]), "lost_to": LIMIT_LABELS[int(cause)]}


def _top(blocks: np.ndarray, lost: np.ndarray, top: int) -> np.ndarray:
    """Groups with blocks, the ``top`` losing the most time, largest first (``lost`` is
    overwritten)."""
    k = min(top, int(np.count_nonzero(blocks)))
    if k <= 0:
        return np.zeros(0, dtype=np.int64)
    lost[blocks == 0] = -np.inf
    part = np.argpartition(lost, len(lost) - k)[len(lost) - k:] if k < len(lost) else np.arange(len(lost))
    return part[np.lexsort((part, -lost[part]))].astype(np.int64)


def _line_keys(path) -> tuple[np.ndarray, np.ndarray]:
    """A group key per block for (file, line), and the key offset of each file."""
    if not path.n:
        return np.zeros(0, dtype=np.int64), np.zeros(1, dtype=np.int64)
    line = path.line.astype(np.int64)
    if len(path.files) == 1:
        return line, np.array([0, int(line.max()) + 1], dtype=np.int64)
    fi = path.file_index.astype(np.int64)
    top = np.zeros(len(path.files), dtype=np.int64)
    np.maximum.at(top, fi, line + 1)
    offsets = np.concatenate([[0], np.cumsum(top)])
    return offsets[fi] + line, offsets


def structure_tables(motion, loss: Losses, top: int = 10) -> dict:
    """The summary's tables (README "JSON summary"): ``by_operation``, ``by_tool`` (all), and
    the ``top`` lines and N numbers losing most time, ``by_line`` and ``by_n``."""
    path = motion.path
    t = block_times(motion, loss)
    numbers = path.block_number
    lines, by_n = by_line_and_number(path, t, top)
    return {"by_operation": by_label(path.operation, path.operations, numbers, t),
            "by_tool": by_label(path.tool, path.tools, numbers, t),
            "by_line": lines, "by_n": by_n}


def hms(seconds: float) -> str:
    """``h:mm:ss.s``: 154.27 -> ``0:02:34.3``."""
    tenths = int(round(max(seconds, 0.0) * 10))
    h, rest = divmod(tenths, 36000)
    m, rest = divmod(rest, 600)
    return f"{h}:{m:02d}:{rest // 10:02d}.{rest % 10}"


def range_text(ranges: list[list[int]], more: int = 0, most: int = 2) -> str:
    """``N550-N15580, N23770-N24200`` (at most ``most`` ranges, then ``+k``)."""
    parts = [f"N{a}" if a == b else f"N{a}-N{b}" for a, b in ranges[:most]]
    extra = len(ranges) - most + more if len(ranges) > most else more
    return ", ".join(parts) + (f" +{extra}" if extra > 0 else "") if parts else "-"


# ---------------------------------------------------------------------------------------------
# Text
# ---------------------------------------------------------------------------------------------

TEXT_GROUPS = 6       # operations and tools listed at most in the text (all in the JSON)


def tool_change_note(s: dict) -> str:
    """What the tool changes cost, or that the machine file gives no time for them."""
    n = s.get("tool_changes", 0)
    each = s.get("tool_change_s", 0.0)
    if not n:
        return ""
    if each > 0:
        return f"tool changes: {n} x {each:g} s = {hms(n * each)} (machine file [tool_change] time_s)"
    return (f"tool changes: {n} at 0 s each, the machine file gives no [tool_change] time_s "
            f"(approximate)")


def structure_lines(s: dict, where, width: int = 28) -> list[str]:
    """The summary's tables by operation, tool and source line, for a terminal; ``where``
    writes a ``file:line`` in ``width`` characters."""
    out: list[str] = []
    total = s["cycle_time_s"] or 1.0
    for key, title in (("by_operation", "operation"), ("by_tool", "tool")):
        rows = s.get(key) or []
        if not rows or (len(rows) == 1 and rows[0]["name"] is None):
            continue
        out += ["", f"time by {title}, most time lost first (h:mm:ss; lost %: share of the cycle)",
                f"  {title:<{width}} {'time':>10} {'ideal':>10} {'lost':>10} {'lost %':>6}  "
                f"{'lost most to':<14} N"]
        for r in rows[:TEXT_GROUPS]:
            name = r["name"] or f"(no {title})"
            name = name if len(name) <= width else name[:width - 2] + ".."
            out.append(f"  {name:<{width}} {hms(r['time_s']):>10} {hms(r['ideal_time_s']):>10} "
                       f"{hms(r['lost_time_s']):>10} {100 * r['lost_time_s'] / total:5.1f}%  "
                       f"{r['lost_to']:<14} {range_text(r['n_ranges'], r['n_ranges_more'])}")
        if len(rows) > TEXT_GROUPS:
            out.append(f"  ... and {len(rows) - TEXT_GROUPS} more (JSON: {key})")
        note = tool_change_note(s) if key == "by_tool" else ""
        if note:
            out.append(f"  {note}")
    lines = s.get("by_line") or []
    if lines:
        out += ["", "source lines losing the most time (a loop's passes summed on its line)",
                f"  {'file:line':<{width}} {'N':>8} {'blocks':>8} {'time s':>10} {'lost s':>10}  lost most to"]
        for r in lines:
            n = "-" if r["n"] is None else f"N{r['n']}"
            out.append(f"  {where(r['file'], r['line'], width):<{width}} {n:>8} {r['blocks']:>8} "
                       f"{r['time_s']:10.3f} {r['lost_time_s']:10.3f}  {r['lost_to']}")
    return out
