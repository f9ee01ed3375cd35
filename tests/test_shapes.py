"""Shapes: validation and mass properties against closed-form results."""

from __future__ import annotations

import math

import numpy as np
import pytest

import phys2d


def test_box_mass_and_inertia_match_the_closed_form():
    w = phys2d.World()
    b = w.add_box(half_extents=(1.0, 0.25), density=3.0)
    width, height = 2.0, 0.5
    m = 3.0 * width * height
    assert b.mass == pytest.approx(m, rel=1e-12)
    assert b.inertia == pytest.approx(m * (width**2 + height**2) / 12.0, rel=1e-12)
    assert np.allclose(w.M_inv[0], [1 / m, 1 / m, 12.0 / (m * (width**2 + height**2))])


def test_equal_boxes_share_one_read_only_shape_and_keep_their_own_bodies():
    """A box's shape is checked and measured once per size; the world copies it, so one body's
    geometry never reaches another's, and the shared arrays cannot be written."""
    spec = phys2d.shapes.box((0.4, 0.3))
    assert phys2d.shapes.box([0.4, 0.3]) is spec
    assert phys2d.shapes.box((0.3, 0.4)) is not spec
    with pytest.raises(ValueError):
        spec.vertices[0, 0] = 1.0
    w = phys2d.World()
    a = w.add_box((0.0, 0.0), half_extents=(0.4, 0.3), density=2.0)
    b = w.add_box((5.0, 0.0), half_extents=(0.4, 0.3), density=1.0)
    assert a.mass == pytest.approx(2.0 * 0.8 * 0.6, rel=1e-12)
    assert b.mass == pytest.approx(1.0 * 0.8 * 0.6, rel=1e-12)
    assert np.allclose(np.abs(spec.vertices), [0.4, 0.3])  # centred: the shared spec is untouched


def test_circle_mass_and_inertia_match_the_closed_form():
    w = phys2d.World()
    c = w.add_circle(radius=0.5, density=2.0)
    m = 2.0 * math.pi * 0.25
    assert c.mass == pytest.approx(m, rel=1e-12)
    assert c.inertia == pytest.approx(0.5 * m * 0.25, rel=1e-12)


def test_triangle_is_recentred_on_its_centroid_with_the_right_inertia():
    # right triangle with legs 3 and 3: area 4.5, centroid (1, 1);
    # polar moment about the centroid = m (a^2 + b^2 + c^2) / 36 for side lengths a, b, c
    w = phys2d.World()
    p = w.add_polygon(position=(5.0, 5.0), vertices=[(0, 0), (3, 0), (0, 3)], density=1.0)
    assert p.mass == pytest.approx(4.5)
    assert p.inertia == pytest.approx(4.5 * (9 + 9 + 18) / 36.0)
    assert np.allclose(p.position, (5.0, 5.0))
    assert np.allclose(p.local_vertices.mean(axis=0), 0.0)
    assert np.allclose(p.vertices, [(4.0, 4.0), (7.0, 4.0), (4.0, 7.0)])


def test_static_bodies_have_zero_inverse_mass():
    w = phys2d.World()
    g = w.add_box(half_extents=(5, 0.5), static=True)
    assert g.static and g.mass > 0
    assert np.all(w.M_inv[0] == 0.0)


@pytest.mark.parametrize(
    "vertices, message",
    [
        ([(0, 0), (1, 0)], "at least 3"),
        ([(0, 0), (0, 1), (1, 0)], "counter-clockwise"),
        ([(0, 0), (2, 0), (1, 0.2), (1, 2)], "convex"),
        ([(0, 0), (1, 0), (2, 0), (1, 1)], "collinear"),
        ([(0, 0), (1, 0), (1, 0), (0, 1)], "repeated"),
        ([(0, 0), (1, float("nan")), (0, 1)], "finite"),
        ([(1.0, 0.0), (-0.809, 0.588), (0.309, -0.951), (0.309, 0.951), (-0.809, -0.588)], "self-intersecting"),
        ([(0, 0, 0), (1, 0, 0), (0, 1, 0)], "shape"),
    ],
)
def test_bad_polygons_are_rejected_and_the_world_is_unchanged(vertices, message):
    w = phys2d.World()
    w.add_box(position=(0, 1))
    before = w.x.copy()
    with pytest.raises(ValueError, match=message):
        w.add_polygon(vertices=vertices)
    assert len(w.bodies) == 1 and np.array_equal(w.x, before)


def test_polygon_of_strings_is_a_type_error():
    with pytest.raises(TypeError, match="vertices"):
        phys2d.World().add_polygon(vertices="abc")
