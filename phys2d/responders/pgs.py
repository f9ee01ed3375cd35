"""Projected Gauss-Seidel, impulse form (sequential impulses), with warm starting.

The lecture's PGS on A lambda = b, with A = J M^-1 J^T never formed: the term
sum_l A_kl lambda_l - b_k is J_k V - xi_k, read off the velocities that every
impulse applied so far has produced (docs/formulation.md, "Projected Gauss-Seidel").

One step (``PGS.respond``):

    V += M^-1 J^T lambda              warm start (contact caching)
    sweeps on A lambda = b            xi: a point still apart may close its gap, no more
    sweeps on A lambda_p >= push      split impulses (``push_out``): pseudo-velocities V_p
    x += dt (V + V_p)                 the contacts' share of V_p is dropped: their push never
                                      becomes velocity; the joints' stays in V
    restitution pass                  points that met their partner fast bounce (restitution.py)

With split=False the push is part of xi, as the lecture has it, and stays in V. Split, the
warm-started sweeps see only xi: A lambda = b then always has a solution, even for a net of
joints with more rows than its bodies have freedoms (Box2D's joint grid), whose Baumgarte
targets may have none; there a warm-started lambda would grow without bound along A's null
space, carried from tick to tick. The push pass starts from zero every tick.

``sweep`` is the lecture's loop, one row at a time in pair order (rows are stored
in it: each contact's normal row, then its friction row; joint rows last; a scene of
``PARTS_FROM`` moving bodies or more comes part by part, pair order within each, so that
``World.threads`` can sweep the parts at once: ``sweep_in_groups``);
``block_sweep`` is Box2D's block solver, which takes a two-point manifold's normal
rows together (``lcp2``, shared with the soft step). ``pgs_step`` runs a whole
``respond`` in one numba call: each call from Python costs a dispatch that grows
with its arguments.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import prange

from ..constraints.joints import OWN_SOLVE, JointArrays
from ..constraints.rows import (
    FRICTION_COULOMB,
    FRICTION_LECTURE,
    apply_row_impulse,
    clamp_accumulated,
    pair_row_impulse,
    pair_row_velocity,
    pair_velocity,
    push_rows,
    row_velocity,
    store_pair_velocity,
    unsigned_indices,
)
from ..integrate import integrate_positions
from ..jit import njit
from ..pipeline.context import pgs_kernel
from ..pipeline.parallel import largest, manifold_groups
from ..pipeline.records import RowRecord, new_bodies, record_of_joints, record_of_rows
from ..validation import (
    Setting,
    check_bool,
    check_int,
    float_in,
    non_negative_float,
    one_of,
    optional_non_negative_float,
)
from .base import Responder, SolveResult, StepContext
from .block import block_is_well_conditioned, inverse_or_zero, lcp2
from .mouse import has_mouse, solve_mice
from .pgs_matrix import solve_matrix_form
from .restitution import bouncing_contacts, restitution_pass


@njit(cache=True)
def apply_impulses(rows, V):
    """V += M^-1 J^T lambda: the warm start, one row at a time."""
    apply_impulses_of(0, rows.lam.shape[0], rows, V)


@njit(cache=True)
def apply_impulses_of(first, last, rows, V):
    """``apply_impulses`` of rows first up to last."""
    body_a, body_b, JM, lam = rows.body_a, rows.body_b, rows.JM, rows.lam
    for k in range(first, last):
        if lam[k] != 0.0:
            apply_row_impulse(k, body_a[k], body_b[k], JM, lam[k], V)


@njit(cache=True)
def sweep(rows, V, visit):
    """One projected Gauss-Seidel sweep, the lecture's loop, over the rows ``visit`` in turn;
    returns the largest velocity correction |delta lambda_k| A_kk (m/s).

    ``rows`` are per unit A_kk (``per_unit_A``): their J and xi are J_hat_k = J_k / A_kk and
    xi_hat_k = xi_k / A_kk, so delta = (xi_k - J_k V) / A_kk is xi_hat_k - J_hat_k V. V_ab is the
    part of V that the row's two bodies a, b hold, (v_a, omega_a, v_b, omega_b), written back
    into V when the rows turn to another pair (docs/formulation.md, "Impulse form").
    """
    body_a, body_b, J_hat, JM, A_kk, xi_hat = rows.body_a, rows.body_b, rows.J, rows.JM, rows.A_kk, rows.xi
    lo, hi, bound_row, mu, lam = rows.lo, rows.hi, rows.bound_row, rows.mu, rows.lam
    worst = 0.0
    if visit.shape[0] == 0:
        return worst
    a_held, b_held = body_a[visit[0]], body_b[visit[0]]
    V_ab = pair_velocity(a_held, b_held, V)
    for k in visit:
        if A_kk[k] <= 0.0:
            continue  # both bodies static: nothing can move
        if bound_row[k] >= 0:  # friction: the Coulomb cone +-mu lambda_n of its normal row
            high = mu[k] * lam[bound_row[k]]
            low = -high
        else:
            low, high = lo[k], hi[k]
        if high == 0.0 and lam[k] == 0.0:
            continue  # friction of a point that does not push: its cone [0, 0] holds lambda_k = 0 already
        a, b = body_a[k], body_b[k]
        if a != a_held or b != b_held:  # another pair of bodies
            store_pair_velocity(a_held, b_held, V_ab, V)
            a_held, b_held, V_ab = a, b, pair_velocity(a, b, V)
        delta = xi_hat[k] - pair_row_velocity(k, J_hat, V_ab)  # (xi_k - J_k V) / A_kk
        delta = clamp_accumulated(lam, k, delta, low, high)  # clamp the accumulated impulse, not delta
        V_ab = pair_row_impulse(k, JM, delta, V_ab)  # V += M^-1 J_k^T delta
        worst = max(worst, abs(delta) * A_kk[k])
    store_pair_velocity(a_held, b_held, V_ab, V)
    return worst


@njit(cache=True, inline="always")
def solve_normal_pair(n1, n2, a, b, J, JM, A_kk, xi, lam, V):
    """Both normal rows n1, n2 of a two-point manifold between bodies a and b at once, as an
    exact 2x2 LCP (lcp2); returns the largest |delta lambda| A_kk (m/s), or -1 when the pair is
    too ill-conditioned to solve as a block (nothing is changed then)."""
    K11, K22 = A_kk[n1], A_kk[n2]
    K12 = 0.0
    for c in range(6):
        K12 += J[n1, c] * JM[n2, c]
    if not block_is_well_conditioned(K11, K12, K22):
        return -1.0
    a1, a2 = lam[n1], lam[n2]
    # the new lambda x solves K x + (J V - xi - K a) >= 0, x >= 0, complementary
    x1, x2 = lcp2(
        K11,
        K12,
        K22,
        1.0 / (K11 * K22 - K12 * K12),
        row_velocity(n1, a, b, J, V) - xi[n1] - (K11 * a1 + K12 * a2),
        row_velocity(n2, a, b, J, V) - xi[n2] - (K12 * a1 + K22 * a2),
    )
    lam[n1] = x1
    lam[n2] = x2
    apply_row_impulse(n1, a, b, JM, x1 - a1, V)
    apply_row_impulse(n2, a, b, JM, x2 - a2, V)
    return max(abs(x1 - a1) * K11, abs(x2 - a2) * K22)


@njit(cache=True, inline="always")
def row_bounds(k, lo, hi, bound_row, mu, lam):
    """lambda_k's bounds (low, high): for friction the Coulomb cone +-mu lambda_n of its normal
    row bound_row[k], else [lo_k, hi_k]."""
    if bound_row[k] >= 0:
        high = mu[k] * lam[bound_row[k]]
        return -high, high
    return lo[k], hi[k]


@njit(cache=True)
def solve_row(k, a, b, bounds, J_hat, JM, A_kk, xi_hat, lam, V):
    """Row k between bodies a and b alone, as ``sweep``'s loop does it: delta = xi_hat_k - J_hat_k V,
    clamp the accumulated impulse to bounds = (low, high), apply. Returns |delta lambda_k| A_kk (m/s)."""
    low, high = bounds
    if A_kk[k] <= 0.0 or (high == 0.0 and lam[k] == 0.0):
        return 0.0  # both bodies static, or friction of a point that does not push: nothing to do
    delta = xi_hat[k] - row_velocity(k, a, b, J_hat, V)  # (xi_k - J_k V) / A_kk
    delta = clamp_accumulated(lam, k, delta, low, high)  # clamp the accumulated impulse, not delta
    apply_row_impulse(k, a, b, JM, delta, V)  # V += M^-1 J_k^T delta
    return abs(delta) * A_kk[k]


@njit(cache=True)
def block_sweep(rows, rows_hat, V, joint_rows):
    """One block Gauss-Seidel sweep (Box2D's block solver): a two-point manifold's normal
    rows together (``solve_normal_pair``, on ``rows``), then its friction rows; other contacts
    row by row (``solve_row``, on ``rows_hat``, the same rows per unit A_kk), and the joint
    rows ``joint_rows`` in a ``sweep``. Returns the largest |delta lambda_k| A_kk (m/s). With no
    friction rows (``RowRecord.friction_row`` empty) only the normal rows are swept."""
    worst = block_sweep_of(0, rows_hat.normal_row.shape[0], rows, rows_hat, V)
    return max(worst, sweep(rows_hat, V, joint_rows))


@njit(cache=True)
def block_sweep_of(first, last, rows, rows_hat, V):
    """``block_sweep`` of contacts first up to last (in visit order; a manifold's points all
    within them), without the joint rows. Returns the largest |delta lambda_k| A_kk (m/s)."""
    normal_row, friction_row = rows_hat.normal_row, rows_hat.friction_row  # unsigned: the sweep's visit
    body_a, body_b, J, JM, A_kk, xi, lam = rows.body_a, rows.body_b, rows.J, rows.JM, rows.A_kk, rows.xi, rows.lam
    J_hat, xi_hat = rows_hat.J, rows_hat.xi  # per unit A_kk, for the rows solved one by one
    lo, hi, bound_row, mu = rows.lo, rows.hi, rows.bound_row, rows.mu
    worst = 0.0
    frictionless = friction_row.shape[0] == 0
    q = first
    while q < last:
        n1 = normal_row[q]
        a, b = body_a[n1], body_b[n1]
        together = 1  # contacts taken in this turn
        if q + 1 < last and body_a[normal_row[q + 1]] == a and body_b[normal_row[q + 1]] == b:
            err = solve_normal_pair(n1, normal_row[q + 1], a, b, J, JM, A_kk, xi, lam, V)
            if err >= 0.0:  # solved as a block: then the two friction rows
                worst = max(worst, err)
                together = 2
        lone = 1 if together == 1 else 0  # a normal row not solved in a block goes first
        for i in range(lone + (0 if frictionless else together)):  # then the friction rows
            k = n1 if i < lone else friction_row[q + i - lone]
            bounds = row_bounds(k, lo, hi, bound_row, mu, lam)
            worst = max(worst, solve_row(k, a, b, bounds, J_hat, JM, A_kk, xi_hat, lam, V))
        q += together
    return worst


@njit(cache=True, inline="always")
def with_target(rows, xi, lam, friction_row):
    """The rows solved for the target xi from the impulses lam, with the friction rows
    ``friction_row`` (none for the push pass)."""
    return RowRecord(
        rows.normal_row, friction_row, rows.body_a, rows.body_b, rows.J, rows.JM, rows.A_kk, xi, rows.push,
        rows.bounce, rows.impact, rows.lo, rows.hi, rows.bound_row, rows.mu, lam,
    )  # fmt: skip


@njit(cache=True)
def per_unit_A(rows):
    """The rows per unit A_kk, for ``sweep``: the same rows with J_hat_k = J_k / A_kk in J and
    xi_hat_k = xi_k / A_kk in xi (0 where A_kk = 0), their row map and bodies as uint32
    (``unsigned_indices``). Made once a step: the push pass takes its target from them
    (``per_unit_A_target``)."""
    normal_row, friction_row, body_a, body_b = unsigned_indices(
        rows.normal_row, rows.friction_row, rows.body_a, rows.body_b
    )
    J, xi, A_kk = rows.J, rows.xi, rows.A_kk
    J_hat = np.empty_like(J)
    xi_hat = np.empty_like(xi)
    for k in range(J.shape[0]):
        inv_A_kk = inverse_or_zero(A_kk[k])  # the sweeps multiply, never divide
        for c in range(6):
            J_hat[k, c] = J[k, c] * inv_A_kk
        xi_hat[k] = xi[k] * inv_A_kk
    return RowRecord(
        normal_row, friction_row, body_a, body_b, J_hat, rows.JM, A_kk, xi_hat, rows.push, rows.bounce,
        rows.impact, rows.lo, rows.hi, rows.bound_row, rows.mu, rows.lam,
    )  # fmt: skip


@njit(cache=True)
def per_unit_A_target(rows_hat, xi, lam, friction_row):
    """``per_unit_A`` of the same rows solved for the target xi from the impulses lam, with the
    friction rows ``friction_row`` (``with_target``), from rows_hat, the rows per unit A_kk:
    J_hat is theirs, xi_hat_k = xi_k / A_kk is new."""
    A_kk = rows_hat.A_kk
    xi_hat = np.empty_like(xi)
    for k in range(xi.shape[0]):
        xi_hat[k] = xi[k] * inverse_or_zero(A_kk[k])  # as per_unit_A's
    return with_target(rows_hat, xi_hat, lam, friction_row)


@njit(cache=True)
def swept_rows(bound_row):
    """The rows the sweeps visit: all but the mouse joints' (bound_row ``OWN_SOLVE``), which
    ``solve_mice`` solves (unsigned, as ``pgs_solve``'s)."""
    n = 0
    for k in range(bound_row.shape[0]):
        if bound_row[k] != OWN_SOLVE:
            n += 1
    visit = np.empty(n, np.uint32)
    n = 0
    for k in range(bound_row.shape[0]):
        if bound_row[k] != OWN_SOLVE:
            visit[n] = k
            n += 1
    return visit


# -- on several threads: the contacts' segments of a group at once (``pipeline.parallel``) ----------
@njit(cache=True)
def contact_groups(threads, rows, M_inv):
    """``pipeline.parallel.manifold_groups`` of the contacts (each its own "manifold": a sweep
    visits rows), segment s being contacts segment_start[s] up to segment_start[s + 1]; None
    when threads is None (one thread)."""
    if threads is None:
        return None
    return manifold_groups(np.arange(rows.normal_row.shape[0] + 1), rows, M_inv, threads[1])


@njit(cache=True)
def sweep_on(groups, rows_hat, V, visit, per_contact):
    """``sweep`` of the rows ``visit``: in one call (groups None), or group by group
    (``sweep_in_groups``; a contact's rows are per_contact consecutive entries of visit).
    A loop of sweeps on one thread calls ``sweep`` itself: through this function, which holds
    its arguments across a call numba may see raise, each sweep would count a reference to
    each array it is handed."""
    if groups is None:
        return sweep(rows_hat, V, visit)
    return sweep_in_groups(groups, rows_hat, V, visit, per_contact)


@njit(cache=True, parallel=True)
def sweep_in_groups(groups, rows_hat, V, visit, per_contact):
    """``sweep`` group by group, a group's segments in parallel (segment s's rows:
    visit[per_contact * c0 : per_contact * c1] for its contacts c0 up to c1), then the rows
    after the contacts' (the joints') on this thread: each row sees what it sees in one sweep,
    so the results are the same (``pipeline.parallel``). Returns the largest correction (m/s)."""
    segment_start, group_start = groups
    worst = np.empty(segment_start.shape[0] - 1)  # per segment: no shared accumulator (each written once)
    for g in range(group_start.shape[0] - 1):
        first, last = group_start[g], group_start[g + 1]
        if last - first == 1:  # one segment: on this thread, no threads to wake
            c0, c1 = segment_start[first], segment_start[first + 1]
            worst[first] = sweep_rows(rows_hat, V, visit, per_contact * c0, per_contact * c1)
            continue
        for s in prange(first, last):
            c0, c1 = segment_start[s], segment_start[s + 1]
            worst[s] = sweep_rows(rows_hat, V, visit, per_contact * c0, per_contact * c1)
    after = sweep_rows(rows_hat, V, visit, per_contact * segment_start[-1], visit.shape[0])
    return max(largest(worst), after)


@njit(cache=True)
def sweep_rows(rows_hat, V, visit, first, last):
    """``sweep`` of visit[first:last]."""
    return sweep(rows_hat, V, visit[first:last])


@njit(cache=True)
def block_sweep_on(groups, rows, rows_hat, V, joint_rows):
    """``block_sweep``: in one call (groups None), or its contacts group by group, a group's
    segments in parallel, then the joint rows (``sweep_in_groups``' order: the same results)."""
    if groups is None:
        return block_sweep(rows, rows_hat, V, joint_rows)
    return max(block_sweep_in_groups(groups, rows, rows_hat, V), sweep(rows_hat, V, joint_rows))


@njit(cache=True, parallel=True)
def block_sweep_in_groups(groups, rows, rows_hat, V):
    segment_start, group_start = groups
    worst = np.empty(segment_start.shape[0] - 1)
    for g in range(group_start.shape[0] - 1):
        first, last = group_start[g], group_start[g + 1]
        if last - first == 1:
            worst[first] = block_sweep_of(segment_start[first], segment_start[first + 1], rows, rows_hat, V)
            continue
        for s in prange(first, last):
            worst[s] = block_sweep_of(segment_start[s], segment_start[s + 1], rows, rows_hat, V)
    return largest(worst)


@njit(cache=True)
def apply_impulses_on(groups, rows, V):
    """``apply_impulses`` (the warm start): in one call (groups None), or the contacts' rows group
    by group, a group's segments in parallel, then the joints': each body adds its impulses in
    the same order, so the results are the same."""
    if groups is None:
        apply_impulses(rows, V)
    else:
        apply_impulses_in_groups(groups, rows, V)


@njit(cache=True, parallel=True)
def apply_impulses_in_groups(groups, rows, V):
    segment_start, group_start = groups
    for g in range(group_start.shape[0] - 1):
        first, last = group_start[g], group_start[g + 1]
        if last - first == 1:
            apply_impulses_of(2 * segment_start[first], 2 * segment_start[first + 1], rows, V)
            continue
        for s in prange(first, last):
            apply_impulses_of(2 * segment_start[s], 2 * segment_start[s + 1], rows, V)
    apply_impulses_of(2 * segment_start[-1], rows.lam.shape[0], rows, V)  # the joint rows


@njit(cache=True)
def pgs_solve(rows, rows_hat, V, iterations, tolerance, residuals, block, joints, dt, groups):
    """Warm start from rows.lam, then sweep all rows in solve order (rows are stored in it)
    until the residual <= tolerance or out of sweeps; rows_hat: the rows per unit A_kk
    (``per_unit_A``), which the sweeps read. Returns the sweeps made;
    residuals[s] is sweep s's. ``block``: see ``PGSSettings``. ``joints``: the JointRecord, or
    None in a world without joints (then none of this joint code is compiled); its mouse
    joints' rows are solved after each sweep by their own soft solve (``solve_mice``, over dt).
    ``groups``: None on one thread, else the contacts' groups (``contact_groups``): the warm
    start and the sweeps run a group's segments on several threads, with the same results."""
    apply_impulses_on(groups, rows, V)
    all_rows = np.arange(rows.lam.shape[0], dtype=np.uint32)  # unsigned, as rows_hat's row map: sweep compiles once
    first_joint_row = 2 * rows.normal_row.shape[0]
    mice = False
    if joints is not None:
        mice = has_mouse(joints)
        if mice:
            all_rows = swept_rows(rows.bound_row)
    joint_rows = all_rows[first_joint_row:]
    for s in range(iterations):  # (on one thread the sweeps are called here, not through ``sweep_on``: see it)
        if groups is not None:
            residuals[s] = (
                block_sweep_on(groups, rows, rows_hat, V, joint_rows)
                if block is not None
                else sweep_on(groups, rows_hat, V, all_rows, 2)  # (a contact's two rows)
            )
        elif block is not None:
            residuals[s] = block_sweep(rows, rows_hat, V, joint_rows)
        else:
            residuals[s] = sweep(rows_hat, V, all_rows)
        if joints is not None:
            if mice:
                residuals[s] = max(residuals[s], solve_mice(joints, first_joint_row, rows, V, dt, dt))
        if residuals[s] <= tolerance:
            return s + 1
    return iterations


@njit(cache=True)
def any_push(push):
    """Whether any row has a push (push_k != 0). A step with none (a scene at rest, every
    overlap within slop) makes no push pass and allocates nothing for one."""
    for k in range(push.shape[0]):
        if push[k] != 0.0:
            return True
    return False


@njit(cache=True)
def pushes(rows, visit):
    """Whether any row in ``visit`` has a push: a contact point overlapping past slop (push_k > 0)
    or a joint off its constraint (push_k != 0); else there is nothing to push out."""
    push = rows.push
    for k in visit:
        if push[k] != 0.0:
            return True
    return False


@njit(cache=True)
def push_out(rows, rows_hat, V_push, lam_push, iterations, tolerance, block, groups):
    """Split impulses: sweep the rows that hold a position (``push_rows``) for pseudo-velocities
    V_push that reach J_k V_push = push_k (the Baumgarte push; >= for a contact or a joint
    limit, with lambda_p >= 0), from lam_push = 0 and V_push = 0: nothing is warm started.
    Leaves the impulses in ``lam_push``; returns the sweeps made (0 when nothing is to be pushed).
    ``rows_hat``, ``block``, ``groups``: as ``pgs_solve``'s.
    """
    visit = push_rows(rows.normal_row, rows.lo, rows.hi, rows.bound_row)
    if not pushes(rows, visit):
        return 0
    push_hat = per_unit_A_target(rows_hat, rows.push, lam_push, rows_hat.normal_row[:0])  # no friction rows
    target = rows  # (read by the block solver alone, for J and lam_push: made only when it runs)
    if block is not None:
        target = with_target(rows, rows.push, lam_push, rows.normal_row[:0])
    joint_visit = visit[rows.normal_row.shape[0] :]
    for s in range(iterations):  # (as ``pgs_solve``'s)
        if groups is not None:
            worst = (
                block_sweep_on(groups, target, push_hat, V_push, joint_visit)
                if block is not None
                else sweep_on(groups, push_hat, V_push, visit, 1)  # (a contact's normal row)
            )
        elif block is not None:
            worst = block_sweep(target, push_hat, V_push, joint_visit)
        else:
            worst = sweep(push_hat, V_push, visit)
        if worst <= tolerance:
            return s + 1
    return iterations


@njit(cache=True)
def keep_joint_push(rows, lam_push, V):
    """V += M^-1 J_k^T lambda_p,k for the joint rows k: a joint's push stays in V, as the
    lecture's Baumgarte term does (a contact's is dropped). Its impulses act along the joint's
    rows, so momentum is kept."""
    for k in range(2 * rows.normal_row.shape[0], lam_push.shape[0]):
        if lam_push[k] != 0.0:
            apply_row_impulse(k, rows.body_a[k], rows.body_b[k], rows.JM, lam_push[k], V)


class PGSSettings(NamedTuple):
    """What ``pgs_step`` is told besides the rows: sweeps at most; the residual (m/s) that
    stops them (None: never); ``block``, Box2D's block sweep (``block_sweep``) or the lecture's
    row-by-row sweep; and ``split``, whether the push goes through pseudo-velocities of its own
    (``push_out``) or into xi. ``pipeline.context.pgs_kernel`` gives them in the kernel's forms:
    tolerance -1.0 for None, block True or None (numba then compiles only the sweep used)."""

    iterations: int
    tolerance: float | None
    block: bool
    split: bool


@njit(cache=True)
def pgs_step(bodies, rows, separation, dt, settings, residuals, joints, threads):
    """``PGS.respond`` in one call on the bodies' record and the step's rows: warm start and
    sweeps on V, the push pass (split) or the push inside xi (not split), positions moved,
    then the restitution pass. ``separation``: (K,) each contact's C (m) in row order;
    ``settings``: ``pipeline.context.PGSKernel``; ``residuals``: each sweep's; ``joints``: the
    JointRecord (for its mouse joints), or None in a world without joints; threads: None on one
    thread (no parallel code is compiled), else
    (count, each body's part of the solve order): the sweeps run on several threads
    (``sweep_in_groups``), with the same results. Returns the sweeps made on A lambda = b."""
    iterations, tolerance, block, split = settings
    V = bodies.V
    groups = contact_groups(threads, rows, bodies.M_inv)  # None on one thread
    system = rows  # split: the push goes through pseudo-velocities of its own (push_out)
    if not split:  # the lecture: the push is part of the target
        system = with_target(rows, rows.xi + rows.push, rows.lam, rows.friction_row)
    system_hat = per_unit_A(system)  # what the sweeps read
    n = pgs_solve(system, system_hat, V, iterations, tolerance, residuals, block, joints, dt, groups)
    V_move = V
    if split and any_push(system.push):
        V_push, lam_push = np.zeros_like(V), np.zeros(rows.lam.shape[0])
        if push_out(system, system_hat, V_push, lam_push, iterations, tolerance, block, groups) > 0:
            V_move = V + V_push  # what the positions move with
            keep_joint_push(system, lam_push, V)  # the contacts' push is dropped, the joints' kept
    bouncing = bouncing_contacts(system, separation, V, dt)
    integrate_positions(bodies.x, bodies.theta, V_move, dt)
    restitution_pass(system, bouncing, V, iterations, tolerance)
    return n


FORMS = ("impulse", "matrix")
FRICTION_MODELS = {"coulomb": FRICTION_COULOMB, "lecture": FRICTION_LECTURE}


def _check_block_and_form(block: bool, form: str) -> None:
    if block and form == "matrix":
        raise ValueError(
            "block=True solves manifolds in pairs of rows; form='matrix' is the "
            "lecture's row-by-row sweep: use one or the other"
        )


class PGS(Responder):
    """Projected Gauss-Seidel with contact caching (warm starting).

    iterations   sweeps per step (>= 1)
    warm_start   start each contact's lambda from last tick's (contact caching)
    beta         Baumgarte push factor in [0, 1]: push = -(beta/dt) min(0, C + slop)
    slop         overlap (m) left alone, so resting contacts stay touching
    push_max     the largest push-out speed (m/s; Box2D v3's contactPushMaxVelocity)
    split        split impulses: the push moves positions through pseudo-velocities of
                 its own (``push_out``) and never becomes velocity. False: the lecture's
                 xi = push, so the push stays in V and a deep overlap throws bodies apart
    tolerance    stop early once a sweep's residual (m/s) is at most this; None: never
    restitution_threshold  approach speed (m/s) at impact above which e applies
    friction     'coulomb' (|lambda_t| <= mu lambda_n) or 'lecture' (|lambda_t| <= mu m_c g dt)
                 with m_c the pair's reduced mass m_a m_b / (m_a + m_b) (m_a on a static
                 partner) shared equally by the manifold's points: exactly Coulomb's bound
                 for one body resting on flat ground, but blind to any load on top, to
                 slopes and to impacts, since it never looks at lambda_n
    form         'impulse' (sequential impulses over the rows) or 'matrix' (J, M^-1,
                 A = J M^-1 J^T and b assembled and swept: ``phys2d.responders.pgs_matrix``;
                 the assembled system is left on ``w.last_step.system``)
    block        solve the two normal rows of each two-point manifold together, as an
                 exact 2x2 LCP (Box2D's block solver): a block Gauss-Seidel that does
                 not rock a resting box from corner to corner. Off by default: the
                 lecture's PGS visits one row at a time.

    One step: warm start; ``iterations`` sweeps on A lambda = b (b from xi: contacts
    close a speculative gap and no more); the push pass (split) or none; positions move;
    then the restitution pass bounces the points that pushed and approached fast.

    Every setting can be changed between steps; a bad value is refused with the
    constructor's message.
    """

    handles_joints = True
    part_order = True  # pair order, part by part in a scene large enough for threads (``constraints.order``)
    solves_mouse_joints = True  # both forms: ``mouse.solve_mice``, or the matrix sweep's ``solve_disk_block``
    counts = "sweeps"

    iterations = Setting(lambda v, name: check_int(v, name, 1), "sweeps per step")
    warm_start = Setting(check_bool, "start from last tick's impulses")
    beta = Setting(lambda v, name: float_in(v, name, 0.0, 1.0), "Baumgarte push factor")
    slop = Setting(non_negative_float, "overlap left alone, m")
    push_max = Setting(non_negative_float, "largest push-out speed, m/s")
    split = Setting(check_bool, "push through pseudo-velocities that never become velocity")
    tolerance = Setting(optional_non_negative_float, "residual (m/s) that stops the sweeps, or None")
    restitution_threshold = Setting(non_negative_float, "approach speed (m/s) above which e applies")

    def __init__(
        self,
        iterations: int = 10,
        warm_start: bool = True,
        beta: float = 0.2,
        slop: float = 0.005,
        tolerance: float | None = None,
        restitution_threshold: float = 1.0,
        friction: str = "coulomb",
        form: str = "impulse",
        block: bool = False,
        push_max: float = 3.0,
        split: bool = True,
    ) -> None:
        self._form, self._block = "impulse", False  # form and block check each other when set
        self._take(locals())

    @property
    def name(self) -> str:
        """pgs, pgs-matrix or pgs-block, with -cold when it does not warm start."""
        name = "pgs-block" if self.block else ("pgs-matrix" if self.form == "matrix" else "pgs")
        return name if self.warm_start else name + "-cold"

    @property
    def friction(self) -> str:
        """'coulomb' or 'lecture': the bound on each friction row."""
        return self._friction

    @friction.setter
    def friction(self, value: str) -> None:
        self._friction = one_of(value, "friction", tuple(FRICTION_MODELS))

    @property
    def friction_model(self) -> int:
        """FRICTION_COULOMB or FRICTION_LECTURE, for the rows."""
        return FRICTION_MODELS[self._friction]

    @property
    def form(self) -> str:
        """'impulse' or 'matrix'."""
        return self._form

    @form.setter
    def form(self, value: str) -> None:
        value = one_of(value, "form", FORMS)
        _check_block_and_form(self.block, value)
        self._form = value

    @property
    def block(self) -> bool:
        """Solve a two-point manifold's normal rows together (impulse form only)."""
        return self._block

    @block.setter
    def block(self, value: bool) -> None:
        value = check_bool(value, "block")
        _check_block_and_form(value, self._form)
        self._block = value

    @property
    def kernel(self) -> str | None:  # type: ignore[override]  # (a property where the base has a name)
        """'pgs': its solve is ``pgs_step``, in the world's one-call tick; None in matrix form."""
        return "pgs" if self.form == "impulse" else None

    @property
    def settings(self) -> PGSSettings:
        """The settings ``pgs_step`` reads, plain values."""
        return PGSSettings(self.iterations, self.tolerance, self.block, self.split)

    def respond(self, ctx: StepContext) -> SolveResult:
        r = ctx.rows
        if self.form == "matrix":
            xi = r.xi if self.split else r.xi + r.push  # the lecture: the push is part of the target
            tolerance = -1.0 if self.tolerance is None else self.tolerance
            return solve_matrix_form(ctx, xi, self.iterations, tolerance, self.split)
        residuals = np.zeros(self.iterations)
        bodies = new_bodies((ctx.x, ctx.theta, ctx.V, ctx.M_inv, ctx.V1))
        joints = None  # a world without joints compiles none of their code
        if isinstance(ctx.joints, JointArrays) and ctx.joints.kind.shape[0] > 0:
            joints = record_of_joints(ctx.joints, r.lam[r.first_joint_row :])  # (lam: not read)
        threads = None  # one thread: no parallel code compiled
        if ctx.threads > 1:  # (without the parts every contact is in part 0: solved on one thread)
            threads = (ctx.threads, ctx.part if ctx.part is not None else np.zeros(ctx.x.shape[0], np.int32))
        kernel = pgs_kernel(self.settings)
        n = pgs_step(bodies, record_of_rows(r), ctx.separation, ctx.dt, kernel, residuals, joints, threads)
        return SolveResult(n, residuals[:n], integrated=True)

    def __repr__(self) -> str:
        tol = "None" if self.tolerance is None else f"{self.tolerance:g}"
        return (
            f"PGS(iterations={self.iterations}, warm_start={self.warm_start}, beta={self.beta:g}, "
            f"slop={self.slop:g}, tolerance={tol}, friction={self.friction!r}, form={self.form!r}, "
            f"block={self.block}, push_max={self.push_max:g}, split={self.split})"
        )


__all__ = [
    "PGS",
    "PGSSettings",
    "apply_impulses",
    "block_sweep",
    "lcp2",
    "per_unit_A",
    "per_unit_A_target",
    "pgs_solve",
    "pgs_step",
    "sweep",
]
