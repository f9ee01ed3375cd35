"""Peer benchmark (issue 7): phys2d against pymunk 7.3 and Box2D 2.3.

Runs the same scenes in every engine in one process and writes
``benchmarks/RESULTS.md``:

- speed: median ms per ``step`` over repeats (engines interleaved within each
  repeat, only ``step`` timed) and the median over repeats of the ratio to pymunk
  taken within the same repeat;
- contact points after settling, and the deepest overlap over the whole run;
- after 30 s (1800 steps): the largest sideways movement of any box, and whether
  the structure fell (a box moved more than 0.5 m or turned more than 30 deg);
- phys2d with recording on (``phys2d.Recorder``), if it exists;
- time of the first ``step`` in a fresh process, with a warm and a cold numba cache.

Usage::

    python benchmarks/peers.py              # full run, a few minutes
    python benchmarks/peers.py --quick      # smoke run, about a minute
    python benchmarks/peers.py --scenes pyramid_20 mass_ratio_100
"""

from __future__ import annotations

import argparse
import datetime as dt
import gc
import json
import math
import os
import platform
import shlex
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import engines  # benchmarks/engines.py: this script's folder is on sys.path
import numpy as np
from engines import DT, SCENES

BENCH_DIR = Path(__file__).resolve().parent
REPO_ROOT = BENCH_DIR.parent
# Benchmark the phys2d of this checkout, not whatever happens to be installed
# (phys2d is imported lazily, inside the adapters).
if str(REPO_ROOT) not in sys.path:
    sys.path.insert(0, str(REPO_ROOT))

FALL_MOVE = 0.5  # m
FALL_TURN = math.radians(30.0)
SETTLE_SECONDS = 2.0  # contact points are counted at this time
PEERS = ("pymunk", "Box2D")
ALL_ENGINES = ("pymunk", "Box2D", "phys2d", "phys2d+rec")

# Peer figures quoted in issue 7 (measured elsewhere), for the comparison table.
ISSUE_TARGETS = [
    # (what, Box2D in the issue, pymunk in the issue, phys2d target)
    ("pyramid_20, ms/step", "about 1.3x pymunk", "1.0", "<= 1.0x pymunk"),
    ("pyramid_40, ms/step", "about 1.4x pymunk", "1.0", "<= 1.0x pymunk"),
    ("pyramid_40, sideways movement at 30 s", "0.21 m", "0.16 m", "< 0.05 m"),
    (
        "vertical_stack_20 at 30 s",
        "falls at 14 s",
        "falls at 2 s",
        "stands, < 0.01 m sway",
    ),
    (
        "mass_ratio_100 at 30 s",
        "holds, wobbles 0.09 m",
        "falls at 1 s",
        "holds, < 0.01 m",
    ),
    ("recording a pyramid_20 tick", "-", "-", "<= 2 ms"),
    ("first step, warm numba cache", "-", "-", "<= 2 s"),
]


# --------------------------------------------------------------------------
# building
# --------------------------------------------------------------------------


def make_adapter(engine: str, scene, args, tmpdir: str):
    if engine == "pymunk":
        return engines.PymunkAdapter(scene, collision_slop=args.pymunk_slop)
    if engine == "Box2D":
        return engines.Box2DAdapter(scene)
    if engine == "phys2d":
        return engines.Phys2DAdapter(scene)
    if engine == "phys2d+rec":
        path = os.path.join(tmpdir, f"{scene.name}-{time.perf_counter_ns()}.rrd")
        return engines.Phys2DAdapter(scene, record_path=path)
    if engine in args.variants:  # phys2d[label] from --variant label=EXPR
        import phys2d

        responder = eval(args.variants[engine], {"phys2d": phys2d})  # the user's own CLI text
        return engines.Phys2DAdapter(scene, responder=responder)
    raise ValueError(engine)


# --------------------------------------------------------------------------
# measuring
# --------------------------------------------------------------------------


def describe(exc: BaseException) -> str:
    text = f"{type(exc).__name__}: {exc}".splitlines()[0]
    return text[:120]


def time_scene(scene, names, args, tmpdir):
    """Median ms/step per engine and median (over repeats) ratio to pymunk.

    An engine that fails to build, or raises while stepping, is reported as
    ``{"error": ...}`` and the others go on.
    """
    adapters, out = {}, {}
    for e in names:
        try:
            a = make_adapter(e, scene, args, tmpdir)
            adapters[e] = a
            for _ in range(args.warmup):
                a.step()
        except Exception as exc:  # noqa: BLE001  (a broken engine must not stop the rest)
            out[e] = {"error": describe(exc)}
            broken = adapters.pop(e, None)
            if broken is not None:
                broken.close()
    live = [e for e in names if e in adapters]
    per_rep = {e: [] for e in live}
    try:
        for r in range(args.repeats):
            k = r % len(live) if live else 0  # rotate who goes first
            for e in live[k:] + live[:k]:
                if e in out:
                    continue
                step = adapters[e].step
                gc.collect()
                gc.disable()
                try:
                    t0 = time.perf_counter_ns()
                    for _ in range(args.steps):
                        step()
                    t1 = time.perf_counter_ns()
                except Exception as exc:  # noqa: BLE001  (as above)
                    out[e] = {"error": describe(exc)}
                    continue
                finally:
                    gc.enable()
                per_rep[e].append((t1 - t0) / args.steps / 1e6)
    finally:
        for a in adapters.values():
            a.close()
    full = {e: ms for e, ms in per_rep.items() if e not in out}
    for e, ms in full.items():
        row = {
            "ms": statistics.median(ms),
            "ms_min": min(ms),
            "ms_max": max(ms),
            "per_repeat": ms,
        }
        if "pymunk" in full:
            row["ratio"] = statistics.median(m / p for m, p in zip(ms, full["pymunk"], strict=True))
        if e == "phys2d+rec" and "phys2d" in full:
            row["rec_overhead"] = statistics.median(m - p for m, p in zip(ms, full["phys2d"], strict=True))
        out[e] = row
    return {e: out[e] for e in names if e in out}


def wrap_angle(a: np.ndarray) -> np.ndarray:
    return np.arctan2(np.sin(a), np.cos(a))


def stability_run(scene, engine, args, tmpdir):
    """Simulate ``args.seconds``; track overlap, movement, tilt and the fall."""
    a = make_adapter(engine, scene, args, tmpdir)
    try:
        start = scene.start()
        n = round(args.seconds / DT)
        settle = min(n, round(SETTLE_SECONDS / DT))
        contacts = None
        max_overlap = 0.0
        late_overlap = 0.0  # deepest over the final second
        late = n - round(1.0 / DT)
        max_dx_run = 0.0
        max_move = 0.0
        max_turn = 0.0
        fell = None
        for i in range(1, n + 1):
            a.step()
            overlap = a.max_overlap()
            max_overlap = max(max_overlap, overlap)
            if i > late:
                late_overlap = max(late_overlap, overlap)
            d = a.positions() - start
            move = np.hypot(d[:, 0], d[:, 1])
            turn = np.abs(wrap_angle(a.angles()))
            max_dx_run = max(max_dx_run, float(np.abs(d[:, 0]).max()))
            max_move = max(max_move, float(move.max()))
            max_turn = max(max_turn, float(turn.max()))
            if fell is None and (move.max() > FALL_MOVE or turn.max() > FALL_TURN):
                j = int(np.argmax(move))
                if move[j] > FALL_MOVE:
                    why = f"box {j} moved {move[j]:.2f} m"
                    why += f" ({d[j, 0]:+.2f}, {d[j, 1]:+.2f})"
                else:
                    j = int(np.argmax(turn))
                    why = f"box {j} turned {math.degrees(turn[j]):.0f} deg"
                fell = {"t": i * DT, "why": why}
            if i == settle:
                contacts = a.contact_count()
        d = a.positions() - start
        return {
            "contacts": contacts,
            "max_overlap": max_overlap,
            "late_overlap": late_overlap,
            "dx_end": float(np.abs(d[:, 0]).max()),
            "dx_run": max_dx_run,
            "dy_end_min": float(d[:, 1].min()),
            "dy_end_max": float(d[:, 1].max()),
            "max_move": max_move,
            "max_turn_deg": math.degrees(max_turn),
            "fell": fell,
            "seconds": n * DT,
        }
    finally:
        a.close()


FIRST_STEP_CODE = r"""
import json, sys, time
t0 = time.perf_counter()
sys.path[:0] = [{root!r}, {bench!r}]
import phys2d
t1 = time.perf_counter()
import engines
a = engines.Phys2DAdapter(engines.pyramid(20))
t2 = time.perf_counter()
a.step()
t3 = time.perf_counter()
a.step()
t4 = time.perf_counter()
print(json.dumps({{"import": t1 - t0, "build": t2 - t1, "first_step": t3 - t2,
                  "second_step": t4 - t3, "total": t3 - t0}}))
"""


def first_step_times(args):
    """Fresh processes: cold numba cache (fresh NUMBA_CACHE_DIR), then warm."""
    code = FIRST_STEP_CODE.format(root=str(REPO_ROOT), bench=str(BENCH_DIR))

    def run(cache_dir):
        env = dict(os.environ, NUMBA_CACHE_DIR=cache_dir)
        p = subprocess.run(
            [sys.executable, "-c", code],
            env=env,
            capture_output=True,
            text=True,
            timeout=1200,
            check=False,
        )
        if p.returncode != 0:
            raise RuntimeError(p.stderr.strip().splitlines()[-1] if p.stderr else "failed")
        return json.loads(p.stdout.strip().splitlines()[-1])

    cold, warm = [], []
    for _ in range(args.cold_runs):
        with tempfile.TemporaryDirectory(prefix="numba-cold-") as cache:
            cold.append(run(cache))
            if not warm:  # the cache this cold run filled is the warm one
                for _ in range(args.warm_runs):
                    warm.append(run(cache))
    return {"cold": cold, "warm": warm}


# --------------------------------------------------------------------------
# reporting
# --------------------------------------------------------------------------


def versions() -> dict:
    import Box2D
    import numba
    import pymunk

    v = {
        "python": platform.python_version(),
        "numpy": np.__version__,
        "numba": numba.__version__,
        "pymunk": f"{pymunk.version} (Chipmunk {pymunk.chipmunk_version[:5]})",
        "Box2D": Box2D.__version__,
    }
    try:
        import phys2d

        v["phys2d"] = f"{getattr(phys2d, '__version__', '?')} from {phys2d.__file__}"
    except ImportError:
        v["phys2d"] = "not importable"
    return v


def machine() -> dict:
    model = platform.processor() or "?"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    try:
        usable = len(os.sched_getaffinity(0))
    except AttributeError:
        usable = os.cpu_count()
    return {
        "cpu": model,
        "cores": os.cpu_count(),
        "usable cores": usable,
        "os": platform.platform(),
    }


def git_rev() -> str:
    try:
        rev = subprocess.run(
            ["git", "-C", str(REPO_ROOT), "rev-parse", "--short", "HEAD"],
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
        dirty = subprocess.run(
            ["git", "-C", str(REPO_ROOT), "status", "--porcelain"],
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
        return rev + (" (uncommitted changes)" if dirty else "")
    except (OSError, subprocess.CalledProcessError):
        return "?"


def fmt_fell(s) -> str:
    if s is None:
        return "n/a"
    if s["fell"] is None:
        return f"stands ({s['seconds']:.0f} s)"
    return f"falls at {s['fell']['t']:.2f} s: {s['fell']['why']}"


def table(header, rows) -> list[str]:
    out = [
        "| " + " | ".join(header) + " |",
        "| " + " | ".join("---" for _ in header) + " |",
    ]
    out += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return out


def report(args, names, timing, stab, first, meta) -> str:
    eng = [e for e in names if e != "phys2d+rec"]
    variants = [e for e in names if e.startswith("phys2d[")]
    m = meta["machine"]
    slop = "default (0.1)" if args.pymunk_slop is None else args.pymunk_slop
    settle = min(args.seconds, SETTLE_SECONDS)
    L = [
        "# Peer benchmark results (issue 7)",
        "",
        f"- command: `{meta['command']}`",
        f"- date: {meta['date']}",
        f"- checkout: {meta['git']}",
        f"- machine: {m['cpu']}, {m['cores']} cores ({m['usable cores']} usable), " + m["os"],
        "- versions: " + ", ".join(f"{k} {v}" for k, v in meta["versions"].items()),
        (
            "- settings: dt 1/60, gravity (0, -10), 10 solver iterations (Box2D: 10 "
            "velocity + 3 position), friction 0.6 per pair, restitution 0, "
            "sleeping off, "
            f"pymunk collision_slop {slop}"
        ),
        (
            f"- timing: {args.warmup} warm-up steps, then {args.repeats} repeats of "
            f"{args.steps} steps per engine, engines interleaved (order rotated each "
            "repeat), only `step` timed, garbage collector off while timing"
        ),
        (
            f"- stability: a fresh scene run for {args.seconds:g} s "
            f"({round(args.seconds / DT)} steps); contacts counted at "
            f"t = {settle:g} s; "
            f"fell = a box moved more than {FALL_MOVE} m from its start or turned more "
            "than 30 deg"
        ),
    ]
    if args.quick:
        L += ["- **quick smoke run**: too few steps for meaningful figures"]

    def cellfmt(per, e, fmt):
        if e not in per:
            return "n/a"
        return f"error ({per[e]['error']})" if "error" in per[e] else fmt(per[e])

    def section(title, columns, rows):
        L.extend(["", f"## {title}", ""])
        L.extend(table(columns, rows))

    def timing_table(title, fmt):
        rows = []
        for s, per in timing.items():
            rows.append([s] + [cellfmt(per, e, fmt) for e in names])
        section(title, ["scene", *names], rows)

    def stab_table(title, fmt):
        rows = []
        for s, per in stab.items():
            rows.append([s] + [cellfmt(per, e, fmt) for e in eng])
        section(title, ["scene", *eng], rows)

    timing_table(
        "Milliseconds per step (median over repeats; min-max in brackets)",
        lambda t: f"{t['ms']:.3f} ({t['ms_min']:.3f}-{t['ms_max']:.3f})",
    )
    timing_table(
        "Ratio to pymunk (median over repeats of the ratio within each repeat)",
        lambda t: f"{t['ratio']:.2f}x" if "ratio" in t else "n/a",
    )
    stab_table(f"Contact points at t = {settle:g} s", lambda r: str(r["contacts"]))
    stab_table(
        "Deepest overlap over the whole run, mm (deepest over the final second in "
        "brackets), from each engine's own contact data",
        lambda r: f"{1e3 * r['max_overlap']:.1f} ({1e3 * r['late_overlap']:.1f})",
    )
    stab_table(
        f"Largest sideways (x) movement of any box at {args.seconds:g} s, m (largest during the run in brackets)",
        lambda r: f"{r['dx_end']:.4f} ({r['dx_run']:.4f})",
    )
    stab_table(f"Did it fall within {args.seconds:g} s?", fmt_fell)
    stab_table(
        "Largest movement (m) / turn (deg) of any box during the run",
        lambda r: f"{r['max_move']:.3f} / {r['max_turn_deg']:.1f}",
    )

    rows = []
    for s, per in timing.items():
        p, r = per.get("phys2d"), per.get("phys2d+rec")
        p = None if p and "error" in p else p
        r = None if r and "error" in r else r
        rows.append(
            [
                s,
                f"{p['ms']:.3f}" if p else "n/a",
                f"{r['ms']:.3f}" if r else "n/a",
                f"{r['rec_overhead']:.3f}" if r and "rec_overhead" in r else "n/a",
            ]
        )
    section(
        "phys2d with recording on (`phys2d.Recorder`, one `log` per step)",
        ["scene", "phys2d ms/step", "phys2d+rec ms/tick", "recording overhead ms"],
        rows,
    )

    title = "First step in a fresh process (phys2d, pyramid_20; seconds)"
    if isinstance(first, dict):
        rows = []
        for label in ("warm", "cold"):
            runs = first[label]
            if not runs:
                continue
            med = {k: statistics.median(r[k] for r in runs) for k in runs[0]}
            rows.append(
                [
                    f"{label} ({len(runs)} runs, median)",
                    f"{med['import']:.2f}",
                    f"{med['build']:.2f}",
                    f"{med['first_step']:.3f}",
                    f"{1e3 * med['second_step']:.2f}",
                    f"{med['total']:.2f}",
                ]
            )
        section(
            title,
            [
                "numba cache",
                "import phys2d",
                "build",
                "first step",
                "second step (ms)",
                "start to end of first step",
            ],
            rows,
        )
        L += [
            "",
            (
                "Cold: `NUMBA_CACHE_DIR` set to a fresh temporary directory. Warm: the "
                "same directory again, after the cold run filled it."
            ),
        ]
    else:
        L.extend(["", f"## {title}", "", f"n/a ({first})"])

    section(
        "Issue 7 targets against this run",
        [
            "measure",
            "issue: Box2D",
            "issue: pymunk",
            "phys2d must reach",
            "this run: Box2D",
            "this run: pymunk",
            "this run: phys2d",
        ] + [f"this run: {v}" for v in variants],
        target_rows(timing, stab, first, variants),
    )
    L.append("")
    return "\n".join(L)


def target_rows(timing, stab, first, variants=()):
    def ratio(s, e):
        t = timing.get(s, {}).get(e)
        return f"{t['ratio']:.2f}x ({t['ms']:.2f} ms)" if t and "ratio" in t else "n/a"

    def dx(s, e):
        r = stab.get(s, {}).get(e)
        return f"{r['dx_end']:.3f} m" if r and "error" not in r else "n/a"

    def fell(s, e):
        r = stab.get(s, {}).get(e)
        if not r or "error" in r:
            return "n/a"
        if r["fell"]:
            return f"falls at {r['fell']['t']:.1f} s"
        return f"stands, sway {r['dx_end']:.3f} m (max {r['dx_run']:.3f})"

    rec = timing.get("pyramid_20", {}).get("phys2d+rec")
    rec = None if rec and "error" in rec else rec
    rec_s = "n/a"
    if rec:
        rec_s = f"{rec['ms']:.2f} ms/tick"
        if "rec_overhead" in rec:
            rec_s += f" (recording {rec['rec_overhead']:.2f} ms of it)"
    warm = "n/a"
    if isinstance(first, dict) and first.get("warm"):
        warm = f"{statistics.median(r['first_step'] for r in first['warm']):.2f} s"
    cols = ("Box2D", "pymunk", "phys2d", *variants)
    measured = [
        [ratio("pyramid_20", e) for e in cols],
        [ratio("pyramid_40", e) for e in cols],
        [dx("pyramid_40", e) for e in cols],
        [fell("vertical_stack_20", e) for e in cols],
        [fell("mass_ratio_100", e) for e in cols],
        ["-", "-", rec_s] + ["-"] * len(variants),
        ["-", "-", warm] + ["-"] * len(variants),
    ]
    return [list(t) + m for t, m in zip(ISSUE_TARGETS, measured, strict=True)]


def update_readme(text: str, meta: dict) -> None:
    """Copy the targets table of a full run into benchmarks/README.md."""
    readme = BENCH_DIR / "README.md"
    start, end = "<!-- results:start -->", "<!-- results:end -->"
    try:
        old = readme.read_text()
        head, rest = old.split(start, 1)
        _, tail = rest.split(end, 1)
    except (OSError, ValueError):
        return
    targets = text.split("## Issue 7 targets against this run", 1)[1].strip()
    block = f"{start}\nFrom `{meta['command']}` on {meta['date']}:\n\n{targets}\n{end}"
    readme.write_text(head + block + tail)


# --------------------------------------------------------------------------


def parse_args(argv=None):
    p = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "--quick",
        action="store_true",
        help="smoke run: few steps, 2 repeats, 3 s of simulation",
    )
    p.add_argument(
        "--scenes",
        nargs="+",
        choices=list(SCENES),
        default=list(SCENES),
        metavar="SCENE",
        help="scenes to run (default: all): " + ", ".join(SCENES),
    )
    p.add_argument(
        "--engines",
        nargs="+",
        choices=ALL_ENGINES,
        default=list(ALL_ENGINES),
        help="engines to run (default: all available)",
    )
    p.add_argument("--repeats", type=int, help="timed repeats (default 5, quick 2)")
    p.add_argument("--steps", type=int, help="steps per timed repeat (default 300, quick 20)")
    p.add_argument("--warmup", type=int, help="warm-up steps (default 60, quick 10)")
    p.add_argument(
        "--seconds",
        type=float,
        help="simulated seconds of the stability run (default 30, quick 3)",
    )
    p.add_argument(
        "--cold-runs",
        type=int,
        default=None,
        help="fresh processes with a cold numba cache (default 2, quick 1)",
    )
    p.add_argument(
        "--warm-runs",
        type=int,
        default=3,
        help="fresh processes with a warm numba cache (default 3)",
    )
    p.add_argument(
        "--no-first-step",
        action="store_true",
        help="skip the fresh-process first-step measurement",
    )
    p.add_argument(
        "--pymunk-slop",
        type=float,
        default=None,
        help="override pymunk's collision_slop (default: pymunk's own, 0.1)",
    )
    p.add_argument(
        "--out",
        type=Path,
        default=None,
        help="results file (default benchmarks/RESULTS.md, quick: benchmarks/RESULTS-quick.md)",
    )
    p.add_argument(
        "--variant",
        action="append",
        default=[],
        metavar="LABEL=EXPR",
        help="add a phys2d column 'phys2d[LABEL]' whose responder is the Python "
        "expression EXPR (phys2d is in scope), e.g. "
        "--variant 'pgs20=phys2d.PGS(iterations=20, warm_start=True)'; repeatable",
    )
    p.add_argument(
        "--no-variants",
        action="store_true",
        help="run only the default phys2d (the lecture's PGS), not the variants of DEFAULT_VARIANTS",
    )
    args = p.parse_args(argv)
    args.variants = {}
    if not args.variant and not args.no_variants:
        args.variant = [f"{label}={expr}" for label, expr in DEFAULT_VARIANTS.items()]
    for v in args.variant:
        label, sep, expr = v.partition("=")
        if not sep or not label or not expr:
            p.error(f"--variant wants LABEL=EXPR, got {v!r}")
        args.variants[f"phys2d[{label}]"] = expr
    q = args.quick
    for name, full, quick in (
        ("repeats", 5, 2),
        ("steps", 300, 20),
        ("warmup", 60, 10),
        ("seconds", 30.0, 3.0),
        ("cold_runs", 2, 1),
    ):
        if getattr(args, name) is None:
            setattr(args, name, quick if q else full)
    if args.out is None:
        args.out = BENCH_DIR / ("RESULTS-quick.md" if q else "RESULTS.md")
    return args


# what the field learned after the lecture, each shown beside the lecture's PGS (issue 7)
DEFAULT_VARIANTS = {
    "block": "phys2d.PGS(iterations=10, warm_start=True, block=True)",
    "soft4": "phys2d.SoftStep(substeps=4)",
    "soft6": "phys2d.SoftStep(substeps=6)",
}


def main(argv=None) -> int:
    args = parse_args(argv)
    command = "python " + shlex.join([os.path.relpath(sys.argv[0])] + sys.argv[1:])
    names = [e for e in ALL_ENGINES if e in args.engines] + list(args.variants)
    if not engines.phys2d_available():
        print("phys2d not importable (no phys2d.World yet): its columns read n/a")
        names = [e for e in names if not e.startswith("phys2d")]
    elif not engines.recorder_available() and "phys2d+rec" in names:
        print("phys2d.Recorder does not exist yet: recording figures read n/a")
        names.remove("phys2d+rec")
    names = tuple(names)

    timing, stab = {}, {}
    with tempfile.TemporaryDirectory(prefix="phys2d-bench-") as tmpdir:
        for sname in args.scenes:
            scene = SCENES[sname]()
            t0 = time.perf_counter()
            timing[sname] = time_scene(scene, names, args, tmpdir)
            line = ", ".join(
                f"{e} {r['error']}"
                if "error" in r
                else f"{e} {r['ms']:.3f} ms" + (f" ({r['ratio']:.2f}x)" if "ratio" in r else "")
                for e, r in timing[sname].items()
            )
            print(f"{sname} ({len(scene.boxes)} boxes) speed: {line}", flush=True)
            stab[sname] = {}
            for e in names:
                if e == "phys2d+rec":  # same physics as phys2d
                    continue
                try:
                    r = stability_run(scene, e, args, tmpdir)
                except Exception as exc:  # noqa: BLE001  (report it, go on)
                    stab[sname][e] = {"error": describe(exc)}
                    print(f"  {e}: {describe(exc)}", flush=True)
                    continue
                stab[sname][e] = r
                print(
                    f"  {e}: contacts {r['contacts']}, overlap "
                    f"{1e3 * r['max_overlap']:.1f} mm, dx {r['dx_end']:.4f} m, "
                    f"{fmt_fell(r)}",
                    flush=True,
                )
            print(f"  ({time.perf_counter() - t0:.0f} s)", flush=True)

    first = "phys2d not available"
    if "phys2d" in names and not args.no_first_step:
        try:
            first = first_step_times(args)
            print("first step:", json.dumps(first), flush=True)
        except (RuntimeError, subprocess.TimeoutExpired, ValueError) as exc:
            first = f"failed: {exc}"
    elif args.no_first_step:
        first = "skipped (--no-first-step)"

    meta = {
        "command": command,
        "date": dt.datetime.now(dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
        "machine": machine(),
        "versions": versions(),
        "git": git_rev(),
    }
    text = report(args, names, timing, stab, first, meta)
    args.out.write_text(text)
    if not args.quick and args.out == BENCH_DIR / "RESULTS.md":
        update_readme(text, meta)
    print()
    print(text)
    print(f"written to {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
