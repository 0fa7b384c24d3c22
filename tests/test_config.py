"""One TOML reader, one error policy: machine files, setup files and published values fail the
same way, as one line ``FILE: key: message`` (or ``FILE: message``), never a traceback."""
from __future__ import annotations

import pytest
from click.testing import CliRunner

from ncsim.cli.main import cli
from ncsim.config import Problems, load_setup, positive, read_toml
from ncsim.errors import ConfigError, MachineSpecError, MeasuredDataError
from ncsim.gap.measured import load_measured_summary
from ncsim.machine import load_machine

#: "é" in Latin-1 at line 2, column 11 (a file saved by an editor in the wrong encoding)
LATIN1 = "[machine]\nname = \"fr\xe9se\"\n".encode("latin-1")
LOADERS = [
    (load_machine, MachineSpecError, "machine file"),
    (load_setup, MachineSpecError, "setup file"),
    (load_measured_summary, MeasuredDataError, "file"),
]


@pytest.mark.parametrize("load, error, what", LOADERS, ids=lambda v: getattr(v, "__name__", v))
def test_not_utf8_names_the_file_and_the_byte(tmp_path, load, error, what):
    f = tmp_path / "latin1.toml"
    f.write_bytes(LATIN1)
    with pytest.raises(error) as info:
        load(f)
    assert str(info.value) == (f"{f}: cannot read {what}: not UTF-8 text (byte 0xe9 at line 2, "
                               "column 11)")


@pytest.mark.parametrize("load, error, what", LOADERS, ids=lambda v: getattr(v, "__name__", v))
def test_missing_file_and_bad_toml(tmp_path, load, error, what):
    with pytest.raises(error, match=rf"missing.toml: cannot read {what}: No such file"):
        load(tmp_path / "missing.toml")
    f = tmp_path / "bad.toml"
    f.write_text("[ncu\n")
    with pytest.raises(error, match=r"bad.toml: not valid TOML: .*line 1"):
        load(f)


def test_a_byte_order_mark_is_fine(tmp_path):
    f = tmp_path / "bom.toml"
    f.write_bytes("\ufeff[work_offsets]\nG54 = [1, 2, 3]\n".encode("utf-8"))
    assert load_setup(f) == {"G54": (1.0, 2.0, 3.0)}


def test_every_problem_of_a_file_is_named_at_once(tmp_path):
    f = tmp_path / "setup.toml"
    f.write_text("[work_offsets]\nG54 = [1, 2]\nG99 = [0, 0, 0]\nG505 = [0, 0, 'z']\n")
    with pytest.raises(MachineSpecError) as info:
        load_setup(f)
    assert str(info.value) == (
        f"{f}: work_offsets.G54: must be a list of three numbers [x_mm, y_mm, z_mm] (and 2 more: "
        "work_offsets.G99: unknown work offset (use G54..G57 or G505..G599); "
        "work_offsets.G505: must be a list of three numbers [x_mm, y_mm, z_mm])")


def test_problems_collector():
    c = Problems("f.toml")
    table = {"a": True, "b": -1.0, "c": 2.0, "t": 3}
    assert c.number(table, "x", "a") is None                    # a bool is no number
    assert c.number(table, "x", "b", check=positive) is None
    assert c.number(table, "x", "c", check=positive, convert=lambda v: v * 10) == 20.0
    assert c.number(table, "x", "d", required=True) is None
    assert c.table(table, "t") == {}
    with pytest.raises(ConfigError) as info:
        c.raise_if_any()
    assert str(info.value) == ("f.toml: x.a: must be a number, got bool True (and 3 more: "
                               "x.b: must be a positive number, got -1; x.d: missing key; "
                               "t: must be a table, got int)")
    Problems("ok.toml").raise_if_any()                            # nothing to report


def test_read_toml_of_a_bundled_resource():
    from importlib import resources
    data = read_toml(resources.files("ncsim.machines") / "mikron.toml", "machine file")
    assert data["machine"]["name"]


@pytest.mark.parametrize("option", ["--machine", "--setup"])
def test_cli_prints_one_line_and_exits_2(tmp_path, repo_root, option):
    f = tmp_path / "latin1.toml"
    f.write_bytes(LATIN1)
    args = ["run", str(repo_root / "programs" / "circle_r30_f6000.mpf"), "--machine", "mikron"]
    args += [option, str(f)] if option == "--setup" else []
    if option == "--machine":
        args[args.index("mikron")] = str(f)
    r = CliRunner().invoke(cli, args)
    assert r.exit_code == 2
    assert r.stderr.strip().startswith(f"{f}: cannot read ") and "not UTF-8" in r.stderr
    assert len(r.stderr.splitlines()) == 1 and "Traceback" not in r.output


@pytest.mark.parametrize("text, message", [
    # G054 would be stored and never applied: the interpreter asks for G54
    ("[work_offsets]\nG054 = [100.0, 0.0, 0.0]\n",
     "work_offsets.G054: unknown work offset (write G54; use G54..G57 or G505..G599)"),
    ("[work_offsets]\nG0505 = [1.0, 0.0, 0.0]\n", "work_offsets.G0505: unknown work offset (write G505;"),
    ('[work_offsets]\n"G\u0665\u0664" = [1.0, 0.0, 0.0]\n', "work_offsets.G\u0665\u0664: unknown work offset (use G54"),
    # 1e160 overflowed the segment lengths and ended as 'circle centre coincides with the start'
    ("[work_offsets]\nG54 = [1e160, 0.0, 0.0]\n",
     "work_offsets.G54: must be three finite numbers of magnitude below 1e+09 mm"),
    ("[work_offsets]\nG54 = [nan, 0.0, 0.0]\n", "work_offsets.G54: must be three finite numbers"),
    ("[work_offsets]\nG54 = [0.0, -inf, 0.0]\n", "work_offsets.G54: must be three finite numbers"),
])
def test_setup_offsets_the_interpreter_would_not_apply_or_cannot_use(tmp_path, text, message):
    f = tmp_path / "setup.toml"
    f.write_text(text, encoding="utf-8")
    with pytest.raises(MachineSpecError) as info:
        load_setup(f)
    assert str(info.value).startswith(f"{f}: {message}")
