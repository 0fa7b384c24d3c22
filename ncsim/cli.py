"""The `ncsim` command: argument handling, output and exit codes only.

The library raises :class:`ncsim.errors.NcsimError`; this module prints its one-line
rendering on stderr and exits with :class:`ncsim.errors.ExitStatus` (never a traceback).
"""
from __future__ import annotations

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


def main() -> None:
    try:
        cli.main(prog_name="ncsim", standalone_mode=True)
    except KeyboardInterrupt:  # pragma: no cover - interactive only
        click.echo("interrupted", err=True)
        sys.exit(130)
