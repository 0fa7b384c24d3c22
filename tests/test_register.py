"""Registering recordings on their program: partial, in machine coordinates, of a program whose
contour repeats, at any rate, filtered like a real recorder -- and refusing what does not fit.

The recordings are made here, independently of ncsim: a closed-form traversal of the program's
lines and arcs at constant speed per block, sampled at 500 Hz, passed through the recorder of
the KIT data (a centred 10-sample moving average, every 10th row: 50 Hz) and shifted by a
planted work offset. Expected values are what was planted: the offset, the blocks and the
fraction of the block at the first and last kept sample, the pass.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.signal import butter, filtfilt

from ncsim.gap.register import block_text, register
from ncsim.machine import load_machine
from ncsim.nc.interpret import interpret_file

RAPID_MM_S = 50.0
FEED_MM_S = 10.0                  # F600
OFFSET_MM = np.array([-250.123456, 120.654321, 380.5])
PASSES = (-2.0, -4.0, -6.0)


def notch_program() -> tuple[str, list]:
    """A 3-pass contour (our own, shaped like the KIT notch) and its moves:
    ``(file line, start, end, centre or None, clockwise, speed)``."""
    lines = ["G17 G90 G94 G710", "G0 X0 Y0 Z10", "G0 X-10 Y40", "F600"]
    moves = [(2, (0, 0, 0), (0, 0, 10), None, False, RAPID_MM_S),
             (3, (0, 0, 10), (-10, 40, 10), None, False, RAPID_MM_S)]
    z_prev = 10.0
    for z in PASSES:
        lines += [f"G0 Z{z:g}", "G1 X20", "G2 X40 Y20 I0 J-20", "G1 Y0", "G1 X-10 Y40"]
        n = len(lines)
        moves += [(n - 4, (-10, 40, z_prev), (-10, 40, z), None, False, RAPID_MM_S),
                  (n - 3, (-10, 40, z), (20, 40, z), None, False, FEED_MM_S),
                  (n - 2, (20, 40, z), (40, 20, z), (20, 20, z), True, FEED_MM_S),
                  (n - 1, (40, 20, z), (40, 0, z), None, False, FEED_MM_S),
                  (n, (40, 0, z), (-10, 40, z), None, False, FEED_MM_S)]
        z_prev = z
    lines.append("M30")
    return "\n".join(lines) + "\n", moves


def move_length(mv) -> float:
    _, a, b, c, cw, _ = mv
    a, b = np.asarray(a, float), np.asarray(b, float)
    if c is None:
        return float(np.linalg.norm(b - a))
    c = np.asarray(c, float)
    r = np.linalg.norm(a - c)
    ang = (math.atan2(*(a - c)[1::-1]) - math.atan2(*(b - c)[1::-1])) % (2 * math.pi)
    return float(r * (ang if cw else 2 * math.pi - ang))


def traverse(moves, dt_s):
    """Positions every ``dt_s`` along the moves at constant speed per move; with each sample's
    move index and fraction of it."""
    lengths = np.array([move_length(m) for m in moves])
    durations = lengths / np.array([m[5] for m in moves])
    t_end = np.concatenate([[0.0], np.cumsum(durations)])
    t = np.arange(0.0, t_end[-1], dt_s)
    k = np.clip(np.searchsorted(t_end, t, side="right") - 1, 0, len(moves) - 1)
    frac = (t - t_end[k]) / durations[k]
    pos = np.empty((len(t), 3))
    for i, (_, a, b, c, cw, _) in enumerate(moves):
        sel = k == i
        a, b = np.asarray(a, float), np.asarray(b, float)
        if c is None:
            pos[sel] = a + frac[sel, None] * (b - a)
        else:
            c = np.asarray(c, float)
            r = np.linalg.norm(a - c)
            a0 = math.atan2(a[1] - c[1], a[0] - c[0])
            ang = a0 - frac[sel] * lengths[i] / r if cw else a0 + frac[sel] * lengths[i] / r
            pos[sel] = np.column_stack([c[0] + r * np.cos(ang), c[1] + r * np.sin(ang),
                                        np.full(sel.sum(), a[2])])
    return t, pos, k, frac


def kit_recorder(t, pos):
    """500 Hz -> a centred 10-sample moving average, every 10th row (the KIT converter)."""
    kernel = np.ones(10) / 10.0
    smooth = np.column_stack([np.convolve(pos[:, a], kernel, mode="valid") for a in range(3)])
    t_mid = np.convolve(t, kernel, mode="valid")
    return t_mid[::10], smooth[::10]


@pytest.fixture(scope="module")
def notch(tmp_path_factory):
    text, moves = notch_program()
    prog = tmp_path_factory.mktemp("reg") / "notch3.mpf"
    prog.write_text(text)
    path = interpret_file(prog, load_machine("mikron")).path
    t, pos, k, frac = traverse(moves, 2e-3)
    t50, q50 = kit_recorder(t, pos)
    # which move and fraction each 50 Hz row stands for: its window's centre
    k50 = np.clip(np.searchsorted(t, t50) - 1, 0, len(t) - 1)
    return dict(path=path, moves=moves, prog=prog, t=t50, q=q50 + OFFSET_MM,
                move=k[k50], frac=frac[k50], raw_t=t, raw_q=pos + OFFSET_MM)


def rows_of(notch, line, frac_from, line_to, frac_to):
    lines = np.array([notch["moves"][m][0] for m in notch["move"]])
    order = np.arange(len(lines))
    first = order[(lines == line) & (notch["frac"] >= frac_from)][0]
    last = order[(lines == line_to) & (notch["frac"] <= frac_to)][-1]
    return slice(first, last + 1)


def test_partial_recording_names_blocks_pass_and_offset(notch):
    """Part of pass 1 from 40 % of its plunge (G0 Z-2, 12 mm) to 60 % of its closing diagonal."""
    sel = rows_of(notch, 5, 0.4, 9, 0.6)
    r = register(notch["q"][sel], notch["path"], signal="command")
    assert r.status == "ok", r.message
    assert np.max(np.abs(r.offset_mm - OFFSET_MM)) < 1e-3           # 1 um
    assert r.residual_rms_mm < 5e-3
    assert (r.first.line, r.last.line) == (5, 9)
    assert r.first.fraction == pytest.approx(notch["frac"][sel][0], abs=0.02)
    assert r.last.fraction == pytest.approx(notch["frac"][sel][-1], abs=0.02)
    assert (r.pass_index, r.n_passes) == (1, 3)
    assert r.first.text == "G0 Z-2" and block_text(str(notch["prog"]), 7) == "G2 X40 Y20 I0 J-20"
    assert "notch3.mpf:5 (G0 Z-2) at 4" in r.covered() and "pass 1 of 3" in r.covered()
    # every sample's place: non-decreasing, on the blocks of lines 5..9
    assert np.all(np.diff(r.s_mm) >= -1e-9)
    assert set(notch["path"].line[r.segment]) == {5, 6, 7, 8, 9}


def test_a_recording_of_several_passes_names_them_all(notch):
    """From pass 1's contour to pass 3's: not 'pass 2 of 3' (its middle sample's pass)."""
    sel = rows_of(notch, 6, 0.1, 13 + 5, 0.9)       # line 6: G1 X20 of pass 1; 18: pass 3's
    r = register(notch["q"][sel], notch["path"], signal="command")
    assert r.status == "ok", r.message
    assert r.passes_spanned == (1, 3) and r.covered().endswith("passes 1 to 3 of 3")
    one = register(notch["q"][rows_of(notch, 5, 0.4, 9, 0.9)], notch["path"], signal="command")
    assert one.passes_spanned is None and one.covered().endswith("pass 1 of 3")


@pytest.mark.parametrize("rate_hz", [10.0, 200.0])
def test_any_rate(notch, rate_hz):
    sel = rows_of(notch, 5, 0.4, 9, 0.6)
    t, q = notch["t"][sel], notch["q"][sel]
    tn = np.arange(t[0], t[-1], 1.0 / rate_hz)
    qn = np.column_stack([np.interp(tn, t, q[:, a]) for a in range(3)])
    r = register(qn, notch["path"], signal="command")
    assert r.status == "ok" and np.max(np.abs(r.offset_mm - OFFSET_MM)) < 1e-3
    assert (r.first.line, r.last.line, r.pass_index) == (5, 9, 1)


def test_heavier_filter_and_noise(notch):
    """A 5 Hz Butterworth on top of the recorder, and 3 um of white noise on the actual
    positions: the corners are cut by ~0.1 mm, the offset still comes out within 2 um."""
    sel = rows_of(notch, 5, 0.4, 9, 0.6)
    b, a = butter(2, 5.0, fs=50.0)
    q = filtfilt(b, a, notch["q"][sel], axis=0)
    q = q + np.random.default_rng(1).normal(0.0, 3e-3, q.shape)
    r = register(q, notch["path"], signal="actual")
    assert r.status == "ok", r.message
    assert np.max(np.abs(r.offset_mm - OFFSET_MM)) < 2e-3
    assert (r.first.line, r.last.line, r.pass_index) == (5, 9, 1)


def test_a_pass_the_geometry_cannot_tell_is_ambiguous(notch):
    """From the end of pass 1's diagonal through pass 2's whole plunge (2 mm, like pass 3's)
    into its contour: passes 2 and 3 fit equally (pass 1's plunge comes after a rapid from
    elsewhere); a given work offset decides."""
    sel = rows_of(notch, 9, 0.9, 11, 0.5)
    r = register(notch["q"][sel], notch["path"], signal="command")
    assert r.status == "ambiguous"
    assert "passes 2 and 3" in r.message and "--work-offset" in r.message
    r = register(notch["q"][sel], notch["path"], signal="command", offset_mm=OFFSET_MM)
    assert r.status == "ok" and (r.first.line, r.last.line, r.pass_index) == (9, 11, 2)
    # starting after the plunge, the three passes are identical
    sel = rows_of(notch, 11, 0.1, 13, 0.5)
    r = register(notch["q"][sel], notch["path"], signal="command")
    assert r.status == "ambiguous" and "passes 1, 2 and 3" in r.message


def test_a_wrong_given_offset_is_refused(notch):
    sel = rows_of(notch, 5, 0.4, 9, 0.6)
    r = register(notch["q"][sel], notch["path"], signal="command",
                 offset_mm=OFFSET_MM + [0.0, 0.0, -2.0])
    assert r.status == "refused"
    assert "given work offset" in r.message and "--work-offset" in r.message
    assert "(they do at (-250.1234" in r.message                  # where it does fit


def test_wrong_unit_axes_or_program_are_refused_with_what_to_check(notch):
    sel = rows_of(notch, 5, 0.4, 9, 0.6)
    q = notch["q"][sel]
    r = register(q * 1000.0, notch["path"], signal="command")           # um read as mm
    assert r.status == "refused" and "--unit pos=um" in r.message and "\n" not in r.message
    r = register(q / 1000.0, notch["path"], signal="command", length_unit="um")   # mm read as um
    assert r.status == "refused" and "--unit pos=mm" in r.message
    r = register(q[:, [1, 0, 2]], notch["path"], signal="command")
    assert r.status == "refused" and "--column" in r.message
    square = np.array([[0, 0, 0], [50, 0, 0], [50, 50, 0], [0, 50, 0], [0, 0, 0]], float)
    other = np.vstack([np.linspace(square[i], square[i + 1], 250) for i in range(4)]) + 100.0
    r = register(other, notch["path"], signal="command")
    assert r.status == "refused"
    for words in ("do not follow the program", "--unit", "--column", "--work-offset"):
        assert words in r.message


def test_a_recording_at_rest_at_the_start_is_pinned_there(notch):
    """Starting at rest at the program's start point (before its first move): the offset is
    that of the rest position, even when the moving samples carry a contour error."""
    q = notch["raw_q"]
    lead = np.repeat(q[:1], 50, axis=0)
    moving = q[: len(q) // 4].copy()
    moving[:, 0] += 0.02                      # a 20 um error of every moving sample along X
    r = register(np.vstack([lead, moving]), notch["path"], signal="actual")
    assert r.status == "ok" and r.offset_source.startswith("fitted, at rest")
    assert np.max(np.abs(r.offset_mm - OFFSET_MM)) < 1e-6


def test_ncsim_gap_refuses_to_guess_the_pass(notch, tmp_path):
    """Through the command: the ambiguous recording exits 2 with one line; with the work offset
    of the setup it is diagnosed on pass 2."""
    from click.testing import CliRunner

    from ncsim.cli.main import cli
    from ncsim.gap.measured import MeasuredTrace, write_measured_csv
    sel = rows_of(notch, 9, 0.9, 11, 0.5)
    csv = tmp_path / "pass2.csv"
    write_measured_csv(MeasuredTrace(t_s=notch["t"][sel], pos_mm=notch["q"][sel]), csv)
    args = ["gap", str(notch["prog"]), "--machine", "mikron", "--measured", str(csv), "--effects", "transition",
            "--no-combine"]
    r = CliRunner().invoke(cli, args)
    assert r.exit_code == 2 and r.output.count("\n") == 1
    assert "ambiguous: passes 2 and 3" in r.output
    offset = ",".join(f"{v:.6f}" for v in OFFSET_MM)
    r = CliRunner().invoke(cli, args + ["--work-offset", f"G54={offset}"])
    assert r.exit_code == 0, r.output
    assert "notch3.mpf:9 (G1 X-10 Y40) at 90 % to notch3.mpf:11 (G1 X20) at 50 %, passes 1 to 2 of 3" \
        in r.output
