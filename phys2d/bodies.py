"""Body state in the lecture's layout, and the Body handles that view it.

The world keeps every body's state in flat arrays (Box2D v3 style), one row per
body in creation order:

    x      (N, 2)  centre of mass, m
    theta  (N,)    angle, rad
    V      (N, 3)  the lecture's V: [vx, vy, omega] in m/s and rad/s
    M_inv  (N, 3)  the diagonal of M^-1: [1/m, 1/m, 1/I] (0 for static bodies)

plus each body's shape (kind, radius, a slice of the polygon vertex arrays), material
(friction, restitution), the forces on it besides contacts (gravity_scale, damping, the
force applied for the next step) and its collision filter (category, mask, group). A
:class:`Body` is a thin handle: an index into these arrays, never a copy of them.

Three kinds of body, as in Box2D: dynamic (moved by forces and contacts), static (never
moves) and kinematic (moves at the velocity it is given; no force or contact changes it).
Static and kinematic bodies both have M^-1 = 0, and the arrays' ``static`` flag (infinite
mass) is set for both; ``kinematic`` tells them apart.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, NamedTuple, TypedDict

import numpy as np
from numpy.typing import ArrayLike

from .shapes import CHAIN, CIRCLE, KIND_NAMES, ShapeSpec
from .validation import (
    MAX_BITS,
    check_bool,
    filter_bits,
    filter_group,
    finite_float,
    float_in,
    non_negative_float,
    positive_float,
    vec2,
)

MAX_BODY_UID = (1 << 23) - 1  # contact keys pack two uids in 46 bits
# densities a body may have (kg/m^2, 2D): water 1 m deep is 1000, steel 1 m deep 7800; the range
# keeps mass ratios within 1e12 and M^-1 a normal float
MIN_DENSITY = 1e-6
MAX_DENSITY = 1e6


ALL_CATEGORIES = MAX_BITS  # the default mask: collide with every category


class PlacedBodyOptions(TypedDict, total=False):
    """``BodyOptions`` but the angle: what a shape placed by its points (a segment, a chain) takes,
    and what an ``add_*`` that names ``angle`` itself takes besides it."""

    density: float  # kg/m^2 (2D)
    friction: float  # mu >= 0 (pairs mix sqrt(mu_a mu_b))
    restitution: float  # e in [0, 1] (pairs take max(e_a, e_b))
    static: bool  # never moves
    kinematic: bool  # moves at the velocity it is given; no force or contact changes it
    velocity: ArrayLike  # (vx, vy) m/s
    angular_velocity: float  # rad/s
    gravity_scale: float  # its gravity is gravity_scale g
    linear_damping: float  # c >= 0 (1/s): v /= 1 + c dt every step
    angular_damping: float  # c >= 0 (1/s): omega /= 1 + c dt every step
    category: int  # the categories it belongs to, a 64-bit mask
    mask: int  # the categories it collides with, a 64-bit mask
    group: int  # a shared negative group never collides, a shared positive group always does
    fixed_rotation: bool  # it never turns: M^-1's 1/I is 0 and omega stays 0 (Box2D's motion lock)


class BodyOptions(PlacedBodyOptions, total=False):
    """The keyword arguments every ``World.add_*`` takes besides the shape (SI units)."""

    angle: float  # rad


class BodySettings(NamedTuple):
    """``BodyOptions`` checked, with every default filled in."""

    angle: float = 0.0
    density: float = 1.0
    friction: float = 0.6
    restitution: float = 0.0
    static: bool = False
    kinematic: bool = False
    velocity: tuple[float, float] = (0.0, 0.0)
    angular_velocity: float = 0.0
    gravity_scale: float = 1.0
    linear_damping: float = 0.0
    angular_damping: float = 0.0
    category: int = 1
    mask: int = ALL_CATEGORIES
    group: int = 0
    fixed_rotation: bool = False


def body_settings(options: BodyOptions) -> BodySettings:
    """Check ``options`` (a ``BodyOptions``): each value, and that no name is unknown."""
    unknown = sorted(set(options) - set(BodySettings._fields))
    if unknown:
        raise TypeError(f"unexpected keyword argument {unknown[0]!r}; a body takes {', '.join(BodySettings._fields)}")
    o = BodySettings()._replace(**options)  # type: ignore[arg-type]  # (velocity: checked just below)
    v = vec2(o.velocity, "velocity")
    checked = BodySettings(
        finite_float(o.angle, "angle"),
        _density(o.density),
        non_negative_float(o.friction, "friction"),
        float_in(o.restitution, "restitution", 0.0, 1.0),
        check_bool(o.static, "static"),
        check_bool(o.kinematic, "kinematic"),
        (float(v[0]), float(v[1])),
        finite_float(o.angular_velocity, "angular_velocity"),
        finite_float(o.gravity_scale, "gravity_scale"),
        non_negative_float(o.linear_damping, "linear_damping"),
        non_negative_float(o.angular_damping, "angular_damping"),
        filter_bits(o.category, "category"),
        filter_bits(o.mask, "mask"),
        filter_group(o.group, "group"),
        check_bool(o.fixed_rotation, "fixed_rotation"),
    )
    if checked.static and checked.kinematic:
        raise ValueError("static and kinematic are both True: a body is static (never moves) or kinematic, not both")
    if checked.fixed_rotation and checked.angular_velocity != 0.0:
        raise ValueError(
            f"angular_velocity: a body with fixed_rotation=True never turns, got angular_velocity="
            f"{checked.angular_velocity}"
        )
    return checked


def _density(value: object) -> float:
    """``value`` as a density in [MIN_DENSITY, MAX_DENSITY] (kg/m^2)."""
    d = positive_float(value, "density")
    if not MIN_DENSITY <= d <= MAX_DENSITY:
        raise ValueError(f"density must be between {MIN_DENSITY:g} and {MAX_DENSITY:g} kg/m^2 (2D), got {d:g}")
    return d


def should_collide(category_a: int, mask_a: int, group_a: int, category_b: int, mask_b: int, group_b: int) -> bool:
    """Box2D's filter: a shared non-zero group decides (positive: always, negative: never);
    else each body's category must be in the other's mask. (``collision.broadphase`` runs
    the same test on the arrays.)"""
    if group_a == group_b and group_a != 0:
        return group_a > 0
    return (mask_a & category_b) != 0 and (category_a & mask_b) != 0


def stored_rows(kind: int, vcount: int) -> int:
    """Rows of ``local_v`` a body of this kind and vertex count takes: its vertices, and a chain
    segment's two ghost vertices after them."""
    return vcount + 2 if kind == CHAIN else vcount


def _grown(a: np.ndarray, capacity: int) -> np.ndarray:
    out = np.zeros((capacity,) + a.shape[1:], dtype=a.dtype)
    out[: a.shape[0]] = a
    return out


class BodyArrays:
    """Structure-of-arrays storage for bodies and their shapes, grown by doubling.

    The public arrays are views of the first ``n`` rows of the private storage
    (``x`` views ``_x``, ...), refreshed whenever a body is added or removed;
    ``local_v`` and ``local_n`` view the first ``n_verts`` polygon vertices.
    """

    # public views: one row per body (the layout in the module docstring)
    x: np.ndarray  # (N, 2) centre of mass, m
    theta: np.ndarray  # (N,) angle, rad
    V: np.ndarray  # (N, 3) [vx, vy, omega], m/s and rad/s
    M_inv: np.ndarray  # (N, 3) diagonal of M^-1: 1/kg, 1/kg, 1/(kg m^2); 0 for static bodies
    mass: np.ndarray  # (N,) kg
    inertia: np.ndarray  # (N,) kg m^2
    kind: np.ndarray  # (N,) int32 shapes.CIRCLE, POLYGON, CAPSULE, SEGMENT or CHAIN
    radius: np.ndarray  # (N,) circle radius, or a capsule's or segment's rounding, m (0 for polygons)
    vstart: np.ndarray  # (N,) int32 first row of the body's vertices in local_v
    vcount: np.ndarray  # (N,) int32 number of vertices (0 for circles)
    friction: np.ndarray  # (N,) friction coefficient mu
    restitution: np.ndarray  # (N,) restitution e in [0, 1]
    static: np.ndarray  # (N,) bool: M^-1 = 0 (static or kinematic)
    kinematic: np.ndarray  # (N,) bool: moves at its velocity, no force or contact changes it
    uid: np.ndarray  # (N,) int64 unique in the world's lifetime
    gravity_scale: np.ndarray  # (N,) its gravity is gravity_scale g
    damping: np.ndarray  # (N, 2) linear and angular damping c (1/s): v /= 1 + c dt
    force: np.ndarray  # (N, 3) [f_x, f_y, tau] (N, N m) applied for the next step only
    category: np.ndarray  # (N,) uint64 the categories the body belongs to
    mask: np.ndarray  # (N,) uint64 the categories it collides with
    group: np.ndarray  # (N,) int32 collision group (0: none)
    sleep_time: np.ndarray  # (N,) s the body has rested (``phys2d.sleep``)
    island: np.ndarray  # (N,) int64 id of the sleeping island it is in; -1: awake
    fixed_rotation: np.ndarray  # (N,) bool: it never turns (M^-1's 1/I is 0, omega 0)
    local_v: np.ndarray  # (n_verts, 2) polygon vertices in the body frame, m (a chain segment's two
    # ghost vertices follow its two vertices: ``stored_rows``)
    local_n: np.ndarray  # (n_verts, 2) unit outward edge normals in the body frame
    # the storage behind them, grown by doubling
    _x: np.ndarray
    _theta: np.ndarray
    _V: np.ndarray
    _M_inv: np.ndarray
    _mass: np.ndarray
    _inertia: np.ndarray
    _kind: np.ndarray
    _radius: np.ndarray
    _vstart: np.ndarray
    _vcount: np.ndarray
    _friction: np.ndarray
    _restitution: np.ndarray
    _static: np.ndarray
    _kinematic: np.ndarray
    _uid: np.ndarray
    _gravity_scale: np.ndarray
    _damping: np.ndarray
    _force: np.ndarray
    _category: np.ndarray
    _mask: np.ndarray
    _group: np.ndarray
    _sleep_time: np.ndarray
    _island: np.ndarray
    _fixed_rotation: np.ndarray
    _local_v: np.ndarray
    _local_n: np.ndarray

    _PER_BODY: dict[str, tuple[tuple[int, ...], type]] = {
        "x": ((2,), np.float64),
        "theta": ((), np.float64),
        "V": ((3,), np.float64),
        "M_inv": ((3,), np.float64),
        "mass": ((), np.float64),
        "inertia": ((), np.float64),
        "kind": ((), np.int32),
        "radius": ((), np.float64),
        "vstart": ((), np.int32),
        "vcount": ((), np.int32),
        "friction": ((), np.float64),
        "restitution": ((), np.float64),
        "static": ((), np.bool_),
        "kinematic": ((), np.bool_),
        "uid": ((), np.int64),
        "gravity_scale": ((), np.float64),
        "damping": ((2,), np.float64),
        "force": ((3,), np.float64),
        "category": ((), np.uint64),
        "mask": ((), np.uint64),
        "group": ((), np.int32),
        "sleep_time": ((), np.float64),
        "island": ((), np.int64),
        "fixed_rotation": ((), np.bool_),
    }

    def __init__(self) -> None:
        self.n = 0
        self.n_verts = 0
        self.next_uid = 0
        self.forces_applied = False  # a force or torque waits in ``force`` for the next step
        for name, (shape, dtype) in self._PER_BODY.items():
            setattr(self, "_" + name, np.zeros((8,) + shape, dtype=dtype))
        self._local_v = np.zeros((32, 2))
        self._local_n = np.zeros((32, 2))
        self._refresh_views()

    def _refresh_views(self) -> None:
        """Public names are views of the first n rows (n_verts for vertices): x, theta, V, ..."""
        for name in self._PER_BODY:
            setattr(self, name, getattr(self, "_" + name)[: self.n])
        self.local_v = self._local_v[: self.n_verts]
        self.local_n = self._local_n[: self.n_verts]

    def append(self, spec: ShapeSpec, x: ArrayLike, mass: float, inertia: float, o: BodySettings) -> int:
        """Add a body's row (values already checked): x (m), mass (kg), inertia (kg m^2) and the
        rest as ``o`` says; returns its row index."""
        if self.next_uid > MAX_BODY_UID:
            raise ValueError(f"a world can create at most {MAX_BODY_UID + 1} bodies in its lifetime")
        i = self.n
        if i == self._x.shape[0]:
            for name in self._PER_BODY:
                setattr(self, "_" + name, _grown(getattr(self, "_" + name), 2 * i))
        nv = spec.vertices.shape[0]
        rows = nv + spec.ghosts.shape[0]
        if self.n_verts + rows > self._local_v.shape[0]:
            cap = max(2 * self._local_v.shape[0], self.n_verts + rows)
            self._local_v = _grown(self._local_v, cap)
            self._local_n = _grown(self._local_n, cap)
        self._local_v[self.n_verts : self.n_verts + nv] = spec.vertices
        self._local_n[self.n_verts : self.n_verts + nv] = spec.normals
        if rows > nv:  # a chain segment's ghosts, after its vertices (their normals unused)
            self._local_v[self.n_verts + nv : self.n_verts + rows] = spec.ghosts
            self._local_n[self.n_verts + nv : self.n_verts + rows] = 0.0
        infinite_mass = o.static or o.kinematic
        self._x[i] = x
        self._theta[i] = o.angle
        self._V[i] = (*o.velocity, o.angular_velocity)
        turns = not (infinite_mass or o.fixed_rotation)
        self._M_inv[i] = (0.0 if infinite_mass else 1.0 / mass,) * 2 + (1.0 / inertia if turns else 0.0,)
        self._mass[i] = mass
        self._inertia[i] = inertia
        self._kind[i] = spec.kind
        self._radius[i] = spec.radius
        self._vstart[i] = self.n_verts
        self._vcount[i] = nv
        self._friction[i] = o.friction
        self._restitution[i] = o.restitution
        self._static[i] = infinite_mass
        self._kinematic[i] = o.kinematic
        self._uid[i] = self.next_uid
        self._gravity_scale[i] = o.gravity_scale
        self._damping[i] = (o.linear_damping, o.angular_damping)
        self._force[i] = 0.0
        self._category[i] = o.category
        self._mask[i] = o.mask
        self._group[i] = o.group
        self._sleep_time[i] = 0.0
        self._island[i] = -1  # awake
        self._fixed_rotation[i] = o.fixed_rotation
        self.next_uid += 1
        self.n_verts += rows
        self.n += 1
        self._refresh_views()
        return i

    @property
    def capacity(self) -> tuple[int, int]:
        """(bodies, vertices) the storage holds before it grows: what a snapshot keeps, so that a
        restored world grows when the original did."""
        return self._x.shape[0], self._local_v.shape[0]

    @classmethod
    def restored(cls, columns: dict[str, np.ndarray], counts: tuple[int, int, int], forces_applied: bool) -> BodyArrays:
        """Body arrays over ``columns`` (each of ``_PER_BODY`` and local_v, local_n, at capacity),
        ``counts`` = (n, n_verts, next_uid) of them live."""
        b = cls.__new__(cls)
        for name, column in columns.items():
            setattr(b, "_" + name, column)
        b.n, b.n_verts, b.next_uid = counts
        b.forces_applied = forces_applied
        b._refresh_views()
        return b

    def delete(self, i: int) -> None:
        """Remove row i, shifting later rows (and their vertex slices) down by one."""
        s, c = int(self._vstart[i]), stored_rows(int(self._kind[i]), int(self._vcount[i]))
        for name in ("_local_v", "_local_n"):
            a = getattr(self, name)
            a[s : self.n_verts - c] = a[s + c : self.n_verts].copy()
        self.n_verts -= c
        for name in self._PER_BODY:
            a = getattr(self, "_" + name)
            a[i : self.n - 1] = a[i + 1 : self.n].copy()
        self.n -= 1
        self._vstart[i : self.n] -= c
        self._refresh_views()

    def snapshot(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Copies of x, theta and V: what a step changes, for :meth:`restore`."""
        return self.x.copy(), self.theta.copy(), self.V.copy()

    def restore(self, snap: tuple[np.ndarray, np.ndarray, np.ndarray]) -> None:
        """Put back x, theta and V from a :meth:`snapshot` (same bodies)."""
        self.x[:], self.theta[:], self.V[:] = snap


class PerBody:
    """A body's setting (float) held in one of the world's per-body arrays (column ``column`` of
    a 2-D one), checked by ``check(value, name)`` when set."""

    def __init__(self, array: str, check: Callable[[object, str], float], doc: str, column: int | None = None) -> None:
        self.array, self.check, self.column, self.__doc__ = array, check, column, doc

    def __set_name__(self, owner: type, name: str) -> None:
        self.name = name

    def _at(self, body: Body) -> tuple:
        return (body._index,) if self.column is None else (body._index, self.column)

    def __get__(self, body: Body | None, owner: type | None = None) -> float:
        if body is None:
            return self  # type: ignore[return-value]  # the class's attribute: the descriptor itself
        return float(getattr(body._arrays(), self.array)[self._at(body)])

    def __set__(self, body: Body, value: float) -> None:
        getattr(body._arrays(), self.array)[self._at(body)] = self.check(value, self.name)


class Body:
    """A handle onto one body's row of the world's arrays.

    Read and set ``position`` (m, the centre of mass), ``angle`` (rad),
    ``velocity`` (m/s) and ``angular_velocity`` (rad/s), ``friction``,
    ``restitution``, ``gravity_scale``, ``linear_damping`` and ``angular_damping``
    (1/s), and the collision filter ``category``, ``mask`` and ``group``; ``mass``
    (kg), ``inertia`` (kg m^2), ``static`` and ``kinematic`` are read-only.
    ``apply_force`` and ``apply_torque`` act for the next step only,
    ``apply_impulse`` at once (each wakes the body's island, as a non-zero velocity does);
    ``awake`` tells whether it sleeps (``World(sleep=True)``). ``index`` is the body's row in the world's arrays and
    in ``w.bodies``; it shifts down when an earlier body is removed.
    """

    __slots__ = ("_world", "_index", "_uid", "__weakref__")

    def __init__(self, world: Any, index: int, uid: int) -> None:  # (its World: this module is below world.py)
        self._world = world
        self._index = index
        self._uid = uid

    # -- plumbing ---------------------------------------------------------
    def _arrays(self) -> BodyArrays:
        if self._index < 0:
            raise ValueError(f"body #{self._uid} was removed from its world")
        return self._world._bodies

    @property
    def index(self) -> int:
        self._arrays()
        return self._index

    @property
    def world(self) -> Any:
        """The world the body belongs (or belonged) to."""
        return self._world

    @property
    def alive(self) -> bool:
        """False once the body has been removed from its world."""
        return self._index >= 0

    # -- state ------------------------------------------------------------
    @property
    def position(self) -> np.ndarray:
        """Centre of mass (m), a copy; assign to move the body."""
        return self._arrays().x[self._index].copy()

    @position.setter
    def position(self, value: ArrayLike) -> None:
        v = vec2(value, "position")
        a = self._arrays()
        self._world._wake(self._index)  # its island, and the islands it leaves
        a.x[self._index] = v
        self._world._wake(self._index)  # and those it comes to

    @property
    def angle(self) -> float:
        """Angle theta (rad), counter-clockwise."""
        return float(self._arrays().theta[self._index])

    @angle.setter
    def angle(self, value: float) -> None:
        v = finite_float(value, "angle")
        a = self._arrays()
        self._world._wake(self._index)
        a.theta[self._index] = v
        self._world._wake(self._index)

    @property
    def velocity(self) -> np.ndarray:
        """Linear velocity v (m/s), a copy."""
        return self._arrays().V[self._index, :2].copy()

    @velocity.setter
    def velocity(self, value: ArrayLike) -> None:
        v = vec2(value, "velocity")
        self._arrays().V[self._index, :2] = v
        if v[0] != 0.0 or v[1] != 0.0:  # (as Box2D: setting a velocity of 0 does not wake it)
            self._world._wake_island_of(self._index)

    @property
    def angular_velocity(self) -> float:
        """Angular velocity omega (rad/s)."""
        return float(self._arrays().V[self._index, 2])

    @angular_velocity.setter
    def angular_velocity(self, value: float) -> None:
        v = finite_float(value, "angular_velocity")
        a = self._arrays()
        if v != 0.0 and a.fixed_rotation[self._index]:
            raise ValueError(f"angular_velocity: body {self._index} has fixed_rotation=True and never turns, got {v}")
        a.V[self._index, 2] = v
        if v != 0.0:
            self._world._wake_island_of(self._index)

    @property
    def mass(self) -> float:
        """Mass m (kg), from density and area (also for static bodies)."""
        return float(self._arrays().mass[self._index])

    @property
    def inertia(self) -> float:
        """Moment of inertia I about the centre of mass (kg m^2)."""
        return float(self._arrays().inertia[self._index])

    @property
    def static(self) -> bool:
        """Static bodies have M^-1 = 0 and never move: no impulse or gravity moves them."""
        a = self._arrays()
        return bool(a.static[self._index] and not a.kinematic[self._index])

    @property
    def kinematic(self) -> bool:
        """Kinematic bodies have M^-1 = 0 and move at the velocity they are given: no force,
        impulse or contact changes it."""
        return bool(self._arrays().kinematic[self._index])

    @property
    def fixed_rotation(self) -> bool:
        """Whether the body never turns (Box2D's motion lock, pymunk's infinite moment): the 1/I
        of its M^-1 is 0, so no torque or contact turns it, and omega stays 0. Its ``inertia``
        stays what its shape gives (energies read it). Settable: True stops its turning now,
        False gives a dynamic body its 1/I back."""
        return bool(self._arrays().fixed_rotation[self._index])

    @fixed_rotation.setter
    def fixed_rotation(self, value: bool) -> None:
        v = check_bool(value, "fixed_rotation")
        a, i = self._arrays(), self._index
        a.fixed_rotation[i] = v
        if v:
            a.V[i, 2] = 0.0
            a.M_inv[i, 2] = 0.0
        elif not a.static[i]:
            a.M_inv[i, 2] = 1.0 / a.inertia[i]
            self._world._wake_island_of(i)

    gravity_scale = PerBody(
        "gravity_scale",
        finite_float,
        "The body's gravity is gravity_scale g (1: the world's; 0: none; negative: it rises).",
    )
    linear_damping = PerBody(
        "damping", non_negative_float, "c >= 0 (1/s): every step v /= 1 + c dt (Box2D's damping), after the forces.", 0
    )
    angular_damping = PerBody(
        "damping", non_negative_float, "c >= 0 (1/s): every step omega /= 1 + c dt, after the forces.", 1
    )

    @property
    def awake(self) -> bool:
        """Whether the body is stepped: False while its island sleeps (``World(sleep=True)``,
        ``phys2d.sleep``) and for static bodies, which never move; kinematic bodies are always
        awake. Set True to wake its island, False to put its island (the dynamic bodies it
        touches or is joined to, and theirs) to sleep now: velocities 0, as Box2D's
        b2Body_SetAwake. Setting it on a static or kinematic body changes nothing."""
        a = self._arrays()
        i = self._index
        if a.static[i]:
            return bool(a.kinematic[i])
        return bool(a.island[i] < 0)

    @awake.setter
    def awake(self, value: bool) -> None:
        v = check_bool(value, "awake")
        a = self._arrays()
        if a.static[self._index]:
            return
        if v:
            self._world._wake_island_of(self._index)
        else:
            self._world._put_to_sleep(self._index)

    # -- collision filter (Box2D's) -------------------------------------------
    @property
    def category(self) -> int:
        """The categories the body belongs to, a 64-bit mask (default 1)."""
        return int(self._arrays().category[self._index])

    @category.setter
    def category(self, value: int) -> None:
        self._set_filter("category", filter_bits(value, "category"))

    @property
    def mask(self) -> int:
        """The categories the body collides with, a 64-bit mask (default: all)."""
        return int(self._arrays().mask[self._index])

    @mask.setter
    def mask(self, value: int) -> None:
        self._set_filter("mask", filter_bits(value, "mask"))

    @property
    def group(self) -> int:
        """Collision group: two bodies of the same negative group never collide, of the same
        positive group always do (whatever their masks); 0 is no group."""
        return int(self._arrays().group[self._index])

    @group.setter
    def group(self, value: int) -> None:
        self._set_filter("group", filter_group(value))

    def _set_filter(self, field: str, value: int) -> None:
        getattr(self._arrays(), field)[self._index] = value
        self._world._pipeline.bodies_changed()  # the broadphase's pairs are found anew
        self._world._wake(self._index)

    friction = PerBody(
        "friction", non_negative_float, "Friction coefficient mu of the body's shape (pairs mix sqrt(mu_a mu_b))."
    )
    restitution = PerBody(
        "restitution",
        lambda v, name: float_in(v, name, 0.0, 1.0),
        "Restitution e in [0, 1] (pairs take max(e_a, e_b)).",
    )

    # -- shape ------------------------------------------------------------
    @property
    def shape(self) -> str:
        """'circle', 'polygon' (boxes are polygons), 'capsule', 'segment' or 'chain' (one segment
        of a chain)."""
        return KIND_NAMES[int(self._arrays().kind[self._index])]

    @property
    def radius(self) -> float:
        """Circle radius, or the rounding of a capsule or segment (m); 0 for polygons and chains."""
        return float(self._arrays().radius[self._index])

    @property
    def local_vertices(self) -> np.ndarray:
        """Polygon vertices in the body frame (m), counter-clockwise; (0, 2) for circles; a capsule's,
        segment's or chain segment's two core ends."""
        a = self._arrays()
        s, c = a.vstart[self._index], a.vcount[self._index]
        return a.local_v[s : s + c].copy()

    @property
    def vertices(self) -> np.ndarray:
        """Polygon vertices in world coordinates (m); (0, 2) for circles."""
        a = self._arrays()
        c, s = math.cos(a.theta[self._index]), math.sin(a.theta[self._index])
        rot = np.array([[c, -s], [s, c]])
        return self.local_vertices @ rot.T + a.x[self._index]

    # -- actions ----------------------------------------------------------
    def apply_force(self, force: ArrayLike, point: ArrayLike | None = None) -> None:
        """Apply a force (N) at a world point (m), the centre of mass by default, for the next
        step only: V += dt M^-1 F_ext then, with the torque (r x F) of r = point - x.
        Forces add up until that step; static and kinematic bodies are not moved."""
        a = self._arrays()
        f = vec2(force, "force")
        r = np.zeros(2) if point is None else vec2(point, "point") - a.x[self._index]
        self._add_force(f[0], f[1], r[0] * f[1] - r[1] * f[0])

    def apply_torque(self, torque: float) -> None:
        """Apply a torque tau (N m) for the next step only: omega += dt tau / I then (none on a
        body with ``fixed_rotation``)."""
        self._add_force(0.0, 0.0, finite_float(torque, "torque"))

    def clear_forces(self) -> None:
        """Drop the force and torque applied to the body for the next step (``apply_force``,
        ``apply_torque``): the way on when a step was refused for them."""
        self._arrays().force[self._index] = 0.0

    def _add_force(self, fx: float, fy: float, tau: float) -> None:
        a = self._arrays()
        with np.errstate(over="ignore", invalid="ignore"):  # an overflow is refused just below, by name
            total = a.force[self._index] + (fx, fy, tau)
        if not np.all(np.isfinite(total)):
            raise ValueError("force: the total force on the body would not be finite")
        a.force[self._index] = total
        a.forces_applied = True
        self._world._wake_island_of(self._index)

    def apply_impulse(self, impulse: ArrayLike, point: ArrayLike | None = None) -> None:
        """Apply an impulse (N s) at a world point (m), the centre of mass by default.

        v += impulse / m and omega += (r x impulse) / I, with r = point - x.
        Static bodies are not moved.
        """
        a = self._arrays()
        j = vec2(impulse, "impulse")
        r = np.zeros(2) if point is None else vec2(point, "point") - a.x[self._index]
        m_inv = a.M_inv[self._index]
        with np.errstate(over="ignore", invalid="ignore"):  # overflow is caught just below, by name
            dv = np.array([j[0] * m_inv[0], j[1] * m_inv[1], (r[0] * j[1] - r[1] * j[0]) * m_inv[2]])
            finite = np.all(np.isfinite(a.V[self._index] + dv))
        if not finite:
            raise ValueError("impulse: the resulting velocity would not be finite")
        a.V[self._index] += dv
        self._world._wake_island_of(self._index)

    def __repr__(self) -> str:
        if self._index < 0:
            return f"<Body #{self._uid} removed>"
        a = self._world._bodies
        i = self._index
        kind = "kinematic " if a.kinematic[i] else "static " if a.static[i] else "asleep " if a.island[i] >= 0 else ""
        if a.kind[i] == CIRCLE:
            shape = f"circle r={a.radius[i]:.3g}"
        elif a.vcount[i] == 2:  # capsule, segment or chain segment: its core's length and rounding
            v = a.local_v[a.vstart[i] : a.vstart[i] + 2]
            shape = f"{KIND_NAMES[a.kind[i]]} length={float(np.hypot(*(v[1] - v[0]))):.3g} r={a.radius[i]:.3g}"
        else:
            shape = f"polygon {a.vcount[i]} vertices"
        x, y = a.x[i]
        return (
            f"<Body {i}: {kind}{shape}, position=({x:.4g}, {y:.4g}) m, "
            f"angle={a.theta[i]:.4g} rad, mass={a.mass[i]:.4g} kg>"
        )

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Body) and other._world is self._world and other._uid == self._uid

    def __hash__(self) -> int:
        return hash((id(self._world), self._uid))
