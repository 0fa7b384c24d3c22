"""One exception family for everything ncsim rejects, and the CLI's exit codes.

Every error renders as a single line that names where the problem is:

* program errors:   ``FILE:LINE:COL: message`` (``FILE: message`` when no line applies, e.g. a
  file that cannot be read; columns count from 1, and one about a whole line names column 1)
* TOML files (machine, setup, published values; ``ncsim.config``): ``FILE: key.path: message``
* measured data:    ``FILE:LINE: message`` or ``FILE: column 'x': message``

The library raises; only ``ncsim.cli`` prints and exits.
"""
from __future__ import annotations

import re
from dataclasses import dataclass
from enum import IntEnum


class ExitStatus(IntEnum):
    """Exit codes of the ``ncsim`` command (documented in the README)."""

    OK = 0
    CHECK_FAILED = 1  # `ncsim check`: a threshold does not hold
    BAD_INPUT = 2     # unreadable program, machine, trace or option
    INTERRUPTED = 130  # Ctrl-C (128 + SIGINT, as shells report it)


#: characters of a user's text a message shows at most (a CAM glitch can make a token of
#: thousands of digits: the line names where it is, the message shows its ends)
SHOWN_CHARS = 40


def shown(text: str, limit: int = SHOWN_CHARS) -> str:
    """``text`` for a message: itself when short, else its start and end around the count of
    characters left out (``1.000000000000...0000 (20,000 characters)``)."""
    if len(text) <= limit:
        return text
    keep = (limit - 3) // 2
    return f"{text[:keep]}...{text[-keep:]} ({len(text):,} characters)"


#: a run of more than 100 characters without a space or a path separator: a token of the
#: program echoed whole (a number, a name)
_LONG_TOKEN = re.compile(r"[^\s/\\]{101,}")


def short_tokens(message: str) -> str:
    """``message`` with every program token of over 100 characters :func:`shown` (a message
    is one short line, whatever the program holds; file paths are kept)."""
    return _LONG_TOKEN.sub(lambda m: shown(m.group()), message) if len(message) > 100 else message


class NcsimError(Exception):
    """Base of every error ncsim raises on bad input."""

    exit_status = ExitStatus.BAD_INPUT

    def render(self) -> str:
        return str(self)


class NcError(NcsimError):
    """An error in an NC program, located at file, line and column (both 1-based)."""

    def __init__(self, message: str, file: str = "<program>", line: int = 0, column: int = 0):
        message = short_tokens(message)
        super().__init__(message)
        self.message = message
        self.file = file
        self.line = line
        self.column = column

    def render(self) -> str:
        if self.line <= 0:  # about the whole file (unreadable, empty): no position to name
            return f"{self.file}: {self.message}"
        return f"{self.file}:{self.line}:{max(self.column, 1)}: {self.message}"

    def __str__(self) -> str:  # so that pytest.raises(match=...) sees the location too
        return self.render()


class NcSyntaxError(NcError):
    """The text is not a program of the grammar (grammars/sinumerik.lark)."""


class NcSemanticError(NcError):
    """The program parses but cannot be executed: unknown word, no feed, bad arc, ..."""


class NcUnsupportedError(NcSemanticError):
    """The program uses something real but outside what ncsim simulates (e.g. TRAORI)."""


class ConfigError(NcsimError):
    """A TOML file (read by ``ncsim.config``) is unreadable, or a key in it is missing,
    unknown, mistyped or out of range: ``FILE: key.path: message``."""

    def __init__(self, message: str, file: str = "<config>", key: str = ""):
        super().__init__(message)
        self.message = message
        self.file = file
        self.key = key

    def render(self) -> str:
        where = f"{self.file}: {self.key}: " if self.key else f"{self.file}: "
        return where + self.message

    def __str__(self) -> str:
        return self.render()


class MachineSpecError(ConfigError):
    """A machine description or a setup file (TOML) is missing, mistyped or out of range."""

    def __init__(self, message: str, file: str = "<machine>", key: str = ""):
        super().__init__(message, file, key)


class MeasuredDataError(NcsimError):
    """A measured trace, or a file of published values, cannot be used."""

    def __init__(self, message: str, file: str = "<measured>", line: int | None = None,
                 column: str | None = None, key: str = ""):
        super().__init__(message)
        self.message = message
        self.file = file
        self.line = line
        self.column = column
        self.key = key

    def render(self) -> str:
        if self.line is not None:
            return f"{self.file}:{self.line}: {self.message}"
        if self.column is not None:
            return f"{self.file}: column '{self.column}': {self.message}"
        if self.key:
            return f"{self.file}: {self.key}: {self.message}"
        return f"{self.file}: {self.message}"

    def __str__(self) -> str:
        return self.render()


class OutOfMemory(NcsimError):
    """The memory ran out while ``doing`` something to ``file``: the input is too large for
    the memory the process may use (the machine's, or a limit such as ``ulimit -v``)."""

    def __init__(self, file: str, doing: str, detail: str = ""):
        super().__init__(f"{file}: out of memory while {doing}")
        self.file = file
        self.doing = doing
        self.detail = detail

    @classmethod
    def of(cls, file: str, doing: str, exc: MemoryError) -> "OutOfMemory":
        """From the MemoryError ``exc`` (numpy's names the allocation that failed)."""
        text = str(exc)
        detail = ("u" + text[1:].split(" for an array")[0]) if text.startswith("Unable to allocate") else ""
        return cls(file, doing, detail)

    def render(self) -> str:
        detail = f" ({self.detail})" if self.detail else ""
        return (f"{self.file}: out of memory while {self.doing}{detail}: the input is too large "
                "for the memory this process may use")

    def __str__(self) -> str:
        return self.render()


class UsageError(NcsimError):
    """A bad option combination or value given on the command line or to the API."""


@dataclass(frozen=True, slots=True)
class NcWarning:
    """Something parsed but not simulated (or simulated approximately), with its location.
    ``kind`` groups warnings of one sort (``"rotary axis"``, ``"M6"``); ``more`` > 0 marks the
    entry that stands for that many more warnings of its kind, not kept one by one."""

    message: str
    file: str
    line: int
    column: int = 0
    kind: str = ""
    more: int = 0

    def render(self) -> str:
        message = short_tokens(self.message)
        if self.line <= 0:  # about the whole program (no motion, no end): no position to name
            return f"{self.file}: warning: {message}"
        return f"{self.file}:{self.line}:{max(self.column, 1)}: warning: {message}"


@dataclass(frozen=True, slots=True)
class ConfigWarning:
    """A value in a TOML file that is accepted but looks wrong (e.g. in the wrong unit)."""

    message: str
    file: str
    key: str

    def render(self) -> str:
        return f"{self.file}: {self.key}: warning: {self.message}"
