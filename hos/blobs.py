"""Connected components of the candidate mask and the per-blob selection rules.

The size rule is the paper's (section 2.4). The structure rule is ours: rain lands at random
places from frame to frame, while the edges of a shaking camera, swaying leaves or a flickering
sign come back to the same pixels. A per-pixel candidate rate (an exponential moving average of
the candidate mask) separates the two: a blob whose pixels are candidates far more often than
the image as a whole is structure, not rain.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import cv2
import numpy as np

from . import _jit
from .moments import BlobMoments, blob_moments
from .motion import reduce

__all__ = [
    "Blobs",
    "CandidateRate",
    "blob_change",
    "blob_mean",
    "blob_mean_rate",
    "find_blobs",
    "find_blobs_sparse",
    "label_candidates",
    "local_rate_at",
    "local_rate_map",
    "moved_edge",
    "size_rule",
    "structure_rule",
    "thin_rule",
]


@dataclass(frozen=True)
class Blobs:
    """Connected components of a set of candidate pixels and the moments of each.

    index : (N,) intp, flat index ``y * W + x`` of every candidate pixel, ascending
    pixel_labels : (N,) int, label of every candidate pixel, in [1, n_labels)
    n_labels : number of labels including 0 (the background)
    moments : BlobMoments over the labels
    shape : (H, W) of the image
    labels : (H, W) int32 label image, 0 = not a candidate, when it was computed (the dense
        path); None otherwise (``FrameResult.label_image`` makes one from index and labels)
    rate_sum : (n_labels,) float64, sum over each blob of the candidate rate it was labelled
        with (:func:`find_blobs_sparse`), else None
    """

    index: np.ndarray
    pixel_labels: np.ndarray
    n_labels: int
    moments: BlobMoments
    shape: tuple[int, int]
    labels: np.ndarray | None = None
    rate_sum: np.ndarray | None = None


def label_candidates(mask: np.ndarray) -> tuple[int, np.ndarray]:
    """``(n_labels, labels)``: the 8-connected components of ``mask`` (uint8, nonzero =
    candidate), labels (H, W) int32 with 0 for the background (OpenCV's Spaghetti labelling)."""
    n_labels, labels = cv2.connectedComponentsWithAlgorithm(mask, 8, cv2.CV_32S, cv2.CCL_SPAGHETTI)
    return n_labels, labels


def find_blobs(mask: np.ndarray, *, labelling: tuple[int, np.ndarray] | None = None) -> Blobs:
    """Label the 8-connected components of ``mask`` (uint8, nonzero = candidate).

    The reference path, with OpenCV and numpy: only the labels are computed over the whole image
    (OpenCV's Spaghetti labelling); statistics come from the sparse candidate pixels with
    ``np.bincount``, several times cheaper than ``connectedComponentsWithStats``.

    ``labelling``: the result of :func:`label_candidates` on ``mask``, if already computed.
    """
    n_labels, labels = label_candidates(mask) if labelling is None else labelling
    points = cv2.findNonZero(mask)
    shape = (mask.shape[0], mask.shape[1])
    if points is None:
        empty = np.zeros(0, dtype=np.intp)
        moments = blob_moments(empty, empty, empty, n_labels)
        return Blobs(empty, empty, n_labels, moments, shape, labels)
    points = points.reshape(-1, 2)  # OpenCV 4 returns (N, 1, 2), OpenCV 5 (N, 2)
    xs = points[:, 0]
    ys = points[:, 1]
    index = ys.astype(np.intp) * mask.shape[1] + xs
    pixel_labels = labels.ravel().take(index)  # a flat take: several times cheaper than [ys, xs]
    moments = blob_moments(xs, ys, pixel_labels, n_labels)
    return Blobs(index, pixel_labels, n_labels, moments, shape, labels)


def find_blobs_sparse(
    index: np.ndarray,
    shape: tuple[int, int],
    *,
    rate: CandidateRate | None = None,
    min_area: float = 0.0,
    max_area: float = np.inf,
    compiled: bool | None = None,
) -> Blobs:
    """:func:`find_blobs` from the candidates as ascending flat indices instead of a mask.

    With the compiled kernel (``hos._jit``) the work is proportional to the candidate pixels,
    not to the image: labelling, moments and the sum of ``rate`` over each blob in one pass.
    Without it, the mask is drawn and :func:`find_blobs` labels it. Blob labels may be numbered
    differently by the two paths; the blobs, their pixels and their moments are the same.

    ``min_area``, ``max_area``: the compiled path computes second moments and orientations only
    for blobs of this size (the size rule's: most blobs are specks), NaN for the others.
    """
    use_jit = _jit.ENABLED if compiled is None else compiled and _jit.ENABLED
    if not use_jit:
        mask = np.zeros(shape, np.uint8)
        mask.reshape(-1)[index] = 255
        blobs = find_blobs(mask)
        rate_sum = None if rate is None else blob_rate_sum(blobs, rate.stored)
        return replace(blobs, rate_sum=rate_sum)
    labels, n_labels, *arrays, rate_sum = _jit.label_sparse(
        index, shape, None if rate is None else rate.stored, min_area=min_area, max_area=max_area
    )
    return Blobs(index, labels, int(n_labels), BlobMoments(*arrays), shape, None, rate_sum)


def size_rule(area: np.ndarray, *, min_area: float, max_area: float) -> np.ndarray:
    """(n,) bool: blobs whose area in pixels is plausible for a streak (section 2.4)."""
    return (area >= min_area) & (area <= max_area)


def thin_rule(
    area: np.ndarray, a: np.ndarray, *, min_area: float, max_area: float, width: float
) -> np.ndarray:
    """(n,) bool: blobs of ``min_area`` to ``max_area`` pixels that are streaks too long for
    the size rule: thin, their area over their length at most ``width`` pixels (beyond the
    paper). A bar L pixels long has the major semi-axis a = L / sqrt(3) (eq. 15 with the
    pixel's own second moment), so its width is area / (sqrt(3) a)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        thin = area <= width * math.sqrt(3.0) * a  # NaN (no moments) compares False
    return size_rule(area, min_area=min_area, max_area=max_area) & thin


class CandidateRate:
    """Per-pixel candidate rate: a running mean of the candidate mask over ``tau`` frames.

    Updated from the sparse candidates only. The whole image decays by the same factor every
    frame, so the decay is kept as one number: the rate is ``stored * scale``; a frame multiplies
    ``scale`` by ``1 - alpha`` and adds ``alpha / scale`` at its candidate pixels, which is
    ``rate = (1 - alpha) rate + alpha * mask`` (``cv2.accumulateWeighted``) without touching the
    other pixels. ``stored`` is folded back into the rate when ``scale`` gets small.

    Parameters
    ----------
    shape : (H, W)
    tau : frames of the running mean (``persistence_frames``); the first frames are averaged
        with ``1 / n`` so that the rate is meaningful from the start
    """

    _RENORMALISE_BELOW = 1e-4

    def __init__(self, shape: tuple[int, int], tau: float) -> None:
        self.shape = shape
        self.tau = float(tau)
        self.stored = np.zeros(shape[0] * shape[1], np.float32)
        self.scale = 1.0
        self.frames = 0
        #: Mean candidate rate over the region of interest (the same running mean of the
        #: candidate fraction).
        self.global_rate = 0.0

    def update(self, index: np.ndarray, fraction: float) -> None:
        """Add one frame: candidate pixels ``index`` (flat), ``fraction`` of the ROI."""
        self.frames += 1
        alpha = max(1.0 / self.frames, 1.0 / self.tau)
        self.global_rate += alpha * (fraction - self.global_rate)
        if alpha >= 1.0:  # the first frame: the rate is the mask
            self.stored.fill(0.0)
            self.scale = 1.0
            self.stored[index] = 1.0
            return
        self.scale *= 1.0 - alpha
        self.stored[index] += np.float32(alpha / self.scale)  # indices are unique
        if self.scale < self._RENORMALISE_BELOW:
            self.stored *= np.float32(self.scale)
            self.scale = 1.0

    def values(self) -> np.ndarray:
        """(H, W) float32, the rate of every pixel."""
        return (self.stored * np.float32(self.scale)).reshape(self.shape)


def blob_rate_sum(blobs: Blobs, stored: np.ndarray) -> np.ndarray:
    """(n_labels,) float64, the sum of ``stored`` (flat, per pixel) over each blob's pixels."""
    if blobs.index.size == 0:
        return np.zeros(blobs.n_labels)
    return np.bincount(blobs.pixel_labels, stored.take(blobs.index), blobs.n_labels)


def blob_mean_rate(blobs: Blobs, rate: CandidateRate) -> np.ndarray:
    """(n_labels,) mean candidate rate of each blob's pixels (NaN for label 0)."""
    total = blobs.rate_sum if blobs.rate_sum is not None else blob_rate_sum(blobs, rate.stored)
    with np.errstate(invalid="ignore", divide="ignore"):
        return total * rate.scale / blobs.moments.area


def blob_change(
    image: np.ndarray,
    previous: np.ndarray,
    index: np.ndarray,
    pixel_labels: np.ndarray,
    n_labels: int,
) -> np.ndarray:
    """Mean absolute change of each blob's pixels since the previous frame, (n_labels,)
    float64, grey levels (NaN for labels without a pixel).

    A streak is where the drop is during this exposure: the drop was elsewhere during the
    last one, so the streak's pixels have changed by about its contrast. A blob whose pixels
    have not changed at all is a copy of the last frame: a video encoder's skipped block,
    which keeps a streak drawn after the drop has gone (beyond the paper).

    Parameters
    ----------
    image, previous : (H, W) uint8, this frame and the last, as the background model saw them
    index : (N,) int, flat indices of the candidate pixels; pixel_labels : (N,) int, their blob
    n_labels : number of labels including 0
    """
    index = np.asarray(index, dtype=np.intp)
    now = image.reshape(-1)[index].astype(np.int16)
    return blob_mean(np.abs(now - previous.reshape(-1)[index]), pixel_labels, n_labels)


def moved_edge(
    image: np.ndarray,
    background: np.ndarray,
    index: np.ndarray,
    pixel_labels: np.ndarray,
    moments: BlobMoments,
    among: np.ndarray,
    *,
    shift_px: float,
) -> np.ndarray:
    """(n_labels,) bool: the blobs of ``among`` whose brightening an edge of the background,
    moved by up to ``shift_px`` pixels across its own length, explains (beyond the paper;
    docs/method.md, departure 30).

    A camera that vibrates by a fraction of a pixel, too little or too brief for the motion
    estimate, slides every edge of the view over its pixels: along each edge the bright side
    moves onto pixels that were dark, and eq. 8 cuts out a sliver as thin as a streak and as
    long as the edge, oriented along it. Under a drop the background can be anything; under a
    sliver it is an edge running along the blob. So: the background's gradient, averaged over
    the blob's pixels with its sign (texture averages out, an edge does not), is taken across
    the blob (along the minor axis of its moments, eqs. 13-16); a step edge moved by d pixels
    brightens its pixel by d times the step, and the central difference reads half the step,
    so a blob is an edge moved when its mean brightening over the background is at most
    ``2 * shift_px`` times that gradient.

    Parameters
    ----------
    image, background : (H, W) uint8, the frame and the background eq. 8 compared it with
    index : (N,) int, flat indices of the candidate pixels; pixel_labels : (N,) int, their blob
    moments : the blobs' :class:`BlobMoments` (central second moments m20, m11, m02)
    among : (n_labels,) bool, the blobs to test (the others are False)
    shift_px : the largest shift explained; 0 tests nothing
    """
    n_labels = among.shape[0]
    out = np.zeros(n_labels, dtype=bool)
    labels = np.asarray(pixel_labels, dtype=np.intp)
    tested = np.flatnonzero(among)
    if shift_px <= 0 or tested.size == 0 or labels.size == 0:
        return out
    # the tested blobs only, renumbered 0..k-1 (their pixels are a small part of the candidates)
    compact = np.full(n_labels, -1, dtype=np.intp)
    compact[tested] = np.arange(tested.size)
    ids = compact[labels]
    keep = ids >= 0
    ids = ids[keep]
    idx = np.asarray(index, dtype=np.intp)[keep]
    h, w = background.shape
    flat = background.reshape(-1)
    x, y = idx % w, idx // w
    # central differences, one-sided at the border (numpy's gradient, at the pixels needed)
    xp, xm = np.minimum(x + 1, w - 1), np.maximum(x - 1, 0)
    yp, ym = np.minimum(y + 1, h - 1), np.maximum(y - 1, 0)
    row = idx - x
    gx = (flat[row + xp].astype(np.float64) - flat[row + xm]) / np.maximum(xp - xm, 1)
    gy = (flat[yp * w + x].astype(np.float64) - flat[ym * w + x]) / np.maximum(yp - ym, 1)
    rise = image.reshape(-1)[idx].astype(np.float64) - flat[idx]
    mean_gx = blob_mean(gx, ids, tested.size)
    mean_gy = blob_mean(gy, ids, tested.size)
    mean_rise = blob_mean(rise, ids, tested.size)
    # the major axis is at 0.5 atan2(2 m11, m20 - m02) in the image's own axes (x right,
    # y down); across it is the unit normal (-sin, cos)
    major = 0.5 * np.arctan2(2.0 * moments.m11[tested], moments.m20[tested] - moments.m02[tested])
    across = np.abs(-mean_gx * np.sin(major) + mean_gy * np.cos(major))
    with np.errstate(invalid="ignore"):
        out[tested] = mean_rise <= 2.0 * shift_px * across  # NaN moments compare False
    return out


def blob_mean(values: np.ndarray, pixel_labels: np.ndarray, n_labels: int) -> np.ndarray:
    """Mean of a per-pixel quantity over each blob, (n_labels,) float64 (NaN for labels
    without a pixel). ``values`` and ``pixel_labels``: (N,), one per candidate pixel."""
    labels = np.asarray(pixel_labels, dtype=np.intp)
    area = np.bincount(labels, minlength=n_labels).astype(np.float64)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.bincount(labels, values, n_labels) / area


def structure_rule(
    mean_rate: np.ndarray,
    *,
    global_rate: float,
    floor: float,
    ratio: float,
    local_rate: np.ndarray | None = None,
    local_ratio: float = 0.0,
) -> np.ndarray:
    """(n_labels,) bool: blobs that recur in place (structure), from their pixels' rate.

    Parameters
    ----------
    mean_rate : (n_labels,) mean per-pixel candidate rate of each blob, *before* this frame was
        added (:func:`blob_mean_rate`)
    global_rate : mean candidate rate over the region of interest
    floor, ratio : a blob is structural when its mean pixel rate exceeds
        ``max(floor, ratio * global_rate)``
    local_rate, local_ratio : optional (n_labels,) candidate rate of the part of the view
        around each blob (:func:`local_rate_at`); a blob is then structural only if its rate
        also exceeds ``local_ratio`` times that (departure 28): an edge recurs on its own
        line, rain as often everywhere around it, however dense it is there
    """
    structural = mean_rate > max(floor, ratio * global_rate)  # NaN (no pixel) compares False
    if structural.size:
        structural[0] = False
    if local_rate is not None and local_ratio > 0:
        idx = np.flatnonzero(structural)
        structural[idx] = mean_rate[idx] > local_ratio * local_rate[idx]
    return structural


def local_rate_map(rate: CandidateRate, *, factor: int, window: int) -> np.ndarray:
    """The candidate rate of the part of the view around each place: ``rate`` reduced by
    ``factor`` (:func:`hos.motion.reduce`, area means) and averaged over ``window`` x
    ``window`` reduced pixels (a box, reflected at the borders). (H // factor, W // factor)
    float32."""
    small = reduce(rate.values(), factor)
    return cv2.blur(small, (window, window), borderType=cv2.BORDER_REFLECT)


def local_rate_at(local_map: np.ndarray, factor: int, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """``local_map`` (from :func:`local_rate_map`) at the image points (x, y); NaN where a
    point is not finite (label 0's centroid)."""
    out = np.full(x.shape, np.nan, np.float32)
    ok = np.isfinite(x) & np.isfinite(y)
    hs, ws = local_map.shape
    col = np.clip((x[ok] / factor).astype(np.intp), 0, ws - 1)
    row = np.clip((y[ok] / factor).astype(np.intp), 0, hs - 1)
    out[ok] = local_map[row, col]
    return out
