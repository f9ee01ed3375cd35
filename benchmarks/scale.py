"""Scale benchmark (issue 28 part 4): the stock scenes and pyramids of base 10 to 100, timed.

    python benchmarks/scale.py --quick                       # a short smoke run, tables to stdout
    python benchmarks/scale.py --out benchmarks/SCALE.md     # the full run (a quiet machine, ~1 h)
    python benchmarks/scale.py --box2d-v3 ~/src/box2d        # plus Box2D v3, 1 and 2 workers
    python benchmarks/scale.py --box2d-v3 ~/src/box2d --repeats 5 --scenes pyramid_20,large_pyramid,many_pyramids
                                   # issue 28's ratios, each taken within a round, and their medians
    python benchmarks/scale.py --box2d-v3 ~/src/box2d --scenes large_pyramid \\
        --engines phys2d-soft4,box2d-v3-1w --paired 30 --steps 10 --warmup 60
                                   # both engines in one process, 30 blocks of 10 steps in turn:
                                   # the ratio per block (a drift of the host falls on both alike)

Engines:

- ``phys2d-pgs``: ``phys2d.PGS()`` (10 sweeps, warm started), ``phys2d-soft4``: ``phys2d.SoftStep(4)``;
  ``phys2d-soft4-2t``, ``phys2d-pgs-2t`` (asked for by ``--engines``): the same on 2 threads (``World.threads``);
- ``pymunk``: the same world, translated body by body (``pymunk_space``): iterations 10, sleeping
  off, each shape's friction sqrt(mu) (Chipmunk multiplies, phys2d mixes sqrt(mu_a mu_b));
  scenes pymunk cannot express (rush's pull, per-body damping or gravity) are skipped;
- ``box2d-v3-1w``, ``box2d-v3-2w`` with ``--box2d-v3 PATH``: Box2D v3 built from that source tree
  (``box2d_v3.build``, as ``peers.py``), on its own benchmark scenes ``large_pyramid`` and
  ``many_pyramids``, built by shared/benchmarks.c's CreateLargePyramid and CreateManyPyramids,
  compiled with ``box2d_v3_scale.c`` into one library; 4 sub-steps, sleeping off, 1 or 2 workers.

Each (scene, engine) runs in a fresh process: build, ``--warmup`` steps (phys2d compiles or
loads its kernels in the first), then ``--steps`` timed steps of 1/60 s. Reported:

    us/step      mean wall time of a timed step, microseconds (and the median)
    ns/contact   us/step over the contact points of the last step, nanoseconds (Box2D v3:
                 over phys2d-soft4's count on the same scene, marked *: the harness does not
                 count v3's points)
    build s      building the scene (World.add_* per body, or the engine's own calls)
    peak MB      the process's peak resident memory (ru_maxrss), and the part of it the
                 scene added: peak minus the resident memory before building (for phys2d
                 this includes the compiled kernels its first step loads, about 70 MB)

Box2D v3's 2 workers run each of its tasks on a thread started for it (box2d_v3_scale.c): a
few thread starts per step, which a pooled task system (Box2D's samples use enkiTS) avoids.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import resource
import statistics
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

# Compile in this process, before anything is timed: after an edit, phys2d by default steps
# stage by stage while a child process compiles the tick beside the timed steps (pipeline.ahead).
os.environ.setdefault("PHYS2D_COMPILE_AHEAD", "0")

BENCH_DIR = Path(__file__).resolve().parent
sys.path.insert(0, str(BENCH_DIR))

DT = 1.0 / 60.0
PYRAMIDS = tuple(range(10, 101, 10))
QUICK_PYRAMIDS = (10, 50, 100)
PHYS2D_ENGINES = ("phys2d-pgs", "phys2d-soft4", "phys2d-soft4-2t", "phys2d-pgs-2t")
THREADS = {"phys2d-soft4-2t": 2, "phys2d-pgs-2t": 2}  # World.threads of an engine (1 when not named)
PEER = {"phys2d-soft4-2t": "box2d-v3-2w", "phys2d-pgs-2t": "box2d-v3-2w"}  # an engine's ratio is against (else 1w)
V3_SCENES = {"large_pyramid": 0, "many_pyramids": 1}  # scale_create's scene argument
V3_ENGINES = {"box2d-v3-1w": 1, "box2d-v3-2w": 2}
V3_SUBSTEPS = 4
SCALE_LIBRARY = "libbox2d_v3_scale.so"


class Unsupported(Exception):
    """An engine that cannot run a scene: its row says why."""


# -- the scenes ----------------------------------------------------------------------------
def scene_names(quick: bool) -> list[str]:
    """The stock scenes of phys2d.stock_scenes, then the pyramids."""
    from phys2d import stock_scenes

    pyramids = QUICK_PYRAMIDS if quick else PYRAMIDS
    return list(stock_scenes.STOCK_SCENES) + [f"pyramid_{n}" for n in pyramids]


def build_phys2d(scene: str, responder):
    """The phys2d world of ``scene`` (a stock scene at its default size, or ``pyramid_N``)."""
    from phys2d import scenes

    if scene.startswith("pyramid_"):
        return scenes.pyramid(int(scene.split("_")[1]), responder=responder)
    return scenes.SCENES[scene][0](responder=responder)


def make_responder(engine: str):
    import phys2d

    return phys2d.PGS() if engine.startswith("phys2d-pgs") else phys2d.SoftStep(substeps=4)


# -- pymunk ----------------------------------------------------------------------------------
def _shared(values, what: str) -> float:
    """The one value every dynamic body has, or Unsupported."""
    import numpy as np

    if values.size and not np.all(values == values[0]):
        raise Unsupported(f"bodies with different {what}: pymunk has one per space")
    return float(values[0]) if values.size else 0.0


def pymunk_space(w):
    """A pymunk Space with w's bodies, shapes and pin joints, in w's body order.

    Each shape gets friction sqrt(mu) (pymunk multiplies the pair's), elasticity e (the
    scenes use 0), phys2d's filter as a ShapeFilter (categories and mask, 32 bits); the
    space gets w's gravity times the bodies' shared gravity_scale and their shared
    damping c as pymunk's per-second factor (1 + c dt)^(-1/dt).
    """
    import numpy as np
    import pymunk

    import phys2d
    from phys2d.constraints.joints import PinJoint

    if type(w) is not phys2d.World:
        raise Unsupported(f"a {type(w).__name__} (a pull applied every step)")
    a = w._bodies
    dynamic = a.M_inv[:, 0] > 0.0
    scale = _shared(a.gravity_scale[dynamic], "gravity_scale")
    linear = _shared(a.damping[dynamic, 0], "linear damping")
    angular = _shared(a.damping[dynamic, 1], "angular damping")
    if linear != angular:
        raise Unsupported("linear and angular damping differ: pymunk has one damping")
    if np.any(a.group != 0):
        raise Unsupported("collision groups")
    space = pymunk.Space()
    space.gravity = (float(w.gravity[0]) * scale, float(w.gravity[1]) * scale)
    space.iterations = 10
    space.sleep_time_threshold = math.inf
    space.damping = (1.0 + linear * DT) ** (-1.0 / DT)
    bodies = []
    for i in range(len(w)):
        if a.kinematic[i]:
            raise Unsupported("kinematic bodies")
        body = pymunk.Body(body_type=pymunk.Body.STATIC) if a.static[i] else pymunk.Body()
        body.position = (float(a.x[i, 0]), float(a.x[i, 1]))
        body.angle = float(a.theta[i])
        if a.kind[i] == 0:
            shape = pymunk.Circle(body, float(a.radius[i]))
        else:
            s, c = int(a.vstart[i]), int(a.vcount[i])
            shape = pymunk.Poly(body, [tuple(map(float, v)) for v in a.local_v[s : s + c]])
        if not a.static[i]:
            shape.mass = float(a.mass[i])  # pymunk's moment follows from the shape and mass
            body.velocity = (float(a.V[i, 0]), float(a.V[i, 1]))
            body.angular_velocity = float(a.V[i, 2])
        shape.friction = math.sqrt(float(a.friction[i]))
        shape.elasticity = float(a.restitution[i])
        shape.filter = pymunk.ShapeFilter(categories=int(a.category[i]) & 0xFFFFFFFF, mask=int(a.mask[i]) & 0xFFFFFFFF)
        space.add(body, shape)
        bodies.append(body)
    for joint in w.joints:
        if not isinstance(joint, PinJoint):
            raise Unsupported(f"{joint.name} joints")
        pj = pymunk.PivotJoint(
            bodies[joint.body_a.index],
            bodies[joint.body_b.index],
            tuple(map(float, joint.local_a)),
            tuple(map(float, joint.local_b)),
        )
        pj.collide_bodies = joint.collide_connected
        space.add(pj)
    return space


def pymunk_contacts(space) -> int:
    """Contact points of the space's arbiters now (an arbiter between two dynamic bodies is on
    both bodies' lists: counted once, as engines.PymunkAdapter does)."""
    seen: set[tuple[int, int]] = set()
    count = 0

    def visit(arbiter) -> None:
        nonlocal count
        a, b = arbiter.shapes
        key = (min(id(a), id(b)), max(id(a), id(b)))
        if key not in seen:
            seen.add(key)
            count += len(arbiter.contact_point_set.points)

    for body in space.bodies:
        body.each_arbiter(visit)
    return count


# -- Box2D v3 --------------------------------------------------------------------------------
def build_v3(source: str, log=print) -> tuple[Path, str]:
    """(the scale library, a label) built from the Box2D v3 tree at ``source``."""
    import box2d_v3

    v3 = box2d_v3.build(Path(source), log=log)
    shared = v3.source / "shared"
    parts = sorted(shared.glob("*.c"))
    if not (shared / "benchmarks.c").is_file():
        raise box2d_v3.BuildError(f"{shared}/benchmarks.c not found: this Box2D v3 has no benchmark scenes")
    static = next((v3.library.parent / "cmake").rglob("libbox2d*.a"))
    library = v3.library.parent / SCALE_LIBRARY
    types = (v3.source / "include" / "box2d" / "types.h").read_text(errors="replace")
    ranges = ["-DSCALE_RANGE_TASKS"] if "int itemCount" in types else []
    cc = os.environ.get("CC", "cc")
    cmd = [
        cc, "-O2", "-DNDEBUG", "-fPIC", "-shared", "-pthread", "-std=gnu17", *ranges,
        "-I", str(v3.source / "include"), "-I", str(shared),
        str(BENCH_DIR / "box2d_v3_scale.c"), *map(str, parts), str(static), "-lm", "-o", str(library),
    ]  # fmt: skip
    done = subprocess.run(cmd, capture_output=True, text=True)
    if done.returncode != 0:
        raise box2d_v3.BuildError(f"compiling box2d_v3_scale.c with shared/*.c failed:\n{done.stderr[-2000:]}")
    return library, v3.label()


def load_v3(path: str):
    import ctypes

    lib = ctypes.CDLL(path)
    p, i, d = ctypes.c_void_p, ctypes.c_int, ctypes.c_double
    for name, res, args in (
        ("scale_create", p, [i, i, i]),
        ("scale_step", None, [p, d]),
        ("scale_body_count", i, [p]),
        ("scale_contact_pairs", i, [p]),
        ("scale_destroy", None, [p]),
    ):
        f = getattr(lib, name)
        f.restype, f.argtypes = res, args
    return lib


# -- one measurement, in a process of its own ---------------------------------------------
def resident_mb() -> float:
    """The process's resident memory now (MB)."""
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20


def peak_mb() -> float:
    """The process's peak resident memory so far (MB; ru_maxrss is in kB on Linux)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


@dataclass
class Built:
    """A scene built in an engine: its step, and what a result row reports of it."""

    step: Callable[[], None]
    bodies: int
    contacts: Callable[[], int]
    build_s: float
    base_mb: float  # resident memory before the scene was built
    contact_pairs: Callable[[], int] | None = None  # Box2D v3's own count


def build(scene: str, engine: str, v3_library: str | None) -> Built:
    """``scene`` built in ``engine``, ready to step (Unsupported if it cannot be)."""
    if engine in PHYS2D_ENGINES:
        import phys2d  # noqa: F401  (imported before the baseline is read)

        base = resident_mb()
        t0 = time.perf_counter()
        w = build_phys2d(scene, make_responder(engine))
        w.threads = THREADS.get(engine, 1)
        return Built(lambda: w.step(DT), len(w), lambda: len(w.contacts), time.perf_counter() - t0, base)
    if engine == "pymunk":
        import pymunk  # noqa: F401

        import phys2d  # noqa: F401

        w = build_phys2d(scene, None)
        base = resident_mb()
        t0 = time.perf_counter()
        space = pymunk_space(w)
        build_s = time.perf_counter() - t0
        del w
        # one shape per body, as in phys2d
        return Built(lambda: space.step(DT), len(space.shapes), lambda: pymunk_contacts(space), build_s, base)
    if scene not in V3_SCENES:
        raise Unsupported("Box2D v3 runs its own benchmark scenes only")
    if v3_library is None:
        raise Unsupported("no --box2d-v3")
    lib = load_v3(v3_library)
    base = resident_mb()
    t0 = time.perf_counter()
    h = lib.scale_create(V3_SCENES[scene], V3_ENGINES[engine], V3_SUBSTEPS)
    if not h:
        raise MemoryError("scale_create failed")
    build_s = time.perf_counter() - t0
    # contacts: -1, filled from phys2d-soft4's count (the harness does not count v3's points)
    return Built(
        lambda: lib.scale_step(h, DT), lib.scale_body_count(h), lambda: -1, build_s, base,
        lambda: lib.scale_contact_pairs(h),
    )  # fmt: skip


def measure(scene: str, engine: str, steps: int, warmup: int, v3_library: str | None) -> dict:
    """Build ``scene`` in ``engine``, run ``warmup`` then ``steps`` timed steps: one result row."""
    row: dict = {"scene": scene, "engine": engine}
    built = build(scene, engine, v3_library)
    row["build_s"] = built.build_s
    for _ in range(warmup):
        built.step()
    times = []
    for _ in range(steps):
        t = time.perf_counter()
        built.step()
        times.append(time.perf_counter() - t)
    row["bodies"] = built.bodies
    row["contacts"] = built.contacts()
    if built.contact_pairs is not None:
        row["contact_pairs"] = built.contact_pairs()
    row["us_per_step"] = 1e6 * sum(times) / len(times)
    row["median_us"] = 1e6 * sorted(times)[len(times) // 2]
    row["peak_mb"] = peak_mb()
    row["scene_mb"] = peak_mb() - built.base_mb
    return row


# -- two engines in one process, block by block ----------------------------------------------
def paired(scene: str, engines: list[str], blocks: int, steps: int, warmup: int, v3_library: str | None) -> str:
    """``scene`` in two engines in this process, stepped in turn: ``warmup`` steps of each, then
    ``blocks`` blocks of ``steps`` timed steps of each, the first engine first in every other
    block. Each block starts with one untimed step (the engine's data back in the caches after
    the other's block), so both engines take the same steps. The ratio is taken block by
    block: a drift of the host within a second falls on both alike. Returns a Markdown table."""
    a, b = (build(scene, e, v3_library) for e in engines)
    for _ in range(warmup):
        a.step()
        b.step()
    per: list[list[float]] = [[], []]
    for i in range(blocks):
        for j in (0, 1) if i % 2 == 0 else (1, 0):
            built = (a, b)[j]
            built.step()
            t0 = time.perf_counter()
            for _ in range(steps):
                built.step()
            per[j].append(1e6 * (time.perf_counter() - t0) / steps)
    ratio = sorted(x / y for x, y in zip(per[0], per[1], strict=True))
    q = statistics.quantiles(ratio, n=4) if len(ratio) > 1 else [ratio[0]] * 3
    head = f"| scene | {engines[0]}, median us | {engines[1]}, median us | ratio: median | quartiles | range |"
    return "\n".join([
        head,
        "| --- | ---: | ---: | ---: | --- | --- |",
        f"| {scene} | {statistics.median(per[0]):,.0f} | {statistics.median(per[1]):,.0f} | {q[1]:.2f}x "
        f"| {q[0]:.2f}-{q[2]:.2f}x | {ratio[0]:.2f}-{ratio[-1]:.2f}x |",
    ])  # fmt: skip


def run_child(args: argparse.Namespace) -> int:
    try:
        row = measure(args.one[0], args.one[1], args.steps, args.warmup, args.v3_library)
    except Unsupported as e:
        row = {"scene": args.one[0], "engine": args.one[1], "unsupported": str(e)}
    print("ROW " + json.dumps(row))
    return 0


# -- the parent: every (scene, engine) in a fresh process, then the tables -------------------
def run_one(scene: str, engine: str, args: argparse.Namespace, v3_library: str | None) -> dict:
    cmd = [sys.executable, __file__, "--one", scene, engine, "--steps", str(args.steps), "--warmup", str(args.warmup)]
    if v3_library:
        cmd += ["--v3-library", v3_library]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=args.timeout)
    rows = [line[4:] for line in done.stdout.splitlines() if line.startswith("ROW ")]
    if done.returncode != 0 or not rows:
        return {"scene": scene, "engine": engine, "error": (done.stderr.strip().splitlines() or ["?"])[-1]}
    return json.loads(rows[-1])


def fill_v3_contacts(rows: list[dict]) -> None:
    """Box2D v3's ns/contact over phys2d-soft4's contact points on the same scene (marked)."""
    soft = {r["scene"]: r.get("contacts") for r in rows if r["engine"] == "phys2d-soft4"}
    for r in rows:
        if r["engine"] in V3_ENGINES and "us_per_step" in r:
            r["contacts"] = soft.get(r["scene"])
            r["contacts_from"] = "phys2d-soft4"


def merge_rounds(rounds: list[list[dict]], names: list[str], engines: list[str]) -> list[dict]:
    """One row per (scene, engine): the median over the rounds of us/step and of the median us,
    the largest peak memory, the rest from the first round that ran it."""
    merged = []
    for scene in names:
        for engine in engines:
            runs = [r for rows in rounds for r in rows if r["scene"] == scene and r["engine"] == engine]
            timed = [r for r in runs if "us_per_step" in r]
            if not runs:
                continue
            if not timed:
                merged.append(runs[0])
                continue
            row = dict(timed[0])
            for field in ("us_per_step", "median_us", "build_s", "scene_mb"):
                row[field] = statistics.median(r[field] for r in timed)
            row["peak_mb"] = max(r["peak_mb"] for r in timed)
            merged.append(row)
    return merged


def ratios(rounds: list[list[dict]], names: list[str]) -> str:
    """Issue 28's ratios, each taken within a round, then their median over the rounds: phys2d's
    time over Box2D v3's (1 worker) on its scenes, and phys2d's ns per contact on large_pyramid over
    its ns per contact on the smallest pyramid run."""

    def times(rows: list[dict]) -> dict[tuple[str, str], dict]:
        return {(r["scene"], r["engine"]): r for r in rows if "us_per_step" in r and r.get("contacts")}

    lines = ["| ratio, within each round | " + " | ".join(f"round {i + 1}" for i in range(len(rounds))) + " | median |"]
    lines.append("| --- |" + " ---: |" * (len(rounds) + 1))

    def add(label: str, values: list[float | None]) -> None:
        got = [v for v in values if v is not None]
        if got:
            cells = [f"{v:.2f}x" if v is not None else "" for v in values]
            lines.append(f"| {label} | " + " | ".join(cells) + f" | {statistics.median(got):.2f}x |")

    def per_contact(r: dict) -> float:
        return r["us_per_step"] / r["contacts"]

    by_round = [times(rows) for rows in rounds]
    for scene in (s for s in names if s in V3_SCENES):
        for engine in PHYS2D_ENGINES:
            peer = PEER.get(engine, "box2d-v3-1w")
            add(
                f"{scene}: {engine} / {peer}",
                [
                    t[(scene, engine)]["us_per_step"] / t[(scene, peer)]["us_per_step"]
                    if (scene, engine) in t and (scene, peer) in t
                    else None
                    for t in by_round
                ],
            )
    small = next((s for s in names if s.startswith("pyramid_")), None)
    if small is not None and "large_pyramid" in names:
        for engine in PHYS2D_ENGINES:
            add(
                f"{engine} ns per contact, {small} -> large_pyramid",
                [
                    per_contact(t[("large_pyramid", engine)]) / per_contact(t[(small, engine)])
                    if (small, engine) in t and ("large_pyramid", engine) in t
                    else None
                    for t in by_round
                ],
            )
    return "\n".join(lines)


def table(rows: list[dict]) -> str:
    head = "| scene | engine | bodies | contacts | us/step | median us | ns/contact | build s | peak MB | scene MB |"
    lines = [head, "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for r in rows:
        if "us_per_step" not in r:
            why = r.get("unsupported") or f"error: {r.get('error')}"
            lines.append(f"| {r['scene']} | {r['engine']} | | | {why} | | | | | |")
            continue
        contacts = r.get("contacts")
        mark = "*" if r.get("contacts_from") else ""
        per = f"{1e3 * r['us_per_step'] / contacts:,.0f}{mark}" if contacts else ""
        lines.append(
            f"| {r['scene']} | {r['engine']} | {r['bodies']:,} | {f'{contacts:,}' if contacts else ''} | "
            f"{r['us_per_step']:,.0f} | {r['median_us']:,.0f} | {per} | {r['build_s']:.2f} | "
            f"{r['peak_mb']:,.0f} | {r['scene_mb']:,.0f} |"
        )
    return "\n".join(lines)


def header(args: argparse.Namespace, v3_label: str | None) -> str:
    import numba
    import numpy

    import phys2d

    try:
        import pymunk

        pm = pymunk.version
    except ImportError:
        pm = "not installed"
    return "\n".join(
        [
            "# Scale benchmark (benchmarks/scale.py)",
            "",
            f"- {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, {platform.machine()}, "
            f"{os.cpu_count()} CPUs, Python {platform.python_version()}, numpy {numpy.__version__}, "
            f"numba {numba.__version__}, phys2d {getattr(phys2d, '__version__', '?')}, pymunk {pm}",
            f"- Box2D v3: {v3_label}" if v3_label else "- Box2D v3: not run (no --box2d-v3)",
            (
                f"- both engines in this process: {args.warmup} warm-up steps of each, then {args.paired} blocks "
                f"of 1 + {args.steps} steps of each in turn (the first untimed), the order swapped every block"
                if args.paired
                else f"- {args.warmup} warm-up steps, then {args.steps} timed steps of 1/60 s; each (scene, engine) "
                "in a fresh process"
            )
            + (" (--quick)" if args.quick else "")
            + (
                f"; {args.repeats} rounds, the engines in reverse order every other round: each figure is the "
                "median over the rounds (peak MB: the largest)"
                if args.repeats > 1 and not args.paired
                else ""
            ),
            "",
        ]
    )


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0], formatter_class=argparse.RawTextHelpFormatter)
    p.add_argument("--quick", action="store_true", help="10 timed steps, pyramids 10, 50 and 100 only")
    p.add_argument("--steps", type=int, default=None, help="timed steps (default 300; --quick: 10)")
    p.add_argument("--warmup", type=int, default=None, help="steps before timing (default 30; --quick: 2)")
    p.add_argument("--scenes", default=None, help="comma-separated scenes (default: all)")
    p.add_argument("--engines", default=None, help="comma-separated engines (default: all available)")
    p.add_argument("--box2d-v3", default=None, metavar="PATH", help="a Box2D v3 source tree to build and run")
    p.add_argument("--out", default=None, help="also write the tables to this Markdown file")
    p.add_argument("--repeats", type=int, default=1, help="rounds of every (scene, engine); medians, ratios per round")
    p.add_argument("--timeout", type=float, default=3600.0, help="seconds per (scene, engine)")
    p.add_argument("--paired", type=int, default=0, metavar="BLOCKS",
                   help="two --engines in one process, BLOCKS blocks of --steps steps each in turn;\n"
                   "the ratio per block, its median and quartiles (``paired``)")  # fmt: skip
    p.add_argument("--one", nargs=2, metavar=("SCENE", "ENGINE"), help=argparse.SUPPRESS)
    p.add_argument("--v3-library", default=None, help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.steps is None:
        args.steps = 10 if args.quick else 300
    if args.warmup is None:
        args.warmup = 2 if args.quick else 30
    if args.steps < 1 or args.warmup < 1:
        p.error("--steps and --warmup must be >= 1 (the first step compiles)")
    if args.repeats < 1:
        p.error("--repeats must be >= 1")
    if args.paired < 0:
        p.error("--paired must be >= 1 blocks (0: not paired)")
    if args.one:
        return run_child(args)
    v3_library = v3_label = None
    if args.box2d_v3:
        library, v3_label = build_v3(args.box2d_v3, log=lambda m: print(m, file=sys.stderr))
        v3_library = str(library)
    names = scene_names(args.quick) if args.scenes is None else args.scenes.split(",")
    engines = ["phys2d-pgs", "phys2d-soft4", "pymunk", *(V3_ENGINES if v3_library else ())]
    if args.engines is not None:
        engines = args.engines.split(",")
    if args.paired:
        if len(engines) != 2:
            p.error("--paired takes two --engines")
        tables = [paired(scene, engines, args.paired, args.steps, args.warmup, v3_library) for scene in names]
        text = header(args, v3_label) + "\n" + "\n\n".join(tables) + "\n"
        print(text)
        if args.out:
            Path(args.out).write_text(text)
        return 0
    rounds: list[list[dict]] = []
    for i in range(args.repeats):
        rows = []
        for scene in names:
            # every other round the engines go in reverse order: a drift of the host falls on each alike
            for engine in engines if i % 2 == 0 else engines[::-1]:
                if engine in V3_ENGINES and scene not in V3_SCENES:
                    continue
                row = run_one(scene, engine, args, v3_library)
                rows.append(row)
                done = f"{row['us_per_step']:,.0f} us/step" if "us_per_step" in row else row.get("unsupported", "error")
                print(f"[{i + 1}/{args.repeats}] {scene} / {engine}: {done}", file=sys.stderr, flush=True)
        fill_v3_contacts(rows)
        rounds.append(rows)
    text = header(args, v3_label) + "\n" + table(merge_rounds(rounds, names, engines)) + "\n"
    if args.repeats > 1:
        text += "\n" + ratios(rounds, names) + "\n"
    print(text)
    if args.out:
        Path(args.out).write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
