"""The soft step's contact points over a tick (``responders.soft_step``): gathered once, their
separation followed from the bodies' motion, their approach kept until they meet their
partner, and the bounce of those that met it fast.

Each sweep of the contacts that follows a move of the bodies works out each point's
separation C from how far its bodies have moved since the tick began (x - x0 and the
rotated lever arms, ``separation_now``), so no new collision detection is needed within
the tick. A point not yet met reads its approach J V from the bodies' velocities as the
sweep began (``Points.V_sweep``), only when it pushes.
"""

from __future__ import annotations

import numpy as np
from numba import config, njit, types
from numba.experimental import structref

from ..constraints.rows import (
    MET,
    approach_at_impact,
    bounce_target,
    pair_inverse_mass,
    pair_row_impulse_of,
    pair_row_velocity,
    pair_velocity,
    row_velocity,
    store_pair_velocity,
)

POINT_FIELDS = ("C0", "e", "r", "C", "moved", "V_sweep", "pending", "impacted", "vn_impact", "dvn_impact", "landed")
_POINTS_DOC = """The tick's contact points, in row order (point c owns rows normal_row[c] and friction_row[c]):
    as found, its separation C0 (m), restitution e and lever arms r = (r_a, r_b) (m); within a
    sub-step its separation C now (m); what the points read of their bodies: moved (per body: dx,
    dy (m), cos and sin dtheta since the tick began, what C follows) and V_sweep (per body: V as
    the sweep began, before its forces and warm start: J V_sweep is the approach of a point not
    yet met, the landing's friction target); the points not yet met (pending, in order) and, once
    met, their approach at impact (vn_impact, m/s, and dvn_impact, the forces' share of the
    sub-step); landed: met its partner fast in this sub-step."""

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
def separation_now(c, k, a, b, C0, r, J, moved):
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
def note_impacts(rows, points, n_pending, dv, h, threshold):
    """After a sweep: a point that pushed for the first time meets its partner in this
    sub-step's motion (gap C, J V_sweep = vn before a sub-step of forces dv): its approach
    at impact (``approach_at_impact``) and the forces' share of the sub-step (m/s), which
    only restitution reads, and only of a point with e > 0. landed[c]: it was still apart
    and met its partner faster than the threshold.
    Returns how many points are still to meet theirs (kept in order in pending)."""
    return note_impacts_of(0, n_pending, rows, points, dv, h, threshold)


@njit(cache=True)
def note_impacts_of(first, last, rows, points, dv, h, threshold):
    """``note_impacts`` of pending[first:last]: those still to meet their partner are kept, in
    order, from pending[first] on (``pipeline.parallel.note_impacts_on`` joins the slices).
    Returns how many were kept."""
    normal_row, body_a, body_b, J, lam = rows.normal_row, rows.body_a, rows.body_b, rows.J, rows.lam
    pending, C, V_sweep, impacted, landed = points.pending, points.C, points.V_sweep, points.impacted, points.landed
    e, vn_impact, dvn_impact = points.e, points.vn_impact, points.dvn_impact
    n = first
    for q in range(first, last):
        c = pending[q]
        k = normal_row[c]
        if lam[k] > 0.0:
            impacted[c] = True
            if e[c] == 0.0 and C[c] <= MET:
                continue  # touching, without restitution: it neither bounces nor lands (landed is False)
            a, b = body_a[k], body_b[k]
            vn, dvn = row_velocity(k, a, b, J, V_sweep), row_velocity(k, a, b, J, dv)
            vn_impact[c] = approach_at_impact(C[c], vn, vn + dvn, h)
            dvn_impact[c] = dvn
            landed[c] = C[c] > MET and vn_impact[c] < -threshold
        else:
            pending[n] = c
            n += 1
    return n - first


@njit(cache=True)
def gather_contacts(order, separation, restitution, anchor):
    """What the tick reads of each contact, in row order (row pair q is contact order[q]):
    its separation C0 (m), restitution e and lever arms (r_a, r_b) (m). One pass, at prepare;
    the normal is read from the contact's normal row (J_k = [-n, . | n, .])."""
    n = order.shape[0]
    C0, e, r = np.empty(n), np.empty(n), np.empty((n, 4))
    gather_contacts_of(0, n, (order, separation, restitution, anchor), (C0, e, r))
    return C0, e, r


@njit(cache=True)
def gather_contacts_of(first, last, found, gathered):
    """``gather_contacts`` of row pairs first up to last: found = (order, separation, e, anchor)
    into gathered = (C0, e, r)."""
    order, separation, restitution, anchor = found
    C0, e, r = gathered
    for q in range(first, last):
        c = order[q]
        C0[q] = separation[c]
        e[q] = restitution[c]
        for i in range(4):
            r[q, i] = anchor[c, i]


@njit(cache=True)
def prepare_points(found, n_bodies):
    """The tick's ``Points`` of the step's contacts: C0, e and r gathered into row order
    (``gather_contacts`` of found = (order, separation, e, anchor)), the rest to fill in."""
    C0, e, r = gather_contacts(found[0], found[1], found[2], found[3])
    return points_of(C0, e, r, n_bodies)


@njit(cache=True)
def points_of(C0, e, r, n_bodies):
    """``Points`` over the gathered C0, e and r of n_bodies' contacts, the rest to fill in: the
    bodies have not moved yet (moved = (0, 0, cos 0, sin 0)), so each point's C is its C0."""
    n_contacts = C0.shape[0]
    moved = np.zeros((n_bodies, 4))
    moved[:, 2] = 1.0
    return Points(  # (np.empty: V_sweep and the approach at impact are written before they are read)
        C0, e, r, C0.copy(), moved, np.empty((n_bodies, 3)),
        np.arange(n_contacts, dtype=np.uint32), np.zeros(n_contacts, np.bool_), np.empty(n_contacts),
        np.empty(n_contacts), np.zeros(n_contacts, np.bool_),
    )  # fmt: skip


@njit(cache=True)
def store(rows, total, points):
    """Add the sub-step's impulses to the tick's; an impact is an event, not a load: it is
    not warm started into the next sub-step. The contacts' rows (``store_of``), then the joints'."""
    lam = rows.lam
    store_of(0, rows.normal_row.shape[0], rows, total, points)
    for k in range(2 * rows.normal_row.shape[0], lam.shape[0]):  # the joint rows follow the contacts' 2K
        total[k] += lam[k]


@njit(cache=True)
def store_of(first, last, rows, total, points):
    """``store`` of contacts first up to last: each adds its two rows' impulses to the tick's, and
    one that landed in this sub-step starts the next from 0."""
    normal_row, friction_row, lam, landed = rows.normal_row, rows.friction_row, rows.lam, points.landed
    for c in range(first, last):
        kn, kt = normal_row[c], friction_row[c]
        total[kn] += lam[kn]
        total[kt] += lam[kt]
        if landed[c]:
            lam[kn] = 0.0
            lam[kt] = 0.0
            landed[c] = False


@njit(cache=True)
def restitution(rows, points, threshold, total, V, M_inv):
    """Bounce the points that met their partner fast (``constraints.rows.bounce_target``),
    keeping the tick's friction inside mu lambda_n; M^-1 J^T formed from J and the pair's M^-1
    (``M_inv``), as in the sweeps."""
    normal_row, friction_row, body_a, body_b = rows.normal_row, rows.friction_row, rows.body_a, rows.body_b
    J, A_kk, mu = rows.J, rows.A_kk, rows.mu
    e, impacted, vn_impact, dvn_impact = points.e, points.impacted, points.vn_impact, points.dvn_impact
    for c in range(normal_row.shape[0]):
        k, kt = normal_row[c], friction_row[c]
        if e[c] == 0.0 or not impacted[c] or vn_impact[c] >= -threshold or total[k] == 0.0 or A_kk[k] <= 0.0:
            continue
        a, b = body_a[k], body_b[k]
        V_ab, M_ab = pair_velocity(a, b, V), pair_inverse_mass(a, b, M_inv)  # M^-1 J^T formed from J
        target = bounce_target(e[c], vn_impact[c], dvn_impact[c])
        d = (target - pair_row_velocity(k, J, V_ab)) / A_kk[k]
        new = max(total[k] + d, 0.0)
        d = new - total[k]
        total[k] = new
        V_ab = pair_row_impulse_of(k, J, M_ab, d, V_ab)
        top = mu[kt] * total[k]  # a smaller push shrinks the cone
        d = min(max(total[kt], -top), top) - total[kt]
        if d != 0.0:
            total[kt] += d
            V_ab = pair_row_impulse_of(kt, J, M_ab, d, V_ab)
        store_pair_velocity(a, b, V_ab, V)
