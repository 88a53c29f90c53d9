"""Rain or snow (hos/ptype.py): the per-frame score, its invariances, the temporal vote, and the
whole detector on rendered rain, snow and clear weather."""

from __future__ import annotations

import math
from dataclasses import fields, replace

import cv2
import numpy as np
import pytest

from drivers.simulator import Scene, SceneParams, SnowParams, StreakParams
from drivers.simulator.demo import demo_params
from drivers.simulator.families import snow_flakes
from drivers.simulator.precipitation import render_snow, render_streaks
from hos.blobs import find_blobs
from hos.params import ANGLE_PARAMETERS, DetectorParams
from hos.pipeline import HosDetector
from hos.ptype import (
    RAIN,
    SNOW,
    UNKNOWN,
    PrecipitationTypeVote,
    PtypeParams,
    StreakShape,
    blob_contrast,
    frame_score,
    frame_vote,
    streak_shape,
)

P = PtypeParams()


def _shape(
    elongation: float, sigma_deg: float, across: float, n: int = 50, contrast: float = math.nan
) -> StreakShape:
    return StreakShape(
        n, elongation, 1.5, 1.5 * elongation, math.radians(sigma_deg), contrast, across
    )


# -- the per-frame score ------------------------------------------------------------------------
def test_typical_values_score_minus_one_and_plus_one() -> None:
    rain = _shape(P.elongation_rain, math.degrees(P.sigma_rain), P.across_rain)
    snow = _shape(P.elongation_snow, math.degrees(P.sigma_snow), P.across_snow)
    assert frame_score(rain) == pytest.approx(-1.0)
    assert frame_score(snow) == pytest.approx(1.0)
    assert (frame_vote(rain), frame_vote(snow)) == (RAIN, SNOW)
    # half-way in every feature (geometric means): no vote
    mid = _shape(
        math.sqrt(P.elongation_rain * P.elongation_snow),
        math.degrees(math.sqrt(P.sigma_rain * P.sigma_snow)),
        math.sqrt(P.across_rain * P.across_snow),
    )
    assert frame_score(mid) == pytest.approx(0.0, abs=1e-12)
    assert frame_vote(mid) == UNKNOWN


def test_each_feature_pulls_its_way_and_no_single_one_decides() -> None:
    base = _shape(2.3, 21.0, 37.0)
    assert frame_score(_shape(6.0, 21.0, 37.0)) < frame_score(base)  # longer, thinner: rain
    assert frame_score(_shape(2.3, 35.0, 37.0)) > frame_score(base)  # wider spread: snow
    assert frame_score(_shape(2.3, 21.0, 90.0)) > frame_score(base)  # brighter: snow
    # a blinding brightness (headlights) is clipped: long parallel streaks still say rain
    assert frame_vote(_shape(5.0, 8.0, 600.0)) == RAIN


def test_the_brightness_is_the_one_the_parameters_name() -> None:
    # "across" (the default) reads the brightness summed across the blobs; "mean" (the
    # releases before) their mean contrast: each ignores the other
    mean = PtypeParams(brightness="mean")
    blurred_flakes = _shape(  # dim, as a blurred flake is, but as bright summed across as snow
        P.elongation_snow, math.degrees(P.sigma_snow), P.across_snow, contrast=P.contrast_rain
    )
    assert frame_score(blurred_flakes) == pytest.approx(1.0)
    assert frame_score(blurred_flakes, mean) == pytest.approx((1 + 1 - 1) / 3)
    only_mean = _shape(
        P.elongation_snow, math.degrees(P.sigma_snow), math.nan, contrast=P.contrast_rain
    )
    assert frame_score(only_mean) == pytest.approx(1.0)  # no sum across: left out
    assert frame_score(only_mean, mean) == pytest.approx(1 / 3)
    with pytest.raises(ValueError, match="brightness"):
        PtypeParams(brightness="peak")  # type: ignore[arg-type]


def test_missing_features_are_left_out_and_thin_evidence_does_not_vote() -> None:
    no_fit = _shape(P.elongation_snow, math.nan, math.nan)
    assert frame_score(no_fit) == pytest.approx(1.0)  # the elongation alone
    assert math.isnan(frame_score(_shape(1.5, 30.0, 50.0, n=P.min_blobs - 1)))
    assert frame_vote(_shape(1.5, 30.0, 50.0, n=P.min_blobs - 1)) == UNKNOWN
    assert math.isnan(frame_score(StreakShape(0, math.nan, math.nan, math.nan, 0.3)))


def test_streak_shape_medians_by_hand_and_scale_invariance() -> None:
    a = np.array([6.0, 4.0, 8.0, 2.0])
    b = np.array([1.0, 2.0, 1.0, 1.0])
    s = streak_shape(a, b, sigma=0.2, height=480, contrast=np.array([10.0, 20.0, 30.0, np.nan]))
    assert s.n == 4
    assert s.elongation == pytest.approx(np.median([6, 2, 8, 2]))  # 4.0
    assert (s.width_px, s.length_px) == (pytest.approx(1.0), pytest.approx(5.0))
    assert (s.sigma, s.contrast) == (0.2, pytest.approx(20.0))
    assert s.across == pytest.approx(np.median([10 * 1, 20 * 2, 30 * 1]))  # NaN left out
    # the same blobs filmed at twice the resolution: twice as long and wide, the same shape
    s2 = streak_shape(2 * a, 2 * b, sigma=0.2, height=960, contrast=np.array([10, 20, 30, np.nan]))
    assert (s2.elongation, s2.width_px, s2.length_px) == pytest.approx(
        (s.elongation, s.width_px, s.length_px)
    )
    # the brightness across is in the frame's own pixels (departure 39): a streak twice as
    # wide and as bright carries twice as much
    assert s2.across == pytest.approx(2 * s.across)
    few = PtypeParams(min_blobs=1)
    assert math.isfinite(frame_score(s, few))
    mean = PtypeParams(min_blobs=1, brightness="mean")
    assert frame_score(s2, mean) == pytest.approx(frame_score(s, mean))
    # a streak as wide in pixels at any frame size (the drops near focus) scores alike
    s3 = streak_shape(2 * a, b, sigma=0.2, height=960, contrast=np.array([10, 20, 30, np.nan]))
    assert s3.across == pytest.approx(s.across)
    empty = streak_shape(np.zeros(0), np.zeros(0), sigma=math.nan, height=480)
    assert empty.n == 0 and math.isnan(empty.elongation)
    with pytest.raises(ValueError, match="one shape"):
        streak_shape(a, b[:2], sigma=0.1, height=480)
    with pytest.raises(ValueError, match="contrast"):
        streak_shape(a, b, sigma=0.1, height=480, contrast=np.ones(3))
    unknown = streak_shape(a, b, sigma=0.1, height=480, contrast=np.full(4, np.nan))
    assert math.isnan(unknown.contrast) and math.isnan(unknown.across)


def test_blob_contrast_by_hand() -> None:
    image = np.array([[10, 50, 0], [0, 0, 90]], np.uint8)
    background = np.array([[5, 20, 0], [0, 0, 30]], np.uint8)
    index = np.array([0, 1, 5])
    labels = np.array([1, 1, 2])
    c = blob_contrast(image, background, index, labels, 3)
    assert math.isnan(c[0])
    assert c[1:].tolist() == [pytest.approx((5 + 30) / 2), pytest.approx(60.0)]
    assert image[0, 0] == 10 and background[0, 1] == 20  # inputs untouched


def _shape_of(
    image: np.ndarray, mask: np.ndarray, height: int, sigma: float, max_area: int
) -> StreakShape:
    """What the detector's steps 3-4 would see of ``image`` (the precipitation on a black
    street) with ``mask`` as its candidates and the size rule's bound ``max_area``."""
    blobs = find_blobs(mask.astype(np.uint8) * 255)
    area = (height / 480) ** 2
    m = blobs.moments
    keep = np.flatnonzero((m.area >= 4 * area) & (m.area <= max_area * area))
    keep = keep[keep > 0]
    contrast = blob_contrast(
        image, np.zeros_like(image), blobs.index, blobs.pixel_labels, blobs.n_labels
    )
    return streak_shape(m.a[keep], m.b[keep], sigma=sigma, height=height, contrast=contrast[keep])


def _rendered_shape(layer, shape: tuple[int, int], sigma: float) -> StreakShape:
    """A precipitation layer as drawn, its drawn pixels the candidates, the published bound."""
    image = np.clip(layer.layer + 0.5, 0, 255).astype(np.uint8)
    return _shape_of(image, layer.mask, shape[0], sigma, max_area=50)


@pytest.mark.parametrize("scale", [1, 2])
def test_rendered_streaks_and_flakes_vote_their_type_at_any_scale(scale: int) -> None:
    shape = (360 * scale, 640 * scale)
    rain = render_streaks(
        shape, StreakParams(count=300 * scale**2, length_px=9.0 * scale, brightness=25.0), rng=3
    )
    snow = render_snow(
        shape,
        SnowParams(count=220 * scale**2, radius_px=(scale, 3.0 * scale), blur_px=3.0 * scale),
        rng=4,
    )
    rain_shape = _rendered_shape(rain, shape, sigma=math.radians(11.0))
    snow_shape = _rendered_shape(snow, shape, sigma=math.radians(30.0))
    assert frame_vote(rain_shape) == RAIN, rain_shape
    assert frame_vote(snow_shape) == SNOW, snow_shape


def _blurred_shape(layer, shape: tuple[int, int], sigma: float, lens_px: float) -> StreakShape:
    """As :func:`_rendered_shape`, the layer seen through a lens that blurs by ``lens_px``
    (a Gaussian's standard deviation), its pixels found by eq. 8 (c = 3) as the detector
    would, the size rule at its default bound."""
    seen = (
        cv2.GaussianBlur(layer.layer.astype(np.float32), (0, 0), lens_px)
        if lens_px
        else layer.layer
    )
    image = np.clip(seen + 0.5, 0, 255).astype(np.uint8)
    return _shape_of(image, image >= 3, shape[0], sigma, max_area=120)


@pytest.mark.parametrize("lens_px", [0.0, 0.8, 1.2])
def test_a_soft_lens_keeps_the_brightness_across_and_the_type(lens_px: float) -> None:
    # departure 39: a blur spreads a flake and dims it, the mean contrast voting rain, but
    # leaves what is summed across it. Windy snow (flakes drawn 3 px along a narrow spread):
    # round-ish, bright; rain: long, faint. Both keep their type through the lens.
    shape = (360, 640)
    rain = render_streaks(shape, StreakParams(count=300, length_px=9.0, brightness=25.0), rng=3)
    snow = render_snow(
        shape, SnowParams(count=300, radius_px=(1.0, 2.0), blur_px=3.0, sigma_deg=12.0), rng=4
    )
    rain_shape = _blurred_shape(rain, shape, math.radians(11.0), lens_px)
    snow_shape = _blurred_shape(snow, shape, math.radians(14.0), lens_px)
    assert frame_vote(rain_shape) == RAIN, rain_shape
    assert frame_vote(snow_shape) == SNOW, snow_shape
    sharp = _blurred_shape(snow, shape, math.radians(14.0), 0.0)
    # the mean contrast falls with the blur; the brightness across, far less
    if lens_px >= 1.0:
        assert snow_shape.contrast < 0.5 * sharp.contrast
        assert snow_shape.across > 0.5 * sharp.across
        mean = PtypeParams(brightness="mean")
        assert frame_vote(snow_shape, mean) != SNOW  # what the releases before said


# -- the temporal vote --------------------------------------------------------------------------
def test_the_vote_needs_a_majority_and_has_hysteresis() -> None:
    p = PtypeParams(window_frames=20, min_votes=5, switch_share=0.7, forget_frames=10)
    vote = PrecipitationTypeVote(p)
    said = [vote.update(RAIN, precipitating=True) for _ in range(6)]
    assert said[:4] == [UNKNOWN] * 4 and said[4:] == [RAIN, RAIN]
    # a split window (60 % snow) does not change the answer
    for v in [SNOW, SNOW, SNOW, RAIN, RAIN] * 4:
        assert vote.update(v, precipitating=True) == RAIN
    # unknown frames do not count either way
    for _ in range(30):
        assert vote.update(UNKNOWN, precipitating=True) == RAIN
    # a clear majority of snow switches it
    said = [vote.update(SNOW, precipitating=True) for _ in range(20)]
    assert said[-1] == SNOW and RAIN not in said[said.index(SNOW) :]
    # no precipitation: unknown; a short gap keeps the votes, a long one forgets them
    assert vote.update(SNOW, precipitating=False) == UNKNOWN
    assert vote.update(UNKNOWN, precipitating=True) == SNOW
    for _ in range(10):
        vote.update(UNKNOWN, precipitating=False)
    assert vote.current == UNKNOWN
    assert vote.update(RAIN, precipitating=True) == UNKNOWN  # counting again from nothing
    with pytest.raises(ValueError, match="vote"):
        vote.update("hail", precipitating=True)


def test_parameters_from_the_config_and_bad_ones_name_the_key() -> None:
    params = DetectorParams.from_dict(
        {"precipitation_type": {"sigma_snow_deg": 28.0, "min_votes": 5}}
    )
    assert params.precipitation_type.sigma_snow == pytest.approx(math.radians(28.0))
    assert params.precipitation_type.min_votes == 5
    assert HosDetector(params)._ptype.params is params.precipitation_type
    with pytest.raises(ValueError, match=r"^detector\.precipitation_type\.min_votes: "):
        DetectorParams.from_dict({"precipitation_type": {"window_frames": 5, "min_votes": 6}})
    # only angles take degrees: a mistyped suffix is refused, not read as radians
    with pytest.raises(ValueError, match=r"across_rain_deg: across_rain is not an angle"):
        DetectorParams.from_dict({"precipitation_type": {"across_rain_deg": 26.0}})
    groups = [getattr(DetectorParams(), f.name) for f in fields(DetectorParams)]
    names = {f.name for g in groups for f in fields(g)}
    assert ANGLE_PARAMETERS <= names  # every angle named is a parameter
    with pytest.raises(ValueError, match=r"^sigma_\*: must be > 0 and differ"):
        PtypeParams(sigma_rain=0.3, sigma_snow=0.3)


# -- the whole detector on rendered scenes --------------------------------------------------------
def _types(weather: str, *, seed: int, frames: int = 100) -> list[str]:
    schedule = {"clear": (0.0, 0.0), "rain": (1.0, 0.0), "snow": (0.0, 1.0)}[weather]
    params = demo_params(640, 360, schedule=lambda i: schedule)
    scene = Scene(640, 360, seed=seed, params=params)
    det = HosDetector()
    out = []
    for i, (gray, _) in enumerate(scene.frames(0, frames)):
        r = det.process(gray, i / 25)
        assert r.precipitation_type == UNKNOWN or r.rain  # a type only with precipitation
        out.append(r.precipitation_type)
    return out


@pytest.mark.parametrize(("weather", "seed"), [("rain", 5), ("snow", 5), ("clear", 5), ("snow", 6)])
def test_rendered_rain_is_rain_snow_is_snow_clear_is_unknown(weather: str, seed: int) -> None:
    types = _types(weather, seed=seed)
    if weather == "clear":
        assert set(types) == {UNKNOWN}
        return
    other = SNOW if weather == RAIN else RAIN
    assert other not in types
    assert types[-20:] == [weather] * 20, types[60:]


def test_mixed_rain_and_snow_never_flips_between_the_two() -> None:
    # rain and snow falling at once: whatever the vote says, it must not flicker between them
    params = SceneParams(
        rain=StreakParams(count=200, length_px=7.0, sigma_deg=15.0),
        snow=SnowParams(count=150),
        schedule=(1.0, 1.0),
    )
    scene = Scene(640, 360, seed=9, params=params)
    det = HosDetector()
    types = [
        det.process(g, i / 25).precipitation_type for i, (g, _) in enumerate(scene.frames(0, 100))
    ]
    said = [t for t in types if t != UNKNOWN]
    assert said, "the mixture is precipitation: something is said after the warm-up"
    assert len(set(said)) == 1, said


def test_windy_snow_through_a_soft_lens_is_typed_snow() -> None:
    # departure 39 on the whole detector: snow drifting at 80 deg in the wind (flakes drawn
    # 3 px along a 12 deg spread) at 480x270 through a lens that blurs by 1.5 px. Its flakes
    # are as dim as rain's streaks: their mean contrast leaves the type unknown, the
    # brightness summed across them says snow. Fall not seen (flakes drawn anew each frame).
    snow = replace(snow_flakes(480, 270), sigma_deg=12.0, blur_px=3.0, mu_deg=80.0)
    params = SceneParams(
        snow=snow,
        lens_blur_px=1.5,
        sensor_noise=1.5,
        cars=2,
        foliage_sway_px=1.0,
        jpeg_quality=75,
    )
    scene = Scene(480, 270, seed=2, params=params)
    frames = [scene.frame(i)[0] for i in range(200)]
    types = {}
    for brightness in ("across", "mean"):
        det = HosDetector(
            DetectorParams.from_dict({"precipitation_type": {"brightness": brightness}})
        )
        results = [det.process(f, i / 25) for i, f in enumerate(frames)][90:]
        assert all(r.rain for r in results), brightness
        types[brightness] = [r.precipitation_type for r in results]
    assert types["across"] == [SNOW] * len(types["across"])
    assert types["mean"].count(UNKNOWN) > len(types["mean"]) // 2, types["mean"]
    assert RAIN not in types["mean"]
