"""Joints as constraint rows: distance, pin (revolute point) and relative angle.

A joint couples bodies a (the row's body_a) and b (the row's body_b); either may be static.
Anchors are given in world coordinates when the joint is made and stored in each
body's frame, so they ride with the bodies. Each step the world turns every joint
into rows (docs/formulation.md#constraint-rows), appended after the contact rows,
with Baumgarte stabilisation xi = -(beta/dt) C:

    distance  1 row   C = (|d|^2 - L^2) / (2 L),   J = [-d, -(r_a x d) | d, r_b x d] / L
    pin       2 rows  C = p_b - p_a along x and y,  J = [-e, -(r_a x e) | e, r_b x e]
    angle     1 row   C = theta_b - theta_a - theta_0,  J = [0, 0, -1 | 0, 0, 1], or
              one one-sided row per limit (lower, upper) with lambda >= 0

with d = p_b - p_a the vector between the anchors, e the unit x or y vector and
r = p - x each body's lever arm to its anchor.

The distance row is the lecture's C = 1/2 (|d|^2 - L^2) and J = [-d, ... d, ...]
divided by L. Dividing a row and its C by the same positive number is the same
constraint (same zero set, same force direction), but it makes the row's
numbers independent of the joint's size: d / L is nearly a unit vector, so
C / L ~ |d| - L is in metres, xi in m/s, lambda in N s along d / |d| (negative
when the joint pulls: tension) and A_kk ~ 1/m_a + 1/m_b + angular terms, as for a
contact row. Without it, A_kk grows as L^2 and lambda shrinks as 1 / L, so rows of
short and long joints would differ in scale by orders of magnitude.

Angle limits are offsets from theta_0, the angle difference at creation. Inside
the limits each limit row is speculative, like a speculative contact: it lets
the remaining gap close within the step and no further (xi = -gap / dt); past a
limit it pushes back with xi = -(beta/dt) C. lambda >= 0 on both rows: a limit
stops rotation, it never holds it back.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..validation import finite_float, vec2
from .rows import fill_row

JOINT_DISTANCE = 0
JOINT_PIN = 1
JOINT_ANGLE = 2


def _rotate_back(p: np.ndarray, x: np.ndarray, theta: float) -> np.ndarray:
    """World point p (m) in the frame of a body at x, theta."""
    c, s = math.cos(theta), math.sin(theta)
    d = p - x
    return np.array([c * d[0] + s * d[1], -s * d[0] + c * d[1]])


class Joint:
    """A joint between two bodies: a handle onto its parameters and last reactions.

    body_a, body_b      the joined bodies (``Body`` handles; either may be static)
    collide_connected   whether body_a and body_b still collide with each other
    row_count           how many constraint rows the joint adds to a step
    row_range           the rows it had in the last step (indices into that step's
                        rows, i.e. ``w.last_step.system``); empty before the first step
    impulse             (row_count,) the lambdas of those rows in the last step (N s,
                        or N m s for angle rows); zeros before the first step
    alive               False once removed from its world
    """

    kind = -1
    name = "joint"

    def __init__(
        self, world, body_a, body_b, local_a: np.ndarray, local_b: np.ndarray, collide_connected: bool
    ) -> None:
        self._world = world
        self.body_a = body_a
        self.body_b = body_b
        self.local_a = local_a  # anchor in body a's frame, m
        self.local_b = local_b
        self.collide_connected = collide_connected
        # while in its world, its reactions are the world's (``World._joint_lam``, in joint order)
        # from _offset on; once removed, the last of them, kept here
        self._impulse = np.zeros(self.row_count)
        self._offset: int | None = None
        self._rows_offset = 0  # where its rows stood among the joint rows of the last step
        self._has_rows = False  # it took part in a step since it was added
        self.alive = True

    @property
    def row_count(self) -> int:
        return 1

    @property
    def row_range(self) -> range:
        if not self._has_rows:
            return range(0)
        start = self._world._joint_rows_first + self._rows_offset
        return range(start, start + self.row_count)

    @property
    def impulse(self) -> np.ndarray:
        """The reaction impulses of the joint's rows in the last step (a copy)."""
        if self._offset is None:
            return self._impulse.copy()
        return self._world._joint_lam[self._offset : self._offset + self.row_count].copy()

    def _params(self) -> tuple[float, float, float, float, float]:
        """(length, theta_0, lower, upper, limit flags) for the packed joint arrays."""
        return 0.0, 0.0, 0.0, 0.0, 0.0

    def _check_alive(self) -> None:
        if not self.alive:
            raise ValueError(f"this {self.name} joint was removed from its world")

    def anchors(self) -> tuple[np.ndarray, np.ndarray]:
        """The two anchor points p_a, p_b in world coordinates now (m)."""
        self._check_alive()
        return (_to_world(self.body_a, self.local_a), _to_world(self.body_b, self.local_b))

    def __repr__(self) -> str:
        state = "" if self.alive else " (removed)"
        a = self.body_a._index if self.body_a.alive else "removed"
        b = self.body_b._index if self.body_b.alive else "removed"
        return f"<{type(self).__name__} bodies {a} and {b}, {self.row_count} rows{state}>"


def _to_world(body, local: np.ndarray) -> np.ndarray:
    x = body.position
    c, s = math.cos(body.angle), math.sin(body.angle)
    return x + np.array([c * local[0] - s * local[1], s * local[0] + c * local[1]])


class DistanceJoint(Joint):
    """Keeps the anchor points p_a and p_b at distance ``length`` (m): a massless rod."""

    kind = JOINT_DISTANCE
    name = "distance"

    def __init__(self, world, body_a, body_b, local_a, local_b, length: float, collide_connected: bool) -> None:
        self.length = length
        super().__init__(world, body_a, body_b, local_a, local_b, collide_connected)

    def _params(self):
        return self.length, 0.0, 0.0, 0.0, 0.0

    def gap(self) -> float:
        """| |p_b - p_a| - L |: how far the rod is from its length now (m)."""
        p_a, p_b = self.anchors()
        return abs(float(np.hypot(*(p_b - p_a))) - self.length)


class PinJoint(Joint):
    """Keeps one point of a and one point of b together: a revolute joint (2 rows, x and y)."""

    kind = JOINT_PIN
    name = "pin"

    @property
    def row_count(self) -> int:
        return 2

    def gap(self) -> float:
        """|p_b - p_a|: how far apart the two pinned points are now (m)."""
        p_a, p_b = self.anchors()
        return float(np.hypot(*(p_b - p_a)))


LIMIT_LOWER = 1.0
LIMIT_UPPER = 2.0


class AngleJoint(Joint):
    """Keeps theta_b - theta_a at theta_0 (its value at creation), or within
    [theta_0 + lower, theta_0 + upper] when limits are given (rad)."""

    kind = JOINT_ANGLE
    name = "angle"

    def __init__(
        self, world, body_a, body_b, theta_0: float, lower: float | None, upper: float | None, collide_connected: bool
    ) -> None:
        self.theta_0 = theta_0
        self.lower = lower
        self.upper = upper
        z = np.zeros(2)
        super().__init__(world, body_a, body_b, z, z.copy(), collide_connected)

    @property
    def limited(self) -> bool:
        return self.lower is not None or self.upper is not None

    @property
    def row_count(self) -> int:
        if not self.limited:
            return 1
        return int(self.lower is not None) + int(self.upper is not None)

    def _params(self):
        flags = (LIMIT_LOWER if self.lower is not None else 0.0) + (LIMIT_UPPER if self.upper is not None else 0.0)
        return (
            0.0,
            self.theta_0,
            0.0 if self.lower is None else self.lower,
            0.0 if self.upper is None else self.upper,
            flags,
        )

    def offset(self) -> float:
        """theta_b - theta_a - theta_0 now (rad)."""
        self._check_alive()
        return self.body_b.angle - self.body_a.angle - self.theta_0


# -- building joints (validation; the world owns the lists) ---------------------------------
def optional_limit(value, name: str) -> float | None:
    return None if value is None else finite_float(value, name)


def check_limits(lower: float | None, upper: float | None) -> None:
    if lower is not None and upper is not None and lower > upper:
        raise ValueError(f"lower must be <= upper, got lower={lower}, upper={upper}")


def local_anchor(body, point, name: str) -> np.ndarray:
    """A world anchor point (m) in the body's frame; the body centre when ``point`` is None."""
    x = body.position
    p = x if point is None else vec2(point, name)
    return _rotate_back(p, x, body.angle)


# -- the rows ------------------------------------------------------------------------------
class JointArrays:
    """The world's joints packed into flat arrays (the fields of a ``JointRecord``, less lam)."""

    def __init__(self, joints) -> None:
        n = len(joints)
        self.kind = np.zeros(n, np.int32)
        self.body_a = np.zeros(n, np.int32)
        self.body_b = np.zeros(n, np.int32)
        self.local_a = np.zeros((n, 2))
        self.local_b = np.zeros((n, 2))
        self.params = np.zeros((n, 5))  # length, theta_0, lower, upper, limit flags
        self.row_offset = np.zeros(n, np.int32)
        offset = 0
        for q, joint in enumerate(joints):
            self.kind[q] = joint.kind
            self.body_a[q] = joint.body_a._index
            self.body_b[q] = joint.body_b._index
            self.local_a[q] = joint.local_a
            self.local_b[q] = joint.local_b
            self.params[q] = joint._params()
            self.row_offset[q] = offset
            offset += joint.row_count
        self.n_rows = offset


@njit(cache=True)
def _fill_angular_row(k, a, b, sign, M_inv, rows):
    """Row k = sign * [0, 0, -1 | 0, 0, 1]: the rate of theta_b - theta_a."""
    J, JM = rows.J, rows.JM
    for c in range(6):
        J[k, c] = 0.0
        JM[k, c] = 0.0
    J[k, 2] = -sign
    J[k, 5] = sign
    JM[k, 2] = -sign * M_inv[a, 2]
    JM[k, 5] = sign * M_inv[b, 2]
    rows.A_kk[k] = M_inv[a, 2] + M_inv[b, 2]


@njit(cache=True)
def _limit_xi(gap, beta, dt):
    """Velocity target of a one-sided angle row whose gap to its limit is ``gap`` (rad)."""
    if gap > 0.0:
        return -gap / dt  # inside: may close the gap within the step, no more
    return -(beta / dt) * gap  # past the limit: Baumgarte push back


@njit(cache=True)
def joint_rows(joints, first_row, bodies, dt, beta, rows):
    """Rows first_row + row_offset[q] ... of joint q into ``rows`` (see the module docstring),
    at the bodies' pose now."""
    x, theta, M_inv = bodies.x, bodies.theta, bodies.M_inv
    xi, lo, hi = rows.xi, rows.lo, rows.hi
    for q in range(joints.kind.shape[0]):
        a, b = joints.body_a[q], joints.body_b[q]
        ca, sa = np.cos(theta[a]), np.sin(theta[a])
        cb, sb = np.cos(theta[b]), np.sin(theta[b])
        r_ax = ca * joints.local_a[q, 0] - sa * joints.local_a[q, 1]
        r_ay = sa * joints.local_a[q, 0] + ca * joints.local_a[q, 1]
        r_bx = cb * joints.local_b[q, 0] - sb * joints.local_b[q, 1]
        r_by = sb * joints.local_b[q, 0] + cb * joints.local_b[q, 1]
        dx = x[b, 0] + r_bx - x[a, 0] - r_ax  # d = p_b - p_a
        dy = x[b, 1] + r_by - x[a, 1] - r_ay
        k = first_row + joints.row_offset[q]
        params = joints.params[q]
        n_rows = 1
        if joints.kind[q] == JOINT_DISTANCE:  # normalised by L
            L = params[0]
            fill_row(k, a, b, (r_ax, r_ay, r_bx, r_by), dx / L, dy / L, M_inv, rows)
            C = 0.5 * (dx * dx + dy * dy - L * L) / L
            xi[k] = -(beta / dt) * C
            lo[k] = -np.inf
            hi[k] = np.inf
        elif joints.kind[q] == JOINT_PIN:  # x row, then y row
            fill_row(k, a, b, (r_ax, r_ay, r_bx, r_by), 1.0, 0.0, M_inv, rows)
            fill_row(k + 1, a, b, (r_ax, r_ay, r_bx, r_by), 0.0, 1.0, M_inv, rows)
            xi[k] = -(beta / dt) * dx
            xi[k + 1] = -(beta / dt) * dy
            n_rows = 2
            for m in range(2):
                lo[k + m] = -np.inf
                hi[k + m] = np.inf
        else:  # relative angle
            C = theta[b] - theta[a] - params[1]
            flags = int(params[4])
            if flags == 0:
                _fill_angular_row(k, a, b, 1.0, M_inv, rows)
                xi[k] = -(beta / dt) * C
                lo[k] = -np.inf
                hi[k] = np.inf
            else:
                n_rows = 0
                if flags & 1:  # lower: C - lower >= 0, row +[0, 0, -1 | 0, 0, 1]
                    _fill_angular_row(k, a, b, 1.0, M_inv, rows)
                    xi[k] = _limit_xi(C - params[2], beta, dt)
                    n_rows = 1
                if flags & 2:  # upper: upper - C >= 0, row -[0, 0, -1 | 0, 0, 1]
                    u = k + n_rows
                    _fill_angular_row(u, a, b, -1.0, M_inv, rows)
                    xi[u] = _limit_xi(params[3] - C, beta, dt)
                    n_rows += 1
                for m in range(n_rows):
                    lo[k + m] = 0.0
                    hi[k + m] = np.inf
        for m in range(n_rows):
            rows.body_a[k + m] = a
            rows.body_b[k + m] = b
            rows.bound_row[k + m] = -1
            rows.mu[k + m] = 0.0


@njit(cache=True)
def start_joint_rows(joints, first_row, bodies, dt, beta, warm_start, rows):
    """The joints' rows (``joint_rows``, from first_row on) as a step starts them: no push (a joint
    keeps its Baumgarte term in xi), no bounce, no impact, and lambda from the joints' last
    reactions (``joints.lam``, in joint order) when warm starting, since joints keep their
    identity; else from 0."""
    joint_rows(joints, first_row, bodies, dt, beta, rows)
    for r in range(first_row, first_row + joints.lam.shape[0]):
        rows.push[r] = 0.0
        rows.bounce[r] = 0.0
        rows.impact[r] = False
        rows.lam[r] = joints.lam[r - first_row] if warm_start else 0.0
