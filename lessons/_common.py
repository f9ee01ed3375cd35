"""What every lesson shares: its command line, stepping a recorded world, printing a table."""

from __future__ import annotations

import argparse
import os

import numpy as np

import phys2d

DT = 1 / 60  # s, one tick


def options(doc: str) -> argparse.Namespace:
    """--quick (a short run, for the tests) and --out DIR (where the .rrd goes)."""
    p = argparse.ArgumentParser(description=doc.strip().splitlines()[0])
    p.add_argument("--quick", action="store_true", help="a short run of a few seconds (for the tests)")
    p.add_argument("--out", default="recordings", help="folder for the recording (default: recordings/)")
    return p.parse_args()


def recorder(args: argparse.Namespace, script: str, name: str) -> phys2d.Recorder:
    """A Recorder writing <out>/<lesson>.rrd, named for the viewer."""
    path = os.path.join(args.out, os.path.splitext(os.path.basename(script))[0] + ".rrd")
    return phys2d.Recorder(path, name=name)


def simulate(w: phys2d.World, seconds: float, rec=None, run: str | None = None, probe=None,
             dt: float = DT) -> np.ndarray:
    """Step w for ``seconds``, logging each tick to rec (as ``run``); returns probe(w) per tick."""
    out = []
    for _ in range(round(seconds / dt)):
        w.step(dt)
        if rec is not None:
            rec.log(w, run=run)
        if probe is not None:
            out.append(probe(w))
    return np.asarray(out, dtype=np.float64)


def claim(text: str) -> None:
    print(f"CLAIM: {text}")


def table(header: list[str], rows: list[list], fmt: str = "{:.4g}") -> None:
    """Print rows under header, columns aligned; numbers go through fmt."""
    cells = [header] + [[c if isinstance(c, str) else fmt.format(c) for c in r] for r in rows]
    widths = [max(len(r[k]) for r in cells) for k in range(len(header))]
    for r in cells:
        print("  " + "  ".join(c.rjust(w) if k else c.ljust(w) for k, (c, w) in enumerate(zip(r, widths))))


def done(rec) -> None:
    print(f"recording: {rec.path}  (open it with: rerun {rec.path})")


# -- the scenes of lessons 1 and 2 ------------------------------------------------------------
def dropped_boxes(responder) -> phys2d.World:
    """Three 1 m boxes dropped from 1 m at angles 0, 0.3 and 0.6 rad onto the ground."""
    w = phys2d.World(responder=responder)
    phys2d.scenes.ground(w)
    for k in range(3):
        w.add_box(position=(3.0 * k - 3.0, 1.5), half_extents=(0.5, 0.5), angle=0.3 * k)
    return w


def zigzag_stack(responder, n: int = 8) -> phys2d.World:
    """n 1 m boxes in a column, every other one 2 cm to the right (as a hand would stack them)."""
    w = phys2d.World(responder=responder)
    phys2d.scenes.ground(w)
    for k in range(n):
        w.add_box(position=(0.02 * (k % 2), 0.5 + k), half_extents=(0.5, 0.5))
    return w


def standing(w: phys2d.World, y0: np.ndarray) -> int:
    """How many dynamic bodies are within 0.25 m of the height they started at."""
    return int(np.sum(np.abs(w.x[1:, 1] - y0[1:]) < 0.25))
