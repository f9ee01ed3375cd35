"""Constraint rows: the lecture's J, one row per constraint, 6 non-zeros each.

A row k couples bodies i and j. Everything the responders need is stored per row:

    i, j       the two bodies (indices into the body arrays)
    J          (R, 6)  [J_i | J_j]: the row's only non-zero entries of the lecture's J
    JM         (R, 6)  M^-1 J^T for the same entries: the velocity change per unit lambda
    A_diag     (R,)    A_kk = J_k M^-1 J_k^T, the diagonal of A = J M^-1 J^T
    xi         (R,)    the velocity J_k V2 must reach (Baumgarte push, bounce, or 0)
    lo, hi     (R,)    fixed bounds on lambda_k
    bound_row  (R,)    for a Coulomb friction row: its normal row, whose current lambda
                       sets the bounds +-mu * lambda_n; -1 for rows with fixed bounds
    mu         (R,)    friction coefficient of a friction row
    lam        (R,)    lambda_k, impulses in N s: the warm start going in, the answer coming out
    kind       (R,)    ROW_NORMAL, ROW_FRICTION, ROW_JOINT
    order      (K,)    which contact each pair of rows belongs to: rows 2q (normal)
                       and 2q + 1 (friction) are contact order[q]'s. The rows are
                       stored in the order the responders visit them (graph colouring,
                       see ``constraints.order``); joint rows follow the contact rows.
"""

from __future__ import annotations

import numpy as np
from numba import njit

ROW_NORMAL = 0
ROW_FRICTION = 1
ROW_JOINT = 2

FRICTION_COULOMB = 0
FRICTION_LECTURE = 1


class Rows:
    """The constraint rows of one step (arrays of length R)."""

    def __init__(self, n_rows: int) -> None:
        self.i = np.zeros(n_rows, np.int32)
        self.j = np.zeros(n_rows, np.int32)
        self.J = np.zeros((n_rows, 6))
        self.JM = np.zeros((n_rows, 6))
        self.A_diag = np.zeros(n_rows)
        self.xi = np.zeros(n_rows)
        self.lo = np.zeros(n_rows)
        self.hi = np.zeros(n_rows)
        self.bound_row = np.full(n_rows, -1, np.int32)
        self.mu = np.zeros(n_rows)
        self.lam = np.zeros(n_rows)
        self.kind = np.zeros(n_rows, np.int8)
        self.order = np.arange(n_rows // 2, dtype=np.int32)  # rows 2q, 2q + 1 are contact order[q]

    def __len__(self) -> int:
        return int(self.i.shape[0])

    def head(self, n_rows: int) -> Rows:
        """The first n_rows rows as views (no copy), with lambda reset to 0."""
        rows = object.__new__(Rows)
        for name in ("i", "j", "J", "JM", "A_diag", "xi", "lo", "hi", "bound_row", "mu", "lam", "kind"):
            setattr(rows, name, getattr(self, name)[:n_rows])
        rows.lam[:] = 0.0
        rows.order = np.zeros(0, np.int32)  # the caller sets the contacts' solve order
        return rows


class RowBuffer:
    """Row storage reused from step to step, so a step allocates no row arrays."""

    def __init__(self) -> None:
        self._rows = Rows(0)
        self._head = self._rows.head(0)

    def take(self, n_rows: int) -> Rows:
        """The first n_rows rows, lambda at 0 (the same views as last step when the count holds)."""
        if n_rows > len(self._rows):
            self._rows = Rows(max(n_rows, 2 * len(self._rows)))
        elif n_rows == len(self._head):
            self._head.lam[:] = 0.0
            return self._head
        self._head = self._rows.head(n_rows)
        return self._head


@njit(cache=True)
def fill_row(k, i, j, r_ix, r_iy, r_jx, r_jy, dx, dy, M_inv, J, JM, A_diag):
    """Row k of J for direction d acting at lever arms r_i, r_j: [-d, -(r_i x d) | d, r_j x d]."""
    J[k, 0] = -dx
    J[k, 1] = -dy
    J[k, 2] = -(r_ix * dy - r_iy * dx)
    J[k, 3] = dx
    J[k, 4] = dy
    J[k, 5] = r_jx * dy - r_jy * dx
    a = 0.0
    for c in range(3):
        JM[k, c] = M_inv[i, c] * J[k, c]
        JM[k, 3 + c] = M_inv[j, c] * J[k, 3 + c]
        a += J[k, c] * JM[k, c] + J[k, 3 + c] * JM[k, 3 + c]
    A_diag[k] = a


@njit(cache=True)
def row_velocity(k, i, j, J, V):
    """J_k V: the row's relative velocity (m/s for contacts)."""
    return (J[k, 0] * V[i, 0] + J[k, 1] * V[i, 1] + J[k, 2] * V[i, 2]
            + J[k, 3] * V[j, 0] + J[k, 4] * V[j, 1] + J[k, 5] * V[j, 2])


@njit(cache=True)
def apply_row_impulse(k, i, j, JM, impulse, V):
    """V += M^-1 J_k^T impulse: what an impulse along row k does to bodies i and j."""
    for c in range(3):
        V[i, c] += JM[k, c] * impulse
        V[j, c] += JM[k, 3 + c] * impulse


@njit(cache=True)
def contact_rows(order, body_a, body_b, point, normal, separation, mu, e, x, V1, M_inv, dt, beta,
                 slop, restitution_threshold, friction_model, gravity, points_in_manifold,
                 out_i, out_j, J, JM, A_diag, xi, lo, hi, bound_row, out_mu, kind):
    """Normal row 2q and friction row 2q + 1 for contact point c = order[q] (FORMULATION.md).

    Normal:   xi = -(beta/dt) min(0, C + slop) when touching (C <= 0); xi = -C/dt for a
              speculative point still C > 0 apart (it may close the gap, no more); the
              bounce -e (J V1) instead when larger and the approach speed exceeds the
              threshold; lambda in [0, inf).
    Friction: t = (-n_y, n_x), xi = 0; Coulomb bounds +-mu lambda_n of row 2q, or the
              lecture's fixed +-mu m_c g dt (lambda is an impulse, hence dt), with m_c
              the pair's reduced mass shared among the manifold's points.
    """
    for q in range(order.shape[0]):
        c = order[q]
        i, j = body_a[c], body_b[c]
        nx, ny = normal[c, 0], normal[c, 1]
        r_ix, r_iy = point[c, 0] - x[i, 0], point[c, 1] - x[i, 1]
        r_jx, r_jy = point[c, 0] - x[j, 0], point[c, 1] - x[j, 1]
        k = 2 * q
        out_i[k] = i
        out_j[k] = j
        fill_row(k, i, j, r_ix, r_iy, r_jx, r_jy, nx, ny, M_inv, J, JM, A_diag)
        if separation[c] > 0.0:
            push = -separation[c] / dt  # speculative: close the gap within the step, no more
        else:
            push = -(beta / dt) * min(0.0, separation[c] + slop)  # Baumgarte
        vn = row_velocity(k, i, j, J, V1)
        # bounce only a point that approaches fast and will touch within this step
        if vn < -restitution_threshold and separation[c] + dt * vn <= 0.0:
            push = max(push, -e[c] * vn)
        xi[k] = push
        lo[k] = 0.0
        hi[k] = np.inf
        bound_row[k] = -1
        out_mu[k] = 0.0
        kind[k] = 0
        k += 1
        out_i[k] = i
        out_j[k] = j
        fill_row(k, i, j, r_ix, r_iy, r_jx, r_jy, -ny, nx, M_inv, J, JM, A_diag)
        xi[k] = 0.0
        out_mu[k] = mu[c]
        kind[k] = 1
        if friction_model == 0:
            bound_row[k] = k - 1
            lo[k] = -np.inf
            hi[k] = np.inf
        else:
            # the reduced mass of the pair: a static partner counts as infinitely heavy
            inv = M_inv[i, 0] + M_inv[j, 0]
            m_c = (1.0 / inv if inv > 0.0 else 0.0) / points_in_manifold[c]
            # fixed: it does not look at lambda_n, so it acts on speculative points too
            bound = mu[c] * m_c * gravity * dt
            bound_row[k] = -1
            lo[k] = -bound
            hi[k] = bound
