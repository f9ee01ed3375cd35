"""The kernels that replaced numpy work in a step (issue 11, "Fast"), each against a second method."""

import numpy as np
import pytest

from phys2d import SoftStep, scenes
from phys2d.collision.recycle import body_extent, body_extents, next_slot
from phys2d.constraints.order import contacts_in_order


def test_contacts_in_order_is_fancy_indexing():
    rng = np.random.default_rng(3)
    k = 17
    order = rng.permutation(k).astype(np.int32)
    body_a = rng.integers(0, 9, k).astype(np.int32)
    body_b = rng.integers(0, 9, k).astype(np.int32)
    point, normal = rng.normal(size=(k, 2)), rng.normal(size=(k, 2))
    separation, restitution, anchor = rng.normal(size=k), rng.random(k), rng.normal(size=(k, 4))
    got = contacts_in_order(order, body_a, body_b, point, normal, separation, restitution, anchor)
    assert len(got) == 7
    for g, field in zip(got, (body_a, body_b, point, normal, separation, restitution, anchor)):
        assert g.dtype == field.dtype
        assert np.array_equal(g, field[order])


@pytest.mark.parametrize("ascending_queries", [True, False])
def test_next_slot_is_a_binary_search(ascending_queries):
    rng = np.random.default_rng(5)
    cached = np.unique(rng.integers(0, 1000, 60)).astype(np.int64)
    queries = rng.integers(-5, 1005, 200).astype(np.int64)
    if ascending_queries:
        queries = np.sort(queries)
    look = 0
    for key in queries:
        look = next_slot(cached, key, look)
        assert look == np.searchsorted(cached, key)


def test_body_extents_are_the_farthest_surface_points():
    """mixed_shapes' bodies in turn: box 0.4 x 0.3 (half extents), circle r 0.35, the triangle
    (-0.5, -0.3), (0.5, -0.3), (0, 0.5) about its centroid (0, -1/30), hexagon r 0.4; static: 0."""
    w = scenes.mixed_shapes(8)
    b = w._bodies
    got = body_extents(b.kind, b.radius, b.vstart, b.vcount, b.local_v, b.static)
    triangle = np.hypot(0.5, -0.3 + 1.0 / 30.0)
    expected = [0.0] + [np.hypot(0.4, 0.3), 0.35, triangle, 0.4] * 2
    assert got == pytest.approx(expected, rel=1e-12)
    for i in range(b.n):
        assert got[i] == body_extent(i, b.kind, b.radius, b.vstart, b.vcount, b.local_v, b.static)


def test_a_recycled_manifold_keeps_its_row_of_the_store():
    w = scenes.vertical_stack(3, SoftStep())
    m = w._manifolds
    for _ in range(3):
        w.step(1 / 60)
    for _ in range(4):
        rows, used, store = m.row.copy(), m.points_used, m.anchor
        w.step(1 / 60)
        assert m.recycled == 3
        assert np.array_equal(m.row, rows) and m.points_used == used  # nothing copied, nothing appended
        assert m.anchor is store


def test_soft_step_reports_the_tick_s_impulse_in_rows_and_contacts():
    """rows.lam comes back as the impulse over the whole tick: the contacts' lambda_n of a box
    resting on the ground carries its weight, m g dt (N s), summed over its points."""
    w = scenes.vertical_stack(1, SoftStep())
    for _ in range(120):
        w.step(1 / 60)
    m = w.bodies[1].mass
    assert np.sum(w.contacts.lambda_n) == pytest.approx(m * 10.0 / 60.0, rel=1e-6)


def test_lost_a_load_is_a_pushed_pair_gone():
    """Against sets of pairs: True exactly when a cached pair that pushed has no key now."""
    from phys2d.contacts import FEATURE_BITS, lost_a_load

    rng = np.random.default_rng(11)
    for _ in range(200):
        pairs = np.unique(rng.integers(1, 40, 12))
        cache_keys = np.sort((pairs[:, None] << FEATURE_BITS) + np.arange(2)).ravel().astype(np.int64)
        pushed = rng.random(cache_keys.shape[0]) < 0.5
        now = pairs[rng.random(pairs.shape[0]) < 0.8]
        keys = np.sort((now[:, None] << FEATURE_BITS) + np.arange(2)).ravel().astype(np.int64)
        gone = {int(k) >> FEATURE_BITS for k, p in zip(cache_keys, pushed) if p} - {int(p) for p in now}
        assert lost_a_load(cache_keys, pushed, keys) == bool(gone)
