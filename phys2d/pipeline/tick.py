"""One tick in one compiled call: the stages before the solve, the responder's solve, the stages after.

    collision -> contacts and cache -> constraint rows -> responder -> integration -> cache

``Pipeline`` (``pipeline.step``) calls ``tick`` for a responder whose solve is a kernel
(``Responder.kernel``: PGS in impulse form, the soft step); for any other it calls the same
``before_solve`` and ``after_solve`` from Python, with the responder's ``respond`` between them.
"""

from __future__ import annotations

import numpy as np

from ..jit import njit
from ..responders.pgs import pgs_step
from ..responders.soft_step import soft_step_solve
from .stages import OK, after_solve, before_solve_rows, flat


@njit(cache=True)
def tick(ctx, settings, solver, counts):
    """One tick: ``before_solve`` (with its rows), the solve ``solver`` names (``context.Solver``), ``after_solve``.
    Returns the step's ``TickResult`` as a plain tuple (``stages.flat``); a status other than OK
    says why it stopped (Python makes room and calls again, or undoes the step)."""
    before, rows = before_solve_rows(ctx, settings, counts)
    if before.status != OK:
        return flat(before)
    count = solve(ctx, settings.dt, solver.pgs, solver.soft, ctx.threads, before, rows)
    return flat(after_solve(ctx, settings, before, count))


@njit(cache=True)
def solve(ctx, dt, pgs, soft, threads, before, rows):
    """The responder's solve of the step's rows (``stages.rows_of``): PGS's (``pgs_step``) when
    ``pgs`` holds its settings, the soft step's (``soft_step_solve``) when ``soft`` does; the
    other is None, and numba compiles only the one given. On one thread (threads None), or on
    ``threads`` with each body's part of the solve order (``pipeline.parallel``). Returns its
    sweeps or sub-steps."""
    k, found, b, joints = before.contacts, ctx.sides[before.side], ctx.bodies, ctx.joints
    residuals = ctx.residuals[before.side]  # (the residuals of the side it writes)
    if pgs is not None:
        separation = in_row_order(found.separation, found.order, k)
        if threads is None:  # (numba compiles one branch: the other's threads has another type)
            return pgs_step(b, rows, separation, dt, pgs, residuals, joints, None)
        return pgs_step(b, rows, separation, dt, pgs, residuals, joints, (threads, ctx.shapes.part))
    if soft is not None:
        contacts = (found.order[:k], found.separation[:k], found.restitution[:k])
        if threads is None:
            return soft_step_solve(b, rows, contacts, joints, dt, soft, residuals, None)
        return soft_step_solve(b, rows, contacts, joints, dt, soft, residuals, (threads, ctx.shapes.part))
    return 0


@njit(cache=True, inline="always")
def in_row_order(values, order, k):
    """values[order[q]] for q < k: a per-contact array gathered into row order (row pair q is
    contact order[q])."""
    out = np.empty(k)
    for q in range(k):
        out[q] = values[order[q]]
    return out
