"""Macros: ``DEFINE <name> AS <instruction>`` (Programming Manual Job planning, "Macro technique
(DEFINE ... AS)").

A macro gives an identifier, or a G, M or H function or an L program name, another meaning:
``DEFINE LINE AS G1``, ``DEFINE M13 AS M3 M8``, ``DEFINE M6 AS L6``, ``DEFINE RADIUS AS 20``.
Where the macro's name stands as a word of its own in a later block, the control reads the
instruction instead. Macros are defined in the program (they apply to the rest of that file)
or in a definitions file (``_N_UMAC_DEF``, ``_N_MMAC_DEF``, ``_N_SMAC_DEF``; ``--definitions``:
they apply to every program). A macro's instruction may not use another macro (nesting is not
possible); a DEFINE must stand alone in its block.

:func:`expand_macros` does this on the text before it is parsed: a DEFINE line becomes a
comment (the line numbers stay), and every later use outside strings and comments is replaced
(the columns after a replacement on that line shift by the difference in length).
"""
from __future__ import annotations

import re

from ncsim.errors import NcSyntaxError

_DEFINE = re.compile(r"^[ \t]*(?:/[0-9]?[ \t]*)?(?:N[0-9]+[ \t]+)?DEFINE\b")
_DEFINITION = re.compile(r"DEFINE[ \t]+([A-Z_][A-Z0-9_]*)[ \t]+AS[ \t]+(\S.*?)[ \t]*$")
_HAS_DEFINE = re.compile(r"(?i)\bDEFINE\b")


def expand_macros(text: str, file: str, macros: dict[str, str] | None = None,
                  upper=None) -> tuple[str, dict[str, str]]:
    """``text`` with its DEFINE lines turned into comments and every macro (``macros``, from a
    definitions file, and the file's own) replaced; and the macros in force at its end.
    ``upper`` upper-cases a line outside strings and comments (``parse.upper_code``)."""
    macros = dict(macros or {})
    if not macros and not _HAS_DEFINE.search(text):
        return text, macros
    lines = text.split("\n")
    pattern = _pattern(macros)
    for i, line in enumerate(lines):
        code, comment = _split_comment(upper(line) if upper else line.upper())
        if _DEFINE.match(code):
            name, body = _definition(code, file, i + 1)
            if pattern is not None and pattern.search(body):
                raise NcSyntaxError(f"DEFINE {name}: the instruction uses a macro "
                                    f"(macros cannot be nested)", file, i + 1, code.find(body) + 1)
            macros[name] = body
            pattern = _pattern(macros)
            lines[i] = ";" + line
            continue
        if pattern is not None and pattern.search(code):
            lines[i] = _replace(code, pattern, macros) + comment
    return "\n".join(lines), macros


def _definition(code: str, file: str, line: int) -> tuple[str, str]:
    start = code.index("DEFINE")
    m = _DEFINITION.match(code, start)
    if m is None:
        raise NcSyntaxError("DEFINE needs a name and an instruction: DEFINE <name> AS "
                            "<instruction>", file, line, start + 1)
    return m.group(1), m.group(2)


def _pattern(macros: dict[str, str]):
    if not macros:
        return None
    names = sorted(macros, key=len, reverse=True)
    return re.compile(r"(?<![A-Z0-9_$.])(" + "|".join(map(re.escape, names)) + r")(?![A-Z0-9_.])")


def _split_comment(code: str) -> tuple[str, str]:
    """(the code, the ``;`` comment) of an upper-cased line, a ``;`` inside a string kept."""
    in_string = False
    for i, ch in enumerate(code):
        if ch == '"':
            in_string = not in_string
        elif ch == ";" and not in_string:
            return code[:i], code[i:]
    return code, ""


def _replace(code: str, pattern, macros: dict[str, str]) -> str:
    """The macros of ``code`` replaced outside its strings."""
    parts = code.split('"')
    for k in range(0, len(parts), 2):          # even parts are outside strings
        parts[k] = pattern.sub(lambda m: macros[m.group(1)], parts[k])
    return '"'.join(parts)


def definition_macros(paths) -> dict[str, str]:
    """The macros of definitions files (``--definitions UMAC.DEF``), for every program."""
    from ncsim.nc.parse import normalize_newlines, read_program_text, upper_code
    macros: dict[str, str] = {}
    for path in paths:
        text = normalize_newlines(read_program_text(path, "definitions file"))
        _, macros = expand_macros(text, str(path), macros, upper_code)
    return macros
