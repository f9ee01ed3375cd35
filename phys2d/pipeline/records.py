"""The records a tick's stages read and write: a few groups of flat arrays, each one idea.

    BodyRecord      x, theta, V, M_inv: the lecture's state; V1, the velocities a tick began with
    ShapeRecord     each body's shape and material, its geometry now, and the broadphase's pairs
    ManifoldRecord  the manifold store: each cached manifold's points as it was found
    ContactRecord   one step's contact points, their cache of impulses, the manifolds found
    RowRecord       the constraint rows J, JM = M^-1 J^T, A_kk, xi, bounds and lambda
    JointRecord     the joints, packed

A kernel takes the records it needs (two or three, Box2D v3's ``b2StepContext`` in spirit),
not the arrays one by one: numba then types and passes one argument per group, which keeps
the compile short. A record is a numba structref whose fields are the world's own arrays
(no copy); Python code keeps the arrays and makes a record over them with ``new_*``.
Under NUMBA_DISABLE_JIT a record is a plain object with the same fields, so a debugger
steps through every kernel as plain Python.
"""

from __future__ import annotations

from typing import Any

from numba import config, types
from numba.experimental import structref

from ..jit import njit


def _record(name: str, fields: tuple[str, ...], doc: str) -> Any:
    """A record class named ``name`` with these fields: a structref proxy, or a plain class
    when numba is off."""
    if config.DISABLE_JIT:  # type: ignore[attr-defined]

        def __init__(self: Any, *values: Any) -> None:
            for field, value in zip(fields, values, strict=True):
                setattr(self, field, value)

        return type(name, (), {"__init__": __init__, "__doc__": doc, "fields": fields, "__module__": __name__})

    def preprocess_fields(self: Any, found: Any) -> tuple:
        return tuple((field, types.unliteral(typ)) for field, typ in found)

    record_type = type(name + "Type", (types.StructRef,), {"preprocess_fields": preprocess_fields})
    record_type.__module__ = __name__
    globals()[name + "Type"] = record_type  # (numba's cache pickles the type by module and name)
    structref.register(record_type)
    proxy = type(name, (structref.StructRefProxy,), {"__doc__": doc, "fields": fields, "__module__": __name__})
    structref.define_proxy(proxy, record_type, fields)
    return proxy


BODY_FIELDS = ("x", "theta", "V", "M_inv", "V1")
BodyRecord = _record(
    "BodyRecord",
    BODY_FIELDS,
    """The lecture's state of the bodies: x (N, 2) m, theta (N,) rad, V (N, 3) [vx, vy, omega]
    (after the external forces, during a step), M_inv (N, 3) the diagonal of M^-1, and V1
    (N, 3) the velocities the tick began with.""",
)

SHAPE_FIELDS = (
    "static", "uid", "friction", "restitution", "kind", "radius", "vstart", "vcount", "local_v", "local_n",
    "rotation", "world_v", "world_n", "aabb", "fat", "travel", "pairs", "pair_order", "excluded", "category", "mask",
    "group", "part",
)  # fmt: skip
ShapeRecord = _record(
    "ShapeRecord",
    SHAPE_FIELDS,
    """What collides, and how: each body's static flag, uid, friction mu and restitution e
    (mixed per contact); its shape: kind, radius (m), vertices vstart:vstart + vcount of local_v and local_n in the
    body's frame; now: rotation (cos, sin), world_v, world_n, the tight aabb and the fat one
    (m), travel (m a body may move within the step); the broadphase's pairs (and their
    colour order, pair_order), the pair keys joints exclude, each body's collision filter
    (category, mask, group: ``bodies.should_collide``) and its part of the solve order
    (``constraints.order.partition``, written with pair_order).""",
)

MANIFOLD_FIELDS = ("found_pose", "found_rotation", "span", "anchor", "normal", "separation", "feature")
ManifoldRecord = _record(
    "ManifoldRecord",
    MANIFOLD_FIELDS,
    """The manifold store: per row, b's centre in a's frame and both rotations as the
    manifold was found, and its points span[r, 0]:span[r, 1] of anchor (r_a, r_b, m),
    normal, separation (m) and feature id.""",
)

CONTACT_FIELDS = (
    "body_a", "body_b", "point", "normal", "separation", "feature", "key", "friction", "restitution", "anchor",
    "lambda_n", "lambda_t", "hit", "order", "pair_start", "cache_lambda_n", "cache_lambda_t", "cache_pushed",
    "manifold_key", "manifold_row",
)  # fmt: skip
ContactRecord = _record(
    "ContactRecord",
    CONTACT_FIELDS,
    """One step's contact points (capacity-sized; the step's count is K): bodies a and b,
    point p and normal n (m), separation C (m), feature id, key, mixed mu and e, lever arms
    (r_a, r_b) as found, the impulses lambda_n and lambda_t (N s), whether the cache warm
    started it (hit), the solve order, each pair's first point (pair_start); the cache the
    next step warm starts from (cache_lambda_n, cache_lambda_t, cache_pushed under key); and
    the step's manifolds' keys and store rows.""",
)

ROW_FIELDS = (
    "normal_row", "friction_row", "body_a", "body_b", "J", "JM", "A_kk", "xi", "push", "bounce", "impact",
    "lo", "hi", "bound_row", "mu", "lam",
)  # fmt: skip
RowRecord = _record(
    "RowRecord",
    ROW_FIELDS,
    """The constraint rows of a step (``phys2d.constraints.rows``): the row map (contact q's
    normal_row and friction_row), and per row its bodies, J, JM = M^-1 J^T, A_kk, xi, push,
    bounce, impact, the bounds lo, hi (or bound_row's cone of slope mu) and lambda (lam).""",
)

JOINT_FIELDS = ("kind", "body_a", "body_b", "local_a", "local_b", "params", "row_offset", "lam")
JointRecord = _record(
    "JointRecord",
    JOINT_FIELDS,
    """The joints, packed (``phys2d.constraints.joints.JointArrays``): kind, bodies, anchors
    in each body's frame (m), parameters, each joint's first row among the joint rows, and
    last step's reactions lambda (N s), which warm start this step's.""",
)


@njit(cache=True)
def new_bodies(arrays):
    """A BodyRecord over ``arrays`` (a tuple in the order of BODY_FIELDS)."""
    return BodyRecord(*arrays)


@njit(cache=True)
def new_shapes(arrays):
    """A ShapeRecord over ``arrays`` (SHAPE_FIELDS' order)."""
    return ShapeRecord(*arrays)


@njit(cache=True)
def new_contacts(arrays):
    """A ContactRecord over ``arrays`` (CONTACT_FIELDS' order)."""
    return ContactRecord(*arrays)


@njit(cache=True)
def new_rows(arrays):
    """A RowRecord over ``arrays`` (ROW_FIELDS' order)."""
    return RowRecord(*arrays)


@njit(cache=True)
def new_joints(arrays):
    """A JointRecord over ``arrays`` (JOINT_FIELDS' order)."""
    return JointRecord(*arrays)


def arrays_of(holder: object, fields: tuple[str, ...]) -> tuple:
    """The attributes ``fields`` of ``holder``, in order: what a ``new_*`` takes."""
    return tuple(getattr(holder, name) for name in fields)


def record_of_rows(rows: object) -> Any:
    """A RowRecord over a ``constraints.rows.Rows`` (its row map and row arrays)."""
    return new_rows(arrays_of(rows, ROW_FIELDS))


def record_of_joints(joints: object, lam: object) -> Any:
    """A JointRecord over a ``constraints.joints.JointArrays`` and the joints' reactions ``lam``."""
    return new_joints((*arrays_of(joints, JOINT_FIELDS[:-1]), lam))


CONTEXT_FIELDS = (
    "bodies", "shapes", "store", "sides", "rows", "undo_x", "undo_theta", "residuals", "forces", "joints", "threads",
    "rounded",
)  # fmt: skip
TickContext = _record(
    "TickContext",
    CONTEXT_FIELDS,
    """One step's context, handed to every stage (Box2D v3's ``b2StepContext``): the bodies, shapes
    and manifold store, both sides of the contact buffers (a tuple of two ContactRecords), the
    row buffers (a RowRecord at capacity), the positions to undo a failed step with, the residual
    of each sweep (residuals[side, s]: per side of the contact buffers), the forces on the bodies
    besides contacts (gravity_scale (N,), damping (N, 2) 1/s, force (N, 3) N and N m applied for
    this step), the joints (a JointRecord, or None in a
    world without joints), the threads (a count, or None on one thread) and rounded (True in a
    world with capsules, segments or chains, else None). The None forms let numba compile the
    code of what is absent away (``pipeline.context``).""",
)


def new_context(bodies, shapes, store, sides, rest):
    """A TickContext over the arrays of each record (tuples in the order of their ``*_FIELDS``;
    sides: one per side; rest: the rows' arrays, undo_x, undo_theta, residuals, forces, then
    joints, threads and rounded as they are), and the records it holds: (context, bodies,
    shapes, store, (side 0, side 1), rows). The records are made in one compiled call
    (``new_records``, the same types whatever the world holds); the context, whose type
    changes with joints, threads and rounded, here (a small constructor per type)."""
    row_arrays, undo_x, undo_theta, residuals, forces, joints, threads, rounded = rest
    records = new_records(bodies, shapes, store, sides, row_arrays)
    return (TickContext(*records, undo_x, undo_theta, residuals, forces, joints, threads, rounded), *records)


@njit(cache=True)
def new_records(bodies, shapes, store, sides, row_arrays):
    """(bodies, shapes, store, (side 0, side 1), rows): the records ``new_context`` holds."""
    return (
        BodyRecord(*bodies),
        ShapeRecord(*shapes),
        ManifoldRecord(*store),
        (ContactRecord(*sides[0]), ContactRecord(*sides[1])),
        RowRecord(*row_arrays),
    )
