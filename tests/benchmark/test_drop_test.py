"""bench/drop_test.py: the paper's eq. 32, a two-sided test of a drop, on hand-made frames with a
known answer, and on a few frames of one rendered scene."""

from __future__ import annotations

import importlib.util
import sys

import numpy as np

from tests.conftest import REPO

_spec = importlib.util.spec_from_file_location("drop_test", REPO / "bench" / "drop_test.py")
dt = importlib.util.module_from_spec(_spec)
sys.modules["drop_test"] = dt
_spec.loader.exec_module(dt)


def test_a_drop_passes_what_lasts_or_moves_a_little_does_not() -> None:
    shape = (40, 60)
    before = np.full(shape, 100, np.uint8)
    now = before.copy()
    after = before.copy()
    labels = np.zeros(shape, np.int32)
    # 1: a streak in this frame only
    now[5:15, 5] += 20
    labels[5:15, 5] = 1
    # 2: a bright bar in all three frames (an edge that recurs)
    for f in (before, now, after):
        f[5:15, 20] += 20
    labels[5:15, 20] = 2
    # 3: a flake of 4 rows that moves down 2 rows a frame: its top half is new, then left
    before[18:22, 40] += 20
    now[20:24, 40] += 20
    after[22:26, 40] += 20
    labels[20:24, 40] = 3
    # 4: a streak 2 grey levels bright, under eq. 8's c
    now[30:38, 50] += 2
    labels[30:38, 50] = 4
    # 5: brighter than the frame before only (a shade's edge coming on)
    now[30:38, 10] += 20
    after[30:38, 10] += 25
    labels[30:38, 10] = 5
    share = dt.two_sided_share(before, now, after, labels, 6, 3.0)
    np.testing.assert_allclose(share[1:], [1.0, 0.0, 0.0, 0.0, 0.0])
    # the flake moving its own height a frame is new everywhere
    before2, after2 = np.full(shape, 100, np.uint8), np.full(shape, 100, np.uint8)
    before2[16:20, 40] += 20
    after2[24:28, 40] += 20
    assert dt.two_sided_share(before2, now, after2, labels, 6, 3.0)[3] == 1.0


def test_measure_counts_the_blobs_of_a_rendered_scene() -> None:
    name, counts = dt.measure(("tuning", 200, "heavy", "static", dt.FIRST_FRAME + 12, 1))
    assert name.startswith("tuning-") and counts["frames"] == 11
    on_blobs, on_passed = counts["voting|1"]
    off_blobs = counts["voting|0"][0]
    # heavy rain votes with its streaks, and most of them were there for one frame only
    assert on_blobs > 10 * max(off_blobs, 1)
    assert on_passed > 0.8 * on_blobs
