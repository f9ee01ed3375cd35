"""The `phys2d` command, run as a user runs it: a subprocess of `python -m phys2d`."""

from __future__ import annotations

import os
import re
import signal
import socket
import subprocess
import sys
import time
import urllib.request

import numpy as np
import pytest
from rerun.chunk import RrdReader

import phys2d
import phys2d.recording
from phys2d.recording import playback
from tests.dropped import busy, dropping_callback

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def phys2d_cmd(*args: str, cwd, timeout: float = 300) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": REPO + os.pathsep + os.environ.get("PYTHONPATH", "")}
    env.pop("PHYS2D_DEBUG", None)
    return subprocess.run(
        [sys.executable, "-m", "phys2d", *args], cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout
    )


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
    path = tmp_path / "recordings" / "pyramid-4-pgs.rrd"
    assert path.is_file()
    assert f"phys2d view {os.path.join('recordings', 'pyramid-4-pgs.rrd')}" in out.stdout
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
    out = phys2d_cmd(
        "run",
        "vertical_stack",
        "--size",
        "3",
        "--steps",
        "20",
        "--dt",
        "0.01",
        "--responder",
        "pgs-cold",
        "--iterations",
        "4",
        "--out",
        "sub/stack.rrd",
        "--progress",
        cwd=tmp_path,
    )
    assert out.returncode == 0, out.stderr
    assert "tick" in out.stderr and "20/20" in out.stderr  # the progress bar, on stderr
    rec = playback.load(tmp_path / "sub" / "stack.rrd")
    np.testing.assert_allclose(rec.time[-1], 0.2, atol=1e-9)
    assert set(rec.iterations[1:]) == {4}
    assert not rec.contacts.warm_started.any()
    assert rec.properties["run"]["responder_name"] == "pgs-cold"


def test_run_with_the_responders_beyond_the_lecture(tmp_path):
    for name, expected in (("pgs-block", "block=True"), ("soft-step", "SoftStep(substeps=2")):
        out = phys2d_cmd(
            "run",
            "vertical_stack",
            "--size",
            "3",
            "--steps",
            "10",
            "--responder",
            name,
            *(["--iterations", "2"] if name == "soft-step" else []),
            "--out",
            f"{name}.rrd",
            cwd=tmp_path,
        )
        assert out.returncode == 0, out.stderr
        rec = playback.load(tmp_path / f"{name}.rrd")
        assert expected in rec.properties["run"]["responder"]


def test_run_without_series_keeps_the_contact_table(tmp_path):
    out = phys2d_cmd(
        "run", "vertical_stack", "--size", "3", "--steps", "15", "--no-series", "--out", "s.rrd", cwd=tmp_path
    )
    assert out.returncode == 0, out.stderr
    rec = playback.load(tmp_path / "s.rrd")
    assert rec.series_keys("lambda") == [] and len(rec.contacts.key) > 0


def test_a_run_that_cannot_build_its_scene_keeps_the_recording_already_there(tmp_path):
    assert (
        phys2d_cmd("run", "vertical_stack", "--size", "2", "--steps", "3", "--out", "v.rrd", cwd=tmp_path).returncode
        == 0
    )
    before = (tmp_path / "v.rrd").read_bytes()
    out = phys2d_cmd("run", "vertical_stack", "--size", "0", "--steps", "3", "--out", "v.rrd", cwd=tmp_path)
    assert out.returncode != 0 and "size" in out.stderr
    assert (tmp_path / "v.rrd").read_bytes() == before  # the earlier run's file, byte for byte
    assert sorted(f.name for f in tmp_path.iterdir()) == ["v.rrd"]


def test_run_without_recording_writes_nothing(tmp_path):
    out = phys2d_cmd("run", "dominoes", "--size", "3", "--steps", "10", "--no-record", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    assert not (tmp_path / "recordings").exists()
    assert "recording:" not in out.stdout


def test_compare_runs_every_responder_with_a_verdict_each_then_inspect(tmp_path):
    out = phys2d_cmd("compare", "vertical_stack", "--size", "3", "--steps", "30", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    path = tmp_path / "recordings" / "vertical_stack-3-compare.rrd"
    verify(path)
    rec = playback.load(path)
    expected = list(phys2d.REGISTRY)  # every registered responder, none left out
    assert sorted(rec.runs) == sorted(expected) and len(expected) >= 7
    for r in rec.runs.values():
        assert list(r.tick) == list(range(31))  # aligned on the same ticks
    verdicts = {ln.split()[0]: ln for ln in out.stdout.splitlines() if ln.split() and ln.split()[0] in expected}
    assert sorted(verdicts) == sorted(expected)
    for label, line in verdicts.items():
        r = rec.runs[label]
        # the verdict's figures are the recording's: largest displacement and the last kinetic energy
        moved = np.nanmax(np.hypot(*(r.x[:, 1:] - r.x[:1, 1:]).transpose(2, 0, 1)))
        assert re.search(r"^\S+\s+(stood|fell at [\d.]+ s \(.*\)|restless \(.*\)): largest displacement", line), line
        assert float(re.search(r"largest displacement ([\d.]+) m", line).group(1)) == pytest.approx(moved, abs=1e-3)
        ke = float(re.search(r"final kinetic energy ([-+\d.e]+) J", line).group(1))
        assert ke == pytest.approx(r.kinetic_energy[-1], rel=1e-2, abs=1e-12)
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


@pytest.mark.parametrize(
    "args, fragment",
    [
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
    ],
)
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
    err = [line for line in err if not line.startswith(("phys2d: compiling", "phys2d: compiled in"))]  # a cold cache's
    assert len(err) == 1 and "step 19 failed" in err[0] and "ticks 0-18 are recorded" in err[0], err
    verify(path)
    rec = playback.load(path)
    assert list(rec.tick) == list(range(19))  # free fall passes 3 m/s at t = 0.3 s: step 19 of 1/60 s


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


# -- counts, plurals, version, notices ----------------------------------------------------------
@pytest.mark.parametrize(
    "responder, option, shown",
    [
        ("pgs", "--sweeps", "PGS(iterations=3"),
        ("iterative", "--passes", "IterativeImpulse(passes=3"),
        ("soft-step", "--substeps", "SoftStep(substeps=3"),
        ("pgs-block", "--iterations", "iterations=3"),
    ],
)
def test_each_count_reaches_the_responders_that_take_it(tmp_path, responder, option, shown):
    out = phys2d_cmd(
        "run",
        "vertical_stack",
        "--size",
        "2",
        "--steps",
        "5",
        "--responder",
        responder,
        option,
        "3",
        "--out",
        "c.rrd",
        cwd=tmp_path,
    )
    assert out.returncode == 0, out.stderr
    assert shown in playback.load(tmp_path / "c.rrd").properties["run"]["responder"]


@pytest.mark.parametrize(
    "args, fragment",
    [
        (
            ["--responder", "naive", "--sweeps", "3"],
            "--sweeps does not apply to the naive responder (it makes one pass)",
        ),
        (["--responder", "pgs", "--passes", "3"], "--passes does not apply to the pgs responder (it takes --sweeps)"),
        (["--responder", "soft-step", "--sweeps", "3"], "(it takes --substeps)"),
        (["--sweeps", "3", "--iterations", "3"], "give one of --iterations, --sweeps, --passes, --substeps"),
    ],
)
def test_a_count_the_responder_does_not_take_is_refused_by_name(tmp_path, args, fragment):
    out = phys2d_cmd("run", "vertical_stack", "--size", "2", "--steps", "5", "--no-record", *args, cwd=tmp_path)
    assert out.returncode == 1
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and fragment in lines[0], out.stderr


def test_output_names_include_the_responder_so_runs_do_not_overwrite_each_other(tmp_path):
    for responder in ("pgs", "pgs-cold"):
        assert (
            phys2d_cmd(
                "run", "vertical_stack", "--size", "2", "--steps", "5", "--responder", responder, cwd=tmp_path
            ).returncode
            == 0
        )
    assert (
        phys2d_cmd("run", "vertical_stack", "--size", "2", "--steps", "5", "--sweeps", "2", cwd=tmp_path).returncode
        == 0
    )
    names = sorted(p.name for p in (tmp_path / "recordings").iterdir())
    assert names == ["vertical_stack-2-pgs-2sweeps.rrd", "vertical_stack-2-pgs-cold.rrd", "vertical_stack-2-pgs.rrd"]
    warm = playback.load(tmp_path / "recordings" / "vertical_stack-2-pgs.rrd")
    cold = playback.load(tmp_path / "recordings" / "vertical_stack-2-pgs-cold.rrd")
    assert warm.properties["run"]["responder_name"] == "pgs" and cold.properties["run"]["responder_name"] == "pgs-cold"


def test_one_sweep_is_singular(tmp_path):
    out = phys2d_cmd(
        "run", "vertical_stack", "--size", "2", "--steps", "1", "--sweeps", "1", "--no-record", cwd=tmp_path
    )
    assert out.returncode == 0, out.stderr
    assert "after 1 sweep;" not in out.stdout and re.search(r"after 1 sweep$", out.stdout, re.M), out.stdout
    assert re.search(r"^1 step of ", out.stdout, re.M), out.stdout


def test_version():
    import rerun

    out = phys2d_cmd("--version", cwd=REPO)
    assert out.returncode == 0
    assert out.stdout.startswith(f"phys2d {phys2d.__version__} (rerun-sdk {rerun.__version__},")
    assert rerun.__version__.startswith("0.41.")


def test_the_version_and_a_run_that_records_nothing_never_import_rerun(tmp_path):
    """rerun takes 0.4 s to import: a command that writes no recording never pays it (a recording
    is written by a writer process of its own, which loads rerun's native layer alone)."""
    env = {**os.environ, "PYTHONPATH": REPO, "PYTHONPROFILEIMPORTTIME": "1"}  # each import on stderr
    for args in (["--version"], ["run", "pyramid", "--size", "2", "--steps", "2", "--no-record"]):
        out = subprocess.run(
            [sys.executable, "-m", "phys2d", *args], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300
        )
        assert out.returncode == 0, out.stderr[-2000:]
        lines = [line for line in out.stderr.splitlines() if line.startswith("import time:")]
        imported = {line.rsplit("|", 1)[-1].strip() for line in lines}
        assert "numpy" in imported  # (the listing works)
        assert not {name for name in imported if name.split(".")[0] in ("rerun", "rerun_bindings")}, args


def test_a_first_step_that_compiles_gets_one_notice_and_a_cached_one_none():
    """numba compiling (a kernel not in the disk cache) is announced once; no compiling, no line."""
    import io

    from numba import njit

    from phys2d import cli

    @njit(cache=False)
    def kernel(v):
        return v + 1.0

    @njit(cache=False)
    def other(v):
        return kernel(v) * 2.0

    class Compiling:
        def step(self, dt: float) -> None:
            other(dt)

    for compiles in (True, False):  # the first call compiles both functions; the second finds them compiled
        stream = io.StringIO()
        cli.first_step([Compiling(), Compiling()], 1 / 60, stream=stream)
        lines = stream.getvalue().splitlines()
        if compiles:  # one line before (with its estimate), one after (how long it took)
            assert (
                len(lines) == 2
                and "compiling the numba kernels" in lines[0]
                and re.search(r"about \d+ s on [12] cores?\)", lines[0])
            )
            assert lines[1].startswith("phys2d: compiled in "), lines
        else:
            assert lines == []


def test_the_eta_leaves_out_the_first_step(tmp_path, monkeypatch, capsys):
    """A first step that takes 3 s (as numba compiling does) is not in the bar's elapsed time."""
    from phys2d import cli

    real = cli.first_step

    def slow_first(worlds, dt, stream=None):
        real(worlds, dt, stream)
        time.sleep(3.0)

    monkeypatch.setattr(cli, "first_step", slow_first)
    assert cli.main(["run", "vertical_stack", "--size", "2", "--steps", "30", "--no-record", "--progress"]) == 0
    err = capsys.readouterr().err
    elapsed = re.findall(r"30/30 \[(\d+):(\d+)<", err)
    assert elapsed and int(elapsed[-1][0]) * 60 + int(elapsed[-1][1]) < 3, err


# -- viewing ---------------------------------------------------------------------------------------
def test_view_without_a_display_says_so_and_offers_web(tmp_path):
    assert (
        phys2d_cmd("run", "vertical_stack", "--size", "2", "--steps", "3", "--out", "v.rrd", cwd=tmp_path).returncode
        == 0
    )
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    env["PYTHONPATH"] = REPO
    out = subprocess.run(
        [sys.executable, "-m", "phys2d", "view", "v.rrd"],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert out.returncode == 1
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and "no display" in lines[0] and "phys2d view v.rrd --web" in lines[0], out.stderr


@pytest.mark.parametrize("which", ["--web-port", "--port"])
def test_view_web_on_a_busy_port_gets_a_clear_message(tmp_path, which):
    assert (
        phys2d_cmd("run", "vertical_stack", "--size", "2", "--steps", "3", "--out", "v.rrd", cwd=tmp_path).returncode
        == 0
    )
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        other = _free_port()
        ports = (
            {"--web-port": port, "--port": other} if which == "--web-port" else {"--web-port": other, "--port": port}
        )
        out = phys2d_cmd(
            "view", "v.rrd", "--web", *[str(a) for kv in ports.items() for a in kv], cwd=tmp_path, timeout=60
        )
    assert out.returncode == 1
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and f"port {port} is already in use" in lines[0] and which in lines[0], out.stderr
    assert "web viewer:" not in out.stdout  # no URL printed for a viewer that is not there


def _wait_port(port: int, timeout: float = 30) -> None:
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        with socket.socket() as s:
            if s.connect_ex(("127.0.0.1", port)) == 0:
                return
        time.sleep(0.1)
    raise AssertionError(f"nothing listens on {port}")


def test_run_live_streams_to_a_viewer_while_the_simulation_runs(tmp_path):
    """A rerun gRPC server saving what it receives stands in for a viewer: the stream grows while
    the run goes on, and at the end holds the same ticks as the recording file."""
    import rerun_cli

    port = _free_port()
    saved = tmp_path / "received.rrd"
    server = subprocess.Popen(
        [
            os.path.join(os.path.dirname(rerun_cli.__file__), "rerun"),
            "--serve-grpc",
            "--bind",
            "127.0.0.1",
            "--port",
            str(port),
            "--save",
            str(saved),
        ],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        _wait_port(port)
        env = {**os.environ, "PYTHONPATH": REPO}
        run = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "phys2d",
                "run",
                "pyramid",
                "--size",
                "8",
                "--steps",
                "600",
                "--out",
                "live.rrd",
                "--live",
                f"rerun+http://127.0.0.1:{port}/proxy",
            ],
            cwd=tmp_path,
            env=env,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        sizes = []
        while run.poll() is None:
            sizes.append(saved.stat().st_size if saved.exists() else 0)
            time.sleep(0.2)
        out, err = run.communicate()
        assert run.returncode == 0, err
        assert len(set(s for s in sizes if s)) >= 3, sizes  # it grew, window by window, during the run
        time.sleep(1.0)
    finally:
        server.terminate()
        server.wait(20)
    got = playback.load(saved)
    want = playback.load(tmp_path / "live.rrd")
    assert list(got.tick) == list(want.tick) == list(range(601))
    assert np.array_equal(got.x, want.x)


def test_run_live_web_prints_the_viewer_url_and_serves_it(tmp_path):
    web, grpc = _free_port(), _free_port()
    env = {**os.environ, "PYTHONPATH": REPO}
    run = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "phys2d",
            "run",
            "vertical_stack",
            "--size",
            "2",
            "--steps",
            "30",
            "--no-record",
            "--live",
            "web",
            "--web-port",
            str(web),
            "--port",
            str(grpc),
        ],
        cwd=tmp_path,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        line = run.stdout.readline()
        assert line.startswith("live web viewer: http://127.0.0.1:"), line + run.stderr.read()
        page = urllib.request.urlopen(line.split()[3], timeout=30).read()
        assert b"<html" in page.lower() or b"<!doctype" in page.lower()
        rest = ""
        while "keeps serving" not in rest:
            rest += run.stdout.readline()
        assert "verdict: " in rest
    finally:
        run.terminate()
        run.wait(30)
    assert run.returncode == 0, run.stderr.read()  # SIGTERM while it serves: the end it was waiting for
    _wait_port_free(web)  # and the viewer went with it


def _wait_port_free(port: int, timeout: float = 20) -> None:
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        with socket.socket() as s:
            if s.connect_ex(("127.0.0.1", port)) != 0:
                return
        time.sleep(0.1)
    raise AssertionError(f"something still listens on {port}: the viewer outlived the command")


@pytest.mark.skipif(sys.platform == "win32", reason="no SIGTERM handler, no process groups")
def test_a_live_web_run_stopped_midway_stops_its_viewer(tmp_path):
    """SIGTERM during the simulation: the command ends as interrupted (130), and the web viewer
    it started is not left serving on its ports."""
    web, grpc = _free_port(), _free_port()
    env = {**os.environ, "PYTHONPATH": REPO}
    cmd = [sys.executable, "-m", "phys2d", "run", "pyramid", "--size", "10", "--steps", "1000000", "--no-record"]
    cmd += ["--live", "web", "--web-port", str(web), "--port", str(grpc)]
    with open(tmp_path / "stderr.txt", "w") as err:  # a file: a viewer left behind would hold a pipe open
        # a group of its own: should the run hang, the web viewer it started goes with it
        run = subprocess.Popen(
            cmd, cwd=tmp_path, env=env, stdout=subprocess.PIPE, stderr=err, text=True, start_new_session=True
        )
    try:
        line = run.stdout.readline()
        assert line.startswith("live web viewer: http://127.0.0.1:"), line
        time.sleep(1.0)
        assert run.poll() is None  # a million steps: still running
        run.terminate()
        run.wait(30)
    finally:
        if run.poll() is None:
            os.killpg(run.pid, signal.SIGKILL)
    assert run.returncode == 130, (tmp_path / "stderr.txt").read_text()
    _wait_port_free(web)


def test_python_drops_an_interrupt_raised_in_a_c_callback(monkeypatch):
    """The fault the CLI guards against: the interrupt goes no further than the callback (Python
    hands it to ``sys.unraisablehook``, which prints "Exception ignored", and goes on), so without
    a guard a run would not stop."""
    dropped: list[type] = []
    monkeypatch.setattr(sys, "unraisablehook", lambda unraisable: dropped.append(type(unraisable.exc_value)))
    dropping_callback()()  # returns: no KeyboardInterrupt here
    assert dropped == [KeyboardInterrupt]


@pytest.mark.parametrize("then", ["goes-on", "fails"])
def test_an_interrupt_dropped_while_a_run_steps_still_ends_it_at_once(monkeypatch, capsys, then):
    """Ctrl-C or SIGTERM that lands in a C callback during a step (the first, compiling, or a later
    one) still stops `phys2d run` within that step: exit 130, the rest of the step not waited for
    (found on a cold cache, where a SIGTERM during the first step's compile was dropped and the run
    went on). Also when the step then fails for want of what the callback did not finish (numba:
    "no compiled object yet"), which was an internal error (exit 1)."""
    from phys2d import cli

    from_c, steps, finished, drop_at = dropping_callback(), [], [], [0]
    original = phys2d.World.step

    def step(self, dt):
        original(self, dt)
        steps.append(self.tick)
        if self.tick == drop_at[0]:
            from_c()
            if then == "fails":
                raise RuntimeError("no compiled object yet")
            busy(20.0)  # the rest of a long compile, in Python
            finished.append(self.tick)

    monkeypatch.setattr(phys2d.World, "step", step)
    for drop_at[0] in (1, 5):  # the first step (where a cold cache compiles), and a later one
        steps.clear()
        argv = ["run", "pyramid", "--size", "2", "--steps", "40", "--no-record", "--no-progress"]
        assert cli.main(argv) == 130
        assert steps == list(range(1, drop_at[0] + 1))
        assert finished == []
        err = capsys.readouterr().err
        assert "interrupted" in err and "Exception ignored" not in err


@pytest.mark.skipif(sys.platform == "win32", reason="no process groups, no SIGTERM handler")
@pytest.mark.parametrize("how", ["ctrl-c", "sigterm"])
def test_a_recorded_run_stopped_midway_exits_130_with_its_recording_complete(tmp_path, how):
    """Ctrl-C in a terminal sends SIGINT to the whole process group (the run and its recording's
    writer process); SIGTERM goes to the run alone. Either way the run ends as interrupted (130) and
    the file has its footer and every tick up to where it stopped, whole: the last is the state a
    world stepped as many ticks has (it exited 1 with "writing the recording failed:
    KeyboardInterrupt" on Ctrl-C, and died with no footer on SIGTERM)."""
    env = {**os.environ, "PYTHONPATH": REPO}
    cmd = [sys.executable, "-m", "phys2d", "run", "pyramid", "--size", "6", "--steps", "1000000", "--out", "p.rrd"]
    run = subprocess.Popen(
        [*cmd, "--no-progress"], cwd=tmp_path, env=env, stderr=subprocess.PIPE, text=True, start_new_session=True
    )
    try:
        deadline = time.monotonic() + 300  # (a cold cache compiles first)
        while not ((tmp_path / "p.rrd").exists() and (tmp_path / "p.rrd").stat().st_size > 200_000):
            assert run.poll() is None and time.monotonic() < deadline, "the run never got going"
            time.sleep(0.05)
        if how == "ctrl-c":
            os.killpg(run.pid, signal.SIGINT)
        else:
            run.terminate()
        _, err = run.communicate(timeout=60)
    finally:
        if run.poll() is None:
            os.killpg(run.pid, signal.SIGKILL)
    assert run.returncode == 130, err
    assert "interrupted" in err
    RrdReader(str(tmp_path / "p.rrd")).store()  # only a file with its footer has a store
    back = playback.load(tmp_path / "p.rrd")
    assert back.tick[0] == 0 and back.tick[-1] > 60 and np.array_equal(back.tick, np.arange(back.tick[-1] + 1))
    w = phys2d.scenes.pyramid(6)
    for _ in range(int(back.tick[-1])):
        w.step(1 / 60)
    assert np.array_equal(back.x[-1], w.x) and np.array_equal(back.theta[-1], w.theta)
    deadline = time.monotonic() + 10  # and the writer process is gone with the run
    while True:
        try:
            os.killpg(run.pid, 0)
        except ProcessLookupError:
            break
        assert time.monotonic() < deadline, "a process of the run outlived it"
        time.sleep(0.05)


VIEWER_WAIT_SCRIPT = """
import signal, subprocess, sys, tempfile, threading, time
from phys2d import cli

v = object.__new__(cli.Viewer)  # a Viewer over a stand-in process (no rerun binary needed)
v.kind, v.files, v.log = "web", None, tempfile.NamedTemporaryFile(delete=False).name
v._sigterm = cli._stop_on_sigterm()
v.proc = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
def other_thread():  # the kernel may hand a process's SIGTERM to any thread that does not block it
    time.sleep(0.5)
    signal.pthread_kill(threading.get_ident(), signal.SIGTERM)
threading.Thread(target=other_thread).start()
code = v.serve()
print(code, v.proc.poll() is not None, signal.getsignal(signal.SIGTERM) is signal.SIG_DFL)
"""


def test_viewer_wait_ends_on_a_sigterm_another_thread_received(tmp_path):
    """Python runs signal handlers in the main thread only: a SIGTERM delivered to another thread
    must still end the wait (it hung in waitpid when it waited without a timeout)."""
    env = {**os.environ, "PYTHONPATH": REPO}
    out = subprocess.run(
        [sys.executable, "-c", VIEWER_WAIT_SCRIPT], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=30
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["0", "True", "True"]  # exit 0, its process stopped, SIGTERM's handler put back


def test_plot_options_choose_the_plotted_contacts(tmp_path):
    out = phys2d_cmd(
        "run", "vertical_stack", "--size", "3", "--steps", "20", "--plot-body", "2", "--out", "b.rrd", cwd=tmp_path
    )
    assert out.returncode == 0, out.stderr
    w = phys2d.scenes.vertical_stack(3)  # the same run, in this process: every contact identity of body 2
    want = set()
    for _ in range(20):
        w.step(1 / 60)
        want |= {phys2d.recording.contact_entity(k) for k in w.contacts.key if 2 in (k >> 39, (k >> 16) & 0x7FFFFF)}
    got = playback.load(tmp_path / "b.rrd").series_keys("lambda")
    assert want and set(got) == want
    assert "plotted contacts: " + ", ".join(sorted(want)) in out.stdout
    bad = phys2d_cmd(
        "run", "vertical_stack", "--steps", "2", "--plot-contacts", "b2-b1/f0", "--no-record", cwd=tmp_path
    )
    assert bad.returncode == 1 and len(bad.stderr.strip().splitlines()) == 1 and "b2-b1/f0" in bad.stderr
