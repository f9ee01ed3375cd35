"""The `phys2d` command, run as a user runs it: a subprocess of `python -m phys2d`."""

from __future__ import annotations

import base64
import json
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import time
import urllib.request

import numpy as np
import pytest

import phys2d
from phys2d.recording import playback

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def phys2d_cmd(*args: str, cwd, timeout: float = 300) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": REPO + os.pathsep + os.environ.get("PYTHONPATH", "")}
    env.pop("PHYS2D_DEBUG", None)
    return subprocess.run([sys.executable, "-m", "phys2d", *args], cwd=cwd, env=env, capture_output=True,
                          text=True, timeout=timeout)


def verify(path) -> None:
    import rerun_cli

    exe = os.path.join(os.path.dirname(rerun_cli.__file__), "rerun")
    out = subprocess.run([exe, "rrd", "verify", str(path)], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr


def test_scenes_lists_every_stock_scene_with_its_size_meaning(tmp_path):
    out = phys2d_cmd("scenes", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    lines = out.stdout.splitlines()
    for name, (_, meaning) in phys2d.scenes.SCENES.items():
        assert any(line.startswith(name + " ") and line.endswith(meaning) for line in lines), name


def test_run_writes_the_default_recording_and_says_how_to_open_it(tmp_path):
    out = phys2d_cmd("run", "pyramid", "--size", "4", "--steps", "60", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    path = tmp_path / "recordings" / "pyramid.rrd"
    assert path.is_file()
    assert f"phys2d view {os.path.join('recordings', 'pyramid.rrd')}" in out.stdout
    assert "tick" not in out.stderr  # no progress bar when stderr is not a terminal
    verify(path)
    rec = playback.load(path)
    assert list(rec.tick) == list(range(61))  # tick 0 (as built) and 60 steps
    assert rec.x.shape == (61, 11, 2)  # ground + 4 + 3 + 2 + 1 boxes
    # the recording is of the same simulation the library runs
    w = phys2d.scenes.pyramid(4)
    for _ in range(60):
        w.step(1 / 60)
    assert np.array_equal(rec.x[-1], w.x)
    assert "PGS(iterations=10, warm_start=True" in rec.properties["run"]["responder"]


def test_run_options_reach_the_engine(tmp_path):
    out = phys2d_cmd("run", "vertical_stack", "--size", "3", "--steps", "20", "--dt", "0.01",
                     "--responder", "pgs-cold", "--iterations", "4", "--out", "sub/stack.rrd", "--progress",
                     cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    assert "tick 20/20" in out.stderr  # the progress bar, on stderr
    rec = playback.load(tmp_path / "sub" / "stack.rrd")
    np.testing.assert_allclose(rec.time[-1], 0.2, atol=1e-9)
    assert set(rec.iterations[1:]) == {4}
    assert not rec.contacts.warm_started.any()
    assert rec.properties["run"]["responder_name"] == "pgs-cold"


def test_run_with_the_responders_beyond_the_lecture(tmp_path):
    for name, expected in (("pgs-block", "block=True"), ("soft-step", "SoftStep(substeps=2")):
        out = phys2d_cmd("run", "vertical_stack", "--size", "3", "--steps", "10", "--responder", name,
                         *(["--iterations", "2"] if name == "soft-step" else []), "--out", f"{name}.rrd",
                         cwd=tmp_path)
        assert out.returncode == 0, out.stderr
        rec = playback.load(tmp_path / f"{name}.rrd")
        assert expected in rec.properties["run"]["responder"]


def test_run_without_series_keeps_the_contact_table(tmp_path):
    out = phys2d_cmd("run", "vertical_stack", "--size", "3", "--steps", "15", "--no-series", "--out", "s.rrd",
                     cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    rec = playback.load(tmp_path / "s.rrd")
    assert rec.series_keys("lambda") == [] and len(rec.contacts.key) > 0


def test_run_without_recording_writes_nothing(tmp_path):
    out = phys2d_cmd("run", "dominoes", "--size", "3", "--steps", "10", "--no-record", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    assert not (tmp_path / "recordings").exists()
    assert "recording:" not in out.stdout


def test_compare_then_inspect(tmp_path):
    out = phys2d_cmd("compare", "vertical_stack", "--size", "3", "--steps", "30", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    path = tmp_path / "recordings" / "vertical_stack-compare.rrd"
    verify(path)
    rec = playback.load(path)
    expected = [name for name in ("naive", "iterative", "pgs-cold", "pgs")
                if name in ("pgs", "pgs-cold") or hasattr(phys2d, {"naive": "NaiveImpulse",
                                                                   "iterative": "IterativeImpulse"}[name])]
    assert sorted(rec.runs) == sorted(expected)
    for r in rec.runs.values():
        assert list(r.tick) == list(range(31))  # aligned on the same ticks
    ins = phys2d_cmd("inspect", str(path), cwd=tmp_path)
    assert ins.returncode == 0, ins.stderr
    rows = {line.split()[0]: line.split() for line in ins.stdout.splitlines()[2:]}
    assert sorted(rows) == sorted(expected)
    for label, cols in rows.items():
        r = rec.runs[label]
        assert cols[2] == "0-30" and int(cols[3]) == 4
        assert float(cols[5]) == pytest.approx(1e3 * max(0.0, -r.contacts.separation.min()), abs=1e-3)


def test_inspect_summarises_a_run(tmp_path):
    assert phys2d_cmd("run", "pyramid", "--size", "3", "--steps", "30", "--out", "p.rrd", cwd=tmp_path).returncode == 0
    out = phys2d_cmd("inspect", "p.rrd", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    header, row = out.stdout.splitlines()[1:3]
    assert header.split()[:5] == ["run", "responder", "ticks", "bodies", "contacts"]
    cols = row.split()
    rec = playback.load(tmp_path / "p.rrd")
    assert cols[1] == "pgs" and cols[2] == "0-30" and int(cols[3]) == 7
    assert int(cols[4]) == int(rec.contact_count.max())
    assert float(cols[6]) == pytest.approx(rec.contacts.normal_impulse.max(), rel=1e-3)


@pytest.mark.parametrize("args, fragment", [
    (["run", "pyrmid"], "unknown scene 'pyrmid'; did you mean 'pyramid'?"),
    (["run", "pyramid", "--steps", "-5"], "--steps: must be a whole number >= 1, got '-5'"),
    (["run", "pyramid", "--steps", "ten"], "--steps: must be a whole number >= 1"),
    (["run", "pyramid", "--dt", "0"], "--dt: must be a number of seconds > 0"),
    (["run", "pyramid", "--size", "0"], "--size 0 for scene 'pyramid' (rows of the pyramid): rows must be >= 1"),
    (["run", "pyramid", "--size", "2.5"], "rows must be an integer"),
    (["run", "pyramid", "--responder", "magic"], "invalid choice: 'magic'"),
    (["run", "pyramid", "--out", "a.rrd", "--no-record"], "not allowed with argument"),
    (["run", "pyramid", "--out", "blocker/x.rrd"], "is not writable"),
    (["run", "pyramid", "--out", "x.txt"], "must name an .rrd file"),
    (["compare", "nothing"], "unknown scene 'nothing'"),
    (["inspect", "missing.rrd"], "no such recording file"),
    (["inspect", "blocker"], "is not a readable .rrd file"),
    (["view", "missing.rrd"], "no such recording: missing.rrd"),
    (["fly"], "invalid choice: 'fly'"),
    ([], "the following arguments are required"),
])
def test_bad_arguments_give_one_clear_line_and_a_nonzero_exit(tmp_path, args, fragment):
    (tmp_path / "blocker").write_text("a file, not a folder or a recording")
    out = phys2d_cmd(*args, cwd=tmp_path)
    assert out.returncode != 0
    assert "Traceback" not in out.stderr
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1, out.stderr
    assert fragment in lines[0]
    assert lines[0].startswith("phys2d")
    assert not (tmp_path / "recordings").exists()  # nothing was run


def test_a_failing_simulation_reports_one_line_and_keeps_the_recording(tmp_path, monkeypatch, capsys):
    """In-process (no stock scene fails on purpose): a scene whose world has a 3 m/s speed limit."""
    from phys2d import cli

    def falling(n: int = 1, responder=None) -> phys2d.World:
        w = phys2d.World(responder=responder, max_speed=3.0)
        phys2d.scenes.ground(w)
        w.add_box(position=(0.0, 20.0))
        return w

    monkeypatch.setitem(phys2d.scenes.SCENES, "falling", (falling, "unused"))
    path = tmp_path / "falling.rrd"
    assert cli.main(["run", "falling", "--steps", "100", "--out", str(path)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "step 19 failed" in err[0] and "ticks 0-18 are recorded" in err[0], err
    verify(path)
    rec = playback.load(path)
    assert list(rec.tick) == list(range(19))  # free fall passes 3 m/s at t = 0.3 s: step 19 of 1/60 s


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _cdp_screenshot(url: str, out: str, wait_s: float) -> None:
    """Headless Chromium over the DevTools protocol (the notes' recipe): load, wait real time, capture."""
    import websocket

    port = _free_port()
    profile = tempfile.mkdtemp(prefix="chr_")
    proc = subprocess.Popen(["chromium", "--headless", "--no-sandbox", "--no-first-run",
                             "--disable-background-networking", "--disable-component-update", "--disable-sync",
                             f"--user-data-dir={profile}", "--window-size=1600,900",
                             f"--remote-debugging-port={port}", "--remote-debugging-address=127.0.0.1",
                             "--use-angle=swiftshader", "--enable-unsafe-swiftshader", "about:blank"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        tabs = None
        for _ in range(200):
            try:
                tabs = json.load(urllib.request.urlopen(f"http://127.0.0.1:{port}/json"))
                break
            except OSError:
                time.sleep(0.1)
        assert tabs is not None, "chromium did not open its DevTools port"
        ws = websocket.create_connection([t for t in tabs if t["type"] == "page"][0]["webSocketDebuggerUrl"],
                                         timeout=60)
        n = 0

        def call(method: str, **params):
            nonlocal n
            n += 1
            ws.send(json.dumps({"id": n, "method": method, "params": params}))
            while True:
                m = json.loads(ws.recv())
                if m.get("id") == n:
                    return m

        call("Emulation.setDeviceMetricsOverride", width=1600, height=900, deviceScaleFactor=1, mobile=False)
        call("Page.navigate", url=url)
        time.sleep(wait_s)  # real time: the wasm viewer downloads, compiles and loads the data
        png = call("Page.captureScreenshot", format="png")["result"]["data"]
        with open(out, "wb") as f:
            f.write(base64.b64decode(png))
        ws.close()
    finally:
        proc.terminate()
        proc.wait(10)
        shutil.rmtree(profile, ignore_errors=True)


@pytest.mark.skipif(shutil.which("chromium") is None, reason="needs chromium for a headless screenshot")
def test_web_viewer_screenshot_shows_the_world_and_plots(tmp_path):
    pytest.importorskip("websocket", reason="needs websocket-client to drive chromium")
    assert phys2d_cmd("run", "pyramid", "--size", "6", "--steps", "90", "--out", "p.rrd", cwd=tmp_path).returncode == 0
    web, grpc = _free_port(), _free_port()
    env = {**os.environ, "PYTHONPATH": REPO}
    view = subprocess.Popen([sys.executable, "-m", "phys2d", "view", "p.rrd", "--web", "--web-port", str(web),
                             "--port", str(grpc)], cwd=tmp_path, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    try:
        line = view.stdout.readline()
        assert line.startswith("web viewer: http://127.0.0.1:"), line
        url = line.split()[2]
        out = os.environ.get("PHYS2D_SCREENSHOT", str(tmp_path / "web.png"))
        _cdp_screenshot(url, out, wait_s=float(os.environ.get("PHYS2D_SCREENSHOT_WAIT", "40")))
    finally:
        view.terminate()
        view.wait(20)
    assert view.returncode is not None
    image = pytest.importorskip("PIL.Image")
    rgb = np.asarray(image.open(out).convert("RGB")).astype(int)
    assert rgb.shape == (900, 1600, 3)

    def near(colour, tol=40):
        return int((np.abs(rgb - np.array(colour)).sum(axis=2) < tol).sum())

    # the bodies' class colour (blue outlines) and the new/warm-started contact colours are on screen
    assert near((80, 140, 255)) > 300, "no body outlines visible"
    assert near((40, 200, 90)) + near((230, 40, 40)) > 50, "no contacts visible"
