"""Compiling on two cores: the first step of a cold numba cache, about half as long.

numba compiles one function at a time, on one core. The one-call tick (``pipeline.tick``)
calls ``before_solve``, the solve and ``after_solve``, and through them a dozen stage kernels,
each compiled once and cached on disk. On a cold cache with a
second core, ``start`` splits the work:

    a child process   steps a small world of the same responder: numba compiles the tick
                      from its first stage down, saving each kernel to the cache
    this process      compiles the tick's stages from the last one up (``compile_from_the_end``),
                      then waits for the child (``wait_for``) and loads the tick it saved; the
                      child reaches the stages this process compiled after their turn and
                      loads them, so each kernel is compiled about once (the tick's own top,
                      ``before_solve`` and ``after_solve``, is the child's alone)

Nothing changes in what runs: the same kernels, compiled for the same argument types, and a
kernel that neither process has compiled yet is compiled by whichever needs it first.

After an edit the cache holds most stages but not the tick, which links them all and takes
seconds to compile on its own. Then (``plan`` says "behind") this process steps the world stage
by stage, compiling only the stages the edit touched, while a child compiles the tick into the
cache; once the child is done the world goes on in one call. Both ways give bit-identical
states, so the switch changes nothing but the speed.

Set PHYS2D_COMPILE_AHEAD=0 to compile in one process.
"""

from __future__ import annotations

import os
import pickle
import subprocess
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np
from numba import config, typeof

# what the last cold tick did: "ahead" (two processes compile it), "behind" (stages now, the tick
# in a child), "here" (this process compiles it); read by the first-run notice
last_plan = ""


def cold(kernel: Any, args: tuple) -> bool:
    """Whether ``kernel`` has neither machine code nor a cached entry for the types of ``args``."""
    if config.DISABLE_JIT or getattr(kernel, "overloads", None) is None:  # type: ignore[attr-defined]
        return False
    return cold_for(kernel, tuple(kernel.typeof_pyval(a) for a in args))


def cold_for(kernel: Any, sig: tuple) -> bool:
    """Whether ``kernel`` has neither machine code nor a cached entry for the argument types ``sig``."""
    if config.DISABLE_JIT or getattr(kernel, "overloads", None) is None:  # type: ignore[attr-defined]
        return False
    if sig in kernel.overloads:
        return False
    try:
        index = kernel._cache._cache_file._load_index()  # numba's cache index (numba internals)
    except Exception:  # another numba, or no cache: assume warm and compile here, as numba does
        return False
    return not any(key[0] == sig for key in index)


def cores() -> int:
    """The cores this process may run on (its affinity: ``taskset -c 0`` gives 1 of 2)."""
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0)) or 1
    return os.cpu_count() or 1


def wanted() -> bool:
    """Whether to compile on two cores: a second core, and not turned off."""
    return os.environ.get("PHYS2D_COMPILE_AHEAD", "1") != "0" and cores() >= 2


def start(responder: Any, joints: bool, rounded: bool = False, threads: int = 1) -> subprocess.Popen | None:
    """The child process that steps a small world under ``responder`` (with a joint when
    ``joints``, a capsule when ``rounded``, on ``threads`` threads), compiling the tick from its
    first stage down; None if it cannot start."""
    try:
        child = subprocess.Popen(
            [sys.executable, "-m", "phys2d.pipeline.compile_child"],
            stdin=subprocess.PIPE,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            env={**os.environ, "PHYS2D_COMPILE_AHEAD": "0"},
        )
        assert child.stdin is not None
        child.stdin.write(pickle.dumps((responder, joints, rounded, threads)))
        child.stdin.close()
    except (OSError, pickle.PicklingError):
        return None
    return child


def plan(pipeline: Any, tick: Any, args: tuple) -> str:
    """How to compile the tick for ``args`` (the tick's own): "here" when its machine code is
    cached (or compiling ahead is off), "behind" when it is not but some of its stages are (an
    edit), "ahead" when nothing is (a first run)."""
    if not wanted() or not cold(tick, args):
        return "here"
    warm = any(not cold_for(kernel, sig) for kernel, sig in stage_jobs(pipeline, args))
    return "behind" if warm else "ahead"


def wait_for(child: subprocess.Popen, limit: float = 600.0) -> None:
    """Wait until the child has compiled the tick into the cache (or died, or ``limit`` s went
    by: then this process compiles what is missing itself, as numba would)."""
    try:
        child.wait(timeout=limit)
    except subprocess.TimeoutExpired:
        pass


def compile_from_the_end(pipeline: Any, args: tuple) -> None:
    """Compile the stages ``pipeline.tick.tick`` calls, from the last one up, for the types the
    tick calls them with: ``args`` are the tick's own (context, settings, solver, counts)."""
    for kernel, sig in stage_jobs(pipeline, args):
        kernel.compile(sig)


def stage_jobs(pipeline: Any, args: tuple) -> list[tuple[Any, tuple]]:
    """The heavy stage kernels ``pipeline.tick.tick`` calls, from the last one up, each with the
    argument types the tick calls it with (``args`` are the tick's own)."""
    from ..collision.recycle import collide_recycling
    from ..constraints.joints import start_joint_rows
    from ..constraints.rows import contact_rows
    from ..contacts import impulses_to_contacts_and_cache
    from ..integrate import first_too_fast
    from ..responders.pgs import pgs_step
    from ..responders.soft_step import soft_step_solve

    ctx, settings, solver, _ = args
    bodies, shapes, store, sides, rows = (typeof(r) for r in pipeline._records)
    found = typeof(pipeline._records[3][0])
    i64, f64 = typeof(0), typeof(0.0)
    floats, residuals = typeof(np.zeros(0)), typeof(pipeline.residuals[0])  # (one side's)
    context = typeof(ctx)
    joints, threads, rounded = (context.field_dict[name] for name in ("joints", "threads", "rounded"))
    solve_threads = typeof(None if pipeline._threads == 1 else (pipeline._threads, np.zeros(0, np.int32)))
    jobs: list[tuple[Any, tuple]] = [
        (impulses_to_contacts_and_cache, (rows, found, i64, threads)),
        (first_too_fast, (bodies.field_dict["V"], bodies.field_dict["x"], floats, f64)),
    ]
    if solver.pgs is not None:
        jobs.append((pgs_step, (bodies, rows, floats, f64, typeof(solver.pgs), residuals, joints, solve_threads)))
    if solver.soft is not None:
        found_of = typeof((np.zeros(0, np.int32), np.zeros(0), np.zeros(0)))  # (order, separation, e)
        jobs.append(
            (soft_step_solve, (bodies, rows, found_of, joints, f64, typeof(solver.soft), residuals, solve_threads))
        )
    if joints != typeof(None):
        jobs.append((start_joint_rows, (joints, i64, bodies, f64, f64, typeof(True), rows)))
    cache = typeof((np.zeros(0, np.int64), np.zeros(0), np.zeros(0), np.zeros(0, np.bool_)))
    jobs += [
        (contact_rows, (bodies, shapes, cache, found, rows, typeof(settings.rows), threads)),
        (
            collide_recycling,
            (bodies, shapes, store, found, found, typeof((0, 0, 0, 0)), typeof((0.0, 0.0, 0.0)), rounded),
        ),
    ]
    del sides
    return jobs


@contextmanager
def one_child_per_cache() -> Iterator[None]:
    """Hold the lock of the numba cache the tick is saved in while compiling into it: a second
    child (two runs started close together after an edit) waits for the first, then finds in
    the cache what the first compiled, instead of compiling the same kernels on the same cores."""
    try:
        import fcntl

        from .tick import tick

        folder = Path(tick._cache._cache_path)  # numba internals: its cache folder
        folder.mkdir(parents=True, exist_ok=True)
        lock = open(folder / "phys2d-ahead.lock", "w")  # noqa: SIM115 (held until the child exits)
    except (ImportError, AttributeError, OSError):  # no fcntl (Windows) or no cache folder: no lock
        yield
        return
    with lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # released when the child exits
        yield
