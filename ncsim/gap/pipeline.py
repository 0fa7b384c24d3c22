"""The gap diagnosis in one call: what ``ncsim gap`` decides, as a library function.

:func:`diagnose` takes the measured file, the program(s) it was measured on and a machine, and
decides:

* **how to read the measurement** (``fmt="auto"``): ``*.toml`` is published values
  (``summaryfile.load_measured_summary``, e.g. ``measured/paper_table3.toml``); a CSV whose header
  has ``X1_ActualPosition`` is a UMich SMART mill file (``measured.load_umich_csv``); one
  with the KIT wbk columns (``time``, ``pos_x``, ``cmd_pos_x`` ...) is read with that layout;
  any other CSV is a trace in the default convention, with ``columns`` / ``units`` mappings
  and ``sample_period_s`` when it has no time column (``measured.load_measured_csv``); a
  trace sampled faster than ``MIN_PERIOD_S`` is averaged down to it;
* **where the trace lies on the program** (:func:`register_trace`): its blocks, pass, work
  offset (from ``work_offsets``, a setup or the machine file, else fitted:
  :func:`offset_prior`) and each sample's place, from the commanded positions when recorded;
  a trace that does not follow the program, or runs at an implausible rate, is refused with
  one line naming what to check;
* **which diagnosis**: published values against every program (``published.diagnose_summary``,
  base ``axis-only`` by default); a trace against one program (``diagnose.diagnose``, base
  ``full`` by default). A trace that also holds the commanded positions is split
  (``servo_part.diagnose_split``): the *planner part* (ncsim against the command, planner
  effects only) and the *servo part* (command against actual, trace effects only); with no
  program only the servo part is possible;
* **which of equally good hypotheses** (:meth:`GapResult.prefer_plausible`): an operator's
  override before a machine-data change that fits as well, the other named
  (``calibration.prefer_plausible``, judged by :meth:`GapResult.evaluator`, the diagnosis's
  own evaluator with the program interpreted again where a model needs it);
* **what goes back into the machine file** (:meth:`GapResult.corrected_machine_toml`,
  :meth:`GapResult.calibration`): the planner diagnosis's corrected model (or the bare
  machine) plus the servo part's best effect, written into the source file's text (comments
  kept) with each changed machine datum, the values on search bounds and notes for what a
  machine file cannot hold (the acceleration mode, a feed-forward weight, a delay);
  ``ncsim.gap.calibration``.

The :class:`GapResult` it returns is what the command prints: ``as_dict()`` (``--json``),
``text()``, ``plot(prefix)``.
"""
from __future__ import annotations

import os
import re
from dataclasses import dataclass, field, replace
from pathlib import Path as FsPath
from typing import Callable, Mapping, Sequence

import numpy as np

from ncsim.config import not_regular
from ncsim.errors import MeasuredDataError, UsageError
from ncsim.gap.effects import COMMAND_EFFECTS, Model, corrected_machine, get_effect
from ncsim.gap.measured import MeasuredTrace, detect_preset, load_measured_csv, load_umich_csv
from ncsim.gap.register import Registration, rate_problem, register
from ncsim.gap.summaryfile import load_measured_summary
from ncsim.machine import MachineSpec, dump_machine_toml, load_machine, machine_file_text

FORMATS = ("auto", "csv", "kit", "umich", "summary")
MIN_PERIOD_S = 1e-3   # a trace sampled faster is averaged down to 1 ms (the model grid is 2 ms)
#: the recorder's mean of known layouts (compared after it): the KIT data set's converter
#: averages 10 samples of the 500 Hz Edge capture (20 ms) before keeping every 10th
RECORDER_WINDOW_MS = {"kit": 20.0}


@dataclass
class GapResult:
    """A diagnosis of one measured file (module docstring). ``kind`` says which parts are set:
    ``"summary"`` (``planner`` is a ``published.SummaryDiagnosis``), ``"trace"`` (``planner``
    is a ``diagnose.Diagnosis``), ``"split"`` (``planner`` of the command and ``servo``) or
    ``"servo"`` (``servo`` alone, a ``servo_part.ServoDiagnosis``)."""

    kind: str
    measured_file: str
    machine: MachineSpec
    planner: object | None = None
    servo: object | None = None
    measured: MeasuredTrace | None = None   # the trace (``kind`` trace, split, servo)
    path: object | None = None              # the interpreted program (trace, split)
    registration: Registration | None = None  # where the trace lies on the program
    #: the machine file's text and its name as given (None: a MachineSpec was given)
    machine_text: str | None = None
    machine_label: str = ""
    #: the program interpreted again on another machine (``diagnose.ModelCache``)
    reinterpret: Callable | None = None
    #: equally good hypotheses not in the corrected model (``calibration.prefer_plausible``)
    alternatives: list = field(default_factory=list)
    _evaluator: object = field(default=None, repr=False, compare=False)
    _calibration: object = field(default=None, repr=False, compare=False)

    def as_dict(self) -> dict:
        """The ``ncsim gap --json`` document (README "Sim-to-real gap")."""
        if self.kind == "summary":
            return self.planner.as_dict()
        reg = {} if self.registration is None else {"registration": self.registration.as_dict()}
        cal = {"calibration": self.calibration().as_dict()}
        if self.kind == "split":
            return {**reg, "planner_part": self.planner.as_dict(),
                    "servo_part": self.servo.as_dict(), **cal}
        if self.kind == "trace":
            return {**reg, "diagnosis": self.planner.as_dict(), **cal}
        return {"servo_part": self.servo.as_dict(), **cal}

    def text(self, feed_unit: str = "mm/min") -> str:
        """The diagnosis as text, every feed in ``feed_unit`` (``units.FEED_UNITS``)."""
        from ncsim.gap.report import (format_registration, format_servo, format_summary,
                                      format_trace)
        if self.kind == "summary":
            return format_summary(self.planner, feed_unit)
        parts = []
        if self.registration is not None:
            parts.append(format_registration(self.registration))
        if self.planner is not None:
            head = "planner part (ncsim against the command): " if self.kind == "split" else ""
            parts.append(head + format_trace(self.planner, feed_unit))
        if self.servo is not None:
            parts.append(format_servo(self.servo, feed_unit))
        return "\n".join(parts)

    def plot(self, prefix: str, fmt: str = "png") -> list[str]:
        """Write the figures ``PREFIX-summary|-servo|-gap.FMT``; returns the file names."""
        from ncsim.gap import plot
        if self.kind == "summary":
            return plot.plot_summary(self.planner, None, prefix, fmt)
        files = []
        if self.servo is not None:
            from ncsim.gap.servo_part import ServoEvaluator
            files += plot.plot_servo(self.servo, ServoEvaluator(self.measured, self.servo.signal),
                                     prefix, fmt)
        if self.planner is not None:
            files += plot.plot_trace(self.planner, self.evaluator(), prefix, fmt)
        return files

    def evaluator(self):
        """The planner part's ``diagnose.Evaluator``, judging models exactly as the diagnosis
        did: the same target (the command when recorded), registration, and the program
        interpreted again where a model changes how it is interpreted (a G64 reset mode)."""
        if self._evaluator is None:
            from ncsim.gap.diagnose import Evaluator, interpretation_key
            target = self.measured.command() if self.measured.has_command else self.measured
            self._evaluator = Evaluator(self.path, target, registration=self.registration,
                                        reinterpret=self.reinterpret,
                                        path_key=interpretation_key(self.machine))
        return self._evaluator

    def prefer_plausible(self) -> None:
        """Of equally good hypotheses, the more plausible one in the corrected model
        (``calibration.prefer_plausible``); the others are kept in ``alternatives``."""
        if self.kind not in ("trace", "split") or self.planner is None:
            return
        from ncsim.gap.calibration import prefer_plausible
        self.planner, alternatives = prefer_plausible(self.evaluator(), self.planner)
        self._calibration = None
        self.alternatives = list(alternatives)
        if alternatives:
            self.planner = replace(self.planner, notes=self.planner.notes + tuple(
                f"machine file: {a.text()}" for a in alternatives))

    def corrected_model(self) -> tuple[Model, list[tuple[str, dict]]]:
        """The corrected model and the fitted ``(effect, params)`` it adds to the machine."""
        model, fitted = Model(machine=self.machine), []
        if self.planner is not None:
            model = self.planner.corrected_model
            final = self.planner.combined or self.planner.best
            for e in final.effects or (final.effect,):
                fitted.append((e, {p.name: final.params[p.name] for p in get_effect(e).params
                                   if p.name in final.params}))
        if self.servo is not None:
            best = self.servo.best
            model = model.with_post(best.effect, best.params)
            fitted.append((best.effect, best.params))
        return model, fitted

    def corrected_machine(self, model: Model | None = None) -> MachineSpec:
        """The machine with the fitted parameters (``effects.corrected_machine`` of ``model``,
        by default :meth:`corrected_model`'s)."""
        spec = corrected_machine(self.corrected_model()[0] if model is None else model)
        desc = (spec.description + " -- " if spec.description else "") + "corrected by ncsim gap"
        return replace(spec, description=desc)

    def calibration(self):
        """What the corrected machine file changes, flags and leaves out
        (``calibration.Calibration``; computed once, after ``prefer_plausible``)."""
        if self._calibration is None:
            self._calibration = self._calibrate()
        return self._calibration

    def _calibrate(self):
        from ncsim.gap.calibration import (Calibration, bound_hits, complete_ovl_changes,
                                           machine_changes)
        model, fitted = self.corrected_model()
        new = self.corrected_machine(model)
        changes = machine_changes(self.machine, new, [n for n, _ in fitted])
        if self.machine_text is not None:
            changes = complete_ovl_changes(self.machine, new, changes, self.machine_text)
        notes = [note for name, params in fitted for note in _machine_file_notes(name, params)]
        times = {}
        if self.path is not None and self.planner is not None:
            from ncsim.motion import FULL_MODEL
            cache = self.evaluator().cache
            times = {"base_cycle_time_s": cache.motion(Model(machine=self.machine)).total_time_s,
                     "cycle_time_s": cache.motion(model).total_time_s}
            if model.options != FULL_MODEL:
                notes.append(f"the base model '{self.planner.base}' leaves planner effects out "
                             "that a machine file cannot switch off: `ncsim run` on this file "
                             "simulates them")
        return Calibration(source=self.machine_label or self.machine.source, fitted=fitted,
                           changes=changes, bounds=bound_hits(fitted),
                           alternatives=list(self.alternatives), notes=notes,
                           fit_lines=self._fit_lines(), **times)

    def _fit_lines(self) -> list[str]:
        """The gap and rms before and after the correction, for the file's header."""
        from ncsim.units import mm_s_to_mm_min
        out = []
        if self.planner is not None:
            b = self.planner.gap_before
            a = (self.planner.combined or self.planner.best).gap_after
        if self.planner is not None and self.kind in ("trace", "split"):
            what = "planner part (ncsim against the command)" if self.kind == "split" else "trace"
            out.append(f"{what}, base model '{self.planner.base}': gap {b.gap:.4g} -> {a.gap:.4g}; "
                       f"feed {mm_s_to_mm_min(b.feed_rms_mm_s):.4g} -> "
                       f"{mm_s_to_mm_min(a.feed_rms_mm_s):.4g} mm/min rms, time "
                       f"{b.time_rms_ms:.4g} -> {a.time_rms_ms:.4g} ms rms, cycle time "
                       f"{b.cycle_time_error_s:+.4f} -> {a.cycle_time_error_s:+.4f} s, contour "
                       f"{b.contour_rms_um:.4g} -> {a.contour_rms_um:.4g} um rms")
        elif self.planner is not None:
            out.append(f"published values, base model '{self.planner.base}': gap {b.gap:.4g} "
                       f"-> {a.gap:.4g}")
        if self.servo is not None:
            s = self.servo
            out.append(f"servo part (command against actual {s.signal}): gap "
                       f"{s.gap_before.gap:.4g} -> {s.best.gap_after.gap:.4g}, rms "
                       f"{s.gap_before.rms:.4g} -> {s.best.gap_after.rms:.4g} "
                       f"{'mm/s' if s.signal == 'velocity' else 'mm'} ({s.best.effect})")
        return out

    def corrected_machine_toml(self) -> str:
        """The corrected machine file: the source file edited in place (its comments and
        provenance kept) under a header recording the fit, the machine data changed, the
        alternatives, the values on bounds and what a machine file cannot hold
        (``ncsim.gap.calibration``)."""
        from ncsim.gap.calibration import edit_machine_text
        cal = self.calibration()
        program = getattr(self.planner, "program", "") or ""
        header = cal.header(self.measured_file, program)
        if self.machine_text is None:
            return dump_machine_toml(self.corrected_machine(), "\n".join(header))
        return edit_machine_text(self.machine_text, cal.changes, header)


def _machine_file_notes(name: str, params: Mapping) -> list[str]:
    """What the machine file makes of a fitted effect that it holds in part (an acceleration
    mode, an override) or not at all (a feed-forward weight, the recorder, a delay)."""
    if name in ("accel_mode", "corner_law"):
        return [f"{name} {params.get('mode')}: written as [ncu] reset_accel_mode (MD20150 group "
                "21), which holds where the program selects none; a block that programs "
                "SOFT/BRISK/DRIVE keeps its own"]
    if name == "servo_lag" and float(params.get("ffw_weight", 0.0)) > 0:
        return [f"servo_lag ffw_weight {float(params['ffw_weight']):.3g}: no machine-file key"]
    if name == "recorder":
        return [f"recorder: a mean of {int(params['samples'])} raw samples, the recorder's filter, "
                "not the machine's (no machine-file key)"]
    if name in ("rapid_override", "feed_override"):
        return [f"{name}: the operator-panel override of this recording, written as "
                f"[ncu] {name}_percent; set it back to 100 for the machine's own rate"]
    if name == "servo_delay":
        return [f"servo_delay {float(params['delay_ms']):.3g} ms: no machine-file key"]
    return []


def detect_format(file: str | FsPath, fmt: str = "auto") -> str:
    """``summary``, ``umich``, ``kit`` or ``csv`` (module docstring); ``fmt`` other than auto
    wins."""
    if fmt not in FORMATS:
        raise UsageError(f"unknown measured format {fmt!r} (known: {', '.join(FORMATS)})")
    if fmt != "auto":
        return fmt
    if FsPath(file).suffix.lower() == ".toml":
        return "summary"
    try:
        if not_regular(os.stat(file).st_mode):   # a FIFO would block the reading of a line
            return "csv"
        with open(file, encoding="utf-8-sig", errors="replace") as fh:
            head = fh.readline()
    except OSError:
        return "csv"  # the loader reports the file error with its name
    if "X1_ActualPosition" in head:
        return "umich"
    return "kit" if detect_preset([h.strip() for h in head.split(",")]) == "kit" else "csv"


def _candidates(effects: Sequence[str] | None) -> list[str] | None:
    if effects is None:
        return None
    names = [e.strip() for e in effects if e.strip()]
    if not names:
        raise UsageError("--effects needs at least one effect name")
    for n in names:
        get_effect(n)
    return names


class Stages:
    """Progress of a diagnosis: calls ``callback(name, index, total)`` as each stage begins
    (``index`` 1-based; ``total`` grows once the candidates are known)."""

    def __init__(self, callback: Callable[[str, int, int], None] | None, total: int):
        self.callback = callback
        self.total = total
        self.done = 0

    def expect(self, more: int) -> None:
        self.total = self.done + more

    def __call__(self, name: str) -> None:
        self.done += 1
        self.total = max(self.total, self.done)
        if self.callback is not None:
            self.callback(name, self.done, self.total)


#: settable zero offsets selected by a program (840D G54..G57, G505..G599)
_FRAME_WORD = re.compile(r"(?<![A-Z0-9_$])G0*(5[4-7]|50[5-9]|5[1-9][0-9])(?![0-9])", re.IGNORECASE)


def selected_frames(path) -> set[str]:
    """The settable frames the program files of ``path`` select (``{"G54"}``), read from
    their text outside comments."""
    found: set[str] = set()
    for file in path.files:
        try:
            text = FsPath(file).read_text(encoding="utf-8-sig", errors="replace")
        except OSError:
            continue
        for line in text.splitlines():
            found.update(f"G{int(m)}" for m in _FRAME_WORD.findall(line.split(";")[0]))
    return found


def offset_prior(path, spec: MachineSpec, given: Mapping[str, tuple]) -> tuple:
    """``(offset_mm or None, source)``: the work offset the recording should show (recorded =
    path + offset). A program that selects a settable frame whose offset is known was
    interpreted in machine coordinates already (offset 0). One that selects none runs in the
    machine's reset frame, G54 on most machines (MD20152 $MC_GCODE_RESET_VALUES): its G54 (or
    the one offset given) is the prior. Otherwise the offset is fitted."""
    known = {name: tuple(float(x) for x in v) for name, v in spec.work_offsets_mm}
    known.update({k: tuple(float(x) for x in v) for k, v in given.items()})
    frames = selected_frames(path)
    applied = sorted(frames & set(known))
    if applied:
        return np.zeros(3), f"{', '.join(applied)} applied by the program"
    if frames:
        return None, "fitted"
    if "G54" in known:
        return np.asarray(known["G54"]), "G54 given, the reset frame"
    if len(given) == 1:
        name, value = next(iter(given.items()))
        return np.asarray(value, dtype=np.float64), f"{name} given"
    return None, "fitted"


def register_trace(trace: MeasuredTrace, path, spec: MachineSpec,
                   work_offsets: Mapping[str, tuple]) -> Registration:
    """Register the trace on the program (commanded positions when recorded: they follow the
    program to the encoder resolution), refusing, with one line, what does not align or runs
    at an implausible rate."""
    prior, source = offset_prior(path, spec, work_offsets)
    signal = "command" if trace.has_command else "actual"
    q = trace.cmd_pos_mm if trace.has_command else trace.pos_mm
    reg = register(q, path, signal=signal, offset_mm=prior, offset_source=source,
                   length_unit=trace.length_unit)
    reg.require(trace.source)
    problem = rate_problem(trace.t_s, q, path, reg)
    if problem:
        raise MeasuredDataError(problem, file=trace.source)
    return reg


def diagnose(programs: Sequence[str | FsPath], measured: str | FsPath,
             machine: MachineSpec | str | FsPath, *, fmt: str = "auto",
             columns: Mapping[str, str] | None = None, units: Mapping[str, str] | None = None,
             sample_period_s: float | None = None, base: str | None = None,
             effects: Sequence[str] | None = None, combine: bool = True,
             work_offsets: Mapping[str, tuple] | None = None,
             setup: str | FsPath | None = None,
             progress: Callable[[str, int, int], None] | None = None) -> GapResult:
    """Diagnose the gap between ``programs`` simulated on ``machine`` and the ``measured`` file:
    where it is, which unmodelled effect causes it and how much of it each effect closes
    (module docstring). ``effects`` are the candidate effects (default: all that apply),
    ``base`` the base model (``full``, ``axis-only``, ``full-minus-EFFECT``).
    ``work_offsets`` (``{"G54": (x, y, z)}``, e.g. ``--work-offset``) and a ``setup`` file
    give the work offsets of the recording's machine coordinates (:func:`offset_prior`);
    ``progress`` is called with each stage's name, number and the number of stages."""
    from ncsim.config import load_setup
    from ncsim.gap.servo_part import SERVO_CANDIDATES

    stages = Stages(progress, 4)
    spec = machine if isinstance(machine, MachineSpec) else load_machine(machine)
    source = {} if isinstance(machine, MachineSpec) else {
        "machine_text": machine_file_text(machine), "machine_label": str(machine)}
    offsets = dict(load_setup(setup)) if setup is not None else {}
    offsets.update(work_offsets or {})
    programs = [str(p) for p in programs]
    file = str(measured)
    kind = detect_format(file, fmt)
    cands = _candidates(effects)
    stages("read")
    if offsets and (kind == "summary" or not programs):
        raise UsageError("--work-offset and --setup place a trace on a PROGRAM: give the program "
                         "it was recorded on")
    if kind == "summary":
        from ncsim.gap.published import diagnose_summary
        if not programs:
            raise UsageError("published values need the PROGRAM(s) they were measured on")
        d = diagnose_summary(programs, spec, load_measured_summary(file), base=base or "axis-only",
                             candidates=cands, do_combine=combine)
        return GapResult("summary", file, spec, planner=d, **source)

    if kind == "umich":
        trace = load_umich_csv(file)
    else:
        trace = load_measured_csv(file, columns=columns or None, units=units or None,
                                  sample_period_s=sample_period_s,
                                  preset="kit" if kind == "kit" else "auto")
    if len(programs) > 1:
        raise UsageError(f"a measured trace is diagnosed against one PROGRAM, got {len(programs)}")
    trace = trace.thinned(MIN_PERIOD_S)
    servo_cands = None if cands is None else [c for c in cands if c in SERVO_CANDIDATES]
    if not programs:
        if not trace.has_command:
            raise UsageError(f"{file}: no PROGRAM given and no commanded positions in the trace: "
                             "nothing to compare with")
        from ncsim.gap.servo_part import diagnose_servo
        if servo_cands == []:
            raise UsageError("--effects names no servo effect for the servo part "
                             f"({', '.join(SERVO_CANDIDATES)})")
        stages.expect(len(servo_cands or SERVO_CANDIDATES))
        s = diagnose_servo(trace, candidates=servo_cands, machine=spec, progress=stages)
        return GapResult("servo", file, spec, servo=s, measured=trace, **source)

    from ncsim.gap.diagnose import default_candidates
    from ncsim.gap.diagnose import diagnose as diagnose_trace
    from ncsim.nc.interpret import interpret_file
    stages("interpret")
    path = interpret_file(programs[0], spec, setup_offsets=offsets or None).path

    def reinterpret(m: MachineSpec):
        """The program on a machine with other reset values (reset_mode, compressor)."""
        return interpret_file(programs[0], m, setup_offsets=offsets or None).path

    stages("register")
    reg = register_trace(trace, path, spec, offsets)
    if not trace.has_command:
        trace_cands = list(cands or default_candidates())
        stages.expect(len(trace_cands) + (1 if combine else 0) + 1)
        d = diagnose_trace(path, spec, trace, base=base or "full", candidates=trace_cands,
                           do_combine=combine, program=programs[0], registration=reg,
                           progress=stages, reinterpret=reinterpret,
                           recorder_window_ms=RECORDER_WINDOW_MS.get(kind))
        result = GapResult("trace", file, spec, planner=d, measured=trace, path=path,
                           registration=reg, reinterpret=reinterpret, **source)
        stages("plausible hypotheses")
        result.prefer_plausible()
        return result
    from ncsim.gap.servo_part import diagnose_split
    planner_cands = [c for c in (cands or default_candidates()) if c in COMMAND_EFFECTS]
    if not planner_cands:
        raise UsageError("--effects names no planner effect for the planner part")
    stages.expect(len(planner_cands) + (1 if combine else 0)
                  + len(servo_cands or SERVO_CANDIDATES) + 1)
    split = diagnose_split(path, spec, trace, base=base or "full",
                           planner_candidates=planner_cands, servo_candidates=servo_cands or None,
                           do_combine=combine, program=programs[0], registration=reg,
                           progress=stages, reinterpret=reinterpret,
                           recorder_window_ms=RECORDER_WINDOW_MS.get(kind))
    result = GapResult("split", file, spec, planner=split.planner, servo=split.servo,
                       measured=trace, path=path, registration=reg, reinterpret=reinterpret,
                       **source)
    stages("plausible hypotheses")
    result.prefer_plausible()
    return result


def warmup_kernels() -> None:
    """Compile numba's versions of the gap's kernels (the nearest-point search of
    ``nearest.track`` and the projection of ``align.project_on_path``), or load them from its
    cache, on a tiny input with the argument types of a real run: ``ncsim warmup`` calls it
    after ``ncsim.pipeline.warmup``, so that no later ``ncsim gap`` pauses to compile."""
    from ncsim import jit
    from ncsim.gap import align, nearest
    from ncsim.nc.interpret import interpret_text

    path = interpret_text("G17 G90 F1000\nG1 X10\nG2 X10 Y0 Z-1 I5 J0 TURN=1\nM30\n",
                          "warmup.mpf").path          # a line and a helix
    q = np.array([[0.0, 0.0, 0.0], [5.0, 0.1, 0.0], [10.0, 0.0, -0.5], [15.0, 0.0, -1.0]])
    s = np.array([0.0, 5.0, 10.0, 15.0])
    t = 0.1 * s
    restart = np.array([True, False, False, False])
    with jit.forced("compiled"):
        nearest.track(q, nearest.path_geometry(path), 0.0, first_window_mm=1.0, slack_mm=1.0)
        for sigma_s in (1.0, 0.0):
            align.project_on_path(q, q, s, t, t, s, restart, np.full(4, 0.5), 100.0, 1.0, 1.0,
                                  0.01, 0.1, sigma_s)
