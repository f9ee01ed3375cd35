"""Queries: World.ray_cast, query_point and query_aabb against analytic results and brute force,
and the per-shape functions of phys2d.collision.queries against a second method."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

import phys2d
from phys2d.collision import queries
from tests.strategies import ellipse_polygons, point_polygon_distance, reals, vectors

# -- second methods, written here ----------------------------------------------------------------


def circle_entry(start, end, centre, r):
    """The quadratic formula: |start + t d - c| = r, the smaller root; None when it misses in
    [0, 1] or starts inside. Also the margins that make the answer robust: (t, disc, c)."""
    s, e, c = (np.asarray(v, float) for v in (start, end, centre))
    d, f = e - s, s - c
    a, b, cc = d @ d, 2.0 * (f @ d), f @ f - r * r
    disc = b * b - 4.0 * a * cc
    if cc <= 0.0 or disc < 0.0 or a == 0.0:
        return None, disc / max(a, 1e-300), cc
    t = (-b - math.sqrt(disc)) / (2.0 * a)
    return (t if 0.0 <= t <= 1.0 else None), disc / a, cc


def box_entry(start, end, centre, angle, h):
    """The slab method in the box's frame: the ray is inside slab k (|local_k| <= h_k) for t in
    [t_k0, t_k1]; it enters at the largest t_k0, if that comes before the smallest t_k1.
    Returns (t or None, the local axis and sign of the face entered, the margin of the answer)."""
    rot = np.array([[math.cos(angle), math.sin(angle)], [-math.sin(angle), math.cos(angle)]])  # R(-angle)
    p = rot @ (np.asarray(start, float) - centre)
    d = rot @ (np.asarray(end, float) - np.asarray(start, float))
    if np.all(np.abs(p) <= h):
        return None, None, 0.0  # starts inside or on it
    t_in, t_out, face = -math.inf, math.inf, None
    for k in range(2):
        if d[k] == 0.0:
            if abs(p[k]) > h[k]:
                return None, None, abs(p[k]) - h[k]
            continue
        t0, t1 = sorted(((-h[k] - p[k]) / d[k], (h[k] - p[k]) / d[k]))
        if t0 > t_in:
            t_in, face = t0, (k, -math.copysign(1.0, d[k]))
        t_out = min(t_out, t1)
    margin = min(abs(t_out - t_in), abs(t_in), abs(t_in - 1.0))
    if t_in > t_out or not 0.0 <= t_in <= 1.0:
        return None, None, margin
    return t_in, face, margin


def box_face_margin(start, end, centre, angle, h):
    """How far apart (in t) the two slabs' entries are: near 0 the ray enters at a corner."""
    rot = np.array([[math.cos(angle), math.sin(angle)], [-math.sin(angle), math.cos(angle)]])
    p = rot @ (np.asarray(start, float) - centre)
    d = rot @ (np.asarray(end, float) - np.asarray(start, float))
    entries = [min((-h[k] - p[k]) / d[k], (h[k] - p[k]) / d[k]) for k in range(2) if d[k] != 0.0]
    return abs(entries[0] - entries[1]) if len(entries) == 2 else math.inf


def rotate(v, angle):
    c, s = math.cos(angle), math.sin(angle)
    return np.array([c * v[0] - s * v[1], s * v[0] + c * v[1]])


# -- rays against one circle or one box: analytic -------------------------------------------------


@given(centre=vectors(-5.0, 5.0), r=reals(0.05, 3.0), start=vectors(-8.0, 8.0), end=vectors(-8.0, 8.0))
def test_ray_against_a_circle_is_the_quadratic_formulas_root(centre, r, start, end) -> None:
    """fraction = the smaller root of |s + t d - c|^2 = r^2, point = s + t d, normal = (p - c) / r."""
    t, disc, cc = circle_entry(start, end, centre, r)
    assume(abs(disc) > 1e-6 and abs(cc) > 1e-6)  # not grazing, not starting on the circle
    if t is not None:
        assume(min(t, 1.0 - t) > 1e-9)
    w = phys2d.World()
    ball = w.add_circle(centre, radius=r)
    hits = w.ray_cast(start, end)
    if t is None:
        assert hits == []
        return
    (hit,) = hits
    assert hit.body == ball
    assert hit.fraction == pytest.approx(t, rel=1e-7, abs=1e-9)
    p = np.asarray(start) + t * (np.asarray(end) - np.asarray(start))
    np.testing.assert_allclose(hit.point, p, atol=1e-7)
    np.testing.assert_allclose(hit.normal, (p - np.asarray(centre)) / r, atol=1e-6)


@given(
    centre=vectors(-4.0, 4.0),
    angle=reals(-math.pi, math.pi),
    h=vectors(0.05, 2.0),
    start=vectors(-8.0, 8.0),
    direction=reals(-math.pi, math.pi),
    length=reals(0.01, 16.0),
)
def test_ray_against_a_box_is_the_slab_methods_entry(centre, angle, h, start, direction, length) -> None:
    """A rotated box: the slab method in its frame gives the fraction, and the face entered
    gives the normal (that face's axis, turned by the box's angle)."""
    end = np.asarray(start) + length * np.array([math.cos(direction), math.sin(direction)])
    t, face, margin = box_entry(start, end, np.asarray(centre), angle, np.asarray(h))
    assume(margin > 1e-7)  # not grazing a corner, not entering at t = 0 or 1
    w = phys2d.World()
    box = w.add_box(centre, half_extents=h, angle=angle)
    hits = w.ray_cast(start, end)
    if t is None:
        assert hits == []
        return
    (hit,) = hits
    assert hit.body == box
    assert hit.fraction == pytest.approx(t, rel=1e-7, abs=1e-9)
    np.testing.assert_allclose(hit.point, np.asarray(start) + t * (end - np.asarray(start)), atol=1e-7)
    assert math.hypot(*hit.normal) == pytest.approx(1.0, rel=1e-12)
    if box_face_margin(start, end, np.asarray(centre), angle, np.asarray(h)) > 1e-7:  # not a corner
        k, sign = face
        np.testing.assert_allclose(hit.normal, rotate(sign * np.eye(2)[k], angle), atol=1e-9)


@given(verts=ellipse_polygons(), position=vectors(-3.0, 3.0), angle=reals(-math.pi, math.pi), u=vectors(0.0, 1.0))
def test_a_ray_starting_inside_a_shape_does_not_hit_it(verts, position, angle, u) -> None:
    """Box2D's rule: from a point inside a polygon (or a circle), the ray hits the shapes beyond
    it only, wherever it points."""
    w = phys2d.World()
    body = w.add_polygon(position, vertices=verts, angle=angle)
    ball = w.add_circle((20.0, position[1]), radius=0.5)
    v = body.vertices
    inside = (1.0 - u[0]) * np.asarray(position) + u[0] * ((1.0 - u[1]) * v[0] + u[1] * v[1])  # in x, v0, v1
    assume(point_polygon_distance(inside, v) < -1e-9)
    assert body in w.query_point(inside)
    assert [h.body for h in w.ray_cast(inside, (30.0, position[1]))] == [ball]
    assert w.ray_cast(inside, (inside[0] + 0.01, inside[1])) == []
    assert w.ray_cast(ball.position, (ball.position[0], 10.0)) == []  # from a circle's centre: nothing


def test_a_ray_that_misses_and_one_that_ends_short() -> None:
    w = phys2d.World()
    w.add_box((0.0, 0.0), half_extents=(1.0, 1.0))
    w.add_circle((5.0, 0.0), radius=1.0)
    assert w.ray_cast((-5.0, 1.5), (10.0, 1.5)) == []  # passes above both
    assert w.ray_cast((-5.0, 0.0), (-1.5, 0.0)) == []  # stops 0.5 m short of the box
    (hit,) = w.ray_cast((-5.0, 0.0), (-1.0, 0.0))  # ends on its face: fraction 1
    assert hit.fraction == 1.0 and np.array_equal(hit.point, [-1.0, 0.0])
    assert np.array_equal(hit.normal, [-1.0, 0.0])


def test_a_ray_of_length_zero_hits_nothing() -> None:
    w = phys2d.World()
    w.add_box((0.0, 0.0), half_extents=(1.0, 1.0))
    w.add_circle((5.0, 0.0), radius=1.0)
    for p in [(0.0, 0.0), (-3.0, 0.0), (-1.0, 0.0), (5.0, 1.0)]:  # inside, outside, on a face
        assert w.ray_cast(p, p) == []


@given(
    gaps=st.lists(reals(0.05, 2.0), min_size=1, max_size=8),
    kinds=st.lists(st.booleans(), min_size=8, max_size=8),
    order=st.permutations(range(8)),
    heading=reals(-math.pi, math.pi),
)
def test_hits_are_sorted_by_fraction_one_per_body(gaps, kinds, order, heading) -> None:
    """Bodies placed along the ray, in any creation order: each is hit once, at the distance
    its near side lies from the start, nearest first."""
    n = len(gaps)
    u = np.array([math.cos(heading), math.sin(heading)])
    size = 0.4
    near, s = [], 1.0
    for g in gaps:  # the near side of body k is at distance s along the ray
        near.append(s)
        s += 2 * size + g
    length = s + 1.0
    placed = [k for k in order if k < n]
    w = phys2d.World()
    made = {}
    for k in placed:
        centre = (near[k] + size) * u
        if kinds[k]:
            made[k] = w.add_circle(centre, radius=size)
        else:
            made[k] = w.add_box(centre, half_extents=(size, size), angle=heading)
    hits = w.ray_cast((0.0, 0.0), length * u)
    assert [h.body for h in hits] == [made[k] for k in range(n)]
    assert [h.fraction for h in hits] == sorted(h.fraction for h in hits)
    np.testing.assert_allclose([h.fraction * length for h in hits], near, atol=1e-9)
    for h in hits:
        np.testing.assert_allclose(h.normal, -u, atol=1e-9)


def test_equal_fractions_come_in_creation_order() -> None:
    w = phys2d.World()
    upper = w.add_circle((2.0, 1.0), radius=1.5)
    lower = w.add_circle((2.0, -1.0), radius=1.5)  # mirror images across the ray's line
    assert [h.body for h in w.ray_cast((0.0, 0.0), (4.0, 0.0))] == [upper, lower]


# -- rounded polygons: the shapes capsules and segments will be --------------------------------


@given(
    verts=st.one_of(ellipse_polygons(), st.tuples(vectors(-1.0, 1.0), vectors(-1.0, 1.0)).map(list)),
    radius=reals(0.01, 1.0),
    start=vectors(-4.0, 4.0),
    end=vectors(-4.0, 4.0),
)
def test_ray_against_a_rounded_polygon_meets_its_surface_first_there(verts, radius, start, end) -> None:
    """The surface of a polygon grown by r is where the distance to the polygon is r: the hit lies
    there, with the normal pointing from the polygon's nearest point to it, and no sample of the
    ray before it is within r. A miss: no sample within r (second method: the distance to
    the polygon, ``point_polygon_distance``; a two-vertex 'polygon' is a segment, a capsule)."""
    v = np.asarray(verts, float)
    assume(len(v) > 2 or np.linalg.norm(v[1] - v[0]) > 1e-3)
    s, e = np.asarray(start, float), np.asarray(end, float)

    def distance(p):
        if len(v) == 2:
            a, b = v
            u = min(1.0, max(0.0, float((p - a) @ (b - a) / ((b - a) @ (b - a)))))
            return float(np.linalg.norm(p - (a + u * (b - a))))
        return max(0.0, point_polygon_distance(p, v))

    assume(distance(s) > radius + 1e-6)
    t, n_x, n_y = queries.ray_polygon(s, e - s, v, radius)
    samples = np.linspace(0.0, 1.0, 401)
    far = [distance(s + u * (e - s)) - radius for u in samples]
    if t == queries.MISS:
        assert min(far) > -1e-6
        return
    p = s + t * (e - s)
    assert 0.0 <= t <= 1.0
    assert distance(p) == pytest.approx(radius, abs=1e-9)
    assert all(f > -1e-6 for u, f in zip(samples, far, strict=True) if u < t - 1e-9)
    assert math.hypot(n_x, n_y) == pytest.approx(1.0, rel=1e-12)
    nearest = p - radius * np.array([n_x, n_y])  # the polygon's nearest point to p
    assert distance(nearest) == pytest.approx(0.0, abs=1e-9)


@given(a=vectors(-2.0, 2.0), b=vectors(-2.0, 2.0), start=vectors(-4.0, 4.0), end=vectors(-4.0, 4.0))
def test_a_two_vertex_polygon_of_radius_0_is_a_segment(a, b, start, end) -> None:
    """Segment against segment: start + t d = a + u (b - a) solved by Cramer's rule; a hit when
    both t and u lie in [0, 1], its normal across the segment, against the ray."""
    s, e, p, q = (np.asarray(v, float) for v in (start, end, a, b))
    d, f = e - s, q - p
    det = d[0] * -f[1] + f[0] * d[1]  # det [d, -f]
    assume(np.linalg.norm(f) > 1e-3 and abs(det) > 1e-6 * np.linalg.norm(d) * np.linalg.norm(f))
    w = p - s
    t = (w[0] * -f[1] + f[0] * w[1]) / det
    u = (d[0] * w[1] - d[1] * w[0]) / det
    assume(min(abs(t), abs(t - 1.0), abs(u), abs(u - 1.0)) > 1e-7)
    got, n_x, n_y = queries.ray_polygon(s, d, np.stack([p, q]), 0.0)
    if not (0.0 < t < 1.0 and 0.0 < u < 1.0):
        assert got == queries.MISS
        return
    assert got == pytest.approx(t, rel=1e-7, abs=1e-9)
    n = np.array([n_x, n_y])
    assert abs(n @ f) < 1e-9 and n @ d < 0.0


@given(centre=vectors(-2.0, 2.0), r=reals(0.05, 2.0), start=vectors(-4.0, 4.0), end=vectors(-4.0, 4.0))
def test_a_one_vertex_rounded_polygon_is_a_circle(centre, r, start, end) -> None:
    s, e = np.asarray(start, float), np.asarray(end, float)
    c = np.asarray(centre, float)
    as_polygon = queries.ray_polygon(s, e - s, c[None, :], r)
    as_circle = queries.ray_circle(s, e - s, c, r)
    assert as_polygon == as_circle
    assert queries.polygon_contains(c[None, :], r, s) == queries.circle_contains(s, c, r)


# -- rays through vertices, along edges, from surfaces and 1e8 m long: exact where float64 allows -


EPS = np.finfo(float).eps


def test_a_ray_through_a_chains_vertex_hits_both_segments_there() -> None:
    """The vertex (0, 0) ends both segments: the ray down through it enters each at t = 1/2,
    on their upper side (a ground listed right to left), normal up."""
    w = phys2d.World()
    right, left = w.add_chain([(5.0, 0.0), (0.0, 0.0), (-5.0, 0.0)])
    hits = w.ray_cast((0.0, 5.0), (0.0, -5.0))
    assert [h.body for h in hits] == [right, left]
    for h in hits:
        assert h.fraction == 0.5
        assert np.array_equal(h.point, [0.0, 0.0]) and np.array_equal(h.normal, [0.0, 1.0])


def test_a_ray_through_a_segments_end() -> None:
    """Straight down through the end (1, 0): the face's normal; at 45 degrees through the end
    (-1, 0): a normal of that end, up (the face) or left (out of the end), facing the ray."""
    w = phys2d.World()
    seg = w.add_segment((-1.0, 0.0), (1.0, 0.0))
    (hit,) = w.ray_cast((1.0, 5.0), (1.0, -5.0))
    assert hit.body == seg and hit.fraction == 0.5
    assert np.array_equal(hit.point, [1.0, 0.0]) and np.array_equal(hit.normal, [0.0, 1.0])
    (hit,) = w.ray_cast((-2.0, 1.0), (0.0, -1.0))
    assert hit.fraction == 0.5 and np.array_equal(hit.point, [-1.0, 0.0])
    assert hit.normal.tolist() in ([0.0, 1.0], [-1.0, 0.0])


@pytest.mark.parametrize("radius", [0.0, 0.25])
def test_a_ray_along_a_segments_own_line_enters_by_its_end(radius) -> None:
    """Along the line of the segment (-1, 0) (1, 0), rounded by r: it enters at the near end's
    cap, x = -1 - r (or 1 + r from the right), its normal pointing back along the ray."""
    w = phys2d.World()
    w.add_segment((-1.0, 0.0), (1.0, 0.0), radius=radius)
    (hit,) = w.ray_cast((-5.0, 0.0), (5.0, 0.0))
    assert hit.fraction == pytest.approx((4.0 - radius) / 10.0, abs=1e-15)
    np.testing.assert_allclose(hit.point, [-1.0 - radius, 0.0], atol=1e-15)
    assert np.array_equal(hit.normal, [-1.0, 0.0])
    (hit,) = w.ray_cast((5.0, 0.0), (-5.0, 0.0))
    np.testing.assert_allclose(hit.point, [1.0 + radius, 0.0], atol=1e-15)
    assert np.array_equal(hit.normal, [1.0, 0.0])


def test_a_ray_along_a_chain_enters_each_segment_by_its_near_end() -> None:
    w = phys2d.World()
    right, left = w.add_chain([(5.0, 0.0), (0.0, 0.0), (-5.0, 0.0)])
    hits = w.ray_cast((-10.0, 0.0), (10.0, 0.0))
    assert [h.body for h in hits] == [left, right]
    assert [h.fraction for h in hits] == [0.25, 0.5]
    assert [h.point.tolist() for h in hits] == [[-5.0, 0.0], [0.0, 0.0]]
    assert all(np.array_equal(h.normal, [-1.0, 0.0]) for h in hits)


def test_a_ray_along_an_edge_touches_at_its_corner() -> None:
    """Touching counts (as for query_point): along a box's top edge the ray is on the box from
    the corner (-1, 1), where it crosses the left edge's line; along a capsule's flat side, from
    where the side begins over its left cap's centre."""
    w = phys2d.World()
    box = w.add_box((0.0, 0.0), half_extents=(1.0, 1.0))
    (hit,) = w.ray_cast((-3.0, 1.0), (3.0, 1.0))
    assert hit.body == box and hit.fraction == pytest.approx(1.0 / 3.0, abs=1e-15)
    np.testing.assert_allclose(hit.point, [-1.0, 1.0], atol=1e-15)
    assert np.array_equal(hit.normal, [-1.0, 0.0])
    w = phys2d.World()
    w.add_capsule((0.0, 0.0), half_length=1.0, radius=0.5)
    (hit,) = w.ray_cast((-5.0, 0.5), (5.0, 0.5))
    assert hit.fraction == 0.4 and np.array_equal(hit.point, [-1.0, 0.5])
    assert np.array_equal(hit.normal, [0.0, 1.0])


@pytest.mark.parametrize("length", [1e6, 1e8, 1e9])
def test_a_long_ray_at_a_small_circle(length) -> None:
    """From (-L, 0) to (L, 0) at a circle of radius 0.5 about the origin: the entry (-0.5, 0),
    within a few ulps of the ray's start (eps L), and within 1 mm at 1e8 m."""
    w = phys2d.World()
    w.add_circle((0.0, 0.0), radius=0.5)
    (hit,) = w.ray_cast((-length, 0.0), (length, 0.0))
    error = float(np.linalg.norm(hit.point - [-0.5, 0.0]))
    assert error <= 16 * EPS * length and error <= 1e-3
    np.testing.assert_allclose(hit.normal, [-1.0, 0.0], atol=1e-12)
    assert hit.fraction == pytest.approx((length - 0.5) / (2 * length), rel=4 * EPS)


@pytest.mark.parametrize("length", [1e6, 1e8, 1e9])
def test_a_long_ray_at_a_capsule(length) -> None:
    """Along y = 0.1 at a capsule of core (-0.5, 0) (0.5, 0) and radius 0.25: it enters the left
    cap at x = -0.5 - sqrt(0.25^2 - 0.1^2), normal (x + 0.5, 0.1) / 0.25, never inside."""
    w = phys2d.World()
    w.add_capsule((0.0, 0.0), half_length=0.5, radius=0.25)
    (hit,) = w.ray_cast((-length, 0.1), (length, 0.1))
    x = -0.5 - math.sqrt(0.25**2 - 0.1**2)
    error = float(np.linalg.norm(hit.point - [x, 0.1]))
    assert error <= 16 * EPS * length and error <= 1e-3
    np.testing.assert_allclose(hit.normal, [(x + 0.5) / 0.25, 0.1 / 0.25], atol=1e-9)
    assert math.hypot(hit.point[0] + 0.5, hit.point[1]) >= 0.25 - 16 * EPS * length  # not inside the cap


def test_a_ray_from_a_surface_does_not_hit_that_shape() -> None:
    """Starting exactly on a box's face, a circle, a segment or a capsule's side, in or out or
    along: no hit of that shape (Box2D's rule), while a ray from just outside does hit it."""
    w = phys2d.World()
    box = w.add_box((0.0, 0.0), half_extents=(1.0, 1.0))
    ball = w.add_circle((5.0, 0.0), radius=0.5)
    seg = w.add_segment((-1.0, 5.0), (1.0, 5.0))
    pill = w.add_capsule((5.0, 5.0), half_length=1.0, radius=0.5)
    on = {box: (1.0, 0.25), ball: (4.5, 0.0), seg: (0.25, 5.0), pill: (5.25, 5.5)}
    for body, p in on.items():
        for direction in [(1.0, 0.0), (-1.0, 0.0), (0.0, 1.0), (0.0, -1.0), (0.6, -0.8)]:
            end = (p[0] + 0.3 * direction[0], p[1] + 0.3 * direction[1])
            assert body not in [h.body for h in w.ray_cast(p, end)], (body.shape, direction)
    (hit,) = w.ray_cast((1.5, 0.25), (0.5, 0.25))
    assert hit.body == box and hit.fraction == 0.5


def test_queries_take_any_finite_input() -> None:
    """query_point and query_aabb answer for any finite point or box; ray_cast too, but for a
    ray whose end - start overflows a float, a ValueError naming start and end."""
    w = phys2d.World()
    ball = w.add_circle((0.0, 0.0), radius=0.5)
    w.add_chain([(5.0, -1.0), (0.0, -2.0), (-5.0, -1.0)])
    big = np.finfo(float).max
    for p in [(big, -big), (1e300, 1e-320), (-1e8, 0.0)]:
        assert w.query_point(p) == []
    assert w.query_aabb((-big, -big), (big, big)) == list(w.bodies)
    assert w.query_aabb((1e300, 1e300), (big, big)) == []
    hits = w.ray_cast((-1e300, 0.0), (1e300, 0.0))  # its points are known to 1e284 m: it may touch all
    assert ball in [h.body for h in hits]
    assert all(np.all(np.isfinite(h.point)) and math.hypot(*h.normal) == pytest.approx(1.0) for h in hits)
    with pytest.raises(ValueError, match="start and end are too far apart"):
        w.ray_cast((-big, 0.0), (big, 0.0))


# -- query_point ---------------------------------------------------------------------------------


@given(
    centre=vectors(-3.0, 3.0),
    r=reals(0.05, 2.0),
    h=vectors(0.05, 2.0),
    angle=reals(-math.pi, math.pi),
    point=vectors(-6.0, 6.0),
)
def test_query_point_is_the_analytic_inside_test(centre, r, h, angle, point) -> None:
    """Circle: |p - c| <= r. Box: |local x| <= hx and |local y| <= hy in the box's frame."""
    c, p = np.asarray(centre), np.asarray(point)
    local = rotate(p - c, -angle)
    in_circle = float(np.linalg.norm(p - c)) - r
    in_box = max(abs(local[0]) - h[0], abs(local[1]) - h[1])
    assume(abs(in_circle) > 1e-9 and abs(in_box) > 1e-9)
    w = phys2d.World()
    ball = w.add_circle(centre, radius=r)
    box = w.add_box(centre, half_extents=h, angle=angle)
    expected = [b for b, inside in ((ball, in_circle < 0), (box, in_box < 0)) if inside]
    assert w.query_point(point) == expected


def test_query_point_counts_the_surface() -> None:
    w = phys2d.World()
    box = w.add_box((0.0, 0.0), half_extents=(1.0, 0.5))
    ball = w.add_circle((3.0, 0.0), radius=0.5)
    assert w.query_point((1.0, 0.25)) == [box]  # on a face
    assert w.query_point((1.0, 0.5)) == [box]  # a corner
    assert w.query_point((3.0, 0.5)) == [ball]
    assert w.query_point((2.0, 0.0)) == []


# -- query_aabb ----------------------------------------------------------------------------------


@given(
    bodies=st.lists(
        st.tuples(st.booleans(), vectors(-5.0, 5.0), vectors(0.05, 1.5), reals(-math.pi, math.pi)),
        min_size=0,
        max_size=10,
    ),
    corner=vectors(-6.0, 6.0),
    size=vectors(0.0, 6.0),
)
def test_query_aabb_is_brute_force_over_the_shapes_boxes(bodies, corner, size) -> None:
    """A body is returned when the box around its world vertices (circle: centre -+ r) overlaps
    the query box, in creation order."""
    w = phys2d.World()
    made = []
    for is_circle, centre, h, angle in bodies:
        if is_circle:
            made.append(w.add_circle(centre, radius=h[0]))
        else:
            made.append(w.add_box(centre, half_extents=h, angle=angle))
    lo = np.asarray(corner)
    hi = lo + np.asarray(size)
    expected, margins = [], [1.0]
    for body in made:
        if body.shape == "circle":
            b_lo, b_hi = body.position - body.radius, body.position + body.radius
        else:
            b_lo, b_hi = body.vertices.min(axis=0), body.vertices.max(axis=0)
        gaps = np.concatenate([b_lo - hi, lo - b_hi])  # all <= 0: they overlap
        margins.append(float(np.min(np.abs(gaps))))
        if np.all(gaps <= 0.0):
            expected.append(body)
    assume(min(margins) > 1e-9)
    assert w.query_aabb(lo, hi) == expected


def test_query_aabb_finds_a_body_whose_box_only_overlaps() -> None:
    """Box2D's meaning: the shapes' boxes are tested, not the shapes."""
    w = phys2d.World()
    ball = w.add_circle((0.0, 0.0), radius=1.0)
    assert w.query_aabb((0.8, 0.8), (2.0, 2.0)) == [ball]  # the box's corner, outside the circle
    assert w.query_point((0.9, 0.9)) == []
    assert w.query_aabb((1.0, -3.0), (2.0, 3.0)) == [ball]  # touching counts
    assert w.query_aabb((1.01, -3.0), (2.0, 3.0)) == []
    assert w.query_aabb((0.0, 0.0), (0.0, 0.0)) == [ball]  # a box of no size: a point


# -- queries see the world as it is --------------------------------------------------------------


def test_queries_follow_the_bodies_as_they_move() -> None:
    """A ball falls onto the ground; after each step the ray down from above it meets its top,
    query_point its centre, query_aabb its box: all where body.position says it is now."""
    w = phys2d.World(gravity=(0.0, -10.0))
    ground = w.add_box((0.0, -0.5), half_extents=(10.0, 0.5), static=True)
    ball = w.add_circle((1.0, 3.0), radius=0.25, velocity=(0.5, 0.0))
    for _ in range(90):
        w.step(1 / 60)
        x = ball.position
        hits = w.ray_cast((x[0], 10.0), (x[0], -10.0))
        assert [h.body for h in hits] == [ball, ground]
        np.testing.assert_allclose(hits[0].point, (x[0], x[1] + 0.25), atol=1e-9)
        assert hits[1].point[1] == pytest.approx(0.0, abs=1e-12)
        assert w.query_point(x) == [ball]
        assert ball in w.query_aabb(x + 0.24, x + 0.3)
        assert ball not in w.query_aabb(x + 0.26, x + 0.3)
    assert ball.position[1] == pytest.approx(0.25, abs=0.02)  # it came to rest on the ground


def test_removed_bodies_are_not_returned() -> None:
    w = phys2d.World()
    a = w.add_circle((0.0, 0.0), radius=0.5)
    b = w.add_box((2.0, 0.0), half_extents=(0.5, 0.5))
    c = w.add_circle((4.0, 0.0), radius=0.5)
    w.remove(b)
    assert [h.body for h in w.ray_cast((-2.0, 0.0), (6.0, 0.0))] == [a, c]
    assert w.query_point((2.0, 0.0)) == []
    assert w.query_aabb((-1.0, -1.0), (5.0, 1.0)) == [a, c]
    w.remove(a)
    (hit,) = w.ray_cast((-2.0, 0.0), (6.0, 0.0))
    assert hit.body == c and hit.body.index == 0
    assert w.query_point((4.0, 0.0)) == [c]


def test_an_empty_world_answers_nothing() -> None:
    w = phys2d.World()
    assert w.ray_cast((0.0, 0.0), (1.0, 0.0)) == []
    assert w.query_point((0.0, 0.0)) == []
    assert w.query_aabb((0.0, 0.0), (1.0, 1.0)) == []


def test_ray_hit_reads_well() -> None:
    w = phys2d.World()
    w.add_box((0.0, 0.0), half_extents=(1.0, 1.0))
    (hit,) = w.ray_cast((-3.0, 0.0), (1.0, 0.0))
    assert isinstance(hit, phys2d.RayHit)
    assert repr(hit) == "<RayHit body 0: fraction=0.5, point=(-1, 0) m, normal=(-1, 0)>"


# -- bad input -----------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "call, error, names",
    [
        (lambda w: w.ray_cast((math.nan, 0.0), (1.0, 0.0)), ValueError, "start must be finite"),
        (lambda w: w.ray_cast((0.0, 0.0), (1.0, math.inf)), ValueError, "end must be finite"),
        (lambda w: w.ray_cast((0.0, 0.0, 0.0), (1.0, 0.0)), ValueError, r"start must have shape \(2,\)"),
        (lambda w: w.ray_cast("ab", (1.0, 0.0)), TypeError, "start must be a pair"),
        (lambda w: w.ray_cast((0.0, 0.0), None), TypeError, "end must be a pair"),
        (lambda w: w.query_point((0.0, math.nan)), ValueError, "point must be finite"),
        (lambda w: w.query_point([[0.0, 1.0]]), ValueError, r"point must have shape \(2,\)"),
        (lambda w: w.query_aabb((1.0, 0.0), (0.0, 1.0)), ValueError, "lower must be <= upper"),
        (lambda w: w.query_aabb((0.0, 2.0), (1.0, 1.0)), ValueError, "lower must be <= upper"),
        (lambda w: w.query_aabb((0.0, 0.0), (1.0, math.nan)), ValueError, "upper must be finite"),
        (lambda w: w.query_aabb(0.0, (1.0, 1.0)), ValueError, r"lower must have shape \(2,\)"),
    ],
)
def test_bad_query_input_names_the_argument(call, error, names) -> None:
    w = phys2d.World()
    w.add_box((0.0, 0.0), half_extents=(1.0, 1.0))
    before = (w.x.copy(), w.theta.copy(), w.V.copy())
    with pytest.raises(error, match=names):
        call(w)
    assert all(np.array_equal(a, b) for a, b in zip(before, (w.x, w.theta, w.V), strict=True))
