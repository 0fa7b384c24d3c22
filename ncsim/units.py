"""The only unit conversions in ncsim.

Inside ncsim every length is in mm, time in s, angle in rad; so velocities are mm/s,
accelerations mm/s^2 and jerks mm/s^3. Names carry the unit as a suffix
(``feed_mm_s``, ``jerk_mm_s3``, ``t_s``). Programs (F in mm/min under G94, inches under
G70/G700), machine files (m/min, m/s^2, m/s^3, ms) and CLI output convert here, at the edge.
"""
from __future__ import annotations

MM_PER_INCH = 25.4
MM_PER_M = 1000.0
S_PER_MIN = 60.0


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
