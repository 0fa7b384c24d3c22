"""Where each segment sits in the program's structure: its N number, tool and operation.

Reports group the time by what a CAM programmer or a machinist looks up: the N number of a
block, the tool in the spindle and the CAM operation. The interpreter labels every segment of
its :class:`~ncsim.path.Path` once, after the run, from what it kept anyway (no object per
block): the parsed programs and the calls it recorded in execution order
(``context.RecordedCall``, each with the index of the next segment).

* **N number** (``block_number``): the block number of the segment's source line
  (``N1230 G1 X10``), -1 where the line has none. N numbers need not be unique (shop programs
  repeat them), and a loop's segments all carry the N of their line.
* **Tool** (``tool``): the tool in the spindle. On the 840D with tool management, ``T`` only
  selects the tool and ``M6`` loads it (MD22550 ``$MC_TOOL_CHANGE_MODE`` = 1; SINUMERIK Function
  Manual Basic Functions, W1 "Tool offset", "Tool change"): a segment's tool is the ``T`` last
  programmed before the ``M6`` last executed before it (Fusion's 840D post preselects the next
  tool right after ``M6``: that ``T`` is not yet in the spindle). A program without any ``M6``
  changes the tool with ``T`` itself (MD22550 = 0). ``T="NAME"`` names a tool by its name
  (NX, tool management), ``T12`` by its number (``T12``).
* **Operation** (``operation``): the CAM operation, from what the posts write at its start:

  - comment lines naming it, ``;Operation : NAME`` (Siemens NX post for the 840D sl, e.g. the
    THWS programs: ``N150 ;Operation : PLANFLAECHE``), and the same with ``OPERATION``, ``OP
    10``, ``JOB 3`` (hyperMILL's job list), ``TOOLPATH`` or ``Arbeitsgang``, an optional number
    and ``:``, ``=`` or ``-`` before the name (:data:`OPERATION_COMMENT`);
  - otherwise the texts of ``MSG("...")``: Autodesk Fusion's ``siemens-840d`` post writes each
    operation's comment as ``MSG ("NAME")`` at the start of its section (older versions write a
    plain comment, which cannot be told from other comments); shop programs and cycles use
    ``MSG`` for the operator. ``MSG()`` ends the operation.

  Where comment lines name operations (NX also writes ``MSG("MILL_ROUGH")``, the operation's
  type), they are used and the MSG texts are not. A segment's operation is the one named last
  before its line in its own file (so a loop's passes keep theirs); a subprogram that names
  none takes the operation of the motion before its call. With MSG texts, the operation is
  the MSG last executed before the segment (the 840D shows a message until the next one).

The string tables (``Path.tools``, ``Path.operations``) hold each name once, in order of first
use.
"""
from __future__ import annotations

import re
from dataclasses import replace

import numpy as np

from ncsim.nc import program as P
from ncsim.path import Path

#: a comment naming a CAM operation (module docstring); group ``name`` is the name. The match
#: starts at the ``;`` (a literal first character keeps the search fast on million-line
#: programs); :data:`_LINE_HEAD` checks that only a block number comes before it
OPERATION_COMMENT = re.compile(
    r";[ \t]*\*?[ \t]*"
    r"(?:operation(?:[ \t]+name)?|op(?=[ \t]*\d)|job|toolpath|arbeitsgang)"
    r"(?:[ \t]*(?:no\.?|nr\.?|#)?[ \t]*\d+)?[ \t]*[:=-][ \t]*(?P<name>[^\r\n]*?)[ \t]*$",
    re.IGNORECASE | re.MULTILINE)
_LINE_HEAD = re.compile(r"[ \t]*(?:/\d?[ \t]*)?(?:N\d+[ \t]*)?", re.IGNORECASE)


def operation_comments(text: str) -> tuple[tuple[int, str], ...]:
    """``(line, name)`` of every comment line of ``text`` that names a CAM operation
    (:data:`OPERATION_COMMENT`), lines counted from 1."""
    out = []
    line, pos = 1, 0
    for m in OPERATION_COMMENT.finditer(text):
        start = text.rfind("\n", 0, m.start()) + 1
        if not m.group("name") or _LINE_HEAD.fullmatch(text, start, m.start()) is None:
            continue
        line += text.count("\n", pos, start)
        pos = start
        out.append((line, m.group("name")))
    return tuple(out)


def line_numbers(program: P.Program) -> np.ndarray:
    """The N number of each line of ``program`` (index = line, -1: none)."""
    numbers = np.full(program.n_lines + 2, -1, dtype=np.int32)
    for item in program.items:
        if isinstance(item, P.PlainRun):
            numbers[item.first_line:item.first_line + len(item)] = item.numbers
        elif item.number is not None and item.line < len(numbers):
            numbers[item.line] = item.number
    return numbers


class _Names:
    """A string table: each name once, in order of first use."""

    def __init__(self) -> None:
        self.index: dict[str, int] = {}

    def __call__(self, name: str) -> int:
        return self.index.setdefault(name, len(self.index))

    def table(self) -> tuple[str, ...]:
        return tuple(self.index)


def tool_name(value) -> str:
    """``T="NAME"`` -> ``NAME``; ``T12`` -> ``T12``."""
    if isinstance(value, str):
        return value
    number = float(value)
    return f"T{int(number)}" if number == int(number) else f"T{number:g}"


def _fill(n: int, at: list[int], codes: list[int]) -> np.ndarray:
    """Per segment, the code of the last event at or before it (-1 before the first): events
    ``codes`` take effect from segment ``at`` on (ascending)."""
    out = np.full(n, -1, dtype=np.int16)
    if not at or n == 0:
        return out
    k = np.searchsorted(np.asarray(at, dtype=np.int64), np.arange(n), side="right") - 1
    table = np.asarray(codes, dtype=np.int16)
    np.copyto(out, table[np.maximum(k, 0)], where=k >= 0)
    return out


def tools(n: int, recorded) -> tuple[np.ndarray, tuple[str, ...]]:
    """The ``tool`` column and its table (module docstring)."""
    names = _Names()
    with_m6 = any(r.name == "M6" for r in recorded)
    at, codes, selected = [], [], None
    for r in recorded:
        if r.name == "T" and r.args:
            selected = tool_name(r.args[0])
            if not with_m6:
                at.append(r.segment_index)
                codes.append(names(selected))
        elif r.name == "M6" and selected is not None:
            at.append(r.segment_index)
            codes.append(names(selected))
    return _fill(n, at, codes), names.table()


def _msg_operations(n: int, recorded) -> tuple[np.ndarray, tuple[str, ...]]:
    names = _Names()
    at, codes = [], []
    for r in recorded:
        if r.name == "MSG":
            text = "".join(str(a) for a in r.args if a is not None).strip()
            at.append(r.segment_index)
            codes.append(names(text) if text else -1)
    return _fill(n, at, codes), names.table()


def operations(path: Path, comments: dict[str, tuple], recorded
               ) -> tuple[np.ndarray, tuple[str, ...]]:
    """The ``operation`` column and its table: from the operation comments of each file
    (``comments``: file -> ``(line, name)`` pairs) where there are any, else from the MSG
    texts (module docstring)."""
    n = path.n
    if not any(comments.get(f) for f in path.files):
        return _msg_operations(n, recorded)
    names = _Names()
    op = np.full(n, -1, dtype=np.int16)
    single = len(path.files) == 1
    for k, file in enumerate(path.files):
        marks = comments.get(file) or ()
        if not marks:
            continue
        lines = np.array([line for line, _ in marks], dtype=np.int64)
        codes = np.array([names(name) for _, name in marks], dtype=np.int16)
        rows = slice(None) if single else np.flatnonzero(path.file_index == k)
        j = np.searchsorted(lines, path.line[rows], side="right") - 1
        op[rows] = np.where(j >= 0, codes[np.maximum(j, 0)], -1)
    # segments of files without an operation of their own take the one before them
    idx = np.where(op >= 0, np.arange(n), -1)
    np.maximum.accumulate(idx, out=idx)
    op = np.where(idx >= 0, op[np.maximum(idx, 0)], -1).astype(np.int16)
    return op, names.table()


def _used(column: np.ndarray, names: tuple[str, ...]) -> tuple[np.ndarray, tuple[str, ...]]:
    """The column and its table without the names no segment has (a tool loaded after the
    last motion, ``T0 M6``)."""
    if not names or column.size == 0:
        return column, ()
    count = np.bincount(column.astype(np.int64) + 1, minlength=len(names) + 1)[1:]
    keep = np.flatnonzero(count)
    if len(keep) == len(names):
        return column, names
    remap = np.full(len(names) + 1, -1, dtype=np.int16)
    remap[keep + 1] = np.arange(len(keep))
    return remap[column.astype(np.int64) + 1], tuple(names[k] for k in keep)


def label_path(path: Path, programs: dict, recorded) -> Path:
    """``path`` with its ``block_number``, ``tool`` and ``operation`` columns and tables, from
    the parsed ``programs`` (file -> :class:`~ncsim.nc.program.Program`) and the ``recorded``
    calls of the run."""
    n = path.n
    number = np.full(n, -1, dtype=np.int32)
    for k, file in enumerate(path.files):
        program = programs.get(file)
        if program is None or n == 0:
            continue
        table = line_numbers(program)
        rows = slice(None) if len(path.files) == 1 else np.flatnonzero(path.file_index == k)
        number[rows] = table[np.clip(path.line[rows], 0, len(table) - 1)]
    tool, tool_names = _used(*tools(n, recorded))
    comments = {f: p.operation_comments for f, p in programs.items()}
    operation, operation_names = _used(*operations(path, comments, recorded))
    return replace(path, block_number=number, tool=tool, operation=operation,
                   tools=tool_names, operations=operation_names)
