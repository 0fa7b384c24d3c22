"""`ncsim gap --write-machine`: a calibrated machine file an engineer can load (issue 18).

Expected values come from what the synthetic recordings were made with (a planted rapid
override, feed override, axis acceleration), from the machine files' own text, and from the
search bounds of the effects; none from ncsim's own output."""
from __future__ import annotations

import json
import math
import re
import warnings

import click
import pytest
from click.testing import CliRunner

from ncsim.cli.gap import gap
from ncsim.cli.main import NcsimGroup, cli as ncsim_cli
from ncsim.gap.calibration import (DATA, Change, bound_hits, edit_machine_text, machine_changes,
                                   on_bound)
from ncsim.gap.effects import get_effect
from ncsim.gap.measured import write_measured_csv
from ncsim.gap.truth.cases import Case, truth_trace
from ncsim.gap.truth.synth import ScopeConfig
from ncsim.machine import load_machine
from ncsim.nc.interpret import interpret_text


@click.group(cls=NcsimGroup)
def cli():
    """test group: renders ncsim errors as the real one does"""


cli.add_command(gap)

#: rapids and a slow feed: a rapid override and an axis velocity (MD32000) at the same rate
#: give the same motion as long as the G1 feed stays under it
RAPIDS = """N10 G17 G90 G64 SOFT
N20 G0 X0 Y0 Z5
N30 G0 X60 Y15
N40 G0 Z0
N50 G1 X90 F600
N60 G1 Y40
N70 G0 Z5
N80 G0 X0 Y0
N90 M30
"""


def _record(tmp, name, program, machine, case):
    prog = tmp / f"{name}.mpf"
    prog.write_text(program)
    path = interpret_text(program, str(prog), machine).path
    csv = tmp / f"{name}.csv"
    write_measured_csv(truth_trace(path, machine, case), csv)
    return prog, csv


SCOPE = ScopeConfig(period_s=4e-3, noise_um=0.5, quant_um=0.1, time_offset_s=0.25,
                    pos_offset_mm=(0.0, 0.0, 0.0))


def _at_a_tenth_of_the_rapid_rate(tmp, name, program, machine, effects: str):
    """``program`` recorded on ``machine`` at a 10 % rapid override, diagnosed by ``ncsim gap``
    against the MIKRON file with the candidates ``effects``, the calibrated file written:
    ``(program, recording, written file, the JSON output)``."""
    prog, csv = _record(tmp, name, program, machine,
                        Case(index=0, effect="rapid_override",
                             params={"rapid_override_percent": 10.0}, base="full",
                             scope=SCOPE, lead_s=0.2, seed=3))
    out = tmp / "calibrated.toml"
    r = CliRunner().invoke(cli, ["gap", str(prog), "--machine", "mikron", "--measured", str(csv),
                                 "--effects", effects, "--json", "--write-machine", str(out)])
    assert r.exit_code == 0, r.output
    return prog, csv, out, json.loads(r.stdout)


@pytest.fixture(scope="module")
def override_case(tmp_path_factory):
    """Recorded on the MIKRON at a 10 % rapid override, diagnosed against its file."""
    d = tmp_path_factory.mktemp("calib")
    prog, csv, out, data = _at_a_tenth_of_the_rapid_rate(
        d, "rapids", RAPIDS, load_machine("mikron"), "axis_velocity,rapid_override")
    return d, prog, csv, out, data


def test_an_override_is_written_before_an_equally_good_axis_velocity(override_case):
    d, prog, csv, out, data = override_case
    spec = load_machine(out)
    # the planted 10 % rapid override, not MD32000 at 3 m/min
    assert spec.ncu.rapid_override * 100 == pytest.approx(10.0, rel=0.03)
    assert list(spec.max_velocity_mm_s) == list(load_machine("mikron").max_velocity_mm_s)
    cal = data["calibration"]
    alt = [a for a in cal["alternatives"] if a["effect"] == "axis_velocity"]
    assert alt and alt[0]["instead_of"] == "rapid_override"
    # 10 % of the MIKRON's 30 m/min
    assert alt[0]["params"]["axis_velocity_m_min"] == pytest.approx(3.0, rel=0.03)
    assert "operator setting" in alt[0]["reason"]
    text = out.read_text()
    assert "Equally good alternatives (not written):" in text and "axis_velocity" in text


def test_the_changed_machine_data_are_listed_with_old_and_new_values(override_case):
    d, prog, csv, out, data = override_case
    changes = data["calibration"]["changes"]
    assert [(c["table"], c["key"], c["old"], c["effects"]) for c in changes] == \
        [("ncu", "rapid_override_percent", 100.0, ["rapid_override"])]   # the planted one only
    assert changes[0]["new"] == pytest.approx(10.0, rel=0.03)
    assert changes[0]["md"] == "rapid override on the operator panel (no machine datum)"
    # in the file: the header lists it, old -> new; the changed line says what it was
    text = out.read_text()
    assert re.search(r"#   rapid override on the operator panel \(no machine datum\): \[ncu\] "
                     r"rapid_override_percent 100 -> (9\.[7-9][0-9]*|10|10\.[0-3][0-9]*) %", text)
    line = next(ln for ln in text.splitlines() if ln.startswith("rapid_override_percent"))
    assert "was 100, the default" in line


def test_the_written_file_keeps_the_source_comments_and_loads_without_warnings(override_case,
                                                                                repo_root):
    d, prog, csv, out, data = override_case
    source = (repo_root / "machines" / "mikron.toml").read_text().splitlines()
    written = out.read_text().splitlines()
    changed = {c["key"] for c in data["calibration"]["changes"]}
    for line in source:
        key = line.split("=")[0].strip()
        if key in changed and "=" in line:
            continue
        assert line in written, f"source line lost: {line!r}"
    # each changed line says what it was and keeps its old comment
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        spec = load_machine(out)
    assert spec.warnings == ()


def test_ncsim_run_on_the_written_file_gives_the_corrected_models_cycle_time(override_case):
    d, prog, csv, out, data = override_case
    r = CliRunner().invoke(ncsim_cli, ["run", str(prog), "--machine", str(out), "--json"])
    assert r.exit_code == 0, r.output
    ran = json.loads(r.stdout)["cycle_time_s"]
    cal = data["calibration"]
    assert ran == pytest.approx(cal["cycle_time_s"], rel=1e-6)
    # and the source file's run is the base model's
    r = CliRunner().invoke(ncsim_cli, ["run", str(prog), "--machine", "mikron", "--json"])
    assert json.loads(r.stdout)["cycle_time_s"] == pytest.approx(cal["base_cycle_time_s"],
                                                                rel=1e-9)
    assert abs(ran - cal["base_cycle_time_s"]) > 1.0       # a 10 % rapid override is slow


@pytest.fixture(scope="module")
def feed_override_case(tmp_path_factory):
    """Recorded at a 200 % feed override: the feed-override search stops at its 150 % bound."""
    d = tmp_path_factory.mktemp("bounds")
    m = load_machine("mikron").with_ncu(feed_override=2.0)
    prog, csv = _record(d, "feed", RAPIDS, m,
                        Case(index=0, effect="rapid_override",
                             params={"rapid_override_percent": 100.0}, base="full",
                             scope=SCOPE, lead_s=0.2, seed=5))
    return d, prog, csv


def test_a_value_on_its_search_bound_is_refused_in_one_line(feed_override_case):
    d, prog, csv = feed_override_case
    out = d / "refused.toml"
    args = ["gap", str(prog), "--machine", "mikron", "--measured", str(csv),
            "--effects", "feed_override", "--write-machine", str(out)]
    r = CliRunner().invoke(cli, args)
    assert r.exit_code == 2
    assert not out.exists()
    hi = get_effect("feed_override").param("feed_override_percent").high
    last = r.output.rstrip("\n").splitlines()[-1]
    assert last.endswith("gap: error: " + f"{out} not written: fitted values on their search "
                         "bounds would go into it: feed_override feed_override_percent=150 (upper "
                         "bound) (the fit stopped there, the data want beyond it; --allow-bounds "
                         "writes them)".replace("150", f"{hi:g}"))
    # the text flags it too
    assert "ON BOUND: feed_override feed_override_percent" in r.output
    # --allow-bounds writes it, flagged in the file
    r = CliRunner().invoke(cli, args + ["--allow-bounds"])
    assert r.exit_code == 0, r.output
    text = out.read_text()
    assert "Values on their search bounds" in text and "feed_override_percent" in text
    assert load_machine(out).ncu.feed_override == pytest.approx(hi / 100)


def test_gap_requires_the_machine(override_case):
    d, prog, csv, out, data = override_case
    r = CliRunner().invoke(ncsim_cli, ["gap", str(prog), "--measured", str(csv)])
    assert r.exit_code == 2 and r.output.count("\n") == 1 and "--machine" in r.output


# ---------------------------------------------------------------------------------------------
# The pieces, without a diagnosis
# ---------------------------------------------------------------------------------------------

def test_machine_changes_name_the_machine_datum_and_both_values(repo_root):
    old = load_machine(repo_root / "machines" / "dmc60h.toml")
    new = old.with_axes(max_velocity_mm_s=[50.0, 50.0, 50.0]).with_ncu(reset_path_mode=64)
    changes = machine_changes(old, new, ["axis_velocity", "reset_mode"])
    got = {(c.datum.table, c.datum.key): (c.old, c.new, c.datum.md.split()[0], c.effects)
           for c in changes}
    assert got == {
        ("axes.X", "max_velocity_m_min"): (40.0, 3.0, "MD32000", ("axis_velocity",)),
        ("axes.Y", "max_velocity_m_min"): (40.0, 3.0, "MD32000", ("axis_velocity",)),
        ("axes.Z", "max_velocity_m_min"): (40.0, 3.0, "MD32000", ("axis_velocity",)),
        ("ncu", "reset_path_mode"): ("G60", "G64", "MD20150", ("reset_mode",)),
    }


def test_edit_keeps_every_other_line_and_adds_missing_keys(repo_root):
    text = (repo_root / "machines" / "dmc60h.toml").read_text()
    old = load_machine(repo_root / "machines" / "dmc60h.toml")
    new = old.with_ncu(rapid_override=0.074, reset_path_mode=64)
    changes = machine_changes(old, new, ["rapid_override", "reset_mode"])
    out = edit_machine_text(text, changes, ["header line"])
    assert out.startswith("# header line\n")
    assert all(line in out.splitlines() for line in text.splitlines())   # nothing changed in place
    spec = load_machine_text(out)
    assert spec.ncu.rapid_override == pytest.approx(0.074) and spec.ncu.reset_path_mode == 64
    assert spec.warnings == ()
    line = next(ln for ln in out.splitlines() if ln.startswith("rapid_override_percent"))
    assert "was 100, the default" in line


def load_machine_text(text: str):
    import tomllib
    from ncsim.machine import machine_from_dict
    return machine_from_dict(tomllib.loads(text), "<written>")


def test_a_file_of_earlier_versions_loses_its_old_corner_key_when_md32310_changes():
    text = """[machine]
name = "old"
[axes.X]
max_velocity_m_min = 30.0
max_accel_m_s2 = 2.0
max_jerk_m_s3 = 20.0
[axes.Y]
max_velocity_m_min = 30.0
max_accel_m_s2 = 2.0
max_jerk_m_s3 = 20.0
[axes.Z]
max_velocity_m_min = 30.0
max_accel_m_s2 = 2.0
max_jerk_m_s3 = 20.0
[ncu]
ipo_cycle_ms = 4.0
curvilinear_jerk_m_s3 = 10.0
tangential_jerk_share = 0.6
central_jerk_share = 0.4
transition_time_ms = 4.0
lookahead_blocks = 50
corner_velocity_jump_factor = 1.0   # the key of earlier versions
"""
    from ncsim.gap.calibration import complete_ovl_changes
    old = load_machine_text(text)
    assert len(old.warnings) == 1                    # the old key, read as MD32310 = 2
    new = old.with_axes(max_accel_ovl_factor=[1.5, 2.0, 2.0])
    changes = complete_ovl_changes(old, new, machine_changes(old, new, ["corner_jump"]), text)
    spec = load_machine_text(edit_machine_text(text, changes, []))
    assert list(spec.max_accel_ovl_factor) == [1.5, 2.0, 2.0] and spec.warnings == ()


@pytest.mark.parametrize("effect, values, flagged", [
    ("axis_accel", {"xy_accel_m_s2": 20.0, "z_accel_m_s2": 1.0}, {("xy_accel_m_s2", "high")}),
    ("cycle_time", {"ipo_cycle_ms": 100.0}, {("ipo_cycle_ms", "high")}),
    ("corner_jump", {"corner_jump_mm_s": 0.1}, {("corner_jump_mm_s", "low")}),
    ("corner_jump", {"corner_jump_mm_s": 0.1000000002}, {("corner_jump_mm_s", "low")}),
    ("corner_jump", {"corner_jump_mm_s": 0.2}, set()),
    # physical ends, not search limits: no settle time, the full rapid rate, no feed forward
    ("reset_mode", {"path_mode": "G64", "settle_ms": 0.0, "corner_jump_mm_s": 5.0}, set()),
    ("rapid_override", {"rapid_override_percent": 100.0}, set()),
    ("servo_lag", {"kv_1_s": 40.0, "ffw_weight": 0.0}, set()),
    ("lookahead", {"lookahead_blocks": 128}, {("lookahead_blocks", "high")}),
])
def test_values_on_search_bounds(effect, values, flagged):
    hits = bound_hits([(effect, values)])
    assert {(h.param, h.end) for h in hits} == flagged
    assert all(h.written for h in hits)


def test_every_datum_names_what_it_is():
    for d in DATA:
        assert d.md and d.effects, d.key
        assert d.md.startswith(("MD", "IPO", "path", "look", "settle", "rapid", "feed",
                                "structure", "no machine")), d.md
        for e in d.effects:
            get_effect(e)


def test_a_change_reads_as_old_to_new():
    d = next(x for x in DATA if x.key == "max_velocity_m_min")
    assert Change(d, 40.0, 3.01, ("axis_velocity",)).text() == \
        "MD32000 $MA_MAX_AX_VELO: [axes.X] max_velocity_m_min 40 -> 3.01 m/min (axis_velocity)"
    p = get_effect("axis_velocity").param("axis_velocity_m_min")
    assert on_bound(p, p.low) == "low" and on_bound(p, p.high) == "high"
    assert on_bound(p, math.sqrt(p.low * p.high)) is None


@pytest.mark.slow
def test_the_kit_plunge_writes_a_rapid_override_and_names_md32000(shared, repo_root, tmp_path):
    """Real 840D data (KIT DMC 60H, the plunge and start window): SOURCE.md reads the G0 Z-6.0
    at about 50 mm/s, 7.5 % of the 40 m/min rapid rate of machines/dmc60h.toml. The file gets
    the override, names MD32000 at about 3 m/min as the alternative, keeps the source's
    comments, loads without warnings and runs the program as the corrected model does."""
    kit = shared / "data/real/kit-dmc60h-notch-sinumerik"
    prog = kit / "AL_2007_T4_Notch_Normal.mpf"
    source = repo_root / "machines/dmc60h.toml"
    out = tmp_path / "dmc60h_calibrated.toml"
    r = CliRunner().invoke(cli, ["gap", str(prog), "--machine", str(source), "--measured",
                                 str(kit / "window_A_plunge_and_start.csv"),
                                 "--effects", "rapid_override,axis_velocity", "--json",
                                 "--write-machine", str(out)])
    assert r.exit_code == 0, r.output
    cal = json.loads(r.stdout)["calibration"]
    spec = load_machine(out)
    assert spec.warnings == ()
    assert spec.ncu.rapid_override * 100 == pytest.approx(50.0 / (40e3 / 60) * 100, abs=0.5)
    assert list(spec.max_velocity_mm_s) == list(load_machine(source).max_velocity_mm_s)
    (alt,) = [a for a in cal["alternatives"] if a["effect"] == "axis_velocity"]
    assert alt["params"]["axis_velocity_m_min"] == pytest.approx(3.0, abs=0.2)
    written = out.read_text().splitlines()
    assert all(line in written for line in source.read_text().splitlines()
               if not line.startswith("rapid_override_percent"))
    ran = CliRunner().invoke(ncsim_cli, ["run", str(prog), "--machine", str(out), "--json"])
    assert json.loads(ran.stdout)["cycle_time_s"] == pytest.approx(cal["cycle_time_s"], rel=1e-6)


#: rapids, then a spiral of tangent arcs whose curvature jumps at each junction: the crossing
#: feed sqrt(R1 R2 J dt / |R1 - R2|) (paper eq. 13) binds under F2400 at dt = 2 ms, not at the
#: MIKRON's 12 ms
SPIRAL_AND_RAPIDS = """N10 G17 G90 G64 SOFT
N20 G0 X40 Y30 Z5
N25 G0 X0 Y-10
N28 G0 Z0
N30 G3 X10 Y0 I0 J10 F2400
N40 G3 X-2 Y12 I-12 J0
N50 G3 X-16 Y-2 I0 J-14
N60 G3 X0 Y-18 I16 J0
N70 G3 X18 Y0 I0 J18
N80 G0 Z5
N90 G0 X40 Y30
N100 M30
"""


def test_a_combined_model_keeps_the_override_and_names_the_axis_velocity(tmp_path):
    """Recorded at a 10 % rapid override on a MIKRON crossing curvature jumps in 2 ms: the
    combined model (two effects) holds the override, whichever of the two equally good rapid
    hypotheses the selection started from, and names MD32000 as the alternative."""
    from ncsim.units import ms_to_s
    m = load_machine("mikron")
    _, _, out, data = _at_a_tenth_of_the_rapid_rate(
        tmp_path, "spiral", SPIRAL_AND_RAPIDS, m.with_ncu(transition_time_s=ms_to_s(2.0)),
        "axis_velocity,rapid_override,transition")
    comb = data["diagnosis"]["combined"]
    assert sorted(comb["effects"]) == ["rapid_override", "transition"]
    assert [a["effect"] for a in data["calibration"]["alternatives"]] == ["axis_velocity"]
    spec = load_machine(out)
    assert spec.ncu.rapid_override * 100 == pytest.approx(10.0, rel=0.03)
    assert spec.ncu.transition_time_s * 1e3 == pytest.approx(2.0, rel=0.25)
    assert list(spec.max_velocity_mm_s) == list(m.max_velocity_mm_s)
    assert spec.warnings == ()


@pytest.mark.parametrize("effect, values", [
    ("corner_law", {"mode": "SOFT", "corner_jump_mm_s": 1.6, "ramp_jerk_m_s3": 20.3}),
    ("accel_mode", {"mode": "SOFT", "axis_accel_m_s2": 2.0})])
def test_a_fitted_acceleration_mode_goes_into_the_written_file(repo_root, effect, values):
    """The corner law's SOFT (the KIT Notch's) is the group-21 reset value ``[ncu]
    reset_accel_mode`` of the written file (MD20150): ``ncsim run`` on that file plans a
    program that selects no mode as the fitted model does (forced SOFT), and not as BRISK,
    the reset value of the source file."""
    from dataclasses import replace

    from ncsim.gap.effects import EFFECTS, Model, corrected_machine
    from ncsim.path import BRISK, SOFT
    from ncsim.pipeline import simulate

    text = "G17 G90 G64\nG1 X20 F6000\nY20\nX0 Y0\nM30\n"           # no BRISK/SOFT/DRIVE
    source = load_machine(repo_root / "machines" / "dmc60h.toml")
    assert source.ncu.reset_accel_mode == BRISK                     # as delivered
    model = EFFECTS[effect].apply(Model(machine=source), values)
    fitted = simulate("p.mpf", model.machine, model.options, text=text).cycle_time_s
    file = repo_root / "machines" / "dmc60h.toml"
    changes = machine_changes(source, corrected_machine(model), (effect,))
    mode = [c for c in changes if c.datum.key == "reset_accel_mode"]
    assert len(mode) == 1 and (mode[0].old, mode[0].new) == ("BRISK", "SOFT")
    assert "MD20150" in mode[0].datum.md and mode[0].effects == (effect,)
    written = load_machine_text(edit_machine_text(file.read_text(), changes, ["fit"]))
    assert written.ncu.reset_accel_mode == SOFT
    assert simulate("p.mpf", written, text=text).cycle_time_s == pytest.approx(fitted, rel=1e-12)
    brisk = simulate("p.mpf", model.machine, replace(model.options, accel_mode=BRISK), text=text)
    assert abs(brisk.cycle_time_s - fitted) > 1e-3                 # the mode matters here
