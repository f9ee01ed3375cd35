"""How long a first run compiles, told before it starts, from this machine's own speed.

A cold numba cache makes the first step compile every kernel: half a minute or more, which
``phys2d run`` announces in one line (``cli.first_step``). The estimate costs a few
milliseconds and compiles nothing:

    remembered   the last first run on this machine wrote its compile time beside numba's
                 cache (``phys2d-first-run.json``): the machine's pace against the reference,
                 scaled by how fast the CPU runs now against then
    measured     otherwise a few milliseconds of pure Python (``cpu_pace``) against the same
                 loop on the machine the reference times were taken on

REFERENCE holds each responder's compile time, wall clock, on a quiet 2-core machine
(benchmarks/STARTUP.md gives the runs); one core takes about the CPU time, REFERENCE_CPU.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

# seconds a first run compiles (the first step, wall clock) with two cores and with one, by responder,
# on the machine where cpu_pace() took REFERENCE_PACE (benchmarks/STARTUP.md, "The first-run estimate")
REFERENCE = {"pgs": 33.0, "soft-step": 35.0, "other": 20.0}
REFERENCE_CPU = {"pgs": 49.0, "soft-step": 52.0, "other": 20.0}
REFERENCE_PACE = 1.3e-3  # s, cpu_pace() there
FILE = "phys2d-first-run.json"


def cpu_pace(repeats: int = 10) -> float:
    """Seconds a fixed pure-Python loop takes here: the least of ``repeats`` (15-25 ms in all). A
    shared machine's core can run at half its pace for tens of milliseconds at a time; the least
    is the pace it can give, which a compile of half a minute mostly sees."""
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        total = 0.0
        for k in range(20_000):
            total += (k % 7) * 0.5
        times.append(time.perf_counter() - start)
    return min(times)


def _cores() -> int:
    from .pipeline.ahead import cores

    return cores()


def _reference(names: list[str], cores: int) -> float:
    table = REFERENCE if cores >= 2 else REFERENCE_CPU
    return max(table.get(name, table["other"]) for name in names)


def _record_file() -> Path | None:
    """Where the last first run's time is kept: beside numba's cache of the one-call tick."""
    try:
        from .pipeline.tick import tick

        return Path(tick._cache._cache_path) / FILE  # numba internals
    except (ImportError, AttributeError):
        return None


def estimate(names: list[str], cores: int | None = None) -> float:
    """Seconds the first run of the responders ``names`` should compile for here."""
    cores = _cores() if cores is None else cores
    pace = cpu_pace()
    record = _record_file()
    try:
        kept = json.loads(record.read_text()) if record is not None else {}
        seconds, kept_names, kept_pace, kept_cores = kept["seconds"], kept["names"], kept["pace"], kept["cores"]
        machine = seconds / _reference(kept_names, kept_cores) * (pace / kept_pace)  # here against the reference
    except (OSError, ValueError, KeyError, TypeError, ZeroDivisionError):
        machine = pace / REFERENCE_PACE
    return _reference(names, cores) * machine


def remember(names: list[str], seconds: float, cores: int | None = None) -> None:
    """Keep this first run's compile time beside the cache for the next estimate."""
    record = _record_file()
    if record is None or seconds <= 0.0:
        return
    cores = _cores() if cores is None else cores
    try:
        record.parent.mkdir(parents=True, exist_ok=True)
        record.write_text(json.dumps({"seconds": seconds, "names": names, "pace": cpu_pace(), "cores": cores}))
    except OSError:  # a read-only cache: the next estimate measures instead
        pass
