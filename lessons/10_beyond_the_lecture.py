"""Lesson 10: beyond the lecture - the block solver and the soft step.

Claim: the lecture's PGS solves one row at a time, and two scenes show the cost.
(a) A resting box has two contact points; the row visited first takes more of
the load, the box rocks from corner to corner, and a 20-box stack sways and
falls. (b) A 100 kg box on a 1 kg box: Gauss-Seidel converges slowly when masses
differ by 100x, so 10 sweeps leave the pair sinking and the heavy box topples.

What the field learned after the lecture:
- Box2D 2.x's block solver, phys2d.PGS(block=True), solves a manifold's two
  normal rows together (an exact 2x2 LCP). The corners share the load: it fixes
  (a). In (b) its 10 sweeps still lag, and the heavy box sinks a few centimetres
  before they catch up; it holds because phys2d's PGS pushes overlap out without
  making the push velocity (split impulses, lesson 6). With the lecture's push
  (PGS(block=True, split=False)) the push out of that overlap throws the pair up.
- Box2D v3's soft step, phys2d.SoftStep(substeps=4) (phys2d/responders/soft_step.py),
  splits the tick into sub-steps and pushes overlapping points apart with a damped
  spring, then relaxes. It fixes both, at a price: the spring of a row has
  stiffness m_eff omega^2 (m_eff = 1/A_kk, omega = 2 pi hertz), so a load F on a
  point needs an overlap F / (m_eff omega^2): millimetres to centimetres under
  heavy loads. A box on two points puts F = m g / 2 on each, so the estimate
  printed beside the overlap measured is m g / (2 m_eff omega^2).

For each responder and scene: the largest sideways (x) move of any box, the
highest any box rose, the largest turn, how long it stood (until a box moved
> 0.5 m or turned > 30 deg), the worst load imbalance between the two corners of a
manifold in the first second (|lambda_1 - lambda_2| / (lambda_1 + lambda_2):
0 shared evenly, 1 all on one corner), the deepest overlap in the last second,
and ms per step (wall clock, informative only).

(c) The same stack with box k shifted sideways by 1 mm * k: no longer symmetric.
This part needs the full 30 s run: --quick stops at 3 s, before the block solver
falls.
Row-by-row PGS falls within seconds, the block solver at about 6 s. The soft step
sways (by about 9 cm in the full 30 s run) and comes back. It stands because a pair
that barely moves keeps its contact points from tick to tick
(World.contact_recycle_distance), and the soft step builds its rows with the lever
arms a kept point was found with (Contacts.anchor), as Box2D v3 does. Its springs
(30 Hz) let each box tilt on the one below; lever arms turned with that tilt add the
torque of the load above through them, which tilts the box further, and a 20-box
column on such springs buckles: with recycling off (contact_recycle_distance = 0) the
points are found anew every tick, their arms follow the tilt, and the soft step's
stack falls at about 5 s, as Box2D v3's does without its recycling. PGS keeps arms
taken at each tick's positions, so its impulses act at one point of both bodies and
keep angular momentum exactly; the soft step's found arms part as the boxes shift,
by millimetres here.

In the viewer: nine worlds side by side. stack-pgs sways and falls while
stack-pgs-block and stack-soft-step stand still; ratio-pgs topples, ratio-pgs-block
stays level, sinks and comes back up, ratio-soft-step sits still with the heavy box
sunk into the light one. Plot "max penetration (m)": the soft step's
lines are flat at its spring's overlap.
"""

import time

import _common as c
import numpy as np

import phys2d

RESPONDERS = (
    ("PGS(10)", lambda: phys2d.PGS(iterations=10)),
    ("PGS(10) block", lambda: phys2d.PGS(iterations=10, block=True)),
    ("SoftStep(4)", lambda: phys2d.SoftStep(substeps=4)),
)
SCENES = (
    ("stack", "20-box stack", lambda r: phys2d.scenes.vertical_stack(20, r)),
    ("lean", "20-box stack, 1 mm lean", lambda r: phys2d.scenes.vertical_stack(20, r, lean=0.001)),
    ("ratio", "100 kg on 1 kg", lambda r: phys2d.scenes.mass_ratio(100.0, r)),
)


def manifolds(w):
    """Each touching pair (a, b) with the indices of its contact points."""
    ct = w.contacts
    pairs = sorted(set(zip(ct.body_a.tolist(), ct.body_b.tolist())))
    return [(a, b, np.flatnonzero((ct.body_a == a) & (ct.body_b == b))) for a, b in pairs]


def imbalance(w):
    """The largest |lambda_1 - lambda_2| / (lambda_1 + lambda_2) over two-point manifolds."""
    lam = w.contacts.normal_impulse
    shares = [abs(lam[p[0]] - lam[p[1]]) / lam[p].sum() for _, _, p in manifolds(w) if len(p) == 2 and lam[p].sum() > 0]
    return max(shares, default=0.0)


def soft_overlap(w, soft):
    """Estimated and measured deepest overlap (m) of a standing pile under SoftStep, hertz, m_eff by pair.

    Bodies were added bottom up, so the point of pair (a, b) carries the weight of
    bodies b, b+1, ... shared by the manifold's points; each row is a spring of
    stiffness m_eff omega^2, omega = 2 pi hertz (twice the hertz against a static body).
    """
    hertz = min(soft.contact_hertz, 0.25 / (c.DT / soft.substeps))
    mass, ct, g = np.array([b.mass for b in w.bodies]), w.contacts, np.hypot(*w.gravity)
    estimate, measured, m_eff = 0.0, 0.0, {}
    for a, b, p in manifolds(w):
        r = [ct.point[p] - w.x[k] for k in (a, b)]  # lever arms; A_kk = sum 1/m + (r x n)^2 / I
        A = sum(
            w.M_inv[k, 0] + w.M_inv[k, 2] * (rk[:, 0] * ct.normal[p, 1] - rk[:, 1] * ct.normal[p, 0]) ** 2
            for k, rk in zip((a, b), r)
        )
        omega = 2 * np.pi * hertz * (2 if w.M_inv[a, 0] == 0 else 1)
        estimate = max(estimate, (g * mass[b:].sum() / len(p) / (omega**2 / A)).max())
        measured = max(measured, -ct.separation[p].min())
        m_eff[a, b] = 1 / A.mean()
    return estimate, measured, hertz, m_eff


args = c.options(__doc__)
seconds = 3.0 if args.quick else 30.0
c.claim(
    "row-by-row PGS rocks a resting box between its corners, so a 20-box stack falls, and converges too "
    "slowly for a 100 kg box on a 1 kg one; the block solver fixes the stack and, its push kept out of the "
    "velocities, holds the mass ratio after sinking; the soft step fixes both, with contacts that sink by "
    "F / (m_eff (2 pi hertz)^2), F the load on a point: m g / (2 m_eff (2 pi hertz)^2) on two points"
)

rows, soft = [], {}
with c.recorder(args, __file__, "lesson 10: beyond the lecture") as rec:
    for key, scene, build in SCENES:
        for label, make in RESPONDERS:
            responder = make()
            w = build(responder)
            x0, theta0 = w.x[1:].copy(), w.theta[1:].copy()
            stood, wall, probe = seconds, 0.0, []
            for tick in range(round(seconds / c.DT)):
                t0 = time.perf_counter()
                w.step(c.DT)
                wall += (time.perf_counter() - t0) if tick else 0.0  # the first tick compiles
                rec.log(w, run=f"{key}-{responder.name}")
                d = w.x[1:] - x0
                turned = np.degrees(np.abs(w.theta[1:] - theta0)).max()
                if stood == seconds and (np.hypot(d[:, 0], d[:, 1]).max() > 0.5 or turned > 30):
                    stood = w.time
                probe.append([np.abs(d[:, 0]).max(), d[:, 1].max(), turned, imbalance(w), w.last_step.max_penetration])
            p = np.array(probe)
            rows.append(
                [
                    f"{scene}, {label}",
                    p[:, 0].max(),
                    p[:, 1].max(),
                    p[:, 2].max(),
                    stood,
                    p[:60, 3].max(),
                    p[:, 4].max(),
                    p[-60:, 4].max(),
                    1e3 * wall / (len(p) - 1),
                ]
            )
            if isinstance(responder, phys2d.SoftStep):
                soft[key] = soft_overlap(w, responder)
print(f"{seconds:g} s at dt = 1/{1 / c.DT:.0f} s; stood = until a box moved > 0.5 m or turned > 30 deg")
c.table(
    [
        "scene, responder",
        "x move (m)",
        "rise (m)",
        "turn (deg)",
        "stood (s)",
        "imbalance, 1st s",
        "overlap, max (m)",
        "overlap, last s (m)",
        "ms/step",
    ],
    rows,
)

est, meas, hertz, m_eff = soft["ratio"]
print(
    f"SoftStep springs: hertz = min({phys2d.SoftStep().contact_hertz:g}, 0.25/h) = {hertz:g} Hz with "
    f"h = dt/4 (twice that against the ground); 100 kg on 1 kg: m_eff = 1/A_kk = {m_eff[1, 2]:.3g} kg a point, "
    f"2 points"
)
print(f"SoftStep overlap, 100 kg on 1 kg: estimate m g / (2 m_eff (2 pi hertz)^2) = {est:.4g} m, measured {meas:.4g} m")
est_s, meas_s = soft["stack"][:2]
print(
    f"SoftStep overlap, 20-box stack: estimate (load above) / (2 m_eff (2 pi hertz)^2) = {est_s:.4g} m, "
    f"measured {meas_s:.4g} m"
)

by = {r[0]: r for r in rows}
pgs_s, blk_s, soft_s = (by[f"20-box stack, {n}"] for n, _ in RESPONDERS)
pgs_r, blk_r, soft_r = (by[f"100 kg on 1 kg, {n}"] for n, _ in RESPONDERS)


def fate(row):
    return f"fell at {row[4]:.2f} s" if row[4] < seconds else f"stood {seconds:g} s"


lean_pgs, lean_blk, lean_soft = (by[f"20-box stack, 1 mm lean, {n}"] for n, _ in RESPONDERS)
if args.quick:
    print(f"(c) needs the full run: --quick stops at {seconds:g} s, before the block solver's lean stack falls")
print(
    f"LEAN: with box k shifted by 1 mm * k, row-by-row PGS {fate(lean_pgs)}; the block solver moved "
    f"{lean_blk[1]:.3f} m and {fate(lean_blk)}; the soft step moved {lean_soft[1]:.3f} m and {fate(lean_soft)} "
    f"(the straight stack: {soft_s[1]:.2g} m)"
)
print(
    f"TAKEAWAY: one row at a time, PGS loads one corner more (imbalance {pgs_s[5]:.2f}): the 20-box stack "
    f"{fate(pgs_s)}, the 100 kg box sank {pgs_r[6]:.3f} m and {fate(pgs_r)}; the block solver shares the corners "
    f"(imbalance {blk_s[5]:.2f}, the stack {fate(blk_s)}, x move {blk_s[1]:.2g} m) and, its push moving positions "
    f"only, holds the 100 kg box ({fate(blk_r)}) after it sank {blk_r[6]:.3f} m; the soft step keeps both up "
    f"({fate(soft_s)}, {fate(soft_r)}) at the price of {meas:.3f} m of overlap under 100 kg "
    f"(m g / (2 m_eff (2 pi hertz)^2) = {est:.3f} m)"
)
c.done(rec)
