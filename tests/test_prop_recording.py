"""Recording round trip: what a recording holds, read back, is what the engine computed."""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import phys2d
import phys2d.recording
from tests.strategies import SceneSpec, body_specs, build, dts, responders, scenes


@settings(max_examples=10)
@given(
    scene=scenes(max_bodies=5, ground=None, static=None),
    responder=responders(),
    dt=dts,
    steps=st.integers(1, 25),
    data=st.data(),
)
def test_recording_round_trip(scene: SceneSpec, responder: phys2d.Responder, dt: float, steps: int, data) -> None:
    """Poses, velocities, residuals and energies read back from the .rrd equal, bit for bit,
    what the world held at each logged tick, also when bodies are added and removed between
    ticks (NaN where a body did not exist); the contact table holds every contact, its
    identity exactly, its impulses and separation as float32, its point on the draw grid."""
    w = build(scene, responder)
    truth = []
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "run.rrd"
        with phys2d.Recorder(path, contact_series=data.draw(st.booleans())) as rec:
            for t in range(steps + 1):
                if t:
                    try:
                        w.step(dt)
                    except phys2d.SimulationError:
                        break
                    change = data.draw(st.sampled_from(["none", "none", "add", "remove"]))
                    if change == "add":
                        data.draw(body_specs()).add_to(w)
                    elif change == "remove" and len(w.bodies) > 1:
                        w.remove(data.draw(st.sampled_from(w.bodies)))
                rec.log(w)
                c = w.contacts
                truth.append(
                    dict(
                        tick=w.tick,
                        uid={b._uid: k for k, b in enumerate(w.bodies)},
                        x=w.x.copy(),
                        theta=w.theta.copy(),
                        V=w.V.copy(),
                        key=c.key.copy(),
                        normal_impulse=c.normal_impulse.copy(),
                        tangent_impulse=c.tangent_impulse.copy(),
                        separation=c.separation.copy(),
                        point=c.point.copy(),
                        residuals=w.last_step.residuals.copy(),
                        ke=w.kinetic_energy(),
                    )
                )
        got = phys2d.playback.load(path)
    assert list(got.tick) == [s["tick"] for s in truth]
    uids = list(got.body_uid)
    for i, s in enumerate(truth):
        present = np.array([u in s["uid"] for u in uids])
        rows = [s["uid"][u] for u in uids if u in s["uid"]]
        assert np.array_equal(got.x[i][present], s["x"][rows])
        assert np.array_equal(got.theta[i][present], s["theta"][rows])
        assert np.array_equal(got.V[i][present], s["V"][rows])
        assert np.all(np.isnan(got.x[i][~present]))
        at = got.contacts.at(i)
        assert np.array_equal(at["key"], s["key"])
        for name in ("normal_impulse", "tangent_impulse", "separation"):
            assert np.array_equal(at[name], s[name].astype(np.float32).astype(np.float64)), name
        grid = phys2d.recording.schema.DRAW_GRID
        assert np.array_equal(at["point"] / grid, np.round(at["point"] / grid))
        assert np.all(np.abs(at["point"] - s["point"]) <= grid / 2)
        assert np.array_equal(got.residuals_at(s["tick"]), s["residuals"])
        assert got.kinetic_energy[i] == pytest.approx(s["ke"], rel=1e-12, abs=1e-12)


@settings(max_examples=10)
@given(junk=st.binary(max_size=300), data=st.data())
def test_recording_refuses_bad_input(junk: bytes, data) -> None:
    """Recorder refuses bad arguments naming them; playback.load refuses a file of junk
    bytes with RecordingError (a ValueError) naming the path; log() refuses non-worlds."""
    with tempfile.TemporaryDirectory() as tmp:
        bad = Path(tmp) / "junk.rrd"
        bad.write_bytes(junk)
        with pytest.raises(phys2d.playback.RecordingError, match="path"):
            phys2d.playback.load(bad)
        name, value = data.draw(
            st.sampled_from(
                [
                    ("path", 3),
                    ("path", Path(tmp) / "x.txt"),
                    ("path", tmp),
                    ("name", 5),
                    ("scene", b"s"),
                    ("flush_every", 0),
                    ("flush_every", 1.5),
                    ("series_every", -1),
                    ("contact_series", "yes"),
                    ("blueprint", None),
                ]
            )
        )
        kwargs = {"path": Path(tmp) / "ok.rrd", name: value}
        with pytest.raises((ValueError, TypeError), match=name):
            phys2d.Recorder(**kwargs)
        with phys2d.Recorder(Path(tmp) / "ok.rrd") as rec, pytest.raises(TypeError, match="world"):
            rec.log(data.draw(st.sampled_from([None, "world", phys2d.PGS()])))
