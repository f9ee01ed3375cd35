"""The ``phys2d`` command (also ``python -m phys2d``).

    phys2d scenes                                  the stock scenes and what --size means
    phys2d run SCENE [--size N] [--responder naive|iterative|pgs|pgs-cold|pgs-block|soft-step]
                     [--iterations K] [--steps N] [--dt S] [--out PATH | --no-record] [--no-series]
    phys2d compare SCENE [--size N] [--steps N] [--dt S] [--out PATH] [--no-series]
    phys2d inspect PATH                            a summary table of a recording
    phys2d view PATH [--web]                       the Rerun viewer, or the web viewer on 127.0.0.1
    phys2d sweep [GRID.toml] [--scenes ...] ...    a grid of runs to one Parquet table (phys2d/sweeps/command.py)

Bad arguments and failures print one line on stderr and exit non-zero (2 for usage
errors, 1 for the rest); set PHYS2D_DEBUG=1 to see tracebacks of unexpected errors.
"""

from __future__ import annotations

import argparse
import difflib
import inspect as pyinspect
import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Sequence
from typing import Any, NoReturn, TextIO

import numpy as np

from . import scenes
from .responders import REGISTRY
from .responders.base import Responder
from .world import SimulationError, World

RESPONDERS = tuple(REGISTRY)
COMPARE_ORDER = ("naive", "iterative", "pgs-cold", "pgs")
DEFAULT_DIR = "recordings"


class CLIError(Exception):
    """A failure to report as one line, exit code 1."""


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> NoReturn:  # one line, not argparse's usage block
        self.exit(2, f"{self.prog}: error: {message} (see '{self.prog} --help')\n")


def _count(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a whole number >= 1, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be a whole number >= 1, got {text!r}")
    return value


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


# -- the pieces ------------------------------------------------------------------
def scene_builder(name: str) -> Callable[..., World]:
    """The builder of a stock scene, or a CLIError naming the choices."""
    if name not in scenes.SCENES:
        close = difflib.get_close_matches(name, scenes.SCENES, n=1)
        hint = f"; did you mean {close[0]!r}?" if close else ""
        raise CLIError(f"unknown scene {name!r}{hint} (choose from: {', '.join(scenes.SCENES)})")
    return scenes.SCENES[name][0]


def default_size(builder: Callable[..., World]) -> Any:
    """The default of a builder's first parameter (its size)."""
    first = next(iter(pyinspect.signature(builder).parameters.values()))
    return first.default


def make_responder(name: str, iterations: int | None = None) -> Responder:
    """A responder by its registered name (``phys2d.responders.REGISTRY``); ``iterations``
    are PGS sweeps, iterative passes or soft-step sub-steps."""
    if name not in REGISTRY:
        raise CLIError(f"unknown responder {name!r} (choose from: {', '.join(RESPONDERS)})")
    entry = REGISTRY[name]
    if iterations is not None and entry.count is None:
        raise CLIError(f"--iterations does not apply to the {name} responder (it makes one pass)")
    return entry(iterations)


def build_world(scene: str, size: Any, responder: Responder) -> World:
    builder = scene_builder(scene)
    try:
        return builder(responder=responder) if size is None else builder(size, responder=responder)
    except (TypeError, ValueError) as e:
        raise CLIError(f"--size {size!r} for scene {scene!r} ({scenes.SCENES[scene][1]}): {e}") from None


class Progress:
    """A one-line progress bar on a stream (stderr), redrawn at most every 0.2 s."""

    def __init__(self, total: int, enabled: bool, stream: TextIO | None = None, width: int = 30) -> None:
        self.total, self.enabled, self.width = total, enabled, width
        self.stream = sys.stderr if stream is None else stream
        self.t0 = time.perf_counter()
        self.last = -1.0

    def update(self, done: int) -> None:
        if not self.enabled:
            return
        now = time.perf_counter()
        if done < self.total and now - self.last < 0.2:
            return
        self.last = now
        frac = done / self.total
        fill = int(round(self.width * frac))
        elapsed = now - self.t0
        per = 1e3 * elapsed / done if done else 0.0
        eta = elapsed / done * (self.total - done) if done else 0.0
        self.stream.write(f"\r  tick {done}/{self.total} [{'#' * fill}{'-' * (self.width - fill)}] "
                          f"{100 * frac:3.0f}%  {per:.2f} ms/tick  eta {eta:.0f} s ")
        self.stream.flush()

    def close(self) -> None:
        if self.enabled:
            self.stream.write("\n")
            self.stream.flush()


def _progress_enabled(flag: bool | None, steps: int) -> bool:
    if flag is not None:
        return flag
    return sys.stderr.isatty() and steps >= 200


def _out_path(out: str | None, default_name: str) -> str:
    return out if out is not None else os.path.join(DEFAULT_DIR, default_name)


def _size_mb(path: str) -> str:
    return f"{os.path.getsize(path) / 1e6:.1f} MB"


def _how_to_open(path: str) -> str:
    return f"open it with: phys2d view {path}   (or: rerun {path}; phys2d view {path} --web for a browser)"


# -- commands --------------------------------------------------------------------------
def cmd_scenes(args: argparse.Namespace) -> int:
    rows = [(name, repr(default_size(b)), meaning) for name, (b, meaning) in scenes.SCENES.items()]
    w0 = max(len(r[0]) for r in rows)
    w1 = max(len(r[1]) for r in rows)
    print(f"{'scene':<{w0}}  {'size':>{w1}}  --size means")
    for name, size, meaning in rows:
        print(f"{name:<{w0}}  {size:>{w1}}  {meaning}")
    return 0


def cmd_run(args: argparse.Namespace) -> int:
    from .recording import Recorder

    responder = make_responder(args.responder, args.iterations)
    w = build_world(args.scene, args.size, responder)
    size = default_size(scene_builder(args.scene)) if args.size is None else args.size
    path = None if args.no_record else _out_path(args.out, f"{args.scene}.rrd")
    rec = Recorder(path, name=f"{args.scene} {size} / {responder.name}", scene=args.scene,
                   contact_series=not args.no_series) if path else None
    bar = Progress(args.steps, _progress_enabled(args.progress, args.steps))
    deepest = 0.0
    t0 = time.perf_counter()
    try:
        if rec is not None:
            rec.log(w)  # tick 0: the scene as built
        for k in range(args.steps):
            try:
                w.step(args.dt)
            except SimulationError as e:
                bar.close()
                saved = f"; ticks 0-{w.tick} are recorded in {path}" if path else ""
                raise CLIError(f"step {k + 1} failed: {e}{saved}") from None
            if rec is not None:
                rec.log(w)
            deepest = max(deepest, w.last_step.max_penetration)
            bar.update(k + 1)
    finally:
        if rec is not None:
            rec.close()
    bar.close()
    elapsed = time.perf_counter() - t0
    s = w.last_step
    res = f"{s.residuals[-1]:.3g} m/s after {s.iterations} sweeps" if s.residuals.size else "-"
    print(f"{args.scene} (size {size}), {len(w)} bodies, responder {responder!r}")
    print(f"{args.steps} steps of {args.dt:.4g} s in {elapsed:.2f} s ({1e3 * elapsed / args.steps:.3f} ms/step"
          f"{' with recording' if rec else ''})")
    print(f"last step: {len(w.contacts)} contacts, cache hit rate {s.cache_hit_rate:.3f}, residual {res}; "
          f"deepest overlap {1e3 * deepest:.2f} mm")
    if path:
        print(f"recording: {path} ({_size_mb(path)})")
        print(_how_to_open(path))
    return 0


def cmd_compare(args: argparse.Namespace) -> int:
    from .recording import Recorder

    scene_builder(args.scene)
    worlds: dict[str, World] = {}
    for name in COMPARE_ORDER:
        try:
            responder = make_responder(name, args.iterations if name != "naive" else None)
        except CLIError as e:
            print(f"phys2d compare: note: {e}; left out", file=sys.stderr)
            continue
        worlds[name] = build_world(args.scene, args.size, responder)
    size = default_size(scene_builder(args.scene)) if args.size is None else args.size
    path = _out_path(args.out, f"{args.scene}-compare.rrd")
    failed: dict[str, str] = {}
    bar = Progress(args.steps, _progress_enabled(args.progress, args.steps * len(worlds)))
    deepest = dict.fromkeys(worlds, 0.0)
    # its own application id: the viewer keeps one blueprint per application, and a comparison's
    # layout (a world per run) differs from a single run's
    with Recorder(path, name=f"{args.scene} {size}: {' vs '.join(worlds)}", scene=args.scene,
                  application_id="phys2d-compare", contact_series=not args.no_series) as rec:
        for label, w in worlds.items():
            rec.log(w, run=label)
        for k in range(args.steps):
            for label, w in worlds.items():
                if label in failed:
                    continue
                try:
                    w.step(args.dt)
                except SimulationError as e:
                    failed[label] = f"step {k + 1}: {e}"
                    continue
                rec.log(w, run=label)
                deepest[label] = max(deepest[label], w.last_step.max_penetration)
            bar.update(k + 1)
    bar.close()
    print(f"{args.scene} (size {size}), {args.steps} steps of {args.dt:.4g} s, same timelines (tick, sim_time)")
    print(f"{'run':<10} {'contacts':>8} {'deepest overlap (mm)':>21} {'kinetic energy (J)':>19}")
    for label, w in worlds.items():
        note = f"  stopped at {failed[label]}" if label in failed else ""
        print(f"{label:<10} {len(w.contacts):>8} {1e3 * deepest[label]:>21.2f} {w.kinetic_energy():>19.4g}{note}")
    print(f"recording: {path} ({_size_mb(path)})")
    print(_how_to_open(path))
    return 0


def cmd_inspect(args: argparse.Namespace) -> int:
    from .recording import playback

    rec = playback.load(args.path)
    print(f"{args.path}: {len(rec.runs)} run(s), phys2d {rec.properties.get('phys2d', {}).get('engine_version', '?')}")
    head = (f"{'run':<10} {'responder':<10} {'ticks':>11} {'bodies':>6} {'contacts':>8} {'max pen (mm)':>12} "
            f"{'max lambda_n':>12} {'last residual':>13} {'KE end (J)':>11}")
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
        print(f"{label or '-':<10} {responder:<10} {ticks:>11} {bodies:>6} {most:>8} {pen:>12.3f} "
              f"{lam:>12} {res:>13} {ke:>11}")
    return 0


def rerun_binary() -> str:
    """The real rerun executable inside the rerun-sdk wheel (not the Python wrapper)."""
    import rerun_cli

    exe = os.path.join(os.path.dirname(rerun_cli.__file__), "rerun")
    if not os.path.isfile(exe):
        raise CLIError(f"the rerun viewer binary was not found at {exe}; reinstall rerun-sdk")
    return exe


def web_url(web_port: int, grpc_port: int) -> str:
    return f"http://127.0.0.1:{web_port}/?url=rerun%2Bhttp%3A%2F%2F127.0.0.1%3A{grpc_port}%2Fproxy"


def cmd_view(args: argparse.Namespace) -> int:
    if not os.path.isfile(args.path):
        raise CLIError(f"no such recording: {args.path}")
    exe = rerun_binary()
    if not args.web:
        return subprocess.call([exe, args.path])
    cmd = [exe, args.path, "--web-viewer", "--bind", "127.0.0.1", "--web-viewer-port", str(args.web_port),
           "--port", str(args.port)]
    proc = subprocess.Popen(cmd, env={**os.environ, "BROWSER": "true"}, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)

    def stop(*_: Any) -> NoReturn:
        raise KeyboardInterrupt

    signal.signal(signal.SIGTERM, stop)
    print(f"web viewer: {web_url(args.web_port, args.port)}   (127.0.0.1 only; Ctrl-C stops it)", flush=True)
    try:
        return proc.wait()
    except KeyboardInterrupt:
        return 0
    finally:
        if proc.poll() is None:
            proc.terminate()
            try:
                proc.wait(10)
            except subprocess.TimeoutExpired:
                proc.kill()


# -- the parser ------------------------------------------------------------------------
def parser() -> argparse.ArgumentParser:
    p = _Parser(prog="phys2d", description="phys2d: run, record, compare and inspect 2D rigid-body scenes.")
    sub = p.add_subparsers(dest="command", metavar="{scenes,run,compare,inspect,view,sweep}")
    sub.required = True

    s = sub.add_parser("scenes", help="the stock scenes and what --size means")
    s.set_defaults(func=cmd_scenes)

    def common(q: argparse.ArgumentParser, default_steps: int) -> None:
        q.add_argument("scene", help="a stock scene (see 'phys2d scenes')")
        q.add_argument("--size", type=_size, default=None, help="the scene's main count (see 'phys2d scenes')")
        q.add_argument("--steps", type=_count, default=default_steps, help="ticks to run (default %(default)s)")
        q.add_argument("--dt", type=_seconds, default=1 / 60, help="tick length in s (default 1/60)")
        q.add_argument("--iterations", type=_count, default=None,
                       help="PGS sweeps, iterative passes or soft-step sub-steps per tick (default 10; soft-step 4)")
        q.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None,
                       help="progress bar on stderr (default: when stderr is a terminal and the run is long)")
        q.add_argument("--no-series", action="store_true",
                       help="leave out the per-contact lambda/penetration series (about half the file); "
                            "the per-tick contact table is kept")

    r = sub.add_parser("run", help="run a scene and record it")
    common(r, 600)
    r.add_argument("--responder", choices=RESPONDERS, default="pgs", help="collision responder (default pgs)")
    out = r.add_mutually_exclusive_group()
    out.add_argument("--out", default=None, help=f"recording path (default {DEFAULT_DIR}/SCENE.rrd)")
    out.add_argument("--no-record", action="store_true", help="run without writing a recording")
    r.set_defaults(func=cmd_run)

    c = sub.add_parser("compare", help="one scene under every responder, in one recording")
    common(c, 300)
    c.add_argument("--out", default=None, help=f"recording path (default {DEFAULT_DIR}/SCENE-compare.rrd)")
    c.set_defaults(func=cmd_compare)

    i = sub.add_parser("inspect", help="a summary table of a recording")
    i.add_argument("path")
    i.set_defaults(func=cmd_inspect)

    v = sub.add_parser("view", help="open a recording in the Rerun viewer")
    v.add_argument("path")
    v.add_argument("--web", action="store_true", help="serve the web viewer on 127.0.0.1 instead")
    v.add_argument("--web-port", type=int, default=9090, help="web viewer port (default %(default)s)")
    v.add_argument("--port", type=int, default=9876, help="data (gRPC) port for --web (default %(default)s)")
    v.set_defaults(func=cmd_view)

    from .sweeps.command import add_parser as add_sweep_parser  # its own module: dask and pyarrow load lazily

    add_sweep_parser(sub)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit code."""
    args = parser().parse_args(argv)
    prog = f"phys2d {args.command}"
    try:
        return int(args.func(args))
    except CLIError as e:
        print(f"{prog}: error: {e}", file=sys.stderr)
    except (ValueError, TypeError, OSError) as e:
        print(f"{prog}: error: {e}", file=sys.stderr)
    except KeyboardInterrupt:
        print(f"{prog}: interrupted", file=sys.stderr)
        return 130
    except Exception as e:  # a bug: still one line, unless asked for the traceback
        if os.environ.get("PHYS2D_DEBUG"):
            raise
        print(f"{prog}: internal error: {type(e).__name__}: {e} (PHYS2D_DEBUG=1 shows the traceback)",
              file=sys.stderr)
    return 1


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
