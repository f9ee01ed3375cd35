"""What a PGS sweep costs per row, and why the order of the rows sets it (issue 11).

    PYTHONPATH=. python benchmarks/sweep_order.py            # writes benchmarks/SWEEP_ORDER.md
    PYTHONPATH=. python benchmarks/sweep_order.py --quick    # smoke run, prints only

The lecture's PGS visits its rows one at a time in pair order: a contact's normal
row, its friction row, then the manifold's next point, then the next pair, which
shares a body with this one more often than not. Each row reads the velocities the
row before it wrote, so a sweep is one long chain of dependent arithmetic: load V,
J_k V (three additions deep), the clamp, V += M^-1 J_k^T delta, store V, and only
then the next row can start. The processor cannot overlap rows, and the time per
row is this chain's latency, not its arithmetic.

The script captures one step's rows (PGS(iterations=10), step 61 of the scene) and
times ten sweeps of ``pgs.sweep`` over them, medians of repeats, in three orders:

- **pair order**: the rows as the lecture's PGS visits them;
- **dependency levels**: the same rows re-ordered so that a row comes after every
  earlier row (in pair order) that shares a moving body with it, and otherwise as
  early as possible (a wavefront). Rows that share no moving body commute, so this
  order gives bit-identical lambda and V (checked here): the lecture's result,
  with neighbouring rows that the processor could overlap;
- **colour order**: the rows of the same scene built for a PGS that visits pairs
  colour by colour (``constraints.order``), as SoftStep does: another Gauss-Seidel
  order (another result: on pyramid_40 PGS in colour order moves 0.38 m in 30 s
  against 0.09 m in pair order, measured while writing this);
- **no dependencies**: the same rows, each given a pair of bodies of its own (a
  different problem): nothing waits for anything, so this is what a row costs
  when only the processor's throughput limits it.

If pair order were bound by its chain of dependencies, the last three would be
much faster than the first. pymunk's whole step on the same scene, in the same
run, is printed beside them.
"""

from __future__ import annotations

import argparse
import datetime as dt
import os
import platform
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from numba import njit

BENCH_DIR = Path(__file__).resolve().parent
sys.path.insert(0, str(BENCH_DIR))

import engines  # noqa: E402

import phys2d  # noqa: E402
from phys2d import scenes  # noqa: E402
from phys2d.pipeline.records import ROW_FIELDS, arrays_of, new_rows  # noqa: E402
from phys2d.responders.pgs import apply_impulses, per_unit_A, sweep  # noqa: E402

SCENES = {"pyramid_20": 20, "pyramid_40": 40}
ORDERS = {
    "pair": "pair order (the lecture)",
    "levels": "dependency levels",
    "colour": "colour order",
    "apart": "no dependencies",
}


class ColourPGS(phys2d.PGS):
    """The lecture's PGS, visiting pairs colour by colour (for this measurement only)."""

    colour_order = True


@njit(cache=True)
def dependency_levels(body_a, body_b, moves):
    """Rows 0..R-1 sorted by dependency level: row k's level is one more than the highest
    level of the earlier rows that share a moving body with it. Returns (order, levels)."""
    n = body_a.shape[0]
    last = np.zeros(moves.shape[0], np.int64)  # the level of the last row that touched each body
    level = np.empty(n, np.int64)
    top = 0
    for k in range(n):
        a, b = body_a[k], body_b[k]
        lv = 1 + max(last[a] if moves[a] else 0, last[b] if moves[b] else 0)
        if moves[a]:
            last[a] = lv
        if moves[b]:
            last[b] = lv
        level[k] = lv
        top = max(top, lv)
    return np.argsort(level, kind="mergesort"), top


def captured_rows(size: int, responder: phys2d.PGS):
    """The rows, warm-start lambda and velocities PGS.respond is handed on step 61."""
    w = scenes.pyramid(size, responder)
    for _ in range(60):
        w.step(engines.DT)
    seen = {}
    respond = type(responder).respond

    def spy(self, ctx):
        seen["rows"], seen["lam"], seen["V"] = ctx.rows, ctx.rows.lam.copy(), ctx.V.copy()
        return respond(self, ctx)

    type(responder).respond = spy
    w.one_call_tick = False  # stage by stage, so the step goes through respond
    try:
        w.step(engines.DT)
    finally:
        type(responder).respond = respond
    return seen["rows"], seen["lam"], seen["V"], ~w.body_static


def ten_sweeps(rows, lam0, V0, visit, bodies=None):
    """Warm start, then time 10 sweeps over ``visit``; returns (seconds, lambda, V).
    ``bodies``: (body_a, body_b, V0) to use instead of the rows' own."""
    r = rows
    body_a, body_b = (r.body_a, r.body_b) if bodies is None else bodies[:2]
    lam, V = lam0.copy(), (V0 if bodies is None else bodies[2]).copy()
    fields = dict(zip(ROW_FIELDS, arrays_of(r, ROW_FIELDS)))
    fields.update(body_a=body_a, body_b=body_b, lam=lam)
    rec = new_rows(tuple(fields.values()))
    visit = visit.astype(r.normal_row.dtype)  # as pgs_solve visits them
    apply_impulses(rec, V)
    hat = per_unit_A(rec)
    t = time.perf_counter()
    for _ in range(10):
        sweep(hat, V, visit)
    return time.perf_counter() - t, lam, V


def measure(name: str, size: int, repeats: int) -> dict:
    rows, lam0, V0, moves = captured_rows(size, phys2d.PGS(iterations=10, warm_start=True))
    c_rows, c_lam0, c_V0, _ = captured_rows(size, ColourPGS(iterations=10, warm_start=True))
    n = len(rows)
    pair = np.arange(n)
    levels, depth = dependency_levels(rows.body_a, rows.body_b, moves)
    _, lam_p, V_p = ten_sweeps(rows, lam0, V0, pair)
    _, lam_l, V_l = ten_sweeps(rows, lam0, V0, levels)
    own = np.arange(2 * n, dtype=np.int32)  # every row a pair of bodies of its own, resting
    apart = (own[0::2], own[1::2], np.zeros((2 * n, 3)))
    identical = bool(np.array_equal(lam_p, lam_l) and np.array_equal(V_p, V_l))
    pm = engines.PymunkAdapter(engines.pyramid(size))
    for _ in range(61):
        pm.step()
    times: dict[str, list[float]] = {"pair": [], "levels": [], "colour": [], "apart": [], "pymunk": []}
    for _ in range(repeats):
        times["pair"].append(ten_sweeps(rows, lam0, V0, pair)[0])
        times["levels"].append(ten_sweeps(rows, lam0, V0, levels)[0])
        times["colour"].append(ten_sweeps(c_rows, c_lam0, c_V0, np.arange(len(c_rows)))[0])
        times["apart"].append(ten_sweeps(rows, lam0, V0, pair, apart)[0])
        t = time.perf_counter()
        for _ in range(10):
            pm.step()
        times["pymunk"].append((time.perf_counter() - t) / 10)
    med = {k: statistics.median(v) for k, v in times.items()}
    return {
        "scene": name,
        "rows": n,
        "depth": int(depth),
        "identical": identical,
        "us": {k: med[k] * 1e6 for k in ORDERS},
        "ns_per_row": {k: med[k] / (10 * n) * 1e9 for k in ORDERS},
        "pymunk_us": med["pymunk"] * 1e6,
    }


def report(results: list[dict], header: list[str]) -> str:
    lines = [
        *header,
        "",
        "| scene | rows | dependency levels (rows per level) | order | 10 sweeps, µs | ns per row visit |",
    ]
    lines.append("| --- | --- | --- | --- | --- | --- |")
    for r in results:
        for order, label in ORDERS.items():
            lines.append(
                f"| {r['scene']} | {r['rows']} | {r['depth']} ({r['rows'] / r['depth']:.1f}) | {label} | "
                f"{r['us'][order]:.0f} | {r['ns_per_row'][order]:.1f} |"
            )
        lines.append(f"| {r['scene']} | | | pymunk's whole step | {r['pymunk_us']:.0f} | |")
    lines.append("")
    for r in results:
        same = "bit-identical" if r["identical"] else "NOT identical (a bug)"
        lines.append(f"- {r['scene']}: dependency-level order against pair order: lambda and V {same}.")
    return "\n".join(lines) + "\n"


def kept_sections(path: Path) -> str:
    """The sections written by hand after the table (from the first '## ' heading on), which a
    new run keeps."""
    if not path.exists():
        return ""
    text = path.read_text()
    at = text.find("\n## ")
    return "" if at < 0 else text[at:]


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--repeats", type=int, default=None, help="repeats (default 31, quick 3)")
    p.add_argument("--quick", action="store_true", help="smoke run: prints, writes nothing")
    p.add_argument("--out", type=Path, default=BENCH_DIR / "SWEEP_ORDER.md")
    args = p.parse_args()
    repeats = args.repeats or (3 if args.quick else 31)
    load0 = os.getloadavg()[0]
    results = [measure(name, size, repeats) for name, size in SCENES.items()]
    load1 = os.getloadavg()[0]
    try:
        rev = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
    except OSError:
        rev = "?"
    header = [
        "# A PGS sweep's cost per row, by visiting order (issue 11)",
        "",
        "- command: `python benchmarks/sweep_order.py`",
        f"- date: {dt.datetime.now(dt.timezone.utc):%Y-%m-%d %H:%M} UTC, checkout {rev}",
        f"- machine: {platform.machine()}, {os.cpu_count()} cores, python {platform.python_version()}",
        f"- load average (1 min) at the start and the end: {load0:.2f} and {load1:.2f}",
        f"- method: the rows of step 61, 10 sweeps of `pgs.sweep`, medians of {repeats} repeats (see the docstring)",
    ]
    text = report(results, header)
    print(text)
    if not args.quick:
        args.out.write_text(text + kept_sections(args.out))


if __name__ == "__main__":
    main()
