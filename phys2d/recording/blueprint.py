"""Building the blueprint: the layout a recording opens with.

One run: the world (with the contact table in a second tab) beside four plots,
lambda and penetration of the plotted contacts, the residual of every sweep and
the energies. Several runs (``phys2d compare``): a world per run beside plots that
overlay the runs, one colour and legend entry per run. Plot titles carry the units
(Rerun 0.41 has no axis titles).

The layout is written as the rows rerun-sdk 0.41's ``rerun.blueprint`` classes write
(views, containers, the viewport and the panels, on the ``blueprint`` timeline), built
here as arrow arrays so that the writer never imports ``rerun`` (``native``).
"""

from __future__ import annotations

import uuid
from dataclasses import dataclass

import pyarrow as pa

from . import native, schema


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

# container kinds and panel states as rerun's blueprint components number them
TABS, HORIZONTAL, VERTICAL, GRID = 1, 2, 3, 4
COLLAPSED = 2
FOLLOWING = 3

Row = tuple[str, dict, bool]  # entity, components, static


def _bp(archetype: str, field: str, component_type: str) -> native.Descriptor:
    return native.archetype_field(archetype, field, component_type, blueprint=True)


VIEW_CLASS = _bp("ViewBlueprint", "class_identifier", "rerun.blueprint.components.ViewClass")
VIEW_NAME = _bp("ViewBlueprint", "display_name", "rerun.components.Name")
VIEW_ORIGIN = _bp("ViewBlueprint", "space_origin", "rerun.blueprint.components.ViewOrigin")
VIEW_QUERY = _bp("ViewContents", "query", "rerun.blueprint.components.QueryExpression")
VISUAL_BOUNDS = _bp("VisualBounds2D", "range", "rerun.blueprint.components.VisualBounds2D")
LEGEND_VISIBLE = _bp("PlotLegend", "visible", "rerun.components.Visible")
CONTAINER_KIND = _bp("ContainerBlueprint", "container_kind", "rerun.blueprint.components.ContainerKind")
CONTAINER_CONTENTS = _bp("ContainerBlueprint", "contents", "rerun.blueprint.components.IncludedContent")
CONTAINER_ACTIVE_TAB = _bp("ContainerBlueprint", "active_tab", "rerun.blueprint.components.ActiveTab")
CONTAINER_COL_SHARES = _bp("ContainerBlueprint", "col_shares", "rerun.blueprint.components.ColumnShare")
ROOT_CONTAINER = _bp("ViewportBlueprint", "root_container", "rerun.blueprint.components.RootContainer")
PANEL_STATE = _bp("PanelBlueprint", "state", "rerun.blueprint.components.PanelState")
TIME_PANEL_STATE = _bp("TimePanelBlueprint", "state", "rerun.blueprint.components.PanelState")
TIME_PANEL_TIMELINE = _bp("TimePanelBlueprint", "timeline", "rerun.blueprint.components.TimelineName")
TIME_PANEL_PLAY = _bp("TimePanelBlueprint", "play_state", "rerun.blueprint.components.PlayState")

_RANGE = pa.list_(pa.field("item", pa.float64(), nullable=False), 2)
_BOUNDS_TYPE = pa.struct([pa.field("x_range", _RANGE, nullable=False), pa.field("y_range", _RANGE, nullable=False)])
_UUID_TYPE = pa.list_(pa.field("item", pa.uint8(), nullable=False), 16)


def _strings(*values: str) -> pa.Array:
    return pa.array(list(values), pa.string())


def _u8(value: int) -> pa.Array:
    return pa.array([value], pa.uint8())


class _Layout:
    """Collects the rows of one blueprint."""

    def __init__(self) -> None:
        self.rows: list[Row] = []

    def view(
        self,
        kind: str,
        name: str,
        origin: str,
        queries: list[str] | None = None,
        bounds: tuple[float, float, float, float] | None = None,
        legend: bool = True,
    ) -> str:
        path = f"view/{uuid.uuid4()}"
        self.rows.append((f"{path}/ViewContents", {VIEW_QUERY: _strings(*(queries or ["$origin/**"]))}, False))
        self.rows.append(
            (path, {VIEW_CLASS: _strings(kind), VIEW_NAME: _strings(name), VIEW_ORIGIN: _strings(origin)}, False)
        )
        if bounds is not None:
            x0, x1, y0, y1 = bounds
            rng = pa.array([{"x_range": [x0, x1], "y_range": [-y1, -y0]}], _BOUNDS_TYPE)  # the view is y-down
            self.rows.append((f"{path}/VisualBounds2D", {VISUAL_BOUNDS: rng}, False))
        if not legend:
            self.rows.append((f"{path}/PlotLegend", {LEGEND_VISIBLE: pa.array([False], pa.bool_())}, False))
        return path

    def container(
        self, kind: int, contents: list[str], active_tab: str | None = None, col_shares: list[float] | None = None
    ) -> str:
        ident = uuid.uuid4()
        path = f"container/{ident}"
        comps = {CONTAINER_KIND: _u8(kind), CONTAINER_CONTENTS: _strings(*contents)}
        if active_tab is not None:
            comps[CONTAINER_ACTIVE_TAB] = _strings(active_tab)
        if col_shares is not None:
            comps[CONTAINER_COL_SHARES] = pa.array(col_shares, pa.float32())
        self.rows.append((path, comps, False))
        self.root = ident
        return path


def _world(layout: _Layout, r: RunView) -> str:
    return layout.view(
        "2D",
        f"world {r.label}" if r.label else "world",
        f"/{schema.run_prefix(r.label)}{schema.WORLD}",
        bounds=r.bounds,
    )


def _plot(layout: _Layout, key: str, paths: list[str], legend: bool = True) -> str:
    return layout.view("TimeSeries", TITLES[key], "/", queries=[f"+ /{p}" for p in paths], legend=legend)


def build(runs: list[RunView]) -> list[Row]:
    """The blueprint for a file holding ``runs``, as rows for ``native.Stream.blueprint``."""
    layout = _Layout()
    if runs:
        if len(runs) == 1:
            r = runs[0]
            p = schema.run_prefix(r.label)
            world = _world(layout, r)
            table = layout.view("Dataframe", "contact table", f"/{p}{schema.CONTACTS}")
            left = layout.container(TABS, [world, table], active_tab=world)
            plots = []
            if r.plotted:
                plots += [
                    _plot(layout, "lambda", [f"{p}{schema.LAMBDA}/**"]),
                    _plot(layout, "penetration", [f"{p}{schema.PENETRATION}/**"]),
                ]
            if r.has_joints:
                plots.append(_plot(layout, "reaction", [f"{p}{schema.REACTION}/**"], legend=False))
            plots += [
                _plot(layout, "residual", [f"{p}{schema.RESIDUAL}"]),
                _plot(layout, "energy", [f"{p}{schema.STATS_ROOT}/energy/**"]),
            ]
        else:
            left = layout.container(GRID, [_world(layout, r) for r in runs])
            prefixes = [schema.run_prefix(r.label) for r in runs]
            plots = [
                _plot(layout, "max_penetration", [f"{p}{schema.STATS_ROOT}/max_penetration" for p in prefixes]),
                _plot(layout, "kinetic", [f"{p}{schema.STATS_ROOT}/energy/kinetic" for p in prefixes]),
                _plot(layout, "residual", [f"{p}{schema.RESIDUAL}" for p in prefixes]),
                _plot(layout, "contacts", [f"{p}{schema.STATS_ROOT}/contact_count" for p in prefixes]),
            ]
        right = layout.container(VERTICAL, plots)
        layout.container(HORIZONTAL, [left, right], col_shares=[3.0, 2.0])
        root = pa.FixedSizeListArray.from_arrays(pa.array(list(layout.root.bytes), pa.uint8()), type=_UUID_TYPE)
        layout.rows += [
            ("viewport", {ROOT_CONTAINER: root}, False),
            ("blueprint_panel", {PANEL_STATE: _u8(COLLAPSED)}, False),
            ("selection_panel", {PANEL_STATE: _u8(COLLAPSED)}, False),
            ("time_panel", {TIME_PANEL_STATE: _u8(COLLAPSED), TIME_PANEL_TIMELINE: _strings(schema.TICK)}, False),
            ("time_panel", {TIME_PANEL_PLAY: _u8(FOLLOWING)}, True),
        ]
    else:
        layout.rows.append(("time_panel", {TIME_PANEL_TIMELINE: _strings(schema.TICK)}, False))
    return layout.rows
