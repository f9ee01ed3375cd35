"""Responders written outside the engine for tests/test_check.py: the lesson's plain PGS with one
thing broken each, and responders that break the protocol."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

import phys2d
from phys2d.checks import load

LecturePGS = load(str(Path(__file__).resolve().parents[1] / "lessons" / "your_responder.py") + ":LecturePGS")


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


class OneSided(LecturePGS):  # type: ignore[misc, valid-type]
    """Impulses act on body a only (M^-1 J^T of body b zeroed): momentum is not kept."""

    name = "one-sided"

    def respond(self, ctx: phys2d.StepContext) -> phys2d.SolveResult:
        ctx.rows.JM[:, 3:] = 0.0
        return super().respond(ctx)
