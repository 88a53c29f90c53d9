"""Blobs copied from the last frames do not vote (``robustness.stale_level``, docs/method.md).

A video encoder's skipped blocks copy a region of the last frame: after the rain stops,
H.264 at a low quality keeps showing the last streaks for about ten frames. A streak is where
the drop is during this exposure, so its pixels change from frame to frame; a copy's do not.
"""

from __future__ import annotations

import functools

import numpy as np
import pytest

from drivers.simulator import Scene, SceneParams, StreakParams
from hos import DetectorParams, HosDetector, State
from hos.blobs import blob_change, find_blobs

W, H = 320, 240


def test_blob_change_is_the_mean_absolute_change_of_each_blobs_pixels():
    mask = np.zeros((H, W), np.uint8)
    mask[10:20, 30] = 255  # blob 1: 10 pixels
    mask[50, 60:64] = 255  # blob 2: 4 pixels
    blobs = find_blobs(mask)
    before = np.full((H, W), 100, np.uint8)
    now = before.copy()
    now[10:15, 30] = 120  # half of blob 1 brighter by 20
    now[50, 60:64] = 97  # all of blob 2 darker by 3
    got = blob_change(now, before, blobs.index, blobs.pixel_labels, blobs.n_labels)
    labels = blobs.labels
    assert got[labels[12, 30]] == pytest.approx(10.0)
    assert got[labels[50, 61]] == pytest.approx(3.0)
    # symmetric, and zero against itself
    back = blob_change(before, now, blobs.index, blobs.pixel_labels, blobs.n_labels)
    np.testing.assert_allclose(back[1:], got[1:])
    same = blob_change(now, now, blobs.index, blobs.pixel_labels, blobs.n_labels)
    assert not same[1:].any()


def _rain_then_ghosts(*stale_levels: float, ghost_frames: int = 14, stop: int = 160):
    """Rain until ``stop``, then clear frames onto which the last rain frame's streaks are
    copied (as an encoder's skipped blocks do), a tenth of them refreshed away each frame.
    The verdicts, frame by frame, of a detector for each of ``stale_levels``, all given the
    same frames (drawn once)."""
    rain = StreakParams(count=250, brightness=30.0)
    wet = Scene(W, H, seed=3, params=SceneParams(cars=1, rain=rain))
    dry = Scene(W, H, seed=3, params=SceneParams(cars=1))
    dets = {
        level: HosDetector(DetectorParams.from_dict({"robustness": {"stale_level": level}}))
        for level in stale_levels
    }
    rng = np.random.default_rng(0)
    verdicts: dict[float, list[bool]] = {level: [] for level in stale_levels}
    last, ghost = None, None
    for i in range(stop + ghost_frames + 20):
        if i < stop:
            gray, truth = wet.frame(i)
            last, ghost = gray, truth.mask.copy()
        else:
            gray = dry.frame(i)[0].copy()
            if i < stop + ghost_frames:
                ghost &= rng.random(ghost.shape) > 0.1
                gray[ghost] = last[ghost]
        for level, det in dets.items():
            verdicts[level].append(det.process(gray, i / 25).rain)
    return verdicts


def test_streaks_copied_after_the_rain_stops_do_not_keep_it_raining():
    """With copies left out, the verdict ends as if the streaks had gone with the drops; with
    ``stale_level = 0`` (every blob votes), the copied streaks hold it for longer."""
    stop = 160
    ends = {}
    for level, verdicts in _rain_then_ghosts(1.0, 0.0, stop=stop).items():
        assert all(verdicts[120:stop]), level  # the rain itself is seen either way
        ends[level] = next(i for i in range(stop, len(verdicts)) if not verdicts[i]) - stop
    assert ends[1.0] <= 10
    assert ends[0.0] >= ends[1.0] + 4, ends


@pytest.fixture(scope="module")
def raining():
    """Frame ``i`` of the rain scene of the two tests below, rendered once for both (when
    first asked for)."""
    rain = StreakParams(count=250, brightness=30.0)
    scene = Scene(W, H, seed=4, params=SceneParams(cars=1, rain=rain))
    return functools.cache(lambda i: scene.frame(i)[0])


def test_a_repeated_frame_holds_the_verdict(raining):
    """A stream that repeats a frame (a dropped frame filled in) shows the same streaks again:
    they are copies, so they do not vote, and the repeat is no evidence of dry weather
    either. The verdict holds through 15 repeats and the rain is seen again after them."""
    det = HosDetector()
    results = []
    for i in range(200):
        gray = raining(min(i, 150) if i < 165 else i)
        results.append(det.process(gray, i / 25))
    assert all(r.rain for r in results[120:])
    assert all(r.state == State.OK for r in results[120:])
    # every blob is a copy once the frame has been the same twice
    assert all(r.n_blobs == 0 for r in results[152:165])


def test_a_frozen_stream_is_not_held_for_ever(raining):
    """A stream frozen on a rain frame: the verdict holds for a moment (up to 25 repeats), then
    the frozen picture, which shows no fresh streak, decays to no precipitation."""
    det = HosDetector()
    frozen = raining(150)
    said = [det.process(raining(i) if i <= 150 else frozen, i / 25).rain for i in range(215)]
    assert all(said[120:176])  # 25 repeats held
    assert not any(said[200:])
