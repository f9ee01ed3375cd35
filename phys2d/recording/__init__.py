"""Recordings: a World's ticks to a Rerun .rrd file (``Recorder``) and back (``playback``).

``schema`` holds the format (entity paths, field names, units) that both use.
The engine never imports this package; recording only reads a World.
"""

from . import playback, schema
from .buffer import ContactChoice
from .recorder import Recorder
from .schema import contact_entity

__all__ = ["ContactChoice", "Recorder", "contact_entity", "playback", "schema"]
