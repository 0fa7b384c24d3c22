"""Start-up benchmark: what a user waits for before and around the work itself.

Each figure is one command in a fresh process, timed from start to exit (wall clock) with the
child's CPU time (user + sys, from ``os.wait4``), the minimum over ``--repeat`` runs: the
machine is shared, so the minimum is the least disturbed run. Python's byte code is cached as
after ``pip install`` (``PYTHONDONTWRITEBYTECODE`` is dropped for the children).

* ``ncsim --help``;
* ``ncsim run`` on an 11-line paper program, warm (numba's cache filled), and which heavy
  packages that run imports;
* the first run after installing: numba's cache empty (a fresh ``NUMBA_CACHE_DIR``) for the
  same small program, for a 100k-block CAM program (``gen_cam.py``), and ``ncsim warmup``;
* the crossover behind ``ncsim.jit.PYTHON_BELOW``: ``ncsim run`` on CAM programs of a few
  thousand blocks with the kernels forced to plain Python and to numba (warm).

``--baseline DIR`` runs the same commands from another checkout (``python -m ncsim`` with DIR
as the working directory, so DIR's package is imported) in the same session, for before/after
figures under the same load.

    python benchmarks/bench_startup.py                       # about 2 minutes
    python benchmarks/bench_startup.py --baseline ../main --repeat 7 --json startup.json
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))

SMALL = ROOT / "programs" / "circle_r30_f12000.mpf"
HEAVY = ("numba", "llvmlite", "scipy", "matplotlib", "dask", "distributed", "ruckig")
IMPORTS = f"""
import runpy, sys
sys.argv = ["ncsim", "run", {str(SMALL)!r}, "--machine", "mikron"]
try:
    runpy.run_module("ncsim", run_name="__main__")
except SystemExit:
    pass
print(sorted({{m.partition(".")[0] for m in sys.modules}} & set({HEAVY!r})), file=sys.stderr)
"""


def child_env(**extra) -> dict:
    env = {k: v for k, v in os.environ.items()
           if k not in ("PYTHONDONTWRITEBYTECODE", "NCSIM_KERNELS", "NUMBA_CACHE_DIR")}
    env.update({k: str(v) for k, v in extra.items()})
    return env


def timed(args: list[str], cwd: Path, env: dict) -> dict:
    """One child process: wall and CPU seconds, peak RSS, exit status and its stderr."""
    with tempfile.TemporaryFile() as err:
        t0 = time.perf_counter()
        proc = subprocess.Popen([sys.executable, *args], cwd=cwd, env=env,
                                stdout=subprocess.DEVNULL, stderr=err)
        _, status, usage = os.wait4(proc.pid, 0)
        wall = time.perf_counter() - t0
        proc.returncode = os.waitstatus_to_exitcode(status)
        err.seek(0)
        stderr = err.read().decode(errors="replace")
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(args)} (in {cwd}) failed:\n{stderr}")
    return dict(wall_s=wall, cpu_s=usage.ru_utime + usage.ru_stime,
                rss_mb=usage.ru_maxrss / 1024, stderr=stderr)


def best(args, cwd, env, repeat: int) -> dict:
    runs = [timed(args, cwd, env) for _ in range(repeat)]
    return dict(wall_s=min(r["wall_s"] for r in runs), cpu_s=min(r["cpu_s"] for r in runs),
                rss_mb=min(r["rss_mb"] for r in runs), stderr=runs[-1]["stderr"])


def load_average() -> str:
    try:
        return " ".join(f"{x:.1f}" for x in os.getloadavg())
    except OSError:  # pragma: no cover
        return "?"


def measure(checkout: Path, work: Path, repeat: int, crossover: list[int], large: int,
            has_warmup: bool) -> dict:
    run = ["-m", "ncsim", "run"]
    out: dict = {}
    warm_cache = work / f"numba-warm-{checkout.name}"
    warm = child_env(NUMBA_CACHE_DIR=warm_cache)
    timed([*run, str(SMALL), "--machine", "mikron"], checkout, warm)         # byte code
    out["help"] = best(["-m", "ncsim", "--help"], checkout, warm, repeat)
    out["run_small_warm"] = best([*run, str(SMALL), "--machine", "mikron"], checkout, warm, repeat)
    out["run_small_imports"] = timed(["-c", IMPORTS], checkout, warm)["stderr"].strip()

    def cold(args, tag):
        runs = []
        for i in range(max(1, repeat // 3)):
            env = child_env(NUMBA_CACHE_DIR=work / f"numba-cold-{checkout.name}-{tag}-{i}")
            runs.append(timed(args, checkout, env))
        return dict(wall_s=min(r["wall_s"] for r in runs), cpu_s=min(r["cpu_s"] for r in runs),
                    rss_mb=min(r["rss_mb"] for r in runs), stderr=runs[-1]["stderr"])

    out["first_run_small"] = cold([*run, str(SMALL), "--machine", "mikron"], "small")
    big = work / f"cam_{large}.mpf"
    out["first_run_large"] = cold([*run, str(big), "--machine", "mikron"], "large")
    if has_warmup:
        out["warmup_cold"] = cold(["-m", "ncsim", "warmup"], "warmup")
    timed([*run, str(big), "--machine", "mikron"], checkout, warm)          # fill the cache
    out["run_large_warm"] = best([*run, str(big), "--machine", "mikron"], checkout, warm, repeat)
    for n in crossover:
        prog = work / f"cam_{n}.mpf"
        for mode in (("python", "compiled") if has_warmup else ("default",)):
            env = child_env(NUMBA_CACHE_DIR=warm_cache, **({"NCSIM_KERNELS": mode}
                                                           if has_warmup else {}))
            out[f"run_{n}_{mode}"] = best([*run, str(prog), "--machine", "mikron"], checkout,
                                          env, repeat)
    return out


def table(results: dict[str, dict], large: int) -> str:
    names = list(results)
    rows = [("help", "`ncsim --help`"),
            ("run_small_warm", f"`ncsim run` {SMALL.name} (11 lines), warm"),
            ("first_run_small", "first run after install, same program (empty numba cache)"),
            ("first_run_large", f"first run after install, {large:,}-block CAM program"),
            ("run_large_warm", f"`ncsim run` {large:,}-block CAM program, warm"),
            ("warmup_cold", "`ncsim warmup`, empty numba cache")]
    head = "| | " + " | ".join(f"{n} wall s | {n} CPU s" for n in names) + " |"
    lines = [head, "|---|" + "---:|---:|" * len(names)]
    for key, label in rows:
        cells = []
        for n in names:
            r = results[n].get(key)
            cells += ["-", "-"] if r is None else [f"{r['wall_s']:.2f}", f"{r['cpu_s']:.2f}"]
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5, help="runs per figure (the minimum is kept)")
    ap.add_argument("--baseline", type=Path, default=None,
                    help="another checkout to measure the same way (e.g. main before a change)")
    ap.add_argument("--large", type=int, default=100_000, help="blocks of the large first run")
    ap.add_argument("--crossover", type=int, nargs="*", default=[2_000, 5_000, 10_000, 20_000])
    ap.add_argument("--json", type=Path, default=None, help="also write the figures here")
    args = ap.parse_args()

    from gen_cam import cam_program
    print(f"load average at start: {load_average()} ({os.cpu_count()} CPUs)")
    results: dict[str, dict] = {}
    with tempfile.TemporaryDirectory(prefix="ncsim-startup-") as tmp:
        work = Path(tmp)
        for n in {args.large, *args.crossover}:
            (work / f"cam_{n}.mpf").write_text(cam_program(n))
        checkouts = [("this", ROOT, True)]
        if args.baseline is not None:
            base = args.baseline.resolve()
            checkouts.insert(0, ("baseline", base, (base / "ncsim" / "jit.py").exists()))
        for name, path, has_warmup in checkouts:
            print(f"measuring {name}: {path}", flush=True)
            results[name] = measure(path, work, args.repeat, args.crossover, args.large,
                                    has_warmup)
    print(f"load average at end: {load_average()}\n")
    print(table(results, args.large))
    for name, r in results.items():
        print(f"\n{name}: heavy packages imported by the small run: {r['run_small_imports']}")
        notice = [line for line in r["first_run_large"]["stderr"].splitlines() if "compil" in line]
        print(f"{name}: first large run says on stderr: {notice or 'nothing'}")
        cross = {k: v for k, v in r.items() if k.startswith("run_") and k.split("_")[1].isdigit()}
        for key, v in cross.items():
            print(f"  {key:<22} wall {v['wall_s']:.2f} s  CPU {v['cpu_s']:.2f} s")
    if args.json:
        args.json.write_text(json.dumps(results, indent=1))


if __name__ == "__main__":
    main()
