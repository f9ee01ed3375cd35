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
    native.py     the Rerun stream: arrow columns to ``rerun_bindings``, without ``import rerun``
    sink.py       the writing side: a Rerun stream fed with sampled ticks, here or in a
                  writer process of its own (``background=True``)
    writer.py     the writer process's entry point
    schema.py     every entity path, field name, unit and dtype (shared with playback)

No module of the recorder imports the ``rerun`` package (0.6 s of CPU): the writing side
loads only its native layer, ``rerun_bindings`` (10 ms), and with ``background=True``
only the writer process does even that.

``log`` only samples (tens of microseconds). Every ``flush_every`` ticks the scene
goes out as columns; the plotted per-contact series go out every ``series_every``
ticks and at the end. A writer process (``background=True``, file only) writes long
chunks instead: it holds an entity's windows until they make about 8 MB and writes
the stats and residuals every ``series_every`` ticks, because Rerun's viewer loads a
few long chunks much faster than many short ones (212 chunks -> 77 for pyramid_20's
600 ticks: fully drawn in the web viewer in about half the time).

Leaving the ``with`` block, ``close()``, or losing the last reference writes what is
buffered and the file footer, so a run that raised part-way leaves a readable recording
of every tick logged before the failure.

``stream_to`` (a ``rerun+http://.../proxy`` URL) also streams every window to a
running viewer while the simulation runs (``phys2d run --live``).
"""

from __future__ import annotations

import dataclasses
import os
import socket
import sys
import warnings
import weakref
from typing import TYPE_CHECKING, Any, TypedDict

import numpy as np

from .arena import SlotWriter
from .buffer import ContactChoice, as_choice
from .sample import Sample, Sampler, pack, window_parts
from .sink_settings import STREAM_FLUSH_S, SinkSettings, StreamError

if TYPE_CHECKING:
    from typing_extensions import Unpack  # typing.Unpack from Python 3.11; annotations only

KEYFRAME_EVERY = 60  # ticks between keyframes, by default (``Recorder``)


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


def _check_every(value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"keyframe_every must be an integer (ticks; 0 for none), got {type(value).__name__}")
    if value < 0:
        raise ValueError(f"keyframe_every must be >= 0 (ticks; 0 for none), got {value}")
    return int(value)


def _check_label(run: Any) -> str:
    if not isinstance(run, str):
        raise TypeError(f"run must be a str, got {type(run).__name__}")
    if not run or not all(ch.isalnum() or ch in "-_." for ch in run):
        raise ValueError(f"run must be a non-empty name of letters, digits, '-', '_' or '.', got {run!r}")
    return run


VIEWER_CONNECT_S = 2.0  # s: how long the check of a viewer's port waits for an answer
STUCK_S = 15.0  # s: after STREAM_FLUSH_S, how much longer a stream-only close waits for its writer


def _check_listening(stream_to: str) -> None:
    """A ValueError unless something listens at ``stream_to``'s host and port: with no viewer there,
    rerun's gRPC sink holds every message it cannot send until its queue is full, and then blocks
    the recording, file and all, for good."""
    from urllib.parse import urlsplit

    try:
        where = urlsplit(stream_to.split("+", 1)[-1])
        host, port = where.hostname, where.port or {"http": 80, "https": 443}.get(where.scheme)
    except ValueError as e:
        raise ValueError(f"stream_to {stream_to!r} is not a viewer URL: {e}") from None
    if not host or port is None:
        raise ValueError(f"stream_to {stream_to!r} names no host and port (like 'rerun+http://127.0.0.1:9876/proxy')")
    try:
        socket.create_connection((host, port), timeout=VIEWER_CONNECT_S).close()
    except OSError as e:
        raise ValueError(f"stream_to: no viewer listens at {stream_to} ({e}); start one (`rerun`) first") from None


def _native_of(recording: Any, path: Any, stream_to: str | None, background: Any) -> Any:
    """The native side of ``recording``, a ``rerun.RecordingStream`` to log into (None: none given),
    checked to be one and to come without a path, stream_to or background of the recorder's own."""
    if recording is None:
        return None
    if not hasattr(recording, "to_native"):
        raise TypeError(f"recording must be a rerun.RecordingStream, got {type(recording).__name__}")
    if path is not None or stream_to is not None or background:
        raise ValueError(
            "recording: a recorder logging into a given RecordingStream takes no path, stream_to or background"
        )
    return recording.to_native()


class _Local:
    """The Sink in this process."""

    def __init__(self, settings: SinkSettings, recording: Any) -> None:
        from .sink import Sink

        self.sink = Sink(settings, recording)

    def add(self, label: str | None, s: Sample, info: dict[str, Any] | None) -> None:
        self.sink.add(label, s, info)

    def close(self) -> dict[str | None, list[str]]:
        self.sink.close()
        return self.sink.plotted()


class _Background:
    """The Sink in a writer process of its own (forked: it starts at once and imports rerun
    there); ticks go over a queue a window at a time, their arrays through a shared arena
    (``arena``: one copy in, one copy out, no pickling) when a slot is free, else pickled, so a
    busy writer never holds up the simulation."""

    def __init__(self, settings: SinkSettings, window: int) -> None:
        import multiprocessing as mp

        from .arena import Arena
        from .writer import run

        ctx = mp.get_context("fork")
        self.queue = ctx.Queue()
        self.arena = Arena()  # before the fork: the writer shares it
        self.reply, child = ctx.Pipe(duplex=False)
        self.freed, child_freed = ctx.Pipe(duplex=False)  # the writer hands slots back
        self.proc = ctx.Process(
            target=run,
            args=(self.queue, child, settings, self.arena, child_freed),
            daemon=True,
            name="phys2d-recording-writer",
        )
        self.proc.start()
        child.close()
        child_freed.close()
        self.window = window
        self.settings = settings
        self.free = list(range(self.arena.slots))
        self.pending: list[tuple[str | None, Sample, dict[str, Any] | None]] = []
        self.sent: dict[str | None, set[int]] = {}  # per run, the layout versions the writer has

    def add(self, label: str | None, s: Sample, info: dict[str, Any] | None) -> None:
        self.pending.append((label, s, info))
        if len(self.pending) >= self.window:
            self._send()

    def _free_slot(self) -> int | None:
        """A slot the writer is done with, or None while the writer is behind (then the window
        goes pickled: the simulation never waits for the writer)."""
        try:
            while self.freed.poll():
                self.free.append(self.freed.recv())
        except (EOFError, OSError):
            raise RuntimeError("the recording's writer process stopped") from None
        return self.free.pop() if self.free else None

    def _send(self) -> None:
        """The pending ticks as one message: per run, its samples packed into a few long arrays,
        in a slot of the arena when they fit (else pickled with the message)."""
        if self.pending:
            if not self.proc.is_alive():
                raise RuntimeError("the recording's writer process stopped")
            runs: dict[str | None, list[Sample]] = {}
            infos: dict[str | None, dict[str, Any]] = {}
            for label, s, info in self.pending:
                runs.setdefault(label, []).append(s)
                if info is not None:
                    infos[label] = info
            parts = [p for ss in runs.values() for p in window_parts(ss)]
            free = self._free_slot() if self.arena.fits(parts) else None
            slot = None if free is None else SlotWriter(self.arena, free)
            # the layouts the writer will know once this message is in the queue, and not before: an
            # interrupt (Ctrl-C, SIGTERM) in between must leave them unsent, to go with the next message
            sent = {label: set(self.sent.get(label, ())) for label in runs}
            packed = [(label, pack(ss, sent[label], slot), infos.get(label)) for label, ss in runs.items()]
            self.queue.put(("add", packed, None if slot is None else slot.slot))
            self.pending = []
            self.sent.update(sent)

    def _answer(self) -> tuple:
        """The writer's answer to "close". A file is waited for as long as it takes. A stream
        alone is not: rerun can block the writer for good on a peer that takes the connection
        but never the data, so after ``STREAM_FLUSH_S`` and ``STUCK_S`` more with no answer,
        ("stuck", why): ``close`` stops the writer (the viewer would not take the rest)."""
        stream_to = self.settings.stream_to
        if self.settings.path is None and stream_to is not None:
            waited = STREAM_FLUSH_S + STUCK_S
            if not self.reply.poll(waited):
                return ("stuck", f"the viewer at {stream_to} did not take the recording ({waited:g} s without end)")
        return self.reply.recv()

    def close(self) -> dict[str | None, list[str]]:
        reply: tuple = ("error", "the recording's writer process stopped")
        told = False
        try:
            self._send()
            self.queue.put(("close",))
            told = True
            reply = self._answer()
        except (EOFError, OSError, RuntimeError):
            reply = ("error", "the recording's writer process stopped")
        finally:
            if not told and self.proc.is_alive():  # whatever stopped the last window (an interrupt, say),
                self.queue.put(("close",))  # the writer completes the file with the ticks it has
            if reply[0] == "stuck":  # blocked in rerun for good: there is no file to finish
                self.proc.kill()
                self.queue.cancel_join_thread()  # what it never read is dropped at exit
            # once the reply is in, the file is complete: the writer's exit (unmapping its memory,
            # ~20 ms) need not be waited for; multiprocessing reaps it at the latest at exit
            self.proc.join(0 if reply[0] == "closed" else 60)
            self.reply.close()
            self.freed.close()
            self.queue.close()
        if reply[0] in ("lost", "stuck"):
            raise StreamError(reply[1])
        if reply[0] == "error":
            raise RuntimeError(f"writing the recording failed: {reply[1]}")
        return reply[1]


class _State:
    """What a Recorder closes, by ``close`` or its finalizer."""

    def __init__(self, backend: _Local | _Background) -> None:
        self.backend = backend
        self.closed = False
        self.plotted: dict[str | None, list[str]] = {}

    def close(self) -> None:
        if not self.closed:
            self.closed = True
            self.plotted = self.backend.close()


class SinkOptions(TypedDict, total=False):
    """``Recorder``'s keywords that become its sink's ``SinkSettings`` (``Recorder`` says what each
    means; ``SINK_DEFAULTS`` gives the defaults)."""

    name: str | None
    scene: str | None
    application_id: str
    recording_id: str | None
    contact_series: bool
    plot: ContactChoice | str | None
    flush_every: int
    series_every: int
    blueprint: bool
    stream_to: str | None


SINK_DEFAULTS: dict[str, Any] = {
    "name": None, "scene": None, "application_id": "phys2d", "recording_id": None, "contact_series": True,
    "plot": None, "flush_every": 60, "series_every": 600, "blueprint": True, "stream_to": None,
}  # fmt: skip


def _checked_settings(path: Any, native: Any, sink: dict[str, Any]) -> SinkSettings:
    """``sink`` (``SinkOptions``, defaults filled) checked, a TypeError or ValueError naming the
    first bad one, then ``path`` checked and its folders made: the sink's settings."""
    for arg in ("name", "scene", "recording_id"):
        if sink[arg] is not None and not isinstance(sink[arg], str):
            raise TypeError(f"{arg} must be a str or None, got {type(sink[arg]).__name__}")
    application_id = sink["application_id"]
    if not isinstance(application_id, str) or not application_id:
        raise TypeError(f"application_id must be a non-empty str, got {application_id!r}")
    for arg in ("contact_series", "blueprint"):
        if not isinstance(sink[arg], (bool, np.bool_)):
            raise TypeError(f"{arg} must be True or False, got {sink[arg]!r}")
    choice = as_choice(sink["plot"])
    flush_every = _check_count(sink["flush_every"], "flush_every")
    series_every = _check_count(sink["series_every"], "series_every")
    stream_to = sink["stream_to"]
    if stream_to is not None:  # (last of the checks that make nothing; then the file is made)
        _check_listening(stream_to)
    p = None if path is None and (stream_to is not None or native is not None) else _checked_path(path)
    return SinkSettings(
        p, sink["name"], sink["scene"], application_id, sink["recording_id"], bool(sink["contact_series"]), choice,
        flush_every, series_every, bool(sink["blueprint"]), stream_to,
    )  # fmt: skip


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
    flush_every   ticks buffered before the scene is written (a hard crash of an in-process
                  recorder loses at most these)
    series_every  ticks buffered before the plotted series are written
    blueprint     store a layout (world beside the plots) in the file
    stream_to     a viewer's ``rerun+http://HOST:PORT/proxy`` URL to stream to as well; a ValueError
                  at once if nothing listens there
    keyframe_every  re-enterable recordings (``playback.world_at``, ``phys2d replay``, ``phys2d branch``):
                  a keyframe (the world's snapshot, zlib-compressed) on a run's first tick and
                  then every this many ticks (0: none), besides every tick's state hash, dt and
                  the responder (its class and settings, when they change). The default,
                  ``KEYFRAME_EVERY``, adds about 6 % to pyramid_20's 600-tick recording
    recording     a ``rerun.RecordingStream`` to log into instead of a file of its own (its sinks stay
                  its own: a notebook viewer's, say); closing the recorder flushes it and leaves it open
    background    write from a process of its own: this process only samples and hands windows
                  of ticks over, so loading rerun's native layer and the encoding run on another
                  core meanwhile (``phys2d run`` does this), and the file gets long chunks (the
                  writer outlives a killed simulation and still writes what it holds); needs
                  fork, so Linux only, elsewhere the recorder writes in this process

    Call ``log(w)`` after each ``w.step``; for comparisons log several worlds into one
    file with ``log(w, run="pgs")`` (each run under ``runs/<run>/``, same timelines).
    A replay steps from a keyframe with the recorded dts and responders: change the world
    from outside the step (a force, a mouse target, a body added or moved) between a step and
    its ``log``, and log that tick with ``keyframe=True``, or a replay through it finds its
    state hash differs and says so.
    Use as a context manager, or call ``close()``. ``schema`` describes the file.
    """

    def __init__(
        self,
        path: str | os.PathLike | None,
        *,
        background: bool = False,
        keyframe_every: int = KEYFRAME_EVERY,
        recording: Any = None,
        **options: Unpack[SinkOptions],
    ) -> None:
        sink = {**SINK_DEFAULTS, **options}
        unknown = sorted(set(options) - set(SINK_DEFAULTS))
        if unknown:
            raise TypeError(f"Recorder() got an unexpected keyword argument {unknown[0]!r}")
        stream_to = sink["stream_to"]
        if stream_to is not None and (not isinstance(stream_to, str) or "://" not in stream_to):
            raise TypeError(
                f"stream_to must be a viewer URL like 'rerun+http://127.0.0.1:9876/proxy', got {stream_to!r}"
            )
        native = _native_of(recording, path, stream_to, background)
        if not isinstance(background, (bool, np.bool_)):
            raise TypeError(f"background must be True or False, got {background!r}")
        self.keyframe_every = _check_every(keyframe_every)
        settings = _checked_settings(path, native, sink)
        self.path = settings.path
        self._samplers: dict[str | None, Sampler] = {}
        forks = sys.platform.startswith("linux")  # fork is safe there; macOS and Windows write in-process
        backend: _Local | _Background
        if background and forks:  # (a recording to log into comes without background: _native_of)
            backend = _Background(dataclasses.replace(settings, long_chunks=True), settings.flush_every)
        else:
            backend = _Local(settings, native)
        self._state = _State(backend)
        self._finalizer = weakref.finalize(self, _State.close, self._state)

    def log(self, world, *, run: str | None = None, keyframe: bool = False) -> None:
        """Buffer the world's current state as tick ``World.tick`` (of run ``run``); ``keyframe``:
        keep its snapshot too, whatever ``keyframe_every`` says (after a change from outside the
        step, so that a replay can start there)."""
        from ..world import World

        if self._state.closed:
            raise ValueError(f"this recorder is closed ({self.path})")
        if not isinstance(world, World):
            raise TypeError(f"world must be a phys2d World, got {type(world).__name__}")
        label = None if run is None else _check_label(run)
        if not isinstance(keyframe, (bool, np.bool_)):
            raise TypeError(f"keyframe must be True or False, got {keyframe!r}")
        sampler = self._samplers.get(label)
        info = None
        if sampler is None:
            if label is None and self._samplers:
                raise ValueError("this recorder holds named runs: pass run=<label> to every log()")
            if label is not None and None in self._samplers:
                raise ValueError("this recorder holds an unnamed run: log() without run= only")
            sampler = self._samplers[label] = Sampler(replay=True, keyframe_every=self.keyframe_every)
            info = dict(
                responder=repr(world.responder),
                responder_name=str(getattr(world.responder, "name", "")),
                bodies=len(world),
                first_tick=int(world.tick),
                keyframe_every=self.keyframe_every,
            )
        note = sampler.note
        sample = sampler.sample(world, bool(keyframe))
        if sampler.note is not None and note is None and (self.keyframe_every > 0 or keyframe):  # once: why they stop
            reason = f"recording {self.path}: no keyframes from tick {world.tick} on: {sampler.note}"
            warnings.warn(reason, stacklevel=2)
        self._state.backend.add(label, sample, info)

    def flush(self) -> None:
        """Write the ticks logged so far now, rather than at the next ``flush_every`` (a viewer fed
        by ``recording`` shows them at once); in this process only (not with ``background``)."""
        if self._state.closed:
            raise ValueError(f"this recorder is closed ({self.path})")
        backend = self._state.backend
        if isinstance(backend, _Local):
            backend.sink.flush()

    @property
    def runs(self) -> list[str | None]:
        """The run labels logged so far (``[None]`` for a single unnamed run)."""
        return list(self._samplers)

    @property
    def plotted(self) -> dict[str | None, list[str]]:
        """Per run, the contacts whose series were written (entity names); known once closed."""
        return dict(self._state.plotted)

    @property
    def closed(self) -> bool:
        return self._state.closed

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
