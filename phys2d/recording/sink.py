"""The writing side of a recording: sampled ticks in, a Rerun stream (file, viewer) out.

``Sink`` runs in the recording process, or in a writer process of its own
(``writer.serve``): a ``Recorder(background=True)`` samples in the simulating process and
hands whole windows of ticks over a pipe, so that loading rerun's native layer, building
the columns and encoding them happen on another core while the simulation runs.
"""

from __future__ import annotations

from typing import Any

from . import blueprint as bp
from . import columns, schema
from .buffer import RunBuffer
from .native import Stream
from .sample import Sample
from .sink_settings import STREAM_FLUSH_S, SinkSettings, StreamError

COALESCE_BYTES = 8 << 20  # windows of an entity are sent as one chunk of about this many bytes


class Sink:
    """The stream and the runs' buffers; closed once, by ``Recorder.close`` or a finalizer."""

    def __init__(self, settings: SinkSettings, recording: Any = None) -> None:
        """``recording``: the native side of a ``rerun.RecordingStream`` to log into, or None."""
        self.settings = settings
        self.runs: dict[str | None, RunBuffer] = {}
        self.closed = False
        self.sent_views: list[bp.RunView] | None = None  # the runs the blueprint in the file shows
        # Long chunks (a file only; a viewer streamed to draws each window as it comes): an entity's
        # windows are held and written as one chunk, and the stats and residuals go out every
        # series_every ticks. Only for a writer process: it outlives a killed simulation and still
        # writes what it holds, where an in-process writer loses it (then every window is written
        # at once: a hard kill loses at most flush_every ticks).
        self.long_chunks = settings.long_chunks and settings.stream_to is None and recording is None
        name = settings.name
        self.rec = Stream(
            settings.application_id,
            settings.recording_id,
            settings.path,
            settings.stream_to,
            coalesce_bytes=COALESCE_BYTES if self.long_chunks else 0,
            recording=recording,
        )
        if name:
            self.rec.recording_name(name)
        from .. import __version__

        self.rec.property(schema.PROPERTIES_ENGINE, engine_version=__version__, scene=self.settings.scene, name=name)

    def add(self, label: str | None, s: Sample, info: dict[str, Any] | None) -> None:
        """One sampled tick of run ``label``; ``info`` (responder, ...) with a run's first tick."""
        b = self.runs.get(label)
        if b is None:
            b = self.runs[label] = RunBuffer(label, schema.run_prefix(label), self.settings.choice)
            columns.write_start(self.rec, b, schema.PALETTE[(len(self.runs) - 1) % len(schema.PALETTE)])
        if info is not None:
            scene, plotted = self.settings.scene, repr(self.settings.choice)
            self.rec.property(schema.run_property(label), scene=scene, run=label, plotted=plotted, **info)
        b.add(s, self.settings.contact_series)
        if len(b.samples) >= self.settings.flush_every:
            if self.sent_views is None:  # the layout goes before the data: the viewer draws it from the start
                self.send_blueprint()
            columns.write_scene(self.rec, b)
            if not self.long_chunks or b.stats_ticks >= self.settings.series_every:
                columns.write_stats(self.rec, b)
            self.rec.flush(timeout_sec=0)  # start writing this window now: a hard kill loses less
        if b.series_ticks >= self.settings.series_every:
            columns.write_series(self.rec, b)

    def flush(self) -> None:
        """Write every run's buffered ticks now (the scene, stats and residuals; the plotted series
        wait for ``series_every`` ticks or the end), and the layout if the runs changed."""
        for r in self.runs.values():
            if r.samples:
                columns.write_scene(self.rec, r)
                columns.write_stats(self.rec, r)
        if self.runs:
            self.send_blueprint()
        self.rec.flush(timeout_sec=0)

    def send_blueprint(self) -> None:
        """The layout for the runs as they are now, unless the file already has that one.

        It is sent before the first window of data (a viewer without it builds a view per entity,
        slow to draw while the file loads) and again at the end only if the runs changed.
        """
        if not self.settings.blueprint:
            return
        views = [
            bp.RunView(r.label, r.bounds, r.plotted or self._will_plot(r), r.has_joints) for r in self.runs.values()
        ]
        if views != self.sent_views:
            self.rec.blueprint(bp.build(views))
            self.sent_views = views

    def _will_plot(self, r: RunBuffer) -> bool:
        return self.settings.contact_series and any(k.size for k in r.contacts.keys)

    def plotted(self) -> dict[str | None, list[str]]:
        """Per run, the contacts whose series were written (entity names)."""
        return {label: [schema.contact_entity(k) for k in sorted(r.styled)] for label, r in self.runs.items()}

    def close(self) -> None:
        if self.closed:
            return
        self.closed = True
        stream_to, lost = self.settings.stream_to, None
        try:
            for r in self.runs.values():
                columns.write_scene(self.rec, r)
                columns.write_stats(self.rec, r)
                columns.write_series(self.rec, r)
            self.send_blueprint()
            if stream_to is None:
                self.rec.flush()
            else:  # a viewer may never take it all (unreached, gone): rerun's flush would wait forever
                try:
                    self.rec.flush(timeout_sec=STREAM_FLUSH_S)
                except RuntimeError as e:
                    lost = str(e)
        finally:
            self.rec.close()  # writes the footer: the file is complete and readable
        if lost is not None:
            kept = f"; {self.settings.path} is complete" if self.settings.path else ""
            raise StreamError(f"the viewer at {stream_to} did not take the whole recording ({lost}){kept}")
