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

Scenes whose claim is not "it stands" have their own watch (``watch_for(scene, world)``,
from ``phys2d.stock_scenes.WATCHES``), each a Watch with its own outcomes:

    SettleWatch    judged from ``settle`` s on (a heavy box dropped first): held; else
                   fell, restless or crushed (overlap deeper than a limit)
    JointWatch     held while no joint opened more than ``gap_limit`` m; else broke
    RecoveryWatch  recovered: apart, at rest, never faster than ``speed_limit``; else
                   blown_apart or overlapping
    ToppleWatch    toppled: every body turned past ``fall_turn``, in creation order;
                   else stopped or out_of_order
    RegionWatch    contained: every centre stayed in a box (and out of a disc); else escaped
    RampWatch      coulomb: after landing, bodies with mu > tan(slope) slowed down (or
                   rested), the rest sped up; else crept or stuck
    DriveWatch     drove: a vehicle's body went right at ``min_speed`` on average and
                   never turned past ``flip_turn``; else stalled or flipped

``Verdict.passed`` is True for the passing outcomes (``PASSED``).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

FALL_DISTANCE = 0.5  # m: a body that moved farther than this has fallen
FALL_TURN = math.radians(30.0)  # rad: likewise for turning
REST_SPEED = 0.1  # m/s: a body faster than this at the end has not come to rest

STOOD, FELL, RESTLESS = "stood", "fell", "restless"
HELD, BROKE, CRUSHED = "held", "broke", "crushed"  # joints (or light bodies under a heavy one) held, or not
RECOVERED, BLOWN_APART, OVERLAPPING = "recovered", "blown_apart", "overlapping"
TOPPLED, STOPPED, OUT_OF_ORDER = "toppled", "stopped", "out_of_order"
CONTAINED, ESCAPED = "contained", "escaped"
COULOMB, CREPT, STUCK = "coulomb", "crept", "stuck"
DROVE, STALLED, FLIPPED = "drove", "stalled", "flipped"
UNSETTLED = "unsettled"  # the run ended before the watch began to judge
PASSED = frozenset({STOOD, HELD, RECOVERED, TOPPLED, CONTAINED, COULOMB, DROVE})  # outcomes that pass


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

    @property
    def passed(self) -> bool:
        """The scene did what its claim says (stood, held, recovered, ...: ``PASSED``)."""
        return self.outcome in PASSED

    def line(self) -> str:
        """One line for a terminal: the outcome, then the figures."""
        if self.outcome == FELL and self.fell_at is not None:
            head = f"fell at {self.fell_at:.2f} s ({self.why})"
        else:
            head = self.outcome.replace("_", " ") + (f" ({self.why})" if self.why else "")
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
            "passed": self.passed,
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
        outcome, why = self._judge(rows, speeds)
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

    def _judge(self, rows: np.ndarray, speeds: np.ndarray) -> tuple[str, str]:
        """(outcome, why) from the figures: fell, restless or stood (rows: the judged bodies now)."""
        if self.fell_at is not None:
            return FELL, self.why
        fastest = float(speeds.max()) if speeds.size else 0.0
        if fastest > self.rest_speed:
            j = int(rows[int(np.argmax(speeds))])
            return RESTLESS, f"held its place, but body {j} still moves at {fastest:.2f} m/s"
        return STOOD, ""


class SettleWatch(Watch):
    """A Watch for a scene that drops bodies first: the ``dropped`` ones (indices of
    ``World.bodies``) are judged from ``settle`` s on, from where they are then; the rest
    from the start. Its passing outcome is ``passes_as`` (``held`` for a heavy box held
    up by light ones); a run shorter than ``settle`` is ``unsettled``. With ``overlap_limit``
    (m), a last step whose deepest overlap is deeper is ``crushed``."""

    def __init__(
        self,
        world,
        *,
        settle: float,
        dropped: Sequence[int] | np.ndarray = (),
        passes_as: str = STOOD,
        overlap_limit: float | None = None,
        fall_distance: float = FALL_DISTANCE,
        fall_turn: float = FALL_TURN,
        rest_speed: float = REST_SPEED,
    ) -> None:
        super().__init__(world, fall_distance=fall_distance, fall_turn=fall_turn, rest_speed=rest_speed)
        self.settle = _check_limit(settle, "settle")
        self.passes_as = passes_as
        self.overlap_limit = None if overlap_limit is None else _check_limit(overlap_limit, "overlap_limit")
        self.settled = False
        self._dropped = np.flatnonzero(np.isin(self._judged, np.asarray(dropped, np.int64)))  # into _judged

    def observe(self) -> None:
        """Take in the world's state after a step; until ``settle`` s the dropped bodies move freely."""
        if not self.settled:
            self.settled = float(self.world.time) - self._t0 >= self.settle - 1e-9
            self._rebase(self._dropped)  # their reference follows them until they have settled
        super().observe()

    def _rebase(self, which: np.ndarray) -> None:
        """Judge the bodies ``which`` (positions in ``_judged``) from where they are now."""
        rows, present = self._current_rows()
        keep = np.isin(present, which)
        self._x0[present[keep]] = self.world.x[rows[keep]]
        self._theta0[present[keep]] = self.world.theta[rows[keep]]

    def _judge(self, rows: np.ndarray, speeds: np.ndarray) -> tuple[str, str]:
        if not self.settled:
            return UNSETTLED, f"the run ended before {self.settle:g} s, when the dropped bodies are judged"
        overlap = float(self.world.last_step.max_penetration)
        if self.overlap_limit is not None and overlap > self.overlap_limit:
            return CRUSHED, f"{1e3 * overlap:.0f} mm deep at the end"
        outcome, why = super()._judge(rows, speeds)
        return (self.passes_as, why) if outcome == STOOD else (outcome, why)


class JointWatch(Watch):
    """A Watch for a scene of joints: ``held`` while no pin or distance joint opened more than
    ``gap_limit`` (m) after any step, else ``broke`` (which joint, how far). Bodies may swing."""

    def __init__(self, world, *, gap_limit: float = 0.05) -> None:
        super().__init__(world)
        self.gap_limit = _check_limit(gap_limit, "gap_limit")
        self.max_gap = 0.0  # m, the widest a joint opened after any step
        self.widest = -1  # which joint (index in world.joints)

    def observe(self) -> None:
        """Take in the world's state after a step, and how far each joint is open."""
        super().observe()
        gaps = joint_gaps(self.world)
        if gaps.size:
            q = int(np.argmax(np.where(np.isnan(gaps), np.inf, gaps)))
            gap = float(gaps[q]) if not math.isnan(gaps[q]) else math.inf
            if gap > self.max_gap:
                self.max_gap, self.widest = gap, q

    def _judge(self, rows: np.ndarray, speeds: np.ndarray) -> tuple[str, str]:
        if self.max_gap > self.gap_limit:
            return BROKE, f"joint {self.widest} opened {1e3 * self.max_gap:.0f} mm"
        return HELD, f"joints open at most {1e3 * self.max_gap:.1f} mm"


def joint_gaps(world) -> np.ndarray:
    """How far each joint is from closed now (m; nan for angle joints): |p_b - p_a| for a pin,
    | |p_b - p_a| - L | for a distance joint, with p the anchors in world coordinates."""
    from .constraints.joints import JOINT_DISTANCE, JOINT_PIN

    ja = world._parts().joints.arrays  # (the joints packed, as the step reads them)
    x, theta = world.x, world.theta

    def anchor(body: np.ndarray, local: np.ndarray) -> np.ndarray:
        c, s = np.cos(theta[body]), np.sin(theta[body])
        return x[body] + np.stack([c * local[:, 0] - s * local[:, 1], s * local[:, 0] + c * local[:, 1]], axis=1)

    d = anchor(ja.body_b, ja.local_b) - anchor(ja.body_a, ja.local_a)
    length = np.hypot(d[:, 0], d[:, 1])
    return np.where(
        ja.kind == JOINT_PIN, length, np.where(ja.kind == JOINT_DISTANCE, np.abs(length - ja.params[:, 0]), np.nan)
    )


class RecoveryWatch(Watch):
    """A Watch for bodies that start overlapping: ``recovered`` when no body ever moved faster
    than ``speed_limit`` (m/s; PGS and SoftStep push overlap out at up to push_max = 3 m/s) and
    the deepest overlap of the last step is below ``overlap_limit`` (m), all at rest; else
    ``blown_apart``, ``overlapping`` or ``restless``."""

    def __init__(self, world, *, speed_limit: float = 5.0, overlap_limit: float = 0.01) -> None:
        super().__init__(world)
        self.speed_limit = _check_limit(speed_limit, "speed_limit")
        self.overlap_limit = _check_limit(overlap_limit, "overlap_limit")
        self.max_speed = 0.0  # m/s, the fastest any judged body moved after a step

    def observe(self) -> None:
        """Take in the world's state after a step, and its fastest body."""
        super().observe()
        rows, _ = self._current_rows()
        if rows.shape[0]:
            V = self.world.V[rows]
            self.max_speed = max(self.max_speed, float(np.hypot(V[:, 0], V[:, 1]).max()))

    def _judge(self, rows: np.ndarray, speeds: np.ndarray) -> tuple[str, str]:
        if not self.max_speed <= self.speed_limit:
            return BLOWN_APART, f"a body reached {self.max_speed:.2f} m/s"
        overlap = float(self.world.last_step.max_penetration)
        if overlap > self.overlap_limit:
            return OVERLAPPING, f"still {1e3 * overlap:.1f} mm deep"
        fastest = float(speeds.max()) if speeds.size else 0.0
        if fastest > self.rest_speed:
            return RESTLESS, f"a body still moves at {fastest:.2f} m/s"
        return RECOVERED, f"fastest {self.max_speed:.2f} m/s on the way"


class ToppleWatch(Watch):
    """A Watch for dominoes: ``toppled`` when every judged body turned past ``fall_turn`` (rad),
    each no earlier than the one created before it; else ``stopped`` or ``out_of_order``."""

    def __init__(self, world, *, fall_turn: float = FALL_TURN) -> None:
        super().__init__(world, fall_turn=fall_turn)
        self.toppled_at = np.full(self._judged.shape[0], np.nan)  # s since the watch began

    def observe(self) -> None:
        """Take in the world's state after a step, and which bodies have turned past fall_turn."""
        super().observe()
        rows, which = self._current_rows()
        turn = self.world.theta[rows] - self._theta0[which]
        turned = np.abs(np.arctan2(np.sin(turn), np.cos(turn))) > self.fall_turn
        new = turned & np.isnan(self.toppled_at[which])
        self.toppled_at[which[new]] = float(self.world.time) - self._t0

    def _judge(self, rows: np.ndarray, speeds: np.ndarray) -> tuple[str, str]:
        standing = np.flatnonzero(np.isnan(self.toppled_at))
        if standing.size:
            return STOPPED, f"body {int(self._judged[standing[0]])} never fell"
        early = np.flatnonzero(np.diff(self.toppled_at) < 0.0)
        if early.size:
            return OUT_OF_ORDER, f"body {int(self._judged[early[0] + 1])} fell before the one behind it"
        return TOPPLED, f"the last at {float(self.toppled_at[-1]):.2f} s"


class RegionWatch(Watch):
    """A Watch for bodies that must stay in a place: ``contained`` while every judged centre
    stays within the box ``lower`` .. ``upper`` (m) and out of the disc ``keep_out`` =
    (centre, radius) (m); else ``escaped`` (the first body out, and when)."""

    def __init__(
        self,
        world,
        *,
        lower: tuple[float, float],
        upper: tuple[float, float],
        keep_out: tuple[tuple[float, float], float] | None = None,
    ) -> None:
        super().__init__(world)
        self.lower, self.upper = np.asarray(lower, np.float64), np.asarray(upper, np.float64)
        self.keep_out = keep_out
        self.escaped = ""

    def observe(self) -> None:
        """Take in the world's state after a step, and whether a body left its place."""
        super().observe()
        if self.escaped:
            return
        rows, _ = self._current_rows()
        x = self.world.x[rows]
        out = ~np.all((x >= self.lower) & (x <= self.upper), axis=1)
        if self.keep_out is not None:
            (cx, cy), radius = self.keep_out
            out |= np.hypot(x[:, 0] - cx, x[:, 1] - cy) < radius
        if np.any(out):
            j = int(np.argmax(out))
            t = float(self.world.time) - self._t0
            self.escaped = f"body {int(rows[j])} at ({x[j, 0]:.2f}, {x[j, 1]:.2f}) m at {t:.2f} s"

    def _judge(self, rows: np.ndarray, speeds: np.ndarray) -> tuple[str, str]:
        return (ESCAPED, self.escaped) if self.escaped else (CONTAINED, "")


class RampWatch(Watch):
    """A Watch for bodies sliding on a slope of ``slope`` rad whose friction is ``ramp_friction``:
    over ``window`` s from ``settle`` s on (they have landed), a body with sqrt(mu mu_ramp) >
    tan(slope) must slow down or rest (Coulomb: friction beats g sin(slope)), the others
    speed up: ``coulomb``; else ``crept`` (one that should stop sped up) or ``stuck``."""

    def __init__(self, world, *, slope: float, ramp_friction: float, settle: float = 1.5, window: float = 0.5) -> None:
        super().__init__(world)
        mu = np.sqrt(np.array([world.bodies[i].friction for i in self._judged]) * ramp_friction)
        self.sticks = mu > math.tan(_check_limit(slope, "slope"))
        self.settle = _check_limit(settle, "settle")
        self.window = _check_limit(window, "window")
        self.speed_at = [np.full(self._judged.shape[0], np.nan), np.full(self._judged.shape[0], np.nan)]

    def observe(self) -> None:
        """Take in the world's state after a step, and the speeds at the window's two ends."""
        super().observe()
        t = float(self.world.time) - self._t0
        for end, at in enumerate((self.settle, self.settle + self.window)):
            if t >= at - 1e-9 and np.isnan(self.speed_at[end]).all():
                rows, which = self._current_rows()
                V = self.world.V[rows]
                self.speed_at[end][which] = np.hypot(V[:, 0], V[:, 1])

    def _judge(self, rows: np.ndarray, speeds: np.ndarray) -> tuple[str, str]:
        before, after = self.speed_at
        if np.isnan(after).all():
            return UNSETTLED, f"the run ended before {self.settle + self.window:g} s, the end of the window"
        gain = after - before  # m/s over the window
        crept = np.flatnonzero(self.sticks & (gain > 0.01))
        if crept.size:
            q = crept[0]
            return CREPT, f"body {int(self._judged[q])} should slow down but sped up by {gain[q]:.2f} m/s"
        stuck = np.flatnonzero(~self.sticks & ~(gain > 0.01))
        if stuck.size:
            q = stuck[0]
            return STUCK, f"body {int(self._judged[q])} should speed up but changed by {gain[q]:.2f} m/s"
        return COULOMB, f"{int(self.sticks.sum())} slowed down, {int((~self.sticks).sum())} sped up"


class DriveWatch(Watch):
    """A Watch for a vehicle: ``drove`` when its ``body`` (index) went right (+x) at ``min_speed``
    (m/s) or more on average over the run and never turned past ``flip_turn`` (rad); else
    ``stalled`` or ``flipped``. Its wheels and the rest may move as they like."""

    def __init__(self, world, *, body: int, min_speed: float, flip_turn: float = math.radians(60.0)) -> None:
        super().__init__(world)
        self.body = int(body)
        self.min_speed = _check_limit(min_speed, "min_speed")
        self.flip_turn = _check_limit(flip_turn, "flip_turn")
        self._start = float(world.x[self.body, 0])
        self.max_tilt = 0.0  # rad, the body's largest turn from its start

    def observe(self) -> None:
        """Take in the world's state after a step, and the vehicle's tilt."""
        super().observe()
        tilt = self.world.theta[self.body] - self._theta0[int(np.searchsorted(self._judged, self.body))]
        self.max_tilt = max(self.max_tilt, abs(math.atan2(math.sin(tilt), math.cos(tilt))))

    def _judge(self, rows: np.ndarray, speeds: np.ndarray) -> tuple[str, str]:
        seconds = float(self.world.time) - self._t0
        speed = (float(self.world.x[self.body, 0]) - self._start) / seconds if seconds > 0.0 else 0.0
        if self.max_tilt > self.flip_turn:
            return FLIPPED, f"it turned {math.degrees(self.max_tilt):.0f} deg"
        if speed < self.min_speed:
            return STALLED, f"it went {speed:.2f} m/s on average (needed {self.min_speed:.2f})"
        return DROVE, f"{speed:.2f} m/s on average, tilted {math.degrees(self.max_tilt):.0f} deg at most"


# each scene's own watch, by the scene's name: ``phys2d.stock_scenes`` (which imports this module)
# adds its scenes' when imported, as ``import phys2d`` does
WATCHES: dict[str, Callable[[Any], Watch]] = {}


def watch_for(scene: str, world) -> Watch:
    """The watch that judges ``scene`` by its own claim (``WATCHES``, the stock scenes' own);
    a plain :class:`Watch` (stood, fell or restless) for every other scene."""
    make = WATCHES.get(scene)
    return Watch(world) if make is None else make(world)


__all__ = [
    "BLOWN_APART",
    "DROVE",
    "DriveWatch",
    "FLIPPED",
    "STALLED",
    "BROKE",
    "CONTAINED",
    "COULOMB",
    "CREPT",
    "CRUSHED",
    "ESCAPED",
    "FALL_DISTANCE",
    "FALL_TURN",
    "FELL",
    "HELD",
    "OUT_OF_ORDER",
    "OVERLAPPING",
    "PASSED",
    "RECOVERED",
    "REST_SPEED",
    "RESTLESS",
    "STOOD",
    "STOPPED",
    "STUCK",
    "TOPPLED",
    "UNSETTLED",
    "JointWatch",
    "RampWatch",
    "RecoveryWatch",
    "RegionWatch",
    "SettleWatch",
    "ToppleWatch",
    "Verdict",
    "Watch",
    "joint_gaps",
    "watch_for",
]
