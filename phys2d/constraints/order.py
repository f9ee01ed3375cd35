"""The order in which the responders visit contacts: pair order, or graph colouring.

Gauss-Seidel may visit rows in any order; the order changes which fixed point
it creeps towards first, not the problem it solves. The lecture's PGS visits
contacts in pair order, row by row (coloured, pyramid_40 toppled). A responder
that sets ``colour_order`` (the soft step) visits contact manifolds colour by
colour instead: a greedy colouring gives each candidate pair the
smallest colour that neither of its dynamic bodies has used yet, so within one
colour no two manifolds share a dynamic body (static bodies are shared freely:
nothing moves them). Consecutive rows then touch different bodies and the
processor can overlap their work, though less than one might hope: SoftStep(4)'s
solve measured 1.1-1.3x faster than in pair order on pyramid_20 and within 2% on
pyramid_40, and the lecture's PGS sweep gains nothing (benchmarks/SWEEP_ORDER.md:
most of a row's cost is the loop's own work, not the wait for the row before).
This is Box2D v3's graph colouring, used here for order only.

The colouring is made when a colour-ordered responder first visits the pairs the
broadphase swept (pairs are kept from tick to tick while nothing moves far), so it
is as stable as the pair list.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..collision.sort import stable_argsort

MAX_COLOURS = 64  # a body in more pairs than this shares the last colour


@njit(cache=True)
def colour_pairs(pairs, n_pairs, static, n_bodies):
    """Pair indices sorted by greedy colour (ties in pair order): the solve order of pairs."""
    used = np.zeros((n_bodies, MAX_COLOURS), np.bool_)
    colour = np.empty(n_pairs, np.int64)
    for p in range(n_pairs):
        a, b = pairs[p, 0], pairs[p, 1]
        chosen = MAX_COLOURS - 1
        for q in range(MAX_COLOURS):
            if (static[a] or not used[a, q]) and (static[b] or not used[b, q]):
                chosen = q
                break
        colour[p] = chosen
        if not static[a]:
            used[a, chosen] = True
        if not static[b]:
            used[b, chosen] = True
    return stable_argsort(colour).astype(np.int32)


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
