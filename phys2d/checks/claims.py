"""The lecture's claims, each a scene and a measure, for the report card (``phys2d.check``).

A claim runs its scene on a new copy of the responder (``make()``), measures one figure and
holds it to a bar: an analytic result (the ramp, the bounce), a conservation law (momenta, no
energy gain), or a second method (an exact LCP solution by enumeration). Each outcome also
keeps what else it measured (``Outcome.evidence``), from which the card names the likely
mistake behind a failure (``hints``). Claims that watch the same scene share one run of it
(``Run.once``), and every scene logs to the card's recorder when it has one, each under its
own run label, so a failing claim's scene can be watched.

Symbols as in docs/formulation.md: lambda_n, lambda_t (N s), mu, e, g (m/s^2), dt (s); an LCP
residual in m/s (an impulse error times A_kk).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Mapping
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
    """What one claim measured: its figure (in the claim's unit), whether it meets the bar, a
    note, and ``evidence``: other figures it measured on the way (named, in SI units; NaN when
    not measured), which the card reads to name a failure's likely cause."""

    figure: float
    passed: bool
    note: str = ""
    evidence: Mapping[str, float] = field(default_factory=dict)


@dataclass
class Run:
    """How the card runs its claims.

    quick     shorter scenes where a claim allows it
    rec       a ``phys2d.Recorder`` that every scene logs to (under its run label), or None
    progress  called with (seconds simulated, seconds the scene lasts) about once a simulated
              second, or None
    done      the scenes run so far, by name (``once``): claims that watch one scene share it
    """

    quick: bool = False
    rec: Any = None
    progress: Callable[[float, float], Any] | None = None
    done: dict[str, Any] = field(default_factory=dict)

    def once(self, name: str, compute: Callable[[], Any]) -> Any:
        """compute(), the first time ``name`` is asked for; then the same result (or exception)."""
        if name not in self.done:
            try:
                self.done[name] = compute()
            except Exception as e:
                self.done[name] = e
        result = self.done[name]
        if isinstance(result, Exception):
            raise result
        return result


@dataclass(frozen=True)
class Claim:
    """One of the lecture's claims: a scene, a measure and a bar.

    name       a short id (``lambda_n >= 0``), the key of the JSON output
    statement  the claim in the lecture's words
    bar        what the figure must meet, in words (``>= 0 N s``)
    unit       the figure's unit
    run        run(make, how) -> Outcome: the scene on ``make()``, run as ``how`` says (a ``Run``)
    scenes     the run labels its scenes log under
    predicted  for each of the lecture's takes (``naive``, ``iterative``) that it says fail this
               claim, the lecture's words
    """

    name: str
    statement: str
    bar: str
    unit: str
    run: Callable[[Make, Run], Outcome]
    scenes: tuple[str, ...]
    predicted: dict[str, str] = field(default_factory=dict)


# -- stepping ----------------------------------------------------------------------------
def simulate(
    w: World,
    seconds: float,
    how: Run,
    label: str,
    probe: Callable[[World], Any] | None = None,
    stop: Callable[[Any], bool] | None = None,
) -> list:
    """Step ``w`` for ``seconds`` (logging each step to ``how.rec`` as run ``label``); probe(w)
    after each step, and stop early once stop(probe(w)) is True. Returns the probes."""
    out = []
    steps = round(seconds / DT)
    every = round(1.0 / DT)
    for i in range(steps):
        w.step(DT)
        if how.rec is not None:
            how.rec.log(w, run=label)
        if probe is not None:
            out.append(probe(w))
            if stop is not None and stop(out[-1]):
                break
        if how.progress is not None and (i + 1) % every == 0 and i + 1 < steps:
            how.progress((i + 1) * DT, seconds)
    return out


def world(make: Make, gravity: tuple[float, float] = (0.0, -G)) -> World:
    """A world with a new copy of the responder, stepped stage by stage (a plain ``respond`` is)."""
    w = World(gravity=gravity, responder=make())
    w.one_call_tick = False
    return w


def rotation(a: float) -> np.ndarray:
    return np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])


def largest(values: Any) -> float:
    """The largest of ``values`` (-inf if none), NaN if any is NaN: a NaN is never passed over,
    as Python's max(0.0, nan) passes over it."""
    a = np.asarray(values, float)
    return float(a.max()) if a.size else -math.inf


def deepest_overlap(w: World) -> float:
    """The deepest overlap among the contacts found at the last step's start (m, >= 0): where
    the step before left the bodies."""
    c = w.contacts
    return max(0.0, -float(c.separation.min())) if len(c) else 0.0


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
    """The smallest lambda_n (N s) and the largest |lambda_t| - mu lambda_n (N s) of the last step
    (NaN if an impulse is)."""
    c = w.contacts
    if len(c) == 0:
        return math.inf, -math.inf
    return float(c.lambda_n.min()), float(np.max(np.abs(c.lambda_t) - c.friction * np.maximum(c.lambda_n, 0.0)))


def fingerprint(w: World) -> bytes:
    """The bits of x, theta, V and the last step's impulses."""
    c = w.contacts
    return b"".join(np.ascontiguousarray(a).tobytes() for a in (w.x, w.theta, w.V, c.lambda_n, c.lambda_t))


DETERMINISTIC_SECONDS = 1.0


def pile_run(make: Make, how: Run) -> tuple[np.ndarray, bytes]:
    """The pile's bounds step by step (``bounds_of``) and its fingerprint after 1 s (shared)."""

    def compute() -> tuple[np.ndarray, bytes]:
        w = pile(make)
        prints: list[bytes] = []

        def probe(w: World) -> tuple[float, float]:
            if w.tick == round(DETERMINISTIC_SECONDS / DT):
                prints.append(fingerprint(w))
            return bounds_of(w)

        bounds = np.array(simulate(w, 2.0 if how.quick else 4.0, how, "pile", probe))
        return bounds, prints[0]

    return how.once("pile", compute)


def lambda_n_nonnegative(make: Make, how: Run) -> Outcome:
    low = float(pile_run(make, how)[0][:, 0].min())
    return Outcome(low, low >= 0.0, evidence={"lambda_n_min": low})


def friction_cone(make: Make, how: Run) -> Outcome:
    bounds = pile_run(make, how)[0]
    over = float(bounds[:, 1].max())
    return Outcome(over, over <= 1e-12, evidence={"cone_excess": over, "lambda_n_min": float(bounds[:, 0].min())})


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


def ramp_sticks(make: Make, how: Run) -> Outcome:
    alpha = 0.8 * math.atan(RAMP_MU)
    w = ramp(make, alpha, RAMP_MU)
    s0 = along_slope(w, alpha)[0]
    simulate(w, 2.0 if how.quick else 5.0, how, "ramp-stick")
    slid = abs(along_slope(w, alpha)[0] - s0)
    return Outcome(
        slid * 1e3,
        slid <= 1e-3,
        f"slope {math.degrees(alpha):.1f} deg < atan(mu) = {math.degrees(math.atan(RAMP_MU)):.1f} deg",
        {"slid": slid},
    )


def ramp_slides(make: Make, how: Run) -> Outcome:
    alpha = math.radians(35.0)
    w = ramp(make, alpha, RAMP_MU)
    seconds = 2.0 if how.quick else 4.0
    v = np.array(simulate(w, seconds, how, "ramp-slide", lambda w: along_slope(w, alpha)[1]))
    settle = round(0.5 / DT)
    accel = float((v[-1] - v[settle - 1]) / ((len(v) - settle) * DT))
    exact = G * (math.sin(alpha) - RAMP_MU * math.cos(alpha))
    error = abs(accel / exact - 1.0)
    note = f"{accel:.4f} m/s^2, g(sin - mu cos) = {exact:.4f} m/s^2"
    return Outcome(100 * error, error <= 0.01, note, {"accel": accel, "accel_exact": exact})


# -- conservation ------------------------------------------------------------------------------
def collisions(make: Make) -> World:
    """No gravity, no static body: two spinning boxes and a circle thrown into one another."""
    w = world(make, gravity=(0.0, 0.0))
    w.add_box(position=(-2.0, 0.0), velocity=(3.0, 0.3), angular_velocity=1.0, friction=0.4)
    w.add_box(position=(2.0, 0.3), half_extents=(0.7, 0.4), velocity=(-2.0, 0.0), angular_velocity=-0.5, friction=0.4)
    w.add_circle(position=(0.1, 3.0), radius=0.4, velocity=(0.0, -2.5), density=2.0, friction=0.4)
    return w


def momenta_conserved(make: Make, how: Run) -> Outcome:
    w = collisions(make)
    p0, L0 = w.linear_momentum(), w.angular_momentum()
    scale = float(np.sum(w.body_masses * np.hypot(w.V[:, 0], w.V[:, 1])))  # kg m/s: sum of m |v|
    hits = simulate(w, 1.5, how, "collisions", lambda w: len(w.contacts) > 0 and not w.contacts.lambda_n.max() <= 0)
    dp = largest(np.abs(w.linear_momentum() - p0)) / scale
    dL = abs(w.angular_momentum() - L0) / scale  # per metre of lever arm
    note = f"angular {dL:.2g} (bar 1e-2: position corrections change it a little)"
    if not any(hits):
        return Outcome(dp, False, "no impulse at all: the bodies never collided", {"momentum_change": dp})
    return Outcome(dp, dp <= 1e-9 and dL <= 1e-2, note, {"momentum_change": dp, "angular_change": dL})


def resting_pile(make: Make) -> World:
    """A 4-row pyramid of 1 m boxes, touching, at rest."""
    w = world(make)
    scenes.ground(w)
    for r in range(4):
        for k in range(4 - r):
            w.add_box(position=(k - 0.5 * (3 - r), 0.5 + r))
    return w


def no_energy_gain(make: Make, how: Run) -> Outcome:
    w = resting_pile(make)
    E0 = w.kinetic_energy() + w.potential_energy()
    seen = simulate(
        w,
        2.0 if how.quick else 5.0,
        how,
        "resting-pile",
        lambda w: (w.kinetic_energy() + w.potential_energy(), bounds_of(w)[0]),
    )
    E, low = np.array([s[0] for s in seen]), np.array([s[1] for s in seen])
    gain = largest(E) - E0
    return Outcome(gain, gain <= 1e-3, f"E = KE + PE of {len(w) - 1} boxes", {"gain": gain, "lambda_n_min": low.min()})


# -- restitution -------------------------------------------------------------------------------
BOUNCE_E, DROP = 0.5, 1.0  # restitution, drop height (m)


def bounce(make: Make, how: Run) -> Outcome:
    w = world(make)
    scenes.ground(w)
    r = 0.25
    w.add_circle(position=(0.0, DROP + r), radius=r, restitution=BOUNCE_E)
    y = np.array(simulate(w, 1.6, how, "bounce", lambda w: w.x[1, 1] - r))
    touched = np.flatnonzero(y <= 1e-3)  # on the ground, to within 1 mm
    exact = BOUNCE_E**2 * DROP
    if touched.size == 0:
        return Outcome(math.inf, False, f"the ball never came within 1 mm of the ground (lowest {y.min():.4f} m)")
    apex = largest(y[touched[0] :])
    error = abs(apex / exact - 1.0)
    return Outcome(100 * error, error <= 0.05, f"rose to {apex:.4f} m, e^2 h = {exact:.4f} m", {"apex": apex})


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
    end of the step (its bottom above y = 1e-6 m); NaN if any such impulse is NaN."""
    c = w.contacts
    apart = [q for q in range(len(c)) if w.x[_box_of(w, q), 1] - 0.5 > 1e-6]
    return largest(np.append(c.lambda_n[apart], 0.0))


def _box_of(w: World, q: int) -> int:
    c = w.contacts
    return int(c.body_b[q]) if w.body_static[c.body_a[q]] else int(c.body_a[q])


def no_impulse_across_gap(make: Make, how: Run) -> Outcome:
    worst = largest(simulate(gaps(make), 0.5, how, "gaps", impulse_across_gap))
    return Outcome(worst, worst <= 0.0, evidence={"gap_impulse": worst})


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
    """A = J M^-1 J^T and b = target - J V of the normal rows (``Rows.normal_row``), dense."""
    k = np.asarray(rows.normal_row)
    J, JM = dense_rows(rows, k, n_bodies)
    return J @ JM.T, target[k] - J @ V.reshape(-1)


def dense_rows(rows: Any, which: np.ndarray, n_bodies: int) -> tuple[np.ndarray, np.ndarray]:
    """J and (M^-1 J^T)^T of the rows ``which``, dense: (len(which), 3 n_bodies) each."""
    J = np.zeros((which.shape[0], 3 * n_bodies))
    JM = np.zeros_like(J)
    for i, row in enumerate(which):
        a, b = rows.body_a[row], rows.body_b[row]
        J[i, 3 * a : 3 * a + 3] += rows.J[row, :3]
        J[i, 3 * b : 3 * b + 3] += rows.J[row, 3:]
        JM[i, 3 * a : 3 * a + 3] += rows.JM[row, :3]
        JM[i, 3 * b : 3 * b + 3] += rows.JM[row, 3:]
    return J, JM


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


class ContactSystem:
    """The card's own copy of one step's contact rows, dense, with the velocities they began
    from: what it judges a responder's impulses and velocities on.

    Rows k with A_kk > 0 (normal and friction rows of every contact); targets xi + push (the
    lecture's); bounds lo, hi, or +-mu lambda_n of the normal row for a friction row.
    """

    def __init__(self, rows: Any, V_in: np.ndarray) -> None:
        contact_rows = np.concatenate([np.asarray(rows.normal_row), np.asarray(rows.friction_row)])
        self.rows = np.sort(contact_rows[np.asarray(rows.A_kk)[contact_rows] > 0.0])
        self.normal = np.isin(self.rows, np.asarray(rows.normal_row))
        self.J, self.JM = dense_rows(rows, self.rows, V_in.shape[0])
        self.A = self.J @ self.JM.T
        self.A_kk = np.diag(self.A).copy()
        self.V_in = V_in.reshape(-1).copy()
        self.target = (rows.xi + rows.push)[self.rows]
        self.b = self.target - self.J @ self.V_in  # A lambda = b where a row pushes
        self.lo, self.hi = rows.lo[self.rows].copy(), rows.hi[self.rows].copy()
        bound = np.asarray(rows.bound_row)[self.rows]
        self.mu = np.where(bound >= 0, rows.mu[self.rows], np.nan)
        self.bound = np.searchsorted(self.rows, np.maximum(bound, 0))  # a friction row's normal row, in self.rows

    def of(self, lam: np.ndarray) -> np.ndarray:
        """The system's rows of a full (R,) lambda."""
        return lam[self.rows]

    def velocity(self, lam: np.ndarray) -> np.ndarray:
        """V_in + M^-1 J^T lambda, flat: the velocities that the impulses ``lam`` (system rows) make."""
        return self.V_in + self.JM.T @ lam

    def bounds(self, lam: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Each row's bounds for ``lam`` (system rows): lo, hi, or +-mu lambda_n."""
        friction = ~np.isnan(self.mu)
        top = np.where(friction, np.nan_to_num(self.mu) * lam[self.bound], self.hi)
        return np.where(friction, -top, self.lo), top

    def residual(self, lam: np.ndarray, V: np.ndarray) -> float:
        """The projected natural residual, max_k A_kk |lambda_k - proj_[lo, hi](lambda_k - (J_k V - target_k) / A_kk)|
        (m/s): 0 exactly where lambda solves the LCP with the velocities V it made; NaN if either is."""
        lo, hi = self.bounds(lam)
        step = lam - (self.J @ V.reshape(-1) - self.target) / self.A_kk
        return largest(self.A_kk * np.abs(lam - np.minimum(np.maximum(step, lo), hi)))

    def held(self, lam: np.ndarray, V: np.ndarray) -> float:
        """max_k |J_k (V - V_in) - (A lambda)_k| (m/s): 0 where the velocities V hold the impulses
        lambda (V = V_in + M^-1 J^T lambda along the rows)."""
        return largest(np.abs(self.J @ (V.reshape(-1) - self.V_in) - self.A @ lam))


@dataclass(frozen=True)
class Call:
    """One call of ``respond`` on the fixed system: the impulses it was given (system rows), the
    impulses and velocities it returned, and the residuals it reported."""

    start: np.ndarray
    lam: np.ndarray
    V: np.ndarray
    own: np.ndarray


CALLS = 8  # responds on the fixed system
FROM_ABOVE = 4  # a warm starter's calls from here on start from twice the exact lambda_n


def converges(make: Make, how: Run) -> Outcome:
    """The responder on one step's rows again and again, each call from the same V. A warm starter
    starts each call from the last call's lambda, and its last calls from twice the exact lambda_n
    (a load that has left): it must bring lambda_n down to the answer. Judged on what it returns,
    call by call: the card's LCP residual of its impulses and velocities (``ContactSystem``) must
    fall 100x, its velocities must hold its impulses, and lambda_n must end within 1 % of the exact
    LCP solution (active sets enumerated). A responder of sub-steps or passes is judged on lambda_n."""
    w = circles(make)
    responder = w.responder
    calls: list[Call] = []
    systems: list[tuple[ContactSystem, np.ndarray]] = []

    def respond(ctx: StepContext) -> SolveResult:
        rows = ctx.rows
        V_in = ctx.V.copy()
        state = (ctx.x.copy(), ctx.theta.copy())
        kept = {name: getattr(rows, name).copy() for name in ("xi", "push", "bounce", "lo", "hi", "mu", "J", "JM")}
        system = ContactSystem(rows, V_in)
        exact = np.zeros(system.rows.shape[0])
        exact[system.normal] = exact_lcp(system.A[np.ix_(system.normal, system.normal)], system.b[system.normal])
        systems.append((system, exact))
        result: SolveResult | None = None
        for i in range(CALLS):  # the first from the cache's lambda (0 in a first step)
            if i > 0:
                for name, value in kept.items():
                    getattr(rows, name)[:] = value
                ctx.V[:] = V_in
                ctx.x[:], ctx.theta[:] = state
                if responder.warm_start:
                    lam = rows.lam.copy()
                    if i == FROM_ABOVE:
                        lam[system.rows] = 2.0 * exact
                    rows.lam[:] = lam
                else:
                    rows.lam[:] = 0.0
            start = system.of(rows.lam).copy()
            result = type(responder).respond(responder, ctx)
            own = np.asarray(result.residuals, float) if isinstance(result, SolveResult) else np.zeros(0)
            calls.append(Call(start, system.of(rows.lam).copy(), ctx.V.copy(), own))
        return result  # type: ignore[return-value]  # None: the world names a respond that returned nothing

    responder.respond = respond  # type: ignore[method-assign]
    try:
        counted = w.step(DT).counted
    except Exception as e:  # the world refused the last call's velocities as too fast: judge the calls
        finite = all(np.isfinite(c.V).all() and np.isfinite(c.lam).all() for c in calls)
        if len(calls) < CALLS or type(e).__name__ != "SimulationError" or not finite:
            raise
        o = judge_convergence(systems[0][0], systems[0][1], calls, responder.counts, responder.warm_start)
        note = f"the world then refused its velocities ({type(e).__name__}: {e}); {o.note}"
        return Outcome(o.figure, False, note, {**o.evidence, "blew_up": 1.0})
    if how.rec is not None:
        how.rec.log(w, run="circles")
    system, exact = systems[0]
    return judge_convergence(system, exact, calls, counted, responder.warm_start)


def judge_convergence(system: ContactSystem, exact: np.ndarray, calls: list[Call], counted: str, warm: bool) -> Outcome:
    """The convergence claim's verdict on the calls (see ``converges``)."""
    exact_n = exact[system.normal]

    def error(lam: np.ndarray) -> float:
        return largest(np.abs(lam[system.normal] - exact_n)) / float(np.abs(exact_n).max())

    start = calls[0].start
    r0 = system.residual(start, system.velocity(start))  # where the first call began
    residuals = [system.residual(c.lam, c.V) for c in calls]
    held = largest([system.held(c.lam, c.V) for c in calls])
    err = error(calls[-1].lam)
    evidence: dict[str, float] = {
        "lambda_error": err,
        "residual_start": r0,
        "residual_end": residuals[-1],
        "held": held,
        "held_first": system.held(calls[0].lam, calls[0].V),
        "warm": float(warm),
    }
    active = np.flatnonzero(exact > 1e-9 * np.abs(exact).max())
    off = system.J[active] @ calls[-1].V.reshape(-1) - system.target[active]
    evidence["target_offset"] = float(np.median(off)) if off.size else 0.0
    evidence["target_spread"] = float(np.ptp(off)) if off.size else 0.0
    first = calls[0]  # rows that approach at its start and need a push: did it give them any?
    approach = system.J[active] @ system.velocity(first.start) - system.target[active] < 0.0
    evidence["approach_ignored"] = float(
        bool(np.any(approach)) and bool(np.all(first.lam[active][approach] <= first.start[active][approach]))
    )
    lo, hi = system.bounds(calls[-1].lam)
    evidence["cone_excess"] = largest(np.maximum(lo - calls[-1].lam, calls[-1].lam - hi)[~system.normal])
    if warm and len(calls) > FROM_ABOVE:  # from twice the answer: did lambda_n come down?
        evidence["came_down"] = 1.0 - error(calls[-1].lam) / max(error(calls[FROM_ABOVE].start), 1e-300)
    own = calls[0].own
    shown = (
        f"its own residuals {own[0]:.2g} -> {own[-1]:.2g} m/s over {own.shape[0]} {counted} (shown, not judged)"
        if own.shape[0] >= 2
        else f"{own.shape[0]} residual(s) of its own (shown, not judged)"
    )
    if counted in ("substeps", "passes"):  # each sub-step a new system, or passes that keep no total: lambda_n
        why = "sub-steps, each a new system (gravity again)" if counted == "substeps" else "passes"
        return Outcome(100 * err, err <= 0.01, f"{why}: judged on lambda_n; {shown}", evidence)
    falls = residuals[-1] <= 0.01 * r0
    holds = held <= 0.01 * r0
    if warm:
        parts = [
            f"LCP residual {r0:.2g} -> {residuals[FROM_ABOVE - 1]:.2g} m/s in {FROM_ABOVE} calls",
            f"from 2x the answer -> {residuals[-1]:.2g} m/s in {CALLS - FROM_ABOVE} more",
        ]
    else:
        parts = [f"LCP residual {r0:.2g} -> {residuals[-1]:.2g} m/s in one call (it starts cold)"]
    if not falls:
        parts.append("(falls < 100x)")
    if not holds:
        parts.append(f"its V misses its impulses by {held:.2g} m/s")
    parts.append(shown)
    return Outcome(100 * err, err <= 0.01 and falls and holds, "; ".join(parts), evidence)


# -- determinism, stacking, position correction --------------------------------------------------
def deterministic(make: Make, how: Run) -> Outcome:
    first = pile_run(make, how)[1]
    w = pile(make)
    simulate(w, DETERMINISTIC_SECONDS, how, "pile-again")
    same = fingerprint(w) == first
    return Outcome(0.0 if same else 1.0, same, "two runs bit-identical" if same else "two runs differ")


def standing(w: World, x0: np.ndarray) -> float:
    """How far the box that moved most has moved from where it began (m)."""
    return largest(np.hypot(*(w.x - x0).T))


FALLEN = 0.5  # m: a scene whose box moved this far has failed for good; it stops there


def stand(w: World, seconds: float, how: Run, label: str) -> tuple[np.ndarray, np.ndarray]:
    """Step a standing scene (stopping once a box has moved FALLEN); each step's largest move (m)
    and deepest overlap (m)."""
    x0 = w.x.copy()
    seen = simulate(w, seconds, how, label, lambda w: (standing(w, x0), deepest_overlap(w)), lambda s: s[0] > FALLEN)
    return np.array([s[0] for s in seen]), np.array([s[1] for s in seen])


def fell(moved: np.ndarray, seconds: float) -> str:
    """The note of a scene stopped early, or ''."""
    steps = round(seconds / DT)
    return f"; a box moved {FALLEN:g} m at {moved.shape[0] * DT:.2f} s: stopped there" if len(moved) < steps else ""


STACK_SECONDS = 10.0


def stack_run(make: Make, how: Run) -> tuple[np.ndarray, np.ndarray]:
    """The 10-box stack's moves and overlaps step by step (shared)."""

    def compute() -> tuple[np.ndarray, np.ndarray]:
        w = scenes.vertical_stack(10, responder=make())
        w.one_call_tick = False
        return stand(w, STACK_SECONDS, how, "stack")

    return how.once("stack", compute)


def stack_stands(make: Make, how: Run) -> Outcome:
    moved = stack_run(make, how)[0]
    return Outcome(moved[-1], moved[-1] <= 0.1, "10 boxes of 1 m, 10 s" + fell(moved, STACK_SECONDS))


def pyramid_stands(make: Make, how: Run) -> Outcome:
    w = scenes.pyramid(10, responder=make())
    w.one_call_tick = False
    seconds = 2.0 if how.quick else 10.0
    moved = stand(w, seconds, how, "pyramid")[0]
    return Outcome(moved[-1], moved[-1] <= 0.1, f"10 rows, 55 boxes of 1 m, {seconds:g} s" + fell(moved, seconds))


def sunk(make: Make) -> World:
    """Bodies that start in overlap, under gravity: boxes 5, 10 and 20 cm into the ground, a ball
    10 cm into it, and two boxes side by side 20 cm into each other."""
    w = world(make)
    scenes.ground(w)
    for x, depth in ((-6.0, 0.05), (-4.0, 0.1), (-2.0, 0.2)):
        w.add_box(position=(x, 0.5 - depth))
    w.add_circle(position=(0.0, 0.4 - 0.1), radius=0.4)
    w.add_box(position=(3.0, 0.5))
    w.add_box(position=(3.8, 0.5))
    return w


SUNK, SUNK_SECONDS = 0.2, 1.0  # m, the deepest starting overlap; s, the time to push it out
OVERLAP_BAR = 0.1 * SUNK  # m, what may be left
STACK_GROWTH_BAR = 0.005  # m, how much a standing stack's deepest overlap may grow


def pushes_out(make: Make, how: Run) -> Outcome:
    """Overlaps are pushed out: those the scene starts with, within 1 s; and a standing 10-box
    stack's do not grow over its 10 s (from its second second to its last)."""
    w = sunk(make)
    left = largest(simulate(w, SUNK_SECONDS, how, "overlap", deepest_overlap)[-1:])
    second = round(1.0 / DT)
    note = f"{1e3 * SUNK:.0f} mm at the start"
    growth = math.nan
    try:
        moved, overlaps = stack_run(make, how)
    except Exception:
        moved, overlaps = np.array([math.nan]), np.zeros(0)
    if math.isnan(moved[-1]):
        note += "; the stack's run failed (10-box stack): its overlaps not judged"
    elif moved[-1] > 0.1:
        note += "; the stack fell (10-box stack): its overlaps not judged"
    elif overlaps.shape[0] >= 3 * second:
        growth = largest(overlaps[-second:]) - largest(overlaps[second : 2 * second])
        note += f"; the stack's deepest overlap grew {1e3 * growth:.2g} mm from its second second to its last"
    passed = left <= OVERLAP_BAR and not growth > STACK_GROWTH_BAR
    evidence = {"overlap_left": left, "overlap_start": SUNK, "stack_growth": growth}
    return Outcome(1e3 * left, passed, note, evidence)


STACKING = "the lecture: the naive takes 'do not support stacking'"
JITTER = "the lecture: the naive take 'jitters a lot'"
NO_GUARANTEE = "the lecture: the naive takes give 'no guarantees', converging to no particular solution"

CLAIMS: tuple[Claim, ...] = (
    Claim("lambda_n >= 0", "contacts push, never pull", "min lambda_n >= 0", "N s", lambda_n_nonnegative, ("pile",)),
    Claim(
        "|lambda_t| <= mu lambda_n",
        "friction stays in its cone",
        "max |lambda_t| - mu lambda_n <= 0",
        "N s",
        friction_cone,
        ("pile",),
    ),
    Claim("ramp: stick", "a box sticks on a ramp below atan(mu)", "slides <= 1 mm", "mm", ramp_sticks, ("ramp-stick",)),
    Claim(
        "ramp: slide",
        "above atan(mu) it slides at g(sin - mu cos)",
        "within 1 %",
        "%",
        ramp_slides,
        ("ramp-slide",),
    ),
    Claim(
        "momenta",
        "collisions conserve momentum (no gravity)",
        "linear change <= 1e-9 of sum m|v|",
        "",
        momenta_conserved,
        ("collisions",),
    ),
    Claim(
        "no energy gain",
        "a resting pile gains no energy",
        "max E - E0 <= 1e-3 J",
        "J",
        no_energy_gain,
        ("resting-pile",),
        {"naive": JITTER, "iterative": JITTER},
    ),
    Claim("bounce", "a ball dropped from h bounces to e^2 h", "within 5 %", "%", bounce, ("bounce",)),
    Claim(
        "no impulse across a gap",
        "no impulse between bodies still apart at the end of a step",
        "max lambda_n <= 0",
        "N s",
        no_impulse_across_gap,
        ("gaps",),
    ),
    Claim(
        "converges to the LCP",
        "its impulses, call after call on one system, reach the exact LCP solution",
        "lambda_n within 1 %, LCP residual falls 100x",
        "%",
        converges,
        ("circles",),
        {"naive": NO_GUARANTEE, "iterative": NO_GUARANTEE},
    ),
    Claim(
        "deterministic",
        "two runs of one scene are bit-identical",
        "identical",
        "",
        deterministic,
        ("pile", "pile-again"),
    ),
    Claim(
        "10-box stack",
        "a 10-box stack stands 10 s (with warm starting)",
        "no box moves > 0.1 m",
        "m",
        stack_stands,
        ("stack",),
        {"naive": STACKING, "iterative": STACKING},
    ),
    Claim(
        "10-row pyramid",
        "a 10-row pyramid stands",
        "no box moves > 0.1 m",
        "m",
        pyramid_stands,
        ("pyramid",),
        {"naive": STACKING, "iterative": STACKING},
    ),
    Claim(
        "pushes overlap out",
        "position correction: overlaps are pushed out, and a standing stack's do not grow",
        "<= 20 of 200 mm left after 1 s; stack's grows <= 5 mm",
        "mm",
        pushes_out,
        ("overlap", "stack"),
    ),
)
