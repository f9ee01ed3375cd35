"""Joints: distance, pin and angle rows against pendulum theory and conservation laws."""

from __future__ import annotations

import math

import numpy as np
import pytest

import phys2d
from phys2d import scenes

G = 10.0


def amplitude_factor(theta_0: float) -> float:
    """T / T_small for a pendulum of amplitude theta_0 (rad): pi / (2 K(sin(theta_0/2))) inverted.

    The exact period is 4 sqrt(L/g) K(k), k = sin(theta_0 / 2), and
    K(k) = pi / (2 AGM(1, sqrt(1 - k^2))), so T = T_small / AGM(1, cos(theta_0 / 2)).
    """
    a, b = 1.0, math.cos(0.5 * theta_0)
    while abs(a - b) > 1e-15:
        a, b = 0.5 * (a + b), math.sqrt(a * b)
    return 1.0 / a


def measured_period(t: np.ndarray, angle: np.ndarray) -> float:
    """Mean time between upward zero crossings of ``angle``, interpolated linearly."""
    s = np.flatnonzero((angle[:-1] < 0.0) & (angle[1:] >= 0.0))
    crossings = t[s] + (t[s + 1] - t[s]) * (-angle[s]) / (angle[s + 1] - angle[s])
    assert crossings.size >= 3, "the pendulum did not swing"
    return float(np.mean(np.diff(crossings)))


def swing(w, bob, pivot, dt: float, seconds: float) -> tuple[np.ndarray, np.ndarray]:
    """Times and angles (from straight down) of the bob's centre around ``pivot``."""
    ts, angles = [], []
    for _ in range(int(round(seconds / dt))):
        w.step(dt)
        d = bob.position - pivot
        ts.append(w.time)
        angles.append(math.atan2(d[0], -d[1]))
    return np.array(ts), np.array(angles)


def test_amplitude_factor_matches_the_series():
    # T / T_small = 1 + theta^2/16 + 11 theta^4/3072 + ... (a second method)
    th = 0.2
    assert amplitude_factor(th) == pytest.approx(1 + th**2 / 16 + 11 * th**4 / 3072, rel=1e-6)


def distance_pendulum(responder: phys2d.Responder, dt: float, L: float = 1.5, theta_0: float = 0.5) -> tuple:
    """A bob on a massless rod of length L m (a distance joint), let go theta_0 rad from the
    vertical and swung for 8 s: (the measured period s, the exact one T = 2 pi sqrt(L/g) times
    the amplitude factor, the largest angle rad, the joint's gap m at the end)."""
    w = phys2d.World(gravity=(0.0, -G), responder=responder)
    pivot = np.array([0.0, 5.0])
    anchor = w.add_circle(position=pivot, radius=0.05, static=True)
    bob = w.add_circle(position=pivot + L * np.array([math.sin(theta_0), -math.cos(theta_0)]), radius=0.1)
    joint = w.add_distance_joint(anchor, bob, anchor_a=pivot, anchor_b=bob.position)
    assert joint.length == pytest.approx(L)
    t, angle = swing(w, bob, pivot, dt, 8.0)
    expected = 2 * math.pi * math.sqrt(L / G) * amplitude_factor(theta_0)
    return measured_period(t, angle), expected, float(angle.max()), joint.gap()


def pin_pendulum(responder: phys2d.Responder, dt: float, theta_0: float = 0.4) -> tuple:
    """A 1 m x 0.1 m rod pinned at one end, let go theta_0 rad from the vertical and swung for
    8 s: (the measured period s, the exact one T = 2 pi sqrt(I_p / (m g d)) times the amplitude
    factor, with I_p = I_cm + m d^2 about the pin, the pin's gap m at the end)."""
    hx, hy = 0.5, 0.05
    w = phys2d.World(gravity=(0.0, -G), responder=responder)
    pivot = np.array([0.0, 5.0])
    base = w.add_circle(position=pivot, radius=0.05, static=True)
    direction = np.array([math.sin(theta_0), -math.cos(theta_0)])
    rod = w.add_box(
        position=pivot + hx * direction, half_extents=(hx, hy), angle=theta_0 + math.pi / 2
    )  # its long axis along the hanging direction
    pin = w.add_pin_joint(base, rod, anchor=pivot)
    m = rod.mass
    I_p = m * ((2 * hx) ** 2 + (2 * hy) ** 2) / 12 + m * hx**2
    assert rod.inertia == pytest.approx(I_p - m * hx**2)
    t, angle = swing(w, rod, pivot, dt, 8.0)
    expected = 2 * math.pi * math.sqrt(I_p / (m * G * hx)) * amplitude_factor(theta_0)
    return measured_period(t, angle), expected, pin.gap()


@pytest.mark.parametrize("form", ["impulse", "matrix"])
def test_distance_pendulum_period(form):
    period, expected, largest, gap = distance_pendulum(phys2d.PGS(form=form), 1 / 120)
    assert period == pytest.approx(expected, rel=0.01)
    assert largest == pytest.approx(0.5, abs=0.01)  # it neither gains nor loses much
    assert gap < 1e-3


def test_pin_joint_physical_pendulum_period():
    period, expected, gap = pin_pendulum(phys2d.PGS(), 1 / 120)
    assert period == pytest.approx(expected, rel=0.01)
    assert gap < 1e-3


def test_hanging_chain_keeps_its_joints_together():
    w = scenes.pendulum_chain(10)
    assert len(w.joints) == 10
    gaps = []
    for _ in range(600):  # 10 s: the chain falls from horizontal and swings
        w.step(1 / 60)
        gaps.append([joint.gap() for joint in w.joints])
    gaps = np.array(gaps)
    assert gaps.mean() < 0.01
    # it really swung: the free end went below the pivot by most of the chain's length
    assert w.x[-1, 1] < 6.0 - 2.0


def test_pendulum_chain_refuses_the_naive_takes():
    with pytest.raises(ValueError, match="contact pairs only"):
        scenes.pendulum_chain(3, responder=phys2d.NaiveImpulse())


@pytest.mark.parametrize("form", ["impulse", "matrix"])
def test_angle_limits_hold_a_spinning_body(form):
    lower, upper = -0.5, 0.8
    w = phys2d.World(gravity=(0.0, -G), responder=phys2d.PGS(form=form))
    base = w.add_box(position=(0.0, 3.0), half_extents=(0.2, 0.2), static=True)
    # an arm pinned 0.6 m off its centre: gravity and spin both drive it into the limits
    arm = w.add_box(position=(0.6, 3.0), half_extents=(1.0, 0.1), angular_velocity=10.0)
    w.add_pin_joint(base, arm, anchor=(0.0, 3.0))
    limit = w.add_angle_joint(base, arm, lower=lower, upper=upper)
    assert limit.row_count == 2
    offsets = []
    for n in range(600):
        if n % 60 == 0:  # kick it hard towards either limit again
            arm.angular_velocity = 15.0 if n % 120 == 0 else -15.0
        w.step(1 / 60)
        offsets.append(limit.offset())
    offsets = np.array(offsets)
    assert offsets.min() >= lower - 0.05
    assert offsets.max() <= upper + 0.05
    # both limits were reached, so both rows did work
    assert offsets.min() < lower + 0.05 and offsets.max() > upper - 0.05


def test_angle_joint_without_limits_keeps_the_relative_angle():
    w = phys2d.World(gravity=(0.0, 0.0))
    a = w.add_box(position=(0.0, 0.0), half_extents=(0.5, 0.5), angle=0.3, angular_velocity=2.0)
    b = w.add_box(position=(3.0, 0.0), half_extents=(0.5, 0.25), angle=-0.2)
    joint = w.add_angle_joint(a, b)
    assert joint.theta_0 == pytest.approx(-0.5)
    L0 = w.angular_momentum()
    for _ in range(120):
        w.step(1 / 60)
    assert abs(joint.offset()) < 1e-3
    # the joint's torques are equal and opposite: the total spin is kept
    assert w.angular_momentum() == pytest.approx(L0, abs=1e-9)
    # and shared in proportion to inertia: omega = L0 / (I_a + I_b)
    assert b.angular_velocity == pytest.approx(L0 / (a.inertia + b.inertia), rel=1e-6)


def test_distance_joint_conserves_momentum_of_a_free_pair():
    w = phys2d.World(gravity=(0.0, 0.0))
    a = w.add_box(position=(0.0, 0.0), half_extents=(0.3, 0.2), velocity=(1.0, 2.0), angular_velocity=3.0)
    b = w.add_circle(position=(2.0, 0.5), radius=0.3, velocity=(-1.0, 0.5), density=2.0)
    joint = w.add_distance_joint(a, b, anchor_a=(0.2, 0.1), anchor_b=(1.8, 0.5))
    p0, L0 = w.linear_momentum(), w.angular_momentum()
    for _ in range(240):
        w.step(1 / 60)
    np.testing.assert_allclose(w.linear_momentum(), p0, atol=1e-9)
    # the joint's impulses act along the line between its anchors: no net torque
    assert w.angular_momentum() == pytest.approx(L0, abs=1e-9)
    assert joint.gap() < 0.01


def test_joint_reactions_of_a_hanging_body_at_rest():
    dt = 1 / 60
    w = phys2d.World(gravity=(0.0, -G))
    ceiling = w.add_box(position=(0.0, 10.0), half_extents=(1.0, 0.1), static=True)
    bob = w.add_circle(position=(0.0, 8.0), radius=0.2)
    rod = w.add_distance_joint(ceiling, bob, anchor_a=(0.0, 10.0), anchor_b=(0.0, 8.0))
    box = w.add_box(position=(3.0, 8.0), half_extents=(0.25, 0.25))
    pin = w.add_pin_joint(box, ceiling, anchor=(3.0, 8.25))  # static body as b
    for _ in range(120):
        w.step(dt)
    # at rest each joint carries its body's weight: m g dt per step
    assert rod.impulse[0] == pytest.approx(-bob.mass * G * dt, rel=1e-4)  # tension: negative
    # pin rows act on b (the ceiling) positively: on the box they push down, hence -m g dt
    np.testing.assert_allclose(pin.impulse, [0.0, -box.mass * G * dt], atol=1e-6 * box.mass)
    report = w.last_step.joint_impulses
    assert report.shape == (3,)
    np.testing.assert_allclose(report, np.concatenate([rod.impulse, pin.impulse]))
    assert list(pin.row_range) == [2 * w.last_step.contact_count + 1, 2 * w.last_step.contact_count + 2]


def test_anchors_ride_with_the_bodies():
    w = phys2d.World(gravity=(0.0, 0.0))
    a = w.add_box(position=(0.0, 0.0), half_extents=(0.5, 0.5), angle=0.7)
    b = w.add_box(position=(3.0, 1.0), half_extents=(0.5, 0.5), angle=-0.4)
    joint = w.add_distance_joint(a, b, anchor_a=(0.3, 0.2), anchor_b=(2.8, 1.1))
    assert joint.length == pytest.approx(math.hypot(2.5, 0.9))
    a.angle = 0.7 + math.pi / 2
    b.position = (4.0, 1.0)
    p_a, p_b = joint.anchors()
    # (0.3, 0.2) turned a quarter turn about a's centre is (-0.2, 0.3); b's anchor moved with b
    np.testing.assert_allclose(p_a, [-0.2, 0.3], atol=1e-12)
    np.testing.assert_allclose(p_b, [3.8, 1.1], atol=1e-12)


def test_connected_bodies_do_not_collide_unless_asked():
    w = phys2d.World(gravity=(0.0, 0.0))
    a = w.add_box(position=(0.0, 0.0), half_extents=(0.5, 0.5))
    b = w.add_box(position=(0.6, 0.0), half_extents=(0.5, 0.5))  # overlapping by 0.4 m
    c = w.add_box(position=(1.2, 0.0), half_extents=(0.5, 0.5))  # overlapping b
    w.add_pin_joint(a, b, anchor=(0.3, 0.0))
    w.add_pin_joint(b, c, anchor=(0.9, 0.0), collide_connected=True)
    w.step(1 / 60)
    pairs = set(zip(w.contacts.body_a.tolist(), w.contacts.body_b.tolist(), strict=True))
    assert (0, 1) not in pairs
    assert (1, 2) in pairs


def test_removing_bodies_and_joints():
    w = phys2d.World(gravity=(0.0, 0.0))
    a = w.add_box(position=(0.0, 0.0))
    b = w.add_box(position=(0.6, 0.0))
    c = w.add_box(position=(1.2, 0.0))
    d = w.add_box(position=(1.8, 0.0))
    ab = w.add_pin_joint(a, b, anchor=(0.3, 0.0))
    cd = w.add_pin_joint(c, d, anchor=(1.5, 0.0))
    bc = w.add_distance_joint(b, c)
    assert w._joints.excluded.tolist() == [(0 << 32) | 1, (1 << 32) | 2, (2 << 32) | 3]
    w.remove(bc)
    assert not bc.alive and w.joints == (ab, cd)
    with pytest.raises(ValueError, match="removed"):
        w.remove(bc)
    with pytest.raises(TypeError, match="item"):
        w.remove("bc")
    with pytest.raises(ValueError, match="another world"):
        phys2d.World().remove(ab)
    w.remove(a)  # takes ab with it; b, c, d become 0, 1, 2
    assert not ab.alive and w.joints == (cd,)
    assert w._joints.excluded.tolist() == [(1 << 32) | 2]
    w.step(1 / 60)  # c and d overlap but stay excluded under their new indices
    pairs = set(zip(w.contacts.body_a.tolist(), w.contacts.body_b.tolist(), strict=True))
    assert (1, 2) not in pairs and (0, 1) in pairs
    assert cd.impulse.shape == (2,)


@pytest.mark.parametrize("one_call", [True, False])
def test_joints_keep_their_reactions_and_rows_when_another_is_removed_or_added(one_call):
    """A joint's impulse and row_range speak of the last step until the next one: removing or
    adding another joint changes neither; after the next step the joints' rows follow the
    contact rows in joint order, and each joint's impulse is its share of the step's report."""
    w = scenes.heavy_chain(6, responder=phys2d.PGS(iterations=10, warm_start=True))
    w.one_call_tick = one_call
    for _ in range(40):
        w.step(1 / 60)
    before = {id(q): (q.impulse, q.row_range) for q in w.joints}
    gone = w.joints[2]
    anchor = tuple(gone.anchors()[0])
    w.remove(gone)
    new = w.add_pin_joint(w.bodies[3], w.bodies[4], anchor=anchor)
    for q in w.joints[:-1]:
        np.testing.assert_array_equal(q.impulse, before[id(q)][0])
        assert q.row_range == before[id(q)][1]
    np.testing.assert_array_equal(gone.impulse, before[id(gone)][0])  # the removed one keeps its last
    assert gone.row_range == range(0) and new.row_range == range(0) and not new.impulse.any()
    w.step(1 / 60)
    start = 2 * w.last_step.contact_count
    for q in w.joints:
        assert q.row_range == range(start, start + q.row_count)
        start += q.row_count
    np.testing.assert_array_equal(np.concatenate([q.impulse for q in w.joints]), w.last_step.joint_impulses)
    assert new.impulse.any()  # it carries the box now


def test_bad_joints_raise_and_leave_the_world_unchanged():
    w = phys2d.World()
    ground = w.add_box(position=(0.0, -0.5), half_extents=(5.0, 0.5), static=True)
    wall = w.add_box(position=(6.0, 0.0), half_extents=(0.5, 0.5), static=True)
    box = w.add_box(position=(0.0, 1.0))
    gone = w.add_box(position=(2.0, 1.0))
    w.remove(gone)
    other = phys2d.World().add_box()
    cases = [
        (TypeError, lambda: w.add_pin_joint(ground, "box", anchor=(0, 0))),
        (ValueError, lambda: w.add_pin_joint(box, box, anchor=(0, 0))),
        (ValueError, lambda: w.add_pin_joint(ground, wall, anchor=(0, 0))),
        (ValueError, lambda: w.add_pin_joint(ground, gone, anchor=(0, 0))),
        (ValueError, lambda: w.add_pin_joint(ground, other, anchor=(0, 0))),
        (TypeError, lambda: w.add_pin_joint(ground, box, anchor="here")),
        (TypeError, lambda: w.add_pin_joint(ground, box, anchor=None)),
        (ValueError, lambda: w.add_pin_joint(ground, box, anchor=(0, math.nan))),
        (ValueError, lambda: w.add_distance_joint(ground, box, anchor_a=(0, 1), anchor_b=(0, 1))),
        (ValueError, lambda: w.add_distance_joint(ground, box, length=-1.0)),
        (TypeError, lambda: w.add_distance_joint(ground, box, collide_connected=1)),
        (ValueError, lambda: w.add_angle_joint(ground, box, lower=0.5, upper=-0.5)),
        (TypeError, lambda: w.add_angle_joint(ground, box, lower="low")),
    ]
    for error, make in cases:
        with pytest.raises(error):
            make()
    assert w.joints == () and w._joints.excluded.size == 0
    with pytest.raises(ValueError, match="anchor"):
        w.add_distance_joint(ground, box, anchor_a=(0, 1), anchor_b=(0, 1))
    with pytest.raises(ValueError, match="lower"):
        w.add_angle_joint(ground, box, lower=0.5, upper=-0.5)


def test_one_sided_angle_limit():
    # only an upper limit: spinning one way is stopped there, the other way is free
    w = phys2d.World(gravity=(0.0, 0.0))
    base = w.add_circle(position=(0.0, 0.0), radius=0.1, static=True)
    wheel = w.add_circle(position=(0.0, 0.0), radius=0.5, angular_velocity=4.0)
    w.add_pin_joint(base, wheel, anchor=(0.0, 0.0))
    limit = w.add_angle_joint(base, wheel, upper=1.0)
    assert limit.row_count == 1
    pushes = []
    for _ in range(60):
        w.step(1 / 60)
        pushes.append(limit.impulse[0])
    assert limit.offset() == pytest.approx(1.0, abs=1e-9)  # stopped at the limit, not beyond
    assert wheel.angular_velocity == pytest.approx(0.0, abs=1e-9)
    # the one-sided row pushed once, taking all the spin: lambda = I omega (N m s)
    assert max(pushes) == pytest.approx(wheel.inertia * 4.0, rel=1e-9)
    assert min(pushes) >= 0.0
    wheel.angular_velocity = -4.0
    for _ in range(60):
        w.step(1 / 60)
    assert limit.offset() == pytest.approx(1.0 - 4.0, abs=1e-9)  # free below: 1 s at -4 rad/s
    assert limit.impulse[0] == 0.0
