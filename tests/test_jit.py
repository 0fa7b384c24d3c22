"""Kernels run as plain Python below a size and compiled above (``ncsim.jit``): the same results
either way, numba never imported by a small run, and its first compilation announced.

The property tests are the guarantee behind the size switch: on random programs (lines, arcs,
dwells, exact stops, SOFT/BRISK changes, look-ahead depths from 1 to 100) the plain-Python
kernels and numba's compiled ones give bit-identical paths, feed laws, traces, CSV bytes,
``ncsim parse`` lines and summaries, and the scanner reads random near-plain lines identically.
"""
from __future__ import annotations

import dataclasses
import io
import json
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from ncsim import jit
from ncsim.errors import UsageError
from ncsim.machine import load_machine
from ncsim.motion import ModelOptions
from ncsim.nc import fastparse
from ncsim.pipeline import simulate, warmup, warmup_program
from ncsim.plan import _kernels as K
from ncsim.plan.sample import sample_motion
from ncsim.report.csvio import write_trace_csv
from ncsim.report.pathtext import format_segments
from ncsim.report.summary import summary
from test_fastpath import near_plain_lines
from test_plan_reference import random_program

SETTINGS = settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def _same(a, b, where: str) -> None:
    if isinstance(a, np.ndarray):
        assert a.dtype == b.dtype and a.shape == b.shape, where
        assert np.array_equal(a, b, equal_nan=a.dtype.kind == "f"), where
    else:
        assert a == b or (a != a and b != b), where


def _run(which: str, text: str, machine, options):
    with jit.forced(which):
        sim = simulate("random.mpf", machine, options, text=text)
        trace = sample_motion(sim.motion)
        out = io.BytesIO()
        write_trace_csv(trace, out, columns="all")
        out.write(format_segments(sim.path))
        out.write(json.dumps(summary(sim, top=20)).encode())
    return sim, trace, out.getvalue()


@SETTINGS
@given(st.integers(0, 2**31 - 1), st.integers(5, 60), st.sampled_from([1, 2, 5, 100]),
       st.booleans(), st.booleans())
def test_plain_and_compiled_kernels_agree_bit_for_bit(seed, n_blocks, depth, lookahead, jerk):
    machine = load_machine("mikron").with_ncu(lookahead_blocks=depth)
    options = ModelOptions(lookahead=lookahead, jerk_limited_ramps=jerk)
    text = random_program(np.random.default_rng(seed), n_blocks)
    sim_py, trace_py, csv_py = _run("python", text, machine, options)
    sim_nb, trace_nb, csv_nb = _run("compiled", text, machine, options)
    for f in dataclasses.fields(sim_py.motion):
        if f.name == "path":
            continue
        _same(getattr(sim_py.motion, f.name), getattr(sim_nb.motion, f.name), f.name)
    for f in dataclasses.fields(sim_py.path):
        _same(getattr(sim_py.path, f.name), getattr(sim_nb.path, f.name), f"path.{f.name}")
    for f in dataclasses.fields(trace_py):
        _same(getattr(trace_py, f.name), getattr(trace_nb, f.name), f"trace.{f.name}")
    assert csv_py == csv_nb


@SETTINGS
@given(st.lists(near_plain_lines(), min_size=1, max_size=12), st.sampled_from(["\n", ""]))
def test_the_scanner_reads_the_same_either_way(lines, end):
    text = "\n".join(lines) + end
    with jit.forced("python"):
        plain_py = fastparse.scan_plain(text)
    with jit.forced("compiled"):
        plain_nb = fastparse.scan_plain(text)
    for i, (a, b) in enumerate(zip(plain_py, plain_nb)):
        if isinstance(a, bytes):
            assert a == b
        else:
            _same(a, b, f"column {i}")


def test_the_warmup_program_uses_every_planner_kernel_path():
    """The creep, the knot removal and the exact stops of the warm-up program run (so that
    ``ncsim warmup`` compiles every specialization a real run needs; see the next test)."""
    text = warmup_program()
    sim = simulate("warmup.mpf", load_machine("mikron").with_ncu(lookahead_blocks=3), text=text)
    assert sim.path.n > 400 and (sim.path.kind == 1).sum() >= 8
    assert sim.path.exact_stop.any() and (sim.motion.junction_dwell_s > 0).any()


def test_after_warmup_no_run_compiles_a_new_specialization(paper_program_paths):
    """Every signature a run uses is one ``warmup`` compiled: after it, simulating other
    programs (and writing their traces) adds no specialization to any kernel."""
    warmup()
    before = {k: len(k.compiled.signatures) for k in jit.kernels()}
    machine = load_machine("mikron")
    rng = np.random.default_rng(7)
    texts = [random_program(rng, 300)] + [open(p).read() for p in paper_program_paths]
    for depth in (1, 100):
        for text in texts:
            _run("compiled", text, machine.with_ncu(lookahead_blocks=depth), ModelOptions())
    after = {k: len(k.compiled.signatures) for k in jit.kernels()}
    assert after == before


@pytest.fixture
def paper_program_paths(repo_root):
    return sorted(str(p) for p in (repo_root / "programs").glob("*.mpf"))[:6]


# ---------------------------------------------------------------------------------------------
# The switch
# ---------------------------------------------------------------------------------------------

def test_small_calls_run_plain_python_and_large_ones_compiled(monkeypatch):
    monkeypatch.setattr(jit, "_active", False)
    monkeypatch.delenv("NCSIM_KERNELS", raising=False)
    k = K.peak_feeds
    assert k.pick(10) is k.py and k.pick(k.python_below - 1) is k.py
    assert k.pick(k.python_below) is not k.py
    with jit.forced("compiled"):
        assert k.pick(1) is not k.py
    with jit.forced("python"):
        assert k.pick(10**9) is k.py
    monkeypatch.setenv("NCSIM_KERNELS", "compiled")
    assert k.pick(1) is not k.py
    monkeypatch.setattr(jit, "_active", True)  # numba already paid for: compiled from then on
    monkeypatch.setenv("NCSIM_KERNELS", "auto")
    assert k.pick(1) is not k.py


def test_a_bad_kernels_setting_is_one_usage_error(monkeypatch):
    monkeypatch.setenv("NCSIM_KERNELS", "fast")
    with pytest.raises(UsageError, match="NCSIM_KERNELS must be one of auto, python, compiled"):
        jit.mode()


def test_plain_kernels_call_plain_kernels():
    """The plain version of a kernel calls the plain versions of the kernels it uses (no
    dispatch per nested call), the compiled one numba's dispatchers."""
    plain = K.peak_feed_scalar.py
    assert plain.__globals__["_peak_excess"] is K._peak_excess.py
    assert plain.__globals__["reach_gain_scalar"] is K.reach_gain_scalar.py
    assert K.peak_feeds.py.__globals__["peak_feed_scalar"] is plain
    assert type(K.peak_feeds.compiled.py_func.__globals__["peak_feed_scalar"]).__name__ == "CPUDispatcher"


# ---------------------------------------------------------------------------------------------
# Start-up: what a run imports, and the notice of a first compilation
# ---------------------------------------------------------------------------------------------

HEAVY = ("numba", "llvmlite", "scipy", "matplotlib", "dask", "distributed", "ruckig")


def _python(code: str, **env) -> subprocess.CompletedProcess:
    environ = {k: v for k, v in os.environ.items() if k != "NCSIM_KERNELS"}
    environ.update(env)
    return subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True,
                          text=True, env=environ, timeout=300)


def test_a_small_run_and_help_import_no_heavy_package(repo_root):
    """``ncsim run`` on a paper program and ``ncsim --help`` load neither numba nor scipy,
    matplotlib, dask or ruckig, nor any gap module."""
    code = f"""
        import sys
        from ncsim.cli.main import cli
        for args in (["--help"], ["run", {str(repo_root / 'programs' / 'bore_d25_f5984.mpf')!r},
                                  "--machine", "mikron"], ["parse", {str(repo_root / 'programs' / 'circle_r30_f6000.mpf')!r}]):
            try:
                cli.main(args, prog_name="ncsim", standalone_mode=False)
            except SystemExit:
                pass
            loaded = sorted({{m.partition(".")[0] for m in sys.modules}} & set({HEAVY!r}))
            gap = sorted(m for m in sys.modules if m.startswith("ncsim.gap"))
            print(args[0], loaded, gap, file=sys.stderr)
        """
    r = _python(code)
    assert r.returncode == 0, r.stderr
    assert r.stderr.splitlines() == ["--help [] []", "run [] []", "parse [] []"]


def test_the_first_compilation_is_announced_once_on_stderr(tmp_path):
    """A kernel numba has not cached yet: the CLI says so on stderr (not a terminal here),
    once, before compiling; the second process loads it from the cache and says nothing."""
    (tmp_path / "toykernels.py").write_text(textwrap.dedent("""
        from ncsim.jit import njit

        @njit(cache=True)
        def twice(x):
            return x * 2.0

        @njit(cache=True)
        def total(a):
            s = 0.0
            for v in a:
                s += twice(v)
            return s
        """))
    code = f"""
        import sys
        import click
        import numpy as np
        sys.path.insert(0, {str(tmp_path)!r})
        from ncsim.cli.main import cli
        import toykernels

        @cli.command("toy")
        def toy():
            click.echo(toykernels.total(np.ones(10**5)))
            click.echo(toykernels.total(np.ones(10**5)))

        cli.main(["toy"], prog_name="ncsim", standalone_mode=False)
        """
    env = dict(NUMBA_CACHE_DIR=str(tmp_path / "cache"))
    first, second = _python(code, **env), _python(code, **env)
    assert first.returncode == 0 and second.returncode == 0, first.stderr + second.stderr
    assert first.stdout == second.stdout == "200000.0\n200000.0\n"
    assert first.stderr.splitlines() == [jit.COMPILE_NOTICE]
    assert second.stderr == ""
