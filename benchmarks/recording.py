"""What recording costs a user, end to end through the command, and how big the file is.

    PYTHONPATH=. python benchmarks/recording.py [--sizes 20 40] [--steps 600] [--repeats 5] [--repo PATH]

For each pyramid size, runs ``python -m phys2d run pyramid --size N --steps S`` as a
user does, once with ``--no-record`` and once writing a recording, ``repeats``
times, alternating which goes first so drift hits both. Each run is a fresh process,
so the figures include everything a user waits for: importing rerun, sampling, the
writer threads, closing the file (footer) and process exit. Reports per size:

    cost per tick   median over repeats of (wall time with recording - without) / steps, ms
    CPU per tick    the same for user + system CPU time of the process (all its threads), ms
    size per tick   file size / (steps + 1), kB (tick 0, the scene as built, is recorded too)

``--repo`` runs another checkout's ``phys2d`` (e.g. an older commit, for before/after
figures). Timings on a shared machine are noisy: compare figures from one run.
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

HERE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def run_once(repo: str, size: int, steps: int, out: str | None) -> tuple[float, float]:
    """(wall s, CPU s) of one ``phys2d run`` process."""
    args = [sys.executable, "-m", "phys2d", "run", "pyramid", "--size", str(size), "--steps", str(steps)]
    args += ["--out", out] if out else ["--no-record"]
    env = {**os.environ, "PYTHONPATH": repo}
    env.pop("PHYS2D_DEBUG", None)
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(args, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        raise SystemExit(f"phys2d run failed: {proc.stderr.strip()}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


def measure(repo: str, size: int, steps: int, repeats: int) -> dict[str, float]:
    walls, cpus, sizes = [], [], []
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "pyramid.rrd")
        run_once(repo, size, 20, path)  # warm the numba cache and the file system
        for k in range(repeats):
            order = (None, path) if k % 2 == 0 else (path, None)
            got = {}
            for out in order:
                got[out] = run_once(repo, size, steps, out)
            walls.append((got[path][0] - got[None][0]) / steps)
            cpus.append((got[path][1] - got[None][1]) / steps)
            sizes.append(os.path.getsize(path))
    return {"cost_ms": 1e3 * statistics.median(walls), "cpu_ms": 1e3 * statistics.median(cpus),
            "all_ms": [1e3 * w for w in walls], "size_kb": statistics.median(sizes) / (steps + 1) / 1e3,
            "size_mb": statistics.median(sizes) / 1e6}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[20, 40], help="pyramid rows (default 20 40)")
    ap.add_argument("--steps", type=int, default=600)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--repo", default=HERE, help="the checkout whose phys2d to run (default: this one)")
    a = ap.parse_args()
    print(f"phys2d run pyramid --steps {a.steps}, recording on vs --no-record, {a.repeats} repeats, "
          f"repo {os.path.abspath(a.repo)}; load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    for size in a.sizes:
        r = measure(a.repo, size, a.steps, a.repeats)
        print(f"pyramid_{size}: recording costs {r['cost_ms']:.2f} ms per tick end to end "
              f"(CPU {r['cpu_ms']:.2f} ms; each repeat: {', '.join(f'{x:.2f}' for x in r['all_ms'])}); "
              f"file {r['size_mb']:.1f} MB, {r['size_kb']:.1f} kB per tick")


if __name__ == "__main__":
    main()
