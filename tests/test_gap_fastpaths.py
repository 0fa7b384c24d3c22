"""The gap's fast paths compute what their definitions say (the speed work of issue 18):
the recorder's mean by slices against its definition by interpolation, and the derived speed
of one unbroken piece against the general form."""
from __future__ import annotations

import numpy as np

from ncsim.gap.closedforms import sample_mean_mm
from ncsim.gap.measured import derived_speed_mm_s


def mean_by_definition(t, x, n, h=2e-3):
    """``(1/N) sum_j x(t + (j - (N-1)/2) h)``, x linear between samples and held at its ends."""
    out = np.zeros_like(x)
    for j in range(n):
        tq = t + (j - 0.5 * (n - 1)) * h
        for k in range(x.shape[1]):
            out[:, k] += np.interp(tq, t, x[:, k])
    return out / n


def test_recorder_mean_by_slices_is_its_definition():
    rng = np.random.default_rng(3)
    for dt in (2e-3, 1e-3, 5e-4, 4e-3):
        t = -0.1 + dt * np.arange(700)
        x = np.cumsum(rng.normal(size=(700, 3)), axis=0)
        for n in (2, 3, 10, 15, 64):
            assert np.allclose(sample_mean_mm(t, x, n), mean_by_definition(t, x, n),
                               rtol=0, atol=1e-10), (dt, n)
    # a grid the raw period does not divide (3 ms): the general form
    t = 3e-3 * np.arange(300)
    x = np.cumsum(rng.normal(size=(300, 3)), axis=0)
    assert np.allclose(sample_mean_mm(t, x, 10), mean_by_definition(t, x, 10), atol=1e-10)


def test_derived_speed_of_one_piece_is_the_general_form():
    rng = np.random.default_rng(4)
    t = 2e-3 * np.arange(5000) + 1e-4 * rng.random(5000)       # a little jitter, no gap
    p = np.cumsum(rng.normal(size=(5000, 3)), axis=0)
    one_piece = np.zeros(5000, dtype=np.int64)                  # the general path (segments)
    for smooth in (0.0, 0.01, 0.04):
        assert np.allclose(derived_speed_mm_s(t, p, smooth),
                           derived_speed_mm_s(t, p, smooth, segment=one_piece), atol=1e-12)
    # a gap of 10 periods breaks the piece: both forms take the general path
    t2 = t.copy()
    t2[2500:] += 0.02
    v = derived_speed_mm_s(t2, p, 0.04)
    assert np.allclose(v, derived_speed_mm_s(t2, p, 0.04, segment=one_piece), atol=1e-12)
