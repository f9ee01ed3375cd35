"""SoftStep with joints: pendulum theory, the heavy chain, angle limits, the direct joint solve."""

from __future__ import annotations

import numba
import numpy as np
import pytest

import phys2d
from phys2d import scenes
from phys2d.constraints.joints import JointArrays, joint_rows
from phys2d.constraints.rows import Rows
from phys2d.pipeline import records
from phys2d.responders.soft_joints import factor_joint_rows, solve_factored
from tests.test_joints import G, distance_pendulum, pin_pendulum


@pytest.mark.parametrize("direct", [True, False], ids=["direct", "sweep"])
def test_soft_step_distance_pendulum_period(direct):
    # T = 2 pi sqrt(L/g) times the amplitude factor (the exact period), as for PGS
    period, expected, largest, gap = distance_pendulum(phys2d.SoftStep(direct_joints=direct), 1 / 60)
    assert period == pytest.approx(expected, rel=0.01)
    assert largest == pytest.approx(0.5, abs=0.02)
    assert gap < 1e-3


def test_soft_step_pin_pendulum_period():
    # a rod pinned at one end: T = 2 pi sqrt(I_p / (m g d)), I_p = I_cm + m d^2, as for PGS
    period, expected, gap = pin_pendulum(phys2d.SoftStep(), 1 / 60)
    assert period == pytest.approx(expected, rel=0.01)
    assert gap < 1e-3


def test_heavy_chain_keeps_every_joint_within_a_centimetre():
    # issue 11: 20 links carrying a 100x heavier box, swinging down from horizontal
    w = scenes.heavy_chain(20, 100.0, responder=phys2d.SoftStep(substeps=4))
    worst = 0.0
    for _ in range(90):  # 1.5 s: the fall and the fastest part of the first swing
        w.step(1 / 60)
        worst = max(worst, max(joint.gap() for joint in w.joints))
    assert worst < 0.01
    assert w.x[-1, 1] < w.x[1, 1] - 5.0  # it really fell: the heavy box is far below the pivot


def test_angle_limit_stops_a_falling_lever():
    # a bar pinned at its left end to a static body falls; its lower limit of -0.3 rad stops it
    w = phys2d.World(gravity=(0.0, -G), responder=phys2d.SoftStep())
    base = w.add_circle(position=(0.0, 5.0), radius=0.05, static=True)
    bar = w.add_box(position=(1.0, 5.0), half_extents=(1.0, 0.05))
    w.add_pin_joint(base, bar, anchor=(0.0, 5.0))
    limit = w.add_angle_joint(base, bar, lower=-0.3, upper=0.3)
    for _ in range(180):
        w.step(1 / 60)
    # without the limit it would hang straight down (-pi/2); the stop holds it at -0.3 rad
    assert limit.offset() == pytest.approx(-0.3, abs=0.01)
    assert abs(w.V[bar.index, 2]) < 0.05


def test_fixed_angle_joint_holds_two_bodies_at_their_angle():
    w = phys2d.World(gravity=(0.0, -G), responder=phys2d.SoftStep())
    base = w.add_circle(position=(0.0, 5.0), radius=0.05, static=True)
    bar = w.add_box(position=(1.0, 5.0), half_extents=(1.0, 0.05))
    w.add_pin_joint(base, bar, anchor=(0.0, 5.0))
    weld = w.add_angle_joint(base, bar)
    for _ in range(120):
        w.step(1 / 60)
    assert abs(weld.offset()) < 0.01  # a cantilever: the pin and the fixed angle together hold it level


def _chain(n_links: int, redundant: bool = False) -> phys2d.World:
    """A chain of 1 m links pinned end to end, each turned a little more than the last."""
    w = phys2d.World(gravity=(0.0, -G), responder=phys2d.PGS())
    previous = w.add_circle(position=(0.0, 0.0), radius=0.05, static=True)
    for k in range(n_links):
        link = w.add_box(position=(k + 0.5, 0.3 * k), half_extents=(0.5, 0.1), angle=0.2 * k)
        w.add_pin_joint(previous, link, anchor=(k, 0.3 * k))
        if redundant:  # the same pin twice: two rows that repeat two others
            w.add_pin_joint(previous, link, anchor=(k, 0.3 * k))
        previous = link
    return w


def _rows_of(w: phys2d.World) -> Rows:
    """The joint rows of w at its positions now, with xi = -C (beta = dt = 1)."""
    ja = JointArrays(list(w.joints))
    rows = Rows(ja.n_rows)
    bodies = records.new_bodies((w.x, w.theta, w.V, w.M_inv, w.V))
    joint_rows(records.record_of_joints(ja, np.zeros(ja.n_rows)), 0, bodies, 1.0, 1.0, records.record_of_rows(rows))
    return rows


def _dense_A(rows):
    """A = J M^-1 J^T, assembled from the 6-column rows (a second method)."""
    n = len(rows)
    n_bodies = int(max(rows.body_a.max(), rows.body_b.max())) + 1
    Jfull = np.zeros((n, 3 * n_bodies))
    JMfull = np.zeros((n, 3 * n_bodies))
    for k in range(n):
        for side, body in enumerate((rows.body_a[k], rows.body_b[k])):
            Jfull[k, 3 * body : 3 * body + 3] += rows.J[k, 3 * side : 3 * side + 3]
            JMfull[k, 3 * body : 3 * body + 3] += rows.JM[k, 3 * side : 3 * side + 3]
    return Jfull @ JMfull.T


def test_direct_joint_solve_matches_a_dense_solve():
    w = _chain(6)
    rows = _rows_of(w)
    n = len(rows)
    eq = np.arange(n, dtype=np.int64)
    L = np.zeros((n, n))
    first = np.zeros(n, np.int64)
    factor_joint_rows(eq, rows.body_a, rows.body_b, rows.J, rows.JM, L, first)
    rhs = np.linspace(-1.0, 2.0, n)
    y = rhs.copy()
    solve_factored(L, first, y)
    A = _dense_A(rows)
    np.testing.assert_allclose(y, np.linalg.solve(A, rhs), rtol=1e-9, atol=1e-12)
    assert first.max() > 0 and first[-1] >= n - 4  # a chain: each row reaches back only to its neighbours


def test_direct_joint_solve_leaves_redundant_rows_out_and_stays_consistent():
    # the same pin twice makes A singular; a consistent right-hand side (from a velocity) is met exactly
    w = _chain(4, redundant=True)
    rows = _rows_of(w)
    n = len(rows)
    eq = np.arange(n, dtype=np.int64)
    L = np.zeros((n, n))
    first = np.zeros(n, np.int64)
    factor_joint_rows(eq, rows.body_a, rows.body_b, rows.J, rows.JM, L, first)
    A = _dense_A(rows)
    rhs = A @ np.sin(np.arange(n) + 1.0)  # in A's range
    y = rhs.copy()
    solve_factored(L, first, y)
    assert np.all(np.isfinite(y))
    np.testing.assert_allclose(A @ y, rhs, atol=1e-8)


def test_soft_step_joint_scenes_are_deterministic():
    states = []
    for _ in range(2):
        w = scenes.heavy_chain(5, 100.0, responder=phys2d.SoftStep())
        for _ in range(30):
            w.step(1 / 60)
        states.append((w.x.copy(), w.theta.copy(), w.V.copy(), w.last_step.joint_impulses.copy()))
    for a, b in zip(*states):
        assert np.array_equal(a, b)


@pytest.mark.parametrize("name", sorted(scenes.SCENES))
def test_every_stock_scene_runs_under_soft_step(name):
    # every scene PGS runs, SoftStep runs (the joint scenes included); a few ticks, finite and moving
    build = scenes.SCENES[name][0]
    w = build(responder=phys2d.SoftStep())
    for _ in range(20):
        w.step(1 / 60)
    assert np.all(np.isfinite(w.x)) and np.all(np.isfinite(w.V))
    assert w.last_step.responder == "soft-step"


def test_redundant_pins_are_solved_without_blowing_up():
    # the same pin twice (lesson 09's redundant constraints): A is singular, the direct solve leaves one out
    w = _chain(3, redundant=True)
    w.responder = phys2d.SoftStep()
    for _ in range(120):
        w.step(1 / 60)
    assert np.all(np.isfinite(w.V))
    assert max(joint.gap() for joint in w.joints) < 0.01


@pytest.mark.skipif(numba.config.DISABLE_JIT, reason="uncompiled kernels have no overloads")
@pytest.mark.fresh_numba_cache
@pytest.mark.xdist_group("fresh_cache")
def test_a_world_without_joints_compiles_none_of_their_code(fresh_cache_compiles):
    """joints=None (SoftStep.respond's for a world without joints): numba drops the `joints is not None`
    branches, so no joint kernel is compiled; with a JointRecord they are. Counted in a fresh process
    and cache (a kernel loaded from the cache does not list the kernels compiled into it), the child
    shared with tests/test_ahead.py: ``tests/fresh_cache.py``, where the soft step's solve is called
    on its own, without joints and then with them, after a pyramid under PGS (no joints either)."""
    calls = fresh_cache_compiles["soft_step_solve"]
    assert calls["without"] == {"substeps": 4, "overloads": [0, 0, 0, 0, 0, 0]}
    assert calls["with"] == {"substeps": 4, "overloads": [1, 1, 1, 1, 1, 1]}
