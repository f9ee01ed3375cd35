"""World.threads: the contact rows and the soft step's sweeps on several threads give
bit-identical results.

The second method is the world on one thread: a world stepped on 2 or 3 threads (more than
this machine's cores is allowed) must hold the same bits after every step, in one call and
stage by stage, under every responder, with joints and sleeping islands. The groups the sweeps
are cut into are checked against their definition (no moving body in two segments of a group),
the parts of a pyramid for balance, and a world on one thread must compile no parallel kernel.
"""

from __future__ import annotations

import copy
import json
import os
import subprocess
import sys
from pathlib import Path

import numba
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import phys2d
from phys2d import scenes as stock
from phys2d.constraints.order import COLOUR_ORDER, PART_DEPTH, PART_ORDER, PARTS_FROM, order_pairs
from phys2d.pipeline.parallel import manifold_groups
from phys2d.pipeline.records import new_rows
from tests.strategies import SceneSpec, build, fingerprint, responders, resting_scenes, scenes, soft_step_keywords

ROOT = Path(__file__).resolve().parent.parent
BIG = 33  # a pyramid of base 33: 561 boxes, at least PARTS_FROM, so PGS and the soft step cut it into parts


def stepped_alike(make, threads: int, one_call: bool, steps: int, dt: float = 1 / 60, seen=None) -> None:
    """Step a world from ``make`` on one thread (in one call) and another on ``threads`` threads
    (``one_call`` or stage by stage), asserting bit-identical fingerprints after every step
    (``seen(world)`` is called after each)."""
    one, many = make(), make()
    many.threads = threads
    many.one_call_tick = one_call
    for _ in range(steps):
        failed = [False, False]
        for i, w in enumerate((one, many)):
            try:
                w.step(dt)
            except phys2d.SimulationError:
                failed[i] = True
        assert failed[0] == failed[1]
        assert fingerprint(many) == fingerprint(one)
        if seen is not None:
            seen(many)
        if failed[0]:
            return


@st.composite
def piles(draw) -> SceneSpec:
    """Stacks at rest, or a few bodies thrown together over a ground (overlaps are common)."""
    if draw(st.booleans()):
        return draw(resting_scenes(max_stacks=3, max_height=4))
    return draw(scenes(min_bodies=2, max_bodies=8, ground=True, static=None))


@settings(max_examples=25)
@given(
    scene=piles(),
    keywords=soft_step_keywords(),
    threads=st.sampled_from([2, 3]),
    one_call=st.booleans(),
    steps=st.integers(5, 30),
)
def test_threads_give_the_same_bits_on_generated_scenes(scene, keywords, threads, one_call, steps) -> None:
    """Any scene, any SoftStep settings: 2 or 3 threads, in one call or in stages, hold the bits
    of one thread after every step."""
    stepped_alike(lambda: build(scene, phys2d.SoftStep(**keywords)), threads, one_call, steps)


@settings(max_examples=20)
@given(scene=piles(), data=st.data(), threads=st.sampled_from([2, 3]), one_call=st.booleans())
def test_threads_give_the_same_bits_under_every_responder(scene, data, threads, one_call) -> None:
    """Every registered responder (their contact rows are built on the threads): the bits of one
    thread after every step."""
    make = data.draw(responders().map(lambda r: lambda: copy.deepcopy(r)))
    stepped_alike(lambda: build(scene, make()), threads, one_call, 15)


@settings(max_examples=8)
@given(
    rows=st.integers(BIG - 1, BIG + 1),
    threads=st.sampled_from([2, 3]),
    one_call=st.booleans(),
    substeps=st.integers(1, 4),
)
def test_threads_give_the_same_bits_on_pyramids(rows: int, threads: int, one_call: bool, substeps: int) -> None:
    """Pyramids of PARTS_FROM boxes or more (two parts and a cut: the parallel loops have work to
    split) hold the bits of one thread after every step."""
    assert rows * (rows + 1) // 2 >= PARTS_FROM
    stepped_alike(lambda: stock.pyramid(rows, responder=phys2d.SoftStep(substeps)), threads, one_call, 40)


def add_pyramid(w: phys2d.World, base: int, x: float) -> None:
    """A pyramid of 1 m boxes, ``base`` at the bottom, centred on ``x`` (m), on the world's ground."""
    for r in range(base):
        for k in range(base - r):
            w.add_box(position=(x + k - 0.5 * (base - r - 1), 0.5 + r), half_extents=(0.5, 0.5))


@settings(max_examples=6)
@given(
    links=st.integers(2, 8),
    ratio=st.sampled_from([1.0, 10.0, 100.0]),
    threads=st.sampled_from([2, 3]),
    one_call=st.booleans(),
    direct=st.booleans(),
)
def test_threads_give_the_same_bits_with_joints(
    links: int, ratio: float, threads: int, one_call: bool, direct: bool
) -> None:
    """A heavy chain swinging into a pile (joint rows and contacts in one solve), beside a pyramid
    that makes the scene large enough for parts, holds the bits of one thread."""

    def make() -> phys2d.World:
        w = stock.heavy_chain(links, ratio, responder=phys2d.SoftStep(direct_joints=direct))
        for i in range(4):
            w.add_box(position=(0.6 * i, 0.5), half_extents=(0.3, 0.3))
        add_pyramid(w, BIG, -40.0)
        return w

    stepped_alike(make, threads, one_call, 60)


def test_threads_give_the_same_bits_while_islands_sleep_and_wake() -> None:
    """Sleeping bodies are immovable (M^-1 = 0) in the step: several segments of a group may share
    one. Piles fall asleep beside a pyramid large enough for parts, a box wakes one: the bits of one
    thread throughout."""

    def make() -> phys2d.World:
        w = stock.pyramid(5, responder=phys2d.SoftStep())
        w.sleep = True
        w.add_box(position=(8.0, 40.0), half_extents=(0.4, 0.4))
        for i in range(4):
            w.add_box(position=(8.0, 0.5 + i), half_extents=(0.5, 0.5))
        add_pyramid(w, BIG, -40.0)
        return w

    asleep = []
    stepped_alike(make, 2, True, 240, seen=lambda w: asleep.append(sum(not b.awake for b in w.bodies)))
    assert max(asleep) >= 4  # piles slept
    assert any(later < now for now, later in zip(asleep, asleep[1:]))  # and the falling box woke one


def test_threads_can_change_between_steps() -> None:
    """Switching threads between steps (and back) changes no bit, and each step runs on the count
    set before it (the count the step read: None for one thread)."""
    one, many = stock.pyramid(6, responder=phys2d.SoftStep()), stock.pyramid(6, responder=phys2d.SoftStep())
    for i in range(30):
        many.threads = 1 + i % 3
        one.step(1 / 60)
        many.step(1 / 60)
        assert many._pipeline._threads == 1 + i % 3  # the count the step read
    assert fingerprint(many) == fingerprint(one)


def test_a_step_leaves_numbas_thread_count_as_it_was() -> None:
    """The world sets numba's thread count for its step only."""
    before = numba.get_num_threads()
    w = stock.pyramid(3, responder=phys2d.SoftStep())
    w.threads = 2
    w.step(1 / 60)
    assert numba.get_num_threads() == before


@pytest.mark.parametrize("friction", ["coulomb", "lecture"])
def test_threads_on_pgs_change_nothing(friction: str) -> None:
    """A small scene under PGS is one part: it sweeps in pair order on one thread, its contact rows
    built on two: the same bits."""
    stepped_alike(lambda: stock.pyramid(6, responder=phys2d.PGS(friction=friction)), 2, True, 30)


@pytest.mark.parametrize(
    "keywords", [{}, {"block": True}, {"split": False}, {"friction": "lecture", "iterations": 4, "tolerance": 1e-3}]
)
def test_pgs_sweeps_on_threads_give_the_same_bits(keywords: dict) -> None:
    """A scene of PARTS_FROM moving bodies or more under PGS, row by row or in blocks, split or
    not, stopping early or not: its warm start and sweeps run a group's segments on 2 or 3
    threads, in one call or in stages, and hold the bits of one thread after every step."""
    assert (BIG * (BIG + 1)) // 2 >= PARTS_FROM
    for threads, one_call in ((2, True), (3, False)):
        stepped_alike(lambda: stock.pyramid(BIG, responder=phys2d.PGS(**keywords)), threads, one_call, 25)


def test_pgs_sweeps_on_threads_with_joints_give_the_same_bits() -> None:
    """Joint rows (a chain, a dragged box) follow the contacts' segments on the calling thread."""

    def make() -> phys2d.World:
        w = stock.pyramid(BIG, responder=phys2d.PGS())
        links = [w.add_box(position=(40.0 + i, 5.0), half_extents=(0.4, 0.1)) for i in range(5)]
        anchor = w.add_box(position=(39.0, 5.0), half_extents=(0.1, 0.1), static=True)
        for a, b in zip([anchor, *links], links):
            w.add_distance_joint(a, b)
        w.add_mouse_joint(w.bodies[3], target=(w.bodies[3].position[0], 40.0), max_force=500.0)
        return w

    stepped_alike(make, 2, True, 40)


# -- the parts and the groups ---------------------------------------------------------------


def groups_of(pairs: list[tuple[int, int]], part: list[int], immovable: set[int]) -> tuple[np.ndarray, np.ndarray]:
    """``manifold_groups`` over one-point manifolds between ``pairs`` of bodies, in this order,
    the bodies in parts ``part``."""
    n = len(pairs)
    body_a = np.array([a for a, _ in pairs], np.int32)
    body_b = np.array([b for _, b in pairs], np.int32)
    empty = np.zeros((n, 6))
    rows = new_rows((
        np.arange(n, dtype=np.int32), np.arange(n, dtype=np.int32), body_a, body_b, empty, empty, np.zeros(n),
        np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(n, np.int32),
        np.zeros(n), np.zeros(n),
    ))  # fmt: skip
    M_inv = np.ones((len(part), 3))
    M_inv[sorted(immovable)] = 0.0
    return manifold_groups(np.arange(n + 1, dtype=np.uint32), rows, M_inv, np.array(part, np.int32))


@given(data=st.data(), n_bodies=st.integers(2, 12), n_pairs=st.integers(0, 40))
def test_groups_hold_no_moving_body_in_two_segments(data, n_bodies: int, n_pairs: int) -> None:
    """Whatever the order and the parts: segments cover the manifolds in order, and within a
    group no moving body appears in two segments (so its segments may run at once). Immovable
    bodies are shared freely."""
    body = st.integers(0, n_bodies - 1)
    pairs = data.draw(
        st.lists(st.tuples(body, body).filter(lambda p: p[0] != p[1]), min_size=n_pairs, max_size=n_pairs)
    )
    part = data.draw(st.lists(st.integers(0, 2**PART_DEPTH - 1), min_size=n_bodies, max_size=n_bodies))
    immovable = set(data.draw(st.lists(body, max_size=3)))
    segments, groups = groups_of(pairs, part, immovable)
    assert segments[0] == 0 and segments[-1] == len(pairs) and np.all(np.diff(segments) > 0)
    assert groups[0] == 0 and groups[-1] == len(segments) - 1 and np.all(np.diff(groups) > 0)
    for g in range(len(groups) - 1):
        seen: set[int] = set()
        for s in range(groups[g], groups[g + 1]):
            moving = {i for a, b in pairs[segments[s] : segments[s + 1]] for i in (a, b) if i not in immovable}
            assert not moving & seen
            seen |= moving


def pyramid_order(n: int) -> tuple[phys2d.World, np.ndarray, np.ndarray]:
    """A pyramid of base n stepped once: the world, its pairs (in solve order) and its bodies' parts."""
    w = stock.pyramid(n, responder=phys2d.SoftStep())
    w.step(1 / 60)
    p = w._pipeline
    return w, p.pairs[: p.n_pairs][p.buffers.pair_order[: p.n_pairs]], p.part


def test_a_pyramid_is_cut_in_halves_of_equal_work_few_pairs_straddle_it() -> None:
    """A pyramid of base 33: the parts hold nearly as many pairs each, and the pairs that
    straddle the cut are few (the cut crosses the pyramid once: a couple of pairs per row)."""
    w, pairs, part = pyramid_order(BIG)
    static = np.array([b.static for b in w.bodies])
    in_part = [0] * 2**PART_DEPTH
    straddle = 0
    for a, b in pairs:
        pa, pb = (part[b] if static[a] else part[a]), (part[a] if static[b] else part[b])
        if pa == pb:
            in_part[pa] += 1
        else:
            straddle += 1
    assert max(in_part) <= 1.1 * min(in_part)
    assert straddle <= 4 * BIG  # of about 33 * 32 * 3 pairs


def test_the_solve_order_is_parts_then_cuts_each_by_colour() -> None:
    """The pairs in solve order: parts first, the cut between them last, and within each set
    no two consecutive pairs of one colour share a moving body (a colour holds no body twice)."""
    w, pairs, part = pyramid_order(BIG)
    static = np.array([b.static for b in w.bodies])
    sets = []
    for a, b in pairs:
        pa, pb = (part[b] if static[a] else part[a]), (part[a] if static[b] else part[b])
        sets.append(0 if pa == pb == 0 else 1 if pa == pb == 1 else 2)
    assert sets == sorted(sets) and set(sets) == {0, 1, 2}
    segments, groups = groups_of([tuple(p) for p in pairs], list(part), set(np.flatnonzero(static)))
    assert len(segments) - 1 == 3 and list(groups) == [0, 2, 3]  # the two parts at once, then the cut


def test_part_order_is_pair_order_within_each_set_and_pair_order_in_a_small_scene() -> None:
    """PGS's order, as the world visits it: a pyramid of fewer than PARTS_FROM boxes stays one
    part, in pair order exactly (the lecture's loop); a larger one's pairs come by set, each set
    in pair order (no colours), in the parts the colour order would cut (``order_pairs``)."""
    for n, parted in ((31, False), (BIG, True)):
        w = stock.pyramid(n)
        w.step(1 / 60)
        p = w._pipeline
        pairs, static, part = p.pairs[: p.n_pairs], w._bodies.static, p.part
        order = p.buffers.pair_order[: p.n_pairs]
        if not parted:
            assert not part.any() and np.array_equal(order, np.arange(p.n_pairs))
            continue
        assert set(part[~static]) == {0, 1}
        sets = []
        for a, b in pairs[order]:
            pa, pb = (part[b] if static[a] else part[a]), (part[a] if static[b] else part[b])
            sets.append(0 if pa == pb == 0 else 1 if pa == pb == 1 else 2)
        assert sets == sorted(sets) and set(sets) == {0, 1, 2}
        for s in range(3):
            assert np.all(np.diff(order[np.array(sets) == s]) > 0)  # pair order within the set
        parts, coloured_parts = np.zeros_like(part), np.zeros_like(part)  # at the positions now
        order_pairs(pairs, p.n_pairs, static, w._bodies.x, parts, PART_ORDER)
        order_pairs(pairs, p.n_pairs, static, w._bodies.x, coloured_parts, COLOUR_ORDER)
        assert np.array_equal(parts, coloured_parts)


def greedy_colours(pairs: np.ndarray, static: np.ndarray) -> list[int]:
    """Each pair's colour, the pairs taken in turn: the smallest that neither of its moving bodies
    has used yet."""
    used: dict[int, set[int]] = {}
    colours = []
    for a, b in pairs:
        moving = [int(i) for i in (a, b) if not static[i]]
        colour = 0
        while any(colour in used.setdefault(i, set()) for i in moving):
            colour += 1
        for i in moving:
            used[i].add(colour)
        colours.append(colour)
    return colours


def test_colour_order_is_one_part_in_a_small_scene() -> None:
    """The soft step's order, as the world visits it: a pyramid of fewer than PARTS_FROM boxes is
    one part, its pairs in greedy colour order exactly (pairs of one colour in pair order), as Box2D
    v3 colours its constraints; a larger one is cut into two parts. (Cut into parts, Box2D's overlap
    recovery of 6 boxes launched its top box faster than push_max: issue 41.)"""
    for n, parted in ((31, False), (BIG, True)):
        w = stock.pyramid(n, responder=phys2d.SoftStep())
        w.step(1 / 60)
        p = w._pipeline
        pairs, static, part = p.pairs[: p.n_pairs], w._bodies.static, p.part
        order = p.buffers.pair_order[: p.n_pairs]
        assert set(part[~static]) == ({0, 1} if parted else {0})
        if not parted:
            assert np.array_equal(order, np.argsort(greedy_colours(pairs, static), kind="stable"))


# -- settings -------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "bad, error",
    [
        (0, ValueError),
        (-2, ValueError),
        (1.5, TypeError),
        (2.0, TypeError),
        (True, TypeError),
        ("2", TypeError),
        (None, TypeError),
    ],
)
def test_bad_threads_are_refused_and_change_nothing(bad, error) -> None:
    """0, negatives, non-integers and bools are refused, naming ``threads``; the world keeps its count."""
    w = stock.pyramid(2, responder=phys2d.SoftStep())
    w.threads = 2
    with pytest.raises(error, match="threads"):
        w.threads = bad
    assert w.threads == 2
    with pytest.raises(error, match="threads"):
        phys2d.World(threads=bad)


def test_threads_default_to_one_and_are_kept() -> None:
    w = phys2d.World(threads=3)
    assert phys2d.World().threads == 1 and w.threads == 3
    w.threads = np.int64(2)
    assert w.threads == 2 and type(w.threads) is int


# -- compiling ------------------------------------------------------------------------------

_PROBE = """
import hashlib, json, sys
import numpy as np
import phys2d
from phys2d import scenes
from numba.np.ufunc import parallel as parallel_layer

out = {}
for threads in json.loads(sys.argv[1]):
    for one_call in (True, False):
        w = scenes.pyramid(4, responder=phys2d.SoftStep())
        w.add_distance_joint(w.bodies[1], w.bodies[2])
        w.threads, w.one_call_tick = threads, one_call
        for _ in range(20):
            w.step(1 / 60)
        h = hashlib.sha256(b"".join(np.ascontiguousarray(a).tobytes() for a in (w.x, w.theta, w.V)))
        out[f"{threads} {one_call}"] = h.hexdigest()
# numba starts its thread pool when it compiles, loads or runs a parallel kernel (or is told a count)
out["thread pool"] = bool(parallel_layer._is_initialized)
print(json.dumps(out))
"""


def probe(threads: list[int], **env: str) -> dict:
    """Run ``_PROBE`` in a fresh process (its own numba state) with ``env`` set."""
    done = subprocess.run(
        [sys.executable, "-c", _PROBE, json.dumps(threads)],
        capture_output=True,
        text=True,
        cwd=ROOT,
        env={**os.environ, "PYTHONPATH": str(ROOT), "PHYS2D_COMPILE_AHEAD": "0", **env},
        timeout=1800,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.splitlines()[-1])


def test_one_thread_compiles_no_parallel_kernel() -> None:
    """A process whose worlds step on one thread (in one call and in stages, with a joint) never
    starts numba's thread pool, which compiling, loading or running a parallel kernel would."""
    assert probe([1])["thread pool"] is False


def test_uncompiled_threads_give_the_compiled_bits() -> None:
    """With NUMBA_DISABLE_JIT=1 (prange is range) a world on 1 or 2 threads holds the bits that
    compiled kernels give on 1 and on 2 threads."""
    compiled = probe([1, 2])
    python = probe([1, 2], NUMBA_DISABLE_JIT="1")
    for key in ("1 True", "1 False", "2 True", "2 False"):
        assert python[key] == compiled[key] == compiled["1 True"]
