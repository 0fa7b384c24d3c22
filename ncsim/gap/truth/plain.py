"""An independent set-point generator: a plain time-optimal planner with ruckig per block.

The withheld-effect benchmark needs "measured" traces whose truth is not made by ncsim's own
planner (``ncsim.plan``), or it proves consistency, not correctness. This module plans the
commanded motion of a path from the 840D rules stated in the manuals and the paper, written
again from those statements, sharing no code with ``ncsim.plan`` (it must not import it):

* **block feed**: G0 at the rapid override times the axis-velocity limit along the line
  (MD32000, ``min_i V_i / |u_i|``); G1/G2/G3 at F times the feed override, capped by the same
  axis limit (for an arc the least over its tangents);
* **ramps**: BRISK (the 840D's reset value): the path acceleration is the least the axes allow
  along the block, ``min_i A_i / |u_i|``, on arcs also less what the centripetal part
  ``V^2 / R`` takes from each axis (paper eq. 1), switched on within one interpolation cycle
  (jerk ``A / t_IPO``, paper §3.3.2);
* **junctions**: rest at the program's start and end; a stop at every G0<->G1 change, waiting
  the exact-stop settle time when MD20552 asks for a window; under G60 (exact stop) a stop and
  a settle at every block end; under G64 the path keeps its speed across tangent junctions and
  crosses corners at ``min_i jump_i / |t2_i - t1_i|`` (the axis velocity jump of 840D B1
  "continuous-path mode", MD32310);
* **motion**: junction speeds from a backward and a forward pass with the exact distance of a
  jerk-limited speed change (:func:`ramp_distance_mm`), then every block is ruckig's
  time-optimal 1-D motion from ``(0, v_in, 0)`` to ``(L, v_out, 0)`` under the block's
  velocity, acceleration and jerk (``min_velocity = 0``: never backwards).

The rules are stated for the cases the benchmark draws (BRISK, lines and arcs whose
curvature and length do not bind other limits); the module says so where it simplifies. It is
deliberately small and slow (Python loops over blocks): it serves validation, not speed.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ncsim.errors import UsageError
from ncsim.path import ARC, Path

ARC_SAMPLES = 91           # tangents sampled per arc for its limits
TANGENT_TOL_RAD = 1e-4     # deflection below which a junction is tangent
_BISECT = 60


@dataclass(frozen=True)
class PlainMachine:
    """What the plain planner needs, in mm and s (per-axis tuples are X, Y, Z)."""

    v_max_mm_s: tuple
    a_max_mm_s2: tuple
    ipo_cycle_s: float
    jump_mm_s: tuple                # G64 corner: velocity jump each axis may make
    continuous_path: bool = False   # reset mode G64 (True) or G60
    settle_s: float = 0.0           # time standing in the exact-stop window
    g0_g1_window: bool = False      # MD20552: wait for the window at G0<->G1 changes too
    rapid_override: float = 1.0
    feed_override: float = 1.0


@dataclass(frozen=True, eq=False)
class PlainMotion:
    """The planned motion: per block its ruckig trajectory and start time."""

    path: Path
    t_start_s: np.ndarray       # (n,) time the block starts moving
    duration_s: np.ndarray      # (n,) time moving through it
    dwell_s: np.ndarray         # (n + 1,) time standing at junction k
    v_junction_mm_s: np.ndarray  # (n + 1,)
    trajectories: list          # ruckig.Trajectory per block (None for a zero-length block)
    total_s: float


# ---------------------------------------------------------------------------------------------
# Geometry (written for this module: lines, arcs and helices from the Path columns)
# ---------------------------------------------------------------------------------------------

def _arc_frame(path: Path, k: int):
    c = path.center_mm[k]
    n = path.normal[k] / np.linalg.norm(path.normal[k])
    r = float(path.radius_mm[k])
    e1 = (path.start_mm[k] - c) / r
    e2 = np.cross(n, e1)
    return c, n, r, e1, e2


def point_at(path: Path, k: int, s_local_mm: np.ndarray) -> np.ndarray:
    """Positions (m, 3) at path length ``s_local_mm`` into block ``k``."""
    s = np.asarray(s_local_mm, dtype=np.float64)
    length = float(path.length_mm[k])
    if path.kind[k] != ARC:
        a, b = path.start_mm[k], path.end_mm[k]
        u = (b - a) / length if length > 0 else np.zeros(3)
        return a + s[:, None] * u
    c, n, r, e1, e2 = _arc_frame(path, k)
    sweep = float(path.sweep_rad[k])
    phi = s / length * sweep
    rise = float(path.helix_mm[k]) * s / length
    return (c + r * (np.cos(phi)[:, None] * e1 + np.sin(phi)[:, None] * e2)
            + rise[:, None] * n)


def tangent_at(path: Path, k: int, s_local_mm: np.ndarray) -> np.ndarray:
    """Unit tangents (m, 3) at ``s_local_mm`` into block ``k``."""
    s = np.asarray(s_local_mm, dtype=np.float64)
    length = float(path.length_mm[k])
    if path.kind[k] != ARC:
        d = path.end_mm[k] - path.start_mm[k]
        return np.broadcast_to(d / length if length > 0 else d, (len(s), 3)).copy()
    c, n, r, e1, e2 = _arc_frame(path, k)
    sweep = float(path.sweep_rad[k])
    phi = s / length * sweep
    t = r * sweep * (-np.sin(phi)[:, None] * e1 + np.cos(phi)[:, None] * e2) + float(path.helix_mm[k]) * n
    return t / np.linalg.norm(t, axis=1, keepdims=True)


def inward_normal_at(path: Path, k: int, s_local_mm: np.ndarray) -> np.ndarray:
    """Unit normals towards the arc's centre (m, 3) (lines: zero)."""
    s = np.asarray(s_local_mm, dtype=np.float64)
    if path.kind[k] != ARC:
        return np.zeros((len(s), 3))
    c, n, r, e1, e2 = _arc_frame(path, k)
    phi = s / float(path.length_mm[k]) * float(path.sweep_rad[k])
    return -(np.cos(phi)[:, None] * e1 + np.sin(phi)[:, None] * e2)


# ---------------------------------------------------------------------------------------------
# Limits
# ---------------------------------------------------------------------------------------------

def axis_limited_mm_s(direction: np.ndarray, per_axis) -> float:
    """``min_i L_i / |d_i|`` over unit directions ``direction`` (m, 3): the least path value
    every axis allows (a path velocity, acceleration or velocity jump)."""
    d = np.abs(np.atleast_2d(direction))
    lim = np.asarray(per_axis, dtype=np.float64)[None, :]
    with np.errstate(divide="ignore"):
        ratio = np.where(d > 1e-12, lim / np.where(d > 1e-12, d, 1.0), np.inf)
    return float(np.min(ratio))


def block_limits(path: Path, machine: PlainMachine):
    """Per block: velocity cap, path acceleration and jerk (module docstring)."""
    n = path.n
    vmax = np.empty(n)
    accel = np.empty(n)
    for k in range(n):
        length = float(path.length_mm[k])
        if length <= 0:
            vmax[k], accel[k] = np.inf, float(min(machine.a_max_mm_s2))
            continue
        s = np.linspace(0.0, length, ARC_SAMPLES if path.kind[k] == ARC else 2)
        tan = tangent_at(path, k, s)
        v_axes = axis_limited_mm_s(tan, machine.v_max_mm_s)
        if path.rapid[k]:
            v = machine.rapid_override * v_axes
        else:
            v = min(float(path.feed_mm_s[k]) * machine.feed_override, v_axes)
        a = axis_limited_mm_s(tan, machine.a_max_mm_s2)
        if path.kind[k] == ARC:
            # eq. 1: the centripetal part V^2 / R takes its share of every axis
            a_n = v * v / float(path.radius_mm[k])
            nrm = np.abs(inward_normal_at(path, k, s))
            left = np.asarray(machine.a_max_mm_s2)[None, :] - a_n * nrm
            if np.any(left <= 0):
                raise UsageError(f"block {k}: the centripetal acceleration exceeds an axis limit "
                                 "(the plain planner does not slow down for curvature)")
            with np.errstate(divide="ignore"):
                a = float(np.min(np.where(np.abs(tan) > 1e-12, left / np.maximum(np.abs(tan), 1e-12), np.inf)))
        vmax[k], accel[k] = v, a
    jerk = accel / machine.ipo_cycle_s                     # BRISK: A within one IPO cycle
    return vmax, accel, jerk


def junction_caps(path: Path, machine: PlainMachine, vmax: np.ndarray):
    """Per junction (n + 1): the highest crossing speed and the time standing there."""
    n = path.n
    cap = np.full(n + 1, np.inf)
    dwell = np.zeros(n + 1)
    cap[0] = cap[n] = 0.0
    for j in range(1, n):
        a, b = j - 1, j
        if path.rapid[a] != path.rapid[b]:
            cap[j] = 0.0
            if machine.g0_g1_window:
                dwell[j] = machine.settle_s
        if path.exact_stop[a]:
            cap[j] = 0.0
            dwell[j] = machine.settle_s
        if cap[j] == 0.0:
            continue
        t1 = tangent_at(path, a, [float(path.length_mm[a])])[0]
        t2 = tangent_at(path, b, [0.0])[0]
        deflection = math.atan2(np.linalg.norm(np.cross(t1, t2)), float(np.dot(t1, t2)))
        if deflection > TANGENT_TOL_RAD:
            jump = t2 - t1
            cap[j] = axis_limited_mm_s(jump / 1.0, machine.jump_mm_s) if np.any(jump) else np.inf
    cap = np.minimum(cap, np.r_[0.0, vmax]) if n else cap
    cap[:n] = np.minimum(cap[:n], vmax)
    return cap, dwell


def ramp_distance_mm(v0: float, v1: float, accel: float, jerk: float) -> float:
    """Shortest distance to change speed from ``v0`` to ``v1`` starting and ending at zero
    acceleration, with acceleration ``accel`` and jerk ``jerk``: ``(v0 + v1)/2 (dv/A + A/J)``
    when the acceleration reaches A (``dv >= A^2 / J``), else ``(v0 + v1) sqrt(dv / J)``."""
    dv = abs(v1 - v0)
    if dv == 0.0:
        return 0.0
    if dv >= accel * accel / jerk:
        return 0.5 * (v0 + v1) * (dv / accel + accel / jerk)
    return (v0 + v1) * math.sqrt(dv / jerk)


def reachable_mm_s(v0: float, length: float, accel: float, jerk: float, cap: float) -> float:
    """The highest speed reachable (or, read backwards, that can be shed) over ``length``
    from ``v0``, at most ``cap`` (bisection on :func:`ramp_distance_mm`)."""
    if ramp_distance_mm(v0, cap, accel, jerk) <= length:
        return cap
    lo, hi = v0, cap
    for _ in range(_BISECT):
        mid = 0.5 * (lo + hi)
        if ramp_distance_mm(v0, mid, accel, jerk) <= length:
            lo = mid
        else:
            hi = mid
    return lo


def junction_speeds(path: Path, vmax, accel, jerk, cap) -> np.ndarray:
    """Backward then forward pass: the fastest junction speeds every block can connect."""
    n = path.n
    v = cap.copy()
    for k in range(n - 1, -1, -1):                 # block k from junction k to k + 1
        v[k] = min(v[k], reachable_mm_s(v[k + 1], float(path.length_mm[k]), accel[k], jerk[k],
                                        vmax[k]))
    for k in range(n):
        v[k + 1] = min(v[k + 1], reachable_mm_s(v[k], float(path.length_mm[k]), accel[k],
                                                jerk[k], vmax[k]))
    return v


# ---------------------------------------------------------------------------------------------
# Planning and sampling
# ---------------------------------------------------------------------------------------------

def plan_plain(path: Path, machine: PlainMachine) -> PlainMotion:
    """Plan ``path`` (module docstring)."""
    if path.n == 0:
        raise UsageError("the plain planner needs a path with at least one block")
    vmax, accel, jerk = block_limits(path, machine)
    cap, dwell = junction_caps(path, machine, vmax)
    return plan_plain_limits(path, vmax, accel, jerk, cap, dwell)


def plan_plain_limits(path: Path, vmax, accel, jerk, cap, dwell) -> PlainMotion:
    """The motion of ``path`` under given per-block limits (velocity cap, path acceleration
    and jerk, each block its own) and per-junction crossing caps and standing times: zero
    acceleration at every junction, junction speeds from the two passes, ruckig's
    time-optimal motion in every block. Also the independent reference for ncsim's planner
    fed the same limits (``tests/test_plan_blocks.py``)."""
    import ruckig

    vmax, accel, jerk, cap, dwell = (np.array(x, dtype=np.float64)
                                     for x in (vmax, accel, jerk, cap, dwell))
    cap[:-1] = np.minimum(cap[:-1], vmax)             # a junction is in both its blocks
    cap[1:] = np.minimum(cap[1:], vmax)
    v = junction_speeds(path, vmax, accel, jerk, cap)
    solver = ruckig.Ruckig(1)
    trajs, durations = [], np.zeros(path.n)
    for k in range(path.n):
        length = float(path.length_mm[k])
        if length <= 0:
            trajs.append(None)
            continue
        inp = ruckig.InputParameter(1)
        inp.current_position, inp.current_velocity, inp.current_acceleration = [0.0], [float(v[k])], [0.0]
        inp.target_position, inp.target_velocity, inp.target_acceleration = [length], [float(v[k + 1])], [0.0]
        inp.max_velocity, inp.min_velocity = [float(vmax[k])], [0.0]
        inp.max_acceleration, inp.max_jerk = [float(accel[k])], [float(jerk[k])]
        traj = ruckig.Trajectory(1)
        result = solver.calculate(inp, traj)
        if result not in (ruckig.Result.Working, ruckig.Result.Finished):
            raise UsageError(f"block {k}: ruckig found no motion ({result.name})")
        trajs.append(traj)
        durations[k] = traj.duration
    t_start = np.zeros(path.n)
    t = 0.0
    for k in range(path.n):
        t += dwell[k]
        t_start[k] = t
        t += durations[k]
    t += dwell[path.n]
    return PlainMotion(path=path, t_start_s=t_start, duration_s=durations, dwell_s=dwell,
                       v_junction_mm_s=v, trajectories=trajs, total_s=t)


def sample_plain(motion: PlainMotion, t_s: np.ndarray) -> np.ndarray:
    """Commanded positions (m, 3) at times ``t_s`` (before the start: the start point; after
    the end: the end point; standing at junctions between blocks)."""
    path = motion.path
    t = np.asarray(t_s, dtype=np.float64)
    out = np.empty((len(t), 3))
    out[:] = path.start_mm[0]
    t_end = motion.t_start_s + motion.duration_s
    for k in range(path.n):
        after = t >= t_end[k]
        out[after] = path.end_mm[k]
        inside = (t >= motion.t_start_s[k]) & (t < t_end[k])
        if not np.any(inside) or motion.trajectories[k] is None:
            continue
        traj = motion.trajectories[k]
        tau = t[inside] - motion.t_start_s[k]
        s = np.array([traj.at_time(float(x))[0][0] for x in tau])
        out[inside] = point_at(path, k, np.clip(s, 0.0, float(path.length_mm[k])))
    return out
