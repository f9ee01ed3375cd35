"""Soft step: sub-stepping with soft contacts and relaxation (Box2D v3's solver).

What the field learned after the lecture, kept beside its PGS, not in place of it.
The tick of length dt is split into n sub-steps of h = dt/n. Each sub-step:

    V += h M^-1 F_ext                        external forces, a slice at a time
    V += M^-1 J^T lambda                     warm start with the impulse per sub-step
    one PGS sweep with a soft push           (below)
    x += h v, theta += h omega               positions move within the tick
    one PGS sweep without the push           "relax": remove the push's velocity

then one restitution pass: the points that met their partner faster than the
threshold bounce from their approach at impact, taken in the sub-step where they
first pushed. Between sweeps the separation of each contact point is updated from
how far its bodies have moved (x - x0 and the rotated lever arms), so no new
collision detection is needed within the tick. The relax sweep leaves points still
apart alone (the next sweep with the push limits their approach), and an impact's
impulse is not warm started into the next sub-step: it was an event, not a load.

The soft push replaces Baumgarte's beta with a spring of stiffness ``contact_hertz``
and damping ratio ``damping_ratio`` (Catto, "Solver2D", 2024): for a row with
separation C < 0,

    omega = 2 pi hertz,  a1 = 2 zeta + h omega,  a2 = h omega a1,  a3 = 1 / (1 + a2)
    bias = max(omega / a1 * C, -push_max)
    delta lambda = -mass_scale * (J V + bias) / A_kk - impulse_scale * lambda
    with mass_scale = a2 a3 and impulse_scale = a3

so the push is bounded and critically damped instead of proportional to 1/dt. A
heavy body on a light one, or a tall stack, converges because each sub-step only
has to correct a sub-step's worth of gravity.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..constraints.rows import MET, apply_row_impulse, approach_at_impact, bounce_target, row_velocity
from ..validation import Setting, check_bool, check_int, non_negative_float
from .base import Responder, SolveResult, StepContext
from .pgs import block_is_well_conditioned, lcp2


@njit(cache=True)
def _soft(hertz, zeta, h, push_max):
    """(bias_rate 1/s, mass_scale, impulse_scale, push_max m/s) of a soft constraint over a sub-step h."""
    if hertz == 0.0:
        return 0.0, 1.0, 0.0, push_max
    omega = 2.0 * np.pi * hertz
    a1 = 2.0 * zeta + h * omega
    a2 = h * omega * a1
    a3 = 1.0 / (1.0 + a2)
    return omega / a1, a2 * a3, a3, push_max


@njit(cache=True)
def _separation(c, a, b, C0, r, normal, moved):
    """Current separation of point c (m) from its bodies' motion since the tick began.

    moved[body] = (dx, dy, cos dtheta, sin dtheta); each anchor has moved by
    dx + R(dtheta) r - r.
    """
    s = C0[c]
    for side in range(2):
        body = a if side == 0 else b
        rx, ry = r[c, 2 * side], r[c, 2 * side + 1]
        dx = moved[body, 0] + moved[body, 2] * rx - moved[body, 3] * ry - rx
        dy = moved[body, 1] + moved[body, 3] * rx + moved[body, 2] * ry - ry
        d = dx * normal[c, 0] + dy * normal[c, 1]
        s += d if side == 1 else -d
    return s


@njit(cache=True)
def _push(s, h, use_bias, soft):
    """(bias m/s, mass_scale, impulse_scale) of a normal row whose separation is s (m)."""
    if s > 0.0:
        return s / h, 1.0, 0.0  # speculative: close the gap, no more
    if use_bias:
        return max(soft[0] * s, -soft[3]), soft[1], soft[2]  # the soft push, at most push_max
    return 0.0, 1.0, 0.0


@njit(cache=True)
def soft_sweep(normal_row, friction_row, i, j, J, JM, A_diag, mu, C, static_pair, lam, V, h, use_bias, soft_dyn,
               soft_static, block):
    """One sweep over the contacts: normal rows (soft push if use_bias), then friction.
    C[c] is contact c's separation now (m).

    With ``block`` the two normal rows of a two-point manifold are solved together
    (lcp2), each row scaled by its own softness:
        K lambda + [m_p (J_p V + bias_p) + s_p A_pp a_p - (K a)_p] >= 0, lambda >= 0.
    Returns the largest |delta lambda| A_kk of the sweep (m/s).
    """
    worst = 0.0
    n_contacts = normal_row.shape[0]
    c = 0
    while c < n_contacts:
        k = normal_row[c]
        a, b = i[k], j[k]
        soft = soft_static if static_pair[c] else soft_dyn
        s1 = C[c]
        if block and c + 1 < n_contacts and i[normal_row[c + 1]] == a and j[normal_row[c + 1]] == b:
            k2 = normal_row[c + 1]
            s2 = C[c + 1]
            K11, K22 = A_diag[k], A_diag[k2]
            K12 = 0.0
            for q in range(6):
                K12 += J[k, q] * JM[k2, q]
            if block_is_well_conditioned(K11, K12, K22) and (use_bias or (s1 <= MET and s2 <= MET)):
                bias1, ms1, is1 = _push(s1, h, use_bias, soft)
                bias2, ms2, is2 = _push(s2, h, use_bias, soft)
                a1, a2 = lam[k], lam[k2]
                b1 = ms1 * (row_velocity(k, a, b, J, V) + bias1) + is1 * K11 * a1 - (K11 * a1 + K12 * a2)
                b2 = ms2 * (row_velocity(k2, a, b, J, V) + bias2) + is2 * K22 * a2 - (K12 * a1 + K22 * a2)
                x1, x2 = lcp2(K11, K12, K22, b1, b2)
                lam[k] = x1
                lam[k2] = x2
                apply_row_impulse(k, a, b, JM, x1 - a1, V)
                apply_row_impulse(k2, a, b, JM, x2 - a2, V)
                worst = max(worst, abs(x1 - a1) * K11, abs(x2 - a2) * K22)
                c += 2
                continue
        # relax leaves a point still apart alone: the next sweep with the push limits its
        # approach to closing the gap (cutting it here would bounce it off the air)
        if A_diag[k] > 0.0 and (use_bias or s1 <= MET):
            bias, mass_scale, impulse_scale = _push(s1, h, use_bias, soft)
            d = -mass_scale * (row_velocity(k, a, b, J, V) + bias) / A_diag[k] - impulse_scale * lam[k]
            new = max(lam[k] + d, 0.0)  # clamp the accumulated impulse, not the increment
            d = new - lam[k]
            lam[k] = new
            apply_row_impulse(k, a, b, JM, d, V)
            worst = max(worst, abs(d) * A_diag[k])
        c += 1
    for c in range(n_contacts):
        k, kn = friction_row[c], normal_row[c]
        if A_diag[k] <= 0.0 or (lam[kn] == 0.0 and lam[k] == 0.0):
            continue  # static pair, or a point that does not push: its friction cone is [0, 0]
        a, b = i[k], j[k]
        top = mu[k] * lam[kn]
        d = -row_velocity(k, a, b, J, V) / A_diag[k]
        new = min(max(lam[k] + d, -top), top)
        d = new - lam[k]
        lam[k] = new
        apply_row_impulse(k, a, b, JM, d, V)
        worst = max(worst, abs(d) * A_diag[k])
    return worst


@njit(cache=True)
def _note_approach(normal_row, i, j, J, C0, r, normal, moved, V, impacted, sub_C, sub_vn):
    """Before a sweep: every point's separation now (m), and J V (m/s) of those not yet met."""
    for c in range(normal_row.shape[0]):
        k = normal_row[c]
        sub_C[c] = _separation(c, i[k], j[k], C0, r, normal, moved)
        if not impacted[c]:
            sub_vn[c] = row_velocity(k, i[k], j[k], J, V)


@njit(cache=True)
def _note_impacts(normal_row, i, j, J, dv, h, lam, sub_C, sub_vn, threshold, impacted, vn_impact, dvn_impact,
                  landed):
    """After a sweep: a point that pushed for the first time meets its partner in this
    sub-step's motion (gap sub_C, J V sub_vn before a sub-step of forces dv): its approach
    at impact (``approach_at_impact``) and the forces' share of the sub-step (m/s).
    landed[c]: it was still apart and met its partner faster than the threshold."""
    for c in range(normal_row.shape[0]):
        k = normal_row[c]
        if not impacted[c] and lam[k] > 0.0:
            impacted[c] = True
            dvn = row_velocity(k, i[k], j[k], J, dv)
            vn_impact[c] = approach_at_impact(sub_C[c], sub_vn[c], sub_vn[c] + dvn, h)
            dvn_impact[c] = dvn
            landed[c] = sub_C[c] > MET and vn_impact[c] < -threshold


@njit(cache=True)
def soft_step_solve(normal_row, friction_row, i, j, J, JM, A_diag, mu, restitution, C0, point, normal, static_pair,
                    x, theta, V, V1, dt, substeps, relax, contact_hertz, damping_ratio, push_max,
                    restitution_threshold, block, lam, total, residuals):
    """The whole tick: sub-steps of forces, warm start, soft sweep, positions, relax.

    ``lam`` holds the impulse per sub-step (warm start in, last sub-step out);
    ``total`` receives the impulse over the whole tick (N s). Positions are
    integrated here. Returns the number of sweeps recorded in ``residuals``.
    """
    n_rows = lam.shape[0]
    n_contacts = normal_row.shape[0]
    h = dt / substeps
    hertz = min(contact_hertz, 0.25 / h)
    soft_dyn = _soft(hertz, damping_ratio, h, push_max)
    soft_static = _soft(2.0 * hertz, damping_ratio, h, push_max)
    x0 = x.copy()
    theta0 = theta.copy()
    moved = np.zeros((x.shape[0], 4))  # per body: dx, dy, cos dtheta, sin dtheta since the tick began
    moved[:, 2] = 1.0
    # lever arms at the start of the tick
    r = np.empty((n_contacts, 4))
    for c in range(n_contacts):
        k = normal_row[c]
        a, b = i[k], j[k]
        r[c, 0] = point[c, 0] - x[a, 0]
        r[c, 1] = point[c, 1] - x[a, 1]
        r[c, 2] = point[c, 0] - x[b, 0]
        r[c, 3] = point[c, 1] - x[b, 1]
    # each point's approach at impact: taken in the sub-step where it first pushes
    impacted = np.zeros(n_contacts, np.bool_)
    vn_impact = np.zeros(n_contacts)
    dvn_impact = np.zeros(n_contacts)
    sub_C = np.zeros(n_contacts)
    sub_vn = np.zeros(n_contacts)
    landed = np.zeros(n_contacts, np.bool_)  # met its partner fast in this sub-step
    dv = (V - V1) / substeps  # a sub-step's share of the external forces
    V[:, :] = V1
    for k in range(n_rows):
        total[k] = 0.0
    n_sweeps = 0
    for _ in range(substeps):
        _note_approach(normal_row, i, j, J, C0, r, normal, moved, V, impacted, sub_C, sub_vn)
        V += dv
        for k in range(n_rows):  # warm start: last sub-step's impulses
            if lam[k] != 0.0:
                apply_row_impulse(k, i[k], j[k], JM, lam[k], V)
        soft_sweep(normal_row, friction_row, i, j, J, JM, A_diag, mu, sub_C, static_pair, lam, V, h, True, soft_dyn,
                   soft_static, block)
        _note_impacts(normal_row, i, j, J, dv, h, lam, sub_C, sub_vn, restitution_threshold, impacted, vn_impact,
                      dvn_impact, landed)
        for b in range(x.shape[0]):
            x[b, 0] += h * V[b, 0]
            x[b, 1] += h * V[b, 1]
            theta[b] += h * V[b, 2]
            moved[b, 0] = x[b, 0] - x0[b, 0]
            moved[b, 1] = x[b, 1] - x0[b, 1]
            moved[b, 2] = np.cos(theta[b] - theta0[b])
            moved[b, 3] = np.sin(theta[b] - theta0[b])
        if relax:  # it stops what would close a gap in the next sub-step's motion: that is an impact too
            _note_approach(normal_row, i, j, J, C0, r, normal, moved, V, impacted, sub_C, sub_vn)
            residuals[n_sweeps] = soft_sweep(normal_row, friction_row, i, j, J, JM, A_diag, mu, sub_C, static_pair, lam,
                                              V, h, False, soft_dyn, soft_static, block)
            _note_impacts(normal_row, i, j, J, dv, h, lam, sub_C, sub_vn, restitution_threshold, impacted, vn_impact,
                          dvn_impact, landed)
        else:
            residuals[n_sweeps] = 0.0
        n_sweeps += 1
        for k in range(n_rows):
            total[k] += lam[k]
        for c in range(n_contacts):  # an impact is an event, not a load: not warm started again
            if landed[c]:
                lam[normal_row[c]] = 0.0
                lam[friction_row[c]] = 0.0
                landed[c] = False
    # restitution: bounce the points that met their partner fast (``constraints.rows.bounce_target``)
    for c in range(n_contacts):
        k, kt = normal_row[c], friction_row[c]
        if (restitution[c] == 0.0 or not impacted[c] or vn_impact[c] >= -restitution_threshold
                or total[k] == 0.0 or A_diag[k] <= 0.0):
            continue
        a, b = i[k], j[k]
        target = bounce_target(restitution[c], vn_impact[c], dvn_impact[c])
        d = (target - row_velocity(k, a, b, J, V)) / A_diag[k]
        new = max(total[k] + d, 0.0)
        d = new - total[k]
        total[k] = new
        apply_row_impulse(k, a, b, JM, d, V)
        # a smaller push shrinks the cone: keep the tick's friction inside mu lambda_n
        top = mu[kt] * total[k]
        d = min(max(total[kt], -top), top) - total[kt]
        if d != 0.0:
            total[kt] += d
            apply_row_impulse(kt, a, b, JM, d, V)
    return n_sweeps


class SoftStep(Responder):
    """Sub-stepped soft-contact solver (Box2D v3's "soft step"): stable stacks and mass ratios.

    substeps       sub-steps per tick (each: one sweep with the soft push, one relax sweep)
    relax          run the relax sweep that removes the push's velocity
    contact_hertz  stiffness of the contact spring (Hz); capped at a quarter of the sub-step rate
    damping_ratio  zeta of the contact spring (10: heavily over-damped, no bounce from the push)
    push_max       largest velocity the push may give an overlapping point (m/s)
    restitution_threshold  approach speed (m/s) above which e applies
    warm_start     start each sub-step from last tick's impulse per sub-step
    block          solve a two-point manifold's normal rows together (see ``soft_sweep``)

    Friction is Coulomb's (|lambda_t| <= mu lambda_n). Joints are not supported.
    """

    name = "soft-step"
    counts = "substeps"
    handles_joints = False
    colour_order = True  # measured: steadier tall piles than pair order, and faster sweeps
    beta = 0.0  # the rows' Baumgarte terms are not used: the push is soft
    slop = 0.0

    substeps = Setting(lambda v, name: check_int(v, name, 1), "sub-steps per tick")
    relax = Setting(check_bool, "run the relax sweep")
    contact_hertz = Setting(non_negative_float, "contact spring stiffness, Hz")
    damping_ratio = Setting(non_negative_float, "contact spring damping ratio")
    push_max = Setting(non_negative_float, "largest push-out speed, m/s")
    restitution_threshold = Setting(non_negative_float, "approach speed (m/s) above which e applies")
    warm_start = Setting(check_bool, "start from last tick's impulses")
    block = Setting(check_bool, "solve two-point manifolds as 2x2 blocks")

    def __init__(self, substeps: int = 4, relax: bool = True, contact_hertz: float = 30.0,
                 damping_ratio: float = 10.0, push_max: float = 3.0, restitution_threshold: float = 1.0,
                 warm_start: bool = True, block: bool = True) -> None:
        self.substeps = substeps
        self.relax = relax
        self.contact_hertz = contact_hertz
        self.damping_ratio = damping_ratio
        self.push_max = push_max
        self.restitution_threshold = restitution_threshold
        self.warm_start = warm_start
        self.block = block

    def respond(self, ctx: StepContext) -> SolveResult:
        rows = ctx.rows
        n_rows = rows.first_joint_row  # contact rows only: a world with joints refuses this responder
        lam = rows.lam[:n_rows] / self.substeps  # cached impulse per tick -> per sub-step
        total = np.zeros(n_rows)
        residuals = np.zeros(self.substeps)
        static_pair = (ctx.M_inv[ctx.body_a, 0] == 0.0) | (ctx.M_inv[ctx.body_b, 0] == 0.0)
        n = soft_step_solve(rows.normal_row, rows.friction_row, rows.i[:n_rows], rows.j[:n_rows], rows.J[:n_rows],
                            rows.JM[:n_rows], rows.A_diag[:n_rows], rows.mu[:n_rows], ctx.restitution,
                            ctx.separation, ctx.point, ctx.normal, static_pair, ctx.x, ctx.theta, ctx.V, ctx.V1,
                            ctx.dt, self.substeps, self.relax, self.contact_hertz, self.damping_ratio,
                            self.push_max, self.restitution_threshold, self.block, lam, total, residuals)
        rows.lam[:n_rows] = total
        return SolveResult(n, residuals[:n], integrated=True)

    def __repr__(self) -> str:
        return (f"SoftStep(substeps={self.substeps}, relax={self.relax}, contact_hertz={self.contact_hertz:g}, "
                f"damping_ratio={self.damping_ratio:g}, push_max={self.push_max:g}, warm_start={self.warm_start}, "
                f"block={self.block})")


__all__ = ["SoftStep", "soft_step_solve"]
