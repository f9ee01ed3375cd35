"""What a fresh process compiles on a fresh numba cache, recorded once for the tests that ask.

Compiling the one-call tick from nothing takes about a minute of CPU per responder, so the
tests whose claim is about what a cold first step compiles share one child process
(``compiles_on_a_fresh_cache``, a session fixture in ``tests/conftest.py``; its tests carry
the ``xdist_group`` mark ``fresh_cache`` so that one pytest-xdist worker runs them all):

  * a pyramid of boxes under PGS: the modules its construction and first step compile
    (``tests/test_capsules_chains.py``: the narrowphase, nothing of ``collision.rounded``), then
    what compiling its stages again from the last one up compiles (``tests/test_ahead.py``:
    nothing, the tick compiled each for the types it calls it with);
  * then the soft step's solve called on its own, first for a world without joints and then with
    them: how many overloads each joint kernel has after each call
    (``tests/test_soft_step_joints.py``: none without joints, numba drops the ``joints is not None``
    branches; one each with them);
  * then the heavy chain under the soft step (joints): the same as for the pyramid, for the soft
    step's tick.

The pyramid comes first, as it did in each test's own child: the soft step's worlds could only
add compiled code before it. Its tick compiles no joint kernel (no joints), so the count without
joints still starts from none.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

CHILD = """
import json
from numba.core import event
from phys2d import scenes, PGS, SoftStep
from phys2d.pipeline import ahead
from phys2d.pipeline.stages import START

compiled = []
class Listener(event.Listener):
    def on_start(self, ev):
        f = ev.data["dispatcher"].py_func
        compiled.append((str(f.__module__), f.__qualname__))
    def on_end(self, ev):
        pass
event.register("numba:compile", Listener())


def joint_overloads():
    # the soft step's solve alone, for a world without joints and then with them: the joint kernels'
    # overloads after each call (a kernel loaded from the cache does not list the kernels compiled
    # into it, hence the fresh cache)
    import numpy as np
    from phys2d.constraints import joints
    from phys2d.constraints.rows import Rows
    from phys2d.pipeline import records
    from phys2d.responders import soft_joints, soft_step
    x, theta, V = np.array([[0.0, 1.0]]), np.zeros(1), np.array([[0.0, -0.1, 0.0]])
    bodies = records.new_bodies((x, theta, V, np.ones((1, 3)), V.copy()))
    rows = Rows(0)
    found = (rows.order, np.zeros(0), np.zeros(0), np.zeros((0, 4)))
    settings = soft_step.SoftStep().settings
    kernels = [soft_joints.prepare_joints, soft_joints.solve_joints, soft_joints.factor_joint_rows,
               soft_joints.solve_factored, soft_joints._equality_rows, joints.joint_rows]
    counts = {}
    for jointed in (False, True):
        joint_record = records.record_of_joints(joints.JointArrays([]), np.zeros(0)) if jointed else None
        n = soft_step.soft_step_solve(bodies, records.record_of_rows(rows), found, joint_record, 1 / 60, settings,
                                      np.zeros(settings.substeps), None)
        counts["with" if jointed else "without"] = {"substeps": n, "overloads": [len(k.overloads) for k in kernels]}
    return counts

out = {}
for name, build in (("pyramid", lambda: scenes.pyramid(3, responder=PGS())),
                    ("heavy_chain", lambda: scenes.heavy_chain(responder=SoftStep()))):
    compiled.clear()
    w = build()
    w.step(1 / 60)  # a cold cache: the tick and every stage it calls compile here, for the tick's types
    first_step = sorted({module for module, _ in compiled})
    p = w._pipeline
    args = (p.context(), p.settings, p.solver, p._counts(w.responder.visit_order, START))
    compiled.clear()
    ahead.compile_from_the_end(p, args)
    out[name] = {"first_step_modules": first_step, "compiled_again": [q for _, q in compiled]}
    if name == "pyramid":
        out["soft_step_solve"] = joint_overloads()
print(json.dumps(out))
"""


def compiles_on_a_fresh_cache(cache: Path) -> dict:
    """Run ``CHILD`` in a fresh process on the empty numba cache ``cache``; its JSON: per world
    ("pyramid", "heavy_chain"), the modules of the kernels its construction and first step
    compiled, and the kernels that compiling its stages from the last one up compiled again; and
    under "soft_step_solve", per call ("without", "with" joints), the sub-steps it returned and
    the joint kernels' overload counts after it."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache), "PHYS2D_COMPILE_AHEAD": "0"}
    child = subprocess.run([sys.executable, "-c", CHILD], env=env, capture_output=True, timeout=1800)
    assert child.returncode == 0, child.stderr.decode()[-2000:]
    return json.loads(child.stdout.decode().splitlines()[-1])
