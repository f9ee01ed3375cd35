"""The child process of ``pipeline.ahead``: one step of a small world, compiling the tick from its
first stage down into numba's cache while the parent compiles the stages from the last one up.

    python -m phys2d.pipeline.compile_child < pickled (responder, joints, rounded, threads)
"""

from __future__ import annotations

import pickle
import sys
from typing import Any

from ..world import World
from .ahead import one_child_per_cache


def main() -> None:
    """Step a small world under the responder read from stdin (one step: every kernel it needs)."""
    responder, joints, rounded, threads = pickle.loads(sys.stdin.buffer.read())
    with one_child_per_cache():
        _step_a_small_world(responder, joints, rounded, threads)


def _step_a_small_world(responder: Any, joints: bool, rounded: bool, threads: int) -> None:
    """One step of a small world with a box, a circle and (as asked) a capsule and a joint."""
    w = World(responder=responder, threads=threads)
    w.add_box(position=(0.0, -0.5), half_extents=(5.0, 0.5), static=True)
    a = w.add_box(position=(0.0, 0.5), half_extents=(0.5, 0.5))
    b = w.add_circle(position=(2.0, 0.5), radius=0.5)
    if rounded:
        w.add_capsule(position=(-2.0, 0.25), half_length=0.5, radius=0.25)
    if joints:
        w.add_distance_joint(a, b)
    w.step(1 / 60)


if __name__ == "__main__":
    main()
