"""phys2d: a 2D rigid-body physics engine for learning collision response.

    import phys2d
    w = phys2d.World(gravity=(0.0, -10.0), responder=phys2d.PGS(iterations=10))
    w.add_box(position=(0.0, -0.5), half_extents=(10.0, 0.5), static=True)
    box = w.add_box(position=(0.0, 2.0), half_extents=(0.5, 0.5))
    for _ in range(120):
        w.step(1 / 60)

Recordings: ``phys2d.Recorder`` writes a world's ticks to a Rerun .rrd file and
``phys2d.playback.load`` reads one back (``phys2d.playback.world_at(path, tick)`` re-enters
it: a live World at any logged tick); both are imported on first use, so the engine itself
never loads rerun. ``w.snapshot()`` / ``w.restore(data)`` / ``World.from_snapshot(data)`` and
``w.state_hash()`` rewind a world (``phys2d.snapshot``); ``phys2d.Lab`` shows a world or a
recording on Rerun's viewer in a notebook, to rewind, step and branch it (``phys2d.lab``).
Likewise ``phys2d.sweep`` (a grid of runs to one Parquet table, on a process pool or a Dask
cluster: ``phys2d.sweeps``) loads on first use, so ``import phys2d`` never imports pyarrow or dask; and ``phys2d.check``
(a responder's report card on the lecture's claims: ``phys2d check FILE.py:CLASS``).
"""

# kernel_cache first (isort keeps it so): it stamps numba's cache before any kernel is defined
from . import kernel_cache, scenes  # noqa: F401  (kernel_cache: imported for what it installs)
from .bodies import Body
from .collision import describe_feature
from .collision.queries import RayHit
from .constraints.joints import AngleJoint, DistanceJoint, Joint, MouseJoint, PinJoint, SliderJoint, WeldJoint
from .contacts import Contacts
from .interrupts import keep_interrupts_while_compiling
from .responders import REGISTRY, make_responder
from .responders.base import Responder, SolveResult, StepContext, StepReport
from .responders.iterative import IterativeImpulse
from .responders.naive import NaiveImpulse
from .responders.pgs import PGS
from .responders.soft_step import SoftStep
from .verdict import Verdict, Watch
from .world import SimulationError, World

# Ctrl-C during a numba compile would be lost in LLVM's callbacks, and the program go on
# (``phys2d.interrupts``): every compile keeps it, in lessons and scripts as in ``phys2d``'s commands
keep_interrupts_while_compiling()

__version__ = "0.1.0"

__all__ = [
    "AngleJoint",
    "Body",
    "Contacts",
    "DistanceJoint",
    "IterativeImpulse",
    "Joint",
    "Lab",
    "MouseJoint",
    "NaiveImpulse",
    "PGS",
    "PinJoint",
    "RayHit",
    "REGISTRY",
    "Recorder",
    "Responder",
    "SimulationError",
    "SliderJoint",
    "SoftStep",
    "SolveResult",
    "StepContext",
    "StepReport",
    "Verdict",
    "Watch",
    "WeldJoint",
    "World",
    "check",
    "describe_feature",
    "make_responder",
    "playback",
    "scenes",
    "sweep",
    "__version__",
]


def __getattr__(name: str):
    # recording pulls in rerun (~0.3 s): load it when first asked for
    if name == "Recorder":
        from .recording import Recorder

        return Recorder
    if name == "playback":
        from .recording import playback

        return playback
    if name == "Lab":  # the notebook lab (rerun's reader and viewer load with it)
        from .lab import Lab

        return Lab
    if name == "check":  # the report card (the function; its package is phys2d.checks)
        from .checks import check

        return check
    if name == "sweep":  # the function; its package is phys2d.sweeps
        from .sweeps import sweep

        return sweep
    raise AttributeError(f"module 'phys2d' has no attribute {name!r}")
