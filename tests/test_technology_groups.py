"""Technology-group dynamics (G group 59: DYNNORM, DYNPOS, DYNROUGH, DYNSEMIFIN, DYNFINISH,
DYNPREC): per-group axis limits in the machine file's ``[dynamics]`` (MD32300/MD32431 arrays),
selected by the DYN... words and by CYCLE832's machining type. The times are checked against the
closed forms of a long straight line from rest to rest: at feed v, acceleration A and jerk J,
t = L/v + v/A + A/J (BRISK: J = A/t_IPO, so A/J = t_IPO) when the ramps reach A, and
t = L/v + 2 sqrt(v/J) when they do not (v < A^2/J)."""
from __future__ import annotations

import math
import tomllib
from importlib import resources

import pytest

from ncsim.errors import MachineSpecError
from ncsim.machine import dump_machine_toml, machine_from_dict
from ncsim.pipeline import simulate

L_MM, V_MM_S, T_IPO_S = 500.0, 100.0, 0.012          # G1 X500 F6000 on the MIKRON (12 ms IPO)
PROGRAM = "G90 G94 G0 X0 Y0 Z0\n{select}\nCOMPOF\nG1 X500 F6000\nM30\n"


def mikron_data(**dynamics) -> dict:
    data = tomllib.loads((resources.files("ncsim.machines") / "mikron.toml").read_text())
    if dynamics:
        data["dynamics"] = dynamics
    return data


def run(data: dict, select: str):
    return simulate("t.mpf", machine_from_dict(data), text=PROGRAM.format(select=select))


def group_warnings(sim) -> list[str]:
    return [w.message for w in sim.interpreted.warnings if "technology group" in w.message]


def test_cycle832_finishing_runs_with_the_dynfinish_acceleration():
    """BRISK finishing (the [cycle832.finish] accel mode) with DYNFINISH's X acceleration
    0.5 m/s^2 against the [axes] 2.5 m/s^2 of DYNNORM."""
    data = mikron_data(DYNFINISH={"X": {"max_accel_m_s2": 0.5}})
    data["cycle832"]["finish"]["accel_mode"] = "BRISK"
    finish = run(data, "CYCLE832(0.01,_FINISH,1)")
    assert group_warnings(finish) == [] and not finish.interpreted.approximate
    assert set(finish.interpreted.path.dyn_group) == {4}               # DYNFINISH
    assert finish.cycle_time_s == pytest.approx(L_MM / V_MM_S + V_MM_S / 500.0 + T_IPO_S, rel=1e-6)
    normal = run(data, "G642 BRISK")                                   # DYNNORM: [axes]
    assert normal.cycle_time_s == pytest.approx(L_MM / V_MM_S + V_MM_S / 2500.0 + T_IPO_S,
                                                rel=1e-6)


def test_a_dyn_word_selects_its_groups_jerk():
    """SOFT with DYNROUGH's X jerk 2 m/s^3 (below J_tcurv = 6 m/s^3): v = 100 mm/s is below
    A^2/J = 125 mm/s, so each ramp is two jerk phases, 2 sqrt(v/J) s for both ramps together."""
    data = mikron_data(DYNROUGH={"X": {"max_jerk_m_s3": 2.0, "max_accel_m_s2": 0.5}})
    rough = run(data, "G64 SOFT DYNROUGH")
    assert group_warnings(rough) == []
    assert rough.cycle_time_s == pytest.approx(L_MM / V_MM_S + 2 * math.sqrt(V_MM_S / 2000.0),
                                               rel=1e-6)


def test_one_set_for_all_groups_is_an_explicit_key_and_silences_the_warning():
    plain = run(mikron_data(), "CYCLE832(0.01,_FINISH,1)")
    assert len(group_warnings(plain)) == 1 and plain.interpreted.approximate
    assert "CYCLE832 selects DYNFINISH" in group_warnings(plain)[0]
    same = run(mikron_data(same_for_all_groups=True), "CYCLE832(0.01,_FINISH,1)")
    assert group_warnings(same) == [] and not same.interpreted.approximate
    assert same.cycle_time_s == plain.cycle_time_s


def test_a_group_the_file_does_not_give_is_warned_and_runs_with_the_axes():
    data = mikron_data(DYNFINISH={"X": {"max_accel_m_s2": 0.5}})
    r = run(data, "G642 BRISK DYNROUGH")
    assert [m.split(":")[0] for m in group_warnings(r)] == ["DYNROUGH"]
    assert r.cycle_time_s == pytest.approx(L_MM / V_MM_S + V_MM_S / 2500.0 + T_IPO_S, rel=1e-6)


def test_dynamics_table_errors_and_round_trip():
    with pytest.raises(MachineSpecError, match="dynamics.DYNNORM: unknown key"):
        machine_from_dict(mikron_data(DYNNORM={"X": {"max_accel_m_s2": 1.0}}))
    with pytest.raises(MachineSpecError, match="dynamics.DYNFINISH: same_for_all_groups = true"):
        machine_from_dict(mikron_data(same_for_all_groups=True,
                                      DYNFINISH={"X": {"max_accel_m_s2": 1.0}}))
    with pytest.raises(MachineSpecError, match="dynamics.DYNFINISH.X.max_accel_m_s2"):
        machine_from_dict(mikron_data(DYNFINISH={"X": {"max_accel_m_s2": -1.0}}))
    m = machine_from_dict(mikron_data(DYNFINISH={"Y": {"max_jerk_m_s3": 2.0}}))
    again = machine_from_dict(tomllib.loads(dump_machine_toml(m)))
    assert (again.group_limits() == m.group_limits()).all()
    assert again.defines_group(4) and not again.defines_group(3)
