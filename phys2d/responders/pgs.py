"""Projected Gauss-Seidel, impulse form (sequential impulses), with warm starting.

The lecture's PGS on A lambda = b, with A = J M^-1 J^T never formed: the term
sum_l A_kl lambda_l - b_k is J_k V - xi_k, read off the velocities that every
impulse applied so far has produced (FORMULATION.md, "Projected Gauss-Seidel").

One step (``PGS.respond``):

    V += M^-1 J^T lambda              warm start (contact caching)
    sweeps on A lambda = b            xi: a point still apart may close its gap, no more
    sweeps on A lambda_p >= push      split impulses (``push_out``): pseudo-velocities V_p
    x += dt (V + V_p)                 V_p is dropped: the push never becomes velocity
    restitution pass                  points that met their partner fast bounce (restitution.py)

With split=False the push is part of xi, as the lecture has it, and stays in V.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..constraints.rows import FRICTION_COULOMB, FRICTION_LECTURE
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
from .pgs_matrix import solve_matrix_form
from .restitution import bounce_after_moving


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
def lcp2(K11, K12, K22, b1, b2):
    """The 2x2 LCP: x >= 0, w = K x + b >= 0, x . w = 0, by trying the four active sets.

    K = [[K11, K12], [K12, K22]] must be symmetric positive definite.
    """
    det = K11 * K22 - K12 * K12
    x1 = -(K22 * b1 - K12 * b2) / det  # both rows push
    x2 = -(K11 * b2 - K12 * b1) / det
    if x1 >= 0.0 and x2 >= 0.0:
        return x1, x2
    x1 = -b1 / K11  # only row 1 pushes
    if x1 >= 0.0 and K12 * x1 + b2 >= 0.0:
        return x1, 0.0
    x2 = -b2 / K22  # only row 2 pushes
    if x2 >= 0.0 and K12 * x2 + b1 >= 0.0:
        return 0.0, x2
    return 0.0, 0.0  # both separate


@njit(cache=True)
def block_is_well_conditioned(K11, K12, K22):
    """False when the two rows are nearly parallel: then solve them one by one."""
    return K11 * K11 < 1000.0 * (K11 * K22 - K12 * K12)


@njit(cache=True)
def sweep(normal_row, friction_row, first_joint_row, i, j, J, JM, A_diag, inv_A, xi, lo, hi, bound_row, mu,
          lam, V, block):
    """One projected Gauss-Seidel sweep over the rows; returns the largest |delta lambda_k| A_kk (m/s).

    Contacts in solve order: each one's normal row then its friction row (the
    lecture's PGS, row by row), or with ``block`` each two-point manifold's normal
    rows together as a 2x2 LCP (Box2D's block solver), then its two friction rows.
    Joint rows (first_joint_row on) come last. A friction row of -1 is skipped (the
    push pass sweeps normal rows only). The row update is written out here, not
    called: a call per row costs more than the row.
    """
    worst = 0.0
    n_contacts = normal_row.shape[0]
    n_steps = n_contacts + lam.shape[0] - first_joint_row
    q = 0
    while q < n_steps:
        if q >= n_contacts:
            k = first_joint_row + (q - n_contacts)
            first, second, step = k, -1, 1  # a joint row
        else:
            k = normal_row[q]
            first, second, step = k, friction_row[q], 1  # a contact's normal and friction rows
        a, b = i[k], j[k]
        if block and q + 1 < n_contacts and i[normal_row[q + 1]] == a and j[normal_row[q + 1]] == b:
            n1, n2 = k, normal_row[q + 1]
            K11, K22 = A_diag[n1], A_diag[n2]
            K12 = 0.0
            for c in range(6):
                K12 += J[n1, c] * JM[n2, c]
            if block_is_well_conditioned(K11, K12, K22):
                a1, a2 = lam[n1], lam[n2]
                vn1 = (J[n1, 0] * V[a, 0] + J[n1, 1] * V[a, 1] + J[n1, 2] * V[a, 2]
                       + J[n1, 3] * V[b, 0] + J[n1, 4] * V[b, 1] + J[n1, 5] * V[b, 2])
                vn2 = (J[n2, 0] * V[a, 0] + J[n2, 1] * V[a, 1] + J[n2, 2] * V[a, 2]
                       + J[n2, 3] * V[b, 0] + J[n2, 4] * V[b, 1] + J[n2, 5] * V[b, 2])
                # the new lambda x solves K x + (J V - xi - K a) >= 0, x >= 0, complementary
                x1, x2 = lcp2(K11, K12, K22, vn1 - xi[n1] - (K11 * a1 + K12 * a2),
                              vn2 - xi[n2] - (K12 * a1 + K22 * a2))
                d1, d2 = x1 - a1, x2 - a2
                lam[n1] = x1
                lam[n2] = x2
                for c in range(3):
                    V[a, c] += JM[n1, c] * d1 + JM[n2, c] * d2
                    V[b, c] += JM[n1, 3 + c] * d1 + JM[n2, 3 + c] * d2
                worst = max(worst, abs(d1) * K11, abs(d2) * K22)
                first, second, step = friction_row[q], friction_row[q + 1], 2  # then the two friction rows
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
def inverse_diagonal(A_diag):
    """1 / A_kk (0 where A_kk = 0), once per step: sweeps multiply, never divide."""
    inv_A = np.zeros(A_diag.shape[0])
    for k in range(A_diag.shape[0]):
        if A_diag[k] > 0.0:
            inv_A[k] = 1.0 / A_diag[k]
    return inv_A


@njit(cache=True)
def pgs_solve(normal_row, friction_row, first_joint_row, i, j, J, JM, A_diag, xi, lo, hi, bound_row, mu, lam,
              V, iterations, tolerance, residuals, block):
    """Warm start from ``lam``, then sweep until the residual <= tolerance or out of sweeps.

    Returns the number of sweeps made; residuals[s] is the residual after sweep s.
    """
    apply_impulses(i, j, JM, lam, V)
    inv_A = inverse_diagonal(A_diag)
    for s in range(iterations):
        residuals[s] = sweep(normal_row, friction_row, first_joint_row, i, j, J, JM, A_diag, inv_A, xi, lo, hi,
                             bound_row, mu, lam, V, block)
        if residuals[s] <= tolerance:
            return s + 1
    return iterations


@njit(cache=True)
def push_out(normal_row, i, j, J, JM, A_diag, push, lo, hi, bound_row, mu, lam_push, V_push, iterations,
             tolerance, block):
    """Split impulses: sweep the contact normal rows for pseudo-velocities V_push that reach
    J_k V_push >= push_k (the capped Baumgarte push), lam_push >= 0, from V_push = 0.

    Positions then move with V + V_push, and V_push is dropped: the push removes overlap
    without ever becoming velocity, so a stack pushed out of a deep overlap is not thrown.
    Nothing is warm started. Returns the sweeps made (0 when no point overlaps past slop).
    """
    pushing = False
    for q in range(normal_row.shape[0]):
        pushing = pushing or push[normal_row[q]] > 0.0
    if not pushing:
        return 0
    inv_A = inverse_diagonal(A_diag)
    no_friction = np.full(normal_row.shape[0], -1, np.int32)
    for s in range(iterations):
        # first_joint_row = the row count: no joint rows, normal rows only
        worst = sweep(normal_row, no_friction, lam_push.shape[0], i, j, J, JM, A_diag, inv_A, push, lo, hi,
                      bound_row, mu, lam_push, V_push, block)
        if worst <= tolerance:
            return s + 1
    return iterations


FORMS = ("impulse", "matrix")
FRICTION_MODELS = {"coulomb": FRICTION_COULOMB, "lecture": FRICTION_LECTURE}


def _check_block_and_form(block: bool, form: str) -> None:
    if block and form == "matrix":
        raise ValueError("block=True solves manifolds in pairs of rows; form='matrix' is the "
                         "lecture's row-by-row sweep: use one or the other")


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

    iterations = Setting(lambda v, name: check_int(v, name, 1), "sweeps per step")
    warm_start = Setting(check_bool, "start from last tick's impulses")
    beta = Setting(lambda v, name: float_in(v, name, 0.0, 1.0), "Baumgarte push factor")
    slop = Setting(non_negative_float, "overlap left alone, m")
    push_max = Setting(non_negative_float, "largest push-out speed, m/s")
    split = Setting(check_bool, "push through pseudo-velocities that never become velocity")
    tolerance = Setting(optional_non_negative_float, "residual (m/s) that stops the sweeps, or None")
    restitution_threshold = Setting(non_negative_float, "approach speed (m/s) above which e applies")

    def __init__(self, iterations: int = 10, warm_start: bool = True, beta: float = 0.2,
                 slop: float = 0.005, tolerance: float | None = None,
                 restitution_threshold: float = 1.0, friction: str = "coulomb",
                 form: str = "impulse", block: bool = False, push_max: float = 3.0,
                 split: bool = True) -> None:
        self.iterations = iterations
        self.warm_start = warm_start
        self.beta = beta
        self.slop = slop
        self.push_max = push_max
        self.split = split
        self.tolerance = tolerance
        self.restitution_threshold = restitution_threshold
        self.friction = friction
        self._form = one_of(form, "form", FORMS)
        self.block = block

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

    def respond(self, ctx: StepContext) -> SolveResult:
        r = ctx.rows
        tol = -1.0 if self.tolerance is None else self.tolerance
        xi = r.xi if self.split else r.xi + r.push  # the lecture: the push is part of the target
        if self.form == "matrix":
            return solve_matrix_form(ctx, xi, self.iterations, tol, self.split)
        residuals = np.zeros(self.iterations)
        n = pgs_solve(r.normal_row, r.friction_row, r.first_joint_row, r.i, r.j, r.J, r.JM, r.A_diag, xi,
                      r.lo, r.hi, r.bound_row, r.mu, r.lam, ctx.V, self.iterations, tol, residuals, self.block)
        V_move = ctx.V
        if self.split:
            V_push = np.zeros_like(ctx.V)
            push_out(r.normal_row, r.i, r.j, r.J, r.JM, r.A_diag, r.push, r.lo, r.hi, r.bound_row, r.mu,
                     np.zeros(len(r)), V_push, self.iterations, tol, self.block)
            V_move = ctx.V + V_push  # what the positions move with; V_push is then dropped
        bounce_after_moving(ctx, V_move, self.iterations, tol)
        return SolveResult(n, residuals[:n], integrated=True)

    def __repr__(self) -> str:
        tol = "None" if self.tolerance is None else f"{self.tolerance:g}"
        return (f"PGS(iterations={self.iterations}, warm_start={self.warm_start}, beta={self.beta:g}, "
                f"slop={self.slop:g}, tolerance={tol}, friction={self.friction!r}, form={self.form!r}, "
                f"block={self.block}, push_max={self.push_max:g}, split={self.split})")


__all__ = ["PGS", "apply_impulses", "lcp2", "pgs_solve", "sweep"]
