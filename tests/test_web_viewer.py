"""pyramid_20's 600-tick recording in Rerun's web viewer, in headless Chromium: every panel draws data.

Skipped without Chromium (``apt-get install chromium``), websocket-client or Pillow. The
load time (navigation to the first screenshot where every panel shows its data) is
printed and written to ``$PHYS2D_WEB_REPORT`` if set; the goal is 20 s on a 2-core
machine, not asserted (timings are not tested), but the panels must fill within
``$PHYS2D_WEB_TIMEOUT`` s (default 180). The plotted contacts' series are the last
data in the file, so their panels filling means the whole file was read.
"""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest

from phys2d.recording import schema
from tests import webview

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

pytestmark = pytest.mark.skipif(webview.chromium() is None, reason="needs chromium (apt-get install chromium)")


def test_pyramid_20_opens_in_the_web_viewer_with_every_panel_drawn(tmp_path):
    pytest.importorskip("websocket", reason="needs websocket-client to drive chromium")
    pytest.importorskip("PIL", reason="needs Pillow to read the screenshots")
    env = {**os.environ, "PYTHONPATH": REPO}
    run = subprocess.run(
        [sys.executable, "-m", "phys2d", "run", "pyramid", "--size", "20", "--steps", "600", "--out", "p20.rrd"],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert run.returncode == 0, run.stderr
    web, grpc = webview.free_port(), webview.free_port()
    view = subprocess.Popen(
        [sys.executable, "-m", "phys2d", "view", "p20.rrd", "--web", "--web-port", str(web), "--port", str(grpc)],
        cwd=tmp_path,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        line = view.stdout.readline()
        assert line.startswith("web viewer: http://127.0.0.1:"), line + view.stderr.read()
        url = line.split()[2]
        four = list(schema.PALETTE[:4])
        plots = [
            four + [schema.lighter(c) for c in four],  # lambda_n, lambda_t of the 4 deepest contacts
            four,  # their penetration
            [schema.PALETTE[0]],  # the residual
            [schema.ENERGY_COLOURS["kinetic"]],
        ]  # kinetic (potential and total are hidden)
        regions = webview.panels(plots)
        world = [c for k, _, c in schema.ANNOTATIONS if k == schema.CLASS_BODY]
        minimum = {name: 2000 if name == "world" else 150 for name in regions}
        timeout = float(os.environ.get("PHYS2D_WEB_TIMEOUT", "180"))
        with webview.Browser() as browser:
            seconds, counts, rgb = webview.wait_until_drawn(browser, url, regions, world, minimum, timeout)
        shot = os.environ.get("PHYS2D_SCREENSHOT")
        if shot:
            from PIL import Image

            Image.fromarray(rgb).save(shot)
    finally:
        view.terminate()
        view.wait(20)
    report = (
        f"pyramid_20, 600 ticks, {os.path.getsize(tmp_path / 'p20.rrd') / 1e6:.1f} MB: "
        + (
            f"every panel drawn {seconds:.1f} s after navigation"
            if seconds is not None
            else f"not every panel drawn after {timeout:.0f} s"
        )
        + f" (pixels per panel: {counts})"
    )
    print(report)
    if os.environ.get("PHYS2D_WEB_REPORT"):
        with open(os.environ["PHYS2D_WEB_REPORT"], "a") as f:
            f.write(report + "\n")
    assert seconds is not None, report
    # and the world really shows the pyramid's contacts, warm-started by the end
    warm = [c for k, _, c in schema.ANNOTATIONS if k == schema.CLASS_WARM][0]
    assert int(webview.near(rgb[:, : int(webview.SPLIT * webview.WIDTH)], warm).sum()) > 50
    assert np.isfinite(seconds)
