"""Withheld-effect benchmark of the gap diagnosis.

Every case draws one effect of ``ncsim.gap.effects`` with random parameters (``ncsim.gap.truth.cases``),
builds a measured trace in which it is present -- the planner with the effect on, then each
axis through the independent RK4 closed-loop simulation of ``ncsim.gap.truth.servo`` (baseline dynamics,
or random loop / structure parameters for the servo and structure effects), then an
oscilloscope-like recording (``ncsim.gap.truth.synth.degrade``: period 1-12 ms, noise, increment, clock
and zero offsets, dropouts) -- and runs ``ncsim.gap.diagnose`` from the base model that lacks
the effect, with every effect of the library as a candidate. Effects are drawn in shuffled
rounds, so that every kind appears about equally often.

Reported: the confusion matrix (true effect against the top-ranked one), the top-1 rate, the
parameter-recovery error of the true effect's fit, and the shrinkage of the combined gap when
the top-ranked effect is the true one. Targets: top-1 >= 90 % over >= 50 cases and >= 5 kinds,
parameter error <= 10 %, shrinkage >= 80 %.

    python benchmarks/bench_gap.py --cases 60 --seed 1            # the README figures
    python benchmarks/bench_gap.py --cases 8 --seed 3 --workers 1  # a quick look

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

from ncsim.gap.effects import EFFECTS  # noqa: E402
from ncsim.gap.diagnose import diagnose  # noqa: E402
from ncsim.gap.truth.cases import CASE_KINDS, draw_case, truth_trace  # noqa: E402
from ncsim.nc.interpret import interpret_file  # noqa: E402
from ncsim.machine import load_machine  # noqa: E402

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


def _init(program: str, machine: str) -> None:
    m = load_machine(machine)
    _STATE["machine"] = m
    _STATE["path"] = interpret_file(program, m).path


def param_errors(case, fit_params: dict) -> dict:
    """Relative error of every drawn parameter; discrete ones: 0 if right, 1 if wrong."""
    out = {}
    kind = CASE_KINDS[case.effect]
    for name in kind.ranges:
        true = float(case.params[name])
        out[name] = abs(float(fit_params[name]) - true) / abs(true)
    for name, value in kind.fixed.items():
        if EFFECTS[case.effect].param(name).kind == "choice":
            out[name] = 0.0 if fit_params.get(name) == value else 1.0
    return out


def run_case(case) -> dict:
    path, machine = _STATE["path"], _STATE["machine"]
    t0 = time.perf_counter()
    measured = truth_trace(path, machine, case)
    t1 = time.perf_counter()
    d = diagnose(path, machine, measured, base=case.base, do_combine=False, localisation=False)
    t2 = time.perf_counter()
    own = next(f for f in d.fits if f.effect == case.effect)
    errs = param_errors(case, own.params)
    return {**case.as_dict(), "n_samples": len(measured),
            "top1": d.fits[0].effect, "right": d.fits[0].effect == case.effect,
            "ranking": [[f.effect, round(f.shrink_percent, 2)] for f in d.fits],
            "fit_params": {k: (v if isinstance(v, str) else float(v)) for k, v in own.params.items()},
            "param_error": errs, "max_param_error": max(errs.values()),
            "shrink_percent": own.shrink_percent, "gap_before": d.gap_before.gap,
            "gap_after": own.gap_after.gap,
            "metric_shrink_percent": own.metric_shrink(),
            "n_evals": sum(f.n_evals for f in d.fits),
            "truth_s": t1 - t0, "diagnosis_s": t2 - t1}


def summarise(rows: list[dict], seconds: float, args) -> tuple[dict, str]:
    kinds = list(CASE_KINDS)
    labels = kinds + sorted({r["top1"] for r in rows} - set(kinds))
    conf = {k: Counter() for k in kinds}
    for r in rows:
        conf[r["effect"]][r["top1"]] += 1
    n = len(rows)
    right = [r for r in rows if r["right"]]
    top1 = len(right) / n if n else math.nan
    per = {}
    for k in kinds:
        rk = [r for r in rows if r["effect"] == k]
        ok = [r for r in rk if r["right"]]
        perr = [r["max_param_error"] for r in rk]
        shr = [r["shrink_percent"] for r in ok]
        per[k] = {"cases": len(rk), "top1": len(ok) / len(rk) if rk else math.nan,
                  "param_error_median": float(np.median(perr)) if perr else math.nan,
                  "param_error_max": float(np.max(perr)) if perr else math.nan,
                  "param_within_10pct": (sum(e <= PARAM_TARGET for e in perr) / len(perr)) if perr else math.nan,
                  "shrink_median": float(np.median(shr)) if shr else math.nan,
                  "shrink_min": float(np.min(shr)) if shr else math.nan}
    perr_all = [r["max_param_error"] for r in rows]
    shr_right = [r["shrink_percent"] for r in right]
    kinds_seen = len({r["effect"] for r in rows})
    summary = {
        "cases": n, "seed": args.seed, "program": args.program, "machine": args.machine,
        "kinds": kinds_seen, "top1_rate": top1,
        "param_error_median": float(np.median(perr_all)) if perr_all else math.nan,
        "param_error_max": float(np.max(perr_all)) if perr_all else math.nan,
        "param_within_10pct": (sum(e <= PARAM_TARGET for e in perr_all) / n) if n else math.nan,
        "shrink_median_right": float(np.median(shr_right)) if shr_right else math.nan,
        "shrink_min_right": float(np.min(shr_right)) if shr_right else math.nan,
        "shrink_at_least_80_right": (sum(s >= SHRINK_TARGET for s in shr_right) / len(shr_right))
        if shr_right else math.nan,
        "per_effect": per,
        "confusion": {k: dict(conf[k]) for k in kinds},
        "runtime_s": seconds, "workers": args.workers,
        "targets": {"top1": TOP1_TARGET, "param_error": PARAM_TARGET, "shrink_percent": SHRINK_TARGET},
    }
    summary["targets_met"] = bool(
        n >= 50 and kinds_seen >= 5 and top1 >= TOP1_TARGET
        and summary["param_within_10pct"] >= 0.9
        and all(v["param_error_median"] <= PARAM_TARGET for v in per.values() if v["cases"])
        and summary["shrink_at_least_80_right"] >= 0.9)

    short = {k: k.replace("ncu_path_jerk", "ncu_jerk").replace("accel_mode", "accel")
             .replace("servo_lag", "servo").replace("compliance", "compl")
             .replace("transition", "trans").replace("lookahead", "look")
             .replace("cycle_time", "t_cy").replace("axis_jerk", "ax_jerk") for k in labels}
    lines = [f"## Gap-diagnosis benchmark: {n} cases, seed {args.seed}", "",
             f"`python benchmarks/bench_gap.py --cases {n} --seed {args.seed}` "
             f"(program `{args.program}`, machine `{args.machine}`, {args.workers} worker(s)): "
             f"{seconds:.0f} s.", "",
             f"* top-1 identification: **{100 * top1:.1f} %** ({len(right)}/{n}) over {kinds_seen} effect kinds",
             f"* parameter error of the true effect's fit: median {100 * summary['param_error_median']:.2f} %, "
             f"max {100 * summary['param_error_max']:.2f} %, within 10 %: {100 * summary['param_within_10pct']:.1f} % of cases",
             f"* gap shrinkage when the top-1 effect is right: median {summary['shrink_median_right']:.1f} %, "
             f"min {summary['shrink_min_right']:.1f} %, at least 80 %: "
             f"{100 * summary['shrink_at_least_80_right']:.1f} % of cases",
             f"* targets (top-1 >= 90 %, >= 50 cases, >= 5 kinds, parameter error <= 10 %, shrinkage >= 80 %): "
             f"**{'met' if summary['targets_met'] else 'NOT met'}**", "",
             "Confusion matrix (rows: effect present in the truth; columns: effect ranked first)", "",
             "| truth \\ top-1 | " + " | ".join(short[k] for k in labels) + " |",
             "|---|" + "---:|" * len(labels)]
    for k in kinds:
        lines.append(f"| {k} | " + " | ".join(str(conf[k].get(c, 0) or ".") for c in labels) + " |")
    lines += ["", "| effect | cases | top-1 | param. error median | max | within 10 % | shrink median | min |",
              "|---|---:|---:|---:|---:|---:|---:|---:|"]
    for k in kinds:
        v = per[k]
        if not v["cases"]:
            continue
        lines.append(f"| {k} | {v['cases']} | {100 * v['top1']:.0f} % | {100 * v['param_error_median']:.2f} % | "
                     f"{100 * v['param_error_max']:.2f} % | {100 * v['param_within_10pct']:.0f} % | "
                     f"{v['shrink_median']:.1f} % | {v['shrink_min']:.1f} % |")
    wrong = [r for r in rows if not r["right"]]
    if wrong:
        lines += ["", "Misidentified cases:", ""]
        for r in wrong:
            lines.append(f"* case {r['index']}: {r['effect']} {r['params']} -> ranked "
                         + ", ".join(f"{e} {s:.1f} %" for e, s in r["ranking"][:3]))
    return summary, "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", type=int, default=60)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--program", default=str(REPO / "programs" / "diagnosis_mix.mpf"))
    ap.add_argument("--machine", default="mikron")
    ap.add_argument("--workers", type=int, default=min(2, os.cpu_count() or 1))
    ap.add_argument("--out", default=str(REPO / "benchmarks" / "bench_gap_results"),
                    help="output prefix (.json and .md are appended); '' to write nothing")
    args = ap.parse_args(argv)
    if args.cases < 1:
        ap.error("--cases must be at least 1")
    cases = draw_cases(args.cases, args.seed)
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
    print(f"[{i:3d}/{n}] {mark} {r['effect']:14s} -> {r['top1']:14s} "
          f"param err {100 * r['max_param_error']:6.2f} %  shrink {r['shrink_percent']:6.1f} %  "
          f"({r['diagnosis_s']:.1f} s)", file=sys.stderr, flush=True)


if __name__ == "__main__":
    raise SystemExit(main())
