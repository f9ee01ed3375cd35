"""Integration: semi-implicit (symplectic) Euler.

    V  <- V + dt M^-1 F_ext            before the responder (gravity, applied forces; then damping)
    x  <- x + dt v,  theta <- theta + dt omega     after it, with the new V2

theta' = omega is the 2D form of the lecture's q' = 1/2 w q.
"""

from __future__ import annotations

import numpy as np

from .jit import njit


@njit(cache=True)
def apply_external_forces(V, M_inv, forces, gravity, dt):
    """V += dt M^-1 F_ext with F_ext = m s g + F: every dynamic body gains dt s g (m/s), s its
    gravity_scale, and dt M^-1 F of the force F (N, and torque N m) applied for this step; then
    damping, Box2D's: v /= 1 + c_v dt, omega /= 1 + c_w dt. forces = (gravity_scale (N,),
    damping (N, 2) [c_v, c_w] 1/s, force (N, 3)). Static and kinematic bodies (M^-1 = 0) keep
    their velocity."""
    gravity_scale, damping, force = forces
    for b in range(V.shape[0]):
        if M_inv[b, 0] == 0.0:
            continue
        s = gravity_scale[b]
        V[b, 0] += dt * (s * gravity[0])
        V[b, 1] += dt * (s * gravity[1])
        if force[b, 0] != 0.0 or force[b, 1] != 0.0 or force[b, 2] != 0.0:  # applied for this step
            for c in range(3):
                V[b, c] += dt * M_inv[b, c] * force[b, c]
        if damping[b, 0] > 0.0:
            V[b, 0] /= 1.0 + damping[b, 0] * dt
            V[b, 1] /= 1.0 + damping[b, 0] * dt
        if damping[b, 1] > 0.0:
            V[b, 2] /= 1.0 + damping[b, 1] * dt


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
