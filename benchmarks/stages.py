"""Where a phys2d step spends its time: the one-call step, the staged step, and its stages.

    python benchmarks/stages.py [--scenes S ...] [--repeats N] [--steps N] [--settle N]
    python benchmarks/stages.py --quick               # a short run: 3 repeats of 10 steps
    python benchmarks/stages.py --markdown > out.md   # the tables for STAGES.md

Per scene (``phys2d.scenes``, named as in benchmarks/engines.py) and responder (``PGS()``, ``SoftStep()``),
three worlds start equal and take the same steps (the script checks they end bit-identical):

- **one-call**: ``World.step`` as users run it: ``Pipeline`` (phys2d/pipeline/step.py) runs the tick in
  one compiled call (``pipeline.tick.tick``);
- **staged**: ``one_call_tick = False``: ``Pipeline._in_stages`` calls ``before_solve``, the responder's
  ``respond`` and ``after_solve`` from Python;
- **timed staged**: staged, with ``before_solve`` and ``after_solve`` replaced by ``timed_before_solve`` and
  ``timed_after_solve`` below, which call their stage kernels (``begin``, ``pairs``, ``collide``, ``rows``;
  ``limits``, ``cache``) one by one from Python in the order the two kernels do, and with the ``Pipeline``
  methods around them (``_room``, ``context``, ``_step_context``, ``_commit``) and the responder class's
  ``respond`` replaced by timing wrappers while it steps. A step that stops for room takes the kernel
  itself (timed as one). Each stage: its calls' time less the timer's own (a timed empty call); the step:
  its time less what the wrappers add (calibrated on an empty function); the Python between the stages:
  the rest.
- **pymunk** on the same scene (``engines.PymunkAdapter``) when engines.py has it; ratios are taken
  within each repeat.

A warm-up world per responder first (the numba cache loaded, or compiled), ``--settle`` steps of every
world, then ``--repeats`` repeats of ``--steps`` steps, the worlds one after another; medians over
repeats, µs per step, garbage collector off while timing."""

from __future__ import annotations

import argparse
import datetime
import gc
import os
import statistics
import subprocess
import sys
import time
from collections import defaultdict
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from importlib.util import find_spec
from pathlib import Path
from typing import Any

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))  # the phys2d of this checkout

import engines  # noqa: E402  (benchmarks/engines.py, next to this script)

import phys2d  # noqa: E402
import phys2d.pipeline.stages as stage_kernels  # noqa: E402
import phys2d.pipeline.step as step_module  # noqa: E402
from phys2d.pipeline.step import Pipeline  # noqa: E402

DT = engines.DT
SCENES: dict[str, Callable[[phys2d.Responder], phys2d.World]] = {
    "pyramid_20": lambda r: phys2d.scenes.pyramid(20, responder=r),
    "pyramid_40": lambda r: phys2d.scenes.pyramid(40, responder=r),
    "pyramid_100": lambda r: phys2d.scenes.pyramid(100, responder=r),
    "vertical_stack_10": lambda r: phys2d.scenes.vertical_stack(10, responder=r),
    "mixed_shapes": lambda r: phys2d.scenes.mixed_shapes(12, responder=r),
    "many_pyramids": lambda r: phys2d.scenes.many_pyramids(responder=r),
}
RESPONDERS: dict[str, Callable[[], phys2d.Responder]] = {"PGS": phys2d.PGS, "SoftStep": phys2d.SoftStep}
# the stages in the order a staged step calls them: (owner, name); "respond" is the responder's
STAGES: list[tuple[Any, str]] = [
    (Pipeline, "_room"), (Pipeline, "context"), (stage_kernels, "first_bad_body"), (stage_kernels, "begin"),
    (stage_kernels, "pairs"), (stage_kernels, "in_visit_order"), (stage_kernels, "collide"), (stage_kernels, "rows"),
    (stage_kernels, "before_solve"), (Pipeline, "_step_context"), (None, "respond"),
    (step_module, "bounce_after_moving"), (stage_kernels, "limits"), (stage_kernels, "cache"), (Pipeline, "_commit"),
]  # fmt: skip
LABELS = [("Pipeline." if owner is Pipeline else "") + name for owner, name in STAGES]


def timed_before_solve(ctx: Any, settings: Any, counts: Any) -> Any:
    """``stages.before_solve``'s stages called one by one from Python (each a kernel, looked up in
    ``stages`` so that the clock's wrappers time them); a step that must stop for room, or that
    resumes, goes to the kernel itself."""
    s = stage_kernels
    if counts.resume != s.START or s.first_bad_body(ctx) >= 0:
        return s.before_solve(ctx, settings, counts)
    fits = s.begin(ctx, settings)
    n_pairs, ordered = counts.n_pairs, counts.ordered
    if counts.sweep_again or not fits:
        n_pairs, ordered = s.pairs(ctx, counts.visit)
    room = 0 <= n_pairs <= ctx.shapes.pair_order.shape[0] and s.store_has_room(ctx, counts, n_pairs)
    if not room:  # the kernel stops for it, and Python resumes after making room
        return s.before_solve(ctx, settings, counts._replace(resume=s.SWEEP if n_pairs < 0 else s.COLLIDE))
    if ordered != counts.visit:
        ordered = s.in_visit_order(ctx, n_pairs, counts.visit)
    k, n_new, recycled, rows_used, points_used = s.collide(ctx, settings, counts, n_pairs)
    deepest, hits = s.rows(ctx, settings, counts, k)
    side = 1 - counts.side
    return s.TickResult(s.OK, side, n_pairs, ordered, k, n_new, recycled, rows_used, points_used, hits, deepest, 0)


def timed_after_solve(ctx: Any, settings: Any, before: Any, count: int) -> Any:
    """``stages.after_solve``'s stages called one by one from Python."""
    s = stage_kernels
    status = s.limits(ctx, settings, before.contacts, count)
    if status == s.OK:
        s.cache(ctx, before)
    return before._replace(status=status, solved=count)


class Clock:
    """Time per label of the wrapped calls, outermost calls only."""

    def __init__(self) -> None:
        self.ns, self.calls, self.busy = defaultdict[str, int](int), defaultdict[str, int](int), False

    def wrap(self, label: str, fn: Callable) -> Callable:
        def timed(*args: Any, **kwargs: Any) -> Any:
            if self.busy:  # inside another timed call: counted there
                return fn(*args, **kwargs)
            self.busy = True
            t0 = time.perf_counter_ns()
            try:
                return fn(*args, **kwargs)
            finally:
                self.ns[label] += time.perf_counter_ns() - t0
                self.calls[label] += 1
                self.busy = False

        return timed


@contextmanager
def timed_stages(clock: Clock, responder_class: type) -> Iterator[None]:
    """The stages' names replaced by ``clock``'s wrappers while inside (and the staged step's two
    kernels by their stages one by one), put back after."""
    owners = [responder_class if owner is None else owner for owner, _ in STAGES]
    saved = [(owner, name, vars(owner)[name]) for owner, (_, name) in zip(owners, STAGES)]
    saved += [(step_module, "before_solve", step_module.before_solve)]
    saved += [(step_module, "after_solve", step_module.after_solve)]
    for (owner, name, original), label in zip(saved, LABELS):
        setattr(owner, name, clock.wrap(label, original))
    step_module.before_solve, step_module.after_solve = timed_before_solve, timed_after_solve  # type: ignore[assignment]
    try:
        yield
    finally:
        for owner, name, original in saved:
            setattr(owner, name, original)


def timer_costs(calls: int = 200_000) -> tuple[float, float]:
    """(ns) What a timed empty call measures (off each timed call), and what a wrapper adds (off the step)."""
    clock, noop = Clock(), lambda *a: None
    timed = clock.wrap("noop", noop)
    t0 = time.perf_counter_ns()
    for _ in range(calls):
        noop(1, 2)
    t1 = time.perf_counter_ns()
    for _ in range(calls):
        timed(1, 2)
    return clock.ns["noop"] / calls, (time.perf_counter_ns() - 2 * t1 + t0) / calls


def run(steps: Callable[[], None], n: int) -> float:
    """µs per step of n calls of ``steps``."""
    t0 = time.perf_counter_ns()
    for _ in range(n):
        steps()
    return (time.perf_counter_ns() - t0) / n / 1e3


def warm_up() -> None:
    """Load (or compile) the kernels of both paths: a small world per responder and path."""
    for make in RESPONDERS.values():
        for one_call in (True, False):
            w = phys2d.scenes.mixed_shapes(12, responder=make())  # its sweeps and store rebuilds too
            w.one_call_tick = one_call
            for _ in range(150):
                w.step(DT)


def profile(scene: str, responder: str, args: argparse.Namespace, costs: tuple[float, float]) -> dict[str, Any]:
    """Medians (µs per step) of the one-call, staged and pymunk steps, of each stage, and the ratios."""
    one_call, staged, timed = (SCENES[scene](RESPONDERS[responder]()) for _ in range(3))
    staged.one_call_tick = timed.one_call_tick = False
    steppers = {"one-call": lambda: one_call.step(DT), "staged": lambda: staged.step(DT)}
    if scene in engines.SCENES and find_spec("pymunk") is not None:  # pymunk on the same scene
        steppers["pymunk"] = engines.PymunkAdapter(engines.SCENES[scene]()).step
    for _ in range(args.settle):
        for f in [*steppers.values(), lambda: timed.step(DT)]:
            f()
    times: dict[str, list[float]] = defaultdict(list)
    for _ in range(args.repeats):
        gc.collect()
        gc.disable()
        clock = Clock()
        now = {name: run(f, args.steps) for name, f in steppers.items()}
        with timed_stages(clock, type(timed._responder)):
            now["timed"] = run(lambda: timed.step(DT), args.steps)
        gc.enable()
        per_step = 1e3 * args.steps  # ns in all the steps -> µs per step
        for label in LABELS:
            n = clock.calls.get(label, 0)
            now[label] = (clock.ns[label] - n * costs[0]) / per_step if n else float("nan")
        now["timed"] -= sum(clock.calls.values()) * costs[1] / per_step  # less what the wrappers add
        now["Python between stages"] = now["timed"] - sum(now[x] for x in LABELS if now[x] == now[x])
        pairs = (("one-call", "staged"), ("one-call", "pymunk"), ("staged", "pymunk"))
        now.update({f"{a} / {b}": now[a] / now[b] for a, b in pairs if b in now})
        for name, value in now.items():
            times[name].append(value)
    same = all(np.array_equal(one_call.x, w.x) and np.array_equal(one_call.theta, w.theta) for w in (staged, timed))
    result: dict[str, Any] = {k: statistics.median(v) for k, v in times.items()}
    result["parts"] = sum(result[k] for k in [*LABELS, "Python between stages"] if result[k] == result[k])
    return {**result, "contacts": len(one_call.contacts), "same": same, "responder": responder}


def fmt(r: dict[str, Any], key: str) -> str:
    v = r.get(key, float("nan"))
    return "-" if v != v else str(v) if isinstance(v, int) else f"{v:.2f}x" if " / " in key else f"{v:.1f}"


SUMMARY = ["contacts", "one-call", "staged", "pymunk", "one-call / pymunk", "staged / pymunk", "one-call / staged"]
ROWS = {**{x: f"`{x}`" for x in LABELS}, "Python between stages": "Python between the stages"}
ROWS.update(parts="**the parts' sum** (of the medians above)", timed="staged step (timed world, less the wrappers)")
ROWS["staged"] = "staged step (untimed world)"


def markdown(results: dict[str, list[dict]], head: str) -> str:
    """The summary table, then a table of the stages per scene."""
    lines = [head, "", "| scene | responder | " + " | ".join(SUMMARY) + " | same states |", "|---" * 10 + "|"]
    for scene, per in results.items():
        for r in per:
            cells = [*(fmt(r, k) for k in SUMMARY), "yes" if r["same"] else "NO"]
            lines.append(f"| {scene} | {r['responder']} | " + " | ".join(cells) + " |")
    for scene, per in results.items():
        lines += ["", f"### {scene}: the staged step by stage (µs per step; share of the parts' sum)", ""]
        lines += ["| stage | " + " | ".join(r["responder"] for r in per) + " |", "|---" * (1 + len(per)) + "|"]
        for key, name in ROWS.items():
            cells = [fmt(r, key) + (f" ({100 * r[key] / r['parts']:.0f}%)" if r[key] == r[key] else "") for r in per]
            lines.append(f"| {name} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def text(scene: str, r: dict[str, Any]) -> str:
    """One scene and responder's figures on two lines."""
    head, stages = (", ".join(f"{k} {fmt(r, k)}" for k in keys if fmt(r, k) != "-") for keys in (SUMMARY, ROWS))
    return f"{scene} {r['responder']} (same states: {r['same']}): {head}\n  {stages}"


def git_rev() -> str:
    def git(*a: str) -> str:
        return subprocess.run(["git", "-C", str(REPO), *a], capture_output=True, text=True).stdout.strip()

    rev, dirty = git("rev-parse", "--short", "HEAD") or "?", git("status", "--porcelain")
    return rev + (" (uncommitted changes)" if dirty else "")


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scenes", nargs="+", choices=list(SCENES), default=list(SCENES))
    p.add_argument("--repeats", type=int, help="repeats (default 15, --quick 3)")
    p.add_argument("--steps", type=int, help="steps per repeat (default 40, --quick 10)")
    p.add_argument("--settle", type=int, help="steps before timing (default 180, --quick 30)")
    p.add_argument("--quick", action="store_true", help="a short run, to see that it works")
    p.add_argument("--markdown", action="store_true", help="print the tables for STAGES.md")
    args = p.parse_args(argv)
    args.repeats = args.repeats or (3 if args.quick else 15)
    args.steps = args.steps or (10 if args.quick else 40)
    args.settle = args.settle if args.settle is not None else (30 if args.quick else 180)
    load0, started = os.getloadavg()[0], datetime.datetime.now(datetime.timezone.utc)
    warm_up()
    costs = timer_costs()
    results: dict[str, list[dict]] = {}
    for scene in args.scenes:
        results[scene] = [profile(scene, r, args, costs) for r in RESPONDERS]
        print("\n".join(text(scene, r) for r in results[scene]), file=sys.stderr if args.markdown else sys.stdout)
    command = " ".join(["python benchmarks/stages.py", *(sys.argv[1:] if argv is None else argv)])
    head = (
        f"## Preliminary: {git_rev()}, {started:%Y-%m-%d %H:%M} UTC, load average {load0:.2f} -> "
        f"{os.getloadavg()[0]:.2f} ({os.cpu_count()} cores)\n\n`{command}`: {args.repeats} repeats of {args.steps} "
        f"steps after {args.settle} settle steps; µs per step, each figure its own median over the repeats (the parts "
        f"need not add up). Timer: {costs[0]:.0f} ns taken off each timed call, {costs[1]:.0f} ns (a wrapper's cost) "
        "off the timed step per call. Preliminary: a shared, loaded machine; the ratios, taken within each repeat, "
        "carry over better than the times."
    )
    print(markdown(results, head) if args.markdown else head.replace("## ", "").replace("`", ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())
