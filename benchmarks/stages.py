"""Where a phys2d step spends its time, stage by stage (issue 11, item 2).

    PYTHONPATH=. python benchmarks/stages.py            # writes benchmarks/STAGES.md
    PYTHONPATH=. python benchmarks/stages.py --quick    # smoke run, prints only

The engine is not edited. ``World.step`` calls its stage functions by their names
in ``phys2d.world`` (and a few methods of phys2d's classes); this script wraps
those names with a timer while one world steps, and leaves them alone while its
twin steps. The twins start equal and phys2d is deterministic, so both go
through the same states; within each repeat the plain twin is timed first, then
the wrapped one.

- **stage times** (µs per step): the sum of the wrapped calls of each stage, less
  the timer's own cost per call (two ``perf_counter_ns`` calls back to back);
- **step**: the wrapped twin's time per step less what the wrappers add (the
  extra wall time per call of a wrapped empty function, times the calls), so
  the stages and the step come from the same steps; the plain twin's time per
  step is shown beside it as a check;
- **Python left over** = step minus the stages: the Python of ``World.step``
  between the stage calls (argument checks, the state snapshot, array
  allocation, the step report, ...);
- **numba dispatch** (an estimate): each numba kernel called from Python costs a
  dispatch (typing its arguments, finding the compiled version) before any work.
  The script records the arguments of every kernel call of one step and times an
  empty numba function called with the same arguments; the sum is the dispatch
  cost per step, which is inside the stage times;
- **fixed cost per step** = Python left over + numba dispatch on the small scene:
  what a step costs whatever the scene's size. As a check, the step time of a
  one-box scene, timed in the same repeats. On large scenes the Python left over
  also holds numpy work that grows with the contacts (arrays allocated per pair,
  the contact arrays sliced and handed on each step), so there it is not a fixed cost.

All figures are medians over repeats. Stages:

| stage | what is timed |
| --- | --- |
| external forces | `apply_external_forces` |
| broadphase | `update_geometry_in` (and the fat-box check); if a body left its box `sweep_and_prune`, `colour_pairs` |
| narrowphase | `ManifoldCache.collide` (contact recycling, and the narrowphase for the pairs not recycled) |
| cache matching | `ContactCache.store_rows` (and `ContactCache.warm_start` where it exists; else in `contact_rows`) |
| rows | `RowBuffer.take`, `solve_order`, `World._context` (contacts in row order), `contact_rows`, `joint_rows` |
| solve | the responder's `respond` (SoftStep's moves the positions too: its sub-steps integrate) |
| integrate | `integrate_positions` (not called for SoftStep), `first_too_fast` (the speed limit check) |
"""

from __future__ import annotations

import argparse
import datetime as dt
import gc
import os
import platform
import statistics
import subprocess
import sys
import time
from collections import defaultdict
from collections.abc import Callable
from pathlib import Path

import numpy as np

BENCH_DIR = Path(__file__).resolve().parent
REPO_ROOT = BENCH_DIR.parent
if str(REPO_ROOT) not in sys.path:  # profile the phys2d of this checkout
    sys.path.insert(0, str(REPO_ROOT))

import phys2d  # noqa: E402
import phys2d.world as world_module  # noqa: E402
from phys2d.collision.recycle import ManifoldCache  # noqa: E402
from phys2d.constraints.rows import RowBuffer  # noqa: E402
from phys2d.contacts import ContactCache  # noqa: E402

DT = 1.0 / 60.0

# stage -> names in phys2d.world that World.step calls
FUNCTION_STAGES = {
    "external forces": ("apply_external_forces",),
    "broadphase": ("update_geometry_in", "sweep_and_prune", "colour_pairs"),
    "narrowphase": ("collide_pairs",),  # (an older world's; now ManifoldCache.collide below)
    "rows": ("solve_order", "contact_rows", "joint_rows"),
    "integrate": ("integrate_positions", "first_too_fast"),
}
# stage -> (class, method name) that World.step calls on its objects
METHOD_STAGES = {
    "narrowphase": ((ManifoldCache, "collide"),),
    "cache matching": ((ContactCache, "warm_start"), (ContactCache, "store_rows")),
    "rows": ((RowBuffer, "take"), (world_module.World, "_context")),
}
STAGE_ORDER = ("external forces", "broadphase", "narrowphase", "cache matching", "rows", "solve", "integrate")

SCENES: dict[str, Callable[..., phys2d.World]] = {
    "vertical_stack_10": lambda responder: phys2d.scenes.vertical_stack(10, responder=responder),
    "pyramid_20": lambda responder: phys2d.scenes.pyramid(20, responder=responder),
    "pyramid_40": lambda responder: phys2d.scenes.pyramid(40, responder=responder),
}
RESPONDERS: dict[str, Callable[[], phys2d.Responder]] = {
    "PGS": lambda: phys2d.PGS(iterations=10, warm_start=True),  # as in peers.py
    "SoftStep(4)": lambda: phys2d.SoftStep(substeps=4),
}


def timer_cost_ns(samples: int = 200_000) -> float:
    """What the wrapper's two perf_counter_ns calls add to every timed call (ns)."""
    pc = time.perf_counter_ns
    costs = []
    for _ in range(samples):
        t0 = pc()
        t1 = pc()
        costs.append(t1 - t0)
    return float(np.median(costs))


def make_timed(original, label: str, ns: dict[str, int], calls: dict[str, int]):
    """``original`` wrapped so that each call adds its time (ns) to ns[label] and 1 to calls[label]."""
    pc = time.perf_counter_ns

    def timed(*args, **kwargs):
        t0 = pc()
        out = original(*args, **kwargs)
        ns[label] += pc() - t0
        calls[label] += 1
        return out

    return timed


class Probe:
    """Wraps the stage functions with timers while ``on``; collects ns and calls per name."""

    def __init__(self, responder_cls: type) -> None:
        self.ns: dict[str, int] = defaultdict(int)
        self.calls: dict[str, int] = defaultdict(int)
        self.stage_of: dict[str, str] = {}
        self._patches: list[tuple[object, str, object, object]] = []  # (owner, name, original, wrapped)
        for stage, names in FUNCTION_STAGES.items():
            for name in names:
                if hasattr(world_module, name):
                    self._add(world_module, name, name, stage)
        for stage, methods in METHOD_STAGES.items():
            for cls, name in methods:
                if hasattr(cls, name):
                    self._add(cls, name, f"{cls.__name__}.{name}", stage)
        self._add(responder_cls, "respond", f"{responder_cls.__name__}.respond", "solve")

    def _add(self, owner, name: str, label: str, stage: str) -> None:
        original = getattr(owner, name)
        self.stage_of[label] = stage
        self._patches.append((owner, name, original, make_timed(original, label, self.ns, self.calls)))

    def on(self) -> None:
        for owner, name, _, wrapped in self._patches:
            setattr(owner, name, wrapped)

    def off(self) -> None:
        for owner, name, original, _ in self._patches:
            setattr(owner, name, original)

    def reset(self) -> None:
        self.ns.clear()
        self.calls.clear()


# -- numba dispatch ------------------------------------------------------------------------------


def _sink_factory():
    from numba import njit

    @njit
    def sink(*args):
        return 0

    return sink


def kernel_calls_of_one_step(w: phys2d.World) -> list[tuple[str, tuple]]:
    """(name, args) of every numba kernel called from Python during one step of w.

    Every numba dispatcher bound to a name in a phys2d module is wrapped for one step
    (all kernels are compiled by then, so no kernel is compiled against the wrapper).
    """
    from numba.core.registry import CPUDispatcher

    seen: list[tuple[str, tuple]] = []
    patches = []
    for mod_name, mod in list(sys.modules.items()):
        if not (mod_name == "phys2d" or mod_name.startswith("phys2d.")) or mod is None:
            continue
        for name, obj in list(vars(mod).items()):
            if isinstance(obj, CPUDispatcher):

                def recorder(*args, _f=obj, _name=name):
                    seen.append((_name, args))
                    return _f(*args)

                patches.append((mod, name, obj))
                setattr(mod, name, recorder)
    try:
        w.step(DT)
    finally:
        for mod, name, obj in patches:
            setattr(mod, name, obj)
    return seen


def dispatch_cost_us(calls: list[tuple[str, tuple]], sink, repeats: int = 7, loops: int = 2000) -> float:
    """Median over repeats of the time (µs) to dispatch ``calls`` once each into an empty kernel."""
    copies = [tuple(a.copy() if isinstance(a, np.ndarray) else a for a in args) for _, args in calls]
    for args in copies:  # compile the sink for each argument signature first
        sink(*args)
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter_ns()
        for _ in range(loops):
            for args in copies:
                sink(*args)
        times.append((time.perf_counter_ns() - t0) / loops / 1e3)
    return statistics.median(times)


# -- measuring -----------------------------------------------------------------------------------


def pymunk_twin(scene: str):
    """The same scene in pymunk (benchmarks/engines.py), as a yardstick timed in the same
    repeats; None if pymunk is not installed."""
    try:
        import engines  # benchmarks/engines.py, next to this script
        import pymunk  # noqa: F401
    except ImportError:
        return None
    return engines.PymunkAdapter(engines.SCENES[scene]())


def calibrate(pc_ns: float, samples: int = 100_000, repeats: int = 7) -> float:
    """The wall time (ns) a timing wrapper adds to one call, beyond the call itself.

    Used to take the wrappers' cost out of the wrapped twin's step time, so that the
    stages and the Python left over come from the same timed steps.
    """

    def noop(*args):
        return None

    ns: dict[str, int] = defaultdict(int)
    calls: dict[str, int] = defaultdict(int)
    timed = make_timed(noop, "noop", ns, calls)
    added = []
    for _ in range(repeats):
        t0 = time.perf_counter_ns()
        for _ in range(samples):
            noop(1.0, 2)
        direct = time.perf_counter_ns() - t0
        t0 = time.perf_counter_ns()
        for _ in range(samples):
            timed(1.0, 2)
        added.append((time.perf_counter_ns() - t0 - direct) / samples)
    return statistics.median(added)


def timed_loop(step, n: int) -> float:
    """µs per call of ``n`` calls of step()."""
    t0 = time.perf_counter_ns()
    for _ in range(n):
        step()
    return (time.perf_counter_ns() - t0) / n / 1e3


def profile(scene: str, responder: str, args, pc_ns: float, added_ns: float, sink) -> dict:
    """Stage times of one scene and responder; see the module docstring."""
    make = SCENES[scene]
    plain = make(RESPONDERS[responder]())
    wrapped = make(RESPONDERS[responder]())
    one_box = phys2d.scenes.vertical_stack(1, responder=RESPONDERS[responder]())
    peer = pymunk_twin(scene)
    for _ in range(args.warmup):
        plain.step(DT)
        wrapped.step(DT)
        one_box.step(DT)
        if peer is not None:
            peer.step()
    probe = Probe(type(wrapped.responder))
    plain_us: list[float] = []
    step_us: list[float] = []  # the wrapped twin's step less what the wrappers added
    left_us: list[float] = []
    box_us: list[float] = []
    ratios: list[float] = []
    per_label: dict[str, list[float]] = defaultdict(list)
    calls_per_step: dict[str, float] = {}
    for _ in range(args.repeats):
        gc.collect()
        gc.disable()
        try:
            plain_us.append(timed_loop(lambda: plain.step(DT), args.steps))
            if peer is not None:
                ratios.append(plain_us[-1] / timed_loop(peer.step, args.steps))
            box_us.append(timed_loop(lambda: one_box.step(DT), args.steps))
            probe.reset()
            probe.on()
            try:
                wrapped_us = timed_loop(lambda: wrapped.step(DT), args.steps)
            finally:
                probe.off()
        finally:
            gc.enable()
        n_calls = sum(probe.calls.values())
        stages_us = 0.0
        for label in probe.stage_of:
            n = probe.calls.get(label, 0)
            us = (probe.ns.get(label, 0) - n * pc_ns) / args.steps / 1e3
            per_label[label].append(us)
            stages_us += us
            calls_per_step[label] = n / args.steps
        step = wrapped_us - n_calls * added_ns / args.steps / 1e3
        step_us.append(step)
        left_us.append(step - stages_us)
    if not np.array_equal(plain.x, wrapped.x):
        raise RuntimeError(f"{scene}/{responder}: the twins diverged, so the stage times are not comparable")
    label_us = {label: statistics.median(v) for label, v in per_label.items()}
    stage_us = {s: 0.0 for s in STAGE_ORDER}
    for label, us in label_us.items():
        stage_us[probe.stage_of[label]] += us
    kernels = kernel_calls_of_one_step(plain)
    dispatch = dispatch_cost_us(kernels, sink) if sink is not None and kernels else float("nan")
    return {
        "total": statistics.median(step_us),
        "plain": statistics.median(plain_us),
        "one_box": statistics.median(box_us),
        "stages": stage_us,
        "left_over": statistics.median(left_us),
        "labels": label_us,
        "calls": calls_per_step,
        "stage_of": dict(probe.stage_of),
        "kernel_calls": len(kernels),
        "kernel_names": sorted({name for name, _ in kernels}),
        "dispatch": dispatch,
        "contacts": len(plain.contacts),
        "ratio": statistics.median(ratios) if ratios else float("nan"),
    }


# -- reporting -----------------------------------------------------------------------------------


def git_rev() -> str:
    try:
        rev = subprocess.run(
            ["git", "-C", str(REPO_ROOT), "rev-parse", "--short", "HEAD"], capture_output=True, text=True, check=True
        ).stdout.strip()
        dirty = subprocess.run(
            ["git", "-C", str(REPO_ROOT), "status", "--porcelain"], capture_output=True, text=True, check=True
        ).stdout.strip()
        return rev + (" (uncommitted changes)" if dirty else "")
    except (OSError, subprocess.CalledProcessError):
        return "?"


def cpu() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "?"


def table(header: list[str], rows: list[list[str]]) -> list[str]:
    return ["| " + " | ".join(header) + " |", "| " + " | ".join("---" for _ in header) + " |"] + [
        "| " + " | ".join(r) + " |" for r in rows
    ]


def pct(part: float, whole: float) -> str:
    return f"{100 * part / whole:.0f}%" if whole > 0 else "-"


def load_average() -> str:
    try:
        return f"{os.getloadavg()[0]:.2f}"
    except (AttributeError, OSError):
        return "?"


def report(results: dict, args, pc_ns: float, added_ns: float, command: str, load: tuple[str, str]) -> str:
    import numba

    L = [
        "# Time per step by stage (issue 11)",
        "",
        f"- command: `{command}`",
        f"- date: {dt.datetime.now(dt.timezone.utc).strftime('%Y-%m-%d %H:%M UTC')}",
        f"- checkout: {git_rev()}",
        f"- machine: {cpu()}, {os.cpu_count()} cores, {platform.platform()}",
        f"- load average (1 min) at the start and the end of the run: {load[0]} and {load[1]} (other work on "
        "the machine inflates the times; the shares and ratios suffer less)",
        f"- versions: python {platform.python_version()}, numpy {np.__version__}, numba {numba.__version__}",
        f"- method: {args.warmup} warm-up steps, then {args.repeats} repeats of {args.steps} steps; in each "
        "repeat the plain world, pymunk on the same scene, a one-box scene, then the twin with its stage "
        "functions wrapped; medians over repeats. The timer's own cost "
        f"({pc_ns:.0f} ns) is taken off each wrapped call, and the wall time a wrapper adds to a call "
        f"({added_ns:.0f} ns) off the wrapped twin's step, so the stages and the Python left over come from "
        "the same steps. Method and stage list: the docstring of `benchmarks/stages.py`.",
        "- responders: `PGS(iterations=10, warm_start=True)` (as in peers.py) and `SoftStep(substeps=4)`",
        "",
        "Times in µs per step; in brackets the share of the step. The ratio to pymunk "
        "(benchmarks/engines.py's pymunk adapter on the same scene, in the same repeats) carries over between "
        "machines better than the times do.",
    ]
    for scene, per in results.items():
        names = list(per)
        L += ["", f"## {scene} ({per[names[0]]['contacts']} contact points at the end)", ""]
        rows = []
        for s in STAGE_ORDER:
            rows.append(
                [s] + [f"{per[r]['stages'][s]:.1f} ({pct(per[r]['stages'][s], per[r]['total'])})" for r in names]
            )
        rows.append(
            ["Python left over"]
            + [f"{per[r]['left_over']:.1f} ({pct(per[r]['left_over'], per[r]['total'])})" for r in names]
        )
        rows.append(["**step** (wrapped twin, less the wrappers)"] + [f"**{per[r]['total']:.1f}**" for r in names])
        rows.append(["step of the plain twin (a check)"] + [f"{per[r]['plain']:.1f}" for r in names])
        rows.append(["plain step / pymunk's step"] + [f"{per[r]['ratio']:.2f}x" for r in names])
        rows.append(["numba kernels called from Python per step"] + [str(per[r]["kernel_calls"]) for r in names])
        rows.append(
            ["numba dispatch, estimated (inside the stages above)"]
            + [f"{per[r]['dispatch']:.1f} ({pct(per[r]['dispatch'], per[r]['total'])})" for r in names]
        )
        rows.append(
            ["**Python left over + dispatch** (the fixed cost, on a small scene)"]
            + [
                f"**{per[r]['left_over'] + per[r]['dispatch']:.1f}** "
                f"({pct(per[r]['left_over'] + per[r]['dispatch'], per[r]['total'])})"
                for r in names
            ]
        )
        rows.append(["one-box scene's step, same repeats"] + [f"{per[r]['one_box']:.1f}" for r in names])
        L += table(["stage", *names], rows)
        labels = list(per[names[0]]["labels"])
        for r in names[1:]:
            labels += [x for x in per[r]["labels"] if x not in labels]
        rows = []
        for label in labels:
            cells = []
            for r in names:
                if label in per[r]["labels"] and per[r]["calls"].get(label, 0) > 0:
                    cells.append(f"{per[r]['labels'][label]:.2f} ({per[r]['calls'][label]:.2g}/step)")
                else:
                    cells.append("-")
            stage = next(per[r]["stage_of"][label] for r in names if label in per[r]["stage_of"])
            rows.append([f"`{label}`", stage] + cells)
        L += ["", "<details><summary>by function (µs per step; calls per step in brackets)</summary>", ""]
        L += table(["function", "stage", *names], rows)
        L += ["", "</details>"]
    L += ["", "## Reading", "", *reading(results), ""]
    return "\n".join(L)


def reading(results: dict) -> list[str]:
    """Which stages dominate, and the fixed cost, in words (from the figures above)."""
    out = []
    for scene, per in results.items():
        parts = []
        for r, res in per.items():
            ranked = sorted(res["stages"].items(), key=lambda kv: -kv[1])
            top = ", ".join(f"{s} {pct(us, res['total'])}" for s, us in ranked[:3])
            parts.append(f"{r}: {top}; Python left over {pct(res['left_over'], res['total'])}")
        out.append(f"- **{scene}**: " + "; ".join(parts) + ".")
    small = next(iter(results))
    for r, res in results[small].items():
        fixed = res["left_over"] + res["dispatch"]
        out.append(
            f"- Fixed cost per step on {small}, {r}: {fixed:.0f} µs of {res['total']:.0f} µs "
            f"({pct(fixed, res['total'])}): Python left over {res['left_over']:.0f} µs and numba dispatch "
            f"about {res['dispatch']:.0f} µs over {res['kernel_calls']} kernel calls. A one-box scene steps "
            f"in {res['one_box']:.0f} µs; the whole step is {res['ratio']:.1f}x pymunk's."
        )
    return out


def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scenes", nargs="+", choices=list(SCENES), default=list(SCENES))
    p.add_argument("--responders", nargs="+", choices=list(RESPONDERS), default=list(RESPONDERS))
    p.add_argument("--repeats", type=int, default=None, help="repeats (default 7, quick 2)")
    p.add_argument("--steps", type=int, default=None, help="steps per repeat (default 200, quick 10)")
    p.add_argument("--warmup", type=int, default=60, help="warm-up steps (default 60)")
    p.add_argument("--quick", action="store_true", help="smoke run: prints, writes nothing")
    p.add_argument("--out", type=Path, default=BENCH_DIR / "STAGES.md")
    args = p.parse_args(argv)
    if args.repeats is None:
        args.repeats = 2 if args.quick else 7
    if args.steps is None:
        args.steps = 10 if args.quick else 200
    if args.repeats < 1 or args.steps < 1 or args.warmup < 0:
        p.error("--repeats and --steps must be >= 1, --warmup >= 0")
    return args


def main(argv=None) -> int:
    args = parse_args(argv)
    command = "python " + " ".join([os.path.relpath(sys.argv[0])] + sys.argv[1:])
    load_start = load_average()
    pc_ns = timer_cost_ns()
    try:
        sink = _sink_factory()
    except Exception as exc:  # noqa: BLE001  (no estimate rather than no profile)
        print(f"numba dispatch estimate unavailable: {exc}")
        sink = None
    added_ns = calibrate(pc_ns)
    results: dict[str, dict] = {}
    for scene in args.scenes:
        results[scene] = {}
        for r in args.responders:
            res = profile(scene, r, args, pc_ns, added_ns, sink)
            results[scene][r] = res
            stages = ", ".join(f"{s} {us:.1f}" for s, us in res["stages"].items())
            print(
                f"{scene} {r}: step {res['total']:.1f} us (plain {res['plain']:.1f}) = {stages}, Python left "
                f"over {res['left_over']:.1f}; dispatch {res['dispatch']:.1f} us over {res['kernel_calls']} kernel "
                f"calls; one box {res['one_box']:.1f} us",
                flush=True,
            )
    text = report(results, args, pc_ns, added_ns, command, (load_start, load_average()))
    if args.quick:
        print(text)
    else:
        args.out.write_text(text)
        print(f"written to {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
