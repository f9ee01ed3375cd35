"""Queries: a ray, a point or a box against the shapes, one function per shape kind.

A ray is the segment p(t) = start + t d from ``start`` to ``end``, d = end - start, and a hit
is where it first enters a shape: its fraction t in [0, 1], the point p(t) and the unit
normal n of the surface there, pointing out of the shape. As in Box2D v3, a ray that starts
inside a shape (or on its surface) does not hit it: the query says where a ray from outside
comes in, and ``contains`` tells whether a point is inside.

Each shape is met in its body's frame: the ray (or point) is taken into the frame, so the
per-shape functions see the local geometry (``local_v``) and never a world copy of it. The
kinds:

    circle           ray_circle, circle_contains               |p - c| <= r
    rounded polygon  ray_polygon, polygon_contains             distance(p, polygon) <= radius

A polygon is a rounded polygon of radius 0 (phys2d's polygons and boxes); one of one vertex
and a radius is a circle, one of two vertices a capsule or, with radius 0, a segment: a new
kind of that family needs only its branch in ``ray_shape`` and ``shape_contains``.

The ray kernels measure in metres along the ray's unit direction, from the shape's own
frame: a circle's entry is found from the ray's closest approach to its centre, not from a
quadratic's coefficients (whose cancellation loses a 1e8 m ray's hit by metres), and a polygon
or a bare segment is clipped by its half-planes (Cyrus-Beck), a ray parallel to one being
inside it for good or never. So a ray through a vertex, along an edge or from a shape's
surface meets ties, not divisions by 0, and a long ray's hit is as close to the surface as
float64 places the ray's own points.

``ray_cast_bodies``, ``bodies_containing`` and ``tight_aabbs`` run one query over every body
of a world, for ``World.ray_cast``, ``query_point`` and ``query_aabb``. ``geometry`` is the
tuple (x, theta, kind, radius, vstart, vcount, local_v) of the world's arrays
(``bodies.BodyArrays``), read as they are now: the broadphase's boxes are from the start
of the last step and grown by margins, so they are not used.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..jit import njit
from ..shapes import CIRCLE

if TYPE_CHECKING:
    from ..bodies import Body

MISS = math.inf  # the fraction of no hit


# -- the ray ----------------------------------------------------------------------------------
@njit(cache=True, inline="always")
def norm(x, y):
    """|(x, y)|: sqrt(x^2 + y^2), rescaled when the squares would overflow or underflow (not
    math.hypot, whose last bit differs between numba and Python)."""
    big = max(abs(x), abs(y))
    if 1e-145 < big < 1e145:
        return math.sqrt(x * x + y * y)
    if big == 0.0 or big == math.inf:
        return big
    x, y = x / big, y / big
    return big * math.sqrt(x * x + y * y)


@njit(cache=True, inline="always")
def ray_direction(d):
    """The ray's unit direction u and length (m): d = length u; (0, 0, 0) for a ray of length 0.
    The kernels measure along u in metres, so a long ray's numbers stay those of its geometry."""
    length = norm(d[0], d[1])
    if length == 0.0:
        return 0.0, 0.0, 0.0
    return d[0] / length, d[1] / length, length


# -- a circle ---------------------------------------------------------------------------------
@njit(cache=True)
def circle_entry(f_x, f_y, u_x, u_y, radius):
    """Where the line f + s u (f: its start from the centre, u unit) first meets the circle of
    ``radius`` about the centre, when it starts outside: (s m, n_x, n_y), s = MISS when it heads
    away or passes by.

    The line passes the centre closest at s_c = -f.u, at h = |f x u| from it, and enters at
    s_c - sqrt((r - h)(r + h)): no quadratic's coefficients, whose cancellation costs a long
    ray its digits. The point, from the centre, is the closest point minus the half chord along
    u, each of size <= r: no cancellation there either."""
    closest = -(f_x * u_x + f_y * u_y)  # along the line, to its point nearest the centre
    across = f_y * u_x - f_x * u_y  # that point from the centre, along perp(u) = (-u_y, u_x)
    h = abs(across)
    if closest <= 0.0 or h > radius:  # heads away, or passes by
        return MISS, 0.0, 0.0
    half_chord = math.sqrt((radius - h) * (radius + h))
    s = closest - half_chord
    if s < 0.0:  # the start is on the circle, to rounding: it starts on it
        return MISS, 0.0, 0.0
    p_x, p_y = -across * u_y - half_chord * u_x, across * u_x - half_chord * u_y  # the hit, from the centre
    length = norm(p_x, p_y)
    if length == 0.0:  # a circle of radius 0 (a polygon's vertex), met dead on: face the ray
        return s, -u_x, -u_y
    return s, p_x / length, p_y / length


@njit(cache=True)
def ray_circle(start, d, centre, radius):
    """Where the ray start + t d first enters the circle (centre, radius): (t, n_x, n_y), t = MISS
    when it does not within t in [0, 1] or starts inside or on it (``circle_entry``, met from
    the centre along the unit direction)."""
    u_x, u_y, length = ray_direction(d)
    if length == 0.0 or circle_contains(start, centre, radius):
        return MISS, 0.0, 0.0
    s, n_x, n_y = circle_entry(start[0] - centre[0], start[1] - centre[1], u_x, u_y, radius)
    if s > length:
        return MISS, 0.0, 0.0
    return s / length, n_x, n_y


@njit(cache=True)
def circle_contains(point, centre, radius):
    """True when ``point`` is in the circle or on it: |p - c| <= r."""
    f_x, f_y = point[0] - centre[0], point[1] - centre[1]
    return abs(f_x) <= radius and abs(f_y) <= radius and f_x * f_x + f_y * f_y <= radius * radius  # no square overflows


# -- a rounded polygon ------------------------------------------------------------------------
@njit(cache=True, inline="always")
def edge_normal(vertices, i):
    """The outward unit normal of edge i = (v_i, v_i+1) of counter-clockwise ``vertices``, and
    the edge's length (m)."""
    n = vertices.shape[0]
    j = i + 1 if i + 1 < n else 0
    e_x, e_y = vertices[j, 0] - vertices[i, 0], vertices[j, 1] - vertices[i, 1]
    length = math.sqrt(e_x * e_x + e_y * e_y)
    return e_y / length, -e_x / length, length


@njit(cache=True)
def polygon_separation(vertices, point):
    """The largest n_i . (p - v_i) over the edges: <= 0 inside the polygon (radius 0), and a
    lower bound of the distance from p to it outside."""
    most = -math.inf
    for i in range(vertices.shape[0]):
        n_x, n_y, _ = edge_normal(vertices, i)
        most = max(most, n_x * (point[0] - vertices[i, 0]) + n_y * (point[1] - vertices[i, 1]))
    return most


@njit(cache=True)
def polygon_distance(vertices, point):
    """The distance (m) from ``point`` outside the polygon to it: the nearest of its edges
    (each a segment; one vertex: that point)."""
    n = vertices.shape[0]
    nearest = math.inf
    for i in range(n):
        j = i + 1 if i + 1 < n else 0
        e_x, e_y = vertices[j, 0] - vertices[i, 0], vertices[j, 1] - vertices[i, 1]
        w_x, w_y = point[0] - vertices[i, 0], point[1] - vertices[i, 1]
        ee = e_x * e_x + e_y * e_y
        s = 0.0 if ee == 0.0 else min(1.0, max(0.0, (w_x * e_x + w_y * e_y) / ee))  # the nearest point's place
        q_x, q_y = w_x - s * e_x, w_y - s * e_y
        nearest = min(nearest, math.sqrt(q_x * q_x + q_y * q_y))
    return nearest


@njit(cache=True)
def polygon_contains(vertices, radius, point):
    """True when ``point`` is in the polygon of ``vertices`` (counter-clockwise, m) grown by
    ``radius`` (m), or on it: n_i . (p - v_i) <= 0 for every edge when radius = 0, else the
    distance from p to the polygon <= radius."""
    if vertices.shape[0] >= 3:
        separation = polygon_separation(vertices, point)
        if separation <= 0.0:
            return True
        if separation > radius:  # farther than radius from an edge's line, so from the polygon
            return False
    return polygon_distance(vertices, point) <= radius


@njit(cache=True)
def ray_polygon(start, d, vertices, radius):
    """Where the ray start + t d first enters the convex polygon of ``vertices`` (counter-clockwise,
    m) grown by ``radius`` (m): (t, n_x, n_y), t = MISS when it does not within t in [0, 1] or
    starts inside or on it. Radius 0: ``ray_sharp_polygon``, or ``ray_segment`` for two
    vertices; else ``ray_rounded_polygon``."""
    if radius == 0.0 and vertices.shape[0] >= 3:
        return ray_sharp_polygon(start, d, vertices)
    if radius == 0.0 and vertices.shape[0] == 2:
        return ray_segment(start, d, vertices[0], vertices[1])
    return ray_rounded_polygon(start, d, vertices, radius)


@njit(cache=True, inline="always")
def clip(m_x, m_y, gap, u_x, u_y, lower, upper, entered, k):
    """Half-plane k, m . p <= m . anchor with gap = m . (anchor - start) (> 0: the start is inside
    it), against the ray start + s u: the span [lower, upper] (m along the ray) inside every
    half-plane so far narrowed to this one's, and ``entered`` the half-plane of its lower end
    when this one raises it. A ray parallel to it (m . u = 0) is inside it for good or never
    (then upper = -inf): no division by 0."""
    rate = m_x * u_x + m_y * u_y
    if rate == 0.0:
        if gap < 0.0:
            upper = -math.inf
    elif rate < 0.0:  # heads in: inside past gap / rate
        s = gap / rate
        if s > lower:
            lower, entered = s, k
    else:  # heads out: inside before gap / rate
        upper = min(upper, gap / rate)
    return lower, upper, entered


@njit(cache=True)
def ray_sharp_polygon(start, d, vertices):
    """The ray against a polygon of radius 0 by clipping (Cyrus-Beck): the polygon is the meet of
    the half-planes n_i . (p - v_i) <= 0, and the ray enters at the largest distance it heads
    into one of them, if it leaves none first; a ray starting inside or on the polygon
    heads into none past 0. Through a vertex the two edges tie; along an edge the ray is
    inside that edge's half-plane throughout (touching counts, as in ``polygon_contains``)."""
    u_x, u_y, length = ray_direction(d)
    if length == 0.0:
        return MISS, 0.0, 0.0
    lower, upper, entered = 0.0, length, -1
    for i in range(vertices.shape[0]):
        n_x, n_y, _ = edge_normal(vertices, i)
        gap = n_x * (vertices[i, 0] - start[0]) + n_y * (vertices[i, 1] - start[1])
        lower, upper, entered = clip(n_x, n_y, gap, u_x, u_y, lower, upper, entered, i)
        if upper < lower:
            return MISS, 0.0, 0.0
    if entered < 0:  # it starts inside or on the polygon
        return MISS, 0.0, 0.0
    n_x, n_y, _ = edge_normal(vertices, entered)
    return lower / length, n_x, n_y


@njit(cache=True)
def ray_segment(start, d, a, b):
    """The ray against the segment a b (radius 0, m) by clipping: the segment is the meet of four
    half-planes, its two faces' (normals +-n across it) and its two ends' (normals +-e along
    it, out of each end), so a ray through an end, or along the segment's own line, enters
    by an end's half-plane with that end's normal; crossing it, by the face towards it."""
    u_x, u_y, length = ray_direction(d)
    e_x, e_y = b[0] - a[0], b[1] - a[1]
    e_length = norm(e_x, e_y)
    if length == 0.0 or e_length == 0.0:
        return MISS, 0.0, 0.0
    e_x, e_y = e_x / e_length, e_y / e_length
    w_x, w_y = a[0] - start[0], a[1] - start[1]  # a, from the start
    across = e_y * w_x - e_x * w_y  # n . (a - start), n = (e_y, -e_x)
    lower, upper, entered = 0.0, length, -1
    lower, upper, entered = clip(e_y, -e_x, across, u_x, u_y, lower, upper, entered, 0)
    lower, upper, entered = clip(-e_y, e_x, -across, u_x, u_y, lower, upper, entered, 1)
    lower, upper, entered = clip(-e_x, -e_y, -(e_x * w_x + e_y * w_y), u_x, u_y, lower, upper, entered, 2)
    lower, upper, entered = clip(
        e_x, e_y, e_x * (b[0] - start[0]) + e_y * (b[1] - start[1]), u_x, u_y, lower, upper, entered, 3
    )
    if upper < lower or entered < 0:  # misses, or starts on the segment
        return MISS, 0.0, 0.0
    normals = ((e_y, -e_x), (-e_y, e_x), (-e_x, -e_y), (e_x, e_y))
    n_x, n_y = normals[entered]
    return lower / length, n_x, n_y


@njit(cache=True)
def cone_normal(vertices, i, m_x, m_y):
    """The unit m from vertex i, or the nearer of the normals of the edges meeting there when m
    leaves their arc (counter-clockwise from edge i-1's to edge i's; half a turn at a capsule's
    end): past the arc a point of v_i's circle lies in an edge's band, where the surface and its
    normal are that edge's (a ray grazing a flat side meets a circle there, its normal off by
    sqrt(eps) without this)."""
    before_x, before_y, _ = edge_normal(vertices, i - 1 if i > 0 else vertices.shape[0] - 1)
    after_x, after_y, _ = edge_normal(vertices, i)
    if before_x * m_y - before_y * m_x >= 0.0 and m_x * after_y - m_y * after_x >= 0.0:
        return m_x, m_y
    if before_x * m_x + before_y * m_y >= after_x * m_x + after_y * m_y:  # the nearer
        return before_x, before_y
    return after_x, after_y


@njit(cache=True)
def ray_rounded_polygon(start, d, vertices, radius):
    """The ray against a polygon grown by r >= 0: its surface is each edge pushed out by r along
    its normal, joined by arcs of radius r about the vertices, so from outside the entry is
    the first of the ray's crossings of those edges (heading in) and of the vertices'
    circles (``circle_entry``, its normal kept to the vertex's arc: ``cone_normal``), all
    measured along the unit direction (m)."""
    u_x, u_y, length = ray_direction(d)
    if length == 0.0 or polygon_contains(vertices, radius, start):
        return MISS, 0.0, 0.0
    best, best_x, best_y, vertex = MISS, 0.0, 0.0, -1
    n = vertices.shape[0]
    for i in range(n):
        w_x, w_y = start[0] - vertices[i, 0], start[1] - vertices[i, 1]
        s, n_x, n_y = circle_entry(w_x, w_y, u_x, u_y, radius)  # the arc about v_i
        if s < best:
            best, best_x, best_y, vertex = s, n_x, n_y, i
        if n < 2:
            continue
        n_x, n_y, e_length = edge_normal(vertices, i)
        rate = n_x * u_x + n_y * u_y
        if rate >= 0.0:  # it crosses this edge's side heading out, if at all
            continue
        s = (radius - (n_x * w_x + n_y * w_y)) / rate  # n . (p(s) - v_i) = r
        if not 0.0 <= s < best:
            continue
        along = (-n_y * (w_x + s * u_x) + n_x * (w_y + s * u_y)) / e_length  # along the edge, 0 at v_i
        if 0.0 <= along <= 1.0:
            best, best_x, best_y, vertex = s, n_x, n_y, -1
    if best > length:
        return MISS, 0.0, 0.0
    if vertex >= 0 and n >= 2:
        best_x, best_y = cone_normal(vertices, vertex, best_x, best_y)
    return best / length, best_x, best_y


# -- a shape of any kind, in its body's frame -------------------------------------------------
@njit(cache=True)
def to_body_frame(x, theta, b, point):
    """``point`` (world, m) in body b's frame: R(-theta_b) (p - x_b)."""
    c, s = math.cos(theta[b]), math.sin(theta[b])
    p_x, p_y = point[0] - x[b, 0], point[1] - x[b, 1]
    return np.array([c * p_x + s * p_y, -s * p_x + c * p_y])


def geometry(bodies) -> tuple:
    """The arrays the query kernels read of a world's ``BodyArrays``: (x, theta, kind, radius,
    vstart, vcount, local_v), as they are now."""
    b = bodies
    return (b.x, b.theta, b.kind, b.radius, b.vstart, b.vcount, b.local_v)


@njit(cache=True)
def ray_shape(geometry, b, start, d):
    """The ray (start, d in body b's frame) against body b's shape, by its kind: (t, n_x, n_y),
    the normal in the body's frame."""
    _, _, kind, radius, vstart, vcount, local_v = geometry
    if kind[b] == CIRCLE:
        return ray_circle(start, d, np.zeros(2), radius[b])
    return ray_polygon(start, d, local_v[vstart[b] : vstart[b] + vcount[b]], radius[b])


@njit(cache=True)
def shape_contains(geometry, b, point):
    """Whether body b's shape holds ``point`` (in its frame), by its kind."""
    _, _, kind, radius, vstart, vcount, local_v = geometry
    if kind[b] == CIRCLE:
        return circle_contains(point, np.zeros(2), radius[b])
    return polygon_contains(local_v[vstart[b] : vstart[b] + vcount[b]], radius[b], point)


@njit(cache=True)
def reach(geometry, b):
    """The farthest any point of body b's shape lies from its centre (m)."""
    _, _, kind, radius, vstart, vcount, local_v = geometry
    if kind[b] == CIRCLE:
        return radius[b]
    far = 0.0
    for k in range(vstart[b], vstart[b] + vcount[b]):
        far = max(far, local_v[k, 0] * local_v[k, 0] + local_v[k, 1] * local_v[k, 1])
    return math.sqrt(far) + radius[b]


# -- every body of a world --------------------------------------------------------------------
@njit(cache=True)
def ray_cast_bodies(geometry, start, end, fraction, normal):
    """The ray from ``start`` to ``end`` (m) against every body: fraction[b] its entry's t
    (MISS: none) and normal[b] the unit outward normal there (world frame). A body whose
    circle of ``reach`` the segment passes by is skipped without looking at its shape.
    ValueError when end - start overflows a float (no fraction of it would be finite)."""
    x, theta = geometry[0], geometry[1]
    d_x, d_y = end[0] - start[0], end[1] - start[1]
    if not (math.isfinite(d_x) and math.isfinite(d_y)):
        raise ValueError("start and end are too far apart: end - start overflows a float")
    u_x, u_y, length = ray_direction(np.array([d_x, d_y]))
    for b in range(x.shape[0]):
        fraction[b] = MISS
        if length == 0.0:  # a ray of length 0 enters nothing
            continue
        w_x, w_y = x[b, 0] - start[0], x[b, 1] - start[1]
        if not (math.isfinite(w_x) and math.isfinite(w_y)):  # farther from the start than floats reach
            continue
        s = min(length, max(0.0, w_x * u_x + w_y * u_y))  # the segment's nearest point to x_b, along it
        q_x, q_y = w_x - s * u_x, w_y - s * u_y
        r = reach(geometry, b)
        if q_x * q_x + q_y * q_y > r * r:
            continue
        c, si = math.cos(theta[b]), math.sin(theta[b])
        local_start = to_body_frame(x, theta, b, start)
        local_d = np.array([c * d_x + si * d_y, -si * d_x + c * d_y])
        t, n_x, n_y = ray_shape(geometry, b, local_start, local_d)
        if t <= 1.0:
            fraction[b] = t
            normal[b, 0], normal[b, 1] = c * n_x - si * n_y + 0.0, si * n_x + c * n_y + 0.0  # (+ 0.0: no -0.0)


@njit(cache=True)
def bodies_containing(geometry, point, inside):
    """inside[b] = whether body b's shape holds ``point`` (m), on its surface included."""
    x, theta = geometry[0], geometry[1]
    for b in range(x.shape[0]):
        inside[b] = circle_contains(point, x[b], reach(geometry, b)) and shape_contains(
            geometry, b, to_body_frame(x, theta, b, point)
        )


@njit(cache=True)
def tight_aabbs(geometry, aabb):
    """aabb[b] = (min x, min y, max x, max y) of body b's shape now (m), with no margin."""
    x, theta, kind, radius, vstart, vcount, local_v = geometry
    for b in range(x.shape[0]):
        r = radius[b]
        if kind[b] == CIRCLE:
            aabb[b, 0], aabb[b, 1], aabb[b, 2], aabb[b, 3] = x[b, 0] - r, x[b, 1] - r, x[b, 0] + r, x[b, 1] + r
            continue
        c, s = math.cos(theta[b]), math.sin(theta[b])
        lo_x, lo_y, hi_x, hi_y = math.inf, math.inf, -math.inf, -math.inf
        for k in range(vstart[b], vstart[b] + vcount[b]):
            v_x = x[b, 0] + c * local_v[k, 0] - s * local_v[k, 1]
            v_y = x[b, 1] + s * local_v[k, 0] + c * local_v[k, 1]
            lo_x, lo_y, hi_x, hi_y = min(lo_x, v_x), min(lo_y, v_y), max(hi_x, v_x), max(hi_y, v_y)
        aabb[b, 0], aabb[b, 1], aabb[b, 2], aabb[b, 3] = lo_x - r, lo_y - r, hi_x + r, hi_y + r


# -- what World.ray_cast returns --------------------------------------------------------------
@dataclass(frozen=True, repr=False)
class RayHit:
    """Where a ray first enters a body's shape: ``body``, the world ``point`` (m), the unit
    ``normal`` there (out of the shape) and ``fraction`` t in [0, 1]: point = start + t (end - start)."""

    body: Body
    point: np.ndarray  # (2,) m
    normal: np.ndarray  # (2,) unit
    fraction: float

    def __repr__(self) -> str:
        (p_x, p_y), (n_x, n_y) = self.point, self.normal
        return (
            f"<RayHit body {self.body.index if self.body.alive else 'removed'}: fraction={self.fraction:.4g}, "
            f"point=({p_x:.4g}, {p_y:.4g}) m, normal=({n_x:.3g}, {n_y:.3g})>"
        )
