"""The soft step's integration (``responders.soft_step``): a sub-step's share of the forces, and
the positions after each sub-step, with how far each body has moved since the tick began."""

from __future__ import annotations

import numpy as np

from ..jit import njit

SMALL_TURN = 1.0 / 32.0  # rad: a turn below this takes cos and sin from their Taylor series


@njit(cache=True)
def cos_less_one_sin(d):
    """(cos d - 1, sin d) of a turn d (rad): R(d) - I = [[cos d - 1, -sin d], [sin d, cos d - 1]].
    Below SMALL_TURN by Taylor series to d^8 and d^7: the terms left out are below 3e-18 of
    the result, so it is libm's to an ulp (cos d - 1 without cancelling), in a few
    multiplications instead of libm's two calls; a body turns far less than that within a
    tick. Larger turns: np.cos, np.sin."""
    if abs(d) >= SMALL_TURN:
        return np.cos(d) - 1.0, np.sin(d)
    d2 = d * d
    c = -d2 * (1.0 / 2.0 - d2 * (1.0 / 24.0 - d2 * (1.0 / 720.0 - d2 * (1.0 / 40320.0))))
    s = d - d * d2 * (1.0 / 6.0 - d2 * (1.0 / 120.0 - d2 * (1.0 / 5040.0)))
    return c, s


@njit(cache=True)
def split_forces(bodies, substeps):
    """dv = (V - V1) / substeps, a sub-step's share of the external forces that V holds over
    V1 (m/s); V back to V1, where the tick began. (Loops: an array expression compiles a shape
    check with its message.)"""
    V, V1 = bodies.V, bodies.V1
    dv = np.empty_like(V)
    for b in range(V.shape[0]):
        for c in range(3):
            dv[b, c] = (V[b, c] - V1[b, c]) / substeps
            V[b, c] = V1[b, c]
    return dv


@njit(cache=True)
def integrate_velocities(V, dv):
    """V += h M^-1 F_ext: a sub-step's share of the external forces, dv (m/s)."""
    for b in range(V.shape[0]):
        for c in range(3):
            V[b, c] += dv[b, c]


@njit(cache=True)
def integrate_positions(first, last, bodies, h, x0, theta0, moved):
    """x += h v, theta += h omega of bodies first up to last; moved[b] = (dx, dy, cos dtheta - 1,
    sin dtheta) since the tick began (each body its own: ``pipeline.parallel.integrate_positions_on``)."""
    x, theta, V = bodies.x, bodies.theta, bodies.V
    for b in range(first, last):
        x[b, 0] += h * V[b, 0]
        x[b, 1] += h * V[b, 1]
        theta[b] += h * V[b, 2]
        moved[b, 0] = x[b, 0] - x0[b, 0]
        moved[b, 1] = x[b, 1] - x0[b, 1]
        moved[b, 2], moved[b, 3] = cos_less_one_sin(theta[b] - theta0[b])
