"""Properties of contacts and the contact cache (warm starting)."""

from __future__ import annotations

import numpy as np
from hypothesis import assume, given
from hypothesis import strategies as st

import phys2d
from tests.strategies import SceneSpec, build, dts, pgs_settings, resting_scenes, scenes

DT = 1 / 60


def settled(scene: SceneSpec, responder: phys2d.PGS, steps: int = 60) -> phys2d.World:
    w = build(scene, responder)
    for _ in range(steps):
        w.step(DT)
    return w


@given(scene=resting_scenes(), iterations=st.integers(10, 30))
def test_resting_scene_keeps_every_feature_id(scene: SceneSpec, iterations: int) -> None:
    """Once a resting scene has settled (no speed above 1 mm/s), every tick has the same
    contact keys (pair of shapes + feature id) as the tick before, and every contact is
    warm started."""
    w = settled(scene, phys2d.PGS(iterations=iterations), steps=120)
    assume(np.max(np.abs(w.V)) < 1e-3)
    keys = w.contacts.key.copy()
    assert len(keys) > 0
    for _ in range(30):
        w.step(DT)
        assert np.array_equal(w.contacts.key, keys)
        assert np.all(w.contacts.warm_started)
        assert w.last_step.cache_hits == len(keys)


@given(scene=resting_scenes(), tolerance=st.sampled_from([1e-4, 1e-6, 1e-8]))
def test_warm_start_needs_no_more_iterations_than_cold(scene: SceneSpec, tolerance: float) -> None:
    """Two identical settled worlds, one tick more: warm-started PGS reaches the tolerance
    in no more sweeps than cold PGS starting from lambda = 0."""
    warm = phys2d.PGS(iterations=200, tolerance=tolerance)
    worlds = [settled(scene, warm) for _ in range(2)]
    worlds[1].responder = phys2d.PGS(iterations=200, tolerance=tolerance, warm_start=False)
    n_warm = worlds[0].step(DT).iterations
    n_cold = worlds[1].step(DT).iterations
    assert worlds[0].last_step.cache_hit_rate == 1.0
    assert worlds[1].last_step.cache_hits == 0
    assert n_warm <= n_cold


@given(scene=resting_scenes())
def test_resting_stacks_stay_put(scene: SceneSpec) -> None:
    """Stable stacks standing on the ground stay where they were put: over 3 s no body
    moves more than a centimetre or turns more than 0.01 rad, and all end at rest."""
    w = build(scene)
    x0, th0 = w.x.copy(), w.theta.copy()
    for _ in range(180):
        w.step(DT)
    assert np.max(np.hypot(*(w.x - x0).T)) < 0.01
    assert np.max(np.abs(w.theta - th0)) < 0.01
    assert np.max(np.abs(w.V)) < 1e-3


@given(scene=scenes(max_bodies=6, ground=None, static=None), responder=pgs_settings(), dt=dts)
def test_contacts_are_well_formed(scene: SceneSpec, responder: phys2d.PGS, dt: float) -> None:
    """Every step's contacts: keys strictly ascending (unique identities), body_a < body_b,
    unit normals, separation within the margin plus how far the two bodies can travel
    in the step (dt (|v| + |omega| r_max), velocities after gravity), mixed mu = sqrt(mu_a mu_b) and
    e = max(e_a, e_b); a contact is warm started exactly when warm starting is on, its
    key was among the previous tick's keys, and its island did not lose a load: no pair
    of bodies that pushed in the previous tick and touches no more is connected to it
    through dynamic bodies (``expected_warm``)."""
    w = build(scene, responder)
    mu = np.array([b.friction for b in scene.bodies])
    e = np.array([b.restitution for b in scene.bodies])
    previous = np.zeros(0, np.int64)
    pushed_pairs: set[tuple[int, int]] = set()  # uid pairs that pushed in the previous tick
    reach = np.array(
        [b.radius if b.shape == "circle" else np.hypot(*b.local_vertices.T).max() for b in w.bodies]
    )  # r_max: how far a body's surface is from its centre
    for _ in range(20):
        # speculative contacts reach as far as the bodies can travel within the step
        V = w.V.copy()
        V[w.M_inv[:, 0] > 0.0, :2] += dt * w.gravity
        travel = dt * (np.hypot(V[:, 0], V[:, 1]) + np.abs(V[:, 2]) * reach)
        try:
            w.step(dt)
        except phys2d.SimulationError:
            return
        c = w.contacts
        assert np.all(np.diff(c.key) > 0)
        assert np.all(c.body_a < c.body_b)
        assert np.allclose(np.hypot(c.normal[:, 0], c.normal[:, 1]), 1.0, rtol=0, atol=1e-12)
        assert np.all(c.separation <= w.contact_margin + travel[c.body_a] + travel[c.body_b] + 1e-12)
        # in extended precision, where mu_a mu_b neither over- nor underflows
        mixed = np.sqrt(mu[c.body_a].astype(np.longdouble) * mu[c.body_b]).astype(np.float64)
        np.testing.assert_allclose(c.friction, mixed, rtol=1e-14)
        assert np.array_equal(c.restitution, np.maximum(e[c.body_a], e[c.body_b]))
        expected = expected_warm(w, previous, pushed_pairs) & responder.warm_start
        assert np.array_equal(c.warm_started, expected)
        assert w.last_step.cache_hits == int(expected.sum())
        previous = c.key.copy()
        uid = np.array([b._uid for b in w.bodies])
        pushed_pairs = {
            (int(uid[a]), int(uid[b])) for a, b, lam in zip(c.body_a, c.body_b, c.normal_impulse) if lam > 0
        }


def expected_warm(w: phys2d.World, previous: np.ndarray, pushed_pairs: set) -> np.ndarray:
    """Second method for the warm start: in the cache, and not in an island that lost a load."""
    c = w.contacts
    uid = [b._uid for b in w.bodies]
    static = [b.static for b in w.bodies]
    island = list(range(len(w)))  # union-find over the contacts between dynamic bodies

    def root(k):
        while island[k] != k:
            k = island[k]
        return k

    for a, b in zip(c.body_a, c.body_b):
        if not static[a] and not static[b]:
            island[root(int(a))] = root(int(b))
    touching = {(uid[a], uid[b]) for a, b in zip(c.body_a, c.body_b)}
    where = {u: k for k, u in enumerate(uid)}
    unloaded = {root(where[u]) for pair in pushed_pairs - touching for u in pair if u in where and not static[where[u]]}
    dynamic = [int(b) if static[a] else int(a) for a, b in zip(c.body_a, c.body_b)]
    return np.isin(c.key, previous) & np.array([root(k) not in unloaded for k in dynamic], dtype=bool)
