"""Lesson 4: the equations of motion as one system A lambda = b.

Claim (lecture, "Equations of motion", with docs/formulation.md's corrected units):

    M (V2 - V1) = dt F_ext + J^T lambda,   J V2 = xi
    =>  (J M^-1 J^T) lambda = xi - J V1 - dt J M^-1 F_ext
         \\_________/          \\____________________________/
              A                              b

with lambda an impulse (N s) and every term of b a velocity (m/s). A is sparse:
rows k and l couple only through a dynamic body they share.

A small scene (two boxes stacked on the ground, each 2 cm into the one below)
takes one step with PGS(form="matrix", split=False), which assembles M^-1, F_ext,
J, A and b exactly as above and sweeps them (split=False: xi holds the Baumgarte
push, as in the lecture; by default phys2d moves positions with the push and keeps
it out of V, see lesson 6). They are printed (zeros as '.'), b is split
into its three terms, the lecture's eps/dt slip is measured, and the solution is
checked: V2 = V1 + M^-1 (dt F_ext + J^T lambda) is what the world moves with.

In the viewer: the boxes are pushed out of each other over a few ticks
(contacts/penetration falls to the slop, 5 mm); stats/iterations is the sweep
count; solver/residual falls within each tick.
"""

import _common as c
import numpy as np

import phys2d


def show(name, M, labels=None):
    print(f"{name}  ({M.shape[0]} x {M.shape[1]}, {np.count_nonzero(M)} non-zero)")
    for k, row in enumerate(M):
        cells = " ".join("      ." if v == 0 else f"{v:7.3f}" for v in row)
        print(f"  {labels[k] if labels else '':>8} {cells}")


def make(responder):
    w = phys2d.World(responder=responder)
    phys2d.scenes.ground(w)
    w.add_box(position=(0, 0.48), half_extents=(0.5, 0.5))  # 2 cm into the ground
    w.add_box(position=(0.3, 1.46), half_extents=(0.5, 0.5))  # 2 cm into the box below
    return w


args = c.options(__doc__)
c.claim(
    "M, M^-1, F_ext, J give A = J M^-1 J^T and b = xi - J V1 - dt J M^-1 F_ext, all of b in m/s; "
    "PGS solves A lambda = b and V2 follows"
)
w = make(phys2d.PGS(form="matrix", iterations=30, warm_start=False, split=False))
w.step(c.DT)
system = w.last_step.system
d = system.dense()
ct = w.contacts
labels = [f"{kind} {ct.body_a[k]}-{ct.body_b[k]}.{k}" for k in w.last_step.solve_order for kind in "nt"]  # row order
with np.errstate(divide="ignore"):
    print("M     diag:", " ".join(f"{m:.3g}" for m in 1 / system.M_inv), "  (inf: the static ground)")
print("M^-1  diag:", " ".join(f"{m:.3g}" for m in system.M_inv))
print("F_ext     :", " ".join(f"{f:.3g}" for f in system.F_ext), "  (N, N m: gravity on the two boxes)")
show("J", d.J, labels)
show("A = J M^-1 J^T", d.A, labels)
print(f"A equals J M^-1 J^T built densely here: max difference {np.abs(d.A - d.J @ d.M_inv @ d.J.T).max():.2g}")

JV1 = d.J @ system.V1
JF = c.DT * d.J @ (system.M_inv * system.F_ext)
c.table(
    ["row", "xi (m/s)", "- J V1 (m/s)", "- dt J M^-1 F_ext (m/s)", "b (m/s)"],
    [[labels[k], system.xi[k], -JV1[k], -JF[k], system.b[k]] for k in range(len(labels))],
    "{:+.4f}",
)
k = int(np.argmax(system.xi))
print(
    f"units: the lecture's b = eps/dt - J V1 - dt J M^-1 F_ext. With eps the row's target velocity, "
    f"row {labels[k]}: xi = {system.xi[k]:.4f} m/s, but eps/dt = {system.xi[k] / c.DT:.3f} m/s^2 - "
    f"{1 / c.DT:.0f} times larger and not a velocity, while dt J M^-1 F_ext = {JF[k]:+.4f} m/s is one"
)
print(
    f"units: the lecture's V2 = J^T eps has {d.J.shape[1]} entries (a force direction per body), "
    f"eps has {d.J.shape[0]}: V2 comes from M (V2 - V1) = dt F_ext + J^T lambda instead"
)

res = w.last_step.residuals
print(
    "PGS residual by sweep (m/s):",
    " ".join(f"{r:.2g}" for r in res[[0, 1, 2, 4, 9, 19, 29]]),
    "(sweeps 1, 2, 3, 5, 10, 20, 30)",
)
lam = system.lam
r = d.A @ lam - d.b  # J V2 - xi for each row
at_lo, at_hi = lam <= d.lo + 1e-12, lam >= d.hi - 1e-12
inside = ~at_lo & ~at_hi
print(f"lambda (N s): {' '.join(f'{v:.4f}' for v in lam)}")
print(
    f"complementarity: {inside.sum()} rows inside their bounds, |A lambda - b| <= "
    f"{np.abs(r[inside]).max():.2g} m/s there (J V2 = xi up to the residual); {at_lo.sum()} at their "
    f"lower bound (A lambda - b >= 0: they separate), {at_hi.sum()} at their upper bound (friction slides)"
)
V2 = system.velocities()
print(
    f"V2 = V1 + M^-1 (dt F_ext + J^T lambda) against the world's V after the step: "
    f"max difference {np.abs(V2 - w.V.ravel()).max():.2g}"
)

big = phys2d.scenes.pyramid(10, responder=phys2d.PGS(form="matrix"))
big.step(c.DT)
A = big.last_step.system.A
print(
    f"sparsity: a 10-row pyramid has R = {A.shape[0]} rows; A stores {A.nnz} entries of "
    f"{A.shape[0] ** 2} ({100 * A.nnz / A.shape[0] ** 2:.1f}%)"
)

seconds = 1.0 if args.quick else 3.0
with c.recorder(args, __file__, "lesson 4: equations of motion") as rec:
    w = make(phys2d.PGS(form="matrix", iterations=30, split=False))
    pen = c.simulate(w, seconds, rec, probe=lambda w: w.last_step.max_penetration)
print(
    f"TAKEAWAY: one system, one solve: the 2 cm overlaps shrink to {pen[-1] * 1000:.1f} mm "
    f"in {seconds:g} s (slop 5 mm), pushed out at the Baumgarte rate beta/dt"
)
c.done(rec)
