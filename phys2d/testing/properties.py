"""Physics properties any responder must keep, as functions a pytest can call on generated
scenes (``phys2d.testing.strategies``); each asserts, and names what broke.

    from hypothesis import given
    from phys2d.testing import properties, strategies as ps

    @given(scene=ps.scenes(max_bodies=6, ground=True), dt=ps.dts)
    def test_bounds(scene, dt):
        properties.lambda_bounds(scene, MyResponder(), dt)

The project's own property tests (tests/test_prop_*.py) call these on every registered
responder. Symbols as in docs/formulation.md; impulses in N s.
"""

from __future__ import annotations

import numpy as np

from ..responders.base import Responder
from ..responders.pgs import PGS
from ..world import SimulationError, World
from .strategies import SceneSpec, build, fingerprint, free_scene, run


def friction_bound(w: World, responder: Responder, dt: float) -> np.ndarray:
    """The bound on |lambda_t| of each contact: Coulomb mu lambda_n, or with the lecture's
    model mu m_c g dt, m_c the pair's reduced mass shared among its manifold's points."""
    c = w.contacts
    if not (isinstance(responder, PGS) and responder.friction == "lecture"):
        return c.friction * c.normal_impulse
    inv = w.M_inv[c.body_a, 0] + w.M_inv[c.body_b, 0]  # a static partner is infinitely heavy
    pair = c.body_a.astype(np.int64) * len(w) + c.body_b
    _, where, count = np.unique(pair, return_inverse=True, return_counts=True)
    return c.friction / inv / count[where] * float(np.hypot(*w.gravity)) * dt


def lambda_bounds(scene: SceneSpec, responder: Responder, dt: float, steps: int = 25) -> None:
    """After every step: lambda_n >= 0 and |lambda_t| within its bound (``friction_bound``)."""
    w = build(scene, responder)
    for _ in run(w, dt, steps):
        c = w.contacts
        assert np.all(c.normal_impulse >= 0.0), f"lambda_n < 0 at step {w.tick}: {c.normal_impulse.min()} N s"
        bound = friction_bound(w, responder, dt)
        over = np.abs(c.tangent_impulse) - bound * (1.0 + 1e-12) - 1e-300
        assert np.all(over <= 0.0), f"|lambda_t| over its bound at step {w.tick} by {over.max()} N s"


def momentum_scale(w: World) -> float:
    """A size for round-off: the sum of |m v| and |I omega| + |x||m v| over the bodies (kg m/s)."""
    m = np.array([b.mass for b in w.bodies])
    inertia = np.array([b.inertia for b in w.bodies])
    speed = np.hypot(w.V[:, 0], w.V[:, 1])
    return float(np.sum(m * speed * (1.0 + np.hypot(*w.x.T)) + inertia * np.abs(w.V[:, 2]))) + 1e-12


def linear_momentum_kept(scene: SceneSpec, responder: Responder, dt: float, steps: int = 30) -> None:
    """No gravity, no static bodies (``free_scene``): every contact impulse acts equally and
    oppositely, so sum m v stays what it was, to round-off."""
    w = build(free_scene(scene), responder)
    p0 = w.linear_momentum()
    scale = momentum_scale(w)  # the largest momenta seen so far set the round-off
    for _ in run(w, dt, steps):
        scale = max(scale, momentum_scale(w))
        np.testing.assert_allclose(w.linear_momentum(), p0, rtol=0, atol=5e-11 * scale * (1 + w.tick))


def same_scene_twice(scene: SceneSpec, responder: Responder, dt: float, steps: int = 20) -> None:
    """Two worlds built from the same scene and stepped alike hold bit-identical arrays,
    contacts, caches and reports after every step (and fail alike, if they fail)."""
    a, b = build(scene, responder), build(scene, responder)
    for _ in range(steps):
        outcome: list[str | None] = []
        for w in (a, b):
            try:
                w.step(dt)
                outcome.append(None)
            except SimulationError as err:
                outcome.append(str(err))
        assert outcome[0] == outcome[1]
        assert fingerprint(a) == fingerprint(b), f"the two runs differ after step {a.tick}"
        if outcome[0] is not None:
            return


__all__ = ["friction_bound", "lambda_bounds", "linear_momentum_kept", "momentum_scale", "same_scene_twice"]
