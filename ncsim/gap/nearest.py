"""Nearest program points of recorded samples, in order: the search behind
``ncsim.gap.register`` (a kernel of ``ncsim.jit``, compiled by numba).

:func:`track` places every sample on the path (its path length ``s``, segment, foot point and
unit tangent) by a windowed nearest-point search on the exact lines, arcs and helices
(``ncsim.geometry``'s convention: ``P(phi) = c + r (cos(phi) u + sin(phi) v) + p phi w``, arc
length ``phi sqrt(r^2 + p^2)``). The window of sample ``i`` starts ``back`` behind where sample
``i - 1`` was placed and reaches ``FORWARD_CHORDS`` times the chord between them plus a slack
ahead (a path length the recorded motion can have covered), so the places advance in order: a
pass of a repeated contour below cannot be mixed in and a place the path visits twice is told
apart by order. On an arc the candidates are the angle of the sample's projection and its
turns (Newton steps on the squared distance for a helix) and the window's ends.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ncsim.geometry import arc_basis
from ncsim.jit import njit
from ncsim.path import ARC, Path

FORWARD_CHORDS = 3.0              # the place may advance up to 3 chords per sample


@dataclass(frozen=True, eq=False)
class PathGeometry:
    """The columns of a :class:`~ncsim.path.Path` the nearest-point search needs."""

    kind: np.ndarray      # (n,) int8: 0 line, 1 arc/helix
    start: np.ndarray     # (n, 3)
    end: np.ndarray       # (n, 3)
    s0: np.ndarray        # (n,) path length at each segment start
    length: np.ndarray    # (n,)
    center: np.ndarray    # (n, 3)
    u: np.ndarray         # (n, 3) arc basis: centre -> start
    v: np.ndarray         # (n, 3) w x u
    w: np.ndarray         # (n, 3) normal (travel counter-clockwise about it)
    radius: np.ndarray    # (n,)
    sweep: np.ndarray     # (n,)
    pitch: np.ndarray     # (n,) helix rise per radian
    total_mm: float


def path_geometry(path: Path) -> PathGeometry:
    n = path.n
    arc = path.kind == ARC
    u = np.zeros((n, 3))
    v = np.zeros((n, 3))
    w = np.zeros((n, 3))
    center = np.zeros((n, 3))
    radius = np.zeros(n)
    sweep = np.zeros(n)
    pitch = np.zeros(n)
    if np.any(arc):
        ua, va, wa = arc_basis(path.center_mm[arc], path.normal[arc], path.start_mm[arc])
        u[arc], v[arc], w[arc] = ua, va, wa
        center[arc] = path.center_mm[arc]
        radius[arc] = path.radius_mm[arc]
        sweep[arc] = path.sweep_rad[arc]
        pitch[arc] = np.divide(path.helix_mm[arc], sweep[arc], out=np.zeros(int(arc.sum())),
                               where=sweep[arc] > 0)
    f = lambda a: np.ascontiguousarray(a, dtype=np.float64)  # noqa: E731
    return PathGeometry(kind=np.ascontiguousarray(path.kind, dtype=np.int8),
                        start=f(path.start_mm), end=f(path.end_mm), s0=f(path.s_start_mm),
                        length=f(path.length_mm), center=f(center), u=f(u), v=f(v), w=f(w),
                        radius=f(radius), sweep=f(sweep), pitch=f(pitch),
                        total_mm=path.total_length_mm)


@njit(cache=True)
def _nearest_on_segment(q0, q1, q2, k, lo, hi, kind, start, end, length, center, u, v, w,
                        radius, sweep, pitch):
    """Nearest point to q on segment k restricted to local path lengths [lo, hi]: returns
    (squared distance, local path length, foot x y z, tangent x y z)."""
    if kind[k] == 0:
        L = length[k]
        if L > 0.0:
            t0 = (end[k, 0] - start[k, 0]) / L
            t1 = (end[k, 1] - start[k, 1]) / L
            t2 = (end[k, 2] - start[k, 2]) / L
        else:
            t0 = 0.0
            t1 = 0.0
            t2 = 0.0
        a = (q0 - start[k, 0]) * t0 + (q1 - start[k, 1]) * t1 + (q2 - start[k, 2]) * t2
        a = min(max(a, lo), hi)
        f0 = start[k, 0] + a * t0
        f1 = start[k, 1] + a * t1
        f2 = start[k, 2] + a * t2
        d2 = (q0 - f0) ** 2 + (q1 - f1) ** 2 + (q2 - f2) ** 2
        return d2, a, f0, f1, f2, t0, t1, t2
    r = radius[k]
    p = pitch[k]
    rho = math.sqrt(r * r + p * p)
    d0 = q0 - center[k, 0]
    d1 = q1 - center[k, 1]
    d2_ = q2 - center[k, 2]
    x = d0 * u[k, 0] + d1 * u[k, 1] + d2_ * u[k, 2]
    y = d0 * v[k, 0] + d1 * v[k, 1] + d2_ * v[k, 2]
    z = d0 * w[k, 0] + d1 * w[k, 1] + d2_ * w[k, 2]
    phi_lo = lo / rho
    phi_hi = hi / rho
    phi0 = math.atan2(y, x)
    if phi0 < 0.0:
        phi0 += 2.0 * math.pi
    best_d2 = np.inf
    best_phi = phi_lo
    n_turns = int(sweep[k] / (2.0 * math.pi)) + 2
    for j in range(-1, n_turns + 1):
        if j == n_turns:
            phi = phi_lo
        elif j == -1:
            phi = phi_hi
        else:
            phi = phi0 + 2.0 * math.pi * j
            if phi > phi_hi + math.pi:
                continue
            if p != 0.0:   # helix: Newton on the squared distance
                for _ in range(4):
                    c = math.cos(phi)
                    s = math.sin(phi)
                    g = r * x * s - r * y * c + p * (p * phi - z)
                    h = p * p + r * x * c + r * y * s
                    if h <= 0.0:
                        break
                    phi -= g / h
        phi = min(max(phi, phi_lo), phi_hi)
        c = math.cos(phi)
        s = math.sin(phi)
        e0 = r * c - x
        e1 = r * s - y
        e2 = p * phi - z
        dd = e0 * e0 + e1 * e1 + e2 * e2
        if dd < best_d2:
            best_d2 = dd
            best_phi = phi
    c = math.cos(best_phi)
    s = math.sin(best_phi)
    f0 = center[k, 0] + r * (c * u[k, 0] + s * v[k, 0]) + p * best_phi * w[k, 0]
    f1 = center[k, 1] + r * (c * u[k, 1] + s * v[k, 1]) + p * best_phi * w[k, 1]
    f2 = center[k, 2] + r * (c * u[k, 2] + s * v[k, 2]) + p * best_phi * w[k, 2]
    t0 = (r * (-s * u[k, 0] + c * v[k, 0]) + p * w[k, 0]) / rho
    t1 = (r * (-s * u[k, 1] + c * v[k, 1]) + p * w[k, 1]) / rho
    t2 = (r * (-s * u[k, 2] + c * v[k, 2]) + p * w[k, 2]) / rho
    return best_d2, best_phi * rho, f0, f1, f2, t0, t1, t2


#: always compiled (unless ``NCSIM_KERNELS=python``): registration tracks every seed and every
#: Gauss-Newton step, and a sample's window can span many segments of a CAM program, so the
#: cost of a call is not told by its number of samples
@njit(cache=True, python_below=0)
def _track(q, s_seed, first_window, back, forward, kind, start, end, s0, length, center, u,
           v, w, radius, sweep, pitch, out_s, out_seg, out_foot, out_tan):
    """Monotone windowed nearest-point search of the samples ``q`` in order (module
    docstring, step 2): sample i is searched in [s_prev - back, s_prev + forward[i]]; the first
    one in s_seed +- first_window."""
    n = s0.shape[0]
    s_prev = s_seed
    for i in range(q.shape[0]):
        if i == 0:
            lo_s = s_seed - first_window
            hi_s = s_seed + first_window
        else:
            lo_s = s_prev - back
            hi_s = s_prev + forward[i]
        k_lo = np.searchsorted(s0, lo_s, side="right") - 1
        k_hi = np.searchsorted(s0, hi_s, side="right") - 1
        k_lo = min(max(k_lo, 0), n - 1)
        k_hi = min(max(k_hi, k_lo), n - 1)
        best = np.inf
        for k in range(k_lo, k_hi + 1):
            lo = max(lo_s - s0[k], 0.0)
            hi = min(hi_s - s0[k], length[k])
            if hi < lo:
                if k == k_lo and k == k_hi:
                    lo = min(max(lo, 0.0), length[k])
                    hi = lo
                else:
                    continue
            d2, a, f0, f1, f2, t0, t1, t2 = _nearest_on_segment(
                q[i, 0], q[i, 1], q[i, 2], k, lo, hi, kind, start, end, length, center, u, v, w,
                radius, sweep, pitch)
            if d2 < best:
                best = d2
                out_s[i] = s0[k] + a
                out_seg[i] = k
                out_foot[i, 0] = f0
                out_foot[i, 1] = f1
                out_foot[i, 2] = f2
                out_tan[i, 0] = t0
                out_tan[i, 1] = t1
                out_tan[i, 2] = t2
        if i == 0:
            s_prev = out_s[i]
        else:
            s_prev = max(s_prev, out_s[i])


@dataclass(frozen=True, eq=False)
class Places:
    """Where each sample was placed: path length, segment, foot point, tangent and the
    sample minus its foot."""

    s: np.ndarray
    segment: np.ndarray
    foot: np.ndarray
    tangent: np.ndarray
    residual: np.ndarray

    @property
    def distance(self) -> np.ndarray:
        return np.sqrt(np.einsum("ij,ij->i", self.residual, self.residual))


def track(q_mm: np.ndarray, geo: PathGeometry, s_seed_mm: float, *, first_window_mm: float,
          slack_mm: float) -> Places:
    """Places of the samples ``q_mm`` (program coordinates) on the path, in order."""
    q = np.ascontiguousarray(q_mm, dtype=np.float64)
    m = len(q)
    chord = np.zeros(m)
    chord[1:] = np.linalg.norm(np.diff(q, axis=0), axis=1)
    forward = FORWARD_CHORDS * chord + slack_mm
    out_s = np.zeros(m)
    out_seg = np.zeros(m, dtype=np.int64)
    out_foot = np.zeros((m, 3))
    out_tan = np.zeros((m, 3))
    _track(q, float(s_seed_mm), float(first_window_mm), float(slack_mm), forward, geo.kind,
           geo.start, geo.end, geo.s0, geo.length, geo.center, geo.u, geo.v, geo.w, geo.radius,
           geo.sweep, geo.pitch, out_s, out_seg, out_foot, out_tan)
    return Places(out_s, out_seg, out_foot, out_tan, q - out_foot)
