"""Stock scenes: each returns a ready World, and each takes ``responder=``.

Units are SI: 1 m boxes of density 1 kg/m^2 on a static ground box 200 m wide
whose top is at y = 0, gravity (0, -10) m/s^2, friction 0.6.
"""

from __future__ import annotations

import math

from .responders.base import Responder
from .scene_parts import check_count as _check_count
from .scene_parts import ground
from .validation import finite_float, positive_float
from .world import World


def pyramid(rows: int = 20, responder: Responder | None = None, size: float = 1.0) -> World:
    """Row r (0 at the bottom) holds rows - r touching boxes centred on x = 0."""
    rows = _check_count(rows, "rows")
    w = World(responder=responder)
    ground(w)
    h = 0.5 * positive_float(size, "size")
    for r in range(rows):
        count = rows - r
        for k in range(count):
            w.add_box(position=((k - 0.5 * (count - 1)) * size, h + r * size), half_extents=(h, h))
    return w


def vertical_stack(n: int = 10, responder: Responder | None = None, size: float = 1.0, lean: float = 0.0) -> World:
    """n touching boxes of side ``size`` (m), one on another; box k (0 at the bottom) is
    centred at x = lean * k (m), so lean != 0 makes a stack that leans to one side
    (lean < 0: to the left). lean = 0 is the straight stack at x = 0.
    """
    n = _check_count(n, "n")
    lean = finite_float(lean, "lean")
    w = World(responder=responder)
    ground(w)
    h = 0.5 * positive_float(size, "size")
    for k in range(n):
        w.add_box(position=(lean * k, h + k * size), half_extents=(h, h))
    return w


def mass_ratio(ratio: float = 100.0, responder: Responder | None = None) -> World:
    """A 1 kg, 0.5 m box on the ground under a box of ``ratio`` kg, 1 m wide."""
    if isinstance(ratio, bool) or not isinstance(ratio, (int, float)) or not ratio > 0 or not math.isfinite(ratio):
        raise ValueError(f"ratio must be a finite number > 0, got {ratio!r}")
    w = World(responder=responder)
    ground(w)
    w.add_box(position=(0.0, 0.25), half_extents=(0.25, 0.25), density=1.0 / 0.25)
    w.add_box(position=(0.0, 1.0), half_extents=(0.5, 0.5), density=float(ratio))
    return w


def dominoes(n: int = 12, responder: Responder | None = None) -> World:
    """n thin dominoes 0.8 m apart; the first is tipped so it topples the rest."""
    n = _check_count(n, "n")
    w = World(responder=responder)
    ground(w)
    hx, hy, gap = 0.1, 0.5, 0.8
    for k in range(n):
        w.add_box(position=(k * gap, hy), half_extents=(hx, hy), angular_velocity=-1.5 if k == 0 else 0.0)
    return w


def mixed_shapes(n: int = 12, responder: Responder | None = None) -> World:
    """Boxes, circles and triangles dropped in a heap onto the ground."""
    n = _check_count(n, "n")
    w = World(responder=responder)
    ground(w)
    tri = [(-0.5, -0.3), (0.5, -0.3), (0.0, 0.5)]
    hexagon = [(0.4 * math.cos(a), 0.4 * math.sin(a)) for a in [k * math.pi / 3 for k in range(6)]]
    for k in range(n):
        x = ((k * 7) % 5 - 2) * 0.9
        y = 1.0 + 1.1 * k
        kind = k % 4
        if kind == 0:
            w.add_box(position=(x, y), half_extents=(0.4, 0.3), angle=0.3 * k)
        elif kind == 1:
            w.add_circle(position=(x, y), radius=0.35)
        elif kind == 2:
            w.add_polygon(position=(x, y), vertices=tri, angle=0.5 * k)
        else:
            w.add_polygon(position=(x, y), vertices=hexagon)
    return w


def pendulum_chain(links: int = 10, responder: Responder | None = None, link_length: float = 0.5) -> World:
    """A chain of ``links`` boxes pinned end to end, hung from a static pivot.

    The chain starts straight out to the right of the pivot (at height
    links * link_length + 1 m, so it never reaches the ground) and swings down.
    Links are link_length x link_length / 4 boxes; neighbours do not collide.
    Needs a responder that solves joints (PGS): the naive takes raise ValueError.
    """
    links = _check_count(links, "links")
    if (
        isinstance(link_length, bool)
        or not isinstance(link_length, (int, float))
        or not link_length > 0
        or not math.isfinite(link_length)
    ):
        raise ValueError(f"link_length must be a finite number > 0, got {link_length!r}")
    w = World(responder=responder)
    ground(w)
    top = links * link_length + 1.0
    previous = w.add_circle(position=(0.0, top), radius=0.05, static=True)
    half = (0.5 * link_length, 0.125 * link_length)
    for k in range(links):
        link = w.add_box(position=((k + 0.5) * link_length, top), half_extents=half)
        w.add_pin_joint(previous, link, anchor=(k * link_length, top))
        previous = link
    return w


def heavy_chain(
    links: int = 20, ratio: float = 100.0, responder: Responder | None = None, link_length: float = 0.5
) -> World:
    """A chain of ``links`` boxes carrying a box ``ratio`` times as heavy as one link.

    As ``pendulum_chain``: links are link_length x link_length / 4 boxes of density
    1 kg/m^2, pinned end to end and hung from a static pivot (a circle of radius
    0.05 m, body 1 after the ground), the chain starting straight out to the right
    and swinging down. A square box of side link_length is pinned at its left edge
    to the free end of the last link; its density makes its mass ratio * a link's
    mass (kg). The pivot is (links + 1) * link_length + 1 m above the ground, so
    the hanging chain and box clear it by 1 m. Joints: ``links`` + 1 pins, joined
    bodies do not collide. Needs a responder that solves joints: others raise
    ValueError.
    """
    links = _check_count(links, "links")
    ratio = positive_float(ratio, "ratio")
    link_length = positive_float(link_length, "link_length")
    w = World(responder=responder)
    ground(w)
    top = (links + 1) * link_length + 1.0
    previous = w.add_circle(position=(0.0, top), radius=0.05, static=True)
    half = (0.5 * link_length, 0.125 * link_length)
    link_mass = 4.0 * half[0] * half[1]  # kg, at density 1
    for k in range(links):
        link = w.add_box(position=((k + 0.5) * link_length, top), half_extents=half)
        w.add_pin_joint(previous, link, anchor=(k * link_length, top))
        previous = link
    h = 0.5 * link_length
    heavy = w.add_box(
        position=(links * link_length + h, top), half_extents=(h, h), density=ratio * link_mass / (4.0 * h * h)
    )
    w.add_pin_joint(previous, heavy, anchor=(links * link_length, top))
    return w


def terrain_height(x: float) -> float:
    """The height (m) of ``capsules_on_chain``'s rolling terrain at x (m): 0.25 sin(x / 2), slopes
    up to 0.125, well below the friction 0.6."""
    return 0.25 * math.sin(0.5 * x)


def capsules_on_chain(n: int = 8, responder: Responder | None = None) -> World:
    """n bodies dropped from 5 cm onto a rolling chain terrain: capsules lying on their sides
    (half length 0.4 m, radius 0.2 m) and 0.6 m boxes in turn, 1.5 m apart, so that some
    land across the joins of its 1 m segments. The terrain is one static chain through
    (x, terrain_height(x)) at every metre, listed right to left so that its colliding
    (right) side faces up, reaching 3 m past the bodies on each side. They should come
    to rest where they land (friction 0.6): the chain meets them with its faces only.
    """
    n = _check_count(n, "n")
    w = World(responder=responder)
    reach = math.ceil(0.75 * n) + 3
    w.add_chain([(float(x), terrain_height(x)) for x in range(reach, -reach - 1, -1)], friction=0.6)
    for k in range(n):
        x = (k - 0.5 * (n - 1)) * 1.5
        ground_y = terrain_height(x)
        slope = math.atan(0.125 * math.cos(0.5 * x))  # the terrain's angle under x
        if k % 2 == 0:
            w.add_capsule((x, ground_y + 0.25), half_length=0.4, radius=0.2, angle=slope, friction=0.6)
        else:
            w.add_box((x, ground_y + 0.35), half_extents=(0.3, 0.3), angle=slope, friction=0.6)
    return w


SCENES = {
    "pyramid": (pyramid, "rows of the pyramid"),
    "vertical_stack": (vertical_stack, "boxes in the stack"),
    "mass_ratio": (mass_ratio, "mass of the heavy box, in kg (the light one is 1 kg)"),
    "dominoes": (dominoes, "dominoes"),
    "mixed_shapes": (mixed_shapes, "bodies dropped"),
    "pendulum_chain": (pendulum_chain, "links in the chain"),
    "heavy_chain": (heavy_chain, "links in the chain (the box at its end is 100x a link's mass)"),
    "capsules_on_chain": (capsules_on_chain, "capsules and boxes dropped on the chain terrain"),
}

# Box2D's and Solver2D's samples (phys2d/stock_scenes.py)
from .stock_scenes import (  # noqa: E402, F401
    STOCK_SCENES,
    arch,
    ball_and_chain,
    bridge,
    car,
    card_house,
    confined,
    double_domino,
    far_pyramid,
    friction_ramp,
    high_mass_ratio,
    joint_grid,
    large_pyramid,
    many_pyramids,
    overlap_recovery,
    ragdoll,
    rush,
)

SCENES.update(STOCK_SCENES)
