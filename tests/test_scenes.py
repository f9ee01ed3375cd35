"""The stock scenes of issue 11: the leaning stack and the heavy chain.

Expected values come from the geometry the docstrings promise (box k at
x = lean * k, masses from density times area) and, for the straight stack, from
building the scene by hand with the World API: a second method.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

import phys2d
from phys2d import scenes

DT = 1 / 60


def state(w: phys2d.World) -> tuple[np.ndarray, ...]:
    return (w.x.copy(), w.theta.copy(), w.V.copy(), w.M_inv.copy())


def assert_same_world(a: phys2d.World, b: phys2d.World) -> None:
    for u, v in zip(state(a), state(b), strict=True):
        assert u.tobytes() == v.tobytes()


# -- the leaning stack ------------------------------------------------------------------


def straight_stack_by_hand(n: int) -> phys2d.World:
    """vertical_stack(n) as it was before ``lean``: ground, then n 1 m boxes at x = 0."""
    w = phys2d.World()
    w.add_box(position=(0.0, -0.5), half_extents=(100.0, 0.5), static=True, friction=0.6)
    for k in range(n):
        w.add_box(position=(0.0, 0.5 + k), half_extents=(0.5, 0.5))
    return w


def test_lean_zero_is_the_straight_stack_bit_for_bit():
    by_hand = straight_stack_by_hand(20)
    default = scenes.vertical_stack(20)
    zero = scenes.vertical_stack(20, lean=0.0)
    assert_same_world(by_hand, default)
    assert_same_world(by_hand, zero)
    for _ in range(120):  # and they stay twins: same bodies, same order, same contacts
        for w in (by_hand, default, zero):
            w.step(DT)
    assert_same_world(by_hand, default)
    assert_same_world(by_hand, zero)


@pytest.mark.parametrize("lean", [1e-4, 1e-3, -0.02, 0.3])
@pytest.mark.parametrize("size", [1.0, 0.5])
def test_lean_shifts_box_k_by_lean_times_k(lean, size):
    n = 20
    w = scenes.vertical_stack(n, size=size, lean=lean)
    straight = scenes.vertical_stack(n, size=size)
    assert len(w) == n + 1
    k = np.arange(n)
    assert np.array_equal(w.x[1:, 0], lean * k)  # exactly the promised offsets
    assert np.array_equal(w.x[1:, 1], straight.x[1:, 1])  # heights unchanged
    assert np.array_equal(w.M_inv, straight.M_inv)
    assert not w.theta.any()
    # neighbours still rest face on face: the top of box k is the bottom of box k + 1
    top = w.x[1:-1, 1] + 0.5 * size
    bottom = w.x[2:, 1] - 0.5 * size
    assert np.allclose(top, bottom, rtol=0.0, atol=1e-12)
    # the top box's centre overhangs the bottom box's by lean * (n - 1)
    assert w.x[-1, 0] - w.x[1, 0] == pytest.approx(lean * (n - 1), rel=1e-12)


def test_a_stack_leaning_past_its_base_topples():
    # box k + 1 overhangs box k by 0.3 m: the centre of mass of the boxes above the bottom
    # box lies 0.3 * (n + 1) / 2 > 0.5 m beyond its centre, past its edge, so it must fall.
    w = scenes.vertical_stack(5, lean=0.3)
    start = w.x.copy()
    for _ in range(180):
        w.step(DT)
    assert np.abs(w.x[1:] - start[1:]).max() > 0.5


@pytest.mark.parametrize(
    "bad, error",
    [(math.nan, ValueError), (math.inf, ValueError), ("1", TypeError), (None, TypeError), (True, TypeError)],
)
def test_lean_refuses_bad_values_naming_lean(bad, error):
    with pytest.raises(error, match="lean"):
        scenes.vertical_stack(5, lean=bad)


# -- the heavy chain -------------------------------------------------------------------------


@pytest.mark.parametrize("links, ratio, length", [(20, 100.0, 0.5), (3, 7.5, 1.0), (1, 1000.0, 0.2)])
def test_heavy_chain_is_what_it_says(links, ratio, length):
    w = scenes.heavy_chain(links, ratio=ratio, link_length=length)
    bodies = w.bodies
    assert len(bodies) == links + 3  # ground, pivot, links, heavy box
    ground, pivot, chain, heavy = bodies[0], bodies[1], bodies[2:-1], bodies[-1]
    assert ground.static and pivot.static and pivot.shape == "circle"
    assert not any(b.static for b in chain) and not heavy.static
    link_mass = length * length / 4  # density 1
    for b in chain:
        assert b.mass == pytest.approx(link_mass, rel=1e-12)
    assert heavy.mass / chain[0].mass == pytest.approx(ratio, rel=1e-12)
    # every joint is a pin holding its two points together at the start
    assert len(w.joints) == links + 1
    assert all(isinstance(j, phys2d.PinJoint) for j in w.joints)
    assert max(j.gap() for j in w.joints) < 1e-12
    # a chain from the pivot to the heavy box, anchored at the links' ends
    top = pivot.position[1]
    expected = [pivot] + list(chain) + [heavy]
    for k, j in enumerate(w.joints):
        assert j.body_a == expected[k] and j.body_b == expected[k + 1]
        p_a, p_b = j.anchors()
        assert np.allclose(p_a, (k * length, top), rtol=0.0, atol=1e-12)
        assert np.allclose(p_b, p_a, rtol=0.0, atol=1e-12)
    # hanging straight down, the chain and the box clear the ground (y = 0) by 1 m
    assert top - (links * length + length) == pytest.approx(1.0, rel=1e-12)


def test_heavy_chain_falls_under_pgs_but_no_faster_than_free_fall():
    w = scenes.heavy_chain(20)
    heavy = w.bodies[-1]
    y0 = heavy.position[1]
    n = 60
    for _ in range(n):
        w.step(DT)
    # after 1 s the box has fallen, but no further than free fall from rest under
    # semi-implicit Euler: sum over steps k = 1..n of k g dt * dt = g dt^2 n (n + 1) / 2
    drop = y0 - heavy.position[1]
    assert 0.5 < drop <= 10.0 * DT**2 * n * (n + 1) / 2 + 1e-9


def test_heavy_chain_refuses_a_responder_without_joints():
    with pytest.raises(ValueError, match="cannot solve joints"):
        scenes.heavy_chain(4, responder=phys2d.NaiveImpulse())


@pytest.mark.parametrize(
    "name, bad, error",
    [
        ("links", 0, ValueError),
        ("links", 2.5, TypeError),
        ("ratio", 0.0, ValueError),
        ("ratio", math.inf, ValueError),
        ("ratio", "100", TypeError),
        ("link_length", -0.5, ValueError),
        ("link_length", None, TypeError),
    ],
)
def test_heavy_chain_refuses_bad_arguments_naming_them(name, bad, error):
    with pytest.raises(error, match=name):
        scenes.heavy_chain(**{name: bad})


def test_new_scenes_are_listed_with_what_size_means():
    assert scenes.SCENES["heavy_chain"][0] is scenes.heavy_chain
    assert "links" in scenes.SCENES["heavy_chain"][1]
    assert scenes.SCENES["vertical_stack"][0] is scenes.vertical_stack


# -- the benchmark builds the same scenes ------------------------------------------------------


@pytest.fixture(scope="module")
def bench_engines():
    bench = str(Path(__file__).resolve().parents[1] / "benchmarks")
    sys.path.insert(0, bench)
    try:
        import engines
    finally:
        sys.path.remove(bench)
    return engines


@pytest.mark.parametrize(
    "name, stock",
    [
        ("vertical_stack_20", lambda: scenes.vertical_stack(20)),
        ("vertical_stack_20_lean_0.1mm", lambda: scenes.vertical_stack(20, lean=1e-4)),
        ("vertical_stack_20_lean_1mm", lambda: scenes.vertical_stack(20, lean=1e-3)),
        ("heavy_chain_20", lambda: scenes.heavy_chain(20)),
    ],
)
def test_benchmark_scenes_match_the_stock_scenes(bench_engines, name, stock):
    """benchmarks/engines.py describes its scenes as plain data; phys2d built from that
    data is the stock scene, body for body and joint for joint."""
    bench = bench_engines.Phys2DAdapter(bench_engines.SCENES[name]()).world
    w = stock()
    assert_same_world(bench, w)
    assert len(bench.joints) == len(w.joints)
    for p, q in zip(bench.joints, w.joints, strict=True):
        assert type(p) is type(q)
        assert (p.body_a.index, p.body_b.index) == (q.body_a.index, q.body_b.index)
        assert np.array_equal(p.local_a, q.local_a) and np.array_equal(p.local_b, q.local_b)
