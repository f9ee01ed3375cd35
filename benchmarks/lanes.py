"""The soft step's normal rows in lanes (issue 45 item 2), measured against the scalar sweep.

    python benchmarks/lanes.py                 # large_pyramid: bits, then µs per pass (~20 s cached)
    python benchmarks/lanes.py --base 40       # a smaller pyramid
    python benchmarks/lanes.py --asm           # also count packed and scalar float64 instructions

An experiment kept with its measurements (benchmarks/LANES.md), not a part of the engine: the
engine's sweep stays ``soft_contacts.soft_normal_rows``, which these lanes did not beat here.

``soft_contacts.soft_normal_rows`` solves one manifold after another. A two-point block
(``lcp2``) is a chain of ~45 dependent adds and multiplies, and the next manifold waits on it
(benchmarks/FLOOR.md). Manifolds that share no moving body do not wait on each other:
Gauss-Seidel over them gives the same numbers in any order. In colour order
(``constraints.order``) consecutive manifolds rarely share a body, so the solve order splits
into *runs* of up to ``LANES`` manifolds that share none (``lane_runs``). A run is solved in
three loops:

    gather   each manifold's pair velocities V_ab, impulses lambda and separations C (or what
             they are worked out from: its bodies' motion and C0) into the run's lanes
             (structure of arrays: one row per quantity, one column per manifold)
    solve    ``soft_normal_rows``' arithmetic on every lane at once (``normal_lanes``): a loop
             with no branch and no store outside the lanes, which LLVM turns into packed
             instructions (AVX-512: 8 doubles; AVX2: 4)
    scatter  each manifold's new lambdas, V_ab and separations back

A branch of the scalar sweep becomes a select: each lane works out both the block's answer and
the rows' one by one, and keeps the one its manifold takes in this sweep. What stays over the
tick (the rows' J, the pair's M^-1, K, 1 / det K, the push's constants) is gathered once per
tick by ``prepare_lanes``, run by run. The arithmetic is the scalar sweep's, operation for
operation, with no fastmath: ``main`` checks that the lanes give its bits, sweep after sweep.
"""

from __future__ import annotations

import argparse
import collections
import copy
import re
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

BENCH_DIR = Path(__file__).resolve().parent
sys.path.insert(0, str(BENCH_DIR))  # floor.py, beside this script
sys.path.insert(0, str(BENCH_DIR.parent))  # the phys2d of this checkout

import floor  # noqa: E402

import phys2d  # noqa: E402
from phys2d.constraints.rows import (  # noqa: E402
    MET,
    pair_inverse_mass,
    pair_row_impulse_of,
    pair_velocity,
    store_pair_velocity,
    unsigned_rows,
)
from phys2d.jit import njit  # noqa: E402
from phys2d.pipeline import records  # noqa: E402
from phys2d.responders.block import inverse_diagonal  # noqa: E402
from phys2d.responders.soft_contacts import (  # noqa: E402
    prepare_manifolds,
    soft_block,
    soft_constants,
    soft_normal_rows,
)
from phys2d.responders.soft_points import Points  # noqa: E402

LANES = 32  # the most manifolds in a run: a run's lanes (~13 kB) stay in L1

# the tick's constants per manifold (``prepare_lanes``), one row each
J1, J2 = 0, 6  # J of each point's normal row (6 rows each)
MA = 12  # the pair's M^-1 (6 rows, ``pair_inverse_mass``)
K11, K22, K12, INV_DET = 18, 19, 20, 21  # A_kk of both normal rows, J_1 M^-1 J_2^T, 1 / det K (``lcp2``)
INV_A1, INV_A2, BLOCK = 22, 23, 24  # 1 / A_kk of both rows; 1.0: a block (``manifold_constants``)
RATE, MASS_SCALE, IMPULSE_SCALE, PUSH_MAX = 25, 26, 27, 28  # its spring (``soft_constants``)
T1, T2 = 29, 31  # each point's friction row's J[2] and J[5] (-n.r_a, n.r_b: ``separation_now``)
N_CONSTANTS = 33

# a run's lanes per sweep (``normal_lanes``), one row each: what it reads ...
V_AB = 0  # the pair's velocities (6 rows)
LAM1, LAM2, C1, C2 = 6, 7, 8, 9  # lambda and separation C of both points (C: when not new_C)
MOVED_A, MOVED_B = 10, 14  # its bodies' moved (4 rows each: dx, dy, cos - 1, sin) ...
C0_1, C0_2 = 18, 19  # ... and its points' C0, when new_C
N_IN = 20
# ... and what it writes: V_AB, then
X1, X2, NEW_C1, NEW_C2, WORST = 6, 7, 8, 9, 10  # lambdas, separations, |delta lambda| A_kk
N_OUT = 11


@njit(cache=True)
def lane_runs(start, rows, M_inv, V, breaks):
    """Where each run of manifolds begins (``run_start``, (R + 1,)): consecutive manifolds in
    solve order, at most ``LANES``, a new run at each manifold in ``breaks`` (ascending: where
    the threads' segments begin, ``pipeline.parallel``), no two sharing a body, unless that body stays as it is:
    M^-1 = 0, so an impulse adds +-0 to its V, which leaves V's bits alone unless a component
    is -0 (-0 + +0 = +0: then the order of the adds would show)."""
    normal_row, body_a, body_b = rows.normal_row, rows.body_a, rows.body_b
    n = start.shape[0] - 1
    shared = np.empty(M_inv.shape[0], np.bool_)  # a body any lanes may share
    for b in range(M_inv.shape[0]):
        shared[b] = M_inv[b, 0] == 0.0 and M_inv[b, 1] == 0.0 and M_inv[b, 2] == 0.0
        for q in range(3):
            shared[b] = shared[b] and not (V[b, q] == 0.0 and np.signbit(V[b, q]))
    last_run = np.full(M_inv.shape[0], -1, np.int64)  # the run that last took each body
    run_start = np.empty(n + 1, np.int64)
    runs = 0
    begun = 0
    j = 0  # the next break
    for m in range(n):
        k = normal_row[start[m]]
        a, b = body_a[k], body_b[k]
        taken = (not shared[a] and last_run[a] == runs - 1) or (not shared[b] and last_run[b] == runs - 1)
        cut = j < breaks.shape[0] and breaks[j] == m
        if cut:
            j += 1
        if runs == 0 or taken or cut or m - begun == LANES:
            run_start[runs] = m
            runs += 1
            begun = m
        last_run[a] = runs - 1
        last_run[b] = runs - 1
    run_start[runs] = n
    return run_start[: runs + 1]


@njit(cache=True)
def prepare_lanes(manifolds, run_start, rows, inv_A_kk, M_inv, springs):
    """What a run's lanes read over the whole tick (``normal_lanes``): per run r, L[r] holds
    ``N_CONSTANTS`` rows of ``LANES`` lanes, one lane per manifold: J of its normal rows, the
    pair's M^-1, A_kk and 1 / A_kk of its rows, the block's K12 and 1 / det K
    (``soft_contacts.manifold_constants``), its spring (static partner or not,
    ``soft_constants``) and the friction rows' J that its separations read. A one-point
    manifold's missing row has A_kk = 0 (no row: its lane leaves it alone); a lane past the
    run's end holds zeros but K11 = K22 = 1 (no lane divides by zero)."""
    start, static_pair, K12_m, as_block, inv_det = manifolds
    normal_row, friction_row, body_a, body_b = rows.normal_row, rows.friction_row, rows.body_a, rows.body_b
    J, A_kk = rows.J, rows.A_kk
    W = LANES
    L = np.zeros((run_start.shape[0] - 1, N_CONSTANTS * W))
    for r in range(run_start.shape[0] - 1):
        for i in range(run_start[r + 1] - run_start[r], W):
            L[r, K11 * W + i] = L[r, K22 * W + i] = 1.0
        for m in range(run_start[r], run_start[r + 1]):
            i = m - run_start[r]
            k = normal_row[start[m]]
            a, b = body_a[k], body_b[k]
            for p in range(start[m + 1] - start[m]):  # each point's rows
                kn, kt = normal_row[start[m] + p], friction_row[start[m] + p]
                for q in range(6):
                    L[r, (J1 + 6 * p + q) * W + i] = J[kn, q]
                L[r, (K11 + p) * W + i], L[r, (INV_A1 + p) * W + i] = A_kk[kn], inv_A_kk[kn]
                L[r, (T1 + 2 * p) * W + i], L[r, (T1 + 2 * p + 1) * W + i] = J[kt, 2], J[kt, 5]
            for q in range(3):
                L[r, (MA + q) * W + i] = M_inv[a, q]
                L[r, (MA + 3 + q) * W + i] = M_inv[b, q]
            L[r, K12 * W + i], L[r, INV_DET * W + i] = K12_m[m], inv_det[m]
            L[r, BLOCK * W + i] = 1.0 if as_block[m] else 0.0
            soft = springs[1] if static_pair[m] else springs[0]
            L[r, RATE * W + i], L[r, MASS_SCALE * W + i] = soft[0], soft[1]
            L[r, IMPULSE_SCALE * W + i], L[r, PUSH_MAX * W + i] = soft[2], soft[3]
    return L


@njit(cache=True)
def normal_lanes(n, L, lanes_in, lanes_out, h, use_bias, new_C):
    """``soft_normal_rows`` on lanes 0..n-1 of a run: each point's separation (worked out
    afresh if new_C, ``separation_now``), then the manifold solved as a 2x2 block (``lcp2``)
    or row by row (each row of a point that touches, or any with the push, clamped to lambda >=
    0), whichever ``soft_normal_rows`` would take: every choice a select, so that the loop has
    no branch. Reads the tick's constants L and the run's lanes_in; writes V_ab, the new
    lambdas and separations and |delta lambda| A_kk into lanes_out.

    Each array is flat, row after row of ``LANES`` lanes (``lane``): rows a constant apart let
    LLVM see that the loop's stores never meet its loads, and a lane index from 0 spares
    numba's wraparound select on a negative index, which would make every load a gather."""
    for i in range(n):
        V_ab, J_1, J_2, M_ab, soft, K, a1, a2 = manifold_of_lane(L, lanes_in, i)
        K_11, K_12, K_22, _ = K
        if new_C:  # the bodies moved since the last sweep
            moved_a, moved_b = lane4(lanes_in, MOVED_A, i), lane4(lanes_in, MOVED_B, i)
            s1 = separation_of(lane(lanes_in, C0_1, i), J_1, lane(L, T1, i), lane(L, T1 + 1, i), moved_a, moved_b)
            s2 = separation_of(lane(lanes_in, C0_2, i), J_2, lane(L, T2, i), lane(L, T2 + 1, i), moved_a, moved_b)
        else:
            s1, s2 = lane(lanes_in, C1, i), lane(lanes_in, C2, i)
        bias1, ms1, is1 = soft_push_by_selects(s1, h, use_bias, soft)
        bias2, ms2, is2 = soft_push_by_selects(s2, h, use_bias, soft)
        x1, x2, V_block, worst_block = block_answer(
            J_1, J_2, M_ab, V_ab, K, a1, a2, (bias1, ms1, is1), (bias2, ms2, is2)
        )
        # row by row: relax leaves a point still apart alone
        on1 = (K_11 > 0.0) & (use_bias | (s1 <= MET))
        on2 = (K_22 > 0.0) & (use_bias | (s2 <= MET))
        V_1, y1, w1 = row_on_its_own(J_1, M_ab, V_ab, a1, s1, bias1, ms1, is1, lane(L, INV_A1, i), K_11, on1)
        V_2, y2, w2 = row_on_its_own(J_2, M_ab, V_1, a2, s2, bias2, ms2, is2, lane(L, INV_A2, i), K_22, on2)
        block = (lane(L, BLOCK, i) != 0.0) & (use_bias | ((s1 <= MET) & (s2 <= MET)))
        for q in range(6):
            lanes_out[(V_AB + q) * LANES + i] = V_block[q] if block else V_2[q]
        lanes_out[X1 * LANES + i] = x1 if block else y1
        lanes_out[X2 * LANES + i] = x2 if block else y2
        lanes_out[NEW_C1 * LANES + i] = s1
        lanes_out[NEW_C2 * LANES + i] = s2
        lanes_out[WORST * LANES + i] = worst_block if block else max(w1, w2)


@njit(cache=True, inline="always")
def manifold_of_lane(L, lanes_in, i):
    """What lane i holds of its manifold: (V_ab, J of both normal rows, the pair's M^-1, its
    spring, K = (K11, K12, K22, 1 / det K), both lambdas)."""
    soft = (lane(L, RATE, i), lane(L, MASS_SCALE, i), lane(L, IMPULSE_SCALE, i), lane(L, PUSH_MAX, i))
    K = (lane(L, K11, i), lane(L, K12, i), lane(L, K22, i), lane(L, INV_DET, i))
    return (
        lane6(lanes_in, V_AB, i), lane6(L, J1, i), lane6(L, J2, i), lane6(L, MA, i), soft, K,
        lane(lanes_in, LAM1, i), lane(lanes_in, LAM2, i),
    )  # fmt: skip


@njit(cache=True, inline="always")
def block_answer(J_1, J_2, M_ab, V_ab, K, a1, a2, push1, push2):
    """A manifold's two normal rows solved as a block (``soft_normal_rows``): b from each row's
    push (bias, mass_scale, impulse_scale: ``soft_push_by_selects``), the 2x2 LCP
    (``lcp2_by_selects``; K = (K11, K12, K22, 1 / det K)), both impulses onto V_ab. Returns
    (lambda_1, lambda_2, V_ab, the larger |delta lambda| A_kk)."""
    K_11, K_12, K_22, inv_det = K
    (bias1, ms1, is1), (bias2, ms2, is2) = push1, push2
    b1 = ms1 * (row_velocity_of(J_1, V_ab) + bias1) + is1 * K_11 * a1 - (K_11 * a1 + K_12 * a2)
    b2 = ms2 * (row_velocity_of(J_2, V_ab) + bias2) + is2 * K_22 * a2 - (K_12 * a1 + K_22 * a2)
    x1, x2 = lcp2_by_selects(K_11, K_12, K_22, inv_det, b1, b2)
    V_block = row_impulse_of(J_2, M_ab, x2 - a2, row_impulse_of(J_1, M_ab, x1 - a1, V_ab))
    return x1, x2, V_block, max(abs(x1 - a1) * K_11, abs(x2 - a2) * K_22)


@njit(cache=True, inline="always")
def row_on_its_own(J_k, M_ab, V_ab, old, s, bias, mass_scale, impulse_scale, inv_A, A, on):
    """One normal row solved alone (``soft_normal_rows``, a manifold that is no block):
    delta lambda = -mass_scale (J V + bias) / A_kk - impulse_scale lambda, the accumulated
    impulse clamped to >= 0 (``clamp_accumulated``), onto V_ab; a row that is not ``on`` leaves
    V_ab and lambda as they were, by select. Returns (V_ab, lambda, |delta lambda| A_kk)."""
    d = -mass_scale * (row_velocity_of(J_k, V_ab) + bias) * inv_A - impulse_scale * old
    applied = min(max(d, 0.0 - old), np.inf - old)
    new = min(max(old + applied, 0.0), np.inf)
    V_new = row_impulse_of(J_k, M_ab, applied, V_ab)
    V_out = (
        V_new[0] if on else V_ab[0], V_new[1] if on else V_ab[1], V_new[2] if on else V_ab[2],
        V_new[3] if on else V_ab[3], V_new[4] if on else V_ab[4], V_new[5] if on else V_ab[5],
    )  # fmt: skip
    return V_out, new if on else old, abs(applied) * A if on else 0.0


@njit(cache=True, inline="always")
def separation_of(C0, J_k, t2, t5, moved_a, moved_b):
    """``soft_points.separation_now`` from the lanes: C0 and its normal row J_k, its friction
    row's J[2] and J[5] (t2, t5), its bodies' moved."""
    along_n = J_k[3] * (moved_b[0] - moved_a[0]) + J_k[4] * (moved_b[1] - moved_a[1])
    turned_b = moved_b[2] * t5 + moved_b[3] * J_k[5]
    turned_a = moved_a[2] * t2 + moved_a[3] * J_k[2]
    return C0 + along_n + (turned_b + turned_a)


@njit(cache=True, inline="always")
def manifold_at(m, start, normal_row, body_a, body_b):
    """Manifold m's first point c, whether it has two points, its first normal row k and its
    bodies a, b: what the gather and the scatter both look up."""
    c = start[m]
    k = normal_row[c]
    return c, start[m + 1] - c == 2, k, body_a[k], body_b[k]


@njit(cache=True, inline="always")
def lane(A, row, i):
    """Lane i of a row of a flat lanes array."""
    return A[row * LANES + i]


@njit(cache=True, inline="always")
def lane4(A, row, i):
    """Lane i of four rows from ``row`` on: a body's moved."""
    W = LANES
    return A[row * W + i], A[(row + 1) * W + i], A[(row + 2) * W + i], A[(row + 3) * W + i]


@njit(cache=True, inline="always")
def lane6(A, row, i):
    """Lane i of six rows from ``row`` on: a J, an M^-1 or a V_ab (``pair_velocity``)."""
    W = LANES
    return (A[row * W + i], A[(row + 1) * W + i], A[(row + 2) * W + i], A[(row + 3) * W + i], A[(row + 4) * W + i],
            A[(row + 5) * W + i])  # fmt: skip


@njit(cache=True, inline="always")
def row_velocity_of(J_k, V_ab):
    """J_k V_ab, summed as ``pair_row_velocity``'s tree."""
    return (
        (J_k[0] * V_ab[0] + J_k[1] * V_ab[1])
        + (J_k[2] * V_ab[2] + J_k[5] * V_ab[5])
        + (J_k[3] * V_ab[3] + J_k[4] * V_ab[4])
    )


@njit(cache=True, inline="always")
def row_impulse_of(J_k, M_ab, impulse, V_ab):
    """V_ab + M^-1 J_k^T impulse, as ``pair_row_impulse_of`` forms it."""
    return (
        V_ab[0] + (M_ab[0] * J_k[0]) * impulse,
        V_ab[1] + (M_ab[1] * J_k[1]) * impulse,
        V_ab[2] + (M_ab[2] * J_k[2]) * impulse,
        V_ab[3] + (M_ab[3] * J_k[3]) * impulse,
        V_ab[4] + (M_ab[4] * J_k[4]) * impulse,
        V_ab[5] + (M_ab[5] * J_k[5]) * impulse,
    )


@njit(cache=True, inline="always")
def soft_push_by_selects(s, h, use_bias, soft):
    """``soft_contacts.soft_push`` as selects: (bias m/s, mass_scale, impulse_scale) of a normal
    row whose separation is s (m): speculative (s > 0), the soft push (with bias), or none."""
    bias = s / h if s > 0.0 else (max(soft[0] * s, -soft[3]) if use_bias else 0.0)
    mass_scale = 1.0 if s > 0.0 else (soft[1] if use_bias else 1.0)
    impulse_scale = 0.0 if s > 0.0 else (soft[2] if use_bias else 0.0)
    return bias, mass_scale, impulse_scale


@njit(cache=True, inline="always")
def lcp2_by_selects(K11, K12, K22, inv_det, b1, b2):
    """``block.lcp2`` as selects: every active set's answer worked out, the first that holds
    taken (both rows push, only row 1, only row 2, neither)."""
    y1 = -(K22 * b1 - K12 * b2) * inv_det
    y2 = -(K11 * b2 - K12 * b1) * inv_det
    z1 = -b1 / K11
    z2 = -b2 / K22
    both = (y1 >= 0.0) & (y2 >= 0.0)
    one = (z1 >= 0.0) & (K12 * z1 + b2 >= 0.0)
    two = (z2 >= 0.0) & (K12 * z2 + b1 >= 0.0)
    x1 = y1 if both else (z1 if one else 0.0)
    x2 = y2 if both else (0.0 if one else (z2 if two else 0.0))
    return x1, x2


@njit(cache=True)
def soft_normal_rows_in_lanes(
    first, last, rows, manifolds, lanes, inv_A_kk, points, M_inv, V, h, use_bias, springs, new_C
):  # fmt: skip
    """``soft_contacts.soft_normal_rows`` of manifolds first up to last, run by run
    (``lane_runs``): the same arguments, with lanes = (run_start, L) from ``prepare_lanes_on``
    (first must begin a run); the same bits. Returns the largest |delta lambda| A_kk (m/s)."""
    run_start, L = lanes
    normal_row, body_a, body_b, lam = rows.normal_row, rows.body_a, rows.body_b, rows.lam
    C, C0, moved = points.C, points.C0, points.moved
    start = manifolds[0]
    W = LANES
    lanes_in, lanes_out = np.zeros(N_IN * W), np.empty(N_OUT * W)
    worst = 0.0
    r = np.searchsorted(run_start, first)  # (first begins a run: lane_runs' breaks)
    while r < run_start.shape[0] - 1 and run_start[r] < last:
        m0 = run_start[r]
        n = run_start[r + 1] - m0
        for i in range(n):  # gather
            c, two, k, a, b = manifold_at(m0 + i, start, normal_row, body_a, body_b)
            for q in range(3):
                lanes_in[(V_AB + q) * W + i] = V[a, q]
                lanes_in[(V_AB + 3 + q) * W + i] = V[b, q]
            lanes_in[LAM1 * W + i] = lam[k]
            lanes_in[LAM2 * W + i] = lam[normal_row[c + 1]] if two else 0.0
            if new_C:
                for q in range(4):
                    lanes_in[(MOVED_A + q) * W + i] = moved[a, q]
                    lanes_in[(MOVED_B + q) * W + i] = moved[b, q]
                lanes_in[C0_1 * W + i] = C0[c]
                lanes_in[C0_2 * W + i] = C0[c + 1] if two else 0.0
            else:
                lanes_in[C1 * W + i] = C[c]
                lanes_in[C2 * W + i] = C[c + 1] if two else 0.0
        normal_lanes(n, L[r], lanes_in, lanes_out, h, use_bias, new_C)
        for i in range(n):  # scatter
            c, two, k, a, b = manifold_at(m0 + i, start, normal_row, body_a, body_b)
            for q in range(3):
                V[a, q] = lanes_out[(V_AB + q) * W + i]
                V[b, q] = lanes_out[(V_AB + 3 + q) * W + i]
            lam[k] = lanes_out[X1 * W + i]
            if new_C:
                C[c] = lanes_out[NEW_C1 * W + i]
            if two:
                lam[normal_row[c + 1]] = lanes_out[X2 * W + i]
                if new_C:
                    C[c + 1] = lanes_out[NEW_C2 * W + i]
            worst = max(worst, lanes_out[WORST * W + i])
        r += 1
    return worst


# -- two manifolds at a time, no lanes (``--pairs``) --------------------------------------------------
@njit(cache=True)
def soft_normal_rows_in_pairs(first, last, rows, manifolds, inv_A_kk, points, M_inv, V, h, use_bias, springs, new_C):
    """``soft_contacts.soft_normal_rows`` with two consecutive blocks that share no body (not even
    a static one) solved side by side: both pairs' V_ab loaded before either is stored, so that
    the two chains of dependent arithmetic (FLOOR.md) are in flight at once. Sweeps with the push
    on the positions the tick began with only (use_bias and not new_C); the rest, one manifold
    at a time. The same arguments and bits."""
    normal_row, body_a, body_b = rows.normal_row, rows.body_a, rows.body_b
    J, A_kk, lam = rows.J, rows.A_kk, rows.lam
    soft_dyn, soft_static = springs[0], springs[1]
    C = points.C
    start, static_pair, K12, as_block, inv_det = manifolds
    worst = 0.0
    m = first
    while m < last:
        c, d = start[m], start[m + 1]
        k = normal_row[c]
        a, b = body_a[k], body_b[k]
        if use_bias and not new_C and m + 1 < last and as_block[m] and as_block[m + 1]:
            l = normal_row[d]
            e, f = body_a[l], body_b[l]
            if e != a and e != b and f != a and f != b:
                k2, l2 = normal_row[c + 1], normal_row[d + 1]
                V_ab, V_ef = pair_velocity(a, b, V), pair_velocity(e, f, V)
                M_ab, M_ef = pair_inverse_mass(a, b, M_inv), pair_inverse_mass(e, f, M_inv)
                soft_m = soft_static if static_pair[m] else soft_dyn
                soft_n = soft_static if static_pair[m + 1] else soft_dyn
                block_rows = (J, A_kk, lam)
                x1, x2, a1, a2, K11, K22 = soft_block(
                    k, k2, (K12[m], inv_det[m]), (C[c], C[c + 1]), V_ab, block_rows, (h, use_bias, soft_m)
                )
                y1, y2, e1, e2, L11, L22 = soft_block(
                    l, l2, (K12[m + 1], inv_det[m + 1]), (C[d], C[d + 1]), V_ef, block_rows, (h, use_bias, soft_n)
                )
                V_ab = pair_row_impulse_of(k2, J, M_ab, x2 - a2, pair_row_impulse_of(k, J, M_ab, x1 - a1, V_ab))
                V_ef = pair_row_impulse_of(l2, J, M_ef, y2 - e2, pair_row_impulse_of(l, J, M_ef, y1 - e1, V_ef))
                lam[k], lam[k2], lam[l], lam[l2] = x1, x2, y1, y2
                worst = max(worst, abs(x1 - a1) * K11, abs(x2 - a2) * K22, abs(y1 - e1) * L11, abs(y2 - e2) * L22)
                store_pair_velocity(a, b, V_ab, V)
                store_pair_velocity(e, f, V_ef, V)
                m += 2
                continue
        worst = max(
            worst, soft_normal_rows(m, m + 1, rows, manifolds, inv_A_kk, points, M_inv, V, h, use_bias, springs, new_C)
        )
        m += 1
    return worst


# -- the measurement --------------------------------------------------------------------------------
def best_of(call: Callable[[], object], repeats: int) -> float:
    """µs of the best of ``repeats`` calls (after one untimed: compiled or loaded)."""
    call()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        call()
        times.append(time.perf_counter() - t0)
    return min(times) * 1e6


@njit(cache=True)
def lanes_only(run_start, L, lanes_in, lanes_out, h, new_C):
    """``normal_lanes`` over every run, on whatever the lanes hold: the solve loop alone."""
    for r in range(run_start.shape[0] - 1):
        normal_lanes(run_start[r + 1] - run_start[r], L[r], lanes_in, lanes_out, h, True, new_C)


@njit(cache=True)
def block_lanes(n, L, lanes_in, lanes_out, h, use_bias):
    """``normal_lanes`` for a run of blocks only: the block's answer alone (no rows one by one,
    no separations worked out), to measure what the other path costs. Not used by the sweep."""
    for i in range(n):
        V_ab, J_1, J_2, M_ab, soft, K, a1, a2 = manifold_of_lane(L, lanes_in, i)
        push1 = soft_push_by_selects(lane(lanes_in, C1, i), h, use_bias, soft)
        push2 = soft_push_by_selects(lane(lanes_in, C2, i), h, use_bias, soft)
        x1, x2, V_block, worst = block_answer(J_1, J_2, M_ab, V_ab, K, a1, a2, push1, push2)
        for q in range(6):
            lanes_out[(V_AB + q) * LANES + i] = V_block[q]
        lanes_out[X1 * LANES + i] = x1
        lanes_out[X2 * LANES + i] = x2
        lanes_out[WORST * LANES + i] = worst


@njit(cache=True)
def block_lanes_only(run_start, L, lanes_in, lanes_out, h):
    """``block_lanes`` over every run, on whatever the lanes hold."""
    for r in range(run_start.shape[0] - 1):
        block_lanes(run_start[r + 1] - run_start[r], L[r], lanes_in, lanes_out, h, True)


@njit(cache=True)
def gather_and_scatter(run_start, start, rows, V, lanes):
    """The lanes' gather and scatter of V_ab and the two lambdas alone, run by run."""
    normal_row, body_a, body_b, lam = rows.normal_row, rows.body_a, rows.body_b, rows.lam
    W = LANES
    for r in range(run_start.shape[0] - 1):
        m0, n = run_start[r], run_start[r + 1] - run_start[r]
        for i in range(n):
            k = normal_row[start[m0 + i]]
            a, b = body_a[k], body_b[k]
            for q in range(3):
                lanes[(V_AB + q) * W + i] = V[a, q]
                lanes[(V_AB + 3 + q) * W + i] = V[b, q]
            lanes[LAM1 * W + i] = lam[k]
        for i in range(n):
            k = normal_row[start[m0 + i]]
            a, b = body_a[k], body_b[k]
            for q in range(3):
                V[a, q] = lanes[(V_AB + q) * W + i]
                V[b, q] = lanes[(V_AB + 3 + q) * W + i]
            lam[k] = lanes[LAM1 * W + i]


def instruction_counts() -> dict[str, int]:
    """Packed and scalar float64 instructions in ``normal_lanes``' machine code, compiled afresh."""
    from numba import njit as plain_njit

    fresh = plain_njit(error_model="numpy")(normal_lanes.py_func)  # (cached code has no assembly to show)
    fresh(LANES, np.zeros(N_CONSTANTS * LANES), np.zeros(N_IN * LANES), np.zeros(N_OUT * LANES), 0.004, True, True)
    asm = next(iter(fresh.inspect_asm().values()))
    ops = collections.Counter(re.findall(r"\n\s+(v\w+)\s", asm))
    return {
        "packed (…pd)": sum(v for k, v in ops.items() if k.endswith("pd")),
        "scalar (…sd)": sum(v for k, v in ops.items() if k.endswith("sd")),
        "zmm operands": asm.count("zmm"),
        "ymm operands": asm.count("ymm"),
    }


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0], formatter_class=argparse.RawTextHelpFormatter)
    p.add_argument("--base", type=int, default=100, help="boxes at the pyramid's base (default 100: large_pyramid)")
    p.add_argument("--settle", type=int, default=60, help="steps before the tick is taken (default 60)")
    p.add_argument("--repeats", type=int, default=21, help="calls of each pass; the best is kept (default 21)")
    p.add_argument("--asm", action="store_true", help="count normal_lanes' packed and scalar instructions")
    p.add_argument("--pairs", action="store_true", help="also two blocks side by side, no lanes (LANES.md)")
    args = p.parse_args(argv)
    scene = floor.measure_scene(args.base, args.settle, 1, 1)
    soft = phys2d.SoftStep(floor.SUBSTEPS)
    ctx = scene.ctx
    rows = copy.copy(ctx.rows)
    M_inv = ctx.M_inv
    N, K = M_inv.shape[0], rows.n_contacts
    C0 = ctx.separation[rows.order]
    h = floor.DT / floor.SUBSTEPS
    hertz = min(soft.contact_hertz, 0.25 / h)
    springs = (
        soft_constants(hertz, soft.damping_ratio, h, soft.push_max),
        soft_constants(2.0 * hertz, soft.damping_ratio, h, soft.push_max),
        soft_constants(min(soft.joint_hertz, 0.25 / h), soft.joint_damping_ratio, h, np.inf),
    )
    inv_A_kk = inverse_diagonal(rows.A_kk)
    moved = np.random.default_rng(0).normal(0.0, 1e-4, (N, 4))  # the bodies' motion since the tick began
    moved[:, 2] = -(moved[:, 3] ** 2) / 2  # cos dtheta - 1 of a small turn

    def fresh() -> tuple:
        """The tick's rows (lambda per sub-step), bodies' V and points, copies: each way its own."""
        r = copy.copy(rows)
        r.lam = scene.lam_in / floor.SUBSTEPS
        C = C0.copy()
        points = Points(
            C0, np.zeros(K), C, moved, scene.V_in.copy(), np.arange(K, dtype=np.uint32), np.zeros(K, np.bool_),
            np.empty(K), np.empty(K), np.zeros(K, np.bool_),
        )  # fmt: skip
        return unsigned_rows(records.record_of_rows(r)), r.lam, scene.V_in.copy(), points, C

    record, _, V, _, _ = fresh()
    manifolds = prepare_manifolds(record, M_inv, soft.block)
    n = manifolds[0].shape[0] - 1
    no_breaks = np.empty(0, np.int64)
    run_start = lane_runs(manifolds[0], record, M_inv, V, no_breaks)
    L = prepare_lanes(manifolds, run_start, record, inv_A_kk, M_inv, springs)
    lanes = (run_start, L)
    print(f"pyramid of base {args.base}: {N} bodies, {K} points, {n} manifolds, {run_start.shape[0] - 1} runs")

    # the bits: eight sweeps (push, relax with the separations afresh, ...) each way
    out = {}
    for way in ("scalar", "lanes"):
        rec, lam, Vw, points, C = fresh()
        worst = []
        for sweep in range(8):
            use_bias, new_C = sweep % 2 == 0, sweep % 2 == 1
            if way == "scalar":
                worst.append(
                    soft_normal_rows(0, n, rec, manifolds, inv_A_kk, points, M_inv, Vw, h, use_bias, springs, new_C)
                )
            else:
                worst.append(soft_normal_rows_in_lanes(
                    0, n, rec, manifolds, lanes, inv_A_kk, points, M_inv, Vw, h, use_bias, springs, new_C
                ))  # fmt: skip
        out[way] = (lam.tobytes(), Vw.tobytes(), C.tobytes(), worst)
    same = out["scalar"] == out["lanes"]
    print(f"the same bits as the scalar sweep (lambda, V, C, residuals; 8 sweeps): {'yes' if same else 'NO'}")

    # the time: each way's best call, from the same state
    rows_s, _, V_s, points_s, _ = fresh()
    rows_l, _, V_l, points_l, _ = fresh()
    for use_bias, new_C, name in ((True, False, "with the push"), (False, True, "relax (separations afresh)")):
        t_s = best_of(
            lambda use_bias=use_bias, new_C=new_C: soft_normal_rows(
                0, n, rows_s, manifolds, inv_A_kk, points_s, M_inv, V_s, h, use_bias, springs, new_C
            ),
            args.repeats,
        )
        t_l = best_of(
            lambda use_bias=use_bias, new_C=new_C: soft_normal_rows_in_lanes(
                0, n, rows_l, manifolds, lanes, inv_A_kk, points_l, M_inv, V_l, h, use_bias, springs, new_C
            ),
            args.repeats,
        )
        print(f"normal rows, {name}: scalar {t_s:,.0f} µs, lanes {t_l:,.0f} µs, scalar / lanes {t_s / t_l:.2f}")
    lanes_in, lanes_out = np.zeros(N_IN * LANES), np.zeros(N_OUT * LANES)
    for new_C in (False, True):
        t = best_of(lambda new_C=new_C: lanes_only(run_start, L, lanes_in, lanes_out, h, new_C), args.repeats)
        print(f"  of which the solve loops alone (new_C {new_C}): {t:,.0f} µs")
    t = best_of(lambda: block_lanes_only(run_start, L, lanes_in, lanes_out, h), args.repeats)
    print(f"  the solve loops of blocks only (no rows one by one, no separations), for comparison: {t:,.0f} µs")
    rows_g, _, V_g, _, _ = fresh()
    t = best_of(lambda: gather_and_scatter(run_start, manifolds[0], rows_g, V_g, lanes_in), args.repeats)
    print(f"  the gather and scatter of V_ab and a lambda alone: {t:,.0f} µs")
    t = best_of(lambda: lane_runs(manifolds[0], record, M_inv, V, no_breaks), args.repeats)
    t2 = best_of(lambda: prepare_lanes(manifolds, run_start, record, inv_A_kk, M_inv, springs), args.repeats)
    print(f"per tick: lane_runs {t:,.0f} µs, prepare_lanes {t2:,.0f} µs")
    if args.asm:
        print("normal_lanes' machine code:", instruction_counts())
    if args.pairs:
        same = same and pairs(args, fresh, rows, manifolds, inv_A_kk, M_inv, h, springs)
    return 0 if same else 1


def pairs(args: argparse.Namespace, fresh: Callable[[], tuple], rows: Any, manifolds: tuple, *consts: object) -> bool:
    """``soft_normal_rows_in_pairs`` against the scalar sweep: its bits over eight sweeps, then
    rounds of each one's best call with the push, in turn. True if the bits are the same."""
    inv_A_kk, M_inv, h, springs = consts
    n = manifolds[0].shape[0] - 1
    out = {}
    for way, sweep in (("scalar", soft_normal_rows), ("pairs", soft_normal_rows_in_pairs)):
        record, lam, V, points, C = fresh()
        worst = [
            sweep(0, n, record, manifolds, inv_A_kk, points, M_inv, V, h, s % 2 == 0, springs, s % 2 == 1)
            for s in range(8)
        ]
        out[way] = (lam.tobytes(), V.tobytes(), C.tobytes(), worst)
    same = out["scalar"] == out["pairs"]
    print(f"two blocks side by side, the same bits as the scalar sweep (8 sweeps): {'yes' if same else 'NO'}")
    start, as_block = manifolds[0], manifolds[3]
    k = rows.normal_row[start[:-1]]
    ends = np.stack([rows.body_a[k], rows.body_b[k]], axis=1)
    paired, m = 0, 0
    while m < n:  # the pairs the sweep forms, greedily, as it does
        if m + 1 < n and as_block[m] and as_block[m + 1] and not set(ends[m]) & set(ends[m + 1]):
            paired, m = paired + 2, m + 2
        else:
            m += 1
    print(f"  {paired:,} of {n:,} manifolds solved two at a time")
    states = {way: fresh() for way in ("scalar", "pairs")}
    for r in range(3):
        t = {}
        for way, sweep in (("scalar", soft_normal_rows), ("pairs", soft_normal_rows_in_pairs)):
            record, _, V, points, _ = states[way]
            t[way] = best_of(
                lambda sweep=sweep, record=record, V=V, points=points: sweep(
                    0, n, record, manifolds, inv_A_kk, points, M_inv, V, h, True, springs, False
                ),
                args.repeats,
            )
        print(f"round {r + 1}, normal rows with the push: scalar {t['scalar']:,.0f} µs, pairs {t['pairs']:,.0f} µs, "
              f"scalar / pairs {t['scalar'] / t['pairs']:.2f}")  # fmt: skip
    return same


if __name__ == "__main__":
    sys.exit(main())
