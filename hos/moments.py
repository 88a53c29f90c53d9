"""Per-blob geometric moments, orientation, semi-axes and orientation uncertainty.

Paper section 3.3.2, eqs. 13-19, vectorised over all blobs at once: the inputs are the
coordinates and labels of the candidate pixels only (a few thousand), reduced with
``np.bincount`` — no loop over blobs, no pass over the whole image.

Orientation convention (project contract): image coordinates, x to the right, y downward,
theta measured from the x axis toward the y axis, in [0, pi). 90 degrees is a vertical streak.
The paper writes eq. 14 as ``1/2 atan(2 m11 / (m02 - m20))``, an angle measured from the
vertical; in our convention the same ellipse axis is ``1/2 atan2(2 m11, m20 - m02)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["BlobMoments", "blob_moments", "moments_from_central", "orientation_uncertainty"]

#: Second moment of a unit pixel about its centre: a pixel is a 1x1 square, not a point.
_PIXEL_VAR = 1.0 / 12.0


@dataclass(frozen=True)
class BlobMoments:
    """Moments and ellipse parameters of blobs 1..n-1 (index 0, the background, is unused).

    All arrays have shape (n_labels,).

    Attributes
    ----------
    area : float64, pixels (m00)
    x0, y0 : float64, centroid in pixels
    m20, m11, m02 : float64, central second-order moments normalised by the area (eq. 13), px^2
    theta : float64, radians in [0, pi), orientation of the major axis (eq. 14)
    a, b : float64, major and minor semi-axes, px (eqs. 15-17)
    """

    area: np.ndarray
    x0: np.ndarray
    y0: np.ndarray
    m20: np.ndarray
    m11: np.ndarray
    m02: np.ndarray
    theta: np.ndarray
    a: np.ndarray
    b: np.ndarray


def blob_moments(xs: np.ndarray, ys: np.ndarray, labels: np.ndarray, n_labels: int) -> BlobMoments:
    """Moments of every blob from its pixel coordinates.

    Parameters
    ----------
    xs, ys : (N,) int or float, coordinates of the candidate pixels
    labels : (N,) int, label of each pixel in [0, n_labels); label 0 is ignored
    n_labels : number of labels including the background

    Returns
    -------
    BlobMoments with arrays of shape (n_labels,); blobs without pixels get area 0 and NaNs.
    """
    xs = np.asarray(xs, dtype=np.float64)
    ys = np.asarray(ys, dtype=np.float64)
    labels = np.asarray(labels, dtype=np.intp)
    area = np.bincount(labels, minlength=n_labels).astype(np.float64)
    with np.errstate(invalid="ignore", divide="ignore"):
        inv = 1.0 / area
        x0 = np.bincount(labels, xs, n_labels) * inv
        y0 = np.bincount(labels, ys, n_labels) * inv
        # Centre on the blob's centroid before squaring: no cancellation at large coordinates.
        dx = xs - x0[labels]
        dy = ys - y0[labels]
        m20 = np.bincount(labels, dx * dx, n_labels) * inv  # eq. 13
        m11 = np.bincount(labels, dx * dy, n_labels) * inv
        m02 = np.bincount(labels, dy * dy, n_labels) * inv
    return moments_from_central(area, x0, y0, m20, m11, m02)


def moments_from_central(
    area: np.ndarray,
    x0: np.ndarray,
    y0: np.ndarray,
    m20: np.ndarray,
    m11: np.ndarray,
    m02: np.ndarray,
) -> BlobMoments:
    """Orientation and semi-axes (eqs. 14-17) from each blob's central moments.

    ``m20, m11, m02`` are the central second-order moments of the pixel *centres* divided by the
    area (eq. 13); the second moment of a unit pixel (1/12) is added to m20 and m02 here.
    """
    m20 = m20 + _PIXEL_VAR
    m02 = m02 + _PIXEL_VAR
    theta = np.mod(0.5 * np.arctan2(2.0 * m11, m20 - m02), np.pi)  # eq. 14, our axes
    half_trace = 0.5 * (m20 + m02)
    root = np.sqrt((0.5 * (m20 - m02)) ** 2 + m11 * m11)
    lam1 = half_trace + root  # eigenvalues of [[m20, m11], [m11, m02]] (eq. 17)
    lam2 = np.maximum(half_trace - root, 0.0)
    a = 2.0 * np.sqrt(lam1)  # eq. 15
    b = 2.0 * np.sqrt(lam2)  # eq. 16
    return BlobMoments(area, x0, y0, m20, m11, m02, theta, a, b)


def orientation_uncertainty(
    m20: np.ndarray, m11: np.ndarray, m02: np.ndarray, *, dm: float, lo: float, hi: float
) -> np.ndarray:
    """Uncertainty d_theta of each blob's orientation, eq. 19, clipped to [lo, hi].

    ``d_theta = dm * sqrt((m02 - m20)^2 + 2 m11^2) / ((m02 - m20)^2 + 4 m11^2)``, the error
    propagated from an equal uncertainty dm on each second-order moment (eq. 18). Elongated
    blobs get a small d_theta (a peaky vote), round blobs a large one (a flat vote); a perfectly
    round blob has no orientation at all (division by zero), hence the clip.
    """
    diff = np.asarray(m02, dtype=np.float64) - m20
    m11 = np.asarray(m11, dtype=np.float64)
    num = np.sqrt(diff * diff + 2.0 * m11 * m11)
    den = diff * diff + 4.0 * m11 * m11
    with np.errstate(invalid="ignore", divide="ignore"):
        d_theta = dm * num / den
    d_theta = np.where(np.isfinite(d_theta), d_theta, hi)  # 0/0 and x/0: no orientation
    return np.minimum(np.maximum(d_theta, lo), hi)
