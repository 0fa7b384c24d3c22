"""Which language a program is in: ISO codes in Siemens mode, and code that is not 840D code.

* ``G20``/``G21`` are the ISO dialect's inch/metric input (ISO Milling, "Inch/metric input
  (G20, G21)"). Real 840D programs written in Siemens mode carry ``G21`` (the KIT program
  ``AL_2007_T4_Gear_Normal.mpf``: ``G21 ; Alle Maße in metrischen Einheiten``, then ``G710``,
  recorded on its DMC 60H with a SINUMERIK 840D): the control ran them. ncsim accepts the two
  in Siemens mode as G700/G710 (what ISO mode makes of them) with a warning that says so;
* other ISO G functions in Siemens mode are unknown G functions, as on the control (alarm
  12470), and the error says that G291 or ``--dialect iso`` runs ISO code;
* a program that fails in Siemens mode and shows ISO/Fanuc signs (``O1234`` program numbers,
  ``#1`` variables, ``M98 P``, ``IF [..]``, ISO-only G functions) is reported as such, located at
  the first sign: "looks like ISO/Fanuc code (O1234, G81): run with --dialect iso"; one that
  shows LinuxCNC/RS274NGC signs (``o100 sub``, ``#<name>``, ``(MSG,``) is "not an 840D program".
"""
from __future__ import annotations

import re

from ncsim.errors import NcError

#: ISO codes the 840D runs in Siemens mode: code -> (Siemens code, what it selects)
SIEMENS_MODE_ISO = {20: (700, "inch"), 21: (710, "metric")}
#: ISO milling G functions that Siemens mode does not know (the hint of the unknown-G error)
ISO_ONLY_G = frozenset({28, 30, 43, 44, 49, 52, 65, 73, 76, 80, 81, 82, 83, 85, 86, 87, 88, 89,
                        92, 98, 99, 291})

_LINUXCNC = (
    (re.compile(r"^\s*(?:N\d+\s*)?(O(?:<[\w.-]+>|\d+)\s*"
                r"(?:SUB|ENDSUB|CALL|IF|ELSEIF|ELSE|ENDIF|WHILE|ENDWHILE|DO|REPEAT|ENDREPEAT|"
                r"RETURN|BREAK|CONTINUE))\b", re.I), None),
    (re.compile(r"(#<[\w.-]+>)"), None),
    (re.compile(r"(\(\s*(?:MSG|DEBUG|PRINT|LOGOPEN|PROBEOPEN)\s*,)", re.I), None),
)
_FANUC = (
    (re.compile(r"^\s*%?\s*(O\d+|:\d+)(?![\w.])", re.I), None),
    (re.compile(r"\b(M0*98\s*P)", re.I), "M98 P"),
    (re.compile(r"\b(G0*65\s*P)", re.I), "G65 P"),
    (re.compile(r"(#\d+)\s*=|(#\d+)"), None),
    (re.compile(r"\b((?:IF|WHILE)\s*\[)", re.I), None),
    (re.compile(r"\b(G0*(?:28|30|43|44|49|73|76|8[0-9]|98|99|54\.1|5\.1))(?![\d.])", re.I), None),
)


def siemens_mode_iso_code(ctx, code: int, col: int) -> int:
    """G20/G21 in Siemens mode: the Siemens code they are taken as, with the warning."""
    siemens, what = SIEMENS_MODE_ISO[code]
    ctx.warn("ISO code", f"G{code} (ISO dialect {what} input) in Siemens mode: taken as "
             f"G{siemens} ({what} lengths and feeds), as 840D controls run it", col)
    return siemens


def iso_hint(code: int) -> str:
    """The hint of an unknown G function that is an ISO dialect one."""
    if code in ISO_ONLY_G:
        return " (an ISO dialect code: G291 or --dialect iso runs ISO code)"
    return ""


def _strip(line: str) -> str:
    """The code of a Siemens line without its ``;`` comment."""
    return line.split(";", 1)[0]


def _signs(lines: list[str], patterns) -> list[tuple[str, int, int]]:
    """(text, line, column) of the signs ``patterns`` find, first per line, in line order."""
    found = []
    for number, line in enumerate(lines, 1):
        code = _strip(line)
        for pattern, label in patterns:
            m = pattern.search(code)
            if m:
                group = next(k for k in range(1, (m.lastindex or 0) + 1) if m.group(k))
                text = label or m.group(group).strip().rstrip("=").strip()
                found.append((text, number, m.start(group) + 1))
                break
    return found


def foreign_code(text: str, file: str, siemens: bool = True) -> NcError | None:
    """The error that says which language ``text`` is in, if it shows another one than the
    840D's (Siemens, or ISO when ``siemens`` is False), else None."""
    lines = text.split("\n")[:20000]
    signs = _signs(lines, _LINUXCNC)
    if signs:
        shown = ", ".join(list(dict.fromkeys(s[0] for s in signs))[:3])
        _, line, col = signs[0]
        return NcError(f"looks like LinuxCNC/RS274NGC code ({shown}): not an 840D program", file,
                       line, col)
    if not siemens:
        return None
    signs = _signs(lines, _FANUC)
    if not signs:
        return None
    shown = ", ".join(list(dict.fromkeys(s[0].upper() for s in signs))[:3])
    _, line, col = signs[0]
    return NcError(f"looks like ISO/Fanuc code ({shown}): run with --dialect iso", file, line,
                   col)
