"""A World's ticks to a Rerun recording (.rrd), cheaply.

    with phys2d.Recorder("recordings/pyramid.rrd", name="pyramid / pgs") as rec:
        for _ in range(600):
            w.step(1 / 60)
            rec.log(w)

``log`` only copies the world's arrays into numpy buffers (tens of microseconds).
Every ``flush_every`` ticks the buffered ticks go to the file as a few columnar
sends, one per entity; the per-contact series (one entity per contact identity)
go as one wide record batch every ``series_every`` ticks and at the end. Leaving
the ``with`` block, ``close()``, or losing the last reference writes what is
buffered and the file footer, so a run that raised part-way leaves a readable
recording of every tick logged before the failure.

Layout of a recording (``<run>`` is ``runs/<label>/`` when several runs share a
file, empty otherwise). Timelines: ``tick`` (sequence, ``w.tick``) and
``sim_time`` (duration, ``w.time`` in s); the residuals also carry ``solver_iter``,
the running count of solver sweeps, on which they read as one continuous curve.

    <run>world/sim/bodies        LineStrips2D: closed outlines of polygons (m, y-up),
                                 plus AnyValues uid, x, y, angle, vx, vy, omega (float64)
    <run>world/sim/circles       Ellipses2D outlines of circles
    <run>world/sim/spokes        LineStrips2D centre -> rim at the body angle (shows rotation)
    <run>world/sim/contacts      Points2D coloured warm / cold started, plus AnyValues
                                 key, separation (m), lambda_n, lambda_t (N s),
                                 point_x, point_y, normal_x, normal_y, warm_started
    <run>world/sim/normals       Arrows2D along the contact normals (0.25 m long)
    <run>world/sim/joints        LineStrips2D anchor to anchor, when the world has joints
    <run>contacts/lambda/b<a>-b<b>/f<feature>   Scalars [lambda_n, lambda_t] (N s), one series per
                                 contact identity (body uids a < b and the manifold's feature id)
    <run>contacts/penetration/b<a>-b<b>/f<feature>  -separation (m): > 0 while the shapes overlap
    <run>joints/reaction/j<k>/r<row>  joint row impulses (N s)
    <run>solver/residual         residual after each sweep (m/s); solver/log10_residual for the plot
    <run>stats/...               energy [kinetic, potential, total] (J), momentum [px, py]
                                 (kg m/s), angular_momentum (kg m^2/s), max_penetration (m),
                                 contact_count, cache_hit_rate, iterations

Once per run, as recording properties: the responder and its parameters, the
scene, dt and the engine version; and at the end a blueprint that opens the file
with the world view(s) beside the plots.
"""

from __future__ import annotations

import os
import uuid
import weakref
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pyarrow as pa
import rerun as rr
import rerun.blueprint as rrb

CLASS_BODY, CLASS_CIRCLE, CLASS_STATIC, CLASS_WARM, CLASS_COLD, CLASS_JOINT = 1, 2, 3, 4, 5, 6
ANNOTATIONS = [
    (CLASS_BODY, "body", (80, 140, 255)),
    (CLASS_CIRCLE, "circle", (255, 160, 40)),
    (CLASS_STATIC, "static", (150, 150, 150)),
    (CLASS_WARM, "warm-started contact", (40, 200, 90)),
    (CLASS_COLD, "new contact", (230, 40, 40)),
    (CLASS_JOINT, "joint", (200, 80, 220)),
]
NORMAL_LENGTH = 0.25  # m, drawn length of a contact normal

_UID_MASK = (1 << 23) - 1
_FEATURE_MASK = (1 << 16) - 1
# exactly rerun's LineStrip2D arrow type: the viewer skips a column whose nullability differs
_STRIP_TYPE = pa.list_(pa.field("item", pa.list_(pa.field("item", pa.float32(), nullable=False), 2), nullable=False))
_CIRCLE = 0  # phys2d.shapes.CIRCLE (not imported: recording only reads a World)


def contact_entity(key: int) -> str:
    """The entity name of a contact identity: ``b<uid_a>-b<uid_b>/f<feature>``."""
    key = int(key)
    return f"b{key >> 39}-b{(key >> 16) & _UID_MASK}/f{key & _FEATURE_MASK}"


class _Arrow:
    """The smallest rerun ComponentBatchLike: an arrow array we built ourselves."""

    def __init__(self, array: pa.Array) -> None:
        self._array = array

    def as_arrow_array(self) -> pa.Array:
        return self._array


def _checked_path(path: Any) -> str:
    """``path`` as a str, after making sure a recording can be written there."""
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"path must be a str or os.PathLike, got {type(path).__name__}")
    p = os.fspath(path)
    if not isinstance(p, str) or not p.endswith(".rrd"):
        raise ValueError(f"path must name an .rrd file, got {p!r}")
    if os.path.isdir(p):
        raise ValueError(f"path {p!r} is a directory, not an .rrd file")
    parent = os.path.dirname(os.path.abspath(p))
    try:
        os.makedirs(parent, exist_ok=True)
        with open(p, "wb"):
            pass
    except OSError as e:
        raise ValueError(f"path {p!r} is not writable: {e.strerror or e}") from e
    return p


def _check_count(value: Any, name: str) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{name} must be an integer, got {type(value).__name__}")
    if value < 1:
        raise ValueError(f"{name} must be >= 1, got {value}")
    return int(value)


def _check_label(run: Any) -> str:
    if not isinstance(run, str):
        raise TypeError(f"run must be a str, got {type(run).__name__}")
    if not run or not all(ch.isalnum() or ch in "-_." for ch in run):
        raise ValueError(f"run must be a non-empty name of letters, digits, '-', '_' or '.', got {run!r}")
    return run


@dataclass(eq=False)
class _Layout:
    """What stays the same while a world's set of bodies does not change."""

    uid: np.ndarray  # (N,) body uids
    poly: np.ndarray  # indices of polygon bodies
    circ: np.ndarray  # indices of circle bodies
    radius: np.ndarray  # (C,) circle radii, m
    loop_body: np.ndarray  # (L,) body index of each outline point (closed loops)
    loop_local: np.ndarray  # (L, 2) body-frame coordinates of each outline point, m
    loop_len: np.ndarray  # (P,) points per loop (vertices + 1)
    poly_class: np.ndarray  # (P,) class ids
    poly_labels: list[str]
    circ_class: np.ndarray  # (C,) class ids
    circ_labels: list[str]

    @classmethod
    def of(cls, w) -> _Layout:
        b = w._bodies
        uid = b.uid.copy()
        kind, static = b.kind, b.static
        poly = np.flatnonzero(kind != _CIRCLE)
        circ = np.flatnonzero(kind == _CIRCLE)
        vstart, vcount = b.vstart[poly].astype(np.int64), b.vcount[poly].astype(np.int64)
        loop_len = vcount + 1
        # vertex indices of each loop, the first vertex repeated at the end
        first = np.repeat(np.cumsum(loop_len) - loop_len, loop_len)
        k = np.arange(int(loop_len.sum())) - first  # position within the loop
        cnt = np.repeat(vcount, loop_len)
        vidx = np.repeat(vstart, loop_len) + np.where(k == cnt, 0, k)
        local_v = b.local_v
        return cls(
            uid=uid, poly=poly, circ=circ, radius=b.radius[circ].copy(),
            loop_body=np.repeat(poly, loop_len), loop_local=local_v[vidx].copy(), loop_len=loop_len,
            poly_class=np.where(static[poly], CLASS_STATIC, CLASS_BODY).astype(np.uint16),
            poly_labels=[f"b{u}" for u in uid[poly]],
            circ_class=np.where(static[circ], CLASS_STATIC, CLASS_CIRCLE).astype(np.uint16),
            circ_labels=[f"b{u}" for u in uid[circ]],
        )


@dataclass(eq=False)
class _Run:
    """Buffers of one run (one World) between two flushes."""

    label: str | None
    prefix: str
    layout: _Layout | None = None
    sent_layout: _Layout | None = None  # the body set whose labels were written last
    had_circles: bool = False
    bounds: tuple[float, float, float, float] | None = None  # xmin, xmax, ymin, ymax of dynamic bodies
    has_joints: bool = False
    sweeps: int = 0  # solver sweeps so far: the solver_iter timeline
    # scene buffers, one entry per logged tick
    ticks: list[int] = field(default_factory=list)
    times: list[float] = field(default_factory=list)
    layouts: list[_Layout] = field(default_factory=list)
    x: list[np.ndarray] = field(default_factory=list)
    theta: list[np.ndarray] = field(default_factory=list)
    V: list[np.ndarray] = field(default_factory=list)
    contacts: list[tuple[np.ndarray, ...]] = field(default_factory=list)
    stats: list[tuple[float, ...]] = field(default_factory=list)
    residuals: list[np.ndarray] = field(default_factory=list)
    joints: list[tuple[np.ndarray, list[np.ndarray]]] = field(default_factory=list)  # (J, 2, 2) ends, row impulses
    # per-contact / per-joint-row series, one entry per logged tick
    s_ticks: list[int] = field(default_factory=list)
    s_times: list[float] = field(default_factory=list)
    contact_series: _Series | None = None
    joint_series: _Series | None = None


def _joint_geometry(joint) -> tuple[np.ndarray, np.ndarray]:
    """(2, 2) world anchor points to draw a joint between, and its row impulses (N s)."""
    pts = np.asarray(joint.anchors(), dtype=np.float64).reshape(2, 2)
    return pts, np.atleast_1d(np.asarray(joint.impulse, dtype=np.float64)).ravel()


def _send_property(rec: rr.RecordingStream, entity: str, **values: Any) -> None:
    """Static run metadata at /__properties/<name>; empty values are left out (Rerun drops them)."""
    kept = {k: v for k, v in values.items() if v is not None and v != ""}
    rec.send_property(entity, rr.AnyValues(**kept))


def _joint_entity(key: int) -> str:
    return f"j{int(key) >> 16}/r{int(key) & _FEATURE_MASK}"


class _Series:
    """Time series per identity (a contact, a joint row), buffered for one wide record batch.

    ``families`` are (entity path, value indices): ``contacts/lambda`` holds values 0 and 1
    (lambda_n, lambda_t) of each contact, ``contacts/penetration`` value 2. A series that
    ends gets one NaN row, so the plot shows a gap rather than a line across it.
    """

    def __init__(self, families: list[tuple[str, tuple[int, ...]]], entity_of) -> None:
        self.families = families
        self.entity_of = entity_of
        self.rows: list[int] = []  # row (tick index within the batch) of each buffered tick
        self.keys: list[np.ndarray] = []
        self.values: list[tuple[np.ndarray, ...]] = []
        self.last = np.zeros(0, np.int64)  # keys present at the last tick already written

    def append(self, keys: np.ndarray, values: tuple[np.ndarray, ...], n_rows: int) -> None:
        self.rows.append(n_rows - 1)
        self.keys.append(keys)
        self.values.append(values)

    def columns(self, T: int, fields: list[pa.Field], arrays: list[pa.Array]) -> None:
        """Append one list<f64> column per (family, identity) to a wide batch of T rows."""
        if not self.keys:
            return
        lengths = np.fromiter((k.size for k in self.keys), dtype=np.int64, count=len(self.keys))
        row = np.repeat(np.asarray(self.rows, dtype=np.int64), lengths)
        keys = np.concatenate(self.keys)
        n_val = len(self.values[0])
        vals = [np.concatenate([v[q] for v in self.values]) for q in range(n_val)]
        new_last = self.keys[-1]
        first = self.rows[0]
        gone0 = np.setdiff1d(self.last, self.keys[0])  # series that ended exactly at this window's first tick
        self.rows, self.keys, self.values, self.last = [], [], [], new_last.copy()
        if keys.size == 0 and gone0.size == 0:
            return
        uniq, col = np.unique(np.concatenate([keys, gone0]), return_inverse=True)
        col, col0 = col[: keys.size], col[keys.size:]
        U = uniq.size
        present = np.zeros((U, T), dtype=np.bool_)
        present[col, row] = True
        dense = np.full((n_val, U, T), np.nan)
        for q in range(n_val):
            dense[q, col, row] = vals[q]
        ended = np.zeros((U, T), dtype=np.bool_)
        ended[:, first + 1:] = present[:, first:-1] & ~present[:, first + 1:]
        ended[col0, first] = True
        present |= ended  # the NaN row that ends a series
        offsets_1 = np.zeros((U, T + 1), dtype=np.int32)
        np.cumsum(present, axis=1, out=offsets_1[:, 1:])
        count = offsets_1[:, -1].astype(np.int64)
        start = np.concatenate([[0], np.cumsum(count)])
        bits = np.packbits(present, axis=1, bitorder="little")
        nulls = T - count
        names = [self.entity_of(k) for k in uniq]
        d = rr.Scalars.descriptor_scalars()
        meta = {b"rerun:component": d.component.encode(), b"rerun:archetype": d.archetype.encode(),
                b"rerun:component_type": d.component_type.encode()}
        list_type = pa.list_(pa.float64())
        for family, which in self.families:
            m = len(which)
            v = np.ascontiguousarray(np.stack([dense[q][present] for q in which], axis=1).reshape(-1))
            offsets = offsets_1 * np.int32(m)
            for j, name in enumerate(names):
                ent = f"/{family}/{name}"
                fields.append(pa.field(f"{ent}:{d.component}", list_type,
                                       metadata={b"rerun:entity_path": ent.encode(), **meta}))
                child = pa.Array.from_buffers(pa.float64(), int(count[j]) * m,
                                              [None, pa.py_buffer(v[m * start[j]: m * start[j + 1]])])
                arrays.append(pa.Array.from_buffers(list_type, T, [pa.py_buffer(bits[j]), pa.py_buffer(offsets[j])],
                                                    null_count=int(nulls[j]), children=[child]))


class _Sink:
    """The stream and the runs' buffers; closed once, by ``Recorder.close`` or a finalizer."""

    def __init__(self, path: str, name: str | None, scene: str | None, application_id: str,
                 recording_id: str | None, contact_series: bool, flush_every: int,
                 series_every: int, blueprint: bool) -> None:
        self.path = path
        self.scene = scene
        self.contact_series = contact_series
        self.flush_every = flush_every
        self.series_every = series_every
        self.blueprint = blueprint
        self.runs: dict[str | None, _Run] = {}
        self.closed = False
        self.rec = rr.RecordingStream(application_id, recording_id=recording_id or str(uuid.uuid4()))
        self.rec.save(path)
        self.rec.set_log_time_enabled(False)  # deterministic files: no wall-clock timeline
        if name:
            self.rec.send_recording_name(name)
        from .. import __version__

        _send_property(self.rec, "phys2d", engine_version=__version__, scene=scene, name=name)

    # -- per tick ---------------------------------------------------------------
    def run(self, label: str | None) -> _Run:
        r = self.runs.get(label)
        if r is None:
            if label is None and self.runs:
                raise ValueError("this recorder holds named runs: pass run=<label> to every log()")
            if label is not None and None in self.runs:
                raise ValueError("this recorder holds an unnamed run: log() without run= only")
            r = _Run(label, "" if label is None else f"runs/{label}/")
            self.runs[label] = r
            self._start_run(r)
        return r

    def _start_run(self, r: _Run) -> None:
        rec, p = self.rec, r.prefix
        rec.log(f"{p}world", rr.AnnotationContext(ANNOTATIONS), static=True)
        # physics is y-up, a 2D view is y-down: flip once under the view origin
        rec.log(f"{p}world/sim", rr.Transform3D(scale=[1.0, -1.0, 1.0]), static=True)
        rec.log(f"{p}world/sim/bodies", rr.LineStrips2D.from_fields(radii=0.02), static=True)
        rec.log(f"{p}world/sim/spokes", rr.LineStrips2D.from_fields(radii=0.02, show_labels=False),
                static=True)
        rec.log(f"{p}world/sim/circles", rr.Ellipses2D.from_fields(line_radii=0.02, show_labels=False),
                static=True)
        rec.log(f"{p}world/sim/contacts", rr.Points2D.from_fields(radii=0.05, show_labels=False), static=True)
        rec.log(f"{p}world/sim/normals", rr.Arrows2D.from_fields(radii=0.015, show_labels=False), static=True)
        tag = f" ({r.label})" if r.label else ""  # runs overlaid in one plot keep their names apart
        rec.log(f"{p}stats/energy", rr.SeriesLines(names=[f"kinetic{tag}", f"potential{tag}", f"total{tag}"]),
                static=True)
        rec.log(f"{p}stats/momentum", rr.SeriesLines(names=[f"px{tag}", f"py{tag}"]), static=True)
        rec.log(f"{p}solver/log10_residual", rr.SeriesPoints(markers="circle", marker_sizes=2.0), static=True)
        rec.log(f"{p}solver/residual", rr.SeriesPoints(markers="circle", marker_sizes=2.0), static=True)

    def log(self, w, label: str | None) -> None:
        r = self.run(label)
        b = w._bodies
        tick = int(w.tick)
        if r.layout is None:
            self._describe(r, w)
        if r.layout is None or r.layout.uid.shape != b.uid.shape or not np.array_equal(r.layout.uid, b.uid):
            r.layout = _Layout.of(w)
        if r.bounds is None:
            dyn = ~b.static
            pts = b.x[dyn] if dyn.any() else b.x
            if pts.shape[0]:
                pad = 1.0 + 0.1 * float(np.ptp(pts, axis=0).max())
                lo, hi = pts.min(axis=0) - pad, pts.max(axis=0) + pad
                r.bounds = (float(lo[0]), float(hi[0]), min(float(lo[1]), -0.5), float(hi[1]))
        r.ticks.append(tick)
        r.times.append(float(w.time))
        r.layouts.append(r.layout)
        r.x.append(b.x.copy())
        r.theta.append(b.theta.copy())
        r.V.append(b.V.copy())
        c = w.contacts
        sep = np.array(c.separation, dtype=np.float64)
        r.contacts.append((np.array(c.key, dtype=np.int64), np.array(c.point, dtype=np.float64),
                           np.array(c.normal, dtype=np.float64), sep,
                           np.array(c.normal_impulse, dtype=np.float64),
                           np.array(c.tangent_impulse, dtype=np.float64),
                           np.array(c.warm_started, dtype=np.bool_)))
        s = w.last_step
        ke, pe = w.kinetic_energy(), w.potential_energy()
        p = w.linear_momentum()
        r.stats.append((ke, pe, ke + pe, float(p[0]), float(p[1]), w.angular_momentum(),
                        float(s.max_penetration), float(len(c)), float(s.cache_hit_rate),
                        float(s.iterations)))
        r.residuals.append(np.array(s.residuals, dtype=np.float64))
        joints = getattr(w, "joints", ())
        r.has_joints = r.has_joints or bool(joints)
        geo = [_joint_geometry(j) for j in joints]
        if r.has_joints:
            r.joints.append((np.stack([g[0] for g in geo]) if geo else np.zeros((0, 2, 2)), [g[1] for g in geo]))
        if self.contact_series or r.has_joints:
            r.s_ticks.append(tick)
            r.s_times.append(float(w.time))
        if self.contact_series:
            if r.contact_series is None:
                r.contact_series = _Series([(f"{r.prefix}contacts/lambda", (0, 1)),
                                            (f"{r.prefix}contacts/penetration", (2,))], contact_entity)
            ct = r.contacts[-1]
            r.contact_series.append(ct[0], (ct[4], ct[5], -sep), len(r.s_ticks))
        if r.has_joints:
            if r.joint_series is None:
                r.joint_series = _Series([(f"{r.prefix}joints/reaction", (0,))], _joint_entity)
            keys = [np.arange(len(imp), dtype=np.int64) + (k << 16) for k, (_, imp) in enumerate(geo)]
            r.joint_series.append(np.concatenate(keys) if keys else np.zeros(0, np.int64),
                                  (np.concatenate([imp for _, imp in geo]) if geo else np.zeros(0),),
                                  len(r.s_ticks))
        if len(r.ticks) >= self.flush_every:
            self._flush_scene(r)
        if len(r.s_ticks) >= self.series_every:
            self._flush_series(r)

    def _describe(self, r: _Run, w) -> None:
        name = "run" if r.label is None else f"runs/{r.label}"
        _send_property(self.rec, name, responder=repr(w.responder),
                       responder_name=str(getattr(w.responder, "name", "")), scene=self.scene, run=r.label,
                       bodies=len(w), first_tick=int(w.tick))

    # -- writing --------------------------------------------------------------
    def _flush_scene(self, r: _Run) -> None:
        if not r.ticks:
            return
        rec, p = self.rec, r.prefix
        ticks = np.asarray(r.ticks, dtype=np.int64)
        times = np.asarray(r.times, dtype=np.float64)

        def idx(sel=slice(None)):
            return [rr.TimeColumn("tick", sequence=ticks[sel]), rr.TimeColumn("sim_time", duration=times[sel])]

        # split the window where the set of bodies changed
        starts = [0] + [i for i in range(1, len(r.layouts)) if r.layouts[i] is not r.layouts[i - 1]]
        for s0, s1 in zip(starts, starts[1:] + [len(r.layouts)], strict=True):
            self._send_bodies(r, r.layouts[s0], slice(s0, s1), ticks, times)
        # contacts: one row per tick, one instance per contact point
        cs = r.contacts
        lengths = np.fromiter((len(c[0]) for c in cs), dtype=np.int64, count=len(cs))
        key, point, normal, sep, ln, lt, warm = (np.concatenate([c[k] for c in cs]) for k in range(7))
        cls = np.where(warm, CLASS_WARM, CLASS_COLD).astype(np.uint16)
        rec.send_columns(f"{p}world/sim/contacts", indexes=idx(), columns=[
            *rr.Points2D.columns(positions=point.reshape(-1, 2), class_ids=cls).partition(lengths),
            *rr.AnyValues.columns(
                key=pa.array(key), separation=pa.array(sep), lambda_n=pa.array(ln), lambda_t=pa.array(lt),
                point_x=pa.array(point[:, 0]), point_y=pa.array(point[:, 1]),
                normal_x=pa.array(normal[:, 0]), normal_y=pa.array(normal[:, 1]),
                warm_started=pa.array(warm)).partition(lengths)])
        rec.send_columns(f"{p}world/sim/normals", indexes=idx(), columns=rr.Arrows2D.columns(
            origins=point.reshape(-1, 2), vectors=(normal * NORMAL_LENGTH).reshape(-1, 2),
            class_ids=cls).partition(lengths))
        # joints
        if r.joints:
            seg = np.concatenate([j[0] for j in r.joints]).reshape(-1, 2, 2)
            jl = np.fromiter((len(j[0]) for j in r.joints), dtype=np.int64, count=len(r.joints))
            jt = ticks[len(ticks) - len(r.joints):]
            jtimes = times[len(times) - len(r.joints):]
            rec.send_columns(f"{p}world/sim/joints",
                             indexes=[rr.TimeColumn("tick", sequence=jt), rr.TimeColumn("sim_time", duration=jtimes)],
                             columns=[*rr.LineStrips2D.columns(
                                 strips=seg, class_ids=np.full(len(seg), CLASS_JOINT, np.uint16)).partition(jl)])
        # aggregates
        st = np.asarray(r.stats, dtype=np.float64)
        for name, cols in (("energy", st[:, 0:3]), ("momentum", st[:, 3:5]), ("angular_momentum", st[:, 5]),
                           ("max_penetration", st[:, 6]), ("contact_count", st[:, 7]),
                           ("cache_hit_rate", st[:, 8]), ("iterations", st[:, 9])):
            rec.send_columns(f"{p}stats/{name}", indexes=idx(), columns=rr.Scalars.columns(scalars=cols))
        # residual of every sweep, on tick and on the running sweep count
        n_it = np.fromiter((len(a) for a in r.residuals), dtype=np.int64, count=len(r.residuals))
        if n_it.sum():
            res = np.concatenate(r.residuals)
            rt = np.repeat(ticks, n_it)
            sweep = r.sweeps + np.arange(res.size, dtype=np.int64)
            r.sweeps += int(res.size)
            rindex = [rr.TimeColumn("tick", sequence=rt), rr.TimeColumn("sim_time", duration=np.repeat(times, n_it)),
                      rr.TimeColumn("solver_iter", sequence=sweep)]
            rec.send_columns(f"{p}solver/residual", indexes=rindex, columns=rr.Scalars.columns(scalars=res))
            rec.send_columns(f"{p}solver/log10_residual", indexes=rindex,
                             columns=rr.Scalars.columns(scalars=np.log10(np.maximum(res, 1e-12))))
        for buf in (r.ticks, r.times, r.layouts, r.x, r.theta, r.V, r.contacts, r.stats, r.residuals, r.joints):
            buf.clear()
        rec.flush(timeout_sec=0)  # start writing this window now (not waited for): a hard kill loses less

    def _send_bodies(self, r: _Run, lay: _Layout, sel: slice, ticks: np.ndarray, times: np.ndarray) -> None:
        rec, p = self.rec, r.prefix
        X = np.stack(r.x[sel])  # (S, N, 2)
        TH = np.stack(r.theta[sel])  # (S, N)
        VV = np.stack(r.V[sel])  # (S, N, 3)
        S, N = TH.shape
        t, tm = ticks[sel], times[sel]
        index = [rr.TimeColumn("tick", sequence=t), rr.TimeColumn("sim_time", duration=tm)]
        if lay is not r.sent_layout:  # labels and classes once per body set: latest-at carries them on
            one = [rr.TimeColumn("tick", sequence=t[:1]), rr.TimeColumn("sim_time", duration=tm[:1])]
            rec.send_columns(f"{p}world/sim/bodies", indexes=one, columns=rr.LineStrips2D.columns(
                class_ids=lay.poly_class, labels=lay.poly_labels).partition([len(lay.poly)]))
            rec.send_columns(f"{p}world/sim/spokes", indexes=one, columns=rr.LineStrips2D.columns(
                class_ids=lay.circ_class, labels=lay.circ_labels).partition([len(lay.circ)]))
            rec.send_columns(f"{p}world/sim/circles", indexes=one, columns=rr.Ellipses2D.columns(
                class_ids=lay.circ_class).partition([len(lay.circ)]))
            r.sent_layout = lay
        # polygon outlines, all ticks at once: x_b + R(theta_b) v_local
        th = TH[:, lay.loop_body]
        c, s = np.cos(th), np.sin(th)
        lx, ly = lay.loop_local[:, 0], lay.loop_local[:, 1]
        pts = np.empty((S, lay.loop_body.size, 2), dtype=np.float32)
        pts[..., 0] = X[:, lay.loop_body, 0] + c * lx - s * ly
        pts[..., 1] = X[:, lay.loop_body, 1] + s * lx + c * ly
        inner_off = np.zeros(S * lay.loop_len.size + 1, dtype=np.int32)
        np.cumsum(np.tile(lay.loop_len, S), out=inner_off[1:])
        points = pa.FixedSizeListArray.from_arrays(pa.array(pts.reshape(-1)), type=_STRIP_TYPE.value_type)
        strips = pa.ListArray.from_arrays(pa.array(inner_off), points, type=_STRIP_TYPE)
        uid = np.broadcast_to(lay.uid, (S, N)).reshape(-1)
        rec.send_columns(f"{p}world/sim/bodies", indexes=index, columns=[
            rr.ComponentColumn(rr.LineStrips2D.descriptor_strips(), _Arrow(strips),
                               lengths=np.full(S, lay.loop_len.size)),
            *rr.AnyValues.columns(uid=pa.array(uid), x=pa.array(X[..., 0].reshape(-1)),
                                  y=pa.array(X[..., 1].reshape(-1)), angle=pa.array(TH.reshape(-1)),
                                  vx=pa.array(VV[..., 0].reshape(-1)), vy=pa.array(VV[..., 1].reshape(-1)),
                                  omega=pa.array(VV[..., 2].reshape(-1))).partition(np.full(S, N))])
        C = lay.circ.size
        if C:
            cx = X[:, lay.circ].reshape(-1, 2)
            ca = TH[:, lay.circ].reshape(-1)
            cr = np.tile(lay.radius, S)
            rec.send_columns(f"{p}world/sim/circles", indexes=index, columns=rr.Ellipses2D.columns(
                centers=cx, half_sizes=np.stack([cr, cr], axis=1)).partition(np.full(S, C)))
            rim = cx + cr[:, None] * np.stack([np.cos(ca), np.sin(ca)], axis=1)
            rec.send_columns(f"{p}world/sim/spokes", indexes=index, columns=rr.LineStrips2D.columns(
                strips=np.stack([cx, rim], axis=1)).partition(np.full(S, C)))
        if C:
            r.had_circles = True
        elif r.had_circles:  # circles were removed: an empty row, or the last ones linger
            empty = np.zeros(S, dtype=np.int64)
            rec.send_columns(f"{p}world/sim/circles", indexes=index, columns=rr.Ellipses2D.columns(
                centers=np.zeros((0, 2)), half_sizes=np.zeros((0, 2))).partition(empty))
            rec.send_columns(f"{p}world/sim/spokes", indexes=index, columns=rr.LineStrips2D.columns(
                strips=np.zeros((0, 2, 2))).partition(empty))

    def _flush_series(self, r: _Run) -> None:
        if not r.s_ticks:
            return
        ticks = np.asarray(r.s_ticks, dtype=np.int64)
        times = np.asarray(r.s_times, dtype=np.float64)
        fields = [pa.field("tick", pa.int64()), pa.field("sim_time", pa.duration("ns"))]
        arrays: list[pa.Array] = [pa.array(ticks), pa.array(np.round(times * 1e9).astype("timedelta64[ns]"))]
        for series in (r.contact_series, r.joint_series):
            if series is not None:
                series.columns(len(ticks), fields, arrays)
        if len(arrays) > 2:
            rr.send_record_batch(pa.RecordBatch.from_arrays(arrays, schema=pa.schema(fields)),
                                 recording=self.rec, index=["tick", "sim_time"])
        r.s_ticks.clear()
        r.s_times.clear()

    def blueprint_of(self) -> rrb.Blueprint:
        runs = list(self.runs.values())
        if not runs:
            return rrb.Blueprint(rrb.TimePanel(timeline="tick"))

        def world_view(r: _Run) -> rrb.Spatial2DView:
            kw = {}
            if r.bounds is not None:
                x0, x1, y0, y1 = r.bounds
                kw["visual_bounds"] = rrb.VisualBounds2D(x_range=[x0, x1], y_range=[-y1, -y0])  # y is flipped
            return rrb.Spatial2DView(name=f"world {r.label}" if r.label else "world",
                                     origin=f"{r.prefix}world", **kw)

        def plots(title: str, tail: str, legend: bool = True) -> rrb.TimeSeriesView:
            contents = [f"+ /{r.prefix}{tail}" for r in runs]
            kw = {} if legend else {"plot_legend": rrb.PlotLegend(visible=False)}
            return rrb.TimeSeriesView(name=title, origin="/", contents=contents, **kw)

        many = len(runs) > 1
        worlds = [world_view(r) for r in runs]
        world_block = worlds[0] if not many else rrb.Grid(*worlds)
        graphs = rrb.Vertical(
            plots("max penetration (m)" if many else "penetration per contact (m)",
                  "stats/max_penetration" if many else "contacts/penetration/**", legend=many),
            plots("lambda per contact: normal, tangent (N s)", "contacts/lambda/**", legend=False),
            plots("solver residual, log10 (m/s)", "solver/log10_residual", legend=many),
            plots("energy (J)", "stats/energy/**" if not many else "stats/energy", legend=True),
        )
        return rrb.Blueprint(
            rrb.Horizontal(world_block, graphs, column_shares=[3, 2]),
            rrb.BlueprintPanel(state="collapsed"),
            rrb.SelectionPanel(state="collapsed"),
            rrb.TimePanel(state="expanded", timeline="tick"),
        )

    def close(self) -> None:
        if self.closed:
            return
        self.closed = True
        try:
            for r in self.runs.values():
                self._flush_scene(r)
                self._flush_series(r)
            if self.blueprint:
                self.rec.send_blueprint(self.blueprint_of())
            self.rec.flush()
        finally:
            self.rec.disconnect()  # writes the footer: the file is complete and readable


class Recorder:
    """Records a World's ticks to a Rerun ``.rrd`` file.

    path          where to write (parent folders are created); checked for writability
                  at once, so a bad path fails before any stepping
    name          the recording's name in the viewer, e.g. ``"pyramid / pgs"``
    scene         the scene's name, stored with the run
    contact_series  also write one time series per contact identity (lambda_n, lambda_t,
                  penetration); the contact table on ``world/sim/contacts`` is always written
    flush_every   ticks buffered before the scene is written (a hard crash loses at most these)
    series_every  ticks buffered before the per-contact series are written
    blueprint     store a layout (world beside the plots) in the file

    Call ``log(w)`` after each ``w.step``; for comparisons log several worlds into one
    file with ``log(w, run="pgs")`` (each run under ``runs/<run>/``, same timelines).
    Use as a context manager, or call ``close()``.
    """

    def __init__(self, path: str | os.PathLike, *, name: str | None = None, scene: str | None = None,
                 application_id: str = "phys2d", recording_id: str | None = None,
                 contact_series: bool = True, flush_every: int = 60, series_every: int = 1200,
                 blueprint: bool = True) -> None:
        p = _checked_path(path)
        for value, arg in ((name, "name"), (scene, "scene"), (recording_id, "recording_id")):
            if value is not None and not isinstance(value, str):
                raise TypeError(f"{arg} must be a str or None, got {type(value).__name__}")
        if not isinstance(application_id, str) or not application_id:
            raise TypeError(f"application_id must be a non-empty str, got {application_id!r}")
        for value, arg in ((contact_series, "contact_series"), (blueprint, "blueprint")):
            if not isinstance(value, (bool, np.bool_)):
                raise TypeError(f"{arg} must be True or False, got {value!r}")
        flush_every = _check_count(flush_every, "flush_every")
        series_every = _check_count(series_every, "series_every")
        self.path = p
        self._sink = _Sink(p, name, scene, application_id, recording_id, bool(contact_series), flush_every,
                           series_every, bool(blueprint))
        self._finalizer = weakref.finalize(self, _Sink.close, self._sink)

    def log(self, world, *, run: str | None = None) -> None:
        """Buffer the world's current state as tick ``world.tick`` (of run ``run``)."""
        if self._sink.closed:
            raise ValueError(f"this recorder is closed ({self.path})")
        if not hasattr(world, "_bodies") or not hasattr(world, "last_step"):
            raise TypeError(f"world must be a phys2d World, got {type(world).__name__}")
        self._sink.log(world, None if run is None else _check_label(run))

    @property
    def runs(self) -> list[str | None]:
        """The run labels logged so far (``[None]`` for a single unnamed run)."""
        return list(self._sink.runs)

    @property
    def closed(self) -> bool:
        return self._sink.closed

    def close(self) -> None:
        """Write what is buffered, the blueprint and the file footer; idempotent."""
        self._finalizer()

    def __enter__(self) -> Recorder:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __repr__(self) -> str:
        state = "closed" if self.closed else "open"
        return f"<Recorder {self.path!r} ({state}), runs={self.runs}>"

