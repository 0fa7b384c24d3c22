"""What a machine allows: its derived limits and the steady feed on a circle of radius R.

``ncsim explain`` prints this; the numbers are the paper's static analysis (§3.1, §5.2):

* ``J_tcurv = J_curv * r_jct`` (eq. 10), the NCU's tangential path jerk;
* per radius R, in the XY plane (G17), the steady feed each limit allows::

      V_Jtcurv = (J_tcurv R^2)^(1/3)                         eq. 11 (one value)
      V_Jt     = (J_t(a) R^2)^(1/3),  J_t from eq. 9          eq. 4  (min and max over a)
      V_An     = sqrt(R A_n(a)),      A_n from eq. 8          eq. 2  (min and max over a)
      V_t      = V_t(a)                                       eq. 7  (min and max over a)
      V_tcy    = 2 pi R / t_cy                                eq. 6  (one full circle)
      V_fr     = sqrt(R J_t dt)                               eq. 13 (line -> arc of radius R,
                                                                      weakest tangent)

  where ``a`` is the direction angle of the path tangent (kinematics module docstring);
* the set point ncsim plans on a full circle started along +X with no programmed feed limit
  (``limits.path_limits``: eq. 12 with the axis limits at alpha_c and the guards), and the
  limit that sets it.

Everything here is computed from the machine file; nothing is simulated in time.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ncsim.plan import kinematics as kin
from ncsim.plan.limits import path_limits
from ncsim.machine import MachineSpec
from ncsim.motion import FULL_MODEL, LIMIT_LABELS
from ncsim.path import PathBuilder
from ncsim.units import mm_s_to_mm_min

DEFAULT_RADII_MM = (1.0, 2.5, 5.0, 10.0, 20.0, 30.0, 50.0, 100.0)
DIRECTION_SAMPLES = 3600        # tangent directions over a turn (0.1 deg steps) for min/max


@dataclass(frozen=True, slots=True)
class RadiusLimits:
    """Steady feeds (mm/min) on a circle of radius ``radius_mm`` in the XY plane."""

    radius_mm: float
    v_jtcurv_mm_min: float       # eq. 11
    v_jt_min_mm_min: float       # eq. 4 with eq. 9, min over the direction
    v_jt_max_mm_min: float
    v_an_min_mm_min: float       # eq. 2 with eq. 8
    v_an_max_mm_min: float
    v_t_min_mm_min: float        # eq. 7
    v_t_max_mm_min: float
    v_tcy_mm_min: float          # eq. 6, one full circle in one block
    v_fr_line_mm_min: float      # eq. 13, a line entering the arc tangentially (weakest tangent)
    setpoint_mm_min: float       # ncsim's set point (eq. 12 + guards) on a full circle
    binding: str                # the limit that sets it (motion.Limit label)

    def as_dict(self) -> dict:
        return {f: getattr(self, f) for f in self.__slots__}


def direction_extremes(machine: MachineSpec, samples: int = DIRECTION_SAMPLES) -> dict[str, tuple[float, float]]:
    """Min and max over the tangent direction in XY of J_t (eq. 9, mm/s^3), A_n (eq. 8,
    mm/s^2) and V_t (eq. 7, mm/s)."""
    alpha = np.linspace(0.0, 2.0 * np.pi, samples, endpoint=False)
    t = kin.tangent_from_angle(alpha)
    n = kin.normal_from_angle(alpha)
    j_t = kin.axis_tangential_jerk_limit_mm_s3(t, machine.max_jerk_mm_s3)
    a_n = kin.axis_normal_accel_limit_mm_s2(n, machine.max_accel_mm_s2)
    v_t = kin.axis_velocity_feed_limit_mm_s(t, machine.max_velocity_mm_s)
    return {"jerk_t_mm_s3": (float(j_t.min()), float(j_t.max())),
            "accel_n_mm_s2": (float(a_n.min()), float(a_n.max())),
            "velocity_t_mm_s": (float(v_t.min()), float(v_t.max()))}


def full_circle_setpoints(machine: MachineSpec, radii_mm) -> tuple[np.ndarray, np.ndarray]:
    """Set point (mm/s) and its limit label of a full G17 circle of each radius, started at
    (0, -R) along +X and counter-clockwise, with no programmed feed (as the paper's tests)."""
    b = PathBuilder(("<explain>",))
    for i, r in enumerate(radii_mm):
        start = (0.0, -float(r), 0.0)
        b.add_arc(start, start, (0.0, 0.0, 0.0), (0.0, 0.0, 1.0), float(r), 2.0 * np.pi,
                  line=i + 1, feed_mm_s=np.inf, cp_mode=64)
    lim = path_limits(b.build(), machine, FULL_MODEL)
    labels = np.asarray(LIMIT_LABELS, dtype=object)[lim.cap_limit.astype(np.int64)]
    return np.asarray(lim.cap_mm_s), labels


def radius_table(machine: MachineSpec, radii_mm=DEFAULT_RADII_MM) -> list[RadiusLimits]:
    """One :class:`RadiusLimits` per radius (module docstring)."""
    radii = np.asarray(radii_mm, dtype=np.float64)
    ext = direction_extremes(machine)
    j_min, j_max = ext["jerk_t_mm_s3"]
    a_min, a_max = ext["accel_n_mm_s2"]
    v_min, v_max = ext["velocity_t_mm_s"]
    ncu = machine.ncu
    j_tcurv = kin.ncu_tangential_jerk_mm_s3(ncu.curvilinear_jerk_mm_s3, ncu.tangential_jerk_share)
    setpoint, binding = full_circle_setpoints(machine, radii)
    m = mm_s_to_mm_min
    rows = []
    for k, r in enumerate(radii):
        rows.append(RadiusLimits(
            radius_mm=float(r),
            v_jtcurv_mm_min=float(m(kin.ncu_path_jerk_feed_limit_mm_s(j_tcurv, r))),
            v_jt_min_mm_min=float(m(kin.tangential_jerk_feed_limit_mm_s(j_min, r))),
            v_jt_max_mm_min=float(m(kin.tangential_jerk_feed_limit_mm_s(j_max, r))),
            v_an_min_mm_min=float(m(kin.normal_accel_feed_limit_mm_s(r, a_min))),
            v_an_max_mm_min=float(m(kin.normal_accel_feed_limit_mm_s(r, a_max))),
            v_t_min_mm_min=float(m(v_min)), v_t_max_mm_min=float(m(v_max)),
            v_tcy_mm_min=float(m(kin.cycle_time_feed_limit_mm_s(2.0 * np.pi * r, ncu.ipo_cycle_s))),
            v_fr_line_mm_min=float(m(kin.transition_feed_mm_s(j_min, ncu.transition_time_s, 1.0 / r))),
            setpoint_mm_min=float(m(setpoint[k])), binding=str(binding[k])))
    return rows
