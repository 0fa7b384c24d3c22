"""Published measured values (TOML summary files): the input of the gap diagnosis when no
trace exists, e.g. ``measured/paper_table3.toml`` (the paper's Table 3 and sections 5.2-5.3).

Tables ``[[circle]]``, ``[[block]]``, ``[[transition]]`` and ``[[cycle]]``; every quantity key
carries its unit (``steady_feed_m_min``, ``G_um``, ``time_s``) and is stored in the unit its
field name says (factors from ``ncsim.units``). Files are read by ``ncsim.config`` with its
error policy: every problem is one :class:`~ncsim.errors.MeasuredDataError` line naming the key
path (``circle[2].G_um``).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Mapping

from ncsim.config import Problems, finite, non_negative, parse_toml, positive, read_text
from ncsim.errors import MeasuredDataError
from ncsim.units import DEG_PER_RAD, FACTORS, UM_PER_MM

#: TOML key base -> (quantity kind, {unit suffix: factor to the stored unit}, stored field)
_VELOCITY_SUFFIXES = {"m_min": FACTORS["velocity"]["m/min"],
                      "mm_min": FACTORS["velocity"]["mm/min"], "mm_s": 1.0}
_SUMMARY_QUANTITIES: dict[str, tuple[dict[str, float], str]] = {
    "radius": ({"mm": 1.0, "um": FACTORS["length"]["um"]}, "radius_mm"),
    "radius_before": ({"mm": 1.0}, "radius_before_mm"),
    "radius_after": ({"mm": 1.0}, "radius_after_mm"),
    "programmed_feed": (_VELOCITY_SUFFIXES, "programmed_feed_mm_s"),
    "feed": (_VELOCITY_SUFFIXES, "feed_mm_s"),
    "steady_feed": (_VELOCITY_SUFFIXES, "steady_feed_mm_s"),
    "max_feed": (_VELOCITY_SUFFIXES, "max_feed_mm_s"),
    "max_feed_below": (_VELOCITY_SUFFIXES, "max_feed_below_mm_s"),
    "normal_accel": ({"m_s2": FACTORS["acceleration"]["m/s2"], "mm_s2": 1.0}, "normal_accel_mm_s2"),
    "tangential_jerk": ({"m_s3": FACTORS["jerk"]["m/s3"], "mm_s3": 1.0}, "tangential_jerk_mm_s3"),
    "G": ({"um": 1.0, "mm": UM_PER_MM}, "G_um"),           # ISO 230-4 indexes are kept in um
    "Fmax": ({"um": 1.0, "mm": UM_PER_MM}, "Fmax_um"),
    "Fmin": ({"um": 1.0, "mm": UM_PER_MM}, "Fmin_um"),
    "time": ({"s": 1.0, "ms": FACTORS["time"]["ms"], "min": FACTORS["time"]["min"]}, "time_s"),
    "angle": ({"deg": 1.0, "rad": DEG_PER_RAD}, "angle_deg"),
    "incline": ({"deg": 1.0, "rad": DEG_PER_RAD}, "incline_deg"),
}
_POSITIVE_QUANTITIES = {"radius", "radius_before", "radius_after", "time"}
_REQUIRED_QUANTITIES = {"circle": ("radius",), "transition": ("radius_before", "radius_after"),
                        "cycle": ("time",)}
_COMMON_TEXT_KEYS = {"id", "program", "source", "note", "trajectory"}
_COMMON_BOOL_KEYS = {"reaches_programmed", "has_steady_phase", "has_ramps"}
#: entry table -> allowed quantity bases
_ENTRY_QUANTITIES = {
    "circle": {"radius", "programmed_feed", "steady_feed", "normal_accel", "tangential_jerk",
               "G", "Fmax", "Fmin", "time"},
    "block": {"radius", "programmed_feed", "steady_feed", "max_feed", "max_feed_below",
              "normal_accel", "incline", "time"},
    "transition": {"radius_before", "radius_after", "angle", "incline", "programmed_feed", "feed"},
    "cycle": {"programmed_feed", "time"},
}
_ENTRY_INT_KEYS = {"block": {"block", "line"}, "circle": set(), "transition": {"block", "line"},
                   "cycle": set()}


@dataclass(frozen=True)
class SummaryEntry:
    """One published measurement. ``kind`` is the TOML table (circle, block, transition,
    cycle); ``values`` maps stored field names (with internal units in the name: ``G_um``,
    ``steady_feed_mm_s``, ``radius_mm``, ``time_s``) to numbers; ``flags`` maps boolean keys
    (``reaches_programmed``, ``has_steady_phase``, ``has_ramps``) to bools."""

    kind: str
    id: str
    values: Mapping[str, float]
    flags: Mapping[str, bool] = field(default_factory=dict)
    ints: Mapping[str, int] = field(default_factory=dict)
    program: str | None = None
    trajectory: str | None = None
    source: str = ""
    note: str = ""

    def get(self, name: str, default=None):
        return self.values.get(name, default)

    def __getattr__(self, name: str):
        # convenient access: entry.G_um, entry.radius_mm (None when not published)
        if name.startswith("_"):
            raise AttributeError(name)
        values = object.__getattribute__(self, "values")
        if name in values:
            return values[name]
        if name in {f for _, f in _SUMMARY_QUANTITIES.values()}:
            return None
        raise AttributeError(name)


@dataclass(frozen=True)
class MeasuredSummary:
    """Published measured values of one machine / paper (for when no trace exists)."""

    source: str
    description: str
    machine: str | None
    entries: tuple[SummaryEntry, ...]

    def of_kind(self, kind: str) -> tuple[SummaryEntry, ...]:
        return tuple(e for e in self.entries if e.kind == kind)

    @property
    def circles(self):
        return self.of_kind("circle")

    @property
    def blocks(self):
        return self.of_kind("block")

    @property
    def transitions(self):
        return self.of_kind("transition")

    @property
    def cycles(self):
        return self.of_kind("cycle")

    def __getitem__(self, entry_id: str) -> SummaryEntry:
        for e in self.entries:
            if e.id == entry_id:
                return e
        raise KeyError(entry_id)


def _split_quantity_key(key: str) -> tuple[str, str] | None:
    """``steady_feed_m_min`` -> (``steady_feed``, ``m_min``) for a known base, longest base first."""
    for base in sorted(_SUMMARY_QUANTITIES, key=len, reverse=True):
        if key.startswith(base + "_"):
            return base, key[len(base) + 1:]
    return None


def summary_from_dict(data: Mapping[str, Any], file: str = "<summary>") -> MeasuredSummary:
    """Validate a parsed summary TOML; every problem is collected into one
    :class:`~ncsim.errors.MeasuredDataError` naming its key path (``circle[2].G_um``)."""
    c = Problems(file, MeasuredDataError)
    c.unknown(data, "", ("summary", *_ENTRY_QUANTITIES),
              f"unknown table (known: summary, {', '.join(_ENTRY_QUANTITIES)})")
    head = c.table(data, "summary")
    c.unknown(head, "summary", ("description", "machine", "source"),
              "unknown key (known: description, machine, source)")
    info = {k: c.string(head, "summary", k) for k in ("description", "machine", "source")}
    entries: list[SummaryEntry] = []
    seen: dict[str, str] = {}
    for kind in _ENTRY_QUANTITIES:
        items = data.get(kind, [])
        if not isinstance(items, list) or not all(isinstance(x, dict) for x in items):
            c.add(kind, f"must be an array of tables ([[{kind}]])")
            continue
        for n, item in enumerate(items):
            entry = _summary_entry(c, kind, f"{kind}[{n}]", item, seen)
            if entry is not None:
                entries.append(entry)
    c.raise_if_any()
    return MeasuredSummary(source=info["source"] or file, description=info["description"] or "",
                           machine=info["machine"], entries=tuple(entries))


def _summary_entry(c: Problems, kind: str, path: str, item: Mapping[str, Any],
                   seen: dict[str, str]) -> SummaryEntry | None:
    """One ``[[kind]]`` table (its problems go to ``c``; None if it has any)."""
    n_problems = len(c.items)
    values: dict[str, float] = {}
    flags: dict[str, bool] = {}
    ints: dict[str, int] = {}
    text: dict[str, str] = {}
    for key in item:
        if key in _COMMON_TEXT_KEYS:
            value = c.string(item, path, key, non_empty=True)
            if value is not None:
                text[key] = value
        elif key in _COMMON_BOOL_KEYS:
            value = c.boolean(item, path, key)
            if value is not None:
                flags[key] = value
        elif key in _ENTRY_INT_KEYS[kind]:
            value = c.integer(item, path, key, minimum=0)
            if value is not None:
                ints[key] = value
        else:
            _summary_quantity(c, kind, path, item, key, values)
    if "id" not in item:
        c.add(f"{path}.id", "missing key")
    elif "id" in text:
        if text["id"] in seen:
            c.add(f"{path}.id", f"duplicate id {text['id']!r} (also {seen[text['id']]})")
        seen.setdefault(text["id"], path)
    given = {split[0] for split in map(_split_quantity_key, item) if split is not None}
    for base in _REQUIRED_QUANTITIES.get(kind, ()):
        if base not in given:
            c.add(f"{path}.{_SUMMARY_QUANTITIES[base][1]}", "missing key" + (
                " (a circle needs its nominal radius)" if kind == "circle" else ""))
    if values.get("G_um", 0.0) < 0:
        c.add(f"{path}.G_um", "circularity G cannot be negative")
    if "Fmax_um" in values and "Fmin_um" in values and values["Fmax_um"] < values["Fmin_um"]:
        c.add(f"{path}.Fmax_um", "Fmax is below Fmin")
    if len(c.items) > n_problems:
        return None
    return SummaryEntry(kind=kind, id=text["id"], values=values, flags=flags, ints=ints,
                        program=text.get("program"), trajectory=text.get("trajectory"),
                        source=text.get("source", ""), note=text.get("note", ""))


def _summary_quantity(c: Problems, kind: str, path: str, item: Mapping[str, Any], key: str,
                      values: dict[str, float]) -> None:
    """A quantity key ``<base>_<unit>`` of an entry, stored in ``values`` in its stored unit."""
    allowed = _ENTRY_QUANTITIES[kind]
    split = _split_quantity_key(key)
    if split is None or split[0] not in allowed:
        known = ", ".join(sorted(f"{b}_<unit>" for b in allowed))
        c.add(f"{path}.{key}", f"unknown key (known quantities for [[{kind}]]: {known})")
        return
    base, suffix = split
    factors, stored = _SUMMARY_QUANTITIES[base]
    if suffix not in factors:
        c.add(f"{path}.{key}", f"unknown unit '{suffix}' for {base} (use {base}_"
                               + f" or {base}_".join(factors) + ")")
        return
    check = (positive if base in _POSITIVE_QUANTITIES
             else non_negative if base.endswith("feed") else finite)
    value = c.number(item, path, key, check=check, convert=lambda v: v * factors[suffix])
    if value is None:
        return
    if stored in values:
        c.add(f"{path}.{key}", f"{base} given twice (in two units)")
        return
    values[stored] = value


def load_measured_summary(file) -> MeasuredSummary:
    """Load published measured values from a TOML file (schema: ``measured/paper_table3.toml``).

    Tables ``[[circle]]`` (ISO 230-4 circular tests: ``radius_mm``, ``programmed_feed_m_min``,
    ``steady_feed_m_min``, ``G_um``, ``Fmax_um``, ``Fmin_um``, ``normal_accel_m_s2`` ...),
    ``[[block]]`` (per-block feeds), ``[[transition]]`` (block-transition feeds) and
    ``[[cycle]]`` (cycle times); every key carries its unit (``_m_min``, ``_mm_min``,
    ``_mm_s``; ``_um``; ``_s``, ``_ms``). Each entry has an ``id`` and optionally ``program``,
    ``trajectory``, ``source`` (citation) and ``note``.
    """
    name = str(file)
    text = read_text(file, "file", error=MeasuredDataError)
    return summary_from_dict(parse_toml(text, name, error=MeasuredDataError), name)
