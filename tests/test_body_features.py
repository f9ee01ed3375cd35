"""Kinematic bodies, gravity scale, damping, applied forces and the collision filter
(issue 27), each against a closed form, a second method or Box2D's stated rule."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import phys2d
from phys2d import scenes
from tests.test_matrix_form import max_difference

DT = 1 / 60
RESPONDERS = {
    "pgs": lambda: phys2d.PGS(),
    "soft-step": lambda: phys2d.SoftStep(),
    "naive": lambda: phys2d.NaiveImpulse(),
    "iterative": lambda: phys2d.IterativeImpulse(),
}
ALL = (1 << 64) - 1


@pytest.fixture(params=list(RESPONDERS))
def responder(request):
    return RESPONDERS[request.param]()


# -- forces besides contacts ---------------------------------------------------------------
def test_gravity_scale_free_fall_is_semi_implicit_euler_with_s_g(responder):
    """v_N = N dt s g and y = h^2 s g M (M + 1) / 2 after M steps of semi-implicit Euler of
    length h (the sub-steps of a sub-stepping responder), s = 0.5, -1, 0."""
    w = phys2d.World(responder=responder)
    scales = (0.5, -1.0, 0.0)
    bodies = [w.add_circle((3.0 * k, 0.0), radius=0.5, gravity_scale=s) for k, s in enumerate(scales)]
    n = 30
    for _ in range(n):
        w.step(DT)
    substeps = getattr(responder, "substeps", 1)
    h, m = DT / substeps, n * substeps
    for b, s in zip(bodies, scales, strict=True):
        assert b.velocity[1] == pytest.approx(n * DT * s * -10.0, rel=1e-12, abs=1e-12)
        assert b.position[1] == pytest.approx(h * h * s * -10.0 * m * (m + 1) / 2, rel=1e-12, abs=1e-12)


def test_gravity_scale_is_settable_and_checked():
    w = phys2d.World()
    b = w.add_box((0.0, 0.0))
    b.gravity_scale = 2.0
    w.step(DT)
    assert b.velocity[1] == pytest.approx(2.0 * -10.0 * DT, rel=1e-12)
    with pytest.raises(ValueError, match="gravity_scale"):
        b.gravity_scale = math.nan
    assert b.gravity_scale == 2.0


@pytest.mark.parametrize("c", [0.5, 3.0])
def test_damping_decays_as_box2d_v_over_1_plus_c_dt(responder, c):
    """No gravity: v_N = v_0 / (1 + c dt)^N, and the same for omega with the angular damping."""
    w = phys2d.World(gravity=(0.0, 0.0), responder=responder)
    b = w.add_box((0.0, 0.0), velocity=(4.0, -2.0), angular_velocity=3.0, linear_damping=c, angular_damping=2 * c)
    n = 40
    for _ in range(n):
        w.step(DT)
    np.testing.assert_allclose(b.velocity, np.array([4.0, -2.0]) / (1 + c * DT) ** n, rtol=1e-12)
    assert b.angular_velocity == pytest.approx(3.0 / (1 + 2 * c * DT) ** n, rel=1e-12)


def test_damping_under_gravity_reaches_box2d_terminal_velocity():
    """v <- (v + g dt) / (1 + c dt) has the fixed point v = g / c: the body falls no faster."""
    w = phys2d.World()
    b = w.add_circle((0.0, 0.0), linear_damping=2.0)
    for _ in range(1200):
        w.step(DT)
    assert b.velocity[1] == pytest.approx(-10.0 / 2.0, rel=1e-9)


def test_a_force_acts_for_the_next_step_only(responder):
    """A force F for one step: v = dt F / m after it, and no more after the next."""
    w = phys2d.World(gravity=(0.0, 0.0), responder=responder)
    b = w.add_box((0.0, 0.0), half_extents=(0.5, 0.25), density=2.0)  # m = 1 kg
    b.apply_force((3.0, 0.0))
    b.apply_force((1.0, -2.0))  # forces add up until the step
    w.step(DT)
    expected = np.array([4.0, -2.0]) * DT / b.mass
    np.testing.assert_allclose(b.velocity, expected, rtol=1e-12)
    w.step(DT)
    np.testing.assert_allclose(b.velocity, expected, rtol=1e-12)


def test_a_force_off_centre_turns_the_body_by_r_cross_f():
    w = phys2d.World(gravity=(0.0, 0.0))
    b = w.add_box((1.0, 2.0), half_extents=(1.0, 0.5))
    f, r = np.array([0.0, 5.0]), np.array([0.8, 0.1])
    b.apply_force(f, point=(1.0 + r[0], 2.0 + r[1]))
    b.apply_torque(0.25)
    w.step(DT)
    tau = r[0] * f[1] - r[1] * f[0] + 0.25
    assert b.angular_velocity == pytest.approx(DT * tau / b.inertia, rel=1e-12)
    np.testing.assert_allclose(b.velocity, DT * f / b.mass, rtol=1e-12)


def test_forces_do_not_move_static_or_kinematic_bodies():
    w = phys2d.World()
    s = w.add_box((0.0, 0.0), static=True)
    k = w.add_box((5.0, 0.0), kinematic=True, velocity=(1.0, 0.0))
    for body in (s, k):
        body.apply_force((100.0, 100.0))
        body.apply_torque(10.0)
    w.step(DT)
    assert np.array_equal(s.velocity, [0.0, 0.0]) and s.angular_velocity == 0.0
    assert np.array_equal(k.velocity, [1.0, 0.0]) and k.angular_velocity == 0.0


@pytest.mark.parametrize("bad", [(math.nan, 0.0), (math.inf, 1.0)])
def test_a_bad_force_is_refused_and_changes_nothing(bad):
    w = phys2d.World()
    b = w.add_box((0.0, 0.0))
    with pytest.raises(ValueError, match="force"):
        b.apply_force(bad)
    with pytest.raises(ValueError, match="torque"):
        b.apply_torque(math.nan)
    w.step(DT)
    assert b.velocity[0] == 0.0 and b.angular_velocity == 0.0


def test_matrix_form_agrees_with_impulse_form_under_damping_and_forces():
    """The matrix form's b holds dt J M^-1 F_ext; F_ext then carries damping, the scale and the forces."""

    def make(form):
        w = scenes.pyramid(4, responder=phys2d.PGS(form=form))
        for k, body in enumerate(w.bodies[1:]):
            body.linear_damping = 0.3 * k
            body.angular_damping = 0.1 * k
            body.gravity_scale = 1.0 + 0.1 * k
        return w

    assert max_difference(make, 40) < 1e-9


# -- kinematic bodies ----------------------------------------------------------------------
def test_a_kinematic_body_keeps_its_velocity_through_a_collision(responder):
    """x = x_0 + v t exactly, whatever it hits; the box it hits is pushed along."""
    w = phys2d.World(responder=responder)
    w.add_box((0.0, -0.5), half_extents=(20.0, 0.5), static=True)
    pusher = w.add_box((-3.0, 0.6), half_extents=(0.5, 0.5), kinematic=True, velocity=(2.0, 0.0))
    box = w.add_box((0.0, 0.5), half_extents=(0.5, 0.5), friction=0.2)
    assert pusher.kinematic and not pusher.static
    for _ in range(120):
        w.step(DT)
        assert np.array_equal(pusher.velocity, [2.0, 0.0])
    assert pusher.position[0] == pytest.approx(-3.0 + 2.0 * 120 * DT, abs=1e-12)
    assert pusher.position[1] == 0.6
    assert box.position[0] > pusher.position[0] + 0.95  # pushed ahead, not passed through


def test_kinematic_and_static_bodies_never_collide():
    w = phys2d.World()
    w.add_box((0.0, 0.0), half_extents=(2.0, 0.5), static=True)
    w.add_box((0.0, 0.2), kinematic=True, velocity=(0.0, -1.0))
    w.add_box((3.0, 0.2), kinematic=True)
    for _ in range(10):
        w.step(DT)
    assert len(w.contacts) == 0


def test_static_and_kinematic_together_is_refused():
    w = phys2d.World()
    with pytest.raises(ValueError, match="static and kinematic"):
        w.add_box((0.0, 0.0), static=True, kinematic=True)
    assert len(w) == 0


# -- the collision filter ------------------------------------------------------------------
def box2d_should_collide(a: tuple[int, int, int], b: tuple[int, int, int]) -> bool:
    """Box2D v3's b2ShouldShapesCollide, written out here from its source as the second method."""
    (cat_a, mask_a, group_a), (cat_b, mask_b, group_b) = a, b
    if group_a == group_b and group_a != 0:
        return group_a > 0
    return (mask_a & cat_b) != 0 and (cat_a & mask_b) != 0


bits = st.sampled_from([0, 1, 2, 3, 4, 6, 1 << 63, ALL, ALL ^ 2])
groups = st.sampled_from([0, 1, 2, -1, -2])


@settings(max_examples=60, deadline=None)
@given(fa=st.tuples(bits, bits, groups), fb=st.tuples(bits, bits, groups))
def test_two_overlapping_bodies_touch_exactly_when_box2d_says(fa, fb):
    w = phys2d.World(gravity=(0.0, 0.0))
    w.add_box((0.0, 0.0), category=fa[0], mask=fa[1], group=fa[2])
    w.add_box((0.6, 0.1), category=fb[0], mask=fb[1], group=fb[2])
    w.step(DT)
    assert (len(w.contacts) > 0) == box2d_should_collide(fa, fb)


def test_a_filtered_body_falls_through_the_ground_and_a_changed_mask_stops_the_next():
    w = phys2d.World()
    ground = w.add_box((0.0, -0.5), half_extents=(10.0, 0.5), static=True, mask=ALL ^ 2)
    ghost = w.add_box((0.0, 1.0), category=2)
    solid = w.add_box((2.0, 1.0))
    for _ in range(90):
        w.step(DT)
    assert ghost.position[1] < -1.0  # fell through
    assert solid.position[1] == pytest.approx(0.5, abs=0.02)  # rests on it
    ground.mask = ALL  # now it collides with category 2 as well
    ghost.position = (0.0, 1.0)
    ghost.velocity = (0.0, 0.0)
    for _ in range(90):
        w.step(DT)
    assert ghost.position[1] == pytest.approx(0.5, abs=0.02)


def test_a_shared_negative_group_never_collides_even_when_masks_match():
    w = phys2d.World()
    w.add_box((0.0, -0.5), half_extents=(10.0, 0.5), static=True)
    low = w.add_box((0.0, 0.5), group=-3)
    high = w.add_box((0.0, 1.5), group=-3)
    for _ in range(60):
        w.step(DT)
    assert high.position[1] == pytest.approx(low.position[1], abs=0.05)  # it sank into its group mate


@pytest.mark.parametrize(
    ("name", "value", "error"),
    [
        ("category", -1, ValueError),
        ("mask", 1 << 64, ValueError),
        ("group", 1 << 31, ValueError),
        ("group", 1.5, TypeError),
        ("category", True, TypeError),
        ("linear_damping", -0.1, ValueError),
        ("angular_damping", math.inf, ValueError),
        ("gravity_scale", math.nan, ValueError),
        ("kinematic", 1, TypeError),
    ],
)
def test_bad_body_options_are_refused_by_name_and_change_nothing(name, value, error):
    w = phys2d.World()
    b = w.add_box((0.0, 0.0))
    with pytest.raises(error, match=name):
        w.add_circle((1.0, 0.0), **{name: value})
    assert len(w) == 1
    if name in ("category", "mask", "group", "linear_damping", "angular_damping", "gravity_scale"):
        before = getattr(b, name)
        with pytest.raises(error, match=name):
            setattr(b, name, value)
        assert getattr(b, name) == before


def test_an_unknown_option_is_a_type_error_naming_it():
    w = phys2d.World()
    with pytest.raises(TypeError, match="frictoin"):
        w.add_box((0.0, 0.0), frictoin=0.3)
    assert len(w) == 0
