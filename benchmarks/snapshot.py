"""What a snapshot of a world costs: its size, and the time to take, restore and hash it.

    PYTHONPATH=. python benchmarks/snapshot.py [--scenes pyramid_20 ...] [--ticks 120] [--repeats 300]
                                               [--markdown benchmarks/SNAPSHOT.md]

For each scene: built, stepped ``ticks`` ticks of 1/60 s (so it has contacts, a cache and
manifolds), then ``w.snapshot()``, ``w.restore(data)``, ``World.from_snapshot(data)`` and
``w.state_hash()`` each timed ``repeats`` times. Reports the snapshot's size (kB), a pickle's
size for comparison (it keeps the buffers' spare room), the zlib-compressed size a recording's
keyframe takes (level 1, as the recorder writes it), and per operation the fastest and the
median time in ms. The goal for pyramid_20 is at most 1 ms each for snapshot and restore; on
a shared machine the median moves with the load, the fastest less (the load average is printed).
``--markdown FILE`` appends the table, with the date, the load and the commit, to FILE.
"""

from __future__ import annotations

import argparse
import os
import pickle
import statistics
import subprocess
import sys
import time
import zlib

HERE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, HERE)

import phys2d  # noqa: E402
from phys2d import stock_scenes  # noqa: E402

SCENES = {
    "pyramid_20": lambda: phys2d.scenes.pyramid(20),
    "pyramid_20_soft": lambda: phys2d.scenes.pyramid(20, responder=phys2d.SoftStep()),
    "pendulum_chain_10": lambda: phys2d.scenes.pendulum_chain(10),
    "bridge_160": lambda: stock_scenes.bridge(160),
    "large_pyramid_100": lambda: stock_scenes.large_pyramid(100),
}


def timed(f, repeats: int) -> tuple[float, float]:
    """(fastest, median) of ``repeats`` calls of f, ms."""
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        f()
        times.append(time.perf_counter() - t0)
    return 1e3 * min(times), 1e3 * statistics.median(times)


def measure(name: str, ticks: int, repeats: int) -> list:
    w = SCENES[name]()
    for _ in range(ticks):
        w.step(1 / 60)
    data = w.snapshot()
    twin = phys2d.World.from_snapshot(data)
    sizes = [len(data) / 1e3, len(pickle.dumps(w)) / 1e3, len(zlib.compress(data, 1)) / 1e3]
    row = [name, len(w), len(w.contacts), *sizes]
    for f in (w.snapshot, lambda: twin.restore(data), lambda: phys2d.World.from_snapshot(data), w.state_hash):
        row += timed(f, repeats)
    return row


HEADER = [
    "scene", "bodies", "contacts", "snapshot kB", "pickle kB", "keyframe kB (zlib 1)",
    "snapshot ms (min)", "snapshot ms (median)", "restore ms (min)", "restore ms (median)",
    "from_snapshot ms (min)", "from_snapshot ms (median)", "state_hash ms (min)", "state_hash ms (median)",
]  # fmt: skip


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scenes", nargs="+", default=["pyramid_20", "pyramid_20_soft", "pendulum_chain_10"])
    p.add_argument("--ticks", type=int, default=120)
    p.add_argument("--repeats", type=int, default=300)
    p.add_argument("--markdown", default=None)
    args = p.parse_args()
    unknown = [s for s in args.scenes if s not in SCENES]
    if unknown:
        raise SystemExit(f"unknown scene {unknown[0]!r}: choose from {', '.join(SCENES)}")
    load = os.getloadavg()[0]
    rows = [measure(name, args.ticks, args.repeats) for name in args.scenes]
    lines = ["| " + " | ".join(HEADER) + " |", "|" + " --- |" * len(HEADER)]
    for row in rows:
        cells = [str(v) if isinstance(v, (str, int)) else f"{v:.3g}" for v in row]
        lines.append("| " + " | ".join(cells) + " |")
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=HERE, capture_output=True, text=True)
    note = (
        f"{time.strftime('%Y-%m-%d')}, commit {commit.stdout.strip() or '?'}, {args.ticks} ticks stepped first, "
        f"{args.repeats} repeats, load average {load:.2f} before, {os.getloadavg()[0]:.2f} after"
    )
    print("\n".join(lines))
    print(note)
    if args.markdown:
        with open(args.markdown, "a") as fh:
            fh.write(f"\n{note}\n\n" + "\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
