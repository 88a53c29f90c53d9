"""The outside world behind small interfaces.

Frames: :mod:`.frames` is the :class:`FrameSource` protocol; :func:`open_source` (in
:mod:`.sources`) maps a spec to a source: a video file or image folder (:mod:`.file_source`,
decoded by :mod:`.video` with PyAV), a V4L2 camera, an RTSP/HTTP stream, or the demo camera
(:mod:`.demo`) over the simulated street of :mod:`.simulator`. Serial instruments are in
:mod:`.instruments`. :mod:`.errors` is the one exception hierarchy of the project.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from .errors import ConfigError, InputError, SourceError, WeatherdError

if TYPE_CHECKING:
    from .frames import FrameSource, LiveFrame, MemorySource, mask_credentials
    from .sources import open_source
    from .video import Frame, VideoReader, open_video

# The frame sources (OpenCV, PyAV) load when first named (PEP 562), not with the package:
# ``drivers.errors`` is imported by every command, including those that read no frame.
_LAZY = {
    "FrameSource": ".frames",
    "LiveFrame": ".frames",
    "MemorySource": ".frames",
    "mask_credentials": ".frames",
    "open_source": ".sources",
    "Frame": ".video",
    "VideoReader": ".video",
    "open_video": ".video",
}


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(module, __name__), name)
    globals()[name] = value
    return value


__all__ = [
    "ConfigError",
    "Frame",
    "FrameSource",
    "InputError",
    "LiveFrame",
    "MemorySource",
    "SourceError",
    "VideoReader",
    "WeatherdError",
    "mask_credentials",
    "open_source",
    "open_video",
]
