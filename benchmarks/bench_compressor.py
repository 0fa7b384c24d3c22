"""The compressor on CAM output: the same program without and with COMPCAD (and with CYCLE832).

    python benchmarks/bench_compressor.py                  # 1M blocks (the README figures)
    python benchmarks/bench_compressor.py --blocks 100000 --repeat 3

The program is ``gen_cam.py``'s surface-finishing raster (0.05-0.5 mm G1 blocks in G64 with
SOFT and FFWON, F6000, G2/G3 links). Variants: ``COMPCAD`` added to its first block, and
``CYCLE832(0.01,_FINISH,1)`` instead of ``G64 SOFT FFWON`` (G642 + COMPCAD per the mikron's
``[cycle832]`` table). For each it reports, from one in-process simulation, the cycle time,
the share of feed time held by ``cycle_time`` (eq. 6) and the highest feed reached; then the
wall time of ``ncsim run PROGRAM --machine mikron`` in fresh processes, run alternately in
the same session, and the ratio COMPCAD / plain (the figure the README quotes: wall times are
noisy on a shared machine, the ratio much less so).

Truth: consistency only (the compressor's fit is ncsim's own); the fit's tolerance and
curvature are tested against independent computations in ``tests/test_compressor.py``.
"""
from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

HEADER = "N10 G17 G90 G71 G94 G64 SOFT FFWON"
VARIANTS = {
    "plain": HEADER,
    "compcad": HEADER + " COMPCAD",
    "cycle832": "N10 G17 G90 G71 G94 CYCLE832(0.01,_FINISH,1)",
}

STAGES = r"""
import json, sys, time
from ncsim.pipeline import simulate
from ncsim.report.summary import summary
simulate("warm.mpf", "mikron", text="G64 SOFT COMPCAD\nG1 X1 F1000\nX2 Y0.01\nX3\n" * 20)
t = time.perf_counter()
sim = simulate(sys.argv[1], "mikron")
wall = time.perf_counter() - t
s = summary(sim, include_blocks=False)
print(json.dumps(dict(blocks=sim.path.n, cycle_time_s=s["cycle_time_s"], feed_time_s=s["feed_time_s"],
                      cycle_time_share=s["time_by_limit_s"].get("cycle_time", 0.0) / s["feed_time_s"],
                      feed_max_mm_min=float(sim.motion.feed_max_mm_s[~sim.path.rapid].max()) * 60.0,
                      stages_s=dict(sim.stage_time_s), in_process_s=wall)))
"""


def programs(directory: Path, blocks: int) -> dict[str, Path]:
    from gen_cam import cam_program

    base = cam_program(blocks)
    assert base.splitlines()[2] == HEADER
    out = {}
    for name, header in VARIANTS.items():
        f = directory / f"cam_{blocks}_{name}.mpf"
        if not f.exists():
            lines = base.splitlines()
            lines[2] = header
            f.write_text("\n".join(lines) + "\n")
        out[name] = f
    return out


def wall_time(args: list[str]) -> float:
    t = time.perf_counter()
    subprocess.run(args, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - t


def main(argv=None) -> int:
    from bench_scale import comparison_args

    args, directory = comparison_args(__doc__.splitlines()[0], argv, repeat=1,
                                      repeat_help="alternating runs per variant (best kept)")
    files = programs(directory, args.blocks)
    py = sys.executable
    run = [py, "-m", "ncsim", "run"]
    wall_time(run + [str(files["compcad"]), "--machine", "mikron"])   # numba cache warm-up

    rows = {}
    for name, f in files.items():
        out = subprocess.run([py, "-c", STAGES, str(f)], check=True, capture_output=True, text=True)
        rows[name] = json.loads(out.stdout)
    best = {name: float("inf") for name in files}
    for _ in range(args.repeat):
        for name, f in files.items():                     # alternate: the same load for each
            best[name] = min(best[name], wall_time(run + [str(f), "--machine", "mikron"]))
    for name in files:
        rows[name]["run_wall_s"] = best[name]
    ratio = best["compcad"] / best["plain"]

    print(f"{args.blocks:,} blocks, ncsim run --machine mikron (best of {args.repeat})\n")
    print("| program | cycle time s | feed time held by `cycle_time` | highest feed mm/min | `ncsim run` s |")
    print("|---|---:|---:|---:|---:|")
    for name, r in rows.items():
        print(f"| {name} | {r['cycle_time_s']:,.1f} | {100 * r['cycle_time_share']:.1f} % | "
              f"{r['feed_max_mm_min']:,.0f} | {r['run_wall_s']:.2f} |")
    print(f"\nCOMPCAD / plain `ncsim run` time: {ratio:.2f}")
    if args.json_out:
        Path(args.json_out).write_text(json.dumps(dict(rows=rows, ratio=ratio), indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
