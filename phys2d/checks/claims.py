"""The lecture's claims, each a scene and a measure, for the report card (``phys2d.check``).

A claim runs its scene on a new copy of the responder (``make()``), measures one figure and
holds it to a bar: an analytic result (the ramp, the bounce), a conservation law (momenta, no
energy gain), or a second method (an exact LCP solution by enumeration). The scenes log to a
recorder when given one, so a failing claim's scene can be run again and watched.

Symbols as in docs/formulation.md: lambda_n, lambda_t (N s), mu, e, g (m/s^2), dt (s).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import scenes
from ..responders.base import Responder, SolveResult, StepContext
from ..world import World

DT = 1 / 60  # s, one step
G = 10.0  # m/s^2

Make = Callable[[], Responder]


@dataclass(frozen=True)
class Outcome:
    """What one claim measured: its figure (in the claim's unit), whether it meets the bar, and a note."""

    figure: float
    passed: bool
    note: str = ""


@dataclass(frozen=True)
class Claim:
    """One of the lecture's claims: a scene, a measure and a bar.

    name       a short id (``lambda_n >= 0``), the key of the JSON output
    statement  the claim in the lecture's words
    bar        what the figure must meet, in words (``>= 0 N s``)
    unit       the figure's unit
    run        run(make, quick, rec) -> Outcome: the scene on ``make()``, logged to ``rec`` if given
    predicted  for each of the lecture's takes (``naive``, ``iterative``) that it says fail this
               claim, the lecture's words
    """

    name: str
    statement: str
    bar: str
    unit: str
    run: Callable[[Make, bool, Any], Outcome]
    predicted: dict[str, str] = field(default_factory=dict)


# -- stepping ----------------------------------------------------------------------------
def simulate(w: World, seconds: float, rec: Any, run: str, probe: Callable[[World], Any] | None = None) -> list:
    """Step ``w`` for ``seconds`` (logging each step to ``rec`` as ``run``); probe(w) after each step."""
    out = []
    for _ in range(round(seconds / DT)):
        w.step(DT)
        if rec is not None:
            rec.log(w, run=run)
        if probe is not None:
            out.append(probe(w))
    return out


def world(make: Make, gravity: tuple[float, float] = (0.0, -G)) -> World:
    """A world with a new copy of the responder, stepped stage by stage (a plain ``respond`` is)."""
    w = World(gravity=gravity, responder=make())
    w.one_call_tick = False
    return w


def rotation(a: float) -> np.ndarray:
    return np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])


# -- the bounds: lambda_n >= 0, |lambda_t| <= mu lambda_n ---------------------------------
def pile(make: Make) -> World:
    """A 3-row pyramid, a circle dropped on it and a box sliding on the ground at 3 m/s (mu 0.6)."""
    w = world(make)
    scenes.ground(w, friction=0.6)
    for r in range(3):
        for k in range(3 - r):
            w.add_box(position=(k - 0.5 * (2 - r), 0.5 + r), friction=0.6)
    w.add_box(position=(-4.0, 0.5), velocity=(3.0, 0.0), friction=0.6)
    w.add_circle(position=(0.2, 4.0), radius=0.3, friction=0.6, restitution=0.3)
    return w


def bounds_of(w: World) -> tuple[float, float]:
    """The smallest lambda_n (N s) and the largest |lambda_t| - mu lambda_n (N s) of the last step."""
    c = w.contacts
    if len(c) == 0:
        return math.inf, -math.inf
    return float(c.lambda_n.min()), float(np.max(np.abs(c.lambda_t) - c.friction * np.maximum(c.lambda_n, 0.0)))


def _pile_bounds(make: Make, quick: bool, rec: Any) -> np.ndarray:
    return np.array(simulate(pile(make), 2.0 if quick else 4.0, rec, "pile", bounds_of))


def lambda_n_nonnegative(make: Make, quick: bool, rec: Any) -> Outcome:
    low = float(_pile_bounds(make, quick, rec)[:, 0].min())
    return Outcome(low, low >= 0.0)


def friction_cone(make: Make, quick: bool, rec: Any) -> Outcome:
    over = float(_pile_bounds(make, quick, rec)[:, 1].max())
    return Outcome(over, over <= 1e-12)


# -- the ramp --------------------------------------------------------------------------------
def ramp(make: Make, alpha: float, mu: float) -> World:
    """A box (1 m) resting on a static ramp of slope ``alpha`` (rad), both of friction mu."""
    w = world(make)
    w.add_box(position=(0.0, 0.0), half_extents=(30.0, 0.5), angle=alpha, static=True, friction=mu)
    w.add_box(position=rotation(alpha) @ (0.0, 1.0), angle=alpha, friction=mu)
    return w


def along_slope(w: World, alpha: float) -> tuple[float, float]:
    """The box's place and velocity down the slope (m, m/s)."""
    down = -rotation(alpha) @ (1.0, 0.0)
    return float(w.x[1] @ down), float(w.V[1, :2] @ down)


RAMP_MU = 0.5


def ramp_sticks(make: Make, quick: bool, rec: Any) -> Outcome:
    alpha = 0.8 * math.atan(RAMP_MU)
    w = ramp(make, alpha, RAMP_MU)
    s0 = along_slope(w, alpha)[0]
    simulate(w, 2.0 if quick else 5.0, rec, "ramp-stick")
    slid = abs(along_slope(w, alpha)[0] - s0)
    return Outcome(
        slid * 1e3,
        slid <= 1e-3,
        f"slope {math.degrees(alpha):.1f} deg < atan(mu) = {math.degrees(math.atan(RAMP_MU)):.1f} deg",
    )


def ramp_slides(make: Make, quick: bool, rec: Any) -> Outcome:
    alpha = math.radians(35.0)
    w = ramp(make, alpha, RAMP_MU)
    seconds = 2.0 if quick else 4.0
    v = np.array(simulate(w, seconds, rec, "ramp-slide", lambda w: along_slope(w, alpha)[1]))
    settle = round(0.5 / DT)
    accel = (v[-1] - v[settle - 1]) / ((len(v) - settle) * DT)
    exact = G * (math.sin(alpha) - RAMP_MU * math.cos(alpha))
    error = abs(accel / exact - 1.0)
    return Outcome(100 * error, error <= 0.01, f"{accel:.4f} m/s^2, g(sin - mu cos) = {exact:.4f} m/s^2")


# -- conservation ------------------------------------------------------------------------------
def collisions(make: Make) -> World:
    """No gravity, no static body: two spinning boxes and a circle thrown into one another."""
    w = world(make, gravity=(0.0, 0.0))
    w.add_box(position=(-2.0, 0.0), velocity=(3.0, 0.3), angular_velocity=1.0, friction=0.4)
    w.add_box(position=(2.0, 0.3), half_extents=(0.7, 0.4), velocity=(-2.0, 0.0), angular_velocity=-0.5, friction=0.4)
    w.add_circle(position=(0.1, 3.0), radius=0.4, velocity=(0.0, -2.5), density=2.0, friction=0.4)
    return w


def momenta_conserved(make: Make, quick: bool, rec: Any) -> Outcome:
    w = collisions(make)
    p0, L0 = w.linear_momentum(), w.angular_momentum()
    scale = float(np.sum(w.body_masses * np.hypot(w.V[:, 0], w.V[:, 1])))  # kg m/s: sum of m |v|
    hits = simulate(w, 1.5, rec, "collisions", lambda w: len(w.contacts) > 0 and w.contacts.lambda_n.max() > 0)
    dp = float(np.abs(w.linear_momentum() - p0).max()) / scale
    dL = abs(w.angular_momentum() - L0) / scale  # per metre of lever arm
    note = f"angular {dL:.2g} (bar 1e-2: position corrections change it a little)"
    if not any(hits):
        return Outcome(dp, False, "no impulse at all: the bodies never collided")
    return Outcome(dp, dp <= 1e-9 and dL <= 1e-2, note)


def resting_pile(make: Make) -> World:
    """A 4-row pyramid of 1 m boxes, touching, at rest."""
    w = world(make)
    scenes.ground(w)
    for r in range(4):
        for k in range(4 - r):
            w.add_box(position=(k - 0.5 * (3 - r), 0.5 + r))
    return w


def no_energy_gain(make: Make, quick: bool, rec: Any) -> Outcome:
    w = resting_pile(make)
    E0 = w.kinetic_energy() + w.potential_energy()
    E = np.array(
        simulate(w, 2.0 if quick else 5.0, rec, "resting-pile", lambda w: w.kinetic_energy() + w.potential_energy())
    )
    gain = float(E.max() - E0)
    return Outcome(gain, gain <= 1e-3, f"E = KE + PE of {len(w) - 1} boxes")


# -- restitution -------------------------------------------------------------------------------
BOUNCE_E, DROP = 0.5, 1.0  # restitution, drop height (m)


def bounce(make: Make, quick: bool, rec: Any) -> Outcome:
    w = world(make)
    scenes.ground(w)
    r = 0.25
    w.add_circle(position=(0.0, DROP + r), radius=r, restitution=BOUNCE_E)
    y = np.array(simulate(w, 1.6, rec, "bounce", lambda w: w.x[1, 1] - r))
    touched = np.flatnonzero(y <= 1e-3)  # on the ground, to within 1 mm
    exact = BOUNCE_E**2 * DROP
    if touched.size == 0:
        return Outcome(math.inf, False, f"the ball never came within 1 mm of the ground (lowest {y.min():.4f} m)")
    apex = float(y[touched[0] :].max())
    error = abs(apex / exact - 1.0)
    return Outcome(100 * error, error <= 0.05, f"rose to {apex:.4f} m, e^2 h = {exact:.4f} m")


# -- no impulse across a gap ---------------------------------------------------------------------
def gaps(make: Make) -> World:
    """No gravity: boxes near the ground within the contact margin; box 1 stays 1 cm up, box 2
    closes 1.5 cm at 0.1 m/s, box 3 leaves the ground at 0.5 m/s."""
    w = world(make, gravity=(0.0, 0.0))
    scenes.ground(w)
    w.add_box(position=(-3.0, 0.51))
    w.add_box(position=(0.0, 0.515), velocity=(0.0, -0.1))
    w.add_box(position=(3.0, 0.5), velocity=(0.0, 0.5))
    return w


def impulse_across_gap(w: World) -> float:
    """The largest lambda_n (N s) of a contact whose box is still apart from the ground at the
    end of the step (its bottom above y = 1e-6 m)."""
    c = w.contacts
    worst = 0.0
    for q in range(len(c)):
        box = int(c.body_b[q]) if w.body_static[c.body_a[q]] else int(c.body_a[q])
        if w.x[box, 1] - 0.5 > 1e-6:
            worst = max(worst, float(c.lambda_n[q]))
    return worst


def no_impulse_across_gap(make: Make, quick: bool, rec: Any) -> Outcome:
    worst = max(simulate(gaps(make), 0.5, rec, "gaps", impulse_across_gap))
    return Outcome(worst, worst <= 0.0)


# -- convergence to the exact LCP solution of a small system ------------------------------------
def circles(make: Make) -> World:
    """Three frictionless circles at rest, two side by side on the ground and one on them (five
    contacts, one of them, between the two below, pushed apart: an LCP with an inactive row)."""
    w = world(make)
    scenes.ground(w, friction=0.0)
    r = 0.5
    w.add_circle(position=(-r, r), radius=r, friction=0.0)
    w.add_circle(position=(r, r), radius=r, friction=0.0, density=2.0)
    w.add_circle(position=(0.0, r + r * math.sqrt(3.0)), radius=r, friction=0.0, density=3.0)
    return w


def dense_system(rows: Any, n_bodies: int, V: np.ndarray, target: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A = J M^-1 J^T and b = target - J V of the normal rows (``rows.normal_row``), dense."""
    k = np.asarray(rows.normal_row)
    J = np.zeros((k.shape[0], 3 * n_bodies))
    JM = np.zeros_like(J)
    for i, row in enumerate(k):
        a, b = rows.body_a[row], rows.body_b[row]
        J[i, 3 * a : 3 * a + 3] += rows.J[row, :3]
        J[i, 3 * b : 3 * b + 3] += rows.J[row, 3:]
        JM[i, 3 * a : 3 * a + 3] += rows.JM[row, :3]
        JM[i, 3 * b : 3 * b + 3] += rows.JM[row, 3:]
    return J @ JM.T, target[k] - J @ V.reshape(-1)


def exact_lcp(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The lambda >= 0 with w = A lambda - b >= 0 and lambda . w = 0, by enumerating the active
    sets (A symmetric positive definite: exactly one set works)."""
    n = b.shape[0]
    best, best_err = np.zeros(n), math.inf
    for size in range(n + 1):
        for active in itertools.combinations(range(n), size):
            lam = np.zeros(n)
            S = list(active)
            if S:
                lam[S] = np.linalg.solve(A[np.ix_(S, S)], b[S])
            w = A @ lam - b
            err = max(-lam.min(initial=0.0), -w.min(initial=0.0))
            if err < best_err:
                best, best_err = lam, err
    return best


def lcp_residual(A: np.ndarray, b: np.ndarray, lam: np.ndarray) -> float:
    """max |min(lambda, A lambda - b)| scaled by A_kk: 0 exactly at an LCP solution (m/s)."""
    return float(np.max(np.abs(np.minimum(lam * np.diag(A), A @ lam - b)), initial=0.0))


CALLS = 8  # responds on the fixed system


def converges(make: Make, quick: bool, rec: Any) -> Outcome:
    """The responder on one step's rows again and again, each call from the same V and from the
    last call's lambda when it warm starts; its lambda_n against the exact LCP solution."""
    w = circles(make)
    responder = w.responder
    seen: list[tuple[float, np.ndarray]] = []
    first: list[SolveResult] = []

    def respond(ctx: StepContext) -> SolveResult:
        rows = ctx.rows
        V_in = ctx.V.copy()
        state = (ctx.x.copy(), ctx.theta.copy())
        A, b = dense_system(rows, V_in.shape[0], V_in, rows.xi + rows.push)
        lam0 = rows.lam.copy()
        kept = {name: getattr(rows, name).copy() for name in ("xi", "push", "bounce", "lo", "hi", "mu", "J", "JM")}
        result = type(responder).respond(responder, ctx)
        first.append(result)
        for _ in range(CALLS - 1):
            seen.append((lcp_residual(A, b, rows.lam[rows.normal_row]), rows.lam[rows.normal_row].copy()))
            lam = rows.lam.copy() if responder.warm_start else lam0
            for name, value in kept.items():
                getattr(rows, name)[:] = value
            rows.lam[:] = lam
            ctx.V[:] = V_in
            ctx.x[:], ctx.theta[:] = state
            result = type(responder).respond(responder, ctx)
        seen.append((lcp_residual(A, b, rows.lam[rows.normal_row]), rows.lam[rows.normal_row].copy()))
        seen.append((np.nan, exact_lcp(A, b)))
        return result

    responder.respond = respond  # type: ignore[method-assign]
    report = w.step(DT)
    if rec is not None:
        rec.log(w, run="circles")
    own = np.asarray(first[0].residuals, float) if first else np.zeros(0)  # its own, sweep by sweep, first call
    substeps = report.counted == "substeps"  # each sub-step a new system: judged on lambda_n alone
    falls = substeps or (own.shape[0] >= 2 and own[-1] <= 0.1 * own[0])
    lcp = np.array([s[0] for s in seen[:-1]])
    exact, lam = seen[-1][1], seen[-2][1]
    error = float(np.abs(lam - exact).max() / np.abs(exact).max())
    if substeps:
        note = "sub-steps, each a new system (gravity again): judged on lambda_n"
    elif own.shape[0] >= 2:
        note = f"its residual {own[0]:.2g} -> {own[-1]:.2g} m/s over {own.shape[0]} {report.counted}"
    else:
        note = f"{own.shape[0]} residual(s) reported: nothing to fall"
    note += f"{'' if falls else ' (falls < 10x)'}; LCP residual after {CALLS} calls {lcp[-1]:.2g} m/s"
    return Outcome(100 * error, bool(falls) and error <= 0.01, note)


# -- determinism, stacking ------------------------------------------------------------------------
def fingerprint(w: World) -> bytes:
    """The bits of x, theta, V and the last step's impulses."""
    c = w.contacts
    return b"".join(np.ascontiguousarray(a).tobytes() for a in (w.x, w.theta, w.V, c.lambda_n, c.lambda_t))


def deterministic(make: Make, quick: bool, rec: Any) -> Outcome:
    runs = []
    for label in ("pile", "pile-again"):
        w = pile(make)
        simulate(w, 1.0, rec, label)
        runs.append(fingerprint(w))
    same = runs[0] == runs[1]
    return Outcome(0.0 if same else 1.0, same, "two runs bit-identical" if same else "two runs differ")


def standing(w: World, x0: np.ndarray) -> float:
    """How far the box that moved most has moved from where it began (m)."""
    return float(np.hypot(*(w.x - x0).T).max())


def stack_stands(make: Make, quick: bool, rec: Any) -> Outcome:
    w = scenes.vertical_stack(10, responder=make())
    w.one_call_tick = False
    x0 = w.x.copy()
    simulate(w, 10.0, rec, "stack")
    moved = standing(w, x0)
    return Outcome(moved, moved <= 0.1, "10 boxes of 1 m, 10 s")


def pyramid_stands(make: Make, quick: bool, rec: Any) -> Outcome:
    w = scenes.pyramid(10, responder=make())
    w.one_call_tick = False
    x0 = w.x.copy()
    seconds = 3.0 if quick else 10.0
    simulate(w, seconds, rec, "pyramid")
    moved = standing(w, x0)
    return Outcome(moved, moved <= 0.1, f"10 rows, 55 boxes of 1 m, {seconds:g} s")


STACKING = "the lecture: the naive takes 'do not support stacking'"
JITTER = "the lecture: the naive take 'jitters a lot'"
NO_GUARANTEE = "the lecture: the naive takes give 'no guarantees', converging to no particular solution"

CLAIMS: tuple[Claim, ...] = (
    Claim("lambda_n >= 0", "contacts push, never pull", "min lambda_n >= 0", "N s", lambda_n_nonnegative),
    Claim(
        "|lambda_t| <= mu lambda_n",
        "friction stays in its cone",
        "max |lambda_t| - mu lambda_n <= 0",
        "N s",
        friction_cone,
    ),
    Claim("ramp: stick", "a box sticks on a ramp below atan(mu)", "slides <= 1 mm", "mm", ramp_sticks),
    Claim("ramp: slide", "above atan(mu) it slides at g(sin - mu cos)", "within 1 %", "%", ramp_slides),
    Claim(
        "momenta",
        "collisions conserve momentum (no gravity)",
        "linear change <= 1e-9 of sum m|v|",
        "",
        momenta_conserved,
    ),
    Claim(
        "no energy gain",
        "a resting pile gains no energy",
        "max E - E0 <= 1e-3 J",
        "J",
        no_energy_gain,
        {"naive": JITTER, "iterative": JITTER},
    ),
    Claim("bounce", "a ball dropped from h bounces to e^2 h", "within 5 %", "%", bounce),
    Claim(
        "no impulse across a gap",
        "no impulse between bodies still apart at the end of a step",
        "max lambda_n <= 0",
        "N s",
        no_impulse_across_gap,
    ),
    Claim(
        "converges to the LCP",
        "the residual falls on a fixed system, toward its exact LCP solution",
        "falls 10x, lambda_n within 1 %",
        "%",
        converges,
        {"naive": NO_GUARANTEE, "iterative": NO_GUARANTEE},
    ),
    Claim("deterministic", "two runs of one scene are bit-identical", "identical", "", deterministic),
    Claim(
        "10-box stack",
        "a 10-box stack stands 10 s (with warm starting)",
        "no box moves > 0.1 m",
        "m",
        stack_stands,
        {"naive": STACKING, "iterative": STACKING},
    ),
    Claim(
        "10-row pyramid",
        "a 10-row pyramid stands",
        "no box moves > 0.1 m",
        "m",
        pyramid_stands,
        {"naive": STACKING, "iterative": STACKING},
    ),
)
