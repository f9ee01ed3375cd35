"""Lesson 12: your own responder - the lecture's assignment, in plain Python, graded.

Claim (lecture, the assignment: "build a collision response system that supports
collisions between multiple objects"): the lecture's PGS, written from scratch in
about 30 lines of plain Python on the rows the engine hands over (J, M^-1 J^T,
A_kk, the target xi + push, the bounds lo, hi, mu lambda_n), meets every claim of
the lecture the report card measures, and steps a 10-box stack at 100 steps/s or
more (its loops run on lists, not on numpy arrays: docs/your-responder.md, "Fast
plain Python"); the naive take, written the same way, fails where the lecture says
it does: it "does not support stacking".

The two responders are in lessons/your_responder.py (the protocol they follow is in
docs/your-responder.md): copy that file, change it, and grade your own with

    phys2d check lessons/your_responder.py:LecturePGS

Part 1 times a 10-box stack under each. Part 2 runs the stack beside the built-in
responders. Part 3 prints each one's report card, with a hint under each failing
claim (a failing card's scenes are kept in <out>/check/<name>.rrd, one run each).

In the viewer: runs "stack-lecture-pgs" and "stack-pgs" stand side by side, as do
"stack-lecture-naive" and "stack-naive", which both fall. Plot solver/residual: the
plain PGS's falls sweep by sweep, as the engine's does.
"""

import inspect
import os
import time

import _common as c
import numpy as np
from your_responder import LectureNaive, LecturePGS

import phys2d

args = c.options(__doc__)
seconds = 3.0 if args.quick else 10.0
c.claim(
    "the lecture's PGS in ~30 lines of plain Python meets every claim of the report card and steps a "
    "10-box stack at >= 100 steps/s; the naive take fails to stack, as the lecture predicts"
)
for cls in (LecturePGS, LectureNaive):
    print(f"{cls.__name__}.respond: {len(inspect.getsource(cls.respond).splitlines())} lines of plain Python")


# 1. speed: 10-box stack, median of repeats of 100 steps
def steps_per_second(make, repeats=5, steps=100):
    w = phys2d.scenes.vertical_stack(10, responder=make())
    w.step(c.DT)  # compile or warm up
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        for _ in range(steps):
            w.step(c.DT)
        times.append(time.perf_counter() - start)
    return steps / float(np.median(times))


speed = {name: steps_per_second(make) for name, make in (("lecture-pgs", LecturePGS), ("pgs", phys2d.PGS))}
print(
    f"10-box stack: lecture-pgs {speed['lecture-pgs']:.0f} steps/s in plain Python, "
    f"the engine's pgs {speed['pgs']:.0f} steps/s (median of 5 x 100 steps)"
)

# 2. the stack under each, recorded side by side
responders = {"lecture-pgs": LecturePGS, "pgs": phys2d.PGS, "lecture-naive": LectureNaive, "naive": phys2d.NaiveImpulse}
rows = []
with c.recorder(args, __file__, "lesson 12: your own responder") as rec:
    for name, make in responders.items():
        w = phys2d.scenes.vertical_stack(10, responder=make())
        x0 = w.x.copy()
        c.simulate(w, seconds, rec, f"stack-{name}")
        rows.append([name, float(np.hypot(*(w.x - x0).T).max()), w.x[-1, 1]])
print(f"10-box stack, {seconds:g} s:")
c.table(["responder", "largest move (m)", "top box y (m, was 9.5)"], rows, "{:.3f}")

# 3. the report cards
cards = {}
for name, make in responders.items():
    print(f"\nreport card: {name}")
    cards[name] = phys2d.check(make(), quick=args.quick, out=os.path.join(args.out, "check"))
passes = {name: sum(r.passed for r in card.results) for name, card in cards.items()}
print(
    f"\nTAKEAWAY: the plain-Python PGS passes {passes['lecture-pgs']} of {len(cards['lecture-pgs'].results)} claims "
    f"(the engine's {passes['pgs']}) at {speed['lecture-pgs']:.0f} steps/s; the naive take written the same way "
    f"passes {passes['lecture-naive']} and its stack falls, as the lecture predicts"
)
c.done(rec)
