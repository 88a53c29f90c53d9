"""The second track: the blobs that pass the paper's eq. 32 (docs/method.md, departure 45).

A drop crosses a pixel within one exposure: the pixel is brighter than in the frame before
and in the frame after. The tests draw the same streaks either as drops (new places every
frame) or lingering for two frames (a stream that shows each drop twice, or flakes slower
than their size), over a textured view with fresh sensor noise. The second track sees the
first and not the second; the first track sees both.
"""

from __future__ import annotations

import cv2
import numpy as np

from hos import DetectorParams, HosDetector

W, H = 320, 240
#: the second track on, as it is by default (said again, so that the tests keep to 0.5)
ON = {"transient_share": 0.5}
FRAMES = 200
JUDGED = 120  # frames from here on are counted


def _view(rng: np.random.Generator) -> np.ndarray:
    y, x = np.mgrid[0:H, 0:W]
    base = 90.0 + 40.0 * x / W + 20.0 * y / H
    texture = cv2.GaussianBlur(rng.normal(0, 12, (H, W)).astype(np.float32), (0, 0), 2.0)
    return base + texture


def _streaks(rng: np.random.Generator, n: int, lift: float) -> np.ndarray:
    layer = np.zeros((H, W), np.float32)
    for _ in range(n):
        x, y = rng.uniform(5, W - 5), rng.uniform(5, H - 20)
        angle = np.radians(rng.normal(90.0, 4.0))
        length = rng.uniform(9, 15)
        end = (x + length * np.cos(angle), y + length * np.sin(angle))
        cv2.line(layer, (round(x), round(y)), (round(end[0]), round(end[1])), lift, 1)
    return layer


def _run(linger: int, params: DetectorParams | None = None, *, n: int = 60) -> tuple:
    """The detector over FRAMES frames of streaks, each set shown on ``linger`` frames in a row
    (0: no streaks). Returns (the verdicts, the second track's verdicts and smoothed Pi) over
    the judged frames."""
    rng = np.random.default_rng(7)
    view = _view(rng)
    det = HosDetector(params or DetectorParams.from_dict({"decision": ON}))
    verdict, track, track_pi = [], [], []
    layer = np.zeros((H, W), np.float32)
    for i in range(FRAMES):
        if linger and i % linger == 0:
            layer = _streaks(rng, n, 25.0)
        noise = rng.normal(0, 1.5, (H, W))
        frame = np.clip(view + layer + noise, 0, 255).astype(np.uint8)
        result = det.process(frame, i / 25)
        if i >= JUDGED:
            verdict.append(result.rain)
            if det._track is not None:
                track.append(det._track.smoother.state.rain)
                track_pi.append(result.drops_pi_smoothed)
                assert result.drops_pi_smoothed == det._track.smoother.state.pi
    return np.array(verdict), np.array(track), np.array(track_pi)


def test_drops_are_seen_by_the_second_track() -> None:
    verdict, track, pi = _run(linger=1)
    assert verdict.all()
    assert track.mean() >= 0.95, track.mean()
    assert np.median(pi) > 0.5


def test_streaks_that_linger_a_frame_are_not_drops() -> None:
    """The same streaks, each shown on two frames: eq. 32 fails on both (each frame's streak
    is bright in its neighbour too), so the second track says nothing; the first still
    says rain."""
    verdict, track, pi = _run(linger=2)
    assert verdict.mean() >= 0.9, verdict.mean()
    assert not track.any()
    assert pi.max() < 0.1


def test_clear_weather_and_noise_say_nothing() -> None:
    verdict, track, pi = _run(linger=0)
    assert not verdict.any() and not track.any()
    assert pi.max() < 0.1


def test_the_second_track_can_be_turned_off() -> None:
    assert HosDetector(DetectorParams())._track is not None
    params = DetectorParams.from_dict({"decision": {"transient_share": 0.0}})
    verdict, track, _ = _run(linger=1, params=params)
    assert verdict.all() and track.size == 0


def test_the_second_track_is_in_the_frame_record() -> None:
    """``drops_pi_smoothed`` and ``n_drop_blobs`` (the per-frame JSON of ``weatherd detect
    --jsonl`` and the MCAP ``hos.frame``): what the second track said, so that a frame said
    rain with a low ``pi_smoothed`` can be read; null and 0 with the track off."""
    rng = np.random.default_rng(3)
    view = _view(rng)
    on = HosDetector(DetectorParams.from_dict({"decision": ON}))
    off = HosDetector(DetectorParams.from_dict({"decision": {"transient_share": 0.0}}))
    for i in range(150):
        frame = np.clip(view + _streaks(rng, 60, 25.0) + rng.normal(0, 1.5, (H, W)), 0, 255)
        a = on.process(frame.astype(np.uint8), i / 25).to_json()
        b = off.process(frame.astype(np.uint8), i / 25).to_json()
    assert a["n_drop_blobs"] >= 30 and a["drops_pi_smoothed"] > 0.5, a
    assert b["n_drop_blobs"] == 0 and b["drops_pi_smoothed"] is None


def _gathered(width_frames: int) -> float:
    """35 short segments a frame whose orientations spread 30 degrees about the vertical,
    dropped at new places every frame within a 120x100 box (the fragments of a tree's crown
    in the wind: they pass eq. 32 as drops do). The share of judged frames the second track
    says rain, its width rules reading the median of its last ``width_frames`` fits."""
    rng = np.random.default_rng(5)
    view = _view(rng)
    params = DetectorParams.from_dict({"decision": ON | {"transient_width_frames": width_frames}})
    det = HosDetector(params)
    track = []
    for i in range(FRAMES):
        layer = np.zeros((H, W), np.float32)
        if i >= 40:
            x, y = rng.uniform(20, 140, 35), rng.uniform(30, 130, 35)
            theta = np.radians(rng.normal(90.0, 30.0, 35))
            for x0, y0, t in zip(x, y, theta, strict=True):
                dx, dy = 3.0 * np.cos(t), 3.0 * np.sin(t)
                p, q = (round(x0 - dx), round(y0 - dy)), (round(x0 + dx), round(y0 + dy))
                cv2.line(layer, p, q, 40.0, 1)
        frame = np.clip(view + layer + rng.normal(0, 1.5, (H, W)), 0, 255).astype(np.uint8)
        det.process(frame, i / 25)
        if i >= JUDGED - 40:
            track.append(det._track.smoother.state.rain)
    return float(np.mean(track))


def test_one_narrow_fit_of_few_drops_is_not_rain() -> None:
    """``decision.transient_width_frames``: a fit of some 30 drops reads its width a few
    degrees off, so now and then a population 30 degrees wide fits under ``spread_sigma``
    (20 degrees). Judged on the median of the last 5 fits' widths, the gathered fragments
    are never rain in the second track; judged on each fit alone (1), they are (the
    control)."""
    assert _gathered(5) == 0.0
    assert _gathered(1) > 0.02


def drizzle_under_a_shade_scene(seed: int, *, rain: bool = True):
    """Faint short streaks (14 grey levels, 4 px, 100 a frame) at 320x240, 15 fps, in a dim
    view (darkness 0.4) under a cloud's shade drifting at 36 px/s, a camera in the wind and
    a soft lens: tuning-012's settings at a quarter of its pixels (also drawn by
    ``tests/hos/test_traffic.py``)."""
    from drivers.simulator import Scene, SceneParams, StreakParams

    streaks = StreakParams(mu_deg=80.0, sigma_deg=12.0, length_px=4.0, count=100, brightness=14.0)
    params = SceneParams(
        fps=15.0,
        cars=1,
        foliage_sway_px=1.86,
        sensor_noise=0.14,
        shake_px=0.15,
        darkness=0.4,
        shade=0.3,
        shade_speed_px_s=36.0,
        shade_cover=0.56,
        shade_edge=0.43,
        wet_road=0.87,
        lens_blur_px=0.41,
        rain=streaks if rain else None,
    )
    return Scene(W, H, seed=seed, params=params)


def _drizzle_under_a_shade(lit: bool, *, rain: bool, seed: int) -> tuple[float, float]:
    """:func:`drizzle_under_a_shade_scene` over frames 100-199 (or 90-299 clear): the share
    said rain, and the second track's highest smoothed Pi."""
    scene = drizzle_under_a_shade_scene(seed, rain=rain)
    det = HosDetector(DetectorParams.from_dict({"decision": ON | {"transient_lit": lit}}))
    first, frames = (100, 200) if rain else (90, 300)
    said, pi = [], []
    for i in range(frames):
        result = det.process(scene.frame(i)[0], i / 15.0)
        if i >= first:
            said.append(result.rain)
            pi.append(det._track.smoother.state.pi)
    return float(np.mean(said)), max(pi)


def test_drops_where_the_light_changed_are_tested_not_left_out() -> None:
    """``decision.transient_lit``: where a cloud's shade moves, the first track leaves every
    blob out (departure 31: what eq. 8 cuts out there is what the correction missed of the
    light). A shade's edge is still there in the next frame and fails eq. 32, a drop passes:
    so the second track tests those blobs itself. Measured: said on 41 and 48 of 100 frames
    (seeds 3, 4) with them, 25 and 0 without (the control); clear, nothing. (Before lanes
    were no longer learnt under a shade, departure 46: 65 and 18, against 10 and 0.)"""
    lit = [_drizzle_under_a_shade(True, rain=True, seed=seed)[0] for seed in (3, 4)]
    unlit = [_drizzle_under_a_shade(False, rain=True, seed=seed)[0] for seed in (3, 4)]
    assert np.mean(lit) >= 0.4 and np.mean(unlit) <= 0.2, (lit, unlit)
    said, pi = _drizzle_under_a_shade(True, rain=False, seed=3)
    assert said == 0.0 and pi < 0.1, pi


def _clear_under_a_fast_shade(rest: bool, seed: int) -> float:
    """A clear 320x240 view at 10 fps, JPEG 60, under a cloud's shade taking half the light
    with sharp edges, drifting at 60 px/s, foliage in the wind and two vehicles: the second
    track's highest smoothed Pi over frames 90-299, with or without the rest test."""
    from drivers.simulator import Scene, SceneParams

    params = SceneParams(
        fps=10.0,
        cars=2,
        foliage_sway_px=2.5,
        sensor_noise=1.0,
        shake_px=0.3,
        darkness=0.3,
        shade=0.5,
        shade_speed_px_s=60.0,
        shade_cover=0.5,
        shade_edge=0.2,
        jpeg_quality=60,
    )
    scene = Scene(W, H, seed=seed, params=params)
    det = HosDetector(DetectorParams.from_dict({"decision": ON | {"transient_rest": rest}}))
    pi = []
    for i in range(300):
        result = det.process(scene.frame(i)[0], i / 10.0)
        if i >= 90:
            assert not result.rain
            pi.append(result.drops_pi_smoothed)
    return max(pi)


def test_a_drop_comes_to_pixels_at_rest() -> None:
    """``decision.transient_rest``: where a shade's edge passes, the correction's residue
    changes from frame to frame, and some of it passes eq. 32. A drop's pixels were at rest
    the frame before it came (within c of the frame before that), the residue's were not.
    Measured: the second track's Pi at most 0.00 and 0.01 (seeds 3, 4) with the test, 0.19
    and 0.20 without (the control)."""
    assert max(_clear_under_a_fast_shade(True, seed) for seed in (3, 4)) < 0.05
    assert max(_clear_under_a_fast_shade(False, seed) for seed in (3, 4)) > 0.15
