"""Plausibility of a machine file beyond each key's own range: what real machines have
(a value outside it is accepted with a warning naming the unit it looks like) and the limits the
planner derives from several keys together (an error: each key may lie in its range while their
product leaves the ramps nothing to compute with)."""
from __future__ import annotations

from typing import Any

from ncsim.config import Problems, is_number
from ncsim.units import mm_s2_to_m_s2, mm_s3_to_m_s3, s_to_ms

#: the least acceleration and jerk the planner may derive from several keys (a share of an
#: axis value, :func:`derived_limits`): a thousandth of an axis's least. Below it no machine
#: moves (at 1e-6 m/s^2 a feed of 1 m/min takes 4.6 hours to reach); far below it the ramp
#: formulas of eq. 16 underflow (a jerk of 1e-300 m/s^3 times a feed step is 0)
MIN_DERIVED_ACCEL_M_S2 = 1e-6
MIN_DERIVED_JERK_M_S3 = 1e-6

#: key -> (usual low, usual high, unit, [(unit it may be in, factor to the key's unit)]):
#: values of real machine tools (840D machine data defaults and manufacturers' data); outside
#: them a value is accepted with a warning that names the unit it looks like
_USUAL: dict[str, tuple[float, float, str, tuple[tuple[str, float], ...]]] = {
    "max_velocity_m_min": (0.5, 300.0, "m/min", (("mm/min", 1e-3), ("m/s", 60.0))),
    "max_accel_m_s2": (0.05, 100.0, "m/s^2", (("mm/s^2", 1e-3),)),
    "max_jerk_m_s3": (0.5, 1e5, "m/s^3", (("mm/s^3", 1e-3),)),
    "curvilinear_jerk_m_s3": (0.5, 1e5, "m/s^3", (("mm/s^3", 1e-3),)),
    "position_gain_1_s": (5.0, 300.0, "1/s", (("(m/min)/mm as MD32200 is entered", 1000.0 / 60.0),)),
    "ipo_cycle_ms": (0.25, 50.0, "ms", (("s", 1e3), ("us", 1e-3))),
    "transition_time_ms": (0.25, 200.0, "ms", (("s", 1e3), ("us", 1e-3))),
    "exact_stop_fine_settle_ms": (0.0, 1000.0, "ms", (("us", 1e-3),)),
    "exact_stop_coarse_settle_ms": (0.0, 1000.0, "ms", (("us", 1e-3),)),
}
#: a jerk that reaches the axis acceleration within this share of the IPO cycle acts on no
#: interpolation cycle: most likely 1000x too large (mm/s^3 in an m/s^3 key)
_JERK_RAMP_MIN_CYCLES = 0.05
#: one jerk of a machine (axes, path) this many times off all the others: likely in another
#: unit (real machines' axis jerks differ by 10x or so, e.g. the paper's Table 1)
_JERK_SPREAD = 100.0


def derived_limits(c: Problems, least_accel_mm_s2: float, ncu: dict[str, Any],
                   ncu_defaults: dict[str, Any]) -> None:
    """The jerk and accelerations the planner derives from several keys, each at least
    ``MIN_DERIVED_JERK_M_S3`` / ``MIN_DERIVED_ACCEL_M_S2``: each key may lie in its range while
    their product leaves the ramps nothing (a tangential jerk share of 1e-300, an acceleration
    of 0 that no ramp reaches a feed with). Noted on the key that makes the value small."""
    j_tcurv = mm_s3_to_m_s3(ncu["curvilinear_jerk_mm_s3"] * ncu["tangential_jerk_share"])
    if j_tcurv < MIN_DERIVED_JERK_M_S3:
        c.add("ncu.tangential_jerk_share",
              f"gives J_tcurv = curvilinear_jerk_m_s3 x tangential_jerk_share = {j_tcurv:.3g} "
              f"m/s^3 (paper eq. 10), below {MIN_DERIVED_JERK_M_S3:g} m/s^3: the NCU could not "
              f"ramp the path feed")
    a_min = mm_s2_to_m_s2(least_accel_mm_s2)
    normal = _ncu_value(ncu, ncu_defaults, "normal_accel_share")
    tangential = (1.0 - normal[0]) * a_min        # left on an arc at its set point (eq. 1)
    if tangential < MIN_DERIVED_ACCEL_M_S2:
        c.add("ncu.normal_accel_share",
              f"{normal[1]} leaves (1 - share) x {a_min:g} m/s^2 = {tangential:.3g} m/s^2 of the "
              f"weakest axis's acceleration to the feed ramps on an arc at its set point "
              f"(eq. 1), below {MIN_DERIVED_ACCEL_M_S2:g} m/s^2")
        return
    reduction = ncu.get("drive_accel_reduction_ratio", ncu_defaults["drive_accel_reduction_ratio"])
    drive = (1.0 - reduction) * tangential
    if drive < MIN_DERIVED_ACCEL_M_S2:
        c.add("ncu.drive_accel_reduction_ratio",
              f"DRIVE keeps (1 - {reduction:g}) of the acceleration at the maximum velocity "
              f"(MD35230, the knee-shaped characteristic of 840D B2): {drive:.3g} m/s^2 of the "
              f"weakest axis's on an arc at its set point, below {MIN_DERIVED_ACCEL_M_S2:g} "
              f"m/s^2: no ramp would reach that velocity")


def _ncu_value(ncu: dict[str, Any], defaults: dict[str, Any], key: str) -> tuple[float, str]:
    """``(value, how to name it)`` of an [ncu] key, its default when the file has none."""
    if key in ncu:
        return ncu[key], f"{ncu[key]:g}"
    return defaults[key], f"the default {defaults[key]:g}"


def unusual_values(c: Problems, tables: dict[str, dict]) -> None:
    """Warn about valid values outside the usual range of real machines (``_USUAL``), naming
    the unit they look like; and about an axis jerk that reaches the axis acceleration within
    a fraction of an interpolation cycle (1000x too large, e.g. mm/s^3)."""
    for prefix, table in tables.items():
        for key, value in table.items():
            if key not in _USUAL or not is_number(value):
                continue
            lo, hi, unit, others = _USUAL[key]
            if lo <= value <= hi:
                continue
            guesses = [f"in {name}? that is {value * factor:.4g} {unit}" for name, factor in others
                       if lo <= value * factor <= hi]
            c.warn(f"{prefix}.{key}", f"{value:g} {unit} is outside the usual {lo:g}..{hi:g} "
                   f"{unit}" + (f" ({'; '.join(guesses)})" if guesses else ""))
    _unusual_jerks(c, tables)


def _unusual_jerks(c: Problems, tables: dict[str, dict]) -> None:
    """A jerk 1000x off (mm/s^3 in an m/s^3 key) can still lie in the usual range, so two more
    signs are looked for: one jerk ``_JERK_SPREAD`` times above or below all the others (the
    axes' and the path's, MD32431 and J_curv), and an axis jerk that reaches the axis
    acceleration within ``_JERK_RAMP_MIN_CYCLES`` of an interpolation cycle (it would limit
    nothing the NC interpolates)."""
    jerks = {f"{p}.max_jerk_m_s3": t.get("max_jerk_m_s3") for p, t in tables.items()
             if p.startswith("axes.")}
    jerks["ncu.curvilinear_jerk_m_s3"] = tables["ncu"].get("curvilinear_jerk_m_s3")
    jerks = {k: float(v) for k, v in jerks.items() if is_number(v) and v > 0}
    flagged = {w.key for w in c.warnings}     # one warning a key
    for key, value in jerks.items():
        others = [v for k, v in jerks.items() if k != key]
        if len(others) < 2 or key in flagged:
            continue
        if value >= _JERK_SPREAD * max(others):
            flagged.add(key)
            c.warn(key, f"{value:g} m/s^3 is over {_JERK_SPREAD:g} times every other jerk of the "
                   f"machine (at most {max(others):g} m/s^3; in mm/s^3? that is "
                   f"{value * 1e-3:.4g} m/s^3)")
        elif value * _JERK_SPREAD <= min(others):
            flagged.add(key)
            c.warn(key, f"{value:g} m/s^3 is under 1/{_JERK_SPREAD:g} of every other jerk of the "
                   f"machine (at least {min(others):g} m/s^3; 1000 times too small?)")
    ipo_ms = tables["ncu"].get("ipo_cycle_ms")
    for prefix in (p for p in tables if p.startswith("axes.")):
        key = f"{prefix}.max_jerk_m_s3"
        accel = tables[prefix].get("max_accel_m_s2")
        if key in flagged or key not in jerks or not (is_number(ipo_ms) and is_number(accel)):
            continue
        ramp_ms = s_to_ms(accel / jerks[key])
        if ramp_ms < _JERK_RAMP_MIN_CYCLES * ipo_ms:
            c.warn(key, f"{jerks[key]:g} m/s^3 reaches max_accel_m_s2 = {accel:g} in "
                   f"{ramp_ms:.2g} ms, a small fraction of the interpolation cycle ({ipo_ms:g} ms): "
                   f"it would limit nothing (in mm/s^3? that is {jerks[key] * 1e-3:.4g} m/s^3)")
