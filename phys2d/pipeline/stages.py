"""The stages of one tick that belong to no other module, and what they share.

A tick, as ``pipeline.step.tick`` runs it (and ``Pipeline`` stage by stage, calling the
same functions with the same records):

    begin                 keep what an undo needs, V += dt M^-1 F_ext (damped), the geometry now
    sweep                 the broadphase's pairs anew, when a body left its fat box
    collide_recycling     manifolds recycled or found (``collision.recycle``)
    order_contacts        the manifolds sorted for the next look-up, the solve order
    contact_rows          the rows J, A_kk, xi, bounds, warm started (``constraints.rows``)
    start_joint_rows      the joints' rows (``constraints.joints``)
    the responder         PGS (``pgs_step``), the soft step, or a ``respond`` in Python
    impulses_to_contacts_and_cache   lambda per contact, and the cache (``contacts``)

Double buffers: the contacts come in two sides (``StepState.sides``). A step reads the side
the last good step wrote (its cache, its manifolds' keys) and writes the other; only a step
that succeeds makes its side current, so one that fails leaves the last good step as it was.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from ..collision.broadphase import find_pairs, update_geometry_on
from ..collision.sort import stable_argsort
from ..constraints.order import PAIR_ORDER, order_pairs, solve_order
from ..integrate import apply_external_forces
from .records import RowRecord

OK = 0
NEED_SWEEP = 1  # a body left its fat box (or the bodies changed): sweep, then go on at stage 1
TOO_FAST = 2  # a body ended the step past max_speed or not finite: undo and raise
NEED_ROOM = 3  # the manifold store has no room for this step's new manifolds: make it, then go on at stage 1
BAD_STATE = 4  # a body's x, theta, V or M^-1, as written between steps, cannot be stepped: refuse, nothing changed
NOT_FINITE = 5  # the responder left a non-finite impulse or residual: undo and refuse


class StepSettings(NamedTuple):
    """What the world sets for a step."""

    gravity: np.ndarray  # (2,) m/s^2
    g: float  # |gravity|, m/s^2 (the lecture's friction bound)
    dt: float  # s
    contact_margin: float  # m
    recycle_distance: float  # m
    max_speed: float  # m/s or rad/s


class Counts(NamedTuple):
    """What Python keeps of the last good step (side ``side``), and the pairs now."""

    side: int  # the side of the buffers the last good step wrote
    n_pairs: int  # the broadphase's pairs
    manifolds: int  # the manifolds cached on that side
    contacts: int  # its contacts (the cache)
    rows_used: int  # the manifold store's rows taken
    points_used: int  # and its points
    visit: int  # the order the responder visits the pairs in (``constraints.order``)
    sweep_again: bool  # the bodies or joints changed: Python sweeps


@njit(cache=True)
def head_of_rows(rows, k, n):
    """The first n rows (and K contacts' row map) of the row buffers: the step's rows."""
    return RowRecord(
        rows.normal_row[:k], rows.friction_row[:k], rows.body_a[:n], rows.body_b[:n], rows.J[:n], rows.JM[:n],
        rows.A_kk[:n], rows.xi[:n], rows.push[:n], rows.bounce[:n], rows.impact[:n], rows.lo[:n], rows.hi[:n],
        rows.bound_row[:n], rows.mu[:n], rows.lam[:n],
    )  # fmt: skip


@njit(cache=True)
def first_bad_body(x, theta, V, M_inv, static):
    """The first body whose state, as written between steps (``w.x``, ``w.theta``, ``w.V``,
    ``w.M_inv``), a step cannot take: not finite, M^-1 < 0, or M^-1 > 0 on a body of infinite
    mass (``static``: static, kinematic or asleep); -1 when every body is fine."""
    for i in range(x.shape[0]):
        if not (np.isfinite(x[i, 0]) and np.isfinite(x[i, 1]) and np.isfinite(theta[i])):
            return i
        for c in range(3):
            m = M_inv[i, c]
            if not (np.isfinite(V[i, c]) and 0.0 <= m < np.inf) or (static[i] and m != 0.0):  # NaN fails too
                return i
    return -1


@njit(cache=True)
def all_finite(values, n):
    """Whether values[:n] are all finite (a responder's impulses lambda, its residuals)."""
    for k in range(n):
        if not np.isfinite(values[k]):
            return False
    return True


@njit(cache=True)
def begin(s, gravity, dt, margin, threads):
    """Keep x and theta to undo (and V as V1, the velocity the tick began with), add the
    external forces to V, and update the geometry (on ``threads``, or one thread when None);
    returns whether last step's pairs still hold (every tight box inside its fat box)."""
    b = s.bodies
    for i in range(b.x.shape[0]):  # loops, not slice copies: those compile a shape check with its message
        s.undo_x[i, 0], s.undo_x[i, 1], s.undo_theta[i] = b.x[i, 0], b.x[i, 1], b.theta[i]
        b.V1[i, 0], b.V1[i, 1], b.V1[i, 2] = b.V[i, 0], b.V[i, 1], b.V[i, 2]
    apply_external_forces(b.V, b.M_inv, s.forces, gravity, dt)
    return update_geometry_on(threads, b, s.shapes, dt, margin)


@njit(cache=True)
def sweep(shapes, x, visit):
    """The broadphase's pairs anew (``collision.broadphase.find_pairs``), put in the order the
    responder visits them in (``pair_order``, and the bodies' ``part``, from their centres x:
    ``constraints.order.order_pairs``) unless that is pair order. Returns their count, or minus
    the room needed when they would not fit the pair buffer: then Python grows it."""
    n_pairs = find_pairs(shapes)
    if visit != PAIR_ORDER and 0 <= n_pairs <= shapes.pair_order.shape[0]:
        ordered = order_pairs(shapes.pairs, n_pairs, shapes.static, x, shapes.part, visit)
        for p in range(n_pairs):
            shapes.pair_order[p] = ordered[p]
    return n_pairs


@njit(cache=True)
def in_row_order(values, order, k):
    """values[order[q]] for q < k: a per-contact array gathered into row order (row pair q is
    contact order[q])."""
    out = np.empty(k)
    for q in range(k):
        out[q] = values[order[q]]
    return out


@njit(cache=True)
def order_contacts(shapes, found, n_pairs, counts, visit):
    """After ``collide_recycling``: the step's manifolds sorted by key for the next step's look-up
    (when they do not ascend already), and the order the responder visits the contacts in: its
    pairs' (``pair_order``: by part, then colour) or pair order (``constraints.order``). counts =
    (K contacts, manifolds, whether their keys ascend)."""
    k, n_new, ascends = counts
    if not ascends:  # pairs come sorted by (a, b), so their keys ascend; if not, sort for the look-up
        by_key = stable_argsort(found.manifold_key[:n_new])
        keys, rows = found.manifold_key[:n_new].copy(), found.manifold_row[:n_new].copy()
        for i in range(n_new):
            found.manifold_key[i], found.manifold_row[i] = keys[by_key[i]], rows[by_key[i]]
    if visit != PAIR_ORDER:
        in_order = solve_order(shapes.pair_order[:n_pairs], found.pair_start[: n_pairs + 1])
        for q in range(k):
            found.order[q] = in_order[q]
    else:
        for q in range(k):
            found.order[q] = q
