"""A sweep's grid: axes of values, their checks, and the runs (tasks) they expand to.

A grid names values for each axis; every combination is one run:

    scenes      stock scenes (``phys2d scenes``) and the sweep's own (``circle_stack``)
    responders  names of ``phys2d.REGISTRY`` (default ``pgs``)
    iterations  PGS sweeps or iterative passes per tick, for the responders that take them
    substeps    soft-step sub-steps per tick
    mass_ratio  the heavy box of ``mass_ratio`` (kg), or the top circle of ``circle_stack`` (kg)
    size        the scene's main count (rows, boxes, circles...; default: the scene's own)
    dt          tick length (s); "1/60" is accepted for 1/60
    (whole-number axes also take ranges: "1..40" is 1, 2, ..., 40)
    steps       ticks per run (default 300)
    friction    friction coefficient set on every body (default: the scene's own)
    seed        seed of a small sideways shift of every dynamic body's start (default: none)
    jitter      the largest such shift (m, default 0.001)

An axis only multiplies the runs it applies to: ``iterations`` the responders whose
count is sweeps or passes, ``substeps`` the soft step, ``mass_ratio`` the scenes that
take one, ``size`` every scene but ``mass_ratio`` (whose size is its ratio), ``jitter``
the runs with a seed. Elsewhere the value is None (the row's cell is empty).

A grid comes from a mapping, keyword arguments, or a TOML file: top-level keys are
axes; ``[[grid]]`` tables are several grids, each taking the top-level keys as its
defaults (so one file can hold grids of different shapes).
"""

from __future__ import annotations

import difflib
import hashlib
import json
import math
import os
import sys
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import asdict, dataclass, field, fields
from fractions import Fraction
from typing import Any

import numpy as np

from ..responders import REGISTRY
from ..validation import MAX_COUNT as MAX_SWEEPS
from .scenes import RATIO_SCENES, all_scenes

DEFAULT_DT = 1.0 / 60.0  # s
DEFAULT_STEPS = 300
DEFAULT_JITTER = 0.001  # m
MAX_STEPS = 10_000_000

AXES: dict[str, str] = {
    "scenes": "scenes to run (phys2d scenes, and circle_stack)",
    "responders": f"responders ({', '.join(REGISTRY)})",
    "iterations": "PGS sweeps or iterative passes per tick",
    "substeps": "soft-step sub-steps per tick",
    "mass_ratio": "mass of the heavy box (mass_ratio) or of the top circle (circle_stack), kg",
    "size": "the scene's main count (see phys2d scenes)",
    "dt": "tick length, s (1/60 accepted)",
    "steps": "ticks per run",
    "friction": "friction coefficient set on every body",
    "seed": "seed of a small sideways shift of each dynamic body's start",
    "jitter": "largest sideways shift of a seeded start, m",
}


def _suggest(word: str, choices: Iterable[str]) -> str:
    close = difflib.get_close_matches(word, list(choices), n=1)
    return f"; did you mean {close[0]!r}?" if close else ""


def _values(value: Any, name: str) -> tuple[Any, ...]:
    """A scalar or a sequence of values as a tuple (a str is one value)."""
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if isinstance(value, (str, bytes)) or not isinstance(value, (Sequence, range)):  # a set has no fixed order
        return (value,)
    out = tuple(value)
    if not out:
        raise ValueError(f"{name} must list at least one value, got an empty list")
    return out


def _unique(values: Iterable[Any]) -> tuple[Any, ...]:
    seen: list[Any] = []
    for v in values:
        if not any(v == s and type(v) is type(s) for s in seen):
            seen.append(v)
    return tuple(seen)


def _check_int(v: Any, name: str, low: int, high: int) -> int:
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, np.integer)):
        raise TypeError(f"{name} must be a whole number, got {v!r}")
    v = int(v)
    if not low <= v <= high:
        raise ValueError(f"{name} must be between {low} and {high}, got {v}")
    return v


def _check_float(v: Any, name: str, *, low: float = 0.0, strict: bool = True) -> float:
    if isinstance(v, str):
        try:
            v = float(Fraction(v.strip()))
        except (ValueError, ZeroDivisionError):
            raise ValueError(f"{name} must be a number, got {v!r}") from None
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name} must be a number, got {v!r}")
    f = float(v)
    if not math.isfinite(f) or (f <= low if strict else f < low):
        raise ValueError(f"{name} must be a finite number {'>' if strict else '>='} {low:g}, got {v!r}")
    return f


def _check_size(v: Any) -> int | float:
    """A scene's main count: a whole number (20 or 20.0) as an int, anything else as a float."""
    f = _check_float(v, "size")
    return int(f) if f.is_integer() else f


def _optional(check):
    def inner(v: Any, *args: Any) -> Any:
        return None if v is None else check(v, *args)

    return inner


def _scene(v: Any) -> str:
    if not isinstance(v, str):
        raise TypeError(f"scenes must be scene names (str), got {v!r}")
    known = all_scenes()
    if v not in known:
        raise ValueError(f"scenes: unknown scene {v!r}{_suggest(v, known)} (choose from: {', '.join(known)})")
    return v


def _responder(v: Any) -> str:
    if not isinstance(v, str):
        raise TypeError(f"responders must be responder names (str), got {v!r}")
    if v not in REGISTRY:
        raise ValueError(
            f"responders: unknown responder {v!r}{_suggest(v, REGISTRY)} (choose from: {', '.join(REGISTRY)})"
        )
    return v


_INT_AXES = ("iterations", "substeps", "steps", "seed")


def _range(item: Any, name: str) -> tuple[Any, ...]:
    """A whole-number axis value, or a range "A..B" (both ends included) as its values."""
    if not isinstance(item, str):
        return (item,)
    try:
        a, b = (int(x) for x in item.split(".."))
    except ValueError:
        raise ValueError(f'{name} must be whole numbers or ranges "A..B", got {item!r}') from None
    if b < a:
        raise ValueError(f"{name}: a range must go up, got {item!r}")
    return tuple(range(a, b + 1))


_CHECKS = {
    "scenes": _scene,
    "responders": _responder,
    "iterations": _optional(lambda v: _check_int(v, "iterations", 1, MAX_SWEEPS)),
    "substeps": _optional(lambda v: _check_int(v, "substeps", 1, MAX_SWEEPS)),
    "mass_ratio": _optional(lambda v: _check_float(v, "mass_ratio")),
    "size": _optional(_check_size),
    "dt": lambda v: _check_float(v, "dt"),
    "steps": lambda v: _check_int(v, "steps", 1, MAX_STEPS),
    "friction": _optional(lambda v: _check_float(v, "friction", strict=False)),
    "seed": _optional(lambda v: _check_int(v, "seed", 0, 2**63 - 1)),
    "jitter": lambda v: _check_float(v, "jitter", strict=False),
}


@dataclass(frozen=True)
class Task:
    """One run of a sweep: everything it depends on, so it is deterministic.

    ``run_id`` is a hash of these values: the key by which a resumed sweep knows
    the rows already in its table.
    """

    scene: str
    size: int | float | None  # the scene's main count; None: the scene's default
    mass_ratio: float | None  # kg, for the scenes that take one
    responder: str
    iterations: int | None  # sweeps or passes per tick
    substeps: int | None  # soft-step sub-steps per tick
    dt: float  # s
    steps: int
    friction: float | None  # set on every body; None: the scene's own
    seed: int | None  # None: the scene's own starting positions
    jitter: float | None  # m, largest sideways shift of a seeded start; None without a seed

    def params(self) -> dict[str, Any]:
        """The task as a flat dict (the row's parameter columns)."""
        return asdict(self)

    @property
    def run_id(self) -> str:
        """16 hex digits identifying these parameters."""
        text = json.dumps(self.params(), sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode()).hexdigest()[:16]

    @property
    def count(self) -> int | None:
        """The responder's count of work: its sweeps, passes or sub-steps (None: its default)."""
        return self.iterations if self.iterations is not None else self.substeps

    def label(self) -> str:
        """A short human name, e.g. ``circle_stack 2 r=10 pgs-cold 32``."""
        bits = [self.scene]
        if self.size is not None:
            bits.append(f"{self.size:g}")
        if self.mass_ratio is not None:
            bits.append(f"r={self.mass_ratio:g}")
        bits.append(self.responder)
        if self.count is not None:
            bits.append(str(self.count))
        if self.seed is not None:
            bits.append(f"seed={self.seed}")
        return " ".join(bits)


@dataclass(frozen=True)
class Grid:
    """Values for each axis (a scalar or a sequence each); every combination is one run."""

    scenes: tuple[str, ...]
    responders: tuple[str, ...] = ("pgs",)
    iterations: tuple[int | None, ...] = (None,)
    substeps: tuple[int | None, ...] = (None,)
    mass_ratio: tuple[float | None, ...] = (None,)
    size: tuple[int | float | None, ...] = (None,)
    dt: tuple[float, ...] = (DEFAULT_DT,)
    steps: tuple[int, ...] = (DEFAULT_STEPS,)
    friction: tuple[float | None, ...] = (None,)
    seed: tuple[int | None, ...] = (None,)
    jitter: tuple[float, ...] = (DEFAULT_JITTER,)
    lenient: tuple[str, ...] = field(default=(), compare=False, repr=False)
    """Axes that may apply to none of this grid's runs: defaults a ``[[grid]]`` table inherits."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "lenient", tuple(self.lenient))
        for f in fields(self):
            if f.name == "lenient":
                continue
            values = _values(getattr(self, f.name), f.name)
            if f.name in _INT_AXES:
                values = tuple(v for item in values for v in _range(item, f.name))
            object.__setattr__(self, f.name, _unique(_CHECKS[f.name](v) for v in values))

    @classmethod
    def from_mapping(cls, spec: Mapping[str, Any], lenient: Sequence[str] = ()) -> Grid:
        """A grid from {axis: value or list of values}; unknown keys are refused by name."""
        if not isinstance(spec, Mapping):
            raise TypeError(f"grid must be a mapping of axis -> values, got {type(spec).__name__}")
        unknown = [k for k in spec if k not in AXES]
        if unknown:
            k = unknown[0]
            raise ValueError(f"grid: unknown axis {k!r}{_suggest(str(k), AXES)} (axes: {', '.join(AXES)})")
        if "scenes" not in spec:
            raise ValueError('grid: scenes must be given (e.g. scenes = ["vertical_stack"])')
        return cls(**{k: v for k, v in spec.items()}, lenient=tuple(lenient))

    def tasks(self) -> list[Task]:
        """Every run of the grid, in a fixed order (scene, size, ratio, responder, count, dt, ...).

        An axis given values that apply to none of the runs is refused (a ValueError
        naming it), unless it is one of ``lenient``.
        """
        out, used = self._expand()
        for axis in self.unused(used):
            raise ValueError(f"{axis} applies only to {_APPLIES[axis]}, and this grid has none of them")
        return out

    def unused(self, used: set[str] | None = None, *, all_axes: bool = False) -> list[str]:
        """The axes given values that apply to none of the runs (the lenient ones too with ``all_axes``)."""
        used = self._expand()[1] if used is None else used
        return [
            a for a in _APPLIES if getattr(self, a) != (None,) and a not in used and (all_axes or a not in self.lenient)
        ]

    def _expand(self) -> tuple[list[Task], set[str]]:
        out: list[Task] = []
        used: set[str] = set()
        for scene in self.scenes:
            sizes = (None,) if scene == "mass_ratio" else self.size
            ratios = self.mass_ratio if scene in RATIO_SCENES else (None,)
            used.update(a for a, vals in (("size", sizes), ("mass_ratio", ratios)) if vals != (None,))
            for size in sizes:
                for ratio in ratios:
                    for name in self.responders:
                        kind = REGISTRY[name].count
                        its = self.iterations if kind in ("sweeps", "passes") else (None,)
                        subs = self.substeps if kind == "substeps" else (None,)
                        used.update(a for a, vals in (("iterations", its), ("substeps", subs)) if vals != (None,))
                        for it in its:
                            for sub in subs:
                                for dt in self.dt:
                                    for steps in self.steps:
                                        for mu in self.friction:
                                            for seed in self.seed:
                                                for jit in self.jitter if seed is not None else (None,):
                                                    out.append(
                                                        Task(
                                                            scene, size, ratio, name, it, sub, dt, steps, mu, seed, jit
                                                        )
                                                    )
        return out, used


_APPLIES = {
    "iterations": "responders that take sweeps or passes (pgs..., iterative)",
    "substeps": "the soft-step responder",
    "mass_ratio": f"scenes {', '.join(RATIO_SCENES)}",
    "size": "scenes other than mass_ratio (its size is mass_ratio)",
}


GridLike = Grid | Mapping[str, Any] | str | os.PathLike | Sequence[Grid | Mapping[str, Any]]


def load_toml(path: str | os.PathLike) -> list[Grid]:
    """The grids of a TOML file (top-level axes, and optional ``[[grid]]`` tables)."""
    if sys.version_info >= (3, 11):
        import tomllib
    else:  # pragma: no cover - Python 3.10
        try:
            import tomli as tomllib
        except ImportError:
            raise ImportError("reading a TOML grid on Python 3.10 needs tomli: pip install 'phys2d[sweep]'") from None
    p = os.fspath(path)
    try:
        with open(p, "rb") as fh:
            data = tomllib.load(fh)
    except FileNotFoundError:
        raise FileNotFoundError(f"grid file not found: {p}") from None
    except tomllib.TOMLDecodeError as e:
        raise ValueError(f"grid file {p} is not valid TOML: {e}") from None
    return grids_from_mapping(data, where=f"grid file {p}")


def grids_from_mapping(data: Mapping[str, Any], where: str = "grid") -> list[Grid]:
    """Grids from a mapping holding axes and, optionally, a list ``grid`` of sub-grids."""
    base = {k: v for k, v in data.items() if k != "grid"}
    subs = data.get("grid")
    try:
        if subs is None:
            grid = Grid.from_mapping(base)
            grid.tasks()  # an axis that applies to none of the runs fails here, where it was written
            return [grid]
        if not isinstance(subs, list) or not all(isinstance(s, Mapping) for s in subs) or not subs:
            raise ValueError("grid must be a list of tables ([[grid]] in TOML)")
        grids = []
        for k, sub in enumerate(subs, 1):
            inherited = tuple(a for a in base if a not in sub)  # a default need not apply in every table
            try:
                grids.append(Grid.from_mapping({**base, **sub}, lenient=inherited))
                grids[-1].tasks()
            except (ValueError, TypeError) as e:
                raise type(e)(f"[[grid]] table {k}: {e}") from None
        for axis in base:  # but each default must apply somewhere
            if axis in _APPLIES and all(axis in g.unused(all_axes=True) for g in grids):
                raise ValueError(f"{axis} applies only to {_APPLIES[axis]}, and no [[grid]] table has one")
        return grids
    except (ValueError, TypeError) as e:
        raise type(e)(f"{where}: {e}") from None


def as_grids(grid: Any) -> list[Grid]:
    """Grid, mapping, TOML path or a sequence of grids/mappings -> a list of grids."""
    if isinstance(grid, Grid):
        return [grid]
    if isinstance(grid, (str, os.PathLike)):
        return load_toml(grid)
    if isinstance(grid, Mapping):
        return grids_from_mapping(grid)
    if isinstance(grid, Sequence) and grid and all(isinstance(g, (Grid, Mapping)) for g in grid):
        out: list[Grid] = []
        for g in grid:
            out += [g] if isinstance(g, Grid) else grids_from_mapping(g)
        return out
    raise TypeError(
        "grid must be a phys2d.sweeps.Grid, a mapping of axis -> values, a path to a TOML file, "
        f"or a list of grids; got {type(grid).__name__}"
    )


def expand(grids: Sequence[Grid]) -> list[Task]:
    """The tasks of several grids in order, each run once (the first time it appears)."""
    seen: set[Task] = set()
    out: list[Task] = []
    for g in grids:
        for t in g.tasks():
            if t not in seen:
                seen.add(t)
                out.append(t)
    return out


__all__ = [
    "AXES",
    "DEFAULT_DT",
    "DEFAULT_JITTER",
    "DEFAULT_STEPS",
    "Grid",
    "GridLike",
    "Task",
    "as_grids",
    "expand",
    "grids_from_mapping",
    "load_toml",
]
