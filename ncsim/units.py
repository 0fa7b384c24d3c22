"""The only unit conversions in ncsim.

Inside ncsim every length is in mm, time in s, angle in rad; so velocities are mm/s,
accelerations mm/s^2 and jerks mm/s^3. Names carry the unit as a suffix
(``feed_mm_s``, ``jerk_mm_s3``, ``t_s``). Programs (F in mm/min under G94, inches under
G70/G700), machine files (m/min, m/s^2, m/s^3, ms), measured data (um, ms, m/min, ...) and
CLI output convert here, at the edge. Some outputs keep a unit of their own because people
read them so: contour errors in um, lags and time errors in ms (the unit is in the name:
``contour_rms_um``, ``lag_ms``).
"""
from __future__ import annotations

import math

MM_PER_INCH = 25.4
MM_PER_M = 1000.0
UM_PER_MM = 1000.0
NM_PER_MM = 1e6
S_PER_MIN = 60.0
MS_PER_S = 1000.0
US_PER_S = 1e6
DEG_PER_RAD = 180.0 / math.pi

#: quantity -> unit name -> factor from that unit to the internal one (s, mm, mm/s, mm/s^2)
FACTORS: dict[str, dict[str, float]] = {
    "time": {"s": 1.0, "ms": 1.0 / MS_PER_S, "us": 1.0 / US_PER_S, "min": S_PER_MIN},
    "length": {"mm": 1.0, "um": 1.0 / UM_PER_MM, "m": MM_PER_M, "in": MM_PER_INCH,
               "nm": 1.0 / NM_PER_MM},
    "velocity": {"mm/s": 1.0, "mm/min": 1.0 / S_PER_MIN, "m/min": MM_PER_M / S_PER_MIN,
                 "m/s": MM_PER_M, "um/s": 1.0 / UM_PER_MM, "in/min": MM_PER_INCH / S_PER_MIN},
    "acceleration": {"mm/s2": 1.0, "m/s2": MM_PER_M, "um/s2": 1.0 / UM_PER_MM},
    "jerk": {"mm/s3": 1.0, "m/s3": MM_PER_M},
}


def mm_min_to_mm_s(value_mm_min):
    return value_mm_min / S_PER_MIN


def mm_s_to_mm_min(value_mm_s):
    return value_mm_s * S_PER_MIN


def m_min_to_mm_s(value_m_min):
    return value_m_min * MM_PER_M / S_PER_MIN


def mm_s_to_m_min(value_mm_s):
    return value_mm_s * S_PER_MIN / MM_PER_M


def m_s2_to_mm_s2(value_m_s2):
    return value_m_s2 * MM_PER_M


def mm_s2_to_m_s2(value_mm_s2):
    return value_mm_s2 / MM_PER_M


def m_s3_to_mm_s3(value_m_s3):
    return value_m_s3 * MM_PER_M


def mm_s3_to_m_s3(value_mm_s3):
    return value_mm_s3 / MM_PER_M


def ms_to_s(value_ms):
    return value_ms / 1000.0


def s_to_ms(value_s):
    return value_s * 1000.0


def um_to_mm(value_um):
    """Noise, encoder increments and contour tolerances are given in um."""
    return value_um / UM_PER_MM


def mm_to_um(value_mm):
    """Contour errors and ISO 230-4 deviations are reported in um."""
    return value_mm * UM_PER_MM


def um_per_m_s2_to_s2(value_um_per_m_s2):
    """A compliance in um per (m/s^2), as people quote it, to mm per (mm/s^2) = s^2."""
    return value_um_per_m_s2 / (UM_PER_MM * MM_PER_M)


def s2_to_um_per_m_s2(value_s2):
    """A compliance in mm per (mm/s^2) = s^2 to um per (m/s^2)."""
    return value_s2 * (UM_PER_MM * MM_PER_M)


#: feed units an output can be printed in (``--feed-unit``); mm/min is the default everywhere
FEED_UNITS = ("mm/min", "m/min", "mm/s", "in/min")


def feed_from_mm_s(value_mm_s, unit: str = "mm/min"):
    """A feed in mm/s to ``unit`` (one of ``FEED_UNITS``)."""
    if unit not in FEED_UNITS:
        raise ValueError(f"unknown feed unit {unit!r} (use {', '.join(FEED_UNITS)})")
    return value_mm_s / FACTORS["velocity"][unit]


def deg_to_rad(value_deg):
    """Angles in files and NC words (CRIT_SPLINE_ANGLE, OTOL) are in degrees."""
    return value_deg / DEG_PER_RAD


def rad_to_deg(value_rad):
    return value_rad * DEG_PER_RAD


def percent_to_share(value_percent):
    """An override or share in percent (as on the operator panel) to a fraction."""
    return value_percent / 100.0


def share_to_percent(value_share):
    """A fraction to percent."""
    return value_share * 100.0
