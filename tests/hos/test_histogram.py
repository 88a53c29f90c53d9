import math

import numpy as np
import pytest

from hos.histogram import hog_histogram, hos_histogram, kernel_variance


def _sample(rng, n, mu_deg, sigma_deg):
    return np.mod(rng.normal(math.radians(mu_deg), math.radians(sigma_deg), n), math.pi)


def test_surface_is_the_sum_of_major_axes():
    rng = np.random.default_rng(0)
    theta = rng.uniform(0, math.pi, 300)
    dtheta = rng.uniform(0.01, 2.0, 300)
    a = rng.uniform(1, 10, 300)
    for method in ("fast", "exact"):
        h = hos_histogram(theta, dtheta, a, method=method)
        assert h.shape == (180,)
        assert h.sum() == pytest.approx(a.sum(), rel=1e-9)
        assert (h >= 0).all()


@pytest.mark.parametrize("width_deg", [0.5, 2.0, 8.0, 40.0])
def test_fast_matches_exact(width_deg):
    rng = np.random.default_rng(1)
    theta = _sample(rng, 500, 70, 12)
    dtheta = np.full(500, math.radians(width_deg)) * rng.uniform(0.8, 1.25, 500)
    a = rng.uniform(2, 8, 500)
    fast = hos_histogram(theta, dtheta, a)
    exact = hos_histogram(theta, dtheta, a, method="exact")
    if width_deg >= 2.0:  # narrower kernels are point-sampled by "exact": both are approximations
        assert np.abs(fast - exact).max() < 0.05 * exact.max()
    # The statistics that the EM reads are the same to a small fraction of a degree.
    c = (np.arange(180) + 0.5) * math.pi / 180
    pf, pe = fast / fast.sum(), exact / exact.sum()
    mf, me = (pf * c).sum(), (pe * c).sum()
    assert abs(mf - me) < math.radians(0.2)
    sf, se = math.sqrt((pf * (c - mf) ** 2).sum()), math.sqrt((pe * (c - me) ** 2).sum())
    assert abs(sf - se) < math.radians(0.3)


def test_wraps_around_zero_and_pi():
    # Streaks at 1 degree and 179 degrees are both nearly horizontal: one peak across the seam.
    theta = np.radians([1.0, 179.0])
    h = hos_histogram(theta, np.radians([3.0, 3.0]), np.ones(2), method="exact")
    assert h[0] > h[90] * 100 and h[179] > h[90] * 100
    assert h[:10].sum() == pytest.approx(h[-10:].sum(), rel=0.05)


@pytest.mark.parametrize("shift_deg", [30, 75, 110])
def test_rotating_streaks_moves_the_peak(shift_deg):
    rng = np.random.default_rng(2)
    theta = _sample(rng, 400, 40, 6)
    dtheta = np.full(400, math.radians(2))
    a = np.ones(400)
    h0 = hos_histogram(theta, dtheta, a)
    h1 = hos_histogram(theta + math.radians(shift_deg), dtheta, a)
    assert np.allclose(np.roll(h0, shift_deg), h1, atol=0.02 * h0.max())


def test_kernel_variance_adds_to_the_histogram_variance():
    rng = np.random.default_rng(4)
    theta = _sample(rng, 2000, 90, 8)
    dtheta = rng.uniform(0.02, 0.12, 2000)
    a = rng.uniform(1, 5, 2000)
    h = hos_histogram(theta, dtheta, a, method="exact")
    c = (np.arange(180) + 0.5) * math.pi / 180
    p = h / h.sum()
    var_h = (p * (c - (p * c).sum()) ** 2).sum()
    var_theta = np.average((theta - np.average(theta, weights=a)) ** 2, weights=a)
    assert var_h == pytest.approx(var_theta + kernel_variance(dtheta, a), rel=0.03)


def test_hos_beats_hog_on_the_same_streaks():
    """Section 3.4: moments of blobs estimate the rain orientation better than gradients."""
    import cv2

    from hos.blobs import find_blobs
    from hos.mixture import fit_mixture
    from hos.moments import orientation_uncertainty

    rng = np.random.default_rng(5)
    img = np.zeros((240, 320), np.float32)
    for _ in range(150):
        x, y = rng.uniform(10, 310), rng.uniform(10, 230)
        t = rng.normal(math.radians(60), math.radians(5))
        p1 = (int(x + 12 * math.cos(t)), int(y + 12 * math.sin(t)))
        cv2.line(img, (int(x), int(y)), p1, 60, 1, cv2.LINE_AA)
    gray = img.astype(np.uint8)
    mask = gray > 3
    hog = fit_mixture(hog_histogram(gray, mask))
    m = find_blobs(mask.astype(np.uint8) * 255).moments
    dth = orientation_uncertainty(m.m20[1:], m.m11[1:], m.m02[1:], dm=0.5, lo=0.01, hi=1.5)
    hos = fit_mixture(hos_histogram(m.theta[1:], dth, m.a[1:]))
    hos_err = abs(math.degrees(hos.mu) - 60)
    hog_err = abs(math.degrees(hog.mu) - 60)
    assert hos_err < 2.0
    assert hog_err > hos_err
