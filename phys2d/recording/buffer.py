"""Buffering ticks: one run's samples between two writes, and which contacts get plotted.

The scene (bodies, contacts, stats, residuals) of every tick is kept until
``flush_every`` ticks have gathered and is then written as a few columns. The
plotted per-contact series need a choice of contacts (``ContactChoice``); their
values are kept until ``series_every`` ticks have gathered. A choice of the N
deepest contacts is made once, over the first window of ticks, and then kept, so
that every plotted series runs the whole recording.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from . import schema
from .sample import Sample

DEFAULT_DEEPEST = 4  # contacts plotted when nothing else is asked for


def member(key: np.ndarray, among: np.ndarray) -> np.ndarray:
    """``np.isin(key, among)``: for the few keys a plot shows one comparison pass per key of
    ``among`` (a (K, n) comparison reduced along its short axis is several times slower), else a
    binary search in the sorted ``among`` (``np.isin`` may call ``np.unique``, see ``unique``)."""
    if among.size > 16:
        ordered = np.sort(among)
        at = np.minimum(np.searchsorted(ordered, key), ordered.size - 1)
        return ordered[at] == key
    out = np.zeros(key.shape, np.bool_)
    for k in among:
        out |= key == k
    return out


def unique(keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(sorted distinct keys, index of each key among them): ``np.unique(keys, return_inverse=True)``
    for 1-D keys, by one stable sort. numpy 2's ``np.unique`` imports ``numpy.ma`` on first use,
    15-20 ms of a writer process's CPU."""
    order = np.argsort(keys, kind="stable")
    ordered = keys[order]
    first = np.ones(ordered.size, dtype=np.bool_)
    first[1:] = ordered[1:] != ordered[:-1]
    inverse = np.empty(keys.size, dtype=np.intp)
    inverse[order] = np.cumsum(first) - 1
    return ordered[first], inverse


class ContactChoice:
    """Which contacts get time-series plots of lambda and penetration.

        ContactChoice.deepest(4)              the 4 contacts that overlap deepest (the default)
        ContactChoice.body(7)                 every contact of the body with uid 7
        ContactChoice.keys(["b3-b7/f512"])    these contacts (names as in the plot legends)
        ContactChoice.parse("deepest:4" | "body:7" | "b3-b7/f512,b0-b1/f0")

    The per-tick contact table on ``world/sim/contacts`` always holds every contact.
    """

    def __init__(self, kind: str, n: int = 0, uid: int = -1, keys: tuple[int, ...] = ()) -> None:
        self.kind, self.n, self.uid, self.key_set = kind, n, uid, np.asarray(sorted(set(keys)), np.int64)

    @classmethod
    def deepest(cls, n: int = DEFAULT_DEEPEST) -> ContactChoice:
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)):
            raise TypeError(f"n must be an integer, got {type(n).__name__}")
        if n < 1:
            raise ValueError(f"n must be >= 1, got {n}")
        return cls("deepest", n=int(n))

    @classmethod
    def body(cls, uid: int) -> ContactChoice:
        if isinstance(uid, bool) or not isinstance(uid, (int, np.integer)):
            raise TypeError(f"uid must be an integer body uid, got {type(uid).__name__}")
        if not 0 <= uid < 1 << schema.UID_BITS:
            raise ValueError(f"uid must be a body uid >= 0, got {uid}")
        return cls("body", uid=int(uid))

    @classmethod
    def keys(cls, names) -> ContactChoice:
        if isinstance(names, str):
            names = [n for n in names.split(",") if n.strip()]
        keys = tuple(
            int(n) if isinstance(n, (int, np.integer)) and not isinstance(n, bool) else schema.parse_contact(n)
            for n in names
        )
        if not keys:
            raise ValueError("keys must name at least one contact, like 'b3-b7/f512'")
        return cls("keys", keys=keys)

    @classmethod
    def parse(cls, text: str) -> ContactChoice:
        """``deepest:N``, ``body:UID`` or comma-separated contact names."""
        if not isinstance(text, str):
            raise TypeError(f"plot must be a str like 'deepest:4', got {type(text).__name__}")
        head, _, tail = text.partition(":")
        try:
            if head == "deepest":
                return cls.deepest(int(tail) if tail else DEFAULT_DEEPEST)
            if head == "body":
                return cls.body(int(tail))
        except ValueError as e:
            raise ValueError(f"plot {text!r}: {e}") from None
        return cls.keys(text)

    def __repr__(self) -> str:
        if self.kind == "deepest":
            return f"ContactChoice.deepest({self.n})"
        if self.kind == "body":
            return f"ContactChoice.body({self.uid})"
        return f"ContactChoice.keys({[schema.contact_entity(k) for k in self.key_set]})"

    def mask(self, key: np.ndarray, chosen: np.ndarray | None) -> np.ndarray | None:
        """Which of a tick's contacts to keep for the series; None: all (the choice is not made yet)."""
        if self.kind == "body":
            a, b, _ = schema.split_key(key)
            return (a == self.uid) | (b == self.uid)
        if self.kind == "keys":
            return member(key, self.key_set)
        return None if chosen is None or chosen.size < self.n else member(key, chosen)

    def candidates(self, key: np.ndarray, penetration: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """A tick's N deepest contacts (ties at the cut kept): only these can be among a window's
        N deepest, so ``decide`` needs only these, gathered tick by tick as the ticks arrive."""
        if key.size <= self.n:
            return key, penetration
        top = np.argpartition(-penetration, self.n - 1)[: self.n]
        top = np.flatnonzero(penetration >= penetration[top].min())
        return key[top], penetration[top]

    def decide(self, keys: list[np.ndarray], penetration: list[np.ndarray], chosen: np.ndarray | None) -> np.ndarray:
        """``chosen`` topped up to N with the deepest other contacts of a window of ticks (deepest
        over the window; ties by key): once N are chosen, the choice stays.

        Only each tick's N deepest can be among the window's N deepest (a contact deepest at
        tick t but not among t's N deepest has N others deeper still), so only those are ranked;
        ``keys`` and ``penetration`` may hold just those (``candidates``). The top ``need`` of the
        contacts not yet chosen are among a tick's top N, as need + chosen = N.
        """
        chosen = np.zeros(0, np.int64) if chosen is None else chosen
        need = self.n - chosen.size
        if need <= 0:
            return chosen
        cand_k, cand_p = [], []
        for k, p in zip(keys, penetration, strict=True):
            free = ~member(k, chosen)
            k, p = k[free], p[free]
            if k.size > need:
                top = np.argpartition(-p, need - 1)[:need]
                top = np.flatnonzero(p >= p[top].min())  # keep ties at the cut
                k, p = k[top], p[top]
            cand_k.append(k)
            cand_p.append(p)
        key = np.concatenate(cand_k) if cand_k else np.zeros(0, np.int64)
        if key.size == 0:
            return chosen
        uniq, inv = unique(key)
        deepest = np.full(uniq.size, -np.inf)
        np.maximum.at(deepest, inv, np.concatenate(cand_p))
        order = np.lexsort((uniq, -deepest))
        return np.sort(np.concatenate([chosen, uniq[order[:need]]]))


def as_choice(plot) -> ContactChoice:
    """A ContactChoice from a ContactChoice, a str (``ContactChoice.parse``) or None (the default)."""
    if plot is None:
        return ContactChoice.deepest()
    if isinstance(plot, ContactChoice):
        return plot
    if isinstance(plot, str):
        return ContactChoice.parse(plot)
    raise TypeError(f"plot must be a ContactChoice, a str like 'deepest:4' or None, got {type(plot).__name__}")


@dataclass(eq=False)
class SeriesWindow:
    """Per-identity values of the ticks since the last write: rows of (key, values...)."""

    ticks: list[int] = field(default_factory=list)
    times: list[float] = field(default_factory=list)
    keys: list[np.ndarray] = field(default_factory=list)
    values: list[np.ndarray] = field(default_factory=list)  # (k, n_values) per tick
    last: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))  # present at the last written tick
    cand_keys: list[np.ndarray] = field(default_factory=list)  # per tick, the candidates for the deepest
    cand_depth: list[np.ndarray] = field(default_factory=list)

    def append(self, tick: int, time: float, keys: np.ndarray, values: np.ndarray) -> None:
        self.ticks.append(tick)
        self.times.append(time)
        self.keys.append(keys)
        self.values.append(values)

    def clear(self) -> None:
        if self.keys:
            self.last = self.keys[-1]
        self.ticks, self.times, self.keys, self.values = [], [], [], []
        self.cand_keys, self.cand_depth = [], []


@dataclass(eq=False)
class RunBuffer:
    """One run's ticks not yet written, and what the writer remembers between writes."""

    label: str | None
    prefix: str
    choice: ContactChoice
    samples: list[Sample] = field(default_factory=list)
    contacts: SeriesWindow = field(default_factory=SeriesWindow)
    joints: SeriesWindow = field(default_factory=SeriesWindow)
    chosen: np.ndarray | None = None  # the deepest contacts, once decided
    series_ticks: int = 0  # ticks in the series windows
    # remembered between writes
    sweeps: int = 0  # solver sweeps written so far: the sweep timeline
    labelled: int | None = None  # the layout version whose labels and classes were written last
    body_classes: np.ndarray | None = None  # the dynamic bodies' class ids as last written
    static_state: tuple | None = None  # (layout version, static bodies' x, theta, V) as last written
    styled: set[int] = field(default_factory=set)  # plotted contacts whose legend entry is written
    colours: dict[int, tuple[int, int, int]] = field(default_factory=dict)
    bounds: tuple[float, float, float, float] | None = None  # xmin, xmax, ymin, ymax of the first tick
    has_joints: bool = False
    plotted: bool = False  # any contact series written
    # the per-tick stats and the residuals of the windows written so far, sent together (``write_stats``):
    # a viewer loads a few long chunks much faster than many short ones
    stats: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = field(default_factory=list)  # ticks, times, values
    residuals: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = field(default_factory=list)
    stats_ticks: int = 0  # ticks in ``stats``

    def add(self, s: Sample, contact_series: bool) -> None:
        """Keep a sample, and the values of the contacts chosen for plotting."""
        self.samples.append(s)
        if self.bounds is None:
            lay = s.layout
            pts = s.x[lay.dynamic] if lay.dynamic.size else s.x
            if pts.shape[0]:
                pad = 1.0 + 0.1 * float(np.ptp(pts, axis=0).max())
                lo, hi = pts.min(axis=0) - pad, pts.max(axis=0) + pad
                self.bounds = (float(lo[0]), float(hi[0]), min(float(lo[1]), -0.5), float(hi[1]))
        if contact_series:
            keep = self.choice.mask(s.key, self.chosen)
            sel = slice(None) if keep is None else keep
            lambda_n = s.lambda_n[sel]
            values = np.empty((lambda_n.size, 3))
            values[:, 0] = lambda_n
            values[:, 1] = s.lambda_t[sel]
            np.multiply(s.separation[sel], -schema.PENETRATION_SCALE, out=values[:, 2])
            self.contacts.append(s.tick, s.time, s.key[sel], values)
            if keep is None and self.choice.kind == "deepest":  # choosing: rank as the ticks arrive
                k, p = self.choice.candidates(s.key, values[:, 2])
                self.contacts.cand_keys.append(k)
                self.contacts.cand_depth.append(p)
        if s.joint_keys is not None and s.joint_impulses is not None:
            self.has_joints = True
            self.joints.append(s.tick, s.time, s.joint_keys, s.joint_impulses[:, None])
        if contact_series or s.joint_keys is not None:
            self.series_ticks += 1
