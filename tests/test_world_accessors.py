"""World's read-only accessors: what an observer (the recorder) may read, and nothing it may write."""

from __future__ import annotations

import numpy as np
import pytest

import phys2d
from phys2d.shapes import CIRCLE, POLYGON


def small_world() -> tuple[phys2d.World, list]:
    w = phys2d.World()
    ground = w.add_box(position=(0.0, -0.5), half_extents=(5.0, 0.5), static=True)
    box = w.add_box(position=(0.0, 1.0), half_extents=(0.5, 0.25), angle=0.3)
    ball = w.add_circle(position=(2.0, 1.0), radius=0.4)
    tri = w.add_polygon(position=(-2.0, 1.0), vertices=[(0.0, 0.0), (1.0, 0.0), (0.0, 1.0)])
    return w, [ground, box, ball, tri]


def test_accessors_agree_with_the_body_handles():
    w, handles = small_world()
    assert list(w.body_uids) == [0, 1, 2, 3]
    assert list(w.body_static) == [True, False, False, False]
    assert list(w.body_kinds) == [POLYGON, POLYGON, CIRCLE, POLYGON]
    np.testing.assert_array_equal(w.body_radii, [0.0, 0.0, 0.4, 0.0])
    assert list(w.vertex_count) == [4, 4, 0, 3]
    np.testing.assert_array_equal(w.body_masses, [h.mass for h in handles])
    np.testing.assert_array_equal(w.body_inertias, [h.inertia for h in handles])
    assert w.body_masses[1] == pytest.approx(1.0 * 0.5)  # density 1 kg/m^2 times 1 m x 0.5 m
    for i, h in enumerate(handles):  # each body's slice of the packed vertices is its own polygon
        s, c = int(w.vertex_start[i]), int(w.vertex_count[i])
        np.testing.assert_array_equal(w.local_vertices[s : s + c], h.local_vertices)
    # the box's local vertices are its half extents, whatever its angle
    np.testing.assert_array_equal(np.abs(handles[1].local_vertices), np.tile([0.5, 0.25], (4, 1)))


@pytest.mark.parametrize(
    "name",
    [
        "body_uids",
        "body_static",
        "body_kinds",
        "body_radii",
        "body_masses",
        "body_inertias",
        "vertex_start",
        "vertex_count",
        "local_vertices",
    ],
)
def test_accessors_are_read_only(name):
    w, _ = small_world()
    a = getattr(w, name)
    with pytest.raises(ValueError, match="read-only"):
        a[0] = a[0]
    with pytest.raises(AttributeError):
        setattr(w, name, a)


def test_uids_survive_removal_and_follow_the_rows():
    w, handles = small_world()
    w.remove(handles[1])
    assert list(w.body_uids) == [0, 2, 3]
    assert list(w.body_kinds) == [POLYGON, CIRCLE, POLYGON]
    s, c = int(w.vertex_start[2]), int(w.vertex_count[2])
    np.testing.assert_array_equal(w.local_vertices[s : s + c], handles[3].local_vertices)
    w.add_box(position=(0.0, 3.0))
    assert list(w.body_uids) == [0, 2, 3, 4]  # a new uid, never a reused one
