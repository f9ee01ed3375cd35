"""The lecture's second take: the pairwise impulses again and again within a tick.

    repeat ``passes`` times:
        for each colliding pair (as in NaiveImpulse):
            f   = -(1 + e) (J_n V) / A_n     if the pair approaches, else nothing
            f_t = clamp(-(J_t V) / A_t, -mu f, +mu f)
            V  += M^-1 (J_n^T f + J_t^T f_t)
    push the overlapping pairs apart (once, after the passes)

The lecture says "apply again during the same tick; average/combine the various
impulses". The reading used here: the impulses of the passes are *combined by
adding them up* on the velocities, each as soon as it is computed (pass p sees
the velocities every earlier application left behind). They are not averaged:
the mean of p impulses that each only half-stop a pair would stop it by half,
which no reading of the lecture intends.

Each application is clamped on its own: an increment never pulls (f >= 0) and its
friction is bounded by mu times that same increment. Nothing is accumulated, so
an impulse one pass over-applied can never be taken back by a later pass. That
is the whole difference from PGS, which clamps the accumulated lambda_k and so
may lower it again: PGS converges to a solution of A lambda = b with its bounds
(J V2 = xi where a contact pushes), this take converges to no particular
solution. It depends on the pair order, restitution is re-applied to whatever
approach speed a neighbour leaves, it has no Baumgarte term (overlap is removed
by moving positions), and friction is capped by the last increment, not the
total normal impulse. Hence the lecture's verdict: "constraints are still broken,
hack-y, no guarantees, still does not support stacking".

``w.last_step.residuals[p]`` is the largest |f| A (m/s) any pair needed in pass p,
and ``w.contacts`` reports the sum of a pair's increments, shared among its
colliding points.
"""

from __future__ import annotations

from ..validation import Setting, check_int, non_negative_float
from .base import Responder, SolveResult, StepContext
from .naive import pairwise_response


class IterativeImpulse(Responder):
    """The lecture's naive take number 2: ``passes`` pairwise impulse passes per tick;
    push_max (m/s) bounds how fast the push-apart may remove an overlap."""

    name = "iterative"
    counts = "passes"
    warm_start = False
    handles_joints = False

    passes = Setting(lambda v, name: check_int(v, name, 1), "impulse passes per tick")
    push_max = Setting(non_negative_float, "largest push-out speed, m/s")

    def __init__(self, passes: int = 10, push_max: float = 3.0) -> None:
        self.passes = passes
        self.push_max = push_max

    def respond(self, ctx: StepContext) -> SolveResult:
        return pairwise_response(ctx, self.passes, self.push_max)

    def __repr__(self) -> str:
        return f"IterativeImpulse(passes={self.passes}, push_max={self.push_max:g})"


__all__ = ["IterativeImpulse"]
