"""PGS in matrix form: the assembled J, M^-1, A, b against dense numpy, and against the
impulse form (the same method, so the same answers to rounding)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import phys2d
from phys2d import scenes
from phys2d.responders.pgs_matrix import SparseMatrix

DT = 1 / 60


def state(w: phys2d.World) -> np.ndarray:
    """Positions, angles, velocities, contact impulses and joint impulses in one vector."""
    return np.concatenate(
        [
            w.x.ravel(),
            w.theta,
            w.V.ravel(),
            w.contacts.normal_impulse,
            w.contacts.tangent_impulse,
            w.last_step.joint_impulses,
        ]
    )


def max_difference(make, steps: int) -> float:
    """Largest difference between the two forms over ``steps`` steps of the world ``make(form)``."""
    a, b = make("impulse"), make("matrix")
    worst = 0.0
    for _ in range(steps):
        a.step(DT)
        b.step(DT)
        assert len(a.contacts) == len(b.contacts)
        assert np.array_equal(a.contacts.key, b.contacts.key)
        assert a.last_step.iterations == b.last_step.iterations
        np.testing.assert_allclose(a.last_step.residuals, b.last_step.residuals, atol=1e-9)
        worst = max(worst, float(np.max(np.abs(state(a) - state(b)), initial=0.0)))
    return worst


def test_forms_agree_on_a_pyramid():
    worst = max_difference(lambda form: scenes.pyramid(5, responder=phys2d.PGS(form=form)), 60)
    assert worst < 1e-9


def test_forms_agree_on_a_chain():
    worst = max_difference(lambda form: scenes.pendulum_chain(6, responder=phys2d.PGS(form=form)), 60)
    assert worst < 1e-9


@st.composite
def random_scene(draw):
    # bodies start apart, in cells of a grid 1.8 m wide (each fits in a 0.85 m radius), and
    # collide through their random velocities and gravity: generic contacts, not exact ties
    # such as two coincident boxes, whose manifold may change with the last bit of rounding
    n = draw(st.integers(1, 7))
    bodies = []
    for k in range(n):
        bodies.append(
            dict(
                kind=draw(st.sampled_from(["box", "circle", "triangle"])),
                x=-2.7 + 1.8 * (k % 4) + draw(st.floats(-0.04, 0.04)),
                y=1.0 + 1.8 * (k // 4) + draw(st.floats(-0.04, 0.04)),
                angle=draw(st.floats(-math.pi, math.pi)),
                size=draw(st.floats(0.2, 0.7)),
                vx=draw(st.floats(-3.0, 3.0)),
                vy=draw(st.floats(-3.0, 3.0)),
                omega=draw(st.floats(-3.0, 3.0)),
                friction=draw(st.floats(0.0, 1.0)),
                restitution=draw(st.floats(0.0, 1.0)),
                density=draw(st.floats(0.5, 5.0)),
            )
        )
    options = dict(
        iterations=draw(st.integers(1, 15)),
        warm_start=draw(st.booleans()),
        friction=draw(st.sampled_from(["coulomb", "lecture"])),
        beta=draw(st.floats(0.0, 1.0)),
    )
    joint = draw(st.sampled_from([None, "distance", "pin", "angle", "limits"])) if n >= 2 else None
    return bodies, options, joint


def build(scene, form: str):
    bodies, options, joint = scene
    w = phys2d.World(responder=phys2d.PGS(form=form, **options))
    w.add_box(position=(0.0, -0.5), half_extents=(5.0, 0.5), static=True)
    made = []
    for b in bodies:
        common = dict(
            position=(b["x"], b["y"]),
            angle=b["angle"],
            velocity=(b["vx"], b["vy"]),
            angular_velocity=b["omega"],
            friction=b["friction"],
            restitution=b["restitution"],
            density=b["density"],
        )
        s = b["size"]
        if b["kind"] == "box":
            made.append(w.add_box(half_extents=(s, 0.6 * s), **common))
        elif b["kind"] == "circle":
            made.append(w.add_circle(radius=s, **common))
        else:
            made.append(w.add_polygon(vertices=[(-s, -0.5 * s), (s, -0.5 * s), (0.0, s)], **common))
    if joint == "distance":
        w.add_distance_joint(made[0], made[1])
    elif joint == "pin":
        w.add_pin_joint(made[0], made[1], anchor=0.5 * (made[0].position + made[1].position))
    elif joint == "angle":
        w.add_angle_joint(w.bodies[0], made[1])
    elif joint == "limits":
        w.add_angle_joint(made[0], made[1], lower=-0.2, upper=0.3)
    return w


@settings(max_examples=40, deadline=None)
@given(random_scene())
def test_forms_agree_on_random_scenes(scene):
    assert max_difference(lambda form: build(scene, form), 30) < 1e-9


def small_world(iterations: int = 10) -> phys2d.World:
    w = scenes.pyramid(3, responder=phys2d.PGS(form="matrix", iterations=iterations))
    w.add_circle(position=(2.5, 0.4), radius=0.4, velocity=(-1.0, 0.0))
    box = w.bodies[-2]
    w.add_distance_joint(box, w.bodies[-1])
    return w


def test_system_is_the_lecture_equations():
    w = small_world()
    for _ in range(5):
        w.step(DT)
    V_before = w.V.copy()
    x_before = w.x.copy()
    w.step(DT)
    s = w.last_step.system
    d = s.dense()
    R, n = len(s.b), 3 * len(w)
    assert d.J.shape == (R, n) and d.A.shape == (R, R) and d.M_inv.shape == (n, n)
    assert R == 2 * len(w.contacts) + 1
    # A = J M^-1 J^T and b = xi - J V1 - dt J M^-1 F_ext, with dense numpy
    np.testing.assert_allclose(d.A, d.J @ d.M_inv @ d.J.T, atol=1e-12)
    np.testing.assert_allclose(d.b, s.xi - d.J @ d.V1 - DT * d.J @ d.M_inv @ d.F_ext, atol=1e-12)
    np.testing.assert_array_equal(d.V1, V_before.ravel())
    # F_ext is gravity on the dynamic bodies
    masses = np.array([b.mass for b in w.bodies])
    static = np.array([b.static for b in w.bodies])
    np.testing.assert_allclose(d.F_ext[1::3], np.where(static, 0.0, -10.0 * masses))
    # M^-1 is [1/m, 1/m, 1/I] and zero for the static ground
    inertia = np.array([b.inertia for b in w.bodies])
    np.testing.assert_allclose(np.diag(d.M_inv)[2::3], np.where(static, 0.0, 1.0 / inertia))
    # V2 = V1 + M^-1 (dt F_ext + J^T lambda) is what the world moved with, lambda with the joint's
    # push (solved apart from the warm-started sweeps, it stays in V as a Baumgarte term does)
    joint = np.arange(R) >= 2 * len(w.contacts)
    assert np.count_nonzero(s.lam_push[joint]) == 1  # the joint is pulled back to its length
    V2 = d.V1 + d.M_inv @ (DT * d.F_ext + d.J.T @ (d.lam + np.where(joint, s.lam_push, 0.0)))
    np.testing.assert_allclose(V2, w.V.ravel(), atol=1e-12)
    np.testing.assert_allclose(w.x, x_before + DT * w.V[:, :2], atol=1e-12)
    # the answer respects its bounds, and the step reports it
    assert np.all(d.lam >= d.lo - 1e-12) and np.all(d.lam <= d.hi + 1e-12)
    # rows 2q, 2q + 1 belong to contact solve_order[q] (the graph-coloured visiting order)
    order = w.last_step.solve_order
    assert sorted(order) == list(range(len(w.contacts)))
    np.testing.assert_array_equal(d.lam[0 : R - 1 : 2], w.contacts.normal_impulse[order])
    np.testing.assert_array_equal(d.lam[R - 1 :], w.last_step.joint_impulses)


def test_converged_solution_meets_the_complementarity_conditions():
    w = small_world(iterations=500)
    for _ in range(30):
        w.step(DT)
    s = w.last_step.system
    d = s.dense()
    w_res = d.A @ d.lam - d.b  # J V2 - xi for every row
    free = (d.lam > d.lo + 1e-9) & (d.lam < d.hi - 1e-9)
    np.testing.assert_allclose(w_res[free], 0.0, atol=1e-8)  # rows strictly inside: J V2 = xi
    at_low = d.lam <= d.lo + 1e-9
    assert np.all(w_res[at_low] >= -1e-8)  # a contact at lambda = 0 is separating
    at_high = d.lam >= d.hi - 1e-9
    assert np.all(w_res[at_high] <= 1e-8)  # friction at its bound: sliding against it
    assert free.sum() > 0


def test_A_is_sparse_with_one_entry_per_pair_of_rows_sharing_a_dynamic_body():
    w = scenes.pyramid(12, responder=phys2d.PGS(form="matrix"))
    w.step(DT)
    s = w.last_step.system
    i, j = s.J.indices[0::6] // 3, s.J.indices[3::6] // 3  # each row's two bodies
    static = {b.index for b in w.bodies if b.static}
    rows_on = {}
    for k, (a, b) in enumerate(zip(i.tolist(), j.tolist(), strict=True)):
        for body in {a, b} - static:
            rows_on.setdefault(body, set()).add(k)
    pairs = {(k, l) for rows in rows_on.values() for k in rows for l in rows}
    R = len(s.b)
    assert s.A.nnz == len(pairs)
    assert s.A.nnz < 0.05 * R * R  # far from dense
    # every stored entry is J_k M^-1 J_l^T
    rng = np.random.default_rng(3)
    for e in rng.integers(0, s.A.nnz, 50):
        k = int(np.searchsorted(s.A.indptr, e, side="right") - 1)
        l = int(s.A.indices[e])
        Jk, Jl = np.zeros(s.J.shape[1]), np.zeros(s.J.shape[1])
        Jk[s.J.indices[6 * k : 6 * k + 6]] = s.J.data[6 * k : 6 * k + 6]
        Jl[s.J.indices[6 * l : 6 * l + 6]] = s.J.data[6 * l : 6 * l + 6]
        assert s.A.data[e] == pytest.approx(Jk @ (s.M_inv * Jl), abs=1e-12)


def test_resting_box_carries_its_weight():
    w = phys2d.World(responder=phys2d.PGS(form="matrix"))
    w.add_box(position=(0.0, -0.5), half_extents=(5.0, 0.5), static=True)
    box = w.add_box(position=(0.0, 0.5), half_extents=(0.5, 0.25), density=2.0)
    for _ in range(60):
        w.step(DT)
    assert w.contacts.normal_impulse.sum() == pytest.approx(box.mass * 10.0 * DT, rel=1e-6)


def test_bad_forms_and_huge_dense_matrices_are_refused():
    with pytest.raises(ValueError, match="form"):
        phys2d.PGS(form="dense")
    with pytest.raises(ValueError, match="block"):
        phys2d.PGS(form="matrix", block=True)
    huge = SparseMatrix(np.zeros(100_001, np.int64), np.zeros(0, np.int64), np.zeros(0), (100_000, 100_000))
    with pytest.raises(ValueError, match="too large"):
        huge.dense()
    with pytest.raises(ValueError, match="shape"):
        huge.dot(np.zeros(3))
