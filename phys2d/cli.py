"""The ``phys2d`` command (also ``python -m phys2d``).

    phys2d scenes                       the stock scenes and what --size means
    phys2d run SCENE [--size N] [--responder NAME] [--sweeps K | --passes K | --substeps K]
                     [--steps N] [--dt S] [--out PATH | --no-record] [--no-series]
                     [--plot-deepest N | --plot-body UID | --plot-contacts NAMES] [--live [spawn|web|URL]]
    phys2d compare SCENE [--size N] [--steps N] [--dt S] [--out PATH] [--no-series] [counts]
    phys2d inspect PATH                 a summary table of a recording
    phys2d view PATH [--web]            the Rerun viewer, or the web viewer on 127.0.0.1
    phys2d replay PATH [--check] [--run LABEL]      a recording's keyframes; --check steps it again
    phys2d branch PATH --at TICK --responder NAME [--steps N] [-o OUT] [counts] [--run LABEL]
                                        the future from a tick under another responder, beside the original
    phys2d sweep [GRID.toml] [--scenes ...] ...    a grid of runs to one Parquet table (phys2d/sweeps/command.py)
    phys2d check FILE.py:CLASS [--quick] [--json] [--out DIR]   a responder's report card (phys2d/checks/)
    phys2d --version

Counts: ``--sweeps`` (PGS), ``--passes`` (iterative) and ``--substeps`` (soft-step) are
each accepted only by responders that take them (``phys2d.responders.REGISTRY``);
``--iterations`` is an alias for whichever of the three the responder takes.

Bad arguments and failures print one line on stderr and exit non-zero (2 for usage
errors, 1 for the rest); set PHYS2D_DEBUG=1 to see tracebacks of unexpected errors.

Subcommands are listed in ``COMMANDS``: to add one, write ``add_<name>(sub)`` that
registers its parser (``set_defaults(func=...)``) and append it there.
"""

from __future__ import annotations

import argparse
import difflib
import gc
import inspect as pyinspect
import json
import os
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from typing import TYPE_CHECKING, Any, NoReturn, TextIO, cast

import numpy as np

from . import scenes
from .interrupts import KeptInterrupts
from .recording.sink_settings import STREAM_FLUSH_S, StreamError
from .responders import REGISTRY
from .responders.base import Responder
from .verdict import Watch, watch_for
from .world import SimulationError, World

if TYPE_CHECKING:
    from .recording import Recorder

RESPONDERS = tuple(REGISTRY)
COMPARE_ORDER = tuple(REGISTRY)  # compare runs every registered responder, in the registry's order
DEFAULT_DIR = "recordings"
COUNT_OPTIONS = ("sweeps", "passes", "substeps")  # the registry's names of a responder's count
SINGULAR = {"sweeps": "sweep", "passes": "pass", "substeps": "sub-step"}


class CLIError(Exception):
    """A failure to report as one line, exit code 1."""


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> NoReturn:  # one line, not argparse's usage block
        self.exit(2, f"{self.prog}: error: {message} (see '{self.prog} --help')\n")


def _whole(least: int, what: str) -> Callable[[str], int]:
    """An argparse type: a whole number >= ``least``, refused as "must be ``what``"."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"must be {what}, got {text!r}") from None
        if value < least:
            raise argparse.ArgumentTypeError(f"must be {what}, got {text!r}")
        return value

    return parse


_count = _whole(1, "a whole number >= 1")
_tick = _whole(0, "a tick number >= 0")


def _seconds(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a number of seconds > 0, got {text!r}") from None
    if not (value > 0 and np.isfinite(value)):
        raise argparse.ArgumentTypeError(f"must be a number of seconds > 0, got {text!r}")
    return value


def _size(text: str) -> int | float:
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    raise argparse.ArgumentTypeError(f"must be a number, got {text!r}")


def _port(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a port number 1-65535, got {text!r}") from None
    if not 1 <= value <= 65535:
        raise argparse.ArgumentTypeError(f"must be a port number 1-65535, got {text!r}")
    return value


def plural(n: int, word: str) -> str:
    """``1 sweep``, ``2 sweeps``: ``word`` is the plural (a registry count name or any noun + s)."""
    return f"{n} {word if n != 1 else SINGULAR.get(word, word[:-1] if word.endswith('s') else word)}"


# -- the pieces ------------------------------------------------------------------
def scene_builder(name: str) -> Callable[..., World]:
    """The builder of a stock scene, or a CLIError naming the choices."""
    if name not in scenes.SCENES:
        close = difflib.get_close_matches(name, scenes.SCENES, n=1)
        hint = f"; did you mean {close[0]!r}?" if close else ""
        raise CLIError(f"unknown scene {name!r}{hint} (choose from: {', '.join(scenes.SCENES)})")
    return cast(Callable[..., World], scenes.SCENES[name][0])


def default_size(builder: Callable[..., World]) -> Any:
    """The default of a builder's first parameter (its size)."""
    first = next(iter(pyinspect.signature(builder).parameters.values()))
    return first.default


def requested_count(args: argparse.Namespace) -> tuple[str, int] | None:
    """(option, value) of the one count option given (``iterations`` or a registry count), or None."""
    given = [
        (name, getattr(args, name)) for name in ("iterations", *COUNT_OPTIONS) if getattr(args, name, None) is not None
    ]
    if len(given) > 1:
        raise CLIError(
            f"give one of --iterations, --sweeps, --passes, --substeps, not {len(given)} "
            f"({', '.join('--' + n for n, _ in given)})"
        )
    return given[0] if given else None


def make_responder(name: str, count: tuple[str, int] | None = None, *, strict: bool = True) -> Responder:
    """A responder by its registered name, with ``count`` = (option, value) from the command line.

    ``--iterations`` goes to whichever count the responder takes; ``--sweeps``, ``--passes``
    and ``--substeps`` only to responders that take that count (with ``strict=False`` the
    others keep their default, as ``compare`` does).
    """
    if name not in REGISTRY:
        raise CLIError(f"unknown responder {name!r} (choose from: {', '.join(RESPONDERS)})")
    entry = REGISTRY[name]
    value = None
    if count is not None:
        option, n = count
        takes = entry.count
        if takes is not None and option in ("iterations", takes):
            value = n
        elif strict:
            what = f"it takes --{takes}" if takes else "it makes one pass"
            raise CLIError(f"--{option} does not apply to the {name} responder ({what})")
    return entry(value)


def build_world(scene: str, size: Any, responder: Responder) -> World:
    builder = scene_builder(scene)
    try:
        return builder(responder=responder) if size is None else builder(size, responder=responder)
    except (TypeError, ValueError) as e:
        raise CLIError(f"--size {size!r} for scene {scene!r} ({scenes.SCENES[scene][1]}): {e}") from None


def plot_choice(args: argparse.Namespace):
    """The contacts to plot, from --plot-deepest / --plot-body / --plot-contacts (None: the default)."""
    from .recording import ContactChoice

    try:
        if getattr(args, "plot_body", None) is not None:
            return ContactChoice.body(args.plot_body)
        if getattr(args, "plot_contacts", None) is not None:
            return ContactChoice.keys(args.plot_contacts)
        if getattr(args, "plot_deepest", None) is not None:
            return ContactChoice.deepest(args.plot_deepest)
    except (TypeError, ValueError) as e:
        raise CLIError(str(e)) from None
    return None


def first_step(worlds: Sequence[World], dt: float, stream: TextIO | None = None) -> None:
    """Step each world once; when numba compiles a kernel meanwhile (a first run: its disk cache
    is cold), say so in one line before it starts, so a quiet wait is not mistaken for a hang."""
    from numba.core import event

    from . import first_run
    from .pipeline import ahead

    out = sys.stderr if stream is None else stream

    class Notice(event.Listener):
        said = 0.0  # when the first compile started (0: none yet)
        names: list[str] = []
        cores = 2 if ahead.wanted() else 1  # the first step compiles on two processes (``pipeline.ahead``)

        def on_start(self, ev: event.Event) -> None:
            if not Notice.said:
                Notice.said = time.perf_counter()
                Notice.names = names = sorted({getattr(getattr(w, "responder", None), "name", "other") for w in worlds})
                if ahead.last_plan == "behind":  # an edit: only what it touched, the one-call tick aside
                    what = "the kernels an edit touched (a few seconds; the one-call step compiles aside)"
                else:  # from this machine's pace (``phys2d.first_run``)
                    about = first_run.estimate(names, Notice.cores)
                    cores = f"{Notice.cores} cores" if Notice.cores > 1 else "1 core"
                    what = f"the numba kernels for {', '.join(names)} (first run only: about {about:.0f} s on {cores})"
                print(f"phys2d: compiling {what}; cached after that ...", file=out, flush=True)

        def on_end(self, ev: event.Event) -> None:
            pass

    with event.install_listener("numba:compile", Notice()), KeptInterrupts() as kept:
        for w in worlds:
            w.step(dt)
            kept.raise_if_lost()
    if Notice.said:
        took = time.perf_counter() - Notice.said
        print(f"phys2d: compiled in {took:.0f} s", file=out, flush=True)
        if ahead.last_plan == "ahead" or (not ahead.wanted() and took > 5.0):  # a first run: the next estimate's base
            first_run.remember(Notice.names, took, Notice.cores)
    # importing numba and loading the kernels leave ~10^5 objects that live to the end of the process;
    # each full collection walks them all (~0.07 s), and the exit collects several times (~0.5 s of a
    # 2.5 s run): frozen, they are left out of the collections
    gc.freeze()


def progress(total: int, initial: int, enabled: bool):
    """A tqdm bar on stderr; created after the first step, so its rate and ETA leave out compiling."""
    from tqdm import tqdm

    return tqdm(
        total=total,
        initial=initial,
        desc="tick",
        unit="tick",
        disable=not enabled,
        file=sys.stderr,
        mininterval=0.2,
        leave=True,
        dynamic_ncols=True,
    )


def _progress_enabled(flag: bool | None, steps: int) -> bool:
    if flag is not None:
        return flag
    return sys.stderr.isatty() and steps >= 200


def _size_of(path: str, ticks: int) -> str:
    size = os.path.getsize(path)
    return f"{size / 1e6:.1f} MB, {size / 1e3 / max(ticks, 1):.1f} kB per tick"


def _how_to_open(path: str) -> str:
    return f"open it with: phys2d view {path}   (or: rerun {path}; phys2d view {path} --web for a browser)"


def _count_tag(count: tuple[str, int] | None, responder: str) -> str:
    """The count in an output name, when one was given and the responder took it: ``-5sweeps``."""
    if count is None or REGISTRY[responder].count is None:
        return ""
    return f"-{count[1]}{REGISTRY[responder].count}"


def _work_done(w: World, responder: str) -> str:
    s = w.last_step
    word = REGISTRY[responder].count or "passes"
    return f"{s.residuals[-1]:.3g} m/s after {plural(int(s.iterations), word)}" if s.residuals.size else "-"


# -- viewers -------------------------------------------------------------------------
def rerun_binary() -> str:
    """The real rerun executable inside the rerun-sdk wheel (not the Python wrapper)."""
    import rerun_cli

    exe = os.path.join(os.path.dirname(rerun_cli.__file__), "rerun")
    if not os.path.isfile(exe):
        raise CLIError(f"the rerun viewer binary was not found at {exe}; reinstall rerun-sdk")
    return exe


def web_url(web_port: int, grpc_port: int, file_url: str | None = None) -> str:
    """The web viewer's page, reading ``file_url`` (an http URL of an .rrd) or the live gRPC proxy."""
    from urllib.parse import quote

    source = file_url if file_url is not None else grpc_url(grpc_port)
    return f"http://127.0.0.1:{web_port}/?url={quote(source, safe='')}"


class FileServer:
    """Serves one file over HTTP on 127.0.0.1 (with CORS), for the web viewer to fetch in one go:
    much faster to open than streaming the same file through the viewer's gRPC proxy."""

    def __init__(self, path: str, port: int = 0) -> None:
        import http.server

        name = "/" + os.path.basename(path)
        size = os.path.getsize(path)

        class Handler(http.server.BaseHTTPRequestHandler):
            def do_GET(self) -> None:  # noqa: N802 - the http.server API
                if self.path.split("?")[0] != name:
                    self.send_error(404)
                    return
                self.send_response(200)
                self.send_header("Access-Control-Allow-Origin", "*")
                self.send_header("Content-Type", "application/octet-stream")
                self.send_header("Content-Length", str(size))
                self.end_headers()
                with open(path, "rb") as f:
                    while chunk := f.read(1 << 20):
                        self.wfile.write(chunk)

            def log_message(self, *args: Any) -> None:
                pass

        self.server = http.server.ThreadingHTTPServer(("127.0.0.1", port), Handler)
        self.url = f"http://127.0.0.1:{self.server.server_address[1]}{name}"
        threading.Thread(target=self.server.serve_forever, daemon=True).start()

    def close(self) -> None:
        self.server.shutdown()
        self.server.server_close()


def grpc_url(port: int) -> str:
    return f"rerun+http://127.0.0.1:{port}/proxy"


def has_display() -> bool:
    """Whether a native window can open (always on macOS and Windows; X11 or Wayland on Linux)."""
    if not sys.platform.startswith("linux"):
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def _no_display(what: str) -> CLIError:
    return CLIError(
        f"no display to open the viewer window on ($DISPLAY and $WAYLAND_DISPLAY are not set); "
        f"use {what} --web to view it in a browser instead"
    )


def check_port_free(port: int, option: str) -> None:
    """A clear error when something already listens on 127.0.0.1:port."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            s.bind(("127.0.0.1", port))
        except OSError:
            raise CLIError(
                f"port {port} is already in use (another viewer?); choose a free one with "
                f"{option} PORT, or stop what is using it"
            ) from None


def _wait_listening(proc: subprocess.Popen, port: int, log: str, timeout: float = 30.0) -> None:
    """Wait until ``proc`` listens on ``port``; a CLIError with its last words if it exits first."""
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        if proc.poll() is not None:
            raise CLIError(f"the viewer stopped at once (exit {proc.returncode}): {_last_line(log)}")
        with socket.socket() as s:
            s.settimeout(0.2)
            if s.connect_ex(("127.0.0.1", port)) == 0:
                return
        time.sleep(0.1)
    raise CLIError(f"the viewer did not start listening on port {port} within {timeout:.0f} s")


def _last_line(path: str) -> str:
    try:
        with open(path, errors="replace") as f:
            lines = [ln.strip() for ln in f if ln.strip()]
    except OSError:
        return "(no output)"
    if not lines:
        return "(no output)"
    text = lines[-1]
    for ln in reversed(lines):  # prefer an error line over trailing noise
        if "error" in ln.lower() or "panic" in ln.lower():
            text = ln
            break
    return text[-300:]


WAIT_POLL = 0.2  # s: how often Viewer.wait looks up from waiting on the viewer


def _interrupt(*_: Any) -> NoReturn:
    raise KeyboardInterrupt


class _HeldInterrupts:
    """While a run steps: Ctrl-C (SIGINT) and SIGTERM raise KeyboardInterrupt, as Ctrl-C alone does
    by default, so that a stopped run closes its recording and exits 130; but not while ``held``
    (the recorder logging a tick or closing the file), where the interrupt would leave a tick
    half-buffered: there it waits until the block ends. A second interrupt is not held (a close
    waiting on a slow viewer, say). Off the main thread: nothing changes."""

    SIGNALS = (signal.SIGINT, signal.SIGTERM)

    def __init__(self) -> None:
        self.holding = False
        self.pending = False
        self.raised = False  # an interrupt has already been raised: the next is not held
        self.former: dict[int, Any] = {}

    def __enter__(self) -> _HeldInterrupts:
        if threading.current_thread() is threading.main_thread():
            self.former = {s: signal.signal(s, self._on_signal) for s in self.SIGNALS}
        return self

    def __exit__(self, *exc: object) -> None:
        for s, handler in self.former.items():
            signal.signal(s, handler)
        self.former = {}

    def _on_signal(self, *_: Any) -> None:
        if self.holding and not (self.pending or self.raised):
            self.pending = True
        else:
            self.raised = True
            raise KeyboardInterrupt

    @contextmanager
    def held(self) -> Iterator[None]:
        """The block runs to its end; an interrupt that came meanwhile is raised after it."""
        self.holding = True
        try:
            yield
        finally:
            self.holding = False
        if self.pending:
            self.pending, self.raised = False, True
            raise KeyboardInterrupt


def _stop_on_sigterm() -> tuple[Any] | None:
    """SIGTERM raises KeyboardInterrupt, as Ctrl-C does, so the viewer we started is stopped
    with us; returns (the former handler,) to put back, or None off the main thread (where
    Python takes no handler)."""
    if threading.current_thread() is not threading.main_thread():
        return None
    return (signal.signal(signal.SIGTERM, _interrupt),)


class Viewer:
    """A rerun viewer process we started: native (``spawn``) or a web viewer with its gRPC proxy."""

    def __init__(self, kind: str, files: Sequence[str] = (), web_port: int = 9090, port: int = 9876) -> None:
        self.kind, self.web_port, self.port = kind, web_port, port
        self.files: FileServer | None = None
        exe = rerun_binary()
        self.log = tempfile.NamedTemporaryFile(prefix="phys2d-viewer-", suffix=".log", delete=False).name
        if kind == "web":
            check_port_free(web_port, "--web-port")
            check_port_free(port, "--port")
            # the page fetches a file over plain HTTP; the gRPC proxy (port) takes live streams
            cmd = [exe, "--serve-web", "--bind", "127.0.0.1", "--web-viewer-port", str(web_port), "--port", str(port)]
            if files:
                self.files = FileServer(files[0])
        elif files:  # a native window on a file: its data port does not matter, take a free one
            if not has_display():
                raise _no_display(f"phys2d view {files[0]}")
            cmd = [exe, *files, "--bind", "127.0.0.1", "--port", "auto"]
        else:  # a native window that a live run streams to, on a known port
            if not has_display():
                raise _no_display("--live")
            check_port_free(port, "--port")
            cmd = [exe, "--bind", "127.0.0.1", "--port", str(port)]
        # one we stop with us (a web viewer, a window on a file we wait on) hears SIGTERM from
        # before it starts; a live run's native window outlives the run
        self._sigterm = _stop_on_sigterm() if kind == "web" or files else None
        self.proc: subprocess.Popen | None = None
        try:
            with open(self.log, "w") as log:
                self.proc = subprocess.Popen(
                    cmd,
                    env={**os.environ, "BROWSER": "true"},
                    stdin=subprocess.DEVNULL,
                    stdout=log,
                    stderr=subprocess.STDOUT,
                    start_new_session=kind != "web",
                )
            if kind == "web":  # the page, and the gRPC proxy a live run streams to
                _wait_listening(self.proc, web_port, self.log)
                _wait_listening(self.proc, port, self.log)
            elif not files:
                _wait_listening(self.proc, port, self.log)
        except BaseException:
            self.stop()
            raise

    @property
    def url(self) -> str:
        if self.kind != "web":
            return grpc_url(self.port)
        return web_url(self.web_port, self.port, self.files.url if self.files is not None else None)

    def serve(self, message: str | None = None) -> int:
        """Print ``message``, then ``wait``: Ctrl-C or SIGTERM from here on is how it is meant to
        end (exit 0), even when it comes before the wait begins."""
        try:
            if message:
                print(message, flush=True)
            return self.wait()
        except KeyboardInterrupt:
            self.stop()
            return 0

    def wait(self) -> int:
        """Until the viewer exits or Ctrl-C / SIGTERM; then stop it."""
        assert self.proc is not None
        try:
            while True:  # in short waits: a signal the kernel hands to another thread (the viewer's
                try:  # stream, tqdm's monitor) does not wake a main thread blocked in waitpid, and
                    code = self.proc.wait(WAIT_POLL)  # Python runs signal handlers in the main thread only
                    break
                except subprocess.TimeoutExpired:
                    continue
            if code != 0:
                raise CLIError(f"the viewer failed (exit {code}): {_last_line(self.log)}")
            return 0
        except KeyboardInterrupt:
            return 0
        finally:
            self.stop()

    def stop(self) -> None:
        """Stop the viewer process (and the file server); give SIGTERM back its former handler."""
        if self._sigterm is not None:
            signal.signal(signal.SIGTERM, self._sigterm[0])
            self._sigterm = None
        if self.files is not None:
            self.files.close()
            self.files = None
        if self.proc is not None and self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
        try:
            os.unlink(self.log)
        except OSError:
            pass


def start_live(target: str, web_port: int, port: int) -> tuple[str, Viewer | None]:
    """(gRPC URL to stream to, the viewer we started or None) for ``--live TARGET``."""
    if "://" in target:
        return target, None
    kind = target if target != "auto" else ("spawn" if has_display() else "web")
    viewer = Viewer(kind, web_port=web_port, port=port)
    if kind == "web":
        print(f"live web viewer: {viewer.url}   (127.0.0.1 only)", flush=True)
    else:
        print(f"live: streaming to a native viewer on port {port}", flush=True)
    return grpc_url(port), viewer


# -- commands --------------------------------------------------------------------------
def cmd_scenes(args: argparse.Namespace) -> int:
    rows = [
        (name, repr(default_size(cast(Callable[..., World], b))), meaning)
        for name, (b, meaning) in scenes.SCENES.items()
    ]
    w0 = max(len(r[0]) for r in rows)
    w1 = max(len(r[1]) for r in rows)
    print(f"{'scene':<{w0}}  {'size':>{w1}}  --size means")
    for name, size, meaning in rows:
        print(f"{name:<{w0}}  {size:>{w1}}  {meaning}")
    return 0


def cmd_run(args: argparse.Namespace) -> int:
    count = requested_count(args)
    choice = plot_choice(args)  # checked even when nothing is recorded
    responder = make_responder(args.responder, count)
    size = default_size(scene_builder(args.scene)) if args.size is None else args.size
    name = f"{args.scene}-{size}-{args.responder}{_count_tag(count, args.responder)}.rrd"
    path = None if args.no_record else (args.out or os.path.join(DEFAULT_DIR, name))
    if args.live is None:
        return _run(args, responder, choice, size, path, None, None)
    stream_to, viewer = start_live(args.live, args.web_port, args.port)
    try:
        return _run(args, responder, choice, size, path, viewer, stream_to)
    except BaseException:
        if viewer is not None and viewer.kind == "web":
            viewer.stop()  # a run that fails or is stopped leaves no web viewer serving behind it
        raise


def _run(
    args: argparse.Namespace,
    responder: Responder,
    choice: Any,
    size: Any,
    path: str | None,
    viewer: Viewer | None,
    stream_to: str | None,
) -> int:
    """``phys2d run`` once its arguments are checked and its live viewer (if any) is up."""
    folder = os.path.dirname(os.path.abspath(path)) if path else None
    new_folder = folder is not None and not os.path.isdir(folder)
    previous = None  # a recording already at path is kept aside until this run has a world to record
    if path is not None and os.path.isfile(path):
        previous = f"{path}.previous"
        os.replace(path, previous)
    rec = _run_recorder(args, choice, size, path, stream_to)
    try:
        w = build_world(args.scene, args.size, responder)
    except BaseException:
        if rec is not None:  # nothing was recorded: leave no empty file (or folder) behind
            rec.close()
            if path is not None and os.path.isfile(path):
                os.unlink(path)
            if new_folder and folder is not None and not os.listdir(folder):
                os.rmdir(folder)
        if previous is not None and path is not None:  # and the recording that was there is back
            os.replace(previous, path)
        raise
    if previous is not None:
        os.unlink(previous)
    watch = watch_for(args.scene, w)
    elapsed, steady = _step_run(args, w, watch, rec, path)
    _say_run(args, responder, size, w, watch, rec, path, elapsed, steady)
    if viewer is not None and viewer.kind == "web":
        return viewer.serve(f"the run is over; the web viewer keeps serving it at {viewer.url} until Ctrl-C")
    return 0


def _run_recorder(
    args: argparse.Namespace, choice: Any, size: Any, path: str | None, stream_to: str | None
) -> Recorder | None:
    """The run's recorder, to ``path`` and the live viewer ``stream_to`` (None: neither), writing from
    a process of its own."""
    from .recording import Recorder

    if not (path or stream_to):
        return None
    # the writer process starts first, so that it loads rerun while this one builds the world
    # and loads the numba kernels
    return Recorder(
        path,
        name=f"{args.scene} {size} / {args.responder}",
        scene=args.scene,
        contact_series=not args.no_series,
        plot=choice,
        stream_to=stream_to,
        flush_every=6 if stream_to else 60,
        background=True,
    )


def _step_run(
    args: argparse.Namespace, w: World, watch: Watch, rec: Recorder | None, path: str | None
) -> tuple[float, float]:
    """Step ``w`` ``args.steps`` times, each tick watched and logged, with a progress bar from the first
    step on (its compiling left out); (the seconds in all, the seconds after the first step)."""
    t0 = time.perf_counter()
    bar = None
    with _HeldInterrupts() as interrupts, KeptInterrupts() as kept:
        try:
            if rec is not None:
                with interrupts.held():
                    rec.log(w)  # tick 0: the scene as built
            for k in range(args.steps):
                try:
                    if k == 0:
                        first_step([w], args.dt)
                        t_first = time.perf_counter()
                        bar = progress(args.steps, 1, _progress_enabled(args.progress, args.steps))
                    else:
                        w.step(args.dt)  # (a step interrupted midway leaves the world as it was)
                except SimulationError as e:
                    if bar is not None:
                        bar.close()
                    saved = f"; ticks 0-{w.tick} are recorded in {path}" if path else ""
                    raise CLIError(f"step {k + 1} failed: {e}{saved}") from None
                kept.raise_if_lost()  # (a step that loads or compiles a kernel calls back from C)
                watch.observe()
                if rec is not None:
                    with interrupts.held():
                        rec.log(w)
                if bar is not None and k:
                    bar.update(1)
        finally:
            if bar is not None:
                bar.close()
            if rec is not None:
                with interrupts.held():  # the file gets its footer, interrupted or not
                    rec.close()
    elapsed = time.perf_counter() - t0
    steady = time.perf_counter() - t_first
    return elapsed, steady


def _say_run(
    args: argparse.Namespace,
    responder: Responder,
    size: Any,
    w: World,
    watch: Watch,
    rec: Recorder | None,
    path: str | None,
    elapsed: float,
    steady: float,
) -> None:
    """What ``phys2d run`` prints once the run is over: the pace, the last step, the verdict and the recording."""
    print(f"{args.scene} (size {size}), {len(w)} bodies, responder {responder!r}")
    per = f"{1e3 * steady / (args.steps - 1):.3f} ms/step after the first" if args.steps > 1 else "1 step"
    print(
        f"{plural(args.steps, 'steps')} of {args.dt:.4g} s in {elapsed:.2f} s ({per}"
        f"{', recording included' if rec else ''})"
    )
    print(
        f"last step: {plural(len(w.contacts), 'contacts')}, cache hit rate {w.last_step.cache_hit_rate:.3f}, "
        f"residual {_work_done(w, args.responder)}"
    )
    print(f"verdict: {watch.verdict().line()}")
    if path:
        plotted = rec.plotted.get(None, []) if rec is not None else []
        print(f"recording: {path} ({_size_of(path, args.steps + 1)})")
        if plotted:
            print(f"plotted contacts: {', '.join(plotted)}")
        print(_how_to_open(path))


def cmd_compare(args: argparse.Namespace) -> int:
    from .recording import Recorder

    scene_builder(args.scene)
    count = requested_count(args)
    worlds: dict[str, World] = {}
    for name in COMPARE_ORDER:
        worlds[name] = build_world(args.scene, args.size, make_responder(name, count, strict=False))
    size = default_size(scene_builder(args.scene)) if args.size is None else args.size
    tag = f"-{count[1]}{count[0]}" if count else ""
    path = args.out or os.path.join(DEFAULT_DIR, f"{args.scene}-{size}-compare{tag}.rrd")
    watches = {label: watch_for(args.scene, w) for label, w in worlds.items()}
    # its own application id: the viewer keeps one blueprint per application, and a comparison's
    # layout (a world per run) differs from a single run's
    with Recorder(
        path,
        name=f"{args.scene} {size}: {' vs '.join(worlds)}",
        scene=args.scene,
        application_id="phys2d-compare",
        contact_series=not args.no_series,
        plot=plot_choice(args),
        background=True,
    ) as rec:
        for label, w in worlds.items():
            rec.log(w, run=label)
        failed = _step_side_by_side(args, worlds, watches, rec)
    print(
        f"{args.scene} (size {size}), {plural(args.steps, 'steps')} of {args.dt:.4g} s, every responder, "
        f"same timelines (tick, sim_time)"
    )
    width = max(len(label) for label in worlds)
    for label in worlds:
        v = watches[label].verdict()
        note = f" (stopped at {failed[label]})" if label in failed else ""
        print(f"{label:<{width}}  {v.line()}{note}")
    print(f"recording: {path} ({_size_of(path, args.steps + 1)})")
    print(_how_to_open(path))
    return 0


def _step_side_by_side(
    args: argparse.Namespace, worlds: dict[str, World], watches: dict[str, Watch], rec: Recorder
) -> dict[str, str]:
    """Step every world ``args.steps`` times, tick by tick in turn, each tick watched and logged as its
    run; a world that fails stops there. Returns where and why each stopped, by label."""
    failed: dict[str, str] = {}
    bar = None
    try:
        for k in range(args.steps):
            for label, w in worlds.items():
                if label in failed:
                    continue
                try:
                    if k == 0:
                        first_step([w], args.dt)
                    else:
                        w.step(args.dt)
                except SimulationError as e:
                    failed[label] = f"step {k + 1}: {e}"
                    continue
                watches[label].observe()
                rec.log(w, run=label)
            if k == 0:
                bar = progress(args.steps, 1, _progress_enabled(args.progress, args.steps * len(worlds)))
            elif bar is not None:
                bar.update(1)
    finally:
        if bar is not None:
            bar.close()
    return failed


def cmd_inspect(args: argparse.Namespace) -> int:
    from .recording import playback

    rec = playback.load(args.path)
    print(
        f"{args.path}: {plural(len(rec.runs), 'runs')}, "
        f"phys2d {rec.properties.get('phys2d', {}).get('engine_version', '?')}"
    )
    head = (
        f"{'run':<10} {'responder':<10} {'ticks':>11} {'bodies':>6} {'contacts':>8} {'max pen (mm)':>12} "
        f"{'max lambda_n':>12} {'last residual':>13} {'KE end (J)':>11}"
    )
    print(head)
    for label, r in rec.runs.items():
        c = r.contacts
        ticks = f"{r.tick[0]}-{r.tick[-1]}" if r.tick.size else "-"
        bodies = int(np.isfinite(r.x[-1, :, 0]).sum()) if r.tick.size else 0
        most = int(np.max(np.diff(c.offsets))) if len(c) else 0
        pen = 1e3 * float(np.max(np.maximum(0.0, -c.separation))) if c.separation.size else 0.0
        lam = f"{float(np.max(c.normal_impulse)):.4g}" if c.normal_impulse.size else "-"
        last_res = r.residuals_at(int(r.tick[-1])) if r.tick.size else np.zeros(0)
        res = f"{last_res[-1]:.3g}" if last_res.size else "-"
        ke = f"{r.kinetic_energy[-1]:.4g}" if r.kinetic_energy.size else "-"
        responder = str(r.properties.get("responder_name", "?"))
        print(
            f"{label or '-':<10} {responder:<10} {ticks:>11} {bodies:>6} {most:>8} {pen:>12.3f} "
            f"{lam:>12} {res:>13} {ke:>11}"
        )
    return 0


def cmd_view(args: argparse.Namespace) -> int:
    if not os.path.isfile(args.path):
        raise CLIError(f"no such recording: {args.path}")
    if not args.web and not has_display():
        raise _no_display(f"phys2d view {args.path}")
    viewer = Viewer("web" if args.web else "spawn", files=[args.path], web_port=args.web_port, port=args.port)
    return viewer.serve(f"web viewer: {viewer.url}   (127.0.0.1 only; Ctrl-C stops it)" if args.web else None)


def cmd_replay(args: argparse.Namespace) -> int:
    from .recording import replay

    if not os.path.isfile(args.path):
        raise CLIError(f"no such recording: {args.path}")
    runs = replay.timelines(args.path)
    if args.run is not None:
        runs = {args.run: replay.timeline(args.path, args.run)}
    failed = 0
    for label, t in runs.items():
        name = f"run {label!r}" if label else "the run"
        if not t.ticks:
            print(f"{args.path}, {name}: no replay data (recorded by a phys2d without keyframes: record it again)")
            failed += 1
            continue
        keys = t.keyframe_ticks()
        shown = ", ".join(str(k) for k in keys[:8]) + (", ..." if len(keys) > 8 else "")
        responders = [json.loads(spec).get("name", "?") for spec in t.responders.values()]
        print(
            f"{args.path}, {name}: ticks {t.first}-{t.last} ({plural(len(t.ticks), 'ticks')} logged), "
            f"{plural(len(keys), 'keyframes')}{f' (at {shown})' if keys else ''}, responder "
            f"{' then '.join(responders) or '?'}"
        )
        if not args.check:
            continue
        if not keys:
            raise CLIError(str(t.missing_keyframes()))
        bar = progress(len(t.ticks), 0, _progress_enabled(args.progress, len(t.ticks)))
        try:
            result = t.check(bar.update)
        finally:
            bar.close()
        if result.ok:
            frames = plural(result.keyframes, "keyframes")
            print(f"{result.matched}/{result.total} ticks match (stepped again from {frames})")
        else:
            failed += 1
            first = f"; tick {result.first_bad} differs first" if result.first_bad is not None else ""
            print(f"{result.matched}/{result.total} ticks match{first}: {result.detail}")
    return 1 if failed else 0


def cmd_branch(args: argparse.Namespace) -> int:
    from .recording import Recorder, replay

    if not os.path.isfile(args.path):
        raise CLIError(f"no such recording: {args.path}")
    count = requested_count(args)
    responder = make_responder(args.responder, count)
    t = replay.timeline(args.path, args.run)
    if args.steps is None and t.ticks and args.at == t.last:
        raise CLIError(f"--at {args.at} is the recording's last tick: give --steps N to go on from it")
    stem = os.path.splitext(args.path)[0]
    tag = _count_tag(count, args.responder)
    out = args.out or f"{stem}-branch-{args.at}-{args.responder}{tag}.rrd"
    label = f"{args.responder}{tag}"
    rec = Recorder(
        out,
        name=f"{os.path.basename(args.path)} from tick {args.at}: original vs {label}",
        application_id="phys2d-compare",  # a world per run, side by side (as phys2d compare)
        contact_series=False,
        background=True,
    )
    bar = None
    original_name = "?"

    def log(original: World, branch: World) -> None:
        nonlocal bar, original_name
        rec.log(original, run="original")
        rec.log(branch, run=label)
        if bar is None:
            original_name = original.responder.name
            bar = progress(args.steps or t.last - args.at, 0, _progress_enabled(args.progress, t.last - args.at))
        else:
            bar.update(1)

    try:
        parting = t.branch(args.at, responder, args.steps, log)
    except BaseException:
        rec.close()
        if os.path.isfile(out):
            os.unlink(out)
        raise
    finally:
        if bar is not None:
            bar.close()
    rec.close()
    end = parting.start + parting.ticks
    print(
        f"{args.path} at tick {args.at}: the original ({original_name}) and a branch under {label}, "
        f"{plural(parting.ticks, 'steps')} to tick {end}"
    )
    for line in parting.lines():
        print(line)
    print(f"recording: {out} (runs original and {label}, ticks {args.at}-{end}; {_size_of(out, parting.ticks + 1)})")
    print(_how_to_open(out))
    return 0


# -- the parser ------------------------------------------------------------------------
def _work_per_tick(q: argparse.ArgumentParser, whose: str) -> None:
    """--sweeps, --passes, --substeps and their alias --iterations (``requested_count`` reads them)."""
    counts = q.add_argument_group("work per tick (each accepted only by responders that take it)")
    counts.add_argument("--sweeps", type=_count, default=None, help="PGS sweeps per tick (default 10)")
    counts.add_argument("--passes", type=_count, default=None, help="iterative passes per tick (default 10)")
    counts.add_argument("--substeps", type=_count, default=None, help="soft-step sub-steps per tick (default 4)")
    counts.add_argument(
        "--iterations", type=_count, default=None, help=f"alias: the sweeps, passes or sub-steps of {whose}"
    )


def _common(q: argparse.ArgumentParser, default_steps: int) -> None:
    q.add_argument("scene", help="a stock scene (see 'phys2d scenes')")
    q.add_argument("--size", type=_size, default=None, help="the scene's main count (see 'phys2d scenes')")
    q.add_argument("--steps", type=_count, default=default_steps, help="ticks to run (default %(default)s)")
    q.add_argument("--dt", type=_seconds, default=1 / 60, help="tick length in s (default 1/60)")
    _work_per_tick(q, "whichever responder runs")
    q.add_argument(
        "--progress",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="progress bar on stderr (default: when stderr is a terminal and the run is long)",
    )
    q.add_argument(
        "--no-series",
        action="store_true",
        help="leave out the plotted per-contact lambda/penetration series; the per-tick contact "
        "table (every contact) is kept",
    )
    plot = q.add_mutually_exclusive_group()
    plot.add_argument(
        "--plot-deepest",
        type=_count,
        default=None,
        metavar="N",
        help="plot lambda and penetration of the N deepest contacts (default 4)",
    )
    plot.add_argument(
        "--plot-body",
        type=int,
        default=None,
        metavar="UID",
        help="plot every contact of the body with this uid (its index in a stock scene)",
    )
    plot.add_argument(
        "--plot-contacts",
        default=None,
        metavar="NAMES",
        help="plot these contacts, comma-separated, named as in the legends: b3-b7/f512,...",
    )


def add_scenes(sub: Any) -> None:
    s = sub.add_parser("scenes", help="the stock scenes and what --size means")
    s.set_defaults(func=cmd_scenes)


def add_run(sub: Any) -> None:
    r = sub.add_parser("run", help="run a scene and record it")
    _common(r, 600)
    r.add_argument(
        "--responder",
        choices=RESPONDERS,
        default="pgs",
        help="collision responder (default pgs): " + "; ".join(f"{n}: {e.description}" for n, e in REGISTRY.items()),
    )
    out = r.add_mutually_exclusive_group()
    out.add_argument(
        "--out",
        default=None,
        help=f"recording path (default {DEFAULT_DIR}/SCENE-SIZE-RESPONDER.rrd, so runs never overwrite each other)",
    )
    out.add_argument("--no-record", action="store_true", help="run without writing a recording")
    r.add_argument(
        "--live",
        nargs="?",
        const="auto",
        default=None,
        metavar="spawn|web|URL",
        help="stream to a viewer while the simulation runs: a spawned native viewer, the web viewer "
        "on 127.0.0.1, or a running viewer's rerun+http://... URL (default: spawn if there is a "
        f"display, else web); a viewer that has not taken the whole stream {STREAM_FLUSH_S:g} s after "
        "the last step is given up on (exit 1; a file recorded beside it is complete)",
    )
    r.add_argument("--web-port", type=_port, default=9090, help="web viewer port for --live web (default 9090)")
    r.add_argument("--port", type=_port, default=9876, help="viewer data (gRPC) port for --live (default 9876)")
    r.set_defaults(func=cmd_run)


def add_compare(sub: Any) -> None:
    c = sub.add_parser("compare", help="one scene under every responder, in one recording, with verdicts")
    _common(c, 300)
    c.add_argument("--out", default=None, help=f"recording path (default {DEFAULT_DIR}/SCENE-SIZE-compare.rrd)")
    c.set_defaults(func=cmd_compare)


def add_inspect(sub: Any) -> None:
    i = sub.add_parser("inspect", help="a summary table of a recording")
    i.add_argument("path")
    i.set_defaults(func=cmd_inspect)


def add_view(sub: Any) -> None:
    v = sub.add_parser("view", help="open a recording in the Rerun viewer (--web: in a browser)")
    v.add_argument("path")
    v.add_argument("--web", action="store_true", help="serve the web viewer on 127.0.0.1 instead")
    v.add_argument("--web-port", type=_port, default=9090, help="web viewer port (default %(default)s)")
    v.add_argument("--port", type=_port, default=9876, help="viewer data (gRPC) port (default %(default)s)")
    v.set_defaults(func=cmd_view)


def add_replay(sub: Any) -> None:
    r = sub.add_parser("replay", help="a recording's keyframes; --check steps it again and compares every tick")
    r.add_argument("path")
    r.add_argument("--check", action="store_true", help="step every tick again from its keyframe and compare hashes")
    r.add_argument("--run", default=None, help="the run to replay, in a file of several (phys2d compare's)")
    r.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None, help="progress bar on stderr")
    r.set_defaults(func=cmd_replay)


def add_branch(sub: Any) -> None:
    b = sub.add_parser("branch", help="the future from a recorded tick under another responder, beside the original")
    b.add_argument("path")
    b.add_argument("--at", type=_tick, required=True, metavar="TICK", help="the tick to branch from")
    b.add_argument(
        "--responder",
        required=True,
        metavar="NAME",
        help="the branch's responder: " + ", ".join(RESPONDERS),
    )
    b.add_argument("--steps", type=_count, default=None, help="ticks to run (default: to the recording's end)")
    b.add_argument("-o", "--out", default=None, help="recording path (default PATH-branch-TICK-NAME.rrd beside it)")
    b.add_argument("--run", default=None, help="the run to branch, in a file of several (phys2d compare's)")
    _work_per_tick(b, "the responder")
    b.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None, help="progress bar on stderr")
    b.set_defaults(func=cmd_branch)


def add_sweep(sub: Any) -> None:
    from .sweeps.command import add_parser  # its own module: dask and pyarrow load lazily

    add_parser(sub)


def add_check(sub: Any) -> None:
    from .checks.card import add_parser  # its own package: the claims and the card

    add_parser(sub)


COMMANDS: list[Callable[[Any], None]] = [
    add_scenes, add_run, add_compare, add_inspect, add_view, add_replay, add_branch, add_sweep, add_check,
]  # fmt: skip


def version() -> str:
    from importlib.metadata import version as installed

    import numba

    from . import __version__

    # rerun-sdk's version as installed, read without importing rerun (the command stays light)
    rerun_sdk = installed("rerun-sdk")
    return f"phys2d {__version__} (rerun-sdk {rerun_sdk}, numba {numba.__version__}, numpy {np.__version__})"


class _Version(argparse.Action):
    def __init__(self, option_strings: Sequence[str], dest: str = argparse.SUPPRESS, **kw: Any) -> None:
        super().__init__(option_strings, dest=dest, nargs=0, help="print the version and exit", **kw)

    def __call__(self, parser: argparse.ArgumentParser, *_: Any) -> NoReturn:
        print(version())
        parser.exit(0)


def parser() -> argparse.ArgumentParser:
    p = _Parser(prog="phys2d", description="phys2d: run, record, compare and inspect 2D rigid-body scenes.")
    p.add_argument("--version", action=_Version)
    sub = p.add_subparsers(dest="command", parser_class=_Parser)
    sub.required = True
    for add in COMMANDS:
        add(sub)
    sub.metavar = "{" + ",".join(sub.choices) + "}"
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit code."""
    args = parser().parse_args(argv)
    prog = f"phys2d {args.command}"
    try:
        with KeptInterrupts() as kept:  # (every command: Ctrl-C while numba compiles stays an interrupt)
            code = int(args.func(args))
            kept.raise_if_lost()
        return code
    except CLIError as e:
        print(f"{prog}: error: {e}", file=sys.stderr)
    except (ValueError, TypeError, OSError, StreamError) as e:
        print(f"{prog}: error: {e}", file=sys.stderr)
    except KeyboardInterrupt:
        print(f"{prog}: interrupted", file=sys.stderr)
        return 130
    except Exception as e:  # a bug: still one line, unless asked for the traceback
        if os.environ.get("PHYS2D_DEBUG"):
            raise
        print(f"{prog}: internal error: {type(e).__name__}: {e} (PHYS2D_DEBUG=1 shows the traceback)", file=sys.stderr)
    return 1


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
