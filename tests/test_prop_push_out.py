"""Push-out speed is bounded: bodies created overlapping separate no faster than push_max."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, note
from hypothesis import strategies as st

import phys2d
from tests.strategies import reals

# every registered responder, and the lecture's push (PGS(split=False), which has no name)
RESPONDERS = {**phys2d.REGISTRY, "pgs-lecture-push": lambda **kw: phys2d.PGS(split=False, **kw)}


@st.composite
def overlapping_pairs(draw):
    """Up to three pairs of bodies, each pair overlapping by up to half the smaller one's size,
    far from the other pairs, some against a static ground (no gravity)."""
    pairs = []
    for p in range(draw(st.integers(1, 3))):
        kinds = draw(st.tuples(st.sampled_from(["box", "circle"]), st.sampled_from(["box", "circle", "ground"])))
        r = draw(st.tuples(reals(0.2, 1.0), reals(0.2, 1.0)))
        depth = draw(reals(0.0, 0.5)) * 2 * min(r)  # up to half the smaller size
        direction = draw(reals(-math.pi, math.pi)) if kinds[1] != "ground" else math.pi / 2
        density = draw(st.tuples(reals(0.2, 5.0), reals(0.2, 5.0)))
        pairs.append((10.0 * p, kinds, r, depth, direction, density))
    return pairs


def build(pairs, responder: phys2d.Responder) -> phys2d.World:
    w = phys2d.World(gravity=(0.0, 0.0), responder=responder)
    for x0, kinds, r, depth, direction, density in pairs:
        if kinds[1] == "ground":  # the first body sunk into a static slab by depth
            w.add_box(position=(x0, -0.5), half_extents=(3.0, 0.5), static=True)
            add(w, kinds[0], (x0, r[0] - depth), r[0], density[0])
            continue
        add(w, kinds[0], (x0, 0.0), r[0], density[0])
        d = r[0] + r[1] - depth  # centres this far apart along the direction: overlap about depth
        add(w, kinds[1], (x0 + d * math.cos(direction), d * math.sin(direction)), r[1], density[1])
    return w


def add(w: phys2d.World, kind: str, position, size: float, density: float) -> None:
    if kind == "circle":
        w.add_circle(position=position, radius=size, density=density)
    else:
        w.add_box(position=position, half_extents=(size, size), density=density)


@given(
    pairs=overlapping_pairs(), name=st.sampled_from(sorted(RESPONDERS)), dt=st.sampled_from([1 / 30, 1 / 60, 1 / 120])
)
def test_overlapping_bodies_separate_no_faster_than_the_push_out_cap(pairs, name: str, dt: float) -> None:
    """Bodies created overlapping by up to half their size, at rest, no gravity: over 2 s
    they separate, and no body ever moves faster than push_max (3 m/s) + 0.5 m/s."""
    responder = RESPONDERS[name]()
    w = build(pairs, responder)
    fastest = 0.0
    for _ in range(round(2.0 / dt)):
        w.step(dt)
        fastest = max(fastest, float(np.hypot(w.V[:, 0], w.V[:, 1]).max()))
    note(f"fastest {fastest:.4g} m/s")
    assert fastest <= responder.push_max + 0.5
    slop = max(responder.slop, 0.005)
    assert max(0.0, -w.contacts.separation.min(initial=0.0)) <= slop + 0.01  # they did separate


@pytest.mark.parametrize("name", sorted(RESPONDERS))
@pytest.mark.parametrize("push_max", [0.5, 3.0])
def test_a_deep_overlap_is_removed_at_push_max(name: str, push_max: float) -> None:
    """A box sunk 0.5 m into the ground: the overlap shrinks by no more than push_max dt a step
    (however beta asks for more), and what moves it is not kept as speed beyond push_max."""
    dt = 1 / 60
    responder = RESPONDERS[name](push_max=push_max)
    w = phys2d.World(gravity=(0.0, 0.0), responder=responder)
    w.add_box(position=(0.0, -0.5), half_extents=(5.0, 0.5), static=True)
    box = w.add_box(position=(0.0, 0.0), half_extents=(0.5, 0.5))
    depth = 0.5
    for _ in range(round(0.5 / (push_max * dt)) + 60):
        w.step(dt)
        now = max(0.0, 0.5 - box.position[1])
        assert depth - now <= push_max * dt * (1 + 1e-9) + 1e-12
        assert float(np.hypot(*box.velocity)) <= push_max + 1e-9
        depth = now
    assert depth <= 0.006  # out, to within slop
