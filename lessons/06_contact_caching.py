"""Lesson 6: contact caching - start PGS from last tick's lambdas.

Claim (lecture, "Contact caching"): "PGS is faster the closer the initial x
vector is to the solution. If we store previous contact points and their lambda
values, PGS converges sooner" - and the lecture warns that it is hard to build.

The hard part is identity: a contact point must be recognised next tick. Here a
point is (pair of bodies, feature id), the feature id saying which edges of the
two boxes made it; the ids of a resting and of a sliding box are shown tick by
tick. Then warm start on and off: sweeps needed to reach a tolerance, the
residual left after a fixed 10 sweeps, and whether lesson 1's 8-box stack stands.

In the viewer: world/sim/contacts are green when warm-started (found in the
cache) and red when new; on the resting box they are red for one tick only.
Compare runs stack-warm and stack-cold: the cold stack sags and falls. Plot
stats/iterations for pyramid-warm against pyramid-cold.
"""

import _common as c
import numpy as np

import phys2d


def feature(f):
    """A polygon-polygon feature id in words (phys2d.collision.narrowphase)."""
    owner = "b" if f >> 15 & 1 else "a"
    return f"ref edge {f >> 8 & 63} of {owner}, incident edge {f >> 1 & 63}, end {f & 1}"


args = c.options(__doc__)
seconds = 3.0 if args.quick else 10.0
c.claim("with contact identities that survive from tick to tick, warm-started PGS reaches a tolerance in "
        "fewer sweeps, leaves less residual at a fixed count, and keeps stacks up")

rec = c.recorder(args, __file__, "lesson 6: contact caching")
for name, v in (("resting box", 0.0), ("sliding box (3 m/s)", 3.0)):
    w = phys2d.World(responder=phys2d.PGS())
    phys2d.scenes.ground(w)
    w.add_box(position=(0, 0.5), velocity=(v, 0))
    rows, hits = [], []
    for tick in range(60):
        w.step(c.DT)
        rec.log(w, run=name.split()[0])
        ct = w.contacts
        hits.append(w.last_step.cache_hit_rate)
        if tick in (0, 1, 59):
            rows += [[str(w.tick), f"{ct.key[k]:#x}", feature(int(ct.feature[k])), str(ct.warm_started[k]),
                      ct.normal_impulse[k]] for k in range(len(ct))]
    print(f"{name}: contacts on ticks 1, 2 and 60")
    c.table(["tick", "key", "feature id", "warm started", "lambda_n (N s)"], rows)
    print(f"{name}: cache hit rate over ticks 2..60: {100 * np.mean(hits[1:]):.1f}%  (tick 1: {100 * hits[0]:.0f}%)")

rows = []
for warm in (True, False):
    label = "warm" if warm else "cold"
    w = phys2d.scenes.pyramid(10, responder=phys2d.PGS(iterations=500, tolerance=1e-3, warm_start=warm))
    sweeps = c.simulate(w, seconds, rec, f"pyramid-{label}", lambda w: w.last_step.iterations)
    w = phys2d.scenes.pyramid(10, responder=phys2d.PGS(iterations=10, warm_start=warm))
    res = c.simulate(w, seconds, probe=lambda w: w.last_step.residuals[-1])
    w = c.zigzag_stack(phys2d.PGS(iterations=10, warm_start=warm))
    y0 = w.x[:, 1].copy()
    pen = c.simulate(w, seconds, rec, f"stack-{label}", lambda w: w.last_step.max_penetration)
    rows.append([label, sweeps[60:].mean(), res[60:].mean(), c.standing(w, y0), pen.max()])
rec.close()
print(f"warm start on and off, {seconds:g} s each (after the first second for the pyramid figures):")
c.table(["start", "pyramid: sweeps to 1e-3 m/s", "pyramid: residual after 10 sweeps (m/s)",
         "8-box stack: standing", "stack: max penetration (m)"], rows)
warm, cold = rows
print(f"TAKEAWAY: warm starting needs {cold[1] / warm[1]:.0f}x fewer sweeps ({warm[1]:.1f} against {cold[1]:.1f}), "
      f"leaves {warm[2]:.2g} m/s of residual after 10 sweeps (cold: {cold[2]:.2g} m/s), "
      f"and the stack keeps {warm[3]} of 8 boxes up (cold: {cold[3]})")
c.done(rec)
