"""Handing windows of ticks to the writer process through shared memory instead of a pipe.

An anonymous shared mapping made before the writer is forked is seen by both processes.
It is cut into ``SLOTS`` slots of ``SLOT_BYTES``. The simulating process concatenates a
window's arrays straight into a free slot (one copy) and sends only where they lie
(``Ref``, a few hundred bytes over the queue); the writer copies them out and hands the
slot back. Pickling a window and pushing it through a pipe cost pyramid_20 about 0.3 s of
CPU per 600 ticks (52 MB, pickled, written, read and unpickled), and fresh pages for each
copy; the slots are the same pages window after window.

A window too big for a slot (``fits``), or sent while the writer still holds both slots, goes
the old way, pickled with the message: the simulation never waits for the writer.
"""

from __future__ import annotations

import mmap
from dataclasses import dataclass

import numpy as np

SLOTS = 2  # the simulating process fills one slot while the writer empties the other
SLOT_BYTES = 64 << 20  # bytes per slot; pyramid_40's 60-tick window needs about 20 MB
ALIGN = 64  # bytes: every array starts on a cache line


@dataclass(frozen=True)
class Ref:
    """Where an array lies in the arena: slot, byte offset in the slot, dtype (``np.dtype.str``), shape."""

    slot: int
    offset: int
    dtype: str
    shape: tuple[int, ...]


def _aligned(n: int) -> int:
    return -(-n // ALIGN) * ALIGN


class Arena:
    """``slots`` slots of ``slot_bytes`` bytes in one anonymous shared mapping (untouched pages
    cost nothing); make it before forking the writer."""

    def __init__(self, slots: int = SLOTS, slot_bytes: int | None = None) -> None:
        slot_bytes = SLOT_BYTES if slot_bytes is None else slot_bytes
        if slots < 1 or slot_bytes < ALIGN:
            raise ValueError(f"an arena needs slots >= 1 and slot_bytes >= {ALIGN}, got {slots}, {slot_bytes}")
        self.slots = slots
        self.slot_bytes = slot_bytes
        self.map = mmap.mmap(-1, slots * slot_bytes)  # MAP_SHARED | MAP_ANONYMOUS: shared across fork

    def view(self, ref: Ref) -> np.ndarray:
        """The array at ``ref`` (a view into the shared mapping)."""
        return np.ndarray(
            ref.shape, np.dtype(ref.dtype), buffer=self.map, offset=ref.slot * self.slot_bytes + ref.offset
        )

    def fits(self, parts: list[list[np.ndarray]]) -> bool:
        """Whether one slot holds the concatenations of every list of ``parts``."""
        return sum(_aligned(sum(a.nbytes for a in arrays)) for arrays in parts) <= self.slot_bytes


class SlotWriter:
    """Lays arrays one after another into one slot of an arena."""

    def __init__(self, arena: Arena, slot: int) -> None:
        if not 0 <= slot < arena.slots:
            raise ValueError(f"slot must be in 0..{arena.slots - 1}, got {slot}")
        self.arena, self.slot, self.used = arena, slot, 0

    def put(self, arrays: list[np.ndarray]) -> Ref:
        """The concatenation of ``arrays`` (along their first axis) in the slot."""
        dtype = np.result_type(*arrays)
        shape = (sum(a.shape[0] for a in arrays),) + arrays[0].shape[1:]
        nbytes = int(np.prod(shape, dtype=np.int64)) * dtype.itemsize
        if self.used + nbytes > self.arena.slot_bytes:
            raise ValueError(f"{nbytes} bytes do not fit in the slot ({self.used} of {self.arena.slot_bytes} used)")
        ref = Ref(self.slot, self.used, dtype.str, shape)
        np.concatenate(arrays, out=self.arena.view(ref))
        self.used = _aligned(self.used + nbytes)
        return ref
