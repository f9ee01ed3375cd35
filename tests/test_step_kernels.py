"""The kernels that replaced numpy work in a step (issue 11, "Fast"), each against a second method."""

import numpy as np
import pytest

from phys2d import SoftStep, scenes
from phys2d.collision.recycle import ascending, body_extent, body_extents, next_slot
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


def test_ascending():
    assert ascending(np.array([1, 4, 9, 100], np.int64), 4)
    assert ascending(np.array([1, 4, 3], np.int64), 2)  # only the first n count
    assert not ascending(np.array([1, 4, 4], np.int64), 3)
    assert ascending(np.zeros(0, np.int64), 0)


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


def test_manifold_buffers_are_taken_in_turn_and_never_the_ones_read():
    w = scenes.vertical_stack(3, SoftStep())
    m = w._manifolds
    bases = []
    for _ in range(4):
        before = m.key.base
        w.step(1 / 60)
        assert m.key.base is not before  # this step's manifolds were written beside last step's
        bases.append(m.key.base)
    assert bases[0] is bases[2] and bases[1] is bases[3] and bases[0] is not bases[1]


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


@pytest.mark.parametrize("responder", ["pgs", "soft"])
def test_contact_rows_start_from_the_cache_by_key(responder, monkeypatch):
    """contact_rows' warm start against a dict: every contact row's lambda is the impulse cached
    under its key (0 for a key not cached), whatever the row buffer held; without warm starting 0."""
    import phys2d
    import phys2d.world as world_module

    make = {"pgs": lambda: phys2d.PGS(iterations=10, warm_start=True), "soft": lambda: SoftStep(substeps=4)}
    w = scenes.pyramid(4, responder=make[responder]())
    for _ in range(20):
        w.step(1 / 60)
    seen = {}
    original = world_module.contact_rows

    def spy(*args):
        seen["args"] = args
        return original(*args)

    monkeypatch.setattr(world_module, "contact_rows", spy)
    w.step(1 / 60)
    monkeypatch.undo()
    args = list(seen["args"])
    code = getattr(original, "py_func", original).__code__  # (plain Python under NUMBA_DISABLE_JIT=1)
    names = code.co_varnames[: code.co_argcount]
    at = {name: i for i, name in enumerate(names)}
    keys, order = args[at["key"]], args[at["order"]]
    rng = np.random.default_rng(2)
    kept = keys[rng.random(keys.shape[0]) < 0.6]
    stale = np.array([keys.max() + 1, keys.max() + 7], np.int64)  # keys gone since last tick
    cache_keys = np.sort(np.concatenate([kept, stale]))
    cache_lambda_n, cache_lambda_t = rng.random(cache_keys.shape[0]), rng.normal(size=cache_keys.shape[0])
    by_key = {int(k): (n, t) for k, n, t in zip(cache_keys, cache_lambda_n, cache_lambda_t)}
    args[at["cache_keys"]], args[at["cache_pushed"]] = cache_keys, np.zeros(cache_keys.shape[0], np.bool_)
    args[at["cache_lambda_n"]], args[at["cache_lambda_t"]] = cache_lambda_n, cache_lambda_t
    lam, hit = args[at["lam"]], args[at["hit"]]
    normal_row, friction_row = args[at["normal_row"]], args[at["friction_row"]]
    for warm in (True, False):
        args[at["warm_start"]] = warm
        lam[:] = np.nan  # what the buffer held must not leak into the start
        _, hits = original(*args)
        expected = [by_key.get(int(keys[c]), (0.0, 0.0)) if warm else (0.0, 0.0) for c in order]
        assert np.array_equal(lam[normal_row], [n for n, _ in expected])
        assert np.array_equal(lam[friction_row], [t for _, t in expected])
        found = np.array([warm and int(k) in by_key for k in keys])
        assert np.array_equal(hit, found)
        assert hits == found.sum() == (len(kept) if warm else 0)
