"""The pipeline in one call: program -> path (interpret) -> limits -> feed law (plan).

:func:`simulate` runs one program; :func:`run_batch` runs many, in parallel processes on this
machine or on a Dask distributed cluster. A cluster's workers may run on other machines, so
they get each program as text with the subprogram files it calls (:func:`program_source`),
never a path. Sampling (``ncsim.plan.sample``) is left to the
caller: a summary needs only the planned motion, which keeps million-block runs cheap.

Batch runs simulate each program in its own task (:func:`simulate_one`); a task never raises
for a bad program: the error's one-line rendering is part of its result, so one broken file
does not stop a CI batch. Results come back in completion order and are reported in input
order. Local worker processes end with the batch, also when it is interrupted or killed
(:func:`_run_processes`). Running out of memory in a stage is one
:class:`~ncsim.errors.OutOfMemory` naming the program and the stage.
"""
from __future__ import annotations

import glob
import os
import re
import signal
import threading
import time
from contextlib import contextmanager
from dataclasses import asdict, dataclass, field, replace
from functools import partial
from pathlib import Path as FsPath
from typing import Callable, Iterable

from ncsim.errors import ConfigWarning, NcsimError, NcWarning, OutOfMemory, UsageError
from ncsim.machine import MachineSpec, load_machine
from ncsim.motion import FULL_MODEL, ModelOptions, Motion
from ncsim.nc.interpret import InterpretResult, interpret_file, interpret_text
from ncsim.path import Path
from ncsim.plan.limits import PathLimits, path_limits
from ncsim.plan.lookahead import plan

#: the stages :func:`simulate` reports to its ``progress`` callback, in order
STAGES = ("interpret", "plan")


@dataclass(frozen=True)
class Simulation:
    program: str
    machine: MachineSpec
    options: ModelOptions
    interpreted: InterpretResult | None
    limits: PathLimits | None          # None once let go (``ncsim run`` does, before reporting)
    motion: Motion
    stage_time_s: dict[str, float] = field(default_factory=dict)

    @property
    def path(self) -> Path:
        return self.motion.path

    @property
    def warnings(self) -> tuple[ConfigWarning | NcWarning, ...]:
        """The machine file's (unusual values), then the program's."""
        program = self.interpreted.warnings if self.interpreted is not None else ()
        return tuple(self.machine.warnings) + tuple(program)

    @property
    def cycle_time_s(self) -> float:
        return self.motion.total_time_s


def release_freed_memory() -> None:
    """Return the memory the last stage freed to the system (glibc's ``malloc_trim``; a no-op
    where there is none). A stage's temporaries are freed into the C heap, which keeps them:
    without this, a million-block run would hold each stage's leftovers while the next one
    allocates, and its peak would be that sum instead of the largest stage. Calling it costs
    microseconds; the next stage faults in the pages it reuses."""
    trim = _malloc_trim()
    if trim is not None:
        trim(0)


def _malloc_trim():
    libc = _libc()
    return getattr(libc, "malloc_trim", None) if libc is not None else None


def _libc():
    global _LIBC
    if _LIBC is False:
        try:
            import ctypes
            _LIBC = ctypes.CDLL(None)
        except (OSError, TypeError):      # no C library to load by name (Windows)
            _LIBC = None
    return _LIBC


_LIBC = False


@contextmanager
def out_of_memory(program: str | FsPath, doing: str):
    """A MemoryError inside becomes :class:`~ncsim.errors.OutOfMemory` naming ``program`` and
    what was being done (the arrays that failed are freed by then: the message costs little)."""
    try:
        yield
    except MemoryError as exc:
        raise OutOfMemory.of(str(program), doing, exc) from None


def resolve_machine(machine: MachineSpec | str | FsPath) -> MachineSpec:
    return machine if isinstance(machine, MachineSpec) else load_machine(machine)


def simulate(program: str | FsPath, machine: MachineSpec | str | FsPath,
             options: ModelOptions = FULL_MODEL, *, text: str | None = None,
             setup_offsets: dict | str | FsPath | None = None,
             progress: Callable[[str], None] | None = None,
             search_dir: str | FsPath | None = None,
             nc_options: dict | None = None) -> Simulation:
    """Interpret ``program`` (a file, or ``text`` named ``program``, whose subprogram files are
    looked up in ``search_dir``) and plan it on ``machine`` (a :class:`MachineSpec`, a TOML
    file or a bundled machine's name).

    ``setup_offsets`` are work offsets (``{"G54": (x, y, z)}``) or a setup TOML file that gives
    them (:func:`ncsim.config.load_setup`). ``progress`` is called with the name of each stage
    of :data:`STAGES` as it begins (e.g. to draw a progress bar). ``nc_options`` are keyword
    options of :func:`ncsim.nc.interpret.interpret_text` (``subprograms``,
    ``missing_subprograms``, ``definitions``, ``block_budget``)."""
    from ncsim.config import load_setup

    spec = resolve_machine(machine)
    if isinstance(setup_offsets, (str, FsPath)):
        setup_offsets = load_setup(setup_offsets)
    if progress is not None:
        progress("interpret")
    t0 = time.perf_counter()
    nc_options = nc_options or {}
    with out_of_memory(program, "interpreting it"):
        if text is None:
            result = interpret_file(program, spec, setup_offsets=setup_offsets, **nc_options)
        else:
            result = interpret_text(text, str(program), spec, setup_offsets=setup_offsets,
                                    search_dir=search_dir, **nc_options)
    t1 = time.perf_counter()
    release_freed_memory()
    if progress is not None:
        progress("plan")
    with out_of_memory(program, "planning its motion"):
        sim = simulate_path(result.path, spec, options, program=str(program))
    stages = {"interpret_s": t1 - t0, **sim.stage_time_s}
    return Simulation(program=str(program), machine=spec, options=options, interpreted=result,
                      limits=sim.limits, motion=sim.motion, stage_time_s=stages)


def simulate_path(path: Path, machine: MachineSpec | str | FsPath,
                  options: ModelOptions = FULL_MODEL, *, program: str = "<path>") -> Simulation:
    """Plan an already interpreted path: limits, then the look-ahead feed law."""
    spec = resolve_machine(machine)
    t0 = time.perf_counter()
    limits = path_limits(path, spec, options)
    release_freed_memory()
    t1 = time.perf_counter()
    motion = plan(path, spec, options, limits=limits)
    release_freed_memory()
    t2 = time.perf_counter()
    return Simulation(program=program, machine=spec, options=options, interpreted=None,
                      limits=limits, motion=motion,
                      stage_time_s={"limits_s": t1 - t0, "plan_s": t2 - t1})


# ---------------------------------------------------------------------------------------------
# Many programs
# ---------------------------------------------------------------------------------------------

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


@dataclass(frozen=True)
class ProgramSource:
    """A program as text, with the subprogram files beside it that it may call: all a worker
    on another machine needs (it cannot read the client's paths)."""

    program: str                     # the name as given (results and errors use it)
    text: str
    subprograms: dict[str, str] = field(default_factory=dict)   # file name -> text


_SUBPROGRAM_SUFFIXES = (".spf", ".mpf")
_NAME = re.compile(r"[A-Z_][A-Z0-9_]*")


def program_source(program: str) -> ProgramSource:
    """Read ``program`` and every file beside it that a name in it (or in such a file, and so
    on) could call: ``NAME.SPF``/``NAME.MPF`` for any word ``NAME`` of the text, as the
    interpreter looks them up. Reads more than needed rather than less (a word in a comment
    brings its file too)."""
    from ncsim.nc.parse import read_program_text

    path = FsPath(program)
    text = read_program_text(path)
    try:
        beside = {p.stem.upper(): p for p in path.parent.iterdir()
                  if p.suffix.lower() in _SUBPROGRAM_SUFFIXES and p.is_file() and p != path}
    except OSError:
        beside = {}
    files: dict[str, str] = {}
    todo = [text]
    while todo:
        for name in set(_NAME.findall(todo.pop().upper())):
            for p in [q for stem, q in beside.items() if stem == name and q.name not in files]:
                files[p.name] = read_program_text(p)
                todo.append(files[p.name])
    return ProgramSource(str(program), text, files)


def simulate_source(source: ProgramSource, machine: MachineSpec,
                    options: ModelOptions = FULL_MODEL) -> BatchResult:
    """:func:`simulate_one` of a program sent as text (runs on a Dask worker anywhere): its
    subprograms are written to a scratch folder for the interpreter's lookup; errors in them
    name them as the client knows them."""
    import tempfile

    with tempfile.TemporaryDirectory(prefix="ncsim-") as scratch:
        for name, text in source.subprograms.items():
            (FsPath(scratch) / name).write_text(text, encoding="utf-8")
        result = simulate_one(source.program, machine, options, text=source.text,
                              search_dir=scratch)
    if result.error and scratch in result.error:
        here = str(FsPath(source.program).parent)
        result = replace(result, error=result.error.replace(scratch, here))
    return result


def simulate_one(program: str, machine: MachineSpec, options: ModelOptions = FULL_MODEL, *,
                 text: str | None = None, search_dir: str | FsPath | None = None) -> BatchResult:
    """Simulate one program and summarise it (runs in a worker process)."""
    from ncsim.report.summary import summary

    t0 = time.perf_counter()
    worker = f"{os.uname().nodename}:{os.getpid()}"
    try:
        sim = simulate(program, machine, options, text=text, search_dir=search_dir)
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
    except MemoryError as exc:      # in the summary (simulate names its stage itself)
        return BatchResult(program=program, ok=False,
                           error=OutOfMemory.of(program, "summarising it", exc).render(),
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
        _run_processes(programs, machine, options, min(jobs, len(programs)), done)
    return [results[p] for p in programs]


def _run_processes(programs, machine, options, jobs: int, done) -> None:
    """``jobs`` local worker processes that end with the batch: when it is done, when it is
    interrupted (Ctrl-C or any error here: the pool is terminated) and when it is killed
    (each worker asks to end with its parent: :func:`_worker_start`)."""
    import multiprocessing

    task = partial(simulate_one, machine=machine, options=options)
    with multiprocessing.get_context().Pool(jobs, initializer=_worker_start,
                                            initargs=(os.getpid(),)) as pool:
        for result in pool.imap_unordered(task, programs):
            done(result)


#: prctl(2) option: the signal a process gets when its parent ends (Linux)
_PR_SET_PDEATHSIG = 1


def _worker_start(parent_pid: int) -> None:
    """A batch worker's first step: Ctrl-C is the batch's to handle (it terminates the pool),
    and the worker ends with the batch even when the batch is killed (``kill -9``, a CI
    timeout): Linux's ``PR_SET_PDEATHSIG``, elsewhere a thread that watches the parent."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    libc = _libc()
    prctl = getattr(libc, "prctl", None) if libc is not None else None
    if prctl is None or prctl(_PR_SET_PDEATHSIG, int(signal.SIGTERM), 0, 0, 0) != 0:
        threading.Thread(target=_end_with_parent, args=(parent_pid,), daemon=True).start()
    if os.getppid() != parent_pid:       # the parent ended before the request
        os._exit(1)


def _end_with_parent(parent_pid: int, every_s: float = 0.5) -> None:
    while os.getppid() == parent_pid:
        time.sleep(every_s)
    os._exit(1)


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
        sources = []
        for program in programs:     # read here: a worker elsewhere cannot read our paths
            try:
                sources.append(program_source(program))
            except NcsimError as exc:
                done(BatchResult(program=program, ok=False, error=exc.render()))
        futures = client.map(simulate_source, sources, machine=machine, options=options,
                             pure=False)
        for fut in dask_completed(futures):
            done(fut.result())
    finally:
        client.close()


def warmup_program(n_blocks: int = 400) -> str:
    """A short program that takes every compiled kernel's path: plain CAM-like G1 blocks (the
    scanner), arcs, an exact stop, a dwell, a SOFT/BRISK change and tiny blocks that the
    look-ahead has to creep over."""
    lines = ["N10 G17 G90 G64 SOFT FFWON", "N20 G0 X0 Y0 Z5", "N30 G1 Z0 F6000"]
    for i in range(n_blocks):
        x, y = 0.2 * (i + 1), 0.05 * (i % 7)
        lines.append(f"N{40 + 10 * i} G1 X{x:.3f} Y{y:.3f} Z{-0.01 * (i % 5):.3f}")
        if i % 97 == 50:
            lines += [f"G3 X{x:.3f} Y{y + 2:.3f} I0 J1", f"G2 X{x:.3f} Y{y:.3f} I0 J-1",
                      "G9 G1 X=IC(0.5)", "G4 F0.05", "BRISK", "G1 X=IC(0.01)", "SOFT"]
    lines.append("M30")
    return "\n".join(lines) + "\n"


def warmup(machine: MachineSpec | str | FsPath = "mikron") -> float:
    """Compile numba's versions of every kernel of ``simulate``, the summary, the CSV trace
    writer and ``ncsim parse``'s row writer (or load them from numba's cache), so that no later run
    compiles. Returns the seconds it took (10-20 s the first time after installing, under
    1 s after)."""
    import io

    from ncsim import jit
    from ncsim.plan.sample import sample_motion
    from ncsim.report.csvio import write_trace_csv
    from ncsim.report.pathtext import format_segments
    from ncsim.report.summary import summary

    t0 = time.perf_counter()
    spec = resolve_machine(machine)
    with jit.forced("compiled"):
        for depth in (spec.ncu.lookahead_blocks, 3):
            sim = simulate("warmup.mpf", spec.with_ncu(lookahead_blocks=depth),
                           text=warmup_program())
        # the compressor's fit kernel (ncsim.plan.compressor)
        simulate("warmup.mpf", spec, text=warmup_program().replace("FFWON", "FFWON COMPCAD", 1))
        trace = sample_motion(sim.motion)
        write_trace_csv(trace, io.BytesIO())
        write_trace_csv(trace, io.BytesIO(), columns="all")
        format_segments(sim.path)
        summary(sim, include_blocks=False)
    return time.perf_counter() - t0
