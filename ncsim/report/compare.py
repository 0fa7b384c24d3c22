"""Two runs side by side: the CAM output before and after a change (``ncsim compare A B``).

:func:`compare` takes two JSON summaries (``report.summary``: simulated here, or saved by
``ncsim run --json``) of the same machine and lines up the cycle time, the time at the
programmed feeds, the time lost, and the time of each operation and each tool, matched by
name (an operation or tool that is in one run only is listed with nothing on the other side).
Differences are B - A: positive is slower. ``max_slower_pct`` makes a CI gate: B may take at
most that many percent longer than A, else the comparison fails (``ok`` False) and names the
operations that grew the most.
"""
from __future__ import annotations

import json
import os

from ncsim.errors import UsageError
from ncsim.report.breakdown import hms, range_text

#: what the summary of a run must hold to be compared (keys of the JSON summary)
REQUIRED = ("schema", "machine", "cycle_time_s", "ideal_time_s", "lost_time_s", "by_operation",
            "by_tool")


_BLOCKS = '\n "blocks_detail": ['   # where ``report.jsonout`` starts the per-block list


def is_summary_file(file: str | os.PathLike) -> bool:
    """Whether ``file`` holds a JSON object (a saved summary) rather than a program."""
    try:
        with open(file, "rb") as f:
            head = f.read(64).lstrip()
    except OSError as exc:
        raise UsageError(f"{os.fspath(file)}: cannot read: {exc.strerror or exc}") from None
    return head.startswith(b"{")


def load_summary(file: str | os.PathLike) -> dict:
    """A summary saved by ``ncsim run --json``, without its per-block list (the head only is
    parsed when the file was written by ``report.jsonout``: a million blocks need not be read
    into memory to compare two runs)."""
    name = os.fspath(file)
    try:
        with open(name, encoding="utf-8") as f:
            text = f.read()
    except (OSError, UnicodeDecodeError) as exc:
        raise UsageError(f"{name}: cannot read the summary: {getattr(exc, 'strerror', None) or exc}") from None
    cut = text.find(_BLOCKS)
    try:
        data = json.loads(text[:cut] + "\n}" if cut >= 0 else text)
    except json.JSONDecodeError:
        try:
            data = json.loads(text)
        except json.JSONDecodeError as exc:
            raise UsageError(f"{name}:{exc.lineno}:{exc.colno}: not valid JSON: {exc.msg}") from None
    check_summary(data, name)
    return data


def check_summary(s: dict, name: str) -> None:
    """``s`` can be compared: a JSON summary of this ncsim (with its tables by operation and
    tool), else one UsageError line naming the file."""
    if not isinstance(s, dict) or "schema" not in s or "cycle_time_s" not in s:
        raise UsageError(f"{name}: not a summary of `ncsim run --json` (no schema or "
                         f"cycle_time_s)")
    missing = [k for k in REQUIRED if k not in s]
    if missing:
        raise UsageError(f"{name}: the summary has no {', '.join(missing)} (written by an older "
                         f"ncsim? run `ncsim run --json` again)")


def _pct(a: float, b: float) -> float | None:
    return 100.0 * (b - a) / a if a > 0 else None


def _side_by_side(rows_a: list[dict], rows_b: list[dict]) -> list[dict]:
    """Rows matched by name, in A's order then B's new ones."""
    a = {r["name"]: r for r in rows_a}
    b = {r["name"]: r for r in rows_b}
    names = list(a) + [n for n in b if n not in a]
    out = []
    for n in names:
        ta = a[n]["time_s"] if n in a else None
        tb = b[n]["time_s"] if n in b else None
        diff = (tb or 0.0) - (ta or 0.0)
        out.append({"name": n, "a_time_s": ta, "b_time_s": tb, "diff_s": diff,
                    "diff_pct": _pct(ta, tb) if ta is not None and tb is not None else None,
                    "a_lost_time_s": a[n]["lost_time_s"] if n in a else None,
                    "b_lost_time_s": b[n]["lost_time_s"] if n in b else None,
                    "n_ranges_b": b[n]["n_ranges"] if n in b else a[n]["n_ranges"]})
    return out


def compare(a: dict, b: dict, *, name_a: str = "A", name_b: str = "B",
            max_slower_pct: float | None = None) -> dict:
    """The comparison of summaries ``a`` and ``b`` (module docstring), as a JSON-able dict."""
    check_summary(a, name_a)
    check_summary(b, name_b)
    if a["machine"] != b["machine"]:
        raise UsageError(f"{name_a} ran on {a['machine']!r} and {name_b} on {b['machine']!r}: "
                         f"compare runs on one machine")
    totals = {}
    for key in ("cycle_time_s", "ideal_time_s", "lost_time_s"):
        totals[key] = {"a": a[key], "b": b[key], "diff_s": b[key] - a[key],
                       "diff_pct": _pct(a[key], b[key])}
    slower = totals["cycle_time_s"]["diff_pct"]
    ok = max_slower_pct is None or slower is None or slower <= max_slower_pct
    return {"a": name_a, "b": name_b, "machine": a["machine"],
            "a_program": a.get("program"), "b_program": b.get("program"),
            **totals,
            "operations": _side_by_side(a["by_operation"], b["by_operation"]),
            "tools": _side_by_side(a["by_tool"], b["by_tool"]),
            "approximate": bool(a.get("approximate") or b.get("approximate")),
            "max_slower_pct": max_slower_pct, "ok": ok}


def _signed(seconds: float) -> str:
    return ("+" if seconds >= 0 else "-") + hms(abs(seconds))


def _percent(p: float | None) -> str:
    return f"{p:+7.1f} %" if p is not None else "      - "


def format_text(c: dict, width: int = 28) -> str:
    """A terminal rendering of :func:`compare`."""
    lines = [f"A  {c['a']}", f"B  {c['b']}", f"on {c['machine']}; B - A: + is slower", "",
             f"  {'':<{width}} {'A':>10} {'B':>10} {'B - A':>11} {'':>9}"]
    for key, title in (("cycle_time_s", "cycle time"), ("ideal_time_s", "at programmed feeds"),
                       ("lost_time_s", "lost")):
        t = c[key]
        lines.append(f"  {title:<{width}} {hms(t['a']):>10} {hms(t['b']):>10} "
                     f"{_signed(t['diff_s']):>11} {_percent(t['diff_pct'])}")
    for key, title in (("operations", "operation"), ("tools", "tool")):
        rows = c[key]
        if not rows or (len(rows) == 1 and rows[0]["name"] is None):
            continue
        lines += ["", f"  {'by ' + title:<{width}} {'A':>10} {'B':>10} {'B - A':>11}"]
        for r in rows:
            name = r["name"] or f"(no {title})"
            name = name if len(name) <= width else name[:width - 2] + ".."
            ta = "-" if r["a_time_s"] is None else hms(r["a_time_s"])
            tb = "-" if r["b_time_s"] is None else hms(r["b_time_s"])
            lines.append(f"  {name:<{width}} {ta:>10} {tb:>10} {_signed(r['diff_s']):>11} "
                         f"{_percent(r['diff_pct'])}")
    if c["approximate"]:
        lines += ["", "approximate: a run leaves out what ncsim does not simulate (see `ncsim run`)"]
    if c["max_slower_pct"] is not None:
        slower = c["cycle_time_s"]["diff_pct"] or 0.0
        verdict = "PASS" if c["ok"] else "FAIL"
        how = f"{abs(slower):.1f} % {'longer' if slower > 0 else 'shorter'} than" if slower else "as long as"
        lines += ["", f"{verdict}  B's cycle time is {how} A's (at most "
                      f"{c['max_slower_pct']:g} % longer allowed)"]
        if not c["ok"]:
            grown = sorted((r for r in c["operations"] if r["diff_s"] > 0),
                           key=lambda r: -r["diff_s"])[:3]
            for r in grown:
                lines.append(f"  {r['name'] or '(no operation)'} {_signed(r['diff_s'])} "
                             f"({range_text(r['n_ranges_b'])})")
    return "\n".join(lines) + "\n"
