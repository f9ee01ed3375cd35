"""Threads: the soft step's sweeps on several cores, with the same results as on one.

(The geometry, the collide and the contact rows run a slice per thread in their own modules:
``collision.broadphase.update_geometry_in_slices``, ``collision.recycle.collide_recycling_in_slices``,
``constraints.rows.contact_rows_in_slices``; PGS's sweeps run in groups in ``responders.pgs``,
``sweep_in_groups``, the groups made here; this module holds what the soft step needs.)

Gauss-Seidel visits its rows one after another: a row reads the velocities every row before
it has written. Two rows whose bodies differ read and write different velocities, so they
may run at the same time without changing a bit of what either computes. The soft step
visits its manifolds in the order ``constraints.order`` gives: the bodies of a scene of
``PARTS_FROM`` moving bodies or more are cut into parts (a smaller one is one part, swept on
the calling thread), and the manifolds come part by part, then cut by cut (the manifolds that
straddle a cut), each colour by colour. Two parts share no moving body, nor do two cuts of one level of the
bisection. ``manifold_groups`` cuts the solve order into *segments* (the manifolds of one part
or one cut) and the segments into *groups* (consecutive segments that share no moving body),
and a sweep is

    for each group, in order:
        for its segments, in parallel (a segment per thread, one after another on each):
            the row updates of the serial sweep (``soft_normal_rows``, ``soft_friction_rows``)

Each manifold sees exactly the velocities it sees in the serial sweep, and each row does
the same floating-point operations in the same order, so the result is bit-identical for
every number of threads. The residual is a maximum, which no order changes. A body that
nothing moves (M^-1 = 0: static, kinematic or asleep) may sit in several segments of a
group: each writes back the velocity it read, plus 0 times its impulse, the same value
whichever writes last. A sweep waits for its threads once per group of several segments,
for the normal rows and again for the friction rows: with two parts, twice, however many
colours there are (a group of one segment, the cut, runs on the calling thread).

The tick's and the sub-step's passes over manifolds, points and bodies (the manifolds'
constants, the points' gather, the positions' integration, the store of the impulses) have no
order to keep: each manifold, point or body writes only its own entries. The ``*_on``
functions run them in one call on one thread, else a slice per thread.

Numba runs the inner loops (``prange``) on ``World.threads`` threads. The kernels here are
compiled with ``parallel=True``, only for a world whose threads > 1 (``groups_for`` returns
None for one thread, and numba drops every branch that would call them); with
NUMBA_DISABLE_JIT ``prange`` is ``range``.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

import numba
import numpy as np
from numba import config, prange

from ..constraints.order import PART_DEPTH, set_of
from ..jit import njit
from ..responders.soft_contacts import (
    manifold_constants,
    new_manifolds,
    prepare_manifolds,
    soft_friction_rows,
    soft_normal_rows,
    warm_start_joints,
    warm_start_manifolds,
)
from ..responders.soft_integrate import integrate_positions
from ..responders.soft_points import (
    gather_contacts_of,
    note_impacts,
    note_impacts_of,
    points_of,
    prepare_points,
    store,
    store_of,
)


@njit(cache=True)
def manifold_groups(start, rows, M_inv, part):
    """Cut the manifolds (in solve order; manifold m's points are start[m] up to start[m + 1])
    into segments, each the manifolds of one set (``constraints.order.set_of`` of the parts of
    its moving bodies, M^-1 != 0), and the segments into groups of consecutive segments of one
    level of the bisection, in node order, which share no moving body. Returns (segment_start
    (S + 1,), group_start (G + 1,)): segment s is manifolds segment_start[s] up to
    segment_start[s + 1], group g segments group_start[g] up to group_start[g + 1]."""
    normal_row, body_a, body_b = rows.normal_row, rows.body_a, rows.body_b
    n_manifolds = start.shape[0] - 1
    segment_start = np.empty(n_manifolds + 1, np.int64)
    group_start = np.empty(n_manifolds + 1, np.int64)
    n_segments = n_groups = 0
    last_set = last_level = last_node = -1
    for m in range(n_manifolds):
        k = normal_row[start[m]]
        a, b = body_a[k], body_b[k]
        moves_a = M_inv[a, 0] != 0.0 or M_inv[a, 2] != 0.0
        moves_b = M_inv[b, 0] != 0.0 or M_inv[b, 2] != 0.0
        part_a = part[a] if moves_a or not moves_b else part[b]
        part_b = part[b] if moves_b else part_a
        s, level, node = set_of(part_a, part_b, PART_DEPTH)
        if s == last_set:
            continue
        if level != last_level or node <= last_node:  # this segment may share a body with the group's
            group_start[n_groups] = n_segments
            n_groups += 1
        segment_start[n_segments] = m
        n_segments += 1
        last_set, last_level, last_node = s, level, node
    segment_start[n_segments] = n_manifolds
    group_start[n_groups] = n_segments
    return segment_start[: n_segments + 1].copy(), group_start[: n_groups + 1].copy()


@njit(cache=True)
def groups_for(threads, start, rows, M_inv):
    """``manifold_groups`` when ``threads`` is (count, part: each body's part); None when it is
    None (one thread: numba then drops every parallel branch, and compiles no parallel kernel)."""
    if threads is None:
        return None
    return manifold_groups(start, rows, M_inv, threads[1])


@njit(cache=True, parallel=True)
def soft_sweep_in_groups(groups, rows, manifolds, inv_A_kk, points, M_inv, V, h, sweep, springs):
    """``soft_sweep`` group by group, each group's segments in parallel (groups: ``groups_for``);
    the same arguments (sweep: (use_bias, new_C)), the same results. Returns the largest
    |delta lambda| A_kk (m/s)."""
    segment_start, group_start = groups
    use_bias, new_C = sweep
    worst = np.empty(segment_start.shape[0] - 1)  # per segment: no shared accumulator
    dynamic, static, joint = springs  # (numba's parallel loops take tuples, not tuples of tuples)
    for g in range(group_start.shape[0] - 1):  # the normal rows, group by group
        first, last = group_start[g], group_start[g + 1]
        if last - first == 1:  # one segment: on this thread, no threads to wake
            m0, m1 = segment_start[first], segment_start[first + 1]
            worst[first] = soft_normal_rows(
                m0, m1, rows, manifolds, inv_A_kk, points, M_inv, V, h, use_bias, springs, new_C
            )
            continue
        for s in prange(first, last):
            soft = (dynamic, static, joint)
            m0, m1 = segment_start[s], segment_start[s + 1]
            worst[s] = soft_normal_rows(m0, m1, rows, manifolds, inv_A_kk, points, M_inv, V, h, use_bias, soft, new_C)
    for g in range(group_start.shape[0] - 1):  # then the friction rows
        first, last = group_start[g], group_start[g + 1]
        if last - first == 1:
            m0, m1 = segment_start[first], segment_start[first + 1]
            worst[first] = max(worst[first], soft_friction_rows(m0, m1, rows, manifolds, inv_A_kk, points, M_inv, V, h))
            continue
        for s in prange(first, last):
            m0, m1 = segment_start[s], segment_start[s + 1]
            w = soft_friction_rows(m0, m1, rows, manifolds, inv_A_kk, points, M_inv, V, h)
            worst[s] = max(worst[s], w)
    return largest(worst)


@njit(cache=True)
def largest(values):
    """The largest of ``values`` (0.0 when none), in a kernel of its own: inside a parallel one,
    numba makes ``values.max()`` a parallel loop, and each parallel loop is a wait for the
    threads (a long one when another program holds a core). So too np.zeros: the parallel
    kernels make their per-thread arrays with np.empty and fill every entry."""
    worst = 0.0
    for v in values:
        worst = max(worst, v)
    return worst


@njit(cache=True, parallel=True)
def warm_start_in_groups(groups, manifolds, rows, M_inv, V):
    """``soft_contacts.warm_start`` group by group, each group's segments in parallel (groups:
    ``groups_for``); the joint rows after."""
    segment_start, group_start = groups
    start = manifolds[0]
    for g in range(group_start.shape[0] - 1):
        first, last = group_start[g], group_start[g + 1]
        if last - first == 1:
            warm_start_manifolds(segment_start[first], segment_start[first + 1], start, rows, M_inv, V)
            continue
        for s in prange(first, last):
            warm_start_manifolds(segment_start[s], segment_start[s + 1], start, rows, M_inv, V)
    warm_start_joints(rows, V)


# The sub-step's passes in which each point or body writes only its own entries: one call on
# one thread (threads None: numba drops the parallel branch), else a slice per thread (threads:
# (count, part)), with the
# same results.


@njit(cache=True)
def prepare_manifolds_on(threads, rows, M_inv, block):
    """``soft_contacts.prepare_manifolds``: the manifolds' starts on one thread, their constants
    (``manifold_constants``) a slice per thread."""
    if threads is None:
        return prepare_manifolds(rows, M_inv, block)
    manifolds = new_manifolds(rows)
    manifold_constants_in_slices(threads[0], manifolds, rows, M_inv, block)
    return manifolds


@njit(cache=True, parallel=True)
def manifold_constants_in_slices(n_slices, manifolds, rows, M_inv, block):
    n = manifolds[0].shape[0] - 1
    for t in prange(n_slices):
        manifold_constants(n * t // n_slices, n * (t + 1) // n_slices, manifolds, rows, M_inv, block)


@njit(cache=True)
def prepare_points_on(threads, found, n_bodies):
    """``soft_points.prepare_points``, the contacts gathered a slice per thread."""
    if threads is None:
        return prepare_points(found, n_bodies)
    n_contacts = found[0].shape[0]
    gathered = (np.empty(n_contacts), np.empty(n_contacts))
    gather_contacts_in_slices(threads[0], found, gathered)
    return points_of(gathered[0], gathered[1], n_bodies)


@njit(cache=True, parallel=True)
def gather_contacts_in_slices(n_slices, found, gathered):
    n = gathered[0].shape[0]
    for t in prange(n_slices):
        gather_contacts_of(n * t // n_slices, n * (t + 1) // n_slices, found, gathered)


@njit(cache=True)
def store_on(threads, rows, total, points):
    """``soft_points.store``, the contacts' rows a slice per thread, then the joints'."""
    if threads is None:
        store(rows, total, points)
    else:
        store_in_slices(threads[0], rows, total, points)
        for k in range(2 * rows.normal_row.shape[0], rows.lam.shape[0]):  # the joint rows
            total[k] += rows.lam[k]


@njit(cache=True, parallel=True)
def store_in_slices(n_slices, rows, total, points):
    n = rows.normal_row.shape[0]
    for t in prange(n_slices):
        store_of(n * t // n_slices, n * (t + 1) // n_slices, rows, total, points)


@njit(cache=True)
def note_impacts_on(threads, rows, points, n_pending, dv, h, threshold):
    """``soft_points.note_impacts`` of the n_pending points not yet met: a slice per thread, each
    keeping its points still pending at its slice's start, then the slices' joined in order (the
    same pending list as one thread's). Returns how many are still pending."""
    if threads is None:
        return note_impacts(rows, points, n_pending, dv, h, threshold)
    n_slices = threads[0]
    kept = note_impacts_in_slices(n_slices, rows, points, n_pending, dv, h, threshold)
    pending = points.pending
    n = kept[0]
    for t in range(1, n_slices):  # slice t's kept move down to follow the slices before it
        first = n_pending * t // n_slices
        for i in range(kept[t]):
            pending[n + i] = pending[first + i]
        n += kept[t]
    return n


@njit(cache=True, parallel=True)
def note_impacts_in_slices(n_slices, rows, points, n_pending, dv, h, threshold):
    kept = np.empty(n_slices, np.int64)
    for t in prange(n_slices):
        first = n_pending * t // n_slices  # its points still pending are kept from pending[first] on
        kept[t] = note_impacts_of(first, n_pending * (t + 1) // n_slices, rows, points, dv, h, threshold)
    return kept


@njit(cache=True)
def integrate_positions_on(threads, bodies, h, x0, theta0, moved):
    """``soft_integrate.integrate_positions`` of every body."""
    if threads is None:
        integrate_positions(0, x0.shape[0], bodies, h, x0, theta0, moved)
    else:
        integrate_positions_in_slices(threads[0], bodies, h, x0, theta0, moved)


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
    "manifold_groups",
    "prepare_manifolds_on",
    "prepare_points_on",
    "groups_for",
    "soft_sweep_in_groups",
    "store_on",
    "using_threads",
    "warm_start_in_groups",
]
