"""The `ncsim` command: argument handling, output and exit codes only.

The library raises :class:`ncsim.errors.NcsimError`; this module prints its one-line
rendering on stderr and exits with :class:`ncsim.errors.ExitStatus` (never a traceback).
Bad command-line usage (an unknown option, a value out of range) is one line as well, exit 2.

Commands: ``run`` (cycle time and where the feed is limited), ``plot``, ``check`` (CI
thresholds), ``machines``, ``explain`` (a machine's derived limits), ``parse``, ``warmup``
(compile the numba kernels ahead; a first compilation is announced on stderr), and in their
own modules ``batch`` (``cli.batch``), ``compare`` (``cli.compare``), ``report``
(``cli.report``) and ``gap`` (``cli.gap``); the options they share are in ``cli.options``. Heavy modules (the parser, the
planner, matplotlib, the gap diagnosis) are imported inside the commands that need them, so
that ``ncsim --help`` is quick and ``ncsim run`` never imports matplotlib.
"""
from __future__ import annotations

import dataclasses
import json
import os
import sys

import click

from ncsim import __version__
from ncsim.cli.batch import batch
from ncsim.cli.compare import compare_cmd
from ncsim.cli.gap import gap
from ncsim.cli.options import (Progress, echo_warnings, feed_unit_option, machine_option,
                               model_options, nc_options, program_options, simulation_options,
                               text_only_feed_unit)
from ncsim.cli.params import FilePath, FiniteFloatRange
from ncsim.cli.report import report_cmd
from ncsim.errors import ExitStatus, NcsimError, UsageError
from ncsim.units import s_to_ms


class NcsimGroup(click.Group):
    """A click group that turns ncsim errors, usage errors and running out of memory into one
    line on stderr and exit status 2, and Ctrl-C into exit status 130 (128 + SIGINT, as shells
    do; 1 means a failed check)."""

    def parse_args(self, ctx: click.Context, args: list[str]) -> list[str]:
        try:                     # the group's own options: `ncsim --badopt`
            return super().parse_args(ctx, args)
        except click.UsageError as exc:
            if type(exc).__name__ == "NoArgsIsHelpError":
                raise
            click.echo(_usage_line(exc), err=True)
            ctx.exit(int(ExitStatus.BAD_INPUT))

    def invoke(self, ctx: click.Context):
        try:
            return super().invoke(ctx)
        except KeyboardInterrupt:
            click.echo("ncsim: interrupted", err=True)
            ctx.exit(int(ExitStatus.INTERRUPTED))
        except NcsimError as exc:
            for warning in getattr(exc, "warnings", ()):   # what led to the error
                click.echo(warning.render(), err=True)
            text = exc.render()
            if isinstance(exc, UsageError) and ctx.invoked_subcommand:  # no file to name
                text = f"{ctx.command_path} {ctx.invoked_subcommand}: error: {text}"
            click.echo(text, err=True)
            ctx.exit(int(exc.exit_status))
        except click.UsageError as exc:
            if type(exc).__name__ == "NoArgsIsHelpError":  # `ncsim run` alone: show the help
                raise
            click.echo(_usage_line(exc), err=True)
            ctx.exit(int(ExitStatus.BAD_INPUT))
        except MemoryError:          # outside a stage that names its input (pipeline.simulate)
            where = f"{ctx.command_path} {ctx.invoked_subcommand or ''}".rstrip()
            click.echo(f"{where}: error: out of memory: the input is too large for the memory "
                       "this process may use", err=True)
            ctx.exit(int(ExitStatus.BAD_INPUT))


def _usage_line(exc: click.UsageError) -> str:
    """A click usage error as one line: ``ncsim run: error: ... (see 'ncsim run --help')``."""
    path = exc.ctx.command_path if exc.ctx is not None else "ncsim"
    message = " ".join(exc.format_message().split())
    return f"{path}: error: {message} (see '{path} --help')"


@click.group(name="ncsim", cls=NcsimGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="ncsim")
def cli() -> None:
    """Simulate SINUMERIK 840D programs on a high-speed machine: cycle time, feed limits, gaps.

    \b
    ncsim run PROGRAM --machine mikron        cycle time, reached feed, where time is lost
    ncsim plot PROGRAM --machine mikron -o run.png
    ncsim check PROGRAM --machine mikron --max-time 60
    ncsim report PROGRAM --machine mikron -o report.html
    ncsim compare BEFORE AFTER --machine mikron --max-slower 2
    ncsim machines / ncsim explain --machine mikron

    Exit status: 0 ok, 1 a `check` or `compare` threshold failed, 2 bad input, 130 interrupted.
    """
    from ncsim import jit
    jit.on_compile(_compile_notice)


def _compile_notice(text: str) -> None:
    """numba starts compiling the kernels: say so (also in logs), over a progress line."""
    tty = getattr(sys.stderr, "isatty", None)
    click.echo(("\r\033[K" if tty and tty() else "") + text, err=True)


@cli.command("parse")
@click.argument("program", type=FilePath())
@click.option("--machine", "machine_name", default=None,
              help="Machine: a bundled name (mikron) or a TOML file; gives work offsets and circle tolerances.")
@click.option("--setup", "setup_file", default=None, type=FilePath(),
              help="Setup TOML with [work_offsets] G54 = [x, y, z] (overrides the machine's).")
@click.option("--json", "as_json", is_flag=True, help="Print the segments and summary as JSON.")
@click.option("--limit", type=click.IntRange(min=0), default=None, help="Print only the first N segments.")
@program_options
def parse_cmd(program, machine_name, setup_file, as_json, limit, **params) -> None:
    """Interpret PROGRAM and list its path segments (warnings on stderr)."""
    from ncsim.config import load_setup
    from ncsim.machine import load_machine
    from ncsim.nc.interpret import interpret_file

    machine = load_machine(machine_name) if machine_name else None
    offsets = load_setup(setup_file) if setup_file else None
    result = interpret_file(program, machine, setup_offsets=offsets, **nc_options(params))
    for warning in (machine.warnings if machine else ()) + result.warnings:
        click.echo(warning.render(), err=True)
    path = result.path
    shown = path.n if limit is None else min(limit, path.n)
    if as_json:
        import json
        click.echo(json.dumps({
            "program": program,
            "segments": [_segment_dict(path.segment(i)) for i in range(shown)],
            "summary": _summary_dict(result),
            "warnings": [w.render() for w in result.warnings]}, indent=1))
        return
    from ncsim.report.pathtext import write_segments
    sys.stdout.flush()
    write_segments(path, sys.stdout.buffer, shown)
    sys.stdout.buffer.flush()
    if shown < path.n:
        click.echo(f"... {path.n - shown} more segments")
    s = _summary_dict(result)
    click.echo(f"segments: {s['segments']} ({s['lines']} lines, {s['arcs']} arcs)  "
               f"total length: {s['total_length_mm']:.3f} mm  blocks executed: "
               f"{s['blocks_executed']}  warnings: {s['warnings']}")


def _feed_mm_min(seg) -> float | None:
    from ncsim.units import mm_s_to_mm_min
    return None if seg.rapid else mm_s_to_mm_min(seg.feed_mm_s)


def _segment_dict(seg) -> dict:
    out = {"index": seg.index, "file": seg.file, "line": seg.line,
           "kind": "arc" if seg.is_arc else "line",
           "start_mm": [float(c) for c in seg.start_mm], "end_mm": [float(c) for c in seg.end_mm],
           "length_mm": seg.length_mm, "feed_mm_min": _feed_mm_min(seg), "rapid": seg.rapid,
           "exact_stop": seg.exact_stop, "stop_window": seg.stop_window, "cp_mode": seg.cp_mode,
           "adis_mm": seg.adis_mm, "accel_mode": seg.accel_mode, "ffw": seg.ffw,
           "stop_before": seg.stop_before, "dwell_before_s": seg.dwell_before_s}
    if seg.is_arc:
        out.update(center_mm=[float(c) for c in seg.center_mm], radius_mm=seg.radius_mm,
                   normal=[float(c) for c in seg.normal], sweep_rad=seg.sweep_rad,
                   helix_mm=seg.helix_mm)
    return out


def _summary_dict(result) -> dict:
    path = result.path
    arcs = int((path.kind == 1).sum())
    return {"segments": path.n, "lines": path.n - arcs, "arcs": arcs,
            "total_length_mm": path.total_length_mm, "end_dwell_s": path.end_dwell_s,
            "blocks_executed": result.blocks_executed, "warnings": len(result.warnings)}


# ---------------------------------------------------------------------------------------------
# run
# ---------------------------------------------------------------------------------------------

@cli.command("run")
@click.argument("program", type=FilePath())
@machine_option()
@simulation_options
@click.option("--json", "as_json", is_flag=True,
              help="Print the JSON summary (README 'JSON summary') instead of text.")
@click.option("--no-blocks", is_flag=True,
              help="With --json: leave out the per-block list blocks_detail (large programs).")
@click.option("--top", type=click.IntRange(min=0), default=10, show_default=True,
              help="Blocks and source lines listed as losing the most time.")
@click.option("--trace", "trace_file", type=FilePath(), default=None,
              help="Write the sampled trace to this CSV file (README 'CSV trace').")
@click.option("--dt", "dt_s", type=FiniteFloatRange(min=0, min_open=True), default=None,
              metavar="SECONDS", help="Trace sampling period [default: the IPO cycle].")
@click.option("--trace-columns", default="default", show_default=True,
              help="Trace columns: 'default', 'all' or a comma-separated list.")
@click.option("--crosscheck", is_flag=True,
              help="Compare every block with ruckig's time-optimal motion (slower).")
@feed_unit_option("Feeds of the text output")
def run_cmd(program, machine_name, as_json, no_blocks, top, trace_file, dt_s, trace_columns,
            crosscheck, feed_unit, **params):
    """Simulate PROGRAM on MACHINE: cycle time, programmed against reached feed, the time
    lost by cause (feed moves and rapids apart), the time by CAM operation, tool and source
    line (h:mm:ss, with their N numbers), and the blocks that lose the most time with their
    line, the limit that holds them and what they lose the time to."""
    from ncsim.report import jsonout, summary as report
    from ncsim.report.losses import losses
    from ncsim.pipeline import STAGES, release_freed_memory, simulate

    options = model_options(params)
    text_only_feed_unit(feed_unit, as_json)
    nc = nc_options(params)
    if no_blocks and not as_json:
        raise UsageError("--no-blocks applies to the JSON summary: add --json")
    if not trace_file and (dt_s is not None or trace_columns != "default"):
        raise UsageError("--dt and --trace-columns apply to the trace: add --trace FILE.csv")
    stages = [*STAGES, *["cross-check"] * crosscheck, "summary"]
    if trace_file:
        stages += ["sample", "write CSV"]
    progress = Progress(stages, enabled=False if params.get("quiet") else None)
    try:
        sim = simulate(program, machine_name, options, setup_offsets=params["setup_file"],
                       progress=progress, nc_options=nc)
        # nothing below reads the per-block limits (the motion has what it needs): they go
        # before the summary, the memory of a large run's peak
        sim = dataclasses.replace(sim, limits=None)
        release_freed_memory()
        check = None
        if crosscheck:
            from ncsim.plan.crosscheck import crosscheck as run_crosscheck
            with progress.stage("cross-check"):
                check = run_crosscheck(sim.motion).summary()
        with progress.stage("summary"):
            loss = losses(sim.motion)
            summary = report.summary(sim, top=top, include_blocks=False, loss=loss)
            if check is not None:
                summary["crosscheck"] = check
        rows = None
        if trace_file:
            from ncsim.report.csvio import write_trace_csv
            from ncsim.plan.sample import sample_motion
            with progress.stage("sample"):
                trace = sample_motion(sim.motion, dt_s)
            with progress.stage("write CSV"):
                columns = None if trace_columns == "default" else trace_columns
                rows = write_trace_csv(trace, trace_file, columns=columns)
    finally:
        progress.close()
    echo_warnings(sim.warnings, params.get("quiet"))
    if as_json:   # the per-block list streamed, never held whole (jsonout)
        sys.stdout.flush()
        blocks = None if no_blocks else jsonout.block_chunks(sim.motion, loss)
        jsonout.write_summary(sys.stdout, summary, blocks)
        return
    click.echo(report.format_text(summary, feed_unit), nl=False)
    if check is not None:
        click.echo(_crosscheck_text(check))
    if rows is not None:
        dt = sim.machine.ncu.ipo_cycle_s if dt_s is None else dt_s
        click.echo(f"\ntrace       {rows} samples every {s_to_ms(dt):g} ms written to {trace_file}")


def _crosscheck_text(c: dict) -> str:
    worst = ("-" if c["worst_ratio"] is None
             else f"{c['worst_ratio']:.3f} (block {c['worst_block']}, line {c['worst_line']})")
    return (f"\ncross-check against ruckig's time-optimal motion ({c['blocks_checked']} blocks)\n"
            f"  time ncsim {c['ncsim_time_s']:.3f} s, optimum {c['optimal_time_s']:.3f} s, "
            f"slower by {c['slower_time_s']:.3f} s\n"
            f"  worst ratio ncsim/ruckig {worst}\n"
            f"  limit violations {c['violations']}, faster than the optimum "
            f"{c['faster_than_optimum']}, ruckig failed {c['ruckig_failed']}")


# ---------------------------------------------------------------------------------------------
# plot
# ---------------------------------------------------------------------------------------------

@cli.command("plot")
@click.argument("program", type=FilePath(), required=False)
@machine_option(required=False)
@simulation_options
@click.option("--trace", "trace_file", type=FilePath(), default=None,
              help="Plot a trace saved by `ncsim run --trace` instead of simulating.")
@click.option("--output", "-o", "output", type=FilePath(), required=True,
              help="Figure file: .png, .svg or .pdf.")
@click.option("--dt", "dt_s", type=FiniteFloatRange(min=0, min_open=True), default=None,
              metavar="SECONDS",
              help="Sampling period [default: the time shown / 20000, at most the IPO cycle; "
                   "traces over 200,000 samples are thinned for drawing].")
@click.option("--rapids", type=click.Choice(["show", "hide"]), default="show", show_default=True,
              help="Rapids (G0) thin and grey over the cutting moves, or hidden; the scales "
                   "come from the cutting moves either way.")
@click.option("--range", "range_text", default=None, metavar="A:B",
              help="Zoom to source lines (120:340), N numbers (N1200:N3400) or seconds "
                   "(12.5s:20s); a side may stay open (120:), 'all' is the whole run.")
@feed_unit_option("Feeds of the figure")
@click.option("--title", default=None, help="Figure title [default: program and machine].")
def plot_cmd(program, machine_name, trace_file, output, dt_s, rapids, range_text, feed_unit,
             title, **params):
    """Plot a run for a machinist: feed against time and along the cutting path (shaded by
    the limit holding it), the XY path coloured by feed and framed on the cutting moves,
    acceleration and jerk. Rapids are thin and grey (or hidden); --range zooms.

    Either PROGRAM with --machine, or --trace FILE.csv (fewer panels if the CSV lacks columns).
    """
    from ncsim.motion import FULL_MODEL
    from ncsim.report import view
    from ncsim.report.plot import check_figure_file

    options = model_options(params)
    nc = nc_options(params)
    check_figure_file(output)
    spec = view.parse_range(range_text) if range_text is not None else None
    if (program is None) == (trace_file is None):
        raise UsageError("give either a PROGRAM (with --machine) or --trace FILE.csv")
    motion = machine = numbers = outline = None
    if trace_file and (params["setup_file"] or options != FULL_MODEL or dt_s is not None):
        raise UsageError("--setup, --dt and the model switches apply to a PROGRAM, not to --trace")
    if trace_file:
        from ncsim.report.csvio import read_trace_csv, trace_from_columns
        from ncsim.machine import load_machine
        trace = trace_from_columns(read_trace_csv(trace_file))
        machine = load_machine(machine_name) if machine_name else None
        window = view.window_for(spec, trace)
        head = title or os.path.basename(trace_file) + (f" on {machine.name}" if machine else "")
    else:
        if not machine_name:
            raise UsageError("--machine is required with a PROGRAM (e.g. --machine mikron)")
        import numpy as np

        from ncsim.plan.sample import sample_motion, time_grid_s
        from ncsim.pipeline import STAGES, simulate
        progress = Progress([*STAGES, "sample", "draw"], enabled=False if params.get("quiet") else None)
        try:
            sim = simulate(program, machine_name, options, setup_offsets=params["setup_file"],
                           progress=progress, nc_options=nc)
            numbers = view.block_numbers(sim.motion.path)
            window = view.window_for(spec, None, sim.motion, numbers)
            with progress.stage("sample"):
                t0, t1 = (0.0, sim.cycle_time_s) if window is None else (window.t0_s, window.t1_s)
                dt = dt_s if dt_s else _plot_dt_s(sim, t1 - t0)
                trace = sample_motion(sim.motion, t_s=np.minimum(t0 + time_grid_s(t1 - t0, dt), t1))
                outline = None if window is None else view.part_outline_xy(sim.motion)
        finally:
            progress.close()
        echo_warnings(sim.warnings, params.get("quiet"))
        motion, machine = sim.motion, sim.machine
        head = title or f"{os.path.basename(program)} on {machine.name}"
    from ncsim.report.plot import run_figure, save_figure
    result = run_figure(trace, motion=motion, machine=machine, title=head, rapids=rapids,
                        window=window, feed_unit=feed_unit, numbers=numbers, outline_xy=outline)
    save_figure(result.figure, output)
    click.echo(f"wrote {output}: panels {', '.join(result.panels)}")
    if result.missing:
        click.echo("note: left out " + "; ".join(f"{p} (needs {need})" for p, need in result.missing.items())
                   + " -- write the trace with `ncsim run --trace FILE --trace-columns all`", err=True)


PLOT_SAMPLES = 20_000


def _plot_dt_s(sim, shown_s: float | None = None) -> float:
    """Fine enough to show each jerk phase of the time shown (~20,000 samples), and never
    coarser than the IPO cycle (``plot.run_figure`` thins very long traces for drawing)."""
    ipo = sim.machine.ncu.ipo_cycle_s
    total = sim.cycle_time_s if shown_s is None else shown_s
    return min(ipo, total / PLOT_SAMPLES) if total > 0 else ipo


# ---------------------------------------------------------------------------------------------
# check
# ---------------------------------------------------------------------------------------------

@cli.command("check")
@click.argument("program", type=FilePath())
@machine_option()
@simulation_options
@click.option("--max-time", "max_time_s", type=FiniteFloatRange(min=0, min_open=True), default=None,
              metavar="SECONDS", help="Fail if the cycle time is longer.")
@click.option("--min-feed-ratio", type=FiniteFloatRange(0, 1), default=None, metavar="R",
              help="Fail if feed_efficiency (ideal time at the programmed feed / real time) is lower.")
@click.option("--max-limited-fraction", type=FiniteFloatRange(0, 1), default=None, metavar="F",
              help="Fail if a larger share of feed-move time is held below the programmed feed.")
@click.option("--baseline", "baseline_file", type=FilePath(), default=None,
              help="A summary saved with `ncsim run --json` to compare the cycle time with.")
@click.option("--max-regression", "max_regression_pct", type=FiniteFloatRange(min=0), default=None,
              metavar="PERCENT", help="Fail if the cycle time grew by more than this against --baseline.")
@click.option("--allow-empty", is_flag=True,
              help="Pass a program without motion or without M30/M2/M17 (by default it fails: "
                   "an empty or truncated export).")
@click.option("--strict", is_flag=True,
              help="Fail when the time is approximate: something that can change it (a cycle "
                   "without source, rotary axes, TRAORI, tool changes, ...) is not simulated.")
@click.option("--json", "as_json", is_flag=True, help="Print the results as JSON.")
def check_cmd(program, machine_name, max_time_s, min_feed_ratio, max_limited_fraction,
              baseline_file, max_regression_pct, allow_empty, strict, as_json, **params):
    """Check PROGRAM against thresholds, for CI: exit 0 when all hold, 1 when one fails
    (with the blocks to look at), 2 on bad input."""
    from ncsim.report import summary as report
    from ncsim.report.check import evaluate, load_baseline, require_thresholds
    from ncsim.pipeline import STAGES, simulate

    options = model_options(params)
    nc = nc_options(params)
    require_thresholds(max_time_s, min_feed_ratio, max_limited_fraction, baseline_file,
                       max_regression_pct, strict)
    baseline = load_baseline(baseline_file) if baseline_file else None
    thresholds = dict(max_time_s=max_time_s, min_feed_ratio=min_feed_ratio,
                      max_limited_fraction=max_limited_fraction, baseline=baseline,
                      max_regression_pct=max_regression_pct, baseline_name=baseline_file or "",
                      allow_empty=allow_empty, strict=strict)
    progress = Progress([*STAGES, "summary"], enabled=False if params.get("quiet") else None)
    try:
        sim = simulate(program, machine_name, options, setup_offsets=params["setup_file"],
                       progress=progress, nc_options=nc)
        with progress.stage("summary"):
            per_block = baseline is not None and "blocks_detail" in baseline
            summary = report.summary(sim, top=5, include_blocks=per_block)
    finally:
        progress.close()
    echo_warnings(sim.warnings, params.get("quiet"))
    results = evaluate(summary, **thresholds)
    failed = [r for r in results if not r.ok]
    if as_json:
        click.echo(json.dumps({"program": program, "machine": sim.machine.name,
                               "ok": not failed, "checks": [r.as_dict() for r in results]}, indent=1))
    else:
        click.echo(f"{program} on {sim.machine.name}: cycle time {summary['cycle_time_s']:.3f} s")
        for r in results:
            click.echo(r.render())
        click.echo(f"{len(failed)} of {_checks(len(results))} failed" if failed
                   else "1 check passed" if len(results) == 1
                   else f"all {_checks(len(results))} passed")
    if failed:
        sys.exit(int(ExitStatus.CHECK_FAILED))


def _checks(n: int) -> str:
    return f"{n} check" if n == 1 else f"{n} checks"


# ---------------------------------------------------------------------------------------------
# machines, explain
# ---------------------------------------------------------------------------------------------

@cli.command("machines")
def machines_cmd() -> None:
    """List the bundled machines (use the name with --machine)."""
    from ncsim.machine import bundled_machines
    machines = bundled_machines()
    width = max([len(n) for n in machines] + [4])
    for name, description in machines.items():
        click.echo(f"{name:<{width}}  {description}")


@cli.command("explain")
@machine_option()
@click.option("--radius-mm", "radii_mm", type=FiniteFloatRange(min=0, min_open=True), multiple=True,
              help="Arc radius of a table row (repeatable) [default: 1 2.5 5 10 20 30 50 100].")
@click.option("--plot", "plot_file", type=FilePath(), default=None,
              help="Also draw the limits against the radius (.png, .svg, .pdf).")
@click.option("--json", "as_json", is_flag=True, help="Print the table as JSON (feeds in mm/min).")
@feed_unit_option("Feeds of the text and the plot")
def explain_cmd(machine_name, radii_mm, plot_file, as_json, feed_unit) -> None:
    """Show MACHINE's axis limits, NCU settings and the steady feed each limit allows on an
    XY circle of radius R (paper eq. 2-11), with the limit that binds."""
    from ncsim.report.explain import DEFAULT_RADII_MM, direction_extremes, radius_table
    from ncsim.machine import load_machine

    text_only_feed_unit(feed_unit, as_json and not plot_file)
    if plot_file:
        from ncsim.report.plot import check_figure_file
        check_figure_file(plot_file)
    machine = load_machine(machine_name)
    for warning in machine.warnings:
        click.echo(warning.render(), err=True)
    radii = sorted(set(radii_mm)) if radii_mm else list(DEFAULT_RADII_MM)
    rows = radius_table(machine, radii)
    if as_json:
        click.echo(json.dumps({"machine": machine.name, "units": "mm/min",
                               "radii": [r.as_dict() for r in rows]}, indent=1))
    else:
        click.echo(_explain_text(machine, direction_extremes(machine), rows, feed_unit))
    if plot_file:
        import numpy as np

        from ncsim.report.plot import explain_figure, save_figure
        lo, hi = min(radii), max(radii)
        dense = np.geomspace(lo, hi, 80) if hi > lo else np.array([lo])
        save_figure(explain_figure(radius_table(machine, dense), machine.name, feed_unit), plot_file)
        if not as_json:
            click.echo(f"\nwrote {plot_file}")


#: decimals of a feed in the explain table, per unit
EXPLAIN_DECIMALS = {"mm/min": 0, "m/min": 2, "mm/s": 1, "in/min": 1}


def _explain_text(machine, ext, rows, feed_unit: str = "mm/min") -> str:
    from ncsim.units import feed_from_mm_s, mm_min_to_mm_s, mm_s2_to_m_s2, mm_s3_to_m_s3
    n = machine.ncu
    d = EXPLAIN_DECIMALS[feed_unit]
    unit = feed_unit

    def f(v_mm_s) -> float:
        return feed_from_mm_s(v_mm_s, feed_unit)

    def g(v_mm_min) -> float:
        return feed_from_mm_s(mm_min_to_mm_s(v_mm_min), feed_unit)

    out = [f"machine  {machine.name}: {machine.description}", f"file     {machine.source}", "",
           f"axes   V_max {unit:<7} A_max m/s^2  J_max m/s^3  Kv 1/s",
           "       (MD32000)      (MD32300)    (MD32431)    (MD32200)"]
    for a in machine.axes:
        kv = "-" if a.position_gain_1_s is None else f"{a.position_gain_1_s:g}"
        out.append(f"  {a.name}    {f(a.max_velocity_mm_s):11.{d}f}  "
                   f"{mm_s2_to_m_s2(a.max_accel_mm_s2):11.3g}  {mm_s3_to_m_s3(a.max_jerk_mm_s3):11.3g}  {kv:>9}")
    out += ["", "NCU",
            f"  interpolation cycle t_cy           {s_to_ms(n.ipo_cycle_s):g} ms",
            f"  curvilinear jerk J_curv            {mm_s3_to_m_s3(n.curvilinear_jerk_mm_s3):g} m/s^3",
            f"  tangential / central share         r_jct {n.tangential_jerk_share:g}, r_jcc {n.central_jerk_share:g}",
            f"  tangential path jerk J_tcurv       {mm_s3_to_m_s3(n.tangential_jerk_mm_s3):g} m/s^3"
            f"   (eq. 10: J_curv x r_jct)",
            f"  transition time dt (eq. 13)        {s_to_ms(n.transition_time_s):g} ms",
            f"  look-ahead                         {n.lookahead_blocks} blocks",
            f"  normal acceleration share          {n.normal_accel_share:g}",
            "  G64 overload factor (MD32310)      "
            + ", ".join(f"{a.name} {a.max_accel_ovl_factor:g}" for a in machine.axes),
            f"  exact-stop settle G601 / G602      {s_to_ms(n.exact_stop_fine_settle_s):g} / "
            f"{s_to_ms(n.exact_stop_coarse_settle_s):g} ms",
            "  default feed (SD42110)             " + (
                f"{f(n.default_feed_mm_s):.{d}f} {unit} until the first F" if n.default_feed_mm_s > 0
                else "0: G1/G2/G3 before any F is alarm 10860"),
            "", "over the tangent direction in XY",
            f"  J_t (eq. 9)   {mm_s3_to_m_s3(ext['jerk_t_mm_s3'][0]):.3g} .. "
            f"{mm_s3_to_m_s3(ext['jerk_t_mm_s3'][1]):.3g} m/s^3",
            f"  A_n (eq. 8)   {mm_s2_to_m_s2(ext['accel_n_mm_s2'][0]):.3g} .. "
            f"{mm_s2_to_m_s2(ext['accel_n_mm_s2'][1]):.3g} m/s^2",
            f"  V_t (eq. 7)   {f(ext['velocity_t_mm_s'][0]):.{d}f} .. "
            f"{f(ext['velocity_t_mm_s'][1]):.{d}f} {unit}",
            "", f"steady feed ({unit}) each limit allows on an XY circle of radius R; set point: what",
            "ncsim plans for a full circle from rest without F limit (eq. 12), and the limit that binds",
            f"  {'R mm':>6} {'V_Jtcurv':>9} {'V_Jt':>15} {'V_An':>15} {'V_t':>15} {'V_tcy':>9} "
            f"{'V_fr':>8} {'set pt':>8}  binds",
            f"  {'':>6} {'eq. 11':>9} {'eq. 4/9':>15} {'eq. 2/8':>15} {'eq. 7':>15} {'eq. 6':>9} "
            f"{'eq. 13':>8} {'eq. 12':>8}"]
    for r in rows:
        span = lambda lo, hi: f"{g(lo):.{d}f}..{g(hi):.{d}f}"  # noqa: E731
        out.append(f"  {r.radius_mm:6g} {g(r.v_jtcurv_mm_min):9.{d}f} {span(r.v_jt_min_mm_min, r.v_jt_max_mm_min):>15} "
                   f"{span(r.v_an_min_mm_min, r.v_an_max_mm_min):>15} {span(r.v_t_min_mm_min, r.v_t_max_mm_min):>15} "
                   f"{g(r.v_tcy_mm_min):9.{max(d - 1, 0)}f} {g(r.v_fr_line_mm_min):8.{d}f} {g(r.setpoint_mm_min):8.{d}f}  {r.binding}")
    out.append("  (V_Jt, V_An, V_t: min..max over the direction; V_tcy: one full circle per block; "
               "V_fr: a line entering the arc, weakest tangent)")
    return "\n".join(out)


@cli.command("warmup")
def warmup_cmd() -> None:
    """Compile ncsim's numba kernels now (once after installing, 10-20 s), so that no later
    run pauses to compile. Programs under about 10,000 blocks never need them."""
    import time

    from ncsim.gap.pipeline import warmup_kernels
    from ncsim.pipeline import warmup
    t0 = time.perf_counter()
    warmup()
    warmup_kernels()       # the gap's (ncsim gap)
    click.echo(f"kernels ready ({time.perf_counter() - t0:.1f} s); later runs load them from "
               f"numba's cache")


# ---------------------------------------------------------------------------------------------
# Commands written in their own modules
# ---------------------------------------------------------------------------------------------

cli.add_command(batch)
cli.add_command(compare_cmd)
cli.add_command(gap)
cli.add_command(report_cmd)


def one_line_warning(message, category, filename, lineno, line=None) -> str:
    """A Python warning (numpy's RuntimeWarning on a degenerate value...) as one line, without
    the source line Python prints under it: ncsim's own inputs are validated so that none
    should reach a user (the test suite turns them into errors), but one that does must not
    look like a crash."""
    return f"ncsim: warning: {category.__name__}: {message} ({os.path.basename(filename)}:{lineno})\n"


def _tune_allocator() -> None:
    """For a process that runs large programs (the CLI): blocks of 4 MiB and more (a column of
    half a million blocks) straight from the system and back to it when freed, smaller ones
    from the C heap, which is trimmed only between stages (``pipeline.release_freed_memory``).
    glibc's default moves that threshold up to the largest block freed so far and trims the
    heap whenever its top is free, so a run's path-size columns piled up in the heap while
    its chunk-size temporaries went back and forth to the system; 1M-block CAM program: peak
    597 -> 561 MiB in the same time. A no-op without glibc's ``mallopt``."""
    import ctypes

    try:
        mallopt = ctypes.CDLL(None).mallopt
    except (OSError, TypeError, AttributeError):    # not glibc
        return
    mallopt(_M_MMAP_THRESHOLD, 4 << 20)
    mallopt(_M_TRIM_THRESHOLD, 1 << 30)


_M_TRIM_THRESHOLD = -1     # glibc malloc.h
_M_MMAP_THRESHOLD = -3


def main() -> None:
    import warnings
    warnings.formatwarning = one_line_warning
    _tune_allocator()
    try:
        cli.main(prog_name="ncsim", standalone_mode=True)
    except KeyboardInterrupt:  # pragma: no cover - Ctrl-C while click parses the arguments
        click.echo("ncsim: interrupted", err=True)
        sys.exit(int(ExitStatus.INTERRUPTED))
