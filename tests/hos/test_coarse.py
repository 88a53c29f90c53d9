"""``robustness.motion_coarse`` (docs/method.md, departure 35): an offset beyond the
linearised fit's reach is found on a coarser image, and taken only where it explains the
frame clearly better."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from drivers.simulator.precipitation import StreakParams, render_streaks
from hos import DetectorParams, HosDetector, State
from hos.background import translate
from hos.pipeline import TexturePoints, offset_mismatch, texture_mask

KNOCK = range(200, 206)  # frames the camera is knocked 8 px aside, then springs back


def _knocked(coarse: int, streaks: int) -> list:
    """A textured 320x240 view, rain of ``streaks`` streaks a frame from frame 80 (none: 0),
    the camera knocked 8 px aside over frames 200-205. The results of the knocked frames."""
    rng = np.random.default_rng(11)
    base = cv2.GaussianBlur(rng.uniform(50, 130, (260, 340)).astype(np.float32), (0, 0), 3)
    det = HosDetector(DetectorParams.from_dict({"robustness": {"motion_coarse": coarse}}))
    rain = StreakParams(count=max(streaks, 1), brightness=30.0, length_px=10.0, mu_deg=85.0)
    out = []
    for i in range(KNOCK.stop):
        dx = 8.0 if i in KNOCK else 0.0
        f = translate(base, dx, 0.0)[10:250, 10:330] + rng.normal(0, 1.5, (240, 320))
        if streaks and i >= 80:
            f += render_streaks((240, 320), rain, rng).layer
        r = det.process(np.clip(f, 0, 255).astype(np.uint8), i / 25)
        if i in KNOCK:
            out.append(r)
    return out


@pytest.mark.parametrize("streaks", [0, 80])
def test_a_knock_of_8_px_is_read_as_8_px_and_is_unstable(streaks: int) -> None:
    knocked = _knocked(4, streaks)
    assert sum(abs(r.motion_px - 8.0) < 0.5 for r in knocked) >= 5
    assert all(r.state == State.UNSTABLE for r in knocked)


def test_without_the_coarse_fit_rain_hides_the_knock() -> None:
    """The linearised fit alone under-reads 8 px as about 2 (under ``motion_frame_px``): in
    rain the knocked frames are judged with the view 6 px off; clear, the first frame reads
    enough to be ``unstable``."""
    knocked = _knocked(0, 80)
    assert all(r.motion_px < 2.5 for r in knocked)
    assert all(r.state == State.OK for r in knocked)
    assert _knocked(0, 0)[0].state == State.UNSTABLE


def test_the_mismatch_is_least_at_the_true_offset() -> None:
    rng = np.random.default_rng(4)
    ref = cv2.GaussianBlur(rng.uniform(40, 160, (135, 240)).astype(np.float32), (0, 0), 2)
    frame = translate(ref, 4.0, -2.0) + rng.normal(0, 1.0, ref.shape).astype(np.float32)
    points = TexturePoints.of(texture_mask(ref))
    true = offset_mismatch(ref, frame, 4.0, -2.0, points, None)
    assert true < 0.7 * offset_mismatch(ref, frame, 1.5, -0.5, points, None)
    assert true < 0.7 * offset_mismatch(ref, frame, 0.0, 0.0, points, None)
    everything = np.full(ref.shape, 255, np.uint8)
    assert offset_mismatch(ref, frame, 4.0, -2.0, points, everything) == np.inf
