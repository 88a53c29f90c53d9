"""The status page and its read-only JSON API, served by aiohttp on a thread of its own.

aiohttp rather than a hand-written server: it is a maintained HTTP/1.1 implementation (request
parsing, keep-alive, limits, TLS through :mod:`ssl`) that runs in one asyncio loop without
extra processes, which suits an edge box; the daemon's threads never wait for it.

Routes (docs/daemon.md, "Status page"):

``GET /``                             the page (``static/``)
``GET /api/state``                    ``weather/<site>/state``, as published
``GET /api/status``                   ``weather/<site>/status``
``GET /api/cameras``                  ``{id: weather/<site>/camera/<id>/hos}``
``GET /api/instruments``              ``{id: weather/<site>/instrument/<id>}`` (latest reading)
``GET /api/history?since=S``          10-s bins of the last 24 h (from UNIX time S)
``GET /api/cameras/{id}/overlay.jpg`` the latest overlay (drawn while someone watches)
``GET /api/cameras/{id}/frame``       its frame result, size and blob centroids
``GET /api/roi``                      each camera's region of interest, and whether a save can
                                      write the configuration
``POST /api/cameras/{id}/roi``        ``{"polygon": [[x, y], ...]}``: writes it into the
                                      configuration (authenticated, writable file) or returns
                                      the TOML snippet to paste

Nothing else: no route changes the detector, deletes a recording or reads a file.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import logging
import math
import ssl
import threading
from importlib import resources
from pathlib import Path
from typing import Any

from aiohttp import web

from daemon.config import CameraConfig, WebConfig, split_listen
from drivers.errors import ConfigError

from .auth import Secrets
from .hub import MAX_BLOBS, WebHub
from .roi_file import RoiWriter, roi_snippet, rounded_polygon

__all__ = ["WebServer"]

log = logging.getLogger(__name__)

_STATIC = ("index.html", "app.js", "style.css")
_TYPES = {".html": "text/html", ".js": "text/javascript", ".css": "text/css"}
#: Every response: no sniffing, no framing, scripts and styles from this server only.
_HEADERS = {
    "X-Content-Type-Options": "nosniff",
    "X-Frame-Options": "DENY",
    "Referrer-Policy": "no-referrer",
    "Content-Security-Policy": (
        "default-src 'self'; img-src 'self' blob: data:; object-src 'none'; "
        "base-uri 'none'; frame-ancestors 'none'; form-action 'none'"
    ),
}
#: A wrong password costs the client this long (s): guessing is slow.
_FAILED_AUTH_DELAY_S = 0.5
_MAX_BODY = 256 * 1024


class WebServer:
    """Serves ``hub`` as configured by ``[web]``; :meth:`start` returns once it listens (or
    has failed to: the daemon runs on without its page, and says why in the log and status).

    Parameters
    ----------
    config : the ``[web]`` table
    hub : what to show
    secrets : the password and token (:func:`daemon.web.auth.load_secrets`)
    cameras : the cameras' configurations (their regions of interest)
    config_path : the configuration file the daemon runs with (ROI saves write it), or None
    """

    def __init__(
        self,
        config: WebConfig,
        hub: WebHub,
        *,
        secrets: Secrets,
        cameras: list[CameraConfig],
        config_path: str | Path | None = None,
    ):
        self.config = config
        self.hub = hub
        self.secrets = secrets
        self.cameras = {c.id: c for c in cameras}
        self.writer = RoiWriter(config_path)
        self.url: str | None = None
        self.error: str | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._stopping: asyncio.Event | None = None
        self._ready = threading.Event()
        self._thread = threading.Thread(target=self._serve, name="web", daemon=True)
        self._static = {name: _read_static(name) for name in _STATIC}

    # -- life cycle --------------------------------------------------------------------------
    def start(self, timeout: float = 10.0) -> None:
        self._thread.start()
        self._ready.wait(timeout)
        if self.url is not None:
            log.info("status page on %s (%s)", self.url, self._access())
        else:
            log.warning("status page: %s; running without it", self.error or "did not start")

    def stop(self, timeout: float = 5.0) -> None:
        loop, stopping = self._loop, self._stopping
        if loop is not None and stopping is not None:
            with contextlib.suppress(RuntimeError):  # the loop has ended already
                loop.call_soon_threadsafe(stopping.set)
        self._thread.join(timeout)

    def stats(self) -> dict[str, Any]:
        return {"enabled": True, "url": self.url, "error": self.error}

    def _access(self) -> str:
        if self.secrets.required:
            return "password or token required"
        return "this machine only, no password"

    def _serve(self) -> None:
        try:
            asyncio.run(self._main())
        except Exception as exc:  # a bind or TLS failure: logged, the daemon runs on
            self.error = str(exc) or type(exc).__name__
            log.debug("status page failed", exc_info=True)
        finally:
            self._ready.set()

    async def _main(self) -> None:
        self._loop = asyncio.get_running_loop()
        self._stopping = asyncio.Event()
        host, port = split_listen(self.config.listen)
        ssl_context = None
        if self.config.tls_cert and self.config.tls_key:
            ssl_context = ssl.create_default_context(ssl.Purpose.CLIENT_AUTH)
            ssl_context.load_cert_chain(self.config.tls_cert, self.config.tls_key)
        runner = web.AppRunner(self.app(), access_log=None, handle_signals=False)
        await runner.setup()
        try:
            try:
                site = web.TCPSite(runner, host, port, ssl_context=ssl_context)
                await site.start()
            except OSError as exc:
                raise OSError(f"cannot listen on {self.config.listen} ({exc.strerror})") from None
            bound = runner.addresses[0]
            shown = f"[{bound[0]}]" if ":" in bound[0] else bound[0]
            self.url = f"{'https' if ssl_context else 'http'}://{shown}:{bound[1]}/"
            self._ready.set()
            await self._stopping.wait()
        finally:
            await runner.cleanup()

    # -- the application ------------------------------------------------------------------
    def app(self) -> web.Application:
        app = web.Application(middlewares=[self._guard], client_max_size=_MAX_BODY)
        app.router.add_get("/", self._page)
        app.router.add_get("/static/{name}", self._asset)
        app.router.add_get("/favicon.ico", self._no_icon)
        app.router.add_get("/api/state", self._state)
        app.router.add_get("/api/status", self._status)
        app.router.add_get("/api/cameras", self._camera_list)
        app.router.add_get("/api/instruments", self._instrument_list)
        app.router.add_get("/api/history", self._history)
        app.router.add_get("/api/cameras/{camera}/overlay.jpg", self._overlay)
        app.router.add_get("/api/cameras/{camera}/frame", self._frame)
        app.router.add_get("/api/roi", self._roi)
        app.router.add_post("/api/cameras/{camera}/roi", self._save_roi)
        return app

    @web.middleware
    async def _guard(self, request: web.Request, handler: Any) -> web.StreamResponse:
        if not self.secrets.allows(request.headers.get("Authorization")):
            await asyncio.sleep(_FAILED_AUTH_DELAY_S)
            response: web.StreamResponse = web.json_response(
                {"error": "authentication required"},
                status=401,
                headers={"WWW-Authenticate": 'Basic realm="weatherd", charset="UTF-8"'},
            )
        else:
            try:
                response = await handler(request)
            except web.HTTPException as exc:  # 4xx from a route or the router: as a response
                response = web.Response(status=exc.status, text=exc.text, headers=exc.headers)
        response.headers.update(_HEADERS)
        response.headers.setdefault("Cache-Control", "no-store")
        return response

    async def _page(self, request: web.Request) -> web.Response:
        return self._static_response("index.html")

    async def _no_icon(self, request: web.Request) -> web.Response:
        return web.Response(status=204)

    async def _asset(self, request: web.Request) -> web.Response:
        name = request.match_info["name"]
        if name not in self._static:
            raise web.HTTPNotFound()
        return self._static_response(name)

    def _static_response(self, name: str) -> web.Response:
        suffix = name[name.rfind(".") :]
        return web.Response(body=self._static[name], content_type=_TYPES[suffix], charset="utf-8")

    async def _state(self, request: web.Request) -> web.Response:
        return _json(self.hub.latest("state"))

    async def _status(self, request: web.Request) -> web.Response:
        return _json(self.hub.latest("status"))

    async def _camera_list(self, request: web.Request) -> web.Response:
        summaries = self.hub.latest_under("camera")
        return _json({cam: summaries.get(cam) for cam in self.hub.feeds})

    async def _instrument_list(self, request: web.Request) -> web.Response:
        return _json(self.hub.latest_under("instrument"))

    async def _history(self, request: web.Request) -> web.Response:
        since = request.query.get("since")
        try:
            since_s = None if since is None else float(since)
        except ValueError:
            raise web.HTTPBadRequest(text="since: expected UNIX seconds") from None
        return _json({"bin_s": 10, "bins": self.hub.history(since_s=since_s)})

    def _feed(self, request: web.Request) -> Any:
        feed = self.hub.feeds.get(request.match_info["camera"])
        if feed is None:
            raise web.HTTPNotFound(text="no such camera")
        feed.watch()
        return feed

    async def _overlay(self, request: web.Request) -> web.Response:
        frame = self._feed(request).latest()
        if frame is None:  # the first one is being drawn
            return web.Response(status=204)
        return web.Response(body=frame.jpeg, content_type="image/jpeg")

    async def _frame(self, request: web.Request) -> web.Response:
        frame = self._feed(request).latest()
        if frame is None:
            return _json(None)
        n = min(len(frame.blobs_x), MAX_BLOBS)
        return _json(
            {
                "t_ns": frame.t_ns,
                "width": frame.width,
                "height": frame.height,
                "result": frame.result,
                "blobs": {
                    "x": frame.blobs_x[:n],
                    "y": frame.blobs_y[:n],
                    "class": frame.blobs_class[:n],
                },
            }
        )

    async def _roi(self, request: web.Request) -> web.Response:
        why_not = self._why_no_write()
        cams = {}
        for cam_id, cam in self.cameras.items():
            roi = cam.roi
            cams[cam_id] = {
                "polygon": roi if isinstance(roi, list) else None,
                "mask": roi if isinstance(roi, str) else None,
            }
        return _json(
            {
                "cameras": cams,
                "can_save": why_not is None,
                "why_not": why_not,
                "path": None if self.writer.path is None else str(self.writer.path),
                "note": "a saved region takes effect when the daemon restarts",
            }
        )

    def _why_no_write(self) -> str | None:
        if not self.secrets.required:
            return (
                "the page has no password (web.password_file or a token): it offers the "
                "snippet instead of writing the configuration"
            )
        return self.writer.why_not()

    async def _save_roi(self, request: web.Request) -> web.Response:
        cam_id = request.match_info["camera"]
        cam = self.cameras.get(cam_id)
        if cam is None and cam_id not in self.hub.feeds:
            raise web.HTTPNotFound(text="no such camera")
        # A cross-site form cannot send JSON without a preflight this server never answers.
        if request.content_type != "application/json":
            raise web.HTTPUnsupportedMediaType(text="send application/json")
        origin = request.headers.get("Origin")
        if origin is not None and origin.split("://", 1)[-1] != request.host:
            raise web.HTTPForbidden(text="cross-origin request refused")
        try:
            body = await request.json()
            polygon = rounded_polygon(body.get("polygon") if isinstance(body, dict) else None)
        except (ValueError, json.JSONDecodeError) as exc:
            return _json({"saved": False, "error": f"polygon: {exc}"}, status=400)
        source = cam.source if cam is not None else "demo:"
        snippet = roi_snippet(cam_id, source, polygon)
        out: dict[str, Any] = {"polygon": polygon, "snippet": snippet, "saved": False}
        why_not = self._why_no_write()
        if why_not is not None:
            out["why_not"] = why_not
            return _json(out)
        try:
            path = await asyncio.to_thread(self.writer.save, cam_id, polygon)
        except ConfigError as exc:
            out["why_not"] = str(exc)
            return _json(out)
        log.info(
            "status page: camera %s region of interest saved to %s (%d points; "
            "takes effect at restart)",
            cam_id,
            path,
            len(polygon),
        )
        out.update(saved=True, path=str(path))
        return _json(out)


def _json(data: Any, *, status: int = 200) -> web.Response:
    return web.json_response(data, status=status, dumps=_dumps)


def _dumps(data: Any) -> str:
    """JSON a browser parses: a non-finite number (never published, but) becomes null."""
    try:
        return json.dumps(data, allow_nan=False)
    except ValueError:
        return json.dumps(_finite(data), allow_nan=False)


def _finite(data: Any) -> Any:
    if isinstance(data, float):
        return data if math.isfinite(data) else None
    if isinstance(data, dict):
        return {k: _finite(v) for k, v in data.items()}
    if isinstance(data, list | tuple):
        return [_finite(v) for v in data]
    return data


def _read_static(name: str) -> bytes:
    return resources.files("daemon.web").joinpath("static", name).read_bytes()
