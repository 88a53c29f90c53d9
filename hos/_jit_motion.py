"""The camera-motion estimate of :mod:`hos.motion`, compiled with numba.

:func:`hos.motion.global_translation` makes about forty numpy and OpenCV calls, each a pass
over the image or over a few thousand pixels with its own temporary array.
:func:`global_translation_jit` keeps OpenCV's Gaussian blur and makes the rest of the fit in
compiled passes: one for the Sobel gradients, the time derivative and the mean gradient energy
together, one to move the strong pixels to the front, then two per round of the reweighted
least squares (the five sums of the normal equations, then the residuals) and a median.

The logic is the reference's, step for step; the arithmetic is not: the sums are plain float64
loops that LLVM may reorder into SIMD lanes, not numpy's summation orders. The shift agrees
with the reference to about 1e-5 px, far below the 0.5 px at which the detector calls a frame
moved (``robustness.motion_frame_px``)."""

from __future__ import annotations

import threading
from typing import Literal

import cv2
import numpy as np

from ._numba import ENABLED, _njit
from .motion import global_translation

__all__ = ["global_translation_jit"]

_BORDER = 4  # px ignored at each side, where the blur and the Sobel see the padding
_MIN_STRONG = 500  # fewer strong-gradient pixels than this: fit all pixels
_ROUNDS = 3  # of iteratively reweighted least squares


# fastmath lets LLVM reorder the float sums into SIMD lanes; not "nnan"/"ninf": the code
# compares with np.inf.
@_njit(fastmath={"reassoc", "contract"})
def _fit_translation(prev, cur, other, significance, terms, residuals, exclude):  # pragma: no cover
    # terms: (3, h - 2b, w - 2b) float32 and residuals: ((h - 2b) * (w - 2b),) float64, scratch
    h, w = prev.shape
    b = _BORDER
    n = max(h - 2 * b, 0) * max(w - 2 * b, 0)
    if n == 0:
        return 0.0, 0.0  # nothing inside the border (the reference: textureless)
    # 1. The terms of the optical-flow constraint inside the border, ix dx + iy dy + it = 0:
    #    the gradient of the mean of prev and other (the Sobel of their sum s, / 16; other is
    #    cur, or prev itself for the gradient of prev alone) and the time derivative; and the
    #    mean gradient energy.
    ix, iy, it = terms[0], terms[1], terms[2]
    g2_sum = 0.0
    for y in range(b, h - b):
        p0, p1, p2 = prev[y - 1], prev[y], prev[y + 1]
        c0, c1, c2 = other[y - 1], other[y], other[y + 1]
        c_row = cur[y]
        ix_row, iy_row, it_row = ix[y - b], iy[y - b], it[y - b]
        ex_row = exclude[y]
        for i in range(w - 2 * b):  # (rows and a non-negative index: SIMD loads and stores)
            x = i + b
            keep = np.float32(1.0) if ex_row[x] == 0 else np.float32(0.0)
            s00, s01, s02 = p0[x - 1] + c0[x - 1], p0[x] + c0[x], p0[x + 1] + c0[x + 1]
            s10, s12 = p1[x - 1] + c1[x - 1], p1[x + 1] + c1[x + 1]
            s20, s21, s22 = p2[x - 1] + c2[x - 1], p2[x] + c2[x], p2[x + 1] + c2[x + 1]
            gx = ((s02 - s00) + np.float32(2) * (s12 - s10) + (s22 - s20)) * np.float32(1 / 16)
            gy = ((s20 - s00) + np.float32(2) * (s21 - s01) + (s22 - s02)) * np.float32(1 / 16)
            gx *= keep  # an excluded pixel's terms are zero: it adds nothing to the sums
            gy *= keep
            ix_row[i] = gx
            iy_row[i] = gy
            it_row[i] = (c_row[x] - p1[x]) * keep
            g2_sum += gx * gx + gy * gy
    ix, iy, it = ix.reshape(n), iy.reshape(n), it.reshape(n)
    g2_mean = g2_sum / n
    # 2. A translation is told by the edges: keep the pixels whose gradient energy is above the
    #    mean (about a quarter of them), moved to the front of the arrays; all pixels when
    #    fewer than 500 are strong.
    m = 0
    for k in range(n):
        m += ix[k] * ix[k] + iy[k] * iy[k] > g2_mean
    if m >= _MIN_STRONG:
        m = 0
        for k in range(n):  # (without a branch: copy every pixel, advance past strong ones)
            ix[m], iy[m], it[m] = ix[k], iy[k], it[k]
            m += ix[k] * ix[k] + iy[k] * iy[k] > g2_mean
    else:
        m = n
    # 3. Iteratively reweighted least squares of ix dx + iy dy + it = 0: a pixel is fitted
    #    when its last residual is below the cut (3 robust sigmas), every pixel at first.
    abs_residual = residuals[:m]
    abs_residual[:] = 0.0
    cut = np.inf
    d0 = d1 = a00 = a01 = a11 = 0.0
    for _ in range(_ROUNDS):
        a00 = a01 = a11 = r0 = r1 = 0.0  # the normal equations A d = r
        for k in range(m):
            weight = 1.0 if abs_residual[k] < cut else 0.0
            wx, wy = weight * ix[k], weight * iy[k]
            a00 += wx * ix[k]
            a01 += wx * iy[k]
            a11 += wy * iy[k]
            r0 -= wx * it[k]
            r1 -= wy * it[k]
        det = a00 * a11 - a01 * a01
        if det <= 1e-9 * max(a00 + a11, 1.0) ** 2:
            return 0.0, 0.0  # a textureless image: no measurable motion
        d0 = (a11 * r0 - a01 * r1) / det
        d1 = (a00 * r1 - a01 * r0) / det
        for k in range(m):
            abs_residual[k] = abs(ix[k] * d0 + iy[k] * d1 + it[k])
        cut = 3.0 * 1.4826 * np.median(abs_residual[::4]) + 1e-3
    # 4. Keep only a shift that the data support: rain and noise over a smooth scene also give
    #    a small least-squares "shift"; its covariance is var(residual) * A^-1, so d A d / var
    #    is chi-square with 2 degrees of freedom. (A is the last round's, as in the reference.)
    n_inliers = 0.0
    squares = 0.0
    for k in range(m):
        weight = 1.0 if abs_residual[k] < cut else 0.0
        n_inliers += weight
        squares += weight * abs_residual[k] ** 2
    var = squares / max(n_inliers - 2.0, 1.0)
    if (a00 * d0 * d0 + 2.0 * a01 * d0 * d1 + a11 * d1 * d1) / max(var, 1e-12) < significance**2:
        return 0.0, 0.0
    return d0, d1


_thread = threading.local()


def _scratch(shape: tuple[int, int]) -> tuple[np.ndarray, ...]:
    """Image-sized buffers of the calling thread, kept from call to call: fresh ones cost
    page faults (about 150 a call at 320x180)."""
    if getattr(_thread, "shape", None) != shape:
        h, w = shape
        inner = (max(h - 2 * _BORDER, 0), max(w - 2 * _BORDER, 0))
        _thread.shape = shape
        _thread.buffers = (
            np.empty(shape, np.float32),  # the blurred frames
            np.empty(shape, np.float32),
            np.empty((3, *inner), np.float32),  # ix, iy, it
            np.empty(inner[0] * inner[1]),  # the residuals
            np.zeros(shape, np.uint8),  # no pixel excluded
        )
    return _thread.buffers


def global_translation_jit(
    previous: np.ndarray,
    current: np.ndarray,
    *,
    significance: float = 4.0,
    exclude: np.ndarray | None = None,
    gradient: Literal["mean", "previous"] = "mean",
) -> tuple[float, float]:
    """Translation (dx, dy) in pixels of ``current`` relative to ``previous``, compiled.

    :func:`hos.motion.global_translation` to about 1e-5 px (see the module's docstring); that
    function runs instead when numba is not available or ``HOS_JIT=0``.

    Parameters
    ----------
    previous, current : (h, w) float32, same shape (reduced images); other dtypes are converted
        to float32
    significance : a shift is reported only when it is this many standard errors from zero
    exclude : (h, w) bool or uint8, optional; nonzero pixels take no part in the fit
    gradient : ``"mean"`` (of the two images) or ``"previous"`` (``previous`` alone), as in
        :func:`hos.motion.global_translation`

    Returns
    -------
    (dx, dy) in pixels of the given images; accurate for shifts below about one pixel and
    monotone (an under-estimate) above; (0, 0) when not significant.
    """
    if not ENABLED:
        return global_translation(
            previous, current, significance=significance, exclude=exclude, gradient=gradient
        )
    if gradient not in ("mean", "previous"):
        raise ValueError(f'gradient must be "mean" or "previous", got {gradient!r}')
    previous = np.asarray(previous, dtype=np.float32)
    current = np.asarray(current, dtype=np.float32)
    if previous.ndim != 2 or previous.shape != current.shape:
        raise ValueError(
            f"previous and current must be 2-D of one shape, got {previous.shape} and "
            f"{current.shape}"
        )
    prev, cur, terms, residuals, none = _scratch(previous.shape)
    if exclude is None:
        exclude = none
    else:
        exclude = np.asarray(exclude)
        if exclude.shape != previous.shape:
            raise ValueError(f"exclude must be {previous.shape}, got {exclude.shape}")
        exclude = exclude.view(np.uint8) if exclude.dtype == np.bool_ else exclude.astype(np.uint8)
    cv2.GaussianBlur(previous, (5, 5), 1.0, dst=prev)
    cv2.GaussianBlur(current, (5, 5), 1.0, dst=cur)
    other = prev if gradient == "previous" else cur
    dx, dy = _fit_translation(prev, cur, other, float(significance), terms, residuals, exclude)
    return float(dx), float(dy)
