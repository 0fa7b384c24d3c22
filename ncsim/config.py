"""One reader for ncsim's TOML files: machine files, setup files and published values.

Every file goes through :func:`read_toml`, and every key through a :class:`Problems`
collector, so all three formats fail the same way: one line per file, never a traceback::

    FILE: cannot read machine file: No such file or directory
    FILE: cannot read setup file: not UTF-8 text (byte 0xe9 at line 3, column 7)
    FILE: not valid TOML: Expected '=' after a key in a key/value pair (at line 2, column 5)
    FILE: key.path: message (and 2 more: other.key: message; ...)

Problems with keys (missing, unknown, mistyped, out of range) are all collected before the
file is rejected, so one run names every mistake. Each format raises its own error class
(:class:`~ncsim.errors.MachineSpecError` for machine and setup files,
:class:`~ncsim.errors.MeasuredDataError` for published values); all render as above. Values
keep their unit in the key (``max_accel_m_s2``); converters from ``ncsim.units`` turn them into
mm and s as they are read.

The schemas live with what they describe: the machine file in ``ncsim.machine``, the
published values in ``ncsim.gap.measured``; the setup file, which is only work offsets, here
(:func:`load_setup`).
"""
from __future__ import annotations

import math
import os
import re
import tomllib
from importlib.resources.abc import Traversable
from pathlib import Path as FsPath
from typing import Any, Callable

from ncsim.errors import ConfigError, ConfigWarning, MachineSpecError

ErrorClass = Callable[..., Exception]   # called as cls(message, file=..., key=...)


# ---------------------------------------------------------------------------------------------
# Reading
# ---------------------------------------------------------------------------------------------

def read_text(source: str | FsPath | Traversable, what: str, *, name: str | None = None,
              error: ErrorClass = ConfigError) -> str:
    """The UTF-8 text of ``source`` (a path, or a resource of an installed package; a byte-order
    mark is dropped). ``what`` names the file in messages (``"machine file"``), ``name`` is the
    ``FILE`` they start with (default: ``source`` itself)."""
    file = str(source) if name is None else name
    try:
        data = FsPath(source).read_bytes() if isinstance(source, (str, os.PathLike)) else source.read_bytes()
    except OSError as exc:
        raise error(f"cannot read {what}: {exc.strerror or exc}", file=file) from None
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = data.count(b"\n", 0, exc.start) + 1
        column = exc.start - (data.rfind(b"\n", 0, exc.start) + 1) + 1
        raise error(f"cannot read {what}: not UTF-8 text (byte 0x{data[exc.start]:02x} at line "
                    f"{line}, column {column})", file=file) from None


def parse_toml(text: str, file: str, *, error: ErrorClass = ConfigError) -> dict[str, Any]:
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise error(f"not valid TOML: {exc}", file=file) from None


def read_toml(source: str | FsPath | Traversable, what: str, *, name: str | None = None,
              error: ErrorClass = ConfigError) -> dict[str, Any]:
    """The parsed TOML of ``source`` (see :func:`read_text`)."""
    file = str(source) if name is None else name
    return parse_toml(read_text(source, what, name=file, error=error), file, error=error)


# ---------------------------------------------------------------------------------------------
# Checking keys
# ---------------------------------------------------------------------------------------------

def positive(v: float) -> str | None:
    return None if v > 0 and math.isfinite(v) else "must be a positive number"


def non_negative(v: float) -> str | None:
    return None if v >= 0 and math.isfinite(v) else "must be zero or positive"


def share(v: float) -> str | None:
    return None if 0.0 < v <= 1.0 else "must be in (0, 1]"


def share0(v: float) -> str | None:
    return None if 0.0 <= v <= 1.0 else "must be in [0, 1]"


def open_share(v: float) -> str | None:
    return None if 0.0 < v < 1.0 else "must be in (0, 1), exclusive"


def finite(v: float) -> str | None:
    return None if math.isfinite(v) else "must be a finite number"


def between(lo: float, hi: float, unit: str) -> Callable[[float], str | None]:
    """A check for ``lo <= v <= hi`` (in the file's ``unit``): the physically possible range
    of a key, wide enough for any real machine, narrow enough that no arithmetic on it
    overflows or divides by (almost) zero."""
    def check(v: float) -> str | None:
        return None if lo <= v <= hi else f"must be between {lo:g} and {hi:g} {unit}".rstrip()
    return check


#: |coordinate| of a work offset: the 840D's input range for positions (+-999 999 999.9999)
MAX_OFFSET_MM = 1e9


def is_number(v: object) -> bool:
    """An int or a float, but not a bool (TOML ``true`` is no number)."""
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def key_path(prefix: str, key: str) -> str:
    return f"{prefix}.{key}" if prefix else key


class Problems:
    """Collects the problems of one file and raises them together (module docstring).

    The typed getters return the converted value, or None when the key is absent (after
    noting it if ``required``) or wrong (after noting the problem)."""

    def __init__(self, file: str, error: ErrorClass = ConfigError):
        self.file = file
        self.error = error
        self.items: list[tuple[str, str]] = []
        self.warnings: list[ConfigWarning] = []

    def __bool__(self) -> bool:
        return bool(self.items)

    def add(self, key: str, message: str) -> None:
        self.items.append((key, message))

    def raise_if_any(self) -> None:
        if not self.items:
            return
        key, message = self.items[0]
        if len(self.items) > 1:
            others = "; ".join(f"{k}: {m}" for k, m in self.items[1:])
            message += f" (and {len(self.items) - 1} more: {others})"
        raise self.error(message, file=self.file, key=key)

    def unknown(self, table: dict, prefix: str, known, message: str = "unknown key") -> None:
        """Note every key of ``table`` not in ``known``."""
        for key in table:
            if key not in known:
                self.add(key_path(prefix, key), message)

    def table(self, data: dict, key: str, *, prefix: str = "", required: bool = False) -> dict:
        """The table ``data[key]`` ({} when absent or not a table)."""
        full = key_path(prefix, key)
        if key not in data:
            if required:
                self.add(full, "missing table")
            return {}
        value = data[key]
        if not isinstance(value, dict):
            self.add(full, f"must be a table, got {type(value).__name__}")
            return {}
        return value

    def _lookup(self, table: dict, prefix: str, key: str, required: bool):
        """``(key path, value)`` of ``table[key]``, or None when absent (noted if required)."""
        if key in table:
            return key_path(prefix, key), table[key]
        if required:
            self.add(key_path(prefix, key), "missing key")
        return None

    def number(self, table: dict, prefix: str, key: str, *, required: bool = False,
               check: Callable[[float], str | None] | None = finite,
               convert: Callable[[float], Any] = float):
        """A number (int or float), checked (``check`` returns a problem or None) in the file's
        unit, then converted (e.g. ``units.m_s2_to_mm_s2``)."""
        found = self._lookup(table, prefix, key, required)
        if found is None:
            return None
        full, value = found
        if not is_number(value):
            self.add(full, f"must be a number, got {type(value).__name__} {value!r}")
            return None
        value = float(value)
        problem = check(value) if check is not None else None
        if problem:
            self.add(full, f"{problem}, got {value:g}")
            return None
        return convert(value)

    def integer(self, table: dict, prefix: str, key: str, *, required: bool = False,
                minimum: int = 1, maximum: int | None = None) -> int | None:
        found = self._lookup(table, prefix, key, required)
        if found is None:
            return None
        full, value = found
        if isinstance(value, bool) or not isinstance(value, int):
            self.add(full, f"must be an integer, got {type(value).__name__} {value!r}")
        elif value < minimum or (maximum is not None and value > maximum):
            self.add(full, f"must be an integer >= {minimum}" if maximum is None else
                     f"must be an integer from {minimum} to {maximum}, got {value}")
        else:
            return value
        return None

    def string(self, table: dict, prefix: str, key: str, *, required: bool = False,
               non_empty: bool = False) -> str | None:
        found = self._lookup(table, prefix, key, required)
        if found is None:
            return None
        full, value = found
        if isinstance(value, str) and (value or not non_empty):
            return value
        self.add(full, "must be a non-empty string" if non_empty else "must be a string")
        return None

    def boolean(self, table: dict, prefix: str, key: str) -> bool | None:
        found = self._lookup(table, prefix, key, False)
        if found is None or isinstance(found[1], bool):
            return None if found is None else found[1]
        self.add(found[0], "must be true or false")
        return None

    def xyz_mm(self, table: dict, prefix: str, key: str) -> tuple[float, float, float] | None:
        """A point ``[x_mm, y_mm, z_mm]`` of three finite numbers within ``MAX_OFFSET_MM``."""
        value = table.get(key)
        if not isinstance(value, list) or len(value) != 3 or not all(is_number(v) for v in value):
            self.add(key_path(prefix, key), "must be a list of three numbers [x_mm, y_mm, z_mm]")
            return None
        if not all(abs(v) < MAX_OFFSET_MM for v in value):   # also NaN and inf
            shown = ", ".join(f"{float(v):g}" for v in value)
            self.add(key_path(prefix, key), f"must be three finite numbers of magnitude below "
                     f"{MAX_OFFSET_MM:g} mm (the 840D's position range), got [{shown}]")
            return None
        return tuple(float(v) for v in value)

    def warn(self, key: str, message: str) -> None:
        """Note a value that is accepted but looks wrong (:class:`ConfigWarning`)."""
        self.warnings.append(ConfigWarning(message, self.file, key))


# ---------------------------------------------------------------------------------------------
# Setup files
# ---------------------------------------------------------------------------------------------

def is_settable_offset(name: str) -> bool:
    """G54..G57 and the extended settable frames G505..G599 (840D settable zero offsets),
    spelled as the interpreter names them (``G054`` would never be applied)."""
    match = re.fullmatch(r"G([1-9][0-9]*)", name)
    if match is None:
        return False
    code = int(match.group(1))
    return 54 <= code <= 57 or 505 <= code <= 599


def setup_from_dict(data: dict[str, Any], file: str = "<setup>") -> dict[str, tuple[float, float, float]]:
    """Work offsets of a parsed setup file (see :func:`load_setup`)."""
    problems = Problems(file, MachineSpecError)
    problems.unknown(data, "", {"work_offsets"}, "unknown key (a setup file has only [work_offsets])")
    table = problems.table(data, "work_offsets")
    offsets = {}
    for key in table:
        if not is_settable_offset(key):
            canonical = re.fullmatch(r"[Gg]0*([1-9][0-9]*)", key)
            hint = f"write G{canonical.group(1)}; " if canonical and is_settable_offset(
                f"G{canonical.group(1)}") else ""
            problems.add(f"work_offsets.{key}", f"unknown work offset ({hint}use G54..G57 or "
                         "G505..G599)")
            continue
        value = problems.xyz_mm(table, "work_offsets", key)
        if value is not None:
            offsets[key] = value
    problems.raise_if_any()
    return offsets


def load_setup(file: str | FsPath) -> dict[str, tuple[float, float, float]]:
    """Work offsets from a setup TOML file: ``[work_offsets]`` ``G54 = [x_mm, y_mm, z_mm]``.

    Accepts G54..G57 and G505..G599; they override the machine file's offsets. Any problem is a
    :class:`~ncsim.errors.MachineSpecError` naming the file and the key."""
    return setup_from_dict(read_toml(file, "setup file", error=MachineSpecError), str(file))
