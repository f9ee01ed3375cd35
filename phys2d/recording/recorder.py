"""A World's ticks to a Rerun recording (.rrd), small and cheap.

    with phys2d.Recorder("recordings/pyramid.rrd", name="pyramid / pgs") as rec:
        for _ in range(600):
            w.step(1 / 60)
            rec.log(w)

The work is split by job, one module each:

    sample.py     reads a World through its public read-only accessors and copies one tick
    buffer.py     keeps a run's ticks until they are written; which contacts get plots
    columns.py    writes buffered ticks as a few columnar sends per entity
    blueprint.py  the layout the file opens with
    schema.py     every entity path, field name, unit and dtype (shared with playback)

``log`` only samples (tens of microseconds). Every ``flush_every`` ticks the scene
goes out as columns; the plotted per-contact series go out every ``series_every``
ticks and at the end. Leaving the ``with`` block, ``close()``, or losing the last
reference writes what is buffered and the file footer, so a run that raised
part-way leaves a readable recording of every tick logged before the failure.

``stream_to`` (a ``rerun+http://.../proxy`` URL) also streams every window to a
running viewer while the simulation runs (``phys2d run --live``).
"""

from __future__ import annotations

import os
import uuid
import weakref
from typing import Any

import numpy as np
import rerun as rr

from . import blueprint as bp
from . import columns, schema
from .buffer import ContactChoice, RunBuffer, as_choice
from .sample import Sampler


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


def _send_property(rec: rr.RecordingStream, entity: str, **values: Any) -> None:
    """Static run metadata at /__properties/<name>; empty values are left out (Rerun drops them)."""
    kept = {k: v for k, v in values.items() if v is not None and v != ""}
    rec.send_property(entity, rr.AnyValues(**kept))


class _Run:
    """One run: its sampler and its buffer."""

    def __init__(self, label: str | None, choice: ContactChoice) -> None:
        self.sampler = Sampler()
        self.buffer = RunBuffer(label, schema.run_prefix(label), choice)


class _Sink:
    """The stream and the runs' buffers; closed once, by ``Recorder.close`` or a finalizer."""

    def __init__(self, path: str | None, name: str | None, scene: str | None, application_id: str,
                 recording_id: str | None, contact_series: bool, choice: ContactChoice, flush_every: int,
                 series_every: int, blueprint: bool, stream_to: str | None) -> None:
        self.scene = scene
        self.contact_series = contact_series
        self.choice = choice
        self.flush_every = flush_every
        self.series_every = series_every
        self.blueprint = blueprint
        self.runs: dict[str | None, _Run] = {}
        self.closed = False
        self.sent_views: list[bp.RunView] | None = None  # the runs the blueprint in the file shows
        self.rec = rr.RecordingStream(application_id, recording_id=recording_id or str(uuid.uuid4()))
        sinks: list[Any] = []
        if path is not None:
            sinks.append(rr.FileSink(path))
        if stream_to is not None:
            sinks.append(rr.GrpcSink(stream_to))
        self.rec.set_sinks(*sinks)
        self.rec.set_log_time_enabled(False)  # deterministic files: no wall-clock timeline
        if name:
            self.rec.send_recording_name(name)
        from .. import __version__

        _send_property(self.rec, schema.PROPERTIES_ENGINE, engine_version=__version__, scene=scene, name=name)

    def run(self, label: str | None) -> _Run:
        r = self.runs.get(label)
        if r is None:
            if label is None and self.runs:
                raise ValueError("this recorder holds named runs: pass run=<label> to every log()")
            if label is not None and None in self.runs:
                raise ValueError("this recorder holds an unnamed run: log() without run= only")
            r = _Run(label, self.choice)
            colour = schema.PALETTE[len(self.runs) % len(schema.PALETTE)]
            self.runs[label] = r
            columns.write_start(self.rec, r.buffer, colour)
        return r

    def log(self, w, label: str | None) -> None:
        r = self.run(label)
        b = r.buffer
        first = not b.samples and b.bounds is None
        s = r.sampler.sample(w)
        if first:
            _send_property(self.rec, schema.run_property(label), responder=repr(w.responder),
                           responder_name=str(getattr(w.responder, "name", "")), scene=self.scene, run=label,
                           bodies=len(w), first_tick=int(w.tick), plotted=repr(self.choice))
        b.add(s, self.contact_series)
        if len(b.samples) >= self.flush_every:
            if self.sent_views is None:  # the layout goes before the data: the viewer draws it from the start
                self.send_blueprint()
            columns.write_scene(self.rec, b)
            self.rec.flush(timeout_sec=0)  # start writing this window now: a hard kill loses less
        if b.series_ticks >= self.series_every:
            columns.write_series(self.rec, b)

    def send_blueprint(self) -> None:
        """The layout for the runs as they are now, unless the file already has that one.

        It is sent before the first window of data (a viewer without it builds a view per entity,
        slow to draw while the file loads) and again at the end only if the runs changed.
        """
        if not self.blueprint:
            return
        views = [bp.RunView(r.buffer.label, r.buffer.bounds, r.buffer.plotted or self._will_plot(r),
                            r.buffer.has_joints) for r in self.runs.values()]
        if views != self.sent_views:
            self.rec.send_blueprint(bp.build(views))
            self.sent_views = views

    def _will_plot(self, r: _Run) -> bool:
        return self.contact_series and any(k.size for k in r.buffer.contacts.keys)

    def close(self) -> None:
        if self.closed:
            return
        self.closed = True
        try:
            for r in self.runs.values():
                columns.write_scene(self.rec, r.buffer)
                columns.write_series(self.rec, r.buffer)
            self.send_blueprint()
            self.rec.flush()
        finally:
            self.rec.disconnect()  # writes the footer: the file is complete and readable


class Recorder:
    """Records a World's ticks to a Rerun ``.rrd`` file.

    path          where to write (parent folders are created); checked for writability
                  at once, so a bad path fails before any stepping; None only with stream_to
    name          the recording's name in the viewer, e.g. ``"pyramid / pgs"``
    scene         the scene's name, stored with the run
    contact_series  write lambda and penetration time series (float64) for the contacts
                  chosen by ``plot``; the per-tick contact table on ``world/sim/contacts``
                  always holds every contact
    plot          which contacts get series: a ``ContactChoice``, a str such as
                  ``"deepest:4"``, ``"body:7"`` or ``"b3-b7/f512,b0-b1/f0"``, or None
                  (the 4 deepest contacts)
    flush_every   ticks buffered before the scene is written (a hard crash loses at most these)
    series_every  ticks buffered before the plotted series are written
    blueprint     store a layout (world beside the plots) in the file
    stream_to     a viewer's ``rerun+http://HOST:PORT/proxy`` URL to stream to as well

    Call ``log(w)`` after each ``w.step``; for comparisons log several worlds into one
    file with ``log(w, run="pgs")`` (each run under ``runs/<run>/``, same timelines).
    Use as a context manager, or call ``close()``. ``schema`` describes the file.
    """

    def __init__(self, path: str | os.PathLike | None, *, name: str | None = None, scene: str | None = None,
                 application_id: str = "phys2d", recording_id: str | None = None,
                 contact_series: bool = True, plot: ContactChoice | str | None = None, flush_every: int = 60,
                 series_every: int = 600, blueprint: bool = True, stream_to: str | None = None) -> None:
        if stream_to is not None and (not isinstance(stream_to, str) or "://" not in stream_to):
            raise TypeError(f"stream_to must be a viewer URL like 'rerun+http://127.0.0.1:9876/proxy', "
                            f"got {stream_to!r}")
        p = None if path is None and stream_to is not None else _checked_path(path)
        for value, arg in ((name, "name"), (scene, "scene"), (recording_id, "recording_id")):
            if value is not None and not isinstance(value, str):
                raise TypeError(f"{arg} must be a str or None, got {type(value).__name__}")
        if not isinstance(application_id, str) or not application_id:
            raise TypeError(f"application_id must be a non-empty str, got {application_id!r}")
        for value, arg in ((contact_series, "contact_series"), (blueprint, "blueprint")):
            if not isinstance(value, (bool, np.bool_)):
                raise TypeError(f"{arg} must be True or False, got {value!r}")
        choice = as_choice(plot)
        flush_every = _check_count(flush_every, "flush_every")
        series_every = _check_count(series_every, "series_every")
        self.path = p
        self._sink = _Sink(p, name, scene, application_id, recording_id, bool(contact_series), choice, flush_every,
                           series_every, bool(blueprint), stream_to)
        self._finalizer = weakref.finalize(self, _Sink.close, self._sink)

    def log(self, world, *, run: str | None = None) -> None:
        """Buffer the world's current state as tick ``world.tick`` (of run ``run``)."""
        from ..world import World

        if self._sink.closed:
            raise ValueError(f"this recorder is closed ({self.path})")
        if not isinstance(world, World):
            raise TypeError(f"world must be a phys2d World, got {type(world).__name__}")
        self._sink.log(world, None if run is None else _check_label(run))

    @property
    def runs(self) -> list[str | None]:
        """The run labels logged so far (``[None]`` for a single unnamed run)."""
        return list(self._sink.runs)

    @property
    def plotted(self) -> dict[str | None, list[str]]:
        """Per run, the contacts whose series were written so far (entity names)."""
        return {label: [schema.contact_entity(k) for k in sorted(r.buffer.styled)]
                for label, r in self._sink.runs.items()}

    @property
    def closed(self) -> bool:
        return self._sink.closed

    def close(self) -> None:
        """Write what is buffered, the blueprint and the file footer; idempotent."""
        self._finalizer()

    def __enter__(self) -> Recorder:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __repr__(self) -> str:
        state = "closed" if self.closed else "open"
        return f"<Recorder {self.path!r} ({state}), runs={self.runs}>"
