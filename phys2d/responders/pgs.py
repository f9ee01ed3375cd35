"""Projected Gauss-Seidel, impulse form (sequential impulses), with warm starting.

The lecture's PGS on A lambda = b, with A = J M^-1 J^T never formed: the term
sum_l A_kl lambda_l - b_k is J_k V - xi_k, read off the velocities that every
impulse applied so far has produced (FORMULATION.md, "Projected Gauss-Seidel").
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..constraints.rows import FRICTION_COULOMB, FRICTION_LECTURE
from ..shapes import finite_float
from .base import Responder, SolveResult, StepContext
from .pgs_matrix import solve_matrix_form


@njit(cache=True)
def apply_impulses(i, j, JM, lam, V):
    """V += M^-1 J^T lambda: the warm start, one row at a time."""
    for k in range(lam.shape[0]):
        if lam[k] == 0.0:
            continue
        a, b = i[k], j[k]
        for c in range(3):
            V[a, c] += JM[k, c] * lam[k]
            V[b, c] += JM[k, 3 + c] * lam[k]


@njit(cache=True)
def lcp2(k11, k12, k22, b1, b2):
    """The 2x2 LCP: x >= 0, w = K x + b >= 0, x . w = 0, by trying the four active sets.

    K = [[k11, k12], [k12, k22]] must be symmetric positive definite.
    """
    det = k11 * k22 - k12 * k12
    x1 = -(k22 * b1 - k12 * b2) / det  # both rows push
    x2 = -(k11 * b2 - k12 * b1) / det
    if x1 >= 0.0 and x2 >= 0.0:
        return x1, x2
    x1 = -b1 / k11  # only row 1 pushes
    if x1 >= 0.0 and k12 * x1 + b2 >= 0.0:
        return x1, 0.0
    x2 = -b2 / k22  # only row 2 pushes
    if x2 >= 0.0 and k12 * x2 + b1 >= 0.0:
        return 0.0, x2
    return 0.0, 0.0  # both separate


@njit(cache=True)
def block_is_well_conditioned(k11, k12, k22):
    """False when the two rows are nearly parallel: then solve them one by one."""
    return k11 * k11 < 1000.0 * (k11 * k22 - k12 * k12)


@njit(cache=True)
def sweep(n_contacts, i, j, J, JM, A_diag, inv_A, xi, lo, hi, bound_row, mu, lam, V, block):
    """One projected Gauss-Seidel sweep over the rows; returns the largest |delta lambda_k| A_kk (m/s).

    Rows in order: each contact's normal row then its friction row (the lecture's
    PGS, row by row), or with ``block`` each two-point manifold's normal rows
    together as a 2x2 LCP (Box2D's block solver), then its two friction rows.
    Joint rows come last.
    """
    worst = 0.0
    n_steps = n_contacts + lam.shape[0] - 2 * n_contacts
    q = 0
    while q < n_steps:
        if q >= n_contacts:
            k = 2 * n_contacts + (q - n_contacts)
            first, second, step = k, -1, 1  # a joint row
        else:
            k = 2 * q
            first, second, step = k, k + 1, 1  # a contact's normal and friction rows
        a, b = i[k], j[k]
        if block and q + 1 < n_contacts and i[k + 2] == a and j[k + 2] == b:
            n1, n2 = k, k + 2
            k11, k22 = A_diag[n1], A_diag[n2]
            k12 = 0.0
            for c in range(6):
                k12 += J[n1, c] * JM[n2, c]
            if block_is_well_conditioned(k11, k12, k22):
                a1, a2 = lam[n1], lam[n2]
                vn1 = (J[n1, 0] * V[a, 0] + J[n1, 1] * V[a, 1] + J[n1, 2] * V[a, 2]
                       + J[n1, 3] * V[b, 0] + J[n1, 4] * V[b, 1] + J[n1, 5] * V[b, 2])
                vn2 = (J[n2, 0] * V[a, 0] + J[n2, 1] * V[a, 1] + J[n2, 2] * V[a, 2]
                       + J[n2, 3] * V[b, 0] + J[n2, 4] * V[b, 1] + J[n2, 5] * V[b, 2])
                # the new lambda x solves K x + (J V - xi - K a) >= 0, x >= 0, complementary
                x1, x2 = lcp2(k11, k12, k22, vn1 - xi[n1] - (k11 * a1 + k12 * a2),
                              vn2 - xi[n2] - (k12 * a1 + k22 * a2))
                d1, d2 = x1 - a1, x2 - a2
                lam[n1] = x1
                lam[n2] = x2
                for c in range(3):
                    V[a, c] += JM[n1, c] * d1 + JM[n2, c] * d2
                    V[b, c] += JM[n1, 3 + c] * d1 + JM[n2, 3 + c] * d2
                worst = max(worst, abs(d1) * k11, abs(d2) * k22)
                first, second, step = n1 + 1, n2 + 1, 2  # then the two friction rows
        for r in range(2):
            kk = first if r == 0 else second
            if kk < 0 or A_diag[kk] <= 0.0:
                continue  # no row, or both bodies static: nothing can move
            if bound_row[kk] >= 0 and lam[bound_row[kk]] == 0.0 and lam[kk] == 0.0:
                continue  # friction of a point that does not push: its cone is [0, 0], nothing to do
            jv = (J[kk, 0] * V[a, 0] + J[kk, 1] * V[a, 1] + J[kk, 2] * V[a, 2]
                  + J[kk, 3] * V[b, 0] + J[kk, 4] * V[b, 1] + J[kk, 5] * V[b, 2])
            delta = (xi[kk] - jv) * inv_A[kk]  # (b_k - sum_l A_kl lambda_l) / A_kk
            if bound_row[kk] >= 0:  # Coulomb: the cone follows the current normal impulse
                top = mu[kk] * lam[bound_row[kk]]
                low = -top
            else:
                low = lo[kk]
                top = hi[kk]
            # clamp the accumulated impulse, not the increment
            new = min(max(lam[kk] + delta, low), top)
            delta = new - lam[kk]
            lam[kk] = new
            for c in range(3):
                V[a, c] += JM[kk, c] * delta
                V[b, c] += JM[kk, 3 + c] * delta
            err = abs(delta) * A_diag[kk]
            if err > worst:
                worst = err
        q += step
    return worst


@njit(cache=True)
def pgs_solve(i, j, J, JM, A_diag, xi, lo, hi, bound_row, mu, lam, V, iterations, tolerance,
              residuals, block, n_contacts):
    """Warm start from ``lam``, then sweep until the residual <= tolerance or out of sweeps.

    Returns the number of sweeps made; residuals[s] is the residual after sweep s.
    """
    apply_impulses(i, j, JM, lam, V)
    inv_A = np.zeros(A_diag.shape[0])  # 1 / A_kk, once per step: sweeps multiply, never divide
    for k in range(A_diag.shape[0]):
        if A_diag[k] > 0.0:
            inv_A[k] = 1.0 / A_diag[k]
    for s in range(iterations):
        residuals[s] = sweep(n_contacts, i, j, J, JM, A_diag, inv_A, xi, lo, hi, bound_row, mu, lam, V, block)
        if residuals[s] <= tolerance:
            return s + 1
    return iterations


MAX_SWEEPS = 100_000  # per step: far past convergence, and the residual buffer stays small


def _check_int(value, name: str, low: int, high: int = MAX_SWEEPS) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{name} must be an integer, got {type(value).__name__}")
    if not low <= value <= high:
        raise ValueError(f"{name} must be between {low} and {high}, got {value}")
    return int(value)


class PGS(Responder):
    """Projected Gauss-Seidel with contact caching (warm starting).

    iterations   sweeps per step (>= 1)
    warm_start   start each contact's lambda from last tick's (contact caching)
    beta         Baumgarte push factor in [0, 1]: xi = -(beta/dt) min(0, C + slop)
    slop         overlap (m) left alone, so resting contacts stay touching
    tolerance    stop early once a sweep's residual (m/s) is at most this; None: never
    restitution_threshold  approach speed (m/s) above which e applies
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
    """

    name = "pgs"
    handles_joints = True

    def __init__(self, iterations: int = 10, warm_start: bool = True, beta: float = 0.2,
                 slop: float = 0.005, tolerance: float | None = None,
                 restitution_threshold: float = 1.0, friction: str = "coulomb",
                 form: str = "impulse", block: bool = False) -> None:
        self.iterations = _check_int(iterations, "iterations", 1)
        if not isinstance(warm_start, (bool, np.bool_)):
            raise TypeError(f"warm_start must be True or False, got {warm_start!r}")
        self.warm_start = bool(warm_start)
        self.beta = finite_float(beta, "beta")
        if not 0.0 <= self.beta <= 1.0:
            raise ValueError(f"beta must be in [0, 1], got {self.beta}")
        self.slop = finite_float(slop, "slop")
        if self.slop < 0.0:
            raise ValueError(f"slop must be >= 0, got {self.slop}")
        if tolerance is not None:
            tolerance = finite_float(tolerance, "tolerance")
            if tolerance < 0.0:
                raise ValueError(f"tolerance must be >= 0, got {tolerance}")
        self.tolerance = tolerance
        self.restitution_threshold = finite_float(restitution_threshold, "restitution_threshold")
        if self.restitution_threshold < 0.0:
            raise ValueError(f"restitution_threshold must be >= 0, got {self.restitution_threshold}")
        models = {"coulomb": FRICTION_COULOMB, "lecture": FRICTION_LECTURE}
        if not isinstance(friction, str) or friction not in models:
            raise ValueError(f"friction must be 'coulomb' or 'lecture', got {friction!r}")
        self.friction = friction
        self.friction_model = models[friction]
        if not isinstance(form, str) or form not in ("impulse", "matrix"):
            raise ValueError(f"form must be 'impulse' or 'matrix', got {form!r}")
        self.form = form
        if form == "matrix":
            self.name = "pgs-matrix"
        if not isinstance(block, (bool, np.bool_)):
            raise TypeError(f"block must be True or False, got {block!r}")
        self.block = bool(block)
        if self.block and form == "matrix":
            raise ValueError("block=True solves manifolds in pairs of rows; form='matrix' is the "
                             "lecture's row-by-row sweep: use one or the other")
        if self.block:
            self.name = "pgs-block"
        if not self.warm_start:
            self.name += "-cold"

    def respond(self, ctx: StepContext) -> SolveResult:
        r = ctx.rows
        residuals = np.zeros(self.iterations)
        tol = -1.0 if self.tolerance is None else self.tolerance
        if self.form == "matrix":
            return solve_matrix_form(ctx, self.iterations, tol)
        n = pgs_solve(r.i, r.j, r.J, r.JM, r.A_diag, r.xi, r.lo, r.hi, r.bound_row, r.mu, r.lam,
                      ctx.V, self.iterations, tol, residuals, self.block, ctx.n_contacts)
        return SolveResult(n, residuals[:n])

    def __repr__(self) -> str:
        tol = "None" if self.tolerance is None else f"{self.tolerance:g}"
        return (f"PGS(iterations={self.iterations}, warm_start={self.warm_start}, beta={self.beta:g}, "
                f"slop={self.slop:g}, tolerance={tol}, friction={self.friction!r}, form={self.form!r}, "
                f"block={self.block})")


__all__ = ["PGS", "apply_impulses", "lcp2", "pgs_solve", "sweep"]
