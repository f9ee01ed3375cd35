"""Contact recycling: kept points agree with the narrowphase, and are given up when they should be."""

from __future__ import annotations

import numpy as np
import pytest

import phys2d
from phys2d import scenes
from phys2d.collision.recycle import (
    RECYCLE_MASS_RATIO,
    RECYCLE_MAX_TURN,
    angle_difference,
    has_room,
    may_recycle,
    turn_since_cached,
)
from tests.probe import manifolds_of, records_now


def narrowphase_now(w: phys2d.World):
    """The narrowphase's own manifolds of w's current pairs at its current positions (a second method)."""
    V = w.V.copy()
    V[~w._bodies.static, :2] += w.gravity / 60.0  # the step's travel is taken after gravity
    bodies, shapes, _, _ = records_now(w, V, w._pipeline.pairs)
    c = manifolds_of(w, bodies, shapes, w._pipeline.n_pairs)
    return {"a": c.body_a, "b": c.body_b, "point": c.point, "normal": c.normal, "separation": c.separation,
            "feature": c.feature, "key": c.key}  # fmt: skip


def test_recycled_points_agree_with_the_narrowphase_on_a_resting_stack():
    w = scenes.vertical_stack(5, phys2d.SoftStep())
    for _ in range(60):
        w.step(1 / 60)
    x, theta, V = w.x.copy(), w.theta.copy(), w.V.copy()
    fresh = narrowphase_now(w)
    w.step(1 / 60)
    assert w._pipeline.store.recycled == 5  # every pair kept its points
    c = w.contacts
    assert np.array_equal(np.sort(c.key), np.sort(fresh["key"]))  # the same features, so the same cache keys
    order = np.argsort(fresh["key"])
    mine = np.argsort(c.key)
    # separations follow the motion since the points were found: the same as collision detection now to
    # within what the bodies turned (below a milliradian here) times their size
    np.testing.assert_allclose(c.separation[mine], fresh["separation"][order], atol=1e-4)
    np.testing.assert_allclose(c.normal[mine], fresh["normal"][order], atol=1e-3)
    np.testing.assert_allclose(c.point[mine], fresh["point"][order], atol=2e-3)
    assert np.all(np.abs(theta) < 1e-3) and np.all(np.isfinite(x)) and np.all(np.isfinite(V))


def test_recycling_off_finds_every_manifold_anew():
    w = scenes.vertical_stack(5, phys2d.SoftStep())
    w.contact_recycle_distance = 0.0
    for _ in range(30):
        w.step(1 / 60)
    assert w._pipeline.store.recycled == 0
    fresh = narrowphase_now(w)
    w.step(1 / 60)
    # the step's contacts are the narrowphase's own at the same positions, bit for bit
    assert np.array_equal(np.sort(w.contacts.key), np.sort(fresh["key"]))
    assert np.array_equal(
        w.contacts.separation[np.argsort(w.contacts.key)], fresh["separation"][np.argsort(fresh["key"])]
    )


def test_a_pair_that_moved_more_than_the_recycle_distance_is_collided_anew():
    w = phys2d.World(gravity=(0.0, 0.0), responder=phys2d.SoftStep())
    w.add_box(position=(0.0, 0.0), half_extents=(1.0, 0.5), static=True)
    box = w.add_box(position=(0.0, 1.0), half_extents=(0.5, 0.5))
    w.step(1 / 60)
    w.step(1 / 60)
    assert w._pipeline.store.recycled == 1
    # slide it sideways by 6 cm (more than the 5 cm recycle distance), slowly enough not to count as fast
    box.position = (0.06, 1.0)
    w.step(1 / 60)
    assert w._pipeline.store.recycled == 0
    fresh = narrowphase_now(w)
    np.testing.assert_allclose(np.sort(w.contacts.point[:, 0]), np.sort(fresh["point"][:, 0]), atol=1e-9)


@pytest.mark.parametrize("top_density", [1.0, 20.0])
def test_a_fast_pair_keeps_its_manifold_while_it_moves_as_one_if_alike_in_mass(top_density):
    # two boxes resting on each other in zero gravity, both moving at 5 m/s: each moves 8 cm a step,
    # four times the 2 cm margin, but not at all relative to the other. Alike in mass (1:1), the pair
    # is judged by that relative motion and keeps its points (Box2D v3's rule); 20:1, by each body's
    # own motion, and it is collided anew (a light body under a heavy one: ``pair_travel``)
    w = phys2d.World(gravity=(0.0, 0.0), responder=phys2d.SoftStep())
    low = w.add_box(position=(0.0, 0.0), half_extents=(0.5, 0.5))
    top = w.add_box(position=(0.0, 1.0), half_extents=(0.5, 0.5), density=top_density)
    low.velocity = top.velocity = (5.0, 0.0)
    for _ in range(3):
        w.step(1 / 60)
        assert len(w.contacts.key) == 2  # the face to face pair's two points, every step
    assert w._pipeline.store.recycled == (1 if top_density < RECYCLE_MASS_RATIO else 0)
    np.testing.assert_allclose(w.V[:, :2], [[5.0, 0.0], [5.0, 0.0]], atol=1e-9)  # still moving as one


def test_a_fresh_point_has_the_lever_arms_from_each_centre_to_it():
    w = scenes.vertical_stack(3, phys2d.SoftStep(), lean=0.01)
    w.contact_recycle_distance = 0.0
    for _ in range(10):
        w.step(1 / 60)
    x = w.x.copy()  # where the next step's collision detection looks
    w.step(1 / 60)
    c = w.contacts
    np.testing.assert_allclose(c.anchor[:, :2], c.point - x[c.body_a], rtol=0, atol=1e-12)
    np.testing.assert_allclose(c.anchor[:, 2:], c.point - x[c.body_b], rtol=0, atol=1e-12)


def test_a_recycled_point_keeps_the_lever_arms_it_was_found_with():
    # SoftStep's rows keep the Jacobian found: arms turned with the bodies would let a soft contact's
    # tilt feed back into its torques (a leaning stack buckles)
    w = phys2d.World(gravity=(0.0, 0.0), responder=phys2d.SoftStep())
    w.add_box(position=(0.0, 0.0), half_extents=(1.0, 0.5), static=True)
    box = w.add_box(position=(0.0, 1.0), half_extents=(0.5, 0.5))
    w.step(1 / 60)
    x = w.x.copy()
    w.step(1 / 60)  # found here, at positions x
    c = w.contacts
    found = np.hstack([c.point - x[c.body_a], c.point - x[c.body_b]])
    box.position = (0.01, 1.0)  # 1 cm across and 0.6 degrees round: within what is recycled
    box.angle = 0.01
    w.step(1 / 60)
    assert w._pipeline.store.recycled == 1
    np.testing.assert_allclose(w.contacts.anchor, found, rtol=0, atol=1e-12)
    # while the separation follows the turn: the corner of the box that went down by 5 mm overlaps
    assert w.contacts.separation.min() < -0.004


def test_points_that_would_lie_beyond_the_margin_are_not_kept():
    # a box lifted by 3 cm: its recycled points would be 3 cm apart, past the 2 cm margin
    w = phys2d.World(gravity=(0.0, 0.0), responder=phys2d.PGS())
    w.add_box(position=(0.0, 0.0), half_extents=(1.0, 0.5), static=True)
    box = w.add_box(position=(0.0, 1.0), half_extents=(0.5, 0.5))
    w.step(1 / 60)
    box.position = (0.0, 1.03)
    w.step(1 / 60)
    assert len(w.contacts) == 0


@pytest.mark.parametrize("responder", [phys2d.PGS(), phys2d.SoftStep()], ids=["pgs", "soft-step"])
def test_recycling_keeps_twins_bit_identical(responder):
    states = []
    for _ in range(2):
        w = scenes.vertical_stack(8, type(responder)(), lean=0.001)
        for _ in range(90):
            w.step(1 / 60)
        states.append((w.x.copy(), w.theta.copy(), w.V.copy(), w.contacts.key.copy()))
    for a, b in zip(*states):
        assert np.array_equal(a, b)


def test_a_failed_step_leaves_the_recycled_manifolds_as_they_were():
    twins = [scenes.vertical_stack(4, phys2d.SoftStep()) for _ in range(2)]
    for w in twins:
        for _ in range(20):
            w.step(1 / 60)
    w = twins[0]
    w.max_speed = 1e-6  # everything is too fast: the step is undone
    with pytest.raises(phys2d.SimulationError):
        w.step(1 / 60)
    w.max_speed = 1e4
    for t in twins:
        for _ in range(10):
            t.step(1 / 60)
    assert np.array_equal(twins[0].x, twins[1].x) and np.array_equal(twins[0].V, twins[1].V)


def test_angle_difference_is_cos_and_sin_of_the_difference():
    rng = np.random.default_rng(11)
    t, t0 = rng.uniform(-20.0, 20.0, 200), rng.uniform(-20.0, 20.0, 200)
    for ti, t0i in zip(t, t0):
        c, s = angle_difference(np.cos(ti), np.sin(ti), np.cos(t0i), np.sin(t0i))
        assert c == pytest.approx(np.cos(ti - t0i), abs=1e-14)
        assert s == pytest.approx(np.sin(ti - t0i), abs=1e-14)


def test_update_geometry_writes_each_body_s_rotation():
    w = scenes.mixed_shapes(8)  # polygons and circles
    b = w._bodies
    w.bodies[3].angle = 0.7
    bodies, shapes, geometry, fits = records_now(w, b.V, w._pipeline.pairs, dt=0.0)
    rotation = geometry[0]
    assert not fits  # no fat boxes yet
    np.testing.assert_allclose(rotation, np.column_stack([np.cos(b.theta), np.sin(b.theta)]), rtol=0, atol=1e-15)


def criterion_by_angles(x, theta, a, b, pose, angles, extent, distance):
    """The module docstring's criterion from the angles themselves (a second method): B's centre in
    A's frame against its cached one, plus extent |sin| of the change of theta_b - theta_a, and
    neither body turned by more than RECYCLE_MAX_TURN (a cosine) since caching."""
    if np.cos(theta[a] - angles[0]) <= RECYCLE_MAX_TURN or np.cos(theta[b] - angles[1]) <= RECYCLE_MAX_TURN:
        return False
    c, s = np.cos(theta[a]), np.sin(theta[a])
    d = x[b] - x[a]
    p = np.array([c * d[0] + s * d[1], -s * d[0] + c * d[1]])
    rel_turn = (theta[b] - theta[a]) - (angles[1] - angles[0])
    return np.hypot(*(p - pose)) + max(extent[a], extent[b]) * abs(np.sin(rel_turn)) < distance


def test_may_recycle_is_the_docstring_s_criterion():
    rng = np.random.default_rng(7)
    extent = np.array([0.7, 1.3])
    distance = 0.05
    agreed = {True: 0, False: 0}
    for _ in range(2000):
        theta0 = rng.uniform(-4.0, 4.0, 2)  # when cached
        x0 = rng.uniform(-3.0, 3.0, (2, 2))
        c, s = np.cos(theta0[0]), np.sin(theta0[0])
        d = x0[1] - x0[0]
        pose = np.array([[c * d[0] + s * d[1], -s * d[0] + c * d[1]]])
        cached_rotation = np.array([[np.cos(theta0[0]), np.sin(theta0[0]), np.cos(theta0[1]), np.sin(theta0[1])]])
        theta = theta0 + rng.normal(0.0, 0.03, 2)  # now: moved by about the recycle distance
        x = x0 + rng.normal(0.0, 0.02, (2, 2))
        rotation = np.column_stack([np.cos(theta), np.sin(theta)])
        turn = turn_since_cached(0, 0, 1, rotation, cached_rotation)
        expected = criterion_by_angles(x, theta, 0, 1, pose[0], theta0, extent, distance)
        assert may_recycle(0, 0, 1, x, rotation, extent, pose, turn, distance) == expected
        agreed[bool(expected)] += 1
    assert min(agreed.values()) > 200  # both answers were put to the test


def test_a_new_store_of_the_live_manifolds_changes_nothing():
    # one twin's manifold store is rebuilt (``compact``) before every step: the same states, bit for bit
    twins = [scenes.pyramid(6, phys2d.SoftStep()) for _ in range(2)]
    for i in range(80):
        for t, w in enumerate(twins):
            if t == 1 and i > 0:
                p = w._pipeline
                before = p.store.live(*p.manifold_keys())
                p.rebuild_store(p.manifolds + 1)  # a new store, with hardly any room: the next step makes its own
                assert p.store.rows_used == p.manifolds and np.array_equal(p.manifold_keys()[1], np.arange(p.manifolds))
                for a, b in zip(before, p.store.live(*p.manifold_keys())):
                    assert np.array_equal(a, b)
            w.step(1 / 60)
    for a, b in zip(*(tw._pipeline.store.live(*tw._pipeline.manifold_keys()) for tw in twins)):
        assert np.array_equal(a, b)
    assert np.array_equal(twins[0].x, twins[1].x) and np.array_equal(twins[0].V, twins[1].V)
    assert twins[0]._pipeline.store.recycled > 0


def test_the_store_stays_bounded_while_pairs_are_collided_anew():
    # recycling off: every step appends every manifold; the store is rebuilt from the live ones when full
    w = scenes.pyramid(5, phys2d.PGS())
    w.contact_recycle_distance = 0.0
    sizes = set()
    for _ in range(200):
        w.step(1 / 60)
        m = w._pipeline.store
        assert m.rows_used <= len(m.found_pose) and m.points_used <= len(m.anchor)
        sizes.add(len(m.found_pose))
    assert max(sizes) <= max(64, 4 * w._pipeline.n_pairs)


def test_room_is_a_row_and_two_points_per_new_manifold():
    # the one test both the kernel (NEED_ROOM) and Pipeline._make_room ask: exactly enough is enough
    assert has_room(10, 8, 20, 16, 2)  # 2 rows and 4 points free: room for 2 new manifolds
    assert not has_room(10, 9, 20, 16, 2)  # one row short
    assert not has_room(10, 8, 20, 17, 2)  # one point short
    assert has_room(10, 10, 20, 20, 0)  # a full store has room for nothing new
