"""Properties of PGS: lambda bounds, the LCP it solves, complementarity, and two-body analytics.

The second method for the LCP is written here from docs/formulation.md alone: J, M^-1,
A = J M^-1 J^T and b = xi - J V1 - dt J M^-1 F_ext are assembled densely from the
step's contacts, and the LCP (lambda >= 0, w = A lambda - b >= 0, lambda . w = 0) is
solved by trying every active set.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import assume, event, given, note
from hypothesis import strategies as st

import phys2d
from phys2d.testing import properties
from tests.strategies import (
    GROUND,
    SceneSpec,
    body_specs,
    build,
    dts,
    pgs_settings,
    reals,
    responders,
    run,
    scenes,
)

# -- the second method ------------------------------------------------------------


def cross(a: np.ndarray, b: np.ndarray) -> float:
    return float(a[0] * b[1] - a[1] * b[0])


def jacobian(n_bodies: int, x: np.ndarray, c: phys2d.Contacts, direction: np.ndarray) -> np.ndarray:
    """Dense J (K, 3N): row k = [-d, -(r_i x d)] at body i, [d, r_j x d] at body j."""
    J = np.zeros((len(c), 3 * n_bodies))
    for k in range(len(c)):
        i, j, p, d = int(c.body_a[k]), int(c.body_b[k]), c.point[k], direction[k]
        J[k, 3 * i : 3 * i + 3] = [-d[0], -d[1], -cross(p - x[i], d)]
        J[k, 3 * j : 3 * j + 3] = [d[0], d[1], cross(p - x[j], d)]
    return J


def normal_targets(
    c: phys2d.Contacts, vn1: np.ndarray, vn_ext: np.ndarray, pgs: phys2d.PGS, dt: float
) -> tuple[np.ndarray, np.ndarray]:
    """(xi, bounce) of each normal row. xi: a point C > 0 apart may close its gap within the
    step (-C/dt), a touching one may not approach (0); the Baumgarte push (beta/dt)(-C - slop),
    at most push_max, joins xi only without split impulses; a touching point that meets its
    partner faster than the threshold bounces in the solve, xi = max(xi, bounce). bounce: the
    target of a point still apart, for the restitution pass once it has moved there.

    Semi-implicit Euler's step-end positions follow a path whose velocity is V minus half a
    step of the external forces: p0 = vn1 + dvn/2 as the step begins (dvn = vn_ext - vn1). A
    touching point meets its partner at p0; a point C apart, if the path closes C within the
    step (C + dt vn_ext <= 0), at -sqrt(p0^2 - 2 (dvn/dt) C).
    It leaves with the path's velocity reversed e times: J V = -e approach - dvn/2."""
    C, e = c.separation, c.restitution
    push = np.minimum((pgs.beta / dt) * np.maximum(0.0, -(C + pgs.slop)), pgs.push_max)
    xi = np.where(C > 0.0, -C / dt, 0.0) + (0.0 if pgs.split else push)
    dvn = vn_ext - vn1
    p0 = vn1 + dvn / 2
    closes = C + dt * vn_ext <= 1e-6  # the path's end, within this step (to within phys2d's MET)
    meet = -np.sqrt(np.maximum(p0 * p0 - 2.0 * (dvn / dt) * C, 0.0))
    apart = C > 1e-6  # phys2d's MET: closer than this counts as touching
    approach = np.where(apart, np.where(closes, meet, 0.0), p0)
    target = np.where(e == 0.0, 0.0, -e * approach - dvn / 2)
    fast = approach < -pgs.restitution_threshold
    xi = np.where(fast & ~apart, np.maximum(xi, target), xi)
    return xi, np.where(fast & apart, target, 0.0)


def friction_targets(c: phys2d.Contacts, vn_ext: np.ndarray, vt_ext: np.ndarray, dt: float) -> np.ndarray:
    """xi of each friction row: friction acts only once its point touches. 0 for a touching
    point; a point C > 0 apart that closes its gap within the step (C < -dt vn) keeps the
    tangential velocity of the part of the step before it touches, vt C / (-dt vn); one that
    does not close it keeps vt (docs/formulation.md, "friction at impact")."""
    C = c.separation
    closes = (vn_ext < 0.0) & (C < -dt * vn_ext)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # np.where evaluates both sides
        fraction = np.where(closes, C / (-dt * vn_ext), 1.0)
    return np.where(C > 0.0, vt_ext * fraction, 0.0)


def solve_lcp_by_active_sets(A: np.ndarray, b: np.ndarray, tol: float = 1e-9) -> np.ndarray:
    """lambda >= 0 with w = A lambda - b >= 0 and lambda_k w_k = 0, by trying every active set."""
    n = len(b)
    scale = max(1.0, float(np.abs(b).max(initial=0.0)))
    for size in range(n + 1):
        for active in itertools.combinations(range(n), size):
            lam = np.zeros(n)
            if active:
                idx = list(active)
                lam[idx] = np.linalg.lstsq(A[np.ix_(idx, idx)], b[idx], rcond=None)[0]
            w = A @ lam - b
            if (
                lam.min(initial=0.0) >= -tol * scale
                and w.min(initial=0.0) >= -tol * scale
                and np.all(np.abs(w[list(active)]) <= tol * scale)
            ):
                return lam
    raise AssertionError("no active set solves the LCP")  # pragma: no cover


def step_with_system(w: phys2d.World, dt: float):
    """Step w and return what the second method needs, taken before the step."""
    x, V1, M_inv, g = w.x.copy(), w.V.copy(), w.M_inv.copy(), w.gravity
    try:
        w.step(dt)
    except phys2d.SimulationError:  # a deep overlap's Baumgarte push past max_speed
        assume(False)
    c = w.contacts
    n = len(w)
    Jn = jacobian(n, x, c, c.normal)
    Jt = jacobian(n, x, c, c.tangent)
    Minv = M_inv.reshape(-1)
    V_ext = V1.copy()
    V_ext[M_inv[:, 0] > 0.0, :2] += dt * g  # dt M^-1 F_ext with F_ext = m g
    return c, Jn, Jt, Minv, V1.reshape(-1), V_ext.reshape(-1)


def converged_pgs(beta: float = 0.0, slop: float = 0.005, threshold: float = 1.0) -> phys2d.PGS:
    return phys2d.PGS(
        iterations=3000, warm_start=False, tolerance=1e-13, beta=beta, slop=slop, restitution_threshold=threshold
    )


@st.composite
def near_touching(draw) -> SceneSpec:
    """Up to three bodies standing on the ground, each a gap in [-slop, margin] above it
    or above the body below (speculative and touching contacts, the resting case)."""
    bodies = [GROUND]
    y = 0.0
    for _ in range(draw(st.integers(1, 3))):
        spec = draw(
            body_specs(kinds=("box", "circle"), size=(0.3, 0.8), density=(0.5, 2.0), max_speed=1.0, max_spin=0.0)
        )
        half = spec.size if spec.kind == "circle" else spec.size[1]
        y += draw(reals(-0.005, 0.02)) + half
        bodies.append(replace(spec, position=(draw(reals(-0.1, 0.1)), y), angle=0.0))
        y += half
    return SceneSpec(tuple(bodies))


small_scenes = (
    scenes(
        min_bodies=1,
        max_bodies=3,
        ground=None,
        gravity=None,
        region=0.8,
        density=(0.5, 2.0),
        size=(0.3, 0.8),
        max_speed=3.0,
    )
    | near_touching()
)


def frictionless(scene: SceneSpec) -> SceneSpec:
    return replace(scene, bodies=tuple(replace(b, friction=0.0) for b in scene.bodies))


# -- properties ---------------------------------------------------------------------


@given(scene=scenes(max_bodies=6, ground=True, static=None), responder=responders(), dt=dts)
def test_lambda_bounds(scene: SceneSpec, responder: phys2d.Responder, dt: float) -> None:
    """After every step: lambda_n >= 0 and |lambda_t| within its bound: mu lambda_n
    (Coulomb) or mu m_c g dt (PGS with the lecture's friction).

    PGS checks the bounds at the end of its sweeps (matrix and impulse form alike).
    The naive takes clamp each pair's impulse (f >= 0, |f_t| <= mu f) and share it
    among the pair's points, so their totals obey Coulomb too. SoftStep's per-sub-step
    bounds add up to the same bounds on the tick's totals, and its restitution pass
    pulls the friction back inside a cone that a smaller push has shrunk.
    """
    properties.lambda_bounds(scene, responder, dt)


@given(scene=small_scenes, dt=dts, beta=reals(0.0, 1.0), e=reals(0.0, 1.0))
def test_converged_pgs_solves_the_lcp(scene: SceneSpec, dt: float, beta: float, e: float) -> None:
    """Frictionless: converged PGS gives the LCP's velocities (M^-1 J^T lambda is unique
    even when A is singular) and, where A is non-singular, the LCP's lambda."""
    scene = replace(frictionless(scene), bodies=tuple(replace(b, restitution=e) for b in frictionless(scene).bodies))
    pgs = converged_pgs(beta=beta, threshold=0.5)
    w = build(scene, pgs)
    c, Jn, _, Minv, V1, V_ext = step_with_system(w, dt)
    assume(0 < len(c) <= 9)
    assume(w.last_step.iterations < pgs.iterations)  # converged
    A = Jn @ (Minv[:, None] * Jn.T)
    xi, bounce = normal_targets(c, Jn @ V1, Jn @ V_ext, pgs, dt)
    b = xi - Jn @ V_ext
    lam = solve_lcp_by_active_sets(A, b)
    # the restitution pass: the points still apart that met their partner (they pushed, or
    # their gap closes) go to their bounce target, an LCP in their total lambda with every
    # other lambda fixed
    V2 = V_ext + Minv * (Jn.T @ lam)
    end_gap = c.separation + dt * (Jn @ V2)
    B = np.flatnonzero(bounce > 0.0)
    assume(np.all((lam[B] > 1e-9) | (end_gap[B] <= 1e-6) | ((lam[B] == 0.0) & (end_gap[B] > 1e-5))))  # clear cut
    B = B[(lam[B] > 0.0) | (end_gap[B] <= 1e-6)]
    if B.size:
        A_BB = A[np.ix_(B, B)]
        lam[B] = solve_lcp_by_active_sets(A_BB, bounce[B] - Jn[B] @ V2 + A_BB @ lam[B])
        event("a point still apart bounced")
    scale = max(1.0, float(np.abs(V_ext).max()), float(np.abs(b).max()))
    np.testing.assert_allclose(w.V.reshape(-1), V_ext + Minv * (Jn.T @ lam), atol=1e-7 * scale)
    if np.linalg.cond(A) < 1e6:
        note(f"A non-singular, {len(c)} contacts")
        np.testing.assert_allclose(c.normal_impulse, lam, atol=1e-7 * scale * np.abs(A).max() ** -1)
    assert np.all(c.tangent_impulse == 0.0)


@given(scene=small_scenes, dt=dts)
def test_converged_pgs_is_complementary(scene: SceneSpec, dt: float) -> None:
    """With Coulomb friction, converged PGS satisfies, at every contact:
    lambda_n > 0 only where the normal velocity meets its target (w_n = 0, else w_n >= 0);
    |lambda_t| < mu lambda_n only where the contact sticks (v_t at its target xi_t: 0, or the
    part of a landing before its touch, ``friction_targets``); a sliding point
    gets |lambda_t| = mu lambda_n exactly; and a friction impulse never pushes along the
    sliding direction (lambda_t v_t <= 0)."""
    pgs = converged_pgs(beta=0.2)
    w = build(scene, pgs)
    c, Jn, Jt, Minv, V1, V_ext = step_with_system(w, dt)
    assume(0 < len(c) <= 9)
    assume(w.last_step.iterations < pgs.iterations)
    V2 = w.V.reshape(-1)
    scale = max(1.0, float(np.abs(V2).max()))
    tol = 1e-8 * scale
    xi, bounce = normal_targets(c, Jn @ V1, Jn @ V_ext, pgs, dt)
    assume(not np.any((bounce > 0.0) & (c.normal_impulse > 0.0)))  # the restitution pass re-clamps friction only
    w_n = Jn @ V2 - xi
    v_t = Jt @ V2 - friction_targets(c, Jn @ V_ext, Jt @ V_ext, dt)
    lam_n, lam_t, mu = c.normal_impulse, c.tangent_impulse, c.friction
    assert np.all(w_n >= -tol)
    assert np.all(np.abs(lam_n * w_n) <= tol * (1.0 + lam_n))
    sticking = np.abs(lam_t) < mu * lam_n - 1e-9 * (1.0 + lam_n)
    assert np.all(np.abs(v_t[sticking]) <= tol)
    assert np.all(lam_t * v_t <= tol * (1.0 + np.abs(lam_t)))
    # a sliding point pushes back with the whole cone, never more
    assert np.all(np.abs(lam_t) <= mu * lam_n * (1 + 1e-12) + 1e-300)
    sliding = np.abs(v_t) > tol
    event(f"{'some' if sliding.any() else 'no'} point sliding")
    np.testing.assert_allclose(np.abs(lam_t[sliding]), (mu * lam_n)[sliding], rtol=1e-9, atol=1e-12)


@given(scene=scenes(max_bodies=5, ground=True), responder=pgs_settings(), dt=dts)
def test_pgs_report_matches_its_stopping_rule(scene: SceneSpec, responder: phys2d.PGS, dt: float) -> None:
    """iterations = len(residuals); PGS stops at the first sweep whose residual is within
    the tolerance, or after the iteration budget; residuals are finite and >= 0."""
    w = build(scene, responder)
    for _ in run(w, dt, 10):
        report = w.last_step
        r = report.residuals
        assert report.iterations == len(r) >= 1
        assert np.all(np.isfinite(r)) and np.all(r >= 0.0)
        tol = -1.0 if responder.tolerance is None else responder.tolerance
        assert np.all(r[:-1] > tol)
        assert r[-1] <= tol or report.iterations == responder.iterations
        assert report.contact_count == len(w.contacts)


@given(
    m=st.tuples(reals(0.1, 10.0), reals(0.1, 10.0)),
    u=st.tuples(reals(0.5, 10.0), reals(-10.0, 0.0)),
    radii=st.tuples(reals(0.2, 1.0), reals(0.2, 1.0)),
    overlap=reals(0.0, 0.004),
    e=reals(0.0, 1.0),
    dt=dts,
)
def test_head_on_circles_follow_newtons_restitution(m, u, radii, overlap: float, e: float, dt: float) -> None:
    """Two frictionless circles meeting head on, touching within the slop: one step gives
    v1' = (m1 u1 + m2 u2 - m2 e (u1 - u2)) / (m1 + m2) and its mirror (Newton's law of
    restitution with momentum conservation)."""
    w = phys2d.World(gravity=(0.0, 0.0), responder=phys2d.PGS(beta=0.0, restitution_threshold=0.0))
    r1, r2 = radii
    rho1, rho2 = m[0] / (math.pi * r1 * r1), m[1] / (math.pi * r2 * r2)
    a = w.add_circle(position=(0.0, 0.0), radius=r1, density=rho1, friction=0.0, restitution=e, velocity=(u[0], 0.0))
    b = w.add_circle(
        position=(r1 + r2 - overlap, 0.0), radius=r2, density=rho2, friction=0.0, restitution=e, velocity=(u[1], 0.0)
    )
    w.step(dt)
    m1, m2 = a.mass, b.mass
    u1, u2 = u
    v1 = (m1 * u1 + m2 * u2 - m2 * e * (u1 - u2)) / (m1 + m2)
    v2 = (m1 * u1 + m2 * u2 + m1 * e * (u1 - u2)) / (m1 + m2)
    assert a.velocity == pytest.approx([v1, 0.0], abs=1e-9)
    assert b.velocity == pytest.approx([v2, 0.0], abs=1e-9)
    assert a.angular_velocity == b.angular_velocity == 0.0


@given(
    speed=reals(1.5, 20.0),
    heading=reals(-1.2, 1.2),
    offset=reals(-0.9, 0.9),
    kind=st.sampled_from(["circle", "box", "polygon"]),
    spin=reals(-5.0, 5.0),
    density=reals(0.2, 5.0),
    dt=dts,
    gap=st.sampled_from([-0.001, 0.003]),
)
def test_energy_kept_with_restitution_one_and_one_contact(
    speed: float, heading: float, offset: float, kind: str, spin: float, density: float, dt: float, gap: float
) -> None:
    """A frictionless circle bouncing (e = 1) off one other body at a single contact point,
    off centre and with spin: the step keeps kinetic energy and linear momentum.

    Touching (1 mm overlap, within slop) it bounces within the solve and keeps angular
    momentum too. 3 mm apart it first closes the gap, the positions move, then it bounces:
    along one row the two impulses add up to the same -(1 + e) J V / A_kk, but the bodies
    moved with a velocity they no longer have, which (like any position correction) does
    not keep angular momentum about a fixed point."""
    w = phys2d.World(gravity=(0.0, 0.0), responder=phys2d.PGS(beta=0.0, restitution_threshold=0.0))
    r = 0.4
    if kind == "circle":
        w.add_circle(position=(0.0, 0.0), radius=0.5, friction=0.0, restitution=1.0, angular_velocity=spin)
        reach = 0.5
    elif kind == "box":
        w.add_box(position=(0.0, 0.0), half_extents=(0.5, 0.5), friction=0.0, restitution=1.0, angular_velocity=spin)
        reach = 0.5
    else:
        body = w.add_polygon(
            position=(0.0, 0.0),
            vertices=[(-0.7, -0.5), (0.6, -0.5), (0.2, 0.5)],
            friction=0.0,
            restitution=1.0,
            angular_velocity=spin,
        )
        reach = -float(body.vertices[:, 1].min())  # the bottom face (re-centred on the centroid: y = -1/3)
    # the ball just below the bottom face (box, polygon) or the circle, moving up into it
    x0 = offset * 0.4 if kind != "circle" else offset * 0.3
    y0 = -(reach + r) - gap if kind != "circle" else -math.sqrt((0.5 + r + gap) ** 2 - x0**2)
    w.add_circle(
        position=(x0, y0),
        radius=r,
        density=density,
        friction=0.0,
        restitution=1.0,
        velocity=(speed * math.sin(heading), speed * math.cos(heading)),
    )
    ke0, p0, l0 = w.kinetic_energy(), w.linear_momentum(), w.angular_momentum()
    w.step(dt)
    assume(len(w.contacts) == 1 and w.contacts.normal_impulse[0] > 0.0)
    assert w.kinetic_energy() == pytest.approx(ke0, rel=1e-10)
    np.testing.assert_allclose(w.linear_momentum(), p0, atol=1e-9 * (1 + np.abs(p0).max()))
    if gap < 0.0:
        assert w.angular_momentum() == pytest.approx(l0, rel=1e-9, abs=1e-9)


@given(
    depth=reals(0.02, 0.3),
    r=reals(0.3, 1.0),
    beta=reals(0.05, 1.0),
    slop=reals(0.0, 0.01),
    density=reals(0.2, 5.0),
    dt=dts,
    steps=st.integers(1, 30),
    split=st.booleans(),
)
def test_baumgarte_removes_overlap_geometrically(
    depth: float, r: float, beta: float, slop: float, density: float, dt: float, steps: int, split: bool
) -> None:
    """A circle spawned overlapping the ground by d, no gravity, no cap on the push: the push
    (beta/dt)(d - slop) lifts it by beta (d - slop) in the first step, and after n steps the
    overlap is at most slop + (1 - beta)^n (d - slop), never growing. As the lecture has it
    (split=False) the push is velocity and the circle keeps it; with split impulses it only
    moves the circle, whose velocity stays 0."""
    pgs = phys2d.PGS(beta=beta, slop=slop, split=split, push_max=1e9)
    w = phys2d.World(gravity=(0.0, 0.0), responder=pgs)
    w.add_box(position=(0.0, -0.5), half_extents=(20.0, 0.5), static=True, friction=0.0)
    ball = w.add_circle(position=(0.3, r - depth), radius=r, density=density, friction=0.0)
    overlap = depth
    for n in range(1, steps + 1):
        w.step(dt)
        now = max(0.0, r - ball.position[1])
        assert now <= overlap + 1e-12
        assert now <= slop + (1.0 - beta) ** n * (depth - slop) + 1e-9
        overlap = now
    expected = 0.0 if split else beta * (depth - slop) / dt
    assert ball.velocity[1] == pytest.approx(expected, rel=1e-9, abs=1e-12)
