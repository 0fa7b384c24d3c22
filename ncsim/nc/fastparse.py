"""Fast path of the parser: plain blocks read as columns, without Lark.

A line is *plain* when it is exactly (spaces or tabs allowed between and around words)::

    [N<digits>] [G0|G1|G2|G3|G00|G01|G02|G03] [X<num>] [Y<num>] [Z<num>] [I<num>] [J<num>] [K<num>] [F<num>] [;comment]

in this order, upper case, each word at most once, ``<num>`` = ``[+-](digits[.digits]|.digits)``
with at most 15 significant digits and 22 decimals. Such lines are what CAM programs are made
of. Anything else (including an empty ``G`` or a 16-digit number) is not plain and goes to
the Lark grammar, which remains the definition of the language: every plain line means
exactly what Lark makes of it (``tests/test_fastpath.py`` proves it by property tests).

The scanner is one pass over the UTF-8 bytes, compiled with numba (``ncsim.jit``: programs
under about 10,000 lines are scanned as plain Python, over ``bytes``). A number is read as an
integer mantissa ``m < 10**15`` and ``d <= 22`` decimals and converted as ``m / 10**d``: both
are exact doubles, so the one correctly rounded division gives exactly ``float(text)``.
"""
from __future__ import annotations

from typing import Callable

import numpy as np
from ncsim.jit import njit

from ncsim.nc import program as P

_POW10 = np.array([10.0 ** k for k in range(23)])  # exact doubles 1 .. 1e22
_MAX_SIG_DIGITS = 15
_MAX_DECIMALS = 22
_MAX_N_DIGITS = 18
_AXIS_LETTERS = np.frombuffer(b"XYZIJKF", dtype=np.uint8).copy()

_NL, _SP, _TAB, _SEMI, _DOT, _PLUS, _MINUS = 10, 32, 9, 59, 46, 43, 45
_N, _G = 78, 71


@njit(cache=True, nogil=True)
def _is_digit(c):
    return 48 <= c <= 57


@njit(cache=True, nogil=True)
def _skip_ws(buf, pos, end):
    while pos < end and (buf[pos] == _SP or buf[pos] == _TAB):
        pos += 1
    return pos


@njit(cache=True, nogil=True)
def _read_digits(buf, pos, end, mantissa, sig):
    """Append the digits at pos to ``mantissa`` (``sig`` significant digits so far; leading
    zeros are not significant). Returns (new_pos, mantissa, sig, digits read)."""
    digits = 0
    while pos < end and _is_digit(buf[pos]):
        d = buf[pos] - 48
        if sig > 0 or d != 0:
            sig += 1
            mantissa = mantissa * 10 + d
        digits += 1
        pos += 1
    return pos, mantissa, sig, digits


@njit(cache=True, nogil=True)
def _read_number(buf, pos, end, pow10):
    """Read ``[+-](digits[.digits]|.digits)`` at pos. Returns (ok, value, new_pos)."""
    neg = False
    if pos < end and (buf[pos] == _PLUS or buf[pos] == _MINUS):
        neg = buf[pos] == _MINUS
        pos += 1
    pos, mantissa, sig, digits = _read_digits(buf, pos, end, 0, 0)
    decimals = 0
    if pos < end and buf[pos] == _DOT:
        pos, mantissa, sig, decimals = _read_digits(buf, pos + 1, end, mantissa, sig)
        digits += decimals
    if digits == 0 or sig > _MAX_SIG_DIGITS or decimals > _MAX_DECIMALS:
        return False, 0.0, pos
    if pos < end and buf[pos] == _DOT:  # "1.2.3": Lark would fail on the second dot
        return False, 0.0, pos
    value = float(mantissa) / pow10[decimals]
    if neg:
        value = -value
    return True, value, pos


@njit(cache=True, nogil=True)
def _scan_line(buf, a, b, letters, pow10, numbers, g, values, cols, row):
    """Scan buf[a:b] as a plain line into row ``row`` of the columns; False if not plain."""
    pos = _skip_ws(buf, a, b)
    if pos < b and buf[pos] == _N:
        cols[row, 0] = pos - a + 1
        pos += 1
        n = 0
        nd = 0
        while pos < b and _is_digit(buf[pos]):
            n = n * 10 + (buf[pos] - 48)
            nd += 1
            pos += 1
        if nd == 0 or nd > _MAX_N_DIGITS:
            return False
        numbers[row] = n
        pos = _skip_ws(buf, pos, b)
    if pos < b and buf[pos] == _G:
        d = pos + 1
        if d + 1 < b and buf[d] == 48 and _is_digit(buf[d + 1]):   # G00..G03 (ISO CAM output)
            d += 1
        if d >= b or not (48 <= buf[d] <= 51):
            return False
        if d + 1 < b and (_is_digit(buf[d + 1]) or buf[d + 1] == _DOT):
            return False
        cols[row, 1] = pos - a + 1
        g[row] = buf[d] - 48
        pos = _skip_ws(buf, d + 1, b)
    for k in range(letters.shape[0]):
        if pos < b and buf[pos] == letters[k]:
            ok, value, end = _read_number(buf, pos + 1, b, pow10)
            if not ok:
                return False
            cols[row, 2 + k] = pos - a + 1
            values[row, k] = value
            pos = _skip_ws(buf, end, b)
    if pos < b and buf[pos] == _SEMI:
        pos = b
    return pos == b


@njit(cache=True, nogil=True)
def _clear_row(numbers, g, values, cols, row):
    numbers[row] = -1
    g[row] = -1
    for k in range(values.shape[1]):
        values[row, k] = np.nan
    for k in range(cols.shape[1]):
        cols[row, k] = 0


@njit(cache=True, nogil=True, python_below=250_000)  # bytes: about 10,000 CAM lines
def _scan(buf, letters, pow10):
    size = len(buf)
    n_lines = 0
    for c in buf:
        if c == _NL:
            n_lines += 1
    if size > 0 and buf[size - 1] != _NL:
        n_lines += 1
    # np.empty and a fill per row (numba compiles np.full and np.zeros once per dtype and
    # shape: seconds in all); values a line does not set stay NaN, -1 or 0
    n_letters = letters.shape[0]
    plain = np.empty(n_lines, dtype=np.bool_)
    starts = np.empty(n_lines, dtype=np.int64)
    ends = np.empty(n_lines, dtype=np.int64)
    numbers = np.empty(n_lines, dtype=np.int64)
    g = np.empty(n_lines, dtype=np.int8)
    values = np.empty((n_lines, n_letters))
    cols = np.empty((n_lines, n_letters + 2), dtype=np.int32)
    a = 0
    for row in range(n_lines):
        b = a
        while b < size and buf[b] != _NL:
            b += 1
        starts[row] = a
        ends[row] = b
        _clear_row(numbers, g, values, cols, row)
        plain[row] = _scan_line(buf, a, b, letters, pow10, numbers, g, values, cols, row)
        if not plain[row]:  # leave no half-read values behind
            _clear_row(numbers, g, values, cols, row)
        a = b + 1
    return plain, starts, ends, numbers, g, values, cols


def scan_plain(text: str):
    """Scan every line. Returns (plain mask, byte starts, byte ends, numbers, g, values, cols)
    with one row per line; the value columns are meaningful where ``plain`` is True."""
    data = text.encode("utf-8", "surrogatepass")
    if _scan.runs_compiled(len(data)):
        return (data,) + _scan(np.frombuffer(data, dtype=np.uint8), _AXIS_LETTERS, _POW10)
    return (data,) + _scan.py(data, _AXIS_LETTERS, _POW10)  # bytes: items are Python ints


def _run_bounds(plain: np.ndarray):
    """(start, stop) row ranges of the consecutive True stretches of ``plain``."""
    edges = np.diff(np.concatenate(([0], plain.view(np.int8), [0])))
    return zip(np.flatnonzero(edges == 1).tolist(), np.flatnonzero(edges == -1).tolist())


def scan_program(text: str, file: str, parse_block: Callable[[str, int, str], P.Block]) -> P.Program:
    """A Program whose plain lines are PlainRuns and whose other lines went to ``parse_block``."""
    data, plain, starts, ends, numbers, g, values, cols = scan_plain(text)
    items: list = []
    row = 0
    for a, b in _run_bounds(plain):
        items.extend(_lark_lines(data, starts, ends, row, a, file, parse_block))
        items.append(P.PlainRun(a + 1, numbers[a:b], g[a:b], values[a:b], cols[a:b]))
        row = b
    items.extend(_lark_lines(data, starts, ends, row, len(plain), file, parse_block))
    return P.Program(file, tuple(items), len(plain))


def _lark_lines(data: bytes, starts, ends, a: int, b: int, file: str, parse_block):
    for row in range(a, b):
        text = data[starts[row]:ends[row]].decode("utf-8", "surrogatepass")
        yield parse_block(text, row + 1, file)
