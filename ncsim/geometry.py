"""Pure geometry of lines, arcs and helices: construction and evaluation along arc length.

All functions are vectorised over segments. A point on an arc at angle ``phi`` (0..sweep) is::

    P(phi) = c + r (cos(phi) u + sin(phi) v) + (phi / sweep) h w

with ``w`` the unit normal (travel is counter-clockwise about ``w``), ``u = (start - c)/r``,
``v = w x u`` and ``h`` the helix rise. Arc length ``s = phi * sqrt(r^2 + p^2)`` with
``p = h / sweep``; the curvature radius of the helix is ``(r^2 + p^2) / r`` and its principal
normal is ``-(cos(phi) u + sin(phi) v)``.
"""
from __future__ import annotations

import numpy as np

from ncsim.path import ARC, Path

TWO_PI = 2.0 * np.pi

# Plane selection (G17/G18/G19): (abscissa axis, ordinate axis, perpendicular axis) indices
PLANE_AXES = {17: (0, 1, 2), 18: (2, 0, 1), 19: (1, 2, 0)}


def plane_normal(plane: int) -> np.ndarray:
    """+Z for G17, +Y for G18, +X for G19: G3 turns counter-clockwise about it, G2 clockwise."""
    n = np.zeros(3)
    n[PLANE_AXES[plane][2]] = 1.0
    return n


def arc_basis(center_mm, normal, start_mm):
    """Unit vectors (u, v, w) of arcs: u from centre to start (in plane), w the normal."""
    w = np.asarray(normal, dtype=np.float64)
    d = np.asarray(start_mm, dtype=np.float64) - np.asarray(center_mm, dtype=np.float64)
    d = d - np.sum(d * w, axis=-1, keepdims=True) * w
    r = np.linalg.norm(d, axis=-1, keepdims=True)
    u = np.divide(d, r, out=np.zeros_like(d), where=r > 0)
    v = np.cross(w, u)
    return u, v, w


def sweep_angle_rad(start_mm, end_mm, center_mm, normal, turns=0):
    """Angle travelled counter-clockwise about ``normal`` from start to end, in (0, 2pi],
    plus ``turns`` full turns (840D TURN=). Start == end gives a full circle."""
    u, v, w = arc_basis(center_mm, normal, start_mm)
    e = np.asarray(end_mm, dtype=np.float64) - np.asarray(center_mm, dtype=np.float64)
    ang = np.arctan2(np.sum(e * v, axis=-1), np.sum(e * u, axis=-1))
    ang = np.mod(ang, TWO_PI)
    ang = np.where(ang <= 1e-12, TWO_PI, ang)
    return ang + TWO_PI * np.asarray(turns)


def in_plane_radius_mm(point_mm, center_mm, normal):
    d = np.asarray(point_mm, dtype=np.float64) - np.asarray(center_mm, dtype=np.float64)
    w = np.asarray(normal, dtype=np.float64)
    d = d - np.sum(d * w, axis=-1, keepdims=True) * w
    return np.linalg.norm(d, axis=-1)


def center_from_radius(start_mm, end_mm, normal, radius_mm: float):
    """Centre of the arc of radius |CR| from start to end turning counter-clockwise about
    ``normal``; CR < 0 selects the arc longer than a half circle (840D CR= convention).
    Returns None if the chord is longer than the diameter."""
    mid, c_len, left = _chord(start_mm, end_mm, normal)
    r = abs(float(radius_mm))
    if c_len == 0.0 or c_len > 2.0 * r * (1 + 1e-9):
        return None
    half = 0.5 * c_len
    h = np.sqrt(max(r * r - half * half, 0.0))
    sign = 1.0 if radius_mm > 0 else -1.0
    return mid + sign * h * left


def center_from_opening_angle(start_mm, end_mm, normal, angle_rad: float):
    """Centre of the arc from start to end with opening angle ``angle_rad`` (840D AR=),
    turning counter-clockwise about ``normal``."""
    mid, c_len, left = _chord(start_mm, end_mm, normal)
    if c_len == 0.0 or not (0.0 < angle_rad < TWO_PI):
        return None
    r = 0.5 * c_len / np.sin(0.5 * angle_rad)
    # signed distance from chord midpoint to centre along `left`
    return mid + r * np.cos(0.5 * angle_rad) * left


def _chord(start_mm, end_mm, normal):
    """Midpoint, length and in-plane left unit normal of the chord start -> end projected on
    the plane of ``normal`` (the centre of the short counter-clockwise arc lies to the left)."""
    start = np.asarray(start_mm, dtype=np.float64)
    w = np.asarray(normal, dtype=np.float64)
    chord = np.asarray(end_mm, dtype=np.float64) - start
    chord_p = chord - np.dot(chord, w) * w
    c_len = float(np.linalg.norm(chord_p))
    left = np.cross(w, chord_p / c_len) if c_len > 0 else np.zeros(3)
    return start + 0.5 * chord_p, c_len, left


def circle_through_points(p1, p2, p3):
    """Centre and CCW normal of the circle through three points (840D CIP).
    Returns (center, normal) or None if the points are collinear."""
    p1, p2, p3 = (np.asarray(p, dtype=np.float64) for p in (p1, p2, p3))
    a, b = p2 - p1, p3 - p1
    n = np.cross(a, b)
    nn = float(np.dot(n, n))
    if nn < 1e-18 * max(float(np.dot(a, a)) * float(np.dot(b, b)), 1e-300):
        return None
    center = p1 + (np.dot(a, a) * np.cross(b, n) + np.dot(b, b) * np.cross(n, a)) / (2.0 * nn)
    normal = n / np.sqrt(nn)  # p1 -> p2 -> p3 runs counter-clockwise about n
    return center, normal


def center_tangential(start_mm, end_mm, tangent, normal):
    """Centre of the arc leaving ``start`` along ``tangent`` and ending at ``end`` (840D CT),
    in the plane with the given normal; also returns the CCW normal for that arc.
    Returns None if the end lies on the tangent line."""
    s = np.asarray(start_mm, dtype=np.float64)
    e = np.asarray(end_mm, dtype=np.float64)
    w = np.asarray(normal, dtype=np.float64)
    t = np.asarray(tangent, dtype=np.float64)
    t = t - np.dot(t, w) * w
    tn = np.linalg.norm(t)
    if tn == 0:
        return None
    t = t / tn
    d = e - s
    d = d - np.dot(d, w) * w
    left = np.cross(w, t)
    side = float(np.dot(d, left))
    if abs(side) < 1e-12:
        return None
    # centre at s + k*left with |c - e| = |k|  ->  k = |d|^2 / (2 d.left)
    k = float(np.dot(d, d)) / (2.0 * side)
    center = s + k * left
    ccw_normal = w if k > 0 else -w
    return center, ccw_normal


# ---------------------------------------------------------------------------------------------
# Evaluation along a Path
# ---------------------------------------------------------------------------------------------

def _arc_terms(path: Path, idx):
    r = path.radius_mm[idx]
    sweep = path.sweep_rad[idx]
    p = np.divide(path.helix_mm[idx], sweep, out=np.zeros_like(r), where=sweep > 0)
    rho = np.sqrt(r * r + p * p)  # ds/dphi
    return r, sweep, p, rho


def point_at(path: Path, idx, s_mm) -> np.ndarray:
    """Positions (m, 3) at arc length ``s_mm`` from the start of segments ``idx``."""
    idx = np.asarray(idx)
    s = np.asarray(s_mm, dtype=np.float64)
    start = path.start_mm[idx]
    end = path.end_mm[idx]
    length = path.length_mm[idx]
    frac = np.divide(s, length, out=np.zeros_like(s), where=length > 0)
    out = start + frac[..., None] * (end - start)
    arc = path.kind[idx] == ARC
    if np.any(arc):
        ia = idx[arc]
        r, sweep, p, rho = _arc_terms(path, ia)
        u, v, w = arc_basis(path.center_mm[ia], path.normal[ia], path.start_mm[ia])
        phi = s[arc] / rho
        out[arc] = (path.center_mm[ia] + r[:, None] * (np.cos(phi)[:, None] * u + np.sin(phi)[:, None] * v)
                    + (p * phi)[:, None] * w)
    return out


def tangent_at(path: Path, idx, s_mm) -> np.ndarray:
    """Unit tangents (m, 3) at arc length ``s_mm`` along segments ``idx``."""
    idx = np.asarray(idx)
    s = np.asarray(s_mm, dtype=np.float64)
    d = path.end_mm[idx] - path.start_mm[idx]
    length = path.length_mm[idx]
    out = np.divide(d, length[:, None], out=np.zeros_like(d), where=length[:, None] > 0)
    arc = path.kind[idx] == ARC
    if np.any(arc):
        ia = idx[arc]
        r, sweep, p, rho = _arc_terms(path, ia)
        u, v, w = arc_basis(path.center_mm[ia], path.normal[ia], path.start_mm[ia])
        phi = s[arc] / rho
        out[arc] = ((r / rho)[:, None] * (-np.sin(phi)[:, None] * u + np.cos(phi)[:, None] * v)
                    + (p / rho)[:, None] * w)
    return out


def curvature_at(path: Path, idx, s_mm) -> np.ndarray:
    """Curvature vectors kappa * n (m, 3), 1/mm, at ``s_mm`` along segments ``idx``; 0 on lines."""
    idx = np.asarray(idx)
    s = np.asarray(s_mm, dtype=np.float64)
    out = np.zeros((idx.shape[0], 3))
    arc = path.kind[idx] == ARC
    if np.any(arc):
        ia = idx[arc]
        r, sweep, p, rho = _arc_terms(path, ia)
        u, v, w = arc_basis(path.center_mm[ia], path.normal[ia], path.start_mm[ia])
        phi = s[arc] / rho
        kappa = r / (rho * rho)
        out[arc] = -kappa[:, None] * (np.cos(phi)[:, None] * u + np.sin(phi)[:, None] * v)
    return out


def curvature_radius_mm(path: Path) -> np.ndarray:
    """Radius of curvature of each segment (inf for lines): (r^2 + p^2) / r for a helix."""
    out = np.full(path.n, np.inf)
    arc = path.kind == ARC
    if np.any(arc):
        r, sweep, p, rho = _arc_terms(path, np.nonzero(arc)[0])
        out[arc] = rho * rho / r
    return out


def line_directions(path: Path) -> np.ndarray:
    """Unit direction of every row taken as a chord (the tangent of a line); 0 if no motion."""
    d = path.end_mm - path.start_mm
    length = np.sqrt(np.einsum("ij,ij->i", d, d))
    return np.divide(d, length[:, None], out=np.zeros_like(d), where=length[:, None] > 0)


def _whole_path(path: Path, at_end: bool, fn, lines_value) -> np.ndarray:
    out = lines_value
    arcs = np.nonzero(path.kind == ARC)[0]
    if arcs.size:
        s = path.length_mm[arcs] if at_end else np.zeros(arcs.size)
        out[arcs] = fn(path, arcs, s)
    return out


def start_tangents(path: Path) -> np.ndarray:
    return _whole_path(path, False, tangent_at, line_directions(path))


def end_tangents(path: Path) -> np.ndarray:
    return _whole_path(path, True, tangent_at, line_directions(path))


def start_curvatures(path: Path) -> np.ndarray:
    return _whole_path(path, False, curvature_at, np.zeros((path.n, 3)))


def end_curvatures(path: Path) -> np.ndarray:
    return _whole_path(path, True, curvature_at, np.zeros((path.n, 3)))
