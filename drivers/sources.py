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
``demo:``              the built-in synthetic street (``demo:?seed=3``)                demo
=====================  ============================================================  ===========

Each source module imports only :mod:`drivers.frames` (the protocol), never this one, and is
imported here when its scheme is opened: a spec costs only the imports of its own source.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from urllib.parse import parse_qsl

from .errors import ConfigError
from .frames import DEFAULT_TIMEOUT_S, FrameSource, mask_credentials

__all__ = ["SCHEMES", "open_source"]

#: The spec prefixes :func:`open_source` knows (compared case-insensitively).
SCHEMES = ("v4l2:", "file:", "demo:", "rtsp://", "rtsps://", "http://", "https://")


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
        from .file_source import FileSource

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
