"""The soft step's contact points over a tick (``responders.soft_step``): gathered once, their
separation followed from the bodies' motion, their approach kept until they meet their
partner, and the bounce of those that met it fast.

Each sweep of the contacts that follows a move of the bodies works out each point's
separation C from how far its bodies have moved since the tick began (x - x0 and their
turns, with n and the lever arms' products read from the point's rows, ``separation_now``),
so no new collision detection is needed within the tick. A point not yet met reads its
approach J V from the bodies' velocities as the sweep began (``Points.V_sweep``), only
when it pushes.
"""

from __future__ import annotations

import numpy as np
from numba import config, types
from numba.experimental import structref

from ..constraints.rows import (
    MET,
    approach_at_impact,
    bounce_target,
    clamp_accumulated,
    pair_inverse_mass,
    pair_row_impulse_of,
    pair_row_velocity,
    pair_velocity,
    row_velocity,
    store_pair_velocity,
)
from ..jit import njit

POINT_FIELDS = ("C0", "e", "C", "moved", "V_sweep", "pending", "impacted", "vn_impact", "dvn_impact", "landed")
_POINTS_DOC = """The tick's contact points, in row order (point c owns rows normal_row[c] and friction_row[c]):
    as found, its separation C0 (m) and restitution e; within a sub-step its separation C now
    (m); what the points read of their bodies: moved (per body: dx, dy (m), cos dtheta - 1 and
    sin dtheta since the tick began, what C follows) and V_sweep (per body: V as
    the sweep began, before its forces and warm start: J V_sweep is the approach of a point not
    yet met, the landing's friction target); the points not yet met (pending, in order) and, once
    met, their approach at impact (vn_impact, m/s, and dvn_impact, the forces' share of the
    sub-step); landed: met its partner fast in this sub-step."""

if config.DISABLE_JIT:  # type: ignore[attr-defined]  # plain Python: a plain object, as the records are

    class Points:
        __doc__ = _POINTS_DOC
        fields = POINT_FIELDS

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
        fields = POINT_FIELDS

    structref.define_proxy(Points, PointsType, POINT_FIELDS)


@njit(cache=True)
def separation_now(c, k, kt, a, b, C0, J, moved):
    """Current separation of point c (m) from its bodies' motion since the tick began: C0 plus
    how far its anchors have moved apart along the normal n.

    moved[body] = (dx, dy, cos dtheta - 1, sin dtheta): an anchor r has moved by d + (R - I) r,
    whose part along n is n.d + (cos dtheta - 1) n.r + sin dtheta (r x n). The point's rows
    hold what that needs (``constraints.rows.jacobian``): its normal row k, J_k = [-n, -(r_a x n)
    | n, r_b x n], and its friction row kt, along t = (-n_y, n_x), J_kt = [., -(n.r_a) | ., n.r_b].
    """
    nx, ny = J[k, 3], J[k, 4]
    along_n = nx * (moved[b, 0] - moved[a, 0]) + ny * (moved[b, 1] - moved[a, 1])
    turned_b = moved[b, 2] * J[kt, 5] + moved[b, 3] * J[k, 5]  # n.(R - I) r_b
    turned_a = moved[a, 2] * J[kt, 2] + moved[a, 3] * J[k, 2]  # -n.(R - I) r_a
    return C0[c] + along_n + (turned_b + turned_a)


@njit(cache=True)
def note_sweep_start(points, V):
    """V_sweep = V (m/s, rad/s) as a sweep begins: the approach of the points not yet met. (A
    loop: numba copies ``V_sweep[:, :] = V`` element by element, checking for broadcasting.)"""
    V_sweep = points.V_sweep
    for b in range(V.shape[0]):
        for c in range(3):
            V_sweep[b, c] = V[b, c]


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
def gather_contacts(order, separation, restitution):
    """What the tick reads of each contact, in row order (row pair q is contact order[q]):
    its separation C0 (m) and restitution e. One pass, at prepare; the normal and the lever
    arms are read from the contact's rows (``separation_now``)."""
    n = order.shape[0]
    C0, e = np.empty(n), np.empty(n)
    gather_contacts_of(0, n, (order, separation, restitution), (C0, e))
    return C0, e


@njit(cache=True)
def gather_contacts_of(first, last, found, gathered):
    """``gather_contacts`` of row pairs first up to last: found = (order, separation, e) into
    gathered = (C0, e)."""
    order, separation, restitution = found
    C0, e = gathered
    for q in range(first, last):
        c = order[q]
        C0[q] = separation[c]
        e[q] = restitution[c]


@njit(cache=True)
def prepare_points(found, n_bodies):
    """The tick's ``Points`` of the step's contacts: C0 and e gathered into row order
    (``gather_contacts`` of found = (order, separation, e)), the rest to fill in."""
    C0, e = gather_contacts(found[0], found[1], found[2])
    return points_of(C0, e, n_bodies)


@njit(cache=True)
def points_of(C0, e, n_bodies):
    """``Points`` over the gathered C0 and e of n_bodies' contacts, the rest to fill in: the
    bodies have not moved yet (moved = (0, 0, cos 0 - 1, sin 0) = 0), so each point's C is its C0."""
    n_contacts = C0.shape[0]
    moved = np.zeros((n_bodies, 4))
    return Points(  # (np.empty: V_sweep and the approach at impact are written before they are read)
        C0, e, C0.copy(), moved, np.empty((n_bodies, 3)),
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
        d = clamp_accumulated(total, k, d, 0.0, np.inf)
        V_ab = pair_row_impulse_of(k, J, M_ab, d, V_ab)
        top = mu[kt] * total[k]  # a smaller push shrinks the cone
        d = min(max(total[kt], -top), top) - total[kt]
        if d != 0.0:
            total[kt] += d
            V_ab = pair_row_impulse_of(kt, J, M_ab, d, V_ab)
        store_pair_velocity(a, b, V_ab, V)
