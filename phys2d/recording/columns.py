"""Writing columns: a run's buffered ticks to Rerun, a few columnar sends per entity and window.

Every function here takes a ``RecordingStream`` and a ``RunBuffer`` and writes
what ``schema`` names; none of them looks at a World.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pyarrow as pa
import rerun as rr

from . import schema
from .buffer import RunBuffer, SeriesWindow, member
from .sample import Sample, Strips, aggregates, on_grid

# exactly rerun's LineStrip2D arrow type: the viewer skips a column whose nullability differs
_STRIP_TYPE = pa.list_(pa.field("item", pa.list_(pa.field("item", pa.float32(), nullable=False), 2), nullable=False))


class _Arrow:
    """The smallest rerun ComponentBatchLike: an arrow array built here."""

    def __init__(self, array: pa.Array) -> None:
        self._array = array

    def as_arrow_array(self) -> pa.Array:
        return self._array


def _index(ticks: np.ndarray, times: np.ndarray) -> list[rr.TimeColumn]:
    return [rr.TimeColumn(schema.TICK, sequence=ticks), rr.TimeColumn(schema.SIM_TIME, duration=times)]


def _strips_column(points: np.ndarray, lengths: np.ndarray) -> rr.ComponentColumn:
    """LineStrips2D:strips for S ticks: points (S, P, 2) float32, ``lengths`` points per strip."""
    S = points.shape[0]
    inner = np.zeros(S * lengths.size + 1, dtype=np.int32)
    np.cumsum(np.tile(lengths, S), out=inner[1:])
    pts = pa.FixedSizeListArray.from_arrays(pa.array(points.reshape(-1)), type=_STRIP_TYPE.value_type)
    strips = pa.ListArray.from_arrays(pa.array(inner), pts, type=_STRIP_TYPE)
    return rr.ComponentColumn(rr.LineStrips2D.descriptor_strips(), _Arrow(strips), lengths=np.full(S, lengths.size))


def _table(fields: tuple[schema.Field, ...], values: dict[str, np.ndarray], lengths: np.ndarray) -> list:
    """AnyValues columns named by ``fields``, cast to their dtypes, partitioned by ``lengths``."""
    cols = {f.name: pa.array(np.ascontiguousarray(values[f.name], dtype=f.dtype)) for f in fields}
    return list(rr.AnyValues.columns(**cols).partition(lengths))


def write_start(rec: rr.RecordingStream, b: RunBuffer, colour: tuple[int, int, int]) -> None:
    """What a run logs once: class colours, the y-flip, drawing styles, and its plots' legend
    names and colours (a named run's plots carry its label and ``colour``, so runs overlaid in
    one plot stay apart)."""
    p = b.prefix
    rec.log(f"{p}{schema.WORLD}", rr.AnnotationContext(list(schema.ANNOTATIONS)), static=True)
    rec.log(f"{p}{schema.SIM}", rr.Transform3D(scale=[1.0, -1.0, 1.0]), static=True)  # physics is y-up
    for path in (schema.BODIES, schema.STATIC, schema.JOINTS):
        rec.log(f"{p}{path}", rr.LineStrips2D.from_fields(radii=schema.LINE_RADIUS, show_labels=False), static=True)
    rec.log(f"{p}{schema.CONTACTS}", rr.Arrows2D.from_fields(radii=schema.ARROW_RADIUS, show_labels=False),
            static=True)
    for st in schema.STATS:
        if b.label:
            names, colours = [f"{b.label} {st.label}"], [colour]
        else:
            names, colours = [st.label], [schema.ENERGY_COLOURS.get(st.name.split("/")[-1], colour)]
        # potential and total energy dwarf the kinetic: listed in the legend, shown when clicked there
        shown = st.name not in schema.ENERGY_HIDDEN
        rec.log(f"{p}{schema.STATS_ROOT}/{st.name}", rr.SeriesLines(names=names, colors=colours, widths=[1.5],
                                                                     visible_series=[shown]), static=True)
    name = f"{b.label} log10 residual" if b.label else "log10 residual"
    rec.log(f"{p}{schema.RESIDUAL}", rr.SeriesLines(names=[name], colors=[colour], widths=[1.5]), static=True)


# -- the scene ----------------------------------------------------------------------------------
def write_scene(rec: rr.RecordingStream, b: RunBuffer) -> None:
    """Bodies, static bodies, contacts, joints, stats and residuals of the buffered ticks."""
    ss = b.samples
    if not ss:
        return
    ticks = np.fromiter((s.tick for s in ss), dtype=np.int64, count=len(ss))
    times = np.fromiter((s.time for s in ss), dtype=np.float64, count=len(ss))
    # split the window where the set of bodies changed
    starts = [0] + [i for i in range(1, len(ss)) if ss[i].layout.version != ss[i - 1].layout.version]
    for s0, s1 in zip(starts, starts[1:] + [len(ss)], strict=True):
        _write_bodies(rec, b, ss[s0:s1], ticks[s0:s1], times[s0:s1])
    _write_static(rec, b, ss)
    _write_contacts(rec, b, ss, ticks, times)
    if b.has_joints:
        _write_joints(rec, b, ss)
    stats = aggregates(ss)
    for k, st in enumerate(schema.STATS):
        rec.send_columns(f"{b.prefix}{schema.STATS_ROOT}/{st.name}", indexes=_index(ticks, times),
                         columns=rr.Scalars.columns(scalars=stats[:, k]))
    _write_residuals(rec, b, ss, ticks, times)
    b.samples = []


def _body_values(lay_rows: np.ndarray, uid: np.ndarray, X: np.ndarray, TH: np.ndarray,
                 VV: np.ndarray) -> dict[str, np.ndarray]:
    S = X.shape[0]
    return {"uid": np.broadcast_to(uid[lay_rows], (S, lay_rows.size)).reshape(-1),
            "x": X[:, lay_rows, 0].reshape(-1), "y": X[:, lay_rows, 1].reshape(-1),
            "angle": TH[:, lay_rows].reshape(-1), "vx": VV[:, lay_rows, 0].reshape(-1),
            "vy": VV[:, lay_rows, 1].reshape(-1), "omega": VV[:, lay_rows, 2].reshape(-1)}


def _labels(rec: rr.RecordingStream, path: str, t: np.ndarray, tm: np.ndarray, classes: np.ndarray,
            labels: list[str]) -> None:
    """Classes and labels of a body set, on one row: the viewer carries them on (latest-at)."""
    rec.send_columns(path, indexes=_index(t[:1], tm[:1]), columns=rr.LineStrips2D.columns(
        class_ids=classes, labels=labels).partition([len(labels)]))


def _write_bodies(rec: rr.RecordingStream, b: RunBuffer, ss: list[Sample], t: np.ndarray, tm: np.ndarray) -> None:
    lay = ss[0].layout
    path = f"{b.prefix}{schema.BODIES}"
    if lay.version != b.labelled:
        _labels(rec, path, t, tm, lay.dynamic_class, lay.dynamic_labels)
        b.labelled = lay.version
    X = np.stack([s.x for s in ss])
    TH = np.stack([s.theta for s in ss])
    VV = np.stack([s.V for s in ss])
    S, D = len(ss), lay.dynamic.size
    lengths = np.full(S, D)
    rec.send_columns(path, indexes=_index(t, tm), columns=[
        _strips_column(lay.dynamic_strips.world_points(X, TH), lay.dynamic_strips.lengths),
        *_table(schema.BODY_FIELDS, _body_values(lay.dynamic, lay.uid, X, TH, VV), lengths)])


def _write_static(rec: rr.RecordingStream, b: RunBuffer, ss: list[Sample]) -> None:
    """Static bodies on the ticks where they differ from what was last written (usually once)."""
    rows = []
    for i, s in enumerate(ss):
        lay = s.layout
        st = lay.static
        state = (lay.version, np.concatenate([s.x[st].ravel(), s.theta[st], s.V[st].ravel()]))
        last = b.static_state
        if last is not None and last[0] == state[0] and np.array_equal(last[1], state[1]):
            continue
        rows.append(i)
        b.static_state = state
    if not rows:
        return
    path = f"{b.prefix}{schema.STATIC}"
    for i in rows:  # rare: one send per change
        s = ss[i]
        lay = s.layout
        t, tm = np.array([s.tick]), np.array([s.time])
        _labels(rec, path, t, tm, lay.static_class, lay.static_labels)
        strips: Strips = lay.static_strips
        pts = strips.world_points(s.x[None], s.theta[None])
        rec.send_columns(path, indexes=_index(t, tm), columns=[
            _strips_column(pts, strips.lengths),
            *_table(schema.BODY_FIELDS, _body_values(lay.static, lay.uid, s.x[None], s.theta[None], s.V[None]),
                    np.array([lay.static.size]))])


def _write_contacts(rec: rr.RecordingStream, b: RunBuffer, ss: list[Sample], t: np.ndarray,
                    tm: np.ndarray) -> None:
    lengths = np.fromiter((s.key.size for s in ss), dtype=np.int64, count=len(ss))
    key = np.concatenate([s.key for s in ss])
    uid_a, uid_b, feature = schema.split_key(key)
    warm = np.concatenate([s.warm for s in ss])
    origins = on_grid(np.concatenate([s.point for s in ss]).reshape(-1, 2), schema.DRAW_GRID)
    normals = on_grid(np.concatenate([s.normal for s in ss]).reshape(-1, 2), schema.NORMAL_GRID)
    values = {"body_a": uid_a, "body_b": uid_b, "feature": feature,
              "lambda_n": np.concatenate([s.lambda_n for s in ss]),
              "lambda_t": np.concatenate([s.lambda_t for s in ss]),
              "separation": np.concatenate([s.separation for s in ss]), "warm_started": warm}
    rec.send_columns(f"{b.prefix}{schema.CONTACTS}", indexes=_index(t, tm), columns=[
        *rr.Arrows2D.columns(origins=origins, vectors=normals * np.float32(schema.NORMAL_LENGTH),
                             class_ids=np.where(warm, schema.CLASS_WARM, schema.CLASS_COLD).astype(np.uint16)
                             ).partition(lengths),
        *_table(schema.CONTACT_FIELDS, values, lengths)])


def _write_joints(rec: rr.RecordingStream, b: RunBuffer, ss: list[Sample]) -> None:
    js = [s for s in ss if s.joint_ends is not None]
    if not js:
        return
    all_ends = [s.joint_ends for s in js if s.joint_ends is not None]
    ends = on_grid(np.concatenate(all_ends).reshape(-1, 2, 2), schema.DRAW_GRID)
    lengths = np.fromiter((len(e) for e in all_ends), dtype=np.int64, count=len(all_ends))
    t = np.fromiter((s.tick for s in js), dtype=np.int64, count=len(js))
    tm = np.fromiter((s.time for s in js), dtype=np.float64, count=len(js))
    rec.send_columns(f"{b.prefix}{schema.JOINTS}", indexes=_index(t, tm), columns=rr.LineStrips2D.columns(
        strips=ends, class_ids=np.full(len(ends), schema.CLASS_JOINT, np.uint16)).partition(lengths))


def _write_residuals(rec: rr.RecordingStream, b: RunBuffer, ss: list[Sample], t: np.ndarray,
                     tm: np.ndarray) -> None:
    """One row per sweep: log10 for the plot, the residual itself (m/s) exactly."""
    n = np.fromiter((s.residuals.size for s in ss), dtype=np.int64, count=len(ss))
    if not n.sum():
        return
    res = np.concatenate([s.residuals for s in ss])
    sweep = b.sweeps + np.arange(res.size, dtype=np.int64)
    b.sweeps += int(res.size)
    index = [*_index(np.repeat(t, n), np.repeat(tm, n)), rr.TimeColumn(schema.SWEEP, sequence=sweep)]
    rec.send_columns(f"{b.prefix}{schema.RESIDUAL}", indexes=index, columns=[
        *rr.Scalars.columns(scalars=np.log10(np.maximum(res, schema.RESIDUAL_FLOOR))),
        *rr.AnyValues.columns(**{schema.RESIDUAL_FIELD.name: pa.array(res)}).partition(np.ones(res.size, np.int64))])


# -- the plotted series ------------------------------------------------------------------------------
def write_series(rec: rr.RecordingStream, b: RunBuffer) -> None:
    """The chosen contacts' lambda and penetration, and the joints' reactions, as one wide batch."""
    fields: list[pa.Field] = []
    arrays: list[pa.Array] = []
    batches: list[tuple[SeriesWindow, list[tuple[str, tuple[int, ...]]], Callable[[int], str]]] = []
    w = b.contacts
    if w.ticks:
        if b.choice.kind == "deepest" and (b.chosen is None or b.chosen.size < b.choice.n):
            b.chosen = b.choice.decide(w.keys, [v[:, 2] for v in w.values], b.chosen)
            keep = [member(k, b.chosen) for k in w.keys]
            w.keys = [k[m] for k, m in zip(w.keys, keep, strict=True)]
            w.values = [v[m] for v, m in zip(w.values, keep, strict=True)]
        new = _style_contacts(rec, b, w)
        b.plotted = b.plotted or bool(new) or bool(b.styled)
        batches.append((w, [(f"{b.prefix}{schema.LAMBDA}", (0, 1)), (f"{b.prefix}{schema.PENETRATION}", (2,))],
                        schema.contact_entity))
    if b.joints.ticks:
        batches.append((b.joints, [(f"{b.prefix}{schema.REACTION}", (0,))],
                        lambda k: schema.joint_entity(int(k) >> 16, int(k) & 0xFFFF)))
    for window, families, entity_of in batches:
        ticks = np.asarray(window.ticks, dtype=np.int64)
        times = np.asarray(window.times, dtype=np.float64)
        fields = [pa.field(schema.TICK, pa.int64()), pa.field(schema.SIM_TIME, pa.duration("ns"))]
        arrays = [pa.array(ticks), pa.array(np.round(times * 1e9).astype("timedelta64[ns]"))]
        _series_columns(window, families, entity_of, fields, arrays)
        if len(arrays) > 2:
            rr.send_record_batch(pa.RecordBatch.from_arrays(arrays, schema=pa.schema(fields)), recording=rec,
                                 index=[schema.TICK, schema.SIM_TIME])
        window.clear()
    b.series_ticks = 0


def _style_contacts(rec: rr.RecordingStream, b: RunBuffer, w: SeriesWindow) -> list[int]:
    """Legend names and colours of contacts plotted for the first time."""
    seen = np.unique(np.concatenate(w.keys)) if w.keys else np.zeros(0, np.int64)
    new = [int(k) for k in seen if int(k) not in b.styled]
    tag = f"{b.label} " if b.label else ""
    for k in new:
        colour = schema.PALETTE[len(b.colours) % len(schema.PALETTE)]
        b.colours[k] = colour
        name = schema.contact_label(k)
        rec.log(f"{b.prefix}{schema.LAMBDA}/{schema.contact_entity(k)}",
                rr.SeriesLines(names=[f"{tag}{name} λn", f"{tag}{name} λt"], colors=[colour, schema.lighter(colour)],
                               widths=[2.0, 1.0]), static=True)
        rec.log(f"{b.prefix}{schema.PENETRATION}/{schema.contact_entity(k)}",
                rr.SeriesLines(names=[f"{tag}{name}"], colors=[colour], widths=[2.0]), static=True)
        b.styled.add(k)
    return new


def _series_columns(w: SeriesWindow, families: list[tuple[str, tuple[int, ...]]], entity_of: Callable[[int], str],
                    fields: list[pa.Field], arrays: list[pa.Array]) -> None:
    """One list<f64> column per (family, identity) over the window's T ticks; an identity that
    ends gets one NaN row, so the plot shows a gap instead of a line across it."""
    T = len(w.ticks)
    lengths = np.fromiter((k.size for k in w.keys), dtype=np.int64, count=T)
    row = np.repeat(np.arange(T, dtype=np.int64), lengths)
    keys = np.concatenate(w.keys)
    vals = np.concatenate(w.values) if keys.size else np.zeros((0, max((len(f[1]) for f in families), default=1)))
    gone0 = np.setdiff1d(w.last, w.keys[0])  # series that ended exactly at this window's first tick
    if keys.size == 0 and gone0.size == 0:
        return
    uniq, col = np.unique(np.concatenate([keys, gone0]), return_inverse=True)
    col, col0 = col[: keys.size], col[keys.size:]
    U = uniq.size
    present = np.zeros((U, T), dtype=np.bool_)
    present[col, row] = True
    n_val = vals.shape[1]
    dense = np.full((n_val, U, T), np.nan)
    for q in range(n_val):
        dense[q, col, row] = vals[:, q]
    ended = np.zeros((U, T), dtype=np.bool_)
    ended[:, 1:] = present[:, :-1] & ~present[:, 1:]
    ended[col0, 0] = True
    present |= ended  # the NaN row that ends a series
    offsets_1 = np.zeros((U, T + 1), dtype=np.int32)
    np.cumsum(present, axis=1, out=offsets_1[:, 1:])
    count = offsets_1[:, -1].astype(np.int64)
    start = np.concatenate([[0], np.cumsum(count)])
    bits = np.packbits(present, axis=1, bitorder="little")
    nulls = T - count
    names = [entity_of(int(k)) for k in uniq]
    d = rr.Scalars.descriptor_scalars()
    meta = {b"rerun:component": str(d.component).encode(), b"rerun:archetype": str(d.archetype).encode(),
            b"rerun:component_type": str(d.component_type).encode()}
    list_type = pa.list_(pa.float64())
    for family, which in families:
        m = len(which)
        v = np.ascontiguousarray(np.stack([dense[q][present] for q in which], axis=1).reshape(-1))
        offsets = offsets_1 * np.int32(m)
        for j, name in enumerate(names):
            ent = f"/{family}/{name}"
            fields.append(pa.field(f"{ent}:{d.component}", list_type, metadata={b"rerun:entity_path": ent.encode(),
                                                                               **meta}))
            child = pa.Array.from_buffers(pa.float64(), int(count[j]) * m,
                                          [None, pa.py_buffer(v[m * start[j]: m * start[j + 1]])])
            arrays.append(pa.Array.from_buffers(list_type, T, [pa.py_buffer(bits[j]), pa.py_buffer(offsets[j])],
                                                null_count=int(nulls[j]), children=[child]))


__all__ = ["write_scene", "write_series", "write_start"]
