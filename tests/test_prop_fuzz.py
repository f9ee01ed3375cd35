"""Input fuzzing: every public entry point rejects bad input with a ValueError or
TypeError naming the argument, and leaves the world bit-identical; valid but extreme
input never produces NaN or infinities."""

from __future__ import annotations

import inspect
import math
from collections.abc import Callable
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import phys2d
from tests.strategies import (
    SceneSpec,
    all_finite,
    build,
    ellipse_polygons,
    fingerprint,
    reals,
    responders,
    scenes,
    step_or_undone,
)

NAN, INF = float("nan"), float("inf")

# -- bad values ---------------------------------------------------------------------

not_numbers = st.sampled_from(
    [None, "1.0", b"1", [1.0], (1.0,), {"x": 1.0}, 1 + 2j, True, False, np.array([1.0]), object()]
)
non_finite = st.sampled_from([NAN, INF, -INF, np.float32("nan"), np.float64("-inf")])
bad_scalars = not_numbers | non_finite

bad_pairs = st.sampled_from(
    [
        None,
        "ab",
        b"xy",
        1.0,
        (1.0,),
        (1.0, 2.0, 3.0),
        [[1.0, 2.0]],
        [[1.0], [2.0, 3.0]],
        (1 + 1j, 2.0),
        np.array([True, False]),
        np.array([1.0, None], dtype=object),
        {"x": 1.0, "y": 2.0},
        np.zeros((2, 1)),
        (NAN, 0.0),
        (0.0, INF),
        (-INF, -INF),
        np.array([0.0, np.nan]),
    ]
)


def rejects(w: phys2d.World, name: str, call: Callable[[], object]) -> None:
    """``call`` raises ValueError or TypeError naming ``name`` and changes nothing in ``w``."""
    before = fingerprint(w)
    with pytest.raises((ValueError, TypeError)) as info:
        call()
    assert name in str(info.value), f"the error does not name {name!r}: {info.value}"
    assert fingerprint(w) == before


def stepped(scene: SceneSpec, steps: int = 3) -> phys2d.World:
    """A world with some history (contacts, cache, clock) for the fuzzers to disturb."""
    w = build(scene)
    for _ in range(steps):
        try:
            w.step(1 / 60)
        except phys2d.SimulationError:
            break
    return w


worlds = scenes(max_bodies=4, ground=None, static=None).map(stepped)

# every add_* argument with values it must refuse
SHAPE_ARGS = {"box": "half_extents", "circle": "radius", "polygon": "vertices"}
VALID_SHAPE = {"box": (0.5, 0.5), "circle": 0.5, "polygon": [(0, 0), (1, 0), (0, 1)]}
BAD_ARGS: dict[str, st.SearchStrategy] = {
    "position": bad_pairs,
    "velocity": bad_pairs,
    "half_extents": bad_pairs
    | st.sampled_from([(0.0, 1.0), (1.0, -1.0), (-2.0, -2.0), (1e-9, 1.0), (1e200, 1e200), (1e-200, 1e-200)]),
    "radius": bad_scalars | st.sampled_from([0.0, -1.0, -INF, 1e-170, 1e160, 1e300]),
    "vertices": st.sampled_from(
        [
            None,
            "abc",
            3.0,
            [],
            [(0, 0), (1, 0)],
            [(0, 0, 0), (1, 0, 0), (0, 1, 0)],
            [(0, 0), (1, 0), (NAN, 1)],
            [(0, 0), (1, 0), (0, INF)],
            [(0, 0), (0, 1), (1, 0)],
            [(0, 0), (1, 0), (2, 0)],
            [(0, 0), (1, 0), (1, 0), (0, 1)],
            [(0, 0), ("a", 0), (0, 1)],
            [(0, 0), (1e-200, 0), (0, 1e-200)],
            [(0, 0), (1e160, 0), (0, 1e160)],
            [(1e155, 0), (-1e155, 1e155), (-1e155, -1e155)],
        ]
    ),
    "angle": bad_scalars,
    "density": bad_scalars | st.sampled_from([0.0, -1.0, 1e-320, 5e-324]),
    "friction": bad_scalars | st.sampled_from([-1e-9, -1.0]),
    "restitution": bad_scalars | st.sampled_from([-0.1, 1.0000001, 2.0]),
    "static": st.sampled_from([None, 1, 0, "True", 1.0, [True]]),
    "angular_velocity": bad_scalars,
}


@given(data=st.data(), w=worlds, kind=st.sampled_from(["box", "circle", "polygon"]))
def test_add_rejects_every_bad_argument(data, w: phys2d.World, kind: str) -> None:
    """add_box/add_circle/add_polygon with one bad argument (NaN, infinities, wrong
    types and shapes, zero, negative, huge and tiny sizes) raise an error naming it
    and add nothing."""
    names = [a for a in BAD_ARGS if a not in SHAPE_ARGS.values() or a == SHAPE_ARGS[kind]]
    name = data.draw(st.sampled_from(names))
    value = data.draw(BAD_ARGS[name], label=name)
    kwargs = {SHAPE_ARGS[kind]: VALID_SHAPE[kind], name: value}
    rejects(w, name, lambda: getattr(w, f"add_{kind}")(**kwargs))


@st.composite
def bad_polygons(draw) -> tuple[str, list]:
    """(what is wrong, vertices): non-convex, self-intersecting, clockwise, collinear,
    repeated points, too few or too many points."""
    v = [tuple(p) for p in draw(ellipse_polygons())]
    n = len(v)
    flaw = draw(st.sampled_from(["non-convex", "star", "clockwise", "collinear", "repeated", "few", "many"]))
    if flaw == "non-convex":  # a dent: a new vertex inside edge k, pulled towards the centre
        k = draw(st.integers(0, n - 1))
        a, b = np.array(v[k]), np.array(v[(k + 1) % n])
        centre = np.mean(v, axis=0)
        mid = 0.5 * (a + b)
        v.insert(k + 1, tuple(mid + draw(reals(0.1, 0.9)) * (centre - mid)))
    elif flaw == "star":  # a regular polygon visited every second (third...) vertex
        m = draw(st.sampled_from([5, 7, 8, 9]))
        step = draw(st.sampled_from([s for s in range(2, m // 2 + 1) if math.gcd(s, m) == 1]))
        t = 2 * math.pi * step * np.arange(m) / m
        v = [(math.cos(u), math.sin(u)) for u in t]
    elif flaw == "clockwise":
        v = v[::-1]
    elif flaw == "collinear":
        k = draw(st.integers(0, n - 1))
        a, b = np.array(v[k]), np.array(v[(k + 1) % n])
        v.insert(k + 1, tuple(a + draw(reals(0.2, 0.8)) * (b - a)))
    elif flaw == "repeated":
        k = draw(st.integers(0, n - 1))
        v.insert(k, v[k])
    elif flaw == "few":
        v = v[: draw(st.integers(0, 2))]
    else:
        t = 2 * math.pi * np.arange(65) / 65
        v = [(math.cos(u), math.sin(u)) for u in t]
    return flaw, v


@given(w=worlds, bad=bad_polygons())
def test_bad_polygons_are_refused(w: phys2d.World, bad) -> None:
    """Non-convex, self-intersecting (star), clockwise, collinear, repeated-point and
    too-short or too-long vertex lists: ValueError naming ``vertices``, nothing added."""
    flaw, v = bad
    rejects(w, "vertices", lambda: w.add_polygon(position=(0.0, 3.0), vertices=v))


@given(w=worlds, dt=bad_scalars | st.sampled_from([0.0, -0.0, -1 / 60, -1e-300, -INF]))
def test_step_refuses_bad_dt(w: phys2d.World, dt) -> None:
    """step(dt) with dt zero, negative, NaN, infinite or not a number: error naming dt."""
    rejects(w, "dt", lambda: w.step(dt))


@given(data=st.data(), w=worlds)
def test_body_handles_refuse_bad_values(data, w: phys2d.World) -> None:
    """Body setters and apply_impulse: bad values raise errors naming the property and
    leave the world as it was (including an impulse whose velocity would overflow)."""
    assert len(w.bodies) > 0
    body = data.draw(st.sampled_from(w.bodies))
    what = data.draw(
        st.sampled_from(
            [
                "position",
                "velocity",
                "angle",
                "angular_velocity",
                "friction",
                "restitution",
                "impulse",
                "point",
                "overflow",
            ]
        )
    )
    if what in ("position", "velocity"):
        value = data.draw(bad_pairs)
        rejects(w, what, lambda: setattr(body, what, value))
    elif what in ("angle", "angular_velocity"):
        value = data.draw(bad_scalars)
        rejects(w, what, lambda: setattr(body, what, value))
    elif what == "friction":
        value = data.draw(bad_scalars | st.sampled_from([-1.0, -1e-300]))
        rejects(w, what, lambda: setattr(body, what, value))
    elif what == "restitution":
        value = data.draw(bad_scalars | st.sampled_from([-0.5, 1.5]))
        rejects(w, what, lambda: setattr(body, what, value))
    elif what == "impulse":
        value = data.draw(bad_pairs)
        rejects(w, "impulse", lambda: body.apply_impulse(value))
    elif what == "point":
        value = data.draw(bad_pairs.filter(lambda v: v is not None))  # None: the centre of mass
        rejects(w, "point", lambda: body.apply_impulse((1.0, 0.0), point=value))
    else:
        if body.static:
            return
        rejects(w, "impulse", lambda: body.apply_impulse((1.7e308, 1.7e308), point=body.position + 1e300))


@given(w=worlds, other=worlds, data=st.data())
def test_removed_and_foreign_bodies_are_refused(w: phys2d.World, other: phys2d.World, data) -> None:
    """A removed body's handle, a body of another world and things that are not bodies:
    remove() refuses them naming ``body``, and a removed handle refuses every use."""
    gone = data.draw(st.sampled_from(w.bodies))
    w.remove(gone)
    rejects(w, "body", lambda: w.remove(gone))
    rejects(w, "body", lambda: w.remove(other.bodies[0]))
    rejects(other, "body", lambda: other.remove(gone))
    rejects(w, "item", lambda: w.remove(data.draw(st.sampled_from([None, 0, "body", w]))))
    rejects(w, "removed", lambda: gone.position)
    rejects(w, "removed", lambda: setattr(gone, "velocity", (1.0, 0.0)))
    rejects(w, "removed", lambda: gone.apply_impulse((1.0, 0.0)))
    if w.bodies:  # removing the same body twice through a second handle is refused too
        rejects(w, "body", lambda: w.remove(gone))


@given(data=st.data(), w=worlds)
def test_world_settings_refuse_bad_values(data, w: phys2d.World) -> None:
    """World(...) and the gravity/responder setters refuse bad values naming them;
    so does angular_momentum(about)."""
    name = data.draw(
        st.sampled_from(["gravity", "responder", "contact_margin", "max_speed", "contact_recycle_distance", "about"])
    )
    if name == "gravity":
        value = data.draw(bad_pairs)
        rejects(w, "gravity", lambda: setattr(w, "gravity", value))
        rejects(w, "gravity", lambda: phys2d.World(gravity=value))
    elif name == "responder":
        value = data.draw(st.sampled_from([None, "pgs", phys2d.PGS, 1, object()]))
        if value is not None:  # None means the default PGS in the constructor
            rejects(w, "responder", lambda: phys2d.World(responder=value))
        rejects(w, "responder", lambda: setattr(w, "responder", value))
    elif name == "contact_margin":
        value = data.draw(bad_scalars | st.sampled_from([-1e-3, -1.0]))
        rejects(w, name, lambda: phys2d.World(contact_margin=value))
    elif name == "contact_recycle_distance":
        value = data.draw(bad_scalars | st.sampled_from([-1e-3, -1.0]))
        rejects(w, name, lambda: phys2d.World(contact_recycle_distance=value))
        rejects(w, name, lambda: setattr(w, name, value))
    elif name == "max_speed":
        value = data.draw(bad_scalars | st.sampled_from([0.0, -1.0]))
        rejects(w, name, lambda: phys2d.World(max_speed=value))
    else:
        value = data.draw(bad_pairs)
        rejects(w, "about", lambda: w.angular_momentum(value))


@given(data=st.data(), w=scenes(min_bodies=3, max_bodies=4, ground=None, static=False).map(stepped), other=worlds)
def test_joints_refuse_bad_input(data, w: phys2d.World, other: phys2d.World) -> None:
    """Joint constructors and joint removal refuse: bodies of another world (joints
    across worlds), removed bodies, a body joined to itself, non-bodies, bad anchors,
    lengths and limits, lower > upper, non-bool collide_connected, a joint removed twice
    or through the wrong world, and responders that cannot solve joints."""
    a, b, c = w.bodies[:3]
    w.add_distance_joint(a, b)  # some joint state to keep intact
    kind = data.draw(st.sampled_from(["distance", "pin", "angle"]))
    add = getattr(w, f"add_{kind}_joint")
    extra = {"pin": {"anchor": (0.0, 0.0)}}.get(kind, {})
    rejects(w, "b", lambda: add(a, other.bodies[0], **extra))
    rejects(w, "a", lambda: add(other.bodies[0], b, **extra))
    rejects(w, "a", lambda: add(data.draw(st.sampled_from([None, 1, "a"])), b, **extra))
    rejects(w, "same body", lambda: add(a, a, **extra))
    rejects(
        w,
        "collide_connected",
        lambda: add(a, c, collide_connected=data.draw(st.sampled_from([1, None, "no"])), **extra),
    )
    if kind == "distance":
        name = data.draw(st.sampled_from(["anchor_a", "anchor_b", "length"]))
        value = data.draw(
            (bad_scalars | st.sampled_from([0.0, -1.0]) if name == "length" else bad_pairs).filter(
                lambda v: v is not None
            )
        )  # None: the default
        rejects(w, name, lambda: w.add_distance_joint(a, c, **{name: value}))
        rejects(w, "anchor_a", lambda: w.add_distance_joint(a, c, anchor_a=(0.0, 0.0), anchor_b=(0.0, 0.0)))
    elif kind == "pin":
        rejects(w, "anchor", lambda: w.add_pin_joint(a, c, anchor=data.draw(bad_pairs)))
    else:
        name = data.draw(st.sampled_from(["lower", "upper"]))
        value = data.draw(bad_scalars.filter(lambda v: v is not None))  # None: no limit
        rejects(w, name, lambda: w.add_angle_joint(a, c, **{name: value}))
        rejects(w, "lower", lambda: w.add_angle_joint(a, c, lower=0.5, upper=-0.5))
    joint = w.joints[0]
    rejects(other, "joint", lambda: other.remove(joint))
    rejects(
        w,
        "responder",
        lambda: setattr(w, "responder", data.draw(st.sampled_from([phys2d.NaiveImpulse(), phys2d.IterativeImpulse()]))),
    )  # SoftStep solves joints (issue 11)
    gone = data.draw(st.sampled_from([a, b]))
    w.remove(gone)  # takes its joint with it
    assert not joint.alive
    rejects(w, "joint", lambda: w.remove(joint))
    rejects(w, "a" if gone is a else "b", lambda: add(a, c, **extra) if gone is a else add(c, b, **extra))


RESPONDER_ARGS: dict[str, dict[str, st.SearchStrategy]] = {
    "PGS": {
        "iterations": st.sampled_from([0, -1, 1.5, True, "10", None, NAN]),
        "warm_start": st.sampled_from([1, 0, "yes", None]),
        "beta": bad_scalars | st.sampled_from([-0.1, 1.5]),
        "slop": bad_scalars | st.sampled_from([-0.001]),
        "tolerance": not_numbers.filter(lambda v: v is not None) | non_finite | st.just(-1e-9),
        "restitution_threshold": bad_scalars | st.just(-1.0),
        "friction": st.sampled_from(["", "Coulomb", "none", None, 1, ["coulomb"], ("lecture",), np.array(["coulomb"])]),
        "form": st.sampled_from(["", "dense", None, 2, ["impulse"]]),
        "block": st.sampled_from([1, "no", None]),
    },
    "SoftStep": {
        "substeps": st.sampled_from([0, -3, 2.0, False, "4", None]),
        "relax": st.sampled_from([1, "yes", None]),
        "contact_hertz": bad_scalars | st.just(-1.0),
        "damping_ratio": bad_scalars | st.just(-1.0),
        "push_max": bad_scalars | st.just(-1.0),
        "restitution_threshold": bad_scalars | st.just(-0.5),
        "warm_start": st.sampled_from([1, None]),
        "block": st.sampled_from([0, "yes"]),
        "joint_hertz": bad_scalars | st.just(-1.0),
        "joint_damping_ratio": bad_scalars | st.just(-1.0),
        "direct_joints": st.sampled_from([1, "yes", None]),
    },
}


@given(data=st.data(), w=worlds, cls=st.sampled_from(sorted(RESPONDER_ARGS)))
def test_responders_refuse_bad_settings(data, w: phys2d.World, cls: str) -> None:
    """Every responder parameter refuses bad values with an error naming it."""
    name = data.draw(st.sampled_from(sorted(RESPONDER_ARGS[cls])))
    value = data.draw(RESPONDER_ARGS[cls][name], label=name)
    rejects(w, name, lambda: getattr(phys2d, cls)(**{name: value}))


def scene_arguments(make: Callable[..., phys2d.World]) -> dict[str, str]:
    """A stock scene's own arguments (all but ``responder``) and their annotated types."""
    params = inspect.signature(make).parameters
    return {name: str(p.annotation) for name, p in params.items() if name != "responder"}


def test_every_stock_scene_takes_its_arguments_by_name() -> None:
    """The fuzz below draws from each scene's real signature: every scene has arguments
    besides ``responder``, each an int (a count) or a float, each with a default."""
    for scene, (make, _) in phys2d.scenes.SCENES.items():
        args = scene_arguments(make)
        assert args, scene
        assert set(args.values()) <= {"int", "float"}, (scene, args)
        assert "responder" in inspect.signature(make).parameters, scene


bad_counts = st.sampled_from([0, -1, 2.5, "3", None, True, np.float64(3.0)])


@given(data=st.data())
def test_stock_scenes_refuse_bad_arguments(data) -> None:
    """Each stock scene refuses a bad value of each of its own arguments (counts: zero,
    negative, fractional, not integers; sizes and ratios: not numbers, not finite, <= 0;
    ``lean``: not a finite number; ``joint_friction``: < 0) with an error that starts with the argument's name,
    and refuses a responder that is not one."""
    scene = data.draw(st.sampled_from(sorted(phys2d.scenes.SCENES)))
    make = phys2d.scenes.SCENES[scene][0]
    args = scene_arguments(make)
    name = data.draw(st.sampled_from(sorted(args)), label="argument")
    if args[name] == "int":
        value = data.draw(bad_counts, label=name)
    elif name == "lean":  # any finite offset is a valid lean
        value = data.draw(bad_scalars, label=name)
    elif name == "joint_friction":  # 0: frictionless pins, valid
        value = data.draw(bad_scalars | st.sampled_from([-1.0, -INF]), label=name)
    else:
        value = data.draw(bad_scalars | st.sampled_from([0.0, -1.0, -INF]), label=name)
    with pytest.raises((ValueError, TypeError)) as info:
        make(**{name: value})
    assert str(info.value).startswith(f"{name} must"), f"{scene}({name}={value!r}): {info.value}"
    with pytest.raises(TypeError, match="responder"):
        make(responder="pgs")


# -- valid extremes ------------------------------------------------------------------


@st.composite
def extreme_scenes(draw) -> SceneSpec:
    """Valid but extreme: huge friction, densities 1e-6..1e6 (the whole range), sizes 1.5e-3..1e3 m,
    positions far from the origin, speeds near the limit."""
    scene = draw(scenes(max_bodies=5, ground=None, static=None, region=1.0))
    far = draw(st.sampled_from([0.0, 1e6, -1e9, 1e12]))
    out = []
    for b in scene.bodies:
        scale = draw(st.sampled_from([1e-2, 1.0, 1e3]))  # sizes 0.15..1 m scaled: within [MIN_SIZE, MAX_SIZE]
        if b.kind == "polygon":  # edges must stay >= MIN_EDGE_LENGTH
            scale = max(scale, 1e-2)
        size = (
            tuple(scale * s for s in b.size)
            if b.kind == "box"
            else scale * b.size
            if b.kind == "circle"
            else [(scale * x, scale * y) for x, y in b.size]
        )
        out.append(
            replace(
                b,
                size=size,
                position=(far + scale * b.position[0], scale * b.position[1]),
                friction=draw(st.sampled_from([0.0, 1.0, 1e3, 1e150, 1e200, 1.7e308])),
                density=draw(st.sampled_from([1e-6, 1.0, 1e6])),
                velocity=draw(st.sampled_from([(0.0, 0.0), (9e3, 0.0), (-5e3, 5e3)])),
            )
        )
    return replace(scene, bodies=tuple(out))


@given(scene=extreme_scenes(), responder=responders(), dt=st.sampled_from([1e-9, 1e-4, 1 / 60, 1.0, 1e3]))
def test_valid_extremes_never_go_non_finite(scene: SceneSpec, responder: phys2d.Responder, dt: float) -> None:
    """Extreme but valid input is accepted, and every step then leaves finite state,
    contacts and impulses, or raises SimulationError and changes nothing."""
    w = build(scene, responder)
    for _ in range(10):
        if not step_or_undone(w, dt):
            return
        assert all_finite(w)
        c = w.contacts
        assert np.all(np.isfinite(c.friction))
        if isinstance(responder, phys2d.PGS) and responder.friction == "coulomb":
            with np.errstate(over="ignore"):  # mu up to 1.7e308: a bound past the largest float is inf
                bound = c.friction * c.normal_impulse * (1 + 1e-12) + 1e-300
            assert np.all(np.abs(c.tangent_impulse) <= bound)


# -- the rest of the public entries that take floats (issue 41): each bad value refused by name ----

huge_or_tiny = st.sampled_from([1e-300, 1e-8, 1e-4, 2e5, 1e30, 1e300])


@given(data=st.data(), w=worlds)
def test_other_shapes_refuse_bad_sizes(data, w: phys2d.World) -> None:
    """add_capsule, add_segment and add_chain: NaN, infinities, wrong types and shapes, and sizes
    outside [1 mm, 100 km] are refused naming the argument; nothing is added."""
    what = data.draw(st.sampled_from(["half_length", "capsule radius", "a", "b", "segment radius", "points"]))
    if what == "half_length":
        value = data.draw(bad_scalars | st.sampled_from([0.0, -1.0, 1e30, 2e5]))
        rejects(w, "half_length", lambda: w.add_capsule((0.0, 3.0), half_length=value, radius=0.2))
    elif what == "capsule radius":
        value = data.draw(bad_scalars | huge_or_tiny.filter(lambda r: not 1e-3 <= r <= 1e5))
        rejects(w, "radius", lambda: w.add_capsule((0.0, 3.0), half_length=0.5, radius=value))
    elif what in ("a", "b"):
        value = data.draw(bad_pairs)
        ends = {"a": (0.0, 0.0), "b": (1.0, 0.0), what: value}
        rejects(w, what, lambda: w.add_segment(ends["a"], ends["b"]))
    elif what == "segment radius":
        value = data.draw(bad_scalars | st.sampled_from([-1.0, 1e-8, 1e30]))
        rejects(w, "radius", lambda: w.add_segment((0.0, 0.0), (1.0, 0.0), radius=value))
    else:
        value = data.draw(
            st.sampled_from([None, "ab", 3.0, [(0, 0)], [(0, 0, 0), (1, 1, 1)], [(0, 0), (NAN, 1)], [(0, 0), (INF, 0)]])
        )
        rejects(w, "points", lambda: w.add_chain(value))


BODY_FLOATS = {
    "gravity_scale": bad_scalars,
    "linear_damping": bad_scalars | st.sampled_from([-1.0, -1e-300]),
    "angular_damping": bad_scalars | st.sampled_from([-1.0]),
    "fixed_rotation": st.sampled_from([1, 0, None, "yes"]),
}


@given(data=st.data(), w=worlds)
def test_body_forces_and_settings_refuse_bad_values(data, w: phys2d.World) -> None:
    """apply_force (force, point), apply_torque, and the body settings gravity_scale, damping and
    fixed_rotation, as add_* options and as setters: refused naming them, the world unchanged
    (pending forces included)."""
    body = data.draw(st.sampled_from(w.bodies))
    what = data.draw(st.sampled_from(["force", "point", "torque", "overflow", *BODY_FLOATS]))
    if what == "force":
        rejects(w, "force", lambda: body.apply_force(data.draw(bad_pairs)))
    elif what == "point":
        value = data.draw(bad_pairs.filter(lambda v: v is not None))
        rejects(w, "point", lambda: body.apply_force((1.0, 0.0), point=value))
    elif what == "torque":
        rejects(w, "torque", lambda: body.apply_torque(data.draw(bad_scalars)))
    elif what == "overflow":  # two finite forces whose sum is not
        body.apply_force((1.7e308, 0.0))
        rejects(w, "force", lambda: body.apply_force((1.7e308, 0.0)))
    else:
        value = data.draw(BODY_FLOATS[what], label=what)
        rejects(w, what, lambda: setattr(body, what, value))
        rejects(w, what, lambda: w.add_box((0.0, 5.0), **{what: value}))


@given(data=st.data(), w=worlds)
def test_queries_refuse_bad_points(data, w: phys2d.World) -> None:
    """ray_cast, query_point and query_aabb: bad points refused naming them; lower > upper too."""
    what = data.draw(st.sampled_from(["start", "end", "point", "lower", "upper"]))
    value = data.draw(bad_pairs)
    if what in ("start", "end"):
        ends = {"start": (0.0, 5.0), "end": (0.0, -5.0), what: value}
        rejects(w, what, lambda: w.ray_cast(ends["start"], ends["end"]))
    elif what == "point":
        rejects(w, "point", lambda: w.query_point(value))
    else:
        box = {"lower": (-1.0, -1.0), "upper": (1.0, 1.0), what: value}
        rejects(w, what, lambda: w.query_aabb(box["lower"], box["upper"]))
    rejects(w, "lower", lambda: w.query_aabb((1.0, 1.0), (0.0, 0.0)))


@given(data=st.data(), w=scenes(min_bodies=2, max_bodies=3, ground=False, static=False).map(stepped))
def test_motors_sliders_and_mice_refuse_bad_values(data, w: phys2d.World) -> None:
    """Slider axes, motor speeds and torques, a mouse's target, force, hertz and damping ratio: at
    creation and as settings afterwards, refused naming them, the world unchanged."""
    a, b = w.bodies[:2]
    what = data.draw(st.sampled_from(["axis", "motor_speed", "max_motor_torque", "target", "max_force", "hertz"]))
    if what == "axis":
        value = data.draw(bad_pairs | st.just((0.0, 0.0)))
        rejects(w, "axis", lambda: w.add_slider_joint(a, b, anchor=(0.0, 0.0), axis=value))
    elif what in ("motor_speed", "max_motor_torque"):
        value = data.draw(bad_scalars.filter(lambda v: v is not None) | st.just(-1.0 if what != "motor_speed" else NAN))
        rejects(w, what, lambda: w.add_pin_joint(a, b, anchor=(0.0, 0.0), motor_speed=1.0, **{what: value}))
        pin = w.add_pin_joint(a, b, anchor=(0.0, 0.0), motor_speed=1.0, max_motor_torque=1.0)
        rejects(w, what, lambda: setattr(pin, what, value))
    else:
        mouse = w.add_mouse_joint(a, target=a.position, max_force=100.0)
        if what == "target":
            value = data.draw(bad_pairs)
            rejects(w, "target", lambda: setattr(mouse, "target", value))
            rejects(w, "target", lambda: w.add_mouse_joint(b, target=value, max_force=1.0))
        elif what == "max_force":
            value = data.draw(bad_scalars | st.just(-1.0))
            rejects(w, "max_force", lambda: setattr(mouse, "max_force", value))
        else:
            value = data.draw(bad_scalars | st.sampled_from([0.0, -1.0]))
            rejects(w, "hertz", lambda: w.add_mouse_joint(b, target=b.position, max_force=1.0, hertz=value))
