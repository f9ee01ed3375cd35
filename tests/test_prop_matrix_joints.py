"""Properties of the matrix form of PGS, and of joints."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

import phys2d
from tests.strategies import SceneSpec, build, dts, free_scene, pgs_settings, reals, scenes, vectors
from tests.test_prop_pgs import jacobian

mice = st.none() | st.fixed_dictionaries(
    dict(
        target=vectors(-3.0, 3.0),
        max_force=st.sampled_from([0.0, 5.0, 1e4]) | reals(0.0, 200.0),
        hertz=reals(0.5, 30.0),
        damping_ratio=reals(0.0, 2.0),
    )
)


def add_mouse(w: phys2d.World, mouse: dict | None) -> None:
    """A mouse joint on the first dynamic body, grabbed at its centre, dragged to mouse['target']."""
    dragged = [b for b in w.bodies if not (b.static or b.kinematic)]
    if mouse is not None and dragged:
        joint = w.add_mouse_joint(
            dragged[0],
            target=dragged[0].position,
            max_force=mouse["max_force"],
            hertz=mouse["hertz"],
            damping_ratio=mouse["damping_ratio"],
        )
        joint.target = mouse["target"]


@given(scene=scenes(max_bodies=6, ground=None, static=None), settings=pgs_settings(form="matrix"), dt=dts, mouse=mice)
def test_matrix_and_impulse_forms_give_the_same_lambdas(
    scene: SceneSpec, settings: phys2d.PGS, dt: float, mouse: dict | None
) -> None:
    """The lecture's matrix form (A and b assembled, rows swept with sum_l A_kl lambda_l)
    and the impulse form (J_k V read off the velocities) make the same iterates: after
    each step their lambdas and velocities agree to round-off. With a mouse joint too: its
    spring is a regularised 2x2 block of A in the matrix form (docs/formulation.md, "Mouse
    rows"), the impulse form's soft update in the other."""
    impulse = phys2d.PGS(
        iterations=settings.iterations,
        warm_start=settings.warm_start,
        beta=settings.beta,
        slop=settings.slop,
        tolerance=settings.tolerance,
        restitution_threshold=settings.restitution_threshold,
        friction=settings.friction,
        form="impulse",
    )
    a, b = build(scene, settings), build(scene, impulse)
    add_mouse(a, mouse)
    add_mouse(b, mouse)
    for _ in range(8):
        try:
            a.step(dt)
        except phys2d.SimulationError:
            with pytest.raises(phys2d.SimulationError):
                b.step(dt)
            return
        b.step(dt)
        ca, cb = a.contacts, b.contacts
        assert np.array_equal(ca.key, cb.key)
        scale = 1.0 + float(np.abs(ca.normal_impulse).max(initial=0.0))
        np.testing.assert_allclose(ca.normal_impulse, cb.normal_impulse, rtol=0, atol=1e-9 * scale)
        np.testing.assert_allclose(ca.tangent_impulse, cb.tangent_impulse, rtol=0, atol=1e-9 * scale)
        np.testing.assert_allclose(a.V, b.V, rtol=0, atol=1e-9 * (1.0 + float(np.abs(b.V).max())))
        pulls = a.last_step.joint_impulses
        np.testing.assert_allclose(pulls, b.last_step.joint_impulses, rtol=0, atol=1e-9 * (scale + np.abs(pulls).sum()))
        # resynchronise, so round-off does not grow over the steps
        b.x[:], b.theta[:], b.V[:] = a.x, a.theta, a.V


@given(scene=scenes(max_bodies=5, ground=None, static=None, gravity=None), settings=pgs_settings(form="matrix"), dt=dts)
def test_matrix_system_is_the_lecture_system(scene: SceneSpec, settings: phys2d.PGS, dt: float) -> None:
    """w.last_step.system holds the step's own equations (docs/formulation.md#equations-of-motion): its rows of J
    are the contacts' [-n, -(r_a x n) | n, r_b x n] and tangent rows, A = J M^-1 J^T,
    b = xi - J V1 - dt J M^-1 F_ext with F_ext = m g, lo <= lambda <= hi, and
    V2 = V1 + M^-1 (dt F_ext + J^T lambda) is the world's new V."""
    w = build(scene, settings)
    x, V1 = w.x.copy(), w.V.copy()
    try:
        w.step(dt)
    except phys2d.SimulationError:
        assume(False)
    s = w.last_step.system
    c = w.contacts
    assert s is not None
    J, A = s.J.dense(), s.A.dense()
    n = len(w)
    assert J.shape == (2 * len(c), 3 * n)
    mine = np.vstack([jacobian(n, x, c, c.normal), jacobian(n, x, c, c.tangent)])
    for row in J:  # every row of the system is one of the contacts' rows
        assert np.min(np.abs(mine - row).max(axis=1)) < 1e-12 * (1 + np.abs(row).max())
    M_inv = w.M_inv.reshape(-1)
    np.testing.assert_array_equal(s.M_inv, M_inv)
    np.testing.assert_array_equal(s.V1, V1.reshape(-1))
    mass = np.array([b.mass for b in w.bodies])
    F = np.zeros((n, 3))
    F[~np.array([b.static for b in w.bodies]), :2] = (mass[:, None] * w.gravity)[
        ~np.array([b.static for b in w.bodies])
    ]
    np.testing.assert_allclose(s.F_ext, F.reshape(-1), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(A, J @ (M_inv[:, None] * J.T), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(s.b, s.xi - J @ s.V1 - dt * J @ (M_inv * s.F_ext), rtol=1e-12, atol=1e-9)
    lam = s.lam
    assert np.all(lam >= s.lo - 1e-12 * (1 + np.abs(lam))) and np.all(lam <= s.hi + 1e-12 * (1 + np.abs(lam)))
    np.testing.assert_allclose(w.V.reshape(-1), s.velocities(), rtol=0, atol=1e-12 * (1 + np.abs(w.V).max()))


# -- joints ----------------------------------------------------------------------------


@st.composite
def jointed(draw) -> tuple[SceneSpec, list[tuple]]:
    """Free bodies without gravity, and joints between random pairs of them."""
    scene = free_scene(draw(scenes(min_bodies=2, max_bodies=5, ground=False, region=1.5)))
    n = len(scene.bodies)
    joints = []
    for _ in range(draw(st.integers(1, 4))):
        a, b = draw(st.lists(st.integers(0, n - 1), min_size=2, max_size=2, unique=True))
        kind = draw(st.sampled_from(["distance", "pin", "angle"]))
        joints.append(
            (
                kind,
                a,
                b,
                draw(vectors(-0.3, 0.3)),
                draw(vectors(-0.3, 0.3)),
                draw(st.none() | reals(-0.5, 0.0)),
                draw(st.none() | reals(0.0, 0.5)),
            )
        )
    return scene, joints


def add_joints(w: phys2d.World, joints: list[tuple]) -> None:
    bodies = w.bodies
    for kind, a, b, off_a, off_b, lower, upper in joints:
        pa, pb = bodies[a].position + off_a, bodies[b].position + off_b
        if kind == "distance":
            if np.hypot(*(pb - pa)) > 1e-3:
                w.add_distance_joint(bodies[a], bodies[b], anchor_a=pa, anchor_b=pb)
        elif kind == "pin":
            w.add_pin_joint(bodies[a], bodies[b], anchor=pa)
        else:
            w.add_angle_joint(bodies[a], bodies[b], lower=lower, upper=upper)


@given(case=jointed(), settings=pgs_settings(), dt=dts, about=vectors(-3.0, 3.0))
def test_joints_conserve_momentum(case, settings: phys2d.PGS, dt: float, about) -> None:
    """No gravity, no static bodies, joints and contacts: every row pushes equally and
    oppositely, so linear momentum is kept by every step. Angular momentum is kept too,
    except for a pin joint whose two points have drifted apart by g = p_b - p_a: its
    impulse lambda (a vector) then acts at two points, a couple of g x lambda, so
    |Delta L| <= sum over pins of |g| |lambda| (distance rows act along g itself, angle
    rows are opposite torques: both exact). The push is the lecture's (split=False) and
    nothing bounces: a split push and the bounce of a point that was still apart move
    bodies with a velocity they do not keep (test_prop_conservation says more)."""
    scene, joints = case
    settings.split = False
    scene = replace(scene, bodies=tuple(replace(b, restitution=0.0) for b in scene.bodies))
    w = build(scene, settings)
    add_joints(w, joints)
    assume(len(w.joints) > 0)
    p0 = w.linear_momentum()
    m = np.array([b.mass for b in w.bodies])
    for _ in range(20):
        size = (
            float(np.sum(m * np.hypot(*w.V[:, :2].T) * (1 + np.hypot(*(w.x - about).T))) + np.sum(np.abs(w.V[:, 2])))
            + 1e-9
        )
        l0 = w.angular_momentum(about)
        gaps = [j.gap() for j in w.joints if isinstance(j, phys2d.PinJoint)]
        try:
            w.step(dt)
        except phys2d.SimulationError:
            return
        couple = sum(
            g * float(np.hypot(*j.impulse))
            for g, j in zip(gaps, [j for j in w.joints if isinstance(j, phys2d.PinJoint)])
        )
        np.testing.assert_allclose(w.linear_momentum(), p0, rtol=0, atol=1e-10 * size * (1 + w.tick))
        assert abs(w.angular_momentum(about) - l0) <= couple * (1 + 1e-9) + 1e-10 * size


@given(case=jointed(), dt=dts)
def test_converged_joints_hold_their_velocity_constraints(case, dt: float) -> None:
    """With beta = 0 and no contacts between jointed bodies, converged PGS leaves every
    equality joint row at J_k V2 = 0 (xi = 0 without a position push)."""
    scene, joints = case
    scene = replace(scene, bodies=tuple(replace(b, position=(4.0 * k, 0.0)) for k, b in enumerate(scene.bodies)))
    joints = [(k, a, b, oa, ob, None, None) for k, a, b, oa, ob, _, _ in joints]  # no limits
    pgs = phys2d.PGS(iterations=5000, tolerance=1e-13, beta=0.0, warm_start=False, form="matrix")
    w = build(scene, pgs)
    add_joints(w, joints)
    assume(len(w.joints) > 0)
    w.step(dt)
    assume(w.last_step.iterations < pgs.iterations)
    s = w.last_step.system
    rows = np.arange(2 * len(w.contacts), s.J.shape[0])
    jv = s.J.dense()[rows] @ w.V.reshape(-1)
    assert np.all(np.abs(jv) <= 1e-8 * (1.0 + np.abs(s.V1).max()))
