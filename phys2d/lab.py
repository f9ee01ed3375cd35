"""The lab: a world (or a recording) on Rerun's viewer in a notebook, to rewind, step and branch.

    lab = phys2d.Lab(phys2d.scenes.pyramid(10))      # or phys2d.Lab("recordings/pyramid-20-pgs.rrd")
    lab.step(120)                                    # the world steps on; the viewer shows every tick
    lab                                              # (last in a cell) the viewer, its controls and tables
    lab.rows_at(lab.tick)                            # the constraint rows of the step into the tick shown
    part = lab.branch_here("naive")                  # the future from the tick shown under another responder

The viewer is ``rerun.notebook.Viewer`` (rerun-notebook), fed by a ``rerun.RecordingStream``
of the lab's own: the world's ticks as the lab steps it (a recording's chunks, for a lab on a
file), and each branch as a recording of its own (the original and the branch side by side, as
``phys2d branch`` writes them). ``Lab.on_event`` is registered with ``rerun.notebook.Viewer.on_event``, so
the lab follows the viewer:

    TimeUpdateEvent       on the ``tick`` timeline: ``Lab.tick`` becomes the tick shown (the
                          logged tick at or before it); on ``sim_time`` (ns) the tick of that
                          time, on ``sweep`` the tick of that solver sweep
    TimelineChangeEvent   the timeline the times come on from now (and its time, converted)
    SelectionChangeEvent  a body picked in a world view: ``Lab.selected`` is its uid. Instance k of
                          ``world/sim/bodies`` is the k-th dynamic body of ``w.bodies`` at the tick
                          shown, instance k of ``world/sim/static`` the k-th static one (the same
                          entity's ``uid`` column and label ``b<uid>`` name it); a run's bodies
                          are under ``runs/<label>/``. Anything else picked leaves it as it was
    PlayEvent, PauseEvent the tables wait while the viewer plays

Beside the viewer: the rows of the step into the tick shown (``rows_at``: body_a, body_b, A_kk,
xi, lo, hi, lam per row, and the residual of each sweep), and the selected body's contacts at
that tick (``contacts_of``). Its controls: the responder and its count, step, play, pause,
and "branch here". Without a notebook (``viewer=False``) the lab works the same, for scripts
and tests; only nothing is shown.
"""

from __future__ import annotations

import html
import json
import os
import uuid
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .recording import schema
from .recording.replay import Parting, ReplayError, Timeline, timeline
from .responders import REGISTRY, make_responder
from .responders.base import Responder
from .world import World

TIMELINES = (schema.TICK, schema.SIM_TIME, schema.SWEEP)  # the timelines the lab follows


@dataclass(eq=False)
class Rows:
    """The constraint rows of one step (the step into ``tick``), in the order the responder met
    them: per row its ``kind`` ('normal', 'friction' or 'joint'), the uids of its bodies
    (``body_a``, ``body_b``), A_kk = J M^-1 J^T, xi (the J V it must reach, m/s) and push (the
    Baumgarte push, m/s: the lecture's target is xi + push), its bounds lo, hi (N s; a friction
    row's are +-mu lambda_n of its normal row, as the sweep left them) and lam (N s) when the
    step ended; ``residuals`` the largest velocity correction of each sweep (m/s); ``note`` if
    the step the rows come from is not the recorded one."""

    tick: int
    responder: str
    kind: np.ndarray
    body_a: np.ndarray
    body_b: np.ndarray
    A_kk: np.ndarray
    xi: np.ndarray
    push: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    lam: np.ndarray
    residuals: np.ndarray
    note: str = ""

    COLUMNS = ("kind", "body_a", "body_b", "A_kk", "xi", "push", "lo", "hi", "lam")

    def __len__(self) -> int:
        return int(self.lam.shape[0])

    def of_body(self, uid: int) -> Rows:
        """The rows on body ``uid``."""
        keep = (self.body_a == uid) | (self.body_b == uid)
        kind, body_a, body_b, A_kk, xi, push, lo, hi, lam = (getattr(self, c)[keep] for c in self.COLUMNS)
        return Rows(
            self.tick, self.responder, kind, body_a, body_b, A_kk, xi, push, lo, hi, lam, self.residuals, self.note
        )

    def table(self, limit: int | None = 40) -> list[list[str]]:
        """Header and rows as text cells (at most ``limit`` rows)."""
        out = [list(self.COLUMNS)]
        for k in range(len(self) if limit is None else min(len(self), limit)):
            out.append(
                [str(self.kind[k]), f"b{self.body_a[k]}", f"b{self.body_b[k]}"]
                + [f"{getattr(self, c)[k]:.4g}" for c in self.COLUMNS[3:]]
            )
        return out

    def __str__(self) -> str:
        cells = self.table()
        widths = [max(len(r[c]) for r in cells) for c in range(len(cells[0]))]
        lines = [f"tick {self.tick}, {self.responder}: {len(self)} rows, residual per sweep (m/s): "
                 + " ".join(f"{r:.3g}" for r in self.residuals)]  # fmt: skip
        lines += ["  " + "  ".join(c.rjust(w) for c, w in zip(r, widths, strict=True)) for r in cells]
        if len(self) > len(cells) - 1:
            lines.append(f"  ... {len(self) - len(cells) + 1} more")
        if self.note:
            lines.append(f"note: {self.note}")
        return "\n".join(lines)

    def _repr_html_(self) -> str:
        return _html_table(
            f"tick {self.tick}: the rows of {self.responder}'s step ({len(self)}); residual per sweep (m/s): "
            + ", ".join(f"{r:.3g}" for r in self.residuals),
            self.table(),
            self.note,
        )


def _html_table(title: str, cells: list[list[str]], note: str = "") -> str:
    head = "".join(f"<th>{html.escape(c)}</th>" for c in cells[0])
    body = "".join("<tr>" + "".join(f"<td>{html.escape(c)}</td>" for c in r) + "</tr>" for r in cells[1:])
    foot = f"<div>{html.escape(note)}</div>" if note else ""
    return f"<div><b>{html.escape(title)}</b><table><tr>{head}</tr>{body}</table>{foot}</div>"


def rows_of_step(world: World, dt: float, responder: Responder | None = None) -> tuple[Rows, World]:
    """Step ``world`` once (dt, s) and keep the rows its responder (``responder`` if given) was
    handed and the impulses it left: the step goes stage by stage (``one_call_tick`` results are
    the same bits). Returns the rows and the world after the step."""
    r = world.responder if responder is None else responder
    kept: dict[str, np.ndarray] = {}
    respond = r.respond

    def watched(ctx: Any) -> Any:
        rows = ctx.rows
        n = rows.lam.shape[0]
        kept.update(
            body_a=rows.body_a[:n].copy(), body_b=rows.body_b[:n].copy(), A_kk=rows.A_kk[:n].copy(),
            xi=rows.xi[:n].copy(), push=rows.push[:n].copy(), lo=rows.lo[:n].copy(), hi=rows.hi[:n].copy(),
            bound_row=rows.bound_row[:n].copy(), mu=rows.mu[:n].copy(),
        )  # fmt: skip
        result = respond(ctx)
        kept["lam"] = rows.lam[:n].copy()
        kept["contacts"] = np.array([2 * ctx.n_contacts])
        return result

    setattr(r, "respond", watched)  # on the instance: the step goes stage by stage  # noqa: B010
    try:
        if responder is not None:
            world.responder = r
        world.step(dt)
    finally:
        delattr(r, "respond")  # (the instance's own, gone: the class's again, and its kernel)  # noqa: B043
    uids = world.body_uids
    n = kept["lam"].shape[0]
    first_joint = int(kept["contacts"][0])
    kind = np.where(np.arange(n) >= first_joint, "joint", np.where(np.arange(n) % 2 == 0, "normal", "friction"))
    lo, hi = kept["lo"].copy(), kept["hi"].copy()
    cone = kept["bound_row"] >= 0  # a friction row: +-mu lambda_n of its normal row
    limit = kept["mu"][cone] * kept["lam"][kept["bound_row"][cone]]
    lo[cone], hi[cone] = -limit, limit
    rows = Rows(
        int(world.tick), r.name, kind, uids[kept["body_a"]], uids[kept["body_b"]], kept["A_kk"], kept["xi"],
        kept["push"], lo, hi, kept["lam"], world.last_step.residuals.copy(),
    )  # fmt: skip
    return rows, world


def rows_at(line: Timeline, tick: int) -> Rows:
    """The rows of the step into ``tick`` of a timeline (a recording's run, or a lab's): the world
    at the tick before, stepped once with the recorded dt and responder, its state hash checked
    against the recorded one."""
    at = line._index(tick)
    if at == 0:
        raise ReplayError(f"tick {tick} is the first of {line.where}: no step led to it")
    world = line.world_at(line.ticks[at - 1])
    from .snapshot import responder_from_spec

    spec = line.responders.get(int(tick))
    responder = responder_from_spec(json.loads(spec)) if spec is not None else None
    rows, world = rows_of_step(world, line.dts[at], responder)
    if world.tick != tick or world.state_hash() != line.hashes[at]:
        rows.note = f"the step does not give the recorded tick {tick} (changed from outside the step there)"
    return rows


@dataclass(eq=False)
class Branch:
    """A branch the lab made: the futures from ``parting.start`` (``original`` and ``branch``
    timelines, kept in memory) and the recording they are shown in."""

    label: str
    parting: Parting
    original: Timeline
    branch: Timeline
    recording_id: str


@dataclass(eq=False)
class _Source:
    """Where the lab's main line comes from: a world it steps, or a recording's run."""

    line: Timeline
    world: World | None  # the world at the line's last tick (None: not made yet, for a recording)
    path: str | None = None
    run: str = ""
    recording_id: str = field(default_factory=lambda: str(uuid.uuid4()))
    application_id: str = "phys2d-lab"


class Lab:
    """A world or a recording in a notebook, on the Rerun viewer (this module's docstring).

    source          a phys2d World (the lab steps it) or the path of a recording (``run``: which
                    run of a file of several); a recording must hold keyframes
    dt              the step the lab takes (s) when it steps a world
    keyframe_every  ticks between the lab's keyframes (its rewinds replay at most this many steps)
    viewer          show the Rerun viewer and the controls (needs rerun-notebook and ipywidgets:
                    ``pip install -e ".[notebook]"``); False: the same lab, nothing shown
    width, height   the viewer's size (px, or "auto")
    """

    def __init__(
        self,
        source: World | str | os.PathLike,
        *,
        run: str | None = None,
        dt: float = 1 / 60,
        keyframe_every: int = 30,
        viewer: bool = True,
        width: int | str = 760,
        height: int | str = 560,
    ) -> None:
        from .validation import check_bool, check_int, positive_float

        self.dt = positive_float(dt, "dt")
        self.keyframe_every = check_int(keyframe_every, "keyframe_every", 1)
        show = check_bool(viewer, "viewer")
        if isinstance(source, World):
            line = Timeline("the lab's world", keyframe_every=self.keyframe_every)
            line.append(source)
            self._source = _Source(line, source)
        elif isinstance(source, (str, os.PathLike)):
            path = os.fspath(source)
            line = timeline(path, run)
            if not line.keyframes:
                raise line.missing_keyframes()
            label = "" if run is None else run
            self._source = _Source(line, None, path, label)
        else:
            raise TypeError(f"source must be a phys2d World or a recording's path, got {type(source).__name__}")
        self.tick = self._source.line.last  # the tick the lab looks at (the viewer's)
        self.timeline_name = schema.TICK  # the viewer's timeline, as its events said
        self.selected: int | None = None  # the uid of the body picked in the viewer
        self._main = self._source.run or "main"  # the main line's run label
        self.recording = self._source.recording_id  # the recording the last event was about
        self.run = self._main  # and its run the lab looks at
        self.playing = False
        self.branches: dict[str, Branch] = {}
        self.responder_name = "naive"  # what "branch here" branches under
        self.count: int | None = None  # its sweeps, passes or sub-steps (None: the responder's default)
        self.events: list[Any] = []  # every event the viewer sent, in order
        self._lines: dict[str, dict[str, Timeline]] = {self.recording: {self._main: self._source.line}}
        self._at: tuple[int, int, World] | None = None  # (id of the line, tick, a world there): the last looked at
        self.viewer: Any = None
        self._recorder: Any = None
        self._stream: Any = None
        self._ui: Any = None
        if show:
            self._show(width, height)

    # -- the world and its future --------------------------------------------------------------
    @property
    def line(self) -> Timeline:
        """The main line: the lab's world's ticks so far (or the recording's run)."""
        return self._source.line

    @property
    def world(self) -> World:
        """The world at the main line's last tick, which ``step`` steps on."""
        if self._source.world is None:
            self._source.world = self.line.world_at(self.line.last)
        return self._source.world

    def step(self, n: int = 1) -> int:
        """Step the world ``n`` ticks on from the main line's last (dt each), log each, and look at
        the last; returns it."""
        from .validation import check_int

        n = check_int(n, "n", 1)
        w = self.world
        for _ in range(n):
            w.step(self.dt)
            self.line.append(w)
            if self._recorder is not None:
                self._recorder.log(w, run=self._run_label())
        if self._recorder is not None:
            self._recorder.flush()
        self.seek(self.line.last)
        return self.line.last

    def _run_label(self) -> str | None:
        """The main line's run as the lab's recorder logs it (a recording's unnamed run: None)."""
        return None if self._source.path is not None and not self._source.run else self._main

    def world_at(self, tick: int, run: str | None = None) -> World:
        """A live World at ``tick`` of the main line (or of a branch's run, ``run``): a copy the
        lab keeps no hold of."""
        line = self._line(run)
        if self._at is not None and self._at[0] == id(line) and self._at[1] == tick:
            return World.from_snapshot(self._at[2].snapshot())
        w = line.world_at(tick)
        self._at = (id(line), int(tick), w)
        return World.from_snapshot(w.snapshot())

    def _line(self, run: str | None) -> Timeline:
        """The timeline of ``run`` (default: the one looked at) of the recording looked at, or of any."""
        label = self.run if run is None else run
        lines = self._lines.get(self.recording, {})
        if label in lines:
            return lines[label]
        for other in self._lines.values():
            if label in other:
                return other[label]
        known = sorted({r for ls in self._lines.values() for r in ls})
        raise ValueError(f"run must be one of {', '.join(repr(r) for r in known)}, got {label!r}")

    def rows_at(self, tick: int | None = None, run: str | None = None) -> Rows:
        """The rows of the step into ``tick`` (default: the tick shown) of ``run`` (default: the run
        looked at last), with each sweep's residual (``Rows``)."""
        return rows_at(self._line(run), self.tick if tick is None else tick)

    def contacts_of(self, uid: int | None = None, tick: int | None = None, run: str | None = None) -> list[dict]:
        """The contacts of body ``uid`` (default: the selected one) at ``tick`` (default: the tick
        shown): per contact its partner's uid, point (m), normal (from a to b), separation (m),
        lambda_n and lambda_t (N s) and whether the cache warm started it."""
        uid = self.selected if uid is None else uid
        if uid is None:
            return []
        w = self.world_at(self.tick if tick is None else tick, run)
        c, uids = w.contacts, w.body_uids
        out = []
        for k in np.flatnonzero((uids[c.body_a] == uid) | (uids[c.body_b] == uid)):
            a, b = int(uids[c.body_a[k]]), int(uids[c.body_b[k]])
            out.append(
                dict(
                    partner=b if a == uid else a, point=c.point[k].copy(), normal=c.normal[k].copy(),
                    separation=float(c.separation[k]), lambda_n=float(c.lambda_n[k]),
                    lambda_t=float(c.lambda_t[k]), warm_started=bool(c.warm_started[k]),
                )
            )  # fmt: skip
        return out

    def branch_here(
        self,
        responder: str | Responder | None = None,
        count: int | None = None,
        steps: int | None = None,
        on_tick: Callable[[World, World], None] | None = None,
    ) -> Parting:
        """The future from the tick shown under ``responder`` (a registered name or a Responder;
        default ``responder_name``, with ``count`` sweeps, passes or sub-steps), beside the one the
        lab has, ``steps`` ticks on (default: to the line's end, or 120 from its last tick); shown
        in a recording of its own (runs ``original`` and the responder's name); ``on_tick(original,
        branch)`` after each tick (and once at the start), to record them elsewhere too. Returns
        where they part."""
        name = self.responder_name if responder is None else responder
        count = self.count if count is None and responder is None else count
        if isinstance(name, Responder):
            r, label = name, name.name
        elif isinstance(name, str):
            if name not in REGISTRY:
                raise ValueError(f"responder must be one of {', '.join(REGISTRY)} or a Responder, got {name!r}")
            r, label = make_responder(name, count), name + (f"-{count}" if count is not None else "")
        else:
            raise TypeError(f"responder must be a responder name or a phys2d Responder, got {type(name).__name__}")
        line = self._line(None)
        at = self.tick
        if steps is None and at >= line.last:
            steps = 120
        label = f"{label}".replace(" ", "-")
        key = f"branch-{at}-{label}"
        original = Timeline(f"the original from tick {at}", keyframe_every=self.keyframe_every)
        other = Timeline(f"the branch under {label} from tick {at}", keyframe_every=self.keyframe_every)
        recorder, recording_id = self._branch_recorder(key, label)

        def each(a: World, b: World) -> None:
            original.append(a)
            other.append(b)
            if recorder is not None:
                recorder.log(a, run="original")
                recorder.log(b, run=label)
            if on_tick is not None:
                on_tick(a, b)

        parting = line.branch(at, r, steps, each)
        if recorder is not None:
            recorder.close()
        self.branches[key] = Branch(label, parting, original, other, recording_id)
        self._lines[recording_id] = {"original": original, label: other}
        self._refresh()
        return parting

    def _branch_recorder(self, name: str, label: str) -> tuple[Any, str]:
        recording_id = str(uuid.uuid4())
        if self.viewer is None:
            return None, recording_id
        import rerun as rr

        from .recording import Recorder

        application = f"phys2d-lab-{name}"  # (a layout is an application's: one per branch, with its runs)
        stream = rr.RecordingStream(application, recording_id=recording_id)
        self.viewer.add_recording(stream)
        self.viewer.set_application_blueprint(application, _layout(["original", label], _bounds(self.world)))
        rec = Recorder(
            None, recording=stream, name=name, contact_series=False, keyframe_every=self.keyframe_every, blueprint=False
        )
        return rec, recording_id

    # -- following the viewer ------------------------------------------------------------------------
    def on_event(self, event: Any) -> None:
        """Follow the viewer (``rerun.notebook.Viewer.on_event`` calls it): time updates, timeline
        changes, selections, play and pause (this module's docstring)."""
        self.events.append(event)
        kind = getattr(event, "type", None)
        recording = getattr(event, "recording_id", None)
        if kind == "play":
            self.playing = True
            return
        if kind == "pause":
            self.playing = False
        elif kind == "timeline_change":
            self.timeline_name = str(event.timeline)
            self._follow_time(recording, float(event.time))
        elif kind == "time_update":
            self._follow_time(recording, float(event.time))
        elif kind == "selection_change":
            self._follow_selection(recording, list(event.items))
        if not self.playing:
            self._refresh()

    def _follow_time(self, recording: str | None, time: float) -> None:
        if recording in self._lines and recording != self.recording:  # another recording shown: a branch
            self.recording = recording
            lines = self._lines[recording]
            self.run = self.run if self.run in lines else next(reversed(lines))
        tick = self.tick_of(self.timeline_name, time, self._line(None))
        if tick is not None:
            self.tick = tick

    def tick_of(self, timeline_name: str, time: float, line: Timeline | None = None) -> int | None:
        """The logged tick a time on a viewer's timeline shows: on ``tick`` the tick at or before it,
        on ``sim_time`` (ns, as the viewer sends it) the tick at or before that time, on ``sweep``
        the tick of that solver sweep; None on a timeline of another kind."""
        line = self.line if line is None else line
        ticks = np.asarray(line.ticks)
        if timeline_name == schema.TICK:
            at = int(np.searchsorted(ticks, time + 1e-9, side="right")) - 1
        elif timeline_name == schema.SIM_TIME:
            at = int(np.searchsorted(np.asarray(line.times), time / 1e9 + 1e-6, side="right")) - 1  # (ns truncated)
        elif timeline_name == schema.SWEEP:
            at = int(np.searchsorted(np.cumsum(line.sweeps), time + 0.5, side="left"))
        else:
            return None
        return int(ticks[min(max(at, 0), ticks.size - 1)])

    def _follow_selection(self, recording: str | None, items: list) -> None:
        if not items:
            self.selected = None
            return
        lines = self._lines.get(recording or "", self._lines.get(self.recording, {}))
        for item in items:
            path, instance = getattr(item, "entity_path", None), getattr(item, "instance_id", None)
            if path is None or instance is None:
                continue
            run, rest = _run_of(path)
            run = self._main if run is None else run
            if rest not in (schema.BODIES, schema.STATIC) or run not in lines:
                continue
            if recording in self._lines:
                self.recording = recording
            w = self.world_at(self.tick, run)
            static = np.asarray(w.body_static)
            rows = np.flatnonzero(static if rest == schema.STATIC else ~static)
            if 0 <= instance < rows.size:
                self.run, self.selected = run, int(w.body_uids[rows[instance]])
                return

    # -- the controls -----------------------------------------------------------------------------
    def seek(self, tick: int) -> None:
        """Look at ``tick``, and move the viewer's time there."""
        self.tick = int(tick)
        if self.viewer is not None:
            self.viewer.set_time_ctrl(sequence=int(tick), timeline=schema.TICK)
        self._refresh()

    def play(self) -> None:
        """Play the viewer from the tick shown."""
        self.playing = True
        if self.viewer is not None:
            self.viewer.set_time_ctrl(play=True)

    def pause(self) -> None:
        """Pause the viewer."""
        self.playing = False
        if self.viewer is not None:
            self.viewer.set_time_ctrl(play=False)
        self._refresh()

    def _show(self, width: int | str, height: int | str) -> None:
        """The viewer, fed by a stream of the lab's own, with the controls and the tables."""
        try:
            import ipywidgets as widgets  # type: ignore[import-untyped]
            import rerun as rr
            from rerun.notebook import Viewer
        except ImportError as e:
            raise ImportError(
                f'the lab shows the Rerun viewer in a notebook: pip install -e ".[notebook]" ({e})'
            ) from None
        from .recording import Recorder

        src = self._source
        if src.path is not None:  # a recording: its chunks, into a stream of its ids
            from rerun.chunk import RrdReader

            entry = RrdReader(src.path).recordings()[0]
            src.application_id, src.recording_id = entry.application_id, entry.recording_id
            self._lines = {src.recording_id: self._lines[self.recording]}
            self.recording = src.recording_id
        self._stream = rr.RecordingStream(src.application_id, recording_id=src.recording_id)
        self.viewer = Viewer(width=width, height=height, recording=self._stream)  # type: ignore[arg-type]
        self.viewer.on_event(self.on_event)
        shown: list[str | None] = [src.run or None] if src.path is not None else [self._main]
        framed = _bounds(self.line.world_at(self.line.first))
        self.viewer.set_application_blueprint(src.application_id, _layout(shown, framed))
        if src.path is not None:
            self._stream.send_chunks(list(RrdReader(src.path).store().stream()))
            self._recorder = Recorder(
                None, recording=self._stream, keyframe_every=self.keyframe_every, flush_every=1, blueprint=False
            )
        else:
            self._recorder = Recorder(
                None, recording=self._stream, name="lab", keyframe_every=self.keyframe_every, blueprint=False
            )
            assert src.world is not None
            self._recorder.log(src.world, run=self._main)
            self._recorder.flush()
        self._ui = self._controls(widgets)

    def _controls(self, widgets: Any) -> tuple[Any, Any, Any, Any]:
        """(the controls, the tables, the rows' table, the contacts' table): the ipywidgets (module
        ``widgets``) beside the viewer, the buttons wired to the lab's step, play, pause and branch_here."""
        responder = widgets.Dropdown(options=list(REGISTRY), value=self.responder_name, description="responder")
        count = widgets.BoundedIntText(value=10, min=1, max=1000, description="count")
        steps = widgets.BoundedIntText(value=1, min=1, max=100000, description="steps")
        buttons = {name: widgets.Button(description=name) for name in ("step", "play", "pause", "branch here")}
        rows_out, contacts_out, said = widgets.HTML(), widgets.HTML(), widgets.HTML()

        def chosen(change: Any) -> None:
            self.responder_name = responder.value
            self.count = count.value if REGISTRY[responder.value].count else None

        responder.observe(chosen, "value")
        count.observe(chosen, "value")
        buttons["step"].on_click(lambda _: self.step(steps.value))
        buttons["play"].on_click(lambda _: self.play())
        buttons["pause"].on_click(lambda _: self.pause())

        def branch(_: Any) -> None:
            said.value = "<br>".join(html.escape(line) for line in self.branch_here().lines())

        buttons["branch here"].on_click(branch)
        controls = widgets.HBox([responder, count, steps, *buttons.values()])
        tables = widgets.VBox([said, rows_out, contacts_out], layout=widgets.Layout(overflow="auto"))
        return controls, tables, rows_out, contacts_out

    def _refresh(self) -> None:
        """The tables beside the viewer, for the tick shown and the body selected."""
        if self._ui is None:
            return
        rows_out, contacts_out = self._ui[2], self._ui[3]
        try:
            rows_out.value = self.rows_at()._repr_html_()
        except ValueError as e:  # (the first tick: no step led to it)
            rows_out.value = f"<div>{html.escape(str(e))}</div>"
        if self.selected is None:
            contacts_out.value = ""
            return
        contacts = self.contacts_of()
        cells = [["partner", "separation (mm)", "lambda_n", "lambda_t", "warm"]] + [
            [f"b{c['partner']}", f"{1e3 * c['separation']:.3g}", f"{c['lambda_n']:.4g}", f"{c['lambda_t']:.4g}",
             str(c["warm_started"])]
            for c in contacts
        ]  # fmt: skip
        contacts_out.value = _html_table(f"body b{self.selected}: {len(contacts)} contacts at tick {self.tick}", cells)

    def display(self) -> None:
        """Show the lab in the notebook cell: its controls, the viewer, and beside it the tables."""
        if self._ui is None:
            raise ValueError("this lab was made with viewer=False: there is nothing to show")
        from IPython.display import display

        display(self._ui[0])
        self.viewer.display()
        display(self._ui[1])
        self._refresh()

    def _ipython_display_(self) -> None:
        self.display()

    def __repr__(self) -> str:
        src = self._source.path or "a world"
        return (
            f"<Lab of {src}: ticks {self.line.first}-{self.line.last}, at tick {self.tick} ({self.run}), "
            f"{len(self.branches)} branches, selected {'b' + str(self.selected) if self.selected is not None else '-'}>"
        )


def _bounds(w: World) -> tuple[float, float, float, float]:
    """(x min, x max, y min, y max) of a world's moving bodies, padded (m): what the world view frames."""
    dynamic = ~np.asarray(w.body_static)
    pts = w.x[dynamic] if dynamic.any() else w.x
    if not len(pts):
        return -5.0, 5.0, -1.0, 5.0
    pad = 1.0 + 0.1 * float(np.ptp(pts, axis=0).max())
    lo, hi = pts.min(axis=0) - pad, pts.max(axis=0) + pad
    return float(lo[0]), float(hi[0]), min(float(lo[1]), -0.5), float(hi[1])


def _layout(labels: list[str | None], bounds: tuple[float, float, float, float]) -> Any:
    """The lab's layout for runs ``labels`` (None: a file's unnamed run): a world view per run beside
    plots overlaying them (kinetic energy, deepest overlap, residual per sweep), the time panel's
    tick timeline below. Built with ``rerun.blueprint`` and handed to the notebook viewer
    (``rerun.notebook.Viewer.set_application_blueprint``: a viewer fed by a callback takes its layout so)."""
    import rerun.blueprint as rrb

    def prefix(label: str | None) -> str:
        return "/" + schema.run_prefix(label)

    x0, x1, y0, y1 = bounds
    framed = rrb.VisualBounds2D(x_range=[x0, x1], y_range=[-y1, -y0])  # (the 2D view is y-down; physics is flipped)
    worlds = [
        rrb.Spatial2DView(
            name=f"world {label or ''}".strip(), origin=f"{prefix(label)}{schema.WORLD}", visual_bounds=framed
        )
        for label in labels
    ]
    plots = [
        rrb.TimeSeriesView(name=name, origin="/", contents=[f"+ {prefix(label)}{path}" for label in labels])
        for name, path in (
            ("kinetic energy (J)", f"{schema.STATS_ROOT}/energy/kinetic"),
            (f"deepest overlap ({schema.PENETRATION_UNIT})", f"{schema.STATS_ROOT}/max_penetration"),
            ("solver residual per sweep, log10 (m/s)", schema.RESIDUAL),
        )
    ]
    left = worlds[0] if len(worlds) == 1 else rrb.Grid(*worlds)
    return rrb.Blueprint(
        rrb.Horizontal(left, rrb.Vertical(*plots), column_shares=[3, 2]),
        rrb.BlueprintPanel(state="collapsed"),
        rrb.SelectionPanel(state="collapsed"),
        rrb.TimePanel(state="collapsed", timeline=schema.TICK),
    )


def _run_of(entity: str) -> tuple[str | None, str]:
    """(run label or None, the path within the run) of an entity path."""
    path = entity.lstrip("/")
    head = schema.RUNS_ROOT + "/"
    if path.startswith(head):
        label, _, rest = path[len(head) :].partition("/")
        return label, rest
    return None, path


__all__ = ["Branch", "Lab", "Rows", "TIMELINES", "rows_at", "rows_of_step"]
