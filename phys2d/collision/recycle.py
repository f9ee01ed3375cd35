"""Contact recycling: keep a manifold's points while its two bodies barely move.

After Box2D v3 (its world's collide stage, 2026). When the narrowphase finds a
manifold, the pair's relative pose is remembered: B's position in A's frame, and
each body's rotation (cos, sin of its angle). In a later step, while

    |p_rel - p_rel,cached| + extent |sin(dtheta_rel)| < contact_recycle_distance

(extent: the larger distance from a moving body's centre to its surface) and
neither body has turned by more than RECYCLE_MAX_TURN since, the narrowphase is
skipped: each point keeps its normal, its feature id and the lever arms r_a, r_b
it was found with (``anchor``), and only its separation follows the motion, the
anchors turned with their bodies,

    C = C_cached + (x_b - x_a + R_b r_b - R_a r_a) . n

as within the soft step's sub-steps (the point reported rides with the incident
polygon, whose corner made it). A stack whose boxes lean by a hair then keeps the
points it had instead of the ones clipping would find at each new tilt, and a pair
that stays put costs no narrowphase. Nor any trigonometry: the turns since caching
(dtheta_rel is B's turn less A's) come from the bodies' rotations now, computed once
a step with the world vertices, and then, by cos(t - t0) = cos t cos t0 + sin t sin t0
and sin(t - t0) = sin t cos t0 - cos t sin t0.
Nor any copying: a manifold is kept in a row of the store (``ManifoldStore``),
and a recycled one stays in its row from step to step; new ones are appended.

A responder with ``found_lever_arms`` (SoftStep) builds its rows with those arms as
found, unturned, as Box2D v3 does. A soft contact lets a box tilt on its partner by
the spring's give; arms that turn with the tilt add the torque of the load through
them (lambda_n times the arm's change), which tilts the box further: a 20-box stack
leaning by a millimetre a box buckles within seconds. With the arms as found, the
torques are those of the pose the manifold was found in, as for rigid contacts. The
price: the two arms' points part as the bodies move relative to each other (by less
than contact_recycle_distance, or the pair is collided anew), and a pair's impulse
lambda then acts at two points, a couple of lambda times their offset; angular
momentum is no longer exact. Other responders take the arms p - x at the positions
now: an impulse acts at one point of both bodies.

Fast pairs (whose motion could carry a point of one further than contact_margin
towards the other within the step, ``pair_travel``) are always collided anew, so
speculative contacts still see what is coming. For two bodies of like mass the
motion that counts is the relative one, as in Box2D v3: a pyramid that sinks into
its soft contacts as one keeps its manifolds, however fast it sinks. Also collided
anew: a pair that had no points, one whose recycled points would lie
further apart than the narrowphase keeps them, and any pair but two polygons: with
a circle or a capsule (a rolling circle's point moves over its surface as it
turns), or a segment or chain segment (a body rocking over a chain's vertex turns
a corner onto the next segment, which the points it had do not hold).
"""

from __future__ import annotations

import numpy as np
from numba import prange

from ..jit import njit
from ..shapes import CIRCLE, POLYGON
from .narrowphase import (
    FLIP_BIT,
    manifold,
    manifold_point,
    pair_friction,
    pair_key,
    point_arrays,
    write_point,
    write_point_to,
)
from .sort import lower_bound

RECYCLE_MAX_TURN = 0.98  # cos of the largest turn (about 11.5 degrees) of either body since caching
RECYCLE_MASS_RATIO = 10.0  # bodies of masses within this ratio recycle by their relative motion (pair_travel)


@njit(cache=True, inline="always")
def body_extent(b, shapes):
    """The largest distance (m) from body b's centre to its surface; 0 for a static body."""
    if shapes.static[b]:
        return 0.0
    if shapes.kind[b] == CIRCLE:
        return shapes.radius[b]
    r2 = 0.0
    local_v = shapes.local_v
    for v in range(shapes.vstart[b], shapes.vstart[b] + shapes.vcount[b]):
        r2 = max(r2, local_v[v, 0] ** 2 + local_v[v, 1] ** 2)
    return np.sqrt(r2) + shapes.radius[b]  # a capsule's rounding (0 for polygons)


@njit(cache=True, inline="always")
def body_extents(shapes):
    """``body_extent`` of every body (m), once per step: a body is in several pairs."""
    extent = np.empty(shapes.kind.shape[0])
    for b in range(shapes.kind.shape[0]):
        extent[b] = body_extent(b, shapes)
    return extent


@njit(cache=True, inline="always")
def pair_travel(a, b, motion, extent, travel, dt):
    """How far (m) the step may carry a point of body b towards body a, as recycling judges it.

    Two moving bodies whose masses lie within RECYCLE_MASS_RATIO of each other: by their
    relative motion, dt (|v_b - v_a| + |omega_a| extent_a + |omega_b| extent_b)
    (``body_extents``). Any other pair: each body's own travel, summed (``update_geometry``'s
    travel): a light body under a heavy one is collided anew while either moves fast (kept by
    their relative motion, the light bodies of ``high_mass_ratio`` did not come to rest).
    motion: the bodies' (V, M_inv)."""
    V, M_inv = motion
    m_a, m_b = M_inv[a, 0], M_inv[b, 0]  # 1/m: 0 for a static or kinematic body
    if m_a > 0.0 and m_b > 0.0 and m_a < RECYCLE_MASS_RATIO * m_b and m_b < RECYCLE_MASS_RATIO * m_a:
        dvx, dvy = V[b, 0] - V[a, 0], V[b, 1] - V[a, 1]
        return dt * (np.sqrt(dvx * dvx + dvy * dvy) + abs(V[a, 2]) * extent[a] + abs(V[b, 2]) * extent[b])
    return travel[a] + travel[b]


@njit(cache=True, inline="always")
def angle_difference(c, s, c0, s0):
    """(cos, sin) of t - t0 from (cos t, sin t) and (cos t0, sin t0), no trigonometry:
    cos(t - t0) = cos t cos t0 + sin t sin t0, sin(t - t0) = sin t cos t0 - cos t sin t0."""
    return c * c0 + s * s0, s * c0 - c * s0


@njit(cache=True, inline="always")
def relative_position(a, b, x, rotation):
    """B's centre in A's frame, R_a^T (x_b - x_a), in m (``rotation``: each body's (cos, sin))."""
    c, s = rotation[a, 0], rotation[a, 1]
    dx, dy = x[b, 0] - x[a, 0], x[b, 1] - x[a, 1]
    return c * dx + s * dy, -s * dx + c * dy


@njit(cache=True, inline="always")
def turn_since_cached(row, a, b, rotation, found_rotation):
    """How far bodies a and b have turned since manifold ``row`` was found: (cos, sin) of each, once
    per pair, from their rotations now and then (``angle_difference``)."""
    ca, sa = angle_difference(rotation[a, 0], rotation[a, 1], found_rotation[row, 0], found_rotation[row, 1])
    cb, sb = angle_difference(rotation[b, 0], rotation[b, 1], found_rotation[row, 2], found_rotation[row, 3])
    return ca, sa, cb, sb


@njit(cache=True)
def may_recycle(row, a, b, x, rotation, extent, found_pose, turn, recycle_distance):
    """True while pair (a, b) has moved less than recycle_distance (m) relative to its pose when
    manifold ``row`` was found (``turn``: ``turn_since_cached``; ``extent``: ``body_extents``)."""
    ca, sa, cb, sb = turn
    if ca <= RECYCLE_MAX_TURN or cb <= RECYCLE_MAX_TURN:
        return False
    px, py = relative_position(a, b, x, rotation)
    dx, dy = px - found_pose[row, 0], py - found_pose[row, 1]
    # B's turn relative to A since caching is turn_b - turn_a: the change of theta_b - theta_a
    sin_relative_turn = angle_difference(cb, sb, ca, sa)[1]
    reach = max(extent[a], extent[b])
    return np.sqrt(dx * dx + dy * dy) + reach * abs(sin_relative_turn) < recycle_distance


@njit(cache=True, inline="always")
def recycled_point(point, a, b, x, turn, cached_points):
    """(px, py, separation) of the store's point now: its anchors turned with their bodies
    (``turn``: ``turn_since_cached``). cached_points: the store's (anchor, normal, separation,
    feature)."""
    anchor, normal, base_separation, feature = cached_points
    ca, sa, cb, sb = turn
    r_ax = ca * anchor[point, 0] - sa * anchor[point, 1]
    r_ay = sa * anchor[point, 0] + ca * anchor[point, 1]
    r_bx = cb * anchor[point, 2] - sb * anchor[point, 3]
    r_by = sb * anchor[point, 2] + cb * anchor[point, 3]
    dx = x[b, 0] + r_bx - x[a, 0] - r_ax
    dy = x[b, 1] + r_by - x[a, 1] - r_ay
    separation = base_separation[point] + dx * normal[point, 0] + dy * normal[point, 1]
    # the point rides with the incident polygon, whose corner made it (b's, unless the reference face
    # was b's), kept midway between the surfaces as the narrowphase puts it: a box sliding on the
    # ground keeps its lever arms
    shift = 0.5 * (separation - base_separation[point])
    if feature[point] & FLIP_BIT:
        return x[a, 0] + r_ax + shift * normal[point, 0], x[a, 1] + r_ay + shift * normal[point, 1], separation
    return x[b, 0] + r_bx - shift * normal[point, 0], x[b, 1] + r_by - shift * normal[point, 1], separation


@njit(cache=True, inline="always")
def next_slot(cached_key, key, m):
    """The first slot whose cached key is >= key. The pairs' keys ascend, so the look-up walks on
    from the last one (``m``): a merge of two sorted lists; a key below the last looks from the start."""
    if m > 0 and cached_key[m - 1] >= key:
        return lower_bound(cached_key, key)
    while m < cached_key.shape[0] and cached_key[m] < key:
        m += 1
    return m


@njit(cache=True, inline="always")
def recycle_manifold(store_arrays, row, into, k, pair, x, turn, margin):
    """Write the points of cached manifold ``row`` of the store into ``into`` (``point_arrays``),
    moved with their bodies (``recycled_point``), from point k on; returns the next k, or -1 if
    one of them lies beyond ``margin`` (m) of its partner: the narrowphase would drop it, so the
    pair is collided anew (over what was written). pair = (a, b, key, mu, e); store_arrays =
    the store's (span, anchor, normal, separation, feature), read once by the caller."""
    a, b = pair[0], pair[1]
    span, anchor, normal, separation, feature = store_arrays
    found_as, cached_points = (normal, feature, anchor), (anchor, normal, separation, feature)
    for point in range(span[row, 0], span[row, 1]):
        now = recycled_point(point, a, b, x, turn, cached_points)
        if now[2] > margin:
            return -1
        write_recycled_point(found_as, point, into, k, now, pair)
        k += 1
    return k


@njit(cache=True, inline="always")
def write_recycled_point(found_as, point, into, k, now, pair):
    """The store's point into ``into`` (``point_arrays``) as point k, where it is now (now = (px,
    py, separation), ``recycled_point``), with what it was found with, found_as = the store's
    (normal, feature, anchor): its normal, feature id and lever arms, unturned. pair = (a, b,
    key, mu, e)."""
    a, b, key, mu, e = pair
    px, py, sep = now
    normal, feature_of, anchor = found_as
    feature = np.int64(feature_of[point])  # as the narrowphase's: one write_point
    write_point_to(into, k, a, b, (px, py, normal[point, 0], normal[point, 1], sep, feature), (key, mu, e))
    out_anchor = into[9]
    for i in range(4):
        out_anchor[k, i] = anchor[point, i]


@njit(cache=True)
def store_manifold(store, row, points_used, out, k, m, pair, x, rotation):
    """Manifold m (``manifold``) of pair (a, b, key, mu, e), found now: its points into ``out``
    from point k on and into the store from points_used on, with their lever arms r_a, r_b
    (m) at the positions x now, and the pair's pose into the store's ``row``. Returns the
    next k and the next free point of the store."""
    a, b, key, mu, e = pair
    p = points_used
    for point in range(m[0]):
        found = manifold_point(m, point)
        px, py, nx, ny, sep, f = found
        write_point(out, k, a, b, found, (key, mu, e))
        store.anchor[p, 0] = out.anchor[k, 0] = px - x[a, 0]
        store.anchor[p, 1] = out.anchor[k, 1] = py - x[a, 1]
        store.anchor[p, 2] = out.anchor[k, 2] = px - x[b, 0]
        store.anchor[p, 3] = out.anchor[k, 3] = py - x[b, 1]
        store.normal[p, 0] = nx
        store.normal[p, 1] = ny
        store.separation[p] = sep
        store.feature[p] = f
        k += 1
        p += 1
    store.found_pose[row, 0], store.found_pose[row, 1] = relative_position(a, b, x, rotation)
    for i in range(2):
        store.found_rotation[row, i] = rotation[a, i]
        store.found_rotation[row, 2 + i] = rotation[b, i]
    store.span[row, 0] = points_used
    store.span[row, 1] = p
    return k, p


@njit(cache=True)
def collide_recycling(bodies, shapes, store, cached, out, counts, margins, rounded):
    """As ``narrowphase.collide_pairs``, reusing the cached manifolds that may be recycled.

    counts = (n_pairs, n_cached, rows_used, points_used); margins = (contact_margin,
    recycle_distance) in m, and the step's dt in s. ``cached`` is last step's ContactRecord: its
    first n_cached manifold_key (ascending) and manifold_row name the cached manifolds and their rows of the
    store, whose rows hold found_pose (B's centre in A's frame, m), found_rotation (both
    bodies' (cos, sin)) and span (its points: span[r, 0] up to span[r, 1] of anchor, normal,
    separation, feature), as the manifold was found. A recycled manifold keeps its row, not
    copied; a new one is appended after rows_used and points_used (room for n_pairs rows and
    2 n_pairs points). ``rounded``: None without capsules, segments or chains in the world, else
    True (``narrowphase.manifold``). ``out`` gets the step's points (and their lever arms as found, anchor),
    pair_start, and the step's manifolds' keys and rows (manifold_key, manifold_row).

    Returns (points K, manifolds cached, recycled, rows_used, points_used, whether the
    manifolds' keys ascend).
    """
    n_pairs, n_cached, rows_used, points_used = counts
    contact_margin, recycle_distance, dt = margins
    x, rotation, travel, pairs = bodies.x, shapes.rotation, shapes.travel, shapes.pairs
    cached_key, cached_row = cached.manifold_key[:n_cached], cached.manifold_row[:n_cached]
    pair_start = out.pair_start
    kind, uid, friction, restitution = shapes.kind, shapes.uid, shapes.friction, shapes.restitution
    found_pose, found_rotation = store.found_pose, store.found_rotation
    k = np.int64(0)  # int64 from the start: a literal 0 would compile write_point twice
    n_new = 0
    n_recycled = 0
    ascends = True
    look = np.int64(0)  # the cached slot looked at last (int64: next_slot compiles once)
    extent = body_extents(shapes) if recycle_distance > 0.0 else np.zeros(0)
    motion = (bodies.V, bodies.M_inv)  # (read once: a record's field read in a loop counts a reference)
    # (read once, not reloaded from the records for each recycled manifold)
    store_arrays, into = (store.span, store.anchor, store.normal, store.separation, store.feature), point_arrays(out)
    for q in range(n_pairs):
        pair_start[q] = k
        a, b = pairs[q, 0], pairs[q, 1]
        key = pair_key(uid, a, b)
        pair = (a, b, key, *pair_friction(friction, restitution, a, b))
        slot = -1
        polygons = kind[a] == POLYGON and kind[b] == POLYGON  # a circle or capsule rolls: its point moves
        if recycle_distance > 0.0 and polygons and n_cached > 0:
            if pair_travel(a, b, motion, extent, travel, dt) <= contact_margin:  # not a fast pair
                look = next_slot(cached_key, key, look)
                if look < n_cached and cached_key[look] == key:
                    slot = look
        margin = contact_margin + travel[a] + travel[b]
        recycled = -1
        row = cached_row[slot] if slot >= 0 else -1
        if slot >= 0:
            turned = turn_since_cached(row, a, b, rotation, found_rotation)
            if may_recycle(row, a, b, x, rotation, extent, found_pose, turned, recycle_distance):
                recycled = recycle_manifold(store_arrays, row, into, k, pair, x, turned, margin)
        if recycled >= 0:
            n_recycled += 1
            k = recycled
        else:
            row = rows_used  # a new row of the store, its points after points_used
            m = manifold(a, b, x, shapes, margin, rounded)
            if m[0] == 0:
                continue
            k, points_used = store_manifold(store, row, points_used, out, k, m, pair, x, rotation)
            rows_used += 1
        n_new, ascends = cache_manifold(out, n_new, key, row, ascends)  # a pair with points
    pair_start[n_pairs] = k
    return k, n_new, n_recycled, rows_used, points_used, ascends


@njit(cache=True, inline="always")
def cache_manifold(out, n_new, key, row, ascends):
    """Cache the step's manifold n_new: its pair's key and its row of the store. Returns the next
    n_new, and whether the keys still ascend."""
    if n_new > 0 and key <= out.manifold_key[n_new - 1]:
        ascends = False
    out.manifold_key[n_new] = key
    out.manifold_row[n_new] = row
    return n_new + 1, ascends


@njit(cache=True)
def collide_recycling_on(threads, bodies, shapes, store, cached, out, counts, margins, rounded):
    """``collide_recycling`` on one thread (threads None: numba drops the parallel branch, and
    compiles no parallel kernel), else on ``threads`` (``collide_recycling_in_slices``), with
    the same results."""
    if threads is None:
        return collide_recycling(bodies, shapes, store, cached, out, counts, margins, rounded)
    return collide_recycling_in_slices(threads, bodies, shapes, store, cached, out, counts, margins, rounded)


@njit(cache=True, parallel=True)
def collide_recycling_in_slices(threads, bodies, shapes, store, cached, out, counts, margins, rounded):
    """``collide_recycling`` on ``threads`` threads, with the same results: the same outcomes
    written in the same places. Three passes:

    1. per pair, a slice per thread (``plan_pairs``): recycle (``may_recycle``, every point
       within the margin) or collide anew (``manifold``), the points kept in a scratch row,
       and their count;
    2. on one thread, in pair order: where each pair's points go (pair_start), the store's rows
       and points for the new manifolds, the manifolds' keys;
    3. per pair, a slice per thread (``write_pairs``): the points written there.
    """
    n_pairs, n_cached, rows_used, points_used = counts
    row_of = np.empty(n_pairs, np.int64)  # the store row of a recycled manifold; -1 collided anew
    count = np.empty(n_pairs, np.int64)  # its points
    found = np.empty((n_pairs, 11))  # per pair: its points now, laid out as ``manifold``'s
    # (np.empty, each entry written by its slice: numba makes np.zeros a parallel loop, one more wait)
    plan = (row_of, count, found, body_extents(shapes) if margins[1] > 0.0 else np.empty(0))
    for t in prange(threads):
        plan_pairs(n_pairs * t // threads, n_pairs * (t + 1) // threads, bodies, shapes, store, cached, counts,
                   margins, rounded, plan)  # fmt: skip
    # 2: in pair order, where everything goes
    pairs, uid, pair_start = shapes.pairs, shapes.uid, out.pair_start
    point_of = np.empty(n_pairs, np.int64)  # a new manifold's first point in the store
    k = n_new = n_recycled = 0
    ascends = True
    for q in range(n_pairs):
        pair_start[q] = k
        if count[q] == 0:
            continue
        key = pair_key(uid, pairs[q, 0], pairs[q, 1])
        if row_of[q] >= 0:
            n_recycled += 1
            row = row_of[q]
        else:
            row = rows_used
            row_of[q] = -2 - rows_used  # (a new row: -2 - row, told from a recycled one)
            point_of[q] = points_used
            rows_used += 1
            points_used += count[q]
        k += count[q]
        n_new, ascends = cache_manifold(out, n_new, key, row, ascends)
    pair_start[n_pairs] = k
    for t in prange(threads):  # 3: the points, where they go
        write_pairs(n_pairs * t // threads, n_pairs * (t + 1) // threads, bodies, shapes, store, out, plan, point_of)
    return k, n_new, n_recycled, rows_used, points_used, ascends


@njit(cache=True)
def plan_pairs(first, last, bodies, shapes, store, cached, counts, margins, rounded, plan):
    """Pass 1 of ``collide_recycling_in_slices`` for pairs first up to last: plan = (row_of,
    count, found, extent) filled in for each (the store row it recycles or -1, its points, the
    points themselves, laid out as ``manifold``'s)."""
    n_pairs, n_cached, _, _ = counts
    contact_margin, recycle_distance, dt = margins
    row_of, count, found, extent = plan
    x, rotation, travel, pairs, uid, kind = (
        bodies.x,
        shapes.rotation,
        shapes.travel,
        shapes.pairs,
        shapes.uid,
        shapes.kind,
    )
    cached_key, cached_row = cached.manifold_key[:n_cached], cached.manifold_row[:n_cached]
    span, found_pose, found_rotation, motion = (
        store.span,
        store.found_pose,
        store.found_rotation,
        (bodies.V, bodies.M_inv),
    )
    cached_points = (store.anchor, store.normal, store.separation, store.feature)
    look = np.int64(0)  # the cached slot looked at last, as collide_recycling's (``next_slot``)
    for q in range(first, last):
        a, b = pairs[q, 0], pairs[q, 1]
        margin = contact_margin + travel[a] + travel[b]
        polygons = kind[a] == POLYGON and kind[b] == POLYGON
        if recycle_distance > 0.0 and polygons and n_cached > 0:
            if pair_travel(a, b, motion, extent, travel, dt) <= contact_margin:
                key = pair_key(uid, a, b)
                look = next_slot(cached_key, key, look) if look > 0 else lower_bound(cached_key, key)
                if look < n_cached and cached_key[look] == key:
                    row = cached_row[look]
                    turned = turn_since_cached(row, a, b, rotation, found_rotation)
                    if may_recycle(row, a, b, x, rotation, extent, found_pose, turned, recycle_distance):
                        points = (span[row, 0], span[row, 1])
                        if recycled_within(cached_points, points, a, b, x, turned, margin, found[q]):
                            row_of[q] = row
                            count[q] = span[row, 1] - span[row, 0]
                            continue
        n, nx, ny, p1x, p1y, s1, f1, p2x, p2y, s2, f2 = manifold(a, b, x, shapes, margin, rounded)
        row_of[q] = -1
        found[q, 0], found[q, 1], found[q, 2], found[q, 3], found[q, 4] = n, nx, ny, p1x, p1y
        found[q, 5], found[q, 6], found[q, 7], found[q, 8], found[q, 9], found[q, 10] = s1, f1, p2x, p2y, s2, f2
        count[q] = n


@njit(cache=True)
def write_pairs(first, last, bodies, shapes, store, out, plan, point_of):
    """Pass 3 of ``collide_recycling_in_slices`` for pairs first up to last: each pair's points
    (plan: ``plan_pairs``'s, the rows of new manifolds -2 - row) written from out.pair_start[q]
    on, a new manifold's into the store too."""
    row_of, count, found, _ = plan
    x, rotation, pairs, uid = bodies.x, shapes.rotation, shapes.pairs, shapes.uid
    friction, restitution, span, pair_start = shapes.friction, shapes.restitution, store.span, out.pair_start
    found_as, into = (store.normal, store.feature, store.anchor), point_arrays(out)
    for q in range(first, last):
        if count[q] == 0:
            continue
        a, b = pairs[q, 0], pairs[q, 1]
        pair = (a, b, pair_key(uid, a, b), *pair_friction(friction, restitution, a, b))
        if row_of[q] >= 0:  # the points pass 1 moved
            for i in range(count[q]):
                now = (found[q, 3 + 4 * i], found[q, 4 + 4 * i], found[q, 5 + 4 * i])
                write_recycled_point(found_as, span[row_of[q], 0] + i, into, pair_start[q] + i, now, pair)
        else:
            f = found[q]
            m = (np.int64(f[0]), f[1], f[2], f[3], f[4], f[5], np.int64(f[6]), f[7], f[8], f[9], np.int64(f[10]))
            store_manifold(store, -2 - row_of[q], point_of[q], out, pair_start[q], m, pair, x, rotation)


@njit(cache=True)
def recycled_within(cached_points, points, a, b, x, turn, margin, found):
    """Whether every point of a cached manifold (``points``: its first and its end in the store's
    cached_points, as ``recycled_point`` reads them), moved with its bodies, lies within
    ``margin`` (m) of its partner, else ``recycle_manifold`` gives up on it; each point's (px,
    py, separation) into found, where ``manifold`` puts them (3-5, then 7-9)."""
    for i in range(points[1] - points[0]):
        px, py, sep = recycled_point(points[0] + i, a, b, x, turn, cached_points)
        if sep > margin:
            return False
        found[3 + 4 * i], found[4 + 4 * i], found[5 + 4 * i] = px, py, sep
    return True


@njit(cache=True, inline="always")
def has_room(n_rows, rows_used, n_points, points_used, n_pairs):
    """Whether a manifold store of n_rows rows and n_points points, rows_used and points_used of
    them taken, has room for n_pairs new manifolds (a row and up to 2 points each)."""
    return n_rows - rows_used >= n_pairs and n_points - points_used >= 2 * n_pairs


def compact(cached_row: np.ndarray, store: ManifoldStore, rows: int) -> tuple:
    """The store's live rows (cached_row's, in its order) and their points copied into a new store of
    ``rows`` rows and 2 rows points: (found_pose, found_rotation, span, anchor, normal, separation,
    feature, points used). Slot s's row becomes s.

    numpy, not a kernel: a store is compacted once in many steps, and a kernel run that rarely
    would be loaded from numba's cache mid-simulation, a hitch of milliseconds."""
    n = cached_row.shape[0]
    first, last = store.span[cached_row, 0], store.span[cached_row, 1]
    counts = last - first
    p = int(counts.sum())
    new_span = np.zeros((rows, 2), np.int64)
    new_span[:n, 1] = np.cumsum(counts)
    new_span[:n, 0] = new_span[:n, 1] - counts
    # the live points, row after row: row s's run first[s] ... last[s] - 1
    points = np.repeat(first - new_span[:n, 0], counts) + np.arange(p)
    new_pose, new_rotation = np.zeros((rows, 2)), np.zeros((rows, 4))
    new_pose[:n], new_rotation[:n] = store.found_pose[cached_row], store.found_rotation[cached_row]
    new_anchor, new_normal = np.zeros((2 * rows, 4)), np.zeros((2 * rows, 2))
    new_separation, new_feature = np.zeros(2 * rows), np.zeros(2 * rows, np.int32)
    new_anchor[:p], new_normal[:p] = store.anchor[points], store.normal[points]
    new_separation[:p], new_feature[:p] = store.separation[points], store.feature[points]
    return new_pose, new_rotation, new_span, new_anchor, new_normal, new_separation, new_feature, p


class ManifoldStore:
    """The manifold store (a ``ManifoldRecord``'s arrays): the manifolds found in earlier steps,
    kept for recycling. Each row holds a manifold's pose and its span of points; the step's
    manifolds name their rows (``ContactRecord.manifold_row``). A step writes only after
    rows_used and points_used, so a manifold recycled from step to step stays in its row,
    and a step that is undone leaves the rows it had."""

    def __init__(self) -> None:
        self.clear()

    def clear(self) -> None:
        """An empty store."""
        self.found_pose = np.zeros((0, 2))  # B's centre in A's frame when found (m)
        self.found_rotation = np.zeros((0, 4))  # (cos, sin) of A's and of B's angle when found
        self.span = np.zeros((0, 2), np.int64)  # a row's points: span[r, 0] up to span[r, 1]
        self.anchor = np.zeros((0, 4))
        self.normal = np.zeros((0, 2))
        self.separation = np.zeros(0)
        self.feature = np.zeros(0, np.int32)
        self.rows_used = 0
        self.points_used = 0
        self.recycled = 0  # manifolds recycled in the last step

    def has_room(self, n_pairs: int) -> bool:
        """Whether n_pairs new manifolds (2 n_pairs points) fit after the rows and points used."""
        # the kernel's own Python (called from here, the kernel would be loaded the first time the store ran low)
        room = getattr(has_room, "py_func", has_room)
        return room(self.found_pose.shape[0], self.rows_used, self.anchor.shape[0], self.points_used, n_pairs)

    def rebuild(self, cached_row: np.ndarray, rows: int) -> None:
        """A new store of ``rows`` rows (2 rows points) holding the live manifolds only (cached_row's),
        slot s in row s."""
        if cached_row.shape[0] == 0:  # nothing to keep (the first step): an empty store
            self.clear()
        (
            self.found_pose, self.found_rotation, self.span, self.anchor, self.normal, self.separation, self.feature,
            self.points_used,
        ) = compact(cached_row, self, rows)  # fmt: skip
        self.rows_used = cached_row.shape[0]

    def live(self, key: np.ndarray, row: np.ndarray) -> tuple:
        """The cached manifolds (keys ``key`` in rows ``row``) as arrays, slot by slot (what two equal
        caches share bit for bit): keys, then the rows' pose, rotation and point counts, then the
        points' anchor, normal, separation and feature."""
        points = np.concatenate([np.arange(*self.span[r]) for r in row]) if row.size else np.zeros(0, np.int64)
        counts = self.span[row, 1] - self.span[row, 0]
        return (
            key,
            self.found_pose[row],
            self.found_rotation[row],
            counts,
            self.anchor[points],
            self.normal[points],
            self.separation[points],
            self.feature[points],
            self.recycled,
        )
