"""Rerun's native layer, without the ``rerun`` Python package: a stream that sends arrow arrays.

``import rerun`` spends about 0.6 s of CPU building its Python archetype and blueprint
classes; the native module ``rerun_bindings`` under it loads in about 10 ms. The writer
needs only the native layer: it builds every column as a pyarrow array itself, with the
component descriptors (archetype, component, component type) that rerun-sdk 0.41's
archetypes use, and hands them to ``rerun_bindings.send_arrow_chunk`` (temporal columns)
or ``log_arrow_msg`` (static rows, properties, the blueprint). The file is the same as
one written through ``rerun``'s archetypes (``tests/test_recording.py`` checks the arrow
types against rerun's own).
"""

from __future__ import annotations

import uuid
from typing import Any

import numpy as np
import pyarrow as pa
import rerun_bindings as rb

Descriptor = Any  # rerun_bindings.ComponentDescriptor


def archetype_field(archetype: str, field: str, component_type: str, blueprint: bool = False) -> Descriptor:
    """The descriptor of ``<archetype>:<field>`` as rerun's archetypes write it."""
    scope = "rerun.blueprint.archetypes" if blueprint else "rerun.archetypes"
    return rb.ComponentDescriptor(f"{archetype}:{field}", f"{scope}.{archetype}", component_type)


def any_value(name: str) -> Descriptor:
    """The descriptor of an ``AnyValues`` column: its name only."""
    return rb.ComponentDescriptor(name)


# -- the components phys2d writes ------------------------------------------------------------
STRIPS = archetype_field("LineStrips2D", "strips", "rerun.components.LineStrip2D")
STRIP_CLASS_IDS = archetype_field("LineStrips2D", "class_ids", "rerun.components.ClassId")
STRIP_LABELS = archetype_field("LineStrips2D", "labels", "rerun.components.Text")
STRIP_RADII = archetype_field("LineStrips2D", "radii", "rerun.components.Radius")
STRIP_SHOW_LABELS = archetype_field("LineStrips2D", "show_labels", "rerun.components.ShowLabels")
ARROW_ORIGINS = archetype_field("Arrows2D", "origins", "rerun.components.Position2D")
ARROW_VECTORS = archetype_field("Arrows2D", "vectors", "rerun.components.Vector2D")
ARROW_CLASS_IDS = archetype_field("Arrows2D", "class_ids", "rerun.components.ClassId")
ARROW_RADII = archetype_field("Arrows2D", "radii", "rerun.components.Radius")
ARROW_SHOW_LABELS = archetype_field("Arrows2D", "show_labels", "rerun.components.ShowLabels")
SCALARS = archetype_field("Scalars", "scalars", "rerun.components.Scalar")
SERIES_NAMES = archetype_field("SeriesLines", "names", "rerun.components.Name")
SERIES_COLORS = archetype_field("SeriesLines", "colors", "rerun.components.Color")
SERIES_WIDTHS = archetype_field("SeriesLines", "widths", "rerun.components.StrokeWidth")
SERIES_VISIBLE = archetype_field("SeriesLines", "visible_series", "rerun.components.Visible")
ANNOTATION_CONTEXT = archetype_field("AnnotationContext", "context", "rerun.components.AnnotationContext")
TRANSFORM_SCALE = archetype_field("Transform3D", "scale", "rerun.components.Scale3D")

# exactly rerun's arrow types: the viewer skips a column whose type or nullability differs
F32_2 = pa.list_(pa.field("item", pa.float32(), nullable=False), 2)
STRIP_TYPE = pa.list_(pa.field("item", F32_2, nullable=False))
_KEYPOINT = pa.struct(
    [pa.field("id", pa.uint16(), nullable=False), pa.field("label", pa.string()), pa.field("color", pa.uint32())]
)
_CONNECTION = pa.struct(
    [pa.field("keypoint0", pa.uint16(), nullable=False), pa.field("keypoint1", pa.uint16(), nullable=False)]
)
ANNOTATION_TYPE = pa.list_(
    pa.field(
        "item",
        pa.struct(
            [
                pa.field("class_id", pa.uint16(), nullable=False),
                pa.field(
                    "class_description",
                    pa.struct(
                        [
                            pa.field("info", _KEYPOINT, nullable=False),
                            pa.field(
                                "keypoint_annotations",
                                pa.list_(pa.field("item", _KEYPOINT, nullable=False)),
                                nullable=False,
                            ),
                            pa.field(
                                "keypoint_connections",
                                pa.list_(pa.field("item", _CONNECTION, nullable=False)),
                                nullable=False,
                            ),
                        ]
                    ),
                    nullable=False,
                ),
            ]
        ),
        nullable=False,
    )
)
SCALE3D_TYPE = pa.list_(pa.field("item", pa.float32(), nullable=False), 3)


def rgba(colour: tuple[int, int, int]) -> int:
    """rerun's packed colour: 0xRRGGBBAA, opaque."""
    r, g, b = colour
    return (r << 24) | (g << 16) | (b << 8) | 0xFF


def array(values: np.ndarray) -> pa.Array:
    """A 1-D numpy array (numbers, bools, timedelta64) as an arrow array without nulls, sharing its
    memory (bools are bit-packed). ``pa.array`` does the same, but its first call imports
    ``numpy.ma`` (15-20 ms of the writer's CPU)."""
    a = np.ascontiguousarray(values).reshape(-1)
    if a.dtype == np.bool_:
        return pa.Array.from_buffers(pa.bool_(), a.size, [None, pa.py_buffer(np.packbits(a, bitorder="little"))])
    return pa.Array.from_buffers(pa.from_numpy_dtype(a.dtype), a.size, [None, pa.py_buffer(a)])


def _one(value: Any) -> pa.Array:
    """A one-element array of a str, bool, int or float, typed as ``pa.array([value])`` infers it
    (without inferring: that imports dateutil)."""
    for kind, arrow in ((str, pa.string()), (bool, pa.bool_()), (int, pa.int64()), (float, pa.float64())):
        if isinstance(value, kind):
            return pa.array([value], arrow)
    return pa.array([value])


def lists(values: pa.Array | np.ndarray, lengths: np.ndarray) -> pa.Array:
    """``values`` cut into consecutive lists of ``lengths`` (one list per row): a component column."""
    if not isinstance(values, pa.Array):
        values = array(values)
    offsets = np.zeros(len(lengths) + 1, dtype=np.int32)
    np.cumsum(lengths, out=offsets[1:])
    return pa.ListArray.from_arrays(array(offsets), values)


def points2(points: np.ndarray) -> pa.Array:
    """(P, 2) float32 as rerun's Position2D / Vector2D items."""
    flat = np.ascontiguousarray(points, dtype=np.float32).reshape(-1)
    return pa.FixedSizeListArray.from_arrays(array(flat), type=F32_2)


def sequence(values: np.ndarray) -> pa.Array:
    """A sequence timeline's column."""
    return array(np.ascontiguousarray(values, dtype=np.int64))


def duration(seconds: np.ndarray) -> pa.Array:
    """A duration timeline's column (ns), truncated as ``rerun.TimeColumn(duration=...)`` does."""
    return array((np.asarray(seconds, dtype=np.float64) * 1e9).astype("timedelta64[ns]"))


class Stream:
    """A Rerun recording stream to a file and/or a viewer, fed with arrow columns.

    ``coalesce_bytes`` > 0: consecutive sends to an entity with the same columns are held and
    sent as one chunk once they hold that many bytes (and at ``flush``/``close``). The
    columns are still built window by window, while the simulation runs; only the chunk
    boundaries move. The web viewer loads a file of a few long chunks several times faster
    than one of many short chunks (tests/test_web_viewer.py; benchmarks/RECORDING.md).
    """

    def __init__(
        self,
        application_id: str,
        recording_id: str | None,
        path: str | None,
        stream_to: str | None,
        coalesce_bytes: int = 0,
        recording: Any = None,
    ) -> None:
        self.application_id = application_id
        self.coalesce_bytes = coalesce_bytes
        # per entity: the column names of the held sends, the sends, their bytes
        self.held: dict[str, tuple[tuple, list[tuple[dict, dict]], int]] = {}
        self.own = recording is None  # a recording of our own (closed with the stream), or one given
        if recording is not None:  # an open native recording: its sinks stay as they are (a notebook viewer's)
            self.rec = recording
        else:
            self.rec = rb.new_recording(
                application_id=application_id,
                recording_id=recording_id or str(uuid.uuid4()),
                make_default=False,
                make_thread_default=False,
                default_enabled=True,
                send_properties=True,
            )
            sinks: list[Any] = []
            if path is not None:
                sinks.append(rb.FileSink(path))
            if stream_to is not None:
                sinks.append(rb.GrpcSink(stream_to))
            rb.set_sinks(sinks, recording=self.rec)
        rb.set_log_time_enabled(False, recording=self.rec)  # deterministic files: no wall-clock timeline

    def send(self, entity: str, timelines: dict[str, pa.Array], components: dict[Descriptor, pa.Array]) -> None:
        """Temporal columns: one row per timeline value."""
        if self.coalesce_bytes <= 0:
            rb.send_arrow_chunk(entity, timelines=timelines, components=components, recording=self.rec)
            return
        names = (tuple(timelines), tuple(d.component for d in components))
        held = self.held.get(entity)
        if held is not None and held[0] != names:
            self._release(entity)
            held = None
        size = sum(a.nbytes for a in timelines.values()) + sum(a.nbytes for a in components.values())
        if held is None:
            held = (names, [], 0)
        held[1].append((timelines, components))
        self.held[entity] = (names, held[1], held[2] + size)
        if held[2] + size >= self.coalesce_bytes:
            self._release(entity)

    def _release(self, entity: str) -> None:
        """Send what is held for ``entity`` as one chunk."""
        held = self.held.pop(entity, None)
        if held is None:
            return
        sends = held[1]
        if len(sends) == 1:
            timelines, components = sends[0]
        else:
            timelines = {k: pa.concat_arrays([t[k] for t, _ in sends]) for k in sends[0][0]}
            columns = zip(*(list(c.values()) for _, c in sends), strict=True)  # same columns, same order
            components = {d: pa.concat_arrays(list(parts)) for d, parts in zip(sends[0][1], columns, strict=True)}
        rb.send_arrow_chunk(entity, timelines=timelines, components=components, recording=self.rec)

    def release(self) -> None:
        """Send everything held."""
        for entity in list(self.held):
            self._release(entity)

    def static(self, entity: str, components: dict[Descriptor, pa.Array]) -> None:
        """One static row (every component an array of the row's instances)."""
        rb.log_arrow_msg(entity, components=components, static_=True, recording=self.rec)

    def recording_name(self, name: str) -> None:
        rb.send_recording_name(name, recording=self.rec)

    def property(self, entity: str, /, **values: Any) -> None:
        """Static run metadata at /__properties/<name>; empty values are left out (Rerun drops them)."""
        kept = {any_value(k): _one(v) for k, v in values.items() if v is not None and v != ""}
        self.static(f"/__properties/{entity}", kept)

    def blueprint(self, rows: list[tuple[str, dict[Descriptor, pa.Array], bool]]) -> None:
        """Send a blueprint given as (entity, components, static) rows: the layout the viewer opens."""
        bp = rb.new_blueprint(
            application_id=self.application_id, make_default=False, make_thread_default=False, default_enabled=True
        )
        rb.set_time_sequence("blueprint", 0, recording=bp)
        for entity, components, static in rows:
            rb.log_arrow_msg(entity, components=components, static_=static, recording=bp)
        storage = rb.memory_recording(recording=bp)
        if storage is None:  # only a disabled stream has no memory sink
            raise RuntimeError("rerun gave the blueprint stream no memory sink")
        rb.send_blueprint(storage, make_active=True, make_default=True, recording=self.rec)

    def flush(self, timeout_sec: float = 1e38) -> None:
        rb.flush(timeout_sec=timeout_sec, recording=self.rec)

    def close(self) -> None:
        """Send what is held, flush and finalize: the file gets its footer (a given recording is only
        flushed: it stays open for its owner)."""
        self.release()
        if self.own:
            rb.disconnect(recording=self.rec)
        else:
            rb.flush(timeout_sec=1e38, recording=self.rec)
