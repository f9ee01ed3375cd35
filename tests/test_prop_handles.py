"""Body handles: materials set through a handle take effect, identity, and reprs."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

import phys2d
from tests.strategies import SceneSpec, build, dts, reals, responders, run, scenes


@given(scene=scenes(min_bodies=2, max_bodies=5, ground=True, static=None), data=st.data(), dt=dts)
def test_materials_set_on_a_handle_are_the_ones_contacts_mix(scene: SceneSpec, data, dt: float) -> None:
    """friction and restitution set through Body handles read back as set, and the next
    step's contacts mix exactly those: mu = sqrt(mu_a mu_b), e = max(e_a, e_b)."""
    w = build(scene)
    mu = data.draw(st.lists(reals(0.0, 2.0), min_size=len(w), max_size=len(w)))
    e = data.draw(st.lists(reals(0.0, 1.0), min_size=len(w), max_size=len(w)))
    for body, m, r in zip(w.bodies, mu, e):
        body.friction, body.restitution = m, r
        assert (body.friction, body.restitution) == (m, r)
    for _ in run(w, dt, 1):
        c = w.contacts
        mu_a, mu_b = np.array(mu)[c.body_a], np.array(mu)[c.body_b]
        np.testing.assert_allclose(c.friction, np.sqrt(mu_a.astype(np.longdouble) * mu_b).astype(float), rtol=1e-14)
        assert np.array_equal(c.restitution, np.maximum(np.array(e)[c.body_a], np.array(e)[c.body_b]))


@given(scene=scenes(min_bodies=2, max_bodies=5, ground=None, static=None), data=st.data())
def test_handles_are_equal_exactly_when_they_name_the_same_body(scene: SceneSpec, data) -> None:
    """A handle equals (and hashes like) itself and the handle w.bodies gives for its row,
    never another body's, nor the same row of an identical world; removal keeps identity."""
    w, twin = build(scene), build(scene)
    handles = w.bodies
    assert len(set(handles)) == len(handles)
    assert all(h.world is w for h in handles)
    assert not set(handles) & set(twin.bodies)
    assert all(a != b for a, b in zip(handles, twin.bodies))
    gone = data.draw(st.sampled_from(handles))
    w.remove(gone)
    for h in w.bodies:
        assert h in handles and w.bodies[h.index] == h and hash(w.bodies[h.index]) == hash(h)
    assert gone not in w.bodies and gone == gone


@given(
    scene=scenes(max_bodies=5, ground=None, static=None),
    responder=responders(),
    dt=dts,
    steps=st.integers(0, 5),
    data=st.data(),
)
def test_every_repr_works_in_every_state(
    scene: SceneSpec, responder: phys2d.Responder, dt: float, steps: int, data
) -> None:
    """repr() of the world, its bodies (alive or removed), contacts, step report and
    responder never fails and says what it is."""
    w = build(scene, responder)
    for _ in run(w, dt, steps):
        pass
    gone = data.draw(st.sampled_from(w.bodies))
    w.remove(gone)
    assert repr(w).startswith("<World")
    assert "removed" in repr(gone)
    assert all(repr(b).startswith("<Body") for b in w.bodies)
    assert repr(w.contacts).startswith("<Contacts")
    assert repr(w.last_step).startswith("<StepReport")
    assert type(responder).__name__ in repr(responder)
    for _ in run(w, dt, 1):
        assert repr(w.contacts).startswith("<Contacts") and repr(w.last_step).startswith("<StepReport")
