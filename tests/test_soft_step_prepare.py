"""SoftStep's once-per-tick preparation (``prepare_manifolds``), checked against a second computation."""

from __future__ import annotations

import copy

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import phys2d
from phys2d import scenes
from phys2d.constraints.rows import Rows, unsigned_rows
from phys2d.pipeline.records import record_of_rows
from phys2d.responders.base import StepContext
from phys2d.responders.soft_contacts import prepare_manifolds


def rows_after(world: phys2d.World, responder: phys2d.SoftStep, steps: int) -> tuple[Rows, np.ndarray]:
    """A copy of the rows ``responder.respond`` saw at the last of ``steps`` steps (taken before
    the solve), and the bodies' M^-1."""
    seen: list[Rows] = []
    respond = responder.respond

    def keep(ctx: StepContext):
        seen.append(copy.deepcopy(ctx.rows))
        return respond(ctx)

    responder.respond = keep  # type: ignore[method-assign]
    for _ in range(steps):
        world.step(1 / 60)
    return seen[-1], world.M_inv.copy()


@pytest.mark.parametrize("block", [True, False])
def test_manifolds_of_a_resting_stack(block):
    responder = phys2d.SoftStep(substeps=4, block=block)
    w = scenes.vertical_stack(3, responder)
    rows, M_inv = rows_after(w, responder, 30)
    normal_row, body_a, body_b, J, A_kk = rows.normal_row, rows.body_a, rows.body_b, rows.J, rows.A_kk
    JM = np.zeros_like(J)
    JM[:, :3] = M_inv[body_a] * J[:, :3]  # M^-1 J^T row by row, from the bodies' masses
    JM[:, 3:] = M_inv[body_b] * J[:, 3:]
    rows.JM = JM
    start, static_pair, K12, as_block, inv_det = prepare_manifolds(unsigned_rows(record_of_rows(rows)), M_inv, block)
    # three boxes resting flat: each touches the one below (or the ground) at two corners
    assert start.tolist() == [0, 2, 4, 6]
    pairs = [{(body_a[normal_row[c]], body_b[normal_row[c]]) for c in range(start[m], start[m + 1])} for m in range(3)]
    assert all(len(p) == 1 for p in pairs)  # a manifold's points share their pair
    assert len(set().union(*pairs)) == 3  # and the three pairs differ
    static = w.body_static
    assert static_pair.tolist() == [bool(static[a] or static[b]) for ((a, b),) in pairs]
    assert static_pair.sum() == 1  # only the bottom box touches the ground
    for m in range(3):
        k, k2 = normal_row[start[m]], normal_row[start[m] + 1]
        a, b = body_a[k], body_b[k]
        # K12 = J_1 M^-1 J_2^T from the Jacobians and the inverse masses (only a block needs it)
        K = J[k, :3] @ (M_inv[a] * J[k2, :3]) + J[k, 3:] @ (M_inv[b] * J[k2, 3:])
        assert K12[m] == (pytest.approx(K, rel=1e-12) if block else 0.0)
        # two corners a box width apart: far from parallel, so solved as a block when asked
        assert as_block[m] == block
        # a block's 1 / det K, from the Jacobians as above (lcp2 multiplies by it)
        det = A_kk[k] * A_kk[k2] - K * K
        assert inv_det[m] == (pytest.approx(1.0 / det, rel=1e-12) if block else 0.0)


class _ReadsTargets(phys2d.SoftStep):
    """The soft step, its own tick, with the rows built as for a responder that reads them all."""

    reads_targets = True


@pytest.mark.parametrize("scene", ["pyramid", "mixed"])
def test_the_soft_step_reads_none_of_the_targets_its_tick_skips(scene):
    # its one-call tick skips xi, push, bounce, lo, hi, bound_row and JM of the contact rows
    # (reads_targets = False): built or not, the states are bit for bit the same
    make = {"pyramid": lambda r: scenes.pyramid(8, responder=r), "mixed": lambda r: scenes.mixed_shapes(12, r)}
    lean, full = make[scene](phys2d.SoftStep()), make[scene](_ReadsTargets())
    for _ in range(90):
        lean.step(1 / 60)
        full.step(1 / 60)
    assert len(lean.contacts) > 0
    for name in ("x", "theta", "V"):
        assert np.array_equal(getattr(lean, name), getattr(full, name))


def test_a_soft_step_whose_respond_is_replaced_is_given_every_row_field():
    w = scenes.pyramid(5, responder=phys2d.SoftStep())
    rows, M_inv = rows_after(w, w.responder, 30)
    k_n, k_t = np.asarray(rows.normal_row), np.asarray(rows.friction_row)
    a, b = rows.body_a, rows.body_b
    # JM = M^-1 J^T, row by row, as the lecture forms it
    assert np.array_equal(rows.JM[:, :3], M_inv[a] * rows.J[:, :3])
    assert np.array_equal(rows.JM[:, 3:], M_inv[b] * rows.J[:, 3:])
    # the normal rows: lambda in [0, inf); the friction rows: Coulomb's cone on their normal row
    assert np.all(rows.lo[k_n] == 0.0) and np.all(rows.hi[k_n] == np.inf) and np.all(rows.bound_row[k_n] == -1)
    assert np.array_equal(rows.bound_row[k_t], k_n)
    assert np.all(rows.mu[k_t] > 0.0) and np.all(np.isfinite(rows.xi)) and np.all(rows.push == 0.0)  # beta = 0


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.floats(-1.0, 1.0), min_size=4, max_size=4),  # r_a, r_b (m)
    st.floats(0.0, 2.0 * np.pi),  # the normal's direction
    st.lists(st.floats(-0.2, 0.2), min_size=4, max_size=4),  # each body's dx, dy since the tick began (m)
    st.lists(st.floats(-0.5, 0.5), min_size=2, max_size=2),  # and its turn (rad)
    st.floats(-0.1, 0.1),  # C0 (m)
)
def test_separation_now_is_the_moved_anchors_apart_along_n(arms, angle, shift, turn, C0):
    """``separation_now`` reads n and the arms' products from the point's two rows; a second
    method moves the anchors themselves: C = C0 + n . ((x_b + R_b r_b) - (x_a + R_a r_a)) less
    the same at the start (x + r)."""
    from phys2d.constraints.rows import jacobian
    from phys2d.responders.soft_integrate import cos_less_one_sin
    from phys2d.responders.soft_points import separation_now

    n = np.array([np.cos(angle), np.sin(angle)])
    r = np.array(arms).reshape(2, 2)
    J = np.array([jacobian(*arms, n[0], n[1]), jacobian(*arms, -n[1], n[0])])
    moved = np.array([[*shift[2 * body : 2 * body + 2], *cos_less_one_sin(turn[body])] for body in (0, 1)])

    def anchor_moved(body: int) -> np.ndarray:
        c, s = np.cos(turn[body]), np.sin(turn[body])
        return np.array(shift[2 * body : 2 * body + 2]) + np.array([[c, -s], [s, c]]) @ r[body] - r[body]

    expected = C0 + n @ (anchor_moved(1) - anchor_moved(0))
    got = separation_now(0, 0, 1, 0, 1, np.array([C0]), J, moved)
    assert got == pytest.approx(expected, abs=1e-14)
