"""What the status page shows, kept by the daemon as it runs: the latest message of each Zenoh
key, the last 24 h in 10-s bins, and each camera's latest overlay while someone watches.

The daemon's threads write (:meth:`WebHub.publish` from the main loop, :meth:`CameraFeed.put`
from a camera's processing thread); the web server's thread reads. One lock each; readers get
copies, so nothing the server does can reach into the daemon's state.
"""

from __future__ import annotations

import copy
import math
import threading
import time
from collections import Counter, deque
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["BIN_S", "HISTORY_S", "CameraFeed", "FeedFrame", "WebHub", "blob_centroids"]

#: Width of a history bin (s) and how much history is kept (s): 8640 bins.
BIN_S = 10
HISTORY_S = 24 * 3600
#: A camera's overlay is drawn while the page asked for it within this many seconds.
WATCH_S = 10.0
#: At most this many blobs are sent to the page for the region-of-interest preview.
MAX_BLOBS = 4000


@dataclass(frozen=True)
class FeedFrame:
    """One camera's latest overlay, as the page gets it."""

    t_ns: int
    jpeg: bytes
    width: int  # the frame the detector saw, pixels
    height: int
    result: dict[str, Any]  # FrameResult.to_json()
    #: Blob centroids in frame pixels and their classes (hos.result.BlobClass).
    blobs_x: list[float] = field(default_factory=list)
    blobs_y: list[float] = field(default_factory=list)
    blobs_class: list[int] = field(default_factory=list)


class CameraFeed:
    """A camera's overlay for the page: drawn only while someone watches, at most every
    ``interval_s``. The processing thread asks :meth:`due`, then :meth:`put`."""

    def __init__(self, camera: str, *, interval_s: float = 0.5, width: int = 960):
        self.camera = camera
        self.interval_s = interval_s
        self.width = width
        self._lock = threading.Lock()
        self._watched_until = -math.inf
        self._next = -math.inf
        self._frame: FeedFrame | None = None

    def watch(self, now: float | None = None) -> None:
        """The page wants frames: keep drawing them for the next ``WATCH_S`` seconds."""
        now = time.monotonic() if now is None else now
        with self._lock:
            self._watched_until = now + WATCH_S

    def due(self, now: float | None = None) -> bool:
        """Should the processing thread draw this frame? (cheap: called once per frame)"""
        now = time.monotonic() if now is None else now
        if now >= self._watched_until or now < self._next:
            return False
        self._next = now + self.interval_s
        return True

    def put(self, frame: FeedFrame) -> None:
        with self._lock:
            self._frame = frame

    def latest(self) -> FeedFrame | None:
        with self._lock:
            return self._frame


def blob_centroids(
    labels_flat_index: np.ndarray | None,
    labels: np.ndarray | None,
    classes: np.ndarray | None,
    *,
    width: int,
    label_image: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Centroids (x, y) and class of each blob, from the sparse labels (pixel flat indices and
    their labels) or a label image: one ``np.bincount`` each, no loop over blobs.

    Returns
    -------
    x, y : (K,) float64 pixels; cls : (K,) int, for the labels 1..K that have pixels.
    """
    empty = (np.zeros(0), np.zeros(0), np.zeros(0, np.int64))
    if classes is None:
        return empty
    if labels_flat_index is None or labels is None:
        if label_image is None:
            return empty
        flat = label_image.reshape(-1)
        labels_flat_index = np.flatnonzero(flat)
        labels = flat[labels_flat_index]
    if labels.size == 0:
        return empty
    n = int(classes.size)
    labels = np.asarray(labels, np.int64)
    keep = (labels > 0) & (labels < n)
    idx, lab = np.asarray(labels_flat_index)[keep], labels[keep]
    ys, xs = np.divmod(idx, width)
    count = np.bincount(lab, minlength=n)
    sx = np.bincount(lab, weights=xs, minlength=n)
    sy = np.bincount(lab, weights=ys, minlength=n)
    present = np.flatnonzero(count)
    present = present[present > 0]
    return (
        sx[present] / count[present],
        sy[present] / count[present],
        np.asarray(classes)[present].astype(np.int64),
    )


class _Bin:
    """Means of numbers and counts of words over one history bin."""

    def __init__(self, t0_s: int):
        self.t0_s = t0_s
        self.sums: dict[str, list[float]] = {}  # key -> [sum, n]
        self.words: dict[str, Counter[str]] = {}

    def add(self, key: str, value: float | None) -> None:
        if value is None or not math.isfinite(value):
            return
        acc = self.sums.setdefault(key, [0.0, 0])
        acc[0] += float(value)
        acc[1] += 1

    def word(self, key: str, value: str | None) -> None:
        if value is not None:
            self.words.setdefault(key, Counter())[value] += 1

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {"t": self.t0_s}
        for key, (total, n) in self.sums.items():
            out[key] = round(total / n, 4)
        for key, counts in self.words.items():
            out[key] = counts.most_common(1)[0][0]
        return out


class WebHub:
    """The latest message of each key and the history the page plots.

    Parameters
    ----------
    site : the site id
    clock : seconds since the epoch (a test passes its own)
    """

    def __init__(self, site: str, *, clock: Callable[[], float] = time.time):
        self.site = site
        self._clock = clock
        self._lock = threading.Lock()
        self._latest: dict[str, dict[str, Any]] = {}
        self._bins: deque[_Bin] = deque(maxlen=HISTORY_S // BIN_S)
        self.feeds: dict[str, CameraFeed] = {}
        #: Set by the daemon: what the page may say about the region of interest.
        self.info: dict[str, Any] = {}

    # -- written by the daemon -------------------------------------------------------------
    def add_camera(self, camera: str, **kwargs: Any) -> CameraFeed:
        feed = CameraFeed(camera, **kwargs)
        self.feeds[camera] = feed
        return feed

    def publish(self, suffix: str, message: dict[str, Any]) -> None:
        """A message the daemon publishes under ``weather/<site>/<suffix>``."""
        with self._lock:
            self._latest[suffix] = message
            b = self._bin(message.get("t_ns"))
            if b is None:
                return
            if suffix == "state":
                p = message.get("precipitation")
                b.add("precipitation", None if p is None else float(p))
                b.add("rate_mm_h", message.get("rain_rate_mm_h"))
                b.word("rate_source", message.get("rain_rate_source"))
                b.add("camera_R", message.get("camera_R"))
            elif suffix.startswith("camera/"):
                cam = suffix.split("/")[1]
                b.add(f"cam.{cam}.rain_fraction", message.get("rain_fraction"))
                b.add(f"cam.{cam}.R", message.get("R_mean"))
                b.word(f"cam.{cam}.state", message.get("state"))
            elif suffix.startswith("instrument/") and message.get("schema", "").startswith(
                "instrument.reading"
            ):
                inst = suffix.split("/")[1]
                b.add(f"inst.{inst}.rate_mm_h", message.get("rain_rate_mm_h"))

    def note(self, key: str, value: float | None, *, t_ns: int) -> None:
        """A number for the history that no message carries (the calibrated camera's rate
        while a gauge gives the site's)."""
        with self._lock:
            b = self._bin(t_ns)
            if b is not None:
                b.add(key, value)

    def _bin(self, t_ns: object) -> _Bin | None:
        if not isinstance(t_ns, int):
            return None
        t0 = t_ns // 1_000_000_000 // BIN_S * BIN_S
        if self._bins and self._bins[-1].t0_s == t0:
            return self._bins[-1]
        if self._bins and t0 < self._bins[-1].t0_s:
            return None  # a late message (an instrument's own clock): not re-binned
        b = _Bin(t0)
        self._bins.append(b)
        return b

    # -- read by the server ---------------------------------------------------------------
    def latest(self, suffix: str) -> dict[str, Any] | None:
        with self._lock:
            msg = self._latest.get(suffix)
            return None if msg is None else copy.deepcopy(msg)

    def latest_under(self, prefix: str) -> dict[str, dict[str, Any]]:
        """``{name: message}`` of the keys ``prefix/<name>`` (e.g. ``camera/<id>/hos``)."""
        with self._lock:
            out = {}
            for suffix, msg in self._latest.items():
                if suffix.startswith(prefix + "/"):
                    out[suffix[len(prefix) + 1 :].split("/")[0]] = copy.deepcopy(msg)
            return out

    def history(self, *, since_s: float | None = None) -> list[dict[str, Any]]:
        """The bins that start at or after ``since_s`` (all of the last 24 h by default); the
        last one may still be filling."""
        horizon = self._clock() - HISTORY_S
        lo = horizon if since_s is None else max(since_s, horizon)
        with self._lock:
            return [b.to_json() for b in self._bins if b.t0_s >= lo]
