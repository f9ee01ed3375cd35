"""The lab (``phys2d.Lab``): following the viewer, its rows, its branches, and a real browser.

The handlers are fed the viewer's own event objects (``rerun.notebook``'s event classes, and
the JSON the viewer sends, through the widget's message path); the browser test runs the
real notebook widget (rerun-notebook's widget.js and viewer wasm) in headless Chromium, on a
page that stands in for Jupyter's widget manager, and checks that the lab follows what the
viewer does. Skipped where Chromium (or websocket-client) is missing, saying why.
"""

from __future__ import annotations

import http.server
import json
import os
import queue
import threading
import time

import numpy as np
import pytest

import phys2d
from phys2d.lab import Lab, rows_at
from phys2d.recording import Recorder
from phys2d.recording.replay import ReplayError
from tests.strategies import fingerprint

notebook = pytest.importorskip("rerun.notebook", reason="the lab needs rerun-notebook (the notebook extra)")
if not notebook.HAS_NOTEBOOK:  # pragma: no cover
    pytest.skip("the lab needs rerun-notebook and ipywidgets", allow_module_level=True)

DT = 1 / 60


def event(kind: str, recording_id: str, **fields):
    """One of the viewer's own event objects (``rerun.notebook``'s classes)."""
    common = dict(application_id="phys2d-lab", recording_id=recording_id, segment_id=None)
    classes = {
        "time": notebook.TimeUpdateEvent,
        "timeline": notebook.TimelineChangeEvent,
        "selection": notebook.SelectionChangeEvent,
        "play": notebook.PlayEvent,
        "pause": notebook.PauseEvent,
    }
    return classes[kind](**common, **fields)


def picked(path: str, instance: int | None):
    return [notebook.EntitySelectionItem(entity_path=path, instance_id=instance)]


@pytest.fixture(scope="module")
def lab() -> Lab:
    """A lab on a 4-row pyramid (a ground and 10 boxes), 40 ticks stepped."""
    lab = Lab(phys2d.scenes.pyramid(4), viewer=False, keyframe_every=15)
    lab.step(40)
    return lab


def test_time_updates_on_the_tick_timeline_move_the_lab(lab):
    rid = lab.recording
    for time_shown, tick in ((25.0, 25), (25.7, 25), (0.0, 0), (400.0, 40)):
        lab.on_event(event("time", rid, time=time_shown))
        assert lab.tick == tick


def test_a_change_of_timeline_is_followed_and_its_times_converted(lab):
    rid = lab.recording
    t10 = lab.world_at(10).time  # s
    ns = float(int(t10 * 1e9))  # the viewer's sim_time is whole nanoseconds, truncated
    lab.on_event(event("timeline", rid, timeline="sim_time", time=ns))
    assert lab.timeline_name == "sim_time" and lab.tick == 10
    lab.on_event(event("time", rid, time=float(int(lab.world_at(33).time * 1e9))))
    assert lab.tick == 33
    # the sweep timeline: a running count of PGS sweeps, 10 a tick from tick 1 on
    lab.on_event(event("timeline", rid, timeline="sweep", time=13.0))
    assert lab.timeline_name == "sweep" and lab.tick == 2  # sweeps 10-19 are tick 2's
    lab.on_event(event("time", rid, time=399.0))
    assert lab.tick == 40
    lab.on_event(event("timeline", rid, timeline="log_time", time=1e18))  # a timeline of another kind
    assert lab.tick == 40
    lab.on_event(event("timeline", rid, timeline="tick", time=5.0))
    assert lab.tick == 5


def test_a_selection_picks_the_body_of_that_instance(lab):
    rid = lab.recording
    lab.on_event(event("time", rid, time=20.0))
    w = lab.world_at(20)
    dynamic = np.flatnonzero(~np.asarray(w.body_static))
    for k in (0, 3, 9):
        lab.on_event(event("selection", rid, items=picked("/runs/main/world/sim/bodies", k)))
        assert lab.selected == int(w.body_uids[dynamic[k]])
    lab.on_event(event("selection", rid, items=picked("/runs/main/world/sim/static", 0)))
    assert lab.selected == 0  # the ground
    lab.on_event(event("selection", rid, items=picked("/runs/main/world/sim/contacts", 2)))
    assert lab.selected == 0  # a contact picked: not a body, the selection stays
    lab.on_event(event("selection", rid, items=picked("/runs/main/world/sim/bodies", None)))
    assert lab.selected == 0  # the whole entity: no body
    view = notebook.ViewSelectionItem(view_id="v", view_name="world")
    lab.on_event(event("selection", rid, items=[view]))
    assert lab.selected == 0
    lab.on_event(event("selection", rid, items=[]))
    assert lab.selected is None
    lab.on_event(event("play", rid))
    assert lab.playing
    lab.on_event(event("pause", rid))
    assert not lab.playing


def test_the_rows_are_those_the_step_solved(lab):
    """rows_at(tick): the step into the tick again, its rows as the responder had them: each contact's
    normal row holds its lambda_n (in solve order), the bounds hold, the residuals are the step's."""
    w = lab.world_at(30)
    rows = lab.rows_at(30)
    k = len(w.contacts)
    order = w.last_step.solve_order
    assert len(rows) == 2 * k and not rows.note
    assert np.array_equal(rows.lam[0::2], w.contacts.lambda_n[order])
    assert np.array_equal(rows.lam[1::2], w.contacts.lambda_t[order])
    assert np.array_equal(rows.residuals, w.last_step.residuals)
    assert np.all(rows.lo <= rows.lam) and np.all(rows.lam <= rows.hi) and np.all(rows.A_kk > 0)
    uids = w.body_uids
    assert np.array_equal(rows.body_a[0::2], uids[w.contacts.body_a[order]])
    assert set(rows.kind) == {"normal", "friction"}
    assert "tick 30, pgs: 40 rows" in str(rows) or str(rows).startswith(f"tick 30, pgs: {2 * k} rows")
    mine = rows.of_body(1)
    assert len(mine) and np.all((mine.body_a == 1) | (mine.body_b == 1))
    with pytest.raises(ReplayError, match="tick 0 is the first .* no step led to it"):
        lab.rows_at(0)


def test_the_selected_bodys_contacts(lab):
    w = lab.world_at(30)
    lab.tick, lab.selected = 30, 2
    got = lab.contacts_of()
    c, uids = w.contacts, w.body_uids
    mine = (uids[c.body_a] == 2) | (uids[c.body_b] == 2)
    assert len(got) == int(mine.sum()) > 0
    assert sorted(g["lambda_n"] for g in got) == sorted(c.lambda_n[mine].tolist())
    assert {g["partner"] for g in got} <= set(uids.tolist()) - {2}


def test_a_branch_is_a_run_the_lab_follows(lab):
    lab.tick = 20
    part = lab.branch_here("naive", steps=15)
    assert part.start == 20 and part.ticks == 15
    branch = lab.branches["branch-20-naive"]
    assert branch.branch.ticks == list(range(20, 36)) and branch.original.ticks == list(range(20, 36))
    assert fingerprint(lab.world_at(30, "original")) == fingerprint(lab.world_at(30, "main"))  # the same future
    rid = branch.recording_id
    lab.on_event(event("time", rid, time=28.0))
    assert lab.recording == rid and lab.tick == 28
    lab.on_event(event("selection", rid, items=picked("/runs/naive/world/sim/bodies", 0)))
    assert lab.run == "naive" and lab.selected == 1
    rows = lab.rows_at()  # the naive take's step into tick 28
    assert rows.responder == "naive" and rows.tick == 28 and not rows.note
    with pytest.raises(ValueError, match="responder must be one of"):
        lab.branch_here("nope")


def test_a_lab_on_a_recording_reads_the_same_rows(tmp_path, lab):
    path = tmp_path / "p.rrd"
    w = phys2d.scenes.pyramid(4)
    with Recorder(path, keyframe_every=15) as rec:
        rec.log(w)
        for _ in range(40):
            w.step(DT)
            rec.log(w)
    on_file = Lab(path, viewer=False)
    assert on_file.tick == 40 and on_file.run == "main"
    a, b = on_file.rows_at(30), rows_at(lab.line, 30)
    for name in a.COLUMNS:
        assert np.array_equal(getattr(a, name), getattr(b, name)), name
    assert on_file.step(5) == 45  # past the recording's end, the lab steps on
    for _ in range(5):
        w.step(DT)
    assert fingerprint(on_file.world_at(45)) == fingerprint(w)


def test_bad_sources_are_refused_in_one_line(tmp_path):
    with pytest.raises(TypeError, match="source must be a phys2d World or a recording's path"):
        Lab(42, viewer=False)  # type: ignore[arg-type]
    with pytest.raises(FileNotFoundError, match="no such recording"):
        Lab(tmp_path / "missing.rrd", viewer=False)
    path = tmp_path / "none.rrd"
    with Recorder(path, keyframe_every=0) as rec:
        rec.log(phys2d.scenes.pyramid(2))
    with pytest.raises(ReplayError, match="holds no keyframes"):
        Lab(path, viewer=False)
    with pytest.raises(ValueError, match="dt must be"):
        Lab(phys2d.scenes.pyramid(2), viewer=False, dt=0.0)


def test_the_viewer_widget_hands_its_events_to_the_lab():
    """With the viewer: the JSON the viewer's page sends goes through rerun-notebook's own parsing
    (the widget's message handler) to Lab.on_event."""
    lab = Lab(phys2d.scenes.pyramid(3), viewer=True)
    lab.step(12)
    widget = lab.viewer._viewer
    raw = {"application_id": "phys2d-lab", "recording_id": lab.recording, "segment_id": None}
    widget._handle_custom_msg(json.dumps({**raw, "type": "time_update", "time": 7.0}), [])
    assert lab.tick == 7 and isinstance(lab.events[-1], notebook.TimeUpdateEvent)
    item = {"type": "entity", "entity_path": "/runs/main/world/sim/bodies", "instance_id": 4}
    widget._handle_custom_msg(json.dumps({**raw, "type": "selection_change", "items": [item]}), [])
    assert lab.selected == 5  # the 5th dynamic body: uid 5 (the ground is uid 0)
    assert lab._ui is not None  # the controls and tables are built


# -- a real browser ------------------------------------------------------------------------------------
class _Page:
    """A page that stands in for Jupyter's widget manager: it renders rerun-notebook's widget.js
    (the viewer's wasm served beside it) with a model whose messages go to and from this process
    over HTTP on 127.0.0.1: what the widget sends is handed to the Python widget's message
    handler, what the Python widget sends (its comm) is queued for the page."""

    HTML = """<!doctype html><html><body style="margin:0;background:#222">
<div id="viewer" style="width:1200px;height:720px"></div>
<script type="module">
import widget from "/widget.js";
const handlers = {};
const state = {_width: 1200, _height: 720, _url: null, _panel_states: null, _fallback_token: null, _theme: "dark"};
const model = {
  get: (k) => state[k],
  on: (ev, f) => { (handlers[ev] = handlers[ev] || []).push(f); },
  send: (content) => fetch("/event", {method: "POST",
    body: typeof content === "string" ? content : JSON.stringify(content)}),
};
widget.render({model, el: document.getElementById("viewer")});
async function poll() {
  for (;;) {
    const r = await fetch("/next");
    if (r.status === 200) {  // every message queued: [content, bytes of its buffer] each, buffers one after another
      const list = JSON.parse(r.headers.get("X-Messages"));
      const buf = await r.arrayBuffer();
      let at = 0;
      for (const [msg, n] of list) {
        const buffers = n ? [new DataView(buf.slice(at, at + n))] : [];
        at += n;
        for (const f of handlers["msg:custom"] || []) f(JSON.parse(msg), buffers);
      }
    } else {
      await new Promise((done) => setTimeout(done, 50));
    }
  }
}
poll();
</script></body></html>"""

    def __init__(self, widget) -> None:
        from rerun_notebook import STATIC_DIR

        self.widget = widget
        self.out: queue.Queue = queue.Queue()
        page, static = self.HTML.encode(), STATIC_DIR
        out = self.out

        def send(data=None, buffers=None, **_) -> None:  # the widget's comm: what it sends goes to the page
            content = data["content"] if isinstance(data, dict) and "content" in data else data
            out.put((json.dumps(content), b"".join(bytes(b) for b in (buffers or []))))

        widget.comm.send = send  # (outside a kernel the comm is a stand-in that sends nowhere)
        handle = widget._handle_custom_msg

        class Handler(http.server.BaseHTTPRequestHandler):
            def do_GET(self) -> None:  # noqa: N802 - the http.server API
                if self.path == "/next":  # every message queued, at once (the page's loop waits on a busy viewer)
                    taken = []
                    while True:
                        try:
                            taken.append(out.get_nowait())
                        except queue.Empty:
                            break
                    if not taken:
                        self.send_response(204)
                        self.end_headers()
                        return
                    listed = json.dumps([[msg, len(body)] for msg, body in taken])
                    self._send(b"".join(body for _, body in taken), "application/octet-stream", {"X-Messages": listed})
                elif self.path in ("/", "/index.html"):
                    self._send(page, "text/html")
                elif self.path in ("/widget.js", "/re_viewer_bg.wasm"):
                    kind = "text/javascript" if self.path.endswith(".js") else "application/wasm"
                    self._send((static / self.path[1:]).read_bytes(), kind)
                else:
                    self.send_response(404)
                    self.end_headers()

            def do_POST(self) -> None:  # noqa: N802
                text = self.rfile.read(int(self.headers.get("Content-Length", 0))).decode()
                handle(text, [])
                self.send_response(204)
                self.end_headers()

            def _send(self, body: bytes, kind: str, extra: dict | None = None) -> None:
                self.send_response(200)
                self.send_header("Content-Type", kind)
                self.send_header("Content-Length", str(len(body)))
                for k, v in (extra or {}).items():
                    self.send_header(k, v)
                self.end_headers()
                self.wfile.write(body)

            def log_message(self, *args) -> None:
                pass

        self.server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.url = f"http://127.0.0.1:{self.server.server_address[1]}/"
        threading.Thread(target=self.server.serve_forever, daemon=True).start()

    def close(self) -> None:
        self.server.shutdown()
        self.server.server_close()


def test_the_lab_follows_the_viewer_in_a_real_browser():
    """The lab's viewer in Chromium: it loads the lab's stream and draws the world; moved to tick 10
    by the lab, it reports the tick; playing, it reports each tick it shows, and the lab follows."""
    from tests import webview

    if webview.chromium() is None:
        pytest.skip("needs chromium (apt-get install chromium) to run the viewer's page")
    pytest.importorskip("websocket", reason="needs websocket-client to drive chromium")
    pytest.importorskip("PIL", reason="needs Pillow to read the screenshot")
    from phys2d.recording import schema

    lab = Lab(phys2d.scenes.pyramid(4), viewer=True)
    lab.step(60)
    page = _Page(lab.viewer._viewer)
    timeout = float(os.environ.get("PHYS2D_WEB_TIMEOUT", "180"))
    t0 = time.monotonic()

    def wait_for(what: str, found, since: int = 0) -> list:
        """The events (from the ``since``-th on) that ``found`` picks, once there is one."""
        while True:
            seen = [e for e in lab.events[since:] if found(e)]
            if seen:
                return seen
            kinds = sorted({getattr(e, "type", "?") for e in lab.events})
            assert time.monotonic() - t0 < timeout, f"no {what} from the viewer in {timeout:.0f} s (saw {kinds})"
            time.sleep(0.2)

    try:
        with webview.Browser() as browser:
            browser.navigate(page.url)
            opened = wait_for("recording", lambda e: e.type == "recording_open")
            assert opened[0].recording_id == lab.recording  # the lab's own stream, loaded
            wait_for("tick 60", lambda e: e.type == "time_update" and e.time == 60.0)  # it follows the stream
            lab.seek(10)
            wait_for("tick 10", lambda e: e.type == "time_update" and e.time == 10.0)
            assert lab.tick == 10
            rgb = browser.screenshot()
            since = len(lab.events)
            lab.play()  # the viewer plays the ticks: it reports each one it shows
            wait_for("play", lambda e: e.type == "play", since)
            wait_for("a tick past 20", lambda e: e.type == "time_update" and e.time > 20.0, since)
            since = len(lab.events)
            lab.pause()
            wait_for("pause", lambda e: e.type == "pause", since)
            time.sleep(0.5)
            shot = os.environ.get("PHYS2D_SCREENSHOT")
            if shot:
                from PIL import Image

                Image.fromarray(browser.screenshot()).save(shot)
    finally:
        page.close()
    updates = [e for e in lab.events if e.type == "time_update"]
    assert all(e.recording_id == lab.recording for e in updates)
    assert lab.tick == int(updates[-1].time) and 20 < lab.tick <= 60  # at the tick the viewer showed last
    body = [c for k, _, c in schema.ANNOTATIONS if k == schema.CLASS_BODY][0]
    world = rgb[40:600, : int(0.55 * webview.WIDTH)]
    assert int(webview.near(world, body).sum()) > 2000  # the pyramid's outlines are drawn
