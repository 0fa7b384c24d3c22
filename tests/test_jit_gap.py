"""The gap kernels (``gap.nearest``, ``gap.align``, ``gap.truth.servo``) are ``ncsim.jit``
kernels like the planner's: plain Python and numba's compiled version give bit-identical
results on random inputs (lines, arcs and helices; noisy samples; closed loops with speed
loop, structure and friction).
"""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from ncsim import jit
from ncsim.gap import align, nearest
from ncsim.gap.truth import servo
from ncsim.nc.interpret import interpret_text

SETTINGS = settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def _both(func, *args):
    out = {}
    for which in ("python", "compiled"):
        with jit.forced(which):
            out[which] = func(*args)
    return out["python"], out["compiled"]


def _random_path(rng):
    """Lines, arcs and helices in random order (an 840D program, interpreted)."""
    lines = ["G17 G90 G64 F3000", "G0 X0 Y0 Z0"]
    x = y = z = 0.0
    for _ in range(int(rng.integers(3, 12))):
        kind = rng.integers(0, 3)
        if kind == 0:
            x, y, z = x + rng.uniform(-20, 20), y + rng.uniform(-20, 20), z + rng.uniform(-2, 2)
            lines.append(f"G1 X{x:.3f} Y{y:.3f} Z{z:.3f}")
        else:
            r = rng.uniform(2, 15)
            dz = rng.uniform(-3, 3) if kind == 2 else 0.0
            z += dz
            turn = "TURN=1 " if kind == 2 and rng.random() < 0.5 else ""
            lines.append(f"G{int(rng.integers(2, 4))} X{x:.3f} Y{y:.3f} Z{z:.3f} I{r:.3f} J0 {turn}")
    lines.append("M30")
    return interpret_text("\n".join(lines) + "\n", "random.mpf").path


def _samples(rng, path, n):
    """n points along the path (on the chords of its arcs) in order, with noise of 0.1 mm."""
    geo = nearest.path_geometry(path)
    s = np.sort(rng.uniform(0.0, geo.total_mm, n))
    k = np.clip(np.searchsorted(geo.s0, s, side="right") - 1, 0, path.n - 1)
    a = (s - geo.s0[k]) / np.where(geo.length[k] > 0, geo.length[k], 1.0)
    pts = geo.start[k] + a[:, None] * (geo.end[k] - geo.start[k])   # on the chords of the arcs
    return pts + rng.normal(0.0, 0.1, pts.shape)


@SETTINGS
@given(st.integers(0, 2**31 - 1), st.integers(2, 400))
def test_nearest_track_is_the_same_plain_and_compiled(seed, n):
    rng = np.random.default_rng(seed)
    path = _random_path(rng)
    geo = nearest.path_geometry(path)
    q = _samples(rng, path, n)
    py, nb = _both(lambda: nearest.track(q, geo, 0.0, first_window_mm=5.0, slack_mm=1.0))
    for name in ("s", "segment", "foot", "tangent", "residual"):
        assert np.array_equal(getattr(py, name), getattr(nb, name)), name


@SETTINGS
@given(st.integers(0, 2**31 - 1), st.integers(2, 400), st.booleans())
def test_align_projection_is_the_same_plain_and_compiled(seed, n, prior):
    rng = np.random.default_rng(seed)
    m = int(rng.integers(20, 300))
    sim_s = np.cumsum(rng.uniform(0.0, 1.0, m) * (rng.random(m) > 0.1))   # with standstills
    sim_t = np.arange(m) * 0.01
    sim_pos = np.column_stack([sim_s, np.sin(sim_s / 5.0), np.zeros(m)])
    pick = np.sort(rng.integers(0, m, n))
    q = sim_pos[pick] + rng.normal(0.0, 0.05, (n, 3))
    t_al = sim_t[pick] + rng.normal(0.0, 0.02, n)
    restart = np.zeros(n, dtype=bool)
    restart[0] = True
    restart |= rng.random(n) < 0.02
    args = (q, sim_pos, sim_s, sim_t, t_al, sim_s[pick], restart, np.full(n, 0.01), 200.0, 0.5,
            5.0, 0.01, 0.1, 1.0 if prior else 0.0)
    (j_py, u_py), (j_nb, u_nb) = _both(lambda: align.project_on_path(*args))
    assert np.array_equal(j_py, j_nb) and np.array_equal(u_py, u_nb)


@pytest.mark.parametrize("case", ["lag", "speed loop, structure, friction"])
def test_servo_integration_is_the_same_plain_and_compiled(case):
    t = np.arange(0.0, 0.4, 1e-3)
    cmd = np.column_stack([20.0 * np.sin(4 * t), 10.0 * (1 - np.cos(4 * t)), 2.0 * t])
    if case == "lag":
        params = servo.ServoParams(kv_1_s=30.0)
    else:
        params = servo.ServoParams(kv_1_s=40.0, ffw_weight=0.9, velocity_loop_time_s=0.004,
                                   structure_freq_hz=50.0, structure_damping=0.05,
                                   friction_mm_s2=50.0)
    py, nb = _both(lambda: servo.simulate_servo(t, cmd, params, dt_s=5e-4))
    for name in ("drive_pos_mm", "drive_vel_mm_s", "deflection_mm"):
        assert np.array_equal(getattr(py, name), getattr(nb, name)), name


def test_the_gap_kernels_are_jit_kernels(monkeypatch):
    """The searches run compiled at any size (a gap run calls them hundreds of times), the servo
    integrator plain on a short command; ``NCSIM_KERNELS=python`` runs all of them plain."""
    monkeypatch.setattr(jit, "_active", False)
    monkeypatch.delenv("NCSIM_KERNELS", raising=False)
    for k in (nearest._track, align._track, servo._integrate):
        assert isinstance(k, jit.Kernel) and k in jit.kernels()
        assert k.pick(10**7) is not k.py
        with jit.forced("python"):
            assert k.pick(10**7) is k.py
    assert nearest._track.pick(1) is not nearest._track.py
    assert align._track.pick(1) is not align._track.py
    assert servo._integrate.pick(100) is servo._integrate.py


def test_after_the_gap_warmup_no_call_compiles_a_new_specialization():
    """``ncsim warmup`` compiles the gap kernels with the argument types real calls use."""
    from ncsim.gap.pipeline import warmup_kernels
    warmup_kernels()
    kernels = (nearest._track, align._track)     # the kernels they call are compiled into them
    before = [len(k.compiled.signatures) for k in kernels]
    assert all(before)
    test_nearest_track_is_the_same_plain_and_compiled.hypothesis.inner_test(seed=3, n=50)
    test_align_projection_is_the_same_plain_and_compiled.hypothesis.inner_test(seed=4, n=50, prior=True)
    test_align_projection_is_the_same_plain_and_compiled.hypothesis.inner_test(seed=5, n=50, prior=False)
    assert [len(k.compiled.signatures) for k in kernels] == before
