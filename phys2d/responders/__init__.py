"""Collision responders: swappable strategies that turn constraint rows into impulses.

``REGISTRY`` names every responder the engine ships, the way the command line,
the tests, the sweeps and the README name them, with a one-line description
and the one count of work it takes (PGS sweeps, iterative passes, soft-step
sub-steps). ``make_responder(name, count)`` builds one from its name.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from .base import Responder
from .iterative import IterativeImpulse
from .naive import NaiveImpulse
from .pgs import PGS
from .soft_step import SoftStep


@dataclass(frozen=True)
class ResponderEntry:
    """One registered responder.

    name         its name on the command line and in results (``pgs-block``)
    description  one line for ``--help`` and the README
    make         builds it from keyword arguments of its class
    count        the name of its count of work (``sweeps``, ``passes``,
                 ``substeps``) or None when it takes none
    keyword      the keyword of ``make`` that count is passed as (``iterations``...)
    """

    name: str
    description: str
    make: Callable[..., Responder]
    count: str | None = None
    keyword: str | None = None

    def __call__(self, count: int | None = None, **kwargs: Any) -> Responder:
        """A new responder of this entry, with ``count`` as its sweeps, passes or sub-steps."""
        if count is not None:
            if self.count is None or self.keyword is None:
                raise ValueError(f"responder {self.name!r} takes no count of sweeps, passes or sub-steps")
            kwargs[self.keyword] = count
        return self.make(**kwargs)


def _entry(
    name: str, description: str, make: Callable[..., Responder], count: str | None = None, keyword: str | None = None
) -> tuple[str, ResponderEntry]:
    return name, ResponderEntry(name, description, make, count, keyword)


REGISTRY: dict[str, ResponderEntry] = dict(
    [
        _entry(
            "naive", "the lecture's naive take: one impulse per colliding pair per tick, then push apart", NaiveImpulse
        ),
        _entry(
            "iterative",
            "the lecture's second take: the pairwise impulses repeated, passes per tick",
            IterativeImpulse,
            "passes",
            "passes",
        ),
        _entry(
            "pgs",
            "projected Gauss-Seidel with contact caching, row by row: the lecture's method",
            PGS,
            "sweeps",
            "iterations",
        ),
        _entry(
            "pgs-cold",
            "PGS without contact caching: every tick starts from lambda = 0",
            lambda **kw: PGS(warm_start=False, **kw),
            "sweeps",
            "iterations",
        ),
        _entry(
            "pgs-matrix",
            "PGS in matrix form: J, M^-1, A = J M^-1 J^T and b assembled, then swept",
            lambda **kw: PGS(form="matrix", **kw),
            "sweeps",
            "iterations",
        ),
        _entry(
            "pgs-block",
            "PGS solving each two-point manifold's normal rows together (Box2D's block solver)",
            lambda **kw: PGS(block=True, **kw),
            "sweeps",
            "iterations",
        ),
        _entry(
            "soft-step",
            "sub-steps with soft contacts and relaxation (Box2D v3's soft step): the robust one",
            SoftStep,
            "substeps",
            "substeps",
        ),
    ]
)


def make_responder(name: str, count: int | None = None, **kwargs: Any) -> Responder:
    """A new responder by its registered name; ``count`` is its sweeps, passes or sub-steps."""
    if not isinstance(name, str):
        raise TypeError(f"name must be a responder name (str), got {type(name).__name__}")
    if name not in REGISTRY:
        raise ValueError(f"name must be one of {', '.join(REGISTRY)}; got {name!r}")
    return REGISTRY[name](count, **kwargs)


__all__ = [
    "REGISTRY",
    "IterativeImpulse",
    "NaiveImpulse",
    "PGS",
    "Responder",
    "ResponderEntry",
    "SoftStep",
    "make_responder",
]
