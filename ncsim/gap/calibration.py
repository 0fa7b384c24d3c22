"""A calibrated machine file from a gap diagnosis (``ncsim gap --write-machine``).

What goes back into the machine file, and how:

* **what changed** (:func:`machine_changes`): every machine-file value of the corrected
  machine that differs from the source file's, as a :class:`Change` naming its key, its 840D
  machine datum (``MD32000 $MA_MAX_AX_VELO``; operator settings and model constants say that
  they are none), the old and new value in the key's unit, and the fitted effects that set it,
  including the values an effect derives rather than fits (MD32310 that keeps the G64 corner
  jump ``A (f - 1) t_IPO`` when the acceleration or the IPO cycle changes, MD20552 that a
  continuous-path reset mode sets);
* **values on their search bounds** (:func:`bound_hits`): a fitted value at the end of the range
  the search was allowed is where the search stopped, not what the data say (the fit wants
  beyond it). Each is flagged; one that would reach the file stops the writing unless
  ``--allow-bounds`` (:class:`~ncsim.errors.UsageError`, exit 2). Ends that are physical limits
  (no settle time, a 100 % rapid override, no feed forward, no recorder mean) are not flagged
  (``NATURAL_ENDS``);
* **which of equally good hypotheses** (:func:`prefer_plausible`): where a machine-data change
  and an operator setting explain the recording equally well (:func:`equally_good`: within
  ``TIE_SHARE`` of the gap, the diagnosis's "indistinguishable", or within the noise), the file gets the one a machine more plausibly has --
  a rapid or feed override the operator turned down before an axis velocity (MD32000) set to a
  tenth of the machine's rapid rate -- and the other is named as the alternative;
* **the text** (:func:`edit_machine_text`): the source file edited in place with ``tomlkit``
  (comments, order and provenance kept; a changed line's comment says what it was and keeps its
  old comment), under a header that records the fit (:func:`header_lines`: source file,
  recording, program, gap and rms before and after, the effects, the changes, the alternatives,
  the flags, and what a machine file cannot hold). No date: the same diagnosis writes the same
  file.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from typing import Callable, Sequence

from ncsim.errors import UsageError
from ncsim.gap.effects import EFFECTS, get_effect
from ncsim.machine import AXIS_NAMES, MachineSpec, accel_mode_name, path_mode_name
from ncsim.path import COMPRESSOR_NAMES
from ncsim.units import (mm_s2_to_m_s2, mm_s3_to_m_s3, mm_s_to_m_min, s2_to_um_per_m_s2,
                         s_to_ms, share_to_percent)

#: hypotheses whose gaps are within this share of each other are equally good (as
#: ``diagnose.TIE_SHARE``: the diagnosis calls such fits indistinguishable) ...
TIE_SHARE = 0.01
#: ... and so are those whose squared gaps differ by less than the noise's own: each of the
#: gap's three groups of residuals (feed, time, contour) at the noise level adds about 1/4 to
#: gap^2 (``diagnose`` module docstring, step 3)
NOISE_GAP2 = 0.75
#: a float parameter within this share of its search range (log range where the search is
#: logarithmic) of a bound sits on it
BOUND_SHARE = 1e-3
#: (parameter, "low"/"high") ends that are physical limits, not search limits
NATURAL_ENDS = {("settle_ms", "low"), ("ffw_weight", "low"), ("ffw_weight", "high"),
                ("rapid_override_percent", "high"), ("delay_ms", "low"), ("samples", "low")}
#: machine-data effects and the operator settings that may explain the same recording: an
#: override is tried in their place and preferred when it fits as well (module docstring)
PLAUSIBLE_SUBSTITUTES = {"axis_velocity": ("rapid_override", "feed_override")}
#: what a kind of hypothesis is, in the order a machine more plausibly has it
PLAUSIBILITY = {"rapid_override": "operator setting", "feed_override": "operator setting"}


# ---------------------------------------------------------------------------------------------
# Machine-file values and their machine data
# ---------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Datum:
    """One machine-file key: ``[table] key``, the 840D machine datum it holds (or what it is
    when it is none), its unit and how to read it off a :class:`MachineSpec` in that unit."""

    table: str
    key: str
    md: str
    unit: str
    get: Callable[[MachineSpec], object]
    effects: tuple[str, ...]    # the effects that set it (``effects.EFFECTS``)


def _axis(i: int, key: str, md: str, unit: str, get, effects) -> Datum:
    return Datum(f"axes.{AXIS_NAMES[i]}", key, md, unit, lambda m, i=i: get(m.axes[i]), effects)


def _ncu(key: str, md: str, unit: str, get, effects) -> Datum:
    return Datum("ncu", key, md, unit, lambda m: get(m.ncu), effects)


#: the corner-jump law ``A (MD32310 - 1) t_IPO`` ties MD32310 to these effects too
_OVL_EFFECTS = ("corner_jump", "reset_mode", "axis_accel", "cycle_time", "accel_mode",
                "corner_law")

DATA: tuple[Datum, ...] = tuple(
    d for i in range(len(AXIS_NAMES)) for d in (
        _axis(i, "max_velocity_m_min", "MD32000 $MA_MAX_AX_VELO", "m/min",
              lambda a: mm_s_to_m_min(a.max_velocity_mm_s), ("axis_velocity",)),
        _axis(i, "max_accel_m_s2", "MD32300 $MA_MAX_AX_ACCEL", "m/s^2",
              lambda a: mm_s2_to_m_s2(a.max_accel_mm_s2), ("axis_accel", "accel_mode")),
        _axis(i, "max_jerk_m_s3", "MD32431 $MA_MAX_AX_JERK", "m/s^3",
              lambda a: mm_s3_to_m_s3(a.max_jerk_mm_s3), ("axis_jerk", "corner_law")),
        _axis(i, "max_accel_ovl_factor", "MD32310 $MA_MAX_ACCEL_OVL_FACTOR", "",
              lambda a: a.max_accel_ovl_factor, _OVL_EFFECTS),
        _axis(i, "position_gain_1_s", "MD32200 $MA_POSCTRL_GAIN (as 1/s)", "1/s",
              lambda a: a.position_gain_1_s, ("servo_lag",)),
    )) + (
    _ncu("ipo_cycle_ms", "IPO cycle, MD10050 $MN_SYSCLOCK_CYCLE_TIME x MD10070 "
         "$MN_IPO_SYSCLOCK_TIME_RATIO", "ms", lambda n: s_to_ms(n.ipo_cycle_s), ("cycle_time",)),
    _ncu("curvilinear_jerk_m_s3", "path jerk, cf. MD20600 $MC_MAX_PATH_JERK", "m/s^3",
         lambda n: mm_s3_to_m_s3(n.curvilinear_jerk_mm_s3), ("ncu_path_jerk", "corner_law")),
    _ncu("transition_time_ms", "no machine datum (paper eq. 13 dt)", "ms",
         lambda n: s_to_ms(n.transition_time_s), ("transition",)),
    _ncu("lookahead_blocks", "look-ahead depth, cf. MD28060 $MC_MM_IPO_BUFFER_SIZE", "blocks",
         lambda n: n.lookahead_blocks, ("lookahead",)),
    _ncu("reset_path_mode", "MD20150 $MC_GCODE_RESET_VALUES (group 10)", "",
         lambda n: path_mode_name(n.reset_path_mode), ("reset_mode", "corner_law")),
    _ncu("exact_stop_fine_settle_ms", "settle time in the MD36010 $MA_STOP_LIMIT_FINE window "
         "(no machine datum)", "ms", lambda n: s_to_ms(n.exact_stop_fine_settle_s), ("reset_mode",)),
    _ncu("exact_pos_mode_g0_to_g1", "MD20552 $MC_EXACT_POS_MODE_G0_TO_G1", "",
         lambda n: n.exact_pos_mode_g0_to_g1, ("reset_mode", "corner_law")),
    _ncu("reset_accel_mode", "MD20150 $MC_GCODE_RESET_VALUES (group 21)", "",
         lambda n: accel_mode_name(n.reset_accel_mode), ("accel_mode", "corner_law")),
    _ncu("reset_compressor", "MD20150 $MC_GCODE_RESET_VALUES (group 30)", "",
         lambda n: COMPRESSOR_NAMES[n.reset_compressor], ("compressor",)),
    _ncu("rapid_override_percent", "rapid override on the operator panel (no machine datum)",
         "%", lambda n: share_to_percent(n.rapid_override), ("rapid_override",)),
    _ncu("feed_override_percent", "feed override on the operator panel (no machine datum)", "%",
         lambda n: share_to_percent(n.feed_override), ("feed_override",)),
    Datum("structure", "radial_compliance_um_per_m_s2", "structure compliance (no machine datum)",
          "um/(m/s^2)", lambda m: s2_to_um_per_m_s2(m.structure.radial_compliance_mm_per_mm_s2),
          ("compliance",)),
)


@dataclass(frozen=True)
class Change:
    """A machine-file value the calibration changes (module docstring)."""

    datum: Datum
    old: object
    new: object
    effects: tuple[str, ...]     # the fitted effects that set it

    @property
    def where(self) -> str:
        return f"[{self.datum.table}] {self.datum.key}"

    def text(self) -> str:
        unit = f" {self.datum.unit}" if self.datum.unit else ""
        by = f" ({', '.join(self.effects)})" if self.effects else ""
        return (f"{self.datum.md}: {self.where} {_show(self.old)} -> {_show(self.new)}{unit}{by}")

    def as_dict(self) -> dict:
        return {"table": self.datum.table, "key": self.datum.key, "md": self.datum.md,
                "unit": self.datum.unit, "old": self.old, "new": self.new,
                "effects": list(self.effects)}


def toml_value(v):
    """A value as written to the file: seven significant digits (far below any fit's
    uncertainty, and what a person reads; a round trip keeps 5e-7 of it), integers and strings as they are."""
    if v is None or isinstance(v, (str, bool, int)):
        return v
    v = float(v)
    return float(f"{v:.7g}")


def _show(v) -> str:
    if v is None:
        return "(none)"
    if isinstance(v, str):
        return v
    if isinstance(v, int):
        return str(v)
    return f"{float(v):.6g}"


def _same(a, b) -> bool:
    if a is None or b is None or isinstance(a, str) or isinstance(b, str):
        return a == b
    a, b = float(a), float(b)
    if math.isnan(a) or math.isnan(b):
        return math.isnan(a) and math.isnan(b)
    return abs(a - b) <= 1e-9 * max(abs(a), abs(b), 1e-12)


def machine_changes(old: MachineSpec, new: MachineSpec,
                    fitted: Sequence[str] = ()) -> list[Change]:
    """Every :data:`DATA` value that differs between ``old`` and ``new``, with the fitted
    effects (``fitted``) that set it."""
    out = []
    for d in DATA:
        a, b = d.get(old), d.get(new)
        if not _same(a, toml_value(b)) and not _same(a, b):
            out.append(Change(d, a, toml_value(b), tuple(e for e in fitted if e in d.effects)))
    return out


# ---------------------------------------------------------------------------------------------
# Values on their search bounds
# ---------------------------------------------------------------------------------------------

#: effects whose fitted values reach the machine file (a parameter of another is a note)
WRITTEN_EFFECTS = frozenset(n for n, e in EFFECTS.items() if e.kind == "planner") \
    | {"servo_lag", "compliance"}
#: parameters of written effects that have no machine-file key
UNWRITTEN_PARAMS = frozenset({("servo_lag", "ffw_weight")})


@dataclass(frozen=True)
class BoundHit:
    """A fitted value at the end of the range its search was allowed."""

    effect: str
    param: str
    value: float
    end: str          # "low" or "high"
    limit: float
    unit: str
    written: bool     # it reaches the machine file

    def text(self) -> str:
        unit = f" {self.unit}" if self.unit else ""
        side = "lower" if self.end == "low" else "upper"
        return (f"{self.effect} {self.param} = {_show(self.value)}{unit} is on its {side} search "
                f"bound {_show(self.limit)}{unit} (the fit wants {'less' if self.end == 'low' else 'more'}"
                f"; not a measured value)")

    def as_dict(self) -> dict:
        return {"effect": self.effect, "param": self.param, "value": self.value, "end": self.end,
                "bound": self.limit, "unit": self.unit, "written": self.written}


def on_bound(p, value) -> str | None:
    """``"low"``, ``"high"`` or None: where ``value`` of parameter ``p`` sits (``BOUND_SHARE``)."""
    if p.kind == "choice":
        return None
    v, lo, hi = float(value), float(p.low), float(p.high)
    if p.kind == "int":
        return "low" if v <= lo else ("high" if v >= hi else None)
    if p.log and lo > 0:
        span, x, a, b = math.log(hi / lo), math.log(max(v, 1e-300)), math.log(lo), math.log(hi)
    else:
        span, x, a, b = hi - lo, v, lo, hi
    tol = BOUND_SHARE * span
    if x - a <= tol:
        return "low"
    if b - x <= tol:
        return "high"
    return None


def bound_hits(fitted: Sequence[tuple[str, dict]]) -> list[BoundHit]:
    """The fitted values of ``(effect, params)`` on a search bound (not a natural end)."""
    out = []
    for name, params in fitted:
        if name not in EFFECTS:
            continue
        for p in get_effect(name).params:
            if p.name not in params:
                continue
            end = on_bound(p, params[p.name])
            if end is None or (p.name, end) in NATURAL_ENDS:
                continue
            out.append(BoundHit(name, p.name, float(params[p.name]), end,
                                float(p.low if end == "low" else p.high), p.unit,
                                name in WRITTEN_EFFECTS and (name, p.name) not in UNWRITTEN_PARAMS))
    return out


# ---------------------------------------------------------------------------------------------
# The more plausible of equally good hypotheses
# ---------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Alternative:
    """A hypothesis that explains the recording as well as the one written
    (:func:`equally_good`), and why the written one was preferred."""

    effect: str           # the alternative, not written
    params: dict
    gap: float
    instead_of: str       # the effect written in its place
    chosen_gap: float
    reason: str

    def text(self) -> str:
        vals = ", ".join(f"{k}={_show(v)}" for k, v in self.params.items())
        return (f"{self.effect} ({vals}; gap {self.gap:.4g}) fits as well as {self.instead_of} "
                f"(gap {self.chosen_gap:.4g}): {self.reason}")

    def as_dict(self) -> dict:
        return {"effect": self.effect, "params": dict(self.params), "gap": self.gap,
                "instead_of": self.instead_of, "chosen_gap": self.chosen_gap,
                "reason": self.reason}


def equally_good(gap: float, best_gap: float) -> bool:
    """Whether a fit leaving ``gap`` explains the recording as well as one leaving
    ``best_gap``: within ``TIE_SHARE`` of it, or ``gap^2`` within ``NOISE_GAP2`` of
    ``best_gap^2`` (what residuals at the noise level add)."""
    return gap <= best_gap * (1.0 + TIE_SHARE) or gap * gap - best_gap * best_gap <= NOISE_GAP2


def plausibility(effect: str) -> int:
    """0 for an operator setting (``PLAUSIBILITY``), 1 for a machine-data change or a model
    constant: the lower, the more plausibly a machine has it."""
    return 0 if effect in PLAUSIBILITY else 1


def _reason(chosen: str, other: str) -> str:
    if plausibility(chosen) < plausibility(other):
        return (f"{chosen} written: an {PLAUSIBILITY[chosen]} is more plausible than a "
                f"machine-data change ({other})")
    return f"{chosen} written: the better fit of two equally plausible hypotheses"


def _alternative(other, chosen) -> Alternative:
    """``other`` (an ``EffectFit``) named as the alternative of ``chosen``."""
    return Alternative(other.effect, dict(other.params), other.gap_after.gap, chosen.effect,
                       chosen.gap_after.gap, _reason(chosen.effect, other.effect))


def prefer_plausible(evaluator, d) -> tuple[object, list[Alternative]]:
    """The diagnosis ``d`` (``diagnose.Diagnosis``) with the more plausible of equally good
    hypotheses as its corrected model (module docstring), and the alternatives named.
    ``evaluator`` judges models exactly as the diagnosis did (``diagnose.Evaluator`` with the
    program interpreted again where a model needs it).

    Single fits (no combined model): every fit :func:`equally_good` as the best is one; the most plausible of them goes first, the others are the alternatives. A combined
    model: for each pair of :data:`PLAUSIBLE_SUBSTITUTES` of which the model holds one, the
    other is fitted in its place (the first reset to the base's value); when it fits as well,
    the more plausible of the two stays in the model and the other is the alternative."""
    from dataclasses import replace as dc_replace
    from ncsim.gap.fit import fit_effect
    final = d.combined if d.combined is not None else d.best
    if final.shrink_percent <= 0:
        return d, []
    if d.combined is None:
        best = d.fits[0]
        pool = [best] + [f for f in d.fits[1:]
                         if equally_good(f.gap_after.gap, best.gap_after.gap)]
        chosen = min(pool, key=lambda f: (plausibility(f.effect), pool.index(f)))
        alternatives = [_alternative(f, chosen) for f in pool if f is not chosen]
        if chosen is not best:
            d = dc_replace(d, fits=[chosen] + [f for f in d.fits if f is not chosen])
        return d, alternatives
    chosen = list(final.effects or (final.effect,))
    current = final
    alternatives: list[Alternative] = []
    pairs = [(md, op) for md, ops in PLAUSIBLE_SUBSTITUTES.items() for op in ops]
    for md, op in pairs:
        if (md in chosen) == (op in chosen):
            continue
        inside, other = (md, op) if md in chosen else (op, md)
        e = get_effect(inside)
        without = e.apply(current.model, e.check(e.current(d.base_model)))
        trial = fit_effect(evaluator, without, other, gap_before=d.gap_before)
        if not equally_good(trial.gap_after.gap, current.gap_after.gap):
            continue
        params_in = {p.name: current.params[p.name] for p in e.params if p.name in current.params}
        fit_in = dc_replace(current, effect=inside, params=params_in)
        if plausibility(other) < plausibility(inside):
            alternatives.append(_alternative(fit_in, trial))
            params = {k: v for k, v in current.params.items() if k not in params_in}
            params.update(trial.params)
            chosen[chosen.index(inside)] = other
            current = dc_replace(current, effect="+".join(chosen), effects=tuple(chosen),
                                 params=params, model=trial.model, gap_after=trial.gap_after)
        else:
            alternatives.append(_alternative(trial, fit_in))
    if current is not final:
        d = dc_replace(d, combined=current)
    return d, alternatives


# ---------------------------------------------------------------------------------------------
# The file
# ---------------------------------------------------------------------------------------------

def edit_machine_text(text: str, changes: Sequence[Change], header: Sequence[str]) -> str:
    """The source machine file ``text`` with ``changes`` made in place (``tomlkit``: comments,
    order and formatting kept), each changed line's comment saying what it was and keeping its
    old comment, under the ``header`` comment lines."""
    import tomlkit
    from tomlkit.exceptions import TOMLKitError
    try:
        doc = tomlkit.parse(text)
    except TOMLKitError as exc:          # the file loaded, so this is not expected
        raise UsageError(f"cannot edit the machine file: {exc}") from None
    _replace_old_corner_key(doc, changes)
    for ch in changes:
        table = doc
        for part in ch.datum.table.split("."):
            if part not in table:
                table[part] = tomlkit.table()
            table = table[part]
        old_comment, comment_ws = "", "  "
        if ch.datum.key in table:
            item = table.item(ch.datum.key)
            old_comment = item.trivia.comment.lstrip("#").strip()
            comment_ws = item.trivia.comment_ws or comment_ws
            was = f"was {_show(ch.old)}"
        else:
            was = f"was {_show(ch.old)}, the default" if ch.old is not None else "new"
        table[ch.datum.key] = ch.new
        note = f"fitted by ncsim gap ({was}; see the header)"
        md = re.search(r"MD\d+", ch.datum.md)
        if (md.group(0) if md else ch.datum.md) not in old_comment:
            note += f"; {ch.datum.md}"
        if old_comment:
            note += f". Before: {old_comment}"
        table[ch.datum.key].comment(note)
        table.item(ch.datum.key).trivia.comment_ws = comment_ws
    body = tomlkit.dumps(doc)
    return "".join(f"# {h}\n" if h else "#\n" for h in header) + "#\n" + body


def _replace_old_corner_key(doc, changes) -> None:
    """A file of earlier versions with ``[ncu] corner_velocity_jump_factor`` (read as MD32310
    on every axis) cannot also hold per-axis MD32310: the old key goes when MD32310 changes
    (the changes then write every axis's value)."""
    ncu = doc.get("ncu")
    if ncu is None or "corner_velocity_jump_factor" not in ncu:
        return
    if any(ch.datum.key == "max_accel_ovl_factor" for ch in changes):
        del ncu["corner_velocity_jump_factor"]


def complete_ovl_changes(old: MachineSpec, new: MachineSpec, changes: list[Change],
                         text: str) -> list[Change]:
    """With the old ``corner_velocity_jump_factor`` key removed, every axis needs its MD32310
    written, changed or not."""
    if "corner_velocity_jump_factor" not in text or \
            not any(ch.datum.key == "max_accel_ovl_factor" for ch in changes):
        return changes
    have = {(ch.datum.table, ch.datum.key) for ch in changes}
    extra = [Change(d, d.get(old), toml_value(d.get(new)), ())
             for d in DATA if d.key == "max_accel_ovl_factor" and (d.table, d.key) not in have]
    return changes + extra


@dataclass
class Calibration:
    """What ``--write-machine`` writes and why (module docstring): built by
    ``pipeline.GapResult.calibration``."""

    source: str                           # the source machine file as given
    fitted: list[tuple[str, dict]]        # (effect, params) in the corrected model
    changes: list[Change]
    bounds: list[BoundHit]
    alternatives: list[Alternative]
    notes: list[str]                      # what the file cannot hold
    fit_lines: list[str] = field(default_factory=list)   # gap and rms before and after
    #: the program's cycle time under the base and the corrected model (None: no program)
    base_cycle_time_s: float | None = None
    cycle_time_s: float | None = None

    @property
    def refused(self) -> list[BoundHit]:
        """The values on a search bound that would reach the file."""
        return [b for b in self.bounds if b.written]

    def header(self, measured_file: str, program: str) -> list[str]:
        """The comment block recording the fit (no date: deterministic)."""
        rec = f"{measured_file}" + (f" of {program}" if program else "")
        lines = [f"Calibrated by `ncsim gap` from {self.source} (its comments follow, a changed "
                 "line says what it was)", f"against the recording {rec}."]
        lines += self.fit_lines
        if self.cycle_time_s is not None:
            lines.append(f"Cycle time of the program: {self.base_cycle_time_s:.6f} s on the source "
                         f"file, {self.cycle_time_s:.6f} s on this one (`ncsim run` on it gives "
                         "the corrected model's).")
        lines.append("Fitted: " + ("; ".join(f"{n} " + ", ".join(f"{k}={_show(v)}"
                                                                 for k, v in p.items())
                                             for n, p in self.fitted) or "nothing"))
        lines.append("Machine data changed (old -> new):" if self.changes
                     else "Machine data changed: none")
        lines += [f"  {c.text()}" for c in self.changes]
        if self.alternatives:
            lines.append("Equally good alternatives (not written):")
            lines += [f"  {a.text()}" for a in self.alternatives]
        if self.bounds:
            lines.append("Values on their search bounds (flagged; written only with "
                         "--allow-bounds):")
            lines += [f"  {b.text()}" + ("" if b.written else " (not a machine-file value)")
                      for b in self.bounds]
        if self.notes:
            lines.append("Notes:")
            lines += [f"  {n}" for n in self.notes]
        return lines

    def text(self) -> str:
        """The CLI's section on the machine file."""
        lines = ["", "machine file (--write-machine): "
                 + (f"{len(self.changes)} machine data changed against {self.source}"
                    if self.changes else f"no machine datum changed against {self.source}")]
        lines += [f"  {c.text()}" for c in self.changes]
        if self.cycle_time_s is not None:
            lines.append(f"  cycle time of the program {self.base_cycle_time_s:.4f} s -> "
                         f"{self.cycle_time_s:.4f} s (corrected model)")
        for a in self.alternatives:
            lines.append(f"  alternative: {a.text()}")
        for b in self.bounds:
            lines.append(f"  ON BOUND: {b.text()}" + ("" if b.written else
                                                     " (not a machine-file value)"))
        for n in self.notes:
            lines.append(f"  note: {n}")
        return "\n".join(lines) + "\n"

    def as_dict(self) -> dict:
        return {"source": self.source,
                "fitted": [{"effect": n, "params": dict(p)} for n, p in self.fitted],
                "changes": [c.as_dict() for c in self.changes],
                "on_bounds": [b.as_dict() for b in self.bounds],
                "alternatives": [a.as_dict() for a in self.alternatives],
                "notes": list(self.notes), "base_cycle_time_s": self.base_cycle_time_s,
                "cycle_time_s": self.cycle_time_s}

    def refusal(self, out: str) -> str:
        """The one line that refuses to write ``out`` (values on bounds, no --allow-bounds)."""
        hits = "; ".join(f"{b.effect} {b.param}={_show(b.value)} ({'lower' if b.end == 'low' else 'upper'} "
                         f"bound)" for b in self.refused)
        return (f"{out} not written: fitted values on their search bounds would go into it: {hits} "
                "(the fit stopped there, the data want beyond it; --allow-bounds writes them)")
