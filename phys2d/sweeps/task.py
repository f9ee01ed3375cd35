"""One run of a sweep: build the world, step it, watch it, return one row.

``run_task(task)`` is a pure function of the task (a ``grid.Task``): the same task
gives a bit-identical row on any worker, except the timing columns. It imports
neither dask nor pyarrow, so it runs on a local process pool or a Dask worker alike.

The row (``ROW_COLUMNS``, in this order):

    run_id, scene, size, mass_ratio, responder, iterations, substeps, dt, steps,
    friction, seed, jitter           the task (see grid.py)
    outcome ... final_residual       ``phys2d.verdict.Verdict.as_row()`` of the scene's watch
                                     (``verdict.watch_for``): stood/fell/restless or the scene's
                                     own outcome, passed (the scene's claim held),
                                     fell_at (s), largest displacement (m), sideways (m),
                                     turn (rad), deepest overlap (m), final kinetic energy (J),
                                     fastest body at the end (m/s), final residual (m/s);
                                     its ``steps`` is renamed ``steps_run``
    load_error_first_tick           for one-column scenes (``scenes.COLUMNS``): the largest
                                     |Lambda - m_above g dt| / (m_above g dt) over the column's
                                     touching pairs on the first tick, Lambda a pair's total
                                     normal impulse (N s) and m_above the mass it carries; on a
                                     column at rest this is the error against the exact impulse.
                                     NaN for other scenes
    load_error_second_half          the same, the largest over the second half of the ticks
    error                            why the run stopped early (a SimulationError: then outcome is
                                     "error" and the figures are those of the steps before), or ""
    ms_per_step, first_step_ms       wall clock: mean of steps 2..N, and step 1 (compiles), ms
    recording                        the run's .rrd, when recordings were asked for
"""

from __future__ import annotations

import math
import os
import time
from typing import Any

import numpy as np

from ..responders import REGISTRY
from ..verdict import Watch, watch_for
from ..world import SimulationError, World
from .grid import Task
from .scenes import COLUMNS, build_scene

PARAM_COLUMNS = (
    "run_id",
    "scene",
    "size",
    "mass_ratio",
    "responder",
    "iterations",
    "substeps",
    "dt",
    "steps",
    "friction",
    "seed",
    "jitter",
)
LOAD_COLUMNS = ("load_error_first_tick", "load_error_second_half")
TIMING_COLUMNS = ("ms_per_step", "first_step_ms")
TAIL_COLUMNS = ("error", *TIMING_COLUMNS, "recording")


def _verdict_kinds() -> dict[str, type]:
    """The verdict's columns and their Python types (a verdict of an empty world as the sample)."""
    row = Watch(World()).verdict().as_row()
    return {("steps_run" if k == "steps" else k): type(v) for k, v in row.items()}


VERDICT_COLUMNS = tuple(_verdict_kinds())
ROW_COLUMNS = (*PARAM_COLUMNS, *VERDICT_COLUMNS, *LOAD_COLUMNS, *TAIL_COLUMNS)
COLUMN_KINDS: dict[str, type] = {
    "run_id": str,
    "scene": str,
    "size": float,
    "mass_ratio": float,
    "responder": str,
    "iterations": int,
    "substeps": int,
    "dt": float,
    "steps": int,
    "friction": float,
    "seed": int,
    "jitter": float,
    **_verdict_kinds(),
    **dict.fromkeys(LOAD_COLUMNS, float),
    "error": str,
    **dict.fromkeys(TIMING_COLUMNS, float),
    "recording": str,
}
"""Each column's type (a table column may hold None, except for the metrics)."""
METRIC_COLUMNS = tuple(c for c in ROW_COLUMNS if c not in TIMING_COLUMNS and c != "recording")
"""The columns that are the same, bit for bit, wherever a task runs."""


def build(task: Task) -> World:
    """The task's world: its scene and responder, then friction and the seeded shift applied to it.

    The shift moves every dynamic body sideways by a uniform draw in [-jitter, jitter] m
    from ``numpy.random.default_rng(seed)``, in body order: the same seed gives the
    same start everywhere.
    """
    responder = REGISTRY[task.responder](task.count)
    w = build_scene(task.scene, task.size, task.mass_ratio, responder)
    if task.friction is not None:
        for body in w.bodies:
            body.friction = task.friction
    if task.seed is not None and task.jitter:
        rng = np.random.default_rng(task.seed)
        for body in w.bodies:
            if not body.static:
                body.position = body.position + np.array([rng.uniform(-task.jitter, task.jitter), 0.0])
    return w


class LoadWatch:
    """How far a column's contact impulses are from the weights they carry (see the module docstring).

    Bodies 1, 2, ... stand bottom up on body 0 (the ground); the pair (i - 1, i)
    carries the mass of bodies i, i + 1, ...
    """

    def __init__(self, world: World, steps: int) -> None:
        self.world = world
        self.steps = steps
        mass = np.array([b.mass if not b.static else 0.0 for b in world.bodies])
        self.carried = np.cumsum(mass[::-1])[::-1][1:]  # kg above pair (i - 1, i), i = 1..N-1
        self.g = float(np.hypot(*world.gravity))
        self.first_tick = math.nan
        self.second_half = math.nan
        self._tick = 0

    def error(self) -> float:
        """The largest relative error of the pairs' total normal impulses on the last step."""
        w = self.world
        if self.carried.size == 0 or self.g == 0.0:
            return math.nan
        ct = w.contacts
        lo = np.minimum(ct.body_a, ct.body_b)
        hi = np.maximum(ct.body_a, ct.body_b)
        adjacent = hi == lo + 1
        total = np.zeros(self.carried.size)
        np.add.at(total, hi[adjacent] - 1, ct.lambda_n[adjacent])
        exact = self.carried * self.g * w.last_step.dt
        return float(np.max(np.abs(total - exact) / exact))

    def observe(self) -> None:
        """Take in the step just made."""
        self._tick += 1
        err = self.error()
        if self._tick == 1:
            self.first_tick = err
        if self._tick > self.steps // 2:
            self.second_half = err if math.isnan(self.second_half) else max(self.second_half, err)


def run_task(task: Task, record_dir: str | None = None) -> dict[str, Any]:
    """Run one task; returns its row (``ROW_COLUMNS``). ``record_dir``: also write <run_id>.rrd there."""
    row: dict[str, Any] = {"run_id": task.run_id, **task.params()}
    w = build(task)
    watch = watch_for(task.scene, w)
    loads = LoadWatch(w, task.steps) if task.scene in COLUMNS else None
    rec = None
    path = None
    if record_dir is not None:
        from ..recording import Recorder

        path = os.path.join(record_dir, f"{task.run_id}.rrd")
        rec = Recorder(path, name=task.label(), scene=task.scene)
        rec.log(w)
    error = ""
    times = np.zeros(task.steps)
    done = 0
    try:
        for k in range(task.steps):
            t0 = time.perf_counter()
            try:
                w.step(task.dt)
            except SimulationError as e:
                error = f"step {k + 1}: {e}"
                break
            times[k] = time.perf_counter() - t0
            done += 1
            watch.observe()
            if loads is not None:
                loads.observe()
            if rec is not None:
                rec.log(w)
    finally:
        if rec is not None:
            rec.close()
    verdict = watch.verdict().as_row()
    row.update(("steps_run" if k == "steps" else k, v) for k, v in verdict.items())
    if error:  # blown up: the figures are those of the steps before, the outcome is not a verdict
        row["outcome"], row["stood"], row["passed"] = "error", False, False
    row["load_error_first_tick"] = loads.first_tick if loads is not None else math.nan
    row["load_error_second_half"] = loads.second_half if loads is not None else math.nan
    row["error"] = error
    row["ms_per_step"] = 1e3 * float(times[1:done].mean()) if done > 1 else math.nan
    row["first_step_ms"] = 1e3 * float(times[0]) if done else math.nan
    row["recording"] = path
    return {c: row.get(c) for c in ROW_COLUMNS}


def run_tasks(tasks: list[Task], record_dir: str | None = None) -> list[dict[str, Any]]:
    """``run_task`` for each of a chunk of tasks (fewer round trips to a pool or a cluster)."""
    return [run_task(t, record_dir) for t in tasks]


__all__ = [
    "COLUMN_KINDS",
    "LOAD_COLUMNS",
    "LoadWatch",
    "METRIC_COLUMNS",
    "PARAM_COLUMNS",
    "ROW_COLUMNS",
    "TIMING_COLUMNS",
    "VERDICT_COLUMNS",
    "build",
    "run_task",
    "run_tasks",
]
