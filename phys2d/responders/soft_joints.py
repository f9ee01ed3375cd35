"""The soft step's joints (``responders.soft_step``): rows rebuilt at every sub-step's positions.

Joints (distance, pin, angle) are rebuilt at each sub-step's positions, so C and J
follow the motion. Their equality rows are solved together: a Cholesky factor of
their A = J M^-1 J^T (a chain's A is banded: only each row's envelope is factored)
gives delta lambda = -A^-1 (J V + bias) exactly for the joint block, bias pulling C
back to 0 at ``joint_hertz``; a heavy body on a long chain then stretches it by
millimetres where one sweep of soft joint rows lets it stretch by decimetres.
Limits (angle, a pin's, a slider's) are one-sided rows solved like contact points
(``soft_contacts.soft_push``); motors are rigid rows toward their speed, clamped to the motor's
torque or force times the sub-step; mouse joints have a soft solve of their own (``mouse``).
"""

from __future__ import annotations

import numpy as np

from ..constraints.joints import OWN_SOLVE, joint_rows
from ..constraints.rows import MET, apply_row_impulse, clamp_accumulated, coupling, row_velocity
from ..jit import njit
from .soft_contacts import soft_push

DIRECT_JOINT_ROWS_MAX = 256  # more equality joint rows than this are swept, not factored
PIVOT_TOL = 1e-9  # a pivot below this fraction of A_kk marks a redundant row: it is left out


@njit(cache=True)
def first_joint_row_of(rows):
    """The first joint row: the joints' rows follow the K contacts' 2K."""
    return 2 * rows.normal_row.shape[0]


@njit(cache=True)
def _joint_C(first_joint_row, n_rows, xi, push, C):
    """C of each joint row (m or rad) from rows built with beta = dt = 1 (xi + push = -C)."""
    for k in range(first_joint_row, n_rows):
        C[k] = -(xi[k] + push[k])


@njit(cache=True)
def _equality_rows(first_joint_row, n_rows, lo):
    """The joint rows with no bound (pins, rods, fixed angles): indices into the rows."""
    n_eq = 0
    for k in range(first_joint_row, n_rows):
        if lo[k] == -np.inf:
            n_eq += 1
    eq = np.empty(n_eq, np.int64)
    n_eq = 0
    for k in range(first_joint_row, n_rows):
        if lo[k] == -np.inf:
            eq[n_eq] = k
            n_eq += 1
    return eq


@njit(cache=True)
def factor_joint_rows(eq, body_a, body_b, J, JM, L, first):
    """Cholesky factor L L^T = A of the equality joint rows ``eq`` (A_pq = J_p M^-1 J_q^T).

    Only each row's envelope is touched: first[p] is the first row that shares a body
    with row p, so a chain's A (banded) costs O(n w^2). A redundant row (a pivot below
    PIVOT_TOL A_pp) gets L_pp = 0 and is left out of the solve.
    """
    n = eq.shape[0]
    n_bodies = 0
    for p in range(n):
        n_bodies = max(n_bodies, body_a[eq[p]] + 1, body_b[eq[p]] + 1)
    first_touch = np.full(n_bodies, n, np.int64)  # per body, the first row on it so far (n: none)
    for p in range(n):  # the envelope in one pass (a scan of the rows before each row is O(n^2))
        a, b = body_a[eq[p]], body_b[eq[p]]
        first[p] = min(p, first_touch[a], first_touch[b])
        first_touch[a] = min(first_touch[a], p)
        first_touch[b] = min(first_touch[b], p)
    for p in range(n):
        for q in range(first[p], p + 1):
            s = coupling(eq[p], eq[q], body_a, body_b, J, JM)
            for m in range(max(first[p], first[q]), q):
                s -= L[p, m] * L[q, m]
            if q < p:
                L[p, q] = s / L[q, q] if L[q, q] > 0.0 else 0.0
            else:
                A_pp = coupling(eq[p], eq[p], body_a, body_b, J, JM)
                L[p, p] = np.sqrt(s) if s > PIVOT_TOL * A_pp else 0.0


@njit(cache=True)
def solve_factored(L, first, y):
    """y <- A^-1 y with A = L L^T from ``factor_joint_rows`` (left-out rows get 0)."""
    n = y.shape[0]
    for p in range(n):  # forward: L z = y
        for m in range(first[p], p):
            y[p] -= L[p, m] * y[m]
        y[p] = y[p] / L[p, p] if L[p, p] > 0.0 else 0.0
    for p in range(n - 1, -1, -1):  # back: L^T x = z
        y[p] = y[p] / L[p, p] if L[p, p] > 0.0 else 0.0
        for m in range(first[p], p):
            y[m] -= L[p, m] * y[p]


@njit(cache=True)
def _joint_bias(C, use_bias, soft):
    """Velocity bias of an equality joint row whose error is C (m or rad): the joint's soft pull."""
    return soft[0] * C if use_bias else 0.0


@njit(cache=True)
def solve_joints(rows, system, V, h, use_bias, soft_joint):
    """The joint rows once: motor rows (rigid, toward their speed, |lambda| <= max_motor h) and
    limit rows (lambda >= 0, like a contact point whose separation is the gap to the stop) one
    by one, then the equality rows, together (``direct``:
    delta lambda = -A^-1 (J V + bias), exact for the joint block) or one by one with the
    joint's softness. ``system``: the joint rows' (eq, L, first, C, direct) (``joint_system``).
    Returns the largest |delta lambda| A_kk (m/s)."""
    first_joint_row, n_rows = first_joint_row_of(rows), rows.lam.shape[0]
    body_a, body_b, J, JM, A_kk, lo, lam = rows.body_a, rows.body_b, rows.J, rows.JM, rows.A_kk, rows.lo, rows.lam
    eq, L, first, C, direct = system
    worst = 0.0
    for k in range(first_joint_row, n_rows):
        unbounded = lo[k] == -np.inf
        if A_kk[k] <= 0.0 or (direct and unbounded) or rows.bound_row[k] == OWN_SOLVE:
            continue  # (a mouse joint's rows: ``mouse.solve_mice``)
        a, b = body_a[k], body_b[k]
        if not unbounded and rows.hi[k] != np.inf:  # a motor: rigid, |lambda| <= max_motor h
            d = (rows.xi[k] - row_velocity(k, a, b, J, V)) / A_kk[k]  # xi: the motor's speed
            d = clamp_accumulated(lam, k, d, lo[k] * h, rows.hi[k] * h)  # lo, hi: -+max_motor (rows of dt = 1)
        elif unbounded:  # the soft joint of Box2D v3
            mass_scale, impulse_scale = (soft_joint[1], soft_joint[2]) if use_bias else (1.0, 0.0)
            d = (
                -mass_scale * (row_velocity(k, a, b, J, V) + _joint_bias(C[k], use_bias, soft_joint)) / A_kk[k]
                - impulse_scale * lam[k]
            )
            lam[k] += d
        else:
            if not use_bias and C[k] > MET:
                continue  # relax leaves a limit still short of its stop alone
            bias, mass_scale, impulse_scale = soft_push(C[k], h, use_bias, soft_joint)
            d = -mass_scale * (row_velocity(k, a, b, J, V) + bias) / A_kk[k] - impulse_scale * lam[k]
            d = clamp_accumulated(lam, k, d, 0.0, np.inf)  # a stop pushes, it never pulls
        apply_row_impulse(k, a, b, JM, d, V)
        worst = max(worst, abs(d) * A_kk[k])
    if direct and eq.shape[0] > 0:
        y = np.empty(eq.shape[0])
        for p in range(eq.shape[0]):
            k = eq[p]
            y[p] = -(row_velocity(k, body_a[k], body_b[k], J, V) + _joint_bias(C[k], use_bias, soft_joint))
        solve_factored(L, first, y)
        for p in range(eq.shape[0]):
            k = eq[p]
            lam[k] += y[p]
            apply_row_impulse(k, body_a[k], body_b[k], JM, y[p], V)
            worst = max(worst, abs(y[p]) * A_kk[k])
    return worst


@njit(cache=True)
def joint_system(joints, rows, direct_joints):
    """What the joint rows keep over the tick: (eq, L, first, C, direct): eq the equality rows
    (``_equality_rows``), L and first their factor (``factor_joint_rows``) when ``direct``
    (``direct_joints`` and at most DIRECT_JOINT_ROWS_MAX of them), C each joint row's error.
    None for a world without joints (joints None): nothing to keep, nothing allocated, and
    none of the joints' code compiled."""
    if joints is None:
        return None
    first_joint_row, n_rows = first_joint_row_of(rows), rows.lam.shape[0]
    eq = _equality_rows(first_joint_row, n_rows, rows.lo)
    direct = direct_joints and 0 < eq.shape[0] <= DIRECT_JOINT_ROWS_MAX
    L = np.zeros((eq.shape[0], eq.shape[0])) if direct else np.zeros((0, 0))
    first = np.zeros(eq.shape[0], np.int64)
    C = np.zeros(n_rows)
    return eq, L, first, C, direct


@njit(cache=True)
def prepare_joints(joints, bodies, rows, system):
    """The joint rows at the bodies' positions now (``joint_rows`` into ``rows``): J, A_kk
    and their error C; with ``direct`` the factor of the equality rows' A."""
    first_joint_row, n_rows = first_joint_row_of(rows), rows.lam.shape[0]
    eq, L, first, C, direct = system
    joint_rows(joints, first_joint_row, bodies, 1.0, 1.0, rows)  # beta = dt = 1: xi + push = -C
    _joint_C(first_joint_row, n_rows, rows.xi, rows.push, C)
    if direct:
        factor_joint_rows(eq, rows.body_a, rows.body_b, rows.J, rows.JM, L, first)
