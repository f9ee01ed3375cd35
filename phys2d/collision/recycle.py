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
Nor any copying: a manifold is kept in a row of the cache's store (``ManifoldCache``),
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

Fast pairs (whose velocities could carry them further than contact_margin within
the step) are always collided anew, so speculative contacts still see what is
coming; so is a pair that had no points, one whose recycled points would lie
further apart than the narrowphase keeps them, and any pair with a circle (a
rolling circle's point moves over its surface as it turns).
"""

from __future__ import annotations

import operator

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
    row,
    a,
    b,
    x,
    turn,
    margin,
    key,
    mu,
    e,
    span,
    anchor,
    normal,
    separation,
    feature,
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
):
    """Write the points of cached manifold ``row``, moved with their bodies (``recycled_point``), from
    point k on; returns the next k, or -1 if one of them lies beyond ``margin`` (m) of its partner:
    the narrowphase would drop it, so the pair is collided anew (over what was written)."""
    for point in range(span[row, 0], span[row, 1]):
        px, py, sep = recycled_point(point, a, b, x, turn, anchor, normal, separation, feature)
        if sep > margin:
            return -1
        write_point(
            k,
            a,
            b,
            px,
            py,
            normal[point, 0],
            normal[point, 1],
            sep,
            np.int64(feature[point]),  # as the narrowphase's: one write_point
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
        for i in range(4):
            out_r[k, i] = anchor[point, i]  # the lever arms it was found with, unturned
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
    cached_row,
    found_pose,
    found_rotation,
    span,
    anchor,
    normal,
    separation,
    feature,
    rows_used,
    points_used,
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
    new_row,
):
    """As ``narrowphase.collide_pairs``, reusing the cached manifolds that may be recycled.

    rotation: each body's (cos theta, sin theta) now (``update_geometry``). cached_key: last
    step's manifolds' pair keys, ascending; cached_row: each one's row of the manifold store,
    whose rows hold found_pose (B's centre in A's frame, m), found_rotation (both bodies'
    (cos, sin)) and span (its points: span[r, 0] up to span[r, 1] of anchor, normal,
    separation, feature), as the manifold was found. A recycled manifold keeps its row, not
    copied; a new one is appended after rows_used and points_used (room for n_pairs rows and
    2 n_pairs points). new_key, new_row: this step's manifolds, to cache. out_r: each point's
    lever arms (r_a, r_b) for the rows, as its manifold was found.

    Returns (points K, manifolds cached, recycled, rows_used, points_used, whether new_key ascends).
    """
    k = np.int64(0)  # int64 from the start: a literal 0 would compile write_point twice
    n_new = 0
    n_recycled = 0
    ascends = True
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
        margin = contact_margin + travel[a] + travel[b]
        recycled = -1
        row = cached_row[slot] if slot >= 0 else -1
        if slot >= 0:
            turned = turn_since_cached(row, a, b, rotation, found_rotation)
            if may_recycle(row, a, b, x, rotation, extent, found_pose, turned, recycle_distance):
                recycled = recycle_manifold(
                    k,
                    row,
                    a,
                    b,
                    x,
                    turned,
                    margin,
                    key,
                    mu,
                    e,
                    span,
                    anchor,
                    normal,
                    separation,
                    feature,
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
                )
        if recycled >= 0:
            n_recycled += 1
            k = recycled
        else:
            row = rows_used  # a new row of the store, its points after points_used
            m = manifold(a, b, x, kind, radius, vstart, vcount, world_v, world_n, margin)
            if m[0] == 0:
                continue
            p = points_used
            for point in range(m[0]):
                if point == 0:
                    px, py, sep, f = m[3], m[4], m[5], m[6]
                else:
                    px, py, sep, f = m[7], m[8], m[9], m[10]
                write_point(
                    k,
                    a,
                    b,
                    px,
                    py,
                    m[1],
                    m[2],
                    sep,
                    f,
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
                anchor[p, 0] = out_r[k, 0] = px - x[a, 0]
                anchor[p, 1] = out_r[k, 1] = py - x[a, 1]
                anchor[p, 2] = out_r[k, 2] = px - x[b, 0]
                anchor[p, 3] = out_r[k, 3] = py - x[b, 1]
                normal[p, 0] = m[1]
                normal[p, 1] = m[2]
                separation[p] = sep
                feature[p] = f
                k += 1
                p += 1
            found_pose[row, 0], found_pose[row, 1] = relative_position(a, b, x, rotation)
            found_rotation[row, 0] = rotation[a, 0]
            found_rotation[row, 1] = rotation[a, 1]
            found_rotation[row, 2] = rotation[b, 0]
            found_rotation[row, 3] = rotation[b, 1]
            span[row, 0] = points_used
            span[row, 1] = p
            rows_used += 1
            points_used = p
        # a pair with points: cache its manifold
        if n_new > 0 and key <= new_key[n_new - 1]:
            ascends = False
        new_key[n_new] = key
        new_row[n_new] = row
        n_new += 1
    pair_start[n_pairs] = k
    return k, n_new, n_recycled, rows_used, points_used, ascends


@njit(cache=True, inline="always")
def has_room(n_rows, rows_used, n_points, points_used, n_pairs):
    """Whether a manifold store of n_rows rows and n_points points, rows_used and points_used of
    them taken, has room for n_pairs new manifolds (a row and up to 2 points each)."""
    return n_rows - rows_used >= n_pairs and n_points - points_used >= 2 * n_pairs


@njit(cache=True)
def compact(cached_row, found_pose, found_rotation, span, anchor, normal, separation, feature, rows):
    """The store's live rows (cached_row's, in its order) and their points copied into a new store of
    ``rows`` rows and 2 rows points: (found_pose, found_rotation, span, anchor, normal, separation,
    feature, points used). Slot s's row becomes s."""
    n = cached_row.shape[0]
    new_pose = np.zeros((rows, 2))
    new_rotation = np.zeros((rows, 4))
    new_span = np.zeros((rows, 2), np.int64)
    new_anchor = np.zeros((2 * rows, 4))
    new_normal = np.zeros((2 * rows, 2))
    new_separation = np.zeros(2 * rows)
    new_feature = np.zeros(2 * rows, np.int32)
    p = 0
    for s in range(n):  # element by element: a row assigned whole compiles a shape check and its message (~3 s)
        r = cached_row[s]
        new_pose[s, 0], new_pose[s, 1] = found_pose[r, 0], found_pose[r, 1]
        for i in range(4):
            new_rotation[s, i] = found_rotation[r, i]
        new_span[s, 0] = p
        for point in range(span[r, 0], span[r, 1]):
            for i in range(4):
                new_anchor[p, i] = anchor[point, i]
            new_normal[p, 0], new_normal[p, 1] = normal[point, 0], normal[point, 1]
            new_separation[p] = separation[point]
            new_feature[p] = feature[point]
            p += 1
        new_span[s, 1] = p
    return new_pose, new_rotation, new_span, new_anchor, new_normal, new_separation, new_feature, p


class ManifoldCache:
    """Last step's manifolds, kept for recycling (the world owns one).

    key: the manifolds' pair keys, ascending; row: each one's row of the store. The store
    (pose, rotation, span: rows; anchor, normal, separation, feature: points) is written
    only after rows_used and points_used: a manifold recycled from step to step stays in
    its row, and a step that is undone leaves the rows it had.
    """

    def __init__(self) -> None:
        self.clear()

    def clear(self) -> None:
        """Forget every manifold: the next step collides every pair anew."""
        self.key = np.zeros(0, np.int64)
        self.row = np.zeros(0, np.int64)
        self.pose = np.zeros((0, 2))  # B's centre in A's frame when found (m)
        self.rotation = np.zeros((0, 4))  # (cos, sin) of A's and of B's angle when found
        self.span = np.zeros((0, 2), np.int64)  # a row's points: span[r, 0] up to span[r, 1]
        self.anchor = np.zeros((0, 4))
        self.normal = np.zeros((0, 2))
        self.separation = np.zeros(0)
        self.feature = np.zeros(0, np.int32)
        self.rows_used = 0
        self.points_used = 0
        self.recycled = 0  # manifolds recycled in the last step
        self._store_changed()

    _STATE = (
        "key",
        "row",
        "pose",
        "rotation",
        "span",
        "anchor",
        "normal",
        "separation",
        "feature",
        "rows_used",
        "points_used",
        "recycled",
    )

    def state(self) -> tuple:
        """What ``restore`` needs to undo a step: the attributes of ``_STATE``, in its order
        (``collide`` replaces key and row, and writes the store only after rows_used and points_used)."""
        return _read_state(self)

    def restore(self, state: tuple) -> None:
        for name, value in zip(self._STATE, state):
            setattr(self, name, value)
        self._store_changed()

    def _store_changed(self) -> None:
        """The store's arrays as the one-call tick takes them (``phys2d.tick``)."""
        self.store = (self.pose, self.rotation, self.span, self.anchor, self.normal, self.separation, self.feature)

    def live(self) -> tuple:
        """The cached manifolds as arrays, slot by slot (what two equal caches share bit for bit):
        keys, then the rows' pose, rotation and point counts, then the points' anchor, normal,
        separation and feature."""
        rows = self.row
        points = np.concatenate([np.arange(*self.span[r]) for r in rows]) if rows.size else np.zeros(0, np.int64)
        counts = self.span[rows, 1] - self.span[rows, 0]
        return (
            self.key,
            self.pose[rows],
            self.rotation[rows],
            counts,
            self.anchor[points],
            self.normal[points],
            self.separation[points],
            self.feature[points],
            self.recycled,
        )

    def make_room(self, n_pairs: int) -> None:
        """Room in the store for n_pairs new manifolds (2 n_pairs points): if there is not, a new
        store of the live rows only, with room for them twice over and for the new ones."""
        if has_room(self.pose.shape[0], self.rows_used, self.anchor.shape[0], self.points_used, n_pairs):
            return
        self._rebuild(max(64, 2 * (self.key.shape[0] + n_pairs)))

    def _rebuild(self, rows: int) -> None:
        """A new store of ``rows`` rows (2 rows points) holding the live manifolds only, in slot order."""
        n = self.key.shape[0]
        *store, points_used = compact(
            self.row, self.pose, self.rotation, self.span, self.anchor, self.normal, self.separation, self.feature, rows
        )
        self.pose, self.rotation, self.span, self.anchor, self.normal, self.separation, self.feature = store
        self._store_changed()
        self.row = np.arange(n, dtype=np.int64)
        self.rows_used, self.points_used = n, points_used

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
        self.make_room(n_pairs)
        new_key = np.empty(n_pairs, np.int64)
        new_row = np.empty(n_pairs, np.int64)
        k, n_new, self.recycled, self.rows_used, self.points_used, ascends = collide_recycling(  # type: ignore[call-arg]
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
            self.key,
            self.row,
            self.pose,
            self.rotation,
            self.span,
            self.anchor,
            self.normal,
            self.separation,
            self.feature,
            self.rows_used,
            self.points_used,
            *out,
            pair_start,
            new_key,
            new_row,
        )
        self.key, self.row = new_key[:n_new], new_row[:n_new]
        if not ascends:  # pairs come sorted by (a, b), so their keys ascend; if not, sort for the look-up
            by_key = np.argsort(self.key, kind="stable")
            self.key, self.row = self.key[by_key], self.row[by_key]
        return k


_read_state = operator.attrgetter(*ManifoldCache._STATE)  # one C call for the whole tuple, once a step
