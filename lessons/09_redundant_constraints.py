"""Lesson 9: redundant constraints - many lambdas, one motion.

Claim (lecture, "Equations of motion"): A lambda = b "admits infinite solutions;
this is due to redundant constraints, such as a table with more than three
legs". Which solution PGS returns depends on where it starts and the order it
visits the rows; but all of them are the same motion: the impulse J^T lambda on
the bodies, and so V2, is one and the same.

The table: a 4 m top resting on four legs (fixed to the ground, so the top is
the only moving body: 3 degrees of freedom, 16 rows). The rank of A is printed,
then the lecture's PGS is run to convergence from different starts and in
different row orders, and np.linalg.lstsq's minimum-norm solution is added.
For each: the load on each leg (sum of its lambda_n), the residual, and J^T lambda.

In the viewer: the top rests still in both runs (warm and cold start) while
contacts/lambda_n shows the symmetric table carried unevenly by its legs: one
of the many solutions, chosen by the order of the rows.
"""

import _common as c
import numpy as np

import phys2d

LEGS = (-1.5, -0.5, 0.5, 1.5)  # m


def make(responder):
    w = phys2d.World(responder=responder)
    for x in LEGS:
        w.add_box(position=(x, 0.5), half_extents=(0.1, 0.5), static=True)
    w.add_box(position=(0, 1.1), half_extents=(2.0, 0.1))  # the top, body 4
    return w


def pgs(system, x, order, sweeps=3000):
    """The lecture's PGS (lesson 5) from the start x, visiting the rows in ``order``."""
    A, b, x = system.A.dense(), system.b, x.copy()
    for _ in range(sweeps):
        for k in order:
            delta = (b[k] - A[k] @ x) / A[k, k]
            lo, hi = system.lo[k], system.hi[k]
            if system.bound_row[k] >= 0:  # Coulomb: +-mu lambda_n of the same point
                lo, hi = -system.mu[k] * x[system.bound_row[k]], system.mu[k] * x[system.bound_row[k]]
            x[k] = np.clip(x[k] + delta, lo, hi)
    return x


args = c.options(__doc__)
seconds = 2.0 if args.quick else 6.0
c.claim(
    "a four-legged table has infinitely many lambda that solve A lambda = b; PGS picks one by its start "
    "and row order, and every one gives the same motion J^T lambda"
)
w = make(phys2d.PGS())
c.simulate(w, 1.0)  # let it settle, then assemble one step's system
w.responder = phys2d.PGS(form="matrix", warm_start=False, iterations=1)
w.step(c.DT)
system = w.last_step.system
d = system.dense()
R = len(system.b)
leg = np.repeat(w.contacts.body_a[w.last_step.solve_order], 2)  # the leg of each row
normal = np.arange(R) % 2 == 0
print(
    f"{R} rows on 1 moving body: rank(J) = {np.linalg.matrix_rank(d.J)}, rank(A) = {np.linalg.matrix_rank(d.A)} "
    f"- {R - np.linalg.matrix_rank(d.A)} directions of lambda that A cannot see"
)

rng = np.random.default_rng(9)
left = np.where(normal & (leg < 2), 0.1, 0.0)  # start with all the weight on the two left legs
starts = {
    "from 0, rows in order": (np.zeros(R), np.arange(R)),
    "from 0, rows reversed": (np.zeros(R), np.arange(R)[::-1]),
    "from 0, rows shuffled": (np.zeros(R), rng.permutation(R)),
    "from the left legs loaded": (left, np.arange(R)),
    "from a random start": (np.where(normal, rng.uniform(0, 0.1, R), 0.0), np.arange(R)),
}
solutions = {name: pgs(system, x0, order) for name, (x0, order) in starts.items()}
solutions["lstsq minimum norm"] = np.linalg.lstsq(d.A, d.b, rcond=None)[0]
rows, moves = [], []
for name, lam in solutions.items():
    JTlam = (d.J.T @ lam)[12:15]  # the impulse on the top: [x, y, torque]
    moves.append(JTlam)
    loads = [lam[normal & (leg == k)].sum() for k in range(4)]
    rows.append([name] + loads + [np.abs(d.A @ lam - d.b).max(), lam[normal].min()] + list(JTlam))
c.table(
    ["solution", "leg 1 (N s)", "leg 2", "leg 3", "leg 4", "|A lam - b|", "min lambda_n", "J^T lam: x", "y", "torque"],
    rows,
    "{:.4g}",
)
loads = np.array([r[1:5] for r in rows])
spread = np.abs(np.array(moves) - moves[0]).max()
print(
    f"leg loads vary by up to {np.ptp(loads, axis=0).max():.4f} N s between solutions; J^T lambda by "
    f"{spread:.2g} (the weight m g dt = {w.bodies[4].mass * 10 * c.DT:.4f} N s)"
)

with c.recorder(args, __file__, "lesson 9: redundant constraints") as rec:
    held = {}
    for warm in (True, False):
        w = make(phys2d.PGS(warm_start=warm))
        out = c.simulate(w, seconds, rec, "warm" if warm else "cold", lambda w: np.abs(w.V[4]).max())
        ct = w.contacts
        held["warm" if warm else "cold"] = (
            [ct.normal_impulse[ct.body_a == k].sum() for k in range(4)],
            out.max(),
            abs(w.x[4, 1] - 1.1),
        )
for name, (loads_run, speed, sink) in held.items():
    print(
        f"engine, {name} start, {seconds:g} s: leg loads {' '.join(f'{v:.4f}' for v in loads_run)} N s "
        f"(off 'from 0, rows in order' by {np.abs(np.array(loads_run) - loads[0]).max():.1g}); "
        f"top's largest speed {speed:.2g} m/s, sank {sink:.2g} m"
    )
print(
    f"TAKEAWAY: {len(solutions)} different lambdas (legs differ by up to {np.ptp(loads, axis=0).max():.3f} N s) "
    f"all solve A lambda = b and all push the top by the same J^T lambda (to {spread:.1g}): the motion is unique, "
    "the forces are not"
)
c.done(rec)
