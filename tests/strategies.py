"""The strategies and helpers the property tests share: ``phys2d.testing.strategies``, where
they live so that a student's own tests can use them too."""

from phys2d.testing.strategies import *  # noqa: F403
from phys2d.testing.strategies import RESPONDER_SETTINGS, _with_warm_start  # noqa: F401
