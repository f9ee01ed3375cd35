"""The order in which the responders visit contacts: pair order, part order or graph colouring.

Gauss-Seidel may visit rows in any order; the order changes which fixed point
it creeps towards first, not the problem it solves. A responder says which order it
visits in (``Responder.visit_order``):

    PAIR_ORDER    the pairs as the broadphase found them, sorted by (a, b): the lecture's
                  loop (the naive takes, the matrix form)
    PART_ORDER    the pairs part by part (below), pair order within each: PGS. A scene of
                  fewer than PARTS_FROM moving bodies is one part, so its order is pair
                  order exactly (every lesson's scene); a larger one's sweeps can share
                  the work among threads
    COLOUR_ORDER  part by part, colour by colour within each: the soft step. A scene of
                  fewer than PARTS_FROM moving bodies is one part here too, so its order is
                  colour order exactly

The lecture's PGS visits contacts in pair order, row by row (coloured, pyramid_40 toppled).
A colour-ordered responder visits contact manifolds colour by colour: a greedy colouring
gives each candidate pair the smallest colour that neither of its dynamic bodies has used
yet, so within one colour no two manifolds share a dynamic body (static bodies are shared
freely: nothing moves them). Consecutive rows then touch different bodies and the
processor can overlap their work, though less than one might hope: SoftStep(4)'s
solve measured 1.1-1.3x faster than in pair order on pyramid_20 and within 2% on
pyramid_40, and the lecture's PGS sweep gains nothing (benchmarks/SWEEP_ORDER.md:
most of a row's cost is the loop's own work, not the wait for the row before).
This is Box2D v3's graph colouring, used here for order only.

The parts are for threads (``pipeline.parallel``), and only in scenes large enough for
threads to pay: they change the Gauss-Seidel order, and a sweep carries a change only
forward in its order. With the cut last, the contacts above a cut are swept before those
below it, so the relax sweep takes the push out of the boxes below only after the boxes
above were matched to them: six 1 m boxes 40 % into each other (Box2D's overlap recovery,
base 3), cut into parts, launched the top box at 3.63 m/s under SoftStep(4), against 2.63 in
colour order and push_max = 3 (benchmarks/SOFT_REGRESSIONS.md). The moving bodies are bisected
``PART_DEPTH`` times (``partition``): each half is cut again at the median of its pairs
along x or y, whichever side leaves the halves least mixed in memory (a pyramid built row
by row: into bottom and top). A pair whose moving bodies lie in one part belongs to that
part; one that straddles a cut belongs to that cut. The solve order is the parts first,
then the cuts, the deepest first and the first cut (between the two halves) last
(``set_of``), and pair by pair or colour by colour within each. Two parts share no moving
body, nor do two cuts of one level, so each may be solved on its own thread, and one thread
visiting them in turn does the same arithmetic. The order is the same on any number of
threads, and so are the bits.

The order is made when a responder in part or colour order first visits the pairs the
broadphase swept (pairs are kept from tick to tick while nothing moves far), so it
is as stable as the pair list.
"""

from __future__ import annotations

import numpy as np

from ..collision.sort import counting_argsort, stable_argsort
from ..jit import njit

MAX_COLOURS = 64  # a body in more pairs than this shares the last colour


PART_DEPTH = 1  # the bodies are bisected this many times: 2**PART_DEPTH parts (``partition``)
PAIR_ORDER, PART_ORDER, COLOUR_ORDER = 0, 1, 2  # how a responder visits the contacts (``Responder.visit_order``)
PARTS_FROM = 512  # moving bodies: in part order, a scene with fewer is one part (pair order exactly)


@njit(cache=True)
def partition(x, weight, depth):
    """Each body's part, 0 to 2**depth - 1: the bodies of weight > 0 (their pairs; 0 for a body
    that does not move) bisected ``depth`` times, each time at the weighted median of x along
    one side (``bisect``; ties in body order). Bodies of weight 0 are in part 0:
    no manifold reads their part."""
    part = np.zeros(x.shape[0], np.int32)
    bodies = np.flatnonzero(weight > 0)
    bounds = np.array([0, bodies.shape[0]])  # node j of this level holds bodies[bounds[j]:bounds[j + 1]]
    for _ in range(depth):
        halves = np.empty(2 * bounds.shape[0] - 1, np.int64)
        for j in range(bounds.shape[0] - 1):
            lo, hi = bounds[j], bounds[j + 1]
            halves[2 * j], halves[2 * j + 1] = lo, bisect(x, weight, bodies[lo:hi]) + lo
        halves[-1] = bodies.shape[0]
        bounds = halves
    for j in range(bounds.shape[0] - 1):
        for i in range(bounds[j], bounds[j + 1]):
            part[bodies[i]] = j
    return part


@njit(cache=True)
def bisect(x, weight, bodies):
    """Sort ``bodies`` (in place) along x or y and return how many make the first half: up to
    the one at which their weight reaches half of it. Of the two sides, the one whose halves
    interleave least in body order (``interleaving``): two threads then write velocities that
    seldom share a cache line. A tie (a scene built in no order) goes to the longer side."""
    n = bodies.shape[0]
    if n < 2:
        return n
    best, best_cut, best_mixed, best_extent = bodies.copy(), n - 1, -1, -1.0
    for axis in range(2):
        along = np.empty(n)
        for i in range(n):
            along[i] = x[bodies[i], axis]
        sorted_bodies = bodies[stable_argsort(along)]
        cut = half_by_weight(sorted_bodies, weight)
        mixed = interleaving(sorted_bodies, cut, x.shape[0])
        extent = along.max() - along.min()
        if best_mixed < 0 or mixed < best_mixed or (mixed == best_mixed and extent > best_extent):
            best, best_cut, best_mixed, best_extent = sorted_bodies, cut, mixed, extent
    for i in range(n):
        bodies[i] = best[i]
    return best_cut


@njit(cache=True)
def half_by_weight(bodies, weight):
    """How many of ``bodies`` (in order) make the first half: up to the one at which their weight
    reaches half of the whole (the second half keeps at least one)."""
    total = 0
    for b in bodies:
        total += weight[b]
    reached = 0
    for i in range(bodies.shape[0] - 1):
        reached += weight[bodies[i]]
        if 2 * reached >= total:
            return i + 1
    return bodies.shape[0] - 1


@njit(cache=True)
def interleaving(bodies, cut, n_bodies):
    """How often, going through ``bodies`` in body order, the half changes (the first ``cut`` of
    them are the first half). A walk over the body indices, no sort: half[b] is 1 or 2 for the
    bodies in ``bodies``, 0 for the others."""
    half = np.zeros(n_bodies, np.int8)
    for i in range(bodies.shape[0]):
        half[bodies[i]] = 1 if i < cut else 2
    changes, last = 0, 0
    for b in range(n_bodies):
        if half[b] != 0:
            changes += last != 0 and half[b] != last
            last = half[b]
    return changes


@njit(cache=True, inline="always")
def set_of(part_a, part_b, depth):
    """The place in the solve order of a manifold whose moving bodies lie in parts part_a and
    part_b (a body that does not move: give the other's part twice), and its level: a part is
    set part (level 0); a cut, after every part, is the node of the bisection where the two
    parted: level s for the cut s bisections above the parts, and the cuts of a level in node
    order. Returns (set, level, node)."""
    level = 0
    while part_a != part_b:
        part_a >>= 1
        part_b >>= 1
        level += 1
    return (1 << (depth + 1)) - (1 << (depth - level + 1)) + part_a, level, part_a


@njit(cache=True)
def order_pairs(pairs, n_pairs, static, x, part, visit):
    """Pair indices in solve order: sorted by set (``set_of``: the parts, then the cuts between
    them), then, in COLOUR_ORDER, by greedy colour (ties in pair order; in PART_ORDER pair order
    within each set). Writes each body's part (``partition`` of the centres x, weighted by their
    pairs; all 0 with fewer than PARTS_FROM moving bodies) into part."""
    n_bodies = x.shape[0]
    weight = np.zeros(n_bodies, np.int64)
    for p in range(n_pairs):
        for i in range(2):
            if not static[pairs[p, i]]:
                weight[pairs[p, i]] += 1
    colours = visit == COLOUR_ORDER
    moving = 0
    for w in weight:
        moving += w > 0
    if moving >= PARTS_FROM:
        parts = partition(x, weight, PART_DEPTH)
        for i in range(n_bodies):  # (a loop: `part[:] = parts` would compile numba's shape-mismatch message too)
            part[i] = parts[i]
    else:
        part[:] = 0
    used = np.zeros((n_bodies, MAX_COLOURS if colours else 1), np.bool_)
    key = np.empty(n_pairs, np.int64)
    for p in range(n_pairs):
        a, b = pairs[p, 0], pairs[p, 1]
        chosen = 0
        if colours:
            chosen = greedy_colour(a, b, static, used)
        part_a = part[b] if static[a] else part[a]
        part_b = part[a] if static[b] else part[b]
        key[p] = set_of(part_a, part_b, PART_DEPTH)[0] * MAX_COLOURS + chosen
    return counting_argsort(key, ((1 << (PART_DEPTH + 1)) - 1) * MAX_COLOURS).astype(np.int32)  # sets x colours


@njit(cache=True)
def greedy_colour(a, b, static, used):
    """The smallest colour that neither of the pair's dynamic bodies has used yet (the last,
    MAX_COLOURS - 1, when all are), marked used for both."""
    chosen = MAX_COLOURS - 1
    for q in range(MAX_COLOURS):
        if (static[a] or not used[a, q]) and (static[b] or not used[b, q]):
            chosen = q
            break
    if not static[a]:
        used[a, chosen] = True
    if not static[b]:
        used[b, chosen] = True
    return chosen


@njit(cache=True)
def solve_order(pair_order, pair_start):
    """Contact indices in solve order: each pair's points (pair_start[p] up to
    pair_start[p + 1]) together, pairs in ``pair_order``.

    A 2D manifold has at most two points: both slots are written whatever the count (a
    pair without points leaves them to the next), so the loop does not branch on a count
    that a pile of one- and two-point manifolds makes unpredictable."""
    order = np.empty(pair_start[-1] + 2, np.int32)  # two spare slots for the last pair's writes
    q = 0
    for p in pair_order:
        c, n = pair_start[p], pair_start[p + 1] - pair_start[p]
        order[q] = c
        order[q + 1] = c + 1
        for i in range(2, n):  # more than two points: none in 2D today
            order[q + i] = c + i
        q += n
    return order[:q]
