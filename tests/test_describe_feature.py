"""describe_feature against the narrowphase's own encoding of contacts whose features are known from geometry."""

from __future__ import annotations

import math

import numpy as np
import pytest

import phys2d
from phys2d import describe_feature
from phys2d.collision import Feature

# shapes.box lists its corners counter-clockwise from (-hx, -hy): edge 0 is the bottom,
# edge 1 the right side, edge 2 the top (from (hx, hy) to (-hx, hy)), edge 3 the left side


def contacts_after_one_step(build) -> phys2d.Contacts:
    w = phys2d.World(gravity=(0.0, 0.0))
    build(w)
    w.step(1 / 60)
    return w.contacts


def test_box_flat_on_the_ground_names_the_top_and_bottom_edges():
    def build(w):
        w.add_box(position=(0.0, -0.5), half_extents=(5.0, 0.5), static=True)  # a: top edge at y = 0
        w.add_box(position=(0.0, 0.49), half_extents=(0.5, 0.5))  # b: bottom edge 1 cm into it

    c = contacts_after_one_step(build)
    assert len(c) == 2
    for k in range(2):
        f = describe_feature(int(c.feature[k]))
        assert (f.pair, f.reference, f.reference_edge, f.incident_edge) == ("polygons", "a", 2, 0)
        # the top edge runs from x = +5 to x = -5: the point at x = +0.5 lies towards its first vertex
        assert f.end == (0 if c.point[k, 0] > 0.0 else 1)
        assert f.edge is None and f.vertex is None
    assert repr(describe_feature(int(c.feature[0]))).startswith("Feature(reference edge 2 of a, incident edge 0 of b")


def test_box_on_its_corner_takes_the_ground_as_reference_even_when_it_is_body_b():
    def build(w):
        # the box first (body a), the ground second (body b): the ground's top face separates least
        w.add_box(position=(0.0, math.sqrt(0.5) - 0.01), half_extents=(0.5, 0.5), angle=math.pi / 4)
        w.add_box(position=(0.0, -0.5), half_extents=(5.0, 0.5), static=True)

    c = contacts_after_one_step(build)
    assert len(c) == 1
    f = describe_feature(int(c.feature[0]))
    assert (f.reference, f.reference_edge) == ("b", 2)
    # the lowest corner of a box turned by 45 degrees is its corner 0 (-h, -h) turned to (0, -h sqrt 2):
    # the incident edge is one of the two edges that meet there (3: left, 0: bottom)
    assert f.incident_edge in (3, 0)
    assert int(c.feature[0]) & phys2d.collision.narrowphase.FLIP_BIT


@pytest.mark.parametrize("x, region", [(0.0, ("edge", 2)), (5.2, ("vertex", 2))])
def test_circle_on_a_box_names_the_edge_or_the_corner_region(x, region):
    def build(w):
        w.add_box(position=(0.0, -0.5), half_extents=(5.0, 0.5), static=True)  # corner 2 at (5, 0)
        y = 0.29 if x == 0.0 else 0.29 / math.sqrt(2.0)
        w.add_circle(position=(x, y), radius=0.3)

    c = contacts_after_one_step(build)
    assert len(c) == 1
    f = describe_feature(int(c.feature[0]), pair="circle-polygon")
    assert f.pair == "circle-polygon"
    if region[0] == "edge":
        assert (f.edge, f.vertex) == (2, None)
    else:
        assert (f.edge, f.vertex) == (None, 2)


def test_circle_circle_feature_is_zero():
    def build(w):
        w.add_circle(position=(0.0, 0.0), radius=0.5, static=True)
        w.add_circle(position=(0.0, 0.99), radius=0.5)

    c = contacts_after_one_step(build)
    assert describe_feature(int(c.feature[0]), pair="circles") == Feature("circles")  # every other field None


@pytest.mark.parametrize(
    "feature, pair, error",
    [
        (1.5, "polygons", TypeError),
        (True, "polygons", TypeError),
        ("1", "polygons", TypeError),
        (-1, "polygons", ValueError),
        (1 << 16, "polygons", ValueError),
        (0x8080, "polygons", ValueError),  # bit 7 alone names two rounded cores' closest features
        (256, "circle-polygon", ValueError),
        (3, "circles", ValueError),
        (0, "capsules", ValueError),
    ],
)
def test_bad_feature_ids_are_refused_by_name(feature, pair, error):
    with pytest.raises(error, match="feature|pair"):
        describe_feature(feature, pair=pair)


def test_every_polygon_feature_round_trips():
    # the fields put back together give the id (the narrowphase's encoding, bit by bit)
    for feature in (0, 1, 0x0201, 0x8300, 0x8000 | 5 << 8 | 7 << 1 | 1):
        f = describe_feature(np.int32(feature))
        again = (f.reference == "b") << 15 | f.reference_edge << 8 | f.incident_edge << 1 | f.end
        assert again == feature
