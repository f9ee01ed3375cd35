"""Collision: manifolds checked against geometry worked out by hand, and feature ids."""

from __future__ import annotations

import math

import numpy as np
import pytest

import phys2d
from tests.probe import contacts_now, manifolds_of, records_now


def collide(w: phys2d.World) -> phys2d.Contacts:
    """This step's contacts, without moving anything (zero gravity, zero velocities, dt tiny)."""
    return contacts_now(w)


def zero_g(margin: float = 0.0) -> phys2d.World:
    return phys2d.World(gravity=(0.0, 0.0), contact_margin=margin)


def test_circle_circle_normal_separation_and_point():
    w = zero_g()
    w.add_circle(position=(0.0, 0.0), radius=1.0)
    w.add_circle(position=(1.5, 0.0), radius=1.0)
    c = collide(w)
    assert len(c) == 1
    assert np.allclose(c.normal[0], (1.0, 0.0))
    assert c.separation[0] == pytest.approx(-0.5)
    assert np.allclose(c.point[0], (0.75, 0.0))  # midway between the two surfaces


def test_separated_circles_make_no_contact_but_speculative_ones_do_within_the_margin():
    w = zero_g(margin=0.02)
    w.add_circle(position=(0.0, 0.0), radius=1.0)
    w.add_circle(position=(2.01, 0.0), radius=1.0)
    w.add_circle(position=(10.0, 0.0), radius=1.0)
    w.add_circle(position=(12.5, 0.0), radius=1.0)
    c = collide(w)
    assert len(c) == 1 and c.separation[0] == pytest.approx(0.01)


def test_box_resting_on_ground_gives_two_points_at_its_corners():
    w = zero_g()
    w.add_box(position=(0.0, -0.5), half_extents=(5.0, 0.5), static=True)
    w.add_box(position=(1.0, 0.49), half_extents=(0.5, 0.5))
    c = collide(w)
    assert len(c) == 2
    assert np.allclose(c.normal, [(0.0, 1.0), (0.0, 1.0)])  # from the ground (a) to the box (b)
    assert np.allclose(c.separation, -0.01)
    assert np.allclose(sorted(c.point[:, 0]), [0.5, 1.5])
    assert np.allclose(c.point[:, 1], -0.005)


def test_box_on_box_clips_to_the_overlap():
    w = zero_g()
    w.add_box(position=(0.0, 0.0), half_extents=(0.5, 0.5))
    w.add_box(position=(0.7, 0.98), half_extents=(0.5, 0.5))
    c = collide(w)
    assert len(c) == 2
    assert np.allclose(sorted(c.point[:, 0]), [0.2, 0.5])
    assert np.allclose(c.separation, -0.02)


def test_circle_on_box_edge_and_corner():
    w = zero_g()
    w.add_box(position=(0.0, 0.0), half_extents=(1.0, 1.0))
    w.add_circle(position=(0.3, 1.4), radius=0.5)  # above the top edge
    c = collide(w)
    assert len(c) == 1
    assert np.allclose(c.normal[0], (0.0, 1.0))
    assert c.separation[0] == pytest.approx(-0.1)
    w = zero_g()
    w.add_circle(position=(1.3, 1.3), radius=0.5)  # off the corner (1, 1), circle is body a
    w.add_box(position=(0.0, 0.0), half_extents=(1.0, 1.0))
    c = collide(w)
    d = math.hypot(0.3, 0.3)
    assert len(c) == 1
    assert c.separation[0] == pytest.approx(d - 0.5)
    assert np.allclose(c.normal[0], -np.array([0.3, 0.3]) / d)  # from the circle (a) to the box (b)


def test_rotated_polygons_separation_matches_the_distance_along_the_normal():
    # a diamond (box rotated 45 degrees) pressing into a box from above: depth known
    w = zero_g()
    w.add_box(position=(0.0, 0.0), half_extents=(1.0, 1.0), static=True)
    h = math.sqrt(0.5)  # the diamond's lowest vertex lies h below its centre
    w.add_box(position=(0.0, 1.0 + h - 0.05), half_extents=(0.5, 0.5), angle=math.pi / 4)
    c = collide(w)
    assert len(c) == 1
    assert c.separation[0] == pytest.approx(-0.05)
    assert np.allclose(c.normal[0], (0.0, 1.0))


def test_static_bodies_never_collide_with_each_other():
    w = zero_g()
    w.add_box(position=(0.0, 0.0), static=True)
    w.add_box(position=(0.5, 0.0), static=True)
    assert len(collide(w)) == 0


def test_feature_ids_stay_the_same_while_a_box_slides_across_the_ground():
    w = phys2d.World()
    w.add_box(position=(0.0, -0.5), half_extents=(50.0, 0.5), static=True)
    b = w.add_box(position=(0.0, 0.5), velocity=(8.0, 0.0))
    keys = []
    for _ in range(60):
        w.step(1 / 60)
        keys.append(tuple(w.contacts.key))
    assert b.velocity[0] > 0.0  # still sliding: the points move along the ground
    assert len(set(keys[1:])) == 1
    assert w.last_step.cache_hit_rate == 1.0


def test_reference_face_does_not_flip_for_equal_boxes_stacked_exactly():
    w = phys2d.World()
    w.add_box(position=(0.0, -0.5), half_extents=(50.0, 0.5), static=True)
    for k in range(3):
        w.add_box(position=(0.0, 0.5 + k))
    seen = set()
    for _ in range(120):
        w.step(1 / 60)
        seen.update(int(f) for f in w.contacts.feature)
    assert len(seen) == 2  # one reference edge, one incident edge, two ends


def test_broadphase_finds_the_same_pairs_as_all_pairs():
    rng = np.random.default_rng(3)
    w = zero_g(margin=0.0)
    for _ in range(60):
        if rng.random() < 0.5:
            w.add_circle(position=rng.uniform(-4, 4, 2), radius=rng.uniform(0.2, 0.7))
        else:
            w.add_box(position=rng.uniform(-4, 4, 2), half_extents=rng.uniform(0.2, 0.7, 2), angle=rng.uniform(0, 3))
    c = collide(w)
    found = set(zip(c.body_a.tolist(), c.body_b.tolist()))
    # second method: every pair through the narrowphase, no broadphase
    n = len(w.bodies)
    pairs = np.array([(i, j) for i in range(n) for j in range(i + 1, n)], np.int32)
    bodies, shapes, _, _ = records_now(w, w.V, pairs, dt=0.0)
    everything = manifolds_of(w, bodies, shapes, len(pairs))
    expected = set(zip(everything.body_a.tolist(), everything.body_b.tolist()))
    assert len(expected) > 10
    assert found == expected
