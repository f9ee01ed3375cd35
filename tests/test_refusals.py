"""No step lost, no state poisoned: a failed or refused step leaves the world exactly as it was,
its message names the cause and the way on, and a step after the way on is taken goes on as
if nothing had happened (the twin world that never saw the fault is the second method).

The fingerprint (``phys2d.testing.strategies.fingerprint``) holds every array of the world, its
contacts, cache, manifolds and joints: equal fingerprints are bit-identical worlds."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import phys2d
from phys2d.shapes import MAX_SIZE, MIN_SIZE
from tests.strategies import fingerprint

DT = 1 / 60


def box_on_ground(responder: phys2d.Responder | None = None, **world) -> tuple[phys2d.World, phys2d.Body]:
    w = phys2d.World(responder=responder, **world)
    w.add_box((0.0, -0.5), half_extents=(10.0, 0.5), static=True)
    return w, w.add_box((0.0, 0.6), half_extents=(0.5, 0.5))


def settled(responder: phys2d.Responder | None = None, steps: int = 30, **world) -> tuple[phys2d.World, phys2d.Body]:
    """A box resting on the ground after ``steps``: contacts, a warm cache, a clock."""
    w, b = box_on_ground(responder, **world)
    for _ in range(steps):
        w.step(DT)
    return w, b


def state(w: phys2d.World) -> bytes:
    return w.x.tobytes() + w.theta.tobytes() + w.V.tobytes()


# -- threads switched at any step ----------------------------------------------------

SWITCHING = {
    "pgs": phys2d.PGS,
    "soft-step": phys2d.SoftStep,
    "pgs-block": lambda: phys2d.PGS(block=True),
    "pgs-matrix": lambda: phys2d.PGS(form="matrix"),
    "iterative": lambda: phys2d.IterativeImpulse(passes=4),
}


def pile(responder: phys2d.Responder, threads: int, sleep: bool) -> phys2d.World:
    w = phys2d.World(responder=responder, threads=threads, sleep=sleep)
    w.add_box((0.0, -0.5), half_extents=(10.0, 0.5), static=True)
    for k in range(4):
        w.add_box((0.1 * k, 0.6 + 1.05 * k), half_extents=(0.5, 0.5))
    w.add_circle((2.0, 0.5), radius=0.4)
    return w


@pytest.mark.xdist_group("threads_switched")  # one worker: each threaded tick compiles once
@pytest.mark.parametrize("name", list(SWITCHING))
def test_switching_threads_after_a_step_loses_none(name):
    """The probe's case: 60 steps on two threads, then one: the step is taken (no TypeError, no
    position put back), bit-identical to a world that ran on one thread throughout."""
    w, twin = pile(SWITCHING[name](), 2, False), pile(SWITCHING[name](), 1, False)
    for _ in range(60):
        w.step(DT)
        twin.step(DT)
    w.threads = 1
    w.step(DT)
    twin.step(DT)
    assert w.tick == twin.tick == 61
    assert state(w) == state(twin)


@pytest.mark.xdist_group("threads_switched")  # one worker: each threaded tick compiles once
@settings(max_examples=12)
@given(
    name=st.sampled_from(list(SWITCHING)),
    counts=st.lists(st.sampled_from([1, 2]), min_size=1, max_size=6),
    every=st.integers(1, 9),
    sleep=st.booleans(),
)
def test_threads_switched_any_number_of_times_change_no_bit(name, counts, every, sleep):
    """Threads switched at any step, any number of times, on every responder, with and without
    sleep: bit-identical to the world that never switched (threads give the same bits)."""
    w, twin = pile(SWITCHING[name](), 1, sleep), pile(SWITCHING[name](), 1, sleep)
    for threads in counts:
        w.threads = threads
        for _ in range(every):
            w.step(DT)
            twin.step(DT)
    assert state(w) == state(twin)
    assert w.contacts.lambda_n.tobytes() == twin.contacts.lambda_n.tobytes()


# -- a responder that leaves NaN --------------------------------------------------------


class NaNImpulses(phys2d.Responder):
    """Leaves every lambda NaN (and V as it was)."""

    name, counts, warm_start = "nan-impulses", "sweeps", True

    def respond(self, ctx):
        ctx.rows.lam[:] = np.nan
        return phys2d.SolveResult(1, np.zeros(1))


class NaNVelocity(phys2d.Responder):
    name, counts = "nan-velocity", "sweeps"

    def respond(self, ctx):
        ctx.V[-1, 0] = np.nan
        return phys2d.SolveResult(1, np.zeros(1))


@pytest.mark.parametrize("bad", [NaNImpulses, NaNVelocity])
@pytest.mark.parametrize("after", ["pgs", "soft-step"])
def test_non_finite_impulses_are_refused_and_poison_no_cache(bad, after):
    """A responder leaving NaN impulses or velocities: SimulationError naming it; the world and
    its cache as before, so the next step of PGS or the soft step equals the twin's that never
    met the bad responder (the probe saw every later step refused)."""
    make = phys2d.PGS if after == "pgs" else phys2d.SoftStep
    w, _ = settled(make())
    twin, _ = settled(make())
    before = fingerprint(w)
    w.responder = bad()
    with pytest.raises(phys2d.SimulationError, match=bad.name):
        w.step(DT)
    w.responder = make()  # (a responder of the same settings: the same repr in the fingerprint)
    assert fingerprint(w) == before
    assert state(w) == state(twin)
    assert w.contacts.lambda_n.tobytes() == twin.contacts.lambda_n.tobytes()
    for _ in range(3):
        w.step(DT)
        twin.step(DT)
    assert state(w) == state(twin)
    assert np.all(np.isfinite(w.contacts.lambda_n))


def test_solve_result_checks_its_arguments():
    for iterations, residuals, kind in [
        (-5, [], ValueError),
        ("x", [], TypeError),
        (True, [0.0], TypeError),
        (1, None, TypeError),
        (1, "abc", TypeError),
        (1, [[0.1]], TypeError),
        (1, [math.nan], ValueError),
        (1, [math.inf], ValueError),
    ]:
        with pytest.raises(kind, match="SolveResult"):
            phys2d.SolveResult(iterations, residuals)
    r = phys2d.SolveResult(np.int64(2), [1, 0.5])
    assert r.iterations == 2 and r.residuals.dtype == np.float64


# -- pending forces and gravity past the limits ------------------------------------


def pushed(kind: str) -> tuple[phys2d.World, phys2d.Body, str]:
    """A settled world given one of the probe's absurd pushes, and what the message must name."""
    w, b = settled()
    if kind == "force":
        b.apply_force((1e30, 0.0))
        return w, b, "pending force"
    if kind == "torque":
        b.apply_torque(1e30)
        return w, b, "torque"
    if kind == "gravity_scale":
        b.gravity_scale = 1e30
        return w, b, "gravity_scale"
    w.gravity = (0.0, -1e30)
    return w, b, "w.gravity"


@pytest.mark.parametrize("kind", ["force", "torque", "gravity_scale", "gravity"])
def test_a_refused_step_keeps_the_world_and_names_the_push(kind):
    w, b, cause = pushed(kind)
    before = fingerprint(w)
    for _ in range(2):  # refused every time while the push is there, the world unchanged each time
        with pytest.raises(phys2d.SimulationError) as info:
            w.step(DT)
        assert cause in str(info.value) and f"body {b.index}" in str(info.value)
        assert fingerprint(w) == before
    if kind in ("force", "torque"):
        assert "clear_forces" in str(info.value)
        (b.clear_forces if kind == "force" else w.clear_forces)()
    elif kind == "gravity_scale":
        b.gravity_scale = 1.0
    else:
        w.gravity = (0.0, -10.0)
    twin, _ = settled()
    w.step(DT)  # the way on: the world goes on as if the push had never been
    twin.step(DT)
    assert state(w) == state(twin)


# -- arrays written between steps --------------------------------------------------


def written(kind: str) -> tuple[phys2d.World, str]:
    w, b = settled()
    i = b.index
    if kind == "nan-x":
        w.x[i, 0] = np.nan
        return w, f"w.x[{i}]"
    if kind == "inf-V":
        w.V[i, 2] = np.inf
        return w, f"w.V[{i}]"
    if kind == "nan-theta":
        w.theta[i] = np.nan
        return w, f"w.theta[{i}]"
    if kind == "static-M_inv":
        w.M_inv[0] = (1.0, 1.0, 1.0)
        return w, "w.M_inv[0]"
    w.M_inv[i] = (-1.0, -1.0, -1.0)
    return w, f"w.M_inv[{i}]"


@pytest.mark.parametrize("kind", ["nan-x", "inf-V", "nan-theta", "static-M_inv", "negative-M_inv"])
@pytest.mark.parametrize("one_call", [True, False])
def test_arrays_written_wrong_are_refused_naming_body_and_array(kind, one_call):
    """NaN or inf in w.x, w.theta, w.V, M^-1 > 0 on the static ground, a negative M^-1: the next
    step refuses (ValueError naming the array and the body), steps nothing, and the tick stays."""
    w, name = written(kind)
    w.one_call_tick = one_call
    before = fingerprint(w)
    with pytest.raises(ValueError) as info:
        w.step(DT)
    assert name in str(info.value) and "body" in str(info.value)
    assert fingerprint(w) == before and w.tick == 30


def test_a_static_body_given_mass_by_hand_no_longer_falls():
    """The probe's case: M^-1 = 1 on the static ground let it fall 5 m in 60 steps."""
    w, _ = settled()
    w.M_inv[0] = (1.0, 1.0, 1.0)
    with pytest.raises(ValueError, match="static"):
        w.step(DT)
    w.M_inv[0] = 0.0
    w.step(DT)
    assert w.x[0].tolist() == [0.0, -0.5]


# -- fixed rotation --------------------------------------------------------------------


def test_fixed_rotation_never_turns_and_keeps_its_inertia():
    """A box dropped on its corner and given a torque: with fixed_rotation its angle and omega
    stay exactly 0 (the 1/I of M^-1 is 0), its inertia is its shape's, m (a^2 + b^2) / 12."""
    w = phys2d.World()
    w.add_box((0.0, -0.5), half_extents=(10.0, 0.5), static=True)
    free = w.add_box((-3.0, 1.5), half_extents=(0.5, 0.25), angle=0.3)
    locked = w.add_box((3.0, 1.5), half_extents=(0.5, 0.25), angle=0.3, fixed_rotation=True)
    locked.apply_torque(50.0)
    for _ in range(90):
        w.step(DT)
    assert locked.angle == 0.3 and locked.angular_velocity == 0.0
    assert free.angle != pytest.approx(0.3, abs=0.05)  # the same drop turns a free box onto its face
    assert locked.inertia == pytest.approx(locked.mass * (1.0**2 + 0.5**2) / 12.0)
    assert w.M_inv[locked.index, 2] == 0.0 and locked.fixed_rotation
    with pytest.raises(ValueError, match="angular_velocity"):
        locked.angular_velocity = 1.0
    with pytest.raises(ValueError, match="angular_velocity"):
        w.add_box((6.0, 1.0), fixed_rotation=True, angular_velocity=2.0)
    locked.fixed_rotation = False  # its 1/I back
    assert w.M_inv[locked.index, 2] == pytest.approx(1.0 / locked.inertia)


# -- sizes and densities ---------------------------------------------------------------


@pytest.mark.parametrize(
    ("call", "name"),
    [
        (lambda w: w.add_capsule(half_length=1e30, radius=0.5), "half_length"),
        (lambda w: w.add_capsule(half_length=1.0, radius=1e30), "radius"),
        (lambda w: w.add_capsule(half_length=1.0, radius=1e-8), "radius"),
        (lambda w: w.add_circle(radius=1e-200), "radius"),
        (lambda w: w.add_circle(radius=1e-8), "radius"),
        (lambda w: w.add_circle(radius=2 * MAX_SIZE), "radius"),
        (lambda w: w.add_box(half_extents=(0.5 * MIN_SIZE, 1.0)), "half_extents"),
        (lambda w: w.add_box(density=1e308), "density"),
        (lambda w: w.add_box(density=1e-9), "density"),
        (lambda w: w.add_polygon(vertices=[(0, 0), (3e5, 0), (0, 3e5)]), "vertices"),
        (lambda w: w.add_segment((0, 0), (1, 0), radius=1e-6), "radius"),
        (lambda w: w.add_segment((-2e5, 0), (2e5, 0)), "segment"),
    ],
)
def test_sizes_and_densities_outside_their_range_are_refused(call, name):
    """Outside [1 mm, 100 km] and [1e-6, 1e6] kg/m^2: ValueError with the name and the range."""
    w, _ = settled()
    before = fingerprint(w)
    with pytest.raises(ValueError, match=name) as info:
        call(w)
    assert "m" in str(info.value) and fingerprint(w) == before


def test_the_ends_of_the_ranges_are_taken():
    w = phys2d.World()
    w.add_circle(radius=MIN_SIZE)
    w.add_box((5.0, 0.0), half_extents=(MAX_SIZE, 1.0), static=True)
    w.add_box((0.0, 9.0), density=1e-6)
    w.add_box((3.0, 9.0), density=1e6)
    w.add_capsule((0.0, 20.0), half_length=1.0, radius=MIN_SIZE)
    w.step(DT)
    assert np.all(np.isfinite(w.V))


# -- joints ------------------------------------------------------------------------------


def test_joining_two_kinematic_bodies_says_kinematic():
    w = phys2d.World()
    a, b = w.add_box(kinematic=True), w.add_box((3.0, 0.0), kinematic=True)
    with pytest.raises(ValueError, match="both kinematic"):
        w.add_distance_joint(a, b)
    s = w.add_box((6.0, 0.0), static=True)
    with pytest.raises(ValueError, match="static and kinematic"):
        w.add_pin_joint(a, s, anchor=(4.0, 0.0))
