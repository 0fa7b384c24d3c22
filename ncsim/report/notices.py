"""Warnings as a reader takes them in: grouped by kind, the first few located, then a count.

A real CAM program gives dozens of warnings of a few kinds (every rotary-axis move, every
tool change); printed one by one they bury the one that matters. :func:`grouped` keeps the
order in which the kinds first appear and, per kind, prints the first :data:`SHOWN` warnings
as they are (``FILE:LINE:COL: warning: ...``, so an editor jumps there), then one line
``FILE: warning: ... and N more 'KIND' warnings (lines a, b, c, ...)``. The JSON summary keeps
every warning the interpreter kept.
"""
from __future__ import annotations

SHOWN = 3            # warnings of one kind printed in full
LINES_LISTED = 8     # lines named in the "and N more" line


def _kind(w) -> str:
    kind = getattr(w, "kind", "")
    if kind:
        return kind
    return "machine file" if hasattr(w, "key") else "other"


def grouped(warnings, shown: int = SHOWN) -> list[str]:
    """The lines to print for ``warnings`` (``NcWarning`` and ``ConfigWarning``), grouped by
    kind (module docstring)."""
    groups: dict[str, list] = {}
    for w in warnings:
        groups.setdefault(_kind(w), []).append(w)
    out = []
    for kind, items in groups.items():
        kept = [w for w in items if not getattr(w, "more", 0)]
        more = sum(getattr(w, "more", 0) for w in items)
        if len(kept) <= shown + 1 and not more:
            out += [w.render() for w in kept]
            continue
        out += [w.render() for w in kept[:shown]]
        rest = kept[shown:]
        lines = sorted({w.line for w in rest if getattr(w, "line", 0) > 0})
        named = ", ".join(str(v) for v in lines[:LINES_LISTED]) + (", ..." if len(lines) > LINES_LISTED or more else "")
        where = getattr(rest[0] if rest else items[0], "file", "ncsim")
        out.append(f"{where}: warning: ... and {len(rest) + more} more '{kind}' warnings"
                   + (f" (lines {named})" if lines else ""))
    return out
