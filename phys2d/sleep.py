"""Sleeping: islands of bodies at rest leave the step until something disturbs them (Box2D's rules).

An island is a set of dynamic bodies linked by touching contacts (separation <= the world's
contact_margin) and by joints; static and kinematic bodies link nothing, so two stacks on
one ground are two islands, but a kinematic body that moves (at any speed) keeps the islands
it touches awake and wakes those it comes near. After each step a dynamic body slower than LINEAR_SLEEP (m/s)
and ANGULAR_SLEEP (rad/s) adds dt to its ``sleep_time``, any other resets it to 0; an island
whose every body has rested TIME_TO_SLEEP (s) falls asleep: its velocities are set to 0 and
its bodies get the island's id (``BodyArrays.island``, -1 while awake).

A sleeping body is stepped as an immovable one: the pipeline reads it as static (no pairs
with static or other sleeping bodies, so none of their contacts are solved) with M^-1 = 0
(no gravity), and V = 0 leaves its x and theta exactly as they are (``Pipeline.sleepers``).
It wakes with its whole island (sleep_time back to 0) when an awake body could touch it in
the coming step (``near_sleepers``: its box grown by how far it may move), a joint is added
or removed on it, an impulse, force, torque or velocity is given to one of its bodies, a
body touching it is removed, or sleeping is switched off (``World.sleep``).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

LINEAR_SLEEP = 0.05  # m/s: a body slower than this may sleep
ANGULAR_SLEEP = math.radians(2.0)  # rad/s: and turning slower than this
TIME_TO_SLEEP = 0.5  # s: an island sleeps when every body has rested this long


@njit(cache=True)
def find_islands(links, dynamic):
    """The island of each body: island[i] = the smallest index of its island (union-find over
    ``links`` (L, 2) body pairs), -1 for bodies not ``dynamic`` (they join no island)."""
    n = dynamic.shape[0]
    parent = np.arange(n)
    for q in range(links.shape[0]):
        a, b = links[q, 0], links[q, 1]
        if not (dynamic[a] and dynamic[b]):
            continue
        while parent[a] != a:  # the roots, halving the paths on the way
            parent[a] = parent[parent[a]]
            a = parent[a]
        while parent[b] != b:
            parent[b] = parent[parent[b]]
            b = parent[b]
        if a != b:
            parent[max(a, b)] = min(a, b)  # the smaller index is the root
    island = np.empty(n, np.int64)
    for i in range(n):
        r = i
        while parent[r] != r:
            r = parent[r]
        island[i] = r if dynamic[i] else -1
    return island


def rests(V: np.ndarray) -> np.ndarray:
    """(N,) bool: |v| <= LINEAR_SLEEP and |omega| <= ANGULAR_SLEEP."""
    return (V[:, 0] * V[:, 0] + V[:, 1] * V[:, 1] <= LINEAR_SLEEP * LINEAR_SLEEP) & (np.abs(V[:, 2]) <= ANGULAR_SLEEP)


def islands_falling_asleep(island: np.ndarray, sleep_time: np.ndarray) -> np.ndarray:
    """The roots of the islands (``find_islands``) whose every body has rested TIME_TO_SLEEP."""
    members = island >= 0
    roots, at = np.unique(island[members], return_inverse=True)
    least = np.full(roots.shape[0], np.inf)
    np.minimum.at(least, at, sleep_time[members])
    return roots[least >= TIME_TO_SLEEP]


def overlapping(boxes_a: np.ndarray, boxes_b: np.ndarray) -> np.ndarray:
    """(A, B) bool: box a overlaps box b (boxes (min x, min y, max x, max y), touching counts)."""
    a, b = boxes_a[:, None, :], boxes_b[None, :, :]
    return (a[..., 0] <= b[..., 2]) & (a[..., 1] <= b[..., 3]) & (b[..., 0] <= a[..., 2]) & (b[..., 1] <= a[..., 3])


def grown_by_travel(aabb: np.ndarray, bodies, gravity: np.ndarray, dt: float, margin: float) -> np.ndarray:
    """Each box grown by ``margin`` and by how far its body may move within a step of dt (m):
    dt (|v| + |omega| r) + dt^2 (|s g| + |M^-1 F| + |I^-1 tau| r), with r a bound on the farthest
    point of its shape from its centre (from its box), s its gravity scale, and F, tau the
    force and torque applied for the step."""
    V, M_inv, x = bodies.V, bodies.M_inv, bodies.x
    r = np.hypot(
        np.maximum(x[:, 0] - aabb[:, 0], aabb[:, 2] - x[:, 0]), np.maximum(x[:, 1] - aabb[:, 1], aabb[:, 3] - x[:, 1])
    )
    speed = np.hypot(V[:, 0], V[:, 1]) + np.abs(V[:, 2]) * r
    force = M_inv * bodies.force  # the accelerations of the applied force and torque
    pull = np.abs(bodies.gravity_scale) * float(np.hypot(*gravity)) + np.hypot(force[:, 0], force[:, 1])
    grow = margin + dt * (speed + dt * (pull + np.abs(force[:, 2]) * r))
    return aabb + np.stack([-grow, -grow, grow, grow], axis=1)
