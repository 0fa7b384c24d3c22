"""``ncsim gap``: where the simulation departs from a measurement, and which effect explains it.

The click command object :data:`gap` is registered by ``ncsim.cli``. Errors are raised as
``ncsim.errors`` exceptions; the ``ncsim`` group prints them on one line and exits with 2.

Measured input (``--measured FILE``, ``--format auto``):

* ``*.toml``: published values (``measured.load_measured_summary``; e.g.
  ``measured/paper_table3.toml``) -- diagnosed against every PROGRAM given
  (``gap_summary.diagnose_summary``), base ``axis-only`` unless ``--base`` says otherwise;
* a UMich SMART mill CSV (header with ``X1_ActualPosition``): ``measured.load_umich_csv``;
* any other CSV: ``measured.load_measured_csv`` with ``--column KEY=NAME`` / ``--unit KEY=UNIT``
  mappings (``--sample-period-ms`` when the file has no time column).

A trace is diagnosed against one PROGRAM (``gap.diagnose``, base ``full`` unless ``--base``).
When it also holds commanded positions, the gap is split: the planner part (ncsim against the
command, planner effects) and the servo part (command against actual, ``gap_servo``); with
no PROGRAM only the servo part is possible.
"""
from __future__ import annotations

import json
from pathlib import Path as FsPath

import click

from ncsim.errors import UsageError


def _pairs(values, what: str) -> dict:
    out = {}
    for v in values:
        if "=" not in v:
            raise UsageError(f"{what} must be KEY=VALUE, got {v!r}")
        k, val = v.split("=", 1)
        if not k.strip() or not val.strip():
            raise UsageError(f"{what} must be KEY=VALUE, got {v!r}")
        out[k.strip()] = val.strip()
    return out


def _detect_format(file: str, fmt: str) -> str:
    if fmt != "auto":
        return fmt
    if FsPath(file).suffix.lower() == ".toml":
        return "summary"
    try:
        with open(file, encoding="utf-8-sig", errors="replace") as fh:
            head = fh.readline()
    except OSError:
        return "csv"  # the loader reports the file error with its name
    return "umich" if "X1_ActualPosition" in head else "csv"


def _candidates(effects: str | None):
    if effects is None:
        return None
    names = [e.strip() for e in effects.split(",") if e.strip()]
    if not names:
        raise UsageError("--effects needs at least one effect name")
    from ncsim.gap.effects import get_effect
    for n in names:
        get_effect(n)
    return names


@click.command("gap")
@click.argument("programs", nargs=-1, type=click.Path(dir_okay=False))
@click.option("--machine", "machine_name", default="mikron", show_default=True,
              help="Machine: a bundled name or a TOML file.")
@click.option("--measured", "measured_file", required=True, type=click.Path(dir_okay=False),
              help="Measured trace (CSV) or published values (TOML summary).")
@click.option("--format", "fmt", type=click.Choice(["auto", "csv", "umich", "summary"]),
              default="auto", show_default=True, help="How to read --measured.")
@click.option("--column", "columns", multiple=True, metavar="KEY=NAME",
              help="CSV column of a trace key (t, x, y, z, feed, vx, vy, vz, x_cmd, y_cmd, z_cmd, line).")
@click.option("--unit", "units", multiple=True, metavar="KEY=UNIT",
              help="Unit of a trace key (t=ms, pos=um, feed=m/min, ...).")
@click.option("--sample-period-ms", type=float, default=None,
              help="Sampling period when the CSV has no time column.")
@click.option("--base", default=None,
              help="Base model: full, axis-only or full-minus-EFFECT (default: full for traces, "
                   "axis-only for published values).")
@click.option("--effects", default=None, metavar="E1,E2,...",
              help="Candidate effects (default: all that apply).")
@click.option("--no-combine", is_flag=True, help="Skip the combined model.")
@click.option("--json", "as_json", is_flag=True, help="Print the diagnosis as JSON.")
@click.option("--plot", "plot_prefix", default=None, metavar="PREFIX",
              help="Write figures PREFIX-gap/-summary/-servo.(png|svg).")
@click.option("--plot-format", type=click.Choice(["png", "svg"]), default="png", show_default=True)
@click.option("--write-machine", "machine_out", default=None, type=click.Path(dir_okay=False),
              help="Write the machine file corrected with the fitted parameters.")
def gap(programs, machine_name, measured_file, fmt, columns, units, sample_period_ms, base,
        effects, no_combine, as_json, plot_prefix, plot_format, machine_out) -> None:
    """Diagnose the gap between PROGRAM(s) simulated on a machine and a measurement: where it is,
    which unmodelled effect causes it, and how much of it each effect closes."""
    from ncsim.machine import load_machine
    from ncsim.gap.measured import load_measured_csv, load_measured_summary, load_umich_csv

    machine = load_machine(machine_name)
    kind = _detect_format(measured_file, fmt)
    cands = _candidates(effects)
    if sample_period_ms is not None and not sample_period_ms > 0:
        raise UsageError(f"--sample-period-ms must be positive, got {sample_period_ms:g}")
    out: dict = {}
    texts: list[str] = []
    plots: list[str] = []
    corrected = None
    servo_diag = None

    if kind == "summary":
        from ncsim.gap.report import format_summary
        from ncsim.gap.published import diagnose_summary
        if not programs:
            raise UsageError("published values need the PROGRAM(s) they were measured on")
        summary = load_measured_summary(measured_file)
        d = diagnose_summary(list(programs), machine, summary, base=base or "axis-only",
                             candidates=cands, do_combine=not no_combine)
        out = d.as_dict()
        texts.append(format_summary(d))
        corrected = d
        if plot_prefix:
            from ncsim.gap.plot import plot_summary
            plots += plot_summary(d, None, plot_prefix, plot_format)
    else:
        if kind == "umich":
            measured = load_umich_csv(measured_file)
        else:
            measured = load_measured_csv(measured_file, columns=_pairs(columns, "--column") or None,
                                         units=_pairs(units, "--unit") or None,
                                         sample_period_s=None if sample_period_ms is None
                                         else ms_to_s(sample_period_ms))
        if len(programs) > 1:
            raise UsageError("a measured trace is diagnosed against one PROGRAM, got "
                             f"{len(programs)}")
        if not programs and not measured.has_command:
            raise UsageError(f"{measured_file}: no PROGRAM given and no commanded positions in the "
                             "trace: nothing to compare with")
        servo_done = False
        if programs:
            from ncsim.gap.effects import PLANNER_EFFECTS
            from ncsim.gap.diagnose import Evaluator, default_candidates, diagnose
            from ncsim.gap.report import format_servo, format_trace
            from ncsim.nc.interpret import interpret_file
            path = interpret_file(programs[0], machine).path
            target = measured.command() if measured.has_command else measured
            if measured.has_command:
                from ncsim.gap.servo_part import SERVO_CANDIDATES, diagnose_split
                planner_cands = [c for c in (cands or default_candidates()) if c in PLANNER_EFFECTS]
                if not planner_cands:
                    raise UsageError("--effects names no planner effect for the planner part")
                servo_cands = None if cands is None else [c for c in cands if c in SERVO_CANDIDATES]
                split = diagnose_split(path, machine, measured, base=base or "full",
                                       planner_candidates=planner_cands,
                                       servo_candidates=servo_cands or None,
                                       do_combine=not no_combine, program=programs[0])
                d, s = split.planner, split.servo
                servo_diag = s
                out.update(split.as_dict())
                texts += ["planner part (ncsim against the command): " + format_trace(d),
                          format_servo(s)]
                servo_done = True
                if plot_prefix:
                    from ncsim.gap.plot import plot_servo
                    from ncsim.gap.servo_part import ServoEvaluator
                    plots += plot_servo(s, ServoEvaluator(measured, s.signal), plot_prefix, plot_format)
            else:
                d = diagnose(path, machine, target, base=base or "full", candidates=cands,
                             do_combine=not no_combine, program=programs[0])
                out["diagnosis"] = d.as_dict()
                texts.append(format_trace(d))
            corrected = d
            if plot_prefix:
                from ncsim.gap.plot import plot_trace
                plots += plot_trace(d, Evaluator(path, target), plot_prefix, plot_format)
        if measured.has_command and not servo_done:
            from ncsim.gap.report import format_servo
            from ncsim.gap.servo_part import SERVO_CANDIDATES, ServoEvaluator, diagnose_servo
            servo_cands = None
            if cands is not None:
                servo_cands = [c for c in cands if c in SERVO_CANDIDATES]
                if not servo_cands and not programs:
                    raise UsageError("--effects names no servo effect for the servo part "
                                     f"({', '.join(SERVO_CANDIDATES)})")
            if servo_cands != []:
                s = diagnose_servo(measured, candidates=servo_cands, machine=machine)
                out["servo_part"] = s.as_dict()
                texts.append(format_servo(s))
                if plot_prefix:
                    from ncsim.gap.plot import plot_servo
                    plots += plot_servo(s, ServoEvaluator(measured, s.signal), plot_prefix, plot_format)
                servo_diag = s

    if machine_out:
        _write_machine(corrected, servo_diag, machine, machine_out, measured_file)
        out["machine_written"] = machine_out
    if plots:
        out["plots"] = plots
    if as_json:
        click.echo(json.dumps(_finite(out), indent=1, default=_json_default, allow_nan=False))
    else:
        click.echo("\n".join(texts), nl=False)
        for p in plots:
            click.echo(f"wrote {p}")
        if machine_out:
            click.echo(f"wrote {machine_out}")


def _finite(o):
    """NaN and infinities (e.g. a share with nothing to explain) as JSON null."""
    import math
    if isinstance(o, float):
        return o if math.isfinite(o) else None
    if isinstance(o, dict):
        return {k: _finite(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [_finite(v) for v in o]
    try:
        import numpy as np
        if isinstance(o, np.floating):
            return _finite(float(o))
        if isinstance(o, np.integer):
            return int(o)
        if isinstance(o, np.ndarray):
            return _finite(o.tolist())
    except ImportError:  # pragma: no cover
        pass
    return o


def _json_default(o):
    import numpy as np
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    raise TypeError(f"not JSON-able: {type(o).__name__}")


def _write_machine(diagnosis, servo, machine, file: str, measured_file: str) -> None:
    """The machine file corrected with the fitted parameters (``effects.corrected_machine``):
    the planner diagnosis's corrected model (or the bare machine), plus the servo part's best
    effect when there is one."""
    from dataclasses import replace

    from ncsim.gap.effects import Model, corrected_machine, get_effect
    from ncsim.machine import dump_machine_toml
    notes = []
    model, fitted = Model(machine=machine), []
    if diagnosis is not None:
        model = diagnosis.corrected_model
        final = diagnosis.combined or diagnosis.best
        effects = final.effects or (final.effect,)
        fitted = [(e, {p.name: final.params[p.name] for p in get_effect(e).params if p.name in final.params})
                  for e in effects]
    if servo is not None:
        best = servo.best
        model = model.with_post(best.effect, best.params)
        fitted.append((best.effect, best.params))
    spec = corrected_machine(model)
    for name, params in fitted:
        if name == "accel_mode":
            notes.append(f"accel_mode {params.get('mode')}: the acceleration mode is set by the program "
                         "(SOFT/BRISK), not by the machine file")
        if name == "servo_lag" and float(params.get("ffw_weight", 0.0)) > 0:
            notes.append(f"servo_lag ffw_weight {float(params['ffw_weight']):.3g}: no machine-file key")
        if name == "servo_delay":
            notes.append(f"servo_delay {float(params['delay_ms']):.3g} ms: no machine-file key")
    desc = (spec.description + " -- " if spec.description else "") + "corrected by ncsim gap"
    spec = replace(spec, description=desc)
    header = [f"Machine file corrected by `ncsim gap` against {measured_file}.",
              "Fitted: " + "; ".join(f"{n} " + ", ".join(f"{k}={v if isinstance(v, str) else f'{float(v):.6g}'}"
                                                       for k, v in p.items()) for n, p in fitted)]
    header += notes
    text = dump_machine_toml(spec, "\n".join(header))
    try:
        FsPath(file).write_text(text, encoding="utf-8")
    except OSError as exc:
        raise UsageError(f"cannot write machine file {file}: {exc.strerror}") from None
