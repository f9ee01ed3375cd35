"""Recordings: a World's ticks to a Rerun .rrd file (``Recorder``) and back (``playback``).

``schema`` holds the format (entity paths, field names, units) that both use.
The engine never imports this package; recording only reads a World. ``Recorder``
and ``ContactChoice`` load without rerun (the writing side loads only rerun's native
layer, ``rerun_bindings``; a background recorder only in its writer process);
``playback`` imports rerun's reader when first used.
"""

from . import schema
from .buffer import ContactChoice
from .recorder import Recorder
from .schema import contact_entity

__all__ = ["ContactChoice", "Recorder", "contact_entity", "playback", "schema"]


def __getattr__(name: str):
    if name == "playback":
        import importlib

        return importlib.import_module(f"{__name__}.playback")
    raise AttributeError(f"module 'phys2d.recording' has no attribute {name!r}")
