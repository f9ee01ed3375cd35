"""Threads: the soft step's sweeps on several cores, with the same results as on one.

(The contact rows, each contact's its own, are built a slice per thread by
``constraints.rows.contact_rows_in_slices``; this module holds what the soft step needs.)

Gauss-Seidel visits its rows one after another: a row reads the velocities every row before
it has written. Two rows whose bodies differ read and write different velocities, so they
may run at the same time without changing a bit of what either computes. The soft step
visits its manifolds colour by colour (``constraints.order``): within a colour no two
manifolds share a body that moves. Cut the solve order into *runs* of consecutive manifolds
in which no moving body appears twice (``manifold_runs``: a colour is one run, the last,
overflow colour as many runs as it needs), and a sweep is

    for each run, in order:
        for its manifolds, in parallel (a slice of them per thread):
            the row updates of the serial sweep (``soft_normal_rows``, ``soft_friction_rows``)

Each manifold sees exactly the velocities it sees in the serial sweep, and each row does
the same floating-point operations in the same order, so the result is bit-identical for
every number of threads. The residual is a maximum, which no order changes. A body that
nothing moves (M^-1 = 0: static, kinematic or asleep) may sit in several manifolds of a run:
each writes back the velocity it read, plus 0 times its impulse, the same value whichever
writes last.

The sub-step's passes over points and bodies (the separations, the noted approaches, the
positions' integration) have no order to keep: each point or body writes only its own
entries. ``separations_on``, ``note_approach_on`` and ``integrate_positions_on`` run them in
one call on one thread, else a slice per thread.

Numba runs the inner loops (``prange``) on ``World.threads`` threads. The kernels here are
compiled with ``parallel=True``, only for a world whose threads > 1 (``runs_for`` returns
None for one thread, and numba drops every branch that would call them); with
NUMBA_DISABLE_JIT ``prange`` is ``range``.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

import numba
import numpy as np
from numba import config, njit, prange

from ..responders.soft_contacts import soft_friction_rows, soft_normal_rows, warm_start_joints, warm_start_manifolds
from ..responders.soft_integrate import integrate_positions
from ..responders.soft_points import note_approach, separations


@njit(cache=True)
def manifold_runs(start, rows, M_inv):
    """Cut the manifolds (in solve order; manifold m's points are start[m] up to start[m + 1])
    into runs of consecutive manifolds in which no body that moves (M^-1 != 0) appears twice.
    Returns run_start (R + 1,): run r is manifolds run_start[r] up to run_start[r + 1]."""
    normal_row, body_a, body_b = rows.normal_row, rows.body_a, rows.body_b
    n_manifolds = start.shape[0] - 1
    run_of = np.full(M_inv.shape[0], -1, np.int64)  # the last run each body appeared in
    run_start = np.empty(n_manifolds + 1, np.int64)
    n_runs = 0
    for m in range(n_manifolds):
        k = normal_row[start[m]]
        a, b = body_a[k], body_b[k]
        moves_a = M_inv[a, 0] != 0.0 or M_inv[a, 2] != 0.0
        moves_b = M_inv[b, 0] != 0.0 or M_inv[b, 2] != 0.0
        if n_runs == 0 or (moves_a and run_of[a] == n_runs - 1) or (moves_b and run_of[b] == n_runs - 1):
            run_start[n_runs] = m  # a body of m is taken in this run: m starts the next
            n_runs += 1
        run_of[a] = run_of[b] = n_runs - 1
    run_start[n_runs] = n_manifolds
    return run_start[: n_runs + 1].copy()


@njit(cache=True)
def runs_for(threads, start, rows, M_inv):
    """(run_start of ``manifold_runs``, threads) when ``threads`` is a count: each run is cut in
    that many slices, one per thread; None when it is None (one thread: numba then drops every
    parallel branch, and compiles no parallel kernel)."""
    if threads is None:
        return None
    return manifold_runs(start, rows, M_inv), threads


@njit(cache=True)
def slice_of(run_start, r, t, n_slices):
    """Slice t of n_slices of run r (``manifold_runs``): manifolds first up to last."""
    first, n = run_start[r], run_start[r + 1] - run_start[r]
    return first + n * t // n_slices, first + n * (t + 1) // n_slices


@njit(cache=True, parallel=True)
def soft_sweep_in_runs(runs, rows, manifolds, inv_A_kk, points, M_inv, V, h, use_bias, springs):
    """``soft_sweep`` run by run, each run's manifolds in parallel, a slice per thread (runs:
    ``runs_for``); the same arguments, the same results. Returns the largest |delta lambda| A_kk
    (m/s)."""
    run_start, n_slices = runs
    worst = np.zeros(n_slices)  # per slice: no shared accumulator
    dynamic, static, joint = springs  # (numba's parallel loops take tuples, not tuples of tuples)
    for r in range(run_start.shape[0] - 1):  # the normal rows, run by run
        for t in prange(n_slices):
            first, last = slice_of(run_start, r, t, n_slices)
            soft = (dynamic, static, joint)
            w = soft_normal_rows(first, last, rows, manifolds, inv_A_kk, points, M_inv, V, h, use_bias, soft)
            worst[t] = max(worst[t], w)
    for r in range(run_start.shape[0] - 1):  # then the friction rows
        for t in prange(n_slices):
            first, last = slice_of(run_start, r, t, n_slices)
            w = soft_friction_rows(first, last, rows, manifolds, inv_A_kk, points, M_inv, V, h)
            worst[t] = max(worst[t], w)
    return worst.max()


@njit(cache=True, parallel=True)
def warm_start_in_runs(runs, manifolds, rows, M_inv, V):
    """``soft_contacts.warm_start`` run by run, each run's manifolds in parallel, a slice per
    thread (runs: ``runs_for``); the joint rows after."""
    run_start, n_slices = runs
    for r in range(run_start.shape[0] - 1):
        for t in prange(n_slices):
            first, last = slice_of(run_start, r, t, n_slices)
            warm_start_manifolds(first, last, manifolds[0], rows, M_inv, V)
    warm_start_joints(rows, V)


# The sub-step's passes in which each point or body writes only its own entries: one call on
# one thread (threads None: numba drops the parallel branch), else a slice per thread, with the
# same results.


@njit(cache=True)
def separations_on(threads, rows, points, moved):
    """``soft_points.separations`` of every point."""
    n = rows.normal_row.shape[0]
    if threads is None:
        separations(0, n, rows, points, moved)
    else:
        separations_in_slices(threads, rows, points, moved)


@njit(cache=True, parallel=True)
def separations_in_slices(n_slices, rows, points, moved):
    n = rows.normal_row.shape[0]
    for t in prange(n_slices):
        separations(n * t // n_slices, n * (t + 1) // n_slices, rows, points, moved)


@njit(cache=True)
def note_approach_on(threads, rows, points, n_pending, V):
    """``soft_points.note_approach`` of the n_pending points not yet met."""
    if threads is None:
        note_approach(0, n_pending, rows, points, V)
    else:
        note_approach_in_slices(threads, rows, points, n_pending, V)


@njit(cache=True, parallel=True)
def note_approach_in_slices(n_slices, rows, points, n_pending, V):
    for t in prange(n_slices):
        note_approach(n_pending * t // n_slices, n_pending * (t + 1) // n_slices, rows, points, V)


@njit(cache=True)
def integrate_positions_on(threads, bodies, h, x0, theta0, moved):
    """``soft_integrate.integrate_positions`` of every body."""
    if threads is None:
        integrate_positions(0, x0.shape[0], bodies, h, x0, theta0, moved)
    else:
        integrate_positions_in_slices(threads, bodies, h, x0, theta0, moved)


@njit(cache=True, parallel=True)
def integrate_positions_in_slices(n_slices, bodies, h, x0, theta0, moved):
    n = x0.shape[0]
    for t in prange(n_slices):
        integrate_positions(n * t // n_slices, n * (t + 1) // n_slices, bodies, h, x0, theta0, moved)


@contextmanager
def using_threads(threads: int) -> Iterator[None]:
    """Within it, numba's parallel loops use ``threads`` threads (at most the NUMBA_NUM_THREADS
    numba started with: more threads than that run on those; the results are the same);
    numba's count before is restored after. One thread: nothing is touched."""
    if threads <= 1 or config.DISABLE_JIT:  # type: ignore[attr-defined]
        yield
        return
    before = numba.get_num_threads()
    numba.set_num_threads(min(threads, config.NUMBA_NUM_THREADS))  # type: ignore[attr-defined]
    try:
        yield
    finally:
        numba.set_num_threads(before)


__all__ = [
    "integrate_positions_on",
    "manifold_runs",
    "note_approach_on",
    "runs_for",
    "separations_on",
    "slice_of",
    "soft_sweep_in_runs",
    "using_threads",
    "warm_start_in_runs",
]
