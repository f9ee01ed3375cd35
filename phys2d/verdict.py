"""Did the scene stand or fall? One verdict for ``compare``, sweeps and benchmarks.

A :class:`Watch` follows a world step by step from the moment it is made and
keeps the figures a verdict needs:

    largest displacement   the farthest any dynamic body got from where it started, m
    largest turn           the largest change of angle of any dynamic body, rad
    deepest overlap        the largest ``last_step.max_penetration`` seen, m
    final kinetic energy   J, and the fastest dynamic body at the end, m/s

The verdict is ``fell`` once any body moved more than ``fall_distance`` or turned
more than ``fall_turn``; otherwise ``restless`` if a body still moves faster than
``rest_speed`` at the end (a stack that holds its place only because the naive
responder pushes positions apart, while its velocities grow); otherwise ``stood``.
Only bodies present when the watch began are judged; bodies added later are not.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

FALL_DISTANCE = 0.5  # m: a body that moved farther than this has fallen
FALL_TURN = math.radians(30.0)  # rad: likewise for turning
REST_SPEED = 0.1  # m/s: a body faster than this at the end has not come to rest

STOOD, FELL, RESTLESS = "stood", "fell", "restless"


@dataclass(frozen=True)
class Verdict:
    """What a watched run did. ``outcome`` is ``stood``, ``fell`` or ``restless``."""

    outcome: str
    why: str  # one phrase: which body fell and how, or which still moves
    fell_at: float | None  # s since the watch began, when it first fell; None if it did not
    steps: int
    seconds: float  # s watched
    max_displacement: float  # m
    max_sideways: float  # m, largest |dx|
    max_turn: float  # rad
    max_overlap: float  # m
    final_kinetic_energy: float  # J
    final_max_speed: float  # m/s
    final_residual: float  # m/s, the last sweep's residual of the last step (nan: no sweeps)

    @property
    def stood(self) -> bool:
        return self.outcome == STOOD

    def line(self) -> str:
        """One line for a terminal: the outcome, then the figures."""
        if self.outcome == FELL:
            head = f"fell at {self.fell_at:.2f} s ({self.why})"
        elif self.outcome == RESTLESS:
            head = f"restless ({self.why})"
        else:
            head = "stood"
        return (
            f"{head}: largest displacement {self.max_displacement:.3f} m, "
            f"final kinetic energy {self.final_kinetic_energy:.3g} J, "
            f"deepest overlap {1e3 * self.max_overlap:.1f} mm"
        )

    def as_row(self) -> dict[str, float | int | str | bool]:
        """The verdict as a flat table row (fell_at is nan when it stood)."""
        return {
            "outcome": self.outcome,
            "stood": self.stood,
            "fell_at": math.nan if self.fell_at is None else self.fell_at,
            "steps": self.steps,
            "seconds": self.seconds,
            "max_displacement": self.max_displacement,
            "max_sideways": self.max_sideways,
            "max_turn": self.max_turn,
            "max_overlap": self.max_overlap,
            "final_kinetic_energy": self.final_kinetic_energy,
            "final_max_speed": self.final_max_speed,
            "final_residual": self.final_residual,
        }


def _check_limit(value: float, name: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)):
        raise TypeError(f"{name} must be a number, got {type(value).__name__}")
    value = float(value)
    if not (math.isfinite(value) and value > 0.0):
        raise ValueError(f"{name} must be a finite number > 0, got {value}")
    return value


class Watch:
    """Follows a World; call :meth:`observe` after every step, then :meth:`verdict`.

    watch = Watch(w)
    for _ in range(600):
        w.step(1 / 60)
        watch.observe()
    print(watch.verdict().line())
    """

    def __init__(
        self,
        world,
        *,
        fall_distance: float = FALL_DISTANCE,
        fall_turn: float = FALL_TURN,
        rest_speed: float = REST_SPEED,
    ) -> None:
        self.fall_distance = _check_limit(fall_distance, "fall_distance")
        self.fall_turn = _check_limit(fall_turn, "fall_turn")
        self.rest_speed = _check_limit(rest_speed, "rest_speed")
        self.world = world
        self._handles = world.bodies
        dynamic = world.M_inv[:, 0] > 0.0
        self._judged = np.flatnonzero(dynamic)  # indices (at the start) of the bodies judged
        self._x0 = world.x[self._judged].copy()
        self._theta0 = world.theta[self._judged].copy()
        self._t0 = float(world.time)
        self.steps = 0
        self.max_displacement = 0.0
        self.max_sideways = 0.0
        self.max_turn = 0.0
        self.max_overlap = 0.0
        self.fell_at: float | None = None
        self.why = ""

    def _current_rows(self) -> tuple[np.ndarray, np.ndarray]:
        """(rows now, which judged bodies they are): removed bodies drop out."""
        now = self.world.bodies
        start = self._handles
        if len(now) == len(start) and (not start or now[-1] is start[-1]):
            return self._judged, np.arange(self._judged.shape[0])  # nothing added or removed
        where = {h: i for i, h in enumerate(now)}
        pairs = [(where[start[s]], q) for q, s in enumerate(self._judged) if start[s] in where]
        if not pairs:
            return np.zeros(0, np.int64), np.zeros(0, np.int64)
        rows, which = np.array(pairs, np.int64).T
        return rows, which

    def observe(self) -> None:
        """Take in the world's state after a step."""
        w = self.world
        self.steps += 1
        self.max_overlap = max(self.max_overlap, float(w.last_step.max_penetration))
        rows, which = self._current_rows()
        if rows.shape[0] == 0:
            return
        d = w.x[rows] - self._x0[which]
        move = np.hypot(d[:, 0], d[:, 1])
        turn = np.abs(
            np.arctan2(np.sin(w.theta[rows] - self._theta0[which]), np.cos(w.theta[rows] - self._theta0[which]))
        )
        self.max_displacement = max(self.max_displacement, float(move.max()))
        self.max_sideways = max(self.max_sideways, float(np.abs(d[:, 0]).max()))
        self.max_turn = max(self.max_turn, float(turn.max()))
        if self.fell_at is None:
            j = int(np.argmax(move))
            if move[j] > self.fall_distance:
                self.fell_at = float(w.time) - self._t0
                self.why = f"body {int(rows[j])} moved {move[j]:.2f} m"
            elif turn.max() > self.fall_turn:
                j = int(np.argmax(turn))
                self.fell_at = float(w.time) - self._t0
                self.why = f"body {int(rows[j])} turned {math.degrees(turn[j]):.0f} deg"

    def verdict(self) -> Verdict:
        """The verdict on the steps observed so far."""
        w = self.world
        rows, _ = self._current_rows()
        speeds = np.hypot(w.V[rows, 0], w.V[rows, 1]) if rows.shape[0] else np.zeros(0)
        fastest = float(speeds.max()) if speeds.size else 0.0
        residuals = w.last_step.residuals
        final_residual = float(residuals[-1]) if residuals.size else math.nan
        if self.fell_at is not None:
            outcome, why = FELL, self.why
        elif fastest > self.rest_speed:
            j = int(rows[int(np.argmax(speeds))])
            outcome = RESTLESS
            why = f"held its place, but body {j} still moves at {fastest:.2f} m/s"
        else:
            outcome, why = STOOD, ""
        return Verdict(
            outcome=outcome,
            why=why,
            fell_at=self.fell_at,
            steps=self.steps,
            seconds=float(w.time) - self._t0,
            max_displacement=self.max_displacement,
            max_sideways=self.max_sideways,
            max_turn=self.max_turn,
            max_overlap=self.max_overlap,
            final_kinetic_energy=float(w.kinetic_energy()),
            final_max_speed=fastest,
            final_residual=final_residual,
        )


__all__ = ["FALL_DISTANCE", "FALL_TURN", "FELL", "REST_SPEED", "RESTLESS", "STOOD", "Verdict", "Watch"]
