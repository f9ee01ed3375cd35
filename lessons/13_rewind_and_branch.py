"""Lesson 13: rewind and branch - a pyramid PGS holds, taken again from tick 120 by the naive take.

Claim: a world's state between two ticks is complete, so any tick can be taken again: a
snapshot restored gives the same future bit for bit, and the future from tick 120 can be
run under another responder beside the first. Under the lecture's naive take (one impulse
per touching pair, then push apart) the pyramid that PGS holds starts to fall at once, and
the constraint rows of the tick it starts to fall say why: PGS's normal impulses under the
pyramid add up to its whole weight m g dt, the naive take's to a small part of it, since one
impulse per pair only stops that pair closing and passes no load down; the box that moves
first, the top one, gets almost nothing from the box under it.

The lab (``phys2d.Lab``) does the work: it steps the world, keeps keyframes, branches from the
tick it shows, and reads the rows of any step (``lab.rows_at``). Opened as a notebook, the lab
shows the Rerun viewer with its controls: scrub to a tick, pick a box, press "branch here".

In the viewer: runs pgs and naive side by side from tick 120; the naive pyramid sinks from
the top while the PGS one stands. Scrub to the tick the account names and pick the top box.
"""

import _common as c
import numpy as np

import phys2d

args = c.options(__doc__)
rows_of_pyramid = 10
at = 120  # the tick to branch from
after = 120 if args.quick else 240  # ticks to run the two futures
c.claim(
    "a snapshot restores a world bit for bit, so the future from tick 120 can be taken again under "
    "another responder; under the naive take a pyramid PGS holds falls, and the rows of the tick it starts "
    "to fall show its normal impulses carry a small part of the pyramid's weight, PGS's all of it"
)

# 1. the original: PGS, every tick recorded (run pgs), in a lab that keeps keyframes
rec = c.recorder(args, __file__, "lesson 13: rewind and branch", keyframe_every=30)
lab = phys2d.Lab(phys2d.scenes.pyramid(rows_of_pyramid), viewer=c.in_notebook())
rec.log(lab.world, run="pgs")
for _ in range(at):
    lab.step()
    rec.log(lab.world, run="pgs")

# 2. a snapshot at tick 120, a minute of steps, the snapshot back, the same steps: the same bits
w = lab.world_at(at)
data = w.snapshot()
first = []
for _ in range(60):
    w.step(c.DT)
    first.append(w.state_hash())
w.restore(data)
again = []
for _ in range(60):
    w.step(c.DT)
    again.append(w.state_hash())
print(
    f"snapshot at tick {at}: {len(data) / 1e3:.0f} kB; 60 steps, restore, 60 steps: "
    f"{sum(a == b for a, b in zip(first, again, strict=True))}/60 state hashes the same"
)

# 3. the branch: from tick 120 the original (PGS, its run goes on) and the naive take beside it
lab.seek(at)


def log(original: phys2d.World, branch: phys2d.World) -> None:
    if original.tick > at:  # (tick 120 of run pgs is logged already)
        rec.log(original, run="pgs")
    rec.log(branch, run="naive")


part = lab.branch_here("naive", steps=after, on_tick=log)
rec.close()
for line in part.lines():
    print(line)
tick, uid = part.first_tick, part.first_uid
assert tick is not None and uid is not None

# 4. what the rows of the step into that tick show
rows = {run: lab.rows_at(tick, run=run) for run in ("original", "naive")}
w = lab.world_at(tick, "original")
weight = float(np.sum(w.body_masses[1:])) * float(np.hypot(*w.gravity)) * c.DT  # m g dt of the pyramid, N s
box = float(w.body_masses[list(w.body_uids).index(uid)]) * float(np.hypot(*w.gravity)) * c.DT
table = []
for run, label in (("original", "PGS"), ("naive", "naive")):
    r = rows[run]
    normal = r.kind == "normal"
    ground = normal & ((r.body_a == 0) | (r.body_b == 0))
    friction = r.kind == "friction"
    sliding = friction & (r.hi > 0) & np.isclose(np.abs(r.lam), r.hi, rtol=1e-9)
    mine = r.of_body(uid)
    under = mine.kind == "normal"
    table.append(
        [label, len(r), r.lam[ground].sum() / weight, float(mine.lam[under].sum()) / box, int(sliding.sum()),
         float(r.residuals[-1])]
    )  # fmt: skip
print(f"the rows of the step into tick {tick} (the pyramid weighs m g dt = {weight:.4g} N s a tick; box b{uid}, "
      f"{box:.4g} N s):")  # fmt: skip
header = ["responder", "rows", "ground lambda_n / (m g dt)", f"b{uid}'s lambda_n / its m g dt"]
c.table([*header, "friction rows at mu lambda_n", "last residual (m/s)"], table)
print(f"the rows on box b{uid} under the naive take:")
print(str(rows["naive"].of_body(uid)))
end = part.start + part.ticks
standing = {
    run: int(np.sum(np.abs(lab.world_at(end, run).x[1:, 1] - lab.world_at(at, run).x[1:, 1]) < 0.25))
    for run in ("original", "naive")
}
n = len(w) - 1
print(
    f"by tick {end}: PGS keeps {standing['original']}/{n} boxes within 0.25 m of their height at "
    f"tick {at}, the naive take {standing['naive']}/{n}"
)
pgs, naive = table
print(
    f"TAKEAWAY: restored from its snapshot the world steps to the same bits; branched at tick {at}, the naive "
    f"take parts from PGS at tick {tick} (box b{uid}, the first more than 1 mm away) and leaves "
    f"{standing['naive']}/{n} boxes standing where PGS keeps {standing['original']}/{n}: at that tick its normal "
    f"impulses under the pyramid carry {100 * naive[2]:.0f} % of its weight (PGS: {100 * pgs[2]:.0f} %), and box "
    f"b{uid} gets {100 * naive[3]:.1f} % of its own (PGS: {100 * pgs[3]:.0f} %): one impulse per pair passes no "
    "load down"
)
c.done(rec)
if c.in_notebook():
    lab.seek(tick)
    lab.display()
