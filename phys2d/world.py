"""The World: the bodies, the joints and the settings, and the user's API to them.

``World.step`` hands a tick to the world's ``Pipeline`` (``phys2d.pipeline``), which owns
the buffers a step fills and runs its stages:

    external forces -> collision -> contacts and cache -> constraint rows
                    -> responder -> integration

in one numba call for PGS and SoftStep (``pipeline.tick.tick``), or with the responder's
``respond`` called from Python between the stages before its solve and those after it, for
every other responder (and for any with ``one_call_tick = False``).

What the world offers its pipeline and its islands (``phys2d.sleep``), on purpose: its body
arrays (``BodyArrays``), its joints (``JointSet``) and the bodies' handles, given once; its
settings (``WorldSettings``) and responder with each step.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING, NamedTuple, TypeVar

import numpy as np
from numpy.typing import ArrayLike

from . import heap, shapes
from . import sleep as sleeping
from .bodies import MAX_BODY_UID, Body, BodyArrays, BodyOptions, PlacedBodyOptions, body_settings
from .collision import queries
from .collision.queries import RayHit
from .constraints.joints import (
    AngleJoint,
    DistanceJoint,
    Joint,
    JointSet,
    MouseJoint,
    PinJoint,
    SliderJoint,
    WeldJoint,
    check_limits,
    local_anchor,
    optional_limit,
)
from .contacts import Contacts
from .pipeline.context import WorldSettings
from .pipeline.step import Pipeline, SimulationError
from .responders.base import Responder, StepReport, check_joints_supported
from .responders.pgs import PGS
from .validation import check_bool, check_int, non_negative_float, positive_float, vec2

if TYPE_CHECKING:
    from typing_extensions import Unpack  # typing.Unpack from Python 3.11; annotations only

_J = TypeVar("_J", bound=Joint)


class WorldParts(NamedTuple):
    """What a World's state is made of (``World._parts``): its body arrays and handles, its
    joints, its pipeline (buffers, caches, pairs) and sleeping islands, its settings, responder,
    last report, and the switches ``sleep`` and ``one_call_tick``."""

    bodies: BodyArrays
    handles: list[Body]
    joints: JointSet
    pipeline: Pipeline
    islands: sleeping.Islands
    settings: WorldSettings
    responder: Responder
    last_step: StepReport
    sleep: bool
    one_call_tick: bool


def _read_only_view(field: str, doc: str) -> property:
    """A property giving a read-only view of the body arrays' ``field``."""

    def get(self: World) -> np.ndarray:
        view = getattr(self._bodies, field).view()
        view.flags.writeable = False
        return view

    return property(get, doc=doc)


def _given(spec: shapes.ShapeSpec) -> Callable[[], shapes.ShapeSpec]:
    """A maker of the shape ``spec``, made already."""
    return lambda: spec


def _static_options(options: PlacedBodyOptions, method: str) -> BodyOptions:
    """The body options of a segment or chain: static, whatever ``options`` say of it (False, or
    kinematic, or an angle, is refused: its points place it)."""
    if "static" in options and options["static"] is not True:
        raise ValueError(f"static: {method} makes static bodies only, got static={options['static']!r}")
    if options.get("kinematic", False) is not False:
        raise ValueError(f"kinematic: {method} makes static bodies only, got kinematic={options['kinematic']!r}")
    if "angle" in options:
        raise TypeError(f"angle: {method} takes no angle, its points place it")
    return BodyOptions(**{**options, "static": True})


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
    sleep       let islands of bodies at rest fall asleep (Box2D's rules, ``phys2d.sleep``):
                an island whose every body stayed under 0.05 m/s and 2 deg/s for 0.5 s
                stops moving and costs almost nothing to step until something wakes it
                (``Body.awake``); default False, settable between steps (False wakes all)
    threads     how many cores a step may use (default 1, settable between steps): with more
                than one, the pairs are collided and the contact rows built on several
                threads, the sweeps of the soft step and of PGS solve the parts of the scene
                (``constraints.order``: from PARTS_FROM moving bodies) each on its own
                thread, and the per-point and per-body passes run a slice per thread
                (``pipeline.parallel``); the results are bit-identical for every count.
                Threads pay on scenes of several thousand contacts and up; on smaller ones
                waking them costs more than they save (benchmarks/SCALE.md)
    """

    def __init__(
        self,
        gravity=(0.0, -10.0),
        responder: Responder | None = None,
        *,
        contact_margin: float = 0.02,
        max_speed: float = 1e4,
        contact_recycle_distance: float = 0.05,
        sleep: bool = False,
        threads: int = 1,
    ) -> None:
        self._bodies = BodyArrays()
        self._handles: list[Body] = []
        self._joints = JointSet()
        # the buffers of a step, and the step that fills them; then which bodies sleep, and what their islands keep
        self._pipeline = Pipeline(self._bodies, self._joints, self._handles)
        self._islands = sleeping.Islands(self._bodies, self._joints, self._pipeline)
        self._settings = WorldSettings(vec2(gravity, "gravity"), 0.02, 0.05, 1e4, 1)
        self.gravity = gravity
        self._responder = self._check_responder(PGS() if responder is None else responder)
        self.contact_margin = contact_margin
        self.max_speed = max_speed
        heap.keep_freed_pages()  # a tick's scratch reuses the last tick's pages (phys2d.heap)
        self.contact_recycle_distance = contact_recycle_distance
        self._one_call_tick = True
        self._last_step = StepReport().read_only()
        self._sleep = check_bool(sleep, "sleep")
        self.threads = threads
        self.tick = 0
        self.time = 0.0

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

    def _check_joints_supported(self, responder: Responder, adding: bool = False, mouse: bool = False) -> None:
        check_joints_supported(responder, bool(self._joints) or adding, mouse or self._joints.mice > 0)

    @property
    def gravity(self) -> np.ndarray:
        """Gravity g (m/s^2), a copy."""
        return self._settings.gravity.copy()

    @gravity.setter
    def gravity(self, value: ArrayLike) -> None:
        self._settings = self._settings._replace(gravity=vec2(value, "gravity"))

    @property
    def contact_margin(self) -> float:
        """Surfaces closer than this (m) make speculative contact points."""
        return self._settings.contact_margin

    @contact_margin.setter
    def contact_margin(self, value: float) -> None:
        self._settings = self._settings._replace(contact_margin=non_negative_float(value, "contact_margin"))
        self._pipeline.forget_manifolds()  # the points were found with the old margin, the fat boxes grown by it

    @property
    def contact_recycle_distance(self) -> float:
        """A pair that moved less than this (m) relative to itself keeps its contact points."""
        return self._settings.recycle_distance

    @contact_recycle_distance.setter
    def contact_recycle_distance(self, value: float) -> None:
        distance = non_negative_float(value, "contact_recycle_distance")
        self._settings = self._settings._replace(recycle_distance=distance)

    @property
    def one_call_tick(self) -> bool:
        """Step PGS (impulse form) and SoftStep in one kernel call (``pipeline.tick.tick``); False: stage by
        stage."""
        return self._one_call_tick

    @one_call_tick.setter
    def one_call_tick(self, value: bool) -> None:
        self._one_call_tick = check_bool(value, "one_call_tick")

    @property
    def max_speed(self) -> float:
        """A step leaving any body faster than this (m/s, or rad/s for spin) is undone."""
        return self._settings.max_speed

    @max_speed.setter
    def max_speed(self, value: float) -> None:
        self._settings = self._settings._replace(max_speed=positive_float(value, "max_speed"))

    @property
    def sleep(self) -> bool:
        """Whether islands at rest fall asleep (``phys2d.sleep``); setting False wakes every body."""
        return self._sleep

    @sleep.setter
    def sleep(self, value: bool) -> None:
        self._sleep = check_bool(value, "sleep")
        if not self._sleep:
            self._islands.wake_all()

    @property
    def threads(self) -> int:
        """How many cores a step may use: 1 (the default) runs every kernel on one; more split the
        collide, the contact rows and the sweeps of the soft step and PGS over numba threads (at
        most the NUMBA_NUM_THREADS numba started with), with bit-identical results
        (``pipeline.parallel``). They pay on scenes of several thousand contacts and up: below,
        one thread is faster."""
        return self._settings.threads

    @threads.setter
    def threads(self, value: int) -> None:
        self._settings = self._settings._replace(threads=check_int(value, "threads", 1))

    # -- the lecture's arrays (views: the first N rows) ------------------------
    # Each is the world's own array, writable, as the lessons use them. A held array goes stale
    # when a body is added or removed (the world's arrays are new views then): read w.x again.
    # The next step checks what was written: a non-finite value, a negative M^-1, or M^-1 > 0 on
    # a static or kinematic body is refused (ValueError naming the body and the array; the
    # world is not stepped).
    @property
    def x(self) -> np.ndarray:
        """(N, 2) centres of mass, m (writable; stale after an add or remove)."""
        return self._bodies.x

    @property
    def theta(self) -> np.ndarray:
        """(N,) angles, rad (writable; stale after an add or remove)."""
        return self._bodies.theta

    @property
    def V(self) -> np.ndarray:
        """(N, 3) velocities [vx, vy, omega]: the lecture's V, one row per body (writable; stale
        after an add or remove)."""
        return self._bodies.V

    @property
    def M_inv(self) -> np.ndarray:
        """(N, 3) the diagonal of M^-1: [1/m, 1/m, 1/I], zeros for static and kinematic bodies
        (writable; stale after an add or remove). Writing it changes how impulses move a body,
        not its ``mass`` or ``inertia``, which the energies and momenta read; a 0 locks that
        direction (``fixed_rotation=True`` locks the turning, as an option)."""
        return self._bodies.M_inv

    @property
    def bodies(self) -> tuple[Body, ...]:
        """Handles of the bodies, in creation order (index i is row i of the arrays)."""
        return tuple(self._handles)

    def __len__(self) -> int:
        return self._bodies.n

    # -- adding and removing bodies ----------------------------------------------
    # Every argument after ``position`` is keyword-only. Besides the shape's own, every add_*
    # takes the body's (``bodies.BodyOptions``): angle (rad), density (kg/m^2, 2D), friction
    # (mu >= 0), restitution (e in [0, 1]), static (never moves), kinematic (moves at its
    # velocity, no force or contact changes it), velocity (m/s), angular_velocity (rad/s),
    # gravity_scale, linear_damping and angular_damping (c >= 0, 1/s: v /= 1 + c dt), the
    # collision filter category, mask (64-bit masks) and group (Box2D's meaning), and
    # fixed_rotation (it never turns). Sizes (every radius, half extent, half length) lie in
    # [1 mm, 100 km] and densities in [1e-6, 1e6] kg/m^2 (``shapes.MIN_SIZE``, ``bodies.MIN_DENSITY``).
    def add_box(
        self, position: ArrayLike = (0.0, 0.0), *, half_extents: ArrayLike = (0.5, 0.5), **options: Unpack[BodyOptions]
    ) -> Body:
        """A box of half extents (hx, hy) in m centred at ``position`` (m), rotated by ``angle`` (rad)."""
        return self._add(lambda: shapes.box(half_extents), position, options)

    def add_circle(
        self, position: ArrayLike = (0.0, 0.0), *, radius: float = 0.5, **options: Unpack[BodyOptions]
    ) -> Body:
        """A circle of ``radius`` (m) centred at ``position`` (m)."""
        return self._add(lambda: shapes.circle(radius), position, options)

    def add_polygon(
        self, position: ArrayLike = (0.0, 0.0), *, vertices: ArrayLike, **options: Unpack[BodyOptions]
    ) -> Body:
        """A convex polygon: ``vertices`` (m), at least 3, counter-clockwise in the body frame.

        The vertices are re-centred on their centroid, which is placed at
        ``position`` (m): a body's position is always its centre of mass.
        """
        return self._add(lambda: shapes.polygon(vertices), position, options)

    def add_capsule(
        self,
        position: ArrayLike = (0.0, 0.0),
        *,
        half_length: float,
        radius: float,
        angle: float = 0.0,
        **options: Unpack[PlacedBodyOptions],
    ) -> Body:
        """A capsule centred at ``position`` (m): the core segment from (-half_length, 0) to
        (half_length, 0) in the body frame (m), rotated by ``angle`` (rad), swept by a disc of
        ``radius`` (m). Mass and inertia are the stadium's (``shapes.rounded_area_properties``)."""
        return self._add(lambda: shapes.capsule(half_length, radius), position, BodyOptions(**options, angle=angle))

    def add_segment(
        self, a: ArrayLike, b: ArrayLike, *, radius: float = 0.0, **options: Unpack[PlacedBodyOptions]
    ) -> Body:
        """A static segment from world point ``a`` to ``b`` (m), rounded by ``radius`` (m, >= 0),
        two-sided. Its body sits at the midpoint, angle 0; it takes the body options but for
        static (always True), kinematic and angle."""
        spec = shapes.segment(a, b, radius)
        return self._add(lambda: spec, spec.centroid, _static_options(options, "add_segment"))

    def add_chain(
        self, points: ArrayLike, *, loop: bool = False, **options: Unpack[PlacedBodyOptions]
    ) -> tuple[Body, ...]:
        """A static chain through ``points`` (m, world; a closed one with ``loop``): one static body
        per segment p_k -> p_k+1, returned as a tuple in that order (remove each to remove it).

        A chain is one-sided, as Box2D's: a segment collides only from its right, the side
        of its normal n_k (the right-hand perpendicular of p_k -> p_k+1): the outside of a
        counter-clockwise loop, the top of a ground listed from right to left. It is also
        smooth: a body sliding along collinear segments meets no bump at the joins, for a
        segment ignores contact normals that belong to its neighbours (their ghost vertices,
        ``collision.rounded``). It takes the body options but static, kinematic and angle.
        """
        loop = check_bool(loop, "loop")
        specs = shapes.chain(points, loop)
        o = _static_options(options, "add_chain")
        body_settings(o)  # checked before any segment is added: a rejected call changes nothing
        if self._bodies.next_uid + len(specs) - 1 > MAX_BODY_UID:
            raise ValueError(f"a world can create at most {MAX_BODY_UID + 1} bodies in its lifetime")
        return tuple(self._add(_given(spec), spec.centroid, o) for spec in specs)

    def _add(self, make_shape: Callable[[], shapes.ShapeSpec], position: ArrayLike, options: BodyOptions) -> Body:
        # validate everything before touching the arrays: a rejected call changes nothing
        x = vec2(position, "position")
        spec = make_shape()
        o = body_settings(options)
        mass, inertia = shapes.mass_properties(spec, o.density)
        index = self._bodies.append(spec, x, mass, inertia, o)
        handle = Body(self, index, int(self._bodies.uid[index]))
        self._handles.append(handle)
        self._pipeline.bodies_changed()  # a new body
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
        self._wake(i)  # its island, and the sleeping islands it touches
        for joint in [q for q in self._joints.handles if i in (q.body_a._index, q.body_b._index)]:
            self._remove_joint(joint)
        self._bodies.delete(i)
        self._handles.pop(i)
        for h in self._handles[i:]:
            h._index -= 1
        item._index = -1
        self._pipeline.forget_contacts()  # their indices no longer match w.bodies
        self._last_step = StepReport().read_only()  # nor does the last step's report
        self._joints.changed()  # the joints name bodies by index
        self._pipeline.bodies_changed()

    # -- joints --------------------------------------------------------------------
    @property
    def joints(self) -> tuple[Joint, ...]:
        """Handles of the joints, in creation order (their rows follow the contact rows)."""
        return tuple(self._joints.handles)

    def _joint_bodies(self, a: Body, b: Body) -> tuple[Body, Body]:
        """The world's handles of a and b, after checking they can be joined."""
        ia, ib = self._own(a, "a"), self._own(b, "b")
        if ia == ib:
            raise ValueError("a and b are the same body: a joint needs two bodies")
        arrays = self._bodies
        if arrays.static[ia] and arrays.static[ib]:
            kinds = sorted({"kinematic" if arrays.kinematic[i] else "static" for i in (ia, ib)})
            both = "both " + kinds[0] if len(kinds) == 1 else "static and kinematic"
            raise ValueError(
                f"a and b are {both}: both have infinite mass, so a joint between them could never act "
                "(join a dynamic body)"
            )
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

    def add_pin_joint(
        self,
        a: Body,
        b: Body,
        *,
        anchor: ArrayLike,
        collide_connected: bool = False,
        motor_speed: float | None = None,
        max_motor_torque: float = 0.0,
        lower: float | None = None,
        upper: float | None = None,
    ) -> PinJoint:
        """Pin a and b together at the world point ``anchor`` (m): they may turn about it.

        With ``motor_speed`` (rad/s) a motor drives omega_b - omega_a toward it with a torque of
        at most ``max_motor_torque`` (N m; |lambda| <= max_motor_torque dt a step). ``lower`` and
        ``upper`` (rad, offsets from theta_b - theta_a now) limit the relative angle. All four
        are settable on the joint afterwards."""
        body_a, body_b = self._joint_bodies(a, b)
        local_a, local_b = self._shared_anchor(body_a, body_b, anchor)
        collide = check_bool(collide_connected, "collide_connected")
        motor = self._motor(motor_speed, max_motor_torque, "max_motor_torque")
        limits = self._limits(lower, upper)
        self._check_joints_supported(self._responder, adding=True)
        theta_0 = body_b.angle - body_a.angle
        return self._add_joint(PinJoint(self, body_a, body_b, local_a, local_b, collide, theta_0, motor, limits))

    def add_slider_joint(
        self,
        a: Body,
        b: Body,
        *,
        anchor: ArrayLike,
        axis: ArrayLike,
        lower: float | None = None,
        upper: float | None = None,
        motor_speed: float | None = None,
        max_motor_force: float = 0.0,
    ) -> SliderJoint:
        """A prismatic joint: b slides relative to a along ``axis`` (a world direction now, kept in
        a's frame, so it turns with a) through the world point ``anchor`` (m), and may not turn
        relative to a. ``lower`` and ``upper`` (m) limit the translation along the axis from
        where b is now; with ``motor_speed`` (m/s) a motor drives it along the axis with a
        force of at most ``max_motor_force`` (N). a and b do not collide with each other."""
        body_a, body_b = self._joint_bodies(a, b)
        local_a, local_b = self._shared_anchor(body_a, body_b, anchor)
        u = vec2(axis, "axis")
        size = float(np.hypot(*u))
        if not size > 1e-12:
            raise ValueError(f"axis must be a nonzero direction (x, y), got {u.tolist()}")
        local_axis = local_anchor(body_a, body_a.position + u / size, "axis")  # u in a's frame
        motor = self._motor(motor_speed, max_motor_force, "max_motor_force")
        limits = self._limits(lower, upper)
        self._check_joints_supported(self._responder, adding=True)
        theta_0 = body_b.angle - body_a.angle
        return self._add_joint(SliderJoint(self, body_a, body_b, local_a, local_b, local_axis, theta_0, motor, limits))

    def add_weld_joint(self, a: Body, b: Body, *, anchor: ArrayLike) -> WeldJoint:
        """Weld b to a at the world point ``anchor`` (m): no relative motion, neither apart nor
        turning (the pin's two rows and the angle row). a and b do not collide with each other."""
        body_a, body_b = self._joint_bodies(a, b)
        local_a, local_b = self._shared_anchor(body_a, body_b, anchor)
        self._check_joints_supported(self._responder, adding=True)
        theta_0 = body_b.angle - body_a.angle
        return self._add_joint(WeldJoint(self, body_a, body_b, local_a, local_b, theta_0))

    def add_mouse_joint(
        self, body: Body, *, target: ArrayLike, max_force: float, hertz: float = 5.0, damping_ratio: float = 0.7
    ) -> MouseJoint:
        """Drag ``body`` by the point of it that lies at ``target`` (m) now toward ``target``,
        which is settable (``joint.target = (x, y)``): Box2D's mouse joint, a soft spring of
        frequency ``hertz`` (Hz) and damping ratio ``damping_ratio`` whose pull is at most
        ``max_force`` (N; |lambda| <= max_force dt a step). The other side is the world."""
        i = self._own(body, "body")
        if self._bodies.static[i]:
            raise ValueError("body must be dynamic: a static or kinematic body cannot be dragged")
        handle = self._handles[i]
        p = vec2(target, "target")
        force = non_negative_float(max_force, "max_force")
        frequency = positive_float(hertz, "hertz")
        zeta = non_negative_float(damping_ratio, "damping_ratio")
        self._check_joints_supported(self._responder, adding=True, mouse=True)
        local = local_anchor(handle, p, "target")
        return self._add_joint(MouseJoint(self, handle, local, p, force, frequency, zeta))

    @staticmethod
    def _shared_anchor(body_a: Body, body_b: Body, anchor: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """The world point ``anchor`` in a's frame and in b's."""
        if anchor is None:
            raise TypeError("anchor must be a pair of numbers (x, y), got None")
        return local_anchor(body_a, anchor, "anchor"), local_anchor(body_b, anchor, "anchor")

    @staticmethod
    def _motor(speed: float | None, max_motor: float, name: str) -> tuple[float | None, float]:
        """(motor_speed or None, the motor's largest torque or force), checked."""
        return optional_limit(speed, "motor_speed"), non_negative_float(max_motor, name)

    @staticmethod
    def _limits(lower: float | None, upper: float | None) -> tuple[float | None, float | None]:
        """(lower, upper), each None or finite, lower <= upper."""
        lower, upper = optional_limit(lower, "lower"), optional_limit(upper, "upper")
        check_limits(lower, upper)
        return lower, upper

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
        self._wake_island_of(joint.body_a._index)
        self._wake_island_of(joint.body_b._index)
        self._joints.add(joint)
        self._pipeline.bodies_changed()  # the pairs it keeps from colliding go
        return joint

    def _remove_joint(self, joint: Joint) -> None:
        if joint._world is not self:
            raise ValueError("joint belongs to another world")
        if not joint.alive:
            raise ValueError("joint was removed from this world")
        self._wake_island_of(joint.body_a._index)
        self._wake_island_of(joint.body_b._index)
        self._joints.remove(joint)
        self._pipeline.bodies_changed()

    def _joint_changed(self, joint: Joint, rows_changed: bool) -> None:
        """A joint's setting changed (``joint.motor_speed = ...``, limits, target, max force): its
        parameters are written into the packed joints in place, or, when its rows changed (a
        motor or a limit added or taken away), the joints are packed anew and its rows start
        from lambda = 0."""
        if rows_changed:
            joint._impulse, joint._offset, joint._has_rows = np.zeros(joint.row_count), None, False
            self._joints.changed()
            return
        self._joints.params_changed(joint)

    # -- one tick ----------------------------------------------------------------
    def clear_forces(self) -> None:
        """Drop every force and torque applied for the next step (``Body.apply_force``,
        ``apply_torque``): the way on when a step was refused for one of them."""
        self._bodies.force[:] = 0.0
        self._bodies.forces_applied = False

    def step(self, dt: float) -> StepReport:
        """Advance the world by dt seconds; returns (and keeps as ``last_step``) the report.

        The pipeline (``phys2d.pipeline``) runs the tick in one kernel call when the responder
        has one and ``one_call_tick`` is set, else stage by stage, with bit-identical results."""
        if type(dt) is not float or not 0.0 < dt < math.inf:  # (a plain positive float passes at once)
            dt = positive_float(dt, "dt")
        if self._islands.some_asleep or self._pipeline.sleep_masks is not None:
            self._islands.before_step(self._settings, dt)
        report = self._pipeline.step(self._settings, self._responder, dt, self._one_call_tick)
        if self._sleep:
            self._islands.after_step(self._settings, dt)
        self._last_step = report
        self.tick += 1
        self.time += dt
        return report

    @property
    def contacts(self) -> Contacts:
        """The contact points of the last step (read-only arrays)."""
        return self._pipeline.contacts()

    @property
    def last_step(self) -> StepReport:
        """What the last step did (``StepReport``; read-only arrays)."""
        return self._last_step

    # -- sleeping (``phys2d.sleep``: the islands, their rest and their waking) ---------------
    def _wake_island_of(self, i: int) -> None:
        """Wake body i's island, if it sleeps."""
        if self._islands.some_asleep:
            self._islands.wake_island_of(i)

    def _wake(self, i: int) -> None:
        """Wake body i's island and the sleeping islands within contact_margin of its shape."""
        if self._islands.some_asleep:
            self._islands.wake_near(i, self._settings.contact_margin)

    def _put_to_sleep(self, i: int) -> None:
        """Body i's island sleeps now (``Body.awake = False``)."""
        self._islands.put_to_sleep(i, self._settings.contact_margin)

    # -- queries -------------------------------------------------------------------------
    # Each reads the bodies where they are now (between steps: where the last step left them).
    def ray_cast(self, start: ArrayLike, end: ArrayLike) -> list[RayHit]:
        """The bodies the segment from ``start`` to ``end`` (m) enters, nearest first: one
        ``RayHit`` per body (where the ray first enters its shape: ``point``, the unit outward
        ``normal`` there, and ``fraction`` t in [0, 1] with point = start + t (end - start)),
        sorted by fraction, equal fractions in creation order.

        As in Box2D, a ray that starts inside a shape (or on its surface) does not hit that
        shape: cast from a point on a body's surface, it finds what lies beyond (``query_point``
        tells which bodies hold a point). A ray of length 0 hits nothing."""
        p_start, p_end = vec2(start, "start"), vec2(end, "end")
        n = self._bodies.n
        fraction, normal = np.empty(n), np.empty((n, 2))
        queries.ray_cast_bodies(queries.geometry(self._bodies), p_start, p_end, fraction, normal)
        hit = np.flatnonzero(fraction <= 1.0)
        hit = hit[np.argsort(fraction[hit], kind="stable")]
        d = p_end - p_start
        return [RayHit(self._handles[i], p_start + fraction[i] * d, normal[i].copy(), float(fraction[i])) for i in hit]

    def query_point(self, point: ArrayLike) -> list[Body]:
        """The bodies whose shape holds ``point`` (m), its surface included, in creation order."""
        p = vec2(point, "point")
        inside = np.zeros(self._bodies.n, np.bool_)
        queries.bodies_containing(queries.geometry(self._bodies), p, inside)
        return [self._handles[i] for i in np.flatnonzero(inside)]

    def query_aabb(self, lower: ArrayLike, upper: ArrayLike) -> list[Body]:
        """The bodies whose shape's axis-aligned bounding box overlaps the box from ``lower`` to
        ``upper`` (m; corners (min x, min y) and (max x, max y)), touching included, in creation
        order. As Box2D's b2World_OverlapAABB, it tests the shapes' boxes (tight, as the bodies
        are now), not the shapes: a body near a corner of the box may be returned though its
        shape lies outside it."""
        lo, hi = vec2(lower, "lower"), vec2(upper, "upper")
        if np.any(lo > hi):
            raise ValueError(f"lower must be <= upper in x and in y, got lower={lo.tolist()}, upper={hi.tolist()}")
        aabb = np.empty((self._bodies.n, 4))
        queries.tight_aabbs(queries.geometry(self._bodies), aabb)
        overlap = (aabb[:, 0] <= hi[0]) & (aabb[:, 1] <= hi[1]) & (aabb[:, 2] >= lo[0]) & (aabb[:, 3] >= lo[1])
        return [self._handles[i] for i in np.flatnonzero(overlap)]

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
        return float(-np.sum(b.mass[dyn] * (b.x[dyn] @ self._settings.gravity)))

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
    body_uids = _read_only_view(
        "uid", "(N,) int64 uid of each body: unique in the world's lifetime, kept through removals."
    )
    body_static = _read_only_view(
        "static", "(N,) bool, True for bodies of infinite mass (M^-1 = 0): static and kinematic ones."
    )
    body_kinds = _read_only_view(
        "kind",
        "(N,) int32 shape kind of each body: ``phys2d.shapes.CIRCLE``, ``POLYGON``, ``CAPSULE``, ``SEGMENT`` "
        "or ``CHAIN``.",
    )
    body_radii = _read_only_view(
        "radius", "(N,) float64 circle radius, or a capsule's or segment's rounding, of each body, m (0 for polygons)."
    )
    body_masses = _read_only_view("mass", "(N,) float64 mass m of each body, kg (also for static bodies).")
    body_inertias = _read_only_view(
        "inertia", "(N,) float64 moment of inertia I of each body about its centre of mass, kg m^2."
    )

    @property
    def body_asleep(self) -> np.ndarray:
        """(N,) bool, True for the bodies that sleep now (``Body.awake`` is False for them), a copy."""
        return self._bodies.island >= 0

    vertex_start = _read_only_view("vstart", "(N,) int32 first row of each body's polygon in ``local_vertices``.")
    vertex_count = _read_only_view(
        "vcount", "(N,) int32 number of polygon vertices of each body (0 for circles, 2 for capsules and segments)."
    )
    local_vertices = _read_only_view(
        "local_v",
        "(V, 2) float64 every polygon vertex in its body's frame, m, counter-clockwise; body i's are rows "
        "``vertex_start[i] : vertex_start[i] + vertex_count[i]`` (a chain segment's two ghost vertices, its "
        "neighbours' far ends, follow them).",
    )

    # -- snapshots (``phys2d.snapshot``: the format, what the hash covers) ---------------------------
    def _parts(self) -> WorldParts:
        """What the world's state is made of, for ``phys2d.snapshot`` to read (and to put back,
        ``_put_parts``): its one way into the world."""
        return WorldParts(
            self._bodies, self._handles, self._joints, self._pipeline, self._islands, self._settings, self._responder,
            self._last_step, self._sleep, self._one_call_tick,
        )  # fmt: skip

    def _put_parts(self, parts: WorldParts) -> None:
        """Take ``parts`` (a snapshot's, built and checked) as the world's state; nothing refuses here."""
        (
            self._bodies, self._handles, self._joints, self._pipeline, self._islands, self._settings, self._responder,
            self._last_step, self._sleep, self._one_call_tick,
        ) = parts  # fmt: skip

    def snapshot(self) -> bytes:
        """The world's live state as bytes, between steps (``phys2d.snapshot.snapshot``)."""
        from .snapshot import snapshot

        return snapshot(self)

    def restore(self, data: bytes) -> None:
        """Put a snapshot's state back in place; a bad image is refused, the world unchanged
        (``phys2d.snapshot.restore``)."""
        from .snapshot import restore

        restore(self, data)

    @classmethod
    def from_snapshot(cls, data: bytes) -> World:
        """A new World holding a snapshot's state (``phys2d.snapshot.from_snapshot``)."""
        from .snapshot import from_snapshot

        return from_snapshot(data)

    def state_hash(self) -> int:
        """A 64-bit hash of everything that decides the future, the tick included
        (``phys2d.snapshot.state_hash``)."""
        from .snapshot import state_hash

        return state_hash(self)

    def __repr__(self) -> str:
        n = self._bodies.n
        n_static = int(self._bodies.static.sum())
        return (
            f"<World: {n} bodies ({n_static} static), gravity=({self._settings.gravity[0]:g}, "
            f"{self._settings.gravity[1]:g}) m/s^2, responder={self._responder!r}, t={self.time:.4g} s>"
        )


__all__ = ["SimulationError", "World"]
