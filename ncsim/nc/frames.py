"""840D coordinate frames: programmed (WCS) coordinates -> machine coordinates (MCS).

A frame is an affine map ``q = M p + t``. The chain ncsim implements::

    MCS = settable zero offset (G54..G57, G505.., G500 = none)  +  programmable frame (WCS)

The programmable frame is built by frame instructions, each defining a new coordinate
system *in the current one*: ``TRANS v`` (p + v), ``ROT`` (rotation), ``SCALE`` (per-axis
factors), ``MIRROR`` (axis sign flip). The absolute forms replace the whole programmable frame
(so ``TRANS`` alone clears it); the additive forms ``ATRANS AROT ASCALE AMIRROR`` chain onto it
(``F := F o G``), so an ATRANS after an AROT moves along the rotated axes, as on the 840D.
Rotations with several angles follow the 840D default RPY convention (MD10600 = 0): about Z,
then the new Y, then the new X, i.e. ``R = Rz(c) Ry(b) Rx(a)``; ``RPL=`` rotates in the active
plane. Angles that are multiples of 90 degrees give exact 0 / +-1 entries.

``apply`` is written component by component so that one point (Python floats) and a column of
points (numpy arrays) give bit-identical results: the fast and the Lark path rely on it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ncsim.geometry import PLANE_AXES

_AXES = "XYZ"


@dataclass(frozen=True, slots=True)
class Frame:
    """``q = m p + t``; ``m`` 3x3 as nested tuples, ``t`` a 3-tuple (mm)."""

    m: tuple = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
    t: tuple = (0.0, 0.0, 0.0)

    @property
    def linear_identity(self) -> bool:
        return self.m == IDENTITY.m

    @property
    def matrix(self) -> np.ndarray:
        return np.array(self.m, dtype=np.float64)

    def apply(self, x, y, z):
        """The image of (x, y, z): floats or equal-shaped arrays, bit-identical either way."""
        t0, t1, t2 = self.t
        if self.linear_identity:
            return x + t0, y + t1, z + t2
        (a, b, c), (d, e, f), (g, h, i) = self.m
        return (a * x + b * y + c * z + t0,
                d * x + e * y + f * z + t1,
                g * x + h * y + i * z + t2)

    def apply_rows(self, p: np.ndarray) -> np.ndarray:
        """``apply`` on an (n, 3) array."""
        x, y, z = self.apply(p[:, 0], p[:, 1], p[:, 2])
        return np.stack([x, y, z], axis=1)

    def inverse_apply(self, x: float, y: float, z: float) -> tuple[float, float, float]:
        """The point p with apply(p) == (x, y, z) (up to rounding)."""
        t0, t1, t2 = self.t
        if self.linear_identity:
            return x - t0, y - t1, z - t2
        inv = np.linalg.inv(self.matrix)
        p = inv @ np.array([x - t0, y - t1, z - t2])
        return float(p[0]), float(p[1]), float(p[2])

    def then(self, other: "Frame") -> "Frame":
        """``self o other``: first ``other`` (in the new system), then ``self``."""
        m = self.matrix @ other.matrix
        t = self.matrix @ np.array(other.t) + np.array(self.t)
        return Frame(_tuple33(m), tuple(float(v) for v in t))

    def offset_by(self, offset_mm) -> "Frame":
        """This frame followed by a pure translation (the settable zero offset)."""
        return Frame(self.m, tuple(float(a + b) for a, b in zip(self.t, offset_mm)))


IDENTITY = Frame()


def _tuple33(m: np.ndarray) -> tuple:
    return tuple(tuple(float(v) for v in row) for row in m)


def cos_sin_deg(angle_deg: float) -> tuple[float, float]:
    """cos and sin of an angle in degrees, exact for multiples of 90 degrees."""
    quarter = angle_deg / 90.0
    if quarter == int(quarter):
        return ((1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0))[int(quarter) % 4]
    rad = math.radians(angle_deg)
    return math.cos(rad), math.sin(rad)


def axis_rotation(axis: int, angle_deg: float) -> np.ndarray:
    """Rotation matrix about X (0), Y (1) or Z (2), counter-clockwise looking from +axis."""
    c, s = cos_sin_deg(angle_deg)
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    r = np.eye(3)
    r[i, i], r[i, j], r[j, i], r[j, j] = c, -s, s, c
    return r


def translation(v_mm) -> Frame:
    return Frame(IDENTITY.m, tuple(float(x) for x in v_mm))


def rotation_rpy(angles_deg: dict[str, float]) -> Frame:
    """ROT X.. Y.. Z..: R = Rz Ry Rx (840D RPY), angles in degrees."""
    r = (axis_rotation(2, angles_deg.get("Z", 0.0)) @ axis_rotation(1, angles_deg.get("Y", 0.0))
         @ axis_rotation(0, angles_deg.get("X", 0.0)))
    return Frame(_tuple33(r))


def rotation_in_plane(plane: int, angle_deg: float) -> Frame:
    """ROT RPL=..: rotation about the axis perpendicular to the active plane."""
    return Frame(_tuple33(axis_rotation(PLANE_AXES[plane][2], angle_deg)))


def scaling(factors: dict[str, float]) -> Frame:
    return Frame(_tuple33(np.diag([factors.get(a, 1.0) for a in _AXES])))


def mirroring(axes: set[str]) -> Frame:
    return Frame(_tuple33(np.diag([-1.0 if a in axes else 1.0 for a in _AXES])))


def arc_normal(frame: Frame, plane: int) -> np.ndarray | None:
    """Unit normal in MCS about which a G3 of ``plane`` turns counter-clockwise after ``frame``.

    A mirror (det < 0 within the plane) flips it, so a mirrored G3 becomes a clockwise arc.
    Returns None if the frame does not map the plane's circles to circles (non-uniform scale
    or shear within the plane).
    """
    m = frame.matrix
    e1, e2 = np.zeros(3), np.zeros(3)
    e1[PLANE_AXES[plane][0]] = 1.0
    e2[PLANE_AXES[plane][1]] = 1.0
    a, b = m @ e1, m @ e2
    la, lb = np.linalg.norm(a), np.linalg.norm(b)
    if abs(la - lb) > 1e-12 * max(la, lb) or abs(np.dot(a, b)) > 1e-12 * la * lb:
        return None
    n = np.cross(a, b)
    return n / np.linalg.norm(n)
