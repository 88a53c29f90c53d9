"""The frame source protocol: what every camera, stream, file and the demo street give.

A source is opened, read and closed by one thread (the capture thread), except :meth:`close`,
which any thread may call at any time: it makes a blocked :meth:`~FrameSource.open` or
:meth:`~FrameSource.read` return promptly by raising :class:`SourceError`.

Times: ``t_s`` is the stream's own clock (seconds since its first frame, strictly increasing,
what the detector wants); ``t_ns`` is the UTC wall-clock time of the frame, taken from the
source where it has one (RTSP sender reports, wall-clock PTS such as V4L2 buffer times), else
the time it was received. For files and the demo, ``t_ns`` is the open time plus ``t_s``,
paced or not: a file read faster than real time gets times in the future, consistent with its
own clock.

This module imports no source: each source module (``file_source``, ``demo``, ``stream``,
``v4l2``) imports it, and :mod:`drivers.sources` maps a spec's scheme to its source.
:class:`MemorySource` is an in-memory double for tests.
"""

from __future__ import annotations

import re
import threading
import time
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Protocol

import cv2
import numpy as np

from .errors import SourceError

__all__ = [
    "DEFAULT_TIMEOUT_S",
    "FrameSource",
    "LiveFrame",
    "MemorySource",
    "Pacer",
    "fit_size",
    "mask_credentials",
]

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


def mask_credentials(spec: str) -> str:
    """The spec fit for logs: ``user:password@`` and secret-looking query values masked.

    >>> mask_credentials("rtsp://admin:hunter2@10.0.0.5/stream1?token=abc&ch=1")
    'rtsp://***@10.0.0.5/stream1?token=***&ch=1'
    """
    masked = _USERINFO.sub("***@", spec, count=1)
    head, sep, query = masked.partition("?")
    return head + sep + _SECRET_QUERY.sub(r"\1***", query) if sep else masked


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
