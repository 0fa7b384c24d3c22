"""Memory and time of ``ncsim run`` on a 1M-block CAM program: text, ``--json`` (the per-block
list streamed) and ``--json --no-blocks``.

    python benchmarks/bench_json.py --repeat 2

Each command runs in a fresh process with its stdout written to a file; the figures are its
wall time, CPU time and peak RSS (``ru_maxrss`` of the child, MiB) and the size of what it
wrote, the best of ``--repeat`` runs. The program is ``gen_cam.py``'s (cached in ``--dir``).
"""
from __future__ import annotations

import json
import os
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from bench_scale import comparison_args, program_file  # noqa: E402

VARIANTS = (("text", []), ("--json", ["--json"]), ("--json --no-blocks", ["--json", "--no-blocks"]))


def run(args: list[str], out: Path) -> tuple[float, float, float]:
    """Wall s, CPU s and peak RSS MiB of ``args`` with stdout to ``out``."""
    t0 = time.perf_counter()
    pid = os.fork()
    if pid == 0:  # child
        fd = os.open(out, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
        os.dup2(fd, 1)
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, 2)
        os.execvp(args[0], args)
    _, status, usage = os.wait4(pid, 0)
    if os.waitstatus_to_exitcode(status) != 0:
        raise SystemExit(f"{' '.join(args)} exited with {os.waitstatus_to_exitcode(status)}")
    return time.perf_counter() - t0, usage.ru_utime + usage.ru_stime, usage.ru_maxrss / 1024.0


def main(argv=None) -> int:
    args, directory = comparison_args(__doc__.splitlines()[0], argv, repeat=2,
                                      repeat_help="runs per variant (the best is kept)")
    program = program_file(directory, args.blocks)
    run(["ncsim", "warmup"], directory / "warmup.out")
    rows = {}
    for name, extra in VARIANTS:
        out = directory / "bench_json.out"
        best = min(run(["ncsim", "run", str(program), "--machine", "mikron", "-q", *extra], out)
                   for _ in range(args.repeat))
        rows[name] = {"wall_s": best[0], "cpu_s": best[1], "peak_rss_mib": best[2],
                      "output_mb": out.stat().st_size / 1e6}
        out.unlink()
    load = os.getloadavg()[0]
    print(f"{args.blocks:,} blocks, load average {load:.1f}")
    print(f"| `ncsim run` | wall | CPU | peak RSS | output |\n|---|---:|---:|---:|---:|")
    for name, r in rows.items():
        print(f"| {name} | {r['wall_s']:.2f} s | {r['cpu_s']:.2f} s | {r['peak_rss_mib']:,.0f} MiB "
              f"| {r['output_mb']:,.1f} MB |")
    if args.json_out:
        Path(args.json_out).write_text(json.dumps({"blocks": args.blocks, "load": load,
                                                   "runs": rows}, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
