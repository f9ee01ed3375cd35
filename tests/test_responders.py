"""The lecture's naive takes against PGS, and the two friction bounds.

Expected values come from the impulse law (bounce, momentum), from the order of
the pairwise passes worked out by hand, and from constant-deceleration kinematics.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import phys2d
from phys2d import scenes

G = 10.0
DT = 1 / 60


def settle_stack(responder, seconds: float = 5.0, last: float = 2.0):
    """A 10-box stack stepped ``seconds``: (mean KE over the ``last`` seconds in J, top box drop
    in m, largest top-box speed reported in the last second, top-box travel in the last second)."""
    w = scenes.vertical_stack(10, responder=responder)
    top0 = w.x[-1].copy()
    steps, tail = int(round(seconds / DT)), int(round(last / DT))
    ke, speed, path = [], [], []
    for _ in range(steps):
        w.step(DT)
        ke.append(w.kinetic_energy())
        speed.append(float(np.hypot(*w.V[-1, :2])))
        path.append(w.x[-1].copy())
    one = int(round(1.0 / DT))
    travel = float(np.hypot(*(path[-1] - path[-one])))
    return float(np.mean(ke[-tail:])), float(top0[1] - w.x[-1, 1]), max(speed[-one:]), travel


def test_stack_naive_takes_never_settle_and_pgs_does():
    ke_naive, drop_naive, v_naive, travel_naive = settle_stack(phys2d.NaiveImpulse())
    ke_iter, drop_iter, v_iter, travel_iter = settle_stack(phys2d.IterativeImpulse(passes=10))
    ke_pgs, drop_pgs, v_pgs, _ = settle_stack(phys2d.PGS())
    # PGS with caching: the stack rests (10 boxes of 1 kg; 0.05 J is |v| ~ 0.1 m/s at most)
    assert ke_pgs < 0.05
    assert drop_pgs < 10 * 0.005  # within the slop of its 10 contacts
    # the naive takes keep kinetic energy that never settles: orders of magnitude more
    assert ke_naive > 100 * ke_pgs and ke_naive > 10.0
    assert ke_iter > 50 * ke_pgs and ke_iter > 0.5
    # ... and it is not motion: the top box "moves" at over 1 m/s (0.4 m/s for the iterative
    # take) yet travels less than 1 cm in a second. Velocities and positions disagree,
    # because the push-apart moves positions and leaves the velocities broken.
    assert v_naive > 1.0 and travel_naive < 0.01
    assert v_iter > 0.3 and travel_iter < 0.01
    # the single pass also lets the stack sink, several times deeper than PGS
    assert drop_naive > 3 * drop_pgs


@pytest.mark.parametrize("passes", [1, 2, 3, 5])
def test_iterative_passes_on_two_resting_boxes(passes):
    # box 1 on the ground, box 2 on box 1, at rest and exactly touching. After gravity both
    # fall at g dt. Pass by pass, in pair order: the ground stops box 1, then the (1, 2)
    # impulse, e = 0 and equal masses, leaves both at the mean of their velocities. So after
    # p passes both move at -g dt / 2^p: the error halves per pass but never vanishes.
    w = phys2d.World(gravity=(0.0, -G), responder=phys2d.IterativeImpulse(passes=passes))
    w.add_box(position=(0.0, -0.5), half_extents=(5.0, 0.5), static=True)
    w.add_box(position=(0.0, 0.5), half_extents=(0.5, 0.5))
    w.add_box(position=(0.0, 1.5), half_extents=(0.5, 0.5))
    w.step(DT)
    expected = -G * DT / 2**passes
    np.testing.assert_allclose(w.V[1:, 1], [expected, expected], rtol=1e-9)
    np.testing.assert_allclose(w.V[1:, [0, 2]], 0.0, atol=1e-12)
    assert w.last_step.iterations == passes and w.last_step.residuals.shape == (passes,)
    # impulses add up over the passes: ground pair m g dt (1 - 2^-p) ... reported per point
    assert w.contacts.normal_impulse.min() >= 0.0
    m = w.bodies[1].mass
    ground_pair = w.contacts.normal_impulse[w.contacts.body_a == 0].sum()
    assert ground_pair == pytest.approx(2 * m * G * DT * (1 - 2.0**-passes), rel=1e-9)


def test_naive_equals_one_iterative_pass():
    a = scenes.mixed_shapes(8, responder=phys2d.NaiveImpulse())
    b = scenes.mixed_shapes(8, responder=phys2d.IterativeImpulse(passes=1))
    for _ in range(120):
        a.step(DT)
        b.step(DT)
    np.testing.assert_array_equal(a.x, b.x)
    np.testing.assert_array_equal(a.V, b.V)
    assert a.last_step.responder == "naive" and b.last_step.responder == "iterative"


@pytest.mark.parametrize("responder", [phys2d.NaiveImpulse(), phys2d.IterativeImpulse()])
def test_naive_takes_work_with_every_shape(responder):
    w = scenes.mixed_shapes(12, responder=responder)
    for _ in range(240):
        w.step(DT)
    assert len(w.contacts) > 0
    # nothing fell through the ground (top at y = 0): every centre stays above -0.1 m
    assert w.x[1:, 1].min() > -0.1
    assert np.all(w.contacts.normal_impulse >= 0.0)
    mu = w.contacts.friction
    assert np.all(np.abs(w.contacts.tangent_impulse) <= mu * w.contacts.normal_impulse + 1e-12)


@pytest.mark.parametrize("responder", [phys2d.NaiveImpulse(), phys2d.IterativeImpulse(passes=4), phys2d.PGS()])
def test_bounce_of_a_ball(responder):
    # 1 cm above the ground and falling at 3 m/s: the gap closes within the step (5 cm),
    # so it is a collision; e = 0.5 sends it back up at 1.5 m/s (no gravity)
    w = phys2d.World(gravity=(0.0, 0.0), responder=responder)
    w.add_box(position=(0.0, -0.5), half_extents=(5.0, 0.5), static=True)
    ball = w.add_circle(position=(0.0, 0.51), radius=0.5, velocity=(0.0, -3.0), restitution=0.5)
    w.step(DT)
    np.testing.assert_allclose(ball.velocity, [0.0, 1.5], atol=1e-12)


@pytest.mark.parametrize("responder", [phys2d.NaiveImpulse(), phys2d.IterativeImpulse()])
def test_slow_speculative_point_is_no_collision(responder):
    # 1.5 cm above the ground (inside the 2 cm contact margin) at 0.5 m/s: it would close only
    # 0.83 cm this step, so the naive takes leave it alone
    w = phys2d.World(gravity=(0.0, 0.0), responder=responder)
    w.add_box(position=(0.0, -0.5), half_extents=(5.0, 0.5), static=True)
    ball = w.add_circle(position=(0.0, 0.515), radius=0.5, velocity=(0.0, -0.5))
    w.step(DT)
    assert len(w.contacts) == 1 and w.contacts.separation[0] == pytest.approx(0.015)
    np.testing.assert_allclose(ball.velocity, [0.0, -0.5], atol=1e-15)
    assert w.contacts.normal_impulse[0] == 0.0
    w.step(DT)  # now 0.67 cm away: the gap closes within this step, so it collides
    assert ball.velocity[1] == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize("e", [0.0, 0.5, 1.0])
def test_naive_impulse_obeys_the_impulse_law(e):
    # a spinning circle hits a free box off-centre: momentum and angular momentum are kept,
    # the relative normal velocity at P_0 becomes -e times what it was, and for e = 1 and
    # no friction the kinetic energy is kept too (the lecture's formula, angular terms included)
    w = phys2d.World(gravity=(0.0, 0.0), responder=phys2d.NaiveImpulse())
    w.add_box(position=(0.0, 0.0), half_extents=(1.0, 0.5), friction=0.0, restitution=e, angular_velocity=0.3)
    # touching (1 nm overlap, below the push-apart's tolerance): the lecture's impulse at once;
    # a point still apart would land first and bounce after moving (test_speculative.py)
    w.add_circle(
        position=(0.7, 0.5 + 0.3 - 1e-9),
        radius=0.3,
        velocity=(0.4, -2.0),
        angular_velocity=5.0,
        density=3.0,
        friction=0.0,
        restitution=e,
    )
    x1, V1 = w.x.copy(), w.V.copy()
    p0, L0, E0 = w.linear_momentum(), w.angular_momentum(), w.kinetic_energy()

    def normal_velocity(x, V, p, n):
        v = [V[b, :2] + V[b, 2] * np.array([-(p - x[b])[1], (p - x[b])[0]]) for b in (0, 1)]
        return float((v[1] - v[0]) @ n)

    w.step(DT)
    assert len(w.contacts) == 1
    p, n = w.contacts.point[0], w.contacts.normal[0]
    before = normal_velocity(x1, V1, p, n)
    assert before < -1.0
    assert normal_velocity(x1, w.V, p, n) == pytest.approx(-e * before, abs=1e-12)
    np.testing.assert_allclose(w.linear_momentum(), p0, atol=1e-12)
    assert w.angular_momentum() == pytest.approx(L0, abs=1e-12)
    if e == 1.0:
        assert w.kinetic_energy() == pytest.approx(E0, rel=1e-12)
    else:
        assert w.kinetic_energy() < E0


def test_push_apart_splits_by_inverse_mass():
    # two overlapping boxes at rest, 3 kg and 1 kg, overlap 0.1 m along x, no gravity:
    # the light one moves 3/4 of the overlap and the heavy one 1/4; velocities stay 0
    # (push_max 6 m/s lets 0.1 m go in one 1/60 s step; the default 3 m/s would take two)
    w = phys2d.World(gravity=(0.0, 0.0), responder=phys2d.NaiveImpulse(push_max=6.0))
    heavy = w.add_box(position=(0.0, 0.0), half_extents=(0.5, 0.5), density=3.0)
    light = w.add_box(position=(0.9, 0.0), half_extents=(0.5, 0.5))
    w.step(DT)
    assert heavy.position[0] == pytest.approx(-0.025, abs=1e-12)
    assert light.position[0] == pytest.approx(0.975, abs=1e-12)
    np.testing.assert_allclose(w.V, 0.0, atol=1e-15)


def test_naive_takes_refuse_joints():
    w = phys2d.World()
    ground = w.add_box(position=(0.0, -0.5), half_extents=(5.0, 0.5), static=True)
    box = w.add_box(position=(0.0, 2.0))
    pgs = w.responder
    w.add_pin_joint(ground, box, anchor=(0.0, 2.5))
    for naive in (phys2d.NaiveImpulse(), phys2d.IterativeImpulse()):
        with pytest.raises(ValueError, match="contact pairs only"):
            w.responder = naive
        assert w.responder is pgs
    naive_world = phys2d.World(responder=phys2d.NaiveImpulse())
    a = naive_world.add_box(position=(0.0, 0.0), static=True)
    b = naive_world.add_box(position=(0.0, 2.0))
    with pytest.raises(ValueError, match="contact pairs only"):
        naive_world.add_distance_joint(a, b)
    assert naive_world.joints == () and naive_world._joints.excluded.size == 0
    # a world that somehow holds both refuses to step, and is left as it was
    w._responder = phys2d.NaiveImpulse()
    x = w.x.copy()
    with pytest.raises(ValueError, match="contact pairs only"):
        w.step(DT)
    np.testing.assert_array_equal(w.x, x)
    assert w.tick == 0


def test_iterative_rejects_bad_passes():
    with pytest.raises(ValueError, match="passes"):
        phys2d.IterativeImpulse(passes=0)
    with pytest.raises(TypeError, match="passes"):
        phys2d.IterativeImpulse(passes=2.5)
    with pytest.raises(TypeError, match="passes"):
        phys2d.IterativeImpulse(passes=True)


# -- friction: Coulomb's bound mu lambda_n against the lecture's mu m_c g dt -----------------
MU, V0 = 0.3, 3.0


def slide(friction: str, load: bool) -> float:
    """How far a 1 kg box sent along the ground at V0 slides before it stops (m)."""
    w = phys2d.World(gravity=(0.0, -G), responder=phys2d.PGS(friction=friction))
    w.add_box(position=(0.0, -0.5), half_extents=(100.0, 0.5), static=True, friction=MU)
    box = w.add_box(position=(0.0, 0.5), half_extents=(0.5, 0.5), friction=MU, velocity=(V0, 0.0))
    if load:  # a second 1 kg box riding on top; between the boxes mu = sqrt(0.3 * 3) = 0.95
        w.add_box(position=(0.0, 1.5), half_extents=(0.5, 0.5), friction=10 * MU, velocity=(V0, 0.0))
    for _ in range(600):
        w.step(DT)
        if abs(box.velocity[0]) < 1e-9:
            break
    assert abs(box.velocity[0]) < 1e-9, "the box never stopped"
    if load:  # the load rode along
        assert abs(w.x[2, 0] - box.position[0]) < 0.01
    return float(box.position[0])


def test_lone_box_stops_where_both_bounds_agree():
    # a box alone on flat ground: lambda_n = m g dt, and m_c (the pair's reduced mass, m,
    # shared by its 2 points) gives the same bound: both decelerate at mu g and stop after
    # v^2 / (2 mu g), less half a step of travel (semi-implicit Euler moves with the new v)
    expected = V0**2 / (2 * MU * G) - 0.5 * V0 * DT
    assert slide("coulomb", load=False) == pytest.approx(expected, abs=1e-6)
    assert slide("lecture", load=False) == pytest.approx(expected, abs=1e-6)


def test_loaded_box_shows_the_lecture_bound_ignores_the_load():
    # with a second box on top, the ground carries twice the weight. Coulomb's bound grows
    # with lambda_n and the pair still stops in v^2 / (2 mu g). The lecture's bound uses m_c of
    # the ground pair, the bottom box's mass only, so the friction force stays mu m g while
    # 2 m decelerate: a = mu g / 2 and the pair slides twice as far.
    coulomb = slide("coulomb", load=True)
    lecture = slide("lecture", load=True)
    assert coulomb == pytest.approx(V0**2 / (2 * MU * G) - 0.5 * V0 * DT, abs=0.01)
    assert lecture == pytest.approx(V0**2 / (2 * MU * G / 2) - 0.5 * V0 * DT, abs=0.01)
    assert lecture / coulomb == pytest.approx(2.0, rel=0.02)


def test_lecture_friction_bound_per_point():
    # bound = mu m_c g dt, m_c = reduced mass / points in the manifold, read off the system
    w = phys2d.World(gravity=(0.0, -G), responder=phys2d.PGS(friction="lecture", form="matrix"))
    w.add_box(position=(0.0, -0.5), half_extents=(5.0, 0.5), static=True, friction=0.5)
    a = w.add_box(position=(0.0, 0.5), half_extents=(0.5, 0.5), friction=0.5)
    b = w.add_box(position=(0.0, 1.5), half_extents=(0.5, 0.5), friction=0.5, density=3.0)
    w.step(DT)
    s = w.last_step.system
    friction_rows = np.arange(1, 2 * len(w.contacts), 2)
    on_ground = w.contacts.body_a == 0
    m_a, m_b = a.mass, b.mass
    m_c = np.where(on_ground, m_a, m_a * m_b / (m_a + m_b)) / 2
    np.testing.assert_allclose(s.hi[friction_rows], 0.5 * m_c * G * DT, rtol=1e-12)
    np.testing.assert_allclose(s.lo[friction_rows], -0.5 * m_c * G * DT, rtol=1e-12)
    assert math.isinf(s.hi[0]) and s.lo[0] == 0.0
