"""Broadphase: candidate pairs by sort-and-sweep on x within horizontal strips, kept while
nothing moves far.

Each body's axis-aligned bounding box is computed from its world geometry. A sweep on x
alone tests a body against every body whose x-interval overlaps its own: in a pile 100 boxes
tall that is the whole column, O(N^1.5). So the plane is first cut into horizontal strips a
few boxes tall (``strips_of``); each body joins every strip its box spans, and each strip is
swept on x by itself (boxes sorted by their left edge, swept left to right). A pair that
shares several strips is kept in one: the strip where their overlap begins. About
O(N log N) for any pile.

The sweep runs on "fat" boxes, grown by a margin, and its pairs are kept from
tick to tick for as long as every body's tight box stays inside its fat box
(``fits_inside``): a resting pile pays for one sweep, not one per tick.
"""

from __future__ import annotations

import numpy as np
from numba import prange

from ..jit import njit
from ..shapes import CIRCLE
from .sort import counting_argsort, lower_bound, stable_argsort


@njit(cache=True)
def update_geometry(bodies, shapes, dt, margin):
    """World-frame vertices and edge normals of every polygon (capsules', segments' and chain segments'
    two core ends too), every body's AABB (a rounded one's grown by its radius) and rotation;
    returns whether every tight box still lies inside its fat box (``fits_inside``: last step's
    pairs still hold).

    travel[b] = dt (|v| + |omega| r_max) is how far (m) any point of body b can move
    within the step (r_max: the farthest point from its centre). aabb[b] = (min x,
    min y, max x, max y) in m, grown by margin + travel[b], so a fast body meets what
    it could reach this step (speculative contacts). rotation[b] = (cos theta_b, sin theta_b):
    computed once here, and the contact recycling uses them too.
    """
    geometry_of(0, bodies.x.shape[0], bodies, shapes, dt, margin)
    return fits_inside(shapes.aabb, shapes.fat)


@njit(cache=True)
def geometry_of(first, last, bodies, shapes, dt, margin):
    """``update_geometry`` of bodies first up to last: each writes only its own entries."""
    x, theta, V = bodies.x, bodies.theta, bodies.V
    vstart, vcount, local_v, local_n = shapes.vstart, shapes.vcount, shapes.local_v, shapes.local_n
    kind, radius = shapes.kind, shapes.radius
    world_v, world_n, aabb, travel, rotation = (
        shapes.world_v,
        shapes.world_n,
        shapes.aabb,
        shapes.travel,
        shapes.rotation,
    )
    for b in range(first, last):
        px, py = x[b, 0], x[b, 1]
        c, s = np.cos(theta[b]), np.sin(theta[b])
        rotation[b, 0] = c
        rotation[b, 1] = s
        speed = np.sqrt(V[b, 0] * V[b, 0] + V[b, 1] * V[b, 1])
        if kind[b] == CIRCLE:
            r = radius[b]
            travel[b] = dt * (speed + abs(V[b, 2]) * r)
            grow = r + margin + travel[b]
            aabb[b, 0] = px - grow
            aabb[b, 1] = py - grow
            aabb[b, 2] = px + grow
            aabb[b, 3] = py + grow
            continue
        lo_x, lo_y, hi_x, hi_y = np.inf, np.inf, -np.inf, -np.inf
        r2 = 0.0
        for k in range(vstart[b], vstart[b] + vcount[b]):
            r2 = max(r2, local_v[k, 0] * local_v[k, 0] + local_v[k, 1] * local_v[k, 1])
            vx = px + c * local_v[k, 0] - s * local_v[k, 1]
            vy = py + s * local_v[k, 0] + c * local_v[k, 1]
            world_v[k, 0] = vx
            world_v[k, 1] = vy
            world_n[k, 0] = c * local_n[k, 0] - s * local_n[k, 1]
            world_n[k, 1] = s * local_n[k, 0] + c * local_n[k, 1]
            lo_x = min(lo_x, vx)
            lo_y = min(lo_y, vy)
            hi_x = max(hi_x, vx)
            hi_y = max(hi_y, vy)
        rounding = shapes.radius[b]  # a capsule's or segment's (0 for polygons): its surface lies that far out
        travel[b] = dt * (speed + abs(V[b, 2]) * (np.sqrt(r2) + rounding))
        grow = margin + travel[b] + rounding
        aabb[b, 0] = lo_x - grow
        aabb[b, 1] = lo_y - grow
        aabb[b, 2] = hi_x + grow
        aabb[b, 3] = hi_y + grow


@njit(cache=True, parallel=True)
def update_geometry_in_slices(threads, bodies, shapes, dt, margin):
    """``update_geometry`` a slice of the bodies per thread, with the same results."""
    n = bodies.x.shape[0]
    for t in prange(threads):
        geometry_of(n * t // threads, n * (t + 1) // threads, bodies, shapes, dt, margin)
    return fits_inside(shapes.aabb, shapes.fat)


@njit(cache=True)
def update_geometry_on(threads, bodies, shapes, dt, margin):
    """``update_geometry`` on one thread (threads None: no parallel code is compiled), else on
    ``threads``."""
    if threads is None:
        return update_geometry(bodies, shapes, dt, margin)
    return update_geometry_in_slices(threads, bodies, shapes, dt, margin)


FAT_MARGIN = 0.1  # m: broadphase boxes are grown by this, so pairs outlive small motions


@njit(cache=True)
def fatten(aabb, fat):
    """fat = each tight box grown by FAT_MARGIN on every side: the boxes the sweep pairs up."""
    for b in range(aabb.shape[0]):
        fat[b, 0], fat[b, 1] = aabb[b, 0] - FAT_MARGIN, aabb[b, 1] - FAT_MARGIN
        fat[b, 2], fat[b, 3] = aabb[b, 2] + FAT_MARGIN, aabb[b, 3] + FAT_MARGIN


@njit(cache=True, inline="always")
def fits_inside(aabb, fat):
    """True when every tight box lies inside its fat box: last step's pairs still hold."""
    if aabb.shape[0] != fat.shape[0]:
        return False
    for b in range(aabb.shape[0]):
        if aabb[b, 0] < fat[b, 0] or aabb[b, 1] < fat[b, 1] or aabb[b, 2] > fat[b, 2] or aabb[b, 3] > fat[b, 3]:
            return False
    return True


@njit(cache=True, inline="always")
def _excluded(excluded, a, b):
    """Binary search of the sorted pair keys a * 2^32 + b (a < b) of joined bodies."""
    key = (np.int64(a) << 32) | np.int64(b)
    at = lower_bound(excluded, key)
    return at < excluded.shape[0] and excluded[at] == key


@njit(cache=True)
def find_pairs(shapes):
    """The broadphase anew: ``fatten`` the tight boxes into the fat ones, then ``sweep_and_prune``
    them into ``ShapeRecord.pairs`` (their count, or minus the room needed when it is too small)."""
    fatten(shapes.aabb, shapes.fat)
    filters = (shapes.category, shapes.mask, shapes.group)
    return sweep_and_prune(shapes.fat, shapes.static, shapes.excluded, shapes.pairs, filters)


@njit(cache=True, inline="always")
def filtered_out(filters, a, b):
    """Box2D's collision filter (``bodies.should_collide``): a shared non-zero group decides
    (positive: collide, negative: never); else each one's category must be in the other's mask.
    filters = (category, mask, group), per body."""
    category, mask, group = filters
    if group[a] == group[b] and group[a] != 0:
        return group[a] < 0
    return (mask[a] & category[b]) == 0 or (category[a] & mask[b]) == 0


STRIP_HEIGHTS = 2.0  # a strip is this many mean box heights tall


@njit(cache=True)
def strips_of(aabb):
    """Horizontal strips for the sweep: (y of the first strip's bottom, strip height H, number
    of strips S), H about STRIP_HEIGHTS mean box heights, at most one strip per box. Boxes with
    no finite extent count in neither the mean nor the range (``strip_index`` clamps them)."""
    n = aabb.shape[0]
    lowest, highest, heights, counted = np.inf, -np.inf, 0.0, 0
    for b in range(n):
        y0, y1 = aabb[b, 1], aabb[b, 3]
        if np.isfinite(y1 - y0):  # (finite ends whose height overflows count as not finite)
            lowest, highest = min(lowest, y0), max(highest, y1)
            heights += y1 - y0
            counted += 1
    span = highest - lowest
    if counted == 0 or not 0.0 < span < np.inf:
        return 0.0, 1.0, 1  # one strip: the plain sweep on x
    height = max(STRIP_HEIGHTS * heights / counted, span / max(n, 1))
    return lowest, height, min(int(span / height), n) + 1  # (at most one strip per box, as said)


@njit(cache=True, inline="always")
def strip_index(y, strips):
    """The strip holding height y (m), clamped to the strips (NaN and -inf to the first)."""
    bottom, height, n_strips = strips
    t = (y - bottom) / height
    if not t >= 0.0:
        return 0
    if t >= n_strips - 1:
        return n_strips - 1
    return int(t)


@njit(cache=True)
def sweep_and_prune(aabb, static, excluded, pairs, filters):
    """Write the candidate pairs (a < b) into ``pairs``, sorted by (a, b).

    Returns how many there are; if ``pairs`` is too small, returns the number
    needed as a negative count so the caller can grow the buffer and retry.
    Pairs of bodies that are both static (or kinematic), the pairs in ``excluded`` (joined
    bodies) and the pairs the collision filter keeps apart (``filtered_out``) are skipped.
    """
    n = aabb.shape[0]
    strips = strips_of(aabb)
    n_strips = strips[2]
    first, last = np.empty(n, np.int64), np.empty(n, np.int64)  # the strips each box spans
    start = np.zeros(n_strips + 1, np.int64)
    for b in range(n):
        first[b], last[b] = strip_index(aabb[b, 1], strips), strip_index(aabb[b, 3], strips)
        for s in range(first[b], last[b] + 1):
            start[s + 1] += 1
    for s in range(n_strips):
        start[s + 1] += start[s]
    members = np.empty(start[n_strips], np.int64)  # strip s's boxes, by left edge: members[start[s]:start[s + 1]]
    fill = start[:n_strips].copy()
    left = np.empty(n)  # the left edges, contiguous: the sort compiled once, for the bisection's too
    for b in range(n):
        left[b] = aabb[b, 0]
    order = stable_argsort(left)
    for ii in range(n):
        a = order[ii]
        for s in range(first[a], last[a] + 1):
            members[fill[s]] = a
            fill[s] += 1
    count = np.int64(0)  # (not the literal 0: numba would compile sort_pairs for Literal[int](0) too)
    cap = pairs.shape[0]
    for s in range(n_strips):
        for ii in range(start[s], start[s + 1]):
            a = members[ii]
            right = aabb[a, 2]
            for jj in range(ii + 1, start[s + 1]):
                b = members[jj]
                if aabb[b, 0] > right:
                    break  # sorted by left edge: nothing further overlaps a in x
                if aabb[a, 1] > aabb[b, 3] or aabb[b, 1] > aabb[a, 3]:
                    continue
                if max(first[a], first[b]) != s:
                    continue  # kept in the strip where the overlap begins: once
                if (static[a] and static[b]) or filtered_out(filters, a, b):
                    continue
                lo, hi = min(a, b), max(a, b)
                if excluded.shape[0] > 0 and _excluded(excluded, lo, hi):
                    continue
                if count < cap:
                    pairs[count, 0] = lo
                    pairs[count, 1] = hi
                count += 1
    if count > cap:
        return -count
    sort_pairs(pairs, count, n)  # by (a, b): contact keys come out ascending, the solve order is stable
    return count


@njit(cache=True)
def sort_pairs(pairs, count, n_bodies):
    """pairs[:count] (body indices below n_bodies) sorted by (a, b): two counting sorts, O(count +
    n_bodies) each (``counting_argsort``, stable), by b and then by a, as a radix sort does."""
    keys = np.empty(count, np.int64)
    for k in range(count):
        keys[k] = pairs[k, 1]
    by_b = counting_argsort(keys, n_bodies)
    for k in range(count):
        keys[k] = pairs[by_b[k], 0]
    by_a = counting_argsort(keys, n_bodies)  # stable: equal a keep their order by b
    sorted_pairs = np.empty((count, 2), np.int64)
    for k in range(count):
        sorted_pairs[k, 0], sorted_pairs[k, 1] = pairs[by_b[by_a[k]], 0], pairs[by_b[by_a[k]], 1]
    for k in range(count):
        pairs[k, 0], pairs[k, 1] = sorted_pairs[k, 0], sorted_pairs[k, 1]
