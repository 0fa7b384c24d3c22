"""Arcs against lines: ``ncsim run`` on 1M-block programs of half circles, of CAM-like fitted
arcs, and of the same fitted curve as straight chords, measured in one run.

    python benchmarks/bench_arcs.py                    # 1M blocks each, best of 3
    python benchmarks/bench_arcs.py --blocks 100000 --repeat 2 --json out.json

Programs (deterministic, cached under ``--dir``; XY plane, G64 SOFT FFWON, F6000):

* ``lines``: the fitted curve below as G1 chords (same block count, same path);
* ``half_circles``: a serpentine of G2/G3 half circles, radius 1-5 mm, tangent joins with a
  curvature reversal at every junction (the paper's spiral tests, a million times);
* ``fitted_arcs``: what CAM arc fitting emits: short tangent arcs of 1-10 deg, radius
  5-200 mm varying from block to block, turning left or right (G3/G2).

Each program runs in a fresh process (wall time from process start to exit, peak RSS, CPU
time); the runs are interleaved and repeated and the best of each kept, so the ratios
arcs / lines come from the same conditions. The machine is shared: read the ratios, not the
absolute times. Set points come from the code under test (this is a speed benchmark).
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

HEADER = ["N10 G17 G90 G71 G94 G64 SOFT FFWON", "N20 G0 X0 Y0 Z5", "N30 G1 Z0 F6000"]


def _numbered(body: list[str] | np.ndarray) -> str:
    body = np.asarray(body)
    numbers = np.char.add("N", np.char.mod("%d", np.arange(40, 40 + 10 * len(body), 10)))
    lines = HEADER + np.char.add(np.char.add(numbers, " "), body).tolist()
    lines.append(f"N{40 + 10 * len(body)} M30")
    return "\n".join(lines) + "\n"


def _fmt(x: np.ndarray) -> np.ndarray:
    return np.char.mod("%.4f", x)


def fitted_curve(n: int, seed: int = 2):
    """Start points, end points and centre offsets of n tangent arcs (1-10 deg, R 5-200 mm)."""
    rng = np.random.default_rng(seed)
    sweep = np.radians(rng.uniform(1.0, 10.0, n))
    radius = rng.uniform(5.0, 200.0, n)
    turn = np.where(rng.random(n) < 0.1, -1.0, 1.0).cumprod()       # switch side now and then
    heading = np.concatenate([[0.0], np.cumsum(turn * sweep)])[:-1]  # tangent at each start
    chord = 2.0 * radius * np.sin(sweep / 2.0)
    mid = heading + turn * sweep / 2.0
    step = np.stack([chord * np.cos(mid), chord * np.sin(mid)], axis=1)
    ends = np.cumsum(step, axis=0)
    starts = np.vstack([[0.0, 0.0], ends[:-1]])
    centre = np.stack([-np.sin(heading), np.cos(heading)], axis=1) * (turn * radius)[:, None]
    return starts, ends, centre, turn


def fitted_arcs_program(n: int) -> str:
    _, ends, centre, turn = fitted_curve(n)
    word = np.where(turn > 0, "G3 X", "G2 X")
    body = np.char.add(np.char.add(np.char.add(np.char.add(np.char.add(np.char.add(np.char.add(
        word, _fmt(ends[:, 0])), " Y"), _fmt(ends[:, 1])), " I"), _fmt(centre[:, 0])), " J"),
        _fmt(centre[:, 1]))
    return _numbered(body)


def lines_program(n: int) -> str:
    _, ends, _, _ = fitted_curve(n)
    body = np.char.add(np.char.add(np.char.add("G1 X", _fmt(ends[:, 0])), " Y"), _fmt(ends[:, 1]))
    return _numbered(body)


def half_circles_program(n: int, seed: int = 3) -> str:
    """Serpentine along +X: upper half circles clockwise (G2), lower ones counter-clockwise
    (G3), each leaving where the previous one ended, tangent (vertical) at every junction."""
    rng = np.random.default_rng(seed)
    radius = np.round(rng.uniform(1.0, 5.0, n), 3)
    x_end = np.cumsum(2.0 * radius)
    word = np.where(np.arange(n) % 2 == 0, "G2 X", "G3 X")
    body = np.char.add(np.char.add(np.char.add(np.char.add(word, _fmt(x_end)), " Y0 I"),
                                   _fmt(radius)), " J0")
    return _numbered(body)


PROGRAMS = {"lines": lines_program, "half_circles": half_circles_program,
            "fitted_arcs": fitted_arcs_program}

STAGES = r"""
import json, sys, time
from ncsim.machine import load_machine
from ncsim.nc.interpret import interpret_file
from ncsim.plan.limits import path_limits
from ncsim.plan.lookahead import plan
from ncsim.pipeline import simulate
m = load_machine("mikron")
from ncsim import jit
with jit.forced("compiled"):  # numba's start-up paid here, not by the first stage timed
    simulate("warm.mpf", m, text="G17 G90 G64 SOFT\nG1 X1 F1000\nG1 X2 Y1\nG2 X3 Y2 I1 J0\n" * 10)
t = time.perf_counter(); r = interpret_file(sys.argv[1], m); interpret_s = time.perf_counter() - t
t = time.perf_counter(); lim = path_limits(r.path, m); limits_s = time.perf_counter() - t
t = time.perf_counter(); mo = plan(r.path, m, limits=lim); plan_s = time.perf_counter() - t
print(json.dumps(dict(interpret_s=interpret_s, limits_s=limits_s, plan_s=plan_s,
                      blocks=r.path.n, arcs=int((r.path.kind == 1).sum()),
                      cycle_time_s=mo.total_time_s)))
"""


def program_file(directory: Path, name: str, n: int) -> Path:
    f = directory / f"{name}_{n}.mpf"
    if not f.exists():
        f.write_text(PROGRAMS[name](n))
    return f


def main(argv=None) -> int:
    from bench_scale import LAST_CPU_S, comparison_args, measure

    args, directory = comparison_args(__doc__.splitlines()[0], argv, repeat=3,
                                      repeat_help="interleaved runs per program")
    py = sys.executable
    files = {name: program_file(directory, name, args.blocks) for name in PROGRAMS}
    measure([py, "-m", "ncsim", "run", str(files["lines"]), "--machine", "mikron"])  # warm-up

    best: dict[str, dict] = {}
    for _ in range(args.repeat):
        for name, f in files.items():
            wall, rss, _ = measure([py, "-m", "ncsim", "run", str(f), "--machine", "mikron"])
            cpu = LAST_CPU_S[0]
            _, _, out = measure([py, "-c", STAGES, str(f)])
            row = dict(json.loads(out), run_wall_s=wall, run_peak_rss_mb=rss, run_cpu_s=cpu)
            if name not in best or row["run_wall_s"] < best[name]["run_wall_s"]:
                best[name] = row
            print(f"  {name:>12}: ncsim run {wall:.2f} s (CPU {cpu:.2f} s), {rss:.0f} MB | interpret "
                  f"{row['interpret_s']:.2f} s, limits {row['limits_s']:.2f} s, plan "
                  f"{row['plan_s']:.2f} s", flush=True)

    lines = best["lines"]
    print(f"\n| program ({args.blocks:,} blocks) | `ncsim run` s | / lines | CPU s | / lines "
          f"| limits s | / lines | plan s | peak RSS MB |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for name, r in best.items():
        print(f"| {name} ({r['arcs']:,} arcs) | {r['run_wall_s']:.2f} | "
              f"{r['run_wall_s'] / lines['run_wall_s']:.2f} | {r['run_cpu_s']:.2f} | "
              f"{r['run_cpu_s'] / lines['run_cpu_s']:.2f} | {r['limits_s']:.2f} | "
              f"{r['limits_s'] / lines['limits_s']:.2f} | {r['plan_s']:.2f} | "
              f"{r['run_peak_rss_mb']:.0f} |")
    if args.json_out:
        Path(args.json_out).write_text(json.dumps(best, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
