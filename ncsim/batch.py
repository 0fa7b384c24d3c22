"""Run many programs: parallel processes on this machine, or a Dask distributed cluster.

Each program is simulated in its own task (``simulate_one``); a task never raises for a bad
program: the error's one-line rendering is part of its result, so one broken file does not
stop a CI batch. Results come back in completion order and are reported in input order.
"""
from __future__ import annotations

import glob
import os
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import asdict, dataclass
from typing import Callable, Iterable

from ncsim.errors import NcsimError, UsageError
from ncsim.machine import MachineSpec
from ncsim.motion import FULL_MODEL, ModelOptions


@dataclass(frozen=True)
class BatchResult:
    program: str
    ok: bool
    cycle_time_s: float | None = None
    blocks: int | None = None
    path_length_mm: float | None = None
    feed_efficiency: float | None = None
    limited_fraction: float | None = None
    warnings: int = 0
    error: str | None = None
    elapsed_s: float = 0.0
    worker: str = ""

    def to_dict(self) -> dict:
        return asdict(self)


def expand_programs(patterns: Iterable[str]) -> list[str]:
    """Files matching the patterns (glob, recursive ``**``), each once, in a stable order."""
    seen: dict[str, None] = {}
    for pattern in patterns:
        matches = sorted(glob.glob(pattern, recursive=True)) if glob.has_magic(pattern) else [pattern]
        if not matches:
            raise UsageError(f"no program matches {pattern!r}")
        for m in matches:
            seen.setdefault(m, None)
    return list(seen)


def simulate_one(program: str, machine: MachineSpec, options: ModelOptions = FULL_MODEL) -> BatchResult:
    """Simulate one program and summarise it (runs in a worker process)."""
    from ncsim.report.summary import summary
    from ncsim.simulate import simulate

    t0 = time.perf_counter()
    worker = f"{os.uname().nodename}:{os.getpid()}"
    try:
        sim = simulate(program, machine, options)
        s = summary(sim, top=0, include_blocks=False)
        return BatchResult(program=program, ok=True, cycle_time_s=s["cycle_time_s"],
                           blocks=s["blocks"], path_length_mm=s["path_length_mm"],
                           feed_efficiency=s["feed_efficiency"],
                           limited_fraction=s["limited_fraction"], warnings=len(s["warnings"]),
                           elapsed_s=time.perf_counter() - t0, worker=worker)
    except NcsimError as exc:
        return BatchResult(program=program, ok=False, error=exc.render(),
                           elapsed_s=time.perf_counter() - t0, worker=worker)
    except OSError as exc:
        return BatchResult(program=program, ok=False, error=f"{program}: {exc.strerror or exc}",
                           elapsed_s=time.perf_counter() - t0, worker=worker)


def run_batch(programs: list[str], machine: MachineSpec, options: ModelOptions = FULL_MODEL, *,
              jobs: int = 1, scheduler: str | None = None,
              on_result: Callable[[BatchResult], None] | None = None) -> list[BatchResult]:
    """Simulate ``programs`` with ``jobs`` local processes, or on the Dask scheduler at
    ``scheduler`` (``tcp://host:port``); ``on_result`` is called as each one finishes."""
    if jobs < 1:
        raise UsageError("--jobs must be at least 1")
    results: dict[str, BatchResult] = {}

    def done(res: BatchResult) -> None:
        results[res.program] = res
        if on_result is not None:
            on_result(res)

    if scheduler:
        _run_dask(programs, machine, options, scheduler, done)
    elif jobs == 1 or len(programs) <= 1:
        for prog in programs:
            done(simulate_one(prog, machine, options))
    else:
        with ProcessPoolExecutor(max_workers=jobs) as pool:
            futures = [pool.submit(simulate_one, prog, machine, options) for prog in programs]
            for fut in as_completed(futures):
                done(fut.result())
    return [results[p] for p in programs]


def _run_dask(programs, machine, options, scheduler: str, done) -> None:
    try:
        from distributed import Client, as_completed as dask_completed
    except ImportError:  # pragma: no cover - depends on the install
        raise UsageError("--scheduler needs Dask: pip install 'ncsim[dask]'") from None
    try:
        client = Client(scheduler, timeout="10s")
    except (OSError, TimeoutError) as exc:
        raise UsageError(f"cannot reach the Dask scheduler at {scheduler}: {exc}") from None
    try:
        futures = client.map(simulate_one, programs, machine=machine, options=options, pure=False)
        for fut in dask_completed(futures):
            done(fut.result())
    finally:
        client.close()
