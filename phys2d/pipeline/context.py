"""The step context: what one step reads, built once and reused while nothing changed.

``Pipeline`` (``pipeline.step``) holds a ``records.TickContext`` over its buffers and the world's
arrays (made anew only when one of them is replaced), and beside it the step's settings
(``stages.StepSettings``, made anew when the world's settings, the responder's or dt change) and
the responder's solve (``Solver``). This module makes the last two from plain values:

    WorldSettings   what the world sets (gravity, margins, max_speed, threads), plain values
    step_settings   the stages' settings: the world's, dt and the responder's row settings
    solver_of       the solve a responder names (``Responder.kernel``) with its settings

and it is the one place where a plain setting becomes the form numba compiles a branch away
with: ``switch`` turns False into None (numba settles ``x is None`` when it compiles, so a
kernel given None compiles none of that branch's code): PGS's block sweep, the threads (a
count, or None on one thread), the joints (a record, or None in a world without), rounded
shapes (True, or None in a world of circles and polygons only).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np

from ..constraints.rows import RowSettings
from .stages import StepSettings


class WorldSettings(NamedTuple):
    """What the world sets for its steps (``World``'s settings), plain values."""

    gravity: np.ndarray  # (2,) m/s^2
    contact_margin: float  # m
    recycle_distance: float  # m
    max_speed: float  # m/s or rad/s
    threads: int  # cores a step may use

    @property
    def g(self) -> float:
        """|gravity|, m/s^2 (the lecture's friction bound)."""
        return float(math.hypot(*self.gravity))


def switch(flag: bool) -> bool | None:
    """True, or None for False: a compile-time switch (numba compiles no code for a None branch)."""
    return True if flag else None


def threads_switch(threads: int) -> int | None:
    """The thread count, or None on one thread (no parallel code compiled)."""
    return threads if threads > 1 else None


class PGSKernel(NamedTuple):
    """PGS's settings as ``responders.pgs.pgs_step`` reads them (``PGS.settings``, in numba's forms)."""

    iterations: int
    tolerance: float  # m/s; -1.0: never stop early
    block: bool | None  # True: Box2D's block sweep; None: the lecture's row-by-row sweep (not compiled then)
    split: bool


def pgs_kernel(settings: Any) -> PGSKernel:
    """``PGS.settings`` (plain: tolerance None or m/s, block a bool) in ``pgs_step``'s forms."""
    tolerance = -1.0 if settings.tolerance is None else settings.tolerance
    return PGSKernel(settings.iterations, tolerance, switch(settings.block), settings.split)


class Solver(NamedTuple):
    """The solve a one-call tick runs (``tick.solve``): one of the two holds its kernel's
    settings, the other is None."""

    pgs: PGSKernel | None
    soft: Any  # ``SoftSettings`` or None


# the solve kernels by the names responders give them (``Responder.kernel``): their Solver from
# the responder's settings
KERNELS: dict[str, Callable[[Any], Solver]] = {
    "pgs": lambda settings: Solver(pgs_kernel(settings), None),
    "soft-step": lambda settings: Solver(None, settings),
}


def solver_of(responder: Any) -> Solver | None:
    """The solve ``responder`` names (``Responder.kernel``) with its settings, or None: its
    ``respond`` runs in Python, stage by stage (as does one given a ``respond`` of its own,
    ``Responder.respond_replaced``)."""
    name = responder.kernel
    if name is None or responder.respond_replaced:
        return None
    if name not in KERNELS:
        raise ValueError(
            f"{type(responder).__name__}.kernel names no solve kernel: {name!r} (known: {sorted(KERNELS)})"
        )
    return KERNELS[name](responder.settings)


def step_settings(world: WorldSettings, responder: Any, dt: float, one_call: bool) -> StepSettings:
    """The stages' settings: the world's, dt (s), and the rows the responder reads (all of them
    when its ``respond`` runs in Python, ``one_call`` False: ``Responder.reads_targets``)."""
    targets = responder.reads_targets or not one_call
    rows = RowSettings(
        dt, world.g, responder.beta, responder.slop, responder.push_max, responder.restitution_threshold,
        responder.friction_model, responder.found_lever_arms, responder.warm_start, targets,
    )  # fmt: skip
    return StepSettings(world.gravity, dt, world.contact_margin, world.recycle_distance, world.max_speed, rows)
