"""Effects: model components a base model may lack, each with physically named parameters.

The sim-to-real gap diagnosis (``ncsim.gap.diagnose``) starts from a *base model* -- a
:class:`Model` with some effects switched off -- and asks, for every effect of the library, how
much of the gap closes once that effect is added with fitted parameters. An effect is a small
object with

* ``name`` (CLI and JSON key), ``title``, ``meaning`` (the physics, with the paper equation),
* ``params``: :class:`Param` (name with unit, bounds, search scale, meaning),
* ``current(model)``: the values the model uses now (machine file; the initial guess),
* ``apply(model, values)``: the model with the effect switched on at those values,
* ``remove(model)``: the model with the effect switched off (to build base models),
* for planner effects ``apply_planner(machine, options, values) -> (machine, options)``;
  for trace (post-processing) effects ``apply_to_trace(trace, t_s, pos_mm, values) -> pos_mm``.

Planner effects change the :class:`~ncsim.machine.MachineSpec` and the
:class:`~ncsim.motion.ModelOptions`, so the planner (``ncsim.plan``) re-plans. Trace effects act
on the sampled set point: what the axes and the structure do to the commanded positions,
by the closed forms of :mod:`ncsim.gap.closedforms` (``servo_lag``, ``compliance``,
``servo_delay``, ``recorder``).

The effects real machines differ by are planner effects on machine and operator settings
(:class:`MachineValue`): the rapid and feed overrides, the axis velocity (MD32000) and
accelerations (MD32300), the reset path mode with its exact-stop settle and G64 corner jump
(MD20150, MD36010, MD20552, MD32310), the G64 corner jump alone and the compressor on or off
(MD20150 group 30); each names its machine data and writes it back through the
machine file.

Units: parameters are in the units people set machines in (m/s^3, ms, 1/s, um per m/s^2) and
say so in their names; everything is converted to mm and s at the boundary of ``apply``.

Base models (``make_base``): ``full`` (the planner's full model, no servo or structure),
``axis-only`` (axis limits only: no NCU path jerk, no transition crossing, no cycle-time limit,
no look-ahead limit -- the paper's §5.2.1 static look-ahead plus controlled-jerk ramps), and
``full-minus-EFFECT`` for any planner effect (``full-minus-transition`` ...).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Callable, Mapping

import numpy as np

from ncsim.errors import UsageError
from ncsim.gap.closedforms import (compliance_offset_mm, corner_jumps_mm_s, delayed_mm,
                                   overload_factors_for, sample_mean_mm, servo_lag_mm)
from ncsim.machine import MachineSpec, StructureSpec
from ncsim.motion import FULL_MODEL, ModelOptions
from ncsim.path import BRISK, COMPRESSOR_NAMES, SOFT
from ncsim.machine import COMPRESSOR_CODES, PATH_MODES, path_mode_name
from ncsim.units import (m_min_to_mm_s, m_s2_to_mm_s2, m_s3_to_mm_s3, mm_s2_to_m_s2, mm_s3_to_m_s3,
                         mm_s_to_m_min, ms_to_s, percent_to_share, s2_to_um_per_m_s2, s_to_ms,
                         share_to_percent, um_per_m_s2_to_s2)

# ---------------------------------------------------------------------------------------------
# Parameters and models
# ---------------------------------------------------------------------------------------------

ACCEL_MODE_CHOICES = {"SOFT": SOFT, "BRISK": BRISK}


@dataclass(frozen=True)
class Param:
    """One fitted parameter of an effect.

    ``kind``: ``"float"`` (searched between ``low`` and ``high``, on a log scale when ``log``),
    ``"int"`` (an integer in [low, high]) or ``"choice"`` (one of ``choices``, strings).
    ``fixed_unless_command``: only identifiable when the measured trace has commanded
    positions (e.g. the feed-forward weight, see ``servo_lag``); held at ``default`` otherwise.
    """

    name: str
    unit: str
    low: float
    high: float
    meaning: str
    kind: str = "float"
    log: bool = True
    choices: tuple[str, ...] = ()
    default: float | str | None = None
    fixed_unless_command: bool = False

    def clip(self, value):
        if self.kind == "choice":
            if value not in self.choices:
                raise UsageError(f"parameter {self.name}: {value!r} is not one of {', '.join(self.choices)}")
            return value
        v = float(value)
        if not math.isfinite(v):
            raise UsageError(f"parameter {self.name} must be a finite number, got {value!r}")
        v = min(max(v, self.low), self.high)
        return int(round(v)) if self.kind == "int" else v


@dataclass(frozen=True)
class Model:
    """A simulation model: machine, planner options and trace (post-processing) effects.

    ``post`` holds ``(effect name, ((param, value), ...))`` in the order they act on the set
    point (servo before structure: the structure deflects under what the drives do)."""

    machine: MachineSpec
    options: ModelOptions = FULL_MODEL
    post: tuple[tuple[str, tuple[tuple[str, object], ...]], ...] = ()

    def post_values(self, name: str) -> dict | None:
        for n, values in self.post:
            if n == name:
                return dict(values)
        return None

    def with_post(self, name: str, values: Mapping[str, object]) -> "Model":
        items = tuple(sorted(values.items()))
        post = [p for p in self.post if p[0] != name] + [(name, items)]
        post.sort(key=lambda p: POST_ORDER.index(p[0]) if p[0] in POST_ORDER else len(POST_ORDER))
        return replace(self, post=tuple(post))

    def without_post(self, name: str) -> "Model":
        return replace(self, post=tuple(p for p in self.post if p[0] != name))

    @property
    def planner_key(self):
        """What the planner depends on (hashable): re-plan only when this changes."""
        return (self.machine, self.options)


#: trace effects in the order they act: the drives, the structure, then the recorder (which
#: filters whatever it records, command or actual)
POST_ORDER = ("servo_delay", "servo_lag", "compliance", "recorder")


def _with_jumps(machine: MachineSpec, jumps_mm_s) -> MachineSpec:
    """The machine with MD32310 set so that the axes jump by ``jumps_mm_s`` at G64 corners."""
    return machine.with_axes(max_accel_ovl_factor=overload_factors_for(
        jumps_mm_s, machine.max_accel_mm_s2, machine.ncu.ipo_cycle_s))


def _jumps(machine: MachineSpec) -> np.ndarray:
    return corner_jumps_mm_s(machine.max_accel_mm_s2, machine.max_accel_ovl_factor,
                             machine.ncu.ipo_cycle_s)


def _plane_ratio(values: np.ndarray) -> np.ndarray:
    """Per-axis factors relative to X (Y and Z keep their machine-file ratio to X)."""
    return values / values[0]


@dataclass(frozen=True)
class NcuSetting:
    """The machine's ``[ncu]`` value ``field`` as a parameter: ``to_param`` converts it to the
    parameter's unit, ``to_machine`` back."""

    field: str
    to_param: Callable = float
    to_machine: Callable = float

    def get(self, machine: MachineSpec):
        return self.to_param(getattr(machine.ncu, self.field))

    def set(self, machine: MachineSpec, value) -> MachineSpec:
        return machine.with_ncu(**{self.field: self.to_machine(value)})


@dataclass(frozen=True)
class XAxisSetting:
    """The X axis's value of the axis field ``field`` as a parameter (converted as
    :class:`NcuSetting`); setting it, Y and Z keep their machine-file ratio to X."""

    field: str
    to_param: Callable = float
    to_machine: Callable = float

    def get(self, machine: MachineSpec):
        return self.to_param(float(getattr(machine, self.field)[0]))

    def set(self, machine: MachineSpec, value) -> MachineSpec:
        ratio = _plane_ratio(np.array(getattr(machine, self.field)))
        return machine.with_axes(**{self.field: self.to_machine(value) * ratio})


# ---------------------------------------------------------------------------------------------
# Effects
# ---------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Effect:
    """Base of the library's effects (see the module docstring). A planner effect whose one
    parameter is one machine value names it in ``setting`` and needs no class of its own."""

    name: str
    title: str
    meaning: str
    params: tuple[Param, ...]
    kind: str = "planner"          # "planner" or "trace"
    option: str | None = None      # the ModelOptions switch of a planner effect
    command_only: bool = False     # only meaningful on command-vs-actual data (the servo part)
    setting: NcuSetting | XAxisSetting | None = None   # the machine value of its parameter

    # -- common API --------------------------------------------------------------------------
    def param(self, name: str) -> Param:
        for p in self.params:
            if p.name == name:
                return p
        raise UsageError(f"effect {self.name} has no parameter {name!r} "
                         f"(it has: {', '.join(p.name for p in self.params)})")

    def check(self, values: Mapping[str, object]) -> dict:
        """Values for every parameter (missing ones from ``default``), clipped to the bounds."""
        out = {}
        for p in self.params:
            if p.name in values:
                out[p.name] = p.clip(values[p.name])
            elif p.default is not None:
                out[p.name] = p.default
            else:
                raise UsageError(f"effect {self.name}: missing parameter {p.name}")
        unknown = set(values) - {p.name for p in self.params}
        if unknown:
            raise UsageError(f"effect {self.name}: unknown parameter {sorted(unknown)[0]!r}")
        return out

    def is_active(self, model: Model) -> bool:
        if self.kind == "trace":
            return model.post_values(self.name) is not None
        return bool(getattr(model.options, self.option))

    def current(self, model: Model) -> dict:
        return {self.params[0].name: self.setting.get(model.machine)}

    def apply(self, model: Model, values: Mapping[str, object]) -> Model:
        v = self.check(values)
        if self.kind == "trace":
            return model.with_post(self.name, v)
        machine, options = self.apply_planner(model.machine, model.options, v)
        return replace(model, machine=machine, options=options)

    def remove(self, model: Model) -> Model:
        if self.kind == "trace":
            return model.without_post(self.name)
        return replace(model, options=replace(model.options, **{self.option: False}))

    def apply_planner(self, machine: MachineSpec, options: ModelOptions, values):
        return self.setting.set(machine, values[self.params[0].name]), self.switched_on(options)

    def without(self, model: Model, base: Model) -> Model:
        """``model`` with this effect as in ``base`` (a combined model pruned): switched off
        or removed when ``base`` lacks it, else at ``base``'s values."""
        if not self.is_active(base) and (self.kind == "trace" or self.option is not None):
            return self.remove(model)
        return self.apply(model, self.check(self.current(base)))

    def switched_on(self, options: ModelOptions) -> ModelOptions:
        """The planner options with this effect's switch on (a setting without one: as they are)."""
        return options if self.option is None else replace(options, **{self.option: True})

    def apply_to_trace(self, trace, t_s: np.ndarray, pos_mm: np.ndarray, values) -> np.ndarray:
        raise NotImplementedError

    def describe(self) -> dict:
        return {"effect": self.name, "title": self.title, "meaning": self.meaning,
                "kind": self.kind,
                "params": [{"name": p.name, "unit": p.unit, "low": p.low, "high": p.high,
                            "kind": p.kind, "choices": list(p.choices), "meaning": p.meaning}
                           for p in self.params]}


class NcuPathJerk(Effect):
    def current(self, model):
        return {"j_tcurv_m_s3": mm_s3_to_m_s3(model.machine.ncu.tangential_jerk_mm_s3)}

    def apply_planner(self, machine, options, v):
        share = machine.ncu.tangential_jerk_share
        m = machine.with_ncu(curvilinear_jerk_mm_s3=m_s3_to_mm_s3(v["j_tcurv_m_s3"]) / share)
        return m, self.switched_on(options)


class CycleTimeLimit(Effect):
    def apply_planner(self, machine, options, v):
        # the G64 corner jump A (MD32310 - 1) t_IPO is corner_jump's parameter: keep it
        m, options = super().apply_planner(machine, options, v)
        return _with_jumps(m, _jumps(machine)), options


#: the X-axis acceleration (MD32300), parameter of accel_mode
X_AXIS_ACCEL = XAxisSetting("max_accel_mm_s2", mm_s2_to_m_s2, m_s2_to_mm_s2)


class AccelMode(Effect):
    def is_active(self, model):
        return model.options.accel_mode is not None

    def current(self, model):
        mode = model.options.accel_mode
        name = {SOFT: "SOFT", BRISK: "BRISK"}.get(mode, "SOFT")
        return {"mode": name, "axis_accel_m_s2": X_AXIS_ACCEL.get(model.machine)}

    def remove(self, model):
        return replace(model, options=replace(model.options, accel_mode=None))

    def apply_planner(self, machine, options, v):
        m = X_AXIS_ACCEL.set(machine, v["axis_accel_m_s2"])
        return m, replace(options, accel_mode=ACCEL_MODE_CHOICES[v["mode"]])


class ServoLag(Effect):
    def current(self, model):
        kv = np.asarray(model.machine.position_gain_1_s, dtype=float)
        post = model.post_values(self.name) or {}
        return {"kv_1_s": post.get("kv_1_s", float(kv[0]) if np.isfinite(kv[0]) else 30.0),
                "ffw_weight": post.get("ffw_weight", 0.0)}

    def apply_to_trace(self, trace, t_s, pos_mm, v):
        return servo_lag_mm(t_s, pos_mm, float(v["kv_1_s"]), float(v["ffw_weight"]))


class Compliance(Effect):
    def current(self, model):
        post = model.post_values(self.name) or {}
        c = s2_to_um_per_m_s2(model.machine.structure.radial_compliance_mm_per_mm_s2)
        return {"compliance_um_per_m_s2": post.get("compliance_um_per_m_s2", c)}

    def apply_to_trace(self, trace, t_s, pos_mm, v):
        c = um_per_m_s2_to_s2(float(v["compliance_um_per_m_s2"]))  # mm/(mm/s^2) = s^2
        return pos_mm + compliance_offset_mm(trace.acc_mm_s2, c)


class ServoDelay(Effect):
    def current(self, model):
        post = model.post_values(self.name) or {}
        return {"delay_ms": post.get("delay_ms", 0.0)}

    def apply_to_trace(self, trace, t_s, pos_mm, v):
        return delayed_mm(t_s, pos_mm, ms_to_s(float(v["delay_ms"])))


@dataclass(frozen=True)
class MachineValue(Effect):
    """A planner effect that is a machine or operator setting rather than a model switch: it
    is "active" when the setting differs from its neutral value (``neutral`` of the first
    parameter, e.g. 100 % override); ``remove`` restores the neutral value. Settings without a
    neutral value (an axis velocity) are always active and cannot be removed."""

    neutral: object = None

    def is_active(self, model):
        if self.neutral is None:
            return True
        return self.current(model)[self.params[0].name] != self.neutral

    def remove(self, model):
        if self.neutral is None:
            return model
        values = dict(self.current(model), **{self.params[0].name: self.neutral})
        machine, options = self.apply_planner(model.machine, model.options, self.check(values))
        return replace(model, machine=machine, options=options)


@dataclass(frozen=True)
class AxisAccel(MachineValue):
    def current(self, model):
        a = model.machine.max_accel_mm_s2
        return {"xy_accel_m_s2": mm_s2_to_m_s2(float(a[0])), "z_accel_m_s2": mm_s2_to_m_s2(float(a[2]))}

    def apply_planner(self, machine, options, v):
        old = np.array(machine.max_accel_mm_s2)
        x = m_s2_to_mm_s2(v["xy_accel_m_s2"])
        new = np.array([x, x * old[1] / old[0], m_s2_to_mm_s2(v["z_accel_m_s2"])])
        # the G64 corner jump A (MD32310 - 1) t_IPO is fitted on its own (corner_jump): keep it
        return _with_jumps(machine.with_axes(max_accel_mm_s2=new), _jumps(machine)), options


@dataclass(frozen=True)
class ResetPathMode(MachineValue):
    """Changes what the interpreter does (MD20150 is applied to the modal state), so a model
    with another reset mode needs the program interpreted again (``diagnose.ModelCache``)."""

    neutral: object = "G60"

    def current(self, model):
        ncu = model.machine.ncu
        mode = path_mode_name(ncu.reset_path_mode)
        return {"path_mode": mode if mode in RESET_MODE_CHOICES else "G64",
                "settle_ms": s_to_ms(ncu.exact_stop_fine_settle_s),
                **EFFECTS["corner_jump"].current(model)}

    def apply_planner(self, machine, options, v):
        mode = PATH_MODES[v["path_mode"]]
        if mode == 64 and machine.ncu.reset_path_mode != 60:
            mode = machine.ncu.reset_path_mode     # "continuous path": the machine's own G64x
        m = machine.with_ncu(reset_path_mode=mode,
                             exact_stop_fine_settle_s=ms_to_s(v["settle_ms"]),
                             exact_pos_mode_g0_to_g1=1)
        # the corner velocity is part of the continuous-path hypothesis (it changes nothing
        # under exact stop, where every corner stops)
        return EFFECTS["corner_jump"].apply_planner(m, options, v)


@dataclass(frozen=True)
class CornerJump(MachineValue):
    def current(self, model):
        return {"corner_jump_mm_s": float(_jumps(model.machine)[0])}

    def apply_planner(self, machine, options, v):
        # Y and Z keep their machine-file ratio to X (equal MD32310: in proportion to A)
        now = _jumps(machine)
        ratio = (now / now[0] if now[0] > 0
                 else np.asarray(machine.max_accel_mm_s2) / machine.max_accel_mm_s2[0])
        return _with_jumps(machine, v["corner_jump_mm_s"] * ratio), options


#: the X-axis jerk (MD32431 $MA_MAX_AX_JERK), parameter of corner_law
X_AXIS_JERK = XAxisSetting("max_jerk_mm_s3", mm_s3_to_m_s3, m_s3_to_mm_s3)


def continuous_path(machine: MachineSpec) -> MachineSpec:
    """The machine running continuous path (G64) where a program sets no path mode: the
    group-10 reset value (MD20150 $MC_GCODE_RESET_VALUES) G64 unless it already is a G64x, and
    the stop in the exact-stop window at G0<->G1 changes (MD20552 = 1), as
    :class:`ResetPathMode`'s G64 hypothesis, the settle time held."""
    if machine.ncu.reset_path_mode != 60:
        return machine
    return machine.with_ncu(reset_path_mode=64, exact_pos_mode_g0_to_g1=1)


def path_jerk_at_least(machine: MachineSpec, jerk_mm_s3: float) -> MachineSpec:
    """The machine whose NCU path jerk (J_tcurv = J_curv r_jct, paper eq. 10; cf. MD20600
    $MC_MAX_PATH_JERK) is at least ``jerk_mm_s3``: a ramp jerk fitted on the lines of a
    recording is the path jerk there, so the NCU's limit cannot be below it."""
    ncu = machine.ncu
    if ncu.tangential_jerk_mm_s3 >= jerk_mm_s3:
        return machine
    return machine.with_ncu(curvilinear_jerk_mm_s3=jerk_mm_s3 / ncu.tangential_jerk_share)


@dataclass(frozen=True)
class CornerLaw(Effect):
    """The G64 corner law of a machine: acceleration mode, axis velocity jump and ramp jerk
    fitted together (see its ``meaning``). Sets continuous path as the reset mode
    (:func:`continuous_path`), so a model with it plans on the program interpreted again."""

    def is_active(self, model):
        return model.options.accel_mode is not None

    def current(self, model):
        mode = {SOFT: "SOFT", BRISK: "BRISK"}.get(model.options.accel_mode, "SOFT")
        return {"mode": mode, "corner_jump_mm_s": float(_jumps(model.machine)[0]),
                "ramp_jerk_m_s3": X_AXIS_JERK.get(model.machine)}

    def remove(self, model):
        return replace(model, options=replace(model.options, accel_mode=None))

    def without(self, model, base):
        """Every value it sets back at ``base``'s: the mode, the reset path mode and its
        G0<->G1 window, the axis jerks and jumps, the NCU path jerk."""
        b, m = base.machine, model.machine
        m = m.with_ncu(reset_path_mode=b.ncu.reset_path_mode,
                       exact_pos_mode_g0_to_g1=b.ncu.exact_pos_mode_g0_to_g1,
                       curvilinear_jerk_mm_s3=b.ncu.curvilinear_jerk_mm_s3)
        m = m.with_axes(max_jerk_mm_s3=np.array(b.max_jerk_mm_s3),
                        max_accel_ovl_factor=np.array(b.max_accel_ovl_factor))
        return replace(model, machine=m,
                       options=replace(model.options, accel_mode=base.options.accel_mode))

    def apply_planner(self, machine, options, v):
        m = continuous_path(machine)
        old = np.array(m.max_jerk_mm_s3, dtype=np.float64)
        x = m_s3_to_mm_s3(v["ramp_jerk_m_s3"])
        # the plane's axes make the corners: X at the value, Y at its ratio to X, Z held
        m = m.with_axes(max_jerk_mm_s3=np.array([x, x * old[1] / old[0], old[2]]))
        m = path_jerk_at_least(m, float(np.max(m.max_jerk_mm_s3)))
        m, options = EFFECTS["corner_jump"].apply_planner(m, options, v)
        return m, replace(options, accel_mode=ACCEL_MODE_CHOICES[v["mode"]],
                          jerk_limited_ramps=True)


#: the group-30 values the compressor effect chooses among (COMPSURF is simulated as COMPCAD)
COMPRESSOR_CHOICES = ("COMPOF", "COMPON", "COMPCURV", "COMPCAD")


def compressor_code(mode: str) -> int:
    """The group-30 reset value (MD20150 $MC_GCODE_RESET_VALUES) that runs the NC block
    compressor ``mode`` where a program selects none (840D sl Job Planning "NC block
    compression", B1 "Compressor functions"; its physics in ``ncsim.plan.compressor``). The
    tolerance MD33100 stays the machine file's: it moves the curve by micrometres only."""
    return COMPRESSOR_CODES[mode]


def compressor_mode(code: int) -> str:
    """The inverse of :func:`compressor_code` (COMPSURF is simulated as COMPCAD)."""
    name = COMPRESSOR_NAMES[int(code)]
    return "COMPCAD" if name == "COMPSURF" else name


class Recorder(Effect):
    def current(self, model):
        post = model.post_values(self.name) or {}
        return {"samples": post.get("samples", 10)}

    def apply_to_trace(self, trace, t_s, pos_mm, v):
        return sample_mean_mm(t_s, pos_mm, int(v["samples"]))


RESET_MODE_CHOICES = ("G60", "G64")

EFFECTS: dict[str, Effect] = {e.name: e for e in (
    NcuPathJerk(
        "ncu_path_jerk", "NCU curvilinear-jerk limit",
        "The NCU limits the tangential jerk on arcs to J_tcurv = J_curv x r_jct (paper eq. 10), "
        "so the steady feed on a circle is V_Jtcurv = (J_tcurv R^2)^(1/3) (eq. 11, 12), and phases "
        "A/C ramp at no more than J_tcurv.",
        (Param("j_tcurv_m_s3", "m/s^3", 0.5, 60.0, "J_curv x r_jct, the tangential jerk the NCU "
               "allows on a curved path (paper: 10 x 0.6 = 6 m/s^3)"),),
        option="ncu_path_jerk"),
    Effect(
        "transition", "curvature-jump transition crossing",
        "Between tangent blocks whose curvature jumps, the feed drops to "
        "V_fr = sqrt(R1 R2 J_t dt / |R1 - R2|) (paper eq. 13) with J_t from the axis jerks at the "
        "junction's direction (eq. 15): the jump in normal acceleration must take dt.",
        (Param("transition_time_ms", "ms", 0.5, 100.0, "dt of eq. 13, the time allowed to cross "
               "the curvature jump (paper: one interpolation cycle, 12 ms)"),),
        option="transition_crossing", setting=NcuSetting("transition_time_s", s_to_ms, ms_to_s)),
    CycleTimeLimit(
        "cycle_time", "interpolation-cycle limit",
        "Every block lasts at least one interpolation cycle: V_tcy = L / t_cy (paper eq. 6), "
        "which caps the feed on short blocks. t_cy also sets the G64 corner velocity jump and "
        "the BRISK jerk.",
        (Param("ipo_cycle_ms", "ms", 0.5, 100.0, "t_cy, the interpolation cycle (paper: 12 ms)"),),
        option="cycle_time_limit", setting=NcuSetting("ipo_cycle_s", s_to_ms, ms_to_s)),
    Effect(
        "axis_jerk", "axis-jerk-limited phases A/C",
        "Phases A and C of the feed law are controlled-jerk ramps at the smallest tangential jerk "
        "the axes allow on the block (paper §5.2.2, eq. 9, 16: the acceleration rises and falls "
        "linearly); without it the ramps are acceleration-limited. The axis jerk also enters the "
        "steady feed (eq. 4) and the transition feeds (eq. 15).",
        (Param("axis_jerk_m_s3", "m/s^3", 0.3, 200.0, "maximum X-axis jerk J_mx (Y and Z keep "
               "their machine-file ratio to X; paper: 5 m/s^3)"),),
        option="jerk_limited_ramps",
        setting=XAxisSetting("max_jerk_mm_s3", mm_s3_to_m_s3, m_s3_to_mm_s3)),
    Effect(
        "lookahead", "limited look-ahead depth",
        "The NC prepares only D blocks ahead and must be able to stop at the end of the last "
        "one (840D dynamic look-ahead, paper §3.2): on short blocks the feed is capped by the "
        "braking distance over D blocks, ramps up inside each block and falls back.",
        (Param("lookahead_blocks", "blocks", 1, 128, "D, the number of blocks prepared ahead",
               kind="int"),),
        option="lookahead", setting=NcuSetting("lookahead_blocks", int, int)),
    AccelMode(
        "accel_mode", "acceleration mode BRISK against SOFT",
        "SOFT ramps the feed at controlled jerk (paper §3.3.2, Fig. 3); BRISK at the full axis "
        "acceleration with no jerk limit (the jerk is A / t_cy), which shortens ramps and shakes "
        "the structure. Chooses the mode the machine really runs and the acceleration it uses.",
        (Param("mode", "", 0, 0, "acceleration mode the NC runs", kind="choice",
               choices=("SOFT", "BRISK")),
         Param("axis_accel_m_s2", "m/s^2", 0.2, 20.0, "maximum X-axis acceleration A_mx (Y and Z "
               "keep their machine-file ratio to X; paper: 2.5 m/s^2)")),
        option="accel_mode"),
    MachineValue(
        "rapid_override", "rapid traverse at a lower speed (rapid override)",
        "G0 runs at the axis-velocity limit along the line (MD32000 $MA_MAX_AX_VELO, eq. 7) "
        "times the rapid-traverse override the operator or the PLC set (840D V1 \"rapid "
        "traverse override\"). A recording made at 10 % override shows flat G0 plateaus at a "
        "tenth of the machine's rapid rate; the feed blocks are unchanged.",
        (Param("rapid_override_percent", "%", 1.0, 100.0, "rapid override in force "
               "(machine file: [ncu] rapid_override_percent)"),),
        setting=NcuSetting("rapid_override", share_to_percent, percent_to_share), neutral=100.0),
    MachineValue(
        "feed_override", "feed override",
        "G1/G2/G3 run at the programmed F times the feed override on the machine control "
        "panel (840D V1 \"feed override\", 0-120 %); the axis and NCU limits still apply to "
        "the overridden feed, so only blocks that reach F show it.",
        (Param("feed_override_percent", "%", 10.0, 150.0, "feed override in force "
               "(machine file: [ncu] feed_override_percent)"),),
        setting=NcuSetting("feed_override", share_to_percent, percent_to_share), neutral=100.0),
    MachineValue(
        "axis_velocity", "axis velocity limit",
        "Every axis is limited to its maximum velocity (MD32000 $MA_MAX_AX_VELO), so a block's "
        "feed is at most min_i V_mi / |u_i| (eq. 7): G0 runs there, and G1 blocks programmed "
        "faster are capped. Unlike a rapid override it also caps fast feed blocks.",
        (Param("axis_velocity_m_min", "m/min", 0.5, 120.0, "maximum X-axis velocity V_mx (Y and "
               "Z keep their machine-file ratio to X)"),),
        setting=XAxisSetting("max_velocity_mm_s", mm_s_to_m_min, m_min_to_mm_s)),
    AxisAccel(
        "axis_accel", "axis acceleration",
        "The acceleration the ramps and the normal acceleration on curves may use (MD32300 "
        "$MA_MAX_AX_ACCEL, eq. 2, 8): tangential ramps at min_i A_mi / |t_i|, whatever the "
        "acceleration mode the program selects (BRISK: at that acceleration; SOFT: jerk-"
        "limited up to it). The plane axes X, Y and the infeed axis Z are fitted apart (a "
        "vertical axis carries the head and often runs another acceleration); the G64 corner "
        "jump is held (it is corner_jump's parameter).",
        (Param("xy_accel_m_s2", "m/s^2", 0.05, 20.0, "maximum X-axis acceleration A_mx (Y keeps "
               "its machine-file ratio to X)"),
         Param("z_accel_m_s2", "m/s^2", 0.05, 20.0, "maximum Z-axis acceleration A_mz"))),
    ResetPathMode(
        "reset_mode", "exact stop or continuous path as the reset mode, with the settle time",
        "Where a program sets no path mode the 840D runs its reset value (MD20150 "
        "$MC_GCODE_RESET_VALUES, group 10): G60 stops at every block end and waits until the "
        "axes are inside the exact-stop window (G601: MD36010 $MA_STOP_LIMIT_FINE), G64 keeps "
        "the path speed across tangent junctions and slows at corners only (G64 corner law). "
        "Under G64 a G0<->G1 change still stops in the window (MD20552 "
        "$MC_EXACT_POS_MODE_G0_TO_G1 = 1). settle_ms is the time spent reaching the window. "
        "A continuous-path hypothesis is only whole with its corner velocity, so the G64 axis "
        "velocity jump (corner_jump) is fitted with it; it changes nothing under G60.",
        (Param("path_mode", "", 0, 0, "group-10 reset value", kind="choice",
               choices=RESET_MODE_CHOICES),
         Param("settle_ms", "ms", 0.0, 100.0, "time standing in the exact-stop window after the "
               "set point stops (machine file: exact_stop_fine_settle_ms)", log=False),
         Param("corner_jump_mm_s", "mm/s", 0.1, 200.0, "velocity jump the X axis may make at a "
               "G64 corner (as corner_jump)"))),
    MachineValue(
        "compressor", "NC block compressor on or off (COMPON/COMPCURV/COMPCAD)",
        "Where a program selects no compressor the 840D runs the reset value of G group 30 "
        "(MD20150 $MC_GCODE_RESET_VALUES; COMPOF as delivered). With COMPON/COMPCURV (10 blocks "
        "per polynomial) or COMPCAD (any number, corners above SD42470 kept) runs of G1 blocks "
        "no longer than MD20170 become one curve within MD33100 $MA_COMPRESS_POS_TOL (MD20482 "
        "$MC_COMPRESSOR_MODE): eq. 6 limits the joined block, not each tiny block, and the kinks "
        "become curvature. Changes nothing on a program without short G1 blocks.",
        (Param("compressor_mode", "", 0, 0, "group-30 reset value (machine file: [ncu] "
               "reset_compressor)", kind="choice", choices=COMPRESSOR_CHOICES),),
        setting=NcuSetting("reset_compressor", compressor_mode, compressor_code),
        neutral="COMPOF"),
    CornerJump(
        "corner_jump", "corner velocity in continuous-path mode (G64 axis velocity jump)",
        "At a G64 corner each axis may jump in velocity by A_i (MD32310 $MA_MAX_ACCEL_OVL_FACTOR "
        "- 1) t_IPO (840D B1, continuous-path mode), so the corner is crossed at "
        "V = min_i jump_i / |t2_i - t1_i|: a 90 deg corner at the X jump, 45 deg at jump / 0.765. "
        "Acts only on corners run in continuous-path mode.",
        (Param("corner_jump_mm_s", "mm/s", 0.1, 200.0, "velocity jump the X axis may make at a "
               "corner (machine file: max_accel_ovl_factor = 1 + jump / (A t_IPO) per axis, "
               "MD32310)"),)),
    CornerLaw(
        "corner_law", "corner law: acceleration mode, G64 velocity jump and ramp jerk together",
        "How a machine in continuous-path mode (G64) crosses a corner, from the corners of a "
        "recording: the feed drops to the corner velocity V = min_i jump_i / |t2_i - t1_i| "
        "(840D B1 \"continuous-path mode\", MD32310 $MA_MAX_ACCEL_OVL_FACTOR: the axis velocity "
        "jump A_i (f_i - 1) t_IPO) on a ramp shaped by the acceleration mode (MD20150 "
        "$MC_GCODE_RESET_VALUES group 21, SOFT or BRISK; B2 \"acceleration\"): SOFT at the path "
        "jerk of the plane's axes (MD32431 $MA_MAX_AX_JERK of X and Y along the block; the NCU's "
        "path jerk is raised to it where lower), BRISK at the full acceleration (the jerk A / t_IPO). A "
        "corner of deflection theta costs about 2 (v - V)^1.5 / (v sqrt(J)) under SOFT and (v - V)^2 / (A v) under "
        "BRISK, so the losses of corners of two angles tell the jump from the jerk. The three "
        "are fitted together because each alone is degenerate with the others (a slower ramp "
        "and a lower corner velocity lose the same time at one corner). Premise: continuous "
        "path where the program sets none (MD20150 group 10 G64, G0<->G1 stops in the "
        "window, MD20552 = 1). The jerk at curvature jumps (MD32432 $MA_PATH_TRANS_JERK_LIM) "
        "is the transition effect's.",
        (Param("mode", "", 0, 0, "acceleration mode of the corner ramps (group-21 reset value, "
               "MD20150)", kind="choice", choices=("SOFT", "BRISK")),
         Param("corner_jump_mm_s", "mm/s", 0.1, 200.0, "velocity jump the X axis may make at a "
               "G64 corner (MD32310 = 1 + jump / (A t_IPO); Y and Z keep their ratio to X)"),
         Param("ramp_jerk_m_s3", "m/s^3", 0.3, 200.0, "maximum X-axis jerk J_mx of SOFT ramps "
               "(MD32431 $MA_MAX_AX_JERK; Y keeps its ratio to X, Z is held, and the NCU path "
               "jerk J_curv r_jct, cf. MD20600, is raised to the largest axis jerk where lower; "
               "no effect under BRISK)")),
        option="accel_mode"),
    ServoLag(
        "servo_lag", "servo lag: position loop Kv with or without feed forward",
        "The axes follow the set point through a P position loop of gain Kv with velocity "
        "feed-forward weight k_ff (FFWON: 1, FFWOF: 0): X/Xc = (k_ff s + Kv)/(s + Kv). The "
        "following error is (1 - k_ff) v / Kv and circles shrink by about "
        "(1 - k_ff^2) a_n / (2 Kv^2). On contour data only Kv / sqrt(1 - k_ff^2) is "
        "identifiable, so k_ff is held at 0 there (Kv is then the FFWOF-equivalent gain) and "
        "fitted only against commanded positions.",
        (Param("kv_1_s", "1/s", 3.0, 1000.0, "position-loop gain Kv (MD32200; 1 m/min/mm = "
               "16.7 1/s)"),
         Param("ffw_weight", "", 0.0, 1.0, "velocity feed-forward weight k_ff (MD32610)",
               log=False, default=0.0, fixed_unless_command=True)),
        kind="trace"),
    Compliance(
        "compliance", "structural compliance (centrifugal radial deviation)",
        "The structure between the drives and the tool yields under the centripetal "
        "acceleration: the tool moves outward by c a_n = c V^2 / R along the principal normal "
        "(paper §5.2, Table 3: Fmax grows with the feed). c = m / k = 1 / w_s^2 of the "
        "structural mode.",
        (Param("compliance_um_per_m_s2", "um/(m/s^2)", 1.0, 1000.0, "c, the outward deviation "
               "per unit normal acceleration"),),
        kind="trace"),
    ServoDelay(
        "servo_delay", "pure delay between command and actual",
        "The actual position is the command delayed by d: a dead time in the drives or a skew "
        "between the instants the command and the actual value are recorded. Invisible against "
        "a simulated path (the alignment absorbs any delay); a candidate of the servo part only.",
        (Param("delay_ms", "ms", 0.0, 200.0, "d, the delay", log=False),),
        kind="trace", command_only=True),
    Recorder(
        "recorder", "recorder low-pass (moving average before down-sampling)",
        "The recorder averages N raw samples before it keeps one (a 50 Hz trace made from "
        "500 Hz: 10 samples, 20 ms, stamped at their mean time), which cuts corners and smears "
        "ramps by about N h / 2. The model is compared after the same average of its samples "
        "h = 2 ms apart (the 840D trace's 500 Hz). A delay of the recorded channel against the "
        "NC clock is the alignment's clock offset (and between command and actual, "
        "servo_delay).",
        (Param("samples", "", 1, 64, "N, the raw samples averaged (window N x 2 ms)",
               kind="int"),),
        kind="trace"),
)}

#: planner effects, in the order the diagnosis lists them
PLANNER_EFFECTS = tuple(n for n, e in EFFECTS.items() if e.kind == "planner")
#: trace effects that act on a simulated path (the servo part adds ``servo_delay``)
TRACE_EFFECTS = tuple(n for n, e in EFFECTS.items() if e.kind == "trace" and not e.command_only)
#: what can shape a recorded command: the planner effects and the recorder's own filter
COMMAND_EFFECTS = PLANNER_EFFECTS + ("recorder",)
#: effects that change how the program is interpreted (they need the program, not a path)
REINTERPRETING = ("reset_mode", "compressor", "corner_law")


def get_effect(name: str) -> Effect:
    try:
        return EFFECTS[name]
    except KeyError:
        raise UsageError(f"unknown effect {name!r} (known: {', '.join(EFFECTS)})") from None


# ---------------------------------------------------------------------------------------------
# Base models
# ---------------------------------------------------------------------------------------------

AXIS_ONLY_OFF = ("ncu_path_jerk", "transition", "cycle_time", "lookahead")


def removable(name: str) -> bool:
    """A planner effect the model can be without (a switch, or a setting with a neutral
    value), so that ``full-minus-NAME`` is a base."""
    e = EFFECTS[name]
    return e.kind == "planner" and (e.option is not None or getattr(e, "neutral", None) is not None)


def base_names() -> tuple[str, ...]:
    return ("full", "axis-only") + tuple(f"full-minus-{n}" for n in PLANNER_EFFECTS if removable(n))


def make_base(machine: MachineSpec, base: str = "full") -> Model:
    """The named base model on ``machine`` (see the module docstring). Trace effects are never
    in a base: a base is what the planner predicts the set point to be."""
    full = Model(machine=machine, options=FULL_MODEL)
    if base == "full":
        return full
    if base == "axis-only":
        m = full
        for name in AXIS_ONLY_OFF:
            m = EFFECTS[name].remove(m)
        return m
    if base.startswith("full-minus-"):
        name = base[len("full-minus-"):].replace("-", "_")
        if name in EFFECTS and removable(name):
            return EFFECTS[name].remove(full)
    raise UsageError(f"unknown base model {base!r} (known: {', '.join(base_names())})")


def model_description(model: Model) -> dict:
    """JSON-able: which effects are on, with their current values."""
    out = {}
    for name, e in EFFECTS.items():
        if e.command_only and not e.is_active(model):
            continue
        out[name] = {"active": e.is_active(model),
                     "params": jsonable(e.current(model)) if e.is_active(model) or e.kind == "planner" else {}}
    return out


def jsonable(values: Mapping[str, object]) -> dict:
    """Parameter values as JSON types: strings stay, integers become int, the rest float."""
    return {k: (v if isinstance(v, str) else (int(v) if isinstance(v, (int, np.integer)) else float(v)))
            for k, v in values.items()}


def corrected_machine(model: Model) -> MachineSpec:
    """The machine file of a (fitted) model: planner parameters are already in the machine;
    a fitted Kv goes to every axis's ``position_gain_1_s``, a compliance to ``[structure]``.
    A forced acceleration mode (``accel_mode``, ``corner_law``) becomes the group-21 reset
    value ``[ncu] reset_accel_mode`` (MD20150), which holds where the program selects none.
    (The feed-forward weight and a delay have no machine-file key.)"""
    m = model.machine
    if model.options.accel_mode is not None:
        m = m.with_ncu(reset_accel_mode=int(model.options.accel_mode))
    lag = model.post_values("servo_lag")
    if lag is not None:
        m = m.with_axes(position_gain_1_s=float(lag["kv_1_s"]))
    comp = model.post_values("compliance")
    if comp is not None:
        m = replace(m, structure=StructureSpec(
            radial_compliance_mm_per_mm_s2=um_per_m_s2_to_s2(float(comp["compliance_um_per_m_s2"]))))
    return m


def apply_trace_effects(model: Model, trace, t_s: np.ndarray, pos_mm: np.ndarray) -> np.ndarray:
    """The set-point positions ``pos_mm`` (on the uniform grid ``t_s``) after the model's trace
    effects, in ``POST_ORDER``."""
    out = pos_mm
    for name, values in model.post:
        out = EFFECTS[name].apply_to_trace(trace, t_s, out, dict(values))
    return out
