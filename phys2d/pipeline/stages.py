"""The stages of one tick, written once: ``before_solve`` and ``after_solve``, each one kernel.

    before_solve   begin      keep what an undo needs, V += dt M^-1 F_ext (damped), the geometry now
                   pairs      the broadphase's pairs anew when a body left its fat box, in the
                              responder's visit order (``constraints.order``)
                   collide    manifolds recycled or found (``collision.recycle``), sorted by key,
                              and the order the responder visits the contacts in
                   rows       the contact rows J, A_kk, xi, bounds, warm started from the cache
                              (``constraints.rows``), then the joints' rows
    the solve      the responder's: a kernel in the one-call tick (``pipeline.tick``), or a
                   Python ``respond`` stage by stage (``pipeline.step``)
    after_solve    limits     no body past max_speed, no impulse or residual not finite
                   cache      lambda per contact, and the cache the next step starts from

Every stage takes the step's context (``records.TickContext``) and the step's settings
(``StepSettings``); the two kernels also take what Python keeps between steps (``Counts``)
and hand back what the step did (``TickResult``), both with named fields.

When a buffer is short (the pairs, the contact buffers, the manifold store) ``before_solve``
stops and says so; Python grows it and calls again, resuming where it stopped
(``Counts.resume``): the forces are not applied twice.

Double buffers: the contacts come in two sides (``TickContext.sides``). A step reads the side
the last good step wrote (its cache, its manifolds' keys) and writes the other; only a step
that succeeds makes its side current, so one that fails leaves the last good step as it was.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..collision.broadphase import find_pairs, update_geometry_on
from ..collision.recycle import collide_recycling_on, has_room
from ..collision.sort import stable_argsort
from ..constraints.joints import start_joint_rows
from ..constraints.order import PAIR_ORDER, order_pairs, solve_order
from ..constraints.rows import RowSettings, contact_rows
from ..contacts import impulses_to_contacts_and_cache
from ..integrate import apply_external_forces, first_too_fast
from ..jit import njit
from .records import RowRecord

# TickResult.status
OK = 0
NEED_PAIRS = 1  # the pair buffer is short: Python grows it (to TickResult.n_pairs) and resumes at SWEEP
TOO_FAST = 2  # a body ended the step past max_speed or not finite: undo and raise
NEED_ROOM = 3  # the manifold store or the contact buffers are short: Python makes room, resumes at COLLIDE
BAD_STATE = 4  # a body's x, theta, V or M^-1, as written between steps, cannot be stepped: refused, nothing changed
NOT_FINITE = 5  # the solve left a non-finite impulse or residual: undo and refuse

# Counts.resume: where before_solve starts
START = 0  # a new step: begin
SWEEP = 1  # begun: the pairs anew
COLLIDE = 2  # begun, the pairs found: collide


class StepSettings(NamedTuple):
    """What the world and the responder set for a step, as the stages read it."""

    gravity: np.ndarray  # (2,) m/s^2
    dt: float  # s
    contact_margin: float  # m
    recycle_distance: float  # m
    max_speed: float  # m/s or rad/s
    rows: RowSettings  # how the contact rows are built (``constraints.rows``)


class Counts(NamedTuple):
    """What Python keeps of the last good step (on side ``side``), the pairs now, and where to start."""

    side: int  # the side of the buffers the last good step wrote
    n_pairs: int  # the broadphase's pairs
    manifolds: int  # the manifolds cached on that side
    contacts: int  # its contacts (the cache)
    rows_used: int  # the manifold store's rows taken
    points_used: int  # and its points
    visit: int  # the order the responder visits the pairs in (``constraints.order``)
    ordered: int  # the order the pair buffer holds them in now
    sweep_again: bool  # the bodies or joints changed: sweep whether or not a body left its fat box
    resume: int  # START, SWEEP or COLLIDE


class TickResult(NamedTuple):
    """What a step did (``before_solve``, ``after_solve``, ``tick``)."""

    status: int  # OK or why it stopped
    side: int  # the side of the contact buffers the step writes
    n_pairs: int  # the broadphase's pairs (with NEED_PAIRS: the room they need)
    ordered: int  # the order the pair buffer holds them in
    contacts: int  # K, the step's contact points
    manifolds: int  # the manifolds found or recycled
    recycled: int  # of which recycled
    rows_used: int  # the manifold store's rows taken after the step
    points_used: int  # and its points
    hits: int  # contacts warm started from the cache
    deepest: float  # the deepest overlap at collision time, m
    solved: int  # the solve's sweeps or sub-steps


@njit(cache=True, inline="always")
def result(status, counts, n_pairs, ordered):
    """A TickResult that stopped before the contacts (status), the pairs as they are."""
    return TickResult(
        status, 1 - counts.side, n_pairs, ordered, 0, 0, 0, counts.rows_used, counts.points_used, 0, 0.0, 0
    )


@njit(cache=True, inline="always")
def flat(r):
    """``r``'s fields as a plain tuple, in TickResult's order: what the one-call tick hands back to
    Python (a tuple crosses into Python for a fifth of what a named tuple costs;
    ``TickResult._make`` names its fields again)."""
    return (
        r.status, r.side, r.n_pairs, r.ordered, r.contacts, r.manifolds, r.recycled, r.rows_used, r.points_used,
        r.hits, r.deepest, r.solved,
    )  # fmt: skip


@njit(cache=True, inline="always")
def with_status(r, status, count):
    """``r`` with another status and the solve's count."""
    return TickResult(
        status, r.side, r.n_pairs, r.ordered, r.contacts, r.manifolds, r.recycled, r.rows_used, r.points_used, r.hits,
        r.deepest, count,
    )  # fmt: skip


# -- before the solve ----------------------------------------------------------------------------
@njit(cache=True)
def before_solve(ctx, settings, counts):
    """The stages before the solve: begin, the pairs, collide, the rows. Stops (TickResult.status)
    when the state written between steps cannot be stepped (BAD_STATE, nothing changed), or
    when a buffer is short (NEED_PAIRS, NEED_ROOM): Python makes room and calls again with
    ``counts.resume`` where it stopped."""
    return before_solve_rows(ctx, settings, counts)[0]


@njit(cache=True)
def before_solve_rows(ctx, settings, counts):
    """``before_solve``, and the step's rows it wrote (``rows_of``; the whole buffers when it
    stopped): the one-call tick hands them on to the solve."""
    n_pairs, ordered = counts.n_pairs, counts.ordered
    if counts.resume == START:
        if first_bad_body(ctx) >= 0:
            return result(BAD_STATE, counts, n_pairs, ordered), ctx.rows
        fits = begin(ctx, settings)
        if counts.sweep_again or not fits:
            n_pairs, ordered = -1, PAIR_ORDER  # (swept below)
    if n_pairs < 0 or counts.resume == SWEEP:
        n_pairs, ordered = pairs(ctx, counts.visit)
        if n_pairs < 0:
            return result(NEED_PAIRS, counts, -n_pairs, PAIR_ORDER), ctx.rows
    if n_pairs > ctx.shapes.pair_order.shape[0] or not store_has_room(ctx, counts, n_pairs):
        return result(NEED_ROOM, counts, n_pairs, ordered), ctx.rows
    if ordered != counts.visit:
        ordered = in_visit_order(ctx, n_pairs, counts.visit)
    k, n_new, recycled, rows_used, points_used = collide(ctx, settings, counts, n_pairs)
    step_rows = rows_of(ctx, k)
    deepest, hits = rows(ctx, settings, counts, k, step_rows)
    done = TickResult(
        OK, 1 - counts.side, n_pairs, ordered, k, n_new, recycled, rows_used, points_used, hits, deepest, 0
    )
    return done, step_rows


@njit(cache=True, inline="always")
def first_bad_body(ctx):
    """The first body whose state, as written between steps (``w.x``, ``w.theta``, ``w.V``,
    ``w.M_inv``), a step cannot take: not finite, M^-1 < 0, or M^-1 > 0 on a body of infinite
    mass (static, kinematic or asleep); -1 when every body is fine."""
    x, theta, V, M_inv, static = ctx.bodies.x, ctx.bodies.theta, ctx.bodies.V, ctx.bodies.M_inv, ctx.shapes.static
    for i in range(x.shape[0]):
        if not (np.isfinite(x[i, 0]) and np.isfinite(x[i, 1]) and np.isfinite(theta[i])):
            return i
        for c in range(3):
            m = M_inv[i, c]
            if not (np.isfinite(V[i, c]) and 0.0 <= m < np.inf) or (static[i] and m != 0.0):  # NaN fails too
                return i
    return -1


@njit(cache=True, inline="always")
def begin(ctx, settings):
    """Keep x and theta to undo (and V as V1, the velocity the tick began with), add the
    external forces to V, and update the geometry (on the context's threads); returns whether
    last step's pairs still hold (every tight box inside its fat box)."""
    b = ctx.bodies
    x, theta, V, V1, undo_x, undo_theta = b.x, b.theta, b.V, b.V1, ctx.undo_x, ctx.undo_theta
    for i in range(x.shape[0]):  # loops, not slice copies: those compile a shape check with its message
        undo_x[i, 0], undo_x[i, 1], undo_theta[i] = x[i, 0], x[i, 1], theta[i]
        V1[i, 0], V1[i, 1], V1[i, 2] = V[i, 0], V[i, 1], V[i, 2]
    apply_external_forces(b.V, b.M_inv, ctx.forces, settings.gravity, settings.dt)
    return update_geometry_on(ctx.threads, b, ctx.shapes, settings.dt, settings.contact_margin)


@njit(cache=True, inline="always")
def pairs(ctx, visit):
    """The broadphase's pairs anew (``collision.broadphase.find_pairs``), in the order the
    responder visits them (``in_visit_order``). Returns (their count, the order they are in), or
    (minus the room needed, PAIR_ORDER) when they would not fit the pair buffer."""
    n_pairs = find_pairs(ctx.shapes)
    if n_pairs < 0 or n_pairs > ctx.shapes.pair_order.shape[0]:
        return n_pairs, PAIR_ORDER
    return n_pairs, in_visit_order(ctx, n_pairs, visit)


@njit(cache=True, inline="always")
def in_visit_order(ctx, n_pairs, visit):
    """The pairs' visit order (``pair_order``, and each body's ``part``, from the centres x:
    ``constraints.order.order_pairs``); in pair order, none. Returns the order they are in."""
    shapes = ctx.shapes
    if visit != PAIR_ORDER:
        ordered = order_pairs(shapes.pairs, n_pairs, shapes.static, ctx.bodies.x, shapes.part, visit)
        pair_order = shapes.pair_order
        for p in range(n_pairs):
            pair_order[p] = ordered[p]
    return visit


@njit(cache=True, inline="always")
def store_has_room(ctx, counts, n_pairs):
    """Whether the manifold store has room for a new manifold per pair (Python makes it if not)."""
    store = ctx.store
    return has_room(store.found_pose.shape[0], counts.rows_used, store.anchor.shape[0], counts.points_used, n_pairs)


@njit(cache=True, inline="always")
def collide(ctx, settings, counts, n_pairs):
    """Collision -> contacts: each pair's manifold recycled or found, into the side the last step
    did not write; then the manifolds sorted by key for the next step's look-up, and the order
    the responder visits the contacts in. Returns (K contacts, manifolds, recycled, the store's
    rows and points used)."""
    old, new = ctx.sides[counts.side], ctx.sides[1 - counts.side]
    now = (n_pairs, counts.manifolds, counts.rows_used, counts.points_used)
    margins = (settings.contact_margin, settings.recycle_distance, settings.dt)
    k, n_new, recycled, rows_used, points_used, ascends = collide_recycling_on(
        ctx.threads, ctx.bodies, ctx.shapes, ctx.store, old, new, now, margins, ctx.rounded
    )
    if not ascends:  # pairs come sorted by (a, b), so their keys ascend; if not, sort for the look-up
        manifold_key, manifold_row = new.manifold_key, new.manifold_row
        by_key = stable_argsort(manifold_key[:n_new])
        keys, store_rows = manifold_key[:n_new].copy(), manifold_row[:n_new].copy()
        for i in range(n_new):
            manifold_key[i], manifold_row[i] = keys[by_key[i]], store_rows[by_key[i]]
    order = new.order
    if counts.visit != PAIR_ORDER:  # the pairs' order, point by point
        in_order = solve_order(ctx.shapes.pair_order[:n_pairs], new.pair_start[: n_pairs + 1])
        for q in range(k):
            order[q] = in_order[q]
    else:
        for q in range(k):
            order[q] = q
    return k, n_new, recycled, rows_used, points_used


@njit(cache=True, inline="always")
def rows(ctx, settings, counts, k, step_rows):
    """Contacts and cache -> constraint rows: the K contacts' rows into ``step_rows``
    (``rows_of``), warm started from the cache the last step left
    (``constraints.rows.contact_rows``), then the joints' rows. Returns (the deepest overlap m,
    the contacts warm started)."""
    old, new = ctx.sides[counts.side], ctx.sides[1 - counts.side]
    kc = counts.contacts
    cache = (old.key[:kc], old.cache_lambda_n[:kc], old.cache_lambda_t[:kc], old.cache_pushed[:kc])
    deepest, hits = contact_rows(ctx.bodies, ctx.shapes, cache, new, step_rows, settings.rows, ctx.threads)
    joint_rows(ctx.joints, ctx, settings, k, step_rows)
    return deepest, hits


@njit(cache=True)
def joint_rows(joints, ctx, settings, k, step_rows):
    """The joints' rows after the K contacts' (none in a world without joints: ``joints`` None)."""
    if joints is not None:
        r = settings.rows
        start_joint_rows(joints, 2 * k, ctx.bodies, settings.dt, r.beta, r.warm_start, step_rows)


@njit(cache=True, inline="always")
def rows_of(ctx, k):
    """The step's rows: the first 2 K + joint rows of the row buffers, and the K contacts' row map."""
    n = 2 * k + n_joint_rows(ctx.joints)
    r = ctx.rows
    return RowRecord(
        r.normal_row[:k], r.friction_row[:k], r.body_a[:n], r.body_b[:n], r.J[:n], r.JM[:n], r.A_kk[:n], r.xi[:n],
        r.push[:n], r.bounce[:n], r.impact[:n], r.lo[:n], r.hi[:n], r.bound_row[:n], r.mu[:n], r.lam[:n],
    )  # fmt: skip


@njit(cache=True)
def n_joint_rows(joints):
    """The joints' rows (0 without joints)."""
    if joints is None:
        return 0
    return joints.lam.shape[0]


# -- after the solve ------------------------------------------------------------------------------
@njit(cache=True)
def after_solve(ctx, settings, before, count):
    """The stages after the solve of ``count`` sweeps or sub-steps: the limits (TOO_FAST: a body
    past max_speed or not finite; NOT_FINITE: an impulse, or one of the ``count`` residuals, not
    finite; Python undoes the step), then lambda per contact and the cache the next step starts
    from. Returns ``before`` with the status and the count."""
    status = limits(ctx, settings, before.side, before.contacts, count)
    if status == OK:
        cache(ctx, before)
    return with_status(before, status, count)


@njit(cache=True, inline="always")
def limits(ctx, settings, side, k, count):
    """OK, TOO_FAST or NOT_FINITE (``after_solve``) for a step of K contacts and ``count`` residuals
    (on ``side``, the side it writes)."""
    b = ctx.bodies
    if first_too_fast(b.V, b.x, b.theta, settings.max_speed) >= 0:
        return TOO_FAST
    if not (all_finite(ctx.rows.lam[: 2 * k + n_joint_rows(ctx.joints)]) and all_finite(ctx.residuals[side, :count])):
        return NOT_FINITE
    return OK


@njit(cache=True, inline="always")
def all_finite(values):
    """Whether every value is finite (a responder's impulses lambda, its residuals)."""
    for v in values:
        if not np.isfinite(v):
            return False
    return True


@njit(cache=True, inline="always")
def cache(ctx, before):
    """Each contact's lambda_n, lambda_t read off its rows, and what the cache keeps of them, on
    the side this step wrote (``contacts.impulses_to_contacts_and_cache``)."""
    k = before.contacts
    impulses_to_contacts_and_cache(ctx.rows, ctx.sides[before.side], k, ctx.threads)  # (rows at capacity: K read)
