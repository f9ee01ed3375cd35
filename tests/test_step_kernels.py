"""The kernels that replaced numpy work in a step (issue 11, "Fast"), each against a second method."""

import numpy as np
import pytest

from phys2d import SoftStep, scenes
from phys2d.collision.recycle import body_extent, body_extents, next_slot
from tests.probe import records_now


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
    shapes = records_now(w, w.V, w._pipeline.pairs)[1]
    got = body_extents(shapes)
    triangle = np.hypot(0.5, -0.3 + 1.0 / 30.0)
    expected = [0.0] + [np.hypot(0.4, 0.3), 0.35, triangle, 0.4] * 2
    assert got == pytest.approx(expected, rel=1e-12)
    for i in range(b.n):
        assert got[i] == body_extent(i, shapes)


def test_a_recycled_manifold_keeps_its_row_of_the_store():
    w = scenes.vertical_stack(3, SoftStep())
    p = w._pipeline
    for _ in range(3):
        w.step(1 / 60)
    for _ in range(4):
        rows, used, store = p.manifold_keys()[1].copy(), p.store.points_used, p.store.anchor
        w.step(1 / 60)
        assert p.store.recycled == 3
        assert np.array_equal(p.manifold_keys()[1], rows) and p.store.points_used == used  # nothing copied or added
        assert p.store.anchor is store


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


def test_the_cache_look_up_in_slices_is_the_whole_merge():
    """Against sets: look_up of any cut of the contacts into slices finds exactly the keys that
    were cached (cached[c] the index of key c among the cache's); lost_a_load_of over any cut
    of the cache says a pushed pair is gone when the whole walk does."""
    from phys2d.contacts import FEATURE_BITS, look_up, lost_a_load, lost_a_load_of

    rng = np.random.default_rng(12)
    for _ in range(200):
        pairs = np.unique(rng.integers(1, 40, 12))
        cache_keys = np.sort((pairs[:, None] << FEATURE_BITS) + np.arange(2)).ravel().astype(np.int64)
        pushed = rng.random(cache_keys.shape[0]) < 0.3
        now = np.unique(rng.integers(1, 40, 12))
        keys = np.sort((now[:, None] << FEATURE_BITS) + rng.integers(0, 3, 2)).ravel().astype(np.int64)
        keys = np.unique(keys)
        where = {int(k): i for i, k in enumerate(cache_keys)}
        expected = np.array([where.get(int(k), -1) for k in keys])
        for cuts in (1, 2, 3, 7):
            cached = np.full(keys.shape[0], -9, np.int64)
            edges = np.linspace(0, keys.shape[0], cuts + 1).astype(int)
            found = sum(look_up(edges[i], edges[i + 1], cache_keys, keys, cached) for i in range(cuts))
            assert np.array_equal(cached, expected)
            assert found == np.sum(expected >= 0)
            edges = np.linspace(0, cache_keys.shape[0], cuts + 1).astype(int)
            lost = any(lost_a_load_of(edges[i], edges[i + 1], cache_keys, pushed, keys) for i in range(cuts))
            assert lost == lost_a_load(cache_keys, pushed, keys)


def test_solve_order_is_the_pairs_points_concatenated():
    """Against numpy: pair p's points pair_start[p]..pair_start[p + 1] in pair_order, for
    pairs of 0, 1, 2 (and, beyond what 2D makes, 3) points; the last pair empty or full."""
    from phys2d.constraints.order import solve_order

    rng = np.random.default_rng(7)
    for counts in ([2, 0, 1, 2, 2, 1, 0], [0], [1, 2, 3, 2], rng.integers(0, 3, 50)):
        pair_start = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
        pair_order = rng.permutation(len(counts)).astype(np.int32)
        expected = np.concatenate([np.arange(pair_start[p], pair_start[p + 1]) for p in pair_order])
        got = solve_order(pair_order, pair_start)
        assert got.dtype == np.int32
        assert np.array_equal(got, expected)


def test_gather_contacts_is_fancy_indexing():
    from phys2d.responders.soft_points import gather_contacts

    rng = np.random.default_rng(4)
    k = 13
    order = rng.permutation(k).astype(np.int32)
    separation, restitution = rng.normal(size=k), rng.random(k)
    C0, e = gather_contacts(order, separation, restitution)
    assert np.array_equal(C0, separation[order])
    assert np.array_equal(e, restitution[order])


def _spying_soft_step(in_row_order, seen):
    """SoftStep that records its contexts; with ``in_row_order`` the world gathers the contacts
    into row order (contacts_in_row_order True) and the spy undoes it for SoftStep."""
    from dataclasses import replace

    class Spy(SoftStep):
        contacts_in_row_order = in_row_order

        def respond(self, ctx):
            seen.append(ctx)
            if in_row_order:  # SoftStep reads contact order: scatter the gathered fields back
                back = np.argsort(ctx.rows.order)
                ctx = replace(
                    ctx, separation=ctx.separation[back], restitution=ctx.restitution[back], anchor=ctx.anchor[back]
                )
            return super().respond(ctx)

    return Spy()


@pytest.mark.parametrize("in_row_order", [True, False])
def test_context_hands_contacts_in_row_order_unless_the_responder_gathers(in_row_order):
    """A colour-ordered responder sees contact q of ctx = contact rows.order[q] of the world;
    one that gathers for itself (``contacts_in_row_order`` False, SoftStep) the world's own."""
    seen = []
    w = scenes.pyramid(4, _spying_soft_step(in_row_order, seen))
    for _ in range(3):
        w.step(1 / 60)
    ctx, c = seen[-1], w.contacts
    order = ctx.rows.order
    assert not np.array_equal(order, np.arange(len(order)))  # coloured: not the contacts' order
    pick = order if in_row_order else np.arange(len(order))
    for field in ("body_a", "body_b", "point", "normal", "separation", "restitution", "anchor"):
        assert np.array_equal(getattr(ctx, field), getattr(c, field)[pick])


def test_soft_step_gathering_for_itself_moves_the_bodies_as_the_world_s_gather():
    """The same 40 steps of a pyramid, contacts gathered by the world or by SoftStep's kernel:
    the same states, bit for bit."""
    worlds = [scenes.pyramid(5, _spying_soft_step(in_row_order, [])) for in_row_order in (True, False)]
    for w in worlds:
        for _ in range(40):
            w.step(1 / 60)
    assert np.array_equal(worlds[0].x, worlds[1].x)
    assert np.array_equal(worlds[0].theta, worlds[1].theta)
    assert np.array_equal(worlds[0].V, worlds[1].V)


def test_cos_less_one_sin_is_libm_s_to_an_ulp():
    """Against np.cos, np.sin: the Taylor series below SMALL_TURN within one ulp (turns from
    1e-12 rad up, both signs), and cos d - 1 within 4 ulps of -2 sin^2(d / 2), which has no
    cancellation (np.cos(d) - 1 loses the digits of a small turn); libm's own at and above it."""
    from phys2d.responders.soft_integrate import SMALL_TURN, cos_less_one_sin

    rng = np.random.default_rng(2)
    small = np.concatenate(
        [rng.uniform(-SMALL_TURN, SMALL_TURN, 3000), rng.choice([-1.0, 1.0], 3000) * 10 ** rng.uniform(-12, -1.6, 3000)]
    )
    small = small[np.abs(small) < SMALL_TURN]
    for d in small:
        c, s = cos_less_one_sin(d)
        assert abs((1.0 + c) - np.cos(d)) <= np.spacing(np.cos(d))
        exact = -2.0 * np.sin(0.5 * d) ** 2
        assert abs(c - exact) <= 4 * np.spacing(abs(exact))
        assert abs(s - np.sin(d)) <= np.spacing(abs(np.sin(d)))
    for d in (SMALL_TURN, -SMALL_TURN, 0.5, -2.0, 7.0):
        assert cos_less_one_sin(d) == (np.cos(d) - 1.0, np.sin(d))
    assert cos_less_one_sin(0.0) == (0.0, 0.0)


@pytest.mark.parametrize("responder", ["pgs", "soft"])
def test_contact_rows_start_from_the_cache_by_key(responder):
    """contact_rows' warm start against a dict: every contact row's lambda is the impulse cached
    under its key (0 for a key not cached), whatever the row buffer held; without warm starting 0."""
    import phys2d
    from phys2d.constraints.rows import contact_rows
    from phys2d.pipeline.stages import rows_of

    make = {"pgs": lambda: phys2d.PGS(iterations=10, warm_start=True), "soft": lambda: SoftStep(substeps=4)}
    w = scenes.pyramid(4, responder=make[responder]())
    for _ in range(21):
        w.step(1 / 60)
    p, k = w._pipeline, len(w.contacts)  # contact_rows' arguments, as the step passed them
    bodies, shapes, found, rows = p.bodies_record, p.shapes_record, p.side_records[p.side], rows_of(p.context(), k)
    settings, threads, original = p.settings.rows._replace(targets=True), None, contact_rows
    t = p.buffers
    side = t.sides[w._pipeline.side]  # the side the step wrote: what contact_rows read and wrote
    keys, order, hit = side.key[:k], side.order[:k], side.hit[:k]
    rng = np.random.default_rng(2)
    kept = keys[rng.random(keys.shape[0]) < 0.6]
    stale = np.array([keys.max() + 1, keys.max() + 7], np.int64)  # keys gone since last tick
    cache_keys = np.sort(np.concatenate([kept, stale]))
    cache_lambda_n, cache_lambda_t = rng.random(cache_keys.shape[0]), rng.normal(size=cache_keys.shape[0])
    by_key = {int(c): (n, t) for c, n, t in zip(cache_keys, cache_lambda_n, cache_lambda_t)}
    cache = (cache_keys, cache_lambda_n, cache_lambda_t, np.zeros(cache_keys.shape[0], np.bool_))
    lam, normal_row, friction_row = t.rows.lam, t.rows.normal_row[:k], t.rows.friction_row[:k]
    for warm in (True, False):
        lam[:] = np.nan  # what the buffer held must not leak into the start
        _, hits = original(bodies, shapes, cache, found, rows, settings._replace(warm_start=warm), threads)
        expected = [by_key.get(int(keys[c]), (0.0, 0.0)) if warm else (0.0, 0.0) for c in order]
        assert np.array_equal(lam[normal_row], [n for n, _ in expected])
        assert np.array_equal(lam[friction_row], [t for _, t in expected])
        found_keys = np.array([warm and int(c) in by_key for c in keys])
        assert np.array_equal(hit, found_keys)
        assert hits == found_keys.sum() == (len(kept) if warm else 0)
