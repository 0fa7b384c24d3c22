"""Independent time-stepping simulation of each axis's closed position loop (the "truth").

The planner gives the NC's *set point* (the commanded positions). A real axis follows it
through its position loop, its speed loop and a compliant structure. This module integrates
that chain in time, axis by axis, with a fixed step of at most 1 ms, so that the benchmark's
"measured" traces come from a model that shares nothing with the planner's closed forms.

Model of one axis (all axes vectorised; parameters may differ per axis)::

    position controller   u   = k_ff v_c + Kv (x_c - x_m)                 [mm/s]
    speed loop (1st order) T_v dv_m/dt = u - v_m - T_v f_c sgn(v_m)        (T_v > 0)
                          v_m = u                                         (T_v = 0, ideal)
    drive                 dx_m/dt = v_m
    structure             d2d/dt2 + 2 zeta w_s dd/dt + w_s^2 d = -a_m,    a_m = dv_m/dt
    tool (actual)         x = x_m + d

* ``x_c, v_c`` command position and velocity (a cubic Hermite interpolation of the sampled
  command, so the input is smooth between command samples);
* ``Kv`` the position-loop gain (840D MD32200 ``POSCTRL_GAIN``; 1 m/min/mm = 16.67 1/s) and
  ``k_ff`` the velocity feed-forward weight (FFWON: ``k_ff`` = 1, FFWOF: 0; MD32610);
* ``T_v`` the equivalent time constant of the closed speed loop (MD32810
  ``EQUIV_SPEEDCTRL_TIME``): a proportional speed controller on a rigid inertia ``J`` with
  gain ``K_p`` gives ``T_v = J / K_p``; a Coulomb friction force ``F_c`` then enters as the
  acceleration ``f_c = F_c / J`` (``friction_mm_s2``), which is what makes the quadrant
  glitches at velocity reversals. Friction is applied by operator splitting with a stick
  condition (Karnopp): it never reverses the velocity within a step;
* the structure is a mass on a spring between the drive (where the encoder is) and the tool:
  base excitation by the drive acceleration. Under a steady acceleration ``a`` the tool lags
  by ``d = -a / w_s^2 = -m a / k``; on a circle the drive acceleration points to the centre,
  so the tool deviates OUTWARD by ``A_n / w_s^2`` (the paper's "centrifugation", §5.2, §6.2).
  The "actual" position is the tool's: the paper's circular tests show this deviation.

Transfer function command -> tool (used by tests and by the gap analysis as a closed form)::

    H(s) = (k_ff s + Kv) / (T_v s^2 + s + Kv) * (2 zeta w_s s + w_s^2) / (s^2 + 2 zeta w_s s + w_s^2)

so a circle of angular rate W keeps its centre and has radius ``R |H(jW)|``: with FFWOF and an
ideal speed loop ``R / sqrt(1 + (W / Kv)^2)`` (shrinks), and with the structure alone
``R (1 + A_n / (w_s^2 R))`` to first order (grows).

Integration: classical RK4 at a fixed step ``dt_s`` (default 0.25 ms, at most 1 ms), the
command evaluated at the step and half-step instants; a kernel of ``ncsim.jit`` (plain Python on
short commands, numba above). The step must resolve the fastest pole (checked:
``dt * max(Kv, 1/T_v, w_s) <= 0.5``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace

import numpy as np
from scipy.interpolate import CubicHermiteSpline

from ncsim.errors import UsageError
from ncsim.gap.measured import MeasuredTrace
from ncsim.jit import njit

MAX_STEP_S = 1e-3
DEFAULT_STEP_S = 2.5e-4
_CHUNK_STEPS = 1 << 15
_STABLE_RATE = 0.5   # max (pole rate x dt) accepted


def _per_axis(value, name: str) -> tuple[float, float, float]:
    arr = np.broadcast_to(np.asarray(value, dtype=np.float64), (3,))
    return tuple(float(v) for v in arr)


@dataclass(frozen=True)
class ServoParams:
    """Axis servo and structure parameters (scalars, or one value per axis X Y Z).

    ``structure_freq_hz = inf`` means a rigid structure (no deflection)."""

    kv_1_s: float | tuple = 30.0               # position-loop gain Kv
    ffw_weight: float | tuple = 0.0            # velocity feed-forward weight (FFWON 1, FFWOF 0)
    velocity_loop_time_s: float | tuple = 0.0  # equivalent closed speed-loop time constant T_v
    structure_freq_hz: float | tuple = math.inf  # tool-on-spring natural frequency
    structure_damping: float | tuple = 0.05    # damping ratio zeta of that mode
    friction_mm_s2: float | tuple = 0.0        # Coulomb friction F_c / J (needs T_v > 0)

    def __post_init__(self) -> None:
        for f in fields(self):
            try:
                v = _per_axis(getattr(self, f.name), f.name)
            except ValueError:
                raise UsageError(f"ServoParams.{f.name} must be a number or 3 numbers, "
                                 f"got {getattr(self, f.name)!r}") from None
            object.__setattr__(self, f.name, v)
        checks = {"kv_1_s": lambda x: 0 < x < math.inf,
                  "ffw_weight": lambda x: 0 <= x <= 1.5,
                  "velocity_loop_time_s": lambda x: 0 <= x < math.inf,
                  "structure_freq_hz": lambda x: x > 0,
                  "structure_damping": lambda x: 0 <= x < math.inf,
                  "friction_mm_s2": lambda x: 0 <= x < math.inf}
        for name, ok in checks.items():
            for v in getattr(self, name):
                if not ok(v):
                    raise UsageError(f"ServoParams.{name} out of range: {v!r}")

    @property
    def structure_omega_rad_s(self) -> np.ndarray:
        return 2 * np.pi * np.array(self.structure_freq_hz)

    @property
    def compliance_mm_per_mm_s2(self) -> np.ndarray:
        """Static deflection per unit acceleration, ``m / k = 1 / w_s^2`` (s^2), per axis."""
        w = self.structure_omega_rad_s
        return np.where(np.isinf(w), 0.0, 1.0 / np.where(np.isinf(w), 1.0, w) ** 2)

    @property
    def equivalent_lag_s(self) -> np.ndarray:
        """First moment of the loop's impulse response, ``-H'(0) = (1 - k_ff) / Kv``: the
        time lag of the actual behind the command at constant velocity (FFWOF: 1/Kv)."""
        return (1.0 - np.array(self.ffw_weight)) / np.array(self.kv_1_s)

    @classmethod
    def from_compliance(cls, compliance_mm_per_mm_s2, **kw) -> "ServoParams":
        """Parameters with the structure mode set from a static compliance ``c = m/k``:
        ``f_s = 1 / (2 pi sqrt(c))`` (zero compliance: rigid)."""
        c = np.broadcast_to(np.asarray(compliance_mm_per_mm_s2, dtype=float), (3,))
        f = np.where(c > 0, 1.0 / (2 * np.pi * np.sqrt(np.where(c > 0, c, 1.0))), np.inf)
        return cls(structure_freq_hz=tuple(f), **kw)

    @classmethod
    def from_machine(cls, machine, *, ffw_weight: float = 1.0, default_kv_1_s: float = 30.0,
                     **kw) -> "ServoParams":
        """Kv from the machine's ``position_gain_1_s`` (``default_kv_1_s`` where absent) and the
        structure from its radial compliance (``[structure]`` of the machine file)."""
        kv = np.nan_to_num(np.asarray(machine.position_gain_1_s, dtype=float), nan=default_kv_1_s)
        c = machine.structure.radial_compliance_mm_per_mm_s2
        if c > 0 and "structure_freq_hz" not in kw:
            return replace(cls.from_compliance(c, **kw), kv_1_s=tuple(kv), ffw_weight=ffw_weight)
        return cls(kv_1_s=tuple(kv), ffw_weight=ffw_weight, **kw)


def transfer_function(params: ServoParams, s) -> np.ndarray:
    """Command-to-tool transfer function ``H(s)`` per axis (see module docstring), evaluated at
    complex ``s`` (any shape); returns shape ``s.shape + (3,)``."""
    s = np.asarray(s, dtype=complex)[..., None]
    kv = np.array(params.kv_1_s)
    kff = np.array(params.ffw_weight)
    tv = np.array(params.velocity_loop_time_s)
    w = params.structure_omega_rad_s
    z = np.array(params.structure_damping)
    h = (kff * s + kv) / (tv * s * s + s + kv)
    rigid = np.isinf(w)
    wf = np.where(rigid, 1.0, w)
    hs = (2 * z * wf * s + wf * wf) / (s * s + 2 * z * wf * s + wf * wf)
    return h * np.where(rigid, 1.0, hs)


# ---------------------------------------------------------------------------------------------
# The integrator
# ---------------------------------------------------------------------------------------------

@njit(cache=True)
def _deriv(xm, vm, d, dd, xc, vc, ac, kv, kff, tv, w, zeta, rigid):
    u = kff * vc + kv * (xc - xm)
    if tv > 0.0:
        am = (u - vm) / tv
        dxm = vm
    else:
        dxm = u
        am = kff * ac + kv * (vc - u)
    if rigid:
        return dxm, am, 0.0, 0.0
    return dxm, am, dd, -am - 2.0 * zeta * w * dd - w * w * d


@njit(cache=True)
def _integrate(xc, vc, ac, state, dt, kv, kff, tv, w, zeta, fric, out_xm, out_vm, out_d):
    """RK4 over ``n = out_xm.shape[0] - 1`` steps. ``xc, vc, ac`` (2n+1, axes) are the command
    at the half-step grid (``xc`` first: its length is the size ``ncsim.jit`` picks the plain or
    compiled version by); ``state`` (4, axes) = (x_m, v_m, d, dd/dt) is updated in place."""
    n = out_xm.shape[0] - 1
    na = state.shape[1]
    for a in range(na):
        xm, vm, d, dd = state[0, a], state[1, a], state[2, a], state[3, a]
        rigid = not np.isfinite(w[a])
        wa = 0.0 if rigid else w[a]
        k_, f_, t_, z_, c_ = kv[a], kff[a], tv[a], zeta[a], fric[a]
        if t_ <= 0.0:
            vm = f_ * vc[0, a] + k_ * (xc[0, a] - xm)
        out_xm[0, a] = xm
        out_vm[0, a] = vm
        out_d[0, a] = d
        for i in range(n):
            j = 2 * i
            k1 = _deriv(xm, vm, d, dd, xc[j, a], vc[j, a], ac[j, a], k_, f_, t_, wa, z_, rigid)
            k2 = _deriv(xm + 0.5 * dt * k1[0], vm + 0.5 * dt * k1[1], d + 0.5 * dt * k1[2],
                        dd + 0.5 * dt * k1[3], xc[j + 1, a], vc[j + 1, a], ac[j + 1, a],
                        k_, f_, t_, wa, z_, rigid)
            k3 = _deriv(xm + 0.5 * dt * k2[0], vm + 0.5 * dt * k2[1], d + 0.5 * dt * k2[2],
                        dd + 0.5 * dt * k2[3], xc[j + 1, a], vc[j + 1, a], ac[j + 1, a],
                        k_, f_, t_, wa, z_, rigid)
            k4 = _deriv(xm + dt * k3[0], vm + dt * k3[1], d + dt * k3[2], dd + dt * k3[3],
                        xc[j + 2, a], vc[j + 2, a], ac[j + 2, a], k_, f_, t_, wa, z_, rigid)
            xm += dt / 6.0 * (k1[0] + 2.0 * k2[0] + 2.0 * k3[0] + k4[0])
            vm += dt / 6.0 * (k1[1] + 2.0 * k2[1] + 2.0 * k3[1] + k4[1])
            d += dt / 6.0 * (k1[2] + 2.0 * k2[2] + 2.0 * k3[2] + k4[2])
            dd += dt / 6.0 * (k1[3] + 2.0 * k2[3] + 2.0 * k3[3] + k4[3])
            if t_ <= 0.0:
                vm = f_ * vc[j + 2, a] + k_ * (xc[j + 2, a] - xm)
            elif c_ > 0.0:
                # Coulomb friction, Karnopp stick: decelerate by c dt, never past zero
                dv = c_ * dt
                if vm > dv:
                    vm -= dv
                elif vm < -dv:
                    vm += dv
                else:
                    vm = 0.0
            out_xm[i + 1, a] = xm
            out_vm[i + 1, a] = vm
            out_d[i + 1, a] = d
        state[0, a], state[1, a], state[2, a], state[3, a] = xm, vm, d, dd


@dataclass(frozen=True, eq=False)
class ServoResponse:
    """Axis response at the integration step (or at the requested output times)."""

    t_s: np.ndarray              # (m,)
    cmd_pos_mm: np.ndarray       # (m, 3) command (interpolated)
    drive_pos_mm: np.ndarray     # (m, 3) drive / encoder position x_m
    drive_vel_mm_s: np.ndarray   # (m, 3) drive velocity v_m
    deflection_mm: np.ndarray    # (m, 3) structural deflection d (tool minus drive)
    params: ServoParams

    @property
    def pos_mm(self) -> np.ndarray:
        """Actual tool position ``x_m + d``."""
        return self.drive_pos_mm + self.deflection_mm

    @property
    def following_error_mm(self) -> np.ndarray:
        """Command minus drive position (what the NC displays as following error)."""
        return self.cmd_pos_mm - self.drive_pos_mm

    def at(self, t_s) -> "ServoResponse":
        """Linear resampling at times ``t_s`` (within the simulated span)."""
        t = np.asarray(t_s, dtype=np.float64)
        def res(a):
            return np.column_stack([np.interp(t, self.t_s, a[:, k]) for k in range(3)])
        return ServoResponse(t, res(self.cmd_pos_mm), res(self.drive_pos_mm),
                             res(self.drive_vel_mm_s), res(self.deflection_mm), self.params)

    def as_measured(self, source: str = "<servo truth>") -> MeasuredTrace:
        """The actual tool positions as a measured trace, with the command alongside."""
        return MeasuredTrace(t_s=self.t_s, pos_mm=self.pos_mm, vel_mm_s=self.drive_vel_mm_s,
                             cmd_pos_mm=self.cmd_pos_mm, source=source)


def command_spline(t_s, cmd_pos_mm, cmd_vel_mm_s=None) -> CubicHermiteSpline:
    """C1 interpolation of a sampled command: cubic Hermite through the positions with the given
    velocities (or ``np.gradient`` estimates). Its derivative is the command velocity."""
    t = np.asarray(t_s, dtype=np.float64)
    x = np.asarray(cmd_pos_mm, dtype=np.float64)
    if x.ndim != 2 or x.shape[0] != len(t) or x.shape[1] != 3:
        raise UsageError(f"command positions must be (m, 3) with m = len(t_s) = {len(t)}, "
                         f"got {x.shape}")
    if len(t) < 2 or np.any(np.diff(t) <= 0) or not np.all(np.isfinite(x)):
        raise UsageError("command needs >= 2 samples, strictly increasing time, finite values")
    v = (np.gradient(x, t, axis=0) if cmd_vel_mm_s is None
         else np.asarray(cmd_vel_mm_s, dtype=np.float64))
    return CubicHermiteSpline(t, x, v, axis=0)


def simulate_servo(t_s, cmd_pos_mm, params: ServoParams, *, cmd_vel_mm_s=None,
                   dt_s: float = DEFAULT_STEP_S, initial: str = "rest",
                   output_t_s=None, extend_s: float = 0.0) -> ServoResponse:
    """Integrate the axis loops of ``params`` driven by the sampled command.

    ``t_s`` (m,) and ``cmd_pos_mm`` (m, 3) are the set points (e.g. a planned trace sampled at
    1 ms); ``cmd_vel_mm_s`` their velocities if known. ``initial``: ``"rest"`` starts the
    drives on the first command point at rest; ``"steady"`` starts in the constant-velocity
    steady state of the first command velocity (following error ``(1 - k_ff) v / Kv``).
    Output at the integration grid ``t_0 + k dt`` (the last step may end before ``t_s[-1]``
    by less than ``dt``), or linearly resampled at ``output_t_s`` (memory-light for long runs).
    ``extend_s`` holds the last command point that much longer, so the axes can settle (the
    servo lag and the structure's ringing outlast the set point).
    """
    if not (0 < dt_s <= MAX_STEP_S):
        raise UsageError(f"integration step must be in (0, {MAX_STEP_S}] s, got {dt_s!r}")
    rates = [np.array(params.kv_1_s)]
    tv = np.array(params.velocity_loop_time_s)
    rates.append(np.divide(1.0, tv, out=np.zeros(3), where=tv > 0))
    w = params.structure_omega_rad_s
    rates.append(np.where(np.isinf(w), 0.0, w * np.maximum(1.0, np.array(params.structure_damping))))
    fastest = float(np.max(rates))
    if fastest * dt_s > _STABLE_RATE:
        raise UsageError(f"integration step {dt_s:g} s too coarse for a pole at {fastest:g} 1/s: "
                         f"use dt_s <= {_STABLE_RATE / fastest:.3g}")
    if np.any((np.array(params.friction_mm_s2) > 0) & (tv <= 0)):
        raise UsageError("friction needs a speed loop with velocity_loop_time_s > 0")
    if extend_s > 0:
        t_in = np.asarray(t_s, dtype=np.float64)
        x_in = np.asarray(cmd_pos_mm, dtype=np.float64)
        v_in = (np.gradient(x_in, t_in, axis=0) if cmd_vel_mm_s is None
                else np.asarray(cmd_vel_mm_s, dtype=np.float64))
        if np.max(np.abs(v_in[-1])) > 1e-6:
            raise UsageError("extend_s holds the last command point: the command must end at "
                             f"rest (it ends at {np.max(np.abs(v_in[-1])):g} mm/s)")
        t_s = np.append(t_in, t_in[-1] + extend_s)
        cmd_pos_mm = np.vstack([x_in, x_in[-1]])
        cmd_vel_mm_s = np.vstack([v_in, np.zeros(3)])
    spline = command_spline(t_s, cmd_pos_mm, cmd_vel_mm_s)
    dspline, ddspline = spline.derivative(1), spline.derivative(2)
    t0, t1 = float(spline.x[0]), float(spline.x[-1])
    n_steps = int(np.floor((t1 - t0) / dt_s + 1e-9))
    kv, kff = np.array(params.kv_1_s), np.array(params.ffw_weight)
    zeta, fric = np.array(params.structure_damping), np.array(params.friction_mm_s2)

    x0, v0 = spline(t0), dspline(t0)
    state = np.zeros((4, 3))
    state[0] = x0
    if initial == "steady":
        state[0] = x0 - (1.0 - kff) * v0 / kv
        state[1] = v0
    elif initial != "rest":
        raise UsageError(f"initial must be 'rest' or 'steady', got {initial!r}")

    out_t = None if output_t_s is None else np.asarray(output_t_s, dtype=np.float64)
    if n_steps < 1:
        raise UsageError(f"command spans {t1 - t0:g} s, less than one step of {dt_s:g} s")
    pieces: list[tuple[np.ndarray, ...]] = []
    for start in range(0, n_steps, _CHUNK_STEPS):
        n = min(_CHUNK_STEPS, n_steps - start)
        th = np.minimum(t0 + dt_s * (start + 0.5 * np.arange(2 * n + 1)), t1)
        xc = np.ascontiguousarray(spline(th))
        vc = np.ascontiguousarray(dspline(th))
        ac = np.ascontiguousarray(ddspline(th))
        oxm, ovm, od = (np.empty((n + 1, 3)) for _ in range(3))
        _integrate(xc, vc, ac, state, dt_s, kv, kff, tv, w, zeta, fric, oxm, ovm, od)
        tg = th[::2]
        if out_t is None:
            skip = 0 if start == 0 else 1  # the first point repeats the previous chunk's last
            pieces.append((tg[skip:], xc[::2][skip:], oxm[skip:], ovm[skip:], od[skip:]))
        else:
            last = start + n >= n_steps
            sel = (out_t >= tg[0]) & ((out_t <= tg[-1]) if last else (out_t < tg[-1]))
            if np.any(sel):
                ts = out_t[sel]
                pieces.append((ts, spline(ts)) + tuple(
                    np.column_stack([np.interp(ts, tg, a[:, k]) for k in range(3)])
                    for a in (oxm, ovm, od)))
    if not pieces:
        raise UsageError("no output time inside the simulated span")
    cols = [np.concatenate([p[i] for p in pieces]) for i in range(5)]
    return ServoResponse(t_s=cols[0], cmd_pos_mm=cols[1], drive_pos_mm=cols[2],
                         drive_vel_mm_s=cols[3], deflection_mm=cols[4], params=params)
