"""The compiled camera-motion estimate agrees with hos.motion.global_translation."""

import cv2
import numpy as np
import pytest

from hos import _jit_motion
from hos._jit_motion import global_translation_jit
from hos.motion import global_translation

# Float64 sums in another order than numpy's: not the same bits, far below the 0.5 px at which
# the detector calls a frame moved.
ATOL_PX = 1e-4

SIZES = [(180, 320), (135, 240), (68, 120)]  # (h, w)
SHIFTS = [  # (dx, dy) px, from 0 to 1.5 in x and y
    (0.0, 0.0),
    (0.1, 0.0),
    (0.0, 0.25),
    (0.5, 0.5),
    (0.8, -0.3),
    (-1.0, 0.6),
    (1.5, 0.0),
    (0.0, -1.5),
    (1.2, 1.5),
    (-0.35, -1.1),
]


def _texture(seed, shape):
    rng = np.random.default_rng(seed)
    img = cv2.GaussianBlur(rng.random(shape).astype(np.float32), (0, 0), 2.0)
    return (img - img.min()) / (img.max() - img.min()) * 200 + 20


def _shifted(img, dx, dy):
    m = np.float32([[1, 0, dx], [0, 1, dy]])
    flags, border = cv2.INTER_LINEAR, cv2.BORDER_REFLECT
    return cv2.warpAffine(img, m, img.shape[::-1], flags=flags, borderMode=border)


def _assert_agrees(previous, current, **kwargs):
    expected = global_translation(previous, current, **kwargs)
    result = global_translation_jit(previous, current, **kwargs)
    assert isinstance(result[0], float) and isinstance(result[1], float)
    if expected == (0.0, 0.0):
        assert result == (0.0, 0.0)  # the same decision, not only a small shift
    else:
        assert result == pytest.approx(expected, abs=ATOL_PX, rel=0)
    return result


@pytest.mark.parametrize("gradient", ["mean", "previous"])
@pytest.mark.parametrize("shape", SIZES)
@pytest.mark.parametrize("dx,dy", SHIFTS)
def test_agrees_with_reference_on_a_shifted_texture(shape, dx, dy, gradient):
    rng = np.random.default_rng(11)
    a = _texture(2, shape)
    b = _shifted(a, dx, dy) + rng.normal(0, 1.0, shape).astype(np.float32)
    result = _assert_agrees(a, b, gradient=gradient)
    if (dx, dy) != (0.0, 0.0):
        assert result != (0.0, 0.0)  # the whole fit ran, to the significance test


def test_agrees_with_reference_on_a_small_image_fitting_all_pixels():
    a = _texture(0, (30, 40))
    b = _shifted(a, 0.4, -0.3)
    # 22x32 px inside the border, fewer than 500 of them above the mean gradient: all are fitted
    gx = cv2.Sobel(0.5 * (a + b), cv2.CV_32F, 1, 0)[4:-4, 4:-4]
    gy = cv2.Sobel(0.5 * (a + b), cv2.CV_32F, 0, 1)[4:-4, 4:-4]
    g2 = gx * gx + gy * gy
    assert np.count_nonzero(g2 > g2.mean()) < 500
    ex, ey = _assert_agrees(a, b)
    assert ex == pytest.approx(0.4, abs=0.08) and ey == pytest.approx(-0.3, abs=0.08)


@pytest.mark.parametrize("dx,dy", [(0.3, 0.0), (0.0, -0.5), (0.2, 0.25), (-0.7, 0.4)])
def test_recovers_subpixel_translation(dx, dy):  # as tests/hos/test_motion.py
    a = _texture(0, (135, 240))
    ex, ey = global_translation_jit(a, _shifted(a, dx, dy))
    assert ex == pytest.approx(dx, abs=0.08) and ey == pytest.approx(dy, abs=0.08)


@pytest.mark.parametrize("shape", [*SIZES, (30, 40), (9, 9)])
def test_flat_images_are_still(shape):
    a = np.full(shape, 100.0, np.float32)
    assert _assert_agrees(a, a) == (0.0, 0.0)
    assert _assert_agrees(a, a + np.float32(30.0)) == (0.0, 0.0)  # a brightness step


@pytest.mark.parametrize("shape", [(8, 8), (8, 120), (3, 2)])
def test_nothing_inside_the_border_is_still(shape):
    # (the reference gives (0, 0) too, with numpy's warning about the mean of an empty slice)
    rng = np.random.default_rng(3)
    a, b = (rng.random(shape).astype(np.float32) for _ in range(2))
    assert global_translation_jit(a, b) == (0.0, 0.0)


@pytest.mark.parametrize("shape", SIZES)
def test_noise_alone_is_insignificant(shape):
    rng = np.random.default_rng(7)
    a = (100 + rng.normal(0, 2, shape)).astype(np.float32)
    b = (100 + rng.normal(0, 2, shape)).astype(np.float32)
    assert _assert_agrees(a, b) == (0.0, 0.0)
    smooth = cv2.GaussianBlur(rng.random(shape).astype(np.float32), (0, 0), 8.0) * 50 + 100
    a = smooth + rng.normal(0, 2, shape).astype(np.float32)
    b = smooth + rng.normal(0, 2, shape).astype(np.float32)
    assert _assert_agrees(a, b) == (0.0, 0.0)
    # without the significance test, the same fit: a small shift, as the reference's
    assert _assert_agrees(a, b, significance=0.0) != (0.0, 0.0)


def test_significance_is_a_threshold_on_the_shift():
    rng = np.random.default_rng(13)
    a = _texture(1, (135, 240))
    b = _shifted(a, 0.05, 0.0) + rng.normal(0, 2.0, a.shape).astype(np.float32)
    assert _assert_agrees(a, b, significance=4.0) != (0.0, 0.0)
    assert _assert_agrees(a, b, significance=1e4) == (0.0, 0.0)


@pytest.mark.parametrize("shape", SIZES)
@pytest.mark.parametrize("noise", [0.0, 2.0])
def test_a_moving_object_over_a_still_scene_is_still(shape, noise):
    rng = np.random.default_rng(5)
    h, w = shape
    y0, x0, rh, rw = h // 3, w // 3, h // 5, w // 6
    a = _texture(3, shape) + rng.normal(0, noise, shape).astype(np.float32)
    b = _texture(3, shape) + rng.normal(0, noise, shape).astype(np.float32)
    a[y0 : y0 + rh, x0 : x0 + rw] = 250.0  # a bright rectangle moved by 10 px
    b[y0 : y0 + rh, x0 + 10 : x0 + 10 + rw] = 250.0
    ex, ey = _assert_agrees(a, b)
    assert abs(ex) < 0.1 and abs(ey) < 0.1


def test_inputs_are_not_modified_and_shapes_are_checked():
    a = _texture(0, (68, 120))
    b = _shifted(a, 0.5, 0.0)
    a0, b0 = a.copy(), b.copy()
    global_translation_jit(a, b)
    assert np.array_equal(a, a0) and np.array_equal(b, b0)
    with pytest.raises(ValueError, match="shape"):
        global_translation_jit(a, b[:, :-1])


@pytest.mark.skipif(not _jit_motion.ENABLED, reason="the reference takes float32 only")
def test_other_dtypes_are_converted():
    a = _texture(0, (68, 120))
    b = _shifted(a, 0.5, 0.0)
    expected = global_translation_jit(a, b)
    assert global_translation_jit(a.astype(np.float64), b.astype(np.float64)) == expected


def test_falls_back_to_the_reference_without_numba(monkeypatch):
    a = _texture(0, (68, 120))
    b = _shifted(a, 0.5, 0.0)
    monkeypatch.setattr(_jit_motion, "ENABLED", False)
    assert global_translation_jit(a, b) == global_translation(a, b)


@pytest.mark.parametrize("dx,dy", [(0.0, 0.0), (0.4, -0.2), (-1.0, 0.6)])
def test_agrees_with_reference_when_pixels_are_excluded(dx, dy):
    rng = np.random.default_rng(5)
    a = _texture(4, (135, 240))
    b = _shifted(a, dx, dy) + rng.normal(0, 1.0, a.shape).astype(np.float32)
    b[30:90, 40:120] = rng.uniform(0, 255, (60, 80)).astype(np.float32)  # something moved
    exclude = np.zeros(a.shape, bool)
    exclude[28:92, 38:122] = True
    for mask in (exclude, exclude.astype(np.uint8)):
        _assert_agrees(a, b, exclude=mask)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_agrees_with_reference_on_the_gradient_of_previous_alone(seed):
    """``gradient="previous"`` (departure 27): the same fit as the reference over a plain view
    with specks in one image only, and over a shifted texture with pixels left out."""
    rng = np.random.default_rng(seed)
    shape = (135, 240)
    view = 100 + 3 * cv2.GaussianBlur(rng.normal(0, 1, shape).astype(np.float32), (0, 0), 1.5)
    specks = np.zeros(shape, np.float32)
    specks[rng.integers(8, 127, 300), rng.integers(8, 232, 300)] = 150
    frame = view + cv2.GaussianBlur(specks, (0, 0), 1.2)
    _assert_agrees(view, frame, gradient="previous")
    _assert_agrees(frame, view, gradient="previous")
    a = _texture(seed, shape)
    b = _shifted(a, 0.6, -0.4) + rng.normal(0, 1.0, shape).astype(np.float32)
    exclude = np.zeros(shape, bool)
    exclude[30:90, 40:120] = True
    ex, ey = _assert_agrees(a, b, gradient="previous", exclude=exclude)
    assert ex == pytest.approx(0.6, abs=0.08) and ey == pytest.approx(-0.4, abs=0.08)


def test_an_unknown_gradient_is_refused():
    a = _texture(0, (68, 120))
    with pytest.raises(ValueError, match="gradient"):
        global_translation_jit(a, a, gradient="current")
