"""``ncsim report PROGRAM --machine M -o report.html``: one self-contained HTML page of a run.

Arguments and output only: the page is :func:`ncsim.report.html.report_html` (plotly, its
JavaScript inlined: the file opens without network).
"""
from __future__ import annotations

import os

import click

from ncsim.cli.options import (Progress, echo_warnings, feed_unit_option, machine_option,
                               model_options, nc_options, simulation_options)
from ncsim.cli.params import FilePath
from ncsim.errors import UsageError


@click.command("report")
@click.argument("program", type=FilePath())
@machine_option()
@simulation_options
@click.option("--output", "-o", "output", type=FilePath(), required=True,
              help="The HTML file to write (self-contained: opens without network).")
@click.option("--max-points", type=click.IntRange(min=100), default=10_000, show_default=True,
              help="Samples drawn per figure at most (large programs are decimated).")
@click.option("--title", default=None, help="Page title [default: program and machine].")
@feed_unit_option("Feeds of the page")
def report_cmd(program, machine_name, output, max_points, title, feed_unit, **params):
    """Write one HTML page of PROGRAM on MACHINE: the 3-D toolpath coloured by feed (hover a
    point: its file:line, N number, tool, operation and limit), the feed against time with
    the CAM operations marked, and the time by operation, tool and source line."""
    from ncsim.pipeline import STAGES, simulate
    from ncsim.report.html import report_html
    from ncsim.report.summary import summary

    if os.path.splitext(output)[1].lower() not in (".html", ".htm"):
        raise UsageError(f"{output}: the report is an HTML file (.html)")
    options = model_options(params)
    nc = nc_options(params)
    quiet = params.get("quiet")
    progress = Progress([*STAGES, "summary", "page"], enabled=False if quiet else None)
    try:
        sim = simulate(program, machine_name, options, setup_offsets=params["setup_file"],
                       progress=progress, nc_options=nc)
        with progress.stage("summary"):
            s = summary(sim, top=10, include_blocks=False)
        with progress.stage("page"):
            page = report_html(sim, s, title=title, feed_unit=feed_unit, max_points=max_points)
    finally:
        progress.close()
    echo_warnings(sim.warnings, quiet)
    try:
        with open(output, "w", encoding="utf-8") as f:
            f.write(page)
    except OSError as exc:
        raise UsageError(f"{output}: cannot write the report: {exc.strerror or exc}") from None
    click.echo(f"wrote {output}: {len(page.encode('utf-8')) / 1e6:.1f} MB, cycle time "
               f"{s['cycle_time_s']:.3f} s")
