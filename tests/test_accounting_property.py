"""The accounting identities of ``ncsim run`` hold for every machine file the validator accepts
(README "JSON summary")::

    cycle_time_s = ideal_time_s + lost_time_s + dwell_time_s
    cycle_time_s = moving_time_s + standstill_time_s

with no negative duration, no NaN or infinity anywhere in the summary and no numpy warning
(pytest turns RuntimeWarnings into errors). Machine files are drawn across the whole range of
every key as the validator states it (``machine._AXIS_KEYS``, ``machine._NCU_KEYS``: the ends
of each :class:`~ncsim.config.Range` included), on a few programs: plain lines, arcs and a
helix, G60/G9/G64 with a dwell and acceleration-mode changes, corner rounding (G641, G642,
G645) and the compressors (COMPCAD, COMPCURV), and G0/G1 changes under every
``exact_pos_mode_g0_to_g1`` (MD20552). A file the validator rejects must be one
:class:`~ncsim.errors.MachineSpecError` naming a key. The identities are the README's
definitions, not ncsim output; the truth is consistency of the accounting, not the times.
"""
from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from ncsim import machine as M
from ncsim.config import Range
from ncsim.errors import MachineSpecError
from ncsim.pipeline import simulate
from ncsim.report.summary import summary

PROGRAMS = {
    "plain": "G17 G90 G64 SOFT\nG1 X10 F3000\nY5\nX20 Y7 Z-0.5\nX0 Y0 Z-1 F500\nM30\n",
    "arcs": ("G17 G90 G64\nG1 X5 F6000\nG3 X5 Y0 I-5 J0\nG2 X0 Y5 I-5 J0 Z-2\nG3 X0 Y-5 CR=5\n"
             "G1 X0 Y0\nM30\n"),
    "g60_g64": ("G17 G90 G60 G601\nG1 X10 F3000\nG64 Y10\nX0 G9\nG4 F0.1\nY0 G60 G602\n"
                "BRISK X3\nDRIVE Y4 F20000\nSOFT G64 X0 Y0\nM30\n"),
    # the paper's bore (programs/bore_d25_f5984.mpf): rapids in and out around feed moves
    "g0_g1": ("G17 G90 G64 SOFT FFWON\nG0 X0 Y0 Z5\nG0 Z-9\nG1 X-1.5 Y-1 F5984\n"
              "G3 X0 Y-2.5 I1.5 J0\nG3 X0 Y-2.5 I0 J2.5\nG3 X1.5 Y-1 I0 J1.5\nG1 X0 Y0\n"
              "G0 Z5\nG1 X2 F1000\nG0 X0\nM30\n"),
    # the HSM modes (issue 16, item 5): corner rounding G641/G642/G645 with and without a
    # programmed tolerance, and the compressors on a raster of short lines at two feeds
    "hsm": ("G17 G90 G64 SOFT\nG642 CTOL=0.05\nG1 X10 F6000\nY5\nX0 Y10\nG645\nX10 Y12\n"
            "X0 Y15 F2000\nG641 ADIS=0.5\nX5 Y0\nG642\nX0 Y0 Z-1\nCOMPCAD\n"
            + "".join(f"X{0.5 * i:g} Y{0.02 * (i % 3):g}\n" for i in range(1, 13))
            + "COMPCURV\n" + "".join(f"X{6 - 0.5 * i:g} Y{0.4 + 0.03 * (i % 2):g} F{3000 + 500 * (i % 2)}\n"
                                       for i in range(1, 13))
            + "COMPOF\nG64\nX0 Y0\nM30\n"),
}


def in_range(rng: Range) -> st.SearchStrategy:
    """A value the range accepts: one of its two ends (the nearest float inside an open end:
    5e-324 for a share in (0, 1]), or, three times as often, one within, log-uniform over a
    range of positive values of more than two decades."""
    lo = float(np.nextafter(rng.lo, rng.hi)) if rng.lo_open else rng.lo
    hi = float(np.nextafter(rng.hi, rng.lo)) if rng.hi_open else rng.hi
    if rng.lo > 0 and hi / lo > 100:
        within = st.floats(math.log(lo), math.log(hi)).map(lambda x: min(max(math.exp(x), lo), hi))
    else:
        within = st.floats(lo, hi)
    return st.one_of(st.sampled_from([lo, hi]), within, within, within)


def table(keys) -> st.SearchStrategy:
    """A table of ``keys`` (the validator's key tuples): required keys always, the others or
    their default."""
    parts = {}
    for key, _field, required, check, convert in keys:
        if convert is int:
            value = st.sampled_from([1, 2, 7, 100, M.MAX_LOOKAHEAD_BLOCKS])
        elif isinstance(check, Range):
            value = in_range(check)
        else:
            continue
        parts[key] = value if required else st.one_of(st.none(), value)
    return st.fixed_dictionaries(parts).map(lambda d: {k: v for k, v in d.items() if v is not None})


def within_derived_limits(data: dict) -> dict:
    """``data`` with the keys that several keys limit together (README "Machine file": J_tcurv
    = J_curv r_jct, the tangential acceleration (1 - r_n) A_min an arc leaves and the part
    (1 - r_drive) of it DRIVE keeps are at least 1e-6 m/s^3 and m/s^2) moved onto the edge of
    what is accepted when drawn beyond it: a drawn file is then mostly accepted, and those
    edges are drawn often."""
    ncu = data["ncu"]
    a_min = min(t["max_accel_m_s2"] for t in data["axes"].values())
    edge = 1.0 + 1e-9                            # just inside, against rounding
    least_share = M.MIN_DERIVED_JERK_M_S3 / ncu["curvilinear_jerk_m_s3"] * edge
    if ncu["tangential_jerk_share"] < least_share:
        ncu["tangential_jerk_share"] = least_share
    most = 1.0 - M.MIN_DERIVED_ACCEL_M_S2 / a_min * edge
    if ncu.get("normal_accel_share", 0.75) > most:
        ncu["normal_accel_share"] = most
    left = (1.0 - ncu.get("normal_accel_share", 0.75)) * a_min
    most = 1.0 - M.MIN_DERIVED_ACCEL_M_S2 / left * edge
    if ncu.get("drive_accel_reduction_ratio", 0.0) > most:
        ncu["drive_accel_reduction_ratio"] = max(most, 0.0)
    return data


DRAWN = st.fixed_dictionaries({
    "machine": st.just({"name": "drawn"}),
    "axes": st.fixed_dictionaries({a: table(M._AXIS_KEYS) for a in M.AXIS_NAMES}),
    "ncu": st.tuples(table(M._NCU_KEYS), st.sampled_from(M.G0_TO_G1_MODES)).map(
        lambda t: {**t[0], "exact_pos_mode_g0_to_g1": t[1]}),
})
#: as drawn (the validator must reject what the kernels cannot compute), or moved onto the
#: edges of what several keys allow together, three times as often
MACHINES = st.one_of(DRAWN, *[DRAWN.map(within_derived_limits)] * 3)


def check_identities(s: dict, feed_override: float = 1.0) -> None:
    """The README's identities; with ``feed_override`` (a share), also that no feed block runs
    above its F times the override (840D V1 "feed override": rounding and compressed blocks
    included, issue 16)."""
    json.dumps(s, allow_nan=False)                      # no NaN or infinity anywhere
    cycle = s["cycle_time_s"]
    tol = 1e-9 * max(cycle, 1e-3)
    assert s["ideal_time_s"] + s["lost_time_s"] + s["dwell_time_s"] == pytest.approx(cycle, abs=tol)
    assert s["moving_time_s"] + s["standstill_time_s"] == pytest.approx(cycle, abs=tol)
    for key in ("ideal_time_s", "lost_time_s", "dwell_time_s", "moving_time_s",
                "standstill_time_s"):
        assert s[key] >= 0.0, key
    for row in s["lost_by_cause"]:
        assert row["time_lost_s"] >= 0.0 and row["settle_s"] >= 0.0, row
    end = 0.0
    for b in s["blocks_detail"]:
        assert b["duration_s"] >= 0.0 and b["time_lost_s"] >= 0.0, b
        assert b["t_start_s"] >= end - tol, b                  # blocks follow each other
        end = b["t_start_s"] + b["duration_s"]
        assert b["feed_setpoint_mm_min"] >= 0.0 and b["feed_max_mm_min"] >= 0.0, b
        if b["feed_programmed_mm_min"] is not None:                   # a feed block
            assert b["feed_max_mm_min"] <= b["feed_programmed_mm_min"] * feed_override * (1 + 1e-9), b
    assert end <= cycle + tol


@settings(max_examples=50, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(MACHINES)
def test_every_accepted_machine_file_keeps_the_accounting(data):
    try:
        spec = M.machine_from_dict(data, "drawn.toml")
    except MachineSpecError as exc:        # rejected: one line naming the key
        assert exc.key and "\n" not in exc.render()
        return
    for name, text in PROGRAMS.items():
        check_identities(summary(simulate(f"{name}.mpf", spec, text=text)), spec.ncu.feed_override)


@pytest.mark.parametrize("mode, settle_key", [(1, "exact_stop_fine_settle_s"),
                                              (2, "exact_stop_coarse_settle_s")])
def test_the_window_at_a_g0_g1_change_is_lost_to_exact_stop(shared, mode, settle_key):
    """``W3``: MD20552 = 1 (G601) or 2 (G602) makes the NC wait for the stop window at each
    G0/G1 change of the bore (G0 -> G1 after line 30, G1 -> G0 after line 80): two settles of
    the machine file's window time, lost to ``exact_stop`` as the settle of a G60 block is."""
    folder = shared / "data" / "fuzz-repro-s3"
    spec = M.load_machine(folder / "W3_machine_g0_g1_stop_window.toml").with_ncu(
        exact_pos_mode_g0_to_g1=mode)
    s = summary(simulate(folder / "bore.mpf", spec))
    check_identities(s)
    settle = 2 * getattr(spec.ncu, settle_key)
    assert s["standstill_time_s"] == pytest.approx(settle, rel=1e-12)
    exact = [r for r in s["lost_by_cause"] if r["cause"] == "exact_stop"]
    assert sum(r["settle_s"] for r in exact) == pytest.approx(settle, rel=1e-12)
    assert sum(r["time_lost_s"] for r in exact) == pytest.approx(settle, rel=1e-12)
