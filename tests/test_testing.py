"""phys2d.testing as a student uses it: the project's strategies and properties, run in a pytest
of their own on a responder written outside the engine, passing a right one and catching wrong ones."""

from __future__ import annotations

import pytest
from hypothesis import given, settings

from phys2d.testing import properties
from phys2d.testing import strategies as ps
from tests import responders_for_check as rc

FEW = settings(max_examples=8)


@FEW
@given(scene=ps.scenes(max_bodies=5, ground=True), dt=ps.dts)
def test_a_plain_pgs_keeps_the_bounds(scene: ps.SceneSpec, dt: float) -> None:
    properties.lambda_bounds(scene, rc.LecturePGS(), dt, steps=15)


@FEW
@given(scene=ps.scenes(min_bodies=2, max_bodies=5, ground=False, gravity=False), dt=ps.dts)
def test_a_plain_pgs_keeps_linear_momentum(scene: ps.SceneSpec, dt: float) -> None:
    properties.linear_momentum_kept(scene, rc.LecturePGS(), dt, steps=15)


@FEW
@given(scene=ps.scenes(min_bodies=2, max_bodies=5, ground=True), dt=ps.dts)
def test_a_plain_pgs_is_deterministic(scene: ps.SceneSpec, dt: float) -> None:
    properties.same_scene_twice(scene, rc.LecturePGS(), dt, steps=10)


SLIDING = ps.SceneSpec((ps.GROUND, ps.BodySpec("box", (0.0, 0.5), (0.5, 0.5), friction=0.5, velocity=(4.0, 0.0))))
HEAD_ON = ps.SceneSpec(
    (
        ps.BodySpec("circle", (-1.0, 0.0), 0.5, velocity=(2.0, 0.0)),
        ps.BodySpec("box", (1.0, 0.0), (0.5, 0.5), density=2.0, velocity=(-1.0, 0.0)),
    ),
    gravity=(0.0, 0.0),
)


def test_the_bounds_catch_friction_without_its_cone() -> None:
    """A box sliding at 4 m/s: Coulomb friction can take at most mu m g dt per step; unbounded
    friction stops it in one step, |lambda_t| = m v >> mu lambda_n."""
    properties.lambda_bounds(SLIDING, rc.LecturePGS(), 1 / 60)
    with pytest.raises(AssertionError, match="lambda_t"):
        properties.lambda_bounds(SLIDING, rc.NoFrictionBound(), 1 / 60)


def test_momentum_catches_a_one_sided_impulse() -> None:
    """Two bodies meeting head on: an impulse on one body only changes sum m v by itself."""
    properties.linear_momentum_kept(HEAD_ON, rc.LecturePGS(), 1 / 60, steps=60)
    with pytest.raises(AssertionError):
        properties.linear_momentum_kept(HEAD_ON, rc.OneSided(), 1 / 60, steps=60)
