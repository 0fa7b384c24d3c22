"""Compiled tallies of a planned motion for the summary: time lost per block and cause, time
per limit, the blocks losing the most time.

Each is one pass over the constant-jerk pieces and the blocks, both ordered in time, with no
per-piece temporaries (a million-block summary used to make a dozen arrays the size of the
pieces, and page faults on that memory cost more than the arithmetic). The kernels run as
plain Python on small motions (``ncsim.jit``).

They add in the order numpy's reductions of :mod:`ncsim.report.losses` and
:mod:`ncsim.report.summary` used to, so the sums are the same to the last bit: ``bincount``
adds in input order from 0.0; ``add.reduceat`` takes a group's first value and adds the
pairwise sum of the rest (numpy's ``pairwise_sum``: eight accumulators over blocks of 128).
"""
from __future__ import annotations

import numpy as np

from ncsim.jit import njit

_PAIRWISE_BLOCK = 128   # numpy's PW_BLOCKSIZE


@njit(cache=True)
def _pairwise_leaf(a, lo, hi):
    """numpy's ``pairwise_sum`` of at most ``_PAIRWISE_BLOCK`` values ``a[lo:hi]``: in order
    from 0.0 below 8 values, else eight interleaved accumulators and the rest in order."""
    n = hi - lo
    if n < 8:
        res = 0.0
        for i in range(lo, hi):
            res += a[i]
        return res
    r0, r1, r2, r3 = a[lo], a[lo + 1], a[lo + 2], a[lo + 3]
    r4, r5, r6, r7 = a[lo + 4], a[lo + 5], a[lo + 6], a[lo + 7]
    i = lo + 8
    while i < hi - (n % 8):
        r0 += a[i]
        r1 += a[i + 1]
        r2 += a[i + 2]
        r3 += a[i + 3]
        r4 += a[i + 4]
        r5 += a[i + 5]
        r6 += a[i + 6]
        r7 += a[i + 7]
        i += 8
    res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < hi:
        res += a[i]
        i += 1
    return res


@njit(cache=True)
def pairwise_sum(a, lo, hi):
    """numpy's pairwise summation of ``a[lo:hi]`` (``np.add.reduce`` of a contiguous array):
    up to ``_PAIRWISE_BLOCK`` values :func:`_pairwise_leaf` (the common case, a block's few
    stretches of one cause: no stack allocated); above, the sum of the two halves (the first
    a multiple of 8 long), each summed the same way. The halving runs on explicit stacks
    (numba's cache does not load recursive functions safely)."""
    if hi - lo <= _PAIRWISE_BLOCK:
        return _pairwise_leaf(a, lo, hi)
    tasks = np.empty((256, 2))     # (lo, hi), exact as doubles; hi < 0: join the last two
    sums = np.empty(128)           # depth <= 64: two tasks and a join per level
    n_tasks = 1
    n_sums = 0
    tasks[0, 0], tasks[0, 1] = lo, hi
    while n_tasks > 0:
        n_tasks -= 1
        t_lo, t_hi = int(tasks[n_tasks, 0]), int(tasks[n_tasks, 1])
        n = t_hi - t_lo
        if t_hi < 0:
            n_sums -= 1
            sums[n_sums - 1] = sums[n_sums - 1] + sums[n_sums]
        elif n > _PAIRWISE_BLOCK:
            n2 = n // 2
            n2 -= n2 % 8
            tasks[n_tasks, 0], tasks[n_tasks, 1] = 0, -1                      # then join
            tasks[n_tasks + 1, 0], tasks[n_tasks + 1, 1] = t_lo + n2, t_hi    # then the right
            tasks[n_tasks + 2, 0], tasks[n_tasks + 2, 1] = t_lo, t_lo + n2    # the left first
            n_tasks += 3
        else:
            sums[n_sums] = _pairwise_leaf(a, t_lo, t_hi)
            n_sums += 1
    return sums[0]


@njit(cache=True)
def block_losses(piece_t, piece_s, piece_v, piece_a, piece_j, piece_phase, piece_limit, t_end,
                 reference, settle, rapid, exact_stop, phase_stop, tiny,
                 block_lost, block_cause, by_cause, blocks_by, worst, worst_lost):
    """Time lost per block and cause (``ncsim.report.losses``), into the given arrays.

    The piece boundaries and the block ends are merged in time (at equal times a piece
    boundary first); every stretch between two of them lies in one piece and one block (the
    last block takes what follows its end) and, moving, loses ``dt - ds / reference``. When a
    block is done, its stretches are summed per cause, its exact-stop settle added to
    ``exact_stop`` last (a sort by block and cause, then ``add.reduceat``).

    Writes per block the loss (before clipping at 0) and the cause losing it the most among
    those above ``tiny`` (``block_cause`` comes filled with the code for none), and per kind of
    move (feed 0, rapid 1) and cause: the seconds, the blocks, and the block losing the most
    with its loss (``worst`` comes filled with -1)."""
    n = t_end.shape[0]
    m = piece_t.shape[0] - 1
    size = 64
    causes = np.empty(size)      # the block's stretches in time order: cause code, loss
    values = np.empty(size)
    group = np.empty(size)
    count = 0
    ip = 0                       # piece boundaries passed
    ie = 0                       # block ends passed
    t_prev = 0.0
    b = 0                        # the block taking the stretches
    while b < n:
        # the next event; after the last one, the last block is done
        if ip <= m and (ie >= n or piece_t[ip] <= t_end[ie]):
            t, is_piece, last = piece_t[ip], True, False
        elif ie < n:
            t, is_piece, last = t_end[ie], False, False
        else:
            t, is_piece, last = t_prev, False, True
        if (ip > 0 or ie > 0) and t > t_prev and m > 0:
            k = min(max(ip - 1, 0), m - 1)
            if piece_phase[k] != phase_stop:
                tau0, tau1 = t_prev - piece_t[k], t - piece_t[k]
                s0 = piece_s[k] + tau0 * (piece_v[k] + tau0 * (0.5 * piece_a[k]
                                                               + tau0 * piece_j[k] / 6.0))
                s1 = piece_s[k] + tau1 * (piece_v[k] + tau1 * (0.5 * piece_a[k]
                                                               + tau1 * piece_j[k] / 6.0))
                ideal = (s1 - s0) / reference[b] if reference[b] > 0.0 else 0.0
                if count + 1 >= size:            # room for this value and the settle
                    size *= 2
                    grown_c, grown_v = np.empty(size), np.empty(size)
                    for i in range(count):
                        grown_c[i], grown_v[i] = causes[i], values[i]
                    causes, values, group = grown_c, grown_v, np.empty(size)
                causes[count] = piece_limit[k]
                values[count] = (t - t_prev) - ideal
                count += 1
        t_prev = t
        if is_piece:
            ip += 1
            continue
        if not last:
            ie += 1
            if ie == n:          # the stretches after the last end stay with the last block
                continue
        # block b is done: its (cause, loss) pairs in cause order
        if settle[b] > 0.0:
            causes[count] = exact_stop
            values[count] = settle[b]
            count += 1
        kind = 1 if rapid[b] else 0
        total = 0.0
        best = -1.0
        done = -1.0
        while count > 0:
            c = -1.0
            for i in range(count):               # the next cause of the block
                if causes[i] > done and (c < 0.0 or causes[i] < c):
                    c = causes[i]
            if c < 0.0:
                break
            done = c
            g = 0
            for i in range(count):               # its values, in time order
                if causes[i] == c:
                    group[g] = values[i]
                    g += 1
            pair = group[0] + pairwise_sum(group, 1, g) if g > 1 else group[0]
            total += pair
            if pair > tiny:
                ci = int(c)
                by_cause[kind, ci] += pair
                blocks_by[kind, ci] += 1
                if worst[kind, ci] < 0 or pair > worst_lost[kind, ci]:
                    worst[kind, ci] = b
                    worst_lost[kind, ci] = pair
                if pair > best:
                    best = pair
                    block_cause[b] = ci
        block_lost[b] = total
        count = 0
        b += 1


@njit(cache=True)
def piece_tally(piece_t, piece_phase, piece_limit, t_start, rapid, phase_stop, out, stops):
    """Seconds per limit on moving pieces into ``out`` (feed moves [0] and rapids [1]), a
    piece belonging to the block running when it starts (``summary.piece_blocks``); the
    durations of the standstill pieces, in order, into ``stops`` (their pairwise sum is the
    standstill time). Returns the number of standstill pieces."""
    m = piece_t.shape[0] - 1
    n = t_start.shape[0]
    n_stop = 0
    b = 0                        # blocks starting at or before the time looked up
    for k in range(m):
        dur = piece_t[k + 1] - piece_t[k]
        if piece_phase[k] == phase_stop:
            stops[n_stop] = dur
            n_stop += 1
            continue
        when = piece_t[k]
        while b < n and t_start[b] <= when:
            b += 1
        if n > 0:
            out[1 if rapid[min(max(b - 1, 0), n - 1)] else 0, piece_limit[k]] += dur
    return n_stop


@njit(cache=True)
def top_blocks(values, rapid, want_rapid, hv, hi):
    """The ``len(hv)`` blocks of the kind ``want_rapid`` with the largest ``values``, ties to
    the earlier block (a stable sort of ``-values``), unordered, into ``hv`` (their values)
    and ``hi`` (their indices): a heap whose root ranks last of those kept. Returns how many
    (fewer when fewer blocks are of that kind). A block ranks after another when it loses
    less, or as much and comes later."""
    k = hv.shape[0]
    size = 0
    for i in range(values.shape[0]):
        if rapid[i] != want_rapid:
            continue
        v = values[i]
        if size < k:                 # add, sift up
            j = size
            size += 1
            while j > 0:
                parent = (j - 1) // 2
                if not (v < hv[parent] or (v == hv[parent] and i > hi[parent])):
                    break
                hv[j], hi[j] = hv[parent], hi[parent]
                j = parent
            hv[j], hi[j] = v, i
        elif v > hv[0]:              # ranks before the root (a later block never ties ahead)
            j = 0
            while True:              # sift down from the root
                c = 2 * j + 1
                if c >= size:
                    break
                if c + 1 < size and (hv[c + 1] < hv[c] or (hv[c + 1] == hv[c] and hi[c + 1] > hi[c])):
                    c += 1
                if not (hv[c] < v or (hv[c] == v and hi[c] > i)):
                    break
                hv[j], hi[j] = hv[c], hi[c]
                j = c
            hv[j], hi[j] = v, i
    return size


def top_order(values: np.ndarray, rapid: np.ndarray, want_rapid: bool, k: int) -> np.ndarray:
    """Indices of the ``k`` blocks of one kind losing the most, largest first, ties to the
    earlier block: ``argsort(-values, kind="stable")`` of that kind, cut at ``k``."""
    k = min(int(k), len(values))
    if k <= 0:
        return np.zeros(0, dtype=np.int64)
    hv, hi = np.empty(k), np.empty(k, dtype=np.int64)
    size = top_blocks(values, rapid, bool(want_rapid), hv, hi)
    hv, hi = hv[:size], hi[:size]
    return hi[np.lexsort((hi, -hv))]
