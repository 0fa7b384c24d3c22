"""The README is accurate: its commands work, its examples are real, its references complete.

* the quick start's test command is the one `.ci/run` runs;
* every `ncsim` command shown (shell blocks and the GitHub Actions job) parses, and the examples
  whose output is shown give that output;
* the example figure is committed and made by a command shown in the README;
* every key of the JSON summary, every CSV column, every machine-file key, every limit name and
  every exit status is documented.
"""
from __future__ import annotations

import glob
import json
import re
import shlex
import shutil
import tomllib

import click
import matplotlib.image as matplotlib_image
import pytest
from click.testing import CliRunner

from ncsim.cli.main import cli

FIGURE_COMMAND = "ncsim plot programs/bore_d25_f5984.mpf --machine mikron -o bore.png"
FIGURE_FILE = "docs/bore_d25_f5984.png"


@pytest.fixture(scope="module")
def readme(repo_root) -> str:
    return (repo_root / "README.md").read_text(encoding="utf-8")


def section(text: str, heading: str) -> str:
    """The text under ``## heading`` up to the next ``## ``."""
    match = re.search(rf"^## {re.escape(heading)}\n(.*?)(?=^## |\Z)", text, re.S | re.M)
    assert match, f"README has no '## {heading}' section"
    return match.group(1)


def fenced(text: str, lang: str) -> list[str]:
    return re.findall(rf"^```{lang}\n(.*?)^```", text, re.S | re.M)


def shell_commands(text: str) -> list[str]:
    """Commands of the ```sh blocks (continuation lines joined), split at &&."""
    out = []
    for block in fenced(text, "sh"):
        for line in block.replace("\\\n", " ").splitlines():
            line = line.strip()
            if line and not line.startswith("#"):
                out += [c.strip() for c in line.split("&&")]
    return out


def workflow_commands(text: str) -> list[str]:
    """Commands run by the ```yaml job (`run: cmd` and the lines of `run: |` blocks)."""
    out = []
    for block in fenced(text, "yaml"):
        lines = block.splitlines()
        for i, line in enumerate(lines):
            m = re.match(r"\s*(?:- )?run: (.*)$", line)
            if not m:
                continue
            if m.group(1).strip() != "|":
                out.append(m.group(1).strip())
                continue
            indent = None
            for follow in lines[i + 1:]:
                width = len(follow) - len(follow.lstrip())
                if indent is None:
                    indent = width
                if not follow.strip() or width < indent:
                    break
                out.append(follow.strip())
    return out


def ncsim_args(command: str) -> list[str]:
    words = shlex.split(command.split(">")[0], comments=True)
    assert words[0] == "ncsim", command
    return words[1:]


# ---------------------------------------------------------------------------------------------
# Quick start and CI
# ---------------------------------------------------------------------------------------------

def test_quick_start_is_two_commands_and_ci_runs_the_same_tests(readme, repo_root):
    """On a fresh machine: make and activate a virtual environment, install, run (two lines);
    then the tests in the same environment."""
    quick = section(readme, "Quick start")
    blocks = fenced(quick, "sh")
    assert [b.strip() for b in blocks] == [
        "python3 -m venv .venv && . .venv/bin/activate && pip install .\n"
        "ncsim run programs/bore_d25_f5984.mpf --machine mikron",
        "pip install '.[test]' && python -m pytest -q",
    ]
    ci = [line.strip() for line in (repo_root / ".ci" / "run").read_text().splitlines()
          if line.strip() and not line.lstrip().startswith("#")]
    assert ci[-1] == blocks[1].strip(), "README's test command and .ci/run must agree"


def test_quick_start_run_works_from_the_repository(readme, repo_root, monkeypatch):
    monkeypatch.chdir(repo_root)
    command = fenced(section(readme, "Quick start"), "sh")[0].splitlines()[1].strip()
    r = CliRunner().invoke(cli, ncsim_args(command))
    assert r.exit_code == 0, r.output
    assert r.stdout.startswith("program     programs/bore_d25_f5984.mpf\nmachine     mikron\ncycle time")


def test_every_ncsim_command_shown_parses(readme, repo_root, monkeypatch):
    """Arguments and options of each command are accepted (click parses them without running)."""
    monkeypatch.chdir(repo_root)
    commands = [c for c in shell_commands(readme) + workflow_commands(readme) if c.startswith("ncsim ")]
    assert len(commands) >= 8
    for command in commands:
        name, *rest = ncsim_args(command)
        ctx = click.Context(cli, info_name="ncsim")
        sub = cli.get_command(ctx, name)
        assert sub is not None, f"no command {name!r}: {command}"
        sub.make_context(name, rest, parent=ctx)   # raises on an unknown option or a bad value


#: the gap diagnosis example whose output the README shows (an excerpt: its lines other than
#: ``...`` are lines of the real output)
GAP_COMMAND = ("ncsim gap programs/gap_passes.mpf --machine mikron --measured "
               "measured/gap_passes_scope.csv --plot out/scope --write-machine my_machine.toml")


def test_every_ncsim_example_runs_as_written_on_the_shipped_files(readme, repo_root, tmp_path,
                                                                  monkeypatch):
    """Each ``ncsim`` command of the README, in order, in a directory holding only what the
    repository ships (programs, machines, measured values): files one command writes are there
    for the next. Not run: a Dask cluster (``--scheduler``), ``../shared`` data (tested with
    their figure). File name patterns are expanded as a shell does. The gap diagnosis's
    output shown is checked, and so is the cycle time its corrected machine file gives."""
    gap_text = section(readme, "Sim-to-real gap diagnosis")
    commands = [" ".join(c.split()) for c in shell_commands(readme) if c.startswith("ncsim ")
                and "--scheduler" not in c and "../shared" not in c]
    assert GAP_COMMAND in commands
    assert len(commands) >= 7
    monkeypatch.chdir(tmp_path)
    for folder in ("programs", "machines", "measured"):
        shutil.copytree(repo_root / folder, folder)
    runner = CliRunner()
    for command in commands:
        args = [m for w in ncsim_args(command) for m in (sorted(glob.glob(w)) or [w])]
        r = runner.invoke(cli, args)
        assert r.exit_code == 0, (command, r.output)
        if ">" in command:
            (tmp_path / command.split(">")[1].split()[0]).write_text(r.stdout)
        if command == GAP_COMMAND:
            shown = [line for line in _output_after(gap_text, "--write-machine my_machine.toml").splitlines()
                     if line not in ("...", "")]
            assert len(shown) >= 8
            assert [line for line in shown if line not in r.stdout.splitlines()] == [], \
                "refresh the README's gap diagnosis output with the command's"
            assert (tmp_path / "out" / "scope-gap.png").exists()
        if command == "ncsim run programs/gap_passes.mpf --machine my_machine.toml":
            cycle = re.search(r"^cycle time  (\S+ s)", r.stdout, re.M).group(1)
            assert f"gives the whole program {cycle}" in " ".join(gap_text.split())


def test_example_recording_is_what_its_script_makes(readme, repo_root, tmp_path):
    """The gap section's example recordings are made, as their headers and the README say, by
    ``benchmarks/make_example_trace.py`` (an independent truth, seeded): made again, the
    same bytes."""
    import importlib.util
    script = repo_root / "benchmarks" / "make_example_trace.py"
    spec = importlib.util.spec_from_file_location("make_example_trace", script)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    made = {"gap_passes_scope.csv": tmp_path / "scope.csv",
            "gap_passes_scope_um.csv": tmp_path / "scope_um.csv"}
    assert module.main(["--out", str(made["gap_passes_scope.csv"]),
                        "--out-um", str(made["gap_passes_scope_um.csv"])]) == 0
    for name, file in made.items():
        assert file.read_bytes() == (repo_root / "measured" / name).read_bytes(), \
            f"measured/{name} is not what {script.name} makes: run it and refresh the README"
        assert f"measured/{name}" in section(readme, "Sim-to-real gap diagnosis")


def _output_after(text: str, command: str) -> str:
    """The ```text block that follows the ```sh block holding ``command``."""
    i = text.index(command)
    start = text.index("```text\n", i) + len("```text\n")
    return text[start:text.index("```", start)]


def test_worked_example_output_is_real(readme, repo_root, monkeypatch):
    monkeypatch.chdir(repo_root)
    example = section(readme, "Worked example: the 25 mm bore")
    command = "ncsim run programs/bore_d25_f5984.mpf --machine mikron --top 4"
    assert command in example
    r = CliRunner().invoke(cli, ncsim_args(command))
    assert r.exit_code == 0
    assert r.stdout == _output_after(example, command), \
        "refresh the README's worked example with the command's output"


def test_check_example_and_ci_job_pass(readme, repo_root, tmp_path, monkeypatch):
    text = section(readme, "ncsim check in CI")
    command = "ncsim check programs/bore_d25_f5984.mpf --machine mikron --max-time 2.5 --min-feed-ratio 0.2"
    assert command in text and command in workflow_commands(text)
    runner = CliRunner()
    monkeypatch.chdir(tmp_path)                  # a checkout: the programs, nothing else
    shutil.copytree(repo_root / "programs", "programs")
    r = runner.invoke(cli, ncsim_args(command))
    assert r.exit_code == 0, r.output
    assert r.stdout == _output_after(text, command)
    # the job's regression step, with `git show origin/main:...` replaced by a copy
    steps = workflow_commands(text)
    git = next(s for s in steps if s.startswith("git show"))
    source, target = re.match(r"git show origin/main:(\S+) > (\S+)", git).groups()
    shutil.copy(source, target)
    for step in steps[steps.index(git) + 1:]:
        r = runner.invoke(cli, ncsim_args(step))
        assert r.exit_code == 0, (step, r.output)
        if ">" in step:
            (tmp_path / step.split(">")[1].strip()).write_text(r.stdout)


# ---------------------------------------------------------------------------------------------
# The example figure
# ---------------------------------------------------------------------------------------------

def _same_picture(made, committed) -> None:
    """The committed figure is what the command draws today (same size, and the same picture
    up to anti-aliasing and font rendering: mean pixel difference below 1 %)."""
    assert made.shape == committed.shape
    diff = abs(made[..., :3].astype(float) - committed[..., :3].astype(float)).mean()
    assert diff < 0.01, f"regenerate the committed figure (mean pixel difference {diff:.4f})"


def test_example_figure_is_committed_and_made_by_a_readme_command(readme, repo_root, tmp_path, monkeypatch):
    """The README's plot command writes a new file (not over docs/); the copy shown is what it
    draws with today's plot defaults."""
    assert FIGURE_COMMAND in shell_commands(section(readme, "Worked example: the 25 mm bore"))
    assert not FIGURE_COMMAND.split("-o ")[1].startswith("docs/")
    assert f"]({FIGURE_FILE})" in readme
    committed = matplotlib_image.imread(repo_root / FIGURE_FILE)
    assert committed.shape[:2] == (1000, 1600)
    monkeypatch.chdir(tmp_path)                   # a checkout: the programs, nothing else
    shutil.copytree(repo_root / "programs", "programs")
    r = CliRunner().invoke(cli, ncsim_args(FIGURE_COMMAND))
    assert r.exit_code == 0, r.output
    _same_picture(matplotlib_image.imread(tmp_path / "bore.png"), committed)


THWS_COMMAND = ("ncsim plot ../shared/data/real/thws-spinner-u5-620-nc-programs/"
                "Bottle_opener_Flaschenoeffner.txt --machine mikron -o bottle_opener.png")
THWS_FILE = "docs/thws_bottle_opener.png"


def test_real_program_figure_is_committed_attributed_and_current(readme, repo_root, tmp_path,
                                                                 monkeypatch, shared):
    """The figure of a real THWS program: made by the README's command (the program is read
    from ../shared, never copied into the repository) and attributed (CC BY 4.0). Its pixels
    are not compared: every change to the 840D model (CYCLE832, G642) redraws it."""
    text = section(readme, "Worked example: the 25 mm bore")
    assert THWS_COMMAND in shell_commands(text) and f"]({THWS_FILE})" in text
    assert "CC BY 4.0" in text and "10.1038/s41597-025-05294-0" in text
    for folder in ("programs", "tests", "docs", "measured", "benchmarks"):   # not copied in
        assert not list((repo_root / folder).rglob("Bottle_opener*"))
    committed = matplotlib_image.imread(repo_root / THWS_FILE)
    monkeypatch.chdir(repo_root)                  # ../shared beside the checkout
    args = ncsim_args(THWS_COMMAND)
    args[args.index("-o") + 1] = str(tmp_path / "bottle_opener.png")
    r = CliRunner().invoke(cli, args)
    assert r.exit_code == 0, r.output
    assert matplotlib_image.imread(tmp_path / "bottle_opener.png").shape == committed.shape == (1000, 1600, 4)


# ---------------------------------------------------------------------------------------------
# References
# ---------------------------------------------------------------------------------------------

def _documented(text: str) -> set[str]:
    return set(re.findall(r"`([A-Za-z_][A-Za-z0-9_]*)`", text))


def test_every_json_summary_key_is_documented(readme, repo_root):
    prog = repo_root / "programs" / "bore_d25_f5984.mpf"
    s = json.loads(CliRunner().invoke(cli, ["run", str(prog), "-m", "mikron", "--json",
                                            "--crosscheck"]).stdout)
    keys = set(s) | set(s["model"]) | set(s["feeds"][0]) | set(s["blocks_detail"][0]) \
        | set(s["slowest_blocks"][0]) | set(s["lost_by_cause"][0]) | (set(s["crosscheck"]) - {"reasons"})
    documented = _documented(section(readme, "JSON summary"))
    assert keys - documented == set()


def test_every_csv_column_and_limit_is_documented(readme):
    from ncsim.report.csvio import ALL_COLUMNS
    from ncsim.motion import LIMIT_LABELS
    assert set(ALL_COLUMNS) - _documented(section(readme, "CSV trace")) == set()
    assert set(LIMIT_LABELS) - _documented(section(readme, "JSON summary")) == set()


def test_every_machine_file_key_is_documented(readme, repo_root):
    from ncsim import machine
    text = section(readme, "Machine file")
    documented = _documented(text)
    data = tomllib.loads((repo_root / "machines" / "mikron.toml").read_text())
    keys = {k for table in data.values() for k in table if not isinstance(table[k], dict)}
    keys |= {k for axis in data["axes"].values() for k in axis}
    keys |= {k for k, *_ in machine._AXIS_KEYS + machine._NCU_KEYS + machine._STRUCTURE_KEYS
             + machine._TOOL_CHANGE_KEYS}
    keys |= set(machine._NCU_OTHER_KEYS)
    assert keys - documented == set()
    for md in ("MD32000", "MD32300", "MD32431", "MD10050"):
        assert md in text


def test_exit_codes_and_reserved_sections(readme):
    from ncsim.errors import ExitStatus
    table = section(readme, "Exit codes")
    for status in ExitStatus:
        assert re.search(rf"^\| {int(status)} \|", table, re.M), status
    for heading in ("Speed and scale", "Sim-to-real gap diagnosis", "Development"):
        section(readme, heading)


# ---------------------------------------------------------------------------------------------
# The Python API example and the real program's run excerpt
# ---------------------------------------------------------------------------------------------

def test_python_api_example_runs_as_written(readme, repo_root, monkeypatch, capsys):
    """The README's Python example, run in the checkout, prints what the README shows."""
    text = section(readme, "Python API")
    code = fenced(text, "python")
    assert len(code) == 1 and "ncsim.simulate(" in code[0]
    monkeypatch.chdir(repo_root)
    exec(compile(code[0], "README.md (Python API)", "exec"), {})
    assert capsys.readouterr().out == fenced(text, "text")[0]


def test_real_program_run_excerpt_is_real(readme, repo_root, monkeypatch, shared):
    """The lines shown of `ncsim run` on the THWS bottle opener are lines of its output."""
    text = section(readme, "Worked example: the 25 mm bore")
    i = text.index("`ncsim run` names the operations and tools")
    excerpt = text[text.index("```text\n", i) + 8:text.index("```", text.index("```text\n", i) + 8)]
    monkeypatch.chdir(repo_root)
    r = CliRunner().invoke(cli, ["run", THWS_COMMAND.split()[2], "--machine", "mikron", "-q"])
    assert r.exit_code == 0, r.output
    shown = [line for line in excerpt.splitlines() if line.strip()]
    assert len(shown) >= 10
    assert [line for line in shown if line not in r.stdout.splitlines()] == [], \
        "refresh the README's excerpt of the bottle opener's run"
