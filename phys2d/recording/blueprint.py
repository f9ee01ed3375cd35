"""Building the blueprint: the layout a recording opens with.

One run: the world (with the contact table in a second tab) beside four plots,
lambda and penetration of the plotted contacts, the residual of every sweep and
the energies. Several runs (``phys2d compare``): a world per run beside plots that
overlay the runs, one colour and legend entry per run. Plot titles carry the units
(Rerun 0.41 has no axis titles).
"""

from __future__ import annotations

from dataclasses import dataclass

import rerun.blueprint as rrb

from . import schema


@dataclass(frozen=True)
class RunView:
    """What the blueprint needs to know of a run."""

    label: str | None
    bounds: tuple[float, float, float, float] | None  # xmin, xmax, ymin, ymax, m
    plotted: bool  # has per-contact series
    has_joints: bool


TITLES = {
    "lambda": f"impulse per contact: λn (dark), λt (light) ({schema.LAMBDA_UNIT})",
    "penetration": f"penetration per contact ({schema.PENETRATION_UNIT})",
    "residual": "solver residual per sweep, log10 (m/s)",
    "energy": "energy (J): kinetic; potential and total in the legend",
    "reaction": "joint reactions (N s)",
    "max_penetration": f"deepest overlap per run ({schema.PENETRATION_UNIT})",
    "kinetic": "kinetic energy per run (J)",
    "contacts": "contacts per run",
}


def _world(r: RunView) -> rrb.Spatial2DView:
    bounds = None
    if r.bounds is not None:
        x0, x1, y0, y1 = r.bounds
        bounds = rrb.VisualBounds2D(x_range=[x0, x1], y_range=[-y1, -y0])  # the view is y-down
    return rrb.Spatial2DView(name=f"world {r.label}" if r.label else "world",
                             origin=f"/{schema.run_prefix(r.label)}{schema.WORLD}", visual_bounds=bounds)


def _plot(key: str, paths: list[str], legend: bool = True) -> rrb.TimeSeriesView:
    return rrb.TimeSeriesView(name=TITLES[key], origin="/", contents=[f"+ /{p}" for p in paths],
                              plot_legend=None if legend else rrb.PlotLegend(visible=False))


def build(runs: list[RunView]) -> rrb.Blueprint:
    """The blueprint for a file holding ``runs``."""
    if not runs:
        return rrb.Blueprint(rrb.TimePanel(timeline=schema.TICK))
    if len(runs) == 1:
        r = runs[0]
        p = schema.run_prefix(r.label)
        table = rrb.DataframeView(name="contact table", origin=f"/{p}{schema.CONTACTS}")
        left: rrb.Tabs | rrb.Grid = rrb.Tabs(_world(r), table, active_tab=0)
        plots = []
        if r.plotted:
            plots += [_plot("lambda", [f"{p}{schema.LAMBDA}/**"]),
                      _plot("penetration", [f"{p}{schema.PENETRATION}/**"])]
        if r.has_joints:
            plots.append(_plot("reaction", [f"{p}{schema.REACTION}/**"], legend=False))
        plots += [_plot("residual", [f"{p}{schema.RESIDUAL}"]), _plot("energy", [f"{p}{schema.STATS_ROOT}/energy/**"])]
    else:
        left = rrb.Grid(*[_world(r) for r in runs])
        prefixes = [schema.run_prefix(r.label) for r in runs]
        plots = [_plot("max_penetration", [f"{p}{schema.STATS_ROOT}/max_penetration" for p in prefixes]),
                 _plot("kinetic", [f"{p}{schema.STATS_ROOT}/energy/kinetic" for p in prefixes]),
                 _plot("residual", [f"{p}{schema.RESIDUAL}" for p in prefixes]),
                 _plot("contacts", [f"{p}{schema.STATS_ROOT}/contact_count" for p in prefixes])]
    return rrb.Blueprint(
        rrb.Horizontal(left, rrb.Vertical(*plots), column_shares=[3, 2]),
        rrb.BlueprintPanel(state="collapsed"),
        rrb.SelectionPanel(state="collapsed"),
        rrb.TimePanel(state="collapsed", timeline=schema.TICK, play_state="following"),
    )
