"""Frames to a video file with PyAV: how rendered sequences become clips for the daemon."""

from __future__ import annotations

import itertools
from collections.abc import Iterable
from fractions import Fraction
from pathlib import Path

import av
import numpy as np

from ._common import _require

__all__ = ["write_video"]

_CODECS = ("libx264", "mpeg4", "mjpeg")


def _pick_codec(codec: str | None) -> str:
    for name in (codec,) if codec else _CODECS:
        try:
            av.codec.Codec(name, "w")
        except ValueError:  # av.codec.codec.UnknownCodecError: not in this build
            continue
        return name
    wanted = codec or " / ".join(_CODECS)
    raise ValueError(f"write_video: no {wanted} encoder in this PyAV build")


def write_video(
    path: str | Path,
    frames: Iterable[np.ndarray],
    fps: float = 25,
    *,
    codec: str | None = None,
    crf: int = 18,
) -> int:
    """Write uint8 frames to a video file with PyAV; return the number of frames written.

    Parameters
    ----------
    path : output file; the container follows its extension (.mp4, .mkv, .avi...)
    frames : iterable of (H, W) uint8 grey or (H, W, 3) uint8 BGR frames, all the same shape;
        H and W must be even (the encoders use 4:2:0 chroma)
    fps : frame rate, Hz
    codec : encoder name; None picks libx264 if this PyAV build has it, else mpeg4, else mjpeg
    crf : libx264 constant rate factor (0 lossless, 18 visually lossless); the other encoders
        run at 8 Mbit/s

    Raises
    ------
    ValueError : no frames, odd or changing size, not uint8, or no such encoder
    """
    it = iter(frames)
    first = next(it, None)
    _require(first is not None, "write_video", "no frames to write")
    first = np.asarray(first)
    shape = first.shape
    _require(
        first.ndim == 2 or (first.ndim == 3 and shape[2] == 3),
        "write_video",
        f"frames must be (H, W) gray or (H, W, 3) BGR, got {shape}",
    )
    h, w = shape[:2]
    _require(
        h % 2 == 0 and w % 2 == 0,
        "write_video",
        f"frame size {w}x{h} must be even for 4:2:0 video; crop or pad the frames",
    )
    fmt = "gray" if first.ndim == 2 else "bgr24"
    name = _pick_codec(codec)
    rate = Fraction(fps).limit_denominator(1001)
    n = 0
    with av.open(str(path), "w") as container:
        stream = container.add_stream(name, rate=rate)
        stream.width, stream.height = w, h
        stream.pix_fmt = "yuvj420p" if name == "mjpeg" else "yuv420p"
        if name == "libx264":
            stream.options = {"crf": str(int(crf)), "preset": "veryfast"}
        else:
            stream.bit_rate = 8_000_000
        for arr in itertools.chain((first,), it):
            arr = np.asarray(arr)
            _require(arr.shape == shape, "write_video", f"frame {n} is {arr.shape}, not {shape}")
            _require(arr.dtype == np.uint8, "write_video", f"frame {n} is {arr.dtype}, not uint8")
            frame = av.VideoFrame.from_ndarray(np.ascontiguousarray(arr), format=fmt)
            container.mux(stream.encode(frame))
            n += 1
        container.mux(stream.encode(None))
    return n
