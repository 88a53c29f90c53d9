"""``weatherd run``: cameras in, weather state out over Zenoh, MCAP on disk.

Threads, per camera: a capture thread (:class:`.capture.CaptureThread`) that keeps only the
newest frame, and a processing thread (:class:`CameraPipeline`) that runs the detector on it and
records the per-frame results. The main thread runs :meth:`Daemon.run`'s loop: camera summaries,
fusion into the site state, health, publishing, recorder flushes and the systemd watchdog. One
``threading.Event`` stops every loop; resources are closed in reverse order of their start.

Start-up, in order: recover unfinished MCAP files, open the recorder, start the Zenoh session
(in the background: start-up never waits for a router), start the cameras, tell systemd READY.
"""

from __future__ import annotations

import contextlib
import functools
import logging
import math
import os
import platform
import threading
import time
from collections import deque
from collections.abc import Callable, Iterator
from importlib import metadata
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from daemon.config import (
    CameraConfig,
    Config,
    config_error,
    default_recording_dir,
    error_lines,
    state_dir,
)
from daemon.recording.mcap_repair import recover_directory
from daemon.recording.recorder import (
    Recorder,
    RecorderLogHandler,
)
from daemon.recording.results import ResultRecorder, thumbnail_jpeg
from daemon.transport.messages import schema_for, stamp
from daemon.transport.publisher import Publisher, ZenohPublisher, zenoh_config
from daemon.web import CameraFeed, FeedFrame, WebHub, WebServer, blob_centroids, load_secrets
from drivers.errors import ConfigError, InputError
from drivers.frames import FrameSource, LiveFrame, mask_credentials
from drivers.sources import open_source
from drivers.video import polygon_mask, read_roi_mask, roi_for_size
from hos import FrameResult, HosDetector, _jit
from hos.params import DetectorParams

from . import sdnotify
from .calibration import CalibrationParams, OnlineCalibration, load_calibration_file
from .capture import CaptureThread
from .clock import clock_status
from .detection import detect_frames
from .fusion import CameraWindow, Persistence, fuse
from .instruments import InstrumentHub

__all__ = ["DEMO_CAMERA", "CameraPipeline", "Daemon", "versions"]

log = logging.getLogger(__name__)

#: The camera of a configuration that has none: the built-in synthetic street.
DEMO_CAMERA = CameraConfig(id="demo", source="demo:", width=640, height=360, fps=25.0)
#: Main loop period (s): summaries, state changes and the watchdog are checked this often.
TICK_S = 0.1
#: A camera whose last result is older than this (s) cannot judge.
STALE_S = 5.0
#: How the log names the site's precipitation verdict.
_WORDS = {True: "YES", False: "no", None: "unknown"}
#: A processing thread that has not looped for this long (s) is hung: the watchdog stops.
HUNG_S = 20.0


def versions() -> dict[str, str]:
    """Versions of this program and of the libraries whose behaviour matters."""
    out = {"python": platform.python_version(), "opencv": cv2.__version__, "numpy": np.__version__}
    for name, dist in (
        ("weatherd", "hos-weatherd"),
        ("zenoh", "eclipse-zenoh"),
        ("mcap", "mcap"),
        ("av", "av"),
    ):
        with contextlib.suppress(metadata.PackageNotFoundError):
            out[name] = metadata.version(dist)
    return out


class CameraPipeline:
    """One camera: its capture thread and the processing thread that runs the detector.

    The processing thread takes the newest frame, runs the detector (segmentation of the next
    frame overlapping the analysis of this one), records the per-frame results, adds them to the
    camera's summary window and logs each change of verdict or state. A change of frame size (a
    camera reconnected at another resolution) starts a fresh detector.
    """

    def __init__(
        self,
        camera: CameraConfig,
        params: DetectorParams,
        *,
        site: str,
        stop: threading.Event,
        recorder: ResultRecorder | None,
        opener: Callable[[], FrameSource] | None = None,
        smoothing_s: float = 60.0,
        feed: CameraFeed | None = None,
    ):
        self.camera = camera
        self.feed = feed
        self.params = params
        self.site = site
        self.stop_event = stop
        self.results = recorder
        self.window = CameraWindow(camera.id, tau_s=smoothing_s)
        self.capture = CaptureThread(camera.id, opener or (lambda: _open_camera(camera)))
        self.heartbeat = time.monotonic()
        self.detector_state: str | None = None
        self.frames_processed = 0
        self._roi_image = _read_roi_image(camera)
        self._thread = threading.Thread(target=self._run, name=f"hos {camera.id}", daemon=True)
        self._verdict: tuple[bool, str] | None = None
        self._carry: LiveFrame | None = None
        self.error: str | None = None
        #: True once a finite source has ended (a file without ``loop``) or failed for good.
        self.finished = False

    def start(self) -> None:
        self.capture.start()
        self._thread.start()

    def stop(self, timeout: float = 10.0) -> None:
        self.capture.stop()
        self._thread.join(timeout)
        if self._thread.is_alive():
            log.warning(
                "camera %s: processing thread did not stop in %.0f s", self.camera.id, timeout
            )

    @property
    def alive(self) -> bool:
        return self._thread.is_alive()

    def _run(self) -> None:
        try:
            while not self.stop_event.is_set() and not self.finished:
                self._run_detector()
        except Exception:  # a programming error: logged, the watchdog then restarts us
            log.exception("camera %s: processing failed", self.camera.id)
            self.error = "processing thread failed"

    def _run_detector(self) -> None:
        """One detector over frames of one size; returns when the size changes or on stop."""
        in_flight: deque[LiveFrame] = deque()
        first = self._next_frame()
        if first is None:
            return
        shape = first.gray.shape
        t0_ns = first.t_ns
        last_t_s = -1.0
        detector = HosDetector(self.params, roi=self._roi(shape[1], shape[0]))
        log.info("camera %s: %dx%d frames, detector started", self.camera.id, shape[1], shape[0])

        def frames() -> Iterator[tuple[float, np.ndarray]]:
            nonlocal last_t_s
            frame: LiveFrame | None = first
            while frame is not None:
                if frame.gray.shape != shape:
                    log.info(
                        "camera %s: frame size changed to %dx%d; restarting the detector",
                        self.camera.id,
                        frame.gray.shape[1],
                        frame.gray.shape[0],
                    )
                    self._carry = frame
                    return
                # The detector's clock: seconds since its first frame, strictly increasing
                # across reconnections of the source.
                t_s = max((frame.t_ns - t0_ns) / 1e9, last_t_s + 1e-3)
                last_t_s = t_s
                in_flight.append(frame)
                yield t_s, frame.gray
                frame = self._next_frame()

        results = detect_frames(detector, frames())
        try:
            for result in results:
                started = time.perf_counter()
                self._handle(result, in_flight.popleft(), started)
        finally:
            results.close()

    def _next_frame(self) -> LiveFrame | None:
        """The newest frame, waiting for one; None once stopping."""
        if self._carry is not None:
            frame, self._carry = self._carry, None
            return frame
        while not self.stop_event.is_set():
            self.heartbeat = time.monotonic()
            frame = self.capture.take(timeout=0.5)
            if frame is not None:
                return frame
            if self.capture.state in ("ended", "failed"):
                log.info("camera %s: source %s; no more frames", self.camera.id, self.capture.state)
                self.finished = True
                return None
        return None

    def _handle(self, result: FrameResult, frame: LiveFrame, started: float) -> None:
        if self.results is not None:
            self.results.write(result, frame.gray, t_ns=frame.t_ns)
        self.frames_processed += 1
        self.detector_state = result.state
        verdict = (bool(result.rain), result.state, result.precipitation_type)
        if verdict != self._verdict:
            log.info(
                "camera %s: %s, state %s (pi_smoothed=%.2f, R=%.0f)",
                self.camera.id,
                _verdict_words(result),
                result.state,
                result.pi_smoothed,
                result.R if math.isfinite(result.R) else float("nan"),
            )
            self._verdict = verdict
        if self.feed is not None and self.feed.due():
            self.feed.put(_feed_frame(result, frame, self.params, width=self.feed.width))
        self.window.add(result, t_ns=frame.t_ns, processing_s=time.perf_counter() - started)

    def _roi(self, width: int, height: int) -> np.ndarray | None:
        roi = self.camera.roi
        if isinstance(roi, list):
            try:
                return polygon_mask(roi, width=width, height=height)
            except InputError as exc:
                # Only the frame size, known once frames come, shows this: better the whole
                # frame than no detection at an unattended site.
                log.error("camera %s: roi: %s; analysing the whole frame", self.camera.id, exc)
                return None
        if self._roi_image is None:
            return None
        return roi_for_size(self._roi_image, width=width, height=height)

    def stats(self) -> dict[str, Any]:
        cap = self.capture.stats()
        return {
            "source": cap.get("source") or mask_credentials(self.camera.source),
            "capture_state": cap.get("state", "unknown"),
            "detector_state": self.detector_state,
            "fps": _round(cap.get("fps")),
            "processing_ms": _round(self.window.last_processing_ms),
            "frames_captured": int(cap.get("frames_captured", 0)),
            "frames_processed": self.frames_processed,
            "frames_dropped": int(cap.get("frames_dropped", 0)),
            "reconnects": int(cap.get("reconnects", 0)),
            "last_frame_age_s": _round(cap.get("last_frame_age_s")),
            "last_error": self.error or cap.get("last_error"),
        }


def _feed_frame(
    result: FrameResult, frame: LiveFrame, params: DetectorParams, *, width: int
) -> FeedFrame:
    """What the status page shows of one frame: drawn now, as the result's arrays are only
    valid until the detector's next frame."""
    h, w = frame.gray.shape
    xs, ys, cls = blob_centroids(
        result.pixel_index,
        result.pixel_labels,
        result.blob_class,
        width=w,
        label_image=result.labels,
    )
    return FeedFrame(
        t_ns=frame.t_ns,
        jpeg=thumbnail_jpeg(frame.gray, result, params, width=width),
        width=w,
        height=h,
        result=result.to_json(),
        blobs_x=np.round(xs, 1).tolist(),
        blobs_y=np.round(ys, 1).tolist(),
        blobs_class=cls.tolist(),
    )


def _verdict_words(result: FrameResult) -> str:
    """A camera's verdict for the log: RAIN, SNOW, PRECIPITATION (type unknown) or no
    precipitation. The detector's ``rain`` is any falling precipitation, rain or snow."""
    if not result.rain:
        return "no precipitation"
    kind = result.precipitation_type
    return kind.upper() if kind in ("rain", "snow") else "PRECIPITATION (type unknown)"


def _round(x: float | None, nd: int = 3) -> float | None:
    return None if x is None or not math.isfinite(x) else round(float(x), nd)


def _open_camera(camera: CameraConfig) -> FrameSource:
    return open_source(
        camera.source,
        width=camera.width,
        height=camera.height,
        fps=camera.fps,
        loop=camera.loop,
        realtime=camera.realtime,
        max_pixels=camera.max_pixels,
    )


def _read_roi_image(camera: CameraConfig) -> np.ndarray | None:
    if not isinstance(camera.roi, str):  # none, or a polygon (drawn at each frame size)
        return None
    try:
        return read_roi_mask(camera.roi)
    except InputError as exc:
        raise ConfigError(f"camera {camera.id}: roi: {exc}") from None


class _NoPublisher:
    """Zenoh disabled in the configuration."""

    def put(self, suffix: str, message: dict[str, Any]) -> None:
        pass

    def stats(self) -> dict[str, Any]:
        return {"enabled": False}

    def close(self) -> None:
        pass


class Daemon:
    """The service: build it from a validated :class:`Config`, then :meth:`run` until ``stop``."""

    def __init__(
        self,
        config: Config,
        *,
        stop: threading.Event | None = None,
        config_path: str | os.PathLike[str] | None = None,
    ):
        self.config = config
        self.config_path = config_path
        self.site = config.site.id
        self.stop = stop or threading.Event()
        self.cameras = list(config.camera) or [DEMO_CAMERA]
        # Check everything that can be checked before anything starts.
        self.params = [
            config.camera_params(i) if config.camera else DetectorParams()
            for i in range(len(self.cameras))
        ]
        check_paths(config)
        self.recording_dir = default_recording_dir(config.recording)
        self.calibration = _calibration(config)
        self.persistence = Persistence(onset_s=config.fusion.onset_s, end_s=config.fusion.end_s)
        self.instruments = InstrumentHub(
            config.instrument, site=self.site, emit=self._emit, calibration=self.calibration
        )
        self.started_monotonic = time.monotonic()
        self.recorder: Recorder | None = None
        self.publisher: Publisher | _NoPublisher = _NoPublisher()
        self.pipelines: list[CameraPipeline] = []
        self.hub = WebHub(self.site)
        self.web: WebServer | None = None
        self._web_secrets = load_secrets(config.web) if config.web.enabled else None
        self._versions = versions()
        self._clock_synchronized: object = "unset"  # logged when it changes

    # -- life cycle ----------------------------------------------------------------------------
    def run(self) -> int:
        """Start, loop until ``stop`` is set, shut down; the exit status (0)."""
        with contextlib.ExitStack() as stack:
            self._start(stack)
            try:
                self._loop()
            finally:
                sdnotify.notify("STOPPING=1", "STATUS=stopping")
                log.info("stopping")
        log.info("stopped")
        return 0

    def _start(self, stack: contextlib.ExitStack) -> None:
        cfg = self.config
        if cfg.recording.enabled:
            self._open_recorder(stack)
        if cfg.zenoh.enabled:
            zc = cfg.zenoh
            conf = zenoh_config(
                mode=zc.mode, connect=zc.connect, listen=zc.listen, config_file=zc.config_file
            )
            publisher = ZenohPublisher(self.site, conf)
            stack.callback(publisher.close)
            publisher.start()
            self.publisher = publisher
        self.instruments.start()
        stack.callback(self.instruments.stop)
        for cam, params in zip(self.cameras, self.params, strict=True):
            results = (
                ResultRecorder(
                    self.recorder,
                    site=self.site,
                    camera=cam.id,
                    params=params,
                    config=cfg.recording,
                )
                if self.recorder is not None
                else None
            )
            feed = (
                self.hub.add_camera(
                    cam.id, interval_s=cfg.web.overlay_interval_s, width=cfg.web.overlay_width
                )
                if cfg.web.enabled
                else None
            )
            pipeline = CameraPipeline(
                cam, params, site=self.site, stop=self.stop, recorder=results, feed=feed
            )
            self.pipelines.append(pipeline)
            stack.callback(pipeline.stop)
            pipeline.start()
            log.info("camera %s: %s", cam.id, mask_credentials(cam.source))
        if cfg.web.enabled and self._web_secrets is not None:
            self.web = WebServer(
                cfg.web,
                self.hub,
                secrets=self._web_secrets,
                cameras=self.cameras,
                config_path=self.config_path,
            )
            self.web.start()
            stack.callback(self.web.stop)
        stack.callback(self.stop.set)  # runs first on the way out: every loop ends
        log.info(
            "site %s: %d camera(s), Zenoh %s, recording %s, detector kernels %s",
            self.site,
            len(self.pipelines),
            f"{cfg.zenoh.mode}" if cfg.zenoh.enabled else "off",
            self.recording_dir if self.recorder is not None else "off",
            "compiled" if _jit.ENABLED else f"numpy ({_jit.why_disabled()})",
        )
        sdnotify.notify("READY=1", f"STATUS=watching {len(self.pipelines)} camera(s)")

    def _open_recorder(self, stack: contextlib.ExitStack) -> None:
        rc = self.config.recording
        directory = self.recording_dir
        try:
            directory.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise ConfigError(
                f"recording.dir: cannot create {directory} ({exc.strerror})"
            ) from None
        # Repairing a large crashed file takes a while (about 5 MB/s): in the background, so
        # that start-up (and systemd's start timeout) does not wait for it. The recorder never
        # touches an earlier run's .part files, and repair renames into place atomically.
        # The unfinished files are listed now, before the new recording's own .part exists.
        unfinished = sorted(directory.glob("*.mcap.part"))
        repair = threading.Thread(
            target=_recover_recordings,
            args=(directory, unfinished),
            name="mcap repair",
            daemon=True,
        )
        repair.start()
        stack.callback(repair.join, 30.0)
        recorder = Recorder(
            directory,
            site=self.site,
            rotate_s=rc.rotate_s,
            rotate_bytes=int(rc.rotate_mb * 2**20),
            budget_bytes=int(rc.budget_mb * 2**20),
            min_free_bytes=int(rc.min_free_mb * 2**20),
            flush_interval_s=rc.flush_interval_s,
            fsync_interval_s=rc.fsync_interval_s,
        )
        stack.callback(recorder.close)
        handler = RecorderLogHandler(recorder)  # the log on /log, INFO and above
        logging.getLogger().addHandler(handler)
        stack.callback(logging.getLogger().removeHandler, handler)
        self.recorder = recorder

    # -- the main loop ---------------------------------------------------------------------------
    def _loop(self) -> None:
        pc = self.config.publish
        now = time.monotonic()
        due_camera = now + pc.camera_interval_s
        due_state = now + pc.state_interval_s
        due_status = now + min(2.0, pc.status_interval_s)  # a first status soon after start
        last_camera = now
        last_flush = now
        precipitation: object = "unset"
        watchdog = sdnotify.Watchdog.from_env()
        while not self.stop.is_set():
            time.sleep(TICK_S)  # not stop.wait: the signal handler runs on this thread
            now = time.monotonic()
            t_ns = time.time_ns()
            if now >= due_camera:
                window = now - last_camera
                last_camera = now
                due_camera = now + pc.camera_interval_s
                for p in self.pipelines:
                    msg = p.window.summary(
                        site=self.site,
                        t_ns=t_ns,
                        capture_state=p.capture.state,
                        window_s=window,
                    )
                    self._emit(f"camera/{p.camera.id}/hos", f"/hos/{p.camera.id}/summary", msg)
                    if self.config.calibration.online:
                        self.calibration.add_camera(
                            t_ns=t_ns,
                            r_mean=msg["R_mean"],
                            frames=msg["frames"],
                            judged=msg["frames_judged"],
                            rain_frames=msg["rain_frames"],
                        )
            self.calibration.tick(t_ns)
            state = fuse(
                {p.camera.id: p.window.view() for p in self.pipelines},
                site=self.site,
                t_ns=t_ns,
                stale_s=STALE_S,
                instruments=self.instruments.views(),
                camera_rate=self.calibration.rate_mm_h,
                calibration=self.calibration.quality(t_ns),
                persistence=self.persistence,
            )
            changed = state["precipitation"] != precipitation
            if changed or now >= due_state:
                if changed and precipitation != "unset":
                    kind = state.get("precipitation_type")
                    log.info(
                        "site %s: precipitation %s%s (was %s)%s",
                        self.site,
                        _WORDS[state["precipitation"]],
                        f", {kind}" if state["precipitation"] and kind else "",
                        _WORDS[precipitation],
                        f": {state['reason']}" if state.get("reason") else "",
                    )
                precipitation = state["precipitation"]
                due_state = now + pc.state_interval_s
                self._emit("state", "/weather/state", state)
                if state.get("camera_R") is not None:  # the camera's own rate, for the page
                    self.hub.note(
                        "camera_rate_mm_h",
                        self.calibration.rate_mm_h(state["camera_R"]),
                        t_ns=state["t_ns"],
                    )
            if now >= due_status:
                due_status = now + pc.status_interval_s
                self._emit("status", "/status", self.status(t_ns))
            if self.recorder is not None and now - last_flush >= 1.0:
                last_flush = now
                self.recorder.flush()
            if watchdog is not None and self._healthy(now):
                watchdog.kick()

    def _emit(self, suffix: str | None, topic: str, message: dict[str, Any]) -> None:
        """Publish under ``weather/<site>/<suffix>`` (unless None) and record on ``topic``."""
        if suffix is not None:
            self.publisher.put(suffix, message)
            self.hub.publish(suffix, message)
        if self.recorder is not None:
            kind = message["schema"].split("/")[0]
            self.recorder.write(topic, kind, schema_for(kind), message, t_ns=message["t_ns"])

    def _healthy(self, now: float) -> bool:
        """Every processing thread alive and looping: the watchdog may be kicked."""
        return all(
            (p.finished and p.error is None) or (p.alive and now - p.heartbeat < HUNG_S)
            for p in self.pipelines
        )

    def status(self, t_ns: int) -> dict[str, Any]:
        """``weather.status/1``."""
        recorder: dict[str, Any] = {"enabled": self.recorder is not None}
        if self.recorder is not None:
            recorder |= self.recorder.stats()
            recorder["dir"] = str(self.recording_dir)
        return stamp(
            "weather.status",
            site=self.site,
            t_ns=t_ns,
            uptime_s=round(time.monotonic() - self.started_monotonic, 3),
            versions=self._versions,
            cameras={p.camera.id: p.stats() for p in self.pipelines},
            recorder=recorder,
            zenoh=self.publisher.stats(),
            instruments=self.instruments.stats(),
            calibration=self.calibration.quality(t_ns),
            clock=self._clock(),
            pid=os.getpid(),
            web=self.web.stats() if self.web is not None else {"enabled": False},
        )

    def _clock(self) -> dict[str, Any]:
        """The system clock's synchronisation, for the status; a log line when it changes."""
        clock = clock_status()
        if clock.synchronized != self._clock_synchronized:
            self._clock_synchronized = clock.synchronized
            if clock.synchronized:
                log.info("clock synchronised (%s)", clock.source)
            elif clock.synchronized is None:
                log.warning("clock synchronisation unknown: recorded UTC times are unchecked")
            else:
                log.warning(
                    "clock NOT synchronised (%s): recorded UTC times may be wrong, and the "
                    "offline comparison with station data with them",
                    clock.source,
                )
        return clock.to_json()


def _calibration(config: Config) -> OnlineCalibration:
    """The site calibration: an offline file as the prior, learnt online from instruments."""
    cc = config.calibration
    prior = load_calibration_file(cc.file) if cc.file else None
    params = CalibrationParams(
        window_s=cc.window_s, min_windows=cc.min_windows, min_rate_mm_h=cc.min_rate_mm_h
    )
    path = state_dir(config.site) / "calibration.json" if cc.online else None
    return OnlineCalibration(params, state_path=path, prior=prior)


def _recover_recordings(directory: Path, parts: list[Path]) -> None:
    try:
        for result in recover_directory(directory, parts=parts):
            if result.dst is not None:
                log.info(
                    "recovered an unfinished recording: %s -> %s (%d messages, %d bytes dropped)",
                    result.src,
                    result.dst,
                    result.messages,
                    result.bytes_dropped,
                )
            else:
                log.info("removed an empty unfinished recording: %s", result.src)
    except Exception:
        log.exception("repairing unfinished recordings in %s failed", directory)


def check_paths(config: Config) -> None:
    """Raise :class:`ConfigError` for what only shows when used: unreadable ROI masks, camera
    sources that do not parse, Zenoh endpoints or a Zenoh config file that Zenoh refuses
    (:class:`ConfigErrors`: all of them)."""
    zc = config.zenoh
    checks: list[Callable[[], object]] = []
    for cam in config.camera:
        checks += [functools.partial(_read_roi_image, cam), functools.partial(_open_camera, cam)]
    if zc.enabled:
        checks.append(
            functools.partial(
                zenoh_config,
                mode=zc.mode,
                connect=zc.connect,
                listen=zc.listen,
                config_file=zc.config_file,
            )
        )
    checks.append(lambda: InstrumentHub(config.instrument, site=config.site.id, emit=_ignore))
    if config.calibration.file:  # the online state is only read by run, which warns on it
        checks.append(functools.partial(load_calibration_file, config.calibration.file))
    if config.web.enabled:
        checks.append(functools.partial(load_secrets, config.web))
    errors = []
    for check in checks:  # none does I/O beyond reading files
        try:
            check()
        except ConfigError as exc:
            errors += error_lines(exc)
    if errors:
        raise config_error(errors)


def _ignore(*_: object) -> None:
    """An instrument hub's ``emit`` while only checking the configuration."""
