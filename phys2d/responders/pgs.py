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
def pgs_sweep(i, j, J, JM, A_diag, xi, lo, hi, bound_row, mu, lam, V):
    """One Gauss-Seidel sweep over the rows; returns the largest |delta lambda_k| A_kk (m/s)."""
    worst = 0.0
    for k in range(lam.shape[0]):
        if A_diag[k] <= 0.0:
            continue  # both bodies static: nothing can move
        a, b = i[k], j[k]
        jv = (J[k, 0] * V[a, 0] + J[k, 1] * V[a, 1] + J[k, 2] * V[a, 2]
              + J[k, 3] * V[b, 0] + J[k, 4] * V[b, 1] + J[k, 5] * V[b, 2])
        delta = (xi[k] - jv) / A_diag[k]  # (b_k - sum_l A_kl lambda_l) / A_kk
        if bound_row[k] >= 0:  # Coulomb: the cone follows the current normal impulse
            top = mu[k] * lam[bound_row[k]]
            low = -top
        else:
            low = lo[k]
            top = hi[k]
        # clamp the accumulated impulse, not the increment
        new = min(max(lam[k] + delta, low), top)
        delta = new - lam[k]
        lam[k] = new
        for c in range(3):
            V[a, c] += JM[k, c] * delta
            V[b, c] += JM[k, 3 + c] * delta
        err = abs(delta) * A_diag[k]
        if err > worst:
            worst = err
    return worst


@njit(cache=True)
def pgs_solve(i, j, J, JM, A_diag, xi, lo, hi, bound_row, mu, lam, V, iterations, tolerance,
              residuals):
    """Warm start from ``lam``, then sweep until the residual <= tolerance or out of sweeps.

    Returns the number of sweeps made; residuals[s] is the residual after sweep s.
    """
    apply_impulses(i, j, JM, lam, V)
    for s in range(iterations):
        residuals[s] = pgs_sweep(i, j, J, JM, A_diag, xi, lo, hi, bound_row, mu, lam, V)
        if residuals[s] <= tolerance:
            return s + 1
    return iterations


def _check_int(value, name: str, low: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{name} must be an integer, got {type(value).__name__}")
    if value < low:
        raise ValueError(f"{name} must be >= {low}, got {value}")
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
    """

    name = "pgs"
    handles_joints = True

    def __init__(self, iterations: int = 10, warm_start: bool = True, beta: float = 0.2,
                 slop: float = 0.005, tolerance: float | None = None,
                 restitution_threshold: float = 1.0, friction: str = "coulomb",
                 form: str = "impulse") -> None:
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
        if friction not in models:
            raise ValueError(f"friction must be 'coulomb' or 'lecture', got {friction!r}")
        self.friction = friction
        self.friction_model = models[friction]
        if form not in ("impulse", "matrix"):
            raise ValueError(f"form must be 'impulse' or 'matrix', got {form!r}")
        self.form = form
        if form == "matrix":
            self.name = "pgs-matrix"
        if not self.warm_start:
            self.name += "-cold"

    def respond(self, ctx: StepContext) -> SolveResult:
        r = ctx.rows
        residuals = np.zeros(self.iterations)
        tol = -1.0 if self.tolerance is None else self.tolerance
        if self.form == "matrix":
            return solve_matrix_form(ctx, self.iterations, tol)
        n = pgs_solve(r.i, r.j, r.J, r.JM, r.A_diag, r.xi, r.lo, r.hi, r.bound_row, r.mu, r.lam,
                      ctx.V, self.iterations, tol, residuals)
        return SolveResult(n, residuals[:n])

    def __repr__(self) -> str:
        tol = "None" if self.tolerance is None else f"{self.tolerance:g}"
        return (f"PGS(iterations={self.iterations}, warm_start={self.warm_start}, beta={self.beta:g}, "
                f"slop={self.slop:g}, tolerance={tol}, friction={self.friction!r}, form={self.form!r})")


__all__ = ["PGS", "apply_impulses", "pgs_solve", "pgs_sweep"]
