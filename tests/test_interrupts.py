"""Ctrl-C while numba compiles stops the program that compiles, not only ``phys2d``'s commands
(``phys2d.interrupts``): a lesson, a notebook or a user's script calls the kernels directly."""

from __future__ import annotations

import time

import pytest
from numba.core import event
from numba.extending import overload

from phys2d import interrupts
from phys2d.jit import njit
from tests.dropped import busy, dropping_callback

COMPILE_REST = 20.0  # s of Python after the drop: the rest of a long compile


def _kernel_whose_compile_drops(then: str, rest: float = COMPILE_REST):
    """A fresh kernel whose compile calls a C callback that raises KeyboardInterrupt (dropped,
    as when Ctrl-C lands while LLVM calls numba back), then goes on in Python for ``rest`` s
    ("goes-on") or fails ("fails": what a cut-short callback leaves, numba's "no compiled object
    yet")."""

    def typed_here() -> int:
        return 0

    @overload(typed_here)
    def _typed_here():  # runs while numba types the kernel: inside its compile
        dropping_callback()()
        if then == "fails":
            raise RuntimeError("no compiled object yet")
        busy(rest)
        return lambda: 0

    @njit
    def kernel() -> int:
        return typed_here()

    return kernel


@pytest.mark.parametrize("then", ["goes-on", "fails"])
def test_an_interrupt_dropped_while_a_kernel_compiles_stops_its_caller(then) -> None:
    kernel = _kernel_whose_compile_drops(then)
    t0 = time.monotonic()
    with pytest.raises(KeyboardInterrupt):
        kernel()
    assert time.monotonic() - t0 < COMPILE_REST / 2  # the compile's rest was not waited for


def test_without_the_guard_the_compile_and_its_caller_go_on(monkeypatch) -> None:
    """The fault itself: with the listener taken off, the dropped interrupt goes nowhere (Python's
    hook sees it), the kernel compiles and runs."""
    (listener,) = interrupts._LISTENER
    event.unregister("numba:compile", listener)
    dropped: list[type] = []
    monkeypatch.setattr("sys.unraisablehook", lambda unraisable: dropped.append(type(unraisable.exc_value)))
    try:
        assert _kernel_whose_compile_drops("goes-on", rest=0.2)() == 0
    finally:
        event.register("numba:compile", listener)
    assert dropped == [KeyboardInterrupt]


def test_the_guard_leaves_other_unraisable_errors_to_the_hook_before_it(monkeypatch) -> None:
    """Only a KeyboardInterrupt is kept; anything else a callback drops goes to the hook that was
    there, as without the guard, and the compile goes on."""
    seen: list[type] = []
    monkeypatch.setattr("sys.unraisablehook", lambda unraisable: seen.append(type(unraisable.exc_value)))
    with interrupts.KeptInterrupts() as kept:
        dropping_callback(ValueError)()
    assert seen == [ValueError] and not kept.lost
