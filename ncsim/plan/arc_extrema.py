"""The paper's axis capacities over an arc's angle range, in closed form (eq. 1, 7-9, §5.2.4).

Along an arc or helix at angle ``phi`` in ``[0, S]`` from its start (``S`` at most one turn:
the tangent repeats every turn), with the basis ``(u, v, w)`` of :mod:`ncsim.geometry` (``u``
from the centre to the start, ``v = w x u``, ``w`` the normal), ``lean = r / rho`` and
``rise = p / rho`` (``rho = ds/dphi``, ``p`` the rise per radian), axis ``i`` sees::

    t_i(phi) = lean v_i cos phi - lean u_i sin phi + rise w_i      unit tangent
    n_i(phi) = -(u_i cos phi + v_i sin phi)                         principal normal

For the paper's XY circle these are ``t = (cos alpha, sin alpha)`` and ``n = (-sin alpha,
cos alpha)`` with alpha the tangent direction: the paper's formulas written along the arc, in
any plane and for helices. The capacities are ratios of the axis limits to those components
(as in :mod:`ncsim.plan.kinematics`)::

    eq. 7  V_t(phi) = min_i V_mi / |t_i|      eq. 8  A_n(phi) = min_i A_mi / |n_i|
    eq. 9  J_t(phi) = min_i J_mi / |t_i|      eq. 1  a_t(phi) = min_i (A_mi - a_n |n_i|)+ / |t_i|

Every extremum over ``[0, S]`` is taken at a few known angles, never by sampling. Each is the
solution of ``p cos phi + q sin phi = k`` (:func:`trig_solutions`, solved for ``cos phi`` and
``sin phi`` directly), kept when it lies on the arc (:func:`on_arc`):

* least V_t, A_n, J_t = ``min_i limit_i / max_phi |component_i|``; a component is a sinusoid
  (plus a constant), largest at the range ends or where it is stationary: the tangent or the
  normal along the axis (the paper's 0, 90, 180, 270 deg);
* largest J_t (eq. 9): a maximum of a minimum of ratios lies at a range end, where one ratio is
  stationary, or where two cross, ``J_mk |t_i| = J_mi |t_k|`` -- 45 deg for equal axes,
  ``tan alpha = J_my / J_mx`` in general (the paper's 39.8 deg, ``tan alpha = A_mx / A_my``,
  is the same crossing for eq. 8);
* alpha_c (§5.2.4, the reading in :mod:`ncsim.plan.limits`): the first angle where
  ``J_t >= J_tcurv``, i.e. ``|t_i| <= J_mi / J_tcurv`` on every axis: the start, or an angle
  where some ``t_i`` reaches ``+-J_mi / J_tcurv``;
* least a_t (eq. 1 split per axis): the ratio ``(A - a_n |n_i|) / t_i`` is stationary where the
  numerator of its derivative vanishes, which for a ratio of two first-order trigonometric
  polynomials is *linear* in ``(cos phi, sin phi)`` (:func:`least_tangential_accel`); for a
  planar arc it gives ``|n_i| = a_n R_i^2 / A_mi`` and ``a_t = sqrt(A_mi^2 - (a_n R_i)^2) / R_i``
  (R_i = hypot(u_i, v_i); the paper's ``sqrt(A_mx^2 - a_n^2)`` on an XY circle).

The kernels loop over arcs (compiled with numba) with a handful of square roots and at most a
few arctangents per arc and no temporaries, so arcs cost about what lines cost.
"""
from __future__ import annotations

import math

import numpy as np

from ncsim.jit import njit

TWO_PI = 2.0 * math.pi
_FEASIBLE_REL = 1e-12   # |t_i| <= bound * (1 + this): J_t reaches J_tcurv (alpha_c)
_JMAX_REL = 1e-9        # "J_t is largest" within this (the first such angle is alpha_c)
_UNREACHED_REL = 1e-9   # max |t_i| this far below J_mi / J_tcurv: t_i never reaches it
_MAX_CAND = 32          # candidate angles per arc and quantity
#: arcs per call below which the drivers run as plain Python (``ncsim.jit``): measured on
#: half circles, a whole run in plain Python costs about 0.1 s of CPU per 1,000 arcs, numba's
#: start-up about 0.7 s, so the compiled drivers pay off from about 6,000 arcs
ARCS_PYTHON_BELOW = 6_000


# ---------------------------------------------------------------------------------------------
# Angles as (cos, sin) pairs
# ---------------------------------------------------------------------------------------------

@njit(cache=True, nogil=True)
def trig_solutions(p, q, k):
    """Solutions of ``p cos x + q sin x = k`` as ``(count, cos x1, sin x1, cos x2, sin x2)``:
    none when ``|k| > hypot(p, q)``, one when tangent, else two."""
    r2 = p * p + q * q
    if r2 <= 0.0:
        return 0, 0.0, 0.0, 0.0, 0.0
    d2 = r2 - k * k
    if d2 < -1e-12 * r2:
        return 0, 0.0, 0.0, 0.0, 0.0
    d = math.sqrt(max(d2, 0.0))
    c1, s1 = (p * k - q * d) / r2, (q * k + p * d) / r2
    if d == 0.0:
        return 1, c1, s1, c1, s1
    return 2, c1, s1, (p * k + q * d) / r2, (q * k - p * d) / r2


@njit(cache=True, nogil=True)
def on_arc(cos_phi, sin_phi, sweep, cos_sweep, sin_sweep):
    """Does the direction angle phi (given by its cosine and sine) lie in [0, sweep] (mod 2 pi)?
    Sign tests only: for sweep <= pi, 0 <= phi and phi <= sweep; beyond, phi is not in the
    (shorter than pi) rest of the turn."""
    if sweep >= TWO_PI:
        return True
    if sweep <= math.pi:
        return sin_phi >= 0.0 and sin_sweep * cos_phi - cos_sweep * sin_phi >= 0.0
    return not (sin_phi < 0.0 and sin_phi * cos_sweep - cos_phi * sin_sweep > 0.0)


@njit(cache=True, nogil=True)
def angle_rad(cos_phi, sin_phi):
    """The angle in [0, 2 pi) of a (cos, sin) pair."""
    a = math.atan2(sin_phi, cos_phi)
    return a + TWO_PI if a < 0.0 else a


# ---------------------------------------------------------------------------------------------
# One arc: axis terms and components
# ---------------------------------------------------------------------------------------------

@njit(cache=True, nogil=True)
def arc_axis_terms(start, center, normal, radius_mm, sweep_rad, helix_mm, ab, c, uv):
    """Per-axis terms of one arc (module docstring): ``t_i = ab[i,0] cos phi + ab[i,1] sin phi
    + c[i]`` and ``n_i = -(uv[i,0] cos phi + uv[i,1] sin phi)``. Returns the curvature radius
    (r^2 + p^2) / r (``geometry.curvature_radius_mm``) and the angle range (<= one turn)."""
    pitch = helix_mm / sweep_rad if sweep_rad > 0.0 else 0.0
    rho = math.hypot(radius_mm, pitch)
    lean = radius_mm / rho
    rise = pitch / rho
    w0, w1, w2 = normal[0], normal[1], normal[2]
    d0, d1, d2 = start[0] - center[0], start[1] - center[1], start[2] - center[2]
    h = d0 * w0 + d1 * w1 + d2 * w2
    d0, d1, d2 = d0 - h * w0, d1 - h * w1, d2 - h * w2
    norm = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
    if norm > 0.0:
        d0, d1, d2 = d0 / norm, d1 / norm, d2 / norm
    uv[0, 0], uv[1, 0], uv[2, 0] = d0, d1, d2
    uv[0, 1], uv[1, 1], uv[2, 1] = w1 * d2 - w2 * d1, w2 * d0 - w0 * d2, w0 * d1 - w1 * d0
    for i in range(3):
        ab[i, 0] = lean * uv[i, 1]
        ab[i, 1] = -lean * uv[i, 0]
        c[i] = rise * normal[i]
    return rho * rho / radius_mm, min(sweep_rad, TWO_PI)


@njit(cache=True, nogil=True)
def tangent_at(ab, c, cos_phi, sin_phi, out):
    """Unit tangent components at the angle whose cosine and sine are given."""
    for i in range(3):
        out[i] = ab[i, 0] * cos_phi + ab[i, 1] * sin_phi + c[i]


@njit(cache=True, nogil=True)
def normal_at(uv, cos_phi, sin_phi, out):
    """Principal normal components -(u_i cos phi + v_i sin phi)."""
    for i in range(3):
        out[i] = -(uv[i, 0] * cos_phi + uv[i, 1] * sin_phi)


@njit(cache=True, nogil=True)
def weakest_axis(limit, comp):
    """min_i limit_i / |comp_i| (+inf where comp_i = 0): eq. 7, 8 or 9 at one angle."""
    out = math.inf
    for i in range(3):
        a = abs(comp[i])
        if a > 0.0:
            out = min(out, limit[i] / a)
    return out


@njit(cache=True, nogil=True)
def max_abs_tangent(ab, c, i, sweep, cs, ss):
    """max over [0, sweep] of |t_i|: the ends, and where t_i is stationary (the tangent along
    the axis, t_i = c_i +- hypot(a_i, b_i)) when on the arc."""
    best = max(abs(ab[i, 0] + c[i]), abs(ab[i, 0] * cs + ab[i, 1] * ss + c[i]))
    amp = math.sqrt(ab[i, 0] * ab[i, 0] + ab[i, 1] * ab[i, 1])
    if amp > 0.0:
        cp, sp = ab[i, 0] / amp, ab[i, 1] / amp
        if on_arc(cp, sp, sweep, cs, ss):
            best = max(best, abs(c[i] + amp))
        if on_arc(-cp, -sp, sweep, cs, ss):
            best = max(best, abs(c[i] - amp))
    return best


@njit(cache=True, nogil=True)
def max_abs_normal(uv, i, sweep, cs, ss):
    """max over [0, sweep] of |n_i|: R_i = hypot(u_i, v_i) if the normal points along the axis
    somewhere on the arc, else the larger end."""
    amp = math.sqrt(uv[i, 0] * uv[i, 0] + uv[i, 1] * uv[i, 1])
    if amp <= 0.0:
        return 0.0
    cp, sp = uv[i, 0] / amp, uv[i, 1] / amp
    if on_arc(cp, sp, sweep, cs, ss) or on_arc(-cp, -sp, sweep, cs, ss):
        return amp
    return max(abs(uv[i, 0]), abs(uv[i, 0] * cs + uv[i, 1] * ss))


# ---------------------------------------------------------------------------------------------
# alpha_c (§5.2.4): the first angle carrying J_tcurv, else the first of largest J_t (eq. 9)
# ---------------------------------------------------------------------------------------------

@njit(cache=True, nogil=True)
def carries_jerk(ab, c, max_jerk, j_floor, cos_phi, sin_phi):
    """J_t(phi) >= j_floor (eq. 9): |t_i| <= J_mi / j_floor on every axis."""
    for i in range(3):
        t_i = ab[i, 0] * cos_phi + ab[i, 1] * sin_phi + c[i]
        if abs(t_i) * j_floor > max_jerk[i] * (1.0 + _FEASIBLE_REL):
            return False
    return True


@njit(cache=True, nogil=True)
def first_carrying_angle(ab, c, sweep, cs, ss, max_jerk, j_floor, t_max):
    """Least phi in [0, sweep] with J_t(phi) >= j_floor as ``(phi, cos phi, sin phi)``, phi = -1
    if none: the start, the end, or an angle where some t_i reaches +-J_mi / j_floor.

    ``t_max[i]`` is max over the arc of |t_i| (:func:`max_abs_tangent`): an axis whose
    component stays below its bound by more than ``_UNREACHED_REL`` has no such angle on the
    arc, and its equations are not solved (a solution the rounded sign tests of
    :func:`on_arc` let through lies within rounding of the arc, where |t_i| is within
    rounding of ``t_max[i]``, far above that margin)."""
    if carries_jerk(ab, c, max_jerk, j_floor, 1.0, 0.0):
        return 0.0, 1.0, 0.0
    best, best_c, best_s = -1.0, 1.0, 0.0
    if carries_jerk(ab, c, max_jerk, j_floor, cs, ss):
        best, best_c, best_s = sweep, cs, ss
    for i in range(3):
        if not math.isfinite(max_jerk[i]):
            continue
        bound = max_jerk[i] / j_floor
        if t_max[i] < bound * (1.0 - _UNREACHED_REL):
            continue
        for k in (bound - c[i], -bound - c[i]):
            m, c1, s1, c2, s2 = trig_solutions(ab[i, 0], ab[i, 1], k)
            for j in range(m):
                cp, sp = (c1, s1) if j == 0 else (c2, s2)
                if not (on_arc(cp, sp, sweep, cs, ss)
                        and carries_jerk(ab, c, max_jerk, j_floor, cp, sp)):
                    continue
                phi = min(angle_rad(cp, sp), sweep)
                if best < 0.0 or phi < best:
                    best, best_c, best_s = phi, cp, sp
    return best, best_c, best_s


@njit(cache=True, nogil=True)
def largest_jerk_angle(ab, c, sweep, cs, ss, max_jerk, cand, t):
    """First phi in [0, sweep] where J_t (eq. 9) is largest, as ``(phi, cos phi, sin phi)``:
    among the ends, the angles where one t_i is stationary and where two ratios cross,
    ``J_mk t_i = +-J_mi t_k`` (a linear equation in cos phi, sin phi)."""
    m = 0
    for cp, sp in ((1.0, 0.0), (cs, ss)):
        cand[m, 0], cand[m, 1] = cp, sp
        m += 1
    for i in range(3):
        amp = math.sqrt(ab[i, 0] * ab[i, 0] + ab[i, 1] * ab[i, 1])
        if amp > 0.0:
            for sgn in (1.0, -1.0):
                cand[m, 0], cand[m, 1] = sgn * ab[i, 0] / amp, sgn * ab[i, 1] / amp
                m += 1
    for i in range(3):
        for k in range(i + 1, 3):
            if not (math.isfinite(max_jerk[i]) and math.isfinite(max_jerk[k])):
                continue
            for sgn in (1.0, -1.0):
                p = max_jerk[k] * ab[i, 0] - sgn * max_jerk[i] * ab[k, 0]
                q = max_jerk[k] * ab[i, 1] - sgn * max_jerk[i] * ab[k, 1]
                rhs = sgn * max_jerk[i] * c[k] - max_jerk[k] * c[i]
                n_sol, c1, s1, c2, s2 = trig_solutions(p, q, rhs)
                for j in range(n_sol):
                    cand[m, 0], cand[m, 1] = (c1, s1) if j == 0 else (c2, s2)
                    m += 1
    best = -math.inf
    for j in range(m):
        cand[j, 2] = -math.inf
        if j < 2 or on_arc(cand[j, 0], cand[j, 1], sweep, cs, ss):
            tangent_at(ab, c, cand[j, 0], cand[j, 1], t)
            cand[j, 2] = weakest_axis(max_jerk, t)
            best = max(best, cand[j, 2])
    first, first_c, first_s = sweep, cs, ss
    for j in range(m):
        if cand[j, 2] >= best * (1.0 - _JMAX_REL):
            phi = 0.0 if j == 0 else (sweep if j == 1 else min(angle_rad(cand[j, 0], cand[j, 1]),
                                                                  sweep))
            if phi < first or (phi == first and j == 0):
                first, first_c, first_s = phi, cand[j, 0], cand[j, 1]
    return first, first_c, first_s


@njit(cache=True, nogil=True)
def plane_angle_rad(normal, t):
    """Direction angle in [0, 2 pi) of tangent ``t`` in the working plane of an arc of axis
    ``normal`` (G17: X, Y; G18: Z, X; G19: Y, Z -- the largest component of the normal)."""
    plane = 0
    for i in (1, 2):
        if abs(normal[i]) > abs(normal[plane]):
            plane = i
    first = (1, 2, 0)[plane]
    second = (2, 0, 1)[plane]
    return angle_rad(t[first], t[second])


# ---------------------------------------------------------------------------------------------
# Eq. 1 split per axis: the tangential acceleration left by a normal acceleration a_n
# ---------------------------------------------------------------------------------------------

@njit(cache=True, nogil=True)
def _accel_ratio(a_axis, a_normal, n_i, t_i):
    """(A_mi - a_n |n_i|)+ / |t_i|; +inf where t_i = 0 (the axis does not limit)."""
    if t_i == 0.0:
        return math.inf
    return max(a_axis - a_normal * abs(n_i), 0.0) / abs(t_i)


@njit(cache=True, nogil=True)
def least_tangential_accel(ab, c, uv, sweep, cs, ss, max_accel, a_normal):
    """min over [0, sweep] of min_i (A_mi - a_n |n_i|)+ / |t_i| (eq. 1 per axis).

    Per axis: 0 if the normal part alone can use all of A_mi somewhere on the arc; else the
    least of the ends and the stationary points of ``N / t_i``, ``N = A - s a_n n_i`` (s the
    sign of n_i). With ``N = A + s a_n (u cos + v sin)`` and ``t_i = c + a cos + b sin``,
    ``N' t_i - N t_i' = 0`` is linear in (cos phi, sin phi):
    ``(s a_n c v - A b) cos + (A a - s a_n c u) sin = -s a_n (v a - u b)``."""
    best = math.inf
    for i in range(3):
        if a_normal * max_abs_normal(uv, i, sweep, cs, ss) >= max_accel[i]:
            if max_abs_tangent(ab, c, i, sweep, cs, ss) > 0.0:
                return 0.0
            continue
        for cp, sp in ((1.0, 0.0), (cs, ss)):
            t_i = ab[i, 0] * cp + ab[i, 1] * sp + c[i]
            n_i = -(uv[i, 0] * cp + uv[i, 1] * sp)
            best = min(best, _accel_ratio(max_accel[i], a_normal, n_i, t_i))
        u, v, a, b = uv[i, 0], uv[i, 1], ab[i, 0], ab[i, 1]
        for sgn in (1.0, -1.0):
            p = sgn * a_normal * c[i] * v - max_accel[i] * b
            q = max_accel[i] * a - sgn * a_normal * c[i] * u
            k = -sgn * a_normal * (v * a - u * b)
            m, c1, s1, c2, s2 = trig_solutions(p, q, k)
            for j in range(m):
                cp, sp = (c1, s1) if j == 0 else (c2, s2)
                if on_arc(cp, sp, sweep, cs, ss):
                    t_i = ab[i, 0] * cp + ab[i, 1] * sp + c[i]
                    n_i = -(uv[i, 0] * cp + uv[i, 1] * sp)
                    best = min(best, _accel_ratio(max_accel[i], a_normal, n_i, t_i))
    return best


# ---------------------------------------------------------------------------------------------
# Drivers over all arcs of a path
# ---------------------------------------------------------------------------------------------

@njit(cache=True, nogil=True)
def _scratch():
    """The per-arc work arrays of :func:`arc_axis_terms`: ``ab``, ``uv`` (3 x 2) and ``c``."""
    return np.empty((3, 2)), np.empty((3, 2)), np.empty(3)


@njit(cache=True, nogil=True)
def _terms_of(a, start, center, normal, radius, sweep, helix, ab, c, uv):
    """:func:`arc_axis_terms` of row ``a`` of the path columns."""
    return arc_axis_terms(start[a], center[a], normal[a], radius[a], sweep[a], helix[a], ab, c,
                          uv)


@njit(cache=True, nogil=True, python_below=ARCS_PYTHON_BELOW)
def arc_capacities(arcs, start, center, normal, radius, sweep, helix, max_velocity, max_accel,
                   max_jerk, j_ncu):
    """Per arc ``arcs[k]`` of the path columns: curvature radius; alpha_c as the angle travelled
    from the start and as the tangent's plane angle; whether J_tcurv is carried; J_t, V_t, A_n
    at alpha_c (J_t raised to J_tcurv when carried); the least V_t, A_n, J_t over the arc
    (eq. 7-9)."""
    n = arcs.shape[0]
    r_curv = np.empty(n)
    phi_c = np.empty(n)
    alpha_c = np.empty(n)
    carried = np.zeros(n, dtype=np.bool_)
    j_t_c = np.empty(n)
    v_t_c = np.empty(n)
    a_n_c = np.empty(n)
    v_t_min = np.empty(n)
    a_n_min = np.empty(n)
    j_t_min = np.empty(n)
    ab, uv, c = _scratch()
    t = np.empty(3)
    nv = np.empty(3)
    cand = np.empty((_MAX_CAND, 3))
    t_max = np.empty(3)
    j_floor = j_ncu * (1.0 - 1e-12)
    for k in range(n):
        a = arcs[k]
        r_curv[k], sw = _terms_of(a, start, center, normal, radius, sweep, helix, ab, c, uv)
        cs, ss = math.cos(sw), math.sin(sw)
        vt = math.inf
        an = math.inf
        jt = math.inf
        for i in range(3):
            tmax = max_abs_tangent(ab, c, i, sw, cs, ss)
            t_max[i] = tmax
            nmax = max_abs_normal(uv, i, sw, cs, ss)
            if tmax > 0.0:
                vt = min(vt, max_velocity[i] / tmax)
                jt = min(jt, max_jerk[i] / tmax)
            if nmax > 0.0:
                an = min(an, max_accel[i] / nmax)
        v_t_min[k], a_n_min[k], j_t_min[k] = vt, an, jt
        phi, cp, sp = -1.0, 1.0, 0.0
        if math.isfinite(j_ncu):
            phi, cp, sp = first_carrying_angle(ab, c, sw, cs, ss, max_jerk, j_floor,
                                               t_max)
        carried[k] = phi >= 0.0
        if phi < 0.0:
            phi, cp, sp = largest_jerk_angle(ab, c, sw, cs, ss, max_jerk, cand, t)
        phi_c[k] = phi
        tangent_at(ab, c, cp, sp, t)
        normal_at(uv, cp, sp, nv)
        alpha_c[k] = plane_angle_rad(normal[a], t)
        j_t_c[k] = weakest_axis(max_jerk, t)
        if carried[k]:
            j_t_c[k] = max(j_t_c[k], j_ncu)
        v_t_c[k] = weakest_axis(max_velocity, t)
        a_n_c[k] = weakest_axis(max_accel, nv)
    return r_curv, phi_c, alpha_c, carried, j_t_c, v_t_c, a_n_c, v_t_min, a_n_min, j_t_min


@njit(cache=True, nogil=True, python_below=ARCS_PYTHON_BELOW)
def arc_tangential_accel(arcs, start, center, normal, radius, sweep, helix, max_accel,
                         normal_accel):
    """Least tangential acceleration the axes leave over each arc ``arcs[k]`` at the normal
    acceleration ``normal_accel[k]`` (eq. 1 per axis, :func:`least_tangential_accel`)."""
    n = arcs.shape[0]
    out = np.empty(n)
    ab, uv, c = _scratch()
    for k in range(n):
        _, sw = _terms_of(arcs[k], start, center, normal, radius, sweep, helix, ab, c, uv)
        out[k] = least_tangential_accel(ab, c, uv, sw, math.cos(sw), math.sin(sw), max_accel,
                                        normal_accel[k])
    return out


@njit(cache=True, nogil=True)
def _end_frame(ab, c, uv, r_curv, phi, tangent, curvature):
    """Unit tangent and curvature vector ``n / R`` at the angle ``phi`` into the given rows."""
    cp, sp = math.cos(phi), math.sin(phi)
    tangent_at(ab, c, cp, sp, tangent)
    normal_at(uv, cp, sp, curvature)
    for i in range(3):
        curvature[i] /= r_curv


@njit(cache=True, nogil=True, python_below=ARCS_PYTHON_BELOW)
def arc_end_frames(arcs, start, center, normal, radius, sweep, helix, offset, tangent_0,
                   curvature_0, tangent_1, curvature_1):
    """Unit tangent and curvature vector ``n / R`` (1/mm, R the curvature radius) at the start
    and at the end of each arc ``arcs[k]``, written into row ``arcs[k] - offset`` of the four
    ``(m, 3)`` arrays (start tangent, start curvature, end tangent, end curvature) -- the
    junction frames of eq. 13-15 (``geometry.tangent_at`` and ``curvature_at``, compiled)."""
    ab, uv, c = _scratch()
    for k in range(arcs.shape[0]):
        a = arcs[k]
        r = a - offset
        r_curv, _ = _terms_of(a, start, center, normal, radius, sweep, helix, ab, c, uv)
        _end_frame(ab, c, uv, r_curv, 0.0, tangent_0[r], curvature_0[r])
        _end_frame(ab, c, uv, r_curv, sweep[a], tangent_1[r], curvature_1[r])
