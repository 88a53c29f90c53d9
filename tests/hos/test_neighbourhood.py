"""Eq. 8 against the brightest background of each 3x3 neighbourhood (beyond the paper): what a
camera in the wind shows up to a pixel off is not a candidate, a streak still is."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from hos.background import neighbourhood_background, photometric_rule


def _scene(rng: np.random.Generator) -> np.ndarray:
    """A background with hard and soft edges of every orientation and some texture."""
    img = np.full((120, 160), 60, np.uint8)
    cv2.rectangle(img, (20, 15), (70, 100), 200, -1)
    cv2.line(img, (90, 10), (150, 110), 230, 3)
    cv2.circle(img, (120, 40), 18, 20, -1)
    img = cv2.GaussianBlur(img, (3, 3), 0.7)
    noise = rng.normal(0, 6, img.shape)
    return np.clip(img + cv2.GaussianBlur(noise, (5, 5), 1.5), 0, 255).astype(np.uint8)


def _shift(img: np.ndarray, dx: float, dy: float) -> np.ndarray:
    m = np.float32([[1, 0, dx], [0, 1, dy]])
    return cv2.warpAffine(img, m, img.shape[::-1], flags=cv2.INTER_LINEAR, borderMode=1)


@pytest.mark.parametrize("seed", range(4))
def test_a_frame_up_to_a_pixel_off_gives_no_candidate_against_the_neighbourhood(seed):
    rng = np.random.default_rng(seed)
    background = _scene(rng)
    everything = np.full(background.shape, 255, np.uint8)  # as if all were foreground
    inner = (slice(2, -2), slice(2, -2))  # the border repeats pixels that were never seen
    for _ in range(10):
        dx, dy = rng.uniform(-1.0, 1.0, 2)
        frame = _shift(background, dx, dy)
        plain = photometric_rule(frame, background, everything, c=3)[inner]
        held = photometric_rule(frame, neighbourhood_background(background), everything, c=3)
        assert plain.any(), (dx, dy)  # the edges light up against the pixel's own background
        assert not held[inner].any(), (dx, dy)


def test_a_streak_stays_a_candidate_against_the_neighbourhood() -> None:
    background = _scene(np.random.default_rng(9))
    frame = background.copy()
    cv2.line(frame, (40, 105), (44, 116), 255, 1)  # over the flat part
    cv2.line(frame, (140, 60), (143, 72), 255, 1)
    everything = np.full(background.shape, 255, np.uint8)
    streak = frame > background
    held = photometric_rule(frame, neighbourhood_background(background), everything, c=3)
    assert held[streak].mean() > 0.9
    assert not held[~streak].any()
