"""Rain that stops leaves nothing behind (``decision.collapse_ratio``, docs/method.md).

When a shower ends, a few blobs are left: noise, compression, a pool still holding the last
rain frames. Pooled, they can fit a narrow Gaussian at Pi 0.3-0.6, which held the verdict
for 10-20 frames. A frame with far fewer voting blobs than the last frames had ends it.
"""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from drivers.simulator import Scene, SceneParams, StreakParams
from hos import DetectorParams, HosDetector

W, H = 320, 240
STOP = 160


def _verdicts(*collapse_ratios: float) -> dict[float, list[bool]]:
    """Moderate rain until STOP, then clear frames on which a few short near-vertical blobs
    (what noise and compression leave) are drawn at random places, 10 at first and fewer
    each frame until none are left 25 frames after STOP. The verdicts of a detector for each
    of ``collapse_ratios``, all given the same frames (drawn once). The second track
    (departure 45) is off: those blobs are drawn at new places for one frame each, drops by
    eq. 32, and it says rain until they end (25 frames); the rule is the first track's."""
    rain = StreakParams(count=400)
    wet = Scene(W, H, seed=4, params=SceneParams(cars=1, rain=rain))
    dry = Scene(W, H, seed=4, params=SceneParams(cars=1))
    dets = {
        ratio: HosDetector(
            DetectorParams.from_dict(
                {"decision": {"collapse_ratio": ratio, "transient_share": 0.0}}
            )
        )
        for ratio in collapse_ratios
    }
    rng = np.random.default_rng(7)
    out: dict[float, list[bool]] = {ratio: [] for ratio in collapse_ratios}
    for i in range(STOP + 60):
        if i < STOP:
            gray = wet.frame(i)[0]
        else:
            gray = dry.frame(i)[0].copy()
            for _ in range(max(0, 10 - (i - STOP) * 10 // 25)):
                x, y = int(rng.integers(5, W - 5)), int(rng.integers(5, H - 12))
                dx = int(rng.integers(-1, 2))
                cv2.line(gray, (x, y), (x + dx, y + 7), 255, 1)
        for ratio, det in dets.items():
            out[ratio].append(det.process(gray, i / 25).rain)
    return out


def _end(verdicts: list[bool]) -> int:
    """Frames after STOP until the verdict is false for good."""
    wet = [i for i, v in enumerate(verdicts) if v]
    return max(wet) + 1 - STOP


@pytest.fixture(scope="module")
def verdicts() -> dict[float, list[bool]]:
    return _verdicts(0.1, 0.0)


@pytest.fixture(scope="module")
def ends(verdicts) -> dict[float, int]:
    return {r: _end(v) for r, v in verdicts.items()}


def test_rain_is_seen_before_it_stops(verdicts):
    assert np.mean(verdicts[0.1][90:STOP]) > 0.95


def test_a_collapse_of_the_blobs_ends_the_verdict(ends):
    assert ends[0.1] <= 10, ends


def test_without_the_rule_the_left_blobs_hold_it(ends):
    """The control: the few blobs left fit, and the verdict lasts longer."""
    assert ends[0.0] >= ends[0.1] + 4, ends
