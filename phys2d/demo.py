"""The main job until recordings land: a 20-row pyramid stepped 10 s and summarised."""

from __future__ import annotations

import time

import numpy as np

from . import scenes


def main(rows: int = 20, seconds: float = 10.0, dt: float = 1 / 60) -> None:
    w = scenes.pyramid(rows)
    start = w.x.copy()
    steps = int(round(seconds / dt))
    t0 = time.perf_counter()
    deepest = 0.0
    for _ in range(steps):
        w.step(dt)
        deepest = max(deepest, w.last_step.max_penetration)
    elapsed = time.perf_counter() - t0
    moved = float(np.max(np.linalg.norm(w.x - start, axis=1)))
    print(f"{w!r}")
    print(f"{steps} steps of {dt:.4g} s in {elapsed:.2f} s ({1e3 * elapsed / steps:.3f} ms/step, "
          "first step includes numba compilation)")
    print(f"contacts: {len(w.contacts)}, cache hit rate {w.last_step.cache_hit_rate:.3f}, "
          f"residual after {w.last_step.iterations} iterations {w.last_step.residuals[-1]:.3g} m/s")
    print(f"largest movement of a box: {moved:.4f} m; deepest overlap: {deepest * 1e3:.2f} mm")


if __name__ == "__main__":
    main()
