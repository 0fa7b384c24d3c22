"""Benchmark: `ncsim gap`, wall clock of the whole command.

    python benchmarks/bench_gap_speed.py [--repeat 2] [--rows 1000000] [--out FILE.md]
    python benchmarks/bench_gap_speed.py --rows 0 --repeat 2      # the KIT Notch alone

First the real KIT DMC 60H "Notch" recording as recorded (1,646 rows at 50 Hz, commanded and
actual positions) against its program on ``machines/dmc60h.toml``, every candidate effect:
the command of issue 18 (target: 20 s warm on this project's 2-core machine). It runs once
to warm numba's cache, then ``--repeat`` times; the least wall time is reported.

Then, unless ``--rows 0``, two traces of ``--rows`` rows, both written to a temporary folder
and diagnosed by the installed ``ncsim`` command (a fresh process: start-up, reading,
registration, every fit and the report included):

* ``bore``: the fuzzing reproducer H2 (``../shared/data/fuzz-repro``: ``G2_make_huge_trace.py``
  resamples ``G0_bore_trace_ok.csv`` to ``--rows`` rows; the same recipe here) diagnosed
  against ``bore.mpf`` with every candidate effect;
* ``kit``: the real KIT DMC 60H recording (``../shared/data/real/kit-dmc60h-notch-sinumerik``,
  commanded and actual positions, machine coordinates) interpolated to ``--rows`` rows, against
  its 3-pass program: registration, the planner part on the command and the servo part.

It also times the stages in-process (read, interpret, register, each fit) through the gap
pipeline's progress callback. Results go to stdout and, with ``--out``, to a Markdown file.
Wall times depend on the machine; the README quotes one run on this project's 2-core machine.
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
SHARED = REPO.parent / "shared" / "data"
FUZZ = SHARED / "fuzz-repro"
KIT = SHARED / "real" / "kit-dmc60h-notch-sinumerik"


def make_bore(rows: int, folder: Path) -> Path:
    """``G2_make_huge_trace.py``'s recipe: the bore trace linearly resampled to ``rows``."""
    a = np.loadtxt(FUZZ / "G0_bore_trace_ok.csv", delimiter=",", skiprows=1, usecols=(0, 2, 3, 4))
    t = np.linspace(0, a[-1, 0], rows)
    out = folder / f"huge_{rows}.csv"
    np.savetxt(out, np.column_stack([t] + [np.interp(t, a[:, 0], a[:, k]) for k in (1, 2, 3)]),
               fmt="%.7f", delimiter=",", header="t_s,x_mm,y_mm,z_mm", comments="")
    return out


def make_kit(rows: int, folder: Path) -> Path:
    """The KIT recording's time, actual and commanded positions interpolated to ``rows``."""
    names = ("time", "pos_x", "pos_y", "pos_z", "cmd_pos_x", "cmd_pos_y", "cmd_pos_z")
    src = KIT / "DMC60H_AL2007T4_Notch_Normal_1.csv"
    header = src.read_text().splitlines()[0].split(",")
    a = np.loadtxt(src, delimiter=",", skiprows=1, usecols=[header.index(n) for n in names])
    t = np.linspace(a[0, 0], a[-1, 0], rows)
    out = folder / f"kit_{rows}.csv"
    np.savetxt(out, np.column_stack([t] + [np.interp(t, a[:, 0], a[:, k]) for k in range(1, 7)]),
               fmt="%.7f", delimiter=",", header=",".join(names), comments="")
    return out


def wall(cmd: list[str]) -> tuple[float, str]:
    t0 = time.perf_counter()
    r = subprocess.run(cmd, capture_output=True, text=True)
    dt = time.perf_counter() - t0
    if r.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} exited {r.returncode}: {r.stderr.strip()}")
    return dt, r.stdout


def stages(program: Path, trace: Path, machine: str) -> list[tuple[str, float]]:
    from ncsim.gap.pipeline import diagnose
    out: list[tuple[str, float]] = []
    last = [time.perf_counter(), "start-up"]

    def cb(name, index, total):
        now = time.perf_counter()
        out.append((last[1], now - last[0]))
        last[:] = [now, name]

    diagnose([program], trace, machine, progress=cb)
    out.append((last[1], time.perf_counter() - last[0]))
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rows", type=int, default=1_000_000,
                    help="rows of the resampled traces (0: the KIT Notch as recorded alone)")
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--out", default=None, help="also write the results as Markdown here")
    args = ap.parse_args(argv)
    ncsim = [sys.executable, "-m", "ncsim"]
    notch = [*ncsim, "gap", str(KIT / "AL_2007_T4_Notch_Normal.mpf"), "--measured",
             str(KIT / "DMC60H_AL2007T4_Notch_Normal_1.csv"), "--machine",
             str(REPO / "machines" / "dmc60h.toml")]
    wall(notch)                                   # numba's cache warm
    times = [wall(notch)[0] for _ in range(max(args.repeat, 1))]
    head = ["## `ncsim gap` on the KIT Notch recording", "",
            "`ncsim gap ../shared/data/real/kit-dmc60h-notch-sinumerik/AL_2007_T4_Notch_Normal.mpf "
            "--measured ../shared/data/real/kit-dmc60h-notch-sinumerik/"
            "DMC60H_AL2007T4_Notch_Normal_1.csv --machine machines/dmc60h.toml` (1,646 rows, "
            f"every candidate), warm numba cache, {os.cpu_count()} CPUs shared with other jobs: "
            f"**{min(times):.1f} s** wall, least of {len(times)} "
            f"({', '.join(f'{t:.1f}' for t in times)} s); target 20 s.", ""]
    print("\n".join(head), flush=True)
    if args.rows <= 0:
        if args.out:
            Path(args.out).write_text("\n".join(head))
            print(f"wrote {args.out}")
        return 0
    lines = head + [f"## `ncsim gap` on {args.rows:,}-row traces", "",
             f"`python benchmarks/bench_gap_speed.py --rows {args.rows}` "
             f"({os.cpu_count()} CPUs), best of {args.repeat}:", "",
             "| trace | rows | file MB | `ncsim gap` wall s | stages (in-process) s |",
             "|---|---:|---:|---:|---|"]
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        cases = [("bore (fuzz H2)", FUZZ / "bore.mpf", make_bore(args.rows, folder), "mikron"),
                 ("KIT DMC 60H, command + actual", KIT / "AL_2007_T4_Notch_Normal.mpf",
                  make_kit(args.rows, folder), str(REPO / "machines" / "dmc60h.toml"))]
        for name, program, trace, machine in cases:
            best = min(wall([*ncsim, "gap", str(program), "--measured", str(trace),
                             "--machine", machine])[0] for _ in range(args.repeat))
            parts = stages(program, trace, machine)
            detail = ", ".join(f"{n} {s:.2f}" for n, s in parts if s >= 0.05)
            size = trace.stat().st_size / 1e6
            lines.append(f"| {name} | {args.rows:,} | {size:.0f} | {best:.1f} | {detail} |")
            print(lines[-1], flush=True)
    text = "\n".join(lines) + "\n"
    if args.out:
        Path(args.out).write_text(text)
        print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
