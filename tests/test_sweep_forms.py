"""The sweep's arithmetic against the lecture's, and the 2x2 LCP that the block solvers share
(``phys2d.responders.pgs``): rows divided by A_kk once per step must give the lecture's update
lambda_k + (xi_k - J_k V) / A_kk, and lcp2 must solve the LCP it names."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st
from numba import njit

import phys2d
from phys2d import scenes
from phys2d.constraints.rows import apply_row_impulse, row_velocity
from phys2d.pipeline.records import ROW_FIELDS, arrays_of, new_rows
from phys2d.responders.pgs import apply_impulses, lcp2, per_unit_A, sweep


def rows_of_a_pile():
    """The rows of pyramid_5's 40th step under PGS, and the velocities they start from."""
    w = scenes.pyramid(5, phys2d.PGS())
    seen = {}
    keep = w.responder.respond

    def spy(ctx):
        r = ctx.rows
        seen.update(rows=r, lam=r.lam.copy(), V=ctx.V.copy())
        return keep(ctx)

    w.one_call_tick = False
    for _ in range(39):
        w.step(1 / 60)
    w.responder.respond = spy  # type: ignore[method-assign]
    w.step(1 / 60)
    return seen["rows"], seen["lam"], seen["V"]


def lecture_sweep(r, lam, V):
    """One sweep written as the slide has it: delta = (xi_k - J_k V) / A_kk, clamp, apply."""
    for k in range(len(lam)):
        if r.A_kk[k] <= 0.0:
            continue
        if r.bound_row[k] >= 0:
            top = r.mu[k] * lam[r.bound_row[k]]
            low, high = -top, top
        else:
            low, high = r.lo[k], r.hi[k]
        a, b = r.body_a[k], r.body_b[k]
        delta = (r.xi[k] - row_velocity(k, a, b, r.J, V)) / r.A_kk[k]
        new = min(max(lam[k] + delta, low), high)
        apply_row_impulse(k, a, b, r.JM, new - lam[k], V)
        lam[k] = new


def test_rows_per_unit_A_give_the_lecture_s_sweep():
    r, lam0, V0 = rows_of_a_pile()
    lam_a, V_a = lam0.copy(), V0.copy()
    lam_b, V_b = lam0.copy(), V0.copy()
    rows_a = new_rows((*arrays_of(r, ROW_FIELDS[:-1]), lam_a))  # the rows, with lambda lam_a
    hat = per_unit_A(rows_a)
    J_hat, xi_hat = njit(lambda rows: (rows.J, rows.xi))(hat)  # (a record's fields are read in a kernel)
    live = r.A_kk > 0.0
    assert np.allclose(J_hat[live] * r.A_kk[live, None], r.J[live], rtol=1e-14, atol=0.0)
    assert np.allclose(xi_hat[live] * r.A_kk[live], r.xi[live], rtol=1e-14, atol=1e-300)
    assert not J_hat[~live].any() and not xi_hat[~live].any()
    apply_impulses(rows_a, V_a)
    apply_impulses(new_rows((*arrays_of(r, ROW_FIELDS[:-1]), lam_b)), V_b)
    visit = np.arange(len(lam_a), dtype=r.normal_row.dtype)
    for _ in range(5):
        sweep(hat, V_a, visit)
        lecture_sweep(r, lam_b, V_b)
    scale = 1.0 + np.abs(lam_b).max()
    assert np.abs(lam_a).max() > 0.0  # a pile under load: the comparison is not of zeros
    np.testing.assert_allclose(lam_a, lam_b, rtol=0, atol=1e-12 * scale)
    np.testing.assert_allclose(V_a, V_b, rtol=0, atol=1e-12 * (1.0 + np.abs(V_b).max()))


finite = st.floats(-10.0, 10.0, allow_nan=False)


@given(st.floats(0.1, 10.0), st.floats(0.1, 10.0), st.floats(-0.95, 0.95), finite, finite)
def test_lcp2_solves_the_2x2_lcp(K11, K22, c, b1, b2):
    """x >= 0, w = K x + b >= 0 and x . w = 0, for symmetric positive definite K (K12 = c
    sqrt(K11 K22), |c| < 1), with the caller's 1 / det K."""
    K12 = c * np.sqrt(K11 * K22)
    det = K11 * K22 - K12 * K12
    x1, x2 = lcp2(K11, K12, K22, 1.0 / det, b1, b2)
    w1, w2 = K11 * x1 + K12 * x2 + b1, K12 * x1 + K22 * x2 + b2
    tol = 1e-9 * (1.0 + abs(b1) + abs(b2)) / min(1.0, 1.0 - c * c)
    assert x1 >= 0.0 and x2 >= 0.0
    assert w1 >= -tol and w2 >= -tol
    assert abs(x1 * w1) <= tol * (1.0 + x1) and abs(x2 * w2) <= tol * (1.0 + x2)
