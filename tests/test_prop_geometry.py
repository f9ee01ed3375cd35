"""Geometry properties: mass properties and contact manifolds against analytic results."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

import phys2d
from tests.strategies import ellipse_polygons, point_polygon_distance, reals, vectors


def contacts_at_rest(w: phys2d.World) -> phys2d.Contacts:
    """The contacts of the world's current positions (one step without gravity or push)."""
    w.gravity = (0.0, 0.0)
    w.responder = phys2d.PGS(beta=0.0)
    w.step(1e-3)
    return w.contacts


@given(h=st.tuples(reals(0.01, 10.0), reals(0.01, 10.0)), density=reals(0.01, 100.0), r=reals(0.01, 10.0))
def test_box_and_circle_mass_properties(h, density: float, r: float) -> None:
    """Box: m = rho 4 hx hy, I = m (w^2 + h^2) / 12. Circle: m = rho pi r^2, I = m r^2 / 2."""
    w = phys2d.World()
    box = w.add_box(half_extents=h, density=density)
    m = density * 4 * h[0] * h[1]
    assert box.mass == pytest.approx(m, rel=1e-12)
    assert box.inertia == pytest.approx(m * ((2 * h[0]) ** 2 + (2 * h[1]) ** 2) / 12, rel=1e-12)
    ball = w.add_circle(radius=r, density=density)
    m = density * math.pi * r * r
    assert ball.mass == pytest.approx(m, rel=1e-12)
    assert ball.inertia == pytest.approx(m * r * r / 2, rel=1e-12)
    assert np.array_equal(w.M_inv[1], [1 / ball.mass, 1 / ball.mass, 1 / ball.inertia])


@given(
    n=st.integers(3, 64),
    radius=reals(0.05, 5.0),
    density=reals(0.1, 10.0),
    phase=reals(0.0, 2 * math.pi),
    centre=vectors(-5.0, 5.0),
)
def test_regular_polygon_mass_properties(n: int, radius: float, density: float, phase: float, centre) -> None:
    """A regular n-gon of circumradius R: area n R^2 sin(2 pi / n) / 2 and
    I = m R^2 (1 + 2 cos^2(pi / n)) / 6, wherever its vertices were given."""
    t = phase + 2 * math.pi * np.arange(n) / n
    verts = np.stack([centre[0] + radius * np.cos(t), centre[1] + radius * np.sin(t)], axis=1)
    w = phys2d.World()
    b = w.add_polygon(position=(1.0, 2.0), vertices=verts, density=density)
    m = density * n * radius**2 * math.sin(2 * math.pi / n) / 2
    assert b.mass == pytest.approx(m, rel=1e-9)
    assert b.inertia == pytest.approx(m * radius**2 * (1 + 2 * math.cos(math.pi / n) ** 2) / 6, rel=1e-9)
    np.testing.assert_allclose(b.local_vertices.mean(axis=0), 0.0, atol=1e-9 * radius)
    assert np.array_equal(b.position, [1.0, 2.0])


@given(verts=ellipse_polygons(), shift=vectors(-10.0, 10.0), roll=st.integers(0, 7), density=reals(0.1, 10.0))
def test_polygon_is_recentred_and_order_free(verts, shift, roll: int, density: float) -> None:
    """A polygon's mass, inertia and shape about its centroid do not depend on where its
    vertices were given or on which vertex is listed first; its position is its centroid."""
    v = np.asarray(verts)
    w = phys2d.World()
    a = w.add_polygon(position=(0.5, -0.5), vertices=v, density=density)
    b = w.add_polygon(position=(0.5, -0.5), vertices=np.roll(v + shift, roll % len(v), axis=0), density=density)
    assert b.mass == pytest.approx(a.mass, rel=1e-9)
    assert b.inertia == pytest.approx(a.inertia, rel=1e-9)
    np.testing.assert_allclose(
        np.roll(b.local_vertices, -(roll % len(v)), axis=0), a.local_vertices, atol=1e-9 * (1 + np.abs(shift).max())
    )
    # the centroid of the area (not of the vertices) sits at the origin of the body frame
    p = a.local_vertices
    q = np.roll(p, -1, axis=0)
    cross = p[:, 0] * q[:, 1] - p[:, 1] * q[:, 0]
    np.testing.assert_allclose(((p + q) * cross[:, None]).sum(axis=0), 0.0, atol=1e-9)


@given(h=st.tuples(reals(0.05, 3.0), reals(0.05, 3.0)), density=reals(0.1, 10.0))
def test_polygon_of_a_box_is_the_box(h, density: float) -> None:
    """add_polygon with a box's four corners gives the same body as add_box."""
    w = phys2d.World()
    a = w.add_box(half_extents=h, density=density)
    hx, hy = h
    b = w.add_polygon(vertices=[(-hx, -hy), (hx, -hy), (hx, hy), (-hx, hy)], density=density)
    assert (a.mass, a.inertia) == pytest.approx((b.mass, b.inertia), rel=1e-12)
    np.testing.assert_allclose(a.local_vertices, b.local_vertices, atol=1e-12)


@given(
    ra=reals(0.1, 2.0),
    rb=reals(0.1, 2.0),
    gap=reals(-0.5, 0.019),
    heading=reals(-math.pi, math.pi),
    a_at=vectors(-3.0, 3.0),
)
def test_circle_circle_contact_is_analytic(ra: float, rb: float, gap: float, heading: float, a_at) -> None:
    """Two circles: one point, normal along the centre line from a to b, separation
    |x_b - x_a| - r_a - r_b, the point midway between the surfaces."""
    assume(gap > -min(ra, rb))
    d = np.array([math.cos(heading), math.sin(heading)])
    xa = np.asarray(a_at)
    xb = xa + (ra + rb + gap) * d
    w = phys2d.World(gravity=(0.0, 0.0))
    w.add_circle(position=xa, radius=ra)
    w.add_circle(position=xb, radius=rb)
    c = contacts_at_rest(w)
    assert len(c) == 1
    sep = float(np.linalg.norm(xb - xa)) - ra - rb
    assert c.separation[0] == pytest.approx(sep, abs=1e-9)
    np.testing.assert_allclose(c.normal[0], d, atol=1e-9)
    np.testing.assert_allclose(c.point[0], xa + (ra + sep / 2) * d, atol=1e-9)


@given(
    verts=ellipse_polygons(),
    r=reals(0.05, 1.0),
    direction=reals(-math.pi, math.pi),
    dist=reals(-0.1, 1.5),
    angle=reals(-math.pi, math.pi),
)
def test_circle_polygon_separation_is_the_distance(
    verts, r: float, direction: float, dist: float, angle: float
) -> None:
    """Circle against a convex polygon: the separation is the signed distance from the
    centre to the polygon (second method: nearest edge segment) minus r, and the normal
    points from the polygon to the circle."""
    w = phys2d.World(gravity=(0.0, 0.0), contact_margin=0.02)
    poly = w.add_polygon(position=(0.0, 0.0), vertices=verts, angle=angle)
    centre = np.array([math.cos(direction), math.sin(direction)]) * dist * 2
    w.add_circle(position=centre, radius=r)
    world_verts = poly.vertices
    expected = point_polygon_distance(centre, world_verts) - r
    c = contacts_at_rest(w)
    if expected > w.contact_margin + 1e-9:
        assert len(c) == 0
        return
    assume(expected < w.contact_margin - 1e-9)
    assert len(c) == 1
    assert c.separation[0] == pytest.approx(expected, abs=1e-9)
    if expected + r > 1e-6:  # centre outside: the normal runs from the nearest point to it
        nearest = centre - (expected + r) * c.normal[0]
        assert point_polygon_distance(nearest, world_verts) == pytest.approx(0.0, abs=1e-9)


@given(
    a=st.tuples(reals(0.2, 2.0), reals(0.2, 2.0)),
    b=st.tuples(reals(0.2, 2.0), reals(0.2, 2.0)),
    dx=reals(-1.0, 1.0),
    gap=reals(-0.1, 0.019),
)
def test_stacked_boxes_touch_along_their_overlap(a, b, dx: float, gap: float) -> None:
    """An axis-aligned box over another: two points with normal +y, separation the
    vertical gap, lying at the ends of the horizontal overlap of the two faces."""
    lo = max(-a[0], dx * (a[0] + b[0]) - b[0])
    hi = min(a[0], dx * (a[0] + b[0]) + b[0])
    assume(hi - lo > max(0.0, -gap) + 0.01)  # the y axis separates least: no tie with x
    w = phys2d.World(gravity=(0.0, 0.0))
    w.add_box(position=(0.0, 0.0), half_extents=a)
    w.add_box(position=(dx * (a[0] + b[0]), a[1] + b[1] + gap), half_extents=b)
    c = contacts_at_rest(w)
    assert len(c) == 2
    np.testing.assert_allclose(c.normal, [[0.0, 1.0], [0.0, 1.0]], atol=1e-12)
    np.testing.assert_allclose(c.separation, [gap, gap], atol=1e-9)
    np.testing.assert_allclose(sorted(c.point[:, 0]), [lo, hi], atol=1e-9)
    np.testing.assert_allclose(c.point[:, 1], a[1] + gap / 2, atol=1e-9)
