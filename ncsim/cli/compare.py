"""``ncsim compare A B``: two runs side by side, with an exit status for CI.

A and B are programs (simulated on ``--machine``) or summaries saved by ``ncsim run --json``
(any mix, all of one machine). What is compared and how is :mod:`ncsim.report.compare`; this
module reads the arguments, simulates, prints and sets the exit status: 0 when B is within
``--max-slower`` of A (or no threshold is given), 1 when it is slower, 2 on bad input.
"""
from __future__ import annotations

import json
import sys

import click

from ncsim.cli.options import (Progress, echo_warnings, machine_option, model_options,
                               nc_options, simulation_options)
from ncsim.cli.params import FilePath, FiniteFloatRange
from ncsim.errors import ExitStatus, UsageError


def _summary_of(file: str, machine_name: str | None, options, nc: dict, params: dict) -> dict:
    """The JSON summary of ``file``: read when it is one, else the program simulated."""
    from ncsim.pipeline import STAGES, simulate
    from ncsim.report import compare as cmp
    from ncsim.report.summary import summary

    if cmp.is_summary_file(file):
        return cmp.load_summary(file)
    if not machine_name:
        raise UsageError(f"{file} is a program: give --machine to simulate it (or compare "
                         f"summaries saved by `ncsim run --json`)")
    quiet = params.get("quiet")
    progress = Progress([*STAGES, "summary"], enabled=False if quiet else None)
    try:
        sim = simulate(file, machine_name, options, setup_offsets=params["setup_file"],
                       progress=progress, nc_options=nc)
        with progress.stage("summary"):
            s = summary(sim, top=5, include_blocks=False)
    finally:
        progress.close()
    echo_warnings(sim.warnings, quiet)
    return s


@click.command("compare")
@click.argument("a", type=FilePath())
@click.argument("b", type=FilePath())
@machine_option(required=False)
@simulation_options
@click.option("--max-slower", "max_slower_pct", type=FiniteFloatRange(min=0), default=None,
              metavar="PCT", help="Exit 1 when B's cycle time is more than PCT percent longer "
                                  "than A's (CI).")
@click.option("--json", "as_json", is_flag=True, help="Print the comparison as JSON.")
def compare_cmd(a, b, machine_name, max_slower_pct, as_json, **params):
    """Compare two runs: A and B are programs (simulated on --machine) or summaries saved by
    `ncsim run --json`. Prints the cycle time, the time at the programmed feeds, the time lost
    and the time of each CAM operation and tool side by side, with B - A.

    Exit status: 0, or 1 when --max-slower is exceeded, 2 on bad input.
    """
    from ncsim.report import compare as cmp

    options = model_options(params)
    nc = nc_options(params)
    summaries = [_summary_of(f, machine_name, options, nc, params) for f in (a, b)]
    if machine_name:
        from ncsim.machine import load_machine
        name = load_machine(machine_name).name
        for f, s in zip((a, b), summaries):
            if s["machine"] != name:
                raise UsageError(f"{f} ran on {s['machine']!r}, not on --machine {name!r}: "
                                 f"compare runs on one machine")
    result = cmp.compare(*summaries, name_a=a, name_b=b, max_slower_pct=max_slower_pct)
    if as_json:
        click.echo(json.dumps(result, indent=1))
    else:
        click.echo(cmp.format_text(result), nl=False)
    if not result["ok"]:
        sys.exit(int(ExitStatus.CHECK_FAILED))
