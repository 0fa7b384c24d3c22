"""Oscilloscope-like degradation of a truth trace (for the withheld-effect benchmark).

A 840D "trace" (servo oscilloscope) records the actual positions every few IPO or position-
control cycles, from an instant nobody aligned with the part program, in encoder increments,
with a little electrical and vibration noise, and sometimes misses samples. :func:`degrade`
turns a dense truth (e.g. :func:`ncsim.gap.truth.servo.simulate_servo` at 0.25 ms) into such a record,
seeded and reproducible:

1. sampling instants ``t_k = t_first + phase + k * period`` over the truth span (``phase``
   uniform in [0, period) unless given: the recorder's clock is not the NC's);
2. positions at ``t_k`` by linear interpolation of the truth (fine for truth steps <= 1 ms:
   the chord error is ``a dt^2 / 8``, 0.1 um at 1 m/s^2 and 1 ms);
3. the start-position offset added, white Gaussian noise of ``noise_um`` added, then rounding to
   the encoder increment ``quant_um`` (the order of a real measuring chain: the scale
   quantises the noisy position);
4. a recorded time ``t_k + time_offset_s``;
5. random dropped samples: each sample lost with probability ``dropout_fraction`` (in bursts
   of ``dropout_burst`` consecutive samples), never the first or the last one.

The recorded path feed (optional) is the truth speed at ``t_k`` with its own noise.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ncsim.errors import UsageError
from ncsim.gap.measured import MeasuredTrace
from ncsim.units import s_to_ms, um_to_mm

MIN_PERIOD_S = 1e-3
MAX_PERIOD_S = 12e-3


@dataclass(frozen=True)
class ScopeConfig:
    """How the recorder degrades the truth (lengths in um where the name says so)."""

    period_s: float = 4e-3                 # sampling period, 1..12 ms
    noise_um: float = 0.0                  # std of white position noise per axis
    quant_um: float = 0.0                  # encoder increment (0: no rounding)
    time_offset_s: float = 0.0             # recorder clock minus NC clock
    pos_offset_mm: tuple = (0.0, 0.0, 0.0)  # recorded zero minus program zero
    dropout_fraction: float = 0.0          # share of samples lost
    dropout_burst: int = 1                 # samples lost together
    phase_s: float | None = None           # first sample after the truth start (None: random)
    feed_noise_mm_s: float = 0.0           # std of the recorded feed's noise
    record_feed: bool = False              # also record the path feed
    record_command: bool = False           # also record the commanded positions (no noise)

    def __post_init__(self) -> None:
        if not (MIN_PERIOD_S - 1e-15 <= self.period_s <= MAX_PERIOD_S + 1e-15):
            raise UsageError(f"sampling period must be in [1, 12] ms, got {s_to_ms(self.period_s):g} ms")
        for name in ("noise_um", "quant_um", "feed_noise_mm_s"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0):
                raise UsageError(f"ScopeConfig.{name} must be >= 0, got {v!r}")
        if not (0.0 <= self.dropout_fraction < 1.0):
            raise UsageError(f"dropout_fraction must be in [0, 1), got {self.dropout_fraction!r}")
        if self.dropout_burst < 1:
            raise UsageError("dropout_burst must be >= 1")
        if len(self.pos_offset_mm) != 3:
            raise UsageError("pos_offset_mm must have 3 values")
        if self.phase_s is not None and not (0 <= self.phase_s < self.period_s):
            raise UsageError("phase_s must be in [0, period_s)")


def sample_times_s(t_first_s: float, t_last_s: float, period_s: float, phase_s: float) -> np.ndarray:
    """``t_first + phase + k period`` for all k with the instant inside the truth span."""
    n = int(math.floor((t_last_s - t_first_s - phase_s) / period_s + 1e-9)) + 1
    return t_first_s + phase_s + period_s * np.arange(max(n, 0))


def dropout_mask(n: int, fraction: float, burst: int, rng: np.random.Generator) -> np.ndarray:
    """Boolean mask of kept samples: bursts of ``burst`` samples start with probability
    ``fraction / burst`` each, so about ``fraction`` of the samples are lost; the first and
    last samples are always kept."""
    keep = np.ones(n, dtype=bool)
    if fraction <= 0 or n <= 2:
        return keep
    starts = np.nonzero(rng.random(n) < fraction / burst)[0]
    for b in range(burst):
        idx = starts + b
        keep[idx[idx < n]] = False
    keep[[0, -1]] = True
    return keep


def quantise(x, step):
    """Round to the nearest multiple of ``step`` (no rounding for step 0)."""
    return x if step <= 0 else np.round(np.asarray(x) / step) * step


def degrade(t_s, pos_mm, config: ScopeConfig, *, seed: int, vel_mm_s=None, cmd_pos_mm=None,
            source: str = "<synthetic scope>") -> MeasuredTrace:
    """Record the truth (``t_s`` (n,), ``pos_mm`` (n, 3), optional ``vel_mm_s`` for the feed,
    ``cmd_pos_mm`` for the command) as ``config`` says, reproducibly for a given ``seed``.
    The recorded trace keeps which truth instant each sample came from in
    ``extra["truth_t_s"]`` (for checking the alignment)."""
    t = np.asarray(t_s, dtype=np.float64)
    p = np.asarray(pos_mm, dtype=np.float64)
    if p.shape != (len(t), 3) or len(t) < 2 or np.any(np.diff(t) <= 0):
        raise UsageError("truth must be (n,) increasing times and (n, 3) positions, n >= 2")
    rng = np.random.default_rng(seed)
    phase = rng.uniform(0.0, config.period_s) if config.phase_s is None else config.phase_s
    tk = sample_times_s(float(t[0]), float(t[-1]), config.period_s, phase)
    if len(tk) < 2:
        raise UsageError("truth shorter than two sampling periods")

    def at(a):
        return np.column_stack([np.interp(tk, t, a[:, k]) for k in range(3)])

    rec = at(p) + np.asarray(config.pos_offset_mm, dtype=np.float64)
    if config.noise_um > 0:
        rec = rec + rng.normal(0.0, um_to_mm(config.noise_um), rec.shape)
    rec = quantise(rec, um_to_mm(config.quant_um))
    feed = None
    if config.record_feed:
        if vel_mm_s is not None:
            speed = np.linalg.norm(np.asarray(vel_mm_s, dtype=np.float64), axis=1)
        else:
            speed = np.linalg.norm(np.gradient(p, t, axis=0), axis=1)
        feed = np.interp(tk, t, speed)
        if config.feed_noise_mm_s > 0:
            feed = np.abs(feed + rng.normal(0.0, config.feed_noise_mm_s, feed.shape))
    cmd = None
    if config.record_command:
        if cmd_pos_mm is None:
            raise UsageError("record_command needs cmd_pos_mm")
        cmd = at(np.asarray(cmd_pos_mm, dtype=np.float64)) + np.asarray(config.pos_offset_mm)
    keep = dropout_mask(len(tk), config.dropout_fraction, config.dropout_burst, rng)
    sel = np.nonzero(keep)[0]
    return MeasuredTrace(t_s=tk[sel] + config.time_offset_s, pos_mm=rec[sel],
                         feed_mm_s=None if feed is None else feed[sel],
                         cmd_pos_mm=None if cmd is None else cmd[sel], source=source,
                         extra={"truth_t_s": tk[sel]})
