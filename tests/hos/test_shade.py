"""Cloud shade is undone before the background model sees it (hos/shade.py; docs/method.md,
departure 31).

On the field: a smooth shade over a textured view is recovered cell by cell; a frame like its
reference, a vehicle (texture of its own), a plain object the size of two cells, one cell
alone and rain's streaks are not light. In the detector: a busy clear street under drifting
cloud shade stays judged (no ``scene_change``, no ``unstable``) and says no rain, where the
control (``shade_cells = 0``) relearns the scene for seconds; rain under the same shade is
still seen.

Departure 32: eq. 8 re-levelled takes a smooth residue of the shade out of the candidates and
keeps thin streaks, moves nothing where only streaks differ from the background, acts only
where its mask says, and sees more of light rain under a slow soft shade than without.
"""

from __future__ import annotations

import dataclasses
from collections import Counter

import cv2
import numpy as np
import pytest

from drivers.simulator.families import case_frames, rain_streaks, sample_cases
from drivers.simulator.scene import Scene, SceneParams
from hos import DetectorParams, HosDetector, SegmentationParams, State
from hos.background import PhotometricRule, photometric_rule, relevelled
from hos.pipeline import _in_cells
from hos.result import BlobClass
from hos.shade import apply_field, shade_field, upsample

H, W, CELL = 180, 320, 20  # a reduced 640x360 frame and its 9 x 16 cells
TOL, COHERENCE, ONSET = 0.01, 0.8, 0.05


def _texture(seed: int = 0) -> np.ndarray:
    """A textured view (grey levels 60-200, features of a few pixels)."""
    rng = np.random.default_rng(seed)
    small = rng.random((H // 4, W // 4)).astype(np.float32)
    view = cv2.resize(small, (W, H), interpolation=cv2.INTER_CUBIC)
    return np.clip(60.0 + 140.0 * view, 60.0, 200.0).astype(np.float32)


def _field(frame, reference, active=None):
    return shade_field(
        frame,
        reference,
        cell=CELL,
        tolerance=TOL,
        coherence=COHERENCE,
        onset=ONSET,
        active=active,
    )


def _follow(frame, reference, frames=20):
    """The cells' log gains after ``frames`` frames of the same view, as the detector keeps
    them (each frame's step added, the frame corrected by what is known so far)."""
    state = np.zeros((H // CELL, W // CELL), np.float32)
    for _ in range(frames):
        corrected = frame * upsample(state, CELL, frame.shape)
        active = cv2.dilate((np.abs(state) > TOL).astype(np.uint8), np.ones((3, 3), np.uint8))
        seen = _field(corrected, reference, active > 0 if state.any() else None)
        if seen is None:
            break
        state += seen.step
    return state


def test_a_smooth_shade_is_recovered() -> None:
    reference = _texture()
    x = np.arange(W, dtype=np.float32)
    light = 1.0 - 0.4 * np.clip((x - 140.0) / 60.0, 0.0, 1.0)  # sun, a ramp, shade (0.6)
    frame = reference * light[None, :]
    state = _follow(frame, reference)
    gain = np.exp(state)
    # the shaded cells (x >= 200) are brought back by 1 / 0.6, the sunlit ones (x < 140) not
    assert np.allclose(gain[:, 10:], 1.0 / 0.6, rtol=0.03)
    assert np.allclose(gain[:, :7], 1.0, atol=0.01)
    # and the steps were bounded: one frame moves a cell's log gain by 0.1 at most
    first = _field(frame, reference)
    assert first is not None
    assert np.abs(first.step).max() <= 0.1 + 1e-6


def test_a_frame_like_its_reference_needs_nothing() -> None:
    reference = _texture()
    rng = np.random.default_rng(1)
    frame = reference + rng.normal(0.0, 2.0, reference.shape).astype(np.float32)
    assert _field(frame, reference) is None


def test_a_vehicle_is_not_light() -> None:
    # texture of its own over 3 x 2 cells, darker on the whole: coherent neither in ratio nor
    # in texture
    reference = _texture()
    frame = reference.copy()
    frame[40:80, 100:160] = 0.6 * _texture(seed=7)[40:80, 100:160]
    seen = _field(frame, reference)
    assert seen is not None
    cells = (slice(2, 4), slice(5, 8))
    assert not seen.step[cells].any()
    assert seen.doubt[cells].any()


def test_a_plain_object_two_cells_wide_is_not_light() -> None:
    # a plain view (an empty road) and a plain van over two of its cells: every pixel of
    # those cells changed alike, but a shade is wider than that
    reference = np.full((H, W), 120.0, np.float32)
    frame = reference.copy()
    frame[60:80, 100:140] = 180.0
    seen = _field(frame, reference)
    assert seen is None or not seen.step.any()


def test_one_cell_alone_is_not_light() -> None:
    reference = _texture()
    frame = reference.copy()
    frame[60:80, 100:120] *= 0.7
    seen = _field(frame, reference)
    assert seen is None or not seen.step.any()


def test_rain_is_not_light() -> None:
    # bright streaks over a tenth of the view: rain adds light to few pixels of a cell
    reference = _texture()
    rng = np.random.default_rng(2)
    frame = reference.copy()
    for _ in range(400):
        x, y = int(rng.integers(0, W)), int(rng.integers(0, H - 12))
        frame[y : y + 12, x] += 40.0
    seen = _field(frame, reference)
    assert seen is None or not seen.step.any()


def test_apply_field_multiplies_the_frame() -> None:
    gray = np.full((360, 640), 100, np.uint8)
    log_gains = np.zeros((9, 16), np.float32)
    log_gains[:, 8:] = np.log(1.5)
    out = apply_field(gray, log_gains, 1.0, 40.0)
    assert out[:, :300].max() == 100 and out[:, 360:].min() == 150
    assert apply_field(gray, log_gains, 2.0, 40.0)[0, 0] == 200  # the global gain too


def test_points_are_found_in_their_cells() -> None:
    cells = np.zeros((3, 4), bool)
    cells[1, 2] = True
    x = np.array([np.nan, 25.0, 25.0, 5.0, 1e9, -3.0])
    y = np.array([np.nan, 15.0, 25.0, 15.0, 15.0, 15.0])
    assert _in_cells(cells, 10.0, x, y).tolist() == [False, True, False, False, False, False]
    cells[1, 3] = True  # beyond the grid: its edge cell
    assert _in_cells(cells, 10.0, x, y)[4]


def _states(scene: Scene, *params: DetectorParams, frames: int = 300):
    """For each of ``params``, the states of the judged frames (from 90 on) and how many said
    rain; the scene is rendered once, each frame given to one detector a set of ``params``."""
    dets = [HosDetector(p) for p in params]
    states, rain = [Counter() for _ in dets], [0 for _ in dets]
    for i in range(frames):
        gray = scene.frame(i)[0]
        for k, det in enumerate(dets):
            r = det.process(gray, i / scene.params.fps)
            if i >= 90:
                states[k][r.state] += 1
                rain[k] += bool(r.rain and r.state == State.OK)
    return list(zip(states, rain, strict=True))


def _without_shade() -> DetectorParams:
    p = DetectorParams()
    return dataclasses.replace(p, robustness=dataclasses.replace(p.robustness, shade_cells=0))


SHADED = {"shade": 0.45, "shade_speed_px_s": 80.0, "shake_px": 0.0, "exposure_steps": False}


@pytest.mark.slow
def test_a_street_under_drifting_shade_stays_judged_and_clear() -> None:
    scene = Scene(640, 360, seed=1, params=SceneParams.busy(**SHADED))
    # 185 judged frames: the control's 62 frames of relearning all come by frame 275 (62 of
    # 210 judged by 300), the shade's edge sweeping the view from about frame 170 on
    (states, rain), (control, _) = _states(scene, DetectorParams(), _without_shade(), frames=275)
    assert states[State.OK] == sum(states.values())
    assert rain == 0
    # the control: the background model sees the shade's edge sweep the view and relearns
    assert control[State.SCENE_CHANGE] + control[State.UNSTABLE] >= 60


@pytest.mark.slow
def test_rain_under_drifting_shade_is_seen() -> None:
    rain = rain_streaks("moderate", 640, 360)
    scene = Scene(640, 360, seed=2, params=SceneParams.busy(rain=rain, **SHADED))
    # 110 judged frames, all under the shade being corrected (its cells' log gain at 0.69
    # from frame 15 on) as it drifts 350 px: what 300 frames showed too (all of them rain)
    ((states, said),) = _states(scene, DetectorParams(), frames=200)
    assert said >= 0.95 * states[State.OK] and states[State.OK] >= 0.9 * sum(states.values())


@pytest.mark.slow
def test_what_eq8_cuts_where_the_light_changes_does_not_vote() -> None:
    """Where the shade's edge passes in a frame (the cells whose light the correction moved,
    and their neighbours), the blobs are structure: no vote, no fall (a sharp edge drifting
    fast cut slivers that the fall rule took for precipitation, on 46 clear frames of a
    1920x1080 scene). Checked frame by frame on the blobs' classes."""
    params = SceneParams.busy(
        shade=0.45, shade_speed_px_s=120.0, shade_edge=0.15, shake_px=0.0, exposure_steps=False
    )
    scene = Scene(640, 360, seed=3, params=params)
    det = HosDetector(DetectorParams())
    checked = 0
    # 70 frames checked after the warm-up, over which the edge drifts 340 px: 23,000 blobs in
    # the cells it passed (42,000 over 110 frames)
    for i in range(160):
        gray = scene.frame(i)[0]
        seg = det.segment(gray, i / 25.0)
        r = det.analyse(seg)
        if seg.shading is None or r.blob_class is None or i < 90:
            continue
        labels = np.flatnonzero(r.blob_class != BlobClass.NONE)
        k = len(r.blob_class)
        n = np.maximum(np.bincount(r.pixel_labels, minlength=k), 1)
        x = np.bincount(r.pixel_labels, weights=r.pixel_index % 640, minlength=k) / n
        y = np.bincount(r.pixel_labels, weights=r.pixel_index // 640, minlength=k) / n
        inside = _in_cells(seg.shading, seg.shading_cell, x, y)
        voted = np.isin(r.blob_class, (BlobClass.RAIN, BlobClass.NOISE))
        assert not (inside & voted)[labels].any()
        checked += int(inside[labels].sum())
        assert not r.rain
    assert checked > 100  # the edge passed, and cut blobs there


# -- departure 32: eq. 8 re-levelled while a shade is corrected ------------------------------


def _streaked(frame: np.ndarray, count: int = 40, seed: int = 5) -> tuple[np.ndarray, np.ndarray]:
    """``frame`` with ``count`` thin streaks 25 grey levels brighter (1 px wide, 15 long), and
    their mask."""
    rng = np.random.default_rng(seed)
    out, mask = frame.copy(), np.zeros(frame.shape, bool)
    h, w = frame.shape
    for x, y in zip(rng.integers(5, w - 5, count), rng.integers(5, h - 20, count), strict=True):
        mask[y : y + 15, x] = True
    out[mask] = np.clip(out[mask].astype(int) + 25, 0, 255).astype(np.uint8)
    return out, mask


def test_relevelling_takes_a_smooth_change_of_light_out_of_eq8_and_keeps_streaks() -> None:
    background = cv2.resize(_texture(3), (640, 360), interpolation=cv2.INTER_LINEAR).astype(
        np.uint8
    )
    # what a cell correction leaves of a shade's edge: up to 10 % over 200 px, across a cell
    ramp = 1.0 + 0.1 * np.clip((np.arange(640) - 200) / 200.0, 0.0, 1.0)
    frame, streaks = _streaked(np.clip(background * ramp[None, :], 0, 255).astype(np.uint8))
    everything = np.full(frame.shape, 255, np.uint8)
    plain = photometric_rule(frame, background, everything, c=3) > 0
    relevel = photometric_rule(frame, relevelled(frame, background, 2), everything, c=3) > 0
    assert plain[~streaks].mean() > 0.3  # the ramp is cut out as candidates
    assert relevel[~streaks].mean() < 0.01
    assert relevel[streaks].mean() > 0.95


def test_relevelling_moves_nothing_where_the_light_is_the_backgrounds() -> None:
    background = cv2.resize(_texture(4), (640, 360), interpolation=cv2.INTER_LINEAR).astype(
        np.uint8
    )
    frame, _ = _streaked(background, count=80)
    for scale in (1, 2, 4):
        np.testing.assert_array_equal(relevelled(frame, background, scale), background)


@pytest.mark.slow
def test_light_rain_under_a_slow_soft_shade_is_seen_with_eq8_relevelled() -> None:
    """The benchmark's tuning-016 (light rain at 320x240, 15 fps, JPEG 70, under a third of
    shade drifting at 20 px/s with soft edges): what the cells' correction misses of the
    shade's edge inside a cell is cut out by eq. 8 as foreground around the streaks. With eq. 8
    re-levelled, rain is said on at least 30 more of its 285 scored frames (measured: 255
    against 195). The streaks' completion along their lines (departure 36) is off in both:
    it completes what eq. 8 cut out too, and with it on the two see rain on 278 and 271.
    The moved-edge rule is at its bound of that release, 1 px: at 2 px (departure 40) it
    takes most of the shade edge's slivers out of the vote as well (242 and 237).
    The scene as the benchmark draws it since (magnified 1.29 times, rolled 1.6 degrees, its
    shade's edge elsewhere) is seen on 262 and 276: docs/method.md, 32. Both without the
    second track (departure 45), which sees the streaks' drops either way (273 and 278)."""
    case = next(
        c
        for c in sample_cases("tuning", per_cell=3, frames=375, views=False)
        if c.name == "tuning-016-light-static"
    )
    p = DetectorParams()
    p = dataclasses.replace(
        p,
        segmentation=dataclasses.replace(p.segmentation, line_length=0),
        robustness=dataclasses.replace(p.robustness, moved_edge_px=1.0),
        decision=dataclasses.replace(p.decision, transient_share=0.0),
    )
    off = dataclasses.replace(p, robustness=dataclasses.replace(p.robustness, shade_relevel=False))

    # the scene rendered once, each frame given to both detectors
    dets = [HosDetector(p), HosDetector(off)]
    said = [0, 0]
    for i, f in enumerate(case_frames(case)):
        for k, det in enumerate(dets):
            r = det.process(f.gray, i / case.fps)
            said[k] += bool(i >= 90 and f.precipitation and r.rain)
    on, without = said
    assert on >= without + 30, (on, without)


@pytest.mark.parametrize("compiled", [False, True])
def test_eq8_is_relevelled_only_where_the_mask_says(compiled: bool) -> None:
    """The candidates of :class:`PhotometricRule` with ``relevel``: the ramp's residue goes
    where the mask is set (the cells whose correction is a shade's), and stays elsewhere."""
    background = cv2.resize(_texture(5), (640, 360), interpolation=cv2.INTER_LINEAR).astype(
        np.uint8
    )
    ramp = 1.0 + 0.1 * np.clip((np.arange(640) - 200) / 200.0, 0.0, 1.0)
    frame, streaks = _streaked(np.clip(background * ramp[None, :], 0, 255).astype(np.uint8))
    everything = np.full(frame.shape, 255, np.uint8)
    mask = np.zeros((180, 320), np.float32)  # one weight a block of 2 x 2 pixels
    mask[:, :210] = 1.0  # the left of the ramp's residue is in shade's cells, the right is not
    rule = PhotometricRule(SegmentationParams(), compiled=compiled)
    rule.candidates(background, everything)  # learns the background
    index = rule.candidates(frame, everything, relevel=2, relevel_mask=mask)
    cand = np.zeros(frame.size, bool)
    cand[index] = True
    cand = cand.reshape(frame.shape)
    assert cand[:, 250:400][~streaks[:, 250:400]].mean() < 0.01
    assert cand[:, 450:][~streaks[:, 450:]].mean() > 0.5
    assert cand[streaks].mean() > 0.95
    # the level applied is the mask's; the level seen (departure 37's) is the whole view's
    assert np.all(rule.level[:, 230:] == 128)
    assert np.median(rule.seen_level[:, 230:].astype(int) - 128) >= 3  # the ramp's residue
    np.testing.assert_array_equal(rule.level[:, :200], rule.seen_level[:, :200])
    rule.candidates(frame, everything)  # not re-levelled: no level either way
    assert rule.level is None and rule.seen_level is None


@pytest.mark.parametrize("size", [(360, 640), (361, 643), (240, 320), (1081, 1921)])
def test_the_relevel_mask_covers_the_blocks_in_the_strong_cells(size: tuple[int, int]) -> None:
    """The weights of departure 32 cover the reduced image whatever its size, 1 in the cells
    whose correction passes ``shade_onset`` and their neighbours, 0 elsewhere, None when
    every correction is weak; and eq. 8's background re-levelled with them is the frame's
    size."""
    h, w = size
    det = HosDetector(DetectorParams())
    det.process(np.full(size, 100, np.uint8), 0.0)
    small = (h // det._scale, w // det._scale)
    side = det._shade_cell(small)
    ny, nx = -(-small[0] // side), -(-small[1] // side)
    det._shade = np.zeros((ny, nx), np.float32)
    det._shade[0, 0] = 0.02  # weak: a busy road's
    assert det._relevel_mask(small) is None
    det._shade[ny - 1, nx - 1] = -0.2  # a shade's, in the bottom right corner
    mask = det._relevel_mask(small)
    assert mask is not None and mask.shape == small and mask.dtype == np.float32
    y, x = (ny - 2) * side, (nx - 2) * side  # the neighbour cell's top left corner
    assert mask[-1, -1] == 1.0 and mask[y, x] == 1.0
    assert mask[0, 0] == 0.0 and mask[y - 1, x - 1] == 0.0
    frame = np.full(size, 120, np.uint8)
    reference = np.full(size, 100, np.uint8)
    out = relevelled(frame, reference, det._scale, mask)
    assert out.shape == size
    assert out[-1, -1] == 120 and out[0, 0] == 100
