"""The World: owns the body arrays and runs one tick of the pipeline.

    external forces -> collision -> cache matching -> constraint rows
                    -> responder -> integration

Each stage lives in its own module; ``World.step`` is the pipeline in one screen.
"""

from __future__ import annotations

import math

import numpy as np

from . import shapes
from .bodies import Body, BodyArrays
from .collision.broadphase import sweep_and_prune, update_geometry
from .collision.narrowphase import collide_pairs
from .constraints.rows import FRICTION_LECTURE, Rows, contact_rows
from .contacts import ContactCache, Contacts, contact_keys
from .integrate import apply_external_forces, integrate_positions
from .responders.base import Responder, StepContext, StepReport
from .responders.pgs import PGS
from .shapes import finite_float, positive_float, vec2


class SimulationError(RuntimeError):
    """A step produced velocities past the world's limits; the world was left as before it."""


def _check_bool(value, name: str) -> bool:
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name} must be True or False, got {value!r}")
    return bool(value)


class World:
    """A 2D world of rigid bodies.

    gravity     (m/s^2), default (0, -10)
    responder   the collision responder, default ``PGS()``; swappable between steps
    contact_margin  surfaces closer than this (m) already make contact points
                (speculative contacts, separation > 0), so resting contacts do not
                flicker on and off; 0 gives contacts only where shapes overlap
    max_speed   a step that leaves any body faster than this (m/s, or rad/s for
                spin) raises SimulationError and is undone
    """

    def __init__(self, gravity=(0.0, -10.0), responder: Responder | None = None, *,
                 contact_margin: float = 0.02, max_speed: float = 1e4) -> None:
        self._gravity = vec2(gravity, "gravity")
        self._responder = self._check_responder(PGS() if responder is None else responder)
        self.contact_margin = finite_float(contact_margin, "contact_margin")
        if self.contact_margin < 0.0:
            raise ValueError(f"contact_margin must be >= 0, got {self.contact_margin}")
        self._max_speed = positive_float(max_speed, "max_speed")
        self._bodies = BodyArrays()
        self._handles: list[Body] = []
        self._cache = ContactCache()
        self._excluded = np.zeros(0, np.int64)  # sorted pair keys that must not collide
        self._pairs = np.zeros((64, 2), np.int32)
        self.contacts = Contacts()
        self.last_step = StepReport()
        self.tick = 0
        self.time = 0.0

    # -- configuration ------------------------------------------------------
    @staticmethod
    def _check_responder(responder) -> Responder:
        if not isinstance(responder, Responder):
            raise TypeError(
                f"responder must be a phys2d responder such as phys2d.PGS(), got {responder!r}")
        return responder

    @property
    def responder(self) -> Responder:
        return self._responder

    @responder.setter
    def responder(self, value: Responder) -> None:
        self._responder = self._check_responder(value)

    @property
    def gravity(self) -> np.ndarray:
        """Gravity g (m/s^2), a copy."""
        return self._gravity.copy()

    @gravity.setter
    def gravity(self, value) -> None:
        self._gravity = vec2(value, "gravity")

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
    def add_box(self, position=(0.0, 0.0), half_extents=(0.5, 0.5), angle=0.0, density=1.0,
                friction=0.6, restitution=0.0, static=False, velocity=(0.0, 0.0),
                angular_velocity=0.0) -> Body:
        """A box of half extents (hx, hy) in m centred at ``position``, rotated by ``angle`` (rad)."""
        return self._add(shapes.box(half_extents), position, angle, density, friction,
                         restitution, static, velocity, angular_velocity)

    def add_circle(self, position=(0.0, 0.0), radius=0.5, angle=0.0, density=1.0, friction=0.6,
                   restitution=0.0, static=False, velocity=(0.0, 0.0),
                   angular_velocity=0.0) -> Body:
        """A circle of ``radius`` (m) centred at ``position``."""
        return self._add(shapes.circle(radius), position, angle, density, friction, restitution,
                         static, velocity, angular_velocity)

    def add_polygon(self, position=(0.0, 0.0), vertices=(), angle=0.0, density=1.0,
                    friction=0.6, restitution=0.0, static=False, velocity=(0.0, 0.0),
                    angular_velocity=0.0) -> Body:
        """A convex polygon: ``vertices`` counter-clockwise in the body frame (m).

        The vertices are re-centred on their centroid, which is placed at
        ``position``: a body's position is always its centre of mass.
        """
        return self._add(shapes.polygon(vertices), position, angle, density, friction,
                         restitution, static, velocity, angular_velocity)

    def _add(self, spec, position, angle, density, friction, restitution, static, velocity,
             angular_velocity) -> Body:
        # validate everything before touching the arrays: a rejected call changes nothing
        x = vec2(position, "position")
        theta = finite_float(angle, "angle")
        density = positive_float(density, "density")
        friction = finite_float(friction, "friction")
        if friction < 0.0:
            raise ValueError(f"friction must be >= 0, got {friction}")
        restitution = finite_float(restitution, "restitution")
        if not 0.0 <= restitution <= 1.0:
            raise ValueError(f"restitution must be in [0, 1], got {restitution}")
        static = _check_bool(static, "static")
        v = vec2(velocity, "velocity")
        omega = finite_float(angular_velocity, "angular_velocity")
        mass, inertia = shapes.mass_properties(spec, density)
        index = self._bodies.append(spec, x, theta, (v[0], v[1], omega), mass, inertia, friction,
                                    restitution, static)
        handle = Body(self, index, int(self._bodies.uid[index]))
        self._handles.append(handle)
        return handle

    def _own(self, body, name: str = "body") -> int:
        """The index of ``body`` after checking it is a live body of this world."""
        if not isinstance(body, Body):
            raise TypeError(f"{name} must be a phys2d Body, got {type(body).__name__}")
        if body._world is not self:
            raise ValueError(f"{name} belongs to another world")
        if body._index < 0:
            raise ValueError(f"{name} was removed from this world")
        return body._index

    def remove(self, body: Body) -> None:
        """Remove a body; its handle becomes unusable and later indices shift down by one."""
        i = self._own(body)
        self._bodies.delete(i)
        self._handles.pop(i)
        for h in self._handles[i:]:
            h._index -= 1
        body._index = -1
        self.contacts = Contacts()  # its indices no longer match w.bodies

    # -- one tick ----------------------------------------------------------------
    def step(self, dt: float) -> StepReport:
        """Advance the world by dt seconds; returns (and keeps as ``last_step``) the report."""
        dt = positive_float(dt, "dt")
        b = self._bodies
        x, theta, V, M_inv = b.x, b.theta, b.V, b.M_inv
        responder = self._responder
        before = b.snapshot()
        try:
            V1 = V.copy()
            apply_external_forces(V, M_inv, self._gravity, dt)
            c = self._collide()
            hit, lam_n, lam_t = self._cache.match(c.key)
            if not responder.warm_start:
                hit[:] = False
            rows = self._build_rows(c, V1, dt)
            if responder.warm_start:
                rows.lam[0 : 2 * len(c) : 2] = lam_n
                rows.lam[1 : 2 * len(c) : 2] = lam_t
            ctx = StepContext(dt, x, theta, V, V1, M_inv, rows, len(c), c.body_a, c.body_b, c.point,
                              c.normal, c.separation, c.restitution)
            result = responder.respond(ctx)
            if not result.integrated:
                integrate_positions(x, theta, V, dt)
            self._check_limits()
        except BaseException:
            b.restore(before)
            raise
        k = len(c)
        c.normal_impulse = rows.lam[0 : 2 * k : 2].copy()
        c.tangent_impulse = rows.lam[1 : 2 * k : 2].copy()
        c.warm_started = hit
        self._cache.store(c.key, c.normal_impulse, c.tangent_impulse)
        self.contacts = c
        self.last_step = StepReport(
            responder=responder.name, dt=dt, iterations=result.iterations,
            residuals=result.residuals,
            max_penetration=float(max(0.0, -c.separation.min())) if k else 0.0,
            contact_count=k, cache_hits=int(hit.sum()),
            joint_impulses=rows.lam[2 * k :].copy(), system=result.system)
        self.tick += 1
        self.time += dt
        return self.last_step

    def _collide(self) -> Contacts:
        """Broadphase and narrowphase at the current positions: this step's contacts."""
        b = self._bodies
        n = b.n
        world_v = np.empty((b.n_verts, 2))
        world_n = np.empty((b.n_verts, 2))
        aabb = np.empty((n, 4))
        update_geometry(b.x, b.theta, b.kind, b.radius, b.vstart, b.vcount, b.local_v, b.local_n,
                        self.contact_margin, world_v, world_n, aabb)
        n_pairs = sweep_and_prune(aabb, b.static, self._excluded, self._pairs)
        if n_pairs < 0:  # the pair buffer was too small: grow it and sweep again
            self._pairs = np.zeros((2 * -n_pairs, 2), np.int32)
            n_pairs = sweep_and_prune(aabb, b.static, self._excluded, self._pairs)
        cap = 2 * n_pairs
        body_a = np.empty(cap, np.int32)
        body_b = np.empty(cap, np.int32)
        point = np.empty((cap, 2))
        normal = np.empty((cap, 2))
        separation = np.empty(cap)
        feature = np.empty(cap, np.int32)
        k = collide_pairs(self._pairs, n_pairs, b.x, b.kind, b.radius, b.vstart, b.vcount,
                          world_v, world_n, self.contact_margin, body_a, body_b, point, normal,
                          separation, feature)
        body_a, body_b = body_a[:k], body_b[:k]
        feature = feature[:k]
        return Contacts(
            body_a=body_a, body_b=body_b, point=point[:k], normal=normal[:k],
            separation=separation[:k], feature=feature,
            key=contact_keys(b.uid, body_a, body_b, feature),
            friction=np.sqrt(b.friction[body_a]) * np.sqrt(b.friction[body_b]),  # no overflow
            restitution=np.maximum(b.restitution[body_a], b.restitution[body_b]))

    def _build_rows(self, c: Contacts, V1: np.ndarray, dt: float) -> Rows:
        """Constraint rows for this step's contacts (2 per point)."""
        b = self._bodies
        r = self._responder
        k = len(c)
        rows = Rows(2 * k)
        if r.friction_model == FRICTION_LECTURE:
            pair = (c.body_a.astype(np.int64) << 32) | c.body_b
            _, inverse, counts = np.unique(pair, return_inverse=True, return_counts=True)
            points_in_manifold = counts[inverse].astype(np.float64)
        else:
            points_in_manifold = np.ones(k)
        contact_rows(c.body_a, c.body_b, c.point, c.normal, c.separation, c.friction,
                     c.restitution, b.x, V1, b.M_inv, dt, r.beta, r.slop,
                     r.restitution_threshold, r.friction_model,
                     float(math.hypot(*self._gravity)), points_in_manifold,
                     rows.i, rows.j, rows.J, rows.JM, rows.A_diag, rows.xi, rows.lo, rows.hi,
                     rows.bound_row, rows.mu, rows.kind)
        return rows

    def _check_limits(self) -> None:
        b = self._bodies
        V = b.V
        speed = np.hypot(V[:, 0], V[:, 1])
        # a finite velocity times a huge dt can still overflow x or theta
        bad = ~(np.isfinite(speed) & (speed <= self._max_speed)
                & np.isfinite(V[:, 2]) & (np.abs(V[:, 2]) <= self._max_speed)
                & np.isfinite(b.x).all(axis=1) & np.isfinite(b.theta))
        if bad.any():
            idx = np.flatnonzero(bad)
            shown = ", ".join(str(i) for i in idx[:10]) + (" ..." if idx.size > 10 else "")
            raise SimulationError(
                f"step would leave bodies [{shown}] faster than max_speed={self._max_speed:g} "
                "(m/s or rad/s) or with a non-finite state; the world was left as it was before the step")

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

    def angular_momentum(self, about=(0.0, 0.0)) -> float:
        """Sum of I omega + (x - about) x m v over dynamic bodies (kg m^2/s)."""
        o = vec2(about, "about")
        b = self._bodies
        dyn = ~b.static
        r = b.x[dyn] - o
        m = b.mass[dyn]
        v = b.V[dyn]
        return float(np.sum(b.inertia[dyn] * v[:, 2] + m * (r[:, 0] * v[:, 1] - r[:, 1] * v[:, 0])))

    def __repr__(self) -> str:
        n = self._bodies.n
        n_static = int(self._bodies.static.sum())
        return (f"<World: {n} bodies ({n_static} static), gravity=({self._gravity[0]:g}, "
                f"{self._gravity[1]:g}) m/s^2, responder={self._responder!r}, t={self.time:.4g} s>")
