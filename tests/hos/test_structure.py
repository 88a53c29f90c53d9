"""The structure rule (departure 6) compared with the rate around each blob (departure 28):
what recurs on its own line is structure, however busy the view; rain falling densely in one
part of the view is not, however quiet the rest."""

from __future__ import annotations

import numpy as np
import pytest

from hos.blobs import (
    CandidateRate,
    blob_mean_rate,
    find_blobs,
    local_rate_at,
    local_rate_map,
    structure_rule,
)

H, W = 240, 320
FRAMES = 150


def _learn(masks) -> CandidateRate:
    rate = CandidateRate((H, W), 100)
    for mask in masks:
        index = np.flatnonzero(mask)
        rate.update(index, index.size / mask.size)
    return rate


def _drops(rng, region, n):
    """A mask of ``n`` vertical drops (1 x 5 px) at random places inside ``region``."""
    y0, y1, x0, x1 = region
    mask = np.zeros((H, W), bool)
    for y, x in zip(rng.integers(y0, y1 - 5, n), rng.integers(x0, x1, n), strict=True):
        mask[y : y + 5, x] = True
    return mask


def _rule(rate, mask, local_ratio):
    blobs = find_blobs(mask.astype(np.uint8) * 255)
    local = local_rate_map(rate, factor=4, window=5)
    m = blobs.moments
    return blobs, structure_rule(
        blob_mean_rate(blobs, rate),
        global_rate=rate.global_rate,
        floor=0.03,
        ratio=2.5,
        local_rate=local_rate_at(local, 4, m.x0, m.y0),
        local_ratio=local_ratio,
    )


@pytest.mark.parametrize("local_ratio", [0.0, 2.0])
def test_rain_dense_in_one_part_of_the_view_is_structure_only_against_the_whole_view(
    local_ratio,
):
    """Dense drops in a pool (a tenth of the view) for 150 frames, none elsewhere: the pool's
    rate is several times the view's. The next frame's drops there are structure when only the
    view is compared (0), none of them with the rate around them (2)."""
    rng = np.random.default_rng(1)
    pool = (120, 200, 160, 260)
    rate = _learn(_drops(rng, pool, 120) for _ in range(FRAMES))
    blobs, structural = _rule(rate, _drops(rng, pool, 120), local_ratio)
    share = np.count_nonzero(structural[1:]) / (blobs.n_labels - 1)
    if local_ratio == 0:
        assert share > 0.8
    else:
        assert share < 0.05


def test_an_edge_that_recurs_is_structure_against_the_rate_around_it_too():
    """A vertical edge lit on most frames (a shaken pole) in a view where the same dense drops
    fall around it: its blob stands out from the rate around it as from the view's, and stays
    structure; the drops beside it do not."""
    rng = np.random.default_rng(2)
    pool = (120, 200, 160, 260)
    edge = np.zeros((H, W), bool)
    edge[130:190, 210] = True
    masks = []
    for _ in range(FRAMES):
        mask = _drops(rng, pool, 120)
        mask[:, 209:212] = False  # drops never touch the pole: one blob each
        masks.append(mask | (edge if rng.random() < 0.8 else False))
    rate = _learn(masks)
    now = _drops(rng, pool, 120)
    now[:, 207:214] = False
    blobs, structural = _rule(rate, now | edge, 2.0)
    m = blobs.moments
    pole = np.flatnonzero((np.abs(m.x0 - 210) < 0.5) & (m.area >= 50))
    assert pole.size == 1 and structural[pole[0]]
    others = np.ones(blobs.n_labels, bool)
    others[[0, pole[0]]] = False
    assert np.count_nonzero(structural[others]) / np.count_nonzero(others) < 0.05
