"""The lecture's first take: one impulse per colliding pair, then push apart.

For each contact pair once per tick (docs/formulation.md#symbols-arrays-and-units, n from a to b):

    f   = -(1 + e) (J_n V) / (1/m_a + 1/m_b + (r_a x n)^2 / I_a + (r_b x n)^2 / I_b)
    V  += M^-1 J_n^T f                       only if the bodies approach (J_n V < 0)
    f_t = clamp(-(J_t V) / A_t, -mu f, +mu f),  V += M^-1 J_t^T f_t  (a pair still apart: below)
    x_a -= n s w_a / (w_a + w_b),  x_b += n s w_b / (w_a + w_b)   (s: the overlap, w = 1/m)

The last line is the lecture's "push away from interpenetration as long as
interpenetration exists": it is swept over the pairs again while any overlap
remains (``push_apart``), since pushing one pair apart can push a body into its
other neighbour. Each pair's overlap shrinks by at most push_max dt per tick (the
push-out speed bound every responder has).

J_n V = (v_b + omega_b x r_b - v_a - omega_a x r_a) . n is the lecture's relative
normal velocity and the denominator is A_nn = J_n M^-1 J_n^T, so f is the lecture's
formula written with the row of J. The lecture's formula has one collision point
P_0 per pair; a manifold here has up to two, so P_0 is the mean of the pair's
colliding points (its row is the mean of their rows: J is linear in r). A point
is colliding when it overlaps (separation <= 0) or is a speculative point that
approaches fast enough to close its gap within the step (separation + dt J_n V <= 0).

The lecture's pairs are always touching. A pair whose colliding points are all
still apart (by a gap s > 0) only meets its partner within this step, so it gets
the impulse that closes the gap and no more, f = -(J_n V + s/dt) / A_nn; the
positions move up to the surface, and only then is it bounced, from its approach
speed at impact (``bounce_landed``, ``constraints.rows.bounce_target``). So a body
turns round where it meets the other, never in the air. Its friction acts only after
the touch: it may keep the tangential velocity that carries it to where it touches
(``constraints.rows.speculative_friction_target``).

Nothing is remembered between ticks and nothing accumulates: there is no
warm start, no bound on the total impulse, no Baumgarte term, restitution e is
applied at every approach however slow (the lecture's formula has no threshold),
and the push-apart moves positions without touching velocities. Each pair is
solved as if it were alone, so in a stack the impulse that stops one box drives
the box below into its own support: the lecture's "jitters a lot, and does not
support stacking". Joints are not pairs of colliding points: a world with joints
refuses these responders.

The impulses of a pair are reported on its colliding points, shared equally
(``w.contacts.lambda_n`` sums to the pair's f); other points report 0.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..constraints.rows import (
    MET,
    apply_row_impulse,
    approach_at_impact,
    bounce_target,
    row_velocity,
    speculative_friction_target,
)
from ..integrate import integrate_positions
from ..jit import njit
from ..pipeline.records import record_of_rows
from ..validation import Setting, non_negative_float
from .base import Responder, SolveResult, StepContext

PUSH_PASSES = 50  # sweeps of the push-apart at most
PUSH_TOLERANCE = 1e-6  # m: overlap the push-apart leaves alone


def manifold_starts(body_a: np.ndarray, body_b: np.ndarray) -> np.ndarray:
    """(P + 1,) where each pair's points begin in the contact arrays (pairs are contiguous)."""
    k = body_a.shape[0]
    if k == 0:
        return np.zeros(1, np.int64)
    change = np.flatnonzero((body_a[1:] != body_a[:-1]) | (body_b[1:] != body_b[:-1])) + 1
    return np.concatenate(([0], change, [k])).astype(np.int64)


@njit(cache=True)
def colliding_points(rows, separation, V, dt, out):
    """out[c] = True where point c is a collision: overlapping, or closing its gap this step
    (to within MET: a path that ends exactly on the surface, as symmetric flights do, meets it)."""
    normal_row, body_a, body_b, J = rows.normal_row, rows.body_a, rows.body_b, rows.J
    for c in range(separation.shape[0]):
        k = normal_row[c]
        a, b = body_a[k], body_b[k]
        vn = (
            J[k, 0] * V[a, 0]
            + J[k, 1] * V[a, 1]
            + J[k, 2] * V[a, 2]
            + J[k, 3] * V[b, 0]
            + J[k, 4] * V[b, 1]
            + J[k, 5] * V[b, 2]
        )
        out[c] = separation[c] <= 0.0 or separation[c] + dt * vn <= MET


class PairRows(NamedTuple):
    """Each contact pair p's rows at P_0 (``pair_rows``) and what its impulses need."""

    body_a: np.ndarray  # (P,) the pair's bodies
    body_b: np.ndarray
    J_n: np.ndarray  # (P, 6) the normal row at P_0, its M^-1 J^T and A_nn (0: no colliding point)
    JM_n: np.ndarray
    A_n: np.ndarray
    J_t: np.ndarray  # (P, 6) the friction row at P_0, its M^-1 J^T and A_tt
    JM_t: np.ndarray
    A_t: np.ndarray
    gap: np.ndarray  # (P,) m: > 0 when all its colliding points are still apart (the smallest gap)
    e: np.ndarray  # (P,) restitution
    mu: np.ndarray  # (P,) friction coefficient
    f_n: np.ndarray  # (P,) N s: the normal impulses applied, added up
    f_t: np.ndarray  # (P,) N s: the friction impulses applied, added up

    @classmethod
    def zeros(cls, n_pairs: int, e: np.ndarray, mu: np.ndarray) -> PairRows:
        """Rows of n_pairs pairs of restitution e and friction mu, all else 0."""

        def rows() -> np.ndarray:
            return np.zeros((n_pairs, 6))

        def each() -> np.ndarray:
            return np.zeros(n_pairs)

        bodies = np.zeros(n_pairs, np.int32), np.zeros(n_pairs, np.int32)
        return cls(*bodies, rows(), rows(), each(), rows(), rows(), each(), each(), e, mu, each(), each())


@njit(cache=True)
def _mean_row(start, end, row, use, J, M_inv, a, b, out_J, out_JM, p):
    """The mean of rows row[c] over the pair's colliding points c; returns its A_kk."""
    count = 0
    for c in range(6):
        out_J[p, c] = 0.0
    for c in range(start, end):
        if use[c]:
            count += 1
            for m in range(6):
                out_J[p, m] += J[row[c], m]
    A = 0.0
    for m in range(3):
        out_J[p, m] /= count
        out_J[p, 3 + m] /= count
        out_JM[p, m] = M_inv[a, m] * out_J[p, m]
        out_JM[p, 3 + m] = M_inv[b, m] * out_J[p, 3 + m]
        A += out_J[p, m] * out_JM[p, m] + out_J[p, 3 + m] * out_JM[p, 3 + m]
    return A


@njit(cache=True)
def pair_rows(starts, use, separation, rows, M_inv, pairs):
    """Each pair's normal and friction row at P_0, the mean of its colliding points, and its
    gap: the smallest separation of those points when all are still apart (m), else 0
    (into ``pairs``, from the contact rows ``rows``).

    A pair without a colliding point gets A_n = 0 and is skipped by the passes.
    """
    normal_row, friction_row, body_a, body_b, J = rows.normal_row, rows.friction_row, rows.body_a, rows.body_b, rows.J
    gap = pairs.gap
    for p in range(starts.shape[0] - 1):
        start, end = starts[p], starts[p + 1]
        a, b = body_a[normal_row[start]], body_b[normal_row[start]]
        pairs.body_a[p] = a
        pairs.body_b[p] = b
        any_used = False
        for c in range(start, end):
            any_used = any_used or use[c]
        if not any_used:
            pairs.A_n[p] = 0.0
            pairs.A_t[p] = 0.0
            continue
        gap[p] = np.inf
        for c in range(start, end):
            if use[c]:
                gap[p] = min(gap[p], separation[c] if separation[c] > MET else 0.0)  # touching within MET
        pairs.A_n[p] = _mean_row(start, end, normal_row, use, J, M_inv, a, b, pairs.J_n, pairs.JM_n, p)
        pairs.A_t[p] = _mean_row(start, end, friction_row, use, J, M_inv, a, b, pairs.J_t, pairs.JM_t, p)


@njit(cache=True)
def impulse_pass(pairs, V, dt):
    """One pass over the pairs: the lecture's impulse where they approach, then friction.

    A pair still apart by gap[p] > 0 only closes it: f = -(J_n V + gap/dt) / A_nn.
    Each increment stands on its own: f >= 0 and |f_t| <= mu f of this same pass.
    f_n, f_t add up what was applied (N s). Returns the largest |f| A (m/s) of the pass.
    """
    pa, pb, Jn, JMn, An, Jt, JMt, At = (
        pairs.body_a, pairs.body_b, pairs.J_n, pairs.JM_n, pairs.A_n, pairs.J_t, pairs.JM_t, pairs.A_t
    )  # fmt: skip
    gap, e, mu, f_n, f_t = pairs.gap, pairs.e, pairs.mu, pairs.f_n, pairs.f_t
    worst = 0.0
    for p in range(pa.shape[0]):
        if An[p] <= 0.0:
            continue
        a, b = pa[p], pb[p]
        vn = row_velocity(p, a, b, Jn, V)  # relative normal velocity, m/s
        xi_t = 0.0  # friction's target: stop the sliding, or for a pair still apart only once it touches
        if gap[p] > 0.0 and At[p] > 0.0:
            xi_t = speculative_friction_target(gap[p], vn, row_velocity(p, a, b, Jt, V), dt)
        if gap[p] > 0.0:
            f = -(vn + gap[p] / dt) / An[p]  # meets its partner within the step: close the gap, no more
        else:
            f = -(1.0 + e[p]) * vn / An[p] if vn < 0.0 else 0.0  # the lecture's, where they approach
        if f <= 0.0:
            continue  # no collision response
        apply_row_impulse(p, a, b, JMn, f, V)
        f_n[p] += f
        worst = max(worst, f * An[p])
        if At[p] > 0.0:
            ft = min(max(-(row_velocity(p, a, b, Jt, V) - xi_t) / At[p], -mu[p] * f), mu[p] * f)
            apply_row_impulse(p, a, b, JMt, ft, V)
            f_t[p] += ft
            worst = max(worst, abs(ft) * At[p])
    return worst


@njit(cache=True)
def bounce_landed(pairs, vn_start, vn_forced, dt, V):
    """After the positions moved: bounce each pair that met its partner within the step (gap > 0,
    and it pushed or its gap closed to within MET) from its approach speed at impact,
    f = (bounce - J_n V) / A_nn when it is > 0, with its friction f_t = clamp(-(J_t V) / A_t,
    -mu f, +mu f): friction acts fully at impact. With the landing impulse this adds up to the
    lecture's -(1 + e) J_n V / A_nn (no external forces)."""
    pa, pb, Jn, JMn, An, gap, e, f_n = (
        pairs.body_a, pairs.body_b, pairs.J_n, pairs.JM_n, pairs.A_n, pairs.gap, pairs.e, pairs.f_n
    )  # fmt: skip
    Jt, JMt, At, mu, f_t = pairs.J_t, pairs.JM_t, pairs.A_t, pairs.mu, pairs.f_t
    for p in range(pa.shape[0]):
        if An[p] <= 0.0 or gap[p] <= 0.0:
            continue
        a, b = pa[p], pb[p]
        if f_n[p] <= 0.0 and gap[p] + dt * row_velocity(p, a, b, Jn, V) > MET:
            continue  # it did not meet its partner: no impulse, and its gap stays open
        vn = approach_at_impact(gap[p], vn_start[p], vn_forced[p], dt)
        f = (bounce_target(e[p], vn, vn_forced[p] - vn_start[p]) - row_velocity(p, a, b, Jn, V)) / An[p]
        if f > 0.0:
            apply_row_impulse(p, a, b, JMn, f, V)
            f_n[p] += f
            if At[p] > 0.0:
                ft = min(max(-row_velocity(p, a, b, Jt, V) / At[p], -mu[p] * f), mu[p] * f)
                apply_row_impulse(p, a, b, JMt, ft, V)
                f_t[p] += ft


@njit(cache=True)
def push_apart(starts, separation, normal, pa, pb, M_inv, x, max_passes, tolerance, max_move):
    """Move overlapping pairs apart along n, split by 1/m, as long as overlap remains.

    A pair's overlap is its deepest point's, -separation, updated for how far the
    pushes have moved its bodies so far: separation + (dx_b - dx_a) . n (rotation
    is left alone). Pushing one pair apart can push a body into its other
    neighbour, so the pairs are swept again until no overlap exceeds
    ``tolerance`` (m) or after ``max_passes`` sweeps. No pair's overlap shrinks by
    more than ``max_move`` (m, push_max dt) in one call. Returns the sweeps made.
    """
    dx = np.zeros((x.shape[0], 2))
    floor = np.zeros(starts.shape[0] - 1)  # the overlap each pair may keep after this tick
    for p in range(starts.shape[0] - 1):
        depth = 0.0
        for c in range(starts[p], starts[p + 1]):
            depth = max(depth, -separation[c])
        floor[p] = max(depth - max_move, 0.0)
    sweeps = 0
    while sweeps < max_passes:
        sweeps += 1
        worst = 0.0
        for p in range(starts.shape[0] - 1):
            a, b = pa[p], pb[p]
            w = M_inv[a, 0] + M_inv[b, 0]
            if w <= 0.0:
                continue
            nx, ny = normal[starts[p], 0], normal[starts[p], 1]
            moved = (dx[b, 0] - dx[a, 0]) * nx + (dx[b, 1] - dx[a, 1]) * ny
            depth = 0.0
            for c in range(starts[p], starts[p + 1]):
                depth = max(depth, -(separation[c] + moved))
            if depth - floor[p] <= tolerance:
                continue
            worst = max(worst, depth - floor[p])
            sa = (depth - floor[p]) * M_inv[a, 0] / w
            sb = (depth - floor[p]) * M_inv[b, 0] / w
            dx[a, 0] -= nx * sa
            dx[a, 1] -= ny * sa
            dx[b, 0] += nx * sb
            dx[b, 1] += ny * sb
        if worst <= tolerance:
            break
    for b in range(x.shape[0]):
        x[b, 0] += dx[b, 0]
        x[b, 1] += dx[b, 1]
    return sweeps


@njit(cache=True)
def report_on_points(starts, use, normal_row, friction_row, f_n, f_t, lam):
    """Share each pair's impulses equally among its colliding points."""
    for p in range(starts.shape[0] - 1):
        count = 0
        for c in range(starts[p], starts[p + 1]):
            count += use[c]
        for c in range(starts[p], starts[p + 1]):
            lam[normal_row[c]] = f_n[p] / count if use[c] else 0.0
            lam[friction_row[c]] = f_t[p] / count if use[c] else 0.0


def pairwise_response(ctx: StepContext, passes: int, push_max: float) -> SolveResult:
    """``passes`` impulse passes over the contact pairs, the push-apart, the positions, then the
    bounce of the pairs that met within the step (both naive takes)."""
    r = ctx.rows
    rows = record_of_rows(r)
    k = ctx.n_contacts
    starts = manifold_starts(ctx.body_a, ctx.body_b)
    n_pairs = starts.shape[0] - 1
    use = np.zeros(k, np.bool_)
    colliding_points(rows, ctx.separation, ctx.V, ctx.dt, use)
    first = starts[:-1]
    e = ctx.restitution[first] if k else np.zeros(0)
    pairs = PairRows.zeros(n_pairs, e, r.mu[r.friction_row[first]] if k else np.zeros(0))
    pair_rows(starts, use, ctx.separation, rows, ctx.M_inv, pairs)
    vn_start, vn_forced = pair_velocities(pairs, ctx.V1), pair_velocities(pairs, ctx.V)
    residuals = np.zeros(passes)
    for s in range(passes):
        residuals[s] = impulse_pass(pairs, ctx.V, ctx.dt)
    push_apart(
        starts,
        ctx.separation,
        ctx.normal,
        pairs.body_a,
        pairs.body_b,
        ctx.M_inv,
        ctx.x,
        PUSH_PASSES,
        PUSH_TOLERANCE,
        push_max * ctx.dt,
    )
    integrate_positions(ctx.x, ctx.theta, ctx.V, ctx.dt)
    bounce_landed(pairs, vn_start, vn_forced, ctx.dt, ctx.V)
    report_on_points(starts, use, r.normal_row, r.friction_row, pairs.f_n, pairs.f_t, r.lam)
    return SolveResult(passes, residuals, integrated=True)


def pair_velocities(pairs: PairRows, V: np.ndarray) -> np.ndarray:
    """J_n V of each pair's row at P_0 (m/s)."""
    Jn = pairs.J_n
    return np.einsum("pc,pc->p", Jn[:, :3], V[pairs.body_a]) + np.einsum("pc,pc->p", Jn[:, 3:], V[pairs.body_b])


class NaiveImpulse(Responder):
    """The lecture's naive take: each colliding pair once per tick, then push apart.

    See the module docstring for the formula. push_max (m/s) bounds how fast the
    push-apart may remove an overlap. No caching, no accumulation, no joints.
    ``w.last_step.residuals`` holds the one pass's largest velocity change |f| A (m/s).
    """

    name = "naive"
    warm_start = False
    handles_joints = False
    push_max = Setting(non_negative_float, "largest push-out speed, m/s")

    def __init__(self, push_max: float = 3.0) -> None:
        self.push_max = push_max

    def respond(self, ctx: StepContext) -> SolveResult:
        return pairwise_response(ctx, 1, self.push_max)

    def __repr__(self) -> str:
        return f"NaiveImpulse(push_max={self.push_max:g})"


__all__ = ["NaiveImpulse", "PairRows", "pairwise_response"]
