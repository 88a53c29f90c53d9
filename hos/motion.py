"""Global image measurements that tell whether the camera can judge: motion and exposure.

Beyond the paper. Both work on a reduced image (a few tens of thousands of pixels), so they cost
about a millisecond at 1920x1080.

* :func:`global_translation`: the frame-to-frame translation of the whole image, by a robust
  least-squares (Lucas-Kanade) fit of the optical-flow constraint ``Ix dx + Iy dy + It = 0`` over
  all pixels, reweighted twice to ignore moving cars and rain. Sub-pixel jitter of a camera in
  the wind, which makes every vertical edge flicker in the foreground, shows up here directly.
  (Phase correlation, the textbook tool, was measured to give unreliable sub-pixel shifts on
  reduced images.)
* :func:`exposure_gain`: the global gain between a frame and the background, as the median of
  their ratio over well-exposed pixels: an auto-exposure step is one number for the whole image.
"""

from __future__ import annotations

from typing import Literal

import cv2
import numpy as np

from ._stats import median

__all__ = ["exposure_gain", "global_translation", "reduce"]


def reduce(gray: np.ndarray, scale: int) -> np.ndarray:
    """(H // scale, W // scale) float32 area-averaged copy of ``gray``.

    The image is cropped to a multiple of ``scale`` first: OpenCV's area resampling has a fast
    path for whole-number factors only (1 ms against 0.1 ms at 960x540), and a faster one still
    for halving (0.01 ms), so a power-of-two factor is applied as repeated halvings (the mean of
    2x2 means is the mean of the block; each halving rounds, so a value may differ from one
    direct reduction by a grey level).
    """
    h, w = gray.shape[:2]
    hs, ws = max(h // scale, 1), max(w // scale, 1)
    if hs * scale <= h and ws * scale <= w:
        gray = gray[: hs * scale, : ws * scale]
    if scale > 1 and scale & (scale - 1) == 0 and hs * scale <= h and ws * scale <= w:
        small = gray
        while scale > 1:
            small = cv2.resize(
                small,
                (small.shape[1] // 2, small.shape[0] // 2),
                interpolation=cv2.INTER_AREA,
            )
            scale //= 2
    else:
        small = cv2.resize(gray, (ws, hs), interpolation=cv2.INTER_AREA)
    return small.astype(np.float32)


def global_translation(
    previous: np.ndarray,
    current: np.ndarray,
    *,
    significance: float = 4.0,
    exclude: np.ndarray | None = None,
    gradient: Literal["mean", "previous"] = "mean",
) -> tuple[float, float]:
    """Translation (dx, dy) in pixels of ``current`` relative to ``previous``.

    Parameters
    ----------
    previous, current : (h, w) float32, same shape (reduced images)

    significance : a shift is reported only when it is this many standard errors from zero
    exclude : (h, w) bool or uint8, optional; nonzero pixels take no part in the fit (what the
        background model saw moving: vehicles, headlights and their reflections, streaks)
    gradient : ``"mean"``, the gradient of the mean of the two images (symmetric: the most
        accurate when both show the same texture); ``"previous"``, that of ``previous`` alone
        (Lucas-Kanade's template, as in the inverse compositional form of Baker and Matthews,
        IJCV 2004): give the reference there, and what only ``current`` shows (falling
        flakes, streaks, vehicles) adds residual, never gradient, to the fit

    Returns
    -------
    (dx, dy) in pixels of the given images; accurate for shifts below about one pixel and
    monotone (an under-estimate) above; (0, 0) when not significant.
    """
    prev = cv2.GaussianBlur(previous, (5, 5), 1.0)
    cur = cv2.GaussianBlur(current, (5, 5), 1.0)
    if gradient not in ("mean", "previous"):
        raise ValueError(f'gradient must be "mean" or "previous", got {gradient!r}')
    textured = prev if gradient == "previous" else 0.5 * (prev + cur)
    ix = cv2.Sobel(textured, cv2.CV_32F, 1, 0, ksize=3) / 8.0
    iy = cv2.Sobel(textured, cv2.CV_32F, 0, 1, ksize=3) / 8.0
    it = cur - prev
    b = 4  # ignore the border, where the blur and the Sobel see the padding
    ix, iy, it = ix[b:-b, b:-b].ravel(), iy[b:-b, b:-b].ravel(), it[b:-b, b:-b].ravel()
    if exclude is not None:  # an excluded pixel's terms are zero: it adds nothing to the sums
        keep = (np.asarray(exclude)[b:-b, b:-b].ravel() == 0).astype(np.float32)
        ix, iy, it = ix * keep, iy * keep, it * keep
    # A translation is told by the edges: keep the pixels whose gradient is above the mean
    # (about a quarter of them), four times less work for the same estimate.
    g2 = ix * ix + iy * iy
    strong = np.flatnonzero(g2 > g2.mean())
    if strong.size >= 500:
        ix, iy, it = ix.take(strong), iy.take(strong), it.take(strong)
    weights = np.ones_like(it)
    d = np.zeros(2)
    a = np.eye(2)
    residual = it
    for _ in range(3):  # iteratively reweighted least squares (cut at 3 robust sigmas)
        wx, wy = weights * ix, weights * iy
        sxx, sxy, syy = _dot(wx, ix), _dot(wx, iy), _dot(wy, iy)
        a = np.array([[sxx, sxy], [sxy, syy]])
        rhs = -np.array([_dot(wx, it), _dot(wy, it)])
        if sxx * syy - sxy * sxy <= 1e-9 * max(sxx + syy, 1.0) ** 2:
            return 0.0, 0.0  # a textureless image: no measurable motion
        d = np.linalg.solve(a, rhs)
        residual = ix * d[0] + iy * d[1] + it
        abs_residual = np.abs(residual)
        scale = 3.0 * 1.4826 * median(abs_residual[::4]) + 1e-3
        weights = (abs_residual < scale).astype(np.float32)
    # Keep only a shift that the data support: rain and noise over a smooth scene also give a
    # small least-squares "shift"; its covariance is var(residual) * A^-1 (chi-square, 2 dof).
    n = float(weights.sum())
    var = _dot(weights, residual * residual) / max(n - 2.0, 1.0)
    if float(d @ a @ d) / max(var, 1e-12) < significance**2:
        return 0.0, 0.0
    return float(d[0]), float(d[1])


def _dot(a: np.ndarray, b: np.ndarray) -> float:
    """Sum of ``a * b`` by numpy's own loop, never BLAS: OpenBLAS splits a dot product of more
    than 10,000 elements across threads that then spin, which cost 5 ms of CPU a frame at
    640x360 (the reduced image is 320 px wide there) for a 0.05 ms sum."""
    return float(np.einsum("i,i->", a, b))


def exposure_gain(frame: np.ndarray, background: np.ndarray) -> float:
    """Gain g such that ``g * frame`` matches ``background`` (median ratio, robust to objects).

    Parameters
    ----------
    frame, background : (h, w) float32 reduced images
    """
    # A median needs few samples: every 4th pixel of every 4th row (~2,000 at any frame size).
    frame, background = frame[::4, ::4], background[::4, ::4]
    valid = (frame > 12.0) & (frame < 243.0) & (background > 12.0) & (background < 243.0)
    if np.count_nonzero(valid) < 0.1 * frame.size:
        return 1.0
    return median(background[valid] / frame[valid])
