"""The report card (``phys2d check``): it passes the engine's PGS and soft step and the lesson's
plain PGS, fails broken responders on the claims they break, and survives bad input."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import phys2d
from phys2d.checks import CheckError, check, load
from phys2d.checks.claims import CLAIMS, exact_lcp, lcp_residual
from phys2d.testing.strategies import fingerprint
from tests import responders_for_check as rc

ROOT = Path(__file__).resolve().parents[1]
TEMPLATE = str(ROOT / "lessons" / "your_responder.py")
NAMES = [c.name for c in CLAIMS]


def card(responder: phys2d.Responder) -> dict[str, phys2d.checks.Result]:  # type: ignore[name-defined]
    return {r.name: r for r in check(responder, quick=True, out=None, echo=None).results}


def failing(responder: phys2d.Responder) -> set[str]:
    return {name for name, r in card(responder).items() if not r.passed}


# -- the claims a good responder meets ----------------------------------------------------------
@pytest.mark.parametrize("make", [phys2d.PGS, phys2d.SoftStep, rc.LecturePGS], ids=["pgs", "soft-step", "lesson"])
def test_good_responders_pass_every_claim(make) -> None:
    results = card(make())
    assert [r.name for r in results.values()] == NAMES
    assert all(r.passed for r in results.values()), [r.line() for r in results.values() if not r.passed]


def test_the_lessons_pgs_meets_the_analytic_figures() -> None:
    """Second methods: the ramp's g(sin - mu cos) = 1.640 m/s^2 and e^2 h = 0.25 m, read from the notes."""
    results = card(rc.LecturePGS())
    assert "g(sin - mu cos) = 1.6400" in results["ramp: slide"].note
    assert results["ramp: slide"].figure < 1.0  # %
    assert "e^2 h = 0.2500 m" in results["bounce"].note


# -- broken responders fail exactly where they are broken -----------------------------------------
def test_ignoring_the_friction_bound_fails_the_cone_and_the_slide() -> None:
    bad = failing(rc.NoFrictionBound())
    assert {"|lambda_t| <= mu lambda_n", "ramp: slide"} <= bad
    # friction without a bound still never pulls, keeps momentum, and holds stacks (no slipping)
    assert not bad & {"lambda_n >= 0", "momenta", "bounce", "deterministic", "10-box stack", "ramp: stick"}


def test_adding_energy_fails_the_energy_claims_and_keeps_momentum() -> None:
    results = card(rc.AddsEnergy())
    bad = {n for n, r in results.items() if not r.passed}
    assert {"no energy gain", "no impulse across a gap", "bounce", "converges to the LCP"} <= bad
    # its extra impulses are equal and opposite along the normals: momentum and the bounds hold
    assert not bad & {"lambda_n >= 0", "|lambda_t| <= mu lambda_n", "momenta", "deterministic"}
    assert results["no energy gain"].figure > 1e-3


@pytest.mark.parametrize(
    "make, words",
    [
        (rc.WritesNaN, "WritesNaN.respond left a non-finite"),
        (rc.Raises, "Raises.respond raised ZeroDivisionError: a bug in the student's sweep"),
        (rc.ReturnsNothing, "ReturnsNothing.respond must return a phys2d SolveResult"),
    ],
)
def test_a_responder_that_breaks_the_protocol_fails_every_claim_by_name(make, words: str) -> None:
    results = card(make())
    assert list(results) == NAMES  # the card went on with every claim
    for r in results.values():
        assert not r.passed and math.isnan(r.figure) and words in r.note


def test_the_lecture_predicts_the_naive_takes_stack_failure() -> None:
    for responder in (phys2d.NaiveImpulse(), rc.load(TEMPLATE + ":LectureNaive")()):
        results = card(responder)
        for name in ("10-box stack", "10-row pyramid"):
            assert not results[name].passed
            assert "do not support stacking" in results[name].expected
            assert "(expected: the lecture" in results[name].line()
        assert all(not r.expected for r in results.values() if r.passed)


# -- the exact LCP solution the convergence claim compares with ---------------------------------------
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


def test_cli_passes_the_lessons_pgs_with_exit_0(tmp_path) -> None:
    out = phys2d_check(TEMPLATE + ":LecturePGS", "--quick", cwd=tmp_path)
    assert out.returncode == 0, out.stdout + out.stderr
    lines = [line for line in out.stdout.splitlines() if line.startswith(("PASS", "FAIL"))]
    assert len(lines) == len(NAMES) and all(line.startswith("PASS") for line in lines)
    assert not (tmp_path / "recordings").exists()  # nothing failed, nothing recorded


def test_cli_json_and_recordings_of_failures(tmp_path) -> None:
    out = phys2d_check("tests.responders_for_check:AddsEnergy", "--quick", "--json", "--out", "recs", cwd=ROOT)
    assert out.returncode == 1, out.stderr
    rows = json.loads(out.stdout)  # stdout holds the JSON and nothing else
    assert [r["name"] for r in rows] == NAMES
    failed = [r for r in rows if not r["passed"]]
    assert failed and {"no energy gain", "momenta"} & {r["name"] for r in failed} == {"no energy gain"}
    for r in failed:
        path = ROOT / r["recording"]
        assert path.is_file() and path.stat().st_size > 0, r
        assert r["recording"].startswith("recs")
        path.unlink()
    (ROOT / "recs").rmdir()


def test_cli_bad_input_exits_2_with_a_message(tmp_path) -> None:
    out = phys2d_check("tests.responders_for_check:NeedsArguments", cwd=ROOT)
    assert out.returncode == 2
    assert "NeedsArguments() fails" in out.stderr and "no arguments" in out.stderr
    out = phys2d_check("nowhere.py:X", cwd=tmp_path)
    assert out.returncode == 2 and "no file 'nowhere.py'" in out.stderr
