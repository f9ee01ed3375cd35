"""phys2d.heap: a tick's scratch arrays reuse the last tick's pages (glibc's top pad)."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import pytest

import phys2d.heap as heap

GLIBC = sys.platform.startswith("linux") and os.confstr("CS_GNU_LIBC_VERSION") is not None

# many_pyramids(8, 8) under SoftStep(4): 3,500 bodies, 18,560 contacts. Without the pad glibc
# handed its freed pages back and took about 640 new ones per tick (measured, PHYS2D_HEAP_PAD=0).
FAULTS_PER_TICK = textwrap.dedent(
    """
    import resource
    import phys2d
    w = phys2d.scenes.many_pyramids(8, columns=8, responder=phys2d.SoftStep())
    for _ in range(20):
        w.step(1 / 60)
    before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
    for _ in range(10):
        w.step(1 / 60)
    print((resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before) / 10)
    """
)


@pytest.mark.skipif(not GLIBC, reason="the pad is glibc's (mallopt M_TOP_PAD)")
def test_a_settled_tick_takes_no_new_pages():
    env = dict(os.environ, PHYS2D_COMPILE_AHEAD="0")
    env.pop("PHYS2D_HEAP_PAD", None)
    out = subprocess.run([sys.executable, "-c", FAULTS_PER_TICK], env=env, capture_output=True, text=True, check=True)
    faults = float(out.stdout.split()[-1])
    assert faults < 20, f"{faults} new pages per tick: the tick's scratch is not kept"


@pytest.mark.skipif(not GLIBC, reason="the pad is glibc's (mallopt M_TOP_PAD)")
def test_the_pad_is_set_once_a_world_exists():
    import phys2d

    phys2d.World()
    assert heap.keep_freed_pages() is True


def test_a_pad_that_is_not_a_number_is_named(monkeypatch):
    monkeypatch.setattr(heap, "_kept", None)
    monkeypatch.setenv("PHYS2D_HEAP_PAD", "lots")
    with pytest.raises(ValueError, match="PHYS2D_HEAP_PAD"):
        heap.keep_freed_pages()
    monkeypatch.setenv("PHYS2D_HEAP_PAD", "0")
    assert heap.keep_freed_pages() is False  # 0: the allocator left as it was
