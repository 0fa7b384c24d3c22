"""Oscilloscope-like degradation: reproducible, and each degradation as configured."""
from __future__ import annotations

import numpy as np
import pytest

from ncsim.errors import UsageError
from ncsim.gap.truth.synth import ScopeConfig, degrade, dropout_mask, quantise, sample_times_s


def truth(duration_s=2.0, dt=2.5e-4):
    t = np.arange(0.0, duration_s + dt / 2, dt)
    pos = np.column_stack([10.0 * np.sin(t), 50.0 * t, np.full(len(t), 3.0)])
    vel = np.column_stack([10.0 * np.cos(t), np.full(len(t), 50.0), 0 * t])
    return t, pos, vel


def test_reproducible_by_seed():
    t, p, v = truth()
    cfg = ScopeConfig(period_s=2e-3, noise_um=3.0, quant_um=0.5, dropout_fraction=0.1,
                      dropout_burst=2, record_feed=True, feed_noise_mm_s=0.5)
    a = degrade(t, p, cfg, seed=42, vel_mm_s=v)
    b = degrade(t, p, cfg, seed=42, vel_mm_s=v)
    c = degrade(t, p, cfg, seed=43, vel_mm_s=v)
    assert np.array_equal(a.t_s, b.t_s) and np.array_equal(a.pos_mm, b.pos_mm)
    assert np.array_equal(a.feed_mm_s, b.feed_mm_s)
    assert len(a) != len(c) or not np.array_equal(a.pos_mm, c.pos_mm)


def test_sampling_offsets_and_clean_positions():
    t, p, v = truth()
    cfg = ScopeConfig(period_s=5e-3, time_offset_s=2.5, pos_offset_mm=(1.0, -2.0, 0.5),
                      phase_s=1e-3)
    tr = degrade(t, p, cfg, seed=0)
    tk = tr.extra["truth_t_s"]
    assert tk[0] == pytest.approx(1e-3) and np.allclose(np.diff(tk), 5e-3)
    assert np.allclose(tr.t_s, tk + 2.5)
    expected = np.column_stack([10.0 * np.sin(tk), 50.0 * tk, np.full(len(tk), 3.0)])
    # linear interpolation of a 0.25 ms truth: chord error <= a dt^2 / 8 = 10 * 6.25e-8 / 8
    assert np.allclose(tr.pos_mm - [1.0, -2.0, 0.5], expected, atol=1e-7)
    assert len(tr) == len(sample_times_s(0.0, 2.0, 5e-3, 1e-3)) == 400


def test_noise_and_quantisation():
    t, p, v = truth()
    tr = degrade(t, p, ScopeConfig(period_s=1e-3, noise_um=5.0, phase_s=0.0), seed=1)
    err = tr.pos_mm - np.column_stack([np.interp(tr.extra["truth_t_s"], t, p[:, k]) for k in range(3)])
    # std of 2001 x 3 normal samples: within 5 % of 5 um
    assert np.std(err) == pytest.approx(5e-3, rel=0.05)
    assert abs(np.mean(err)) < 4 * 5e-3 / np.sqrt(err.size)
    q = degrade(t, p, ScopeConfig(period_s=1e-3, noise_um=1.0, quant_um=2.0), seed=1)
    steps = q.pos_mm / 2e-3
    assert np.allclose(steps, np.round(steps), atol=1e-6)
    assert np.allclose(quantise(np.array([0.0014, -0.0016]), 1e-3), [0.001, -0.002])


def test_dropouts():
    rng = np.random.default_rng(0)
    keep = dropout_mask(100000, 0.1, 4, rng)
    assert keep[0] and keep[-1]
    assert np.mean(~keep) == pytest.approx(0.1, abs=0.01)
    lost = np.nonzero(~keep)[0]
    runs = np.split(lost, np.nonzero(np.diff(lost) > 1)[0] + 1)
    assert np.median([len(r) for r in runs]) == 4
    t, p, v = truth()
    tr = degrade(t, p, ScopeConfig(period_s=2e-3, dropout_fraction=0.2), seed=5)
    gaps = np.diff(tr.t_s) / 2e-3
    assert np.allclose(gaps, np.round(gaps)) and gaps.max() >= 2    # missing samples = gaps
    assert len(tr) < 0.9 * 1000


def test_feed_and_command_recording():
    t, p, v = truth()
    cmd = p + 0.01
    tr = degrade(t, p, ScopeConfig(period_s=4e-3, record_feed=True, record_command=True,
                                   pos_offset_mm=(1, 1, 1)), seed=3, vel_mm_s=v, cmd_pos_mm=cmd)
    tk = tr.extra["truth_t_s"]
    assert np.allclose(tr.feed_mm_s, np.hypot(10 * np.cos(tk), 50.0), atol=1e-4)
    assert np.allclose(tr.cmd_pos_mm - tr.pos_mm, 0.01, atol=1e-9)


def test_config_checks():
    for bad in (dict(period_s=0.5e-3), dict(period_s=13e-3), dict(noise_um=-1),
                dict(dropout_fraction=1.0), dict(dropout_burst=0), dict(pos_offset_mm=(0, 0)),
                dict(phase_s=5e-3, period_s=4e-3)):
        with pytest.raises(UsageError):
            ScopeConfig(**bad)
    ScopeConfig(period_s=1e-3), ScopeConfig(period_s=12e-3)
    t, p, v = truth()
    with pytest.raises(UsageError, match="cmd_pos_mm"):
        degrade(t, p, ScopeConfig(record_command=True), seed=0)
