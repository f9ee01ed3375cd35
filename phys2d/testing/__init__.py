"""Test a responder, yours too, with the project's own tools (needs hypothesis: ``pip install
-e ".[test]"``): ``strategies`` draws valid scenes, bodies and responder settings; ``properties``
holds what every responder must keep, as functions that assert on a generated scene.
``phys2d check`` is the report card on the lecture's claims; these are for your own pytest."""

from . import properties, strategies

__all__ = ["properties", "strategies"]
