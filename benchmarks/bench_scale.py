"""Speed and scale benchmark: CAM-like programs of 10k, 100k and 1M blocks (or more).

    python benchmarks/bench_scale.py                 # 10k, 100k, 1M blocks
    python benchmarks/bench_scale.py --sizes 10000 100000 --json out.json

For each size it generates a program with ``gen_cam.py`` (cached under ``--dir``) and runs,
each in a fresh process so that peak memory is per run:

* the stages in-process: parse only, interpret (parse + interpret), limits, plan, summary;
* the command a user runs, ``ncsim run PROGRAM --machine mikron`` (summary only), timed from
  process start to exit, with its peak resident memory (ru_maxrss of the child), and the same
  command on a 4-block program: the start-up part of every run.

It then reports parse, plan and total blocks/s, peak RSS, the 1M/100k time ratio, and the
trace-writing rate (sampling a planned motion to >= 1M samples and writing the CSV).
Numba's compiled kernels are cached on disk after the first run ever; a warm-up run makes
sure the figures are for a normal (cached) start.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

STAGES = r"""
import json, resource, sys, time
t0 = time.perf_counter()
from ncsim.nc.parse import parse_file
from ncsim.nc.interpret import interpret_file
from ncsim.plan.limits import path_limits
from ncsim.plan.lookahead import plan
from ncsim.machine import load_machine
from ncsim.report.summary import summary
from ncsim.pipeline import Simulation
from ncsim.motion import FULL_MODEL
from ncsim.pipeline import simulate
t_import = time.perf_counter() - t0
file = sys.argv[1]
m = load_machine("mikron")
# load the compiled kernels once (numba's on-disk cache), so stage figures are per-block rates
t = time.perf_counter()
from ncsim import jit
with jit.forced("compiled"):  # numba's start-up paid here, not by the first stage timed
    simulate("warm.mpf", m, text="G17 G90 G64 SOFT\nG1 X1 F1000\nG1 X2 Y1\nG2 X3 Y2 I1 J0\n" * 10)
warm_s = time.perf_counter() - t
t = time.perf_counter(); parse_file(file); parse_s = time.perf_counter() - t
t = time.perf_counter(); r = interpret_file(file, m); interpret_s = time.perf_counter() - t
t = time.perf_counter(); lim = path_limits(r.path, m); limits_s = time.perf_counter() - t
t = time.perf_counter(); mo = plan(r.path, m, limits=lim); plan_s = time.perf_counter() - t
sim = Simulation(program=file, machine=m, options=FULL_MODEL, interpreted=r, limits=lim, motion=mo)
t = time.perf_counter(); s = summary(sim, include_blocks=False); summary_s = time.perf_counter() - t
print(json.dumps(dict(import_s=t_import, warm_s=warm_s, parse_s=parse_s, interpret_s=interpret_s, limits_s=limits_s,
                      plan_s=plan_s, summary_s=summary_s, blocks=r.path.n,
                      cycle_time_s=s["cycle_time_s"],
                      peak_rss_mb=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024)))
"""

TRACE = r"""
import json, sys, time, os, tempfile
from ncsim.pipeline import simulate
from ncsim.plan.sample import sample_motion
from ncsim.report.csvio import write_trace_csv
sim = simulate(sys.argv[1], "mikron")
dt = sim.motion.total_time_s / 1_000_000
trace = sample_motion(sim.motion, dt)
out = os.path.join(tempfile.mkdtemp(), "trace.csv")
t = time.perf_counter(); rows = write_trace_csv(trace, out); write_s = time.perf_counter() - t
print(json.dumps(dict(samples=len(trace), write_s=write_s, bytes=os.path.getsize(out))))
"""


#: CPU seconds (user + system) of the last :func:`measure`d child: on a shared machine the wall
#: time includes waiting for a core, the CPU time does not
LAST_CPU_S = [0.0]


def measure(args: list[str]) -> tuple[float, float, str]:
    """Run ``args``; return wall time (s), peak RSS of the child (MB) and its stdout (its CPU
    time goes to ``LAST_CPU_S[0]``)."""
    r_out, w_out = os.pipe()
    t0 = time.perf_counter()
    pid = os.fork()
    if pid == 0:  # child
        os.close(r_out)
        os.dup2(w_out, 1)
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, 2)
        os.execvp(args[0], args)
    os.close(w_out)
    chunks = []
    while True:
        b = os.read(r_out, 1 << 16)
        if not b:
            break
        chunks.append(b)
    _, status, usage = os.wait4(pid, 0)
    wall = time.perf_counter() - t0
    os.close(r_out)
    if os.waitstatus_to_exitcode(status) != 0:
        raise SystemExit(f"{' '.join(args)} exited with {os.waitstatus_to_exitcode(status)}")
    LAST_CPU_S[0] = usage.ru_utime + usage.ru_stime
    return wall, usage.ru_maxrss / 1024.0, b"".join(chunks).decode()


def comparison_args(description: str, argv, *, repeat: int, repeat_help: str):
    """The options of the benchmarks that compare 1M-block programs side by side
    (``bench_arcs``, ``bench_compressor``): ``--blocks``, ``--repeat``, ``--dir`` (the programs'
    cache) and ``--json``. Returns the parsed arguments and the directory, created."""
    ap = argparse.ArgumentParser(description=description)
    ap.add_argument("--blocks", type=int, default=1_000_000)
    ap.add_argument("--repeat", type=int, default=repeat, help=repeat_help)
    ap.add_argument("--dir", default=os.path.join(tempfile.gettempdir(), "ncsim-bench"))
    ap.add_argument("--json", dest="json_out", default=None)
    args = ap.parse_args(argv)
    directory = Path(args.dir)
    directory.mkdir(parents=True, exist_ok=True)
    return args, directory


def program_file(directory: Path, blocks: int) -> Path:
    from gen_cam import cam_program

    f = directory / f"cam_{blocks}.mpf"
    if not f.exists():
        f.write_text(cam_program(blocks))
    return f


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[10_000, 100_000, 1_000_000])
    ap.add_argument("--dir", default=os.path.join(tempfile.gettempdir(), "ncsim-bench"))
    ap.add_argument("--json", dest="json_out", default=None, help="also write the figures here")
    ap.add_argument("--repeat", type=int, default=1, help="runs per size (the best is kept)")
    args = ap.parse_args(argv)
    directory = Path(args.dir)
    directory.mkdir(parents=True, exist_ok=True)
    py = sys.executable
    ncsim_run = [py, "-m", "ncsim", "run"]

    # warm-up: compiled kernels loaded from (or written to) numba's cache
    small = program_file(directory, 1000)
    measure(ncsim_run + [str(small), "--machine", "mikron"])
    # start-up: the same command on a 4-block program (imports, numba's cached kernels)
    tiny = directory / "tiny.mpf"
    tiny.write_text("G17 G90 G64 SOFT\nG1 X1 F1000\nG1 X2 Y1\nG2 X3 Y2 I1 J0\nM30\n")
    startups = []
    for _ in range(max(args.repeat, 2)):
        wall, rss, _ = measure(ncsim_run + [str(tiny), "--machine", "mikron"])
        startups.append((wall, rss, LAST_CPU_S[0]))
    startup_s, startup_mb, startup_cpu_s = min(startups)

    rows = []
    for n in args.sizes:
        f = program_file(directory, n)
        best = None
        for _ in range(args.repeat):
            _, _, out = measure([py, "-c", STAGES, str(f)])
            stages = json.loads(out)
            wall, rss, _ = measure(ncsim_run + [str(f), "--machine", "mikron"])
            cand = dict(stages, run_wall_s=wall, run_peak_rss_mb=rss, run_cpu_s=LAST_CPU_S[0])
            if best is None or cand["run_wall_s"] < best["run_wall_s"]:
                best = cand
        blocks = best["blocks"]
        best.update(
            requested_blocks=n,
            parse_blocks_per_s=blocks / best["parse_s"],
            interpret_blocks_per_s=blocks / best["interpret_s"],
            plan_blocks_per_s=blocks / (best["limits_s"] + best["plan_s"]),
            total_blocks_per_s=blocks / best["run_wall_s"],
        )
        rows.append(best)
        print(f"{n:>9} blocks: ncsim run {best['run_wall_s']:.2f} s (CPU {best['run_cpu_s']:.2f} s), "
              f"peak RSS {best['run_peak_rss_mb']:.0f} MB | "
              f"parse {best['parse_blocks_per_s']:,.0f}/s, interpret {best['interpret_blocks_per_s']:,.0f}/s, "
              f"limits+plan {best['plan_blocks_per_s']:,.0f}/s, total {best['total_blocks_per_s']:,.0f}/s",
              flush=True)

    by_n = {r["requested_blocks"]: r for r in rows}
    ratio = (by_n[1_000_000]["run_wall_s"] / by_n[100_000]["run_wall_s"]
             if 1_000_000 in by_n and 100_000 in by_n else None)
    trace_file = program_file(directory, 100_000 if 100_000 in by_n else args.sizes[0])
    _, trace_rss, out = measure([py, "-c", TRACE, str(trace_file)])
    trace = json.loads(out)
    trace["samples_per_s"] = trace["samples"] / trace["write_s"]

    print()
    print("| blocks | `ncsim run` s | peak RSS MB | parse blocks/s | limits+plan blocks/s | total blocks/s | cycle time s |")
    print("|---:|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        print(f"| {r['blocks']:,} | {r['run_wall_s']:.2f} | {r['run_peak_rss_mb']:.0f} | "
              f"{r['parse_blocks_per_s']:,.0f} | {r['plan_blocks_per_s']:,.0f} | "
              f"{r['total_blocks_per_s']:,.0f} | {r['cycle_time_s']:,.0f} |")
    print(f"\nstart-up (`ncsim run` on a 4-block program): {startup_s:.2f} s (CPU {startup_cpu_s:.2f} s), "
          f"{startup_mb:.0f} MB; "
          "without it: " + ", ".join(f"{r['blocks']:,} blocks {r['run_wall_s'] - startup_s:.2f} s"
                                     for r in rows))
    if ratio is not None:
        print(f"1M / 100k `ncsim run` time ratio: {ratio:.2f} (linear would be 10)")
    print(f"trace writing: {trace['samples']:,} samples in {trace['write_s']:.2f} s = "
          f"{trace['samples_per_s']:,.0f} samples/s ({trace['bytes'] / 1e6:.0f} MB CSV)")
    if args.json_out:
        Path(args.json_out).write_text(json.dumps(dict(rows=rows, ratio_1m_100k=ratio, trace=trace,
                                                       startup_s=startup_s, startup_mb=startup_mb,
                                                       startup_cpu_s=startup_cpu_s),
                                                  indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
