"""The KIT DMC 60H Notch program's first pass, mapped by hand from its text (no ncsim geometry):
the truth side of the tests and benchmarks that measure time lost at its junctions on the real
recording (``../shared/data/real/kit-dmc60h-notch-sinumerik``, its ``SOURCE.md``).
"""
from __future__ import annotations

import math

import numpy as np

#: the recording's work offset, SOURCE.md "Coordinates"
ORIGIN_MM = np.array([-38.648045, 249.499981, 404.94])
# pass 1 in program coordinates: G0 Z10 -> Z-6 at (-10, 60), G1 X30, G2 to (60, 30) about
# (30, 30), G1 Y10, G1 X40, G1 X-10 Y60
PASS1_LENGTHS_MM = np.array([16.0, 40.0, 15.0 * math.pi, 20.0, 20.0, 50.0 * math.sqrt(2.0)])
PASS1_S_MM = np.concatenate([[0.0], np.cumsum(PASS1_LENGTHS_MM)])


def pass1_length_mm(q: np.ndarray) -> np.ndarray:
    """Path length along pass 1 of program points ``q`` (n, 3): the nearest of its six pieces
    (five lines and the arc), by hand from the program text."""
    lines = [((-10.0, 60.0, 10.0), (-10.0, 60.0, -6.0), 0), ((-10.0, 60.0, -6.0), (30.0, 60.0, -6.0), 1),
             ((60.0, 30.0, -6.0), (60.0, 10.0, -6.0), 3), ((60.0, 10.0, -6.0), (40.0, 10.0, -6.0), 4),
             ((40.0, 10.0, -6.0), (-10.0, 60.0, -6.0), 5)]
    dist = np.full((len(q), 6), np.inf)
    along = np.zeros((len(q), 6))
    for a, b, k in lines:
        a, b = np.array(a), np.array(b)
        u = (b - a) / np.linalg.norm(b - a)
        w = np.clip((q - a) @ u, 0.0, np.linalg.norm(b - a))
        dist[:, k] = np.linalg.norm(q - (a + w[:, None] * u), axis=1)
        along[:, k] = w
    # the G2 arc about (30, 30), R 30, from (30, 60) clockwise to (60, 30)
    ang = np.arctan2(q[:, 0] - 30.0, q[:, 1] - 30.0)              # 0 at (30, 60), pi/2 at (60, 30)
    inside = (ang >= 0.0) & (ang <= 0.5 * math.pi)
    dist[:, 2] = np.where(inside, np.hypot(np.hypot(q[:, 0] - 30.0, q[:, 1] - 30.0) - 30.0,
                                           q[:, 2] + 6.0), np.inf)
    along[:, 2] = 30.0 * ang
    k = np.argmin(dist, axis=1)
    return PASS1_S_MM[k] + along[np.arange(len(q)), k]
