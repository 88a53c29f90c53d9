"""``segmentation.line_length`` (docs/method.md, departure 36): the pixels of a faint streak
that MOG2 leaves in the background join the candidates when the frame's difference from the
background, summed along a line through them, stands out of the noise, and when they touch
a candidate."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from drivers.simulator.precipitation import StreakParams, render_streaks
from hos import _jit
from hos.background import (
    MogSegmenter,
    PhotometricRule,
    grown_along_lines,
    line_capped,
    line_limit,
    line_offsets,
)
from hos.params import SegmentationParams

needs_jit = pytest.mark.skipif(not _jit.ENABLED, reason=f"no JIT: {_jit.why_disabled()}")


@pytest.mark.parametrize("length", [3, 9, 10, 15])
@pytest.mark.parametrize("orientations", [2, 12, 16])
def test_lines_are_straight_distinct_and_symmetric(length: int, orientations: int) -> None:
    lines = line_offsets(length, orientations)
    odd = length | 1
    assert lines.shape == (orientations, odd, 2)
    for i, line in enumerate(lines):
        assert len({tuple(p) for p in line}) == odd  # every pixel once
        np.testing.assert_array_equal(line, -line[::-1])  # symmetric about (0, 0)
        # the line's direction is the orientation it stands for, to within its rounding
        dy, dx = line[-1] - line[0]
        angle = math.degrees(math.atan2(dy, dx)) % 180.0
        want = 180.0 * i / orientations
        off = abs((angle - want + 90.0) % 180.0 - 90.0)
        assert off <= math.degrees(math.atan(1.0 / (odd - 1))) + 1e-9


def _faint_streaks(seed: int, *, noise: float = 2.0, brightness: float = 8.0):
    """(diff, streak mask, seeds): the difference from the background of a frame of faint
    streaks in Gaussian noise, and the brightest pixel of every streak as the candidates."""
    rng = np.random.default_rng(seed)
    shape = (180, 240)
    streaks = render_streaks(
        shape,
        StreakParams(count=25, brightness=brightness, brightness_jitter=0.0, length_px=14.0),
        rng,
    )
    diff = np.round(streaks.layer + rng.normal(0.0, noise, shape)).astype(np.int16)
    n, labels = cv2.connectedComponents(streaks.mask.view(np.uint8), connectivity=8)
    flat = labels.reshape(-1)
    # the brightest pixel of each streak: what MOG2 alone would have caught
    layer = streaks.layer.reshape(-1)
    seeds = [np.flatnonzero(flat == k) for k in range(1, n)]
    seeds = np.sort(np.array([s[np.argmax(layer[s])] for s in seeds], np.intp))
    return diff, streaks.mask, seeds


def _grown(diff, seeds, grow=grown_along_lines, *, k: float = 6.0):
    lines = line_offsets(9, 12)
    limit = line_limit(diff, c=3, k=k, length=9, window=31)
    return grow(seeds, diff, limit, lines, c=3)


@needs_jit
@pytest.mark.parametrize("seed", range(6))
def test_compiled_equals_reference(seed: int) -> None:
    diff, _, seeds = _faint_streaks(seed, noise=1.0 + seed * 0.5)
    for k in (0.0, 4.0, 6.0):
        want = _grown(diff, seeds, k=k)
        got = _grown(diff, seeds, _jit.grown_along_lines, k=k)
        np.testing.assert_array_equal(got, want)
        assert np.all(np.diff(got) > 0) and np.isin(seeds, got).all()


@pytest.mark.parametrize("seed", range(3))
def test_faint_streaks_are_completed_and_noise_is_not(seed: int) -> None:
    """Candidates from a per-pixel test at 3 standard deviations of the noise (MOG2's D)
    find half of the streaks' pixels; grown along lines, they find a good deal more, and
    add few pixels off the streaks (noise that happened to line up)."""
    diff, mask, _ = _faint_streaks(seed)
    seeds = np.flatnonzero(diff.reshape(-1) >= 6)
    grown = _grown(diff, seeds)
    on = mask.reshape(-1)
    added = np.setdiff1d(grown, seeds)
    assert on[grown].sum() >= on[seeds].sum() + 0.1 * on.sum()
    assert np.count_nonzero(~on[added]) <= 0.25 * np.count_nonzero(on[added])


def test_seeds_in_noise_alone_stay_alone() -> None:
    """Candidates that are noise (the brightest pixels of a frame of pure noise) grow into
    their neighbours rarely: no line of noise stands 2 standard deviations of its own mean
    out."""
    rng = np.random.default_rng(5)
    diff = np.round(rng.normal(0.0, 3.0, (180, 240))).astype(np.int16)
    seeds = np.flatnonzero(diff.reshape(-1) >= 9)
    grown = _grown(diff, seeds)
    assert grown.size <= 1.05 * seeds.size


def test_off_the_candidates_are_eq8s() -> None:
    """With ``line_length = 0`` the rule is eq. 8 alone; with it, a faint streak that MOG2
    leaves partly in the background (8 grey levels at its core, in noise of 2: D = 3
    standard deviations is 6) is found on many more of its pixels, and a frame without
    streaks gains almost nothing. Uncapped (``line_cap = 0``), half as many again; capped
    (1.5, the default cap), a little less: the streak's core, 8 over a line threshold of 4,
    counts as 6."""
    shape = (180, 240)
    base = cv2.GaussianBlur(
        np.random.default_rng(2).uniform(60, 140, shape).astype(np.float32), (0, 0), 4
    )
    found = {}
    dry = {}
    for length, cap in ((0, 0.0), (9, 0.0), (9, 1.5)):
        rng = np.random.default_rng(3)  # the same frames either way

        def frame(layer=None, rng=rng):
            f = base + rng.normal(0.0, 2.0, shape)
            if layer is not None:
                f = f + layer
            return np.clip(np.round(f), 0, 255).astype(np.uint8)

        params = SegmentationParams(line_length=length, line_cap=cap)
        mog, rule = MogSegmenter(params), PhotometricRule(params)
        for _ in range(80):
            g = frame()
            rule.candidates(g, mog.model(g))
        hits = total = extra = 0
        for i in range(20):
            layer = render_streaks(
                shape, StreakParams(count=30, brightness=8.0, length_px=14.0), 100 + i
            )
            g = frame(layer.layer)
            index = rule.candidates(g, mog.model(g))
            hits += np.count_nonzero(layer.mask.reshape(-1)[index])
            total += np.count_nonzero(layer.mask)
            g = frame()
            extra += rule.candidates(g, mog.model(g)).size
        found[length, cap] = hits / total
        dry[length, cap] = extra / 20
    assert SegmentationParams().line_cap == 1.5
    assert found[9, 0.0] >= 1.5 * found[0, 0.0], found
    assert found[9, 1.5] >= 1.4 * found[0, 0.0], found
    for grown in ((9, 0.0), (9, 1.5)):
        assert dry[grown] <= dry[0, 0.0] + 0.001 * shape[0] * shape[1], dry


def _flakes(seed: int, *, noise: float = 2.0, brightness: float = 40.0):
    """(diff, flake mask): bright round flakes, 3 pixels across, in Gaussian noise."""
    rng = np.random.default_rng(seed)
    shape = (180, 240)
    mask = np.zeros(shape, np.uint8)
    for y, x in zip(rng.integers(10, 170, 30), rng.integers(10, 230, 30), strict=True):
        cv2.circle(mask, (int(x), int(y)), 1, 1, -1)
    diff = np.round(mask * brightness + rng.normal(0.0, noise, shape)).astype(np.int16)
    return diff, mask > 0


@pytest.mark.parametrize("seed", range(3))
def test_a_bright_flake_does_not_lengthen_itself_under_the_cap(seed: int) -> None:
    """A line through a bright flake sums past the threshold on the flake alone, so without
    the cap the noise beside a flake joins it (a flake in the wind grown into a streak);
    with each pixel counted up to twice the line's per-pixel threshold, hardly any does.
    A faint streak is completed as before: its pixels are under the cap."""
    lines = line_offsets(9, 12)
    diff, mask = _flakes(seed)
    seeds = np.flatnonzero(mask.reshape(-1))
    limit = line_limit(diff, c=3, k=6.0, length=9, window=31)
    free = np.setdiff1d(grown_along_lines(seeds, diff, limit, lines, c=3), seeds).size
    capped = line_capped(diff, limit, cap=2.0, length=9)
    held = np.setdiff1d(grown_along_lines(seeds, capped, limit, lines, c=3), seeds).size
    assert free >= 30 and held <= 0.2 * free, (free, held)
    if _jit.ENABLED:
        np.testing.assert_array_equal(
            _jit.grown_along_lines(seeds, capped, limit, lines, c=3),
            grown_along_lines(seeds, capped, limit, lines, c=3),
        )
    # the cap keeps eq. 8's test: a pixel at c or more stays at c or more
    assert np.array_equal(capped >= 3, diff >= 3)
    diff, streaks, _ = _faint_streaks(seed)
    seeds = np.flatnonzero(diff.reshape(-1) >= 6)
    limit = line_limit(diff, c=3, k=6.0, length=9, window=31)
    on = streaks.reshape(-1)
    plain = grown_along_lines(seeds, diff, limit, lines, c=3)
    kept = grown_along_lines(seeds, line_capped(diff, limit, cap=2.0, length=9), limit, lines, c=3)
    assert on[kept].sum() >= 0.9 * on[plain].sum()


@pytest.mark.parametrize("cap", [0.5, -1.0])
def test_a_cap_under_one_is_refused(cap: float) -> None:
    """Under 1, a capped pixel could fall under eq. 8's c and the cap would change which
    pixels may join: refused, and the key named."""
    with pytest.raises(ValueError, match="line_cap"):
        SegmentationParams(line_cap=cap)
    assert SegmentationParams(line_cap=0.0).line_cap == 0.0  # no cap
