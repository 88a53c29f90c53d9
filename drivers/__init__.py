"""The outside world behind small interfaces: video files and image folders (PyAV), errors.

Cameras (V4L2, RTSP), the demo source and serial instruments join here with the daemon.
"""

from .errors import ConfigError, InputError, SourceError, WeatherdError
from .frames import FrameSource, LiveFrame, MemorySource, mask_credentials, open_source
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
