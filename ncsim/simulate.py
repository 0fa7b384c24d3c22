"""The pipeline in one call: program -> path (interpret) -> limits -> feed law (plan).

Sampling (``ncsim.sample``) is left to the caller: a summary needs only the planned motion,
which keeps million-block runs cheap.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path as FsPath

from ncsim.errors import NcWarning
from ncsim.nc.interpret import InterpretResult, interpret_file, interpret_text
from ncsim.plan.limits import PathLimits, path_limits
from ncsim.machine import MachineSpec, load_machine
from ncsim.motion import FULL_MODEL, ModelOptions, Motion
from ncsim.path import Path
from ncsim.plan.lookahead import plan


@dataclass(frozen=True)
class Simulation:
    program: str
    machine: MachineSpec
    options: ModelOptions
    interpreted: InterpretResult | None
    limits: PathLimits
    motion: Motion
    stage_time_s: dict[str, float] = field(default_factory=dict)

    @property
    def path(self) -> Path:
        return self.motion.path

    @property
    def warnings(self) -> tuple[NcWarning, ...]:
        return self.interpreted.warnings if self.interpreted is not None else ()

    @property
    def cycle_time_s(self) -> float:
        return self.motion.total_time_s


def resolve_machine(machine: MachineSpec | str | FsPath) -> MachineSpec:
    return machine if isinstance(machine, MachineSpec) else load_machine(machine)


def simulate(program: str | FsPath, machine: MachineSpec | str | FsPath,
             options: ModelOptions = FULL_MODEL, *, text: str | None = None,
             setup_offsets: dict | None = None) -> Simulation:
    """Interpret ``program`` (a file, or ``text`` named ``program``) and plan it on ``machine``."""
    spec = resolve_machine(machine)
    t0 = time.perf_counter()
    if text is None:
        result = interpret_file(program, spec, setup_offsets=setup_offsets)
    else:
        result = interpret_text(text, str(program), spec, setup_offsets=setup_offsets)
    t1 = time.perf_counter()
    sim = simulate_path(result.path, spec, options, program=str(program))
    stages = {"interpret_s": t1 - t0, **sim.stage_time_s}
    return Simulation(program=str(program), machine=spec, options=options, interpreted=result,
                      limits=sim.limits, motion=sim.motion, stage_time_s=stages)


def simulate_path(path: Path, machine: MachineSpec | str | FsPath,
                  options: ModelOptions = FULL_MODEL, *, program: str = "<path>") -> Simulation:
    """Plan an already interpreted path (used by the gap diagnosis to re-plan variants)."""
    spec = resolve_machine(machine)
    t0 = time.perf_counter()
    limits = path_limits(path, spec, options)
    t1 = time.perf_counter()
    motion = plan(path, spec, options, limits=limits)
    t2 = time.perf_counter()
    return Simulation(program=program, machine=spec, options=options, interpreted=None,
                      limits=limits, motion=motion,
                      stage_time_s={"limits_s": t1 - t0, "plan_s": t2 - t1})
