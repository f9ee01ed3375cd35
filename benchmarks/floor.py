"""The soft step's floor (issue 45 item 7): its arithmetic and its bytes per contact point per sub-step,
against this machine's measured peak and bandwidth, and where large_pyramid stands against it.

    python benchmarks/floor.py                       # ~11 s of CPU: limits, the scene, the passes
    python benchmarks/floor.py --save-limits l.json  # keep the machine's limits for later runs
    python benchmarks/floor.py --limits l.json       # reuse them (no compile, no 5 s measure)
    python benchmarks/floor.py --no-passes           # skip the replay of each pass

Three parts:

1. This machine's limits: ``machine_limits.c`` (next to this script) built with gcc (``-O2 -mavx2``, no
   FMA, no fast-math) in a temporary directory and run: the clock, peak float64 adds and multiplies
   (packed 4 wide and scalar), divisions, and read / write / copy bandwidth per working-set size.
2. The soft step's work, counted from its code (``WORK``: floating-point operations; ``PASSES``: the
   arrays each pass streams), per unit (a point, a manifold, a body, a row), each entry naming the
   function and the line it comes from. Which units each entry applies to (all points; the points still
   apart; the manifolds solved as 2x2 blocks; ...) is counted on the scene itself, on the tick that is
   timed (``Scene.counts``). Flops: adds (subtractions too), multiplies, divisions, square roots and
   min/max (a clamp's halves: the add pipes run them) apart; a sign flip or abs (a mask) and a
   comparison are not counted. Bytes: what each pass streams, array by array, once per pass (the
   compulsory traffic of a pass that finds nothing of them in L1/L2: the row arrays, ~6 MB at this
   size, do not fit in a 512 KiB L2), at cache-line grain: a point's normal and friction rows are
   neighbours (rows 2q and 2q + 1), so a pass that reads one of them moves the lines of both. The
   body arrays (V, M^-1, ...: 24-32 bytes a body) are counted once per body per pass: ~120 kB each,
   they are taken to stay in L2 while a pass gathers them manifold by manifold.
3. The floor: max(flops / peak, bytes / bandwidth at the working-set size), per step of 4 sub-steps,
   against the measured step (``World.step``, one thread, as benchmarks/scale.py times it), the
   measured solve alone (``soft_step_solve``, in a staged step), and, unless ``--no-passes``, each pass
   replayed on the timed tick's rows (as benchmarks/threads.py replays them).
"""

from __future__ import annotations

import argparse
import copy
import json
import math
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

BENCH_DIR = Path(__file__).resolve().parent
sys.path.insert(0, str(BENCH_DIR.parent))  # the phys2d of this checkout

import phys2d  # noqa: E402
from phys2d import stock_scenes  # noqa: E402
from phys2d.constraints.rows import MET, unsigned_rows  # noqa: E402
from phys2d.pipeline import records  # noqa: E402
from phys2d.responders import soft_step as soft_step_module  # noqa: E402
from phys2d.responders.block import inverse_diagonal  # noqa: E402
from phys2d.responders.soft_contacts import (  # noqa: E402
    prepare_manifolds,
    soft_constants,
    soft_friction_rows,
    soft_normal_rows,
    warm_start_manifolds,
)
from phys2d.responders.soft_integrate import integrate_positions, integrate_velocities, split_forces  # noqa: E402
from phys2d.responders.soft_points import Points, note_sweep_start, prepare_points, store  # noqa: E402

DT = 1.0 / 60.0
SUBSTEPS = 4
CFLAGS = ("-O2", "-mavx2")  # no -mfma, no -ffast-math: the soft step's own arithmetic


# -- 1. the machine -----------------------------------------------------------------------------
@dataclass(frozen=True)
class Limits:
    """This machine's measured limits (``machine_limits.c``): per second."""

    clock_hz: float
    packed_flops: float  # float64 adds and multiplies, 4 wide, no FMA
    scalar_flops: float
    packed_divs: float  # float64 divisions (4 a vdivpd)
    scalar_divs: float
    bandwidth: list[dict[str, float]]  # per working-set size: bytes, read, write, copy (bytes/s)

    def at(self, size: float, kind: str) -> float:
        """Bandwidth of ``kind`` (read, write, copy) at a working set of ``size`` bytes, interpolated
        linearly in log2(size) between the sizes measured (the end values beyond them)."""
        rows = sorted(self.bandwidth, key=lambda r: r["bytes"])
        if size <= rows[0]["bytes"]:
            return rows[0][kind]
        for lo, hi in zip(rows, rows[1:]):
            if size <= hi["bytes"]:
                f = (math.log2(size) - math.log2(lo["bytes"])) / (math.log2(hi["bytes"]) - math.log2(lo["bytes"]))
                return lo[kind] + f * (hi[kind] - lo[kind])
        return rows[-1][kind]


def measure_limits(cc: str = "gcc") -> Limits:
    """Build ``machine_limits.c`` with ``cc`` in a temporary directory, run it, read its JSON."""
    with tempfile.TemporaryDirectory(prefix="phys2d-floor-") as tmp:
        exe = Path(tmp) / "machine_limits"
        build = [cc, *CFLAGS, "-o", str(exe), str(BENCH_DIR / "machine_limits.c")]
        done = subprocess.run(build, capture_output=True, text=True)
        if done.returncode != 0:
            raise RuntimeError(f"{' '.join(build)} failed:\n{done.stderr}")
        out = subprocess.run([str(exe)], capture_output=True, text=True, check=True).stdout
    return Limits(**json.loads(out))


def cpu_model() -> str:
    """lscpu's model name (or platform's processor)."""
    try:
        for line in subprocess.run(["lscpu"], capture_output=True, text=True).stdout.splitlines():
            if line.startswith("Model name:"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "?"


# -- 2. the work, from the code -----------------------------------------------------------------
@dataclass(frozen=True)
class Flops:
    """Floating-point operations: adds (and subtractions), multiplies, divisions, square roots, min/max."""

    add: int = 0
    mul: int = 0
    div: int = 0
    sqrt: int = 0
    minmax: int = 0

    def __add__(self, o: Flops) -> Flops:
        return Flops(self.add + o.add, self.mul + o.mul, self.div + o.div, self.sqrt + o.sqrt, self.minmax + o.minmax)

    def __mul__(self, n: int) -> Flops:
        return Flops(self.add * n, self.mul * n, self.div * n, self.sqrt * n, self.minmax * n)

    @property
    def pipelined(self) -> int:
        """What runs at the add and multiply pipes' rate: adds, multiplies, min/max."""
        return self.add + self.mul + self.minmax

    @property
    def total(self) -> int:
        return self.pipelined + self.div + self.sqrt


# the pieces every row update is made of (constraints/rows.py)
ROW_VELOCITY = Flops(add=5, mul=6)  # pair_row_velocity / row_velocity: J[k, i] * V_ab[i], six products summed as a tree
ROW_IMPULSE = Flops(add=6, mul=12)  # pair_row_impulse_of: V_ab[i] + (M_ab[i] * J[k, i]) * impulse, i = 0..5
# clamp_accumulated: low - old, high - old, min(max(delta, .), .), old + applied, min(max(., low), high)
CLAMP = Flops(add=3, minmax=4)
WORST = Flops(mul=1, minmax=1)  # worst = max(worst, abs(d) * A_kk[k]) (abs: a mask, not counted)
# soft_normal_rows, a two-point block (per manifold, both points), use_bias or both touching:
B_TERM = Flops(add=4, mul=5)  # b1 = ms1 * (J V + bias1) + is1 * K11 * a1 - (K11 * a1 + K12[m] * a2), J V aside
LCP2 = Flops(add=2, mul=6)  # block.lcp2, both rows push: x1 = -(K22 * b1 - K12 * b2) * inv_det, and x2
BLOCK = ROW_VELOCITY * 2 + B_TERM * 2 + LCP2 + Flops(add=2) + ROW_IMPULSE * 2 + Flops(mul=2, minmax=2)
# soft_normal_rows, a row on its own: d = -mass_scale * (J V + bias) * inv_A_kk[k] - impulse_scale * lam[k]
SINGLE = ROW_VELOCITY + Flops(add=2, mul=3) + CLAMP + ROW_IMPULSE + WORST
# soft_friction_rows: top = mu[k] * lam[kn]; d = -(J V - target) * inv_A_kk[k]; clamp into [-top, top]
FRICTION = Flops(mul=1) + ROW_VELOCITY + Flops(add=1, mul=1) + CLAMP + ROW_IMPULSE + WORST
# soft_points.separation_now: C0 + n.(d_b - d_a) + (cos - 1)_b n.r_b + sin_b (r_b x n) - the same of a
SEPARATION = Flops(add=8, mul=6)
# soft_integrate.integrate_positions: x += h v (3 mul, 3 add), moved = x - x0 (2), theta - theta0 (1),
# cos_less_one_sin's two Taylor series (d2 = d * d; c: 4 mul 3 add; s: 4 mul 3 add)
POSITIONS = Flops(add=3 + 2 + 1 + 3 + 3, mul=3 + 1 + 4 + 4)
# note_impacts_of for a point still apart that pushed: J V_sweep and J dv (row_velocity twice), vn + dvn, and
# rows.approach_at_impact's path that meets: dvn, p0 = vn + dvn / 2, C + dt vn, -sqrt(max(p0^2 - 2 (dvn/dt) C, 0))
APPROACH = ROW_VELOCITY * 2 + Flops(add=5, mul=5, div=1, sqrt=1, minmax=1)
# soft_friction_rows for a point still apart before its impact is noted: J V_sweep twice and
# speculative_friction_target's -vn dt and vt * (C / (-vn dt))
SPECULATIVE = ROW_VELOCITY * 2 + Flops(mul=3, div=1)
# soft_contacts.manifold_constants per two-point manifold: K12 = sum J_1 (M^-1 J_2) (12 mul, 6 add),
# block.block_is_well_conditioned (4 mul, 1 add), inv_det = 1 / (K11 K22 - K12^2)
MANIFOLD_CONSTANTS = Flops(add=6 + 1 + 1, mul=12 + 4 + 2, div=1)

# how often a piece runs, per sub-step (4 sub-steps, each a sweep with the push and a relax sweep)
TIMES: dict[str, Callable[[int], float]] = {
    "sub-step": lambda s: 1.0,
    "sweep": lambda s: 2.0,  # both sweeps of a sub-step
    "tick": lambda s: 1.0 / s,  # once per tick (prepare, restitution), over its sub-steps
    "later sweeps": lambda s: (2.0 * s - 1.0) / s,  # every sweep of the tick but its first
}


@dataclass(frozen=True)
class Work:
    """Arithmetic of one piece of the soft step: ``flops`` per unit of ``count`` (a key of ``Scene.counts``),
    ``times`` (a key of ``TIMES``); ``stage``: the pass; ``source``: the function and line it comes from."""

    stage: str
    source: str
    count: str
    times: str
    flops: Flops


WORK: tuple[Work, ...] = (
    Work("integrate velocities", "soft_integrate.integrate_velocities: V[b, c] += dv[b, c]", "bodies", "sub-step",
         Flops(add=3)),
    Work("warm start", "soft_contacts.warm_start_manifolds: pair_row_impulse_of(k, J, M_ab, lam[k], V_ab), normal row",
         "pushing points", "sub-step", ROW_IMPULSE),
    Work("warm start", "soft_contacts.warm_start_manifolds: the same, friction row (lam[k] != 0)",
         "friction rows with impulse", "sub-step", ROW_IMPULSE),
    Work("normal rows, push", "soft_contacts.soft_push: max(soft[0] * s, -soft[3]) of a touching point",
         "touching points", "sub-step", Flops(mul=1, minmax=1)),
    Work("normal rows, push", "soft_contacts.soft_push: s / h of a point still apart (speculative)",
         "apart points", "sub-step", Flops(div=1)),
    Work("normal rows, push", "soft_contacts.soft_normal_rows: b1, b2, lcp2, 2 x pair_row_impulse_of (a block)",
         "block manifolds", "sub-step", BLOCK),
    Work("normal rows, push", "soft_contacts.soft_normal_rows: d = -mass_scale * (J V + bias) * inv_A_kk[k] ...",
         "single-path points", "sub-step", SINGLE),
    Work("friction rows", "soft_contacts.soft_friction_rows: top = mu[k] * lam[kn], d, clamp_accumulated, impulse",
         "friction-active points", "sweep", FRICTION),
    Work("friction rows", "soft_contacts.soft_friction_rows: speculative_friction_target of a point not yet met",
         "apart points met", "tick", SPECULATIVE),
    Work("note impacts", "soft_points.note_impacts_of: approach_at_impact of a point that met its partner",
         "apart points met", "tick", APPROACH),
    Work("integrate positions", "soft_integrate.integrate_positions: x += h v, moved, cos_less_one_sin",
         "bodies", "sub-step", POSITIONS),
    Work("normal rows, relax", "soft_points.separation_now: C[p] (new_C: the bodies moved)", "points", "sub-step",
         SEPARATION),
    Work("normal rows, relax", "soft_contacts.soft_normal_rows: a block whose two points touch (soft_push: 0)",
         "relax block manifolds", "sub-step", BLOCK),
    Work("normal rows, relax", "soft_contacts.soft_normal_rows: a touching point on its own (s1 <= MET)",
         "relax single-path points", "sub-step", SINGLE),
    Work("store", "soft_points.store_of: total[kn] += lam[kn]; total[kt] += lam[kt]", "points", "sub-step",
         Flops(add=2)),
    Work("prepare (per tick)", "soft_step_solve: lam[k] /= substeps", "rows", "tick", Flops(div=1)),
    Work("prepare (per tick)", "block.inverse_diagonal: inv_A_kk[k] = 1.0 / A_kk[k]", "rows", "tick", Flops(div=1)),
    Work("prepare (per tick)", "soft_contacts.manifold_constants: K12, block_is_well_conditioned, inv_det",
         "two-point manifolds", "tick", MANIFOLD_CONSTANTS),
    Work("prepare (per tick)", "soft_integrate.split_forces: dv[b, c] = (V[b, c] - V1[b, c]) / substeps", "bodies",
         "tick", Flops(add=3, div=3)),
)  # fmt: skip


@dataclass(frozen=True)
class Array:
    """An array the soft step streams: ``nbytes`` per unit of ``per`` (points, manifolds, bodies)."""

    nbytes: int
    per: str
    what: str


ARRAYS: dict[str, Array] = {
    # the rows (RowRecord): 2 per point, normal row 2q and friction row 2q + 1 side by side
    "J": Array(2 * 6 * 8, "points", "rows.J (2K, 6) float64"),
    "lam": Array(2 * 8, "points", "rows.lam (2K,) float64"),
    "A_kk": Array(2 * 8, "points", "rows.A_kk (2K,) float64"),
    "inv_A_kk": Array(2 * 8, "points", "inverse_diagonal(A_kk) (2K,) float64"),
    "mu": Array(2 * 8, "points", "rows.mu (2K,) float64"),
    "body_a": Array(2 * 4, "points", "rows.body_a (2K,) int32"),
    "body_b": Array(2 * 4, "points", "rows.body_b (2K,) int32"),
    "total": Array(2 * 8, "points", "soft_step_solve's total (2K,) float64"),
    # per point
    "normal_row": Array(4, "points", "rows.normal_row (K,) int32"),
    "friction_row": Array(4, "points", "rows.friction_row (K,) int32"),
    "order": Array(4, "points", "rows.order (K,) int32"),
    "separation": Array(8, "points", "the contacts' separation (K,) float64"),
    "restitution": Array(8, "points", "the contacts' restitution (K,) float64"),
    "C0": Array(8, "points", "Points.C0 (K,) float64"),
    "C": Array(8, "points", "Points.C (K,) float64"),
    "e": Array(8, "points", "Points.e (K,) float64"),
    "pending": Array(4, "points", "Points.pending (K,) uint32"),
    "impacted": Array(1, "points", "Points.impacted (K,) bool"),
    "landed": Array(1, "points", "Points.landed (K,) bool"),
    # per manifold (prepare_manifolds)
    "start": Array(4, "manifolds", "start (M + 1,) uint32"),
    "static_pair": Array(1, "manifolds", "static_pair (M,) bool"),
    "K12": Array(8, "manifolds", "K12 (M,) float64"),
    "as_block": Array(1, "manifolds", "as_block (M,) bool"),
    "inv_det": Array(8, "manifolds", "inv_det (M,) float64"),
    # per body
    "V": Array(3 * 8, "bodies", "V (N, 3) float64"),
    "V1": Array(3 * 8, "bodies", "V1 (N, 3) float64"),
    "M_inv": Array(3 * 8, "bodies", "M_inv (N, 3) float64"),
    "V_sweep": Array(3 * 8, "bodies", "Points.V_sweep (N, 3) float64"),
    "dv": Array(3 * 8, "bodies", "split_forces' dv (N, 3) float64"),
    "moved": Array(4 * 8, "bodies", "Points.moved (N, 4) float64"),
    "x": Array(2 * 8, "bodies", "x (N, 2) float64"),
    "theta": Array(8, "bodies", "theta (N,) float64"),
    "x0": Array(2 * 8, "bodies", "x0 (N, 2) float64"),
    "theta0": Array(8, "bodies", "theta0 (N,) float64"),
}

Access = str | tuple[str, str]  # an array (all its units), or (array, the count key of the units touched)


@dataclass(frozen=True)
class Pass:
    """One pass of the soft step over its arrays: what it reads and writes (``Access``), ``times`` (``TIMES``);
    ``source``: the function."""

    stage: str
    source: str
    times: str
    reads: tuple[Access, ...]
    writes: tuple[Access, ...] = ()


_PAIR = ("start", "body_a", "body_b", "M_inv", "V")  # what every manifold loop reads: its pair's bodies
PASSES: tuple[Pass, ...] = (
    Pass("integrate velocities", "soft_integrate.integrate_velocities", "sub-step", ("V", "dv"), ("V",)),
    Pass("note sweep start", "soft_points.note_sweep_start (both sweeps, while points are pending)", "sweep",
         (("V", "bodies while pending"),), (("V_sweep", "bodies while pending"),)),
    Pass("warm start", "soft_contacts.warm_start_manifolds", "sub-step",
         (*_PAIR, "normal_row", "friction_row", "lam", ("J", "pushing points")), ("V",)),
    Pass("normal rows, push", "soft_contacts.soft_normal_rows (use_bias, new_C False)", "sub-step",
         (*_PAIR, "normal_row", "static_pair", "as_block", "K12", "inv_det", "C", "A_kk", "lam", "J",
          ("inv_A_kk", "single-path points")), ("lam", "V")),
    Pass("friction rows", "soft_contacts.soft_friction_rows (both sweeps)", "sweep",
         (*_PAIR, "friction_row", "normal_row", "A_kk", "lam", ("mu", "friction-active points"),
          ("C", "friction-active points"), ("impacted", "apart points"), ("inv_A_kk", "friction-active points"),
          ("J", "friction-active points")),
         (("lam", "friction-active points"), "V")),
    Pass("note impacts", "soft_points.note_impacts_of, first sweep of the tick: every point", "tick",
         ("pending", "normal_row", "lam", ("e", "pushing points"), ("C", "pushing points")),
         (("impacted", "pushing points"), ("pending", "pending points"))),
    Pass("note impacts", "soft_points.note_impacts_of, the other sweeps: the points still pending", "later sweeps",
         (("pending", "pending points"), ("normal_row", "pending points"), ("lam", "pending points")),
         (("pending", "pending points"),)),
    Pass("integrate positions", "soft_integrate.integrate_positions", "sub-step",
         ("x", "theta", "V", "x0", "theta0"), ("x", "theta", "moved")),
    Pass("normal rows, relax", "soft_contacts.soft_normal_rows (relax, new_C: separation_now)", "sub-step",
         (*_PAIR, "normal_row", "friction_row", "static_pair", "as_block", "K12", "inv_det", "C0", "moved", "A_kk",
          "lam", "J", ("inv_A_kk", "relax single-path points")), ("C", "lam", "V")),
    Pass("store", "soft_points.store_of", "sub-step", ("normal_row", "friction_row", "lam", "landed", "total"),
         ("total",)),
    Pass("prepare (per tick)", "soft_step_solve: lam[k] /= substeps; total = np.zeros", "tick", ("lam",),
         ("lam", "total")),
    Pass("prepare (per tick)", "soft_contacts.prepare_manifolds (new_manifolds, manifold_constants)", "tick",
         ("normal_row", "body_a", "body_b", "A_kk", "M_inv", ("J", "points in two-point manifolds")),
         ("start", "start", "static_pair", "K12", "as_block", "inv_det")),
    Pass("prepare (per tick)", "block.inverse_diagonal", "tick", ("A_kk",), ("inv_A_kk",)),
    Pass("prepare (per tick)", "soft_step_solve: x0 = x.copy(); theta0 = theta.copy()", "tick", ("x", "theta"),
         ("x0", "theta0")),
    Pass("prepare (per tick)", "soft_points.prepare_points (gather_contacts, points_of)", "tick",
         ("order", "separation", "restitution", "C0"),
         ("C0", "e", "C", "moved", "pending", "impacted", "landed")),
    Pass("prepare (per tick)", "soft_integrate.split_forces", "tick", ("V", "V1"), ("dv", "V")),
    Pass("restitution (per tick)", "soft_points.restitution (e = 0: each point read and left)", "tick",
         ("normal_row", "friction_row", "e")),
    Pass("restitution (per tick)", "soft_step_solve: lam[k] = total[k]", "tick", ("total",), ("lam",)),
)  # fmt: skip


def access_bytes(access: Access, counts: dict[str, float]) -> float:
    """Bytes an access moves: the array's bytes per unit, times its units (all, or the count named)."""
    name, key = (access, None) if isinstance(access, str) else access
    array = ARRAYS[name]
    units = counts[array.per if key is None else key]
    return array.nbytes * units


def pass_bytes(p: Pass, counts: dict[str, float]) -> tuple[float, float]:
    """(read, written) bytes of one run of a pass."""
    return sum(access_bytes(a, counts) for a in p.reads), sum(access_bytes(a, counts) for a in p.writes)


def working_set(counts: dict[str, float]) -> float:
    """Bytes of every array the soft step streams (each once)."""
    return sum(a.nbytes * counts[a.per] for a in ARRAYS.values())


# -- the scene --------------------------------------------------------------------------------------
@dataclass
class Scene:
    """large_pyramid after settling: its counts (units the work applies to), the timed figures and the tick
    that was timed last (for the replay)."""

    counts: dict[str, float]
    contacts: int  # len(World.contacts) after settling
    steps: int  # timed steps per round
    step_rounds: list[float] = field(default_factory=list)  # s per step (World.step), per round
    solve_rounds: list[float] = field(default_factory=list)  # s per soft_step_solve, per round
    staged_rounds: list[float] = field(default_factory=list)  # s per staged step, per round
    ctx: Any = None  # the last staged step's StepContext (its arrays as the solve left them)
    lam_in: np.ndarray | None = None  # rows.lam as the solve got it (the cached impulse per tick)
    V_in: np.ndarray | None = None  # V as the solve got it
    x_in: tuple[np.ndarray, np.ndarray] | None = None  # x and theta as the solve got them


def scene_counts(ctx: Any, lam_in: np.ndarray, lam_out: np.ndarray, soft: phys2d.SoftStep) -> dict[str, float]:
    """How many units each piece of work applies to, on the tick of ``ctx``: lam_out holds the tick's
    impulses. A point's separation is taken as found (it moves by micrometres within a tick of a settled
    pile); a point that pushed at all in the tick is taken to push in every sweep."""
    rows = ctx.rows
    K, N = rows.n_contacts, ctx.x.shape[0]
    record = unsigned_rows(records.record_of_rows(rows))
    start, static_pair, K12, as_block, inv_det = prepare_manifolds(record, ctx.M_inv, soft.block)
    sizes = np.diff(start.astype(np.int64))
    C0 = ctx.separation[rows.order]
    touching = C0 <= MET
    lam_n, lam_t = lam_out[rows.normal_row], lam_out[rows.friction_row]
    pushing = lam_n > 0.0
    block_points = np.repeat(as_block, sizes)
    both_touch = np.minimum.reduceat(touching.astype(np.int8), start[:-1].astype(np.int64)).astype(bool)
    relax_block = as_block & both_touch
    relax_block_points = np.repeat(relax_block, sizes)
    pending = int((~pushing).sum())
    return {
        "points": K,
        "rows": 2 * K,
        "bodies": N,
        "manifolds": len(sizes),
        "two-point manifolds": int((sizes == 2).sum()),
        "points in two-point manifolds": int(sizes[sizes == 2].sum()),
        "block manifolds": int(as_block.sum()),
        "single-path points": int((~block_points).sum()),
        "touching points": int(touching.sum()),
        "apart points": int((~touching).sum()),
        "relax block manifolds": int(relax_block.sum()),
        "relax single-path points": int((touching & ~relax_block_points).sum()),
        "pushing points": int(pushing.sum()),
        "friction rows with impulse": int((lam_t != 0.0).sum()),
        "friction-active points": int(((lam_n != 0.0) | (lam_t != 0.0)).sum()),
        "pending points": pending,
        "apart points met": int((~touching & pushing).sum()),
        "bodies while pending": N if pending > 0 else 0,
        "static-pair manifolds": int(static_pair.sum()),
        "warm-started points": int((lam_in[rows.normal_row] != 0.0).sum()),
    }


def measure_scene(base: int, settle: int, steps: int, rounds: int) -> Scene:
    """Build large_pyramid (base ``base``) with SoftStep(4) on one thread, ``settle`` steps, then ``rounds``
    rounds of ``steps`` timed steps: first ``World.step`` (the one-call tick, as benchmarks/scale.py times
    it), then the staged step with ``soft_step_solve`` timed on its own; the last staged tick is kept."""
    soft = phys2d.SoftStep(SUBSTEPS)
    w = stock_scenes.large_pyramid(base, responder=soft)
    w.threads = 1
    for _ in range(settle):
        w.step(DT)
    contacts = len(w.contacts)
    step_rounds = []
    for _ in range(rounds):
        t0 = time.perf_counter()
        for _ in range(steps):
            w.step(DT)
        step_rounds.append((time.perf_counter() - t0) / steps)

    w.one_call_tick = False  # the staged step hands the responder its context, and calls soft_step_solve
    solve = soft_step_module.soft_step_solve
    spent: list[float] = []
    caught: dict[str, Any] = {}

    def timed_solve(*args: Any) -> int:
        t0 = time.perf_counter()
        n = solve(*args)
        spent.append(time.perf_counter() - t0)
        return n

    respond = soft.respond

    def spying_respond(ctx: Any) -> Any:
        caught.update(ctx=ctx, lam_in=ctx.rows.lam.copy(), V_in=ctx.V.copy(), x_in=(ctx.x.copy(), ctx.theta.copy()))
        return respond(ctx)

    soft_step_module.soft_step_solve = timed_solve
    soft.respond = spying_respond  # type: ignore[method-assign]
    try:
        for _ in range(2):  # the staged kernels loaded
            w.step(DT)
        solve_rounds, staged_rounds = [], []
        for _ in range(rounds):
            spent.clear()
            t0 = time.perf_counter()
            for _ in range(steps):
                w.step(DT)
            staged_rounds.append((time.perf_counter() - t0) / steps)
            solve_rounds.append(sum(spent) / len(spent))
    finally:
        soft_step_module.soft_step_solve = solve
        del soft.respond
    ctx = caught["ctx"]
    counts = scene_counts(ctx, caught["lam_in"], ctx.rows.lam, soft)
    return Scene(
        counts, contacts, steps, step_rounds, solve_rounds, staged_rounds, ctx, caught["lam_in"], caught["V_in"],
        caught["x_in"],
    )  # fmt: skip


# -- each pass, replayed --------------------------------------------------------------------------
def replay_passes(scene: Scene, repeats: int) -> dict[str, float]:
    """Seconds per call of each pass, the best of ``repeats`` calls, replayed on the timed tick's rows
    and bodies (copies: the world is left alone), called from Python as ``soft_step_solve`` calls them;
    keys: ``REPLAY_CALLS``. The sweeps, warm start and integrate positions: less a call over no units."""
    soft = phys2d.SoftStep(SUBSTEPS)
    ctx = scene.ctx
    rows = copy.copy(ctx.rows)
    rows.lam = scene.lam_in / SUBSTEPS  # the impulse per sub-step, as the sweeps see it
    record = unsigned_rows(records.record_of_rows(rows))
    M_inv = ctx.M_inv
    N = M_inv.shape[0]
    manifolds = prepare_manifolds(record, M_inv, soft.block)
    inv_A_kk = inverse_diagonal(rows.A_kk)
    found = (rows.order, ctx.separation, ctx.restitution)
    K = rows.n_contacts
    C0, e = ctx.separation[rows.order], ctx.restitution[rows.order]  # (gather_contacts)
    moved = np.zeros((N, 4))
    points = Points(  # as points_of makes them, with arrays in hand (a record's fields are not read from Python)
        C0, e, C0.copy(), moved, np.empty((N, 3)), np.arange(K, dtype=np.uint32), np.zeros(K, np.bool_),
        np.empty(K), np.empty(K), np.zeros(K, np.bool_),
    )  # fmt: skip
    h = DT / SUBSTEPS
    hertz = min(soft.contact_hertz, 0.25 / h)
    springs = (
        soft_constants(hertz, soft.damping_ratio, h, soft.push_max),
        soft_constants(2.0 * hertz, soft.damping_ratio, h, soft.push_max),
        soft_constants(min(soft.joint_hertz, 0.25 / h), soft.joint_damping_ratio, h, np.inf),
    )
    V = scene.V_in.copy()
    x, theta = scene.x_in[0].copy(), scene.x_in[1].copy()
    x0, theta0 = x.copy(), theta.copy()
    bodies = records.new_bodies((x, theta, V, M_inv, ctx.V1.copy()))
    dv = np.zeros_like(V)
    forced = records.new_bodies((x.copy(), theta.copy(), V.copy(), M_inv, ctx.V1.copy()))  # split_forces sets its V
    total = np.zeros(rows.lam.shape[0])
    n = manifolds[0].shape[0] - 1
    start = manifolds[0]
    # (call, its units): a kernel over a range of manifolds or bodies is also called over none, and that
    # call's time (its dispatch from Python: unboxing the records, a few µs) is taken off
    ranged: dict[str, tuple[Callable[[int, int], object], int]] = {
        "warm start": (lambda a, b: warm_start_manifolds(a, b, start, record, M_inv, V), n),
        "normal rows, push": (
            lambda a, b: soft_normal_rows(a, b, record, manifolds, inv_A_kk, points, M_inv, V, h, True, springs, False),
            n,
        ),
        "friction rows": (
            lambda a, b: soft_friction_rows(a, b, record, manifolds, inv_A_kk, points, M_inv, V, h),
            n,
        ),
        "integrate positions": (lambda a, b: integrate_positions(a, b, bodies, h, x0, theta0, moved), N),
        "normal rows, relax": (
            lambda a, b: soft_normal_rows(a, b, record, manifolds, inv_A_kk, points, M_inv, V, h, False, springs, True),
            n,
        ),
    }
    whole: dict[str, Callable[[], object]] = {
        "integrate velocities": lambda: integrate_velocities(V, dv),
        "note sweep start": lambda: note_sweep_start(points, V),
        "store": lambda: store(record, total, points),
        "prepare manifolds": lambda: prepare_manifolds(record, M_inv, soft.block),
        "inverse diagonal": lambda: inverse_diagonal(rows.A_kk),
        "prepare points": lambda: prepare_points(found, N),
        "split forces": lambda: split_forces(forced, SUBSTEPS),
    }

    def timed(call: Callable[[], object]) -> float:
        call()  # loaded (or compiled) once, untimed
        times = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            call()
            times.append(time.perf_counter() - t0)
        return min(times)  # the best call: on a shared host the slower ones are other programs' doing

    out = {}
    for name in REPLAY_CALLS:
        if name in ranged:
            call, units = ranged[name]
            empty = timed(lambda call=call: call(0, 0))
            out[name] = max(timed(lambda call=call, units=units: call(0, units)) - empty, 0.0)
        else:
            out[name] = timed(whole[name])
    return out


# how many calls of each replayed pass a tick makes (relax on, points pending all tick)
REPLAY_CALLS = {
    "integrate velocities": SUBSTEPS,
    "note sweep start": 2 * SUBSTEPS,
    "warm start": SUBSTEPS,
    "normal rows, push": SUBSTEPS,
    "friction rows": 2 * SUBSTEPS,
    "integrate positions": SUBSTEPS,
    "normal rows, relax": SUBSTEPS,
    "store": SUBSTEPS,
    "prepare manifolds": 1,
    "inverse diagonal": 1,
    "prepare points": 1,
    "split forces": 1,
}
REPLAY_STAGE = {  # the replayed call's stage in WORK and PASSES
    "prepare manifolds": "prepare (per tick)",
    "inverse diagonal": "prepare (per tick)",
    "prepare points": "prepare (per tick)",
    "split forces": "prepare (per tick)",
}


# -- 3. the floor --------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Floor:
    """Per step of ``substeps`` sub-steps, seconds, and the per-point figures behind them."""

    flops_per_point: dict[str, float]  # per point per sub-step, by kind (units that apply to few points averaged in)
    read_per_point: float  # bytes per point per sub-step
    written_per_point: float
    body_bytes_per_body: float  # of which the body arrays': bytes per body per sub-step
    working_set: float  # bytes
    bandwidth: float  # bytes/s at the working set (copy: reads and writes mixed)
    t_flops: float  # s per step at the packed peak (divisions and square roots at the packed division rate)
    t_flops_scalar: float  # the same at the scalar rates
    t_bytes: float  # s per step: (read + written) / bandwidth
    t_bytes_split: float  # read / read bandwidth + written / write bandwidth, no overlap

    @property
    def t(self) -> float:
        return max(self.t_flops, self.t_bytes)

    @property
    def bound(self) -> str:
        return "memory" if self.t_bytes >= self.t_flops else "arithmetic"


def flops_per_point(counts: dict[str, float], work: tuple[Work, ...] = WORK) -> dict[str, float]:
    """Flops per point per sub-step by kind (add, mul, div, sqrt, minmax), summed over ``work``."""
    out = dict.fromkeys(("add", "mul", "div", "sqrt", "minmax"), 0.0)
    for w in work:
        scale = counts[w.count] * TIMES[w.times](SUBSTEPS) / counts["points"]
        for kind in out:
            out[kind] += getattr(w.flops, kind) * scale
    return out


def bytes_per_point(counts: dict[str, float], passes: tuple[Pass, ...] = PASSES) -> tuple[float, float]:
    """(read, written) bytes per point per sub-step, summed over ``passes``."""
    read = written = 0.0
    for p in passes:
        r, w = pass_bytes(p, counts)
        scale = TIMES[p.times](SUBSTEPS) / counts["points"]
        read, written = read + r * scale, written + w * scale
    return read, written


def floor_of(counts: dict[str, float], limits: Limits, stage: str | None = None) -> Floor:
    """The floor of the whole soft step (``stage`` None) or of one stage, per step."""
    work = tuple(w for w in WORK if stage is None or w.stage == stage)
    passes = tuple(p for p in PASSES if stage is None or p.stage == stage)
    f = flops_per_point(counts, work)
    read, written = bytes_per_point(counts, passes)
    body = 0.0
    for p in passes:
        for accesses in (p.reads, p.writes):
            for a in accesses:
                if ARRAYS[a if isinstance(a, str) else a[0]].per == "bodies":
                    body += access_bytes(a, counts) * TIMES[p.times](SUBSTEPS) / counts["bodies"]
    ws = working_set(counts)
    per_step = counts["points"] * SUBSTEPS
    pipelined = f["add"] + f["mul"] + f["minmax"]
    slow = f["div"] + f["sqrt"]
    return Floor(
        flops_per_point=f,
        read_per_point=read,
        written_per_point=written,
        body_bytes_per_body=body,
        working_set=ws,
        bandwidth=limits.at(ws, "copy"),
        t_flops=per_step * (pipelined / limits.packed_flops + slow / limits.packed_divs),
        t_flops_scalar=per_step * (pipelined / limits.scalar_flops + slow / limits.scalar_divs),
        t_bytes=per_step * (read + written) / limits.at(ws, "copy"),
        t_bytes_split=per_step * (read / limits.at(ws, "read") + written / limits.at(ws, "write")),
    )


# -- the report ------------------------------------------------------------------------------------
def table(head: list[str], rows: list[list[str]], text: int = 1) -> str:
    """A Markdown table: the first ``text`` columns left-aligned, the rest (figures) right-aligned."""
    lines = ["| " + " | ".join(head) + " |", "|" + " --- |" * text + " ---: |" * (len(head) - text)]
    lines += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(lines)


def report(
    limits: Limits, scene: Scene, passes: dict[str, float] | None, small: tuple[int, Scene, dict[str, float]] | None
) -> str:
    """The tables: the machine, the counts, the work per point, the floor against the measured times; each
    pass replayed (``passes``), and on a small pyramid whose arrays fit in L2 (``small``: base, scene, passes)."""
    c = scene.counts
    K = c["points"]
    out = []
    out.append(f"# The soft step's floor: large_pyramid, SoftStep({SUBSTEPS}), one thread\n")
    load = os.getloadavg()
    out.append(
        f"- {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, {cpu_model()}, {os.cpu_count()} CPUs, "
        f"load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}; Python {platform.python_version()}, "
        f"numpy {np.__version__}, phys2d {getattr(phys2d, '__version__', '?')}\n"
    )
    out.append("## This machine (machine_limits.c, gcc " + " ".join(CFLAGS) + ")\n")
    out.append(
        table(
            ["limit", "measured", "per cycle"],
            [
                ["clock (dependent integer adds)", f"{limits.clock_hz / 1e9:.2f} GHz", "1"],
                [
                    "float64 adds + multiplies, packed 4 wide",
                    f"{limits.packed_flops / 1e9:.1f} GFLOP/s",
                    f"{limits.packed_flops / limits.clock_hz:.1f}",
                ],
                [
                    "float64 adds + multiplies, scalar",
                    f"{limits.scalar_flops / 1e9:.1f} GFLOP/s",
                    f"{limits.scalar_flops / limits.clock_hz:.1f}",
                ],
                [
                    "float64 divisions, packed",
                    f"{limits.packed_divs / 1e9:.2f} G/s",
                    f"{limits.packed_divs / limits.clock_hz:.2f}",
                ],
                [
                    "float64 divisions, scalar",
                    f"{limits.scalar_divs / 1e9:.2f} G/s",
                    f"{limits.scalar_divs / limits.clock_hz:.2f}",
                ],
            ],
        )
    )
    out.append("")
    out.append(
        table(
            ["working set", "read GB/s", "write GB/s", "copy GB/s"],
            [
                [
                    f"{r['bytes'] / 2**20:g} MiB" if r["bytes"] >= 2**20 else f"{r['bytes'] / 2**10:g} KiB",
                    f"{r['read'] / 1e9:.1f}",
                    f"{r['write'] / 1e9:.1f}",
                    f"{r['copy'] / 1e9:.1f}",
                ]
                for r in limits.bandwidth
            ],
        )
    )
    out.append("\n## The scene, as the timed tick found it\n")
    out.append(f"World.contacts after settling: {scene.contacts:,}\n")
    out.append(table(["count", "units"], [[k, f"{int(v):,}"] for k, v in c.items()]))

    fl = floor_of(c, limits)
    out.append("\n## The work per contact point per sub-step, from the code (WORK)\n")
    rows = []
    for w in WORK:
        scale = c[w.count] * TIMES[w.times](SUBSTEPS) / K
        f = w.flops
        rows.append(
            [
                w.stage,
                f"`{w.source}`",
                w.count,
                w.times,
                f"{f.add}/{f.mul}/{f.div}/{f.sqrt}/{f.minmax}",
                f"{f.total * scale:.1f}",
            ]
        )
    out.append(
        table(["stage", "source", "per", "how often", "add/mul/div/sqrt/minmax per unit", "flops per point"], rows, 4)
    )
    f = fl.flops_per_point
    out.append(
        f"\nTotal per point per sub-step: {sum(f.values()):.1f} flops: {f['add']:.1f} add, {f['mul']:.1f} mul, "
        f"{f['div']:.2f} div, {f['sqrt']:.3f} sqrt, {f['minmax']:.1f} min/max.\n"
    )
    out.append("## The bytes per contact point per sub-step, from the code (PASSES)\n")
    rows = []
    for p in PASSES:
        r, w = pass_bytes(p, c)
        scale = TIMES[p.times](SUBSTEPS) / K
        names = ", ".join(a if isinstance(a, str) else f"{a[0]} ({a[1]})" for a in p.reads)
        wnames = ", ".join(a if isinstance(a, str) else f"{a[0]} ({a[1]})" for a in p.writes)
        rows.append([p.stage, f"`{p.source}`", p.times, names, wnames or "-", f"{r * scale:.1f}", f"{w * scale:.1f}"])
    out.append(table(["stage", "source", "how often", "reads", "writes", "read B/point", "written B/point"], rows, 5))
    out.append(
        f"\nTotal per point per sub-step: {fl.read_per_point:.0f} bytes read, {fl.written_per_point:.0f} written "
        f"({fl.read_per_point + fl.written_per_point:.0f}); of which the body arrays: "
        f"{fl.body_bytes_per_body:.0f} bytes per body per sub-step. Working set (every array once): "
        f"{fl.working_set / 2**20:.2f} MiB.\n"
    )
    unit = {"points": "point", "manifolds": "manifold", "bodies": "body"}
    out.append("Array sizes: " + "; ".join(f"{k} {a.nbytes} B/{unit[a.per]}" for k, a in ARRAYS.items()) + "\n")

    out.append("## By stage, per contact point per sub-step\n")
    rows = []
    for stage in dict.fromkeys([w.stage for w in WORK] + [p.stage for p in PASSES]):
        part = floor_of(c, limits, stage)
        rows.append(
            [
                stage,
                f"{sum(part.flops_per_point.values()):.1f}",
                f"{part.read_per_point:.0f}",
                f"{part.written_per_point:.0f}",
                f"{part.t_flops * 1e6:,.0f}",
                f"{part.t_bytes * 1e6:,.0f}",
            ]
        )
    rows.append(
        [
            "**all**",
            f"{sum(fl.flops_per_point.values()):.1f}",
            f"{fl.read_per_point:.0f}",
            f"{fl.written_per_point:.0f}",
            f"{fl.t_flops * 1e6:,.0f}",
            f"{fl.t_bytes * 1e6:,.0f}",
        ]
    )
    out.append(table(["stage", "flops", "bytes read", "bytes written", "µs/step, peak", "µs/step, bandwidth"], rows))
    out.append("")
    out.append(f"## The floor against the measured step ({SUBSTEPS} sub-steps, {K:,} points)\n")
    us = 1e6
    step = statistics.median(scene.step_rounds)
    solve = statistics.median(scene.solve_rounds)
    staged = statistics.median(scene.staged_rounds)
    per_step = K * SUBSTEPS
    rows = [
        [
            "flops per step",
            f"{sum(fl.flops_per_point.values()) * per_step / 1e6:.1f} M",
            f"at {limits.packed_flops / 1e9:.1f} GFLOP/s packed (divisions at {limits.packed_divs / 1e9:.2f} G/s)",
            f"{fl.t_flops * us:,.0f}",
        ],
        [
            "flops per step, scalar",
            "",
            f"at {limits.scalar_flops / 1e9:.1f} GFLOP/s scalar (divisions at {limits.scalar_divs / 1e9:.2f} G/s)",
            f"{fl.t_flops_scalar * us:,.0f}",
        ],
        [
            "bytes per step",
            f"{(fl.read_per_point + fl.written_per_point) * per_step / 2**20:.1f} MiB",
            f"at {fl.bandwidth / 1e9:.1f} GB/s (copy at {fl.working_set / 2**20:.1f} MiB)",
            f"{fl.t_bytes * us:,.0f}",
        ],
        [
            "bytes per step, reads and writes apart",
            "",
            f"read at {limits.at(fl.working_set, 'read') / 1e9:.1f}, write at "
            f"{limits.at(fl.working_set, 'write') / 1e9:.1f} GB/s",
            f"{fl.t_bytes_split * us:,.0f}",
        ],
        ["**floor** = max(flops, bytes)", "", f"{fl.bound} bound", f"**{fl.t * us:,.0f}**"],
        [
            "measured: World.step",
            "",
            f"median of {len(scene.step_rounds)} rounds of {scene.steps}: "
            + ", ".join(f"{t * us:,.0f}" for t in scene.step_rounds),
            f"{step * us:,.0f} ({step / fl.t:.1f}x the floor)",
        ],
        [
            "measured: soft_step_solve alone",
            "",
            "in a staged step, rounds: " + ", ".join(f"{t * us:,.0f}" for t in scene.solve_rounds),
            f"{solve * us:,.0f} ({solve / fl.t:.1f}x the floor)",
        ],
        ["measured: the staged step", "", "its whole step, for reference", f"{staged * us:,.0f}"],
    ]
    out.append(table(["", "per step", "how", "µs per step"], rows, 1))
    if passes is not None:
        out.append("\n## Each pass replayed on the timed tick (the best of its calls)\n")
        rows = []
        total = 0.0
        stages_done = set()
        for name, t in passes.items():
            stage = REPLAY_STAGE.get(name, name)
            n = REPLAY_CALLS[name]
            total += t * n
            if stage in stages_done:
                rows.append([name, f"{t * us:,.1f}", str(n), f"{t * n * us:,.0f}", "(in the row above)", "", ""])
                rows[-1][-1] = f"{t * 1e9 / K:.1f}"
                continue
            stages_done.add(stage)
            part = floor_of(c, limits, stage)
            ratio = ""
            if stage != "prepare (per tick)":
                ratio = f"{t * n / part.t:.1f}x"
            rows.append(
                [
                    name,
                    f"{t * us:,.1f}",
                    str(n),
                    f"{t * n * us:,.0f}",
                    f"{part.t * us:,.0f} ({part.bound})",
                    ratio,
                    f"{t * 1e9 / K:.1f}",
                ]
            )
            if small is not None:
                rows[-1].append(f"{small[2][name] * 1e9 / small[1].counts['points']:.1f}")
        head = ["pass", "µs per call", "calls per tick", "µs per tick", "floor µs", "x floor", "ns/point a call"]
        if small is not None:
            head.append(f"the same, base {small[0]}")
            # rows the table left blank for the per-tick passes after the first
            for r in rows:
                if len(r) < len(head):
                    r.append(f"{small[2][r[0]] * 1e9 / small[1].counts['points']:.1f}")
        out.append(table(head, rows))
        out.append(
            f"\nReplayed passes sum to {total * us:,.0f} µs a tick; the solve measured {solve * us:,.0f} µs "
            "(the rest: note_impacts, restitution, the tick's own loops and copies, and the replays' differences)."
        )
        if small is not None:
            ws = working_set(small[1].counts)
            out.append(
                f"\nThe last column: the same passes on a pyramid of base {small[0]} "
                f"({int(small[1].counts['points']):,} points, working set {ws / 2**10:,.0f} KiB: in L2, "
                f"{limits.at(ws, 'copy') / 1e9:.0f} GB/s copy), settled and replayed alike."
            )
    return "\n".join(out) + "\n"


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0], formatter_class=argparse.RawTextHelpFormatter)
    p.add_argument("--base", type=int, default=100, help="boxes at the pyramid's base (default 100: large_pyramid)")
    p.add_argument("--settle", type=int, default=60, help="steps before timing (default 60)")
    p.add_argument("--steps", type=int, default=20, help="timed steps per round (default 20)")
    p.add_argument("--rounds", type=int, default=3, help="rounds; the median is reported (default 3)")
    p.add_argument("--repeats", type=int, default=9, help="calls of each replayed pass (default 9)")
    p.add_argument("--no-passes", action="store_true", help="skip the replay of each pass")
    p.add_argument("--small-base", type=int, default=20, help="a pyramid whose arrays fit in L2 (20; 0: none)")
    p.add_argument("--cc", default=os.environ.get("CC", "gcc"), help="C compiler for machine_limits.c (gcc)")
    p.add_argument("--limits", default=None, help="read the machine's limits from this JSON file, do not measure")
    p.add_argument("--save-limits", default=None, help="write the measured limits to this JSON file")
    p.add_argument("--out", default=None, help="also write the report to this file")
    args = p.parse_args(argv)
    if args.limits:
        limits = Limits(**json.loads(Path(args.limits).read_text()))
    else:
        limits = measure_limits(args.cc)
        if args.save_limits:
            Path(args.save_limits).write_text(json.dumps(limits.__dict__) + "\n")
    scene = measure_scene(args.base, args.settle, args.steps, args.rounds)
    passes = small = None
    if not args.no_passes:
        passes = replay_passes(scene, args.repeats)
        if args.small_base > 0:
            small_scene = measure_scene(args.small_base, args.settle, 1, 1)
            small = (args.small_base, small_scene, replay_passes(small_scene, args.repeats))
    text = report(limits, scene, passes, small)
    print(text)
    if args.out:
        Path(args.out).write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
