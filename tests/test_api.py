"""The public API of ``import ncsim``: its names, its docstring example, and a lean import."""
from __future__ import annotations

import doctest
import subprocess
import sys

import pytest

import ncsim

HEAVY = ("matplotlib", "scipy", "dask", "distributed", "numba", "lark", "ncsim.gap", "ncsim.plan")


def test_every_public_name_resolves():
    for name in ncsim.__all__:
        assert getattr(ncsim, name) is not None, name
    assert callable(ncsim.simulate) and callable(ncsim.diagnose) and callable(ncsim.load_machine)
    assert set(ncsim.__all__) <= set(dir(ncsim))
    with pytest.raises(AttributeError, match="no attribute 'nonesuch'"):
        ncsim.nonesuch  # noqa: B018


def test_docstring_example_runs(repo_root, monkeypatch):
    """The example of ``help(ncsim)``: the paper's R 2.5 mm circle (Table 3: 2.01 m/min)."""
    monkeypatch.chdir(repo_root)
    result = doctest.testmod(ncsim, verbose=False, report=True)
    assert result.attempted >= 5 and result.failed == 0


@pytest.mark.parametrize("code", [
    "import ncsim",
    "from click.testing import CliRunner\nfrom ncsim.cli.main import cli\n"
    "r = CliRunner().invoke(cli, ['--help'])\nassert r.exit_code == 0, r.output",
])
def test_import_and_help_stay_lean(code):
    """Neither ``import ncsim`` nor ``ncsim --help`` loads plotting, SciPy, Dask, numba, the
    parser, the planner or the gap diagnosis."""
    probe = code + f"\nimport sys\nprint([m for m in sys.modules if m.split('.')[0] in {HEAVY!r} " \
                   f"or m.startswith({HEAVY!r})])"
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]"


def test_simulate_reports_its_stages_and_reads_a_setup_file(repo_root, tmp_path, mikron):
    program = repo_root / "programs" / "circle_r30_f6000.mpf"
    stages = []
    sim = ncsim.simulate(program, mikron, progress=stages.append)
    assert stages == ["interpret", "plan"] and sim.cycle_time_s > 0
    # a setup file's work offset moves the programmed point: X10 Y0 under G54 = (10, 20, 30)
    # ends at machine (20, 20); Z is not programmed, so the machine's Z stays at 0
    setup = tmp_path / "setup.toml"
    setup.write_text("[work_offsets]\nG54 = [10, 20, 30]\n")
    sim = ncsim.simulate("offset.mpf", mikron, text="G54 G1 X10 Y0 F1000\nM30\n", setup_offsets=setup)
    assert sim.path.end_mm[-1].tolist() == [20.0, 20.0, 0.0]
