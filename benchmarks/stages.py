"""Where a phys2d step spends its time (issue 11, item 2): the one-call step, and the staged
step stage by stage.

    PYTHONPATH=. python benchmarks/stages.py            # writes benchmarks/STAGES.md
    PYTHONPATH=. python benchmarks/stages.py --quick    # smoke run, prints only

``World.step`` runs a PGS (impulse form) or SoftStep world's tick in one numba kernel call
(``phys2d.tick``): the **one-call step**, what users run. With ``World.one_call_tick = False``
it runs the **staged step** (``World._step_in_stages``): the same stages, one kernel call
each, with Python in between, bit-identical. The staged step shows where a step's work goes,
stage by stage; the one-call step how much of it is left outside numba.

The engine is not edited. For each scene and responder three twins start equal and step
in lockstep (phys2d is deterministic, so they go through the same states; the script
checks that they end equal):

- the **plain twin**: the staged step, untouched (a check on the wrapped twin);
- the **wrapped twin**: the staged step with its stage functions wrapped by a timer. The
  staged step calls them by their names in ``phys2d.world`` (and a few methods of phys2d's
  classes); the script replaces those while this twin steps, and puts them back after;
- the **one-call twin**: ``World.step`` as users run it, its tick kernel (``pgs_tick`` or
  ``soft_tick``) wrapped by a timer. The world reaches the kernel through
  ``phys2d.tick.tick_for(responder)``, a ``TickSpec`` kept on the responder; this twin's
  responder is given a copy of it whose kernel is the wrapper.

In each repeat the plain twin steps, then the one-call twin, pymunk on the same scene, a
one-box scene (one-call, then staged), and the wrapped twin. All figures are medians over
repeats; ratios are taken within each repeat.

The one-call step:

- **one-call step** (µs per step): the one-call twin's time per step less what the
  kernel's wrapper adds (the extra wall time per call of a wrapped empty function, times
  the calls);
- **kernel call**: the wrapped kernel calls less the timer's own cost per call (two
  ``perf_counter_ns`` calls back to back): the whole tick in numba, with what is left of its dispatch;
- **numba dispatch** of that call (an estimate, inside the kernel call): see below;
- **Python of the step** = one-call step minus the kernel call: ``World.step``'s check of
  dt and ``World._step_in_one_call`` around the call (buffers checked, the tick's state
  looked up, the caches' views, the step report); the kernel sweeps for the pairs itself
  when a body left its fat box, and the world only after bodies or joints changed
  (``find_pairs``, ``colour_pairs``, between the kernel's two calls);
- **fixed cost** = Python of the step + dispatch, on the small scene; as a check, the
  one-call step of a one-box scene. On large scenes the Python of the step grows too: it
  runs on CPU caches the kernel has just filled with the scene's arrays (the same few
  lines of Python ran 2.5x slower right after pyramid_40's kernel than on warm caches),
  so there it is not a fixed cost;
- **numba kernel calls from Python per step**: counted in one recorded step; 1 (the tick
  kernel is called twice in a step that sweeps). The tick kernel's calls per timed step
  show how often that happens.

The staged step:

- **stage times** (µs per step): the sum of the wrapped calls of each stage, less the
  timer's own cost per call;
- **step**: the wrapped twin's time per step less what the wrappers add, so the stages
  and the step come from the same steps; the plain twin's time per step is shown beside
  it as a check, and it is the staged step of the ratios;
- **Python left over** = step minus the stages: the Python of ``World._step_in_stages``
  between the stage calls (the state snapshot, array allocation, the step report, ...);
- **numba dispatch** (an estimate, inside the stage times): each numba kernel called
  from Python costs a dispatch (typing its arguments, finding the compiled version)
  before any work; 7-8 kernels a step;
- **fixed cost per step** = Python left over + numba dispatch on the small scene: what a
  step costs whatever the scene's size. As a check, the staged step of a one-box scene.
  On large scenes the Python left over also holds numpy work that grows with the
  contacts (arrays allocated per pair, the contact arrays sliced and handed on each
  step), so there it is not a fixed cost.

Numba dispatch, both paths: the script records the arguments of every numba kernel called
from Python during one step (every numba dispatcher bound to a name in a phys2d module,
and the one-call tick's kernel), and times, for each, an empty numba function with the
same parameters called with those arguments; the sum is the dispatch cost per step. (Not
one empty function of ``*args``, as this script used before: numba dispatches that slower
than the kernels' own parameters, 22 µs against 16 for the staged kernels of
vertical_stack_10 under PGS, and about 200 µs against 2 for the tick's call, whose
``TickState`` and tuples it types the slow way; load average 1.4.) The world calls the
tick's compiled code directly from its second step on (``phys2d.tick.compiled_for``), so the
tick's call is timed, and its empty twin called, that way too (``Compiled``): what is left
of its dispatch is unboxing the arguments.

Stages of the staged step:

| stage | what is timed |
| --- | --- |
| external forces | `apply_external_forces` |
| broadphase | `update_geometry_in` (and the fat-box check); if a body left its box `find_pairs`, `colour_pairs` |
| narrowphase | `ManifoldCache.collide` (contact recycling, and the narrowphase for the pairs not recycled) |
| cache matching | `ContactCache.store_rows` (the look-up runs inside `contact_rows`, under rows) |
| rows | `RowBuffer.take`, `solve_order`, `World._context` (contacts in row order), `contact_rows`, `joint_rows` |
| solve | the responder's `respond` (SoftStep's moves the positions too: its sub-steps integrate) |
| integrate | `integrate_positions` (not called for SoftStep), `first_too_fast` (the speed limit check) |
"""

from __future__ import annotations

import argparse
import datetime as dt
import gc
import inspect
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
from phys2d.tick import TickSpec, compiled_for, tick_for  # noqa: E402

DT = 1.0 / 60.0

# stage -> names in phys2d.world that the staged step (World._step_in_stages) calls
FUNCTION_STAGES = {
    "external forces": ("apply_external_forces",),
    "broadphase": ("update_geometry_in", "find_pairs", "colour_pairs"),
    "rows": ("solve_order", "contact_rows", "joint_rows"),
    "integrate": ("integrate_positions", "first_too_fast"),
}
# stage -> (class, method name) that the staged step calls on its objects
METHOD_STAGES = {
    "narrowphase": ((ManifoldCache, "collide"),),
    "cache matching": ((ContactCache, "store_rows"),),
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


# -- the one-call tick's kernel ------------------------------------------------------------------


class Compiled:
    """Calls a tick kernel's compiled code for its arguments' types, without numba's dispatch,
    as ``World`` does from a world's second step on (``phys2d.tick.compiled_for``): a wrapper
    of the kernel would otherwise put the dispatch back into the step it times."""

    def __init__(self, kernel: Callable) -> None:
        self.kernel, self.code, self.__name__ = kernel, kernel, kernel.__name__

    def __call__(self, *args):
        if self.code is self.kernel:  # (the dispatcher compiles, or loads, on the first call)
            out = self.kernel(*args)
            self.code = compiled_for(self.kernel, args)
            return out
        return self.code(*args)


def swap_tick_kernel(w: phys2d.World, wrap: Callable[[Callable], Callable]) -> TickSpec:
    """Give w's responder a copy of its ``TickSpec`` whose kernel is ``wrap(kernel)``; returns
    the spec it had, for ``put_back``."""
    spec = tick_for(w.responder)
    if spec is None or not w.one_call_tick:
        raise RuntimeError(f"{w.responder.name}: this world does not step in one call")
    w.responder.__dict__["_tick_spec"] = spec._replace(kernel=wrap(spec.kernel))
    return spec


def put_back(w: phys2d.World, spec: TickSpec) -> None:
    """Give w's responder back the ``TickSpec`` that ``swap_tick_kernel`` returned."""
    w.responder.__dict__["_tick_spec"] = spec


class KernelTimer:
    """Wraps the one-call tick's kernel of world w with a timer; collects its ns and calls."""

    def __init__(self, w: phys2d.World) -> None:
        self.ns: dict[str, int] = defaultdict(int)
        self.calls: dict[str, int] = defaultdict(int)
        self.spec = swap_tick_kernel(
            w, lambda kernel: make_timed(Compiled(kernel), kernel.__name__, self.ns, self.calls)
        )
        self.name = self.spec.kernel.__name__

    def reset(self) -> None:
        self.ns.clear()
        self.calls.clear()


# -- numba dispatch ------------------------------------------------------------------------------


def empty_like(kernel) -> Callable:
    """An empty numba function with ``kernel``'s parameters: calling it costs the dispatch alone."""
    from numba import njit

    signature = inspect.signature(kernel.py_func)
    parameters = [p.replace(annotation=p.empty) for p in signature.parameters.values()]
    namespace: dict[str, Callable] = {}
    exec(
        f"def empty{signature.replace(parameters=parameters, return_annotation=signature.empty)}:\n    return 0",
        namespace,
    )
    return njit(namespace["empty"])


def kernel_calls_of_one_step(w: phys2d.World) -> list[tuple[str, Callable, tuple]]:
    """(name, kernel, args) of every numba kernel called from Python during one step of w.

    Every numba dispatcher bound to a name in a phys2d module is wrapped for one step, and
    so is the one-call tick's kernel when w steps in one call (all kernels are compiled by
    then, so no kernel is compiled against a wrapper).
    """
    from numba.core.registry import CPUDispatcher

    seen: list[tuple[str, Callable, tuple]] = []

    def recorder(kernel, name: str):
        def record(*args):
            seen.append((name, kernel, args))
            return kernel(*args)

        return record

    patches = []
    for mod_name, mod in list(sys.modules.items()):
        if not (mod_name == "phys2d" or mod_name.startswith("phys2d.")) or mod is None:
            continue
        for name, obj in list(vars(mod).items()):
            if isinstance(obj, CPUDispatcher):
                patches.append((mod, name, obj))
                setattr(mod, name, recorder(obj, name))
    one_call = w.one_call_tick and tick_for(w.responder) is not None
    spec = swap_tick_kernel(w, lambda kernel: recorder(Compiled(kernel), kernel.__name__)) if one_call else None
    try:
        w.step(DT)
    finally:
        for mod, name, obj in patches:
            setattr(mod, name, obj)
        if spec is not None:
            put_back(w, spec)
    return seen


def dispatch_cost_us(calls: list[tuple[str, Callable, tuple]], repeats: int = 7, loops: int = 2000) -> float:
    """Median over repeats of the time (µs) to make ``calls`` once each into empty kernels of
    the same parameters (``empty_like``)."""
    empties: dict[int, Callable] = {}
    for _, kernel, _ in calls:
        direct = isinstance(kernel, Compiled)  # the tick's kernel: called without dispatch
        empties.setdefault(id(kernel), Compiled(empty_like(kernel.kernel)) if direct else empty_like(kernel))
    made = [(empties[id(kernel)], args) for _, kernel, args in calls]
    for empty, args in made:  # compile each empty for its arguments' types first
        empty(*args)
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter_ns()
        for _ in range(loops):
            for empty, args in made:
                empty(*args)
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

    Used to take the wrappers' cost out of the wrapped twins' step times, so that the
    stages (or the kernel call) and the Python come from the same timed steps.
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


def staged(w: phys2d.World) -> phys2d.World:
    """w, set to step in stages (``World._step_in_stages``: one kernel call per stage)."""
    w.one_call_tick = False
    return w


def profile(scene: str, responder: str, args, pc_ns: float, added_ns: float) -> dict:
    """The one-call step and the staged step's stage times of one scene and responder; see
    the module docstring."""
    make, new = SCENES[scene], RESPONDERS[responder]
    plain, wrapped, one_call = staged(make(new())), staged(make(new())), make(new())
    one_box = phys2d.scenes.vertical_stack(1, responder=new())
    one_box_staged = staged(phys2d.scenes.vertical_stack(1, responder=new()))
    peer = pymunk_twin(scene)
    for _ in range(args.warmup):
        for w in (plain, wrapped, one_call, one_box, one_box_staged):
            w.step(DT)
        if peer is not None:
            peer.step()
    probe = Probe(type(wrapped.responder))
    kernel = KernelTimer(one_call)
    per_repeat: dict[str, list[float]] = defaultdict(list)  # figure -> its value in each repeat
    per_label: dict[str, list[float]] = defaultdict(list)
    calls_per_step: dict[str, float] = {}
    tick_calls = 0
    for _ in range(args.repeats):
        gc.collect()
        gc.disable()
        try:
            plain_us = timed_loop(lambda: plain.step(DT), args.steps)
            kernel.reset()
            one_call_us = timed_loop(lambda: one_call.step(DT), args.steps)
            peer_us = timed_loop(peer.step, args.steps) if peer is not None else float("nan")
            per_repeat["one_box"].append(timed_loop(lambda: one_box.step(DT), args.steps))
            per_repeat["one_box_staged"].append(timed_loop(lambda: one_box_staged.step(DT), args.steps))
            probe.reset()
            probe.on()
            try:
                wrapped_us = timed_loop(lambda: wrapped.step(DT), args.steps)
            finally:
                probe.off()
        finally:
            gc.enable()
        # the one-call step: the kernel call, and the Python around it
        n = kernel.calls[kernel.name]
        tick_calls += n
        step = one_call_us - n * added_ns / args.steps / 1e3
        kernel_us = (kernel.ns[kernel.name] - n * pc_ns) / args.steps / 1e3
        per_repeat["one_call"].append(step)
        per_repeat["kernel"].append(kernel_us)
        per_repeat["python"].append(step - kernel_us)
        # the staged step, by stage
        stages_us = 0.0
        for label in probe.stage_of:
            calls = probe.calls.get(label, 0)
            us = (probe.ns.get(label, 0) - calls * pc_ns) / args.steps / 1e3
            per_label[label].append(us)
            stages_us += us
            calls_per_step[label] = calls / args.steps
        total = wrapped_us - sum(probe.calls.values()) * added_ns / args.steps / 1e3
        per_repeat["total"].append(total)
        per_repeat["left_over"].append(total - stages_us)
        per_repeat["plain"].append(plain_us)
        # the yardstick
        per_repeat["pymunk"].append(peer_us)
        per_repeat["ratio"].append(plain_us / peer_us)
        per_repeat["one_call_ratio"].append(step / peer_us)
        per_repeat["one_call_vs_staged"].append(step / plain_us)
    for twin, name in ((wrapped, "wrapped"), (one_call, "one-call")):
        if not (np.array_equal(plain.x, twin.x) and np.array_equal(plain.theta, twin.theta)):
            raise RuntimeError(f"{scene}/{responder}: the {name} twin diverged, so its times are not comparable")
    put_back(one_call, kernel.spec)
    label_us = {label: statistics.median(v) for label, v in per_label.items()}
    stage_us = {s: 0.0 for s in STAGE_ORDER}
    for label, us in label_us.items():
        stage_us[probe.stage_of[label]] += us
    kernels = kernel_calls_of_one_step(plain)
    one_call_kernels = kernel_calls_of_one_step(one_call)
    return {
        **{figure: statistics.median(values) for figure, values in per_repeat.items()},
        "stages": stage_us,
        "labels": label_us,
        "calls": calls_per_step,
        "stage_of": dict(probe.stage_of),
        "kernel_calls": len(kernels),
        "dispatch": dispatch_cost_us(kernels),
        "tick_kernel": kernel.name,
        "tick_calls": tick_calls / (args.repeats * args.steps),
        "one_call_kernel_calls": len(one_call_kernels),
        "one_call_kernel_names": [name for name, _, _ in one_call_kernels],
        "one_call_dispatch": dispatch_cost_us(one_call_kernels),
        "contacts": len(plain.contacts),
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
        "# Time per step: the one-call step, and the staged step by stage (issue 11)",
        "",
        f"- command: `{command}`",
        f"- date: {dt.datetime.now(dt.timezone.utc).strftime('%Y-%m-%d %H:%M UTC')}",
        f"- checkout: {git_rev()}",
        f"- machine: {cpu()}, {os.cpu_count()} cores, {platform.platform()}",
        f"- load average (1 min) at the start and the end of the run: {load[0]} and {load[1]} (other work on "
        "the machine inflates the times; the shares and ratios suffer less)",
        f"- versions: python {platform.python_version()}, numpy {np.__version__}, numba {numba.__version__}",
        f"- method: {args.warmup} warm-up steps, then {args.repeats} repeats of {args.steps} steps; in each "
        "repeat the plain (staged) twin, the one-call twin with its tick kernel wrapped, pymunk on the same "
        "scene, a one-box scene (one-call, then staged), then the staged twin with its stage functions "
        f"wrapped; medians over repeats, ratios taken within each repeat. The timer's own cost ({pc_ns:.0f} ns) "
        f"is taken off each wrapped call, and the wall time a wrapper adds to a call ({added_ns:.0f} ns) off "
        "the wrapped twins' steps, so the parts and the step come from the same steps. Method and stage "
        "list: the docstring of `benchmarks/stages.py`.",
        "- responders: `PGS(iterations=10, warm_start=True)` (as in peers.py) and `SoftStep(substeps=4)`",
        "",
        "The **one-call step** is `World.step` as users run it (`phys2d.tick`: the whole tick in one numba "
        "kernel call); the **staged step** is the same tick with `World.one_call_tick = False` (one kernel "
        "call per stage, Python in between; bit-identical states), timed here to show where a step's work "
        "goes. Times in µs per step; in brackets the share of the step. The ratio to pymunk "
        "(benchmarks/engines.py's pymunk adapter on the same scene, in the same repeats) carries over between "
        "machines better than the times do.",
        "",
        "## Headline",
        "",
        "Time per step (µs) and, in brackets, its ratio to pymunk's. Each figure is its own median: the "
        "ratios, taken within each repeat, are the ones to compare; when other work slows some repeats, a "
        "median time can disagree with a median ratio.",
        "",
        *headline(results),
    ]
    for scene, per in results.items():
        names = list(per)
        L += ["", f"## {scene} ({per[names[0]]['contacts']} contact points at the end)", ""]
        L += ["### The one-call step", "", *table(["part", *names], one_call_rows(per))]
        L += ["", "### The staged step, by stage", "", *table(["stage", *names], staged_rows(per))]
        L += ["", "<details><summary>staged step by function (µs per step; calls per step in brackets)</summary>"]
        L += ["", *table(["function", "stage", *names], function_rows(per)), "", "</details>"]
    L += ["", "## Reading", "", *reading(results), ""]
    return "\n".join(L)


def headline(results: dict) -> list[str]:
    """One row per scene and responder: the one-call step, the staged step and pymunk's."""
    rows = []
    for scene, per in results.items():
        for r, res in per.items():
            rows.append(
                [scene, r, f"**{res['one_call']:.1f}** ({res['one_call_ratio']:.2f}x)",
                 f"{res['plain']:.1f} ({res['ratio']:.2f}x)", f"{res['pymunk']:.1f}",
                 f"{res['one_call_vs_staged']:.2f}x"]
            )  # fmt: skip
    header = ["scene", "responder", "one-call step (/ pymunk)", "staged step (/ pymunk)", "pymunk", "one-call / staged"]
    return table(header, rows)


def one_call_rows(per: dict) -> list[list[str]]:
    """The one-call step of each responder, split into its kernel call and the Python around it."""
    names = list(per)

    def us(key: str) -> list[str]:
        return [f"{per[r][key]:.1f} ({pct(per[r][key], per[r]['one_call'])})" for r in names]

    fixed = {r: per[r]["python"] + per[r]["one_call_dispatch"] for r in names}
    return [
        ["the kernel call (" + ", ".join(sorted({f"`{per[r]['tick_kernel']}`" for r in names})) + "), from Python"]
        + us("kernel"),
        ["numba dispatch of that call, estimated (inside the kernel call)"] + us("one_call_dispatch"),
        ["Python of the step (the step less the kernel call)"] + us("python"),
        ["**one-call step** (wrapped twin, less the wrapper)"] + [f"**{per[r]['one_call']:.1f}**" for r in names],
        ["one-call step / pymunk's step"] + [f"{per[r]['one_call_ratio']:.2f}x" for r in names],
        ["one-call step / staged step (the plain twin's)"] + [f"{per[r]['one_call_vs_staged']:.2f}x" for r in names],
        ["numba kernels called from Python per step (one step recorded)"]
        + [str(per[r]["one_call_kernel_calls"]) for r in names],
        ["tick kernel calls per timed step (2 in a step that sweeps)"] + [f"{per[r]['tick_calls']:.2f}" for r in names],
        ["**Python + dispatch** (the fixed cost, on a small scene)"]
        + [f"**{fixed[r]:.1f}** ({pct(fixed[r], per[r]['one_call'])})" for r in names],
        ["one-box scene's one-call step, same repeats"] + [f"{per[r]['one_box']:.1f}" for r in names],
    ]


def staged_rows(per: dict) -> list[list[str]]:
    """The staged step of each responder, stage by stage, with its Python left over and dispatch."""
    names = list(per)

    def us(value: Callable[[dict], float]) -> list[str]:
        return [f"{value(per[r]):.1f} ({pct(value(per[r]), per[r]['total'])})" for r in names]

    rows = [[s, *us(lambda res, s=s: res["stages"][s])] for s in STAGE_ORDER]
    return rows + [
        ["Python left over", *us(lambda res: res["left_over"])],
        ["**staged step** (wrapped twin, less the wrappers)"] + [f"**{per[r]['total']:.1f}**" for r in names],
        ["staged step of the plain twin (a check)"] + [f"{per[r]['plain']:.1f}" for r in names],
        ["plain twin's step / pymunk's step"] + [f"{per[r]['ratio']:.2f}x" for r in names],
        ["numba kernels called from Python per step"] + [str(per[r]["kernel_calls"]) for r in names],
        ["numba dispatch, estimated (inside the stages above)", *us(lambda res: res["dispatch"])],
        ["**Python left over + dispatch** (the fixed cost, on a small scene)"]
        + [
            f"**{per[r]['left_over'] + per[r]['dispatch']:.1f}** "
            f"({pct(per[r]['left_over'] + per[r]['dispatch'], per[r]['total'])})"
            for r in names
        ],  # fmt: skip
        ["one-box scene's staged step, same repeats"] + [f"{per[r]['one_box_staged']:.1f}" for r in names],
    ]


def function_rows(per: dict) -> list[list[str]]:
    """The staged step's wrapped functions: µs per step and calls per step, per responder."""
    names = list(per)
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
    return rows


def calls(n: int) -> str:
    return f"{n} kernel call" + ("" if n == 1 else "s")


def reading(results: dict) -> list[str]:
    """Where each step's time goes, and the fixed cost, in words (from the figures above)."""
    out = []
    for scene, per in results.items():
        parts = []
        for r, res in per.items():
            ranked = sorted(res["stages"].items(), key=lambda kv: -kv[1])
            top = ", ".join(f"{s} {pct(us, res['total'])}" for s, us in ranked[:3])
            parts.append(
                f"{r}: one-call step {res['one_call']:.0f} µs ({res['one_call_ratio']:.2f}x pymunk), "
                f"{pct(res['kernel'], res['one_call'])} in the kernel call; staged step {res['plain']:.0f} µs "
                f"({res['ratio']:.2f}x pymunk): {top}, Python left over {pct(res['left_over'], res['total'])}"
            )
        out.append(f"- **{scene}**: " + "; ".join(parts) + ".")
    small = next(iter(results))
    for r, res in results[small].items():
        fixed = res["python"] + res["one_call_dispatch"]
        staged_fixed = res["left_over"] + res["dispatch"]
        out.append(
            f"- Fixed cost per step on {small}, {r}: one-call {fixed:.0f} µs of {res['one_call']:.0f} µs "
            f"({pct(fixed, res['one_call'])}): Python {res['python']:.0f} µs and numba dispatch about "
            f"{res['one_call_dispatch']:.0f} µs over {calls(res['one_call_kernel_calls'])}; staged "
            f"{staged_fixed:.0f} µs of {res['total']:.0f} µs ({pct(staged_fixed, res['total'])}): Python left "
            f"over {res['left_over']:.0f} µs and dispatch about {res['dispatch']:.0f} µs over "
            f"{calls(res['kernel_calls'])}. A one-box scene steps in {res['one_box']:.0f} µs in one call, "
            f"{res['one_box_staged']:.0f} µs in stages."
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
    added_ns = calibrate(pc_ns)
    results: dict[str, dict] = {}
    for scene in args.scenes:
        results[scene] = {}
        for r in args.responders:
            res = results[scene][r] = profile(scene, r, args, pc_ns, added_ns)
            stages = ", ".join(f"{s} {us:.1f}" for s, us in res["stages"].items())
            print(
                f"{scene} {r}: one-call step {res['one_call']:.1f} us = kernel call {res['kernel']:.1f} (dispatch "
                f"{res['one_call_dispatch']:.1f}) + Python {res['python']:.1f}; staged step {res['total']:.1f} us "
                f"(plain {res['plain']:.1f}) = {stages}, Python left over {res['left_over']:.1f}; dispatch "
                f"{res['dispatch']:.1f} us over {res['kernel_calls']} kernel calls; pymunk {res['pymunk']:.1f} us; "
                f"one box {res['one_box']:.1f} / {res['one_box_staged']:.1f} us",
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
