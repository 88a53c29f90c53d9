"""The status page's server, in this process on a free loopback port: every route, the
password, what it refuses (cross-site posts, other files, unknown cameras), and TLS."""

from __future__ import annotations

import base64
import http.client
import json
import ssl
import subprocess
import urllib.error
import urllib.request
from collections.abc import Iterator
from pathlib import Path

import pytest

from daemon.config import CameraConfig, WebConfig
from daemon.web import FeedFrame, Secrets, WebHub, WebServer

CONFIG = """\
# kept
[[camera]]
id = "c1"
source = "demo:"
"""


def _request(url: str, *, data: bytes | None = None, headers: dict | None = None, ctx=None):
    req = urllib.request.Request(url, data=data, headers=headers or {})
    try:
        with urllib.request.urlopen(req, timeout=10, context=ctx) as r:
            return r.status, dict(r.headers), r.read()
    except urllib.error.HTTPError as exc:
        return exc.code, dict(exc.headers), exc.read()


def _auth(password: str) -> dict:
    return {"Authorization": "Basic " + base64.b64encode(f"u:{password}".encode()).decode()}


@pytest.fixture
def served(tmp_path: Path) -> Iterator[tuple[str, WebHub, Path]]:
    hub = WebHub("s1")
    hub.add_camera("c1")
    path = tmp_path / "weatherd.toml"
    path.write_text(CONFIG)
    server = WebServer(
        WebConfig(listen="127.0.0.1:0"),
        hub,
        secrets=Secrets(password="pw"),
        cameras=[CameraConfig(id="c1", source="demo:")],
        config_path=path,
    )
    server.start()
    assert server.url is not None, server.error
    try:
        yield server.url.rstrip("/"), hub, path
    finally:
        server.stop()


def test_every_route_answers_with_the_hub_content(served) -> None:
    url, hub, _ = served
    a = _auth("pw")
    status, headers, body = _request(url + "/", headers=a)
    assert status == 200 and b"<title>weatherd</title>" in body
    assert "default-src 'self'" in headers["Content-Security-Policy"]
    for name, ctype in (("app.js", "text/javascript"), ("style.css", "text/css")):
        status, headers, _ = _request(f"{url}/static/{name}", headers=a)
        assert status == 200 and headers["Content-Type"].startswith(ctype)
    assert _request(url + "/api/state", headers=a)[2] == b"null"
    state = {"schema": "weather.state/1", "t_ns": 10**18, "precipitation": True, "x": float("nan")}
    hub.publish("state", state)
    hub.publish("camera/c1/hos", {"schema": "weather.camera/1", "t_ns": 10**18, "rain": True})
    hub.publish("instrument/g1", {"schema": "instrument.reading/1", "t_ns": 10**18})
    got = json.loads(_request(url + "/api/state", headers=a)[2])
    assert got["precipitation"] is True and got["x"] is None  # NaN never reaches the browser
    assert json.loads(_request(url + "/api/cameras", headers=a)[2])["c1"]["rain"] is True
    assert "g1" in json.loads(_request(url + "/api/instruments", headers=a)[2])
    hist = json.loads(_request(url + "/api/history?since=0", headers=a)[2])
    assert hist["bin_s"] == 10 and isinstance(hist["bins"], list)
    assert _request(url + "/api/history?since=x", headers=a)[0] == 400
    # the overlay: 204 until the processing thread drew one, then JPEG bytes
    assert _request(url + "/api/cameras/c1/overlay.jpg", headers=a)[0] == 204
    feed = hub.feeds["c1"]
    assert feed.due()  # asking for the overlay made the camera draw it
    feed.put(
        FeedFrame(
            t_ns=5,
            jpeg=b"\xff\xd8jpeg",
            width=64,
            height=48,
            result={"rain": True},
            blobs_x=[1.5],
            blobs_y=[2.5],
            blobs_class=[1],
        )
    )
    status, headers, body = _request(url + "/api/cameras/c1/overlay.jpg", headers=a)
    assert status == 200 and headers["Content-Type"] == "image/jpeg" and body == b"\xff\xd8jpeg"
    frame = json.loads(_request(url + "/api/cameras/c1/frame", headers=a)[2])
    assert frame["width"] == 64 and frame["blobs"] == {"x": [1.5], "y": [2.5], "class": [1]}


@pytest.mark.parametrize(
    "path",
    [
        "/api/cameras/nope/overlay.jpg",
        "/static/../../etc/passwd",
        "/static/hub.py",
        "/api/recordings",
        "/etc/passwd",
        "/api/cameras/nope/frame",
    ],
)
def test_nothing_else_is_served(served, path: str) -> None:
    url, _, _ = served
    assert _request(url + path, headers=_auth("pw"))[0] == 404


@pytest.mark.parametrize("headers", [{}, _auth("wrong"), {"Authorization": "Bearer pw"}])
def test_wrong_or_missing_password_is_refused(served, headers: dict) -> None:
    url, _, _ = served
    for path in ("/", "/api/state", "/static/app.js"):
        status, got, _ = _request(url + path, headers=headers)
        assert status == 401 and got["WWW-Authenticate"].startswith("Basic")


def test_roi_save_writes_the_file_or_refuses(served) -> None:
    url, _, path = served
    a = _auth("pw") | {"Content-Type": "application/json"}
    poly = [[1, 1], [50.04, 1], [50, 40]]
    status, _, body = _request(
        url + "/api/cameras/c1/roi", data=json.dumps({"polygon": poly}).encode(), headers=a
    )
    out = json.loads(body)
    assert status == 200 and out["saved"] is True, out
    assert (
        "roi = [[1.0, 1.0], [50.0, 1.0], [50.0, 40.0]]" in path.read_text()
        and "# kept" in path.read_text()
    )
    info = json.loads(_request(url + "/api/roi", headers=a)[2])
    assert info["can_save"] is True and info["path"] == str(path)
    # refused: a bad polygon, a form post, another site's page, an unknown camera
    bad = json.dumps({"polygon": [[1, 1], [2, 2]]}).encode()
    assert _request(url + "/api/cameras/c1/roi", data=bad, headers=a)[0] == 400
    form = _auth("pw") | {"Content-Type": "application/x-www-form-urlencoded"}
    assert _request(url + "/api/cameras/c1/roi", data=b"polygon=1", headers=form)[0] == 415
    evil = a | {"Origin": "http://evil.example"}
    body = json.dumps({"polygon": poly}).encode()
    assert _request(url + "/api/cameras/c1/roi", data=body, headers=evil)[0] == 403
    assert _request(url + "/api/cameras/zz/roi", data=body, headers=a)[0] == 404
    # a GET cannot save
    assert _request(url + "/api/cameras/c1/roi", headers=a)[0] == 405


def test_without_password_the_page_offers_the_snippet(tmp_path: Path) -> None:
    path = tmp_path / "weatherd.toml"
    path.write_text(CONFIG)
    hub = WebHub("s1")
    server = WebServer(
        WebConfig(listen="127.0.0.1:0"),
        hub,
        secrets=Secrets(),
        cameras=[CameraConfig(id="c1", source="demo:")],
        config_path=path,
    )
    server.start()
    try:
        body = json.dumps({"polygon": [[1, 1], [9, 1], [9, 9]]}).encode()
        status, _, out = _request(
            server.url + "api/cameras/c1/roi",
            data=body,
            headers={"Content-Type": "application/json"},
        )
        out = json.loads(out)
        assert status == 200 and out["saved"] is False and "no password" in out["why_not"]
        assert "roi = [[1.0, 1.0], [9.0, 1.0], [9.0, 9.0]]" in out["snippet"]
        assert path.read_text() == CONFIG
    finally:
        server.stop()


def test_a_taken_port_is_reported_and_the_daemon_runs_on() -> None:
    first = WebServer(WebConfig(listen="127.0.0.1:0"), WebHub("a"), secrets=Secrets(), cameras=[])
    first.start()
    try:
        port = first.url.rsplit(":", 1)[1].strip("/")
        second = WebServer(
            WebConfig(listen=f"127.0.0.1:{port}"), WebHub("b"), secrets=Secrets(), cameras=[]
        )
        second.start()
        assert second.url is None and "cannot listen on 127.0.0.1:" in second.error
        assert second.stats() == {"enabled": True, "url": None, "error": second.error}
        second.stop()
    finally:
        first.stop()


def test_tls_when_a_certificate_is_given(tmp_path: Path) -> None:
    cert, key = tmp_path / "cert.pem", tmp_path / "key.pem"
    subprocess.run(
        [
            "openssl",
            "req",
            "-x509",
            "-newkey",
            "rsa:2048",
            "-nodes",
            "-days",
            "1",
            "-subj",
            "/CN=localhost",
            "-keyout",
            str(key),
            "-out",
            str(cert),
        ],
        check=True,
        capture_output=True,
    )
    server = WebServer(
        WebConfig(listen="127.0.0.1:0", tls_cert=str(cert), tls_key=str(key)),
        WebHub("s"),
        secrets=Secrets(token="tok"),
        cameras=[],
    )
    server.start()
    try:
        assert server.url.startswith("https://127.0.0.1:")
        ctx = ssl.create_default_context(cafile=str(cert))
        ctx.check_hostname = False
        status, _, _ = _request(
            server.url + "api/state", headers={"Authorization": "Bearer tok"}, ctx=ctx
        )
        assert status == 200
        with pytest.raises((OSError, http.client.HTTPException)):  # plain HTTP to TLS
            urllib.request.urlopen(server.url.replace("https", "http") + "api/state", timeout=5)
    finally:
        server.stop()
