"""A phys2d recording read back into numpy arrays, with rerun's own reader.

    rec = phys2d.playback.load("recordings/pyramid.rrd")
    rec.tick, rec.x, rec.theta           # (T,), (T, U, 2), (T, U): poses per tick
    rec.contacts.at(-1)["normal_impulse"]  # the last tick's lambda_n, N s
    rec.residuals_at(rec.tick[-1])       # the solver's residual after each sweep, m/s
    rec.kinetic_energy                   # (T,) J
    ticks, lam = rec.series("lambda", key)   # one contact's [lambda_n, lambda_t] over time

Re-entering a recording (``replay``): ``world_at(path, tick)`` gives a live World at any
logged tick, from the keyframe at or before it, checked against the recorded state hashes.

A file with several runs (``phys2d compare``) gives ``rec.runs["pgs"]`` and so on;
a file with one run forwards attribute access to it. Poses, velocities, residuals,
the per-tick aggregates and the plotted series are exactly the float64 values the
engine had; the per-tick contact table is float32 (drawn points and normals also on
the draw grid), see ``schema``. ``time`` comes from the ``sim_time`` timeline, which
Rerun stores in whole nanoseconds. Entity paths and field names come from ``schema``.
"""

from __future__ import annotations

import os
import warnings
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
from rerun.chunk import RrdReader

from . import schema
from .replay import CheckResult, ReplayError, Timeline, timeline, timelines, world_at
from .schema import contact_entity

SERIES_FAMILIES = {"lambda": schema.LAMBDA, "penetration": schema.PENETRATION, "reaction": schema.REACTION}
SERIES_UNITS = {"lambda": schema.LAMBDA_UNIT, "penetration": schema.PENETRATION_UNIT, "reaction": "N s"}


class RecordingError(ValueError):
    """The file is not a phys2d recording (or not a readable .rrd at all)."""


def _table(batches: list[pa.RecordBatch], timeline: str = "tick") -> pa.Table | None:
    """The rows of an entity's temporal chunks as one table sorted by ``timeline`` (stable)."""
    if not batches:
        return None
    types: dict[str, pa.DataType] = {}
    for b in batches:  # union of the columns: a chunk without a column gets nulls there
        for f in b.schema:
            types.setdefault(f.name, f.type)
    names = list(types)
    t = pa.Table.from_batches(
        [
            pa.RecordBatch.from_arrays(
                [b.column(n) if n in b.schema.names else pa.nulls(b.num_rows, types[n]) for n in names], names=names
            )
            for b in batches
        ]
    )
    return t.take(pc.sort_indices(t, sort_keys=[(timeline, "ascending"), ("rerun.controls.RowId", "ascending")]))


def _flat(t: pa.Table, name: str) -> np.ndarray:
    """A list<...> column flattened to numpy (one entry per instance, rows in order)."""
    col = t.column(name).combine_chunks()
    return pc.list_flatten(col).to_numpy(zero_copy_only=False)


def _points(t: pa.Table, name: str) -> np.ndarray:
    """A list<fixed_size_list<f32, 2>> column (Points, Arrows) as (n, 2) float64."""
    col = pc.list_flatten(t.column(name).combine_chunks())
    return col.flatten().to_numpy(zero_copy_only=False).astype(np.float64).reshape(-1, 2)


def _lengths(t: pa.Table, name: str) -> np.ndarray:
    return pc.list_value_length(t.column(name)).fill_null(0).to_numpy(zero_copy_only=False).astype(np.int64)


def _scalars(t: pa.Table | None, width: int = 1) -> np.ndarray:
    if t is None:
        return np.zeros((0, width)) if width > 1 else np.zeros(0)
    v = _flat(t, "Scalars:scalars").astype(np.float64)
    return v.reshape(-1, width) if width > 1 else v


@dataclass(eq=False)
class ContactFrames:
    """Every tick's contacts, flattened: tick i's contacts are rows ``offsets[i]:offsets[i+1]``.

    key (M,) int64 identities (``schema.contact_entity(key)`` names them), body_a, body_b (M,)
    the bodies' uids, feature (M,) feature ids; separation (M,) m and normal_impulse,
    tangent_impulse (M,) N s as float32 values widened (the contact table is for looking at);
    point (M, 2) m and normal (M, 2) as drawn: on ``schema.DRAW_GRID`` and ``schema.NORMAL_GRID``;
    warm_started (M,) bool; tick (M,) the tick of each row.
    """

    offsets: np.ndarray
    tick: np.ndarray
    key: np.ndarray
    body_a: np.ndarray
    body_b: np.ndarray
    feature: np.ndarray
    point: np.ndarray
    normal: np.ndarray
    separation: np.ndarray
    normal_impulse: np.ndarray
    tangent_impulse: np.ndarray
    warm_started: np.ndarray

    _FIELDS = (
        "key",
        "body_a",
        "body_b",
        "feature",
        "point",
        "normal",
        "separation",
        "normal_impulse",
        "tangent_impulse",
        "warm_started",
    )

    @classmethod
    def empty(cls, ticks: int) -> ContactFrames:
        z = np.zeros(0)
        i = np.zeros(0, np.int64)
        return cls(
            np.zeros(ticks + 1, np.int64),
            i,
            i,
            i.copy(),
            i.copy(),
            i.copy(),
            np.zeros((0, 2)),
            np.zeros((0, 2)),
            z,
            z.copy(),
            z.copy(),
            z.astype(np.bool_),
        )

    def __len__(self) -> int:
        return int(self.offsets.shape[0]) - 1

    def at(self, i: int) -> dict[str, np.ndarray]:
        """The contacts of the i-th recorded tick (an index into ``Run.tick``; negative counts back)."""
        n = len(self)
        if isinstance(i, bool) or not isinstance(i, (int, np.integer)):
            raise TypeError(f"i must be an integer index, got {type(i).__name__}")
        if not -n <= i < n:
            raise IndexError(f"i={i} is out of range for {n} recorded ticks")
        i = int(i) % n
        s = slice(int(self.offsets[i]), int(self.offsets[i + 1]))
        return {f: getattr(self, f)[s] for f in self._FIELDS}


@dataclass(eq=False)
class Run:
    """One world's recorded ticks (T of them) as arrays.

    tick (T,) and time (T,) s; body_uid (U,) every body seen, in uid order (a world's
    order); x (T, U, 2) m, theta (T, U) rad, V (T, U, 3) [vx, vy, omega], float64 as
    the engine held them (NaN where a body did not exist at that tick); contacts:
    ContactFrames; residual_tick, residual (R,) the residual (m/s) after every solver
    sweep; per tick: kinetic_energy, potential_energy (J), linear_momentum (T, 2) kg m/s,
    angular_momentum kg m^2/s, max_penetration m, contact_count, cache_hit_rate,
    iterations; properties: what the run was (responder, scene, ...).
    """

    label: str
    properties: dict[str, Any]
    tick: np.ndarray
    time: np.ndarray
    body_uid: np.ndarray
    x: np.ndarray
    theta: np.ndarray
    V: np.ndarray
    contacts: ContactFrames
    residual_tick: np.ndarray
    residual: np.ndarray
    kinetic_energy: np.ndarray
    potential_energy: np.ndarray
    linear_momentum: np.ndarray
    angular_momentum: np.ndarray
    max_penetration: np.ndarray
    contact_count: np.ndarray
    cache_hit_rate: np.ndarray
    iterations: np.ndarray
    joint_anchors: list[np.ndarray] = field(default_factory=list)
    _recording: Recording | None = field(default=None, repr=False)

    @property
    def prefix(self) -> str:
        return schema.run_prefix(self.label)

    def residuals_at(self, tick: int) -> np.ndarray:
        """The residual (m/s) after each solver sweep of ``tick`` (a tick number, as in ``self.tick``)."""
        return self.residual[self.residual_tick == tick]

    def series_keys(self, quantity: str = "lambda") -> list[str]:
        """Entity names (``b<a>-b<b>/f<feature>``, ``j<k>/r<row>``) with a series of ``quantity``."""
        family = self._family(quantity)
        assert self._recording is not None
        return self._recording._series_names(f"/{self.prefix}{family}/")

    def series(self, quantity: str, key: int | str) -> tuple[np.ndarray, np.ndarray]:
        """(ticks, values) of one plotted contact's (or joint row's) series, float64 as the engine
        held them; a NaN row marks where it ended.

        quantity  'lambda' (values (n, 2): lambda_n, lambda_t in N s), 'penetration' ((n,),
                  -separation in mm: ``schema.PENETRATION_UNIT``) or 'reaction' (joint rows, (n,) N s)
        key       a contact key from ``Contacts.key`` or an entity name from ``series_keys``
        """
        family = self._family(quantity)
        if isinstance(key, (int, np.integer)) and not isinstance(key, bool):
            name = contact_entity(int(key))
        elif isinstance(key, str):
            name = key
        else:
            raise TypeError(f"key must be a contact key (int) or an entity name (str), got {type(key).__name__}")
        assert self._recording is not None
        t = self._recording._temporal(f"/{self.prefix}{family}/{name}")
        if t is None:
            raise KeyError(f"no {quantity} series for {name!r} in run {self.label or '(unnamed)'}")
        valid = t.filter(pc.is_valid(t.column("Scalars:scalars")))
        ticks = valid.column(schema.TICK).to_numpy()
        values = _scalars(valid, 2 if quantity == "lambda" else 1)
        return ticks, values

    @staticmethod
    def _family(quantity: str) -> str:
        if quantity not in SERIES_FAMILIES:
            raise ValueError(f"quantity must be one of {sorted(SERIES_FAMILIES)}, got {quantity!r}")
        return SERIES_FAMILIES[quantity]


class Recording:
    """A loaded recording: ``runs`` by label ('' for a file with one unnamed run)."""

    def __init__(self, path: str, store, entities: dict[str, list], properties: dict[str, dict]) -> None:
        self.path = path
        self._store = store
        self._entities = entities  # entity path -> its temporal chunks (not yet converted)
        self.properties = properties  # property entity ('phys2d', 'run', 'runs/<label>') -> values
        root = f"/{schema.RUNS_ROOT}/"
        labels = sorted({e.split("/")[2] for e in entities if e.startswith(root) and e.endswith("/" + schema.BODIES)})
        if f"/{schema.BODIES}" in entities:
            labels.insert(0, "")
        if not labels:
            raise RecordingError(f"{path!r} holds no phys2d run (no {schema.BODIES} entity)")
        self.runs: dict[str, Run] = {label: self._run(label) for label in labels}

    def __getattr__(self, name: str):
        if name.startswith("_") or name in ("runs", "path", "properties"):
            raise AttributeError(name)
        runs = self.__dict__.get("runs", {})
        if len(runs) != 1:
            raise AttributeError(f"{name!r}: this recording holds runs {sorted(runs)}; use .runs[label].{name}")
        return getattr(next(iter(runs.values())), name)

    def __repr__(self) -> str:
        parts = [f"{label or '(run)'}: {len(r.tick)} ticks" for label, r in self.runs.items()]
        return f"<Recording {self.path!r}: {', '.join(parts)}>"

    # -- reading ---------------------------------------------------------------
    def _temporal(self, entity: str) -> pa.Table | None:
        chunks = self._entities.get(entity)
        if not chunks:
            return None
        return _table([c.to_record_batch() for c in chunks])

    def _series_names(self, prefix: str) -> list[str]:
        return sorted(e[len(prefix) :] for e in self._entities if e.startswith(prefix))

    def _bodies(self, entity: str) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray], np.ndarray] | None:
        """(ticks (n,), instances per row (n,), flat field values, row of each instance) of a body table."""
        t = self._temporal(entity)
        if t is None or "x" not in t.column_names:
            return None
        t = t.filter(pc.is_valid(t.column("x")))  # rows that carry the table, not only labels
        n = _lengths(t, "uid")
        vals: dict[str, np.ndarray] = {f.name: _flat(t, f.name).astype(f.dtype) for f in schema.BODY_FIELDS}
        return t.column(schema.TICK).to_numpy().astype(np.int64), n, vals, np.repeat(np.arange(len(n)), n)

    def _run(self, label: str) -> Run:
        p = "/" + schema.run_prefix(label)
        dyn = self._bodies(f"{p}{schema.BODIES}")
        if dyn is None:
            raise RecordingError(f"{self.path!r}: run {label!r} has no bodies")
        tick, n_dyn, dval, drow = dyn
        bodies_t = self._temporal(f"{p}{schema.BODIES}")
        assert bodies_t is not None
        bt = bodies_t.filter(pc.is_valid(bodies_t.column("x")))
        time = bt.column(schema.SIM_TIME).cast(pa.int64()).to_numpy() / 1e9
        body_uid, x, theta, V = _poses(tick, dval, drow, self._bodies(f"{p}{schema.STATIC}"))
        contacts = self._contacts(p, tick)
        res = self._temporal(f"{p}{schema.SWEEPS}")
        if res is None:  # written before the exact residuals had an entity of their own
            res = self._temporal(f"{p}{schema.RESIDUAL}")
        stats = {st.name: _scalars(self._temporal(f"{p}{schema.STATS_ROOT}/{st.name}")) for st in schema.STATS}
        anchors = self._joint_anchors(p)
        props = self.properties.get(schema.run_property(label), {})
        return Run(
            label=label,
            properties={**self.properties.get(schema.PROPERTIES_ENGINE, {}), **props},
            tick=tick,
            time=time,
            body_uid=body_uid,
            x=x,
            theta=theta,
            V=V,
            contacts=contacts,
            residual_tick=res.column(schema.TICK).to_numpy().astype(np.int64)
            if res is not None
            else np.zeros(0, np.int64),
            residual=_flat(res, schema.RESIDUAL_FIELD.name).astype(np.float64) if res is not None else np.zeros(0),
            kinetic_energy=stats["energy/kinetic"],
            potential_energy=stats["energy/potential"],
            linear_momentum=np.stack([stats["momentum/x"], stats["momentum/y"]], axis=1),
            angular_momentum=stats["angular_momentum"],
            max_penetration=stats["max_penetration"] / schema.PENETRATION_SCALE,
            contact_count=stats["contact_count"].astype(np.int64),
            cache_hit_rate=stats["cache_hit_rate"],
            iterations=stats["iterations"].astype(np.int64),
            joint_anchors=anchors,
            _recording=self,
        )

    def _contacts(self, p: str, tick: np.ndarray) -> ContactFrames:
        """The run's per-tick contact table (entity ``p`` + ``schema.CONTACTS``) over the body ticks ``tick``."""
        ct = self._temporal(f"{p}{schema.CONTACTS}")
        if ct is None or "lambda_n" not in ct.column_names:
            return ContactFrames.empty(tick.size)
        ct = ct.filter(pc.is_valid(ct.column("lambda_n")))
        cn = _lengths(ct, "lambda_n")
        rows_tick = ct.column(schema.TICK).to_numpy()
        counts = np.zeros(tick.size, np.int64)  # contacts per body tick (a tick without a contact row has none)
        counts[np.searchsorted(tick, rows_tick)] = cn
        f = {
            name: _flat(ct, name)
            for name in ("body_a", "body_b", "feature", "lambda_n", "lambda_t", "separation", "warm_started")
        }
        a, b_, feat = (f[k].astype(np.int64) for k in ("body_a", "body_b", "feature"))
        origins = _points(ct, "Arrows2D:origins")
        vectors = _points(ct, "Arrows2D:vectors")
        return ContactFrames(
            offsets=np.concatenate([[0], np.cumsum(counts)]),
            tick=np.repeat(rows_tick, cn),
            key=schema.contact_key(a, b_, feat),
            body_a=a,
            body_b=b_,
            feature=feat,
            point=origins,
            normal=vectors / schema.NORMAL_LENGTH,
            separation=f["separation"].astype(np.float64),
            normal_impulse=f["lambda_n"].astype(np.float64),
            tangent_impulse=f["lambda_t"].astype(np.float64),
            warm_started=f["warm_started"].astype(np.bool_),
        )

    def _joint_anchors(self, p: str) -> list[np.ndarray]:
        """Each tick's joint anchors as drawn (entity ``p`` + ``schema.JOINTS``): (joints, 2, 2) m."""
        joints = self._temporal(f"{p}{schema.JOINTS}")
        if joints is None or "LineStrips2D:strips" not in joints.column_names:
            return []
        joints = joints.filter(pc.is_valid(joints.column("LineStrips2D:strips")))
        jl = _lengths(joints, "LineStrips2D:strips")
        pts = np.asarray(
            pc.list_flatten(pc.list_flatten(joints.column("LineStrips2D:strips"))).to_pylist(), dtype=np.float64
        ).reshape(-1, 2, 2)
        return np.split(pts, np.cumsum(jl)[:-1])


def _poses(
    tick: np.ndarray,
    dval: dict[str, np.ndarray],
    drow: np.ndarray,
    stat: tuple[np.ndarray, np.ndarray, dict[str, np.ndarray], np.ndarray] | None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(body_uid, x, theta, V): every body seen, in uid order, and its pose at each of ``tick`` (NaN
    where it did not exist), from the bodies' table (values ``dval``, each instance's row ``drow``)
    and the static bodies' (``stat``, None when there is none)."""
    T = tick.size
    # static bodies: written when they change; each tick takes the latest row at or before it
    uids = [dval["uid"]]
    if stat is not None:
        s_tick, n_st, sval, srow = stat
        which = np.searchsorted(s_tick, tick, side="right") - 1  # latest static row per tick (-1: none)
        s_start = np.concatenate([[0], np.cumsum(n_st)])
        take = [np.arange(s_start[k], s_start[k + 1]) if k >= 0 else np.zeros(0, np.int64) for k in which]
        s_idx = np.concatenate(take) if take else np.zeros(0, np.int64)
        s_rowtick = np.repeat(np.arange(T), [len(a) for a in take])
        uids.append(sval["uid"][s_idx])
    body_uid = np.unique(np.concatenate(uids))  # uid order is the world's order
    U = body_uid.size
    x, theta, V = np.full((T, U, 2), np.nan), np.full((T, U), np.nan), np.full((T, U, 3), np.nan)

    def fill(rows: np.ndarray, vals: dict[str, np.ndarray], idx) -> None:
        slot = np.searchsorted(body_uid, vals["uid"][idx])
        x[rows, slot, 0], x[rows, slot, 1] = vals["x"][idx], vals["y"][idx]
        theta[rows, slot] = vals["angle"][idx]
        V[rows, slot, 0], V[rows, slot, 1], V[rows, slot, 2] = vals["vx"][idx], vals["vy"][idx], vals["omega"][idx]

    fill(drow, dval, slice(None))
    if stat is not None:
        fill(s_rowtick, sval, s_idx)
    return body_uid, x, theta, V


def load(path: str | os.PathLike) -> Recording:
    """Read a phys2d recording (.rrd) back into arrays; see the module docstring.

    A file without a footer (a process that died hard) is read as far as it was written.
    """
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"path must be a str or os.PathLike, got {type(path).__name__}")
    p = os.fspath(path)
    if not os.path.isfile(p):
        raise FileNotFoundError(f"path {p!r}: no such recording file")
    try:
        with warnings.catch_warnings():  # a file without footer warns; it is handled below
            warnings.simplefilter("ignore")
            reader = RrdReader(p)
        try:
            store = reader.store()
            chunks = list(store.stream())
        except Exception:  # no footer: stream what was written
            store = None
            chunks = list(reader.stream())
    except Exception as e:
        raise RecordingError(f"path {p!r} is not a readable .rrd file: {e}") from e
    entities: dict[str, list] = {}
    properties: dict[str, dict] = {}
    for ch in chunks:
        ep = ch.entity_path
        if ep.startswith("/__properties/"):
            rb = ch.to_record_batch()
            # rerun escapes a property name's '/' and '.' (one path part); undo it
            d = properties.setdefault(ep[len("/__properties/") :].replace("\\", ""), {})
            for name in rb.schema.names:
                if name.startswith("rerun.") or name in ("tick", "sim_time"):
                    continue
                v = rb.column(name).to_pylist()[-1]
                d[name] = v[0] if isinstance(v, list) and len(v) == 1 else v
        elif not ch.is_static:
            entities.setdefault(ep, []).append(ch)
    return Recording(p, store, entities, properties)


__all__ = [
    "CheckResult",
    "ContactFrames",
    "Recording",
    "RecordingError",
    "ReplayError",
    "Run",
    "SERIES_FAMILIES",
    "SERIES_UNITS",
    "Timeline",
    "load",
    "timeline",
    "timelines",
    "world_at",
]
