"""The report card (``phys2d check``): it passes the engine's PGS and soft step and the lesson's
plain PGS, fails broken responders on the claims they break and names the likely mistake from
what it measured, judges convergence on the impulses a responder returns, and survives bad input.

Cards are --quick and cached per responder class for the module (``card``): each responder's
card runs once however many tests read it."""

from __future__ import annotations

import io
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import phys2d
from phys2d.checks import CLAIMS, Card, CheckError, Result, Stage, check, load
from phys2d.checks.card import Progress, compiling
from phys2d.checks.claims import ContactSystem, exact_lcp, largest, lcp_residual
from phys2d.checks.hints import CAUSES as CAUSES_FOUND
from phys2d.checks.hints import NEEDS
from phys2d.testing.strategies import fingerprint
from tests import card_docs
from tests import responders_for_check as rc
from tests.dropped import busy, dropping_callback

ROOT = Path(__file__).resolve().parents[1]
TEMPLATE = str(ROOT / "lessons" / "your_responder.py")
NAMES = [c.name for c in CLAIMS]
CAUSES = (  # the lecture's words the hints use
    "the clamp on the accumulated impulse",
    "the warm start applied to V",
    "the cone from the current lambda_n",
    "the push in the target",
    "the sign of J V",
)


class Cards:
    """--quick cards, each run once per responder class and kept (the ``card`` fixture, for the module)."""

    def __init__(self) -> None:
        self.done: dict[type[phys2d.Responder], Card] = {}

    def of(self, make: type[phys2d.Responder]) -> Card:
        """The --quick card of ``make()``."""
        if make not in self.done:
            self.done[make] = check(make(), quick=True, out=None, echo=None)
        return self.done[make]

    def __call__(self, make: type[phys2d.Responder]) -> dict[str, Result]:
        """The --quick card of ``make()``, by claim name."""
        return {r.name: r for r in self.of(make).results}

    def failing(self, make: type[phys2d.Responder]) -> set[str]:
        return {name for name, r in self(make).items() if not r.passed}

    def named(self, make: type[phys2d.Responder]) -> set[str]:
        """The causes the hints of a card name."""
        return {cause for r in self(make).values() for cause in CAUSES if cause in r.hint}


@pytest.fixture(scope="module")
def card() -> Cards:
    return Cards()


# -- the claims a good responder meets ----------------------------------------------------------
@pytest.mark.parametrize("make", [phys2d.PGS, phys2d.SoftStep, rc.LecturePGS], ids=["pgs", "soft-step", "lesson"])
def test_good_responders_pass_every_claim(card: Cards, make) -> None:
    results = card(make)
    assert list(results) == NAMES and len(NAMES) == 13
    assert all(r.passed for r in results.values()), [r.line() for r in results.values() if not r.passed]
    assert not any(r.hint for r in results.values())


def test_the_lessons_pgs_meets_the_analytic_figures(card: Cards) -> None:
    """Second methods: the ramp's g(sin - mu cos) = 1.640 m/s^2 and e^2 h = 0.25 m, read from the notes."""
    results = card(rc.LecturePGS)
    assert "g(sin - mu cos) = 1.6400" in results["ramp: slide"].note
    assert results["ramp: slide"].figure < 1.0  # %
    assert "e^2 h = 0.2500 m" in results["bounce"].note


# -- planted mistakes: the failures they cause, and the hint that names them -------------------------
PLANTED = [
    # (responder, claims it must fail, claims it must pass, the cause its hints name)
    (
        rc.ClampsDelta,
        {"|lambda_t| <= mu lambda_n", "no energy gain", "converges to the LCP", "10-box stack"},
        {"lambda_n >= 0", "momenta", "deterministic"},
        "the clamp on the accumulated impulse",
    ),
    (
        rc.WarmStartNotApplied,
        {"converges to the LCP", "10-box stack"},
        {"lambda_n >= 0", "|lambda_t| <= mu lambda_n", "momenta", "bounce"},
        "the warm start applied to V",
    ),
    (
        rc.FixedFrictionBound,
        {"|lambda_t| <= mu lambda_n", "ramp: slide"},
        {"lambda_n >= 0", "converges to the LCP", "10-box stack", "pushes overlap out"},
        "the cone from the current lambda_n",
    ),
    (rc.NoPush, {"pushes overlap out"}, set(NAMES) - {"pushes overlap out"}, "the push in the target"),
    (rc.FlippedSign, set(NAMES), set(), "the sign of J V"),
]


@pytest.mark.parametrize("make, fails, passes, cause", PLANTED, ids=[p[0].name for p in PLANTED])
def test_a_planted_mistake_fails_its_claims_and_the_hint_names_it(card: Cards, make, fails, passes, cause: str) -> None:
    results = card(make)
    bad = card.failing(make)
    assert fails <= bad, [results[n].line() for n in fails - bad]
    assert not bad & passes, [results[n].line() for n in bad & passes]
    for name in bad:  # every failing claim has a hint; the planted cause is in every one, no other cause is
        assert cause in results[name].hint, (name, results[name].hint)
    assert card.named(make) == {cause}
    assert all(not r.hint for r in results.values() if r.passed)


def test_the_clamp_hint_rests_on_lambda_that_never_came_down(card: Cards) -> None:
    """From a warm start of twice the exact lambda_n every sweep's delta is negative, and clamped to
    0 one by one it stays: lambda_n ends 100 % above the answer, as it began."""
    converges = card(rc.ClampsDelta)["converges to the LCP"]
    assert converges.figure == pytest.approx(100.0, rel=1e-6)
    assert "came down by 0 %" in converges.hint


def test_the_warm_start_hint_rests_on_velocities_that_miss_the_impulses(card: Cards) -> None:
    """Calls 1 to 4 each add the whole answer again to a lambda_n never applied to V, calls 5 to 8
    the same from twice the answer: lambda_n ends at 2 + 4 = 6 times the answer, 500 % above it."""
    converges = card(rc.WarmStartNotApplied)["converges to the LCP"]
    assert converges.figure == pytest.approx(500.0, rel=1e-3)
    assert "misses its impulses" in converges.note


def test_the_cone_hint_rests_on_the_ramp(card: Cards) -> None:
    """Two points each bounded by mu m g dt hold 2 mu m g dt = 1.0 m g dt of friction, more than the
    m g sin 35 deg dt = 0.57 m g dt the slope asks: the box is held where it should slide."""
    results = card(rc.FixedFrictionBound)
    assert results["ramp: slide"].figure == pytest.approx(100.0, abs=1.0)  # no acceleration at all
    assert "friction held the box" in results["ramp: slide"].hint


def test_the_push_hint_rests_on_the_overlap_that_stayed(card: Cards) -> None:
    result = card(rc.NoPush)["pushes overlap out"]
    assert result.figure == pytest.approx(200.0, abs=1.0)  # mm: nothing pushed, nothing removed
    assert "stayed: 200 of 200 mm" in result.hint


@pytest.mark.parametrize("make", [rc.ResidualBeforeClamp, rc.ProjectedJacobi], ids=["residual-early", "jacobi"])
def test_right_impulses_pass_convergence_whatever_residuals_it_reports(card: Cards, make) -> None:
    """The card judges the impulses: a residual measured before the clamp (it never falls at a
    row that stays clamped), and a projected Jacobi that converges slowly, both pass."""
    result = card(make)["converges to the LCP"]
    assert result.passed, result.line()
    assert result.figure < 1.0  # % off the exact lambda_n
    assert "(shown, not judged)" in result.note


def test_the_residual_before_the_clamp_is_shown_not_judged(card: Cards) -> None:
    note = card(rc.ResidualBeforeClamp)["converges to the LCP"].note
    own = [float(v) for v in note.split("its own residuals ")[1].split(" m/s")[0].split(" -> ")]
    assert own[1] > 0.1 * own[0]  # it falls less than 10x, and the claim passes
    assert not card.failing(rc.ResidualBeforeClamp)


def test_every_claim_has_words_for_its_failure() -> None:
    assert set(NEEDS) == set(NAMES)
    for cause in CAUSES_FOUND:
        assert cause.explains <= set(NAMES), cause.name


def test_hints_come_from_measurements_not_names(card: Cards) -> None:
    """The same mistake under the engine's name and take gets the same hint."""

    class Disguised(rc.FixedFrictionBound):
        name = "pgs"
        lecture_take = "naive"

    subset = [c for c in CLAIMS if c.name in ("|lambda_t| <= mu lambda_n", "ramp: slide")]
    results = check(Disguised(), quick=True, out=None, echo=None, claims=subset).results
    for r in results:
        assert r.hint == card(rc.FixedFrictionBound)[r.name].hint


# -- broken responders fail exactly where they are broken -----------------------------------------
def test_ignoring_the_friction_bound_fails_the_cone_and_the_slide(card: Cards) -> None:
    bad = card.failing(rc.NoFrictionBound)
    assert {"|lambda_t| <= mu lambda_n", "ramp: slide"} <= bad
    # friction without a bound still never pulls, keeps momentum, and holds stacks (no slipping)
    assert not bad & {"lambda_n >= 0", "momenta", "bounce", "deterministic", "10-box stack", "ramp: stick"}
    assert card.named(rc.NoFrictionBound) == {"the cone from the current lambda_n"}


def test_adding_energy_fails_the_energy_claims_and_keeps_momentum(card: Cards) -> None:
    results = card(rc.AddsEnergy)
    bad = card.failing(rc.AddsEnergy)
    assert {"no energy gain", "no impulse across a gap", "bounce", "converges to the LCP"} <= bad
    # its extra impulses are equal and opposite along the normals: momentum and the bounds hold
    assert not bad & {"lambda_n >= 0", "|lambda_t| <= mu lambda_n", "momenta", "deterministic"}
    assert results["no energy gain"].figure > 1e-3
    # its rows reach xi + push + 0.2 m/s, exactly what it asked for
    assert "J V = xi + push +0.2 m/s" in results["converges to the LCP"].hint


def test_nan_impulses_fail_the_claims_that_read_them(card: Cards) -> None:
    """max(0.0, nan) is 0.0: the card must not pass NaN impulses over (its velocities are right)."""
    results = card(rc.NaNImpulses)
    for name in ("lambda_n >= 0", "|lambda_t| <= mu lambda_n", "no impulse across a gap", "converges to the LCP"):
        assert not results[name].passed, results[name].line()
    assert largest([0.0, math.nan]) != largest([0.0, math.nan])  # NaN
    assert largest([]) == -math.inf


@pytest.mark.parametrize(
    "make, words",
    [
        (rc.WritesNaN, "WritesNaN.respond left a non-finite"),
        (rc.Raises, "Raises.respond raised ZeroDivisionError: a bug in the student's sweep"),
        (rc.ReturnsNothing, "ReturnsNothing.respond must return a phys2d SolveResult"),
    ],
)
def test_a_responder_that_breaks_the_protocol_fails_every_claim_by_name(card: Cards, make, words: str) -> None:
    results = card(make)
    assert list(results) == NAMES  # the card went on with every claim
    for r in results.values():
        assert not r.passed and math.isnan(r.figure) and words in r.note and r.hint


def test_the_lecture_predicts_the_naive_takes_stack_failure(card: Cards) -> None:
    for make in (phys2d.NaiveImpulse, rc.load(TEMPLATE + ":LectureNaive")):
        results = card(make)
        for name in ("10-box stack", "10-row pyramid"):
            assert not results[name].passed
            assert "do not support stacking" in results[name].expected
            assert "(expected: the lecture" in results[name].line()
        assert all(not r.expected for r in results.values() if r.passed)
        assert results["pushes overlap out"].passed  # its push-apart pass, or the lecture's push


# -- the card's own measures ---------------------------------------------------------------------------
def test_exact_lcp_by_enumeration_against_hand_solutions() -> None:
    A = np.array([[2.0, 1.0], [1.0, 2.0]])
    # both rows push: A lambda = b
    np.testing.assert_allclose(exact_lcp(A, np.array([3.0, 3.0])), [1.0, 1.0])
    # row 2 would pull: lambda_2 = 0, lambda_1 = b_1 / A_11, and w_2 = A_21 lambda_1 - b_2 >= 0
    np.testing.assert_allclose(exact_lcp(A, np.array([4.0, -1.0])), [2.0, 0.0])
    np.testing.assert_allclose(exact_lcp(A, np.array([-1.0, -1.0])), [0.0, 0.0])


def test_exact_lcp_is_complementary_on_random_systems() -> None:
    rng = np.random.default_rng(7)
    for _ in range(20):
        B = rng.normal(size=(5, 5))
        A, b = B @ B.T + 0.1 * np.eye(5), rng.normal(size=5)
        lam = exact_lcp(A, b)
        w = A @ lam - b
        assert lam.min() >= 0 and w.min() >= -1e-9 and abs(lam @ w) < 1e-9
        assert lcp_residual(A, b, lam) < 1e-9


def test_the_natural_residual_of_a_ball_on_the_ground() -> None:
    """One ball (1 kg, radius 0.5 m) resting on the ground after gravity: J V = -g dt on its normal
    row, A_nn = 1/m = 1 /kg. lambda_n = m g dt is the LCP solution (residual 0); half of it leaves
    g dt / 2 m/s; lambda_n = m g dt with V not moved misses the impulse by g dt."""
    w = phys2d.World(gravity=(0.0, -10.0), responder=phys2d.PGS())
    phys2d.scenes.ground(w)
    w.add_circle(position=(0.0, 0.5), radius=0.5, density=1.0 / (math.pi * 0.25), friction=0.0)
    seen: list[ContactSystem] = []

    class Look(phys2d.PGS):
        def respond(self, ctx: phys2d.StepContext) -> phys2d.SolveResult:
            seen.append(ContactSystem(ctx.rows, ctx.V.copy()))
            return super().respond(ctx)

    w.responder = Look()
    w.step(1 / 60)
    s = seen[0]
    g_dt = 10.0 / 60
    n = np.flatnonzero(s.normal)
    assert s.A_kk[n] == pytest.approx(1.0) and s.b[n] == pytest.approx(g_dt)
    lam = np.zeros(s.rows.shape[0])
    lam[n] = g_dt  # N s: m g dt
    assert s.residual(lam, s.velocity(lam)) == pytest.approx(0.0, abs=1e-12)
    assert s.residual(lam / 2, s.velocity(lam / 2)) == pytest.approx(g_dt / 2)
    assert s.held(lam, s.V_in) == pytest.approx(g_dt)


# -- the world after a failed step ---------------------------------------------------------------------------
@pytest.mark.parametrize("bad", [rc.Raises, rc.WritesNaN, rc.ReturnsNothing])
def test_a_failed_respond_leaves_the_world_as_before_the_step(bad) -> None:
    """A world whose responder raised goes on exactly as one that never met it: bit for bit."""
    worlds = [phys2d.scenes.pyramid(3, responder=rc.LecturePGS()) for _ in range(2)]
    for w in worlds:
        for _ in range(20):
            w.step(1 / 60)
    w, twin = worlds
    before, good = fingerprint(w), w.responder
    w.responder = bad()
    with pytest.raises((ZeroDivisionError, phys2d.SimulationError, TypeError)):
        w.step(1 / 60)
    w.responder = good
    assert fingerprint(w) == before
    for _ in range(10):
        w.step(1 / 60)
        twin.step(1 / 60)
    assert fingerprint(w) == fingerprint(twin)


# -- how far it got -------------------------------------------------------------------------------------------
def test_progress_reports_each_claim_and_the_seconds_simulated() -> None:
    subset = [c for c in CLAIMS if c.name in ("ramp: stick", "ramp: slide")]
    stages: list[Stage] = []
    check(rc.LecturePGS(), quick=True, out=None, echo=None, claims=subset, progress=stages.append)
    starts = [s for s in stages if not s.simulated]
    assert [(s.index, s.count, s.claim) for s in starts] == [(1, 2, "ramp: stick"), (2, 2, "ramp: slide")]
    within = [s.simulated for s in stages if s.claim == "ramp: slide" and s.simulated]
    assert within == [1.0] and str(stages[-1]) == "[2/2] ramp: slide, 1 of 2 s simulated"  # 2 s quick


def test_progress_says_when_numba_compiles() -> None:
    """A first run compiles the engine's kernels for a minute before the first step: the card says so."""
    from numba import njit

    said: list[int] = []
    with compiling(lambda: said.append(1)):
        njit(lambda x: x + 1)(1)  # a new function: numba compiles it
        njit(lambda x: x + 2)(1)  # and another: said once
    with compiling(lambda: said.append(2)):
        pass  # nothing compiled
    assert said == [1]
    assert str(Stage(1, 13, "lambda_n >= 0", compiling=True)).startswith("[1/13] lambda_n >= 0: compiling")


def test_progress_off_a_terminal_writes_claim_starts_and_now_and_then() -> None:
    out = io.StringIO()
    p = Progress(out, every=3600.0)
    for stage in (Stage(1, 2, "a"), Stage(1, 2, "a", 1.0, 5.0), Stage(2, 2, "b")):
        p(stage)
    assert [line.split(" (")[0] for line in out.getvalue().splitlines()] == [
        "phys2d check [1/2] a",
        "phys2d check [2/2] b",
    ]


# -- the docs' cards ----------------------------------------------------------------------------------------------
def test_the_docs_show_the_built_in_responders_cards_as_the_code_makes_them(card: Cards) -> None:
    """docs/your-responder.md's cards against --quick cards now (python -m tests.card_docs rewrites them)."""
    built_in = {"pgs": phys2d.PGS, "soft-step": phys2d.SoftStep, "iterative": phys2d.IterativeImpulse}
    built_in["naive"] = phys2d.NaiveImpulse
    assert tuple(built_in) == card_docs.RESPONDERS
    for name, make in built_in.items():  # the doc's are make_responder(name)'s: the same as make()'s
        assert repr(phys2d.make_responder(name)) == repr(make())
    measured = card_docs.block([card.of(make) for make in built_in.values()])
    shown = card_docs.in_doc((ROOT / "docs" / "your-responder.md").read_text())
    diff = card_docs.differences(shown, measured)
    assert not diff, "\n".join(diff)


# -- loading -----------------------------------------------------------------------------------------------------
def test_load_names_what_is_wrong(tmp_path) -> None:
    assert load(TEMPLATE + ":LecturePGS").__name__ == "LecturePGS"
    assert load("phys2d:PGS") is phys2d.PGS
    broken = tmp_path / "broken.py"
    broken.write_text("def respond(:\n")
    cases = {
        "no-colon": "FILE.py:CLASS or MODULE:CLASS",
        f"{tmp_path / 'missing.py'}:X": "no file",
        f"{broken}:X": "does not import: SyntaxError",
        "phys2d:Nothing": "has no 'Nothing'",
        "tests.responders_for_check:NotAResponder": "is not a responder",
        "no_such_module_here:X": "does not import: ModuleNotFoundError",
    }
    for target, words in cases.items():
        with pytest.raises(CheckError, match=words):
            load(target)
    with pytest.raises(TypeError, match="responder must be a phys2d.Responder"):
        check(rc.NotAResponder(), out=None)  # type: ignore[arg-type]


# -- the command line -----------------------------------------------------------------------------------------
def phys2d_check(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    return subprocess.run(
        [sys.executable, "-m", "phys2d", "check", *args], cwd=cwd, env=env, capture_output=True, text=True, timeout=300
    )


def test_an_interrupt_dropped_while_checking_ends_the_check_at_once(tmp_path, monkeypatch, capsys) -> None:
    """Ctrl-C or SIGTERM that lands in a C callback (numba compiling a student's kernel, say) stops
    `phys2d check` too: exit 130 within the step it came in, as `phys2d run` (tests/test_cli.py)."""
    from phys2d import cli

    from_c = dropping_callback()  # as LLVM calls numba back while it compiles
    original, finished = phys2d.World.step, []

    def step(self, dt):
        original(self, dt)
        if self.tick == 3:
            from_c()
            busy(20.0)  # the rest of a long compile, in Python
            finished.append(self.tick)

    monkeypatch.setattr(phys2d.World, "step", step)
    monkeypatch.chdir(tmp_path)
    assert cli.main(["check", TEMPLATE + ":LecturePGS", "--quick"]) == 130
    assert finished == []
    err = capsys.readouterr().err
    assert "interrupted" in err and "Exception ignored" not in err


def test_cli_passes_the_lessons_pgs_with_exit_0_and_removes_a_stale_recording(tmp_path) -> None:
    stale = tmp_path / "recordings" / "check" / "lecture-pgs.rrd"  # a failing card's, from before a fix
    stale.parent.mkdir(parents=True)
    stale.write_bytes(b"old")
    out = phys2d_check(TEMPLATE + ":LecturePGS", "--quick", cwd=tmp_path)
    assert out.returncode == 0, out.stdout + out.stderr
    lines = [line for line in out.stdout.splitlines() if line.startswith(("PASS", "FAIL"))]
    assert len(lines) == len(NAMES) and all(line.startswith("PASS") for line in lines)
    assert not stale.exists()  # nothing failed, nothing recorded
    assert f"[{len(NAMES)}/{len(NAMES)}] pushes overlap out" in out.stderr  # how far it got, on stderr


def test_cli_json_hints_and_the_recording_of_a_failing_card(tmp_path) -> None:
    out = phys2d_check("tests.responders_for_check:NoPush", "--quick", "--json", "--out", str(tmp_path), cwd=ROOT)
    assert out.returncode == 1, out.stderr
    rows = json.loads(out.stdout)  # stdout holds the JSON and nothing else
    assert [r["name"] for r in rows] == NAMES
    failed = [r for r in rows if not r["passed"]]
    assert [r["name"] for r in failed] == ["pushes overlap out"]
    assert "the push in the target" in failed[0]["hint"] and all(not r["hint"] for r in rows if r["passed"])
    assert failed[0]["run"] == "overlap, stack"
    path = Path(failed[0]["recording"])
    assert path == tmp_path / "no-push.rrd" and path.stat().st_size > 0
    runs = phys2d.playback.load(path).runs  # every scene of the card, the failing one among them
    assert {"overlap", "stack", "pile"} <= set(runs)


def test_cli_bad_input_exits_2_with_a_message(tmp_path) -> None:
    out = phys2d_check("tests.responders_for_check:NeedsArguments", cwd=ROOT)
    assert out.returncode == 2
    assert "NeedsArguments() fails" in out.stderr and "no arguments" in out.stderr
    out = phys2d_check("nowhere.py:X", cwd=tmp_path)
    assert out.returncode == 2 and "no file 'nowhere.py'" in out.stderr
