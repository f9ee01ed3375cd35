"""What the block solvers share: the exact 2x2 LCP of a two-point manifold's normal rows.

Box2D's block solver takes both normal rows of a manifold at once: with K the 2x2 block of
A = J M^-1 J^T and b their targets, it solves x >= 0, w = K x + b >= 0, x . w = 0 by
trying the four active sets (``lcp2``). PGS (``block=True``) and the soft step use it.
"""

from __future__ import annotations

import numpy as np

from ..jit import njit


@njit(cache=True)
def lcp2(K11, K12, K22, inv_det, b1, b2):
    """The 2x2 LCP: x >= 0, w = K x + b >= 0, x . w = 0, by trying the four active sets.

    K = [[K11, K12], [K12, K22]] must be symmetric positive definite; inv_det is
    1 / (K11 K22 - K12^2), which the caller works out once (a division takes as long as
    several products, and the soft step solves the same K many times a tick).
    """
    x1 = -(K22 * b1 - K12 * b2) * inv_det  # both rows push
    x2 = -(K11 * b2 - K12 * b1) * inv_det
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
def inverse_diagonal(A_kk):
    """1 / A_kk (0 where A_kk = 0), once per step: the sweeps multiply, never divide."""
    inv_A_kk = np.empty(A_kk.shape[0])
    for k in range(A_kk.shape[0]):
        inv_A_kk[k] = inverse_or_zero(A_kk[k])
    return inv_A_kk


@njit(cache=True, inline="always")
def inverse_or_zero(A_kk_k):
    """1 / A_kk for one row, 0 where A_kk = 0 (both bodies static: the row cannot move)."""
    return 1.0 / A_kk_k if A_kk_k > 0.0 else 0.0
