"""A hint per failing claim: the likely mistakes that the card's measurements point to.

The card does not read a responder's code or name; it reads what its claims measured
(``Outcome.evidence``): which claims failed together, and what the impulses and velocities
showed on the card's own system (``claims.converges``) and in the scenes. Each ``Cause`` is
one of the mistakes the lecture's method guards against, named in the lecture's words, with
the test that detects it and the claims it explains. A failing claim's hint lists the causes
detected that explain it, each with the figure that gave it away; when none is detected, it
says what the claim's bar needs, in the same words.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass

from .claims import CLAIMS, Outcome

Outcomes = Mapping[str, Outcome]

ALL = frozenset(c.name for c in CLAIMS)
FRICTION = frozenset({"|lambda_t| <= mu lambda_n", "ramp: stick", "ramp: slide"})
MOTION = ALL - {"deterministic", "momenta", "pushes overlap out"}


def figure(outcomes: Outcomes, claim: str, name: str) -> float:
    """What ``claim`` measured as ``name`` (NaN if it did not)."""
    o = outcomes.get(claim)
    return float(o.evidence.get(name, math.nan)) if o is not None else math.nan


def smallest(*values: float) -> float:
    """The smallest of the values measured (NaN: not measured; NaN if none was)."""
    measured = [v for v in values if not math.isnan(v)]
    return min(measured) if measured else math.nan


def failed(outcomes: Outcomes, claim: str) -> bool:
    o = outcomes.get(claim)
    return o is not None and not o.passed


def blew_up(outcomes: Outcomes) -> list[str]:
    """The claims whose scene the world refused: a velocity non-finite or faster than max_speed."""
    return [name for name, o in outcomes.items() if o.evidence.get("blew_up", 0.0) > 0.0]


# -- the causes ------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Cause:
    """A mistake, named in the lecture's words, with its remedy; ``detect`` returns what the card
    measured that points to it ('' when nothing does); ``explains`` the claims it makes fail."""

    name: str
    remedy: str
    detect: Callable[[Outcomes], str]
    explains: frozenset[str]


CONVERGES = "converges to the LCP"


def _r0(o: Outcomes) -> float:
    """The card's LCP residual where the convergence claim's first call began (m/s)."""
    return figure(o, CONVERGES, "residual_start")


def _velocities_miss(o: Outcomes) -> bool:
    """Whether the velocities a responder returned miss its impulses on the card's system."""
    return figure(o, CONVERGES, "held") > 0.01 * _r0(o)


def sign_of_JV(o: Outcomes) -> str:
    if figure(o, CONVERGES, "approach_ignored") <= 0.0:
        return ""
    if figure(o, CONVERGES, "came_down") < 0.0:
        return (
            "on the card's system it gave no impulse to rows that approach, and from a warm start above the "
            "answer it pushed harder on rows that already separate"
        )
    if blew_up(o):
        return (
            "on the card's system it gave no impulse to rows that approach, yet bodies were flung past "
            f"max_speed in {len(blew_up(o))} scenes"
        )
    return ""


def impulse_on_V(o: Outcomes) -> str:
    first = figure(o, CONVERGES, "held_first")
    if first > 0.01 * _r0(o):
        return (
            f"from lambda = 0, its velocities already miss its impulses by {first:.3g} m/s on the card's system "
            "(J (V - V_in) against A lambda)"
        )
    return ""


def warm_start_in_V(o: Outcomes) -> str:
    if _velocities_miss(o) and figure(o, CONVERGES, "warm") > 0.0:
        return (
            f"its velocities held its impulses from lambda = 0, but missed them by {figure(o, CONVERGES, 'held'):.3g} "
            "m/s when it was given a warm start: the cached lambda never reached V"
        )
    return ""


def clamp_accumulated(o: Outcomes) -> str:
    low = smallest(figure(o, "lambda_n >= 0", "lambda_n_min"), figure(o, "no energy gain", "lambda_n_min"))
    if low < 0.0:
        return f"lambda_n went to {low:.3g} N s: a contact pulled"
    came_down = figure(o, CONVERGES, "came_down")
    if came_down < 0.5:
        return (
            f"from a warm start twice the answer its lambda_n came down by {100 * max(came_down, 0.0):.0f} % of the "
            "excess: an impulse applied too strongly is never taken back"
        )
    gain, excess = figure(o, "no energy gain", "gain"), figure(o, "|lambda_t| <= mu lambda_n", "cone_excess")
    if gain > 1e-3 and excess > 1e-12:
        return (
            f"friction went {excess:.3g} N s past its cone while a resting pile gained {gain:.3g} J, every "
            "lambda_n >= 0: changes clamped one by one add up past the bound"
        )
    return ""


def cone_from_lambda_n(o: Outcomes) -> str:
    excess = figure(o, "|lambda_t| <= mu lambda_n", "cone_excess")
    frictionless = figure(o, CONVERGES, "cone_excess")
    accel, exact = figure(o, "ramp: slide", "accel"), figure(o, "ramp: slide", "accel_exact")
    words = []
    if excess > 1e-12:
        words.append(f"|lambda_t| went {excess:.3g} N s past mu lambda_n")
    if frictionless > 1e-12:
        words.append(f"frictionless contacts (mu = 0) got |lambda_t| = {frictionless:.3g} N s")
    if failed(o, "ramp: slide") and accel < 0.5 * exact:
        words.append(f"friction held the box on the 35 deg ramp ({accel:.3g} m/s^2, not {exact:.3g})")
    elif failed(o, "ramp: slide") and accel > exact:
        words.append(f"friction let the box slide too fast ({accel:.3g} m/s^2, not {exact:.3g})")
    if failed(o, "ramp: stick") and words:
        words.append(f"the box slid {1e3 * figure(o, 'ramp: stick', 'slid'):.3g} mm down a ramp it should hold")
    return "; ".join(words)


def target(o: Outcomes) -> str:
    offset, spread = figure(o, CONVERGES, "target_offset"), figure(o, CONVERGES, "target_spread")
    if abs(offset) > 0.01 * _r0(o) and spread <= 0.1 * abs(offset):
        return f"on the card's system every pushing row ended at J V = xi + push {offset:+.3g} m/s"
    return ""


def push_in_target(o: Outcomes) -> str:
    left, start = figure(o, "pushes overlap out", "overlap_left"), figure(o, "pushes overlap out", "overlap_start")
    if left >= 0.5 * start:
        return f"overlaps it started with stayed: {1e3 * left:.0f} of {1e3 * start:.0f} mm after 1 s"
    growth = figure(o, "pushes overlap out", "stack_growth")
    if growth > 0.005:
        return f"a standing stack's overlap grew {1e3 * growth:.3g} mm"
    return ""


def push_too_weak(o: Outcomes) -> str:
    left, start = figure(o, "pushes overlap out", "overlap_left"), figure(o, "pushes overlap out", "overlap_start")
    if failed(o, "pushes overlap out") and left < 0.5 * start:
        return f"{1e3 * left:.0f} of {1e3 * start:.0f} mm of overlap left after 1 s: pushed out too slowly"
    return ""


def gauss_seidel(o: Outcomes) -> str:
    gain = figure(o, "no energy gain", "gain")
    low = figure(o, "no energy gain", "lambda_n_min")
    settles = not failed(o, CONVERGES) and figure(o, CONVERGES, "came_down") >= 0.5  # it takes impulses back
    if gain > 1e-3 and low >= 0.0 and settles and not failed(o, "|lambda_t| <= mu lambda_n"):
        return (
            "its impulses keep their bounds, solve the card's small system and come down from above it, yet a "
            f"resting pile gained {gain:.3g} J: its sweeps overshoot on a large one"
        )
    return ""


# in order: a cause found masks those after it that ``masks`` names (their symptoms follow from it)
CAUSES: tuple[Cause, ...] = (
    Cause(
        "the sign of J V",
        "delta = (target - J V) / A_kk: a row that approaches (J V < target) gets a positive delta",
        sign_of_JV,
        ALL,
    ),
    Cause(
        "each impulse applied to V",
        "after each change of lambda_k, V[a] += JM[k, :3] * delta and V[b] += JM[k, 3:] * delta (JM = M^-1 J^T), "
        "and rows.lam holding exactly what was applied",
        impulse_on_V,
        ALL - {"deterministic", "pushes overlap out"},
    ),
    Cause(
        "the warm start applied to V",
        "with warm_start = True, rows.lam holds last step's impulses and ctx.V does not: apply "
        "V += M^-1 J^T lambda (JM[k] * lam[k] on bodies a, b) before the sweeps",
        warm_start_in_V,
        MOTION,
    ),
    Cause(
        "the target xi + push",
        "delta = (xi + push - J V) / A_kk: xi closes a gap or bounces, push pushes out an overlap, nothing more",
        target,
        ALL - {"deterministic", "momenta", "|lambda_t| <= mu lambda_n"},
    ),
    Cause(
        "the clamp on the accumulated impulse",
        "new = clamp(lam[k] + delta, low, high); apply new - lam[k]; lam[k] = new (not the clamp of each delta)",
        clamp_accumulated,
        MOTION,
    ),
    Cause(
        "the cone from the current lambda_n",
        "a friction row's bounds are +-mu[k] * lam[bound_row[k]], its normal row's lambda_n as the sweep "
        "reaches it (not lo, hi, nor a fixed mu m g dt)",
        cone_from_lambda_n,
        FRICTION | {CONVERGES, "10-box stack", "10-row pyramid", "no energy gain"},
    ),
    Cause(
        "the push in the target",
        "the lecture's target is xi + push: rows.push holds the Baumgarte push out of an overlap; xi alone "
        "leaves overlaps, more than that adds energy",
        push_in_target,
        frozenset({"pushes overlap out", "10-box stack", "10-row pyramid"}),
    ),
    Cause(
        "the push's strength",
        "push = min((beta / dt) max(0, -(C + slop)), push_max): beta in [0, 1] (0.2), push_max (3 m/s)",
        push_too_weak,
        frozenset({"pushes overlap out"}),
    ),
    Cause(
        "Gauss-Seidel's order",
        "each row's change applied to V before the next row reads J V (a Jacobi sweep, all rows from one V, "
        "needs a relaxation small enough for the most rows a body has)",
        gauss_seidel,
        frozenset({"no energy gain", "10-box stack", "10-row pyramid"}),
    ),
)
MASKS = {  # a cause found hides these: what they saw follows from it
    "the sign of J V": {c.name for c in CAUSES[1:]},
    "each impulse applied to V": {c.name for c in CAUSES[2:]},
    "the warm start applied to V": {
        "the target xi + push",
        "the clamp on the accumulated impulse",
        "Gauss-Seidel's order",
    },
    "the target xi + push": {
        "the clamp on the accumulated impulse",
        "the cone from the current lambda_n",
        "Gauss-Seidel's order",
    },
    "the clamp on the accumulated impulse": {"the cone from the current lambda_n", "Gauss-Seidel's order"},
}

REMEDY = {cause.name: cause.remedy for cause in CAUSES}

# what a failing claim needs when no cause is detected, in the lecture's words
NEEDS = {
    "lambda_n >= 0": "the clamp on the accumulated impulse: a normal row's lam[k] + delta clamped into [0, inf)",
    "|lambda_t| <= mu lambda_n": REMEDY["the cone from the current lambda_n"],
    "ramp: stick": "the cone from the current lambda_n, and friction's target xi (0: stop the sliding)",
    "ramp: slide": "the cone from the current lambda_n: a sliding box's friction is exactly mu lambda_n",
    "momenta": "every impulse on both bodies, equal and opposite: V[a] += JM[k, :3] * delta and "
    "V[b] += JM[k, 3:] * delta",
    "no energy gain": "the clamp on the accumulated impulse (an impulse applied too strongly is taken back within "
    "the step), and each row's change applied to V before the next row reads it (Gauss-Seidel)",
    "bounce": "the bounce in the target: a touching contact's is in xi; a contact still apart is bounced by the "
    "world after respond (rows.bounce) when SolveResult(integrated=False)",
    "no impulse across a gap": "the target xi + push, no more: a contact still apart has xi = -C/dt, which "
    "closes its gap and no more; and lambda_n clamped at 0",
    CONVERGES: "the clamp on the accumulated impulse, each change applied to V, and the warm start applied to V",
    "deterministic": "nothing random or order-dependent in respond (no sets, no clocks)",
    "10-box stack": "the warm start applied to V (contact caching) and enough sweeps (iterations=)",
    "10-row pyramid": "the warm start applied to V (contact caching) and enough sweeps (iterations=)",
    "pushes overlap out": REMEDY["the push in the target"],
}


def hints(outcomes: Outcomes) -> dict[str, str]:
    """A hint for each failing claim of ``outcomes`` (claim name -> Outcome)."""
    found: list[tuple[Cause, str]] = []
    hidden: set[str] = set()
    for cause in CAUSES:
        seen = "" if cause.name in hidden else cause.detect(outcomes)
        if seen:
            found.append((cause, seen))
            hidden |= MASKS.get(cause.name, set())
    out = {}
    for name, o in outcomes.items():
        if o.passed:
            continue
        these = [f"likely {cause.name} ({seen}): {cause.remedy}" for cause, seen in found if name in cause.explains]
        out[name] = "; ".join(these) if these else f"needs {NEEDS.get(name, 'what its bar says')}"
    return out
