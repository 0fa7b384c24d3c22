"""Make the example recording the README's gap diagnosis runs on (``measured/``).

A truth that ncsim's planner did not make, recorded as an 840D servo trace would be:

1. **command**: ``programs/gap_passes.mpf`` planned on the MIKRON machine by the plain
   time-optimal planner of ``ncsim.gap.truth.plain`` (ruckig per block, the 840D junction
   rules written apart from ``ncsim.plan``), with one planted difference from the machine
   file: the X/Y and Z axes accelerate at ``XY_ACCEL_M_S2`` and ``Z_ACCEL_M_S2`` (MD32300)
   instead of the file's 2.5/3.0 and 2.1 m/s^2 (``truth_machine``, the ``axis_accel`` case of
   the withheld-effect benchmark); sampled every ``COMMAND_DT_S``;
2. **actual**: every axis through the RK4 closed-loop simulation of ``ncsim.gap.truth.servo``
   with the velocity feed-forward off (FFWOF) and a position-loop gain ``KV_1_S`` (MD32200),
   a ``VELOCITY_LOOP_S`` speed loop and a stiff ``STRUCTURE_HZ`` structure mode: the actual
   lags the command by about (1 - k_ff) / Kv;
3. **recording** (``ncsim.gap.truth.synth.degrade``): every ``PERIOD_S`` from ``LEAD_S``
   before the cycle start to the end of the first pass (``END_BLOCK``, the recording is
   stopped there, as real ones are), actual positions with white noise of ``NOISE_UM`` and
   rounded to the ``QUANT_UM`` encoder increment, commanded positions to the 840D's 0.1 um;
   program coordinates, a clock that starts at 0 with the recorder.

Seeded: the same file every run (``--check`` compares with the committed one)::

    python benchmarks/make_example_trace.py            # writes measured/gap_passes_scope.csv
    python benchmarks/make_example_trace.py --check    # exit 1 if the committed file differs
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from ncsim.gap.truth.independent import IndependentCase, truth_machine  # noqa: E402
from ncsim.gap.truth.plain import plan_plain, sample_plain  # noqa: E402
from ncsim.gap.truth.servo import ServoParams, simulate_servo  # noqa: E402
from ncsim.gap.truth.synth import ScopeConfig, degrade, quantise  # noqa: E402
from ncsim.machine import load_machine  # noqa: E402
from ncsim.nc.interpret import interpret_file  # noqa: E402
from ncsim.units import m_s2_to_mm_s2  # noqa: E402

PROGRAM = REPO / "programs" / "gap_passes.mpf"
OUT = REPO / "measured" / "gap_passes_scope.csv"
OUT_UM = REPO / "measured" / "gap_passes_scope_um.csv"   # the first UM_SPAN_S, other names and units
UM_SPAN_S = 3.0
SEED = 20261127

XY_ACCEL_M_S2 = 1.2          # planted: X (Y keeps the file's 3.0/2.5 ratio: 1.44)
Z_ACCEL_M_S2 = 0.8           # planted
KV_1_S = 33.3                # MD32200 = 2 (m/min)/mm, FFWOF
VELOCITY_LOOP_S = 1e-3
STRUCTURE_HZ = 120.0
STRUCTURE_DAMPING = 0.2

COMMAND_DT_S = 1e-3
SERVO_DT_S = 5e-5
LEAD_S = 0.3
PERIOD_S = 4e-3
NOISE_UM = 0.5
QUANT_UM = 0.1
CMD_RESOLUTION_UM = 0.1
END_BLOCK = 13               # the recording stops in this block (the G0 to pass 2; None: at the end)
END_SHARE = 0.5              # ... this share of its motion time in


def make_trace():
    nominal = load_machine("mikron")
    case = IndependentCase(index=0, effect="axis_accel",
                           params={"xy_accel_m_s2": XY_ACCEL_M_S2, "z_accel_m_s2": Z_ACCEL_M_S2},
                           condition="scope", seed=SEED, period_s=PERIOD_S,
                           offset_mm=(0.0, 0.0, 0.0), window=(0.0, 1.0), g64=False)
    pm, reset = truth_machine(nominal, case)
    assert abs(pm.a_max_mm_s2[0] - m_s2_to_mm_s2(XY_ACCEL_M_S2)) < 1e-9
    path = interpret_file(str(PROGRAM), nominal.with_ncu(reset_path_mode=reset)).path
    motion = plan_plain(path, pm)
    end_s = (motion.total_s + LEAD_S if END_BLOCK is None
             else float(motion.t_start_s[END_BLOCK] + END_SHARE * motion.duration_s[END_BLOCK]))
    t_cmd = np.arange(-LEAD_S, motion.total_s + LEAD_S + COMMAND_DT_S / 2, COMMAND_DT_S)
    cmd = sample_plain(motion, t_cmd)
    servo = ServoParams(kv_1_s=KV_1_S, ffw_weight=0.0, velocity_loop_time_s=VELOCITY_LOOP_S,
                        structure_freq_hz=STRUCTURE_HZ, structure_damping=STRUCTURE_DAMPING)
    grid = np.arange(t_cmd[0], min(end_s, t_cmd[-1]) + 1e-9, 2.5e-4)
    r = simulate_servo(t_cmd, cmd, servo, dt_s=SERVO_DT_S, output_t_s=grid)
    rec = degrade(r.t_s, r.pos_mm, ScopeConfig(period_s=PERIOD_S, noise_um=NOISE_UM,
                                               quant_um=QUANT_UM, phase_s=0.0,
                                               record_command=True),
                  seed=SEED, cmd_pos_mm=r.cmd_pos_mm, source=str(OUT))
    t = rec.t_s - rec.t_s[0]
    cmd_q = quantise(rec.cmd_pos_mm, CMD_RESOLUTION_UM * 1e-3)
    return t, rec.pos_mm, cmd_q, motion, servo


HEADER = """\
example recording made by benchmarks/make_example_trace.py (seed {seed}); not a real machine.
program programs/gap_passes.mpf on machine mikron, planned by the plain ruckig planner of
ncsim.gap.truth.plain (not ncsim's planner) with the axis accelerations set to X {ax:g}, Y {ay:g},
Z {az:g} m/s^2 (the machine file says 2.5, 3.0, 2.1): the planted planner effect;
actual = command through the RK4 position loop of ncsim.gap.truth.servo, FFWOF, Kv {kv:g} 1/s,
speed loop {tv:g} ms, {fs:g} Hz structure: the planted servo effect (lag about {lag:.1f} ms);
every {period:g} ms, actual with {noise:g} um noise and a {quant:g} um increment, command to 0.1 um.
t_s in s, positions in mm, program coordinates."""


def write(path: Path, t, pos, cmd, motion, servo) -> None:
    header = HEADER.format(seed=SEED, ax=XY_ACCEL_M_S2, ay=XY_ACCEL_M_S2 * 3.0 / 2.5,
                           az=Z_ACCEL_M_S2, kv=KV_1_S, tv=VELOCITY_LOOP_S * 1e3,
                           fs=STRUCTURE_HZ, lag=1e3 / KV_1_S, period=PERIOD_S * 1e3,
                           noise=NOISE_UM, quant=QUANT_UM)
    lines = [f"# {h}" for h in header.splitlines()]
    lines.append("t_s,x_mm,y_mm,z_mm,x_cmd_mm,y_cmd_mm,z_cmd_mm")
    for i in range(len(t)):
        lines.append(f"{t[i]:.3f}," + ",".join(f"{v + 0.0:.4f}" for v in np.round((*pos[i], *cmd[i]), 4)))
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")


HEADER_UM = """\
the first {span:g} s of gap_passes_scope.csv (see its header) with other column names and units:
Time in ms, PosX/PosY/PosZ actual and CmdX/CmdY/CmdZ commanded positions in um."""


def write_um(path: Path, t, pos, cmd) -> None:
    """The first ``UM_SPAN_S`` of the recording as another recorder might export it."""
    lines = [f"# {h}" for h in HEADER_UM.format(span=UM_SPAN_S).splitlines()]
    lines.append("Time,PosX,PosY,PosZ,CmdX,CmdY,CmdZ")
    for i in np.flatnonzero(t <= UM_SPAN_S + 1e-9):
        lines.append(f"{t[i] * 1e3:.0f}," + ",".join(f"{v + 0.0:.1f}" for v in
                                                    np.round(np.r_[pos[i], cmd[i]] * 1e3, 1)))
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default=str(OUT))
    ap.add_argument("--out-um", default=str(OUT_UM))
    ap.add_argument("--check", action="store_true",
                    help="compare with the files at --out and --out-um instead of writing them")
    args = ap.parse_args(argv)
    t, pos, cmd, motion, servo = make_trace()
    made = {Path(args.out): lambda p: write(p, t, pos, cmd, motion, servo),
            Path(args.out_um): lambda p: write_um(p, t, pos, cmd)}
    status = 0
    for out, writer in made.items():
        if args.check:
            tmp = out.with_name(out.name + ".check")
            writer(tmp)
            same = tmp.read_bytes() == out.read_bytes()
            tmp.unlink()
            print(f"{out}: {'same' if same else 'differs from what the script makes'}")
            status |= 0 if same else 1
        else:
            writer(out)
            rows = sum(1 for line in out.open(encoding="utf-8") if not line.startswith("#")) - 1
            print(f"{out}: {rows} samples, {out.stat().st_size / 1e3:.0f} kB")
    return status


if __name__ == "__main__":
    raise SystemExit(main())
