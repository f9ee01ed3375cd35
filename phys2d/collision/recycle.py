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

Fast pairs (whose velocities could carry them further than contact_margin within
the step) are always collided anew, so speculative contacts still see what is
coming; so is a pair that had no points, one whose recycled points would lie
further apart than the narrowphase keeps them, and any pair with a circle (a
rolling circle's point moves over its surface as it turns).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..shapes import CIRCLE
from .narrowphase import FLIP_BIT, manifold, pair_friction, pair_key, write_point
from .sort import lower_bound

RECYCLE_MAX_TURN = 0.98  # cos of the largest turn (about 11.5 degrees) of either body since caching


@njit(cache=True, inline="always")
def body_extent(b, kind, radius, vstart, vcount, local_v, static):
    """The largest distance (m) from body b's centre to its surface; 0 for a static body."""
    if static[b]:
        return 0.0
    if kind[b] == CIRCLE:
        return radius[b]
    r2 = 0.0
    for v in range(vstart[b], vstart[b] + vcount[b]):
        r2 = max(r2, local_v[v, 0] ** 2 + local_v[v, 1] ** 2)
    return np.sqrt(r2)


@njit(cache=True, inline="always")
def body_extents(kind, radius, vstart, vcount, local_v, static):
    """``body_extent`` of every body (m), once per step: a body is in several pairs."""
    extent = np.empty(kind.shape[0])
    for b in range(kind.shape[0]):
        extent[b] = body_extent(b, kind, radius, vstart, vcount, local_v, static)
    return extent


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
def turn_since_cached(slot, a, b, rotation, cached_rotation):
    """How far bodies a and b have turned since the slot was cached: (cos, sin) of each, once per pair,
    from their rotations now and then (``angle_difference``)."""
    ca, sa = angle_difference(rotation[a, 0], rotation[a, 1], cached_rotation[slot, 0], cached_rotation[slot, 1])
    cb, sb = angle_difference(rotation[b, 0], rotation[b, 1], cached_rotation[slot, 2], cached_rotation[slot, 3])
    return ca, sa, cb, sb


@njit(cache=True)
def may_recycle(slot, a, b, x, rotation, extent, cached_pose, turn, recycle_distance):
    """True while pair (a, b) has moved less than recycle_distance (m) relative to its cached pose
    (``turn``: ``turn_since_cached``; ``extent``: ``body_extents``)."""
    ca, sa, cb, sb = turn
    if ca <= RECYCLE_MAX_TURN or cb <= RECYCLE_MAX_TURN:
        return False
    px, py = relative_position(a, b, x, rotation)
    dx, dy = px - cached_pose[slot, 0], py - cached_pose[slot, 1]
    # B's turn relative to A since caching is turn_b - turn_a: the change of theta_b - theta_a
    sin_relative_turn = angle_difference(cb, sb, ca, sa)[1]
    reach = max(extent[a], extent[b])
    return np.sqrt(dx * dx + dy * dy) + reach * abs(sin_relative_turn) < recycle_distance


@njit(cache=True)
def recycled_point(point, a, b, x, turn, anchor, normal, base_separation, feature):
    """(px, py, separation) of a cached point now: its anchors turned with their bodies
    (``turn``: ``turn_since_cached``)."""
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


@njit(cache=True)
def recycle_manifold(
    k,
    slot,
    a,
    b,
    x,
    turn,
    margin,
    key,
    mu,
    e,
    cached_start,
    cached_anchor,
    cached_normal,
    cached_separation,
    cached_feature,
    out_a,
    out_b,
    out_p,
    out_n,
    out_s,
    out_f,
    out_key,
    out_mu,
    out_e,
    out_r,
    new_anchor,
    new_normal,
    new_separation,
    new_feature,
):
    """Write the slot's cached points, moved with their bodies (``recycled_point``), from point k on;
    returns the next k, or -1 if one of them lies beyond ``margin`` (m) of its partner: the
    narrowphase would drop it, so the pair is collided anew (over what was written)."""
    for point in range(cached_start[slot], cached_start[slot + 1]):
        px, py, sep = recycled_point(
            point, a, b, x, turn, cached_anchor, cached_normal, cached_separation, cached_feature
        )
        if sep > margin:
            return -1
        write_point(
            k,
            a,
            b,
            px,
            py,
            cached_normal[point, 0],
            cached_normal[point, 1],
            sep,
            np.int64(cached_feature[point]),  # as the narrowphase's: one write_point
            key,
            mu,
            e,
            out_a,
            out_b,
            out_p,
            out_n,
            out_s,
            out_f,
            out_key,
            out_mu,
            out_e,
        )
        # the cache keeps the manifold as it was found: anchors and separation
        for i in range(4):
            new_anchor[k, i] = cached_anchor[point, i]
            out_r[k, i] = cached_anchor[point, i]  # the lever arms it was found with, unturned
        new_normal[k, 0] = cached_normal[point, 0]
        new_normal[k, 1] = cached_normal[point, 1]
        new_separation[k] = cached_separation[point]
        new_feature[k] = cached_feature[point]
        k += 1
    return k


@njit(cache=True)
def collide_recycling(
    pairs,
    n_pairs,
    x,
    rotation,
    kind,
    radius,
    vstart,
    vcount,
    local_v,
    static,
    world_v,
    world_n,
    contact_margin,
    travel,
    uid,
    friction,
    restitution,
    recycle_distance,
    cached_key,
    cached_start,
    cached_pose,
    cached_rotation,
    cached_anchor,
    cached_normal,
    cached_separation,
    cached_feature,
    out_a,
    out_b,
    out_p,
    out_n,
    out_s,
    out_f,
    out_key,
    out_mu,
    out_e,
    out_r,
    pair_start,
    new_key,
    new_start,
    new_pose,
    new_rotation,
    new_anchor,
    new_normal,
    new_separation,
    new_feature,
):
    """As ``narrowphase.collide_pairs``, reusing the cached manifolds that may be recycled.

    rotation: each body's (cos theta, sin theta) now (``update_geometry``). cached_*: last
    step's manifolds, sorted by pair key (slot s's points are cached_start[s] up to
    cached_start[s + 1]; its pose is B's centre in A's frame, its rotation both bodies'
    (cos, sin) when it was found). new_*: this step's, to cache (room for n_pairs manifolds
    and 2 n_pairs points). out_r: each point's lever arms (r_a, r_b) for the rows, as its
    manifold was found. Returns (points K, manifolds cached, recycled).
    """
    k = np.int64(0)  # int64 from the start: a literal 0 would compile write_point twice
    n_new = 0
    n_recycled = 0
    n_cached = cached_key.shape[0]
    look = np.int64(0)  # the cached slot looked at last (int64: next_slot compiles once)
    extent = body_extents(kind, radius, vstart, vcount, local_v, static) if recycle_distance > 0.0 else np.zeros(0)
    for q in range(n_pairs):
        pair_start[q] = k
        a, b = pairs[q, 0], pairs[q, 1]
        key = pair_key(uid, a, b)
        mu, e = pair_friction(friction, restitution, a, b)
        slot = -1
        polygons = kind[a] != CIRCLE and kind[b] != CIRCLE  # a circle rolls: its point moves over it
        if recycle_distance > 0.0 and polygons and travel[a] + travel[b] <= contact_margin and n_cached > 0:
            look = next_slot(cached_key, key, look)
            if look < n_cached and cached_key[look] == key:
                slot = look
        new_start[n_new] = k
        margin = contact_margin + travel[a] + travel[b]
        recycled = -1
        if slot >= 0:
            turned = turn_since_cached(slot, a, b, rotation, cached_rotation)
            if may_recycle(slot, a, b, x, rotation, extent, cached_pose, turned, recycle_distance):
                recycled = recycle_manifold(
                    k,
                    slot,
                    a,
                    b,
                    x,
                    turned,
                    margin,
                    key,
                    mu,
                    e,
                    cached_start,
                    cached_anchor,
                    cached_normal,
                    cached_separation,
                    cached_feature,
                    out_a,
                    out_b,
                    out_p,
                    out_n,
                    out_s,
                    out_f,
                    out_key,
                    out_mu,
                    out_e,
                    out_r,
                    new_anchor,
                    new_normal,
                    new_separation,
                    new_feature,
                )
        if recycled >= 0:
            n_recycled += 1
            k = recycled
            # the cache keeps the manifold as it was found: pose and rotations
            new_pose[n_new, 0] = cached_pose[slot, 0]
            new_pose[n_new, 1] = cached_pose[slot, 1]
            for i in range(4):
                new_rotation[n_new, i] = cached_rotation[slot, i]
        else:
            m = manifold(a, b, x, kind, radius, vstart, vcount, world_v, world_n, margin)
            for point in range(m[0]):
                if point == 0:
                    px, py, sep, feature = m[3], m[4], m[5], m[6]
                else:
                    px, py, sep, feature = m[7], m[8], m[9], m[10]
                write_point(
                    k,
                    a,
                    b,
                    px,
                    py,
                    m[1],
                    m[2],
                    sep,
                    feature,
                    key,
                    mu,
                    e,
                    out_a,
                    out_b,
                    out_p,
                    out_n,
                    out_s,
                    out_f,
                    out_key,
                    out_mu,
                    out_e,
                )
                new_anchor[k, 0] = out_r[k, 0] = px - x[a, 0]
                new_anchor[k, 1] = out_r[k, 1] = py - x[a, 1]
                new_anchor[k, 2] = out_r[k, 2] = px - x[b, 0]
                new_anchor[k, 3] = out_r[k, 3] = py - x[b, 1]
                new_normal[k, 0] = m[1]
                new_normal[k, 1] = m[2]
                new_separation[k] = sep
                new_feature[k] = feature
                k += 1
            px, py = relative_position(a, b, x, rotation)
            new_pose[n_new, 0] = px
            new_pose[n_new, 1] = py
            new_rotation[n_new, 0] = rotation[a, 0]
            new_rotation[n_new, 1] = rotation[a, 1]
            new_rotation[n_new, 2] = rotation[b, 0]
            new_rotation[n_new, 3] = rotation[b, 1]
        if k > new_start[n_new]:  # a pair with points: cache its manifold
            new_key[n_new] = key
            n_new += 1
    pair_start[n_pairs] = k
    new_start[n_new] = k
    return k, n_new, n_recycled


@njit(cache=True)
def ascending(key, n):
    """True if key[0] < key[1] < ... < key[n - 1]: the manifolds are already in look-up order."""
    for m in range(1, n):
        if key[m] <= key[m - 1]:
            return False
    return True


@njit(cache=True)
def points_in_order(start, order, new_start):
    """The points of manifolds order[0], order[1], ... (indices), and each one's first in new_start."""
    points = np.empty(start[order.shape[0]] if order.shape[0] else 0, np.int64)
    n = 0
    for m in range(order.shape[0]):
        new_start[m] = n
        for point in range(start[order[m]], start[order[m] + 1]):
            points[n] = point
            n += 1
    new_start[order.shape[0]] = n
    return points[:n]


class ManifoldCache:
    """Last step's manifolds, kept for recycling (the world owns one)."""

    def __init__(self) -> None:
        self._sets: list[tuple | None] = [None, None]  # the buffers ``collide`` writes into (``_buffers``)
        self.clear()

    def clear(self) -> None:
        """Forget every manifold: the next step collides every pair anew."""
        self.key = np.zeros(0, np.int64)
        self.start = np.zeros(1, np.int64)
        self.pose = np.zeros((0, 2))  # B's centre in A's frame (m)
        self.rotation = np.zeros((0, 4))  # (cos, sin) of A's and of B's angle
        self.anchor = np.zeros((0, 4))
        self.normal = np.zeros((0, 2))
        self.separation = np.zeros(0)
        self.feature = np.zeros(0, np.int32)
        self.recycled = 0  # manifolds recycled in the last step

    _STATE = ("key", "start", "pose", "rotation", "anchor", "normal", "separation", "feature", "recycled")

    def state(self) -> tuple:
        """What ``restore`` needs to undo a step (``collide`` replaces the arrays, never edits them):
        the attributes of ``_STATE``, in its order."""
        return (*self._cached(), self.recycled)

    def _cached(self) -> tuple:
        """The cached manifolds' arrays, in ``collide_recycling``'s argument order."""
        return (self.key, self.start, self.pose, self.rotation, self.anchor, self.normal, self.separation, self.feature)

    def restore(self, state: tuple) -> None:
        for name, value in zip(self._STATE, state):
            setattr(self, name, value)

    def _buffers(self, n_pairs: int) -> tuple:
        """Room for n_pairs manifolds (2 n_pairs points) to collide into: kept from step to step,
        two sets taken in turn, never the set the cache's arrays (read during ``collide``) live in."""
        sets = self._sets
        s = 1 if sets[0] is not None and self.key.base is sets[0][0] else 0
        current = sets[s]
        if current is None or current[0].shape[0] < n_pairs:
            size = max(n_pairs, 64)
            cap = 2 * size
            current = (
                np.zeros(size, np.int64),
                np.zeros(size + 1, np.int64),
                np.zeros((size, 2)),
                np.zeros((size, 4)),
                np.zeros((cap, 4)),
                np.zeros((cap, 2)),
                np.zeros(cap),
                np.zeros(cap, np.int32),
            )
            sets[s] = current
        return current

    def collide(
        self,
        pairs,
        n_pairs,
        bodies,
        rotation,
        world_v,
        world_n,
        contact_margin,
        travel,
        recycle_distance,
        out,
        pair_start,
    ) -> int:
        """The step's contact points into ``out`` (as ``collide_pairs``); returns K.
        rotation: each body's (cos theta, sin theta), as ``update_geometry_in`` returns it."""
        b = bodies
        new = self._buffers(n_pairs)
        k, n_new, self.recycled = collide_recycling(  # type: ignore[call-arg]
            pairs,
            n_pairs,
            b.x,
            rotation,
            b.kind,
            b.radius,
            b.vstart,
            b.vcount,
            b.local_v,
            b.static,
            world_v,
            world_n,
            contact_margin,
            travel,
            b.uid,
            b.friction,
            b.restitution,
            recycle_distance,
            *self._cached(),
            *out,
            pair_start,
            *new,
        )
        key, start, pose, cached_rotation, anchor, normal, separation, feature = new
        if ascending(key, n_new):  # pairs come sorted by (a, b), so their keys ascend: keep them as they are
            self.key, self.start, self.pose = key[:n_new], start[: n_new + 1], pose[:n_new]
            self.rotation = cached_rotation[:n_new]
            self.anchor, self.normal, self.separation, self.feature = (
                anchor[:k],
                normal[:k],
                separation[:k],
                feature[:k],
            )
            return k
        # sorted by pair key for the next step's look-up; points follow their manifolds
        by_key = np.argsort(key[:n_new], kind="stable")
        self.start = np.zeros(n_new + 1, np.int64)
        points = points_in_order(start, by_key, self.start)
        self.key = key[:n_new][by_key]
        self.pose = pose[:n_new][by_key]
        self.rotation = cached_rotation[:n_new][by_key]
        self.anchor = anchor[points]
        self.normal = normal[points]
        self.separation = separation[points]
        self.feature = feature[points]
        return k
