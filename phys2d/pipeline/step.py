"""The pipeline of one tick: the buffers it owns, and the step that runs its stages.

``World.step`` hands a step to its ``Pipeline``, which runs the stages in one of two ways,
with the same results bit for bit:

    in one call    a responder whose solve is a kernel (PGS in impulse form, SoftStep) gets
                   one compiled call: ``pipeline.tick.tick`` runs the stages in order
    stage by stage Python calls the same stage kernels in turn (``_in_stages``), and the
                   responder's ``respond`` in the place of the solve: the way to time the
                   stages, watch them in a debugger, or plug in a responder of your own
                   (``w.one_call_tick = False`` forces it)

Python's part either way: the sweep after the bodies or joints changed, growing the buffers
(the kernel stops and says so), the undo of a step that failed, and the report.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from ..collision.recycle import ManifoldStore, collide_recycling_on
from ..constraints.joints import start_joint_rows
from ..constraints.order import PAIR_ORDER, PART_ORDER, PARTS_FROM, order_pairs
from ..constraints.rows import Rows, RowSettings, contact_row_map, contact_rows
from ..contacts import FEATURE_BITS, UID_BITS, Contacts, impulses_to_contacts_and_cache
from ..integrate import first_too_fast
from ..responders.base import EMPTY, Responder, SolveResult, StepContext, StepReport
from ..responders.pgs import PGS
from ..responders.restitution import bounce_after_moving
from ..responders.soft_step import SoftStep
from ..shapes import POLYGON
from . import ahead, records
from .parallel import using_threads
from .stages import (
    BAD_STATE,
    NEED_ROOM,
    NEED_SWEEP,
    NOT_FINITE,
    TOO_FAST,
    Counts,
    StepSettings,
    begin,
    first_bad_body,
    head_of_rows,
    order_contacts,
    sweep,
)
from .tick import tick

if TYPE_CHECKING:
    from ..world import World


BOUNCE_SWEEPS = 10  # sweeps of the restitution pass the world makes for a responder that leaves it the move


class SimulationError(RuntimeError):
    """A step produced velocities past the world's limits; the world was left as before it."""


class TickSpec(NamedTuple):
    """What a step needs of its responder, read once and kept on the responder until one of its
    settings changes (``Responder.__setattr__`` drops it)."""

    one_call: bool  # its solve is a kernel: ``stages.tick`` runs the whole step in one call
    pgs: Any  # PGS's settings for the tick (``PGSSettings``), or None
    soft: Any  # the soft step's (``SoftSettings``), or None
    n_residuals: int  # sweeps (or sub-steps) it may make
    rows: tuple  # beta, slop, push_max, restitution_threshold, friction_model, found_lever_arms, warm_start
    name: str
    counts: str
    visit: int  # the order it visits the contacts in (``Responder.visit_order``)


class StepInputs(NamedTuple):
    """What a step reads of the world and its responder: read anew only when one of them changes
    (``Pipeline.settings_changed``, a new spec or dt)."""

    spec: TickSpec
    dt: float  # s
    step: StepSettings
    rows: RowSettings
    joints: Any  # the JointRecord, or None in a world without joints
    threads: int | None  # None on one thread: no parallel code is compiled
    joint_lam: np.ndarray  # the world's joint reactions (N s), in joint order


def spec_of(responder: Responder) -> TickSpec:
    """What a step needs of ``responder`` (``TickSpec``), kept on it until a setting changes."""
    spec = responder.__dict__.get("_tick_spec")
    if spec is None:
        spec = responder.__dict__["_tick_spec"] = _tick_spec(responder)
    return spec


def tick_for(responder: Responder) -> TickSpec | None:
    """The responder's spec when its steps run in one call, else None: a responder of another
    kind, PGS in matrix form, or one whose ``respond`` is its own (stage by stage)."""
    spec = spec_of(responder)
    return spec if spec.one_call else None


def _tick_spec(r: Responder) -> TickSpec:
    rows = (r.beta, r.slop, r.push_max, r.restitution_threshold, r.friction_model, r.found_lever_arms, r.warm_start)
    staged = TickSpec(False, None, None, 0, (*rows, True), r.name, r.counts, r.visit_order)  # respond: every field
    if "respond" in r.__dict__:  # replaced on the instance (a test's spy, say): call it, stage by stage
        return staged
    own = (*rows, r.reads_targets)  # the engine's own tick: the rows it reads, no more
    if isinstance(r, PGS) and type(r).respond is PGS.respond and r.form == "impulse":
        return staged._replace(one_call=True, rows=own, pgs=r.settings, n_residuals=r.iterations)
    if isinstance(r, SoftStep) and type(r).respond is SoftStep.respond:
        return staged._replace(one_call=True, rows=own, soft=r.settings, n_residuals=r.substeps)
    return staged


# per kind of tick (PGS or soft, its argument types): the child compiling it, once started
_BEHIND: dict[tuple, Any] = {}


def compiled_for(kernel: Callable, args: tuple) -> Callable:
    """The machine code ``kernel`` compiled for the types of ``args``, callable without numba's
    dispatch (which works out every argument's type on every call), or ``kernel`` itself when
    there is none (not compiled for them, or NUMBA_DISABLE_JIT)."""
    overloads = getattr(kernel, "overloads", None)
    if overloads is None:  # NUMBA_DISABLE_JIT: the plain function
        return kernel
    compiled = overloads.get(tuple(kernel.typeof_pyval(a) for a in args))  # type: ignore[attr-defined]
    return kernel if compiled is None else compiled.entry_point


# -- the buffers -----------------------------------------------------------------------------
class ContactBuffers:
    """One side of the contact buffers: the fields of a ``ContactRecord``, sized for ``pairs``
    broadphase pairs (2 points each)."""

    def __init__(self, pairs: int) -> None:
        cap = 2 * pairs
        self.body_a, self.body_b = np.zeros(cap, np.int32), np.zeros(cap, np.int32)
        self.point, self.normal, self.anchor = np.zeros((cap, 2)), np.zeros((cap, 2)), np.zeros((cap, 4))
        self.separation, self.friction, self.restitution = np.zeros(cap), np.zeros(cap), np.zeros(cap)
        self.feature, self.key = np.zeros(cap, np.int32), np.zeros(cap, np.int64)
        self.lambda_n, self.lambda_t, self.hit = np.zeros(cap), np.zeros(cap), np.zeros(cap, np.bool_)
        self.order = np.zeros(cap + 2, np.int32)  # two spare slots: ``solve_order``
        self.pair_start = np.zeros(pairs + 1, np.int64)
        self.cache_lambda_n, self.cache_lambda_t = np.zeros(cap), np.zeros(cap)
        self.cache_pushed = np.zeros(cap, np.bool_)
        self.manifold_key, self.manifold_row = np.zeros(pairs, np.int64), np.zeros(pairs, np.int64)

    def contacts(self, k: int) -> Contacts:
        """A copy of its first K contacts, as the world hands them out."""
        return Contacts(
            body_a=self.body_a[:k].copy(), body_b=self.body_b[:k].copy(), point=self.point[:k].copy(),
            anchor=self.anchor[:k].copy(), normal=self.normal[:k].copy(), separation=self.separation[:k].copy(),
            lambda_n=self.lambda_n[:k].copy(), lambda_t=self.lambda_t[:k].copy(), feature=self.feature[:k].copy(),
            key=self.key[:k].copy(), warm_started=self.hit[:k].copy(), friction=self.friction[:k].copy(),
            restitution=self.restitution[:k].copy(),
        )  # fmt: skip


class Buffers:
    """What a step writes, sized for ``pairs`` broadphase pairs and ``joint_rows`` joint rows:
    both sides of the contacts, the rows, and the pairs' colour order."""

    def __init__(self, pairs: int, joint_rows: int) -> None:
        self.pairs, self.joint_rows = pairs, joint_rows
        self.sides = (ContactBuffers(pairs), ContactBuffers(pairs))
        self.rows = Rows(4 * pairs + joint_rows)
        self.rows.normal_row, self.rows.friction_row, _ = contact_row_map(2 * pairs)
        self.pair_order = np.zeros(pairs, np.int32)

    def holds(self, pairs: int, joint_rows: int) -> bool:
        """Whether these buffers have room for ``pairs`` pairs and ``joint_rows`` joint rows."""
        return pairs <= self.pairs and joint_rows <= self.joint_rows


# -- the pipeline -----------------------------------------------------------------------------
class Pipeline:
    """The buffers of a world's steps and the step that fills them (``step``).

    It reads the world's bodies, joints and settings, and keeps what one step hands to the
    next: the broadphase's pairs, the manifold store, the contact cache (the side of the
    buffers the last good step wrote) and the joints' reactions.
    """

    def __init__(self) -> None:
        self.store = ManifoldStore()
        self.buffers = Buffers(0, 0)
        self.side = 0  # the side of the buffers the last good step wrote
        self.manifolds = 0  # the manifolds it cached (side's manifold_key, manifold_row)
        self.cached = 0  # its contacts (side's key and cache_*: the cache)
        self.pairs = np.zeros((64, 2), np.int32)
        self.n_pairs = 0
        self.ordered = PAIR_ORDER  # the visit order pair_order holds for these pairs (PAIR_ORDER: none)
        self.part = np.zeros(0, np.int32)  # each body's part of that order (``constraints.order.partition``)
        self.sweep_again = True  # the bodies or joints changed: the pairs must be found anew
        self.geometry: tuple = ()  # world_v, world_n, aabb, travel, rotation, fat
        self.undo = (np.zeros((0, 2)), np.zeros(0), np.zeros((0, 3)))  # x, theta, V1 to undo a failed step
        self.residuals = np.zeros(16)
        self._state: Any = None  # the StepState over all of the above, made anew when one is replaced
        self._records: list = []  # the records it holds: bodies, shapes, store, sides, rows
        self._state_over: Any = None  # the bodies' x it was made with (x is replaced when bodies are)
        self._compiled: tuple = (None, None, None)  # (inputs, state, machine code) of the last call
        self._compiled_types: tuple = ()  # the types of the arguments it was compiled for
        self._ready: StepInputs | None = None  # what the last step read of the world
        self.sleep_masks: tuple | None = None  # (static, M_inv) with the sleeping bodies immovable, or None
        self.rounded: bool | None = None  # True with capsules, segments or chains (the tick's last argument)

    def __getstate__(self) -> dict:
        """A copy (pickle, deepcopy) leaves out the records: numba structrefs, made anew when needed."""
        state = self.__dict__.copy()
        state.update(_state=None, _records=[], _state_over=None, _compiled=(None, None, None), _ready=None)
        return state

    # -- what the world changes -------------------------------------------------------------
    def bodies_changed(self) -> None:
        """Bodies or joints were added or removed: sweep anew before the next step."""
        self.sweep_again = True
        self._forget_state()

    def sleepers(self, asleep: np.ndarray | None, bodies: Any) -> None:
        """Step the bodies ``asleep`` (N,) bool as immovable: the kernels read a copy of the static
        flags and of M^-1 in which they are static with M^-1 = 0 (``phys2d.sleep``), so no pair
        of two of them or with a static body is swept, and no force moves them. None: nobody
        sleeps, and the kernels read the world's own arrays again."""
        if asleep is None:
            if self.sleep_masks is not None:
                self.sleep_masks = None
                self._forget_state()
            return
        if self.sleep_masks is None or self.sleep_masks[0].shape[0] != bodies.n:
            self.sleep_masks = (np.empty(bodies.n, np.bool_), np.empty((bodies.n, 3)))
            self._forget_state()
        static, M_inv = self.sleep_masks
        np.logical_or(bodies.static, asleep, out=static)
        M_inv[:] = bodies.M_inv
        M_inv[asleep] = 0.0

    def cache_of(self, uids: np.ndarray) -> tuple[np.ndarray, ...]:
        """The cache entries (keys, lambda_n, lambda_t, pushed) of the pairs with a body among
        ``uids``: an island's, kept while it sleeps (``warm`` puts them back)."""
        c, k = self.buffers.sides[self.side], self.cached
        keys = c.key[:k]
        pair = keys >> FEATURE_BITS
        mine = np.isin(pair >> UID_BITS, uids) | np.isin(pair & ((1 << UID_BITS) - 1), uids)
        return tuple(a[:k][mine].copy() for a in (c.key, c.cache_lambda_n, c.cache_lambda_t, c.cache_pushed))

    def warm(self, keys: np.ndarray, lambda_n: np.ndarray, lambda_t: np.ndarray, pushed: np.ndarray) -> None:
        """Put cache entries back (``cache_of``: a woken island's), merged in by key, so the next
        step warm starts its contacts as if it had never slept. The world's contacts must be
        copied out first: they share the cache's keys."""
        c, k = self.buffers.sides[self.side], self.cached
        fresh = ~np.isin(keys, c.key[:k])
        merged = [np.concatenate([a[:k], b[fresh]]) for a, b in zip(
            (c.key, c.cache_lambda_n, c.cache_lambda_t, c.cache_pushed), (keys, lambda_n, lambda_t, pushed), strict=True
        )]  # fmt: skip
        n = merged[0].shape[0]
        t = self.buffers
        if (n + 1) // 2 > t.pairs:  # more entries than the buffers hold: grow them, keeping the manifolds
            self.buffers = Buffers(max((n + 1) // 2, 2 * t.pairs), t.joint_rows)
            m, new = self.manifolds, self.buffers.sides[self.side]
            new.manifold_key[:m], new.manifold_row[:m] = c.manifold_key[:m], c.manifold_row[:m]
            self._forget_state()
            self.ordered = PAIR_ORDER
            c = new
        by_key = np.argsort(merged[0], kind="stable")
        for a, values in zip((c.key, c.cache_lambda_n, c.cache_lambda_t, c.cache_pushed), merged, strict=True):
            a[:n] = values[by_key]
        self.cached = n

    def forget_manifolds(self) -> None:
        """Collide every pair anew (the contact margin changed: the points were found with the old)."""
        self.store.clear()
        self._forget_state()
        self.manifolds = 0
        self.sweep_again = True

    def manifold_keys(self) -> tuple[np.ndarray, np.ndarray]:
        """The cached manifolds' keys (ascending) and their rows of the store."""
        c = self.buffers.sides[self.side]
        return c.manifold_key[: self.manifolds], c.manifold_row[: self.manifolds]

    def cache(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The contact cache: keys (ascending), lambda_n and lambda_t (N s) of the last step's contacts."""
        c, k = self.buffers.sides[self.side], self.cached
        return c.key[:k], c.cache_lambda_n[:k], c.cache_lambda_t[:k]

    # -- the records --------------------------------------------------------------------------
    def _geometry(self, world: World) -> tuple:
        """World vertices, edge normals, AABBs, travel, rotations and fat boxes: kept while the bodies are."""
        b = world._bodies
        g = self.geometry
        if not g or g[0].shape[0] != b.n_verts or g[2].shape[0] != b.n:
            n = b.n
            g = np.empty((b.n_verts, 2)), np.empty((b.n_verts, 2)), np.empty((n, 4)), np.empty(n), np.empty((n, 2))
            self.geometry = g = (*g, np.zeros((n, 4)))
        return g

    def state(self, world: World) -> Any:
        """The ``StepState`` over the world's arrays and these buffers, and the records it holds
        (``bodies_record``, ``shapes_record``, ...): made anew when one of the arrays was replaced."""
        b, t, store = world._bodies, self.buffers, self.store
        if self._state is None or self._state_over is not b.x:  # something was replaced (``_forget_state``)
            if self.undo[1].shape[0] != b.n:
                self.undo = (np.empty((b.n, 2)), np.empty(b.n), np.empty((b.n, 3)))
            if self.part.shape[0] != b.n:
                self.part = np.zeros(b.n, np.int32)
                self.ordered = PAIR_ORDER
            world_v, world_n, aabb, travel, rotation, fat = self._geometry(world)
            static, M_inv = (b.static, b.M_inv) if self.sleep_masks is None else self.sleep_masks
            shapes = (
                static, b.uid, b.friction, b.restitution, b.kind, b.radius, b.vstart, b.vcount, b.local_v, b.local_n,
                rotation, world_v, world_n, aabb, fat, travel, self.pairs, t.pair_order, world._excluded, b.category,
                b.mask, b.group, self.part,
            )  # fmt: skip
            self._state, *self._records = records.new_state(
                (b.x, b.theta, b.V, M_inv, self.undo[2]),
                shapes,
                records.arrays_of(store, records.MANIFOLD_FIELDS),
                tuple(records.arrays_of(c, records.CONTACT_FIELDS) for c in t.sides),
                (
                    records.arrays_of(t.rows, records.ROW_FIELDS),
                    self.undo[0],
                    self.undo[1],
                    self.residuals,
                    (b.gravity_scale, b.damping, b.force),
                ),  # fmt: skip
            )
            self._state_over = b.x
            self.rounded = True if bool(np.any(b.kind > POLYGON)) else None
        return self._state

    def _forget_state(self) -> None:
        """An array the state holds was replaced: make the records anew before the next kernel call."""
        self._state = None

    @property
    def bodies_record(self) -> Any:
        return self._records[0]

    @property
    def shapes_record(self) -> Any:
        return self._records[1]

    @property
    def store_record(self) -> Any:
        return self._records[2]

    @property
    def side_records(self) -> tuple:
        return self._records[3]

    @property
    def rows_record(self) -> Any:
        return self._records[4]

    def _room(self, n_joint_rows: int, n_residuals: int) -> None:
        """Buffers with room for this step's pairs, joint rows and sweeps: grown when short, with
        the last step's caches copied into the new ones."""
        t = self.buffers
        if (  # room for the pairs, the manifolds, the cached contacts (2 a pair), the joint rows, the sweeps
            self.n_pairs <= t.pairs
            and self.manifolds <= t.pairs
            and self.cached <= 2 * t.pairs
            and n_joint_rows <= t.joint_rows
            and n_residuals <= self.residuals.shape[0]
        ):
            return
        pairs = max(self.n_pairs, self.manifolds, (self.cached + 1) // 2)
        if not t.holds(pairs, n_joint_rows):
            self.buffers = Buffers(max(pairs, 2 * t.pairs), max(n_joint_rows, t.joint_rows))
            self._forget_state()
            old, new = t.sides[self.side], self.buffers.sides[self.side]
            m, k = self.manifolds, self.cached
            new.manifold_key[:m], new.manifold_row[:m] = old.manifold_key[:m], old.manifold_row[:m]
            for name in ("key", "cache_lambda_n", "cache_lambda_t", "cache_pushed"):
                getattr(new, name)[:k] = getattr(old, name)[:k]
            self.ordered = PAIR_ORDER
        if self.residuals.shape[0] < n_residuals:
            self.residuals = np.zeros(n_residuals)
            self._forget_state()

    def _order(self, world: World, visit: int) -> None:
        """The pairs in the order ``visit`` (part or colour order), in the buffers. Part order in
        a scene of fewer than PARTS_FROM moving bodies is pair order (``order_pairs``): written
        here, so that a small PGS world's first run does not compile the ordering twice (the
        tick has its own copy)."""
        if self.ordered != visit:
            b = world._bodies
            self.state(world)  # (the part buffer sized for the bodies)
            static = b.static if self.sleep_masks is None else self.sleep_masks[0]
            pairs = self.pairs[: self.n_pairs]
            if visit == PART_ORDER and np.count_nonzero(np.bincount(pairs[~static[pairs]], minlength=b.n)) < PARTS_FROM:
                self.part[:] = 0
                self.buffers.pair_order[: self.n_pairs] = np.arange(self.n_pairs)
            else:
                order = order_pairs(self.pairs, self.n_pairs, static, b.x, self.part, visit)
                self.buffers.pair_order[: self.n_pairs] = order
            self.ordered = visit

    def _sweep(self, world: World) -> None:
        """The broadphase's pairs anew (``stages.sweep``), the pair buffer grown when short. The
        one-call tick sweeps itself while its buffers have room."""
        self.state(world)
        n_pairs = sweep(self.shapes_record, world._bodies.x, PAIR_ORDER)
        if n_pairs < 0:  # the pair buffer was too small: grow it and sweep again
            self.pairs = np.zeros((2 * -n_pairs, 2), np.int32)
            self._forget_state()
            self.state(world)
            n_pairs = sweep(self.shapes_record, world._bodies.x, PAIR_ORDER)
        self.n_pairs, self.sweep_again, self.ordered = n_pairs, False, PAIR_ORDER

    def _make_room(self) -> None:
        """Room in the manifold store for a new manifold per pair: a new store of the live rows
        only, with room for them twice over and for the new ones, when there is not."""
        if not self.store.has_room(self.n_pairs):
            self.rebuild_store(max(64, 2 * (self.manifolds + self.n_pairs)))

    def rebuild_store(self, rows: int) -> None:
        """A new manifold store of ``rows`` rows (2 rows points) holding the cached manifolds only."""
        _, row = self.manifold_keys()
        self.store.rebuild(row, rows)
        self._forget_state()
        row[:] = np.arange(self.manifolds)  # slot s's manifold is now in row s

    def _counts(self, visit: int) -> Counts:
        store = self.store
        return Counts._make((  # the counts a kernel reads, as one tuple
            self.side, self.n_pairs, self.manifolds, self.cached, store.rows_used, store.points_used, visit,
            self.sweep_again,
        ))  # fmt: skip

    # -- a step ---------------------------------------------------------------------------------
    def settings_changed(self) -> None:
        """The world's gravity, margins, limits or joints changed: the next step reads them again."""
        self._ready = None

    def step(self, world: World, dt: float, one_call: bool) -> StepReport:
        """One tick of ``world``: in one call when the responder has one and ``one_call``, else
        stage by stage. Returns the report; a step that fails leaves the world as it was."""
        responder = world._responder
        spec = spec_of(responder)
        ready = self._ready
        if ready is None or ready.spec is not spec or ready.dt != dt:  # what the step reads of the world, anew
            world._check_joints_supported(responder)
            step = StepSettings(
                world._gravity, world._gravity_norm, dt, world._contact_margin, world._contact_recycle_distance,
                world._max_speed,
            )  # fmt: skip
            joint_lam = world._joint_lam
            joints = records.record_of_joints(world._joint_arrays, joint_lam) if world._joints else None
            threads = world._threads if world._threads > 1 else None
            rows = RowSettings(dt, world._gravity_norm, *spec.rows)
            self._ready = ready = StepInputs(spec, dt, step, rows, joints, threads, joint_lam)
        self.began = False  # set once the undo buffers hold the state before the step
        try:
            if ready.threads is None:  # (no context to enter: a small scene's step is a few microseconds)
                done = self._one_tick(world, responder, ready, one_call)
            else:
                with using_threads(ready.threads):
                    done = self._one_tick(world, responder, ready, one_call)
        except _TooFast as fast:
            world._bodies.restore(self.undo)
            raise SimulationError(fast.message(world, dt)) from None  # told of the world as it is again
        except BaseException:
            if self.began and (self.undo[1].shape[0] == 0 or np.isfinite(self.undo[1][0])):  # (begin ran)
                world._bodies.restore(self.undo)
            raise
        return self._commit(world, ready, done)

    def _one_tick(self, world: World, responder: Responder, ready: StepInputs, one_call: bool) -> tuple:
        """The tick in one call when it can (``_in_one_call``), else stage by stage."""
        done = self._in_one_call(world, ready) if ready.spec.one_call and one_call else None
        return self._in_stages(world, responder, ready) if done is None else done

    def _in_one_call(self, world: World, ready: StepInputs) -> tuple | None:
        """The tick as one kernel call (``stages.tick``; two when Python must sweep or make room first);
        None, having changed nothing, while a child process compiles it (``_behind``)."""
        spec, _, step, row_settings, joints, threads, joint_lam = ready
        stage, visit = 0, spec.visit
        while True:
            self._room(joint_lam.shape[0], spec.n_residuals)
            if visit != PAIR_ORDER and not self.sweep_again:
                self._order(world, visit)
            s = self.state(world)
            counts = self._counts(visit)
            args = (s, joints, stage, counts, step, row_settings, spec.pgs, spec.soft, self.rounded, threads)
            ready_was, state_was, kernel = self._compiled  # the machine code of the last call
            if ready_was is not ready or state_was is not s or kernel is tick:  # are the types still its?
                types_now = (getattr(s, "_numba_type_", None), joints is None, self.rounded, threads is None)
                if ready_was is not None and ready_was.spec is spec and self._compiled_types == types_now:
                    self._compiled = (ready, s, kernel)  # the same code serves the new settings or state
                else:
                    kernel = tick
            if kernel is tick and self._behind(world, spec, args, types_now):
                return None  # a child compiles the tick: this step goes stage by stage
            child = self._compile_ahead(world, args) if kernel is tick else None
            if stage == 0 and self.undo[1].shape[0]:  # a NaN angle to undo to: ``begin`` has not run (yet)
                self.undo[1][0] = np.nan
            self.began = True
            result = kernel(*args)
            if child is not None:  # the tick is compiled: the child's work is done or no longer needed
                child.kill()
                child.wait()
            if kernel is tick:  # the next steps call its machine code for these types directly
                self._compiled, self._compiled_types = (ready, s, compiled_for(tick, args)), types_now
            if result[-1] >= 0:  # the kernel swept: its pairs (and their order) are the world's
                self.n_pairs, self.ordered = result[-1], visit
            if result[0] == NEED_SWEEP:
                self._sweep(world)
            elif result[0] == NEED_ROOM:
                self._make_room()
            else:
                break
            stage = 1  # forces and geometry are done: go on from the contacts
        if result[0] == BAD_STATE:
            self.began = False  # refused before anything changed: nothing to undo
            raise_bad_state(world)
        if result[0] == TOO_FAST:
            raise_too_fast(world, explain=True)
        if result[0] == NOT_FINITE:
            raise_not_finite(world, "impulses or residuals")
        _, k, n_new, recycled, rows_used, points_used, hits, deepest, count, _ = result
        return k, n_new, recycled, rows_used, points_used, hits, deepest, count, self.residuals[:count].copy(), None

    def _behind(self, world: World, spec: TickSpec, args: tuple, types_now: tuple) -> bool:
        """Whether a child process is compiling the tick for these types while the world steps in
        stages (``ahead.plan``: the cache holds some of its stages, not the tick)."""
        key = (spec.pgs is None, spec.soft is None, types_now)
        child = _BEHIND.get(key)
        if child is None:
            if ahead.plan(self, tick, args) != "behind":
                return False
            child = ahead.start(world._responder, args[1] is not None, args[8] is not None, world._threads)
            if child is None:
                return False
            _BEHIND[key] = child
            ahead.last_plan = "behind"
        return child.poll() is None  # once it is done, the tick loads from the cache it filled

    def _compile_ahead(self, world: World, args: tuple) -> Any:
        """On a cold numba cache with a second core: start a child process compiling the tick from
        its first stage down, and compile its stages here from the last one up (``pipeline.ahead``).
        Returns the child (None when the cache is warm, or it cannot help)."""
        if ahead.plan(self, tick, args) != "ahead":
            return None
        ahead.last_plan = "ahead"
        child = ahead.start(world._responder, args[1] is not None, args[8] is not None, world._threads)
        if child is not None:
            ahead.compile_from_the_end(self, args)
        return child

    def _in_stages(self, world: World, responder: Responder, ready: StepInputs) -> tuple:
        """The stages one call each, as ``stages.tick`` calls them, with the responder's ``respond``
        in the place of its solve."""
        _, _, step, settings, joints, threads, joint_lam = ready
        visit = responder.visit_order
        self._room(joint_lam.shape[0], 0)
        s = self.state(world)
        b = world._bodies
        static, M_inv = (b.static, b.M_inv) if self.sleep_masks is None else self.sleep_masks
        if first_bad_body(b.x, b.theta, b.V, M_inv, static) >= 0:
            raise_bad_state(world)  # written between steps: refused before anything changed
        self.began = True
        fits = begin(s, step.gravity, step.dt, step.contact_margin, threads)
        if self.sweep_again or not fits:  # something left its fat box: sweep again
            self._sweep(world)
            self._room(joint_lam.shape[0], 0)
        self._make_room()
        if visit != PAIR_ORDER:
            self._order(world, visit)
        s = self.state(world)
        # collision -> contacts
        store, t = self.store, self.buffers
        old = t.sides[self.side]
        now = (self.n_pairs, self.manifolds, store.rows_used, store.points_used)
        margins = (step.contact_margin, step.recycle_distance, step.dt)
        old_record, new_record = self.side_records[self.side], self.side_records[1 - self.side]
        records_in = (self.bodies_record, self.shapes_record, self.store_record, old_record, new_record)
        k, n_new, recycled, rows_used, points_used, ascends = collide_recycling_on(
            threads, *records_in, now, margins, self.rounded
        )
        order_contacts(self.shapes_record, new_record, self.n_pairs, (k, n_new, ascends), visit)
        # contacts and cache -> constraint rows
        n = 2 * k + world._joint_lam.shape[0]
        rows = head_of_rows(self.rows_record, k, n)
        kc = self.cached
        cache = (old.key[:kc], old.cache_lambda_n[:kc], old.cache_lambda_t[:kc], old.cache_pushed[:kc])
        deepest, hits = contact_rows(self.bodies_record, self.shapes_record, cache, new_record, rows, settings, threads)
        if joints is not None:
            start_joint_rows(joints, 2 * k, self.bodies_record, step.dt, settings.beta, settings.warm_start, rows)
        # rows -> responder -> integration
        ctx = self._context(world, responder, k, step)
        result = responder.respond(ctx)
        if not isinstance(result, SolveResult):
            raise TypeError(
                f"{type(responder).__name__}.respond must return a phys2d SolveResult(iterations, residuals, "
                f"integrated=...), got {type(result).__name__}"
            )
        b = world._bodies
        if not np.isfinite(ctx.rows.lam).all():  # before the bounce pass reads them
            raise_not_finite(world, "impulses rows.lam")
        if not result.integrated:  # the world moves the positions, then bounces the points that met (rows.bounce)
            bounce_after_moving(ctx, b.V, BOUNCE_SWEEPS, 0.0)
        # the limits, then the impulses per contact and the cache the next step starts from
        if first_too_fast(b.V, b.x, b.theta, step.max_speed) >= 0:
            raise_too_fast(world, explain=True)
        residuals = result.residuals
        if not (np.isfinite(ctx.rows.lam).all() and np.isfinite(residuals).all()):
            raise_not_finite(world, "impulses or residuals")
        impulses_to_contacts_and_cache(rows, new_record, k, threads)
        return k, n_new, recycled, rows_used, points_used, hits, deepest, result.iterations, residuals, result

    def _context(self, world: World, responder: Responder, k: int, step: StepSettings) -> StepContext:
        """What a responder sees: the rows, and the contacts in row order (contact q of ctx is
        contact order[q]), or as found for a responder that gathers what it reads itself."""
        b, t = world._bodies, self.buffers
        c = t.sides[1 - self.side]
        order = c.order[:k]
        rows = Rows.view(t.rows, order, 2 * k + world._joint_lam.shape[0])
        found: tuple[np.ndarray, ...] = (c.body_a, c.body_b, c.point, c.normal, c.separation, c.restitution, c.anchor)
        if responder.visit_order != PAIR_ORDER and responder.contacts_in_row_order:  # the fields it reads, in row order
            found = tuple(f[order] for f in found)
        else:
            found = tuple(f[:k] for f in found)
        body_a, body_b, point, normal, separation, restitution, anchor = found
        M_inv = b.M_inv if self.sleep_masks is None else self.sleep_masks[1]  # sleeping bodies: M^-1 = 0
        return StepContext(
            step.dt, b.x, b.theta, b.V, self.undo[2], M_inv, rows, k, body_a, body_b, point, normal, separation,
            restitution, gravity=world._gravity, joints=world._joint_arrays, anchor=anchor,
            forces=self._forces(b, M_inv, step.dt), threads=world._threads, part=self.part,
        )  # fmt: skip

    def _forces(self, b: Any, M_inv: np.ndarray, dt: float) -> np.ndarray | None:
        """F_ext of the step (``StepContext.F_ext``) when a body has more than m g on it: the force
        that took V1 to V over dt, forces applied and damping included; None otherwise."""
        if not (b.forces_applied or np.any(b.gravity_scale != 1.0) or np.any(b.damping)):
            return None
        F = np.zeros(b.V.shape)
        np.divide(b.V - self.undo[2], dt * M_inv, out=F, where=M_inv > 0.0)  # (a locked direction: 0)
        return F

    def _commit(self, world: World, ready: StepInputs, done: tuple) -> StepReport:
        """A step that succeeded: its side of the buffers becomes the cache, and the report."""
        k, n_new, recycled, rows_used, points_used, hits, deepest, count, residuals, result = done
        store = self.store
        store.recycled, store.rows_used, store.points_used = recycled, rows_used, points_used
        self.side = w = 1 - self.side
        self.manifolds, self.cached = n_new, k
        b = world._bodies
        if b.forces_applied:  # Body.apply_force and apply_torque act for one step
            b.force[:] = 0.0
            b.forces_applied = False
        c = self.buffers.sides[w]
        world._pending_contacts, world._contacts_sealed = (c, k), False  # copied out when first looked at
        joint_impulses = EMPTY
        if ready.joints is not None:
            world._store_joint_impulses(2 * k, self.buffers.rows.lam, ready.joint_lam)
            joint_impulses = ready.joint_lam.copy()
        spec = ready.spec
        return StepReport(
            spec.name, ready.dt, count, residuals, deepest, k, hits, joint_impulses,
            None if result is None else result.system, c.order[:k].copy(), spec.counts,
        )  # fmt: skip


def _body_label(world: World, i: int) -> str:
    return f"body {i} ({world._handles[i]!r})"


def raise_bad_state(world: World) -> None:
    """Raise ValueError naming the first body whose state, as written between steps, a step
    cannot take, the array and what is wrong (``stages.first_bad_body``); nothing has changed."""
    b = world._bodies
    for i in range(b.n):
        label = _body_label(world, i)
        for name, values in (("x", b.x[i]), ("theta", b.theta[i : i + 1]), ("V", b.V[i]), ("M_inv", b.M_inv[i])):
            if not np.all(np.isfinite(values)):
                raise ValueError(
                    f"w.{name}[{i}] = {values.tolist()} is not finite: {label} cannot be stepped; write finite values "
                    "back (body.position, .angle, .velocity, .angular_velocity); the world was not stepped"
                )
        if np.any(b.M_inv[i] < 0.0):
            raise ValueError(
                f"w.M_inv[{i}] = {b.M_inv[i].tolist()} is negative: {label}'s M^-1 = [1/m, 1/m, 1/I] must be >= 0 "
                "(0 locks a direction); the world was not stepped"
            )
        if b.static[i] and np.any(b.M_inv[i] != 0.0):
            kind = "kinematic" if b.kinematic[i] else "static"
            raise ValueError(
                f"w.M_inv[{i}] = {b.M_inv[i].tolist()} on a {kind} body: {label} has infinite mass, so its M^-1 must "
                f"stay 0 (w.M_inv[{i}] = 0); the world was not stepped"
            )
    raise ValueError("a body's state cannot be stepped; the world was not stepped")  # (asleep: its island's copy)


def raise_not_finite(world: World, what: str) -> None:
    """Raise SimulationError: the responder left non-finite ``what``; the step is undone."""
    r = world._responder
    raise SimulationError(
        f"responder {r.name!r} ({type(r).__name__}) left non-finite {what}; the step was refused and the world and "
        "its contact cache were left as they were before it"
    )


class _TooFast(Exception):
    """A step left bodies past the limits (``raise_too_fast``): ``Pipeline.step`` undoes it, then
    raises SimulationError with ``message``, which describes the world as it was again."""

    def __init__(self, bad: np.ndarray) -> None:
        super().__init__()
        self.bad = bad

    def message(self, world: World, dt: float) -> str:
        return too_fast_message(world, self.bad) + "; " + _causes(world, int(self.bad[0]), dt)


def _causes(world: World, i: int, dt: float) -> str:
    """What could have sent body i past the limits in a step of dt (s) from where the world is
    now: the velocity it has, the forces waiting on it, its gravity, the world's; else the
    responder's impulses. Each with what to undo."""
    b, limit = world._bodies, world._max_speed
    causes = []
    if not (np.hypot(b.V[i, 0], b.V[i, 1]) <= limit and abs(b.V[i, 2]) <= limit):
        causes.append(f"it begins the step at V = {b.V[i].tolist()} (set body.velocity and .angular_velocity lower)")
    if np.any(b.force[i] != 0.0):
        with np.errstate(over="ignore", invalid="ignore"):
            dv = float(np.max(np.abs(dt * b.M_inv[i] * b.force[i])))
        causes.append(
            f"a pending force ({b.force[i, 0]:g}, {b.force[i, 1]:g}) N and torque {b.force[i, 2]:g} N m, "
            f"{dv:.3g} m/s (or rad/s) in one step: body.clear_forces() or w.clear_forces() drops it"
        )
    if b.M_inv[i, 0] > 0.0:
        g = world._gravity_norm
        if abs(b.gravity_scale[i]) * g * dt > limit and b.gravity_scale[i] != 1.0:
            dv = abs(b.gravity_scale[i]) * g * dt
            causes.append(f"its gravity_scale {b.gravity_scale[i]:g} ({dv:.3g} m/s a step)")
        if g * dt > limit:
            causes.append(f"w.gravity = {world._gravity.tolist()} m/s^2 ({g * dt:.3g} m/s a step)")
    if not causes:
        causes.append(
            f"the impulses of {world._responder.name!r} (a deep overlap pushed out, a stiff joint or a fast collision: "
            "lower the responder's push_max or beta, or raise max_speed)"
        )
    return f"{_body_label(world, i)}: " + "; ".join(causes)


def _past_limits(world: World) -> np.ndarray:
    """The bodies past max_speed or with a non-finite state."""
    b = world._bodies
    V, max_speed = b.V, world._max_speed
    speed = np.hypot(V[:, 0], V[:, 1])
    ok = (
        np.isfinite(speed)
        & (speed <= max_speed)
        & np.isfinite(V[:, 2])
        & (np.abs(V[:, 2]) <= max_speed)
        & np.isfinite(b.x).all(axis=1)
        & np.isfinite(b.theta)
    )
    return np.flatnonzero(~ok)


def too_fast_message(world: World, bad: np.ndarray) -> str:
    shown = ", ".join(str(i) for i in bad[:10]) + (" ..." if bad.size > 10 else "")
    return (
        f"step would leave bodies [{shown}] faster than max_speed={world._max_speed:g} "
        "(m/s or rad/s) or with a non-finite state; the world was left as it was before the step"
    )


def raise_too_fast(world: World, explain: bool = False) -> None:
    """Raise SimulationError naming the bodies past the world's max_speed or not finite (with
    ``explain``: ``_TooFast``, which ``Pipeline.step`` turns into one that says what sent the
    first there, once the step is undone); nothing when none is."""
    b = world._bodies
    if first_too_fast(b.V, b.x, b.theta, world._max_speed) < 0:
        return
    bad = _past_limits(world)
    if explain:
        raise _TooFast(bad)
    raise SimulationError(too_fast_message(world, bad))


__all__ = ["Pipeline", "SimulationError", "TickSpec", "tick_for"]
