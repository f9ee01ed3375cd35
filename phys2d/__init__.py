"""phys2d: a 2D rigid-body physics engine for learning collision response.

    import phys2d
    w = phys2d.World(gravity=(0.0, -10.0), responder=phys2d.PGS(iterations=10))
    w.add_box(position=(0.0, -0.5), half_extents=(10.0, 0.5), static=True)
    box = w.add_box(position=(0.0, 2.0), half_extents=(0.5, 0.5))
    for _ in range(120):
        w.step(1 / 60)
"""

from . import scenes
from .bodies import Body
from .contacts import Contacts
from .responders.base import Responder, StepReport
from .responders.pgs import PGS
from .responders.soft_step import SoftStep
from .world import SimulationError, World

__version__ = "0.1.0"

__all__ = ["Body", "Contacts", "PGS", "Responder", "SimulationError", "SoftStep", "StepReport", "World",
           "scenes", "__version__"]
