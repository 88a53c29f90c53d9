"""bench/codec_survival.py: the streaks that stand out of a frame against its dry twin, on
hand-made frames with a known answer, and on one scene before and after H.264."""

from __future__ import annotations

import importlib.util
import sys
from dataclasses import replace

import numpy as np
import pytest

from drivers.simulator.families import sample_case
from tests.conftest import REPO

_spec = importlib.util.spec_from_file_location(
    "codec_survival", REPO / "bench" / "codec_survival.py"
)
cs = importlib.util.module_from_spec(_spec)
sys.modules["codec_survival"] = cs  # its dataclasses look their module up
_spec.loader.exec_module(cs)


def test_standing_out_counts_streaks_and_the_codec_noise_beside_them() -> None:
    dry = np.full((120, 160), 100, np.uint8)
    streaks = np.zeros(dry.shape, bool)
    wet = dry.copy()
    for y, x, lift in [(10, 10, 20), (40, 60, 8), (70, 100, 3)]:
        streaks[y : y + 8, x] = True
        wet[y : y + 8, x] += lift
    assert cs.standing_out(wet, dry, streaks) == (3, 2, 0)  # the faint one (3 grey) is lost
    # noise as bright as a streak where the control looks (17 rows, 23 columns further)
    wet[10 + 17 + 3, 10 + 23] = 130
    assert cs.standing_out(wet, dry, streaks) == (3, 2, 1)
    # darker is never standing out; no streak, nothing to count
    assert cs.standing_out(dry - 10, dry, streaks)[1] == 0
    assert cs.standing_out(wet, dry, np.zeros_like(streaks)) == (0, 0, 0)


def test_a_harsh_codec_leaves_fewer_streaks_standing_out() -> None:
    case = sample_case("tuning", 1200, condition="light", camera="static", frames=110)
    case = replace(case, params=replace(case.params, jpeg_quality=None))
    raw = cs.measure(replace(case, h264_crf=None))
    harsh = cs.measure(replace(case, h264_crf=40))
    assert raw.frames == harsh.frames == 110 - cs.SETTLE
    assert raw.stand_out >= 0.9 * raw.drawn and raw.chance == 0
    assert harsh.drawn == raw.drawn
    assert harsh.stand_out - harsh.chance < 0.7 * raw.stand_out
    assert harsh.contrast < raw.contrast


def test_a_scene_without_rain_is_refused() -> None:
    case = sample_case("tuning", 200, condition="snow", camera="static", frames=10)
    with pytest.raises(ValueError, match="no rain"):
        cs.dry_twin(case)
