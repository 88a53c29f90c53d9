"""Acceptance: the paper's quantitative claims and our robustness goals, on rendered data.

Every scene is seeded; every figure asserted here is also reported in docs/figures.md.
"""

from __future__ import annotations

import itertools
import math

import cv2
import numpy as np
import pytest

from drivers.simulator import (
    Scene,
    SceneParams,
    SnowParams,
    StreakParams,
    composite,
    render_falling_snow,
    render_streaks,
)
from drivers.simulator.families import snow_flakes
from hos import DetectorParams, HosDetector, State
from hos.blobs import find_blobs
from hos.histogram import hos_histogram
from hos.mixture import fit_mixture
from hos.moments import orientation_uncertainty
from hos.pipeline import classify_blobs

pytestmark = pytest.mark.slow

HP = DetectorParams().histogram
W, H = 640, 360
WARMUP = 65  # frames excluded from rates: the detector says warming_up for 60


def _fit_streaks(layer, *, min_area=4, max_area=None):
    """Blobs of a rendered streak layer -> HOS -> EM, as the pipeline does it."""
    blobs = find_blobs(layer.mask.astype(np.uint8) * 255)
    m = blobs.moments
    ok = m.area >= min_area
    if max_area is not None:
        ok &= m.area <= max_area
    ok[0] = False
    idx = np.flatnonzero(ok)
    dth = orientation_uncertainty(
        m.m20[idx], m.m11[idx], m.m02[idx], dm=HP.dm, lo=HP.dtheta_min, hi=HP.dtheta_max
    )
    fit = fit_mixture(hos_histogram(m.theta[idx], dth, m.a[idx]))
    return blobs, idx, fit


def _run(params: SceneParams, n: int, *, seed: int = 1, detector: HosDetector | None = None):
    scene = Scene(W, H, seed=seed, params=params)
    det = detector or HosDetector()
    out = []
    for i in range(n):
        gray, truth = scene.frame(i)
        out.append((det.process(gray, i / params.fps), truth))
    return out


# -- Fig. 6: the HOS estimates the streaks' orientation distribution ---------------------------
@pytest.mark.parametrize("length", [5, 7, 11, 15, 21])
def test_fig6_hos_peak_matches_the_streak_distribution(length):
    """Paper: relative errors under 5 % on the mean and 10 % on the std once streaks are longer
    than 5 px (350 streaks, mu 55, sigma 10). At exactly 5 px we measure 5.1 % on the mean:
    OpenCV's antialiased 5-px lines themselves lean toward the diagonal by 3.2 degrees (see the
    next test, with exactly drawn streaks, and docs/figures.md)."""
    e_mu, e_sigma = [], []
    for seed in range(5):
        layer = render_streaks(
            (480, 640),
            StreakParams(mu_deg=55, sigma_deg=10, length_px=length, count=350),
            np.random.default_rng(seed),
        )
        _, _, fit = _fit_streaks(layer, min_area=2, max_area=4 * (length + 2))
        assert fit.ok
        e_mu.append(abs(55 - math.degrees(fit.mu)) / 55)  # eq. 21
        e_sigma.append(abs(10 - math.degrees(fit.sigma)) / 10)  # eq. 22
    mu_bound = 0.06 if length <= 5 else 0.05
    sigma_bound = 0.10
    assert np.mean(e_mu) < mu_bound
    assert np.mean(e_sigma) < sigma_bound


@pytest.mark.parametrize("length", [5, 7, 11, 21])
def test_fig6_with_exactly_drawn_streaks(length):
    """Fig. 6 again, with streaks drawn without OpenCV's lean toward the diagonal
    (StreakParams.supersample): the mean is within 5 % at every length from 5 px. The spread
    is within 10 % from 11 px; shorter blobs add their own pixelisation noise to it (measured
    37 % at 5 px, 15 % at 7 px: docs/figures.md), so there it is only bounded."""
    e_mu, e_sigma = [], []
    for seed in range(5):
        layer = render_streaks(
            (480, 640),
            StreakParams(mu_deg=55, sigma_deg=10, length_px=length, count=350, supersample=8),
            np.random.default_rng(seed),
        )
        _, _, fit = _fit_streaks(layer, min_area=2, max_area=4 * (length + 2))
        assert fit.ok
        e_mu.append(abs(55 - math.degrees(fit.mu)) / 55)
        e_sigma.append(abs(10 - math.degrees(fit.sigma)) / 10)
    assert np.mean(e_mu) < 0.05
    assert np.mean(e_sigma) < (0.10 if length >= 11 else 0.45)


def test_section_4_3_em_on_rendered_streaks():
    """mu 65, sigma 10, 40 % uniform streaks: within 2 deg, 2 deg and 5 points on average
    (paper: 64.3, 11.2, 37 %)."""
    est = []
    for seed in range(6):
        layer = render_streaks(
            (480, 640),
            StreakParams(mu_deg=65, sigma_deg=10, noise_fraction=0.4, count=600),
            np.random.default_rng(seed),
        )
        _, _, fit = _fit_streaks(layer)
        est.append((math.degrees(fit.mu), math.degrees(fit.sigma), 1 - fit.pi))
    mu, sigma, uniform = np.mean(est, axis=0)
    assert abs(mu - 65) < 2.0
    assert abs(sigma - 10) < 2.0
    assert abs(uniform - 0.40) < 0.05


def test_rotating_the_rain_rotates_the_estimate():
    fits = []
    for mu_deg in (70, 100):
        layer = render_streaks(
            (360, 640), StreakParams(mu_deg=mu_deg, count=400), np.random.default_rng(9)
        )
        fits.append(_fit_streaks(layer)[2])
    shift = math.degrees(fits[1].mu - fits[0].mu)
    assert shift == pytest.approx(30, abs=1.5)
    assert fits[1].sigma == pytest.approx(fits[0].sigma, rel=0.15)


# -- Fig. 10: rain pixels ------------------------------------------------------------------------
def _dice(noise_fraction: float, s_b: float, seed: int) -> float:
    layer = render_streaks(
        (480, 640),
        StreakParams(mu_deg=80, sigma_deg=10, noise_fraction=noise_fraction, count=400),
        np.random.default_rng(seed),
    )
    blobs, idx, fit = _fit_streaks(layer)
    is_rain = classify_blobs(
        blobs.moments.theta[idx], pi=fit.pi, mu=fit.mu, sigma=fit.sigma, s_b=s_b
    )
    lut = np.zeros(blobs.n_labels, bool)
    lut[idx[is_rain]] = True
    pred, truth = lut[blobs.labels], layer.rain_mask
    tp = np.count_nonzero(pred & truth)
    return 2 * tp / (2 * tp + np.count_nonzero(pred & ~truth) + np.count_nonzero(~pred & truth))


@pytest.mark.parametrize("noise_fraction", [0.1, 0.3])
def test_fig10_rain_pixel_dice(noise_fraction):
    """Paper: Dice 90.9 % at S_b = 0.56 on synthetic streaks with noise; flat for S_b in
    [0.1, 0.7]."""
    dice = np.mean([_dice(noise_fraction, 0.56, seed) for seed in range(3)])
    assert dice >= 0.90
    flat = [np.mean([_dice(noise_fraction, s_b, seed) for seed in range(2)]) for s_b in (0.2, 0.7)]
    assert max(flat) - min(flat) < 0.03


# -- Section 5: the decision ---------------------------------------------------------------------
def test_latency_clear_rain_clear():
    """Paper (simulator): ~50 frames clear -> rain, ~25 rain -> clear. Goal: <= 25 each way."""
    schedule = [0] * 150 + [1] * 150 + [0] * 150
    params = SceneParams(
        cars=2, pedestrians=2, rain=StreakParams(mu_deg=80, sigma_deg=8), schedule=schedule
    )
    res = _run(params, 450)
    rain = np.array([r.rain for r, _ in res])
    assert not rain[:150].any()
    onset = int(np.argmax(rain[150:]))
    assert rain[150 + onset] and onset <= 25
    end = int(np.argmax(~rain[300:]))
    assert not rain[300 + end] and end <= 25
    assert not rain[300 + end :].any()  # and it stays clear
    assert rain[150 + onset : 300].mean() >= 0.98


CLEAR_CASES = {
    "cars_and_pedestrians": SceneParams(cars=4, pedestrians=4),
    "foliage_sway": SceneParams(foliage_sway_px=3.0),
    "exposure_steps": SceneParams(exposure_steps=True, exposure_interval_s=2.0),
    "noise_and_jpeg": SceneParams(sensor_noise=3.0, jpeg_quality=60),
    "slight_shake": SceneParams(shake_px=0.2),
    "shake_over_vertical_edges": SceneParams(shake_px=0.6),
    "everything": SceneParams.busy(),
}


@pytest.mark.parametrize("case", sorted(CLEAR_CASES))
def test_clear_weather_stays_clear(case):
    """Goal: under 3 % false positives in every robustness case (paper: 7 % overall), over
    the 135 frames after the warm-up of a 200-frame run."""
    res = _run(CLEAR_CASES[case], 200)
    post = [r for r, _ in res[WARMUP:]]
    fp = np.mean([r.rain for r in post])
    assert fp < 0.03, (case, fp)


def test_shaking_camera_says_unstable_rather_than_guess():
    """Shaken by about 3 px, beyond the wind that ``robustness.motion_frame_px`` (2.5 px)
    judges through: unstable (over the 100 frames after the warm-up), never rain."""
    res = _run(SceneParams(shake_px=3.0), WARMUP + 100)
    states = [r.state for r, _ in res[WARMUP:]]
    assert states.count(State.UNSTABLE) / len(states) > 0.9
    assert not any(r.rain for r, _ in res)


@pytest.mark.parametrize(("seed", "shake"), [(1, 0.35), (3, 0.6)])
def test_camera_in_the_wind_is_held_still_and_judges(seed, shake):
    """A camera shaken by a third to two thirds of a pixel is translated back onto its
    reference before the background model sees it, and its edges, a pixel off at most, are
    held out by eq. 8 against the 3x3 neighbourhood: it judges rain and clear weather on every
    frame (200 of each; issue 10: with robustness.motion_frame_px at 0.3 px, it said unstable
    on every frame; at 0.6 px, seed 3 still did, and seed 1 on a quarter of them. Seed 2 at
    0.35 px, once a case of its own, failed under both limits as seed 1 does)."""
    clear = _run(SceneParams(cars=4, shake_px=shake), 200, seed=seed)
    states = [r.state for r, _ in clear[WARMUP:]]
    assert states.count(State.UNSTABLE) / len(states) <= 0.01
    assert not any(r.rain for r, _ in clear)
    rain = _run(SceneParams(cars=4, shake_px=shake, rain=StreakParams()), 200, seed=seed)
    assert np.mean([r.rain for r, _ in rain[WARMUP + 25 :]]) >= 0.95


def test_a_camera_in_the_wind_is_moved_back_by_whole_pixels_and_keeps_faint_streaks():
    """Faint streaks (8 grey levels, a pixel wide) under a camera shaken by 0.9 px. Moving the
    frame back by a fraction of a pixel resamples it: a one-pixel streak spreads over two
    pixels at half its contrast, under eq. 8's c, and only its fragments are candidates. Moved
    back by whole pixels (the default), the streaks keep their contrast; the background eq. 8
    compares with is moved by the fraction left, and the 3x3 neighbourhood rule takes the
    estimate's error (docs/method.md, departure 7). Clear weather stays clear either way."""
    faint = StreakParams(count=150, length_px=9.0, brightness=8.0, sigma_deg=10.0, mu_deg=85)
    said, blobs = {}, {}
    for weather in (faint, None):
        scene = Scene(
            W, H, seed=2, params=SceneParams(cars=2, shake_px=0.9, rain=weather, sensor_noise=1.5)
        )
        frames = [scene.frame(i)[0] for i in range(220)]
        for subpixel in (False, True):
            params = DetectorParams.from_dict({"robustness": {"stabilise_subpixel": subpixel}})
            det = HosDetector(params)
            results = [det.process(f, i / 25) for i, f in enumerate(frames)][90:]
            said[weather is None, subpixel] = np.mean([r.rain for r in results])
            blobs[weather is None, subpixel] = np.median([r.n_blobs for r in results])
            assert np.mean([r.state == State.UNSTABLE for r in results]) < 0.15
    assert said[True, False] == 0 and said[True, True] == 0, said
    assert said[False, False] > 0.85 and said[False, True] < 0.6, said
    assert blobs[False, False] > 1.2 * blobs[False, True], blobs


def _swayed(gray: np.ndarray, i: int, amplitude: float) -> np.ndarray:
    """``gray`` moved by a wind gust: a sway of ``amplitude`` px at 0.6 Hz (25 fps) along a
    slanted line, so that both axes carry fractions of a pixel."""
    d = amplitude * math.sin(2 * math.pi * 0.6 * i / 25)
    m = np.float32([[1, 0, 0.9 * d], [0, 1, 0.44 * d]])
    return cv2.warpAffine(gray, m, (W, H), borderMode=cv2.BORDER_REFLECT)


def test_a_gust_of_two_pixels_is_judged_through():
    """The wind sways a camera by up to 2 px (its typical amplitude of a pixel has such
    peaks): translated back by whole pixels, what is left is within the 3x3 neighbourhood's
    reach as at 1 px, so every frame is judged, the rain is seen and clear weather stays
    clear (issue 10: with ``motion_frame_px`` at 1.5 px, the frames of the gust beyond 1.5 px
    were unstable, up to 17 % of a windy scene's). Judged over frames 100-199: four seconds of
    the gust, nearly five of its 2-px peaks."""
    said = {}
    for weather in (StreakParams(count=300, brightness=30.0), None):
        scene = Scene(W, H, seed=4, params=SceneParams(cars=2, rain=weather))
        det = HosDetector()
        results = [
            det.process(_swayed(scene.frame(i)[0], i, 2.0 if i >= 90 else 0.0), i / 25)
            for i in range(200)
        ]
        late = results[100:]
        assert sum(r.state == State.UNSTABLE for r in late) <= 0.01 * len(late), weather
        said[weather is None] = np.mean([r.rain for r in late])
        far = [r.motion_px for r in late if r.motion_px > 1.5]
        assert len(far) > 0.2 * len(late)  # the gust was seen that far off, and judged
    assert said[False] >= 0.95
    assert said[True] == 0.0


def test_camera_being_re_aimed_says_unstable():
    """A camera panned by 2 px a frame for 2.4 s says unstable (not only scene_change) on at
    least 90 % of those frames, and never rain."""
    scene = Scene(W, H, seed=3, params=SceneParams(cars=2))
    det = HosDetector()
    offset = np.zeros(2)
    states, rain = [], []
    for i in range(260):
        gray, _ = scene.frame(i)
        if 150 <= i < 210:
            offset += (2.0, 0.6)
        if offset.any():
            m = np.float32([[1, 0, offset[0]], [0, 1, offset[1]]])
            gray = cv2.warpAffine(gray, m, (W, H), borderMode=cv2.BORDER_REFLECT)
        r = det.process(gray, i / 25)
        states.append(r.state)
        rain.append(r.rain)
    panning = states[152:210]
    assert panning.count(State.UNSTABLE) / len(panning) >= 0.9
    assert states[100:150].count(State.OK) == 50
    assert not any(rain)


@pytest.mark.parametrize("name", ["tuning-121-clear-knock", "tuning-125-clear-knock"])
def test_a_knocked_camera_says_no_rain_while_it_relearns_its_view(name):
    """Two knocked cameras of the benchmark's tuning split (320x240, knocks of 1-3 % of the
    width and 1-4 degrees of roll; sampled with 8 scenes a cell, so not in ``make eval``'s
    table). The knock is a scene change: the background model relearns the new view, and
    the reference the camera's offset is measured against must relearn it as fast. Left to
    learn at its own slow rate, the reference was a blend of both views, read offsets of
    1-2 px that were not there, and frames moved back by them put edges in the foreground:
    with ``motion_frame_px`` at 2.5 px these cameras said rain on 8 and 10 clear frames."""
    from drivers.simulator.families import case_frames, sample_cases

    case = next(c for c in sample_cases("tuning", per_cell=8, frames=375) if c.name == name)
    det = HosDetector()
    results = [det.process(f.gray, i / case.fps) for i, f in enumerate(case_frames(case))]
    assert not any(r.rain for r in results)
    after = results[case.reaim[1] + 80 :]  # the new view learnt
    assert all(r.state == State.OK for r in after)
    assert np.median([r.motion_px for r in after]) < 0.25


@pytest.mark.parametrize("rest_frames", [10, 0])
def test_a_knocked_camera_judges_again_at_its_new_aim(rest_frames):
    """A blow turns the view by 8 px and rolls it by 1.5 degrees in 3 frames: unstable while it
    happens, never rain, and judging the rain again once the new view is learnt (about 10 +
    60 frames). With ``rest_frames = 0`` the new view is found by the scene change it makes
    instead, and the motion reference relearns with the background model: judging again as
    soon (it took over 90 frames while the reference learnt at its own slow rate)."""
    rain = StreakParams(count=350, brightness=40.0)
    scene = Scene(W, H, seed=5, params=SceneParams(cars=2, rain=rain))
    params = DetectorParams.from_dict({"robustness": {"rest_frames": rest_frames}})
    det = HosDetector(params)
    states, verdicts = [], []
    for i in range(300):
        gray, _ = scene.frame(i)
        k = min(max(i - 149, 0), 3)  # frames 150-152 are the knock
        if k:
            m = cv2.getRotationMatrix2D((W / 2, H / 2), 0.5 * k, 1.0)
            m[:, 2] += (2.4 * k, -1.2 * k)
            gray = cv2.warpAffine(gray, m, (W, H), borderMode=cv2.BORDER_REFLECT)
        r = det.process(gray, i / 25)
        states.append(r.state)
        verdicts.append(r.rain)
    assert states[100:150].count(State.OK) == 50 and all(verdicts[110:150])
    assert all(s == State.UNSTABLE for s in states[150:153])
    back = next(i for i in range(153, 300) if states[i] == State.OK)
    assert back - 153 <= 90
    assert all(s == State.OK for s in states[back:]) and np.mean(verdicts[back + 10 :]) > 0.9


def test_demo_street_has_no_false_rain_in_its_clear_phases():
    """The demo's two clear phases of its first 80 s (seed 4): the first from the start, the
    second (60-80 s) by a detector started 10 s before it, in the rain (the 30 s of rain
    before those 10 are not run again: the second detector is one that starts in the rain).
    The snow that follows has no clear frame to judge: a gust in the tree or a pedestrian made
    12-25 blobs look like a streak population, and one such fit moved the smoothed Pi over the
    threshold (2 false episodes, 3.2 % of the clear frames). A fit's variance now grows as its
    blobs get fewer (decision.measurement_blobs)."""
    from drivers.simulator.demo import _DEMO_PHASES_S, _demo_schedule, demo_frames

    first_clear, rain, second_clear, _ = _DEMO_PHASES_S
    false = episodes = clear = 0
    end_s = first_clear + rain + second_clear
    for start_s, stop_s in ((0.0, first_clear), (first_clear + rain - 10.0, end_s)):
        det = HosDetector()
        was = False
        start = round(start_s * 25)
        for i, (gray, _) in enumerate(demo_frames(seed=4, start=start), start):
            if i >= stop_s * 25:
                break
            r = det.process(gray, (i - start) / 25)
            now_clear = sum(_demo_schedule(i, fps=25)) == 0
            settled = sum(_demo_schedule(max(i - 75, 0), fps=25)) == 0
            if now_clear and settled and r.state == State.OK:
                clear += 1
                false += r.rain
                episodes += r.rain and not was
            was = r.rain
    assert clear > 800
    assert episodes == 0 and false == 0, (episodes, false)


def test_dark_scene_says_dark():
    res = _run(SceneParams(darkness=0.93, rain=StreakParams()), 80)
    assert all(r.state in (State.DARK, State.WARMING_UP) for r, _ in res)
    assert not any(r.rain for r, _ in res)


def test_precipitation_is_detected():
    """Rain through every distractor at once is seen after the warm-up (frames 90-199). Light
    rain and snow, on their own, are asserted the same way, on the first 250 frames of
    ``test_steady_precipitation_is_still_seen_after_a_minute``'s runs."""
    res = _run(SceneParams.busy(shake_px=0.0, rain=StreakParams(mu_deg=75)), 200)
    tpr = np.mean([r.rain for r, _ in res[WARMUP + 25 :]])
    assert tpr >= 0.95, tpr


@pytest.mark.parametrize(
    "name,params,min_tpr",
    [
        ("steady_rain", SceneParams(cars=2, rain=StreakParams()), 0.95),
        (
            "steady_light_rain",
            SceneParams(cars=2, rain=StreakParams(count=80, brightness=25)),
            0.95,
        ),
        ("steady_snow", SceneParams(cars=2, snow=SnowParams()), 0.85),
    ],
)
def test_steady_precipitation_is_still_seen_after_a_minute(name, params, min_tpr):
    """The structure rule must not learn rain itself as structure: a daemon watches for
    hours. (A unit slip once made the per-pixel rate drift up until, after ~300 frames of
    steady rain, every streak was "structural" and detection fell to 0 %.) The same run's
    first 250 frames show it detected soon after the warm-up (frames 90-249: at least
    ``min_tpr``), and its last 150 (frames 450-599) that it still is."""
    res = _run(params, 600)
    tpr = np.mean([r.rain for r, _ in res[WARMUP + 25 : 250]])
    assert tpr >= min_tpr, (name, tpr)
    late = np.mean([r.rain for r, _ in res[450:]])
    assert late >= 0.95, (name, late)


# -- Section 7: intensity ------------------------------------------------------------------------
def test_intensity_grows_with_rain_density_into_heavy_rain():
    """R = S * Pi (eq. 31) must keep rising when streaks overlap and merge (Fig. 14). 2000
    streaks cover ~23 % of the frame in every frame."""
    means = []
    for count in (100, 300, 1000, 2000):
        params = SceneParams(rain=StreakParams(mu_deg=85, count=count), schedule=[0] * 50 + [1])
        res = _run(params, 130, seed=2)
        assert all(r.rain for r, _ in res[80:])
        means.append(np.mean([r.R for r, _ in res[80:]]))
    assert all(b > 1.3 * a for a, b in itertools.pairwise(means)), means


# -- Real clear-weather clips ----------------------------------------------------------------------
@pytest.mark.parametrize("name", ["motorway_clear_320x240.avi", "road_surface_clear_640x360.avi"])
def test_real_clear_clips_say_no_rain(shared_fixtures, name):
    import av

    det = HosDetector()
    rain = 0
    with av.open(str(shared_fixtures / "video" / name)) as container:
        for i, frame in enumerate(container.decode(video=0)):
            rain += det.process(frame.to_ndarray(format="gray"), i / 25).rain
    assert rain == 0


def test_faint_rain_at_a_low_resolution_is_seen_by_pooling_frames():
    """320x240, 4 cars, 8 faint streaks a frame: 8-10 blobs pass the rules, fewer than the 12
    a fit needs. Pooled with the frames before (decision.pool_frames = 4), they are rain on
    every frame (seeds 1-3); one frame at a time, on 0-12 %. (With 20 streaks, the size rule
    before departure 16 let only fragments through: 25-56 %; departure 16 lets the streaks
    themselves vote, and 20 a frame need no pooling.) The rate of one seed moves with any
    change upstream, so the claim is on the three together. Four pedestrians in clear weather
    make a broad population from frame to frame: no false rain."""
    from dataclasses import replace

    params = SceneParams(
        fps=15.0,
        cars=4,
        jpeg_quality=70,
        foliage_sway_px=0.8,
        sensor_noise=0.5,
        darkness=0.3,
        rain=StreakParams(mu_deg=100, count=8, length_px=11.0, brightness=25.0),
    )
    one_frame = DetectorParams()
    one_frame = replace(one_frame, decision=replace(one_frame.decision, pool_frames=1))
    pooled, single = [], []
    for seed in (1, 2, 3):
        scene = Scene(320, 240, seed=seed, params=params)
        frames = [scene.frame(i)[0] for i in range(240)]
        for detector, rates in ((HosDetector(), pooled), (HosDetector(one_frame), single)):
            rain = [detector.process(f, i / 15).rain for i, f in enumerate(frames)]
            rates.append(np.mean(rain[90:]))
    assert np.mean(pooled) >= 0.3 and np.mean(pooled) >= np.mean(single) + 0.25, (pooled, single)
    assert min(pooled) >= 0.15, pooled
    for seed in (1, 2):
        clear = Scene(320, 240, seed=seed, params=replace(params, rain=None, pedestrians=4))
        detector = HosDetector()
        assert not any(detector.process(clear.frame(i)[0], i / 15).rain for i in range(240))


def test_a_pooled_frame_still_reports_its_own_histogram():
    """``histogram`` is the frame's own HOS (its sum is S), recorded as ``/hos/<cam>/histogram``
    and averaged offline: pooling changes what is fitted, not what is reported."""
    scene = Scene(
        320,
        240,
        seed=1,
        params=SceneParams(fps=15.0, cars=4, rain=StreakParams(mu_deg=100, count=20)),
    )
    detector = HosDetector()
    few = 0
    for i in range(160):
        r = detector.process(scene.frame(i)[0], i / 15)
        if 0 < r.n_blobs < detector.params.decision.min_blobs and r.state == State.OK:
            few += 1
            assert r.histogram.sum() == pytest.approx(r.S)
    assert few >= 10


def _said_at_720_rows(scalings, *, shake_px: float) -> dict:
    """Drizzle-like streaks (5 px long, 8 grey levels, at 95 degrees) at 1280x720, with sensor
    noise: the share of frames said rain for each ``segmentation.min_area_scaling``; where
    rain is said, its smoothed orientation is within 3 degrees of the streaks'. The streaks'
    completion along their lines (departure 36) is off, so that the law alone is shown: the
    completed streaks are long enough for either law (the area law says rain on 82 % of
    these frames with it on)."""
    drizzle = StreakParams(count=500, length_px=5.0, brightness=8.0, sigma_deg=12.0, mu_deg=95)
    params = SceneParams(cars=1, rain=drizzle, sensor_noise=2.0, shake_px=shake_px)
    scene = Scene(1280, 720, seed=8, params=params)
    frames = [scene.frame(i)[0] for i in range(150)]
    said = {}
    for scaling in scalings:
        segmentation = {"min_area_scaling": scaling, "line_length": 0}
        det = HosDetector(DetectorParams.from_dict({"segmentation": segmentation}))
        results = [det.process(f, i / 25) for i, f in enumerate(frames)]
        said[scaling] = np.mean([r.rain for r in results[90:]])
        mus = [math.degrees(r.mu_smoothed) for r in results[90:] if r.rain]
        if len(mus) > 10:
            assert abs(np.median(mus) - 95) < 3, scaling
    return said


def test_short_streaks_at_720_rows_pass_the_size_rule_that_scales_with_the_height():
    """A streak is a pixel or so wide at any resolution, so its area grows as its length. The
    paper's bounds scaled with the area ask 9 pixels at 720 rows and reject nearly all of
    them; scaled with the height (``segmentation.min_area_scaling = "length"``), 6 pixels let
    them vote; ``"still"`` (the default) does so while the camera stands still
    (docs/method.md, departure 15). The length law alone is shown under the shaken camera of
    the next test, where it sees the same drizzle."""
    assert HosDetector().params.segmentation.min_area_scaling == "still"
    said = _said_at_720_rows(("area", "still"), shake_px=0.0)
    assert said["still"] > 0.9 and said["area"] < 0.1, said


def test_a_shaken_camera_at_720_rows_keeps_the_area_law():
    """``"still"``: a camera in the wind asks the area law's 9 pixels (a shaken view's edge
    fragments grow with the frame's area, as swaying foliage did at 1080 rows): the same
    drizzle under a camera shaken by 0.4 px is judged as with the area law (not seen), where
    the length law sees it."""
    said = _said_at_720_rows(("area", "still", "length", "lower"), shake_px=0.4)
    assert said["still"] == pytest.approx(said["area"], abs=0.05), said
    assert said["length"] > 0.9, said  # so the law, not the shake, decides
    # ``"lower"`` (an option, departure 47) keeps the length law under the shaken camera
    assert said["lower"] > 0.9, said


def test_below_480_rows_the_lower_law_is_the_area_law_shaken_or_not():
    """``"lower"`` (an option, departure 47) and ``"still"`` (the default) differ only above
    480 rows, where the length law is the lower: at 480x270 under a shaken camera in faint
    rain they give the same frames."""
    rain = StreakParams(count=120, length_px=5.0, brightness=12.0, sigma_deg=12.0, mu_deg=95)
    params = SceneParams(cars=2, rain=rain, sensor_noise=1.5, shake_px=0.5)
    frames = [Scene(480, 270, seed=2, params=params).frame(i)[0] for i in range(110)]
    runs = {}
    for law in ("still", "lower"):
        det = HosDetector(DetectorParams.from_dict({"segmentation": {"min_area_scaling": law}}))
        runs[law] = [det.process(f, i / 25) for i, f in enumerate(frames)]
        assert det._shaken > 0
    for a, b in zip(runs["still"], runs["lower"], strict=True):
        assert (a.rain, a.n_blobs, a.pi_smoothed) == (b.rain, b.n_blobs, b.pi_smoothed)


def test_long_streaks_at_240_rows_pass_the_size_rule_that_scales_like_a_streak():
    """Streaks 12 px long at 320x240 and 15 fps (a long exposure, a small frame): about a pixel
    wide, they cover 12-25 pixels. The paper's upper bound (50 pixels at 480 rows) scaled with
    the frame's area allows 12.5 pixels here and keeps only fragments; the larger of the area
    and the length laws (``segmentation.max_area_scaling = "streak"``, the default) allows 25
    and keeps the streaks (docs/method.md, departure 16). The thin rule (departure 25), which
    would keep them under either law, is off, and the bound is the paper's (not departure
    38's), so that the law alone is shown."""
    rain = StreakParams(count=40, length_px=12.0, brightness=30.0, sigma_deg=10.0, mu_deg=80)
    params = SceneParams(fps=15.0, cars=2, rain=rain, sensor_noise=2.0)
    frames = [Scene(320, 240, seed=4, params=params).frame(i)[0] for i in range(150)]
    said, blobs = {}, {}
    for law in ("streak", "area"):
        det = HosDetector(
            DetectorParams.from_dict(
                {"segmentation": {"max_area_scaling": law, "thin_factor": 1.0, "max_area": 50}}
            )
        )
        results = [det.process(f, i / 15) for i, f in enumerate(frames)][90:]
        said[law] = np.mean([r.rain for r in results])
        blobs[law] = np.median([r.n_blobs for r in results])
        if law == "streak":
            assert abs(np.median([math.degrees(r.mu_smoothed) for r in results]) - 80) < 3
    assert HosDetector().params.segmentation.max_area_scaling == "streak"
    assert said["streak"] > 0.95 and said["area"] < 0.1, said
    assert blobs["streak"] > 4 * blobs["area"], blobs


def test_snow_through_a_soft_lens_at_270_rows_passes_the_size_rule():
    """Snow at 480x270 in the wind through a lens that blurs by 1.2 px: the blur spreads each
    flake over more pixels, past the published bound (50 pixels at 480 rows, 28 at 270 rows),
    and the flakes' blobs are turned away as bodies. With departure 38's bound (120, so 68
    pixels at 270 rows) they vote: snow said and typed on the judged frames, where the paper's
    bound says it on none, and about twice as many blobs a frame."""
    params = SceneParams(
        snow=snow_flakes(480, 270),
        lens_blur_px=1.2,
        sensor_noise=1.5,
        cars=2,
        shake_px=0.6,
        foliage_sway_px=1.0,
        jpeg_quality=75,
    )
    scene = Scene(480, 270, seed=3, params=params)
    frames = [scene.frame(i)[0] for i in range(160)]
    said, blobs, kinds = {}, {}, {}
    for bound in (50, 120):
        det = HosDetector(DetectorParams.from_dict({"segmentation": {"max_area": bound}}))
        results = [det.process(f, i / 25) for i, f in enumerate(frames)][90:]
        said[bound] = np.mean([r.rain for r in results])
        blobs[bound] = np.median([r.n_blobs for r in results])
        kinds[bound] = results[-1].precipitation_type
    assert HosDetector().params.segmentation.max_area == 120
    assert said[120] > 0.95 and kinds[120] == "snow", (said, kinds)
    assert said[50] < 0.5, said
    assert blobs[120] > 1.5 * blobs[50], blobs


def _said_over_texture(
    decision: dict,
    draw,
    *,
    seed: int,
    robustness: dict | None = None,
    segmentation: dict | None = None,
) -> float:
    """The share of frames said rain (frames 100-199) over a still textured 320x240 scene with
    sensor noise, where ``draw(frame, i, rng)`` adds blobs to every frame from the 80th on,
    with ``decision`` (``robustness``, ``segmentation``) parameters set."""
    rng = np.random.default_rng(seed)
    bg = cv2.GaussianBlur(rng.uniform(60, 120, (240, 320)).astype(np.float32), (0, 0), 3)
    params = {
        "decision": decision,
        "robustness": robustness or {},
        "segmentation": segmentation or {},
    }
    det = HosDetector(DetectorParams.from_dict(params))
    said = []
    for i in range(200):
        f = bg + rng.normal(0, 1.0, bg.shape).astype(np.float32)
        if i >= 80:
            draw(f, i, rng)
        said.append(det.process(np.clip(f, 0, 255).astype(np.uint8), i / 25).rain)
    return float(np.mean(said[100:]))


def _few_streaks(
    places: float, *, spread: bool, stale_level: float = 1.0, found_again: float = 3.0
) -> float:
    """Three short vertical streaks a frame over a still textured scene, too few to fit alone:
    at new random places every frame (rain) or at the same places, moving a pixel every four
    frames (the parts of a distant walker). The share of frames said rain."""

    def draw(f, i, rng):
        for k in range(3):
            if spread:
                x, y = rng.integers(10, 310), rng.integers(10, 220)
            else:
                x, y = 100 + i // 4 + 3 * k, 120 + 7 * k
            f[y : y + 5, x] += 40

    robustness = {"stale_level": stale_level, "found_again_radius": found_again}
    return _said_over_texture({"pool_places": places}, draw, seed=3, robustness=robustness)


def test_a_pooled_fit_needs_its_blobs_spread_like_rain():
    """``decision.pool_places``: pooled over four frames, a few parts seen again and again in
    the same cells are no rain, while as few streaks landing somewhere new are; without the
    rule (0) the parts were rain on about half the frames. The parts stand still for three
    frames in four, so most are also copies of the last frames (departure 19), which
    ``stale_level = 0`` turns off, and moved a pixel they are found again (departure 23),
    which ``found_again_radius = 0`` turns off: each rule is shown alone."""
    alone = {"stale_level": 0.0, "found_again": 0.0}
    assert _few_streaks(0.75, spread=False, **alone) == 0.0
    assert _few_streaks(0.75, spread=True) > 0.9
    assert _few_streaks(0.0, spread=False, **alone) > 0.3
    assert _few_streaks(0.0, spread=False, found_again=0.0) == 0.0  # the copies rule alone
    assert _few_streaks(0.0, spread=False, stale_level=0.0) == 0.0  # the found again alone


def _draw_segments(f, x, y, theta, *, half_length: float) -> None:
    """Bright one-pixel segments (160 grey levels) centred at (x, y), at orientations theta
    (radians), ``half_length`` pixels each way, drawn into ``f``."""
    for x0, y0, t in zip(x, y, theta, strict=True):
        dx, dy = half_length * math.cos(t), half_length * math.sin(t)
        p, q = (round(x0 - dx), round(y0 - dy)), (round(x0 + dx), round(y0 + dy))
        cv2.line(f, p, q, 160.0, 1)


def _random_segments(
    n: int, *, margin: float, mu_deg: float, spread_deg: float | None, half_length: float
):
    """A ``draw(frame, i, rng)`` for :func:`_said_over_texture`: ``n`` segments a frame at
    random places at least ``margin`` pixels inside the 320x240 frame, their orientations
    spread by ``spread_deg`` about ``mu_deg`` (uniform over 180 degrees for None)."""

    def draw(f, i, rng):
        x, y = rng.uniform(margin, 320 - margin, n), rng.uniform(margin, 240 - margin, n)
        if spread_deg is None:
            theta = rng.uniform(0, math.pi, n)
        else:
            theta = np.radians(rng.normal(mu_deg, spread_deg, n))
        _draw_segments(f, x, y, theta, half_length=half_length)

    return draw


def _wide_population(places: float, *, gathered: bool) -> float:
    """35 short segments a frame whose orientations spread 30 degrees about the vertical (a
    snow-like population), over a still textured scene: dropped anywhere in the view (flakes)
    or anywhere in a 120x100 box (the fragments of a tree's crown swaying in the wind: new
    places every frame, too sparse for the structure rule). The share of frames said rain."""

    def draw(f, i, rng):
        n = 35
        if gathered:
            x, y = rng.uniform(20, 140, n), rng.uniform(30, 130, n)
        else:
            x, y = rng.uniform(5, 315, n), rng.uniform(5, 235, n)
        _draw_segments(f, x, y, np.radians(rng.normal(90, 30, n)), half_length=3.0)

    return _said_over_texture({"spread_places": places}, draw, seed=5)


def test_a_wide_population_must_be_spread_over_the_view():
    """``decision.spread_places``: a population as wide as snow's counts only if its blobs are
    spread over the view; gathered in one part of it (a tree's foliage in the wind), it is no
    precipitation. Without the rule (0) the gathered one is said rain."""
    assert _wide_population(0.5, gathered=False) > 0.9
    assert _wide_population(0.5, gathered=True) == 0.0
    assert _wide_population(0.0, gathered=True) > 0.5


def _short_streaks(corrected: bool, *, spread_deg: float | None) -> float:
    """Six 4-pixel segments a frame at random places, their orientations spread by
    ``spread_deg`` about the vertical (uniform over 180 degrees for None), over a still
    textured scene: too few to fit alone, pooled over frames. The share of frames said rain."""

    draw = _random_segments(6, margin=10, mu_deg=90, spread_deg=spread_deg, half_length=1.5)
    return _said_over_texture({"kernel_corrected": corrected}, draw, seed=1)


def test_short_streaks_are_judged_by_their_spread_not_their_votes_width():
    """``decision.kernel_corrected`` (docs/method.md, departure 18): 4-pixel streaks vote with
    kernels of about 20 degrees (eq. 19), so 8 degrees of spread fit sigma over the pooled
    fit's 20-degree limit. With the kernels taken out they are rain on every frame; without,
    on none. Segments at any orientation stay no rain."""
    assert _short_streaks(True, spread_deg=8.0) > 0.9
    assert _short_streaks(False, spread_deg=8.0) == 0.0
    assert _short_streaks(True, spread_deg=None) == 0.0


def _parallel_lines(sigma_min_deg: float) -> float:
    """Four bright lines of 16 pixels a frame, exactly vertical, at new places every frame:
    the lights of vehicles mirrored in a wet road, before the traffic map has learnt the
    lanes. The share of frames said rain."""

    def draw(f, i, rng):
        for _ in range(4):
            x, y = rng.integers(10, 310), rng.integers(10, 215)
            f[y : y + 16, x] += 40

    return _said_over_texture({"sigma_min_deg": sigma_min_deg}, draw, seed=4)


def test_one_orientation_repeated_is_not_rain():
    """``decision.sigma_min`` (departure 24): their fit collapses to the mixture's floor
    (1 degree), narrower than rain's orientations ever are; the control, without the limit,
    says rain. (Lines of 8 pixels vote with kernels of 4.6 degrees, eq. 19: their fit is
    wider than the limit, which catches long parallel blobs only.)"""
    assert _parallel_lines(2.0) == 0.0
    assert _parallel_lines(0.0) > 0.5


def _long_streaks(thin_factor: float, *, spread_deg: float | None) -> float:
    """Twelve one-pixel segments of 30 pixels a frame at random places, their orientations
    spread by ``spread_deg`` about 80 degrees (uniform over 180 degrees for None), over a
    still textured 320x240 scene: rain seen through a long exposure, each streak longer than
    the size rule's bound at the published 50 pixels at 480 rows (25 at 240 rows; departure
    38's 120 allows 60, and these would pass it). The share of frames said rain."""

    draw = _random_segments(12, margin=20, mu_deg=80, spread_deg=spread_deg, half_length=15.0)
    segmentation = {"thin_factor": thin_factor, "max_area": 50}
    return _said_over_texture({}, draw, seed=6, segmentation=segmentation)


def test_streaks_longer_than_the_size_bound_are_seen_when_thin():
    """``segmentation.thin_factor`` (departure 25): thin blobs up to four times the area bound
    are streaks. Sparse long streaks are rain on every frame; with the area bound alone (1)
    every one of them is too large and no rain is said. Long segments at any orientation are
    still no rain."""
    assert _long_streaks(4.0, spread_deg=5.0) > 0.9
    assert _long_streaks(1.0, spread_deg=5.0) == 0.0
    assert _long_streaks(4.0, spread_deg=None) == 0.0


def _swaying_trunks(robustness: dict, segmentation: dict | None = None) -> float:
    """Twenty bright bars 3 pixels wide and 44 long, tilted about the vertical (8 degrees),
    swaying a pixel each way at fixed places, over a still textured scene: their edges are
    thin, near vertical and longer than the size bound. The share of frames said rain."""
    rng = np.random.default_rng(11)
    x, y = rng.uniform(15, 305, 20), rng.uniform(40, 200, 20)
    theta = np.radians(rng.normal(90, 8, 20))

    def draw(f, i, _rng):
        for k in range(20):
            d = math.sin(0.9 * i + k)
            dx, dy = 22 * math.cos(theta[k]), 22 * math.sin(theta[k])
            p = (round((x[k] + d - dx) * 16), round((y[k] - dy) * 16))
            q = (round((x[k] + d + dx) * 16), round((y[k] + dy) * 16))
            cv2.line(f, p, q, 200.0, 3, cv2.LINE_AA, 4)

    return _said_over_texture({}, draw, seed=7, robustness=robustness, segmentation=segmentation)


def test_swaying_trunks_are_not_taken_for_long_streaks():
    """With the thin rule on (the default), the edges of swaying trunks are no rain: the rules
    for what recurs in place stop them. Without those rules they are rain on most frames, so
    the scene would show a rule that let them through. That is shown with the completion
    along lines (departure 36, the default since departure 40) off: with it on, the edges
    grow past the thin rule's bound, and without the rules they are rain on 13 % of the
    frames; with the rules, on none, the completion on or off."""
    assert HosDetector().params.segmentation.thin_factor > 1
    assert HosDetector().params.segmentation.line_length == 9
    assert _swaying_trunks({}) == 0.0
    assert _swaying_trunks({}, {"line_length": 0}) == 0.0
    off = {
        "found_again_radius": 0.0,
        "persistence_floor": 1.0,
        "persistence_ratio": 1000.0,
        "stale_level": 0.0,
        "traffic": False,
    }
    assert _swaying_trunks(off, {"line_length": 0}) > 0.5


def _parallel_rain(sigma_min_blobs: float, *, angle: float, n: int) -> float:
    """``n`` one-pixel segments of 16 pixels a frame, all at ``angle`` degrees, at new places
    every frame, over a still textured scene: rain drawn at one orientation (or seen through
    a telephoto lens in a steady wind). The share of frames said rain."""

    def draw(f, i, rng):
        x, y = rng.uniform(15, 305, n), rng.uniform(15, 225, n)
        _draw_segments(f, x, y, np.full(n, math.radians(angle)), half_length=8.0)

    decision = {"sigma_min_blobs": sigma_min_blobs}
    return _said_over_texture(decision, draw, seed=8)


@pytest.mark.parametrize("angle", [90.0, 75.0])
def test_many_parallel_streaks_in_one_frame_are_rain(angle):
    """``decision.sigma_min_blobs`` (departure 25): 40 streaks a frame at one orientation fit
    a Gaussian at the mixture's floor, narrower than ``sigma_min``; one frame alone explains
    more than 24 of them, so they are rain on every frame. With the exception off (0) the
    limit calls them parallel structure: no rain (on a few frames at 75 degrees, where the
    pixel grid spreads their orientations past the limit). Four such lines a frame, pooled over
    frames, stay no rain (``test_one_orientation_repeated_is_not_rain``)."""
    assert _parallel_rain(24.0, angle=angle, n=40) > 0.9
    assert _parallel_rain(0.0, angle=angle, n=40) < 0.2


def _night(
    dark_share: float, *, rain: bool, count: int = 200, local_ratio: float | None = None
) -> tuple[float, float]:
    """A street at night, 320x240: a dark textured view (mean grey about 8) with a lamp's
    pool of light over a sixth of it (grey 60-90), sensor noise 2; from frame 80, streaks
    (25 grey levels) where the lamp lights the rain. Over frames 100-199: the share of frames
    judged (``state`` ok) and the share said rain."""
    rng = np.random.default_rng(9)
    dark = cv2.GaussianBlur(rng.uniform(2, 14, (240, 320)).astype(np.float32), (0, 0), 3)
    yy, xx = np.mgrid[0:240, 0:320]
    pool = np.exp(-(((xx - 200) / 60.0) ** 2 + ((yy - 150) / 45.0) ** 2))
    scene = dark + 80.0 * pool.astype(np.float32)
    lamp = pool > 0.35  # where the rain is lit
    robustness: dict[str, float] = {"dark_share": dark_share}
    if local_ratio is not None:
        robustness["persistence_local_ratio"] = local_ratio
    det = HosDetector(DetectorParams.from_dict({"robustness": robustness}))
    streaks = StreakParams(count=count, brightness=25.0, length_px=10.0, mu_deg=85.0)
    judged, said = [], []
    for i in range(200):
        f = scene + rng.normal(0, 2.0, scene.shape).astype(np.float32)
        if rain and i >= 80:
            f += render_streaks((240, 320), streaks, rng).layer * lamp
        r = det.process(np.clip(f, 0, 255).astype(np.uint8), i / 25)
        if i >= 100:
            judged.append(r.state == State.OK)
            said.append(r.rain)
    return float(np.mean(judged)), float(np.mean(said))


def test_rain_in_a_lamps_light_at_night_is_judged():
    """``robustness.dark_share`` (departure 26): a view whose mean grey level is 8 but whose
    brightest tenth is lit is judged, and the rain in the lamp's light is seen; clear, the
    same night says no rain. With the mean compared instead (0, as before) the camera says
    ``dark`` on every frame and no rain. A view with nothing lit stays ``dark``
    (``test_dark_scene_says_dark``)."""
    judged, said = _night(0.1, rain=True)
    assert judged > 0.95 and said > 0.9
    judged, said = _night(0.1, rain=False)
    assert judged > 0.95 and said == 0.0
    judged, said = _night(0.0, rain=True)
    assert judged == 0.0 and said == 0.0


def test_dense_rain_in_a_lamps_light_is_not_structure_against_the_rate_around_it():
    """``robustness.persistence_local_ratio`` (departure 28, an option): three times the rain
    in the same lamp's pool (600 streaks a frame over the view, about 70 lit) makes the pool's
    pixels candidates far more often than the view's mean, and the structure rule compared
    with the whole view alone (the default) takes the rain for structure (rain on 16 % of
    the frames). Compared with the rate around each blob too (2), it is rain on every frame;
    clear, the same night is still never rain."""
    judged, said = _night(0.1, rain=True, count=600, local_ratio=2.0)
    assert judged > 0.95 and said > 0.9
    judged, said = _night(0.1, rain=False, count=600, local_ratio=2.0)
    assert judged > 0.95 and said == 0.0
    judged, said = _night(0.1, rain=True, count=600)
    assert said < 0.5


def _snow_over_plain_view(
    gradient: str, *, size=(480, 640), blur=1.5, frames=200, explained: float | None = None
):
    """Snow whose flakes persist and fall 3 px a frame (at 480 rows) from frame 60 over a still,
    nearly plain view (a random texture blurred by ``blur`` px, grey-level deviation 3), with
    sensor noise: the shares of frames 100 on that are ``unstable`` and said precipitation."""
    h, w = size
    rng = np.random.default_rng(1)
    view = cv2.GaussianBlur(rng.uniform(60, 120, (h, w)).astype(np.float32), (0, 0), blur)
    snow = SnowParams(count=int(250 * w * h / (640 * 360)), blur_px=3.0, fall_px=3.0 * h / 480)
    robustness: dict[str, object] = {"motion_gradient": gradient}
    if explained is not None:
        robustness["motion_explained"] = explained
    det = HosDetector(DetectorParams.from_dict({"robustness": robustness}))
    unstable, said = [], []
    for i in range(frames):
        f = np.clip(view + rng.normal(0, 1.0, (h, w)), 0, 255).astype(np.uint8)
        if i >= 60:
            f = composite(f, render_falling_snow((h, w), snow, 7, i, pool=2 * snow.count + 64))
        r = det.process(f, i / 25)
        if i >= 100:
            unstable.append(r.state == State.UNSTABLE)
            said.append(r.rain)
    return float(np.mean(unstable)), float(np.mean(said))


@pytest.mark.parametrize("gradient", ["shorter", "mean"])
def test_falling_snow_over_a_plain_view_is_not_camera_motion(gradient):
    """``robustness.motion_gradient`` (departure 27): over a view with little texture of its
    own, flakes falling together are the only texture a frame shows. The camera-offset fit on
    the reference's gradients sees only the view's texture, and the still camera is judged
    and says snow (``"shorter"``, the default, keeps that fit's offset). On the gradients of
    the mean of the reference and the frame alone (``"mean"``, as before) the flakes' fall was
    read as a camera being re-aimed: ``unstable`` on every frame, unless the offset is checked
    against the frame (departure 33, ``robustness.motion_explained``; off here, to show the
    fit alone)."""
    unstable, said = _snow_over_plain_view(gradient, explained=0.0)
    if gradient == "mean":
        assert unstable > 0.9 and said < 0.1
    else:
        assert unstable < 0.05 and said > 0.9


@pytest.mark.parametrize("gradient", ["shorter", "mean"])
def test_falling_snow_pulls_no_offset_past_the_check(gradient):
    """Departure 33: the flakes' fall read by either fit does not explain the frame (moved
    back by it, the still view matches worse), so the still camera is judged and says snow
    with either fit."""
    unstable, said = _snow_over_plain_view(gradient)
    assert unstable < 0.05 and said > 0.9
