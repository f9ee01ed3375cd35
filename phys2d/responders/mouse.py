"""The mouse joint's solve, shared by PGS and the soft step: a soft pull of a body's point
toward a target, Box2D's mouse joint.

Its two rows (x and y, on body b alone: ``constraints.joints``) are solved together, as a 2x2
block K = [J_x; J_y] M^-1 [J_x; J_y]^T, with the soft update of a spring of frequency
``hertz`` and damping ratio ``zeta`` over a step (or sub-step) h (``soft_contacts.soft_constants``:
bias rate omega / a1, mass_scale, impulse_scale):

    delta lambda = -mass_scale K^-1 (J V + bias_rate C) - impulse_scale lambda

which is Gauss-Seidel on (K + K / a2) lambda = -(J V0 + bias_rate C): a rigid pull softened
by a compliance. The accumulated impulse is then clamped to the disk |lambda| <= max_force h,
so the pull never exceeds max_force. The rows are swept by neither PGS's nor the soft step's
row loop (their bound_row is ``OWN_SOLVE``); this does them. PGS's matrix form solves the same
block in its sweep (``pgs_matrix.solve_disk_block``): there the compliance is part of A, whose
2x2 block for the two rows is K / (a2 a3) = K + K / a2, and ``mouse_springs`` gives it a2 a3 and
omega / a1 row by row.
"""

from __future__ import annotations

import math

import numpy as np

from ..constraints.joints import JOINT_MOUSE, P_HERTZ, P_MOTOR_MAX, P_ZETA
from ..constraints.rows import apply_row_impulse, row_velocity
from ..jit import njit
from .soft_contacts import soft_constants


@njit(cache=True)
def has_mouse(joints):
    """Whether any joint is a mouse joint."""
    for q in range(joints.kind.shape[0]):
        if joints.kind[q] == JOINT_MOUSE:
            return True
    return False


@njit(cache=True, inline="always")
def clamp_to_disk(x, y, radius):
    """(x, y) scaled back onto the disk |(x, y)| <= radius when it lies outside: the pull's cap,
    max_force over the step (N s)."""
    size = math.sqrt(x * x + y * y)  # (not hypot: numba's and Python's may differ in the last bit)
    if size > radius:
        return x * (radius / size), y * (radius / size)
    return x, y


@njit(cache=True)
def solve_mouse(k, rows, V, C, soft, max_impulse):
    """One soft 2x2 solve of the mouse rows k (x) and k + 1 (y) with position error C = (C_x,
    C_y) (m), the spring ``soft`` = (bias_rate, mass_scale, impulse_scale) and the clamp
    |lambda| <= max_impulse (N s). Returns the largest |delta lambda| A_kk (m/s)."""
    J, JM, lam = rows.J, rows.JM, rows.lam
    b = rows.body_b[k]
    K11, K22 = rows.A_kk[k], rows.A_kk[k + 1]
    K12 = 0.0
    for c in range(3, 6):
        K12 += J[k, c] * JM[k + 1, c]
    det = K11 * K22 - K12 * K12
    if det <= 0.0:
        return 0.0  # a static body: nothing to pull
    bias_rate, mass_scale, impulse_scale = soft[0], soft[1], soft[2]
    cx = row_velocity(k, b, b, J, V) + bias_rate * C[0]
    cy = row_velocity(k + 1, b, b, J, V) + bias_rate * C[1]
    old_x, old_y = lam[k], lam[k + 1]
    new_x = old_x - mass_scale * (K22 * cx - K12 * cy) / det - impulse_scale * old_x  # K^-1 c
    new_y = old_y - mass_scale * (K11 * cy - K12 * cx) / det - impulse_scale * old_y
    new_x, new_y = clamp_to_disk(new_x, new_y, max_impulse)
    lam[k], lam[k + 1] = new_x, new_y
    apply_row_impulse(k, b, b, JM, new_x - old_x, V)
    apply_row_impulse(k + 1, b, b, JM, new_y - old_y, V)
    return max(abs(new_x - old_x) * K11, abs(new_y - old_y) * K22)


@njit(cache=True)
def solve_mice(joints, first_row, rows, V, h, rows_dt):
    """Every mouse joint's rows once (``solve_mouse``), over a step or sub-step of h (s). The
    rows were built with time step rows_dt (xi = -C / rows_dt). Returns the largest |delta
    lambda| A_kk (m/s)."""
    worst = 0.0
    for q in range(joints.kind.shape[0]):
        if joints.kind[q] != JOINT_MOUSE:
            continue
        k = first_row + joints.row_offset[q]
        params = joints.params[q]
        soft = soft_constants(params[P_HERTZ], params[P_ZETA], h, np.inf)
        C = (-rows.xi[k] * rows_dt, -rows.xi[k + 1] * rows_dt)
        worst = max(worst, solve_mouse(k, rows, V, C, soft, params[P_MOTOR_MAX] * h))
    return worst


@njit(cache=True)
def mouse_springs(joints, first_row, h, mass_scale, bias_rate):
    """Each mouse row's spring over a step of h (s), for the matrix form: mass_scale[k] = a2 a3
    and bias_rate[k] = omega / a1 (1/s), the ``soft_constants`` that ``solve_mice`` uses. The
    other rows' entries are left as they are."""
    for q in range(joints.kind.shape[0]):
        if joints.kind[q] != JOINT_MOUSE:
            continue
        k = first_row + joints.row_offset[q]
        params = joints.params[q]
        soft = soft_constants(params[P_HERTZ], params[P_ZETA], h, np.inf)
        for m in range(2):
            bias_rate[k + m] = soft[0]
            mass_scale[k + m] = soft[1]
