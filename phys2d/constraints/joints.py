"""Joints as constraint rows: distance, pin (revolute, with motor and limits), relative angle,
slider (prismatic), weld and mouse.

A joint couples bodies a (the row's body_a) and b (the row's body_b); either may be static.
Anchors are given in world coordinates when the joint is made and stored in each
body's frame, so they ride with the bodies. Each step the world turns every joint
into rows (docs/formulation.md#constraint-rows), appended after the contact rows,
with Baumgarte stabilisation push = -(beta/dt) C and xi = 0 (the row holds still):

    distance  1 row   C = (|d|^2 - L^2) / (2 L),   J = [-d, -(r_a x d) | d, r_b x d] / L
    pin       2 rows  C = p_b - p_a along x and y,  J = [-e, -(r_a x e) | e, r_b x e]
    angle     1 row   C = theta_b - theta_a - theta_0,  J = [0, 0, -1 | 0, 0, 1], or
              one one-sided row per limit (lower, upper) with lambda >= 0
    slider    2 rows  C = n . d (n the axis u turned by +90 deg, both turning with a) and the
              angle row;  J = [-n, -((r_a + d) x n) | n, r_b x n]
    weld      3 rows  the pin's two and the angle row
    mouse     2 rows  C = p_b - target along x and y, J = [0 | e, r_b x e]: the world is the
              other side (the row's body_a is body_b, its entries zero); soft, solved by its own
              2x2 block (``responders.mouse``), |lambda| <= max_force dt

with d = p_b - p_a the vector between the anchors, e the unit x or y vector and
r = p - x each body's lever arm to its anchor.

A pin's motor and limits, and a slider's, come first among its rows (motor, lower, upper),
then its equality rows: the motor row J = [0, 0, -1 | 0, 0, 1] (pin) or [-u, -((r_a + d) x u)
| u, r_b x u] (slider, the axis u) with xi = motor_speed and lo, hi = -+max_motor dt (N m s
or N s); the limit rows are one-sided (lambda >= 0) on the angle theta_b - theta_a - theta_0
(pin) or the translation s = u . d (slider), the upper one with the row negated.

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
limit it holds still (xi = 0) and pushes back with push = -(beta/dt) C. lambda >= 0
on both rows: a limit stops rotation, it never holds it back.

The Baumgarte term goes in ``push``, as a contact's does, not in xi: the lecture's
target is xi + push (PGS with split=False); split, PGS solves it after the warm-started
sweeps, in a pass from zero whose joint impulses stay in V. That split matters for a net
of joints with more rows than its bodies have freedoms (Box2D's joint grid): their errors
C need not lie in the range of J, so A lambda = -(beta/dt) C has no solution, and a
warm-started sweep lets lambda grow without bound in A's null space; A lambda = -J V
always has one.
"""

from __future__ import annotations

import math

import numpy as np

from ..jit import njit
from ..validation import finite_float, non_negative_float, vec2
from .rows import fill_row

JOINT_DISTANCE = 0
JOINT_PIN = 1
JOINT_ANGLE = 2
JOINT_SLIDER = 3
JOINT_WELD = 4
JOINT_MOUSE = 5

# the columns of JointArrays.params
P_LENGTH, P_THETA_0, P_LOWER, P_UPPER, P_FLAGS = 0, 1, 2, 3, 4
P_MOTOR_SPEED, P_MOTOR_MAX = 5, 6  # rad/s or m/s; N m or N (the mouse: max_force, N)
P_X, P_Y = 7, 8  # the slider's axis u in a's frame, or the mouse's target (m)
P_HERTZ, P_ZETA = 9, 10  # the mouse's spring: frequency (Hz) and damping ratio
N_PARAMS = 11

HAS_LOWER, HAS_UPPER, HAS_MOTOR = 1, 2, 4  # the bits of params[P_FLAGS]

OWN_SOLVE = -2  # bound_row of a mouse row: solved by its joint's own soft 2x2 solve, not swept


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
        # while in its world, its reactions are the world's (``JointSet.lam``, in joint order)
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
        start = self._world._joints.rows_first + self._rows_offset
        return range(start, start + self.row_count)

    @property
    def impulse(self) -> np.ndarray:
        """The reaction impulses of the joint's rows in the last step (a copy)."""
        if self._offset is None:
            return self._impulse.copy()
        return self._world._joints.lam[self._offset : self._offset + self.row_count].copy()

    def _params(self) -> tuple[float, float, float, float, float]:
        """The joint's row of the packed joint arrays' params (columns P_*; the rest are 0)."""
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


class _MotorAndLimits(Joint):
    """A joint with an optional motor and optional limits on one relative coordinate (the pin's
    angle, the slider's translation): their rows come first, then the joint's equality rows.

    motor_speed   the speed the motor drives the coordinate at (rad/s or m/s), None: no motor
    lower, upper  the limits (rad or m, offsets from the pose at creation), None: none
    and the motor's largest torque or force (``max_motor_torque`` or ``max_motor_force``)

    Each is settable; a bad value is refused with the constructor's message and changes nothing.
    """

    equality_rows = 2
    _max_name = "max_motor"

    def _init_motor(self, motor_speed, max_motor, lower, upper) -> None:
        self._motor_speed = motor_speed
        self._max_motor = max_motor
        self._lower = lower
        self._upper = upper

    @property
    def row_count(self) -> int:
        return self.extra_rows + self.equality_rows

    @property
    def extra_rows(self) -> int:
        """Its motor and limit rows, which come before its equality rows."""
        return int(self._motor_speed is not None) + int(self._lower is not None) + int(self._upper is not None)

    def _flags(self) -> float:
        flags = HAS_LOWER if self._lower is not None else 0
        flags += HAS_UPPER if self._upper is not None else 0
        flags += HAS_MOTOR if self._motor_speed is not None else 0
        return float(flags)

    def _extras(self) -> tuple[float, float, float, float, float]:
        """(lower, upper, flags, motor_speed, max motor) for the packed joint arrays."""
        return (
            0.0 if self._lower is None else self._lower,
            0.0 if self._upper is None else self._upper,
            self._flags(),
            0.0 if self._motor_speed is None else self._motor_speed,
            self._max_motor,
        )

    def _set(self, **values) -> None:
        """Set already-checked attributes and tell the world (its rows change when the set of
        motor and limits does)."""
        self._check_alive()
        before = self.row_count
        for name, value in values.items():
            setattr(self, "_" + name, value)
        self._world._joint_changed(self, self.row_count != before)

    @property
    def motor_speed(self) -> float | None:
        """The motor's target speed (rad/s for a pin, m/s for a slider), or None: no motor."""
        return self._motor_speed

    @motor_speed.setter
    def motor_speed(self, value: float | None) -> None:
        self._set(motor_speed=optional_limit(value, "motor_speed"))

    @property
    def lower(self) -> float | None:
        """The lower limit (rad or m, from the pose at creation), or None."""
        return self._lower

    @lower.setter
    def lower(self, value: float | None) -> None:
        value = optional_limit(value, "lower")
        check_limits(value, self._upper)
        self._set(lower=value)

    @property
    def upper(self) -> float | None:
        """The upper limit (rad or m, from the pose at creation), or None."""
        return self._upper

    @upper.setter
    def upper(self, value: float | None) -> None:
        value = optional_limit(value, "upper")
        check_limits(self._lower, value)
        self._set(upper=value)

    def set_limits(self, lower: float | None, upper: float | None) -> None:
        """Both limits at once (rad or m; None: no limit on that side)."""
        lower, upper = optional_limit(lower, "lower"), optional_limit(upper, "upper")
        check_limits(lower, upper)
        self._set(lower=lower, upper=upper)

    def _row_names(self) -> list[str]:
        names = ["motor"] if self._motor_speed is not None else []
        names += ["lower"] if self._lower is not None else []
        names += ["upper"] if self._upper is not None else []
        return names

    def _impulse_of(self, name: str) -> float:
        names = self._row_names()
        return float(self.impulse[names.index(name)]) if name in names else 0.0

    @property
    def motor_impulse(self) -> float:
        """The motor row's lambda in the last step (N m s or N s), 0 without a motor."""
        return self._impulse_of("motor")

    @property
    def limit_impulse(self) -> float:
        """The limit rows' lambda in the last step, lower minus upper (N m s or N s): positive
        when the lower stop pushes."""
        return self._impulse_of("lower") - self._impulse_of("upper")

    def _motor_repr(self) -> str:
        parts = []
        if self._motor_speed is not None:
            parts.append(f"motor_speed={self._motor_speed:g}, {self._max_name}={self._max_motor:g}")
        if self._lower is not None:
            parts.append(f"lower={self._lower:g}")
        if self._upper is not None:
            parts.append(f"upper={self._upper:g}")
        return "".join(", " + p for p in parts)


class PinJoint(_MotorAndLimits):
    """Keeps one point of a and one point of b together: a revolute joint (2 rows, x and y),
    with an optional motor on omega_b - omega_a and optional limits on theta_b - theta_a -
    theta_0 (theta_0: its value at creation), one row each, before the point rows."""

    kind = JOINT_PIN
    name = "pin"
    _max_name = "max_motor_torque"

    def __init__(
        self,
        world,
        body_a,
        body_b,
        local_a,
        local_b,
        collide_connected: bool,
        theta_0: float = 0.0,
        motor: tuple[float | None, float] = (None, 0.0),
        limits: tuple[float | None, float | None] = (None, None),
    ) -> None:
        self.theta_0 = theta_0
        self._init_motor(motor[0], motor[1], limits[0], limits[1])
        super().__init__(world, body_a, body_b, local_a, local_b, collide_connected)

    def _params(self):
        return (0.0, self.theta_0, *self._extras())

    @property
    def max_motor_torque(self) -> float:
        """The motor's largest torque (N m): |lambda_motor| <= max_motor_torque dt."""
        return self._max_motor

    @max_motor_torque.setter
    def max_motor_torque(self, value: float) -> None:
        self._set(max_motor=non_negative_float(value, "max_motor_torque"))

    def angle(self) -> float:
        """theta_b - theta_a - theta_0 now (rad): what the limits bound."""
        self._check_alive()
        return self.body_b.angle - self.body_a.angle - self.theta_0

    def gap(self) -> float:
        """|p_b - p_a|: how far apart the two pinned points are now (m)."""
        p_a, p_b = self.anchors()
        return float(np.hypot(*(p_b - p_a)))

    def __repr__(self) -> str:
        return super().__repr__()[:-1] + self._motor_repr() + ">"


class SliderJoint(_MotorAndLimits):
    """A prismatic joint: b slides relative to a along the axis u (a world direction at
    creation, kept in a's frame) and may not turn relative to a. Two equality rows (across the
    axis, the relative angle), after an optional motor along u and optional limits on the
    translation s = u . (p_b - p_a) (m, 0 at creation)."""

    kind = JOINT_SLIDER
    name = "slider"
    _max_name = "max_motor_force"

    def __init__(
        self,
        world,
        body_a,
        body_b,
        local_a,
        local_b,
        axis: np.ndarray,
        theta_0: float,
        motor: tuple[float | None, float] = (None, 0.0),
        limits: tuple[float | None, float | None] = (None, None),
    ) -> None:
        self.local_axis = axis  # the unit axis u in a's frame
        self.theta_0 = theta_0
        self._init_motor(motor[0], motor[1], limits[0], limits[1])
        super().__init__(world, body_a, body_b, local_a, local_b, False)

    def _params(self):
        return (0.0, self.theta_0, *self._extras(), self.local_axis[0], self.local_axis[1])

    @property
    def max_motor_force(self) -> float:
        """The motor's largest force (N): |lambda_motor| <= max_motor_force dt."""
        return self._max_motor

    @max_motor_force.setter
    def max_motor_force(self, value: float) -> None:
        self._set(max_motor=non_negative_float(value, "max_motor_force"))

    @property
    def axis(self) -> np.ndarray:
        """The axis u in world coordinates now (unit; it turns with body a)."""
        self._check_alive()
        c, s = math.cos(self.body_a.angle), math.sin(self.body_a.angle)
        u = self.local_axis
        return np.array([c * u[0] - s * u[1], s * u[0] + c * u[1]])

    def translation(self) -> float:
        """s = u . (p_b - p_a) now (m): what the limits bound and the motor drives."""
        p_a, p_b = self.anchors()
        return float(self.axis @ (p_b - p_a))

    def drift(self) -> float:
        """|n . (p_b - p_a)|: how far b has left the axis now (m)."""
        p_a, p_b = self.anchors()
        u = self.axis
        return abs(float(-u[1] * (p_b - p_a)[0] + u[0] * (p_b - p_a)[1]))

    def __repr__(self) -> str:
        u = self.local_axis
        return super().__repr__()[:-1] + f", axis ({u[0]:g}, {u[1]:g}) in a's frame" + self._motor_repr() + ">"


class WeldJoint(Joint):
    """Glues b to a at ``anchor``: no relative motion (the pin's two rows and the angle row)."""

    kind = JOINT_WELD
    name = "weld"

    def __init__(self, world, body_a, body_b, local_a, local_b, theta_0: float) -> None:
        self.theta_0 = theta_0
        super().__init__(world, body_a, body_b, local_a, local_b, False)

    @property
    def row_count(self) -> int:
        return 3

    def _params(self):
        return 0.0, self.theta_0, 0.0, 0.0, 0.0

    def gap(self) -> float:
        """|p_b - p_a|: how far apart the two welded points are now (m)."""
        p_a, p_b = self.anchors()
        return float(np.hypot(*(p_b - p_a)))

    def angle(self) -> float:
        """theta_b - theta_a - theta_0 now (rad): 0 for a perfect weld."""
        self._check_alive()
        return self.body_b.angle - self.body_a.angle - self.theta_0


class MouseJoint(Joint):
    """Pulls a point of a body toward ``target`` (m, settable) with a soft spring, Box2D's mouse
    joint: frequency ``hertz`` and damping ratio ``damping_ratio``, the pull's impulse at most
    ``max_force`` dt a step (N s). The point is the body's material point that lay under the
    target when the joint was made (it need not lie inside the shape). The other side is the
    world: ``body_a`` and ``body_b`` are both the body. Two rows (x, y), solved together."""

    kind = JOINT_MOUSE
    name = "mouse"

    def __init__(self, world, body, local: np.ndarray, target: np.ndarray, max_force, hertz, damping_ratio) -> None:
        self._target = target
        self._max_force = max_force
        self.hertz = hertz
        self.damping_ratio = damping_ratio
        super().__init__(world, body, body, local, local.copy(), True)

    @property
    def body(self):
        """The dragged body."""
        return self.body_b

    @property
    def row_count(self) -> int:
        return 2

    def _params(self):
        t = self._target
        return (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, self._max_force, t[0], t[1], self.hertz, self.damping_ratio)

    @property
    def target(self) -> np.ndarray:
        """Where the point is pulled to (m), a copy; set it to drag."""
        return self._target.copy()

    @target.setter
    def target(self, value) -> None:
        self._check_alive()
        self._target = vec2(value, "target")
        self._world._joint_changed(self, False)

    @property
    def max_force(self) -> float:
        """The largest pull (N): |lambda| <= max_force dt a step."""
        return self._max_force

    @max_force.setter
    def max_force(self, value: float) -> None:
        self._check_alive()
        self._max_force = non_negative_float(value, "max_force")
        self._world._joint_changed(self, False)

    def anchors(self) -> tuple[np.ndarray, np.ndarray]:
        """The target and the body's pulled point now (m): what the recordings draw."""
        self._check_alive()
        return self._target.copy(), _to_world(self.body_b, self.local_b)

    def error(self) -> float:
        """|p - target|: how far the pulled point is from the target now (m)."""
        target, p = self.anchors()
        return float(np.hypot(*(p - target)))

    def __repr__(self) -> str:
        state = "" if self.alive else " (removed)"
        b = self.body_b._index if self.body_b.alive else "removed"
        t = self._target
        return (
            f"<MouseJoint body {b}, target ({t[0]:g}, {t[1]:g}), max_force={self._max_force:g}, "
            f"hertz={self.hertz:g}, damping_ratio={self.damping_ratio:g}{state}>"
        )


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
        self.params = np.zeros((n, N_PARAMS))  # the columns P_*
        self.row_offset = np.zeros(n, np.int32)
        offset = 0
        for q, joint in enumerate(joints):
            self.kind[q] = joint.kind
            self.body_a[q] = joint.body_a._index
            self.body_b[q] = joint.body_b._index
            self.local_a[q] = joint.local_a
            self.local_b[q] = joint.local_b
            values = joint._params()
            self.params[q, : len(values)] = values
            self.row_offset[q] = offset
            offset += joint.row_count
        self.n_rows = offset


class JointSet:
    """A world's joints: the handles in creation order, the same packed into flat arrays for the
    step (``arrays``, repacked once after any number of changes, so a scene of n joints builds in
    O(n)), their last reactions (``lam``, each step's warm start) and the pairs of bodies they
    keep from colliding (``excluded``). What the world offers its pipeline and its islands of
    the joints."""

    def __init__(self) -> None:
        self.handles: list[Joint] = []
        self.mice = 0  # how many are mouse joints
        self.rows_first = 0  # the first joint row of the last step
        self.version = 0  # counts the changes: the pipeline reads the packed joints anew when it moves
        self._packed = True  # arrays, lam and excluded hold the joints as they are
        self._placed = True  # every joint knows where its rows stood in the last step
        self._arrays = JointArrays([])
        self._lam = np.zeros(0)
        self._excluded = np.zeros(0, np.int64)

    def __len__(self) -> int:
        return len(self.handles)

    def __bool__(self) -> bool:
        return bool(self.handles)

    def add(self, joint: Joint) -> None:
        self.handles.append(joint)
        self.mice += isinstance(joint, MouseJoint)
        self.changed()

    def remove(self, joint: Joint) -> None:
        """Take ``joint`` out; its handle keeps its last reactions."""
        joint._impulse = joint.impulse
        joint._offset = None
        self.handles.remove(joint)
        self.mice -= isinstance(joint, MouseJoint)
        joint.alive = False
        joint._has_rows = False
        self.changed()

    def changed(self) -> None:
        """Joints were added, removed or had their rows changed: pack them anew when next read."""
        self._packed = False
        self.version += 1

    def params_changed(self, joint: Joint) -> None:
        """``joint``'s parameters changed, not its rows: written into the packed arrays in place."""
        values = joint._params()
        self.arrays.params[self.handles.index(joint), : len(values)] = values

    @property
    def arrays(self) -> JointArrays:
        """The joints packed into flat arrays, in creation order."""
        if not self._packed:
            self._pack()
        return self._arrays

    @property
    def lam(self) -> np.ndarray:
        """The joints' last reactions, in joint order (N s): each step's warm start."""
        if not self._packed:
            self._pack()
        return self._lam

    @property
    def excluded(self) -> np.ndarray:
        """The sorted keys (a << 32 | b, a < b) of the pairs of bodies that must not collide."""
        if not self._packed:
            self._pack()
        return self._excluded

    def pairs(self) -> np.ndarray:
        """(L, 2) int64 the bodies each joint holds together."""
        return np.array([(q.body_a._index, q.body_b._index) for q in self.handles], np.int64).reshape(-1, 2)

    def _pack(self) -> None:
        """Pack the joints (each keeps its last reactions) and the keys of the pairs they exclude."""
        self._arrays = ja = JointArrays(self.handles)
        lam, old = np.zeros(ja.n_rows), self._lam
        for q, joint in enumerate(self.handles):
            offset = int(ja.row_offset[q])
            if joint._offset is not None:  # its reactions in the old packing (``Joint.impulse``)
                lam[offset : offset + joint.row_count] = old[joint._offset : joint._offset + joint.row_count]
            joint._offset = offset
        self._lam = lam
        self._placed = False
        keys = [
            (min(q.body_a._index, q.body_b._index) << 32) | max(q.body_a._index, q.body_b._index)
            for q in self.handles
            if not q.collide_connected
        ]
        self._excluded = np.unique(np.asarray(keys, np.int64))
        self._packed = True

    def impulses(self) -> list[np.ndarray]:
        """Each joint's last reactions (``Joint.impulse``), read without packing the joints anew."""
        out = []
        for joint in self.handles:
            if joint._offset is None:
                out.append(np.asarray(joint._impulse, np.float64))
            else:
                out.append(self._lam[joint._offset : joint._offset + joint.row_count])
        return out

    def state(self) -> tuple[np.ndarray, int, bool, bool]:
        """(the packed reactions as they lie, rows_first, packed, placed): what a snapshot keeps."""
        return self._lam, self.rows_first, self._packed, self._placed

    @classmethod
    def restored(cls, handles: list[Joint], lam: np.ndarray, rows_first: int, packed: bool, placed: bool) -> JointSet:
        """The joints of a snapshot: ``handles`` (their offsets into ``lam`` as they were), packed
        again, and the bookkeeping as the original's next pack would leave it."""
        joints = cls()
        joints.handles = list(handles)
        joints.mice = sum(isinstance(j, MouseJoint) for j in handles)
        joints._lam, joints.rows_first = lam, rows_first
        joints._pack()  # the packed joints and excluded pairs, each joint's reactions from its offset
        joints._placed = placed if packed else False
        return joints

    def store_impulses(self, first_row: int, lam: np.ndarray) -> None:
        """Keep the reactions of the step just taken: the rows' ``lam`` from first_row on, in
        joint order (one copy, which every joint's ``impulse`` reads)."""
        self._lam[:] = lam[first_row : first_row + self._lam.shape[0]]
        self.rows_first = first_row
        if not self._placed:  # joints were added or removed since: each learns its rows' place
            for joint in self.handles:
                assert joint._offset is not None  # placed by _pack
                joint._rows_offset, joint._has_rows = joint._offset, True
            self._placed = True


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
def _limit_target(gap, beta, dt):
    """(xi, push) of a one-sided row whose gap to its limit is ``gap`` (rad or m): inside, xi
    lets the gap close within the step and no more; past the limit, xi holds still and the
    push is the Baumgarte term that pushes back."""
    if gap > 0.0:
        return -gap / dt, 0.0  # inside: may close the gap within the step, no more
    return 0.0, -(beta / dt) * gap  # past the limit: Baumgarte push back


@njit(cache=True, inline="always")
def _free(k, n, lo, hi):
    """Rows k .. k + n - 1 are equality rows: lambda free."""
    for m in range(n):
        lo[k + m] = -np.inf
        hi[k + m] = np.inf


@njit(cache=True)
def _extra_rows(k, a, b, arms, u, s, params, dt, beta, M_inv, rows):
    """A pin's or slider's motor and limit rows from row k: the motor (xi = motor_speed,
    |lambda| <= max_motor dt), then the one-sided limits on s (rad or m): lower with the row
    +J, upper with -J, each with the limit's target (``_limit_target``). ``u`` is the rows'
    direction (a slider's axis), or None for the angle rows of a pin. Returns how many rows."""
    xi, push, lo, hi = rows.xi, rows.push, rows.lo, rows.hi
    flags = int(params[P_FLAGS])
    n = 0
    if flags & HAS_MOTOR:
        _fill_direction(k, a, b, arms, u, 1.0, M_inv, rows)
        xi[k], push[k] = params[P_MOTOR_SPEED], 0.0  # a speed to reach: no position to hold
        lo[k] = -params[P_MOTOR_MAX] * dt
        hi[k] = params[P_MOTOR_MAX] * dt
        n = 1
    if flags & HAS_LOWER:  # s - lower >= 0
        _fill_direction(k + n, a, b, arms, u, 1.0, M_inv, rows)
        xi[k + n], push[k + n] = _limit_target(s - params[P_LOWER], beta, dt)
        lo[k + n], hi[k + n] = 0.0, np.inf
        n += 1
    if flags & HAS_UPPER:  # upper - s >= 0
        _fill_direction(k + n, a, b, arms, u, -1.0, M_inv, rows)
        xi[k + n], push[k + n] = _limit_target(params[P_UPPER] - s, beta, dt)
        lo[k + n], hi[k + n] = 0.0, np.inf
        n += 1
    return n


@njit(cache=True)
def _fill_direction(k, a, b, arms, u, sign, M_inv, rows):
    """Row k along sign * u at the lever arms ``arms`` (a slider's axis), or sign times the
    angle row when u is None."""
    if u is None:
        _fill_angular_row(k, a, b, sign, M_inv, rows)
    else:
        fill_row(k, a, b, arms, sign * u[0], sign * u[1], M_inv, rows)


@njit(cache=True, inline="always")
def _fill_world_row(k, b, r_bx, r_by, dx, dy, M_inv, rows):
    """Row k = [0, 0, 0 | d, r_b x d] on body b alone: its other side is the world (static).
    body_a is b too, with zero entries, so the row touches no other body."""
    J, JM = rows.J, rows.JM
    j = (dx, dy, r_bx * dy - r_by * dx)
    A = 0.0
    for c in range(3):
        J[k, c], JM[k, c] = 0.0, 0.0
        J[k, 3 + c] = j[c]
        JM[k, 3 + c] = M_inv[b, c] * j[c]
        A += j[c] * JM[k, 3 + c]
    rows.A_kk[k] = A


@njit(cache=True)
def joint_rows(joints, first_row, bodies, dt, beta, rows):
    """Rows first_row + row_offset[q] ... of joint q into ``rows`` (see the module docstring),
    at the bodies' pose now."""
    x, theta, M_inv = bodies.x, bodies.theta, bodies.M_inv
    xi, push, lo, hi = rows.xi, rows.push, rows.lo, rows.hi
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
        kind = joints.kind[q]
        n_rows = 1
        if kind == JOINT_DISTANCE:  # normalised by L
            L = params[0]
            fill_row(k, a, b, (r_ax, r_ay, r_bx, r_by), dx / L, dy / L, M_inv, rows)
            C = 0.5 * (dx * dx + dy * dy - L * L) / L
            xi[k], push[k] = 0.0, -(beta / dt) * C
            lo[k] = -np.inf
            hi[k] = np.inf
        elif kind == JOINT_PIN or kind == JOINT_WELD:  # (motor, limits,) x row, y row (, angle)
            p = 0
            if kind == JOINT_PIN and params[P_FLAGS] != 0.0:
                C = theta[b] - theta[a] - params[P_THETA_0]
                p = _extra_rows(k, a, b, (r_ax, r_ay, r_bx, r_by), None, C, params, dt, beta, M_inv, rows)
            fill_row(k + p, a, b, (r_ax, r_ay, r_bx, r_by), 1.0, 0.0, M_inv, rows)
            fill_row(k + p + 1, a, b, (r_ax, r_ay, r_bx, r_by), 0.0, 1.0, M_inv, rows)
            xi[k + p], push[k + p] = 0.0, -(beta / dt) * dx
            xi[k + p + 1], push[k + p + 1] = 0.0, -(beta / dt) * dy
            _free(k + p, 2, lo, hi)
            n_rows = p + 2
            if kind == JOINT_WELD:
                _fill_angular_row(k + 2, a, b, 1.0, M_inv, rows)
                xi[k + 2], push[k + 2] = 0.0, -(beta / dt) * (theta[b] - theta[a] - params[P_THETA_0])
                _free(k + 2, 1, lo, hi)
                n_rows = 3
        elif kind == JOINT_SLIDER:  # (motor, limits,) across the axis, angle
            ux = ca * params[P_X] - sa * params[P_Y]  # the axis u turns with a
            uy = sa * params[P_X] + ca * params[P_Y]
            arms = (r_ax + dx, r_ay + dy, r_bx, r_by)  # a's arm reaches p_b: u turns about x_a
            p = _extra_rows(k, a, b, arms, (ux, uy), ux * dx + uy * dy, params, dt, beta, M_inv, rows)
            fill_row(k + p, a, b, arms, -uy, ux, M_inv, rows)  # n = u turned by +90 deg
            xi[k + p], push[k + p] = 0.0, -(beta / dt) * (-uy * dx + ux * dy)
            _fill_angular_row(k + p + 1, a, b, 1.0, M_inv, rows)
            xi[k + p + 1], push[k + p + 1] = 0.0, -(beta / dt) * (theta[b] - theta[a] - params[P_THETA_0])
            _free(k + p, 2, lo, hi)
            n_rows = p + 2
        elif kind == JOINT_MOUSE:  # x row, y row on b alone; xi = -C/dt, the rigid target
            _fill_world_row(k, b, r_bx, r_by, 1.0, 0.0, M_inv, rows)
            _fill_world_row(k + 1, b, r_bx, r_by, 0.0, 1.0, M_inv, rows)
            xi[k] = -(x[b, 0] + r_bx - params[P_X]) / dt
            xi[k + 1] = -(x[b, 1] + r_by - params[P_Y]) / dt
            push[k], push[k + 1] = 0.0, 0.0  # its own soft solve: not in the push pass
            for m in range(2):
                lo[k + m] = -params[P_MOTOR_MAX] * dt
                hi[k + m] = params[P_MOTOR_MAX] * dt
            n_rows = 2
        else:  # relative angle
            C = theta[b] - theta[a] - params[1]
            flags = int(params[4])
            if flags == 0:
                _fill_angular_row(k, a, b, 1.0, M_inv, rows)
                xi[k], push[k] = 0.0, -(beta / dt) * C
                lo[k] = -np.inf
                hi[k] = np.inf
            else:
                n_rows = 0
                if flags & 1:  # lower: C - lower >= 0, row +[0, 0, -1 | 0, 0, 1]
                    _fill_angular_row(k, a, b, 1.0, M_inv, rows)
                    xi[k], push[k] = _limit_target(C - params[2], beta, dt)
                    n_rows = 1
                if flags & 2:  # upper: upper - C >= 0, row -[0, 0, -1 | 0, 0, 1]
                    u = k + n_rows
                    _fill_angular_row(u, a, b, -1.0, M_inv, rows)
                    xi[u], push[u] = _limit_target(params[3] - C, beta, dt)
                    n_rows += 1
                for m in range(n_rows):
                    lo[k + m] = 0.0
                    hi[k + m] = np.inf
        for m in range(n_rows):
            rows.body_a[k + m] = a
            rows.body_b[k + m] = b
            rows.bound_row[k + m] = OWN_SOLVE if kind == JOINT_MOUSE else -1
            rows.mu[k + m] = 0.0


@njit(cache=True)
def start_joint_rows(joints, first_row, bodies, dt, beta, warm_start, rows):
    """The joints' rows (``joint_rows``, from first_row on) as a step starts them: no bounce, no
    impact, and lambda from the joints' last reactions (``JointRecord.lam``, in joint order) when
    warm starting, since joints keep their identity; else from 0."""
    joint_rows(joints, first_row, bodies, dt, beta, rows)
    for r in range(first_row, first_row + joints.lam.shape[0]):
        rows.bounce[r] = 0.0
        rows.impact[r] = False
        rows.lam[r] = joints.lam[r - first_row] if warm_start else 0.0
