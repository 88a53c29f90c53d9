"""``robustness.settle_frames`` (docs/method.md, departure 34): the frames after a camera was
off its place are judged but held, carrying no evidence either way."""

from __future__ import annotations

import cv2
import numpy as np

from drivers.simulator.precipitation import StreakParams, render_streaks
from hos import DetectorParams, HosDetector, State
from hos.background import translate

KNOCK = range(200, 206)  # frames the camera is knocked 8 px off its place, then springs back


def _knocked_in_rain(settle: int) -> list:
    """A textured 320x240 view in light rain over frames 80-205; the camera knocked 8 px
    aside over frames 200-205, and back on 206 when the rain has stopped. Every frame's
    result."""
    rng = np.random.default_rng(11)
    base = cv2.GaussianBlur(rng.uniform(50, 130, (260, 340)).astype(np.float32), (0, 0), 3)
    det = HosDetector(DetectorParams.from_dict({"robustness": {"settle_frames": settle}}))
    streaks = StreakParams(count=20, brightness=30.0, length_px=10.0, mu_deg=85.0)
    out = []
    for i in range(260):
        dx = 8.0 if i in KNOCK else 0.0
        f = translate(base, dx, 0.0)[10:250, 10:330] + rng.normal(0, 1.5, (240, 320))
        if 80 <= i < KNOCK.stop:
            f += render_streaks((240, 320), streaks, rng).layer
        out.append(det.process(np.clip(f, 0, 255).astype(np.uint8), i / 25))
    return out


def _after(results: list) -> list:
    """The results from the first frame after the knock judged again (state ok)."""
    start = next(i for i in range(KNOCK.stop, len(results)) if results[i].state == State.OK)
    return results[start:]


def test_the_frames_after_a_knock_are_judged_but_held() -> None:
    held = _knocked_in_rain(10)
    assert all(r.rain for r in held[150 : KNOCK.start])
    assert any(r.state == State.UNSTABLE for r in held[KNOCK.start : KNOCK.stop])
    after = _after(held)
    # judged, still saying the rain it saw before the knock, Pi frozen for 10 frames...
    assert all(r.state == State.OK and r.rain for r in after[:10])
    assert len({r.pi_smoothed for r in after[:10]}) == 1
    # ...then measured again: the rain has stopped, and is said to within the dwell
    assert after[10].pi_smoothed < after[9].pi_smoothed
    assert not any(r.rain for r in after[30:])


def test_without_settling_the_first_frames_back_are_measurements() -> None:
    after = _after(_knocked_in_rain(0))
    assert after[1].pi_smoothed < after[0].pi_smoothed
    assert not any(r.rain for r in after[20:])
