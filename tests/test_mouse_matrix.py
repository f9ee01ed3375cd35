"""Mouse joints under PGS's matrix form (issue 27): the soft pull as a regularised 2x2 block of A
(K / (a2 a3) = K + K / a2, docs/formulation.md "Matrix form"), solved as one block with a disk
clamp after each sweep. Checked against the impulse form (the same iterates), against the
system written out by hand from the bodies, and against the closed forms the impulse form
meets: a held body hangs g / omega^2 below its target, and the pull never exceeds max_force."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import phys2d
from tests.strategies import dts, reals
from tests.test_matrix_form import state

G = 10.0
DT = 1.0 / 60.0


@st.composite
def dragged_scenes(draw):
    """A body dragged by a mouse joint: resting on the ground (contacts on the dragged body) or
    in the air, with or without a second body tied to it (rows that couple with the mouse's),
    and PGS settings for both forms."""
    body = dict(
        kind=draw(st.sampled_from(["box", "circle"])),
        size=draw(reals(0.15, 0.6)),
        density=draw(reals(0.5, 5.0)),
        angle=draw(reals(-0.5, 0.5)),
        on_ground=draw(st.booleans()),
        friction=draw(reals(0.0, 1.0)),
    )
    mouse = dict(
        grab=draw(st.tuples(reals(-0.5, 0.5), reals(-0.5, 0.5))),  # in units of the body's size
        target=draw(st.tuples(reals(-2.0, 2.0), reals(-0.5, 3.0))),
        moved=draw(st.tuples(reals(-2.0, 2.0), reals(-0.5, 3.0))),
        max_force=draw(st.sampled_from([0.0, 1.0, 10.0, 100.0, 1e4]) | reals(0.0, 500.0)),
        hertz=draw(reals(0.5, 30.0)),
        damping_ratio=draw(reals(0.0, 2.0)),
    )
    tied = draw(st.sampled_from([None, "distance", "pin", "second mouse"]))
    options = dict(
        iterations=draw(st.integers(1, 15)),
        warm_start=draw(st.booleans()),
        split=draw(st.booleans()),
        friction=draw(st.sampled_from(["coulomb", "lecture"])),
        beta=draw(reals(0.0, 1.0)),
    )
    return body, mouse, tied, options


def build(case, form: str) -> tuple[phys2d.World, phys2d.MouseJoint]:
    body, mouse, tied, options = case
    w = phys2d.World(gravity=(0.0, -G), responder=phys2d.PGS(form=form, **options))
    w.add_box(position=(0.0, -0.5), half_extents=(5.0, 0.5), static=True)
    s = body["size"]
    y = s if body["on_ground"] else 2.0
    common = dict(position=(0.0, y), density=body["density"], friction=body["friction"])
    if body["kind"] == "box":
        dragged = w.add_box(half_extents=(s, 0.6 * s), angle=body["angle"], **common)
    else:
        dragged = w.add_circle(radius=s, **common)
    grab = dragged.position + s * np.array(mouse["grab"])
    joint = w.add_mouse_joint(
        dragged,
        target=grab,
        max_force=mouse["max_force"],
        hertz=mouse["hertz"],
        damping_ratio=mouse["damping_ratio"],
    )
    joint.target = mouse["target"]
    if tied is not None:
        other = w.add_circle(position=(1.2 * s + 0.3, y + 0.2), radius=0.25, density=1.5)
        if tied == "distance":
            w.add_distance_joint(dragged, other)
        elif tied == "pin":
            w.add_pin_joint(dragged, other, anchor=0.5 * (dragged.position + other.position))
        else:
            w.add_mouse_joint(other, target=other.position, max_force=20.0).target = (-1.0, 1.5)
            w.add_distance_joint(dragged, other)  # the two mice's blocks couple through the rod
    return w, joint


@given(case=dragged_scenes(), dt=dts)
def test_matrix_and_impulse_forms_agree_with_mouse_joints(case, dt: float) -> None:
    """The matrix form's block solve, x_blk = (K / a2 a3)^-1 (b_blk - coupling), is the impulse
    form's soft update delta = -a2 a3 K^-1 (J V + (omega / a1) C) - a3 lambda written for the
    new lambda (a2 a3 + a3 = 1), visited at the same point of each sweep: the same iterates, so
    the same sweeps, residuals, impulses and states, up to rounding. Both forms sum the same
    terms of size <= |V|, |lambda| in another order, a few ulp (~1e-16 relative) a row, and a
    sweep's residual (m/s, a change of some J_k V) is a difference of such terms: 1e-9 of the
    largest value leaves a margin of 1e6. The bodies are set equal again after each step, as
    in tests/test_prop_matrix_joints.py, so that a scene that runs away (one sweep, beta = 1,
    no damping) does not grow the rounding from step to step."""
    a, _ = build(case, "impulse")
    b, _ = build(case, "matrix")
    moved = case[1]["moved"]
    for step in range(30):
        if step == 15:
            for w in (a, b):
                next(j for j in w.joints if isinstance(j, phys2d.MouseJoint)).target = moved
        a.step(dt)
        b.step(dt)
        assert np.array_equal(a.contacts.key, b.contacts.key)
        assert a.last_step.iterations == b.last_step.iterations
        sa, sb = state(a), state(b)
        scale = 1.0 + float(np.abs(sa).max())
        np.testing.assert_allclose(sb, sa, rtol=0, atol=1e-9 * scale)
        np.testing.assert_allclose(b.last_step.residuals, a.last_step.residuals, rtol=0, atol=1e-9 * scale)
        b.x[:], b.theta[:], b.V[:] = a.x, a.theta, a.V  # resynchronise


def spring(hertz: float, zeta: float, h: float) -> tuple[float, float]:
    """(omega / a1, a2 a3) of the mouse's spring over h (docs/formulation.md, "Mouse")."""
    omega = 2.0 * math.pi * hertz
    a1 = 2.0 * zeta + h * omega
    a2 = h * omega * a1
    return omega / a1, a2 / (1.0 + a2)


@given(
    case=dragged_scenes(),
    dt=st.sampled_from([1 / 30, 1 / 60, 1 / 120]),
    grab=st.tuples(reals(-0.5, 0.5), reals(-0.5, 0.5)),
)
def test_the_system_holds_the_mouse_rows_written_out_by_hand(case, dt: float, grab) -> None:
    """From the body alone (m, I, x, V1, the grabbed point p and the target T): the mouse rows are
    J_x = [1, 0, -r_y], J_y = [0, 1, r_x] (r = p - x), their block of A is K / (a2 a3) with
    K = J M^-1 J^T, b = -(J V0 + (omega / a1) C) with V0 = V1 + g dt and C = p - T, the rows
    are flagged as one disk-clamped block, and A = J M^-1 J^T + compliance."""
    body, mouse, _, options = case
    case = (body, dict(mouse, grab=grab), None, options)
    w, joint = build(case, "matrix")
    handle = joint.body
    V1 = handle.velocity.copy(), handle.angular_velocity
    target, p = joint.anchors()
    r = p - handle.position
    w.step(dt)
    s = w.last_step.system
    (k,) = s.disk_blocks()
    assert list(s.bound_row[k : k + 2]) == [-2, -2]
    J = np.array([[1.0, 0.0, -r[1]], [0.0, 1.0, r[0]]])
    M_inv = np.array([1.0 / handle.mass, 1.0 / handle.mass, 1.0 / handle.inertia])
    K = J @ (M_inv[:, None] * J.T)
    bias_rate, mass_scale = spring(joint.hertz, joint.damping_ratio, dt)
    d = s.dense()
    i = 3 * handle.index
    np.testing.assert_allclose(d.J[k : k + 2, i : i + 3], J, rtol=0, atol=1e-12)
    block = K / mass_scale
    np.testing.assert_allclose(d.A[k : k + 2, k : k + 2], block, rtol=0, atol=1e-12 * np.abs(block).max())
    np.testing.assert_allclose(s.mass_scale[k : k + 2], mass_scale, rtol=1e-12)
    V0 = np.array([V1[0][0], V1[0][1] - G * dt, V1[1]])
    b = -(J @ V0 + bias_rate * (p - target))
    np.testing.assert_allclose(s.b[k : k + 2], b, rtol=0, atol=1e-9 * (1.0 + np.abs(b).max()))
    np.testing.assert_allclose(d.A, d.J @ d.M_inv @ d.J.T + d.compliance, rtol=0, atol=1e-12 * np.abs(d.A).max())
    rigid = np.ones(len(s.b), bool)
    rigid[k : k + 2] = False
    assert np.all(d.compliance[rigid] == 0.0) and np.all(s.mass_scale[rigid] == 1.0)
    lam = s.lam[k : k + 2]
    assert float(np.hypot(*lam)) <= joint.max_force * dt * (1.0 + 1e-12)  # the disk, not only the square lo, hi
    np.testing.assert_array_equal(joint.impulse, lam)


@given(
    hertz=reals(2.0, 15.0),
    zeta=reals(0.3, 1.0),
    dt=st.sampled_from([1 / 30, 1 / 60, 1 / 120, 1 / 240]),
    density=reals(0.5, 5.0),
)
def test_a_held_body_hangs_g_over_omega_squared_below_the_target(hertz, zeta, dt, density) -> None:
    """At rest, V2 = 0 makes K lambda = -J V0 = m g dt (the weight), and the soft block's
    equation (K + K / a2) lambda = -(J V0 + (omega / a1) C) leaves K lambda / a2 = -(omega /
    a1) C, so C = -g dt / (a2 omega / a1) = -g / omega^2 exactly, for every h and zeta."""
    w = phys2d.World(gravity=(0.0, -G), responder=phys2d.PGS(form="matrix"))
    box = w.add_box(position=(0.0, 0.0), half_extents=(0.3, 0.2), density=density)
    mouse = w.add_mouse_joint(box, target=(0.0, 0.0), max_force=1e3 * box.mass, hertz=hertz, damping_ratio=zeta)
    mouse.target = (0.5, 0.3)
    omega = 2.0 * math.pi * hertz
    steps = int(math.ceil(40.0 / (zeta * omega) / dt))  # e^-40: the transient is gone
    for _ in range(steps):
        w.step(dt)
    sag = G / omega**2
    target, point = mouse.anchors()
    assert point[0] == pytest.approx(target[0], abs=1e-9)
    assert target[1] - point[1] == pytest.approx(sag, rel=1e-6)
    assert mouse.impulse[1] == pytest.approx(box.mass * G * dt, rel=1e-9)  # it holds the weight
    assert abs(box.velocity[1]) < 1e-9


@given(
    share=reals(0.05, 0.95),
    hertz=reals(1.0, 20.0),
    dt=st.sampled_from([1 / 30, 1 / 60, 1 / 120]),
    density=reals(0.5, 5.0),
)
def test_the_pull_is_capped_at_max_force(share, hertz, dt, density) -> None:
    """A mouse of max_force = share m g (share < 1), its target 1 m straight above the body's
    centre: the spring asks for more than the cap from the first step, so each step's impulse
    is max_force dt, straight up (|lambda| <= max_force dt on the disk), and the body falls
    with g - max_force / m: v_y after n steps is -n dt (g - F / m)."""
    w = phys2d.World(gravity=(0.0, -G), responder=phys2d.PGS(form="matrix"))
    box = w.add_box(position=(0.0, 0.0), half_extents=(0.4, 0.4), density=density)
    F = share * box.mass * G
    mouse = w.add_mouse_joint(box, target=(0.0, 0.0), max_force=F, hertz=hertz)
    mouse.target = (0.0, 1.0)
    for n in range(1, 61):
        w.step(dt)
        lam = mouse.impulse
        assert float(np.hypot(*lam)) <= F * dt * (1.0 + 1e-12)
        assert lam[1] == pytest.approx(F * dt, rel=1e-12) and lam[0] == pytest.approx(0.0, abs=1e-12 * F * dt)
        assert box.velocity[1] == pytest.approx(-n * dt * (G - F / box.mass), rel=1e-9)


def test_matrix_form_takes_a_mouse_joint_and_changing_form_keeps_it() -> None:
    """Both forms solve mouse joints: a world with one takes PGS(form='matrix'), and a PGS
    switched between forms mid-drag keeps stepping the same motion (to rounding)."""
    w = phys2d.World(responder=phys2d.PGS())
    box = w.add_box(position=(0.0, 1.0), half_extents=(0.3, 0.3))
    mouse = w.add_mouse_joint(box, target=(0.1, 1.1), max_force=50.0)
    w.responder = phys2d.PGS(form="matrix")
    twin = phys2d.World(responder=phys2d.PGS(form="matrix"))
    twin_box = twin.add_box(position=(0.0, 1.0), half_extents=(0.3, 0.3))
    twin_mouse = twin.add_mouse_joint(twin_box, target=(0.1, 1.1), max_force=50.0)
    for k in range(40):
        if k == 10:
            mouse.target = twin_mouse.target = (1.0, 2.0)
        if k == 20:
            w.responder.form = "impulse"
        w.step(DT)
        twin.step(DT)
        np.testing.assert_allclose(w.V, twin.V, rtol=0, atol=1e-9)
    assert mouse.error() < 0.1


def test_a_world_without_mouse_joints_has_the_rigid_system() -> None:
    """No mouse joint: no block is flagged, mass_scale is 1 everywhere, the compliance is zero and
    A = J M^-1 J^T exactly as before."""
    w = phys2d.scenes.pyramid(3, responder=phys2d.PGS(form="matrix"))
    w.add_distance_joint(w.bodies[1], w.bodies[2])
    w.step(DT)
    s = w.last_step.system
    assert s.disk_blocks().shape == (0,)
    assert np.all(s.mass_scale == 1.0)
    d = s.dense()
    assert np.all(d.compliance == 0.0)
    np.testing.assert_allclose(d.A, d.J @ d.M_inv @ d.J.T, rtol=0, atol=1e-12)
