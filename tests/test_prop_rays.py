"""World.ray_cast against a brute force written here, for every shape kind: rays at random,
through vertices, along edges, from inside or on a surface, and up to 1e8 m long.

The reference knows each shape as the test placed it (its core points in the world, worked
out here from the add_* call, and its radius) and measures the signed distance g to it, a
convex function of the distance s along the ray for a convex shape. Its minimum on the ray
(golden section) says whether the ray gets in, and the first zero before it (bisection) where:
no per-feature algebra, nothing read from the engine's arrays. A bare segment has no inside
for g to go below 0: a ray clearly crossing its line between its ends must hit it there.

Float64 places the ray's own points only to about eps M, M the largest coordinate in play
(1e8 m for a long ray), so the checks allow TOL = 1024 eps M (2e-5 m at 1e8 m, under the
1 mm required): a reported hit lies on the surface within TOL (|g| <= TOL), the ray before
it is nowhere deeper inside than TOL, its point is start + fraction (end - start), and its
unit normal faces the ray and supports the shape there (no point of the shape lies more
than TOL beyond the tangent line). Where the ray gets deeper in than TOL, a hit is required
and its distance along the ray from the reference's entry is bounded by TOL over the slope
of g there (bounded below by convexity); where it stays farther than TOL, none is allowed.
Within TOL of the surface (grazing, or starting on it) either answer stands, and so it does
for a chain segment's back: which side of a chain a ray hits is not promised.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import pytest
from hypothesis import event, given
from hypothesis import strategies as st

import phys2d
from tests.strategies import ellipse_polygons, reals, vectors

EPS = 2.0**-52
KINDS = ["circle", "box", "polygon", "capsule", "segment", "rounded segment", "chain"]
Point = tuple[float, float]

# -- the shapes, as the test places them ---------------------------------------------------------


@dataclass(frozen=True)
class Shape:
    """A convex core (one point, a segment, or a filled counter-clockwise polygon: world
    points, m) grown by ``radius`` (m); ``front`` for a chain segment: its right-hand normal."""

    core: tuple[Point, ...]
    radius: float
    front: Point | None = None

    def distance(self, p: Point) -> float:
        """Signed distance from p to the shape (m, negative inside)."""
        return core_distance(p, self.core) - self.radius

    def support(self, n: Point) -> float:
        """max over the shape of n . q (m): how far it reaches along the unit n."""
        return max(n[0] * q[0] + n[1] * q[1] for q in self.core) + self.radius


def segment_distance(p: Point, a: Point, b: Point) -> float:
    """|p - the nearest point of the segment a b| (m), by projection onto it."""
    e_x, e_y = b[0] - a[0], b[1] - a[1]
    w_x, w_y = p[0] - a[0], p[1] - a[1]
    ee = e_x * e_x + e_y * e_y
    lam = 0.0 if ee == 0.0 else min(1.0, max(0.0, (w_x * e_x + w_y * e_y) / ee))
    return math.hypot(w_x - lam * e_x, w_y - lam * e_y)


def core_distance(p: Point, core: tuple[Point, ...]) -> float:
    """Signed distance from p to a point, a segment or a filled convex polygon (m)."""
    if len(core) == 1:
        return math.hypot(p[0] - core[0][0], p[1] - core[0][1])
    if len(core) == 2:
        return segment_distance(p, core[0], core[1])
    edges = list(zip(core, core[1:] + core[:1], strict=True))
    nearest = min(segment_distance(p, a, b) for a, b in edges)
    inside = all((b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0]) >= 0.0 for a, b in edges)
    return -nearest if inside else nearest


def turn(v: Point, angle: float) -> Point:
    c, s = math.cos(angle), math.sin(angle)
    return (c * v[0] - s * v[1], s * v[0] + c * v[1])


def place(centre: Point, angle: float, local: list[Point]) -> tuple[Point, ...]:
    """Body-frame points in the world: centre + R(angle) v."""
    return tuple((centre[0] + turn(v, angle)[0], centre[1] + turn(v, angle)[1]) for v in local)


def centroid(vertices: list[Point]) -> Point:
    """The area centroid of a counter-clockwise polygon (shoelace)."""
    area, c_x, c_y = 0.0, 0.0, 0.0
    for (x0, y0), (x1, y1) in zip(vertices, vertices[1:] + vertices[:1], strict=True):
        cross = x0 * y1 - x1 * y0
        area += cross / 2.0
        c_x, c_y = c_x + (x0 + x1) * cross, c_y + (y0 + y1) * cross
    return (c_x / (6.0 * area), c_y / (6.0 * area))


@st.composite
def placed_shapes(draw, kind: str) -> tuple[list[Shape], tuple[str, tuple, dict]]:
    """A shape of ``kind`` at a random pose: as Shapes (a chain: one per segment) and as the World
    method, arguments and keywords that add it. Sometimes whole centres, angle 0 and sizes of
    a few bits: vertices exact, so rays meet them exactly."""
    exact = draw(st.booleans())
    if exact:
        centre = tuple(float(c) for c in draw(st.tuples(st.integers(-4, 4), st.integers(-4, 4))))
        angle, size, radius = 0.0, draw(st.sampled_from([0.25, 0.5, 1.0, 1.5])), draw(st.sampled_from([0.125, 0.5]))
    else:
        centre, angle, size, radius = (
            draw(vectors(-5.0, 5.0)),
            draw(reals(-math.pi, math.pi)),
            draw(reals(0.1, 1.5)),
            draw(reals(0.05, 1.0)),
        )
    if kind == "circle":
        return [Shape((centre,), radius)], ("add_circle", (centre,), {"radius": radius})
    if kind == "box":
        h = (size, size / 2.0 if exact else draw(reals(0.1, 1.5)))
        corners = [(-h[0], -h[1]), (h[0], -h[1]), (h[0], h[1]), (-h[0], h[1])]
        return [Shape(place(centre, angle, corners), 0.0)], ("add_box", (centre,), {"half_extents": h, "angle": angle})
    if kind == "polygon":
        vertices = draw(ellipse_polygons())
        c = centroid(vertices)  # add_polygon puts the centroid at the position
        local = [(v[0] - c[0], v[1] - c[1]) for v in vertices]
        return [Shape(place(centre, angle, local), 0.0)], (
            "add_polygon",
            (centre,),
            {"vertices": vertices, "angle": angle},
        )
    if kind == "capsule":
        core = place(centre, angle, [(-size, 0.0), (size, 0.0)])
        return [Shape(core, radius)], (
            "add_capsule",
            (centre,),
            {"half_length": size, "radius": radius, "angle": angle},
        )
    if kind in ("segment", "rounded segment"):
        r = radius if kind == "rounded segment" else 0.0
        a, b = place(centre, angle, [(-size, 0.0), (size, 0.0)])
        return [Shape((a, b), r)], ("add_segment", (a, b), {"radius": r})
    if exact:  # two steps of a grid, never back
        steps = draw(st.lists(st.sampled_from([(2.0, 0.0), (0.0, 2.0), (2.0, -2.0)]), min_size=2, max_size=2))
        steps = [(size * x, size * y) for x, y in steps]
    else:
        steps = [turn((2.0 * size, 0.0), angle + bend) for bend in draw(st.tuples(reals(-2.5, 2.5), reals(-2.5, 2.5)))]
    points = [centre]
    for step in steps:
        points.append((points[-1][0] + step[0], points[-1][1] + step[1]))
    shapes = []
    for a, b in zip(points, points[1:], strict=False):
        length = math.hypot(b[0] - a[0], b[1] - a[1])
        shapes.append(Shape((a, b), 0.0, ((b[1] - a[1]) / length, -(b[0] - a[0]) / length)))
    return shapes, ("add_chain", (points,), {})


# -- the rays ------------------------------------------------------------------------------------


def features(shape: Shape) -> tuple[list[Point], list[tuple[Point, Point]], list[Point]]:
    """Points of the surface where features meet (vertices, a rounded edge's ends), its edges
    (a point on the edge's line and the edge's direction) and points inside or on the core."""
    core, r = shape.core, shape.radius
    if len(core) == 1:
        c = core[0]
        rims = [(c[0] + r * math.cos(k), c[1] + r * math.sin(k)) for k in (0.0, 1.0, 2.5, 4.0)]
        tangents = [(p, (-(p[1] - c[1]), p[0] - c[0])) for p in rims]
        return rims, tangents, [c, (c[0] + 0.5 * r, c[1])]
    ring = core + core[:1] if len(core) > 2 else core
    vertices, edges = [], []
    for a, b in zip(ring, ring[1:], strict=False):
        e = (b[0] - a[0], b[1] - a[1])
        length = math.hypot(*e)
        n = (e[1] / length, -e[0] / length)  # the right-hand normal: outward, counter-clockwise
        for side in (1.0, -1.0) if len(core) == 2 else (1.0,):
            off = (side * r * n[0], side * r * n[1])
            p, q = (a[0] + off[0], a[1] + off[1]), (b[0] + off[0], b[1] + off[1])
            vertices += [p, q]
            edges.append((p, e))
    mean = (sum(p[0] for p in core) / len(core), sum(p[1] for p in core) / len(core))
    return vertices, edges, [mean, core[0]]


@st.composite
def rays(draw, shapes: list[Shape]) -> tuple[Point, Point]:
    """A ray (start, end) for ``shapes``: at random, across an edge, through a vertex, along an
    edge, from inside, from the surface, or long (a start and an end 1e3 to 1e8 m from a point
    near the shape)."""
    vertices, edges, inner = [], [], []
    for shape in shapes:
        v, e, i = features(shape)
        vertices, edges, inner = vertices + v, edges + e, inner + i
    mode = draw(st.sampled_from(["random", "across", "vertex", "edge", "inside", "surface", "long"]))
    event(f"ray: {mode}")
    if mode == "random":
        return draw(vectors(-8.0, 8.0)), draw(vectors(-8.0, 8.0))
    heading = draw(st.one_of(st.sampled_from([0.0, 0.5 * math.pi, math.pi, -0.5 * math.pi]), reals(-4.0, 4.0)))
    u = (math.cos(heading), math.sin(heading))
    before = draw(reals(0.0, 8.0))
    after = draw(reals(0.0, 8.0))
    if mode == "across":
        p, e = draw(st.sampled_from(edges))
        lam = draw(reals(0.0, 1.0))
        through = (p[0] + lam * e[0], p[1] + lam * e[1])
    elif mode == "vertex":
        through = draw(st.sampled_from(vertices))
    elif mode == "edge":
        p, e = draw(st.sampled_from(edges))
        lam = draw(st.one_of(st.sampled_from([0.0, 1.0]), reals(0.0, 1.0)))
        through = (p[0] + lam * e[0], p[1] + lam * e[1])
        sign = draw(st.sampled_from([1.0, -1.0])) / math.hypot(*e)
        u = (sign * e[0], sign * e[1])
    elif mode == "inside":
        through, before = draw(st.sampled_from(inner)), 0.0
    elif mode == "surface":
        p, e = draw(st.sampled_from(edges))
        lam = draw(st.one_of(st.sampled_from([0.0, 1.0]), reals(0.0, 1.0)))
        through, before = (p[0] + lam * e[0], p[1] + lam * e[1]), 0.0
    else:
        near = draw(st.sampled_from(vertices + inner))
        offset = draw(vectors(-1.0, 1.0))
        through = (near[0] + offset[0], near[1] + offset[1])
        before, after = 10.0 ** draw(reals(3.0, 8.0)), 10.0 ** draw(reals(3.0, 8.0))
    start = (through[0] - before * u[0], through[1] - before * u[1])
    return start, (through[0] + after * u[0], through[1] + after * u[1])


# -- the brute force -----------------------------------------------------------------------------


def lowest(g, lo: float, hi: float) -> tuple[float, float]:
    """(s, g(s)) at the minimum of the convex g on [lo, hi], by golden section."""
    k = (math.sqrt(5.0) - 1.0) / 2.0
    a, b = lo, hi
    for _ in range(200):
        c, d = b - k * (b - a), a + k * (b - a)
        if not a < c < d < b:
            break
        if g(c) <= g(d):
            b = d
        else:
            a = c
    return min(((s, g(s)) for s in (lo, a, b, hi)), key=lambda sg: sg[1])


def first_zero(g, lo: float, hi: float) -> float:
    """The s in [lo, hi] where g, > 0 at lo and < 0 at hi, crosses 0, by bisection."""
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if not lo < mid < hi:
            break
        lo, hi = (mid, hi) if g(mid) > 0.0 else (lo, mid)
    return 0.5 * (lo + hi)


def check_hit(hit, shape: Shape, start: Point, end: Point, tol: float) -> float:
    """The properties of a valid hit; returns its distance along the ray (m)."""
    d = (end[0] - start[0], end[1] - start[1])
    length = math.hypot(*d)
    u = (d[0] / length, d[1] / length)
    t = hit.fraction
    assert 0.0 <= t <= 1.0
    p = (float(hit.point[0]), float(hit.point[1]))
    assert math.hypot(p[0] - (start[0] + t * d[0]), p[1] - (start[1] + t * d[1])) <= tol  # the fraction's point
    assert abs(shape.distance(p)) <= tol, "the hit is off the surface"
    s_hit = t * length

    def g(s: float) -> float:
        return shape.distance((start[0] + s * u[0], start[1] + s * u[1]))

    assert lowest(g, 0.0, s_hit)[1] >= -tol, "the ray was inside before its hit"
    n = (float(hit.normal[0]), float(hit.normal[1]))
    assert math.hypot(*n) == pytest.approx(1.0, abs=1e-12)
    assert shape.support(n) - (n[0] * p[0] + n[1] * p[1]) <= tol, "the shape reaches beyond the tangent line"
    facing = tol / shape.radius if shape.radius > 0.0 else tol  # an arc's normal is its point over r
    assert n[0] * u[0] + n[1] * u[1] <= facing, "the normal faces along the ray"
    return s_hit


def check_body(hit, shape: Shape, start: Point, end: Point) -> None:
    """One body's answer (its RayHit or None) against the brute force on ``shape``."""
    scale = max([1.0, *map(abs, start + end)] + [abs(c) + shape.radius for q in shape.core for c in q])
    tol = 1024 * EPS * scale
    d = (end[0] - start[0], end[1] - start[1])
    length = math.hypot(*d)
    if length == 0.0:
        event("body: the ray has length 0")
        assert hit is None, "a ray of length 0 hit"
        return
    u = (d[0] / length, d[1] / length)
    if (
        shape.front is not None
        and shape.front[0] * (start[0] - shape.core[0][0]) + shape.front[1] * (start[1] - shape.core[0][1]) < -tol
    ):  # a chain segment from behind: which side a ray hits is not promised, only a hit's validity
        event("body: a chain segment from behind")
        if hit is not None:
            check_hit(hit, shape, start, end, tol)
        return

    def g(s: float) -> float:
        return shape.distance((start[0] + s * u[0], start[1] + s * u[1]))

    g_0 = g(0.0)
    if g_0 < -tol:
        event("body: the ray starts inside")
        assert hit is None, "a ray starting inside hit its shape"
        return
    if g_0 <= tol:  # on the surface, to float64: no hit, or a valid one at the start
        event(f"body: the ray starts on the surface, {'hit' if hit else 'missed'}")
        if hit is not None:
            check_hit(hit, shape, start, end, tol)
        return
    s_min, g_min = lowest(g, 0.0, length)
    crossing = segment_crossing(shape, start, u, length, tol)
    if g_min > tol:
        event("body: the ray passes by")
        assert hit is None, f"hit, but the ray passes {g_min:.3g} m from the shape"
    elif g_min < -tol or crossing is not None:  # it gets in, or through a bare segment, clearly
        event("body: the ray gets in")
        assert hit is not None, "missed"
        s_hit = check_hit(hit, shape, start, end, tol)
        if crossing is not None:
            s_ref, slope = crossing
        else:
            s_ref = first_zero(g, 0.0, s_min)
            slope = max(g_0 / s_ref, -g_min / (s_min - s_ref))  # |g'| at the entry is at least either secant's
        assert abs(s_hit - s_ref) <= 4.0 * tol / slope + tol, (s_hit, s_ref)
        if length > 1e3 and slope > 1e-2:  # a long ray: the entry within 1 mm of the true one
            assert abs(s_hit - s_ref) <= 1e-3
    else:  # it grazes the shape: a hit must still be valid
        event(f"body: the ray grazes it, {'hit' if hit else 'missed'}")
        if hit is not None:
            check_hit(hit, shape, start, end, tol)


def segment_crossing(shape: Shape, start: Point, u: Point, length: float, tol: float) -> tuple[float, float] | None:
    """For a bare segment (no inside for g to go below 0): (s, slope) where the ray crosses it
    clear of its ends, by bisection on the side of its line, slope = |n . u|; None otherwise."""
    if len(shape.core) != 2 or shape.radius > 0.0:
        return None
    (a_x, a_y), (b_x, b_y) = shape.core
    e_length = math.hypot(b_x - a_x, b_y - a_y)
    n = ((b_y - a_y) / e_length, -(b_x - a_x) / e_length)

    def side(s: float) -> float:
        return n[0] * (start[0] + s * u[0] - a_x) + n[1] * (start[1] + s * u[1] - a_y)

    side_0, side_end = side(0.0), side(length)
    if side_0 * side_end >= 0.0 or min(abs(side_0), abs(side_end)) <= tol:
        return None
    s = first_zero(lambda s: side(s) if side_0 > 0.0 else -side(s), 0.0, length)
    slope = abs(side_0 - side_end) / length
    along = ((start[0] + s * u[0] - a_x) * (b_x - a_x) + (start[1] + s * u[1] - a_y) * (b_y - a_y)) / e_length
    if min(along, e_length - along) <= 4.0 * tol / slope + tol:  # at an end, to float64
        return None
    return s, slope


@pytest.mark.xdist_group("ray_casts")  # one worker: the kinds share one compiled ray cast
@pytest.mark.parametrize("kind", KINDS)
@given(data=st.data())
def test_ray_cast_is_the_brute_forces_entry(kind: str, data: st.DataObject) -> None:
    """Each body the ray meets (a chain: each segment) answers as the brute force on its shape."""
    shapes, (method, args, keywords) = data.draw(placed_shapes(kind), label="shapes")
    start, end = data.draw(rays(shapes), label="ray")
    w = phys2d.World()
    added = getattr(w, method)(*args, **keywords)
    bodies = list(added) if method == "add_chain" else [added]
    hits = {h.body: h for h in w.ray_cast(start, end)}
    assert set(hits) <= set(bodies)
    for body, shape in zip(bodies, shapes, strict=True):
        check_body(hits.get(body), shape, start, end)
