"""Recorder and playback: what the engine computed is what a recording gives back."""

from __future__ import annotations

import gc
import os
import re
import subprocess
import sys

import numpy as np
import pyarrow.compute as pc
import pytest
from rerun.chunk import RrdReader

import phys2d
from phys2d.recording import ContactChoice, Recorder, contact_entity, playback, schema
from phys2d.world import SimulationError


def rerun_exe() -> str:
    import rerun_cli

    return os.path.join(os.path.dirname(rerun_cli.__file__), "rerun")


def assert_verified(path) -> None:
    """`rerun rrd verify` accepts the file (footer present, every column well-formed)."""
    out = subprocess.run([rerun_exe(), "rrd", "verify", str(path)], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr


def snapshot(w: phys2d.World) -> dict:
    """The engine's own arrays after a step, copied."""
    c, s = w.contacts, w.last_step
    return dict(
        tick=w.tick,
        time=w.time,
        x=w.x.copy(),
        theta=w.theta.copy(),
        V=w.V.copy(),
        uid=w.body_uids.copy(),
        key=c.key.copy(),
        point=c.point.copy(),
        normal=c.normal.copy(),
        separation=c.separation.copy(),
        normal_impulse=c.normal_impulse.copy(),
        tangent_impulse=c.tangent_impulse.copy(),
        warm_started=c.warm_started.copy(),
        residuals=s.residuals.copy(),
        max_penetration=s.max_penetration,
        contact_count=s.contact_count,
        cache_hit_rate=s.cache_hit_rate,
        iterations=s.iterations,
        ke=w.kinetic_energy(),
        pe=w.potential_energy(),
        p=w.linear_momentum().copy(),
        L=w.angular_momentum(),
    )


def record(path, w: phys2d.World, steps: int, **kw) -> list[dict]:
    snaps = []
    with Recorder(path, **kw) as rec:
        rec.log(w)
        snaps.append(snapshot(w))
        for _ in range(steps):
            w.step(1 / 60)
            rec.log(w)
            snaps.append(snapshot(w))
    return snaps


def assert_drawn(got: np.ndarray, engine: np.ndarray, grid: float) -> None:
    """A drawn value: a whole multiple of ``grid``, within half a grid step of the engine's."""
    assert got.shape == engine.shape
    assert np.array_equal(got / grid, np.round(got / grid))
    assert np.all(np.abs(got - engine) <= 0.5 * grid + 1e-12)


def f32(a) -> np.ndarray:
    """What float32 storage keeps of the engine's float64 values."""
    return np.asarray(a, dtype=np.float64).astype(np.float32).astype(np.float64)


@pytest.fixture(scope="module")
def mixed(tmp_path_factory):
    """Boxes, circles and polygons falling in a heap: contacts come, go and come back.

    Small flush windows so that several scene and series batches (and their seams) are read;
    every contact plotted, so every series can be checked.
    """
    path = tmp_path_factory.mktemp("rec") / "mixed.rrd"
    w = phys2d.scenes.mixed_shapes(10)
    snaps = record(
        path, w, 150, name="mixed", scene="mixed_shapes", flush_every=7, series_every=23, plot="deepest:100000"
    )
    return path, snaps, playback.load(path), w


def test_every_file_written_passes_rerun_verify(mixed):
    assert_verified(mixed[0])


def test_poses_round_trip_exactly(mixed):
    _, snaps, rec, _ = mixed
    assert list(rec.tick) == [s["tick"] for s in snaps] == list(range(151))
    np.testing.assert_allclose(rec.time, [s["time"] for s in snaps], rtol=0, atol=1e-9)
    assert np.array_equal(rec.body_uid, snaps[0]["uid"])
    assert np.array_equal(rec.x, np.stack([s["x"] for s in snaps]))
    assert np.array_equal(rec.theta, np.stack([s["theta"] for s in snaps]))
    assert np.array_equal(rec.V, np.stack([s["V"] for s in snaps]))


def test_contact_table_holds_every_contact_at_its_precision(mixed):
    """Identities and flags exactly; impulses and separation as float32; points and normals as drawn."""
    _, snaps, rec, _ = mixed
    assert len(rec.contacts) == len(snaps)
    assert sum(len(s["key"]) for s in snaps) > 100  # the scene really has contacts
    for i, s in enumerate(snaps):
        got = rec.contacts.at(i)
        assert np.array_equal(got["key"], s["key"]), i
        assert np.array_equal(got["warm_started"], s["warm_started"]), i
        assert np.array_equal(got["body_a"], s["key"] >> 39) and np.array_equal(got["feature"], s["key"] & 0xFFFF)
        for name in ("separation", "normal_impulse", "tangent_impulse"):
            assert np.array_equal(got[name], f32(s[name])), (i, name)
        assert_drawn(got["point"], s["point"], schema.DRAW_GRID)
        assert_drawn(got["normal"], s["normal"], schema.NORMAL_GRID)
    assert rec.contacts.warm_started.any() and not rec.contacts.warm_started.all()


def test_solver_and_aggregates_round_trip_exactly(mixed):
    _, snaps, rec, _ = mixed
    for s in snaps:
        assert np.array_equal(rec.residuals_at(s["tick"]), s["residuals"])
    # energies and momenta are worked out by the recorder from the sampled state: the engine's
    # methods agree to round-off (summation order)
    for got, want in (
        (rec.kinetic_energy, [s["ke"] for s in snaps]),
        (rec.potential_energy, [s["pe"] for s in snaps]),
        (rec.linear_momentum, np.stack([s["p"] for s in snaps])),
        (rec.angular_momentum, [s["L"] for s in snaps]),
    ):
        want = np.asarray(want)
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12 * np.abs(want).max())
    np.testing.assert_allclose(rec.max_penetration, [s["max_penetration"] for s in snaps], rtol=1e-15, atol=0)
    assert np.array_equal(rec.contact_count, [s["contact_count"] for s in snaps])
    assert np.array_equal(rec.cache_hit_rate, [s["cache_hit_rate"] for s in snaps])
    assert np.array_equal(rec.iterations, [s["iterations"] for s in snaps])


def test_properties_name_the_responder_scene_and_version(mixed):
    _, _, rec, w = mixed
    assert rec.properties["phys2d"]["engine_version"] == phys2d.__version__
    run = rec.runs[""]
    assert run.properties["responder"] == repr(w.responder)
    assert run.properties["scene"] == "mixed_shapes"


def test_per_contact_series_follow_each_contact_and_break_where_it_ends(mixed):
    _, snaps, rec, _ = mixed
    # what the engine said, per contact identity: {key: {tick: (lambda_n, lambda_t, penetration)}}
    truth: dict[int, dict[int, tuple]] = {}
    for s in snaps:
        for k, ln, lt, sep in zip(s["key"], s["normal_impulse"], s["tangent_impulse"], s["separation"], strict=True):
            truth.setdefault(int(k), {})[s["tick"]] = (ln, lt, -sep * 1e3)  # penetration in mm
    assert sorted(rec.series_keys("lambda")) == sorted(contact_entity(k) for k in truth)
    ticks = [s["tick"] for s in snaps]
    gaps = 0
    for k, per_tick in truth.items():
        t_l, lam = rec.series("lambda", k)
        t_p, pen = rec.series("penetration", k)
        assert np.array_equal(t_l, t_p)
        expect_t, expect_l, expect_p = [], [], []
        for i, t in enumerate(ticks):
            if t in per_tick:
                expect_t.append(t)
                expect_l.append(per_tick[t][:2])
                expect_p.append(per_tick[t][2])
            elif i > 0 and ticks[i - 1] in per_tick:  # the contact ended: one NaN breaks the line
                expect_t.append(t)
                expect_l.append((np.nan, np.nan))
                expect_p.append(np.nan)
                gaps += 1
        assert np.array_equal(t_l, expect_t), k
        np.testing.assert_array_equal(lam, np.array(expect_l).reshape(-1, 2))
        np.testing.assert_array_equal(pen, np.array(expect_p))
    assert gaps > 0  # the scene made contacts vanish, so the NaN marker was exercised


def strips_at_last_tick(path, entity: str) -> list:
    rows = []
    for ch in (
        RrdReader(str(path)).store().stream().filter(content=entity, is_static=False, components="LineStrips2D:strips")
    ):
        rb = ch.to_record_batch()
        rows += [
            (t, s)
            for t, s in zip(rb.column("tick").to_pylist(), rb.column("LineStrips2D:strips").to_pylist(), strict=True)
            if s is not None
        ]
    return max(rows, key=lambda r: r[0])[1]


def test_outlines_drawn_are_the_bodies_vertices(mixed):
    """Each dynamic body's strip at the last tick: a polygon's world vertices, closed; a circle's
    centre, then its rim from the point at its angle around (y-up, rotated), all on the draw grid."""
    path, _, _, w = mixed
    last = strips_at_last_tick(path, "/world/sim/bodies")
    dynamic = [b for b in w.bodies if not b.static]
    assert len(last) == len(dynamic)
    assert any(b.shape == "circle" for b in dynamic) and any(b.shape == "polygon" for b in dynamic)
    for b, strip in zip(dynamic, last, strict=True):
        strip = np.array(strip)
        if b.shape == "polygon":
            v = b.vertices
            want = np.vstack([v, v[:1]])
        else:
            phi = b.angle + 2 * np.pi * np.arange(schema.CIRCLE_SEGMENTS + 1) / schema.CIRCLE_SEGMENTS
            want = np.vstack([b.position, b.position + b.radius * np.stack([np.cos(phi), np.sin(phi)], axis=1)])
        assert_drawn(strip, want, schema.DRAW_GRID)


def static_strip_rows(path) -> int:
    """How many timed rows of outlines the file holds under world/sim/static."""
    return sum(
        ch.num_rows
        for ch in RrdReader(str(path))
        .store()
        .stream()
        .filter(content="/world/sim/static", is_static=False, components="LineStrips2D:strips")
    )


def test_static_geometry_is_written_once(mixed):
    """The ground never moves: one row on world/sim/static, none of it on world/sim/bodies."""
    path, snaps, rec, w = mixed
    rows = static_strip_rows(path)
    assert rows == 1
    ground = [b for b in w.bodies if b.static]
    assert len(ground) == 1 and len(strips_at_last_tick(path, "/world/sim/static")) == 1
    col = list(rec.body_uid).index(w.body_uids[ground[0].index])
    assert np.array_equal(rec.x[:, col], np.stack([s["x"][ground[0].index] for s in snaps]))  # read at every tick


def test_a_blueprint_is_stored_in_the_file(mixed):
    assert len(RrdReader(str(mixed[0])).blueprints()) >= 1


def test_exception_in_the_with_block_leaves_every_tick_before_it(tmp_path):
    path = tmp_path / "boom.rrd"
    w = phys2d.scenes.vertical_stack(3)
    with pytest.raises(RuntimeError, match="boom"), Recorder(path, flush_every=60) as rec:
        for _ in range(45):
            w.step(1 / 60)
            rec.log(w)
            if w.tick == 33:
                x33 = w.x.copy()
                raise RuntimeError("boom")
    assert_verified(path)
    rec = playback.load(path)
    assert list(rec.tick) == list(range(1, 34))
    assert np.array_equal(rec.x[-1], x33)


def test_simulation_error_part_way_leaves_a_readable_recording(tmp_path):
    path = tmp_path / "fail.rrd"
    w = phys2d.World(max_speed=4.0)
    phys2d.scenes.ground(w)
    w.add_box(position=(0.0, 5.0))
    rec = Recorder(path)
    with pytest.raises(SimulationError):
        for _ in range(200):
            w.step(1 / 60)
            rec.log(w)
    failed_at = w.tick  # the failing step was undone: w is as at the last logged tick
    assert 0 < failed_at < 200
    del rec
    gc.collect()  # no close(): the finalizer writes the buffered ticks and the footer
    assert_verified(path)
    back = playback.load(path)
    assert back.tick[-1] == failed_at and len(back.tick) == failed_at
    assert np.array_equal(back.x[-1], w.x) and np.array_equal(back.V[-1], w.V)


@pytest.mark.parametrize("bad", ["file_as_dir", "directory", "suffix"])
def test_unwritable_paths_fail_at_once(tmp_path, bad):
    blocker = tmp_path / "a_file"
    blocker.write_text("x")
    path = {"file_as_dir": blocker / "sub" / "r.rrd", "directory": tmp_path, "suffix": tmp_path / "r.txt"}[bad]
    with pytest.raises(ValueError, match="path"):
        Recorder(path)


def test_bad_arguments_are_named(tmp_path):
    with pytest.raises(TypeError, match="path"):
        Recorder(3)
    with pytest.raises(ValueError, match="flush_every"):
        Recorder(tmp_path / "a.rrd", flush_every=0)
    with pytest.raises(TypeError, match="contact_series"):
        Recorder(tmp_path / "b.rrd", contact_series="yes")
    with pytest.raises(TypeError, match="unexpected keyword argument 'flush_evry'"):
        Recorder(tmp_path / "sub" / "d.rrd", flush_evry=3)  # a misspelt keyword: nothing is made
    assert not (tmp_path / "sub").exists()
    rec = Recorder(tmp_path / "c.rrd")
    with pytest.raises(TypeError, match="world"):
        rec.log("not a world")
    with pytest.raises(ValueError, match="run"):
        rec.log(phys2d.scenes.vertical_stack(1), run="has space")
    rec.close()
    with pytest.raises(ValueError, match="closed"):
        rec.log(phys2d.scenes.vertical_stack(1))
    with pytest.raises(FileNotFoundError, match="no-such.rrd"):
        playback.load(tmp_path / "no-such.rrd")
    (tmp_path / "junk.rrd").write_bytes(b"not a recording")
    with pytest.raises(ValueError, match="junk.rrd"):
        playback.load(tmp_path / "junk.rrd")


def test_comparison_runs_share_one_recording_and_timelines(tmp_path):
    path = tmp_path / "cmp.rrd"
    worlds = {
        "pgs": phys2d.scenes.vertical_stack(4, responder=phys2d.PGS(warm_start=True)),
        "pgs-cold": phys2d.scenes.vertical_stack(4, responder=phys2d.PGS(warm_start=False)),
    }
    truth: dict[str, list] = {k: [] for k in worlds}
    with Recorder(path, name="stack: warm vs cold") as rec:
        for _ in range(40):
            for label, w in worlds.items():
                w.step(1 / 60)
                rec.log(w, run=label)
                truth[label].append(snapshot(w))
    assert_verified(path)
    back = playback.load(path)
    assert sorted(back.runs) == ["pgs", "pgs-cold"]
    for label, snaps in truth.items():
        r = back.runs[label]
        assert list(r.tick) == list(range(1, 41))
        assert np.array_equal(r.x, np.stack([s["x"] for s in snaps]))
        assert np.array_equal(r.contacts.normal_impulse, f32(np.concatenate([s["normal_impulse"] for s in snaps])))
        assert r.properties["responder"] == repr(worlds[label].responder)
    # warm starting really differs from cold, so the runs are not one run read twice
    assert not np.array_equal(back.runs["pgs"].residual, back.runs["pgs-cold"].residual)
    with pytest.raises(AttributeError, match="runs"):
        back.x  # noqa: B018 - two runs: no single x


def test_bodies_added_and_removed_mid_run(tmp_path):
    path = tmp_path / "churn.rrd"
    w = phys2d.scenes.vertical_stack(3)
    snaps = []
    with Recorder(path, flush_every=5) as rec:
        for k in range(30):
            if k == 10:
                w.remove(w.bodies[2])
            if k == 17:
                w.add_circle(position=(3.0, 1.0), radius=0.3)
            w.step(1 / 60)
            rec.log(w)
            snaps.append(snapshot(w))
    assert_verified(path)
    back = playback.load(path)
    uids = list(back.body_uid)
    assert uids == [0, 1, 2, 3, 4]
    for i, s in enumerate(snaps):
        cols = [uids.index(u) for u in s["uid"]]
        assert np.array_equal(back.x[i, cols], s["x"])
        missing = sorted(set(range(5)) - set(cols))
        assert np.isnan(back.x[i, missing]).all()


def test_joints_are_drawn_and_their_reactions_recorded(tmp_path):
    path = tmp_path / "joints.rrd"
    w = phys2d.World()
    anchor = w.add_box(position=(0.0, 5.0), half_extents=(0.2, 0.2), static=True)
    bob = w.add_box(position=(1.0, 5.0), half_extents=(0.1, 0.1))
    arm = w.add_box(position=(3.0, 5.0), half_extents=(0.1, 0.1))
    pin = w.add_pin_joint(anchor, bob, anchor=(0.0, 5.0))  # two rows
    rod = w.add_distance_joint(bob, arm, anchor_a=(1.0, 5.0), anchor_b=(3.0, 5.0))  # one row
    expect_anchor, expect_imp = [], []
    with Recorder(path) as rec:
        for _ in range(12):
            w.step(1 / 60)
            rec.log(w)
            expect_anchor.append(np.array([pin.anchors(), rod.anchors()]))
            expect_imp.append([pin.impulse, rod.impulse])
    assert_verified(path)
    back = playback.load(path)
    assert len(back.joint_anchors) == 12
    for got, want in zip(back.joint_anchors, expect_anchor, strict=True):
        assert_drawn(got, want, schema.DRAW_GRID)
    assert back.series_keys("reaction") == ["j0/r0", "j0/r1", "j1/r0"]
    for key, (q, row) in {"j0/r0": (0, 0), "j0/r1": (0, 1), "j1/r0": (1, 0)}.items():
        t, v = back.series("reaction", key)
        assert np.array_equal(t, np.arange(1, 13))
        assert np.array_equal(v, [imp[q][row] for imp in expect_imp])
    assert any(abs(imp[1][0]) > 0 for imp in expect_imp)  # the rod carries a load


def test_contact_table_is_one_row_per_tick_including_empty_ticks(tmp_path):
    """A tick without contacts writes an empty row, so old contacts do not linger in the view."""
    path = tmp_path / "air.rrd"
    w = phys2d.World()
    phys2d.scenes.ground(w)
    w.add_box(position=(0.0, 0.5))
    w.add_box(position=(5.0, 3.0))
    with Recorder(path) as rec:
        for _ in range(20):
            w.step(1 / 60)
            rec.log(w)
        w.remove(w.bodies[1])  # the resting box goes: its contacts end
        w.step(1 / 60)
        rec.log(w)
    store = RrdReader(str(path)).store()
    n_rows = 0
    for ch in store.stream().filter(content="/world/sim/contacts", is_static=False, components="Arrows2D:origins"):
        rb = ch.to_record_batch()
        lens = pc.list_value_length(rb.column("Arrows2D:origins")).to_numpy(zero_copy_only=False)
        n_rows += len(lens)
        ticks = rb.column("tick").to_numpy()
        assert (lens[ticks == 21] == 0).all()
    assert n_rows == 21


def test_outline_column_has_rerun_own_arrow_type(mixed):
    """The outlines are built as raw arrow; the viewer silently skips a column of another type."""
    import rerun as rr

    want = rr.components.LineStrip2DBatch([[[0.0, 0.0], [1.0, 1.0]]]).as_arrow_array().type
    store = RrdReader(str(mixed[0])).store()
    types = {
        ch.to_record_batch().schema.field("LineStrips2D:strips").type
        for ch in store.stream().filter(content="/world/sim/bodies", components="LineStrips2D:strips")
    }
    assert types and all(t.value_type == want for t in types)


def killed_child(script: str) -> subprocess.CompletedProcess:
    """``script`` run by a child Python on this checkout's phys2d (it ends with ``os._exit(1)``: a
    hard kill, no clean-up)."""
    repo = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    return subprocess.run(
        [sys.executable, "-c", script],
        env={**os.environ, "PYTHONPATH": repo},
        capture_output=True,
        text=True,
        timeout=120,
    )


def test_a_hard_kill_leaves_the_windows_already_written(tmp_path):
    """os._exit skips every finalizer: no footer, but each flushed window of ticks is readable."""
    import textwrap

    path = tmp_path / "killed.rrd"
    script = textwrap.dedent(f"""
        import os, time, phys2d
        from phys2d.recording import Recorder
        w = phys2d.scenes.vertical_stack(3)
        rec = Recorder({str(path)!r}, flush_every=10)
        for _ in range(95):
            w.step(1 / 60)
            rec.log(w)
        time.sleep(1.0)  # the writer thread catches up with the windows already sent
        os._exit(1)
    """)
    out = killed_child(script)
    assert out.returncode == 1, out.stderr
    back = playback.load(path)
    assert list(back.tick) == list(range(1, 91))  # 9 whole windows; the last 5 ticks were still buffered
    w = phys2d.scenes.vertical_stack(3)
    for _ in range(90):
        w.step(1 / 60)
    assert np.array_equal(back.x[-1], w.x)


def test_without_contact_series_the_contact_table_is_still_written(tmp_path):
    path = tmp_path / "lean.rrd"
    w = phys2d.scenes.vertical_stack(3)
    snaps = record(path, w, 20, contact_series=False)
    assert_verified(path)
    back = playback.load(path)
    assert back.series_keys("lambda") == [] and back.series_keys("penetration") == []
    assert np.array_equal(back.contacts.normal_impulse, f32(np.concatenate([s["normal_impulse"] for s in snaps])))


# -- which contacts get plots -----------------------------------------------------------------
def _pyramid_run(tmp_path, name: str, plot, steps: int = 40, **kw):
    path = tmp_path / f"{name}.rrd"
    w = phys2d.scenes.pyramid(4)
    snaps = record(path, w, steps, plot=plot, **kw)
    return snaps, playback.load(path)


def _deepest_by_key(snaps: list[dict]) -> dict[int, float]:
    out: dict[int, float] = {}
    for s in snaps:
        for k, sep in zip(s["key"], s["separation"], strict=True):
            out[int(k)] = max(out.get(int(k), -np.inf), -sep)
    return out


def test_default_plots_the_four_deepest_contacts(tmp_path):
    snaps, rec = _pyramid_run(tmp_path, "deepest", None)
    deepest = _deepest_by_key(snaps)
    chosen = rec.series_keys("lambda")
    assert len(chosen) == 4 and len(deepest) > 4
    ranked = sorted(deepest, key=lambda k: (-deepest[k], k))
    assert sorted(chosen) == sorted(contact_entity(k) for k in ranked[:4])
    assert rec.series_keys("penetration") == chosen


def test_plot_a_chosen_body_s_contacts(tmp_path):
    snaps, rec = _pyramid_run(tmp_path, "body", "body:3")
    want = {contact_entity(k) for s in snaps for k in s["key"] if 3 in (int(k) >> 39, (int(k) >> 16) & 0x7FFFFF)}
    assert want and set(rec.series_keys("lambda")) == want


def test_plot_contacts_named_on_the_command_line(tmp_path):
    w = phys2d.scenes.pyramid(4)
    for _ in range(5):
        w.step(1 / 60)
    names = [contact_entity(k) for k in w.contacts.key[[0, -1]]]
    snaps, rec = _pyramid_run(tmp_path, "keys", ",".join(names + ["b90-b91/f0"]))  # one never touches
    assert rec.series_keys("lambda") == sorted(names)
    key = int(w.contacts.key[0])
    t, lam = rec.series("lambda", key)
    truth = [(s["tick"], s["normal_impulse"][list(s["key"]).index(key)]) for s in snaps if key in s["key"]]
    assert list(t) == [tk for tk, _ in truth] and np.array_equal(lam[:, 0], [v for _, v in truth])


@pytest.mark.parametrize(
    "text, error",
    [
        ("deepest:0", ValueError),
        ("body:-1", ValueError),
        ("body:x", ValueError),
        ("b1-b0/f0", ValueError),
        ("nonsense", ValueError),
        ("", ValueError),
    ],
)
def test_bad_plot_choices_are_named(tmp_path, text, error):
    with pytest.raises(error, match="plot|contact|keys|n must|uid"):
        Recorder(tmp_path / "x.rrd", plot=text)
    with pytest.raises(TypeError, match="plot"):
        Recorder(tmp_path / "y.rrd", plot=3)
    assert repr(ContactChoice.parse("body:4")) == "ContactChoice.body(4)"


def _static_style(path, prefix: str) -> dict[str, tuple]:
    """entity -> (names, colours) of the SeriesLines/SeriesPoints styles written once per entity."""
    out = {}
    for ch in RrdReader(str(path)).store().stream().filter(content=f"{prefix}/**", is_static=True):
        rb = ch.to_record_batch()
        cols = {n.split(":")[-1]: rb.column(n).to_pylist()[0] for n in rb.schema.names if ":" in n}
        if "names" in cols:
            out[ch.entity_path] = (cols["names"], cols.get("colors"))
    return out


def test_plot_legends_name_each_contact_by_its_bodies_and_feature_in_distinct_colours(mixed):
    path, snaps, rec, _ = mixed
    styles = _static_style(path, "/contacts/penetration")
    assert len(styles) == len(rec.series_keys("penetration")) > 5
    for entity, (names, _) in styles.items():
        a, b, f = entity.split("/")[-2].replace("b", "").split("-") + [entity.split("/")[-1][1:]]
        assert names == [f"b{a}-b{b} f{f}"]
    colours = [c[0] for _, c in styles.values()]
    assert len(set(colours)) == min(len(colours), len(schema.PALETTE))  # every palette colour used before any repeats
    energy = _static_style(path, "/stats/energy")
    assert sorted(n[0] for n, _ in energy.values()) == ["kinetic", "potential", "total"]
    assert len({c[0] for _, c in energy.values()}) == 3


def test_a_static_body_moved_by_hand_is_written_again(tmp_path):
    path = tmp_path / "moved.rrd"
    w = phys2d.scenes.vertical_stack(2)
    ground = [b for b in w.bodies if b.static][0]
    xs = []
    with Recorder(path, flush_every=4) as rec:
        for k in range(12):
            if k == 6:
                ground.position = ground.position + np.array([0.25, 0.0])
            w.step(1 / 60)
            rec.log(w)
            xs.append(ground.position)
    rows = static_strip_rows(path)
    assert rows == 2
    back = playback.load(path)
    assert np.array_equal(back.x[:, list(back.body_uid).index(0)], np.stack(xs))


# -- the background writer -------------------------------------------------------------------
def test_a_background_writer_writes_what_an_in_process_one_does(tmp_path):
    out = {}
    for background in (False, True):
        path = tmp_path / f"bg{background}.rrd"
        w = phys2d.scenes.mixed_shapes(6)
        with Recorder(path, flush_every=9, background=background) as rec:
            for _ in range(40):
                w.step(1 / 60)
                rec.log(w)
        assert rec.plotted[None]  # the writer reports which contacts it plotted
        assert_verified(path)
        out[background] = (playback.load(path), rec.plotted)
    (a, pa_), (b, pb) = out[False], out[True]
    assert pa_ == pb
    for name in ("tick", "x", "V", "residual", "kinetic_energy"):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name
    for name in ("key", "normal_impulse", "point"):
        assert np.array_equal(getattr(a.contacts, name), getattr(b.contacts, name)), name


def _data_chunks(path, entity: str) -> list[int]:
    """Rows of each temporal chunk of ``entity``."""
    return [ch.num_rows for ch in RrdReader(str(path)).store().stream().filter(content=entity, is_static=False)]


def test_a_background_writer_writes_long_chunks_of_the_same_rows(tmp_path):
    """A writer process holds an entity's windows and writes them as one chunk (up to ~8 MB):
    the rows are those an in-process recorder writes window by window."""
    chunks = {}
    for background in (False, True):
        path = tmp_path / f"chunks{background}.rrd"
        w = phys2d.scenes.pyramid(6)
        with Recorder(path, flush_every=10, series_every=50, background=background) as rec:
            rec.log(w)
            for _ in range(99):
                w.step(1 / 60)
                rec.log(w)
        chunks[background] = {
            e: _data_chunks(path, e)
            for e in ("/world/sim/bodies", "/world/sim/contacts", "/stats/energy/kinetic", "/solver/residual")
        }
    for entity, rows in chunks[False].items():
        assert sum(chunks[True][entity]) == sum(rows), entity  # the same rows ...
    assert chunks[False]["/world/sim/contacts"] == [10] * 10  # ... one chunk per window in process,
    assert chunks[True]["/world/sim/contacts"] == [100]  # one for the whole run from a writer process
    assert chunks[True]["/world/sim/bodies"] == [1, 100]  # the labels' row, then every tick
    assert chunks[True]["/stats/energy/kinetic"] == [100]
    assert chunks[True]["/solver/residual"] == [sum(chunks[False]["/solver/residual"])]


def test_the_blueprint_has_rerun_s_own_components_and_types():
    """blueprint.build writes the rows rerun.blueprint writes for the same layout (entity kinds,
    component descriptors, arrow types and values, up to the random view and container ids)."""
    import rerun as rr
    import rerun_bindings

    from phys2d.recording import blueprint as bp

    def ours(views):
        return bp.build(views)

    def theirs(views):
        """What rerun's blueprint classes log, caught at rerun_bindings.log_arrow_msg."""
        import rerun.blueprint as rrb

        rows = []
        original = rerun_bindings.log_arrow_msg

        def catch(entity_path, components, static_, recording=None):
            rows.append((entity_path, components, static_))

        rerun_bindings.log_arrow_msg = catch
        try:
            stream = rr.RecordingStream("check", recording_id="x")
            runs = views
            single = len(runs) == 1
            r = runs[0]
            p = schema.run_prefix(r.label)

            def world(r):
                x0, x1, y0, y1 = r.bounds
                return rrb.Spatial2DView(
                    name=f"world {r.label}" if r.label else "world",
                    origin=f"/{schema.run_prefix(r.label)}{schema.WORLD}",
                    visual_bounds=rrb.VisualBounds2D(x_range=[x0, x1], y_range=[-y1, -y0]),
                )

            def plot(key, paths, legend=True):
                return rrb.TimeSeriesView(
                    name=bp.TITLES[key],
                    origin="/",
                    contents=[f"+ /{q}" for q in paths],
                    plot_legend=None if legend else rrb.PlotLegend(visible=False),
                )

            if single:
                left = rrb.Tabs(
                    world(r), rrb.DataframeView(name="contact table", origin=f"/{p}{schema.CONTACTS}"), active_tab=0
                )
                plots = [
                    plot("lambda", [f"{p}{schema.LAMBDA}/**"]),
                    plot("penetration", [f"{p}{schema.PENETRATION}/**"]),
                    plot("reaction", [f"{p}{schema.REACTION}/**"], legend=False),
                    plot("residual", [f"{p}{schema.RESIDUAL}"]),
                    plot("energy", [f"{p}{schema.STATS_ROOT}/energy/**"]),
                ]
            else:
                left = rrb.Grid(*[world(v) for v in runs])
                plots = [plot("residual", [f"{schema.run_prefix(v.label)}{schema.RESIDUAL}" for v in runs])]
            blueprint = rrb.Blueprint(
                rrb.Horizontal(left, rrb.Vertical(*plots), column_shares=[3, 2]),
                rrb.BlueprintPanel(state="collapsed"),
                rrb.SelectionPanel(state="collapsed"),
                rrb.TimePanel(state="collapsed", timeline=schema.TICK, play_state="following"),
            )
            blueprint._log_to_stream(stream)
        finally:
            rerun_bindings.log_arrow_msg = original
        return rows

    def shape(rows):
        out = []
        for entity, comps, static in rows:
            kind = entity.split("/")[0] + ("/" + entity.split("/")[-1] if entity.count("/") > 1 else "")
            for d, a in comps.items():
                values = (
                    None
                    if "contents" in d.component or "active_tab" in d.component or "root_container" in d.component
                    else a.to_pylist()
                )
                out.append((kind, d.component, d.archetype, d.component_type, str(a.type), values, bool(static)))
        return sorted(out, key=repr)

    one = [bp.RunView(None, (-3.0, 3.0, -0.5, 6.0), True, True)]
    assert shape(ours(one)) == shape(theirs(one))
    two = [bp.RunView("a", (0.0, 1.0, 0.0, 1.0), False, False), bp.RunView("b", (0.0, 2.0, 0.0, 2.0), False, False)]
    for component in ("ContainerBlueprint:container_kind", "VisualBounds2D:range"):  # a grid of worlds, each framed
        assert [r for r in shape(ours(two)) if r[1] == component] == [
            r for r in shape(theirs(two)) if r[1] == component
        ], component


def test_a_background_writer_finishes_the_file_when_the_simulation_dies(tmp_path):
    """os._exit in the simulating process: the writer sees it gone, writes every window it was
    sent and the footer."""
    import textwrap

    path = tmp_path / "orphan.rrd"
    script = textwrap.dedent(f"""
        import os, phys2d
        from phys2d.recording import Recorder
        w = phys2d.scenes.vertical_stack(3)
        rec = Recorder({str(path)!r}, flush_every=10, background=True)
        for _ in range(95):
            w.step(1 / 60)
            rec.log(w)
        import time; time.sleep(0.5)  # the queue's feeder thread hands over the windows sent
        os._exit(1)
    """)
    out = killed_child(script)
    assert out.returncode == 1, out.stderr
    for _ in range(100):  # the writer notices within a second or so
        try:
            assert_verified(path)
            break
        except AssertionError:
            import time

            time.sleep(0.2)
    assert_verified(path)
    back = playback.load(path)
    assert list(back.tick) == list(range(1, 91))  # the 9 whole windows sent; 5 ticks were still buffered


def test_a_plotted_entity_holds_no_numeric_column_but_its_scalars(tmp_path):
    """Rerun (0.30 on) draws every numeric component of an entity in a time series view: an entity
    a plot shows must carry its Scalars and nothing else numeric (the exact residuals once sat beside
    the log10 ones and were drawn as a flat line at 0). The exact residuals still read back."""
    path = tmp_path / "plotted.rrd"
    w = phys2d.scenes.pyramid(4)
    residuals = []
    with Recorder(path, flush_every=5) as rec:
        for _ in range(12):
            w.step(1 / 60)
            rec.log(w)
            residuals.append(w.last_step.residuals.copy())
    store = RrdReader(str(path)).store()
    plotted = ("/solver/residual", "/stats/", "/contacts/lambda/", "/contacts/penetration/")
    timelines = {schema.TICK, schema.SIM_TIME, schema.SWEEP}
    seen = set()
    for ch in store.stream().filter(is_static=False):
        rb = ch.to_record_batch()
        entity = rb.schema.metadata.get(b"rerun:entity_path", b"").decode() if rb.schema.metadata else ""
        if not entity.startswith(plotted):
            continue
        seen.add(entity.split("/")[1])
        for field in rb.schema:
            if field.name in timelines or field.name.startswith("rerun.") or "RowId" in field.name:
                continue
            assert field.name == "Scalars:scalars", (entity, field.name)
    assert {"solver", "stats", "contacts"} <= seen
    assert np.array_equal(playback.load(path).residual, np.concatenate(residuals))


@pytest.mark.parametrize("seed", range(5))
def test_unique_is_numpy_s(seed):
    """buffer.unique (the writer's, without numpy.ma) gives what np.unique(..., return_inverse=True) does."""
    from phys2d.recording.buffer import unique

    keys = np.random.default_rng(seed).integers(-5, 9, size=seed * 7).astype(np.int64)
    got, inv = unique(keys)
    want, want_inv = np.unique(keys, return_inverse=True)
    assert np.array_equal(got, want) and np.array_equal(inv, want_inv.reshape(-1))
    assert np.array_equal(got[inv], keys)


@pytest.mark.parametrize("seed", range(5))
def test_member_is_numpy_s_isin(seed):
    """buffer.member gives np.isin's answer, for few keys (comparisons) and many (binary search)."""
    from phys2d.recording.buffer import member

    rng = np.random.default_rng(seed)
    key = rng.integers(0, 60, size=200).astype(np.int64)
    for n in (0, 1, 5, 16, 17, 40):
        among = rng.integers(0, 60, size=n).astype(np.int64)
        assert np.array_equal(member(key, among), np.isin(key, among)), n


def test_packed_windows_come_back_through_an_arena_as_they_went_in():
    """sample.pack into a shared arena's slot, then unpack: the same samples, field by field, and
    the copies do not share the slot (it may be refilled at once)."""
    from phys2d.recording.arena import Arena, SlotWriter
    from phys2d.recording.sample import Sampler, pack, unpack, window_parts

    w = phys2d.scenes.mixed_shapes(5)
    sampler = Sampler()
    samples = []
    for _ in range(7):
        w.step(1 / 60)
        samples.append(sampler.sample(w))
    arena = Arena(slots=2, slot_bytes=1 << 20)
    assert arena.fits(window_parts(samples))
    packed = pack(samples, set(), SlotWriter(arena, 1))
    back = unpack(packed, {}, arena)
    arena.map[:] = b"\xff" * len(arena.map)  # the slot is refilled: the unpacked copies stay
    assert [s.tick for s in back] == [s.tick for s in samples]
    for a, b in zip(samples, back, strict=True):
        for name in ("x", "theta", "V", "key", "point", "normal", "separation", "lambda_n", "warm", "residuals"):
            assert np.array_equal(getattr(a, name), getattr(b, name)), name
            assert getattr(a, name).dtype == getattr(b, name).dtype, name
    assert not Arena(slots=1, slot_bytes=64).fits(window_parts(samples))


def test_a_background_writer_takes_windows_too_big_for_its_arena(tmp_path, monkeypatch):
    """A window larger than a slot goes pickled over the queue: the file is the same."""
    from phys2d.recording import arena

    out = {}
    for slot_bytes in (arena.SLOT_BYTES, 4096):
        monkeypatch.setattr(arena, "SLOT_BYTES", slot_bytes)
        path = tmp_path / f"slot{slot_bytes}.rrd"
        record(path, phys2d.scenes.pyramid(4), 30, flush_every=8, background=True)
        out[slot_bytes] = playback.load(path)
    a, b = out.values()
    for name in ("tick", "x", "V", "residual"):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name
    assert np.array_equal(a.contacts.key, b.contacts.key)


def test_a_stream_to_a_port_nobody_listens_on_is_refused_at_once(tmp_path):
    """With nobody at the port, rerun's gRPC sink would hold every message until its queue is
    full and then block the recording, file and all, for good (``phys2d run --live URL`` hung):
    the recorder refuses such a ``stream_to`` before it makes the file."""
    import socket
    import time

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        url = f"rerun+http://127.0.0.1:{s.getsockname()[1]}/proxy"
    start = time.monotonic()
    with pytest.raises(ValueError, match=re.escape(f"stream_to: no viewer listens at {url}")):
        Recorder(tmp_path / "never.rrd", stream_to=url, background=True)
    assert time.monotonic() - start < 10
    assert not (tmp_path / "never.rrd").exists()
    with pytest.raises(ValueError, match="stream_to 'rerun\\+http://\\[::1/proxy' is not a viewer URL"):
        Recorder(None, stream_to="rerun+http://[::1/proxy")


def test_a_stream_only_close_ends_when_the_viewer_takes_the_connection_but_never_the_data(monkeypatch):
    """A port that accepts connections and never answers (a hung viewer, or no viewer at all):
    rerun can block the writer process for good, so a recorder with no file to finish waits
    ``STREAM_FLUSH_S`` + ``STUCK_S`` (1 + 2 s here) for its writer's answer, then stops the writer
    and raises a StreamError naming the viewer (it waited forever before)."""
    import socket
    import time

    from phys2d.recording import recorder, sink
    from phys2d.recording.sink_settings import StreamError

    for module in (recorder, sink):  # (the writer process is forked: it has sink's too)
        monkeypatch.setattr(module, "STREAM_FLUSH_S", 1.0)
    monkeypatch.setattr(recorder, "STUCK_S", 2.0)
    with socket.socket() as silent:
        silent.bind(("127.0.0.1", 0))
        silent.listen(16)  # connections complete in the backlog; nothing is read or answered
        url = f"rerun+http://127.0.0.1:{silent.getsockname()[1]}/proxy"
        rec = Recorder(None, stream_to=url, background=True, flush_every=6)
        writer = rec._state.backend.proc
        w = phys2d.scenes.vertical_stack(3)
        for _ in range(120):
            w.step(1 / 60)
            rec.log(w)
        start = time.monotonic()
        with pytest.raises(StreamError, match=re.escape(f"the viewer at {url} did not take the recording")):
            rec.close()
        assert time.monotonic() - start < 20
    assert rec.closed and not writer.is_alive()
