"""Restitution at impact: the pass that bounces the points that hit, once positions have moved.

The rows (``constraints.rows``) give each contact point a bounce target, -e vn, where
vn is its approach speed at impact (``approach_at_impact``) and exceeds the
restitution threshold. The solve itself never bounces: a point still apart closes its
gap and no more, so the bodies move up to the surface. Then this pass drives
J_k V to the bounce target, for the points that pushed in the solve only: a point
that did not reach its partner never bounces, so bodies turn round where they meet.
This is Box2D v3's restitution step, after the positions moved, for the points that
were still apart when the step began; a touching point bounces within the solve, as
the lecture has it (xi = max(xi, bounce)). Along one row, the landing impulse and the
bounce add up to the lecture's -(1 + e) J V / A_kk; but the landing moved the bodies
with a velocity they no longer have, so (like any position correction) it keeps linear
momentum and the centre of mass, not angular momentum about a fixed point.
"""

from __future__ import annotations

import numpy as np

from ..constraints.rows import MET, apply_row_impulse, clamp_accumulated, row_velocity
from ..integrate import integrate_positions
from ..jit import njit
from ..pipeline.records import record_of_rows
from .base import StepContext


@njit(cache=True)
def bouncing_contacts(rows, separation, V, dt):
    """True for each contact with a bounce target that met its partner in this step's solve:
    it pushed, or its gap C closes with the solve's velocities (C + dt J V <= MET; this way
    the answer does not hang on how a converged solve shared lambda among redundant rows).
    ``separation``: (K,) each contact's C (m), in row order."""
    normal_row, body_a, body_b, J, A_kk, bounce, lam = (
        rows.normal_row, rows.body_a, rows.body_b, rows.J, rows.A_kk, rows.bounce, rows.lam
    )  # fmt: skip
    out = np.zeros(normal_row.shape[0], np.bool_)
    for q in range(normal_row.shape[0]):
        k = normal_row[q]
        if bounce[k] > 0.0 and A_kk[k] > 0.0:
            out[q] = lam[k] > 0.0 or separation[q] + dt * row_velocity(k, body_a[k], body_b[k], J, V) <= MET
    return out


@njit(cache=True)
def restitution_pass(rows, bouncing, V, iterations, tolerance):
    """Restitution, once positions have moved: sweep the bouncing contacts' normal rows towards
    J_k V = bounce_k (lambda_n >= 0), keeping each one's Coulomb friction inside mu lambda_n.

    Only points that pushed bounce, so a point still apart at the end of the step never
    does: it turns round at the surface. Returns the sweeps made.
    """
    normal_row, friction_row, body_a, body_b, J, JM, A_kk = (
        rows.normal_row, rows.friction_row, rows.body_a, rows.body_b, rows.J, rows.JM, rows.A_kk
    )  # fmt: skip
    bounce, bound_row, mu, lam = rows.bounce, rows.bound_row, rows.mu, rows.lam
    n_contacts = normal_row.shape[0]
    if not bouncing.any():
        return 0
    for s in range(iterations):
        worst = 0.0
        for q in range(n_contacts):
            if not bouncing[q]:
                continue
            k, kt = normal_row[q], friction_row[q]
            a, b = body_a[k], body_b[k]
            d = clamp_accumulated(lam, k, (bounce[k] - row_velocity(k, a, b, J, V)) / A_kk[k], 0.0, np.inf)
            apply_row_impulse(k, a, b, JM, d, V)
            worst = max(worst, abs(d) * A_kk[k])
            if bound_row[kt] >= 0:  # a smaller lambda_n shrinks the cone: pull friction back inside
                top = mu[kt] * lam[k]
                d = min(max(lam[kt], -top), top) - lam[kt]
                lam[kt] += d
                apply_row_impulse(kt, a, b, JM, d, V)
        if worst <= tolerance:
            return s + 1
    return iterations


def bounce_after_moving(ctx: StepContext, V_move: np.ndarray, iterations: int, tolerance: float) -> None:
    """Move the positions with V_move (m/s), then bounce the points that met their partner within
    the step (``restitution_pass`` on ctx.V and ctx.rows.lam; PGS in both forms)."""
    rows = record_of_rows(ctx.rows)
    bouncing = bouncing_contacts(rows, ctx.separation, ctx.V, ctx.dt)
    integrate_positions(ctx.x, ctx.theta, V_move, ctx.dt)
    restitution_pass(rows, bouncing, ctx.V, iterations, tolerance)
