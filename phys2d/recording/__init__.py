"""Recordings: a World's ticks to a Rerun .rrd file (``Recorder``) and back (``playback``).

The engine never imports this package; recording only reads a World.
"""

from . import playback
from .recorder import Recorder, contact_entity

__all__ = ["Recorder", "contact_entity", "playback"]
