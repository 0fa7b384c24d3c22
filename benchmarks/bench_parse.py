"""Benchmark of the NC front end: parse only, and parse + interpret, in blocks per second.

Generates programs of plain blocks ``N.. G1 X.. Y.. Z.. F..`` (every word in every block; with
``--arc-every K`` every K-th block is a G2/G3 half circle with I J instead), then times
``ncsim.nc.parse.parse_text`` and ``ncsim.nc.interpret.interpret_text`` on them. One untimed warm-up
run first loads the grammar and the numba scanner (compiled once, then cached on disk).

    python benchmarks/bench_parse.py                      # 200k and 1M blocks
    python benchmarks/bench_parse.py --blocks 200000 --repeat 3 --arc-every 10
"""
from __future__ import annotations

import argparse
import time

import numpy as np


def plain_program(n_blocks: int, arc_every: int = 0, seed: int = 1) -> str:
    """A program of ``n_blocks`` plain blocks; every ``arc_every``-th one a half circle."""
    rng = np.random.default_rng(seed)
    x = np.cumsum(rng.uniform(0.05, 0.5, n_blocks))
    z = np.round(np.sin(x / 17.0) * 4.0, 3)
    feed = rng.integers(2000, 12000, n_blocks)
    lines = ["G17 G90 G71 G94 G64 SOFT FFWON"]
    y = 0.0
    for k in range(n_blocks):
        n = 10 * (k + 1)
        if arc_every and k % arc_every == arc_every - 1:
            word = "G3" if (k // arc_every) % 2 == 0 else "G2"
            lines.append(f"N{n} {word} X{x[k - 1]:.3f} Y{y + 1.0:.3f} Z{z[k - 1]:.3f} I0 J0.5 F{feed[k]}")
            y += 1.0
            x[k] = x[k - 1]
        else:
            lines.append(f"N{n} G1 X{x[k]:.3f} Y{y:.3f} Z{z[k]:.3f} F{feed[k]}")
    lines.append("M30")
    return "\n".join(lines) + "\n"


def best_time_s(fn, repeat: int) -> float:
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--blocks", type=int, nargs="+", default=[200_000, 1_000_000])
    ap.add_argument("--repeat", type=int, default=3, help="timed runs per measurement (best is shown)")
    ap.add_argument("--arc-every", type=int, default=0, help="every K-th block a G2/G3 (0: none)")
    args = ap.parse_args()

    t0 = time.perf_counter()
    from ncsim import jit
    from ncsim.nc.interpret import interpret_text
    from ncsim.nc.parse import parse_text
    with jit.forced("compiled"):  # a small program alone would run the plain-Python scanner
        interpret_text(plain_program(100, args.arc_every), "warmup.mpf")
    print(f"import + grammar + scanner warm-up: {time.perf_counter() - t0:.2f} s")

    for n in args.blocks:
        text = plain_program(n, args.arc_every)
        n_lines = text.count("\n")
        t_parse = best_time_s(lambda: parse_text(text, "bench.mpf"), args.repeat)
        t_all = best_time_s(lambda: interpret_text(text, "bench.mpf"), args.repeat)
        segments = len(interpret_text(text, "bench.mpf").path)
        print(f"{n:>9} blocks ({n_lines} lines, {segments} segments): "
              f"parse {t_parse:6.3f} s = {n_lines / t_parse:>10,.0f} blocks/s | "
              f"parse+interpret {t_all:6.3f} s = {n_lines / t_all:>10,.0f} blocks/s")


if __name__ == "__main__":
    main()
