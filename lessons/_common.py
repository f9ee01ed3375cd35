"""What every lesson shares: its command line, stepping a recorded world, printing a table.

A lesson is a script and, opened in Jupyter, a notebook (jupytext reads the .py as
it is: ``pip install -e ".[notebook]"``, then open the .py as a notebook). In a
notebook this module stands in for what a script gets from its command line:

- ``__file__`` is set in the notebook's namespace to the lesson's .py (from
  ``PHYS2D_LESSON``, else the notebook's own name, ``JPY_SESSION_NAME``);
- the options come from ``PHYS2D_LESSON_ARGS`` (e.g. ``--quick``) instead of argv,
  and recordings go to the repository's recordings/ folder;
- ``done`` shows the lesson's recording in an inline Rerun viewer (rerun-notebook).
"""

from __future__ import annotations

import argparse
import os
import shlex
import subprocess
import sys
import tempfile
import uuid

import numpy as np

import phys2d

DT = 1 / 60  # s, one tick
LESSONS = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(LESSONS)


def in_notebook() -> bool:
    """Whether this runs in a Jupyter kernel (a lesson opened as a notebook)."""
    shell = sys.modules["IPython"].get_ipython() if "IPython" in sys.modules else None
    return shell is not None and hasattr(shell, "kernel")


def _notebook_file() -> str:
    """The .py of the lesson this notebook is (PHYS2D_LESSON, the notebook's name, or a stand-in)."""
    shell = sys.modules["IPython"].get_ipython()
    for given in (
        os.environ.get("PHYS2D_LESSON"),
        os.environ.get("JPY_SESSION_NAME"),
        shell.user_ns.get("__vsc_ipynb_file__"),
    ):
        stem = os.path.splitext(os.path.basename(given or ""))[0]
        if stem:
            return os.path.join(LESSONS, stem + ".py")
    return os.path.join(LESSONS, "notebook.py")


if in_notebook():  # give the notebook the __file__ its script has (lessons name their recording after it)
    sys.modules["IPython"].get_ipython().user_ns.setdefault("__file__", _notebook_file())


def options(doc: str | None) -> argparse.Namespace:
    """--quick (a short run, for the tests) and --out DIR (where the .rrd goes).

    In a notebook the arguments come from the environment variable PHYS2D_LESSON_ARGS.
    """
    lines = (doc or "").strip().splitlines()
    p = argparse.ArgumentParser(description=lines[0] if lines else None)
    p.add_argument("--quick", action="store_true", help="a short run of a few seconds (for the tests)")
    p.add_argument(
        "--out",
        default=os.path.join(ROOT, "recordings") if in_notebook() else "recordings",
        help="folder for the recording (default: recordings/)",
    )
    if in_notebook():
        return p.parse_args(shlex.split(os.environ.get("PHYS2D_LESSON_ARGS", "")))
    return p.parse_args()


def recorder(args: argparse.Namespace, script: str, name: str, **kwargs) -> phys2d.Recorder:
    """A Recorder writing <out>/<lesson>.rrd, named for the viewer (kwargs go to phys2d.Recorder)."""
    path = os.path.join(args.out, os.path.splitext(os.path.basename(script))[0] + ".rrd")
    return phys2d.Recorder(path, name=name, **kwargs)


def add_images(path: str, recording_id: str, images: dict[str, str]) -> None:
    """Log PNG files (entity path -> file) into the closed recording ``path`` of ``recording_id``.

    They are written as a second recording with the same id, then merged into the
    file with ``rerun rrd merge`` (the rerun binary that rerun-sdk ships).
    """
    import rerun as rr
    import rerun_cli

    with tempfile.TemporaryDirectory() as tmp:
        part = os.path.join(tmp, "images.rrd")
        stream = rr.RecordingStream("phys2d", recording_id=recording_id)
        stream.save(part)
        stream.set_log_time_enabled(False)
        for entity, png in images.items():
            stream.log(entity, rr.EncodedImage(path=png), static=True)
        stream.flush()
        stream.disconnect()
        merged = os.path.join(tmp, "merged.rrd")
        exe = os.path.join(os.path.dirname(rerun_cli.__file__), "rerun")
        with open(merged, "wb") as out:
            subprocess.run([exe, "rrd", "merge", path, part], stdout=out, stderr=subprocess.DEVNULL, check=True)
        os.replace(merged, path)


def new_recording_id() -> str:
    return str(uuid.uuid4())


def simulate(
    w: phys2d.World, seconds: float, rec=None, run: str | None = None, probe=None, dt: float = DT
) -> np.ndarray:
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
    if in_notebook():
        show(rec.path)


def show(path: str, height: int = 640) -> None:
    """In a notebook, the recording at ``path`` in an inline Rerun viewer (needs rerun-notebook)."""
    try:
        from rerun_notebook import Viewer
    except ImportError:
        print('(the inline viewer needs rerun-notebook: pip install -e ".[notebook]")')
        return
    from IPython.display import display

    viewer = Viewer(width="auto", height=height)
    display(viewer)
    with open(path, "rb") as fh:
        viewer.send_rrd(fh.read())  # queued until the viewer has loaded in the browser


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
