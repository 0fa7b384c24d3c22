"""`ncsim parse`: one line per segment and a summary; warnings on stderr; errors exit 2 in one line."""
from __future__ import annotations

import json

import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from ncsim.cli.main import cli
# imported with this module: its @given decorators run then, not nested in a @given test (a
# nested @given fails hypothesis's health check when this file runs alone)
from test_plan_reference import random_program


def invoke(*args):
    return CliRunner().invoke(cli, ["parse", *map(str, args)])


@pytest.fixture
def program(tmp_path):
    p = tmp_path / "part.mpf"
    p.write_text("G17 G90 G64 SOFT\nG0 X0 Y0 Z5\nG1 Z0 F600\nG3 X10 Y0 I5 J0\nG54 G1 X12\nB30\nM30\n")
    return p


def test_lists_segments_and_summary(program):
    r = invoke(program)
    assert r.exit_code == 0, r.stderr
    out = r.stdout.splitlines()
    assert len(out) == 5
    assert out[1].split()[1].endswith("part.mpf:3") and "feed_mm_min=600" in out[1]
    arc = out[2]
    assert " arc " in arc and "centre=(5.0000, 0.0000, 0.0000)" in arc and "radius_mm=5.0000" in arc
    assert "sweep_deg=180.000" in arc and "SOFT" in arc and "G64" in arc
    assert "G0" in out[0].split() and "feed_mm_min=rapid" in out[0]
    assert out[-1].startswith("segments: 4 (3 lines, 1 arcs)  total length: 27.708 mm")
    # warnings: G54 without offsets, rotary axis B
    assert [w.split(": warning: ")[0] for w in r.stderr.splitlines()] == [
        f"{program}:5:1", f"{program}:6:1"]


def test_limit_and_json(program):
    r = invoke(program, "--limit", 1)
    assert r.exit_code == 0 and len(r.stdout.splitlines()) == 3 and "3 more segments" in r.stdout
    data = json.loads(invoke(program, "--json", "--limit", 2).stdout)
    assert [s["kind"] for s in data["segments"]] == ["line", "line"]
    assert data["segments"][1]["feed_mm_min"] == pytest.approx(600)
    assert data["summary"]["segments"] == 4 and data["summary"]["arcs"] == 1
    assert len(data["warnings"]) == 2


def test_setup_file_and_machine(program, tmp_path):
    setup = tmp_path / "setup.toml"
    setup.write_text("[work_offsets]\nG54 = [100.0, 0.0, 0.0]\n")
    data = json.loads(invoke(program, "--machine", "mikron", "--setup", setup, "--json").stdout)
    assert data["segments"][3]["end_mm"] == [112.0, 0.0, 0.0]
    assert len(data["warnings"]) == 1


@pytest.mark.parametrize("text, where", [
    ("G1 X1 F100\nG1 X=(\n", "2:7: unexpected end of block"),
    ("G1 X1\n", "1:1: G1 without a feed"),
    ("G1 F100\nG2 X5 Y5\n", "2:1: G2 without centre"),
    ("G1 X5 F100\nG3 X-5.1 I-5\n", "2:1: circle end point error"),
    ("R1=1/0\n", "1:5: division by zero"),
    ("GOTOF NOWHERE\n", "1:7: jump destination NOWHERE not found"),
    ("G1 Q1\n", "1:4: unknown word Q"),
])
def test_errors_exit_2_with_one_located_line(tmp_path, text, where):
    p = tmp_path / "bad.mpf"
    p.write_text(text)
    r = invoke(p)
    assert r.exit_code == 2
    assert r.stdout == ""
    assert r.stderr.splitlines() == [r.stderr.strip()] and r.stderr.startswith(f"{p}:{where}")
    assert "Traceback" not in r.stderr


def test_missing_files_and_bad_setup(tmp_path, program):
    r = invoke(tmp_path / "nope.mpf")
    assert r.exit_code == 2 and "cannot read program" in r.stderr
    bad = tmp_path / "setup.toml"
    bad.write_text("[work_offsets]\nG54 = 5\n")
    r = invoke(program, "--setup", bad)
    assert r.exit_code == 2 and r.stderr.strip() == f"{bad}: work_offsets.G54: must be a list of three numbers [x_mm, y_mm, z_mm]"
    r = invoke(program, "--machine", "no_such_machine")
    assert r.exit_code == 2 and "no_such_machine" in r.stderr


def test_endless_loop_exits_2_at_its_line(tmp_path):
    """The block budget (--block-budget) stops a loop with one line at the jump that closes it
    (a loop whose jump tests a condition: one that decides nothing stops at its second pass)."""
    p = tmp_path / "loop.mpf"
    p.write_text("G1 F100\nTOP: G91 X1\nIF R1==0 GOTOB TOP\n")
    r = invoke(p, "--block-budget", "50")
    assert r.exit_code == 2
    # blocks: line 1, then lines 2, 3, 2, 3, ...: block 51 is line 3, after 24 jumps back
    assert r.stderr.strip() == (f"{p}:3:10: block budget of 50 blocks exceeded: endless loop? this "
                                f"jump back was taken 24 times (--block-budget N allows more)")


# ---------------------------------------------------------------------------------------------
# The row writer (report.pathtext) against Python's own formatting of each segment
# ---------------------------------------------------------------------------------------------

def _python_lines(path) -> list[str]:
    """Python's f-string lines; the writer never writes a minus sign on a value that rounds
    to zero (Python writes -0.0000 for -1e-9)."""
    from ncsim.report.pathtext import segment_text
    return [segment_text(path, i).replace("-0.0000", "0.0000") for i in range(path.n)]


def test_the_row_writer_writes_what_python_formats(repo_root):
    from ncsim.nc.interpret import interpret_file
    from ncsim.report.pathtext import format_segments
    for program in sorted((repo_root / "programs").glob("*.mpf")):
        path = interpret_file(str(program)).path
        assert format_segments(path).decode().splitlines() == _python_lines(path), program


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(0, 2**31 - 1), st.integers(1, 60), st.sampled_from(["G64", "G641 ADIS=0.25",
                                                                       "G60", "G64 G9"]))
def test_the_row_writer_writes_what_python_formats_on_random_programs(seed, n_blocks, mode):
    import numpy as np

    from ncsim.nc.interpret import interpret_text
    from ncsim.report.pathtext import format_segments
    text = random_program(np.random.default_rng(seed), n_blocks).replace("G64", mode, 1)
    text = text.replace("G0 X0 Y0 Z0", "G0 X0 Y0 Z0\nG1 Z1 F777.5\nG2 X0 Y0 Z0 I1 J0", 1)
    path = interpret_text(text, "random.mpf").path
    assert format_segments(path).decode().splitlines() == _python_lines(path)


def test_values_beyond_the_integer_path_are_written_by_python(program):
    import numpy as np

    from ncsim.nc.interpret import interpret_file
    from ncsim.report.pathtext import format_segments, segment_text
    path = interpret_file(str(program)).path
    far = path.replace_columns(end_mm=np.where(np.arange(path.n)[:, None] == 1, 1e16, path.end_mm))
    lines = format_segments(far).decode().splitlines()
    assert lines == [segment_text(far, i) for i in range(far.n)]
    assert "10000000000000000.0000" in lines[1]


def test_chunks_and_limit(program, monkeypatch):
    import io

    from ncsim.nc.interpret import interpret_file
    from ncsim.report import pathtext
    path = interpret_file(str(program)).path
    whole = pathtext.format_segments(path)
    monkeypatch.setattr(pathtext, "CHUNK_ROWS", 3)
    out = io.BytesIO()
    assert pathtext.write_segments(path, out) == path.n and out.getvalue() == whole
    out = io.BytesIO()
    assert pathtext.write_segments(path, out, limit=2) == 2
    assert out.getvalue().decode().splitlines() == whole.decode().splitlines()[:2]
