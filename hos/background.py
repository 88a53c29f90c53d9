"""Segmentation of candidate streak pixels (paper section 2).

* :class:`MogSegmenter`: mixture-of-Gaussians background subtraction (eqs. 3-6) followed by the
  photometric rule (eq. 8). We use OpenCV's MOG2 (Zivkovic's adaptive-K variant of
  Stauffer-Grimson; the paper's stand-in is allowed by the method note): K components, decay
  ``gamma_1 = 1 / history``, background ratio T (eq. 5), and D standard deviations
  (``varThreshold = D**2``). MOG2 does not expose the background mean per pixel cheaply, so the
  photometric rule compares with a running background image learnt from non-foreground pixels.
* :func:`frame_difference_rule`: eq. 32, ``I_n - I_{n-1} >= c and I_n - I_{n+1} >= c``.

These are the only stateful parts of segmentation; the state is the background model.
"""

from __future__ import annotations

import cv2
import numpy as np

from .params import SegmentationParams

__all__ = [
    "FrameDiffSegmenter",
    "MogSegmenter",
    "create_mog2",
    "frame_difference_rule",
    "photometric_rule",
]


def photometric_rule(
    gray: np.ndarray, background: np.ndarray, foreground: np.ndarray, *, c: float
) -> np.ndarray:
    """Eq. 8: keep foreground pixels at least ``c`` grey levels brighter than the background.

    Parameters
    ----------
    gray, background : (H, W) uint8
    foreground : (H, W) uint8, nonzero where foreground

    Returns
    -------
    (H, W) uint8 mask, 255 where candidate.
    """
    threshold = cv2.add(background, round(c))  # saturating: never wraps at 255
    brighter = cv2.compare(gray, threshold, cv2.CMP_GE)
    return cv2.bitwise_and(brighter, foreground)


def frame_difference_rule(
    previous: np.ndarray, current: np.ndarray, following: np.ndarray, *, c: float
) -> np.ndarray:
    """Eq. 32: ``I_n - I_{n-1} >= c`` and ``I_n - I_{n+1} >= c``; (H, W) uint8 mask, 255 = kept."""
    ci = round(c)
    a = cv2.compare(current, cv2.add(previous, ci), cv2.CMP_GE)
    b = cv2.compare(current, cv2.add(following, ci), cv2.CMP_GE)
    return cv2.bitwise_and(a, b)


def create_mog2(params: SegmentationParams) -> cv2.BackgroundSubtractorMOG2:
    """OpenCV's MOG2 set from the paper's parameters: K, gamma_1 = 1/history, T and D."""
    mog = cv2.createBackgroundSubtractorMOG2(
        history=params.mog_history, varThreshold=params.mog_d**2, detectShadows=False
    )
    mog.setNMixtures(params.mog_mixtures)
    mog.setBackgroundRatio(params.mog_background_ratio)
    return mog


class MogSegmenter:
    """MoG foreground + photometric rule; ``apply(gray) -> candidate mask``."""

    def __init__(self, params: SegmentationParams) -> None:
        self.params = params
        self._mog = create_mog2(params)
        self._background: np.ndarray | None = None  # float32 running background
        self._background_u8: np.ndarray | None = None
        self.delay = 0
        #: Fraction of the image in MoG's foreground at the last frame (scene-change check).
        self.foreground_fraction = 0.0

    def apply(self, gray: np.ndarray, *, learning_rate: float = -1.0) -> np.ndarray:
        """Candidate mask (uint8, 255 = candidate) for ``gray``; updates the model.

        ``learning_rate`` < 0 lets MOG2 use ``1 / min(frames seen, history)``.
        """
        fg = self._mog.apply(gray, learningRate=learning_rate)
        self.foreground_fraction = cv2.countNonZero(fg) / fg.size
        if self._background is None:
            self._background = gray.astype(np.float32)
            self._background_u8 = gray.copy()
            return np.zeros_like(gray)
        candidates = photometric_rule(gray, self._background_u8, fg, c=self.params.photometric_c)
        rate = self.params.background_rate if learning_rate < 0 else max(learning_rate, 0.02)
        cv2.accumulateWeighted(gray, self._background, rate, mask=cv2.bitwise_not(fg))
        self._background_u8 = cv2.convertScaleAbs(self._background)
        return candidates


class FrameDiffSegmenter:
    """Eq. 32 with one frame of delay: ``apply(I_{n+1})`` returns the mask of frame n."""

    def __init__(self, params: SegmentationParams) -> None:
        self.params = params
        self._frames: list[np.ndarray] = []
        self.delay = 1
        self.foreground_fraction = 0.0

    def apply(self, gray: np.ndarray, *, learning_rate: float = -1.0) -> np.ndarray:
        del learning_rate  # no model to learn
        self._frames.append(gray)
        if len(self._frames) > 3:
            self._frames.pop(0)
        if len(self._frames) < 3:
            return np.zeros_like(gray)
        prev, cur, nxt = self._frames
        return frame_difference_rule(prev, cur, nxt, c=self.params.photometric_c)
