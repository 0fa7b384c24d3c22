"""``ncsim gap``: where the simulation departs from a measurement, and which effect explains it.

Arguments and output only: what is read, which diagnosis runs and what goes back into the
machine file is decided by :func:`ncsim.gap.pipeline.diagnose` (see its module docstring for
the input formats). The click command object :data:`gap` is registered by ``ncsim.cli.main``;
errors are raised as ``ncsim.errors`` exceptions, which the ``ncsim`` group prints on one line
with exit status 2.
"""
from __future__ import annotations

import json
import math
from pathlib import Path as FsPath

import click

from ncsim.cli.params import FilePath, FiniteFloatRange
from ncsim.errors import UsageError
from ncsim.units import FEED_UNITS, ms_to_s


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


@click.command("gap")
@click.argument("programs", nargs=-1, type=FilePath())
@click.option("--machine", "machine_name", required=True,
              help="Machine the program is simulated on: a bundled name (mikron, dmc60h) or a "
                   "TOML file; the calibrated file (--write-machine) is this file edited.")
@click.option("--measured", "measured_file", required=True, type=FilePath(),
              help="Measured trace (CSV) or published values (TOML summary).")
@click.option("--format", "fmt", type=click.Choice(["auto", "csv", "kit", "umich", "summary"]),
              default="auto", show_default=True, help="How to read --measured.")
@click.option("--column", "columns", multiple=True, metavar="KEY=NAME",
              help="CSV column of a trace key (t, x, y, z, feed, vx, vy, vz, x_cmd, y_cmd, z_cmd, line).")
@click.option("--unit", "units", multiple=True, metavar="KEY=UNIT",
              help="Unit of a trace key (t=ms, pos=um, feed=m/min, ...).")
@click.option("--sample-period-ms", type=FiniteFloatRange(min=0, min_open=True), default=None,
              help="Sampling period when the CSV has no time column.")
@click.option("--work-offset", "work_offsets", multiple=True, metavar="G54=X,Y,Z",
              help="Work offset (mm) of the trace's machine coordinates; default: the setup "
                   "or machine file's, else fitted.")
@click.option("--setup", "setup_file", default=None, type=FilePath(),
              help="Setup file with the work offsets ([work_offsets] G54 = [x, y, z]).")
@click.option("--base", default=None,
              help="Base model: full, axis-only or full-minus-EFFECT (default: full for traces, "
                   "axis-only for published values).")
@click.option("--effects", default=None, metavar="E1,E2,...",
              help="Candidate effects (default: all that apply).")
@click.option("--no-combine", is_flag=True, help="Skip the combined model.")
@click.option("--json", "as_json", is_flag=True, help="Print the diagnosis as JSON.")
@click.option("--plot", "plot_prefix", default=None, metavar="PREFIX", type=FilePath(),
              help="Write figures PREFIX-gap/-summary/-servo.(png|svg).")
@click.option("--plot-format", type=click.Choice(["png", "svg"]), default="png", show_default=True)
@click.option("--write-machine", "machine_out", default=None, type=FilePath(),
              help="Write the --machine file calibrated with the fitted parameters (its comments "
                   "kept, the fit and each changed machine datum recorded).")
@click.option("--allow-bounds", is_flag=True,
              help="Write the calibrated machine file even with fitted values on their search "
                   "bounds (flagged in it); without it such a file is refused.")
@click.option("--feed-unit", type=click.Choice(FEED_UNITS), default="mm/min", show_default=True,
              help="Feeds of the text output in this unit (the JSON keeps the unit in its keys).")
def gap(programs, machine_name, measured_file, fmt, columns, units, sample_period_ms,
        work_offsets, setup_file, base, effects, no_combine, as_json, plot_prefix, plot_format,
        machine_out, allow_bounds, feed_unit) -> None:
    """Diagnose the gap between PROGRAM(s) simulated on a machine and a measurement: where it is,
    which unmodelled effect causes it, and how much of it each effect closes."""
    from ncsim.gap.pipeline import diagnose

    if as_json and feed_unit != "mm/min":
        raise UsageError("--feed-unit applies to the text output; the JSON keeps the unit in "
                         "its key names")
    bar = _ProgressBar()
    try:
        result = diagnose(programs, measured_file, machine_name, fmt=fmt,
                          columns=_pairs(columns, "--column"), units=_pairs(units, "--unit"),
                          sample_period_s=None if sample_period_ms is None
                          else ms_to_s(sample_period_ms),
                          base=base, effects=None if effects is None else effects.split(","),
                          combine=not no_combine, work_offsets=_offsets(work_offsets),
                          setup=setup_file, progress=bar)
    finally:
        bar.close()
    for warning in result.machine.warnings:
        click.echo(warning.render(), err=True)
    out = result.as_dict()
    calibration = result.calibration()
    refused = bool(machine_out and calibration.refused and not allow_bounds)
    written_warnings = []
    if machine_out and not refused:
        written_warnings = _write_machine(result, machine_out)
        out["machine_written"] = machine_out
    plots = result.plot(plot_prefix, plot_format) if plot_prefix else []
    if plots:
        out["plots"] = plots
    if as_json:
        click.echo(json.dumps(_finite(out), indent=1, default=_json_default, allow_nan=False))
    else:
        click.echo(result.text(feed_unit), nl=False)
        click.echo(calibration.text(), nl=False)
        for p in plots:
            click.echo(f"wrote {p}")
        if machine_out and not refused:
            click.echo(f"wrote {machine_out}")
    for warning in written_warnings:
        click.echo(warning.render(), err=True)
    if refused:
        raise UsageError(calibration.refusal(machine_out))


def _write_machine(result, machine_out: str) -> list:
    """Write the calibrated machine file and load it back with the machine loader: the
    warnings it gives (values outside the usual range of real machines) are returned."""
    from ncsim.machine import load_machine
    try:
        FsPath(machine_out).write_text(result.corrected_machine_toml(), encoding="utf-8")
    except OSError as exc:
        raise UsageError(f"cannot write machine file {machine_out}: {exc.strerror}") from None
    return list(load_machine(machine_out).warnings)


def _offsets(values) -> dict:
    """``--work-offset G54=X,Y,Z`` (repeatable) as ``{"G54": (x, y, z)}`` in mm."""
    from ncsim.config import is_settable_offset
    out = {}
    for name, text in _pairs(values, "--work-offset").items():
        key = name.upper()
        if not is_settable_offset(key):
            raise UsageError(f"--work-offset {name}: not a settable work offset (G54..G57, "
                             "G505..G599)")
        try:
            xyz = tuple(float(v) for v in text.split(","))
        except ValueError:
            xyz = ()
        if len(xyz) != 3 or not all(math.isfinite(v) for v in xyz):
            raise UsageError(f"--work-offset {name}: expected three finite numbers X,Y,Z in mm, "
                             f"got {text!r}")
        out[key] = xyz
    return out


class _ProgressBar:
    """The gap pipeline's progress (stage, number, total) on ``ncsim``'s stderr bar, drawn
    only on a terminal."""

    def __init__(self):
        from ncsim.cli.main import Progress
        self.bar = Progress([])

    def __call__(self, name: str, index: int, total: int) -> None:
        if len(self.bar.stages) != total:
            self.bar.stages = [""] * total
        self.bar.started = index - 1
        self.bar(name)

    def close(self) -> None:
        self.bar.close()


def _finite(o):
    """NaN and infinities (e.g. a share with nothing to explain) as JSON null."""
    import numpy as np
    if isinstance(o, (float, np.floating)):
        return float(o) if math.isfinite(o) else None
    if isinstance(o, np.integer):
        return int(o)
    if isinstance(o, np.ndarray):
        return _finite(o.tolist())
    if isinstance(o, dict):
        return {k: _finite(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [_finite(v) for v in o]
    return o


def _json_default(o):
    import numpy as np
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    raise TypeError(f"not JSON-able: {type(o).__name__}")
