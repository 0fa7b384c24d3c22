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


def trace_series(evaluator, model) -> dict:
    """What the trace figure draws of one model, and the gap metrics those very arrays give
    (the figure and the text agree by construction; ``tests/test_gap_plot.py`` recomputes them):

    * ``t_model_s``, ``speed_model_mm_s``: the model's path feed on the measured clock (its
      grid shifted by the alignment's clock offset), through the measured speed's operator;
    * ``t_s``: the measured samples' times (the recording's clock); ``time_error_ms``: measured minus model time at
      the same place, counted from its median over the compared samples (a constant is only a
      clock offset, ``metrics.gap_metrics``); ``contour_um``: distance to the model path;
      ``valid``: samples placed on the model path; ``compared``: samples in motion whose time
      error counts; ``outside_ms``: the time outside the model's motion of samples in motion
      the model does not reach (``unmatched``);
    * ``time_rms_ms``, ``contour_rms_um``: the rms of these arrays, as the text reports them.
    """
    from ncsim.gap.metrics import compared_samples, rms
    m, al, mt = evaluator.evaluate(model, full=True)
    c = compared_samples(al, mt, evaluator.scales)      # the samples gap_metrics compares
    compared, unmatched = c.moving, c.unmatched
    te = np.asarray(al.time_error_s, dtype=np.float64)
    median = float(np.median(te[compared])) if np.any(compared) else 0.0
    time_error_ms = s_to_ms(te - median)
    dist_um = mm_to_um(np.asarray(al.distance_mm, dtype=np.float64))
    outside = c.outside_s
    return {"t_model_s": mt.t_s + al.time_shift_s, "speed_model_mm_s": c.model_speed,
            "t_s": np.asarray(evaluator.measured.t_s), "time_error_ms": time_error_ms, "contour_um": dist_um,
            "valid": np.asarray(al.valid), "compared": compared, "unmatched": unmatched,
            "outside_ms": s_to_ms(outside),
            "time_rms_ms": rms(np.concatenate([time_error_ms[compared],
                                               s_to_ms(outside[unmatched])])),
            "contour_rms_um": rms(dist_um[al.valid]), "metrics": m}


def trace_models(d) -> tuple:
    """``((label, model), (label, model))``: the base model and the corrected model the text
    reports (the combined one when there is one, else the best single fit)."""
    final = d.combined if d.combined is not None else d.best
    return ((f"base model ({d.base})", d.base_model),
            (f"corrected ({final.effect})", d.corrected_model))


def plot_trace(d, evaluator, prefix: str, fmt: str = "png") -> list[str]:
    """Feed, contour deviation and time error: measured against base and corrected models
    (:func:`trace_series`; ``evaluator`` judges models as the diagnosis did, re-interpreting
    the program where a model changes its reset mode)."""
    plt = _plt()
    (label_b, model_b), (label_c, model_c) = trace_models(d)
    base = trace_series(evaluator, model_b)
    corr = trace_series(evaluator, model_c)
    meas = evaluator.measured
    fig, ax = plt.subplots(3, 1, figsize=(11, 9), sharex=True)
    ax[0].plot(meas.t_s, evaluator.measured_speed, ".", ms=2, color="k", label="measured")
    for s, label, color in ((base, label_b, "tab:red"), (corr, label_c, "tab:blue")):
        ax[0].plot(s["t_model_s"], s["speed_model_mm_s"], lw=1, color=color,
                   label=f"{label}: time {s['time_rms_ms']:.3g} ms rms")
    ax[0].set_ylabel("path feed (mm/s)")
    ax[0].legend(loc="upper right", fontsize=8)
    ax[0].set_title(f"gap diagnosis: {FsPath(d.program).name if d.program else ''} against "
                    f"{FsPath(d.source).name}", fontsize=10)
    for s, label, color, size in ((corr, "measured to corrected path", "tab:blue", 2),
                                  (base, "measured to base path", "tab:red", 1.5)):
        v = s["valid"]
        ax[1].plot(s["t_s"][v], s["contour_um"][v], ".", ms=size, color=color,
                   label=f"{label} ({s['contour_rms_um']:.3g} um rms)")
    ax[1].set_ylabel("contour deviation (um)")
    ax[1].legend(loc="upper right", fontsize=8)
    for s, label, color in ((base, "base", "tab:red"), (corr, "corrected", "tab:blue")):
        c = s["compared"]      # the samples whose time error the rms counts (in motion)
        ax[2].plot(s["t_s"][c], s["time_error_ms"][c], lw=1, color=color,
                   label=f"{label} ({s['time_rms_ms']:.3g} ms rms)")
        u = s["unmatched"]
        if np.any(u):
            ax[2].plot(s["t_s"][u], s["outside_ms"][u], "x", ms=3, color=color,
                       label=f"{label}: outside the model's motion")
    ax[2].set_ylabel("time error at the place,\nfrom its median (ms)")
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
