"""One tick in one call: ``World.step``'s stages inside one numba kernel.

The staged step (``World._step_in_stages``) calls one kernel per stage, with Python in
between: on a small scene those calls and that Python are most of the step
(benchmarks/STAGES.md). A responder whose whole solve is one kernel (``PGS`` in impulse
form, ``SoftStep``) gets a tick here instead: the same stage functions, called in the same
order on the same arrays, so every state after any number of steps is bit-identical to the
staged path's (tests/test_tick.py).

    begin_tick         undo copy, external forces, geometry (do last step's pairs still hold?)
    find_contacts      manifolds recycled or found; the order the responder visits them in
    build_rows         contact rows (warm started from the cache), joint rows
    pgs_tick / soft_tick   the responder's kernel, then ``end_tick``: the speed limits, the cache

The kernels read the world's arrays from one ``TickState`` (a numba structref: a call costs
~0.18 us per array argument, and the tick reads 85 arrays; the state is one argument). When a
body left its fat box the kernel sweeps for the pairs itself (``sweep_in_tick``). What stays in
Python (``World._step_in_one_call``): the sweep after the bodies or joints changed, growing
buffers (the kernel stops and says so), the report.

Double buffers: the contacts, the contact cache and the manifold keys come in two sides
(a leading axis of 2). A tick reads the side the last good step wrote and writes the
other; only a step that succeeds makes its side current, so a step that fails leaves the
last good step's contacts (read lazily) and caches as they were.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import numpy as np
from numba import config, njit, types
from numba.experimental import structref

from .collision.broadphase import find_pairs, update_geometry_in
from .collision.recycle import collide_recycling, has_room
from .collision.sort import stable_argsort
from .constraints.joints import start_joint_rows
from .constraints.order import colour_pairs, solve_order
from .constraints.rows import contact_row_map, contact_rows
from .contacts import impulses_to_contacts_and_cache
from .integrate import apply_external_forces, first_too_fast
from .pipeline.records import BodyRecord, JointRecord, RowRecord
from .responders.base import Responder
from .responders.pgs import PGS, pgs_step
from .responders.soft_step import SoftStep, soft_step_solve

OK = 0
NEED_SWEEP = 1  # a body left its fat box (or the bodies changed): sweep, then call again at stage 1
NEED_ROOM = 3  # the manifold store has no room for this step's new manifolds: make it, then call again at stage 1
TOO_FAST = 2  # a body ended the step past max_speed or not finite: undo and raise

BODY_FIELDS = (
    "x", "theta", "V", "M_inv", "kind", "radius", "vstart", "vcount", "local_v", "local_n", "static", "uid",
    "friction", "restitution",
)  # fmt: skip
GEOMETRY_FIELDS = ("world_v", "world_n", "aabb", "travel", "rotation", "fat", "pairs", "pair_order", "excluded")
STORE_FIELDS = (  # the manifold store (``ManifoldCache``), then the manifolds' keys and rows, two sides
    "found_pose", "found_rotation", "span", "m_anchor", "m_normal", "m_separation", "m_feature", "m_key", "m_row",
)  # fmt: skip
CACHE_FIELDS = ("cache_keys", "cache_lambda_n", "cache_lambda_t", "cache_pushed")  # two sides
CONTACT_FIELDS = (  # two sides
    "body_a", "body_b", "point", "normal", "separation", "feature", "key", "mu", "e", "anchor", "lambda_n",
    "lambda_t", "hit", "order",
)  # fmt: skip
ROW_FIELDS = (
    "pair_start", "normal_row", "friction_row", "row_a", "row_b", "J", "JM", "A_kk", "xi",
    "push", "bounce", "impact", "lo", "hi", "bound_row", "row_mu", "lam",
)  # fmt: skip
JOINT_FIELDS = ("joint_kind", "joint_i", "joint_j", "joint_local_i", "joint_local_j", "joint_params",
                "joint_row_offset", "joint_lam")  # fmt: skip
TICK_FIELDS = (
    BODY_FIELDS + GEOMETRY_FIELDS + STORE_FIELDS + CACHE_FIELDS + CONTACT_FIELDS + ROW_FIELDS + JOINT_FIELDS
    + ("x0", "theta0", "V1", "residuals")
)  # fmt: skip

if config.DISABLE_JIT:  # type: ignore[attr-defined]  # plain Python: a plain object, so a debugger steps through the kernels below

    class TickState:
        """The world's arrays as the one-call tick reads them (fields: ``TICK_FIELDS``)."""

        def __init__(self, *arrays: np.ndarray) -> None:
            for name, a in zip(TICK_FIELDS, arrays, strict=True):
                setattr(self, name, a)

else:

    @structref.register
    class TickStateType(types.StructRef):
        def preprocess_fields(self, fields):
            return tuple((name, types.unliteral(typ)) for name, typ in fields)

    class TickState(structref.StructRefProxy):  # type: ignore[no-redef]
        """The world's arrays as the one-call tick reads them (fields: ``TICK_FIELDS``): one
        kernel argument. Made by ``make_tick_state`` (compiled once and cached)."""

    structref.define_proxy(TickState, TickStateType, TICK_FIELDS)


@njit(cache=True)
def make_tick_state(bodies, geometry, store, cache, contacts, rows, joints, rest):
    """A ``TickState`` of the groups of arrays (each a tuple, in the order of its ``*_FIELDS``)."""
    x, theta, V, M_inv, kind, radius, vstart, vcount, local_v, local_n, static, uid, friction, restitution = bodies
    world_v, world_n, aabb, travel, rotation, fat, pairs, pair_order, excluded = geometry
    found_pose, found_rotation, span, m_anchor, m_normal, m_separation, m_feature, m_key, m_row = store
    cache_keys, cache_lambda_n, cache_lambda_t, cache_pushed = cache
    body_a, body_b, point, normal, separation, feature, key, mu, e, anchor, lambda_n, lambda_t, hit, order = contacts
    pair_start, normal_row, friction_row, row_a, row_b, J, JM, A_kk, xi = rows[:9]
    push, bounce, impact, lo, hi, bound_row, row_mu, lam = rows[9:]
    joint_kind, joint_i, joint_j, joint_local_i, joint_local_j, joint_params, joint_row_offset, joint_lam = joints
    x0, theta0, V1, residuals = rest
    return TickState(
        x, theta, V, M_inv, kind, radius, vstart, vcount, local_v, local_n, static, uid, friction, restitution,
        world_v, world_n, aabb, travel, rotation, fat, pairs, pair_order, excluded,
        found_pose, found_rotation, span, m_anchor, m_normal, m_separation, m_feature, m_key, m_row,
        cache_keys, cache_lambda_n, cache_lambda_t, cache_pushed,
        body_a, body_b, point, normal, separation, feature, key, mu, e, anchor, lambda_n, lambda_t, hit, order,
        pair_start, normal_row, friction_row, row_a, row_b, J, JM, A_kk, xi,
        push, bounce, impact, lo, hi, bound_row, row_mu, lam,
        joint_kind, joint_i, joint_j, joint_local_i, joint_local_j, joint_params, joint_row_offset, joint_lam,
        x0, theta0, V1, residuals,
    )  # fmt: skip


class TickBuffers:
    """What the one-call tick writes, sized for ``pairs`` broadphase pairs (2 points each) and
    ``joint_rows`` joint rows; kept by the world from step to step, grown when short.
    Attributes are named as in ``TICK_FIELDS``; the two-sided ones have a leading axis of 2."""

    def __init__(self, pairs: int, joint_rows: int) -> None:
        self.pairs, self.joint_rows = pairs, joint_rows
        cap = 2 * pairs  # contact points
        self.pair_order = np.zeros(pairs, np.int32)
        self.m_key, self.m_row = np.zeros((2, pairs), np.int64), np.zeros((2, pairs), np.int64)
        self.cache_keys, self.cache_pushed = np.zeros((2, cap), np.int64), np.zeros((2, cap), np.bool_)
        self.cache_lambda_n, self.cache_lambda_t = np.zeros((2, cap)), np.zeros((2, cap))
        self.body_a, self.body_b = np.zeros((2, cap), np.int32), np.zeros((2, cap), np.int32)
        self.point, self.normal, self.anchor = np.zeros((2, cap, 2)), np.zeros((2, cap, 2)), np.zeros((2, cap, 4))
        self.separation, self.mu, self.e = np.zeros((2, cap)), np.zeros((2, cap)), np.zeros((2, cap))
        self.feature, self.key = np.zeros((2, cap), np.int32), np.zeros((2, cap), np.int64)
        self.lambda_n, self.lambda_t, self.hit = np.zeros((2, cap)), np.zeros((2, cap)), np.zeros((2, cap), np.bool_)
        self.order = np.zeros((2, cap + 2), np.int32)  # two spare slots: ``solve_order``
        n_rows = 2 * cap + joint_rows
        self.pair_start = np.zeros(pairs + 1, np.int64)
        self.normal_row, self.friction_row, _ = contact_row_map(cap)
        self.row_a, self.row_b = np.zeros(n_rows, np.int32), np.zeros(n_rows, np.int32)
        self.J, self.JM = np.zeros((n_rows, 6)), np.zeros((n_rows, 6))
        self.A_kk, self.xi, self.push, self.bounce = (np.zeros(n_rows) for _ in range(4))
        self.lo, self.hi, self.row_mu, self.lam = (np.zeros(n_rows) for _ in range(4))
        self.impact, self.bound_row = np.zeros(n_rows, np.bool_), np.full(n_rows, -1, np.int32)
        self.joint_lam = np.zeros(joint_rows)
        self.side = 0  # the side the last good step wrote
        self._forget_views()

    def _forget_views(self) -> None:
        self.held: tuple = (-1, -1, (), (), ())  # ``caches_of(side, ...)`` as the world's caches hold it
        self._kept: list[tuple] = [self.held, self.held]
        self.coloured: np.ndarray | None = None  # the pair order copied into pair_order

    def __getstate__(self) -> dict:
        """A copy (pickle, deepcopy) without the kept views: copied, they would be arrays of their own."""
        state = self.__dict__.copy()
        copy = object.__new__(TickBuffers)
        copy._forget_views()
        state.update(held=copy.held, _kept=copy._kept, coloured=None)
        return state

    def holds(self, pairs: int, joint_rows: int) -> bool:
        """Whether these buffers have room for a step of ``pairs`` pairs and ``joint_rows`` joint rows."""
        return pairs <= self.pairs and joint_rows <= self.joint_rows

    def caches_of(self, side: int, manifolds: int, contacts: int) -> tuple:
        """(manifolds, contacts, then views of side ``side``: the manifolds' keys and rows, the
        contact cache's keys, lambda_n, lambda_t and pushed, the solve order), kept while the
        counts hold: a resting pile keeps them step after step (a view costs ~0.2 us to make)."""
        kept = self._kept[side]
        if kept[0] != manifolds or kept[1] != contacts:
            kept = self._kept[side] = (
                manifolds, contacts, self.m_key[side][:manifolds], self.m_row[side][:manifolds],
                self.cache_keys[side][:contacts], self.cache_lambda_n[side][:contacts],
                self.cache_lambda_t[side][:contacts], self.cache_pushed[side][:contacts],
                self.order[side][:contacts],
            )  # fmt: skip
        return kept

    def group(self, fields: tuple[str, ...]) -> tuple[np.ndarray, ...]:
        return tuple(getattr(self, name) for name in fields)


@njit(cache=True)
def begin_tick(s, gravity, dt, margin):
    """Keep the state to undo (x0, theta0; V1 is also the velocity the tick began with), add
    the external forces to V, and update the geometry; returns whether last step's pairs
    still hold (every tight box inside its fat box)."""
    for b in range(s.x.shape[0]):  # loops, not slice copies: those compile a shape check with its message
        s.x0[b, 0], s.x0[b, 1], s.theta0[b] = s.x[b, 0], s.x[b, 1], s.theta[b]
        s.V1[b, 0], s.V1[b, 1], s.V1[b, 2] = s.V[b, 0], s.V[b, 1], s.V[b, 2]
    apply_external_forces(s.V, s.M_inv, gravity, dt)
    return update_geometry_in(
        s.x, s.theta, s.kind, s.radius, s.vstart, s.vcount, s.local_v, s.local_n, s.V, dt, margin,
        s.world_v, s.world_n, s.aabb, s.travel, s.rotation, s.fat,
    )  # fmt: skip


@njit(cache=True)
def sweep_in_tick(s, colour_order):
    """The broadphase's pairs anew in the state's buffers (``find_pairs``, as ``World._sweep``
    does), coloured (``pair_order``) when the responder visits them by colour.
    Returns their count, or -1 when they would not fit the pair buffer or the tick's buffers:
    then the world grows them and sweeps (NEED_SWEEP)."""
    n_pairs = find_pairs(s.aabb, s.fat, s.static, s.excluded, s.pairs)
    if n_pairs < 0 or n_pairs > s.pair_order.shape[0]:
        return -1
    if colour_order:
        coloured = colour_pairs(s.pairs, n_pairs, s.static, s.x.shape[0])
        for p in range(n_pairs):
            s.pair_order[p] = coloured[p]
    return n_pairs


@njit(cache=True)
def find_contacts(s, side, n_pairs, colour_order, n_cached, rows_used, points_used, margin, recycle_distance):
    """The step's contact points into side 1 - side (``collide_recycling``: recycled manifolds or
    new ones), this step's manifolds sorted by key for the next step's look-up, and the solve
    order: by colour (``pair_order``) or pair order. Returns (K, manifolds, recycled,
    rows_used, points_used)."""
    w = 1 - side
    new_key, new_row = s.m_key[w], s.m_row[w]
    k, n_new, recycled, rows_used, points_used, ascends = collide_recycling(
        s.pairs, n_pairs, s.x, s.rotation, s.kind, s.radius, s.vstart, s.vcount, s.local_v, s.static,
        s.world_v, s.world_n, margin, s.travel, s.uid, s.friction, s.restitution, recycle_distance,
        s.m_key[side][:n_cached], s.m_row[side][:n_cached], s.found_pose, s.found_rotation, s.span, s.m_anchor,
        s.m_normal, s.m_separation, s.m_feature, rows_used, points_used,
        s.body_a[w], s.body_b[w], s.point[w], s.normal[w], s.separation[w], s.feature[w], s.key[w], s.mu[w],
        s.e[w], s.anchor[w], s.pair_start, new_key, new_row,
    )  # fmt: skip
    if not ascends:  # pairs come sorted by (a, b), so their keys ascend; if not, sort for the look-up
        by_key = stable_argsort(new_key[:n_new])
        keys, rows = new_key[:n_new].copy(), new_row[:n_new].copy()
        for i in range(n_new):
            new_key[i], new_row[i] = keys[by_key[i]], rows[by_key[i]]
    order = s.order[w]
    if colour_order:
        visit = solve_order(s.pair_order[:n_pairs], s.pair_start[: n_pairs + 1])
        for q in range(k):
            order[q] = visit[q]
    else:
        for q in range(k):
            order[q] = q
    return k, n_new, recycled, rows_used, points_used


@njit(cache=True)
def build_rows(s, side, k, k_cached, dt, gravity_norm, row_settings):
    """The contacts' rows (``contact_rows``: row pair q is contact order[q]) and then the joints'
    (``start_joint_rows``), warm started from the caches when ``warm_start``. Returns (deepest
    overlap in m, contacts warm started)."""
    beta, slop, push_max, restitution_threshold, friction_model, found_arms, warm_start = row_settings
    w = 1 - side
    first = 2 * k  # the first joint row
    n = first + s.joint_lam.shape[0]  # the step's rows
    deepest, hits = contact_rows(
        s.order[w][:k], s.normal_row[:k], s.friction_row[:k], s.body_a[w][:k], s.body_b[w][:k], s.point[w][:k],
        s.anchor[w][:k], found_arms, s.normal[w][:k], s.separation[w][:k], s.mu[w][:k], s.e[w][:k],
        s.x, s.V1, s.V, s.M_inv, dt, beta, slop, push_max, restitution_threshold, friction_model, gravity_norm,
        warm_start, s.cache_keys[side][:k_cached], s.cache_lambda_n[side][:k_cached],
        s.cache_lambda_t[side][:k_cached], s.cache_pushed[side][:k_cached], s.key[w][:k], s.uid, s.static,
        s.row_a[:n], s.row_b[:n], s.J[:n], s.JM[:n], s.A_kk[:n], s.xi[:n], s.push[:n], s.bounce[:n],
        s.impact[:n], s.lo[:n], s.hi[:n], s.bound_row[:n], s.row_mu[:n], s.lam[:n], s.hit[w][:k],
    )  # fmt: skip
    if s.joint_kind.shape[0] > 0:  # (a switch by argument type would compile the tick twice)
        joints = JointRecord(
            s.joint_kind, s.joint_i, s.joint_j, s.joint_local_i, s.joint_local_j, s.joint_params, s.joint_row_offset,
            s.joint_lam,
        )  # fmt: skip
        rows = RowRecord(
            s.normal_row[:k], s.friction_row[:k], s.row_a[:n], s.row_b[:n], s.J[:n], s.JM[:n], s.A_kk[:n], s.xi[:n],
            s.push[:n], s.bounce[:n], s.impact[:n], s.lo[:n], s.hi[:n], s.bound_row[:n], s.row_mu[:n], s.lam[:n],
        )  # fmt: skip
        bodies = BodyRecord(s.x, s.theta, s.V, s.M_inv, s.V1)
        start_joint_rows(joints, first, bodies, dt, beta, warm_start, rows)
    return deepest, hits


@njit(cache=True)
def contacts_and_rows(s, stage, side, found, cached, world, row_settings):
    """The tick up to the responder. Stage 0: ``begin_tick``; when a body left its fat box, the
    pairs anew (``sweep_in_tick``), or NEED_SWEEP when the bodies or joints changed or the pairs
    outgrow the buffers (the world sweeps). Then (stage 1 joins here after the world's sweep)
    NEED_ROOM when the manifold store is short of room for a new manifold per pair, else
    ``find_contacts`` and ``build_rows``.

    found: (n_pairs, colour_order, sweep_again); cached: (manifolds, contacts, rows_used,
    points_used) of the side last written; world: (gravity, |g|, dt, contact_margin,
    recycle_distance). Returns (status, K, manifolds, recycled, rows_used, points_used,
    warm-started contacts, deepest overlap m, the pairs' count when this call swept, else -1).
    """
    n_pairs, colour_order, sweep_again = found
    n_cached, k_cached, rows_used, points_used = cached
    gravity, gravity_norm, dt, margin, recycle_distance = world
    swept = -1
    if stage == 0:
        fits = begin_tick(s, gravity, dt, margin)
        if not fits and not sweep_again:
            swept = sweep_in_tick(s, colour_order)
            n_pairs = swept
        if sweep_again or n_pairs < 0:  # (n_pairs < 0: the buffers had no room for the kernel's sweep)
            return NEED_SWEEP, 0, 0, 0, rows_used, points_used, 0, 0.0, -1
    if not has_room(s.found_pose.shape[0], rows_used, s.m_anchor.shape[0], points_used, n_pairs):
        return NEED_ROOM, 0, 0, 0, rows_used, points_used, 0, 0.0, swept  # (``ManifoldCache.make_room``)
    k, n_new, recycled, rows_used, points_used = find_contacts(
        s, side, n_pairs, colour_order, n_cached, rows_used, points_used, margin, recycle_distance
    )
    deepest, hits = build_rows(s, side, k, k_cached, dt, gravity_norm, row_settings)
    return OK, k, n_new, recycled, rows_used, points_used, hits, deepest, swept


@njit(cache=True)
def end_tick(s, side, k, max_speed):
    """After the responder: TOO_FAST if a body ended past max_speed or not finite (nothing
    cached: the world undoes the step), else the impulses per contact (N s, contact order)
    and the contact cache the next step warm starts from (``ContactCache.store_rows``)."""
    if first_too_fast(s.V, s.x, s.theta, max_speed) >= 0:
        return TOO_FAST
    w = 1 - side
    n = 2 * k + s.joint_lam.shape[0]
    for c in range(k):
        s.cache_keys[w, c] = s.key[w, c]
    impulses_to_contacts_and_cache(
        s.order[w][:k], s.normal_row[:k], s.friction_row[:k], s.lam[:n], s.impact[:n], s.lambda_n[w][:k],
        s.lambda_t[w][:k], s.cache_lambda_n[w][:k], s.cache_lambda_t[w][:k], s.cache_pushed[w][:k],
    )  # fmt: skip
    return OK


@njit(cache=True)
def pgs_tick(s, stage, side, found, cached, world, row_settings, max_speed, iterations, tolerance, block, split):
    """One tick under ``PGS`` (impulse form): ``contacts_and_rows``, ``pgs_step``, ``end_tick``.
    Returns (status, K, manifolds, recycled, rows_used, points_used, warm-started contacts,
    deepest overlap m, sweeps, the pairs' count when it swept them, else -1)."""
    status, k, n_new, recycled, rows_used, points_used, hits, deepest, swept = contacts_and_rows(
        s, stage, side, found, cached, world, row_settings
    )
    if status != OK:
        return status, k, n_new, recycled, rows_used, points_used, hits, deepest, 0, swept
    w, n = 1 - side, 2 * k + s.joint_lam.shape[0]
    sweeps = pgs_step(
        s.normal_row[:k], s.friction_row[:k], 2 * k, s.row_a[:n], s.row_b[:n], s.J[:n], s.JM[:n], s.A_kk[:n],
        s.xi[:n], s.push[:n], s.bounce[:n], s.lo[:n], s.hi[:n], s.bound_row[:n], s.row_mu[:n], s.lam[:n],
        s.x, s.theta, s.V, s.separation[w][:k], world[2], iterations, tolerance, block, split, s.residuals,
    )  # fmt: skip
    status = end_tick(s, side, k, max_speed)
    return status, k, n_new, recycled, rows_used, points_used, hits, deepest, sweeps, swept


@njit(cache=True)
def soft_tick(s, stage, side, found, cached, world, row_settings, max_speed, settings):
    """One tick under ``SoftStep``: ``contacts_and_rows``, ``soft_step_solve``, ``end_tick``.
    settings: a ``SoftSettings``. Returns as ``pgs_tick`` (the count is sub-steps)."""
    status, k, n_new, recycled, rows_used, points_used, hits, deepest, swept = contacts_and_rows(
        s, stage, side, found, cached, world, row_settings
    )
    if status != OK:
        return status, k, n_new, recycled, rows_used, points_used, hits, deepest, 0, swept
    w, n = 1 - side, 2 * k + s.joint_lam.shape[0]
    bodies = BodyRecord(s.x, s.theta, s.V, s.M_inv, s.V1)
    rows = RowRecord(
        s.normal_row[:k], s.friction_row[:k], s.row_a[:n], s.row_b[:n], s.J[:n], s.JM[:n], s.A_kk[:n], s.xi[:n],
        s.push[:n], s.bounce[:n], s.impact[:n], s.lo[:n], s.hi[:n], s.bound_row[:n], s.row_mu[:n], s.lam[:n],
    )  # fmt: skip
    contacts = (s.order[w][:k], s.separation[w][:k], s.e[w][:k], s.anchor[w][:k])
    joints = JointRecord(
        s.joint_kind, s.joint_i, s.joint_j, s.joint_local_i, s.joint_local_j, s.joint_params, s.joint_row_offset,
        s.joint_lam,
    )  # fmt: skip
    count = soft_step_solve(bodies, rows, contacts, joints, world[2], settings, s.residuals)
    status = end_tick(s, side, k, max_speed)
    return status, k, n_new, recycled, rows_used, points_used, hits, deepest, count, swept


def compiled_for(kernel: Callable, args: tuple) -> Callable:
    """The machine code ``kernel`` compiled for the types of ``args``, callable from Python
    without numba's dispatch, or ``kernel`` itself when there is none (not compiled for them,
    or NUMBA_DISABLE_JIT). A dispatcher works out every argument's type on every call to pick
    its code: for the tick's ten arguments ~1.4 us of a ~2.1 us call, the TickState's type
    through Python. A world keeps it per spec (settings) and TickState type (arrays): nothing
    else in the arguments can change type (``World`` makes its scalars floats and ints)."""
    overloads = getattr(kernel, "overloads", None)
    if overloads is None:  # NUMBA_DISABLE_JIT: the plain function
        return kernel
    compiled = overloads.get(tuple(kernel.typeof_pyval(a) for a in args))  # type: ignore[attr-defined]
    return kernel if compiled is None else compiled.entry_point


def tick_state_type(state: TickState) -> object:
    """A TickState's numba type (None for the plain object of NUMBA_DISABLE_JIT): with the
    spec, what fixes the types of a one-call tick's arguments."""
    return getattr(state, "_numba_type_", None)


class TickSpec(NamedTuple):
    """How the world runs a responder's one-call tick: read once, kept until a setting changes."""

    kernel: Callable
    settings: tuple  # the kernel's arguments after max_speed
    n_residuals: int  # sweeps (or sub-steps) it may make
    row_settings: tuple  # beta, slop, push_max, restitution_threshold, friction_model, found_lever_arms, warm_start
    name: str
    counts: str
    colour_order: bool


def tick_for(responder: Responder) -> TickSpec | None:
    """The one-call tick of a responder, or None when it has none: a responder of another kind,
    PGS in matrix form, or one whose ``respond`` is its own (the world then runs the stages
    one call each). Kept on the responder, which drops it when a setting changes
    (``Responder.__setattr__``), so the settings are read once, not every step."""
    spec = responder.__dict__.get("_tick_spec", False)
    if spec is False:
        spec = responder.__dict__["_tick_spec"] = _tick_spec(responder)
    return spec


def _tick_spec(r: Responder) -> TickSpec | None:
    if "respond" in r.__dict__:  # replaced on the instance (a test's spy, say): call it, stage by stage
        return None
    kernel: Callable
    settings: tuple
    if isinstance(r, PGS) and type(r).respond is PGS.respond and r.form == "impulse":
        tol = -1.0 if r.tolerance is None else r.tolerance
        kernel, settings, n = pgs_tick, (r.iterations, tol, True if r.block else None, r.split), r.iterations
    elif isinstance(r, SoftStep) and type(r).respond is SoftStep.respond:
        kernel, settings, n = soft_tick, (r.settings(),), r.substeps
    else:
        return None
    row_settings = (
        r.beta, r.slop, r.push_max, r.restitution_threshold, r.friction_model, r.found_lever_arms, r.warm_start
    )  # fmt: skip
    return TickSpec(kernel, settings, n, row_settings, r.name, r.counts, r.colour_order)
