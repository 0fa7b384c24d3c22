"""Options and helpers shared by the commands that simulate a program (``run``, ``plot``,
``check`` in ``cli.main``; ``report`` and ``compare`` in their own modules): how the program is
read, the model switches, the machine, the feed unit, ``--quiet``, the progress bar on stderr
and the warnings printed there. Arguments and output only."""
from __future__ import annotations

import sys
import threading
import time
from contextlib import contextmanager

import click

from ncsim.cli.params import FilePath, dialect_option
from ncsim.errors import UsageError
from ncsim.units import FEED_UNITS


def program_options(func):
    """How the program is read: subprogram folders, missing subprograms, GUD definitions and
    the block budget, the dialect (``nc_options`` pops them for ``pipeline.simulate``)."""
    func = dialect_option(func)
    func = click.option("--block-budget", type=click.IntRange(min=1), default=None, metavar="N",
                        help="Stop as an endless loop after N executed blocks [default: the "
                             "program's lines + 2,000,000, FOR loop passes not counted].")(func)
    func = click.option("--definitions", type=click.Path(dir_okay=False, exists=True), multiple=True,
                        metavar="FILE", help="GUD definitions file (MGUD.DEF, UGUD.DEF: DEF "
                        "NCK|CHAN type name), read before the program; repeatable.")(func)
    func = click.option("--missing-subprograms", type=click.Choice(["error", "warn"]),
                        default="error", show_default=True,
                        help="A call of a subprogram found nowhere: an error, or a warning "
                             "(no motion, the time is marked approximate).")(func)
    func = click.option("--subprograms", type=click.Path(file_okay=False, exists=True), multiple=True,
                        metavar="DIR", help="Folder searched for subprogram and cycle files "
                        "(NAME.SPF/.MPF, any case) after the program's own folder; "
                        "repeatable.")(func)
    return func


def nc_options(params: dict) -> dict:
    """The interpreter options of :func:`program_options` (popped from ``params``)."""
    return {"subprograms": params.pop("subprograms", ()),
            "missing_subprograms": params.pop("missing_subprograms", "error"),
            "definitions": params.pop("definitions", ()),
            "block_budget": params.pop("block_budget", None),
            "dialect": params.pop("dialect", None)}


#: ModelOptions fields that a --no-... flag switches off, with their help.
MODEL_FLAGS = (
    ("ncu_path_jerk", "the NCU path-jerk set point V_Jtcurv (eq. 10-11)"),
    ("axis_jerk_setpoint", "the axis-jerk set point V_Jt at alpha_c (eq. 4/9)"),
    ("transition_crossing", "the curvature-jump crossing feed V_fr (eq. 13/15)"),
    ("cycle_time_limit", "the one-block-per-IPO-cycle limit V_tcy (eq. 6)"),
    ("jerk_limited_ramps", "jerk-limited ramps (phases A/C become acceleration-limited)"),
    ("lookahead", "the finite look-ahead (stop at the end of the prepared blocks)"),
)
ACCEL_MODES = ("soft", "brisk", "drive")


def machine_option(required: bool = True):
    return click.option("--machine", "-m", "machine_name", required=required, metavar="MACHINE",
                        help="Machine: a TOML file or the name of a bundled machine "
                             "(`ncsim machines`), e.g. mikron.")


def feed_unit_option(what: str = "Feeds"):
    """``--feed-unit``: the one unit of every feed a text output prints (mm/min by default)."""
    return click.option("--feed-unit", type=click.Choice(FEED_UNITS), default="mm/min",
                        show_default=True, help=f"{what} in this unit.")


def text_only_feed_unit(feed_unit: str, as_json: bool) -> None:
    if as_json and feed_unit != "mm/min":
        raise UsageError("--feed-unit applies to the text output; the JSON keeps mm/min "
                         "(the unit is in its key names)")


def simulation_options(func):
    """PROGRAM-independent options of every command that simulates: --setup, how the program
    is read (:func:`program_options`) and the model."""
    func = program_options(func)
    for field, what in reversed(MODEL_FLAGS):
        flag = "--no-" + field.replace("_", "-")
        func = click.option(flag, f"no_{field}", is_flag=True, help=f"Switch off {what}.")(func)
    func = click.option("--accel-mode", type=click.Choice(ACCEL_MODES, case_sensitive=False),
                        default=None, help="Force SOFT, BRISK or DRIVE on every block.")(func)
    func = click.option("--setup", "setup_file", default=None, type=FilePath(),
                        help="Setup TOML with [work_offsets] G54 = [x, y, z] "
                             "(overrides the machine's).")(func)
    return quiet_option(func)


def quiet_option(func):
    """``--quiet``: nothing on stderr but errors (no warnings, no progress bar)."""
    return click.option("--quiet", "-q", is_flag=True,
                        help="Print no warnings and no progress on stderr (errors still; "
                             "the JSON keeps the warnings).")(func)


def model_options(params: dict):
    """The ModelOptions of the --no-... and --accel-mode flags (popped from ``params``)."""
    from ncsim.motion import ModelOptions
    from ncsim.path import BRISK, DRIVE, SOFT
    off = {field: False for field, _ in MODEL_FLAGS if params.pop(f"no_{field}", False)}
    mode = params.pop("accel_mode", None)
    if mode is not None:
        off["accel_mode"] = {"soft": SOFT, "brisk": BRISK, "drive": DRIVE}[mode.lower()]
    return ModelOptions(**off)


class Progress:
    """Stage-by-stage progress on stderr, drawn only on a terminal (silent in logs and CI).

    Calling it with a stage name begins that stage (and ends the one before): it is the
    ``progress`` callback of ``ncsim.pipeline.simulate``; ``stage`` does the same for the
    command's own stages. While a stage runs, a daemon thread redraws the line every
    ``TICK_S`` so that the elapsed time moves on long stages (interpreting a million blocks
    takes seconds)."""

    WIDTH = 24
    TICK_S = 0.25

    def __init__(self, stages: list[str], stream=None, enabled: bool | None = None):
        self.stream = stream if stream is not None else sys.stderr
        if enabled is None:
            isatty = getattr(self.stream, "isatty", None)
            enabled = bool(isatty and isatty())
        self.enabled = enabled
        self.stages = list(stages)
        self.started = 0
        self.current = ""
        self.t0 = time.perf_counter()
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._ticker: threading.Thread | None = None

    def _draw(self) -> None:
        n = len(self.stages)
        done = max(self.started - 1, 0)
        filled = self.WIDTH * done // max(n, 1)
        bar = "#" * filled + "-" * (self.WIDTH - filled)
        self.stream.write(f"\r\033[Kncsim [{bar}] {min(done + 1, n)}/{n} {self.current} "
                          f"({time.perf_counter() - self.t0:.1f} s)")
        self.stream.flush()

    def _tick(self) -> None:
        while not self._stop.wait(self.TICK_S):
            with self._lock:
                if not self._stop.is_set():
                    self._draw()

    def __call__(self, name: str) -> None:
        self.started += 1
        if not self.enabled:
            return
        with self._lock:
            self.current = name
            self._draw()
        if self._ticker is None:
            self._ticker = threading.Thread(target=self._tick, name="ncsim-progress", daemon=True)
            self._ticker.start()

    @contextmanager
    def stage(self, name: str):
        self(name)
        yield

    def close(self) -> None:
        if self.enabled:
            self._stop.set()
            if self._ticker is not None:
                self._ticker.join()
            self.stream.write("\r\033[K")
            self.stream.flush()


def echo_warnings(warnings, quiet: bool = False) -> None:
    """The warnings on stderr, grouped by kind: the first few of each located, then how many
    more (``report.notices.grouped``); nothing with ``--quiet``."""
    if quiet:
        return
    from ncsim.report.notices import grouped
    for line in grouped(warnings):
        click.echo(line, err=True)
