"""Benchmark: sample a motion into a 1M-sample trace, write it as CSV, read it back.

    python benchmarks/bench_trace_io.py [--samples 1000000] [--repeat 3] [--all-columns]

Prints the best of ``--repeat`` runs: sampling time, CSV samples/s (default columns and,
with ``--all-columns``, every column), file size and read time. The motion is a hand-built
feed law (one jerk-limited rest-to-rest profile) over 20,000 blocks alternating 1 mm lines and
quarter helices of 1 mm radius, so it does not depend on the planner.
"""
from __future__ import annotations

import argparse
import math
import os
import tempfile
import time

import numpy as np

from ncsim.report.csvio import ALL_COLUMNS, read_trace_csv, write_trace_csv
from ncsim.machine import load_machine
from ncsim.motion import FULL_MODEL, Limit, Motion, Phase
from ncsim.path import ARC, LINE, PathBuilder
from ncsim.plan.sample import sample_motion


def bench_path(n_blocks: int = 20_000):
    kind = np.where(np.arange(n_blocks) % 2, ARC, LINE).astype(np.int8)
    start = np.zeros((n_blocks, 3))
    end = np.zeros((n_blocks, 3))
    center = np.full((n_blocks, 3), np.nan)
    normal = np.zeros((n_blocks, 3))
    radius = np.full(n_blocks, np.nan)
    sweep = np.zeros(n_blocks)
    helix = np.zeros(n_blocks)
    length = np.zeros(n_blocks)
    pos = np.zeros(3)
    for i in range(n_blocks):
        start[i] = pos
        if kind[i] == LINE:
            end[i] = pos + [1.0, 0.0, 0.0]
            length[i] = 1.0
        else:  # quarter helix, counter-clockwise about +Z, rising 0.01 mm
            c = pos + [0.0, 1.0, 0.0]
            center[i], normal[i], radius[i] = c, [0, 0, 1], 1.0
            sweep[i], helix[i] = math.pi / 2, 0.01
            end[i] = c + [1.0, 0.0, 0.01]
            length[i] = math.hypot(math.pi / 2, 0.01)
        pos = end[i]
    b = PathBuilder()
    b.extend(kind=kind, start_mm=start, end_mm=end, center_mm=center, normal=normal,
             radius_mm=radius, sweep_rad=sweep, helix_mm=helix, length_mm=length,
             line=np.arange(n_blocks), feed_mm_s=100.0)
    return b.build()


def bench_motion(machine, path, v=100.0, a=1000.0, j=5000.0) -> Motion:
    """Rest-to-rest jerk-limited feed law over the whole path (closed form, 7 pieces)."""
    L = path.total_length_mm
    t1 = math.sqrt(v / j) if v * j <= a * a else a / j
    t2 = 0.0 if v * j <= a * a else v / a - a / j
    t4 = (L - v * (2 * t1 + t2)) / v
    dur = [t1, t2, t1, t4, t1, t2, t1]
    jerk = [j, 0, -j, 0, -j, 0, j]
    t, s, vv, aa = [0.0], [], [], []
    s0 = v0 = a0 = 0.0
    for d, jj in zip(dur, jerk):
        s.append(s0), vv.append(v0), aa.append(a0)
        s0, v0, a0 = s0 + v0 * d + a0 * d * d / 2 + jj * d ** 3 / 6, v0 + a0 * d + jj * d * d / 2, a0 + jj * d
        t.append(t[-1] + d)
    n = path.n
    T = t[-1]
    tj = np.linspace(0, T, n + 1)  # block times are not used by sampling
    return Motion(
        path=path, machine=machine, options=FULL_MODEL, cap_mm_s=np.full(n, v),
        cap_limit=np.full(n, Limit.PROGRAMMED, np.int8), jerk_mm_s3=np.full(n, j),
        accel_mm_s2=np.full(n, a), t_start_s=tj[:-1], t_end_s=tj[1:], feed_max_mm_s=np.full(n, v),
        junction_cap_mm_s=np.zeros(n + 1), junction_limit=np.zeros(n + 1, np.int8),
        junction_dwell_s=np.zeros(n + 1), v_junction_mm_s=np.zeros(n + 1),
        a_junction_mm_s2=np.zeros(n + 1), knot=np.ones(n + 1, bool), piece_t_s=np.array(t),
        piece_s_mm=np.array(s), piece_v_mm_s=np.array(vv), piece_a_mm_s2=np.array(aa),
        piece_j_mm_s3=np.array(jerk, float),
        piece_phase=np.array([Phase.A] * 3 + [Phase.B] + [Phase.C] * 3, np.int8),
        piece_limit=np.array([Limit.PROGRAM_END] * 3 + [Limit.PROGRAMMED] + [Limit.PROGRAM_END] * 3, np.int8))


def best_of(repeat, fn):
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=1_000_000)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--all-columns", action="store_true")
    args = ap.parse_args()

    motion = bench_motion(load_machine("mikron"), bench_path())
    dt = motion.total_time_s / (args.samples - 1)
    trace = sample_motion(motion, dt)
    n = len(trace)
    t_sample = best_of(args.repeat, lambda: sample_motion(motion, dt))
    print(f"sample_motion: {n} samples in {t_sample:.3f} s ({n / t_sample / 1e6:.2f} M samples/s)")

    with tempfile.TemporaryDirectory() as tmp:
        file = os.path.join(tmp, "trace.csv")
        for label, cols in (("default columns", None), ("all columns", ALL_COLUMNS)):
            if cols is not None and not args.all_columns:
                continue

            def write():
                if os.path.exists(file):
                    os.remove(file)  # truncating a big file costs the OS time: start afresh
                write_trace_csv(trace, file, columns=cols)

            t_write = best_of(args.repeat, write)
            size = os.path.getsize(file)
            t_read = best_of(1, lambda: read_trace_csv(file))
            print(f"write_trace_csv ({label}): {n / t_write / 1e6:.2f} M samples/s "
                  f"({t_write:.3f} s, {size / 1e6:.0f} MB); read_trace_csv: {t_read:.2f} s")


if __name__ == "__main__":
    main()
