"""Projected Gauss-Seidel, matrix form: the lecture's A x = b, assembled and swept.

Each step this builds, exactly as docs/formulation.md writes them,

    J      (R, 3N)  sparse: row k has its 6 non-zeros in the columns of bodies a and b
                    (3 for a row between a body and the world: a mouse joint's)
    M^-1   (3N,)    the diagonal [1/m_1, 1/m_1, 1/I_1, ...] (0 for static bodies)
    A      (R, R)   J M^-1 J^T, sparse: A_kl != 0 only where rows k and l share a
                    dynamic body (static bodies have M^-1 = 0 and couple nothing);
                    plus a compliance on the mouse joints' 2x2 blocks (below)
    b      (R,)     xi - J V1 - dt J M^-1 F_ext
    lo, hi (R,)     bounds on lambda; a Coulomb friction row's are +-mu lambda_n of its
                    normal row, so they move as the sweeps go

and runs the lecture's pseudocode on them, skipping the zero entries of A:

    repeat until converged (or out of iterations):
        for each row k:
            delta  = (b_k - sum_l A_kl x_l) / A_kk
            x_k    = clamp(x_k + delta, lo_k, hi_k)

then V2 = V1 + M^-1 (dt F_ext + J^T x).

A mouse joint's two rows (bound_row ``OWN_SOLVE``) are a soft spring, not rigid rows:
with a1, a2, a3 of its spring over the step (docs/formulation.md, "Mouse"), their 2x2
block of A is K / (a2 a3) = K + K / a2 (K = J M^-1 J^T there: the rigid block made
compliant), their b_k = -(J V0 + (omega / a1) C) (xi_k = -(omega / a1) C: the spring's
target, not the rigid -C/dt), and the row loop skips them: after each sweep each such
pair is solved as one 2x2 block, and (x_k, x_k+1) is clamped to the disk of radius
max_force dt (``solve_disk_block``), as the impulse form's ``mouse.solve_mice`` does.

Row order, warm start (x starts at the cached lambdas), bounds and the residual (the
largest |delta_k| A_kk of a sweep, m/s) are those of the impulse form, so the two forms
make the same iterates: the test that the lecture's equations and the fast solver are
one method. The split push is a second system on the same A, A x_p >= push over the
contact normal rows from x_p = 0; positions move with V2 + M^-1 J^T x_p; then the
restitution pass (shared with the impulse form) adds lam_bounce.

The sparse matrices are plain CSR arrays (``SparseMatrix``): no scipy. Everything
assembled stays on ``w.last_step.system`` (a ``MatrixSystem``) for lessons;
``system.dense()`` expands a small one into ordinary numpy matrices.
"""

from __future__ import annotations

from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np

from ..constraints.joints import JOINT_MOUSE, OWN_SOLVE, JointArrays
from ..constraints.rows import Rows, clamp_accumulated, coupling, push_rows
from ..jit import njit
from ..pipeline.records import record_of_joints
from .base import SolveResult, StepContext
from .mouse import clamp_to_disk, has_mouse, mouse_springs
from .restitution import bounce_after_moving

DENSE_MAX_ENTRIES = 4_000_000  # dense() refuses matrices larger than this (8 bytes each)


class SparseMatrix:
    """A sparse matrix in CSR form: row k's entries are data[indptr[k]:indptr[k+1]]
    in the columns indices[indptr[k]:indptr[k+1]] (ascending)."""

    def __init__(self, indptr: np.ndarray, indices: np.ndarray, data: np.ndarray, shape: tuple[int, int]) -> None:
        self.indptr = indptr
        self.indices = indices
        self.data = data
        self.shape = shape

    @property
    def csr(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(indptr, indices, data): the matrix as the kernels take it."""
        return self.indptr, self.indices, self.data

    @property
    def nnz(self) -> int:
        """How many entries are stored."""
        return int(self.indptr[-1])

    def dot(self, v: np.ndarray) -> np.ndarray:
        """The product with a vector of length shape[1]."""
        v = np.asarray(v, np.float64)
        if v.shape != (self.shape[1],):
            raise ValueError(f"v must have shape ({self.shape[1]},), got {v.shape}")
        out = np.zeros(self.shape[0])
        _csr_dot(self.indptr, self.indices, self.data, v, out)
        return out

    def dot_transposed(self, v: np.ndarray) -> np.ndarray:
        """The product of the transpose with a vector of length shape[0]."""
        v = np.asarray(v, np.float64)
        if v.shape != (self.shape[0],):
            raise ValueError(f"v must have shape ({self.shape[0]},), got {v.shape}")
        out = np.zeros(self.shape[1])
        _csr_dot_transposed(self.indptr, self.indices, self.data, v, out)
        return out

    def dense(self) -> np.ndarray:
        """The full matrix as a numpy array (for small matrices only)."""
        if self.shape[0] * self.shape[1] > DENSE_MAX_ENTRIES:
            raise ValueError(
                f"a {self.shape[0]} x {self.shape[1]} matrix is too large to make "
                f"dense (more than {DENSE_MAX_ENTRIES} entries)"
            )
        out = np.zeros(self.shape)
        for k in range(self.shape[0]):
            s, e = self.indptr[k], self.indptr[k + 1]
            out[k, self.indices[s:e]] += self.data[s:e]
        return out

    def __repr__(self) -> str:
        return f"<SparseMatrix {self.shape[0]} x {self.shape[1]}, {self.nnz} stored entries>"


@njit(cache=True)
def _csr_dot(indptr, indices, data, v, out):
    for k in range(indptr.shape[0] - 1):
        s = 0.0
        for e in range(indptr[k], indptr[k + 1]):
            s += data[e] * v[indices[e]]
        out[k] = s


@njit(cache=True)
def _csr_dot_transposed(indptr, indices, data, v, out):
    for k in range(indptr.shape[0] - 1):
        for e in range(indptr[k], indptr[k + 1]):
            out[indices[e]] += data[e] * v[k]


@dataclass(eq=False)
class MatrixSystem:
    """The system one step solved: A lam = b with lo <= lam <= hi (docs/formulation.md).

    J (R x 3N) and A (R x R) are ``SparseMatrix``; M_inv, V1, F_ext are flat (3N,)
    vectors in the lecture's order [.., vx_b, vy_b, omega_b, ..]. lo, hi are the
    bounds at the end of the solve (a Coulomb row's are +-mu lam of its normal row,
    ``bound_row``). lam holds the impulses found (N s; N m s for angle rows).

    A mouse joint's rows (bound_row ``OWN_SOLVE``, -2; ``disk_blocks()`` lists each pair's
    first row) are soft: their 2x2 diagonal block of A is K / mass_scale = K + K / a2 with
    K = J M^-1 J^T there and mass_scale = a2 a3 of the spring (so A = J M^-1 J^T + the
    compliance of ``dense()``), their xi is the spring's -(omega / a1) C, and the pair is
    solved as one block with (lam_k, lam_k+1) clamped to the disk of radius hi_k =
    max_force dt (lo, hi hold the square around it).
    """

    dt: float  # s
    J: SparseMatrix
    M_inv: np.ndarray  # (3N,) the diagonal of M^-1
    V1: np.ndarray  # (3N,) m/s, rad/s: velocities before the step
    F_ext: np.ndarray  # (3N,) N, N m
    xi: np.ndarray  # (R,) velocity targets, m/s
    A: SparseMatrix
    b: np.ndarray  # (R,) m/s
    lo: np.ndarray
    hi: np.ndarray
    bound_row: np.ndarray  # (R,) normal row bounding a Coulomb friction row, else -1
    mu: np.ndarray  # (R,)
    lam: np.ndarray  # (R,) N s, the sweeps' answer to A lam = b
    push: np.ndarray  # (R,) m/s, the split push targets (zeros when the push is part of xi)
    lam_push: np.ndarray  # (R,) N s, the push impulses: a contact's move positions only, a joint's stay in V
    bounce: np.ndarray  # (R,) m/s, bounce targets of the points that approached fast
    lam_bounce: np.ndarray  # (R,) N s, what the restitution pass added once the bodies moved:
    # the step's impulses (w.contacts) are lam + lam_bounce
    mass_scale: np.ndarray  # (R,) a2 a3 of a mouse row's spring (A's block there is K / a2 a3), 1 on a rigid row
    first_joint_row: int = 0  # the joints' rows follow the contacts' 2K

    def read_only(self) -> MatrixSystem:
        """Make every array of the system read-only, and return self."""
        for a in (
            self.J.indptr,
            self.J.indices,
            self.J.data,
            self.A.indptr,
            self.A.indices,
            self.A.data,
            self.M_inv,
            self.V1,
            self.F_ext,
            self.xi,
            self.b,
            self.lo,
            self.hi,
            self.bound_row,
            self.mu,
            self.lam,
            self.push,
            self.lam_push,
            self.bounce,
            self.lam_bounce,
            self.mass_scale,
        ):
            a.flags.writeable = False
        return self

    def disk_blocks(self) -> np.ndarray:
        """The first row k of each pair (k, k + 1) solved as one 2x2 block with its lam clamped to
        a disk (a mouse joint's x and y rows), ascending."""
        return disk_block_rows(self.bound_row)

    def velocities(self) -> np.ndarray:
        """V2 = V1 + M^-1 (dt F_ext + J^T (lam + lam_bounce + the joints' lam_push)), (3N,): the
        step's new V (a joint's push stays in V, a contact's only moves positions)."""
        lam = self.lam + self.lam_bounce
        lam[self.first_joint_row :] += self.lam_push[self.first_joint_row :]
        return self.V1 + self.M_inv * (self.dt * self.F_ext + self.J.dot_transposed(lam))

    def dense(self) -> SimpleNamespace:
        """J, M_inv (3N x 3N), A as dense numpy matrices, with b, lo, hi, lam: for lessons
        on small scenes. ``np.allclose(d.A, d.J @ d.M_inv @ d.J.T + d.compliance)`` holds;
        ``d.compliance`` (R x R) is zero but on the mouse joints' 2x2 blocks, where it is
        K / a2 (A's block times 1 - a2 a3): with no mouse joint, A = J M^-1 J^T."""
        n = self.M_inv.shape[0]
        if n * n > DENSE_MAX_ENTRIES:
            raise ValueError(f"M_inv is {n} x {n}: too large to make dense")
        A = self.A.dense()
        compliance = np.zeros_like(A)
        for k in self.disk_blocks():
            pair = slice(k, k + 2)
            compliance[pair, pair] = A[pair, pair] * (1.0 - self.mass_scale[k])
        return SimpleNamespace(
            J=self.J.dense(),
            M_inv=np.diag(self.M_inv),
            A=A,
            compliance=compliance,
            b=self.b.copy(),
            lo=self.lo.copy(),
            hi=self.hi.copy(),
            lam=self.lam.copy(),
            V1=self.V1.copy(),
            F_ext=self.F_ext.copy(),
        )

    def __repr__(self) -> str:
        return (
            f"<MatrixSystem: {self.A.shape[0]} rows, {self.J.shape[1] // 3} bodies, A has {self.A.nnz} stored entries>"
        )


# -- assembly ------------------------------------------------------------------------------
def jacobian(rows: Rows, n_bodies: int) -> SparseMatrix:
    """J as CSR: row k = [.. J_i in columns 3i..3i+2 .. J_j in columns 3j..3j+2 ..]; a row
    between a body and the world (a mouse joint's: body_a = body_b) has its body's 3 only."""
    R = len(rows)
    indptr = np.zeros(R + 1, np.int64)
    np.cumsum(np.where(rows.body_a == rows.body_b, 3, 6), out=indptr[1:])
    indices = np.zeros(indptr[R], np.int64)
    data = np.zeros(indptr[R])
    _jacobian_entries(rows.body_a, rows.body_b, rows.J, indptr, indices, data)
    return SparseMatrix(indptr, indices, data, (R, 3 * n_bodies))


@njit(cache=True)
def _jacobian_entries(body_a, body_b, J, indptr, indices, data):
    """Each row's 6 entries, the lower-numbered body's block first (columns ascending); a world
    row's 3, its body's block (its body_a block is zero)."""
    for k in range(body_a.shape[0]):
        s = indptr[k]
        if body_a[k] == body_b[k]:
            for c in range(3):
                indices[s + c] = 3 * body_b[k] + c
                data[s + c] = J[k, 3 + c]
            continue
        first, second = (0, 3) if body_a[k] < body_b[k] else (3, 0)
        lo_body, hi_body = min(body_a[k], body_b[k]), max(body_a[k], body_b[k])
        for c in range(3):
            indices[s + c] = 3 * lo_body + c
            data[s + c] = J[k, first + c]
            indices[s + 3 + c] = 3 * hi_body + c
            data[s + 3 + c] = J[k, second + c]


@njit(cache=True)
def rows_of_bodies(body_a, body_b, M_inv):
    """For each dynamic body b, the rows that touch it (ascending, each once: a world row has
    body_a = body_b): CSR (start, rows)."""
    n = M_inv.shape[0]
    count = np.zeros(n + 1, np.int64)
    for k in range(body_a.shape[0]):
        for side in range(2):
            b = body_a[k] if side == 0 else body_b[k]
            if side == 1 and b == body_a[k]:
                continue  # a world row: its body once
            if M_inv[b, 0] > 0.0 or M_inv[b, 2] > 0.0:
                count[b + 1] += 1
    start = np.cumsum(count)
    fill = start[:-1].copy()
    out = np.zeros(start[-1], np.int64)
    for k in range(body_a.shape[0]):
        for side in range(2):
            b = body_a[k] if side == 0 else body_b[k]
            if side == 1 and b == body_a[k]:
                continue
            if M_inv[b, 0] > 0.0 or M_inv[b, 2] > 0.0:
                out[fill[b]] = k
                fill[b] += 1
    return start, out


@njit(cache=True)
def _neighbours(k, body_a, body_b, start, body_rows, out):
    """Rows sharing a dynamic body with row k, ascending and without repeats; returns the count."""
    a, b = body_a[k], body_b[k]
    p, p_end = start[a], start[a + 1]
    q, q_end = start[b], start[b + 1]
    n = 0
    while p < p_end or q < q_end:
        if q >= q_end or (p < p_end and body_rows[p] < body_rows[q]):
            row = body_rows[p]
            p += 1
        elif p >= p_end or body_rows[q] < body_rows[p]:
            row = body_rows[q]
            q += 1
        else:  # rows on the same pair of bodies appear in both lists
            row = body_rows[p]
            p += 1
            q += 1
        out[n] = row
        n += 1
    return n


@njit(cache=True)
def assemble_A(body_a, body_b, J, JM, M_inv):
    """A = J M^-1 J^T in CSR, one entry per pair of rows sharing a dynamic body."""
    R = body_a.shape[0]
    start, body_rows = rows_of_bodies(body_a, body_b, M_inv)
    buf = np.zeros(max(1, body_rows.shape[0]), np.int64)
    indptr = np.zeros(R + 1, np.int64)
    for k in range(R):
        indptr[k + 1] = indptr[k] + _neighbours(k, body_a, body_b, start, body_rows, buf)
    indices = np.zeros(indptr[R], np.int64)
    data = np.zeros(indptr[R])
    for k in range(R):
        n = _neighbours(k, body_a, body_b, start, body_rows, buf)
        for e in range(n):
            l = buf[e]
            indices[indptr[k] + e] = l
            data[indptr[k] + e] = coupling(k, l, body_a, body_b, J, JM)
    return indptr, indices, data


@njit(cache=True)
def diagonal(A, R):
    """A_kk of a CSR matrix A = (indptr, indices, data) (0 where a row has no entry on the diagonal)."""
    indptr, indices, data = A
    out = np.zeros(R)
    for k in range(R):
        for e in range(indptr[k], indptr[k + 1]):
            if indices[e] == k:
                out[k] = data[e]
    return out


def assemble(ctx: StepContext, xi: np.ndarray) -> MatrixSystem:
    """J, M^-1, A, b = xi - J V1 - dt J M^-1 F_ext and the bounds of this step (lam: the warm
    start, ctx.rows.lam). A mouse joint's rows are its spring's (``soften_mouse_rows``)."""
    r = ctx.rows
    n = ctx.V.shape[0]
    R = len(r)
    J = jacobian(r, n)
    M_inv = ctx.M_inv.reshape(-1).copy()
    V1, F_ext = ctx.V1.reshape(-1).copy(), ctx.F_ext.reshape(-1).copy()
    indptr, indices, data = assemble_A(r.body_a, r.body_b, r.J, r.JM, ctx.M_inv)
    A = SparseMatrix(indptr, indices, data, (R, R))
    xi = xi.copy()
    mass_scale = np.ones(R)
    if isinstance(ctx.joints, JointArrays) and ctx.joints.kind.shape[0] > 0:
        joints = record_of_joints(ctx.joints, r.lam[r.first_joint_row :])  # (lam: not read)
        if has_mouse(joints):
            soften_mouse_rows(joints, r.first_joint_row, ctx.dt, A.csr, xi, mass_scale)
    b = xi - J.dot(V1) - ctx.dt * J.dot(M_inv * F_ext)
    return MatrixSystem(
        ctx.dt,
        J,
        M_inv,
        V1,
        F_ext,
        xi,
        A,
        b,
        r.lo.copy(),
        r.hi.copy(),
        r.bound_row.copy(),
        r.mu.copy(),
        r.lam.copy(),
        push=np.zeros(R),
        lam_push=np.zeros(R),
        bounce=r.bounce.copy(),
        lam_bounce=np.zeros(R),
        mass_scale=mass_scale,
        first_joint_row=r.first_joint_row,
    )


@njit(cache=True)
def soften_mouse_rows(joints, first_row, dt, A, xi, mass_scale):
    """Make each mouse joint's two rows its spring's over the step dt (s): with a2 a3 and
    omega / a1 from ``mouse_springs``, xi_k = -(omega / a1) C (C = -xi_k dt: xi held the rigid
    -C/dt) and the pair's 2x2 block of A = (indptr, indices, data) becomes K / (a2 a3) =
    K + K / a2: the block whose Gauss-Seidel step is the impulse form's soft update. Their
    couplings to other rows stay J_k M^-1 J_l^T. mass_scale gets a2 a3 on these rows."""
    bias_rate = np.zeros(xi.shape[0])
    mouse_springs(joints, first_row, dt, mass_scale, bias_rate)
    indptr, indices, data = A
    for q in range(joints.kind.shape[0]):
        if joints.kind[q] != JOINT_MOUSE:
            continue
        k = first_row + joints.row_offset[q]
        for row in (k, k + 1):
            xi[row] = bias_rate[row] * (xi[row] * dt)  # -(omega / a1) C with C = -xi dt
            if mass_scale[row] <= 0.0:
                continue  # a2 underflowed to 0: no spring (the sweep holds lam at 0)
            for e in range(indptr[row], indptr[row + 1]):
                if indices[e] == k or indices[e] == k + 1:
                    data[e] /= mass_scale[row]


@njit(cache=True)
def disk_block_rows(bound_row):
    """The first row k of each pair (k, k + 1) of rows marked ``OWN_SOLVE`` (a mouse joint's x
    and y rows), ascending."""
    n = 0
    k = 0
    out = np.empty(bound_row.shape[0] // 2, np.int64)
    while k < bound_row.shape[0]:
        if bound_row[k] == OWN_SOLVE:
            out[n] = k
            n += 1
            k += 2
        else:
            k += 1
    return out[:n].copy()


# -- the lecture's PGS on A x = b -----------------------------------------------------------
@njit(cache=True)
def pgs_matrix_sweep(A, A_kk, b, lo, hi, bound_row, mu, x, mass_scale):
    """One sweep of the lecture's pseudocode on A = (indptr, indices, data) (CSR), then each
    mouse joint's pair of rows (bound_row ``OWN_SOLVE``) as one block (``solve_disk_block``);
    returns the largest |delta_k| K_kk (m/s), K_kk = mass_scale_k A_kk (A_kk on a rigid row)."""
    indptr, indices, data = A
    worst = 0.0
    for k in range(x.shape[0]):
        if A_kk[k] <= 0.0 or bound_row[k] == OWN_SOLVE:
            continue  # both bodies static: the row has no entries; or a mouse row: below
        s = 0.0
        for e in range(indptr[k], indptr[k + 1]):  # only the non-zero A_kl
            s += data[e] * x[indices[e]]
        delta = (b[k] - s) / A_kk[k]
        if bound_row[k] >= 0:  # Coulomb: +-mu times the normal row's current x
            top = mu[k] * x[bound_row[k]]
            low = -top
        else:
            low = lo[k]
            top = hi[k]
        delta = clamp_accumulated(x, k, delta, low, top)  # clamp the accumulated impulse, not delta
        worst = max(worst, abs(delta) * A_kk[k])
    k = 0
    while k < x.shape[0]:  # after the sweep, as the impulse form's solve_mice
        if bound_row[k] == OWN_SOLVE:
            worst = max(worst, solve_disk_block(A, k, b, hi[k], x, mass_scale))
            k += 2
        else:
            k += 1
    return worst


@njit(cache=True)
def solve_disk_block(A, k, b, radius, x, mass_scale):
    """Rows k and k + 1 of A x = b together, the other x held: (x_k, x_k+1) = A_blk^-1 (b_blk -
    sum over the other rows l of A_kl x_l), then clamped to the disk of radius ``radius`` (N s).
    With a mouse joint's A_blk = K / (a2 a3) this is the impulse form's soft update exactly
    (docs/formulation.md, "Matrix form"). Returns the largest |delta x| K_kk (m/s)."""
    K11, K12, r_x = _block_row(A, k, k, b, x)
    K21, K22, r_y = _block_row(A, k + 1, k, b, x)
    det = K11 * K22 - K12 * K21
    if det <= 0.0:
        return 0.0  # a static body: nothing to pull
    new_x, new_y = 0.0, 0.0  # a spring of no stiffness (a2 a3 = 0) pulls nothing
    if mass_scale[k] > 0.0:
        new_x = (K22 * r_x - K12 * r_y) / det  # A_blk^-1 r
        new_y = (K11 * r_y - K21 * r_x) / det
    new_x, new_y = clamp_to_disk(new_x, new_y, radius)
    worst = max(abs(new_x - x[k]) * K11 * mass_scale[k], abs(new_y - x[k + 1]) * K22 * mass_scale[k + 1])
    x[k], x[k + 1] = new_x, new_y
    return worst


@njit(cache=True, inline="always")
def _block_row(A, row, k, b, x):
    """Row ``row`` of A x = b seen from the block of rows (k, k + 1): (A_row,k, A_row,k+1,
    b_row - sum over the other rows l of A_row,l x_l)."""
    indptr, indices, data = A
    first, second, rest = 0.0, 0.0, b[row]
    for e in range(indptr[row], indptr[row + 1]):
        l = indices[e]
        if l == k:
            first = data[e]
        elif l == k + 1:
            second = data[e]
        else:
            rest -= data[e] * x[l]
    return first, second, rest


@njit(cache=True)
def pgs_matrix_solve(A, A_kk, b, lo, hi, bound_row, mu, x, mass_scale, iterations, tolerance, residuals):
    """Sweep until the residual <= tolerance or out of sweeps; returns the sweeps made."""
    for s in range(iterations):
        residuals[s] = pgs_matrix_sweep(A, A_kk, b, lo, hi, bound_row, mu, x, mass_scale)
        if residuals[s] <= tolerance:
            return s + 1
    return iterations


@njit(cache=True)
def final_bounds(bound_row, mu, x, lo, hi):
    """Write the Coulomb rows' bounds +-mu x_n as they stand at the end of the solve."""
    for k in range(x.shape[0]):
        if bound_row[k] >= 0:
            hi[k] = mu[k] * x[bound_row[k]]
            lo[k] = -hi[k]


@njit(cache=True)
def push_matrix_solve(visit, A, A_kk, push, lo, hi, x_push, iterations, tolerance):
    """Split impulses in matrix form: A x_push = push on the rows that hold a position (``visit``,
    ``pgs.push_rows``: contact normal rows, then joint equality and limit rows), each x_push
    clamped to [lo_k, hi_k] (>= 0 for a contact or a limit), swept from x_push = 0 (every other
    row's x_push stays 0). Returns the sweeps."""
    pushing = False
    for k in visit:
        pushing = pushing or push[k] != 0.0
    if not pushing:
        return 0
    for s in range(iterations):
        worst = 0.0
        for k in visit:
            if A_kk[k] <= 0.0:
                continue
            delta = clamp_accumulated(x_push, k, (push[k] - csr_row_dot(A, k, x_push)) / A_kk[k], lo[k], hi[k])
            worst = max(worst, abs(delta) * A_kk[k])
        if worst <= tolerance:
            return s + 1
    return iterations


@njit(cache=True, inline="always")
def csr_row_dot(A, k, x):
    """sum_l A_kl x_l over the stored entries of row k of A = (indptr, indices, data)."""
    indptr, indices, data = A
    s = 0.0
    for e in range(indptr[k], indptr[k + 1]):
        s += data[e] * x[indices[e]]
    return s


def solve_matrix_form(ctx: StepContext, xi: np.ndarray, iterations: int, tolerance: float, split: bool) -> SolveResult:
    """The impulse form's step, with matrices: assemble and sweep A lam = b; with ``split``, the
    push system A lam_push = push; positions move with V2 (+ M^-1 J^T lam_push), and the joints'
    share of the push stays in V2 (``velocities``); then the restitution pass
    (``restitution.bounce_after_moving``, the same code as the impulse form's)."""
    r = ctx.rows
    system = assemble(ctx, xi)
    A = system.A
    A_kk = diagonal(A.csr, A.shape[0])
    residuals = np.zeros(iterations)
    n = pgs_matrix_solve(
        A.csr, A_kk, system.b, system.lo, system.hi, system.bound_row, system.mu, system.lam, system.mass_scale,
        iterations, tolerance, residuals,
    )  # fmt: skip
    final_bounds(system.bound_row, system.mu, system.lam, system.lo, system.hi)
    V2 = system.velocities()
    V_move = V2
    if split:
        system.push[:] = r.push
        visit = push_rows(r.normal_row, r.lo, r.hi, r.bound_row)
        push_matrix_solve(visit, A.csr, A_kk, system.push, r.lo, r.hi, system.lam_push, iterations, tolerance)
        V_move = V2 + system.M_inv * system.J.dot_transposed(system.lam_push)
        V2 = system.velocities()  # the joints' push stays in V
    ctx.rows.lam[:] = system.lam
    ctx.V[:] = V2.reshape(ctx.V.shape)
    bounce_after_moving(ctx, V_move.reshape(ctx.V.shape), iterations, tolerance)
    system.lam_bounce[:] = ctx.rows.lam - system.lam
    return SolveResult(n, residuals[:n], system, integrated=True)


__all__ = ["MatrixSystem", "SparseMatrix", "assemble", "solve_matrix_form"]
