"""Network streams (RTSP, HTTP MJPEG, HLS, MPEG-TS...) decoded by FFmpeg through PyAV.

A worker thread owns the PyAV container: it opens it, demuxes and decodes, and hands decoded
frames to :meth:`StreamSource.read` through a small queue (the oldest is dropped if the reader
falls behind: a live stream must be drained). Only that thread touches the container, so
:meth:`StreamSource.close` from any thread is safe and prompt: it flags the worker, which
closes the container as soon as FFmpeg returns, within the read timeout at worst.

Timeouts, so that a stalled stream raises :class:`SourceError` within seconds:

- PyAV's interrupt callback (``av.open(timeout=(open, read))``) aborts a blocked open or read;
- FFmpeg's own socket timeouts (``rw_timeout``, and ``timeout`` for RTSP) as a second line;
- :meth:`~StreamSource.read` gives up after ``timeout_s`` plus a margin without a frame (a
  stream that sends packets but no decodable video).

RTSP goes over TCP by default (``rtsp_transport=tcp``): UDP loses packets through NAT and
firewalls and smears the frames. A stream that ends is a failure (a live stream has no end):
the capture thread reconnects.

Wall-clock times (``t_ns``): from the RTSP sender reports (FFmpeg's ``start_time_realtime``)
once the first one has arrived, from the PTS when they are wall-clock times (within a minute
of the clock), else the time the frame was decoded.
"""

from __future__ import annotations

import logging
import queue
import threading
import time
from dataclasses import dataclass

import av

from .errors import SourceError
from .frames import LiveFrame, fit_size
from .video import DEFAULT_FPS, _luma, _reason, _seconds, _Timeline, _valid_rate

__all__ = ["StreamSource", "stream_source"]

log = logging.getLogger(__name__)

#: Decoded frames queued for the reader; the oldest is dropped beyond this.
_QUEUE_FRAMES = 4
#: Seconds :meth:`StreamSource.read` waits beyond the FFmpeg timeout before giving up itself.
_MARGIN_S = 1.0
#: How often a waiting reader checks whether the source was closed, seconds.
_POLL_S = 0.05
#: PTS within this many seconds of a clock are taken as times of that clock.
_CLOCK_TOLERANCE_S = 60.0
#: RTSP sender-report times further than this from the local clock are ignored, seconds.
_RTCP_TOLERANCE_S = 600.0


def stream_source(
    url: str,
    *,
    width: int | None = None,
    height: int | None = None,
    timeout_s: float = 5.0,
    options: dict[str, str] | None = None,
) -> StreamSource:
    """A :class:`StreamSource` for an ``rtsp(s)://`` or ``http(s)://`` URL, with FFmpeg's
    timeouts and transport set (``options`` override them)."""
    from .frames import mask_credentials

    timeout_us = str(round(timeout_s * 1e6))
    defaults = {"rw_timeout": timeout_us}
    if url.lower().startswith(("rtsp://", "rtsps://")):
        defaults |= {"rtsp_transport": "tcp", "timeout": timeout_us}
    defaults |= options or {}
    return StreamSource(
        url,
        name=mask_credentials(url),
        options=defaults,
        width=width,
        height=height,
        timeout_s=timeout_s,
    )


@dataclass(frozen=True)
class _Decoded:
    """A frame from the worker, with what is known of its time."""

    frame: av.VideoFrame
    pts_s: float | None  # stream time, seconds
    received_ns: int  # time.time_ns() when decoded
    received_mono_ns: int  # time.monotonic_ns() at the same moment
    realtime_us: int | None  # the container's start_time_realtime (RTSP sender reports)


@dataclass(frozen=True)
class _Failed:
    reason: str


class StreamSource:
    """Frames from anything FFmpeg opens as a live stream, read with timeouts.

    Parameters
    ----------
    url : what FFmpeg opens (a URL or a device path)
    name : for logs, without credentials
    format : FFmpeg input format (``"v4l2"``), None to let FFmpeg guess
    options : FFmpeg options (strings)
    width, height : resize frames of another size to this size, pixels
    timeout_s : seconds allowed to open, and between frames
    monotonic_pts : the PTS may be ``CLOCK_MONOTONIC`` times (V4L2 buffer times)

    Attributes
    ----------
    fps : float or None, the stream's frame rate once open (guessed by FFmpeg)
    frames_skipped : int, packets or frames that failed to decode
    frames_dropped : int, decoded frames dropped because the reader fell behind
    """

    def __init__(
        self,
        url: str,
        *,
        name: str,
        format: str | None = None,
        options: dict[str, str] | None = None,
        width: int | None = None,
        height: int | None = None,
        timeout_s: float = 5.0,
        monotonic_pts: bool = False,
    ):
        self.name = name
        self.fps: float | None = None
        self.frames_skipped = 0
        self.frames_dropped = 0
        self._url = url
        self._format = format
        self._options = dict(options or {})
        self._size = (width, height)
        self._timeout_s = float(timeout_s)
        self._monotonic_pts = monotonic_pts
        self._queue: queue.Queue[_Decoded | _Failed] = queue.Queue(maxsize=_QUEUE_FRAMES)
        self._closed = threading.Event()
        self._ready = threading.Event()
        self._open_failure: str | None = None
        self._thread: threading.Thread | None = None
        self._timeline: _Timeline | None = None
        self._index = 0

    # -- reader side (the capture thread) ------------------------------------------------
    def open(self) -> None:
        if self._thread is not None:
            raise SourceError(f"{self.name}: opened twice")
        self._thread = threading.Thread(target=self._run, name=f"stream {self.name}", daemon=True)
        self._thread.start()
        deadline = time.monotonic() + self._timeout_s + _MARGIN_S
        while not self._ready.wait(_POLL_S):
            if self._closed.is_set():
                raise SourceError(f"{self.name}: closed")
            if time.monotonic() > deadline:
                self.close()
                raise SourceError(f"{self.name}: no answer within {self._timeout_s:g} s")
        if self._open_failure is not None:
            raise SourceError(f"{self.name}: cannot open ({self._open_failure})")
        self._timeline = _Timeline(self.fps or DEFAULT_FPS)

    def read(self) -> LiveFrame:
        if self._timeline is None:
            raise SourceError(f"{self.name}: not open")
        item = self._take()
        if isinstance(item, _Failed):
            raise SourceError(f"{self.name}: {item.reason}")
        gray = fit_size(_luma(item.frame), *self._size)
        frame = LiveFrame(self._index, self._timeline(item.pts_s), self._wall_ns(item), gray)
        self._index += 1
        return frame

    def _take(self) -> _Decoded | _Failed:
        limit_s = self._timeout_s + _MARGIN_S
        deadline = time.monotonic() + limit_s
        while not self._closed.is_set():
            try:
                return self._queue.get(timeout=_POLL_S)
            except queue.Empty:
                if time.monotonic() > deadline:
                    return _Failed(f"no frame for {limit_s:g} s")
        raise SourceError(f"{self.name}: closed")

    def _wall_ns(self, item: _Decoded) -> int:
        """UTC time of a frame, ns: sender report, wall-clock or monotonic PTS, else receipt."""
        received = item.received_ns
        if item.pts_s is None:
            return received
        pts_ns = round(item.pts_s * 1e9)
        if item.realtime_us is not None:
            t_ns = item.realtime_us * 1000 + pts_ns
            if abs(t_ns - received) < _RTCP_TOLERANCE_S * 1e9:
                return t_ns
        if abs(pts_ns - received) < _CLOCK_TOLERANCE_S * 1e9:
            return pts_ns
        if self._monotonic_pts and abs(pts_ns - item.received_mono_ns) < _CLOCK_TOLERANCE_S * 1e9:
            return received - (item.received_mono_ns - pts_ns)
        return received

    def close(self) -> None:
        """Flag the worker to stop and close the container; returns at once (idempotent)."""
        self._closed.set()

    def describe(self, exc: BaseException) -> str:
        """One line saying why FFmpeg failed (overridden for devices)."""
        if isinstance(exc, av.ExitError):
            return f"timed out after {self._timeout_s:g} s"
        return _reason(exc)

    # -- worker thread ---------------------------------------------------------------------
    def _run(self) -> None:
        try:
            container = av.open(
                self._url,
                format=self._format,
                options=self._options,
                timeout=(self._timeout_s, self._timeout_s),
                metadata_errors="ignore",
            )
        except Exception as exc:  # av.FFmpegError, OSError, ValueError: reported to open()
            self._open_failure = self.describe(exc)
            self._ready.set()
            return
        try:
            if not container.streams.video:
                self._open_failure = "no video stream"
                return
            stream = container.streams.video[0]
            self.fps = _valid_rate(stream.average_rate or stream.guessed_rate)
            self._ready.set()
            self._pump(container, stream)
        except Exception as exc:
            self._put(_Failed(self.describe(exc)))
        finally:
            self._ready.set()
            container.close()

    def _pump(self, container: av.container.InputContainer, stream: av.VideoStream) -> None:
        """Demux and decode until the stream ends, fails or the source is closed."""
        for packet in container.demux(stream):
            if self._closed.is_set():
                return
            if not packet.size:  # PyAV's flush packets at the end
                continue
            try:
                frames = packet.decode()
            except av.FFmpegError as exc:
                self._skip(exc)
                continue
            received_ns, received_mono_ns = time.time_ns(), time.monotonic_ns()
            realtime_us = container.start_time_realtime
            for frame in frames:
                if frame.is_corrupt:
                    self._skip("frame decoded with errors")
                    continue
                pts_s = _seconds(frame.pts, stream.time_base)
                self._put(_Decoded(frame, pts_s, received_ns, received_mono_ns, realtime_us))
        if not self._closed.is_set():
            self._put(_Failed("the stream ended"))

    def _put(self, item: _Decoded | _Failed) -> None:
        """Queue an item, dropping the oldest frame if the reader fell behind."""
        while not self._closed.is_set():
            try:
                self._queue.put_nowait(item)
                return
            except queue.Full:
                try:
                    self._queue.get_nowait()
                    self.frames_dropped += 1
                except queue.Empty:
                    pass

    def _skip(self, why: object) -> None:
        if self.frames_skipped == 0:
            log.warning("%s: skipping undecodable data (%s)", self.name, _reason(why))
        self.frames_skipped += 1
