import cv2
import numpy as np
import pytest

from hos.motion import exposure_gain, global_translation


def _texture(seed=0, shape=(135, 240)):
    rng = np.random.default_rng(seed)
    img = cv2.GaussianBlur(rng.random(shape).astype(np.float32), (0, 0), 2.0)
    return (img - img.min()) / (img.max() - img.min()) * 200 + 20


@pytest.mark.parametrize("gradient", ["mean", "previous"])
@pytest.mark.parametrize("dx,dy", [(0.3, 0.0), (0.0, -0.5), (0.2, 0.25), (-0.7, 0.4)])
def test_recovers_subpixel_translation(dx, dy, gradient):
    a = _texture()
    m = np.float32([[1, 0, dx], [0, 1, dy]])
    b = cv2.warpAffine(a, m, a.shape[::-1], flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT)
    ex, ey = global_translation(a, b, gradient=gradient)
    assert ex == pytest.approx(dx, abs=0.08) and ey == pytest.approx(dy, abs=0.08)


def _specks(rng, shape, n=300):
    specks = np.zeros(shape, np.float32)
    specks[rng.integers(8, shape[0] - 8, n), rng.integers(8, shape[1] - 8, n)] = 150
    return cv2.GaussianBlur(specks, (0, 0), 1.2)


def _fallen(img, dy):
    m = np.float32([[1, 0, 0], [0, 1, dy]])
    return cv2.warpAffine(img, m, img.shape[::-1], flags=cv2.INTER_LINEAR)


@pytest.mark.parametrize("seed", [0, 1])
def test_flakes_only_the_frame_shows_are_texture_to_the_symmetric_fit_alone(seed):
    """Departure 27, the symmetric fit's way to err: over a nearly plain view, flakes that fell
    1.5 px since the last frame (whose foreground, grown by a pixel, is left out) are half out
    of that mask, and their leading edges are the strongest texture the mean of the two images
    has: the fit follows them. On the reference's gradients alone they are residual."""
    rng = np.random.default_rng(seed)
    shape = (135, 240)
    noise = rng.normal(0, 1, shape).astype(np.float32)
    view = 100 + 3 * cv2.GaussianBlur(noise, (0, 0), 1.5)
    was = _specks(rng, shape)
    exclude = cv2.dilate((was > 3).astype(np.uint8), np.ones((3, 3), np.uint8))
    frame = view + _fallen(was, 1.5) + rng.normal(0, 0.5, shape).astype(np.float32)
    ex, ey = global_translation(view, frame, exclude=exclude)
    assert ey > 1.0 and abs(ex) < 0.1
    ex, ey = global_translation(view, frame, exclude=exclude, gradient="previous")
    assert np.hypot(ex, ey) < 0.1


@pytest.mark.parametrize("seed", [0, 1])
def test_a_faint_copy_in_the_reference_is_magnified_by_the_template_fit(seed):
    """Departure 27, the template fit's way to err: specks that the reference holds at a
    tenth of their contrast (a reference that learnt them as they passed) and the frame shows
    a pixel further on read as a move of about ten pixels on the reference's gradients alone,
    about a third of one on the mean's. Hence the detector keeps the shorter of the two."""
    rng = np.random.default_rng(seed)
    shape = (135, 240)
    view = 100 + rng.normal(0, 0.5, shape).astype(np.float32)
    specks = _specks(rng, shape, 400)
    reference = view + 0.1 * specks
    frame = view + _fallen(specks, 1.0) + rng.normal(0, 0.5, shape).astype(np.float32)
    template = np.hypot(*global_translation(reference, frame, gradient="previous"))
    symmetric = np.hypot(*global_translation(reference, frame))
    assert template > 5.0
    assert symmetric < 0.5


def test_an_unknown_gradient_is_refused():
    a = _texture()
    with pytest.raises(ValueError, match="gradient"):
        global_translation(a, a, gradient="current")


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
