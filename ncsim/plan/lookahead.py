"""Look-ahead planner: per-block limits -> the controlled-jerk feed law of the whole path.

The paper's kinematic model (§5.5) has three stages, applied here to every block:

1. *Feed set point* of each block (eq. 5-12, Fig. 12 reading) -- ``limits.path_limits``.
2. *Extremity feeds*: crossing feeds at the block transitions (eq. 13/15, corners, stops)
   -- also ``limits.path_limits`` -- lowered here by the dynamic look-ahead so that every
   change of feed is feasible.
3. *Controlled-jerk law* per block: phase A (ramp up), B (steady at the set point) and C
   (ramp down), the ramps starting and ending at zero acceleration; when B vanishes the
   peak feed solves eq. 16 (``ramps.peak_feed_mm_s``).

Generalisation for programs with many short blocks (HSM CAM output). The paper's law puts a
zero-acceleration point at every block end. Across a run of short blocks that share the same
set point and whose junctions do not limit the feed, that would make the feed crawl (each
0.1 mm block could only change the feed a little), which no 840D does. So the planner works
on *sections*:

* a junction is a **knot** (a zero-acceleration point of the feed law) when something
  happens there: start/end of the program, a stop, a junction cap below the adjacent set
  points (corner, curvature jump, look-ahead), or a change of set point between the blocks;
* the blocks between two consecutive knots form a **section**: its set point ``V_st`` is the
  lowest set point of its blocks and crossing cap of its inner junctions;
* on a section the law is exactly the paper's: A from the start knot's feed, B at ``V_st``
  if the section is long enough, C to the end knot's feed, eq. 16 otherwise. A paper arc is
  its own section, so the paper's per-block law is reproduced unchanged;
* each ramp runs under the jerk and acceleration of the blocks it crosses, not the least of
  the section (``_sections``): a line entered tangentially from an arc brakes with the
  line's own acceleration when its ramp C lies in the line; a ramp across blocks of
  different limits takes the least of those it crosses;
* knots that turn out not to limit anything (the feed stays at or below the caps on both
  sides) are removed and their sections merged, in groups that never lower a section's set
  point below its peak (``_refine_knots``): ramps then run across short blocks as on a real
  NC, and a section steady at its set point runs on into a block of a higher set point that
  it cannot rise in (no zero-acceleration stop at the change of set point).

Knot feeds come from the classic two passes (grbl's planner, in ramp form): backward, each
knot's feed is at most what one ramp can bring down to the next knot's feed over the
section (``ramps.ramp_reach_mm_s``, under the limits of the blocks the ramp crosses);
forward, at most what one ramp can bring up from the previous knot. One backward then one
forward pass reach the fixed point (a forward reduction never breaks a backward condition,
since a raised ramp end only helps a fall). The passes are a sequential recurrence, compiled
(``_sections.knot_feeds_cover``).

Look-ahead (840D "dynamic look-ahead", paper §3.2): while a block runs, the NC knows only
``lookahead_blocks`` blocks ahead and must be able to stop at the end of the last one (NC
blocks: the rows the compressor joins into one polynomial count once, ``PathLimits.nc_block``). Block
``k`` therefore gets the cap ``ramp_reach(0, S[k + D + 1] - S[k])`` and its end junction
``ramp_reach(0, S[k + D + 1] - S[k + 1])``: with too short a look-ahead the feed rises inside
each block and falls back at its end -- the sawtooth of a starved look-ahead. Beyond feeds,
the condition holds on the state: from its feed *and acceleration* at every junction the tool
can stop inside the window (``stopping_distance_mm``); a ramp that would break it is replaced
by a creep of smaller steps up to the braking-limited feed (``_pin_unstoppable``). So no
deceleration is ever cut short by the end of the window (tested with ruckig's braking
profiles).

Why this is never faster than the limits allow: every knot feed respects its cap; a section's
set point is at most every cap inside it and the feed never exceeds it; every ramp has
|j| <= J and |a| <= A of every block it runs through. ``tests/test_plan.py``
checks these invariants on random paths, ``tests/test_plan_reference.py`` checks the whole
construction against a plain scalar reference implementation.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ncsim.plan._kernels import (creep_caps, inner_junction_states, junction_states,
                                 knots_and_reasons, lookahead_caps, reach_array,
                                 removable_knots, section_minima, section_pieces,
                                 unstoppable_junctions)
from ncsim.plan._sections import (block_section_values, knot_feeds_cover, peak_feeds_cover,
                                  peak_feeds_cover_reusing)
from ncsim.machine import MachineSpec
from ncsim.motion import FULL_MODEL, Limit, ModelOptions, Motion, Phase
from ncsim.path import Path
from ncsim.plan.ramps import ramp_distance_mm

_REL = 1e-9  # relative tolerance when comparing feeds
CREEP_TOL = 0.01  # look-ahead: hold within 1 % of the braking-limited feed (see _pin_unstoppable)


def plan(path: Path, machine: MachineSpec, options: ModelOptions = FULL_MODEL, *,
         limits=None) -> Motion:
    """Plan the feed law of ``path`` on ``machine`` (see the module docstring).

    ``limits`` (a ``limits.PathLimits``) may be given to reuse or replace stage 1. When the
    limits carry the path they were made for (``limits.path``: with the compressor's runs and
    the rounding blocks of ``ncsim.plan.hsm``), that path is planned.
    """
    if limits is None:
        from ncsim.plan.limits import path_limits

        limits = path_limits(path, machine, options)
    if getattr(limits, "path", None) is not None:
        path = limits.path
    n = path.n
    length = np.asarray(path.length_mm, dtype=np.float64)
    s_junction = np.empty(n + 1)
    s_junction[0] = 0.0
    np.cumsum(length, out=s_junction[1:])

    # the caps are lowered here (look-ahead); the ramp limits and dwells are only read
    cap = np.array(limits.cap_mm_s, dtype=np.float64)
    cap_limit = np.array(limits.cap_limit, dtype=np.int8)
    jerk = np.asarray(limits.jerk_mm_s3, dtype=np.float64)
    accel = np.asarray(limits.accel_mm_s2, dtype=np.float64)
    jcap = np.array(limits.junction_cap_mm_s, dtype=np.float64)
    jlimit = np.array(limits.junction_limit, dtype=np.int8)
    dwell = np.asarray(limits.junction_dwell_s, dtype=np.float64)
    if n == 0:
        return _empty_motion(path, machine, options, dwell)

    cap = _transparent_zero_length(cap, length)
    nc_block = getattr(limits, "nc_block", None)
    depth = machine.ncu.lookahead_blocks if options.lookahead else None
    if depth is not None:
        _apply_lookahead(cap, cap_limit, jcap, jlimit, s_junction, jerk, accel, depth, nc_block)

    # crossing cap of every junction, including the set points of the blocks it joins
    p = jcap.copy()
    np.minimum(p[:-1], cap, out=p[:-1])
    np.minimum(p[1:], cap, out=p[1:])
    p[0] = min(p[0], 0.0) if np.isfinite(p[0]) else 0.0
    p[-1] = 0.0
    np.maximum(p, 0.0, out=p)

    knots, knot_reason = _find_knots(p, cap, cap_limit, jcap, jlimit)
    keep = p <= 0.0
    keep[[0, n]] = True
    lookahead_end = None
    if depth is not None:
        # junction k is crossed while block k-1 runs: blocks up to k-1+D are prepared
        lookahead_end = _prepared_end(n, depth, nc_block)
    blocks = _Blocks(np.ascontiguousarray(jerk), np.ascontiguousarray(accel), length,
                     s_junction)
    sol, p = _refine_knots(knots, p, cap, blocks, keep, lookahead_end)
    del p, keep, lookahead_end
    knots = sol["knots"]
    pieces, t_arrive, v_j, a_j = _pieces_and_junctions(sol, s_junction, knot_reason,
                                                       cap_limit, jlimit, dwell)
    sec_jerk, sec_accel, feed_max = block_section_values(
        knots, sol["ramp_limits"], sol["v_knot"], sol["v_peak"], sol["sec_len"],
        s_junction, v_j, blocks.jerk, blocks.accel)
    t_end = t_arrive[1:]
    # without dwells a block starts when the previous one ends: share the arrival times
    t_start = t_arrive[:-1] + dwell[:-1] if np.any(dwell[:-1] > 0.0) else t_arrive[:-1]
    knot_mask = np.zeros(n + 1, dtype=bool)
    knot_mask[knots] = True

    return Motion(
        path=path, machine=machine, options=options,
        cap_mm_s=cap, cap_limit=cap_limit,
        jerk_mm_s3=sec_jerk, accel_mm_s2=sec_accel,
        t_start_s=t_start, t_end_s=t_end, feed_max_mm_s=feed_max,
        junction_cap_mm_s=jcap, junction_limit=jlimit, junction_dwell_s=dwell,
        v_junction_mm_s=v_j, a_junction_mm_s2=a_j, knot=knot_mask,
        piece_t_s=pieces["t"], piece_s_mm=pieces["s"], piece_v_mm_s=pieces["v"],
        piece_a_mm_s2=pieces["a"], piece_j_mm_s3=pieces["j"],
        piece_phase=pieces["phase"], piece_limit=pieces["limit"],
    )


# ---------------------------------------------------------------------------------------------
# Stage 2: crossing caps, look-ahead, knots and knot feeds
# ---------------------------------------------------------------------------------------------

def _transparent_zero_length(cap: np.ndarray, length: np.ndarray) -> np.ndarray:
    """A block without motion takes no time and limits nothing: it inherits the set point of
    the block before it (or after it, at the start), so it never splits a section."""
    zero = length <= 0.0
    if not np.any(zero):
        return cap
    out = cap.copy()
    out[zero] = np.nan
    idx = np.where(~zero, np.arange(len(out)), 0)
    np.maximum.accumulate(idx, out=idx)
    filled = out[idx]
    if np.isnan(filled[0]):  # leading zero-length blocks: take the first real set point
        first = np.argmax(~zero) if np.any(~zero) else None
        filled[np.isnan(filled)] = out[first] if first is not None else np.inf
    return np.where(zero, filled, out)


def _nc_blocks(nc_block, n):
    """Rows -> NC blocks: the index of each row's NC block and the first row of every NC block
    (plus n). Without ``nc_block`` every row is an NC block."""
    if nc_block is None:
        return None, None
    first = np.flatnonzero(np.concatenate([[True], nc_block[1:] != nc_block[:-1]]))
    index = np.cumsum(np.concatenate([[True], nc_block[1:] != nc_block[:-1]])) - 1
    return index, np.append(first, n)


def _prepared_end(n, depth, nc_block):
    """Per junction k (crossed while row k-1 runs): the junction at the end of the prepared
    blocks -- D NC blocks after the one of row k-1."""
    index, first = _nc_blocks(nc_block, n)
    if index is None:
        return np.minimum(np.arange(n + 1) + depth, n)
    before = np.concatenate([[-1], index])          # NC block of row k-1 (-1 at the start)
    return first[np.minimum(before + depth + 1, len(first) - 1)]


def _apply_lookahead(cap, cap_limit, jcap, jlimit, s_junction, jerk, accel, depth,
                     nc_block=None) -> None:
    """Stop assumed at the end of the last prepared block (840D dynamic look-ahead).

    Block k sees blocks k+1..k+depth: it must be able to stop at junction k+depth+1. Its
    cap is the feed one ramp can brake to rest from within that window, measured from the
    block start; its end junction gets the same measured from the junction. Windows that
    reach the end of the path add nothing (the real stop is planned anyway).

    The window counts NC blocks: rows that the compressor joins into one polynomial block
    share an ``nc_block`` (``PathLimits.nc_block``) and count once; the ramp limits are then
    the least over the whole NC blocks of the window. Without NC blocks (every row one), one
    compiled pass in place (``_kernels.lookahead_caps``, window minima by monotone queues).
    """
    if nc_block is None:
        lookahead_caps(cap, cap_limit, jcap, jlimit, s_junction, np.ascontiguousarray(jerk),
                       np.ascontiguousarray(accel), int(depth), int(Limit.LOOKAHEAD))
        return
    n = len(cap)
    k = np.arange(n)
    index, first = _nc_blocks(nc_block, n)
    end = first[np.minimum(index + depth + 1, len(first) - 1)]
    j_win = window_min(np.minimum.reduceat(jerk, first[:-1]), depth + 1)[index]
    a_win = window_min(np.minimum.reduceat(accel, first[:-1]), depth + 1)[index]
    cut = end < n
    if not np.any(cut):
        return
    kk, e = k[cut], end[cut]
    zero = np.zeros(len(kk))
    jw, aw = np.ascontiguousarray(j_win[cut]), np.ascontiguousarray(a_win[cut])
    block_cap = reach_array(zero, s_junction[e] - s_junction[kk], jw, aw)
    bind = block_cap < cap[kk]
    cap[kk[bind]] = block_cap[bind]
    cap_limit[kk[bind]] = Limit.LOOKAHEAD
    junction_cap = reach_array(zero, s_junction[e] - s_junction[kk + 1], jw, aw)
    bind = junction_cap < jcap[kk + 1]
    jcap[kk[bind] + 1] = junction_cap[bind]
    jlimit[kk[bind] + 1] = Limit.LOOKAHEAD


def window_min(x: np.ndarray, width: int) -> np.ndarray:
    """min(x[k : k + width]) for every k (the window is cut at the end), in O(n) by the van
    Herk / Gil-Werman method: prefix minima inside blocks of ``width``, suffix minima, and the
    minimum of the two that cover each window."""
    n = len(x)
    if width <= 1 or n == 0:
        return x.copy()
    blocks = -(-n // width) + 1
    padded = np.full(blocks * width, np.inf)
    padded[:n] = x
    rows = padded.reshape(blocks, width)
    prefix = np.minimum.accumulate(rows, axis=1).ravel()
    suffix = np.minimum.accumulate(rows[:, ::-1], axis=1)[:, ::-1].ravel()
    k = np.arange(n)
    return np.minimum(suffix[k], prefix[k + width - 1])


def _find_knots(p, cap, cap_limit, jcap, jlimit):
    """Zero-acceleration points: ends, junctions that limit below both set points, and
    changes of set point (relative ``_REL``). Returns the knot junction indices and, per
    junction, the reason a ramp heads to or leaves it (a ``Limit``): the junction's own limit
    when its cap binds, else the limit of the lower set point beside it
    (``_kernels.knots_and_reasons``)."""
    return knots_and_reasons(p, cap, cap_limit, jcap, jlimit, _REL, int(Limit.NONE),
                             int(Limit.PROGRAM_END))


class _Blocks(NamedTuple):
    """Per block: path jerk and acceleration (its own limits), length; per junction: path
    length from the start. What the section kernels read."""

    jerk: np.ndarray
    accel: np.ndarray
    length: np.ndarray
    s_junction: np.ndarray


def _solve_knots(knots, p, cap, blocks: _Blocks, prev=None):
    """Section limits, knot feeds (both passes) and section peaks (eq. 16) for a knot set.

    A section's set point is the lowest set point of its blocks and crossing cap of its
    inner junctions, so its law can exceed neither. ``sec_cap_from`` says where it comes
    from: the first block holding the lowest set point (>= 0), or -(b + 2) for the end
    junction of block b when an inner junction holds a lower cap (``_kernels.section_minima``).
    Every ramp runs under the limits of the blocks it crosses (``_sections``): the knot
    passes and the peaks walk the blocks of the sections whose blocks' limits differ;
    ``ramp_limits`` holds each section's ramp A and C limits. ``sec_jerk``/``sec_accel``, the
    least of each section, bound the look-ahead's stops. ``prev``, the solution of a knot
    set before, lends the peaks of the sections that did not change.
    """
    jerk, accel, length, s_junction = blocks
    sec_len, sec_jerk, sec_accel, uniform, sec_cap, cap_from = section_minima(
        knots, p, cap, jerk, accel, s_junction)
    knots64 = np.ascontiguousarray(knots, dtype=np.int64)
    w = p[knots]                            # a knot is also in its sections' set points
    w[:-1] = np.minimum(w[:-1], sec_cap)
    w[1:] = np.minimum(w[1:], sec_cap)
    v_knot = knot_feeds_cover(w, knots64, uniform, sec_len, sec_jerk, sec_accel, jerk, accel,
                              length, s_junction)
    if prev is None:
        v_peak, ramp_limits = peak_feeds_cover(v_knot, knots64, uniform, sec_len, sec_jerk,
                                               sec_accel, sec_cap, jerk, accel, length,
                                               s_junction)
    else:
        v_peak, ramp_limits = peak_feeds_cover_reusing(
            v_knot, knots64, uniform, sec_len, sec_jerk, sec_accel, sec_cap, jerk, accel,
            length, s_junction, np.ascontiguousarray(prev["knots"], dtype=np.int64),
            prev["v_knot"], prev["sec_cap"], prev["v_peak"], prev["ramp_limits"])
    return dict(knots=knots, sec_len=sec_len, sec_jerk=sec_jerk, sec_accel=sec_accel,
                sec_cap=sec_cap, v_knot=v_knot, v_peak=v_peak, ramp_limits=ramp_limits,
                sec_cap_from=cap_from)


def _refine_knots(knots, p, cap, blocks: _Blocks, keep, lookahead_end, max_rounds=8):
    """Drop knots that do not limit anything, so that ramps run across them.

    The first knot set marks every junction that *might* limit the feed. A knot where the
    sections it joins stay at or below the lower of their set points and of its own crossing
    cap is only a zero-acceleration stop in the middle of a ramp: it is removed and the
    sections merge (set point = the smallest, the removed junction's cap included; each ramp
    still under the limits of the blocks it crosses), which keeps every cap. Removal walks
    along the path in groups (``_kernels.removable_knots``): a group grows only while its
    highest peak stays at or below its lowest set point, so a merge never lowers the set
    point under a section's peak.

    One condition is on the state, not the feed: with a finite look-ahead the tool must be
    able to stop, from its feed *and acceleration* at junction k, before ``lookahead_end[k]``
    (the end of the blocks prepared while block k - 1 runs; None: no look-ahead).
    A junction passed while still accelerating may fail that although its feed is below the
    cap; it becomes a knot for good (at a knot the acceleration is zero and the cap suffices).
    """
    sol = _solve_knots(knots, p, cap, blocks)
    for _ in range(max_rounds):
        k = sol["knots"]
        inner = np.arange(1, len(k) - 1)
        if inner.size == 0:
            break
        remove = removable_knots(sol["v_peak"], sol["sec_cap"], p[k], keep[k])
        if not np.any(remove):
            break
        sol = _solve_knots(k[~remove], p, cap, blocks, prev=sol)
    if lookahead_end is not None:
        sol, p = _pin_unstoppable(sol, p, cap, blocks, keep, lookahead_end)
    return sol, p


def _pin_unstoppable(sol, p, cap, blocks: _Blocks, keep, lookahead_end, rounds=8):
    """Bring every junction state inside the look-ahead's braking room.

    The critical state on a ramp towards V is where its last -J piece begins: stopping from
    there takes that piece plus one ramp from V to rest
    (``_kernels.approach_stop_distance_scalar``). A
    section whose rise fails at some junction (``_kernels.unstoppable_junctions``) is rebuilt
    as a creep (``_kernels.creep_caps``): ramps to the highest approach feed that passes, each
    ending at a new knot, then the next (smaller) step, until within ``CREEP_TOL`` of the set
    point, where the feed holds -- as an NC re-planning at every new block edges up to the
    braking-limited feed. Repeats until no junction fails. The stops and the creep assume the
    least limits of the section (a stop may run through any of its blocks). Lowers ``p`` and
    sets ``keep`` in place.
    """
    s_junction = blocks.s_junction
    for _ in range(rounds):
        knots = sol["knots"]
        v_j, a_j = _inner_states(sol, s_junction)
        bad, bad_sec, bad_room = unstoppable_junctions(
            v_j, a_j, knots.astype(np.int64), sol["sec_jerk"], sol["sec_accel"], s_junction,
            lookahead_end)
        del v_j, a_j
        if len(bad) == 0:
            break
        sections = np.unique(bad_sec)
        # the tightest room over the failing section bounds every step of its creep
        sec_room = np.full(len(sol["v_peak"]), np.inf)
        np.minimum.at(sec_room, bad_sec, bad_room)
        creep_caps(p, keep, s_junction, knots[sections].astype(np.int64),
                   knots[sections + 1].astype(np.int64), sol["v_knot"][sections],
                   sec_room[sections], sol["sec_jerk"][sections], sol["sec_accel"][sections],
                   sol["sec_cap"][sections], CREEP_TOL)
        new_knots = np.union1d(knots, np.nonzero(keep)[0])
        sol = _solve_knots(new_knots, p, cap, blocks, prev=sol)
    return sol, p


def _inner_states(sol, s_junction):
    """Feed and acceleration at every junction for a solved knot set (without building the
    pieces: ``_kernels.inner_junction_states``)."""
    return inner_junction_states(sol["v_knot"], sol["v_peak"], sol["sec_len"],
                                 sol["ramp_limits"], sol["knots"].astype(np.int64), s_junction)


def stopping_distance_mm(v_mm_s, a_mm_s2, jerk_mm_s3, accel_mm_s2):
    """Shortest distance to rest from feed v and tangential acceleration a (jerk J, accel A).

    * a >= 0: first bring a back to zero at jerk -J (the feed still grows by a^2/2J), then
      one ramp from there to rest.
    * a < 0 with |a| < A: the state lies on the first piece of a braking ramp that began at
      rest acceleration from v_s = v + a^2/2J; the rest of that ramp is the stop.
    * |a| >= A: the state is on the constant-deceleration part: brake at A down to A^2/2J,
      then the closing +J piece (A^3/6J^2).
    """
    v = np.asarray(v_mm_s, dtype=np.float64)
    a = np.asarray(a_mm_s2, dtype=np.float64)
    j = np.asarray(jerk_mm_s3, dtype=np.float64)
    A = np.asarray(accel_mm_s2, dtype=np.float64)
    ap = np.maximum(a, 0.0)
    t = ap / j
    rising = v * t + ap * t * t / 2.0 - j * t ** 3 / 6.0 \
        + ramp_distance_mm(v + ap * ap / (2.0 * j), 0.0, j, A)
    an = np.minimum(np.maximum(-a, 0.0), A)
    t = an / j
    v_s = v + an * an / (2.0 * j)
    braking = ramp_distance_mm(v_s, 0.0, j, A) - (v_s * t - j * t ** 3 / 6.0)
    v_f = A * A / (2.0 * j)
    constant = np.maximum(v * v - v_f * v_f, 0.0) / (2.0 * A) + A ** 3 / (6.0 * j * j)
    return np.where(a >= 0.0, rising, np.where(-a < A * (1.0 - 1e-12), braking, constant))


# ---------------------------------------------------------------------------------------------
# Stage 3: the controlled-jerk law of every section as constant-jerk pieces
# ---------------------------------------------------------------------------------------------

def _pieces_and_junctions(sol, s_junction, knot_reason, cap_limit, junction_limit, dwell):
    """The section laws as constant-jerk pieces, and the state at every junction."""
    knots = sol["knots"]
    src = sol["sec_cap_from"]
    # steady phase: the limit of the block or inner junction that sets the section's set point
    # (-(j + 2) encodes junction j + 1, the end of block j)
    steady_reason = np.where(src >= 0, cap_limit[np.maximum(src, 0)],
                             junction_limit[np.maximum(-src - 1, 0)]).astype(np.int8)
    times, s0, v0, a0, jj, ph, lim, sec_end_t = section_pieces(
        sol["v_knot"], sol["v_peak"], sol["sec_len"], sol["ramp_limits"],
        s_junction[knots[:-1]], dwell[knots[:-1]], float(dwell[knots[-1]]),
        knot_reason[knots[:-1]], knot_reason[knots[1:]], steady_reason,
        int(Phase.A), int(Phase.B), int(Phase.C), int(Phase.STOP), int(Limit.DWELL))
    pieces = dict(t=times, s=s0, v=v0, a=a0, j=jj, phase=ph, limit=lim)
    is_knot = np.zeros(len(s_junction), dtype=np.bool_)
    is_knot[knots] = True
    knot_time = np.concatenate([[0.0], sec_end_t])
    t_arr, v_j, a_j = junction_states(times, s0, v0, a0, jj, ph, int(Phase.STOP),
                                      s_junction, is_knot, knot_time, sol["v_knot"],
                                      np.ascontiguousarray(dwell[knots], dtype=np.float64))
    return pieces, t_arr, v_j, a_j


def _empty_motion(path, machine, options, dwell):
    total = float(dwell.sum()) if len(dwell) else 0.0
    e = np.zeros(0)
    ei = np.zeros(0, dtype=np.int8)
    t = np.array([0.0, total]) if total > 0 else np.array([0.0])
    one = np.zeros(1) if total > 0 else e
    return Motion(path=path, machine=machine, options=options,
                  cap_mm_s=e, cap_limit=ei, jerk_mm_s3=e, accel_mm_s2=e,
                  t_start_s=e, t_end_s=e, feed_max_mm_s=e,
                  junction_cap_mm_s=np.zeros(1), junction_limit=np.array([Limit.PROGRAM_END], dtype=np.int8),
                  junction_dwell_s=dwell if len(dwell) else np.zeros(1),
                  v_junction_mm_s=np.zeros(1), a_junction_mm_s2=np.zeros(1),
                  knot=np.ones(1, dtype=bool),
                  piece_t_s=t, piece_s_mm=one, piece_v_mm_s=one, piece_a_mm_s2=one,
                  piece_j_mm_s3=one,
                  piece_phase=np.full(len(one), Phase.STOP, dtype=np.int8),
                  piece_limit=np.full(len(one), Limit.DWELL, dtype=np.int8))
