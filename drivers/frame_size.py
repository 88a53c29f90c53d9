"""The largest frame the detector is given, and how a larger one is brought within it.

An edge box has a few hundred MB to spare: the detector keeps about
:data:`DETECTOR_BYTES_PER_PIXEL` bytes of state and scratch per pixel (the MOG2 background
model, the running background, motion images...), so a 8192 x 8192 frame needs gigabytes where
1920 x 1080 needs about 130 MB. HOS looks at streaks a few pixels wide and tens of pixels long;
1080p is plenty to see them. Frames with more than ``max_pixels`` pixels are therefore shrunk by
the smallest integer factor ``k`` that brings them within the limit, averaging ``k x k`` blocks
(an exact box filter, what a camera's binning does), before they are queued or analysed.
A streak keeps its orientation; it becomes ``k`` times shorter and thinner and its contrast
is averaged with the background: the size rules then see it as the same streak filmed with a
lower-resolution camera, which is what the paper's parameters are meant for (640x480 to 1080p).
"""

from __future__ import annotations

import logging
import math
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import numpy as np


__all__ = [
    "DETECTOR_BYTES_PER_PIXEL",
    "MAX_FRAME_PIXELS",
    "MAX_PIXELS_LIMIT",
    "MIN_FRAME_PIXELS",
    "Shrinker",
    "downscale",
    "downscale_factor",
    "frame_memory_mb",
]

log = logging.getLogger(__name__)

#: Default limit: 1920 x 1080 pixels.
MAX_FRAME_PIXELS = 1920 * 1080
#: The largest limit that may be configured: 3840 x 2160 (4K UHD).
MAX_PIXELS_LIMIT = 3840 * 2160
#: The smallest: 64 x 64.
MIN_FRAME_PIXELS = 64 * 64
#: Memory the detector needs per pixel of frame, bytes (measured, docs/daemon.md "Limits").
DETECTOR_BYTES_PER_PIXEL = 90


def frame_memory_mb(pixels: int) -> float:
    """MB of memory a camera's detector needs for frames of ``pixels`` pixels."""
    return pixels * DETECTOR_BYTES_PER_PIXEL / 1e6


def downscale_factor(width: int, height: int, *, max_pixels: int | None) -> int:
    """The smallest integer ``k >= 1`` with ``(width // k) * (height // k) <= max_pixels``
    (1 when there is no limit)."""
    if max_pixels is None or width * height <= max_pixels:
        return 1
    k = max(1, math.floor(math.sqrt(width * height / max_pixels)))
    while (width // k) * (height // k) > max_pixels:
        k += 1
    return k


def downscale(gray: np.ndarray, factor: int) -> np.ndarray:
    """``gray`` (H, W) with each ``factor x factor`` block averaged: (H // factor, W // factor),
    a new contiguous array (a rest of fewer than ``factor`` rows or columns is dropped). The
    input may be a strided view (a decoder's plane); it is not modified."""
    if factor == 1:
        return gray
    h, w = gray.shape[0] // factor, gray.shape[1] // factor
    block = gray[: h * factor, : w * factor]
    import cv2  # here, not at the top: every command's parser reads this module's limits

    return cv2.resize(block, (w, h), interpolation=cv2.INTER_AREA)


class Shrinker:
    """The integer factor that brings the frames of one source within ``max_pixels`` (None: no
    limit), and the frames so brought; the first shrink is said once in the log."""

    def __init__(self, name: str, max_pixels: int | None):
        self._name, self._max_pixels = name, max_pixels
        self._said = False

    def factor(self, width: int, height: int) -> int:
        k = downscale_factor(width, height, max_pixels=self._max_pixels)
        if k > 1 and not self._said:
            self._said = True
            log.warning(
                "%s: %dx%d frames shrunk by %d to %dx%d (more than %d pixels; see max_pixels)",
                self._name,
                width,
                height,
                k,
                width // k,
                height // k,
                self._max_pixels,
            )
        return k

    def __call__(self, gray: np.ndarray) -> np.ndarray:
        """``gray`` (H, W) brought within the limit."""
        return downscale(gray, self.factor(gray.shape[1], gray.shape[0]))
