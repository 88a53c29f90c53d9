"""Segmentation of candidate streak pixels (paper section 2).

* :class:`MogSegmenter`: mixture-of-Gaussians background subtraction (eqs. 3-6) followed by the
  photometric rule (eq. 8). We use OpenCV's MOG2 (Zivkovic's adaptive-K variant of
  Stauffer-Grimson; the paper's stand-in is allowed by the method note): K components, decay
  ``gamma_1 = 1 / history``, background ratio T (eq. 5), and D standard deviations
  (``varThreshold = D**2``). MOG2 does not expose the background mean per pixel cheaply, so the
  photometric rule compares with a running background image learnt from non-foreground pixels.
* :func:`frame_difference_rule`: eq. 32, ``I_n - I_{n-1} >= c and I_n - I_{n+1} >= c``.

These are the only stateful parts of segmentation; the state is the background model. Both
segmenters return the candidate pixels as a sparse list (ascending flat indices ``y * W + x``):
a few percent of the image at most, which is all the later steps read.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from . import _jit
from .params import SegmentationParams

__all__ = [
    "FrameDiffSegmenter",
    "MogSegmenter",
    "PhotometricRule",
    "create_mog2",
    "frame_difference_rule",
    "grown_along_lines",
    "line_capped",
    "line_limit",
    "line_offsets",
    "mask_to_index",
    "photometric_rule",
]


def mask_to_index(mask: np.ndarray) -> np.ndarray:
    """(N,) intp ascending flat indices ``y * W + x`` of the nonzero pixels of a (H, W) mask."""
    points = cv2.findNonZero(mask)  # several times faster than np.flatnonzero on sparse masks
    if points is None:
        return np.zeros(0, np.intp)
    points = points.reshape(-1, 2)  # OpenCV 4 returns (N, 1, 2), OpenCV 5 (N, 2)
    return points[:, 1].astype(np.intp) * mask.shape[1] + points[:, 0]


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


#: The running background of the photometric rule is updated one band of rows at a time.
BACKGROUND_BANDS = 4


class MogSegmenter:
    """The MoG background model (eqs. 3-6): ``model(gray) -> foreground mask``."""

    def __init__(self, params: SegmentationParams) -> None:
        self.params = params
        self._mog = create_mog2(params)
        self.delay = 0
        #: Fraction of the image in MoG's foreground at the last frame (scene-change check).
        self.foreground_fraction = 0.0

    def model(self, gray: np.ndarray, *, learning_rate: float = -1.0) -> np.ndarray:
        """(H, W) uint8 foreground of ``gray`` (255 = foreground); updates the model.

        ``learning_rate`` < 0 lets MOG2 use ``1 / min(frames seen, history)``.
        """
        fg = self._mog.apply(gray, learningRate=learning_rate)
        self.foreground_fraction = cv2.countNonZero(fg) / fg.size
        return fg


_SQUARE3 = np.ones((3, 3), np.uint8)


def translate(image: np.ndarray, dx: float, dy: float) -> np.ndarray:
    """``image`` moved by (dx, dy) pixels (bilinear, exact for whole pixels; the border
    repeated), as a new array."""
    m = np.float32([[1.0, 0.0, dx], [0.0, 1.0, dy]])
    h, w = image.shape[:2]
    return cv2.warpAffine(image, m, (w, h), flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)


def neighbourhood_background(background: np.ndarray) -> np.ndarray:
    """The brightest background grey level of each pixel's 3x3 neighbourhood (beyond the paper).

    A camera off its learnt place by up to a pixel (the wind, or what is left of it after the
    frame was translated back) shows each edge pixel with a grey level between those of its
    neighbours in the background: never brighter than their maximum. A streak is brighter than
    the background all around it (eq. 8 holds against the neighbourhood's maximum too, unless
    it crosses an edge). So eq. 8 against this image keeps the streaks and drops the edges,
    with no resampling of the frame at all.
    """
    return cv2.dilate(background, _SQUARE3)


def line_offsets(length: int, orientations: int) -> np.ndarray:
    """(orientations, length, 2) int32 (dy, dx): the pixels of a line of ``length`` pixels
    (odd: rounded up) through (0, 0) at each of ``orientations`` evenly spaced orientations
    in [0, 180) degrees. One pixel per step along the line's major axis, so that every line
    has ``length`` distinct pixels, symmetric about its centre."""
    half = length // 2
    steps = np.arange(-half, half + 1)
    out = np.empty((orientations, steps.size, 2), np.int32)
    for i in range(orientations):  # a handful of orientations, once per detector
        theta = math.pi * i / orientations
        c, s = math.cos(theta), math.sin(theta)
        if abs(c) >= abs(s):  # mostly across: one pixel a column
            dx, dy = steps, np.round(steps * (s / c))
        else:  # mostly down: one pixel a row
            dx, dy = np.round(steps * (c / s)), steps
        out[i, :, 0] = dy
        out[i, :, 1] = dx
    return out


def line_limit(diff: np.ndarray, *, c: float, k: float, length: int, window: int) -> np.ndarray:
    """(H, W) float32: what the sum of ``diff`` along a line of ``length`` pixels must reach
    at each pixel (departure 36): ``length * max(c, k * noise / sqrt(length))``, the noise
    being the local standard deviation of ``diff``, its mean absolute value over ``window``
    pixels square times sqrt(pi / 2) (exact for Gaussian noise; a streak or an edge in the
    window raises it, which only makes the test stricter there)."""
    noise = cv2.blur(np.abs(diff).astype(np.float32), (window, window))
    limit = noise * np.float32(k * math.sqrt(math.pi / 2.0) / math.sqrt(length))
    np.maximum(limit, np.float32(c), out=limit)
    limit *= np.float32(length)
    return limit


def line_capped(diff: np.ndarray, limit: np.ndarray, *, cap: float, length: int) -> np.ndarray:
    """``diff`` with each pixel's difference counted up to ``cap`` times the per-pixel
    threshold of a line through it, ``limit / length`` (departure 36): a line must then be
    met by ``length / cap`` of its pixels at least, not by one bright blob on it. A flake
    of 40 grey levels, three pixels across, makes a line of 9 through it sum to 120, over
    the 27-45 a line must reach, and so drags the noise beside it into a streak; capped
    at 2 x 3-5 it sums to 18-30. ``cap`` >= 1 leaves the test ``diff >= c`` unchanged
    (the threshold is at least c)."""
    bound = (limit * np.float32(cap / length)).astype(np.int16)
    return np.minimum(diff, bound)


def _line_kernels(offsets: np.ndarray) -> list[np.ndarray]:
    half = int(np.abs(offsets).max())
    kernels = []
    for lines in offsets:
        kernel = np.zeros((2 * half + 1, 2 * half + 1), np.float32)
        kernel[lines[:, 0] + half, lines[:, 1] + half] = 1.0
        kernels.append(kernel)
    return kernels


def grown_along_lines(
    index: np.ndarray, diff: np.ndarray, limit: np.ndarray, offsets: np.ndarray, *, c: int
) -> np.ndarray:
    """The candidates ``index`` and the pixels that complete them along a line (departure 36;
    the reference of ``hos._jit.grown_along_lines``).

    A pixel is added when ``diff`` (the frame minus the background, int16) is at least ``c``
    there, when its sum along one of the lines of ``offsets`` through it (:func:`line_offsets`;
    the border repeated) reaches ``limit`` (:func:`line_limit`), and when it is connected
    (8-neighbours) to a candidate through such pixels.

    Returns (N,) intp ascending flat indices.
    """
    h, w = diff.shape
    d = diff.astype(np.float32)
    best = None
    for kernel in _line_kernels(offsets):
        # integer sums of at most a few thousand: exact in float32
        total = cv2.filter2D(d, -1, kernel, borderType=cv2.BORDER_REPLICATE)
        best = total if best is None else np.maximum(best, total, out=best)
    seed = np.zeros(h * w, np.uint8)
    seed[index] = 1
    seed = seed.reshape(h, w)
    joins = (diff >= c) & (best >= limit)
    _, labels = cv2.connectedComponents((joins | (seed > 0)).view(np.uint8), connectivity=8)
    labels = labels.reshape(-1)
    kept = np.zeros(int(labels.max()) + 1, bool)
    kept[labels[index]] = True
    kept[0] = False
    return np.flatnonzero(kept[labels])


class PhotometricRule:
    """Eq. 8 against a running background: ``candidates(gray, fg) -> candidate pixels``.

    The background is the running average of the frames off the foreground, learnt here
    because MOG2 does not expose its means cheaply (``getBackgroundImage`` costs as much as
    a quarter of MOG2 itself).

    ``compiled``: read the background at the foreground pixels only, in one compiled pass
    (``hos._jit``; the same candidates as the OpenCV calls, tests/hos/test_jit.py). None uses
    it when numba is available.
    """

    def __init__(self, params: SegmentationParams, *, compiled: bool | None = None) -> None:
        self.params = params
        self._compiled = _jit.ENABLED if compiled is None else compiled and _jit.ENABLED
        self._background: np.ndarray | None = None  # float32 running background
        self._background_u8: np.ndarray | None = None
        self._band = 0
        self._lines: np.ndarray | None = None  # line_offsets of departure 36
        #: the last frame's blocks' level (:func:`relevel_blocks`) as applied (weighted by the
        #: cells re-levelled), and as seen over the whole view; None when not re-levelled
        self.level: np.ndarray | None = None
        self.seen_level: np.ndarray | None = None

    @property
    def background(self) -> np.ndarray | None:
        """(H, W) uint8, the running background the rule compares with (None before the
        first frame). Read-only: a view of the rule's working buffer."""
        if self._background_u8 is None:
            return None
        view = self._background_u8.view()
        view.flags.writeable = False
        return view

    def candidates(
        self,
        gray: np.ndarray,
        fg: np.ndarray,
        *,
        learning_rate: float = -1.0,
        neighbourhood: bool = False,
        offset: tuple[float, float] = (0.0, 0.0),
        relevel: int = 0,
        relevel_mask: np.ndarray | None = None,
    ) -> np.ndarray:
        """Candidate pixels of ``gray``, (N,) intp ascending flat indices; learns the background.

        ``fg``: the background model's foreground. ``learning_rate`` >= 0 while the model
        relearns a changed scene (the background follows at least as fast), else the
        ``background_rate`` parameter. ``neighbourhood``: compare with the brightest background
        pixel of each 3x3 neighbourhood instead of the pixel's own (a camera off its place by up
        to a pixel; see :func:`neighbourhood_background`). ``offset``: (dx, dy), where ``gray``
        is off the background's place by a fraction of a pixel (a camera in the wind, moved
        back by whole pixels): the background is moved there (bilinear) before the comparison.
        Resampling the background costs nothing a streak needs: it has none. ``relevel`` > 0:
        the background is first raised or lowered by the frame's local level over it, in
        blocks of that many pixels (:func:`relevelled`; a shade's edge the exposure
        correction missed, departure 32), weighted by ``relevel_mask`` (one float32 weight
        a block, 1 where to re-level; None: everywhere).
        """
        self.level = self.seen_level = None
        if self._background is None or self._background.shape != gray.shape:
            self._background = gray.astype(np.float32)
            self._background_u8 = gray.copy()
            return np.zeros(0, np.intp)
        c = round(self.params.photometric_c)
        rate = self.params.background_rate if learning_rate < 0 else max(learning_rate, 0.02)
        reference = self._background_u8
        if offset[0] or offset[1]:
            reference = translate(reference, offset[0], offset[1])
        if neighbourhood:
            reference = neighbourhood_background(reference)
        if relevel > 0:
            self.seen_level = local_level(gray, reference, relevel)
            self.level = weighted_level(self.seen_level, relevel_mask)
            reference = relevel_apply(reference, self.level, relevel)
        if self._compiled:
            index, _ = _jit.photometric_candidates(gray, fg, reference, c=c)
        else:
            index = mask_to_index(photometric_rule(gray, reference, fg, c=c))
        p = self.params
        if p.line_length > 0 and index.size:
            # departure 36: the streaks' pixels under MOG2's threshold, integrated along them
            if self._lines is None:
                self._lines = line_offsets(p.line_length, p.line_orientations)
            diff = cv2.subtract(gray, reference, dtype=cv2.CV_16S)
            length = self._lines.shape[1]
            limit = line_limit(diff, c=c, k=p.line_k, length=length, window=p.line_window)
            if p.line_cap > 0:
                diff = line_capped(diff, limit, cap=p.line_cap, length=length)
            grow = _jit.grown_along_lines if self._compiled else grown_along_lines
            index = grow(index, diff, limit, self._lines, c=c)
        self._update_background(gray, fg, rate)
        return index

    def _update_background(self, gray: np.ndarray, fg: np.ndarray, rate: float) -> None:
        """Running average of the frame off the foreground, one horizontal band per frame.

        Each of the ``BACKGROUND_BANDS`` bands is updated every ``BACKGROUND_BANDS`` frames with
        the rate compounded to match, ``1 - (1 - rate) ** bands``: the same average over the
        ~50-frame memory, for a fraction of the memory traffic (the float32 image is the
        largest thing the detector touches after MOG2's model).
        """
        bands = BACKGROUND_BANDS
        k = self._band % bands
        self._band += 1
        h = gray.shape[0]
        lo, hi = h * k // bands, h * (k + 1) // bands
        if hi <= lo:
            return
        band = self._background[lo:hi]  # rows of a C-contiguous image: updated in place
        compounded = 1.0 - (1.0 - rate) ** bands
        cv2.accumulateWeighted(gray[lo:hi], band, compounded, mask=cv2.bitwise_not(fg[lo:hi]))
        self._background_u8[lo:hi] = cv2.convertScaleAbs(band)


def relevelled(
    gray: np.ndarray, reference: np.ndarray, scale: int, where: np.ndarray | None = None
) -> np.ndarray:
    """``reference`` raised (or lowered) by the local level of ``gray - reference``: the
    median over 5 x 5 blocks of ``scale`` x ``scale`` pixels (area means), bilinear between
    blocks. A change of light smoother than the window leaves eq. 8's comparison; a streak,
    a column of blocks at most, does not move the median.

    ``where``: (h // scale, w // scale) float32 weights of the blocks' levels (1: re-levelled,
    0: not; None: everywhere), so that the level fades over a block at the border of what is
    re-levelled. Four passes over the frame: the two area reductions, the upsampling and the
    addition; the median is taken on the blocks.
    """
    level = relevel_blocks(gray, reference, scale, where)
    return relevel_apply(reference, level, scale)


def relevel_blocks(
    gray: np.ndarray, reference: np.ndarray, scale: int, where: np.ndarray | None = None
) -> np.ndarray:
    """The blocks' level of :func:`relevelled`: (h // scale, w // scale) uint8, the median
    of ``gray - reference`` over 5 x 5 blocks plus 128, weighted by ``where``."""
    return weighted_level(local_level(gray, reference, scale), where)


def weighted_level(level: np.ndarray, where: np.ndarray | None) -> np.ndarray:
    """``level`` (:func:`local_level`) weighted by ``where`` (one float32 weight a block;
    None: ``level`` itself). On the blocks: cheap."""
    if where is None:
        return level
    return cv2.convertScaleAbs((level.astype(np.float32) - 128.0) * where + 128.0)


def local_level(gray: np.ndarray, reference: np.ndarray, scale: int) -> np.ndarray:
    """(h // scale, w // scale) uint8: the median of ``gray - reference`` over 5 x 5 blocks
    of ``scale`` x ``scale`` pixels (area means), plus 128."""
    h, w = gray.shape
    hs, ws = max(h // scale, 1), max(w // scale, 1)
    if scale > 1:
        # whole blocks only (OpenCV's fast path); the last rows and columns take the edge's
        hb, wb = min(hs * scale, h), min(ws * scale, w)
        gray = cv2.resize(gray[:hb, :wb], (ws, hs), interpolation=cv2.INTER_AREA)
        small = cv2.resize(reference[:hb, :wb], (ws, hs), interpolation=cv2.INTER_AREA)
    else:
        small = reference
    # the level, offset by 128 grey levels in uint8 (differences past 127 are not a shade's)
    return cv2.medianBlur(cv2.addWeighted(gray, 1.0, small, -1.0, 128.0, dtype=cv2.CV_8U), 5)


def relevel_apply(reference: np.ndarray, level: np.ndarray, scale: int) -> np.ndarray:
    """``reference`` plus the blocks' ``level`` (:func:`relevel_blocks`), bilinear between
    the blocks."""
    h, w = reference.shape
    hs, ws = level.shape
    hb, wb = min(hs * scale, h), min(ws * scale, w)
    if scale > 1:
        level = cv2.resize(level, (wb, hb), interpolation=cv2.INTER_LINEAR)
        if (hb, wb) != (h, w):
            level = cv2.copyMakeBorder(level, 0, h - hb, 0, w - wb, cv2.BORDER_REPLICATE)
    return cv2.addWeighted(reference, 1.0, level, 1.0, -128.0, dtype=cv2.CV_8U)


class FrameDiffSegmenter:
    """Eq. 32 with one frame of delay: ``model(I_{n+1})`` returns the mask of frame n."""

    def __init__(self, params: SegmentationParams) -> None:
        self.params = params
        self._frames: list[np.ndarray] = []
        self.delay = 1
        self.foreground_fraction = 0.0

    def model(self, gray: np.ndarray, *, learning_rate: float = -1.0) -> np.ndarray:
        """(H, W) uint8, 255 where eq. 32 holds for the previous frame."""
        del learning_rate  # no model to learn
        self._frames.append(gray)
        if len(self._frames) > 3:
            self._frames.pop(0)
        if len(self._frames) < 3:
            return np.zeros_like(gray)
        prev, cur, nxt = self._frames
        mask = frame_difference_rule(prev, cur, nxt, c=self.params.photometric_c)
        self.foreground_fraction = cv2.countNonZero(mask) / mask.size
        return mask
