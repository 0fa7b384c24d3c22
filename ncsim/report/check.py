"""Pass/fail thresholds on a simulation summary (``ncsim check``, for CI on CAM output).

Each threshold is checked against the JSON summary of ``summary.summary`` and gives one
:class:`CheckResult`: what was measured, the threshold, pass or fail, and for a failure where
the time goes (the blocks losing the most time, with ``file:line`` and the limit holding them).

Before any threshold, the program itself: one without motion or without a program end
(M30, M2, M17) -- an empty, comments-only or truncated export -- fails with the reason
(``program``), unless ``allow_empty``; it is listed only when it fails.

Thresholds (all optional, at least one is needed):

* ``max_time_s``: cycle time (s) at most this;
* ``min_feed_ratio``: ``feed_efficiency`` (ideal time at the programmed feeds / real time on
  feed moves) at least this;
* ``max_limited_fraction``: ``limited_fraction`` (share of feed-move time held below the
  programmed feed) at most this;
* ``baseline`` + ``max_regression_pct``: cycle time at most ``(1 + pct/100)`` times the
  ``cycle_time_s`` of a summary saved with ``ncsim run --json``. When both summaries have
  ``blocks_detail`` for the same blocks, a failure names the blocks that got slower;
* ``strict``: the time is exact, i.e. nothing that can change it went unsimulated (the
  summary's ``approximate``); a failure names what was left out.
"""
from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, field

from ncsim.config import read_text
from ncsim.errors import MeasuredDataError, UsageError
from ncsim.report.summary import SCHEMA_VERSION

WHERE_BLOCKS = 3     # blocks named in a failure


@dataclass(frozen=True, slots=True)
class CheckResult:
    name: str            # max_time, min_feed_ratio, max_limited_fraction, max_regression
    ok: bool
    measured: float
    threshold: float
    text: str            # one line: what was compared
    where: tuple[str, ...] = field(default=())  # for failures: the blocks to look at

    def render(self) -> str:
        line = f"{'PASS' if self.ok else 'FAIL'}  {self.text}"
        if not self.ok and self.where:
            line += "\n" + "\n".join(f"      {w}" for w in self.where)
        return line

    def as_dict(self) -> dict:
        return {"name": self.name, "ok": self.ok, "measured": self.measured,
                "threshold": self.threshold, "text": self.text, "where": list(self.where)}


def load_baseline(path: str | os.PathLike) -> dict:
    """A summary saved by ``ncsim run --json``; any problem is one MeasuredDataError line."""
    name = os.fspath(path)
    text = read_text(path, "baseline summary", error=MeasuredDataError)
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise MeasuredDataError(f"baseline summary is not valid JSON (line {exc.lineno}, column "
                                f"{exc.colno}): {exc.msg}", file=name) from None
    if not isinstance(data, dict):
        raise MeasuredDataError("baseline summary must be a JSON object (from `ncsim run --json`)",
                                file=name)
    if data.get("schema") != SCHEMA_VERSION:
        raise MeasuredDataError(f"key 'schema': expected {SCHEMA_VERSION} (a summary from "
                                f"`ncsim run --json`), got {data.get('schema')!r}", file=name)
    t = data.get("cycle_time_s")
    if isinstance(t, bool) or not isinstance(t, (int, float)) or not math.isfinite(t) or t < 0:
        raise MeasuredDataError(f"key 'cycle_time_s': expected a number of seconds >= 0, got {t!r}",
                                file=name)
    return data


def _where(block: dict) -> str:
    prog = block.get("feed_programmed_mm_min")
    prog = "rapid" if prog is None else f"F{prog:.0f}"
    reached = block.get("feed_max_mm_min")
    reached = "-" if reached is None else f"{reached:.0f}"
    return (f"{block['file']}:{block['line']}: {block['limit']} holds the feed "
            f"({prog} mm/min, reached {reached} mm/min), {block['time_lost_s']:.3f} s lost")


def _slowest(summary: dict, feed_only: bool = False) -> tuple[str, ...]:
    blocks = [b for b in summary.get("slowest_blocks", [])
              if not feed_only or b.get("feed_programmed_mm_min") is not None]
    return tuple(_where(b) for b in blocks[:WHERE_BLOCKS])


def _top_causes(summary: dict, n: int = 2) -> tuple[str, ...]:
    """The causes losing the most time over the program (``lost_by_cause``), one line each."""
    rows = sorted(summary.get("lost_by_cause", []), key=lambda r: -r["time_lost_s"])[:n]
    return tuple(f"{r['cause']} loses {r['time_lost_s']:.3f} s over {r['blocks']} "
                 f"{'rapids' if r['moves'] == 'rapid' else 'feed blocks'} (most at "
                 f"{r['worst_file']}:{r['worst_line']})" for r in rows)


def _slower_blocks(summary: dict, baseline: dict) -> tuple[str, ...]:
    now, then = summary.get("blocks_detail"), baseline.get("blocks_detail")
    if not now or not then or len(now) != len(then):
        return _slowest(summary)
    deltas = sorted(((b["duration_s"] - a.get("duration_s", 0.0), b) for a, b in zip(then, now)),
                    key=lambda d: -d[0])
    return tuple(f"{b['file']}:{b['line']}: {d:+.3f} s against the baseline ({b['limit']} holds "
                 f"the feed)" for d, b in deltas[:WHERE_BLOCKS] if d > 0)


def _program_check(summary: dict) -> list[CheckResult]:
    """A failed ``program`` check for a program that moves nothing or never reaches its end."""
    reasons = []
    if summary["blocks"] == 0:
        reasons.append("no motion")
    if not summary.get("reached_program_end", True):
        reasons.append("no M30, M2 or M17 at the end (truncated?)")
    if not reasons:
        return []
    return [CheckResult("program", False, float(summary["blocks"]), 1.0,
                        f"program: {' and '.join(reasons)}; an empty or truncated export is no "
                        "pass (--allow-empty accepts it)")]


def require_thresholds(max_time_s=None, min_feed_ratio=None, max_limited_fraction=None,
                       baseline=None, max_regression_pct=None, strict: bool = False) -> None:
    """Raise a one-line UsageError unless at least one threshold is given, and the baseline
    and its allowed regression come together."""
    if (baseline is None) != (max_regression_pct is None):
        raise UsageError("--baseline and --max-regression go together")
    if not strict and all(v is None for v in (max_time_s, min_feed_ratio, max_limited_fraction,
                                              baseline)):
        raise UsageError("no threshold given: use --max-time, --min-feed-ratio, "
                         "--max-limited-fraction, --baseline with --max-regression or --strict")


def evaluate(summary: dict, *, max_time_s: float | None = None,
             min_feed_ratio: float | None = None, max_limited_fraction: float | None = None,
             baseline: dict | None = None, max_regression_pct: float | None = None,
             baseline_name: str = "baseline", allow_empty: bool = False,
             strict: bool = False) -> list[CheckResult]:
    """Check ``summary`` against the given thresholds (module docstring), in that order."""
    require_thresholds(max_time_s, min_feed_ratio, max_limited_fraction, baseline,
                       max_regression_pct, strict)
    out = [] if allow_empty else _program_check(summary)
    if strict:
        left_out = summary.get("approximations", {})
        ok = not summary.get("approximate", False)
        n = sum(a["count"] for a in left_out.values())
        out.append(CheckResult("strict", ok, float(n), 0.0,
                               "the time is exact (nothing that can change it is left out)" if ok
                               else f"the time is approximate: {n} unsimulated feature use(s) "
                                    f"of {len(left_out)} kind(s) (--strict)",
                               () if ok else tuple(f"{kind}: {a['count']} x, {a['reason']}"
                                                   for kind, a in left_out.items())))
    t = summary["cycle_time_s"]
    if max_time_s is not None:
        ok = t <= max_time_s
        out.append(CheckResult("max_time", ok, t, max_time_s,
                               f"cycle time {t:.3f} s {'<=' if ok else '>'} {max_time_s:.3f} s",
                               () if ok else _top_causes(summary) + _slowest(summary)))
    if min_feed_ratio is not None:
        r = summary["feed_efficiency"]
        ok = r >= min_feed_ratio
        out.append(CheckResult("min_feed_ratio", ok, r, min_feed_ratio,
                               f"feed ratio {r:.3f} {'>=' if ok else '<'} {min_feed_ratio:.3f} "
                               "(ideal time at the programmed feed / real time, feed moves)",
                               () if ok else _slowest(summary, feed_only=True)))
    if max_limited_fraction is not None:
        f = summary["limited_fraction"]
        ok = f <= max_limited_fraction
        by = sorted(((k, v) for k, v in summary.get("time_by_limit_s", {}).items()
                     if k != "programmed" and v > 0), key=lambda kv: -kv[1])
        holders = ", ".join(f"{k} {v:.3f} s" for k, v in by[:3])
        out.append(CheckResult("max_limited_fraction", ok, f, max_limited_fraction,
                               f"limited fraction {f:.3f} {'<=' if ok else '>'} "
                               f"{max_limited_fraction:.3f} of feed-move time"
                               + (f" (held by {holders})" if holders and not ok else ""),
                               () if ok else _slowest(summary, feed_only=True)))
    if baseline is not None:
        t0 = float(baseline["cycle_time_s"])
        allowed = t0 * (1.0 + max_regression_pct / 100.0)
        change = 100.0 * (t / t0 - 1.0) if t0 > 0 else (0.0 if t == 0 else math.inf)
        ok = t <= allowed
        out.append(CheckResult("max_regression", ok, change, max_regression_pct,
                               f"cycle time {t:.3f} s is {change:+.2f} % against {baseline_name} "
                               f"{t0:.3f} s ({'<=' if ok else '>'} +{max_regression_pct:g} % allowed)",
                               () if ok else _slower_blocks(summary, baseline)))
    return out
