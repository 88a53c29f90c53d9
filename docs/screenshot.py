"""Make docs/status-page.jpg: the status page of `weatherd run` on the demo camera, raining.

    .venv/bin/python docs/screenshot.py [OUT.jpg]

Needs Debian's chromium (`make browser`). Starts the daemon on a free port with a throw-away
configuration, waits for the demo's rain, draws a region of interest, and takes the picture.
"""

from __future__ import annotations

import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from playwright.sync_api import sync_playwright

REPO = Path(__file__).resolve().parents[1]


def main(out: Path) -> None:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    with tempfile.TemporaryDirectory() as tmp:
        config = Path(tmp) / "weatherd.toml"
        config.write_text(
            f'[site]\nid = "demo"\nstate_dir = "{tmp}/state"\n[zenoh]\nenabled = false\n'
            f'[recording]\ndir = "{tmp}/rec"\n[web]\nlisten = "127.0.0.1:{port}"\n'
        )
        daemon = subprocess.Popen(
            [sys.executable, "-m", "daemon.cli", "run", "--config", str(config)], cwd=REPO
        )
        try:
            with sync_playwright() as p:
                browser = p.chromium.launch(executable_path="/usr/bin/chromium")
                page = browser.new_page(viewport={"width": 1280, "height": 1500})
                time.sleep(3)
                page.goto(f"http://127.0.0.1:{port}/")
                page.wait_for_selector("#precipitation.rain", timeout=120_000)
                time.sleep(15)  # some rain in the plots
                page.click("details.roi summary")
                page.click(".roi-draw")
                box = page.locator(".roi-canvas").bounding_box()
                for fx, fy in [(0.02, 0.5), (0.55, 0.5), (0.55, 0.98), (0.02, 0.98)]:
                    page.mouse.click(box["x"] + fx * box["width"], box["y"] + fy * box["height"])
                time.sleep(2)
                page.screenshot(path=str(out), full_page=True, type="jpeg", quality=70)
                browser.close()
        finally:
            daemon.terminate()
            daemon.wait(30)


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else REPO / "docs" / "status-page.jpg")
