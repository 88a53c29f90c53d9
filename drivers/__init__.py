"""The outside world behind small interfaces.

Frames: :mod:`.frames` is the :class:`FrameSource` protocol; :func:`open_source` (in
:mod:`.sources`) maps a spec to a source: a video file or image folder (:mod:`.file_source`,
decoded by :mod:`.video` with PyAV), a V4L2 camera, an RTSP/HTTP stream, or the demo camera
(:mod:`.demo`) over the simulated street of :mod:`.simulator`. Serial instruments are in
:mod:`.instruments`. :mod:`.errors` is the one exception hierarchy of the project.
"""

from .errors import ConfigError, InputError, SourceError, WeatherdError
from .frames import FrameSource, LiveFrame, MemorySource, mask_credentials
from .sources import open_source
from .video import Frame, VideoReader, open_video

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
