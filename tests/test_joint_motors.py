"""Motors, limits, slider, weld and mouse joints (issue 27), under PGS and SoftStep, against
closed forms: a motor's speed and its torque-limited acceleration tau / I, a stalled motor's
impulse tau dt, a pendulum stopped at its limit, a slider's axis, a welded cantilever, a mouse
joint's spring sag g / omega^2 and its force cap."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import phys2d

# one worker runs this file and test_ragdoll_rest.py: their worlds' ticks (joints, each responder) compile once
pytestmark = pytest.mark.xdist_group("joint_worlds")

G = 10.0
DT = 1.0 / 60.0

RESPONDERS = {
    "pgs": lambda: phys2d.PGS(),
    "pgs-block": lambda: phys2d.PGS(block=True),
    "pgs-matrix": lambda: phys2d.PGS(form="matrix"),
    "soft-step": lambda: phys2d.SoftStep(),
}
BOTH = pytest.mark.parametrize("responder", ["pgs", "soft-step"])
MICE = pytest.mark.parametrize("responder", ["pgs", "pgs-matrix", "soft-step"])  # every responder's own mouse solve
ALL = pytest.mark.parametrize("responder", list(RESPONDERS))


def world(responder: str, gravity=(0.0, -G)) -> phys2d.World:
    return phys2d.World(gravity=gravity, responder=RESPONDERS[responder]())


def wheel_on_axle(responder: str, **motor):
    """A disc of radius 0.5 m pinned at its centre to a static post, no gravity."""
    w = world(responder, gravity=(0.0, 0.0))
    post = w.add_box(position=(0.0, 0.0), half_extents=(0.1, 0.1), static=True)
    wheel = w.add_circle(position=(0.0, 0.0), radius=0.5, density=2.0)
    pin = w.add_pin_joint(post, wheel, anchor=(0.0, 0.0), **motor)
    return w, wheel, pin


# -- pin motor ---------------------------------------------------------------------------
@ALL
def test_a_strong_motor_reaches_its_speed_in_one_step(responder):
    w, wheel, pin = wheel_on_axle(responder, motor_speed=3.0, max_motor_torque=1e3)
    w.step(DT)
    assert wheel.angular_velocity == pytest.approx(3.0, abs=1e-9)
    I = w.body_inertias[1]
    assert pin.motor_impulse == pytest.approx(I * 3.0, rel=1e-9)  # the angular momentum it gave


@ALL
def test_a_capped_motor_accelerates_at_tau_over_I_then_holds_its_speed(responder):
    tau, speed = 0.4, 2.0
    w, wheel, pin = wheel_on_axle(responder, motor_speed=speed, max_motor_torque=tau)
    I = w.body_inertias[1]
    alpha = tau / I  # rad/s^2 while the motor pushes at its cap
    n_reach = speed / (alpha * DT)  # steps to reach the speed
    for n in range(1, int(n_reach) + 1):
        w.step(DT)
        assert wheel.angular_velocity == pytest.approx(alpha * DT * n, rel=1e-9)
        assert pin.motor_impulse == pytest.approx(tau * DT, rel=1e-9)
    for _ in range(3):
        w.step(DT)
    assert wheel.angular_velocity == pytest.approx(speed, abs=1e-9)
    assert abs(pin.motor_impulse) < 1e-9  # at speed, with nothing to overcome


@BOTH
def test_a_motor_too_weak_to_lift_its_load_stalls_at_its_cap(responder):
    # a horizontal bar pinned at its end: gravity's torque m g L/2 is twice the motor's
    w = world(responder)
    post = w.add_box(position=(0.0, 0.0), half_extents=(0.05, 0.05), static=True)
    bar = w.add_box(position=(0.5, 0.0), half_extents=(0.5, 0.05))
    tau = 0.5 * bar.mass * G * 0.5
    pin = w.add_pin_joint(post, bar, anchor=(0.0, 0.0), motor_speed=1.0, max_motor_torque=tau)
    for _ in range(30):
        w.step(DT)
        assert pin.motor_impulse == pytest.approx(tau * DT, rel=1e-6)  # pushing at its cap ...
        assert bar.angular_velocity < 1.0  # ... never reaching its speed
    assert pin.angle() < -0.1  # the bar went down
    assert pin.gap() < 1e-2  # (PGS's Baumgarte term lets a swinging pin open by millimetres)


@BOTH
def test_a_strong_enough_motor_lifts_the_same_load_at_its_speed(responder):
    w = world(responder)
    post = w.add_box(position=(0.0, 0.0), half_extents=(0.05, 0.05), static=True)
    bar = w.add_box(position=(0.5, 0.0), half_extents=(0.5, 0.05))
    tau = 3.0 * bar.mass * G * 0.5
    w.add_pin_joint(post, bar, anchor=(0.0, 0.0), motor_speed=1.0, max_motor_torque=tau)
    for _ in range(30):
        w.step(DT)
    assert bar.angular_velocity == pytest.approx(1.0, abs=1e-3)


@settings(max_examples=15, deadline=None)
@given(
    speed=st.floats(-20.0, 20.0).filter(lambda v: abs(v) > 0.1),
    tau=st.floats(0.05, 5.0),
    radius=st.floats(0.2, 1.5),
)
def test_motor_acceleration_is_tau_over_I_whatever_the_wheel(speed, tau, radius):
    # property: omega after n steps is min(n dt tau / I, |speed|) in the motor's direction
    w = phys2d.World(gravity=(0.0, 0.0), responder=phys2d.PGS())
    post = w.add_box(position=(0.0, 0.0), half_extents=(0.1, 0.1), static=True)
    wheel = w.add_circle(position=(0.0, 0.0), radius=radius)
    w.add_pin_joint(post, wheel, anchor=(0.0, 0.0), motor_speed=speed, max_motor_torque=tau)
    I = w.body_inertias[1]
    for n in range(1, 11):
        w.step(DT)
        expected = math.copysign(min(n * DT * tau / I, abs(speed)), speed)
        assert wheel.angular_velocity == pytest.approx(expected, rel=1e-6, abs=1e-9)


# -- pin limits ----------------------------------------------------------------------------
@ALL
def test_a_pendulum_stops_at_its_lower_limit(responder):
    w = world(responder)
    post = w.add_box(position=(0.0, 0.0), half_extents=(0.05, 0.05), static=True)
    bar = w.add_box(position=(0.5, 0.0), half_extents=(0.5, 0.05))
    pin = w.add_pin_joint(post, bar, anchor=(0.0, 0.0), lower=-math.pi / 4, upper=0.1)
    angles = []
    for _ in range(180):
        w.step(DT)
        angles.append(pin.angle())
    assert min(angles) > -math.pi / 4 - 0.03  # never far past it (the soft step's stop is soft)
    assert angles[-1] == pytest.approx(-math.pi / 4, abs=0.01)  # resting on it
    assert pin.limit_impulse > 0.0  # the lower stop pushes
    assert pin.gap() < 1e-3


@BOTH
def test_an_upper_limit_stops_a_motor(responder):
    w, wheel, pin = wheel_on_axle(responder, motor_speed=2.0, max_motor_torque=1.0, upper=1.0)
    for _ in range(120):
        w.step(DT)
    assert pin.angle() == pytest.approx(1.0, abs=0.01)
    assert abs(wheel.angular_velocity) < 1e-3
    assert pin.limit_impulse < 0.0  # the upper stop holds the motor back
    assert pin.motor_impulse == pytest.approx(DT * 1.0, rel=1e-6)  # at its cap against the stop


# -- slider --------------------------------------------------------------------------------
def slider_scene(responder: str, axis=(1.0, 0.5), **options):
    w = world(responder)
    base = w.add_box(position=(0.0, 0.0), half_extents=(0.1, 0.1), static=True)
    car = w.add_box(position=(1.0, 1.0), half_extents=(0.3, 0.1), angle=0.2)
    slider = w.add_slider_joint(base, car, anchor=(1.0, 1.0), axis=axis, **options)
    return w, car, slider


@ALL
def test_a_slider_moves_only_along_its_axis_and_does_not_turn(responder):
    # gravity has a part along the axis (1, 0.5)/|.|: the car slides down it at g u.(0, -1)
    w, car, slider = slider_scene(responder)
    u = np.array([1.0, 0.5]) / math.hypot(1.0, 0.5)
    for _ in range(60):
        w.step(DT)
        assert slider.drift() < 1e-4
        assert car.angle == pytest.approx(0.2, abs=1e-4)
    a = -G * u[1]  # m/s^2 along u
    assert float(car.velocity @ u) == pytest.approx(a * 60 * DT, rel=1e-3)
    assert slider.translation() == pytest.approx(0.5 * a * (60 * DT) ** 2, rel=0.03)


@ALL
def test_slider_limits_hold(responder):
    w, car, slider = slider_scene(responder, lower=-0.4, upper=0.2)
    seen = []
    for _ in range(120):
        w.step(DT)
        seen.append(slider.translation())
    assert min(seen) > -0.4 - 0.01
    assert seen[-1] == pytest.approx(-0.4, abs=0.005)
    assert slider.limit_impulse > 0.0
    assert slider.drift() < 1e-3


@BOTH
def test_slider_motor_reaches_its_speed_with_acceleration_F_over_m(responder):
    w = world(responder, gravity=(0.0, 0.0))
    base = w.add_box(position=(0.0, 0.0), half_extents=(0.1, 0.1), static=True)
    car = w.add_box(position=(0.0, 1.0), half_extents=(0.3, 0.1))
    force, speed = 0.5, 1.5
    slider = w.add_slider_joint(base, car, anchor=(0.0, 1.0), axis=(0.0, 2.0), motor_speed=speed, max_motor_force=force)
    accel = force / car.mass
    for n in range(1, int(speed / (accel * DT)) + 1):
        w.step(DT)
        assert car.velocity[1] == pytest.approx(accel * DT * n, rel=1e-9)
        assert abs(car.velocity[0]) < 1e-9
    for _ in range(5):
        w.step(DT)
    assert car.velocity[1] == pytest.approx(speed, abs=1e-9)
    assert slider.motor_impulse == pytest.approx(0.0, abs=1e-9)


@settings(max_examples=10, deadline=None)
@given(angle=st.floats(-math.pi, math.pi), spin=st.floats(-2.0, 2.0))
def test_slider_on_a_spinning_base_keeps_its_axis(angle, spin):
    # property: the axis turns with a; whatever its direction and a's spin, b stays on it (the soft
    # step: PGS's one correction a step lets a car flung along a turning axis drift by centimetres)
    w = phys2d.World(gravity=(0.0, -G), responder=phys2d.SoftStep())
    hub = w.add_circle(position=(0.0, 0.0), radius=0.3, density=50.0, angular_velocity=spin)
    # the pin's static body lies out of the car's way: the car may slide through the hub's centre, and
    # a box there met it in 3 of 40 random cases, its friction fighting the slider's angle (up to 18 mrad)
    pin_base = w.add_box(position=(0.0, -5.0), half_extents=(0.05, 0.05), static=True)
    w.add_pin_joint(pin_base, hub, anchor=(0.0, 0.0))
    car = w.add_box(position=(0.8, 0.0), half_extents=(0.1, 0.05))
    slider = w.add_slider_joint(hub, car, anchor=(0.8, 0.0), axis=(math.cos(angle), math.sin(angle)))
    for _ in range(60):
        w.step(DT)
    assert slider.drift() < 2e-3
    assert car.angle - hub.angle == pytest.approx(0.0, abs=2e-3)


# -- weld ----------------------------------------------------------------------------------
@ALL
def test_a_welded_cantilever_stays_put(responder):
    w = world(responder)
    wall = w.add_box(position=(0.0, 0.0), half_extents=(0.1, 0.5), static=True)
    first = w.add_box(position=(0.6, 0.0), half_extents=(0.5, 0.1))
    second = w.add_box(position=(1.6, 0.0), half_extents=(0.5, 0.1))
    welds = [w.add_weld_joint(wall, first, anchor=(0.1, 0.0)), w.add_weld_joint(first, second, anchor=(1.1, 0.0))]
    for _ in range(120):
        w.step(DT)
    for weld in welds:
        assert weld.gap() < 1e-3
        assert abs(weld.angle()) < 1e-3
    assert np.allclose(second.position, (1.6, 0.0), atol=5e-3)
    # the wall carries both boxes: its weld's vertical impulse is their weight over the step
    assert welds[0].impulse[1] == pytest.approx((first.mass + second.mass) * G * DT, rel=1e-3)


# -- mouse ---------------------------------------------------------------------------------
@MICE
def test_the_mouse_pulls_a_body_to_its_target_and_sags_g_over_omega_squared(responder):
    w = world(responder)
    box = w.add_box(position=(0.0, 0.0), half_extents=(0.3, 0.3))
    mouse = w.add_mouse_joint(box, target=(0.0, 0.0), max_force=1e3 * box.mass)
    mouse.target = (2.0, 1.0)
    errors = []
    for _ in range(180):
        w.step(DT)
        errors.append(mouse.error())
    assert errors[0] > errors[5] > errors[10] and errors[20] < 0.05 * errors[0]  # it decays
    sag = G / (2 * math.pi * 5.0) ** 2  # a spring of 5 Hz holding the weight: g / omega^2
    assert errors[-1] == pytest.approx(sag, rel=0.02)
    assert box.position[1] == pytest.approx(1.0 - sag, abs=2e-3)
    assert mouse.impulse[1] == pytest.approx(box.mass * G * DT, rel=1e-3)  # it holds the weight


@MICE
def test_the_mouse_reaches_its_target_without_gravity(responder):
    w = world(responder, gravity=(0.0, 0.0))
    ball = w.add_circle(position=(0.0, 0.0), radius=0.2)
    mouse = w.add_mouse_joint(ball, target=(0.0, 0.0), max_force=100.0)
    mouse.target = (1.0, -1.0)
    for _ in range(120):
        w.step(DT)
    assert mouse.error() < 1e-3


@MICE
def test_the_mouse_cannot_lift_a_body_heavier_than_its_force(responder):
    w = world(responder)
    box = w.add_box(position=(0.0, 0.0), half_extents=(0.5, 0.5), density=4.0)
    max_force = 0.8 * box.mass * G
    mouse = w.add_mouse_joint(box, target=(0.0, 0.0), max_force=max_force)
    mouse.target = (0.0, 1.0)
    for _ in range(60):
        w.step(DT)
        assert float(np.hypot(*mouse.impulse)) <= max_force * DT * (1 + 1e-12)
    assert box.position[1] < 0.0  # it sank under its weight: (m g - F) / m downward
    expected = -0.5 * (G - max_force / box.mass) * (60 * DT) ** 2
    assert box.position[1] == pytest.approx(expected, rel=0.05)


def test_the_mouse_anchor_is_the_bodys_point_under_the_target():
    w = world("pgs")
    box = w.add_box(position=(0.0, 0.0), half_extents=(0.5, 0.5), angle=0.3)
    mouse = w.add_mouse_joint(box, target=(0.2, 0.1), max_force=10.0)
    target, point = mouse.anchors()
    assert np.allclose(point, (0.2, 0.1)) and np.allclose(target, (0.2, 0.1))
    assert mouse.body is box


# -- handles, setters, bad input -----------------------------------------------------------
def test_settable_motor_and_limits_change_the_rows():
    w, wheel, pin = wheel_on_axle("pgs")
    assert pin.row_count == 2 and pin.motor_speed is None
    pin.motor_speed = 1.0
    pin.max_motor_torque = 1e3
    assert pin.row_count == 3
    w.step(DT)
    assert wheel.angular_velocity == pytest.approx(1.0, abs=1e-9)
    pin.motor_speed = -2.0  # in place: the rows stay
    w.step(DT)
    assert wheel.angular_velocity == pytest.approx(-2.0, abs=1e-9)
    pin.set_limits(-0.5, 0.5)
    assert pin.row_count == 5 and pin.lower == -0.5 and pin.upper == 0.5
    pin.motor_speed = None
    assert pin.row_count == 4
    assert "lower=-0.5" in repr(pin) and "upper=0.5" in repr(pin)
    w.step(DT)
    assert pin.impulse.shape == (4,)


def test_removing_new_joints_frees_the_bodies():
    w = world("soft-step")
    a = w.add_box(position=(0.0, 0.0), half_extents=(0.1, 0.1), static=True)
    b = w.add_box(position=(1.0, 0.0))
    weld = w.add_weld_joint(a, b, anchor=(0.5, 0.0))
    mouse = w.add_mouse_joint(b, target=(1.0, 0.0), max_force=5.0)
    w.step(DT)
    w.remove(weld)
    w.remove(mouse)
    assert w.joints == () and not weld.alive and not mouse.alive
    assert "removed" in repr(mouse)
    w.step(DT)
    assert b.velocity[1] == pytest.approx(-G * DT, rel=1e-9)  # free fall from the second step
    with pytest.raises(ValueError, match="removed"):
        mouse.target = (0.0, 0.0)


def snapshot(w: phys2d.World):
    return (len(w.joints), w._joints.arrays.params.copy(), w._joints.lam.copy())


@pytest.mark.parametrize(
    ("make", "error", "match"),
    [
        (lambda w, a, b: w.add_pin_joint(a, b, anchor=(math.nan, 0.0)), ValueError, "anchor"),
        (lambda w, a, b: w.add_pin_joint(a, b, anchor=(0, 0), lower=1.0, upper=0.0), ValueError, "lower"),
        (lambda w, a, b: w.add_pin_joint(a, b, anchor=(0, 0), max_motor_torque=-1.0), ValueError, "max_motor_torque"),
        (lambda w, a, b: w.add_pin_joint(a, b, anchor=(0, 0), motor_speed=math.inf), ValueError, "motor_speed"),
        (lambda w, a, b: w.add_pin_joint(a, b, anchor=(0, 0), upper=math.nan), ValueError, "upper"),
        (lambda w, a, b: w.add_slider_joint(a, b, anchor=(0, 0), axis=(0.0, 0.0)), ValueError, "axis"),
        (lambda w, a, b: w.add_slider_joint(a, b, anchor=(0, 0), axis="x"), TypeError, "axis"),
        (
            lambda w, a, b: w.add_slider_joint(a, b, anchor=(0, 0), axis=(1, 0), max_motor_force=-2.0),
            ValueError,
            "max_motor_force",
        ),
        (
            lambda w, a, b: w.add_slider_joint(a, b, anchor=(0, 0), axis=(1, 0), lower=0.5, upper=0.1),
            ValueError,
            "lower",
        ),
        (lambda w, a, b: w.add_weld_joint(a, b, anchor=None), TypeError, "anchor"),
        (lambda w, a, b: w.add_weld_joint(a, a, anchor=(0, 0)), ValueError, "same body"),
        (lambda w, a, b: w.add_mouse_joint(b, target=(math.inf, 0.0), max_force=1.0), ValueError, "target"),
        (lambda w, a, b: w.add_mouse_joint(b, target=(0.0, 0.0), max_force=-1.0), ValueError, "max_force"),
        (lambda w, a, b: w.add_mouse_joint(b, target=(0.0, 0.0), max_force=math.nan), ValueError, "max_force"),
        (lambda w, a, b: w.add_mouse_joint(a, target=(0.0, 0.0), max_force=1.0), ValueError, "dynamic"),
        (lambda w, a, b: w.add_mouse_joint(b, target=(0, 0), max_force=1.0, hertz=0.0), ValueError, "hertz"),
        (lambda w, a, b: w.add_mouse_joint("b", target=(0, 0), max_force=1.0), TypeError, "body"),
    ],
)
def test_bad_input_is_refused_and_the_world_left_as_it_was(make, error, match):
    w = world("pgs")
    a = w.add_box(position=(0.0, 0.0), static=True)
    b = w.add_box(position=(1.0, 0.0))
    w.add_pin_joint(a, b, anchor=(0.5, 0.0), motor_speed=1.0, max_motor_torque=1.0)
    before = snapshot(w)
    with pytest.raises(error, match=match):
        make(w, a, b)
    after = snapshot(w)
    assert before[0] == after[0]
    assert np.array_equal(before[1], after[1]) and np.array_equal(before[2], after[2])


def test_bad_settings_are_refused_and_change_nothing():
    w = world("pgs")
    a = w.add_box(position=(0.0, 0.0), static=True)
    b = w.add_box(position=(1.0, 0.0))
    pin = w.add_pin_joint(a, b, anchor=(0.5, 0.0), lower=-1.0, upper=1.0)
    slider = w.add_slider_joint(a, w.add_box(position=(3.0, 0.0)), anchor=(3.0, 0.0), axis=(1, 0))
    mouse = w.add_mouse_joint(b, target=(1.0, 0.0), max_force=3.0)
    before = snapshot(w)
    for joint, name, value, error in [
        (pin, "lower", 2.0, ValueError),  # above upper
        (pin, "upper", -2.0, ValueError),
        (pin, "motor_speed", math.nan, ValueError),
        (pin, "max_motor_torque", -1.0, ValueError),
        (slider, "max_motor_force", math.inf, ValueError),
        (slider, "motor_speed", "fast", TypeError),
        (mouse, "target", (0.0, math.nan), ValueError),
        (mouse, "target", (1.0, 2.0, 3.0), ValueError),
        (mouse, "max_force", -1.0, ValueError),
    ]:
        with pytest.raises(error, match=name if name != "target" else "target"):
            setattr(joint, name, value)
    with pytest.raises(ValueError, match="lower"):
        pin.set_limits(1.0, -1.0)
    after = snapshot(w)
    assert np.array_equal(before[1], after[1]) and np.array_equal(before[2], after[2])
    assert pin.lower == -1.0 and pin.upper == 1.0 and mouse.max_force == 3.0


def test_reprs_say_what_each_joint_is():
    w = world("pgs")
    a = w.add_box(position=(0.0, 0.0), static=True)
    b = w.add_box(position=(1.0, 0.0))
    pin = w.add_pin_joint(a, b, anchor=(0.5, 0.0), motor_speed=2.0, max_motor_torque=3.0)
    slider = w.add_slider_joint(a, b, anchor=(1.0, 0.0), axis=(0, 1), lower=-1.0)
    weld = w.add_weld_joint(a, b, anchor=(1.0, 0.0))
    mouse = w.add_mouse_joint(b, target=(1.0, 0.5), max_force=4.0)
    assert repr(pin) == "<PinJoint bodies 0 and 1, 3 rows, motor_speed=2, max_motor_torque=3>"
    assert repr(slider) == "<SliderJoint bodies 0 and 1, 3 rows, axis (0, 1) in a's frame, lower=-1>"
    assert repr(weld) == "<WeldJoint bodies 0 and 1, 3 rows>"
    assert repr(mouse) == "<MouseJoint body 1, target (1, 0.5), max_force=4, hertz=5, damping_ratio=0.7>"


def test_matrix_form_takes_the_mouse_and_agrees_on_motors_and_limits():
    w = world("pgs")
    b = w.add_box(position=(1.0, 0.0))
    w.add_mouse_joint(b, target=(1.0, 0.0), max_force=1.0)
    w.responder = phys2d.PGS(form="matrix")  # both forms solve mouse joints (tests/test_mouse_matrix.py)
    w2 = phys2d.World(responder=phys2d.PGS(form="matrix"))
    w2.add_mouse_joint(w2.add_box(), target=(0, 0), max_force=1.0)
    assert len(w2.joints) == 1

    def scene(form):
        w = phys2d.World(gravity=(0.0, -G), responder=phys2d.PGS(form=form))
        post = w.add_box(position=(0.0, 0.0), half_extents=(0.05, 0.05), static=True)
        bar = w.add_box(position=(0.5, 0.0), half_extents=(0.5, 0.05))
        w.add_pin_joint(post, bar, anchor=(0.0, 0.0), motor_speed=1.0, max_motor_torque=1.0, lower=-0.5, upper=0.3)
        car = w.add_box(position=(1.5, 0.0), half_extents=(0.2, 0.05))
        w.add_slider_joint(bar, car, anchor=(1.5, 0.0), axis=(1, 1), lower=-0.2, upper=0.2, motor_speed=0.5)
        w.add_weld_joint(car, w.add_box(position=(1.9, 0.0), half_extents=(0.2, 0.05)), anchor=(1.7, 0.0))
        w.add_mouse_joint(car, target=(1.6, 0.0), max_force=3.0).target = (1.6, 0.5)
        return w

    impulse, matrix = scene("impulse"), scene("matrix")
    for _ in range(60):
        impulse.step(DT)
        matrix.step(DT)
    assert np.allclose(impulse.x, matrix.x, atol=1e-9) and np.allclose(impulse.V, matrix.V, atol=1e-9)


def test_new_joints_are_drawn_in_recordings(tmp_path):
    w = world("soft-step")
    a = w.add_box(position=(0.0, 0.0), half_extents=(0.1, 0.1), static=True)
    b = w.add_box(position=(1.0, 0.0), half_extents=(0.2, 0.1))
    c = w.add_box(position=(2.0, 0.0), half_extents=(0.2, 0.1))
    w.add_slider_joint(a, b, anchor=(1.0, 0.0), axis=(1, 0), motor_speed=0.5, max_motor_force=5.0)
    w.add_weld_joint(b, c, anchor=(1.5, 0.0))
    mouse = w.add_mouse_joint(c, target=(2.0, 0.0), max_force=50.0)
    mouse.target = (2.0, 1.0)
    path = tmp_path / "joints.rrd"
    with phys2d.Recorder(path, name="new joints") as rec:
        for _ in range(5):
            w.step(DT)
            rec.log(w)
    back = phys2d.playback.load(path)
    ends = back.joint_anchors[-1].reshape(-1, 2, 2)
    assert ends.shape == (3, 2, 2)
    assert np.allclose(ends[2, 0], (2.0, 1.0))  # the mouse's line starts at its target
    assert np.allclose(ends[2, 1], mouse.anchors()[1], atol=1e-3)  # (drawn on the recording's grid)


def _rows_at(w: phys2d.World, x, theta):
    """The joint rows at the poses (x, theta), built with beta = dt = 1: xi + push = -C (limits: -gap)."""
    from phys2d.constraints.joints import JointArrays, joint_rows
    from phys2d.constraints.rows import Rows
    from phys2d.pipeline import records

    ja = JointArrays(list(w.joints))
    rows = Rows(ja.n_rows)
    bodies = records.new_bodies((x, theta, w.V, w.M_inv, w.V))
    joint_rows(records.record_of_joints(ja, np.zeros(ja.n_rows)), 0, bodies, 1.0, 1.0, records.record_of_rows(rows))
    return rows


@settings(max_examples=20, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    kind=st.sampled_from(["pin", "slider", "weld", "mouse"]),
)
def test_each_row_is_the_rate_of_its_C(seed, kind):
    # a second method: J V against the central difference (C(x + eps V) - C(x - eps V)) / (2 eps)
    rng = np.random.default_rng(seed)
    w = phys2d.World(gravity=(0.0, 0.0))
    a = w.add_box(position=tuple(rng.uniform(-1, 1, 2)), half_extents=(0.3, 0.2), angle=float(rng.uniform(-3, 3)))
    b = w.add_box(position=tuple(rng.uniform(-1, 1, 2)), half_extents=(0.2, 0.4), angle=float(rng.uniform(-3, 3)))
    anchor = tuple(rng.uniform(-1, 1, 2))
    if kind == "pin":
        w.add_pin_joint(a, b, anchor=anchor, lower=-0.3, upper=0.4)
    elif kind == "slider":
        w.add_slider_joint(a, b, anchor=anchor, axis=tuple(rng.uniform(-1, 1, 2)), lower=-0.2, upper=0.5)
    elif kind == "weld":
        w.add_weld_joint(a, b, anchor=anchor)
    else:
        w.add_mouse_joint(b, target=anchor, max_force=1.0)
        w.joints[0].target = tuple(rng.uniform(-1, 1, 2))
    # move the bodies off the joint's pose, then give them velocities
    x = w.x + rng.uniform(-0.2, 0.2, (2, 2))
    theta = w.theta + rng.uniform(-0.3, 0.3, 2)
    V = rng.uniform(-1, 1, (2, 3))
    rows = _rows_at(w, x, theta)
    eps = 1e-6
    plus, minus = (
        _rows_at(w, x + eps * V[:, :2], theta + eps * V[:, 2]),
        _rows_at(w, x - eps * V[:, :2], theta - eps * V[:, 2]),
    )
    for k in range(len(rows)):
        a_k, b_k = rows.body_a[k], rows.body_b[k]
        JV = rows.J[k, :3] @ V[a_k] + rows.J[k, 3:] @ V[b_k]
        dC = (-(plus.xi[k] + plus.push[k]) + minus.xi[k] + minus.push[k]) / (2 * eps)
        assert JV == pytest.approx(dC, rel=1e-5, abs=1e-7)


def every_joint_hash(responder: str, one_call: bool = True) -> str:
    """sha256 of the states of a scene with every new joint, a target dragged halfway."""
    import hashlib

    w = world(responder)
    w.one_call_tick = one_call
    w.add_box(position=(0.0, -0.5), half_extents=(5.0, 0.5), static=True)
    post = w.add_box(position=(0.0, 2.0), half_extents=(0.05, 0.05), static=True)
    bar = w.add_box(position=(0.5, 2.0), half_extents=(0.5, 0.05))
    w.add_pin_joint(post, bar, anchor=(0.0, 2.0), motor_speed=1.0, max_motor_torque=2.0, lower=-0.5, upper=0.5)
    car = w.add_box(position=(1.5, 2.0), half_extents=(0.2, 0.1))
    w.add_slider_joint(
        bar, car, anchor=(1.5, 2.0), axis=(1, 0), lower=-0.3, upper=0.3, motor_speed=-0.5, max_motor_force=3.0
    )
    w.add_weld_joint(car, w.add_box(position=(2.0, 2.0), half_extents=(0.2, 0.1)), anchor=(1.75, 2.0))
    mouse = w.add_mouse_joint(
        w.add_box(position=(-1.0, 0.5), half_extents=(0.3, 0.3)), target=(-1, 0.6), max_force=20.0
    )
    h = hashlib.sha256()
    for i in range(60):
        if i == 20:
            mouse.target = (-2.0, 2.0)  # far: the pull is capped
        w.step(DT)
        for a in (w.x, w.theta, w.V, w.last_step.joint_impulses):
            h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()


@ALL
def test_every_joint_steps_alike_in_one_call_staged_and_uncompiled(responder):
    import os
    import subprocess
    import sys

    compiled = every_joint_hash(responder)
    assert every_joint_hash(responder, one_call=False) == compiled
    code = f"from tests.test_joint_motors import every_joint_hash; print(every_joint_hash({responder!r}))"
    env = dict(os.environ, NUMBA_DISABLE_JIT="1", PHYS2D_COMPILE_AHEAD="0")
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    out = subprocess.run([sys.executable, "-c", code], env=env, cwd=root, capture_output=True, text=True, check=True)
    assert out.stdout.strip() == compiled


@st.composite
def new_joints(draw):
    """Free bodies without gravity (tests.strategies), and new joints between random pairs."""
    from tests.strategies import free_scene, reals, scenes, vectors

    scene = free_scene(draw(scenes(min_bodies=2, max_bodies=4, ground=False, region=1.5)))
    n = len(scene.bodies)
    joints = []
    for _ in range(draw(st.integers(1, 3))):
        a, b = draw(st.lists(st.integers(0, n - 1), min_size=2, max_size=2, unique=True))
        kind = draw(st.sampled_from(["pin", "slider", "weld"]))
        lower, upper = draw(st.none() | reals(-0.5, 0.0)), draw(st.none() | reals(0.0, 0.5))
        motor = draw(st.none() | reals(-3.0, 3.0))
        joints.append((kind, a, b, draw(vectors(-0.3, 0.3)), draw(vectors(-1, 1)), lower, upper, motor))
    return scene, joints


def add_new_joints(w: phys2d.World, joints) -> None:
    bodies = w.bodies
    for kind, a, b, offset, axis, lower, upper, motor in joints:
        anchor = bodies[a].position + offset
        if kind == "pin":
            w.add_pin_joint(
                bodies[a], bodies[b], anchor=anchor, lower=lower, upper=upper, motor_speed=motor, max_motor_torque=2.0
            )
        elif kind == "slider" and np.hypot(*axis) > 1e-3:
            w.add_slider_joint(
                bodies[a], bodies[b], anchor=anchor, axis=axis, lower=lower, upper=upper, motor_speed=motor,
                max_motor_force=2.0,
            )  # fmt: skip
        elif kind == "weld":
            w.add_weld_joint(bodies[a], bodies[b], anchor=anchor)


@settings(max_examples=25, deadline=None)
@given(case=new_joints(), dt=st.sampled_from([1 / 30, 1 / 60, 1 / 120]))
def test_new_joints_keep_momentum_and_both_forms_of_pgs_agree(case, dt):
    """No gravity, no static body: every new row (motor, limit, slider, weld) pushes its two
    bodies equally and oppositely, so linear momentum is kept; and the lecture's matrix form
    makes the same iterates as the impulse form (to round-off)."""
    from tests.strategies import build

    scene, joints = case
    impulse, matrix = build(scene, phys2d.PGS(split=False)), build(scene, phys2d.PGS(split=False, form="matrix"))
    add_new_joints(impulse, joints)
    add_new_joints(matrix, joints)
    p0 = impulse.linear_momentum()
    size = 1.0 + float(np.sum([b.mass for b in impulse.bodies]) * np.abs(impulse.V).max())
    for _ in range(10):
        try:
            impulse.step(dt)
        except phys2d.SimulationError:
            return
        matrix.step(dt)
        np.testing.assert_allclose(impulse.linear_momentum(), p0, rtol=0, atol=1e-9 * size)
        scale = 1.0 + float(np.abs(impulse.V).max())
        np.testing.assert_allclose(matrix.V, impulse.V, rtol=0, atol=1e-9 * scale)
        np.testing.assert_allclose(matrix.last_step.joint_impulses, impulse.last_step.joint_impulses, atol=1e-9 * size)
        matrix.x[:], matrix.theta[:], matrix.V[:] = impulse.x, impulse.theta, impulse.V  # no drift of round-off


@settings(max_examples=12, deadline=None)
@given(
    responder=st.sampled_from(["pgs", "soft-step"]),
    lower=st.floats(-1.2, -0.1),
    upper=st.floats(0.1, 1.2),
    spin=st.floats(-8.0, 8.0),
)
def test_pin_limits_hold_whatever_the_range_and_spin(responder, lower, upper, spin):
    # property: a wheel spun toward a stop ends within [lower, upper] (a few hundredths of a
    # radian past it at most, while it lands), and never rebounds past the other
    w = world(responder, gravity=(0.0, 0.0))
    post = w.add_box(position=(0.0, 0.0), half_extents=(0.1, 0.1), static=True)
    wheel = w.add_circle(position=(0.0, 0.0), radius=0.5, angular_velocity=spin)
    pin = w.add_pin_joint(post, wheel, anchor=(0.0, 0.0), lower=lower, upper=upper)
    for _ in range(60):
        w.step(DT)
        assert lower - 0.05 <= pin.angle() <= upper + 0.05
    assert lower - 0.01 <= pin.angle() <= upper + 0.01


@settings(max_examples=12, deadline=None)
@given(
    responder=st.sampled_from(["pgs", "soft-step"]),
    target=st.tuples(st.floats(-5.0, 5.0), st.floats(-5.0, 5.0)),
    max_force=st.floats(0.0, 200.0),
)
def test_the_mouse_never_pulls_harder_than_max_force(responder, target, max_force):
    w = world(responder)
    box = w.add_box(position=(0.0, 0.0), half_extents=(0.3, 0.2), angle=0.4)
    mouse = w.add_mouse_joint(box, target=(0.2, 0.1), max_force=max_force)
    mouse.target = target
    for _ in range(20):
        w.step(DT)
        assert float(np.hypot(*mouse.impulse)) <= max_force * DT * (1 + 1e-12) + 1e-15
