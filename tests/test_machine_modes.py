"""Machine-file settings that real recordings differ by: the group-10 reset value (MD20150),
the stop window at G0<->G1 changes (MD20552) and the operator-panel overrides. Expected values
are hand computations from the machine file (MIKRON: V_max 30 m/min = 500 mm/s on every axis,
fine settle 24 ms, coarse settle 12 ms)."""
from __future__ import annotations

import math

import pytest

from ncsim.errors import MachineSpecError
from ncsim.machine import dump_machine_toml, load_machine, machine_from_dict
from ncsim.motion import Limit
from ncsim.nc.interpret import interpret_text
from ncsim.plan.limits import path_limits

PROGRAM = """G90 G17 G94
G0 X0 Y0 Z10
G0 Z0
G1 X30 F600
G1 Y20
G9 X40
G1 X50
M30
"""


@pytest.fixture(scope="module")
def mikron():
    return load_machine("mikron")


def _limits(machine, text=PROGRAM):
    path = interpret_text(text, "<t>", machine).path
    return path, path_limits(path, machine)


def test_reset_path_mode_is_the_start_of_group_10(mikron):
    path, lim = _limits(mikron)
    assert set(path.cp_mode) == {60} and path.exact_stop.all()          # delivery state G60
    g64 = mikron.with_ncu(reset_path_mode=64)
    path, lim = _limits(g64)
    assert set(path.cp_mode) == {64}
    # only the G9 block (X40) still ends in an exact stop; the 90 deg corner is a G64 corner
    assert list(path.exact_stop) == [False, False, False, False, True, False]
    assert lim.junction_limit[4] == Limit.CORNER
    # min_i f A_i t_cy / |dt_i|: X 2.5 m/s^2, Y 3 m/s^2, each axis jumps by the whole feed
    assert math.isclose(lim.junction_cap_mm_s[4], min(2500.0, 3000.0) * 0.012 / 1.0)
    assert lim.junction_limit[5] == Limit.EXACT_STOP
    # a programmed G60 still wins over the reset value
    path, _ = _limits(g64, "G0 X5 Y0\nG60 G1 X10 F600\nG1 Y10\nM30\n")
    assert list(path.cp_mode) == [64, 60, 60] and list(path.exact_stop) == [False, True, True]


def test_g0_to_g1_settle_follows_md20552(mikron):
    g64 = mikron.with_ncu(reset_path_mode=64)
    _, lim = _limits(g64)
    g0g1 = 2  # junction between G0 Z0 and G1 X30
    assert lim.junction_limit[g0g1] == Limit.AUX_STOP and lim.junction_dwell_s[g0g1] == 0.0
    for mode, settle in ((1, 0.024), (2, 0.012), (3, 0.0), (0, 0.0)):
        _, lim = _limits(g64.with_ncu(exact_pos_mode_g0_to_g1=mode))
        assert math.isclose(lim.junction_dwell_s[g0g1], settle, abs_tol=1e-15), mode
        assert lim.junction_dwell_s[5] == pytest.approx(0.024)           # the G9 stop: fine window
    # under G60 the G0 block's own exact stop already waits: no second settle
    _, lim = _limits(mikron.with_ncu(exact_pos_mode_g0_to_g1=1))
    assert lim.junction_dwell_s[g0g1] == pytest.approx(0.024)


def test_overrides_scale_g0_and_f(mikron):
    _, lim = _limits(mikron.with_ncu(rapid_override=0.1, feed_override=0.5))
    # G0 Z0: axis velocity 500 mm/s x 10 %; G1 F600 = 10 mm/s x 50 %
    assert lim.cap_mm_s[1] == pytest.approx(50.0) and lim.cap_limit[1] == Limit.PROGRAMMED
    assert lim.cap_mm_s[2] == pytest.approx(5.0)
    # a diagonal rapid: each axis may run 500 mm/s, so the path sqrt(2) x that, then 10 %
    _, diag = _limits(mikron.with_ncu(rapid_override=0.1), "G0 X10 Y10\nM30\n")
    assert diag.cap_mm_s[0] == pytest.approx(0.1 * 500.0 * math.sqrt(2.0))
    _, lim = _limits(mikron.with_ncu(rapid_override=1.0, feed_override=1.2))
    assert lim.cap_mm_s[1] == pytest.approx(500.0) and lim.cap_limit[1] == Limit.AXIS_VELOCITY
    assert lim.cap_mm_s[2] == pytest.approx(12.0)


def test_machine_file_keys_round_trip_and_reject_bad_values(mikron):
    m = mikron.with_ncu(reset_path_mode=64, exact_pos_mode_g0_to_g1=1, rapid_override=0.1,
                        feed_override=0.95, reset_accel_mode=0)     # 0: SOFT (group 21)
    import tomllib
    back = machine_from_dict(tomllib.loads(dump_machine_toml(m)))
    assert back.ncu == m.ncu
    data = tomllib.loads(dump_machine_toml(mikron))
    for key, value, words in (("reset_path_mode", "G61", "must be one of G60, G64"),
                              ("reset_path_mode", 64, "must be a string"),
                              ("reset_accel_mode", "SMOOTH", "must be one of BRISK, SOFT, DRIVE"),
                              ("exact_pos_mode_g0_to_g1", 4, "must be an integer from 0 to 3"),
                              ("rapid_override_percent", 0, "must be between 0.001 and 200 %"),
                              ("feed_override_percent", 250, "must be between 0.001 and 200 %")):
        bad = {**data, "ncu": {**data["ncu"], key: value}}
        with pytest.raises(MachineSpecError) as err:
            machine_from_dict(bad, "m.toml")
        assert f"m.toml: ncu.{key}: {words}" in str(err.value)
