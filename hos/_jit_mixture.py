"""The EM of :mod:`hos.mixture`, compiled with numba: the same fit in one compiled call.

``fit_mixture`` makes a dozen numpy calls per EM step on a 180-bin histogram; most of its time is
call overhead. :func:`fit_mixture_jit` runs the whole fit (the start of section 4.2, EM of
eqs. 24-25 with SQUAREM, the goodness of fit of eq. 26) in one compiled function, written as plain
loops over the bins.

It is the same algorithm as the reference, step for step, but not the same floating-point
operations: sums and dot products are sequential here (numpy sums pairwise, BLAS in its own
order) and the normal CDF comes from libm's ``erfc`` (scipy's ``ndtr`` is cephes). The fits
agree to 1e-8 or better, with the same step counts (``tests/hos/test_jit_mixture.py`` holds them
to 1e-7), except on knife edges where the reference itself depends on the last bits: two equal
peaks a right angle apart, whose axial mean is an angle of rounding noise. This module imports
neither scipy nor :mod:`hos.mixture`.
"""

from __future__ import annotations

import math

import numpy as np

from ._numba import _njit
from .result import MixtureFit

__all__ = ["fit_mixture_jit"]

_OK, _EMPTY, _FLAT = 0, 1, 2
_REASONS = {_EMPTY: "empty histogram", _FLAT: "flat histogram"}
_HALF_PI = math.pi / 2
_SQRT2 = math.sqrt(2.0)


@_njit
def _wrap(d):
    """``d`` wrapped into [-pi/2, pi/2), pi-periodic (hos.angles.wrap_diff)."""
    return (d + _HALF_PI) % math.pi - _HALF_PI


@_njit
def _normal_cdf(x):
    """Standard normal CDF."""
    return 0.5 * math.erfc(-x / _SQRT2)


@_njit
def _median(y):
    """``np.median`` of a 1-D array without NaNs: the middle of a sorted copy, or the mean of the
    two middles."""
    s = np.sort(y)
    k = s.size // 2
    if s.size % 2:
        return s[k]
    return (s[k - 1] + s[k]) / 2.0


@_njit
def _gaussian_bin_mass(mu, sigma, cdf, mass):
    """Mass of the wrapped normal N(mu, sigma) over each bin of [0, pi), into ``mass`` (sums to 1).

    As ``hos.mixture.gaussian_bin_mass``: the normal CDF at the bin edges shifted by -2pi..2pi,
    summed over the shifts (the wrapping), then differenced. ``cdf`` is (bins + 1,) scratch.

    Beyond 9 sigma the CDF is not computed: above, it is 1 to the last bit; below, it is under
    1.2e-19, and left out (most edges of the shifted circles are there).
    """
    bins = mass.size
    width = math.pi / bins
    cdf[:] = 0.0
    for k in range(-2, 3):
        for j in range(bins + 1):
            z = (j * width + math.pi * k - mu) / sigma
            if z > 9.0:
                cdf[j] += 1.0
            elif z > -9.0:
                cdf[j] += _normal_cdf(z)
    total = 0.0
    for j in range(bins):
        mass[j] = cdf[j + 1] - cdf[j]
        total += mass[j]
    for j in range(bins):
        mass[j] /= total


@_njit
def _clamp(pi, mu, sigma, sigma_min):
    """Parameters back into their domain: pi in [1e-4, 1 - 1e-4], mu in [0, pi),
    sigma in [sigma_min, pi]."""
    return min(max(pi, 1e-4), 1.0 - 1e-4), mu % math.pi, min(max(sigma, sigma_min), math.pi)


@_njit
def _em_step(theta, y, pi, mu, sigma, sigma_min, cdf, w):
    """One EM step (eqs. 24-25) from (pi, mu, sigma); also the log-likelihood of (pi, mu, sigma).

    Returns the new (pi, mu, sigma) and the log-likelihood. ``cdf`` (bins + 1,) and ``w`` (bins,)
    are scratch.
    """
    bins = y.size
    _gaussian_bin_mass(mu, sigma, cdf, w)
    loglik = 0.0
    sw = 0.0
    for i in range(bins):
        rain = pi * w[i] * (bins / math.pi)  # eq. 23: the Gaussian's density over bin i ...
        total = rain + (1.0 - pi) / math.pi  # ... plus the uniform's
        loglik += y[i] * math.log(total)
        w[i] = y[i] * rain / total  # (1 - z_i) y_i, z_i of eq. 24
        sw += w[i]
    if sw <= 1e-12:
        return 0.0, mu, _HALF_PI, loglik
    shift = 0.0
    for i in range(bins):
        shift += w[i] * _wrap(theta[i] - mu)  # eq. 25, with wrapped distances
    shift /= sw
    var = 0.0
    for i in range(bins):
        d = _wrap(theta[i] - mu) - shift
        var += w[i] * d * d
    sigma_new = max(math.sqrt(var / sw), sigma_min)  # eq. 25
    return sw, (mu + shift) % math.pi, sigma_new, loglik  # eq. 25: Pi, mu, sigma


@_njit
def _fit(histogram, max_iter, tol, gof_dc, sigma_min, start):
    """The whole fit of :func:`fit_mixture_jit`, as ``hos.mixture.fit_mixture``; ``start`` is
    (3,) or (0,) for none. Returns (status, pi, mu, sigma, gof_d, gof_ok, iterations)."""
    nan = math.nan
    bins = histogram.size
    total = 0.0
    for i in range(bins):
        total += histogram[i]
    if not math.isfinite(total) or total <= 0.0:
        return _EMPTY, nan, nan, nan, nan, False, 0
    y = histogram / total
    theta = (np.arange(bins) + 0.5) * (math.pi / bins)  # bin centres
    cdf = np.empty(bins + 1)
    w = np.empty(bins)

    # Section 4.2: subtract the median, keep the upper part, take its mean, spread, surface.
    upper = np.maximum(y - _median(y), 0.0)
    u_total = upper.sum()
    if u_total <= 0.0:
        return _FLAT, nan, nan, nan, nan, False, 0
    s = 0.0
    c = 0.0
    for i in range(bins):  # axial mean: doubled angles
        s += upper[i] * math.sin(2.0 * theta[i])
        c += upper[i] * math.cos(2.0 * theta[i])
    mu0 = (0.5 * math.atan2(s, c)) % math.pi
    var = 0.0
    for i in range(bins):
        d = _wrap(theta[i] - mu0)
        var += upper[i] * d * d
    pi0, mu0, sigma0 = _clamp(u_total / y.sum(), mu0, math.sqrt(var / u_total), sigma_min)

    steps = 0
    have_first = False  # the EM step from x0, when already made
    first = (0.0, 0.0, 0.0, 0.0)
    if start.size == 3:  # the warm start, if it explains the histogram better
        a_pi, a_mu, a_sigma = _clamp(start[0], start[1], start[2], sigma_min)
        alt = _em_step(theta, y, a_pi, a_mu, a_sigma, sigma_min, cdf, w)
        first = _em_step(theta, y, pi0, mu0, sigma0, sigma_min, cdf, w)
        if alt[3] > first[3]:
            pi0, mu0, sigma0, first = a_pi, a_mu, a_sigma, alt
        have_first = True
        steps += 2
    while steps < max_iter:
        # SQUAREM (Varadhan & Roland, 2008): two EM steps, then an extrapolation.
        if have_first:
            pi1, mu1, sigma1 = first[0], first[1], first[2]
            have_first = False
        else:
            pi1, mu1, sigma1, _ = _em_step(theta, y, pi0, mu0, sigma0, sigma_min, cdf, w)
        pi2, mu2, sigma2, ll1 = _em_step(theta, y, pi1, mu1, sigma1, sigma_min, cdf, w)
        steps += 2
        r0, r1, r2 = pi1 - pi0, _wrap(mu1 - mu0), sigma1 - sigma0  # r = x1 - x0
        s0, s1, s2 = pi2 - pi1, _wrap(mu2 - mu1), sigma2 - sigma1  # the last EM step
        v0, v1, v2 = s0 - r0, s1 - r1, s2 - r2
        if max(abs(s0), abs(s1), abs(s2)) < tol or pi2 <= 0.0:
            pi0, mu0, sigma0 = pi2, mu2, sigma2
            break
        rr = r0 * r0 + r1 * r1 + r2 * r2
        vv = v0 * v0 + v1 * v1 + v2 * v2
        alpha = min(-math.sqrt(rr / max(vv, 1e-300)), -1.0)  # alpha = -1 is plain EM (x2)
        c_pi, c_mu, c_sigma = _clamp(
            pi0 - 2.0 * alpha * r0 + alpha * alpha * v0,
            mu0 - 2.0 * alpha * r1 + alpha * alpha * v1,
            sigma0 - 2.0 * alpha * r2 + alpha * alpha * v2,
            sigma_min,
        )
        n_pi, n_mu, n_sigma, ll_c = _em_step(theta, y, c_pi, c_mu, c_sigma, sigma_min, cdf, w)
        steps += 1
        # Keep the extrapolation only if it is at least as likely as the last EM iterate
        # (whose likelihood came free with the second step); else fall back to plain EM.
        if ll_c >= ll1:
            pi0, mu0, sigma0 = _clamp(n_pi, n_mu, n_sigma, sigma_min)
        else:
            pi0, mu0, sigma0 = pi2, mu2, sigma2
    if pi0 <= 0.0:
        sigma0 = _HALF_PI

    # Eq. 26: the largest gap between the observed and the fitted cumulative distributions.
    _gaussian_bin_mass(mu0, sigma0, cdf, w)
    y_total = y.sum()
    f_o = 0.0
    f_e = 0.0
    gof_d = 0.0
    for i in range(bins):
        f_o += y[i] / y_total
        f_e += pi0 * w[i] + (1.0 - pi0) / bins  # eq. 23, bin by bin
        gof_d = max(gof_d, abs(f_e - f_o))
    return _OK, pi0, mu0, sigma0, gof_d, gof_d <= gof_dc, steps


def fit_mixture_jit(
    histogram: np.ndarray,
    *,
    max_iter: int = 100,
    tol: float = 1e-4,
    gof_dc: float = 0.06,
    sigma_min: float = math.radians(1.0),
    start: tuple[float, float, float] | None = None,
) -> MixtureFit:
    """Fit eq. 23 to a HOS by EM (eqs. 24-25) and test the fit (eq. 26), compiled.

    A drop-in twin of :func:`hos.mixture.fit_mixture`: same arguments, same result to 1e-8
    (see the module's docstring). The first call in a process compiles, or loads the compiled
    code from numba's on-disk cache.

    Parameters
    ----------
    histogram : (bins,) non-negative, the HOS over [0, pi)
    max_iter : most EM steps (SQUAREM extrapolations count as one step each)
    tol : convergence threshold on the largest parameter change of an EM step (pi, and mu and
        sigma in radians)
    gof_dc : threshold on the goodness-of-fit distance D of eq. 26
    sigma_min : smallest standard deviation, radians
    start : optional (pi, mu, sigma), e.g. the previous frame's fit, used instead of the median
        rule of section 4.2 when it explains the histogram better (higher likelihood).

    Returns
    -------
    MixtureFit; ``ok`` is False (with ``reason``) when the histogram is empty or flat.
    ``gof_ok`` is ``gof_d <= gof_dc``. ``iterations`` counts EM steps.
    """
    y = np.asarray(histogram, dtype=np.float64)
    if y.ndim != 1 or y.size < 8:
        return MixtureFit(ok=False, reason="histogram must be 1-D with at least 8 bins")
    x0 = np.zeros(0) if start is None else np.asarray(start, dtype=np.float64).reshape(3)
    status, pi, mu, sigma, gof_d, gof_ok, iterations = _fit(
        np.ascontiguousarray(y), int(max_iter), float(tol), float(gof_dc), float(sigma_min), x0
    )
    if status != _OK:
        return MixtureFit(ok=False, reason=_REASONS[status])
    return MixtureFit(
        ok=True,
        pi=float(pi),
        mu=float(mu),
        sigma=float(sigma),
        gof_d=float(gof_d),
        gof_ok=bool(gof_ok),
        iterations=int(iterations),
    )
