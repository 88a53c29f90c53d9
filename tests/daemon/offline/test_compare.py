"""Scoring the camera's precipitation detection against the reference: confusion and ROC."""

from __future__ import annotations

import json

import numpy as np
import pytest

from daemon.offline.compare import auc, compare, confusion, reference_wet, roc_curves, score
from daemon.offline.series import PI_GRID, Series, aggregate
from drivers.errors import InputError
from tests.daemon.offline.test_series import HOUR_NS, T0_NS, frame, hours, write_mcap


def hour_frames(h: int, rain_share: float, n: int = 20, **fields) -> list[dict]:
    """``n`` judged frames spread over hour ``h``, the first ``rain_share`` of them with rain."""
    k = round(rain_share * n)
    step = HOUR_NS // n
    return [frame(T0_NS + h * HOUR_NS + i * step, rain=i < k, **fields) for i in range(n)]


def series_of(frames, intervals) -> Series:
    stats = aggregate(frames, intervals)
    return Series(intervals=stats, cameras=sorted({s.camera for s in stats}))


def test_confusion_counts_and_rates():
    truth = np.array([1, 1, 1, 0, 0, 0, 0, 1], bool)
    det = np.array([1, 1, 0, 0, 0, 1, 0, 1], bool)
    c = confusion(truth, det)
    assert (c["tp"], c["fp"], c["tn"], c["fn"], c["n"]) == (3, 1, 3, 1, 8)
    assert c["tpr"] == pytest.approx(0.75) and c["fpr"] == pytest.approx(0.25)
    assert c["accuracy"] == pytest.approx(0.75) and c["precision"] == pytest.approx(0.75)
    only_dry = confusion(np.zeros(3, bool), np.zeros(3, bool))
    assert only_dry["tpr"] is None and only_dry["fpr"] == 0.0


def test_auc_of_known_curves():
    assert auc(np.array([0.0]), np.array([1.0])) == pytest.approx(1.0)
    assert auc(np.array([0.3, 0.6]), np.array([0.3, 0.6])) == pytest.approx(0.5)
    assert auc(np.array([1.0]), np.array([0.0])) == pytest.approx(0.0)
    assert auc(np.array([np.nan]), np.array([0.5])) is None


def test_score_confusion_with_thresholds():
    frames = hour_frames(0, 0.0) + hour_frames(1, 0.3) + hour_frames(2, 0.05)
    frames += hour_frames(3, 0.9)
    s = series_of(frames, hours([0.0, 0.05, 0.5, 2.0]))
    r = score(s)
    assert [row["outcome"] for row in r["table"]] == ["TN", "FP", "FN", "TP"]
    c = r["confusion"]
    assert (c["tp"], c["fp"], c["tn"], c["fn"]) == (1, 1, 1, 1)
    assert (r["n_wet"], r["n_dry"]) == (2, 2)
    # a lower gauge threshold: hour 1 becomes wet; a lower camera share: hour 2 is detected
    r = score(s, threshold_mm=0.01, camera_fraction=0.04)
    assert [row["outcome"] for row in r["table"]] == ["TN", "TP", "TP", "TP"]
    json.dumps(r)


def test_presence_reports_and_missing_values():
    frames = hour_frames(0, 0.5) + hour_frames(1, 0.0) + hour_frames(2, 0.5)
    ivs = hours([1.0, 0.0, None], kind="presence")
    assert reference_wet(aggregate(hour_frames(0, 0.5), ivs[:1])[0]) is True
    r = score(series_of(frames, ivs), threshold_mm=5.0)  # presence ignores the mm threshold
    assert [row["outcome"] for row in r["table"]] == ["TP", "TN"]
    assert r["intervals_missing"] == 1


def test_roc_from_recorded_fits():
    wet = [0.6, 0.7, 0.8, 0.2]
    dry = [0.1, 0.2, 0.5, 0.3]
    frames = [
        frame(T0_NS + i * 900 * 10**9, pi=p, gof_d=0.01, gof_ok=True, pi_smoothed=p)
        for i, p in enumerate(wet)
    ]
    frames += [
        frame(T0_NS + HOUR_NS + i * 900 * 10**9, pi=p, gof_d=0.2, gof_ok=True, pi_smoothed=p)
        for i, p in enumerate(dry)
    ]
    stats = aggregate(frames, hours([2.0, 0.0]))
    roc = roc_curves(stats, np.array([True, False]), camera_fraction=0.5)
    pi = roc["frame"]["pi"]
    k = int(np.flatnonzero(PI_GRID == 0.4)[0])
    assert (pi["tpr"][k], pi["fpr"][k]) == (0.75, 0.25)
    # the area is the Mann-Whitney statistic: P(wet pi > dry pi) with ties counted half
    assert pi["auc"] == pytest.approx(13.5 / 16)
    assert roc["frame"]["pi_smoothed"]["auc"] == pytest.approx(13.5 / 16)
    # GoF alone separates them perfectly (0.01 vs 0.2)
    assert roc["frame"]["gof"]["auc"] == pytest.approx(1.0)
    # interval level at p = 0.4: wet hour has 3/4 >= 0.5 -> detected, dry 1/4 -> not
    assert (roc["interval"]["pi"]["tpr"][k], roc["interval"]["pi"]["fpr"][k]) == (1.0, 0.0)


def test_bad_options_and_nothing_to_score(tmp_path):
    s = series_of(hour_frames(0, 0.5), hours([1.0]))
    with pytest.raises(InputError, match="camera_fraction"):
        score(s, camera_fraction=0.0)
    with pytest.raises(InputError, match="threshold_mm"):
        score(s, threshold_mm=-1)
    unjudged = series_of(hour_frames(0, 0.0, state="dark"), hours([1.0]))
    with pytest.raises(InputError, match="no interval to score"):
        score(unjudged)


def test_compare_on_crafted_logs(tmp_path):
    frames = hour_frames(0, 0.0) + hour_frames(1, 0.8) + hour_frames(2, 0.6)
    write_mcap(tmp_path / "a.mcap", frames)
    r = compare([tmp_path], hours([0.0, 1.0, 3.0]), progress=False)
    assert r["confusion"]["accuracy"] == 1.0
    assert r["intervals"]["frames_read"] == 60
    assert "plots" not in r
