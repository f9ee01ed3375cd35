"""Scenes the sweeps add to the stock ones (``phys2d.scenes.SCENES``).

``circle_stack`` is Catto's test (GDC 2014, "Understanding Constraints"): circles
stacked on the ground, touching, at rest, so that the exact impulse of every contact
over a tick is known in closed form (the weight it carries times dt).

``COLUMNS`` names the scenes whose bodies stand in one column, added bottom up
after the ground (body 0): for them the contact between bodies i - 1 and i must
carry g dt times the mass of bodies i, i + 1, ..., and a sweep row reports how far
the impulses are from that (``load_error_*``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, cast

from .. import scenes
from ..responders.base import Responder
from ..validation import positive_float
from ..world import World

CIRCLE_RADIUS = 0.5  # m
BASE_MASS = 1.0  # kg, every circle but the top one


def circle_stack(n: int = 2, responder: Responder | None = None, mass_ratio: float = 1.0) -> World:
    """n circles of radius 0.5 m stacked on the ground, each touching the next, at rest.

    Every circle weighs 1 kg except the top one, which weighs ``mass_ratio`` kg:
    mass_ratio 10 is Catto's heavy on light (10 kg on 1 kg), 0.5 his light on heavy
    (0.5 kg on 1 kg), 1 his equal masses.
    """
    if isinstance(n, bool) or not isinstance(n, int):
        raise TypeError(f"n must be an integer, got {type(n).__name__}")
    if n < 1:
        raise ValueError(f"n must be >= 1, got {n}")
    ratio = positive_float(mass_ratio, "mass_ratio")
    w = World(responder=responder)
    scenes.ground(w)
    area = math.pi * CIRCLE_RADIUS**2
    for k in range(n):
        mass = ratio * BASE_MASS if k == n - 1 else BASE_MASS
        w.add_circle(position=(0.0, (k + 0.5) * 2.0 * CIRCLE_RADIUS), radius=CIRCLE_RADIUS, density=mass / area)
    return w


SWEEP_SCENES: dict[str, tuple[Callable[..., World], str]] = {
    "circle_stack": (circle_stack, "circles in the stack (1 kg each; the top one weighs mass_ratio kg)"),
}

RATIO_SCENES = ("mass_ratio", "circle_stack")  # scenes that take the mass_ratio axis
COLUMNS = ("vertical_stack", "mass_ratio", "circle_stack")  # one column, bottom up, ground first


def all_scenes() -> dict[str, tuple[Callable[..., World], str]]:
    """The stock scenes (read now, so scenes added to ``phys2d.scenes`` count) and the sweep's own."""
    known = cast(dict[str, tuple[Callable[..., World], str]], dict(scenes.SCENES))
    known.update(SWEEP_SCENES)
    return known


def build_scene(scene: str, size: Any, mass_ratio: float | None, responder: Responder) -> World:
    """The world of ``scene`` with its main count ``size`` (None: the scene's default) and ratio."""
    known = all_scenes()
    if scene not in known:
        raise ValueError(f"scene must be one of {', '.join(known)}; got {scene!r}")
    builder = known[scene][0]
    if scene == "mass_ratio":
        return builder(responder=responder) if mass_ratio is None else builder(mass_ratio, responder=responder)
    kwargs: dict[str, Any] = {"responder": responder}
    if scene in RATIO_SCENES and mass_ratio is not None:
        kwargs["mass_ratio"] = mass_ratio
    return builder(**kwargs) if size is None else builder(size, **kwargs)


__all__ = [
    "BASE_MASS",
    "CIRCLE_RADIUS",
    "COLUMNS",
    "RATIO_SCENES",
    "SWEEP_SCENES",
    "all_scenes",
    "build_scene",
    "circle_stack",
]
