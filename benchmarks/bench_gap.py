"""Withheld-effect benchmark of the gap diagnosis, in two suites.

**planner** (truths made by ncsim's planner: they prove consistency, not correctness): every
case draws one effect of ``ncsim.gap.effects`` with random parameters
(``ncsim.gap.truth.cases``), builds a measured trace in which it is present -- the planner with
the effect on, then each axis through the independent RK4 closed-loop simulation of
``ncsim.gap.truth.servo`` (baseline dynamics, or random loop / structure parameters for the
servo and structure effects), then an oscilloscope-like recording
(``ncsim.gap.truth.synth.degrade``: period 1-12 ms, noise, increment, clock and zero offsets,
dropouts) -- and runs ``ncsim.gap.diagnose`` from the base model that lacks the effect, with
every effect of the library as a candidate. Program ``programs/diagnosis_mix.mpf``.

**independent** (truths NOT made by ncsim's planner): every case draws one of the effects
real machines differ by (rapid and feed override, axis velocity and acceleration, reset path
mode with settle time, G64 corner velocity, recorder filter) and one recording condition
(whole program, partial, machine coordinates with an unknown offset, one pass of three,
50 Hz after a 20 ms moving average, or all of those at once like KIT's recording;
``ncsim.gap.truth.independent``); the commanded motion comes from the plain ruckig planner of
``ncsim.gap.truth.plain``, which does not use ``ncsim.plan``. The planner part of the
diagnosis (planner effects and the recorder) runs on the recorded command. Program
``programs/gap_passes.mpf``.

Effects (and conditions) are drawn in shuffled rounds, so that every kind appears about
equally often. Reported: the confusion matrix (true effect against the top-ranked one), the
top-1 rate, the parameter-recovery error of the true effect's fit, and the shrinkage of the
combined gap when the top-ranked effect is the true one -- per effect, per suite and per
recording condition. Targets: top-1 >= 90 % over all cases, parameter error <= 10 % and
shrinkage >= 80 % in >= 90 % of the cases.

    python benchmarks/bench_gap.py --cases 60 --independent-cases 84 --seed 1   # the README
    python benchmarks/bench_gap.py --suite independent --independent-cases 7 --workers 1

Writes ``--out`` + ``.json`` (every case) and ``.md`` (the tables) and prints the tables.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from collections import Counter
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from ncsim.gap.effects import COMMAND_EFFECTS, EFFECTS  # noqa: E402
from ncsim.gap.diagnose import diagnose  # noqa: E402
from ncsim.errors import MeasuredDataError, UsageError  # noqa: E402
from ncsim.gap.pipeline import register_trace  # noqa: E402
from ncsim.gap.truth.cases import CASE_KINDS, draw_case, truth_trace  # noqa: E402
from ncsim.gap.truth.independent import (CONDITIONS, INDEPENDENT_KINDS,  # noqa: E402
                                         draw_independent_case, independent_trace, start_machine)
from ncsim.nc.interpret import interpret_file  # noqa: E402
from ncsim.machine import load_machine  # noqa: E402

INDEPENDENT_PROGRAM = REPO / "programs" / "gap_passes.mpf"

TOP1_TARGET = 0.90
PARAM_TARGET = 0.10
SHRINK_TARGET = 80.0

_STATE: dict = {}


def draw_cases(n: int, seed: int):
    """``n`` cases, effects in shuffled rounds of all kinds (deterministic for a seed)."""
    rng = np.random.default_rng(seed)
    kinds = list(CASE_KINDS)
    order: list[str] = []
    while len(order) < n:
        order += [kinds[i] for i in rng.permutation(len(kinds))]
    return [draw_case(rng, i, k) for i, k in enumerate(order[:n])]


def draw_independent_cases(n: int, seed: int):
    """``n`` independent-truth cases: (effect, condition) pairs in shuffled rounds of all
    combinations (deterministic for a seed)."""
    rng = np.random.default_rng(seed + 1000)
    pairs = [(k, c) for k in INDEPENDENT_KINDS for c in CONDITIONS]
    order: list = []
    while len(order) < n:
        order += [pairs[i] for i in rng.permutation(len(pairs))]
    return [draw_independent_case(rng, i, k, c) for i, (k, c) in enumerate(order[:n])]


def _init(program: str, machine: str) -> None:
    m = load_machine(machine)
    _STATE["machine"] = m
    _STATE["program"] = program
    _STATE["path"] = interpret_file(program, m).path


def param_errors(case, fit_params: dict) -> dict:
    """Relative error of every drawn parameter; discrete ones: 0 if right, 1 if wrong."""
    out = {}
    kind = (INDEPENDENT_KINDS if getattr(case, "condition", None) else CASE_KINDS)[case.effect]
    for name in kind.ranges:
        true = float(case.params[name])
        out[name] = abs(float(fit_params[name]) - true) / abs(true)
    for name, value in kind.fixed.items():
        if EFFECTS[case.effect].param(name).kind == "choice":
            out[name] = 0.0 if fit_params.get(name) == value else 1.0
    return out


def _reinterpret(program: str):
    return lambda m: interpret_file(program, m).path


def run_case(case) -> dict:
    """One case's row; a recording the diagnosis refuses (one line, exit 2 in the CLI) is a
    row too: a miss, with the refusal as its top-1."""
    try:
        if getattr(case, "condition", None):
            return run_independent_case(case)
        return run_planner_case(case)
    except (MeasuredDataError, UsageError) as exc:
        kind = (INDEPENDENT_KINDS if getattr(case, "condition", None) else CASE_KINDS)[case.effect]
        errs = {name: 1.0 for name in kind.ranges}
        return {**case.as_dict(), "suite": "independent" if getattr(case, "condition", None) else "planner",
                "n_samples": 0, "top1": "refused", "right": False, "refusal": str(exc),
                "ranking": [], "fit_params": {}, "param_error": errs, "max_param_error": 1.0,
                "shrink_percent": 0.0, "gap_before": math.nan, "gap_after": math.nan,
                "metric_shrink_percent": {}, "n_evals": 0, "truth_s": 0.0, "diagnosis_s": 0.0}


def run_planner_case(case) -> dict:
    path, machine = _STATE["path"], _STATE["machine"]
    t0 = time.perf_counter()
    measured = truth_trace(path, machine, case)
    t1 = time.perf_counter()
    d = diagnose(path, machine, measured, base=case.base, do_combine=False, localisation=False,
                 reinterpret=_reinterpret(_STATE["program"]))
    t2 = time.perf_counter()
    return _row(case, measured, d, t1 - t0, t2 - t1, "planner")


def run_independent_case(case) -> dict:
    nominal = _STATE["machine"]
    program = str(INDEPENDENT_PROGRAM)
    t0 = time.perf_counter()
    measured = independent_trace(program, nominal, case)
    t1 = time.perf_counter()
    machine = start_machine(nominal, case)
    path = interpret_file(program, machine).path
    # as `ncsim gap` does with a recorded command: register it on the program (offset and
    # covered stretch fitted), then the planner part. A recording of one pass that looks like
    # another is refused as ambiguous: the user then gives the work offset (--work-offset or a
    # setup file), as here; the case records that it needed it
    try:
        reg = register_trace(measured, path, machine, {})
        offset_given = False
    except MeasuredDataError as exc:
        if "ambiguous" not in str(exc):
            raise
        reg = register_trace(measured, path, machine, {"G54": case.offset_mm})
        offset_given = True
    d = diagnose(path, machine, measured.command(), base=case.base, candidates=COMMAND_EFFECTS,
                 do_combine=False, localisation=False, reinterpret=_reinterpret(program),
                 recorder_window_ms=case.known_recorder_ms, registration=reg)
    t2 = time.perf_counter()
    return {**_row(case, measured, d, t1 - t0, t2 - t1, "independent"),
            "offset_given": offset_given, "registration": reg.status,
            "offset_error_um": float(1e3 * np.max(np.abs(np.asarray(reg.offset_mm) - case.offset_mm)))}


def _row(case, measured, d, truth_s: float, diagnosis_s: float, suite: str) -> dict:
    own = next(f for f in d.fits if f.effect == case.effect)
    errs = param_errors(case, own.params)
    return {**case.as_dict(), "suite": suite, "n_samples": len(measured),
            "top1": d.fits[0].effect, "right": d.fits[0].effect == case.effect,
            "ranking": [[f.effect, round(f.shrink_percent, 2)] for f in d.fits],
            "fit_params": {k: (v if isinstance(v, str) else float(v)) for k, v in own.params.items()},
            "param_error": errs, "max_param_error": max(errs.values()),
            "shrink_percent": own.shrink_percent, "gap_before": d.gap_before.gap,
            "gap_after": own.gap_after.gap,
            "metric_shrink_percent": own.metric_shrink(),
            "n_evals": sum(f.n_evals for f in d.fits),
            "truth_s": truth_s, "diagnosis_s": diagnosis_s}


SHORT = {"ncu_path_jerk": "ncu_jerk", "accel_mode": "accel", "servo_lag": "servo",
         "compliance": "compl", "transition": "trans", "lookahead": "look", "cycle_time": "t_cy",
         "axis_jerk": "ax_jerk", "rapid_override": "rapid", "feed_override": "feed_ovr",
         "axis_velocity": "ax_vel", "axis_accel": "ax_acc", "reset_mode": "reset",
         "corner_jump": "corner", "recorder": "rec"}


def _stats(rows: list[dict]) -> dict:
    """top-1, parameter error and shrinkage of a group of cases."""
    n = len(rows)
    right = [r for r in rows if r["right"]]
    perr = [r["max_param_error"] for r in rows]
    shr = [r["shrink_percent"] for r in right]
    return {"cases": n, "top1": len(right) / n if n else math.nan, "right": len(right),
            "param_error_median": float(np.median(perr)) if perr else math.nan,
            "param_error_max": float(np.max(perr)) if perr else math.nan,
            "param_within_10pct": (sum(e <= PARAM_TARGET for e in perr) / n) if n else math.nan,
            "shrink_median": float(np.median(shr)) if shr else math.nan,
            "shrink_min": float(np.min(shr)) if shr else math.nan,
            "shrink_at_least_80": (sum(v >= SHRINK_TARGET for v in shr) / len(shr)) if shr else math.nan}


def _table(groups: dict, head: str) -> list[str]:
    lines = [f"| {head} | cases | top-1 | param. error median | max | within 10 % | shrink median | min |",
             "|---|---:|---:|---:|---:|---:|---:|---:|"]
    for k, v in groups.items():
        if v["cases"]:
            lines.append(f"| {k} | {v['cases']} | {100 * v['top1']:.0f} % | {100 * v['param_error_median']:.2f} % | "
                         f"{100 * v['param_error_max']:.2f} % | {100 * v['param_within_10pct']:.0f} % | "
                         f"{v['shrink_median']:.1f} % | {v['shrink_min']:.1f} % |")
    return lines


def _confusion(rows: list[dict], kinds: list[str]) -> tuple[dict, list[str]]:
    labels = kinds + sorted({r["top1"] for r in rows} - set(kinds))
    conf = {k: Counter() for k in kinds}
    for r in rows:
        conf[r["effect"]][r["top1"]] += 1
    lines = ["Confusion matrix (rows: effect present in the truth; columns: effect ranked first)", "",
             "| truth \\ top-1 | " + " | ".join(SHORT.get(k, k) for k in labels) + " |",
             "|---|" + "---:|" * len(labels)]
    for k in kinds:
        if sum(conf[k].values()):
            lines.append(f"| {k} | " + " | ".join(str(conf[k].get(c, 0) or ".") for c in labels) + " |")
    return {k: dict(conf[k]) for k in kinds}, lines


def _bullets(st: dict, kinds_seen: int) -> list[str]:
    return [f"* top-1 identification: **{100 * st['top1']:.1f} %** ({st['right']}/{st['cases']}) over {kinds_seen} effect kinds",
            f"* parameter error of the true effect's fit: median {100 * st['param_error_median']:.2f} %, "
            f"max {100 * st['param_error_max']:.2f} %, within 10 %: {100 * st['param_within_10pct']:.1f} % of cases",
            f"* gap shrinkage when the top-1 effect is right: median {st['shrink_median']:.1f} %, "
            f"min {st['shrink_min']:.1f} %, at least 80 %: {100 * st['shrink_at_least_80']:.1f} % of cases"]


def summarise(rows: list[dict], seconds: float, args) -> tuple[dict, str]:
    for r in rows:
        r.setdefault("suite", "planner")
    suites = {"independent": [r for r in rows if r["suite"] == "independent"],
              "planner": [r for r in rows if r["suite"] == "planner"]}
    n = len(rows)
    overall = _stats(rows)
    kinds_seen = len({r["effect"] for r in rows})
    conditions_seen = sorted({r.get("condition", "scope") for r in rows})
    summary = {"cases": n, "seed": args.seed, "kinds": kinds_seen, "top1_rate": overall["top1"],
               "conditions": conditions_seen,
               "param_error_median": overall["param_error_median"],
               "param_error_max": overall["param_error_max"],
               "param_within_10pct": overall["param_within_10pct"],
               "shrink_median_right": overall["shrink_median"],
               "shrink_min_right": overall["shrink_min"],
               "shrink_at_least_80_right": overall["shrink_at_least_80"],
               "runtime_s": seconds, "workers": args.workers,
               "targets": {"top1": TOP1_TARGET, "param_error": PARAM_TARGET, "shrink_percent": SHRINK_TARGET},
               "suites": {}}
    per_all = {}
    for name, rs in suites.items():
        if not rs:
            continue
        kinds = list(INDEPENDENT_KINDS if name == "independent" else CASE_KINDS)
        per = {k: _stats([r for r in rs if r["effect"] == k]) for k in kinds}
        per_all.update({f"{name}:{k}": v for k, v in per.items() if v["cases"]})
        conf, _ = _confusion(rs, kinds)
        entry = {**_stats(rs), "per_effect": per, "confusion": conf,
                 "program": os.path.relpath(str(INDEPENDENT_PROGRAM), REPO) if name == "independent" else args.program}
        if name == "independent":
            entry["per_condition"] = {c: _stats([r for r in rs if r["condition"] == c]) for c in CONDITIONS}
        summary["suites"][name] = entry
    # kept for readers of the previous format: the planner suite's per-effect table
    if "planner" in summary["suites"]:
        summary["per_effect"] = summary["suites"]["planner"]["per_effect"]
        summary["confusion"] = summary["suites"]["planner"]["confusion"]
    summary["targets_met"] = bool(
        n >= 50 and kinds_seen >= 5 and overall["top1"] >= TOP1_TARGET
        and overall["param_within_10pct"] >= 0.9
        and all(v["param_error_median"] <= PARAM_TARGET for v in per_all.values())
        and overall["shrink_at_least_80"] >= 0.9)

    cmd = f"python benchmarks/bench_gap.py --cases {getattr(args, 'cases', n)} " \
          f"--independent-cases {getattr(args, 'independent_cases', 0)} --seed {args.seed}"
    lines = [f"## Gap-diagnosis benchmark: {n} cases, seed {args.seed}", "",
             f"`{cmd}` (machine `{getattr(args, 'machine', 'mikron')}`, {args.workers} worker(s)): "
             f"{seconds:.0f} s.", "",
             f"All cases ({len(suites['independent'])} with independent truths, "
             f"{len(suites['planner'])} with planner-made truths; recording conditions "
             f"{', '.join(conditions_seen)}):", ""]
    lines += _bullets(overall, kinds_seen)
    lines += [f"* targets (top-1 >= 90 % over all cases, >= 50 cases, >= 5 kinds, parameter error <= 10 % and "
              f"shrinkage >= 80 % in >= 90 % of cases): **{'met' if summary['targets_met'] else 'NOT met'}**", ""]
    titles = {"independent": "### Independent truths (ruckig plain planner, `ncsim/gap/truth/plain.py`; not ncsim's planner)",
              "planner": "### Planner-made truths (ncsim's planner + RK4 servo; consistency, not correctness)"}
    for name, rs in suites.items():
        if not rs:
            continue
        entry = summary["suites"][name]
        kinds = list(INDEPENDENT_KINDS if name == "independent" else CASE_KINDS)
        lines += [titles[name], "", f"Program `{entry['program']}`.", ""]
        lines += _bullets(entry, len({r['effect'] for r in rs})) + [""]
        lines += _confusion(rs, kinds)[1] + [""]
        lines += _table({k: v for k, v in entry["per_effect"].items()}, "effect") + [""]
        if name == "independent":
            lines += ["Per recording condition:", ""]
            lines += _table(entry["per_condition"], "condition") + [""]
    wrong = [r for r in rows if not r["right"]]
    if wrong:
        lines += ["Misidentified cases:", ""]
        for r in wrong:
            where = f" ({r['condition']})" if r.get("condition") else ""
            if r["top1"] == "refused":
                lines.append(f"* case {r['index']}{where}: {r['effect']} {r['params']} -> refused: "
                             + r["refusal"].split(": ", 1)[-1])
                continue
            lines.append(f"* case {r['index']}{where}: {r['effect']} {r['params']} -> ranked "
                         + ", ".join(f"{e} {s_:.1f} %" for e, s_ in r["ranking"][:3]))
    return summary, "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", type=int, default=60, help="cases with planner-made truths")
    ap.add_argument("--independent-cases", type=int, default=84,
                    help="cases with independent truths (7 effects x 6 recording conditions)")
    ap.add_argument("--suite", choices=("all", "planner", "independent"), default="all")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--program", default=str(REPO / "programs" / "diagnosis_mix.mpf"))
    ap.add_argument("--machine", default="mikron")
    ap.add_argument("--workers", type=int, default=min(2, os.cpu_count() or 1))
    ap.add_argument("--out", default=str(REPO / "benchmarks" / "bench_gap_results"),
                    help="output prefix (.json and .md are appended); '' to write nothing")
    args = ap.parse_args(argv)
    if args.suite == "planner":
        args.independent_cases = 0
    if args.suite == "independent":
        args.cases = 0
    if args.cases < 0 or args.independent_cases < 0 or args.cases + args.independent_cases < 1:
        ap.error("--cases and --independent-cases must be >= 0 and give at least one case")
    # independent cases first: they are the slower ones, so the pool ends on short ones
    cases = draw_independent_cases(args.independent_cases, args.seed) + draw_cases(args.cases, args.seed)
    t0 = time.perf_counter()
    if args.workers > 1:
        import multiprocessing as mp
        with mp.get_context("fork").Pool(args.workers, initializer=_init,
                                         initargs=(args.program, args.machine)) as pool:
            rows = []
            for r in pool.imap(run_case, cases):
                rows.append(r)
                _progress(r, len(rows), len(cases))
    else:
        _init(args.program, args.machine)
        rows = []
        for c in cases:
            rows.append(run_case(c))
            _progress(rows[-1], len(rows), len(cases))
    seconds = time.perf_counter() - t0
    args.program = os.path.relpath(args.program, REPO)
    summary, text = summarise(rows, seconds, args)
    print(text)
    if args.out:
        Path(args.out + ".json").write_text(json.dumps({"summary": summary, "cases": rows},
                                                       indent=1, default=float))
        Path(args.out + ".md").write_text(text)
        print(f"wrote {args.out}.json and {args.out}.md")
    return 0


def _progress(r: dict, i: int, n: int) -> None:
    mark = "ok " if r["right"] else "MISS"
    print(f"[{i:3d}/{n}] {mark} {r['effect']:14s} {r.get('condition', 'scope'):8s} -> {r['top1']:14s} "
          f"param err {100 * r['max_param_error']:6.2f} %  shrink {r['shrink_percent']:6.1f} %  "
          f"({r['diagnosis_s']:.1f} s)", file=sys.stderr, flush=True)


if __name__ == "__main__":
    raise SystemExit(main())
