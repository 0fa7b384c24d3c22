"""Where the time of a large program goes: one row per stage of ``ncsim run``, and the
commands end to end.

A CAM-like program (``gen_cam.py``, 1M blocks by default) goes through the stages one by one,
in this process, after ``ncsim.pipeline.warmup()`` (numba's kernels loaded, not compiled):

* read: the file's bytes decoded (``nc.parse.read_program_text``);
* parse: text -> ``Program`` (``nc.parse.parse_text``: the compiled scanner, Lark for the rest);
* interpret: ``Program`` -> ``Path`` (``nc.interpret.interpret_text`` minus parse);
* limits: each block's set point and junction cap (``plan.limits.path_limits``);
* plan: the look-ahead's feed law (``plan.lookahead.plan``);
* report: the summary ``ncsim run`` prints (``report.summary.summary`` + ``format_text``);
* and the two writers: ``ncsim parse``'s lines (``report.pathtext``) and the CSV trace
  (``plan.sample.sample_motion`` + ``report.csvio.write_trace_csv``), each to a file.

Each stage is timed ``--repeat`` times, wall clock and CPU (``time.process_time``), and the
minimum is kept (the machine is shared). ``ncsim run`` and ``ncsim parse > FILE`` also run as
commands in fresh processes (wall, CPU, peak RSS of the child).

    python benchmarks/bench_profile.py                     # 1M blocks, about 2 minutes
    python benchmarks/bench_profile.py --blocks 100000 --repeat 3 --json profile.json
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))


def best(fn, repeat: int):
    """(result, wall s, CPU s): the minimum over ``repeat`` calls."""
    wall = cpu = float("inf")
    for _ in range(repeat):
        w0, c0 = time.perf_counter(), time.process_time()
        out = fn()
        wall = min(wall, time.perf_counter() - w0)
        cpu = min(cpu, time.process_time() - c0)
    return out, wall, cpu


#: runs one command and prints its wall time and rusage: a child forked straight from this
#: (large) process would report this process's size as its peak RSS
CHILD = r"""
import json, os, subprocess, sys, time
with open(sys.argv[1], "wb") as out:
    t0 = time.perf_counter()
    proc = subprocess.Popen(sys.argv[2:], stdout=out, stderr=subprocess.PIPE)
    err = proc.stderr.read()
    _, status, usage = os.wait4(proc.pid, 0)
print(json.dumps(dict(wall_s=time.perf_counter() - t0, cpu_s=usage.ru_utime + usage.ru_stime,
                      rss_mb=usage.ru_maxrss / 1024, status=os.waitstatus_to_exitcode(status),
                      stderr=err.decode(errors="replace"))))
"""


def command(args: list[str], stdout_path: Path | None, repeat: int) -> dict:
    env = {k: v for k, v in os.environ.items()
           if k not in ("PYTHONDONTWRITEBYTECODE", "NCSIM_KERNELS")}
    runs = []
    for _ in range(repeat):
        done = subprocess.run([sys.executable, "-c", CHILD, str(stdout_path or os.devnull),
                               sys.executable, "-m", "ncsim", *args], cwd=ROOT, env=env,
                              capture_output=True, text=True, check=True)
        r = json.loads(done.stdout)
        if r["status"] != 0:
            raise SystemExit(f"ncsim {' '.join(args)} failed:\n{r['stderr']}")
        runs.append(r)
    return {k: min(r[k] for r in runs) for k in ("wall_s", "cpu_s", "rss_mb")}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--blocks", type=int, default=1_000_000)
    ap.add_argument("--repeat", type=int, default=3, help="runs per stage (the minimum is kept)")
    ap.add_argument("--no-trace", action="store_true", help="skip the CSV trace row")
    ap.add_argument("--json", type=Path, default=None)
    args = ap.parse_args()

    from gen_cam import cam_program

    from ncsim.machine import load_machine
    from ncsim.motion import FULL_MODEL
    from ncsim.nc.interpret import interpret_text
    from ncsim.nc.parse import parse_text, read_program_text
    from ncsim.pipeline import Simulation, warmup
    from ncsim.plan.limits import path_limits
    from ncsim.plan.lookahead import plan
    from ncsim.plan.sample import sample_motion
    from ncsim.report.csvio import write_trace_csv
    from ncsim.report.pathtext import write_segments
    from ncsim.report.summary import format_text, summary

    print(f"load average at start: {' '.join(f'{x:.1f}' for x in os.getloadavg())} "
          f"({os.cpu_count()} CPUs)")
    warmup()
    machine = load_machine("mikron")
    rows: list[tuple[str, float, float]] = []
    with tempfile.TemporaryDirectory(prefix="ncsim-profile-") as tmp:
        program = Path(tmp) / f"cam_{args.blocks}.mpf"
        program.write_text(cam_program(args.blocks))
        name = str(program)
        # the commands first: a child forked from a large process reports its size as peak RSS
        run = command(["run", name, "--machine", "mikron"], None, args.repeat)
        parse = command(["parse", name], Path(tmp) / "parse.txt", args.repeat)
        text, w, c = best(lambda: read_program_text(program), args.repeat)
        rows.append(("read", w, c))
        _, w_parse, c_parse = best(lambda: parse_text(text, name), args.repeat)
        rows.append(("parse", w_parse, c_parse))
        result, w, c = best(lambda: interpret_text(text, name, machine), args.repeat)
        rows.append(("interpret", max(w - w_parse, 0.0), max(c - c_parse, 0.0)))
        path = result.path
        limits, w, c = best(lambda: path_limits(path, machine, FULL_MODEL), args.repeat)
        rows.append(("limits", w, c))
        motion, w, c = best(lambda: plan(path, machine, FULL_MODEL, limits=limits), args.repeat)
        rows.append(("plan", w, c))
        sim = Simulation(name, machine, FULL_MODEL, result, limits, motion)
        _, w, c = best(lambda: format_text(summary(sim, include_blocks=False)), args.repeat)
        rows.append(("report", w, c))
        stage_total = sum(r[1] for r in rows), sum(r[2] for r in rows)

        def write_lines():
            with open(Path(tmp) / "segments.txt", "wb") as f:
                return write_segments(path, f)
        _, w, c = best(write_lines, args.repeat)
        extra = [("`ncsim parse` lines (report.pathtext)", w, c, path.n, "segments")]
        if not args.no_trace:
            def trace_csv():
                trace = sample_motion(motion)
                return write_trace_csv(trace, Path(tmp) / "trace.csv")
            samples, w, c = best(trace_csv, 1)
            extra.append(("trace: sample + CSV", w, c, samples, "samples"))
        own_rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024

    n = path.n
    print(f"\n{args.blocks:,} blocks ({n:,} segments), after warm-up; min of {args.repeat} runs\n")
    print("| stage | wall s | CPU s | blocks/s (wall) | share of stages (wall) |")
    print("|---|---:|---:|---:|---:|")
    for stage, w, c in rows:
        print(f"| {stage} | {w:.3f} | {c:.3f} | {n / max(w, 1e-9):,.0f} | "
              f"{100 * w / stage_total[0]:.0f} % |")
    print(f"| **all stages** | {stage_total[0]:.3f} | {stage_total[1]:.3f} | "
          f"{n / stage_total[0]:,.0f} | 100 % |")
    for label, w, c, count, unit in extra:
        print(f"| {label} | {w:.3f} | {c:.3f} | {count / max(w, 1e-9):,.0f} {unit}/s | |")
    print(f"\nthis process's peak RSS: {own_rss:.0f} MB")
    print("\n| command | wall s | CPU s | peak RSS MB | segments/s (wall) |")
    print("|---|---:|---:|---:|---:|")
    for label, r in ((f"`ncsim run` ({args.blocks:,} blocks)", run),
                     (f"`ncsim parse > FILE` ({args.blocks:,} blocks)", parse)):
        print(f"| {label} | {r['wall_s']:.2f} | {r['cpu_s']:.2f} | {r['rss_mb']:.0f} | "
              f"{n / r['wall_s']:,.0f} |")
    print(f"\nload average at end: {' '.join(f'{x:.1f}' for x in os.getloadavg())}")
    if args.json:
        args.json.write_text(json.dumps(dict(
            blocks=args.blocks, segments=n, stages={s: dict(wall_s=w, cpu_s=c) for s, w, c in rows},
            writers={label: dict(wall_s=w, cpu_s=c, count=k) for label, w, c, k, _ in extra},
            run=run, parse=parse), indent=1))


if __name__ == "__main__":
    main()
