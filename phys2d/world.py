"""The World: owns the body arrays and runs one tick of the pipeline.

    external forces -> collision -> cache matching -> constraint rows
                    -> responder -> integration

Each stage lives in its own module; ``World._step_in_stages`` is the pipeline in one
screen. Responders that move positions themselves (the split push, sub-steps, a bounce
after the move) say so, and the world does not integrate again. For PGS and SoftStep,
``World.step`` runs the same stages in one numba call (``phys2d.tick``): on a small
scene the calls from Python and the Python between them cost more than the physics.
"""

from __future__ import annotations

import math
from typing import TypeVar

import numpy as np
from numpy.typing import ArrayLike

from . import shapes
from .bodies import Body, BodyArrays
from .collision.broadphase import find_pairs, update_geometry_in
from .collision.recycle import ManifoldCache
from .constraints.joints import (
    AngleJoint,
    DistanceJoint,
    Joint,
    JointArrays,
    PinJoint,
    check_limits,
    local_anchor,
    optional_limit,
    start_joint_rows,
)
from .constraints.order import colour_pairs, contacts_in_order, solve_order
from .constraints.rows import RowBuffer, Rows, contact_rows
from .contacts import ContactCache, Contacts
from .integrate import apply_external_forces, first_too_fast, integrate_positions
from .pipeline import records
from .responders.base import EMPTY, Responder, StepContext, StepReport
from .responders.pgs import PGS
from .tick import (
    CACHE_FIELDS,
    CONTACT_FIELDS,
    NEED_ROOM,
    NEED_SWEEP,
    ROW_FIELDS,
    TOO_FAST,
    TickBuffers,
    TickSpec,
    TickState,
    compiled_for,
    make_tick_state,
    tick_for,
    tick_state_type,
)
from .validation import check_bool, finite_float, float_in, non_negative_float, positive_float, vec2

_J = TypeVar("_J", bound=Joint)

NONE_WARM = np.zeros(0, np.bool_)  # placeholder until the step has warm started its contacts


class SimulationError(RuntimeError):
    """A step produced velocities past the world's limits; the world was left as before it."""


class World:
    """A 2D world of rigid bodies.

    gravity     (m/s^2), default (0, -10)
    responder   the collision responder, default ``PGS()``; swappable between steps
    contact_margin  surfaces closer than this (m) already make contact points
                (speculative contacts, separation > 0), so resting contacts do not
                flicker on and off; bodies in motion are also met as far away as
                their velocity could carry them within the step, so fast bodies stop
                at the surface instead of sinking into it
    max_speed   a step that leaves any body faster than this (m/s, or rad/s for
                spin) raises SimulationError and is undone
    contact_recycle_distance  a touching pair that has moved less than this (m)
                relative to itself since its points were found keeps them
                (``collision.recycle``); 0 finds every manifold anew each step

    gravity, contact_margin, max_speed, contact_recycle_distance and responder can be
    set between steps; a bad value is refused with the constructor's message and
    changes nothing.

    one_call_tick  run a step in one kernel call when the responder has one (PGS in
                impulse form, SoftStep; default True); False calls each stage's kernel
                from Python, with bit-identical results (to time or watch the stages)
    """

    def __init__(
        self,
        gravity=(0.0, -10.0),
        responder: Responder | None = None,
        *,
        contact_margin: float = 0.02,
        max_speed: float = 1e4,
        contact_recycle_distance: float = 0.05,
    ) -> None:
        self.gravity = gravity
        self._responder = self._check_responder(PGS() if responder is None else responder)
        self.contact_margin = contact_margin
        self.max_speed = max_speed
        self._manifolds = ManifoldCache()
        self.contact_recycle_distance = contact_recycle_distance
        self._bodies = BodyArrays()
        self._handles: list[Body] = []
        self._cache = ContactCache()
        self._excluded = np.zeros(0, np.int64)  # sorted pair keys that must not collide
        self._joints: list[Joint] = []
        self._joint_arrays = JointArrays(self._joints)  # packed joints, rebuilt on changes
        self._pairs = np.zeros((64, 2), np.int32)
        self._n_pairs = 0
        self._pair_order: np.ndarray | None = None  # pair indices in solve order (graph colouring), made when needed
        self._fat = np.zeros((0, 4))  # the fat boxes the pairs were swept with
        self._geometry: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None = None
        self._sweep_again = True  # bodies or exclusions changed since: the pairs must be found anew
        self._rows = RowBuffer()
        self._contacts = Contacts().read_only()
        self._contacts_sealed = True
        self._pending_contacts: tuple | None = None  # (buffers, K) of a one-call tick's contacts, read lazily
        self._tick_buffers = TickBuffers(0, 0)
        self._undo = (np.empty((0, 2)), np.empty(0), np.empty((0, 3)))  # x0, theta0, V1 of the one-call tick
        self._joint_lam = np.zeros(0)  # the joints' last reactions, in joint order: each step's warm start
        self._joint_rows_first = 0  # the first joint row of the last step
        self._joints_placed = True  # every joint knows where its rows stood in the last step
        self._residuals = np.zeros(16)
        self._tick_state_over: tuple = ()  # the arrays the kept TickState was made over
        self._tick_state_kept: TickState | None = None
        # (spec, buffers, state, compiled kernel) of the last one-call step: kept while the responder's
        # settings hold and nothing set _sweep_again (bodies, joints, margin), swept, made room or stepped in stages
        self._ready: tuple | None = None
        # (spec, TickState type, compiled kernel): the tick's machine code for a spec and state type
        self._tick_code: tuple = (None, None, None)
        self._one_call_tick = True
        self._last_step = StepReport().read_only()
        self.tick = 0
        self.time = 0.0

    def __getstate__(self) -> dict:
        """A copy (pickle, deepcopy) leaves out the TickState, a numba structref: made anew when needed."""
        state = self.__dict__.copy()
        state.update(_tick_state_kept=None, _tick_state_over=(), _ready=None, _tick_code=(None, None, None))
        return state

    # -- configuration ------------------------------------------------------
    @staticmethod
    def _check_responder(responder: object) -> Responder:
        if not isinstance(responder, Responder):
            raise TypeError(f"responder must be a phys2d responder such as phys2d.PGS(), got {responder!r}")
        return responder

    @property
    def responder(self) -> Responder:
        return self._responder

    @responder.setter
    def responder(self, value: Responder) -> None:
        value = self._check_responder(value)
        self._check_joints_supported(value)
        self._responder = value

    def _check_joints_supported(self, responder: Responder, adding: bool = False) -> None:
        if (self._joints or adding) and not responder.handles_joints:
            raise ValueError(
                f"responder {responder.name!r} cannot solve joints: it handles contact pairs only "
                "(as the lecture's naive takes do); use phys2d.PGS() or phys2d.SoftStep() in a world with joints"
            )

    @property
    def gravity(self) -> np.ndarray:
        """Gravity g (m/s^2), a copy."""
        return self._gravity.copy()

    @gravity.setter
    def gravity(self, value: ArrayLike) -> None:
        self._gravity = vec2(value, "gravity")
        self._gravity_norm = float(math.hypot(*self._gravity))  # |g|, m/s^2

    @property
    def contact_margin(self) -> float:
        """Surfaces closer than this (m) make speculative contact points."""
        return self._contact_margin

    @contact_margin.setter
    def contact_margin(self, value: float) -> None:
        self._contact_margin = non_negative_float(value, "contact_margin")
        self._sweep_again = True  # the fat boxes were grown by the old margin
        if hasattr(self, "_manifolds"):
            self._manifolds.clear()  # their points were found with the old margin

    @property
    def contact_recycle_distance(self) -> float:
        """A pair that moved less than this (m) relative to itself keeps its contact points."""
        return self._contact_recycle_distance

    @contact_recycle_distance.setter
    def contact_recycle_distance(self, value: float) -> None:
        self._contact_recycle_distance = non_negative_float(value, "contact_recycle_distance")

    @property
    def one_call_tick(self) -> bool:
        """Step PGS (impulse form) and SoftStep in one kernel call (``phys2d.tick``); False: stage by stage."""
        return self._one_call_tick

    @one_call_tick.setter
    def one_call_tick(self, value: bool) -> None:
        self._one_call_tick = check_bool(value, "one_call_tick")

    @property
    def max_speed(self) -> float:
        """A step leaving any body faster than this (m/s, or rad/s for spin) is undone."""
        return self._max_speed

    @max_speed.setter
    def max_speed(self, value: float) -> None:
        self._max_speed = positive_float(value, "max_speed")

    # -- the lecture's arrays (views: the first N rows) ------------------------
    @property
    def x(self) -> np.ndarray:
        """(N, 2) centres of mass, m."""
        return self._bodies.x

    @property
    def theta(self) -> np.ndarray:
        """(N,) angles, rad."""
        return self._bodies.theta

    @property
    def V(self) -> np.ndarray:
        """(N, 3) velocities [vx, vy, omega]: the lecture's V, one row per body."""
        return self._bodies.V

    @property
    def M_inv(self) -> np.ndarray:
        """(N, 3) the diagonal of M^-1: [1/m, 1/m, 1/I], zeros for static bodies."""
        return self._bodies.M_inv

    @property
    def bodies(self) -> tuple[Body, ...]:
        """Handles of the bodies, in creation order (index i is row i of the arrays)."""
        return tuple(self._handles)

    def __len__(self) -> int:
        return self._bodies.n

    # -- adding and removing bodies ----------------------------------------------
    # Every argument after ``position`` is keyword-only. The ones all add_* share:
    #   angle (rad), density (kg/m^2, 2D), friction (mu >= 0), restitution (e in [0, 1]),
    #   static (never moved by impulses or gravity), velocity (m/s), angular_velocity (rad/s).
    def add_box(
        self,
        position: ArrayLike = (0.0, 0.0),
        *,
        half_extents: ArrayLike = (0.5, 0.5),
        angle: float = 0.0,
        density: float = 1.0,
        friction: float = 0.6,
        restitution: float = 0.0,
        static: bool = False,
        velocity: ArrayLike = (0.0, 0.0),
        angular_velocity: float = 0.0,
    ) -> Body:
        """A box of half extents (hx, hy) in m centred at ``position`` (m), rotated by ``angle`` (rad)."""
        return self._add(
            shapes.box(half_extents),
            position,
            angle,
            density,
            friction,
            restitution,
            static,
            velocity,
            angular_velocity,
        )

    def add_circle(
        self,
        position: ArrayLike = (0.0, 0.0),
        *,
        radius: float = 0.5,
        angle: float = 0.0,
        density: float = 1.0,
        friction: float = 0.6,
        restitution: float = 0.0,
        static: bool = False,
        velocity: ArrayLike = (0.0, 0.0),
        angular_velocity: float = 0.0,
    ) -> Body:
        """A circle of ``radius`` (m) centred at ``position`` (m)."""
        return self._add(
            shapes.circle(radius), position, angle, density, friction, restitution, static, velocity, angular_velocity
        )

    def add_polygon(
        self,
        position: ArrayLike = (0.0, 0.0),
        *,
        vertices: ArrayLike,
        angle: float = 0.0,
        density: float = 1.0,
        friction: float = 0.6,
        restitution: float = 0.0,
        static: bool = False,
        velocity: ArrayLike = (0.0, 0.0),
        angular_velocity: float = 0.0,
    ) -> Body:
        """A convex polygon: ``vertices`` (m), at least 3, counter-clockwise in the body frame.

        The vertices are re-centred on their centroid, which is placed at
        ``position`` (m): a body's position is always its centre of mass.
        """
        return self._add(
            shapes.polygon(vertices),
            position,
            angle,
            density,
            friction,
            restitution,
            static,
            velocity,
            angular_velocity,
        )

    def _add(
        self,
        spec: shapes.ShapeSpec,
        position: ArrayLike,
        angle: float,
        density: float,
        friction: float,
        restitution: float,
        static: bool,
        velocity: ArrayLike,
        angular_velocity: float,
    ) -> Body:
        # validate everything before touching the arrays: a rejected call changes nothing
        x = vec2(position, "position")
        theta = finite_float(angle, "angle")
        density = positive_float(density, "density")
        friction = non_negative_float(friction, "friction")
        restitution = float_in(restitution, "restitution", 0.0, 1.0)
        static = check_bool(static, "static")
        v = vec2(velocity, "velocity")
        omega = finite_float(angular_velocity, "angular_velocity")
        mass, inertia = shapes.mass_properties(spec, density)
        index = self._bodies.append(spec, x, theta, (v[0], v[1], omega), mass, inertia, friction, restitution, static)
        handle = Body(self, index, int(self._bodies.uid[index]))
        self._handles.append(handle)
        self._sweep_again = True  # a new body
        return handle

    def _own(self, body: object, name: str = "body") -> int:
        """The index of ``body`` after checking it is a live body of this world."""
        if not isinstance(body, Body):
            raise TypeError(f"{name} must be a phys2d Body, got {type(body).__name__}")
        if body._world is not self:
            raise ValueError(f"{name} belongs to another world")
        if body._index < 0:
            raise ValueError(f"{name} was removed from this world")
        return body._index

    def remove(self, item: Body | Joint) -> None:
        """Remove a body (and every joint on it) or a joint; the handle becomes unusable.

        Removing a body shifts the indices of later bodies down by one.
        """
        if isinstance(item, Joint):
            self._remove_joint(item)
            return
        if not isinstance(item, Body):
            raise TypeError(f"item must be a phys2d Body or Joint, got {type(item).__name__}")
        i = self._own(item)
        for joint in [q for q in self._joints if i in (q.body_a._index, q.body_b._index)]:
            self._remove_joint(joint)
        self._bodies.delete(i)
        self._handles.pop(i)
        for h in self._handles[i:]:
            h._index -= 1
        item._index = -1
        self._contacts = Contacts().read_only()  # its indices no longer match w.bodies
        self._contacts_sealed, self._pending_contacts = True, None
        self._last_step = StepReport().read_only()  # nor does the last step's report
        self._joints_changed()

    # -- joints --------------------------------------------------------------------
    @property
    def joints(self) -> tuple[Joint, ...]:
        """Handles of the joints, in creation order (their rows follow the contact rows)."""
        return tuple(self._joints)

    def _joint_bodies(self, a: Body, b: Body) -> tuple[Body, Body]:
        """The world's handles of a and b, after checking they can be joined."""
        ia, ib = self._own(a, "a"), self._own(b, "b")
        if ia == ib:
            raise ValueError("a and b are the same body: a joint needs two bodies")
        if self._bodies.static[ia] and self._bodies.static[ib]:
            raise ValueError("a and b are both static: a joint between them could never act")
        return self._handles[ia], self._handles[ib]

    def add_distance_joint(
        self,
        a: Body,
        b: Body,
        *,
        anchor_a: ArrayLike | None = None,
        anchor_b: ArrayLike | None = None,
        length: float | None = None,
        collide_connected: bool = False,
    ) -> DistanceJoint:
        """Keep point ``anchor_a`` of a and point ``anchor_b`` of b at distance ``length`` (m).

        Anchors are world points (m) at creation, the body centres when None; they are
        stored in the bodies' frames. ``length`` defaults to their distance now.
        """
        body_a, body_b = self._joint_bodies(a, b)
        local_a = local_anchor(body_a, anchor_a, "anchor_a")
        local_b = local_anchor(body_b, anchor_b, "anchor_b")
        p_a = body_a.position if anchor_a is None else np.asarray(anchor_a, np.float64)
        p_b = body_b.position if anchor_b is None else np.asarray(anchor_b, np.float64)
        if length is None:
            length = float(np.hypot(*(p_b - p_a)))
            if length < 1e-6:
                raise ValueError(
                    "anchor_a and anchor_b coincide, so length would be 0: "
                    "use add_pin_joint to hold two points together"
                )
        else:
            length = positive_float(length, "length")
        collide = check_bool(collide_connected, "collide_connected")
        self._check_joints_supported(self._responder, adding=True)
        return self._add_joint(DistanceJoint(self, body_a, body_b, local_a, local_b, length, collide))

    def add_pin_joint(self, a: Body, b: Body, *, anchor: ArrayLike, collide_connected: bool = False) -> PinJoint:
        """Pin a and b together at the world point ``anchor`` (m): they may turn about it."""
        body_a, body_b = self._joint_bodies(a, b)
        if anchor is None:
            raise TypeError("anchor must be a pair of numbers (x, y), got None")
        local_a = local_anchor(body_a, anchor, "anchor")
        local_b = local_anchor(body_b, anchor, "anchor")
        collide = check_bool(collide_connected, "collide_connected")
        self._check_joints_supported(self._responder, adding=True)
        return self._add_joint(PinJoint(self, body_a, body_b, local_a, local_b, collide))

    def add_angle_joint(
        self,
        a: Body,
        b: Body,
        *,
        lower: float | None = None,
        upper: float | None = None,
        collide_connected: bool = False,
    ) -> AngleJoint:
        """Keep theta_b - theta_a at its value now (theta_0), or with ``lower`` and/or ``upper``
        (rad, offsets from theta_0) within [theta_0 + lower, theta_0 + upper]."""
        body_a, body_b = self._joint_bodies(a, b)
        lower = optional_limit(lower, "lower")
        upper = optional_limit(upper, "upper")
        check_limits(lower, upper)
        collide = check_bool(collide_connected, "collide_connected")
        self._check_joints_supported(self._responder, adding=True)
        theta_0 = body_b.angle - body_a.angle
        return self._add_joint(AngleJoint(self, body_a, body_b, theta_0, lower, upper, collide))

    def _add_joint(self, joint: _J) -> _J:
        self._joints.append(joint)
        self._joints_changed()
        return joint

    def _remove_joint(self, joint: Joint) -> None:
        if joint._world is not self:
            raise ValueError("joint belongs to another world")
        if not joint.alive:
            raise ValueError("joint was removed from this world")
        joint._impulse = joint.impulse  # its last reactions, kept by the handle from now on
        joint._offset = None
        self._joints.remove(joint)
        joint.alive = False
        joint._has_rows = False
        self._joints_changed()

    def _joints_changed(self) -> None:
        """Repack the joints (each keeps its last reactions) and rebuild the sorted keys of pairs
        that must not collide."""
        self._joint_arrays = ja = JointArrays(self._joints)
        lam = np.zeros(ja.n_rows)
        for q, joint in enumerate(self._joints):
            offset = int(ja.row_offset[q])
            if joint._offset is not None:
                lam[offset : offset + joint.row_count] = joint.impulse
            joint._offset = offset
        self._joint_lam = lam
        self._joints_placed = False
        keys = [
            (min(q.body_a._index, q.body_b._index) << 32) | max(q.body_a._index, q.body_b._index)
            for q in self._joints
            if not q.collide_connected
        ]
        self._excluded = np.unique(np.asarray(keys, np.int64))
        self._sweep_again = True

    # -- one tick ----------------------------------------------------------------
    def step(self, dt: float) -> StepReport:
        """Advance the world by dt seconds; returns (and keeps as ``last_step``) the report.

        The tick runs in one kernel call (``phys2d.tick``) when the responder has one and
        ``one_call_tick`` is set, else stage by stage (``_step_in_stages``): the same stages
        in the same order, with bit-identical results."""
        if type(dt) is not float or not 0.0 < dt < math.inf:  # (a plain positive float passes at once)
            dt = positive_float(dt, "dt")
        responder = self._responder
        if self._joints:
            self._check_joints_supported(responder)
        spec = tick_for(responder) if self._one_call_tick else None
        report = self._step_in_stages(dt, responder) if spec is None else self._step_in_one_call(dt, spec)
        self._last_step = report
        self.tick += 1
        self.time += dt
        return report

    def _step_in_stages(self, dt: float, responder: Responder) -> StepReport:
        """The tick one stage at a time: external forces, collision, rows, the responder's
        ``respond``, integration (unless it moved the bodies itself), the limits, the caches."""
        b = self._bodies
        x, theta, V, M_inv = b.x, b.theta, b.V, b.M_inv
        self._ready = None  # this step replaces the caches' arrays: a one-call tick looks them over again
        x0, theta0, V1 = x.copy(), theta.copy(), V.copy()  # the undo; V1 is also the velocity the tick began with
        manifolds_before = self._manifolds.state()
        try:
            apply_external_forces(V, M_inv, self._gravity, dt)
            c, order = self._collide(dt)
            rows, hit, hits, deepest = self._build_rows(c, order, V1, V, dt)
            ctx = self._context(c, order, rows, dt, V1)
            result = responder.respond(ctx)
            if not result.integrated:
                integrate_positions(x, theta, V, dt)
            self._check_limits()
        except BaseException:
            b.restore((x0, theta0, V1))
            self._manifolds.restore(manifolds_before)
            raise
        k = len(c)
        c.lambda_n, c.lambda_t = self._cache.store_rows(c.key, rows)
        c.warm_started = hit
        self._store_joint_impulses(rows.first_joint_row, rows.lam)
        self._contacts, self._contacts_sealed, self._pending_contacts = c, False, None  # sealed when first looked at
        return StepReport(
            responder=responder.name,
            dt=dt,
            iterations=result.iterations,
            counted=responder.counts,
            residuals=result.residuals,
            max_penetration=deepest,
            contact_count=k,
            cache_hits=hits,
            joint_impulses=rows.joint_impulses() if self._joints else EMPTY,
            system=result.system,
            solve_order=order,
        )  # its arrays turn read-only when first looked at

    def _step_in_one_call(self, dt: float, spec: TickSpec) -> StepReport:
        """The tick as one kernel call (``phys2d.tick``; two when the broadphase must sweep
        first). The kernel writes the side of the double buffers the last good step did not;
        only a step that succeeds makes it the caches' and the contacts'."""
        b, m, cache = self._bodies, self._manifolds, self._cache
        world = (self._gravity, self._gravity_norm, dt, self._contact_margin, self._contact_recycle_distance)
        stage, began = 0, False
        try:
            while True:
                ready = self._ready
                if ready is not None and ready[0] is spec and not self._sweep_again:
                    _, t, state, kernel = ready  # nothing was replaced since the last step (see _ready)
                else:
                    t = self._room_for_tick(spec)
                    state = self._tick_state(t)
                    code = self._tick_code  # kept through sweeps: a fast chain sweeps nearly every step
                    kernel = code[2] if code[0] is spec and code[1] is tick_state_type(state) else spec.kernel
                side = t.side
                began = True  # from here the undo buffers hold the state before the step
                found = (self._n_pairs, spec.colour_order, self._sweep_again)
                args = (
                    state, stage, side, found,
                    (m.key.shape[0], cache.keys.shape[0], m.rows_used, m.points_used), world, spec.row_settings,
                    self._max_speed, *spec.settings,
                )  # fmt: skip
                result = kernel(*args)
                if result[-1] >= 0:  # the kernel swept: its pairs (and their colouring) are the world's
                    self._n_pairs = result[-1]
                    self._pair_order = t.pair_order[: self._n_pairs] if spec.colour_order else None
                    t.coloured = self._pair_order
                if kernel is spec.kernel:  # the next steps call its compiled code for these types directly
                    kernel = compiled_for(spec.kernel, args)
                    self._tick_code = (spec, tick_state_type(state), kernel)
                self._ready = (spec, t, state, kernel)
                if result[0] == NEED_SWEEP:
                    self._sweep(self._geometry_buffers()[2])
                elif result[0] == NEED_ROOM:
                    m.make_room(self._n_pairs)
                    self._ready = None
                else:
                    break
                stage = 1  # forces and geometry are done: go on from the contacts
            if result[0] == TOO_FAST:
                self._check_limits()  # raises, naming the bodies
        except BaseException:
            if began:
                b.restore(self._undo)
            raise
        _, k, n_new, m.recycled, m.rows_used, m.points_used, hits, deepest, count, _ = result
        w = t.side = 1 - side
        t.held = t.caches_of(w, n_new, k)
        _, _, m.key, m.row, cache.keys, cache.lambda_n, cache.lambda_t, cache.pushed, order = t.held
        self._pending_contacts, self._contacts_sealed = (t, w, k), False
        joint_impulses = EMPTY
        if self._joints:
            self._store_joint_impulses(2 * k, t.lam)
            joint_impulses = self._joint_lam.copy()
        return StepReport(
            spec.name, dt, count, self._residuals[:count].copy(), deepest, k, hits, joint_impulses, None,
            order.copy(), spec.counts,
        )  # fmt: skip

    def _room_for_tick(self, spec: TickSpec) -> TickBuffers:
        """The one-call tick's buffers, with room for this step's pairs, joint rows and sweeps, and
        for the caches; caches a staged step left (arrays of their own, or a store made anew with
        its rows numbered anew) are copied in."""
        t, m, cache = self._tick_buffers, self._manifolds, self._cache
        n_joint_rows = self._joint_lam.shape[0]
        pairs = max(self._n_pairs, m.key.shape[0], (cache.keys.shape[0] + 1) // 2)
        if not t.holds(pairs, n_joint_rows):
            t = self._tick_buffers = TickBuffers(max(pairs, 2 * t.pairs), max(n_joint_rows, t.joint_rows))
        held = t.held
        if held[2] is not m.key or held[3] is not m.row or held[4] is not cache.keys:
            n, k, side = m.key.shape[0], cache.keys.shape[0], t.side  # not this side's views: copy them in
            t.m_key[side][:n], t.m_row[side][:n] = m.key, m.row
            t.cache_keys[side][:k], t.cache_lambda_n[side][:k] = cache.keys, cache.lambda_n
            t.cache_lambda_t[side][:k], t.cache_pushed[side][:k] = cache.lambda_t, cache.pushed
            t.held = t.caches_of(side, n, k)
            _, _, m.key, m.row, cache.keys, cache.lambda_n, cache.lambda_t, cache.pushed, _ = t.held
        if self._residuals.shape[0] < spec.n_residuals:
            self._residuals = np.zeros(spec.n_residuals)
        if spec.colour_order and not self._sweep_again:  # the pairs in colour order, in the buffers
            if self._pair_order is None:
                self._pair_order = colour_pairs(self._pairs, self._n_pairs, self._bodies.static, self._bodies.n)
            if t.coloured is not self._pair_order:
                t.pair_order[: self._n_pairs] = self._pair_order
                t.coloured = self._pair_order
        return t

    def _tick_state(self, t: TickBuffers) -> TickState:
        """The ``TickState`` over the world's arrays: made anew when one of them was replaced."""
        b, m = self._bodies, self._manifolds
        if self._undo[1].shape[0] != b.n:
            self._undo = (np.empty((b.n, 2)), np.empty(b.n), np.empty((b.n, 3)))
        geometry = self._geometry_buffers()
        over = self._tick_state_over
        if (
            not over
            or over[0] is not b.kernel_arrays
            or over[1] is not geometry
            or over[2] is not self._fat
            or over[3] is not self._pairs
            or over[4] is not t
            or over[5] is not m.store
            or over[6] is not self._joint_arrays
            or over[7] is not self._joint_lam
            or over[8] is not self._residuals
            or over[9] is not self._undo
            or over[10] is not self._excluded
        ):
            ja = self._joint_arrays
            self._tick_state_kept = make_tick_state(
                b.kernel_arrays,
                (*geometry, self._fat, self._pairs, t.pair_order, self._excluded),
                (*m.store, t.m_key, t.m_row),
                t.group(CACHE_FIELDS),
                t.group(CONTACT_FIELDS),
                t.group(ROW_FIELDS),
                (ja.kind, ja.body_a, ja.body_b, ja.local_a, ja.local_b, ja.params, ja.row_offset, self._joint_lam),
                (*self._undo, self._residuals),
            )
            self._tick_state_over = (
                b.kernel_arrays, geometry, self._fat, self._pairs, t, m.store, ja, self._joint_lam, self._residuals,
                self._undo, self._excluded,
            )  # fmt: skip
        return self._tick_state_kept  # type: ignore[return-value]

    @property
    def contacts(self) -> Contacts:
        """The contact points of the last step (read-only arrays)."""
        if not self._contacts_sealed:
            if self._pending_contacts is not None:  # a one-call tick's: copied out of its buffers now
                self._contacts = _contacts_from(*self._pending_contacts)
                self._pending_contacts = None
            self._contacts.read_only()
            self._contacts_sealed = True
        return self._contacts

    @property
    def last_step(self) -> StepReport:
        """What the last step did (``StepReport``; read-only arrays)."""
        return self._last_step

    def _context(self, c: Contacts, order: np.ndarray, rows: Rows, dt: float, V1: np.ndarray) -> StepContext:
        """What the responder sees: the contacts in row order (contact q of ctx is contact order[q]),
        or as found for a responder that gathers what it reads (``contacts_in_row_order`` False)."""
        b = self._bodies
        r = self._responder
        if r.colour_order and r.contacts_in_row_order:  # the fields a responder reads, in row order
            body_a, body_b, point, normal, separation, restitution, anchor = contacts_in_order(
                order, c.body_a, c.body_b, c.point, c.normal, c.separation, c.restitution, c.anchor
            )
        else:  # pair order (row order is contact order), or a responder that gathers for itself
            body_a, body_b, point, normal = c.body_a, c.body_b, c.point, c.normal
            separation, restitution, anchor = c.separation, c.restitution, c.anchor
        return StepContext(
            dt,
            b.x,
            b.theta,
            b.V,
            V1,
            b.M_inv,
            rows,
            len(c),
            body_a,
            body_b,
            point,
            normal,
            separation,
            restitution,
            gravity=self._gravity,
            joints=self._joint_arrays,
            anchor=anchor,
        )

    def _geometry_buffers(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """World vertices, edge normals, AABBs, travel and rotations: kept while the bodies are the same."""
        b = self._bodies
        if self._geometry is None or self._geometry[0].shape[0] != b.n_verts or self._geometry[2].shape[0] != b.n:
            self._geometry = (
                np.empty((b.n_verts, 2)),
                np.empty((b.n_verts, 2)),
                np.empty((b.n, 4)),
                np.empty(b.n),
                np.empty((b.n, 2)),
            )
        return self._geometry

    def _collide(self, dt: float = 0.0) -> tuple[Contacts, np.ndarray]:
        """Broadphase and narrowphase at the current positions: this step's contacts, and
        the order the responder visits them in (contact order[q] is the q-th visited).

        Bodies are looked for as far apart as contact_margin plus what their current
        velocities could close within dt (speculative contacts).
        """
        b = self._bodies
        world_v, world_n, aabb, travel, rotation = self._geometry_buffers()
        fits = update_geometry_in(
            b.x,
            b.theta,
            b.kind,
            b.radius,
            b.vstart,
            b.vcount,
            b.local_v,
            b.local_n,
            b.V,
            dt,
            self._contact_margin,
            world_v,
            world_n,
            aabb,
            travel,
            rotation,
            self._fat,
        )
        if self._sweep_again or not fits:  # something left its fat box: sweep again
            self._sweep(aabb)
        cap = 2 * self._n_pairs
        out = (
            np.empty(cap, np.int32),
            np.empty(cap, np.int32),
            np.empty((cap, 2)),
            np.empty((cap, 2)),
            np.empty(cap),
            np.empty(cap, np.int32),
            np.empty(cap, np.int64),
            np.empty(cap),
            np.empty(cap),
            np.empty((cap, 4)),
        )
        pair_start = np.empty(self._n_pairs + 1, np.int64)
        k = self._manifolds.collide(
            self._pairs,
            self._n_pairs,
            b,
            rotation,
            world_v,
            world_n,
            self.contact_margin,
            travel,
            self.contact_recycle_distance,
            out,
            pair_start,
        )
        body_a, body_b, point, normal, separation, feature, key, mu, e, anchor = [a[:k] for a in out]
        if self._responder.colour_order:
            if self._pair_order is None:
                self._pair_order = colour_pairs(self._pairs, self._n_pairs, b.static, b.n)
            order = solve_order(self._pair_order, pair_start)
        else:
            order = np.arange(k, dtype=np.int32)
        return Contacts(
            body_a=body_a,
            body_b=body_b,
            point=point,
            anchor=anchor,
            normal=normal,
            separation=separation,
            lambda_n=EMPTY,
            lambda_t=EMPTY,
            feature=feature,
            key=key,
            warm_started=NONE_WARM,
            friction=mu,
            restitution=e,
        ), order

    def _sweep(self, aabb: np.ndarray) -> None:
        """The broadphase's pairs anew, from the bodies' boxes grown by FAT_MARGIN (the fat boxes).
        The one-call tick sweeps itself (``tick.sweep_in_tick``) while its buffers have room."""
        fat = self._fat if self._fat.shape == aabb.shape else np.empty_like(aabb)  # kept: the tick's state holds it
        n_pairs = find_pairs(aabb, fat, self._bodies.static, self._excluded, self._pairs)
        if n_pairs < 0:  # the pair buffer was too small: grow it and sweep again
            self._pairs = np.zeros((2 * -n_pairs, 2), np.int32)
            n_pairs = find_pairs(aabb, fat, self._bodies.static, self._excluded, self._pairs)
        self._fat, self._n_pairs, self._sweep_again = fat, n_pairs, False
        self._ready = None  # the one-call tick's buffers and state are looked over again
        self._pair_order = None  # coloured when a responder first visits these pairs by colour

    def _build_rows(
        self, c: Contacts, order: np.ndarray, V1: np.ndarray, V: np.ndarray, dt: float
    ) -> tuple[Rows, np.ndarray, int, float]:
        """Constraint rows for this step: contacts (visited in ``order``), then the joints' rows.

        V1 is the velocity the tick began with, V the one after external forces.

        Returns the rows, lambda started from the contact cache when the responder
        warm starts, the mask of contacts found in the cache and their number, and the
        deepest overlap (m).
        """
        b = self._bodies
        r = self._responder
        k = len(c)
        ja = self._joint_arrays
        rows = self._rows.take(order, ja.n_rows)
        cache = self._cache
        hit = np.empty(k, np.bool_)
        deepest, hits = contact_rows(
            rows.order,
            rows.normal_row,
            rows.friction_row,
            c.body_a,
            c.body_b,
            c.point,
            c.anchor,
            r.found_lever_arms,
            c.normal,
            c.separation,
            c.friction,
            c.restitution,
            b.x,
            V1,
            V,
            b.M_inv,
            dt,
            r.beta,
            r.slop,
            r.push_max,
            r.restitution_threshold,
            r.friction_model,
            self._gravity_norm,
            r.warm_start,
            cache.keys,
            cache.lambda_n,
            cache.lambda_t,
            cache.pushed,
            c.key,
            b.uid,
            b.static,
            rows.body_a,
            rows.body_b,
            rows.J,
            rows.JM,
            rows.A_kk,
            rows.xi,
            rows.push,
            rows.bounce,
            rows.impact,
            rows.lo,
            rows.hi,
            rows.bound_row,
            rows.mu,
            rows.lam,
            hit,
        )
        if ja.n_rows:  # joints keep their identity: last step's reactions (_joint_lam) start this one's
            joints = records.record_of_joints(ja, self._joint_lam)
            bodies = records.new_bodies((b.x, b.theta, V, b.M_inv, V1))
            start_joint_rows(
                joints, rows.first_joint_row, bodies, dt, r.beta, r.warm_start, records.record_of_rows(rows)
            )
        return rows, hit, hits, deepest

    def _store_joint_impulses(self, first_joint_row: int, lam: np.ndarray) -> None:
        """Keep the joints' reactions (``lam`` of the step's rows, from first_joint_row) of the step
        just taken: one copy, which every joint's ``impulse`` reads its rows of."""
        self._joint_lam[:] = lam[first_joint_row : first_joint_row + self._joint_lam.shape[0]]
        self._joint_rows_first = first_joint_row
        if not self._joints_placed:  # joints were added or removed since: each learns its rows' place
            for joint in self._joints:
                assert joint._offset is not None  # placed by _joints_changed
                joint._rows_offset, joint._has_rows = joint._offset, True
            self._joints_placed = True

    def _check_limits(self) -> None:
        b = self._bodies
        V = b.V
        first = first_too_fast(V, b.x, b.theta, self._max_speed)
        if first >= 0:
            speed = np.hypot(V[:, 0], V[:, 1])
            bad = ~(
                np.isfinite(speed)
                & (speed <= self._max_speed)
                & np.isfinite(V[:, 2])
                & (np.abs(V[:, 2]) <= self._max_speed)
                & np.isfinite(b.x).all(axis=1)
                & np.isfinite(b.theta)
            )
            idx = np.flatnonzero(bad)
            shown = ", ".join(str(i) for i in idx[:10]) + (" ..." if idx.size > 10 else "")
            raise SimulationError(
                f"step would leave bodies [{shown}] faster than max_speed={self._max_speed:g} "
                "(m/s or rad/s) or with a non-finite state; the world was left as it was before the step"
            )

    # -- energy and momentum ---------------------------------------------------------
    def kinetic_energy(self) -> float:
        """Sum of 1/2 m v^2 + 1/2 I omega^2 over dynamic bodies (J)."""
        b = self._bodies
        dyn = ~b.static
        v2 = b.V[dyn, 0] ** 2 + b.V[dyn, 1] ** 2
        return float(0.5 * np.sum(b.mass[dyn] * v2 + b.inertia[dyn] * b.V[dyn, 2] ** 2))

    def potential_energy(self) -> float:
        """Sum of -m g . x over dynamic bodies (J), zero at the origin."""
        b = self._bodies
        dyn = ~b.static
        return float(-np.sum(b.mass[dyn] * (b.x[dyn] @ self._gravity)))

    def linear_momentum(self) -> np.ndarray:
        """Sum of m v over dynamic bodies (kg m/s)."""
        b = self._bodies
        dyn = ~b.static
        return np.sum(b.mass[dyn, None] * b.V[dyn, :2], axis=0)

    def angular_momentum(self, about: ArrayLike = (0.0, 0.0)) -> float:
        """Sum of I omega + (x - about) x m v over dynamic bodies (kg m^2/s)."""
        o = vec2(about, "about")
        b = self._bodies
        dyn = ~b.static
        r = b.x[dyn] - o
        m = b.mass[dyn]
        v = b.V[dyn]
        return float(np.sum(b.inertia[dyn] * v[:, 2] + m * (r[:, 0] * v[:, 1] - r[:, 1] * v[:, 0])))

    # -- read-only views for observers (the recorder, tools): no copies, no writes ----------
    # Each is a read-only view of the world's arrays, valid until a body is added or removed.
    def _read_only(self, a: np.ndarray) -> np.ndarray:
        v = a.view()
        v.flags.writeable = False
        return v

    @property
    def body_uids(self) -> np.ndarray:
        """(N,) int64 uid of each body: unique in the world's lifetime, kept through removals."""
        return self._read_only(self._bodies.uid)

    @property
    def body_static(self) -> np.ndarray:
        """(N,) bool, True for static bodies (M^-1 = 0)."""
        return self._read_only(self._bodies.static)

    @property
    def body_kinds(self) -> np.ndarray:
        """(N,) int32 shape kind of each body: ``phys2d.shapes.CIRCLE`` or ``POLYGON``."""
        return self._read_only(self._bodies.kind)

    @property
    def body_radii(self) -> np.ndarray:
        """(N,) float64 circle radius of each body, m (0 for polygons)."""
        return self._read_only(self._bodies.radius)

    @property
    def body_masses(self) -> np.ndarray:
        """(N,) float64 mass m of each body, kg (also for static bodies)."""
        return self._read_only(self._bodies.mass)

    @property
    def body_inertias(self) -> np.ndarray:
        """(N,) float64 moment of inertia I of each body about its centre of mass, kg m^2."""
        return self._read_only(self._bodies.inertia)

    @property
    def vertex_start(self) -> np.ndarray:
        """(N,) int32 first row of each body's polygon in ``local_vertices``."""
        return self._read_only(self._bodies.vstart)

    @property
    def vertex_count(self) -> np.ndarray:
        """(N,) int32 number of polygon vertices of each body (0 for circles)."""
        return self._read_only(self._bodies.vcount)

    @property
    def local_vertices(self) -> np.ndarray:
        """(V, 2) float64 every polygon vertex in its body's frame, m, counter-clockwise;
        body i's are rows ``vertex_start[i] : vertex_start[i] + vertex_count[i]``."""
        return self._read_only(self._bodies.local_v)

    def __repr__(self) -> str:
        n = self._bodies.n
        n_static = int(self._bodies.static.sum())
        return (
            f"<World: {n} bodies ({n_static} static), gravity=({self._gravity[0]:g}, "
            f"{self._gravity[1]:g}) m/s^2, responder={self._responder!r}, t={self.time:.4g} s>"
        )


# Contacts' fields and the tick's buffers (``TickBuffers``) they are copied from
CONTACTS_FROM_BUFFERS = {
    "body_a": "body_a", "body_b": "body_b", "point": "point", "anchor": "anchor", "normal": "normal",
    "separation": "separation", "lambda_n": "lambda_n", "lambda_t": "lambda_t", "feature": "feature", "key": "key",
    "warm_started": "hit", "friction": "mu", "restitution": "e",
}  # fmt: skip


def _contacts_from(t: TickBuffers, side: int, k: int) -> Contacts:
    """A one-call tick's K contacts, copied out of side ``side`` of its buffers."""
    return Contacts(**{field: getattr(t, name)[side][:k].copy() for field, name in CONTACTS_FROM_BUFFERS.items()})
