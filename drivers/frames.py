"""Live frame sources: one small protocol over cameras, streams, files and the demo street.

:func:`open_source` turns a source spec (contract) into a :class:`FrameSource`:

=====================  ============================================================  ==========
spec                   source                                                        module
=====================  ============================================================  ==========
``v4l2:/dev/video0``   a V4L2 camera (``?input_format=mjpeg`` etc. pass FFmpeg        v4l2
                       options)
``file:PATH``          a video file or image folder; ``loop`` restarts it at the end,  frames
                       ``realtime`` paces frames at the file's rate
``rtsp://``,           a network stream FFmpeg opens (RTSP over TCP, MJPEG over HTTP,  stream
``rtsps://``,          HLS, MPEG-TS...), opened and read with timeouts
``http(s)://``
``demo:``              the built-in synthetic street (``demo:?seed=3``)                demo
=====================  ============================================================  ==========

A source is opened, read and closed by one thread (the capture thread), except :meth:`close`,
which any thread may call at any time: it makes a blocked :meth:`~FrameSource.open` or
:meth:`~FrameSource.read` return promptly by raising :class:`SourceError`.

Times: ``t_s`` is the stream's own clock (seconds since its first frame, strictly increasing,
what the detector wants); ``t_ns`` is the UTC wall-clock time of the frame, taken from the
source where it has one (RTSP sender reports, wall-clock PTS such as V4L2 buffer times), else
the time it was received. For files and the demo, ``t_ns`` is the open time plus ``t_s``,
paced or not: a file read faster than real time gets times in the future, consistent with its
own clock.

:class:`MemorySource` is an in-memory double for tests.
"""

from __future__ import annotations

import re
import threading
import time
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol
from urllib.parse import parse_qsl

import cv2
import numpy as np

from .errors import ConfigError, InputError, SourceError
from .video import DEFAULT_FPS, VideoReader, open_video

__all__ = [
    "SCHEMES",
    "FileSource",
    "FrameSource",
    "LiveFrame",
    "MemorySource",
    "Pacer",
    "fit_size",
    "mask_credentials",
    "open_source",
]

#: The spec prefixes :func:`open_source` knows (compared case-insensitively).
SCHEMES = ("v4l2:", "file:", "demo:", "rtsp://", "rtsps://", "http://", "https://")
#: Default seconds a network stream or camera may stay silent before it counts as failed.
DEFAULT_TIMEOUT_S = 5.0

_USERINFO = re.compile(r"(?<=://)[^/@?#]*@")
_SECRET_QUERY = re.compile(r"((?:pass|pwd|token|key|secret|auth|sig)[^=&]*=)[^&#]*", re.IGNORECASE)


@dataclass(frozen=True)
class LiveFrame:
    """One frame from a live source.

    Attributes
    ----------
    index : int, 0-based count of the frames delivered since the source was opened
    t_s : float, seconds since the stream's first frame; strictly increasing
    t_ns : int, UTC wall-clock time of the frame, ns since the Unix epoch (see the module doc)
    gray : (H, W) uint8, owned by this frame
    """

    index: int
    t_s: float
    t_ns: int
    gray: np.ndarray


class FrameSource(Protocol):
    """What the capture thread reads frames from.

    ``name`` is the spec without credentials, for logs. :meth:`close` is idempotent and may
    be called from another thread while :meth:`open` or :meth:`read` is blocked.
    """

    name: str

    def open(self) -> None:
        """Connect; raises SourceError (recoverable) or, for a file, InputError."""

    def read(self) -> LiveFrame | None:
        """The next frame; None at the clean end of a finite source; SourceError on a failure
        or a stall (timeout) or when closed meanwhile."""

    def close(self) -> None:
        """Release the source; idempotent, callable from any thread."""


def open_source(
    spec: str,
    *,
    width: int | None = None,
    height: int | None = None,
    fps: float | None = None,
    loop: bool = False,
    realtime: bool = True,
    timeout_s: float = DEFAULT_TIMEOUT_S,
    options: Mapping[str, str] | None = None,
) -> FrameSource:
    """Make the frame source a spec names, not yet opened (no I/O happens here).

    Parameters
    ----------
    spec : ``v4l2:DEVICE``, ``file:PATH``, ``rtsp://...``, ``rtsps://...``, ``http(s)://...``
        or ``demo:`` (see the module doc)
    width, height : requested frame size, pixels. A camera is asked for it; the demo renders
        it (default 640x360); frames of another size from any source are resized to it.
    fps : requested frame rate, Hz: asked of a camera; the demo's rate (default 25); the rate
        of an image folder (default 25). Ignored by network streams.
    loop, realtime : ``file:`` only: restart at the end; pace frames at the file's rate
        (else as fast as they are read). ``realtime`` also paces the demo.
    timeout_s : network streams and cameras: seconds allowed to open and between frames
        before the source counts as failed
    options : FFmpeg options for streams and cameras, over the defaults
        (e.g. ``{"rtsp_transport": "udp"}``)

    Raises
    ------
    ConfigError : unknown scheme or malformed spec, naming the spec (without credentials).
    """
    name = mask_credentials(spec)
    lower = spec.lower()
    scheme = next((s for s in SCHEMES if lower.startswith(s)), None)
    if scheme is None:
        known = ", ".join(f"{s}..." for s in SCHEMES)
        raise ConfigError(f"{name}: unknown frame source (use one of {known})")
    if (width is None) != (height is None):
        raise ConfigError(f"{name}: give both width and height, or neither")
    for key, value in (("width", width), ("height", height), ("fps", fps), ("timeout", timeout_s)):
        if value is not None and not value > 0:
            raise ConfigError(f"{name}: {key} must be > 0, got {value}")
    rest = spec[len(scheme) :]
    if scheme == "demo:":
        from .demo import DemoSource

        return DemoSource(
            width=width or 640,
            height=height or 360,
            fps=fps or 25.0,
            realtime=realtime,
            **_demo_query(name, rest),
        )
    if scheme == "file:":
        path = rest[2:] if rest.startswith("//") else rest  # file:///x is file:/x
        if not path:
            raise ConfigError(f"{name}: no file or folder after 'file:'")
        return FileSource(
            Path(path).expanduser(),
            width=width,
            height=height,
            fps=fps,
            loop=loop,
            realtime=realtime,
        )
    if scheme == "v4l2:":
        from .v4l2 import v4l2_source

        device, _, query = rest.partition("?")
        if not device:
            raise ConfigError(f"{name}: no device after 'v4l2:' (e.g. v4l2:/dev/video0)")
        extra = dict(parse_qsl(query, keep_blank_values=True))
        extra.update(options or {})
        return v4l2_source(
            device, width=width, height=height, fps=fps, timeout_s=timeout_s, options=extra
        )
    from .stream import stream_source

    if len(rest.split("/", 1)[0].rsplit("@", 1)[-1]) == 0:
        raise ConfigError(f"{name}: no host in the URL")
    return stream_source(
        spec, width=width, height=height, timeout_s=timeout_s, options=dict(options or {})
    )


def mask_credentials(spec: str) -> str:
    """The spec fit for logs: ``user:password@`` and secret-looking query values masked.

    >>> mask_credentials("rtsp://admin:hunter2@10.0.0.5/stream1?token=abc&ch=1")
    'rtsp://***@10.0.0.5/stream1?token=***&ch=1'
    """
    masked = _USERINFO.sub("***@", spec, count=1)
    head, sep, query = masked.partition("?")
    return head + sep + _SECRET_QUERY.sub(r"\1***", query) if sep else masked


def _demo_query(name: str, query: str) -> dict[str, int]:
    """``?seed=3`` of a demo spec as keyword arguments."""
    query = query.removeprefix("//").removeprefix("?")
    out: dict[str, int] = {}
    for key, value in parse_qsl(query, keep_blank_values=True):
        if key != "seed":
            raise ConfigError(f"{name}: unknown demo option {key!r} (known: seed)")
        try:
            out["seed"] = int(value)
        except ValueError:
            raise ConfigError(f"{name}: seed must be an integer, got {value!r}") from None
    return out


def fit_size(gray: np.ndarray, width: int | None, height: int | None) -> np.ndarray:
    """``gray`` resized to (height, width) pixels if a size is given and differs, else as is."""
    if width is None or height is None or gray.shape == (height, width):
        return gray
    shrink = width * height < gray.shape[0] * gray.shape[1]
    interpolation = cv2.INTER_AREA if shrink else cv2.INTER_LINEAR
    return cv2.resize(gray, (width, height), interpolation=interpolation)


class Pacer:
    """Holds frames back until their time: the frame at ``t_s`` is due ``t_s`` seconds after
    the first one (monotonic clock). A consumer more than ``max_lag_s`` late re-anchors the
    schedule instead of receiving a burst of overdue frames.

    Parameters
    ----------
    cancel : an event that ends a wait early (set by the source's ``close``)
    max_lag_s : seconds, lateness beyond which the schedule restarts from now
    """

    def __init__(self, cancel: threading.Event, *, max_lag_s: float = 1.0):
        self._cancel = cancel
        self._max_lag_s = max_lag_s
        self._origin: float | None = None

    def wait(self, t_s: float) -> bool:
        """Sleep until ``t_s`` is due; False if cancelled."""
        now = time.monotonic()
        if self._origin is None or now - (self._origin + t_s) > self._max_lag_s:
            self._origin = now - t_s
        delay = self._origin + t_s - now
        if delay > 0:
            return not self._cancel.wait(delay)
        return not self._cancel.is_set()


class FileSource:
    """A video file or image folder read as a live source (decoded by :func:`open_video`).

    With ``loop`` the file is reopened at its end and its clock continues (one frame period
    after the last frame); a file that has gone by then raises :class:`SourceError`. A missing
    or unreadable file at :meth:`open` raises :class:`InputError`.

    Attributes
    ----------
    fps : float, the file's frame rate (known once open)
    frames_skipped : int, corrupt frames skipped by the decoder so far
    """

    def __init__(
        self,
        path: Path,
        *,
        width: int | None = None,
        height: int | None = None,
        fps: float | None = None,
        loop: bool = False,
        realtime: bool = True,
    ):
        self.name = f"file:{path}"
        self.path = path
        self.fps = fps or DEFAULT_FPS
        self._size = (width, height)
        self._fps_hint = fps
        self._loop = loop
        self._realtime = realtime
        self._closed = threading.Event()
        self._lock = threading.Lock()
        self._reader: VideoReader | None = None
        self._frames: Iterator = iter(())
        self._pacer = Pacer(self._closed)
        self._index = 0
        self._offset_s = 0.0
        self._last_t_s = -1.0
        self._open_ns = 0
        self._skipped_before = 0

    @property
    def frames_skipped(self) -> int:
        current = self._reader.frames_skipped if self._reader is not None else 0
        return self._skipped_before + current

    def open(self) -> None:
        self._open_ns = time.time_ns()
        self._start_reader()

    def _start_reader(self) -> None:
        with self._lock:
            if self._closed.is_set():
                raise SourceError(f"{self.name}: closed")
            if self._reader is not None:
                self._skipped_before += self._reader.frames_skipped
                self._reader.close()
                self._reader = None
            reader = open_video(self.path, fps=self._fps_hint)
            self._reader, self._frames, self.fps = reader, iter(reader), reader.fps

    def read(self) -> LiveFrame | None:
        if self._closed.is_set():
            raise SourceError(f"{self.name}: closed")
        frame = next(self._frames, None)
        if frame is None and self._loop and not self._closed.is_set():
            self._offset_s = self._last_t_s + 1.0 / self.fps
            try:
                self._start_reader()
            except InputError as exc:
                raise SourceError(f"cannot restart the loop: {exc}") from None
            frame = next(self._frames, None)
        if self._closed.is_set():
            raise SourceError(f"{self.name}: closed")
        if frame is None:
            return None
        t_s = self._offset_s + frame.t_s
        if self._realtime and not self._pacer.wait(t_s):
            raise SourceError(f"{self.name}: closed")
        self._last_t_s = t_s
        gray = fit_size(frame.gray, *self._size)
        live = LiveFrame(self._index, t_s, self._open_ns + round(t_s * 1e9), gray)
        self._index += 1
        return live

    def close(self) -> None:
        self._closed.set()
        with self._lock:
            if self._reader is not None:
                self._reader.close()


class MemorySource:
    """In-memory :class:`FrameSource` double for tests.

    Parameters
    ----------
    items : what successive reads give, shared by every source made over the same iterator:
        an (H, W) uint8 array is a frame, an exception is raised, ``None`` ends the source
        (read returns None), :attr:`BLOCK` blocks the read until :meth:`close`. When the items
        run out, reads end the source (``end=True``) or block (``end=False``).
    open_error : raised by :meth:`open` if given
    fps : frame rate for ``t_s`` (frame i at i / fps)
    interval_s : seconds each read waits before giving its item (a camera's pace)
    """

    BLOCK = object()

    def __init__(
        self,
        items: Iterable[object] = (),
        *,
        name: str = "memory:",
        open_error: BaseException | None = None,
        fps: float = 25.0,
        interval_s: float = 0.0,
        end: bool = True,
    ):
        self.name = name
        self._items = iter(items)
        self._open_error = open_error
        self._fps = fps
        self._interval_s = interval_s
        self._end = end
        self._closed = threading.Event()
        self._index = 0
        self._open_ns = 0
        self.opened = False

    @property
    def closed(self) -> bool:
        return self._closed.is_set()

    def open(self) -> None:
        if self._open_error is not None:
            raise self._open_error
        self._open_ns = time.time_ns()
        self.opened = True

    def read(self) -> LiveFrame | None:
        if self._interval_s > 0 and self._closed.wait(self._interval_s):
            raise SourceError(f"{self.name}: closed")
        item = next(self._items, None if self._end else self.BLOCK)
        if item is self.BLOCK:
            self._closed.wait()
        if self._closed.is_set():
            raise SourceError(f"{self.name}: closed")
        if item is None:
            return None
        if isinstance(item, BaseException):
            raise item
        t_s = self._index / self._fps
        frame = LiveFrame(self._index, t_s, self._open_ns + round(t_s * 1e9), np.asarray(item))
        self._index += 1
        return frame

    def close(self) -> None:
        self._closed.set()
