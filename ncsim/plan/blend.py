"""Corner rounding in continuous-path mode: G641 (ADIS), G642/G643/G644/G645 (tolerances).

What the 840D does (SINUMERIK 828D/840D Basic Functions B1, "Continuous-path mode",
"Rounding according to a path criterion (G641)", "Rounding in compliance with defined
tolerances (G642/G643)", "G645"; Job Planning "CTOL, OTOL, ATOL"):

* at a corner crossed in continuous-path mode the 840D inserts an intermediate rounding block
  and shortens the two adjoining blocks; the rounding lies within the adjoining blocks and
  "the maximum acceleration values of the axes are not exceeded";
* its size: G641 starts it at most ADIS (ADISPOS for G0) before the block end and ends it at
  most ADIS after it; G642/G643/G645 keep the deviation from the corner within the tolerance:
  CTOL when programmed (CYCLE832 programs it), else per MD20480 tens digit the contour
  tolerance SD42465 ``$SC_SMOOTH_CONTUR_TOL`` (1) or the axis tolerances MD33100
  ``$MA_COMPRESS_POS_TOL`` (0);
* on short blocks the rounding distance is reduced so that about 60 % of the rest of the block
  remains ("ADIS is reduced to the remaining 40 %"): here every rounding distance is at most
  ``BLOCK_SHARE`` = 40 % of what is left of each adjoining block (for the block before the
  corner: after the largest share its own start corner may take);
* no rounding block is inserted where the axes stop anyway (auxiliary output, BRISK/SOFT
  change, exact stop, G0/G1 change: ncsim's stop junctions), nor where G64 crosses the corner
  without slowing down -- so MD32310 (the G64 jump) decides whether a corner is rounded, except
  under G643 or with MD20490 ``$MC_IGNORE_OVL_FACTOR_FOR_ADIS`` -- nor "between two very short
  blocks", whose intermediate block would double the time: here, when an adjoining block is
  shorter than its feed covers in one interpolation cycle (such corners run as G64, the
  manual's implicit G64); nor -- ncsim's reading of the same rule, the rounding being there to
  keep the path from slowing down at the corner -- where the rounding block would take longer
  than the G64 corner it replaces (:func:`_rounding_saves_time`: the planner's ramps away
  from the G64 crossing against the rounding held at its feed and the ramps from its ends,
  over half of each adjoining block). So rounding never costs time against G64, and a larger
  tolerance (a longer, flatter rounding) none against a smaller one
  (``tests/test_hsm_properties.py``). The rounding block is planned at the feed of its peak
  curvature over its whole length (below), which is pessimistic for a clothoid whose
  curvature falls to 0 at both ends: a small tolerance at a high feed -- a rounding held at a
  few mm/s by eq. 11 or ADIS / t_cy, against the MIKRON's 30 mm/s G64 jump at 90 deg -- stays
  a G64 corner (``tests/test_cycle832.py``: the THWS programs' 0.02 mm roundings);
* "every interpolated block, even an intermediate rounding block, contains at least one
  interpolation point. The maximum path velocity is thereby limited to ADIS / interpolation
  cycle" (eq. 6 for the rounding block: d / t_cy, d its rounding distance);
* in the smoothing range the axes run with jerk limitation under SOFT, without it under BRISK
  (MD20480, ten-thousands digit 0);
* G0 blocks are rounded with the same tolerance (the G0 tolerance factor MD20560 and
  CTOLG0/STOLF are not simulated);
* G645 also smooths tangential transitions with a curvature jump, within MD33120
  ``$MA_PATH_TRANS_POS_TOL``; G644 (rounding with the greatest possible dynamics, MD20480
  thousands digit) is simulated as G642 (the interpreter warns).

The rounding curve. The 840D's rounding polynomials have a continuous curvature; a circular arc
would not, and its two curvature jumps would be charged at eq. 13 (V = sqrt(J dt / delta
kappa)), far below what the 840D reaches. The rounding is modelled as the symmetric
*clothoid pair* of total length L turning by the deflection phi: curvature rising linearly
from 0 to kappa_max = 2 phi / L in the middle and back (the curvature-continuous blend of least
peak jerk for its length). Its end points lie d = g(phi) L before and after the corner and its
middle deviates e = h(phi) L from it, in closed form through the Fresnel integrals
(:func:`clothoid_pair_shape`; small phi: d = L/2, e = phi L / 12). The feed on it is the least
of (closed forms, :func:`rounding_feed_mm_s`)::

    eq. 2/8   sqrt(normal_accel_share A_n(n_m) / kappa_max)     A_n along the middle normal
    eq. 11    (J_tcurv / kappa_max^2)^(1/3)                      SOFT
    eq. 4/9   (J_t(t_m) / kappa_max^2)^(1/3)                     SOFT
    eq. 13    curvature 0 -> kappa_max spread over L / 2          SOFT (curvature_change_feed)
    eq. 6     d / t_cy                                           (the manual's ADIS / IPO cycle)
    F of the adjoining blocks, V_t along both tangents (eq. 7)

The Path holds lines and arcs only, so the rounding block is *sampled* as the circular arc
tangent to both blocks with the same deviation e from the corner (tangent length
e / tan(phi / 4) <= d: it lies inside the planned rounding), and its two ends are smooth
junctions: the planner uses the closed forms above for it, never the stand-in arc's own
curvature (``ncsim.plan.hsm`` applies them). A corner with an arc on one side is rounded the
same way in time (its crossing feed is the rounding's) but keeps its programmed geometry.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ncsim.geometry import end_curvatures, end_tangents, start_curvatures, start_tangents
from ncsim.machine import MachineSpec
from ncsim.motion import Limit, ModelOptions
from ncsim.path import ARC, LINE, SOFT, Path, path_columns
from ncsim.plan import kinematics as kin
from ncsim.plan.ramps import ramp_distance_mm, ramp_reach_mm_s, ramp_time_s

ROUNDING_MODES = (641, 642, 643, 644, 645)
BLOCK_SHARE = 0.4                 # rounding distance <= 40 % of what is left of a block (B1 G641)
TANGENT_TOL_RAD = 1e-4            # deflection above which a junction is a corner (as plan.limits)
CURVATURE_TOL_REL = 1e-6          # relative curvature jump that counts as a transition
_MAX_DEFLECTION_RAD = np.pi - 1e-6  # a reversal cannot be rounded
_SMALL_RAD = 1e-6                 # below: the small-angle series of the clothoid pair
_FEED_REL = 1e-9                  # relative margin when comparing crossing feeds


def clothoid_pair_shape(deflection_rad) -> tuple[np.ndarray, np.ndarray]:
    """``(g, h)`` of the symmetric clothoid pair turning by ``deflection_rad`` (phi): per unit
    of its length L, the distance d = g L of its ends from the corner along the adjoining
    blocks, and the distance e = h L of its middle from the corner.

    Its first half (length L/2, curvature c s with c = 4 phi / L^2) ends at
    x_m = a C(z), y_m = a S(z), with a = sqrt(pi / c), z = L / (2 a) and C, S the Fresnel
    integrals; by symmetry the corner lies on the normal through that middle point, so
    d = x_m + y_m tan(phi/2) and e = y_m / cos(phi/2). For small phi: g = 1/2, h = phi/12."""
    from scipy.special import fresnel   # only where corners are rounded: a short run needs no scipy

    phi = np.asarray(deflection_rad, dtype=np.float64)
    small = phi < _SMALL_RAD
    p = np.where(small, 1.0, phi)
    a = np.sqrt(np.pi / (4.0 * p))                 # L = 1
    s_z, c_z = fresnel(0.5 / a)
    x_m, y_m = a * c_z, a * s_z
    g = x_m + y_m * np.tan(p / 2.0)
    h = y_m / np.cos(p / 2.0)
    return np.where(small, 0.5, g), np.where(small, phi / 12.0, h)


def axial_tolerance_along_mm(axis_tol_mm, direction) -> np.ndarray:
    """The largest deviation along ``direction`` (unit, (..., 3)) keeping every axis i within
    its tolerance: min_i tol_i / |direction_i| (MD33100 per axis, G642 with MD20480 = 0)."""
    return kin.axis_velocity_feed_limit_mm_s(direction, axis_tol_mm)   # same weakest-axis rule


def rounding_feed_mm_s(deflection_rad, length_mm, distance_mm, t_before, t_after, machine,
                       options: ModelOptions, soft, feed_before_mm_s, feed_after_mm_s):
    """Feed on the clothoid rounding of total length ``length_mm`` and rounding distance
    ``distance_mm`` at corners between unit tangents ``t_before`` and ``t_after`` (module
    docstring). Returns ``(feed, limit)``, the limit as in :class:`~ncsim.motion.Limit`
    (the curvature limits are reported as CORNER)."""
    ncu = machine.ncu
    phi = np.asarray(deflection_rad, dtype=np.float64)
    length = np.asarray(length_mm, dtype=np.float64)
    kappa = np.divide(2.0 * phi, length, out=np.full(phi.shape, np.inf), where=length > 0.0)
    t_mid = _unit(t_before + t_after)
    n_mid = _unit(t_after - t_before)
    inf = np.full(phi.shape, np.inf)
    a_n = ncu.normal_accel_share * kin.axis_normal_accel_limit_mm_s2(n_mid, machine.max_accel_mm_s2)
    radius = np.divide(1.0, kappa, out=np.zeros_like(kappa), where=np.isfinite(kappa))
    v_accel = kin.normal_accel_feed_limit_mm_s(radius, a_n)
    j_t = np.minimum(kin.axis_tangential_jerk_limit_mm_s3(t_before, machine.max_jerk_mm_s3),
                     kin.axis_tangential_jerk_limit_mm_s3(t_after, machine.max_jerk_mm_s3))
    v_ncu = v_axis_jerk = v_change = inf
    if options.ncu_path_jerk:
        v_ncu = np.where(soft, kin.ncu_path_jerk_feed_limit_mm_s(ncu.tangential_jerk_mm_s3, radius), np.inf)
    if options.axis_jerk_setpoint:
        j_mid = kin.axis_tangential_jerk_limit_mm_s3(t_mid, machine.max_jerk_mm_s3)
        v_axis_jerk = np.where(soft, kin.tangential_jerk_feed_limit_mm_s(j_mid, radius), np.inf)
    if options.transition_crossing:
        v_change = np.where(soft, kin.curvature_change_feed_mm_s(j_t, ncu.transition_time_s, kappa,
                                                                 length / 2.0), np.inf)
    v_cycle = (kin.cycle_time_feed_limit_mm_s(distance_mm, ncu.ipo_cycle_s)
               if options.cycle_time_limit else inf)
    v_prog = np.minimum(feed_before_mm_s, feed_after_mm_s)
    v_axes = np.minimum.reduce([kin.axis_velocity_feed_limit_mm_s(t, machine.max_velocity_mm_s)
                                for t in (t_before, t_after, t_mid)])
    stack = np.stack([v_prog, v_ncu, v_axis_jerk, v_accel, v_axes, v_cycle, v_change])
    which = np.argmin(stack, axis=0)
    labels = np.array([Limit.PROGRAMMED, Limit.CORNER, Limit.CORNER, Limit.CORNER,
                       Limit.AXIS_VELOCITY, Limit.CYCLE_TIME, Limit.CORNER], dtype=np.int8)
    return np.take_along_axis(stack, which[None], axis=0)[0], labels[which]


@dataclass(frozen=True, slots=True)
class Rounding:
    """The path with its rounding blocks, and what the planner must know about them.

    ``row_of`` maps each programmed row to its row in ``path``; ``blend_row`` are the inserted
    rounding blocks and ``blend_feed_mm_s``/``blend_limit`` their feed; corners rounded in time
    only (an arc on one side) are ``junction_row`` (junction indices of ``path``) with
    ``junction_feed_mm_s``/``junction_limit``; ``transition_*`` are the G645-smoothed
    tangential transitions (junction indices of ``path``)."""

    path: Path
    row_of: np.ndarray
    blend_row: np.ndarray
    blend_feed_mm_s: np.ndarray
    blend_limit: np.ndarray
    blend_accel_mm_s2: np.ndarray
    junction_row: np.ndarray
    junction_feed_mm_s: np.ndarray
    junction_limit: np.ndarray
    transition_row: np.ndarray
    transition_feed_mm_s: np.ndarray
    deviation_mm: np.ndarray          # per rounded corner: distance of the rounding from it


def round_corners(path: Path, machine: MachineSpec, options: ModelOptions,
                  smooth: np.ndarray) -> Rounding | None:
    """Rounding blocks for the corners of ``path`` crossed under G641-G645 (module docstring);
    junctions where ``smooth`` is True (inside compressed runs) are not corners. None when
    nothing is rounded."""
    n = path.n
    if n < 2 or not np.any(np.isin(path.cp_mode, ROUNDING_MODES)):
        return None
    ncu = machine.ncu
    k = np.arange(1, n)                            # junction k: end of block k-1, start of k
    a, b = k - 1, k
    t1 = end_tangents(path)[:-1]
    t2 = start_tangents(path)[1:]
    phi = kin.deflection_angle_rad(t1, t2)
    mode = path.cp_mode[a]
    moving = ~((path.rapid[a] != path.rapid[b]) | path.stop_before[b] | path.exact_stop[a]
               | (path.dwell_before_s[b] > 0.0) | smooth[1:n])
    rounding_mode = np.isin(mode, ROUNDING_MODES) & moving
    corner = rounding_mode & (phi > TANGENT_TOL_RAD) & (phi < _MAX_DEFLECTION_RAD)

    transitions = _g645_transitions(path, machine, options, rounding_mode & (mode == 645)
                                    & (phi <= TANGENT_TOL_RAD), t1)
    if not corner.any() and transitions is None:
        return None

    ci = np.nonzero(corner)[0]                     # corners, as positions in k
    g, h = clothoid_pair_shape(phi[ci])
    tol = _tolerance_mm(path, machine, a[ci], t1[ci], t2[ci])
    d_nominal = np.zeros(n - 1)
    d_nominal[ci] = np.where(mode[ci] == 641, path.adis_mm[a[ci]],
                             np.divide(g * tol, h, out=np.zeros_like(g), where=h > 0.0))
    length = path.length_mm
    # the share the corner at the start of block a may take (its nominal distance, capped)
    start_share = np.concatenate([[0.0], np.minimum(d_nominal[:-1], BLOCK_SHARE * length[a[1:]])])
    ac, bc = a[ci], b[ci]
    d = np.minimum.reduce([d_nominal[ci], BLOCK_SHARE * length[bc],
                           BLOCK_SHARE * np.maximum(length[ac] - start_share[ci], 0.0)])
    blend_len = np.divide(d, g, out=np.zeros_like(d), where=g > 0.0)
    deviation = h * blend_len
    t1c, t2c, phic = t1[ci], t2[ci], phi[ci]

    mode_a = (np.full(len(ci), options.accel_mode) if options.accel_mode is not None
              else path.accel_mode[ac])
    soft = (mode_a == SOFT) & options.jerk_limited_ramps
    # the feeds the NC runs on either side: F times the feed override (kinematics), as the
    # blocks' own set points are capped in plan.limits -- never the programmed F alone
    feed_a = np.where(path.rapid[ac], np.inf,
                      kin.overridden_feed_mm_s(path.feed_mm_s[ac], ncu.feed_override))
    feed_b = np.where(path.rapid[bc], np.inf,
                      kin.overridden_feed_mm_s(path.feed_mm_s[bc], ncu.feed_override))
    v_blend, v_limit = rounding_feed_mm_s(phic, blend_len, d, t1c, t2c, machine, options, soft,
                                          feed_a, feed_b)
    v64 = kin.corner_feed_g64_mm_s(t1c, t2c, machine.max_accel_mm_s2, ncu.ipo_cycle_s,
                                   machine.max_accel_ovl_factor)
    v_adjacent = np.minimum.reduce([feed_a, feed_b,
                                    kin.axis_velocity_feed_limit_mm_s(t1c, machine.max_velocity_mm_s),
                                    kin.axis_velocity_feed_limit_mm_s(t2c, machine.max_velocity_mm_s)])
    always = (mode[ci] == 643) | ncu.ignore_ovl_factor_for_adis
    short = np.minimum(length[ac], length[bc]) < np.minimum(feed_a, feed_b) * ncu.ipo_cycle_s
    short &= options.cycle_time_limit
    v_corner = np.minimum(v64, v_adjacent)          # the corner as G64 crosses it
    both_lines = (path.kind[ac] == LINE) & (path.kind[bc] == LINE)
    faster = np.where(both_lines, _rounding_saves_time(
        machine, options, soft, t1c, t2c, v_corner, np.maximum(v_blend, 1e-300), blend_len, d,
        length[ac], length[bc], v_adjacent), v_blend >= v_corner * (1.0 - _FEED_REL))
    rounded = (d > 0.0) & (v_blend > 0.0) & ~short & (always | (v64 < v_adjacent)) & faster
    if not rounded.any() and transitions is None:
        return None

    ins = np.nonzero(rounded & both_lines)[0]      # positions in ci
    in_time = np.nonzero(rounded & ~both_lines)[0]
    new_path, row_of, blend_row = _insert_blends(path, k[ci[ins]], t1c[ins], t2c[ins], phic[ins],
                                                 deviation[ins])
    kappa = 2.0 * phic[ins] / blend_len[ins]
    accel = kin.tangential_accel_available_mm_s2(_unit(t1c[ins] + t2c[ins]),
                                                 _unit(t2c[ins] - t1c[ins]),
                                                 v_blend[ins] ** 2 * kappa, machine.max_accel_mm_s2)
    floor = 1e-3 * np.minimum(kin.axis_tangential_accel_limit_mm_s2(t1c[ins], machine.max_accel_mm_s2),
                              kin.axis_tangential_accel_limit_mm_s2(t2c[ins], machine.max_accel_mm_s2))
    accel = np.maximum(accel, floor)               # > 0, as the planner needs
    junction_of = np.append(row_of, new_path.n)    # programmed junction -> junction of new_path
    tr_rows = tr_feed = np.zeros(0)
    if transitions is not None:
        tr_k, tr_feed = transitions
        tr_rows = junction_of[tr_k]
    return Rounding(path=new_path, row_of=row_of, blend_row=blend_row,
                    blend_feed_mm_s=v_blend[ins], blend_limit=v_limit[ins], blend_accel_mm_s2=accel,
                    junction_row=junction_of[k[ci[in_time]]], junction_feed_mm_s=v_blend[in_time],
                    junction_limit=v_limit[in_time], transition_row=tr_rows.astype(np.int64),
                    transition_feed_mm_s=tr_feed, deviation_mm=deviation[rounded])


def _rounding_saves_time(machine, options, soft, t1, t2, v_corner, v_blend, blend_len, d,
                         length_before, length_after, v_adjacent) -> np.ndarray:
    """Whether the rounding block (length ``blend_len``, crossed at ``v_blend``, its ends ``d``
    from the corner) takes no longer than the G64 corner it replaces (crossed at ``v_corner``)
    over the stretch around the corner: on each side, half the block (its other end belongs
    to the next corner). G64 leaves the corner with one ramp up to the block's set point (F,
    eq. 7, eq. 6 on the block); the rounding holds v_blend over its length, then ramps along
    the trimmed block (eq. 6 on what is left). Ramps are the planner's, with the block's jerk
    and acceleration (:func:`cover_time_s`, as ``plan.limits`` gives a line: SOFT J_t and
    J_tcurv, BRISK A / t_cy); the approach to the corner is the same law run backwards."""
    ncu = machine.ncu
    t_g64 = np.zeros(len(v_corner))
    t_round = blend_len / v_blend
    for t, block in ((t1, length_before), (t2, length_after)):
        accel = kin.axis_tangential_accel_limit_mm_s2(t, machine.max_accel_mm_s2)
        jerk = kin.axis_tangential_jerk_limit_mm_s3(t, machine.max_jerk_mm_s3)
        if options.ncu_path_jerk:
            jerk = np.minimum(jerk, ncu.tangential_jerk_mm_s3)
        jerk = np.where(soft, jerk, kin.brisk_jerk_mm_s3(accel, ncu.ipo_cycle_s))
        top, top_trimmed = v_adjacent, v_adjacent
        if options.cycle_time_limit:
            top = np.minimum(top, kin.cycle_time_feed_limit_mm_s(block, ncu.ipo_cycle_s))
            top_trimmed = np.minimum(v_adjacent, kin.cycle_time_feed_limit_mm_s(block - d,
                                                                              ncu.ipo_cycle_s))
        window = 0.5 * block
        t_g64 += cover_time_s(v_corner, window, jerk, accel, top)
        t_round += cover_time_s(v_blend, window - d, jerk, accel, top_trimmed)
    return t_round <= t_g64 * (1.0 + _FEED_REL)


def cover_time_s(v0_mm_s, distance_mm, jerk_mm_s3, accel_mm_s2, v_top_mm_s) -> np.ndarray:
    """Time to cover ``distance_mm`` from feed v0 at zero acceleration: one ramp of the planner
    (eq. 16: jerk J, acceleration A, zero acceleration at both ends) up to v_top, then v_top
    held; where the distance is too short for that ramp, the ramp to the highest feed it
    reaches within it (v0 above v_top starts at v_top)."""
    top = np.asarray(v_top_mm_s, dtype=np.float64)
    v0 = np.minimum(np.asarray(v0_mm_s, dtype=np.float64), top)
    x = np.maximum(np.asarray(distance_mm, dtype=np.float64), 0.0)
    ramp = ramp_distance_mm(v0, top, jerk_mm_s3, accel_mm_s2)
    full = ramp_time_s(top - v0, jerk_mm_s3, accel_mm_s2) + (x - ramp) / top
    v1 = np.minimum(ramp_reach_mm_s(v0, x, jerk_mm_s3, accel_mm_s2), top)
    part = ramp_time_s(v1 - v0, jerk_mm_s3, accel_mm_s2)
    return np.where(x >= ramp, full, part)


def _tolerance_mm(path, machine, a, t1, t2) -> np.ndarray:
    """Deviation allowed at the corners: CTOL, else SD42465 or MD33100 per axis (MD20480)."""
    ctol = path.ctol_mm[a]
    if machine.ncu.g642_contour_tolerance:
        md = np.full(len(a), machine.ncu.smooth_contur_tol_mm)
    else:
        md = axial_tolerance_along_mm(machine.compress_pos_tol_mm, _unit(t2 - t1))
    return np.where(np.isfinite(ctol), ctol, md)


def _g645_transitions(path, machine, options, candidate, t1):
    """G645 at tangential transitions with a curvature jump: the jump is spread over the length
    l at which the smoothed curve stays within MD33120 (a curvature step smoothed linearly over
    l moves the path by delta_kappa l^2 / 24), l <= 2 x 40 % of each adjoining block; crossed
    at :func:`~ncsim.plan.kinematics.curvature_change_feed_mm_s`. Returns (junction indices
    of the programmed path, feeds) or None."""
    if not options.transition_crossing or not candidate.any():
        return None
    k1 = end_curvatures(path)[:-1]
    k2 = start_curvatures(path)[1:]
    dk_vec = k1 - k2
    dk = np.sqrt(np.einsum("ij,ij->i", dk_vec, dk_vec))
    scale = np.maximum(np.linalg.norm(k1, axis=1), np.linalg.norm(k2, axis=1))
    sel = np.nonzero(candidate & (dk > CURVATURE_TOL_REL * scale) & (dk > 0.0))[0]
    if sel.size == 0:
        return None
    tol = axial_tolerance_along_mm(machine.path_trans_pos_tol_mm, _unit(dk_vec[sel]))
    length = path.length_mm
    ell = np.minimum(np.sqrt(24.0 * tol / dk[sel]),
                     2.0 * BLOCK_SHARE * np.minimum(length[sel], length[sel + 1]))
    j_t = kin.axis_tangential_jerk_limit_mm_s3(t1[sel], machine.max_jerk_mm_s3)
    v = kin.curvature_change_feed_mm_s(j_t, machine.ncu.transition_time_s, dk[sel], ell)
    return sel + 1, v


def _unit(v: np.ndarray) -> np.ndarray:
    norm = np.sqrt(np.einsum("...i,...i->...", v, v))[..., None]
    return np.divide(v, norm, out=np.zeros_like(v), where=norm > 0.0)


def _insert_blends(path: Path, corners, t1, t2, phi, deviation):
    """``path`` with a circular stand-in rounding block inserted at each corner junction
    ``corners`` (between two lines), the lines trimmed by its tangent length. Returns the new
    path, the new row of every programmed row and the rows of the rounding blocks."""
    n = path.n
    m = len(corners)
    shift = np.zeros(n, dtype=np.int64)
    np.add.at(shift, corners, 1)
    row_of = np.arange(n) + np.cumsum(shift)
    blend_row = corners + np.arange(m)
    if m == 0:
        return path, row_of, blend_row
    d = deviation / np.tan(phi / 4.0)              # tangent length of the stand-in arc
    corner_pt = path.start_mm[corners]
    p1 = corner_pt - d[:, None] * t1
    p2 = corner_pt + d[:, None] * t2
    radius = d / np.tan(phi / 2.0)
    w = _unit(np.cross(t1, t2))
    center = p1 + radius[:, None] * np.cross(w, t1)

    start = path.start_mm.copy()
    end = path.end_mm.copy()
    length = path.length_mm.copy()
    end[corners - 1] = p1
    start[corners] = p2
    np.subtract.at(length, corners - 1, d)
    np.subtract.at(length, corners, d)

    before = corners - 1
    inserted = {
        "kind": np.full(m, ARC), "start_mm": p1, "end_mm": p2, "center_mm": center, "normal": w,
        "radius_mm": radius, "sweep_rad": phi, "helix_mm": np.zeros(m), "length_mm": radius * phi,
        "feed_mm_s": np.minimum(path.feed_mm_s[before], path.feed_mm_s[corners]),
        "exact_stop": np.zeros(m, dtype=bool), "stop_before": np.zeros(m, dtype=bool),
        "dwell_before_s": np.zeros(m), "compressor": np.zeros(m),
    }
    changed = {"start_mm": start, "end_mm": end, "length_mm": length}
    total = n + m
    cols = {}
    for name in path_columns():
        old = changed.get(name, getattr(path, name))
        col = np.empty((total, *old.shape[1:]), dtype=old.dtype)
        col[row_of] = old
        col[blend_row] = inserted[name] if name in inserted else old[before]
        cols[name] = col
    return replace(path, **cols), row_of, blend_row   # its tables (files, tools) kept


@dataclass(frozen=True, slots=True)
class ProgrammedPlaces:
    """The rounded path's places in the programmed path's terms (block by block).

    A programmed line trimmed by ``d`` at a rounded corner keeps its geometry, so its rows map
    one to one, shifted by the trims; the rounding block inserted at the corner between
    programmed blocks ``k-1`` and ``k`` spans the programmed stretch ``[S_k - d, S_k + d]``
    around the corner (at ``S_k``) and is mapped onto it linearly: its first half belongs to
    block ``k-1``, its second to ``k`` (the 840D's rounding lies "within the adjoining blocks",
    B1 "Continuous-path mode"). ``s_rounded_mm``/``s_programmed_mm`` are the junctions of the
    rounded path on both; ``programmed_row`` the programmed row of each rounded row (-1: a
    rounding block)."""

    s_rounded_mm: np.ndarray       # (n' + 1,) junctions of the rounded path, its own length
    s_programmed_mm: np.ndarray    # (n' + 1,) the same junctions along the programmed path
    programmed_row: np.ndarray     # (n',) programmed row of each rounded row; -1: rounding
    corner_s_mm: np.ndarray        # (n',) programmed place of the corner a rounding block rounds

    @classmethod
    def of(cls, programmed: Path, rounded: Path, row_of) -> "ProgrammedPlaces":
        """From the two paths and ``Rounding.row_of`` (programmed row -> rounded row)."""
        row_of = np.asarray(row_of, dtype=np.int64)
        n, n_new = programmed.n, rounded.n
        s_prog = np.concatenate([[0.0], np.cumsum(programmed.length_mm)])
        s_new = np.concatenate([[0.0], np.cumsum(rounded.length_mm)])
        # trims: a rounded corner moves a line's end along the line itself (arcs are untouched)
        trim_start = np.linalg.norm(rounded.start_mm[row_of] - programmed.start_mm, axis=1)
        trim_end = np.linalg.norm(programmed.end_mm - rounded.end_mm[row_of], axis=1)
        places = np.empty(n_new + 1)
        places[row_of + 1] = s_prog[1:] - trim_end
        places[row_of] = s_prog[:-1] + trim_start
        prog_row = np.full(n_new, -1, dtype=np.int64)
        prog_row[row_of] = np.arange(n)
        corner = np.full(n_new, np.nan)
        blend = np.nonzero(prog_row < 0)[0]          # never the last row: a corner has a block after
        corner[blend] = s_prog[prog_row[blend + 1]]
        return cls(s_rounded_mm=s_new, s_programmed_mm=np.maximum.accumulate(places),
                   programmed_row=prog_row, corner_s_mm=corner)

    def programmed_s_mm(self, s_rounded_mm) -> np.ndarray:
        """Path length along the rounded path -> along the programmed path."""
        return np.interp(s_rounded_mm, self.s_rounded_mm, self.s_programmed_mm)

    def rounded_s_mm(self, s_programmed_mm) -> np.ndarray:
        """The inverse of :meth:`programmed_s_mm`."""
        return np.interp(s_programmed_mm, self.s_programmed_mm, self.s_rounded_mm)

    def programmed_block(self, row, s_programmed_mm) -> np.ndarray:
        """The programmed block of points on rounded rows ``row`` at programmed places
        ``s_programmed_mm``: a rounding block's first half is its corner's block before, the
        second half the block after."""
        row = np.asarray(row, dtype=np.int64)
        out = self.programmed_row[row]
        blend = out < 0
        if np.any(blend):
            r = row[blend]
            after = np.asarray(s_programmed_mm)[blend] >= self.corner_s_mm[r]
            out[blend] = np.where(after, self.programmed_row[r + 1], self.programmed_row[r - 1])
        return out
