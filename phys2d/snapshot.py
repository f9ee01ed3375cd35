"""Snapshots of a World: its live state as bytes, put back bit for bit, and a 64-bit hash of it.

    data = w.snapshot()              # between steps; a few hundred kB for pyramid_20
    w.step(1 / 60)                   # ... the world goes on
    w.restore(data)                  # back: the next steps give the same bits as the first time
    twin = phys2d.World.from_snapshot(data)
    w.state_hash() == twin.state_hash()

A snapshot holds the live state only: the first N rows of the body arrays, the contact
cache, the cached manifolds (compacted: the store's dead rows are left out), the
broadphase's pairs, their solve order and the fat boxes, the joints with their last
reactions, the sleeping islands and the cache each keeps, the last step's contacts and
report, the responder (its class and settings), the world's settings, the tick and the
time. Not the buffers' spare room: only their sizes, so that a restored world grows its
buffers at the ticks the original did (a grown buffer makes its pair order anew, from the
positions then). ``docs/snapshots.md`` describes the format byte by byte.

The format: a 32-byte header (``HEADER``: magic ``MAGIC``, format version, the lengths of
the two parts that follow, the CRC-32 of both), a JSON part (the phys2d version, the
settings, the responder, the joints, the counts, and the name, dtype and shape of every
array), and the arrays' raw bytes, little-endian, each starting on an 8-byte boundary. No
object is pickled: the responder is named by ``module:Class`` and rebuilt from its
settings (numbers, strings, booleans, None, and lists, tuples, dicts and numpy arrays of
them). An image that is damaged (its CRC-32 differs), truncated, foreign (another magic)
or of another format or phys2d version is refused with ``SnapshotError``, a one-line
ValueError, and the world is left exactly as it was: an image is checked and everything
is built from it before the first attribute of the world changes.

Handles: ``restore`` into the world a snapshot was taken of (or of a world restored or
built from its snapshots: a lineage, told by a token in the image) gives back the
``Body`` and ``Joint`` handles that existed then, removed ones included (they work again);
those made since say ``alive`` False. Into a world of another lineage, every handle the
world had is dead and new ones are made. As after an add, arrays held from ``w.x`` and the
like go stale: read them again.

``state_hash`` is the first 8 bytes of SHA-256 (little-endian) over canonical bytes of
everything that decides the world's future: the tick and time, the settings but the
thread count and the step path, the responder, the live body rows, the cache, the cached
manifolds in cache order, the pairs and their order (while they hold), the joints and their
reactions, the islands, and the bodies and separations of the last step's contacts (what
putting an island to sleep by hand reads). Equal states hash equal whatever ``threads``,
``one_call_tick`` or the buffers' sizes; the tick is in it, so every step changes it.

This module is the only one that reads the private state of a World and its Pipeline for
snapshots: ``_gather`` reads it, ``_prepare`` and ``_commit`` put it back.
"""

from __future__ import annotations

import hashlib
import importlib
import json
import math
import secrets
import struct
import weakref
import zlib
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from .bodies import Body, BodyArrays
from .constraints import joints as joint_module
from .constraints.order import PAIR_ORDER
from .contacts import Contacts
from .responders.base import Responder, StepReport

if TYPE_CHECKING:
    from .collision.recycle import ManifoldStore
    from .pipeline.step import ContactBuffers, Pipeline
    from .sleep import Islands
    from .world import World, WorldParts

MAGIC = b"PHYS2D\x00S"  # 8 bytes: what every snapshot starts with
FORMAT = 1  # the format version: a reader refuses any other
HEADER = struct.Struct("<8sIIQI4x")  # magic, format, JSON bytes, array bytes, CRC-32 of both; 32 bytes
ALIGN = 8  # every array starts on a multiple of this many bytes after the JSON part

# a Joint's attributes that are not its settings: the world and the handles (put back by uid), its life
_JOINT_LINKS = ("_world", "body_a", "body_b", "alive")
# the joint classes a snapshot may name (the world makes joints; no other class is built from an image)
_JOINT_CLASSES = {
    cls.__name__: cls
    for cls in (
        joint_module.DistanceJoint,
        joint_module.PinJoint,
        joint_module.AngleJoint,
        joint_module.SliderJoint,
        joint_module.WeldJoint,
        joint_module.MouseJoint,
    )
}
# Contacts' fields, and the ContactBuffers field each is copied out of
_CONTACT_FIELDS = (
    "body_a", "body_b", "point", "anchor", "normal", "separation", "lambda_n", "lambda_t", "feature", "key",
    "warm_started", "friction", "restitution",
)  # fmt: skip
# a responder's count of its changes and its note of a respond of its own: not settings
_RESPONDER_SKIP = ("version", "respond_replaced")


class SnapshotError(ValueError):
    """An image that is not a snapshot this phys2d can restore (damaged, truncated, foreign, of
    another version), or a world whose state a snapshot cannot hold; one line, the world unchanged."""


# -- the handles of a lineage -------------------------------------------------------------------
@dataclass(eq=False)
class _Lineage:
    """A world's handles as snapshots know them: a token that tells images of its lineage, and
    weak references to every Body and Joint handle a snapshot has seen (removed ones included),
    so that ``restore`` can bring them back."""

    token: int = field(default_factory=lambda: secrets.randbits(63))
    bodies: dict[int, weakref.ref] = field(default_factory=dict)  # uid -> Body
    seen_uid: int = -1  # the largest uid in ``bodies``: handles come in uid order, so only later ones are new
    joints: weakref.WeakValueDictionary = field(default_factory=weakref.WeakValueDictionary)  # id -> Joint
    joint_ids: weakref.WeakKeyDictionary = field(default_factory=weakref.WeakKeyDictionary)  # Joint -> id


_LINEAGES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()  # World -> _Lineage


def _lineage(world: World) -> _Lineage:
    found = _LINEAGES.get(world)
    if found is None:
        found = _LINEAGES[world] = _Lineage()
    return found


def _note_handles(world: World, lineage: _Lineage) -> list[int]:
    """Remember the world's handles (only those made since the last look: uids ascend along
    ``w.bodies``); returns each joint's id, in joint order."""
    parts = world._parts()
    for h in reversed(parts.handles):
        if h._uid <= lineage.seen_uid:
            break
        lineage.bodies[h._uid] = weakref.ref(h)
    if parts.handles:
        lineage.seen_uid = max(lineage.seen_uid, parts.handles[-1]._uid)
    ids = []
    for joint in parts.joints.handles:
        jid = lineage.joint_ids.get(joint)
        if jid is None:
            jid = secrets.randbits(62)
            lineage.joint_ids[joint] = jid
            lineage.joints[jid] = joint
        ids.append(jid)
    return ids


# -- plain values: settings to JSON and back --------------------------------------------------------
_SCALARS = (type(None), bool, int, float, str)


class _Unstorable(Exception):
    """A value ``_plain`` cannot write: its type's name."""


def _plain(value: Any) -> Any:
    """``value`` as JSON can hold it, exactly (floats by repr; tuples and arrays tagged)."""
    t = type(value)
    if t in _SCALARS:
        return value
    if isinstance(value, np.ndarray):
        if value.dtype.kind not in "biuf":
            raise _Unstorable(f"an array of {value.dtype}")
        return {"__array__": [value.dtype.str, list(value.shape), value.ravel().tolist()]}
    if isinstance(value, (np.bool_, np.integer, np.floating)):
        return value.item()
    for kind in (int, float, str):  # a subclass (an IntEnum, say): as its base
        if isinstance(value, kind):
            return kind(value)
    if t is tuple:
        return {"__tuple__": [_plain(v) for v in value]}
    if t is list:
        return [_plain(v) for v in value]
    if t is dict and all(type(k) is str for k in value):
        return {k: _plain(v) for k, v in value.items()}
    raise _Unstorable(f"a {t.__name__}")


def _plain_attributes(
    attributes: dict[str, Any], what: str, skip: tuple[str, ...] = (), lenient: bool = False
) -> dict[str, Any]:
    """An object's attributes (but ``skip``) as plain values: SnapshotError naming one that is not
    (``lenient``: that one as its type's name, for the hash)."""
    out = {}
    for key, value in attributes.items():
        if key in skip:
            continue
        try:
            out[key] = _plain(value)
        except _Unstorable as e:
            if lenient:
                out[key] = {"__unstorable__": type(value).__qualname__}
                continue
            raise SnapshotError(
                f"{what}'s {key} is {e}: a snapshot keeps numbers, strings, booleans, None, and lists, tuples, "
                "dicts and numpy arrays of them"
            ) from None
    return out


def _unplain(value: Any) -> Any:
    """The value ``_plain`` made ``value`` of."""
    t = type(value)
    if t is list:
        return [_unplain(v) for v in value]
    if t is dict:
        if len(value) == 1:
            if "__array__" in value:
                dtype, shape, items = value["__array__"]
                return np.array(items, dtype=np.dtype(dtype)).reshape(shape)
            if "__tuple__" in value:
                return tuple(_unplain(v) for v in value["__tuple__"])
        return {k: _unplain(v) for k, v in value.items()}
    return value


def _canonical(value: Any) -> bytes:
    """Canonical JSON bytes of a plain value (keys sorted, no spaces): what the hash reads."""
    return json.dumps(value, sort_keys=True, separators=(",", ":")).encode()


# -- responders by class and settings -----------------------------------------------------------------
def responder_spec(responder: Responder, lenient: bool = False) -> dict[str, Any]:
    """What rebuilds ``responder``: its class as ``module:Class``, its name (and the registry's, when
    it is one of phys2d's registered responders) and its settings (its attributes, as plain
    values: ``SnapshotError`` for one a snapshot cannot hold; ``lenient``: its type's name instead)."""
    cls = type(responder)
    settings = _plain_attributes(vars(responder), f"responder {cls.__name__}", _RESPONDER_SKIP, lenient)
    name = str(responder.name)
    from .responders import REGISTRY

    own = cls.__module__.startswith("phys2d.")
    return {
        "class": f"{cls.__module__}:{cls.__qualname__}",
        "name": name,
        "registry": name if own and name in REGISTRY else None,
        "settings": settings,
    }


def responder_from_spec(spec: dict[str, Any]) -> Responder:
    """The responder ``responder_spec`` describes: its class imported (``module:Class``), made
    without calling its constructor, and given its settings; a ValueError (one line) when the
    class cannot be imported or is not a phys2d Responder."""
    path = spec.get("class") if isinstance(spec, dict) else None
    if not isinstance(path, str) or ":" not in path:
        raise SnapshotError(f"a responder must be named as 'module:Class', got {path!r}")
    module_name, qualname = path.split(":", 1)
    try:
        obj: Any = importlib.import_module(module_name)
        for part in qualname.split("."):
            obj = getattr(obj, part)
    except (ImportError, AttributeError) as e:
        where = "a script run as __main__" if module_name == "__main__" else f"module {module_name!r}"
        raise SnapshotError(
            f"responder {path} cannot be imported ({e}): it was defined in {where}; put its module on "
            "PYTHONPATH (or import it first) and try again"
        ) from None
    if not (isinstance(obj, type) and issubclass(obj, Responder)):
        raise SnapshotError(f"responder {path} is not a phys2d Responder class")
    responder = obj.__new__(obj)
    settings = spec.get("settings", {})
    if not isinstance(settings, dict):
        raise SnapshotError(f"responder {path}: its settings must be a dict, got {type(settings).__name__}")
    responder.__dict__.update({k: _unplain(v) for k, v in settings.items()})
    return responder


# -- gathering: the one place that reads a world's state ------------------------------------------------
def _points_of(span: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(point counts, the store's points of rows ``span`` (M, 2), row after row)."""
    counts = span[:, 1] - span[:, 0]
    total = int(counts.sum())
    ends = np.cumsum(counts)
    return counts, np.repeat(span[:, 0] - (ends - counts), counts) + np.arange(total)


def _gather(world: World, for_hash: bool = False) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """The world's live state: a plain dict (settings, counts, the responder, the joints) and the
    arrays, by name, as views where they can be (nothing is changed, nothing copied that need not be).
    ``for_hash`` leaves out what does not decide the future: sizes, the thread count, the step
    path, the last report, the joints' bookkeeping, and of the last step's contacts all but what
    putting an island to sleep by hand reads."""
    parts = world._parts()
    b, p, joint_set = parts.bodies, parts.pipeline, parts.joints
    arrays: dict[str, np.ndarray] = {}
    for name in BodyArrays._PER_BODY:
        arrays["bodies." + name] = getattr(b, name)
    arrays["bodies.local_v"], arrays["bodies.local_n"] = b.local_v, b.local_n
    _gather_cache(p, arrays)
    n_pairs, ordered = _gather_pairs(p, b, arrays)
    contacts = p.contact_fields(_CONTACT_FIELDS)  # (read where they lie: ``w.contacts`` would copy them out)
    if for_hash:  # what putting an island to sleep by hand reads of them (``sleep.touching``)
        contacts = {name: contacts[name] for name in ("body_a", "body_b", "separation")}
    for name, values in contacts.items():
        arrays["contacts." + name] = values
    impulses = joint_set.impulses()  # (read without packing the joints anew)
    lam, rows_first, packed, placed = joint_set.state()
    if for_hash:
        arrays["joints.impulse"] = np.concatenate(impulses) if impulses else np.zeros(0)
    else:
        arrays["joints.lam"] = lam
    _gather_islands(parts.islands, arrays)
    meta = _describe(world, parts, n_pairs, ordered, for_hash)
    if not for_hash:
        _gather_for_restore(parts, meta)
        meta["joint_state"] = {"rows_first": int(rows_first), "packed": bool(packed), "placed": bool(placed)}
        _gather_report(parts.last_step, meta, arrays)
    return meta, arrays


def _gather_cache(p: Pipeline, arrays: dict[str, np.ndarray]) -> None:
    """The contact cache and the cached manifolds with their points, in cache order: views when the
    store holds just these, else the live rows gathered (the store's dead rows left out)."""
    side, k, m = p.buffers.sides[p.side], p.cached, p.manifolds
    arrays["cache.key"], arrays["cache.lambda_n"] = side.key[:k], side.cache_lambda_n[:k]
    arrays["cache.lambda_t"], arrays["cache.pushed"] = side.cache_lambda_t[:k], side.cache_pushed[:k]
    rows = side.manifold_row[:m]
    store = p.store
    span = store.span[rows]
    counts, points = _points_of(span)
    arrays["manifolds.key"], arrays["manifolds.points"] = side.manifold_key[:m], counts
    total = points.shape[0]
    if m and rows[-1] == m - 1 and span[0, 0] == 0 and span[-1, 1] == total and np.all(np.diff(rows) == 1):
        took: Any = slice(0, m), slice(0, total)  # the store holds just these, in cache order: views
    else:
        took = rows, points  # the live rows and points gathered, in cache order
    arrays["manifolds.pose"], arrays["manifolds.rotation"] = store.found_pose[took[0]], store.found_rotation[took[0]]
    arrays["points.anchor"], arrays["points.normal"] = store.anchor[took[1]], store.normal[took[1]]
    arrays["points.separation"], arrays["points.feature"] = store.separation[took[1]], store.feature[took[1]]


def _gather_pairs(p: Pipeline, b: BodyArrays, arrays: dict[str, np.ndarray]) -> tuple[int, int]:
    """The broadphase's pairs, fat boxes and solve order, as far as they hold; returns (the pairs kept,
    the order they are in: ``PAIR_ORDER`` when none is kept)."""
    # the pairs (while they hold: once the bodies or joints changed, the next step sweeps anew), the fat
    # boxes they were swept from, and their solve order with the bodies' parts (once made: else the next
    # step makes them, from the positions then)
    n = b.n
    live_pairs = not p.sweep_again
    n_pairs = int(p.n_pairs) if live_pairs else 0
    g = p.geometry
    fat_holds = live_pairs and bool(g) and g[0].shape[0] == b.n_verts and g[2].shape[0] == n
    ordered = int(p.ordered) if live_pairs and p.part.shape[0] == n else PAIR_ORDER
    arrays["pairs"] = p.pairs[:n_pairs]
    arrays["fat"] = g[5] if fat_holds else np.zeros((n, 4))
    arrays["pair_order"] = p.buffers.pair_order[:n_pairs] if ordered != PAIR_ORDER else np.zeros(0, np.int32)
    arrays["part"] = p.part if ordered != PAIR_ORDER else np.zeros(n, np.int32)
    return n_pairs, ordered


def _gather_islands(islands: Islands, arrays: dict[str, np.ndarray]) -> None:
    """The cache each sleeping island keeps, concatenated in island order, with the ids and counts."""
    kept = sorted(islands.kept.items())
    arrays["islands.id"] = np.array([i for i, _ in kept], np.int64)
    arrays["islands.count"] = np.array([e[0].shape[0] for _, e in kept], np.int64)
    for q, name in enumerate(("key", "lambda_n", "lambda_t", "pushed")):
        dtype = (np.int64, np.float64, np.float64, np.bool_)[q]
        arrays["islands." + name] = np.concatenate([e[q] for _, e in kept]) if kept else np.zeros(0, dtype)


def _joint_specs(joint_set: joint_module.JointSet, for_hash: bool) -> list[dict[str, Any]]:
    """Each joint as plain values: its class, its bodies' uids and its settings (``for_hash``: without
    its bookkeeping); SnapshotError for a setting a snapshot cannot hold."""
    skip = ("_offset", "_rows_offset", "_has_rows", "_impulse") if for_hash else ()
    return [
        {
            "type": type(j).__name__,
            "a": int(j.body_a._uid),
            "b": int(j.body_b._uid),
            "attrs": _plain_attributes(vars(j), f"joint {q}", _JOINT_LINKS + skip),
        }
        for q, j in enumerate(joint_set.handles)
    ]


def _describe(world: World, parts: WorldParts, n_pairs: int, ordered: int, for_hash: bool) -> dict[str, Any]:
    """The plain part both a snapshot and the hash read: the tick and time, the settings, the responder,
    the counts, the joints and the islands' bookkeeping."""
    b, p, islands, settings = parts.bodies, parts.pipeline, parts.islands, parts.settings
    joints = _joint_specs(parts.joints, for_hash)
    return {
        "tick": int(world.tick),
        "time": float(world.time),
        "world": {
            "gravity": [float(v) for v in settings.gravity],
            "contact_margin": settings.contact_margin,
            "max_speed": settings.max_speed,
            "contact_recycle_distance": settings.recycle_distance,
            "sleep": parts.sleep,
        },
        "responder": responder_spec(parts.responder, lenient=for_hash),
        "bodies": {"n": b.n, "n_verts": b.n_verts, "next_uid": b.next_uid, "forces_applied": b.forces_applied},
        "pipeline": {
            "n_pairs": n_pairs,
            "manifolds": int(p.manifolds),
            "cached": int(p.cached),
            "ordered": ordered,
            "sweep_again": bool(p.sweep_again),
        },
        "joints": joints,
        "islands": {"some_asleep": islands.some_asleep, "next_island": islands.next_island},
    }


def _gather_for_restore(parts: WorldParts, meta: dict[str, Any]) -> None:
    """What a restore needs and the hash does not: the thread count, the step path, and the buffers'
    sizes (so that a restored world grows them at the ticks the original did)."""
    p, store, b, settings = parts.pipeline, parts.pipeline.store, parts.bodies, parts.settings
    meta["world"].update(threads=settings.threads, one_call_tick=parts.one_call_tick)
    meta["pipeline"].update(
        recycled=int(store.recycled),
        room={
            "pairs": p.buffers.pairs,
            "joint_rows": p.buffers.joint_rows,
            "pair_list": int(p.pairs.shape[0]),
            "store_rows": int(store.found_pose.shape[0]),
            "residuals": int(p.residuals.shape[1]),
            "bodies": int(b.capacity[0]),
            "vertices": int(b.capacity[1]),
        },
    )


def _gather_report(r: StepReport, meta: dict[str, Any], arrays: dict[str, np.ndarray]) -> None:
    """The last step's report, which a restored world hands back as ``World.last_step``."""
    meta["report"] = {
        "responder": r.responder,
        "dt": float(r.dt),
        "count": int(r.count),
        "counted": r.counted,
        "max_penetration": float(r.max_penetration),
        "contact_count": int(r.contact_count),
        "cache_hits": int(r.cache_hits),
    }
    arrays["report.residuals"] = r.residuals
    arrays["report.joint_impulses"] = r.joint_impulses
    arrays["report.solve_order"] = r.solve_order


# -- the image ---------------------------------------------------------------------------------------
def _version() -> str:
    from . import __version__

    return __version__


def snapshot(world: World) -> bytes:
    """The world's live state as bytes (the format: this module's docstring), between steps; the
    world is not changed. ``restore`` and ``from_snapshot`` put it back."""
    _check_world(world)
    lineage = _lineage(world)
    joint_ids = _note_handles(world, lineage)
    meta, arrays = _gather(world)
    meta["phys2d"] = _version()
    meta["lineage"] = lineage.token
    for spec, jid in zip(meta["joints"], joint_ids, strict=True):
        spec["id"] = jid
    table = []
    offset = 0
    parts = []
    for name, a in arrays.items():
        a = np.ascontiguousarray(a)
        if a.dtype.byteorder == ">":  # (the world's arrays are native; a big-endian machine writes little)
            a = a.astype(a.dtype.newbyteorder("<"))
        table.append([name, a.dtype.str, list(a.shape)])
        parts.append((offset, a))
        offset += -(-a.nbytes // ALIGN) * ALIGN
    meta["arrays"] = table
    head = json.dumps(meta, separators=(",", ":")).encode()
    head += b" " * (-len(head) % ALIGN)
    out = bytearray(HEADER.size + len(head) + offset)
    start = HEADER.size + len(head)
    out[HEADER.size : start] = head
    view = memoryview(out)
    for at, a in parts:
        if a.nbytes:
            view[start + at : start + at + a.nbytes] = a.reshape(-1).view(np.uint8).data
    crc = zlib.crc32(view[HEADER.size :])
    HEADER.pack_into(out, 0, MAGIC, FORMAT, len(head), offset, crc)
    return bytes(out)


@dataclass(eq=False)
class _Image:
    """A checked image: its plain part and its arrays (read-only views of the image's bytes)."""

    meta: dict[str, Any]
    arrays: dict[str, np.ndarray]


def _decode(data: object) -> _Image:
    """Check an image and read it: SnapshotError (one line) for anything but a whole snapshot of
    this format and phys2d version."""
    if isinstance(data, (bytearray, memoryview)):
        data = bytes(data)  # a copy: the world's read-only arrays may be views of it
    if not isinstance(data, bytes):
        raise TypeError(f"data must be bytes from World.snapshot(), got {type(data).__name__}")
    if len(data) < len(MAGIC) or data[: len(MAGIC)] != MAGIC:
        raise SnapshotError(f"data is not a phys2d snapshot: it starts with {data[:8]!r}, not {MAGIC!r}")
    if len(data) < HEADER.size:
        raise SnapshotError(f"snapshot is truncated: {len(data)} bytes, shorter than its {HEADER.size}-byte header")
    _, fmt, head_len, body_len, crc = HEADER.unpack_from(data)
    if fmt != FORMAT:
        raise SnapshotError(f"snapshot is of format {fmt}; this phys2d ({_version()}) reads format {FORMAT} only")
    total = HEADER.size + head_len + body_len
    if len(data) < total:
        raise SnapshotError(f"snapshot is truncated: {len(data)} of its {total} bytes")
    if len(data) > total:
        raise SnapshotError(f"snapshot is damaged: {len(data) - total} bytes follow its end ({total} bytes)")
    view = memoryview(data)
    if zlib.crc32(view[HEADER.size :]) != crc:
        raise SnapshotError(f"snapshot is damaged: its CRC-32 does not match its {total} bytes")
    try:
        meta = json.loads(view[HEADER.size : HEADER.size + head_len].tobytes())
        version = meta["phys2d"]
        table = meta["arrays"]
    except (ValueError, KeyError, TypeError) as e:
        raise SnapshotError(f"snapshot is damaged: its description cannot be read ({e})") from None
    if version != _version():
        raise SnapshotError(
            f"snapshot was taken by phys2d {version}, this is phys2d {_version()}: restore it with phys2d "
            f"{version}, or rebuild the scene and step it to that tick here"
        )
    arrays: dict[str, np.ndarray] = {}
    at = HEADER.size + head_len
    try:
        for name, dtype, shape in table:
            dt = np.dtype(dtype)
            size = math.prod(shape) * dt.itemsize
            if at + size > total:
                raise ValueError(f"array {name} runs past the end")
            if size:
                arrays[name] = np.frombuffer(data, dt, count=size // dt.itemsize, offset=at).reshape(shape)
            else:
                arrays[name] = np.zeros(shape, dt)
            at += -(-size // ALIGN) * ALIGN
    except (ValueError, TypeError) as e:
        raise SnapshotError(f"snapshot is damaged: its arrays do not match their description ({e})") from None
    if at != total:
        raise SnapshotError(f"snapshot is damaged: its arrays take {at - HEADER.size - head_len} of {body_len} bytes")
    return _Image(meta, arrays)


# -- putting it back -------------------------------------------------------------------------------
@dataclass(eq=False)
class _Plan:
    """Everything ``_commit`` puts into the world, built and checked."""

    meta: dict[str, Any]
    parts: Any  # ``world.WorldParts``: the bodies, handles, pipeline, islands, settings, responder, report
    joints: list[joint_module.Joint]
    joint_attrs: list[dict[str, Any]]
    joint_lam: np.ndarray
    contacts: Contacts
    lineage: int
    joint_ids: list[int]
    made: list[Body]  # the handles made anew (the others were the lineage's)


def _need(image: _Image, name: str, dtype: Any, shape: tuple[int, ...]) -> np.ndarray:
    """Array ``name`` of the image, checked to be of ``dtype`` and ``shape``."""
    a = image.arrays.get(name)
    if a is None:
        raise SnapshotError(f"snapshot is damaged: it has no array {name!r}")
    if a.shape != shape or a.dtype != dtype:
        raise SnapshotError(f"snapshot is damaged: array {name!r} is {a.dtype}{list(a.shape)}, not {np.dtype(dtype)}")
    return a


def _room(n: int, capacity: int) -> int:
    """A capacity of at least n (and the original's)."""
    return max(int(n), int(capacity))


def _prepare(world: World, image: _Image) -> _Plan:
    """Everything the image puts into ``world``, built and checked; the world is not touched."""
    from .world import WorldParts, WorldSettings

    meta = image.meta
    try:
        counts, pipe = meta["bodies"], meta["pipeline"]
        meta["world"], meta["responder"], meta["joint_state"], meta["report"]  # noqa: B018  (present)
        n, n_verts = int(counts["n"]), int(counts["n_verts"])
        room = pipe["room"]
    except (KeyError, TypeError, ValueError) as e:
        raise SnapshotError(f"snapshot is damaged: its description lacks {e}") from None
    b = _bodies_from(image, n, n_verts, counts, room)
    handles: list[Body] = []  # (the pipeline's: filled below, once the lineage is known)
    p = _pipeline_from(image, b, pipe, handles)

    # the responder, the contacts, the report, the islands
    responder = responder_from_spec(meta["responder"])
    contacts = Contacts(**{name: image.arrays[f"contacts.{name}"] for name in _CONTACT_FIELDS}).read_only()
    report = _report_from(image)
    islands = _islands_from(image, b, p)

    # the handles: this lineage's own where they live on, new ones for the rest
    lineage = _LINEAGES.get(world)
    token = int(meta["lineage"])
    own = lineage if lineage is not None and lineage.token == token else None
    made = _handles_from(world, own, b.uid.tolist(), handles)
    joints, attrs, jids = _joints_from(world, meta["joints"], own, {h._uid: h for h in handles})
    lam = image.arrays["joints.lam"].copy()
    s = meta["world"]
    settings = WorldSettings(
        np.array(s["gravity"], np.float64), float(s["contact_margin"]), float(s["contact_recycle_distance"]),
        float(s["max_speed"]), int(s["threads"]),
    )  # fmt: skip
    parts = WorldParts(b, handles, p.joints, p, islands, settings, responder, report, bool(s["sleep"]), False)
    parts = parts._replace(one_call_tick=bool(s["one_call_tick"]))
    return _Plan(meta, parts, joints, attrs, lam, contacts, token, jids, made)


def _bodies_from(image: _Image, n: int, n_verts: int, counts: dict[str, Any], room: dict[str, Any]) -> BodyArrays:
    """The bodies: new storage of the original's size, the live rows copied in, their uids checked."""
    cap, vcap = _room(max(n, 8), room["bodies"]), _room(max(n_verts, 32), room["vertices"])
    columns = {}
    for name, (shape, dtype) in BodyArrays._PER_BODY.items():
        column: np.ndarray = np.zeros((cap, *shape), dtype)
        column[:n] = _need(image, "bodies." + name, dtype, (n, *shape))
        columns[name] = column
    for name in ("local_v", "local_n"):
        column = np.zeros((vcap, 2))
        column[:n_verts] = _need(image, "bodies." + name, np.float64, (n_verts, 2))
        columns[name] = column
    b = BodyArrays.restored(columns, (n, n_verts, int(counts["next_uid"])), bool(counts["forces_applied"]))
    uids = b.uid
    if n and (np.any(np.diff(uids) <= 0) or uids[0] < 0 or uids[-1] >= b.next_uid):
        raise SnapshotError("snapshot is damaged: its bodies' uids do not ascend below next_uid")
    return b


def _pipeline_from(image: _Image, b: BodyArrays, pipe: dict[str, Any], handles: list[Body]) -> Pipeline:
    """The pipeline of bodies ``b`` and ``handles``: its buffers of the original's sizes, the live state
    in them (side 0); its joints are set once made."""
    from .pipeline.step import Buffers, Pipeline

    n, n_verts, room = b.n, b.n_verts, pipe["room"]
    k, m, n_pairs = int(pipe["cached"]), int(pipe["manifolds"]), int(pipe["n_pairs"])
    p = Pipeline(b, joint_module.JointSet(), handles)  # (its joints: set below, once made)
    pairs_room = _room(max(n_pairs, m, (k + 1) // 2), room["pairs"])
    p.buffers = t = Buffers(pairs_room, int(room["joint_rows"]))
    points = _side_from(image, t.sides[0], k, m)
    _store_from(image, p.store, points, pipe)
    p.side, p.manifolds, p.cached = 0, m, k
    p.pairs = np.zeros((_room(n_pairs, room["pair_list"]), 2), np.int32)
    pairs = _need(image, "pairs", np.int32, (n_pairs, 2))
    if n_pairs and (pairs.min() < 0 or pairs.max() >= n):
        raise SnapshotError("snapshot is damaged: a pair names a body it does not hold")
    p.pairs[:n_pairs] = pairs
    p.n_pairs = n_pairs
    p.ordered = int(pipe["ordered"])
    if p.ordered != PAIR_ORDER:
        t.pair_order[:n_pairs] = _need(image, "pair_order", np.int32, (n_pairs,))
    p.part = _need(image, "part", np.int32, (n,)).copy()
    p.sweep_again = bool(pipe["sweep_again"])
    p.geometry = (
        np.empty((n_verts, 2)), np.empty((n_verts, 2)), np.empty((n, 4)), np.empty(n), np.empty((n, 2)),
        _need(image, "fat", np.float64, (n, 4)).copy(),
    )  # fmt: skip
    p.residuals = np.zeros((2, _room(16, room["residuals"])))
    return p


def _side_from(image: _Image, c: ContactBuffers, k: int, m: int) -> np.ndarray:
    """The contact cache (``k`` entries) and the manifolds' keys (``m``, the store's first rows) into
    side ``c``; returns each manifold's point count, checked."""
    c.key[:k] = _need(image, "cache.key", np.int64, (k,))
    c.cache_lambda_n[:k] = _need(image, "cache.lambda_n", np.float64, (k,))
    c.cache_lambda_t[:k] = _need(image, "cache.lambda_t", np.float64, (k,))
    c.cache_pushed[:k] = _need(image, "cache.pushed", np.bool_, (k,))
    points = _need(image, "manifolds.points", np.int64, (m,))
    if np.any(points < 0) or np.any(points > 2):
        raise SnapshotError("snapshot is damaged: a manifold has more than 2 points")
    c.manifold_key[:m] = _need(image, "manifolds.key", np.int64, (m,))
    c.manifold_row[:m] = np.arange(m)
    return points


def _store_from(image: _Image, store: ManifoldStore, points: np.ndarray, pipe: dict[str, Any]) -> None:
    """The cached manifolds into a store of the original's size: rows in cache order, ``points``
    of each, packed from the first."""
    m, total = points.shape[0], int(points.sum())
    rows = _room(m, pipe["room"]["store_rows"])
    store.found_pose, store.found_rotation = np.zeros((rows, 2)), np.zeros((rows, 4))
    store.span = np.zeros((rows, 2), np.int64)
    store.anchor, store.normal = np.zeros((2 * rows, 4)), np.zeros((2 * rows, 2))
    store.separation, store.feature = np.zeros(2 * rows), np.zeros(2 * rows, np.int32)
    store.found_pose[:m] = _need(image, "manifolds.pose", np.float64, (m, 2))
    store.found_rotation[:m] = _need(image, "manifolds.rotation", np.float64, (m, 4))
    np.cumsum(points, out=store.span[:m, 1])
    store.span[:m, 0] = store.span[:m, 1] - points
    store.anchor[:total] = _need(image, "points.anchor", np.float64, (total, 4))
    store.normal[:total] = _need(image, "points.normal", np.float64, (total, 2))
    store.separation[:total] = _need(image, "points.separation", np.float64, (total,))
    store.feature[:total] = _need(image, "points.feature", np.int32, (total,))
    store.rows_used, store.points_used, store.recycled = m, total, int(pipe.get("recycled", 0))


def _report_from(image: _Image) -> StepReport:
    """The last step's report, read-only, as the original's ``World.last_step`` was."""
    r = image.meta["report"]
    return StepReport(
        r["responder"], r["dt"], r["count"], image.arrays["report.residuals"], r["max_penetration"],
        r["contact_count"], r["cache_hits"], image.arrays["report.joint_impulses"], None,
        image.arrays["report.solve_order"], r["counted"],
    ).read_only()  # fmt: skip


def _islands_from(image: _Image, b: BodyArrays, p: Pipeline) -> Islands:
    """The sleeping islands with the cache each keeps (their joints: set once made)."""
    from .sleep import Islands

    islands = Islands(b, p.joints, p)  # (its joints: set below, once made)
    islands.some_asleep = bool(image.meta["islands"]["some_asleep"])
    islands.next_island = int(image.meta["islands"]["next_island"])
    ids, sizes = image.arrays["islands.id"], image.arrays["islands.count"]
    ends = np.cumsum(sizes)
    kept = [image.arrays[f"islands.{name}"] for name in ("key", "lambda_n", "lambda_t", "pushed")]
    for island, end, size in zip(ids.tolist(), ends.tolist(), sizes.tolist(), strict=True):
        islands.kept[island] = tuple(a[end - size : end].copy() for a in kept)
    return islands


def _handles_from(world: World, own: _Lineage | None, uids: list[int], handles: list[Body]) -> list[Body]:
    """Append to ``handles`` a Body for each of ``uids``: the world's or its lineage ``own``'s where
    they live on (None: the image is of another lineage), new ones for the rest; returns the new ones."""
    made: list[Body] = []
    now = world._parts()
    if own is not None and [h._uid for h in now.handles] == uids:  # (a rollback: the same bodies)
        handles += now.handles
        uids = []
    current = {h._uid: h for h in now.handles} if own is not None else {}
    for i, u in enumerate(uids):
        h = current.get(u)
        if h is None and own is not None:
            ref = own.bodies.get(u)
            h = ref() if ref is not None else None
        if h is None:
            h = Body(world, i, u)
            made.append(h)
        handles.append(h)
    return made


def _joints_from(
    world: World, specs: list[Any], own: _Lineage | None, by_uid: dict[int, Body]
) -> tuple[list[joint_module.Joint], list[dict[str, Any]], list[int]]:
    """(the joints, the attributes each gets, their ids): the lineage ``own``'s joint where it is one of
    the same class, else a new one, for each of ``specs``; bodies by uid from ``by_uid``."""
    joints, attrs, jids = [], [], []
    for q, spec in enumerate(specs):
        cls = _JOINT_CLASSES.get(spec.get("type"))
        if cls is None or spec["a"] not in by_uid or spec["b"] not in by_uid:
            raise SnapshotError(f"snapshot is damaged: joint {q} is not a joint of its bodies")
        old = own.joints.get(spec["id"]) if own is not None else None
        joint = old if type(old) is cls else cls.__new__(cls)
        joints.append(joint)
        attrs.append(
            {**{key: _unplain(v) for key, v in spec["attrs"].items()}, "_world": world, "alive": True,
             "body_a": by_uid[spec["a"]], "body_b": by_uid[spec["b"]]}
        )  # fmt: skip
        jids.append(int(spec["id"]))
    return joints, attrs, jids


def _commit(world: World, plan: _Plan) -> None:
    """Put a prepared plan into the world: assignments only, nothing here refuses."""
    meta, now, parts = plan.meta, world._parts(), plan.parts
    staying = {id(j) for j in plan.joints}
    for joint in now.joints.handles:  # joints made since the image: removed, their last reactions kept
        if id(joint) not in staying:
            joint._impulse, joint._offset, joint.alive, joint._has_rows = joint.impulse, None, False, False
    keep = {id(h) for h in parts.handles}
    for h in now.handles:
        if id(h) not in keep:
            h._index = -1
    for i, h in enumerate(parts.handles):
        h._index = i
    for joint, attrs in zip(plan.joints, plan.joint_attrs, strict=True):
        joint.__dict__.clear()
        joint.__dict__.update(attrs)
    js = meta["joint_state"]
    rows_first, packed, placed = int(js["rows_first"]), bool(js["packed"]), bool(js["placed"])
    joints = joint_module.JointSet.restored(plan.joints, plan.joint_lam, rows_first, packed, placed)
    pipeline, islands = parts.pipeline, parts.islands
    pipeline.joints = islands.joints = joints
    pipeline.keep_contacts(plan.contacts)
    world._put_parts(parts._replace(joints=joints))
    world.tick, world.time = int(meta["tick"]), float(meta["time"])
    lineage = _LINEAGES.get(world)
    if lineage is None or lineage.token != plan.lineage:  # the world goes on as one of the image's lineage
        lineage = _LINEAGES[world] = _Lineage(token=plan.lineage)
    for h in plan.made:
        lineage.bodies[h._uid] = weakref.ref(h)
    if parts.handles:
        lineage.seen_uid = max(lineage.seen_uid, parts.handles[-1]._uid)
    for joint, jid in zip(plan.joints, plan.joint_ids, strict=True):
        lineage.joint_ids[joint] = jid
        lineage.joints[jid] = joint


def _check_world(world: object) -> None:
    from .world import World

    if not isinstance(world, World):
        raise TypeError(f"world must be a phys2d World, got {type(world).__name__}")


def restore(world: World, data: bytes) -> None:
    """Put the state of a ``snapshot`` back into ``world`` in place (handles: see the module
    docstring). A damaged, truncated or foreign image, or one of another phys2d version, is refused
    with SnapshotError and the world left exactly as it was."""
    _check_world(world)
    image = _decode(data)
    try:
        plan = _prepare(world, image)
    except SnapshotError:
        raise
    except (KeyError, TypeError, ValueError, IndexError) as e:
        raise SnapshotError(f"snapshot is damaged: {type(e).__name__}: {e}") from None
    _commit(world, plan)


def from_snapshot(data: bytes) -> World:
    """A new World holding the state of a ``snapshot`` (SnapshotError as ``restore``)."""
    from .world import World

    world = World()
    restore(world, data)
    return world


def state_hash(world: World) -> int:
    """A 64-bit hash of everything that decides the world's future, the tick included (this
    module's docstring): the first 8 bytes of SHA-256 over canonical bytes, as an unsigned int."""
    _check_world(world)
    meta, arrays = _gather(world, for_hash=True)
    meta["arrays"] = [[name, a.dtype.str, list(a.shape)] for name, a in arrays.items()]
    h = hashlib.sha256(b"phys2d state 1\x00")
    h.update(_canonical(meta))
    for a in arrays.values():  # (C-contiguous views are hashed where they lie)
        h.update((a if a.flags.c_contiguous else np.ascontiguousarray(a)).data)
    return int.from_bytes(h.digest()[:8], "little")


__all__ = [
    "FORMAT",
    "MAGIC",
    "SnapshotError",
    "from_snapshot",
    "responder_from_spec",
    "responder_spec",
    "restore",
    "snapshot",
    "state_hash",
]
