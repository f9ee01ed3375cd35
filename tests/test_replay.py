"""Re-entering recordings (``phys2d.recording.replay``): keyframes, world_at, phys2d replay and branch.

A recording keeps a keyframe (a snapshot) every ``keyframe_every`` ticks and every tick's state
hash and dt; ``world_at`` must give back the very world the recorder saw at that tick (its
fingerprint, bit for bit), or say in one line why it cannot.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import warnings

import numpy as np
import pytest

import phys2d
from phys2d.recording import Recorder, playback
from phys2d.recording.replay import ReplayError
from tests.strategies import fingerprint

DT = 1 / 60
REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def record(path, w: phys2d.World, steps: int, change=None, **kw) -> dict[int, tuple]:
    """Step ``w`` and log every tick; ``change(w, tick)`` runs after each log (a change from outside
    the step, before the next one). Returns each logged tick's fingerprint."""
    seen = {}
    with Recorder(path, **kw) as rec:
        rec.log(w)
        seen[w.tick] = fingerprint(w)
        for _ in range(steps):
            w.step(DT)
            rec.log(w)
            seen[w.tick] = fingerprint(w)
            if change is not None:
                change(w, w.tick)
    return seen


def strip_report(fp: tuple) -> tuple:
    """A fingerprint as a replayed world matches it: everything (a replay's last report is the
    replayed step's, the same)."""
    return fp


@pytest.fixture(scope="module")
def chain(tmp_path_factory) -> tuple:
    """A pendulum chain (joints) recorded 40 ticks, a keyframe every 15, the responder swapped to
    the soft step after tick 25 (as the lab's 'branch here' does, between a log and a step)."""
    path = tmp_path_factory.mktemp("replay") / "chain.rrd"

    def swap(w, tick):
        if tick == 25:
            w.responder = phys2d.SoftStep(substeps=3)

    seen = record(path, phys2d.scenes.pendulum_chain(5), 40, swap, keyframe_every=15)
    return path, seen


def test_the_recording_keeps_keyframes_hashes_dts_and_responders(chain):
    path, seen = chain
    t = playback.timeline(path)
    assert t.ticks == list(range(41))
    assert t.keyframe_ticks() == [0, 15, 30]
    assert t.dts == [0.0] + [DT] * 40  # float64, bit for bit
    assert sorted(t.responders) == [0, 26]  # the responder at each tick's log: swapped after 25
    assert '"name": "soft-step"' in t.responders[26] and '"substeps": 3' in t.responders[26]
    twin = phys2d.scenes.pendulum_chain(5)
    hashes = [twin.state_hash()]
    for tick in range(1, 41):
        if tick == 26:
            twin.responder = phys2d.SoftStep(substeps=3)
        twin.step(DT)
        hashes.append(twin.state_hash())
    assert t.hashes == hashes  # what a world stepped alike hashes to, in this process


@pytest.mark.parametrize("tick", [0, 14, 15, 25, 26, 29, 40])
def test_world_at_gives_back_the_world_the_recorder_saw(chain, tick):
    path, seen = chain
    w = playback.world_at(path, tick)
    assert w.tick == tick and fingerprint(w) == seen[tick]


def test_a_tick_the_recording_does_not_hold_is_refused_naming_what_it_holds(chain, tmp_path):
    path, _ = chain
    for tick, says in ((41, r"tick 41 is outside .* it holds ticks 0-40"), (-1, r"tick -1 is outside")):
        with pytest.raises(ReplayError, match=says):
            playback.world_at(path, tick)
    with pytest.raises(TypeError, match="tick must be an integer"):
        playback.world_at(path, 2.0)  # type: ignore[arg-type]
    gaps = tmp_path / "gaps.rrd"
    w = phys2d.scenes.pyramid(3)
    with Recorder(gaps, keyframe_every=10) as rec:  # every other tick logged
        for _ in range(20):
            w.step(DT)
            if w.tick % 2 == 0:
                rec.log(w)
    with pytest.raises(ReplayError, match="tick 7 was never logged .* the nearest logged ticks are 6 and 8"):
        playback.world_at(gaps, 7)
    assert fingerprint(playback.world_at(gaps, 8)) == fingerprint(_stepped(phys2d.scenes.pyramid(3), 8))


def _stepped(w: phys2d.World, n: int) -> phys2d.World:
    for _ in range(n):
        w.step(DT)
    return w


def test_a_recording_without_keyframes_says_what_to_do_instead(tmp_path):
    path = tmp_path / "none.rrd"
    record(path, phys2d.scenes.pyramid(3), 5, keyframe_every=0)
    t = playback.timeline(path)
    assert t.ticks == list(range(6)) and not t.keyframes
    with pytest.raises(ReplayError, match=r"holds no keyframes .* keyframe_every=60\) .* step it to the tick") as e:
        playback.world_at(path, 3)
    assert "\n" not in str(e.value)


def test_keyframe_every_is_checked():
    with pytest.raises(ValueError, match="keyframe_every must be >= 0"):
        Recorder(None, stream_to="rerun+http://127.0.0.1:1/proxy", keyframe_every=-1)
    with pytest.raises(TypeError, match="keyframe_every must be an integer"):
        Recorder(None, stream_to="rerun+http://127.0.0.1:1/proxy", keyframe_every=2.5)  # type: ignore[arg-type]


def test_a_change_from_outside_the_step_is_named_or_kept_by_a_keyframe(tmp_path):
    """A force applied between a log and the next step: a replay through it finds the tick after it
    differs, and says so. Applied before a log with keyframe=True: a replay starts there."""
    bad = tmp_path / "pushed.rrd"

    def push(w, tick):
        if tick == 12:
            w.bodies[3].apply_force((400.0, 0.0))

    seen = record(bad, phys2d.scenes.pyramid(3), 20, push, keyframe_every=10)
    with pytest.raises(ReplayError, match="tick 13 .* differs .* keyframe at tick 10: .* between ticks 12 and 13"):
        playback.world_at(bad, 16)
    assert fingerprint(playback.world_at(bad, 12)) == seen[12]  # before the change, all is well
    result = playback.timeline(bad).check()
    assert result.first_bad == 13 and not result.ok
    assert result.matched == 13 + 1  # ticks 0-12, and the keyframe at 20 (its own hash)

    good = tmp_path / "kept.rrd"
    w = phys2d.scenes.pyramid(3)
    seen = {}
    with Recorder(good, keyframe_every=10) as rec:
        rec.log(w)
        for _ in range(20):
            w.step(DT)
            if w.tick == 12:
                w.bodies[3].apply_force((400.0, 0.0))  # after the step, before its log ...
            rec.log(w, keyframe=w.tick == 12)  # ... kept by a keyframe there
            seen[w.tick] = fingerprint(w)
    assert playback.timeline(good).keyframe_ticks() == [0, 10, 12]
    assert fingerprint(playback.world_at(good, 16)) == seen[16]
    assert playback.timeline(good).check().ok


def test_runs_of_a_file_of_several_are_picked_by_label(tmp_path):
    path = tmp_path / "two.rrd"
    a, b = phys2d.scenes.pyramid(3), phys2d.scenes.pyramid(3, responder=phys2d.SoftStep())
    seen = {}
    with Recorder(path, keyframe_every=5) as rec:
        for _ in range(8):
            for label, w in (("pgs", a), ("soft", b)):
                rec.log(w, run=label)
                seen[label, w.tick] = fingerprint(w)
                w.step(DT)
    assert fingerprint(playback.world_at(path, 6, run="soft")) == seen["soft", 6]
    assert fingerprint(playback.world_at(path, 6, run="pgs")) == seen["pgs", 6]
    with pytest.raises(ReplayError, match=r"holds runs \['pgs', 'soft'\]: pass run="):
        playback.world_at(path, 6)
    with pytest.raises(ReplayError, match=r"holds no run 'x' \(its runs: 'pgs', 'soft'\)"):
        playback.world_at(path, 6, run="x")


def test_a_user_responder_that_replay_cannot_import_is_named(tmp_path):
    """A responder class of the recording's own script (``__main__``) cannot be imported by another
    process: world_at says so in one line."""
    path = tmp_path / "own.rrd"
    code = (
        "import phys2d\n"
        "class Mine(phys2d.PGS):\n    pass\n"
        "w = phys2d.scenes.pyramid(2, responder=Mine())\n"
        f"with phys2d.Recorder({str(path)!r}, keyframe_every=5) as rec:\n"
        "    for _ in range(6):\n        w.step(1 / 60)\n        rec.log(w)\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], env={**os.environ, "PYTHONPATH": REPO}, capture_output=True, text=True
    )
    assert out.returncode == 0, out.stderr
    with pytest.raises(ValueError, match=r"responder __main__:Mine cannot be imported .* a script run as __main__"):
        playback.world_at(path, 3)


# -- the commands -------------------------------------------------------------------------------------
def phys2d_cmd(*args: str, cwd) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": REPO}
    env.pop("PHYS2D_DEBUG", None)
    return subprocess.run([sys.executable, "-m", "phys2d", *args], cwd=cwd, env=env, capture_output=True, text=True)


@pytest.fixture(scope="module")
def run_rrd(tmp_path_factory):
    cwd = tmp_path_factory.mktemp("cli")
    out = phys2d_cmd("run", "pyramid", "--size", "4", "--steps", "90", "--out", "p.rrd", cwd=cwd)
    assert out.returncode == 0, out.stderr
    return cwd, cwd / "p.rrd"


def test_replay_lists_the_keyframes_and_check_steps_every_tick_again(run_rrd):
    cwd, path = run_rrd
    out = phys2d_cmd("replay", "p.rrd", cwd=cwd)
    assert out.returncode == 0, out.stderr
    assert re.search(r"ticks 0-90 \(91 ticks logged\), 2 keyframes \(at 0, 60\), responder pgs", out.stdout)
    out = phys2d_cmd("replay", "p.rrd", "--check", cwd=cwd)
    assert out.returncode == 0, out.stderr
    assert "91/91 ticks match (stepped again from 2 keyframes)" in out.stdout


def test_replay_check_names_the_first_tick_that_differs(tmp_path):
    path = tmp_path / "pushed.rrd"
    record(path, phys2d.scenes.pyramid(3), 20, lambda w, t: t == 7 and w.bodies[2].apply_impulse((1.0, 0.0)))
    out = phys2d_cmd("replay", str(path), "--check", cwd=tmp_path)
    assert out.returncode == 1
    assert re.search(
        r"^8/21 ticks match; tick 8 differs first: tick 8 of .* differs .* keyframe at tick 0: ", out.stdout, re.M
    ), out.stdout


def test_branch_writes_both_futures_and_says_where_they_part(run_rrd):
    cwd, path = run_rrd
    out = phys2d_cmd("branch", "p.rrd", "--at", "30", "--responder", "naive", "--steps", "40", "-o", "b.rrd", cwd=cwd)
    assert out.returncode == 0, out.stderr
    lines = out.stdout.splitlines()
    assert lines[0] == "p.rrd at tick 30: the original (pgs) and a branch under naive, 40 steps to tick 70"
    part = re.match(r"they part at tick (\d+): body b(\d+) is ([\d.]+) mm from where it was", lines[1])
    assert part, lines[1]
    assert re.match(r"by tick 70 the largest distance is [\d.]+ (mm|m) \(body b\d+ at tick \d+\)", lines[2])
    branch = playback.load(cwd / "b.rrd")
    assert set(branch.runs) == {"original", "naive"}
    orig, naive = branch.runs["original"], branch.runs["naive"]
    assert list(orig.tick) == list(range(30, 71)) == list(naive.tick)
    rec = playback.load(path)
    assert np.array_equal(orig.x, rec.x[30:71])  # the original's future is the recorded one, bit for bit
    d = np.hypot(*(naive.x - orig.x).transpose(2, 0, 1)).max(axis=1)  # per tick, the farthest body (m)
    first = int(np.argmax(d > 1e-3))
    assert int(part.group(1)) == 30 + first and float(part.group(3)) == pytest.approx(1e3 * d[first], rel=1e-2)


@pytest.mark.parametrize(
    ("args", "says"),
    [
        (("--at", "30", "--responder", "nope"), "unknown responder 'nope' (choose from: naive,"),
        (("--at", "500", "--responder", "naive"), "tick 500 is outside"),
        (("--at", "90", "--responder", "naive"), "--at 90 is the recording's last tick: give --steps N"),
        (("--at", "10", "--responder", "naive", "--sweeps", "3"), "--sweeps does not apply to the naive responder"),
        (("--at", "10", "--responder", "pgs", "--run", "x"), "holds no run 'x'"),
    ],
)
def test_branch_refuses_bad_input_in_one_line(run_rrd, args, says):
    cwd, _ = run_rrd
    out = phys2d_cmd("branch", "p.rrd", *args, cwd=cwd)
    assert out.returncode == 1 and says in out.stderr, out.stderr
    assert len(out.stderr.strip().splitlines()) == 1


def test_replay_of_a_recording_without_keyframes_says_what_to_do(tmp_path):
    path = tmp_path / "none.rrd"
    record(path, phys2d.scenes.pyramid(2), 3, keyframe_every=0)
    out = phys2d_cmd("replay", str(path), "--check", cwd=tmp_path)
    assert out.returncode == 1 and "holds no keyframes" in out.stderr and "keyframe_every=60" in out.stderr


@pytest.mark.parametrize("every", [60, 0])
def test_a_responder_no_snapshot_can_keep_warns_only_where_keyframes_were_asked(tmp_path, every):
    """A responder holding a function cannot be kept in a keyframe: the recorder says so once,
    when it was asked for keyframes; with ``keyframe_every=0`` (the report card's recordings)
    there is nothing to stop, and nothing is said."""
    w = phys2d.scenes.pyramid(2)
    w.responder.helper = lambda: None  # a function: no snapshot keeps it
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        rec = Recorder(str(tmp_path / "r.rrd"), keyframe_every=every)
        for _ in range(3):
            w.step(1 / 60)
            rec.log(w)
        rec.close()
    messages = [str(m.message) for m in said if "keyframes" in str(m.message)]
    assert len(messages) == (1 if every else 0), messages
    if every:
        assert "helper" in messages[0] and "tick 1" in messages[0]
