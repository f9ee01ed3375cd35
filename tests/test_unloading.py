"""Stored impulses must not outlive their load: removing a heavy box does not launch the
column it rested on (the lecture's contact caching has this price, lesson 06)."""

from __future__ import annotations

import numpy as np
import pytest

import phys2d

DT = 1 / 60
RESPONDERS = {name: phys2d.REGISTRY[name] for name in ("pgs", "pgs-block", "soft-step")}


def column(responder: phys2d.Responder, ratio: float | None) -> tuple[phys2d.World, list, phys2d.Body | None]:
    """Three 1 m boxes of 1 kg on the ground, and on top a 1 m box ``ratio`` times as heavy."""
    w = phys2d.World(responder=responder)
    phys2d.scenes.ground(w)
    boxes = [w.add_box(position=(0.0, 0.5 + k)) for k in range(3)]
    top = None if ratio is None else w.add_box(position=(0.0, 3.5), density=ratio)
    return w, boxes, top


def rise_after_unloading(name: str, ratio: float, settle: float = 2.0, after: float = 3.0) -> tuple[float, float]:
    """(largest speed in the last 0.5 s before the removal, m/s; largest rise of any box above
    its unloaded resting height after it, m). The unloaded resting heights are those of the
    same column without the heavy box, settled by the same responder."""
    rest_w, rest_boxes, _ = column(RESPONDERS[name](), None)
    for _ in range(round((settle + after) / DT)):
        rest_w.step(DT)
    rest = np.array([b.position[1] for b in rest_boxes])
    w, boxes, top = column(RESPONDERS[name](), ratio)
    moving = 0.0
    for k in range(round(settle / DT)):
        w.step(DT)
        if k >= round((settle - 0.5) / DT):
            moving = max(moving, float(np.abs(w.V).max()))
    w.remove(top)
    rise = -np.inf
    for _ in range(round(after / DT)):
        w.step(DT)
        rise = max(rise, max(b.position[1] - r for b, r in zip(boxes, rest)))
    return moving, rise


@pytest.mark.parametrize("name", sorted(RESPONDERS))
def test_removing_a_30x_heavier_box_does_not_launch_the_column(name: str) -> None:
    moving, rise = rise_after_unloading(name, 30.0)
    assert moving < 0.1  # the loaded column was at rest
    assert rise <= 0.005


def test_a_removed_load_starts_its_island_cold_and_leaves_other_islands_warm() -> None:
    """The pairs that pushed on the removed box are gone: every contact connected to them
    through dynamic bodies starts from lambda = 0; a box resting elsewhere keeps its cache."""
    w, boxes, top = column(phys2d.PGS(), 30.0)
    far = w.add_box(position=(5.0, 0.5))
    for _ in range(60):
        w.step(DT)
    w.remove(top)
    w.step(DT)
    c = w.contacts
    in_column = np.isin(c.body_b, [b.index for b in boxes])
    assert in_column.sum() == 6 and not c.warm_started[in_column].any()
    assert c.warm_started[c.body_b == far.index].all()
    w.step(DT)  # and from the next step on the column warm starts again
    assert w.contacts.warm_started.all()
