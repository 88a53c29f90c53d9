"""Arithmetic on orientations, which are pi-periodic (theta and theta + pi are one axis)."""

from __future__ import annotations

import numpy as np

__all__ = ["axial_mean", "bin_centers", "wrap_diff", "wrapped_normal_pdf"]


def wrap_diff(a: np.ndarray | float, b: np.ndarray | float) -> np.ndarray:
    """Signed difference ``a - b`` of orientations, wrapped into [-pi/2, pi/2)."""
    return np.mod(np.asarray(a, dtype=np.float64) - b + np.pi / 2, np.pi) - np.pi / 2


def wrapped_normal_pdf(
    theta: np.ndarray | float, mu: np.ndarray | float, sigma: np.ndarray | float
) -> np.ndarray:
    """Density (1/rad) over [0, pi) of the normal N(mu, sigma) wrapped on the pi-periodic circle,
    summed over the nearest three periods (enough for sigma up to about pi/2). Broadcasts."""
    d = wrap_diff(theta, mu)
    sigma = np.asarray(sigma, dtype=np.float64)
    g = sum(np.exp(-0.5 * ((d + k * np.pi) / sigma) ** 2) for k in (-1, 0, 1))
    return g / (sigma * np.sqrt(2.0 * np.pi))


def axial_mean(theta: np.ndarray, weights: np.ndarray) -> float:
    """Weighted mean orientation in [0, pi), by doubling the angles (axial statistics)."""
    s = float(np.sum(weights * np.sin(2.0 * theta)))
    c = float(np.sum(weights * np.cos(2.0 * theta)))
    return float(np.mod(0.5 * np.arctan2(s, c), np.pi))


def bin_centers(bins: int) -> np.ndarray:
    """(bins,) centres of ``bins`` equal bins over [0, pi), radians."""
    return (np.arange(bins) + 0.5) * (np.pi / bins)
