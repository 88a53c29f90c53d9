"""The registry of frame sources: a source spec's scheme names the module that reads it.

:func:`open_source` turns a source spec (contract) into a :class:`FrameSource`:

=====================  ============================================================  ===========
spec                   source                                                        module
=====================  ============================================================  ===========
``v4l2:/dev/video0``   a V4L2 camera (``?input_format=mjpeg`` etc. pass FFmpeg        v4l2
                       options)
``file:PATH``          a video file or image folder; ``loop`` restarts it at the end,  file_source
                       ``realtime`` paces frames at the file's rate
``rtsp://``,           a network stream FFmpeg opens (RTSP over TCP, MJPEG over HTTP,  stream
``rtsps://``,          HLS, MPEG-TS...), opened and read with timeouts
``http(s)://``
``demo:``              the built-in synthetic street (``demo:?seed=3&start=15``)       demo
=====================  ============================================================  ===========

Each source module imports only :mod:`drivers.frames` (the protocol), never this one, and is
imported here when its scheme is opened: a spec costs only the imports of its own source.

With ``max_pixels``, no source gives frames of more pixels (:mod:`drivers.frame_size`): a
requested size beyond it is refused, a file is shrunk as it is decoded, and a camera or stream
of a larger native size has each frame shrunk by an integer factor as it is read.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any
from urllib.parse import parse_qsl

from .errors import ConfigError, InputError
from .frame_size import Shrinker, frame_memory_mb
from .frames import DEFAULT_TIMEOUT_S, FrameSource, LiveFrame, mask_credentials

if TYPE_CHECKING:
    from .video import Frame, VideoReader

__all__ = ["OFFLINE_SCHEMES", "SCHEMES", "SourceReader", "open_frames", "open_source"]

#: The spec prefixes :func:`open_source` knows (compared case-insensitively).
SCHEMES = ("v4l2:", "file:", "demo:", "rtsp://", "rtsps://", "http://", "https://")
#: Those :func:`open_frames` reads offline (as fast as they decode); a bare path is a file.
OFFLINE_SCHEMES = ("file:", "demo:")


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
    max_pixels: int | None = None,
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
    max_pixels : the most pixels a frame may have (None: no limit); see the module doc

    Raises
    ------
    ConfigError : unknown scheme or malformed spec, or a requested size of more than
        ``max_pixels``, naming the spec (without credentials).
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
    if max_pixels is not None and width is not None and height is not None:
        if width * height > max_pixels:
            raise ConfigError(
                f"{name}: {width}x{height} is more than {max_pixels} pixels (about "
                f"{frame_memory_mb(width * height):.0f} MB for the detector): ask for less"
            )
    rest = spec[len(scheme) :]
    if scheme == "demo:":
        from .demo import DemoSource

        demo = DemoSource(
            width=width or 640,
            height=height or 360,
            fps=fps or 25.0,
            realtime=realtime,
            **_demo_query(name, rest),
        )
        if max_pixels is not None and demo.width * demo.height > max_pixels:  # its 640x360
            return _Limited(demo, max_pixels)
        return demo
    if scheme == "file:":
        path = rest[2:] if rest.startswith("//") else rest  # file:///x is file:/x
        if not path:
            raise ConfigError(f"{name}: no file or folder after 'file:'")
        from .file_source import FileSource

        return FileSource(
            Path(path).expanduser(),
            width=width,
            height=height,
            fps=fps,
            loop=loop,
            realtime=realtime,
            max_pixels=max_pixels,
        )
    if scheme == "v4l2:":
        from .v4l2 import v4l2_source

        device, _, query = rest.partition("?")
        if not device:
            raise ConfigError(f"{name}: no device after 'v4l2:' (e.g. v4l2:/dev/video0)")
        extra = dict(parse_qsl(query, keep_blank_values=True))
        extra.update(options or {})
        source = v4l2_source(
            device, width=width, height=height, fps=fps, timeout_s=timeout_s, options=extra
        )
        return _Limited(source, max_pixels) if max_pixels is not None else source
    from .stream import stream_source

    if len(rest.split("/", 1)[0].rsplit("@", 1)[-1]) == 0:
        raise ConfigError(f"{name}: no host in the URL")
    source = stream_source(
        spec, width=width, height=height, timeout_s=timeout_s, options=dict(options or {})
    )
    return _Limited(source, max_pixels) if max_pixels is not None else source


def open_frames(spec: str, *, max_pixels: int | None = None) -> VideoReader | SourceReader:
    """Frames of a file, an image folder or the demo street, read offline (``weatherd detect``).

    Parameters
    ----------
    spec : a path, ``file:PATH`` or ``demo:`` (``demo:?seed=3``); the demo never ends, so its
        reader must be stopped by the caller
    max_pixels : see :func:`open_source`

    Returns
    -------
    An iterator of :class:`~drivers.video.Frame` with ``width``, ``height``, ``fps``,
    ``frames_skipped``, ``frame_count`` and ``close()``: a :class:`~drivers.video.VideoReader`
    for files, a :class:`SourceReader` for the demo.

    Raises
    ------
    InputError : the file cannot be read, or the spec names a live camera or stream.
    ConfigError : a malformed ``demo:`` spec.
    """
    from .video import open_video

    lower = spec.lower()
    scheme = next((s for s in SCHEMES if lower.startswith(s)), None)
    if scheme is None:
        return open_video(spec, max_pixels=max_pixels)
    if scheme not in OFFLINE_SCHEMES:
        raise InputError(
            f"{mask_credentials(spec)}: a live camera or stream; this reads files, image "
            "folders, file:PATH and demo: (weatherd run watches live sources)"
        )
    source = open_source(spec, realtime=False, max_pixels=max_pixels)
    if scheme == "file:":
        return open_video(source.path, max_pixels=max_pixels)  # type: ignore[attr-defined]
    return SourceReader(source)


class SourceReader:
    """A frame source read as :func:`drivers.video.open_video`'s reader is (an iterator of
    ``Frame``, its size that of the first frame); opened here, closed by :meth:`close`.

    Raises
    ------
    InputError : the source gives no frame at all.
    """

    def __init__(self, source: FrameSource):
        self._source = source
        self.name = source.name
        self.fps = float(getattr(source, "fps", 25.0))
        self.frame_count: int | None = None
        try:
            source.open()
            first = source.read()
            if first is None:
                raise InputError(f"{self.name}: no frame")
        except BaseException:
            source.close()
            raise
        self._first: LiveFrame | None = first
        self.height, self.width = first.gray.shape

    @property
    def frames_skipped(self) -> int:
        return int(getattr(self._source, "frames_skipped", 0))

    def __iter__(self) -> Iterator[Frame]:
        from .video import Frame  # here: the live sources do not need PyAV

        while True:
            frame, self._first = self._first or self._source.read(), None
            if frame is None:
                return
            yield Frame(frame.index, frame.t_s, frame.gray)

    def close(self) -> None:
        self._source.close()

    def __enter__(self) -> SourceReader:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()


class _Limited:
    """A camera or stream whose frames are shrunk to at most ``max_pixels`` as they are read
    (by the capture thread, before the frame is handed on)."""

    def __init__(self, source: FrameSource, max_pixels: int):
        self._source = source
        self.name = source.name
        self._shrink = Shrinker(source.name, max_pixels)

    def open(self) -> None:
        self._source.open()

    def read(self) -> LiveFrame | None:
        frame = self._source.read()
        if frame is None:
            return None
        gray = self._shrink(frame.gray)
        return frame if gray is frame.gray else dataclasses.replace(frame, gray=gray)

    def close(self) -> None:
        self._source.close()

    def __getattr__(self, attribute: str) -> Any:  # the source's own attributes (stats...)
        return getattr(self._source, attribute)


def _demo_query(name: str, query: str) -> dict[str, float]:
    """``?seed=3&start=15`` of a demo spec as keyword arguments: ``seed`` (the street, an
    integer) and ``start`` (seconds into the street's weather cycle, >= 0)."""
    query = query.removeprefix("//").removeprefix("?")
    out: dict[str, float] = {}
    for key, value in parse_qsl(query, keep_blank_values=True):
        if key == "seed":
            try:
                out["seed"] = int(value)
            except ValueError:
                raise ConfigError(f"{name}: seed must be an integer, got {value!r}") from None
        elif key == "start":
            try:
                start = float(value)
            except ValueError:
                start = math.nan
            if not math.isfinite(start) or start < 0:
                raise ConfigError(f"{name}: start must be a number of seconds >= 0, got {value!r}")
            out["start_s"] = start
        else:
            raise ConfigError(f"{name}: unknown demo option {key!r} (known: seed, start)")
    return out
