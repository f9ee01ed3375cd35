"""What a learner waits for before phys2d simulates anything: numba's compiles, end to end.

    python benchmarks/startup.py                        # all four parts on this checkout
    python benchmarks/startup.py --repo /tmp/base_wt    # another checkout (a git worktree of an older commit)
    python benchmarks/startup.py --only cold,warm --repeats 3 --markdown

Every command is timed as typed, in a subprocess, by the wall clock, with
``PYTHONPATH=<repo>`` so that ``python -m phys2d`` imports the checkout measured (not
the installed one) and ``NUMBA_CACHE_DIR`` set to a directory of this script's own:

1. **cold**: ``python -m phys2d run pyramid --size 20 --steps 600`` (the README's main
   job, recording included) with a fresh, empty ``NUMBA_CACHE_DIR``
   (``tempfile.mkdtemp``), and the same with ``--responder soft-step``, each in its own
   fresh cache and in a temporary working directory (the recordings land there);
2. **warm**: the same two commands again, each with the cache its cold run filled;
3. **edit**: on a copy of the checkout (``shutil.copytree`` without ``.git``, the
   recordings, ``__pycache__`` and the egg-info; run with ``PYTHONPATH`` and the working
   directory both the copy), for each module of ``phys2d/responders/`` that holds numba
   kernels (``@njit``): warm the copy's cache, time a warm run, append one comment line
   to the module, time ``python -m phys2d run pyramid --size 10 --steps 60 --no-record``,
   and restore the module (the next module's warm-up recompiles what the restore made
   stale); then the same with ``--responder soft-step`` around an edit of each of the
   soft step's modules (``responders/soft_*.py``);
4. **kernels**: in a child process with a fresh ``NUMBA_CACHE_DIR`` and a listener on
   numba's ``"numba:compile"`` event, ``scenes.pyramid(15, responder=...)`` and one
   step, for ``pgs`` and ``soft-step``: each function's compile time inclusive (the whole
   event) and exclusive (less the compiles nested inside it, kept on a stack of open
   events), its number of signatures, and the totals. numba's compile event does not
   cover writing the cache file, so the totals are a little under the first step.

``--repeats N`` takes the median of N runs of each timed command (cold: N fresh caches);
every run is shown beside the median. After each timed command the script waits, untimed, for
the compile children it left (``phys2d.pipeline.ahead``) to finish, so no two runs overlap.
``--markdown`` prints Markdown tables for benchmarks/STARTUP.md. The load average is printed
before and after each part: the figures mean little on a busy machine. Only the standard library is used here; numba
is imported in the kernels child alone.
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import os
import platform
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

DEFAULT_REPO = Path(__file__).resolve().parent.parent
PARTS = ("cold", "warm", "edit", "kernels")
RESPONDERS = ("pgs", "soft-step")
MAIN_JOB = ("run", "pyramid", "--size", "20", "--steps", "600")
EDIT_JOB = ("run", "pyramid", "--size", "10", "--steps", "60", "--no-record")
KERNEL_SCENE_SIZE = 15
TOP = 20
EDIT_LINE = "# benchmarks/startup.py: an edit (one comment line)\n"
COPY_IGNORE = (".git", "recordings", "__pycache__", "*.egg-info", ".pytest_cache", ".ruff_cache", ".mypy_cache")
TIMEOUT = 3600.0  # s, for one command


@dataclass
class Table:
    """One table of results: a title, column headers, rows of cells, notes below it."""

    title: str
    headers: list[str]
    rows: list[list[str]] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    text_columns: int = 1  # the leading columns of text (left-aligned); the others hold figures


def job_args(job: Sequence[str], responder: str) -> list[str]:
    """The phys2d command line ``job`` with ``responder`` (pgs is the default, left unsaid)."""
    return list(job) + ([] if responder == "pgs" else ["--responder", responder])


def shown(args: Sequence[str]) -> str:
    """A command as a learner types it."""
    return " ".join(["python", "-m", "phys2d", *args])


def environment(repo: Path, cache: Path) -> dict[str, str]:
    """This process's environment with phys2d imported from ``repo`` and numba caching in ``cache``."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(repo)] + ([env["PYTHONPATH"]] if env.get("PYTHONPATH") else []))
    env["NUMBA_CACHE_DIR"] = str(cache)
    env.pop("NUMBA_DISABLE_JIT", None)
    return env


def timed(args: Sequence[str], repo: Path, cache: Path, cwd: Path) -> float:
    """Wall-clock seconds of ``python -m phys2d *args``, run from ``cwd`` with phys2d from ``repo``."""
    start = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-m", "phys2d", *args],
        cwd=cwd,
        env=environment(repo, cache),
        capture_output=True,
        text=True,
        timeout=TIMEOUT,
        check=False,
    )
    seconds = time.perf_counter() - start
    if done.returncode != 0:
        raise RuntimeError(f"{shown(args)} failed ({done.returncode}):\n{done.stdout[-2000:]}{done.stderr[-4000:]}")
    wait_for_compiling_children()
    return seconds


def compiling_children() -> list[int]:
    """The processes still compiling a tick into a cache (``phys2d.pipeline.ahead``'s children,
    which outlive the run that started them); Linux only (/proc), else none."""
    found = []
    for cmdline in Path("/proc").glob("[0-9]*/cmdline"):
        try:
            if b"phys2d.pipeline.ahead" in cmdline.read_bytes():
                found.append(int(cmdline.parent.name))
        except OSError:  # it ended while we looked
            continue
    return found


def wait_for_compiling_children(limit: float = 600.0) -> None:
    """Wait (untimed) until no child of the last run compiles on: the next timed run then has
    the machine to itself, as a learner's next command would a while later."""
    end = time.monotonic() + limit
    while compiling_children() and time.monotonic() < end:
        time.sleep(0.2)


def median_cell(samples: Sequence[float]) -> str:
    """The median of ``samples`` in seconds, with every sample beside it when there are several."""
    text = f"{statistics.median(samples):.2f}"
    if len(samples) > 1:
        text += " (" + ", ".join(f"{s:.2f}" for s in samples) + ")"
    return text


def load() -> str:
    """The 1, 5 and 15 minute load averages."""
    return " / ".join(f"{x:.2f}" for x in os.getloadavg())


@contextmanager
def temporary(prefix: str) -> Iterator[Path]:
    """A fresh, empty directory (``tempfile.mkdtemp``), removed afterwards."""
    path = Path(tempfile.mkdtemp(prefix=prefix))
    try:
        yield path
    finally:
        shutil.rmtree(path, ignore_errors=True)


def measure_cold_warm(repo: Path, repeats: int, parts: set[str]) -> list[Table]:
    """Parts 1 and 2: the main job (and with soft-step) in fresh caches, then again in the caches they filled."""
    cold: dict[str, list[float]] = {r: [] for r in RESPONDERS}
    warm: dict[str, list[float]] = {r: [] for r in RESPONDERS}
    loads = [load()]
    for responder in RESPONDERS:
        args = job_args(MAIN_JOB, responder)
        with temporary("startup-cwd-") as cwd, temporary("startup-cache-") as cache:
            first = timed(args, repo, cache, cwd)
            if "cold" in parts:
                cold[responder].append(first)
                for _ in range(repeats - 1):  # each in a fresh cache of its own
                    with temporary("startup-cache-") as fresh:
                        cold[responder].append(timed(args, repo, fresh, cwd))
            if "warm" in parts:
                warm[responder] = [timed(args, repo, cache, cwd) for _ in range(repeats)]
    loads.append(load())
    tables = []
    for part, samples, what in (
        ("cold", cold, "fresh, empty NUMBA_CACHE_DIR"),
        ("warm", warm, "the NUMBA_CACHE_DIR its cold run filled"),
    ):
        if part not in parts:
            continue
        table = Table(f"{part}: the main job, {what}", ["command", "wall s"])
        for responder in RESPONDERS:
            table.rows.append([f"`{shown(job_args(MAIN_JOB, responder))}`", median_cell(samples[responder])])
        table.notes.append(f"load average (1/5/15 min) before {loads[0]}, after {loads[1]}")
        tables.append(table)
    return tables


def kernel_modules(copy: Path) -> list[Path]:
    """The modules of ``phys2d/responders/`` that hold numba kernels (``@njit``), sorted."""
    folder = copy / "phys2d" / "responders"
    return sorted(p for p in folder.glob("*.py") if "@njit" in p.read_text(encoding="utf-8"))


def edited_run(copy: Path, cache: Path, module: Path, responder: str) -> tuple[float, float]:
    """Warm ``cache`` for the edit job, time a warm run, then time the job after appending a line
    to ``module`` (restored before returning): (warm s, after-the-edit s)."""
    args = job_args(EDIT_JOB, responder)
    timed(args, copy, cache, copy)  # compiles whatever is stale: all of it at first, after a restore its dependents
    warm = timed(args, copy, cache, copy)
    original = module.read_bytes()
    try:
        text = original.decode("utf-8")
        module.write_text(text + ("" if text.endswith("\n") else "\n") + EDIT_LINE, encoding="utf-8")
        edited = timed(args, copy, cache, copy)
    finally:
        module.write_bytes(original)
    return warm, edited


def measure_edit(repo: Path, repeats: int) -> list[Table]:
    """Part 3: one edit of each kernel module of the responders, on a copy of the checkout."""
    loads = [load()]
    with temporary("startup-copy-") as top, temporary("startup-cache-") as cache:
        copy = top / repo.name
        shutil.copytree(repo, copy, ignore=shutil.ignore_patterns(*COPY_IGNORE), symlinks=True)
        jobs = [(module, "pgs") for module in kernel_modules(copy)]
        # the soft step's modules again with the soft step: the run that compiles them
        jobs += [(module, "soft-step") for module in kernel_modules(copy) if module.name.startswith("soft_")]
        table = Table(
            "edit-then-run: one comment line appended to a module, the cache warm before it",
            ["module edited", "command", "warm s", "after the edit s"],
            text_columns=2,
        )
        for module, responder in jobs:
            warm: list[float] = []
            edited: list[float] = []
            for _ in range(repeats):
                w, e = edited_run(copy, cache, module, responder)
                warm.append(w)
                edited.append(e)
            table.rows.append(
                [
                    f"`{module.relative_to(copy).as_posix()}`",
                    f"`{shown(job_args(EDIT_JOB, responder))}`",
                    median_cell(warm),
                    median_cell(edited),
                ]
            )
    loads.append(load())
    table.notes.append(
        "PYTHONPATH and the working directory: a copy of the checkout; one NUMBA_CACHE_DIR for the copy, "
        "warmed by a run of the same command before each edit (and its warm run timed after that)"
    )
    table.notes.append(f"load average (1/5/15 min) before {loads[0]}, after {loads[1]}")
    return [table]


def kernels_child(responder: str, repo: str) -> None:
    """In a child process: compile events of building ``scenes.pyramid`` and one step, as JSON on stdout."""
    from numba.core import event

    compiles: list[dict[str, Any]] = []
    stack: list[list[float]] = []  # per open compile event: [its start, the inclusive time of compiles inside it]

    def name_of(dispatcher: Any) -> str:
        func = dispatcher.py_func
        module = func.__module__
        if module is None:  # numba may leave it unset: name the file instead
            filename = Path(func.__code__.co_filename)
            try:
                module = filename.resolve().relative_to(Path(repo).resolve()).as_posix()
            except ValueError:
                module = filename.as_posix()
        return f"{module}.{func.__qualname__}"

    class Timer(event.Listener):
        def on_start(self, ev: Any) -> None:
            stack.append([time.perf_counter(), 0.0])

        def on_end(self, ev: Any) -> None:
            start, nested = stack.pop()
            inclusive = time.perf_counter() - start
            if stack:
                stack[-1][1] += inclusive
            compiles.append(
                {
                    "name": name_of(ev.data["dispatcher"]),
                    "args": str(ev.data["args"]),
                    "inclusive": inclusive,
                    "exclusive": inclusive - nested,
                    "top": not stack,
                }
            )

    event.register("numba:compile", Timer())
    start = time.perf_counter()
    from phys2d import scenes
    from phys2d.responders import make_responder

    imported = time.perf_counter()
    world = scenes.pyramid(KERNEL_SCENE_SIZE, responder=make_responder(responder))
    built = time.perf_counter()
    world.step(1 / 60)
    stepped = time.perf_counter()
    phases = {"import": imported - start, "build": built - imported, "step": stepped - built}
    print(json.dumps({"phases": phases, "compiles": compiles}))


def measure_kernels(repo: Path) -> list[Table]:
    """Part 4: compile time per kernel, for each responder, each in a fresh cache."""
    tables = []
    for responder in RESPONDERS:
        before = load()
        with temporary("startup-cache-") as cache, temporary("startup-cwd-") as cwd:
            done = subprocess.run(
                [sys.executable, str(Path(__file__).resolve()), "--kernels-child", responder, "--repo", str(repo)],
                cwd=cwd,
                env=environment(repo, cache),
                capture_output=True,
                text=True,
                timeout=TIMEOUT,
                check=False,
            )
        if done.returncode != 0:
            raise RuntimeError(f"the kernels child failed ({done.returncode}):\n{done.stderr[-4000:]}")
        found = json.loads(done.stdout.strip().splitlines()[-1])
        tables.append(kernel_table(responder, found["compiles"], found["phases"], (before, load())))
    return tables


def kernel_table(
    responder: str, compiles: list[dict[str, Any]], phases: dict[str, float], loads: tuple[str, str]
) -> Table:
    """The top functions by exclusive compile time, and the totals, from the kernels child's events."""
    per: dict[str, list[float]] = {}  # name -> [inclusive, exclusive, signatures]
    for c in compiles:
        entry = per.setdefault(c["name"], [0.0, 0.0, 0])
        entry[0] += c["inclusive"]
        entry[1] += c["exclusive"]
        entry[2] += 1
    ranked = sorted(per.items(), key=lambda item: -item[1][1])
    table = Table(
        f"kernels: compile time per function, `scenes.pyramid({KERNEL_SCENE_SIZE}, responder="
        f'make_responder("{responder}"))` and one step, fresh cache (top {TOP} by exclusive time)',
        ["function", "inclusive s", "exclusive s", "signatures"],
    )
    for name, (inclusive, exclusive, signatures) in ranked[:TOP]:
        table.rows.append([f"`{name}`", f"{inclusive:.2f}", f"{exclusive:.2f}", f"{int(signatures)}"])
    rest = ranked[TOP:]
    if rest:
        table.rows.append(
            [
                f"the other {len(rest)} functions",
                "",
                f"{sum(v[1] for _, v in rest):.2f}",
                f"{int(sum(v[2] for _, v in rest))}",
            ]
        )
    total = sum(c["inclusive"] for c in compiles if c["top"])
    exclusive = sum(c["exclusive"] for c in compiles)
    table.rows.append(["**total**", f"{total:.2f}", f"{exclusive:.2f}", f"{len(compiles)}"])
    table.notes.append(
        f"{len(per)} functions compiled, {len(compiles)} signatures; compile time {total:.2f} s "
        f"(the top-level events; the exclusive times add up to {exclusive:.2f} s)"
    )
    table.notes.append(
        f"child process: import phys2d {phases['import']:.2f} s, build the scene {phases['build']:.2f} s, "
        f"first step {phases['step']:.2f} s"
    )
    table.notes.append(f"load average (1/5/15 min) before {loads[0]}, after {loads[1]}")
    return table


def git(repo: Path, *args: str) -> str:
    """The output of a git command in ``repo``, or '' when it fails."""
    try:
        done = subprocess.run(["git", "-C", str(repo), *args], capture_output=True, text=True, check=False)
    except OSError:
        return ""
    return done.stdout.strip() if done.returncode == 0 else ""


def header(repo: Path, repeats: int, parts: Sequence[str]) -> list[str]:
    """Lines that say what was measured, where and when."""
    commit = git(repo, "rev-parse", "--short", "HEAD") or "unknown"
    if git(repo, "status", "--porcelain", "--untracked-files=no"):
        commit += " (with uncommitted changes)"
    versions = subprocess.run(
        [sys.executable, "-c", "import numba, numpy; print(numba.__version__, numpy.__version__)"],
        capture_output=True,
        text=True,
        check=False,
    ).stdout.split() or ["?", "?"]
    return [
        f"checkout: {repo} at commit {commit}",
        f"date: {dt.datetime.now(dt.timezone.utc):%Y-%m-%d %H:%M} UTC",
        f"machine: {platform.machine()}, {os.cpu_count()} cores, {platform.platform()}; Python "
        f"{platform.python_version()}, numba {versions[0]}, numpy {versions[-1]}",
        f"load average (1/5/15 min) at the start: {load()}",
        f"parts: {', '.join(parts)}; repeats: {repeats} (median, every run in brackets)",
        f"command: python benchmarks/startup.py {' '.join(sys.argv[1:])}",
    ]


def render(tables: Sequence[Table], lines: Sequence[str], markdown: bool) -> str:
    """The header lines and the tables, as Markdown or as aligned plain text."""
    out: list[str] = []
    if markdown:
        out += [f"- {line}" for line in lines]
        for t in tables:
            out += ["", f"**{t.title}**", "", "| " + " | ".join(t.headers) + " |"]
            out.append("|" + "|".join(" --- " if i < t.text_columns else " ---: " for i in range(len(t.headers))) + "|")
            out += ["| " + " | ".join(row) + " |" for row in t.rows]
            if t.notes:
                out += [""] + [f"- {note}" for note in t.notes]
        return "\n".join(out)
    out += lines
    for t in tables:
        cells = [[c.replace("`", "").replace("**", "") for c in row] for row in [t.headers, *t.rows]]
        widths = [max(len(row[i]) for row in cells) for i in range(len(t.headers))]
        out += ["", t.title]
        for k, row in enumerate(cells):
            aligned = (c.ljust(w) if i < t.text_columns else c.rjust(w) for i, (c, w) in enumerate(zip(row, widths)))
            out.append("  ".join(aligned).rstrip())
            if k == 0:
                out.append("  ".join("-" * w for w in widths))
        out += [f"  {note}" for note in t.notes]
    return "\n".join(out)


def parse(argv: Sequence[str] | None) -> argparse.Namespace:
    """The command line."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawTextHelpFormatter)
    p.add_argument("--repo", type=Path, default=DEFAULT_REPO, help="the checkout to measure (default: %(default)s)")
    p.add_argument("--repeats", type=int, default=1, help="runs of each timed command; the median is shown")
    p.add_argument("--only", default=",".join(PARTS), help=f"the parts to run, comma-separated, of {','.join(PARTS)}")
    p.add_argument("--markdown", action="store_true", help="print Markdown tables for benchmarks/STARTUP.md")
    p.add_argument("--kernels-child", choices=RESPONDERS, help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    args.parts = [part.strip() for part in args.only.split(",") if part.strip()]
    unknown = [part for part in args.parts if part not in PARTS]
    if unknown or not args.parts:
        p.error(f"--only takes some of {','.join(PARTS)}; got {args.only!r}")
    if args.repeats < 1:
        p.error("--repeats must be at least 1")
    args.repo = args.repo.resolve()
    if not (args.repo / "phys2d" / "__main__.py").is_file():
        p.error(f"{args.repo} holds no phys2d package")
    return args


def main(argv: Sequence[str] | None = None) -> int:
    args = parse(argv)
    if args.kernels_child:
        kernels_child(args.kernels_child, str(args.repo))
        return 0
    lines = header(args.repo, args.repeats, args.parts)
    print("\n".join(lines), file=sys.stderr, flush=True)
    parts = set(args.parts)
    tables: list[Table] = []
    for wanted, measure in (
        ({"cold", "warm"}, lambda: measure_cold_warm(args.repo, args.repeats, parts)),
        ({"edit"}, lambda: measure_edit(args.repo, args.repeats)),
        ({"kernels"}, lambda: measure_kernels(args.repo)),
    ):
        if parts & wanted:
            found = measure()
            print(render(found, [], False), file=sys.stderr, flush=True)  # as it goes: the whole run takes minutes
            tables += found
    lines.append(f"load average (1/5/15 min) at the end: {load()}")
    print(render(tables, lines, args.markdown))
    return 0


if __name__ == "__main__":
    sys.exit(main())
