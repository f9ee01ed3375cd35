"""Soft step: sub-stepping with soft contacts and relaxation (Box2D v3's solver).

What the field learned after the lecture, kept beside its PGS, not in place of it.
The tick of length dt is split into n sub-steps of h = dt/n. The stages carry
Box2D v3's names:

    prepare                                  lever arms (as each manifold was found: a recycled
                                             one keeps them); once per tick, per manifold, what
                                             the sweeps reuse (``prepare_manifolds``); per
                                             sub-step, the joint rows at the positions now (and
                                             their factor, below)
    integrate velocities  V += h M^-1 F_ext  external forces, a slice at a time
    warm start            V += M^-1 J^T lam  the impulse per sub-step
    solve (with bias)                        joint rows, then one PGS sweep of the contacts
                                             with a soft push (below)
    integrate positions   x += h v, theta += h omega
    relax                                    the same without the push: remove its velocity
    store                                    add the sub-step's impulses to the tick's

and after the last sub-step one restitution pass: the points that met their partner
faster than the threshold bounce from their approach at impact, taken in the
sub-step where they first pushed. Between sweeps the separation of each contact point
is updated from how far its bodies have moved (x - x0 and the rotated lever arms),
so no new collision detection is needed within the tick. The relax sweep leaves
points still apart alone (the next sweep with the push limits their approach), and
an impact's impulse is not warm started into the next sub-step: it was an event,
not a load.

Joints (distance, pin, angle) are rebuilt at each sub-step's positions, so C and J
follow the motion. Their equality rows are solved together: a Cholesky factor of
their A = J M^-1 J^T (a chain's A is banded: only each row's envelope is factored)
gives delta lambda = -A^-1 (J V + bias) exactly for the joint block, bias pulling C
back to 0 at ``joint_hertz``; a heavy body on a long chain then stretches it by
millimetres where one sweep of soft joint rows lets it stretch by decimetres.
Angle limits are one-sided rows solved like contact points.

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

The kernels take records (``phys2d.pipeline.records``), a few arguments each: the bodies,
the rows, the tick's contact points (``Points``) and the joints, which are None in a world
without them, so that none of the joints' code is compiled there.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import config, njit, types
from numba.experimental import structref

from ..constraints.joints import JointArrays, joint_rows
from ..constraints.rows import (
    MET,
    apply_row_impulse,
    approach_at_impact,
    bounce_target,
    pair_row_impulse,
    pair_row_velocity,
    pair_velocity,
    row_velocity,
    store_pair_velocity,
    unsigned_indices,
)
from ..pipeline import records
from ..pipeline.records import RowRecord
from ..validation import Setting, check_bool, check_int, non_negative_float
from .base import Responder, SolveResult, StepContext
from .block import block_is_well_conditioned, inverse_diagonal, lcp2


class SoftSettings(NamedTuple):
    """A ``SoftStep``'s settings as its kernel reads them (see ``SoftStep``)."""

    substeps: int
    relax: bool
    contact_hertz: float
    damping_ratio: float
    push_max: float
    joint_hertz: float
    joint_damping_ratio: float
    direct_joints: bool
    restitution_threshold: float
    block: bool


POINT_FIELDS = ("C0", "e", "r", "C", "vn", "pending", "impacted", "vn_impact", "dvn_impact", "landed")
_POINTS_DOC = """The tick's contact points, in row order (point c owns rows normal_row[c] and friction_row[c]):
    as found, its separation C0 (m), restitution e and lever arms r = (r_a, r_b) (m); within a
    sub-step its separation C now (m) and J V before the sweep, vn (m/s); the points not yet met
    (pending, in order) and, once met, their approach at impact (vn_impact, m/s, and dvn_impact,
    the forces' share of the sub-step); landed: met its partner fast in this sub-step."""

if config.DISABLE_JIT:  # type: ignore[attr-defined]  # plain Python: a plain object, as the records are

    class Points:
        __doc__ = _POINTS_DOC

        def __init__(self, *arrays: np.ndarray) -> None:
            for name, a in zip(POINT_FIELDS, arrays, strict=True):
                setattr(self, name, a)

else:

    @structref.register
    class PointsType(types.StructRef):
        def preprocess_fields(self, fields):
            return tuple((name, types.unliteral(typ)) for name, typ in fields)

    class Points(structref.StructRefProxy):  # type: ignore[no-redef]
        __doc__ = _POINTS_DOC

    structref.define_proxy(Points, PointsType, POINT_FIELDS)


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
def _separation(c, k, a, b, C0, r, J, moved):
    """Current separation of point c (m) from its bodies' motion since the tick began.

    moved[body] = (dx, dy, cos dtheta, sin dtheta); each anchor has moved by
    dx + R(dtheta) r - r. The normal n is that of the point's normal row k (J_k = [-n, . | n, .]).
    """
    s = C0[c]
    for side in range(2):
        body = a if side == 0 else b
        rx, ry = r[c, 2 * side], r[c, 2 * side + 1]
        dx = moved[body, 0] + moved[body, 2] * rx - moved[body, 3] * ry - rx
        dy = moved[body, 1] + moved[body, 3] * rx + moved[body, 2] * ry - ry
        d = dx * J[k, 3] + dy * J[k, 4]
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


@njit(cache=True, inline="always")  # into solve, its one caller: a call takes and drops a reference per array
def soft_sweep(rows, manifolds, inv_A_kk, C, V, h, use_bias, springs):
    """One sweep over the contacts: the normal rows manifold by manifold (soft push if use_bias),
    then the friction rows. C[c] is point c's separation now (m); ``manifolds`` comes from
    ``prepare_manifolds``; inv_A_kk = 1 / A_kk (``inverse_diagonal``: the sweeps multiply,
    never divide); springs: the soft push against a dynamic and a static partner (``_soft``).

    A two-point manifold marked as a block has its normal rows solved together (lcp2), each
    row scaled by its own softness (relax does so only while both points touch):
        K lambda + [m_p (J_p V + bias_p) + s_p A_pp a_p - (K a)_p] >= 0, lambda >= 0.
    Returns the largest |delta lambda| A_kk of the sweep (m/s).
    """
    normal_row, friction_row, body_a, body_b = rows.normal_row, rows.friction_row, rows.body_a, rows.body_b
    J, JM, A_kk, mu, lam = rows.J, rows.JM, rows.A_kk, rows.mu, rows.lam
    soft_dyn, soft_static = springs[0], springs[1]
    start, static_pair, K12, as_block, inv_det = manifolds
    worst = 0.0
    for m in range(start.shape[0] - 1):
        c = start[m]
        k = normal_row[c]
        a, b = body_a[k], body_b[k]
        soft = soft_static if static_pair[m] else soft_dyn
        s1 = C[c]
        V_ab = pair_velocity(a, b, V)  # the pair's velocities in hand through its rows (sweep, pgs.py)
        if as_block[m] and (use_bias or (s1 <= MET and C[c + 1] <= MET)):
            k2 = normal_row[c + 1]
            s2 = C[c + 1]
            K11, K22 = A_kk[k], A_kk[k2]
            bias1, ms1, is1 = _push(s1, h, use_bias, soft)
            bias2, ms2, is2 = _push(s2, h, use_bias, soft)
            a1, a2 = lam[k], lam[k2]
            b1 = ms1 * (pair_row_velocity(k, J, V_ab) + bias1) + is1 * K11 * a1 - (K11 * a1 + K12[m] * a2)
            b2 = ms2 * (pair_row_velocity(k2, J, V_ab) + bias2) + is2 * K22 * a2 - (K12[m] * a1 + K22 * a2)
            x1, x2 = lcp2(K11, K12[m], K22, inv_det[m], b1, b2)
            lam[k] = x1
            lam[k2] = x2
            V_ab = pair_row_impulse(k2, JM, x2 - a2, pair_row_impulse(k, JM, x1 - a1, V_ab))
            worst = max(worst, abs(x1 - a1) * K11, abs(x2 - a2) * K22)
        else:
            # relax leaves a point still apart alone: the next sweep with the push limits its
            # approach to closing the gap (cutting it here would bounce it off the air)
            for c in range(start[m], start[m + 1]):
                k = normal_row[c]
                s1 = C[c]
                if A_kk[k] > 0.0 and (use_bias or s1 <= MET):
                    bias, mass_scale, impulse_scale = _push(s1, h, use_bias, soft)
                    d = -mass_scale * (pair_row_velocity(k, J, V_ab) + bias) * inv_A_kk[k] - impulse_scale * lam[k]
                    new = max(lam[k] + d, 0.0)  # clamp the accumulated impulse, not the increment
                    d = new - lam[k]
                    lam[k] = new
                    V_ab = pair_row_impulse(k, JM, d, V_ab)
                    worst = max(worst, abs(d) * A_kk[k])
        store_pair_velocity(a, b, V_ab, V)
    for m in range(start.shape[0] - 1):  # then the friction rows, manifold by manifold
        k = friction_row[start[m]]
        a, b = body_a[k], body_b[k]
        V_ab = pair_velocity(a, b, V)
        for c in range(start[m], start[m + 1]):
            k, kn = friction_row[c], normal_row[c]
            if A_kk[k] <= 0.0 or (lam[kn] == 0.0 and lam[k] == 0.0):
                continue  # static pair, or a point that does not push: its friction cone is [0, 0]
            top = mu[k] * lam[kn]
            d = -pair_row_velocity(k, J, V_ab) * inv_A_kk[k]
            new = min(max(lam[k] + d, -top), top)
            d = new - lam[k]
            lam[k] = new
            V_ab = pair_row_impulse(k, JM, d, V_ab)
            worst = max(worst, abs(d) * A_kk[k])
        store_pair_velocity(a, b, V_ab, V)
    return worst


@njit(cache=True)
def _separations(rows, points, moved):
    """Every point's separation C at the positions now (m)."""
    normal_row, body_a, body_b, J = rows.normal_row, rows.body_a, rows.body_b, rows.J
    C0, r, C = points.C0, points.r, points.C
    for c in range(normal_row.shape[0]):
        k = normal_row[c]
        C[c] = _separation(c, k, body_a[k], body_b[k], C0, r, J, moved)


@njit(cache=True)
def _note_approach(rows, points, n_pending, V):
    """Before a sweep: J V (m/s) of the points not yet met (pending[:n_pending])."""
    normal_row, body_a, body_b, J = rows.normal_row, rows.body_a, rows.body_b, rows.J
    pending, vn = points.pending, points.vn
    for q in range(n_pending):
        c = pending[q]
        k = normal_row[c]
        vn[c] = row_velocity(k, body_a[k], body_b[k], J, V)


@njit(cache=True)
def _note_impacts(rows, points, n_pending, dv, h, threshold):
    """After a sweep: a point that pushed for the first time meets its partner in this
    sub-step's motion (gap C, J V vn before a sub-step of forces dv): its approach
    at impact (``approach_at_impact``) and the forces' share of the sub-step (m/s).
    landed[c]: it was still apart and met its partner faster than the threshold.
    Returns how many points are still to meet theirs (kept in order in pending)."""
    normal_row, body_a, body_b, J, lam = rows.normal_row, rows.body_a, rows.body_b, rows.J, rows.lam
    pending, C, vn, impacted, landed = points.pending, points.C, points.vn, points.impacted, points.landed
    vn_impact, dvn_impact = points.vn_impact, points.dvn_impact
    n = 0
    for q in range(n_pending):
        c = pending[q]
        k = normal_row[c]
        if lam[k] > 0.0:
            impacted[c] = True
            dvn = row_velocity(k, body_a[k], body_b[k], J, dv)
            vn_impact[c] = approach_at_impact(C[c], vn[c], vn[c] + dvn, h)
            dvn_impact[c] = dvn
            landed[c] = C[c] > MET and vn_impact[c] < -threshold
        else:
            pending[n] = c
            n += 1
    return n


# -- joints: rows rebuilt at every sub-step's positions ------------------------------------------
DIRECT_JOINT_ROWS_MAX = 256  # more equality joint rows than this are swept, not factored
PIVOT_TOL = 1e-9  # a pivot below this fraction of A_kk marks a redundant row: it is left out


@njit(cache=True)
def first_joint_row_of(rows):
    """The first joint row: the joints' rows follow the K contacts' 2K."""
    return 2 * rows.normal_row.shape[0]


@njit(cache=True)
def _joint_C(first_joint_row, n_rows, xi, C):
    """C of each joint row (m or rad) from rows built with beta = dt = 1 (xi = -C)."""
    for k in range(first_joint_row, n_rows):
        C[k] = -xi[k]


@njit(cache=True)
def _equality_rows(first_joint_row, n_rows, lo):
    """The joint rows with no bound (pins, rods, fixed angles): indices into the rows."""
    n_eq = 0
    for k in range(first_joint_row, n_rows):
        if lo[k] == -np.inf:
            n_eq += 1
    eq = np.empty(n_eq, np.int64)
    n_eq = 0
    for k in range(first_joint_row, n_rows):
        if lo[k] == -np.inf:
            eq[n_eq] = k
            n_eq += 1
    return eq


@njit(cache=True)
def _coupling(p, q, body_a, body_b, J, JM):
    """A_pq = J_p M^-1 J_q^T: nonzero only through a body rows p and q share."""
    s = 0.0
    for side_p in range(2):
        body_p = body_a[p] if side_p == 0 else body_b[p]
        for side_q in range(2):
            body_q = body_a[q] if side_q == 0 else body_b[q]
            if body_p == body_q:
                for m in range(3):
                    s += J[p, 3 * side_p + m] * JM[q, 3 * side_q + m]
    return s


@njit(cache=True)
def factor_joint_rows(eq, body_a, body_b, J, JM, L, first):
    """Cholesky factor L L^T = A of the equality joint rows ``eq`` (A_pq = J_p M^-1 J_q^T).

    Only each row's envelope is touched: first[p] is the first row that shares a body
    with row p, so a chain's A (banded) costs O(n w^2). A redundant row (a pivot below
    PIVOT_TOL A_pp) gets L_pp = 0 and is left out of the solve.
    """
    n = eq.shape[0]
    n_bodies = 0
    for p in range(n):
        n_bodies = max(n_bodies, body_a[eq[p]] + 1, body_b[eq[p]] + 1)
    first_touch = np.full(n_bodies, n, np.int64)  # per body, the first row on it so far (n: none)
    for p in range(n):  # the envelope in one pass (a scan of the rows before each row is O(n^2))
        a, b = body_a[eq[p]], body_b[eq[p]]
        first[p] = min(p, first_touch[a], first_touch[b])
        first_touch[a] = min(first_touch[a], p)
        first_touch[b] = min(first_touch[b], p)
    for p in range(n):
        for q in range(first[p], p + 1):
            s = _coupling(eq[p], eq[q], body_a, body_b, J, JM)
            for m in range(max(first[p], first[q]), q):
                s -= L[p, m] * L[q, m]
            if q < p:
                L[p, q] = s / L[q, q] if L[q, q] > 0.0 else 0.0
            else:
                A_pp = _coupling(eq[p], eq[p], body_a, body_b, J, JM)
                L[p, p] = np.sqrt(s) if s > PIVOT_TOL * A_pp else 0.0


@njit(cache=True)
def solve_factored(L, first, y):
    """y <- A^-1 y with A = L L^T from ``factor_joint_rows`` (left-out rows get 0)."""
    n = y.shape[0]
    for p in range(n):  # forward: L z = y
        for m in range(first[p], p):
            y[p] -= L[p, m] * y[m]
        y[p] = y[p] / L[p, p] if L[p, p] > 0.0 else 0.0
    for p in range(n - 1, -1, -1):  # back: L^T x = z
        y[p] = y[p] / L[p, p] if L[p, p] > 0.0 else 0.0
        for m in range(first[p], p):
            y[m] -= L[p, m] * y[p]


@njit(cache=True)
def _joint_bias(C, use_bias, soft):
    """Velocity bias of an equality joint row whose error is C (m or rad): the joint's soft pull."""
    return soft[0] * C if use_bias else 0.0


@njit(cache=True)
def solve_joints(rows, system, V, h, use_bias, soft_joint):
    """The joint rows once: limit rows one by one (lambda >= 0, like a contact point whose
    separation is the gap to the stop), then the equality rows, together (``direct``:
    delta lambda = -A^-1 (J V + bias), exact for the joint block) or one by one with the
    joint's softness. ``system``: the joint rows' (eq, L, first, C, direct) (``joint_system``).
    Returns the largest |delta lambda| A_kk (m/s)."""
    first_joint_row, n_rows = first_joint_row_of(rows), rows.lam.shape[0]
    body_a, body_b, J, JM, A_kk, lo, lam = rows.body_a, rows.body_b, rows.J, rows.JM, rows.A_kk, rows.lo, rows.lam
    eq, L, first, C, direct = system
    worst = 0.0
    for k in range(first_joint_row, n_rows):
        unbounded = lo[k] == -np.inf
        if A_kk[k] <= 0.0 or (direct and unbounded):
            continue
        a, b = body_a[k], body_b[k]
        if unbounded:  # the soft joint of Box2D v3
            mass_scale, impulse_scale = (soft_joint[1], soft_joint[2]) if use_bias else (1.0, 0.0)
            d = (
                -mass_scale * (row_velocity(k, a, b, J, V) + _joint_bias(C[k], use_bias, soft_joint)) / A_kk[k]
                - impulse_scale * lam[k]
            )
            lam[k] += d
        else:
            if not use_bias and C[k] > MET:
                continue  # relax leaves a limit still short of its stop alone
            bias, mass_scale, impulse_scale = _push(C[k], h, use_bias, soft_joint)
            d = -mass_scale * (row_velocity(k, a, b, J, V) + bias) / A_kk[k] - impulse_scale * lam[k]
            new = max(lam[k] + d, 0.0)  # a stop pushes, it never pulls
            d = new - lam[k]
            lam[k] = new
        apply_row_impulse(k, a, b, JM, d, V)
        worst = max(worst, abs(d) * A_kk[k])
    if direct and eq.shape[0] > 0:
        y = np.empty(eq.shape[0])
        for p in range(eq.shape[0]):
            k = eq[p]
            y[p] = -(row_velocity(k, body_a[k], body_b[k], J, V) + _joint_bias(C[k], use_bias, soft_joint))
        solve_factored(L, first, y)
        for p in range(eq.shape[0]):
            k = eq[p]
            lam[k] += y[p]
            apply_row_impulse(k, body_a[k], body_b[k], JM, y[p], V)
            worst = max(worst, abs(y[p]) * A_kk[k])
    return worst


@njit(cache=True)
def joint_system(joints, rows, direct_joints):
    """What the joint rows keep over the tick: (eq, L, first, C, direct): eq the equality rows
    (``_equality_rows``), L and first their factor (``factor_joint_rows``) when ``direct``
    (``direct_joints`` and at most DIRECT_JOINT_ROWS_MAX of them), C each joint row's error.
    Empty for a world without joints (joints None): then none of the joints' code is compiled."""
    first_joint_row, n_rows = first_joint_row_of(rows), rows.lam.shape[0]
    eq = np.zeros(0, np.int64)
    if joints is not None:
        eq = _equality_rows(first_joint_row, n_rows, rows.lo)
    direct = direct_joints and 0 < eq.shape[0] <= DIRECT_JOINT_ROWS_MAX
    L = np.zeros((eq.shape[0], eq.shape[0])) if direct else np.zeros((0, 0))
    first = np.zeros(eq.shape[0], np.int64)
    C = np.zeros(n_rows)
    return eq, L, first, C, direct


@njit(cache=True)
def prepare_joints(joints, bodies, rows, system):
    """The joint rows at the bodies' positions now (``joint_rows`` into ``rows``): J, A_kk
    and their error C; with ``direct`` the factor of the equality rows' A."""
    first_joint_row, n_rows = first_joint_row_of(rows), rows.lam.shape[0]
    eq, L, first, C, direct = system
    joint_rows(joints, first_joint_row, bodies, 1.0, 1.0, rows)  # beta = dt = 1: xi = -C
    _joint_C(first_joint_row, n_rows, rows.xi, C)
    if direct:
        factor_joint_rows(eq, rows.body_a, rows.body_b, rows.J, rows.JM, L, first)


# -- the stages of a sub-step ---------------------------------------------------------------------
@njit(cache=True)
def gather_contacts(order, separation, restitution, anchor):
    """What the tick reads of each contact, in row order (row pair q is contact order[q]):
    its separation C0 (m), restitution e and lever arms (r_a, r_b) (m). One pass, at prepare;
    the normal is read from the contact's normal row (J_k = [-n, . | n, .])."""
    n = order.shape[0]
    C0, e, r = np.empty(n), np.empty(n), np.empty((n, 4))
    for q in range(n):
        c = order[q]
        C0[q] = separation[c]
        e[q] = restitution[c]
        for i in range(4):
            r[q, i] = anchor[c, i]
    return C0, e, r


@njit(cache=True)
def prepare_points(found, n_contacts):
    """The tick's ``Points`` of the step's contacts: C0, e and r gathered into row order
    (``gather_contacts`` of found = (order, separation, e, anchor)), the rest to fill in."""
    C0, e, r = gather_contacts(found[0], found[1], found[2], found[3])
    return Points(
        C0, e, r, np.zeros(n_contacts), np.zeros(n_contacts), np.arange(n_contacts, dtype=np.uint32),
        np.zeros(n_contacts, np.bool_), np.zeros(n_contacts), np.zeros(n_contacts), np.zeros(n_contacts, np.bool_),
    )  # fmt: skip


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
    normal_row, body_a, body_b, J, JM, A_kk = rows.normal_row, rows.body_a, rows.body_b, rows.J, rows.JM, rows.A_kk
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
    start = start[: n + 1].copy()
    static_pair = np.empty(n, np.bool_)
    K12 = np.zeros(n)
    as_block = np.zeros(n, np.bool_)
    inv_det = np.zeros(n)
    for m in range(n):
        k = normal_row[start[m]]
        a, b = body_a[k], body_b[k]
        static_pair[m] = M_inv[a, 0] == 0.0 or M_inv[b, 0] == 0.0
        if block and start[m + 1] - start[m] == 2:
            k2 = normal_row[start[m] + 1]
            K = 0.0
            for q in range(6):
                K += J[k, q] * JM[k2, q]
            K12[m] = K
            as_block[m] = block_is_well_conditioned(A_kk[k], K, A_kk[k2])
            if as_block[m]:
                inv_det[m] = 1.0 / (A_kk[k] * A_kk[k2] - K * K)
    return start, static_pair, K12, as_block, inv_det


@njit(cache=True)
def warm_start(manifolds, rows, V):
    """Apply last sub-step's impulses (N s) to V: a manifold's rows (normal, then friction, point
    by point) on its pair's velocities held in hand (``pair_velocity``), stored once; then the
    joint rows."""
    normal_row, friction_row, body_a, body_b = rows.normal_row, rows.friction_row, rows.body_a, rows.body_b
    JM, lam = rows.JM, rows.lam
    start = manifolds[0]
    for m in range(start.shape[0] - 1):
        k = normal_row[start[m]]
        a, b = body_a[k], body_b[k]
        V_ab = pair_velocity(a, b, V)
        for c in range(start[m], start[m + 1]):
            for k in (normal_row[c], friction_row[c]):
                if lam[k] != 0.0:
                    V_ab = pair_row_impulse(k, JM, lam[k], V_ab)
        store_pair_velocity(a, b, V_ab, V)
    for k in range(first_joint_row_of(rows), lam.shape[0]):
        if lam[k] != 0.0:
            apply_row_impulse(k, body_a[k], body_b[k], JM, lam[k], V)


SMALL_TURN = 1.0 / 32.0  # rad: a turn below this takes cos and sin from their Taylor series


@njit(cache=True)
def cos_sin(d):
    """(cos d, sin d) of a turn d (rad). Below SMALL_TURN by Taylor series to d^8 and d^7: the
    terms left out are below 3e-18 of the result, so it is libm's to an ulp, in a few
    multiplications instead of libm's two calls; a body turns far less than that within a
    tick. Larger turns: np.cos, np.sin."""
    if abs(d) >= SMALL_TURN:
        return np.cos(d), np.sin(d)
    d2 = d * d
    c = 1.0 - d2 * (1.0 / 2.0 - d2 * (1.0 / 24.0 - d2 * (1.0 / 720.0 - d2 * (1.0 / 40320.0))))
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
def integrate_positions(bodies, h, x0, theta0, moved):
    """x += h v, theta += h omega; moved[b] = (dx, dy, cos dtheta, sin dtheta) since the tick began."""
    x, theta, V = bodies.x, bodies.theta, bodies.V
    for b in range(x.shape[0]):
        x[b, 0] += h * V[b, 0]
        x[b, 1] += h * V[b, 1]
        theta[b] += h * V[b, 2]
        moved[b, 0] = x[b, 0] - x0[b, 0]
        moved[b, 1] = x[b, 1] - x0[b, 1]
        moved[b, 2], moved[b, 3] = cos_sin(theta[b] - theta0[b])


@njit(cache=True)
def store(rows, total, points):
    """Add the sub-step's impulses to the tick's; an impact is an event, not a load: it is
    not warm started into the next sub-step."""
    normal_row, friction_row, lam, landed = rows.normal_row, rows.friction_row, rows.lam, points.landed
    for k in range(lam.shape[0]):
        total[k] += lam[k]
    for c in range(normal_row.shape[0]):
        if landed[c]:
            lam[normal_row[c]] = 0.0
            lam[friction_row[c]] = 0.0
            landed[c] = False


@njit(cache=True)
def restitution(rows, points, threshold, total, V):
    """Bounce the points that met their partner fast (``constraints.rows.bounce_target``),
    keeping the tick's friction inside mu lambda_n."""
    normal_row, friction_row, body_a, body_b = rows.normal_row, rows.friction_row, rows.body_a, rows.body_b
    J, JM, A_kk, mu = rows.J, rows.JM, rows.A_kk, rows.mu
    e, impacted, vn_impact, dvn_impact = points.e, points.impacted, points.vn_impact, points.dvn_impact
    for c in range(normal_row.shape[0]):
        k, kt = normal_row[c], friction_row[c]
        if e[c] == 0.0 or not impacted[c] or vn_impact[c] >= -threshold or total[k] == 0.0 or A_kk[k] <= 0.0:
            continue
        a, b = body_a[k], body_b[k]
        target = bounce_target(e[c], vn_impact[c], dvn_impact[c])
        d = (target - row_velocity(k, a, b, J, V)) / A_kk[k]
        new = max(total[k] + d, 0.0)
        d = new - total[k]
        total[k] = new
        apply_row_impulse(k, a, b, JM, d, V)
        top = mu[kt] * total[k]  # a smaller push shrinks the cone
        d = min(max(total[kt], -top), top) - total[kt]
        if d != 0.0:
            total[kt] += d
            apply_row_impulse(kt, a, b, JM, d, V)


@njit(cache=True, inline="always")  # into soft_step_solve, at its one call site (the sub-step's sweep loop)
def solve(rows, manifolds, inv_A_kk, C, V, h, use_bias, springs, joints, system):
    """One solve of a sub-step (with bias, or the relax pass without): joints first, contacts
    last (they have the last word on overlap). springs: (contacts with a dynamic partner, with
    a static one, joints) (``_soft``). Returns the largest velocity correction (m/s)."""
    worst = 0.0
    if joints is not None and rows.lam.shape[0] > first_joint_row_of(rows):
        worst = solve_joints(rows, system, V, h, use_bias, springs[2])
    return max(worst, soft_sweep(rows, manifolds, inv_A_kk, C, V, h, use_bias, springs))


@njit(cache=True)
def unsigned_rows(rows):
    """The rows with their row map and bodies as uint32 (``unsigned_indices``, for the sweeps'
    loops): a record over the same arrays."""
    normal_row, friction_row, body_a, body_b = unsigned_indices(
        rows.normal_row, rows.friction_row, rows.body_a, rows.body_b
    )
    return RowRecord(
        normal_row, friction_row, body_a, body_b, rows.J, rows.JM, rows.A_kk, rows.xi, rows.push, rows.bounce,
        rows.impact, rows.lo, rows.hi, rows.bound_row, rows.mu, rows.lam,
    )  # fmt: skip


@njit(cache=True)
def soft_step_solve(bodies, rows, found, joints, dt, settings, residuals):
    """The whole tick, Box2D v3's stages: prepare, then per sub-step integrate velocities,
    warm start, solve with bias, integrate positions, relax (the same sweep without bias),
    store; then restitution.

    bodies: a BodyRecord (V after the external forces, V1 before); rows: the step's rows, the
    K contacts' first (row pair q is contact order[q]), then the joints' from row 2K;
    found: (order, separation, e, anchor) of the K contacts, in contact order; joints: a
    JointRecord, or None for a world without joints (then no joint code is compiled: numba
    drops the ``joints is not None`` branches); settings: a ``SoftSettings``.

    ``rows.lam`` holds the cached impulse per tick going in and the impulse over the whole tick
    (N s) coming out; within the tick it is the impulse per sub-step (warm start in, last
    sub-step out). Joint rows are rebuilt at each sub-step's positions. Returns the number of
    sub-steps; residuals[s] (length ``substeps``, the caller's buffer) is the largest correction
    of sub-step s's relax sweep (m/s), 0 without one.
    """
    x, theta, V = bodies.x, bodies.theta, bodies.V
    substeps, relax, threshold = settings.substeps, settings.relax, settings.restitution_threshold
    n_rows = rows.lam.shape[0]
    n_contacts = rows.normal_row.shape[0]
    h = dt / substeps
    hertz = min(settings.contact_hertz, 0.25 / h)
    springs = (
        _soft(hertz, settings.damping_ratio, h, settings.push_max),  # contacts between dynamic bodies
        _soft(2.0 * hertz, settings.damping_ratio, h, settings.push_max),  # contacts with a static body
        _soft(min(settings.joint_hertz, 0.25 / h), settings.joint_damping_ratio, h, np.inf),  # joints
    )
    # prepare
    joint_rows_in = rows  # the joints' rows are rebuilt in these (signed, as joint_rows is compiled for)
    rows = unsigned_rows(rows)
    lam = rows.lam
    for k in range(n_rows):
        lam[k] /= substeps  # cached impulse per tick -> per sub-step
    total = np.zeros(n_rows)
    manifolds = prepare_manifolds(rows, bodies.M_inv, settings.block)
    inv_A_kk = inverse_diagonal(rows.A_kk)  # the contact rows' A_kk hold over the tick (joint rows do not use it)
    x0 = x.copy()
    theta0 = theta.copy()
    moved = np.zeros((x.shape[0], 4))  # per body: dx, dy, cos dtheta, sin dtheta since the tick began
    moved[:, 2] = 1.0
    points = prepare_points(found, n_contacts)
    system = joint_system(joints, rows, settings.direct_joints)
    dv = split_forces(bodies, substeps)
    n_pending = n_contacts  # the points not yet met: their approach is still to come
    n_sweeps = 0
    for i in range(substeps):
        if joints is not None and n_rows > first_joint_row_of(rows):
            prepare_joints(joints, bodies, joint_rows_in, system)
        for sweep in range(2 if relax else 1):  # with bias, then the relax sweep without
            with_bias = sweep == 0
            if not with_bias or i == 0 or not relax:  # (after a relax sweep the positions have not moved)
                _separations(rows, points, moved)
            if n_pending > 0:  # (once every point has met its partner, nothing is left to note)
                _note_approach(rows, points, n_pending, V)
            if with_bias:
                integrate_velocities(V, dv)
                warm_start(manifolds, rows, V)
            worst = solve(rows, manifolds, inv_A_kk, points.C, V, h, with_bias, springs, joints, system)
            if n_pending > 0:  # relax stops what would close a gap in the next sub-step's motion: an impact too
                n_pending = _note_impacts(rows, points, n_pending, dv, h, threshold)
            if with_bias:
                integrate_positions(bodies, h, x0, theta0, moved)
            residuals[n_sweeps] = 0.0 if with_bias else worst  # the relax sweep's, when there is one
        n_sweeps += 1
        store(rows, total, points)
    restitution(rows, points, threshold, total, V)
    for k in range(n_rows):
        lam[k] = total[k]
    return n_sweeps


class SoftStep(Responder):
    """Sub-stepped soft-contact solver (Box2D v3's "soft step"): stable stacks, mass ratios, joints.

    substeps       sub-steps per tick (each: one sweep with the soft push, one relax sweep)
    relax          run the relax sweep that removes the push's velocity
    contact_hertz  stiffness of the contact spring (Hz); capped at a quarter of the sub-step rate
    damping_ratio  zeta of the contact spring (10: heavily over-damped, no bounce from the push)
    push_max       largest velocity the push may give an overlapping point (m/s)
    joint_hertz    stiffness of the joints' pull back to C = 0 (Hz), capped like contact_hertz
    joint_damping_ratio  zeta of that pull
    direct_joints  solve the equality joint rows (pins, rods, fixed angles) together, exactly,
                   in each sweep (a Cholesky factor of their A, refreshed every sub-step) instead
                   of one by one; the pull keeps its rate, the rows are rigid
    restitution_threshold  approach speed (m/s) above which e applies
    warm_start     start each sub-step from last tick's impulse per sub-step
    block          solve a two-point manifold's normal rows together (see ``soft_sweep``)

    Friction is Coulomb's (|lambda_t| <= mu lambda_n). Joints' rows are rebuilt at every
    sub-step's positions; angle limits are one-sided rows treated like contact points.
    Contact rows take the lever arms each manifold was found with (``found_lever_arms``;
    a recycled manifold keeps them, as in Box2D v3, ``collision.recycle``): a 20-box stack
    leaning 1 mm a box stands, where arms turned with the boxes let it buckle. Angular
    momentum is then kept to within lambda times how far a point's two arms have parted.
    """

    name = "soft-step"
    counts = "substeps"
    handles_joints = True
    colour_order = True  # measured: steadier tall piles than pair order, and faster sweeps
    contacts_in_row_order = False  # it gathers the three fields it reads itself (gather_contacts)
    found_lever_arms = True  # measured: a 1 mm leaning 20-stack stands (it buckled with arms p - x)
    beta = 0.0  # the rows' Baumgarte terms are not used: the push is soft
    slop = 0.0

    substeps = Setting(lambda v, name: check_int(v, name, 1), "sub-steps per tick")
    relax = Setting(check_bool, "run the relax sweep")
    contact_hertz = Setting(non_negative_float, "contact spring stiffness, Hz")
    damping_ratio = Setting(non_negative_float, "contact spring damping ratio")
    push_max = Setting(non_negative_float, "largest push-out speed, m/s")
    joint_hertz = Setting(non_negative_float, "joint spring stiffness, Hz")
    joint_damping_ratio = Setting(non_negative_float, "joint spring damping ratio")
    direct_joints = Setting(check_bool, "solve the equality joint rows together, exactly")
    restitution_threshold = Setting(non_negative_float, "approach speed (m/s) above which e applies")
    warm_start = Setting(check_bool, "start from last tick's impulses")
    block = Setting(check_bool, "solve two-point manifolds as 2x2 blocks")

    def __init__(
        self,
        substeps: int = 4,
        relax: bool = True,
        contact_hertz: float = 30.0,
        damping_ratio: float = 10.0,
        push_max: float = 3.0,
        restitution_threshold: float = 1.0,
        warm_start: bool = True,
        block: bool = True,
        joint_hertz: float = 60.0,
        joint_damping_ratio: float = 2.0,
        direct_joints: bool = True,
    ) -> None:
        self.substeps = substeps
        self.relax = relax
        self.contact_hertz = contact_hertz
        self.damping_ratio = damping_ratio
        self.push_max = push_max
        self.restitution_threshold = restitution_threshold
        self.warm_start = warm_start
        self.block = block
        self.joint_hertz = joint_hertz
        self.joint_damping_ratio = joint_damping_ratio
        self.direct_joints = direct_joints

    @property
    def settings(self) -> SoftSettings:
        """The settings as ``soft_step_solve`` reads them."""
        return SoftSettings(
            self.substeps, self.relax, self.contact_hertz, self.damping_ratio, self.push_max, self.joint_hertz,
            self.joint_damping_ratio, self.direct_joints, self.restitution_threshold, self.block,
        )  # fmt: skip

    def respond(self, ctx: StepContext) -> SolveResult:
        rows = ctx.rows
        bodies = records.new_bodies((ctx.x, ctx.theta, ctx.V, ctx.M_inv, ctx.V1))
        found = (rows.order, ctx.separation, ctx.restitution, ctx.anchor)
        joints = None  # a world without joints compiles none of their code
        if isinstance(ctx.joints, JointArrays) and ctx.joints.kind.shape[0] > 0:
            joints = records.record_of_joints(ctx.joints, rows.lam[rows.first_joint_row :])  # (lam: not read)
        residuals = np.zeros(self.substeps)
        n = soft_step_solve(bodies, records.record_of_rows(rows), found, joints, ctx.dt, self.settings, residuals)
        return SolveResult(n, residuals[:n], integrated=True)

    def __repr__(self) -> str:
        return (
            f"SoftStep(substeps={self.substeps}, relax={self.relax}, contact_hertz={self.contact_hertz:g}, "
            f"damping_ratio={self.damping_ratio:g}, push_max={self.push_max:g}, warm_start={self.warm_start}, "
            f"block={self.block}, joint_hertz={self.joint_hertz:g}, "
            f"joint_damping_ratio={self.joint_damping_ratio:g}, direct_joints={self.direct_joints})"
        )


__all__ = ["SoftSettings", "SoftStep", "soft_step_solve"]
