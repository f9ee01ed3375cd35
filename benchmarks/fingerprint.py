"""A fingerprint of the engine's results: sha256 of the state after a run of each scene under
each responder, for checking that a change of the code's shape leaves the results bit for bit.

    python benchmarks/fingerprint.py            # one line per scene and responder
    python benchmarks/fingerprint.py > a.txt    # then, after the change: diff a.txt b.txt

Each run steps the world one call at a time (``World.step``) and, for the responders with a
one-call tick, also stage by stage (``one_call_tick = False``): both must give the same
fingerprint. It hashes x, theta, V, the contacts' lambda_n, lambda_t and the joints' impulses.
"""

from __future__ import annotations

import hashlib
import sys

import numpy as np

from phys2d import scenes
from phys2d.responders import make_responder

SCENES = {
    "pyramid_8": lambda r: scenes.pyramid(8, responder=r),
    "mixed_shapes": lambda r: scenes.mixed_shapes(12, responder=r),
    "heavy_chain": lambda r: scenes.heavy_chain(responder=r),
    "mass_ratio": lambda r: scenes.mass_ratio(100.0, responder=r),
    "dominoes": lambda r: scenes.dominoes(12, responder=r),
    "leaning_stack": lambda r: scenes.vertical_stack(10, responder=r, lean=0.001),
    "capsules_on_chain": lambda r: scenes.capsules_on_chain(8, responder=r),
}
RESPONDERS = ("pgs", "pgs-block", "pgs-matrix", "soft-step", "naive", "iterative")
STEPS = 150


def fingerprint(scene: str, responder: str, one_call: bool) -> str:
    """sha256 (16 hex digits) of the state after STEPS steps of 1/60 s."""
    w = SCENES[scene](make_responder(responder))
    w.one_call_tick = one_call
    h = hashlib.sha256()
    for step in range(STEPS):
        w.step(1.0 / 60.0)
        if step % 10 == 9:
            c = w.contacts
            for a in (w.x, w.theta, w.V, c.lambda_n, c.lambda_t, w.last_step.joint_impulses):
                h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()[:16]


def main() -> None:
    chosen = sys.argv[1:] or list(SCENES)
    for scene in chosen:
        for responder in RESPONDERS:
            try:
                one = fingerprint(scene, responder, True)
                staged = fingerprint(scene, responder, False)
            except Exception as error:  # a responder that does not take this scene (joints)
                print(f"{scene:14} {responder:11} {type(error).__name__}")
                continue
            same = "" if one == staged else "  STAGED DIFFERS " + staged
            print(f"{scene:14} {responder:11} {one}{same}", flush=True)


if __name__ == "__main__":
    main()
