"""The leaning 20-stack in Box2D v3 and in phys2d, side by side, step by step (issue 11).

    python benchmarks/lean_compare.py --box2d-v3 PATH [--lean 0.001] [--seconds 6] [--every 1]
                                      [--pair 1] [--no-recycle] [--substeps 4]

Builds Box2D v3 from the source tree PATH with our harness (as ``peers.py`` does), puts
the same scene in both engines (box k of 20 shifted sideways by lean * k, dt 1/60,
Box2D v3 and phys2d's SoftStep with the same sub-steps) and prints, every ``--every``
seconds:

- the top box's sideways movement and box ``--pair``'s angle in each engine;
- each contact point between box ``--pair`` - 1 (the ground for 0) and box ``--pair``:
  its lever arms r_a, r_b (m) as each solver used them, its separation (m) and the
  normal impulse of the whole step (N s).

With contact recycling on (both engines' default) the lever arms of a kept manifold
stay as they were found, in both; ``--no-recycle`` turns recycling off in both, and
each step's points are found anew. This is how the leaning stack's fall was traced
to lever arms that turned with the boxes (README, "Speed and stability").
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import box2d_v3  # noqa: E402
import engines  # noqa: E402


def phys2d_points(adapter: engines.Phys2DAdapter, a: int, b: int) -> np.ndarray:
    """(P, 6) rows [r_a x, y, r_b x, y, separation, lambda_n] of phys2d's points between bodies a and b."""
    c = adapter.world.contacts
    mine = np.flatnonzero((c.body_a == a) & (c.body_b == b))
    return np.column_stack([c.anchor[mine], c.separation[mine], c.lambda_n[mine]])


def v3_points(adapter: engines.Box2DV3Adapter, a: int, b: int) -> np.ndarray:
    """(P, 6) rows [anchorA x, y, anchorB x, y, separation, normal impulse of the step] of Box2D v3's."""
    pair, data = adapter.manifold_points()
    mine = np.flatnonzero((pair[:, 0] == a) & (pair[:, 1] == b))
    return data[mine][:, [0, 1, 2, 3, 4, 7]]


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--box2d-v3", type=Path, required=True, metavar="PATH", help="a Box2D v3 source tree")
    p.add_argument("--lean", type=float, default=0.001, help="box k is shifted sideways by lean * k (m)")
    p.add_argument("--seconds", type=float, default=6.0, help="simulated seconds")
    p.add_argument("--every", type=float, default=1.0, help="print every so many simulated seconds")
    p.add_argument("--pair", type=int, default=1, help="show the points under box PAIR (0: on the ground)")
    p.add_argument("--substeps", type=int, default=4, help="sub-steps of both solvers")
    p.add_argument("--no-recycle", action="store_true", help="turn contact recycling off in both engines")
    args = p.parse_args(argv)

    import phys2d

    lib = engines.load_box2d_v3(box2d_v3.build(args.box2d_v3, log=lambda *_: None).library)
    scene = engines.vertical_stack(20, args.lean, "vertical_stack_20_lean")
    v3 = engines.Box2DV3Adapter(scene, lib, substeps=args.substeps)
    ours = engines.Phys2DAdapter(scene, responder=phys2d.SoftStep(substeps=args.substeps))
    if args.no_recycle:
        v3.set_recycle_distance(0.0)
        ours.world.contact_recycle_distance = 0.0
    start = scene.start()
    a, b = args.pair, args.pair + 1  # both engines: the ground is body 0, box k is body k + 1
    every = max(1, round(args.every / engines.DT))
    print(f"lean {args.lean:g} m per box, {args.substeps} sub-steps, recycling {'off' if args.no_recycle else 'on'}")
    print("rows: engine, step, top box dx (m), box angle (rad); then per point r_a, r_b (m), C (m), lambda_n (N s)")
    try:
        for step in range(1, round(args.seconds / engines.DT) + 1):
            v3.step()
            ours.step()
            if step % every:
                continue
            for name, engine, points in (("Box2D v3", v3, v3_points), ("phys2d", ours, phys2d_points)):
                dx = engine.positions()[-1, 0] - start[-1, 0]
                angle = engine.angles()[args.pair]
                print(f"{name:9s} t {step * engines.DT:5.2f} s  top dx {dx:+.4f}  box {args.pair} angle {angle:+.5f}")
                for r in points(engine, a, b):
                    print(
                        f"          r_a ({r[0]:+.5f}, {r[1]:+.5f})  r_b ({r[2]:+.5f}, {r[3]:+.5f})  "
                        f"C {r[4]:+.5f}  lambda_n {r[5]:.4f}"
                    )
    finally:
        v3.close()
        ours.close()


if __name__ == "__main__":
    main()
