"""A phys2d recording read back into numpy arrays, with rerun's own reader.

    rec = phys2d.playback.load("recordings/pyramid.rrd")
    rec.tick, rec.x, rec.theta           # (T,), (T, U, 2), (T, U): poses per tick
    rec.contacts.at(-1)["normal_impulse"]  # the last tick's lambda_n, N s
    rec.residuals_at(rec.tick[-1])       # the solver's residual after each sweep, m/s
    rec.kinetic_energy                   # (T,) J
    ticks, lam = rec.series("lambda", key)   # one contact's [lambda_n, lambda_t] over time

A file with several runs (``phys2d compare``) gives ``rec.runs["pgs"]`` and so on;
a file with one run forwards attribute access to it. Every array holds exactly the
float64 values the engine had; ``time`` comes from the ``sim_time`` timeline, which
Rerun stores in whole nanoseconds.
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

from .recorder import contact_entity

SERIES_FAMILIES = {"lambda": "contacts/lambda", "penetration": "contacts/penetration",
                   "reaction": "joints/reaction"}


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
    t = pa.Table.from_batches([
        pa.RecordBatch.from_arrays([b.column(n) if n in b.schema.names else pa.nulls(b.num_rows, types[n])
                                    for n in names], names=names) for b in batches])
    return t.take(pc.sort_indices(t, sort_keys=[(timeline, "ascending"), ("rerun.controls.RowId", "ascending")]))


def _flat(t: pa.Table, name: str) -> np.ndarray:
    """A list<...> column flattened to numpy (one entry per instance, rows in order)."""
    col = t.column(name).combine_chunks()
    return pc.list_flatten(col).to_numpy(zero_copy_only=False)


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

    key (M,) int64 identities (``phys2d.recording.contact_entity(key)`` names them),
    point, normal (M, 2), separation (M,) m, normal_impulse, tangent_impulse (M,) N s,
    warm_started (M,) bool; tick (M,) the tick of each row.
    """

    offsets: np.ndarray
    tick: np.ndarray
    key: np.ndarray
    point: np.ndarray
    normal: np.ndarray
    separation: np.ndarray
    normal_impulse: np.ndarray
    tangent_impulse: np.ndarray
    warm_started: np.ndarray

    _FIELDS = ("key", "point", "normal", "separation", "normal_impulse", "tangent_impulse", "warm_started")

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

    tick (T,) and time (T,) s; body_uid (U,) every body seen, in first-seen order;
    x (T, U, 2) m, theta (T, U) rad, V (T, U, 3) [vx, vy, omega] (NaN where a body did
    not exist at that tick); contacts: ContactFrames; residual_tick, residual (R,) the
    residual (m/s) after every solver sweep; per tick: kinetic_energy, potential_energy
    (J), linear_momentum (T, 2) kg m/s, angular_momentum kg m^2/s, max_penetration m,
    contact_count, cache_hit_rate, iterations; properties: what the run was (responder,
    scene, ...).
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
        return f"runs/{self.label}/" if self.label else ""

    def residuals_at(self, tick: int) -> np.ndarray:
        """The residual (m/s) after each solver sweep of ``tick`` (a tick number, as in ``self.tick``)."""
        return self.residual[self.residual_tick == tick]

    def series_keys(self, quantity: str = "lambda") -> list[str]:
        """Entity names (``b<a>-b<b>/f<feature>``, ``j<k>/r<row>``) with a series of ``quantity``."""
        family = self._family(quantity)
        assert self._recording is not None
        return self._recording._series_names(f"/{self.prefix}{family}/")

    def series(self, quantity: str, key: int | str) -> tuple[np.ndarray, np.ndarray]:
        """(ticks, values) of one contact's (or joint row's) series; a NaN row marks where it ended.

        quantity  'lambda' (values (n, 2): lambda_n, lambda_t in N s), 'penetration' ((n,), m)
                  or 'reaction' (joint rows, (n,) N s)
        key       a contact key from ``contacts.key`` or an entity name from ``series_keys``
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
        ticks = valid.column("tick").to_numpy()
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
        labels = sorted({e.split("/")[2] for e in entities if e.startswith("/runs/")})
        if "/world/sim/bodies" in entities:
            labels.insert(0, "")
        if not labels:
            raise RecordingError(f"{path!r} holds no phys2d run (no world/sim/bodies entity)")
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
        return sorted(e[len(prefix):] for e in self._entities if e.startswith(prefix))

    def _run(self, label: str) -> Run:
        p = f"/runs/{label}/" if label else "/"
        bodies = self._temporal(f"{p}world/sim/bodies")
        if bodies is None:
            raise RecordingError(f"{self.path!r}: run {label!r} has no bodies")
        bodies = bodies.filter(pc.is_valid(bodies.column("x")))  # rows that carry poses, not only labels
        tick = bodies.column("tick").to_numpy().astype(np.int64)
        time = bodies.column("sim_time").cast(pa.int64()).to_numpy() / 1e9
        n = _lengths(bodies, "uid")
        uid = _flat(bodies, "uid").astype(np.int64)
        body_uid, first = np.unique(uid, return_index=True)
        body_uid = body_uid[np.argsort(first)]  # first-seen order
        slot = np.empty(uid.size, np.int64)
        order = np.argsort(body_uid)
        slot = order[np.searchsorted(body_uid[order], uid)]
        row = np.repeat(np.arange(tick.size), n)
        T, U = tick.size, body_uid.size

        def grid(*names: str) -> np.ndarray:
            out = np.full((T, U, len(names)), np.nan)
            for k, name in enumerate(names):
                out[row, slot, k] = _flat(bodies, name)
            return out

        x, theta, V = grid("x", "y"), grid("angle")[..., 0], grid("vx", "vy", "omega")

        ct = self._temporal(f"{p}world/sim/contacts")
        if ct is not None:
            ct = ct.filter(pc.is_valid(ct.column("key")))
            cn = _lengths(ct, "key")
            c_tick = np.repeat(ct.column("tick").to_numpy(), cn)

            def f(name: str) -> np.ndarray:
                return _flat(ct, name)

            contacts = ContactFrames(
                offsets=np.concatenate([[0], np.cumsum(cn)]), tick=c_tick, key=f("key").astype(np.int64),
                point=np.stack([f("point_x"), f("point_y")], axis=1),
                normal=np.stack([f("normal_x"), f("normal_y")], axis=1), separation=f("separation"),
                normal_impulse=f("lambda_n"), tangent_impulse=f("lambda_t"),
                warm_started=f("warm_started").astype(np.bool_))
        else:
            z = np.zeros(0)
            contacts = ContactFrames(np.zeros(1, np.int64), z.astype(np.int64), z.astype(np.int64),
                                     np.zeros((0, 2)), np.zeros((0, 2)), z, z.copy(), z.copy(), z.astype(np.bool_))

        res = self._temporal(f"{p}solver/residual")
        stats = {name: self._temporal(f"{p}stats/{name}") for name in (
            "energy", "momentum", "angular_momentum", "max_penetration", "contact_count", "cache_hit_rate",
            "iterations")}
        energy = _scalars(stats["energy"], 3)
        joints = self._temporal(f"{p}world/sim/joints")
        anchors: list[np.ndarray] = []
        if joints is not None:
            jl = _lengths(joints, "LineStrips2D:strips")
            pts = np.asarray(pc.list_flatten(pc.list_flatten(joints.column("LineStrips2D:strips"))).to_pylist(),
                             dtype=np.float64).reshape(-1, 2, 2)
            anchors = np.split(pts, np.cumsum(jl)[:-1])
        props = self.properties.get(f"runs/{label}" if label else "run", {})
        return Run(
            label=label, properties={**self.properties.get("phys2d", {}), **props}, tick=tick, time=time,
            body_uid=body_uid, x=x, theta=theta, V=V, contacts=contacts,
            residual_tick=res.column("tick").to_numpy().astype(np.int64) if res is not None else np.zeros(0, np.int64),
            residual=_scalars(res), kinetic_energy=energy[:, 0] if energy.size else np.zeros(0),
            potential_energy=energy[:, 1] if energy.size else np.zeros(0),
            linear_momentum=_scalars(stats["momentum"], 2), angular_momentum=_scalars(stats["angular_momentum"]),
            max_penetration=_scalars(stats["max_penetration"]),
            contact_count=_scalars(stats["contact_count"]).astype(np.int64),
            cache_hit_rate=_scalars(stats["cache_hit_rate"]),
            iterations=_scalars(stats["iterations"]).astype(np.int64), joint_anchors=anchors, _recording=self)


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
            d = properties.setdefault(ep[len("/__properties/"):].replace("\\", ""), {})
            for name in rb.schema.names:
                if name.startswith("rerun.") or name in ("tick", "sim_time"):
                    continue
                v = rb.column(name).to_pylist()[-1]
                d[name] = v[0] if isinstance(v, list) and len(v) == 1 else v
        elif not ch.is_static:
            entities.setdefault(ep, []).append(ch)
    return Recording(p, store, entities, properties)


__all__ = ["ContactFrames", "Recording", "RecordingError", "Run", "SERIES_FAMILIES", "load"]
