import math

import numpy as np
import pytest

from drivers.simulator import Scene, SceneParams, StreakParams
from hos import BlobClass, HosDetector
from hos.overlay import CLASS_COLOURS, draw_overlay


@pytest.fixture(scope="module")
def rainy_result():
    scene = Scene(640, 360, seed=5, params=SceneParams(rain=StreakParams(mu_deg=70)))
    det = HosDetector()
    for i in range(70):
        gray, _ = scene.frame(i)
        result = det.process(gray, i / 25)
    assert result.rain
    return gray, result


def test_blobs_take_their_class_colour(rainy_result):
    gray, result = rainy_result
    before = gray.copy()
    out = draw_overlay(gray, result)
    assert out.shape == (*gray.shape, 3) and out.dtype == np.uint8
    assert np.array_equal(gray, before)  # the input is never modified
    rain_pixels = result.blob_class[result.label_image()] == BlobClass.RAIN
    assert rain_pixels.sum() > 100
    ys, xs = np.nonzero(rain_pixels)
    w = gray.shape[1]
    outside_inset = (xs < 0.6 * w) & (ys > 30)  # away from the HOS panel and the text line
    colours = out[ys[outside_inset], xs[outside_inset]]
    green = np.array(CLASS_COLOURS[BlobClass.RAIN])
    assert np.mean(np.all(colours == green, axis=1)) > 0.95


def test_without_fit_or_labels_it_still_draws():
    scene = Scene(320, 180, seed=1)
    gray, _ = scene.frame(0)
    result = HosDetector().process(gray, 0.0)  # first frame: no fit
    assert not result.fit.ok
    out = draw_overlay(gray, result)
    assert out.shape == (180, 320, 3)
    result.labels = result.pixel_index = None
    assert result.label_image() is None
    assert draw_overlay(gray, result).shape == (180, 320, 3)
    assert not math.isnan(float(out.mean()))
