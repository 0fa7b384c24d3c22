"""ISO 230-4 circular-test indexes of a measured (or simulated) circular path.

The paper (§2.1) uses three indexes of a circular test:

* ``G``, the circularity deviation: the radial distance between two concentric circles that
  enclose the whole path. ISO 230-4 lets it be evaluated about the least-squares circle
  ("square-fit method"): ``G = max(r_i) - min(r_i)`` with ``r_i`` the distances of the points
  to the least-squares centre. That is what :func:`circular_deviation` computes (it is at least
  the minimum-zone value, and equal to it for the ellipses and offsets of servo and structure
  errors to first order).
* ``Fmax`` and ``Fmin``, the radial deviations: the largest and smallest distance from the
  path to the NOMINAL circle (centre and radius from the program, "obtained by centring the
  measurement devices"), positive outward: ``F_i = |p_i - c_nom| - R_nom``.

All lengths in mm except the indexes themselves, which are in um (as the paper reports them).
The least-squares circle is the algebraic (Kasa) fit refined by a geometric fit (minimising
the sum of squared radial residuals ``|p_i - c| - R``) with ``scipy.optimize.least_squares``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from ncsim.errors import UsageError
from ncsim.units import UM_PER_MM


def _xy(pos_mm, axes=(0, 1)) -> np.ndarray:
    p = np.asarray(pos_mm, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] < 2:
        raise UsageError(f"circle points must be an (m, 2) or (m, 3) array, got shape {p.shape}")
    p = p[:, list(axes)] if p.shape[1] > 2 else p
    if not np.all(np.isfinite(p)):
        raise UsageError("circle points contain NaN or infinite values")
    if len(p) < 3:
        raise UsageError(f"a circle fit needs at least 3 points, got {len(p)}")
    return p


def fit_circle_kasa(pos_xy_mm) -> tuple[np.ndarray, float]:
    """Algebraic least-squares circle (Kasa): minimise ``sum (x^2 + y^2 + D x + E y + F)^2``,
    a linear problem; centre ``(-D/2, -E/2)``, radius ``sqrt(D^2/4 + E^2/4 - F)``.

    Exact for points on a circle; slightly biased (towards smaller radii) for noisy points or
    short arcs, hence only the starting point of :func:`fit_circle`."""
    p = _xy(pos_xy_mm)
    mean = p.mean(axis=0)
    q = p - mean  # centring improves conditioning
    sv = np.linalg.svd(q, compute_uv=False)
    if sv[-1] <= 1e-9 * max(sv[0], 1e-300):
        raise UsageError("points are collinear: no circle fits them")
    a = np.column_stack([q[:, 0], q[:, 1], np.ones(len(q))])
    b = -(q[:, 0] ** 2 + q[:, 1] ** 2)
    (d, e, f), *_ = np.linalg.lstsq(a, b, rcond=None)
    center = np.array([-d / 2.0, -e / 2.0])
    r2 = center @ center - f
    if not np.isfinite(r2) or r2 <= 0:
        raise UsageError("points are collinear: no circle fits them")
    return center + mean, float(np.sqrt(r2))


def fit_circle(pos_xy_mm, initial=None) -> tuple[np.ndarray, float]:
    """Geometric least-squares circle: centre ``c`` and radius ``R`` minimising
    ``sum (|p_i - c| - R)^2`` (the ISO 230-4 least-squares circle), started from the Kasa fit
    (or ``initial = (center, radius)``)."""
    p = _xy(pos_xy_mm)
    c0, r0 = initial if initial is not None else fit_circle_kasa(p)
    c0 = np.asarray(c0, dtype=np.float64)
    scale = max(float(r0), 1e-9)

    def residual(x):
        return np.hypot(p[:, 0] - x[0], p[:, 1] - x[1]) - x[2]

    def jac(x):
        d = np.hypot(p[:, 0] - x[0], p[:, 1] - x[1])
        d = np.where(d > 0, d, 1e-300)
        return np.column_stack([-(p[:, 0] - x[0]) / d, -(p[:, 1] - x[1]) / d, -np.ones(len(p))])

    sol = least_squares(residual, np.array([c0[0], c0[1], float(r0)]), jac=jac, method="lm",
                        x_scale=scale, xtol=1e-15, ftol=1e-15, gtol=1e-15)
    return sol.x[:2].copy(), float(sol.x[2])


def polar_about(pos_xy_mm, center_mm) -> tuple[np.ndarray, np.ndarray]:
    """Angle (rad, in (-pi, pi], from +X of the plane) and distance (mm) of points about a centre."""
    p = _xy(pos_xy_mm)
    d = p - np.asarray(center_mm, dtype=np.float64)
    return np.arctan2(d[:, 1], d[:, 0]), np.hypot(d[:, 0], d[:, 1])


def radial_deviation_um(pos_xy_mm, center_mm, radius_mm) -> tuple[np.ndarray, np.ndarray]:
    """Per-point radial deviation from a circle, positive outward (um), and each point's angle
    (rad): ``F_i = |p_i - c| - R`` (paper §2.1, Fig. 1b). For localisation on arcs."""
    ang, r = polar_about(pos_xy_mm, center_mm)
    return ang, (r - float(radius_mm)) * UM_PER_MM


def deviation_profile(angle_rad, dev_um, n_bins: int = 36, start_rad: float = -np.pi):
    """Radial deviation binned by angular position: for each of ``n_bins`` equal sectors from
    ``start_rad``, the bin centre (rad) and the mean, max and min deviation (NaN if empty) and
    the point count. Use it to say WHERE on a circle the contour departs (quadrants, reversals).
    """
    ang = np.mod(np.asarray(angle_rad, dtype=np.float64) - start_rad, 2 * np.pi)
    dev = np.asarray(dev_um, dtype=np.float64)
    k = np.minimum((ang / (2 * np.pi) * n_bins).astype(np.int64), n_bins - 1)
    count = np.bincount(k, minlength=n_bins)
    total = np.bincount(k, weights=dev, minlength=n_bins)
    mean = np.divide(total, count, out=np.full(n_bins, np.nan), where=count > 0)
    vmax = np.full(n_bins, -np.inf)
    vmin = np.full(n_bins, np.inf)
    np.maximum.at(vmax, k, dev)
    np.minimum.at(vmin, k, dev)
    vmax[count == 0] = np.nan
    vmin[count == 0] = np.nan
    centres = start_rad + (np.arange(n_bins) + 0.5) * 2 * np.pi / n_bins
    return centres, mean, vmax, vmin, count


@dataclass(frozen=True, eq=False)
class CircleIndexes:
    """ISO 230-4 indexes of one circular path (paper §2.1); indexes in um, geometry in mm."""

    G_um: float                    # circularity deviation about the least-squares centre
    Fmax_um: float                 # largest radial deviation from the nominal circle (outward +)
    Fmin_um: float                 # smallest radial deviation from the nominal circle
    center_mm: np.ndarray          # least-squares centre (2,)
    radius_mm: float               # least-squares radius
    nominal_center_mm: np.ndarray  # centre the F indexes refer to (2,)
    nominal_radius_mm: float       # radius the F indexes refer to
    angle_rad: np.ndarray          # (m,) angular position of each point about the nominal centre
    radial_dev_um: np.ndarray      # (m,) F_i, deviation from the nominal circle, outward +
    ls_dev_um: np.ndarray          # (m,) deviation from the least-squares circle
    coverage_rad: float            # angular span covered by the points (2 pi for a full circle)

    @property
    def n_points(self) -> int:
        return len(self.angle_rad)

    @property
    def center_offset_um(self) -> float:
        """Distance between the least-squares and the nominal centre."""
        return float(np.hypot(*(self.center_mm - self.nominal_center_mm)) * UM_PER_MM)

    @property
    def radius_error_um(self) -> float:
        """Least-squares radius minus nominal radius (negative: the circle shrank)."""
        return (self.radius_mm - self.nominal_radius_mm) * UM_PER_MM

    def profile(self, n_bins: int = 36):
        """:func:`deviation_profile` of the radial deviation from the nominal circle."""
        return deviation_profile(self.angle_rad, self.radial_dev_um, n_bins)


def _coverage(angle_rad: np.ndarray) -> float:
    """Angular span covered: 2 pi minus the largest gap between sorted angles."""
    a = np.sort(np.mod(angle_rad, 2 * np.pi))
    gaps = np.diff(np.concatenate([a, [a[0] + 2 * np.pi]]))
    return float(2 * np.pi - gaps.max())


def circular_deviation(pos_xy_mm, nominal_center_mm=None, nominal_radius_mm=None, *,
                       axes=(0, 1)) -> CircleIndexes:
    """ISO 230-4 indexes of the points ``pos_xy_mm`` ((m, 2), or (m, 3) with ``axes`` the two
    plane axes, default X Y).

    ``G`` is about the least-squares circle; ``Fmax``/``Fmin`` about the nominal circle
    (``nominal_center_mm``, ``nominal_radius_mm`` from the program). A missing nominal centre
    or radius is replaced by the least-squares one (then ``Fmax - Fmin = G``).
    The caller chooses the points: the paper's tests take the whole circle; exclude the
    approach arcs (and, if wanted, the ramps) before calling.
    """
    p = _xy(pos_xy_mm, axes)
    center, radius = fit_circle(p)
    _, r_ls = polar_about(p, center)
    ls_dev = (r_ls - radius) * UM_PER_MM
    nc = center if nominal_center_mm is None else np.asarray(nominal_center_mm, dtype=float)[:2]
    nr = radius if nominal_radius_mm is None else float(nominal_radius_mm)
    ang, dev = radial_deviation_um(p, nc, nr)
    return CircleIndexes(G_um=float(ls_dev.max() - ls_dev.min()), Fmax_um=float(dev.max()),
                         Fmin_um=float(dev.min()), center_mm=center, radius_mm=radius,
                         nominal_center_mm=np.array(nc, dtype=float), nominal_radius_mm=nr,
                         angle_rad=ang, radial_dev_um=dev, ls_dev_um=ls_dev,
                         coverage_rad=_coverage(ang))
