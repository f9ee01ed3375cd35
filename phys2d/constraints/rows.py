"""Constraint rows: the lecture's J, one row per constraint, 6 non-zeros each.

A row k couples bodies a and b. Everything the responders need is stored per row:

    body_a, body_b  the two bodies (indices into the body arrays)
    J          (R, 6)  [J_a | J_b]: the row's only non-zero entries of the lecture's J
    JM         (R, 6)  M^-1 J^T for the same entries: the velocity change per unit lambda
    A_kk       (R,)    J_k M^-1 J_k^T, the diagonal of A = J M^-1 J^T
    xi         (R,)    the velocity J_k V2 must reach: -C/dt for a speculative contact point
                       (close the gap, no more), 0 for a touching one, a joint's 0 or motor speed
    push       (R,)    the row's Baumgarte push: a touching contact point's push-out speed, capped,
                       or a joint's -(beta/dt) C (0 elsewhere); PGS solves it in a pass of its
                       own (split impulses: a contact's never becomes velocity), or, as the
                       lecture does, adds it to xi
    impact     (R,)    True on the normal row of a contact point still apart that meets its
                       partner within the step faster than the restitution threshold: its
                       impulse is an event, not a load, and is not carried to the next step
    bounce     (R,)    the velocity J_k V a speculative contact point bounces to once it has
                       moved to its partner (the restitution pass), when it approaches faster
                       than the restitution threshold; 0 elsewhere (a touching point that
                       bounces has its bounce in xi)
    lo, hi     (R,)    fixed bounds on lambda_k
    bound_row  (R,)    for a Coulomb friction row: its normal row, whose current lambda
                       sets the bounds +-mu * lambda_n; -1 for rows with fixed bounds
    mu         (R,)    friction coefficient of a friction row
    lam        (R,)    lambda_k, impulses in N s: the warm start going in, the answer coming out

and the row map, the one place that says which rows belong to which contact:

    order         (K,)  contact order[q] is the q-th contact the responders visit
    normal_row    (K,)  the normal row of the q-th visited contact
    friction_row  (K,)  its friction row
    first_joint_row     joint rows run from here to the end

Rows are stored in the order the responders visit them (``Responder.visit_order``, see
``constraints.order``): contact by contact in pair order (the lecture's loop), part by part
(PGS: pair order within each part), or pair by pair in colour order (the soft step); the
joint rows come last. After a step, ``contacts.impulses_to_contacts_and_cache`` gives each
contact its lambda_n and lambda_t back in contact order.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import prange

from ..contacts import find_in_cache
from ..jit import njit
from ..pipeline.records import RowRecord

FRICTION_COULOMB = 0
FRICTION_LECTURE = 1

MET = 1e-6  # m: a contact point closer than this has met its partner (it touches, rounding aside:
# so the choice between "touching" and "still apart" never hangs on the last bit of a separation)


@njit(cache=True, inline="always")
def as_uint32(a):
    """An index array as uint32: a view of the same memory when it is int32 (the row map's and
    the bodies' dtype; indices are never negative, so the bits read the same), else a copy."""
    if a.itemsize == 4:
        return a.view(np.uint32)
    return a.astype(np.uint32)


@njit(cache=True, inline="always")
def unsigned_indices(normal_row, friction_row, body_a, body_b):
    """The row map and the bodies as uint32 (``as_uint32``), for a kernel's loops: numba then
    leaves out its fix-up for negative indices on every array access (benchmarks/HISTORY.md has
    what that saved)."""
    return as_uint32(normal_row), as_uint32(friction_row), as_uint32(body_a), as_uint32(body_b)


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


def contact_row_map(n_contacts: int) -> tuple[np.ndarray, np.ndarray, int]:
    """The row map: the q-th visited contact owns rows 2q (normal) and 2q + 1 (friction);
    joint rows follow the last contact's. Returns (normal_row, friction_row, first_joint_row)."""
    q = np.arange(n_contacts, dtype=np.int32)
    return 2 * q, 2 * q + 1, contact_row_count(n_contacts)


def contact_row_count(n_contacts: int) -> int:
    """How many rows n_contacts contacts own: the first joint row."""
    return 2 * n_contacts


class Rows:
    """The constraint rows of one step (arrays of length R) and the row map."""

    def __init__(self, n_rows: int) -> None:
        self.body_a = np.zeros(n_rows, np.int32)
        self.body_b = np.zeros(n_rows, np.int32)
        self.J = np.zeros((n_rows, 6))
        self.JM = np.zeros((n_rows, 6))
        self.A_kk = np.zeros(n_rows)
        self.xi = np.zeros(n_rows)
        self.push = np.zeros(n_rows)
        self.bounce = np.zeros(n_rows)
        self.impact = np.zeros(n_rows, np.bool_)
        self.lo = np.zeros(n_rows)
        self.hi = np.zeros(n_rows)
        self.bound_row = np.full(n_rows, -1, np.int32)
        self.mu = np.zeros(n_rows)
        self.lam = np.zeros(n_rows)
        self.map_contacts(np.zeros(0, np.int32))

    _ARRAYS = (
        "body_a",
        "body_b",
        "J",
        "JM",
        "A_kk",
        "xi",
        "push",
        "bounce",
        "impact",
        "lo",
        "hi",
        "bound_row",
        "mu",
        "lam",
    )

    def __len__(self) -> int:
        return int(self.lam.shape[0])

    def map_contacts(self, order: np.ndarray, row_map: tuple[np.ndarray, np.ndarray, int] | None = None) -> None:
        """Give the contacts, visited in ``order``, their rows (``contact_row_map``; ``row_map``:
        that map made for at least as many contacts, to be cut to length)."""
        self.order = order
        self.n_contacts = k = int(order.shape[0])
        if row_map is None:
            row_map = contact_row_map(k)
        self.normal_row, self.friction_row = row_map[0][:k], row_map[1][:k]
        self.first_joint_row = contact_row_count(k)

    def joint_impulses(self) -> np.ndarray:
        """lambda of the joint rows, in joint order (a copy)."""
        return self.lam[self.first_joint_row :].copy()

    @classmethod
    def view(cls, buffer: Rows, order: np.ndarray, n_rows: int) -> Rows:
        """The first n_rows rows of ``buffer`` as views (no copy), for the contacts visited in
        ``order`` (row pair q is contact order[q]) and then the joints."""
        rows = object.__new__(cls)
        for name in cls._ARRAYS:
            setattr(rows, name, getattr(buffer, name)[:n_rows])
        rows.map_contacts(order, (buffer.normal_row, buffer.friction_row, 0))
        return rows


@njit(cache=True, inline="always")
def jacobian(r_ax, r_ay, r_bx, r_by, dx, dy):
    """The six entries of a row for direction d at lever arms r_a, r_b: [-d, -(r_a x d) | d, r_b x d]."""
    return (-dx, -dy, -(r_ax * dy - r_ay * dx), dx, dy, r_bx * dy - r_by * dx)


@njit(cache=True, inline="always")
def store_row(k, j, M_inv_a, M_inv_b, J, JM, A_kk, with_JM=True):
    """Row k's J = j, JM = M^-1 J^T (unless not with_JM) and A_kk = J M^-1 J^T, from its entries
    and the two bodies' rows of M^-1 in hand."""
    A = 0.0
    for c in range(3):
        jm_a, jm_b = M_inv_a[c] * j[c], M_inv_b[c] * j[3 + c]
        J[k, c], J[k, 3 + c] = j[c], j[3 + c]
        if with_JM:
            JM[k, c], JM[k, 3 + c] = jm_a, jm_b
        A += j[c] * jm_a + j[3 + c] * jm_b
    A_kk[k] = A


@njit(cache=True, inline="always")
def fill_row(k, a, b, arms, dx, dy, M_inv, rows):
    """Row k of J for direction d acting at lever arms (r_a, r_b) = arms: [-d, -(r_a x d) | d, r_b x d]
    (``jacobian``), with its JM and A_kk (``store_row``)."""
    r_ax, r_ay, r_bx, r_by = arms
    M_inv_a, M_inv_b = (M_inv[a, 0], M_inv[a, 1], M_inv[a, 2]), (M_inv[b, 0], M_inv[b, 1], M_inv[b, 2])
    store_row(k, jacobian(r_ax, r_ay, r_bx, r_by, dx, dy), M_inv_a, M_inv_b, rows.J, rows.JM, rows.A_kk)


@njit(cache=True, inline="always")
def row_velocity(k, a, b, J, V):
    """J_k V: the row's relative velocity (m/s for contacts). Summed as a tree: where a sum waits
    for the last row's impulse (a sweep: ``pair_row_velocity``, the same tree), a tree waits
    three additions, not five."""
    return (
        (J[k, 0] * V[a, 0] + J[k, 1] * V[a, 1])
        + (J[k, 2] * V[a, 2] + J[k, 5] * V[b, 2])
        + (J[k, 3] * V[b, 0] + J[k, 4] * V[b, 1])
    )


@njit(cache=True, inline="always")
def clamp_accumulated(lam, k, delta, low, high):
    """The lecture's projection: lambda_k += delta with the accumulated impulse clamped into
    [low, high], not delta. Written as delta clamped into [low - lambda_k, high - lambda_k]: those
    bounds are known before delta is, so the velocity update that the next row waits on follows
    delta at once; lambda_k then moves by it, clamped again (rounding may not step past a bound).
    Returns the change applied (N s), what M^-1 J_k^T acts on. Every sweep's update, PGS's and
    the soft step's, is this one."""
    old = lam[k]
    applied = min(max(delta, low - old), high - old)
    lam[k] = min(max(old + applied, low), high)
    return applied


@njit(cache=True, inline="always")
def apply_row_impulse(k, a, b, JM, impulse, V):
    """V += M^-1 J_k^T impulse: what an impulse along row k does to bodies a and b."""
    for c in range(3):
        V[a, c] += JM[k, c] * impulse
        V[b, c] += JM[k, 3 + c] * impulse


@njit(cache=True)
def coupling(k, l, body_a, body_b, J, JM):
    """A_kl = J_k M^-1 J_l^T = J_k . (M^-1 J_l^T): nonzero only through a body rows k and l share."""
    a = 0.0
    for side_k in range(2):
        body_k = body_a[k] if side_k == 0 else body_b[k]
        for side_l in range(2):
            body_l = body_a[l] if side_l == 0 else body_b[l]
            if body_k == body_l:
                for c in range(3):
                    a += J[k, 3 * side_k + c] * JM[l, 3 * side_l + c]
    return a


@njit(cache=True, inline="always")
def pair_velocity(a, b, V):
    """V_ab = (v_a, omega_a, v_b, omega_b): the part of V that a row between bodies a and b
    multiplies, as a 6-tuple. Numba keeps a tuple in registers: a sweep holds the pair's
    velocities while its rows follow one another, instead of storing V and loading it back."""
    return (V[a, 0], V[a, 1], V[a, 2], V[b, 0], V[b, 1], V[b, 2])


@njit(cache=True, inline="always")
def store_pair_velocity(a, b, V_ab, V):
    """Write the pair's velocities V_ab (``pair_velocity``) back into V."""
    V[a, 0], V[a, 1], V[a, 2] = V_ab[0], V_ab[1], V_ab[2]
    V[b, 0], V[b, 1], V[b, 2] = V_ab[3], V_ab[4], V_ab[5]


@njit(cache=True, inline="always")
def pair_inverse_mass(a, b, M_inv):
    """M^-1 of the pair's six velocities (``pair_velocity``): (1/m_a, 1/m_a, 1/I_a, 1/m_b, 1/m_b,
    1/I_b), held in hand with V_ab so a sweep forms M^-1 J_k^T from J_k (``pair_row_impulse_of``)."""
    return (M_inv[a, 0], M_inv[a, 1], M_inv[a, 2], M_inv[b, 0], M_inv[b, 1], M_inv[b, 2])


@njit(cache=True, inline="always")
def pair_row_velocity(k, J, V_ab):
    """J_k V on the pair's velocities V_ab: ``row_velocity``, summed as the same tree."""
    return (
        (J[k, 0] * V_ab[0] + J[k, 1] * V_ab[1])
        + (J[k, 2] * V_ab[2] + J[k, 5] * V_ab[5])
        + (J[k, 3] * V_ab[3] + J[k, 4] * V_ab[4])
    )


@njit(cache=True, inline="always")
def pair_row_impulse_of(k, J, M_ab, impulse, V_ab):
    """V_ab + M^-1 J_k^T impulse with M^-1 J_k^T formed from J_k and the pair's M^-1 in hand
    (``pair_inverse_mass``): the products JM[k] holds, bit for bit, without reading JM. A sweep
    over rows too many for the cache reads half the bytes."""
    return (
        V_ab[0] + (M_ab[0] * J[k, 0]) * impulse,
        V_ab[1] + (M_ab[1] * J[k, 1]) * impulse,
        V_ab[2] + (M_ab[2] * J[k, 2]) * impulse,
        V_ab[3] + (M_ab[3] * J[k, 3]) * impulse,
        V_ab[4] + (M_ab[4] * J[k, 4]) * impulse,
        V_ab[5] + (M_ab[5] * J[k, 5]) * impulse,
    )


@njit(cache=True, inline="always")
def pair_row_impulse(k, JM, impulse, V_ab):
    """V_ab + M^-1 J_k^T impulse: ``apply_row_impulse`` on the pair's velocities in hand."""
    return (
        V_ab[0] + JM[k, 0] * impulse,
        V_ab[1] + JM[k, 1] * impulse,
        V_ab[2] + JM[k, 2] * impulse,
        V_ab[3] + JM[k, 3] * impulse,
        V_ab[4] + JM[k, 4] * impulse,
        V_ab[5] + JM[k, 5] * impulse,
    )


@njit(cache=True, inline="always")
def speculative_friction_target(C, vn, vt, dt):
    """xi of a friction row (m/s): friction acts only once its point touches. A touching point
    (C <= 0): 0, friction may stop it. A point still C > 0 apart that approaches at -vn closes
    its gap after t = C / -vn, a fraction C / (-vn dt) of the step: its tangential velocity vt
    may carry it that far and no further (so that it lands where it touches, and friction stops
    it from then on); one that does not close its gap within the step keeps vt."""
    if C <= 0.0:
        return 0.0
    if vn >= 0.0 or C >= -vn * dt:
        return vt
    return vt * (C / (-vn * dt))


@njit(cache=True, inline="always")
def speculative_target(C, dt):
    """xi of a normal row: a point still C > 0 apart may approach at C/dt (close the gap
    within the step, no more); a touching one may not approach at all (m/s)."""
    return -C / dt if C > 0.0 else 0.0


@njit(cache=True, inline="always")
def holds_position(k, lo, hi, bound_row):
    """Whether row k has a position to hold, so takes part in a split push pass: a contact's
    normal row or a joint's equality or limit row; not a motor row (both bounds finite: a
    speed to reach, no position), a friction row or a mouse row (its own soft solve)."""
    return bound_row[k] == -1 and not (lo[k] > -np.inf and hi[k] < np.inf)


@njit(cache=True)
def push_rows(normal_row, lo, hi, bound_row):
    """The rows a split push pass sweeps, in solve order (uint32, as a sweep's visit): the
    contact normal rows ``normal_row``, then the joint rows (after the contacts' 2K rows)
    that hold a position (``holds_position``)."""
    first_joint_row = 2 * normal_row.shape[0]
    n = normal_row.shape[0]
    for k in range(first_joint_row, lo.shape[0]):
        if holds_position(k, lo, hi, bound_row):
            n += 1
    visit = np.empty(n, np.uint32)
    for q in range(normal_row.shape[0]):
        visit[q] = normal_row[q]
    n = normal_row.shape[0]
    for k in range(first_joint_row, lo.shape[0]):
        if holds_position(k, lo, hi, bound_row):
            visit[n] = k
            n += 1
    return visit


@njit(cache=True, inline="always")
def baumgarte_push(C, beta_over_dt, slop, push_max):
    """The speed (m/s) at which to push out an overlap deeper than slop: (beta/dt) of the
    excess, never more than push_max (Box2D v3's contactPushMaxVelocity)."""
    return min(beta_over_dt * max(0.0, -(C + slop)), push_max)


@njit(cache=True, inline="always")
def approach_at_impact(C, vn_start, vn_forced, dt):
    """The normal velocity (m/s, negative when approaching) a point meets its partner with.

    Semi-implicit Euler's positions at the ends of steps lie on a path whose velocity is
    V minus half a step of the external forces: p0 = vn_start + dvn/2 as the step begins
    (dvn = vn_forced - vn_start, the forces' share of the step). A touching point (C <= MET)
    met its partner before the step: p0. A point C > MET apart meets it if the path closes C
    within the step (its end, C + dt vn_forced, is <= MET: a path that ends on the surface,
    as a symmetric flight does, meets it whatever the rounding), under the forces' constant
    acceleration a = dvn/dt, at -sqrt(p0^2 - 2 a C); else it does not meet it now: 0.
    """
    dvn = vn_forced - vn_start
    p0 = vn_start + 0.5 * dvn
    if C <= MET:
        return p0
    if C + dt * vn_forced > MET:
        return 0.0
    return -np.sqrt(max(p0 * p0 - 2.0 * (dvn / dt) * C, 0.0))


@njit(cache=True, inline="always")
def bounce_target(e, vn_impact, dvn):
    """The J V a point of restitution e leaves with when it met its partner at vn_impact (m/s):
    the path's velocity reversed e times, turned back into V (plus half the forces' share dvn).
    Then a ball dropped from h rises to e^2 h with no error of order dt; e = 0 does not bounce."""
    if e == 0.0:
        return 0.0
    return -e * vn_impact - 0.5 * dvn


@njit(cache=True)
def manifold_sizes(body_a, body_b):
    """How many points each contact's manifold has: the run of contacts on its pair of bodies
    (a pair's points are consecutive in contact order)."""
    k = body_a.shape[0]
    sizes = np.empty(k, np.int32)
    c = 0
    while c < k:
        end = c + 1
        while end < k and body_a[end] == body_a[c] and body_b[end] == body_b[c]:
            end += 1
        for q in range(c, end):
            sizes[q] = end - c
        c = end
    return sizes


class RowSettings(NamedTuple):
    """How the contact rows are built: the step, and the responder's settings."""

    dt: float  # s
    g: float  # |gravity|, m/s^2 (the lecture's friction bound)
    beta: float  # Baumgarte push factor
    slop: float  # m
    push_max: float  # m/s
    restitution_threshold: float  # m/s
    friction_model: int  # FRICTION_COULOMB or FRICTION_LECTURE
    found_arms: bool  # lever arms as each manifold was found (else p - x now)
    warm_start: bool  # lambda starts from the cache
    targets: bool  # write the lecture's targets and bounds (xi, push, bounce, lo, hi, bound_row) and JM


@njit(cache=True)
def contact_rows(bodies, shapes, cache, found, rows, settings, threads):
    """The normal and friction rows of contact point c = order[q] (docs/formulation.md), and
    their starting impulses.

    Normal:   xi = -C/dt for a speculative point still C > 0 apart (it may close the gap
              within the step, no more), 0 when touching; push = min(-(beta/dt) min(0, C + slop),
              push_max) when touching. A point whose approach speed at impact -vn exceeds the
              threshold bounces (``bounce_target``): a touching one at once, xi = max(xi, bounce),
              one still apart after the move to its partner (bounce, for the responder's
              restitution pass). lambda in [0, inf).
    Friction: t = (-n_y, n_x), xi = 0 when touching; a speculative point's friction acts only
              once it touches (``speculative_friction_target``); Coulomb bounds +-mu lambda_n of its normal row, or the
              lecture's fixed +-mu m_c g dt (lambda is an impulse, hence dt), with m_c
              the pair's reduced mass shared among the manifold's points (``manifold_sizes``).

    Lever arms (m): with ``found_arms``, anchor[c] = (r_a, r_b) as the point's manifold was
    found (a recycled one keeps them: Box2D v3's soft step); else p - x_a and p - x_b at the
    positions x now, so every impulse acts at one point of both bodies (angular momentum exact).

    Warm start (contact caching, with ``warm_start``): lam of both rows starts from the
    impulses (N s) cached under the contact's key last tick, cache_lambda_n[m] and
    cache_lambda_t[m] of cache entry m = cached[c] (``phys2d.contacts.find_in_cache``), or
    from 0 when it is new or its island lost a load; hit[c] says which. Without, from 0.

    Without ``settings.targets`` (the one-call tick of a responder that works out its own
    targets from C and its bounds from mu, ``Responder.reads_targets``) only the bodies, J,
    A_kk, mu, lam and impact are written: xi, push, bounce, lo, hi, bound_row and JM are not.

    Each contact's rows are its own (``contact_rows_of``): with ``threads`` a count, not None,
    they are built on that many threads, a slice of the contacts each (``contact_rows_in_slices``),
    as is the look-up in the cache, with the same results. Returns the deepest overlap,
    max(0, -min C) (m), and the number of contacts warm started.
    """
    K = rows.normal_row.shape[0]
    body_a, body_b = as_uint32(found.body_a[:K]), as_uint32(found.body_b[:K])
    normal_row, friction_row = as_uint32(rows.normal_row), as_uint32(rows.friction_row)
    indices = (as_uint32(found.order[:K]), normal_row, friction_row, body_a, body_b)  # (made here: see contact_rows_of)
    cached = np.empty(K, np.int64)
    hit = found.hit[:K]
    if settings.warm_start:
        cache_keys, _, _, cache_pushed = cache
        hits = find_in_cache(cache_keys, cache_pushed, found.key[:K], body_a, body_b, shapes.uid, shapes.static,
                             cached, hit, threads)  # fmt: skip
    else:
        cached[:] = -1
        hit[:] = False
        hits = 0
    coulomb = settings.friction_model == FRICTION_COULOMB
    points_in_manifold = np.empty(0, np.int32) if coulomb else manifold_sizes(body_a, body_b)  # the lecture's bound
    found_cache = (cache[1], cache[2], cached, points_in_manifold)
    if threads is None:
        return contact_rows_of(0, K, bodies, found, rows, settings, found_cache, indices), hits
    return contact_rows_in_slices(threads, bodies, found, rows, settings, found_cache, indices), hits


@njit(cache=True)
def contact_rows_of(first, last, bodies, found, rows, settings, found_cache, indices):
    """The rows of the contacts visited first up to last (``contact_rows``): each contact's normal
    and friction rows, written in its own slots. found_cache = (cache_lambda_n, cache_lambda_t,
    each contact's cache entry or -1, its manifold's point count for the lecture's friction bound);
    indices = (order, normal_row, friction_row, body_a, body_b) as uint32 (``as_uint32``), made
    by the caller: a view may raise, and numba keeps a reference count on every array a function
    with such a path reads. Returns the deepest overlap among them, max(0, -min C) (m)."""
    dt, beta, slop, push_max = settings.dt, settings.beta, settings.slop, settings.push_max
    order, normal_row, friction_row, body_a, body_b = indices
    x, V1, V, M_inv = bodies.x, bodies.V1, bodies.V, bodies.M_inv
    point, anchor, normal, separation = found.point, found.anchor, found.normal, found.separation
    mu, e = found.friction, found.restitution
    J, JM, A_kk, xi, push, bounce, impact = rows.J, rows.JM, rows.A_kk, rows.xi, rows.push, rows.bounce, rows.impact
    lo, hi, bound_row, out_mu, lam = rows.lo, rows.hi, rows.bound_row, rows.mu, rows.lam
    out_a, out_b = rows.body_a, rows.body_b
    cache_lambda_n, cache_lambda_t, cached, points_in_manifold = found_cache
    coulomb = settings.friction_model == FRICTION_COULOMB
    targets = settings.targets
    deepest = 0.0
    beta_over_dt = beta / dt
    for q in range(first, last):
        c = order[q]
        a, b = body_a[c], body_b[c]
        M_inv_a, M_inv_b = (M_inv[a, 0], M_inv[a, 1], M_inv[a, 2]), (M_inv[b, 0], M_inv[b, 1], M_inv[b, 2])
        C = separation[c]
        deepest = max(deepest, -C)
        nx, ny = normal[c, 0], normal[c, 1]
        if settings.found_arms:
            r_ax, r_ay, r_bx, r_by = anchor[c, 0], anchor[c, 1], anchor[c, 2], anchor[c, 3]
        else:
            r_ax, r_ay = point[c, 0] - x[a, 0], point[c, 1] - x[a, 1]
            r_bx, r_by = point[c, 0] - x[b, 0], point[c, 1] - x[b, 1]
        m = cached[c]
        k = normal_row[q]
        out_a[k] = a
        out_b[k] = b
        store_row(k, jacobian(r_ax, r_ay, r_bx, r_by, nx, ny), M_inv_a, M_inv_b, J, JM, A_kk, targets)
        vn_start, vn_forced = row_velocity(k, a, b, J, V1), row_velocity(k, a, b, J, V)
        vn = approach_at_impact(C, vn_start, vn_forced, dt)
        threshold = settings.restitution_threshold
        impact[k] = C > MET and vn < -threshold
        out_mu[k] = 0.0
        lam[k] = cache_lambda_n[m] if m >= 0 else 0.0
        if targets:
            xi_k = speculative_target(C, dt)
            bounce_k = 0.0
            if vn < -threshold:
                target = bounce_target(e[c], vn, vn_forced - vn_start)
                if C > MET:
                    bounce_k = target  # it meets its partner within the step: bounce once it has moved there
                else:
                    xi_k = max(xi_k, target)  # touching already: bounce now, as the lecture does
            xi[k] = xi_k
            push[k] = baumgarte_push(C, beta_over_dt, slop, push_max)
            bounce[k] = bounce_k
            lo[k] = 0.0
            hi[k] = np.inf
            bound_row[k] = -1
        k_n, k = k, friction_row[q]
        out_a[k] = a
        out_b[k] = b
        store_row(k, jacobian(r_ax, r_ay, r_bx, r_by, -ny, nx), M_inv_a, M_inv_b, J, JM, A_kk, targets)
        impact[k] = False
        out_mu[k] = mu[c]
        lam[k] = cache_lambda_t[m] if m >= 0 else 0.0
        if not targets:
            continue
        xi[k] = speculative_friction_target(C, vn_forced, row_velocity(k, a, b, J, V), dt)
        push[k] = 0.0
        bounce[k] = 0.0
        if coulomb:
            bound_row[k] = k_n
            lo[k] = -np.inf
            hi[k] = np.inf
        else:
            # the reduced mass of the pair: a static partner counts as infinitely heavy
            inv = M_inv_a[0] + M_inv_b[0]
            m_c = (1.0 / inv if inv > 0.0 else 0.0) / points_in_manifold[c]
            # fixed: it does not look at lambda_n, so it acts on speculative points too
            bound = mu[c] * m_c * settings.g * dt
            bound_row[k] = -1
            lo[k] = -bound
            hi[k] = bound
    return deepest


@njit(cache=True, parallel=True)
def contact_rows_in_slices(threads, bodies, found, rows, settings, found_cache, indices):
    """``contact_rows_of`` over all the contacts, a slice of them on each of ``threads`` threads
    (each contact writes its own rows: the same results as one call). Returns the deepest overlap (m)."""
    K = rows.normal_row.shape[0]
    deepest = np.empty(threads)  # per slice: no shared accumulator
    for t in prange(threads):
        deepest[t] = contact_rows_of(
            K * t // threads, K * (t + 1) // threads, bodies, found, rows, settings, found_cache, indices
        )
    overall = 0.0  # (a loop: numba would make deepest.max() a parallel loop, one more wait for the threads)
    for t in range(threads):
        overall = max(overall, deepest[t])
    return overall
