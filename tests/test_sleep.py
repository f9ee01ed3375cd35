"""Sleeping: islands at rest fall asleep after TIME_TO_SLEEP of rest, cost no rows, never move
while asleep, and wake as a whole on a touch, an impulse, a force, a joint or a removal."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from rerun.chunk import RrdReader

import phys2d
from phys2d import sleep as sleeping
from phys2d.recording import schema
from tests.strategies import build, fingerprint, reals, resting_scenes, scenes, vectors

DT = 1.0 / 60.0


def two_stacks(responder: phys2d.Responder | None = None, heights=(4, 3), sleep: bool = True):
    """Boxes stacked at rest on one ground, 8 m apart: two islands (the ground joins none)."""
    w = phys2d.World(responder=responder, sleep=sleep)
    ground = w.add_box((0.0, -0.5), half_extents=(20.0, 0.5), static=True)
    stacks = [[w.add_box((8.0 * s, 0.5 + k), half_extents=(0.5, 0.5)) for k in range(h)] for s, h in enumerate(heights)]
    return w, ground, stacks


def asleep(bodies) -> list[bool]:
    return [not b.awake for b in bodies]


def run_until_asleep(w: phys2d.World, steps: int = 300) -> None:
    for _ in range(steps):
        w.step(DT)
        if not any(b.awake for b in w.bodies if not (b.static or b.kinematic)):
            return
    raise AssertionError("the bodies did not fall asleep")


# -- falling asleep ------------------------------------------------------------------------------


@pytest.mark.parametrize("responder", ["pgs", "soft-step"])
def test_a_resting_stack_falls_asleep_after_half_a_second_of_rest(responder: str) -> None:
    """Each body's rest is counted here from the velocities after each step (|v| <= 0.05 m/s and
    |omega| <= 2 deg/s, unbroken): the stack sleeps once all have rested 0.5 s, not before."""
    w, _, (stack, other) = two_stacks(phys2d.make_responder(responder))
    bodies = stack + other
    rest = np.zeros(len(bodies))
    fell_asleep_at = None
    for step in range(1, 200):
        w.step(DT)
        V = np.array([[*b.velocity, b.angular_velocity] for b in bodies])
        still = (np.hypot(V[:, 0], V[:, 1]) <= 0.05) & (np.abs(V[:, 2]) <= math.radians(2.0))
        rest = np.where(still, rest + DT, 0.0)
        slept = asleep(stack)
        assert len(set(slept)) == 1  # the island sleeps as a whole
        if min(rest[: len(stack)]) < 0.5 - 1e-9:
            assert not slept[0], f"asleep after only {min(rest[: len(stack)]):.3f} s of rest"
        elif min(rest[: len(stack)]) > 0.5 + 1e-9:
            assert slept[0]
        if slept[0] and fell_asleep_at is None:
            fell_asleep_at = step * DT
    assert fell_asleep_at is not None and 0.5 <= fell_asleep_at < 1.0  # it starts at rest: about 0.5 s
    assert all(b.velocity.tolist() == [0.0, 0.0] and b.angular_velocity == 0.0 for b in bodies)


def test_a_sleeping_world_stays_put_and_solves_no_rows() -> None:
    """Asleep: not a bit of x or theta changes, and a step finds no contact (no row is built or
    swept); the same world awake solves 2 rows per contact every step."""
    w, _, stacks = two_stacks(phys2d.PGS(block=True), heights=(10, 10))  # (PGS row by row: 10 boxes sway)
    awake, _, _ = two_stacks(phys2d.PGS(block=True), heights=(10, 10), sleep=False)
    run_until_asleep(w)
    x, theta = w.x.copy(), w.theta.copy()
    for _ in range(120):
        w.step(DT)
        awake.step(DT)
        assert len(w.contacts) == 0
        assert len(awake.contacts) >= 2 * 20  # every box rests on something, on two points
    assert np.array_equal(w.x, x) and np.array_equal(w.theta, theta)
    assert not np.any(w.V)
    assert all(asleep(stacks[0] + stacks[1]))


def test_sleep_is_off_by_default_and_switching_it_off_wakes_every_body() -> None:
    w, _, stacks = two_stacks(sleep=False)
    assert phys2d.World().sleep is False
    for _ in range(120):
        w.step(DT)
    assert not any(asleep(stacks[0] + stacks[1]))
    w.sleep = True
    run_until_asleep(w)
    x = w.x.copy()
    w.sleep = False
    assert not any(asleep(stacks[0] + stacks[1]))
    assert np.array_equal(w.x, x)  # waking moves nothing


# -- waking --------------------------------------------------------------------------------------


@pytest.mark.parametrize("responder", ["pgs", "pgs-block", "soft-step"])
def test_a_ball_dropped_on_a_stack_wakes_that_island_only(responder: str) -> None:
    """The stack wakes before the ball touches it: whenever the ball has a contact with a stack body,
    they are one island (awake, or fallen asleep together at the end of that step); the other
    stack sleeps on, bit for bit where it was."""
    w, _, (stack, other) = two_stacks(phys2d.make_responder(responder))
    run_until_asleep(w)
    x_other = np.array([b.position for b in other])
    ball = w.add_circle((0.0, 7.0), radius=0.3, density=5.0)
    stack_rows = {b.index for b in stack}
    woken_at = None
    for step in range(150):
        w.step(DT)
        c = w.contacts
        for a, b in zip(c.body_a.tolist(), c.body_b.tolist(), strict=True):
            if ball.index in (a, b) and {a, b} & stack_rows:  # they met in the step: one island since
                assert asleep(stack) == [not ball.awake] * len(stack)
        if woken_at is None and not any(asleep(stack)):
            woken_at = step
        assert all(asleep(other))
        assert np.array_equal(np.array([b.position for b in other]), x_other)
    assert woken_at is not None
    assert ball.position[1] > 4.0  # it came to rest on the stack, which woke and held it


@pytest.mark.parametrize(
    "wake",
    [
        lambda top, w: top.apply_impulse((0.5, 0.0)),
        lambda top, w: top.apply_force((0.0, 1.0)),
        lambda top, w: top.apply_torque(0.1),
        lambda top, w: setattr(top, "velocity", (0.1, 0.0)),
        lambda top, w: setattr(top, "angular_velocity", 0.1),
        lambda top, w: setattr(top, "awake", True),
        lambda top, w: w.add_distance_joint(top, w.bodies[0]),
        lambda top, w: w.remove(top),
    ],
    ids=["impulse", "force", "torque", "velocity", "angular_velocity", "awake", "joint", "removal"],
)
def test_each_disturbance_wakes_the_whole_island_and_moves_nothing(wake) -> None:
    """The stack's top box is disturbed: every box of its stack wakes (the island, not the body);
    the other stack sleeps on; no position changes by the waking itself."""
    w, _, (stack, other) = two_stacks()
    run_until_asleep(w)
    x = {b: b.position for b in w.bodies}
    wake(stack[-1], w)
    rest = [b for b in stack if b.alive]
    assert not any(asleep(rest))
    assert all(asleep(other))
    assert all(np.array_equal(b.position, x[b]) for b in w.bodies)


def test_a_joint_wakes_both_islands_it_joins() -> None:
    w, _, (stack, other) = two_stacks()
    run_until_asleep(w)
    w.add_distance_joint(stack[-1], other[-1])
    assert not any(asleep(stack + other))


@pytest.mark.parametrize("responder", ["pgs", "soft-step"])
def test_a_woken_island_warm_starts_from_the_impulses_it_fell_asleep_with(responder: str) -> None:
    """Box2D keeps a sleeping island's contact impulses: the step after waking finds the same
    contacts and warm starts every one of them from the cache it fell asleep with."""
    w, _, (stack, other) = two_stacks(phys2d.make_responder(responder))
    run_until_asleep(w)
    fell_asleep_with = set(w.contacts.key.tolist())
    for _ in range(30):
        w.step(DT)
        assert len(w.contacts) == 0
    stack[0].awake = True
    w.step(DT)
    c = w.contacts
    assert len(c) > 0 and c.warm_started.all()
    assert set(c.key.tolist()) <= fell_asleep_with


def test_a_kept_cache_larger_than_the_buffers_grows_them() -> None:
    """An island that slept while the buffers held fewer contacts than it and the awake bodies
    together: putting its cache back grows them, and every contact still warm starts."""
    w = phys2d.World(sleep=True)
    w.add_box((0.0, -0.5), half_extents=(40.0, 0.5), static=True)
    boxes = [w.add_box((2.0 * k - 30.0, 0.5), half_extents=(0.5, 0.5)) for k in range(30)]
    for _ in range(5):
        w.step(DT)
    pipeline = w._pipeline
    keys, lambda_n, lambda_t, pushed = pipeline.cache_of(np.sort(w.body_uids))
    far = (np.int64(1) << 22) << 39  # pairs of uids no body has: entries no contact will match
    extra = far + np.arange(4 * pipeline.buffers.pairs, dtype=np.int64)
    pipeline.warm(extra, np.ones(extra.size), np.zeros(extra.size), np.zeros(extra.size, np.bool_))
    assert pipeline.cached == keys.size + extra.size > 2 * 30
    w.step(DT)
    assert len(w.contacts) == keys.size and w.contacts.warm_started.all()
    assert all(b.position[1] == pytest.approx(0.5, abs=0.01) for b in boxes)


@pytest.mark.parametrize("responder", ["pgs", "pgs-block", "pgs-matrix", "soft-step"])
def test_a_sleeping_chain_of_joints_stays_put(responder: str) -> None:
    """A damped chain hanging from a static anchor sleeps as one island; its joint rows then join
    bodies of M^-1 = 0 (A_kk = 0), which every responder that takes joints leaves alone: nothing
    moves, nothing turns NaN, and an impulse wakes the whole chain."""
    w = phys2d.World(sleep=True, responder=phys2d.make_responder(responder))
    anchor = w.add_box((0.0, 5.0), half_extents=(0.2, 0.2), static=True)
    links, previous = [], anchor
    for k in range(4):
        link = w.add_circle((0.0, 4.5 - 0.5 * k), radius=0.1, linear_damping=2.0, angular_damping=2.0)
        w.add_pin_joint(previous, link, anchor=(0.0, 4.75 - 0.5 * k))
        links.append(link)
        previous = link
    run_until_asleep(w, steps=600)
    x = w.x.copy()
    for _ in range(60):
        w.step(DT)
    assert np.array_equal(w.x, x) and np.all(np.isfinite(w.V)) and not np.any(w.V)
    links[-1].apply_impulse((0.1, 0.0))
    assert not any(asleep(links))
    w.step(DT)
    assert np.all(np.isfinite(w.x)) and links[0].velocity[0] != 0.0  # the joints pull the chain along


def test_a_velocity_of_zero_and_settings_do_not_wake() -> None:
    """As Box2D: setting a zero velocity, friction or damping leaves the island asleep."""
    w, _, (stack, other) = two_stacks()
    run_until_asleep(w)
    top = stack[-1]
    top.velocity = (0.0, 0.0)
    top.angular_velocity = 0.0
    top.friction = 0.2
    top.linear_damping = 1.0
    assert all(asleep(stack + other))


def test_removing_the_ground_wakes_every_island_on_it_and_they_fall() -> None:
    w, ground, (stack, other) = two_stacks()
    run_until_asleep(w)
    y = [b.position[1] for b in stack + other]
    w.remove(ground)
    assert not any(asleep(stack + other))
    for _ in range(30):
        w.step(DT)
    assert all(b.position[1] < y0 - 1.0 for b, y0 in zip(stack + other, y, strict=True))  # 1/2 g t^2 = 1.25 m


def test_awake_false_puts_the_island_to_sleep_now() -> None:
    """Box2D's b2Body_SetAwake(false): the body's island sleeps at once, velocities 0, here even in
    the air and with sleep off; it falls when woken."""
    w = phys2d.World()
    a = w.add_box((0.0, 5.0), half_extents=(0.5, 0.5), velocity=(1.0, 2.0))
    b = w.add_box((3.0, 5.0), half_extents=(0.5, 0.5))
    w.add_pin_joint(a, b, anchor=(1.5, 5.0))
    loner = w.add_circle((9.0, 5.0), radius=0.5)
    w.step(DT)
    a.awake = False
    assert asleep([a, b, loner]) == [True, True, False]
    assert a.velocity.tolist() == [0.0, 0.0]
    x = w.x.copy()
    for _ in range(30):
        w.step(DT)
    assert np.array_equal(w.x[:2], x[:2]) and loner.position[1] < 5.0 - 1.0
    b.awake = True
    assert not any(asleep([a, b]))
    w.step(DT)
    assert a.position[1] < x[0, 1]


def test_static_and_kinematic_bodies_are_never_asleep() -> None:
    w = phys2d.World(sleep=True)
    ground = w.add_box((0.0, -0.5), half_extents=(5.0, 0.5), static=True)
    lift = w.add_box((0.0, 3.0), half_extents=(0.5, 0.1), kinematic=True)
    assert not ground.awake and lift.awake  # (Box2D: a static body is not awake)
    ground.awake = True
    lift.awake = False
    assert not ground.awake and lift.awake
    with pytest.raises(TypeError, match="awake must be True or False"):
        lift.awake = 1
    with pytest.raises(TypeError, match="sleep must be True or False"):
        w.sleep = "yes"
    with pytest.raises(TypeError, match="sleep must be True or False"):
        phys2d.World(sleep=None)
    assert w.sleep is True


def test_a_moving_kinematic_body_keeps_what_it_carries_awake() -> None:
    """A box riding a kinematic platform that moves at 0.5 m/s never rests, so never sleeps; once
    the platform stops, the box rests and sleeps."""
    w = phys2d.World(sleep=True)
    lift = w.add_box((0.0, 0.0), half_extents=(3.0, 0.1), kinematic=True, velocity=(0.5, 0.0))
    box = w.add_box((0.0, 0.6), half_extents=(0.5, 0.5))
    for _ in range(180):
        w.step(DT)
        assert box.awake
    lift.velocity = (0.0, 0.0)
    run_until_asleep(w)


def test_a_kinematic_body_that_starts_moving_wakes_what_hangs_from_it() -> None:
    """A load on a rope from a resting kinematic crane sleeps; given a velocity, the crane wakes
    it (the joint pulls it along) though their boxes are 2 m apart."""
    w = phys2d.World(sleep=True)
    crane = w.add_box((0.0, 5.0), half_extents=(0.5, 0.1), kinematic=True)
    load = w.add_circle((0.0, 3.0), radius=0.2, linear_damping=1.0)
    w.add_distance_joint(crane, load)
    run_until_asleep(w)
    crane.velocity = (1.0, 0.0)
    w.step(DT)
    assert load.awake
    for _ in range(60):
        w.step(DT)
    assert load.awake and load.position[0] > 0.3


def test_a_body_the_filter_keeps_apart_passes_through_a_sleeping_one_without_waking_it() -> None:
    w = phys2d.World(sleep=True, gravity=(0.0, 0.0))
    sleeper = w.add_box((0.0, 0.0), half_extents=(0.5, 0.5))
    sleeper.awake = False
    ghost = w.add_circle((-3.0, 0.0), radius=0.2, velocity=(3.0, 0.0), mask=0)
    solid = w.add_circle((-3.0, 3.0), radius=0.2, velocity=(0.0, 0.0))
    for _ in range(120):
        w.step(DT)
    assert ghost.position[0] > 2.0 and not sleeper.awake
    solid.position = (-3.0, 0.0)
    solid.velocity = (3.0, 0.0)
    for _ in range(60):
        w.step(DT)
    assert sleeper.awake and sleeper.velocity[0] > 0.0  # the solid one hit it


# -- properties ----------------------------------------------------------------------------------


@given(
    scene=resting_scenes(),
    actions=st.lists(
        st.one_of(
            st.tuples(st.just("step"), st.integers(1, 40)),
            st.tuples(st.just("impulse"), st.integers(0, 20), vectors(-2.0, 2.0)),
            st.tuples(st.just("awake"), st.integers(0, 20), st.booleans()),
        ),
        min_size=1,
        max_size=8,
    ),
)
def test_an_asleep_body_never_moves_and_waking_moves_nothing(scene, actions) -> None:
    """Over steps, impulses and awake set by hand: a body asleep before and after a step has not
    moved by a bit and has V = 0; no waking or putting to sleep changes a position; touching
    dynamic bodies are asleep together or awake together."""
    w = build(scene)
    w.sleep = True
    dynamic = [b for b in w.bodies if not b.static]
    for action in [("step", 40)] + list(actions):
        if action[0] == "step":
            for _ in range(action[1]):
                before = w.body_asleep.copy(), w.x.copy(), w.theta.copy()
                w.step(DT)
                both = before[0] & w.body_asleep
                assert np.array_equal(w.x[both], before[1][both]) and np.array_equal(w.theta[both], before[2][both])
                assert not np.any(w.V[w.body_asleep])
                c = w.contacts
                for a, b, s in zip(c.body_a, c.body_b, c.separation, strict=True):
                    if s <= w.contact_margin and not (w.body_static[a] or w.body_static[b]):
                        assert w.body_asleep[a] == w.body_asleep[b]
            continue
        if not dynamic:
            continue
        body = dynamic[action[1] % len(dynamic)]
        x, theta = w.x.copy(), w.theta.copy()
        if action[0] == "impulse":
            body.apply_impulse(action[2])
            assert body.awake
        else:
            body.awake = action[2]
            assert body.awake == action[2]
        assert np.array_equal(w.x, x) and np.array_equal(w.theta, theta)
        assert not np.any(w.V[w.body_asleep])


@given(scene=scenes(), steps=st.integers(1, 90), gravity=vectors(-10.0, 10.0))
def test_sleep_on_is_bit_identical_to_sleep_off_until_an_island_sleeps(scene, steps, gravity) -> None:
    """Nothing asleep, nothing different: the same scene with sleep on and off gives bit-identical
    worlds step for step until the first island falls asleep (and with sleep off none ever does)."""
    on, off = build(scene), build(scene)
    on.sleep = True
    on.gravity = off.gravity = gravity
    for _ in range(steps):
        on.step(DT)
        off.step(DT)
        assert not off.body_asleep.any()
        if on.body_asleep.any():
            break
        rested = on._bodies.sleep_time.copy()  # the one thing sleep adds: how long each body rested
        on._bodies.sleep_time[:] = 0.0
        assert fingerprint(on) == fingerprint(off)
        on._bodies.sleep_time[:] = rested


@given(gaps=st.lists(reals(0.0, 0.015), min_size=1, max_size=5))
def test_find_islands_joins_what_touches(gaps) -> None:
    """A row of boxes, neighbours 0 to 15 mm apart (within the contact margin: touching), is one
    island; a ground under them joins none."""
    links = np.array([(k, k + 1) for k in range(len(gaps))] + [(k, len(gaps) + 1) for k in range(len(gaps) + 1)])
    dynamic = np.array([True] * (len(gaps) + 1) + [False])
    island = sleeping.find_islands(links, dynamic)
    assert island.tolist() == [0] * (len(gaps) + 1) + [-1]


# -- recordings ----------------------------------------------------------------------------------


def test_recordings_draw_sleeping_bodies_dimmed(tmp_path) -> None:
    """The bodies' class ids change to the asleep classes on the tick the island falls asleep, and
    back when it wakes."""
    w = phys2d.World(sleep=True)
    w.add_box((0.0, -0.5), half_extents=(5.0, 0.5), static=True)
    box = w.add_box((0.0, 0.5), half_extents=(0.5, 0.5))
    ball = w.add_circle((1.0, 0.5), radius=0.5)  # touching the box: one island
    path = tmp_path / "sleep.rrd"
    slept = woke = None
    with phys2d.Recorder(path) as rec:
        for _ in range(80):
            w.step(DT)
            rec.log(w)
            if slept is None and not box.awake:
                slept = w.tick
                assert not ball.awake  # asleep with the box
        box.apply_impulse((0.0, 1.0))
        w.step(DT)
        rec.log(w)
        woke = w.tick
    assert slept is not None and ball.awake
    rows = []
    for ch in (
        RrdReader(str(path)).store().stream().filter(content="/world/sim/bodies", components="LineStrips2D:class_ids")
    ):
        rb = ch.to_record_batch()
        rows += [
            (t, c)
            for t, c in zip(rb.column("tick").to_pylist(), rb.column("LineStrips2D:class_ids").to_pylist(), strict=True)
            if c is not None
        ]
    rows.sort()
    body, circle = schema.CLASS_BODY, schema.CLASS_CIRCLE
    assert rows == [
        (1, [body, circle]),
        (slept, [schema.CLASS_ASLEEP_BODY, schema.CLASS_ASLEEP_CIRCLE]),
        (woke, [body, circle]),
    ]
