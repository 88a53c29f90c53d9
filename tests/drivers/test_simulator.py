import itertools
import math

import av
import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from drivers.simulator import (
    VISIBLE_C,
    Scene,
    SceneParams,
    SnowParams,
    StreakParams,
    _demo_schedule,
    composite,
    demo_frames,
    render_falling_snow,
    render_snow,
    render_streaks,
    write_video,
)
from drivers.simulator.scene import fit_view, view_centre_range, view_fits, view_matrix

SIZE = (160, 96)  # (W, H) of the scenes: small, so that the file runs in a few seconds


def _wrapped_deg(theta: np.ndarray, mu_deg: float) -> np.ndarray:
    """Orientations in degrees relative to ``mu_deg``, wrapped to [-90, 90)."""
    return np.mod(np.degrees(theta) - mu_deg + 90.0, 180.0) - 90.0


def _moments(mask: np.ndarray) -> tuple[float, float, float, float, float]:
    """Centroid and central second-order moments (x0, y0, m20, m11, m02) of a mask, by hand."""
    ys, xs = np.nonzero(mask)
    x0, y0 = xs.mean(), ys.mean()
    dx, dy = xs - x0, ys - y0
    return x0, y0, (dx * dx).mean(), (dx * dy).mean(), (dy * dy).mean()


def _single_streak(theta_deg: float, length: float = 21.0):
    """One streak of a given orientation, its centre far enough from the border to be whole."""
    params = StreakParams(
        mu_deg=theta_deg,
        sigma_deg=0.0,
        count=1,
        length_px=length,
        length_jitter=0.0,
        brightness=120.0,
        brightness_jitter=0.0,
    )
    for seed in range(200):
        layer = render_streaks((64, 64), params, np.random.default_rng(seed))
        if np.all((layer.centers >= length) & (layer.centers <= 63 - length)):
            return layer
    raise AssertionError("no seed put the streak inside the frame")


# -- streaks ------------------------------------------------------------------------------------


@pytest.mark.parametrize("mu_deg", [65.0, 90.0, 3.0])
def test_orientations_follow_the_requested_mixture(mu_deg):
    # The paper's check (section 4.3): mu = 65, sigma = 10, 40 % uniform noise. mu = 3 wraps.
    params = StreakParams(mu_deg=mu_deg, sigma_deg=10.0, noise_fraction=0.4, count=5000)
    layer = render_streaks((270, 480), params, np.random.default_rng(1))
    assert layer.theta.shape == (5000,) and layer.is_noise.shape == (5000,)
    assert np.all((layer.theta >= 0) & (layer.theta < np.pi))
    assert layer.is_noise.mean() == pytest.approx(0.4, abs=0.025)
    gauss = _wrapped_deg(layer.theta[~layer.is_noise], mu_deg)
    assert gauss.mean() == pytest.approx(0.0, abs=0.6)  # standard error 10 / sqrt(3000) = 0.18
    assert gauss.std() == pytest.approx(10.0, rel=0.06)
    counts = np.histogram(np.degrees(layer.theta[layer.is_noise]), bins=6, range=(0, 180))[0]
    assert counts / counts.sum() == pytest.approx(np.full(6, 1 / 6), abs=0.03)


def test_lengths_and_centres():
    params = StreakParams(length_px=15.0, length_jitter=0.2, count=3000)
    layer = render_streaks((200, 300), params, np.random.default_rng(2))
    assert layer.lengths.mean() == pytest.approx(15.0, rel=0.02)
    assert layer.lengths.std() == pytest.approx(3.0, rel=0.08)
    x, y = layer.centers.T
    assert x.min() >= -0.5 and x.max() < 299.5 and y.min() >= -0.5 and y.max() < 199.5
    assert x.mean() == pytest.approx(149.5, abs=4) and y.mean() == pytest.approx(99.5, abs=3)


@pytest.mark.parametrize("theta_deg", [0.0, 30.0, 45.0, 60.0, 90.0, 120.0, 135.0, 170.0])
def test_a_single_streak_has_the_requested_orientation(theta_deg):
    layer = _single_streak(theta_deg)
    x0, y0, m20, m11, m02 = _moments(layer.mask)
    # The ellipse's axis in the project's convention (eq. 14, see hos/moments.py).
    got = math.degrees(0.5 * math.atan2(2 * m11, m20 - m02)) % 180.0
    assert abs((got - theta_deg + 90.0) % 180.0 - 90.0) < 1.5
    assert (x0, y0) == pytest.approx(tuple(layer.centers[0]), abs=0.7)  # thresholded mask
    # Sub-pixel endpoints: the intensity-weighted centroid is where the streak says it is.
    ys, xs = np.mgrid[0:64, 0:64]
    total = layer.layer.sum()
    weighted = ((layer.layer * xs).sum() / total, (layer.layer * ys).sum() / total)
    assert weighted == pytest.approx(tuple(layer.centers[0]), abs=0.15)


def test_vertical_and_diagonal_streaks_by_hand():
    _, _, m20, m11, m02 = _moments(_single_streak(90.0).mask)
    assert m02 > 10 * m20 and abs(m11) < 0.1 * m02  # vertical: spans y, not x
    _, _, m20, m11, m02 = _moments(_single_streak(45.0).mask)
    assert m11 > 0.8 * math.sqrt(m20 * m02)  # x and y grow together: top-left to bottom-right
    assert m20 == pytest.approx(m02, rel=0.1)
    _, _, m20, m11, m02 = _moments(_single_streak(135.0).mask)
    assert m11 < -0.8 * math.sqrt(m20 * m02)  # x grows as y shrinks: top-right to bottom-left


def test_a_streak_is_antialiased_and_as_bright_as_asked():
    layer = _single_streak(90.0)
    rows = layer.layer[layer.layer.sum(axis=1) > 0][3:-3]  # away from the rounded ends
    # OpenCV's antialiased profile is about 1.4 px wide: the core pixel gets 0.7-0.9 of the
    # brightness depending on where the streak falls within it.
    assert np.all((rows.max(axis=1) >= 0.65 * 120) & (rows.max(axis=1) <= 120))
    assert rows.sum(axis=1) == pytest.approx(1.37 * 120, rel=0.08)
    assert np.unique(rows).size > 2  # antialiased edges, not a binary line


@pytest.mark.parametrize("render", [render_streaks, render_snow])
def test_masks_are_the_thresholded_layer_split_in_two(render):
    params = (
        StreakParams(noise_fraction=0.3, count=800)
        if render is render_streaks
        else SnowParams(noise_fraction=0.3, count=400)
    )
    layer = render((120, 200), params, np.random.default_rng(3))
    assert layer.layer.dtype == np.float32 and layer.layer.shape == (120, 200)
    np.testing.assert_array_equal(layer.mask, layer.layer >= VISIBLE_C)
    assert not np.any(layer.rain_mask & layer.noise_mask)
    np.testing.assert_array_equal(layer.rain_mask | layer.noise_mask, layer.mask)
    assert layer.rain_mask.sum() > 2 * layer.noise_mask.sum() > 0


def test_ground_truth_follows_the_population():
    only_rain = render_streaks((100, 100), StreakParams(noise_fraction=0.0), 4)
    only_noise = render_streaks((100, 100), StreakParams(noise_fraction=1.0), 4)
    assert only_rain.mask.any() and not only_rain.noise_mask.any()
    assert only_noise.mask.any() and not only_noise.rain_mask.any()


def test_render_is_reproducible_and_seeded():
    a = render_streaks((80, 120), StreakParams(), np.random.default_rng(7))
    b = render_streaks((80, 120), StreakParams(), np.random.default_rng(7))
    c = render_streaks((80, 120), StreakParams(), np.random.default_rng(8))
    np.testing.assert_array_equal(a.layer, b.layer)
    assert not np.array_equal(a.layer, c.layer)


def test_snow_flakes_are_small_bright_blobs():
    p = SnowParams(count=300, level=220.0, level_jitter=0.0, blur_px=0.0, blur_jitter=0.0)
    snow = render_snow((200, 300), p, np.random.default_rng(5))
    assert snow.blend == "max"
    assert snow.layer.max() == pytest.approx(220.0, abs=2.0)
    core = (snow.layer >= 110).sum() / 300  # half-level footprint: radius 1-3 px discs
    assert math.pi * 1.0**2 < core < math.pi * 2.0**2  # small flakes are the most frequent
    wide = render_snow((200, 300), SnowParams(count=3000), np.random.default_rng(5))
    assert _wrapped_deg(wide.theta, 90.0).std() == pytest.approx(25.0, rel=0.08)


@settings(max_examples=40, deadline=None)
@given(
    mu=st.floats(-720.0, 720.0),
    sigma=st.floats(0.0, 200.0),
    noise=st.floats(0.0, 1.0),
    seed=st.integers(0, 2**32 - 1),
)
def test_orientations_always_in_range(mu, sigma, noise, seed):
    p = StreakParams(mu_deg=mu, sigma_deg=sigma, noise_fraction=noise, count=50)
    theta = render_streaks((8, 8), p, seed).theta
    assert np.all((theta >= 0) & (theta < np.pi))


def _mean_orientation_deg(theta_deg: float, length: float, supersample: int) -> float:
    """Mean intensity-weighted orientation of 200 single streaks at random sub-pixel places."""
    rng = np.random.default_rng(11)
    params = StreakParams(
        mu_deg=theta_deg,
        sigma_deg=0.0,
        length_px=length,
        length_jitter=0.0,
        brightness_jitter=0.0,
        count=1,
        supersample=supersample,
    )
    ys, xs = np.mgrid[0:40, 0:40]
    got = []
    for _ in range(200):
        layer = render_streaks((40, 40), params, rng).layer.astype(np.float64)
        x0, y0 = (layer * xs).sum() / layer.sum(), (layer * ys).sum() / layer.sum()
        dx, dy = xs - x0, ys - y0
        m20, m11, m02 = ((layer * d).sum() for d in (dx * dx, dx * dy, dy * dy))
        got.append(math.degrees(0.5 * math.atan2(2 * m11, m20 - m02)) % 180.0)
    return float(np.mean(got))


@pytest.mark.parametrize("length", [5, 11])
def test_supersampled_streaks_have_no_orientation_bias(length):
    """OpenCV's antialiased lines cut their ends square to the major axis, so a short line
    leans toward the diagonal; the supersampled rectangles do not (Fig. 6 depends on it)."""
    exact = _mean_orientation_deg(55.0, length, supersample=8)
    assert exact == pytest.approx(55.0, abs=0.3)
    if length == 5:
        assert _mean_orientation_deg(55.0, length, supersample=1) < 53.5  # the artefact


def test_invalid_parameters_name_the_field():
    with pytest.raises(ValueError, match=r"StreakParams\.noise_fraction"):
        StreakParams(noise_fraction=1.5)
    with pytest.raises(ValueError, match=r"StreakParams\.supersample"):
        StreakParams(supersample=0)
    with pytest.raises(ValueError, match=r"SnowParams\.radius_px"):
        SnowParams(radius_px=(3.0, 1.0))
    with pytest.raises(ValueError, match=r"SceneParams\.darkness"):
        SceneParams(darkness=1.0)


# -- composite ----------------------------------------------------------------------------------


def test_composite_saturates_and_leaves_inputs_alone():
    bg = np.array([[10, 250], [100, 0]], np.uint8)
    values = np.array([[5.0, 20.0], [0.0, 3.4]], np.float32)
    bg_before, values_before = bg.copy(), values.copy()
    out = composite(bg, values)
    np.testing.assert_array_equal(out, [[15, 255], [100, 3]])
    assert out.dtype == np.uint8
    np.testing.assert_array_equal(bg, bg_before)
    np.testing.assert_array_equal(values, values_before)


def test_composite_of_snow_is_a_maximum():
    snow = render_snow((50, 60), SnowParams(count=40), 1)
    bg = np.full((50, 60), 128, np.uint8)
    out = composite(bg, snow)
    np.testing.assert_array_equal(out, np.maximum(128, np.rint(snow.layer)).astype(np.uint8))
    bgr = composite(np.dstack([bg] * 3), snow)
    assert bgr.shape == (50, 60, 3) and np.array_equal(bgr[:, :, 1], out)


# -- the scene ----------------------------------------------------------------------------------


def _scene(seed=0, **kw):
    return Scene(*SIZE, seed=seed, params=SceneParams(**kw))


def test_scene_frames_are_deterministic_and_random_access():
    params = SceneParams.busy(rain=StreakParams(count=60), snow=SnowParams(count=30))
    a, b = Scene(*SIZE, seed=11, params=params), Scene(*SIZE, seed=11, params=params)
    for i in range(8):  # walk a through the frames first: its caches must not matter
        a.frame(i)
    gray_a, truth_a = a.frame(7)
    gray_b, truth_b = b.frame(7)
    assert gray_a.shape == (SIZE[1], SIZE[0]) and gray_a.dtype == np.uint8
    np.testing.assert_array_equal(gray_a, gray_b)
    np.testing.assert_array_equal(a.frame(7)[0], gray_a)
    np.testing.assert_array_equal(truth_a.mask, truth_b.mask)
    assert truth_a.gain == truth_b.gain and truth_a.shake == truth_b.shake
    other = Scene(*SIZE, seed=12, params=params).frame(7)[0]
    assert np.abs(other.astype(int) - gray_a).mean() > 5  # another seed, another street


def test_rain_does_not_depend_on_the_distractors():
    dry = _scene(seed=3, rain=StreakParams(count=80)).frame(4)[1]
    busy = _scene(seed=3, rain=StreakParams(count=80), cars=2, sensor_noise=3.0).frame(4)[1]
    np.testing.assert_array_equal(dry.theta, busy.theta)


def test_truth_masks_are_what_the_photometric_rule_sees():
    scene = _scene(seed=1, rain=StreakParams(noise_fraction=0.3, count=150))
    gray, truth = scene.frame(2)
    diff = gray.astype(int) - scene.background
    assert truth.precipitation and truth.kind == "rain"
    assert truth.mu == pytest.approx(math.radians(90.0))
    assert truth.sigma == pytest.approx(math.radians(10.0))
    assert not np.any(truth.rain_mask & truth.noise_mask)
    np.testing.assert_array_equal(truth.rain_mask | truth.noise_mask, truth.mask)
    assert truth.noise_mask.any() and truth.rain_mask.sum() > truth.noise_mask.sum()
    # Rounding to integers can move a pixel across the threshold, nothing else can.
    agree = np.mean(truth.mask == (diff >= VISIBLE_C))
    assert agree > 0.998
    assert np.all(diff[~truth.mask] < VISIBLE_C + 1)


def test_snow_scene_truth():
    scene = _scene(seed=2, snow=SnowParams(count=80))
    gray, truth = scene.frame(0)
    assert truth.kind == "snow" and truth.precipitation
    assert math.degrees(truth.sigma) == pytest.approx(25.0)
    assert truth.mask.sum() > 80 and len(truth.theta) > 40
    diff = gray.astype(int) - scene.background
    assert np.all(diff[truth.mask] >= VISIBLE_C - 1)  # flakes brighten what they cover...
    assert np.all(diff >= 0)  # ...and never darken it (max compositing)
    assert np.percentile(gray[truth.mask], 90) > 200


def test_falling_snow_persists_and_falls():
    """SnowParams.fall_px: the same flakes, a few pixels lower each frame (0.5-1.5 times the
    mean fall, drifting sideways by at most a fifth of it); wrapped round the frame."""
    w, h = 200, 400
    snow = SnowParams(count=1, fall_px=4.0, radius_px=(1.5, 1.5), blur_px=0.0)
    ys = []
    for i in range(6):
        layer = render_falling_snow((h, w), snow, 9, i, pool=64)
        x0, y0, *_ = _moments(layer.mask)
        ys.append((x0, y0))
    steps = np.diff(np.array(ys), axis=0)
    steps = steps[steps[:, 1] > 0]  # a step that wrapped round the frame is left out
    assert len(steps) >= 4
    assert np.allclose(steps[:, 1], steps[0, 1], atol=0.6)
    assert 2.0 - 0.6 <= steps[0, 1] <= 6.0 + 0.6
    assert np.all(np.abs(steps[:, 0]) <= 0.2 * steps[:, 1] + 0.6)
    # many flakes: the layer one frame on is the layer shifted down, mostly
    many = SnowParams(count=60, fall_px=3.0)
    a = render_falling_snow((h, w), many, 9, 10, pool=128).mask
    b = render_falling_snow((h, w), many, 9, 11, pool=128).mask
    overlap = [(np.roll(a, k, axis=0) & b).sum() for k in range(0, 7)]
    assert overlap[0] < 0.8 * max(overlap)  # they moved...
    assert int(np.argmax(overlap)) in (2, 3, 4)  # ...down by about 3 pixels
    # a scene with falling snow draws it so, frame after frame
    scene = _scene(seed=2, snow=SnowParams(count=80, fall_px=3.0))
    m0, m1 = scene.frame(5)[1].mask, scene.frame(6)[1].mask
    overlap = [(np.roll(m0, k, axis=0) & m1).sum() for k in range(0, 7)]
    assert int(np.argmax(overlap)) in (2, 3, 4)


def test_snow_drawn_anew_is_unchanged_by_the_falling_kind():
    """fall_px = 0 draws what render_snow always drew (the benchmark's other scenes)."""
    layer = render_snow((96, 160), SnowParams(count=50), 3)
    again = render_snow((96, 160), SnowParams(count=50, fall_px=0.0), 3)
    assert np.array_equal(layer.layer, again.layer)
    with pytest.raises(ValueError, match="fall_px"):
        render_falling_snow((96, 160), SnowParams(count=5), 3, 0, pool=8)


def test_schedule_zero_is_clear_weather():
    rain = StreakParams(count=200)
    clear = _scene(seed=4, rain=rain, schedule=0.0).frame(3)
    no_rain = _scene(seed=4).frame(3)
    gray, truth = clear
    assert not truth.precipitation and truth.kind == "clear"
    assert not truth.mask.any() and truth.theta.size == 0 and math.isnan(truth.mu)
    np.testing.assert_array_equal(gray, no_rain[0])


def test_schedule_builds_clear_rain_clear_sequences_and_scales_the_count():
    schedule = [0.0] * 3 + [1.0] * 3 + [2.0] * 3 + [0.0]
    scene = _scene(seed=5, rain=StreakParams(count=100), schedule=schedule)
    truths = [scene.frame(i)[1] for i in range(12)]  # past its end, the last value holds
    assert [t.precipitation for t in truths] == [False] * 3 + [True] * 6 + [False] * 3
    n1 = np.mean([t.theta.size for t in truths[3:6]])
    n2 = np.mean([t.theta.size for t in truths[6:9]])
    assert n1 == pytest.approx(100, abs=20) and n2 == pytest.approx(200, abs=30)
    # A pair of multipliers sets rain and snow apart: here it snows, the rain is off.
    rain, snow = StreakParams(count=50), SnowParams(count=50)
    truth = _scene(seed=5, rain=rain, snow=snow, schedule=[(0.0, 1.0)]).frame(0)[1]
    assert truth.kind == "snow" and truth.rain_intensity == 0.0
    assert math.degrees(truth.sigma) == pytest.approx(25.0)  # the snow's, not the rain's


def test_shake_moves_the_edges():
    def mean_abs_diff(scene):
        frames = [scene.frame(i)[0].astype(float) for i in range(6)]
        return np.mean([np.abs(b - a).mean() for a, b in itertools.pairwise(frames)])

    still = mean_abs_diff(_scene(seed=6))
    shaken = _scene(seed=6, shake_px=0.7)
    assert still == 0.0  # nothing moves, nothing is noisy
    assert mean_abs_diff(shaken) > 0.5
    shakes = np.array([shaken.frame(i)[1].shake for i in range(40)])
    assert 0.2 < np.abs(shakes).mean() < 2.0


def test_shake_moves_the_street_and_not_the_streaks():
    # A drop falls at a random place in front of the camera, drawn antialiased at its sub-pixel
    # place: moving its layer with the street by a fraction of a pixel would blur every streak
    # a second time (to half its contrast at half a pixel), which no camera does.
    rain = StreakParams(count=120, brightness=20.0)

    def fraction(shake):  # how far from whole pixels, along the worse axis
        return max(abs(v - round(v)) for v in shake)

    # a frame the shake leaves well off whole pixels: a fraction to blur with
    i = next(i for i in range(50) if fraction(_scene(seed=9, shake_px=0.8).frame(i)[1].shake) > 0.3)

    def streaks(shake_px):
        wet = _scene(seed=9, rain=rain, shake_px=shake_px).frame(i)
        dry = _scene(seed=9, shake_px=shake_px).frame(i)[0]
        return wet[0].astype(int) - dry, wet[1]

    still, still_truth = streaks(0.0)
    shaken, shaken_truth = streaks(0.8)
    assert still.max() >= 18
    np.testing.assert_array_equal(shaken, still)
    # the truth is the drawn layer against the street under it: rounding moves a few pixels
    assert np.mean(shaken_truth.mask == still_truth.mask) > 0.999


def test_exposure_steps_change_the_mean():
    flat = _scene(seed=7)
    steps = _scene(seed=7, exposure_steps=True, exposure_interval_s=0.4)
    flat_means = [flat.frame(i)[0].mean() for i in range(0, 60, 3)]
    frames = [steps.frame(i) for i in range(0, 60, 3)]
    means = np.array([f[0].mean() for f in frames])
    gains = np.array([f[1].gain for f in frames])
    assert np.ptp(flat_means) == 0.0
    assert np.ptp(gains) > 0.1 and np.all((gains > 0.4) & (gains < 2.0))
    ratio = means / flat_means[0]
    assert ratio == pytest.approx(gains, rel=0.06)  # only saturation breaks proportionality


def test_darkness_dims_the_scene():
    day = _scene(seed=8).frame(0)[0].mean()
    night = _scene(seed=8, darkness=0.75).frame(0)[0].mean()
    assert night == pytest.approx(0.25 * day, rel=0.03)


def test_cloud_shade_darkens_part_of_the_view_and_drifts():
    sun = _scene(seed=8)
    shaded = _scene(seed=8, shade=0.4, shade_speed_px_s=25.0, shade_cover=0.4, fps=25.0)
    ratio = shaded.frame(0)[0].astype(float) / np.maximum(sun.frame(0)[0], 1)
    lit = sun.frame(0)[0] > 40  # away from dark pixels, where rounding dominates
    # light is multiplied: 1 in the sun, 0.6 under the cloud, a soft edge between
    assert ratio[lit].max() == pytest.approx(1.0, abs=0.03)
    assert ratio[lit].min() == pytest.approx(0.6, abs=0.03)
    under = np.mean(ratio[lit] < 0.8)
    assert 0.2 < under < 0.6  # about shade_cover of the view
    # 25 px/s at 25 fps: a pixel a frame to the right, 10 in 10 frames
    canvas_0 = shaded._shade_at(0)
    assert np.array_equal(shaded._shade_at(10)[:, 10:], canvas_0[:, :-10])
    # the precipitation's truth is the visible streaks of the shaded frame
    rainy = _scene(seed=8, shade=0.4, rain=StreakParams(count=200))
    _, truth = rainy.frame(3)
    assert truth.mask.any() and truth.gain == 1.0  # the shade is not a global gain


def test_a_mirrored_view_is_the_street_flipped():
    street = _scene(seed=4, cars=2, pedestrians=2, foliage_sway_px=1.0)
    mirrored = _scene(seed=4, cars=2, pedestrians=2, foliage_sway_px=1.0, view_mirror=True)
    for i in (0, 7):
        np.testing.assert_array_equal(mirrored.frame(i)[0], np.fliplr(street.frame(i)[0]))
    np.testing.assert_array_equal(mirrored.background, np.fliplr(street.background))


def test_a_view_magnifies_and_rolls_the_street_about_its_centre():
    w, h = SIZE
    p = SceneParams(view_zoom=1.5, view_centre=(0.45, 0.55), view_roll_deg=10.0)
    m = view_matrix(p, w, h)
    centre = np.array([0.45 * (w - 1), 0.55 * (h - 1)])
    mid = np.array([(w - 1) / 2, (h - 1) / 2])
    np.testing.assert_allclose(m[:, :2] @ centre + m[:, 2], mid, atol=1e-4)
    # a step to the right on the street: 1.5 times as long, turned up (counter-clockwise)
    step = m[:, :2] @ np.array([10.0, 0.0])
    assert np.hypot(*step) == pytest.approx(15.0, rel=1e-5)
    assert math.degrees(math.atan2(-step[1], step[0])) == pytest.approx(10.0, abs=1e-4)
    assert view_matrix(SceneParams(), w, h) is None  # the street as drawn


@pytest.mark.parametrize("roll", [0.0, 3.0, -4.0])
@pytest.mark.parametrize("zoom", [1.15, 1.6])
def test_a_view_anywhere_in_its_range_shows_only_the_street(zoom, roll):
    w, h = 192, 108
    (x0, x1), (y0, y1) = view_centre_range(zoom, roll, (w / h,))
    for centre in itertools.product((x0, x1), (y0, y1)):
        p = SceneParams(view_zoom=zoom, view_centre=centre, view_roll_deg=roll)
        assert view_fits(zoom, centre, roll, w / h)
        # beyond the street, the warp leaves black (the street has no pixel darker than 40)
        assert Scene(w, h, seed=2, params=p).background.min() > 20
    assert view_centre_range(1.0, 3.0, (w / h,)) is None  # a rolled view needs a zoom
    outside = SceneParams(view_zoom=1.2, view_centre=(0.05, 0.5))
    with pytest.raises(ValueError, match="view_centre"):
        Scene(w, h, params=outside)


def test_a_view_drawn_for_one_frame_is_fitted_to_another():
    # a 4:3 scene's view, rolled and aimed near its edge, drawn at 16:9: the least change
    p = SceneParams(view_zoom=1.1, view_centre=(0.5, 0.478), view_roll_deg=2.0)
    assert view_fits(1.1, (0.5, 0.478), 2.0, 4 / 3)
    assert not view_fits(1.1, (0.5, 0.478), 2.0, 16 / 9)
    q = fit_view(p, 16 / 9)
    assert view_fits(q.view_zoom, q.view_centre, q.view_roll_deg, 16 / 9)
    assert q.view_roll_deg == 2.0 and q.view_zoom >= 1.1
    assert fit_view(q, 16 / 9) is q  # a view that fits is left alone
    Scene(192, 108, params=q)


def test_a_soft_lens_blurs_the_street_and_the_drops_alike():
    rain = StreakParams(count=150, brightness=20.0)
    sharp, sharp_truth = _scene(seed=5, rain=rain).frame(2)
    soft, soft_truth = _scene(seed=5, rain=rain, lens_blur_px=1.5).frame(2)

    def fine(img):  # energy of the finest detail
        g = img.astype(np.float32)
        return float(np.mean((g - cv2.GaussianBlur(g, (0, 0), 1.0)) ** 2))

    assert fine(soft) < 0.3 * fine(sharp)
    assert soft.mean() == pytest.approx(sharp.mean(), abs=0.5)  # light is kept
    # a blurred drop is spread and dimmer: its peak over the street is lower, and fewer of
    # its pixels stand out by VISIBLE_C
    dry_sharp = _scene(seed=5).frame(2)[0].astype(int)
    dry_soft = _scene(seed=5, lens_blur_px=1.5).frame(2)[0].astype(int)
    assert (soft - dry_soft).max() < 0.6 * (sharp - dry_sharp).max()
    assert 0 < soft_truth.mask.sum() < sharp_truth.mask.sum()
    with pytest.raises(ValueError, match="lens_blur_px"):
        SceneParams(lens_blur_px=-1.0)


def test_sensor_noise_is_fresh_every_frame():
    scene = _scene(seed=9, sensor_noise=4.0)
    a, b = (scene.frame(i)[0].astype(float) for i in (0, 1))
    assert (b - a).std() == pytest.approx(4.0 * math.sqrt(2), rel=0.1)


def test_jpeg_changes_a_little():
    raw = _scene(seed=10).frame(0)[0].astype(float)
    jpeg = _scene(seed=10, jpeg_quality=75).frame(0)[0].astype(float)
    assert 0 < np.abs(jpeg - raw).mean() < 3


def test_cars_pedestrians_and_foliage_move_where_they_should():
    h = SIZE[1]
    busy = _scene(seed=11, cars=4, pedestrians=6, foliage_sway_px=2.0)
    background = _scene(seed=11).frame(0)[0].astype(float)
    changed = np.zeros(SIZE[::-1], bool)
    for i in range(0, 400, 8):
        changed |= np.abs(busy.frame(i)[0] - background) > 8
    rows = changed.mean(axis=1)
    assert rows[int(0.66 * h) : int(0.86 * h)].max() > 0.2  # traffic on the road
    assert rows[int(0.56 * h) : int(0.62 * h)].max() > 0.02  # walkers on the pavement
    assert changed[int(0.2 * h) : int(0.4 * h), : SIZE[0] // 4].mean() > 0.02  # leaves move
    assert not changed[: int(0.5 * h), SIZE[0] // 3 :].any()  # façades and sky stay put


def test_a_wet_road_adds_spray_and_reflections_around_the_vehicles_only_when_wet():
    """Spray and the lights' reflections move with the vehicles (within their lane band), are
    bright, change from frame to frame, and appear only while it rains (and 10 s after) or on
    a road that is always wet; a dry road is the scene it was."""
    h = SIZE[1]
    rain = StreakParams(count=50)
    plain = _scene(seed=12, cars=6, rain=rain)
    assert _scene(seed=12, cars=6, rain=rain, wet_road=0.0).frame(30)[0].tobytes() == (
        plain.frame(30)[0].tobytes()
    )
    wet = _scene(seed=12, cars=6, rain=rain, wet_road=1.0)
    diff = np.zeros(SIZE[::-1])
    for i in range(0, 200, 5):
        d = wet.frame(i)[0].astype(float) - plain.frame(i)[0]
        assert d.min() >= -1.0  # only brighter
        diff = np.maximum(diff, d)
    rows = (diff > 8).mean(axis=1)
    assert rows[int(0.62 * h) : int(0.95 * h)].max() > 0.05  # around the lanes
    assert not (diff[: int(0.55 * h)] > 8).any()  # nowhere above the road
    a, b = wet.frame(40)[0].astype(float), wet.frame(41)[0].astype(float)
    assert a.tobytes() != b.tobytes()
    # clear weather: dry, unless the road is always wet
    clear = _scene(seed=12, cars=6, wet_road=1.0)
    assert clear.frame(40)[0].tobytes() == _scene(seed=12, cars=6).frame(40)[0].tobytes()
    after = _scene(seed=12, cars=6, wet_road=1.0, wet_always=True)
    assert after.frame(40)[0].tobytes() != _scene(seed=12, cars=6).frame(40)[0].tobytes()
    # a shower of 2 s at 25 fps: still wet 4 s after it, dry 14 s after
    shower = [1.0] * 50 + [0.0]
    wet_then = _scene(seed=12, cars=6, rain=rain, schedule=shower, wet_road=1.0)
    dry_then = _scene(seed=12, cars=6, rain=rain, schedule=shower)
    assert wet_then._wetness(150) == 1.0 and wet_then._wetness(400) == 0.0
    assert wet_then.frame(400)[0].tobytes() == dry_then.frame(400)[0].tobytes()


# -- demo and video -----------------------------------------------------------------------------


def test_demo_cycles_clear_rain_clear_snow():
    fps = 25.0

    def at(t_s):
        return _demo_schedule(round(t_s * fps), fps=fps)

    assert at(10) == (0.0, 0.0)
    assert at(40) == (1.0, 0.0)
    assert at(70) == (0.0, 0.0)
    assert at(100) == (0.0, 1.0)
    assert at(120 + 100)[0] > 1.0  # the next cycle ends with heavy rain
    gray, truth = next(demo_frames(320, 180, seed=1))
    assert gray.shape == (180, 320) and not truth.precipitation


@pytest.mark.parametrize(
    "codec", [c for c in ("libx264", "mpeg4", "mjpeg") if c in av.codecs_available]
)
def test_write_video_round_trip(tmp_path, codec):
    scene = _scene(seed=12, rain=StreakParams(count=40), sensor_noise=1.0)
    frames = [scene.frame(i)[0] for i in range(20)]
    path = tmp_path / "rain.mkv"
    assert write_video(path, iter(frames), fps=25, codec=codec) == 20
    with av.open(str(path)) as container:
        decoded = [f.to_ndarray(format="gray") for f in container.decode(video=0)]
    assert len(decoded) == 20
    assert all(d.shape == (SIZE[1], SIZE[0]) for d in decoded)
    assert np.abs(decoded[10].astype(float) - frames[10]).mean() < 4


def test_write_video_default_codec_bgr_and_errors(tmp_path):
    bgr = [np.full((48, 64, 3), (10 * i, 100, 200), np.uint8) for i in range(5)]
    assert write_video(tmp_path / "bgr.mp4", bgr) == 5
    with pytest.raises(ValueError, match="even"):
        write_video(tmp_path / "odd.mp4", [np.zeros((47, 64), np.uint8)])
    with pytest.raises(ValueError, match="no frames"):
        write_video(tmp_path / "none.mp4", [])
    with pytest.raises(ValueError, match="uint8"):
        write_video(tmp_path / "f.mp4", [np.zeros((48, 64), np.float32)])
