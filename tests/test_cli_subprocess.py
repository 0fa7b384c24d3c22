"""The installed `ncsim` console script, run as a separate process from a foreign directory."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest


def ncsim_script() -> str:
    """The console script installed next to this interpreter (the venv's bin/), else on PATH."""
    here = Path(sys.executable).parent / ("ncsim.exe" if os.name == "nt" else "ncsim")
    found = str(here) if here.exists() else shutil.which("ncsim")
    assert found, "the ncsim console script is not installed (pip install .)"
    return found


def run(*args, cwd):
    return subprocess.run([ncsim_script(), *map(str, args)], cwd=cwd, capture_output=True,
                          text=True, timeout=120)


def test_run_prints_the_cycle_time_and_the_limit(repo_root, tmp_path):
    prog = repo_root / "programs" / "circle_r2p5_f6000.mpf"
    r = run("run", prog, "--machine", "mikron", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert r.stderr == ""                        # stderr is a pipe: no progress bar
    assert "cycle time" in r.stdout
    # the R 2.5 circle is held at 2.01 m/min by the NCU path jerk (paper Table 3)
    row = next(line for line in r.stdout.splitlines() if line.strip().startswith("6000"))
    assert float(row.split()[2]) == pytest.approx(2010, abs=5)
    assert any("circle_r2p5_f6000.mpf:" in line and "ncu_path_jerk" in line for line in r.stdout.splitlines())
    assert not list(tmp_path.iterdir())          # nothing written to the working directory


def test_bad_program_is_one_line_on_stderr_and_exit_2(tmp_path):
    bad = tmp_path / "bad.mpf"
    bad.write_text("G1 X10 F1000\nG1 X=(2\n")
    r = run("run", bad.name, "--machine", "mikron", cwd=tmp_path)
    assert r.returncode == 2
    assert r.stdout == ""
    assert len(r.stderr.splitlines()) == 1
    assert r.stderr.startswith("bad.mpf:2:") and "Traceback" not in r.stderr


def test_run_does_not_import_matplotlib(repo_root):
    """`ncsim run` stays lean: matplotlib is imported only by `plot` and `explain --plot`."""
    code = ("import sys\nfrom click.testing import CliRunner\nfrom ncsim.cli.main import cli\n"
            f"r = CliRunner().invoke(cli, ['run', {str(repo_root / 'programs' / 'circle_r30_f6000.mpf')!r},"
            " '-m', 'mikron'])\nassert r.exit_code == 0, r.output\n"
            "print('matplotlib' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "False"


def test_python_dash_m(tmp_path):
    r = subprocess.run([sys.executable, "-m", "ncsim", "--version"], cwd=tmp_path,
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 0 and r.stdout.strip() == "ncsim, version 0.1.0"


def test_a_python_warning_reaching_the_user_is_one_line(tmp_path):
    """None should (inputs are validated; the suite turns RuntimeWarnings into errors), but a
    warning that does reach stderr is one line, without Python's source line under it."""
    code = ("import sys, numpy as np; from ncsim.cli import main as m; "
            "m.cli.add_command(m.click.Command('nan', callback=lambda: np.float64(0) / 0)); "
            "sys.argv = ['ncsim', 'nan']; m.main()")
    r = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True,
                       timeout=120)
    assert r.returncode == 0, r.stderr
    assert r.stderr.splitlines() == ["ncsim: warning: RuntimeWarning: invalid value encountered in "
                                     "scalar divide (<string>:1)"]
