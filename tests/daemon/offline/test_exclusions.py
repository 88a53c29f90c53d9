"""``calibrate`` and ``compare`` say which rule left the intervals out, how many, and which
option changes it (issue 13: "0 wet interval(s)" when --threshold-mm was the cause, "no
interval to score" when the coverage rule was)."""

from __future__ import annotations

import io
import sys

import pytest

from daemon.offline.calibrate import calibrate
from daemon.offline.compare import compare
from daemon.offline.series import load_series
from drivers.errors import InputError
from tests.daemon.offline.test_series import HOUR_NS, T0_NS, frame, hours, write_mcap

MINUTE_NS = 60 * 10**9


def rainy_hours(tmp_path, n_hours, *, minutes=60, judged=True):
    """A log of ``n_hours`` hours of rain seen by the camera (R = 200), one frame a minute over
    the first ``minutes`` of each hour."""
    state = "ok" if judged else "dark"
    frames = [
        frame(T0_NS + h * HOUR_NS + i * MINUTE_NS, R=200.0, rain=True, state=state)
        for h in range(n_hours)
        for i in range(minutes)
    ]
    return write_mcap(tmp_path / "logs" / "site.mcap", frames)


def test_calibrate_blames_the_threshold_when_amounts_are_small(tmp_path):
    path = rainy_hours(tmp_path, 4)
    with pytest.raises(InputError) as err:
        calibrate([path], hours([0.05, 0.06, 0.08, 0.04]), out=None, n_boot=0, progress=False)
    message = str(err.value)
    assert "4 are dry" in message and "--threshold-mm 0.1" in message
    assert "largest amount is 0.08 mm" in message
    # and the option named does fix it
    result = calibrate(
        [path], hours([0.05, 0.06, 0.08, 0.04]), out=None, n_boot=0, progress=False,
        threshold_mm=0.01,
    )  # fmt: skip
    assert result["n"] == 4


def test_calibrate_blames_the_coverage_rule(tmp_path):
    path = rainy_hours(tmp_path, 3, minutes=20)  # frames over 20 min of each hour
    with pytest.raises(InputError) as err:
        calibrate([path], hours([1.0, 2.0, 3.0]), out=None, n_boot=0, progress=False)
    message = str(err.value)
    assert "3 are covered by frames for less than 50%" in message
    assert "--min-coverage" in message and "dry" not in message


def test_compare_blames_the_coverage_rule_and_the_missing_frames(tmp_path):
    path = rainy_hours(tmp_path, 2, minutes=20)
    with pytest.raises(InputError) as err:
        compare([path], hours([1.0, 0.0, 2.0]), progress=False)
    message = str(err.value)
    assert "of 3 reference interval(s)" in message
    assert "1 have no frame of camera cam1" in message
    assert "2 are covered by frames for less than 50%" in message and "--min-coverage" in message
    result = compare([path], hours([1.0, 0.0, 2.0]), progress=False, min_coverage=0.2)
    assert result["intervals_scored"] == 2


def test_compare_blames_the_judged_rule(tmp_path):
    path = rainy_hours(tmp_path, 2, judged=False)
    with pytest.raises(InputError, match=r"2 have fewer than 50% judged frames.*--min-judged"):
        compare([path], hours([1.0, 0.0]), progress=False)


def test_progress_counts_frame_messages_from_the_summaries(tmp_path, monkeypatch):
    rainy_hours(tmp_path, 3, minutes=30)
    stderr = io.StringIO()
    stderr.isatty = lambda: True  # a terminal, as far as the bar can tell
    monkeypatch.setattr(sys, "stderr", stderr)
    series = load_series([tmp_path / "logs"], hours([1.0, 2.0, 3.0]), progress=None)
    assert series.counts["frames_read"] == 90
    shown = stderr.getvalue()
    assert "/90" in shown and "frames of the logs" in shown
