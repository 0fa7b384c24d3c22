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
    (lambda d: d["axes"]["Y"].update(max_accel_m_s2=-3.0), "axes.Y.max_accel_m_s2", "must be a positive number"),
    (lambda d: d["axes"]["Z"].update(max_velocity_m_min="fast"), "axes.Z.max_velocity_m_min", "must be a number"),
    (lambda d: d["ncu"].update(ipo_cycle_sec=12), "ncu.ipo_cycle_sec", "unknown key"),
    (lambda d: d["ncu"].update(lookahead_blocks=10.5), "ncu.lookahead_blocks", "must be an integer"),
    (lambda d: d["ncu"].update(tangential_jerk_share=1.6), "ncu.tangential_jerk_share", "must be in (0, 1]"),
    (lambda d: d["axes"].pop("Y"), "axes.Y", "missing table"),
    (lambda d: d.pop("ncu"), "ncu", "missing table"),
    (lambda d: d["axes"].update(A={}), "axes.A", "unknown key"),
])
def test_each_bad_key_is_named(edit, key, message):
    data = mikron_dict()
    edit(data)
    with pytest.raises(MachineSpecError) as info:
        machine_from_dict(data, "shop.toml")
    assert info.value.render().startswith(f"shop.toml: {key}: {message}")
    assert "\n" not in info.value.render()


def test_several_problems_are_reported_together():
    data = mikron_dict()
    data["axes"]["X"]["max_jerk_m_s3"] = 0
    data["ncu"]["bogus"] = 1
    with pytest.raises(MachineSpecError, match=r"axes.X.max_jerk_m_s3: must be a positive number.*1 more: ncu.bogus: unknown key"):
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
