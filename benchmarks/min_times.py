"""Min CPU time per step of small and mid-size scenes: for comparing two checkouts of phys2d.

    python benchmarks/min_times.py                           # every scene and responder below
    python benchmarks/min_times.py --scenes stack20 pyr40 --responders pgs soft
    PYTHONPATH=/path/to/other/checkout python benchmarks/min_times.py   # the other checkout

Each scene (``phys2d.scenes``) under each responder (``PGS()``, ``PGS(block=True)``, ``SoftStep()``):
60 steps to settle (and compile), then the min over ``--repeats`` repeats of the CPU time per step
(``time.process_time``, garbage collector off) of 300 steps (40 for the pyramids). A min, not a
median: a step is a few microseconds on the small scenes, and on a shared 2-core machine their
medians spread more than the differences between two checkouts (``--median`` prints the
median instead, for larger scenes). Run it in fresh processes, alternating the checkouts, and
compare the mins over the rounds (benchmarks/RESULTS.md).
"""

from __future__ import annotations

import argparse
import gc
import os
import statistics
import time
from collections.abc import Callable

import phys2d
from phys2d import scenes

# Compile in this process, before anything is timed: after an edit, phys2d by default steps
# stage by stage while a child process compiles the tick beside the timed steps (pipeline.ahead).
os.environ.setdefault("PHYS2D_COMPILE_AHEAD", "0")

RESPONDERS: dict[str, Callable[[], phys2d.Responder]] = {
    "pgs": lambda: phys2d.PGS(iterations=10),
    "pgs-lecture": lambda: phys2d.PGS(iterations=10, split=False),  # the lecture's push, in xi
    "block": lambda: phys2d.PGS(iterations=10, block=True),
    "soft": lambda: phys2d.SoftStep(),
}
SCENES: dict[str, Callable[[phys2d.Responder], phys2d.World]] = {
    "stack10": lambda r: scenes.vertical_stack(10, responder=r),
    "stack20": lambda r: scenes.vertical_stack(20, responder=r),
    "pyr20": lambda r: scenes.pyramid(20, responder=r),
    "pyr40": lambda r: scenes.pyramid(40, responder=r),
    "mass100": lambda r: scenes.mass_ratio(100.0, responder=r),
    "chain20": lambda r: scenes.heavy_chain(responder=r),
}


def min_time(world: phys2d.World, steps: int, repeats: int, median: bool = False) -> float:
    """The least (or with ``median`` the median) CPU time per step (µs) over ``repeats`` runs of
    ``steps`` steps."""
    times = []
    gc.disable()
    try:
        for _ in range(repeats):
            t = time.process_time()
            for _ in range(steps):
                world.step(1 / 60)
            times.append((time.process_time() - t) / steps * 1e6)
    finally:
        gc.enable()
    return statistics.median(times) if median else min(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", nargs="+", choices=list(SCENES), default=list(SCENES))
    parser.add_argument("--responders", nargs="+", choices=list(RESPONDERS), default=list(RESPONDERS))
    parser.add_argument("--repeats", type=int, default=15)
    parser.add_argument("--median", action="store_true", help="the median over the repeats, not the min")
    args = parser.parse_args()
    out = []
    for scene in args.scenes:
        for name in args.responders:
            world = SCENES[scene](RESPONDERS[name]())
            for _ in range(60):
                world.step(1 / 60)
            steps = 40 if scene.startswith("pyr") else 300
            out.append(f"{scene}/{name}={min_time(world, steps, args.repeats, args.median):.1f}")
    print(" ".join(out))


if __name__ == "__main__":
    main()
