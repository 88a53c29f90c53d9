"""The whole detector: one grey frame in, one :class:`~hos.result.FrameResult` out.

Steps, in the paper's order (Fig. 1), with our additions marked *beyond*:

1. *beyond*: global measurements on a reduced image: brightness (``dark``), frame-to-frame
   camera motion (``unstable``), exposure gain (undone before the background model sees it);
2. candidate pixels: MoG + photometric rule (eqs. 3-8) or the frame difference rule (eq. 32),
   restricted to the region of interest;
3. connected components, size rule (section 2.4), *beyond*: structure rule (blobs that recur in
   place), copies of the last frame, the traffic map (``hos.traffic``), blobs found again a
   little way off (``hos.again``);
4. moments, orientation, semi-axes and uncertainty of every blob (eqs. 13-19);
5. HOS (eq. 20), EM fit of the Gaussian-uniform mixture (eqs. 23-25), goodness of fit (eq. 26);
6. Kalman smoothing of (Pi, mu, sigma) and the decision on Pi_rain (section 5), *beyond*: misses
   decay the state, hysteresis, a minimum number of blobs, a minimum and a maximum sigma,
   precipitation seen by its fall (``hos.fall``);
7. rain pixels: blobs classified by the Bayes ratio against S_b (eqs. 28-30);
8. intensity R = S * Pi (eq. 31), *beyond*: corrected for merged streaks in heavy rain;
9. *beyond*: rain or snow, from the rain blobs' shape, voted over recent frames (``hos.ptype``).

Steps 1 (without the camera motion) and the background model run in :meth:`HosDetector.segment`,
the rest in :meth:`HosDetector.analyse`, so that a caller can overlap the two on two threads
(``daemon.service.detection``); :meth:`HosDetector.process` runs both.

The detector is pure: no I/O, no threads, no clock. Its state is the background model and the
exposure gain (``segment``), and the running background of the photometric rule, the per-pixel
candidate rate, the camera's reference image, the Kalman filter and the vote on the
precipitation type (``analyse``).
"""

from __future__ import annotations

import copy
import dataclasses
import itertools
import math
from collections import deque
from dataclasses import dataclass

import cv2
import numpy as np

from . import _jit
from .again import FoundAgain
from .angles import wrap_diff, wrapped_normal_pdf
from .background import (
    FrameDiffSegmenter,
    MogSegmenter,
    PhotometricRule,
    mask_to_index,
    translate,
)
from .blobs import (
    Blobs,
    CandidateRate,
    blob_change,
    blob_mean_rate,
    find_blobs_sparse,
    local_rate_at,
    local_rate_map,
    moved_edge,
    size_rule,
    structure_rule,
    thin_rule,
)
from .fall import FallMeter
from .histogram import hos_histogram
from .mixture import fit_mixture
from .moments import orientation_uncertainty
from .motion import exposure_gain, global_translation, reduce
from .params import DecisionParams, DetectorParams
from .ptype import SNOW, PrecipitationTypeVote, blob_contrast, frame_vote, streak_shape
from .result import BlobClass, FrameResult, MixtureFit, State
from .shade import apply_field, shade_field, upsample
from .smoothing import Dwell, ParameterSmoother
from .traffic import TrafficMap, grid_cells

if _jit.ENABLED:
    from ._jit_mixture import fit_mixture_jit
    from ._jit_motion import global_translation_jit

__all__ = ["HosDetector", "Segmented", "classify_blobs"]

_GAIN_OUTLIER = 4.0  # grey levels on the reduced image
_SHADE_MAX = math.log(2.0)  # a cloud's shade halves the light at most (departure 31)
_BOX3 = np.ones((3, 3), np.uint8)
_SHADE_DOUBT = 0.9  # a cell's shade in doubt keeps this much of itself a frame
_REDUCED_WIDTH = 240  # the image used for brightness, gain and motion is about this wide
#: Departure 33: the reference's texture is found again every this many frames; an offset
#: is checked in the parts of a 3 x 3 grid over the reduced image holding this many of them.
_TEXTURE_FRAMES = 25
_EXPLAIN_GRID = 3
_TEXTURE_MIN_PART = 30
_TEXTURE_POINTS = 1024  # at most this many texture pixels checked
_DIFF_LEVELS = 512  # quarter grey levels up to 128, for the parts' medians
#: ... and only an offset of at least this many reduced pixels: a smaller one changes the
#: frame by less than its 8-bit rounding and noise where the view is faint (a camera in the
#: wind off by 0.1-0.2 reduced pixels differs from its reference by a median of 0-1 grey
#: level), so the medians cannot tell; it stands
_EXPLAIN_MIN = 0.5
# ... but reduced by at most 4: a wind's 1.5 px at 1920x1080 is 0.19 px of a 240-px image, too
# little for the motion fit to tell from noise (it then reads 0 and nothing is undone), and
# 0.38 px of a 480-px one (docs/method.md, departure 7)
_MAX_SCALE = 4
#: An offset the coarse fit finds (departure 35) is taken when longer than this, in reduced
#: pixels, and than the reduced fit's by a pixel: the linearised fit reads shifts up to about
#: two pixels well, and under-reads longer ones.
_COARSE_REACH = 2.0
#: ... and when it leaves at most this share of the reduced fit's mismatch with the
#: reference (:func:`offset_mismatch`): an 8 px knock read as 2 px leaves edges 6 px apart.
_COARSE_BETTER = 0.7
#: Learning rate of the background model, and of the motion reference, while they relearn the
#: view after a scene change or a knock (about 20 frames' memory).
_RELEARN_RATE = 0.05
#: Frames in a row repeating the one before that hold the verdict (a stream filling in
#: dropped frames); more is a frozen stream, judged like any frame without fresh streaks.
_REPEATS_HELD = 25


@dataclass(frozen=True)
class _Pending:
    """A frame's voting blobs, kept for the next frame's eq. 32 (departure 45): the frame's
    shape; their pixels' flat indices, blob (0..k-1) and grey level, and whether each was
    ``photometric_c`` brighter than in the frame before (and at rest before it, with
    ``decision.transient_rest``); their votes (3, k: orientation,
    uncertainty, weight), traffic-map cells and centroids."""

    shape: tuple[int, ...]
    index: np.ndarray
    which: np.ndarray
    level: np.ndarray
    brighter: np.ndarray
    votes: np.ndarray
    cells: np.ndarray
    x: np.ndarray
    y: np.ndarray


class _TransientTrack:
    """The second track's state (departure 45): its pool, Kalman filter, last fit, and the
    last frame's voting blobs waiting for this frame's eq. 32."""

    def __init__(self, params: DecisionParams) -> None:
        # its frames come a frame late, so it ends a frame sooner: the verdict ends with the
        # first track's when both end with the rain
        tp = dataclasses.replace(params, dwell_off_frames=max(params.dwell_off_frames - 1, 1))
        self.smoother = ParameterSmoother(tp)
        self.pool: deque = deque(maxlen=params.pool_frames)
        self.last_fit: tuple[float, float, float] | None = None
        self.pending: _Pending | None = None
        self.votes_rate = 0.0  # drops a frame, a running mean (decision.collapse_ratio)
        # the last fits' widths (sigma, the streaks' own spread): a fit of 30 drops reads its
        # width a few degrees off, so the width rules take their median
        self.widths: deque = deque(maxlen=params.transient_width_frames)


def _in_cells(cells: np.ndarray, cell: float, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """(N,) bool: whether each point (x, y) falls in a True cell of ``cells`` (cells of
    ``cell`` pixels from the top left corner; points beyond the grid take its edge cell)."""
    # (the background label's centroid is NaN: it lands in cell 0, and is the caller's to drop)
    return cells.reshape(-1)[grid_cells(x, y, cell, cells.shape)]


def texture_mask(image: np.ndarray) -> np.ndarray:
    """(h, w) bool: the most textured quarter of ``image`` (float32, reduced), by the
    magnitude of its Sobel gradient (departure 33)."""
    grad = cv2.magnitude(
        cv2.Sobel(image, cv2.CV_32F, 1, 0, ksize=3), cv2.Sobel(image, cv2.CV_32F, 0, 1, ksize=3)
    )
    flat = grad.reshape(-1)
    k = (3 * flat.size) // 4
    return grad > float(np.partition(flat, k)[k])


@dataclass(frozen=True)
class TexturePoints:
    """Where an offset is checked (departure 33): up to ``_TEXTURE_POINTS`` pixels of a
    texture mask, evenly taken, as flat indices, coordinates and grid parts."""

    index: np.ndarray
    x: np.ndarray
    y: np.ndarray
    part: np.ndarray
    shape: tuple[int, int]

    @classmethod
    def of(cls, mask: np.ndarray) -> TexturePoints:
        index = np.flatnonzero(mask)
        step = max(-(-index.size // _TEXTURE_POINTS), 1)
        index = index[::step]
        h, w = mask.shape
        y, x = np.divmod(index, w)
        g = _EXPLAIN_GRID
        part = (y * g // h) * g + x * g // w
        return cls(index, x.astype(np.float32), y.astype(np.float32), part, (h, w))

    def kept(self, exclude: np.ndarray | None) -> TexturePoints:
        """These points less those where ``exclude`` (the image's shape) is nonzero."""
        if exclude is None:
            return self
        keep = exclude.reshape(-1)[self.index] == 0
        return TexturePoints(
            self.index[keep], self.x[keep], self.y[keep], self.part[keep], self.shape
        )


def offset_explains(
    reference: np.ndarray,
    frame: np.ndarray,
    dx: float,
    dy: float,
    points: TexturePoints,
    exclude: np.ndarray | None,
    tolerance: float,
) -> bool:
    """Whether the offset (dx, dy) of ``frame`` from ``reference`` (float32 reduced images,
    pixels) is the camera's (departure 33, beyond the paper).

    A camera that moves moves the whole view: in each part of it, the frame moved back by
    the offset matches the reference better. The view is cut in ``_EXPLAIN_GRID`` x
    ``_EXPLAIN_GRID`` parts; in a part with at least ``_TEXTURE_MIN_PART`` of the texture
    ``points`` (``exclude`` nonzero left out), the offset explains the frame if the median
    absolute difference moved back is at most ``tolerance`` times that of the frame as it
    is. It is the camera's if it explains at least half of those parts. An offset shorter
    than ``_EXPLAIN_MIN`` stands unchecked. Dense streaks, or a large object swinging, pull a
    linearised fit that has little else to go by: moving the frame back by what they read
    matches worse, or better only where the object is. Too few textured parts to tell: True.
    The frame is moved back at the points only (bilinear, the border repeated:
    :func:`hos.background.translate` there).
    """
    if math.hypot(dx, dy) < _EXPLAIN_MIN:
        return True
    points = points.kept(exclude)
    part = points.part
    as_is = _part_medians(_moved_back_difference(reference, frame, 0.0, 0.0, points), part)
    moved = _part_medians(_moved_back_difference(reference, frame, dx, dy, points), part)
    counts = np.bincount(part, minlength=_EXPLAIN_GRID**2)
    judged = counts >= _TEXTURE_MIN_PART
    n = int(np.count_nonzero(judged))
    explained = int(np.count_nonzero(judged & (moved <= tolerance * as_is)))
    return n < 2 or 2 * explained >= n


def _lit_otherwise(frame: np.ndarray, reference: np.ndarray, ratio: float) -> bool:
    """Whether ``frame``'s mean grey level (plus one) is more than ``ratio`` times
    ``reference``'s or less than its inverse (departure 42); never with ``ratio`` 0."""
    return _ratio_over(float(frame.mean()), float(reference.mean()), ratio)


def _ratio_over(now: float, before: float, ratio: float) -> bool:
    """Whether mean grey level ``now`` (plus one) is more than ``ratio`` times ``before``
    (plus one) or less than its inverse; never with ``ratio`` 0."""
    if ratio <= 0:
        return False
    now, before = now + 1.0, before + 1.0
    return max(now / before, before / now) > ratio


def offset_mismatch(
    reference: np.ndarray,
    frame: np.ndarray,
    dx: float,
    dy: float,
    points: TexturePoints,
    exclude: np.ndarray | None,
) -> float:
    """The median absolute difference between ``reference`` and ``frame`` moved back by the
    offset (dx, dy), pixels, at the texture ``points`` (``exclude`` nonzero left out), grey
    levels: how well the offset explains the frame as a whole (departure 35)."""
    points = points.kept(exclude)
    if points.index.size == 0:
        return math.inf
    return float(np.median(_moved_back_difference(reference, frame, dx, dy, points)))


def _moved_back_difference(
    reference: np.ndarray, frame: np.ndarray, dx: float, dy: float, points: TexturePoints
) -> np.ndarray:
    """|reference - frame moved back by (dx, dy)| at ``points``, float32 reduced images; the
    frame is read at the points only (bilinear, clamped), or as it is at (0, 0)."""
    flat = frame.reshape(-1)
    if dx == 0.0 and dy == 0.0:
        moved = flat[points.index]
    else:
        h, w = points.shape
        moved = _bilinear(flat, w, h, points.x + dx, points.y + dy)
    return np.abs(moved - reference.reshape(-1)[points.index])


def _refined_fit(
    translation, reference: np.ndarray, frame: np.ndarray, exclude, gradient: str
) -> tuple[float, float]:
    """``translation``'s offset of ``frame`` from ``reference``, refined once from the frame
    moved back by it when it is over half a pixel (the linearised fit under-reads a shift)."""
    fx, fy = translation(reference, frame, exclude=exclude, gradient=gradient)
    if math.hypot(fx, fy) > 0.5:
        back = translate(frame, -fx, -fy)
        ddx, ddy = translation(reference, back, exclude=exclude, gradient=gradient)
        fx, fy = fx + ddx, fy + ddy
    return fx, fy


def _bilinear(flat: np.ndarray, w: int, h: int, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """The (h, w) image ``flat`` (raveled) at points (x, y), bilinear, clamped to the image."""
    x = np.clip(x, 0.0, w - 1.0)
    y = np.clip(y, 0.0, h - 1.0)
    x0 = np.minimum(x.astype(np.intp), w - 2) if w > 1 else np.zeros(x.shape, np.intp)
    y0 = np.minimum(y.astype(np.intp), h - 2) if h > 1 else np.zeros(y.shape, np.intp)
    fx = x - x0
    fy = y - y0
    i00 = y0 * w + x0
    i01 = i00 + (1 if w > 1 else 0)
    i10 = i00 + (w if h > 1 else 0)
    i11 = i10 + (1 if w > 1 else 0)
    top = flat[i00] * (1.0 - fx) + flat[i01] * fx
    bottom = flat[i10] * (1.0 - fx) + flat[i11] * fx
    return top * (1.0 - fy) + bottom * fy


def _part_medians(diff: np.ndarray, part: np.ndarray) -> np.ndarray:
    """(parts,) the (lower) median of ``diff`` (absolute differences, grey levels) in each
    part, to a quarter of a grey level (128 and more: 128): a bincount, no sort, no loop over
    the parts."""
    levels = _DIFF_LEVELS
    q = np.minimum(diff * 4.0, levels - 1).astype(np.intp)
    hist = np.bincount(part * levels + q, minlength=_EXPLAIN_GRID**2 * levels)
    cum = np.cumsum(hist.reshape(-1, levels), axis=1)
    half = (cum[:, -1] + 1) // 2
    return np.argmax(cum >= np.maximum(half, 1)[:, None], axis=1) / 4.0


def classify_blobs(
    theta: np.ndarray, *, pi: float, mu: float, sigma: float, s_b: float
) -> np.ndarray:
    """Rain pixels, section 6: (P,) bool, True where a blob's orientation is the rain's.

    With the fitted mixture, P(theta|rain) = N / (Pi N + (1-Pi) U) (eq. 28) and
    P(theta|noise) = U / (Pi N + (1-Pi) U) (eq. 29); by Bayes' rule the ratio of the posteriors
    is ``P(rain|theta) / P(noise|theta) = Pi N(theta) / ((1 - Pi) U)``, compared with S_b.
    """
    gauss = wrapped_normal_pdf(theta, mu, sigma)
    uniform = 1.0 / np.pi
    with np.errstate(divide="ignore"):
        ratio = pi * gauss / ((1.0 - pi) * uniform)
    return ratio > s_b


def streak_spread(fit: MixtureFit, votes: np.ndarray) -> float:
    """The spread of the streaks of a fit's Gaussian, its voting kernels taken out (beyond
    the paper): ``sqrt(sigma^2 - mean d_theta^2)``, radians.

    Eq. 20 draws each blob as a Gaussian of its orientation's uncertainty (eq. 19), so the
    fitted sigma is the streaks' spread and their kernels' width added in quadrature
    (:func:`hos.histogram.kernel_variance`). A streak of 4 pixels votes with a kernel of
    about 20 degrees: parallel faint streaks at a low resolution fit a sigma over the pooled
    fit's 20-degree limit. The mean is over the blobs the Gaussian explains (their posterior,
    eq. 28) among those whose kernel is narrower than the Gaussian itself: a wider vote (a
    blob of 2-3 pixels) is spread over the uniform part by EM and takes nothing from sigma.
    ``votes``: (3, P) orientations, uncertainties and weights. Returns the fitted sigma when
    no kernel is narrower than it.
    """
    theta, dtheta, weight = votes
    inside = dtheta < fit.sigma
    if not np.any(inside):
        return fit.sigma
    theta, dtheta, weight = theta[inside], dtheta[inside], weight[inside]
    gauss = fit.pi * wrapped_normal_pdf(theta, fit.mu, fit.sigma)
    share = weight * gauss / (gauss + (1.0 - fit.pi) / np.pi)
    total = float(share.sum())
    if total <= 0.0:
        return fit.sigma
    kernel = float(np.sum(share * dtheta * dtheta)) / total
    return math.sqrt(max(fit.sigma * fit.sigma - kernel, 0.0))


@dataclass(frozen=True)
class Segmented:
    """What :meth:`HosDetector.segment` hands to :meth:`HosDetector.analyse` for one frame.

    The two stages share no mutable state, so a caller may run ``segment`` of frame n+1 on a
    worker thread while ``analyse`` of frame n runs (``daemon.service.detection`` does).
    ``segment`` does only what the background model needs (the exposure gain) and the model
    itself; everything that can wait for the model's foreground is done by ``analyse``, so that
    the thread running MOG2, whose cost is the floor of the method, does little else.
    """

    frame: int
    t_s: float
    #: warming_up, scene_change, dark or ok (``analyse`` adds unstable)
    state: str
    #: (H, W) uint8, the frame as the background model saw it (exposure gain undone)
    image: np.ndarray
    #: (H, W) uint8, the background model's foreground (or the frame difference rule's mask)
    foreground: np.ndarray
    #: (h, w) float32, the reduced, exposure-corrected frame
    small: np.ndarray
    #: the camera's offset from where the background model learnt the scene, pixels at full
    #: resolution (``image`` was translated back by it when below ``motion_frame_px``)
    motion_px: float
    gain: float
    brightness: float
    #: learning rate given to the background model (< 0: its own), for the running background
    learning_rate: float
    #: the region of interest: (H * W,) bool or None, its area in pixels, and the reduction
    #: factor of ``small``
    roi: np.ndarray | None
    roi_area: int
    scale: int
    #: cells of the view whose light changes in this frame (a cloud's shade coming or going,
    #: and the cells next to them; departure 31), (ny, nx) bool or None, and the cells' side in
    #: pixels of ``image``
    shading: np.ndarray | None
    shading_cell: float
    #: what is left of the camera's offset after ``image`` was moved back by whole pixels,
    #: (dx, dy) at full resolution: the background of eq. 8 is moved by it
    residual: tuple[float, float] = (0.0, 0.0)
    #: where eq. 8's background is re-levelled to the frame in blocks of ``scale`` pixels
    #: (``robustness.shade_relevel``, departure 32): (h, w) float32 over the blocks (the
    #: reduced image), 1 in the cells whose correction is a shade's (more than
    #: ``shade_onset``) and next to them; None: nowhere
    relevel_mask: np.ndarray | None = None


class HosDetector:
    """Rain/snow detector of Bossu, Hautière & Tarel (IJCV 2011), made robust for roadside use.

    Parameters
    ----------
    params : DetectorParams, paper defaults
    roi : (H, W) bool or uint8, optional; nonzero pixels are analysed (exclude sky, trees, a
        busy road...). Resized with nearest neighbour if the frames have another size.
    compiled : run the per-pixel and per-blob steps as compiled kernels (``hos._jit``, numba);
        None (the default) does when numba is available. The results are the same either way
        (tests/hos/test_jit.py); only the speed differs.
    """

    def __init__(
        self,
        params: DetectorParams | None = None,
        *,
        roi: np.ndarray | None = None,
        compiled: bool | None = None,
    ):
        self.params = params or DetectorParams()
        self.compiled = _jit.ENABLED if compiled is None else bool(compiled) and _jit.ENABLED
        self._roi_input = None if roi is None else (np.asarray(roi) != 0).astype(np.uint8) * 255
        self._shape: tuple[int, int] | None = None
        self._index = -1
        self._reset_segmentation()
        # analyse()'s state: the per-pixel candidate rate and the Kalman filter
        self._smoother = ParameterSmoother(self.params.decision)
        self._rate: CandidateRate | None = None
        self._photometric: PhotometricRule | None = None
        self._rate_frames = 0  # frames analysed since the rate map was (re)made
        self._local_map: np.ndarray | None = None
        self._moving = 0.0  # fraction of recent frames with the camera off its position
        self._shaken = 0  # frames left in which the camera counts as shaken (wind)
        self._settling = 0  # frames left to hold after the camera was last moved
        self._prev_small: np.ndarray | None = None  # the last frame, for its own motion
        self._flash = 0  # frames left without a frame-to-frame step after a flash (dep. 44)
        # the last frames analysed, newest first: for blobs copied from them (stale_level)
        self._prev_images: deque[np.ndarray] = deque(maxlen=self.params.robustness.stale_frames)
        self._repeats = 0  # frames in a row that repeated the one before
        # the last frame-to-frame steps (dx, dy) and the frame each started from
        self._steps: deque[tuple[float, float, np.ndarray]] = deque(maxlen=_PAN_FRAMES)
        # the last frames' (HOS, the blobs' cells, their votes: orientation, uncertainty,
        # weight), newest first
        self._pool: deque[tuple[np.ndarray, np.ndarray, np.ndarray]] = deque(
            maxlen=self.params.decision.pool_frames
        )
        self._last_fit: tuple[float, float, float] | None = None
        self._votes_rate = 0.0  # voting blobs a frame, a running mean (collapse_ratio)
        #: of the rain blobs of recent frames, running sums of those the next frame showed
        #: again beyond chance and of all (decision.flicker_share; :attr:`_flicker_rate`)
        self._flicker_sums = np.zeros(2)
        self._again_labels = np.zeros(0, np.intp)  # the labels FoundAgain was given
        # beyond the paper: rain or snow (hos/ptype.py)
        self._ptype = PrecipitationTypeVote(self.params.precipitation_type)
        # beyond the paper: precipitation seen by its fall (hos/fall.py); made per frame size
        self._again: FoundAgain | None = None
        self._fall = _FallVerdict(self.params.decision)
        # the type's own, while it parts from the verdict's: blobs where the light is off
        # outside the cells re-levelled still tell snow from rain (departure 37); None: the
        # verdict's is the type's
        self._fall_type: _FallVerdict | None = None
        self._fall_memory = 0  # frames left in which the type remembers the fall (dep. 43)
        # beyond the paper: the second track, of the blobs that pass eq. 32 (departure 45)
        dp = self.params.decision
        self._track = _TransientTrack(dp) if dp.transient_share > 0 else None

    # -- the frame -----------------------------------------------------------------------
    def process(self, gray: np.ndarray, t_s: float) -> FrameResult:
        """Run every step on one frame: ``analyse(segment(gray, t_s))``.

        Parameters
        ----------
        gray : (H, W) uint8 grey frame (a (H, W, 3) BGR frame is converted)
        t_s : float, time of the frame in seconds
        """
        return self.analyse(self.segment(gray, t_s))

    # -- stage 1: global measurements and candidate pixels -----------------------------------
    def _reset_segmentation(self) -> None:
        seg = self.params.segmentation
        self._segmenter = MogSegmenter(seg) if seg.method == "mog" else FrameDiffSegmenter(seg)
        self._frames_seen = 0
        self._relearn = 0
        self._bg_small: np.ndarray | None = None
        self._gain = 1.0
        self._shade: np.ndarray | None = None  # log gain of each cell (departure 31)
        self._ref_small: np.ndarray | None = None  # reference image of the motion estimate
        # frames in a row lit otherwise than the reference but alike, and the first one's
        # mean grey level (departure 44)
        self._lit_frames = 0
        self._lit_mean = 0.0
        self._ref_texture: TexturePoints | None = None  # its most textured quarter (dep. 33)
        self._ref_texture_age = 0  # frames since that was found
        self._fg_small: np.ndarray | None = None  # where the last frame's foreground was
        self._fg_rate: np.ndarray | None = None  # how often each reduced pixel was foreground
        self._movers: np.ndarray | None = None  # where it is often: left out of the motion fit
        self._last_shift: tuple[float, float] | None = None  # the last frame's offset
        self._resting = 0  # frames the camera has stood still off its place

    def _setup(self, shape: tuple[int, int]) -> None:
        self._shape = shape
        h, w = shape
        if self._roi_input is None:
            self._roi = None
            self._roi_flat = None
            self._roi_area = h * w
            self._roi_box = (0, 0, w, h)
        else:
            roi = self._roi_input
            if roi.shape != shape:
                roi = cv2.resize(roi, (w, h), interpolation=cv2.INTER_NEAREST)
            self._roi = roi
            self._roi_flat = roi.reshape(-1) != 0
            self._roi_area = max(cv2.countNonZero(roi), 1)
            x, y, bw, bh = cv2.boundingRect(roi)
            self._roi_box = (x, y, max(bw, 1), max(bh, 1))
        self._scale = min(max(w // _REDUCED_WIDTH, 1), _MAX_SCALE)
        self._roi_small = None if self._roi is None else reduce(self._roi, self._scale) > 127

    def segment(self, gray: np.ndarray, t_s: float) -> Segmented:
        """Steps 1-2a: brightness, exposure gain, background model (foreground pixels)."""
        gray = _as_gray(gray)
        self._index += 1
        if gray.shape != self._shape:
            if self._shape is not None:  # the camera changed resolution: start over
                self._reset_segmentation()
            self._setup(gray.shape)
        rob = self.params.robustness
        self._frames_seen += 1

        # 1. global measurements (beyond the paper)
        small = reduce(gray, self._scale)
        in_roi = small if self._roi_small is None else small[self._roi_small]
        brightness = float(in_roi.mean()) if in_roi.size else 0.0
        lit = brightness
        if rob.dark_share > 0 and in_roi.size:
            # the grey level of the brightest dark_share of the view (departure 26); an order
            # statistic by partition, a tenth of np.quantile's cost
            values = in_roi.reshape(-1)
            k = int((1.0 - rob.dark_share) * (values.size - 1))
            lit = float(np.partition(values, k)[k])
        frame, corrected_small, shading, shading_cell = self._compensate_exposure(gray, small)
        # 1b. camera motion (beyond the paper): a camera shaken by the wind is held still by
        # translating each frame back onto the reference before the background model sees it
        motion_px, (shift_x, shift_y) = self._camera_offset(corrected_small)
        if self._at_rest_elsewhere(motion_px, shift_x, shift_y):
            # knocked or re-aimed, and now at rest: the new view is learnt at once, instead of
            # staying unstable while the reference drifts over (reference_frames frames)
            # (a background model already relearning since the blow is learning this view)
            self._ref_small = corrected_small.copy()
            if self._relearn == 0:
                self._relearn = rob.warmup_frames
            motion_px, shift_x, shift_y = 0.0, 0.0, 0.0
        residual = (0.0, 0.0)
        if rob.stabilise and rob.stabilise_min_px < motion_px <= rob.motion_frame_px:
            if rob.stabilise_subpixel:
                frame = translate(frame, -shift_x, -shift_y)
            else:
                # Whole pixels: moving the frame by a fraction would spread a one-pixel streak
                # over two pixels at half its contrast. The fraction left is taken by the
                # background eq. 8 compares with, which has no streak to lose (departure 7).
                whole_x, whole_y = float(round(shift_x)), float(round(shift_y))
                if whole_x or whole_y:
                    frame = translate(frame, -whole_x, -whole_y)
                residual = (shift_x - whole_x, shift_y - whole_y)

        # 2a. the background model
        learning_rate = _RELEARN_RATE if self._relearn > 0 else -1.0
        self._relearn = max(self._relearn - 1, 0)
        foreground = self._segmenter.model(frame, learning_rate=learning_rate)
        changed = self._segmenter.foreground_fraction
        if self._roi is not None:
            # the candidates are foreground pixels of the ROI: their fraction is at most this
            in_roi_fg = cv2.countNonZero(cv2.bitwise_and(foreground, self._roi))
            changed = max(changed, in_roi_fg / self._roi_area)
        if self._frames_seen > rob.warmup_frames and changed > rob.scene_change_fraction:
            self._relearn = rob.warmup_frames
        self._remember_foreground(foreground, changed)
        relevel_mask = self._relevel_mask(small.shape) if rob.shade_relevel else None
        return Segmented(
            frame=self._index,
            t_s=float(t_s),
            state=self._state(lit),
            image=frame,
            foreground=foreground,
            small=corrected_small,
            motion_px=motion_px,
            gain=self._gain,
            brightness=brightness,
            learning_rate=learning_rate,
            roi=self._roi_flat,
            roi_area=self._roi_area,
            scale=self._scale,
            residual=residual,
            shading=shading,
            shading_cell=shading_cell,
            relevel_mask=relevel_mask,
        )

    def _state(self, lit: float) -> str:
        rob = self.params.robustness
        if self._frames_seen <= rob.warmup_frames + self._segmenter.delay:
            return State.WARMING_UP
        if self._relearn > 0:
            return State.SCENE_CHANGE
        if lit < rob.dark_level:
            return State.DARK
        return State.OK

    def _compensate_exposure(
        self, gray: np.ndarray, small: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, float]:
        """Undo global gain steps (auto-exposure) and local changes of light (cloud shade)
        before the background model sees them: the frame and the reduced frame so corrected,
        and the cells whose light changed in this frame (with their neighbours; None when
        none did) with the cells' side in pixels of the frame (departure 31).

        The applied gain relaxes back to 1 slowly (ten background memories), so that a real,
        lasting change of light is absorbed by the background model without a foreground flash;
        the shade's cells relax in one memory (departure 31).
        """
        rob = self.params.robustness
        history = self.params.segmentation.mog_history
        shade = self._shade_gains(small.shape)
        corrected_small = small * self._gain if shade is None else small * self._gain * shade
        if self._bg_small is None:
            self._bg_small = corrected_small.copy()
        residual = exposure_gain(corrected_small, self._bg_small)
        if abs(residual - 1.0) > rob.gain_tolerance:
            self._gain = min(max(self._gain * residual, 0.25), 4.0)
            corrected_small = small * self._gain if shade is None else small * self._gain * shade
        relax = 1.0 / (10.0 * history)
        self._gain = 1.0 + (self._gain - 1.0) * (1.0 - relax)
        shading, shading_cell = None, 0.0
        if rob.shade_cells > 0:
            # Beyond the paper (departure 31): what is left is a change of light over part of
            # the view, undone cell by cell against the same reference, and kept (relaxing in
            # one background memory, so that a lasting shade fades into the model) until the
            # light comes back.
            cell = self._shade_cell(small.shape)
            active = None
            if self._shade is not None:  # the cells corrected, and their neighbours
                live = (np.abs(self._shade) > rob.gain_tolerance).astype(np.uint8)
                active = cv2.dilate(live, _BOX3) > 0
            seen = shade_field(
                corrected_small,
                self._bg_small,
                cell=cell,
                tolerance=rob.gain_tolerance,
                coherence=rob.shade_coherence,
                onset=rob.shade_onset,
                active=active,
            )
            if seen is not None:
                if self._shade is None or self._shade.shape != seen.step.shape:
                    self._shade = np.zeros_like(seen.step)
                if seen.step.any():
                    shading = cv2.dilate((seen.step != 0).view(np.uint8), _BOX3) > 0
                    shading_cell = cell * self._scale
                self._shade += seen.step
                # a correction the frame no longer bears out (the shade has gone from a
                # plain cell, an object came) fades in a second instead of a memory
                self._shade[seen.doubt] *= np.float32(_SHADE_DOUBT)
                np.clip(self._shade, -_SHADE_MAX, _SHADE_MAX, out=self._shade)
                corrected_small = corrected_small * upsample(seen.step, cell, small.shape)
            if self._shade is not None:
                self._shade *= np.float32(1.0 - 1.0 / history)
                if float(np.abs(self._shade).max()) < 0.003:
                    self._shade = None
        # Beyond the paper: each pixel's step is clipped to a few grey levels (a Huber running
        # mean). Rain only brightens: learnt in full, its streaks made the reference brighter
        # than a frame's typical pixel in heavy rain, and the median ratio read a gain of
        # 0.5-1 % a frame that was not there. Clipped, a drop moves it by 0.2 grey levels.
        step = np.clip(corrected_small - self._bg_small, -_GAIN_OUTLIER, _GAIN_OUTLIER)
        self._bg_small += np.float32(0.05) * step
        if self._shade is not None:
            cell = self._shade_cell(small.shape) * self._scale
            frame = apply_field(gray, self._shade, self._gain, cell)
        elif abs(self._gain - 1.0) < 0.003:
            frame = gray
        else:
            frame = cv2.convertScaleAbs(gray, alpha=self._gain)
        return frame, corrected_small, shading, shading_cell

    def _relevel_mask(self, small_shape: tuple[int, int]) -> np.ndarray | None:
        """(h, w) float32 over the reduced image, 1 in the cells whose correction is a
        shade's (more than ``shade_onset``) and in the cells next to them, 0 elsewhere; None
        when there are none (departure 32: a correction of a few per cent leaves too little
        to matter to eq. 8, and the re-levelling costs a streak in dense rain what the rain's
        veil adds to its blocks)."""
        if self._shade is None:
            return None
        strong = (np.abs(self._shade) > self.params.robustness.shade_onset).view(np.uint8)
        if not strong.any():
            return None
        cells = cv2.dilate(strong, _BOX3).astype(np.float32)
        side = self._shade_cell(small_shape)
        ny, nx = cells.shape  # the cells cover the reduced image (ny * side >= its height)
        full = cv2.resize(cells, (nx * side, ny * side), interpolation=cv2.INTER_NEAREST)
        return full[: small_shape[0], : small_shape[1]]

    def _shade_cell(self, shape: tuple[int, int]) -> int:
        """The side of the shade's cells, pixels of the reduced image (even)."""
        return 2 * max(-(-shape[1] // (2 * self.params.robustness.shade_cells)), 1)

    def _shade_gains(self, shape: tuple[int, int]) -> np.ndarray | None:
        """(h, w) gains of the shade's cells on the reduced image, or None."""
        if self._shade is None:
            return None
        return upsample(self._shade, self._shade_cell(shape), shape)

    # -- stage 2: blobs, HOS, mixture, decision, rain pixels, intensity ----------------------
    def analyse(self, seg: Segmented) -> FrameResult:
        """Steps 2b-8 of one frame (call in frame order): camera motion, candidate pixels,
        blobs, HOS, mixture, decision, rain pixels, intensity."""
        p = self.params
        rob = p.robustness
        shape = seg.foreground.shape
        h = shape[0]
        relearning = seg.state == State.SCENE_CHANGE
        if self._rate is None or self._rate.shape != shape:
            self._learn_view(shape)
            self._photometric = PhotometricRule(p.segmentation, compiled=self.compiled)
            self._moving = 0.0
            self._shaken = 0
            self._settling = 0
        elif relearning and not self._relearning:
            # The view changed as a whole (a knock, lights): what recurred in place and where
            # the traffic went are the old view's; both are learnt again, as after the warm-up.
            self._learn_view(shape)
        self._relearning = relearning
        self._rate_frames += 1

        # 1b. camera motion (beyond the paper): offsets up to motion_frame_px were undone by
        # segment(); a camera further off its position than that carries no rain evidence, and
        # one that is so for a good part of the recent frames is being moved (knocked,
        # re-aimed): unstable, even while the background model relearns the scene it shows.
        motion_px = seg.motion_px
        moved = motion_px > rob.motion_frame_px
        if rob.shaken_px > 0 and motion_px >= rob.shaken_px:
            self._shaken = rob.motion_window_frames
        else:
            self._shaken = max(self._shaken - 1, 0)
        k = 1.0 / rob.motion_window_frames
        self._moving += k * (float(moved) - self._moving)
        state = seg.state
        # Not the wind, which sways about a position: the camera is being moved.
        # Measured while the camera is off its place, and while the scene relearns or the camera
        # was moving lately: the offset from the reference is unmeasurable (0) once the view
        # has gone further than the fit can reach.
        still = (
            motion_px <= rob.stabilise_min_px
            and state != State.SCENE_CHANGE
            and self._moving < 1.0 / rob.motion_window_frames
        )
        pan_px = self._pan(seg.small, seg.scale, still=still)
        far = motion_px > rob.motion_far_px or pan_px > rob.motion_far_px
        moved = moved or far
        # Too far off its place to be judged (not the wind), or moved on many recent frames;
        # a scene that changed because the camera moves is unstable too.
        if state in (State.OK, State.SCENE_CHANGE) and (
            moved or self._moving > rob.motion_unstable_fraction
        ):
            state = State.UNSTABLE
        hold = state in (State.WARMING_UP, State.SCENE_CHANGE) or moved
        # Beyond the paper (departure 34): the first frames after the camera was off its place
        # are judged but held; the edges it moved are half-learnt there, and vote as one
        # orientation repeated.
        if moved or state == State.UNSTABLE:
            self._settling = rob.settle_frames
        elif self._settling > 0:
            self._settling -= 1
            hold = True

        # 2b. candidate pixels
        if p.segmentation.method == "mog":
            candidates = self._photometric.candidates(
                seg.image,
                seg.foreground,
                learning_rate=seg.learning_rate,
                neighbourhood=self._shaken > 0,
                offset=seg.residual,
                relevel=seg.scale if seg.relevel_mask is not None else 0,
                relevel_mask=seg.relevel_mask,
            )
        else:  # the frame difference rule's mask is the candidates
            candidates = mask_to_index(seg.foreground)
        if seg.roi is not None:
            candidates = candidates[seg.roi[candidates]]
        candidate_fraction = candidates.size / seg.roi_area
        sp = p.segmentation
        at = h / sp.size_reference_height
        # the bounds scale with the area, or the lower one with the height only
        # (SegmentationParams.min_area_scaling; docs/method.md, departures 15 and 47).
        if sp.min_area_scaling == "length":
            min_scale = at
        elif sp.min_area_scaling == "lower" or (
            sp.min_area_scaling == "still" and self._shaken == 0
        ):
            min_scale = min(at, at * at)  # the lower of the two laws
        else:
            min_scale = at * at
        min_area = max(sp.min_area * min_scale, sp.min_area_px)
        # the upper one with the area, or with the height where that allows more: a long
        # streak in a frame under 480 rows (max_area_scaling; docs/method.md, departure 16)
        max_scale = max(at, at * at) if sp.max_area_scaling == "streak" else at * at
        max_area = sp.max_area * max_scale
        # thin blobs up to this size are streaks too (SegmentationParams.thin_factor)
        thin_area = max_area * sp.thin_factor

        # 3. blobs, size rule, structure rule
        blobs = find_blobs_sparse(
            candidates,
            shape,
            rate=self._rate,
            min_area=min_area,
            max_area=thin_area,
            compiled=self.compiled,
        )
        mom = blobs.moments
        local_rate = None
        if rob.persistence_local_ratio > 0:
            # the rate of the part of the view around each blob (departure 28): made again
            # every _LOCAL_EVERY frames, a tenth of the rate's own time constant
            if self._local_map is None or self._rate_frames % _LOCAL_EVERY == 1:
                window = max(round(rob.persistence_local_px * at / _LOCAL_FACTOR), 1) | 1
                self._local_map = local_rate_map(self._rate, factor=_LOCAL_FACTOR, window=window)
            local_rate = local_rate_at(self._local_map, _LOCAL_FACTOR, mom.x0, mom.y0)
        structural = structure_rule(
            blob_mean_rate(blobs, self._rate),
            global_rate=self._rate.global_rate,
            floor=rob.persistence_floor,
            ratio=rob.persistence_ratio,
            local_rate=local_rate,
            local_ratio=rob.persistence_local_ratio,
        )
        # 3b. copies of the last frame (beyond the paper): a video encoder's skipped blocks keep
        # streaks for frames after the drops have gone; they vote no more than an edge that
        # recurs in place, and a repeated frame says nothing new at all
        if any(f.shape != shape for f in self._prev_images):
            self._prev_images.clear()  # the camera changed resolution
        frames = [seg.image, *self._prev_images]
        repeated = False
        if rob.stale_level > 0 and len(frames) > rob.stale_frames:
            repeated = cv2.norm(frames[0], frames[1], cv2.NORM_INF) == 0
            stale = np.ones(blobs.n_labels, dtype=bool)
            for now, before in itertools.pairwise(frames):
                change = blob_change(now, before, blobs.index, blobs.pixel_labels, blobs.n_labels)
                stale &= change < rob.stale_level  # NaN (no pixel) compares False
            stale[0] = False
            structural |= stale
        if rob.stale_level > 0 or self._track is not None:  # nothing to keep when both are off
            self._prev_images.appendleft(seg.image.copy())
        # ... for a moment only: a stream frozen on one picture shows no fresh streak, and
        # decays to no precipitation as before
        self._repeats = self._repeats + 1 if repeated else 0
        hold = hold or 0 < self._repeats <= _REPEATS_HELD
        learn = self._rate_frames > rob.warmup_frames // 2 and (
            candidate_fraction <= rob.scene_change_fraction
        )
        if learn:
            # Not while the background model is still learning, nor on a frame that changed
            # as a whole: that foreground says nothing about what recurs in place.
            self._rate.update(candidates, candidate_fraction)
        sized = size_rule(mom.area, min_area=min_area, max_area=max_area)
        if thin_area > max_area:  # a streak longer than the area bound allows (departure 25)
            sized |= thin_rule(
                mom.area, mom.a, min_area=max_area, max_area=thin_area, width=sp.thin_width
            )
        sized[0] = False
        # the traffic map's cell of every blob: for the map, and for the pooled fit's spread
        blob_cells = self._traffic.cells(mom.x0, mom.y0)
        if rob.traffic:
            # beyond the paper: where vehicles, pedestrians and spray are or often pass
            # ... learning no lane under a shade being corrected (departure 46)
            exclude = seg.relevel_mask if rob.traffic_shade else None
            self._traffic.update(seg.foreground, learn=learn and state == State.OK, exclude=exclude)
            in_traffic = self._traffic.covers(blob_cells)
            in_traffic[0] = False
        else:
            in_traffic = np.zeros(blobs.n_labels, dtype=bool)
        # 3c. blobs found again a little way off (beyond the paper, hos/again.py): not new drops
        # (compared from the warm-up on, so that slow snow is known to fall when judging starts)
        comparable = state in (State.OK, State.WARMING_UP) and not moved
        again = self._found_again(comparable, h, mom.x0, mom.y0, sized)
        traffic = in_traffic & sized & ~structural & ~again
        accepted = sized & ~structural & ~traffic & ~again
        # 3d. slivers of an edge the camera moved (beyond the paper, departure 30)
        if rob.moved_edge_px > 0 and p.segmentation.method == "mog":
            moved_edge_ = moved_edge(
                seg.image,
                self._photometric.background,
                blobs.index,
                blobs.pixel_labels,
                mom,
                accepted,
                shift_px=rob.moved_edge_px,
            )
            accepted &= ~moved_edge_
            structural |= moved_edge_
        # 3e. where the light changes in this frame (a cloud's shade coming or going, beyond
        # the paper, departure 31), what eq. 8 cuts out is what the correction missed of it
        # (the second track tests them itself: a shade's edge is still there in the next frame)
        drops = (
            accepted.copy() if self._track is not None and p.decision.transient_lit else accepted
        )
        if seg.shading is not None:
            lit = _in_cells(seg.shading, seg.shading_cell, mom.x0, mom.y0)
            lit[0] = False
            accepted &= ~lit
            structural |= lit
        idx = np.flatnonzero(accepted)
        flicker = self._flicker(comparable and state == State.OK and not hold)

        # 4-5. orientation, HOS, mixture
        hp = p.histogram
        dtheta = orientation_uncertainty(
            mom.m20[idx], mom.m11[idx], mom.m02[idx], dm=hp.dm, lo=hp.dtheta_min, hi=hp.dtheta_max
        )
        theta = mom.theta[idx]
        hist = hos_histogram(
            theta,
            dtheta,
            mom.a[idx],
            bins=hp.bins,
            dtheta_min=hp.dtheta_min,
            dtheta_max=hp.dtheta_max,
        )
        S = float(hist.sum())
        dp = p.decision
        fitted, n_pooled, pooled, n_eff, places, votes = self._pooled_hos(
            hist, hold, blob_cells[idx], np.stack((theta, dtheta, mom.a[idx]))
        )
        fit, self._last_fit = self._fit(fitted, idx.size, n_eff, self._last_fit)

        # 6. decision
        plausible = self._plausible(
            fit, votes, pooled, n_eff, places, n_pooled, flicker, mom.x0[idx], mom.y0[idx]
        )
        # Beyond the paper: rain that stops leaves nothing behind. A frame with far fewer
        # voting blobs than the last frames had is the end of a shower, whatever the few
        # left (noise, compression, the pool's older frames) fit.
        collapsed = (
            dp.collapse_ratio > 0
            and state == State.OK
            and not hold
            and idx.size < dp.collapse_ratio * self._votes_rate
        )
        if not hold and state == State.OK:
            self._votes_rate += (idx.size - self._votes_rate) / dp.collapse_frames
        if hold:
            smoothed = self._smoother.hold()
        elif collapsed and dp.empty_measurement_var > 0:
            smoothed = self._smoother.update(None, measurement_var=dp.empty_measurement_var)
        elif state == State.OK and plausible and n_pooled >= dp.min_blobs:
            # Beyond the paper: the variance of a fit grows as its blobs get fewer, and with the
            # number of frames pooled (each frame's blobs count in that many fits).
            var = dp.measurement_var * max(1.0, dp.measurement_blobs / max(n_eff, 1.0)) * pooled
            smoothed = self._smoother.update((fit.pi, fit.mu, fit.sigma), measurement_var=var)
        elif (
            idx.size < dp.min_blobs
            and not plausible
            and dp.empty_measurement_var > 0
            and not (
                dp.empty_ratio > 0
                and self._smoother.state.rain
                and idx.size >= dp.empty_ratio * self._votes_rate
            )
        ):
            # Beyond the paper: a few blobs that do not even look like a streak population are
            # sure evidence of no rain (rain that stops leaves nothing behind); a failed fit of
            # many blobs, or a few blobs that fit (faint rain at a low resolution), much less.
            smoothed = self._smoother.update(None, measurement_var=dp.empty_measurement_var)
        else:
            smoothed = self._smoother.update(None)
        # 6b. precipitation seen by its fall (beyond the paper, hos/fall.py): round flakes
        # and specks that the HOS cannot orient, but that are found lower in the next frame
        fall_points = (mom.area <= max_area) & ~structural & ~in_traffic
        fall_points[0] = False  # the background label
        judged = state == State.OK and not hold
        applied, seen = self._light_missed(seg.scale) if dp.fall_light else (None, None)
        radius = max(8.0, dp.fall_radius * h / p.segmentation.size_reference_height)
        if applied is None:
            # the type's meter is the verdict's (and is forked from it when they part)
            self._fall_type = None
        else:
            # where the shade's correction missed the light by eq. 8's c, a speck may be the
            # light's edge moving, not a flake (departure 37): not paired where eq. 8 was
            # re-levelled by the light; and not to start precipitation where the light is
            # off anywhere (a plain sky outside the cells re-levelled), though it still tells
            # snow from rain there, once precipitation is seen
            if self._fall_type is None:
                self._fall_type = self._fall.fork()
            fall_points &= ~_in_cells(applied, float(seg.scale), mom.x0, mom.y0)
            type_z, _ = self._fall_type.update(judged, radius, mom.x0, mom.y0, fall_points)
            fall_points &= ~_in_cells(seen, float(seg.scale), mom.x0, mom.y0)
        fall_z, fall_px = self._fall.update(judged, radius, mom.x0, mom.y0, fall_points)
        if self._fall_type is None:
            type_z = fall_z
        # 6c. the second track (beyond the paper, departure 45): the last frame's voting blobs
        # that this frame shows were drops
        track_rain, track_pi, n_drops = False, math.nan, 0
        if self._track is not None:
            track_rain, track_pi, n_drops = self._track_step(
                seg.image,
                frames,
                blobs,
                drops,
                blob_cells,
                judged=state == State.OK and not hold,
                flicker=flicker,
            )
        # the type is voted on the first track's frames: the second's is a test for rain,
        # and a soft camera's fast flakes pass it too, which their shape would then type rain
        typed = (smoothed.rain or self._fall.falling) and state == State.OK
        rain = typed or (track_rain and state == State.OK)

        # 7. rain pixels
        blob_class = np.full(blobs.n_labels, BlobClass.SIZE, dtype=np.uint8)
        blob_class[0] = BlobClass.NONE
        # streak-sized, but recurs in place, or was found again a little way off
        blob_class[sized & (structural | again)] = BlobClass.STRUCTURE
        blob_class[traffic] = BlobClass.TRAFFIC
        if smoothed.rain:
            model = (smoothed.pi, smoothed.mu, smoothed.sigma)
        elif fit.ok and fit.gof_ok:
            model = (fit.pi, fit.mu, fit.sigma)
        else:
            model = None
        if model is not None and 0.0 < model[0] < 1.0:
            is_rain = classify_blobs(theta, pi=model[0], mu=model[1], sigma=model[2], s_b=dp.s_b)
        else:
            is_rain = np.zeros(idx.size, dtype=bool)
        blob_class[idx] = np.where(is_rain, BlobClass.RAIN, BlobClass.NOISE)

        # 9. precipitation type (beyond the paper): the shape of the rain blobs, voted over time
        valid_sigma = fit.sigma if fit.ok and fit.gof_ok else math.nan
        rain_idx = idx[is_rain]
        self._voted_rain(blobs.n_labels, rain_idx)
        background = self._photometric.background if p.segmentation.method == "mog" else None
        contrast = None
        if background is not None and rain_idx.size:
            contrast = blob_contrast(
                seg.image, background, blobs.index, blobs.pixel_labels, blobs.n_labels
            )[rain_idx]
        shape_ = streak_shape(
            mom.a[rain_idx],
            mom.b[rain_idx],
            sigma=valid_sigma,
            height=h,
            contrast=contrast,
            reference_height=self._ptype.params.reference_height,
        )
        vote = frame_vote(shape_, self._ptype.params) if state == State.OK else "unknown"
        typing = self._fall if self._fall_type is None else self._fall_type
        remembered = self._fall_memory > 0 and 0 < dp.fall_type_hold * dp.fall_z <= type_z
        if state == State.OK and (typing.falling or remembered):
            # seen falling a few pixels a frame: flakes, whatever their streaks look like (a
            # drop falls further between two frames than its streak is long, and is not found
            # again lower down; docs/method.md, "Precipitation type"). Departure 43: the type
            # remembers the fall: seen falling within the type's window, and still falling
            # above anything rain gives though under the verdict's threshold, flakes still
            vote = SNOW
            self._fall_memory = self._ptype.params.window_frames
        else:
            self._fall_memory = max(self._fall_memory - 1, 0)
        precipitation_type = self._ptype.update(vote, precipitating=typed)

        # 8. intensity
        merge = self._merge_correction(
            mom.area, accepted, structural | in_traffic | sized, max_area
        )
        R = S * smoothed.pi * merge

        return FrameResult(
            frame=seg.frame,
            t_s=seg.t_s,
            rain=rain,
            state=state,
            fit=fit,
            pi_smoothed=smoothed.pi,
            mu_smoothed=smoothed.mu,
            sigma_smoothed=smoothed.sigma,
            S=S,
            R=R,
            n_blobs=int(idx.size),
            n_rain_blobs=int(np.count_nonzero(is_rain)),
            histogram=hist,
            precipitation_type=precipitation_type,
            streak_shape=shape_,
            motion_px=motion_px,
            gain=seg.gain,
            brightness=seg.brightness,
            candidate_fraction=candidate_fraction,
            n_structural_blobs=int(np.count_nonzero(sized & structural)),
            n_traffic_blobs=int(np.count_nonzero(traffic)),
            n_found_again_blobs=int(np.count_nonzero(again & ~structural)),
            fall_z=fall_z,
            fall_px=fall_px,
            flicker_share=self._flicker_rate,
            drops_pi_smoothed=track_pi,
            n_drop_blobs=n_drops,
            labels=blobs.labels,
            blob_class=blob_class,
            pixel_index=blobs.index,
            pixel_labels=blobs.pixel_labels,
            image_shape=shape,
        )

    def _learn_view(self, shape: tuple[int, int]) -> None:
        """Start the maps learnt from what one view shows: the structure rule's per-pixel
        candidate rate and the map of where the traffic goes (cells sized for ``shape``)."""
        rob = self.params.robustness
        self._rate = CandidateRate(shape, rob.persistence_frames)
        self._rate_frames = 0
        self._local_map = None  # the rate around each place (departure 28), made from _rate
        at = shape[0] / self.params.segmentation.size_reference_height
        self._traffic = TrafficMap(
            shape,
            cell=max(round(rob.traffic_cell * at), 1),
            width=max(round(rob.traffic_width * at), 1),
            density=rob.traffic_density,
            frames=rob.traffic_frames,
            rate=rob.traffic_rate,
            ratio=rob.traffic_ratio,
            now=rob.traffic_now,
            hits=rob.traffic_hits,
            below=rob.traffic_below,
        )

    def _at_rest_elsewhere(self, motion_px: float, dx: float, dy: float) -> bool:
        """Whether the camera has stood still for ``robustness.rest_frames`` frames further
        than ``motion_frame_px`` from where the background was learnt (its offset changing by
        less than ``stabilise_min_px``, or a tenth of the offset, a frame: the linearised fit
        is that much less sure far off): knocked or re-aimed, not swaying."""
        rob = self.params.robustness
        last, self._last_shift = self._last_shift, (dx, dy)
        if rob.rest_frames <= 0 or motion_px <= rob.motion_frame_px or last is None:
            self._resting = 0
            return False
        if math.hypot(dx - last[0], dy - last[1]) >= max(rob.stabilise_min_px, 0.1 * motion_px):
            self._resting = 0
            return False
        self._resting += 1
        if self._resting < rob.rest_frames:
            return False
        self._resting = 0
        return True

    def _camera_offset(self, small: np.ndarray) -> tuple[float, tuple[float, float]]:
        """The camera's offset from where the background model learnt the scene: its length
        and (dx, dy), pixels at full resolution, from the reduced image ``small``.

        Edges light up in the foreground in proportion to this offset, not to the frame-to-frame
        motion: it is measured against a reference image that learns about as slowly as the
        model (on the exposure-corrected image, so that a gain step is not read as motion).
        What the background model saw moving in the last frame (vehicles, headlights and their
        reflections, streaks) takes no part in the fit, unless it covers most of the image (a
        camera being moved). A shift beyond half a reduced pixel is refined once (the
        linearised fit under-estimates it). Two fits, the shorter kept
        (``robustness.motion_gradient``, departure 27).
        """
        rob = self.params.robustness
        if self._ref_small is None or self._ref_small.shape != small.shape:
            self._take_reference(small)
            self._fg_small = None
            return 0.0, (0.0, 0.0)
        mean = float(small.mean())
        if _ratio_over(mean, float(self._ref_small.mean()), rob.motion_light_ratio):
            # Departure 42: lit otherwise than the view the reference learnt (a flash, the
            # dark between flashes): no offset can be read. Departure 44: nor does the
            # reference learn from it (a flash would stay in it for reference_frames frames,
            # and the frames after be read against a blend of two lights), until one light
            # (each frame within the ratio of the first) has lasted motion_light_frames
            # frames: then it is the view's, taken as it is.
            if self._lit_frames == 0 or _ratio_over(mean, self._lit_mean, rob.motion_light_ratio):
                self._lit_frames, self._lit_mean = 0, mean  # another light: counted anew
            self._lit_frames += 1
            if rob.motion_light_frames <= 0:
                self._learn_reference(small)
            elif self._lit_frames >= rob.motion_light_frames:
                self._take_reference(small)
            return 0.0, (0.0, 0.0)
        self._lit_frames = 0
        translation = global_translation_jit if self.compiled else global_translation
        exclude = self._fg_small
        if self._movers is not None:
            exclude = self._movers if exclude is None else cv2.bitwise_or(exclude, self._movers)
        # Departure 27: the fit on the reference's own gradients (the template), and on those
        # of the mean of the reference and the frame; the shorter offset. Each reads motion
        # that is not there in its own way (the symmetric fit follows texture only the frame
        # has: flakes falling together over a plain view; the template magnifies texture the
        # reference holds only faintly); neither shrinks a real offset.
        dx = dy = math.inf
        coarse = self._coarse_pair(small, exclude) if rob.motion_coarse > 1 else None
        for gradient in _MOTION_FITS[rob.motion_gradient]:
            fx, fy = _refined_fit(translation, self._ref_small, small, exclude, gradient)
            if coarse is not None:
                # Departure 35: an offset beyond the fit's reach (a knock of several pixels,
                # the fit under-reading it) is found on a coarser image, then refined here.
                cx, cy = self._coarse_offset(coarse, gradient, translation)
                if math.hypot(cx, cy) > max(_COARSE_REACH, math.hypot(fx, fy) + 1.0):
                    back = translate(small, -cx, -cy)
                    ddx, ddy = translation(
                        self._ref_small, back, exclude=exclude, gradient=gradient
                    )
                    # taken only where it matches the reference clearly better than the
                    # fit that did not reach it
                    points = self._ref_texture_points().kept(exclude)
                    far = offset_mismatch(self._ref_small, small, cx + ddx, cy + ddy, points, None)
                    near = offset_mismatch(self._ref_small, small, fx, fy, points, None)
                    if far < _COARSE_BETTER * near:
                        fx, fy = cx + ddx, cy + ddy
            if math.hypot(fx, fy) < math.hypot(dx, dy):
                dx, dy = fx, fy
            if dx == 0.0 and dy == 0.0:
                break  # nothing shorter: the other fit is not needed
        if (dx or dy) and not self._explains(self._ref_small, small, dx, dy, self._movers):
            dx = dy = 0.0
        self._learn_reference(small)
        scale = self._scale
        return math.hypot(dx, dy) * scale, (dx * scale, dy * scale)

    def _take_reference(self, small: np.ndarray) -> None:
        """Make ``small`` the camera-offset reference as it is (a first view, or a light
        that lasted, departure 44); its texture is found again."""
        self._ref_small = small.copy()
        self._ref_texture = None
        self._lit_frames = 0

    def _learn_reference(self, small: np.ndarray) -> None:
        """Step the camera-offset reference towards ``small``. While the background model
        relearns the view (after a scene change: a knock, lights), the reference learns as fast
        as the model: both must describe the same view."""
        rate = _RELEARN_RATE if self._relearn > 0 else 1.0 / self.params.robustness.reference_frames
        cv2.accumulateWeighted(small, self._ref_small, rate)

    def _coarse_pair(
        self, small: np.ndarray, exclude: np.ndarray | None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, float, float]:
        """The reference, ``small`` and ``exclude`` shrunk ``robustness.motion_coarse`` times
        more (area means; a coarse pixel is left out when more than half of its pixels are),
        and the factors from coarse to reduced pixels, across and down (departure 35)."""
        k = self.params.robustness.motion_coarse
        h, w = small.shape
        size = (max(w // k, 16), max(h // k, 16))
        ref = cv2.resize(self._ref_small, size, interpolation=cv2.INTER_AREA)
        cur = cv2.resize(small, size, interpolation=cv2.INTER_AREA)
        mask = None
        if exclude is not None:
            share = cv2.resize(
                np.asarray(exclude, dtype=np.float32), size, interpolation=cv2.INTER_AREA
            )
            mask = (share > 0.5).view(np.uint8)
        return ref, cur, mask, w / size[0], h / size[1]

    @staticmethod
    def _coarse_offset(coarse, gradient: str, translation) -> tuple[float, float]:
        """The offset fitted on the coarse images of :meth:`_coarse_pair`, refined once as at
        the reduced size, in reduced pixels."""
        ref, cur, mask, kx, ky = coarse
        fx, fy = _refined_fit(translation, ref, cur, mask, gradient)
        return fx * kx, fy * ky

    def _explains(
        self,
        before: np.ndarray,
        small: np.ndarray,
        dx: float,
        dy: float,
        exclude: np.ndarray | None,
    ) -> bool:
        """Whether the offset (dx, dy) (reduced pixels) of ``small`` from ``before`` explains
        it, on the reference's texture (departure 33; :func:`offset_explains`); True when
        ``robustness.motion_explained`` is 0."""
        tolerance = self.params.robustness.motion_explained
        if tolerance <= 0:
            return True
        return offset_explains(
            before, small, dx, dy, self._ref_texture_points(), exclude, tolerance
        )

    def _ref_texture_points(self) -> TexturePoints:
        """Where an offset or a frame-to-frame step is checked (departure 33): the
        reference's most textured quarter, the view as learnt (not the last frame's, which
        in heavy rain is the streaks' edges), found again every ``_TEXTURE_FRAMES`` checks."""
        if self._ref_texture is None or self._ref_texture_age >= _TEXTURE_FRAMES:
            self._ref_texture = TexturePoints.of(texture_mask(self._ref_small))
            self._ref_texture_age = 0
        self._ref_texture_age += 1
        return self._ref_texture

    def _pan(self, small: np.ndarray, scale: int, *, still: bool) -> float:
        """How far the camera went over its last ``_PAN_FRAMES`` frames, pixels at full
        resolution: the length of the sum of its frame-to-frame translations (the wind's sway
        goes back and forth; a camera being re-aimed keeps going). Not measured while the
        camera is ``still`` where it was learnt (it cannot be panning): no fit on a fixed
        camera, only the light compared with the last frame's (departure 44)."""
        rob = self.params.robustness
        prev, self._prev_small = self._prev_small, small
        same_size = prev is not None and prev.shape == small.shape
        if same_size and _lit_otherwise(small, prev, rob.motion_light_ratio):
            # a flash (departure 42); the clouds it lit move for a while after it, not the
            # camera: no step is read for motion_light_frames frames (departure 44)
            self._flash = max(rob.motion_light_frames, 1)
        flash, self._flash = self._flash > 0, max(self._flash - 1, 0)
        if still or not same_size or flash:
            self._steps.clear()
            return 0.0
        translation = global_translation_jit if self.compiled else global_translation
        dx, dy = translation(prev, small)
        if math.hypot(dx, dy) > 0.5:
            ddx, ddy = translation(prev, translate(small, -dx, -dy))
            dx, dy = dx + ddx, dy + ddy
        self._steps.append((dx, dy, prev))
        sx = sum(d[0] for d in self._steps)
        sy = sum(d[1] for d in self._steps)
        pan = math.hypot(sx, sy) * scale
        # the sum is checked against the frame the oldest step started from
        if pan > rob.motion_far_px and not self._explains(self._steps[0][2], small, sx, sy, None):
            # the view did not go that far: the steps followed something large moving in
            # it (a leaf, a swing), not the camera (departure 33)
            return 0.0
        return pan

    def _spread(self, x: np.ndarray, y: np.ndarray) -> float:
        """How spread the blobs at (x, y) are over the region of interest (beyond the paper):
        the cells of a ``decision.spread_grid`` square grid over its bounding box that they
        occupy, over the number that as many blobs placed at random would occupy on average
        (``G (1 - (1 - 1/G)^n)``, G cells). About 1 for precipitation, which falls
        everywhere it can be seen; far less for blobs gathered in one place."""
        n = x.size
        if n == 0:
            return 0.0
        g = self.params.decision.spread_grid
        x_lo, y_lo, width, height = self._roi_box
        col = np.clip(((x - x_lo) * (g / width)).astype(np.intp), 0, g - 1)
        row = np.clip(((y - y_lo) * (g / height)).astype(np.intp), 0, g - 1)
        occupied = np.count_nonzero(np.bincount(row * g + col, minlength=g * g))
        cells = g * g
        return occupied / (cells * (1.0 - (1.0 - 1.0 / cells) ** n))

    def _track_step(
        self,
        image: np.ndarray,
        frames: list[np.ndarray],
        blobs: Blobs,
        voting: np.ndarray,
        blob_cells: np.ndarray,
        *,
        judged: bool,
        flicker: bool,
    ) -> tuple[bool, float, int]:
        """One frame of the second track (beyond the paper, departure 45): the last frame's
        voting blobs that pass eq. 32 against this frame (``image``) are fitted, pooled and
        smoothed as the first track's are, and this frame's (``voting``, by label) are kept
        for the next. Returns the track's verdict, its smoothed Pi and how many drops voted."""
        track = self._track
        assert track is not None
        votes, cells, x, y = self._drops(track, image, judged)
        self._keep_voting(track, frames, blobs, voting, blob_cells, judged)
        if not judged:
            track.pool.clear()
            track.widths.clear()
            held = track.smoother.hold()
            return held.rain, held.pi, 0
        dp = self.params.decision
        hp = self.params.histogram
        hist = hos_histogram(
            votes[0],
            votes[1],
            votes[2],
            bins=hp.bins,
            dtheta_min=hp.dtheta_min,
            dtheta_max=hp.dtheta_max,
        )
        fitted, n_pooled, pooled, n_eff, places, pooled_votes = self._pooled_hos(
            hist, False, cells, votes, pool=track.pool
        )
        n = votes.shape[1]
        fit, track.last_fit = self._fit(fitted, n, n_eff, track.last_fit)
        width = None
        if fit.ok and fit.gof_ok:
            own = (fit.sigma, self._streak_spread(fit, pooled_votes))
            track.widths.append(own)
            width = tuple(np.median(np.asarray(track.widths), axis=0))
            # the stricter of the fit's own width and the median: narrow enough both ways
            # for spread_sigma and sigma_max, wide enough both ways for sigma_min
            width = (min(own[0], width[0]), max(own[1], width[1]))
        plausible = self._plausible(
            fit, pooled_votes, pooled, n_eff, places, n_pooled, flicker, x, y, width=width
        )
        # rain that stops leaves no drops (departure 20, as in the first track)
        collapsed = dp.collapse_ratio > 0 and n < dp.collapse_ratio * track.votes_rate
        track.votes_rate += (n - track.votes_rate) / dp.collapse_frames
        if collapsed and dp.empty_measurement_var > 0:
            state = track.smoother.update(None, measurement_var=dp.empty_measurement_var)
        elif plausible and n_pooled >= dp.min_blobs:
            var = dp.measurement_var * max(1.0, dp.transient_blobs / max(n_eff, 1.0)) * pooled
            state = track.smoother.update((fit.pi, fit.mu, fit.sigma), measurement_var=var)
        elif n < dp.min_blobs and not plausible and dp.empty_measurement_var > 0:
            state = track.smoother.update(None, measurement_var=dp.empty_measurement_var)
        else:
            state = track.smoother.update(None)
        return state.rain, state.pi, n

    def _keep_voting(
        self,
        track: _TransientTrack,
        frames: list[np.ndarray],
        blobs: Blobs,
        voting: np.ndarray,
        blob_cells: np.ndarray,
        judged: bool,
    ) -> None:
        """Keep this frame's ``voting`` blobs (by label) for the next frame's eq. 32
        (:meth:`_drops`): their votes (orientation, uncertainty, weight), cells and
        centroids, their pixels and grey levels, and which pixels are ``photometric_c``
        brighter than in the frame before (``frames``: this frame and the last ones, newest
        first, as the background model saw them)."""
        track.pending = None
        voting = voting & (blobs.moments.area >= self.params.decision.transient_min_area)
        labels = np.flatnonzero(voting)
        if not judged or len(frames) < 2 or labels.size == 0:
            return
        on = voting[blobs.pixel_labels]
        index = np.asarray(blobs.index, dtype=np.intp)[on]
        _, which = np.unique(blobs.pixel_labels[on], return_inverse=True)
        now = frames[0].reshape(-1)[index].astype(np.int16)
        before = frames[1].reshape(-1)[index].astype(np.int16)
        c = self.params.segmentation.photometric_c
        brighter = now - before >= c
        if self.params.decision.transient_rest and len(frames) > 2:
            # ... and at rest before it came: a light that flickers (its reflection in a wet
            # road, shimmering with the water film) was there, and changed, the frame before
            brighter &= np.abs(before - frames[2].reshape(-1)[index].astype(np.int16)) < c
        mom = blobs.moments
        hp = self.params.histogram
        dtheta = orientation_uncertainty(
            mom.m20[labels],
            mom.m11[labels],
            mom.m02[labels],
            dm=hp.dm,
            lo=hp.dtheta_min,
            hi=hp.dtheta_max,
        )
        track.pending = _Pending(
            shape=frames[0].shape,
            index=index,
            which=which,
            level=now,
            brighter=brighter,
            votes=np.stack((mom.theta[labels], dtheta, mom.a[labels])),
            cells=blob_cells[labels],
            x=mom.x0[labels],
            y=mom.y0[labels],
        )

    def _drops(
        self, track: _TransientTrack, image: np.ndarray, judged: bool
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The votes, cells and centroids of the blobs :meth:`_keep_voting` kept last frame
        that pass eq. 32 against ``image``, this frame: at least
        ``decision.transient_share`` of their pixels ``photometric_c`` brighter than in the
        frame before and than in this one (beyond the paper, departure 45)."""
        pending, track.pending = track.pending, None
        if pending is None or not judged or pending.shape != image.shape:
            return np.zeros((3, 0)), np.zeros(0, np.intp), np.zeros(0), np.zeros(0)
        after = image.reshape(-1)[pending.index].astype(np.int16)
        c = self.params.segmentation.photometric_c
        both = pending.brighter & (pending.level - after >= c)
        n = pending.cells.size
        share = np.bincount(pending.which, weights=both, minlength=n) / np.maximum(
            np.bincount(pending.which, minlength=n), 1
        )
        drop = share >= self.params.decision.transient_share
        return pending.votes[:, drop], pending.cells[drop], pending.x[drop], pending.y[drop]

    def _fit(
        self,
        hist: np.ndarray,
        n: int,
        n_eff: float,
        start: tuple[float, float, float] | None,
    ) -> tuple[MixtureFit, tuple[float, float, float] | None]:
        """The mixture of eqs. 23-25 fitted to ``hist`` (``n`` blobs voted this frame,
        ``n_eff`` in the histogram fitted), started from ``start`` (the last good fit), and
        the start for the next frame: this fit if it is good, else None."""
        if not n:
            return MixtureFit(ok=False, reason="no blobs"), None
        mp = self.params.mixture
        fit = (fit_mixture_jit if self.compiled else fit_mixture)(
            hist,
            max_iter=mp.max_iter,
            tol=mp.tol,
            gof_dc=max(mp.gof_dc, mp.gof_ks_c / math.sqrt(n_eff)),
            sigma_min=mp.sigma_min,
            start=start,
        )
        return fit, (fit.pi, fit.mu, fit.sigma) if fit.ok and fit.gof_ok else None

    def _plausible(
        self,
        fit: MixtureFit,
        votes: np.ndarray,
        pooled: int,
        n_eff: float,
        places: int,
        n_pooled: int,
        flicker: bool,
        x: np.ndarray,
        y: np.ndarray,
        *,
        width: tuple[float, float] | None = None,
    ) -> bool:
        """Whether a fit is a streak population (section 5, and the rules beyond the paper):
        ``votes`` the blobs fitted (3, P), ``pooled`` the frames they came from, ``x``, ``y``
        this frame's voting blobs' centroids. ``width``: the second track's (departure 45),
        the median (sigma, spread) of its last fits, judged in their place, and only a
        population as narrow as ``decision.spread_sigma`` (a test for rain)."""
        dp = self.params.decision
        narrow = width is not None
        if narrow:
            sigma, spread = width
        else:
            sigma, spread = fit.sigma, self._streak_spread(fit, votes)
        return bool(
            fit.ok
            and fit.gof_ok
            and spread <= (dp.sigma_max if pooled == 1 else dp.pool_sigma_max)
            # beyond the paper: not one orientation repeated (parallel structure), unless one
            # frame alone has many blobs at that orientation (parallel rain)
            and (
                sigma >= dp.sigma_min
                or (dp.sigma_min_blobs > 0 and pooled == 1 and fit.pi * n_eff >= dp.sigma_min_blobs)
            )
            and abs(float(wrap_diff(fit.mu, dp.vertical))) <= dp.max_tilt
            # beyond the paper: not a population the next frame shows again (departure 29)
            and not flicker
            # beyond the paper: a pooled fit's blobs must be spread like rain, not a few
            # bodies' parts seen again and again (a pedestrian's limbs, a light's reflection)
            and (pooled == 1 or places >= dp.pool_places * n_pooled)
            # beyond the paper: a wide population must be spread over the view like snow, not
            # gathered in one place like a tree's foliage in the wind
            and (pooled > 1 or spread <= dp.spread_sigma or self._spread(x, y) >= dp.spread_places)
            and (not narrow or spread <= dp.spread_sigma)
        )

    def _streak_spread(self, fit: MixtureFit, votes: np.ndarray) -> float:
        """The fit's width as the width rules read it: sigma, or (beyond the paper,
        ``decision.kernel_corrected``) the streaks' own spread, the voting kernels' width
        taken out."""
        if self.params.decision.kernel_corrected and fit.ok:
            return float(streak_spread(fit, votes))
        return fit.sigma

    def _pooled_hos(
        self,
        hist: np.ndarray,
        hold: bool,
        cells: np.ndarray,
        votes: np.ndarray,
        pool: deque | None = None,
    ) -> tuple[np.ndarray, int, int, float, int, np.ndarray]:
        """The HOS to fit: ``(histogram, blobs, frames pooled, n_eff, places, votes)``
        (beyond the paper).

        A frame with fewer than ``decision.min_blobs`` blobs is fitted together with the frames
        before it, up to ``decision.pool_frames`` of them (faint rain at a low resolution leaves
        5-10 streaks a frame; their orientations agree from frame to frame, those of noise do
        not). ``votes``: (3, P) the blobs' orientations, uncertainties and weights; returned
        for the blobs pooled, whose weights give n_eff, the effective number of blobs
        (sum w)^2 / sum w^2. ``cells``: the cell of each blob (the traffic map's grid);
        ``places`` is the number of distinct cells of the blobs pooled (rain lands somewhere
        new each frame, a body's parts do not). A held frame empties the pool.
        """
        pool = self._pool if pool is None else pool
        if hold:
            pool.clear()
        else:
            pool.appendleft((hist, cells, votes))
        n = votes.shape[1]
        pooled = 1
        places = n
        if 0 < n < self.params.decision.min_blobs and len(pool) > 1:
            hist = hist.copy()
            seen = [cells]
            seen_votes = [votes]
            for other, c, v in itertools.islice(pool, 1, None):
                if n >= self.params.decision.min_blobs:
                    break
                hist += other
                seen.append(c)
                seen_votes.append(v)
                n, pooled = n + v.shape[1], pooled + 1
            if pooled > 1:
                places = int(np.unique(np.concatenate(seen)).size)
                votes = np.concatenate(seen_votes, axis=1)
        weights = votes[2]
        w1, w2 = float(weights.sum()), float(np.sum(weights * weights))
        return hist, n, pooled, (w1 * w1 / w2 if w2 > 0 else 0.0), places, votes

    def _remember_foreground(self, foreground: np.ndarray, changed: float) -> None:
        """Where the background model saw motion, on the reduced grid, grown by a reduced pixel:
        left out of the next frame's motion estimate (not when most of the image changed)."""
        if changed > 0.5:
            self._fg_small = None
            return
        small = reduce(foreground, self._scale) > 0.0
        self._fg_small = cv2.dilate(small.view(np.uint8), _CROSS)
        rob = self.params.robustness
        if rob.mover_rate <= 0:
            return
        # ... and where it moves often (a crown in the wind): a gust sways it by more than the
        # camera moves, and as the largest textured part of many views it drags the fit
        # (a pixel or two at 1600x900) unless it is left out (departure 7)
        now = small.astype(np.float32)
        if self._fg_rate is None:  # a new resolution starts over (_reset_segmentation)
            self._fg_rate = now
            return
        cv2.accumulateWeighted(now, self._fg_rate, 1.0 / rob.mover_frames)
        # the median of a sixteenth of the pixels: a tenth of the cost, the same level
        typical = float(np.median(self._fg_rate[::4, ::4]))
        level = max(rob.mover_rate, rob.mover_ratio * typical)
        movers = (self._fg_rate > level).view(np.uint8)
        self._movers = None if cv2.countNonZero(movers) > movers.size // 2 else movers

    def _found_again(
        self, comparable: bool, height: int, x: np.ndarray, y: np.ndarray, sized: np.ndarray
    ) -> np.ndarray:
        """Step 3c: (n_labels,) bool, the streak-sized blobs (``sized``; label 0 is left
        out) found again a little way off since the last comparable frame (hos/again.py). A
        frame that is not (the camera moved, the view changed) restarts the rule: the next one
        is not compared with the last."""
        rob = self.params.robustness
        found = np.zeros(sized.size, dtype=bool)
        if rob.found_again_radius <= 0:
            return found
        radius = rob.found_again_radius * height / self.params.segmentation.size_reference_height
        if self._again is None or self._again.radius != radius:
            self._again = FoundAgain(
                radius=radius,
                frames=rob.found_again_frames,
                fall_z=rob.found_again_fall_z,
                vertical=self.params.decision.vertical,
                lower_only=rob.found_again_fall_lower,
            )
        if not comparable:
            self._again.reset()
            self._again_labels = np.zeros(0, np.intp)
            return found
        blobs = np.flatnonzero(sized)
        blobs = blobs[blobs > 0]  # the background label
        found[blobs] = self._again.update(np.column_stack((x[blobs], y[blobs])))
        self._again_labels = blobs
        return found

    def _flicker(self, judged: bool) -> bool:
        """Step 3f: take in how many of the last frame's rain blobs this frame showed again,
        and say whether their running share exceeds ``decision.flicker_share``
        (departure 29)."""
        dp = self.params.decision
        if self._again is None:
            return False
        if self._again.falling:
            # What is found again falls: slow snow (or a crown bent down by a gust, whose
            # blobs found beside or above are left out all the same, departure 41). The rule
            # stands aside, and the evidence behind its share fades, so that the share is
            # measured afresh when the fall ends (frozen, a share above the threshold held
            # every fit off for as long as the snow was seen to fall).
            self._flicker_sums *= 1.0 - 1.0 / dp.flicker_frames
            return False
        flicker = self._again.flicker
        if judged and flicker is not None:
            # running sums, not a running share: a frame of few rain blobs weighs little
            self._flicker_sums += (np.asarray(flicker) - self._flicker_sums) / dp.flicker_frames
        return dp.flicker_share > 0 and self._flicker_rate > dp.flicker_share

    @property
    def _flicker_rate(self) -> float:
        """The running share of the rain blobs that the next frame showed again (departure 29)."""
        found, voted = self._flicker_sums
        return float(found / max(voted, 1e-9))

    def _voted_rain(self, n_labels: int, rain_idx: np.ndarray) -> None:
        """Tell the found-again rule which of this frame's blobs were the Gaussian's (rain)
        blobs: the next frame counts how many of them it shows again (departure 29)."""
        if self._again is not None and self._again_labels.size:
            rain = np.zeros(n_labels, dtype=bool)
            rain[rain_idx] = True
            self._again.voted(rain[self._again_labels])

    def _light_missed(self, scale: int) -> tuple[np.ndarray | None, np.ndarray | None]:
        """Two (h // scale, w // scale) bool over eq. 8's blocks: where the frame's local
        level is off the background's by eq. 8's c or more while a shade is corrected
        (departure 32's medians, which a streak does not move), and the blocks next to
        them: as applied (in the cells re-levelled) and as seen (anywhere in the view);
        (None, None) when eq. 8 was not re-levelled this frame (or is not run: the frame
        difference rule). ``scale``: the blocks' side, pixels."""
        rule = self._photometric
        if rule is None or rule.level is None or rule.seen_level is None:
            return None, None
        c = round(self.params.segmentation.photometric_c)
        out = []
        for level in (rule.level, rule.seen_level):
            off = cv2.absdiff(level, np.full_like(level, 128)) >= c
            out.append(cv2.dilate(off.view(np.uint8), _BOX3) > 0)
        return out[0], out[1]

    def _merge_correction(
        self, area: np.ndarray, accepted: np.ndarray, excluded: np.ndarray, max_area: float
    ) -> float:
        """Factor >= 1 restoring the streaks lost to the size rule by overlap (beyond eq. 31).

        In heavy rain streaks cross and merge into blobs larger than ``max_area``: the HOS loses
        them and S, hence R, would fall as rain gets heavier. The candidate area in merged blobs
        (larger than ``max_area`` but far smaller than a car) is added back in proportion,
        except blobs that are ``excluded`` (structure, or where the traffic goes).
        """
        rob = self.params.robustness
        if not rob.merge_correction:
            return 1.0
        accepted_area = float(area[accepted].sum())
        if accepted_area <= 0.0:
            return 1.0
        merged = (area > max_area) & (area <= max_area * rob.merge_max_factor) & ~excluded
        return 1.0 + float(area[merged].sum()) / accepted_area


_CROSS = cv2.getStructuringElement(cv2.MORPH_CROSS, (3, 3))
#: The camera-offset fits of each ``robustness.motion_gradient``, as ``global_translation``'s
#: ``gradient``: the reference's alone ("previous") and the mean of the reference and the frame.
_MOTION_FITS = {"shorter": ("previous", "mean"), "reference": ("previous",), "mean": ("mean",)}
#: The rate around each place (departure 28) is made on the rate map reduced by this factor,
#: again every _LOCAL_EVERY frames.
_LOCAL_FACTOR = 4
_LOCAL_EVERY = 10
#: Frames over which a pan is measured.
_PAN_FRAMES = 5


def _as_gray(frame: np.ndarray) -> np.ndarray:
    frame = np.asarray(frame)
    if frame.ndim == 3 and frame.shape[2] == 3:
        frame = cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY)
    elif frame.ndim == 3 and frame.shape[2] == 1:
        frame = frame[:, :, 0]
    if frame.ndim != 2:
        raise ValueError(f"expected a (H, W) grey or (H, W, 3) BGR frame, got shape {frame.shape}")
    if frame.dtype != np.uint8:
        raise ValueError(f"expected uint8 pixels, got {frame.dtype}")
    return np.ascontiguousarray(frame)


class _FallVerdict:
    """Step 6b's state: the fall meter (hos/fall.py) and its verdict, on at ``fall_z`` and
    off under three quarters of it, each held for the decision's dwell frames."""

    def __init__(self, dp: DecisionParams) -> None:
        self._dp = dp
        self.meter: FallMeter | None = None  # made per frame size (its pairing radius)
        self.dwell = Dwell(dp.dwell_on_frames, dp.dwell_off_frames)

    def fork(self) -> _FallVerdict:
        """An independent copy, from here on fed apart."""
        twin = _FallVerdict(self._dp)
        twin.meter, twin.dwell = copy.deepcopy(self.meter), copy.deepcopy(self.dwell)
        return twin

    @property
    def falling(self) -> bool:
        """The verdict: precipitation seen falling."""
        return self.dwell.value

    def update(
        self, judged: bool, radius: float, x: np.ndarray, y: np.ndarray, small: np.ndarray
    ) -> tuple[float, float]:
        """Add a frame's small blobs (``small``, a mask over the labels, False at label 0,
        the background); ``(z, fall_px)``, ``fall_px`` NaN unless falling. A frame that
        cannot be judged restarts the meter: the next one is not paired with the last."""
        dp = self._dp
        if dp.fall_z <= 0:
            return 0.0, math.nan
        if self.meter is None or self.meter.radius != radius:
            self.meter = FallMeter(window=dp.fall_frames, radius=radius, vertical=dp.vertical)
        if not judged:
            self.meter.reset()
            return 0.0, math.nan
        z, fall_px = self.meter.update(np.column_stack((x[small], y[small])))
        falling = self.dwell.update(z >= (0.75 if self.dwell.value else 1.0) * dp.fall_z)
        return z, fall_px if falling else math.nan
