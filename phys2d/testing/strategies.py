"""Hypothesis strategies for phys2d: valid shapes, bodies, scenes and responder settings
(``phys2d.testing.strategies``; the property tests import them through tests/strategies.py).

A scene is generated as plain data (:class:`SceneSpec`, a tuple of :class:`BodySpec`)
and built into a World by :func:`build`, so one generated scene can be built several
times (determinism, add-order permutations) and shrinks to a small readable example.

Also here: the helpers the property tests share (a bit-exact fingerprint of a world,
stepping that tolerates the velocity limit, and a few geometric second methods).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from hypothesis import strategies as st

import phys2d

# -- numbers -------------------------------------------------------------------


def reals(lo: float, hi: float) -> st.SearchStrategy[float]:
    """Finite floats in [lo, hi] (no NaN, no infinities, no subnormals)."""
    return st.floats(lo, hi, allow_nan=False, allow_infinity=False, allow_subnormal=False)


def vectors(lo: float, hi: float) -> st.SearchStrategy[tuple[float, float]]:
    return st.tuples(reals(lo, hi), reals(lo, hi))


# -- shapes ----------------------------------------------------------------------


def ellipse_polygons(
    min_size: float = 0.15, max_size: float = 1.5, max_vertices: int = 8
) -> st.SearchStrategy[list[tuple[float, float]]]:
    """Convex counter-clockwise polygons: points at increasing angles on an ellipse.

    Any points on a strictly convex curve, taken in angular order, form a strictly
    convex polygon; gaps of at least 0.25 rad keep edges long and turns clear of the
    engine's collinearity tolerance. The vertices are offset by a random shift so the
    engine has to re-centre them on their centroid.
    """

    @st.composite
    def build(draw) -> list[tuple[float, float]]:
        n = draw(st.integers(3, max_vertices))
        gaps = draw(st.lists(reals(0.25, 1.0), min_size=n, max_size=n))
        scale = 2.0 * math.pi / sum(gaps)
        if max(gaps) * scale >= math.pi - 0.2:  # keep every gap well under half a turn
            gaps = [1.0] * n
            scale = 2.0 * math.pi / n
        a = draw(st.tuples(reals(min_size, max_size), reals(min_size, max_size)))
        phase = draw(reals(0.0, 2.0 * math.pi))
        shift = draw(vectors(-1.0, 1.0))
        t = phase + scale * np.cumsum([0.0] + gaps[:-1])
        return [(shift[0] + a[0] * math.cos(u), shift[1] + a[1] * math.sin(u)) for u in t]

    return build()


@dataclass(frozen=True)
class BodySpec:
    """One add_* call as data: ``kind`` is 'box', 'circle' or 'polygon'."""

    kind: str
    position: tuple[float, float]
    size: Any  # half extents, radius or vertices
    angle: float = 0.0
    density: float = 1.0
    friction: float = 0.6
    restitution: float = 0.0
    static: bool = False
    velocity: tuple[float, float] = (0.0, 0.0)
    angular_velocity: float = 0.0

    def add_to(self, w: phys2d.World) -> phys2d.Body:
        common: dict[str, Any] = dict(
            position=self.position,
            angle=self.angle,
            density=self.density,
            friction=self.friction,
            restitution=self.restitution,
            static=self.static,
            velocity=self.velocity,
            angular_velocity=self.angular_velocity,
        )
        if self.kind == "box":
            return w.add_box(half_extents=self.size, **common)
        if self.kind == "circle":
            return w.add_circle(radius=self.size, **common)
        return w.add_polygon(vertices=self.size, **common)


@dataclass(frozen=True)
class SceneSpec:
    bodies: tuple[BodySpec, ...]
    gravity: tuple[float, float] = (0.0, -10.0)
    contact_margin: float = 0.02
    max_speed: float = 1e4


def build(scene: SceneSpec, responder: phys2d.Responder | None = None, order: list[int] | None = None) -> phys2d.World:
    """A World holding ``scene``'s bodies, added in ``order`` (default: as listed)."""
    w = phys2d.World(
        gravity=scene.gravity, responder=responder, contact_margin=scene.contact_margin, max_speed=scene.max_speed
    )
    for k in range(len(scene.bodies)) if order is None else order:
        scene.bodies[k].add_to(w)
    return w


SHAPE_KINDS = ("box", "circle", "polygon")


@st.composite
def body_specs(
    draw,
    *,
    region: float = 2.0,
    max_speed: float = 5.0,
    max_spin: float = 3.0,
    density: tuple[float, float] = (0.2, 5.0),
    size: tuple[float, float] = (0.15, 1.0),
    kinds: tuple[str, ...] = SHAPE_KINDS,
    friction: tuple[float, float] = (0.0, 1.0),
    restitution: tuple[float, float] = (0.0, 1.0),
    static: bool | None = False,
) -> BodySpec:
    """A dynamic (or, with ``static=None``, possibly static) body somewhere in a small region."""
    kind = draw(st.sampled_from(kinds))
    if kind == "box":
        shape = draw(st.tuples(reals(*size), reals(*size)))
    elif kind == "circle":
        shape = draw(reals(*size))
    else:
        shape = draw(ellipse_polygons(size[0], size[1]))
    is_static = draw(st.booleans()) if static is None else static
    return BodySpec(
        kind=kind,
        position=draw(vectors(-region, region)),
        size=shape,
        angle=draw(reals(-math.pi, math.pi)),
        density=draw(reals(*density)),
        friction=draw(reals(*friction)),
        restitution=draw(reals(*restitution)),
        static=is_static,
        velocity=(0.0, 0.0) if is_static else draw(vectors(-max_speed, max_speed)),
        angular_velocity=0.0 if is_static else draw(reals(-max_spin, max_spin)),
    )


GROUND = BodySpec("box", (0.0, -0.5), (20.0, 0.5), static=True, friction=0.6)


@st.composite
def scenes(
    draw,
    *,
    min_bodies: int = 1,
    max_bodies: int = 6,
    ground: bool | None = None,
    gravity: bool | None = True,
    **body_kw,
) -> SceneSpec:
    """Scenes of a few bodies in a small region (overlapping spawns are common)."""
    bodies = draw(st.lists(body_specs(**body_kw), min_size=min_bodies, max_size=max_bodies))
    with_ground = draw(st.booleans()) if ground is None else ground
    if with_ground:
        bodies = [GROUND, *bodies]
    with_gravity = draw(st.booleans()) if gravity is None else gravity
    return SceneSpec(tuple(bodies), gravity=(0.0, -10.0) if with_gravity else (0.0, 0.0))


def violent_scenes() -> st.SearchStrategy[SceneSpec]:
    """Fast, spinning, overlapping bodies, static ones among them, mass ratios up to about 1e8."""
    return scenes(
        max_bodies=8,
        ground=None,
        region=1.0,
        max_speed=60.0,
        max_spin=60.0,
        density=(1e-3, 1e2),
        size=(0.05, 2.0),
        static=None,
    )


def free_scene(scene: SceneSpec) -> SceneSpec:
    """The same bodies, none static, without gravity: momentum must be conserved."""
    return replace(
        scene, gravity=(0.0, 0.0), bodies=tuple(replace(b, static=False) for b in scene.bodies if not b.static)
    )


@st.composite
def pgs_keywords(draw, *, friction: str | None = "coulomb") -> dict[str, Any]:
    """Valid PGS keywords shared by every PGS entry of the registry (sweeps, Baumgarte,
    stopping rule, bounce threshold, friction model): Coulomb friction unless ``friction``
    says otherwise (None: either model)."""
    return dict(
        iterations=draw(st.integers(1, 30)),
        beta=draw(reals(0.0, 1.0)),
        slop=draw(reals(0.0, 0.02)),
        tolerance=draw(st.none() | reals(0.0, 1e-2)),
        restitution_threshold=draw(reals(0.0, 2.0)),
        friction=draw(st.sampled_from(["coulomb", "lecture"])) if friction is None else friction,
    )


@st.composite
def pgs_settings(
    draw, *, warm_start: bool | None = None, friction: str | None = "coulomb", form: str | None = None
) -> phys2d.PGS:
    """Valid PGS settings: impulse form (row by row or block) or matrix form; Coulomb
    friction unless ``friction`` says otherwise (None: either model)."""
    block = draw(st.booleans()) if form in (None, "impulse") else False
    if form is None:
        form = "impulse" if block else draw(st.sampled_from(["impulse", "matrix"]))
    return phys2d.PGS(
        warm_start=draw(st.booleans()) if warm_start is None else warm_start,
        form=form,
        block=block,
        **draw(pgs_keywords(friction=friction)),
    )


@st.composite
def soft_step_keywords(draw) -> dict[str, Any]:
    """Valid SoftStep keywords."""
    return dict(
        substeps=draw(st.integers(1, 6)),
        relax=draw(st.booleans()),
        contact_hertz=draw(reals(0.0, 60.0)),
        damping_ratio=draw(reals(0.0, 10.0)),
        push_max=draw(reals(0.0, 5.0)),
        restitution_threshold=draw(reals(0.0, 2.0)),
        warm_start=draw(st.booleans()),
        block=draw(st.booleans()),
    )


def soft_step_settings() -> st.SearchStrategy[phys2d.SoftStep]:
    return soft_step_keywords().map(lambda kw: phys2d.SoftStep(**kw))


def _with_warm_start(keywords: st.SearchStrategy[dict[str, Any]]) -> st.SearchStrategy[dict[str, Any]]:
    return st.tuples(keywords, st.booleans()).map(lambda t: {**t[0], "warm_start": t[1]})


# Keywords for each registered responder (phys2d.REGISTRY, in its order), beyond what its
# entry fixes: given the PGS friction model (None: either), a strategy of valid keyword
# arguments for ``REGISTRY[name](**keywords)``. tests/test_project.py checks that the names
# are exactly the registry's.
RESPONDER_SETTINGS: dict[str, Callable[[str | None], st.SearchStrategy[dict[str, Any]]]] = {
    "naive": lambda friction: st.just({}),
    "iterative": lambda friction: st.integers(1, 20).map(lambda n: {"passes": n}),
    "pgs": lambda friction: pgs_keywords(friction=friction),
    "pgs-cold": lambda friction: pgs_keywords(friction=friction),
    "pgs-matrix": lambda friction: _with_warm_start(pgs_keywords(friction=friction)),
    "pgs-block": lambda friction: _with_warm_start(pgs_keywords(friction=friction)),
    "soft-step": lambda friction: soft_step_keywords(),
}


def registered(name: str, *, friction: str | None = None) -> st.SearchStrategy[phys2d.Responder]:
    """The responder registered as ``name``, with valid settings drawn for it."""
    return RESPONDER_SETTINGS[name](friction).map(lambda kw: phys2d.REGISTRY[name](**kw))


def responders(*, friction: str | None = None) -> st.SearchStrategy[phys2d.Responder]:
    """Every registered responder (``phys2d.REGISTRY``), with valid settings (PGS with
    either friction model unless ``friction`` is given)."""
    return st.sampled_from(list(phys2d.REGISTRY)).flatmap(lambda name: registered(name, friction=friction))


dts = st.sampled_from([1 / 30, 1 / 60, 1 / 120, 1 / 240]) | reals(1e-4, 0.05)


# -- helpers shared by the properties -----------------------------------------------


# every per-contact array of ``World.contacts``
CONTACT_ARRAYS = (
    "body_a body_b point normal separation normal_impulse tangent_impulse feature key warm_started"
).split()


def fingerprint(w: phys2d.World) -> tuple:
    """Everything a World holds, as bytes: two equal fingerprints mean bit-identical worlds."""
    parts = w._parts()  # (what the world is made of: ``World._parts``)
    b, pipeline = parts.bodies, parts.pipeline
    arrays = [getattr(b, name) for name in b._PER_BODY] + [b.local_v, b.local_n]
    contact_arrays = [getattr(w.contacts, name) for name in CONTACT_ARRAYS]
    cache_keys, cache_lambda_n, cache_lambda_t = pipeline.cache()
    return (
        b.n,
        b.n_verts,
        b.next_uid,
        w.tick,
        w.time,
        w.contact_margin,
        repr(w.responder),
        w.gravity.tobytes(),
        tuple(h._index for h in w.bodies),
        len(w.bodies),
        tuple(a.tobytes() for a in arrays),
        tuple(a.tobytes() for a in contact_arrays),
        cache_keys.tobytes(),
        cache_lambda_n.tobytes(),
        cache_lambda_t.tobytes(),
        w.last_step.iterations,
        w.last_step.residuals.tobytes(),
        tuple(
            (type(j).__name__, j.body_a._uid, j.body_b._uid, j.alive, j.impulse.tobytes())
            for j in getattr(w, "joints", ())
        ),
        parts.joints.excluded.tobytes(),
        w.contact_recycle_distance,
        tuple(np.asarray(a).tobytes() for a in pipeline.store.live(*pipeline.manifold_keys())),
    )


def state(w: phys2d.World) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    return w.x.copy(), w.theta.copy(), w.V.copy()


def all_finite(w: phys2d.World) -> bool:
    c = w.contacts
    floats = [getattr(c, name) for name in CONTACT_ARRAYS if getattr(c, name).dtype.kind == "f"]
    parts = [w.x, w.theta, w.V, w.M_inv, w.last_step.residuals, *floats]
    return all(bool(np.all(np.isfinite(p))) for p in parts)


def point_polygon_distance(p: np.ndarray, verts: np.ndarray) -> float:
    """Signed distance from p to a convex polygon's boundary (negative inside).

    Second method for the narrowphase: outside, the distance to the nearest edge
    segment; inside, minus the distance to the nearest edge line.
    """
    n = len(verts)
    inside = True
    best = math.inf
    for k in range(n):
        a, b = verts[k], verts[(k + 1) % n]
        e = b - a
        if e[0] * (p[1] - a[1]) - e[1] * (p[0] - a[0]) < 0.0:
            inside = False
        u = min(1.0, max(0.0, float(np.dot(p - a, e) / np.dot(e, e))))
        best = min(best, float(np.linalg.norm(p - (a + u * e))))
    return -best if inside else best


@st.composite
def resting_scenes(draw, max_stacks: int = 3, max_height: int = 3) -> SceneSpec:
    """Stacks of boxes (and circles on the ground) that start touching and at rest.

    Stacks stand 3 m apart; each box is centred over the one below within a fifth of
    their widths and weighs at most twice as much, so every stack is statically stable
    and within what 10 PGS sweeps hold (heavier-on-lighter stacks creep: the mass_ratio
    scene shows it).
    """
    bodies = [GROUND]
    for s in range(draw(st.integers(1, max_stacks))):
        x = 3.0 * s
        if draw(st.booleans()):
            r = draw(reals(0.2, 0.8))
            bodies.append(BodySpec("circle", (x, r), r, density=draw(reals(0.5, 4.0)), friction=draw(reals(0.2, 1.0))))
            continue
        y = 0.0
        below: tuple[float, float] | None = None  # (half width, mass) of the box below
        for _ in range(draw(st.integers(1, max_height))):
            hx, hy = draw(reals(0.25, 0.8)), draw(reals(0.15, 0.6))
            if below is None:
                density = draw(reals(0.5, 4.0))
            else:
                x += draw(reals(-0.2, 0.2)) * min(hx, below[0])
                density = draw(reals(0.25, 2.0)) * below[1] / (4.0 * hx * hy)
            bodies.append(BodySpec("box", (x, y + hy), (hx, hy), density=density, friction=draw(reals(0.3, 1.0))))
            y += 2.0 * hy
            below = (hx, density * 4.0 * hx * hy)
    return SceneSpec(tuple(bodies))


def step_or_undone(w: phys2d.World, dt: float) -> bool:
    """One step: True if it was taken; False if it raised SimulationError, after checking
    that the failed step left the world bit-identical."""
    before = fingerprint(w)
    try:
        w.step(dt)
    except phys2d.SimulationError:
        assert fingerprint(w) == before
        return False
    return True


def run(w: phys2d.World, dt: float, steps: int):
    """Step ``w`` up to ``steps`` times, yielding after each step; stop quietly at a
    SimulationError (a Baumgarte push past max_speed is allowed: test_prop_safety
    checks that such a step is undone)."""
    for _ in range(steps):
        try:
            w.step(dt)
        except phys2d.SimulationError:
            return
        yield w
