"""Why SoftStep's ragdolls kept moving, in the smallest scene: an arm (two capsules, the elbow a
pin with limits at its creation angle) hanging from a shoulder pin on a static body.

Measured in ``stock_scenes.ragdoll(3)`` under SoftStep: what moves at 4-10 s are two straight
arms (elbows at their lower limit, 0) hanging off ragdolls propped on the step, swinging as
pendulums about frictionless shoulders (kinetic energy peaks every 0.6 s, half a swing), and
the total energy KE + PE falls all the while: no row adds energy. A frictionless pendulum swings
on; it comes to rest with joint friction (Box2D's human: a motor toward zero relative speed).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import phys2d
from phys2d import stock_scenes

# one worker runs this file and test_joint_motors.py: their worlds' ticks (joints, each responder) compile once
pytestmark = pytest.mark.xdist_group("joint_worlds")

DT = 1 / 60
RESPONDERS = {"pgs": lambda: phys2d.PGS(), "soft-step": lambda: phys2d.SoftStep()}
SHOULDER = (0.0, 2.0)


def hanging_arm(responder, swing: float, friction: float = 0.0, gravity=(0.0, -10.0)):
    """The arm of ``stock_scenes``' ragdoll turned ``swing`` rad from hanging straight down about
    its shoulder (on a static body), elbow straight at its lower limit; pins with ``friction``
    (N m) when > 0. Returns (world, elbow)."""
    w = phys2d.World(responder=responder, gravity=gravity)
    anchor = w.add_box((0.0, 2.3), half_extents=(0.05, 0.05), static=True)
    d = np.array([math.sin(swing), -math.cos(swing)])
    s = np.array(SHOULDER)
    angle = math.atan2(d[1], d[0])
    upper = w.add_capsule(s + 0.13 * d, half_length=0.12, radius=0.05, angle=angle, density=1000.0, group=-1)
    lower = w.add_capsule(s + 0.39 * d, half_length=0.1, radius=0.045, angle=angle, density=1000.0, group=-1)
    motor = {"motor_speed": 0.0, "max_motor_torque": friction} if friction > 0.0 else {}
    w.add_pin_joint(anchor, upper, anchor=SHOULDER, **motor)
    elbow = w.add_pin_joint(upper, lower, anchor=tuple(s + 0.26 * d), lower=0.0, upper=2.5, **motor)
    return w, elbow


def energy(w: phys2d.World) -> float:
    return w.kinetic_energy() + w.potential_energy()


@pytest.mark.parametrize("responder", RESPONDERS)
def test_a_frictionless_hanging_arm_swings_on_and_never_gains_energy(responder):
    """Frictionless pins conserve KE + PE: over 5 s it never rises above its start (1 mJ), and
    most of the swing's energy (E0 minus the PE hanging straight down, from a second world) is
    still there: the solver's losses at the elbow's stop and in its rows are small."""
    w, elbow = hanging_arm(RESPONDERS[responder](), swing=0.5)
    rest, _ = hanging_arm(RESPONDERS[responder](), swing=0.0)
    E0 = energy(w)
    swing_energy = E0 - rest.potential_energy()
    highest = E0
    for _ in range(round(5.0 / DT)):
        w.step(DT)
        highest = max(highest, energy(w))
        assert elbow.lower - 0.01 <= elbow.angle() <= elbow.upper + 0.01
    assert highest <= E0 + 1e-3
    assert E0 - energy(w) < 0.4 * swing_energy


@pytest.mark.parametrize("responder", RESPONDERS)
def test_a_hanging_arm_with_joint_friction_comes_to_rest(responder):
    """10 N m of friction at each pin stops the swing (the shoulder's 10 N m exceeds the
    gravity torque m g d sin(theta) of the straight arm once theta < ~3.4 deg): at rest after
    3 s, the elbow within its limits."""
    w, elbow = hanging_arm(RESPONDERS[responder](), swing=0.5, friction=10.0)
    for _ in range(round(3.0 / DT)):
        w.step(DT)
    assert w.kinetic_energy() < 1e-6
    assert elbow.lower - 0.01 <= elbow.angle() <= elbow.upper + 0.01


@settings(max_examples=25, deadline=None)
@given(
    omega=st.tuples(*[st.floats(-6.0, 6.0)] * 2),
    v=st.tuples(*[st.floats(-2.0, 2.0)] * 2),
)
def test_a_pinned_pair_with_a_limit_never_gains_energy_without_gravity(omega, v):
    """No gravity, no motor: the soft step's pin and limit rows only take energy out, whatever
    the bodies' velocities (the elbow starts at its lower limit). KE after a step <= before
    (1e-9 J, plus 1e-6 of it for rounding)."""
    w, elbow = hanging_arm(phys2d.SoftStep(), swing=0.3, gravity=(0.0, 0.0))
    upper, lower = elbow.body_a, elbow.body_b
    upper.velocity, upper.angular_velocity = (v[0], v[1]), omega[0]
    lower.velocity, lower.angular_velocity = (v[0], v[1]), omega[1]
    for _ in range(30):
        before = w.kinetic_energy()
        w.step(DT)
        assert w.kinetic_energy() <= before * (1.0 + 1e-6) + 1e-9


def test_ragdoll_joint_friction_is_checked_and_the_world_left_as_it_was():
    w = phys2d.World()
    with pytest.raises(ValueError, match="joint_friction"):
        stock_scenes.add_ragdoll(w, (0.0, 1.0), joint_friction=-1.0)
    assert len(w) == 0 and len(w.joints) == 0
    with pytest.raises(ValueError, match="joint_friction"):
        stock_scenes.ragdoll(1, joint_friction=float("nan"))
