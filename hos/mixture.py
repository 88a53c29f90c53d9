"""EM for the Gaussian-uniform mixture of the HOS, and its goodness of fit (section 4).

Model (eq. 23): ``y(theta) ~ Pi N(theta | mu, sigma) + (1 - Pi) U[0, pi](theta)``; the Gaussian
is the rain (or snow), the uniform the noise. The histogram is quantised, so EM runs on bin
centres theta_i with masses y_i (eqs. 24-25). Two details differ from a literal reading:

* the Gaussian's value at bin i is its *mass over the bin* divided by the bin width, from the
  normal CDF, and the Gaussian is wrapped around the pi-periodic circle. With sigma of one or two
  degrees, the density at the centre misstates a bin's probability; the mass does not;
* distances between angles are wrapped into [-pi/2, pi/2) (the paper asks for this), and the
  mean is updated as ``mu + weighted mean of wrapped distances``.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.special import ndtr

from .angles import axial_mean, bin_centers, wrap_diff
from .result import MixtureFit

__all__ = ["fit_mixture", "gaussian_bin_mass", "gof_distance", "mixture_bin_mass"]


def gaussian_bin_mass(mu: float, sigma: float, bins: int) -> np.ndarray:
    """(bins,) mass of the wrapped normal N(mu, sigma) over each bin of [0, pi); sums to 1."""
    edges = np.arange(bins + 1) * (np.pi / bins)
    cdf = sum(ndtr((edges - mu + k * np.pi) / sigma) for k in (-2, -1, 0, 1, 2))
    mass = np.diff(cdf)
    return mass / mass.sum()


def mixture_bin_mass(pi: float, mu: float, sigma: float, bins: int) -> np.ndarray:
    """(bins,) probability of each bin under the mixture of eq. 23; sums to 1."""
    return pi * gaussian_bin_mass(mu, sigma, bins) + (1.0 - pi) / bins


def gof_distance(y: np.ndarray, pi: float, mu: float, sigma: float) -> float:
    """Goodness of fit D of eq. 26: the largest gap between the cumulative distributions of the
    observed histogram and of the fitted mixture over [0, pi]."""
    y = np.asarray(y, dtype=np.float64)
    f_o = np.cumsum(y / y.sum())
    f_e = np.cumsum(mixture_bin_mass(pi, mu, sigma, y.size))
    return float(np.max(np.abs(f_e - f_o)))


def _initial_guess(theta: np.ndarray, y: np.ndarray) -> tuple[float, float, float] | None:
    """Section 4.2: subtract the median, keep the upper part, take its mean, spread, surface."""
    upper = np.maximum(y - np.median(y), 0.0)
    total = upper.sum()
    if total <= 0.0:
        return None
    mu = axial_mean(theta, upper)
    d = wrap_diff(theta, mu)
    sigma = math.sqrt(float(np.sum(upper * d * d) / total))
    return float(total / y.sum()), mu, sigma


def fit_mixture(
    histogram: np.ndarray,
    *,
    max_iter: int = 100,
    tol: float = 1e-6,
    gof_dc: float = 0.06,
    sigma_min: float = math.radians(1.0),
) -> MixtureFit:
    """Fit eq. 23 to a HOS by EM (eqs. 24-25) and test the fit (eq. 26).

    Parameters
    ----------
    histogram : (bins,) non-negative, the HOS over [0, pi)

    Returns
    -------
    MixtureFit; ``ok`` is False (with ``reason``) when the histogram is empty or flat.
    ``gof_ok`` is ``gof_d <= gof_dc``.
    """
    y = np.asarray(histogram, dtype=np.float64)
    total = y.sum()
    if y.ndim != 1 or y.size < 8:
        return MixtureFit(ok=False, reason="histogram must be 1-D with at least 8 bins")
    if not np.isfinite(total) or total <= 0.0:
        return MixtureFit(ok=False, reason="empty histogram")
    bins = y.size
    y = y / total
    theta = bin_centers(bins)
    width = np.pi / bins
    start = _initial_guess(theta, y)
    if start is None:
        return MixtureFit(ok=False, reason="flat histogram")
    pi, mu, sigma = start
    pi = min(max(pi, 0.01), 0.99)
    sigma = max(sigma, sigma_min)
    uniform = 1.0 / np.pi
    iterations = 0
    for iterations in range(1, max_iter + 1):  # noqa: B007 (the count is reported)
        gauss = gaussian_bin_mass(mu, sigma, bins) / width
        # E-step (eq. 24): probability that bin i is noise.
        z = (1.0 - pi) * uniform / (pi * gauss + (1.0 - pi) * uniform)
        w = (1.0 - z) * y
        sw = w.sum()
        if sw <= 1e-12:
            pi, sigma = 0.0, math.pi / 2
            break
        # M-step (eq. 25) with wrapped distances.
        mu_new = float(np.mod(mu + np.sum(w * wrap_diff(theta, mu)) / sw, np.pi))
        d = wrap_diff(theta, mu_new)
        sigma_new = max(math.sqrt(float(np.sum(w * d * d) / sw)), sigma_min)
        pi_new = float(sw)  # sum(y) == 1
        change = max(abs(pi_new - pi), abs(float(wrap_diff(mu_new, mu))), abs(sigma_new - sigma))
        pi, mu, sigma = pi_new, mu_new, sigma_new
        if change < tol:
            break
    d_gof = gof_distance(y, pi, mu, sigma)
    return MixtureFit(
        ok=True,
        pi=pi,
        mu=mu,
        sigma=sigma,
        gof_d=d_gof,
        gof_ok=d_gof <= gof_dc,
        iterations=iterations,
    )
