"""Compiling on two cores (``phys2d.pipeline.ahead``): this process compiles the tick's stages
from the last one up for exactly the types the tick calls them with (else it would compile
code nothing runs), and the child steps a small world of the same responder."""

from __future__ import annotations

import os
import pickle
import subprocess
import sys

import pytest
from numba import config

import phys2d
from phys2d import scenes
from phys2d.collision.recycle import collide_recycling
from phys2d.constraints.joints import start_joint_rows
from phys2d.constraints.rows import contact_rows
from phys2d.contacts import impulses_to_contacts_and_cache
from phys2d.integrate import first_too_fast
from phys2d.pipeline import ahead
from phys2d.pipeline.context import Solver
from phys2d.pipeline.stages import START
from phys2d.pipeline.tick import tick
from phys2d.responders.pgs import pgs_step
from phys2d.responders.soft_step import soft_step_solve

STAGES = (
    collide_recycling, start_joint_rows, contact_rows, impulses_to_contacts_and_cache, first_too_fast, pgs_step,
    soft_step_solve,
)  # fmt: skip


def _tick_args(w: phys2d.World) -> tuple:
    p = w._pipeline
    return (p.context(), p.settings, p.solver, p._counts(w.responder.visit_order, START))


@pytest.mark.skipif(config.DISABLE_JIT, reason="nothing is compiled")
@pytest.mark.fresh_numba_cache
@pytest.mark.xdist_group("fresh_cache")
@pytest.mark.parametrize("world", ["pyramid", "heavy_chain"])
def test_the_stages_are_compiled_for_the_types_the_tick_calls_them_with(fresh_cache_compiles, world):
    """In a fresh process and cache the tick compiles every stage it calls; compiling them again from
    the last one up must then find each already compiled for its types (PGS on a pyramid, and the
    soft step on the heavy chain, with joints): ``tests/fresh_cache.py``, one child for both."""
    again = fresh_cache_compiles[world]["compiled_again"]
    assert again == [], "compiled again, for other types: " + ", ".join(again)


@pytest.mark.skipif(config.DISABLE_JIT, reason="nothing is compiled")
def test_a_warm_cache_is_not_cold_and_an_unknown_type_is():
    w = scenes.pyramid(3)
    w.step(1 / 60)
    args = _tick_args(w)
    assert not ahead.cold(tick, args)
    assert ahead.cold(tick, (*args[:2], Solver(None, None), args[3]))  # a tick with no solve was never compiled


@pytest.mark.parametrize("joints", [False, True])
def test_the_child_steps_a_small_world_of_the_responder(joints):
    child = subprocess.run(
        [sys.executable, "-c", "import phys2d.pipeline.compile_child as c; c.main(); print('stepped')"],
        input=pickle.dumps((phys2d.SoftStep(substeps=2), joints, False, 1)),
        capture_output=True,
        timeout=600,
    )
    assert child.returncode == 0, child.stderr.decode()
    assert child.stdout.decode().strip() == "stepped"


def test_it_is_wanted_unless_turned_off(monkeypatch):
    monkeypatch.setenv("PHYS2D_COMPILE_AHEAD", "0")
    assert not ahead.wanted()
    monkeypatch.setenv("PHYS2D_COMPILE_AHEAD", "1")
    assert ahead.wanted() == ((os.cpu_count() or 1) >= 2)


AHEAD = """
import os
from phys2d import scenes, PGS
from phys2d.pipeline import ahead
from phys2d.pipeline.tick import tick

scenes.pyramid(3, responder=PGS()).step(1 / 60)  # a cold cache: compiled ahead, on two cores
assert ahead.last_plan == "ahead", ahead.last_plan
os.remove(tick._cache._cache_file._index_path)  # as after an edit of the tick: its stages stay cached, it goes
print("ahead")
"""

BEHIND = """
import time
import numpy as np
from phys2d import scenes, PGS
from phys2d.pipeline import ahead

w, ref = scenes.pyramid(4, responder=PGS()), scenes.pyramid(4, responder=PGS())
ref.one_call_tick = False
w.step(1 / 60)
ref.step(1 / 60)
assert ahead.last_plan == "behind", ahead.last_plan
assert not w._pipeline._machine, "the first step went in one call"
start = time.time()
while not w._pipeline._machine:  # until the child has cached the tick
    assert time.time() - start < 900, "the child never finished"
    w.step(1 / 60)
    ref.step(1 / 60)
for _ in range(20):  # in one call from here
    w.step(1 / 60)
    ref.step(1 / 60)
for name in ("x", "theta", "V"):
    assert np.array_equal(getattr(w._bodies, name), getattr(ref._bodies, name)), name
print("behind")
"""


@pytest.mark.skipif(config.DISABLE_JIT, reason="nothing is compiled")
@pytest.mark.fresh_numba_cache
def test_an_edit_steps_in_stages_while_a_child_compiles_the_tick(tmp_path):
    """A first step on a cold cache compiles ahead, on two cores. Then, with the stages cached but
    not the tick (its cache entry removed, as after an edit of it), a new process steps the world
    stage by stage until a child has compiled the tick, then goes on in one call, bit-identical to
    a world that went stage by stage throughout."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path), "PHYS2D_COMPILE_AHEAD": "1"}
    for script, said in ((AHEAD, "ahead"), (BEHIND, "behind")):
        child = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True, timeout=1800)
        assert child.returncode == 0, child.stderr.decode()[-2000:]
        assert child.stdout.decode().split() == [said]


HOLD_THE_LOCK = """
import sys, time
from phys2d.pipeline.ahead import one_child_per_cache
with one_child_per_cache():
    took = time.time()
    print("held", flush=True)
    time.sleep(float(sys.argv[1]))
    left = time.time()
print(took, left, flush=True)
"""


@pytest.mark.skipif(sys.platform == "win32", reason="no fcntl: no lock")
def test_a_second_child_on_one_cache_waits_for_the_first(tmp_path):
    """Two compile children on one numba cache (two runs started close together after an edit)
    take turns: the second holds the cache's lock only after the first let it go."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path), "PHYS2D_COMPILE_AHEAD": "0"}
    run = [sys.executable, "-c", HOLD_THE_LOCK]
    first = subprocess.Popen([*run, "1.5"], stdout=subprocess.PIPE, text=True, env=env)
    assert first.stdout is not None and first.stdout.readline().strip() == "held"
    second = subprocess.run([*run, "0"], capture_output=True, text=True, env=env, timeout=120, check=True)
    out, _ = first.communicate(timeout=120)
    _, first_left = (float(v) for v in out.split())
    second_took, _ = (float(v) for v in second.stdout.split()[-2:])
    assert second_took >= first_left
