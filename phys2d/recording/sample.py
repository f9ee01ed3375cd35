"""Sampling a World: copies of what a recording keeps of one tick, read through public accessors.

``Sampler.sample(w)`` is the only place the recorder touches a World. It reads the
public arrays (``w.x``, ``w.theta``, ``w.V``), the read-only accessors
(``w.body_uids``, ``w.body_static``, ``w.body_kinds``, ``w.body_radii``,
``w.vertex_start``, ``w.vertex_count``, ``w.local_vertices``), ``w.contacts``,
``w.last_step``, ``w.joints`` and the energy and momentum methods, and copies
what it keeps, so the world may step on at once.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass

import numpy as np

from ..shapes import CIRCLE
from . import schema
from .arena import Arena, Ref, SlotWriter


@dataclass(eq=False)
class Strips:
    """How to draw a group of bodies: point p of strip s is x[body[p]] + R(theta[body[p]]) local[p].

    body     (P,) index (into the world's arrays) of the body each point belongs to
    local    (P, 2) the point in its body's frame, m
    lengths  (B,) points per strip, one strip per body of the group
    """

    body: np.ndarray
    local: np.ndarray
    lengths: np.ndarray

    @classmethod
    def of(cls, w, rows: np.ndarray) -> Strips:
        kinds, radii = w.body_kinds, w.body_radii
        start, count, verts = w.vertex_start, w.vertex_count, w.local_vertices
        seg = schema.CIRCLE_SEGMENTS
        phi = 2.0 * np.pi * np.arange(seg + 1) / seg
        rim = np.concatenate([np.zeros((1, 2)), np.stack([np.cos(phi), np.sin(phi)], axis=1)])  # centre, rim
        locals_, lengths = [], []
        for i in rows:
            if kinds[i] == CIRCLE:  # the spoke from the centre along the body's angle, then the rim
                pts = rim * radii[i]
            elif count[i] == 2 and radii[i] > 0.0:  # a capsule or rounded segment: its stadium
                s = int(start[i])
                pts = stadium(verts[s], verts[s + 1], float(radii[i]))
            elif count[i] == 2:  # a bare segment or chain segment: the line
                s = int(start[i])
                pts = verts[s : s + 2].copy()
            else:  # the closed outline
                s, c = int(start[i]), int(count[i])
                pts = np.concatenate([verts[s : s + c], verts[s : s + 1]])
            locals_.append(pts)
            lengths.append(pts.shape[0])
        lengths_a = np.asarray(lengths, dtype=np.int64)
        return cls(
            body=np.repeat(np.asarray(rows, dtype=np.int64), lengths_a),
            local=np.concatenate(locals_) if locals_ else np.zeros((0, 2)),
            lengths=lengths_a,
        )

    def world_points(self, x: np.ndarray, theta: np.ndarray) -> np.ndarray:
        """(S, P, 2) drawn points for S ticks of poses x (S, N, 2), theta (S, N), m, on the draw grid."""
        c, s = np.cos(theta)[:, self.body], np.sin(theta)[:, self.body]  # trig once per body, not per point
        lx, ly = self.local[:, 0], self.local[:, 1]
        out = np.empty(c.shape + (2,))
        out[..., 0] = x[:, self.body, 0] + c * lx - s * ly
        out[..., 1] = x[:, self.body, 1] + s * lx + c * ly
        return on_grid(out, schema.DRAW_GRID)


def stadium(v0: np.ndarray, v1: np.ndarray, radius: float) -> np.ndarray:
    """The closed outline of the core v0 -> v1 (m, body frame) rounded by ``radius`` (m): its right
    side, the half circle around v1, its left side, the half circle around v0."""
    half = schema.CIRCLE_SEGMENTS // 2
    d = v1 - v0
    base = math.atan2(d[1], d[0]) - 0.5 * math.pi  # the right-hand normal's angle
    phi = base + math.pi * np.arange(half + 1) / half
    arc = radius * np.stack([np.cos(phi), np.sin(phi)], axis=1)
    outline = np.concatenate([v1 + arc, v0 - arc])  # each arc turns counter-clockwise by pi
    return np.concatenate([outline, outline[:1]])


def on_grid(a: np.ndarray, grid: float) -> np.ndarray:
    """float32 of ``a`` rounded to multiples of ``grid`` (a power of two, so exact below 2^24 grid).
    One float64 temporary, rounded and scaled in place."""
    steps = np.multiply(a, 1.0 / grid)  # exact: 1 / grid is a power of two
    np.rint(steps, out=steps)  # as np.round: halves to even
    steps *= grid
    return steps.astype(np.float32)


@dataclass(eq=False)
class Layout:
    """What stays the same while the world's set of bodies does not change."""

    uid: np.ndarray  # (N,) body uids
    dynamic: np.ndarray  # indices of dynamic bodies
    static: np.ndarray  # indices of static bodies
    dynamic_strips: Strips
    static_strips: Strips
    dynamic_class: np.ndarray  # (D,) class ids
    static_class: np.ndarray  # (S,)
    dynamic_labels: list[str]
    static_labels: list[str]
    mass: np.ndarray  # (N,) kg
    inertia: np.ndarray  # (N,) kg m^2
    version: int = 0  # which layout of its run this is (0, 1, ...): equal versions, same bodies

    @classmethod
    def of(cls, w, version: int = 0) -> Layout:
        uid = np.array(w.body_uids, dtype=np.int64)
        static_mask = np.asarray(w.body_static)
        circle = np.asarray(w.body_kinds) == CIRCLE
        dyn, stat = np.flatnonzero(~static_mask), np.flatnonzero(static_mask)
        return cls(
            uid=uid,
            dynamic=dyn,
            static=stat,
            dynamic_strips=Strips.of(w, dyn),
            static_strips=Strips.of(w, stat),
            dynamic_class=np.where(circle[dyn], schema.CLASS_CIRCLE, schema.CLASS_BODY).astype(np.uint16),
            static_class=np.full(stat.size, schema.CLASS_STATIC, np.uint16),
            dynamic_labels=[f"b{u}" for u in uid[dyn]],
            static_labels=[f"b{u}" for u in uid[stat]],
            mass=np.array(w.body_masses, dtype=np.float64),
            inertia=np.array(w.body_inertias, dtype=np.float64),
            version=version,
        )


@dataclass(eq=False)
class Sample:
    """One tick of one world, copied.

    key (K,) contact identities; point, normal (K, 2); separation, lambda_n, lambda_t (K,);
    warm (K,) bool; gravity (2,) m/s^2; step (4,) the step's max_penetration (mm), contact count,
    cache hit rate and iterations (the energies and momenta are worked out when written,
    ``aggregates``); residuals (R,) m/s; joint_ends (J, 2, 2) m and joint_impulses (rows,) N s with joint_keys (rows,)
    (joint << 16 | row), or None in a world without joints. For replay (``replay``), when the
    recorder keeps it: state (1,) uint64 the world's state hash, dt (1,) float64 the step that led
    to the tick (s; 0 before the first), keyframe (B,) uint8 the world's snapshot on a keyframe
    tick, responder (B,) uint8 the responder's spec as JSON on a tick where it changed.
    """

    tick: int
    time: float
    layout: Layout
    x: np.ndarray
    theta: np.ndarray
    V: np.ndarray
    key: np.ndarray
    point: np.ndarray
    normal: np.ndarray
    separation: np.ndarray
    lambda_n: np.ndarray
    lambda_t: np.ndarray
    warm: np.ndarray
    gravity: np.ndarray
    step: np.ndarray
    residuals: np.ndarray
    joint_ends: np.ndarray | None = None
    joint_keys: np.ndarray | None = None
    joint_impulses: np.ndarray | None = None
    asleep: np.ndarray | None = None  # (N,) bool: the body sleeps; None when none does
    state: np.ndarray | None = None  # (1,) uint64 state hash
    dt: np.ndarray | None = None  # (1,) float64 s
    keyframe: np.ndarray | None = None  # (B,) uint8: a snapshot (``phys2d.snapshot``)
    responder: np.ndarray | None = None  # (B,) uint8: JSON of ``snapshot.responder_spec``

    def dynamic_classes(self) -> np.ndarray:
        """(D,) the class ids of the dynamic bodies this tick: a sleeping one's dimmed."""
        lay = self.layout
        if self.asleep is None:
            return lay.dynamic_class
        dimmed = np.where(
            lay.dynamic_class == schema.CLASS_CIRCLE, schema.CLASS_ASLEEP_CIRCLE, schema.CLASS_ASLEEP_BODY
        )
        return np.where(self.asleep[lay.dynamic], dimmed, lay.dynamic_class).astype(np.uint16)


class Sampler:
    """Samples one world tick by tick, rebuilding the layout only when its bodies change.

    replay          also keep what re-enters the recording (``replay``): every tick's state hash
                    and dt, the responder's spec when it changes, and a keyframe (a snapshot) on
                    the first tick and every ``keyframe_every`` ticks after the last (0: none)
    """

    def __init__(self, replay: bool = False, keyframe_every: int = 0) -> None:
        self.layout: Layout | None = None
        self.had_joints = False
        self.replay = replay
        self.keyframe_every = keyframe_every
        self.last_keyframe: int | None = None  # the tick of the last keyframe
        self.spec: str | None = None  # the responder's spec as last written
        self.note: str | None = None  # why keyframes stopped (a responder a snapshot cannot hold)

    def sample(self, w, keyframe: bool = False) -> Sample:
        """Tick ``w.tick`` copied; with ``keyframe`` (and ``replay``) a keyframe whatever the count."""
        uid = w.body_uids
        lay = self.layout
        if lay is None or lay.uid.shape != uid.shape or not np.array_equal(lay.uid, uid):
            lay = self.layout = Layout.of(w, 0 if lay is None else lay.version + 1)
        c, s = w.contacts, w.last_step
        step = np.array(
            [s.max_penetration * schema.PENETRATION_SCALE, len(c), s.cache_hit_rate, s.iterations], dtype=np.float64
        )
        out = Sample(
            tick=int(w.tick),
            time=float(w.time),
            layout=lay,
            x=np.array(w.x, dtype=np.float64),
            theta=np.array(w.theta, dtype=np.float64),
            V=np.array(w.V, dtype=np.float64),
            key=np.array(c.key, dtype=np.int64),
            point=np.array(c.point, dtype=np.float64),
            normal=np.array(c.normal, dtype=np.float64),
            separation=np.array(c.separation, dtype=np.float64),
            lambda_n=np.array(c.lambda_n, dtype=np.float64),
            lambda_t=np.array(c.lambda_t, dtype=np.float64),
            warm=np.array(c.warm_started, dtype=np.bool_),
            gravity=w.gravity,
            step=step,
            residuals=np.array(s.residuals, dtype=np.float64),
        )
        asleep = getattr(w, "body_asleep", None)  # (a world of phys2d's; an observer's stand-in may lack it)
        if asleep is not None and asleep.any():
            out.asleep = np.array(asleep, dtype=np.bool_)
        joints = w.joints
        if joints or self.had_joints:
            self.had_joints = True
            ends = [np.asarray(j.anchors(), dtype=np.float64).reshape(2, 2) for j in joints]
            imps = [np.atleast_1d(np.asarray(j.impulse, dtype=np.float64)).ravel() for j in joints]
            out.joint_ends = np.stack(ends) if ends else np.zeros((0, 2, 2))
            out.joint_keys = (
                np.concatenate([(k << 16) + np.arange(v.size, dtype=np.int64) for k, v in enumerate(imps)])
                if imps
                else np.zeros(0, np.int64)
            )
            out.joint_impulses = np.concatenate(imps) if imps else np.zeros(0)
        if self.replay:
            self._replay(w, out, keyframe)
        return out

    def _replay(self, w, out: Sample, keyframe: bool) -> None:
        """The state hash, dt, responder spec and keyframe of the tick (``replay``)."""
        from .. import snapshot

        out.state = np.array([snapshot.state_hash(w)], dtype=np.uint64)
        out.dt = np.array([w.last_step.dt], dtype=np.float64)
        try:
            spec = json.dumps(snapshot.responder_spec(w.responder), sort_keys=True)
        except snapshot.SnapshotError as e:
            self.note = self.note or str(e)
            return
        if spec != self.spec:
            self.spec = spec
            out.responder = np.frombuffer(spec.encode(), dtype=np.uint8)
        last, every = self.last_keyframe, self.keyframe_every
        if keyframe or (every > 0 and (last is None or w.tick - last >= every)):
            out.keyframe = np.frombuffer(snapshot.snapshot(w), dtype=np.uint8)
            self.last_keyframe = w.tick


def aggregates(samples: list[Sample]) -> np.ndarray:
    """(S, len(schema.STATS)) per tick: kinetic, potential and total energy (J), momentum x, y
    (kg m/s), angular momentum about the origin (kg m^2/s) of the dynamic bodies, then the step's
    figures. Worked out here, in bulk, from the sampled state and the bodies' masses:

        KE = sum 1/2 m |v|^2 + 1/2 I omega^2,  PE = -sum m g . x,  p = sum m v,
        L = sum I omega + m (x_x v_y - x_y v_x)
    """
    out = np.empty((len(samples), len(schema.STATS)))
    start = 0
    while start < len(samples):  # runs of ticks with the same bodies, in bulk
        lay = samples[start].layout
        end = start
        while end < len(samples) and samples[end].layout.version == lay.version:
            end += 1
        d = lay.dynamic
        m, inertia = lay.mass[d], lay.inertia[d]
        x = np.stack([s.x[d] for s in samples[start:end]])  # (S, D, 2)
        v = np.stack([s.V[d] for s in samples[start:end]])  # (S, D, 3)
        g = np.stack([s.gravity for s in samples[start:end]])  # (S, 2)
        ke = 0.5 * ((v[..., 0] ** 2 + v[..., 1] ** 2) @ m + v[..., 2] ** 2 @ inertia)
        pe = -(np.einsum("sdk,sk->sd", x, g) @ m)
        out[start:end, 0], out[start:end, 1], out[start:end, 2] = ke, pe, ke + pe
        out[start:end, 3], out[start:end, 4] = v[..., 0] @ m, v[..., 1] @ m
        out[start:end, 5] = v[..., 2] @ inertia + (x[..., 0] * v[..., 1] - x[..., 1] * v[..., 0]) @ m
        out[start:end, 6:] = np.stack([s.step for s in samples[start:end]])
        start = end
    return out


# -- handing samples to a writer process -------------------------------------------------------
_PACKED = (
    "x",
    "theta",
    "V",
    "key",
    "point",
    "normal",
    "separation",
    "lambda_n",
    "lambda_t",
    "warm",
    "gravity",
    "step",
    "residuals",
    "joint_ends",
    "joint_keys",
    "joint_impulses",
    "asleep",
    "state",
    "dt",
    "keyframe",
    "responder",
)


def pack(samples: list[Sample], sent: set[int], slot: SlotWriter | None = None) -> dict:
    """One run's samples as a few long arrays (one concatenation per field), cheap to send to a
    writer process; the layouts whose versions are not in ``sent`` go along once and are added to
    it. With ``slot``, the long arrays are written into that slot of a shared arena and only
    their places (``Ref``) are kept (``window_parts`` and ``Arena.fits`` say whether they fit)."""
    out: dict = {
        "tick": np.fromiter((s.tick for s in samples), np.int64, len(samples)),
        "time": np.fromiter((s.time for s in samples), np.float64, len(samples)),
        "layout": np.fromiter((s.layout.version for s in samples), np.int64, len(samples)),
        "layouts": {},
    }
    for s in samples:
        if s.layout.version not in sent:
            sent.add(s.layout.version)
            out["layouts"][s.layout.version] = s.layout
    for name in _PACKED:
        arrays = [getattr(s, name) for s in samples]
        present = np.array([a is not None for a in arrays])
        kept = [a for a in arrays if a is not None]
        flat: np.ndarray | Ref | None = None
        if kept:
            flat = slot.put(kept) if slot is not None else np.concatenate(kept)
        out[name] = (present, np.fromiter((a.shape[0] for a in kept), np.int64, len(kept)), flat)
    return out


def window_parts(samples: list[Sample]) -> list[list[np.ndarray]]:
    """Per packed field, the arrays ``pack`` concatenates (for ``Arena.fits``)."""
    return [[a for a in (getattr(s, name) for s in samples) if a is not None] for name in _PACKED]


def unpack(packed: dict, layouts: dict[int, Layout], arena: Arena | None = None) -> list[Sample]:
    """The samples ``pack`` packed (views into its arrays; arrays in ``arena`` are copied out, so
    the slot may be reused at once); ``layouts`` (by version) remembers the run's layouts sent so far."""
    layouts.update(packed["layouts"])
    n = packed["tick"].size
    fields: dict[str, list] = {}
    for name in _PACKED:
        present, lengths, flat = packed[name]
        if isinstance(flat, Ref):
            if arena is None:
                raise ValueError(f"field {name!r} lies in a shared arena, but no arena was given")
            flat = arena.view(flat).copy()
        parts = iter(np.split(flat, np.cumsum(lengths)[:-1]) if flat is not None else [])
        fields[name] = [next(parts) if p else None for p in present]
    return [
        Sample(
            tick=int(packed["tick"][i]),
            time=float(packed["time"][i]),
            layout=layouts[int(packed["layout"][i])],
            **{name: fields[name][i] for name in _PACKED},
        )
        for i in range(n)
    ]
