"""Box2D's and Solver2D's sample scenes, built as their sources set them up.

Each function returns a ready World and takes ``responder=`` like the scenes of
``phys2d.scenes`` (which lists them in ``SCENES``). The docstrings name the sample
(Box2D v3: samples/sample_stacking.cpp, sample_robustness.cpp, sample_joints.cpp and
shared/benchmarks.c; Solver2D: samples/collection/sample_contact.cpp, sample_far.cpp,
sample_joints.cpp) and what it tests. Units are SI; Box2D's defaults carry over:
density 1 kg/m^2, friction 0.6, gravity (0, -10) m/s^2.

Some scenes were written before phys2d had segments: there a ground segment is a static
box whose top face lies on the segment; each docstring says where. Revolute joints are
``add_pin_joint``, with their motors (``car``) and limits (``ragdoll``, whose limbs are
capsules); joint friction is a motor of speed 0 and bounded torque; the springs some samples
add are left out.

``STOCK_SCENES`` lists them as ``phys2d.scenes.SCENES`` does (which takes them in), and
``WATCHES`` gives each the watch that judges its own claim (``verdict.watch_for``).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np
from numpy.typing import ArrayLike

from . import shapes, verdict
from .bodies import ALL_CATEGORIES, Body
from .responders.base import Responder, StepReport
from .scene_parts import check_count as _check_count
from .scene_parts import ground
from .validation import non_negative_float, positive_float
from .verdict import (
    HELD,
    DriveWatch,
    JointWatch,
    RampWatch,
    RecoveryWatch,
    RegionWatch,
    SettleWatch,
    ToppleWatch,
    Watch,
)
from .world import World

__all__ = [
    "STOCK_SCENES",
    "WATCHES",
    "PulledWorld",
    "arch",
    "ball_and_chain",
    "bridge",
    "card_house",
    "confined",
    "double_domino",
    "far_pyramid",
    "friction_ramp",
    "high_mass_ratio",
    "joint_grid",
    "large_pyramid",
    "many_pyramids",
    "overlap_recovery",
    "rush",
    "spaced_pyramid",
]

RAMP_SLOPE = 0.25  # rad, Solver2D's friction ramps
RAMP_FRICTION = 0.2  # the ramps' mu
RAMP_BOX_FRICTIONS = (0.75, 0.5, 0.35, 0.1, 0.0)  # the boxes' mu, left to right
CONFINED_INNER = 10.0  # m: the confined walls' inner faces are at |x| = 10, y = 0.5 and y = 20
FAR_DIRECTION = (1.0, -0.8)  # Solver2D's far pyramid sits at (100 km, -80 km)


# -- building blocks ---------------------------------------------------------------
def _segment_ground(w: World, x0: float, x1: float, y: float = 0.0, friction: float = 0.6, thickness: float = 1.0):
    """Box2D's ground segment from (x0, y) to (x1, y) as a static box whose top face is the segment."""
    return w.add_box(
        position=(0.5 * (x0 + x1), y - 0.5 * thickness),
        half_extents=(0.5 * (x1 - x0), 0.5 * thickness),
        static=True,
        friction=friction,
    )


def _box_ground(w: World, half_width: float, half_height: float, friction: float = 0.6):
    """Box2D's ground box: half extents (half_width, half_height) m, its top at y = 0."""
    return w.add_box(
        position=(0.0, -half_height), half_extents=(half_width, half_height), static=True, friction=friction
    )


def _hull(w: World, points: Sequence[tuple[float, float]], **options) -> Body:
    """A polygon given by its world-frame vertices (counter-clockwise), placed where they are."""
    centroid = shapes.polygon(points).centroid  # add_polygon puts the centroid at ``position``
    return w.add_polygon(position=(float(centroid[0]), float(centroid[1])), vertices=points, **options)


def _anchor_post(w: World, point: tuple[float, float]) -> Body:
    """A static point to pin to (Box2D's shapeless ground body): a 5 cm circle that collides with nothing."""
    return w.add_circle(position=point, radius=0.05, static=True, category=0, mask=0)


def _ratio_in(value, name: str, low: float, high: float) -> float:
    """A float strictly between low and high."""
    v = positive_float(value, name)
    if not low < v < high:
        raise ValueError(f"{name} must be between {low:g} and {high:g} (exclusive), got {v:g}")
    return v


# -- Box2D's stacking samples (Solver2D's contact samples) ------------------------
ARCH_INNER = (
    (16.0, 0.0),
    (14.93803712795643, 5.133601056842984),
    (13.79871746027416, 10.24928069555078),
    (12.56252963284711, 15.34107019122473),
    (11.20040987372525, 20.39856541571217),
    (9.66521217819836, 25.40369899225096),
    (7.87179930638133, 30.3179337000085),
    (5.635199558196225, 35.03820717801641),
    (2.405937953536585, 39.09554102558315),
)
ARCH_OUTER = (
    (24.0, 0.0),
    (22.33619528222415, 6.02299846205841),
    (20.54936888969905, 12.00964361211476),
    (18.60854610798073, 17.9470321677465),
    (16.46769273811807, 23.81367936585418),
    (14.05325025774858, 29.57079353071012),
    (11.23551045834022, 35.13775818285372),
    (7.752568160730571, 40.30450679009583),
    (3.016931552701656, 44.28891593799322),
)


def arch(scale: float = 0.25, responder: Responder | None = None) -> World:
    """Box2D's and Solver2D's "Arch": 17 voussoirs and 4 boxes on top, friction 0.6.

    The voussoirs are quadrilaterals between the sample's inner and outer curves (its
    points, in m, times ``scale``): 8 up each side and a keystone; four 4 m x 1 m boxes
    stand on the keystone. Nothing holds the stones but contact and friction, so the
    arch tests friction under large, slanted normal loads: it stands or slides apart.
    Ground: Box2D's segment from x = -100 to 100 m (a static box, top at y = 0).
    """
    s = positive_float(scale, "scale")
    w = World(responder=responder)
    _segment_ground(w, -100.0, 100.0, friction=0.6)
    inner = [(s * x, s * y) for x, y in ARCH_INNER]
    outer = [(s * x, s * y) for x, y in ARCH_OUTER]
    for i in range(8):  # the right side, bottom up
        _hull(w, [inner[i], outer[i], outer[i + 1], inner[i + 1]], friction=0.6)
    for i in range(8):  # the left side, mirrored
        (ix, iy), (ox, oy), (ix1, iy1), (ox1, oy1) = inner[i], outer[i], inner[i + 1], outer[i + 1]
        _hull(w, [(-ox, oy), (-ix, iy), (-ix1, iy1), (-ox1, oy1)], friction=0.6)
    (ix, iy), (ox, oy) = inner[8], outer[8]
    _hull(w, [(ix, iy), (ox, oy), (-ox, oy), (-ix, iy)], friction=0.6)  # the keystone
    for i in range(4):
        w.add_box(position=(0.0, 0.5 + oy + 1.0 * i), half_extents=(2.0, 0.5), friction=0.6)
    return w


def card_house(levels: int = 5, responder: Responder | None = None) -> World:
    """Box2D's and Solver2D's "Card House" (from PEEL): cards 0.4 m tall, 2 mm thick, friction 0.7.

    The bottom level holds ``levels`` pairs of cards leaning on each other at +-25 deg,
    with a flat card across each neighbouring pair's tops; each level up holds one pair
    fewer. Thin, light bodies (0.8 g) leaning at an angle: only friction keeps their feet
    in place, and the flat cards load the tips. Ground: a static box 80 m x 4 m, top at y = 0.
    """
    levels = _check_count(levels, "levels")
    w = World(responder=responder)
    _box_ground(w, 40.0, 2.0, friction=0.7)
    height, thickness = 0.2, 0.001  # m, half extents
    lean_right, lean_left, flat = math.radians(25.0), math.radians(-25.0), 0.5 * math.pi
    card = (thickness, height)
    z0, y = 0.0, height - 0.02
    for count in range(levels, 0, -1):
        z = z0
        for i in range(count):
            if i != count - 1:
                w.add_box(position=(z + 0.25, y + height - 0.015), half_extents=card, angle=flat, friction=0.7)
            w.add_box(position=(z, y), half_extents=card, angle=lean_left, friction=0.7)
            z += 0.175
            w.add_box(position=(z, y), half_extents=card, angle=lean_right, friction=0.7)
            z += 0.175
        y += 2.0 * height - 0.03
        z0 += 0.175
    return w


def confined(grid: int = 25, responder: Responder | None = None) -> World:
    """Box2D's and Solver2D's "Confined": grid x grid circles of radius 0.5 m packed in a closed box.

    Gravity does not act on them (gravity_scale 0); the grid is denser than the circles,
    so they start overlapping their neighbours and must push apart inside the walls. It
    tests that overlap recovery does not push bodies through walls: every circle stays
    inside. The walls are the sample's capsules of radius 0.5 m from (-10.5, 0) to
    (10.5, 20.5) as static boxes around them (inner faces at x = +-10, y = 0.5 and 20).
    """
    grid = _check_count(grid, "grid")
    w = World(responder=responder)
    r, lo, hi = 0.5, -10.5, 10.5
    top = 20.5
    w.add_box(position=(0.0, 0.0), half_extents=(hi + r, r), static=True)  # floor
    w.add_box(position=(lo, 0.5 * top), half_extents=(r, 0.5 * top + r), static=True)  # left wall
    w.add_box(position=(hi, 0.5 * top), half_extents=(r, 0.5 * top + r), static=True)  # right wall
    w.add_box(position=(0.0, top), half_extents=(hi + r, r), static=True)  # ceiling
    for column in range(grid):
        for row in range(grid):
            x = -8.75 + column * 18.0 / grid
            y = 1.5 + row * 18.0 / grid
            w.add_circle(position=(x, y), radius=0.5, gravity_scale=0.0)
    return w


def double_domino(count: int = 15, responder: Responder | None = None) -> World:
    """Box2D's and Solver2D's "Double Domino": ``count`` dominoes 0.25 m x 1 m, 1 m apart, friction 0.6.

    The first (leftmost) gets an impulse of 0.2 N s to the right at its top edge; it
    topples the next, and so on down the line. It tests that a push travels through a
    chain of new contacts: each domino falls, and in order. Ground: Box2D's box 200 m x
    2 m, top at y = 0.
    """
    count = _check_count(count, "count")
    w = World(responder=responder)
    _box_ground(w, 100.0, 1.0)
    x = -0.5 * count
    for i in range(count):
        domino = w.add_box(position=(x, 0.5), half_extents=(0.125, 0.5), friction=0.6)
        if i == 0:
            domino.apply_impulse((0.2, 0.0), point=(x, 1.0))
        x += 1.0
    return w


def friction_ramp(density: float = 25.0, responder: Responder | None = None) -> World:
    """Solver2D's "Friction Ramp" (Box2D's "Friction" sample's ramps): five boxes on zig-zag ramps.

    Three ramps 26 m long, tilted by 0.25 rad, with short walls at their lower ends,
    friction 0.2. Five 1 m boxes of ``density`` (kg/m^2) fall onto the top ramp from
    y = 28 m, with friction 0.75, 0.5, 0.35, 0.1 and 0. Pairs mix friction as
    sqrt(mu_a mu_b), so on the ramp the boxes have mu = 0.39, 0.32, 0.26, 0.14 and 0:
    Coulomb's law says the first three (mu > tan 0.25 = 0.255) stick and the last two
    slide. Ground: the sample's segment from x = -40 to 40 m (a static box, top at y = 0).
    """
    rho = positive_float(density, "density")
    w = World(responder=responder)
    _segment_ground(w, -40.0, 40.0, friction=RAMP_FRICTION)
    ramp, wall = (13.0, 0.25), (0.25, 1.0)
    for centre, half, angle in (
        ((-4.0, 22.0), ramp, -RAMP_SLOPE),
        ((10.5, 19.0), wall, 0.0),
        ((4.0, 14.0), ramp, RAMP_SLOPE),
        ((-10.5, 11.0), wall, 0.0),
        ((-4.0, 6.0), ramp, -RAMP_SLOPE),
    ):
        w.add_box(position=centre, half_extents=half, angle=angle, static=True, friction=RAMP_FRICTION)
    for i, mu in enumerate(RAMP_BOX_FRICTIONS):
        w.add_box(position=(-15.0 + 4.0 * i, 28.0), half_extents=(0.5, 0.5), density=rho, friction=mu)
    return w


# -- Box2D's robustness samples --------------------------------------------------------------
def high_mass_ratio(variant: int = 1, responder: Responder | None = None) -> World:
    """Box2D's "HighMassRatio1", "2" and "3" (samples/sample_robustness.cpp); Solver2D has the first two.

    1: three pyramids of 2 m boxes, 10 at the base, each topped by a box 100, 200 and
       300 times as dense dropped from 2 m above its place (100:1 to 300:1 on the boxes below);
    2: a 20 m box of 400 kg dropped 15 m onto two 1 m boxes of 1 kg standing 18 m apart;
    3: the same 20 m box dropped 2.5 m onto two small triangles (1 m base, 1 m tall, 0.5 kg):
       800:1 on two points.
    The light bodies must carry the heavy one without being crushed into the ground or
    squeezed out. Ground: Box2D's box 100 m x 2 m, top at y = 0.
    """
    variant = _check_count(variant, "variant")
    if variant > 3:
        raise ValueError(f"variant must be 1, 2 or 3, got {variant}")
    w = World(responder=responder)
    _box_ground(w, 50.0, 1.0)
    if variant == 1:
        extent = 1.0
        for j in range(3):
            count = 10
            offset = -20.0 * extent + 2.0 * (count + 1.0) * extent * j
            y = extent
            while count > 0:
                for i in range(count):
                    coeff = i - 0.5 * count
                    yy = y + 2.0 if count == 1 else y
                    density = (j + 1.0) * 100.0 if count == 1 else 1.0
                    w.add_box(
                        position=(2.0 * coeff * extent + offset, yy), half_extents=(extent, extent), density=density
                    )
                count -= 1
                y += 2.0 * extent
        return w
    if variant == 2:
        for x in (-9.0, 9.0):
            w.add_box(position=(x, 0.5), half_extents=(0.5, 0.5))
        w.add_box(position=(0.0, 26.0), half_extents=(10.0, 10.0))
        return w
    triangle = [(-0.5, 0.0), (0.5, 0.0), (0.0, 1.0)]  # in the body frame of Box2D's body at (x, 0.5)
    for x in (-9.0, 9.0):
        _hull(w, [(x + px, 0.5 + py) for px, py in triangle])
    w.add_box(position=(0.0, 14.0), half_extents=(10.0, 10.0))
    return w


def overlap_recovery(
    base: int = 4, responder: Responder | None = None, overlap: float = 0.25, extent: float = 0.5
) -> World:
    """Box2D's and Solver2D's "Overlap Recovery": a pyramid of boxes that start overlapping.

    ``base`` boxes of half extent ``extent`` (m) at the bottom, one fewer each row up, each
    box overlapping its neighbours (and the row below) by ``overlap`` of its width. The
    solver must push them apart without blowing them apart: speeds stay small and the
    pyramid ends at rest, separated. Box2D's sample also sets its contact push-out speed
    to 3 m/s and contact hertz to 30 (responder settings, left to ``responder``).
    Ground: the sample's segment from x = -40 to 40 m (a static box, top at y = 0).
    """
    base = _check_count(base, "base")
    fraction = 1.0 - _ratio_in(overlap, "overlap", 0.0, 1.0)
    extent = positive_float(extent, "extent")
    w = World(responder=responder)
    _segment_ground(w, -40.0, 40.0)
    y = extent
    for i in range(base):
        x = fraction * extent * (i - base)
        for _ in range(i, base):
            w.add_box(position=(x, y), half_extents=(extent, extent))
            x += 2.0 * fraction * extent
        y += 2.0 * fraction * extent
    return w


class PulledWorld(World):
    """A World whose dynamic bodies are pulled toward ``centre`` (m) by a force of ``pull`` N each.

    Before every step each dynamic body farther than 0.1 m from the centre gets the force
    -pull (x - centre) / |x - centre| for that step (Solver2D's "Rush" applies it so); the
    rest is World's.
    """

    def __init__(self, pull: float, centre: tuple[float, float] = (0.0, 0.0), **world_options) -> None:
        super().__init__(**world_options)
        self.pull = positive_float(pull, "pull")
        self.centre = np.array(centre, np.float64)

    def step(self, dt: float) -> StepReport:
        """Apply the pull for this step, then step as World does."""
        a = self._bodies
        d = a.x - self.centre
        dist = np.hypot(d[:, 0], d[:, 1])
        pulled = (a.M_inv[:, 0] > 0.0) & (dist >= 0.1)
        if np.any(pulled):
            a.force[pulled, :2] -= (self.pull / dist[pulled])[:, None] * d[pulled]
            a.forces_applied = True
        return super().step(dt)


def rush(count: int = 400, responder: Responder | None = None) -> World:
    """Solver2D's "Rush": ``count`` circles (radius 0.5 m, 100 kg/m^2, friction 0.2) rush a static circle.

    The circles start on a spiral around the origin (distance 5 m + 0.05 m per circle,
    0.2 rad apart) without gravity; every step a force of 1000 N pulls each toward the
    origin, where a static circle of radius 0.5 m stands. The pile must pack around it
    without pushing anything through it: a crowd's weight on one small body. Returns a
    ``PulledWorld`` (the pull is applied in its ``step``).
    """
    count = _check_count(count, "count")
    w = PulledWorld(1000.0, responder=responder)
    w.add_circle(position=(0.0, 0.0), radius=0.5, static=True, friction=0.2, density=100.0)
    distance, angle = 5.0, 0.0
    delta_angle = 1.0 / distance  # fixed at the start, as in the sample
    for _ in range(count):
        w.add_circle(
            position=(distance * math.cos(angle), distance * math.sin(angle)),
            radius=0.5,
            friction=0.2,
            density=100.0,
            gravity_scale=0.0,
        )
        angle += delta_angle
        distance += 0.05
    return w


# -- joints --------------------------------------------------------------------------------
def bridge(planks: int = 160, responder: Responder | None = None) -> World:
    """Solver2D's "Bridge" (samples/collection/sample_joints.cpp): ``planks`` planks pinned end to end.

    Planks 1 m x 0.25 m (20 kg/m^2: 5 kg) span x = -planks/2 .. planks/2 m at y = 20 m,
    pinned to each other and, at the ends, to two static posts; linear and angular
    damping 0.1 1/s. Pinned taut, the bridge can sag only as far as its joints give: it
    tests a long chain of joints under its own weight (160 planks: 800 kg hung from two
    points). Box2D's version adds joint friction, springs (phys2d's pins have neither)
    and a load of triangles and circles. No ground.
    """
    planks = _check_count(planks, "planks")
    w = World(responder=responder)
    xbase = -0.5 * planks
    posts = (_anchor_post(w, (xbase, 20.0)), _anchor_post(w, (xbase + planks, 20.0)))
    bodies = [posts[0]]
    for i in range(planks):
        bodies.append(
            w.add_box(
                position=(xbase + 0.5 + i, 20.0),
                half_extents=(0.5, 0.125),
                density=20.0,
                linear_damping=0.1,
                angular_damping=0.1,
            )
        )
    bodies.append(posts[1])
    for i, (a, b) in enumerate(zip(bodies[:-1], bodies[1:])):
        w.add_pin_joint(a, b, anchor=(xbase + i, 20.0))
    return w


def ball_and_chain(links: int = 30, responder: Responder | None = None, radius: float = 4.0) -> World:
    """Box2D's "Ball & Chain": ``links`` links 1 m long (20 kg/m^2) and a ball of ``radius`` m at the end.

    The chain starts straight out to the right of a static pivot at (0, links / 2 m) and
    swings down with the ball (20 kg/m^2: 1005 kg at radius 4, 161 times a 6.25 kg link). Links
    collide only with the ball (Box2D's filter: links category 1, mask 2; the ball
    category 2, mask 1). It tests a heavy load at the end of a long chain of joints: the
    joints must not stretch. Box2D's links are capsules of radius 0.125 m (here boxes
    1.25 m x 0.25 m around them); its joints' friction and springs are left out. No ground.
    """
    links = _check_count(links, "links")
    r = positive_float(radius, "radius")
    w = World(responder=responder)
    hx, y = 0.5, links * 0.5
    bodies = [_anchor_post(w, (0.0, y))]
    for i in range(links):
        bodies.append(
            w.add_box(
                position=((1.0 + 2.0 * i) * hx, y), half_extents=(hx + 0.125, 0.125), density=20.0, category=1, mask=2
            )
        )
    bodies.append(
        w.add_circle(position=((1.0 + 2.0 * links) * hx + r - hx, y), radius=r, density=20.0, category=2, mask=1)
    )
    for i, (a, b) in enumerate(zip(bodies[:-1], bodies[1:])):
        w.add_pin_joint(a, b, anchor=(2.0 * i * hx, y))
    return w


def joint_grid(n: int = 100, responder: Responder | None = None) -> World:
    """Box2D's ``CreateJointGrid`` (shared/benchmarks.c; Solver2D's "Joint Grid"): n x n pinned circles.

    Circles of radius 0.4 m (1 kg/m^2) on a 1 m grid, row i at y = -i, column k at x = k,
    each pinned to its neighbours above and to the left at the midpoint between them; the
    7 circles of the top row around the middle column (k = n/2 - 3 .. n/2 + 3) are static.
    The circles never collide (category 2, mask ~2): the grid hangs from its middle as a
    net of 2 n (n - 1) - 6 joints (Box2D's 6 between the static circles, which could never
    act, are left out), a stress test of the joint solver.
    """
    n = _check_count(n, "n")
    w = World(responder=responder)
    grid: list[Body] = []
    pairs: list[tuple[Body, Body]] = []
    anchors: list[tuple[float, float]] = []
    no_self = ALL_CATEGORIES & ~2
    for k in range(n):
        for i in range(n):
            static = n // 2 - 3 <= k <= n // 2 + 3 and i == 0
            body = w.add_circle(position=(k, -i), radius=0.4, static=static, category=2, mask=no_self)
            if i > 0:
                pairs.append((grid[-1], body))
                anchors.append((k, -i + 0.5))
            if k > 0 and not (static and grid[-n].static):  # Box2D keeps joints between statics; they never act
                pairs.append((grid[-n], body))
                anchors.append((k - 0.5, -i))
            grid.append(body)
    for (a, b), anchor in zip(pairs, anchors):
        w.add_pin_joint(a, b, anchor=anchor)
    return w


# -- pyramids ------------------------------------------------------------------------------
def spaced_pyramid(origin: ArrayLike = (0.0, 0.0), base: int = 10, responder: Responder | None = None) -> World:
    """Solver2D's far pyramid's setup around any ``origin`` (m): see ``far_pyramid``."""
    o = np.asarray(origin, np.float64)
    if o.shape != (2,) or not np.all(np.isfinite(o)):
        raise ValueError(f"origin must be a finite (x, y) pair, got {origin!r}")
    base = _check_count(base, "base")
    w = World(responder=responder)
    w.add_box(position=(o[0], o[1] - 1.0), half_extents=(100.0, 1.0), static=True)
    h, shift = 0.5, 0.625
    for i in range(base):
        y = (2.0 * i + 1.0) * shift + 0.5
        for j in range(i, base):
            x = (i + 1.0) * shift + 2.0 * (j - i) * shift - h * base
            w.add_box(position=(o[0] + x, o[1] + y), half_extents=(h, h))
    return w


def far_pyramid(base: int = 10, responder: Responder | None = None, distance: float = 100_000.0) -> World:
    """Solver2D's "Far Pyramid" (samples/collection/sample_far.cpp): a pyramid far from the origin.

    Its ground (Box2D's box 200 m x 2 m) has its top at (distance, -0.8 distance) m, the
    sample's (100 km, -80 km) by default. ``base`` boxes of 1 m at the bottom; neighbours
    are 1.25 m apart, across and up, so the bottom row drops 0.625 m to the ground, each row
    0.25 m onto the one below, and the pyramid settles 2.9 m lower (base 10). Solver2D
    runs in 32-bit floats, where 100 km leaves 8 mm between neighbouring numbers; phys2d's
    64-bit state leaves 15 pm, so the pyramid must stand as it does at the origin.
    """
    base = _check_count(base, "base")
    d = positive_float(distance, "distance")
    return spaced_pyramid((FAR_DIRECTION[0] * d, FAR_DIRECTION[1] * d), base, responder)


def large_pyramid(base: int = 100, responder: Responder | None = None) -> World:
    """Box2D's ``CreateLargePyramid`` (shared/benchmarks.c): a pyramid of 1 m boxes, ``base`` at the bottom.

    Touching boxes, row i centred on x = 0 at y = i + 0.5 m, on Box2D's ground box
    200 m x 2 m (top at y = 0): 5,050 boxes at base 100, Box2D's benchmark of a tall,
    wide stack. The same as ``phys2d.scenes.pyramid(base)`` but for the ground's depth.
    """
    base = _check_count(base, "base")
    w = World(responder=responder)
    _box_ground(w, 100.0, 1.0)
    a = 0.5
    for i in range(base):
        y = (2.0 * i + 1.0) * a
        for j in range(i, base):
            w.add_box(position=((i + 1.0) * a + 2.0 * (j - i) * a - a * base, y), half_extents=(a, a))
    return w


def many_pyramids(rows: int = 20, responder: Responder | None = None, columns: int = 20, base: int = 10) -> World:
    """Box2D's ``CreateManyPyramids`` (shared/benchmarks.c): rows x columns pyramids of ``base`` boxes.

    Each row of pyramids stands on its own ground segment, 2 (base + 1) * 0.5 m above the
    one below and 2 (base + 1) * 0.5 * columns m wide; pyramids of 1 m boxes (base 10:
    55 boxes) sit side by side, 1 m apart. 20 x 20 pyramids of base 10 are 22,000 boxes,
    Box2D's benchmark of many small islands. The segments are static boxes 10 cm thick,
    their top faces on the segments, until phys2d has segments.
    """
    rows = _check_count(rows, "rows")
    columns = _check_count(columns, "columns")
    base = _check_count(base, "base")
    w = World(responder=responder)
    extent = 0.5
    ground_dy = 2.0 * extent * (base + 1.0)
    ground_width = 2.0 * extent * columns * (base + 1.0)
    for i in range(rows):
        _segment_ground(w, -0.5 * ground_width, 0.5 * ground_width, y=i * ground_dy, thickness=0.1)
    base_width = 2.0 * extent * base
    for r in range(rows):
        base_y = r * ground_dy
        for c in range(columns):
            centre_x = -0.5 * ground_width + c * (base_width + 2.0 * extent) + 2.0 * extent
            for i in range(base):
                y = (2.0 * i + 1.0) * extent + base_y
                for j in range(i, base):
                    x = (i + 1.0) * extent + 2.0 * (j - i) * extent + centre_x - 0.5
                    w.add_box(position=(x, y), half_extents=(extent, extent))
    return w


# -- the registry ----------------------------------------------------------------------------
# -- issue 27's scenes: a car on a chain terrain, ragdolls of capsules ---------------------
def car_terrain_height(x: float) -> float:
    """The car's hills (m): flat for x < 0, then rolling, slopes under 20 deg."""
    if x <= 0.0:
        return 0.0
    return 0.6 * math.sin(0.25 * x) ** 2 + 0.25 * math.sin(0.8 * x) * min(1.0, 0.1 * x)


def car(length: float = 60.0, responder: Responder | None = None, wheel_speed: float = 8.0) -> World:
    """Box2D's "Driving" sample (samples/sample_joints.cpp, samples/car.cpp), with rigid
    axles: a car with motor wheels on a chain terrain.

    A 2.5 m x 0.5 m chassis (2 kg/m^2: 2.5 kg) on two wheels of radius 0.4 m (1 kg/m^2,
    friction 0.9), each on a pin joint at its centre whose motor turns the wheel clockwise
    relative to the chassis at ``wheel_speed`` (rad/s, > 0: motor_speed = -wheel_speed drives
    right) with at most 20 N m. The terrain is one static chain through a point every 0.5 m
    from x = -10 m to ``length`` m, listed right to left so that its colliding side faces up;
    flat to x = 0, rolling hills after. Box2D's car has wheel joints (springs); these axles
    are rigid. The claim: the car drives right, close to the wheels' rolling speed
    wheel_speed r, and stays on its wheels.
    """
    length = positive_float(length, "length")
    wheel_speed = positive_float(wheel_speed, "wheel_speed")
    w = World(responder=responder)
    xs = np.arange(length, -10.0 - 1e-9, -0.5)
    w.add_chain([(float(x), car_terrain_height(float(x))) for x in xs], friction=0.9)
    chassis = w.add_box((0.0, 1.0), half_extents=(1.25, 0.25), density=2.0, friction=0.6)
    for x in (-0.9, 0.9):
        wheel = w.add_circle((x, 0.45), radius=0.4, density=1.0, friction=0.9)
        w.add_pin_joint(chassis, wheel, anchor=(x, 0.45), motor_speed=-wheel_speed, max_motor_torque=20.0)
    return w


# a ragdoll's bones: (name, parent, capsule centre (m, from the hips), half_length, radius, angle (rad),
# the joint's anchor (m, from the hips), the limits of the bone's angle relative to its parent's (rad))
_BONES = (
    ("torso", None, (0.0, 0.35), 0.2, 0.12, 0.5 * math.pi, None, None),
    ("head", "torso", (0.0, 0.82), 0.04, 0.12, 0.5 * math.pi, (0.0, 0.68), (-0.6, 0.6)),
    ("upper_arm_l", "torso", (-0.18, 0.5), 0.12, 0.05, 0.5 * math.pi, (-0.18, 0.63), (-1.5, 1.5)),
    ("lower_arm_l", "upper_arm_l", (-0.18, 0.24), 0.1, 0.045, 0.5 * math.pi, (-0.18, 0.37), (0.0, 2.5)),
    ("upper_arm_r", "torso", (0.18, 0.5), 0.12, 0.05, 0.5 * math.pi, (0.18, 0.63), (-1.5, 1.5)),
    ("lower_arm_r", "upper_arm_r", (0.18, 0.24), 0.1, 0.045, 0.5 * math.pi, (0.18, 0.37), (0.0, 2.5)),
    ("upper_leg_l", "torso", (-0.09, -0.2), 0.15, 0.07, 0.5 * math.pi, (-0.09, 0.0), (-0.5, 1.5)),
    ("lower_leg_l", "upper_leg_l", (-0.09, -0.6), 0.15, 0.06, 0.5 * math.pi, (-0.09, -0.4), (-2.3, 0.0)),
    ("upper_leg_r", "torso", (0.09, -0.2), 0.15, 0.07, 0.5 * math.pi, (0.09, 0.0), (-0.5, 1.5)),
    ("lower_leg_r", "upper_leg_r", (0.09, -0.6), 0.15, 0.06, 0.5 * math.pi, (0.09, -0.4), (-2.3, 0.0)),
)


def add_ragdoll(w: World, hips: tuple[float, float], group: int = -1, joint_friction: float = 0.0) -> dict[str, Body]:
    """A ragdoll of capsules (Box2D's human, simplified: 10 bones, 1.9 m tall, 1000 kg/m^2)
    standing with its hips at ``hips`` (m); each joint a pin with limits on the bone's angle
    relative to its parent's. Its bones share the negative collision ``group`` and never touch
    one another, as in Box2D; give each ragdoll its own group. ``joint_friction`` (N m, >= 0):
    each pin's friction torque, as Box2D's human has it: a motor toward omega_b - omega_a = 0
    of at most that torque; 0: frictionless pins (a limb hanging free then swings on)."""
    friction = non_negative_float(joint_friction, "joint_friction")
    motor_speed = 0.0 if friction > 0.0 else None  # (None: no motor, the pins as without friction)
    bones: dict[str, Body] = {}
    hx, hy = hips
    for name, parent, centre, half_length, radius, angle, anchor, limits in _BONES:
        body = w.add_capsule(
            (hx + centre[0], hy + centre[1]), half_length=half_length, radius=radius, angle=angle,
            density=1000.0, friction=0.6, group=group,
        )  # fmt: skip
        bones[name] = body
        if parent is not None:
            assert anchor is not None and limits is not None
            w.add_pin_joint(
                bones[parent], body, anchor=(hx + anchor[0], hy + anchor[1]), lower=limits[0], upper=limits[1],
                motor_speed=motor_speed, max_motor_torque=friction,
            )  # fmt: skip
    return bones


def ragdoll(n: int = 3, responder: Responder | None = None, joint_friction: float = 10.0) -> World:
    """Box2D's "Ragdoll" (samples/sample_joints.cpp, shared/human.c), simplified: ``n`` ragdolls
    of capsules (``add_ragdoll``) dropped side by side, each tipped a little,
    from 1 m onto the ground, with a step to fall over. The claim: the joints hold (no pin
    opens past 5 cm) and every bone keeps within its limits, as the ragdolls crumple and come
    to rest. They rest thanks to ``joint_friction`` (N m per pin, as Box2D's human has): with
    0, an arm left hanging off a ragdoll propped on the step swings on as a frictionless
    pendulum under either solver (SoftStep's three end with two such arms, PGS's with none)."""
    n = _check_count(n, "n")
    non_negative_float(joint_friction, "joint_friction")
    w = World(responder=responder)
    ground(w)
    w.add_box((0.0, 0.25), half_extents=(0.6 * n, 0.25), static=True, friction=0.6)
    for k in range(n):
        x = (k - 0.5 * (n - 1)) * 1.0
        add_ragdoll(w, (x, 2.5 + 0.3 * k), group=-(k + 1), joint_friction=joint_friction)
        for body in w.bodies[-len(_BONES) :]:
            body.velocity = (0.3 * (k % 2) - 0.15, 0.0)
    return w


STOCK_SCENES: dict[str, tuple[Callable[..., World], str]] = {
    "arch": (arch, "scale of the sample's arch points (the arch is 0.25: 11 m tall)"),
    "card_house": (card_house, "pairs of cards on the bottom level"),
    "confined": (confined, "circles per side of the square grid"),
    "double_domino": (double_domino, "dominoes"),
    "friction_ramp": (friction_ramp, "density of the five boxes, in kg/m^2"),
    "high_mass_ratio": (high_mass_ratio, "Box2D's variant: 1 pyramids, 2 big box on boxes, 3 on triangles"),
    "overlap_recovery": (overlap_recovery, "boxes at the base of the overlapping pyramid"),
    "rush": (rush, "circles rushing the centre"),
    "bridge": (bridge, "planks of the bridge"),
    "ball_and_chain": (ball_and_chain, "links in the chain"),
    "joint_grid": (joint_grid, "circles per side of the pinned grid"),
    "far_pyramid": (far_pyramid, "boxes at the base of the pyramid 100 km out"),
    "large_pyramid": (large_pyramid, "boxes at the base of the pyramid"),
    "many_pyramids": (many_pyramids, "rows of pyramids (20 pyramids of base 10 each)"),
    "car": (car, "length of the terrain, in m"),
    "ragdoll": (ragdoll, "ragdolls dropped"),
}


def _joint_watch(limit: float) -> Callable[[World], Watch]:
    return lambda w: JointWatch(w, gap_limit=limit)


WATCHES: dict[str, Callable[[World], Watch]] = {
    # stood: nothing moved more than 0.5 m (the arch sags 0.3 m at its top as it settles) or
    # 5 cm and 20 deg (cards), at rest at the end
    "arch": lambda w: Watch(w),
    "card_house": lambda w: Watch(w, fall_distance=0.05, fall_turn=math.radians(20.0)),
    # contained: no circle's centre crosses a wall's inner face (none more than half into a wall)
    "confined": lambda w: RegionWatch(w, lower=(-CONFINED_INNER, 0.5), upper=(CONFINED_INNER, 2.0 * CONFINED_INNER)),
    # toppled: every domino turned past 30 deg, each no earlier than the one before
    "double_domino": lambda w: ToppleWatch(w),
    # coulomb: from 1.5 s to 2 s (landed), boxes with mu > tan(slope) slowed down, the others sped up
    "friction_ramp": lambda w: RampWatch(w, slope=RAMP_SLOPE, ramp_friction=RAMP_FRICTION),
    # held: from 3 s on (landed) nothing moved more than 0.25 m, and the light bodies were not
    # crushed: the deepest overlap at the end is under 0.25 m (a quarter of their height)
    "high_mass_ratio": lambda w: SettleWatch(
        w,
        settle=3.0,
        dropped=np.flatnonzero(w.M_inv[:, 0] > 0.0),
        passes_as=HELD,
        overlap_limit=0.25,
        fall_distance=0.25,
    ),
    # recovered: no body faster than 5 m/s, apart (overlap < 1 cm) and at rest at the end
    "overlap_recovery": lambda w: RecoveryWatch(w),
    # contained: nothing pushed into the centre circle (centres stay 0.9 m away) nor flung out
    "rush": lambda w: RegionWatch(w, keep_out=((0.0, 0.0), 0.9), lower=(-40.0, -40.0), upper=(40.0, 40.0)),
    # held: no joint opened more than the limit (m) in any step
    "bridge": _joint_watch(0.05),
    "ball_and_chain": _joint_watch(0.05),
    "joint_grid": _joint_watch(0.1),
    # stood: from 1.5 s on (the spaced pyramid has dropped into place) nothing moved more than 0.5 m
    "far_pyramid": lambda w: SettleWatch(w, settle=1.5, dropped=np.flatnonzero(w.M_inv[:, 0] > 0.0)),
    "large_pyramid": lambda w: Watch(w),
    "many_pyramids": lambda w: Watch(w),
    # drove: the chassis (the first dynamic body) went right at half the wheels' rolling speed
    # wheel_speed r = 3.2 m/s (the default) or more, on its wheels (it never turned past 60 deg)
    "car": lambda w: DriveWatch(w, body=int(np.flatnonzero(w.M_inv[:, 0] > 0.0)[0]), min_speed=1.6),
    # held: no pin opened more than 5 cm as the ragdolls fell and crumpled
    "ragdoll": _joint_watch(0.05),
}
verdict.WATCHES.update(WATCHES)  # ``verdict.watch_for`` judges each by its own claim
