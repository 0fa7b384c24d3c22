"""Closed-form arc extrema (ncsim.plan.arc_extrema) against an independent dense sampling.

Random arcs in G17, G18, G19 and tilted planes, both directions, helices (principal and tilted
axes), sweeps from a fraction of a degree to several turns, on a machine whose axes all differ.
The oracle samples every 0.01 deg the derivatives of the helix of ``ncsim.geometry`` and
evaluates the paper's equations with ``ncsim.plan.kinematics``, then refines by bisection
(first angle carrying J_tcurv) or golden-section search (largest J_t) -- it shares no code with
the closed forms. Minima over the arc must not exceed the sampled minima and may undercut them
only by the sampling's quadratic error.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from ncsim import geometry, jit
from ncsim.path import ARC, PathBuilder
from ncsim.plan import kinematics as kin
from ncsim.plan.arc_extrema import arc_capacities, arc_tangential_accel
from ncsim.plan.limits import path_limits

STEP_RAD = math.radians(0.01)
V_MAX = np.array([300.0, 500.0, 400.0])
A_MAX = np.array([2500.0, 3000.0, 1200.0])
J_MAX = np.array([5000.0, 7000.0, 4500.0])
J_TCURV = 6000.0


@pytest.fixture(scope="module")
def machine(mikron):
    return mikron.with_axes(max_velocity_mm_s=V_MAX, max_accel_mm_s2=A_MAX, max_jerk_mm_s3=J_MAX)


def _unit(v):
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


def random_arcs(rng, n=100):
    """A path of unrelated arcs: principal planes (both senses), tilted planes, helices."""
    b = PathBuilder()
    axes = np.eye(3)
    for k in range(n):
        kind = k % 5
        if kind < 3:                                   # G17 / G18 / G19, G2 or G3
            w = axes[2 - kind] * rng.choice([-1.0, 1.0])
        else:                                          # tilted plane
            w = _unit(rng.normal(size=3))
        u = _unit(np.cross(w, rng.normal(size=3)))
        v = np.cross(w, u)
        r = rng.uniform(0.5, 80.0)
        sweep = [rng.uniform(1e-3, 0.1), rng.uniform(0.1, 3.0), rng.uniform(3.0, 2 * math.pi),
                 rng.uniform(2 * math.pi, 4 * math.pi)][k % 4]
        helix = 0.0 if rng.random() < 0.5 else rng.uniform(-30.0, 30.0)
        c = rng.uniform(-50, 50, 3)
        start = c + r * u
        end = c + r * (math.cos(sweep) * u + math.sin(sweep) * v) + helix * w
        b.add_arc(start, end, c, w, r, sweep, helix, line=k + 1, feed_mm_s=rng.uniform(10, 800),
                  cp_mode=64)
    return b.build()


# ---- the oracle ---------------------------------------------------------------------------------

class Dense:
    """Tangent and principal normal of arc ``i`` at angles ``phi`` from its start (the helix
    of ``ncsim.geometry``: P = c + r (cos phi u + sin phi v) + p phi w, differentiated)."""

    def __init__(self, path, i):
        r, sweep, h = path.radius_mm[i], path.sweep_rad[i], path.helix_mm[i]
        self.u, self.v, self.w = (x[0] for x in geometry.arc_basis(
            path.center_mm[i:i + 1], path.normal[i:i + 1], path.start_mm[i:i + 1]))
        self.r, self.p = r, h / sweep
        self.sweep = min(sweep, 2 * math.pi)
        self.phi = np.append(np.arange(0.0, self.sweep, STEP_RAD), self.sweep)

    def frames(self, phi):
        phi = np.atleast_1d(np.asarray(phi, dtype=float))[:, None]
        c, s = np.cos(phi), np.sin(phi)
        t = self.r * (c * self.v - s * self.u) + self.p * self.w
        t /= np.linalg.norm(t, axis=1, keepdims=True)
        return t, -(c * self.u + s * self.v)

    def jerk(self, phi):                                  # eq. 9
        return kin.axis_tangential_jerk_limit_mm_s3(self.frames(phi)[0], J_MAX)

    def velocity(self, phi):                              # eq. 7
        return kin.axis_velocity_feed_limit_mm_s(self.frames(phi)[0], V_MAX)

    def normal_accel(self, phi):                          # eq. 8
        return kin.axis_normal_accel_limit_mm_s2(self.frames(phi)[1], A_MAX)

    def tangential_accel(self, phi, a_normal):           # eq. 1 per axis
        t, n = self.frames(phi)
        return kin.tangential_accel_available_mm_s2(t, n, np.full(len(t), a_normal), A_MAX)

    def first_carrying(self, j_min):
        """First angle with J_t >= j_min: first carrying sample, bisected down to the crossing."""
        ok = self.jerk(self.phi) >= j_min
        if not ok.any():
            return None
        k = int(np.argmax(ok))
        if k == 0:
            return 0.0
        lo, hi = self.phi[k - 1], self.phi[k]
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            lo, hi = (lo, mid) if self.jerk(mid)[0] >= j_min else (mid, hi)
        return hi

    def maxima(self):
        """(angle, value) of every local maximum of J_t, refined by golden-section search."""
        j = self.jerk(self.phi)
        peaks = [k for k in range(len(j)) if (k == 0 or j[k] > j[k - 1])
                 and (k == len(j) - 1 or j[k] >= j[k + 1]) and j[k] >= j.max() * (1 - 1e-3)]
        out = []
        g = (math.sqrt(5) - 1) / 2
        for k in peaks:
            a, b = self.phi[max(k - 1, 0)], self.phi[min(k + 1, len(j) - 1)]
            for _ in range(80):
                x1, x2 = b - g * (b - a), a + g * (b - a)
                if self.jerk(x1)[0] >= self.jerk(x2)[0]:
                    b = x2
                else:
                    a = x1
            best = max((self.phi[k], a, b), key=lambda x: self.jerk(x)[0])
            out.append((best, float(self.jerk(best)[0])))
        return out


def _kernel(path, j_ncu):
    """The kernel's outputs per arc, compiled and as plain Python (``ncsim.jit``): identical."""
    arcs = np.nonzero(path.kind == ARC)[0]
    names = ("r_curv", "phi_c", "alpha_c", "carried", "j_t_c", "v_t_c", "a_n_c", "v_t_min",
             "a_n_min", "j_t_min")
    runs = []
    for which in ("compiled", "python"):
        with jit.forced(which):
            runs.append(arc_capacities(arcs, path.start_mm, path.center_mm, path.normal,
                                       path.radius_mm, path.sweep_rad, path.helix_mm, V_MAX,
                                       A_MAX, J_MAX, j_ncu))
    for a, b in zip(*runs):
        np.testing.assert_array_equal(a, b)
    return arcs, dict(zip(names, runs[0]))


def _assert_least(exact, sampled, what):
    """A closed-form minimum is at most the sampled one and undercuts it by the sampling error
    only (quadratic at a smooth minimum: (0.005 deg)^2 / 2 ~ 4e-9 relative)."""
    assert exact <= sampled * (1 + 1e-12), what
    assert exact >= sampled * (1 - 1e-7), what


# ---- tests --------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def arcs_path():
    return random_arcs(np.random.default_rng(11))


def test_least_capacities_match_dense_sampling(arcs_path):
    """Least V_t, A_n, J_t over the arc (eq. 7-9) and the least tangential acceleration left by
    a normal acceleration (eq. 1)."""
    arcs, k = _kernel(arcs_path, J_TCURV)
    rng = np.random.default_rng(5)
    a_normal = k["a_n_min"] * rng.uniform(0.0, 0.9, len(arcs))
    runs = []
    for which in ("compiled", "python"):
        with jit.forced(which):
            runs.append(arc_tangential_accel(arcs, arcs_path.start_mm, arcs_path.center_mm,
                                             arcs_path.normal, arcs_path.radius_mm,
                                             arcs_path.sweep_rad, arcs_path.helix_mm, A_MAX,
                                             a_normal))
    np.testing.assert_array_equal(*runs)
    accel = runs[0]
    for j, i in enumerate(arcs):
        d = Dense(arcs_path, i)
        _assert_least(k["v_t_min"][j], d.velocity(d.phi).min(), f"V_t arc {i}")
        _assert_least(k["a_n_min"][j], d.normal_accel(d.phi).min(), f"A_n arc {i}")
        _assert_least(k["j_t_min"][j], d.jerk(d.phi).min(), f"J_t arc {i}")
        _assert_least(accel[j], d.tangential_accel(d.phi, a_normal[j]).min(), f"a_t arc {i}")
        r, sweep, h = arcs_path.radius_mm[i], arcs_path.sweep_rad[i], arcs_path.helix_mm[i]
        assert k["r_curv"][j] == pytest.approx((r * r + (h / sweep) ** 2) / r, rel=1e-12)


def test_alpha_c_is_the_first_angle_carrying_j_tcurv(arcs_path):
    arcs, k = _kernel(arcs_path, J_TCURV)
    n_carried = 0
    for j, i in enumerate(arcs):
        d = Dense(arcs_path, i)
        ref = d.first_carrying(J_TCURV)
        if ref is None:     # no sample carries: the closed form may find only a sliver between
            if k["carried"][j]:
                assert d.jerk(k["phi_c"][j])[0] >= J_TCURV * (1 - 1e-9)
            continue
        n_carried += 1
        assert k["carried"][j], f"arc {i}"
        phi = k["phi_c"][j]
        assert phi <= ref + 1e-9, f"arc {i}: {phi} after the first carrying angle {ref}"
        assert d.jerk(phi)[0] >= J_TCURV * (1 - 1e-9), f"arc {i}"
        # the set point's values at alpha_c: eq. 9 raised to J_tcurv, eq. 7, eq. 8
        assert k["j_t_c"][j] == pytest.approx(max(d.jerk(phi)[0], J_TCURV), rel=1e-12)
        assert k["v_t_c"][j] == pytest.approx(d.velocity(phi)[0], rel=1e-9)
        assert k["a_n_c"][j] == pytest.approx(d.normal_accel(phi)[0], rel=1e-9)
    assert 0 < n_carried < len(arcs)


@pytest.mark.parametrize("j_ncu", [J_TCURV, math.inf])
def test_otherwise_alpha_c_is_the_first_largest_j_t(arcs_path, j_ncu):
    """Without J_tcurv (option off, or no point of the arc carries it): the first angle where
    J_t is largest, within 1e-9 of the refined sampled maxima (ties included)."""
    arcs, k = _kernel(arcs_path, j_ncu)
    checked = 0
    for j, i in enumerate(arcs):
        if k["carried"][j]:
            continue
        checked += 1
        d = Dense(arcs_path, i)
        samples = d.jerk(d.phi)
        peaks = d.maxima()
        best = max(max(v for _, v in peaks), samples.max())
        level = best * (1 - 1e-9)
        phi = k["phi_c"][j]
        assert d.jerk(phi)[0] >= level, f"arc {i}"
        # first: no sample and no refined peak before it reaches the largest J_t
        assert not np.any(samples[d.phi < phi - 1e-8] >= level), f"arc {i}"
        assert all(p >= phi - 1e-8 for p, v in peaks if v >= level), f"arc {i}"
        assert k["j_t_c"][j] == pytest.approx(d.jerk(phi)[0], rel=1e-12)
    assert checked >= 10


def test_set_points_compose_the_sampled_values(arcs_path, machine):
    """path_limits on the random arcs: the eq. 12 candidates are the oracle's values at the
    oracle's own alpha_c (or at the kernel's, for ties of the largest J_t)."""
    lim = path_limits(arcs_path, machine)
    arcs, k = _kernel(arcs_path, J_TCURV)
    share = machine.ncu.normal_accel_share
    for j, i in enumerate(arcs):
        d = Dense(arcs_path, i)
        r = k["r_curv"][j]
        phi = d.first_carrying(J_TCURV)
        j_t = (max(J_TCURV, d.jerk(phi)[0]) if phi is not None
               else d.jerk(k["phi_c"][j])[0])
        phi = k["phi_c"][j] if phi is None else phi
        v_t_guard = d.velocity(d.phi).min()
        a_n_guard = d.normal_accel(d.phi).min()
        assert lim.candidates["axis_jerk"][i] == pytest.approx((j_t * r * r) ** (1 / 3), rel=1e-9)
        assert lim.candidates["axis_velocity"][i] == pytest.approx(
            min(d.velocity(phi)[0], v_t_guard), rel=1e-7)
        assert lim.candidates["axis_accel"][i] == pytest.approx(
            min(math.sqrt(r * d.normal_accel(phi)[0]), math.sqrt(r * share * a_n_guard)), rel=1e-7)
        a_n = lim.cap_mm_s[i] ** 2 / r
        assert lim.accel_mm_s2[i] <= d.tangential_accel(d.phi, a_n).min() * (1 + 1e-12)
        assert lim.accel_mm_s2[i] > 0.0


def test_paper_angles(mikron):
    """The paper's angles on its machine, in closed form: a full XY circle leaving along +X
    carries J_tcurv = 6 m/s^3 first at acos(5/6) = 33.56 deg (§5.2.4); without J_tcurv the
    largest J_t is 5 sqrt(2) = 7.07 m/s^3 at 45 deg (§5.2.1); least J_t 5 m/s^3 (§5.2.2)."""
    b = PathBuilder()
    b.add_arc([0, -2.5, 0], [0, -2.5, 0], [0, 0, 0], [0, 0, 1.0], 2.5, 2 * math.pi,
              line=1, feed_mm_s=100.0, cp_mode=64)
    path = b.build()
    v, a, jm = (mikron.max_velocity_mm_s, mikron.max_accel_mm_s2, mikron.max_jerk_mm_s3)
    arcs = np.array([0])
    cols = (arcs, path.start_mm, path.center_mm, path.normal, path.radius_mm, path.sweep_rad,
            path.helix_mm)
    out = arc_capacities(*cols, v, a, jm, 6000.0)
    assert math.degrees(out[1][0]) == pytest.approx(math.degrees(math.acos(5 / 6)), abs=1e-9)
    assert out[9][0] == pytest.approx(5000.0, rel=1e-12)
    out = arc_capacities(*cols, v, a, jm, math.inf)
    assert math.degrees(out[1][0]) == pytest.approx(45.0, abs=1e-9)
    assert out[4][0] == pytest.approx(5000.0 * math.sqrt(2), rel=1e-12)
    # eq. 8: A_n is largest where tan(alpha_c) = A_mx / A_my (39.8 deg); the least tangential
    # acceleration at a_n: min over alpha of (A_mx - a_n |sin a|)/|cos a| = sqrt(A_mx^2 - a_n^2)
    acc = arc_tangential_accel(*cols, a, np.array([1000.0]))
    assert acc[0] == pytest.approx(math.sqrt(2500.0 ** 2 - 1000.0 ** 2), rel=1e-12)
