"""The separating axis test of two convex polygons, the incident edge clipped to the reference
face's sides, and the bits of a polygon pair's feature id, shared by the polygon narrowphase
(``narrowphase``) and the rounded one (``rounded``)."""

from __future__ import annotations

import numpy as np

from ..jit import njit

FLIP_BIT = 1 << 15
VERTEX_BIT = 1 << 7
EDGE_MASK = 63  # 6 bits: an edge or vertex index
REFERENCE_SHIFT = 8
INCIDENT_SHIFT = 1
END_BIT = 1

# Prefer the first polygon's face unless the second's separates clearly more:
# nearly equal faces then never trade places from one tick to the next.
REFERENCE_FACE_TOL = 5e-4  # m


@njit(cache=True)
def max_separation(world_v, world_n, sa, na, sb, nb, margin):
    """Edge of polygon A whose outward normal separates B the most: (edge, separation m)."""
    best_edge = 0
    best = -np.inf
    for e in range(na):
        nx, ny = world_n[sa + e, 0], world_n[sa + e, 1]
        vx, vy = world_v[sa + e, 0], world_v[sa + e, 1]
        deepest = np.inf  # support point of B against this face
        for k in range(nb):
            d = nx * (world_v[sb + k, 0] - vx) + ny * (world_v[sb + k, 1] - vy)
            if d < deepest:
                deepest = d
        if deepest > best:
            best = deepest
            best_edge = e
            if best > margin:
                break  # a separating axis: no contact, whatever the other edges say
    return best_edge, best


@njit(cache=True)
def incident_edge(world_n, si, ni, nx, ny):
    """Edge of polygon I (vertices si..si+ni) most anti-parallel to the reference normal (nx, ny):
    the one that meets the reference face, to be clipped against it."""
    inc = 0
    most = np.inf
    for e in range(ni):
        d = world_n[si + e, 0] * nx + world_n[si + e, 1] * ny
        if d < most:
            most = d
            inc = e
    return inc


@njit(cache=True)
def clip_incident(world_v, sr, nr, ref_edge, si, ni, inc):
    """The incident edge inc of polygon si clipped to the side planes of reference edge ref_edge
    of polygon sr: (ok, end-1 point x, y, end-0 point x, y); ok False when nothing is left."""
    p1x, p1y = world_v[si + inc, 0], world_v[si + inc, 1]  # lies towards the reference edge's end 1
    p2x, p2y = world_v[si + (inc + 1) % ni, 0], world_v[si + (inc + 1) % ni, 1]  # towards end 0
    r1 = sr + ref_edge
    r2 = sr + (ref_edge + 1) % nr
    tx, ty = world_v[r2, 0] - world_v[r1, 0], world_v[r2, 1] - world_v[r1, 1]
    tl = np.sqrt(tx * tx + ty * ty)
    tx, ty = tx / tl, ty / tl
    for side in range(2):  # keep t . p >= t . r1, then t . p <= t . r2
        if side == 0:
            ox, oy, sx, sy = world_v[r1, 0], world_v[r1, 1], tx, ty
        else:
            ox, oy, sx, sy = world_v[r2, 0], world_v[r2, 1], -tx, -ty
        d1 = sx * (p1x - ox) + sy * (p1y - oy)
        d2 = sx * (p2x - ox) + sy * (p2y - oy)
        if d1 < 0.0 and d2 < 0.0:
            return False, p1x, p1y, p2x, p2y
        if d1 < 0.0 or d2 < 0.0:
            u = d1 / (d1 - d2)
            cx, cy = p1x + u * (p2x - p1x), p1y + u * (p2y - p1y)
            if d1 < 0.0:
                p1x, p1y = cx, cy
            else:
                p2x, p2y = cx, cy
    return True, p1x, p1y, p2x, p2y
