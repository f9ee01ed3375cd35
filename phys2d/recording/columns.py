"""Writing columns: a run's buffered ticks to Rerun, a few columnar sends per entity and window.

Every function here takes a ``native.Stream`` and a ``RunBuffer`` and writes what
``schema`` names as arrow arrays (no ``rerun`` import: ``native``); none of them looks
at a World.
"""

from __future__ import annotations

import zlib
from collections.abc import Callable

import numpy as np
import pyarrow as pa

from . import native, schema
from .buffer import RunBuffer, SeriesWindow, member, unique
from .native import Stream
from .sample import Sample, Strips, aggregates, on_grid


def _index(ticks: np.ndarray, times: np.ndarray) -> dict[str, pa.Array]:
    return {schema.TICK: native.sequence(ticks), schema.SIM_TIME: native.duration(times)}


def _ones(n: int) -> np.ndarray:
    return np.ones(n, dtype=np.int64)


def _strips_column(points: np.ndarray, lengths: np.ndarray) -> pa.Array:
    """LineStrips2D:strips for S ticks: points (S, P, 2) float32, ``lengths`` points per strip."""
    S = points.shape[0]
    inner = np.zeros(S * lengths.size + 1, dtype=np.int32)
    np.cumsum(np.tile(lengths, S), out=inner[1:])
    strips = pa.ListArray.from_arrays(
        native.array(inner), native.points2(points.reshape(-1, 2)), type=native.STRIP_TYPE
    )
    return native.lists(strips, np.full(S, lengths.size))


def _table(fields: tuple[schema.Field, ...], values: dict[str, np.ndarray], lengths: np.ndarray) -> dict:
    """AnyValues columns named by ``fields``, cast to their dtypes, partitioned by ``lengths``."""
    return {
        native.any_value(f.name): native.lists(np.ascontiguousarray(values[f.name], dtype=f.dtype), lengths)
        for f in fields
    }


def _series_style(
    names: list[str], colours: list[tuple[int, int, int]], widths: list[float], visible: list[bool] | None = None
) -> dict:
    comps = {
        native.SERIES_COLORS: pa.array([native.rgba(c) for c in colours], pa.uint32()),
        native.SERIES_WIDTHS: pa.array(widths, pa.float32()),
        native.SERIES_NAMES: pa.array(names, pa.string()),
    }
    if visible is not None:
        comps[native.SERIES_VISIBLE] = pa.array(visible, pa.bool_())
    return comps


def write_start(rec: Stream, b: RunBuffer, colour: tuple[int, int, int]) -> None:
    """What a run logs once: class colours, the y-flip, drawing styles, and its plots' legend
    names and colours (a named run's plots carry its label and ``colour``, so runs overlaid in
    one plot stay apart)."""
    p = b.prefix
    context = [
        {
            "class_id": k,
            "class_description": {
                "info": {"id": k, "label": label, "color": native.rgba(c)},
                "keypoint_annotations": [],
                "keypoint_connections": [],
            },
        }
        for k, label, c in schema.ANNOTATIONS
    ]
    rec.static(f"{p}{schema.WORLD}", {native.ANNOTATION_CONTEXT: pa.array([context], native.ANNOTATION_TYPE)})
    rec.static(f"{p}{schema.SIM}", {native.TRANSFORM_SCALE: pa.array([[1.0, -1.0, 1.0]], native.SCALE3D_TYPE)})
    for path in (schema.BODIES, schema.STATIC, schema.JOINTS):  # physics is y-up
        rec.static(
            f"{p}{path}",
            {
                native.STRIP_RADII: pa.array([schema.LINE_RADIUS], pa.float32()),
                native.STRIP_SHOW_LABELS: pa.array([False], pa.bool_()),
            },
        )
    rec.static(
        f"{p}{schema.CONTACTS}",
        {
            native.ARROW_RADII: pa.array([schema.ARROW_RADIUS], pa.float32()),
            native.ARROW_SHOW_LABELS: pa.array([False], pa.bool_()),
        },
    )
    for st in schema.STATS:
        if b.label:
            names, colours = [f"{b.label} {st.label}"], [colour]
        else:
            names, colours = [st.label], [schema.ENERGY_COLOURS.get(st.name.split("/")[-1], colour)]
        # potential and total energy dwarf the kinetic: listed in the legend, shown when clicked there
        shown = st.name not in schema.ENERGY_HIDDEN
        rec.static(f"{p}{schema.STATS_ROOT}/{st.name}", _series_style(names, colours, [1.5], [shown]))
    name = f"{b.label} log10 residual" if b.label else "log10 residual"
    rec.static(f"{p}{schema.RESIDUAL}", _series_style([name], [colour], [1.5]))


# -- the scene ----------------------------------------------------------------------------------
def write_scene(rec: Stream, b: RunBuffer) -> None:
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
    b.stats.append((ticks, times, aggregates(ss)))
    b.stats_ticks += len(ss)
    _keep_residuals(b, ss, ticks, times)
    _write_replay(rec, b, ss)
    b.samples = []


def write_stats(rec: Stream, b: RunBuffer) -> None:
    """The stats and residuals of the windows written so far: one chunk per entity."""
    if b.stats:
        ticks, times, stats = (np.concatenate(parts) for parts in zip(*b.stats, strict=True))
        index = _index(ticks, times)
        ones = _ones(ticks.size)
        for k, st in enumerate(schema.STATS):
            rec.send(
                f"{b.prefix}{schema.STATS_ROOT}/{st.name}",
                index,
                {native.SCALARS: native.lists(np.ascontiguousarray(stats[:, k]), ones)},
            )
    if b.residuals:
        t, tm, sweep, res = (np.concatenate(parts) for parts in zip(*b.residuals, strict=True))
        index = {**_index(t, tm), schema.SWEEP: native.sequence(sweep)}
        ones = _ones(res.size)
        rec.send(
            f"{b.prefix}{schema.RESIDUAL}",
            index,
            {native.SCALARS: native.lists(np.log10(np.maximum(res, schema.RESIDUAL_FLOOR)), ones)},
        )
        rec.send(
            f"{b.prefix}{schema.SWEEPS}", index, {native.any_value(schema.RESIDUAL_FIELD.name): native.lists(res, ones)}
        )
    b.stats, b.residuals, b.stats_ticks = [], [], 0


def _body_values(
    lay_rows: np.ndarray, uid: np.ndarray, X: np.ndarray, TH: np.ndarray, VV: np.ndarray
) -> dict[str, np.ndarray]:
    S = X.shape[0]
    return {
        "uid": np.broadcast_to(uid[lay_rows], (S, lay_rows.size)).reshape(-1),
        "x": X[:, lay_rows, 0].reshape(-1),
        "y": X[:, lay_rows, 1].reshape(-1),
        "angle": TH[:, lay_rows].reshape(-1),
        "vx": VV[:, lay_rows, 0].reshape(-1),
        "vy": VV[:, lay_rows, 1].reshape(-1),
        "omega": VV[:, lay_rows, 2].reshape(-1),
    }


def _labels(rec: Stream, path: str, t: np.ndarray, tm: np.ndarray, classes: np.ndarray, labels: list[str]) -> None:
    """Classes and labels of a body set, on one row: the viewer carries them on (latest-at)."""
    n = np.array([len(labels)])
    rec.send(
        path,
        _index(t[:1], tm[:1]),
        {
            native.STRIP_CLASS_IDS: native.lists(np.asarray(classes, dtype=np.uint16), n),
            native.STRIP_LABELS: native.lists(pa.array(labels, pa.string()), n),
        },
    )


def _write_bodies(rec: Stream, b: RunBuffer, ss: list[Sample], t: np.ndarray, tm: np.ndarray) -> None:
    lay = ss[0].layout
    path = f"{b.prefix}{schema.BODIES}"
    for i, s in enumerate(ss):  # classes where they change: a new layout, a body falling asleep or waking
        classes = s.dynamic_classes()
        if lay.version != b.labelled or b.body_classes is None or not np.array_equal(classes, b.body_classes):
            _labels(rec, path, t[i:], tm[i:], classes, lay.dynamic_labels)
            b.labelled, b.body_classes = lay.version, classes
    X = np.stack([s.x for s in ss])
    TH = np.stack([s.theta for s in ss])
    VV = np.stack([s.V for s in ss])
    S, D = len(ss), lay.dynamic.size
    lengths = np.full(S, D)
    rec.send(
        path,
        _index(t, tm),
        {
            native.STRIPS: _strips_column(lay.dynamic_strips.world_points(X, TH), lay.dynamic_strips.lengths),
            **_table(schema.BODY_FIELDS, _body_values(lay.dynamic, lay.uid, X, TH, VV), lengths),
        },
    )


def _write_static(rec: Stream, b: RunBuffer, ss: list[Sample]) -> None:
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
        rec.send(
            path,
            _index(t, tm),
            {
                native.STRIPS: _strips_column(pts, strips.lengths),
                **_table(
                    schema.BODY_FIELDS,
                    _body_values(lay.static, lay.uid, s.x[None], s.theta[None], s.V[None]),
                    np.array([lay.static.size]),
                ),
            },
        )


def _write_contacts(rec: Stream, b: RunBuffer, ss: list[Sample], t: np.ndarray, tm: np.ndarray) -> None:
    lengths = np.fromiter((s.key.size for s in ss), dtype=np.int64, count=len(ss))
    key = np.concatenate([s.key for s in ss])
    uid_a, uid_b, feature = schema.split_key(key)
    warm = np.concatenate([s.warm for s in ss])
    origins = on_grid(np.concatenate([s.point for s in ss]).reshape(-1, 2), schema.DRAW_GRID)
    normals = on_grid(np.concatenate([s.normal for s in ss]).reshape(-1, 2), schema.NORMAL_GRID)
    values = {
        "body_a": uid_a,
        "body_b": uid_b,
        "feature": feature,
        "lambda_n": np.concatenate([s.lambda_n for s in ss]),
        "lambda_t": np.concatenate([s.lambda_t for s in ss]),
        "separation": np.concatenate([s.separation for s in ss]),
        "warm_started": warm,
    }
    rec.send(
        f"{b.prefix}{schema.CONTACTS}",
        _index(t, tm),
        {
            native.ARROW_ORIGINS: native.lists(native.points2(origins), lengths),
            native.ARROW_VECTORS: native.lists(native.points2(normals * np.float32(schema.NORMAL_LENGTH)), lengths),
            native.ARROW_CLASS_IDS: native.lists(
                np.where(warm, schema.CLASS_WARM, schema.CLASS_COLD).astype(np.uint16), lengths
            ),
            **_table(schema.CONTACT_FIELDS, values, lengths),
        },
    )


def _write_joints(rec: Stream, b: RunBuffer, ss: list[Sample]) -> None:
    js = [s for s in ss if s.joint_ends is not None]
    if not js:
        return
    all_ends = [s.joint_ends for s in js if s.joint_ends is not None]
    ends = on_grid(np.concatenate(all_ends).reshape(-1, 2, 2), schema.DRAW_GRID)
    lengths = np.fromiter((len(e) for e in all_ends), dtype=np.int64, count=len(all_ends))
    t = np.fromiter((s.tick for s in js), dtype=np.int64, count=len(js))
    tm = np.fromiter((s.time for s in js), dtype=np.float64, count=len(js))
    strips = pa.ListArray.from_arrays(
        native.array(np.arange(0, 2 * len(ends) + 1, 2, dtype=np.int32)),
        native.points2(ends.reshape(-1, 2)),
        type=native.STRIP_TYPE,
    )
    rec.send(
        f"{b.prefix}{schema.JOINTS}",
        _index(t, tm),
        {
            native.STRIPS: native.lists(strips, lengths),
            native.STRIP_CLASS_IDS: native.lists(np.full(len(ends), schema.CLASS_JOINT, np.uint16), lengths),
        },
    )


def _write_replay(rec: Stream, b: RunBuffer, ss: list[Sample]) -> None:
    """What re-enters the recording (``schema.REPLAY_STATE``, ``REPLAY_KEYFRAMES``, ``REPLAY_RESPONDER``):
    every tick's state hash and dt, the keyframes (compressed here, on the writing side) and the
    responder's spec where it changed."""
    kept = [s for s in ss if s.state is not None and s.dt is not None]
    if kept:
        t = np.fromiter((s.tick for s in kept), dtype=np.int64, count=len(kept))
        tm = np.fromiter((s.time for s in kept), dtype=np.float64, count=len(kept))
        ones = _ones(t.size)
        rec.send(
            f"{b.prefix}{schema.REPLAY_STATE}",
            _index(t, tm),
            {
                native.any_value(schema.STATE_HASH.name): native.lists(np.concatenate([s.state for s in kept]), ones),
                native.any_value(schema.DT.name): native.lists(np.concatenate([s.dt for s in kept]), ones),
            },
        )
    for entity, field, rows in (
        (
            schema.REPLAY_KEYFRAMES,
            schema.KEYFRAME,
            [(s, zlib.compress(s.keyframe.tobytes(), 1)) for s in ss if s.keyframe is not None],
        ),
        (
            schema.REPLAY_RESPONDER,
            schema.RESPONDER_SPEC,
            [(s, s.responder.tobytes().decode()) for s in ss if s.responder is not None],
        ),
    ):
        if not rows:
            continue
        t = np.fromiter((s.tick for s, _ in rows), dtype=np.int64, count=len(rows))
        tm = np.fromiter((s.time for s, _ in rows), dtype=np.float64, count=len(rows))
        kind = pa.string() if field is schema.RESPONDER_SPEC else pa.binary()
        values = pa.array([v for _, v in rows], kind)
        rec.send(
            f"{b.prefix}{entity}", _index(t, tm), {native.any_value(field.name): native.lists(values, _ones(t.size))}
        )


def _keep_residuals(b: RunBuffer, ss: list[Sample], t: np.ndarray, tm: np.ndarray) -> None:
    """One row per sweep (written by ``write_stats``): log10 for the plot (``schema.RESIDUAL``), the
    residual itself (m/s) exactly (``schema.SWEEPS``)."""
    n = np.fromiter((s.residuals.size for s in ss), dtype=np.int64, count=len(ss))
    if not n.sum():
        return
    res = np.concatenate([s.residuals for s in ss])
    sweep = b.sweeps + np.arange(res.size, dtype=np.int64)
    b.sweeps += int(res.size)
    b.residuals.append((np.repeat(t, n), np.repeat(tm, n), sweep, res))


# -- the plotted series ------------------------------------------------------------------------------
def write_series(rec: Stream, b: RunBuffer) -> None:
    """The chosen contacts' lambda and penetration, and the joints' reactions: per entity, one
    column over the window's ticks."""
    batches: list[tuple[SeriesWindow, list[tuple[str, tuple[int, ...]]], Callable[[int], str]]] = []
    w = b.contacts
    if w.ticks:
        if b.choice.kind == "deepest" and (b.chosen is None or b.chosen.size < b.choice.n):
            if len(w.cand_keys) == len(w.keys):  # every tick ranked as it arrived
                b.chosen = b.choice.decide(w.cand_keys, w.cand_depth, b.chosen)
            else:
                b.chosen = b.choice.decide(w.keys, [v[:, 2] for v in w.values], b.chosen)
            # keep the chosen contacts' values, tick by tick (no copy of the whole window)
            keeps = [member(k, b.chosen) for k in w.keys]
            w.keys = [k[m] for k, m in zip(w.keys, keeps, strict=True)]
            w.values = [v[m] for v, m in zip(w.values, keeps, strict=True)]
        new = _style_contacts(rec, b, w)
        b.plotted = b.plotted or bool(new) or bool(b.styled)
        batches.append(
            (
                w,
                [(f"{b.prefix}{schema.LAMBDA}", (0, 1)), (f"{b.prefix}{schema.PENETRATION}", (2,))],
                schema.contact_entity,
            )
        )
    if b.joints.ticks:
        batches.append(
            (
                b.joints,
                [(f"{b.prefix}{schema.REACTION}", (0,))],
                lambda k: schema.joint_entity(int(k) >> 16, int(k) & 0xFFFF),
            )
        )
    for window, families, entity_of in batches:
        ticks = np.asarray(window.ticks, dtype=np.int64)
        times = np.asarray(window.times, dtype=np.float64)
        index = {
            schema.TICK: native.sequence(ticks),
            schema.SIM_TIME: native.array(np.round(times * 1e9).astype("timedelta64[ns]")),
        }
        for entity, column in _series_columns(window, families, entity_of):
            rec.send(entity, index, {native.SCALARS: column})
        window.clear()
    b.series_ticks = 0


def _style_contacts(rec: Stream, b: RunBuffer, w: SeriesWindow) -> list[int]:
    """Legend names and colours of contacts plotted for the first time."""
    seen = unique(np.concatenate(w.keys))[0] if w.keys else np.zeros(0, np.int64)
    new = [int(k) for k in seen if int(k) not in b.styled]
    tag = f"{b.label} " if b.label else ""
    for k in new:
        colour = schema.PALETTE[len(b.colours) % len(schema.PALETTE)]
        b.colours[k] = colour
        name = schema.contact_label(k)
        rec.static(
            f"{b.prefix}{schema.LAMBDA}/{schema.contact_entity(k)}",
            _series_style([f"{tag}{name} λn", f"{tag}{name} λt"], [colour, schema.lighter(colour)], [2.0, 1.0]),
        )
        rec.static(
            f"{b.prefix}{schema.PENETRATION}/{schema.contact_entity(k)}",
            _series_style([f"{tag}{name}"], [colour], [2.0]),
        )
        b.styled.add(k)
    return new


def _series_columns(
    w: SeriesWindow, families: list[tuple[str, tuple[int, ...]]], entity_of: Callable[[int], str]
) -> list[tuple[str, pa.Array]]:
    """One list<f64> column per (family, identity) over the window's T ticks; an identity that
    ends gets one NaN row, so the plot shows a gap instead of a line across it."""
    T = len(w.ticks)
    lengths = np.fromiter((k.size for k in w.keys), dtype=np.int64, count=T)
    row = np.repeat(np.arange(T, dtype=np.int64), lengths)
    keys = np.concatenate(w.keys)
    vals = np.concatenate(w.values) if keys.size else np.zeros((0, max((len(f[1]) for f in families), default=1)))
    gone0 = unique(w.last[~member(w.last, w.keys[0])])[0]  # series that ended exactly at this window's first tick
    if keys.size == 0 and gone0.size == 0:
        return []
    uniq, col = unique(np.concatenate([keys, gone0]))
    col, col0 = col[: keys.size], col[keys.size :]
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
    list_type = pa.list_(pa.float64())
    out = []
    for family, which in families:
        m = len(which)
        v = np.ascontiguousarray(np.stack([dense[q][present] for q in which], axis=1).reshape(-1))
        offsets = offsets_1 * np.int32(m)
        for j, name in enumerate(names):
            child = pa.Array.from_buffers(
                pa.float64(), int(count[j]) * m, [None, pa.py_buffer(v[m * start[j] : m * start[j + 1]])]
            )
            out.append(
                (
                    f"/{family}/{name}",
                    pa.Array.from_buffers(
                        list_type,
                        T,
                        [pa.py_buffer(bits[j]), pa.py_buffer(offsets[j])],
                        null_count=int(nulls[j]),
                        children=[child],
                    ),
                )
            )
    return out


__all__ = ["write_scene", "write_series", "write_start", "write_stats"]
