"""Responders written outside the engine for tests/test_check.py: the lesson's plain PGS with one
thing broken each (among them the mistakes a student makes reading docs/your-responder.md:
``Planted``), and responders that break the protocol."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

import phys2d
from phys2d.checks import load

TEMPLATE = str(Path(__file__).resolve().parents[1] / "lessons" / "your_responder.py")
LecturePGS = load(TEMPLATE + ":LecturePGS")
apply, velocity = sys.modules[LecturePGS.__module__].apply, sys.modules[LecturePGS.__module__].velocity  # its helpers


class NoFrictionBound(LecturePGS):  # type: ignore[misc, valid-type]
    """Friction rows clamped to (-inf, inf): the cone is ignored."""

    name = "no-friction-bound"

    def respond(self, ctx: phys2d.StepContext) -> phys2d.SolveResult:
        r = ctx.rows
        friction = r.bound_row >= 0
        r.bound_row[friction] = -1
        r.lo[friction], r.hi[friction] = -math.inf, math.inf
        return super().respond(ctx)


class AddsEnergy(LecturePGS):  # type: ignore[misc, valid-type]
    """Every contact pushes its bodies apart at 0.2 m/s more than asked: equal and opposite
    impulses (momentum kept) that add energy."""

    name = "adds-energy"

    def respond(self, ctx: phys2d.StepContext) -> phys2d.SolveResult:
        r = ctx.rows
        r.xi[r.normal_row] += 0.2
        return super().respond(ctx)


class WritesNaN(phys2d.Responder):
    name = "writes-nan"

    def respond(self, ctx: phys2d.StepContext) -> phys2d.SolveResult:
        ctx.V[:] = np.nan
        return phys2d.SolveResult(1, np.zeros(1))


class Raises(phys2d.Responder):
    name = "raises"

    def respond(self, ctx: phys2d.StepContext) -> phys2d.SolveResult:
        ctx.V[:] += 1.0  # half a step's work, then a bug
        ctx.x[:] += 1.0
        raise ZeroDivisionError("a bug in the student's sweep")


class ReturnsNothing(phys2d.Responder):
    name = "returns-nothing"

    def respond(self, ctx: phys2d.StepContext) -> phys2d.SolveResult:
        return None  # type: ignore[return-value]


class NeedsArguments(phys2d.Responder):
    def __init__(self, sweeps: int) -> None:
        self.sweeps = sweeps


class NotAResponder:
    def respond(self, ctx: object) -> None:
        return None


class NaNImpulses(LecturePGS):  # type: ignore[misc, valid-type]
    """The lesson's PGS, cold, then every impulse reported NaN: its velocities stay right."""

    name = "nan-impulses"
    warm_start = False

    def respond(self, ctx: phys2d.StepContext) -> phys2d.SolveResult:
        result = super().respond(ctx)
        ctx.rows.lam[:] = np.nan
        return result


class OneSided(LecturePGS):  # type: ignore[misc, valid-type]
    """Impulses act on body a only (M^-1 J^T of body b zeroed): momentum is not kept."""

    name = "one-sided"

    def respond(self, ctx: phys2d.StepContext) -> phys2d.SolveResult:
        ctx.rows.JM[:, 3:] = 0.0
        return super().respond(ctx)


# -- the lesson's PGS with one mistake planted each (docs/your-responder.md's steps, misread) ----
class Planted(phys2d.Responder):
    """The lesson's plain PGS (lessons/your_responder.py) with the mistake ``mistake`` planted:

    clamp-delta      clamps each sweep's delta into the bounds, not the accumulated lambda_k
    cold-warm-start  says ``warm_start = True`` but never applies the cached lambda to V
    fixed-cone       bounds friction by mu m g dt (m the dynamic body's mass), not mu lambda_n
    no-push          targets xi, not xi + push
    flipped-sign     delta = (target + J V) / A_kk: the sign of J V flipped
    residual-early   reports |delta| A_kk before the clamp (its impulses are right)
    jacobi           projected Jacobi, every row's delta from the sweep's starting V, relaxed by
                     0.5 (its impulses converge, more slowly)
    """

    name = "planted"
    counts = "sweeps"
    warm_start = True
    mistake = ""

    def __init__(self, iterations: int = 10) -> None:
        self.iterations = iterations

    def respond(self, ctx: phys2d.StepContext) -> phys2d.SolveResult:
        r, mistake = ctx.rows, self.mistake
        V, lam = ctx.V.tolist(), r.lam.tolist()
        A, J, JM, a, b = r.A_kk.tolist(), r.J.tolist(), r.JM.tolist(), r.body_a.tolist(), r.body_b.tolist()
        target = (r.xi if mistake == "no-push" else r.xi + r.push).tolist()
        lo, hi, bound, mu = r.lo.tolist(), r.hi.tolist(), r.bound_row.tolist(), r.mu.tolist()
        g = float(np.hypot(*ctx.gravity)) if ctx.gravity is not None else 0.0
        m = [1.0 / w if w > 0.0 else 0.0 for w in ctx.M_inv[:, 0].tolist()]
        rows = [k for k in range(len(lam)) if A[k] > 0.0]
        if mistake != "cold-warm-start":
            for k in rows:
                apply(V, a[k], b[k], JM[k], lam[k])
        sign = -1.0 if mistake == "flipped-sign" else 1.0
        residuals = []
        for _ in range(self.iterations):
            worst = 0.0
            start = [list(v) for v in V] if mistake == "jacobi" else V
            changes = []
            for k in rows:
                if bound[k] >= 0:
                    high = mu[k] * (max(m[a[k]], m[b[k]]) * g * ctx.dt if mistake == "fixed-cone" else lam[bound[k]])
                    low = -high
                else:
                    low, high = lo[k], hi[k]
                delta = (target[k] - sign * velocity(start, a[k], b[k], J[k])) / A[k]
                if mistake == "residual-early":
                    worst = max(worst, abs(delta) * A[k])
                if mistake == "jacobi":
                    delta *= 0.5
                if mistake == "clamp-delta":
                    delta = min(max(delta, low), high)
                else:
                    delta = min(max(lam[k] + delta, low), high) - lam[k]
                lam[k] += delta
                if mistake == "jacobi":
                    changes.append((k, delta))
                else:
                    apply(V, a[k], b[k], JM[k], delta)
                if mistake != "residual-early":
                    worst = max(worst, abs(delta) * A[k])
            for k, delta in changes:
                apply(V, a[k], b[k], JM[k], delta)
            residuals.append(worst)
        ctx.V[:] = V
        r.lam[:] = lam
        return phys2d.SolveResult(self.iterations, np.array(residuals))


class ClampsDelta(Planted):
    name, mistake = "clamps-delta", "clamp-delta"


class WarmStartNotApplied(Planted):
    name, mistake = "warm-start-not-applied", "cold-warm-start"


class FixedFrictionBound(Planted):
    name, mistake = "fixed-friction-bound", "fixed-cone"


class NoPush(Planted):
    name, mistake = "no-push", "no-push"


class FlippedSign(Planted):
    name, mistake = "flipped-sign", "flipped-sign"


class ResidualBeforeClamp(Planted):
    name, mistake = "residual-before-clamp", "residual-early"


class ProjectedJacobi(Planted):
    name, mistake = "projected-jacobi", "jacobi"
