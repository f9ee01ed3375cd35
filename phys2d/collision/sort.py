"""A stable sort and a binary search for the kernels: what np.argsort(keys, kind="stable") and
np.searchsorted(keys, key) give.

The broadphase sorts boxes by their left edge and pairs by their key, and the
graph colouring sorts pairs by colour, each inside a numba kernel. NumPy's stable
argsort compiled there costs seconds of the first run's wait (numba's generic
merge sort); this plain merge sort compiles in a fraction of that and gives the
same indices: ascending, equal keys in index order, NaN last. The look-ups in sorted
keys (joined pairs, cached manifolds, body uids) share one binary search, ``lower_bound``,
for the same reason.
"""

from __future__ import annotations

import numpy as np

from ..jit import njit


@njit(cache=True, inline="always")
def merge_runs(keys, src, dst, lo, mid, hi):
    """Merge the sorted runs src[lo:mid] and src[mid:hi] (indices into keys) into dst[lo:hi].

    The right run's index goes first only when its key sorts strictly before the left's
    (u < v, or v is NaN and u is not: NumPy's order): equal keys keep their order (stable).
    """
    i, j = lo, mid
    for k in range(lo, hi):
        if j < hi and i < mid:
            u, v = keys[src[j]], keys[src[i]]
            right_first = u < v or (v != v and u == u)  # v != v: v is NaN
        else:
            right_first = j < hi
        if right_first:
            dst[k] = src[j]
            j += 1
        else:
            dst[k] = src[i]
            i += 1


@njit(cache=True)
def stable_argsort(keys):
    """Indices that sort the 1-D array keys ascending, equal keys in index order, NaN last:
    np.argsort(keys, kind="stable"). A natural merge sort: the runs in which keys already ascend
    (a stack's or a pyramid's boxes, made row by row, arrive so) are found first, then merged in
    pairs, pass after pass, until one is left."""
    n = keys.shape[0]
    src = np.arange(n)
    dst = np.empty(n, np.int64)
    bounds = np.empty(n + 1, np.int64)  # run r is src[bounds[r]:bounds[r + 1]]
    bounds[0] = 0
    runs = 0
    for i in range(1, n):
        u, v = keys[i], keys[i - 1]
        if u < v or (v != v and u == u):  # keys[i] sorts before keys[i - 1]: a run ends
            runs += 1
            bounds[runs] = i
    if n > 0:
        runs += 1
        bounds[runs] = n
    while runs > 1:
        merged = 0
        for r in range(0, runs, 2):  # (writes bounds[merged], merged <= r: read already)
            lo, mid = bounds[r], bounds[r + 1]
            hi = bounds[r + 2] if r + 2 <= runs else mid  # a last run alone is copied
            merge_runs(keys, src, dst, lo, mid, hi)
            bounds[merged] = lo
            merged += 1
        bounds[merged] = n
        runs = merged
        src, dst = dst, src
    return src


@njit(cache=True)
def counting_argsort(keys, bound):
    """``stable_argsort`` of integer keys in [0, bound): a counting sort, O(n + bound), for keys
    as few as the solve order's sets and colours. Equal keys keep their index order."""
    start = np.zeros(bound + 1, np.int64)
    for k in keys:
        start[k + 1] += 1
    for v in range(bound):
        start[v + 1] += start[v]
    out = np.empty(keys.shape[0], np.int64)
    for i in range(keys.shape[0]):
        out[start[keys[i]]] = i
        start[keys[i]] += 1
    return out


@njit(cache=True, inline="always")
def lower_bound(keys, key):
    """The first index i with keys[i] >= key in the ascending array keys (keys.shape[0] if none):
    np.searchsorted(keys, key). Binary search: keys[lo - 1] < key <= keys[hi] throughout."""
    lo, hi = 0, keys.shape[0]
    while lo < hi:
        mid = (lo + hi) // 2
        if keys[mid] < key:
            lo = mid + 1
        else:
            hi = mid
    return lo
