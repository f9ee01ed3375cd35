"""What a ``Recorder`` tells the writing side of its recording (``sink.Sink``), in one record.

Kept apart from ``sink`` so that the recorder, in the simulating process, names it without
loading rerun's native layer (``sink`` imports ``native``).
"""

from __future__ import annotations

from dataclasses import dataclass

from .buffer import ContactChoice


class StreamError(RuntimeError):
    """The viewer a recording streamed to (``stream_to``) did not take all of it: gone, or not
    done within ``STREAM_FLUSH_S`` of the close. A file written beside the stream is complete
    all the same. (A ``stream_to`` where nothing listens is refused when the recorder is made.)"""


STREAM_FLUSH_S = 30.0  # s: how long a close waits for the viewer streamed to to take the rest


@dataclass(frozen=True)
class SinkSettings:
    """What a ``Recorder`` tells its sink, checked by the recorder (its arguments of the same
    names; ``choice`` is its ``plot``): where and under which names to write, what to write, and
    how often. ``long_chunks``: hold an entity's windows and write them as one chunk (a writer
    process of its own, writing a file)."""

    path: str | None
    name: str | None
    scene: str | None
    application_id: str
    recording_id: str | None
    contact_series: bool
    choice: ContactChoice
    flush_every: int
    series_every: int
    blueprint: bool
    stream_to: str | None
    long_chunks: bool = False
