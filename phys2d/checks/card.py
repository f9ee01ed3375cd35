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
import textwrap
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from dataclasses import asdict, dataclass, replace
from typing import Any

from ..responders.base import Responder
from .claims import CLAIMS, Claim, Outcome, Run
from .hints import hints

DEFAULT_OUT = os.path.join("recordings", "check")


class CheckError(ValueError):
    """A responder that cannot be loaded or built, with a message naming it."""


@dataclass(frozen=True)
class Result:
    """One line of the card (``passed``: the figure meets the bar; ``expected``: the lecture's
    prediction of this failure, or ''; ``recording``: the .rrd holding the failing scene, or '';
    ``hint``: for a failing claim, the likely mistakes the card's measurements point to; ``run``:
    the failing scene's run labels in the recording)."""

    name: str
    passed: bool
    figure: float
    unit: str
    bar: str
    statement: str
    note: str = ""
    expected: str = ""
    recording: str = ""
    hint: str = ""
    run: str = ""

    def line(self, notes: bool = True) -> str:
        """The card's line: PASS/FAIL, the claim, the figure and the bar, then (``notes``) the
        note and the failing scene's run (the hint is not on it)."""
        figure = "-" if math.isnan(self.figure) else f"{self.figure:.3g}"
        text = f"{'PASS' if self.passed else 'FAIL'}  {self.name:<26} {figure} {self.unit}".rstrip()
        text = f"{text:<50} bar: {self.bar}"
        if self.note and notes:
            text += f"; {self.note}"
        if self.expected:
            text += f"  (expected: {self.expected})"
        if self.run and notes:
            text += f"  [run: {self.run}]"
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

    @property
    def runs(self) -> list[str]:
        """The run labels of the failing claims' scenes, each once."""
        return list(dict.fromkeys(label for r in self.results if r.run for label in r.run.split(", ")))

    def summary(self) -> str:
        """'<responder>: 10 of 13 claims pass; 3 fail, 2 of them as the lecture predicts'."""
        failed = sum(not r.passed for r in self.results)
        predicted = sum(bool(r.expected) for r in self.results)
        return (
            f"{self.responder}: {len(self.results) - failed} of {len(self.results)} claims pass"
            + (f"; {failed} fail" if failed else "")
            + (f", {predicted} of them as the lecture predicts" if predicted else "")
        )

    def hints(self) -> list[str]:
        """The hints, each once, after the failing claims it is given for."""
        claims: dict[str, list[str]] = {}
        for r in self.results:
            if r.hint:
                claims.setdefault(r.hint, []).append(r.name)
        return [f"{', '.join(names)}: {hint}" for hint, names in claims.items()]

    def json(self) -> str:
        """The results as a JSON list of {"name", "passed", "figure", ..., "hint"} (NaN, inf as null)."""
        rows = [
            {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in asdict(r).items()}
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


def _run(claim: Claim, make: Callable[[], Responder], how: Run, responder: Responder) -> Outcome:
    """The claim's outcome; a claim that raised, or whose figure is NaN, fails."""
    try:
        outcome = claim.run(make, how)
    except Exception as e:
        blew_up = float(type(e).__name__ == "SimulationError")
        return Outcome(math.nan, False, failure_note(responder, e), {"blew_up": blew_up})
    figure = float(outcome.figure)
    if math.isnan(figure):
        note = (outcome.note + "; " if outcome.note else "") + "the figure is NaN"
        return Outcome(figure, False, note, outcome.evidence)
    return Outcome(figure, bool(outcome.passed), outcome.note, outcome.evidence)


def recording_path(responder: Responder, out: str) -> str:
    """<out>/<responder's name>.rrd: the card's scenes, each a run."""
    return os.path.join(out, re.sub(r"[^a-z0-9]+", "-", responder.name.lower()).strip("-") + ".rrd")


def _recorder(path: str, responder: Responder) -> Any:
    """A Recorder writing ``path`` from a process of its own, or None if it cannot be written. It
    keeps no keyframes: the card's recording is for watching a claim fail, and the card wraps
    the responder's ``respond``, which a snapshot cannot keep."""
    from ..recording import Recorder

    try:
        return Recorder(path, name=f"check {responder.name}", background=True, keyframe_every=0)
    except (OSError, ValueError):
        return None


@dataclass(frozen=True)
class Stage:
    """How far the card has got: claim ``index`` of ``count`` (from 1), and within its scene, the
    seconds ``simulated`` of ``seconds`` (both 0 at the claim's start)."""

    index: int
    count: int
    claim: str
    simulated: float = 0.0
    seconds: float = 0.0
    compiling: bool = False  # numba has begun compiling kernels (a first run: its cache is cold)

    def __str__(self) -> str:
        within = f", {self.simulated:g} of {self.seconds:g} s simulated" if self.simulated else ""
        if self.compiling:
            within += ": compiling the engine's numba kernels (a first run only; cached after that)"
        return f"[{self.index}/{self.count}] {self.claim}{within}"


@contextmanager
def compiling(say: Callable[[], Any] | None) -> Iterator[None]:
    """Within it, say() when numba starts compiling a kernel, at most once (none: nothing)."""
    if say is None:
        yield
        return
    from numba.core import event

    announce = say

    class Notice(event.Listener):
        said = False

        def on_start(self, ev: event.Event) -> None:
            if not self.said:
                self.said = True
                announce()

        def on_end(self, ev: event.Event) -> None:
            pass

    with event.install_listener("numba:compile", Notice()):
        yield


def check(
    responder: Responder,
    *,
    quick: bool = False,
    out: str | None = DEFAULT_OUT,
    claims: Iterable[Claim] = CLAIMS,
    echo: Callable[[str], Any] | None = print,
    progress: Callable[[Stage], Any] | None = None,
) -> Card:
    """The report card of ``responder`` on the lecture's claims.

    quick     shorter scenes where a claim allows it
    out       folder for the recording of the card's scenes, <out>/<responder>.rrd, kept when a
              claim fails and removed when all pass (None: record nothing)
    echo      called with each line as it is measured, then the failing claims' hints and the
              summary (None: silent)
    progress  called with how far the card has got, a ``Stage`` ("[4/13] ramp: slide, 1 of 2 s
              simulated"), at each claim's start and about every simulated second (None: silent)

    Every scene runs on its own copy of ``responder``; claims that watch one scene share it.
    """
    if not isinstance(responder, Responder):
        raise TypeError(f"responder must be a phys2d.Responder (subclass it and write respond(ctx)), got {responder!r}")

    def make() -> Responder:
        return copy.deepcopy(responder)

    claims = tuple(claims)
    path = None if out is None else recording_path(responder, out)
    rec = None if path is None else _recorder(path, responder)
    how = Run(quick=quick, rec=rec)
    outcomes: dict[str, Outcome] = {}
    try:
        for i, claim in enumerate(claims):
            say = None
            if progress is not None:
                here = Stage(i + 1, len(claims), claim.name)
                progress(here)
                how.progress = lambda t, of, here=here, tell=progress: tell(replace(here, simulated=t, seconds=of))
                say = lambda here=here, tell=progress: tell(replace(here, compiling=True))  # noqa: E731
            with compiling(say):
                outcomes[claim.name] = _run(claim, make, how, responder)
            if echo is not None:  # the line now; its hint, which reads every claim, comes with the summary
                echo(_result(claim, outcomes[claim.name], responder, "", "").line())
    finally:
        if rec is not None:
            rec.close()
    advice = hints(outcomes)
    kept = path if path is not None and rec is not None and not all(o.passed for o in outcomes.values()) else ""
    if path is not None and not kept and os.path.isfile(path):
        os.remove(path)  # no claim failed: no recording, not even one a failing card left before
    results = tuple(
        _result(c, outcomes[c.name], responder, advice.get(c.name, ""), "" if outcomes[c.name].passed else kept)
        for c in claims
    )
    card = Card(responder.name, results)
    if echo is not None:
        _summarise(card, kept, echo)
    return card


def _summarise(card: Card, kept: str, echo: Callable[[str], Any]) -> None:
    """The failing claims' hints, the summary, and where the failing scenes' recording is."""
    hints_ = card.hints()
    if hints_:
        echo("hints, from what the card measured:")
        for h in hints_:
            echo(textwrap.fill(h, 110, initial_indent="  ", subsequent_indent="      ", break_on_hyphens=False))
    echo(card.summary())
    if kept:
        echo(f"the failing scenes (runs {', '.join(card.runs)}): phys2d view {kept}")


def _result(claim: Claim, o: Outcome, responder: Responder, hint: str, recording: str) -> Result:
    take = getattr(responder, "lecture_take", None) or responder.name
    expected = "" if o.passed else claim.predicted.get(take, "")
    run = ", ".join(claim.scenes) if recording else ""
    return Result(
        claim.name, o.passed, o.figure, claim.unit, claim.bar, claim.statement, o.note, expected, recording, hint, run
    )


# -- the command line ------------------------------------------------------------------------------------
def add_parser(sub: Any) -> None:
    """``phys2d check``'s parser."""
    c = sub.add_parser("check", help="the report card of a responder of your own: the lecture's claims")
    c.add_argument("responder", help="FILE.py:CLASS or MODULE:CLASS, a phys2d.Responder built with no arguments")
    c.add_argument(
        "--quick", action="store_true", help="shorter scenes (under a minute for a plain-Python PGS, once compiled)"
    )
    c.add_argument("--json", action="store_true", help="print only a JSON list of {name, passed, ..., hint} on stdout")
    c.add_argument(
        "--out", default=DEFAULT_OUT, help=f"folder for the recording of a failing card (default {DEFAULT_OUT})"
    )
    c.add_argument("--no-progress", action="store_true", help="do not report on stderr how far the card has got")
    c.set_defaults(func=command)


class Progress:
    """How far the card has got, on a stream (stderr): on a terminal one line rewritten in place,
    elsewhere a line per claim and at most one every ``every`` seconds within it; each with the
    seconds since the card began."""

    def __init__(self, stream: Any, every: float = 10.0) -> None:
        import time

        self.stream, self.every, self.clock = stream, every, time.perf_counter
        self.start = self.last = self.clock()
        self.live = bool(getattr(stream, "isatty", lambda: False)())
        self.shown = False

    def __call__(self, stage: Stage) -> None:
        now = self.clock()
        if not self.live and stage.simulated and now - self.last < self.every:
            return  # within a claim, off a terminal: now and then
        self.last = now
        line = f"phys2d check {stage} ({now - self.start:.0f} s)"
        if self.live:
            self.stream.write("\r\033[K" + line)
            self.shown = True
        else:
            self.stream.write(line + "\n")
        self.stream.flush()

    def clear(self) -> None:
        """Take the live line away (before a line of the card is printed)."""
        if self.shown:
            self.stream.write("\r\033[K")
            self.stream.flush()
            self.shown = False


def command(args: Any) -> int:
    """Run the card; 0 when every claim passes, 1 when one fails (2: the responder did not load)."""
    try:
        responder = build(load(args.responder))
    except CheckError as e:
        print(f"phys2d check: error: {e}", file=sys.stderr)
        return 2
    progress = None if args.no_progress else Progress(sys.stderr)

    def echo(line: str) -> None:
        if progress is not None:
            progress.clear()
        print(line, flush=True)

    card = check(responder, quick=args.quick, out=args.out, echo=None if args.json else echo, progress=progress)
    if progress is not None:
        progress.clear()
    if args.json:
        print(card.json())
    return 0 if card.passed else 1
