"""Benchmark of control flow: programs that make their motion with loops and R-parameter arithmetic.

Shop programs generate their toolpath in the control: label loops (``IF .. GOTOB``), WHILE, FOR,
REPEAT, trigonometry on R parameters, one short G1 per pass. This times the interpreter alone
(``ncsim.nc.interpret.interpret_text``, no planning) on

* ``loops``: a program of ours (:func:`loop_program`): a helical groove made by label loops, a
  spiral by WHILE, a raster by FOR and a REPEAT/UNTIL zig-zag, ~150,000 motion blocks;
* ``kanavka``: the real shop program ``dubovikov/kanavka_vint_sector.mpf`` from
  ``../shared/data/real/programs-840d`` (label loops, 152,446 motion blocks), when present;

and reports motion blocks (path segments) per second and executed blocks (every block, R
assignments, labels and jumps included) per second, best of ``--repeat`` runs. ``--reference``
also times the reference interpreter (``fast=False``: every line through Lark, every block
evaluated node by node), in the same run, so the ratio does not depend on the machine's load.

    python benchmarks/bench_control_flow.py
    python benchmarks/bench_control_flow.py --repeat 3 --reference
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

SHARED = Path(__file__).resolve().parent.parent.parent / "shared"
KANAVKA = SHARED / "data" / "real" / "programs-840d" / "dubovikov" / "kanavka_vint_sector.mpf"


def loop_program(turns: int = 200, steps: int = 600) -> str:
    """A program whose motion comes from loops: ``turns`` x ``steps`` blocks of a helical groove
    (label loop), then a spiral (WHILE), a raster (FOR) and a zig-zag (REPEAT ... UNTIL)."""
    return f"""; loop-generated motion (ncsim benchmark)
DEF INT _I
N10 G17 G90 G71 G94 G64 SOFT
N20 R1=40 R2=0.5 R3=360/{steps} R4=0 R5=0 R9=0
N30 G0 X=R1 Y0 Z2
N40 G1 Z0 F3000
TURN:
R5=0
STEP:
R5=R5+1 R4=R4+R3
R6=R1*COS(R4) R7=R1*SIN(R4) R8=-R2*R4/360
G1 X=R6 Y=R7 Z=R8
IF R5<{steps} GOTOB STEP
R9=R9+1
IF (R9<{turns}) AND (R1>0) GOTOB TURN
G0 Z5
R10=0
WHILE R10<{steps * 20}
R10=R10+1
R11=5+R10*0.002
G1 X=R11*COS(R10*7) Y=R11*SIN(R10*7) Z=-1
ENDWHILE
FOR _I=1 TO {steps * 20}
G1 X=_I*0.01 Y=TRUNC(_I/100)*0.5 Z=-2
ENDFOR
R12=0
REPEAT
R12=R12+1
G1 X=R12*0.05 Y=(R12 MOD 2)*3 Z=-3
UNTIL R12>={steps * 20}
G0 Z50
M30
"""


def best(fn, repeat: int) -> tuple[float, object]:
    best_s, result = float("inf"), None
    for _ in range(repeat):
        t0 = time.perf_counter()
        result = fn()
        best_s = min(best_s, time.perf_counter() - t0)
    return best_s, result


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=2, help="timed runs per measurement (best shown)")
    ap.add_argument("--reference", action="store_true",
                    help="also time the reference interpreter (fast=False)")
    args = ap.parse_args()

    t0 = time.perf_counter()
    from ncsim.nc.interpret import interpret_text
    interpret_text(loop_program(2, 10), "warmup.mpf")
    print(f"import + warm-up: {time.perf_counter() - t0:.2f} s\n")

    programs = [("loops (ours)", "loops.mpf", loop_program())]
    if KANAVKA.is_file():
        programs.append(("kanavka_vint_sector (real)", str(KANAVKA), KANAVKA.read_text()))
    else:
        print(f"({KANAVKA} not found: the real program is left out)\n")
    modes = [("fast", True)] + ([("reference", False)] if args.reference else [])
    print("| program | interpreter | motion blocks | executed blocks | time s | motion blocks/s | executed blocks/s |")
    print("|---|---|---:|---:|---:|---:|---:|")
    for label, name, text in programs:
        for mode, fast in modes:
            kwargs = {} if fast else {"fast": False}
            t, r = best(lambda: interpret_text(text, name, **kwargs), args.repeat)
            n, blocks = r.path.n, r.blocks_executed
            print(f"| {label} | {mode} | {n:,} | {blocks:,} | {t:.2f} | {n / t:,.0f} | {blocks / t:,.0f} |")


if __name__ == "__main__":
    main()
