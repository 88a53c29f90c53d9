"""The status page in a real browser (Debian's chromium driven by Playwright) against the real
``weatherd run`` on the demo camera: the password is required, the page loads, the overlay and
the plots update, a region of interest drawn with the mouse is saved into the configuration and
is the detector's after a restart, and the site state turns to rain when the demo rains.

``make test`` installs chromium when it runs as root on Debian; elsewhere this module is skipped
with the reason, except under CI, where a missing browser is a failure.
"""

from __future__ import annotations

import base64
import json
import os
import shutil
import time
import urllib.error
import urllib.request
from pathlib import Path

import pytest
from playwright.sync_api import Error as PlaywrightError

from daemon.config import load_config
from tests.daemon.service.test_e2e_instruments import SimulatedPwd, pwd_message
from tests.daemon.service.test_e2e_run import Daemon
from tests.zenoh_tools import free_port

pytestmark = pytest.mark.e2e

CHROMIUM = shutil.which("chromium") or "/usr/bin/chromium"
PASSWORD = "cabinet-7"
CONFIG = """\
# The roadside cabinet's configuration (the status page must keep this comment).
[site]
id = "roadside"
state_dir = "{state}"

[[camera]]
id = "street"   # the demo street
source = "demo:?start=14"  # 14 s into the demo's cycle: it rains 6 s after the start

[[instrument]]
id = "gauge"
driver = "vaisala-pwd"
kind = "gauge"
port = "{gauge}"

[zenoh]
enabled = false

[recording]
dir = "{recordings}"

[publish]
camera_interval_s = 0.5
state_interval_s = 0.5
status_interval_s = 1.0

[fusion]
onset_s = 3.0

[web]
listen = "127.0.0.1:{port}"
password_file = "{password}"
overlay_interval_s = 0.3
"""
#: The region drawn, as fractions of the displayed image.
DRAWN = [(0.05, 0.45), (0.6, 0.45), (0.6, 0.95), (0.05, 0.95)]


@pytest.fixture(scope="module")
def browser():
    if not os.path.exists(CHROMIUM):
        why = "Debian's chromium is not installed (make test installs it when run as root)"
        if os.environ.get("CI"):
            pytest.fail(why)
        pytest.skip(why)
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, args=["--no-sandbox"])
        try:
            yield b
        finally:
            b.close()


def _get(url: str) -> object:
    token = base64.b64encode(f"tech:{PASSWORD}".encode()).decode()
    req = urllib.request.Request(url, headers={"Authorization": f"Basic {token}"})
    with urllib.request.urlopen(req, timeout=10) as r:
        return json.loads(r.read())


class DryGauge(SimulatedPwd):
    """A PWD used as a rain gauge on a pty, measuring no rain (so that the site's state follows
    the camera)."""

    def _run(self) -> None:
        while not self._stop.wait(0.5):
            try:
                os.write(self.master, pwd_message(self.unit, rate=0.0, wawa=0))
            except OSError:
                return


def daemon_get_401(url: str) -> str:
    """A request with a wrong password, as a script would send it: the body of the 401."""
    token = base64.b64encode(b"tech:wrong").decode()
    req = urllib.request.Request(url + "api/state", headers={"Authorization": f"Basic {token}"})
    with pytest.raises(urllib.error.HTTPError) as err:
        urllib.request.urlopen(req, timeout=10)
    assert err.value.code == 401
    return err.value.read().decode()


def _inside(poly: list[list[float]], x: float, y: float, tol: float = 1.0) -> bool:
    """In the convex polygon ``poly`` (to ``tol`` pixels)."""
    xs, ys = [p[0] for p in poly], [p[1] for p in poly]
    return min(xs) - tol <= x <= max(xs) + tol and min(ys) - tol <= y <= max(ys) + tol


def test_status_page_in_a_real_browser(browser, tmp_path: Path) -> None:
    port = free_port()
    password = tmp_path / "web-password"
    password.write_text(PASSWORD + "\n")
    password.chmod(0o600)
    config = tmp_path / "weatherd.toml"
    gauge = DryGauge(tmp_path / "gauge", "1", polled=False)  # a serial gauge on a pty
    config.write_text(
        CONFIG.format(
            state=tmp_path / "state",
            recordings=tmp_path / "rec",
            port=port,
            password=password,
            gauge=tmp_path / "gauge",
        )
    )
    url = f"http://127.0.0.1:{port}/"
    daemon = Daemon(config, tmp_path / "daemon.log")
    started = time.monotonic()
    try:
        daemon.wait_log("status page on", timeout=60)

        # No password, a wrong one: refused (the server answers 401; Chromium shows it, or
        # gives up on the credentials it was given).
        for credentials in (None, {"username": "tech", "password": "wrong"}):
            ctx = browser.new_context(http_credentials=credentials)
            try:
                status = ctx.new_page().goto(url).status
            except PlaywrightError as exc:
                assert "ERR_INVALID_AUTH_CREDENTIALS" in str(exc)
                status = 401
            assert status == 401
            ctx.close()
        assert "authentication required" in daemon_get_401(url)

        ctx = browser.new_context(
            http_credentials={"username": "tech", "password": PASSWORD},
            viewport={"width": 1280, "height": 1800},
            bypass_csp=True,  # Playwright's wait_for_function evaluates strings
        )
        page = ctx.new_page()
        errors: list[str] = []
        page.on("pageerror", lambda exc: errors.append(str(exc)))
        assert page.goto(url).status == 200
        page.wait_for_function("document.querySelector('#site').textContent === 'roadside'")
        page.wait_for_function(
            "/dry|rain/.test(document.querySelector('#precipitation').className)", timeout=30_000
        )

        # The gauge's reading, and the fusion's use of it.
        page.wait_for_function(
            "document.querySelector('#instruments tbody').innerText.includes('0.00 mm/h')",
            timeout=20_000,
        )
        row = page.inner_text("#instruments tbody tr")
        assert row.startswith("gauge") and "vaisala-pwd" in row

        # The overlay image is replaced as new frames come.
        page.wait_for_function("document.querySelector('.overlay').dataset.updated", timeout=20_000)
        first = page.eval_on_selector(".overlay", "img => img.dataset.updated")
        page.wait_for_function(
            f"document.querySelector('.overlay').dataset.updated !== '{first}'", timeout=10_000
        )
        assert page.eval_on_selector(".overlay", "img => img.naturalWidth") > 0

        # The plots take new points from the history.
        page.wait_for_function(
            "Number(document.querySelector('#plot-fraction').dataset.points || 0) > 0",
            timeout=30_000,
        )
        points = int(page.eval_on_selector("#plot-fraction", "c => c.dataset.points"))
        page.wait_for_function(
            f"Number(document.querySelector('#plot-fraction').dataset.points) > {points}",
            timeout=30_000,
        )

        # A region of interest drawn with the mouse: the blobs outside it are left out, and
        # saving writes it into the configuration, comments kept.
        page.click("details.roi summary")
        page.click(".roi-draw")
        box = page.locator(".roi-canvas").bounding_box()
        for fx, fy in DRAWN:
            page.mouse.click(box["x"] + fx * box["width"], box["y"] + fy * box["height"])
        page.wait_for_function("Number(document.querySelector('.roi-count').dataset.total) > 0")
        kept = int(page.eval_on_selector(".roi-count", "p => p.dataset.kept"))
        total = int(page.eval_on_selector(".roi-count", "p => p.dataset.total"))
        assert 0 <= kept < total
        page.click(".roi-save")
        page.wait_for_function("document.querySelector('.roi-message').dataset.saved === 'true'")
        assert "takes effect when the daemon restarts" in page.inner_text(".roi-message")
        saved = load_config(config).camera[0].roi
        frame = _get(url + "api/cameras/street/frame")
        want = [[fx * frame["width"], fy * frame["height"]] for fx, fy in DRAWN]
        assert len(saved) == 4
        for (x, y), (wx, wy) in zip(saved, want, strict=True):
            assert abs(x - wx) < 2 and abs(y - wy) < 2
        assert "must keep this comment" in config.read_text()

        # The demo rains after 6 s: the camera, then the site, say so.
        page.wait_for_function(
            "document.querySelector('#precipitation').className.includes('rain')",
            timeout=max(1.0, 90 - (time.monotonic() - started)) * 1000,
        )
        assert page.inner_text(".cam-verdict") in ("Rain seen", "Precipitation seen", "Snow seen")
        page.screenshot(path=str(tmp_path / "raining.png"), full_page=True)
        assert errors == []
        ctx.close()
    finally:
        assert daemon.stop() == 0, daemon.stderr()

    # After a restart, the detector works inside the saved region, and the page shows it.
    daemon = Daemon(config, tmp_path / "daemon2.log")
    try:
        daemon.wait_log("status page on", timeout=60)
        assert _get(url + "api/roi")["cameras"]["street"]["polygon"] == saved
        ctx = browser.new_context(
            http_credentials={"username": "tech", "password": PASSWORD}, bypass_csp=True
        )
        page = ctx.new_page()
        page.goto(url)
        page.wait_for_function("typeof roiInfo !== 'undefined' && roiInfo !== null")
        assert page.evaluate("roiInfo.cameras.street.polygon") == saved
        ctx.close()
        deadline = time.monotonic() + 30
        blobs: dict = {"x": []}
        while time.monotonic() < deadline:
            frame = _get(url + "api/cameras/street/frame")
            blobs = (frame or {}).get("blobs") or {"x": []}
            if len(blobs["x"]) >= 5:
                break
            time.sleep(0.5)
        assert len(blobs["x"]) >= 5, "no blob to check the region with"
        outside = [
            (x, y) for x, y in zip(blobs["x"], blobs["y"], strict=True) if not _inside(saved, x, y)
        ]
        assert outside == []
    finally:
        gauge.pull()
        assert daemon.stop() == 0, daemon.stderr()
