"""ncsim: a SINUMERIK 840D-style G-code interpreter and HSM feed-rate / cycle-time simulator.

A few nouns and two verbs. :func:`simulate` runs a program on a machine and returns a
:class:`Simulation`: its interpreted :class:`Path` (geometry), its planned :class:`Motion` (the
feed law along the path) and the cycle time; :func:`sample_motion` turns the motion into a
:class:`Trace` (what the NC's oscilloscope would record). :func:`diagnose` compares a
measurement with the simulation and says which unmodelled effect explains the gap.

From the repository root (the R 2.5 mm circle of the paper's Table 3, held by the NCU's path
jerk to 2.01 m/min where 6 m/min is programmed)::

    >>> import ncsim
    >>> from ncsim.units import mm_s_to_m_min
    >>> sim = ncsim.simulate("programs/circle_r2p5_f6000.mpf", machine="mikron")
    >>> trace = ncsim.sample_motion(sim.motion)
    >>> round(float(mm_s_to_m_min(trace.feed_mm_s.max())), 2)
    2.01
    >>> result = ncsim.diagnose(["programs/circle_r2p5_f6000.mpf"], "measured/paper_table3.toml",
    ...                         "mikron", effects=["ncu_path_jerk", "axis_jerk"])
    >>> result.planner.best.effect
    'ncu_path_jerk'

Data flow, one package per stage (``docs/architecture.md``)::

    program text --ncsim.nc--> Path --ncsim.plan--> Motion --sample--> Trace
        --> ncsim.report (summaries, checks, plots, CSV)    --> ncsim.gap (measured vs model)

Names are imported on first use (PEP 562), so ``import ncsim`` and the ``ncsim`` command stay
quick and never load matplotlib, the planner or the gap diagnosis until they are needed.
"""
from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

__version__ = "0.1.0"

#: public name -> the module that defines it
_EXPORTS = {
    "simulate": "ncsim.pipeline", "Simulation": "ncsim.pipeline", "run_batch": "ncsim.pipeline",
    "load_machine": "ncsim.machine", "MachineSpec": "ncsim.machine",
    "ModelOptions": "ncsim.motion", "FULL_MODEL": "ncsim.motion", "Motion": "ncsim.motion",
    "Trace": "ncsim.motion", "Path": "ncsim.path", "sample_motion": "ncsim.plan.sample",
    "diagnose": "ncsim.gap.pipeline", "GapResult": "ncsim.gap.pipeline",
    "NcsimError": "ncsim.errors", "NcWarning": "ncsim.errors",
}

__all__ = ["__version__", *_EXPORTS]


def __getattr__(name: str):
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'ncsim' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_EXPORTS))


if TYPE_CHECKING:  # for type checkers and IDEs; at run time __getattr__ imports on first use
    from ncsim.errors import NcsimError, NcWarning
    from ncsim.gap.pipeline import GapResult, diagnose
    from ncsim.machine import MachineSpec, load_machine
    from ncsim.motion import FULL_MODEL, ModelOptions, Motion, Trace
    from ncsim.path import Path
    from ncsim.pipeline import Simulation, run_batch, simulate
    from ncsim.plan.sample import sample_motion
