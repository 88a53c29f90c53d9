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

import functools
import math

import numpy as np

from ._stats import median
from .angles import axial_mean, bin_centers, wrap_diff
from .result import MixtureFit

__all__ = ["fit_mixture", "gaussian_bin_mass", "gof_distance", "mixture_bin_mass"]


@functools.lru_cache(maxsize=8)
def _shifted_edges(bins: int) -> np.ndarray:
    """(5, bins + 1) bin edges of [0, pi) shifted by -2pi..2pi, for the wrapped normal."""
    edges = np.arange(bins + 1) * (np.pi / bins)
    return edges[None, :] + np.pi * np.arange(-2, 3)[:, None]


def gaussian_bin_mass(mu: float, sigma: float, bins: int) -> np.ndarray:
    """(bins,) mass of the wrapped normal N(mu, sigma) over each bin of [0, pi); sums to 1."""
    # Imported here: scipy costs 0.13 s of start-up, and the compiled detector
    # (hos._jit_mixture) never calls this.
    from scipy.special import ndtr

    z = _shifted_edges(bins) - mu
    z /= sigma
    cdf = ndtr(z, out=z).sum(axis=0)
    mass = cdf[1:] - cdf[:-1]
    mass /= mass.sum()
    return mass


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
    upper = np.maximum(y - median(y), 0.0)
    total = upper.sum()
    if total <= 0.0:
        return None
    mu = axial_mean(theta, upper)
    d = wrap_diff(theta, mu)
    sigma = math.sqrt(float(np.sum(upper * d * d) / total))
    return float(total / y.sum()), mu, sigma


def _em_step(
    theta: np.ndarray, y: np.ndarray, params: np.ndarray, sigma_min: float
) -> tuple[np.ndarray, float]:
    """One EM step (eqs. 24-25) from ``params = (pi, mu, sigma)``; also the log-likelihood of
    ``params`` (computed on the way, for free)."""
    pi, mu, sigma = (float(v) for v in params)
    bins = y.size
    gauss = gaussian_bin_mass(mu, sigma, bins)
    gauss *= bins / np.pi  # density over each bin
    rain = gauss
    rain *= pi
    total = rain + (1.0 - pi) / np.pi
    loglik = float(y @ np.log(total))
    w = y * rain
    w /= total  # (1 - z_i) y_i, z_i of eq. 24
    sw = float(w.sum())
    if sw <= 1e-12:
        return np.array([0.0, mu, np.pi / 2]), loglik
    d = theta - mu  # eq. 25, with wrapped distances (wrap_diff, written out)
    d += np.pi / 2
    np.mod(d, np.pi, out=d)
    d -= np.pi / 2
    shift = float(w @ d) / sw
    d -= shift
    d *= d
    sigma_new = max(math.sqrt(float(w @ d) / sw), sigma_min)
    return np.array([sw, (mu + shift) % math.pi, sigma_new]), loglik


def _clamp(params: np.ndarray, sigma_min: float) -> np.ndarray:
    pi, mu, sigma = (float(v) for v in params)
    pi = min(max(pi, 1e-4), 1.0 - 1e-4)
    return np.array([pi, mu % math.pi, min(max(sigma, sigma_min), np.pi)])


def fit_mixture(
    histogram: np.ndarray,
    *,
    max_iter: int = 100,
    tol: float = 1e-4,
    gof_dc: float = 0.06,
    sigma_min: float = math.radians(1.0),
    start: tuple[float, float, float] | None = None,
) -> MixtureFit:
    """Fit eq. 23 to a HOS by EM (eqs. 24-25) and test the fit (eq. 26).

    EM converges slowly on the flat histograms of clear weather (often 100 steps). Each round
    here makes two EM steps and one SQUAREM extrapolation (Varadhan & Roland, 2008), kept only
    when it does not lower the likelihood, so the result is EM's, in a fraction of the steps.

    Parameters
    ----------
    histogram : (bins,) non-negative, the HOS over [0, pi)
    start : optional (pi, mu, sigma), e.g. the previous frame's fit. EM starts from it instead of
        the paper's median rule when it explains the histogram better (higher likelihood): in
        steady rain it is already near the optimum and EM needs a few steps, not twenty.

    Returns
    -------
    MixtureFit; ``ok`` is False (with ``reason``) when the histogram is empty or flat.
    ``gof_ok`` is ``gof_d <= gof_dc``. ``iterations`` counts EM steps.
    """
    y = np.asarray(histogram, dtype=np.float64)
    if y.ndim != 1 or y.size < 8:
        return MixtureFit(ok=False, reason="histogram must be 1-D with at least 8 bins")
    total = y.sum()
    if not np.isfinite(total) or total <= 0.0:
        return MixtureFit(ok=False, reason="empty histogram")
    y = y / total
    theta = bin_centers(y.size)
    initial = _initial_guess(theta, y)
    if initial is None:
        return MixtureFit(ok=False, reason="flat histogram")
    x0 = _clamp(np.array(initial), sigma_min)
    steps = 0
    first: tuple[np.ndarray, float] | None = None  # the EM step from x0, when already made
    if start is not None:
        alternative = _clamp(np.array(start, dtype=np.float64), sigma_min)
        from_alternative = _em_step(theta, y, alternative, sigma_min)
        first = _em_step(theta, y, x0, sigma_min)
        if from_alternative[1] > first[1]:
            x0, first = alternative, from_alternative
        steps += 2
    while steps < max_iter:
        x1, _ = first if first is not None else _em_step(theta, y, x0, sigma_min)
        first = None
        x2, ll1 = _em_step(theta, y, x1, sigma_min)
        steps += 2
        r = _delta(x1, x0)
        step = _delta(x2, x1)
        v = step - r
        if max(abs(float(step[0])), abs(float(step[1])), abs(float(step[2]))) < tol or x2[0] <= 0.0:
            x0 = x2
            break
        alpha = -math.sqrt(float(r @ r) / max(float(v @ v), 1e-300))
        alpha = min(alpha, -1.0)  # alpha = -1 is plain EM (x2)
        candidate = _clamp(x0 - 2.0 * alpha * r + alpha * alpha * v, sigma_min)
        x_next, ll_candidate = _em_step(theta, y, candidate, sigma_min)
        steps += 1
        # Keep the extrapolation only if it is at least as likely as the last EM iterate
        # (whose likelihood came free with the second step); else fall back to plain EM.
        x0 = _clamp(x_next, sigma_min) if ll_candidate >= ll1 else x2
    pi, mu, sigma = (float(v) for v in x0)
    if pi <= 0.0:
        sigma = math.pi / 2
    d_gof = gof_distance(y, pi, mu, sigma)
    return MixtureFit(
        ok=True,
        pi=pi,
        mu=mu,
        sigma=sigma,
        gof_d=d_gof,
        gof_ok=d_gof <= gof_dc,
        iterations=steps,
    )


def _delta(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a - b for parameter vectors, the mean's difference wrapped (pi-periodic)."""
    d = a - b
    d[1] = (float(a[1]) - float(b[1]) + math.pi / 2) % math.pi - math.pi / 2  # wrap_diff
    return d
