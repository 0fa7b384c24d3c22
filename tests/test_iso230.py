"""ISO 230-4 indexes against hand-computed values (paper §2.1)."""
from __future__ import annotations

import numpy as np
import pytest

from ncsim.errors import UsageError
from ncsim.gap.iso230 import (circular_deviation, deviation_profile, fit_circle, fit_circle_kasa,
                          radial_deviation_um)


def circle(center, r, n=3600, start=0.0):
    a = start + np.linspace(0, 2 * np.pi, n, endpoint=False)
    return np.column_stack([center[0] + r * np.cos(a), center[1] + r * np.sin(a)]), a


def test_fits_are_exact_on_a_circle():
    p, _ = circle((3.0, -4.0), 12.5, n=50)
    for fit in (fit_circle_kasa, fit_circle):
        c, r = fit(p)
        assert np.allclose(c, [3.0, -4.0], atol=1e-9) and r == pytest.approx(12.5, abs=1e-9)


def test_offset_circle():
    # a circle of the nominal radius R whose centre is off by d along 30 deg: about the
    # nominal centre the distance is |c + R u|, largest (R + d) where u is along the offset
    # and smallest (R - d) opposite; G about the least-squares centre is 0.
    R, d, phi = 30.0, 0.020, np.radians(30)
    c = (d * np.cos(phi), d * np.sin(phi))
    p, _ = circle(c, R, start=phi)          # a point exactly along the offset
    ix = circular_deviation(p, (0.0, 0.0), R)
    assert ix.G_um == pytest.approx(0.0, abs=1e-6)
    assert ix.Fmax_um == pytest.approx(20.0, abs=1e-6)
    assert ix.Fmin_um == pytest.approx(-20.0, abs=1e-6)
    assert np.allclose(ix.center_mm, c, atol=1e-10)
    assert ix.center_offset_um == pytest.approx(20.0, abs=1e-6)
    assert ix.coverage_rad == pytest.approx(2 * np.pi, abs=2e-3)
    # per angle: F(theta) = d cos(theta - phi) + O(d^2 / R)
    expected = 1000 * d * np.cos(ix.angle_rad - phi)
    assert np.max(np.abs(ix.radial_dev_um - expected)) < 1000 * d * d / R


def test_ellipse():
    # x = (R + e) cos t, y = (R - e) sin t: by symmetry the least-squares centre is the origin,
    # r ranges from R - e (at t = 90 deg) to R + e (at t = 0): G = 2e; about the nominal circle
    # of radius R, Fmax = +e and Fmin = -e.
    R, e = 30.0, 0.015
    t = np.linspace(0, 2 * np.pi, 3600, endpoint=False)
    p = np.column_stack([(R + e) * np.cos(t), (R - e) * np.sin(t)])
    ix = circular_deviation(p, (0, 0), R)
    assert np.allclose(ix.center_mm, 0, atol=1e-12)
    assert ix.G_um == pytest.approx(30.0, abs=1e-6)
    assert ix.Fmax_um == pytest.approx(15.0, abs=1e-6)
    assert ix.Fmin_um == pytest.approx(-15.0, abs=1e-6)


def test_centrifugal_growth_and_no_nominal():
    # a circle grown by 40 um (the paper's outward "centrifugation"): Fmax = Fmin = +40, G = 0
    p, _ = circle((5, 5), 2.5 + 0.040)
    ix = circular_deviation(p, (5, 5), 2.5)
    assert (ix.Fmax_um, ix.Fmin_um) == (pytest.approx(40, abs=1e-6), pytest.approx(40, abs=1e-6))
    assert ix.radius_error_um == pytest.approx(40.0, abs=1e-6)
    # without a nominal circle, F refers to the least-squares circle, so Fmax - Fmin = G
    q = p + np.column_stack([0.004 * np.cos(3 * np.arange(len(p))), np.zeros(len(p))])
    ix = circular_deviation(q)
    assert ix.Fmax_um - ix.Fmin_um == pytest.approx(ix.G_um)


def test_noisy_circle_and_3d_input():
    rng = np.random.default_rng(1)
    p, _ = circle((1.0, 2.0), 10.0, n=2000)
    noisy = p + rng.normal(0, 0.002, p.shape)
    c, r = fit_circle(noisy)
    # standard error of the centre is sigma sqrt(2 / n) = 0.06 um; allow 5x
    assert np.all(np.abs(c - [1.0, 2.0]) < 5 * 0.002 * np.sqrt(2 / 2000))
    assert abs(r - 10.0) < 5 * 0.002 / np.sqrt(2000)
    p3 = np.column_stack([np.full(len(p), 7.0), p])            # YZ plane circle in 3-D
    ix = circular_deviation(p3, (1.0, 2.0), 10.0, axes=(1, 2))
    assert ix.G_um == pytest.approx(0, abs=1e-6)


def test_profile_and_radial_deviation():
    ang, dev = radial_deviation_um([[2.0, 0.0], [0.0, -3.0], [-1.0, 0.0]], (0, 0), 2.0)
    assert np.allclose(dev, [0.0, 1000.0, -1000.0])
    assert np.allclose(ang, [0.0, -np.pi / 2, np.pi])
    centres, mean, vmax, vmin, count = deviation_profile([0.1, 0.2, 3.0], [1.0, 3.0, 5.0], n_bins=4)
    # bins from -pi: [-pi,-pi/2) [-pi/2,0) [0,pi/2) [pi/2,pi)
    assert list(count) == [0, 0, 2, 1]
    assert mean[2] == 2.0 and vmax[2] == 3.0 and vmin[2] == 1.0 and np.isnan(mean[0])


def test_bad_input():
    with pytest.raises(UsageError, match="at least 3 points"):
        circular_deviation([[0, 0], [1, 1]])
    with pytest.raises(UsageError, match="collinear"):
        circular_deviation([[0, 0], [1, 1], [2, 2], [3, 3]])
    with pytest.raises(UsageError, match="NaN"):
        circular_deviation([[0, 0], [1, np.nan], [2, 0]])
