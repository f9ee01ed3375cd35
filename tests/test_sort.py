"""The kernels' stable sort gives exactly NumPy's stable argsort (ascending, ties in index order,
NaN last), their binary search NumPy's searchsorted, and the broadphase's pairs come out
sorted by (a, b) as the sort promises."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from phys2d.collision.broadphase import sort_pairs, sweep_and_prune
from phys2d.collision.sort import counting_argsort, lower_bound, stable_argsort

# few distinct values, so ties (and -0.0 beside 0.0, NaN beside NaN) are common
FLOATS = st.sampled_from([-np.inf, -1.5, -0.0, 0.0, 1e-300, 2.0, np.inf, np.nan]) | st.floats(allow_nan=True)
INTS = st.integers(-3, 3) | st.integers(-(2**63), 2**63 - 1)


@given(arrays(np.float64, st.integers(0, 80), elements=FLOATS))
def test_floats_sort_as_numpy_stable(keys):
    assert np.array_equal(stable_argsort(keys), np.argsort(keys, kind="stable"))


@given(arrays(np.int64, st.integers(0, 80), elements=INTS))
def test_ints_sort_as_numpy_stable(keys):
    assert np.array_equal(stable_argsort(keys), np.argsort(keys, kind="stable"))


@given(
    st.integers(1, 300).flatmap(
        lambda bound: st.tuples(
            st.just(bound), arrays(np.int64, st.integers(0, 80), elements=st.integers(0, bound - 1))
        )
    )
)
def test_small_ints_count_sort_as_numpy_stable(bound_and_keys):
    """The counting sort of keys in [0, bound) (the solve order's sets and colours)."""
    bound, keys = bound_and_keys
    assert np.array_equal(counting_argsort(keys, bound), np.argsort(keys, kind="stable"))


@given(arrays(np.float64, st.tuples(st.integers(0, 40), st.just(4)), elements=FLOATS))
def test_a_strided_column_sorts_as_numpy_stable(table):
    # the broadphase sorts aabb[:, 0], a view with a stride of four floats
    assert np.array_equal(stable_argsort(table[:, 0]), np.argsort(table[:, 0], kind="stable"))


@given(arrays(np.int64, st.integers(0, 40), elements=st.integers(-5, 5)), st.integers(-7, 7))
def test_lower_bound_is_searchsorted(keys, key):
    keys = np.sort(keys)  # with repeats, so "the first of equal keys" is tested
    assert lower_bound(keys, np.int64(key)) == np.searchsorted(keys, key)


def swept_pairs(aabb: np.ndarray, static: np.ndarray) -> list[tuple[int, int]]:
    """The pairs sweep_and_prune finds among boxes ``aabb`` (no collision filter)."""
    n = aabb.shape[0]
    pairs = np.zeros((n * n + 1, 2), np.int32)
    no_filter = (np.ones(n, np.uint64), np.full(n, np.iinfo(np.uint64).max, np.uint64), np.zeros(n, np.int32))
    count = sweep_and_prune(aabb, static, np.zeros(0, np.int64), pairs, no_filter)
    return [tuple(p) for p in pairs[:count].tolist()]


def overlapping_pairs(aabb: np.ndarray, static: np.ndarray) -> list[tuple[int, int]]:
    """The second method: by brute force, every pair a < b of boxes whose closed intervals overlap
    on both axes, but two static ones, in pair order."""
    n = aabb.shape[0]
    return [
        (a, b)
        for a in range(n)
        for b in range(a + 1, n)
        if not (static[a] and static[b])
        and aabb[a, 0] <= aabb[b, 2]
        and aabb[b, 0] <= aabb[a, 2]
        and aabb[a, 1] <= aabb[b, 3]
        and aabb[b, 1] <= aabb[a, 3]
    ]


@given(st.lists(st.tuples(st.integers(0, 20), st.integers(0, 20), st.integers(1, 4), st.integers(1, 4)), max_size=30))
def test_sweep_pairs_are_every_overlap_sorted_by_pair(boxes):
    # second method: every pair of boxes whose closed intervals overlap on both axes, by brute force
    aabb = np.array([(x, y, x + w, y + h) for x, y, w, h in boxes], float).reshape(-1, 4)
    static = np.zeros(aabb.shape[0], np.bool_)
    assert swept_pairs(aabb, static) == overlapping_pairs(aabb, static)


@given(
    st.lists(
        st.tuples(
            st.floats(-50, 50), st.floats(-50, 50), st.floats(0, 30), st.floats(0, 3), st.booleans()
        ),  # x, y, height (up to a tall wall), width, static
        max_size=40,
    )
)
def test_the_strips_find_every_overlap_once_in_tall_and_flat_piles(boxes):
    # second method: brute force over all pairs, less those of two static boxes; boxes of very
    # different heights make strips that a box spans many of, and pairs that share several strips
    aabb = np.array([(x, y, x + width, y + height) for x, y, height, width, _ in boxes], float).reshape(-1, 4)
    static = np.array([s for *_, s in boxes], np.bool_)
    assert swept_pairs(aabb, static) == overlapping_pairs(aabb, static)


@given(st.data(), st.integers(2, 60), st.booleans())
def test_pairs_sort_by_body_then_partner(data, n_bodies, a_ground):
    """sort_pairs against sorted(): any unique pairs a < b in any order, with (when a_ground)
    body 0 paired with every other body, as a ground under a pile is."""
    pair = st.tuples(st.integers(0, n_bodies - 1), st.integers(0, n_bodies - 1)).filter(lambda p: p[0] < p[1])
    pairs = set(data.draw(st.lists(pair, max_size=200)))
    if a_ground:
        pairs |= {(0, b) for b in range(1, n_bodies)}
    order = data.draw(st.permutations(sorted(pairs)))
    array = np.array(order, np.int32).reshape(-1, 2)
    sort_pairs(array, array.shape[0], n_bodies)
    assert [tuple(p) for p in array.tolist()] == sorted(pairs)
