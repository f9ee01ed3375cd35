"""Lesson 6: contact caching - start PGS from last tick's lambdas.

Claim (lecture, "Contact caching"): "PGS is faster the closer the initial x
vector is to the solution. If we store previous contact points and their lambda
values, PGS converges sooner" - and the lecture warns that it is hard to build.

The hard part is identity: a contact point must be recognised next tick. Here a
point is (pair of bodies, feature id), the feature id saying which edges of the
two boxes made it; the ids of a resting and of a sliding box are shown tick by
tick. Then warm start on and off: sweeps needed to reach a tolerance, the
residual left after a fixed 10 sweeps, and whether lesson 1's 8-box stack stands.

Caching has a price too (Catto, "Understanding Constraints", GDC 2014): a
stored impulse is sized for the load it carried. Take a 30 kg box off a column of
three 1 kg boxes, and last tick's impulses under it would throw the column up.
Run unload-warm-stored forces them in (a PGS whose respond sets rows.lam, as
lesson 12 writes responders): its sweeps take most of the kick back, not all.
phys2d starts cold every contact of an island that lost a pair which pushed (the
removed box's), so only the island that changed pays the cold start. The load also
pressed the boxes into each other: the lecture's Baumgarte push out of that overlap
is velocity, and a heavy column bounces on it; phys2d's PGS moves positions with
the push and keeps it out of V (split impulses, ``PGS(split=True)``).

In the viewer: world/sim/contacts are green when warm-started (found in the
cache) and red when new; on the resting box they are red for one tick only.
Compare runs stack-warm and stack-cold: the cold stack sags and falls. Plot
stats/iterations for pyramid-warm against pyramid-cold. In unload-split the column
rises by the overlap it was pressed into (its contacts red for one tick); in
unload-warm-stored it is thrown up; in unload-lecture-push it bounces before, and after.
"""

import _common as c
import numpy as np

import phys2d

args = c.options(__doc__)
seconds = 3.0 if args.quick else 10.0
c.claim(
    "with contact identities that survive from tick to tick, warm-started PGS reaches a tolerance in "
    "fewer sweeps, leaves less residual at a fixed count, and keeps stacks up; but a stored impulse outlives "
    "its load, so an island that lost a load starts cold"
)

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
            rows += [
                [
                    str(w.tick),
                    f"{ct.key[k]:#x}",
                    repr(phys2d.describe_feature(int(ct.feature[k]))),
                    str(ct.warm_started[k]),
                    ct.normal_impulse[k],
                ]
                for k in range(len(ct))
            ]
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
print(f"warm start on and off, {seconds:g} s each (after the first second for the pyramid figures):")
c.table(
    [
        "start",
        "pyramid: sweeps to 1e-3 m/s",
        "pyramid: residual after 10 sweeps (m/s)",
        "8-box stack: standing",
        "stack: max penetration (m)",
    ],
    rows,
)
warm, cold = rows


# -- the price: stored impulses outlive their load ------------------------------------------
def loaded_column(responder, heavy=True):
    """Three 1 m, 1 kg boxes on the ground and (heavy) a 30 kg box of the same size on top."""
    w = phys2d.World(responder=responder)
    phys2d.scenes.ground(w)
    column = [w.add_box(position=(0, 0.5 + k)) for k in range(3)]
    return w, column, w.add_box(position=(0, 3.5), density=30.0) if heavy else None


def pair_impulse(w, a, b):
    """lambda_n of pair (a, b), summed over its points (N s)."""
    ct = w.contacts
    return float(ct.normal_impulse[(ct.body_a == a) & (ct.body_b == b)].sum())


class WarmFromStored(phys2d.PGS):
    """PGS warm-started from given impulses (N s per pair of bodies, shared by its points), as if
    the cache had kept them: what phys2d's cold start of the island avoids."""

    def __init__(self, stored):
        super().__init__()
        self.stored = stored

    def respond(self, ctx):
        r = ctx.rows
        for q in range(ctx.n_contacts):
            a, b = ctx.body_a[q], ctx.body_b[q]
            r.lam[r.normal_row[q]] = self.stored[a] / np.sum((ctx.body_a == a) & (ctx.body_b == b))
        return super().respond(ctx)


settle, after = (1.0, 1.0) if args.quick else (2.0, 3.0)
unload = []
for label in ("split", "warm-stored", "lecture-push"):
    w, column, top = loaded_column(phys2d.PGS(split=label != "lecture-push"))
    speed = c.simulate(w, settle, rec, f"unload-{label}", lambda w: np.abs(w.V).max())
    held = [pair_impulse(w, k, k + 1) for k in range(4)]  # ground-1, 1-2, 2-3, 3-top
    if label == "split":  # phys2d's PGS: the impulses the cache holds under the load
        g_dt = float(np.hypot(*w.gravity)) * c.DT
        stored = held
        carried = [(4 - k + 29) * g_dt for k in range(4)]  # the weight above each pair, m g dt
        kick = stored[2] / column[2].mass - g_dt  # box 3 warm-started from them, nothing above it now
    y_removed = w.x[1:4, 1].copy()  # the column, before the box on top goes
    w.remove(top)
    responder = w.responder
    if label == "warm-stored":
        w.responder = WarmFromStored(held)
    w.step(c.DT)
    thrown = float(w.V[1:, 1].max())  # the column's fastest upward speed as it leaves the step
    started_cold = not w.contacts.warm_started.any() and label != "warm-stored"
    w.responder = responder
    rec.log(w, run=f"unload-{label}")
    rise = c.simulate(w, after, rec, f"unload-{label}", lambda w, y0=y_removed: (w.x[1:, 1] - y0).max())
    unload.append([label, speed[-30:].max(), thrown, 1000 * rise.max(), "cold" if started_cold else "warm"])
rec.close()
print(
    f"the price: a 30 kg box on three 1 kg boxes, PGS(), {settle:g} s; lambda_n under each pair (N s) against "
    f"the weight it carries, m g dt:"
)
c.table(
    ["pair", "stored lambda_n (N s)", "weight above, m g dt (N s)"],
    [[f"{k}-{k + 1}", stored[k], carried[k]] for k in range(4)],
)
print(
    f"take the 30 kg box (body 4) away: warm-started from its stored {stored[2]:.3g} N s, box 3 (it carries only "
    f"its own {g_dt:.3g} N s now) would start the step at {kick:.2f} m/s up"
)
print(
    f"so phys2d starts the island that lost the pair 3-4 cold; run warm-stored forces the stored impulses in. "
    f"Then {after:g} s:"
)
c.table(
    [
        "PGS push, start",
        "speed, last 0.5 s before (m/s)",
        "up after the step (m/s)",
        "rise above the removal (mm)",
        "column at removal",
    ],
    unload,
)
split, stored_run, lecture = unload
print(
    f"TAKEAWAY: warm starting needs {cold[1] / warm[1]:.0f}x fewer sweeps ({warm[1]:.1f} against {cold[1]:.1f}), "
    f"leaves {warm[2]:.2g} m/s of residual after 10 sweeps (cold: {cold[2]:.2g} m/s), "
    f"and the stack keeps {warm[3]} of 8 boxes up (cold: {cold[3]}); but the impulses under a 30 kg box would "
    f"throw box 3 up at {kick:.1f} m/s once it is gone: forced in, PGS's sweeps take most of it back and the "
    f"column still leaves at {stored_run[2]:.2f} m/s and rises {stored_run[3]:.1f} mm; started cold it leaves at "
    f"{split[2]:.2f} m/s and rises {split[3]:.1f} mm (the overlap the load pressed in, pushed out); with the "
    f"lecture's push, which stays in V, the loaded column never came to rest: it bounced at up to "
    f"{lecture[1]:.2f} m/s, and is thrown at {lecture[2]:.2f} m/s"
)
c.done(rec)
