"""Your own responder: the lecture's two takes written from scratch in plain Python.

Lesson 12 runs these; copy this file, change a take, and grade it with the report card:

    phys2d check lessons/your_responder.py:LecturePGS

The protocol (docs/your-responder.md): ``respond(ctx)`` gets the step's rows in
``ctx.rows`` (J, JM = M^-1 J^T, A_kk, xi, push, lo, hi, bound_row, mu, lam, body_a,
body_b) and the velocities ``ctx.V`` after external forces; it changes ``ctx.V`` in
place, leaves each row's impulse in ``rows.lam`` (N s) and returns a ``SolveResult``.
The world then moves the positions with ``ctx.V``.

Lists, not numpy arrays, in the loops: ``.tolist()`` each array once per step, loop over
the lists, write ``ctx.V`` and ``rows.lam`` back at the end. A Python loop reads a list's
floats about five times faster than it indexes an array's (a 10-box stack: about 700
steps/s here, 120 with ``V[a] += JM[k, :3] * delta`` on the arrays).
"""

from __future__ import annotations

import numpy as np

import phys2d


def apply(V: list, a: int, b: int, jm: list, impulse: float) -> None:
    """V += M^-1 J_k^T impulse, for row k's bodies a, b and its M^-1 J_k^T = jm."""
    va, vb = V[a], V[b]
    va[0] += jm[0] * impulse
    va[1] += jm[1] * impulse
    va[2] += jm[2] * impulse
    vb[0] += jm[3] * impulse
    vb[1] += jm[4] * impulse
    vb[2] += jm[5] * impulse


def velocity(V: list, a: int, b: int, j: list) -> float:
    """J_k V: the row's relative velocity, m/s."""
    va, vb = V[a], V[b]
    return j[0] * va[0] + j[1] * va[1] + j[2] * va[2] + j[3] * vb[0] + j[4] * vb[1] + j[5] * vb[2]


class LecturePGS(phys2d.Responder):
    """The lecture's projected Gauss-Seidel, sequential impulses, warm started (contact caching).

    iterations  sweeps over the rows per step, as ``phys2d.PGS(iterations=)`` names them (the
                card builds LecturePGS() with the default)
    """

    name = "lecture-pgs"
    counts = "sweeps"  # the unit of SolveResult's count: the reports say "10 sweeps"
    warm_start = True  # rows.lam holds last step's impulses: apply them first

    def __init__(self, iterations: int = 10) -> None:
        self.iterations = iterations

    def respond(self, ctx: phys2d.StepContext) -> phys2d.SolveResult:
        r = ctx.rows
        V, lam = ctx.V.tolist(), r.lam.tolist()
        A, J, JM, a, b = r.A_kk.tolist(), r.J.tolist(), r.JM.tolist(), r.body_a.tolist(), r.body_b.tolist()
        target = (r.xi + r.push).tolist()  # the lecture's b_k + J_k V: xi with the push in it
        lo, hi, bound, mu = r.lo.tolist(), r.hi.tolist(), r.bound_row.tolist(), r.mu.tolist()
        rows = [k for k in range(len(lam)) if A[k] > 0.0]  # a row between two static bodies moves nothing
        for k in rows:  # warm start: V += M^-1 J^T lambda
            apply(V, a[k], b[k], JM[k], lam[k])
        residuals = []
        for _ in range(self.iterations):
            worst = 0.0  # the largest change of the sweep, |new - lam[k]| A_kk (m/s): after the clamp
            for k in rows:
                if bound[k] >= 0:  # friction: inside +-mu lambda_n of its normal row
                    high = mu[k] * lam[bound[k]]
                    low = -high
                else:
                    low, high = lo[k], hi[k]
                new = min(max(lam[k] + (target[k] - velocity(V, a[k], b[k], J[k])) / A[k], low), high)
                delta = new - lam[k]  # clamp the accumulated impulse, apply the change
                lam[k] = new
                apply(V, a[k], b[k], JM[k], delta)
                worst = max(worst, abs(delta) * A[k])
            residuals.append(worst)
        ctx.V[:] = V
        r.lam[:] = lam
        return phys2d.SolveResult(self.iterations, np.array(residuals))

    def __repr__(self) -> str:
        return f"LecturePGS(iterations={self.iterations})"


class LectureNaive(phys2d.Responder):
    """The lecture's naive take: one impulse per colliding contact point, once per step.

    f = -(1 + e) J_n V / A_nn where the point touches and approaches (the lecture's impulse;
    a point still apart only closes its gap, f = (xi - J_n V) / A_nn), then friction
    f_t = clamp(-J_t V / A_tt, -mu f, mu f). Nothing is remembered or accumulated.
    """

    name = "lecture-naive"
    counts = "passes"
    lecture_take = "naive"  # the card notes the failures the lecture predicts for this take

    def respond(self, ctx: phys2d.StepContext) -> phys2d.SolveResult:
        r = ctx.rows
        V, lam = ctx.V.tolist(), [0.0] * len(r.lam)
        A, J, JM, a, b = r.A_kk.tolist(), r.J.tolist(), r.JM.tolist(), r.body_a.tolist(), r.body_b.tolist()
        target = (r.xi + r.push).tolist()  # close a gap, push out an overlap
        worst = 0.0
        for q in range(ctx.n_contacts):
            n, t = int(r.normal_row[q]), int(r.friction_row[q])
            if A[n] <= 0.0:
                continue
            vn = velocity(V, a[n], b[n], J[n])
            if ctx.separation[q] <= 0.0 and vn < 0.0:
                target[n] = max(target[n], -float(ctx.restitution[q]) * vn)  # the lecture's bounce
            f = (target[n] - vn) / A[n]
            if f <= 0.0:
                continue  # no collision response: never pull
            apply(V, a[n], b[n], JM[n], f)
            top = r.mu[t] * f
            f_t = min(max(-velocity(V, a[t], b[t], J[t]) / A[t], -top), top)
            apply(V, a[t], b[t], JM[t], f_t)
            lam[n], lam[t] = f, f_t
            worst = max(worst, f * A[n])
        ctx.V[:] = V
        r.lam[:] = lam
        return phys2d.SolveResult(1, np.array([worst]))

    def __repr__(self) -> str:
        return "LectureNaive()"
