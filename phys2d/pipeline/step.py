"""The pipeline of one tick: the buffers it owns, and the step that runs its stages.

``World.step`` hands a step to its ``Pipeline``, which runs it in one of two ways, with the same
results bit for bit:

    in one call     a responder whose solve is a kernel (``Responder.kernel``: PGS in impulse
                    form, SoftStep) gets one compiled call, ``pipeline.tick.tick``:
                    ``before_solve``, its solve, ``after_solve``
    stage by stage  Python calls the same ``before_solve`` and ``after_solve``, with the
                    responder's ``respond`` between them: the way to watch the stages in a
                    debugger or plug in a responder of your own (``w.one_call_tick = False``
                    forces it)

Both hand the stages one context (``records.TickContext``, made by ``context``), and the step's
settings. Python's part either way: growing a buffer when a kernel says it is short (it
resumes where it stopped), the undo of a step that failed, and the report.

What the world offers the pipeline on purpose: its body arrays (``BodyArrays``), its joints
(``JointSet``) and its bodies' handles (for messages), given once; its settings
(``WorldSettings``) and responder at each step; and the notes that something changed
(``bodies_changed``, ``settings_changed``, ``sleepers``).
"""

from __future__ import annotations

import weakref
from collections.abc import Callable
from typing import Any

import numpy as np

from ..collision.recycle import ManifoldStore
from ..constraints.order import PAIR_ORDER
from ..constraints.rows import Rows, contact_row_map
from ..contacts import FEATURE_BITS, UID_BITS, Contacts
from ..integrate import first_too_fast
from ..responders.base import EMPTY, Responder, SolveResult, StepContext, StepReport, check_joints_supported
from ..responders.restitution import bounce_after_moving
from ..shapes import POLYGON
from . import ahead, records
from .context import Solver, WorldSettings, solver_of, step_settings, threads_switch
from .parallel import using_threads
from .stages import (
    BAD_STATE,
    COLLIDE,
    NEED_PAIRS,
    NEED_ROOM,
    NOT_FINITE,
    OK,
    START,
    SWEEP,
    TOO_FAST,
    Counts,
    StepSettings,
    TickResult,
    after_solve,
    before_solve,
)
from .tick import tick

BUFFER_NAMES = {"warm_started": "hit"}  # a field of ``Contacts`` by its name in the buffers
BOUNCE_SWEEPS = 10  # sweeps of the restitution pass the world makes for a responder that leaves it the move
NAN = float("nan")  # (a constant: ``np.nan`` is a module attribute looked up on every read)


class SimulationError(RuntimeError):
    """A step produced velocities past the world's limits; the world was left as before it."""


def compiled_for(kernel: Callable, args: tuple) -> Callable:
    """The machine code ``kernel`` compiled for the types of ``args``, callable without numba's
    dispatch (which works out every argument's type on every call), or ``kernel`` itself when
    there is none (not compiled for them, or NUMBA_DISABLE_JIT)."""
    overloads = getattr(kernel, "overloads", None)
    if overloads is None:  # NUMBA_DISABLE_JIT: the plain function
        return kernel
    compiled = overloads.get(tuple(kernel.typeof_pyval(a) for a in args))  # type: ignore[attr-defined]
    return kernel if compiled is None else compiled.entry_point


# per kind of tick (its solve, its argument types): the child compiling it, once started
_BEHIND: dict[tuple, Any] = {}


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
    both sides of the contacts, the rows, and the pairs' visit order."""

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
# a named tuple from a plain one without its __new__'s keyword handling (a third of the time, per
# step: the tick's counts in and its result out)
_named = tuple.__new__


class Pipeline:
    """The buffers of a world's steps and the step that fills them (``step``).

    It keeps what one step hands to the next: the broadphase's pairs and their fat boxes, the
    manifold store, the contact cache (the side of the buffers the last good step wrote), the
    last step's contacts; and the step's context (``context``), made anew only when something
    it holds was replaced.
    """

    def __init__(self, bodies: Any, joints: Any, handles: list) -> None:
        self.bodies, self.joints, self.handles = bodies, joints, handles  # the world's, given once
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
        self._begun: Any = np.empty(1).data  # undo[1][:1] (``context``): NaN until ``begin`` has run
        self._residual_rows: tuple = ()  # residuals[0] and residuals[1] (``context``): a step's, lent to its report
        self.residuals = np.zeros((2, 16))  # per side: residuals[side, s] of the step that wrote that side
        self.sleep_masks: tuple | None = None  # (static, M_inv) with the sleeping bodies immovable, or None
        self.rounded: bool | None = None  # True with capsules, segments or chains
        self.last_contacts: tuple = (None, 0)  # (side, K) of the last step's contacts, copied out when read
        self._contacts: Contacts | None = Contacts().read_only()
        self._lent: list = [None, None]  # per side: a weak reference to the report lent its buffers (``_commit``)
        # the context (``context``): the record, its records, what it was made over
        self.ctx: Any = None
        self._records: list = []
        self._over = -1  # the joints' version the context was made with
        # the step's settings and solve (``prepare``), what they were made from, and the machine code
        self.settings: StepSettings | None = None
        self.solver: Solver | None = None
        self._made_from: tuple = ()
        self._solver_of: tuple = (None, -1, None)
        self._machine: dict[tuple, Callable] = {}
        self._kernel: tuple = (None, None, None)  # (context, solver, machine code) of the last call
        self._names = ("none", "iterations")  # the responder's name and counts word, as prepared
        self._visit = PAIR_ORDER  # the order it visits the contacts in (``Responder.visit_order``)
        self._n_residuals = 0  # the sweeps or sub-steps its solve may make
        self.began = False

    def __getstate__(self) -> dict:
        """A copy (pickle, deepcopy) leaves out the context (numba structrefs) and the machine
        code: made anew when needed."""
        state = self.__dict__.copy()
        state.update(ctx=None, _records=[], _over=-1, settings=None, solver=None, _made_from=(), _machine={})
        state.update(_kernel=(None, None, None), _lent=[None, None], _begun=None, _residual_rows=())
        state.update(_solver_of=(None, -1, None))
        return state

    # -- what the world changes -------------------------------------------------------------
    def bodies_changed(self) -> None:
        """Bodies or joints were added or removed: sweep anew before the next step."""
        self.sweep_again = True
        self.ctx = None

    def settings_changed(self) -> None:
        """The world's gravity, margins, limits or joints changed: the next step reads them again."""
        self._made_from = ()

    def sleepers(self, asleep: np.ndarray | None) -> None:
        """Step the bodies ``asleep`` (N,) bool as immovable: the kernels read a copy of the static
        flags and of M^-1 in which they are static with M^-1 = 0 (``phys2d.sleep``), so no pair
        of two of them or with a static body is swept, and no force moves them. None: nobody
        sleeps, and the kernels read the world's own arrays again."""
        bodies = self.bodies
        if asleep is None:
            if self.sleep_masks is not None:
                self.sleep_masks = None
                self.ctx = None
            return
        if self.sleep_masks is None or self.sleep_masks[0].shape[0] != bodies.n:
            self.sleep_masks = (np.empty(bodies.n, np.bool_), np.empty((bodies.n, 3)))
            self.ctx = None
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
        step warm starts its contacts as if it had never slept."""
        self.contacts()  # the last step's contacts copied out first: they share the cache's keys
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
            self.ctx = None
            self.ordered = PAIR_ORDER
            c = new
        by_key = np.argsort(merged[0], kind="stable")
        for a, values in zip((c.key, c.cache_lambda_n, c.cache_lambda_t, c.cache_pushed), merged, strict=True):
            a[:n] = values[by_key]
        self.cached = n

    def forget_manifolds(self) -> None:
        """Collide every pair anew (the contact margin changed: the points were found with the old)."""
        self.store.clear()
        self.ctx = None
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

    # -- the last step's contacts ---------------------------------------------------------------
    def contacts(self) -> Contacts:
        """The contact points of the last step (read-only arrays), copied out of the buffers the
        first time they are read."""
        if self._contacts is None:
            side, k = self.last_contacts
            self._contacts = self.buffers.sides[side].contacts(k).read_only()
        return self._contacts

    def contact_fields(self, names: tuple[str, ...]) -> dict[str, np.ndarray]:
        """The last step's contacts' fields ``names`` (``Contacts``'), read where they lie: in the
        buffers while nobody has looked at them (``contacts`` would copy them out)."""
        if self._contacts is not None:
            return {name: getattr(self._contacts, name) for name in names}
        side, k = self.last_contacts
        found = self.buffers.sides[side]
        return {name: getattr(found, BUFFER_NAMES.get(name, name))[:k] for name in names}

    def keep_contacts(self, contacts: Contacts) -> None:
        """The last step's contacts are ``contacts`` (a snapshot's)."""
        self._contacts, self.last_contacts = contacts.read_only(), (None, contacts.body_a.shape[0])

    def forget_contacts(self) -> None:
        """No contacts to show (a body was removed: their indices no longer match)."""
        self._contacts, self.last_contacts = Contacts().read_only(), (None, 0)

    def touching(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """body_a, body_b and separation (m) of the last step's contacts, read in place."""
        if self._contacts is not None:
            c = self._contacts
            return c.body_a, c.body_b, c.separation
        side, k = self.last_contacts
        found = self.buffers.sides[side]
        return found.body_a[:k], found.body_b[:k], found.separation[:k]

    # -- the context ------------------------------------------------------------------------------
    def context(self) -> Any:
        """The step's ``TickContext`` over the world's arrays and these buffers (and the records it
        holds: ``bodies_record``, ``shapes_record``, ...): made anew when one of the arrays was
        replaced or the threads changed (``ctx`` set to None), or the joints changed; with room
        for them first (``_room``: between a step that succeeded and the next, only such changes
        and ``prepare`` can leave the buffers short)."""
        if self.ctx is not None and self._over == self.joints.version:
            return self.ctx
        self._room()
        b, t, store = self.bodies, self.buffers, self.store
        joints = self.joints.arrays if self.joints.handles else None
        threads = threads_switch(self._threads)
        if self.undo[1].shape[0] != b.n:
            self.undo = (np.empty((b.n, 2)), np.empty(b.n), np.empty((b.n, 3)))
        self._begun = (self.undo[1][:1] if b.n else np.empty(1)).data  # (its [0] written without numpy's indexing)
        self._residual_rows = (self.residuals[0], self.residuals[1])
        if self.part.shape[0] != b.n:
            self.part = np.zeros(b.n, np.int32)
            self.ordered = PAIR_ORDER
        world_v, world_n, aabb, travel, rotation, fat = self._geometry()
        static, M_inv = (b.static, b.M_inv) if self.sleep_masks is None else self.sleep_masks
        shapes = (
            static, b.uid, b.friction, b.restitution, b.kind, b.radius, b.vstart, b.vcount, b.local_v, b.local_n,
            rotation, world_v, world_n, aabb, fat, travel, self.pairs, t.pair_order, self.joints.excluded, b.category,
            b.mask, b.group, self.part,
        )  # fmt: skip
        self.rounded = True if bool(np.any(b.kind > POLYGON)) else None
        joint_record = None if joints is None else records.record_of_joints(joints, self.joints.lam)
        self.ctx, *self._records = records.new_context(
            (b.x, b.theta, b.V, M_inv, self.undo[2]),
            shapes,
            records.arrays_of(store, records.MANIFOLD_FIELDS),
            tuple(records.arrays_of(c, records.CONTACT_FIELDS) for c in t.sides),
            (
                records.arrays_of(t.rows, records.ROW_FIELDS), self.undo[0], self.undo[1], self.residuals,
                (b.gravity_scale, b.damping, b.force), joint_record, threads, self.rounded,
            ),
        )  # fmt: skip
        self._over = self.joints.version
        return self.ctx

    _threads = 1  # the world's threads, as the last ``prepare`` read them

    def _geometry(self) -> tuple:
        """World vertices, edge normals, AABBs, travel, rotations and fat boxes: kept while the bodies are."""
        b = self.bodies
        g = self.geometry
        if not g or g[0].shape[0] != b.n_verts or g[2].shape[0] != b.n:
            n = b.n
            g = np.empty((b.n_verts, 2)), np.empty((b.n_verts, 2)), np.empty((n, 4)), np.empty(n), np.empty((n, 2))
            self.geometry = g = (*g, np.zeros((n, 4)))
        return g

    @property
    def bodies_record(self) -> Any:
        return self._records[0]

    @property
    def shapes_record(self) -> Any:
        return self._records[1]

    @property
    def side_records(self) -> tuple:
        return self._records[3]

    @property
    def rows_record(self) -> Any:
        return self._records[4]

    def prepare(self, world: WorldSettings, responder: Responder, dt: float, one_call: bool) -> None:
        """The step's settings (``settings``) and the solve it runs in one call (``solver``; None:
        stage by stage), made anew: ``step`` calls it when the world's settings, the responder's
        or dt changed since the last (``_made_from``)."""
        check_joints_supported(responder, bool(self.joints.handles), self.joints.mice > 0)
        solver = self._solver(responder) if one_call else None
        self.settings = step_settings(world, responder, dt, solver is not None)
        self.solver = solver
        self._names = (responder.name, responder.counts)
        self._visit = responder.visit_order
        self._n_residuals = 0
        if solver is not None:
            self._n_residuals = solver.pgs.iterations if solver.pgs is not None else solver.soft.substeps
        if self._threads != world.threads:
            self._threads, self.ctx = world.threads, None
        self._room()  # (room for its sweeps' residuals)
        self._made_from = (world, responder, responder.version, dt, one_call)

    def _solver(self, responder: Responder) -> Solver | None:
        kept_responder, version, solver = self._solver_of
        if kept_responder is not responder or version != responder.version:
            solver = solver_of(responder)
            self._solver_of = (responder, responder.version, solver)
        return solver

    def _counts(self, visit: int, resume: int) -> Counts:
        store = self.store
        return _named(Counts, (
            self.side, self.n_pairs, self.manifolds, self.cached, store.rows_used, store.points_used, visit,
            self.ordered, self.sweep_again, resume,
        ))  # fmt: skip

    # -- a step ---------------------------------------------------------------------------------
    def step(self, world: WorldSettings, responder: Responder, dt: float, one_call: bool) -> StepReport:
        """One tick: in one call when the responder names its solve kernel and ``one_call``, else
        stage by stage. Returns the report; a step that fails leaves the world as it was."""
        kept = self._made_from  # (checked here, not in a call: a small scene's step is a few microseconds)
        if (
            not kept
            or kept[0] is not world
            or kept[1] is not responder
            or kept[2] != responder.version
            or kept[3] != dt
            or kept[4] != one_call
        ):
            self.prepare(world, responder, dt, one_call)
        solver = self.solver
        self.began = False
        lent = self._lent[1 - self.side]  # the report lent the buffers of the side this step writes
        if lent is not None and (report := lent()) is not None:
            report.own()  # (still held: it copies them)
        try:
            if world.threads == 1:  # (no context to enter: a small scene's step is a few microseconds)
                done = self._in_one_call(responder, solver) if solver is not None else None
                done = self._in_stages(responder) if done is None else done
            else:
                with using_threads(world.threads):
                    done = self._in_one_call(responder, solver) if solver is not None else None
                    done = self._in_stages(responder) if done is None else done
        except _TooFast as fast:
            self.bodies.restore(self.undo)
            raise SimulationError(fast.message(self, world, responder, dt)) from None  # of the world as it is again
        except BaseException:
            if self.began and (self.undo[1].shape[0] == 0 or np.isfinite(self.undo[1][0])):  # (begin ran)
                self.bodies.restore(self.undo)
            raise
        return self._commit(responder, dt, done)

    def _in_one_call(self, responder: Responder, solver: Solver) -> tuple | None:
        """The tick as one kernel call (``tick.tick``; again when it stopped for room); None,
        having changed nothing, while a child process compiles it (``_behind``)."""
        counts = self._counts(self._visit, START)
        while True:
            ctx = self.context()  # (with room for the step: ``context``)
            args = (ctx, self.settings, solver, counts)
            kept_ctx, kept_solver, kernel = self._kernel
            if kept_ctx is not ctx or kept_solver is not solver or kernel is tick:  # machine code for these types
                key = (getattr(ctx, "_numba_type_", None), solver.pgs is None, solver.pgs is None or solver.pgs.block)
                kernel = self._machine.get(key, tick)
                self._kernel = (ctx, solver, kernel)
            child = None
            if kernel is tick:
                if self._behind(responder, args, key):
                    return None  # a child compiles the tick: this step goes stage by stage
                child = self._compile_ahead(responder, args)
            if counts.resume == START:
                self._begun[0] = NAN  # undo_theta[0] NaN until ``begin`` fills the undo buffers
            self.began = True
            result = kernel(*args)  # (a plain tuple, in TickResult's order)
            if child is not None:  # the tick is compiled: the child's work is done or no longer needed
                child.kill()
                child.wait()
            if kernel is tick:  # the next steps call its machine code for these types directly
                self._machine[key] = compiled_for(tick, args)
                self._kernel = (ctx, solver, self._machine[key])
            if result[0] == OK:  # (status)
                return result, self._residual_rows[result[1]], None  # (side; its first ``solved``: the report's)
            counts = self._stopped(_named(TickResult, result), counts, responder)

    def _in_stages(self, responder: Responder) -> tuple:
        """``before_solve``, the responder's ``respond`` from Python, ``after_solve``."""
        counts = self._counts(responder.visit_order, START)
        while True:
            self._room()
            ctx = self.context()
            self.began = True
            before = before_solve(ctx, self.settings, counts)
            if before.status == OK:
                break
            counts = self._stopped(before, counts, responder)
        self._keep_pairs(before)
        step_ctx = self._step_context(responder, before)
        result = responder.respond(step_ctx)
        if not isinstance(result, SolveResult):
            raise TypeError(
                f"{type(responder).__name__}.respond must return a phys2d SolveResult(iterations, residuals, "
                f"integrated=...), got {type(result).__name__}"
            )
        if not np.isfinite(step_ctx.rows.lam).all():  # before the bounce pass reads them
            raise_not_finite(responder, "impulses rows.lam")
        if not result.integrated:  # the world moves the positions, then bounces the points that met (rows.bounce)
            bounce_after_moving(step_ctx, self.bodies.V, BOUNCE_SWEEPS, 0.0)
        after = after_solve(ctx, self.settings, before, 0)  # (its residuals: checked by SolveResult)
        if after.status != OK:
            self._stopped(after, counts, responder)
        return after._replace(solved=result.iterations), result.residuals, result

    def _stopped(self, result: TickResult, counts: Counts, responder: Responder) -> Counts:
        """What to do when a kernel stopped (``TickResult.status``): make room and say where to resume,
        or raise (the step is then undone by ``step``)."""
        status = result.status
        if status == BAD_STATE:
            self.began = False  # refused before anything changed: nothing to undo
            raise_bad_state(self.bodies, self.handles)
        if status == NEED_PAIRS:  # the pair buffer was short: grow it, sweep again
            self.pairs = np.zeros((2 * result.n_pairs, 2), np.int32)
            self.ctx = None
            self.sweep_again = True
            return counts._replace(resume=SWEEP)
        self._keep_pairs(result)
        if status == NEED_ROOM:
            self._room()
            self._make_room()
            return self._counts(counts.visit, COLLIDE)
        if status == TOO_FAST:
            raise_too_fast(self.bodies, self.handles, self.settings, explain=True)
        if status == NOT_FINITE:
            raise_not_finite(responder, "impulses or residuals")
        raise AssertionError(f"a kernel stopped with status {status}")  # pragma: no cover

    def _keep_pairs(self, result: TickResult) -> None:
        """The pairs the kernel swept (and their order) are the world's now."""
        if result.n_pairs != self.n_pairs or result.ordered != self.ordered or self.sweep_again:
            self.n_pairs, self.ordered, self.sweep_again = result.n_pairs, result.ordered, False

    def _behind(self, responder: Responder, args: tuple, key: tuple) -> bool:
        """Whether a child process is compiling the tick for these types while the world steps in
        stages (``ahead.plan``: the cache holds some of its stages, not the tick)."""
        child = _BEHIND.get(key)
        if child is None:
            if ahead.plan(self, tick, args) != "behind":
                return False
            child = ahead.start(
                responder, self.joints.arrays.kind.shape[0] > 0, self.rounded is not None, self._threads
            )
            if child is None:
                return False
            _BEHIND[key] = child
            ahead.last_plan = "behind"
        return child.poll() is None  # once it is done, the tick loads from the cache it filled

    def _compile_ahead(self, responder: Responder, args: tuple) -> Any:
        """On a cold numba cache with a second core: start a child process compiling the tick from
        its first stage down, and compile its stages here from the last one up (``pipeline.ahead``).
        Returns the child (None when the cache is warm, or it cannot help)."""
        if ahead.plan(self, tick, args) != "ahead":
            return None
        ahead.last_plan = "ahead"
        joints = self.joints.arrays.kind.shape[0] > 0
        child = ahead.start(responder, joints, self.rounded is not None, self._threads)
        if child is not None:
            ahead.compile_from_the_end(self, args)
            ahead.wait_for(child)  # its tick then loads from the cache, not compiled twice
        return child

    # -- room -------------------------------------------------------------------------------------
    def _room(self) -> None:
        """Buffers with room for the pairs, the cache, the joint rows and the sweeps: grown when
        short, with the last step's caches copied into the new ones."""
        t, n_residuals = self.buffers, self._n_residuals
        n_joint_rows = self.joints.lam.shape[0] if self.joints.handles else 0
        if (  # room for the pairs, the manifolds, the cached contacts (2 a pair), the joint rows, the sweeps
            self.n_pairs <= t.pairs
            and self.manifolds <= t.pairs
            and self.cached <= 2 * t.pairs
            and n_joint_rows <= t.joint_rows
            and n_residuals <= self.residuals.shape[1]
        ):
            return
        pairs = max(self.n_pairs, self.manifolds, (self.cached + 1) // 2)
        if not t.holds(pairs, n_joint_rows):
            self.buffers = Buffers(max(pairs, 2 * t.pairs), max(n_joint_rows, t.joint_rows))
            self.ctx = None
            old, new = t.sides[self.side], self.buffers.sides[self.side]
            m, k = self.manifolds, self.cached
            new.manifold_key[:m], new.manifold_row[:m] = old.manifold_key[:m], old.manifold_row[:m]
            for name in ("key", "cache_lambda_n", "cache_lambda_t", "cache_pushed"):
                getattr(new, name)[:k] = getattr(old, name)[:k]
            self.ordered = PAIR_ORDER
        if self.residuals.shape[1] < n_residuals:
            self.residuals = np.zeros((2, n_residuals))
            self.ctx = None

    def _make_room(self) -> None:
        """Room in the manifold store for a new manifold per pair: a new store of the live rows
        only, with room for them twice over and for the new ones, when there is not."""
        if not self.store.has_room(self.n_pairs):
            self.rebuild_store(max(64, 2 * (self.manifolds + self.n_pairs)))

    def rebuild_store(self, rows: int) -> None:
        """A new manifold store of ``rows`` rows (2 rows points) holding the cached manifolds only."""
        _, row = self.manifold_keys()
        self.store.rebuild(row, rows)
        self.ctx = None
        row[:] = np.arange(self.manifolds)  # slot s's manifold is now in row s

    # -- what a responder sees, and the report ------------------------------------------------------
    def _step_context(self, responder: Responder, before: TickResult) -> StepContext:
        """What a responder sees: the rows, and the contacts in row order (contact q of ctx is
        contact order[q]), or as found for a responder that gathers what it reads itself."""
        b, t, k, settings = self.bodies, self.buffers, before.contacts, self.settings
        assert settings is not None
        c = t.sides[before.side]
        order = c.order[:k]
        joints = self.joints.arrays
        rows = Rows.view(t.rows, order, 2 * k + joints.n_rows)
        found: tuple[np.ndarray, ...] = (c.body_a, c.body_b, c.point, c.normal, c.separation, c.restitution, c.anchor)
        if responder.visit_order != PAIR_ORDER and responder.contacts_in_row_order:  # the fields it reads, in row order
            found = tuple(f[order] for f in found)
        else:
            found = tuple(f[:k] for f in found)
        body_a, body_b, point, normal, separation, restitution, anchor = found
        M_inv = b.M_inv if self.sleep_masks is None else self.sleep_masks[1]  # sleeping bodies: M^-1 = 0
        return StepContext(
            settings.dt, b.x, b.theta, b.V, self.undo[2], M_inv, rows, k, body_a, body_b, point, normal, separation,
            restitution, gravity=settings.gravity, joints=joints, anchor=anchor,
            forces=self._forces(M_inv, settings.dt), threads=self._threads, part=self.part,
        )  # fmt: skip

    def _forces(self, M_inv: np.ndarray, dt: float) -> np.ndarray | None:
        """F_ext of the step (``StepContext.F_ext``) when a body has more than m g on it: the force
        that took V1 to V over dt, forces applied and damping included; None otherwise."""
        b = self.bodies
        if not (b.forces_applied or np.any(b.gravity_scale != 1.0) or np.any(b.damping)):
            return None
        F = np.zeros(b.V.shape)
        np.divide(b.V - self.undo[2], dt * M_inv, out=F, where=M_inv > 0.0)  # (a locked direction: 0)
        return F

    def _commit(self, responder: Responder, dt: float, done: tuple) -> StepReport:
        """A step that succeeded: its side of the buffers becomes the cache, and the report.
        ``done``: (its TickResult, its residuals, the responder's SolveResult or None)."""
        tick_result, residuals, result = done
        _, side, n_pairs, ordered, k, manifolds, recycled, rows_used, points_used, hits, deepest, solved = tick_result
        if n_pairs != self.n_pairs or ordered != self.ordered or self.sweep_again:  # (``_keep_pairs``)
            self.n_pairs, self.ordered, self.sweep_again = n_pairs, ordered, False
        store = self.store
        store.recycled, store.rows_used, store.points_used = recycled, rows_used, points_used
        self.side, self.manifolds, self.cached = side, manifolds, k
        b = self.bodies
        if b.forces_applied:  # Body.apply_force and apply_torque act for one step
            b.force[:] = 0.0
            b.forces_applied = False
        self._contacts, self.last_contacts = None, (side, k)  # copied out when first looked at
        joint_impulses = EMPTY
        if self.joints.handles:
            self.joints.store_impulses(2 * k, self.buffers.rows.lam)
            joint_impulses = self.joints.lam.copy()
        c = self.buffers.sides[side]
        name, counted = self._names
        if result is not None:  # stage by stage: the responder's residuals, and the order copied
            system, order = result.system, c.order[:k].copy()
            return StepReport(name, dt, solved, residuals, deepest, k, hits, joint_impulses, system, order, counted)
        report = StepReport(name, dt, solved, residuals, deepest, k, hits, joint_impulses, None, c.order, counted, True)
        self._lent[side] = weakref.ref(report)  # (lent this side's residuals and order)
        return report


# -- refusals -------------------------------------------------------------------------------------
def _body_label(handles: list, i: int) -> str:
    return f"body {i} ({handles[i]!r})"


def raise_bad_state(b: Any, handles: list) -> None:
    """Raise ValueError naming the first body whose state, as written between steps, a step
    cannot take, the array and what is wrong (``stages.first_bad_body``); nothing has changed."""
    for i in range(b.n):
        label = _body_label(handles, i)
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


def raise_not_finite(responder: Responder, what: str) -> None:
    """Raise SimulationError: the responder left non-finite ``what``; the step is undone."""
    raise SimulationError(
        f"responder {responder.name!r} ({type(responder).__name__}) left non-finite {what}; the step was refused and "
        "the world and its contact cache were left as they were before it"
    )


class _TooFast(Exception):
    """A step left bodies past the limits (``raise_too_fast``): ``Pipeline.step`` undoes it, then
    raises SimulationError with ``message``, which describes the world as it was again."""

    def __init__(self, bad: np.ndarray) -> None:
        super().__init__()
        self.bad = bad

    def message(self, pipeline: Pipeline, world: WorldSettings, responder: Responder, dt: float) -> str:
        why = _causes(pipeline.bodies, pipeline.handles, world, responder, int(self.bad[0]), dt)
        return too_fast_message(self.bad, world.max_speed) + "; " + why


def _causes(b: Any, handles: list, world: WorldSettings, responder: Responder, i: int, dt: float) -> str:
    """What could have sent body i past the limits in a step of dt (s) from where the world is
    now: the velocity it has, the forces waiting on it, its gravity, the world's; else the
    responder's impulses. Each with what to undo."""
    limit = world.max_speed
    with np.errstate(over="ignore", invalid="ignore"):  # (a huge dt: the sizes below overflow, as they may)
        return _causes_of(b, handles, world, responder, i, dt, limit)


def _causes_of(
    b: Any, handles: list, world: WorldSettings, responder: Responder, i: int, dt: float, limit: float
) -> str:
    causes = []
    if not (np.hypot(b.V[i, 0], b.V[i, 1]) <= limit and abs(b.V[i, 2]) <= limit):
        causes.append(f"it begins the step at V = {b.V[i].tolist()} (set body.velocity and .angular_velocity lower)")
    if np.any(b.force[i] != 0.0):
        dv = float(np.max(np.abs(dt * b.M_inv[i] * b.force[i])))
        causes.append(
            f"a pending force ({b.force[i, 0]:g}, {b.force[i, 1]:g}) N and torque {b.force[i, 2]:g} N m, "
            f"{dv:.3g} m/s (or rad/s) in one step: body.clear_forces() or w.clear_forces() drops it"
        )
    if b.M_inv[i, 0] > 0.0:
        g = world.g
        if abs(b.gravity_scale[i]) * g * dt > limit and b.gravity_scale[i] != 1.0:
            dv = abs(b.gravity_scale[i]) * g * dt
            causes.append(f"its gravity_scale {b.gravity_scale[i]:g} ({dv:.3g} m/s a step)")
        if g * dt > limit:
            causes.append(f"w.gravity = {world.gravity.tolist()} m/s^2 ({g * dt:.3g} m/s a step)")
    if not causes:
        causes.append(
            f"the impulses of {responder.name!r} (a deep overlap pushed out, a stiff joint or a fast collision: "
            "lower the responder's push_max or beta, or raise max_speed)"
        )
    return f"{_body_label(handles, i)}: " + "; ".join(causes)


def _past_limits(b: Any, max_speed: float) -> np.ndarray:
    """The bodies past max_speed or with a non-finite state."""
    V = b.V
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


def too_fast_message(bad: np.ndarray, max_speed: float) -> str:
    shown = ", ".join(str(i) for i in bad[:10]) + (" ..." if bad.size > 10 else "")
    return (
        f"step would leave bodies [{shown}] faster than max_speed={max_speed:g} "
        "(m/s or rad/s) or with a non-finite state; the world was left as it was before the step"
    )


def raise_too_fast(b: Any, handles: list, settings: Any, explain: bool = False) -> None:
    """Raise SimulationError naming the bodies past max_speed or not finite (with ``explain``:
    ``_TooFast``, which ``Pipeline.step`` turns into one that says what sent the first there,
    once the step is undone); nothing when none is."""
    if first_too_fast(b.V, b.x, b.theta, settings.max_speed) < 0:
        return
    bad = _past_limits(b, settings.max_speed)
    if explain:
        raise _TooFast(bad)
    raise SimulationError(too_fast_message(bad, settings.max_speed))


__all__ = ["Pipeline", "SimulationError", "compiled_for"]
