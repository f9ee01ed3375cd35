"""Scenes and engine adapters for the peer benchmark (issue 7).

Every engine sits behind the same tiny interface: ``build(scene)`` returns an
object with

- ``step()``: advance one fixed step of ``DT``;
- ``positions()``: (N, 2) centres of the dynamic boxes, in scene order;
- ``angles()``: (N,) angles of the dynamic boxes, in scene order;
- ``velocities()``: (N, 2) linear velocities of the dynamic boxes (m/s), in scene order
  (phys2d and Box2D v3 only);
- ``contact_count()``: contact points of the last step;
- ``max_overlap()``: deepest overlap (>= 0, metres) among those contact points,
  read from the engine's own contact data;
- ``joint_gaps()``: (J,) distance between the two anchor points of each pin
  joint, in scene order (m);
- ``close()``: release anything the adapter holds (recordings).

The scenes are plain data (``Scene``), so each engine builds exactly the same
bodies in the same order: the ground, the static pivots, the dynamic boxes,
then the pin joints. Units are SI throughout.
"""

from __future__ import annotations

import ctypes
import math
from dataclasses import dataclass, field

import numpy as np

GRAVITY = (0.0, -10.0)
DT = 1.0 / 60.0
ITERATIONS = 10  # solver (velocity) iterations in every engine
BOX2D_POSITION_ITERATIONS = 3
FRICTION = 0.6  # the friction every pair of shapes must end up with
RESTITUTION = 0.0

# The static ground: 200 m wide, 1 m thick, top face at y = 0.
GROUND_CENTER = (0.0, -0.5)
GROUND_HALF = (100.0, 0.5)


@dataclass(frozen=True)
class Box:
    """A dynamic box: centre, half extents and density (kg/m^2)."""

    x: float
    y: float
    hw: float
    hh: float
    density: float = 1.0

    @property
    def mass(self) -> float:
        return 4.0 * self.hw * self.hh * self.density


@dataclass(frozen=True)
class Pivot:
    """A static circle: centre and radius (m), something to hang a chain from."""

    x: float
    y: float
    radius: float


def pivot_ref(k: int) -> int:
    """How a Pin names ``Scene.pivots[k]`` (boxes are named by their index >= 0)."""
    return -1 - k


@dataclass(frozen=True)
class Pin:
    """A pin (revolute) joint holding body a's and body b's points at (x, y) together.

    a, b: an index into ``Scene.boxes``, or ``pivot_ref(k)`` for ``Scene.pivots[k]``.
    Joined bodies do not collide with each other.
    """

    a: int
    b: int
    x: float
    y: float


@dataclass(frozen=True)
class Scene:
    name: str
    boxes: tuple[Box, ...] = field(default_factory=tuple)
    pivots: tuple[Pivot, ...] = field(default_factory=tuple)
    pins: tuple[Pin, ...] = field(default_factory=tuple)

    def start(self) -> np.ndarray:
        return np.array([(b.x, b.y) for b in self.boxes], dtype=float)


def vertical_stack(n: int, lean: float = 0.0, name: str | None = None) -> Scene:
    """n touching 1 m boxes; box k centred at (lean * k, 0.5 + k), lean in m."""
    boxes = tuple(Box(lean * k, 0.5 + k, 0.5, 0.5) for k in range(n))
    return Scene(name or f"vertical_stack_{n}", boxes)


def pyramid(rows: int) -> Scene:
    """Row r (0 = bottom) holds rows - r touching 1 m boxes centred on x = 0."""
    boxes = []
    for r in range(rows):
        count = rows - r
        for i in range(count):
            boxes.append(Box(i - 0.5 * (count - 1), 0.5 + r, 0.5, 0.5))
    return Scene(f"pyramid_{rows}", tuple(boxes))


def mass_ratio_100() -> Scene:
    """A 1 kg, 0.5 m box on the ground under a 100 kg, 1 m box.

    Densities are picked so the masses are exact: 0.25 m^2 * 4 = 1 kg and
    1 m^2 * 100 = 100 kg.
    """
    small = Box(0.0, 0.25, 0.25, 0.25, density=4.0)
    big = Box(0.0, 0.5 + 0.5, 0.5, 0.5, density=100.0)
    assert small.mass == 1.0 and big.mass == 100.0
    return Scene("mass_ratio_100", (small, big))


def heavy_chain(links: int = 20, ratio: float = 100.0, link_length: float = 0.5) -> Scene:
    """``links`` boxes pinned end to end from a static pivot, carrying a box ``ratio``
    times a link's mass; as ``phys2d.scenes.heavy_chain``.

    Links are link_length x link_length / 4 boxes of density 1; the chain starts
    straight out to the right of the pivot, at height (links + 1) * link_length + 1 m,
    and swings down. The heavy box (side link_length) is pinned at its left edge
    to the free end of the last link.
    """
    top = (links + 1) * link_length + 1.0
    hw, hh = 0.5 * link_length, 0.125 * link_length
    boxes = [Box((k + 0.5) * link_length, top, hw, hh) for k in range(links)]
    h = 0.5 * link_length
    link_mass = 4.0 * hw * hh
    boxes.append(Box(links * link_length + h, top, h, h, density=ratio * link_mass / (4.0 * h * h)))
    pins = [Pin(pivot_ref(0) if k == 0 else k - 1, k, k * link_length, top) for k in range(links + 1)]
    name = f"heavy_chain_{links}" + ("" if ratio == 100.0 else f"_ratio_{ratio:g}")
    return Scene(name, tuple(boxes), (Pivot(0.0, top, 0.05),), tuple(pins))


SCENES = {
    "vertical_stack_10": lambda: vertical_stack(10),
    "vertical_stack_20": lambda: vertical_stack(20),
    # box k shifted sideways by lean * k: symmetry no longer holds the stack up (issue 11)
    "vertical_stack_20_lean_0.1mm": lambda: vertical_stack(20, 1e-4, "vertical_stack_20_lean_0.1mm"),
    "vertical_stack_20_lean_1mm": lambda: vertical_stack(20, 1e-3, "vertical_stack_20_lean_1mm"),
    "pyramid_10": lambda: pyramid(10),
    "pyramid_20": lambda: pyramid(20),
    "pyramid_40": lambda: pyramid(40),
    "mass_ratio_100": mass_ratio_100,
    "heavy_chain_20": lambda: heavy_chain(20),
}


class Unsupported(Exception):
    """An engine (or phys2d responder) that cannot build a scene: the cell reads the message."""


# --------------------------------------------------------------------------
# pymunk (Chipmunk 7)
# --------------------------------------------------------------------------


class PymunkAdapter:
    """pymunk: iterations 10, sleeping off (the default), default collision_slop.

    Chipmunk multiplies the two shapes' friction coefficients, so each shape
    gets sqrt(0.6) and every pair ends up with 0.6.
    """

    name = "pymunk"

    def __init__(self, scene: Scene, collision_slop: float | None = None):
        import pymunk

        space = pymunk.Space()
        space.gravity = GRAVITY
        space.iterations = ITERATIONS
        space.sleep_time_threshold = math.inf  # sleeping off
        if collision_slop is not None:
            space.collision_slop = collision_slop
        mu = math.sqrt(FRICTION)

        ground = pymunk.Body(body_type=pymunk.Body.STATIC)
        ground.position = GROUND_CENTER
        gshape = pymunk.Poly.create_box(ground, (2 * GROUND_HALF[0], 2 * GROUND_HALF[1]))
        gshape.friction = mu
        gshape.elasticity = RESTITUTION
        space.add(ground, gshape)

        pivots = []
        for p in scene.pivots:
            body = pymunk.Body(body_type=pymunk.Body.STATIC)
            body.position = (p.x, p.y)
            shape = pymunk.Circle(body, p.radius)
            shape.friction = mu
            shape.elasticity = RESTITUTION
            space.add(body, shape)
            pivots.append(body)
        self.bodies = []
        for box in scene.boxes:
            body = pymunk.Body()
            body.position = (box.x, box.y)
            shape = pymunk.Poly.create_box(body, (2 * box.hw, 2 * box.hh))
            shape.density = box.density  # mass and moment follow from the shape
            shape.friction = mu
            shape.elasticity = RESTITUTION
            space.add(body, shape)
            self.bodies.append(body)
        self.joints = []
        for pin in scene.pins:
            a, b = (self.bodies[r] if r >= 0 else pivots[-1 - r] for r in (pin.a, pin.b))
            joint = pymunk.PivotJoint(a, b, (pin.x, pin.y))
            joint.collide_bodies = False
            space.add(joint)
            self.joints.append(joint)
        self.space = space
        self._step = space.step

    def step(self) -> None:
        self._step(DT)

    def positions(self) -> np.ndarray:
        return np.array([tuple(b.position) for b in self.bodies], dtype=float)

    def angles(self) -> np.ndarray:
        return np.array([b.angle for b in self.bodies], dtype=float)

    def _arbiter_distances(self) -> list[float]:
        # A body's arbiter list holds exactly the arbiters of the last step;
        # an arbiter between two dynamic boxes shows up on both, so dedupe.
        seen: set[tuple[int, int]] = set()
        dists: list[float] = []

        def visit(arb):
            a, b = arb.shapes
            key = (min(id(a), id(b)), max(id(a), id(b)))
            if key in seen:
                return
            seen.add(key)
            dists.extend(p.distance for p in arb.contact_point_set.points)

        for body in self.bodies:
            body.each_arbiter(visit)
        return dists

    def contact_count(self) -> int:
        return len(self._arbiter_distances())

    def max_overlap(self) -> float:
        d = self._arbiter_distances()
        return max(0.0, -min(d)) if d else 0.0

    def joint_gaps(self) -> np.ndarray:
        gaps = []
        for j in self.joints:
            pa = j.a.local_to_world(j.anchor_a)
            pb = j.b.local_to_world(j.anchor_b)
            gaps.append(math.hypot(pb.x - pa.x, pb.y - pa.y))
        return np.array(gaps, dtype=float)

    def close(self) -> None:
        pass


# --------------------------------------------------------------------------
# Box2D 2.3 (pybox2d)
# --------------------------------------------------------------------------


class Box2DAdapter:
    """Box2D 2.3: Step(dt, 10, 3), sleeping off, defaults otherwise.

    Box2D mixes friction as sqrt(mu_a * mu_b), so 0.6 per fixture gives 0.6.
    """

    name = "Box2D"

    def __init__(self, scene: Scene):
        import Box2D

        world = Box2D.b2World(gravity=GRAVITY, doSleep=False)
        world.SetAllowSleeping(False)
        ground = world.CreateStaticBody(position=GROUND_CENTER)
        ground.CreatePolygonFixture(box=GROUND_HALF, density=0.0, friction=FRICTION, restitution=RESTITUTION)
        pivots = []
        for p in scene.pivots:
            body = world.CreateStaticBody(position=(p.x, p.y))
            body.CreateCircleFixture(radius=p.radius, density=0.0, friction=FRICTION, restitution=RESTITUTION)
            pivots.append(body)
        self.bodies = []
        for box in scene.boxes:
            body = world.CreateDynamicBody(position=(box.x, box.y), angle=0.0, allowSleep=False)
            body.CreatePolygonFixture(
                box=(box.hw, box.hh),
                density=box.density,
                friction=FRICTION,
                restitution=RESTITUTION,
            )
            self.bodies.append(body)
        self.joints = []
        for pin in scene.pins:
            a, b = (self.bodies[r] if r >= 0 else pivots[-1 - r] for r in (pin.a, pin.b))
            self.joints.append(
                world.CreateRevoluteJoint(bodyA=a, bodyB=b, anchor=(pin.x, pin.y), collideConnected=False)
            )
        self.world = world
        self._step = world.Step

    def step(self) -> None:
        self._step(DT, ITERATIONS, BOX2D_POSITION_ITERATIONS)

    def positions(self) -> np.ndarray:
        return np.array([tuple(b.position) for b in self.bodies], dtype=float)

    def angles(self) -> np.ndarray:
        return np.array([b.angle for b in self.bodies], dtype=float)

    def _separations(self) -> list[float]:
        # pybox2d's b2WorldManifold does not expose ``separations``, so work them
        # out the way Box2D defines them: distance from the reference face to each
        # clip point along the face normal, less both shapes' skin radii.
        seps: list[float] = []
        for c in self.world.contacts:
            if not c.touching:
                continue
            m = c.manifold
            n_pts = m.pointCount
            if n_pts == 0:
                continue
            fa, fb = c.fixtureA, c.fixtureB
            radii = fa.shape.radius + fb.shape.radius
            if m.type_ == m.e_faceA:
                ref, inc = fa.body, fb.body
            elif m.type_ == m.e_faceB:
                ref, inc = fb.body, fa.body
            else:  # circles: not used by these scenes
                continue
            normal = ref.GetWorldVector(m.localNormal)
            plane = ref.GetWorldPoint(m.localPoint)
            for i in range(n_pts):
                clip = inc.GetWorldPoint(m.points[i].localPoint)
                seps.append((clip.x - plane.x) * normal.x + (clip.y - plane.y) * normal.y - radii)
        return seps

    def contact_count(self) -> int:
        return sum(c.manifold.pointCount for c in self.world.contacts if c.touching)

    def max_overlap(self) -> float:
        s = self._separations()
        return max(0.0, -min(s)) if s else 0.0

    def joint_gaps(self) -> np.ndarray:
        gaps = []
        for j in self.joints:
            pa, pb = j.anchorA, j.anchorB  # world points
            gaps.append(math.hypot(pb[0] - pa[0], pb[1] - pa[1]))
        return np.array(gaps, dtype=float)

    def close(self) -> None:
        pass


# --------------------------------------------------------------------------
# Box2D v3 (built from the user's source tree by box2d_v3.py, through ctypes)
# --------------------------------------------------------------------------

V3_SUBSTEPS = 4  # Box2D v3's own default


def load_box2d_v3(path) -> ctypes.CDLL:
    """The harness library built by ``box2d_v3.build``, with its argument types declared."""
    lib = ctypes.CDLL(str(path))
    h, d, i = ctypes.c_void_p, ctypes.c_double, ctypes.c_int
    pd, pi = ctypes.POINTER(ctypes.c_double), ctypes.POINTER(ctypes.c_int)
    signatures = {
        "harness_box2d_version": (i, []),
        "harness_noop": (None, [h]),
        "harness_create": (h, [d, d, i]),
        "harness_destroy": (None, [h]),
        "harness_add_box": (i, [h, d, d, d, d, d, d, d, i]),
        "harness_add_circle": (i, [h, d, d, d, d, d, d, i]),
        "harness_add_pin": (i, [h, i, i, d, d]),
        "harness_step": (None, [h, d]),
        "harness_read": (None, [h, pi, i, pd, pd]),
        "harness_velocities": (None, [h, pi, i, pd]),
        "harness_contacts": (i, [h, pd]),
        "harness_joint_gaps": (None, [h, pd]),
        "harness_set_recycle_distance": (None, [h, d]),
        "harness_manifold_points": (i, [h, i, pi, pd]),
    }
    for name, (res, args) in signatures.items():
        f = getattr(lib, name)
        f.restype = res
        f.argtypes = args
    return lib


def box2d_v3_version(lib: ctypes.CDLL) -> str:
    v = lib.harness_box2d_version()
    return f"{v // 10000}.{v // 100 % 100}.{v % 100}"


class Box2DV3Adapter:
    """Box2D v3: b2World_Step(dt, substeps), sleeping off, one worker, defaults otherwise.

    Box2D v3's defaults: soft step with relaxation, contact hertz 30, damping ratio
    10, push-out speed 3 m/s, continuous collision, contact recycling. Friction is
    mixed as sqrt(mu_a * mu_b), so 0.6 per shape gives 0.6. Its polygons have no
    skin (radius 0). Positions and angles are float32 inside Box2D.
    """

    name = "Box2D-v3"

    def __init__(self, scene: Scene, lib: ctypes.CDLL, substeps: int = V3_SUBSTEPS):
        self._lib = lib
        h = lib.harness_create(GRAVITY[0], GRAVITY[1], substeps)
        if not h:
            raise MemoryError("harness_create failed")
        self._h = h

        def check(index: int) -> int:
            if index < 0:
                raise MemoryError("the Box2D v3 harness could not grow its arrays")
            return index

        check(lib.harness_add_box(h, *GROUND_CENTER, *GROUND_HALF, 1.0, FRICTION, RESTITUTION, 0))
        pivots = [
            check(lib.harness_add_circle(h, p.x, p.y, p.radius, 1.0, FRICTION, RESTITUTION, 0)) for p in scene.pivots
        ]
        bodies = [
            check(lib.harness_add_box(h, b.x, b.y, b.hw, b.hh, b.density, FRICTION, RESTITUTION, 1))
            for b in scene.boxes
        ]
        for pin in scene.pins:
            a, b = (bodies[r] if r >= 0 else pivots[-1 - r] for r in (pin.a, pin.b))
            check(lib.harness_add_pin(h, a, b, pin.x, pin.y))
        self._n_joints = len(scene.pins)
        n = len(bodies)
        self._index = np.array(bodies, dtype=np.int32)
        self._xy = np.zeros((n, 2))
        self._angle = np.zeros(n)
        self._args = (
            self._index.ctypes.data_as(ctypes.POINTER(ctypes.c_int)),
            n,
            self._xy.ctypes.data_as(ctypes.POINTER(ctypes.c_double)),
            self._angle.ctypes.data_as(ctypes.POINTER(ctypes.c_double)),
        )
        self._step = lib.harness_step
        self._noop = lib.harness_noop

    def step(self) -> None:
        self._step(self._h, DT)

    def noop(self) -> None:
        """The same Python and ctypes path as ``step``, into a C function that does nothing."""
        self._noop(self._h)

    def _read(self) -> None:
        self._lib.harness_read(self._h, *self._args)

    def positions(self) -> np.ndarray:
        self._read()
        return self._xy.copy()

    def angles(self) -> np.ndarray:
        self._read()
        return self._angle.copy()

    def velocities(self) -> np.ndarray:
        """(N, 2) linear velocities of the dynamic boxes, m/s."""
        v = np.zeros((self._xy.shape[0], 2))
        self._lib.harness_velocities(
            self._h, self._args[0], self._args[1], v.ctypes.data_as(ctypes.POINTER(ctypes.c_double))
        )
        return v

    def _contacts(self) -> tuple[int, float]:
        deepest = ctypes.c_double(0.0)
        count = self._lib.harness_contacts(self._h, ctypes.byref(deepest))
        if count < 0:
            raise MemoryError("the Box2D v3 harness could not grow its contact buffer")
        return count, deepest.value

    def contact_count(self) -> int:
        return self._contacts()[0]

    def max_overlap(self) -> float:
        return self._contacts()[1]

    def set_recycle_distance(self, distance: float) -> None:
        """Box2D v3's contact recycling distance (m); 0 turns recycling off."""
        self._lib.harness_set_recycle_distance(self._h, distance)

    def manifold_points(self) -> tuple[np.ndarray, np.ndarray]:
        """The last step's contact points: (P, 2) harness body indices (A, B), and (P, 10) rows
        [anchorA x, y, anchorB x, y, separation, normal impulse of the last sub-step, friction
        impulse, normal impulse of the step, normal x, y] (see harness_manifold_points)."""
        capacity = 64
        while True:
            pair = np.zeros((capacity, 2), dtype=np.int32)
            data = np.zeros((capacity, 10))
            n = self._lib.harness_manifold_points(
                self._h,
                capacity,
                pair.ctypes.data_as(ctypes.POINTER(ctypes.c_int)),
                data.ctypes.data_as(ctypes.POINTER(ctypes.c_double)),
            )
            if n < 0:
                raise MemoryError("the Box2D v3 harness could not grow its contact buffer")
            if n <= capacity:
                return pair[:n], data[:n]
            capacity = n

    def joint_gaps(self) -> np.ndarray:
        gaps = np.zeros(self._n_joints)
        self._lib.harness_joint_gaps(self._h, gaps.ctypes.data_as(ctypes.POINTER(ctypes.c_double)))
        return gaps

    def close(self) -> None:
        if getattr(self, "_h", None):
            self._lib.harness_destroy(self._h)
            self._h = None

    def __del__(self) -> None:
        self.close()


# --------------------------------------------------------------------------
# phys2d
# --------------------------------------------------------------------------


class Phys2DAdapter:
    """phys2d: PGS, 10 iterations, warm starting; friction 0.6 per shape.

    phys2d mixes friction as sqrt(mu_a * mu_b), so 0.6 per box gives 0.6.
    With ``record_path`` every step is followed by ``Recorder.log(world)``;
    ``responder`` replaces the default PGS (to compare phys2d's options).
    """

    name = "phys2d"

    def __init__(self, scene: Scene, record_path: str | None = None, responder=None):
        import phys2d

        if responder is None:
            responder = phys2d.PGS(iterations=ITERATIONS, warm_start=True)
        if scene.pins and not responder.handles_joints:
            raise Unsupported("no joints")
        w = phys2d.World(gravity=GRAVITY, responder=responder)
        w.add_box(
            position=GROUND_CENTER,
            half_extents=GROUND_HALF,
            angle=0.0,
            density=1.0,
            friction=FRICTION,
            restitution=RESTITUTION,
            static=True,
        )
        pivots = [
            w.add_circle(position=(p.x, p.y), radius=p.radius, friction=FRICTION, restitution=RESTITUTION, static=True)
            for p in scene.pivots
        ]
        first = len(w.bodies)
        self.bodies = []
        for box in scene.boxes:
            self.bodies.append(
                w.add_box(
                    position=(box.x, box.y),
                    half_extents=(box.hw, box.hh),
                    angle=0.0,
                    density=box.density,
                    friction=FRICTION,
                    restitution=RESTITUTION,
                    static=False,
                    velocity=(0.0, 0.0),
                    angular_velocity=0.0,
                )
            )
        self._index = np.arange(first, first + len(scene.boxes))
        self.joints = []
        for pin in scene.pins:
            a, b = (self.bodies[r] if r >= 0 else pivots[-1 - r] for r in (pin.a, pin.b))
            self.joints.append(w.add_pin_joint(a, b, anchor=(pin.x, pin.y)))
        self.world = w
        self._rec = None
        self._recorder = None
        if record_path is not None:
            self._recorder = phys2d.Recorder(record_path, name=f"bench_{scene.name}")
            self._rec = self._recorder.__enter__()
            log = self._rec.log
            wstep = w.step

            def step_and_log() -> None:
                wstep(DT)
                log(w)

            self.step = step_and_log
            self.name = "phys2d+rec"
        else:
            self._wstep = w.step

    def step(self) -> None:
        self._wstep(DT)

    def positions(self) -> np.ndarray:
        return np.asarray(self.world.x, dtype=float)[self._index].copy()

    def angles(self) -> np.ndarray:
        return np.asarray(self.world.theta, dtype=float)[self._index].copy()

    def velocities(self) -> np.ndarray:
        """(N, 2) linear velocities of the dynamic boxes, m/s."""
        return np.asarray(self.world.V, dtype=float)[self._index, :2].copy()

    def contact_count(self) -> int:
        return len(self.world.contacts)

    def max_overlap(self) -> float:
        sep = np.asarray(self.world.contacts.separation, dtype=float)
        return max(0.0, float(-sep.min())) if sep.size else 0.0

    def joint_gaps(self) -> np.ndarray:
        return np.array([j.gap() for j in self.joints], dtype=float)

    def close(self) -> None:
        if self._recorder is not None:
            self._recorder.__exit__(None, None, None)
            self._recorder = None


def phys2d_available() -> bool:
    try:
        import phys2d
    except ImportError:
        return False
    return hasattr(phys2d, "World")


def recorder_available() -> bool:
    try:
        import phys2d
    except ImportError:
        return False
    return hasattr(phys2d, "Recorder")
