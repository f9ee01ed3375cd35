"""The writer process of a ``Recorder(background=True)``.

Kept apart from ``sink`` so that the simulating process, which only forks this,
never loads rerun: the child loads its native layer (``native``, about 10 ms; the
``rerun`` package itself, 0.6 s, is never imported) while the simulation runs.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from .sink_settings import SinkSettings


def serve(queue, conn, settings: SinkSettings, arena=None, freed=None) -> None:
    """A writer process: a Sink fed from ``queue`` with ("add", [(label, packed samples, info), ...],
    slot) and ("close",) messages; answers on ``conn`` ("closed", plotted), ("lost", text) when the viewer
    streamed to did not take it all (``sink_settings.StreamError``), or ("error", text).
    Packed arrays in a slot of ``arena`` are copied out and the slot number sent back on ``freed``.
    When the simulating process dies, the file is closed too, so every tick sent is readable."""
    import os
    import queue as queues
    import signal

    parent = os.getppid()
    # the writer ends when its recorder says so or dies, not on a signal: Ctrl-C in a terminal
    # reaches the whole process group, and the recorder, interrupted, closes the file through it
    for s in (signal.SIGINT, signal.SIGTERM):
        signal.signal(s, signal.SIG_IGN)
    sink = None
    try:
        from .sample import unpack
        from .sink import Sink  # rerun's native layer is loaded here, in the writer, not in the simulating process

        sink = Sink(settings)
        layouts: dict[str | None, dict] = {}
        while True:
            try:
                msg = queue.get(timeout=1.0)
            except queues.Empty:
                if os.getppid() != parent:  # orphaned: the simulating process is gone
                    break
                continue
            except (EOFError, OSError):
                break
            if msg[0] == "add":
                _, runs, slot = msg
                unpacked = [
                    (label, unpack(packed, layouts.setdefault(label, {}), arena), info) for label, packed, info in runs
                ]
                if slot is not None and freed is not None:
                    try:
                        freed.send(slot)  # copied out: the simulating process may refill it
                    except OSError:  # the simulating process is gone: write what it sent all the same
                        freed = None
                for label, samples, info in unpacked:
                    for k, sample in enumerate(samples):
                        sink.add(label, sample, info if k == 0 else None)
            else:
                break
        sink.close()
        conn.send(("closed", sink.plotted()))
    except BaseException as e:  # report it to the recorder: one line
        from .sink_settings import StreamError

        if sink is not None:
            try:
                sink.close()
            except Exception:
                pass
        try:
            if isinstance(e, StreamError):  # the file, if any, is complete: the viewer went without
                conn.send(("lost", str(e)))
            else:
                conn.send(("error", f"{type(e).__name__}: {e}"))
        except Exception:
            pass


def run(queue, conn, settings: SinkSettings, arena=None, freed=None) -> None:
    """The writer process's target: ``serve``, then exit at once. The file is complete and the
    reply sent by then; the interpreter's teardown (rerun's and arrow's threads and modules,
    20-40 ms) would only hold up the recorder, which joins this process in ``close``."""
    import os

    serve(queue, conn, settings, arena, freed)
    os._exit(0)
