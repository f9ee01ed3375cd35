"""Sweeps: a grid of runs (scenes x responders x parameters), one row of metrics each.

    import phys2d
    result = phys2d.sweep({"scenes": ["vertical_stack"], "responders": ["pgs", "soft-step"],
                           "size": [5, 10, 20], "steps": 600}, out="sweeps/stacks.parquet")
    result.table            # a pyarrow.Table: one row per run
    result.rows             # the same rows as dicts

The same from the command line, on a local process pool or a Dask cluster:

    phys2d sweep grid.toml
    phys2d sweep grid.toml --scheduler tcp://HOST:8786

Each run is a deterministic task (``grid.Task``): its row (``task.ROW_COLUMNS``)
holds the parameters, the stood/fell verdict of ``phys2d.verdict`` (largest
displacement, deepest overlap, final residual...), the load errors of one-column
scenes, and the time per step. The metrics are bit-identical wherever a task runs.

Needs the ``sweep`` extra (pyarrow, tqdm, dask.distributed): ``pip install 'phys2d[sweep]'``.
``import phys2d`` does not import this package; ``phys2d.sweep`` loads it on first use.
"""

from .grid import AXES, Grid, Task, as_grids, expand, load_toml
from .runner import DEFAULT_OUT, SweepResult, check_scheduler, metrics_equal, read_table, sweep
from .scenes import COLUMNS, SWEEP_SCENES, all_scenes, circle_stack
from .task import METRIC_COLUMNS, ROW_COLUMNS, TIMING_COLUMNS, LoadWatch, build, run_task

__all__ = [
    "AXES",
    "COLUMNS",
    "DEFAULT_OUT",
    "Grid",
    "LoadWatch",
    "METRIC_COLUMNS",
    "ROW_COLUMNS",
    "SWEEP_SCENES",
    "SweepResult",
    "TIMING_COLUMNS",
    "Task",
    "all_scenes",
    "as_grids",
    "build",
    "check_scheduler",
    "circle_stack",
    "expand",
    "load_toml",
    "metrics_equal",
    "read_table",
    "run_task",
    "sweep",
]
