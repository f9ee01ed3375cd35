"""Sleeping: islands of bodies at rest leave the step until something disturbs them (Box2D's rules).

An island is a set of dynamic bodies linked by touching contacts (separation <= the world's
contact_margin) and by joints; static and kinematic bodies link nothing, so two stacks on
one ground are two islands. After each step a dynamic body slower than LINEAR_SLEEP (m/s)
and ANGULAR_SLEEP (rad/s) adds dt to its ``sleep_time``, any other resets it to 0 (as does
touching a kinematic body that moves, at any speed); an island whose every body has rested
TIME_TO_SLEEP (s) falls asleep: its velocities are set to 0, its bodies get the island's id
(``BodyArrays.island``, -1 while awake) and its entries of the contact cache are kept.

A sleeping body is stepped as an immovable one: the pipeline reads it as static (no pairs
with static or other sleeping bodies, so none of their contacts are solved) with M^-1 = 0
(no gravity), and V = 0 leaves its x and theta exactly as they are (``Pipeline.sleepers``).
It wakes with its whole island (sleep_time back to 0, its kept cache back, so its first step
warm starts) when an awake body could touch it in the coming step (``Islands.before_step``:
the mover's box grown by how far it may move), a moving kinematic body is joined to it, a
joint is added or removed on it, an impulse, force, torque, non-zero velocity, move or
filter change is given to one of its bodies, a body touching it is removed, or sleeping is
switched off (``World.sleep``). ``Body.awake`` reads and sets it by hand.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .bodies import should_collide
from .collision.queries import geometry, tight_aabbs
from .jit import njit

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


class Islands:
    """A world's sleeping islands: which bodies sleep (``BodyArrays.island``, -1 awake), each
    island's contact cache while it sleeps, and the rules that put islands to sleep and wake
    them. ``World`` calls it around each step (with its settings, ``WorldSettings``) and on
    every event that wakes; it reads the world's bodies, joints and last contacts, and tells
    the pipeline which bodies sleep."""

    def __init__(self, bodies: Any, joints: Any, pipeline: Any) -> None:
        self.bodies, self.joints, self.pipeline = bodies, joints, pipeline  # the world's
        self.some_asleep = False  # a body sleeps (then the pipeline steps it as immovable)
        self.next_island = 0  # the id the next island to fall asleep gets
        self.kept: dict[int, tuple] = {}  # a sleeping island's contact cache (``Pipeline.cache_of``)

    # -- around a step ---------------------------------------------------------------------
    def before_step(self, settings: Any, dt: float) -> None:
        """Wake the sleeping islands an awake body could touch within the step or pulls on
        through a joint, then tell the pipeline which bodies sleep (it steps them as immovable)."""
        b = self.bodies
        movers = (~b.static | (b.kinematic & np.any(b.V != 0.0, axis=1))) & (b.island < 0)
        if self.some_asleep and movers.any():  # (a world all asleep skips this)
            aabb = np.empty((b.n, 4))
            tight_aabbs(geometry(b), aabb)
            reach = grown_by_travel(aabb, b, settings.gravity, dt, settings.contact_margin)
            while self.some_asleep and movers.any():
                movers = self.wake_reached(movers, reach, aabb)  # the woken may reach further (rarely)
        self.pipeline.sleepers(b.island >= 0 if self.some_asleep else None)

    def wake_reached(self, movers: np.ndarray, reach: np.ndarray, aabb: np.ndarray) -> np.ndarray:
        """Wake the islands of the sleeping bodies whose box (``aabb``) a mover's ``reach`` overlaps
        (when the filter lets the two touch), or that a mover is joined to; returns the woken."""
        b = self.bodies
        asleep, moving = np.flatnonzero(b.island >= 0), np.flatnonzero(movers)
        m, s = np.nonzero(overlapping(reach[moving], aabb[asleep]))
        reached = [
            int(j) for i, j in zip(moving[m], asleep[s], strict=True) if should_collide(*_filter(b, i), *_filter(b, j))
        ]
        if self.joints:  # a moving kinematic body's joint partners (dynamic ones share its islands)
            ja = self.joints.arrays
            for one, other in ((ja.body_a, ja.body_b), (ja.body_b, ja.body_a)):
                reached += [int(j) for j in other[movers[one] & (b.island[other] >= 0)]]
        woken = np.zeros(b.n, np.bool_)
        for j in reached:
            if not woken[j]:
                woken |= b.island == b.island[j]
                self.wake_island_of(j)
        return woken

    def after_step(self, settings: Any, dt: float) -> None:
        """Each awake dynamic body's rest time, then the islands that rested long enough sleep."""
        b = self.bodies
        dynamic = ~b.static & (b.island < 0)
        b.sleep_time[:] = np.where(dynamic & rests(b.V), b.sleep_time + dt, 0.0)
        links = self.touching(settings.contact_margin)
        if b.kinematic.any() and links.shape[0]:  # a moving kinematic body keeps what it touches awake
            pushing = b.kinematic & np.any(b.V != 0.0, axis=1)
            b.sleep_time[links[pushing[links[:, 0]], 1]] = 0.0
            b.sleep_time[links[pushing[links[:, 1]], 0]] = 0.0
        if not np.any(b.sleep_time >= TIME_TO_SLEEP):
            return
        island = find_islands(links, dynamic)
        for root in islands_falling_asleep(island, b.sleep_time):
            self.fall_asleep(island == root)

    # -- falling asleep ----------------------------------------------------------------------
    def fall_asleep(self, members: np.ndarray) -> None:
        """The bodies ``members`` (an island) sleep: V = 0, the island's id, and their cache kept."""
        b = self.bodies
        b.V[members] = 0.0
        b.island[members] = self.next_island
        self.kept[self.next_island] = self.pipeline.cache_of(np.sort(b.uid[members]))
        self.next_island += 1
        self.some_asleep = True
        self.pipeline.bodies_changed()  # their pairs with static and sleeping bodies go

    def put_to_sleep(self, i: int, margin: float) -> None:
        """Body i's island (as the last step's contacts within ``margin`` (m) and the joints
        link it) sleeps now."""
        b = self.bodies
        if b.island[i] < 0:
            island = find_islands(self.touching(margin), ~b.static & (b.island < 0))
            self.fall_asleep(island == island[i])

    # -- waking ------------------------------------------------------------------------------
    def wake_island_of(self, i: int) -> None:
        """Wake body i's island, if it sleeps: its bodies rest from 0 s again, its cache is back."""
        b = self.bodies
        if b.island[i] < 0:
            return
        island = int(b.island[i])
        members = b.island == island
        b.island[members] = -1
        b.sleep_time[members] = 0.0
        self.warm(island)
        self.some_asleep = bool(np.any(b.island >= 0))
        self.pipeline.bodies_changed()

    def wake_near(self, i: int, margin: float) -> None:
        """Wake body i's island and the sleeping islands within ``margin`` (m, the contact margin)
        of its shape (a static body moved or removed, say, leaves nothing asleep in the air)."""
        self.wake_island_of(i)
        b = self.bodies
        aabb = np.empty((b.n, 4))
        tight_aabbs(geometry(b), aabb)
        near = overlapping(aabb[i : i + 1] + (-margin, -margin, margin, margin), aabb)[0] & (b.island >= 0)
        for j in np.flatnonzero(near):
            self.wake_island_of(int(j))

    def warm(self, island: int) -> None:
        """Put a woken island's contact cache back: its first step warm starts, as if awake."""
        kept = self.kept.pop(island, None)
        if kept is not None and kept[0].size:
            self.pipeline.warm(*kept)

    def wake_all(self) -> None:
        """Every body awake (sleep switched off)."""
        b = self.bodies
        if self.some_asleep:
            for island in np.unique(b.island[b.island >= 0]):
                self.warm(int(island))
            b.island[:] = -1
            b.sleep_time[:] = 0.0
            self.some_asleep = False
            self.pipeline.bodies_changed()

    def touching(self, margin: float) -> np.ndarray:
        """(L, 2) the body pairs an island holds together: the last step's touching contacts
        (separation <= margin, m) and the joints."""
        a, b, separation = self.pipeline.touching()
        near = separation <= margin
        pairs = [np.stack([a[near], b[near]], axis=1).astype(np.int64)]
        if self.joints:
            pairs.append(self.joints.pairs())
        return np.concatenate(pairs) if len(pairs) > 1 else pairs[0]


def _filter(b: Any, i: int) -> tuple[int, int, int]:
    """Body i's collision filter (category, mask, group) as ints, for ``should_collide``."""
    return int(b.category[i]), int(b.mask[i]), int(b.group[i])
