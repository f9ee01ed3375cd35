"""Lesson 2: naive take number 2 - the pairwise impulses again and again within a tick.

Claim (lecture, "Naive take number 2"): applying the pair impulses several times
per tick and adding them up helps a little, but "constraints are still broken,
hack-y method, gives no guarantees, still does not support stacking". Measured
here: the help is the stack standing a little longer; the dropped boxes jitter
more with more passes, not less (their leftover kinetic energy rises).

The scenes of lesson 1 (three dropped boxes, an 8-box stack with a 2 cm zigzag)
run with IterativeImpulse(passes) for 1 pass (= lesson 1's NaiveImpulse) up to
20 passes. Measured: kinetic energy left on the dropped boxes, how long the
stack stood (all 8 boxes within 0.25 m of where they started), the deepest
penetration while it stood, and how many boxes stand at the end. PGS (lesson 5)
is the last row, for reference.

In the viewer: compare the runs stack-p1 ... stack-p20 side by side; every
naive stack sinks and leans, then falls (more passes only delay it); stack-pgs
stands. stats/max_penetration shows how deep the boxes sink into each other.
"""

import _common as c
import numpy as np

import phys2d

args = c.options(__doc__)
seconds = 5.0 if args.quick else 10.0
last = round(1.0 / c.DT)
c.claim(
    "more passes of the naive impulse keep a stack up a little longer, but make dropped boxes jitter more, "
    "and still give no stacking and no guarantees"
)
print(f"{seconds:g} s of each scene at dt = 1/60 s")

responders = (
    [("p1", phys2d.NaiveImpulse())]
    + [(f"p{n}", phys2d.IterativeImpulse(passes=n)) for n in (2, 5, 10, 20)]
    + [("pgs", phys2d.PGS())]
)


def probe(w, y0=None):
    return [w.kinetic_energy(), w.last_step.max_penetration, 0 if y0 is None else c.standing(w, y0)]


rows = []
with c.recorder(args, __file__, "lesson 2: iterative naive") as rec:
    for label, responder in responders:
        drops = c.simulate(c.dropped_boxes(responder), seconds, rec, f"drops-{label}", probe)
        w = c.zigzag_stack(responder)
        y0 = w.x[:, 1].copy()
        stack = c.simulate(w, seconds, rec, f"stack-{label}", lambda w, y0=y0: probe(w, y0))
        fell = np.flatnonzero(stack[:, 2] < len(w) - 1)
        upright = fell[0] if fell.size else len(stack)  # ticks before the first box fell
        stood = upright * c.DT
        name = repr(responder).split("(")[0] if label != "pgs" else "PGS (lesson 5)"
        passes = label[1:] if label != "pgs" else "10 sweeps"
        rows.append([f"{name} {passes}", drops[-last:, 0].mean(), stood, stack[:upright, 1].max(), c.standing(w, y0)])
c.table(
    [
        "responder, passes",
        "drops: KE last s (J)",
        "stack stood for (s)",
        "max penetration meanwhile (m)",
        "standing at the end",
    ],
    rows,
)
naive, passes, pgs = rows[0], rows[1:-1], rows[-1]
stood = [r[2] for r in passes]
pen = [r[3] for r in passes]
print(
    f"naive (lesson 1): stood {naive[2]:.2f} s, penetrating up to {naive[3]:.3g} m; 2 to 20 passes: stood "
    f"{min(stood):.2f} to {max(stood):.2f} s, penetrating up to {min(pen):.3g} to {max(pen):.3g} m"
)
ke = [r[1] for r in passes]
print(
    f"dropped boxes: kinetic energy left in the last second {naive[1]:.3g} J with 1 pass, "
    f"{min(ke):.3g} to {max(ke):.3g} J with 2 to 20: more passes jitter more, not less"
)
print(
    f"TAKEAWAY: more passes keep the stack up at best {max(stood) / naive[2]:.1f}x as long, but every naive take "
    f"lets it fall ({max(r[4] for r in rows[:-1])} of 8 standing at most after {seconds:g} s) and sinks boxes "
    f"{min(pen) / pgs[3]:.0f}x deeper than PGS, which keeps {pgs[4]} of 8 up"
)
c.done(rec)
