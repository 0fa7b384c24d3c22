"""Text rendering of gap diagnoses (``ncsim gap``): ranked tables and where the gap is.

Pure functions from the diagnosis objects of ``ncsim.gap`` (traces), ``ncsim.gap.published``
(published values) and ``ncsim.gap.servo_part`` (commanded against actual) to strings; the JSON form
is each object's ``as_dict()``.
"""
from __future__ import annotations

import math

from ncsim.gap.effects import EFFECTS
from ncsim.units import feed_from_mm_s, mm_to_um, s_to_ms

#: decimals of a feed error per unit: the text prints every feed in one unit (mm/min unless
#: ``feed_unit`` says otherwise); the JSON keeps the unit in its key names (``_mm_s``)
FEED_ERROR_DECIMALS = {"mm/min": 1, "m/min": 4, "mm/s": 3, "in/min": 2}


def _f(v_mm_s, unit: str) -> float:
    return feed_from_mm_s(v_mm_s, unit)


def _fd(unit: str) -> int:
    return FEED_ERROR_DECIMALS.get(unit, 3)


def _params(params: dict) -> str:
    out = []
    for k, v in params.items():
        if isinstance(v, str):
            out.append(f"{k}={v}")
        elif isinstance(v, (int,)) or (isinstance(v, float) and float(v).is_integer() and abs(v) < 1e6
                                        and k.endswith("blocks")):
            out.append(f"{k}={int(v)}")
        else:
            out.append(f"{k}={v:.4g}")
    return " ".join(out)


def _shown_params(f) -> str:
    """Fitted parameters, or a note when the effect changes nothing on these data (its
    parameters are then arbitrary)."""
    if abs(f.shrink_percent) < 0.05 and f.gap_after.gap == f.gap_before.gap:
        return "(changes nothing on these data)"
    return _params(f.params)


def _pct(v: float) -> str:
    return "   n/a" if v is None or not math.isfinite(v) else f"{v:6.1f} %"


def format_registration(reg) -> str:
    """Where a :class:`ncsim.gap.register.Registration` put the recording, as one paragraph."""
    what = "commanded positions" if reg.signal == "command" else "positions"
    off = ", ".join(f"{v:.6f}" for v in reg.offset_mm)
    lines = [f"recording: {what} cover {reg.covered()}",
             f"  work offset ({off}) mm ({reg.offset_source}); residual "
             f"{mm_to_um(reg.residual_rms_mm):.3g} um rms, {mm_to_um(reg.residual_max_mm):.3g} um "
             f"max (noise {mm_to_um(reg.noise_mm):.2g} um)"]
    lines += [f"  note: {n}" for n in reg.notes]
    return "\n".join(lines) + "\n"


def format_trace(d, feed_unit: str = "mm/min") -> str:
    """A :class:`ncsim.gap.diagnose.Diagnosis` as text, feeds in ``feed_unit``."""
    u, k = feed_unit, _fd(feed_unit)
    g = d.gap_before
    al = d.alignment
    lines = [f"gap diagnosis: {d.program or '<path>'} against {d.source}, base model '{d.base}'",
             f"  alignment: time shift {al['time_shift_s']:.4f} s ({al['shift_method']}), "
             f"zero offset ({', '.join(f'{v:.4f}' for v in al['offset_mm'])}) mm "
             f"({al['offset_method']}); position noise {mm_to_um(d.scales.noise_mm):.2f} um",
             f"  covers {al['covered']}" if al.get("covered") else None,
             f"  base gap {g.gap:.3g}: feed {_f(g.feed_rms_mm_s, u):.{k}f} {u} rms, time {g.time_rms_ms:.2f} ms rms, "
             f"cycle time {g.cycle_time_error_s:+.4f} s, contour {g.contour_rms_um:.2f} um rms "
             f"(scales: feed {_f(d.scales.feed_mm_s, u):.3g} {u}, time {s_to_ms(d.scales.time_s):.3g} ms, "
             f"contour {mm_to_um(d.scales.contour_mm):.3g} um)", ""]
    lines = [ln for ln in lines if ln is not None]
    lines += _fit_table(d.fits, d.combined, u)
    lines += _localisation(d.localisation_before, "where the base model departs", u)
    if d.localisation_after:
        lines += _circles(d.localisation_after, "after correction")
    for n in d.notes:
        lines.append(f"note: {n}")
    return "\n".join(lines) + "\n"


def _fit_table(fits, combined, u: str = "mm/min") -> list[str]:
    k = _fd(u)
    head = (f"{'rank':>4} {'effect':<15} {'shrink':>8} {'gap':>9} {'feed ' + u:>11} {'time ms':>8} "
            f"{'cycle s':>8} {'contour um':>10}  fitted parameters")
    lines = [head]
    rows = list(enumerate(fits, 1)) + ([("all", combined)] if combined is not None else [])
    for rank, f in rows:
        a = f.gap_after
        name = f.effect if rank != "all" else "combined"
        lines.append(f"{rank!s:>4} {name:<15} {_pct(f.shrink_percent):>8} {a.gap:9.3g} "
                     f"{_f(a.feed_rms_mm_s, u):11.{k}f} {a.time_rms_ms:8.2f} {a.cycle_time_error_s:+8.4f} "
                     f"{a.contour_rms_um:10.2f}  {_shown_params(f)}"
                     + ("" if f.added else "  (re-fitted)"))
    if combined is not None:
        lines.append(f"     combined model: {' + '.join(combined.effects)}")
    return lines


def _localisation(loc: dict, title: str, u: str = "mm/min") -> list[str]:
    if not loc:
        return []
    k = _fd(u)
    lines = ["", f"{title} (blocks with the largest gap):",
             f"  {'line':>6} {'block':>6} {'kind':<5} {'feed err ' + u:>15} {'duration err ms':>15} "
             f"{'contour rms um':>14}"]
    for b in loc["blocks"]:
        lines.append(f"  {b['line']:>6} {b['block']:>6} {b['kind']:<5} {_f(b['feed_error_rms_mm_s'], u):15.{k}f} "
                     f"{b['duration_error_ms']:15.2f} {b['contour_rms_um']:14.2f}")
    lines += ["  per phase:"]
    for p in loc["phases"]:
        lines.append(f"    {p['phase']:<10} n={p['n']:<6} feed err {_f(p['feed_error_rms_mm_s'], u):.{k}f} {u} rms, "
                     f"contour {p['contour_rms_um']:.2f} um rms, mean time err {p['time_error_mean_ms']:+.2f} ms")
    arcs = [a for a in loc.get("arcs", []) if a["sectors"]]
    if arcs:
        lines.append(f"  arcs, worst {30:.0f}-degree sector (angle about the centre: radial gap "
                     "measured - model, feed error, time error):")
        for a in arcs[:8]:
            sec = max(a["sectors"], key=lambda x: abs(x["gap_um"] or 0.0))
            fsec = max(a["sectors"], key=lambda x: abs(x["feed_error_mm_s"] or 0.0))
            lines.append(f"    line {a['line']} R {a['radius_mm']:g}: radial {sec['gap_um'] or 0:+.1f} um at "
                         f"{sec['angle_deg']:.0f} deg; feed {_f(fsec['feed_error_mm_s'] or 0, u):+.{k}f} {u} at "
                         f"{fsec['angle_deg']:.0f} deg (time {fsec['time_error_ms'] or 0:+.1f} ms)")
        if len(arcs) > 8:
            lines.append(f"    ... {len(arcs) - 8} more arcs (--json)")
    lines += _circles(loc, "")
    return lines


def _circles(loc: dict, title: str) -> list[str]:
    rows = [a for a in loc.get("arcs", []) if "iso230" in a]
    if not rows:
        return []
    lines = [f"  circles, ISO 230-4 (measured / model){' ' + title if title else ''}:"]
    for a in rows:
        m, s = a["iso230"]["measured"], a["iso230"]["model"]
        lines.append(f"    line {a['line']} R {a['radius_mm']:g} mm: G {m['G_um']:.1f} / {s['G_um']:.1f} um, "
                     f"Fmax {m['Fmax_um']:.1f} / {s['Fmax_um']:.1f} um, Fmin {m['Fmin_um']:.1f} / {s['Fmin_um']:.1f} um")
    return lines


_SUMMARY_UNITS = {"steady_feed": "mm/s", "max_feed_below": "mm/s", "normal_accel": "mm/s^2",
                  "tangential_jerk": "mm/s^3", "G": "um", "Fmax": "um", "Fmin": "um"}


def format_summary(d, feed_unit: str = "mm/min") -> str:
    """A :class:`ncsim.gap.published.SummaryDiagnosis` as text, feeds in ``feed_unit``."""
    from ncsim.gap.metrics import shrink_percent
    g = d.gap_before
    lines = [f"gap diagnosis against published values: {d.source}, base model '{d.base}'",
             f"  {len(d.matches)} entries matched to program blocks"
             + (f"; unmatched: {', '.join(e.id for e in d.unmatched)}" if d.unmatched else ""),
             f"  base gap {g.gap:.3g}: kinematics {g.kinematics:.3g} (steady feeds {g.feed_rms_percent:.2f} % rms), "
             f"radial deviations {g.radial_rms_um:.1f} um rms (measured {g.radial_measured_rms_um:.1f} um rms)", "",
             "ranked on the whole gap (kinematic and radial rankings below the table):",
             f"{'rank':>4} {'effect':<15} {'shrink':>8} {'gap':>8} {'kinematics':>10} {'kin. shrink':>11} "
             f"{'radial um':>9} {'radial explained':>16}  fitted parameters"]
    rows = list(enumerate(d.fits, 1)) + ([("all", d.combined)] if d.combined is not None else [])
    for rank, f in rows:
        a = f.gap_after
        name = f.effect if rank != "all" else "combined"
        lines.append(f"{rank!s:>4} {name:<15} {_pct(f.shrink_percent):>8} {a.gap:8.3g} {a.kinematics:10.3g} "
                     f"{_pct(shrink_percent(g.kinematics, a.kinematics)):>11} {a.radial_rms_um:9.1f} "
                     f"{_pct(100 * a.radial_share_explained):>16}  {_shown_params(f)}")
    best_kin = d.ranked("kinematics")[0]
    best_rad = d.ranked("radial")[0]
    lines += ["",
              f"feeds, jerks and accelerations: best explained by {best_kin.effect} "
              f"({EFFECTS[best_kin.effect].title}; {_params(best_kin.params)}), kinematic gap "
              f"{g.kinematics:.3g} -> {best_kin.gap_after.kinematics:.3g}",
              f"radial deviations (G, Fmax, Fmin): best explained by {best_rad.effect} "
              f"({EFFECTS[best_rad.effect].title}; {_params(best_rad.params)}), "
              f"{100 * best_rad.gap_after.radial_share_explained:.1f} % explained "
              f"(rms {g.radial_rms_um:.1f} -> {best_rad.gap_after.radial_rms_um:.1f} um)"]
    if d.combined is not None:
        lines.append(f"combined model {' + '.join(d.combined.effects)}: "
                     f"{100 * d.combined.gap_after.radial_share_explained:.1f} % of the radial deviations explained")
    final = d.combined or d.best
    lines += ["", "per entry: published / corrected model (residual in resolution units)"]
    for r in final.gap_after.rows:
        q = r[1]
        if q == "reaches_programmed":
            meas, model = ("yes" if r[2] else "no"), f"{100 * r[3]:.1f} % of F"
        elif _SUMMARY_UNITS.get(q) == "mm/s":      # a feed: in the output's feed unit
            k = max(_fd(feed_unit) - 1, 0)
            meas, model = (f"{_f(r[2], feed_unit):.{k}f} {feed_unit}", f"{_f(r[3], feed_unit):.{k}f} {feed_unit}")
        else:
            unit = _SUMMARY_UNITS.get(q, "")
            meas, model = f"{r[2]:.4g} {unit}", f"{r[3]:.4g} {unit}"
        lines.append(f"  {r[0]:<24} {q:<18} {meas:>16} {model:>16}   {r[4]:+.2f}")
    return "\n".join(lines) + "\n"


def format_servo(d, feed_unit: str = "mm/min") -> str:
    """A :class:`ncsim.gap.servo_part.ServoDiagnosis` as text (velocities in ``feed_unit``)."""
    signal = {"velocity": "velocities", "position": "positions"}.get(d.signal, d.signal)
    velocity = d.signal == "velocity"
    rms = _f(d.gap_before.rms, feed_unit) if velocity else d.gap_before.rms
    lines = [f"servo part (commanded against actual {signal}): {d.source}",
             f"  command as actual: gap {d.gap_before.gap:.3g}, rms {rms:.4g} "
             f"{feed_unit if velocity else 'mm'} over {d.gap_before.n_samples} values",
             f"{'rank':>4} {'effect':<12} {'shrink':>8} {'gap':>8} {'rms':>9} {'lag ms':>7}  fitted parameters"]
    for i, f in enumerate(d.fits, 1):
        lag = "" if f.lag_s is None else f"{s_to_ms(f.lag_s):7.2f}"
        rms = _f(f.gap_after.rms, feed_unit) if velocity else f.gap_after.rms
        lines.append(f"{i:>4} {f.effect:<12} {_pct(f.shrink_percent):>8} {f.gap_after.gap:8.3g} "
                     f"{rms:9.4g} {lag:>7}  {_params(f.params)}")
    le = d.lag_estimate
    if le is not None and math.isfinite(le.pooled_ramp_delay_s):
        lines.append(f"  independent estimate (lag.estimate_lag): ramp delay "
                     f"{s_to_ms(le.pooled_ramp_delay_s):.2f} ms over {int(sum(le.n_ramp_samples))} ramp samples")
    best = d.best
    verdict = ("better than" if d.distinguishable else "indistinguishable from")
    others = [f for f in d.fits if f.effect in ("servo_lag", "servo_delay") and f is not best]
    if best.effect in ("servo_lag", "servo_delay") and others:
        lines.append(f"  {best.effect} is {verdict} {others[0].effect} "
                     f"(gap {best.gap_after.gap:.4g} against {others[0].gap_after.gap:.4g})")
    for n in d.notes:
        lines.append(f"note: {n}")
    return "\n".join(lines) + "\n"
