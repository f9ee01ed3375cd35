"""The contacts of a step, and the cache that carries their impulses to the next.

A contact point's identity is (shape pair, feature id). Every body has one shape,
so the pair is the two bodies' uids (stable through removals), and the identity
packs into one int64 key:

    key = uid_a << 39 | uid_b << 16 | feature          (uid_a < uid_b)

Keys of a step come out of the narrowphase in ascending order, so matching the
new contacts against last tick's is one walk along both sorted lists (a merge):
contact caching.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from numba import prange

from .collision.sort import lower_bound
from .jit import njit

if TYPE_CHECKING:  # constraints.rows imports this module: its contact rows start from the cache
    pass


@njit(cache=True)
def look_up(first, last, cache_keys, keys, cached):
    """Contact caching: walk both sorted key lists together (a merge), and for every contact c
    of first up to last set cached[c] to the index of its key in last tick's cache, or -1 when
    it is not there. The merge starts where keys[first] sits in cache_keys (a binary search,
    where the walk from 0 would have got to), so a slice finds what the whole walk finds.
    Returns how many were found."""
    m = lower_bound(cache_keys, keys[first]) if first < last else 0
    found = 0
    for c in range(first, last):
        while m < cache_keys.shape[0] and cache_keys[m] < keys[c]:
            m += 1
        cached[c] = m if m < cache_keys.shape[0] and cache_keys[m] == keys[c] else -1
        if cached[c] >= 0:
            found += 1
    return found


UID_BITS = 23  # key = uid_a << 39 | uid_b << 16 | feature: key >> 16 is the pair of uids
FEATURE_BITS = 16


@njit(cache=True, inline="always")  # (called with int32 and uint32 bodies: one compile, not two)
def _root(parent, b):
    """The representative of body b's island (union-find with path halving)."""
    while parent[b] != b:
        parent[b] = parent[parent[b]]
        b = parent[b]
    return b


@njit(cache=True)
def lost_a_load(cache_keys, cache_pushed, keys):
    """True if a pair that pushed last tick has no contact now (a merge of the sorted keys by pair)."""
    return lost_a_load_of(0, cache_keys.shape[0], cache_keys, cache_pushed, keys)


@njit(cache=True)
def lost_a_load_of(first, last, cache_keys, cache_pushed, keys):
    """``lost_a_load`` of cache entries first up to last: the merge starts at the first contact
    of entry first's pair or after (a binary search), where the walk from 0 would have got to."""
    m = lower_bound(keys, (cache_keys[first] >> FEATURE_BITS) << FEATURE_BITS) if first < last else 0
    for e in range(first, last):
        pair = cache_keys[e] >> FEATURE_BITS
        while m < keys.shape[0] and (keys[m] >> FEATURE_BITS) < pair:
            m += 1
        if cache_pushed[e] and not (m < keys.shape[0] and (keys[m] >> FEATURE_BITS) == pair):
            return True
    return False


@njit(cache=True)
def unloaded_islands(cache_keys, cache_pushed, keys, body_a, body_b, uid, static, cold):
    """cold[c] = True for every contact c whose island lost a load since last tick.

    A pair of bodies that pushed last tick (cache_pushed) and has no contact now (one
    was removed, or they flew apart) leaves the impulses cached around it sized for a
    load that is gone. Those stored impulses would launch what was under it, so every
    contact connected to either body through dynamic bodies starts cold. Static bodies
    do not connect islands: nothing flows through the ground. ``find_in_cache`` calls it only
    on the rare tick when such a pair exists (``lost_a_load``).
    """
    n = uid.shape[0]
    parent = np.arange(n)
    for c in range(keys.shape[0]):
        a, b = body_a[c], body_b[c]
        if not static[a] and not static[b]:
            ra, rb = _root(parent, a), _root(parent, b)
            if ra != rb:
                parent[max(ra, rb)] = min(ra, rb)
    unloaded = np.zeros(n, np.bool_)
    any_unloaded = False
    m = 0
    for e in range(cache_keys.shape[0]):
        pair = cache_keys[e] >> FEATURE_BITS
        while m < keys.shape[0] and (keys[m] >> FEATURE_BITS) < pair:
            m += 1
        if not cache_pushed[e] or (m < keys.shape[0] and (keys[m] >> FEATURE_BITS) == pair):
            continue  # it carried nothing, or the pair still touches
        for u in (pair >> UID_BITS, pair & ((1 << UID_BITS) - 1)):
            b = np.int32(lower_bound(uid, u))  # uids ascend in the body arrays; int32 as body_a's
            if b < n and uid[b] == u and not static[b]:
                unloaded[_root(parent, b)] = True
                any_unloaded = True
    for c in range(keys.shape[0]):
        body = body_b[c] if static[body_a[c]] else body_a[c]
        cold[c] = any_unloaded and unloaded[_root(parent, body)]


@njit(cache=True)
def find_in_cache(cache_keys, cache_pushed, keys, body_a, body_b, uid, static, cached, hit, threads):
    """Contact caching: cached[c] = the cache entry contact c starts its rows from
    (``look_up``; ``constraints.rows.contact_rows`` reads it), or -1 when it
    is new or its island lost a load (``unloaded_islands``); hit[c] = cached[c] >= 0.
    threads: None on one thread, else a count: the look-up runs a slice of the contacts, and of
    the cache, per thread (``look_up_in_slices``), with the same results. Returns the hits."""
    k = keys.shape[0]
    if threads is None:
        hits = look_up(0, k, cache_keys, keys, cached)
        lost = lost_a_load(cache_keys, cache_pushed, keys)
    else:
        hits, lost = look_up_in_slices(threads, cache_keys, cache_pushed, keys, cached)
    if lost:  # rare: a pair that pushed is gone, so its islands start cold
        cold = np.empty(k, np.bool_)
        unloaded_islands(cache_keys, cache_pushed, keys, body_a, body_b, uid, static, cold)
        hits = 0
        for c in range(k):
            if cold[c]:
                cached[c] = -1
            if cached[c] >= 0:
                hits += 1
    for c in range(k):
        hit[c] = cached[c] >= 0
    return hits


@njit(cache=True, parallel=True)
def look_up_in_slices(threads, cache_keys, cache_pushed, keys, cached):
    """``look_up`` of all the contacts and ``lost_a_load_of`` of all the cache entries, a slice of
    each per thread. Returns (the contacts found, whether a pair that pushed is gone)."""
    k, n = keys.shape[0], cache_keys.shape[0]
    found = np.empty(threads, np.int64)  # per slice: no shared accumulator
    lost = np.empty(threads, np.bool_)
    for t in prange(threads):
        found[t] = look_up(k * t // threads, k * (t + 1) // threads, cache_keys, keys, cached)
        lost[t] = lost_a_load_of(n * t // threads, n * (t + 1) // threads, cache_keys, cache_pushed, keys)
    hits, any_lost = 0, False  # (loops: numba would make found.sum() a parallel loop, one more wait)
    for t in range(threads):
        hits, any_lost = hits + found[t], any_lost or lost[t]
    return hits, any_lost


@njit(cache=True)
def impulses_to_contacts_and_cache(rows, found, k, threads):
    """The K contacts' lambda_n, lambda_t (N s) read off their rows, and what the cache keeps of
    them, into ``found`` (a ContactRecord): ``impulses_of`` every row pair, on one thread
    (threads None) or a slice per thread (threads a count), with the same results."""
    if threads is None:
        impulses_of(0, k, rows, found)
    else:
        impulses_in_slices(threads, rows, found, k)


@njit(cache=True)
def impulses_of(first, last, rows, found):
    """Row pairs q = first up to last: contact c = order[q]'s lambda_n, lambda_t (N s), and what
    the cache keeps: 0 for a contact that met its partner fast within the step (its normal
    row's ``impact``: an event, not a load), and whether it pushed."""
    order, lam, impact, pushed = found.order, rows.lam, rows.impact, found.cache_pushed
    lambda_n, lambda_t, cache_n, cache_t = found.lambda_n, found.lambda_t, found.cache_lambda_n, found.cache_lambda_t
    normal_row, friction_row = rows.normal_row, rows.friction_row
    for q in range(first, last):
        c, kn, kt = order[q], normal_row[q], friction_row[q]
        lambda_n[c] = lam[kn]
        lambda_t[c] = lam[kt]
        cache_n[c] = 0.0 if impact[kn] else lam[kn]
        cache_t[c] = 0.0 if impact[kn] else lam[kt]
        pushed[c] = lam[kn] > 0.0


@njit(cache=True, parallel=True)
def impulses_in_slices(threads, rows, found, k):
    for t in prange(threads):
        impulses_of(k * t // threads, k * (t + 1) // threads, rows, found)


@dataclass(eq=False)
class Contacts:
    """The contact points of one step, as arrays of length K.

    body_a, body_b    indices into ``w.bodies`` (body_a < body_b)
    point             (K, 2) contact point p, m
    anchor            (K, 4) lever arms r_a, r_b (m): p - x_a and p - x_b when the manifold
                      was found (a recycled point keeps them, unturned); SoftStep's rows use
                      them (``Responder.found_lever_arms``), other responders' p - x now
    normal            (K, 2) unit normal n, from a to b
    separation        (K,) C in m, negative when overlapping
    lambda_n          (K,) the accumulated normal impulse of the step, N s (>= 0 under PGS)
    lambda_t          (K,) the accumulated friction impulse along t = (-n_y, n_x), N s
    feature           (K,) feature id (see ``phys2d.collision.narrowphase``)
    key               (K,) the contact's identity (pair of uids and feature)
    warm_started      (K,) True where the cache supplied last tick's impulses
    friction, restitution  (K,) the pair's mixed mu = sqrt(mu_a mu_b) and e = max(e_a, e_b)
    """

    body_a: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int32))
    body_b: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int32))
    point: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    anchor: np.ndarray = field(default_factory=lambda: np.zeros((0, 4)))
    normal: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    separation: np.ndarray = field(default_factory=lambda: np.zeros(0))
    lambda_n: np.ndarray = field(default_factory=lambda: np.zeros(0))
    lambda_t: np.ndarray = field(default_factory=lambda: np.zeros(0))
    feature: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int32))
    key: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    warm_started: np.ndarray = field(default_factory=lambda: np.zeros(0, np.bool_))
    friction: np.ndarray = field(default_factory=lambda: np.zeros(0))
    restitution: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def __len__(self) -> int:
        return int(self.body_a.shape[0])

    def read_only(self) -> Contacts:
        """Make every array read-only (the world hands these out: they describe a step taken,
        and editing them must not look as if it could change the next) and return self."""
        for name in self.__dataclass_fields__:
            getattr(self, name).flags.writeable = False
        return self

    @property
    def normal_impulse(self) -> np.ndarray:
        """``lambda_n`` under the name the API used first (read-only, N s)."""
        return self.lambda_n

    @property
    def tangent_impulse(self) -> np.ndarray:
        """``lambda_t`` under the name the API used first (read-only, N s)."""
        return self.lambda_t

    @property
    def tangent(self) -> np.ndarray:
        """(K, 2) friction direction t = (-n_y, n_x)."""
        return np.stack([-self.normal[:, 1], self.normal[:, 0]], axis=1)

    def __repr__(self) -> str:
        k = len(self)
        if k == 0:
            return "<Contacts: none>"
        return (
            f"<Contacts: {k} points, deepest overlap {max(0.0, -self.separation.min()):.4g} m, "
            f"{int(self.warm_started.sum())} warm started>"
        )
