"""Exposure changes are undone, and rain is not taken for one (``robustness.gain_tolerance``).

Auto-exposure changes every pixel at once; the detector measures the global gain against a
reduced reference and undoes it before the background model sees the frame
(docs/method.md, departure 8).
"""

from __future__ import annotations

import numpy as np
import pytest

import hos.pipeline
from drivers.simulator import Scene, SceneParams, StreakParams
from drivers.simulator.families import case_frames, sample_cases
from hos import DetectorParams, HosDetector

W, H = 320, 240
#: the benchmark's heavy rain at 320x240 (drivers/simulator/families.py)
_HEAVY = SceneParams(
    fps=15.0, cars=1, rain=StreakParams(count=400, brightness=45.0, length_px=16.0)
)
_TIGHT = DetectorParams.from_dict({"robustness": {"gain_tolerance": 0.01}})


def _run(frames: list[np.ndarray], fps: float, detector: DetectorParams | None = None):
    det = HosDetector(detector or DetectorParams())
    return [det.process(gray, i / fps) for i, gray in enumerate(frames)]


@pytest.fixture(scope="module")
def heavy() -> list[np.ndarray]:
    """160 frames of the benchmark's heavy rain, rendered once for the test and its control
    (100 after the gain's warm-up, 80 after the verdict's: the gain held to 1.000 and rain on
    every frame, and the control 0.21 off, as over 240 frames they were 1.000, every frame
    and 0.34)."""
    scene = Scene(W, H, seed=5, params=_HEAVY)
    return [scene.frame(i)[0] for i in range(160)]


def test_heavy_rain_is_not_taken_for_an_exposure_change(heavy):
    """Rain only brightens: a reference that learnt it at full rate was brighter than a
    frame's typical pixel, and the gain crept up by a per cent every few frames."""
    results = _run(heavy, _HEAVY.fps, _TIGHT)
    gains = np.array([r.gain for r in results[60:]])
    assert np.abs(gains - 1.0).max() < 0.02, gains.round(3)
    assert np.mean([r.rain for r in results[80:]]) > 0.95


def test_the_reference_learns_rain_at_full_rate_creeps(heavy, monkeypatch):
    """The control: without the clipped steps the same rain moves the gain."""
    monkeypatch.setattr(hos.pipeline, "_GAIN_OUTLIER", 1e9)
    gains = np.array([r.gain for r in _run(heavy, _HEAVY.fps, _TIGHT)[60:]])
    assert np.abs(gains - 1.0).max() > 0.03


@pytest.fixture(scope="module")
def ramp() -> tuple[list[np.ndarray], float]:
    """The frames of the tuning scene with the exposure ramp (rendered and encoded once, for
    both tolerances), and its frame rate."""
    cases = sample_cases("tuning", per_cell=3, frames=260)
    case = next(c for c in cases if c.name == "tuning-018-light-wind")
    return [f.gray for f in case_frames(case)], case.fps


@pytest.mark.parametrize("tolerance, judged", [(0.01, True), (0.03, False)])
def test_rain_is_judged_through_an_exposure_ramp(ramp, tolerance, judged):
    """A tuning scene (light rain, H.264, a camera in the wind) whose exposure ramps up at
    frame 222 and settles 2-3 % off the background: at a 3 % tolerance that remainder was
    left for the background model, 5 grey levels on its bright scene; noise all over the
    frame became candidates, the HOS went flat and the verdict was lost for 80 frames. (The
    control is the first track's alone: the second, of the drops that pass eq. 32, keeps
    the verdict through that noise, departure 45.)"""
    frames, fps = ramp
    second = {} if judged else {"transient_share": 0.0}
    detector = DetectorParams.from_dict(
        {"robustness": {"gain_tolerance": tolerance}, "decision": second}
    )
    rain = [r.rain for r in _run(frames, fps, detector)]
    seen = float(np.mean(rain[200:]))
    if judged:
        assert seen > 0.95, seen
    else:
        assert seen < 0.8, seen  # the control: the ramp costs the verdict
