"""What the stock scenes (``phys2d.scenes``, ``phys2d.stock_scenes``) are built on: the ground, and
their counts checked.

Units are SI: a static ground box 200 m wide whose top is at y = 0, friction 0.6.
"""

from __future__ import annotations

from .bodies import Body
from .world import World

GROUND_HALF_WIDTH = 100.0  # m
GROUND_HALF_HEIGHT = 0.5  # m


def check_count(value, name: str, low: int = 1) -> int:
    """``value`` as a count >= low (bools refused), the error naming ``name``."""
    if isinstance(value, bool) or not isinstance(value, int):
        raise TypeError(f"{name} must be an integer, got {type(value).__name__}")
    if value < low:
        raise ValueError(f"{name} must be >= {low}, got {value}")
    return value


def ground(w: World, friction: float = 0.6) -> Body:
    """The static ground box: 200 m wide, top at y = 0."""
    return w.add_box(
        position=(0.0, -GROUND_HALF_HEIGHT),
        half_extents=(GROUND_HALF_WIDTH, GROUND_HALF_HEIGHT),
        static=True,
        friction=friction,
    )
