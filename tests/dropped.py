"""An interrupt dropped in a C callback, for the tests of what keeps it (``phys2d.interrupts``)."""

from __future__ import annotations

import ctypes
import time
from collections.abc import Callable


def dropping_callback(error: type[BaseException] = KeyboardInterrupt) -> Callable[[], None]:
    """A Python function called from C through ctypes, raising ``error`` (KeyboardInterrupt: what a
    signal handler does when Ctrl-C or SIGTERM comes while LLVM calls numba back as it compiles).
    Python cannot raise it out of the callback: it hands it to ``sys.unraisablehook`` and returns."""

    @ctypes.CFUNCTYPE(None)
    def from_c() -> None:
        raise error

    return from_c


def busy(seconds: float) -> None:
    """Python running for ``seconds`` (the rest of a long compile): a resent interrupt lands here."""
    until = time.monotonic() + seconds
    while time.monotonic() < until:
        pass
