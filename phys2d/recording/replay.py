"""Re-entering a recording: a live World at any tick a run logged, from the keyframe at or before it.

    w = phys2d.playback.world_at("recordings/pyramid-20-pgs.rrd", 240)   # a World at tick 240
    t = phys2d.playback.timeline("recordings/pyramid-20-pgs.rrd")        # what the run keeps for it
    t.check()                                                            # every tick stepped again

A run of a recording keeps (``schema``: ``replay/state``, ``replay/keyframes``,
``replay/responder``) every tick's state hash (``World.state_hash``) and dt, the responder's
class and settings on the ticks where they changed, and a keyframe, the world's snapshot
(``phys2d.snapshot``), on its first tick and every ``Recorder(keyframe_every=...)`` ticks.
``Timeline.world_at(tick)`` restores the keyframe at or before the tick and steps it on with
the recorded dts, the responder the recording had at each tick set before the step into it,
and checks every tick's state hash against the recorded one: a tick whose hash differs is
where code outside the step changed the world (a force applied, a mouse target moved, a body
added: nothing a replay can know of), and ``ReplayError`` names it.

A ``Timeline`` is also kept live, in memory (``append``), by ``phys2d.Lab``.
"""

from __future__ import annotations

import json
import os
import warnings
import zlib
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
import pyarrow as pa

from . import schema

if TYPE_CHECKING:
    from ..world import World


PART_DISTANCE = 1e-3  # m: two futures have parted once a body is this far from where it was


class ReplayError(ValueError):
    """A tick a recording cannot give back (never logged, before its first keyframe, no keyframes),
    or a replay whose state hash parts from the recording's; one line."""


@dataclass(frozen=True)
class CheckResult:
    """What ``Timeline.check`` found: ``matched`` of ``total`` logged ticks stepped again to the
    recorded state hash; ``first_bad`` the first tick that did not (None: all did), ``detail`` why."""

    matched: int
    total: int
    keyframes: int
    first_bad: int | None = None
    detail: str = ""

    @property
    def ok(self) -> bool:
        return self.first_bad is None and self.matched == self.total


@dataclass(eq=False)
class Timeline:
    """One run's replay record: its logged ticks in order with each one's state hash and dt (s),
    its keyframes (tick -> snapshot, zlib-compressed) and its responders (tick -> spec as JSON,
    on the ticks where it changed). ``where`` names it in messages."""

    where: str = "this timeline"
    ticks: list[int] = field(default_factory=list)
    hashes: list[int] = field(default_factory=list)
    dts: list[float] = field(default_factory=list)
    keyframes: dict[int, bytes] = field(default_factory=dict)
    responders: dict[int, str] = field(default_factory=dict)
    times: list[float] = field(default_factory=list)  # each tick's w.time, s (as the sim_time timeline)
    sweeps: list[int] = field(default_factory=list)  # each tick's solver sweeps (rows of the sweep timeline)
    keyframe_every: int = 0  # ticks between keyframes for ``append`` (0: the first only)
    _spec: str | None = None  # the responder's spec as ``append`` last kept it

    # -- kept live ----------------------------------------------------------------------------
    def append(self, world: World, keyframe: bool = False) -> None:
        """Keep ``world`` as it is now as its tick (after the last one kept): its hash and dt, its
        responder if changed, and a keyframe on the first tick, every ``keyframe_every`` ticks and
        when ``keyframe`` says so (after a change from outside the step)."""
        from .. import snapshot

        tick = int(world.tick)
        if self.ticks and tick <= self.ticks[-1]:
            raise ValueError(f"tick {tick} comes after tick {self.ticks[-1]} only in a new timeline")
        spec = json.dumps(snapshot.responder_spec(world.responder), sort_keys=True)
        last = max(self.keyframes) if self.keyframes else None
        if keyframe or last is None or (self.keyframe_every > 0 and tick - last >= self.keyframe_every):
            self.keyframes[tick] = zlib.compress(snapshot.snapshot(world), 1)
        if spec != self._spec:
            self.responders[tick] = self._spec = spec
        self.ticks.append(tick)
        self.hashes.append(snapshot.state_hash(world))
        self.dts.append(float(world.last_step.dt))
        self.times.append(float(world.time))
        self.sweeps.append(int(world.last_step.residuals.size))

    # -- read back --------------------------------------------------------------------------------
    @property
    def first(self) -> int:
        return self.ticks[0]

    @property
    def last(self) -> int:
        return self.ticks[-1]

    def keyframe_ticks(self) -> list[int]:
        return sorted(self.keyframes)

    def snapshot_at(self, tick: int) -> bytes:
        """The keyframe of ``tick`` as ``World.snapshot`` wrote it."""
        return zlib.decompress(self.keyframes[tick])

    def _index(self, tick: int) -> int:
        """Where ``tick`` is among the logged ticks; ReplayError naming the nearest when it is not."""
        if isinstance(tick, bool) or not isinstance(tick, (int, np.integer)):
            raise TypeError(f"tick must be an integer, got {type(tick).__name__}")
        tick = int(tick)
        if not self.ticks:
            raise ReplayError(f"{self.where} logged no tick")
        at = int(np.searchsorted(self.ticks, tick))
        if at < len(self.ticks) and self.ticks[at] == tick:
            return at
        if tick < self.first or tick > self.last:
            raise ReplayError(f"tick {tick} is outside {self.where}: it holds ticks {self.first}-{self.last}")
        raise ReplayError(
            f"tick {tick} was never logged in {self.where}: the nearest logged ticks are "
            f"{self.ticks[at - 1]} and {self.ticks[at]}"
        )

    def missing_keyframes(self) -> ReplayError:
        """The error for a timeline without keyframes: what to do instead."""
        return ReplayError(
            f"{self.where} holds no keyframes (recorded with keyframe_every=0, or by a phys2d without "
            "snapshots), so no tick of it can be re-entered: record it again with phys2d.Recorder(..., "
            "keyframe_every=60) (phys2d run and compare keep them), or build the scene again and step it to "
            "the tick"
        )

    def world_at(self, tick: int, on_tick: Callable[[World], None] | None = None) -> World:
        """A live World at ``tick``: the keyframe at or before it, stepped on with the recorded dts
        and responders, each tick's state hash checked (ReplayError at the first that differs).
        ``on_tick(w)`` is called after every step of the replay."""
        at = self._index(tick)
        if not self.keyframes:
            raise self.missing_keyframes()
        before = [k for k in self.keyframes if k <= tick]
        if not before:
            raise ReplayError(
                f"{self.where} has no keyframe at or before tick {tick}: its first is at tick {min(self.keyframes)}"
            )
        start = max(before)
        w = self._restored(start)
        self._replay(w, self.ticks.index(start), at, on_tick)
        return w

    def _restored(self, tick: int) -> World:
        from ..world import World

        w = World.from_snapshot(self.snapshot_at(tick))
        recorded = self.hashes[self.ticks.index(tick)]
        if w.state_hash() != recorded:
            raise ReplayError(
                f"the keyframe at tick {tick} of {self.where} does not hash to the recorded state hash "
                f"({w.state_hash():#018x}, recorded {recorded:#018x}): the file was written by another build"
            )
        return w

    def _replay(
        self, w: World, frm: int, to: int, on_tick: Callable[[World], None] | None = None, start: int | None = None
    ) -> None:
        """Step ``w`` (at logged tick index ``frm``) on to logged tick index ``to``, checking hashes
        (``start``: the keyframe's tick the replay began at, for the message)."""
        from ..snapshot import responder_from_spec

        start = self.ticks[frm] if start is None else start
        for i in range(frm + 1, to + 1):
            tick = self.ticks[i]
            spec = self.responders.get(tick)
            if spec is not None:
                w.responder = responder_from_spec(json.loads(spec))
            for _ in range(tick - int(w.tick)):  # (a gap in the log: each missing step with the tick's dt)
                w.step(self.dts[i])
            if on_tick is not None:
                on_tick(w)
            got = w.state_hash()
            if got != self.hashes[i]:
                raise ReplayError(
                    f"tick {tick} of {self.where} differs from its replay from the keyframe at tick {start}: its "
                    f"state hash is {got:#018x}, the recording's {self.hashes[i]:#018x}; code outside the step "
                    f"changed the world between ticks {self.ticks[i - 1]} and {tick} (a force, a mouse target, a "
                    "body added or moved: make such changes after a step and before its log, and log that tick with "
                    "Recorder.log(w, keyframe=True)), or another build of phys2d steps differently"
                )

    def check(self, progress: Callable[[int], None] | None = None) -> CheckResult:
        """Every logged tick stepped again from the keyframe before it, its state hash checked;
        ``progress(ticks)`` after each stretch from one keyframe to the next."""
        if not self.keyframes:
            raise self.missing_keyframes()
        keys = self.keyframe_ticks()
        bounds = [self.ticks.index(k) for k in keys] + [len(self.ticks)]
        matched = 0
        first_bad: int | None = None
        detail = ""
        for k, (frm, end) in enumerate(zip(bounds, bounds[1:], strict=False)):
            i = frm
            try:
                w = self._restored(keys[k])
                matched += 1
                for i in range(frm + 1, end):
                    self._replay(w, i - 1, i, start=keys[k])
                    matched += 1
            except ReplayError as e:
                if first_bad is None:
                    first_bad, detail = self.ticks[i], str(e)
            if progress is not None:
                progress(end - frm)
        if bounds[0] and not detail:  # ticks logged before the first keyframe cannot be replayed
            detail = f"ticks {self.first}-{self.ticks[bounds[0] - 1]} come before the first keyframe, at {keys[0]}"
        return CheckResult(matched, len(self.ticks), len(keys), first_bad, detail)

    def dt_at(self, tick: int) -> float:
        """The dt (s) of the step into ``tick``: the recorded one, or past the log the last one."""
        at = int(np.searchsorted(self.ticks, tick))
        if at < len(self.ticks) and self.ticks[at] == tick:
            return self.dts[at]
        return self.dts[-1] if self.dts and self.dts[-1] > 0.0 else 1 / 60

    def branch(
        self,
        at: int,
        responder: Any,
        steps: int | None = None,
        on_tick: Callable[[World, World], None] | None = None,
        threshold: float = PART_DISTANCE,
    ) -> Parting:
        """The future from tick ``at`` under ``responder`` beside the recorded one: both worlds from
        the tick's state (``world_at``), stepped ``steps`` ticks (default: to the end of the log)
        with the recorded dts; the original with the recorded responders, its state hash checked
        against the recording's as long as the log goes. ``on_tick(original, branch)`` after every
        step (and once before the first). Returns where they part (``Parting``)."""
        from ..world import SimulationError, World

        self._index(at)  # a tick the log holds
        if steps is None:
            steps = self.last - int(at)
            if steps <= 0:
                raise ReplayError(f"tick {at} is the last of {self.where}: say how many steps to take from it")
        original = self.world_at(at)
        other = World.from_snapshot(original.snapshot())
        other.responder = responder
        parting = Parting(int(at), threshold=threshold)
        if on_tick is not None:
            on_tick(original, other)
        logged = set(self.ticks)
        for tick in range(int(at) + 1, int(at) + steps + 1):
            dt = self.dt_at(tick)
            spec = self.responders.get(tick)
            if spec is not None:
                from ..snapshot import responder_from_spec

                original.responder = responder_from_spec(json.loads(spec))
            try:
                original.step(dt)
            except SimulationError as e:
                parting.note = f"the original refused the step into tick {tick}: {e}"
                break
            if tick in logged and original.state_hash() != self.hashes[self.ticks.index(tick)]:
                parting.note = (
                    f"from tick {tick} on the original's replay differs from the recording (changed from "
                    "outside the step there): compared up to the tick before"
                )
                break
            try:
                other.step(dt)
            except SimulationError as e:
                parting.note = f"the branch refused the step into tick {tick}: {e}"
                break
            parting.observe(tick, original, other)
            if on_tick is not None:
                on_tick(original, other)
        return parting


@dataclass(eq=False)
class Parting:
    """Where two futures from one tick part: ``start`` the tick they share, ``ticks`` how many
    steps were compared; the first tick (``first_tick``) where a body (uid ``first_uid``) is more
    than ``threshold`` m from where it is in the original (``first_distance`` m), None while
    none is; the largest distance by the end (``largest`` m, body ``largest_uid`` at tick
    ``largest_tick``); ``distance`` the largest of each tick (m); ``note`` why it stopped early."""

    start: int
    ticks: int = 0
    threshold: float = PART_DISTANCE
    first_tick: int | None = None
    first_uid: int | None = None
    first_distance: float = 0.0
    largest: float = 0.0
    largest_uid: int | None = None
    largest_tick: int | None = None
    distance: list[float] = field(default_factory=list)
    note: str = ""

    def observe(self, tick: int, original: World, branch: World) -> None:
        """Compare tick ``tick`` of the two worlds (the same bodies, row by row)."""
        d = np.hypot(*(branch.x - original.x).T) if len(original) else np.zeros(0)
        self.ticks += 1
        worst = int(np.argmax(d)) if d.size else -1
        far = float(d[worst]) if d.size else 0.0
        self.distance.append(far)
        uid = int(original.body_uids[worst]) if d.size else None
        if self.first_tick is None and far > self.threshold:
            self.first_tick, self.first_uid, self.first_distance = tick, uid, far
        if far > self.largest:
            self.largest, self.largest_uid, self.largest_tick = far, uid, tick

    def lines(self) -> list[str]:
        """The account, a line each: where they part, and how far by the end."""
        end = self.start + self.ticks
        if self.first_tick is None:
            out = [
                f"they do not part: no body is more than {1e3 * self.threshold:g} mm from where it was by tick {end}"
            ]
        else:
            out = [
                f"they part at tick {self.first_tick}: body b{self.first_uid} is {1e3 * self.first_distance:.3g} mm "
                f"from where it was (the first more than {1e3 * self.threshold:g} mm away)"
            ]
        if self.largest_tick is not None:
            out.append(
                f"by tick {end} the largest distance is {_metres(self.largest)} (body b{self.largest_uid} at tick "
                f"{self.largest_tick})"
            )
        if self.note:
            out.append(f"note: {self.note}")
        return out


def _metres(d: float) -> str:
    return f"{1e3 * d:.3g} mm" if d < 0.1 else f"{d:.3g} m"


# -- from a recording file ------------------------------------------------------------------------------
def _label_of(entity: str, suffix: str) -> str | None:
    """The run label of a replay entity path ('' for a file's unnamed run), or None if it is not one."""
    if entity == f"/{suffix}":
        return ""
    head = f"/{schema.RUNS_ROOT}/"
    if entity.startswith(head) and entity.endswith(f"/{suffix}"):
        return entity[len(head) : -len(suffix) - 1]
    return None


def _column(batch: Any, name: str) -> list:
    return [v[0] if isinstance(v, list) and v else v for v in batch.column(name).to_pylist()]


def timelines(path: str | os.PathLike) -> dict[str, Timeline]:
    """Every run's Timeline in a recording, by label ('' for a file's one unnamed run); runs recorded
    without replay data come back empty."""
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"path must be a str or os.PathLike, got {type(path).__name__}")
    p = os.fspath(path)
    if not os.path.isfile(p):
        raise FileNotFoundError(f"path {p!r}: no such recording file")
    rows: dict[str, dict[str, list]] = {}
    labels: set[str] = set()
    for ch in _chunks(p):
        ep = ch.entity_path
        if ch.is_static:
            continue
        run = _label_of(ep, schema.BODIES)
        if run is not None:
            labels.add(run)
        for suffix in (schema.REPLAY_STATE, schema.REPLAY_KEYFRAMES, schema.REPLAY_RESPONDER, schema.SWEEPS):
            run = _label_of(ep, suffix)
            if run is not None:
                labels.add(run)
                rb = ch.to_record_batch()
                kept = rows.setdefault(run, {})
                kept.setdefault(suffix, []).append(rb)
    out = {}
    for run in sorted(labels):
        where = f"{p!r}" + (f" (run {run!r})" if run else "")
        out[run] = _timeline_of(where, rows.get(run, {}))
    return out


def _chunks(p: str) -> list:
    """The chunks of recording file ``p``, read with rerun's own reader (a file without a footer: what
    was written); RecordingError when it is not a readable .rrd."""
    from rerun.chunk import RrdReader

    from .playback import RecordingError

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            reader = RrdReader(p)
        try:
            return list(reader.store().stream())
        except Exception:  # no footer: what was written
            return list(reader.stream())
    except Exception as e:
        raise RecordingError(f"path {p!r} is not a readable .rrd file: {e}") from e


def _timeline_of(where: str, kept: dict[str, list]) -> Timeline:
    """One run's Timeline from its record batches (``kept``, by entity: ``schema.REPLAY_STATE``, the
    keyframes, the responders and ``schema.SWEEPS``); ``where`` names it in messages."""
    t = Timeline(where)
    state = sorted(
        (int(tick), int(h), float(dt), int(ns) / 1e9)
        for b in kept.get(schema.REPLAY_STATE, [])
        for tick, h, dt, ns in zip(
            b.column(schema.TICK).to_pylist(),
            _column(b, schema.STATE_HASH.name),
            _column(b, schema.DT.name),
            b.column(schema.SIM_TIME).cast(pa.int64()).to_pylist(),
        )
    )
    t.ticks, t.hashes = [s[0] for s in state], [s[1] for s in state]
    t.dts, t.times = [s[2] for s in state], [s[3] for s in state]
    swept = [np.asarray(b.column(schema.TICK).to_numpy()) for b in kept.get(schema.SWEEPS, [])]
    per_tick = np.concatenate(swept) if swept else np.zeros(0, np.int64)
    t.sweeps = np.searchsorted(np.sort(per_tick), t.ticks, side="right").tolist()
    t.sweeps = np.diff(np.concatenate([[0], t.sweeps])).astype(int).tolist() if t.ticks else []
    for suffix, name, into in (
        (schema.REPLAY_KEYFRAMES, schema.KEYFRAME.name, t.keyframes),
        (schema.REPLAY_RESPONDER, schema.RESPONDER_SPEC.name, t.responders),
    ):
        for b in kept.get(suffix, []):
            into.update(zip((int(v) for v in b.column(schema.TICK).to_pylist()), _column(b, name)))
    return t


def timeline(path: str | os.PathLike, run: str | None = None) -> Timeline:
    """The Timeline of one run of a recording (``run``: its label, as ``compare`` names them; None
    for a file of one run)."""
    runs = timelines(path)
    if run is None:
        if len(runs) != 1:
            raise ReplayError(f"{os.fspath(path)!r} holds runs {sorted(runs)}: pass run= (or --run) to pick one")
        return next(iter(runs.values()))
    if not isinstance(run, str):
        raise TypeError(f"run must be a run label (str) or None, got {type(run).__name__}")
    if run not in runs:
        names = ", ".join(repr(r) for r in sorted(runs)) or "none"
        raise ReplayError(f"{os.fspath(path)!r} holds no run {run!r} (its runs: {names})")
    return runs[run]


def world_at(path: str | os.PathLike, tick: int, run: str | None = None) -> World:
    """A live World at ``tick`` of a recording (``run``: which run, in a file of several), from the
    keyframe at or before it, stepped on with the recorded dts and responders and checked
    against the recorded state hashes (``Timeline.world_at``)."""
    return timeline(path, run).world_at(tick)


__all__ = ["CheckResult", "PART_DISTANCE", "Parting", "ReplayError", "Timeline", "timeline", "timelines", "world_at"]
