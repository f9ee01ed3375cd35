"""Rounded polygons: capsules, segments and chain segments against every shape.

A capsule, a segment and a chain segment are two-vertex polygons with a radius: a core
segment v_0 v_1 swept by a disc of radius r (0 for a bare segment or chain segment). Their
manifolds are found on the cores, then moved out by the radii (after Box2D v3):

    separation  C = (distance between the cores) - r_a - r_b
    point       midway between the two surfaces: core point + (r_ref - r_inc - C_core) / 2 n

Box or polygon against a capsule or segment (``collide_rounded``): SAT on the cores' edge
normals and clipping of the incident edge, as ``narrowphase.collide_polygons``. When the
cores are apart, their closest features decide: two vertices closer than the clipped
points make one vertex-vertex point (a capsule's cap on a box's corner). Capsule or
segment against capsule or segment (``collide_capsules``): the closest points of the two
cores; cores that overlap along each other give two clipped points (a capsule lying on
another). Circle against a capsule or segment (``collide_circle_capsule``): the closest
point of the core.

A chain segment (``collide_chain``, ``collide_circle_chain``) is one-sided and smooth, as
Box2D's chains: it collides only with a body whose centre is on its right (the side of its
normal n_1, the right-hand perpendicular of p_1 -> p_2), and it knows its neighbours' far
ends, its ghost vertices g_0 and g_3. A contact normal n is classified on the segment's
Gauss map: pointing into a neighbour's region past a convex vertex, it belongs to the
neighbour (skipped); within a convex vertex's wedge it is kept; at a flat or concave vertex
it is snapped to n_1, the manifold found again on the segment's face. A box sliding along
collinear segments so meets only the face n_1, never the corner of the next segment's end.

Feature ids (besides ``narrowphase``'s polygon and circle-polygon ones, which the clipped
and circle points use): a single point from the closest features of two cores sets bit 7
(``CLOSEST_BIT``); bits 8-13 name a's vertex (bit 14 set: a's edge instead), bits 1-6 b's
vertex (bit 0 set: b's edge).
"""

from __future__ import annotations

import numpy as np

from ..jit import njit
from .sat import FLIP_BIT, REFERENCE_FACE_TOL, VERTEX_BIT, clip_incident, incident_edge, max_separation

CLOSEST_BIT = VERTEX_BIT  # a polygon-pair feature from the cores' closest features
A_EDGE_BIT = 1 << 14  # ... whose point on a lies inside a's edge
B_EDGE_BIT = 1  # ... whose point on b lies inside b's edge
CORE_APART = 5e-4  # m: cores further apart than this are met by their closest features
SIN_TOL = 0.01  # sin of the angle within which a normal counts as a neighbour's (Box2D's)
CONVEX_TOL = 0.01  # sin of the smallest turn that makes a chain vertex convex

SKIP, ADMIT, SNAP = 0, 1, 2  # what a chain segment does with a contact normal


@njit(cache=True, inline="always")
def clamp01(f):
    """f clamped to [0, 1]."""
    return min(max(f, 0.0), 1.0)


@njit(cache=True)
def closest_fractions(p1x, p1y, d1x, d1y, p2x, p2y, d2x, d2y):
    """Fractions (f1, f2) of the closest points p1 + f1 d1 and p2 + f2 d2 of two segments of
    non-zero length (m): the unclamped solution of the 2x2 normal equations, clamped to
    segment 1, then segment 2 clamped and segment 1 solved again (Ericson 5.1.9)."""
    rx, ry = p1x - p2x, p1y - p2y
    dd1 = d1x * d1x + d1y * d1y
    dd2 = d2x * d2x + d2y * d2y
    rd1 = rx * d1x + ry * d1y
    rd2 = rx * d2x + ry * d2y
    d12 = d1x * d2x + d1y * d2y
    denom = dd1 * dd2 - d12 * d12
    f1 = 0.0
    if denom > 0.0:  # not parallel
        f1 = clamp01((d12 * rd2 - rd1 * dd2) / denom)
    f2 = (d12 * f1 + rd2) / dd2
    if f2 < 0.0:
        f2 = 0.0
        f1 = clamp01(-rd1 / dd1)
    elif f2 > 1.0:
        f2 = 1.0
        f1 = clamp01((d12 - rd1) / dd1)
    return f1, f2


@njit(cache=True, inline="always")
def closest_feature(f, vertex_first, edge_bit, shift):
    """The closest-point feature bits of one core: its vertex (fraction 0 or 1 along its edge
    from ``vertex_first``) or its edge 0 (``edge_bit``), at bit ``shift``."""
    if f <= 0.0:
        return vertex_first << shift
    if f >= 1.0:
        return (1 - vertex_first) << shift
    return edge_bit


@njit(cache=True)
def rounded_points(n, o, q0, q1, radii, base, sign, margin):
    """The manifold of two core points q0 (end 0) and q1 (end 1) facing the reference face through
    o with normal n: separations C = n . (q - o) - r_ref - r_inc, points midway between the
    surfaces, those within ``margin`` (m) kept, end 0 first. radii = (r_ref, r_inc) m; base:
    the feature id but its end bit; sign: -1 when the reference face is b's (normal a to b)."""
    nx, ny = n
    r_ref, r_inc = radii
    core0 = nx * (q0[0] - o[0]) + ny * (q0[1] - o[1])
    core1 = nx * (q1[0] - o[0]) + ny * (q1[1] - o[1])
    shift0, shift1 = 0.5 * (r_ref - r_inc - core0), 0.5 * (r_ref - r_inc - core1)
    p0 = (q0[0] + shift0 * nx, q0[1] + shift0 * ny, core0 - r_ref - r_inc, base)
    p1 = (q1[0] + shift1 * nx, q1[1] + shift1 * ny, core1 - r_ref - r_inc, base | 1)
    if p0[2] <= margin and p1[2] <= margin:
        return (2, sign * nx, sign * ny) + p0 + p1
    if p0[2] <= margin:
        return (1, sign * nx, sign * ny) + p0 + p1
    if p1[2] <= margin:
        return (1, sign * nx, sign * ny) + p1 + p0
    return (0, 0.0, 0.0, 0.0, 0.0, 0.0, 0, 0.0, 0.0, 0.0, 0)


@njit(cache=True)
def closest_point_manifold(c1, c2, radii, feature, fallback, margin):
    """One point from the closest points c1 on a's core and c2 on b's (m): normal (c2 - c1) / d (or
    ``fallback`` when they meet), C = d - r_a - r_b, the point midway between the surfaces."""
    ra, rb = radii
    dx, dy = c2[0] - c1[0], c2[1] - c1[1]
    d = np.sqrt(dx * dx + dy * dy)
    sep = d - ra - rb
    if sep > margin:
        return (0, 0.0, 0.0, 0.0, 0.0, 0.0, 0, 0.0, 0.0, 0.0, 0)
    nx, ny = fallback
    if d > 1e-12:
        nx, ny = dx / d, dy / d
    px, py = c1[0] + (ra + 0.5 * sep) * nx, c1[1] + (ra + 0.5 * sep) * ny
    return (1, nx, ny, px, py, sep, feature, px, py, sep, feature)


@njit(cache=True)
def collide_rounded(world_v, world_n, a, b, radii, margin):
    """Polygon a (vertices a = (start, count)) against polygon b, either rounded (radii = (r_a, r_b),
    m): the manifold as ``narrowphase.collide_polygons`` returns it, normal from a to b."""
    sa, na = a
    sb, nb = b
    ra, rb = radii
    r = ra + rb
    none = (0, 0.0, 0.0, 0.0, 0.0, 0.0, 0, 0.0, 0.0, 0.0, 0)
    edge_a, sep_a = max_separation(world_v, world_n, sa, na, sb, nb, margin + r)
    if sep_a > margin + r:
        return none
    edge_b, sep_b = max_separation(world_v, world_n, sb, nb, sa, na, margin + r)
    if sep_b > margin + r:
        return none
    if sep_b > sep_a + REFERENCE_FACE_TOL:  # reference face: b's only if clearly better
        sr, nr, ref_edge, si, ni, flip, r_ref, r_inc = sb, nb, edge_b, sa, na, 1, rb, ra
    else:
        sr, nr, ref_edge, si, ni, flip, r_ref, r_inc = sa, na, edge_a, sb, nb, 0, ra, rb
    nx, ny = world_n[sr + ref_edge, 0], world_n[sr + ref_edge, 1]
    inc = incident_edge(world_n, si, ni, nx, ny)  # the edge of the other polygon that meets the face
    ok, e1x, e1y, e0x, e0y = clip_incident(world_v, sr, nr, ref_edge, si, ni, inc)
    base = (flip << 15) | (ref_edge << 8) | (inc << 1)
    o = (world_v[sr + ref_edge, 0], world_v[sr + ref_edge, 1])
    sign = -1.0 if flip else 1.0
    clipped = rounded_points((nx, ny), o, (e0x, e0y), (e1x, e1y), (r_ref, r_inc), base, sign, np.inf)
    if max(sep_a, sep_b) <= CORE_APART:  # the cores overlap: the clipped points
        return rounded_points((nx, ny), o, (e0x, e0y), (e1x, e1y), (r_ref, r_inc), base, sign, margin) if ok else none
    # the cores are apart: two vertices closer than the clipped points make one point
    va0, va1 = sa + edge_a, sa + (edge_a + 1) % na
    vb0, vb1 = sb + edge_b, sb + (edge_b + 1) % nb
    if flip == 0:
        vb0, vb1 = si + inc, si + (inc + 1) % ni
    else:
        va0, va1 = si + inc, si + (inc + 1) % ni
    d1x, d1y = world_v[va1, 0] - world_v[va0, 0], world_v[va1, 1] - world_v[va0, 1]
    d2x, d2y = world_v[vb1, 0] - world_v[vb0, 0], world_v[vb1, 1] - world_v[vb0, 1]
    f1, f2 = closest_fractions(world_v[va0, 0], world_v[va0, 1], d1x, d1y, world_v[vb0, 0], world_v[vb0, 1], d2x, d2y)
    c1 = (world_v[va0, 0] + f1 * d1x, world_v[va0, 1] + f1 * d1y)
    c2 = (world_v[vb0, 0] + f2 * d2x, world_v[vb0, 1] + f2 * d2y)
    vertices = (f1 == 0.0 or f1 == 1.0) and (f2 == 0.0 or f2 == 1.0)
    nearest = np.sqrt((c2[0] - c1[0]) ** 2 + (c2[1] - c1[1]) ** 2) - r
    lowest = np.inf
    if ok:
        lowest = min(clipped[5], clipped[9])
    if vertices and nearest + CORE_APART < lowest:
        ia = (va0 - sa) if f1 == 0.0 else (va1 - sa)
        ib = (vb0 - sb) if f2 == 0.0 else (vb1 - sb)
        feature = CLOSEST_BIT | (ia << 8) | (ib << 1)
        return closest_point_manifold(c1, c2, radii, feature, (sign * nx, sign * ny), margin)
    if not ok:
        return none
    return rounded_points((nx, ny), o, (e0x, e0y), (e1x, e1y), (r_ref, r_inc), base, sign, margin)


@njit(cache=True)
def side_separation(p, u, q0, q1):
    """The side normal of core p + t u (u unit) that separates points q0, q1 most, and that
    separation (m): (nx, ny, C)."""
    nx, ny = -u[1], u[0]  # the left-hand perpendicular
    s0 = nx * (q0[0] - p[0]) + ny * (q0[1] - p[1])
    s1 = nx * (q1[0] - p[0]) + ny * (q1[1] - p[1])
    if min(s0, s1) >= min(-s0, -s1):
        return nx, ny, min(s0, s1)
    return -nx, -ny, min(-s0, -s1)


@njit(cache=True)
def clip_to_core(p, u, length, q0, q1):
    """Points q0, q1 moved along q0 q1 to lie within core p + t u, 0 <= t <= length (m), with their
    coordinates t along it: (q0x, q0y, q1x, q1y, t0, t1)."""
    t0 = u[0] * (q0[0] - p[0]) + u[1] * (q0[1] - p[1])
    t1 = u[0] * (q1[0] - p[0]) + u[1] * (q1[1] - p[1])
    c0x, c0y, c1x, c1y = q0[0], q0[1], q1[0], q1[1]
    for bound in (0.0, length):
        low = bound == 0.0
        if (t0 < bound) == low and (t1 < bound) != low:  # q0 beyond the bound, q1 within
            w = (bound - t0) / (t1 - t0)
            c0x, c0y = q0[0] + w * (q1[0] - q0[0]), q0[1] + w * (q1[1] - q0[1])
        elif (t1 < bound) == low and (t0 < bound) != low:
            w = (bound - t1) / (t0 - t1)
            c1x, c1y = q1[0] + w * (q0[0] - q1[0]), q1[1] + w * (q0[1] - q1[1])
    return c0x, c0y, c1x, c1y, t0, t1


@njit(cache=True)
def core_of(world_v, s):
    """Core p -> q of the two-vertex polygon at row s: (p, q, u unit, length m)."""
    p = (world_v[s, 0], world_v[s, 1])
    q = (world_v[s + 1, 0], world_v[s + 1, 1])
    dx, dy = q[0] - p[0], q[1] - p[1]
    length = np.sqrt(dx * dx + dy * dy)
    return p, q, (dx / length, dy / length), length


@njit(cache=True)
def lying_on(world_v, world_n, ref, inc, radii, margin, flip):
    """Two points where core ``inc`` lies along core ``ref`` (rows of two-vertex polygons): inc's ends
    clipped to ref's length, their separations along ref's side normal. Normal a to b (flip:
    ref is b). Returns the manifold, or a count of 0 when both lie beyond margin."""
    p, _, u, length = core_of(world_v, ref)
    q0 = (world_v[inc, 0], world_v[inc, 1])
    q1 = (world_v[inc + 1, 0], world_v[inc + 1, 1])
    nx, ny, _ = side_separation(p, u, q0, q1)
    c0x, c0y, c1x, c1y, t0, t1 = clip_to_core(p, u, length, q0, q1)
    ref_edge = 0 if nx * world_n[ref, 0] + ny * world_n[ref, 1] > 0.0 else 1
    inc_edge = 0 if nx * world_n[inc, 0] + ny * world_n[inc, 1] < 0.0 else 1
    base = (flip << 15) | (ref_edge << 8) | (inc_edge << 1)
    # end 0 lies towards the reference edge's first vertex: p for edge 0, q for edge 1
    first0 = (t0 <= t1) == (ref_edge == 0)
    e0, e1 = ((c0x, c0y), (c1x, c1y)) if first0 else ((c1x, c1y), (c0x, c0y))
    sign = -1.0 if flip else 1.0
    r_ref, r_inc = (radii[1], radii[0]) if flip else radii
    return rounded_points((nx, ny), p, e0, e1, (r_ref, r_inc), base, sign, margin)


@njit(cache=True)
def collide_capsules(world_v, world_n, sa, sb, radii, margin):
    """Capsule or segment a (the two-vertex polygon at row sa) against b (row sb), radii (r_a, r_b)
    m: the manifold, normal from a to b. Cores that overlap along each other give two points
    on the face that separates them more (a's unless b's clearly does), else one point at
    their closest points."""
    ra, rb = radii
    none = (0, 0.0, 0.0, 0.0, 0.0, 0.0, 0, 0.0, 0.0, 0.0, 0)
    p1, _, u1, len1 = core_of(world_v, sa)
    p2, _, u2, len2 = core_of(world_v, sb)
    f1, f2 = closest_fractions(p1[0], p1[1], u1[0] * len1, u1[1] * len1, p2[0], p2[1], u2[0] * len2, u2[1] * len2)
    c1 = (p1[0] + f1 * len1 * u1[0], p1[1] + f1 * len1 * u1[1])
    c2 = (p2[0] + f2 * len2 * u2[0], p2[1] + f2 * len2 * u2[1])
    d = np.sqrt((c2[0] - c1[0]) ** 2 + (c2[1] - c1[1]) ** 2)
    if d - ra - rb > margin:
        return none
    # does each core project onto the other? then they may lie along each other: clip
    b0 = (world_v[sb, 0], world_v[sb, 1])
    b1 = (world_v[sb + 1, 0], world_v[sb + 1, 1])
    a0 = (world_v[sa, 0], world_v[sa, 1])
    a1 = (world_v[sa + 1, 0], world_v[sa + 1, 1])
    tb0 = u1[0] * (b0[0] - p1[0]) + u1[1] * (b0[1] - p1[1])
    tb1 = u1[0] * (b1[0] - p1[0]) + u1[1] * (b1[1] - p1[1])
    ta0 = u2[0] * (a0[0] - p2[0]) + u2[1] * (a0[1] - p2[1])
    ta1 = u2[0] * (a1[0] - p2[0]) + u2[1] * (a1[1] - p2[1])
    outside_a = (tb0 <= 0.0 and tb1 <= 0.0) or (tb0 >= len1 and tb1 >= len1)
    outside_b = (ta0 <= 0.0 and ta1 <= 0.0) or (ta0 >= len2 and ta1 >= len2)
    if not outside_a and not outside_b:
        sep_a = side_separation(p1, u1, b0, b1)[2]
        sep_b = side_separation(p2, u2, a0, a1)[2]
        if sep_a + REFERENCE_FACE_TOL >= sep_b:
            m = lying_on(world_v, world_n, sa, sb, radii, margin, 0)
        else:
            m = lying_on(world_v, world_n, sb, sa, radii, margin, 1)
        # points no further apart than the closest ones (and a slop): the cores lie along each other
        if m[0] == 2 or (m[0] == 1 and m[5] <= d - ra - rb + 0.005):
            return m
    feature = CLOSEST_BIT | closest_feature(f1, 0, A_EDGE_BIT, 8) | closest_feature(f2, 0, B_EDGE_BIT, 1)
    return closest_point_manifold(c1, c2, radii, feature, (world_n[sa, 0], world_n[sa, 1]), margin)


@njit(cache=True)
def collide_circle_capsule(world_v, world_n, s, rc, centre, r, margin):
    """Circle (centre m, radius r) against the capsule or segment at row s (rounding rc, m): the
    closest point of the core. Returns (count, nx, ny, px, py, sep, feature), normal from the
    capsule to the circle; feature as circle-polygon: the edge whose side holds the centre, or
    VERTEX_BIT | the core end nearest it."""
    p, _, u, length = core_of(world_v, s)
    t = u[0] * (centre[0] - p[0]) + u[1] * (centre[1] - p[1])
    side = world_n[s, 0] * (centre[0] - p[0]) + world_n[s, 1] * (centre[1] - p[1])
    feature = 0 if side >= 0.0 else 1
    if t <= 0.0:
        t, feature = 0.0, VERTEX_BIT
    elif t >= length:
        t, feature = length, VERTEX_BIT | 1
    m = closest_point_manifold(
        (p[0] + t * u[0], p[1] + t * u[1]), centre, (rc, r), feature, (world_n[s, 0], world_n[s, 1]), margin
    )
    return m[0], m[1], m[2], m[3], m[4], m[5], m[6]


# -- chain segments: one-sided, with ghost vertices ------------------------------------------


@njit(cache=True, inline="always")
def to_world(c, k, x, rotation, local_v):
    """Row k of local_v, a point of body c's frame, in world coordinates (m)."""
    cs, sn = rotation[c, 0], rotation[c, 1]
    return x[c, 0] + cs * local_v[k, 0] - sn * local_v[k, 1], x[c, 1] + sn * local_v[k, 0] + cs * local_v[k, 1]


@njit(cache=True)
def chain_geometry(c, x, rotation, local_v, vstart):
    """Chain segment c in world coordinates: (g0, p1, p2, g3), its ghosts g0 and g3 around p1 -> p2
    (m), from its body's pose (``rotation``: (cos, sin)); the ghosts follow its vertices in local_v."""
    s = vstart[c]
    g0 = to_world(c, s + 2, x, rotation, local_v)
    p1 = to_world(c, s, x, rotation, local_v)
    p2 = to_world(c, s + 1, x, rotation, local_v)
    g3 = to_world(c, s + 3, x, rotation, local_v)
    return g0, p1, p2, g3


@njit(cache=True, inline="always")
def unit(dx, dy):
    """(dx, dy) / |(dx, dy)|."""
    length = np.sqrt(dx * dx + dy * dy)
    return dx / length, dy / length


@njit(cache=True)
def gauss_map(g0, p1, p2, g3):
    """The chain segment's Gauss map: (edge1, normal0, normal1, normal2, convex1, convex2): unit edge
    p1 -> p2, the right-hand normals of the edge before, of it and of the edge after, and
    whether p1 and p2 are convex vertices (the chain turns left there by more than CONVEX_TOL)."""
    e0 = unit(p1[0] - g0[0], p1[1] - g0[1])
    e1 = unit(p2[0] - p1[0], p2[1] - p1[1])
    e2 = unit(g3[0] - p2[0], g3[1] - p2[1])
    convex1 = e0[0] * e1[1] - e0[1] * e1[0] >= CONVEX_TOL
    convex2 = e1[0] * e2[1] - e1[1] * e2[0] >= CONVEX_TOL
    return e1, (e0[1], -e0[0]), (e1[1], -e1[0]), (e2[1], -e2[0]), convex1, convex2


@njit(cache=True)
def classify_normal(n, edge1, normal0, normal2, convex1, convex2):
    """What the segment does with contact normal n (from the segment to the body): SKIP it (it points
    into a neighbour's region past a convex vertex: the neighbour's contact), ADMIT it (within
    a convex vertex's wedge), or SNAP it to the segment's normal (towards a flat or concave
    vertex, where the face alone decides)."""
    if n[0] * edge1[0] + n[1] * edge1[1] <= 0.0:  # towards p1
        if not convex1:
            return SNAP
        return SKIP if n[0] * normal0[1] - n[1] * normal0[0] > SIN_TOL else ADMIT
    if not convex2:
        return SNAP
    return SKIP if normal2[0] * n[1] - normal2[1] * n[0] > SIN_TOL else ADMIT


@njit(cache=True)
def behind(centre, g0, p1, p2, g3):
    """True when ``centre`` is behind the segment and behind its convex neighbours: one-sided."""
    edge1, normal0, normal1, normal2, convex1, convex2 = gauss_map(g0, p1, p2, g3)
    behind1 = normal1[0] * (centre[0] - p1[0]) + normal1[1] * (centre[1] - p1[1]) < 0.0
    behind0 = not convex1 or normal0[0] * (centre[0] - p1[0]) + normal0[1] * (centre[1] - p1[1]) < 0.0
    behind2 = not convex2 or normal2[0] * (centre[0] - p2[0]) + normal2[1] * (centre[1] - p2[1]) < 0.0
    return behind1 and behind0 and behind2


@njit(cache=True)
def face_manifold(world_v, world_n, c, o, r_o, margin):
    """Body o's polygon (rows o = (start, count), rounding r_o m) against chain segment c's face only:
    its incident edge clipped to the segment's ends, separations along the segment's normal n_1.
    Normal from the chain to o; features as polygons with the chain's edge 0 the reference."""
    so, no = o
    nx, ny = world_n[c, 0], world_n[c, 1]
    inc = incident_edge(world_n, so, no, nx, ny)
    ok, e1x, e1y, e0x, e0y = clip_incident(world_v, c, 2, 0, so, no, inc)
    if not ok:
        return (0, 0.0, 0.0, 0.0, 0.0, 0.0, 0, 0.0, 0.0, 0.0, 0)
    o1 = (world_v[c, 0], world_v[c, 1])
    return rounded_points((nx, ny), o1, (e0x, e0y), (e1x, e1y), (0.0, r_o), inc << 1, 1.0, margin)


@njit(cache=True)
def collide_chain(world_v, world_n, c, pose, shape_o, margin):
    """Chain segment c (row ``c`` of world_v, its ghosts in ``pose`` = (g0, p1, p2, g3) m) against
    body o's polygon, box or capsule (shape_o = (start, count, radius m, centre of mass)):
    the manifold with the normal from the chain to o, or none when o is behind it or the
    normal belongs to a neighbour (``classify_normal``)."""
    so, no, r_o, centre = shape_o
    g0, p1, p2, g3 = pose
    none = (0, 0.0, 0.0, 0.0, 0.0, 0.0, 0, 0.0, 0.0, 0.0, 0)
    if behind(centre, g0, p1, p2, g3):
        return none
    if no == 2:
        m = collide_capsules(world_v, world_n, c, so, (0.0, r_o), margin)
    else:
        m = collide_rounded(world_v, world_n, (c, 2), (so, no), (0.0, r_o), margin)
    if m[0] == 0:
        return none
    edge1, normal0, _, normal2, convex1, convex2 = gauss_map(g0, p1, p2, g3)
    kind = classify_normal((m[1], m[2]), edge1, normal0, normal2, convex1, convex2)
    if kind == SKIP:
        return none
    if kind == ADMIT:
        return m
    return face_manifold(world_v, world_n, c, (so, no), r_o, margin)


@njit(cache=True)
def collide_circle_chain(pose, centre, r, margin):
    """Circle (centre m, radius r) against a chain segment (pose = (g0, p1, p2, g3), m): nothing
    behind it, nothing in a neighbour's region; else the closest point of the segment.
    Returns (count, nx, ny, px, py, sep, feature), normal from the chain to the circle;
    feature as circle-polygon (edge 0, or VERTEX_BIT | the end)."""
    g0, p1, p2, g3 = pose
    none = (0, 0.0, 0.0, 0.0, 0.0, 0.0, 0)
    ex, ey = p2[0] - p1[0], p2[1] - p1[1]
    if ey * (centre[0] - p1[0]) - ex * (centre[1] - p1[1]) < 0.0:  # behind n_1 = (e_y, -e_x)
        return none
    u = ex * (p2[0] - centre[0]) + ey * (p2[1] - centre[1])  # weight of p1
    v = ex * (centre[0] - p1[0]) + ey * (centre[1] - p1[1])  # weight of p2
    feature = 0
    if v <= 0.0:  # beyond p1: the previous segment's unless in p1's wedge
        if (p1[0] - g0[0]) * (centre[0] - p1[0]) + (p1[1] - g0[1]) * (centre[1] - p1[1]) <= 0.0:
            return none
        q, feature = p1, VERTEX_BIT
    elif u <= 0.0:  # beyond p2: the next segment's unless in p2's wedge
        if (g3[0] - p2[0]) * (centre[0] - p2[0]) + (g3[1] - p2[1]) * (centre[1] - p2[1]) > 0.0:
            return none
        q, feature = p2, VERTEX_BIT | 1
    else:
        ee = ex * ex + ey * ey
        q = ((u * p1[0] + v * p2[0]) / ee, (u * p1[1] + v * p2[1]) / ee)
    length = np.sqrt(ex * ex + ey * ey)
    m = closest_point_manifold(q, centre, (0.0, r), feature, (ey / length, -ex / length), margin)
    return m[0], m[1], m[2], m[3], m[4], m[5], m[6]


@njit(cache=True, inline="always")
def swapped(m, feature_pair):
    """Manifold m of (a, b) as one of (b, a): the normal negated, each feature id swapped
    (``swap_feature``; feature_pair: whether they are polygon-pair ids)."""
    f1, f2 = m[6], m[10]
    if feature_pair:
        f1, f2 = swap_feature(f1), swap_feature(f2)
    return (m[0], -m[1], -m[2], m[3], m[4], m[5], f1, m[7], m[8], m[9], f2)


@njit(cache=True, inline="always")
def swap_feature(f):
    """A polygon-pair feature id with a and b swapped: the flip bit toggled, or a closest-point id's
    two halves exchanged."""
    if f & CLOSEST_BIT:
        a_part = (f >> 8) & 63
        b_part = (f >> 1) & 63
        edges = (B_EDGE_BIT if f & A_EDGE_BIT else 0) | (A_EDGE_BIT if f & B_EDGE_BIT else 0)
        return CLOSEST_BIT | (b_part << 8) | (a_part << 1) | edges
    return f ^ FLIP_BIT
