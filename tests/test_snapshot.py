"""Snapshots (``phys2d.snapshot``): a world's state to bytes and back, bit for bit, and its hash.

The fingerprint (``phys2d.testing.strategies.fingerprint``) holds every array of a world, its
contacts, cache, manifolds, joints and last report: equal fingerprints are bit-identical worlds.
A world's future is compared step by step: a step refused (SimulationError) counts as an
outcome too, by its message.
"""

from __future__ import annotations

import copy
import json
import os
import pickle
import subprocess
import sys
import zlib

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import phys2d
from phys2d import snapshot as snap
from phys2d import stock_scenes
from tests.strategies import build, dts, fingerprint, responders, scenes

DT = 1 / 60
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def future(w: phys2d.World, steps: int, dt: float = DT) -> list:
    """The world's fingerprint after each of ``steps`` steps (a refused step: its message)."""
    out = []
    for _ in range(steps):
        try:
            w.step(dt)
            out.append(fingerprint(w))
        except phys2d.SimulationError as e:
            out.append(("refused", str(e)))
    return out


def stepped(w: phys2d.World, steps: int, dt: float = DT) -> phys2d.World:
    for _ in range(steps):
        w.step(dt)
    return w


def rewritten(data: bytes, change) -> bytes:
    """The image with ``change(meta)`` applied to its JSON part and a CRC-32 that matches again: an
    image this phys2d would have written, but for the change."""
    _, fmt, head_len, body_len, _ = snap.HEADER.unpack_from(data)
    start = snap.HEADER.size
    meta = json.loads(data[start : start + head_len])
    change(meta)
    head = json.dumps(meta, separators=(",", ":")).encode()
    head += b" " * (-len(head) % snap.ALIGN)
    rest = head + data[start + head_len :]
    return snap.HEADER.pack(snap.MAGIC, fmt, len(head), body_len, zlib.crc32(rest)) + rest


# -- the property: snapshot, step on, restore, step again ------------------------------------------
@settings(max_examples=20)
@given(
    scene=scenes(min_bodies=1, max_bodies=6, ground=None, static=None),
    responder=responders(),
    dt=dts,
    before=st.integers(0, 15),
    after=st.integers(1, 20),
)
def test_restore_gives_the_future_the_world_had(scene, responder, dt, before, after):
    """Snapshot between steps, step on, restore, step again: the same bits after every step; and
    from_snapshot, pickle and deepcopy of the world at the snapshot give those bits too."""
    w = build(scene, responder)
    future(w, before, dt)
    data = w.snapshot()
    copies = [phys2d.World.from_snapshot(data), pickle.loads(pickle.dumps(w)), copy.deepcopy(w)]
    assert all(fingerprint(c) == fingerprint(w) for c in copies)
    first = future(w, after, dt)
    w.restore(data)
    assert future(w, after, dt) == first
    for c in copies:
        assert future(c, after, dt) == first


def _sleeping_pyramid() -> phys2d.World:
    w = phys2d.scenes.pyramid(4)
    w.sleep = True
    stepped(w, 90)  # a pyramid at rest falls asleep after 0.5 s of rest
    assert w.body_asleep[1:].all()
    w.bodies[-1].apply_impulse((0.5, 0.0))  # the top box wakes its island: it slides
    stepped(w, 3)
    return w


def _mouse() -> phys2d.World:
    w = phys2d.scenes.pyramid(3)
    w.add_mouse_joint(w.bodies[-1], target=(0.0, 3.0), max_force=200.0)
    return w


def _threads() -> phys2d.World:
    w = phys2d.scenes.pyramid(6)
    w.threads = 2
    return w


def _stages() -> phys2d.World:
    w = phys2d.scenes.pyramid(4, responder=phys2d.SoftStep())
    w.one_call_tick = False
    return w


def _forces() -> phys2d.World:
    w = phys2d.scenes.pyramid(3)
    w.bodies[2].apply_force((30.0, 0.0))  # pending for the next step: in the snapshot
    w.bodies[3].linear_damping = 0.5
    return w


WORLDS = {
    "joints, PGS": lambda: phys2d.scenes.pendulum_chain(6),
    "joints, soft step": lambda: phys2d.scenes.pendulum_chain(6, responder=phys2d.SoftStep()),
    "motors and limits": lambda: stock_scenes.car(20.0),
    "ragdolls": lambda: stock_scenes.ragdoll(1),
    "capsules on a chain": lambda: phys2d.scenes.capsules_on_chain(4),
    "sleeping islands": _sleeping_pyramid,
    "mouse joint": _mouse,
    "threads=2": _threads,
    "stage by stage": _stages,
    "naive": lambda: phys2d.scenes.pyramid(3, responder=phys2d.NaiveImpulse()),
    "pgs-matrix": lambda: phys2d.scenes.pyramid(3, responder=phys2d.make_responder("pgs-matrix")),
    "pending force": _forces,
}


@pytest.mark.parametrize("name", list(WORLDS))
def test_restore_gives_the_same_future_in_every_kind_of_world(name):
    w = WORLDS[name]()
    stepped(w, 20)
    data = w.snapshot()
    twin = phys2d.World.from_snapshot(data)
    first = future(w, 40)
    w.restore(data)
    assert future(w, 40) == first == future(twin, 40)


def test_a_sleeping_island_keeps_its_cache_through_a_snapshot():
    """Islands asleep at the snapshot wake alike: their kept caches warm start the same contacts."""
    w = phys2d.scenes.pyramid(4)
    w.sleep = True
    stepped(w, 90)
    assert w.body_asleep[1:].all() and w._islands.kept
    twin = phys2d.World.from_snapshot(w.snapshot())
    for x in (w, twin):
        x.bodies[-1].apply_impulse((0.2, 0.0))
    a, b = future(w, 5), future(twin, 5)
    assert a == b
    assert w.last_step.cache_hits > 0  # the woken island's first steps were warm started


def test_changes_made_after_the_snapshot_are_undone():
    """Settings, responder, joints and bodies changed after a snapshot are as they were after restore."""
    w = phys2d.scenes.pendulum_chain(4)
    stepped(w, 10)
    before = fingerprint(w)
    data = w.snapshot()
    w.gravity = (1.0, -3.0)
    w.contact_margin = 0.05
    w.responder = phys2d.SoftStep(substeps=2)
    w.remove(w.joints[1])
    w.add_box((5.0, 5.0))
    w.remove(w.bodies[2])
    w.threads = 2
    stepped(w, 3)
    w.restore(data)
    assert fingerprint(w) == before
    assert w.threads == 1 and w.contact_margin == 0.02 and repr(w.responder) == repr(phys2d.PGS())


# -- handles ------------------------------------------------------------------------------------
def test_handles_of_then_work_again_and_those_made_since_are_dead():
    w = phys2d.scenes.pendulum_chain(3)
    stepped(w, 5)
    bodies, joints = w.bodies, w.joints
    data = w.snapshot()
    w.remove(bodies[2])  # and its joints with it
    late_body = w.add_circle((4.0, 4.0))
    late_joint = w.add_distance_joint(bodies[1], late_body)
    assert not bodies[2].alive and not all(j.alive for j in joints)
    w.restore(data)
    assert w.bodies == bodies and all(a is b for a, b in zip(w.bodies, bodies))
    assert all(a is b for a, b in zip(w.joints, joints)) and all(j.alive for j in joints)
    assert bodies[2].alive and bodies[2].index == 2
    assert all(any(j.body_a is h for h in bodies) and any(j.body_b is h for h in bodies) for j in joints)
    assert not late_body.alive and not late_joint.alive
    bodies[2].velocity = (1.0, 0.0)  # a revived handle moves its body
    assert w.V[2, 0] == 1.0
    assert joints[1].impulse.shape == (2,)


def test_restore_into_another_world_makes_new_handles():
    a = stepped(phys2d.scenes.pyramid(3), 5)
    b = phys2d.scenes.pendulum_chain(3)
    old = b.bodies
    b.restore(a.snapshot())
    assert fingerprint(b) == fingerprint(a)
    assert not any(h.alive for h in old)
    assert [h.index for h in b.bodies] == list(range(len(a)))
    assert all(h.world is b for h in b.bodies)


def test_a_world_made_from_a_snapshot_takes_its_lineage_on():
    """A world made from a snapshot and restored from a later snapshot of the same lineage keeps its
    own handles (matched by uid)."""
    w = phys2d.scenes.pyramid(3)
    twin = phys2d.World.from_snapshot(w.snapshot())
    handles = twin.bodies
    stepped(w, 5)
    twin.restore(w.snapshot())
    assert all(a is b for a, b in zip(twin.bodies, handles))


# -- refused images --------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def image() -> tuple[phys2d.World, bytes]:
    w = stepped(phys2d.scenes.pendulum_chain(4), 12)
    return w, w.snapshot()


def _flip(data: bytes, at: int) -> bytes:
    b = bytearray(data)
    b[at] ^= 0x10
    return bytes(b)


BAD = {
    "empty": (lambda d: b"", "not a phys2d snapshot"),
    "foreign": (lambda d: b"PK\x03\x04 a zip file, say" + d[24:], "not a phys2d snapshot"),
    "a pickle": (lambda d: pickle.dumps([1, 2, 3]), "not a phys2d snapshot"),
    "header cut": (lambda d: d[:20], "truncated"),
    "cut in the middle": (lambda d: d[: len(d) // 2], "truncated"),
    "last byte missing": (lambda d: d[:-1], "truncated"),
    "bytes appended": (lambda d: d + b"\x00", "damaged"),
    "a bit flipped in the arrays": (lambda d: _flip(d, len(d) - 40), "damaged"),
    "a bit flipped in the description": (lambda d: _flip(d, snap.HEADER.size + 5), "damaged"),
    "another format": (lambda d: d[:8] + (snap.FORMAT + 1).to_bytes(4, "little") + d[12:], "format"),
    "another phys2d": (lambda d: rewritten(d, lambda m: m.update(phys2d="0.0.1")), "phys2d 0.0.1"),
    "a joint of no body": (lambda d: rewritten(d, lambda m: m["joints"][0].update(a=10**6)), "damaged"),
    "an array missing": (
        lambda d: rewritten(d, lambda m: m["arrays"].__setitem__(0, ["bodies.nothing", "<f8", [0]])),
        "damaged",
    ),
}


@pytest.mark.parametrize("case", list(BAD))
def test_a_bad_image_is_refused_in_one_line_and_the_world_is_unchanged(image, case):
    w, data = image
    make, says = BAD[case]
    target = stepped(phys2d.scenes.pyramid(3), 4)
    before, h = fingerprint(target), target.state_hash()
    handles = target.bodies
    with pytest.raises(snap.SnapshotError) as e:
        target.restore(make(data))
    message = str(e.value)
    assert says in message and "\n" not in message
    assert isinstance(e.value, ValueError)
    assert fingerprint(target) == before and target.state_hash() == h
    assert all(b.alive for b in handles)
    with pytest.raises(snap.SnapshotError):
        phys2d.World.from_snapshot(make(data))
    twin = phys2d.World.from_snapshot(target.snapshot())
    assert future(target, 5) == future(twin, 5)  # the refused world steps on as before


def test_another_version_says_what_to_do(image):
    _, data = image
    says = r"taken by phys2d 9\.9, this is phys2d .*: restore it with phys2d 9\.9"
    with pytest.raises(snap.SnapshotError, match=says):
        phys2d.World.from_snapshot(rewritten(data, lambda m: m.update(phys2d="9.9")))


def test_arguments_are_checked(image):
    w, data = image
    with pytest.raises(TypeError, match="data must be bytes"):
        w.restore("not bytes")  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="world must be a phys2d World"):
        snap.snapshot(object())  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="world must be a phys2d World"):
        snap.state_hash(None)  # type: ignore[arg-type]
    assert fingerprint(phys2d.World.from_snapshot(bytearray(data))) == fingerprint(phys2d.World.from_snapshot(data))


# -- responders --------------------------------------------------------------------------------------
class DampedPGS(phys2d.PGS):
    """A user's own responder: PGS that also damps the bodies' spin, its settings kept on it."""

    def __init__(self, spin: float = 0.5, **kwargs) -> None:
        super().__init__(**kwargs)
        self.spin = spin
        self.weights = np.array([1.0, 0.5])
        self.tags = ("a", 2)

    def respond(self, ctx):
        result = super().respond(ctx)
        ctx.V[:, 2] *= self.spin
        return result


def test_a_responder_of_the_users_own_comes_back_by_module_and_class():
    w = stepped(phys2d.scenes.pyramid(3, responder=DampedPGS(0.25, iterations=7)), 5)
    data = w.snapshot()
    twin = phys2d.World.from_snapshot(data)
    r = twin.responder
    assert type(r) is DampedPGS and r.spin == 0.25 and r.iterations == 7
    assert r.tags == ("a", 2) and r.weights.dtype == np.float64 and r.weights.tolist() == [1.0, 0.5]
    assert future(twin, 10) == future(w, 10)


def test_a_responder_that_cannot_be_imported_is_named():
    w = stepped(phys2d.scenes.pyramid(2, responder=DampedPGS()), 2)
    data = rewritten(w.snapshot(), lambda m: m["responder"].update({"class": "no_such_module:DampedPGS"}))
    before = fingerprint(w)
    with pytest.raises(snap.SnapshotError, match="no_such_module:DampedPGS cannot be imported.*PYTHONPATH"):
        w.restore(data)
    assert fingerprint(w) == before


def test_a_responder_holding_what_a_snapshot_cannot_keep_is_refused_by_name():
    r = phys2d.PGS()
    r.callback = lambda: None  # type: ignore[attr-defined]
    w = phys2d.scenes.pyramid(2, responder=r)
    with pytest.raises(snap.SnapshotError, match="responder PGS's callback is a function"):
        w.snapshot()


def test_the_registry_name_is_kept_for_the_engines_responders():
    for name in phys2d.REGISTRY:
        spec = snap.responder_spec(phys2d.make_responder(name))
        assert spec["registry"] == name
        assert repr(snap.responder_from_spec(spec)) == repr(phys2d.make_responder(name))
    assert snap.responder_spec(DampedPGS())["registry"] is None


# -- what a snapshot holds -------------------------------------------------------------------------
def test_a_snapshot_holds_the_live_state_not_the_buffers_room():
    """A world whose buffers grew for 100 boxes and that holds 3 now: its snapshot is a small part of
    its pickle, which keeps the room."""
    w = stepped(phys2d.scenes.pyramid(14), 30)
    for body in w.bodies[4:]:
        w.remove(body)
    stepped(w, 2)
    data = w.snapshot()
    assert len(data) < 0.1 * len(pickle.dumps(w))
    twin = phys2d.World.from_snapshot(data)
    assert future(twin, 30) == future(w, 30)  # and the restored buffers grow when the original's would


# -- the hash ------------------------------------------------------------------------------------
def test_the_hash_is_the_same_whatever_threads_step_path_or_buffer_room():
    worlds = []
    for threads, one_call in ((1, True), (2, True), (1, False)):
        w = phys2d.scenes.pyramid(6)
        w.threads, w.one_call_tick = threads, one_call
        worlds.append(stepped(w, 25))
    hashes = {w.state_hash() for w in worlds}
    assert len(hashes) == 1
    data = worlds[0].snapshot()
    roomy = rewritten(data, lambda m: m["pipeline"]["room"].update(pairs=4096, store_rows=4096, pair_list=8192))
    big = phys2d.World.from_snapshot(roomy)
    assert big._pipeline.buffers.pairs == 4096 and big.state_hash() in hashes
    assert future(big, 20) == future(worlds[0], 20)


def test_the_hash_changes_with_every_step_even_asleep_and_with_every_setting():
    w = phys2d.scenes.pyramid(3)
    w.sleep = True
    stepped(w, 60)
    assert w.body_asleep[1:].all()
    seen = {w.state_hash()}
    x = w.x.copy()
    for _ in range(10):
        w.step(DT)
        seen.add(w.state_hash())
    assert len(seen) == 11 and np.array_equal(w.x, x)  # nothing moved, the tick did
    h = w.state_hash()
    for change in (
        lambda: setattr(w, "gravity", (0.0, -9.0)),
        lambda: setattr(w.responder, "iterations", 11),
        lambda: setattr(w.bodies[1], "friction", 0.3),
        lambda: w.bodies[2].apply_force((1.0, 0.0)),
    ):
        change()
        assert w.state_hash() != h
        h = w.state_hash()


def test_the_hash_is_stable_across_processes():
    """Not Python's hash(): another interpreter (another hash seed) gets the same 64 bits."""
    code = (
        "import phys2d\nw = phys2d.scenes.pendulum_chain(3)\nfor _ in range(7): w.step(1 / 60)\nprint(w.state_hash())\n"
    )
    env = {**os.environ, "PYTHONHASHSEED": "12345", "PYTHONPATH": ROOT}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    w = stepped(phys2d.scenes.pendulum_chain(3), 7)
    h = w.state_hash()
    assert int(out.stdout) == h and 0 <= h < 2**64
