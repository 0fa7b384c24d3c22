"""Withheld-effect cases whose truth is NOT made by ncsim's planner, recorded as machines do.

Each case draws one of the effects real machines differ by (:data:`INDEPENDENT_KINDS`) with
random parameters, plans the benchmark program ``programs/gap_passes.mpf`` with the plain
planner of :mod:`ncsim.gap.truth.plain` (ruckig per block, the 840D rules written again; no
``ncsim.plan``) on the nominal machine with that effect planted, and records the commanded
positions under one of the :data:`CONDITIONS` real recordings come in:

* ``scope``: the whole program from rest to rest, every 2-12 ms, a zero offset of a few mm;
* ``partial``: starts and ends mid-program (20-35 % and 65-80 % of the motion time);
* ``machine``: the whole program in machine coordinates (an offset of hundreds of mm);
* ``passes``: one pass of the three (from the middle of its G0 plunge to the middle of its
  last G1): its X and Y are those of every pass;
* ``50hz``: the recorder of a real 840D trace: 500 Hz set points, a centred moving average
  of 10 samples (20 ms), every 10th kept (:func:`moving_average_record`);
* ``kit``: all at once, like KIT's DMC 60H recording (one pass, machine coordinates, 50 Hz).

The commanded positions carry the 840D's 0.1 um resolution and no other noise. The case names
the machine the diagnosis starts from (the nominal one, or its G64 variant for a corner
velocity) and, for filtered recordings, the recorder window it may assume (known, as for
KIT); for the ``recorder`` kind the window is the withheld effect and is not given.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ncsim.gap.measured import MeasuredTrace
from ncsim.gap.truth.draw import EffectDraw
from ncsim.gap.truth.plain import PlainMachine, plan_plain, sample_plain
from ncsim.machine import MachineSpec
from ncsim.nc.interpret import interpret_file
from ncsim.units import m_min_to_mm_s, m_s2_to_mm_s2, ms_to_s, um_to_mm

CONDITIONS = ("scope", "partial", "machine", "passes", "50hz", "kit")
RAW_PERIOD_S = 2e-3          # the 840D's set points as the recorder samples them (500 Hz)
KIT_AVERAGE = 10             # samples averaged and kept-one-in (50 Hz from 500 Hz)
RESOLUTION_UM = 0.1          # set-point resolution
LEAD_S = 0.3                 # rest recorded before the cycle start and after the end
N_PASSES = 3


@dataclass(frozen=True)
class IndependentKind(EffectDraw):
    """How to draw one effect's truth (:class:`~ncsim.gap.truth.draw.EffectDraw`) and whether
    the machine runs continuous path (truth and the diagnosis's start alike)."""

    g64: bool = False


INDEPENDENT_KINDS: dict[str, IndependentKind] = {k.effect: k for k in (
    IndependentKind("rapid_override", {"rapid_override_percent": (3.0, 15.0, "log")}),
    IndependentKind("feed_override", {"feed_override_percent": (60.0, 120.0, "lin")}),
    IndependentKind("axis_velocity", {"axis_velocity_m_min": (1.2, 2.7, "lin")}),
    IndependentKind("axis_accel", {"xy_accel_m_s2": (0.3, 2.0, "log"),
                                   "z_accel_m_s2": (0.3, 2.0, "log")}),
    IndependentKind("reset_mode", {"settle_ms": (5.0, 40.0, "lin")}, fixed={"path_mode": "G64"}),
    IndependentKind("corner_jump", {"corner_jump_mm_s": (2.0, 25.0, "log")}, g64=True),
    IndependentKind("recorder", {"samples": (5, 15, "int")}),
)}


@dataclass(frozen=True)
class IndependentCase:
    index: int
    effect: str
    params: dict
    condition: str
    seed: int
    period_s: float
    offset_mm: tuple
    window: tuple              # (start, end) share of the motion time recorded (partial)
    g64: bool

    @property
    def base(self) -> str:
        return "full"

    @property
    def known_recorder_ms(self) -> float | None:
        """The recorder window the diagnosis may assume (None: not filtered, or withheld)."""
        if self.effect == "recorder" or self.condition not in ("50hz", "kit"):
            return None
        return KIT_AVERAGE * RAW_PERIOD_S * 1e3

    def as_dict(self) -> dict:
        return {"index": self.index, "effect": self.effect, "params": dict(self.params),
                "condition": self.condition, "seed": self.seed, "period_ms": self.period_s * 1e3,
                "offset_mm": list(self.offset_mm), "window": list(self.window), "g64": self.g64,
                "truth": "independent (ncsim.gap.truth.plain)"}


def draw_independent_case(rng: np.random.Generator, index: int, effect: str,
                          condition: str) -> IndependentCase:
    k = INDEPENDENT_KINDS[effect]
    params = k.draw(rng)
    machine_coords = condition in ("machine", "kit")
    offset = (tuple(float(v) for v in rng.uniform([-500, -500, 0], [500, 500, 500]))
              if machine_coords else tuple(float(v) for v in rng.uniform(-5.0, 5.0, 3)))
    return IndependentCase(index=index, effect=effect, params=params, condition=condition,
                           seed=int(rng.integers(2 ** 31)),
                           period_s=float(rng.choice([2e-3, 4e-3, 6e-3, 8e-3, 12e-3])),
                           offset_mm=offset,
                           window=(float(rng.uniform(0.2, 0.35)), float(rng.uniform(0.65, 0.8))),
                           g64=k.g64)


# ---------------------------------------------------------------------------------------------
# The truth: nominal machine + planted effect, planned by the plain planner
# ---------------------------------------------------------------------------------------------

def start_machine(nominal: MachineSpec, case: IndependentCase) -> MachineSpec:
    """The machine the diagnosis starts from: the nominal one (G64 as the reset mode for a
    corner-velocity case, whose corners only exist in continuous path)."""
    return nominal.with_ncu(reset_path_mode=64) if case.g64 else nominal


def truth_machine(nominal: MachineSpec, case: IndependentCase) -> tuple[PlainMachine, int]:
    """The plain planner's machine with the case's effect planted, and the reset path mode
    the program is interpreted with. The planted values follow the effects' physical
    statements (module docstring of ``ncsim.gap.effects``), written here again."""
    ncu = nominal.ncu
    v = np.array(nominal.max_velocity_mm_s)
    a = np.array(nominal.max_accel_mm_s2)
    jump = (np.array(nominal.max_accel_ovl_factor) - 1.0) * a * ncu.ipo_cycle_s   # MD32310
    pm = PlainMachine(v_max_mm_s=tuple(v), a_max_mm_s2=tuple(a), ipo_cycle_s=ncu.ipo_cycle_s,
                      jump_mm_s=tuple(jump), continuous_path=case.g64,
                      settle_s=ncu.exact_stop_fine_settle_s,
                      g0_g1_window=ncu.exact_pos_mode_g0_to_g1 in (1, 2))
    p = case.params
    reset = 64 if case.g64 else ncu.reset_path_mode
    if case.effect == "rapid_override":
        pm = replace(pm, rapid_override=p["rapid_override_percent"] / 100.0)
    elif case.effect == "feed_override":
        pm = replace(pm, feed_override=p["feed_override_percent"] / 100.0)
    elif case.effect == "axis_velocity":
        pm = replace(pm, v_max_mm_s=tuple(v / v[0] * m_min_to_mm_s(p["axis_velocity_m_min"])))
    elif case.effect == "axis_accel":
        ax = m_s2_to_mm_s2(p["xy_accel_m_s2"])
        pm = replace(pm, a_max_mm_s2=(ax, ax * a[1] / a[0], m_s2_to_mm_s2(p["z_accel_m_s2"])))
    elif case.effect == "reset_mode":
        reset = 64
        pm = replace(pm, continuous_path=True, settle_s=ms_to_s(p["settle_ms"]), g0_g1_window=True)
    elif case.effect == "corner_jump":
        pm = replace(pm, jump_mm_s=tuple(p["corner_jump_mm_s"] * jump / jump[0]))
    return pm, reset


def moving_average_record(t_raw_s: np.ndarray, pos_raw_mm: np.ndarray, n: int):
    """What a recorder that averages ``n`` raw samples and keeps one in ``n`` writes: the mean
    of each block of ``n`` consecutive samples, stamped at the block's mean time."""
    m = (len(t_raw_s) // n) * n
    t = np.asarray(t_raw_s[:m]).reshape(-1, n).mean(axis=1)
    p = np.asarray(pos_raw_mm[:m]).reshape(-1, n, 3).mean(axis=1)
    return t, p


def pass_window_s(motion, path) -> tuple[float, float]:
    """(start, end) of the middle pass's recording: the middle of its G0 plunge to the middle
    of its last G1."""
    plunges = [k for k in range(path.n) if path.rapid[k] and abs(path.end_mm[k][2] - path.start_mm[k][2]) > 0
               and path.end_mm[k][2] < path.start_mm[k][2]]
    k0 = plunges[1]
    k1 = plunges[2] - 1
    t0 = motion.t_start_s[k0] + 0.5 * motion.duration_s[k0]
    t1 = motion.t_start_s[k1] + 0.5 * motion.duration_s[k1]
    return float(t0), float(t1)


def independent_trace(program: str, nominal: MachineSpec, case: IndependentCase) -> MeasuredTrace:
    """The recorded commanded positions of a case (module docstring)."""
    pm, reset = truth_machine(nominal, case)
    path = interpret_file(program, nominal.with_ncu(reset_path_mode=reset)).path
    motion = plan_plain(path, pm)
    rng = np.random.default_rng(case.seed)
    total = motion.total_s
    t_raw = np.arange(-LEAD_S, total + LEAD_S, RAW_PERIOD_S) + rng.uniform(0.0, RAW_PERIOD_S)
    if case.condition in ("passes", "kit"):
        lo, hi = pass_window_s(motion, path)
    elif case.condition == "partial":
        lo, hi = case.window[0] * total, case.window[1] * total
    else:
        lo, hi = -LEAD_S, total + LEAD_S
    if case.effect == "recorder":
        n = int(case.params["samples"])
    elif case.condition in ("50hz", "kit"):
        n = KIT_AVERAGE
    else:
        n = 0
    pos_raw = sample_plain(motion, t_raw)
    if n:
        t, pos = moving_average_record(t_raw, pos_raw, n)
    else:
        step = max(1, int(round(case.period_s / RAW_PERIOD_S)))
        t, pos = t_raw[::step], pos_raw[::step]
    keep = (t >= lo) & (t <= hi)
    t, pos = t[keep], pos[keep]
    q = um_to_mm(RESOLUTION_UM)
    pos = np.round((pos + np.asarray(case.offset_mm)) / q) * q
    # the recording holds the commanded positions (as an 840D trace of DES_POS): they are
    # also its "actual" column, there being no servo in this truth
    return MeasuredTrace(t_s=t + 100.0, pos_mm=pos, cmd_pos_mm=pos,
                         source=f"<independent case {case.index}: {case.effect}, {case.condition}>")
