"""The soft step's contact rows (``responders.soft_step``): the soft push, the manifolds, the sweep.

The soft push replaces Baumgarte's beta with a spring of stiffness ``contact_hertz``
and damping ratio ``damping_ratio`` (Catto, "Solver2D", 2024): for a row with
separation C < 0,

    omega = 2 pi hertz,  a1 = 2 zeta + h omega,  a2 = h omega a1,  a3 = 1 / (1 + a2)
    bias = max(omega / a1 * C, -push_max)
    delta lambda = -mass_scale * (J V + bias) / A_kk - impulse_scale * lambda
    with mass_scale = a2 a3 and impulse_scale = a3

so the push is bounded and critically damped instead of proportional to 1/dt.
"""

from __future__ import annotations

import numpy as np

from ..constraints.rows import (
    MET,
    apply_row_impulse,
    clamp_accumulated,
    pair_inverse_mass,
    pair_row_impulse_of,
    pair_row_velocity,
    pair_velocity,
    row_velocity,
    speculative_friction_target,
    store_pair_velocity,
)
from ..jit import njit
from .block import block_is_well_conditioned, lcp2
from .soft_points import separation_now


@njit(cache=True)
def soft_constants(hertz, zeta, h, push_max):
    """(bias_rate 1/s, mass_scale, impulse_scale, push_max m/s) of a soft constraint over a sub-step h."""
    if hertz == 0.0:
        return 0.0, 1.0, 0.0, push_max
    omega = 2.0 * np.pi * hertz
    a1 = 2.0 * zeta + h * omega
    a2 = h * omega * a1
    a3 = 1.0 / (1.0 + a2)
    return omega / a1, a2 * a3, a3, push_max


@njit(cache=True)
def soft_push(s, h, use_bias, soft):
    """(bias m/s, mass_scale, impulse_scale) of a normal row whose separation is s (m)."""
    if s > 0.0:
        return s / h, 1.0, 0.0  # speculative: close the gap, no more
    if use_bias:
        return max(soft[0] * s, -soft[3]), soft[1], soft[2]  # the soft push, at most push_max
    return 0.0, 1.0, 0.0


@njit(cache=True)
def soft_sweep(rows, manifolds, inv_A_kk, points, M_inv, V, h, use_bias, springs, new_C):
    """One sweep over the contacts: the normal rows manifold by manifold (soft push if use_bias,
    ``soft_normal_rows``), then the friction rows (``soft_friction_rows``). points.C[c] is
    point c's separation now (m), worked out afresh from points.moved when new_C (the bodies
    moved since the last sweep); ``manifolds`` comes from ``prepare_manifolds``; inv_A_kk =
    1 / A_kk (``inverse_diagonal``: the sweeps multiply, never divide); M_inv: the bodies'
    M^-1, from which each manifold forms M^-1 J^T as it applies an impulse
    (``pair_row_impulse_of``: the products JM would hold; the soft step's contact rows carry none); springs: the soft
    push against a dynamic and a static partner (``soft_constants``). The same updates run
    part by part on several threads in ``pipeline.parallel.soft_sweep_in_groups``.

    Returns the largest |delta lambda| A_kk of the sweep (m/s).
    """
    n = manifolds[0].shape[0] - 1
    worst = soft_normal_rows(0, n, rows, manifolds, inv_A_kk, points, M_inv, V, h, use_bias, springs, new_C)
    return max(worst, soft_friction_rows(0, n, rows, manifolds, inv_A_kk, points, M_inv, V, h))


@njit(cache=True)
def soft_normal_rows(first, last, rows, manifolds, inv_A_kk, points, M_inv, V, h, use_bias, springs, new_C):
    """The normal rows of manifolds first up to last, one manifold after another, with the soft
    push if use_bias (``soft_sweep``'s arguments). Returns the largest |delta lambda| A_kk (m/s).
    When new_C, each manifold first works out its points' separations at the positions now
    (``separation_now``), in the pass that reads their rows anyway, as Box2D v3 does.

    A two-point manifold marked as a block has its normal rows solved together (lcp2), each
    row scaled by its own softness (relax does so only while both points touch):
        K lambda + [m_p (J_p V + bias_p) + s_p A_pp a_p - (K a)_p] >= 0, lambda >= 0.
    """
    normal_row, body_a, body_b = rows.normal_row, rows.body_a, rows.body_b
    J, A_kk, lam = rows.J, rows.A_kk, rows.lam
    soft_dyn, soft_static = springs[0], springs[1]
    friction_row, C, C0, moved = rows.friction_row, points.C, points.C0, points.moved
    start, static_pair, K12, as_block, inv_det = manifolds
    worst = 0.0
    for m in range(first, last):
        c = start[m]
        k = normal_row[c]
        a, b = body_a[k], body_b[k]
        if new_C:  # the bodies moved since the last sweep
            for p in range(c, start[m + 1]):
                C[p] = separation_now(p, normal_row[p], friction_row[p], a, b, C0, J, moved)
        soft = soft_static if static_pair[m] else soft_dyn
        s1 = C[c]
        V_ab = pair_velocity(a, b, V)  # the pair's velocities in hand through its rows (sweep, pgs.py)
        M_ab = pair_inverse_mass(a, b, M_inv)  # and its M^-1: M^-1 J^T formed from J
        if as_block[m] and (use_bias or (s1 <= MET and C[c + 1] <= MET)):
            k2 = normal_row[c + 1]
            x1, x2, a1, a2, K11, K22 = soft_block(
                k, k2, (K12[m], inv_det[m]), (s1, C[c + 1]), V_ab, (J, A_kk, lam), (h, use_bias, soft)
            )
            lam[k] = x1
            lam[k2] = x2
            V_ab = pair_row_impulse_of(k2, J, M_ab, x2 - a2, pair_row_impulse_of(k, J, M_ab, x1 - a1, V_ab))
            worst = max(worst, abs(x1 - a1) * K11, abs(x2 - a2) * K22)
        else:
            # relax leaves a point still apart alone: the next sweep with the push limits its
            # approach to closing the gap (cutting it here would bounce it off the air)
            for c in range(start[m], start[m + 1]):
                k = normal_row[c]
                s1 = C[c]
                if A_kk[k] > 0.0 and (use_bias or s1 <= MET):
                    bias, mass_scale, impulse_scale = soft_push(s1, h, use_bias, soft)
                    d = -mass_scale * (pair_row_velocity(k, J, V_ab) + bias) * inv_A_kk[k] - impulse_scale * lam[k]
                    d = clamp_accumulated(lam, k, d, 0.0, np.inf)  # clamp the accumulated impulse, not d
                    V_ab = pair_row_impulse_of(k, J, M_ab, d, V_ab)
                    worst = max(worst, abs(d) * A_kk[k])
        store_pair_velocity(a, b, V_ab, V)
    return worst


@njit(cache=True, inline="always")
def soft_block(k, k2, K, s, V_ab, rows, push):
    """A two-point manifold's normal rows k and k2 solved together (``lcp2``) on the pair's
    velocities V_ab, each row scaled by its softness at its separation (s = (s1, s2), m).
    K = (K12, inv_det): J_k M^-1 J_k2^T and 1 / det K (``manifold_constants``); rows = (J, A_kk,
    lam), the rows' arrays (``RowRecord``); push = (h, use_bias, soft): ``soft_push``'s. Returns
    (x1, x2) the new accumulated lambdas (N s), (a1, a2) the old, and (K11, K22) = (A_kk,
    A_k2k2); stores nothing."""
    K12, inv_det = K
    s1, s2 = s
    J, A_kk, lam = rows
    h, use_bias, soft = push
    K11, K22 = A_kk[k], A_kk[k2]
    bias1, ms1, is1 = soft_push(s1, h, use_bias, soft)
    bias2, ms2, is2 = soft_push(s2, h, use_bias, soft)
    a1, a2 = lam[k], lam[k2]
    b1 = ms1 * (pair_row_velocity(k, J, V_ab) + bias1) + is1 * K11 * a1 - (K11 * a1 + K12 * a2)
    b2 = ms2 * (pair_row_velocity(k2, J, V_ab) + bias2) + is2 * K22 * a2 - (K12 * a1 + K22 * a2)
    x1, x2 = lcp2(K11, K12, K22, inv_det, b1, b2)
    return x1, x2, a1, a2, K11, K22


@njit(cache=True)
def soft_friction_rows(first, last, rows, manifolds, inv_A_kk, points, M_inv, V, h):
    """The friction rows of manifolds first up to last, one manifold after another
    (``soft_sweep``'s arguments): Coulomb's cone mu lambda_n; a point still apart that has not
    yet met its partner lets friction act only once it touches (``speculative_friction_target``
    of its rows' J V_sweep). Returns the largest |delta lambda| A_kk (m/s)."""
    normal_row, friction_row, body_a, body_b = rows.normal_row, rows.friction_row, rows.body_a, rows.body_b
    J, A_kk, mu, lam = rows.J, rows.A_kk, rows.mu, rows.lam
    C, V_sweep, impacted = points.C, points.V_sweep, points.impacted
    start = manifolds[0]
    worst = 0.0
    for m in range(first, last):
        k = friction_row[start[m]]
        a, b = body_a[k], body_b[k]
        V_ab, M_ab = pair_velocity(a, b, V), pair_inverse_mass(a, b, M_inv)
        for c in range(start[m], start[m + 1]):
            k, kn = friction_row[c], normal_row[c]
            if A_kk[k] <= 0.0 or (lam[kn] == 0.0 and lam[k] == 0.0):
                continue  # static pair, or a point that does not push: its friction cone is [0, 0]
            top = mu[k] * lam[kn]
            target = 0.0  # stop sliding; a point landing within this sweep: only after its touch
            if C[c] > 0.0 and not impacted[c]:  # its approach as the sweep began
                vn, vt = row_velocity(kn, a, b, J, V_sweep), row_velocity(k, a, b, J, V_sweep)
                target = speculative_friction_target(C[c], vn, vt, h)
            d = -(pair_row_velocity(k, J, V_ab) - target) * inv_A_kk[k]
            d = clamp_accumulated(lam, k, d, -top, top)  # Coulomb's cone on the accumulated impulse
            V_ab = pair_row_impulse_of(k, J, M_ab, d, V_ab)
            worst = max(worst, abs(d) * A_kk[k])
        store_pair_velocity(a, b, V_ab, V)
    return worst


@njit(cache=True)
def prepare_manifolds(rows, M_inv, block):
    """What stays the same over the tick, per contact manifold in solve order (a manifold:
    one point, or two consecutive points on the same pair):

        start        (M + 1,)  its points are start[m] up to start[m + 1]
        static_pair  (M,)      a partner is static (M^-1 = 0): the stiffer push
        K12          (M,)      J_1 M^-1 J_2^T of a two-point manifold's normal rows
        as_block     (M,)      ``block`` and its 2x2 K is well conditioned: solve them together
        inv_det      (M,)      1 / det K of a block (``lcp2``), 0 elsewhere
    """
    manifolds = new_manifolds(rows)
    manifold_constants(0, manifolds[0].shape[0] - 1, manifolds, rows, M_inv, block)
    return manifolds


@njit(cache=True)
def new_manifolds(rows):
    """``prepare_manifolds``' arrays: start (the contacts grouped by pair, in solve order), the
    rest to fill in (``manifold_constants``)."""
    normal_row, body_a, body_b = rows.normal_row, rows.body_a, rows.body_b
    n_contacts = normal_row.shape[0]
    start = np.empty(n_contacts + 1, np.uint32)
    n = 0
    c = 0
    while c < n_contacts:
        start[n] = c
        n += 1
        k = normal_row[c]
        pair = c + 1 < n_contacts and body_a[normal_row[c + 1]] == body_a[k] and body_b[normal_row[c + 1]] == body_b[k]
        c += 2 if pair else 1
    start[n] = n_contacts
    start = start[: n + 1]  # (a view: the rest of the buffer is freed with it)
    return start, np.empty(n, np.bool_), np.zeros(n), np.zeros(n, np.bool_), np.zeros(n)


@njit(cache=True)
def manifold_constants(first, last, manifolds, rows, M_inv, block):
    """``prepare_manifolds`` of manifolds first up to last: each writes only its own entries."""
    normal_row, body_a, body_b, J, A_kk = rows.normal_row, rows.body_a, rows.body_b, rows.J, rows.A_kk
    start, static_pair, K12, as_block, inv_det = manifolds
    for m in range(first, last):
        k = normal_row[start[m]]
        a, b = body_a[k], body_b[k]
        static_pair[m] = M_inv[a, 0] == 0.0 or M_inv[b, 0] == 0.0
        if block and start[m + 1] - start[m] == 2:
            k2 = normal_row[start[m] + 1]
            M_ab = pair_inverse_mass(a, b, M_inv)
            K = 0.0
            for q in range(6):
                K += J[k, q] * (M_ab[q] * J[k2, q])  # J_1 (M^-1 J_2^T), M^-1 J_2^T formed from J
            K12[m] = K
            as_block[m] = block_is_well_conditioned(A_kk[k], K, A_kk[k2])
            if as_block[m]:
                inv_det[m] = 1.0 / (A_kk[k] * A_kk[k2] - K * K)


@njit(cache=True)
def warm_start(manifolds, rows, M_inv, V):
    """Apply last sub-step's impulses (N s) to V: manifold by manifold (``warm_start_manifolds``),
    then the joint rows (``warm_start_joints``)."""
    warm_start_manifolds(0, manifolds[0].shape[0] - 1, manifolds[0], rows, M_inv, V)
    warm_start_joints(rows, V)


@njit(cache=True)
def warm_start_manifolds(first, last, start, rows, M_inv, V):
    """The last impulses (N s) of manifolds first up to last on V, one manifold after another:
    its rows (normal, then friction, point by point) on its pair's velocities held in hand
    (``pair_velocity``), stored once, with M^-1 J^T formed from J and the pair's M^-1
    (``pair_row_impulse_of``)."""
    normal_row, friction_row, body_a, body_b = rows.normal_row, rows.friction_row, rows.body_a, rows.body_b
    J, lam = rows.J, rows.lam
    for m in range(first, last):
        k = normal_row[start[m]]
        a, b = body_a[k], body_b[k]
        V_ab, M_ab = pair_velocity(a, b, V), pair_inverse_mass(a, b, M_inv)
        for c in range(start[m], start[m + 1]):
            for k in (normal_row[c], friction_row[c]):
                if lam[k] != 0.0:
                    V_ab = pair_row_impulse_of(k, J, M_ab, lam[k], V_ab)
        store_pair_velocity(a, b, V_ab, V)


@njit(cache=True)
def warm_start_joints(rows, V):
    """The joint rows' last impulses (N s) on V, row by row."""
    body_a, body_b, JM, lam = rows.body_a, rows.body_b, rows.JM, rows.lam
    for k in range(2 * rows.normal_row.shape[0], lam.shape[0]):  # the joint rows follow the contacts' 2K
        if lam[k] != 0.0:
            apply_row_impulse(k, body_a[k], body_b[k], JM, lam[k], V)
