"""Time lost at block transitions, measured model-free on s(t).

A machine that slows down at a junction arrives later than one that keeps its feed. With the
path length ``s(t)`` of a trace (a recording mapped onto the program's path, or a model's
set point), the loss at a junction at ``s_c`` is measured as the research on real 840D traces
does: straight lines ``s = v (t - t0)`` are fitted to ``s(t)`` on a window before the junction
(ending ``gap_s`` before the instant it is passed) and on a window after it (starting
``gap_s`` after), each extrapolated to ``s_c``; the loss is the difference of the two
instants::

    loss = t_after(s_c) - t_before(s_c)

A junction crossed at full feed loses 0; a stop of settle time T with ramps of acceleration A
from and to feed v loses ``v / A + T`` (BRISK), whatever happens inside the gap. A recorder's
centred moving average leaves straight stretches straight, so the measure does not depend on
the recorder filter as long as the windows avoid the filter's reach (``gap_s`` > half the
window).
"""
from __future__ import annotations

import numpy as np

from ncsim.errors import UsageError


def time_at_length_s(t_s: np.ndarray, s_mm: np.ndarray, s_query_mm) -> np.ndarray:
    """When a non-decreasing ``s(t)`` reaches ``s_query_mm`` (linear interpolation; standstills
    are one instant, the first one)."""
    t = np.asarray(t_s, dtype=np.float64)
    s = np.asarray(s_mm, dtype=np.float64)
    keep = np.r_[True, np.diff(s) > 0.0]
    return np.interp(s_query_mm, s[keep], t[keep])


def line_fit(t_s: np.ndarray, s_mm: np.ndarray) -> tuple[float, float]:
    """Least-squares ``s = v t + c``: ``(v_mm_s, c_mm)``."""
    if len(t_s) < 2 or np.ptp(t_s) <= 0:
        raise UsageError("a junction window holds fewer than two samples")
    v, c = np.polyfit(np.asarray(t_s, dtype=np.float64), np.asarray(s_mm, dtype=np.float64), 1)
    return float(v), float(c)


def junction_loss_s(t_s, s_mm, s_junction_mm: float, *, before_s=(0.6, 0.12),
                    after_s=(0.12, 0.6)) -> float:
    """Time lost at the junction at ``s_junction_mm`` (module docstring). ``before_s = (a, b)``:
    the window before is ``[t_c - a, t_c - b]``, ``after_s = (a, b)``: ``[t_c + a, t_c + b]``,
    with ``t_c`` the instant ``s`` passes the junction."""
    t = np.asarray(t_s, dtype=np.float64)
    s = np.asarray(s_mm, dtype=np.float64)
    t_c = float(time_at_length_s(t, s, s_junction_mm))
    out = []
    for lo, hi in ((t_c - before_s[0], t_c - before_s[1]), (t_c + after_s[0], t_c + after_s[1])):
        sel = (t >= lo) & (t <= hi)
        v, c = line_fit(t[sel], s[sel])
        if v <= 0:
            raise UsageError(f"no motion in a window next to the junction at s = {s_junction_mm:g} mm")
        out.append((s_junction_mm - c) / v)
    return out[1] - out[0]
