"""Peer benchmark (issues 7 and 11): phys2d against pymunk 7.3, Box2D 2.3 and Box2D v3.

Runs the same scenes in every engine in one process and writes
``benchmarks/RESULTS.md``:

- speed: median microseconds per ``step`` over repeats (engines interleaved within
  each repeat, only ``step`` timed) and the median over repeats of the ratio to
  pymunk taken within the same repeat;
- contact points after settling, and the deepest overlap over the whole run;
- after 30 s (1800 steps): the largest sideways movement of any box, and whether
  the structure fell (a box moved more than 0.5 m or turned more than 30 deg);
  for scenes with joints, the largest joint gap;
- phys2d with recording on (``phys2d.Recorder``), if it exists;
- time of the first ``step`` in a fresh process, with a warm and a cold numba cache.

Box2D v3 runs only when given a source tree (``--box2d-v3 PATH``): it is built
with its own CMake and linked with our C harness (``box2d_v3_harness.c``) into a
shared library that ``engines.Box2DV3Adapter`` calls through ctypes (see
``box2d_v3.py``).

Usage::

    python benchmarks/peers.py              # full run, a few minutes
    python benchmarks/peers.py --quick      # smoke run, about a minute
    python benchmarks/peers.py --scenes pyramid_20 mass_ratio_100
    python benchmarks/peers.py --box2d-v3 ~/src/box2d   # with Box2D v3
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

import box2d_v3  # benchmarks/box2d_v3.py
import engines  # benchmarks/engines.py: this script's folder is on sys.path
import numpy as np
from engines import DT, SCENES

BENCH_DIR = Path(__file__).resolve().parent
REPO_ROOT = BENCH_DIR.parent
# Benchmark the phys2d of this checkout, not whatever happens to be installed
# (phys2d is imported lazily, inside the adapters).
if str(REPO_ROOT) not in sys.path:
    sys.path.insert(0, str(REPO_ROOT))
# Compile in this process, before anything is timed: after an edit, phys2d by default steps
# stage by stage while a child process compiles the tick beside the timed steps (pipeline.ahead).
# The first-step processes get the environment as given: a user's first run compiles ahead.
USER_ENV = dict(os.environ)
os.environ.setdefault("PHYS2D_COMPILE_AHEAD", "0")

FALL_MOVE = 0.5  # m
FALL_TURN = math.radians(30.0)
SETTLE_SECONDS = 2.0  # contact points are counted at this time
PEERS = ("pymunk", "Box2D", "Box2D-v3")
ALL_ENGINES = ("pymunk", "Box2D", "Box2D-v3", "phys2d", "phys2d+rec")

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
    (
        "recording a pyramid_20 tick (`Recorder.log` in the step loop, in process; end to end: RECORDING.md)",
        "-",
        "-",
        "<= 2 ms",
    ),
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
    if engine == "Box2D-v3":
        return engines.Box2DV3Adapter(scene, args.v3_lib, substeps=args.box2d_v3_substeps)
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


def try_adapter(engine: str, scene, args, tmpdir: str):
    """(adapter, None), or (None, cell) when the engine cannot build the scene:
    ``{"skip": reason}`` for a known limit (a phys2d responder without joints),
    ``{"error": ...}`` for anything else."""
    try:
        return make_adapter(engine, scene, args, tmpdir), None
    except engines.Unsupported as exc:
        return None, {"skip": str(exc)}
    except Exception as exc:  # noqa: BLE001  (a broken engine must not stop the rest)
        return None, {"error": describe(exc)}


# --------------------------------------------------------------------------
# measuring
# --------------------------------------------------------------------------


def describe(exc: BaseException) -> str:
    text = f"{type(exc).__name__}: {exc}".splitlines()[0]
    return text[:120]


def time_scene(scene, names, args, tmpdir):
    """Median µs/step per engine and median (over repeats) ratio to pymunk.

    An engine that fails to build, or raises while stepping, is reported as
    ``{"error": ...}``, one that cannot build the scene by design as
    ``{"skip": reason}``, and the others go on.
    """
    adapters, out = {}, {}
    for e in names:
        a, refused = try_adapter(e, scene, args, tmpdir)
        if a is None:
            out[e] = refused
            continue
        adapters[e] = a
        try:
            for _ in range(args.warmup):
                a.step()
        except Exception as exc:  # noqa: BLE001  (a broken engine must not stop the rest)
            out[e] = {"error": describe(exc)}
            adapters.pop(e).close()
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
                per_rep[e].append((t1 - t0) / args.steps / 1e3)  # microseconds per step
    finally:
        for a in adapters.values():
            a.close()
    full = {e: ms for e, ms in per_rep.items() if e not in out}
    for e, us in full.items():
        row = {
            "us": statistics.median(us),
            "us_min": min(us),
            "us_max": max(us),
            "per_repeat": us,
        }
        if "pymunk" in full:
            row["ratio"] = statistics.median(m / p for m, p in zip(us, full["pymunk"], strict=True))
        if e == "phys2d+rec" and "phys2d" in full:
            row["rec_overhead"] = statistics.median(m - p for m, p in zip(us, full["phys2d"], strict=True))
        out[e] = row
    return {e: out[e] for e in names if e in out}


def wrap_angle(a: np.ndarray) -> np.ndarray:
    return np.arctan2(np.sin(a), np.cos(a))


def stability_run(scene, engine, args, tmpdir):
    """Simulate ``args.seconds``; track overlap, movement, tilt and the fall, and for
    scenes with joints the largest joint gap (which joint, when)."""
    a, refused = try_adapter(engine, scene, args, tmpdir)
    if a is None:
        return refused
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
        gap_run, gap_joint, gap_t = 0.0, -1, 0.0
        for i in range(1, n + 1):
            a.step()
            if scene.pins:
                gaps = a.joint_gaps()
                j = int(np.argmax(gaps))
                if gaps[j] > gap_run:
                    gap_run, gap_joint, gap_t = float(gaps[j]), j, i * DT
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
        out = {}
        if scene.pins:
            out = {
                "gap_run": gap_run,
                "gap_joint": gap_joint,
                "gap_t": gap_t,
                "gap_end": float(a.joint_gaps().max()),
                "joints": len(scene.pins),
            }
        return out | {
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
        env = dict(USER_ENV, NUMBA_CACHE_DIR=cache_dir)  # (as a user's: compiling ahead unless told not to)
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


def load_average() -> str:
    """The 1-minute load average, or '?' where the OS does not report it."""
    try:
        return f"{os.getloadavg()[0]:.2f}"
    except (AttributeError, OSError):
        return "?"


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


def speed(t) -> str:
    """A timing result as 'us/step (ratio to pymunk)'."""
    return f"{t['us']:.1f} us" + (f" ({t['ratio']:.2f}x)" if "ratio" in t else "")


def fmt_gap(s) -> str:
    """The largest joint gap of a stability run, in mm."""
    return (
        f"{1e3 * s['gap_run']:.1f} mm (joint {s['gap_joint']} of {s['joints']}, t = {s['gap_t']:.2f} s); "
        f"{1e3 * s['gap_end']:.1f} mm at the end"
    )


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


def cell(per: dict, e: str, fmt) -> str:
    """One engine's table cell: n/a, its skip reason, its error, or fmt(result)."""
    r = per.get(e)
    if r is None:
        return "n/a"
    if "skip" in r:
        return r["skip"]
    if "error" in r:
        return f"error ({r['error']})"
    return fmt(r)


def v3_lines(args, meta) -> list[str]:
    v3 = meta.get("box2d_v3")
    if v3 is None:
        return [f"- Box2D v3: not run ({args.v3_note})"]
    return [
        f"- Box2D v3: {v3['label']}; Box2D reports version {v3['version']}; "
        f"{args.box2d_v3_substeps} sub-steps, sleeping off, one worker, its defaults otherwise",
        f"- Box2D v3 is called through ctypes, one call per step: an empty call on the same path "
        f"costs {v3['call_us']:.2f} µs, included in its times below",
    ]


def report(args, names, timing, stab, first, meta) -> str:
    eng = [e for e in names if e != "phys2d+rec"]
    variants = [e for e in names if e.startswith("phys2d[")]
    m = meta["machine"]
    slop = "default (0.1)" if args.pymunk_slop is None else args.pymunk_slop
    settle = min(args.seconds, SETTLE_SECONDS)
    L = [
        "# Peer benchmark results (issues 7 and 11)",
        "",
        f"- command: `{meta['command']}`",
        f"- date: {meta['date']}",
        f"- checkout: {meta['git']}",
        f"- machine: {m['cpu']}, {m['cores']} cores ({m['usable cores']} usable), " + m["os"],
        f"- load average (1 min) at the start and the end of the run: {meta['load'][0]} and {meta['load'][1]} "
        "(other work on the machine slows the engines unevenly: ratios within a repeat suffer less than times)",
        "- versions: " + ", ".join(f"{k} {v}" for k, v in meta["versions"].items()),
        *v3_lines(args, meta),
        (
            "- settings: dt 1/60, gravity (0, -10), 10 solver iterations (Box2D 2.3: 10 "
            "velocity + 3 position; Box2D v3: sub-steps instead), friction 0.6 per pair, restitution 0, "
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
            "than 30 deg; for scenes with joints, the gap of a pin joint is the distance "
            "between its two anchor points (0 when it holds)"
        ),
        "- `no joints`: a phys2d responder that does not solve joints cannot build the scene",
    ]
    if args.quick:
        L += ["- **quick smoke run**: too few steps for meaningful figures"]

    def section(title, columns, rows):
        L.extend(["", f"## {title}", ""])
        L.extend(table(columns, rows))

    def timing_table(title, fmt):
        rows = [[s] + [cell(per, e, fmt) for e in names] for s, per in timing.items()]
        section(title, ["scene", *names], rows)

    piles = {s: per for s, per in stab.items() if not SCENES[s]().pins}
    chains = {s: per for s, per in stab.items() if SCENES[s]().pins}

    def stab_table(title, fmt, scenes=None):
        scenes = stab if scenes is None else scenes
        if not scenes:
            return
        rows = [[s] + [cell(per, e, fmt) for e in eng] for s, per in scenes.items()]
        section(title, ["scene", *eng], rows)

    timing_table(
        "Microseconds per step (median over repeats; min-max in brackets)",
        lambda t: f"{t['us']:.1f} ({t['us_min']:.1f}-{t['us_max']:.1f})",
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
        piles,
    )
    stab_table(f"Did it fall within {args.seconds:g} s?", fmt_fell, piles)
    stab_table(
        "Largest movement (m) / turn (deg) of any box during the run",
        lambda r: f"{r['max_move']:.3f} / {r['max_turn_deg']:.1f}",
        piles,
    )
    stab_table(
        f"Scenes with joints: largest joint gap during the {args.seconds:g} s run (which joint, when), "
        "and the largest at the end",
        fmt_gap,
        chains,
    )

    rows = []
    for s, per in timing.items():
        p, r = per.get("phys2d"), per.get("phys2d+rec")
        p = None if p and ("error" in p or "skip" in p) else p
        r = None if r and ("error" in r or "skip" in r) else r
        rows.append(
            [
                s,
                f"{p['us'] / 1e3:.3f}" if p else "n/a",
                f"{r['us'] / 1e3:.3f}" if r else "n/a",
                f"{r['rec_overhead'] / 1e3:.3f}" if r and "rec_overhead" in r else "n/a",
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
        ISSUE7_TITLE,
        [
            "measure",
            "issue: Box2D",
            "issue: pymunk",
            "phys2d must reach",
            "this run: Box2D",
            "this run: pymunk",
            "this run: phys2d",
        ]
        + [f"this run: {v}" for v in variants],
        target_rows(timing, stab, first, variants),
    )
    section(
        ISSUE11_TITLE,
        ["measure", "issue 11: Box2D v3 s4", "issue 11: pymunk", "issue 11: phys2d", "target"]
        + [f"this run: {e}" for e in eng],
        issue11_rows(timing, stab, eng),
    )
    L += [
        "",
        "Times in µs per step, ratio to pymunk in brackets. The issue's figures were measured in "
        "another sitting (Box2D v3 617d32ab, pymunk 7.3.1, phys2d a770bfe); compare ratios, not times, "
        "across sittings.",
    ]
    L.append("")
    return "\n".join(L)


ISSUE7_TITLE = "Issue 7 targets against this run"
ISSUE11_TITLE = "Issue 11 targets against this run"


def target_rows(timing, stab, first, variants=()):
    def ratio(s, e):
        t = timing.get(s, {}).get(e)
        return f"{t['ratio']:.2f}x ({t['us'] / 1e3:.2f} ms)" if t and "ratio" in t else "n/a"

    def dx(s, e):
        r = stab.get(s, {}).get(e)
        return f"{r['dx_end']:.3f} m" if r and "dx_end" in r else "n/a"

    rec = timing.get("pyramid_20", {}).get("phys2d+rec")
    rec = None if rec and ("error" in rec or "skip" in rec) else rec
    rec_s = "n/a"
    if rec:
        rec_s = f"{rec['us'] / 1e3:.2f} ms/tick"
        if "rec_overhead" in rec:
            rec_s += f" (recording {rec['rec_overhead'] / 1e3:.2f} ms of it)"
    warm = "n/a"
    if isinstance(first, dict) and first.get("warm"):
        warm = f"{statistics.median(r['first_step'] for r in first['warm']):.2f} s"
    cols = ("Box2D", "pymunk", "phys2d", *variants)
    measured = [
        [ratio("pyramid_20", e) for e in cols],
        [ratio("pyramid_40", e) for e in cols],
        [dx("pyramid_40", e) for e in cols],
        [standing(stab, "vertical_stack_20", e) for e in cols],
        [standing(stab, "mass_ratio_100", e) for e in cols],
        ["-", "-", rec_s] + ["-"] * len(variants),
        ["-", "-", warm] + ["-"] * len(variants),
    ]
    return [list(t) + m for t, m in zip(ISSUE_TARGETS, measured, strict=True)]


def standing(stab, s, e) -> str:
    """'falls at t' or 'stands, sway dx_end (max dx_run)' of one stability run."""
    r = stab.get(s, {}).get(e)
    if not r:
        return "n/a"
    if "skip" in r or "error" in r:
        return r.get("skip") or "error"
    if r["fell"]:
        return f"falls at {r['fell']['t']:.1f} s"
    return f"stands, sway {r['dx_end']:.3f} m (max {r['dx_run']:.3f})"


# Issue 11's figures (Box2D v3 617d32ab, pymunk 7.3.1 and phys2d a770bfe in one sitting).
# (measure, kind, scene, issue: v3 s4, issue: pymunk, issue: phys2d, target)
ISSUE11_TARGETS = [
    (
        "vertical_stack_10, µs/step",
        "time",
        "vertical_stack_10",
        "5.2 (.59)",
        "8.8",
        "PGS 38 (4.4), SoftStep(4) 63 (7.2)",
        "PGS and SoftStep(4) <= 2x pymunk",
    ),
    (
        "pyramid_20, µs/step",
        "time",
        "pyramid_20",
        "120 (.36)",
        "334",
        "PGS 403 (1.20), SoftStep(4) 466 (1.40)",
        "SoftStep(4) <= 1.0x, PGS <= 0.8x pymunk; stretch: within 2x of Box2D v3 s4",
    ),
    (
        "pyramid_40, µs/step",
        "time",
        "pyramid_40",
        "468 (.31)",
        "1529",
        "PGS 1633 (1.06), SoftStep(4) 1827 (1.19)",
        "SoftStep(4) <= 1.0x, PGS <= 0.8x pymunk; stretch: within 2x of Box2D v3 s4",
    ),
    ("mass_ratio_100, µs/step", "time", "mass_ratio_100", "3.3 (1.43)", "2.3", "PGS 32 (14), SoftStep(4) 57 (25)", "-"),
    (
        "vertical_stack_20, box i shifted by 0.1 mm * i, at 30 s",
        "stand",
        "vertical_stack_20_lean_0.1mm",
        "holds, 0.006 m",
        "-",
        "SoftStep(4/6) fall at 9 s, PGS at 3 s",
        "-",
    ),
    (
        "vertical_stack_20, box i shifted by 1 mm * i, at 30 s",
        "stand",
        "vertical_stack_20_lean_1mm",
        "holds, 0.07 m",
        "-",
        "SoftStep(4/6) fall at 6 s, PGS at 3 s",
        "SoftStep(4) stands 30 s, sway < 0.1 m",
    ),
    (
        "pyramid_40, sideways movement at 30 s",
        "dx",
        "pyramid_40",
        "0.030 m",
        "-",
        "PGS 0.117 m, SoftStep(4) 0.050 m, SoftStep(6) 0.004 m",
        "SoftStep(4) < 0.05 m",
    ),
    (
        "mass_ratio_100 at 30 s",
        "stand",
        "mass_ratio_100",
        "holds, 0.005 m",
        "-",
        "SoftStep holds",
        "SoftStep(4) holds, < 0.01 m",
    ),
    (
        "heavy_chain_20: largest joint gap over 30 s (at the end)",
        "gap",
        "heavy_chain_20",
        "-",
        "-",
        "SoftStep has no joints",
        "SoftStep(4) < 1 cm",
    ),
]


def issue11_rows(timing, stab, cols) -> list[list[str]]:
    def measured(kind, s, e):
        if kind == "time":
            t = timing.get(s, {}).get(e)
            if not t or "us" not in t:
                return cell(timing.get(s, {}), e, str)
            return f"{t['us']:.1f}" + (f" ({t['ratio']:.2f})" if "ratio" in t else "")
        r = stab.get(s, {}).get(e)
        if not r or "skip" in r or "error" in r:
            return cell(stab.get(s, {}), e, str)
        if kind == "dx":
            return f"{r['dx_end']:.3f} m"
        if kind == "gap":
            return f"{1e3 * r['gap_run']:.1f} mm ({1e3 * r['gap_end']:.1f} mm)"
        return standing(stab, s, e)

    return [
        [what, v3, pm, p2, target] + [measured(kind, s, e) for e in cols]
        for what, kind, s, v3, pm, p2, target in ISSUE11_TARGETS
    ]


def update_readme(text: str, meta: dict) -> None:
    """Copy the targets tables of a full run into benchmarks/README.md."""
    readme = BENCH_DIR / "README.md"
    start, end = "<!-- results:start -->", "<!-- results:end -->"
    try:
        old = readme.read_text()
        head, rest = old.split(start, 1)
        _, tail = rest.split(end, 1)
    except (OSError, ValueError):
        return
    blocks = []
    for title in (ISSUE11_TITLE, ISSUE7_TITLE):
        part = text.split(f"## {title}", 1)
        if len(part) == 2:
            blocks.append(f"#### {title}\n\n" + part[1].split("\n## ", 1)[0].strip())
    targets = "\n\n".join(blocks)
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
        "--box2d-v3",
        type=Path,
        default=None,
        metavar="PATH",
        help="a Box2D v3 source tree (github.com/erincatto/box2d): build it and our C harness "
        "(box2d_v3_harness.c) and run it as engine Box2D-v3; without it Box2D v3 is skipped",
    )
    p.add_argument(
        "--box2d-v3-substeps",
        type=int,
        default=engines.V3_SUBSTEPS,
        metavar="N",
        help=f"Box2D v3 sub-steps per step (default {engines.V3_SUBSTEPS}, its own default)",
    )
    p.add_argument(
        "--box2d-v3-build",
        type=Path,
        default=box2d_v3.DEFAULT_BUILD_ROOT,
        metavar="DIR",
        help="where to build Box2D v3 (default benchmarks/build/box2d-v3, ignored by git)",
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
    if args.box2d_v3_substeps < 1:
        p.error(f"--box2d-v3-substeps must be >= 1, got {args.box2d_v3_substeps}")
    if args.box2d_v3 is None and "Box2D-v3" in args.engines and args.engines != list(ALL_ENGINES):
        p.error("--engines Box2D-v3 needs a Box2D v3 source tree: --box2d-v3 PATH")
    return args


def setup_box2d_v3(args) -> dict | None:
    """Build and load Box2D v3 if asked (sets args.v3_lib); None and args.v3_note if not."""
    args.v3_lib = None
    if args.box2d_v3 is None:
        args.v3_note = "no source tree given: add --box2d-v3 PATH to include it"
        print(f"Box2D v3: skipped ({args.v3_note})")
        return None
    try:
        build = box2d_v3.build(args.box2d_v3, args.box2d_v3_build)
    except box2d_v3.BuildError as exc:
        sys.exit(f"Box2D v3: {exc}")
    args.v3_lib = engines.load_box2d_v3(build.library)
    probe = engines.Box2DV3Adapter(engines.mass_ratio_100(), args.v3_lib, args.box2d_v3_substeps)
    calls = []
    for _ in range(7):
        t0 = time.perf_counter_ns()
        for _ in range(10000):
            probe.noop()
        calls.append((time.perf_counter_ns() - t0) / 10000 / 1e3)
    probe.close()
    info = {
        "label": build.label(),
        "version": engines.box2d_v3_version(args.v3_lib),
        "commit": build.commit,
        "call_us": statistics.median(calls),
    }
    print(f"Box2D v3: {info['label']}; ctypes call {info['call_us']:.2f} µs")
    return info


# what the field learned after the lecture, each shown beside the lecture's PGS (issue 7)
DEFAULT_VARIANTS = {
    "block": "phys2d.PGS(iterations=10, warm_start=True, block=True)",
    "soft4": "phys2d.SoftStep(substeps=4)",
    "soft6": "phys2d.SoftStep(substeps=6)",
}


def main(argv=None) -> int:
    args = parse_args(argv)
    command = "python " + shlex.join([os.path.relpath(sys.argv[0])] + sys.argv[1:])
    load_start = load_average()
    names = [e for e in ALL_ENGINES if e in args.engines] + list(args.variants)
    v3 = setup_box2d_v3(args)
    if v3 is None and "Box2D-v3" in names:
        names.remove("Box2D-v3")
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
            line = ", ".join(f"{e} {cell(timing[sname], e, speed)}" for e in timing[sname])
            print(f"{sname} ({len(scene.boxes)} boxes) speed: {line}", flush=True)
            stab[sname] = {}
            for e in names:
                if e == "phys2d+rec":  # same physics as phys2d
                    continue
                try:
                    r = stability_run(scene, e, args, tmpdir)
                except Exception as exc:  # noqa: BLE001  (report it, go on)
                    r = {"error": describe(exc)}
                stab[sname][e] = r
                if "error" in r or "skip" in r:
                    print(f"  {e}: {r.get('error') or r.get('skip')}", flush=True)
                    continue
                what = fmt_gap(r) if "gap_run" in r else f"dx {r['dx_end']:.4f} m, {fmt_fell(r)}"
                print(
                    f"  {e}: contacts {r['contacts']}, overlap {1e3 * r['max_overlap']:.1f} mm, {what}",
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
        "load": (load_start, load_average()),
        "versions": versions(),
        "git": git_rev(),
        "box2d_v3": v3,
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
