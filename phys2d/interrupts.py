"""Ctrl-C while numba compiles: kept, so that it stops the program.

LLVM calls back into Python as numba compiles (through ctypes: the object cache's notices). A
KeyboardInterrupt (Ctrl-C, or SIGTERM where ``phys2d`` turns it into one) that lands inside
such a callback cannot leave it: Python hands it to ``sys.unraisablehook`` ("Exception
ignored") and goes on, and the compile, and the program, carry on as if nothing had been
pressed; or the compile fails later, cut short ("no compiled object yet").

``KeptInterrupts`` keeps such an interrupt within a block and raises it again in the main
thread once the callback has returned. ``keep_interrupts_while_compiling`` puts every numba
compile of the process inside one (a ``numba:compile`` listener), so a lesson, a notebook or a
user's script stops on the first Ctrl-C as ``phys2d``'s commands do; the commands also hold one
around the whole command (``cli.main``).
"""

from __future__ import annotations

import _thread
import sys
import threading
from collections.abc import Callable
from typing import Any

from numba.core import event


class KeptInterrupts:
    """Within the block, a KeyboardInterrupt dropped in a C callback is kept: raised again in the
    main thread once the callback has returned (``_thread.interrupt_main``, RESEND s later), and
    ``raise_if_lost`` raises it at the caller's next safe point should that land in a callback
    too. An error that leaves the block after such a drop (what the cut-short callback left
    behind) leaves it as a KeyboardInterrupt."""

    RESEND = 0.01  # s: a callback's Python part takes microseconds

    def __init__(self) -> None:
        self.lost = False
        self.former: Callable[[Any], Any] | None = None
        self.resend: threading.Timer | None = None

    def __enter__(self) -> KeptInterrupts:
        self.former = sys.unraisablehook
        sys.unraisablehook = self._hook
        return self

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None, *_: object) -> None:
        if self.former is not None:
            sys.unraisablehook = self.former
        self.former = None
        self._cancel()
        if self.lost and kind is not None and not issubclass(kind, KeyboardInterrupt):
            # what the dropped interrupt left behind (numba: "no compiled object yet"): still an interrupt
            raise KeyboardInterrupt from error

    def _hook(self, unraisable: Any) -> None:
        if not isinstance(unraisable.exc_value, KeyboardInterrupt):
            if self.former is not None:
                self.former(unraisable)
            return
        self.lost = True
        if self.resend is None and threading.current_thread() is threading.main_thread():
            self.resend = threading.Timer(self.RESEND, self._resend)
            self.resend.daemon = True
            self.resend.start()

    def _resend(self) -> None:  # (on the timer's thread; a resent interrupt dropped again is resent again)
        self.resend = None
        _thread.interrupt_main()

    def _cancel(self) -> None:
        if self.resend is not None:
            self.resend.cancel()
            self.resend = None

    def raise_if_lost(self) -> None:
        """Raise the KeyboardInterrupt a C callback dropped, if one did."""
        if self.lost:
            self.lost = False
            self._cancel()
            raise KeyboardInterrupt


class _WhileCompiling(event.Listener):
    """A ``KeptInterrupts`` around each outermost numba compile (a compile nests the compiles of
    the kernels it calls; numba's compiler lock keeps one at a time): at its end, a dropped
    interrupt is raised, out of numba, to the code that called the kernel, in place of the
    error a cut-short compile may end with."""

    def __init__(self) -> None:
        self.depth = 0
        self.kept: KeptInterrupts | None = None

    def on_start(self, ev: event.Event) -> None:
        self.depth += 1
        if self.depth == 1:
            self.kept = KeptInterrupts().__enter__()

    def on_end(self, ev: event.Event) -> None:
        self.depth -= 1
        if self.depth > 0 or self.kept is None:
            return
        kept, self.kept = self.kept, None
        kept.__exit__(None, None)
        kept.raise_if_lost()  # (raised while the compile's error, if any, leaves: it takes its place)


_LISTENER: list[_WhileCompiling] = []


def keep_interrupts_while_compiling() -> None:
    """Keep a KeyboardInterrupt dropped during any numba compile of this process (once; phys2d
    calls it on import)."""
    if not _LISTENER:
        _LISTENER.append(_WhileCompiling())
        event.register("numba:compile", _LISTENER[0])


__all__ = ["KeptInterrupts", "keep_interrupts_while_compiling"]
