"""The World: resting contact, stacking, warm starting, restitution, friction, the API."""

from __future__ import annotations

import math
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

import phys2d
from phys2d import scenes

DT = 1 / 60


def run(w: phys2d.World, seconds: float) -> None:
    for _ in range(int(round(seconds / DT))):
        w.step(DT)


def test_box_circle_and_triangle_come_to_rest_on_the_ground_within_slop():
    w = phys2d.World()
    scenes.ground(w)
    box = w.add_box(position=(-3.0, 2.0), angle=0.3)
    ball = w.add_circle(position=(0.0, 3.0), radius=0.5)
    tri = w.add_polygon(position=(3.0, 1.5), vertices=[(-0.6, -0.4), (0.6, -0.4), (0.0, 0.6)], angle=2.0)
    run(w, 4.0)
    slop = w.responder.slop
    for b in (box, ball, tri):
        assert np.linalg.norm(b.velocity) < 1e-3 and abs(b.angular_velocity) < 1e-2
    assert w.contacts.separation.min() >= -(slop + 0.001)
    # each rests on the ground: its lowest point is at y = 0 within slop + 1 mm
    assert abs(box.vertices[:, 1].min()) <= slop + 0.001
    assert abs(tri.vertices[:, 1].min()) <= slop + 0.001
    assert abs(ball.position[1] - 0.5) <= slop + 0.001


def test_twenty_row_pyramid_stands_for_thirty_seconds():
    w = scenes.pyramid(20, responder=phys2d.PGS(iterations=10, warm_start=True))
    start = w.x.copy()
    deepest = 0.0
    for _ in range(1800):
        w.step(DT)
        deepest = max(deepest, w.last_step.max_penetration)
    moved = np.linalg.norm(w.x - start, axis=1).max()
    assert moved < 0.05
    assert deepest <= 0.010


@pytest.mark.parametrize(
    "responder", [phys2d.PGS(iterations=10, block=True), phys2d.SoftStep()], ids=["pgs-block", "soft-step"]
)
def test_ten_box_stack_stands_thirty_seconds_with_under_a_centimetre_of_sway(responder):
    w = scenes.vertical_stack(10, responder=responder)
    start = w.x.copy()
    sway = 0.0
    for _ in range(1800):
        w.step(DT)
        sway = max(sway, np.abs(w.x[:, 0] - start[:, 0]).max())
    assert sway < 0.01
    assert np.abs(w.theta).max() < 0.01


def test_warm_starting_lowers_the_residual_on_a_resting_pyramid():
    residual = {}
    for warm in (True, False):
        w = scenes.pyramid(10, responder=phys2d.PGS(iterations=10, warm_start=warm))
        tail = []
        hits = []
        for step in range(240):
            w.step(DT)
            if step >= 120:
                tail.append(w.last_step.residuals[-1])
                hits.append(w.last_step.cache_hit_rate)
        residual[warm] = float(np.median(tail))
        if warm:
            assert min(hits) >= 0.95
            assert w.contacts.warm_started.mean() >= 0.95
        else:
            assert not w.contacts.warm_started.any()
    assert residual[True] < 0.1 * residual[False]


def test_tolerance_stops_the_sweeps_early_and_reports_each_residual():
    w = scenes.pyramid(5, responder=phys2d.PGS(iterations=50, tolerance=1e-6))
    run(w, 1.0)
    r = w.last_step.residuals
    assert w.last_step.iterations == len(r) < 50
    assert r[-1] <= 1e-6 and (len(r) == 1 or r[-2] > 1e-6)


def test_same_scene_same_steps_gives_bit_identical_states():
    states = []
    for _ in range(2):
        w = scenes.mixed_shapes(12)
        run(w, 2.0)
        states.append((w.x.copy(), w.theta.copy(), w.V.copy(), w.contacts.normal_impulse.copy()))
    for a, b in zip(*states):
        assert np.array_equal(a, b)


def test_uncompiled_kernels_give_the_same_states():
    # every responder and a joint, stepped compiled and with NUMBA_DISABLE_JIT=1 (plain Python)
    code = textwrap.dedent("""
        import numpy as np, phys2d
        out = []
        for responder in (phys2d.PGS(), phys2d.PGS(block=True), phys2d.PGS(form="matrix"),
                          phys2d.SoftStep(), phys2d.NaiveImpulse(), phys2d.IterativeImpulse(passes=3)):
            w = phys2d.scenes.mixed_shapes(6, responder=responder)
            if responder.handles_joints:
                w.add_distance_joint(w.bodies[1], w.bodies[2], anchor_a=w.bodies[1].position,
                                     anchor_b=w.bodies[2].position)
            for _ in range(40):
                w.step(1 / 60)
            out.append(np.concatenate([w.x.ravel(), w.theta, w.V.ravel(), w.contacts.normal_impulse]))
        print(repr([a.tolist() for a in out]))
    """)
    out = {}
    for jit in ("0", "1"):
        env = dict(os.environ, NUMBA_DISABLE_JIT=jit, PYTHONPATH=os.getcwd())
        res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=900)
        assert res.returncode == 0, res.stderr
        out[jit] = [np.array(a) for a in eval(res.stdout)]
    assert len(out["0"]) == len(out["1"]) == 6
    for compiled, plain in zip(out["0"], out["1"], strict=True):
        assert compiled.shape == plain.shape
        assert np.allclose(compiled, plain, rtol=0, atol=1e-9)


def test_restitution_returns_e_times_the_impact_speed():
    # semi-implicit Euler puts the ends of steps on a parabola whose velocity is V - g dt/2:
    # the ball, a gap C above the ground with V = v at the start of the landing step, meets
    # it at u = sqrt((v - g dt/2)^2 + 2 g C) and leaves with the path's velocity e u, which
    # is V = e u + g dt/2 (closed form, docs/formulation.md#symbols-arrays-and-units: the integrator; bounce_target)
    e, g = 0.5, 10.0
    w = phys2d.World()
    scenes.ground(w, friction=0.0)
    ball = w.add_circle(position=(0.0, 3.0), radius=0.25, restitution=e, friction=0.0)
    for _ in range(240):
        v, gap = ball.velocity[1], ball.position[1] - 0.25
        w.step(DT)
        if ball.velocity[1] > 0 > v:
            break
    assert v < -5.0 and 0.0 < gap <= -(v - g * DT) * DT + 1e-12  # it met the ground within the step
    assert ball.position[1] - 0.25 == pytest.approx(0.0, abs=1e-12)  # it turned round on the surface
    u = math.sqrt((v - g * DT / 2) ** 2 + 2 * g * gap)
    assert ball.velocity[1] == pytest.approx(e * u + g * DT / 2, rel=1e-9)


def ramp(slope_deg: float, mu: float) -> tuple[phys2d.World, phys2d.Body]:
    a = math.radians(slope_deg)
    w = phys2d.World()
    n = np.array([-math.sin(a), math.cos(a)])
    w.add_box(position=(0.0, 0.0), half_extents=(20.0, 0.5), angle=a, static=True, friction=mu)
    box = w.add_box(position=tuple(n * 1.0), half_extents=(0.5, 0.5), angle=a, friction=mu)
    return w, box


def test_box_holds_on_a_ramp_below_the_friction_angle():
    w, box = ramp(20.0, 0.6)  # tan 20 deg = 0.36 < 0.6
    start = box.position
    run(w, 2.0)
    assert np.linalg.norm(box.position - start) < 0.005


def test_box_slides_down_a_steep_ramp_with_coulomb_acceleration():
    slope, mu, g = 40.0, 0.3, 10.0
    w, box = ramp(slope, mu)
    run(w, 0.5)
    v0 = np.linalg.norm(box.velocity)
    run(w, 1.0)
    a = (np.linalg.norm(box.velocity) - v0) / 1.0
    expected = g * (math.sin(math.radians(slope)) - mu * math.cos(math.radians(slope)))
    assert a == pytest.approx(expected, rel=0.01)


def test_sliding_box_stops_after_the_discrete_coulomb_distance():
    v0, mu, g = 6.0, 0.6, 10.0
    w = phys2d.World()
    scenes.ground(w, friction=mu)
    b = w.add_box(position=(0.0, 0.5), velocity=(v0, 0.0), friction=mu)
    run(w, 2.0)
    # v^2 / (2 mu g), less the half step semi-implicit Euler loses: v0 dt / 2
    expected = v0**2 / (2 * mu * g) - 0.5 * v0 * DT
    assert b.position[0] == pytest.approx(expected, abs=0.01)
    assert abs(b.velocity[0]) < 1e-9


def test_apply_impulse_changes_velocity_and_spin_by_m_inverse_j():
    w = phys2d.World(gravity=(0.0, 0.0))
    b = w.add_box(half_extents=(1.0, 0.5), density=2.0)
    b.apply_impulse((0.0, 4.0), point=(1.0, 0.0))
    assert np.allclose(b.velocity, (0.0, 4.0 / b.mass))
    assert b.angular_velocity == pytest.approx(1.0 * 4.0 / b.inertia)


def test_setters_move_the_body_and_reject_bad_values_without_change():
    w = phys2d.World()
    b = w.add_box()
    b.position = (1.0, 2.0)
    b.angle = 0.5
    b.velocity = (3.0, 4.0)
    b.angular_velocity = -1.0
    assert np.allclose(w.x[0], (1, 2)) and w.theta[0] == 0.5 and np.allclose(w.V[0], (3, 4, -1))
    for attr, value, exc in [
        ("position", (np.nan, 0.0), ValueError),
        ("velocity", (1.0, 2.0, 3.0), ValueError),
        ("angle", "a", TypeError),
        ("angular_velocity", math.inf, ValueError),
        ("friction", -1.0, ValueError),
        ("restitution", 1.5, ValueError),
    ]:
        with pytest.raises(exc, match=attr):
            setattr(b, attr, value)
    assert np.allclose(w.x[0], (1, 2)) and np.allclose(w.V[0], (3, 4, -1))


@pytest.mark.parametrize(
    "kwargs, exc, name",
    [
        (dict(density=0.0), ValueError, "density"),
        (dict(density=-1.0), ValueError, "density"),
        (dict(half_extents=(0.5, 0.0)), ValueError, "half_extents"),
        (dict(half_extents=(0.5, np.inf)), ValueError, "half_extents"),
        (dict(position=(np.nan, 0.0)), ValueError, "position"),
        (dict(position="here"), TypeError, "position"),
        (dict(friction=-0.1), ValueError, "friction"),
        (dict(restitution=1.1), ValueError, "restitution"),
        (dict(static="yes"), TypeError, "static"),
        (dict(angle=float("nan")), ValueError, "angle"),
        (dict(velocity=(1.0,)), ValueError, "velocity"),
    ],
)
def test_bad_box_arguments_name_the_argument_and_change_nothing(kwargs, exc, name):
    w = phys2d.World()
    w.add_box()
    with pytest.raises(exc, match=name):
        w.add_box(**kwargs)
    assert len(w.bodies) == 1 and len(w) == 1


def test_bad_circle_radius_and_step_arguments():
    w = phys2d.World()
    with pytest.raises(ValueError, match="radius"):
        w.add_circle(radius=0.0)
    for dt in (0.0, -1.0, math.nan, math.inf):
        with pytest.raises(ValueError, match="dt"):
            w.step(dt)
    with pytest.raises(TypeError, match="dt"):
        w.step("0.1")
    assert w.tick == 0
    with pytest.raises(ValueError, match="iterations"):
        phys2d.PGS(iterations=0)
    with pytest.raises(TypeError, match="responder"):
        phys2d.World(responder="pgs")


def test_remove_shifts_indices_and_keeps_the_cache_for_the_rest():
    w = scenes.vertical_stack(3)
    far = w.add_box(position=(5.0, 0.5))  # rests alone: nothing it touches changes
    run(w, 0.5)
    ground, b1, b2, b3, far = w.bodies
    w.remove(b2)
    assert not b2.alive and w.bodies == (ground, b1, b3, far) and b3.index == 2
    with pytest.raises(ValueError, match="removed"):
        _ = b2.position
    with pytest.raises(ValueError, match="removed"):
        w.remove(b2)
    other = phys2d.World()
    with pytest.raises(ValueError, match="another world"):
        other.remove(b1)
    w.step(DT)
    c = w.contacts
    on_far, on_b1 = c.body_b == far.index, c.body_b == b1.index
    assert on_far.sum() == 2 and c.warm_started[on_far].all()  # far's points are still cached
    # b1 lost the load of b2 and b3: its stored impulses are too big, so its island starts cold
    assert on_b1.sum() == 2 and not c.warm_started[on_b1].any()
    run(w, 2.0)
    assert b3.position[1] == pytest.approx(1.5, abs=0.02)  # b3 fell onto b1


def test_a_blown_up_step_raises_and_leaves_the_world_as_it_was():
    w = phys2d.World(max_speed=50.0)
    scenes.ground(w)
    b = w.add_box(position=(0.0, 20.0))
    w.step(DT)
    before = (w.x.copy(), w.theta.copy(), w.V.copy())
    b.velocity = (0.0, -49.99)  # gravity takes it past 50 m/s within the step
    v = w.V.copy()
    with pytest.raises(phys2d.SimulationError, match=r"\[1\]"):
        w.step(DT)
    assert np.array_equal(w.x, before[0]) and np.array_equal(w.V, v)
    assert w.tick == 1


def test_responders_swap_between_steps():
    w = scenes.vertical_stack(3)
    run(w, 0.5)
    w.responder = phys2d.PGS(iterations=4)
    w.step(DT)
    assert w.last_step.iterations == 4
    w.responder = phys2d.SoftStep(substeps=2)
    w.step(DT)
    assert w.last_step.responder == "soft-step"


def test_momentum_and_energy_helpers_match_hand_sums():
    w = phys2d.World(gravity=(0.0, -10.0))
    a = w.add_box(position=(1.0, 2.0), velocity=(1.0, 0.0), angular_velocity=2.0)
    c = w.add_circle(position=(0.0, 1.0), radius=0.5, velocity=(0.0, 3.0))
    ke = 0.5 * a.mass * 1.0 + 0.5 * a.inertia * 4.0 + 0.5 * c.mass * 9.0
    assert w.kinetic_energy() == pytest.approx(ke)
    assert w.potential_energy() == pytest.approx(10.0 * (a.mass * 2.0 + c.mass * 1.0))
    assert np.allclose(w.linear_momentum(), (a.mass, 3.0 * c.mass))
    assert w.angular_momentum() == pytest.approx(a.inertia * 2.0 + (1.0 * 0.0 - 2.0 * a.mass * 1.0))


def test_fast_falling_box_stops_at_the_ground_instead_of_sinking_into_it():
    # 30 m/s is half a metre per tick: only speculative contacts sized by the velocity catch it
    w = phys2d.World()
    scenes.ground(w)
    box = w.add_box(position=(0.0, 3.0), velocity=(0.0, -30.0), angle=0.1)
    ball = w.add_circle(position=(3.0, 3.0), radius=0.3, velocity=(0.0, -30.0))
    deepest = 0.0
    for _ in range(60):
        w.step(DT)
        deepest = max(deepest, w.last_step.max_penetration)
    assert deepest <= w.responder.slop + 0.002
    assert box.vertices[:, 1].min() > -0.01 and ball.position[1] > 0.29


def test_absurd_sweep_counts_are_refused_by_name_not_by_running_out_of_memory():
    for make, name in (
        (lambda n: phys2d.PGS(iterations=n), "iterations"),
        (lambda n: phys2d.SoftStep(substeps=n), "substeps"),
        (lambda n: phys2d.IterativeImpulse(passes=n), "passes"),
    ):
        with pytest.raises(ValueError, match=name):
            make(10**13)
        make(1000)  # large but sane is fine
