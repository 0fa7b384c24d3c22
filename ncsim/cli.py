"""The `ncsim` command: argument handling, output and exit codes only.

The library raises :class:`ncsim.errors.NcsimError`; this module prints its one-line
rendering on stderr and exits with :class:`ncsim.errors.ExitStatus` (never a traceback).
"""
from __future__ import annotations

import math
import sys

import click

from . import __version__
from .errors import ExitStatus, NcsimError


class NcsimGroup(click.Group):
    """A click group that turns ncsim errors into one line on stderr and exit status 2."""

    def invoke(self, ctx: click.Context):
        try:
            return super().invoke(ctx)
        except NcsimError as exc:
            click.echo(exc.render(), err=True)
            ctx.exit(int(exc.exit_status))


@click.group(cls=NcsimGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="ncsim")
def cli() -> None:
    """Simulate SINUMERIK 840D programs on a high-speed machine: cycle time, feed limits, gaps."""


@cli.command("parse")
@click.argument("program", type=click.Path(dir_okay=False))
@click.option("--machine", "machine_name", default=None,
              help="Machine: a bundled name (mikron) or a TOML file; gives work offsets and circle tolerances.")
@click.option("--setup", "setup_file", default=None, type=click.Path(dir_okay=False),
              help="Setup TOML with [work_offsets] G54 = [x, y, z] (overrides the machine's).")
@click.option("--json", "as_json", is_flag=True, help="Print the segments and summary as JSON.")
@click.option("--limit", type=click.IntRange(min=0), default=None, help="Print only the first N segments.")
def parse_cmd(program, machine_name, setup_file, as_json, limit) -> None:
    """Interpret PROGRAM and list its path segments (warnings on stderr)."""
    from .frames import read_setup_offsets
    from .interpret import interpret_file
    from .machine import load_machine

    machine = load_machine(machine_name) if machine_name else None
    offsets = read_setup_offsets(setup_file) if setup_file else None
    result = interpret_file(program, machine, setup_offsets=offsets)
    for warning in result.warnings:
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
    for i in range(shown):
        click.echo(_segment_text(path.segment(i)))
    if shown < path.n:
        click.echo(f"... {path.n - shown} more segments")
    s = _summary_dict(result)
    click.echo(f"segments: {s['segments']} ({s['lines']} lines, {s['arcs']} arcs)  "
               f"total length: {s['total_length_mm']:.3f} mm  blocks executed: "
               f"{s['blocks_executed']}  warnings: {s['warnings']}")


def _xyz(v) -> str:
    return "(" + ", ".join(f"{float(c):.4f}" for c in v) + ")"


def _feed_mm_min(seg) -> float | None:
    from .units import mm_s_to_mm_min
    return None if seg.rapid else mm_s_to_mm_min(seg.feed_mm_s)


def _flags(seg) -> list[str]:
    from .path import ACCEL_MODE_NAMES
    flags = ["G0" if seg.rapid else "feed", f"G{seg.cp_mode}", f"G{seg.stop_window}",
             ACCEL_MODE_NAMES[seg.accel_mode]]
    if seg.exact_stop:
        flags.append("exact_stop")
    if seg.cp_mode == 641 or seg.adis_mm:
        flags.append(f"adis={seg.adis_mm:g}")
    if seg.ffw:
        flags.append("FFWON")
    if seg.stop_before:
        flags.append("stop_before")
    if seg.dwell_before_s:
        flags.append(f"dwell_before={seg.dwell_before_s:g}s")
    return flags


def _segment_text(seg) -> str:
    """One output line per segment: index, source line, kind, geometry, length, feed, flags."""
    feed = _feed_mm_min(seg)
    kind = "arc" if seg.is_arc else "line"
    text = (f"{seg.index:>7} {seg.file}:{seg.line:<6} {kind:<4} {_xyz(seg.start_mm)} -> "
            f"{_xyz(seg.end_mm)}")
    if seg.is_arc:
        text += (f" centre={_xyz(seg.center_mm)} radius_mm={seg.radius_mm:.4f} "
                 f"sweep_deg={math.degrees(seg.sweep_rad):.3f} normal={_xyz(seg.normal)}")
        if seg.helix_mm:
            text += f" helix_mm={seg.helix_mm:.4f}"
    text += f" length_mm={seg.length_mm:.4f} feed_mm_min={'rapid' if feed is None else f'{feed:g}'}"
    return text + " " + " ".join(_flags(seg))


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


def main() -> None:
    try:
        cli.main(prog_name="ncsim", standalone_mode=True)
    except KeyboardInterrupt:  # pragma: no cover - interactive only
        click.echo("interrupted", err=True)
        sys.exit(130)
