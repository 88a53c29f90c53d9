"""``file:PATH``: a video file or image folder read as a live source."""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator
from pathlib import Path

from .errors import InputError, SourceError
from .frames import LiveFrame, Pacer, fit_size
from .video import DEFAULT_FPS, VideoReader, open_video

__all__ = ["FileSource"]


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
        max_pixels: int | None = None,
    ):
        self.name = f"file:{path}"
        self.path = path
        self.fps = fps or DEFAULT_FPS
        self._size = (width, height)
        self._fps_hint = fps
        self._loop = loop
        self._realtime = realtime
        self._max_pixels = max_pixels
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
            reader = open_video(self.path, fps=self._fps_hint, max_pixels=self._max_pixels)
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
