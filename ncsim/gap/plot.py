"""Figures of a gap diagnosis (``ncsim gap --plot PREFIX``), matplotlib imported lazily.

* trace: the path feed against time (measured, base model, corrected model, each model on the
  measured clock through its own alignment), the contour deviation of the measured samples from
  the base and from the corrected model path, and the time error along the path;
* summary: published values against the base and the corrected model, per entry (feeds, and
  the ISO 230-4 radial indexes);
* servo part: commanded, actual and modelled actual signal of the axis that moves most.
"""
from __future__ import annotations

from pathlib import Path as FsPath

import numpy as np

from ncsim.errors import UsageError
from ncsim.units import mm_to_um, s_to_ms


def _plt():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def _save(fig, prefix: str, suffix: str, fmt: str) -> str:
    if fmt not in ("png", "svg"):
        raise UsageError(f"plot format must be png or svg, got {fmt!r}")
    out = f"{prefix}-{suffix}.{fmt}"
    try:
        FsPath(out).parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(out, dpi=120)
    except OSError as exc:
        raise UsageError(f"cannot write plot {out}: {exc.strerror}") from None
    finally:
        _plt().close(fig)
    return out


def plot_trace(d, evaluator, prefix: str, fmt: str = "png") -> list[str]:
    """Feed, contour deviation and time error: measured against base and corrected models."""
    plt = _plt()
    from ncsim.gap.diagnose import compare_speed_mm_s
    final = d.corrected_model
    _, al_b, mt_b = evaluator.evaluate(d.base_model, full=True)
    _, al_c, mt_c = evaluator.evaluate(final, full=True)
    scales = evaluator.scales
    meas = evaluator.measured
    fig, ax = plt.subplots(3, 1, figsize=(11, 9), sharex=True)
    ax[0].plot(meas.t_s, evaluator.measured_speed, ".", ms=2, color="k", label="measured")
    ax[0].plot(mt_b.t_s + al_b.time_shift_s, compare_speed_mm_s(mt_b, scales), lw=1, color="tab:red",
               label=f"base model ({d.base})")
    label = d.combined.effect if d.combined is not None else d.best.effect
    ax[0].plot(mt_c.t_s + al_c.time_shift_s, compare_speed_mm_s(mt_c, scales), lw=1, color="tab:blue",
               label=f"corrected ({label})")
    ax[0].set_ylabel("path feed (mm/s)")
    ax[0].legend(loc="upper right", fontsize=8)
    ax[0].set_title(f"gap diagnosis: {d.program or ''} against {d.source}")
    ax[1].plot(meas.t_s[al_c.valid], mm_to_um(al_c.distance_mm[al_c.valid]), ".", ms=2, color="tab:blue",
               label="measured to corrected path")
    ax[1].plot(meas.t_s[al_b.valid], mm_to_um(al_b.distance_mm[al_b.valid]), ".", ms=1.5, color="tab:red",
               alpha=0.5, label="measured to base path")
    ax[1].set_ylabel("contour deviation (um)")
    ax[1].legend(loc="upper right", fontsize=8)
    ax[2].plot(meas.t_s[al_b.valid], s_to_ms(al_b.time_error_s[al_b.valid]), lw=1, color="tab:red",
               label="base")
    ax[2].plot(meas.t_s[al_c.valid], s_to_ms(al_c.time_error_s[al_c.valid]), lw=1, color="tab:blue",
               label="corrected")
    ax[2].set_ylabel("time error at the place (ms)")
    ax[2].set_xlabel("measured time (s)")
    ax[2].legend(loc="upper left", fontsize=8)
    for a in ax:
        a.grid(alpha=0.3)
    fig.tight_layout()
    return [_save(fig, prefix, "gap", fmt)]


def plot_summary(d, evaluator, prefix: str, fmt: str = "png") -> list[str]:
    """Published values against the base and the corrected model, per entry."""
    plt = _plt()
    base = {(r[0], r[1]): r for r in d.gap_before.rows}
    corr = {(r[0], r[1]): r for r in (d.combined or d.best).gap_after.rows}
    feeds = [k for k in base if k[1] == "steady_feed"]
    radial = [k for k in base if k[1] in ("G", "Fmax", "Fmin")]
    fig, ax = plt.subplots(2, 1, figsize=(11, 8))
    for a, keys, scale, unit in ((ax[0], feeds, 0.06, "steady feed (m/min)"),
                                 (ax[1], radial, 1.0, "radial index (um)")):
        x = np.arange(len(keys))
        a.bar(x - 0.27, [base[k][2] * scale for k in keys], 0.27, color="k", label="measured (paper)")
        a.bar(x, [base[k][3] * scale for k in keys], 0.27, color="tab:red", label=f"base ({d.base})")
        a.bar(x + 0.27, [corr[k][3] * scale for k in keys], 0.27, color="tab:blue",
              label="corrected (" + (d.combined or d.best).effect + ")")
        a.set_xticks(x, [f"{k[0]}\n{k[1]}" if k[1] != "steady_feed" else k[0] for k in keys],
                     rotation=30, ha="right", fontsize=7)
        a.set_ylabel(unit)
        a.legend(fontsize=8)
        a.grid(alpha=0.3, axis="y")
    src = d.source if len(d.source) <= 60 else d.source[:57] + "..."
    ax[0].set_title(f"published values against base and corrected model ({src})", fontsize=10)
    fig.tight_layout()
    return [_save(fig, prefix, "summary", fmt)]


def plot_servo(d, evaluator, prefix: str, fmt: str = "png") -> list[str]:
    """Command, actual and the best model's prediction for the axis that moves most."""
    plt = _plt()
    from ncsim.gap.servo_part import single_effect_model
    best = d.best
    pred = evaluator.predict(single_effect_model(best.effect, best.params))
    idx = evaluator.idx
    t = evaluator.measured.t_s[idx]
    act = evaluator.act[idx]
    cmd = evaluator.cmd[idx]
    k = int(np.argmax(np.std(cmd, axis=0)))
    unit = "mm/s" if d.signal == "velocity" else "mm"
    fig, ax = plt.subplots(2, 1, figsize=(11, 7), sharex=True)
    ax[0].plot(t, cmd[:, k], lw=1, color="0.5", label="commanded")
    ax[0].plot(t, act[:, k], ".", ms=2, color="k", label="actual")
    ax[0].plot(t, pred[:, k], lw=1, color="tab:blue", label=f"model ({best.effect})")
    ax[0].set_ylabel(f"{'XYZ'[k]} {d.signal} ({unit})")
    ax[0].legend(fontsize=8)
    ax[0].set_title(f"servo part: {d.source}")
    ax[1].plot(t, act[:, k] - cmd[:, k], ".", ms=2, color="tab:red", label="actual - commanded")
    ax[1].plot(t, act[:, k] - pred[:, k], ".", ms=2, color="tab:blue", label="actual - model")
    ax[1].set_ylabel(f"residual ({unit})")
    ax[1].set_xlabel("time (s)")
    ax[1].legend(fontsize=8)
    for a in ax:
        a.grid(alpha=0.3)
    fig.tight_layout()
    return [_save(fig, prefix, "servo", fmt)]
