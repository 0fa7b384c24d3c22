"""The summary's compiled tallies (``ncsim.report.tally``) against their numpy definitions.

The kernels replace numpy formulations that made a dozen arrays the size of the pieces; they
must give the same numbers to the last bit, both as plain Python and compiled. The references
below are those formulations, written out here: the merge of piece boundaries and block ends
into stretches, each stretch's loss ``dt - ds / reference``, the (block, cause) sums of a
stable sort and ``np.add.reduceat``, ``np.bincount`` over the pairs, the stable ``argsort``
of the slowest blocks.
"""
from __future__ import annotations

import numpy as np
import pytest

from ncsim import jit
from ncsim.motion import LIMIT_LABELS, Limit, Phase
from ncsim.pipeline import simulate
from ncsim.report import tally
from ncsim.report.losses import N_CAUSES, TINY_S, losses, reference_feed_mm_s, settle_s
from ncsim.report.summary import summary, time_by_limit_s


def random_program(rng: np.random.Generator, n: int) -> str:
    """Lines, rapids, arcs (G2/G3 with exact end points), dwells, exact stops (G60 modal and
    G9), SOFT/BRISK changes and feed changes, in random order."""
    lines = ["G17 G90 G64 SOFT", "G0 X0 Y0 Z0", "G1 X1 F3000"]
    x, y = 1.0, 0.0
    for _ in range(n):
        r = rng.random()
        if r < 0.05:
            lines.append(f"G4 F{rng.uniform(0.01, 0.1):.3f}")
        elif r < 0.10:
            lines.append(str(rng.choice(["G60", "G64", "BRISK", "SOFT", "G601", "G602"])))
        elif r < 0.14:
            lines.append(f"F{rng.choice([600, 3000, 6000, 12000])}")
        elif r < 0.22:
            x, y = x + rng.uniform(-20, 20), y + rng.uniform(-20, 20)
            lines.append(f"G0 X{x:.6f} Y{y:.6f}")
        elif r < 0.45:
            i, j = rng.uniform(-5, 5), rng.uniform(-5, 5)
            cx, cy = x + i, y + j
            turn = rng.uniform(0.1, 3.0) * (1 if rng.random() < 0.5 else -1)
            a = np.arctan2(y - cy, x - cx) + turn
            radius = np.hypot(i, j)
            x, y = cx + radius * np.cos(a), cy + radius * np.sin(a)
            lines.append(f"{'G3' if turn > 0 else 'G2'} X{x:.9f} Y{y:.9f} I{i:.9f} J{j:.9f}")
        else:
            step = rng.choice([0.01, 0.2, 3.0, 30.0])
            x, y = x + rng.uniform(-step, step), y + rng.uniform(-step, step)
            lines.append(f"{'G9 ' if rng.random() < 0.05 else ''}G1 X{x:.6f} Y{y:.6f}")
    lines.append("M30")
    return "\n".join(lines) + "\n"


# ---- the numpy definitions -------------------------------------------------------------------

def reference_losses(motion):
    """Per block loss and cause, per kind and cause: seconds, blocks, worst block and loss."""
    path = motion.path
    n = path.n
    ref = reference_feed_mm_s(motion)
    pt, te = motion.piece_t_s, motion.t_end_s
    m = len(pt) - 1
    pos_p = np.arange(len(pt)) + np.searchsorted(te, pt, side="left")
    pos_e = np.arange(n) + np.searchsorted(pt, te, side="right")
    t = np.empty(len(pt) + n)
    t[pos_p], t[pos_e] = pt, te
    is_piece, is_end = np.zeros(len(t), np.int64), np.zeros(len(t), np.int64)
    is_piece[pos_p], is_end[pos_e] = 1, 1
    piece = np.clip(np.cumsum(is_piece)[:-1] - 1, 0, m - 1)
    block = np.clip(np.cumsum(is_end)[:-1], 0, n - 1)
    keep = (t[1:] > t[:-1]) & (motion.piece_phase[piece] != Phase.STOP)
    t0, t1, piece, block = t[:-1][keep], t[1:][keep], piece[keep], block[keep]

    def s_at(k, tt):
        tau = tt - motion.piece_t_s[k]
        return motion.piece_s_mm[k] + tau * (motion.piece_v_mm_s[k] + tau * (
            0.5 * motion.piece_a_mm_s2[k] + tau * motion.piece_j_mm_s3[k] / 6.0))

    ds = s_at(piece, t1) - s_at(piece, t0)
    with np.errstate(divide="ignore", invalid="ignore"):
        lost = (t1 - t0) - np.where(ref[block] > 0, ds / ref[block], 0.0)
    cause = motion.piece_limit[piece].astype(np.int64)
    settle = settle_s(motion)
    settled = np.flatnonzero(settle > 0)
    key = np.concatenate([block * N_CAUSES + cause, settled * N_CAUSES + int(Limit.EXACT_STOP)])
    value = np.concatenate([lost, settle[settled]])
    order = np.argsort(key, kind="stable")
    key, value = key[order], value[order]
    first = np.flatnonzero(np.concatenate([[True], key[1:] != key[:-1]]))
    pair_lost = np.add.reduceat(value, first) if len(value) else np.zeros(0)
    pair_block, pair_cause = key[first] // N_CAUSES, key[first] % N_CAUSES
    significant = pair_lost > TINY_S
    block_lost = np.maximum(np.bincount(pair_block, weights=pair_lost, minlength=n), 0.0)
    block_cause = np.full(n, int(Limit.NONE), dtype=np.int8)
    for b in np.unique(pair_block[significant]):
        sel = np.flatnonzero(significant & (pair_block == b))
        block_cause[b] = pair_cause[sel[np.argmax(pair_lost[sel])]]
    kind = path.rapid[pair_block].astype(np.int64)
    by_cause = np.zeros((2, N_CAUSES))
    blocks_by = np.zeros((2, N_CAUSES), dtype=np.int64)
    worst = np.full((2, N_CAUSES), -1, dtype=np.int64)
    worst_lost = np.zeros((2, N_CAUSES))
    for k in (0, 1):
        sel = (kind == k) & significant
        by_cause[k] = np.bincount(pair_cause[sel], weights=pair_lost[sel], minlength=N_CAUSES)
        blocks_by[k] = np.bincount(pair_cause[sel], minlength=N_CAUSES)
        for c in np.flatnonzero(blocks_by[k]):
            where = np.flatnonzero(sel & (pair_cause == c))
            w = where[int(np.argmax(pair_lost[where]))]
            worst[k, c], worst_lost[k, c] = pair_block[w], pair_lost[w]
    return block_lost, block_cause, np.maximum(by_cause, 0.0), blocks_by, worst, worst_lost


def reference_time_by_limit(motion):
    t = motion.piece_t_s
    when = np.where(motion.piece_phase == Phase.STOP, t[1:], t[:-1])
    blk = np.clip(np.searchsorted(motion.t_start_s, when, side="right") - 1, 0, motion.path.n - 1)
    dur = np.diff(t)
    rapid = motion.path.rapid[blk]
    moving = motion.piece_phase != Phase.STOP
    out = {"standstill_s": float(dur[~moving].sum())}
    for key, mask in (("feed", moving & ~rapid), ("rapid", moving & rapid)):
        sums = np.bincount(motion.piece_limit[mask], weights=dur[mask], minlength=len(LIMIT_LABELS))
        out[key] = {LIMIT_LABELS[i]: float(s) for i, s in enumerate(sums) if s > 0}
    return out


# ---- tests -----------------------------------------------------------------------------------

@pytest.mark.parametrize("which", ["python", "compiled"])
@pytest.mark.parametrize("seed", range(6))
def test_losses_and_time_by_limit_are_their_numpy_definitions(seed, which, mikron):
    text = random_program(np.random.default_rng(seed), 150)
    with jit.forced(which):
        sim = simulate("random.mpf", mikron, text=text)
        loss = losses(sim.motion)
        tbl = time_by_limit_s(sim.motion)
    want = reference_losses(sim.motion)
    got = (loss.lost_s, loss.cause, loss.by_cause_s, loss.blocks_by_cause, loss.worst_block,
           loss.worst_lost_s)
    for name, a, b in zip(("lost", "cause", "by_cause", "blocks", "worst", "worst_lost"), got, want):
        assert a.dtype == b.dtype and np.array_equal(a, b), name
    assert loss.blocks_by_cause.sum() > 0 and (loss.settle_s > 0).any()   # the cases occur
    assert tbl == reference_time_by_limit(sim.motion)


@pytest.mark.parametrize("seed", range(4))
def test_slowest_blocks_are_a_stable_sort(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(0, 3000))
    values = np.round(rng.exponential(1.0, n), 1)           # many ties
    rapid = rng.random(n) < 0.3
    order = np.argsort(-values, kind="stable")
    for k in (0, 1, 5, 10, 200, n + 3):
        for want_rapid in (False, True):
            expected = order[rapid[order] == want_rapid][:k]
            for which in ("python", "compiled"):
                with jit.forced(which):
                    got = tally.top_order(values, rapid, want_rapid, k)
                assert np.array_equal(got, expected), (k, want_rapid, which)


def test_pairwise_sum_is_numpys():
    rng = np.random.default_rng(7)
    for n in (0, 1, 7, 8, 9, 127, 128, 129, 255, 256, 1000, 4099):
        a = rng.standard_normal(n + 3) * 10.0 ** rng.integers(-8, 8, n + 3)
        for lo in (0, 3):
            want = np.add.reduce(a[lo:n + 3]) if n + 3 > lo else 0.0
            assert tally.pairwise_sum.py(a, lo, n + 3) == want
            assert tally.pairwise_sum.compiled(a, lo, n + 3) == want


def test_summary_is_the_same_with_plain_and_compiled_kernels(mikron):
    text = random_program(np.random.default_rng(11), 300)
    sims = {}
    for which in ("python", "compiled"):
        with jit.forced(which):
            sim = simulate("random.mpf", mikron, text=text)
            sims[which] = summary(sim, top=15)
    assert sims["python"] == sims["compiled"]
    assert sims["python"]["slowest_rapids"] and sims["python"]["lost_by_cause"]
