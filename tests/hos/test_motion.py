import cv2
import numpy as np
import pytest

from hos.motion import exposure_gain, global_translation


def _texture(seed=0, shape=(135, 240)):
    rng = np.random.default_rng(seed)
    img = cv2.GaussianBlur(rng.random(shape).astype(np.float32), (0, 0), 2.0)
    return (img - img.min()) / (img.max() - img.min()) * 200 + 20


@pytest.mark.parametrize("dx,dy", [(0.3, 0.0), (0.0, -0.5), (0.2, 0.25), (-0.7, 0.4)])
def test_recovers_subpixel_translation(dx, dy):
    a = _texture()
    m = np.float32([[1, 0, dx], [0, 1, dy]])
    b = cv2.warpAffine(a, m, a.shape[::-1], flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT)
    ex, ey = global_translation(a, b)
    assert ex == pytest.approx(dx, abs=0.08) and ey == pytest.approx(dy, abs=0.08)


def test_still_scene_with_noise_and_a_moving_object_is_still():
    rng = np.random.default_rng(1)
    a = _texture()
    b = a + rng.normal(0, 2, a.shape).astype(np.float32)
    b[40:70, 100:160] = np.roll(a[40:70, 100:160], 6, axis=1)  # a car moves, the camera does not
    ex, ey = global_translation(a, b)
    assert abs(ex) < 0.1 and abs(ey) < 0.1


def test_exposure_gain_is_the_global_ratio():
    bg = _texture()
    assert exposure_gain(bg / 1.2, bg) == pytest.approx(1.2, rel=0.01)
    assert exposure_gain(bg, bg) == pytest.approx(1.0)


def test_what_moved_is_left_out_of_the_fit():
    """Traffic filling most of the frame, moving by half a pixel, takes the plain fit with it;
    left out, the camera is still."""
    a = _texture(3)
    m = np.float32([[1, 0, 0.5], [0, 1, 0]])
    moved = cv2.warpAffine(
        a, m, a.shape[::-1], flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT
    )
    b = a.copy()
    b[10:125, 10:200] = moved[10:125, 10:200]  # 67 % of the image moves, the camera does not
    exclude = np.zeros(a.shape, np.uint8)
    exclude[8:127, 8:202] = 1
    pulled = np.hypot(*global_translation(a, b, significance=0.0))
    ex, ey = global_translation(a, b, exclude=exclude)
    assert pulled > 0.3
    assert abs(ex) < 0.02 and abs(ey) < 0.02
    # the camera's own motion is still measured around an excluded region
    m = np.float32([[1, 0, 0.4], [0, 1, -0.2]])
    c = cv2.warpAffine(b, m, a.shape[::-1], flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT)
    ex, ey = global_translation(a, c, exclude=exclude)
    assert ex == pytest.approx(0.4, abs=0.08) and ey == pytest.approx(-0.2, abs=0.08)
