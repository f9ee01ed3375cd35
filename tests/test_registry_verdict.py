"""The responder registry and the stood/fell verdict, against analytic motion."""

from __future__ import annotations

import math

import numpy as np
import pytest

import phys2d
from phys2d.responders import REGISTRY, make_responder
from phys2d.verdict import FELL, RESTLESS, STOOD, Watch

DT = 1 / 60


def test_registry_counts_reach_the_right_parameter():
    assert make_responder("pgs", 7).iterations == 7
    assert make_responder("pgs-block", 3).block is True
    assert make_responder("pgs-cold").warm_start is False
    assert make_responder("pgs-matrix", 4).form == "matrix"
    assert make_responder("iterative", 5).passes == 5
    assert make_responder("soft-step", 6).substeps == 6
    assert isinstance(make_responder("naive"), phys2d.NaiveImpulse)


def test_registry_rejects_bad_names_and_counts():
    with pytest.raises(ValueError, match="name must be one of"):
        make_responder("pgs2")
    with pytest.raises(TypeError, match="name must be"):
        make_responder(3)
    with pytest.raises(ValueError, match="takes no count"):
        make_responder("naive", 3)
    with pytest.raises(ValueError, match="iterations"):
        make_responder("pgs", 0)


@pytest.mark.parametrize("name", list(REGISTRY))
def test_every_registered_responder_holds_a_box_on_the_ground(name):
    entry = REGISTRY[name]
    assert entry.description and entry.name == name
    w = phys2d.World(responder=entry())
    w.add_box(position=(0.0, -0.5), half_extents=(5.0, 0.5), static=True)
    box = w.add_box(position=(0.0, 0.5), half_extents=(0.5, 0.5))
    for _ in range(60):
        w.step(DT)
    assert abs(box.position[1] - 0.5) < 0.02  # resting on the ground's top, y = 0


def _ground_world(**kw) -> phys2d.World:
    w = phys2d.World(**kw)
    w.add_box(position=(0.0, -0.5), half_extents=(50.0, 0.5), static=True, friction=0.6)
    return w


def test_a_resting_box_stood():
    w = _ground_world()
    w.add_box(position=(0.0, 0.5), half_extents=(0.5, 0.5), friction=0.6)
    watch = Watch(w)
    for _ in range(120):
        w.step(DT)
        watch.observe()
    v = watch.verdict()
    assert v.outcome == STOOD and v.stood and v.fell_at is None
    assert v.max_displacement < 0.01 and v.steps == 120
    assert math.isclose(v.seconds, 2.0)
    assert v.line().startswith("stood:")


def test_a_sliding_box_falls_when_friction_has_carried_it_half_a_metre():
    # x(t) = v0 t - mu g t^2 / 2 reaches 0.5 m at t = (v0 - sqrt(v0^2 - 2 mu g 0.5)) / (mu g)
    w = _ground_world()
    w.add_box(position=(0.0, 0.5), half_extents=(0.5, 0.5), friction=0.6, velocity=(5.0, 0.0))
    watch = Watch(w)
    for _ in range(60):
        w.step(DT)
        watch.observe()
    v = watch.verdict()
    a = 0.6 * 10.0
    t_half = (5.0 - math.sqrt(25.0 - 2 * a * 0.5)) / a
    assert v.outcome == FELL and not v.stood
    assert abs(v.fell_at - t_half) <= 1.5 * DT
    assert "moved" in v.why and v.line().startswith("fell at")


def test_a_spinning_box_falls_at_thirty_degrees():
    w = phys2d.World(gravity=(0.0, 0.0))
    w.add_box(position=(0.0, 0.0), angular_velocity=10.0)
    watch = Watch(w)
    for _ in range(10):
        w.step(DT)
        watch.observe()
    v = watch.verdict()
    steps = math.ceil(math.radians(30.0) / (10.0 * DT))  # theta = omega t passes 30 deg in this step
    assert v.outcome == FELL and math.isclose(v.fell_at, steps * DT)
    assert "turned" in v.why


def test_a_body_that_keeps_moving_without_falling_is_restless():
    # free fall for 0.1 s: 5 cm travelled, 1 m/s reached
    w = phys2d.World()
    w.add_box(position=(0.0, 100.0))
    watch = Watch(w)
    for _ in range(6):
        w.step(DT)
        watch.observe()
    v = watch.verdict()
    assert v.outcome == RESTLESS
    assert math.isclose(v.final_max_speed, 10.0 * 6 * DT)
    assert math.isclose(v.final_kinetic_energy, 0.5 * 1.0 * (10.0 * 6 * DT) ** 2)


def test_removed_bodies_drop_out_and_added_ones_are_not_judged():
    w = _ground_world()
    runner = w.add_box(position=(-5.0, 0.5), velocity=(5.0, 0.0))
    w.add_box(position=(5.0, 0.5))
    watch = Watch(w)
    w.step(DT)
    watch.observe()
    first_move = watch.max_displacement  # the runner's first step: (5 - mu g dt) dt
    assert math.isclose(first_move, (5.0 - 6.0 * DT) * DT, rel_tol=1e-6)
    w.remove(runner)
    w.add_box(position=(20.0, 0.5), velocity=(9.0, 0.0))  # not judged: it was not there at the start
    for _ in range(60):
        w.step(DT)
        watch.observe()
    v = watch.verdict()
    assert v.outcome == STOOD and v.max_displacement == first_move  # the removed runner no longer counts


def test_watch_rejects_bad_limits():
    w = phys2d.World()
    with pytest.raises(ValueError, match="fall_distance"):
        Watch(w, fall_distance=-1.0)
    with pytest.raises(TypeError, match="rest_speed"):
        Watch(w, rest_speed="fast")
    assert np.isnan(Watch(w).verdict().final_residual)
