"""What recording costs per tick: a 20-row pyramid stepped with and without a Recorder.

    PYTHONPATH=. python benchmarks/recording.py [--rows 20] [--steps 600] [--repeats 5]

Each repeat builds the scene afresh, lets it settle for a few ticks (numba compiles on
the first), then times ``steps`` ticks of ``w.step`` alone and ``steps`` ticks of
``w.step`` + ``rec.log`` + the final ``close`` (which writes the buffered columns and
the footer). The two runs alternate so drift hits both. Reports the median over
repeats of the wall time per tick (ms) with recording off and on, their difference
(the recording cost), and the file size.
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time

import phys2d
from phys2d.recording import Recorder


def run(rows: int, steps: int, path: str | None, dt: float = 1 / 60) -> tuple[float, int]:
    """Seconds for ``steps`` ticks (plus closing the recording), and the final contact count."""
    w = phys2d.scenes.pyramid(rows)
    for _ in range(5):
        w.step(dt)
    rec = Recorder(path, name=f"pyramid {rows}", scene="pyramid") if path else None
    t0 = time.perf_counter()
    for _ in range(steps):
        w.step(dt)
        if rec is not None:
            rec.log(w)
    if rec is not None:
        rec.close()
    return time.perf_counter() - t0, len(w.contacts)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rows", type=int, default=20)
    ap.add_argument("--steps", type=int, default=600)
    ap.add_argument("--repeats", type=int, default=5)
    a = ap.parse_args()
    run(a.rows, 10, None)  # compile
    off, on, sizes = [], [], []
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "pyramid.rrd")
        for _ in range(a.repeats):
            t_off, k = run(a.rows, a.steps, None)
            t_on, _ = run(a.rows, a.steps, path)
            off.append(1e3 * t_off / a.steps)
            on.append(1e3 * t_on / a.steps)
            sizes.append(os.path.getsize(path))
    cost = [b - a_ for a_, b in zip(off, on, strict=True)]
    print(f"pyramid({a.rows}): {k} contacts at the end, {a.steps} ticks, median of {a.repeats} repeats")
    print(f"  recording off: {statistics.median(off):.3f} ms/tick  (all: {', '.join(f'{x:.3f}' for x in off)})")
    print(f"  recording on:  {statistics.median(on):.3f} ms/tick  (all: {', '.join(f'{x:.3f}' for x in on)})")
    print(f"  recording cost: {statistics.median(cost):.3f} ms/tick (median of the per-repeat differences)")
    print(f"  file: {statistics.median(sizes) / 1e6:.1f} MB, {statistics.median(sizes) / a.steps / 1e3:.0f} kB/tick")


if __name__ == "__main__":
    main()
