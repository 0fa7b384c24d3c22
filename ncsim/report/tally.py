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
def _block_sum(a, lo, hi):
    """numpy's pairwise sum of at most ``_PAIRWISE_BLOCK`` values: in order below 8, else
    eight interleaved accumulators and the rest in order."""
    n = hi - lo
    if n < 8:
        res = 0.0
        for i in range(lo, hi):
            res += a[i]
        return res
    r0, r1, r2, r3 = a[lo], a[lo + 1], a[lo + 2], a[lo + 3]
    r4, r5, r6, r7 = a[lo + 4], a[lo + 5], a[lo + 6], a[lo + 7]
    i = 8
    while i < n - (n % 8):
        r0 += a[lo + i]
        r1 += a[lo + i + 1]
        r2 += a[lo + i + 2]
        r3 += a[lo + i + 3]
        r4 += a[lo + i + 4]
        r5 += a[lo + i + 5]
        r6 += a[lo + i + 6]
        r7 += a[lo + i + 7]
        i += 8
    res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < n:
        res += a[lo + i]
        i += 1
    return res


@njit(cache=True)
def pairwise_sum(a, lo, hi):
    """numpy's pairwise summation of ``a[lo:hi]`` (``np.add.reduce`` of a contiguous array):
    above ``_PAIRWISE_BLOCK`` values, the sum of the two halves (the first a multiple of 8
    long), each summed the same way. The recursion runs on explicit stacks (numba's cache
    does not load recursive functions safely)."""
    if hi - lo <= _PAIRWISE_BLOCK:
        return _block_sum(a, lo, hi)
    task_lo = np.empty(256, dtype=np.int64)    # depth <= 64: two tasks and a join per level
    task_hi = np.empty(256, dtype=np.int64)    # task_hi < 0: join the two last sums
    sums = np.empty(128)
    n_tasks = 1
    n_sums = 0
    task_lo[0], task_hi[0] = lo, hi
    while n_tasks > 0:
        n_tasks -= 1
        t_lo, t_hi = task_lo[n_tasks], task_hi[n_tasks]
        if t_hi < 0:
            n_sums -= 1
            sums[n_sums - 1] = sums[n_sums - 1] + sums[n_sums]
        elif t_hi - t_lo <= _PAIRWISE_BLOCK:
            sums[n_sums] = _block_sum(a, t_lo, t_hi)
            n_sums += 1
        else:
            n2 = (t_hi - t_lo) // 2
            n2 -= n2 % 8
            task_lo[n_tasks], task_hi[n_tasks] = 0, -1                      # then join
            task_lo[n_tasks + 1], task_hi[n_tasks + 1] = t_lo + n2, t_hi    # then the right
            task_lo[n_tasks + 2], task_hi[n_tasks + 2] = t_lo, t_lo + n2    # the left first
            n_tasks += 3
    return sums[0]


@njit(cache=True)
def _s_at(piece_t, piece_s, piece_v, piece_a, piece_j, k, t):
    """Path length at time ``t`` on piece ``k`` (the piece's cubic)."""
    tau = t - piece_t[k]
    return piece_s[k] + tau * (piece_v[k] + tau * (0.5 * piece_a[k] + tau * piece_j[k] / 6.0))


@njit(cache=True)
def _close_block(b, causes, values, count, settle, exact_stop, tiny, rapid, group,
                 block_lost, block_cause, by_cause, blocks_by, worst, worst_lost):
    """Sum block ``b``'s stretches by cause (``causes[:count]``, ``values[:count]`` in time
    order, the exact-stop settle last) and add the sums to the tallies."""
    if settle[b] > 0.0:
        causes[count] = exact_stop
        values[count] = settle[b]
        count += 1
    if count == 0:
        return
    kind = 1 if rapid[b] else 0
    total = 0.0
    best = -1.0
    done = -1                    # causes are taken in increasing order
    while True:
        c = -1
        for i in range(count):   # the next cause of the block
            if causes[i] > done and (c < 0 or causes[i] < c):
                c = causes[i]
        if c < 0:
            break
        done = c
        m = 0
        for i in range(count):   # its values, in time order
            if causes[i] == c:
                group[m] = values[i]
                m += 1
        pair = group[0] + pairwise_sum(group, 1, m) if m > 1 else group[0]
        total += pair
        if pair > tiny:
            by_cause[kind, c] += pair
            blocks_by[kind, c] += 1
            if worst[kind, c] < 0 or pair > worst_lost[kind, c]:
                worst[kind, c] = b
                worst_lost[kind, c] = pair
            if pair > best:
                best = pair
                block_cause[b] = c
    block_lost[b] = total


@njit(cache=True)
def block_losses(piece_t, piece_s, piece_v, piece_a, piece_j, piece_phase, piece_limit, t_end,
                 reference, settle, rapid, n_causes, exact_stop, phase_stop, none_code, tiny):
    """Time lost per block and cause (``ncsim.report.losses``).

    The piece boundaries and the block ends are merged in time (at equal times a piece
    boundary first); every stretch between two of them lies in one piece and one block (the
    last block takes what follows its end) and, moving, loses ``dt - ds / reference``. A
    block's stretches are summed per cause, its exact-stop settle added to ``exact_stop``.

    Returns per block the loss (before clipping at 0) and the cause losing it the most among
    those above ``tiny`` (``none_code``: none), and per kind of move (feed 0, rapid 1) and
    cause: the seconds, the blocks and the block losing the most with its loss."""
    n = t_end.shape[0]
    m = piece_t.shape[0] - 1
    block_lost = np.zeros(n)
    block_cause = np.full(n, none_code, dtype=np.int8)
    by_cause = np.zeros((2, n_causes))
    blocks_by = np.zeros((2, n_causes), dtype=np.int64)
    worst = np.full((2, n_causes), -1, dtype=np.int64)
    worst_lost = np.zeros((2, n_causes))
    size = 64
    causes = np.empty(size, dtype=np.int64)
    values = np.empty(size)
    group = np.empty(size)
    count = 0
    ip = 0                       # piece boundaries passed
    ie = 0                       # block ends passed
    t_prev = 0.0
    first = True
    while ip <= m or ie < n:
        if ip <= m and (ie >= n or piece_t[ip] <= t_end[ie]):
            t = piece_t[ip]
            is_piece = True
        else:
            t = t_end[ie]
            is_piece = False
        if not first and t > t_prev and m > 0:
            k = min(max(ip - 1, 0), m - 1)
            if piece_phase[k] != phase_stop:
                b = min(ie, n - 1)
                ds = (_s_at(piece_t, piece_s, piece_v, piece_a, piece_j, k, t)
                      - _s_at(piece_t, piece_s, piece_v, piece_a, piece_j, k, t_prev))
                ideal = ds / reference[b] if reference[b] > 0.0 else 0.0
                if count + 1 >= size:            # room for this value and the settle
                    size *= 2
                    grown_c = np.empty(size, dtype=np.int64)
                    grown_v = np.empty(size)
                    grown_c[:count] = causes[:count]
                    grown_v[:count] = values[:count]
                    causes, values, group = grown_c, grown_v, np.empty(size)
                causes[count] = piece_limit[k]
                values[count] = (t - t_prev) - ideal
                count += 1
        first = False
        t_prev = t
        if is_piece:
            ip += 1
        else:
            if ie < n - 1:       # the stretches after the last end stay with the last block
                _close_block(ie, causes, values, count, settle, exact_stop, tiny, rapid, group,
                             block_lost, block_cause, by_cause, blocks_by, worst, worst_lost)
                count = 0
            ie += 1
    if n > 0:
        _close_block(n - 1, causes, values, count, settle, exact_stop, tiny, rapid, group,
                     block_lost, block_cause, by_cause, blocks_by, worst, worst_lost)
    return block_lost, block_cause, by_cause, blocks_by, worst, worst_lost


@njit(cache=True)
def piece_tally(piece_t, piece_phase, piece_limit, t_start, rapid, n_limits, phase_stop):
    """Seconds per limit on moving pieces, feed moves [0] and rapids [1] apart, a piece
    belonging to the block running when it starts (a standstill: when it ends, the block it
    waits for; ``summary.piece_blocks``); and the durations of the standstill pieces, in
    order (their pairwise sum is the standstill time)."""
    m = piece_t.shape[0] - 1
    n = t_start.shape[0]
    out = np.zeros((2, n_limits))
    n_stop = 0
    for k in range(m):
        if piece_phase[k] == phase_stop:
            n_stop += 1
    stops = np.empty(n_stop)
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
        blk = min(max(b - 1, 0), n - 1)
        if n > 0:
            out[1 if rapid[blk] else 0, piece_limit[k]] += dur
    return out, stops


@njit(cache=True)
def _after(v1, i1, v2, i2):
    """Whether block i1 losing v1 ranks after block i2 losing v2: less lost, or as much and
    later."""
    return v1 < v2 or (v1 == v2 and i1 > i2)


@njit(cache=True)
def top_blocks(values, rapid, want_rapid, k):
    """The ``k`` blocks of the kind ``want_rapid`` with the largest ``values``, ties to the
    earlier block (a stable sort of ``-values``), unordered: a heap whose root is the last
    of the k best seen so far."""
    hv = np.empty(k)
    hi = np.empty(k, dtype=np.int64)
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
                if not _after(v, i, hv[parent], hi[parent]):
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
                if c + 1 < size and _after(hv[c + 1], hi[c + 1], hv[c], hi[c]):
                    c += 1
                if not _after(hv[c], hi[c], v, i):
                    break
                hv[j], hi[j] = hv[c], hi[c]
                j = c
            hv[j], hi[j] = v, i
    return hv[:size], hi[:size]


def top_order(values: np.ndarray, rapid: np.ndarray, want_rapid: bool, k: int) -> np.ndarray:
    """Indices of the ``k`` blocks of one kind losing the most, largest first, ties to the
    earlier block: ``argsort(-values, kind="stable")`` of that kind, cut at ``k``."""
    if k <= 0 or len(values) == 0:
        return np.zeros(0, dtype=np.int64)
    hv, hi = top_blocks(values, rapid, bool(want_rapid), int(k))
    return hi[np.lexsort((hi, -hv))]
