"""Run a sweep's tasks on a local process pool or a Dask cluster, into one Parquet table.

The table is written through pyarrow, at the end and every ``checkpoint`` seconds
while the sweep runs (to a temporary file, then renamed over the old one), so an
interrupted sweep keeps the rows it finished. Run again, it skips every task whose
``run_id`` is already in the table (``resume=True``, the default).

Rows come in the order of the grid, whichever worker finished first; rows of the
table that are not in the grid (an earlier, different sweep) follow, as they were.
"""

from __future__ import annotations

import math
import os
import re
import signal
import struct
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any

from .grid import Task, as_grids, expand
from .task import ROW_COLUMNS, run_task, run_tasks

DEFAULT_OUT = os.path.join("sweeps", "sweep.parquet")
CHECKPOINT_S = 10.0  # s between checkpoints of the table while a sweep runs
_ADDRESS = re.compile(r"^(tcp|tls)://(\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9_.-]+):(\d{1,5})$")
EXTRA_HINT = "pip install 'phys2d[sweep]'"


def check_scheduler(address: Any) -> str:
    """``tcp://HOST:PORT`` (or ``tls://``), checked; a ValueError/TypeError naming ``scheduler`` otherwise."""
    if not isinstance(address, str):
        raise TypeError(f"scheduler must be an address such as tcp://HOST:PORT, got {type(address).__name__}")
    m = _ADDRESS.match(address.strip())
    if not m or not 0 < int(m.group(3)) < 65536:
        raise ValueError(f"scheduler must be an address tcp://HOST:PORT (port 1-65535), got {address!r}")
    return address.strip()


def _require(module: str, what: str) -> Any:
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError:
        raise ImportError(f"{what} needs {module.split('.')[0]}, part of the sweep extra: {EXTRA_HINT}") from None


@dataclass
class SweepResult:
    """What ``phys2d.sweep`` did.

    table    the whole table (pyarrow.Table), rows already there included
    path     the Parquet file; csv: the CSV file, or None
    ran      tasks run now; skipped: tasks whose rows were already in the table
    failed   tasks run now that stopped early (their ``error`` is not empty)
    seconds  wall clock of the whole sweep, s
    where    what ran the tasks ("this process", "2 local processes", "Dask at tcp://...")
    rows     the table's rows as dicts, in the table's order and types
    """

    table: Any
    path: str
    csv: str | None
    ran: int
    skipped: int
    failed: int
    seconds: float
    where: str = ""
    rows: list[dict[str, Any]] = field(repr=False, default_factory=list)


# -- the table -------------------------------------------------------------------------------
def _schema(pa: Any) -> Any:
    """Fixed column types, so tables from different sweeps concatenate and resume."""
    from .task import COLUMN_KINDS

    kinds = {str: pa.string(), bool: pa.bool_(), int: pa.int64(), float: pa.float64()}
    return pa.schema([pa.field(c, kinds[COLUMN_KINDS[c]]) for c in ROW_COLUMNS])


def read_table(path: str) -> list[dict[str, Any]]:
    """The rows of a sweep table (Parquet), or [] when there is none yet."""
    if not os.path.exists(path):
        return []
    pq = _require("pyarrow.parquet", "reading a sweep table")
    try:
        return pq.read_table(path).to_pylist()
    except Exception as e:  # a file that is not Parquet: say so rather than overwrite it
        raise ValueError(
            f"out {path!r} exists and is not a readable Parquet table ({e}); choose another path, or remove it"
        ) from None


def to_table(rows: list[dict[str, Any]]) -> Any:
    """Rows -> pyarrow.Table with the sweep's schema (extra columns of older tables kept)."""
    pa = _require("pyarrow", "a sweep table")
    schema = _schema(pa)
    extra = [c for r in rows for c in r if c not in schema.names]
    for c in dict.fromkeys(extra):
        schema = schema.append(pa.field(c, pa.array([r.get(c) for r in rows]).type))
    return pa.Table.from_pylist([{c: r.get(c) for c in schema.names} for r in rows], schema=schema)


def write_table(rows: list[dict[str, Any]], path: str, csv: str | None = None) -> Any:
    """Write rows to ``path`` (Parquet, atomically) and to ``csv`` when given; returns the table."""
    pq = _require("pyarrow.parquet", "writing a sweep table")
    table = to_table(rows)
    parent = os.path.dirname(os.path.abspath(path))
    os.makedirs(parent, exist_ok=True)
    tmp = f"{path}.tmp-{os.getpid()}"
    pq.write_table(table, tmp)
    os.replace(tmp, path)
    if csv is not None:
        import pyarrow.csv as pcsv

        os.makedirs(os.path.dirname(os.path.abspath(csv)), exist_ok=True)
        pcsv.write_csv(table, csv)
    return table


def _ordered(tasks: Sequence[Task], rows: dict[str, dict[str, Any]], old: list[dict[str, Any]]) -> list[dict]:
    ids = [t.run_id for t in tasks]
    in_grid = set(ids)
    return [rows[i] for i in ids if i in rows] + [r for r in old if r.get("run_id") not in in_grid]


# -- executors -------------------------------------------------------------------------------
def _chunks(tasks: Sequence[Task], slots: int) -> list[list[Task]]:
    """Tasks in chunks of 1 to 16, about 4 chunks per worker slot: fewer round trips for tiny runs."""
    size = max(1, min(16, len(tasks) // (4 * max(1, slots))))
    return [list(tasks[k : k + size]) for k in range(0, len(tasks), size)]


def _serial(tasks: Sequence[Task], record: str | None) -> Iterator[list[dict[str, Any]]]:
    for t in tasks:
        yield [run_task(t, record)]


def _ignore_sigint() -> None:
    """A pool worker leaves Ctrl-C to the parent, which stops the whole pool."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _run_chunk(args: tuple[list[Task], str | None]) -> list[dict[str, Any]]:
    return run_tasks(*args)


def _pool(tasks: Sequence[Task], record: str | None, workers: int) -> Iterator[list[dict[str, Any]]]:
    import multiprocessing

    # spawn: a clean interpreter per worker (no fork of a process that has threads running)
    pool = multiprocessing.get_context("spawn").Pool(workers, initializer=_ignore_sigint)
    try:
        yield from pool.imap_unordered(_run_chunk, [(chunk, record) for chunk in _chunks(tasks, workers)])
        pool.close()
    except BaseException:  # an interrupt, a failed task, or the caller stopped reading: stop the workers now
        pool.terminate()
        raise
    finally:
        pool.join()


def _dask(tasks: Sequence[Task], record: str | None, address: str) -> Iterator[list[dict[str, Any]]]:
    distributed = _require("dask.distributed", "--scheduler (a Dask cluster)")
    try:
        client = distributed.Client(address, timeout="10s", set_as_default=False)
    except (OSError, TimeoutError) as e:
        raise ConnectionError(f"could not reach the Dask scheduler at {address}: {e}") from None
    try:
        slots = sum(client.nthreads().values())
        futures = client.map(run_tasks, _chunks(tasks, slots), record_dir=record, pure=False)
        try:
            with client.as_current():
                completed = distributed.as_completed(futures)
            for f in completed:
                try:
                    yield f.result()
                except (ImportError, AttributeError) as e:
                    raise RuntimeError(
                        f"a Dask worker could not run a phys2d task ({type(e).__name__}: {e}); "
                        "is the same phys2d installed on every worker?"
                    ) from None
        except BaseException:
            client.cancel(futures)
            raise
    finally:
        client.close()


# -- the sweep ---------------------------------------------------------------------------------
def sweep(
    grid: Any,
    out: str | os.PathLike = DEFAULT_OUT,
    *,
    csv: str | os.PathLike | bool | None = None,
    scheduler: str | None = None,
    workers: int | None = None,
    record: str | os.PathLike | None = None,
    resume: bool = True,
    progress: bool | None = None,
    checkpoint: float = CHECKPOINT_S,
    on_row: Callable[[dict[str, Any]], None] | None = None,
) -> SweepResult:
    """Run every combination of a grid, one deterministic task per run, into one Parquet table.

    grid       a ``Grid``, a mapping {axis: values}, a list of those, or the path of a
               TOML file (see ``phys2d.sweeps.grid`` for the axes)
    out        the Parquet table (default sweeps/sweep.parquet); parent folders are made
    csv        also write the table as CSV: a path, or True for ``out`` with .csv
    scheduler  None: a local process pool; ``tcp://HOST:PORT``: a Dask distributed
               scheduler (needs dask.distributed here and phys2d on every worker)
    workers    local pool size (default: the CPU count); 1 runs in this process
    record     a folder: each run also writes its recording there as <run_id>.rrd
               (on the machine that runs it)
    resume     skip the tasks whose rows are already in ``out`` (False: start afresh)
    progress   a tqdm bar on stderr (None: when stderr is a terminal)
    checkpoint seconds between rewrites of ``out`` while running
    on_row     called with each new row as it arrives

    The metrics of a row are the same, bit for bit, on the pool and on a cluster
    (``task.METRIC_COLUMNS``); only the timings differ. Returns a ``SweepResult``. The local
    pool starts fresh interpreters (multiprocessing's spawn), which import the calling script
    again: in a script, call ``sweep`` under ``if __name__ == "__main__":`` as with any pool.
    """
    t_start = time.perf_counter()
    tasks = expand(as_grids(grid))
    path, csv_path = _table_paths(out, csv)
    scheduler = _checked_options(scheduler, workers, resume, checkpoint)
    record_dir = None if record is None else os.path.abspath(os.fspath(record))
    tqdm = _ready(tasks, scheduler)
    old = read_table(path) if resume else []
    rows: dict[str, dict[str, Any]] = {r["run_id"]: r for r in old if r.get("run_id") is not None}
    todo = [t for t in tasks if t.run_id not in {r.get("run_id") for r in old}]
    skipped = len(tasks) - len(todo)
    if record_dir is not None:
        os.makedirs(record_dir, exist_ok=True)
    source, where = _source(todo, record_dir, scheduler, workers)
    show = sys.stderr.isatty() if progress is None else bool(progress)
    desc = f"sweep ({where})" + (f", {skipped} already done" if skipped else "")
    bar = tqdm(total=len(todo), disable=not show, file=sys.stderr, unit="run", dynamic_ncols=True, desc=desc)
    new_rows: list[dict[str, Any]] = []
    try:
        _collect(source, rows, new_rows, bar, on_row, lambda: write_table(_ordered(tasks, rows, old), path), checkpoint)
    finally:  # also on an interrupt or a failed task: keep the rows that finished
        bar.close()
        table = write_table(_ordered(tasks, rows, old), path, csv_path)
    failed = sum(bool(row.get("error")) for row in new_rows)
    seconds = time.perf_counter() - t_start
    return SweepResult(table, path, csv_path, len(new_rows), skipped, failed, seconds, where, table.to_pylist())


def _collect(
    source: Any, rows: dict, new_rows: list, bar: Any, on_row: Callable | None, save: Callable, checkpoint: float
) -> None:
    """The rows of ``source``'s chunks into ``rows`` (by run id) and ``new_rows``, each told to
    ``on_row``; ``save`` the table every ``checkpoint`` seconds."""
    last = time.perf_counter()
    for chunk in source:
        for row in chunk:
            rows[row["run_id"]] = row
            new_rows.append(row)
            if on_row is not None:
                on_row(row)
        bar.update(len(chunk))
        if time.perf_counter() - last > checkpoint:
            save()
            last = time.perf_counter()


def _ready(tasks: Sequence[Task], scheduler: str | None) -> Any:
    """Check that every run builds and that what the sweep needs is installed; returns tqdm."""
    _check_grid_builds(tasks)
    tqdm = _require("tqdm", "the sweep's progress bar").tqdm
    _require("pyarrow.parquet", "the sweep's table")
    if scheduler is not None:
        _require("dask.distributed", "--scheduler (a Dask cluster)")
    return tqdm


def _table_paths(out: Any, csv: Any) -> tuple[str, str | None]:
    """The Parquet table's path and the CSV's (or None), checked."""
    if not isinstance(out, (str, os.PathLike)):
        raise TypeError(f"out must be a path, got {type(out).__name__}")
    path = os.fspath(out)
    if not path.endswith(".parquet"):
        raise ValueError(f"out must name a .parquet file, got {path!r}")
    if csv is True:
        return path, path[: -len(".parquet")] + ".csv"
    if csv is None or csv is False:
        return path, None
    if isinstance(csv, (str, os.PathLike)):
        return path, os.fspath(csv)
    raise TypeError(f"csv must be a path, True or None, got {type(csv).__name__}")


def _checked_options(scheduler: Any, workers: Any, resume: Any, checkpoint: Any) -> str | None:
    """Check the sweep's options; returns the scheduler's address (or None: a local pool)."""
    if scheduler is not None:
        scheduler = check_scheduler(scheduler)
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or workers < 1):
        raise ValueError(f"workers must be a whole number >= 1, got {workers!r}")
    if not isinstance(resume, bool):
        raise TypeError(f"resume must be True or False, got {resume!r}")
    if not (isinstance(checkpoint, (int, float)) and not isinstance(checkpoint, bool) and checkpoint > 0):
        raise ValueError(f"checkpoint must be a number of seconds > 0, got {checkpoint!r}")
    return scheduler


def _source(todo: list[Task], record_dir: str | None, scheduler: str | None, workers: int | None) -> tuple[Any, str]:
    """Where the runs go (a Dask cluster, a local pool, or this process) and its name: chunks of rows."""
    if scheduler is not None:
        return _dask(todo, record_dir, scheduler), f"Dask at {scheduler}"
    n = min(workers or os.cpu_count() or 1, max(1, len(todo)))
    if n == 1:
        return _serial(todo, record_dir), "this process"
    return _pool(todo, record_dir, n), f"{n} local processes"


def _check_grid_builds(tasks: Sequence[Task]) -> None:
    """Build each distinct (scene, size, ratio, responder) once: a bad combination fails here, by name."""
    from ..responders import REGISTRY
    from .scenes import build_scene

    seen: set[tuple[Any, ...]] = set()
    for t in tasks:
        key = (t.scene, t.size, t.mass_ratio, t.responder)
        if key in seen:
            continue
        seen.add(key)
        try:
            build_scene(t.scene, t.size, t.mass_ratio, REGISTRY[t.responder](t.count))
        except (ValueError, TypeError) as e:
            what = (
                f"scene {t.scene!r}"
                + (f" with size {t.size!r}" if t.size is not None else "")
                + (f" and mass_ratio {t.mass_ratio!r}" if t.mass_ratio is not None else "")
            )
            raise type(e)(f"{what} under responder {t.responder!r}: {e}") from None


def _same(x: Any, y: Any) -> bool:
    if isinstance(x, float) and isinstance(y, float):
        return struct.pack("<d", x) == struct.pack("<d", y) or (math.isnan(x) and math.isnan(y))
    return x == y and isinstance(x, bool) == isinstance(y, bool)


def metrics_equal(a: dict[str, Any], b: dict[str, Any]) -> bool:
    """Whether two rows (as read back from tables) have the same metrics, bit for bit, timings aside.

    Floats compare by their bits (so -0.0 differs from 0.0), except that NaN equals NaN.
    """
    from .task import METRIC_COLUMNS

    return all(_same(a.get(c), b.get(c)) for c in METRIC_COLUMNS)


__all__ = [
    "CHECKPOINT_S",
    "DEFAULT_OUT",
    "SweepResult",
    "check_scheduler",
    "metrics_equal",
    "read_table",
    "sweep",
    "to_table",
    "write_table",
]
