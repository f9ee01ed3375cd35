"""Settings checked alike in constructors and setters; arrays handed out cannot steer the world."""

from __future__ import annotations

import math

import numpy as np
import pytest

import phys2d
from tests.strategies import fingerprint

DT = 1 / 60


def refusal(call) -> tuple[type, str]:
    """The exception type and message ``call`` raises (it must raise one)."""
    with pytest.raises((ValueError, TypeError)) as info:
        call()
    return type(info.value), str(info.value)


# (a factory of a valid owner, the constructor as a function of one keyword, parameter, bad values)
WORLD = (phys2d.World, lambda **kw: phys2d.World(**kw))
OWNERS = {
    "World": WORLD,
    "PGS": (phys2d.PGS, lambda **kw: phys2d.PGS(**kw)),
    "SoftStep": (phys2d.SoftStep, lambda **kw: phys2d.SoftStep(**kw)),
    "IterativeImpulse": (phys2d.IterativeImpulse, lambda **kw: phys2d.IterativeImpulse(**kw)),
    "NaiveImpulse": (phys2d.NaiveImpulse, lambda **kw: phys2d.NaiveImpulse(**kw)),
}
NOT_A_NUMBER = ["x", None, True, [1.0]]
BAD = [
    ("World", "contact_margin", [-5.0, -1e-9, math.nan, math.inf] + NOT_A_NUMBER),
    ("World", "max_speed", [0.0, -1.0, math.inf, math.nan] + NOT_A_NUMBER),
    ("World", "contact_recycle_distance", [-0.01, math.inf, math.nan] + NOT_A_NUMBER),
    ("World", "gravity", [(math.nan, 0.0), (1.0, 2.0, 3.0), "ab", None]),
    ("PGS", "iterations", [0, -3, 100_001, 1.5, True, "10"]),
    ("PGS", "warm_start", [1, 0, "yes", None]),
    ("PGS", "beta", [-0.1, 1.5, math.nan] + NOT_A_NUMBER),
    ("PGS", "slop", [-1e-3, math.inf] + NOT_A_NUMBER),
    ("PGS", "tolerance", [-1.0, math.nan, "x", True]),
    ("PGS", "restitution_threshold", [-1.0, math.nan] + NOT_A_NUMBER),
    ("PGS", "push_max", [-1.0, math.inf] + NOT_A_NUMBER),
    ("PGS", "friction", ["Coulomb", "", None, 1]),
    ("PGS", "form", ["sparse", None, 0]),
    ("PGS", "block", [1, "no", None]),
    ("SoftStep", "substeps", [0, 2.0, False]),
    ("SoftStep", "relax", [1, None]),
    ("SoftStep", "contact_hertz", [-1.0, math.nan] + NOT_A_NUMBER),
    ("SoftStep", "damping_ratio", [-1.0, math.inf] + NOT_A_NUMBER),
    ("SoftStep", "push_max", [-1.0, math.nan] + NOT_A_NUMBER),
    ("SoftStep", "restitution_threshold", [-0.5] + NOT_A_NUMBER),
    ("SoftStep", "warm_start", [0, "x"]),
    ("SoftStep", "block", [0, "x"]),
    ("SoftStep", "joint_hertz", [-1.0, math.nan] + NOT_A_NUMBER),
    ("SoftStep", "joint_damping_ratio", [-1.0, math.inf] + NOT_A_NUMBER),
    ("SoftStep", "direct_joints", [1, None]),
    ("IterativeImpulse", "passes", [0, 2.5, True]),
    ("IterativeImpulse", "push_max", [-1.0, math.nan] + NOT_A_NUMBER),
    ("NaiveImpulse", "push_max", [-1.0, math.inf] + NOT_A_NUMBER),
]


@pytest.mark.parametrize("owner, name, values", BAD, ids=[f"{o}.{n}" for o, n, _ in BAD])
def test_a_setter_refuses_what_its_constructor_refuses_with_the_same_message(owner, name, values):
    make, construct = OWNERS[owner]
    for value in values:
        expected = refusal(lambda value=value: construct(**{name: value}))
        assert name in expected[1]
        obj = make()
        before = repr(obj), getattr(obj, name)
        if isinstance(obj, phys2d.World):
            before = fingerprint(obj)
        assert refusal(lambda obj=obj, value=value: setattr(obj, name, value)) == expected, (name, value)
        after = fingerprint(obj) if isinstance(obj, phys2d.World) else (repr(obj), getattr(obj, name))
        assert str(after) == str(before)  # nothing changed (str: NaN-free, arrays compared by value)


def test_settings_that_exclude_each_other_are_refused_either_way_round():
    message = refusal(lambda: phys2d.PGS(form="matrix", block=True))
    assert refusal(lambda: setattr(phys2d.PGS(form="matrix"), "block", True)) == message
    assert refusal(lambda: setattr(phys2d.PGS(block=True), "form", "matrix")) == message


def test_good_values_set_between_steps_take_effect():
    w = phys2d.scenes.vertical_stack(2)
    w.max_speed = 50.0
    w.contact_margin = 0.05
    assert w.max_speed == 50.0 and w.contact_margin == 0.05
    pgs = w.responder
    pgs.iterations, pgs.block, pgs.warm_start = 3, True, False
    assert pgs.name == "pgs-block-cold"
    w.step(DT)
    assert w.last_step.iterations == 3 and w.last_step.responder == "pgs-block-cold"
    w.max_speed = 1.0
    w.bodies[2].velocity = (0.0, 5.0)
    with pytest.raises(phys2d.SimulationError, match="max_speed=1"):
        w.step(DT)


# -- arrays handed out ---------------------------------------------------------------------


def scene(responder: phys2d.Responder) -> phys2d.World:
    """A stack, a bouncing ball, and (for PGS) a pendulum: contacts, caching and joint rows."""
    w = phys2d.scenes.vertical_stack(3, responder=responder)
    w.add_circle(position=(2.0, 1.0), radius=0.3, restitution=0.8, velocity=(0.0, -3.0))
    if responder.handles_joints:
        a = w.add_box(position=(5.0, 3.0), half_extents=(0.2, 0.2))
        b = w.add_box(position=(6.0, 3.0), half_extents=(0.2, 0.2))
        w.add_pin_joint(a, b, anchor=(5.5, 3.0))
        w.add_distance_joint(w.bodies[0], a, anchor_a=(5.0, 5.0), anchor_b=(5.0, 3.0))
    return w


def handed_out(w: phys2d.World) -> list[tuple[str, np.ndarray]]:
    """Every array reachable from w.contacts and w.last_step."""
    c, s = w.contacts, w.last_step
    out = [(f"contacts.{n}", getattr(c, n)) for n in c.__dataclass_fields__]
    out += [(f"last_step.{n}", getattr(s, n)) for n in ("residuals", "joint_impulses", "solve_order")]
    if s.system is not None:
        m = s.system
        out += [
            (f"system.{n}", getattr(m, n))
            for n in ("M_inv", "V1", "F_ext", "xi", "b", "lo", "hi", "bound_row", "mu", "lam")
        ]
        out += [
            (f"system.{m_name}.{n}", getattr(getattr(m, m_name), n))
            for m_name in ("J", "A")
            for n in ("indptr", "indices", "data")
        ]
    return out


def vandalise(a: np.ndarray) -> None:
    """Overwrite a with junk of its own type, forcing it writable first."""
    a.flags.writeable = True  # a user can always do this to an array that owns its memory
    if a.dtype == np.bool_:
        a[...] = ~a
    elif a.dtype.kind in "iu":
        a[...] = a[::-1] if a.ndim == 1 else 0
    else:
        a[...] = 7.5


@pytest.mark.parametrize(
    "responder",
    [phys2d.PGS(form="matrix"), phys2d.PGS(), phys2d.PGS(block=True), phys2d.SoftStep(), phys2d.IterativeImpulse()],
    ids=repr,
)
def test_editing_any_array_handed_out_leaves_the_next_step_bit_identical(responder):
    edited, untouched = scene(responder), scene(responder)
    for _ in range(20):
        edited.step(DT)
        untouched.step(DT)
        arrays = handed_out(edited)
        assert len(edited.contacts) > 0
        for name, a in arrays:
            assert not a.flags.writeable, f"{name} is writable"
            with pytest.raises(ValueError, match="read-only"):
                a[...] = 0
        for _, a in arrays:
            if a.size:
                vandalise(a)
    edited.step(DT)
    untouched.step(DT)
    assert fingerprint(edited) == fingerprint(untouched)


REPORTED = ("residuals", "solve_order", "joint_impulses")


@pytest.mark.parametrize(
    "make",
    [phys2d.PGS, lambda: phys2d.PGS(block=True), phys2d.SoftStep, phys2d.IterativeImpulse],
    ids=["pgs", "block", "soft", "iterative"],
)
def test_a_report_kept_across_steps_and_a_failed_step_keeps_what_its_step_did(make):
    """A report's arrays are those of its own step however long it is kept and whenever they are
    first read (the world lends it views of its buffers and copies them before it writes them
    again): against a twin world whose reports are read as soon as each step returns."""
    kept, twin = scene(make()), scene(make())
    reports, read_at_once = [], []
    for _ in range(8):
        reports.append(kept.step(DT))  # kept, not read
        r = twin.step(DT)
        read_at_once.append({n: getattr(r, n).copy() for n in REPORTED})
    assert read_at_once[-1]["residuals"].size > 0 and read_at_once[-1]["solve_order"].size > 0
    held, body = kept.last_step, kept.bodies[4]  # the ball, free
    velocity = body.velocity
    body.velocity = (2 * kept.max_speed, 0.0)  # the next step ends past max_speed: refused, undone
    with pytest.raises(phys2d.SimulationError):
        kept.step(DT)
    assert kept.last_step is held
    body.velocity = velocity
    for _ in range(3):  # the failed step wrote the other side of the buffers; these write both again
        kept.step(DT)
    for i, (report, expected) in enumerate(zip(reports, read_at_once, strict=True)):
        for n in REPORTED:
            np.testing.assert_array_equal(getattr(report, n), expected[n], err_msg=f"step {i}: {n}")
