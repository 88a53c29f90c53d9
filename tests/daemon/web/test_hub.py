"""The page's data: blob centroids, history bins, and overlays drawn only while watched."""

from __future__ import annotations

import numpy as np
import pytest

from daemon.web.hub import BIN_S, HISTORY_S, CameraFeed, FeedFrame, WebHub, blob_centroids


def _brute_centroids(labels: np.ndarray, classes: np.ndarray):
    out = []
    for k in range(1, classes.size):
        ys, xs = np.nonzero(labels == k)
        if xs.size:
            out.append((xs.mean(), ys.mean(), classes[k]))
    return out


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_blob_centroids_equal_a_loop_over_blobs(seed: int) -> None:
    rng = np.random.default_rng(seed)
    labels = rng.integers(0, 12, size=(30, 41)).astype(np.int32)
    labels[labels == 7] = 0  # a label with no pixel
    classes = rng.integers(1, 5, size=12).astype(np.uint8)
    want = _brute_centroids(labels, classes)
    # from a label image
    x, y, cls = blob_centroids(None, None, classes, width=41, label_image=labels)
    np.testing.assert_allclose(np.c_[x, y, cls], np.array(want, dtype=float))
    # from the sparse form (flat indices + labels), as the detector keeps it
    flat = labels.reshape(-1)
    idx = np.flatnonzero(flat)
    x2, y2, cls2 = blob_centroids(idx, flat[idx], classes, width=41)
    np.testing.assert_allclose(np.c_[x2, y2, cls2], np.array(want, dtype=float))


def test_blob_centroids_of_nothing() -> None:
    for args in ((None, None, None), (np.zeros(0, int), np.zeros(0, int), np.zeros(1, np.uint8))):
        x, y, cls = blob_centroids(*args, width=10)
        assert x.size == y.size == cls.size == 0


def _msg(schema: str, t_s: float, **fields):
    return {"schema": schema, "t_ns": int(t_s * 1e9), **fields}


def test_history_bins_average_numbers_and_keep_the_commonest_word() -> None:
    now = [1_000_000.0]
    hub = WebHub("s", clock=lambda: now[0])
    t0 = 1_000_000 // BIN_S * BIN_S
    for i, (p, rate) in enumerate([(True, 2.0), (False, 0.0), (True, 4.0)]):
        hub.publish("state", _msg("weather.state/1", t0 + i, precipitation=p, rain_rate_mm_h=rate))
    for i, st in enumerate(["ok", "unstable", "ok"]):
        hub.publish(
            "camera/c1/hos",
            _msg("weather.camera/1", t0 + i, rain_fraction=0.5, R_mean=10.0 * i, state=st),
        )
    hub.publish("instrument/g/x", _msg("instrument.reading/1", t0 + 1, rain_rate_mm_h=1.5))
    hub.publish("state", _msg("weather.state/1", t0 + BIN_S, precipitation=None))
    bins = hub.history()
    assert [b["t"] for b in bins] == [t0, t0 + BIN_S]
    first = bins[0]
    assert first["precipitation"] == pytest.approx(2 / 3, abs=1e-4)
    assert first["rate_mm_h"] == 2.0
    assert first["cam.c1.state"] == "ok"
    assert first["cam.c1.R"] == 10.0
    assert first["inst.g.rate_mm_h"] == 1.5
    assert "precipitation" not in bins[1]  # null is not a number
    assert [b["t"] for b in hub.history(since_s=t0 + 1)] == [t0 + BIN_S]
    # Older than 24 h: gone from what the page gets.
    now[0] = t0 + HISTORY_S + 5
    assert [b["t"] for b in hub.history()] == [t0 + BIN_S]


def test_latest_messages_are_copies() -> None:
    hub = WebHub("s")
    hub.publish("camera/a/hos", _msg("weather.camera/1", 5, rain=True))
    hub.publish("camera/b/hos", _msg("weather.camera/1", 5, rain=False))
    got = hub.latest_under("camera")
    assert set(got) == {"a", "b"} and got["a"]["rain"] is True
    got["a"]["rain"] = False
    assert hub.latest("camera/a/hos")["rain"] is True
    assert hub.latest("state") is None


def test_feed_draws_only_while_watched_and_at_its_interval() -> None:
    feed = CameraFeed("c", interval_s=0.5)
    assert not feed.due(now=100.0)  # nobody watches
    feed.watch(now=100.0)
    assert feed.due(now=100.0)
    assert not feed.due(now=100.2)  # too soon
    assert feed.due(now=100.6)
    assert not feed.due(now=111.0)  # the page stopped asking 10 s ago
    frame = FeedFrame(t_ns=1, jpeg=b"x", width=4, height=3, result={})
    feed.put(frame)
    assert feed.latest() is frame
