import math

import cv2
import numpy as np
import pytest

from hos.blobs import find_blobs, thin_rule
from hos.moments import blob_moments, orientation_uncertainty


def _line_mask(theta_deg: float, length: int = 21, size: int = 64) -> np.ndarray:
    mask = np.zeros((size, size), np.uint8)
    c = size / 2
    t = math.radians(theta_deg)
    dx, dy = 0.5 * length * math.cos(t), 0.5 * length * math.sin(t)
    p0 = (round((c - dx) * 16), round((c - dy) * 16))
    p1 = (round((c + dx) * 16), round((c + dy) * 16))
    cv2.line(mask, p0, p1, 255, 1, cv2.LINE_8, shift=4)
    return mask


def test_moments_of_a_rectangle_by_hand():
    # A 3x7 block (3 wide in x, 7 tall in y): m20 = (3^2 - 1)/12 + 1/12, m02 = (7^2 - 1)/12 + 1/12.
    ys, xs = np.mgrid[10:17, 20:23]
    labels = np.ones(xs.size, int)
    m = blob_moments(xs.ravel(), ys.ravel(), labels, 2)
    assert m.area[1] == 21
    assert m.x0[1] == pytest.approx(21.0) and m.y0[1] == pytest.approx(13.0)
    assert m.m20[1] == pytest.approx(9 / 12) and m.m02[1] == pytest.approx(49 / 12)
    assert m.m11[1] == pytest.approx(0.0)
    assert math.degrees(m.theta[1]) == pytest.approx(90.0)  # vertical: the contract's 90 degrees
    assert m.a[1] == pytest.approx(2 * math.sqrt(49 / 12))  # eq. 15
    assert m.b[1] == pytest.approx(2 * math.sqrt(9 / 12))  # eq. 16


@pytest.mark.parametrize("theta", [0.0, 30.0, 45.0, 60.0, 90.0, 120.0, 135.0, 170.0])
def test_orientation_convention_on_drawn_lines(theta):
    blobs = find_blobs(_line_mask(theta))
    assert blobs.n_labels == 2
    got = math.degrees(blobs.moments.theta[1])
    err = (got - theta + 90.0) % 180.0 - 90.0
    assert abs(err) < 3.0, (theta, got)


def test_45_runs_top_left_to_bottom_right():
    mask = np.zeros((20, 20), np.uint8)
    for i in range(10):
        mask[5 + i, 5 + i] = 255  # x and y grow together: top-left to bottom-right
    m = find_blobs(mask).moments
    assert math.degrees(m.theta[1]) == pytest.approx(45.0, abs=1e-6)
    mask = np.fliplr(mask).copy()
    assert math.degrees(find_blobs(mask).moments.theta[1]) == pytest.approx(135.0, abs=1e-6)


def test_many_blobs_match_one_at_a_time():
    rng = np.random.default_rng(3)
    mask = np.zeros((200, 300), np.uint8)
    for _ in range(40):
        x, y = rng.integers(10, 290), rng.integers(10, 190)
        t = rng.uniform(0, math.pi)
        cv2.line(mask, (int(x), int(y)), (int(x + 8 * math.cos(t)), int(y + 8 * math.sin(t))), 255)
    blobs = find_blobs(mask)
    for k in range(1, blobs.n_labels):
        ys, xs = np.nonzero(blobs.labels == k)
        single = blob_moments(xs, ys, np.ones(xs.size, int), 2)
        assert blobs.moments.theta[k] == pytest.approx(single.theta[1], abs=1e-9)
        assert blobs.moments.m02[k] == pytest.approx(single.m02[1])


def test_translation_invariance_at_large_coordinates():
    ys, xs = np.nonzero(_line_mask(70.0))
    a = blob_moments(xs, ys, np.ones(xs.size, int), 2)
    b = blob_moments(xs + 4000, ys + 3000, np.ones(xs.size, int), 2)
    assert b.theta[1] == pytest.approx(a.theta[1], abs=1e-12)
    assert b.m11[1] == pytest.approx(a.m11[1], abs=1e-9)


def test_uncertainty_eq19_small_for_long_large_for_round():
    # Vertical streak of length L, width 1: m02 - m20 ~ L^2/12, m11 = 0 -> dtheta = dm / (m02-m20)
    lo, hi = math.radians(0.01), math.radians(90)
    d = orientation_uncertainty(
        np.array([0.1]), np.array([0.0]), np.array([10.1]), dm=0.5, lo=lo, hi=hi
    )
    assert d[0] == pytest.approx(0.5 / 10.0)
    round_blob = orientation_uncertainty(
        np.array([2.0]), np.array([0.0]), np.array([2.0]), dm=0.5, lo=lo, hi=hi
    )
    assert round_blob[0] == pytest.approx(hi)  # no orientation at all: the flattest vote
    # Eq. 19 against a numerical propagation of the error in eq. 14 (dm on each moment).
    m20, m11, m02, dm = 1.0, 0.7, 5.0, 1e-4
    th = lambda a, b, c: 0.5 * math.atan2(2 * b, a - c)  # noqa: E731
    grads = [
        (th(m20 + dm, m11, m02) - th(m20, m11, m02)),
        (th(m20, m11 + dm, m02) - th(m20, m11, m02)),
        (th(m20, m11, m02 + dm) - th(m20, m11, m02)),
    ]
    numeric = math.sqrt(sum(g * g for g in grads))
    analytic = orientation_uncertainty(
        np.array([m20]), np.array([m11]), np.array([m02]), dm=dm, lo=0, hi=10
    )[0]
    assert analytic == pytest.approx(numeric, rel=1e-3)


def _blob_of(mask: np.ndarray):
    blobs = find_blobs(mask.astype(np.uint8) * 255)
    return blobs.moments.area[1:], blobs.moments.a[1:]


@pytest.mark.parametrize("angle", [0.0, 30.0, 80.0, 90.0, 135.0])
def test_thin_rule_keeps_a_long_line_at_any_orientation(angle):
    """A one-pixel line 60 pixels long, at any orientation, is thin: its area over its length
    (sqrt(3) a) is about a pixel."""
    mask = np.zeros((120, 120), np.uint8)
    t = math.radians(angle)
    dx, dy = 30 * math.cos(t), 30 * math.sin(t)
    cv2.line(mask, (round(60 - dx), round(60 - dy)), (round(60 + dx), round(60 + dy)), 1, 1)
    area, a = _blob_of(mask)
    assert area[0] / (math.sqrt(3.0) * a[0]) == pytest.approx(1.0, abs=0.45)
    assert thin_rule(area, a, min_area=25, max_area=100, width=2.5).tolist() == [True]


def test_thin_rule_refuses_wide_blobs_and_the_sizes_outside_its_range():
    """A 6x10 body is too wide, a 2x40 bar is thin; a thin blob under ``min_area`` (the size
    rule's own) or over ``max_area`` is not the thin rule's; a blob without moments (NaN) is
    refused."""
    mask = np.zeros((80, 80), np.uint8)
    mask[5:15, 5:11] = 1  # 60 pixels, 6 wide
    mask[20:60, 30:32] = 1  # 80 pixels, 2 wide
    area, a = _blob_of(mask)
    assert thin_rule(area, a, min_area=25, max_area=100, width=2.5).tolist() == [False, True]
    assert thin_rule(area, a, min_area=25, max_area=70, width=2.5).tolist() == [False, False]
    assert thin_rule(area, a, min_area=25, max_area=100, width=1.5).tolist() == [False, False]
    nan = np.array([np.nan])
    assert thin_rule(np.array([50.0]), nan, min_area=25, max_area=100, width=2.5).tolist() == [
        False
    ]
