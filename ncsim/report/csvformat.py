"""The compiled CSV row writer of ``ncsim.report.csvio``: integers and labels to bytes.

``csvio`` turns each value into the integer ``round(|x| 10^d)`` and its sign with numpy; this
loop writes the rows' bytes (sign, digits two at a time from a 100-entry table, point,
labels, separators); ``benchmarks/bench_trace_io.py`` measures it. ``tests/test_csvio.py``
holds it byte-identical to the pure-numpy formatter ``csvio.format_rows``.
"""
from __future__ import annotations

import numpy as np
from ncsim.jit import njit

_DIGIT_PAIRS = np.frombuffer("".join(f"{i:02d}" for i in range(100)).encode("ascii"),
                             dtype=np.uint8).copy()


@njit(cache=True)
def format_csv_rows(ints, neg, kind, decimals, labels, label_len, out):
    """Write CSV rows into ``out`` (uint8) and return the byte count (see ``csvio``).

    Per column ``c``: ``kind[c]`` 0 = fixed point (``ints`` holds round(|x| 10^d), ``neg`` the
    sign, ``decimals[c]`` digits after the point), 1 = integer (|value| and sign), 2 = label
    (``ints`` holds the code, ``labels[c, code, :label_len[c, code]]`` its bytes). Digits come
    two at a time (one unsigned division by 100 and a 100-entry table).
    """
    m, k = ints.shape
    pos = 0
    digits = np.empty(24, dtype=np.uint8)
    pairs = _DIGIT_PAIRS
    for r in range(m):
        for c in range(k):
            if kind[c] == 2:
                code = ints[r, c]
                n = label_len[c, code]
                for i in range(n):
                    out[pos + i] = labels[c, code, i]
                pos += n
            else:
                if neg[r, c]:
                    out[pos] = 45  # '-'
                    pos += 1
                q = np.uint64(ints[r, c])
                d = decimals[c] if kind[c] == 0 else 0
                nd = 0                        # digits, least significant first
                while q >= 100:
                    rem = q % np.uint64(100)
                    q //= np.uint64(100)
                    digits[nd] = pairs[2 * rem + 1]
                    digits[nd + 1] = pairs[2 * rem]
                    nd += 2
                digits[nd] = pairs[2 * q + 1]
                nd += 1
                if q >= 10:
                    digits[nd] = pairs[2 * q]
                    nd += 1
                while nd <= d:                # zero-pad: all decimals and one integer digit
                    digits[nd] = 48
                    nd += 1
                for i in range(nd - 1, -1, -1):
                    out[pos] = digits[i]
                    pos += 1
                    if d > 0 and i == d:
                        out[pos] = 46  # '.'
                        pos += 1
            out[pos] = 44 if c < k - 1 else 10  # ',' or newline
            pos += 1
    return pos
