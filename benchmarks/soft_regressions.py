"""The soft step's two figures of issue 41 (item 9), in phys2d and in Box2D v3, on the same scenes.

    python benchmarks/soft_regressions.py                          # this checkout's phys2d
    python benchmarks/soft_regressions.py --phys2d /tmp/wt-old     # another checkout's phys2d
    python benchmarks/soft_regressions.py --box2d-v3 PATH          # and Box2D v3 (built as peers.py does)
    python benchmarks/soft_regressions.py --figure launch --scene overlap_pyramid_6 --substeps 4 --bare

Two figures, each the largest of any box:

- launch: the fastest any box moves (linear speed |v|, m/s, read after each step) over 3 s
  of boxes that start 40 % into each other; the push-out speed ``push_max`` is 3 m/s in
  both engines, so a box much faster than that was launched, not pushed out. Three layouts
  of six 1 m boxes on the ground, each box 0.4 m into its neighbours:
    overlap_pyramid_6  Box2D's "Overlap Recovery" sample with base 3 and overlap 0.4
                       (``phys2d.stock_scenes.overlap_recovery(3, overlap=0.4)``): rows of
                       3, 2, 1 boxes, 0.6 m apart, each row 0.6 m above the one below;
    overlap_stack_6    one column: box k centred at (0, 0.5 + 0.6 k);
    overlap_row_6      one row on the ground: box k centred at (0.6 k - 1.5, 0.5).
- drift: the largest sideways movement |x - x0| (m) of any box of pyramid_40 (peers.py's
  scene, ``phys2d.scenes.pyramid(40)``) at 30 s, as peers.py measures it; the project's
  bar since issue 11 is 0.05 m. A pile of 820 boxes is chaotic: ``--jitter N`` also runs N
  copies whose boxes start up to ``--jitter-size`` (m, 1e-12 by default: the last bits of
  phys2d's doubles; Box2D v3 keeps positions in floats, for which 1e-5 is a few ulps) to
  the side of their places (seeds 1 to N), to show how far the figure moves when the start
  barely does.

Every scene is ``engines.Scene`` data, so phys2d (``SoftStep(substeps)``) and Box2D v3
(``b2World_Step(dt, substeps)``, its defaults: contact hertz 30, damping ratio 10, push-out
3 m/s) build the same bodies: ground, friction 0.6, density 1, dt 1/60. ``--phys2d PATH``
imports phys2d from another checkout (for comparing commits and ``git bisect run``); this
script and ``engines.py`` come from this folder. ``--bare`` prints the one figure asked for.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

BENCH_DIR = Path(__file__).resolve().parent
sys.path.insert(0, str(BENCH_DIR))

import box2d_v3  # noqa: E402
import engines  # noqa: E402

OVERLAP = 0.4  # of a box's width
SIDE = 1.0 - OVERLAP  # m between neighbouring centres (1 m boxes)
LAUNCH_SECONDS = 3.0
DRIFT_SECONDS = 30.0


def overlap_pyramid(base: int = 3) -> engines.Scene:
    """``stock_scenes.overlap_recovery(base, overlap=OVERLAP)``'s boxes: row i holds base - i boxes
    from x = SIDE / 2 (i - base), SIDE apart, at y = 0.5 + SIDE i."""
    boxes = [
        engines.Box(0.5 * SIDE * (i - base) + SIDE * k, 0.5 + SIDE * i, 0.5, 0.5)
        for i in range(base)
        for k in range(base - i)
    ]
    return engines.Scene(f"overlap_pyramid_{len(boxes)}", tuple(boxes))


def overlap_stack(n: int = 6) -> engines.Scene:
    """n boxes in a column, box k at (0, 0.5 + SIDE k): each 0.4 m into the one below."""
    return engines.Scene(f"overlap_stack_{n}", tuple(engines.Box(0.0, 0.5 + SIDE * k, 0.5, 0.5) for k in range(n)))


def overlap_row(n: int = 6) -> engines.Scene:
    """n boxes in a row on the ground, box k at (SIDE (k - (n - 1) / 2), 0.5)."""
    return engines.Scene(
        f"overlap_row_{n}", tuple(engines.Box(SIDE * (k - 0.5 * (n - 1)), 0.5, 0.5, 0.5) for k in range(n))
    )


LAUNCH_SCENES = {s.name: s for s in (overlap_pyramid(), overlap_stack(), overlap_row())}


def jittered(scene: engines.Scene, seed: int, size: float) -> engines.Scene:
    """``scene`` with each box's start moved sideways by up to ``size`` (m; uniform, from ``seed``)."""
    dx = np.random.default_rng(seed).uniform(-size, size, len(scene.boxes))
    boxes = tuple(engines.Box(b.x + float(d), b.y, b.hw, b.hh, b.density) for b, d in zip(scene.boxes, dx))
    return engines.Scene(f"{scene.name}_jitter_{seed}", boxes)


def launch(adapter, steps: int) -> tuple[float, int, float]:
    """(the largest |v| of any box after any of ``steps`` steps (m/s), which box, when (s))."""
    fastest, box, when = 0.0, -1, 0.0
    for i in range(1, steps + 1):
        adapter.step()
        v = adapter.velocities()
        speed = np.hypot(v[:, 0], v[:, 1])
        j = int(np.argmax(speed))
        if speed[j] > fastest:
            fastest, box, when = float(speed[j]), j, i * engines.DT
    return fastest, box, when


def drift(adapter, scene: engines.Scene, steps: int) -> float:
    """The largest |x - x0| (m) of any box after ``steps`` steps."""
    for _ in range(steps):
        adapter.step()
    return float(np.abs(adapter.positions()[:, 0] - scene.start()[:, 0]).max())


def make(engine: str, scene: engines.Scene, substeps: int, lib):
    """An adapter of ``engine`` ("phys2d" or "Box2D-v3") for ``scene`` at ``substeps``."""
    if engine == "phys2d":
        import phys2d

        return engines.Phys2DAdapter(scene, responder=phys2d.SoftStep(substeps=substeps))
    return engines.Box2DV3Adapter(scene, lib, substeps=substeps)


def rows_of(engine: str, args: argparse.Namespace, lib, log) -> list[list[str]]:
    """One row per figure, scene and sub-step count: [figure, scene, engine, substeps, value, where]."""
    figures, scenes, substeps = args.figure, args.scene, args.substeps
    rows = []
    if "launch" in figures:
        for name in scenes:
            for n in substeps:
                a = make(engine, LAUNCH_SCENES[name], n, lib)
                fastest, box, when = launch(a, round(LAUNCH_SECONDS / engines.DT))
                a.close()
                rows.append(["launch", name, engine, str(n), f"{fastest:.3f}", f"box {box} at {when:.3f} s"])
                log(rows[-1])
    if "drift" in figures:
        steps = round(DRIFT_SECONDS / engines.DT)
        for n in substeps:
            scene = engines.pyramid(40)
            a = make(engine, scene, n, lib)
            rows.append(["drift", scene.name, engine, str(n), f"{drift(a, scene, steps):.4f}", "at 30 s"])
            a.close()
            log(rows[-1])
            if args.jitter > 0:
                figures = []
                for seed in range(1, args.jitter + 1):
                    scene = jittered(engines.pyramid(40), seed, args.jitter_size)
                    a = make(engine, scene, n, lib)
                    figures.append(drift(a, scene, steps))
                    a.close()
                where = f"{args.jitter} starts jittered by {args.jitter_size:g} m: " + " ".join(
                    f"{f:.4f}" for f in figures
                )
                rows.append(["drift", "pyramid_40 jittered", engine, str(n), f"{np.median(figures):.4f}", where])
                log(rows[-1])
    return rows


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--phys2d", type=Path, metavar="ROOT", help="import phys2d from this checkout (default: this one)")
    p.add_argument("--box2d-v3", type=Path, metavar="PATH", help="also run Box2D v3 built from this source tree")
    p.add_argument("--figure", choices=("launch", "drift"), nargs="+", default=["launch", "drift"])
    p.add_argument("--scene", choices=sorted(LAUNCH_SCENES), nargs="+", default=list(LAUNCH_SCENES))
    p.add_argument("--substeps", type=int, nargs="+", default=[4, 6])
    p.add_argument("--jitter", type=int, default=0, metavar="N", help="drift: also N jittered pyramids (median)")
    p.add_argument("--jitter-size", type=float, default=1e-12, metavar="M", help="the jitter's largest shift (m)")
    p.add_argument("--bare", action="store_true", help="print only the figures, one a line")
    args = p.parse_args(argv)
    sys.path.insert(0, str((args.phys2d or BENCH_DIR.parent).resolve()))
    import phys2d

    log = (lambda row: None) if args.bare else (lambda row: print(" | ".join(row), flush=True))
    if not args.bare:
        print(f"phys2d from {Path(phys2d.__file__).parent}")
    rows = rows_of("phys2d", args, None, log)
    if args.box2d_v3 is not None:
        build = box2d_v3.build(args.box2d_v3, log=lambda *_: None)
        if not args.bare:
            print(f"Box2D v3: {build.label()}")
        lib = engines.load_box2d_v3(build.library)
        rows += rows_of("Box2D-v3", args, lib, log)
    if args.bare:
        for row in rows:
            print(row[4])
    return 0


if __name__ == "__main__":
    sys.exit(main())
