"""The calibration's confidence interval and plotted band sit around the estimate they qualify
(issue 13: a = 0.003204 with a 95 % CI of [0.002118, 0.003219], the band below the fit)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from daemon.offline.calibrate import (
    CalibrationPoints,
    ci_bounds,
    fit_calibration,
    fit_model,
)
from daemon.offline.report import fitted_labels


def tight_with_low_outliers(seed: int) -> tuple[np.ndarray, np.ndarray]:
    """8 intervals: 6 within 3 % of 0.0032·R, 2 far below (spray seen as rain)."""
    rng = np.random.default_rng(seed)
    r = rng.uniform(200, 2000, 8)
    y = 0.0032 * r * np.exp(rng.normal(0.0, 0.03, 8))
    y[:2] *= np.exp(-rng.uniform(1.5, 2.5, 2))
    return r, y


@pytest.mark.parametrize("seed", [10, 23, 62])
def test_interval_is_centred_on_its_estimate(seed):
    r, y = tight_with_low_outliers(seed)
    fit = fit_model(r, y, model="linear", n_boot=500, seed=0)
    assert fit.n == 8 and fit.n_outliers == 2
    assert fit.a == pytest.approx(0.0032, rel=0.03)
    # the raw percentiles, before ci_bounds widens them: the estimate must be inside, and not
    # at one edge (the old bootstrap gave log(a/lo) = 0.57 against log(hi/a) = 0.009)
    lo, hi = np.percentile(fit.boot_a[np.isfinite(fit.boot_a)], [2.5, 97.5])
    assert lo < fit.a < hi
    below, above = math.log(fit.a / lo), math.log(hi / fit.a)
    assert 1 / 3 < below / above < 3
    # six inliers within 3 %: the interval is a few per cent wide, not a factor of two
    assert fit.a_ci[1] / fit.a_ci[0] < 1.15


def test_plotted_band_contains_the_fit_and_matches_the_ci():
    r, y = tight_with_low_outliers(10)
    fit = fit_model(r, y, model="linear", n_boot=300, seed=0)
    grid = np.linspace(1.0, 2500.0, 50)
    lo, hi = fit.band(grid)
    fitted = fit.predict(grid)
    assert np.all(lo <= fitted) and np.all(fitted <= hi)
    np.testing.assert_allclose(lo, fit.a_ci[0] * grid, rtol=1e-9)
    np.testing.assert_allclose(hi, fit.a_ci[1] * grid, rtol=1e-9)


def test_ci_bounds_follow_the_level_and_contain_the_estimate():
    reps = np.arange(1.0, 101.0)
    assert ci_bounds(reps, 50.0, ci_level=0.9) == pytest.approx((5.95, 95.05))
    assert ci_bounds(reps, 200.0)[1] == 200.0
    assert ci_bounds(np.array([np.nan]), 3.0) == (3.0, 3.0)


def test_legend_counts_every_fitted_interval():
    r, y = tight_with_low_outliers(10)
    points = CalibrationPoints(r=r, rate_mm_h=y, r_all=r, rate_all_mm_h=y, n_dry=0, n_unseen=0)
    result, fits = fit_calibration(points, model="linear", n_boot=50)
    inliers, outliers = fitted_labels(fits["linear"])
    assert result["n"] == 8
    assert "n = 8" in inliers and "6" in inliers
    assert outliers is not None and "2" in outliers
