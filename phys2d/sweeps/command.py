"""``phys2d sweep``: the command line of ``phys2d.sweep``.

    phys2d sweep [GRID.toml] [--scenes A,B] [--responders pgs,soft-step] [--iterations 1..40]
                 [--substeps 1,2,4] [--mass-ratio 0.5,1,10] [--size 2,4] [--dt 1/60] [--steps N]
                 [--friction 0.2,0.6] [--seed 0..9] [--jitter M] [--out PATH.parquet] [--csv [PATH]]
                 [--record DIR] [--scheduler tcp://HOST:PORT] [--workers N] [--no-resume]

Axes given on the command line replace the same axes of the file. Lists are
comma-separated; whole numbers also take ranges ``1..40`` (both ends included);
``--dt`` takes fractions (``1/60``).
"""

from __future__ import annotations

import argparse
import os
import sys
from collections import Counter
from collections.abc import Callable
from fractions import Fraction
from typing import Any

from .grid import AXES, DEFAULT_JITTER, DEFAULT_STEPS, Grid, grids_from_mapping, load_toml


def _split(text: str) -> list[str]:
    items = [t.strip() for t in text.split(",")]
    if not text.strip() or any(not t for t in items):
        raise argparse.ArgumentTypeError(f"must be a comma-separated list, got {text!r}")
    return items


def _ints(text: str) -> list[int]:
    out: list[int] = []
    for item in _split(text):
        try:
            if ".." in item:
                a, b = (int(x) for x in item.split("..", 1))
                if b < a:
                    raise argparse.ArgumentTypeError(f"a range must go up, got {item!r}")
                out += range(a, b + 1)
            else:
                out.append(int(item))
        except ValueError:
            raise argparse.ArgumentTypeError(f"must be whole numbers or ranges A..B, got {item!r}") from None
    return out


def _numbers(text: str) -> list[float | int]:
    out: list[float | int] = []
    for item in _split(text):
        try:
            value = Fraction(item)
        except (ValueError, ZeroDivisionError):
            raise argparse.ArgumentTypeError(f"must be numbers (fractions such as 1/60 too), got {item!r}") from None
        out.append(int(value) if value.denominator == 1 else float(value))
    return out


def _names(text: str) -> list[str]:
    return _split(text)


def _scheduler(text: str) -> str:
    from .runner import check_scheduler

    try:
        return check_scheduler(text)
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e).removeprefix("scheduler ")) from None


def _workers(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be a whole number >= 1, got {text!r}")
    return value


_AXIS_TYPES: dict[str, Callable[[str], list[Any]]] = {
    "scenes": _names,
    "responders": _names,
    "iterations": _ints,
    "substeps": _ints,
    "mass_ratio": _numbers,
    "size": _numbers,
    "dt": _numbers,
    "steps": _ints,
    "friction": _numbers,
    "seed": _ints,
    "jitter": _numbers,
}


def add_parser(sub: Any) -> argparse.ArgumentParser:
    """Add the ``sweep`` subcommand to the ``phys2d`` subparsers ``sub``."""
    p = sub.add_parser(
        "sweep",
        help="a grid of runs (scenes x responders x parameters) to one Parquet table",
        description="Run every combination of scenes, responders and parameters, one deterministic run each, "
        "into one Parquet table (one row of metrics per run: stood or fell, largest displacement, "
        "deepest overlap, final residual, time per step). Rows already in the table are skipped. "
        "Runs on a local process pool, or on a Dask cluster with --scheduler.",
        epilog="Lists are comma-separated; whole numbers take ranges A..B; --dt takes 1/60. "
        "Needs the sweep extra: pip install 'phys2d[sweep]'.",
    )
    p.add_argument(
        "grid",
        nargs="?",
        default=None,
        help="a TOML grid file: axes as top-level keys, or [[grid]] tables (axes given below replace the file's)",
    )
    for axis, kind in _AXIS_TYPES.items():
        flags = [f"--{axis.replace('_', '-')}"]
        if axis in ("scenes", "responders"):
            flags.append(f"--{axis[:-1]}")
        default = {
            "steps": f" (default {DEFAULT_STEPS})",
            "jitter": f" (default {DEFAULT_JITTER:g})",
            "dt": " (default 1/60)",
            "responders": " (default pgs)",
        }.get(axis, "")
        p.add_argument(*flags, dest=axis, type=kind, default=None, metavar="LIST", help=AXES[axis] + default)
    _add_output_options(p)
    p.set_defaults(func=cmd_sweep, sweep_parser=p)
    return p


def _add_output_options(p: argparse.ArgumentParser) -> None:
    """``sweep``'s options of where the table and recordings go, and where the runs run."""
    p.add_argument(
        "--out", default=None, help="the Parquet table (default sweeps/GRID.parquet, or sweeps/sweep.parquet)"
    )
    p.add_argument(
        "--csv",
        nargs="?",
        const=True,
        default=None,
        metavar="PATH",
        help="also write the table as CSV (default path: OUT with .csv)",
    )
    p.add_argument(
        "--record",
        default=None,
        metavar="DIR",
        help="also write each run's recording to DIR/<run_id>.rrd (on the machine that runs it)",
    )
    p.add_argument(
        "--scheduler",
        type=_scheduler,
        default=None,
        metavar="tcp://HOST:PORT",
        help="run on this Dask distributed scheduler instead of local processes",
    )
    p.add_argument(
        "--workers",
        type=_workers,
        default=None,
        help="local processes (default: the CPU count; 1 runs in this process)",
    )
    p.add_argument("--no-resume", action="store_true", help="run every task again and replace the table")
    p.add_argument(
        "--progress",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="progress bar on stderr (default: when stderr is a terminal)",
    )


def grids_of(args: argparse.Namespace) -> list[Grid]:
    """The grids the command line asks for: the file's, with the command line's axes laid over them."""
    given = {axis: getattr(args, axis) for axis in _AXIS_TYPES if getattr(args, axis) is not None}
    if args.grid is None:
        if "scenes" not in given:
            raise ValueError("give a grid file or --scenes (see 'phys2d sweep --help')")
        return grids_from_mapping(given, where="command line")
    grids = load_toml(args.grid)
    return [
        Grid(**{**{f: getattr(g, f) for f in AXES}, **given}, lenient=tuple(a for a in g.lenient if a not in given))
        for g in grids
    ]


def summary(rows: list[dict[str, Any]]) -> list[str]:
    """Lines: outcomes per (scene, responder), with the median time per step."""
    groups: dict[tuple[str, str], list[dict[str, Any]]] = {}
    for r in rows:
        groups.setdefault((r["scene"], r["responder"]), []).append(r)
    head = (
        f"{'scene':<16} {'responder':<10} {'runs':>5} {'stood':>5} {'fell':>5} {'restless':>8} {'error':>5} "
        f"{'ms/step':>8}"
    )
    lines = [head]
    for (scene, responder), rs in groups.items():
        n = Counter(r["outcome"] for r in rs)
        ms = sorted(r["ms_per_step"] for r in rs if r["ms_per_step"] == r["ms_per_step"] and r["ms_per_step"])
        med = f"{ms[len(ms) // 2]:.3f}" if ms else "-"
        lines.append(
            f"{scene:<16} {responder:<10} {len(rs):>5} {n['stood']:>5} {n['fell']:>5} "
            f"{n['restless']:>8} {n['error']:>5} {med:>8}"
        )
    return lines


def cmd_sweep(args: argparse.Namespace) -> int:
    """Run the sweep; print what ran and where the table is."""
    from .runner import DEFAULT_OUT, sweep

    if args.grid is None and args.scenes is None:
        args.sweep_parser.error("give a grid file or --scenes")  # a usage error: exit 2
    grids = grids_of(args)
    out = args.out
    if out is None:
        stem = os.path.splitext(os.path.basename(args.grid))[0] if args.grid else None
        out = os.path.join("sweeps", f"{stem}.parquet") if stem else DEFAULT_OUT
    try:
        result = sweep(
            grids,
            out,
            csv=args.csv,
            scheduler=args.scheduler,
            workers=args.workers,
            record=args.record,
            resume=not args.no_resume,
            progress=args.progress,
        )
    except ImportError as e:
        print(f"phys2d sweep: error: {e}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(
            f"phys2d sweep: interrupted; the runs that finished are in {out}: run the same command to resume",
            file=sys.stderr,
        )
        return 130
    total = result.ran + result.skipped
    print(
        f"sweep: {total} runs, {result.ran} run now on {result.where} in {result.seconds:.1f} s, "
        f"{result.skipped} already in the table"
        + (f", {result.failed} stopped early (see the error column)" if result.failed else "")
    )
    print("\n".join(summary(result.rows)))
    print(f"table: {result.path} ({result.table.num_rows} rows)" + (f"; csv: {result.csv}" if result.csv else ""))
    return 0


__all__ = ["add_parser", "cmd_sweep", "grids_of", "summary"]
