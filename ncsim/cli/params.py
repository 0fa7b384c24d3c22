"""Click parameter types that reject what click lets through: NaN and infinite numbers
(``--max-time nan`` would compare false with everything and pass or fail at random) and empty
file names (``--trace ''`` would silently write nothing). Both fail as click usage errors:
one line, exit 2. And the ``--dialect`` option the program-reading commands share."""
from __future__ import annotations

import math

import click


class FiniteFloatRange(click.FloatRange):
    """A :class:`click.FloatRange` of finite numbers only."""

    def convert(self, value, param, ctx):
        rv = super().convert(value, param, ctx)
        if not math.isfinite(rv):
            self.fail(f"{value!r} is not a finite number.", param, ctx)
        return rv


class FilePath(click.Path):
    """A file name (``click.Path(dir_okay=False)``) that is not empty."""

    def __init__(self, **kwargs):
        super().__init__(dir_okay=False, **kwargs)

    def convert(self, value, param, ctx):
        if isinstance(value, str) and not value.strip():
            self.fail("the file name is empty.", param, ctx)
        return super().convert(value, param, ctx)


def dialect_option(func):
    """``--dialect siemens|iso``: the language the program starts in (ISO dialect mode is G291;
    default: the machine file's ``[iso] dialect``, else Siemens)."""
    return click.option("--dialect", type=click.Choice(["siemens", "iso"]), default=None,
                        help="The language the program starts in: siemens (G290) or iso (ISO "
                             "dialect milling, Fanuc-style, G291) [default: the machine file's "
                             "[iso] dialect, else siemens].")(func)
