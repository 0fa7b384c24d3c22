"""`ncsim batch`: simulate many programs in parallel (local processes or a Dask cluster)."""
from __future__ import annotations

import json
import os
import sys

import click

from ncsim.errors import ExitStatus


@click.command("batch")
@click.argument("patterns", nargs=-1, required=True)
@click.option("--machine", "-m", "machine_name", required=True,
              help="Machine TOML file or bundled machine name (see `ncsim machines`).")
@click.option("--jobs", "-j", type=int, default=lambda: os.cpu_count() or 1, show_default="CPU count",
              help="Parallel worker processes on this machine.")
@click.option("--scheduler", metavar="ADDRESS", default=None,
              help="Run on a Dask distributed cluster instead (e.g. tcp://host:8786); "
                   "the workers need ncsim installed.")
@click.option("--json", "as_json", is_flag=True, help="Print the results as JSON.")
def batch(patterns, machine_name, jobs, scheduler, as_json):
    """Simulate every program matching PATTERNS (globs, ** recurses) and summarise them.

    Exit status 0 when every program ran, 2 when any could not be simulated.
    """
    from ncsim.machine import load_machine
    from ncsim.pipeline import expand_programs, run_batch

    programs = expand_programs(patterns)
    machine = load_machine(machine_name)
    if sys.stderr.isatty():  # a progress bar for people; silence for logs and CI
        with click.progressbar(length=len(programs), label="simulating", file=sys.stderr,
                               show_pos=True) as bar:
            results = run_batch(programs, machine, jobs=jobs, scheduler=scheduler,
                                on_result=lambda _r: bar.update(1))
    else:
        results = run_batch(programs, machine, jobs=jobs, scheduler=scheduler)
    if as_json:
        click.echo(json.dumps({"machine": machine.name, "results": [r.to_dict() for r in results]},
                              indent=2))
    else:
        click.echo(_table(results))
    failed = [r for r in results if not r.ok]
    for r in failed:
        click.echo(r.error, err=True)
    if failed:
        sys.exit(int(ExitStatus.BAD_INPUT))


def _table(results) -> str:
    width = max([len(r.program) for r in results] + [7])
    lines = [f"{'program':<{width}} {'status':<6} {'cycle s':>10} {'blocks':>9} {'eff %':>6} {'limited %':>9} {'run s':>7}"]
    for r in results:
        if r.ok:
            lines.append(f"{r.program:<{width}} {'ok':<6} {r.cycle_time_s:10.3f} {r.blocks:9d} "
                         f"{100 * r.feed_efficiency:6.1f} {100 * r.limited_fraction:9.1f} {r.elapsed_s:7.2f}")
        else:
            lines.append(f"{r.program:<{width}} {'error':<6} {'-':>10} {'-':>9} {'-':>6} {'-':>9} {r.elapsed_s:7.2f}")
    ok = [r for r in results if r.ok]
    total = sum(r.cycle_time_s for r in ok)
    lines.append(f"{len(ok)}/{len(results)} programs simulated, total cycle time {total:.3f} s")
    return "\n".join(lines)
