"""Scenes and engine adapters for the peer benchmark (issue 7).

Every engine sits behind the same tiny interface: ``build(scene)`` returns an
object with

- ``step()``: advance one fixed step of ``DT``;
- ``positions()``: (N, 2) centres of the dynamic boxes, in scene order;
- ``angles()``: (N,) angles of the dynamic boxes, in scene order;
- ``contact_count()``: contact points of the last step;
- ``max_overlap()``: deepest overlap (>= 0, metres) among those contact points,
  read from the engine's own contact data;
- ``close()``: release anything the adapter holds (recordings).

The scenes are plain data (``Scene``), so each engine builds exactly the same
bodies in the same order. Units are SI throughout.
"""

from __future__ import annotations

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
class Scene:
    name: str
    boxes: tuple[Box, ...] = field(default_factory=tuple)

    def start(self) -> np.ndarray:
        return np.array([(b.x, b.y) for b in self.boxes], dtype=float)


def vertical_stack(n: int) -> Scene:
    """n touching 1 m boxes at x = 0; box k centred at y = 0.5 + k."""
    boxes = tuple(Box(0.0, 0.5 + k, 0.5, 0.5) for k in range(n))
    return Scene(f"vertical_stack_{n}", boxes)


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


SCENES = {
    "vertical_stack_10": lambda: vertical_stack(10),
    "vertical_stack_20": lambda: vertical_stack(20),
    "pyramid_10": lambda: pyramid(10),
    "pyramid_20": lambda: pyramid(20),
    "pyramid_40": lambda: pyramid(40),
    "mass_ratio_100": mass_ratio_100,
}


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

    def close(self) -> None:
        pass


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

    def contact_count(self) -> int:
        return len(self.world.contacts)

    def max_overlap(self) -> float:
        sep = np.asarray(self.world.contacts.separation, dtype=float)
        return max(0.0, float(-sep.min())) if sep.size else 0.0

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
