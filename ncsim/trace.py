"""Sampled trace of a planned motion (what the NC's oscilloscope would record).

A :class:`Trace` is columns of equal length, one row per sample. It is produced by
``ncsim.sample.sample_motion`` and consumed by reports, plots, CSV output and the gap
diagnosis. Tangential quantities describe the feed law; per-axis quantities (X, Y, Z) are the
derivatives of the interpolated position.
"""
from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

AXES = ("x", "y", "z")


@dataclass(frozen=True, slots=True)
class Trace:
    t_s: np.ndarray               # (m,) time
    s_mm: np.ndarray              # (m,) path length travelled
    feed_mm_s: np.ndarray         # (m,) path feed |v|
    accel_t_mm_s2: np.ndarray     # (m,) tangential acceleration dV/dt
    jerk_t_mm_s3: np.ndarray      # (m,) tangential jerk of the feed law d2V/dt2
    accel_n_mm_s2: np.ndarray     # (m,) normal acceleration V^2/R (paper eq. 1)
    jerk_n_mm_s3: np.ndarray      # (m,) jerk of direction change V^3/R^2 (paper eq. 3)
    pos_mm: np.ndarray            # (m, 3) X Y Z
    vel_mm_s: np.ndarray          # (m, 3)
    acc_mm_s2: np.ndarray         # (m, 3)
    jerk_mm_s3: np.ndarray        # (m, 3)
    block: np.ndarray             # (m,) int32 block (= path segment) index
    line: np.ndarray              # (m,) int32 source line of the block
    limit: np.ndarray             # (m,) int8 motion.Limit holding the feed
    phase: np.ndarray             # (m,) int8 motion.Phase
    setpoint_mm_s: np.ndarray     # (m,) the block's feed set point V_st
    programmed_mm_s: np.ndarray   # (m,) the programmed feed (inf for rapid)

    def __post_init__(self) -> None:
        m = len(self.t_s)
        for f in fields(self):
            arr = getattr(self, f.name)
            if arr.shape[0] != m:
                raise ValueError(f"Trace.{f.name} has {arr.shape[0]} rows, expected {m}")

    def __len__(self) -> int:
        return len(self.t_s)

    def select(self, index) -> "Trace":
        return Trace(**{f.name: getattr(self, f.name)[index] for f in fields(self)})
