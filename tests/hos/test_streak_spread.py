"""The streaks' own spread (``decision.kernel_corrected``, beyond the paper): the fitted sigma
of a HOS with the width of its voting kernels (eq. 19) taken out, against streaks drawn with a
known spread."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hos.histogram import hos_histogram
from hos.mixture import fit_mixture
from hos.moments import orientation_uncertainty
from hos.pipeline import streak_spread


def _population(rng, n, length, spread_deg, noise=0):
    """Orientations, eq. 19 uncertainties and weights of ``n`` one-pixel-wide streaks of
    ``length`` pixels about the vertical, spread by ``spread_deg``, and ``noise`` more at
    uniform orientations."""
    theta = np.concatenate(
        (
            rng.normal(math.pi / 2, math.radians(spread_deg), n),
            rng.uniform(0, math.pi, noise),
        )
    )
    # the second moments of a segment of `length` pixels, one pixel wide, at angle theta
    along, across = (length * length - 1) / 12.0, 1.0 / 12.0
    c, s = np.cos(theta), np.sin(theta)
    m20 = along * c * c + across * s * s
    m02 = along * s * s + across * c * c
    m11 = (along - across) * c * s
    dtheta = orientation_uncertainty(m20, m11, m02, dm=0.4, lo=math.radians(0.5), hi=math.pi / 2)
    weight = np.full(theta.size, length / 2.0)
    return np.stack((np.mod(theta, math.pi), dtheta, weight))


def _fit(votes):
    hist = hos_histogram(votes[0], votes[1], votes[2])
    fit = fit_mixture(hist, gof_dc=1.0)
    assert fit.ok
    return fit


@pytest.mark.parametrize("length, spread", [(4, 8.0), (4, 15.0), (5, 5.0), (20, 10.0), (20, 25.0)])
def test_the_streaks_spread_is_found_under_the_kernels(length, spread):
    rng = np.random.default_rng([length, int(spread)])
    votes = _population(rng, 400, length, spread, noise=100)
    fit = _fit(votes)
    found = math.degrees(streak_spread(fit, votes))
    assert found == pytest.approx(spread, abs=max(3.0, 0.25 * spread))
    # and where the kernels are wide, the fitted sigma is not the streaks' spread
    if length <= 5:
        assert math.degrees(fit.sigma) > spread + 8.0


def test_long_streaks_keep_their_fitted_sigma():
    """Kernels of a degree or two change nothing a limit of 20 degrees can see."""
    rng = np.random.default_rng(7)
    votes = _population(rng, 300, 30, 18.0, noise=50)
    fit = _fit(votes)
    assert math.degrees(fit.sigma - streak_spread(fit, votes)) < 0.5


def test_kernels_wider_than_the_gaussian_leave_it_alone():
    """Blobs whose vote is flatter than the Gaussian (two-pixel blobs vote over 90 degrees)
    are the uniform part's: they take nothing from sigma."""
    rng = np.random.default_rng(3)
    votes = _population(rng, 300, 30, 12.0)
    flat = np.stack((rng.uniform(0, math.pi, 200), np.full(200, math.pi / 2), np.ones(200)))
    both = np.concatenate((votes, flat), axis=1)
    fit = _fit(both)
    assert streak_spread(fit, both) == pytest.approx(streak_spread(fit, votes), abs=1e-3)
    assert streak_spread(fit, np.zeros((3, 0))) == fit.sigma
