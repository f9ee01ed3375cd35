"""Narrowphase: contact manifolds of up to two points, each with a feature id.

For every candidate pair (a, b) with a < b the narrowphase finds where the shapes
touch. A manifold point carries

    point       the contact point p (m), midway between the two surfaces
    normal      n, unit, from a to b
    separation  C = (x_b + r_b - x_a - r_a) . n (m), negative when overlapping
    feature     which edges or vertices made it (below)

Feature ids are what contact caching keys on: they stay the same from tick to
tick while the same features touch, whatever the bodies' exact positions.

Polygon-polygon (SAT plus clipping of the incident edge, as in Box2D-Lite):
    bit 15     flip: 1 when the reference face belongs to b
    bits 8-13  the reference edge
    bits 1-6   the incident edge (on the other polygon)
    bit 0      which end of the reference edge the point lies towards: 0 for its
               first vertex, 1 for its second (the same whether or not clipping
               moved the point, so a sliding box keeps its ids)
Circle-polygon: bit 7 is 0 for the polygon's edge region (bits 0-6: edge),
    1 for a vertex region (bits 0-6: vertex). Circle-circle: 0.

Capsules, segments and chain segments are rounded two-vertex polygons (``rounded``):
against a polygon or one another they make polygon-pair ids (a capsule's edge 0 runs
from its vertex 0 to 1, edge 1 back), and against a circle circle-polygon ids. A single
point from the closest features of two cores sets bit 7 in a polygon-pair id: bits 8-13
a's vertex (bit 14: a's edge instead), bits 1-6 b's vertex (bit 0: b's edge).

Points whose surfaces are still up to a small margin apart (separation > 0) are
kept as speculative contacts: their rows let the gap close within the step and
no further, so a resting box that tilts by a hair keeps both corners supported.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..jit import njit
from ..shapes import CHAIN, CIRCLE, POLYGON
from .rounded import (
    A_EDGE_BIT,
    B_EDGE_BIT,
    CLOSEST_BIT,
    chain_geometry,
    collide_capsules,
    collide_chain,
    collide_circle_capsule,
    collide_circle_chain,
    collide_rounded,
    swapped,
)
from .sat import (
    EDGE_MASK,
    END_BIT,
    FLIP_BIT,
    INCIDENT_SHIFT,
    REFERENCE_FACE_TOL,
    REFERENCE_SHIFT,
    VERTEX_BIT,
    clip_incident,
    incident_edge,
    max_separation,
)

PAIR_KINDS = ("polygons", "circle-polygon", "circles")


def pair_kind(kind_a: int, kind_b: int) -> str:
    """Which ``describe_feature`` pair two shape kinds (``shapes.CIRCLE``, ...) make: "circles",
    "circle-polygon" (a circle and anything else) or "polygons" (boxes, polygons, capsules,
    segments and chain segments: all polygons, some rounded)."""
    circles = (kind_a == CIRCLE) + (kind_b == CIRCLE)
    return PAIR_KINDS[circles]


class Feature(NamedTuple):
    """What a feature id names (``describe_feature``); fields that do not apply are None.

    pair            "polygons", "circle-polygon" or "circles"
    reference       polygons: the body ("a" or "b") whose edge is the reference face
    reference_edge  polygons: that edge's index (edge e runs from vertex e to vertex e + 1)
    incident_edge   polygons: the other polygon's edge that was clipped against it
    end             polygons: 0 if the point lies towards the reference edge's first vertex, 1 its second
    edge            circle-polygon: the polygon edge whose region holds the circle's centre
    vertex          circle-polygon: the polygon vertex whose region holds it
    closest_a       polygons, one point from the closest features of two rounded cores:
                    a's feature, ("vertex", k) or ("edge", k)
    closest_b       ... and b's
    """

    pair: str
    reference: str | None = None
    reference_edge: int | None = None
    incident_edge: int | None = None
    end: int | None = None
    edge: int | None = None
    vertex: int | None = None
    closest_a: tuple[str, int] | None = None
    closest_b: tuple[str, int] | None = None

    def __repr__(self) -> str:
        if self.closest_a is not None and self.closest_b is not None:
            (kind_a, index_a), (kind_b, index_b) = self.closest_a, self.closest_b
            return f"Feature(closest features: {kind_a} {index_a} of a, {kind_b} {index_b} of b)"
        if self.pair == "polygons":
            other = "a" if self.reference == "b" else "b"
            return (
                f"Feature(reference edge {self.reference_edge} of {self.reference}, incident edge "
                f"{self.incident_edge} of {other}, end {self.end})"
            )
        if self.pair == "circle-polygon":
            where = f"edge {self.edge}" if self.vertex is None else f"vertex {self.vertex}"
            return f"Feature(circle in the region of polygon {where})"
        return "Feature(circle against circle)"


def describe_feature(feature: int, pair: str = "polygons") -> Feature:
    """The edges and vertices a contact's feature id names (encoding in the module docstring).

    ``pair`` says which shapes made the contact ("polygons", "circle-polygon" or
    "circles"): the same number means different things for each.
    """
    if isinstance(feature, (bool, np.bool_)) or not isinstance(feature, (int, np.integer)):
        raise TypeError(f"feature must be an integer feature id, got {type(feature).__name__}")
    feature = int(feature)
    if pair not in PAIR_KINDS:
        raise ValueError(f"pair must be one of {', '.join(PAIR_KINDS)}, got {pair!r}")
    if pair == "polygons" and 0 <= feature < FLIP_BIT and feature & CLOSEST_BIT:
        a_index, b_index = feature >> REFERENCE_SHIFT & EDGE_MASK, feature >> INCIDENT_SHIFT & EDGE_MASK
        return Feature(
            pair,
            closest_a=("edge" if feature & A_EDGE_BIT else "vertex", a_index),
            closest_b=("edge" if feature & B_EDGE_BIT else "vertex", b_index),
        )
    if pair == "polygons":
        if not 0 <= feature < 2 * FLIP_BIT or feature & (VERTEX_BIT | 1 << 14):
            raise ValueError(f"feature {feature:#x} is not a polygon-polygon feature id")
        return Feature(
            pair,
            reference="b" if feature & FLIP_BIT else "a",
            reference_edge=feature >> REFERENCE_SHIFT & EDGE_MASK,
            incident_edge=feature >> INCIDENT_SHIFT & EDGE_MASK,
            end=feature & END_BIT,
        )
    if pair == "circle-polygon":
        if not 0 <= feature < 2 * VERTEX_BIT:
            raise ValueError(f"feature {feature:#x} is not a circle-polygon feature id")
        index = feature & ~VERTEX_BIT
        return Feature(pair, vertex=index) if feature & VERTEX_BIT else Feature(pair, edge=index)
    if feature != 0:
        raise ValueError(f"feature {feature:#x} is not a circle-circle feature id (always 0)")
    return Feature(pair)


@njit(cache=True)
def collide_polygons(world_v, world_n, sa, na, sb, nb, margin):
    """Polygon-polygon manifold of polygons A (vertices sa..sa+na) and B.

    Returns (count, nx, ny, p1x, p1y, sep1, feature1, p2x, p2y, sep2, feature2) with
    the normal from A to B and count in 0..2 (the first ``count`` points are valid).
    """
    none = (0, 0.0, 0.0, 0.0, 0.0, 0.0, 0, 0.0, 0.0, 0.0, 0)
    edge_a, sep_a = max_separation(world_v, world_n, sa, na, sb, nb, margin)
    if sep_a > margin:
        return none
    edge_b, sep_b = max_separation(world_v, world_n, sb, nb, sa, na, margin)
    if sep_b > margin:
        return none
    # reference face: the one that separates most, with a bias towards A's
    if sep_b > sep_a + REFERENCE_FACE_TOL:
        sr, nr, ref_edge, si, ni, flip = sb, nb, edge_b, sa, na, 1
    else:
        sr, nr, ref_edge, si, ni, flip = sa, na, edge_a, sb, nb, 0
    nx, ny = world_n[sr + ref_edge, 0], world_n[sr + ref_edge, 1]
    inc = incident_edge(world_n, si, ni, nx, ny)  # the edge of the other polygon that meets the face
    # The incident edge runs against the reference edge r1 -> r2, so its second
    # vertex lies on r1's side and its first on r2's. Each clip point is named by
    # its end (0: r1's side, 1: r2's) whether or not clipping moved it: a hair of
    # sideways motion must not rename a point, or its cached impulse would be lost.
    ok, p1x, p1y, p2x, p2y = clip_incident(world_v, sr, nr, ref_edge, si, ni, inc)  # end 1, end 0
    if not ok:
        return none
    r1 = sr + ref_edge
    base = (flip << 15) | (ref_edge << 8) | (inc << 1)
    ox, oy = world_v[r1, 0], world_v[r1, 1]
    sep0 = nx * (p2x - ox) + ny * (p2y - oy)
    sep1 = nx * (p1x - ox) + ny * (p1y - oy)
    sign = -1.0 if flip else 1.0  # the normal is written from A to B
    # each point midway between the incident point and the reference face; end 0 first
    q0 = (p2x - 0.5 * sep0 * nx, p2y - 0.5 * sep0 * ny, sep0, base)
    q1 = (p1x - 0.5 * sep1 * nx, p1y - 0.5 * sep1 * ny, sep1, base | 1)
    if sep0 <= margin and sep1 <= margin:
        return (2, sign * nx, sign * ny) + q0 + q1
    if sep0 <= margin:
        return (1, sign * nx, sign * ny) + q0 + q1
    if sep1 <= margin:
        return (1, sign * nx, sign * ny) + q1 + q0
    return none


@njit(cache=True)
def collide_circle_polygon(world_v, world_n, s, n, cx, cy, r, margin):
    """Circle (centre c, radius r) against the polygon with vertices s..s+n.

    Returns (count, nx, ny, px, py, sep, feature) with the normal from the polygon
    to the circle and count 0 or 1.
    """
    best_edge = 0
    best = -np.inf
    for e in range(n):
        d = world_n[s + e, 0] * (cx - world_v[s + e, 0]) + world_n[s + e, 1] * (cy - world_v[s + e, 1])
        if d > best:
            best = d
            best_edge = e
    if best > r + margin:
        return 0, 0.0, 0.0, 0.0, 0.0, 0.0, 0
    v1 = s + best_edge
    v2 = s + (best_edge + 1) % n
    nx, ny = world_n[v1, 0], world_n[v1, 1]
    depth_from_face = best  # distance of the centre from the polygon surface
    feature = best_edge
    if best > 0.0:  # centre outside: edge region or one of its vertices
        ex, ey = world_v[v2, 0] - world_v[v1, 0], world_v[v2, 1] - world_v[v1, 1]
        u1 = (cx - world_v[v1, 0]) * ex + (cy - world_v[v1, 1]) * ey
        u2 = (cx - world_v[v2, 0]) * -ex + (cy - world_v[v2, 1]) * -ey
        corner = -1
        if u1 <= 0.0:
            corner = v1
            feature = VERTEX_BIT | best_edge
        elif u2 <= 0.0:
            corner = v2
            feature = VERTEX_BIT | ((best_edge + 1) % n)
        if corner >= 0:
            dx, dy = cx - world_v[corner, 0], cy - world_v[corner, 1]
            dist = np.sqrt(dx * dx + dy * dy)
            if dist > r + margin:
                return 0, 0.0, 0.0, 0.0, 0.0, 0.0, 0
            if dist > 1e-12:
                nx, ny = dx / dist, dy / dist
            depth_from_face = dist
    sep = depth_from_face - r
    # midway between the circle's surface and the polygon's
    return 1, nx, ny, cx - nx * (r + 0.5 * sep), cy - ny * (r + 0.5 * sep), sep, feature


@njit(cache=True, inline="always")
def collide_circles(xa, ya, ra, xb, yb, rb, margin):
    """Circle A against circle B: (count, nx, ny, px, py, sep, feature), normal from A to B."""
    dx, dy = xb - xa, yb - ya
    dist = np.sqrt(dx * dx + dy * dy)
    if dist > ra + rb + margin:
        return 0, 0.0, 0.0, 0.0, 0.0, 0.0, 0
    nx, ny = 0.0, 1.0  # concentric: any normal will do, pick +y
    if dist > 1e-12:
        nx, ny = dx / dist, dy / dist
    sep = dist - ra - rb
    return 1, nx, ny, xa + nx * (ra + 0.5 * sep), ya + ny * (ra + 0.5 * sep), sep, 0


@njit(cache=True)
def manifold(a, b, x, shapes, margin, rounded):
    """The manifold of bodies a and b (at centres x), points up to ``margin`` (m) apart, normal
    from a to b: (count, nx, ny, p1x, p1y, sep1, feature1, p2x, p2y, sep2, feature2).

    ``rounded``: None in a world of circles and polygons only, True when it has capsules,
    segments or chains. numba prunes the branch on None when it compiles, so a world
    without them compiles none of ``rounded``'s code."""
    kind, radius, vstart, vcount = shapes.kind, shapes.radius, shapes.vstart, shapes.vcount
    world_v, world_n = shapes.world_v, shapes.world_n
    if rounded is not None:
        if kind[a] > POLYGON or kind[b] > POLYGON:
            return rounded_manifold(a, b, x, shapes, margin)
    if kind[a] != CIRCLE and kind[b] != CIRCLE:
        return collide_polygons(world_v, world_n, vstart[a], vcount[a], vstart[b], vcount[b], margin)
    if kind[a] == CIRCLE and kind[b] == CIRCLE:
        c = collide_circles(x[a, 0], x[a, 1], radius[a], x[b, 0], x[b, 1], radius[b], margin)
        sign = 1.0
    elif kind[a] == CIRCLE:  # polygon b, normal from b to a: flip it
        c = collide_circle_polygon(world_v, world_n, vstart[b], vcount[b], x[a, 0], x[a, 1], radius[a], margin)
        sign = -1.0
    else:
        c = collide_circle_polygon(world_v, world_n, vstart[a], vcount[a], x[b, 0], x[b, 1], radius[b], margin)
        sign = 1.0
    return (c[0], sign * c[1], sign * c[2], c[3], c[4], c[5], c[6], c[3], c[4], c[5], c[6])


@njit(cache=True)
def circle_against(p, c, x, shapes, margin):
    """Circle body c against body p, a capsule, segment or chain segment: (count, nx, ny, px, py,
    sep, feature) with the normal from p to the circle."""
    world_v, world_n, s, r = shapes.world_v, shapes.world_n, shapes.vstart[p], shapes.radius[c]
    if shapes.kind[p] == CHAIN:
        pose = chain_geometry(p, x, shapes.rotation, shapes.local_v, shapes.vstart)
        return collide_circle_chain(pose, (x[c, 0], x[c, 1]), r, margin)
    return collide_circle_capsule(world_v, world_n, s, shapes.radius[p], (x[c, 0], x[c, 1]), r, margin)


@njit(cache=True)
def rounded_manifold(a, b, x, shapes, margin):
    """Bodies a and b, one a capsule, segment or chain segment (``rounded``): the manifold, normal
    from a to b."""
    kind, radius, vstart, vcount = shapes.kind, shapes.radius, shapes.vstart, shapes.vcount
    world_v, world_n = shapes.world_v, shapes.world_n
    if kind[a] == CIRCLE or kind[b] == CIRCLE:  # normal from the other shape to the circle
        circle_first = kind[a] == CIRCLE
        c = circle_against(b, a, x, shapes, margin) if circle_first else circle_against(a, b, x, shapes, margin)
        sign = -1.0 if circle_first else 1.0
        return (c[0], sign * c[1], sign * c[2], c[3], c[4], c[5], c[6], c[3], c[4], c[5], c[6])
    if kind[a] == CHAIN or kind[b] == CHAIN:  # the chain first, then swapped back if it is b
        c, o = (a, b) if kind[a] == CHAIN else (b, a)
        pose = chain_geometry(c, x, shapes.rotation, shapes.local_v, vstart)
        shape_o = (vstart[o], vcount[o], radius[o], (x[o, 0], x[o, 1]))
        m = collide_chain(world_v, world_n, vstart[c], pose, shape_o, margin)
        return m if c == a else swapped(m, True)
    if kind[a] != POLYGON and kind[b] != POLYGON:  # capsules and segments
        return collide_capsules(world_v, world_n, vstart[a], vstart[b], (radius[a], radius[b]), margin)
    radii = (radius[a], radius[b])  # a polygon's is 0
    return collide_rounded(world_v, world_n, (vstart[a], vcount[a]), (vstart[b], vcount[b]), radii, margin)


@njit(cache=True, inline="always")
def pair_key(uid, a, b):
    """The key of pair (a, b): uid_a << 39 | uid_b << 16; a point's key adds its feature id."""
    return (uid[a] << 39) | (uid[b] << 16)


@njit(cache=True, inline="always")
def write_point(out, k, a, b, found, pair):
    """Contact point k of ``out`` (a ``ContactRecord``): found = (px, py, nx, ny, separation,
    feature), pair = (key, mu, e) of bodies a and b (``write_point_to``)."""
    write_point_to(point_arrays(out), k, a, b, found, pair)


@njit(cache=True, inline="always")
def point_arrays(out):
    """The arrays of a ``ContactRecord`` a point is written into, as one tuple: (key, friction,
    restitution, body_a, body_b, point, normal, separation, feature, anchor). A parallel loop
    takes them once, before it starts: a record's field read within the loop counts a reference
    on each read, which the threads would share."""
    return (
        out.key, out.friction, out.restitution, out.body_a, out.body_b, out.point, out.normal, out.separation,
        out.feature, out.anchor,
    )  # fmt: skip


@njit(cache=True, inline="always")
def write_point_to(arrays, k, a, b, found, pair):
    """``write_point`` into the arrays of ``point_arrays``."""
    px, py, nx, ny, separation, feature = found
    key, mu, e = pair
    out_key, friction, restitution, body_a, body_b, point, normal, out_separation, out_feature, _ = arrays
    out_key[k] = key | feature
    friction[k] = mu
    restitution[k] = e
    body_a[k] = a
    body_b[k] = b
    point[k, 0] = px
    point[k, 1] = py
    normal[k, 0] = nx
    normal[k, 1] = ny
    out_separation[k] = separation
    out_feature[k] = feature


@njit(cache=True, inline="always")
def manifold_point(m, point):
    """Point 0 or 1 of manifold m (``manifold``): (px, py, nx, ny, separation, feature)."""
    if point == 0:
        return m[3], m[4], m[1], m[2], m[5], m[6]
    return m[7], m[8], m[1], m[2], m[9], m[10]


@njit(cache=True, inline="always")
def pair_friction(friction, restitution, a, b):
    """The pair's friction sqrt(mu_a mu_b) and restitution max(e_a, e_b)."""
    return np.sqrt(friction[a]) * np.sqrt(friction[b]), max(restitution[a], restitution[b])  # no overflow


@njit(cache=True)
def collide_pairs(bodies, shapes, n_pairs, contact_margin, out, rounded):
    """Manifolds of the first n_pairs candidate pairs (``ShapeRecord.pairs``) into ``out``; returns
    the number of points K.

    Points up to contact_margin + travel[a] + travel[b] apart (m) are kept as
    speculative contacts: surfaces that are close, or that the bodies' motion could
    bring together within the step (``travel``, see broadphase). Each point also
    gets its contact key (uid_a << 39 | uid_b << 16 | feature), the pair's friction
    sqrt(mu_a mu_b) and restitution max(e_a, e_b). ``out`` needs room for 2 n_pairs
    points; pair q's points are out.pair_start[q] up to out.pair_start[q + 1]. ``rounded``: as
    ``manifold``'s.
    """
    k = np.int64(0)  # int64 from the start: a literal 0 would compile write_point twice
    travel = shapes.travel
    for q in range(n_pairs):
        out.pair_start[q] = k
        a, b = shapes.pairs[q, 0], shapes.pairs[q, 1]
        m = manifold(a, b, bodies.x, shapes, contact_margin + travel[a] + travel[b], rounded)
        pair = (pair_key(shapes.uid, a, b), *pair_friction(shapes.friction, shapes.restitution, a, b))
        for point in range(m[0]):  # one or two points
            write_point(out, k, a, b, manifold_point(m, point), pair)
            k += 1
    out.pair_start[n_pairs] = k
    return k
