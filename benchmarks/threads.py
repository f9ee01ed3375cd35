"""What World.threads buys: time per step on 1 and 2 threads, and the share of a step that threads split.

    python benchmarks/threads.py                     # pyramids of base 40, 70 and 100, SoftStep(4) and PGS
    python benchmarks/threads.py --quick             # a short run, to see that it works (pyramid_20)
    python benchmarks/threads.py --scenes pyramid_70 --repeats 15 --markdown

Per scene (``phys2d.scenes.pyramid(n)``: pyramid_40, pyramid_70, pyramid_100 = Box2D's large_pyramid) and
responder (``SoftStep(4)``, ``PGS()``), two worlds start equal, one on 1 thread and one on 2
(``World.threads``), settle, then take ``--repeats`` repeats of ``--steps`` steps, one world after the
other within each repeat: the ratio (1 thread / 2 threads) is taken within each repeat, the figures are
medians over the repeats. The script checks that both worlds end bit-identical.

Then, for SoftStep, the share of its one-thread step that threads split (Amdahl's p): the contact rows
(``contact_rows``), contact sweeps and warm starts of one step (not the per-point and per-body passes that
``pipeline.parallel.*_on`` split too: called from Python, each would add a call's overhead the tick does
not pay, so p and s are of the larger parts only), replayed on the settled world (as many
as ``soft_step_solve`` makes: 2 sweeps and 1 warm start per sub-step), timed against the whole step;
the same replay on 2 threads (``contact_rows_in_slices``, ``soft_sweep_in_groups``) gives those parts' own
speed-up s, and 1 / ((1 - p) + p / s) the step's best case. The machine should be quiet: threads wait for a busy core.
"""

from __future__ import annotations

import argparse
import datetime
import gc
import hashlib
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numba
import numpy as np

import phys2d
from phys2d.constraints.rows import contact_rows, unsigned_rows
from phys2d.pipeline import records
from phys2d.pipeline import stages as stage_kernels
from phys2d.pipeline.parallel import manifold_groups, soft_sweep_in_groups, using_threads, warm_start_in_groups
from phys2d.responders.block import inverse_diagonal
from phys2d.responders.soft_contacts import (
    prepare_manifolds,
    soft_constants,
    soft_friction_rows,
    soft_normal_rows,
    warm_start_manifolds,
)
from phys2d.responders.soft_points import prepare_points

# Compile in this process, before anything is timed: after an edit, phys2d by default steps
# stage by stage while a child process compiles the tick beside the timed steps (pipeline.ahead).
os.environ.setdefault("PHYS2D_COMPILE_AHEAD", "0")

REPO = Path(__file__).resolve().parent.parent
DT = 1 / 60
SCENES = {"pyramid_20": 20, "pyramid_40": 40, "pyramid_70": 70, "pyramid_100": 100}
RESPONDERS = {"SoftStep(4)": lambda: phys2d.SoftStep(4), "PGS": lambda: phys2d.PGS()}


def digest(w: phys2d.World) -> str:
    """sha256 of the world's state and the last step's impulses."""
    h = hashlib.sha256()
    for a in (w.x, w.theta, w.V, w.contacts.lambda_n, w.contacts.lambda_t):
        h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()


def per_step(w: phys2d.World, n: int) -> float:
    """µs per step of n steps of ``w``."""
    t0 = time.perf_counter_ns()
    for _ in range(n):
        w.step(DT)
    return (time.perf_counter_ns() - t0) / n / 1e3


def compare(scene: str, responder: str, args: argparse.Namespace) -> dict[str, Any]:
    """Time per step on 1 and 2 threads, ratios within each repeat."""
    worlds = []
    for threads in (1, 2):
        w = phys2d.scenes.pyramid(SCENES[scene], responder=RESPONDERS[responder]())
        w.threads = threads
        for _ in range(args.settle):
            w.step(DT)
        worlds.append(w)
    times: list[list[float]] = [[], []]
    gc.disable()
    try:
        for _ in range(args.repeats):
            for i, w in enumerate(worlds):
                times[i].append(per_step(w, args.steps))
    finally:
        gc.enable()
    ratios = [a / b for a, b in zip(*times, strict=True)]
    return {
        "scene": scene,
        "responder": responder,
        "contacts": len(worlds[0].contacts),
        "t1": statistics.median(times[0]),
        "t2": statistics.median(times[1]),
        "ratio": statistics.median(ratios),
        "same": digest(worlds[0]) == digest(worlds[1]),
    }


def replay_share(scene: str, args: argparse.Namespace) -> dict[str, Any]:
    """Amdahl's p for SoftStep(4): one step's contact rows, contact sweeps and warm starts replayed
    on a settled world, against the whole step; and those parts' speed-up on 2 threads."""
    soft = phys2d.SoftStep(4)
    w = phys2d.scenes.pyramid(SCENES[scene], responder=soft)
    for _ in range(args.settle):
        w.step(DT)
    w.one_call_tick = False  # the staged path hands the responder its context: keep it
    caught: list[Any] = []
    respond = soft.respond
    soft.respond = lambda ctx: (caught.append(ctx), respond(ctx))[1]  # type: ignore[method-assign]
    p = w._pipeline
    old_side, kc = p.side, p.cached  # the cache the step reads
    w.step(DT)
    w.one_call_tick = True
    (ctx,) = caught
    old = p.buffers.sides[old_side]
    cache = (old.key[:kc], old.cache_lambda_n[:kc], old.cache_lambda_t[:kc], old.cache_pushed[:kc])
    found, k = p.side_records[p.side], len(w.contacts)
    row_args = (p.bodies_record, p.shapes_record, cache, found, stage_kernels.rows_of(p.context(), k), p.settings.rows)
    soft = phys2d.SoftStep(4)  # (its respond was the spy's)
    # the world's contact buffers are two sides it swaps and refills each tick: the world that is
    # timed whole is a second one, so this one's buffers stay as the replayed step left them
    timed = phys2d.scenes.pyramid(SCENES[scene], responder=phys2d.SoftStep(4))
    for _ in range(args.settle + 1):
        timed.step(DT)
    rows = unsigned_rows(records.record_of_rows(ctx.rows))
    manifolds = prepare_manifolds(rows, ctx.M_inv, soft.block)
    inv_A_kk = inverse_diagonal(ctx.rows.A_kk)  # (the same arrays as the record)
    points = prepare_points((ctx.rows.order, ctx.separation, ctx.restitution), ctx.x.shape[0])
    h = DT / soft.substeps
    hertz = min(soft.contact_hertz, 0.25 / h)
    springs = tuple(soft_constants(f * hertz, soft.damping_ratio, h, soft.push_max) for f in (1.0, 2.0, 1.0))
    groups = manifold_groups(manifolds[0], rows, ctx.M_inv, ctx.part)  # (``groups_for``)
    V = ctx.V.copy()

    n = manifolds[0].shape[0] - 1

    def serial() -> None:
        contact_rows(*row_args, None)
        for _ in range(soft.substeps):
            warm_start_manifolds(0, n, manifolds[0], rows, ctx.M_inv, V)
            for bias in (True, False):  # the sweep with the push, then the relax sweep
                soft_normal_rows(0, n, rows, manifolds, inv_A_kk, points, ctx.M_inv, V, h, bias, springs, True)
                soft_friction_rows(0, n, rows, manifolds, inv_A_kk, points, ctx.M_inv, V, h)

    def parallel() -> None:
        with using_threads(2):
            contact_rows(*row_args, 2)
            for _ in range(soft.substeps):
                warm_start_in_groups(groups, manifolds, rows, ctx.M_inv, V)
                soft_sweep_in_groups(groups, rows, manifolds, inv_A_kk, points, ctx.M_inv, V, h, (True, True), springs)
                soft_sweep_in_groups(groups, rows, manifolds, inv_A_kk, points, ctx.M_inv, V, h, (False, True), springs)

    serial()
    parallel()  # compiled or loaded
    t_step, t_serial, t_parallel = [], [], []
    gc.disable()
    try:
        for _ in range(args.repeats):
            t_step.append(per_step(timed, args.steps))
            for times, run in ((t_serial, serial), (t_parallel, parallel)):
                t0 = time.perf_counter_ns()
                for _ in range(args.steps):
                    run()
                times.append((time.perf_counter_ns() - t0) / args.steps / 1e3)
    finally:
        gc.enable()
    p = statistics.median(a / b for a, b in zip(t_serial, t_step, strict=True))
    s = statistics.median(a / b for a, b in zip(t_serial, t_parallel, strict=True))
    return {
        "scene": scene,
        "manifolds": int(manifolds[0].shape[0] - 1),
        "groups": int(groups[1].shape[0] - 1),
        "step": statistics.median(t_step),
        "parts": statistics.median(t_serial),
        "parts_2": statistics.median(t_parallel),
        "p": p,
        "s": s,
        "best": 1.0 / ((1.0 - p) + p / 2.0),
        "expected": 1.0 / ((1.0 - p) + p / s),
    }


def git_rev() -> str:
    def git(*a: str) -> str:
        return subprocess.run(["git", "-C", str(REPO), *a], capture_output=True, text=True).stdout.strip()

    rev, dirty = git("rev-parse", "--short", "HEAD") or "?", git("status", "--porcelain")
    return rev + (" (uncommitted changes)" if dirty else "")


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scenes", nargs="+", choices=list(SCENES), help="default: pyramid_40 pyramid_70 pyramid_100")
    p.add_argument("--repeats", type=int, help="repeats (default 11, --quick 3)")
    p.add_argument("--steps", type=int, help="steps per repeat (default 20, --quick 5)")
    p.add_argument("--settle", type=int, help="steps before timing (default 120, --quick 20)")
    p.add_argument("--quick", action="store_true", help="a short run on pyramid_20, to see that it works")
    p.add_argument("--markdown", action="store_true", help="print markdown tables")
    args = p.parse_args(argv)
    args.scenes = args.scenes or (["pyramid_20"] if args.quick else ["pyramid_40", "pyramid_70", "pyramid_100"])
    args.repeats = args.repeats or (3 if args.quick else 11)
    args.steps = args.steps or (5 if args.quick else 20)
    args.settle = args.settle if args.settle is not None else (20 if args.quick else 120)
    load0, started = os.getloadavg()[0], datetime.datetime.now(datetime.timezone.utc)
    timed = [compare(scene, r, args) for scene in args.scenes for r in RESPONDERS]
    shares = [replay_share(scene, args) for scene in args.scenes]
    command = " ".join(["python benchmarks/threads.py", *(sys.argv[1:] if argv is None else argv)])
    print(
        f"{git_rev()}, {started:%Y-%m-%d %H:%M} UTC, load average {load0:.2f} -> {os.getloadavg()[0]:.2f} "
        f"({os.cpu_count()} cores, numba {numba.__version__}, threading layer {numba.threading_layer()})\n"
        f"`{command}`: {args.repeats} repeats of {args.steps} steps after {args.settle} settle steps; "
        "µs per step, medians over the repeats; ratios within each repeat.\n"
    )
    bar = "|" if args.markdown else ""
    head = ["scene", "responder", "contacts", "1 thread", "2 threads", "1 / 2", "same states"]
    print(bar + " | ".join(head) + bar)
    if args.markdown:
        print("|" + "---|" * len(head))
    for r in timed:
        cells = [r["scene"], r["responder"], str(r["contacts"]), f"{r['t1']:.0f}", f"{r['t2']:.0f}"]
        print(bar + " | ".join([*cells, f"{r['ratio']:.2f}x", "yes" if r["same"] else "NO"]) + bar)
    print()
    head = ["scene", "manifolds", "groups", "step", "split parts", "on 2 threads", "p", "s", "best 1/2", "expected 1/2"]
    print(bar + " | ".join(head) + bar)
    if args.markdown:
        print("|" + "---|" * len(head))
    for r in shares:
        cells = [r["scene"], str(r["manifolds"]), str(r["groups"]), f"{r['step']:.0f}", f"{r['parts']:.0f}"]
        cells += [
            f"{r['parts_2']:.0f}",
            f"{r['p']:.2f}",
            f"{r['s']:.2f}x",
            f"{r['best']:.2f}x",
            f"{r['expected']:.2f}x",
        ]
        print(bar + " | ".join(cells) + bar)
    return 0 if all(r["same"] for r in timed) else 1


if __name__ == "__main__":
    sys.exit(main())
