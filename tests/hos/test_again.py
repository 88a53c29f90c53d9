"""Blobs found again a little way off are not new drops (hos/again.py; docs/method.md,
departure 23).

The unit tests move points as a drop, clutter, a codec's copy and slow snow would move them.
The detector's test draws rain behind fragments that creep a pixel a frame, as a distant
vehicle's parts do along a lane the traffic map has not learnt, or a hedge's texture does
with the sway; its control turns the rule off.
"""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from drivers.simulator import Scene, SceneParams
from drivers.simulator.precipitation import SnowParams, StreakParams, render_streaks
from hos import DetectorParams, HosDetector
from hos.again import FoundAgain

W, H = 320, 240


def _points(n: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.column_stack((rng.uniform(0, W, n), rng.uniform(0, H, n)))


# -- the rule on points -------------------------------------------------------------------------
def test_the_first_frame_finds_nothing_again() -> None:
    rule = FoundAgain(radius=3.0)
    assert not rule.update(_points(40)).any()


def test_what_moves_a_little_is_found_again_both_ways() -> None:
    rng = np.random.default_rng(1)
    p = _points(40)
    rule = FoundAgain(radius=3.0)
    rule.update(p)
    for _ in range(40):  # clutter sways both ways: never taken for falling snow
        q = p + rng.uniform(-1.5, 1.5, p.shape)
        assert rule.update(q).mean() >= 0.95
        assert not rule.falling
        p = q


def test_a_drop_is_never_found_again() -> None:
    """A streak of length L seen again one frame later is at least L - 1 further along its
    orientation: from 4 pixels on, outside the radius of 3."""
    rule = FoundAgain(radius=3.0)
    gx, gy = np.meshgrid(np.arange(20, W, 20), np.arange(20, H, 20))
    p = np.column_stack((gx.ravel(), gy.ravel())).astype(float)  # drops 20 px apart
    rule.update(p)
    for theta_deg in (60.0, 90.0, 110.0):
        t = math.radians(theta_deg)
        assert not rule.update(p + 3.01 * np.array([math.cos(t), math.sin(t)])).any()
        rule.update(p)


def test_an_exact_copy_is_not_found_again() -> None:
    """A video encoder's skipped block repeats the last frame's blobs as they were."""
    p = _points(40, seed=3)
    rule = FoundAgain(radius=3.0)
    rule.update(p)
    assert not rule.update(p.copy()).any()


def test_new_points_are_found_again_only_by_chance() -> None:
    rule = FoundAgain(radius=3.0)
    rule.update(_points(60, seed=4))
    found = rule.update(_points(60, seed=5))
    # 60 points over 320 x 240: a neighbour within 3 px by chance about 2 % of the time
    assert found.mean() < 0.1


def test_slow_snow_is_found_again_until_it_is_seen_to_fall() -> None:
    """Flakes falling 0.8 px a frame are found again; once the pairs found again fall by
    fall_z standard deviations, the rule stands aside and they vote again."""
    rng = np.random.default_rng(6)
    p = _points(60, seed=6)
    rule = FoundAgain(radius=3.0, frames=25, fall_z=8.0)
    rule.update(p)
    found = []
    for _ in range(30):
        p = p + np.column_stack((rng.normal(0.0, 0.2, len(p)), rng.normal(0.8, 0.2, len(p))))
        found.append(rule.update(p).mean())
    assert found[0] > 0.9  # at first, not yet known to fall
    assert rule.falling and rule.z > 20
    # nearly all found lower down (since departure 41 those off the down cone, or nearest to
    # another flake, stay found: 1 of 60 here, up to 7 at other seeds)
    assert found[-1] <= 0.15
    rule.reset()
    assert rule.z == 0.0 and not rule.falling


@pytest.mark.parametrize("lower_only", [True, False])
def test_once_snow_is_seen_to_fall_only_what_was_found_lower_votes(lower_only: bool) -> None:
    """Flakes falling 0.8 px a frame among clutter that sways both ways: once the pairs found
    again fall, the flakes found lower down vote again; the clutter found again beside or
    above where it was is still left out (departure 41). The control (the rule before)
    lets every blob found again vote."""
    rng = np.random.default_rng(16)
    flakes, clutter = _points(60, seed=16), _points(60, seed=17)
    rule = FoundAgain(radius=3.0, frames=25, fall_z=8.0, lower_only=lower_only)
    rule.update(np.concatenate((flakes, clutter)))
    for _ in range(30):
        flakes = flakes + np.column_stack((rng.normal(0.0, 0.2, 60), rng.normal(0.8, 0.2, 60)))
        step = rng.uniform(-1.5, 1.5, clutter.shape)
        found = rule.update(np.concatenate((flakes, clutter + step)))
    assert rule.falling
    assert found[:60].mean() <= 0.2  # the flakes vote (1 of 60 here; up to 10 at other seeds)
    # clutter found again in the down cone votes with them (about a fifth); the rest is out
    assert found[60:].mean() >= 0.6 if lower_only else not found[60:].any()


def test_the_fall_follows_the_cameras_vertical() -> None:
    """Rolled by 30 degrees, the camera's vertical is 60 degrees, and what falls moves along
    it; a camera on its side (vertical 0) sees a fall straight down the image across its
    vertical, and the rule does not stand aside."""
    rng = np.random.default_rng(7)
    p = _points(60, seed=7)
    v = math.radians(60.0)
    rule = FoundAgain(radius=3.0, vertical=v)
    rule.update(p)
    for _ in range(30):
        p = p + 0.8 * np.array([math.cos(v), math.sin(v)]) + rng.normal(0.0, 0.1, p.shape)
        rule.update(p)
    assert rule.falling
    rule = FoundAgain(radius=3.0, vertical=0.0)  # a camera on its side
    p = _points(60, seed=7)
    rule.update(p)
    for _ in range(30):
        p = p + np.array([0.0, 0.8])
        rule.update(p)
    assert not rule.falling


# -- what the next frame shows again of the rain blobs (departure 29) -------------------------
def _flicker_after(step, *, n: int = 200, voted=None, seed: int = 11, fall_z: float = 8.0):
    """The flicker measure of a frame after one of ``n`` points, all voted unless ``voted``
    says which, the next frame's points being ``step(points)``."""
    p = _points(n, seed=seed)
    rule = FoundAgain(radius=3.0, fall_z=fall_z)
    rule.update(p)
    rule.voted(np.ones(n, bool) if voted is None else voted)
    rule.update(step(p))
    return rule.flicker


def test_the_rain_blobs_seen_again_are_counted_beyond_chance() -> None:
    rng = np.random.default_rng(12)
    # a crown's leaves, stirred: seen again a pixel or so off, every one
    again, n = _flicker_after(lambda p: p + rng.uniform(-1.2, 1.2, p.shape))
    assert n == 200 and again >= 0.9 * n
    # drops: never seen again; the next frame's are elsewhere, found by chance alone
    again, n = _flicker_after(lambda p: _points(200, seed=13))
    assert abs(again) <= 0.05 * n
    # ... however dense: 2,000 points over 320 x 240 find a neighbour within 3 px by chance
    # a third of the time, and the measure takes that chance off
    again, n = _flicker_after(lambda p: _points(2000, seed=14), n=2000)
    assert abs(again) <= 0.06 * n


def test_flakes_falling_are_not_counted_as_seen_again() -> None:
    """Found lower down counts only as often as found higher up: a fall is not a sway (with
    the fall test off); once the flakes are known to fall, nothing is measured at all."""
    rng = np.random.default_rng(15)
    fall = np.column_stack((rng.normal(0.0, 0.2, 200), rng.normal(1.0, 0.2, 200)))
    again, n = _flicker_after(lambda p: p + fall, fall_z=0.0)
    assert n == 200 and abs(again) <= 0.05 * n
    assert _flicker_after(lambda p: p + fall) is None


def test_only_the_voted_points_are_looked_for() -> None:
    voted = np.zeros(200, bool)
    voted[:50] = True
    again, n = _flicker_after(lambda p: p + 0.8, voted=voted)
    assert n == 50 and again >= 45
    rule = FoundAgain(radius=3.0)
    rule.update(_points(20))
    rule.update(_points(20, seed=1))
    assert rule.flicker is None  # nothing was said to have voted
    rule.voted(np.ones(20, bool))
    rule.update(np.zeros((0, 2)))
    assert rule.flicker == (0.0, 20)  # the next frame has no blob at all
    rule.voted(np.ones(0, bool))
    rule.update(_points(20))
    assert rule.flicker is None
    rule.voted(np.ones(20, bool))
    rule.reset()
    assert rule.flicker is None


@pytest.mark.parametrize(
    ("kwargs", "match"), [({"radius": 0.0}, "radius"), ({"radius": 1.0, "frames": 0}, "frames")]
)
def test_bad_settings_are_refused(kwargs: dict, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        FoundAgain(**kwargs)


# -- the detector -------------------------------------------------------------------------------
#: The frames a detector is given in each test below: 60 judged after 100. What each rule and
#: its control say is the same on them as it was on 100 of 200 frames (creeping fragments:
#: rain on every frame at Pi 0.68 with the rule, on none at 0.27 without, alone on none; slow
#: snow on every frame, on none without; the gusts on none, on every frame without, the rain
#: among them on every frame; the gusts' flicker shares 0.76, 0.76, 0.15 against 0.75, 0.75,
#: 0.16).
FRAMES = 160


def _frames(n: int, *, rain: int, clutter: int, seed: int = 0, drift: float = 0.0):
    """A flat grey scene, fragments of 3 px at random orientations creeping about a pixel a
    frame in random directions (and ``drift`` pixels a frame down the image, as foliage
    bent by a gust), and rain at 80 degrees drawn anew in every frame."""
    rng = np.random.default_rng([seed, 1])
    base = cv2.GaussianBlur((110 + 6 * rng.standard_normal((H, W))).astype(np.float32), (0, 0), 1.0)
    anchors = rng.uniform((10, 10), (W - 10, H - 10), size=(clutter, 2))
    angle = rng.uniform(0, math.pi, clutter)
    heading = rng.uniform(0, 2 * math.pi, clutter)
    velocity = np.column_stack((np.cos(heading), np.sin(heading) + drift))
    half = 1.5 * np.column_stack((np.cos(angle), np.sin(angle)))
    for i in range(n):
        r = np.random.default_rng([seed, 2, i])
        img = base.copy()
        at = anchors + velocity * i + r.uniform(-0.3, 0.3, size=(clutter, 2))
        at %= (W, H)
        _segments(img, at, half, 150.0)
        yield _delivered(img, r, rain=rain, length_px=9.0)


def _segments(img: np.ndarray, at: np.ndarray, half: np.ndarray, level: float) -> None:
    """Antialiased one-pixel segments from ``at - half`` to ``at + half``, drawn in ``img``."""
    ends = np.round(np.stack((at - half, at + half), axis=1) * 16).astype(np.int32)
    cv2.polylines(img, list(ends), False, level, 1, cv2.LINE_AA, 4)


def _delivered(img: np.ndarray, r, *, rain: int, length_px: float) -> np.ndarray:
    """``img`` with ``rain`` streaks at 80 degrees drawn from ``r`` and sensor noise, as uint8."""
    h, w = img.shape
    if rain:
        streaks = StreakParams(count=rain, mu_deg=80.0, brightness=30.0, length_px=length_px)
        img = img + render_streaks((h, w), streaks, r).layer
    img = img + 1.5 * r.standard_normal((h, w)).astype(np.float32)
    return np.clip(img + 0.5, 0, 255).astype(np.uint8)


def _said(frames, **robustness) -> tuple[float, float]:
    """Share of frames 100 on said to precipitate, and their mean smoothed Pi."""
    det = HosDetector(DetectorParams.from_dict({"robustness": robustness}))
    said, pis = [], []
    for i, gray in enumerate(frames):
        r = det.process(gray, i / 25.0)
        if i >= 100:
            said.append(r.rain)
            pis.append(r.pi_smoothed)
    return float(np.mean(said)), float(np.mean(pis))


@pytest.fixture(scope="module")
def creeping() -> list[np.ndarray]:
    """The frames of the rule's test and of its control, drawn once for both."""
    return list(_frames(FRAMES, rain=40, clutter=200))


@pytest.mark.parametrize("radius", [3.0, 0.0])
def test_rain_behind_creeping_fragments_is_seen_once_they_are_left_out(
    creeping, radius: float
) -> None:
    """200 fragments creeping about a pixel a frame, 40 streaks a frame: Pi 0.65 with the rule,
    0.24 without, under the threshold (the control). Pi is the first track's: the second
    (departure 45) sees the streaks either way, the fragments failing eq. 32."""
    said, pi = _said(creeping, found_again_radius=radius)
    if radius > 0:
        assert said >= 0.95 and pi > 0.5
    else:
        assert pi < 0.35


def test_creeping_fragments_alone_are_not_rain() -> None:
    """Fewer votes are left with the rule; what is left is not a streak population."""
    said, _ = _said(_frames(FRAMES, rain=0, clutter=200))
    assert said == 0.0


def test_rain_behind_fragments_sinking_in_a_gust_is_still_seen() -> None:
    """200 fragments creeping as above and sinking 0.8 px a frame on top (foliage bent down by
    a gust, real leaves in rain: docs/method.md, departure 41): the pairs found again fall,
    and the rule stands aside. Only what was found lower down then votes: the rain is seen
    on every frame, the fragments alone on none. The control (every fragment found again
    voting, the rule before) lets 1.6 times as many blobs vote and its Pi falls by 0.11-0.16
    (seeds 0-7; under the threshold at this seed). The fall's own verdict (departure 22) is
    off: a field of specks sinking alike is what it takes for snow."""

    def run(frames, lower_only: bool):
        settings = {"robustness": {"found_again_fall_lower": lower_only}, "decision": {"fall_z": 0}}
        det = HosDetector(DetectorParams.from_dict(settings))
        results = [det.process(gray, i / 25.0) for i, gray in enumerate(frames)][100:]
        assert det._again is not None and det._again.falling
        return (
            float(np.mean([r.rain for r in results])),
            float(np.mean([r.pi_smoothed for r in results])),
            float(np.median([r.n_blobs for r in results])),
        )

    frames = list(_frames(FRAMES, rain=40, clutter=200, drift=0.8))
    said, pi, voting = run(frames, True)
    _, pi_before, voting_before = run(frames, False)
    assert said >= 0.95
    assert pi >= pi_before + 0.08 and voting <= 0.75 * voting_before
    assert not run(_frames(FRAMES, rain=0, clutter=200, drift=0.8), True)[0]


@pytest.fixture(scope="module")
def slow_snow() -> list[np.ndarray]:
    """The frames of the rule's test and of its control, rendered once for both."""
    scene = Scene(W, H, seed=3, params=SceneParams(cars=2, snow=SnowParams(fall_px=0.8, count=120)))
    return [scene.frame(i)[0] for i in range(FRAMES)]


@pytest.mark.parametrize("fall_z", [8.0, 0.0])
def test_slow_snow_is_found_again_and_still_seen(slow_snow, fall_z: float) -> None:
    """Streaky flakes falling 0.8 px a frame at 320 x 240 are within the radius (1.5 px) of
    where they were: the rule stands aside once they are seen to fall, and the snow is seen
    on every frame; the control, without that exception, loses it."""
    said, _ = _said(slow_snow, found_again_fall_z=fall_z)
    if fall_z > 0:
        assert said >= 0.98
    else:
        assert said <= 0.2


def _gusts(n: int, *, rain: int = 0, seed: int = 0):
    """640 x 480: fragments 7 px long near the vertical (90 +- 12 degrees) that appear at
    random places, 30 a frame, and stay for 4 frames, each a pixel or so off the last: leaves
    stirred by gusts, as a crown seen by a soft or sharp high-resolution camera shows them;
    ``rain`` streaks at 80 degrees drawn anew in every frame."""
    w, h = 640, 480
    rng = np.random.default_rng([seed, 3])
    base = cv2.GaussianBlur((70 + 6 * rng.standard_normal((h, w))).astype(np.float32), (0, 0), 1.0)
    born = rng.uniform((10, 10), (w - 10, h - 10), size=(n, 30, 2))
    angle = np.radians(90.0 + 12.0 * rng.standard_normal((n, 30)))
    for i in range(n):
        r = np.random.default_rng([seed, 4, i])
        img = base.copy()
        for k in range(max(0, i - 3), i + 1):  # the fragments born in the last 4 frames
            at = born[k] + r.uniform(-0.8, 0.8, size=(30, 2))
            half = 3.5 * np.column_stack((np.cos(angle[k]), np.sin(angle[k])))
            _segments(img, at, half, 120.0)
        yield _delivered(img, r, rain=rain, length_px=12.0)


def _said_with(frames, **decision) -> tuple[float, float]:
    """Share of frames 100 on said to precipitate, and their median ``flicker_share`` (as the
    per-frame JSON reports it)."""
    det = HosDetector(DetectorParams.from_dict({"decision": decision}))
    results = [det.process(gray, i / 25.0) for i, gray in enumerate(frames)][100:]
    shares = [r.to_json()["flicker_share"] for r in results]
    return float(np.mean([r.rain for r in results])), float(np.median(shares))


@pytest.fixture(scope="module")
def gusts() -> list[np.ndarray]:
    """The frames of the rule's test and of its control, drawn once for both."""
    return list(_gusts(FRAMES))


@pytest.mark.parametrize("share", [0.25, 0.0])
def test_leaves_stirred_by_gusts_are_not_rain(gusts, share: float) -> None:
    """Each fragment votes on the frame it appears (nothing was there before) and is found
    again on the next three: a population the next frame shows again is not rain
    (departure 29); the control, without the rule, says rain. The share is measured
    either way."""
    said, flicker = _said_with(gusts, flicker_share=share)
    assert flicker > 0.5
    if share > 0:
        assert said == 0.0
    else:
        assert said >= 0.8


def test_rain_among_leaves_stirred_by_gusts_is_still_seen() -> None:
    """Rain's own blobs are never seen again: among the same fragments, the rain is seen, and
    the share the next frame shows again (the fragments the fit takes for rain) stays under
    the threshold."""
    said, flicker = _said_with(_gusts(FRAMES, rain=150))
    assert said >= 0.95 and flicker < DetectorParams().decision.flicker_share


def test_a_share_measured_before_snow_was_seen_to_fall_does_not_hold_it_off() -> None:
    """While what is found again falls (slow snow), the flicker rule stands aside; the share it
    measured before (0.5, over the threshold) must neither hold the fits off meanwhile nor
    outweigh the first frames measured after the fall (it was frozen, and held snow in a
    shaded, windy scene off for 200 frames)."""
    det = HosDetector(DetectorParams())
    det._again = FoundAgain(radius=3.0, frames=25, fall_z=8.0)
    det._flicker_sums = np.array([5.0, 10.0])  # half of the rain blobs seen again
    assert det._flicker(True)  # over the threshold (0.25): no fit is a measurement
    det._again._down, det._again._up = 100, 0  # then the pairs found again are seen to fall
    assert det._again.falling
    assert not any(det._flicker(True) for _ in range(30))
    det._again._down = 0  # the fall is no longer seen; the next frame finds none of 20 again
    det._again.flicker = (0.0, 20)
    assert not det._flicker(True)
    assert det._flicker_rate < 0.1
