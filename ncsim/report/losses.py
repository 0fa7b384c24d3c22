"""Where the time goes: the time lost against the programmed feed, by cause and by block.

The *ideal* time of a block is its length at its reference speed: the programmed feed F for a
feed move (G1/G2/G3), the rapid traverse speed for a rapid (G0: ``min_i V_mi / |u_i|`` along
its direction, paper eq. 7), each times the override the machine file holds (what the
operator panel was set to). Everything above that is *lost*::

    cycle time = ideal time + time lost + programmed dwell (G4)

and every lost second goes to one cause, a ``motion.Limit`` label:

* while moving, each stretch of a constant-jerk piece of the motion inside one block loses
  ``dt - ds / v_ref(block)``; the loss goes to the limit of the piece, i.e. what the feed law
  is doing there: a steady phase held below F by ``ncu_path_jerk`` or ``cycle_time``, a ramp
  down to (or up from) an ``exact_stop``, a ``transition``, a ``corner``, the
  ``program_end``, an ``aux_stop`` (G0/G1 change, M output, STOPRE), or ``programmed`` for the
  ramps between two different programmed feeds;
* standing still, the exact-stop settle (the G601/G602 window must be reached before the
  block change: 840D Function Manual Basic Functions, B1 "Continuous-path mode, exact stop
  and LookAhead") is lost to ``exact_stop`` and charged to the block that ends there: the
  settle of a G60/G9 block's own window, and that of the window MD20552
  ``$MC_EXACT_POS_MODE_G0_TO_G1`` sets at a G0/G1 change (B1 "exact stop at G0-G1 change");
  a G4 dwell is programmed time, not a loss.

Pieces and blocks are merged in one pass (both are ordered in time), so a piece that spans
several short blocks is split at the block ends: the per-block sums are exact and linear in
the number of blocks. A block's loss is ``duration - length / v_ref`` plus the exact-stop
settle at its end; the blocks' losses add up to the causes' losses.

``feed`` and ``rapid`` are kept apart: a machinist reads the cutting losses first; rapids lose
their ramps at every G0/G1 change, which CAM cannot change much.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ncsim.motion import LIMIT_LABELS, Limit, Phase
from ncsim.plan.kinematics import (axis_velocity_feed_limit_mm_s, overridden_feed_mm_s,
                                   rapid_feed_mm_s)
from ncsim.report.tally import block_losses

N_CAUSES = len(LIMIT_LABELS)
KINDS = ("feed", "rapid")
TINY_S = 1e-9        # a block's loss to a cause below this is rounding (equal feeds)
MIN_CAUSE_S = 1e-6   # a cause losing less over the whole program is not listed


@dataclass(frozen=True, slots=True)
class Losses:
    """Lost time of a motion (module docstring). ``n`` blocks."""

    reference_mm_s: np.ndarray   # (n,) F, or the rapid traverse speed of a G0 block
    ideal_s: np.ndarray          # (n,) length / reference
    lost_s: np.ndarray           # (n,) duration - ideal + the exact-stop settle at its end
    settle_s: np.ndarray         # (n,) exact-stop settle at the block's end
    cause: np.ndarray            # (n,) int8 Limit losing the block the most time, settle
                                 # included (NONE: the block loses nothing)
    dwell_s: float               # programmed G4 dwell (not lost)
    # per cause (N_CAUSES), for feed moves [0] and rapids [1]
    by_cause_s: np.ndarray       # (2, N_CAUSES) seconds lost
    settle_by_kind_s: np.ndarray  # (2,) the exact-stop settle part of by_cause_s[:, EXACT_STOP]
    blocks_by_cause: np.ndarray  # (2, N_CAUSES) blocks losing more than TINY_S to the cause
    worst_block: np.ndarray      # (2, N_CAUSES) block losing the most to the cause (-1: none)
    worst_lost_s: np.ndarray     # (2, N_CAUSES) what that block loses to it

    @property
    def total_lost_s(self) -> float:
        """Moving losses and exact-stop settling, feed moves and rapids."""
        return float(self.by_cause_s.sum())


def reference_feed_mm_s(motion) -> np.ndarray:
    """The speed each block would run at with nothing in the way: F for a feed move, the
    rapid traverse speed ``min_i V_mi / |u_i|`` (eq. 7) of the line for a G0 block, each
    times the override the machine file holds (``ncu.feed_override``; ``ncu.rapid_override``
    below 100 %, a rapid never runs above its traverse speed): the speed the NC is asked for,
    as ``plan.limits`` takes it (``kinematics.overridden_feed_mm_s``, ``rapid_feed_mm_s``)."""
    path = motion.path
    ncu = motion.machine.ncu
    ref = overridden_feed_mm_s(path.feed_mm_s, ncu.feed_override)
    rapid = np.asarray(path.rapid, dtype=bool)
    if rapid.any():
        chord = path.end_mm[rapid] - path.start_mm[rapid]
        norm = np.linalg.norm(chord, axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            u = np.where(norm[:, None] > 0, chord / norm[:, None], 0.0)
        v_t = rapid_feed_mm_s(axis_velocity_feed_limit_mm_s(u, motion.machine.max_velocity_mm_s),
                              min(ncu.rapid_override, 1.0))
        # the set point is the fallback for a zero-length move (no direction)
        ref[rapid] = np.where(np.isfinite(v_t) & (v_t > 0), v_t, motion.cap_mm_s[rapid])
    return ref


def _f8(a) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float64)


def settle_s(motion) -> np.ndarray:
    """Exact-stop settle at the end of each block: the junction's standstill minus the G4
    dwell programmed there (``limits.path_limits`` adds the two; the settle is the block's own
    G60/G9 window or the MD20552 window of a G0/G1 change, all of it lost to ``exact_stop``)."""
    path = motion.path
    n = path.n
    dwell = np.asarray(motion.junction_dwell_s, dtype=np.float64)
    settle = np.empty(n)
    if n:
        np.subtract(dwell[1:n], path.dwell_before_s[1:], out=settle[:n - 1])
        settle[n - 1] = dwell[n] - path.end_dwell_s
        np.maximum(settle, 0.0, out=settle)
    return settle


def losses(motion) -> Losses:
    """The lost time of ``motion`` by cause and block (module docstring)."""
    path = motion.path
    n = path.n
    ref = reference_feed_mm_s(motion) if n else np.zeros(0)
    ideal = np.zeros(n)
    np.divide(path.length_mm, ref, out=ideal, where=ref > 0)
    g4_total = float(np.sum(path.dwell_before_s) + path.end_dwell_s) if n else float(path.end_dwell_s)
    if n == 0:
        e = np.zeros(0)
        return Losses(e, e, e, e, np.zeros(0, np.int8), g4_total, np.zeros((2, N_CAUSES)),
                      np.zeros(2), np.zeros((2, N_CAUSES), dtype=np.int64),
                      np.full((2, N_CAUSES), -1, dtype=np.int64), np.zeros((2, N_CAUSES)))

    settle = settle_s(motion)
    block_lost = np.zeros(n)
    block_cause = np.full(n, int(Limit.NONE), dtype=np.int8)
    by_cause = np.zeros((2, N_CAUSES))
    blocks_by = np.zeros((2, N_CAUSES), dtype=np.int64)
    worst = np.full((2, N_CAUSES), -1, dtype=np.int64)
    worst_lost = np.zeros((2, N_CAUSES))
    block_losses(_f8(motion.piece_t_s), _f8(motion.piece_s_mm), _f8(motion.piece_v_mm_s),
                 _f8(motion.piece_a_mm_s2), _f8(motion.piece_j_mm_s3), motion.piece_phase,
                 motion.piece_limit, _f8(motion.t_end_s), ref, settle, path.rapid,
                 int(Limit.EXACT_STOP), int(Phase.STOP), TINY_S,
                 block_lost, block_cause, by_cause, blocks_by, worst, worst_lost)
    np.maximum(block_lost, 0.0, out=block_lost)
    rapid = np.asarray(path.rapid, dtype=bool)
    settle_by_kind = np.array([settle[~rapid].sum(), settle[rapid].sum()])
    return Losses(reference_mm_s=ref, ideal_s=ideal, lost_s=block_lost,
                  settle_s=settle, cause=block_cause, dwell_s=g4_total,
                  by_cause_s=np.maximum(by_cause, 0.0), settle_by_kind_s=settle_by_kind,
                  blocks_by_cause=blocks_by, worst_block=worst, worst_lost_s=worst_lost)


def cause_rows(loss: Losses, files, path) -> list[dict]:
    """The causes losing time, largest first, feed moves and rapids apart (README "JSON
    summary", ``lost_by_cause``)."""
    rows = []
    for k, kind in enumerate(KINDS):
        for c in np.flatnonzero(loss.by_cause_s[k] > MIN_CAUSE_S):
            b = int(loss.worst_block[k, c])
            rows.append({
                "moves": kind, "cause": LIMIT_LABELS[c], "time_lost_s": float(loss.by_cause_s[k, c]),
                "settle_s": float(loss.settle_by_kind_s[k]) if c == Limit.EXACT_STOP else 0.0,
                "blocks": int(loss.blocks_by_cause[k, c]),
                "worst_block": b, "worst_file": files[int(path.file_index[b])] if b >= 0 else None,
                "worst_line": int(path.line[b]) if b >= 0 else None,
                "worst_time_lost_s": float(loss.worst_lost_s[k, c]),
            })
    rows.sort(key=lambda r: (r["moves"] != "feed", -r["time_lost_s"]))
    return rows
