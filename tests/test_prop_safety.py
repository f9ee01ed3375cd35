"""Properties: nothing becomes NaN or infinite, the velocity limit undoes a step, free flight."""

from __future__ import annotations

import re
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, note
from hypothesis import strategies as st

import phys2d
from tests.strategies import (
    SceneSpec,
    all_finite,
    body_specs,
    build,
    dts,
    fingerprint,
    reals,
    responders,
    scenes,
    state,
    step_or_undone,
    vectors,
    violent_scenes,
)


@given(scene=violent_scenes(), responder=responders(), dt=dts)
def test_violent_scenes_stay_finite(scene: SceneSpec, responder: phys2d.Responder, dt: float) -> None:
    """Every step either leaves all state, contacts and residuals finite, or raises
    SimulationError and leaves the world bit-identical to before that step."""
    w = build(scene, responder)
    for _ in range(40):
        if not step_or_undone(w, dt):
            break
        assert all_finite(w)
        assert np.all(np.abs(w.V) <= scene.max_speed)
        assert np.isfinite(w.kinetic_energy())


@given(
    scene=scenes(max_bodies=4, ground=None, static=None, gravity=None), dt=st.sampled_from([1e3, 1e150, 1e300, 1.7e308])
)
def test_huge_dt_never_leaves_non_finite_state(scene: SceneSpec, dt: float) -> None:
    """A finite (if absurd) dt is valid input: a step must end finite or raise and undo."""
    w = build(scene)
    if step_or_undone(w, dt):
        assert all_finite(w)


@given(scene=scenes(max_bodies=5, ground=True), limit=reals(0.5, 3.0), dt=dts)
def test_velocity_limit_raises_and_restores(scene: SceneSpec, limit: float, dt: float) -> None:
    """With a low max_speed, the step that takes a body past it raises SimulationError
    naming exactly the bodies a twin world without the limit finds too fast, and the
    world (state, contacts, cache, clock) is exactly as before that step."""
    worlds = []
    for max_speed in (limit, 1e4):
        w = build(replace(scene, max_speed=max_speed))
        w.add_circle(position=(50.0, 50.0), radius=0.2, velocity=(0.0, -0.99 * limit))
        worlds.append(w)
    w, twin = worlds
    for _ in range(1000):
        before = fingerprint(w)
        twin.step(dt)
        try:
            w.step(dt)
        except phys2d.SimulationError as err:
            assert fingerprint(w) == before
            V = twin.V
            too_fast = np.flatnonzero((np.hypot(V[:, 0], V[:, 1]) > limit) | (np.abs(V[:, 2]) > limit))
            listed = re.search(r"bodies \[([0-9, .]+)\]", str(err))
            assert listed is not None
            names = [int(s) for s in listed.group(1).replace("...", "").split(",") if s.strip()]
            assert names == too_fast[:10].tolist()
            return
        assert np.array_equal(w.V, twin.V)
    pytest.fail("a body falling freely never passed max_speed")  # pragma: no cover


@given(
    body=body_specs(kinds=("box", "circle", "polygon")), gravity=vectors(-20.0, 20.0), dt=dts, steps=st.integers(1, 60)
)
def test_free_flight_is_semi_implicit_euler(body, gravity, dt: float, steps: int) -> None:
    """Without contacts, n steps of semi-implicit Euler have a closed form:
    v_n = v_0 + n dt g, x_n = x_0 + n dt v_0 + dt^2 g n (n + 1) / 2, theta_n = theta_0 + n dt omega."""
    w = phys2d.World(gravity=gravity)
    b = body.add_to(w)
    x0, v0, th0, om0 = b.position, b.velocity, b.angle, b.angular_velocity
    for _ in range(steps):
        w.step(dt)
    g = np.asarray(gravity)
    n = steps
    np.testing.assert_allclose(b.velocity, v0 + n * dt * g, rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(b.position, x0 + n * dt * v0 + dt * dt * g * n * (n + 1) / 2, rtol=1e-12, atol=1e-9)
    assert b.angle == pytest.approx(th0 + n * dt * om0, rel=1e-12, abs=1e-9)
    assert b.angular_velocity == om0


@given(scene=scenes(max_bodies=5, ground=True, static=None), responder=responders(), dt=dts)
def test_static_bodies_never_move(scene: SceneSpec, responder: phys2d.Responder, dt: float) -> None:
    """M^-1 = 0 for static bodies: neither gravity nor any impulse moves them."""
    w = build(scene, responder)
    static = np.array([b.static for b in scene.bodies])
    x0, th0, v0 = state(w)
    for _ in range(30):
        try:
            w.step(dt)
        except phys2d.SimulationError:
            break
    note(f"{int(static.sum())} static bodies")
    assert np.array_equal(w.x[static], x0[static])
    assert np.array_equal(w.theta[static], th0[static])
    assert np.array_equal(w.V[static], v0[static])
    assert np.all(w.M_inv[static] == 0.0)
