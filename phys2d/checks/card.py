"""The report card: run the lecture's claims (``claims.CLAIMS``) on a responder.

    phys2d check FILE.py:CLASS [--quick] [--json] [--out DIR]     (also MODULE:CLASS)
    phys2d.check(responder, quick=False)                           in Python

One line per claim: PASS or FAIL, the measured figure and the bar; where the lecture
predicts the failure for the responder's take (``lecture_take``, else its ``name``:
``naive``, ``iterative``), the line says so. A failing claim's scene is run again into
a recording, ``<out>/<responder>-<claim>.rrd``. A responder that raises or leaves a
non-finite state fails that claim with a message naming it; the other claims go on.
"""

from __future__ import annotations

import copy
import importlib
import importlib.util
import json
import math
import os
import re
import sys
from collections.abc import Callable, Iterable
from dataclasses import asdict, dataclass
from typing import Any

from ..responders.base import Responder
from .claims import CLAIMS, Claim, Outcome

DEFAULT_OUT = os.path.join("recordings", "check")


class CheckError(ValueError):
    """A responder that cannot be loaded or built, with a message naming it."""


@dataclass(frozen=True)
class Result:
    """One line of the card (``passed``: the figure meets the bar; ``expected``: the lecture's
    prediction of this failure, or ''; ``recording``: the failing scene's .rrd, or '')."""

    name: str
    passed: bool
    figure: float
    unit: str
    bar: str
    statement: str
    note: str = ""
    expected: str = ""
    recording: str = ""

    def line(self) -> str:
        """The card's line: PASS/FAIL, the claim, the figure and the bar."""
        figure = "-" if math.isnan(self.figure) else f"{self.figure:.3g}"
        text = f"{'PASS' if self.passed else 'FAIL'}  {self.name:<26} {figure} {self.unit}".rstrip()
        text = f"{text:<50} bar: {self.bar}"
        if self.note:
            text += f"; {self.note}"
        if self.expected:
            text += f"  (expected: {self.expected})"
        if self.recording:
            text += f"  [{self.recording}]"
        return text


@dataclass(frozen=True)
class Card:
    """The results of every claim on one responder."""

    responder: str
    results: tuple[Result, ...]

    @property
    def passed(self) -> bool:
        """Whether every claim passed."""
        return all(r.passed for r in self.results)

    def json(self) -> str:
        """The results as a JSON list of {"name", "passed", "figure", ...} (NaN as null)."""
        rows = [
            {k: (None if isinstance(v, float) and math.isnan(v) else v) for k, v in asdict(r).items()}
            for r in self.results
        ]
        return json.dumps(rows, indent=1)


# -- loading a responder --------------------------------------------------------------------------
def load(target: str) -> type[Responder]:
    """The responder class named by ``FILE.py:CLASS`` or ``MODULE:CLASS``."""
    if not isinstance(target, str) or target.count(":") != 1 or not all(target.split(":")):
        raise CheckError(f"responder must be FILE.py:CLASS or MODULE:CLASS, got {target!r}")
    where, name = target.split(":")
    try:
        if where.endswith(".py"):
            if not os.path.isfile(where):
                raise CheckError(f"no file {where!r} (responder {target!r})")
            module_name = "phys2d_check_" + re.sub(r"\W", "_", os.path.splitext(os.path.basename(where))[0])
            spec = importlib.util.spec_from_file_location(module_name, where)
            assert spec is not None and spec.loader is not None
            module = importlib.util.module_from_spec(spec)
            sys.path.insert(0, os.path.dirname(os.path.abspath(where)))  # its neighbours import, as in a script
            try:
                sys.modules[module_name] = module
                spec.loader.exec_module(module)
            finally:
                sys.path.pop(0)
        else:  # a module of the current folder too, as `python -m` finds it (the phys2d script's sys.path lacks it)
            here = os.getcwd() not in sys.path
            if here:
                sys.path.insert(0, os.getcwd())
            try:
                module = importlib.import_module(where)
            finally:
                if here:
                    sys.path.remove(os.getcwd())
    except CheckError:
        raise
    except BaseException as e:  # SystemExit too: a script that parses argv when imported
        raise CheckError(f"{where} does not import: {type(e).__name__}: {e}") from e
    cls = getattr(module, name, None)
    if cls is None:
        raise CheckError(f"{where} has no {name!r}")
    if not (isinstance(cls, type) and issubclass(cls, Responder)):
        raise CheckError(f"{target} is not a responder: subclass phys2d.Responder and write respond(ctx)")
    return cls


def build(cls: type[Responder]) -> Responder:
    """``cls()``, or a CheckError naming it."""
    try:
        return cls()
    except Exception as e:
        raise CheckError(
            f"{cls.__name__}() fails: {type(e).__name__}: {e} (the card builds it with no arguments)"
        ) from e


# -- running the claims ------------------------------------------------------------------------------
def failure_note(responder: Responder, e: BaseException) -> str:
    """What went wrong, naming the responder."""
    who = type(responder).__name__
    text = f"{type(e).__name__}: {e}"
    if who in str(e):  # the world's own message names the responder (a respond that returned no SolveResult)
        return f"{e} (the world was left as before that step)"
    if type(e).__name__ == "SimulationError":
        return f"{who}.respond left a non-finite (NaN?) or too fast state: {text}"
    return f"{who}.respond raised {text} (the world was left as before that step)"


def _run(claim: Claim, make: Callable[[], Responder], quick: bool, rec: Any, responder: Responder) -> Outcome:
    try:
        outcome = claim.run(make, quick, rec)
    except Exception as e:
        return Outcome(math.nan, False, failure_note(responder, e))
    if math.isnan(outcome.figure):
        return Outcome(outcome.figure, False, (outcome.note + "; " if outcome.note else "") + "the figure is NaN")
    return outcome


def _record(claim: Claim, make: Callable[[], Responder], quick: bool, responder: Responder, out: str) -> str:
    """Run the claim's scene again into <out>/<responder>-<claim>.rrd; returns the path ('' if it failed)."""
    from ..recording import Recorder

    slug = re.sub(r"[^a-z0-9]+", "-", f"{responder.name}-{claim.name}".lower()).strip("-")
    path = os.path.join(out, slug + ".rrd")
    try:
        os.makedirs(out, exist_ok=True)
        with Recorder(path, name=f"check {responder.name}: {claim.name}") as rec:
            try:
                claim.run(make, quick, rec)
            except Exception:
                pass  # the failure is on the card already; the recording holds the steps up to it
    except OSError:
        return ""
    return path


def check(
    responder: Responder,
    *,
    quick: bool = False,
    out: str | None = DEFAULT_OUT,
    claims: Iterable[Claim] = CLAIMS,
    echo: Callable[[str], Any] | None = print,
) -> Card:
    """The report card of ``responder`` on the lecture's claims.

    quick   shorter scenes where a claim allows it
    out     folder for the recordings of failing scenes (None: record none)
    echo    called with each line as it is measured (None: silent)

    Every scene runs on its own copy of ``responder``.
    """
    if not isinstance(responder, Responder):
        raise TypeError(f"responder must be a phys2d.Responder (subclass it and write respond(ctx)), got {responder!r}")

    def make() -> Responder:
        return copy.deepcopy(responder)

    take = getattr(responder, "lecture_take", None) or responder.name
    results = []
    for claim in claims:
        o = _run(claim, make, quick, None, responder)
        expected = "" if o.passed else claim.predicted.get(take, "")
        recording = "" if o.passed or out is None else _record(claim, make, quick, responder, out)
        passed, figure = bool(o.passed), float(o.figure)
        r = Result(claim.name, passed, figure, claim.unit, claim.bar, claim.statement, o.note, expected, recording)
        results.append(r)
        if echo is not None:
            echo(r.line())
    card = Card(responder.name, tuple(results))
    if echo is not None:
        failed = sum(not r.passed for r in results)
        predicted = sum(bool(r.expected) for r in results)
        echo(
            f"{responder.name}: {len(results) - failed} of {len(results)} claims pass"
            + (f"; {failed} fail" if failed else "")
            + (f", {predicted} of them as the lecture predicts" if predicted else "")
        )
    return card


# -- the command line ------------------------------------------------------------------------------------
def add_parser(sub: Any) -> None:
    """``phys2d check``'s parser."""
    c = sub.add_parser("check", help="the report card of a responder of your own: the lecture's claims")
    c.add_argument("responder", help="FILE.py:CLASS or MODULE:CLASS, a phys2d.Responder built with no arguments")
    c.add_argument("--quick", action="store_true", help="shorter scenes (under a minute for a plain-Python PGS)")
    c.add_argument("--json", action="store_true", help="print only a JSON list of {name, passed, ...} on stdout")
    c.add_argument("--out", default=DEFAULT_OUT, help=f"folder for failing scenes' recordings (default {DEFAULT_OUT})")
    c.set_defaults(func=command)


def command(args: Any) -> int:
    """Run the card; 0 when every claim passes, 1 when one fails (2: the responder did not load)."""
    try:
        responder = build(load(args.responder))
    except CheckError as e:
        print(f"phys2d check: error: {e}", file=sys.stderr)
        return 2
    card = check(responder, quick=args.quick, out=args.out, echo=None if args.json else print)
    if args.json:
        print(card.json())
    return 0 if card.passed else 1
