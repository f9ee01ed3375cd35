"""Capsules, segments and chains (issue 27): resting heights and contact points against the geometry,
mass properties against the closed form and a quadrature, sliding along a chain against a single
long segment (and against separate segments, which do bump), one-sidedness, feature ids, filtering,
the recordings' outlines, the stock scene, and bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numba import config as numba_config

import phys2d
from phys2d import scenes, shapes
from phys2d.collision import describe_feature
from phys2d.collision.narrowphase import pair_kind
from phys2d.recording.sample import Strips

# one worker runs the worlds at rest below: their ticks (capsules, each responder) compile once, not on
# both workers at the same time (a module mark would also rename the fresh_cache test's group)
AT_REST = pytest.mark.xdist_group("capsules_at_rest")

DT = 1.0 / 60.0
RESPONDERS = ("pgs", "pgs-block", "soft-step")


def ground_world(responder: str = "pgs", **kw) -> phys2d.World:
    """A world whose static ground box has its top at y = 0."""
    w = phys2d.World(responder=phys2d.make_responder(responder), **kw)
    w.add_box(position=(0.0, -0.5), half_extents=(10.0, 0.5), static=True)
    return w


def run(w: phys2d.World, steps: int) -> None:
    for _ in range(steps):
        w.step(DT)


# -- resting: heights and contact points from the geometry --------------------------------------


@AT_REST
@pytest.mark.parametrize("responder", RESPONDERS)
def test_a_capsule_on_its_side_rests_radius_above_the_ground_on_two_points(responder):
    """Its core lies r above the ground; the two points sit under the core's ends, on the ground's
    surface (midway between surfaces that touch), with the normal straight up."""
    w = ground_world(responder)
    h, r = 0.6, 0.25
    cap = w.add_capsule((1.0, r + 0.1), half_length=h, radius=r)
    run(w, 120)
    tol = 2e-3 if responder == "soft-step" else 1e-4  # the soft step's springs give a little
    assert cap.position[1] == pytest.approx(r, abs=tol)
    assert abs(cap.angle) < 1e-6 and np.linalg.norm(cap.velocity) < 1e-3
    c = w.contacts
    assert len(c) == 2
    np.testing.assert_allclose(c.normal, [[0.0, 1.0], [0.0, 1.0]], atol=1e-9)
    np.testing.assert_allclose(np.sort(c.point[:, 0]), [1.0 - h, 1.0 + h], atol=tol)
    np.testing.assert_allclose(c.point[:, 1], 0.0, atol=tol)
    assert np.sum(c.lambda_n) == pytest.approx(cap.mass * 10.0 * DT, rel=1e-3)  # it carries its weight


@AT_REST
def test_a_capsule_standing_on_its_end_rests_on_one_point_under_its_axis():
    """Upright, its lowest point is its cap's: the centre stays h + r above the ground, one point
    right under the centre, and it does not tip."""
    w = ground_world()
    h, r = 0.5, 0.2
    cap = w.add_capsule((0.0, h + r + 0.05), half_length=h, radius=r, angle=math.pi / 2)
    run(w, 120)
    assert cap.position[1] == pytest.approx(h + r, abs=1e-4)
    assert cap.angle == pytest.approx(math.pi / 2, abs=1e-9)
    c = w.contacts
    assert len(c) == 1
    assert c.point[0] == pytest.approx([0.0, 0.0], abs=1e-4)


@AT_REST
def test_a_capsule_lies_on_a_capsule_and_a_ball_on_a_rounded_segment():
    """Rounded on rounded: a capsule across another rests 2 r above it (cores 2 r apart); a ball on
    a segment of radius r_s rests r_s + r_ball above the segment's core."""
    w = ground_world()
    r = 0.2
    low = w.add_capsule((0.0, r), half_length=1.0, radius=r)
    top = w.add_capsule((0.3, 3 * r + 0.05), half_length=0.5, radius=r)
    w.add_segment((4.0, 1.0), (8.0, 1.0), radius=0.1)
    ball = w.add_circle((6.0, 1.5), radius=0.3)
    run(w, 150)
    assert top.position[1] - low.position[1] == pytest.approx(2 * r, abs=2e-4)
    assert ball.position[1] == pytest.approx(1.0 + 0.1 + 0.3, abs=1e-4)
    pairs = {(int(a), int(b)) for a, b in zip(w.contacts.body_a, w.contacts.body_b, strict=True)}
    assert (low.index, top.index) in pairs


@AT_REST
def test_a_box_on_a_segment_and_a_capsule_end_on_a_box_corner():
    """A box rests on a bare segment at its half height; a capsule lying against a box's top corner
    end first meets it with its cap: one point, the normal along the line from corner to cap centre."""
    w = phys2d.World(gravity=(0.0, 0.0))
    box = w.add_box((0.0, 0.0), half_extents=(0.5, 0.5), static=True)
    r = 0.25
    d = np.array([1.0, 1.0]) / math.sqrt(2.0)
    end = np.array([0.5, 0.5]) + d * (r - 0.001)  # the cap's centre, 1 mm inside the corner
    cap = w.add_capsule((end[0] + 0.4, end[1]), half_length=0.4, radius=r)
    w.step(DT)
    c = w.contacts
    assert len(c) == 1 and {int(c.body_a[0]), int(c.body_b[0])} == {box.index, cap.index}
    np.testing.assert_allclose(c.normal[0], d, atol=1e-9)
    assert c.separation[0] == pytest.approx(-0.001, abs=1e-9)
    f = describe_feature(int(c.feature[0]), "polygons")
    assert f.closest_a == ("vertex", 2) and f.closest_b == ("vertex", 0)  # the box's top right corner, the cap's end
    w2 = phys2d.World()
    w2.add_segment((-3.0, 0.0), (3.0, 0.0))
    b = w2.add_box((0.0, 0.6), half_extents=(0.5, 0.5))
    run(w2, 90)
    assert b.position[1] == pytest.approx(0.5, abs=1e-4)


# -- mass properties ----------------------------------------------------------------------------


def stadium_quadrature(h: float, r: float, n: int = 1200) -> tuple[float, float]:
    """Area and polar moment about the centre of the stadium |y| <= r around the core
    [-h, h] x {0}, by the midpoint rule on an n x n grid over its bounding box."""
    xs = (np.arange(n) + 0.5) / n * 2 * (h + r) - (h + r)
    ys = (np.arange(n) + 0.5) / n * 2 * r - r
    x, y = np.meshgrid(xs, ys)
    dx = np.clip(np.abs(x) - h, 0.0, None)
    inside = dx * dx + y * y <= r * r
    cell = (2 * (h + r) / n) * (2 * r / n)
    return float(inside.sum() * cell), float(np.sum((x * x + y * y)[inside]) * cell)


@settings(max_examples=20, deadline=None)
@given(h=st.floats(0.05, 3.0), r=st.floats(0.05, 1.0), density=st.floats(0.1, 10.0))
def test_capsule_mass_and_inertia_are_the_closed_form(h, r, density):
    """m = rho (4 h r + pi r^2); I = rho [4 h r (4 h^2 + 4 r^2) / 12 + pi r^2 (r^2 / 2 + h^2 + 8 h r / (3 pi))]
    (a rectangle and a disc split to its ends, by the parallel axis theorem)."""
    w = phys2d.World()
    cap = w.add_capsule((0.0, 0.0), half_length=h, radius=r, density=density)
    area = 4 * h * r + math.pi * r * r
    disc = math.pi * r * r
    inertia = 4 * h * r * (4 * h * h + 4 * r * r) / 12 + disc * (r * r / 2 + h * h + 8 * h * r / (3 * math.pi))
    assert cap.mass == pytest.approx(density * area, rel=1e-12)
    assert cap.inertia == pytest.approx(density * inertia, rel=1e-12)


@pytest.mark.parametrize("h, r", [(0.5, 0.25), (2.0, 0.1), (0.1, 1.0)])
def test_capsule_mass_properties_match_a_quadrature(h, r):
    """A second method: the midpoint rule over the stadium, to its resolution."""
    spec = shapes.capsule(h, r)
    area, polar = stadium_quadrature(h, r)
    assert spec.area == pytest.approx(area, rel=2e-3)
    assert spec.unit_inertia == pytest.approx(polar, rel=2e-3)


def test_segments_and_chains_are_static_with_their_points_placed():
    w = phys2d.World()
    s = w.add_segment((1.0, 2.0), (3.0, 2.0), radius=0.1)
    chain = w.add_chain([(4.0, 0.0), (2.0, 1.0), (0.0, 0.0)])
    assert s.static and s.shape == "segment" and s.radius == 0.1
    np.testing.assert_allclose(s.position, [2.0, 2.0])
    np.testing.assert_allclose(s.vertices, [[1.0, 2.0], [3.0, 2.0]])
    assert isinstance(chain, tuple) and len(chain) == 2 and all(b.static and b.shape == "chain" for b in chain)
    np.testing.assert_allclose(chain[1].vertices, [[2.0, 1.0], [0.0, 0.0]])
    assert w.add_chain([(0.0, 0.0), (1.0, 0.0), (0.0, 1.0)], loop=True).__len__() == 3
    assert "capsule length=1 r=0.2" in repr(w.add_capsule((0.0, 5.0), half_length=0.5, radius=0.2))


# -- a chain is smooth: no bump at the joins ------------------------------------------------------


def slide(ground: str, shape: str, responder: str = "pgs", steps: int = 150):
    """A body sliding at 6 m/s without friction along y = 0 (from x = -5): the largest |v_y| (m/s)
    over the run, its final position and angle. The ground: a chain of 0.5 m collinear segments,
    one long segment, or the same 0.5 m pieces as separate two-sided segments."""
    w = phys2d.World(responder=phys2d.make_responder(responder))
    points = [(x, 0.0) for x in np.arange(10.0, -10.01, -0.5)]  # right to left: the top collides
    if ground == "chain":
        w.add_chain(points, friction=0.0)
    elif ground == "pieces":
        for p, q in zip(points[:-1], points[1:], strict=True):
            w.add_segment(p, q, friction=0.0)
    else:
        w.add_segment((10.0, 0.0), (-10.0, 0.0), friction=0.0)
    if shape == "box":
        body = w.add_box((-5.0, 0.25), half_extents=(0.25, 0.25), velocity=(6.0, 0.0), friction=0.0, density=50.0)
    else:
        body = w.add_capsule((-5.0, 0.2), half_length=0.3, radius=0.2, velocity=(6.0, 0.0), friction=0.0, density=50.0)
    vy = []
    for _ in range(steps):
        w.step(DT)
        vy.append(body.velocity[1])
    return float(np.max(np.abs(vy))), body.position, body.angle


@pytest.mark.parametrize("responder", ["pgs", "soft-step"])
@pytest.mark.parametrize("shape", ["box", "capsule"])
def test_sliding_along_a_collinear_chain_meets_no_bump(shape, responder):
    """Across 20 joins the vertical velocity stays ~0, as on one long segment, and the body ends where
    it would on that segment; the same pieces as separate segments catch its corner (the control)."""
    on_chain = slide("chain", shape, responder)
    on_segment = slide("segment", shape, responder)
    assert on_chain[0] < 1e-3 and on_segment[0] < 1e-3
    np.testing.assert_allclose(on_chain[1], on_segment[1], atol=1e-3)
    assert abs(on_chain[2]) < 1e-3
    assert slide("pieces", shape, responder)[0] > 0.1  # ghost vertices are what make the difference


def test_a_ball_rolls_over_the_joins_of_a_chain_without_a_bump():
    w = phys2d.World()
    w.add_chain([(x, 0.0) for x in np.arange(6.0, -6.01, -0.25)])
    ball = w.add_circle((-4.0, 0.3), radius=0.3, velocity=(3.0, 0.0), angular_velocity=-10.0)
    vy = []
    for _ in range(120):
        w.step(DT)
        vy.append(ball.velocity[1])
    assert max(abs(v) for v in vy) < 1e-6
    assert ball.position[1] == pytest.approx(0.3, abs=1e-6)


# -- a chain is one-sided -----------------------------------------------------------------------------


@pytest.mark.parametrize("shape", ["box", "capsule", "circle"])
def test_a_chain_stops_bodies_from_its_right_side_only(shape):
    """Without gravity, a body moving up from below the chain (its left side) passes through; the same
    body moving down from above (its right side) stops on it."""

    def fire(y0: float, vy: float) -> float:
        w = phys2d.World(gravity=(0.0, 0.0))
        w.add_chain([(4.0, 0.0), (0.0, 0.0), (-4.0, 0.0)])
        opts = dict(velocity=(0.0, vy), restitution=0.0)
        if shape == "box":
            b = w.add_box((0.3, y0), half_extents=(0.3, 0.3), **opts)
        elif shape == "capsule":
            b = w.add_capsule((0.3, y0), half_length=0.3, radius=0.3, **opts)
        else:
            b = w.add_circle((0.3, y0), radius=0.3, **opts)
        run(w, 60)
        return float(b.position[1])

    assert fire(-1.0, 3.0) > 1.5  # through from below
    assert fire(1.0, -3.0) == pytest.approx(0.3, abs=1e-3)  # stopped from above


def test_a_closed_loop_holds_bodies_outside_it():
    """A counter-clockwise loop collides from outside: a box dropped on a square loop rests on its
    top edge; a box inside it falls through the bottom edge."""
    w = phys2d.World()
    w.add_chain([(-2.0, -2.0), (2.0, -2.0), (2.0, 0.0), (-2.0, 0.0)], loop=True)
    outside = w.add_box((0.0, 0.6), half_extents=(0.5, 0.5))
    inside = w.add_box((0.0, -1.0), half_extents=(0.3, 0.3))
    run(w, 90)
    assert outside.position[1] == pytest.approx(0.5, abs=1e-3)
    assert inside.position[1] < -2.5


# -- feature ids, warm starting, filtering -------------------------------------------------------------


def test_feature_ids_stay_the_same_while_a_capsule_slides_along_a_chain_segment():
    """A capsule sliding along one chain segment keeps its two points' ids from tick to tick, so
    every tick after the first warm starts both. It slides all along: mu = sqrt(0.3 * 0.6) takes
    mu g = 4.24 m/s^2 off its 6 m/s, 1.40 m/s left after 65 ticks (Coulomb, on the flat)."""
    w = phys2d.World()
    w.add_chain([(10.0, 0.0), (-10.0, 0.0)], friction=0.3)
    cap = w.add_capsule((-3.0, 0.2), half_length=0.4, radius=0.2, velocity=(6.0, 0.0), friction=0.6)
    run(w, 5)
    keys = None
    for _ in range(60):
        w.step(DT)
        c = w.contacts
        assert len(c) == 2 and c.warm_started.all()
        if keys is not None:
            assert sorted(c.key.tolist()) == keys
        keys = sorted(c.key.tolist())
    mu_g = math.sqrt(0.3 * 0.6) * -w.gravity[1]
    assert cap.velocity[0] == pytest.approx(6.0 - mu_g * 65 * DT, rel=1e-6)  # still sliding
    assert {describe_feature(int(f), "polygons").reference for f in w.contacts.feature} == {"a"}


def test_describe_feature_knows_the_new_pairs():
    assert pair_kind(shapes.CAPSULE, shapes.POLYGON) == "polygons"
    assert pair_kind(shapes.CHAIN, shapes.CAPSULE) == "polygons"
    assert pair_kind(shapes.CIRCLE, shapes.SEGMENT) == "circle-polygon"
    assert pair_kind(shapes.CIRCLE, shapes.CIRCLE) == "circles"
    f = describe_feature(0x80 | (1 << 8) | (1 << 14) | (0 << 1), "polygons")
    assert f.closest_a == ("edge", 1) and f.closest_b == ("vertex", 0)
    assert "closest features" in repr(f)


def test_the_collision_filter_holds_for_capsules_and_chains():
    """A capsule whose mask leaves out the chain's category falls through it; one of the same negative
    group as the chain does too; the default filter holds it."""
    w = phys2d.World()
    w.add_chain([(4.0, 0.0), (-4.0, 0.0)], category=0b10, group=-3)
    held = w.add_capsule((-2.0, 0.3), half_length=0.3, radius=0.2)
    masked = w.add_capsule((0.0, 0.3), half_length=0.3, radius=0.2, mask=0b01)
    grouped = w.add_capsule((2.0, 0.3), half_length=0.3, radius=0.2, group=-3)
    run(w, 60)
    assert held.position[1] == pytest.approx(0.2, abs=1e-3)
    assert masked.position[1] < -1.0 and grouped.position[1] < -1.0


def test_segments_and_chains_never_collide_with_static_bodies():
    w = ground_world()
    w.add_segment((-1.0, -0.1), (1.0, -0.1))  # inside the ground box
    w.add_chain([(1.0, 0.0), (-1.0, -0.2)])
    w.step(DT)
    assert len(w.contacts) == 0


# -- recordings, the stock scene, compare and sweeps -------------------------------------------------


def test_the_recordings_draw_capsules_as_stadiums_and_segments_as_lines():
    """Every outline point of a capsule lies r from its core; a segment's and a chain's strip are
    their two end points."""
    w = phys2d.World()
    cap = w.add_capsule((1.0, 2.0), half_length=0.5, radius=0.3, angle=0.7)
    seg = w.add_segment((0.0, 0.0), (2.0, 1.0))
    link = w.add_chain([(3.0, 0.0), (2.0, 0.0)])[0]
    strips = Strips.of(w, np.array([cap.index, seg.index, link.index]))
    pts = strips.world_points(w.x[None], w.theta[None])[0].astype(np.float64)
    n_cap = int(strips.lengths[0])
    a, b = cap.vertices
    t = np.clip((pts[:n_cap] - a) @ (b - a) / np.dot(b - a, b - a), 0.0, 1.0)
    dist = np.linalg.norm(pts[:n_cap] - (a + t[:, None] * (b - a)), axis=1)
    np.testing.assert_allclose(dist, 0.3, atol=1e-4)
    assert n_cap > 20 and np.allclose(pts[0], pts[n_cap - 1], atol=1e-4)  # closed
    np.testing.assert_allclose(pts[n_cap : n_cap + 2], seg.vertices, atol=1e-4)
    np.testing.assert_allclose(pts[n_cap + 2 :], link.vertices, atol=1e-4)


def test_a_recording_of_capsules_and_chains_reads_back(tmp_path):
    """Through the Recorder: every tick's poses come back exactly, static chains included."""
    from phys2d.recording import Recorder, playback

    w = scenes.capsules_on_chain(2)
    path = tmp_path / "capsules.rrd"
    with Recorder(path, name="capsules") as rec:
        for _ in range(5):
            w.step(DT)
            rec.log(w)
    back = playback.load(path)
    assert list(back.tick) == [1, 2, 3, 4, 5]
    np.testing.assert_array_equal(back.x[-1], w.x)  # every body, the chain's static segments too


def test_capsules_on_chain_is_a_stock_scene_that_stands():
    assert scenes.SCENES["capsules_on_chain"][0] is scenes.capsules_on_chain
    for responder in ("pgs", "soft-step"):
        w = scenes.capsules_on_chain(4, responder=phys2d.make_responder(responder))
        assert {b.shape for b in w.bodies} == {"chain", "capsule", "polygon"}
        watch = phys2d.Watch(w)
        for _ in range(120):
            w.step(DT)
            watch.observe()
        assert watch.verdict().stood, (responder, watch.verdict().line())


def test_a_sweep_runs_the_new_scene():
    from phys2d.sweeps import Task, run_task

    row = run_task(
        Task(
            scene="capsules_on_chain",
            size=2,
            mass_ratio=None,
            responder="pgs",
            iterations=10,
            substeps=None,
            dt=DT,
            steps=30,
            friction=None,
            seed=None,
            jitter=None,
        )
    )
    assert row["outcome"] == "stood" and row["error"] == ""


# -- bad input ------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "call, error, fragment",
    [
        (lambda w: w.add_capsule((0, 0), half_length=0.5, radius=-0.1), ValueError, "radius"),
        (lambda w: w.add_capsule((0, 0), half_length=0.5, radius=math.nan), ValueError, "radius"),
        (lambda w: w.add_capsule((0, 0), half_length=-0.5, radius=0.1), ValueError, "half_length"),
        (lambda w: w.add_capsule((0, 0), half_length=math.nan, radius=0.1), ValueError, "half_length"),
        (lambda w: w.add_capsule((0, 0), half_length=0.0, radius=0.1), ValueError, "half_length"),
        (lambda w: w.add_capsule((0, 0), half_length="1", radius=0.1), TypeError, "half_length"),
        (lambda w: w.add_capsule((0, 0), half_length=0.5, radius=0.1, density=-1.0), ValueError, "density"),
        (lambda w: w.add_segment((0, 0), (1, 0), radius=-0.1), ValueError, "radius"),
        (lambda w: w.add_segment((0, 0), (0, 0)), ValueError, "repeated"),
        (lambda w: w.add_segment((0, math.nan), (1, 0)), ValueError, "a must be finite"),
        (lambda w: w.add_segment((0, 0), (1, 0), static=False), ValueError, "static"),
        (lambda w: w.add_segment((0, 0), (1, 0), kinematic=True), ValueError, "kinematic"),
        (lambda w: w.add_segment((0, 0), (1, 0), angle=0.3), TypeError, "angle"),
        (lambda w: w.add_chain([(0, 0)]), ValueError, "points"),
        (lambda w: w.add_chain([(0, 0), (1, 0)], loop=True), ValueError, "points"),
        (lambda w: w.add_chain([(0, 0), (1, 0), (1, 0), (2, 0)]), ValueError, "points 1 and 2"),
        (lambda w: w.add_chain([(0, 0), (1, 0), (0, 0)], loop=True), ValueError, "repeated"),
        (lambda w: w.add_chain([(0, 0), (1, math.nan), (2, 0)]), ValueError, "point 1"),
        (lambda w: w.add_chain("abc"), TypeError, "points"),
        (lambda w: w.add_chain([(0, 0), (1, 0)], friction=-1.0), ValueError, "friction"),
        (lambda w: w.add_chain([(0, 0), (1, 0)], loop="yes"), TypeError, "loop"),
    ],
)
def test_bad_input_is_refused_by_name_and_changes_nothing(call, error, fragment):
    w = ground_world()
    before = (len(w), w.x.copy(), w.local_vertices.copy())
    with pytest.raises(error, match=fragment):
        call(w)
    assert len(w) == before[0]
    np.testing.assert_array_equal(w.x, before[1])
    np.testing.assert_array_equal(w.local_vertices, before[2])
    w.step(DT)  # and it still steps


def test_removing_chain_segments_keeps_the_other_bodies_shapes():
    """A chain segment stores two ghost vertices after its own: removing one shifts later bodies'
    vertex rows by all four, and they keep their shapes."""
    w = phys2d.World()
    links = w.add_chain([(2.0, 0.0), (1.0, 0.0), (0.0, 0.0)])
    box = w.add_box((5.0, 1.0), half_extents=(0.5, 0.25))
    before = box.vertices.copy()
    w.remove(links[0])
    np.testing.assert_array_equal(box.vertices, before)
    np.testing.assert_allclose(links[1].vertices, [[1.0, 0.0], [0.0, 0.0]])
    run(w, 3)


# -- compiling: a world without the new shapes compiles none of their code ------------------------


@pytest.mark.skipif(numba_config.DISABLE_JIT, reason="nothing is compiled")
@pytest.mark.fresh_numba_cache
@pytest.mark.xdist_group("fresh_cache")
def test_a_world_of_boxes_compiles_none_of_the_rounded_shapes_code(fresh_cache_compiles):
    """On a fresh cache, a pyramid's first step compiles the narrowphase but nothing of
    ``collision.rounded``: numba prunes the tick's branch for capsules, segments and chains.
    (The pyramid's child process is shared with tests/test_ahead.py: ``tests/fresh_cache.py``.)"""
    compiled = fresh_cache_compiles["pyramid"]["first_step_modules"]
    assert "phys2d.collision.narrowphase" in compiled, compiled
    assert "phys2d.collision.rounded" not in compiled, "a world of boxes compiled phys2d.collision.rounded"
