"""The one-call tick (phys2d.pipeline.tick.tick) against the staged step: a second method of the same pipeline.

``World.step`` runs PGS (impulse form) and SoftStep in one kernel call; with
``one_call_tick = False`` it calls ``before_solve`` and ``after_solve`` from Python around the
responder's ``respond``. Both paths run the same stage kernels in the same order, so every state,
contact, cache and report must agree bit for bit, and a failed step must leave either world as it was.
"""

from __future__ import annotations

import copy

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numba import config

import phys2d
from phys2d import scenes
from phys2d.pipeline import step as step_module
from phys2d.pipeline.context import solver_of
from phys2d.pipeline.step import compiled_for
from phys2d.pipeline.tick import tick
from tests.strategies import build, dts, fingerprint, responders, violent_scenes

RESPONDERS = {
    "pgs": lambda: phys2d.PGS(),
    "pgs-block": lambda: phys2d.PGS(block=True),
    "pgs-lecture-friction": lambda: phys2d.PGS(friction="lecture"),
    "pgs-cold-unsplit": lambda: phys2d.PGS(warm_start=False, split=False),
    "pgs-tolerance": lambda: phys2d.PGS(tolerance=1e-3, iterations=30),
    "soft-step": lambda: phys2d.SoftStep(),
    "soft-step-plain": lambda: phys2d.SoftStep(substeps=2, relax=False, block=False, direct_joints=False),
}

SCENES = {
    "pyramid": lambda r: scenes.pyramid(6, responder=r),
    "leaning-stack": lambda r: scenes.vertical_stack(8, responder=r, lean=0.01),
    "mass-ratio": lambda r: scenes.mass_ratio(100.0, responder=r),
    "mixed-shapes": lambda r: scenes.mixed_shapes(8, responder=r),
    "dominoes": lambda r: scenes.dominoes(6, responder=r),
    "pendulum-chain": lambda r: scenes.pendulum_chain(5, responder=r),
}


def twins(make_world, make_responder):
    """The same world twice: stepped in one call, and stage by stage."""
    one, staged = make_world(make_responder()), make_world(make_responder())
    staged.one_call_tick = False
    return one, staged


@pytest.mark.parametrize("responder", RESPONDERS)
@pytest.mark.parametrize("scene", SCENES)
def test_one_call_tick_is_the_staged_step(scene, responder):
    one, staged = twins(SCENES[scene], RESPONDERS[responder])
    assert solver_of(one.responder) is not None  # the path under test is taken
    touched = 0
    for _ in range(90):
        a, b = one.step(1 / 60), staged.step(1 / 60)
        touched = max(touched, a.contact_count)
        assert a.count == b.count and a.cache_hits == b.cache_hits and a.max_penetration == b.max_penetration
        assert np.array_equal(a.solve_order, b.solve_order) and np.array_equal(a.joint_impulses, b.joint_impulses)
    assert fingerprint(one) == fingerprint(staged)
    assert touched > 0 or scene == "pendulum-chain"  # the contact stages ran


@settings(max_examples=40, deadline=None)
@given(scene=violent_scenes(), responder=responders(), dt=dts, steps=st.integers(1, 25))
def test_one_call_tick_is_the_staged_step_on_violent_scenes(scene, responder, dt, steps):
    """Fast, spinning, overlapping bodies: sweeps, new and lost manifolds, undone steps."""
    one, staged = build(scene, copy.deepcopy(responder)), build(scene, copy.deepcopy(responder))
    staged.one_call_tick = False
    for _ in range(steps):
        failed = []
        for w in (one, staged):
            before = fingerprint(w)
            try:
                w.step(dt)
                failed.append(False)
            except phys2d.SimulationError:
                assert fingerprint(w) == before  # undone, bit for bit
                failed.append(True)
        assert failed[0] == failed[1]
        assert fingerprint(one) == fingerprint(staged)


def test_a_failed_one_call_step_keeps_the_last_steps_contacts_and_caches():
    """The kernel writes the buffer set the last good step did not: a step that raises leaves
    that step's contacts (read lazily, after the failure) and caches as they were."""
    w = scenes.vertical_stack(4)
    for _ in range(30):
        w.step(1 / 60)
    staged = scenes.vertical_stack(4)
    staged.one_call_tick = False
    for _ in range(30):
        staged.step(1 / 60)
    w.bodies[-1].velocity = (0.0, 50.0)
    staged.bodies[-1].velocity = (0.0, 50.0)
    w.max_speed = staged.max_speed = 20.0
    for x in (w, staged):
        with pytest.raises(phys2d.SimulationError, match="max_speed"):
            x.step(1 / 60)
    assert fingerprint(w) == fingerprint(staged)
    assert len(w.contacts) == 8  # the last good step's: four resting pairs (ground and 4 boxes), two points each
    w.max_speed = staged.max_speed = 1e4
    w.step(1 / 60)
    staged.step(1 / 60)
    assert fingerprint(w) == fingerprint(staged)


def test_contacts_handed_out_are_not_the_tick_buffers():
    """A Contacts kept by the user does not change when the world steps on."""
    w = scenes.vertical_stack(3)
    w.step(1 / 60)
    kept = w.contacts
    copied = {name: getattr(kept, name).copy() for name in kept.__dataclass_fields__}
    report = w.last_step
    order = report.solve_order.copy()
    for _ in range(5):
        w.bodies[-1].velocity = (1.0, 0.0)
        w.step(1 / 60)
    for name, values in copied.items():
        assert np.array_equal(getattr(kept, name), values)
    assert np.array_equal(report.solve_order, order)
    with pytest.raises(ValueError):
        kept.lambda_n[0] = 1.0  # read-only, as the staged step's


def test_a_setting_changed_between_steps_is_read_by_the_next_tick():
    """The world keeps the responder's tick settings until one of them is set."""
    one, staged = twins(lambda r: scenes.pyramid(4, responder=r), lambda: phys2d.PGS())
    for w in (one, staged):
        w.step(1 / 60)
        w.responder.iterations = 3
        w.responder.block = True
        w.step(1 / 60)
    assert one.last_step.count == 3 and one.last_step.responder == "pgs-block"
    assert fingerprint(one) == fingerprint(staged)


def test_switching_between_one_call_and_staged_steps_keeps_the_caches():
    """Steps of either kind continue each other: recycling and warm starts carry over."""
    one, staged = twins(lambda r: scenes.pyramid(5, responder=r), lambda: phys2d.SoftStep())
    for i in range(40):
        one.one_call_tick = i % 3 != 0
        one.step(1 / 60)
        staged.step(1 / 60)
        assert one.last_step.cache_hits == staged.last_step.cache_hits
    assert fingerprint(one) == fingerprint(staged)


def test_responders_without_a_one_call_tick_run_in_stages():
    assert solver_of(phys2d.PGS(form="matrix")) is None
    assert solver_of(phys2d.NaiveImpulse()) is None

    class Logged(phys2d.PGS):
        def respond(self, ctx):
            self.seen = ctx.n_contacts
            return super().respond(ctx)

    w = scenes.vertical_stack(3, responder=Logged())
    w.step(1 / 60)
    assert w.responder.seen == len(w.contacts) > 0  # its own respond ran


@pytest.mark.parametrize("how", ["deepcopy", "pickle"])
def test_a_copied_world_steps_on_as_the_original(how):
    """A World copied mid-run (the one-call tick's buffers and kept views with it) goes on
    bit for bit as the original, in one call and in stages."""
    import pickle

    w = scenes.pyramid(5, responder=phys2d.SoftStep())
    for _ in range(20):
        w.step(1 / 60)
    twin = copy.deepcopy(w) if how == "deepcopy" else pickle.loads(pickle.dumps(w))
    for i in range(20):
        for x in (w, twin):
            x.one_call_tick = i % 5 != 4
            x.step(1 / 60)
        assert fingerprint(w) == fingerprint(twin)


def test_later_steps_call_the_compiled_tick_without_dispatch():
    """From the second step the world calls the tick's machine code for its argument types
    directly (``compiled_for``): the twin tests above then compare that path with the staged one."""
    w = scenes.pyramid(3)
    assert solver_of(w.responder) is not None
    w.step(1 / 60)
    (kernel,) = w._pipeline._machine.values()
    if config.DISABLE_JIT:
        assert kernel is tick
    else:
        assert any(kernel is compiled.entry_point for compiled in tick.overloads.values())
    before = fingerprint(w)
    w.step(1 / 60)
    assert list(w._pipeline._machine.values()) == [kernel] and fingerprint(w) != before  # it ran, moved the pile


def test_the_compiled_tick_is_looked_up_once_though_the_broadphase_sweeps(monkeypatch):
    """A swinging chain leaves its fat boxes, and the world sweeps, step after step (and the bodies
    or joints changed before each: it sweeps whether or not they left them): the tick's compiled
    code is kept for the arguments' types (looking it up types every argument: ~0.3 ms a step)."""
    looked_up = []

    def counting(kernel, args):
        looked_up.append(kernel)
        return compiled_for(kernel, args)

    monkeypatch.setattr(step_module, "compiled_for", counting)
    w = scenes.heavy_chain(responder=phys2d.PGS())
    for _ in range(60):
        w._pipeline.sweep_again = True  # as when bodies or joints change
        w.step(1 / 60)
        assert not w._pipeline.sweep_again  # the tick swept
    assert len(looked_up) == 1


def test_the_tick_sweeps_for_the_pairs_itself_when_a_body_leaves_its_fat_box():
    """A swinging chain leaves its fat boxes nearly every step: the kernel sweeps (no call back
    to Python), and its pairs are those a brute-force test of every two fat boxes finds."""
    w = scenes.heavy_chain(responder=phys2d.SoftStep())
    pipeline, swept = w._pipeline, 0
    for _ in range(60):
        fat_before = pipeline.geometry[5].copy() if pipeline.geometry else None
        w.step(1 / 60)
        aabb, fat, static = pipeline.geometry[2], pipeline.geometry[5], w.body_static
        swept += fat_before is None or not np.array_equal(fat, fat_before)  # fat boxes anew: a sweep
        assert np.all(fat[:, :2] <= aabb[:, :2]) and np.all(fat[:, 2:] >= aabb[:, 2:])  # the pairs hold
        excluded = set(w._joints.excluded.tolist())
        want = [
            (a, b)
            for a in range(len(w))
            for b in range(a + 1, len(w))
            if not (static[a] and static[b])
            and ((a << 32) | b) not in excluded
            and fat[a, 0] <= fat[b, 2] and fat[b, 0] <= fat[a, 2] and fat[a, 1] <= fat[b, 3] and fat[b, 1] <= fat[a, 3]
        ]  # fmt: skip
        assert [tuple(p) for p in pipeline.pairs[: pipeline.n_pairs].tolist()] == want
    assert swept >= 30


def test_compiled_for_falls_back_to_the_dispatcher_for_types_it_has_no_code_for():
    args = ("not a tick state", 0.5)
    assert compiled_for(tick, args) is tick


def test_one_call_tick_takes_only_a_bool():
    w = scenes.vertical_stack(2)
    with pytest.raises(TypeError, match="one_call_tick must be True or False"):
        w.one_call_tick = 1
    assert w.one_call_tick is True
    w.one_call_tick = np.False_
    assert w.one_call_tick is False


def test_changes_between_steps_reach_the_one_call_tick():
    """Bodies added and removed, a joint added, the contact margin and gravity changed between
    steps: the one-call world keeps step with the staged one (its kept buffers and state are
    looked over again whenever one of these changes)."""
    one, staged = twins(lambda r: scenes.pyramid(4, responder=r), lambda: phys2d.PGS())
    for i in range(60):
        for w in (one, staged):
            if i == 10:
                w.add_box(position=(0.3, 6.0), half_extents=(0.4, 0.3), angle=0.2)
            if i == 20:
                w.remove(w.bodies[3])
            if i == 30:
                w.add_distance_joint(
                    w.bodies[1], w.bodies[2], anchor_a=w.bodies[1].position, anchor_b=w.bodies[2].position
                )
            if i == 40:
                w.contact_margin = 0.03
            if i == 50:
                w.gravity = (1.0, -9.0)
            w.step(1 / 60)
        assert fingerprint(one) == fingerprint(staged), i
