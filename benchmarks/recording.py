"""What recording costs a user, end to end through the command, and how big the file is.

    PYTHONPATH=. python benchmarks/recording.py [--sizes 20 40] [--steps 600] [--repeats 5] [--repo PATH]
                                                [--markdown benchmarks/RECORDING.md]

For each pyramid size, runs ``python -m phys2d run pyramid --size N --steps S`` as a
user does, once with ``--no-record`` and once writing a recording, ``repeats``
times, alternating which goes first so drift hits both. Each run is a fresh process,
so the figures include everything a user waits for: importing rerun, sampling, the
writer threads, closing the file (footer) and process exit. Reports per size:

    cost per tick   median over repeats of (wall time with recording - without) / steps, ms
    CPU per tick    the same for user + system CPU time of the process (all its threads), ms
    size per tick   file size / (steps + 1), kB (tick 0, the scene as built, is recorded too)

    run without   median wall time of the ``--no-record`` runs, s (what the cost is added to)

``--repo`` (repeatable) runs other checkouts' ``phys2d`` (e.g. an older commit), repeat
by repeat beside this one, so before/after figures come from one run under the same
load. Timings on a shared machine are noisy: compare figures from one run; the load
average (1 min) is printed before and after each size. ``--markdown FILE`` appends the
figures as a table (with the date, the load and the commit) to FILE.
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from typing import Any

HERE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def run_once(repo: str, size: int, steps: int, out: str | None) -> tuple[float, float]:
    """(wall s, CPU s) of one ``phys2d run`` process, run outside any checkout (``python -m``
    puts the working directory first on the path), with ``repo`` on PYTHONPATH."""
    args = [sys.executable, "-m", "phys2d", "run", "pyramid", "--size", str(size), "--steps", str(steps)]
    args += ["--out", out] if out else ["--no-record"]
    env = {**os.environ, "PYTHONPATH": repo}
    env.pop("PHYS2D_DEBUG", None)
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(args, env=env, capture_output=True, text=True, cwd=tempfile.gettempdir())
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        raise SystemExit(f"phys2d run failed ({repo}): {proc.stderr.strip()}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


def measure(repos: list[str], size: int, steps: int, repeats: int) -> dict[str, dict[str, Any]]:
    """Per repo: the median recording cost per tick (wall and CPU, ms), each repeat's, the size."""
    walls: dict[str, list[float]] = {r: [] for r in repos}
    bases: dict[str, list[float]] = {r: [] for r in repos}
    cpus: dict[str, list[float]] = {r: [] for r in repos}
    sizes: dict[str, list[int]] = {r: [] for r in repos}
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "pyramid.rrd")
        for repo in repos:
            run_once(repo, size, 20, path)  # warm the numba cache and the file system
        for k in range(repeats):
            for repo in repos:  # every repo in every repeat: the same load for all
                order = (None, path) if k % 2 == 0 else (path, None)
                got = {}
                for out in order:
                    got[out] = run_once(repo, size, steps, out)
                walls[repo].append((got[path][0] - got[None][0]) / steps)
                bases[repo].append(got[None][0])
                cpus[repo].append((got[path][1] - got[None][1]) / steps)
                sizes[repo].append(os.path.getsize(path))
    return {
        r: {
            "cost_ms": 1e3 * statistics.median(walls[r]),
            "cpu_ms": 1e3 * statistics.median(cpus[r]),
            "all_ms": [1e3 * w for w in walls[r]],
            "size_kb": statistics.median(sizes[r]) / (steps + 1) / 1e3,
            "size_mb": statistics.median(sizes[r]) / 1e6,
            "base_s": statistics.median(bases[r]),
        }
        for r in repos
    }


def commit(repo: str) -> str:
    """The checkout's short commit, with '+' when it has uncommitted changes."""
    try:
        head = subprocess.run(
            ["git", "-C", repo, "rev-parse", "--short", "HEAD"], capture_output=True, text=True, check=True
        ).stdout.strip()
        dirty = subprocess.run(
            ["git", "-C", repo, "status", "--porcelain", "--untracked-files=no"], capture_output=True, text=True
        ).stdout.strip()
        return head + ("+" if dirty else "")
    except (OSError, subprocess.CalledProcessError):
        return "?"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[20, 40], help="pyramid rows (default 20 40)")
    ap.add_argument("--steps", type=int, default=600)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument(
        "--repo",
        action="append",
        default=[],
        help="also run this checkout's phys2d, repeat by repeat beside this one (repeatable)",
    )
    ap.add_argument("--markdown", default=None, help="append the figures as a markdown table to this file")
    a = ap.parse_args()
    repos = [os.path.abspath(r) for r in a.repo] + [HERE]
    print(
        f"phys2d run pyramid --steps {a.steps}, recording on vs --no-record, {a.repeats} repeats; "
        f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores"
    )
    commits = {repo: commit(repo) for repo in repos}  # before measuring: a checkout may move meanwhile
    rows = []
    for size in a.sizes:
        load0 = os.getloadavg()[0]
        results = measure(repos, size, a.steps, a.repeats)
        load1 = os.getloadavg()[0]
        for repo, r in results.items():
            print(
                f"pyramid_{size} [{repo} {commits[repo]}]: recording costs {r['cost_ms']:.2f} ms per tick end to "
                f"end (CPU {r['cpu_ms']:.2f} ms; each repeat: {', '.join(f'{x:.2f}' for x in r['all_ms'])}; "
                f"run without recording {r['base_s']:.2f} s); file {r['size_mb']:.1f} MB, "
                f"{r['size_kb']:.1f} kB per tick; load {load0:.1f} -> {load1:.1f}"
            )
            each = ", ".join(f"{x:.2f}" for x in r["all_ms"])
            rows.append(
                f"| pyramid_{size} | {commits[repo]} | {r['size_kb']:.1f} kB ({r['size_mb']:.1f} MB) | "
                f"{r['cost_ms']:.2f} ms | {r['cpu_ms']:.2f} ms | {each} | "
                f"{r['base_s']:.2f} s | {load0:.1f} -> {load1:.1f} |"
            )
    if a.markdown:
        with open(a.markdown, "a") as f:
            f.write(
                f"\n`python benchmarks/recording.py --steps {a.steps} --repeats {a.repeats}`, "
                f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, {os.cpu_count()} cores:\n\n"
                "| scene | commit | file per tick | cost per tick, wall | CPU | each repeat (ms) | "
                "run without recording | load (1 min) |\n| --- | --- | --- | --- | --- | --- | --- | --- |\n"
            )
            f.write("\n".join(rows) + "\n")


if __name__ == "__main__":
    main()
