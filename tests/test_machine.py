"""Machine files: the paper's machine loads in internal units; every bad key is one clear error."""
from __future__ import annotations

import tomllib
from dataclasses import replace

import pytest
from click.testing import CliRunner

from ncsim.cli.main import cli
from ncsim.errors import MachineSpecError
from ncsim.machine import bundled_machines, dump_machine_toml, load_machine, machine_from_dict


def test_mikron_holds_the_papers_values_in_mm_and_s(mikron):
    # Table 1: 30 m/min, 2.5/3/2.1 m/s^2, 5/5/50 m/s^3; §5.2.4: J_curv 10 m/s^3, r_jct 60 %;
    # §5.3.2: 12 ms interpolation cycle and transition time
    assert list(mikron.max_velocity_mm_s) == pytest.approx([500.0] * 3)
    assert list(mikron.max_accel_mm_s2) == pytest.approx([2500.0, 3000.0, 2100.0])
    assert list(mikron.max_jerk_mm_s3) == pytest.approx([5000.0, 5000.0, 50000.0])
    assert mikron.ncu.tangential_jerk_mm_s3 == pytest.approx(6000.0)  # eq. 10
    assert mikron.ncu.ipo_cycle_s == pytest.approx(0.012)
    assert mikron.ncu.transition_time_s == pytest.approx(0.012)
    assert "mikron" in bundled_machines()


def mikron_dict():
    from importlib import resources

    return tomllib.loads((resources.files("ncsim.machines") / "mikron.toml").read_text())


@pytest.mark.parametrize("edit,key,message", [
    (lambda d: d["axes"]["X"].pop("max_jerk_m_s3"), "axes.X.max_jerk_m_s3", "missing key"),
    (lambda d: d["axes"]["Y"].update(max_accel_m_s2=-3.0), "axes.Y.max_accel_m_s2", "must be between 0.001 and 1e+06 m/s^2, got -3"),
    (lambda d: d["axes"]["Z"].update(max_velocity_m_min="fast"), "axes.Z.max_velocity_m_min", "must be a number"),
    (lambda d: d["ncu"].update(ipo_cycle_sec=12), "ncu.ipo_cycle_sec", "unknown key"),
    (lambda d: d["ncu"].update(lookahead_blocks=10.5), "ncu.lookahead_blocks", "must be an integer"),
    (lambda d: d["ncu"].update(tangential_jerk_share=1.6), "ncu.tangential_jerk_share", "must be in (0, 1]"),
    (lambda d: d["axes"].pop("Y"), "axes.Y", "missing table"),
    (lambda d: d.pop("ncu"), "ncu", "missing table"),
    (lambda d: d["axes"].update(A={}), "axes.A", "unknown key"),
    (lambda d: (d["ncu"].update(corner_velocity_jump_factor=1.0),
                d["axes"]["X"].update(max_accel_ovl_factor=2.0)), "ncu.corner_velocity_jump_factor",
     "replaced by max_accel_ovl_factor in [axes.X], [axes.Y], [axes.Z] (MD32310"),
    (lambda d: d["axes"]["X"].update(max_accel_ovl_factor=0.9), "axes.X.max_accel_ovl_factor",
     "must be >= 1 (MD32310"),
    (lambda d: d["axes"]["Z"].update(compress_pos_tol_mm=0), "axes.Z.compress_pos_tol_mm", "must be between 1e-06 and 100 mm"),
    (lambda d: d["ncu"].update(smoothing_mode=1), "ncu.smoothing_mode", "MD20480: ncsim simulates the tens digit"),
    (lambda d: d["ncu"].update(crit_spline_angle_deg=200), "ncu.crit_spline_angle_deg", "must be between 0 and 180 degrees"),
    (lambda d: d["ncu"].update(ignore_ovl_factor_for_adis=1), "ncu.ignore_ovl_factor_for_adis", "must be true or false"),
    (lambda d: d["cycle832"]["off"].update(path_mode="G61"), "cycle832.off.path_mode", "must be one of"),
    (lambda d: d["cycle832"].update(medium={}), "cycle832.medium", "unknown key"),
])
def test_each_bad_key_is_named(edit, key, message):
    data = mikron_dict()
    edit(data)
    with pytest.raises(MachineSpecError) as info:
        machine_from_dict(data, "shop.toml")
    assert info.value.render().startswith(f"shop.toml: {key}: {message}")
    assert "\n" not in info.value.render()


def test_the_former_corner_key_is_read_as_md32310_with_a_warning(mikron):
    """corner_velocity_jump_factor k (jump k A t_IPO) is max_accel_ovl_factor 1 + k (MD32310:
    jump A (f - 1) t_IPO) on every axis: the same machine, and a warning naming the key."""
    data = mikron_dict()
    factors = {a: t.pop("max_accel_ovl_factor") for a, t in data["axes"].items()}
    assert set(factors.values()) == {2.0}
    data["ncu"]["corner_velocity_jump_factor"] = 1.0
    old = machine_from_dict(data, "old.toml")
    assert [w.key for w in old.warnings] == ["ncu.corner_velocity_jump_factor"]
    assert "max_accel_ovl_factor = 2" in str(old.warnings[0])
    assert replace(old, warnings=(), source="") == replace(mikron, warnings=(), source="")


def test_several_problems_are_reported_together():
    data = mikron_dict()
    data["axes"]["X"]["max_jerk_m_s3"] = 0
    data["ncu"]["bogus"] = 1
    with pytest.raises(MachineSpecError, match=r"axes.X.max_jerk_m_s3: must be between 0.001 and 1e\+09 m/s\^3, got 0.*1 more: ncu.bogus: unknown key"):
        machine_from_dict(data, "shop.toml")


def test_unknown_name_lists_the_bundled_machines():
    with pytest.raises(MachineSpecError, match="no machine file and no bundled machine named 'nonesuch'.*mikron"):
        load_machine("nonesuch")


def test_invalid_toml_names_the_file(tmp_path):
    f = tmp_path / "bad.toml"
    f.write_text("[machine\nname = 1\n")
    with pytest.raises(MachineSpecError, match=rf"{f}: not valid TOML"):
        load_machine(f)


def test_written_machine_file_reads_back(tmp_path, mikron):
    f = tmp_path / "copy.toml"
    f.write_text(dump_machine_toml(mikron.with_ncu(curvilinear_jerk_mm_s3=7000.0), header="calibrated"))
    again = load_machine(f)
    assert again.ncu.curvilinear_jerk_mm_s3 == pytest.approx(7000.0)
    assert again.max_accel_mm_s2 == pytest.approx(mikron.max_accel_mm_s2)
    assert again.ncu == replace(mikron.ncu, curvilinear_jerk_mm_s3=7000.0)


def test_cli_reports_a_bad_machine_on_one_line(tmp_path, repo_root):
    data = mikron_dict()
    data["axes"]["X"]["max_accel_m_s2"] = "2.5 m/s2"
    lines = []
    for section, table in (("machine", data["machine"]), ("ncu", data["ncu"])):
        lines.append(f"[{section}]")
        lines += [f"{k} = {v!r}" if not isinstance(v, str) else f'{k} = "{v}"' for k, v in table.items()]
    for ax, table in data["axes"].items():
        lines.append(f"[axes.{ax}]")
        lines += [f"{k} = {v!r}" if not isinstance(v, str) else f'{k} = "{v}"' for k, v in table.items()]
    f = tmp_path / "shop.toml"
    f.write_text("\n".join(lines) + "\n")
    r = CliRunner().invoke(cli, ["run", str(repo_root / "programs/circle_r30_f6000.mpf"), "--machine", str(f)])
    assert r.exit_code == 2
    assert r.output.strip() == f"{f}: axes.X.max_accel_m_s2: must be a number, got str '2.5 m/s2'"


# ---------------------------------------------------------------------------------------------
# Physically possible ranges (errors) and usual ranges (warnings naming the likely unit)
# ---------------------------------------------------------------------------------------------

@pytest.mark.parametrize("edit, key, message", [
    # values the fuzzer found passing validation, then dividing by ~0 or overflowing
    (lambda d: d["axes"]["X"].update(max_jerk_m_s3=1e-300), "axes.X.max_jerk_m_s3",
     "must be between 0.001 and 1e+09 m/s^3, got 1e-300"),
    (lambda d: d["ncu"].update(lookahead_blocks=2 ** 64), "ncu.lookahead_blocks",
     "must be an integer from 1 to 100000, got 18446744073709551616"),
    (lambda d: d["axes"]["Y"].update(max_velocity_m_min=5e-324), "axes.Y.max_velocity_m_min",
     "must be between 0.001 and 1e+06 m/min"),
    (lambda d: d["ncu"].update(exact_stop_fine_settle_ms=1e300), "ncu.exact_stop_fine_settle_ms",
     "must be between 0 and 100000 ms, got 1e+300"),
    (lambda d: d["ncu"].update(ipo_cycle_ms=float("inf")), "ncu.ipo_cycle_ms",
     "must be between 0.001 and 100000 ms, got inf"),
    (lambda d: d["ncu"].update(curvilinear_jerk_m_s3=float("nan")), "ncu.curvilinear_jerk_m_s3",
     "must be between"),
    (lambda d: d.update(work_offsets={"G54": [float("nan"), 0.0, 0.0]}), "work_offsets.G54",
     "must be three finite numbers of magnitude below 1e+09 mm (the 840D's position range), got [nan, 0, 0]"),
    (lambda d: d.update(work_offsets={"G55": [0.0, float("inf"), 0.0]}), "work_offsets.G55",
     "must be three finite numbers"),
])
def test_impossible_values_are_errors(edit, key, message):
    data = mikron_dict()
    edit(data)
    with pytest.raises(MachineSpecError) as info:
        machine_from_dict(data, "shop.toml")
    assert info.value.render().startswith(f"shop.toml: {key}: {message}")


def test_the_papers_machine_has_nothing_unusual(mikron):
    assert mikron.warnings == ()


@pytest.mark.parametrize("edit, key, words", [
    (lambda d: d["axes"]["X"].update(max_velocity_m_min=30000.0), "axes.X.max_velocity_m_min",
     "30000 m/min is outside the usual 0.5..300 m/min (in mm/min? that is 30 m/min)"),
    (lambda d: d["axes"]["Y"].update(max_velocity_m_min=0.25), "axes.Y.max_velocity_m_min",
     "0.25 m/min is outside the usual 0.5..300 m/min (in m/s? that is 15 m/min)"),
    (lambda d: d["axes"]["Z"].update(max_accel_m_s2=2100.0), "axes.Z.max_accel_m_s2",
     "(in mm/s^2? that is 2.1 m/s^2)"),
    (lambda d: d["ncu"].update(ipo_cycle_ms=0.012), "ncu.ipo_cycle_ms", "(in s? that is 12 ms)"),
    (lambda d: d["ncu"].update(transition_time_ms=12000.0), "ncu.transition_time_ms",
     "(in us? that is 12 ms)"),
    (lambda d: d["axes"]["X"].update(position_gain_1_s=2.0), "axes.X.position_gain_1_s",
     "(in (m/min)/mm as MD32200 is entered? that is 33.33 1/s)"),
    # a jerk 1000x too large is still a usual jerk: other signs give it away
    (lambda d: d["axes"]["X"].update(max_jerk_m_s3=5000.0), "axes.X.max_jerk_m_s3",
     "5000 m/s^3 is over 100 times every other jerk of the machine (at most 50 m/s^3; in mm/s^3? "
     "that is 5 m/s^3)"),
    (lambda d: [d["axes"][a].update(max_jerk_m_s3=1000 * d["axes"][a]["max_jerk_m_s3"]) for a in "XYZ"]
     and d["ncu"].update(curvilinear_jerk_m_s3=1e4), "axes.Z.max_jerk_m_s3",
     "50000 m/s^3 reaches max_accel_m_s2 = 2.1 in 0.042 ms, a small fraction of the interpolation "
     "cycle (12 ms): it would limit nothing (in mm/s^3? that is 50 m/s^3)"),
    (lambda d: d["axes"]["Y"].update(max_jerk_m_s3=0.005), "axes.Y.max_jerk_m_s3",
     "0.005 m/s^3 is outside the usual 0.5..100000 m/s^3"),
])
def test_values_in_the_wrong_unit_load_with_a_warning_naming_key_and_unit(edit, key, words):
    data = mikron_dict()
    edit(data)
    spec = machine_from_dict(data, "shop.toml")
    rendered = [w.render() for w in spec.warnings]
    assert any(r.startswith(f"shop.toml: {key}: warning: ") and words in r for r in rendered), rendered
    assert all("\n" not in r for r in rendered)
    assert len({w.key for w in spec.warnings}) == len(spec.warnings)   # one warning a key


def test_cli_prints_the_unit_warning_on_stderr_and_runs(tmp_path, repo_root):
    text = (repo_root / "ncsim" / "machines" / "mikron.toml").read_text()
    f = tmp_path / "shop.toml"
    f.write_text(text.replace("max_velocity_m_min = 30.0   # paper Table 1 (V_mx)",
                              "max_velocity_m_min = 30000.0   # paper Table 1 (V_mx)"))
    r = CliRunner().invoke(cli, ["run", str(repo_root / "programs/circle_r30_f6000.mpf"),
                                 "--machine", str(f), "--json"])
    assert r.exit_code == 0
    assert r.stderr.splitlines() == [f"{f}: axes.X.max_velocity_m_min: warning: 30000 m/min is "
                                     "outside the usual 0.5..300 m/min (in mm/min? that is 30 m/min)"]
    import json
    assert json.loads(r.stdout)["warnings"] == r.stderr.splitlines()
