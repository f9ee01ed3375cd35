"""Integration: semi-implicit (symplectic) Euler.

    V  <- V + dt M^-1 F_ext            before the responder (gravity)
    x  <- x + dt v,  theta <- theta + dt omega     after it, with the new V2

theta' = omega is the 2D form of the lecture's q' = 1/2 w q.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def apply_external_forces(V, M_inv, gravity, dt):
    """V += dt M^-1 F_ext with F_ext = m g: every dynamic body gains dt g (m/s)."""
    for b in range(V.shape[0]):
        if M_inv[b, 0] > 0.0:
            V[b, 0] += dt * gravity[0]
            V[b, 1] += dt * gravity[1]


@njit(cache=True)
def integrate_positions(x, theta, V, dt):
    """x += dt v, theta += dt omega (static bodies move only if given a velocity)."""
    for b in range(x.shape[0]):
        x[b, 0] += dt * V[b, 0]
        x[b, 1] += dt * V[b, 1]
        theta[b] += dt * V[b, 2]


@njit(cache=True)
def first_too_fast(V, x, theta, max_speed):
    """Index of the first body faster than max_speed (m/s, or rad/s) or not finite; -1 if none.

    x and theta are checked too: a finite velocity times a huge dt can still overflow them.
    """
    limit = max_speed * max_speed
    for b in range(V.shape[0]):
        v2 = V[b, 0] * V[b, 0] + V[b, 1] * V[b, 1]
        if not (v2 <= limit and abs(V[b, 2]) <= max_speed):  # NaN fails every comparison
            return b
        if not (np.isfinite(x[b, 0]) and np.isfinite(x[b, 1]) and np.isfinite(theta[b])):
            return b
    return -1
