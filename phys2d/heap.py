"""Keep the C heap's freed pages for the next tick (glibc only).

A tick allocates its scratch arrays afresh: the soft step's per-tick impulses, the
points' separations, the manifolds' blocks (``np.zeros`` inside the kernels), the
rows of new contacts. glibc hands the freed top of its heap back to the operating
system and maps it again on the next tick's first touch, one zeroed 4 KiB page at a
time: on a scene of a hundred thousand contacts, thousands of page faults a step. Box2D
v3 keeps such scratch in an arena for the same reason.

``keep_freed_pages`` asks glibc (``mallopt(M_TOP_PAD)``) to keep a pad of freed pages
at the heap's top instead, and to take blocks up to 32 MB from the heap (the ceiling of
glibc's own sliding threshold, which setting the pad would otherwise fix at 128 KiB), so
a tick of the same size as the last one touches no new page. It changes the process's
allocator, once, when the first ``World`` is made; set ``PHYS2D_HEAP_PAD=0`` (bytes) to
leave the allocator as it was. Elsewhere than glibc it does nothing.
"""

from __future__ import annotations

import ctypes
import os
import sys

M_TOP_PAD = -2  # glibc's malloc.h: the bytes kept at the heap's top when it grows or is trimmed
M_MMAP_THRESHOLD = -3  # glibc's malloc.h: blocks at least this large get pages of their own
MMAP_THRESHOLD = 32 << 20  # bytes: glibc's own ceiling for it (setting the pad fixes it at 128 KiB)
PAD = 64 << 20  # bytes: more than many_pyramids' scratch per tick (about 30 MB)

_kept: bool | None = None  # None: not asked yet


def keep_freed_pages() -> bool:
    """Set glibc's top pad to ``PHYS2D_HEAP_PAD`` bytes (default ``PAD``), once per process.
    Returns whether the allocator now keeps them (False: not glibc, or a pad of 0)."""
    global _kept
    if _kept is None:
        _kept = _set_top_pad()
    return _kept


def _set_top_pad() -> bool:
    raw = os.environ.get("PHYS2D_HEAP_PAD", "")
    try:
        pad = int(raw) if raw.strip() else PAD
    except ValueError:
        raise ValueError(f"PHYS2D_HEAP_PAD must be a whole number of bytes, got {raw!r}") from None
    if pad <= 0 or not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(None)
        mallopt = libc.mallopt
        if not hasattr(libc, "gnu_get_libc_version"):  # musl and others: no M_TOP_PAD
            return False
    except (OSError, AttributeError):
        return False
    mallopt.argtypes = (ctypes.c_int, ctypes.c_int)
    # the arrays up to 32 MB come from the heap, as glibc's sliding threshold would have them
    return mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD) == 1 and mallopt(M_TOP_PAD, min(pad, 2**31 - 1)) == 1


__all__ = ["keep_freed_pages"]
