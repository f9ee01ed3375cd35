"""The Python around the one-call tick, timed apart from the tick's machine code.

    python benchmarks/around_kernel.py                 # vertical_stack(10) under PGS()
    python benchmarks/around_kernel.py --responder soft

``World.step`` is timed with the tick's machine code replaced by a function that returns a
result the real code returned for the same side of the buffers, so what is timed is only the
Python of a step (``World.step``, ``Pipeline.step``, ``_in_one_call``, ``_commit``, the report):
the least time per step over ``--repeats`` runs of ``--steps`` steps, garbage collector off.
The world is stepped into a rest state first, and the stub keeps it there, so every timed
step takes the same path.

Then the crossing into numba's machine code: an empty kernel compiled for the tick's four
arguments (context, settings, solver, counts), called through its machine code entry as the
pipeline calls the tick (``compiled_for``), and each argument alone, against one of an int.
"""

from __future__ import annotations

import argparse
import gc
import time
from collections.abc import Callable

from numba import njit

import phys2d
from phys2d import scenes
from phys2d.pipeline.stages import START
from phys2d.pipeline.step import compiled_for


def least(f: Callable[[], object], steps: int, repeats: int) -> float:
    """The least time of one call of f (ns) over repeats runs of steps calls."""
    best = float("inf")
    for _ in range(repeats):
        t = time.perf_counter()
        for _ in range(steps):
            f()
        best = min(best, (time.perf_counter() - t) / steps)
    return best * 1e9


@njit
def empty4(a, b, c, d):  # noqa: ANN001, ANN201  (numba types it)
    return 1


@njit
def empty1(a):  # noqa: ANN001, ANN201
    return 1


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--responder", choices=("pgs", "soft"), default="pgs")
    p.add_argument("--steps", type=int, default=5000)
    p.add_argument("--repeats", type=int, default=20)
    args = p.parse_args()
    responder = phys2d.PGS() if args.responder == "pgs" else phys2d.SoftStep(substeps=4)
    w = scenes.vertical_stack(10, responder=responder)
    dt = 1 / 60
    for _ in range(200):
        w.step(dt)
    pipe = w._pipeline
    ctx, solver, kernel = pipe._kernel
    kept = {}
    for _ in range(2):  # a result for each side of the buffers
        counts = pipe._counts(pipe._visit, START)
        kept[counts.side] = tuple(kernel(ctx, pipe.settings, solver, counts))
        w.step(dt)

    def stub(ctx: object, settings: object, solver: object, counts: tuple) -> tuple:
        return kept[counts.side]

    pipe._kernel = (ctx, solver, stub)
    for key in pipe._machine:
        pipe._machine[key] = stub
    gc.disable()
    nothing = least(lambda: None, args.steps, args.repeats)
    print(f"World.step around a stub tick: {least(lambda: w.step(dt), args.steps, args.repeats) - nothing:.0f} ns")

    settings = pipe.settings
    four = (ctx, settings, solver, pipe._counts(pipe._visit, START))
    empty4(*four)
    entry = compiled_for(empty4, four)
    print(f"crossing, all four arguments: {least(lambda: entry(*four), args.steps, args.repeats) - nothing:.0f} ns")
    alone = (("an int", 1), ("context", ctx), ("settings", settings), ("solver", solver), ("counts", four[3]))
    for name, value in alone:
        empty1(value)
        one = compiled_for(empty1, (value,))
        print(f"crossing, {name} alone: {least(lambda: one(value), args.steps, args.repeats) - nothing:.0f} ns")  # noqa: B023


if __name__ == "__main__":
    main()
