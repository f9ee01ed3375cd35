"""Lesson 11: Catto's figures, reproduced with a sweep - iterations against mass ratio.

Claim (Erin Catto, "Understanding Constraints", GDC 2014): Gauss-Seidel needs more
iterations as the mass ratio grows. Two circles resting on the ground reach 95 % of
the exact impulse after about 5 iterations for equal masses, 3 for light on heavy
(0.5 kg on 1 kg, his "ratio 2") and about 50 for heavy on light (10 kg on 1 kg); his
regression is iterations = 3 x ratio + 2; a stack of 4 circles needs 20.

Every number below comes from one sweep: phys2d.sweep over lessons/11_catto.toml.
The same grid runs alone with `phys2d sweep lessons/11_catto.toml`, on local
processes or on a Dask cluster (--scheduler tcp://HOST:PORT), with the same metrics
bit for bit. A run is the scene circle_stack: circles of radius 0.5 m, touching, at
rest on the ground, 1 kg each but the top one (mass_ratio kg).

The exact impulse: at rest and touching, the rigid contact problem of a tick has one
solution, every circle staying at rest, so the contact under circle i passes the
weight of circle i and of all above it: m_above g dt. A run's load error is the
largest |lambda - m_above g dt| / (m_above g dt) over the contacts (the sweep table's
load_error_first_tick); "95 % of the exact impulse" is a load error of at most 5 %.
The first tick starts from lambda = 0, as nothing is cached yet.

A second method beside the engine: Gauss-Seidel on the 1D chain A = J M^-1 J^T,
written out below in a few lines. The circles touch along vertical normals through
their centres, so nothing turns and no friction acts: the 2D problem is this 1D one.
For two circles the error shrinks by rho = r / (1 + r) per sweep (r = top mass /
bottom mass), so the count is about ln 20 / ln(1 + 1/r), close to 3 r + 1.5 for
large r: Catto's regression, its 3 being ln 20, the 95 % target.

Then what came after 2014, in the same sweep: warm starting (pgs: each tick starts
from the last tick's impulses) and sub-steps (soft-step, Box2D v3: each sub-step one
soft sweep and one relax sweep, the contacts stiff damped springs). Neither helps on
the first tick: nothing is cached yet, and a spring needs time to load. Nor is the
load the difference later on: with too few sweeps the stack sinks until Baumgarte's
push makes up the missing impulse, so with a few sweeps per tick even cold PGS
carries its load within 5 % after half a second. The difference is how far it sank. The second table counts the
fewest sweeps (or sub-steps) per tick with which every contact carries its load
within 5 % through the second half-second AND no overlap ever grows past 5 mm (the
slop PGS leaves alone) in the 1 s run.

In the viewer: runs ratio10-* (10 kg on 1 kg) and stack4-* under pgs-cold, pgs (4
sweeps per tick) and soft-step (2 sub-steps, also 4 sweeps); plot
contacts/lambda to see the impulses build up tick by tick; figures/ holds the two
plots, also saved as PNG next to the recording.
"""

import math
import os
from dataclasses import replace

import _common as c
import numpy as np

import phys2d
import phys2d.sweeps

TOLERANCE = 0.05  # 95 % of the exact impulse
OVERLAP = 0.005  # m: PGS's slop, the overlap Baumgarte leaves alone
G = 10.0  # m/s^2, the scenes' gravity
CASES = (  # label, circles, top mass (kg), Catto's figure, his regression 3 r + 2 (None: not a pair)
    ("equal, 1 kg on 1 kg", 2, 1.0, 5, 5.0),
    ("light on heavy, 0.5 kg on 1 kg", 2, 0.5, 3, 3.5),
    ("heavy on light, 10 kg on 1 kg", 2, 10.0, 50, 32.0),
    ("stack of 4 circles, 1 kg each", 4, 1.0, 20, None),
)


def load_error_1d(masses, sweeps: int, top_first: bool = False) -> float:
    """Load error after ``sweeps`` Gauss-Seidel sweeps from lambda = 0 on the 1D chain, bottom contact first
    (the engine's order here), or top first.

    Contact k joins body k - 1 (the ground for k = 0) and body k: J_k V = v_k - v_(k-1).
    After gravity every v = -g dt, so A lambda = -J V = (g dt, 0, ..., 0).
    """
    masses = np.asarray(masses, dtype=float)
    n = masses.size
    J = np.eye(n) - np.eye(n, k=-1)
    A = J @ np.diag(1.0 / masses) @ J.T
    b = np.zeros(n)
    b[0] = G * c.DT
    exact = G * c.DT * np.cumsum(masses[::-1])[::-1]
    lam = np.zeros(n)
    for _ in range(sweeps):
        for k in range(n - 1, -1, -1) if top_first else range(n):
            lam[k] = max(0.0, lam[k] + (b[k] - A[k] @ lam) / A[k, k])
    return float(np.max(np.abs(lam - exact) / exact))


def count_1d(masses, tol: float = TOLERANCE, top_first: bool = False, most: int = 1000) -> int:
    """The fewest Gauss-Seidel sweeps that bring the 1D load error within ``tol``."""
    for k in range(1, most + 1):
        if load_error_1d(masses, k, top_first) <= tol:
            return k
    raise ValueError(f"no count up to {most} reaches {tol}")


def stack(size: int, ratio: float) -> list:
    return [1.0] * (size - 1) + [ratio]


def fewest(rows, column: str, overlap: float | None = None):
    """The smallest count among rows (count -> row) whose ``column`` is within the tolerance
    (and whose deepest overlap is within ``overlap`` m, when given), or None."""
    ok = [
        k
        for k, r in rows.items()
        if r[column] <= TOLERANCE and (overlap is None or (r["max_overlap"] <= overlap and r["outcome"] == "stood"))
    ]
    return min(ok) if ok else None


def show(value, most: int | None = None) -> str:
    """A count, "-" when there is none, or "> most" when none up to ``most`` was enough."""
    if value is None:
        return "-" if most is None else f"> {most}"
    return f"{value:g}"


def main() -> None:
    args = c.options(__doc__)
    c.claim(
        "the iterations Gauss-Seidel needs to reach 95 % of the exact impulse grow with the mass ratio as "
        "3 x ratio + 2 (Catto, GDC 2014); warm starting and sub-steps (after 2014) hold the load with far "
        "fewer per tick"
    )

    grids = phys2d.sweeps.load_toml(os.path.join(c.LESSONS, "11_catto.toml"))
    if args.quick:  # fewer counts and mass ratios; the first-tick tables still reach every count they need
        first, regression, hold = grids[:2], grids[2], grids[3:]
        grids = (
            [replace(g, iterations=tuple(range(1, 35)), substeps=tuple(range(1, 9))) for g in first]
            + [replace(regression, mass_ratio=(0.5, 1, 2, 5, 10), iterations=tuple(range(1, 35)))]
            + [replace(g, iterations=tuple(range(1, 21)), substeps=tuple(range(1, 9))) for g in hold]
        )
    os.makedirs(args.out, exist_ok=True)
    result = phys2d.sweep(grids, out=os.path.join(args.out, "11_catto_figures.parquet"), resume=False, progress=False)
    print(f"sweep: {result.ran} runs on {result.where} in {result.seconds:.1f} s -> {result.path}")

    runs: dict = {}  # (circles, top mass, responder, steps) -> {count: row}
    for r in result.rows:
        key = (int(r["size"]), r["mass_ratio"], r["responder"], r["steps"])
        runs.setdefault(key, {})[r["iterations"] if r["iterations"] is not None else r["substeps"]] = r

    def of(size, ratio, responder, steps=60):
        return runs[(size, ratio, responder, steps)]

    rows1, rows2 = [], []
    names = ("pgs-cold", "pgs", "soft-step")
    for label, size, ratio, catto, line in CASES:
        analysis = count_1d(stack(size, ratio))
        first = [fewest(of(size, ratio, name, 1), "load_error_first_tick") for name in names]
        rows1.append([label, show(catto), show(line), show(analysis), *map(show, first)])
        held = [
            show(fewest(of(size, ratio, name), "load_error_second_half", OVERLAP), max(of(size, ratio, name)))
            for name in names
        ]
        rows2.append([label, *held])

    print(
        f"first tick from rest, lambda from 0: sweeps until every contact is within {TOLERANCE:.0%} of the "
        "exact impulse (soft-step: sub-steps; '-' none in the sweep)"
    )
    c.table(["case", "Catto 2014 (about)", "3 r + 2", "1D Gauss-Seidel", "pgs-cold", "pgs (warm)", "soft-step"], rows1)
    print(
        f"holding the load: fewest sweeps (soft-step: sub-steps, 2 sweeps each) per tick with every contact within "
        f"{TOLERANCE:.0%} of its load through the second half-second and no overlap past {1e3 * OVERLAP:g} mm "
        f"in 1 s"
    )
    c.table(["case", "pgs-cold", "pgs (warm)", "soft-step"], rows2)

    # Catto's line against the analysis: where the 95 % count comes from
    ratios = sorted({key[1] for key in runs if key[3] == 1})
    measured = {r: fewest(of(2, r, "pgs-cold", 1), "load_error_first_tick") for r in ratios}
    analysis = {r: count_1d(stack(2, r)) for r in ratios}
    print("regression over mass ratios (first tick, pgs-cold; 1D analysis; Catto's 3 r + 2; ln 20 / ln(1 + 1/r)):")
    c.table(
        ["top / bottom mass r", "engine", "1D Gauss-Seidel", "3 r + 2", "ln 20 / ln(1 + 1/r)"],
        [
            [
                f"{r:g}",
                show(measured[r]),
                show(analysis[r]),
                f"{3 * r + 2:g}",
                f"{math.log(20) / math.log1p(1 / r):.1f}",
            ]
            for r in ratios
        ],
    )
    slope, intercept = np.polyfit([r for r in ratios if r >= 1], [measured[r] for r in ratios if r >= 1], 1)
    print(f"least-squares line through the engine's counts for r >= 1: {slope:.2f} r + {intercept:.2f}")
    strict = {r: count_1d(stack(2, r), 0.01) for r in (1.0, 10.0)}
    print(
        f"why Catto's 50 at 10:1 is off his own line: with a 99 % target the 1D count at 10:1 is {strict[10.0]}, "
        f"near his 50, but then equal masses need {strict[1.0]}, not his 5; no one target gives both, and "
        f"3 x 10 + 2 = 32 is what we measure"
    )

    other = [count_1d(stack(size, ratio), top_first=True) for _, size, ratio, _, _ in CASES]
    print(
        f"visiting the top contact first instead (a solver's choice), the 1D counts are "
        f"{', '.join(map(str, other))}: the order moves a count by a sweep or three, not to 50"
    )
    pairs = [(r[4], r[3]) for r in rows1] + [(show(measured[r]), show(analysis[r])) for r in ratios]
    same = sum(a == b for a, b in pairs)
    print(
        f"2D against 1D: the circles touch along vertical normals through their centres, so nothing turns and "
        f"no friction acts; the engine's counts equal the 1D analysis in {same} of {len(pairs)} cases"
    )

    figures = plot(args, ratios, measured, analysis, of)
    rid = c.new_recording_id()
    seconds = 1.0 if args.quick else 3.0
    with c.recorder(args, __file__, "lesson 11: Catto's figures", recording_id=rid) as rec:
        for tag, size, ratio in (("ratio10", 2, 10.0), ("stack4", 4, 1.0)):
            for name, count in (("pgs-cold", 4), ("pgs", 4), ("soft-step", 2)):
                w = phys2d.sweeps.circle_stack(size, phys2d.make_responder(name, count), mass_ratio=ratio)
                c.simulate(w, seconds, rec, f"{tag}-{name}")
    c.add_images(rec.path, rid, {f"figures/{os.path.splitext(os.path.basename(p))[0]}": p for p in figures})
    print("figures: " + ", ".join(figures))

    heavy = rows1[2]
    held = rows2[2]
    print(
        f"TAKEAWAY: on the first tick the count follows 3 r + 2 (engine {heavy[4]} at 10 kg on 1 kg, the 1D "
        f"analysis {heavy[3]}, Catto's line 32; his 'about 50' is off his own line); warm starting carries the "
        f"work over ticks, so the 10:1 pair holds its load without sinking past {1e3 * OVERLAP:g} mm with "
        f"{held[2]} sweeps per tick where cold PGS needs {held[1]}, and the soft step with {held[3]} sub-steps"
    )
    c.done(rec)


def plot(args, ratios, measured, analysis, of) -> list:
    """The two figures as PNG files next to the recording; returns their paths."""
    import matplotlib

    if not c.in_notebook():
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    paths = []
    fig, ax = plt.subplots(figsize=(7, 4.5), layout="constrained")
    r = np.linspace(min(ratios), max(ratios), 200)
    ax.plot(r, 3 * r + 2, "k--", label="Catto's regression 3 r + 2")
    ax.plot(
        r,
        [math.log(20) / math.log1p(1 / x) for x in r],
        ":",
        color="tab:gray",
        label="ln 20 / ln(1 + 1/r) (Gauss-Seidel rate)",
    )
    ax.plot(
        ratios,
        [analysis[x] for x in ratios],
        "s",
        mfc="none",
        ms=9,
        color="tab:blue",
        label="1D Gauss-Seidel (second method)",
    )
    ax.plot(ratios, [measured[x] for x in ratios], "o", color="tab:orange", label="phys2d, first tick (sweep)")
    ax.plot([1, 0.5, 10], [5, 3, 50], "x", ms=10, mew=2, color="tab:red", label="Catto 2014 (reported)")
    ax.set_xlabel("mass ratio r = top mass / bottom mass")
    ax.set_ylabel("sweeps to 95 % of the exact impulse")
    ax.set_title("Two circles on the ground: iterations against mass ratio")
    ax.legend()
    ax.grid(alpha=0.3)
    paths.append(os.path.join(args.out, "11_iterations_vs_mass_ratio.png"))
    fig.savefig(paths[-1], dpi=100, bbox_inches="tight")
    if c.in_notebook():
        plt.show()
    plt.close(fig)

    fig, axes = plt.subplots(2, 2, figsize=(10, 7.5), sharey=True, layout="constrained")
    for ax, (label, size, ratio, _, _) in zip(axes.flat, CASES):
        for name, colour in (("pgs-cold", "tab:red"), ("pgs", "tab:blue"), ("soft-step", "tab:green")):
            rows = of(size, ratio, name)
            counts = sorted(rows)
            ax.semilogy(
                counts,
                [max(1e3 * rows[k]["max_overlap"], 1e-3) for k in counts],
                "-o",
                ms=3,
                color=colour,
                label=name + (" (sub-steps)" if name == "soft-step" else ""),
            )
        ax.axhline(1e3 * OVERLAP, color="k", lw=0.8, label=f"{1e3 * OVERLAP:g} mm (PGS slop)")
        ax.set_title(label)
        ax.set_xlabel("sweeps per tick (soft-step: sub-steps)")
        ax.set_ylabel("deepest overlap in 1 s (mm; 0.001: none)")
        ax.grid(alpha=0.3)
    axes.flat[0].legend(fontsize=8)
    fig.suptitle("After 2014: warm starting and sub-steps hold the load with fewer sweeps, sinking less")
    paths.append(os.path.join(args.out, "11_after_2014.png"))
    fig.savefig(paths[-1], dpi=100, bbox_inches="tight")
    if c.in_notebook():
        plt.show()
    plt.close(fig)
    return paths


if __name__ == "__main__":  # the sweep's worker processes import this file: run only as the main script
    main()
