"""Headless Chromium over the DevTools protocol, for looking at a recording in Rerun's web viewer.

Used by ``test_web_viewer.py``; also runnable by hand to save a screenshot:

    PYTHONPATH=. python tests/webview.py recordings/pyramid-20-pgs.rrd shot.png [seconds]
"""

from __future__ import annotations

import base64
import io
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

CHROMIUM_FLAGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--window-size=1600,900",
]
WIDTH, HEIGHT = 1600, 900


def chromium() -> str | None:
    for name in ("chromium", "chromium-browser", "google-chrome"):
        path = shutil.which(name)
        if path:
            return path
    return None


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Browser:
    """One headless Chromium page driven over CDP (websocket-client)."""

    def __init__(self) -> None:
        import websocket

        exe = chromium()
        if exe is None:
            raise RuntimeError("chromium is not installed")
        self.port = free_port()
        self.profile = tempfile.mkdtemp(prefix="phys2d-chromium-")
        self.proc = subprocess.Popen(
            [
                exe,
                *CHROMIUM_FLAGS,
                f"--user-data-dir={self.profile}",
                f"--remote-debugging-port={self.port}",
                "--remote-debugging-address=127.0.0.1",
                "about:blank",
            ],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        tabs = None
        for _ in range(300):
            try:
                tabs = json.load(urllib.request.urlopen(f"http://127.0.0.1:{self.port}/json", timeout=2))
                break
            except OSError:
                time.sleep(0.1)
        if tabs is None:
            self.close()
            raise RuntimeError("chromium did not open its DevTools port")
        page = [t for t in tabs if t["type"] == "page"][0]
        # no Origin header: newer Chromium (111+) refuses a DevTools socket from an origin it was not
        # told to allow (403), and takes one with none, as from a debugger rather than a page
        self.ws = websocket.create_connection(page["webSocketDebuggerUrl"], timeout=120, suppress_origin=True)
        self.n = 0
        self.call("Emulation.setDeviceMetricsOverride", width=WIDTH, height=HEIGHT, deviceScaleFactor=1, mobile=False)

    def call(self, method: str, **params) -> dict:
        self.n += 1
        self.ws.send(json.dumps({"id": self.n, "method": method, "params": params}))
        while True:
            m = json.loads(self.ws.recv())
            if m.get("id") == self.n:
                if "error" in m:
                    raise RuntimeError(f"{method}: {m['error']}")
                return m.get("result", {})

    def navigate(self, url: str) -> None:
        self.call("Page.navigate", url=url)

    def screenshot(self) -> np.ndarray:
        """(HEIGHT, WIDTH, 3) uint8 RGB of the page now."""
        from PIL import Image

        data = base64.b64decode(self.call("Page.captureScreenshot", format="png")["data"])
        return np.asarray(Image.open(io.BytesIO(data)).convert("RGB"))

    def close(self) -> None:
        try:
            self.ws.close()
        except Exception:
            pass
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
        shutil.rmtree(self.profile, ignore_errors=True)

    def __enter__(self) -> Browser:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def near(rgb: np.ndarray, colour, tol: int = 40) -> np.ndarray:
    """Mask of pixels within ``tol`` (sum of channel differences) of ``colour``."""
    return np.abs(rgb.astype(int) - np.array(colour)).sum(axis=-1) < tol


# -- what a drawn panel looks like -------------------------------------------------------------------
TOP, BOTTOM = 36, 868  # y range of the views: below the top bar, above the collapsed time panel
SPLIT = 0.6  # the world takes 3/5 of the width (column_shares=[3, 2])


def panels(plot_colours: list[list[tuple[int, int, int]]]) -> dict[str, tuple[slice, slice, list]]:
    """Screen regions (rows, columns) of the world view and of each plot, stacked equally on the
    right, with the colours that show data there (the legend corner is left out)."""
    x0 = int(SPLIT * WIDTH)
    out = {"world": (slice(TOP, BOTTOM), slice(0, x0 - 5), [])}
    n = len(plot_colours)
    h = (BOTTOM - TOP) / n
    for k, colours in enumerate(plot_colours):
        rows = slice(int(TOP + k * h + 25), int(TOP + (k + 1) * h - 12))  # below the title, above the axis labels
        out[f"plot {k}"] = (rows, slice(x0 + 170, WIDTH - 10), colours)
    return out


def drawn(rgb: np.ndarray, regions: dict, world_colours: list, min_pixels: int = 150) -> dict[str, int]:
    """Pixels of the expected colours in each region."""
    out = {}
    for name, (rows, cols, colours) in regions.items():
        part = rgb[rows, cols]
        want = world_colours if name == "world" else colours
        out[name] = int(sum(near(part, c).sum() for c in want))
    return out


def wait_until_drawn(
    browser: Browser,
    url: str,
    regions: dict,
    world_colours: list,
    minimum: dict[str, int],
    timeout: float,
    every: float = 1.0,
) -> tuple[float | None, dict[str, int], np.ndarray]:
    """Navigate, then screenshot every ``every`` s until each region holds at least ``minimum[name]``
    pixels of its colours: (seconds from navigation to that screenshot or None, counts, last image)."""
    t0 = time.monotonic()
    browser.navigate(url)
    counts: dict[str, int] = {}
    rgb = np.zeros((HEIGHT, WIDTH, 3), np.uint8)
    while time.monotonic() - t0 < timeout:
        time.sleep(every)
        rgb = browser.screenshot()
        counts = drawn(rgb, regions, world_colours)
        if all(counts[k] >= minimum[k] for k in regions):
            return time.monotonic() - t0, counts, rgb
    return None, counts, rgb


def main() -> None:
    path, out = sys.argv[1], sys.argv[2]
    wait = float(sys.argv[3]) if len(sys.argv) > 3 else 30.0
    web, grpc = free_port(), free_port()
    env = {**os.environ, "PYTHONPATH": os.path.dirname(os.path.dirname(os.path.abspath(__file__)))}
    view = subprocess.Popen(
        [sys.executable, "-m", "phys2d", "view", path, "--web", "--web-port", str(web), "--port", str(grpc)],
        env=env,
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        url = view.stdout.readline().split()[2]
        with Browser() as b:
            b.navigate(url)
            time.sleep(wait)
            from PIL import Image

            Image.fromarray(b.screenshot()).save(out)
    finally:
        view.terminate()
        view.wait(20)


if __name__ == "__main__":
    main()
