"""Contacts only ever join live bodies, after any sequence of add, remove and step."""

from __future__ import annotations

import numpy as np
from hypothesis import given, note
from hypothesis import strategies as st

import phys2d
from tests.strategies import body_specs, dts

UID_BITS = 23  # a contact key is uid_a << 39 | uid_b << 16 | feature (phys2d.contacts)


def check_contacts(w: phys2d.World) -> None:
    """Every contact names two live bodies of w, by index and by the uids in its key."""
    c = w.contacts
    n = len(w)
    assert np.all((0 <= c.body_a) & (c.body_a < c.body_b) & (c.body_b < n))
    uid = np.array([b._uid for b in w.bodies], dtype=np.int64)
    if len(c):
        np.testing.assert_array_equal(c.key >> (16 + UID_BITS), uid[c.body_a])
        np.testing.assert_array_equal((c.key >> 16) & ((1 << UID_BITS) - 1), uid[c.body_b])
    assert w.last_step.contact_count == len(c)
    assert all(np.all(np.isfinite(getattr(c, f))) for f in ("separation", "normal_impulse", "point"))


operations = st.lists(
    st.one_of(
        st.tuples(st.just("add"), body_specs(static=None, region=1.5, max_speed=3.0)),
        st.tuples(st.just("remove"), st.integers(0, 10)),
        st.tuples(st.just("remove all"), st.none()),
        st.tuples(st.just("step"), dts),
    ),
    min_size=1,
    max_size=25,
)


@given(
    ops=operations,
    responder=st.sampled_from(["pgs", "pgs-block", "pgs-matrix", "soft-step", "naive"]),
    ground=st.booleans(),
)
def test_contacts_never_name_a_removed_body(ops, responder: str, ground: bool) -> None:
    """Random adds, removals (one body, or every body) and steps: after each step every
    contact joins two live bodies, its key holds their uids, and a world emptied of bodies
    reports no contact, ever after."""
    w = phys2d.World(responder=phys2d.make_responder(responder))
    if ground:
        phys2d.scenes.ground(w)
    for op, arg in ops:
        note(f"{op} {arg if op != 'add' else arg.kind}")
        if op == "add":
            arg.add_to(w)
        elif op == "remove" and len(w):
            w.remove(w.bodies[arg % len(w)])
        elif op == "remove all":
            for b in w.bodies:
                w.remove(b)
        elif op == "step":
            try:
                w.step(arg)
            except phys2d.SimulationError:
                continue
            check_contacts(w)
            if len(w) == 0:
                assert len(w.contacts) == 0 and w.last_step.contact_count == 0


def test_removing_every_body_leaves_no_phantom_pair() -> None:
    """The issue's case: a resting stack, every body removed between steps, then steps."""
    w = phys2d.scenes.vertical_stack(3)
    for _ in range(10):
        w.step(1 / 60)
    for b in w.bodies:
        w.remove(b)
    for _ in range(5):
        report = w.step(1 / 60)
        assert len(w.contacts) == 0 and report.contact_count == 0 and report.residuals.size in (0, 10)
    w.add_box(position=(0.0, 3.0))  # and a world emptied can be filled again
    w.step(1 / 60)
    check_contacts(w)
