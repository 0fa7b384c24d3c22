"""`ncsim parse` text: one line per path segment, written by a compiled row formatter.

A segment's line (one line; the brackets are present only where they apply)::

    <index, right-aligned in 7> <file>:<line, left-aligned in 6> <line|arc > (x, y, z) -> (x, y, z)
    [ centre=(x, y, z) radius_mm=R sweep_deg=S normal=(x, y, z)[ helix_mm=H]] length_mm=L
    feed_mm_min=<F|rapid> <G0|feed> G<cp_mode> G<stop_window> <SOFT|BRISK|DRIVE>
    [ exact_stop][ adis=A][ FFWON][ stop_before][ dwell_before=Ds]

Positions, the centre, radius, normal, helix rise and length have 4 decimals and the sweep 3;
the feed (mm/min), ADIS (mm) and dwell (s) at most 3, 4 and 6, trailing zeros dropped
(``600``, ``0.5``). A number is written from the integer ``round(|x| 10^d)`` (numpy's ``rint``
of the scaled double) and its sign; one that rounds to zero has no minus sign.

As for the CSV trace (``csvformat``), numpy scales a chunk of rows to integers and a compiled
loop writes the bytes, about 40 times the speed of one f-string per segment
(``benchmarks/bench_profile.py`` measures ``ncsim parse``). A path under ``jit.PYTHON_BELOW``
rows goes through the same loop as plain Python (``ncsim.jit``; about 25,000 rows/s), so a
small ``ncsim parse`` never starts numba. A chunk holding a value too large for 64-bit
integers once scaled (beyond ±9e13 mm) is written by Python's own formatting, row by row.
"""
from __future__ import annotations

import math

import numpy as np

from ncsim.jit import njit
from ncsim.path import ACCEL_MODE_NAMES, Path
from ncsim.units import mm_s_to_mm_min

CHUNK_ROWS = 1 << 14

# columns of the scaled-integer table, with their decimals and whether trailing zeros go
_START, _END, _CENTRE, _RADIUS, _SWEEP, _NORMAL, _HELIX, _LENGTH, _FEED, _ADIS, _DWELL = (
    0, 3, 6, 9, 10, 11, 14, 15, 16, 17, 18)
_N_NUM = 19
_DECIMALS = np.array([4] * 9 + [4, 3] + [4] * 3 + [4, 4, 3, 4, 6], dtype=np.int64)
_TRIM = np.array([0] * 16 + [1, 1, 1], dtype=np.int64)
_POW10 = np.array([10 ** k for k in range(19)], dtype=np.int64)
_LIMIT = 1e18                 # |x| 10^d at or above this does not fit the integer path

# flag columns
_F_KIND, _F_RAPID, _F_CP, _F_WINDOW, _F_ACCEL, _F_EXACT, _F_FFW, _F_STOP, _F_ADIS, _F_HELIX, \
    _F_DWELL = range(11)
_N_FLAGS = 11

_LITERALS = [" ", ":", " (", ", ", " -> (", ")", " centre=(", " radius_mm=", " sweep_deg=",
             " normal=(", " helix_mm=", " length_mm=", " feed_mm_min=", "rapid", " G0", " feed",
             " G", " exact_stop", " adis=", " FFWON", " stop_before", " dwell_before=", "s\n",
             "\n", "line", "arc "] + [ACCEL_MODE_NAMES[k] for k in sorted(ACCEL_MODE_NAMES)]
(_SP, _COLON, _OPEN, _COMMA, _ARROW, _CLOSE, _CENTRE_EQ, _RADIUS_EQ, _SWEEP_EQ, _NORMAL_EQ,
 _HELIX_EQ, _LENGTH_EQ, _FEED_EQ, _RAPID, _G0, _FEED_WORD, _G, _EXACT_WORD, _ADIS_EQ, _FFW_WORD,
 _STOP_WORD, _DWELL_EQ, _S_NL, _NL, _LINE_WORD, _ARC_WORD) = range(26)
_ACCEL_WORD = 26               # + accel mode
_LIT = np.zeros((len(_LITERALS), max(len(s) for s in _LITERALS)), dtype=np.uint8)
for _i, _s in enumerate(_LITERALS):
    _LIT[_i, :len(_s)] = np.frombuffer(_s.encode("ascii"), dtype=np.uint8)
_LIT_LEN = np.array([len(s) for s in _LITERALS], dtype=np.int64)
_ROOM = int(_LIT_LEN.sum()) + _N_NUM * 22 + 4 * 20  # bytes per row besides the file name


@njit(cache=True)
def _put_literal(out, pos, k):
    for i in range(_LIT_LEN[k]):
        out[pos + i] = _LIT[k, i]
    return pos + _LIT_LEN[k]


@njit(cache=True)
def _put_digits(out, pos, v, n):
    """The last ``n`` decimal digits of v >= 0, zero-padded."""
    for i in range(n - 1, -1, -1):
        out[pos + i] = 48 + v % 10
        v //= 10
    return pos + n


@njit(cache=True)
def _n_digits(v):
    n = 1
    while v >= 10:
        v //= 10
        n += 1
    return n


@njit(cache=True)
def _put_fixed(out, pos, q, neg, d, trim):
    """round(|x| 10^d) = q written with d decimals (trailing zeros dropped when ``trim``)."""
    if neg and q > 0:
        out[pos] = 45  # '-'
        pos += 1
    whole = q // _POW10[d]
    frac = q - whole * _POW10[d]
    pos = _put_digits(out, pos, whole, _n_digits(whole))
    if trim:
        while d > 0 and frac % 10 == 0:
            frac //= 10
            d -= 1
    if d > 0:
        out[pos] = 46  # '.'
        pos = _put_digits(out, pos + 1, frac, d)
    return pos


@njit(cache=True)
def _put_triple(out, pos, q, neg, r, c):
    pos = _put_fixed(out, pos, q[r, c], neg[r, c], _DECIMALS[c], False)
    for k in range(1, 3):
        pos = _put_literal(out, pos, _COMMA)
        pos = _put_fixed(out, pos, q[r, c + k], neg[r, c + k], _DECIMALS[c + k], False)
    return _put_literal(out, pos, _CLOSE)


@njit(cache=True)
def format_segment_rows(first, file_index, names, name_len, line, q, neg, flags, out):
    """Write the rows' lines into ``out`` (uint8) and return the byte count: row r is segment
    ``first + r``; ``q``/``neg`` the scaled integers and signs of the numeric columns,
    ``flags`` the kind, modal columns and which optional fields apply."""
    pos = 0
    for r in range(q.shape[0]):
        index = first + r
        nd = _n_digits(index)
        for _ in range(nd, 7):
            out[pos] = 32
            pos += 1
        pos = _put_digits(out, pos, index, nd)
        pos = _put_literal(out, pos, _SP)
        f = file_index[r]
        for i in range(name_len[f]):
            out[pos + i] = names[f, i]
        pos = _put_literal(out, pos + name_len[f], _COLON)
        nd = _n_digits(line[r])
        pos = _put_digits(out, pos, line[r], nd)
        for _ in range(nd, 6):
            out[pos] = 32
            pos += 1
        pos = _put_literal(out, pos, _SP)
        arc = flags[r, _F_KIND] == 1
        pos = _put_literal(out, pos, _ARC_WORD if arc else _LINE_WORD)
        pos = _put_literal(out, pos, _OPEN)
        pos = _put_triple(out, pos, q, neg, r, _START)
        pos = _put_literal(out, pos, _ARROW)
        pos = _put_triple(out, pos, q, neg, r, _END)
        if arc:
            pos = _put_literal(out, pos, _CENTRE_EQ)
            pos = _put_triple(out, pos, q, neg, r, _CENTRE)
            pos = _put_literal(out, pos, _RADIUS_EQ)
            pos = _put_fixed(out, pos, q[r, _RADIUS], neg[r, _RADIUS], 4, False)
            pos = _put_literal(out, pos, _SWEEP_EQ)
            pos = _put_fixed(out, pos, q[r, _SWEEP], neg[r, _SWEEP], 3, False)
            pos = _put_literal(out, pos, _NORMAL_EQ)
            pos = _put_triple(out, pos, q, neg, r, _NORMAL)
            if flags[r, _F_HELIX]:
                pos = _put_literal(out, pos, _HELIX_EQ)
                pos = _put_fixed(out, pos, q[r, _HELIX], neg[r, _HELIX], 4, False)
        pos = _put_literal(out, pos, _LENGTH_EQ)
        pos = _put_fixed(out, pos, q[r, _LENGTH], neg[r, _LENGTH], 4, False)
        pos = _put_literal(out, pos, _FEED_EQ)
        if flags[r, _F_RAPID]:
            pos = _put_literal(out, pos, _RAPID)
            pos = _put_literal(out, pos, _G0)
        else:
            pos = _put_fixed(out, pos, q[r, _FEED], neg[r, _FEED], _DECIMALS[_FEED], True)
            pos = _put_literal(out, pos, _FEED_WORD)
        pos = _put_literal(out, pos, _G)
        pos = _put_digits(out, pos, flags[r, _F_CP], _n_digits(flags[r, _F_CP]))
        pos = _put_literal(out, pos, _G)
        pos = _put_digits(out, pos, flags[r, _F_WINDOW], _n_digits(flags[r, _F_WINDOW]))
        pos = _put_literal(out, pos, _SP)
        pos = _put_literal(out, pos, _ACCEL_WORD + flags[r, _F_ACCEL])
        if flags[r, _F_EXACT]:
            pos = _put_literal(out, pos, _EXACT_WORD)
        if flags[r, _F_ADIS]:
            pos = _put_literal(out, pos, _ADIS_EQ)
            pos = _put_fixed(out, pos, q[r, _ADIS], neg[r, _ADIS], _DECIMALS[_ADIS], True)
        if flags[r, _F_FFW]:
            pos = _put_literal(out, pos, _FFW_WORD)
        if flags[r, _F_STOP]:
            pos = _put_literal(out, pos, _STOP_WORD)
        if flags[r, _F_DWELL]:
            pos = _put_literal(out, pos, _DWELL_EQ)
            pos = _put_fixed(out, pos, q[r, _DWELL], neg[r, _DWELL], _DECIMALS[_DWELL], True)
            pos = _put_literal(out, pos, _S_NL)
        else:
            pos = _put_literal(out, pos, _NL)
    return pos


def _columns(path: Path, sl: slice):
    """The numeric columns of rows ``sl`` (file units: mm, degrees, mm/min, s) and the flags."""
    n = len(range(*sl.indices(path.n)))
    values = np.zeros((n, _N_NUM))
    values[:, _START:_START + 3] = path.start_mm[sl]
    values[:, _END:_END + 3] = path.end_mm[sl]
    arc = path.kind[sl] == 1
    values[:, _CENTRE:_CENTRE + 3] = np.where(arc[:, None], path.center_mm[sl], 0.0)
    values[:, _RADIUS] = np.where(arc, path.radius_mm[sl], 0.0)
    values[:, _SWEEP] = np.degrees(path.sweep_rad[sl])
    values[:, _NORMAL:_NORMAL + 3] = path.normal[sl]
    values[:, _HELIX] = path.helix_mm[sl]
    values[:, _LENGTH] = path.length_mm[sl]
    rapid = path.rapid[sl]
    values[:, _FEED] = np.where(rapid, 0.0, mm_s_to_mm_min(np.where(rapid, 0.0, path.feed_mm_s[sl])))
    values[:, _ADIS] = path.adis_mm[sl]
    values[:, _DWELL] = path.dwell_before_s[sl]
    flags = np.empty((n, _N_FLAGS), dtype=np.int64)
    cp_mode = path.cp_mode[sl]
    for col, value in ((_F_KIND, path.kind[sl]), (_F_RAPID, rapid), (_F_CP, cp_mode),
                       (_F_WINDOW, path.stop_window[sl]), (_F_ACCEL, path.accel_mode[sl]),
                       (_F_EXACT, path.exact_stop[sl]), (_F_FFW, path.ffw[sl]),
                       (_F_STOP, path.stop_before[sl]),
                       (_F_ADIS, (cp_mode == 641) | (path.adis_mm[sl] != 0)),
                       (_F_HELIX, arc & (path.helix_mm[sl] != 0)),
                       (_F_DWELL, path.dwell_before_s[sl] != 0)):
        flags[:, col] = value
    return values, flags


def format_segments(path: Path, start: int = 0, stop: int | None = None) -> bytes:
    """The lines of segments ``start`` to ``stop`` (see the module docstring)."""
    sl = slice(start, path.n if stop is None else stop)
    values, flags = _columns(path, sl)
    if len(values) == 0:
        return b""
    with np.errstate(over="ignore", invalid="ignore"):
        scaled = np.rint(values * (10.0 ** _DECIMALS.astype(np.float64)))
    if not np.abs(scaled).max() < _LIMIT or np.any(flags[:, _F_CP] < 0) \
            or np.any(flags[:, _F_WINDOW] < 0):
        return "".join(segment_text(path, i) + "\n" for i in range(*sl.indices(path.n))).encode()
    names = [f.encode("utf-8", "surrogateescape") for f in path.files]
    table = np.zeros((len(names), max(1, max(len(b) for b in names))), dtype=np.uint8)
    for i, b in enumerate(names):
        table[i, :len(b)] = np.frombuffer(b, dtype=np.uint8)
    name_len = np.array([len(b) for b in names], dtype=np.int64)
    out = np.empty(len(values) * (_ROOM + int(name_len.max())), dtype=np.uint8)
    used = format_segment_rows(sl.start, path.file_index[sl].astype(np.int64), table, name_len,
                               path.line[sl].astype(np.int64), np.abs(scaled).astype(np.int64),
                               scaled < 0, flags, out)
    return out[:used].tobytes()


def write_segments(path: Path, stream, limit: int | None = None) -> int:
    """Write the first ``limit`` segments (all by default) to the binary ``stream`` in chunks;
    returns how many."""
    shown = path.n if limit is None else min(limit, path.n)
    for lo in range(0, shown, CHUNK_ROWS):
        stream.write(format_segments(path, lo, min(lo + CHUNK_ROWS, shown)))
    return shown


def segment_text(path: Path, i: int) -> str:
    """Segment ``i``'s line by Python's formatting (for values beyond the integer path)."""
    seg = path.segment(i)
    xyz = lambda v: "(" + ", ".join(f"{float(c):.4f}" for c in v) + ")"  # noqa: E731
    text = (f"{seg.index:>7} {seg.file}:{seg.line:<6} {'arc' if seg.is_arc else 'line':<4} "
            f"{xyz(seg.start_mm)} -> {xyz(seg.end_mm)}")
    if seg.is_arc:
        text += (f" centre={xyz(seg.center_mm)} radius_mm={seg.radius_mm:.4f} "
                 f"sweep_deg={math.degrees(seg.sweep_rad):.3f} normal={xyz(seg.normal)}")
        if seg.helix_mm:
            text += f" helix_mm={seg.helix_mm:.4f}"
    feed = "rapid G0" if seg.rapid else f"{float(mm_s_to_mm_min(seg.feed_mm_s)):g} feed"
    text += (f" length_mm={seg.length_mm:.4f} feed_mm_min={feed} G{seg.cp_mode} "
             f"G{seg.stop_window} {ACCEL_MODE_NAMES[seg.accel_mode]}")
    if seg.exact_stop:
        text += " exact_stop"
    if seg.cp_mode == 641 or seg.adis_mm:
        text += f" adis={seg.adis_mm:g}"
    if seg.ffw:
        text += " FFWON"
    if seg.stop_before:
        text += " stop_before"
    if seg.dwell_before_s:
        text += f" dwell_before={seg.dwell_before_s:g}s"
    return text
