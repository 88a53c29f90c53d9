"""V4L2 cameras (``v4l2:/dev/video0``) through FFmpeg's ``v4l2`` input.

The camera is asked for the requested size (``video_size``) and rate (``framerate``); extra
FFmpeg options come from the spec's query (``v4l2:/dev/video0?input_format=mjpeg``). Frame
times come from the driver's buffer timestamps (``CLOCK_MONOTONIC`` on UVC cameras), turned
into UTC at receipt. Errors say what to check: an unplugged camera, the ``video`` group, a
device held by another program.
"""

from __future__ import annotations

import errno
import os

from .errors import SourceError
from .stream import StreamSource

__all__ = ["V4L2Source", "v4l2_source"]

_HINTS = {
    errno.ENOENT: "no such device: camera unplugged?",
    errno.ENODEV: "no such device: camera unplugged?",
    errno.EACCES: "permission denied: is the user in the 'video' group?",
    errno.EPERM: "permission denied: is the user in the 'video' group?",
    errno.EBUSY: "device busy: is another program using the camera?",
    errno.EIO: "input/output error: camera disconnected or failing?",
}


class V4L2Source(StreamSource):
    """A V4L2 camera; see :class:`~drivers.stream.StreamSource` for the reading."""

    def __init__(self, device: str, **kwargs: object):
        self.device = device
        super().__init__(device, name=f"v4l2:{device}", format="v4l2", **kwargs)

    def open(self) -> None:
        if not os.path.exists(self.device):
            raise SourceError(f"{self.name}: {_HINTS[errno.ENOENT]}")
        super().open()

    def describe(self, exc: BaseException) -> str:
        hint = _HINTS.get(getattr(exc, "errno", None) or 0)
        return hint or super().describe(exc)


def v4l2_source(
    device: str,
    *,
    width: int | None = None,
    height: int | None = None,
    fps: float | None = None,
    timeout_s: float = 5.0,
    options: dict[str, str] | None = None,
) -> V4L2Source:
    """A V4L2 camera asked for ``width`` x ``height`` pixels at ``fps`` Hz (each None: the
    camera's default); ``options`` are more FFmpeg ``v4l2`` options (``input_format``...)."""
    requested: dict[str, str] = {}
    if width is not None and height is not None:
        requested["video_size"] = f"{width}x{height}"
    if fps is not None:
        requested["framerate"] = f"{fps:g}"
    requested |= options or {}
    return V4L2Source(
        device,
        options=requested,
        width=width,
        height=height,
        timeout_s=timeout_s,
        monotonic_pts=True,
    )
