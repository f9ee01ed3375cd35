"""Conservation properties: momentum, energy, and the analytic sliding block."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

import phys2d
from phys2d.testing import properties
from phys2d.testing.properties import momentum_scale
from tests.strategies import (
    SceneSpec,
    body_specs,
    build,
    dts,
    free_scene,
    pgs_settings,
    reals,
    responders,
    run,
    scenes,
    vectors,
)

# Scenes of free bodies (no static ones, no gravity) that collide often.
crowds = scenes(
    min_bodies=2,
    max_bodies=6,
    ground=False,
    gravity=False,
    region=1.2,
    max_speed=4.0,
    max_spin=4.0,
    density=(0.2, 5.0),
    size=(0.2, 0.9),
)


@given(scene=crowds, responder=responders(), dt=dts)
def test_linear_momentum_is_conserved(scene: SceneSpec, responder: phys2d.Responder, dt: float) -> None:
    """No gravity, no static bodies: every contact impulse acts equally and oppositely,
    so sum m v is unchanged by any number of steps (to round-off), under every responder."""
    properties.linear_momentum_kept(scene, responder, dt)


@given(scene=crowds, responder=pgs_settings(), dt=dts, about=vectors(-5.0, 5.0))
def test_angular_momentum_is_conserved(
    scene: SceneSpec, responder: phys2d.PGS, dt: float, about: tuple[float, float]
) -> None:
    """No gravity, no static bodies: impulses act at one point on both bodies, so
    sum I omega + (x - o) x m v about any point o is unchanged by each step.

    PGS only, with the lecture's push (split=False) and no restitution: what moves
    positions with a velocity the bodies do not keep, keeps the centre of mass (and
    linear momentum) but not (x - o) x m v. That is the split push, and the bounce of
    a point that was still apart (it moves to its partner, then bounces); likewise the
    naive takes' push-apart. SoftStep moves the bodies between its sub-steps but keeps
    the tick's lever arms, so its impulses act at points that have drifted apart by the
    bodies' motion within the tick, and angular momentum is kept only to O(dt) (as in
    Box2D v3); a recycled manifold keeps its arms as found for longer still
    (``Responder.found_lever_arms``).
    """
    responder.split = False
    scene = replace(scene, bodies=tuple(replace(b, restitution=0.0) for b in scene.bodies))
    w = build(free_scene(scene), responder)
    for _ in range(30):
        scale = momentum_scale(w) * (1.0 + math.hypot(*about))
        before = w.angular_momentum(about)
        try:
            w.step(dt)
        except phys2d.SimulationError:
            return
        # positions moved with the new velocities; angular momentum about a fixed point
        # is still conserved because each body's x moves along its own v. Round-off is
        # relative to the momenta before or after the step, whichever is larger.
        scale = max(scale, momentum_scale(w) * (1.0 + math.hypot(*about)))
        assert w.angular_momentum(about) == pytest.approx(before, rel=0, abs=1e-11 * scale)


@given(
    scene=scenes(
        min_bodies=2, max_bodies=5, ground=None, gravity=False, region=1.2, max_speed=4.0, max_spin=4.0, static=None
    ),
    dt=dts,
    warm=st.booleans(),
)
def test_energy_does_not_grow_without_restitution_or_push(scene: SceneSpec, dt: float, warm: bool) -> None:
    """e = 0 and beta = 0, no gravity, PGS run to convergence: every contact's target is
    xi <= 0 (at rest, or a speculative gap it may close), so with complementarity
    KE2 - KE1 = lambda . J V2 - 1/2 lambda^T A lambda <= 0 at every step."""
    scene = replace(scene, bodies=tuple(replace(b, restitution=0.0) for b in scene.bodies))
    pgs = phys2d.PGS(iterations=2000, tolerance=1e-12, beta=0.0, warm_start=warm)
    w = build(scene, pgs)
    for _ in range(20):
        ke = w.kinetic_energy()
        try:
            w.step(dt)
        except phys2d.SimulationError:  # pragma: no cover - beta = 0 pushes nothing apart
            pytest.fail("a step without push or bounce raised SimulationError")
        assume(w.last_step.iterations < pgs.iterations)
        assert w.kinetic_energy() <= ke * (1.0 + 1e-9) + 1e-12


@given(
    v0=reals(0.5, 8.0),
    mu=reals(0.1, 1.0),
    hx=reals(0.2, 1.0),
    flat=reals(0.2, 0.7),
    density=reals(0.2, 5.0),
    dt=st.sampled_from([1 / 60, 1 / 120, 1 / 240]),
)
def test_sliding_box_decelerates_at_mu_g(
    v0: float, mu: float, hx: float, flat: float, density: float, dt: float
) -> None:
    """A box sliding on flat ground with Coulomb friction: v(t) = v0 - mu g t until it
    stops after v0 / (mu g), having slid v0^2 / (2 mu g) (mixed mu = sqrt(mu_box mu_ground)).
    The box is flat enough (mu hy < hx) that friction cannot tip it over."""
    g = 10.0
    size = (hx, min(0.5, flat * hx / mu))
    w = phys2d.World(gravity=(0.0, -g))
    w.add_box(position=(0.0, -0.5), half_extents=(100.0, 0.5), static=True, friction=mu)
    box = w.add_box(
        position=(0.0, size[1] - 0.002), half_extents=size, friction=mu, density=density, velocity=(v0, 0.0)
    )
    a = mu * g  # mixed mu = sqrt(mu * mu) = mu
    t_stop = v0 / a
    steps = int(0.5 * t_stop / dt)
    for _ in range(steps):
        w.step(dt)
    # semi-implicit Euler of a constant deceleration a: v_n = v0 - n dt a, and friction
    # stops the box (no reversal): x_n = dt sum_k max(0, v0 - k dt a)
    assert box.velocity[0] == pytest.approx(v0 - steps * dt * a, rel=1e-3, abs=1e-4)
    more = int(0.7 * t_stop / dt) + 10
    for _ in range(more):
        w.step(dt)
    k = np.arange(1, steps + more + 1)
    assert abs(box.velocity[0]) < 1e-4
    assert box.position[0] == pytest.approx(dt * np.sum(np.maximum(0.0, v0 - k * dt * a)), rel=1e-3, abs=1e-4)


@given(scene=scenes(max_bodies=5, ground=None, static=None), steps=st.integers(0, 20), dt=dts, about=vectors(-3.0, 3.0))
def test_energy_and_momentum_reports_match_the_bodies(scene: SceneSpec, steps: int, dt: float, about) -> None:
    """kinetic_energy, potential_energy, linear_momentum and angular_momentum equal the
    sums computed from each dynamic body handle's mass, inertia, position and velocity."""
    w = build(scene)
    for _ in run(w, dt, steps):
        pass
    g = np.array(scene.gravity)
    ke = pe = lz = 0.0
    p = np.zeros(2)
    for b in w.bodies:
        if b.static:
            continue
        v, x = b.velocity, b.position
        ke += 0.5 * b.mass * float(v @ v) + 0.5 * b.inertia * b.angular_velocity**2
        pe -= b.mass * float(x @ g)
        p += b.mass * v
        r = x - np.asarray(about)
        lz += b.inertia * b.angular_velocity + b.mass * (r[0] * v[1] - r[1] * v[0])
    assert w.kinetic_energy() == pytest.approx(ke, rel=1e-12, abs=1e-12)
    assert w.potential_energy() == pytest.approx(pe, rel=1e-12, abs=1e-12)
    np.testing.assert_allclose(w.linear_momentum(), p, rtol=1e-12, atol=1e-12)
    assert w.angular_momentum(about) == pytest.approx(lz, rel=1e-12, abs=1e-12)


@given(body=body_specs(), impulse=vectors(-50.0, 50.0), arm=vectors(-1.0, 1.0))
def test_apply_impulse_changes_momentum_by_the_impulse(body, impulse, arm) -> None:
    """Applying impulse j at point p changes linear momentum by j and angular momentum
    about the origin by p x j (momentum balance for an impulse)."""
    w = phys2d.World()
    b = body.add_to(w)
    p0, l0 = w.linear_momentum(), w.angular_momentum()
    point = b.position + np.asarray(arm)
    b.apply_impulse(impulse, point=point)
    j = np.asarray(impulse)
    np.testing.assert_allclose(w.linear_momentum() - p0, j, atol=1e-9 * (1 + np.abs(j).max()))
    dl = point[0] * j[1] - point[1] * j[0]
    assert w.angular_momentum() - l0 == pytest.approx(dl, abs=1e-9 * (1 + abs(dl) + np.abs(j).max()))
