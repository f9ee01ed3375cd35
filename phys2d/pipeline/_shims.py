"""TEMPORARY."""

import numpy as np
from numba import njit

from ..responders.soft_step import soft_step_solve


@njit(cache=True)
def _soft_shim(bodies, r, found, joints, dt, soft, residuals):  # TEMPORARY: the old soft_step_solve
    substeps, relax, hertz, zeta, push_max, joint_hertz, joint_zeta, direct, threshold, block = soft
    order, separation, e, anchor = found
    z = np.zeros(0, np.int32)
    z2 = np.zeros((0, 2))
    z5 = np.zeros((0, 5))
    if joints is not None:
        return soft_step_solve(
            r.normal_row, r.friction_row, r.body_a, r.body_b, r.J, r.JM, r.A_kk, r.xi, r.lo, r.hi, r.bound_row, r.mu,
            order, separation, e, anchor, bodies.x, bodies.theta, bodies.M_inv, bodies.V, bodies.V1, dt, substeps,
            relax, hertz, zeta, push_max, joint_hertz, joint_zeta, direct, threshold, block, joints.kind,
            joints.body_a, joints.body_b, joints.local_a, joints.local_b, joints.params, joints.row_offset,
            2 * r.normal_row.shape[0], r.lam, residuals,
        )  # fmt: skip
    return soft_step_solve(
        r.normal_row, r.friction_row, r.body_a, r.body_b, r.J, r.JM, r.A_kk, r.xi, r.lo, r.hi, r.bound_row, r.mu,
        order, separation, e, anchor, bodies.x, bodies.theta, bodies.M_inv, bodies.V, bodies.V1, dt, substeps,
        relax, hertz, zeta, push_max, joint_hertz, joint_zeta, direct, threshold, block, z, z, z, z2, z2, z5, z,
        2 * r.normal_row.shape[0], r.lam, residuals,
    )  # fmt: skip
