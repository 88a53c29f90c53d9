"""The spread of a wide population's blobs over the view (``decision.spread_*``, beyond the
paper): about 1 for blobs dropped at random, far less for blobs gathered in one place, and
measured over the region of interest's box when there is one."""

from __future__ import annotations

import numpy as np
import pytest

from hos import HosDetector


def _detector(shape, roi=None):
    det = HosDetector(roi=roi)
    det._setup(shape)
    return det


@pytest.mark.parametrize("n", [12, 40, 200])
def test_blobs_at_random_are_spread(n):
    rng = np.random.default_rng(n)
    det = _detector((240, 320))
    spread = [det._spread(rng.uniform(0, 320, n), rng.uniform(0, 240, n)) for _ in range(50)]
    assert 0.85 < np.mean(spread) < 1.15
    assert np.percentile(spread, 5) > 0.6


def test_blobs_in_one_corner_are_not():
    rng = np.random.default_rng(1)
    det = _detector((240, 320))
    assert det._spread(rng.uniform(0, 80, 40), rng.uniform(0, 60, 40)) < 0.1
    assert det._spread(np.zeros(0), np.zeros(0)) == 0.0


def test_the_grid_covers_the_region_of_interest():
    """Blobs at random over a region of interest in the frame's right half are spread; over
    the whole frame they would occupy half of the cells."""
    rng = np.random.default_rng(2)
    roi = np.zeros((240, 320), np.uint8)
    roi[:, 160:] = 1
    x, y = rng.uniform(160, 320, 100), rng.uniform(0, 240, 100)
    assert _detector((240, 320), roi)._spread(x, y) > 0.9
    assert _detector((240, 320))._spread(x, y) < 0.6
