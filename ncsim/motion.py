"""Planned motion: the planner's output, a 1-D feed law along the path.

Geometry stays in :class:`~ncsim.path.Path`; a :class:`Motion` maps time to path length as a
sequence of constant-jerk *pieces* (Klipper's trapq idea, ruckig's profile phases)::

    s(tau) = s0 + v0 tau + a0 tau^2 / 2 + j tau^3 / 6,   0 <= tau < t[k+1] - t[k]

Pieces cover the whole run, including standstills (dwell, exact-stop settle) as pieces with
v = a = j = 0. Per block and per junction the motion also keeps the limits that shaped it,
so that reports can say where and why the feed is limited.

Limit names (the ``limit`` column of traces and JSON summaries) are the values of
:class:`Limit`; phases follow the paper (A acceleration, B steady, C deceleration).

A :class:`Trace` is a motion sampled in time (what the NC's oscilloscope would record): columns
of equal length, one row per sample, made by ``ncsim.plan.sample.sample_motion`` and read by
reports, plots, CSV output and the gap diagnosis. Tangential quantities describe the feed law;
per-axis quantities (X, Y, Z) are the derivatives of the interpolated position.
"""
from __future__ import annotations

from dataclasses import dataclass, field, fields
from enum import IntEnum

import numpy as np

from ncsim.machine import MachineSpec
from ncsim.path import Path


class Limit(IntEnum):
    """Why the feed is what it is. ``name.lower()`` is the public name used in CSV/JSON."""

    PROGRAMMED = 0      # the programmed feed F (or G0 at axis velocity: see AXIS_VELOCITY)
    NCU_PATH_JERK = 1   # V_Jtcurv, NCU curvilinear jerk J_curv * r_jct (paper eq. 10-11)
    AXIS_JERK = 2       # V_Jt, axis jerk capacity (paper eq. 4, 9)
    AXIS_ACCEL = 3      # V_An, axis acceleration capacity (paper eq. 2, 8)
    AXIS_VELOCITY = 4   # V_t, axis velocity capacity (paper eq. 7)
    CYCLE_TIME = 5      # V_tcy, one block per interpolation cycle at least (paper eq. 6)
    TRANSITION = 6      # V_fr, curvature-jump crossing (paper eq. 13, 15)
    CORNER = 7          # tangent discontinuity in continuous-path mode (G64, G641, G642)
    EXACT_STOP = 8      # G60 / G9 exact stop
    LOOKAHEAD = 9       # stop assumed at the end of the last prepared block
    PROGRAM_END = 10    # start and end of the program at rest
    DWELL = 11          # G4 dwell or exact-stop settle: standing still
    AUX_STOP = 12       # no rounding across M output, STOPRE, SOFT/BRISK change, G0<->G1
    NONE = 13           # unconstrained (e.g. a junction that limits nothing)

    @property
    def label(self) -> str:
        return self.name.lower()


LIMIT_LABELS = tuple(m.label for m in Limit)


class Phase(IntEnum):
    """Phase of the feed law at a sample (paper §5.2.2)."""

    A = 0      # acceleration
    B = 1      # steady feed
    C = 2      # deceleration
    STOP = 3   # standing still (dwell, exact-stop settle, start/end)


@dataclass(frozen=True, slots=True)
class ModelOptions:
    """Which parts of the 840D model the planner applies (all on = the full model).

    The gap diagnosis (``ncsim.gap``) starts from a base model with some of these off and adds
    them back one by one.
    """

    ncu_path_jerk: bool = True        # eq. 10-11: V_Jtcurv in the set point
    axis_jerk_setpoint: bool = True   # eq. 4/9 at alpha_c: V_Jt in the set point
    transition_crossing: bool = True  # eq. 13/15: curvature-jump crossing speeds
    cycle_time_limit: bool = True     # eq. 6: V_tcy
    jerk_limited_ramps: bool = True   # phases A/C at the jerk in force; False: accel-limited
    lookahead: bool = True            # finite look-ahead depth (stop at the end of the window)
    accel_mode: int | None = None     # force SOFT/BRISK/DRIVE (path.SOFT...) on every block


FULL_MODEL = ModelOptions()


@dataclass(frozen=True, slots=True)
class Motion:
    """The planned feed law of a :class:`Path` on a machine (see module docstring).

    Shapes: ``n`` blocks (= path segments), ``n + 1`` junctions, ``m`` pieces.
    """

    path: Path
    machine: MachineSpec
    options: ModelOptions

    # -- per block (n) ------------------------------------------------------------------------
    cap_mm_s: np.ndarray          # feed set point V_st of the block (paper eq. 12 + guards)
    cap_limit: np.ndarray         # int8 Limit that sets cap_mm_s
    jerk_mm_s3: np.ndarray        # tangential jerk in force for phases A/C
    accel_mm_s2: np.ndarray       # tangential acceleration in force
    t_start_s: np.ndarray         # time the tool leaves the block's start junction
    t_end_s: np.ndarray           # time the tool reaches the block's end junction
    feed_max_mm_s: np.ndarray     # highest feed reached inside the block

    # -- per junction (n + 1); junction k is the start of block k -----------------------------
    junction_cap_mm_s: np.ndarray     # max crossing feed (0 at stops), before block caps
    junction_limit: np.ndarray        # int8 Limit of the junction cap
    junction_dwell_s: np.ndarray      # time standing still at the junction (G4, settle)
    v_junction_mm_s: np.ndarray       # planned feed at the junction
    a_junction_mm_s2: np.ndarray      # planned tangential acceleration at the junction
    knot: np.ndarray                  # bool: a zero-acceleration point of the feed law

    # -- pieces (m) --------------------------------------------------------------------------
    piece_t_s: np.ndarray         # (m + 1,) start times; piece_t_s[-1] is the end of the run
    piece_s_mm: np.ndarray        # path length at piece start
    piece_v_mm_s: np.ndarray      # feed at piece start
    piece_a_mm_s2: np.ndarray     # tangential acceleration at piece start
    piece_j_mm_s3: np.ndarray     # constant tangential jerk over the piece
    piece_phase: np.ndarray       # int8 Phase
    piece_limit: np.ndarray       # int8 Limit: what holds the feed during the piece

    notes: tuple[str, ...] = field(default=())

    @property
    def n_blocks(self) -> int:
        return len(self.cap_mm_s)

    @property
    def total_time_s(self) -> float:
        return float(self.piece_t_s[-1]) if len(self.piece_t_s) else 0.0

    @property
    def duration_s(self) -> np.ndarray:
        """Time spent moving through each block (dwells at junctions excluded)."""
        return self.t_end_s - self.t_start_s


# ---------------------------------------------------------------------------------------------
# Samples
# ---------------------------------------------------------------------------------------------

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
