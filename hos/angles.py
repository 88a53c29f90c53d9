"""Arithmetic on orientations, which are pi-periodic (theta and theta + pi are one axis)."""

from __future__ import annotations

import numpy as np

__all__ = ["axial_mean", "bin_centers", "wrap_diff"]


def wrap_diff(a: np.ndarray | float, b: np.ndarray | float) -> np.ndarray:
    """Signed difference ``a - b`` of orientations, wrapped into [-pi/2, pi/2)."""
    return np.mod(np.asarray(a, dtype=np.float64) - b + np.pi / 2, np.pi) - np.pi / 2


def axial_mean(theta: np.ndarray, weights: np.ndarray) -> float:
    """Weighted mean orientation in [0, pi), by doubling the angles (axial statistics)."""
    s = float(np.sum(weights * np.sin(2.0 * theta)))
    c = float(np.sum(weights * np.cos(2.0 * theta)))
    return float(np.mod(0.5 * np.arctan2(s, c), np.pi))


def bin_centers(bins: int) -> np.ndarray:
    """(bins,) centres of ``bins`` equal bins over [0, pi), radians."""
    return (np.arange(bins) + 0.5) * (np.pi / bins)
