"""Determinism, add-order permutations, translation invariance and removal.

What the order of add_* calls changes (and so what the permutation properties allow):

- a body's index (row of w.x, w.V, ...) and so contact order: pairs come out sorted by
  (body_a, body_b) with body_a < body_b, which sets the order in which PGS visits the
  rows. Gauss-Seidel is order dependent, so an unconverged solve gives slightly
  different impulses; a converged one gives the same velocities up to round-off.
- which body of a pair is ``a``: the normal points from a to b, and for two polygons
  the reference face is a's unless b's separates clearly more, so the feature ids (and,
  when the faces are nearly parallel, the manifold points) can differ.
- body uids, and so contact keys.
- two circles with the very same centre get the normal +y from a to b (any normal
  would do), so which one goes up depends on the order.

Bodies that never touch are untouched by any of this: their states are bit-identical.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from hypothesis import assume, given
from hypothesis import strategies as st

import phys2d
from phys2d.testing import properties
from tests.strategies import (
    BodySpec,
    SceneSpec,
    body_specs,
    build,
    dts,
    reals,
    responders,
    run,
    scenes,
    vectors,
)


def min_centre_gap(scene: SceneSpec) -> float:
    """The smallest distance between two bodies' centres (m)."""
    centres = np.array([b.position for b in scene.bodies])
    gaps = np.hypot(*(centres[:, None, :] - centres[None, :, :]).transpose(2, 0, 1))
    return float(gaps[np.triu_indices(len(centres), 1)].min(initial=np.inf))


@given(
    scene=scenes(min_bodies=2, max_bodies=6, ground=True, static=None),
    responder=responders(),
    dt=dts,
    steps=st.integers(5, 40),
)
def test_same_scene_twice_is_bit_identical(
    scene: SceneSpec, responder: phys2d.Responder, dt: float, steps: int
) -> None:
    """Two worlds built from the same scene and stepped alike hold bit-identical arrays,
    contacts, caches and reports after every step."""
    properties.same_scene_twice(scene, responder, dt, steps)


@st.composite
def spread_out(draw) -> SceneSpec:
    """Bodies 10 m apart on a line that never meet within the test's steps."""
    bodies = draw(st.lists(body_specs(max_speed=2.0, static=None), min_size=2, max_size=6))
    return SceneSpec(tuple(replace(b, position=(10.0 * k, b.position[1])) for k, b in enumerate(bodies)))


@given(data=st.data(), scene=spread_out(), dt=dts)
def test_add_order_does_not_change_bodies_that_never_touch(data, scene: SceneSpec, dt: float) -> None:
    """Bodies that never touch: adding them in any order gives bit-identical states
    (each body's row is the same, only the row index changes)."""
    order = data.draw(st.permutations(range(len(scene.bodies))))
    a, b = build(scene), build(scene, order=order)
    for _ in range(30):
        a.step(dt)
        b.step(dt)
    assert len(a.contacts) == len(b.contacts) == 0
    assert np.array_equal(a.x[order], b.x)
    assert np.array_equal(a.theta[order], b.theta)
    assert np.array_equal(a.V[order], b.V)


@given(
    data=st.data(),
    scene=scenes(
        min_bodies=2,
        max_bodies=5,
        ground=None,
        gravity=None,
        kinds=("circle",),
        region=1.0,
        density=(0.5, 2.0),
        size=(0.3, 0.7),
        static=None,
    ),
    dt=dts,
)
def test_add_order_gives_the_same_converged_step(data, scene: SceneSpec, dt: float) -> None:
    """Circles (whose contacts do not depend on which body is a): one step with converged
    frictionless PGS gives the same velocities whatever the add order, to round-off.

    No push (beta = 0): a body squeezed between two others cannot be pushed out of both,
    and the split push's sweeps then end wherever the order leaves them."""
    scene = replace(scene, bodies=tuple(replace(b, friction=0.0) for b in scene.bodies))
    assume(min_centre_gap(scene) > 1e-3)  # no concentric pair
    order = data.draw(st.permutations(range(len(scene.bodies))))
    pgs = phys2d.PGS(iterations=5000, tolerance=1e-13, warm_start=False, beta=0.0)
    a, b = build(scene, pgs), build(scene, pgs, order=order)
    try:
        a.step(dt)
        b.step(dt)
    except phys2d.SimulationError:
        assume(False)
    assume(a.last_step.iterations < pgs.iterations and b.last_step.iterations < pgs.iterations)
    assert len(a.contacts) == len(b.contacts)
    scale = 1.0 + float(np.abs(a.V).max())
    np.testing.assert_allclose(a.V[order], b.V, rtol=0, atol=1e-7 * scale)
    np.testing.assert_allclose(a.x[order], b.x, rtol=0, atol=1e-7 * scale * dt)


@given(scene=scenes(max_bodies=5, ground=True, static=None), shift=vectors(-64.0, 64.0), responder=responders(), dt=dts)
def test_translating_the_scene_translates_the_motion(scene: SceneSpec, shift, responder, dt: float) -> None:
    """Physics does not depend on where the origin is: the same scene moved by a shift
    moves the same way, to round-off, over a few steps (integer shifts keep the
    coordinates' rounding alike). Bodies spawned on the very same centre are a tie that
    round-off breaks (which way two coincident boxes part), so centres are kept apart."""
    assume(min_centre_gap(scene) > 1e-3)
    shift = (float(round(shift[0])), float(round(shift[1])))
    moved = replace(
        scene,
        bodies=tuple(replace(b, position=(b.position[0] + shift[0], b.position[1] + shift[1])) for b in scene.bodies),
    )
    a, b = build(scene, responder), build(moved, responder)
    for _ in range(3):
        try:
            a.step(dt)
            b.step(dt)
        except phys2d.SimulationError:
            return
        scale = 1.0 + float(np.abs(a.V).max())
        np.testing.assert_allclose(b.x - np.asarray(shift), a.x, rtol=0, atol=1e-6 * scale)
        np.testing.assert_allclose(b.V, a.V, rtol=0, atol=1e-6 * scale)


@given(
    data=st.data(), scene=scenes(min_bodies=2, max_bodies=6, ground=None, static=None), dt=dts, steps=st.integers(0, 10)
)
def test_remove_leaves_the_other_bodies_as_they_were(data, scene: SceneSpec, dt: float, steps: int) -> None:
    """Removing a body: every other handle still reads its own state, rows after it
    shift down by one, and the removed handle is refused everywhere."""
    w = build(scene)
    for _ in run(w, dt, steps):
        pass
    handles = w.bodies
    gone = handles[data.draw(st.integers(0, len(handles) - 1))]
    kept = [h for h in handles if h is not gone]
    before = [(h.position, h.angle, h.velocity, h.angular_velocity, h.mass, h.inertia, h.local_vertices) for h in kept]
    w.remove(gone)
    assert not gone.alive
    assert list(w.bodies) == kept
    for k, (h, old) in enumerate(zip(kept, before)):
        assert h.index == k
        assert np.array_equal(w.x[k], old[0]) and w.theta[k] == old[1]
        now = (h.position, h.angle, h.velocity, h.angular_velocity, h.mass, h.inertia, h.local_vertices)
        for x, y in zip(now, old):
            assert np.array_equal(x, y)
    for _ in run(w, dt, 2):
        pass


@given(x=reals(-3.0, 3.0), spec=body_specs())
def test_mirror_symmetric_scene_stays_symmetric(x: float, spec: BodySpec) -> None:
    """Two circles mirrored about x = 0 falling on the ground stay mirror images
    (to round-off): nothing in the step prefers left or right."""
    r = 0.3 + abs(x) * 0.05
    w = phys2d.World(responder=phys2d.PGS(iterations=100, tolerance=1e-12))
    w.add_box(position=(0.0, -0.5), half_extents=(20.0, 0.5), static=True)
    left = w.add_circle(
        position=(-abs(x) - 0.5, 1.0), radius=r, velocity=(1.0, 0.0), angular_velocity=spec.angular_velocity
    )
    right = w.add_circle(
        position=(abs(x) + 0.5, 1.0), radius=r, velocity=(-1.0, 0.0), angular_velocity=-spec.angular_velocity
    )
    for _ in range(90):
        w.step(1 / 60)
    assert np.allclose(left.position * [-1, 1], right.position, rtol=0, atol=1e-8)
    assert np.allclose(left.velocity * [-1, 1], right.velocity, rtol=0, atol=1e-8)
    assert abs(left.angular_velocity + right.angular_velocity) < 1e-8
