"""Friction acts only after touch, and fully at impact (issue 27's fidelity defect).

A body that cannot turn falls straight down onto a slope whose friction holds it
(mu > tan slope). At impact its approach has |v_t| / |v_n| = tan(slope) < mu, so a
Coulomb impulse can stop it dead: it must stay where it touched. The touch point is
the closed form of the fall: the centre at height d / cos(slope) above the slope's
surface line, straight below where it was dropped (d: the half height, or the radius).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import phys2d

RESPONDERS = {
    "pgs": lambda: phys2d.PGS(),
    "pgs-block": lambda: phys2d.PGS(block=True),
    "pgs-matrix": lambda: phys2d.PGS(form="matrix"),
    "soft-step": lambda: phys2d.SoftStep(),
    "naive": lambda: phys2d.NaiveImpulse(),
    "iterative": lambda: phys2d.IterativeImpulse(),
}
TOLERANCE = 0.010  # m: the bar, where it touched


def drop_on_slope(responder, shape: str, drop: float, slope_deg: float, dt: float, down_speed: float = 0.0):
    """(distance along the slope from the touch point, m; speed at the end, m/s) of a body that
    cannot turn, dropped ``drop`` m above its touch point with ``down_speed`` m/s straight down."""
    a = math.radians(slope_deg)
    n = np.array([-math.sin(a), math.cos(a)])  # the slope's surface is the line c . n = 0
    t = np.array([math.cos(a), math.sin(a)])
    w = phys2d.World(responder=responder)
    w.add_box(-0.5 * n, half_extents=(40.0, 0.5), angle=a, static=True, friction=1.0)
    if shape == "box":
        d = 0.25
        body = w.add_box((0.0, 0.0), half_extents=(0.5, d), angle=a, friction=1.0, fixed_rotation=True)
    else:
        d = 0.3
        body = w.add_circle((0.0, 0.0), radius=d, friction=1.0, fixed_rotation=True)  # it cannot turn
    touch = np.array([0.0, d / math.cos(a)])  # (touch . n = d) straight below the drop
    body.position = touch + (0.0, drop)
    body.velocity = (0.0, -down_speed)
    for _ in range(int(round(1.5 / dt))):
        w.step(dt)
    return float((body.position - touch) @ t), float(np.hypot(*body.velocity))


@pytest.mark.parametrize("name", list(RESPONDERS))
@pytest.mark.parametrize("shape", ["box", "circle"])
@pytest.mark.parametrize("drop", [0.5, 2.0, 8.0])
def test_a_body_that_lands_where_friction_holds_it_stays_where_it_touched(name, shape, drop):
    along, speed = drop_on_slope(RESPONDERS[name](), shape, drop, 30.0, 1 / 60)
    assert abs(along) <= TOLERANCE
    assert speed < 1e-6  # and it is held there


@settings(max_examples=25, deadline=None)
@given(
    name=st.sampled_from(["pgs", "soft-step", "naive"]),
    shape=st.sampled_from(["box", "circle"]),
    slope=st.floats(5.0, 40.0),  # tan 40 deg = 0.84 < mu = 1
    drop=st.floats(0.05, 8.0),
    down_speed=st.floats(0.0, 6.0),
    dt=st.sampled_from([1 / 30, 1 / 60, 1 / 120]),
)
def test_friction_acts_only_after_touch_over_slopes_speeds_and_steps(name, shape, slope, drop, down_speed, dt):
    along, _ = drop_on_slope(RESPONDERS[name](), shape, drop, slope, dt, down_speed)
    assert abs(along) <= TOLERANCE


def test_a_body_that_lands_too_steeply_for_its_friction_slides_at_g_sin_minus_mu_cos():
    """The other side of the cone: mu = 0.2 < tan 30 deg, so after landing it slides with
    a = g (sin - mu cos) along the slope (checked over the last second, once sliding steadily)."""
    a = math.radians(30.0)
    n, t = np.array([-math.sin(a), math.cos(a)]), np.array([math.cos(a), math.sin(a)])
    w = phys2d.World()
    w.add_box(-0.5 * n, half_extents=(40.0, 0.5), angle=a, static=True, friction=0.2)
    body = w.add_box(
        (0.0, 0.25 / math.cos(a) + 1.0), half_extents=(0.5, 0.25), angle=a, friction=0.2, fixed_rotation=True
    )
    for _ in range(60):
        w.step(1 / 60)
    v0 = body.velocity @ t
    for _ in range(60):
        w.step(1 / 60)
    expected = -10.0 * (math.sin(a) - 0.2 * math.cos(a))
    assert (body.velocity @ t - v0) / 1.0 == pytest.approx(expected, rel=1e-6)
