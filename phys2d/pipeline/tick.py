"""One tick in one compiled call: the pipeline's stages in order, in one screen of code.

    collision -> contacts and cache -> constraint rows -> responder -> integration -> cache

``Pipeline`` (``pipeline.step``) calls ``tick`` for PGS in impulse form and the soft step, whose
solves are kernels; for any other responder it calls the same stages one by one from Python,
with the responder's ``respond`` in the place of the solve.
"""

from __future__ import annotations

from numba import njit

from ..collision.recycle import collide_recycling_on, has_room
from ..constraints.joints import start_joint_rows
from ..constraints.rows import contact_rows
from ..contacts import impulses_to_contacts_and_cache
from ..integrate import first_too_fast
from ..responders.pgs import pgs_step
from ..responders.soft_step import soft_step_solve
from .stages import (
    BAD_STATE,
    NEED_ROOM,
    NEED_SWEEP,
    NOT_FINITE,
    OK,
    TOO_FAST,
    all_finite,
    begin,
    first_bad_body,
    head_of_rows,
    in_row_order,
    order_contacts,
    sweep,
)


@njit(cache=True)
def tick(s, joints, stage, counts, step, row_settings, pgs, soft, rounded, threads):
    """One tick in one call, the stages in order; the responder's solve is PGS's (``pgs_step``)
    when ``pgs`` holds its settings, the soft step's (``soft_step_solve``) when ``soft`` does
    (the other is None: numba compiles only the one given). ``rounded`` is True in a world with
    capsules, segments or chains, else None: the collision of those shapes is then not compiled
    either (``narrowphase.manifold``). threads: None on one thread (no parallel code is
    compiled), else the count of threads the pairs are collided, the contact rows built and the
    responder's sweeps solved on (``collide_recycling_on``, ``contact_rows``, ``pipeline.parallel``).

    Stage 0 starts the tick (``begin``); when a body left its fat box it sweeps (``sweep``), or
    returns NEED_SWEEP when the bodies or joints changed or the pairs outgrow the buffers (Python
    sweeps and calls again at stage 1). NEED_ROOM: the manifold store is short of room for a
    new manifold per pair (Python makes it). TOO_FAST: a body ended the step past max_speed
    (Python undoes it). BAD_STATE: a body's state as written between steps cannot be stepped
    (refused before anything changed). NOT_FINITE: the solve left a non-finite impulse or
    residual (Python undoes it). Returns (status, K, manifolds, recycled, rows_used, points_used,
    contacts warm started, deepest overlap m, sweeps or sub-steps, the pairs' count when it
    swept them, else -1).
    """
    n_pairs, swept = counts.n_pairs, -1
    if stage == 0:
        b = s.bodies
        if first_bad_body(b.x, b.theta, b.V, b.M_inv, s.shapes.static) >= 0:  # written between steps: refused
            return BAD_STATE, 0, 0, 0, 0, 0, 0, 0.0, 0, -1
        fits = begin(s, step.gravity, step.dt, step.contact_margin, threads)
        if not fits and not counts.sweep_again:
            swept = n_pairs = sweep(s.shapes, s.bodies.x, counts.visit)
        if counts.sweep_again or n_pairs < 0 or n_pairs > s.shapes.pair_order.shape[0]:
            return NEED_SWEEP, 0, 0, 0, 0, 0, 0, 0.0, 0, -1
    store = s.store
    if not has_room(store.found_pose.shape[0], counts.rows_used, store.anchor.shape[0], counts.points_used, n_pairs):
        return NEED_ROOM, 0, 0, 0, 0, 0, 0, 0.0, 0, swept
    # collision -> contacts: manifolds recycled or found, into the side the last step did not write
    old, new = s.sides[counts.side], s.sides[1 - counts.side]
    now = (n_pairs, counts.manifolds, counts.rows_used, counts.points_used)
    margins = (step.contact_margin, step.recycle_distance, step.dt)
    k, n_new, recycled, rows_used, points_used, ascends = collide_recycling_on(
        threads, s.bodies, s.shapes, store, old, new, now, margins, rounded
    )
    order_contacts(s.shapes, new, n_pairs, (k, n_new, ascends), counts.visit)
    # contacts and cache -> constraint rows
    n = 2 * k + (joints.lam.shape[0] if joints is not None else 0)
    rows = head_of_rows(s.rows, k, n)
    kc = counts.contacts
    cache = (old.key[:kc], old.cache_lambda_n[:kc], old.cache_lambda_t[:kc], old.cache_pushed[:kc])
    deepest, hits = contact_rows(s.bodies, s.shapes, cache, new, rows, row_settings, threads)
    if joints is not None:
        start_joint_rows(joints, 2 * k, s.bodies, step.dt, row_settings.beta, row_settings.warm_start, rows)
    # rows -> responder -> integration
    count = 0
    if pgs is not None:
        separation = in_row_order(new.separation, new.order, k)
        if threads is None:  # (numba compiles one branch: the other's threads has another type)
            count = pgs_step(s.bodies, rows, separation, step.dt, pgs, s.residuals, joints, None)
        else:  # the count and each body's part of the solve order (``pipeline.parallel``)
            count = pgs_step(s.bodies, rows, separation, step.dt, pgs, s.residuals, joints, (threads, s.shapes.part))
    if soft is not None:
        found = (new.order[:k], new.separation[:k], new.restitution[:k])
        if threads is None:
            count = soft_step_solve(s.bodies, rows, found, joints, step.dt, soft, s.residuals, None)
        else:
            count = soft_step_solve(s.bodies, rows, found, joints, step.dt, soft, s.residuals, (threads, s.shapes.part))
    # the limits, then the impulses per contact and the cache the next step starts from
    b = s.bodies
    if first_too_fast(b.V, b.x, b.theta, step.max_speed) >= 0:
        return TOO_FAST, k, n_new, recycled, rows_used, points_used, hits, deepest, count, swept
    if not (all_finite(rows.lam, n) and all_finite(s.residuals, count)):
        return NOT_FINITE, k, n_new, recycled, rows_used, points_used, hits, deepest, count, swept
    impulses_to_contacts_and_cache(rows, new, k, threads)
    return OK, k, n_new, recycled, rows_used, points_used, hits, deepest, count, swept
