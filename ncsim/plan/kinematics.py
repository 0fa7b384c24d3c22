"""The paper's kinematic equations as small, pure, vectorised functions.

Paper: "Circular tests for HSM machine tools: Bore machining application" (``shared/paper``),
§3.1 (eq. 1-5), §3.2 (eq. 6), §5.2 (eq. 7-12), §5.3-5.4 (eq. 13-15). Units inside: mm, s, rad
(velocities mm/s, accelerations mm/s^2, jerks mm/s^3); the paper's m/min, m/s^2, m/s^3 are
converted by :mod:`ncsim.units` at the edges. Eq. 16 (the A/C ramps) is in :mod:`ncsim.plan.ramps`.

The angle alpha of eq. 7-9 and 15
---------------------------------
The paper writes the axis limits of an XY circle with an angle alpha. Read alpha as the
direction angle of the path tangent in the working plane (design/model-notes.md): with the
unit tangent ``t = (cos a, sin a, 0)`` and the unit principal normal ``n = (-sin a, cos a, 0)``
the paper's formulas are the special cases of one rule, "the weakest axis along the direction
of the quantity sets the limit"::

    eq. 7   V_t  = min(V_mx/|cos a|, V_my/|sin a|) = min_i V_mi / |t_i|   (velocity is along t)
    eq. 8   A_n  = min(A_mx/|sin a|, A_my/|cos a|) = min_i A_mi / |n_i|   (steady accel along n)
    eq. 9   J_t  = min(J_mx/|cos a|, J_my/|sin a|) = min_i J_mi / |t_i|   (steady jerk along t)
    eq. 15  J_t at a transition: eq. 9 with the tangent at the junction.

The functions below take the 3-D unit vectors ``t`` / ``n`` (shape ``(..., 3)``) and the
per-axis limits (shape ``(3,)``), so they hold for any plane, for helices and for lines;
:func:`tangent_from_angle` and :func:`normal_from_angle` build the paper's planar case. An
axis whose component is 0 does not limit (its ratio is +inf).
"""
from __future__ import annotations

import numpy as np

__all__ = [
    "tangent_from_angle", "normal_from_angle",
    "axis_velocity_feed_limit_mm_s", "axis_normal_accel_limit_mm_s2",
    "axis_tangential_jerk_limit_mm_s3", "axis_tangential_accel_limit_mm_s2",
    "tangential_accel_available_mm_s2",
    "normal_accel_feed_limit_mm_s", "tangential_jerk_on_circle_mm_s3",
    "tangential_jerk_feed_limit_mm_s", "static_lookahead_mm_s", "cycle_time_feed_limit_mm_s",
    "ncu_tangential_jerk_mm_s3", "ncu_path_jerk_feed_limit_mm_s", "feed_set_point_mm_s",
    "curvature_jump_1_mm", "transition_feed_mm_s", "transition_feed_from_radii_mm_s",
    "deflection_angle_rad", "corner_feed_g64_mm_s", "curvature_change_feed_mm_s",
    "brisk_jerk_mm_s3", "drive_accel_mm_s2",
]


# ---------------------------------------------------------------------------------------------
# The paper's planar angle -> vectors
# ---------------------------------------------------------------------------------------------

def tangent_from_angle(alpha_rad) -> np.ndarray:
    """Unit tangent ``(cos a, sin a, 0)`` of direction angle ``alpha_rad`` in the XY plane
    (the reading of alpha in eq. 7-9, 15). Shape ``(..., 3)``."""
    a = np.asarray(alpha_rad, dtype=np.float64)
    return np.stack([np.cos(a), np.sin(a), np.zeros_like(a)], axis=-1)


def normal_from_angle(alpha_rad) -> np.ndarray:
    """Unit normal ``(-sin a, cos a, 0)``, perpendicular to :func:`tangent_from_angle` (eq. 8;
    its sign does not matter to the limits). Shape ``(..., 3)``."""
    a = np.asarray(alpha_rad, dtype=np.float64)
    return np.stack([-np.sin(a), np.cos(a), np.zeros_like(a)], axis=-1)


def _min_ratio(numerator, denominator) -> np.ndarray:
    """min_i num_i / |den_i| over the last axis (length 3); +inf where den_i = 0 (or all are).
    Column by column: numpy reductions over a short last axis are slow."""
    num = np.asarray(numerator, dtype=np.float64)
    den = np.abs(np.asarray(denominator, dtype=np.float64))
    shape = np.broadcast_shapes(num.shape, den.shape)[:-1]
    out = np.full(shape, np.inf)
    for i in range(den.shape[-1]):
        d = np.broadcast_to(den[..., i], shape)
        q = np.divide(np.broadcast_to(num[..., i], shape), d, out=np.full(shape, np.inf),
                      where=d > 0.0)
        np.minimum(out, q, out=out)
    return out


def _weakest_axis_along(axis_limit, direction) -> np.ndarray:
    """min_i L_i / |d_i| over the last axis; +inf where a component is zero (or all are)."""
    return _min_ratio(axis_limit, direction)


# ---------------------------------------------------------------------------------------------
# Axis capacities along the path (eq. 7, 8, 9, 15; eq. 1 for the tangential share)
# ---------------------------------------------------------------------------------------------

def axis_velocity_feed_limit_mm_s(tangent, max_velocity_mm_s) -> np.ndarray:
    """V_t = min_i V_mi / |t_i| -- paper eq. 7 (42.4 m/min at alpha = 45 deg for 30 m/min axes)."""
    return _weakest_axis_along(max_velocity_mm_s, tangent)


def axis_normal_accel_limit_mm_s2(normal, max_accel_mm_s2) -> np.ndarray:
    """A_n = min_i A_mi / |n_i| -- paper eq. 8, the normal acceleration the axes can carry
    (planar: min(A_mx/|sin a|, A_my/|cos a|), largest at tan a = A_mx/A_my)."""
    return _weakest_axis_along(max_accel_mm_s2, normal)


def axis_tangential_jerk_limit_mm_s3(tangent, max_jerk_mm_s3) -> np.ndarray:
    """J_t = min_i J_mi / |t_i| -- paper eq. 9, and eq. 15 at a transition's tangent
    (7.07 m/s^3 at alpha = 45 deg for 5 m/s^3 axes)."""
    return _weakest_axis_along(max_jerk_mm_s3, tangent)


def axis_tangential_accel_limit_mm_s2(tangent, max_accel_mm_s2) -> np.ndarray:
    """min_i A_mi / |t_i|: the tangential acceleration the axes allow on a straight path
    (paper eq. 1 with V_f^2 / R = 0)."""
    return _weakest_axis_along(max_accel_mm_s2, tangent)


def tangential_accel_available_mm_s2(tangent, normal, normal_accel_mm_s2,
                                     max_accel_mm_s2) -> np.ndarray:
    """Tangential acceleration left by a normal acceleration a_n -- paper eq. 1 split per axis:
    A_i(t) = a_t t_i + a_n n_i must stay within A_mi, so
    ``a_t <= min_i (A_mi - a_n |n_i|) / |t_i|`` (an axis with t_i = 0 does not limit it).
    Clipped at 0 where the normal part alone saturates an axis."""
    n = np.abs(np.asarray(normal, dtype=np.float64))
    a_n = np.asarray(normal_accel_mm_s2, dtype=np.float64)[..., None]
    room = np.maximum(np.asarray(max_accel_mm_s2, dtype=np.float64) - a_n * n, 0.0)
    return _min_ratio(room, tangent)


# ---------------------------------------------------------------------------------------------
# Feed limits on a circle of radius R (eq. 2-6)
# ---------------------------------------------------------------------------------------------

def normal_accel_feed_limit_mm_s(radius_mm, normal_accel_mm_s2) -> np.ndarray:
    """V_An = sqrt(R * A_n) -- paper eq. 2 (steady feed whose normal acceleration is A_n)."""
    return np.sqrt(np.asarray(radius_mm, dtype=np.float64) * normal_accel_mm_s2)


def tangential_jerk_on_circle_mm_s3(feed_mm_s, radius_mm) -> np.ndarray:
    """J_t = V_f^3 / R^2 -- paper eq. 3, the jerk of the direction change at steady feed."""
    v = np.asarray(feed_mm_s, dtype=np.float64)
    r = np.asarray(radius_mm, dtype=np.float64)
    return v ** 3 / (r * r)


def tangential_jerk_feed_limit_mm_s(jerk_mm_s3, radius_mm) -> np.ndarray:
    """V_Jt = (J_t * R^2)^(1/3) -- paper eq. 4 (the inverse of eq. 3)."""
    r = np.asarray(radius_mm, dtype=np.float64)
    return np.cbrt(np.asarray(jerk_mm_s3, dtype=np.float64) * r * r)


def static_lookahead_mm_s(v_t_mm_s, v_an_mm_s, v_jt_mm_s) -> np.ndarray:
    """V_s = min(V_t, V_An, V_Jt) -- paper eq. 5, the "static look-ahead"."""
    return np.minimum(np.minimum(v_t_mm_s, v_an_mm_s), v_jt_mm_s)


def cycle_time_feed_limit_mm_s(length_mm, ipo_cycle_s) -> np.ndarray:
    """V_tcy = L / t_cy -- paper eq. 6 (L = R (alpha_e - alpha_s) on an arc): a block lasts at
    least one interpolation cycle. A block of zero length is not limited (+inf)."""
    length = np.asarray(length_mm, dtype=np.float64)
    return np.where(length > 0.0, length / ipo_cycle_s, np.inf)


# ---------------------------------------------------------------------------------------------
# NCU settings and the set point (eq. 10-12)
# ---------------------------------------------------------------------------------------------

def ncu_tangential_jerk_mm_s3(curvilinear_jerk_mm_s3, tangential_jerk_share):
    """J_tcurv = J_curv * r_jct -- paper eq. 10 (10 m/s^3 * 60 % = 6 m/s^3 on the MIKRON)."""
    return curvilinear_jerk_mm_s3 * tangential_jerk_share


def ncu_path_jerk_feed_limit_mm_s(ncu_tangential_jerk_mm_s3_, radius_mm) -> np.ndarray:
    """V_Jtcurv = (J_tcurv * R^2)^(1/3) -- paper eq. 11 (2.01 m/min at R 2.5, 10.53 at R 30)."""
    return tangential_jerk_feed_limit_mm_s(ncu_tangential_jerk_mm_s3_, radius_mm)


def feed_set_point_mm_s(*limits_mm_s):
    """V_st = min(V_prog, V_Jtcurv, V_Jt, V_An, V_t, V_tcy) -- paper eq. 12.

    Takes the candidate limits (broadcastable arrays) in a fixed order and returns
    ``(set_point, index)``: the elementwise minimum and the position of the first candidate
    that reaches it (ties go to the earlier candidate)."""
    stack = np.stack(np.broadcast_arrays(*[np.asarray(v, dtype=np.float64) for v in limits_mm_s]))
    index = np.argmin(stack, axis=0)
    return np.take_along_axis(stack, index[None], axis=0)[0], index


# ---------------------------------------------------------------------------------------------
# Transitions (eq. 13-15)
# ---------------------------------------------------------------------------------------------

def curvature_jump_1_mm(curvature_before_1_mm, curvature_after_1_mm) -> np.ndarray:
    """|kappa_1 n_1 - kappa_2 n_2|: the jump of the curvature vector at a junction (1/mm).

    Same-side tangent arcs: |1/R1 - 1/R2|; line -> arc: 1/R; reversal (S): 1/R1 + 1/R2."""
    d = np.asarray(curvature_before_1_mm, dtype=np.float64) - np.asarray(curvature_after_1_mm,
                                                                          dtype=np.float64)
    return np.linalg.norm(d, axis=-1)


def transition_feed_mm_s(jerk_mm_s3, transition_time_s, curvature_jump_1_mm_) -> np.ndarray:
    """V_fr = sqrt(J_t * dt / |kappa_1 n_1 - kappa_2 n_2|) -- paper eq. 13 generalised.

    Crossing a curvature jump at constant feed V changes the normal acceleration by
    V^2 * |delta kappa| within dt, a jerk the axes can carry up to J_t (eq. 14, 15). For
    same-side arcs |delta kappa| = |R1 - R2| / (R1 R2), which is the paper's eq. 13 (see
    :func:`transition_feed_from_radii_mm_s`); line -> arc gives sqrt(R J_t dt); a reversal
    gives sqrt(J_t dt R1 R2 / (R1 + R2)). No jump: +inf."""
    dk = np.asarray(curvature_jump_1_mm_, dtype=np.float64)
    num = np.asarray(jerk_mm_s3, dtype=np.float64) * transition_time_s
    num = np.broadcast_to(num, np.broadcast_shapes(num.shape, dk.shape))
    dk = np.broadcast_to(dk, num.shape)
    return np.sqrt(np.divide(num, dk, out=np.full(dk.shape, np.inf), where=dk > 0.0))


def transition_feed_from_radii_mm_s(radius_before_mm, radius_after_mm, jerk_mm_s3,
                                    transition_time_s) -> np.ndarray:
    """V_fr = sqrt(R1 R2 J_t dt / |R1 - R2|) -- paper eq. 13 as printed (same-side tangent arcs;
    +inf for R1 = R2). 4.92 / 5.29 / 5.85 m/min for 14 -> 16 mm at 0 / 30 / 45 deg (§5.4.1)."""
    r1 = np.asarray(radius_before_mm, dtype=np.float64)
    r2 = np.asarray(radius_after_mm, dtype=np.float64)
    return transition_feed_mm_s(jerk_mm_s3, transition_time_s, np.abs(1.0 / r1 - 1.0 / r2))


# ---------------------------------------------------------------------------------------------
# Corners (tangent discontinuities) -- not in the paper's model; 840D continuous-path behaviour
# (the rounding of G641-G645 is in ncsim.plan.blend)
# ---------------------------------------------------------------------------------------------

def overridden_feed_mm_s(feed_mm_s, feed_override) -> np.ndarray:
    """The path feed the NC runs: programmed F times the feed override (840D V1 "feed
    override", 0..120 % on the machine control panel; the axis limits still apply)."""
    return np.asarray(feed_mm_s, dtype=np.float64) * feed_override


def rapid_feed_mm_s(axis_velocity_limit_mm_s, rapid_override) -> np.ndarray:
    """G0 path velocity: the axis-velocity limit along the line (MD32000 $MA_MAX_AX_VELO,
    eq. 7) times the rapid-traverse override (840D V1 "rapid traverse override")."""
    return np.asarray(axis_velocity_limit_mm_s, dtype=np.float64) * rapid_override


def deflection_angle_rad(tangent_before, tangent_after) -> np.ndarray:
    """Angle between two unit tangents (0 = smooth, pi = reversal), robust near 0 and pi."""
    t1 = np.asarray(tangent_before, dtype=np.float64)
    t2 = np.asarray(tangent_after, dtype=np.float64)
    return np.arctan2(np.linalg.norm(np.cross(t1, t2), axis=-1), np.sum(t1 * t2, axis=-1))


def corner_feed_g64_mm_s(tangent_before, tangent_after, max_accel_mm_s2, ipo_cycle_s,
                         overload_factor) -> np.ndarray:
    """G64 corner feed without rounding (840D B1 "Continuous-path mode", overload factor): the
    velocity of axis i may jump at a block end by ``A_mi (MD32310_i - 1) t_IPO``, and crossing
    the corner at feed V makes it jump by V |t2_i - t1_i|, so
    ``V = min_i A_mi (f_i - 1) t_cy / |t2_i - t1_i|`` (f = MD32310 $MA_MAX_ACCEL_OVL_FACTOR per
    axis or one value). f = 1 gives 0 ("only tangential transitions at finite velocity"); +inf
    without a corner."""
    jump = np.asarray(tangent_after, dtype=np.float64) - np.asarray(tangent_before,
                                                                     dtype=np.float64)
    allowed = ((np.asarray(overload_factor, dtype=np.float64) - 1.0)
               * np.asarray(max_accel_mm_s2, dtype=np.float64) * ipo_cycle_s)
    return _weakest_axis_along(allowed, jump)


def curvature_change_feed_mm_s(jerk_mm_s3, transition_time_s, curvature_change_1_mm,
                               length_mm) -> np.ndarray:
    """Crossing a curvature change spread over a length -- paper eq. 13/14 generalised.

    At constant feed V a change |delta kappa| of the curvature vector changes the normal
    acceleration by V^2 |delta kappa| (eq. 1), within the time the tool takes over the change:
    l / V, but never less than the transition time dt (eq. 13: a jump is crossed in dt). The
    jerk V^2 |delta kappa| / max(l / V, dt) must stay within J_t (eq. 14/15). It grows with V,
    so the highest feed is the larger of the two branches::

        V = max(sqrt(J_t dt / |delta kappa|)  [eq. 13],  (J_t l / |delta kappa|)^(1/3))

    l = 0 is eq. 13 itself; no change gives +inf. Used where the 840D smooths a curvature jump
    over a length: corner rounding (G641-G645), the compressor's curves, G645 transitions."""
    dk = np.asarray(curvature_change_1_mm, dtype=np.float64)
    j = np.asarray(jerk_mm_s3, dtype=np.float64)
    length = np.asarray(length_mm, dtype=np.float64)
    j, dk, length = np.broadcast_arrays(j, dk, length)
    jump = transition_feed_mm_s(j, transition_time_s, dk)
    spread = np.cbrt(np.divide(j * length, dk, out=np.full(dk.shape, np.inf), where=dk > 0.0))
    return np.maximum(jump, spread)


# ---------------------------------------------------------------------------------------------
# Acceleration modes (paper §3.3.2): BRISK and DRIVE are acceleration-limited laws
# ---------------------------------------------------------------------------------------------

def brisk_jerk_mm_s3(accel_mm_s2, ipo_cycle_s) -> np.ndarray:
    """BRISK: the acceleration is switched on within one interpolation cycle, J = A / t_cy."""
    return np.asarray(accel_mm_s2, dtype=np.float64) / ipo_cycle_s


def drive_accel_mm_s2(accel_mm_s2, feed_mm_s, max_feed_mm_s, speed_point_ratio,
                      reduction_ratio) -> np.ndarray:
    """DRIVE: full acceleration up to p * V_max, then reduced linearly to (1 - r) * A at V_max
    (840D MD35220 / MD35230): ``A * (1 - r * clip((V - p V_max) / (V_max - p V_max), 0, 1))``.
    With p = 1 there is no reduction."""
    a = np.asarray(accel_mm_s2, dtype=np.float64)
    v = np.asarray(feed_mm_s, dtype=np.float64)
    vmax = np.asarray(max_feed_mm_s, dtype=np.float64)
    v, vmax, a = np.broadcast_arrays(v, vmax, a)
    span = vmax * (1.0 - speed_point_ratio)
    ok = (span > 0.0) & np.isfinite(span)
    share = np.divide(v - speed_point_ratio * vmax, span, out=np.zeros(v.shape), where=ok)
    return a * (1.0 - reduction_ratio * np.clip(np.nan_to_num(share), 0.0, 1.0))
