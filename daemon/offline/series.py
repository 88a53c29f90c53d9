"""Per-frame camera results from MCAP logs, aggregated onto reference intervals in one pass.

The offline tools (calibration of R, comparison with a station) all start here: the
``/hos/<cam>/frame`` messages of the logs are streamed in time order, each frame lands in the
reference interval ``[start, end)`` that holds its time ``t_ns``, and per interval and camera only
counters and sums are kept: months of 25 fps logs never need to fit in memory.

Per interval and camera (:class:`IntervalStats`)
    frames (all), judged frames (``state == "ok"``), judged frames with ``rain``, mean ``R`` and
    mean ``pi_smoothed`` over the judged frames, circular mean of the raw ``mu_deg`` over the
    judged frames whose fit passed the goodness-of-fit test, the time span the frames cover, and
    what the ROC curves need: over the grid :data:`PI_GRID`, the number of judged frames whose
    raw fit has ``pi >= p`` and passed the daemon's GoF test (``gof_ok``; the paper's "GoF +
    Π_rain"), and whose ``pi_smoothed >= p`` (the full decision with Π_rain = p); over
    :data:`GOF_GRID`, the number of judged frames with a fit whose ``gof_d <= d`` (GoF alone).
Usable intervals
    an interval is *used* when at least ``min_judged`` of its frames were judged and its frames
    span at least ``min_coverage`` of it; the others are kept (flagged, counted, reported) but
    the calibration and the scores skip them. Frames outside every interval are counted.

The frames are read by :mod:`daemon.offline.mcap_frames` (:func:`find_mcap_files`,
:func:`iter_frames`: which files, in what order, and what happens to damaged ones) and the mean
histograms computed by :mod:`daemon.offline.histograms` (:func:`mean_histograms`); both are
re-exported here.
"""

from __future__ import annotations

import itertools
import logging
import math
import os
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from drivers.errors import InputError

from .histograms import mean_histograms
from .mcap_frames import find_mcap_files, iter_frames
from .progress import progress_bar

__all__ = [
    "GOF_GRID",
    "PI_GRID",
    "IntervalStats",
    "ReferenceInterval",
    "Series",
    "aggregate",
    "find_mcap_files",
    "iter_frames",
    "load_series",
    "mean_histograms",
    "reference_intervals",
]

log = logging.getLogger(__name__)

#: Thresholds on Π (raw ``pi`` and ``pi_smoothed``) for the ROC curves, dimensionless.
PI_GRID: np.ndarray = np.round(np.linspace(0.0, 1.0, 51), 4)
#: Thresholds on the goodness-of-fit distance D (eq. 26) for the ROC curves, dimensionless.
GOF_GRID: np.ndarray = np.round(np.linspace(0.0, 0.3, 61), 4)

_FLUSH = 8192  # frames buffered per interval and camera before their counts are updated


class ReferenceInterval(Protocol):
    """What the aggregation needs of :class:`daemon.offline.reference.Interval`."""

    start: datetime
    end: datetime
    precip_mm: float | None
    station: str | None
    kind: str


@dataclass
class IntervalStats:
    """The frames of one camera within one reference interval ``[start, end)``.

    Attributes
    ----------
    start, end : UTC, tz-aware
    precip_mm : reference amount over the interval, mm (``kind == "presence"``: 1.0 or 0.0);
        None when missing
    kind, station, quality : from the reference
    camera : camera id
    frames, judged, rain_frames : frame counts (judged: ``state == "ok"``; rain among judged)
    r_mean : mean R over judged frames with an R (relative units), None if none
    pi_smoothed_mean : mean smoothed Π over judged frames, None if none
    mu_mean_deg : circular mean of the raw μ over judged frames whose fit passed the GoF test,
        degrees in [0, 180), None if none
    gof_frames : judged frames whose fit passed the GoF test
    first_t_ns, last_t_ns : times of the first and last frame in the interval, ns
    pi_counts : (len(PI_GRID),) judged frames with a GoF-passing fit and ``pi >= PI_GRID[i]``
    pi_smoothed_counts : (len(PI_GRID),) judged frames with ``pi_smoothed >= PI_GRID[i]``
    gof_counts : (len(GOF_GRID),) judged frames with a fit and ``gof_d <= GOF_GRID[j]``
    used : enough judged frames and coverage to be used (see the module docstring)
    """

    start: datetime
    end: datetime
    precip_mm: float | None
    kind: str
    station: str | None
    quality: str | None
    camera: str
    frames: int = 0
    judged: int = 0
    rain_frames: int = 0
    r_mean: float | None = None
    pi_smoothed_mean: float | None = None
    mu_mean_deg: float | None = None
    gof_frames: int = 0
    first_t_ns: int = 0
    last_t_ns: int = 0
    pi_counts: np.ndarray = field(default_factory=lambda: np.zeros(PI_GRID.size, np.int64))
    pi_smoothed_counts: np.ndarray = field(default_factory=lambda: np.zeros(PI_GRID.size, np.int64))
    gof_counts: np.ndarray = field(default_factory=lambda: np.zeros(GOF_GRID.size, np.int64))
    used: bool = False

    @property
    def duration_s(self) -> float:
        """Length of the interval, s."""
        return (self.end - self.start).total_seconds()

    @property
    def judged_fraction(self) -> float:
        """Share of the interval's frames that the camera could judge, in [0, 1]."""
        return self.judged / self.frames if self.frames else 0.0

    @property
    def rain_fraction(self) -> float:
        """Share of the judged frames with ``rain``, in [0, 1] (0 when none was judged)."""
        return self.rain_frames / self.judged if self.judged else 0.0

    @property
    def coverage(self) -> float:
        """Share of the interval spanned by its frames (one frame period added), in [0, 1]."""
        if self.frames == 0:
            return 0.0
        span_ns = self.last_t_ns - self.first_t_ns
        period_ns = span_ns / (self.frames - 1) if self.frames > 1 else 0.0
        return min(1.0, (span_ns + period_ns) / (self.duration_s * 1e9))

    @property
    def rate_mm_h(self) -> float | None:
        """Reference rain rate, mm/h: ``precip_mm`` over the interval's length."""
        if self.precip_mm is None or self.kind != "amount":
            return None
        return self.precip_mm / (self.duration_s / 3600.0)

    def to_json(self) -> dict[str, Any]:
        """The scalar fields as a JSON-able dict (times ISO-8601 UTC)."""
        return {
            "start": _iso(self.start),
            "end": _iso(self.end),
            "camera": self.camera,
            "precip_mm": self.precip_mm,
            "rate_mm_h": self.rate_mm_h,
            "kind": self.kind,
            "frames": self.frames,
            "judged": self.judged,
            "judged_fraction": round(self.judged_fraction, 4),
            "coverage": round(self.coverage, 4),
            "rain_fraction": round(self.rain_fraction, 4),
            "r_mean": self.r_mean,
            "pi_smoothed_mean": self.pi_smoothed_mean,
            "mu_mean_deg": self.mu_mean_deg,
            "used": self.used,
        }


@dataclass
class Series:
    """The aggregated logs: per-interval statistics of one or more cameras, and the bookkeeping.

    Attributes
    ----------
    intervals : IntervalStats of every (interval, camera) that received at least one frame,
        sorted by start then camera
    cameras : camera ids seen, sorted
    mcap_files : the files read, in reading order
    counts : frames_read, frames_outside (in no interval), bad_messages, files_skipped,
        reference_intervals, intervals_no_frames, intervals_low_judged, intervals_low_coverage
    skipped_files : paths of the damaged files skipped
    reference : name of the reference file (or None), station (or None)
    min_judged, min_coverage : the rules an interval passed to be used (see :func:`aggregate`)
    """

    intervals: list[IntervalStats]
    cameras: list[str]
    mcap_files: list[Path] = field(default_factory=list)
    counts: dict[str, int] = field(default_factory=dict)
    skipped_files: list[str] = field(default_factory=list)
    reference: str | None = None
    station: str | None = None
    min_judged: float = 0.5
    min_coverage: float = 0.5

    def for_camera(self, camera: str) -> list[IntervalStats]:
        """The intervals of ``camera``, in time order."""
        return [s for s in self.intervals if s.camera == camera]

    def unused_reasons(self, camera: str) -> list[str]:
        """Why reference intervals are not used for ``camera``: one phrase per rule that left
        some out, with the count and the option that changes the rule (empty if all are used).
        """
        stats = self.for_camera(camera)
        n_ref = self.counts.get("reference_intervals", len(stats))
        low_judged = sum(s.judged_fraction < self.min_judged for s in stats)
        low_coverage = sum(
            s.judged_fraction >= self.min_judged and s.coverage < self.min_coverage for s in stats
        )
        reasons = []
        if n_ref > len(stats):
            reasons.append(f"{n_ref - len(stats)} have no frame of camera {camera} in the logs")
        if low_judged:
            reasons.append(
                f"{low_judged} have fewer than {self.min_judged:.0%} judged frames "
                "(the camera could not judge: dark, unstable, warming up; --min-judged)"
            )
        if low_coverage:
            reasons.append(
                f"{low_coverage} are covered by frames for less than {self.min_coverage:.0%} of "
                "their length (the log starts or ends inside them, or has gaps; --min-coverage)"
            )
        return reasons

    def select_camera(self, camera: str | None) -> str:
        """``camera`` if it was seen, or the only camera seen.

        Raises
        ------
        InputError : no frame at all, an unknown camera, or several cameras and none chosen.
        """
        if not self.cameras:
            raise InputError("no /hos/<camera>/frame message falls in any reference interval")
        if camera is None:
            if len(self.cameras) > 1:
                raise InputError(
                    f"the logs hold several cameras ({', '.join(self.cameras)}): choose one "
                    "with --camera"
                )
            return self.cameras[0]
        if camera not in self.cameras:
            raise InputError(
                f"camera {camera!r} has no frame in the reference intervals "
                f"(cameras seen: {', '.join(self.cameras)})"
            )
        return camera


# ---------------------------------------------------------------------------------------------
# Reference


def reference_intervals(
    reference: str | os.PathLike[str] | Iterable[ReferenceInterval],
    *,
    station: str | None = None,
    options: Mapping[str, Any] | None = None,
) -> list[ReferenceInterval]:
    """Reference intervals, sorted and checked for overlaps.

    Parameters
    ----------
    reference : a station file (read with :func:`daemon.offline.reference.read_reference`) or
        intervals already read
    station : keep this station only (passed to the reader, and filtered here)
    options : more keyword arguments of ``read_reference`` (``fmt``, ``tz``, ``interval_s``...)

    Raises
    ------
    InputError : unreadable file (from the reader), no interval, or overlapping intervals
        (several stations in the file and none chosen).
    """
    if isinstance(reference, str | os.PathLike):
        from .reference import read_reference

        name = Path(reference).name
        intervals = list(read_reference(reference, station=station, **(options or {})))
    else:
        name = "reference"
        intervals = list(reference)
    if station is not None:
        intervals = [iv for iv in intervals if iv.station in (None, station)]
    if not intervals:
        raise InputError(
            f"{name}: no reference interval" + (f" for station {station}" * bool(station))
        )
    intervals.sort(key=lambda iv: (iv.start, iv.end))
    for prev, cur in itertools.pairwise(intervals):
        if cur.start < prev.end:
            stations = sorted({str(iv.station) for iv in intervals})
            if len(stations) > 1:
                raise InputError(
                    f"{name}: holds several stations ({', '.join(stations[:5])}"
                    f"{', …' if len(stations) > 5 else ''}): choose one with --station"
                )
            raise InputError(
                f"{name}: overlapping reference intervals at {_iso(prev.start)} and "
                f"{_iso(cur.start)}"
            )
    return intervals


# ---------------------------------------------------------------------------------------------
# Aggregation


class _Acc:
    """Running counts of one (interval, camera); per-frame values buffered, then counted."""

    __slots__ = (
        "buf_d",
        "buf_pi",
        "buf_ps",
        "first",
        "frames",
        "gof",
        "judged",
        "last",
        "mu_c",
        "mu_s",
        "n_ps",
        "n_r",
        "rain",
        "stats",
        "sum_ps",
        "sum_r",
    )

    def __init__(self, stats: IntervalStats, t_ns: int):
        self.stats = stats
        self.frames = self.judged = self.rain = self.gof = self.n_r = self.n_ps = 0
        self.sum_r = self.sum_ps = self.mu_c = self.mu_s = 0.0
        self.first = self.last = t_ns
        self.buf_pi: list[float] = []  # raw pi of judged frames whose fit passed GoF
        self.buf_ps: list[float] = []  # pi_smoothed of judged frames
        self.buf_d: list[float] = []  # gof_d of judged frames with a fit

    def add(self, frame: dict[str, Any], t_ns: int) -> None:
        self.frames += 1
        self.first = min(self.first, t_ns)
        self.last = max(self.last, t_ns)
        if frame.get("state") != "ok":
            return
        self.judged += 1
        if frame.get("rain") is True:
            self.rain += 1
        r = frame.get("R")
        if r is not None and math.isfinite(r):
            self.sum_r += r
            self.n_r += 1
        ps = frame.get("pi_smoothed")
        if ps is not None and math.isfinite(ps):
            self.sum_ps += ps
            self.n_ps += 1
            self.buf_ps.append(ps)
        d = frame.get("gof_d")
        if d is not None and math.isfinite(d):
            self.buf_d.append(d)
        pi = frame.get("pi")
        if frame.get("gof_ok") is True and pi is not None and math.isfinite(pi):
            self.gof += 1
            self.buf_pi.append(pi)
            mu = frame.get("mu_deg")
            if mu is not None and math.isfinite(mu):
                angle = math.radians(2.0 * mu)  # orientations are π-periodic: double the angle
                self.mu_c += math.cos(angle)
                self.mu_s += math.sin(angle)
        if len(self.buf_ps) >= _FLUSH or len(self.buf_d) >= _FLUSH:
            self.flush()

    def flush(self) -> None:
        s = self.stats
        s.pi_counts += _count_at_least(self.buf_pi, PI_GRID)
        s.pi_smoothed_counts += _count_at_least(self.buf_ps, PI_GRID)
        s.gof_counts += _count_at_most(self.buf_d, GOF_GRID)
        self.buf_pi.clear()
        self.buf_ps.clear()
        self.buf_d.clear()

    def finish(self, *, min_judged: float, min_coverage: float) -> IntervalStats:
        self.flush()
        s = self.stats
        s.frames, s.judged, s.rain_frames, s.gof_frames = (
            self.frames,
            self.judged,
            self.rain,
            self.gof,
        )
        s.first_t_ns, s.last_t_ns = self.first, self.last
        s.r_mean = self.sum_r / self.n_r if self.n_r else None
        s.pi_smoothed_mean = self.sum_ps / self.n_ps if self.n_ps else None
        if self.mu_c or self.mu_s:
            s.mu_mean_deg = (math.degrees(math.atan2(self.mu_s, self.mu_c)) / 2.0) % 180.0
        s.used = s.judged_fraction >= min_judged and s.coverage >= min_coverage
        return s


def _count_at_least(values: list[float], grid: np.ndarray) -> np.ndarray:
    """(len(grid),) number of ``values`` >= each threshold of the ascending ``grid``."""
    if not values:
        return np.zeros(grid.size, np.int64)
    v = np.sort(np.asarray(values, dtype=np.float64))
    return v.size - np.searchsorted(v, grid, side="left")


def _count_at_most(values: list[float], grid: np.ndarray) -> np.ndarray:
    """(len(grid),) number of ``values`` <= each threshold of the ascending ``grid``."""
    if not values:
        return np.zeros(grid.size, np.int64)
    v = np.sort(np.asarray(values, dtype=np.float64))
    return np.searchsorted(v, grid, side="right").astype(np.int64)


def aggregate(
    frames: Iterable[dict[str, Any]],
    intervals: Sequence[ReferenceInterval],
    *,
    min_judged: float = 0.5,
    min_coverage: float = 0.5,
    counts: dict[str, int] | None = None,
) -> list[IntervalStats]:
    """Aggregate time-ordered frame payloads onto sorted, non-overlapping intervals, in one pass.

    Parameters
    ----------
    frames : ``hos.frame/1`` payloads (``t_ns``, ``camera``, ``state``, ``rain``, ``R``...) in
        ascending ``t_ns``, give or take a little: a frame earlier than the previous one still
        counts while its interval is open; once a later interval has begun, it is counted as
        out of order and dropped
    intervals : reference intervals sorted by start, not overlapping (:func:`reference_intervals`)
    min_judged : least share of judged frames for an interval to be used, in [0, 1]
    min_coverage : least share of an interval its frames must span to be used, in [0, 1]
    counts : if given, updated with frames_read, frames_outside, frames_out_of_order

    Returns
    -------
    list of IntervalStats, one per (interval, camera) with at least one frame, in time order.
    """
    bounds = [(_ns(iv.start), _ns(iv.end)) for iv in intervals]
    out: list[IntervalStats] = []
    open_accs: dict[str, _Acc] = {}
    k = 0  # the first interval that may still receive frames
    n_read = n_outside = n_disorder = 0
    last_t = -(2**63)

    def close_current() -> None:
        for cam in sorted(open_accs):
            out.append(open_accs[cam].finish(min_judged=min_judged, min_coverage=min_coverage))
        open_accs.clear()

    for frame in frames:
        n_read += 1
        t = int(frame["t_ns"])
        late = t < last_t
        last_t = max(last_t, t)
        while k < len(bounds) and bounds[k][1] <= t:
            close_current()
            k += 1
        if k == len(bounds) or t < bounds[k][0]:
            if late and k > 0 and t < bounds[k - 1][1]:
                n_disorder += 1  # its interval is already closed
            else:
                n_outside += 1
            continue
        cam = str(frame.get("camera", ""))
        acc = open_accs.get(cam)
        if acc is None:
            iv = intervals[k]
            stats = IntervalStats(
                start=iv.start,
                end=iv.end,
                precip_mm=iv.precip_mm,
                kind=getattr(iv, "kind", "amount"),
                station=iv.station,
                quality=getattr(iv, "quality", None),
                camera=cam,
            )
            acc = open_accs[cam] = _Acc(stats, t)
        acc.add(frame, t)
    close_current()
    if counts is not None:
        counts["frames_read"] = counts.get("frames_read", 0) + n_read
        counts["frames_outside"] = counts.get("frames_outside", 0) + n_outside
        counts["frames_out_of_order"] = counts.get("frames_out_of_order", 0) + n_disorder
    if n_disorder:
        log.warning("%d frames out of time order were dropped", n_disorder)
    return out


def load_series(
    mcap_paths: Iterable[str | os.PathLike[str]],
    reference: str | os.PathLike[str] | Iterable[ReferenceInterval],
    *,
    station: str | None = None,
    camera: str | None = None,
    min_judged: float = 0.5,
    min_coverage: float = 0.5,
    progress: bool | None = None,
    reference_options: Mapping[str, Any] | None = None,
) -> Series:
    """Read the reference, stream the logs and aggregate them: the common first step.

    Parameters
    ----------
    mcap_paths : MCAP files or directories
    reference : a station file or intervals (see :func:`reference_intervals`)
    station : station to keep from a multi-station file
    camera : only this camera (the ``--camera`` filter); None: all cameras
    min_judged, min_coverage : see :func:`aggregate`
    progress : progress bar in frame messages, with an ETA (None or True: on a terminal only;
        False: none)
    reference_options : more keyword arguments of ``read_reference`` (``fmt``, ``tz``,
        ``interval_s``, ``month``)

    Raises
    ------
    InputError : bad paths, unreadable reference, thresholds out of [0, 1].
    """
    for name, value in (("min_judged", min_judged), ("min_coverage", min_coverage)):
        if not 0.0 <= value <= 1.0:
            option = "--" + name.replace("_", "-")
            raise InputError(f"{option} ({name}) must be within [0, 1], got {value}")
    mcap_paths = list(mcap_paths)
    if not mcap_paths:
        raise InputError("no MCAP file given")
    find_mcap_files(mcap_paths)  # fail early on a bad path, before reading the reference
    intervals = reference_intervals(reference, station=station, options=reference_options)
    counts: dict[str, int] = {}
    skipped: list[str] = []
    opened: list[Path] = []
    frames = iter_frames(mcap_paths, camera=camera, progress=False, skipped=skipped, opened=opened)
    bar = progress_bar(
        _frame_messages(find_mcap_files(mcap_paths), camera) if progress is not False else None,
        desc="frames of the logs",
        enabled=progress,
    )
    if bar is not None:
        frames = _counted(frames, bar)
    stats = aggregate(
        frames, intervals, min_judged=min_judged, min_coverage=min_coverage, counts=counts
    )
    with_frames = {s.start for s in stats}
    counts["files_read"] = len(opened)
    counts["files_skipped"] = len(skipped)
    counts["reference_intervals"] = len(intervals)
    counts["intervals_no_frames"] = len(intervals) - len(with_frames)
    counts["intervals_low_judged"] = sum(s.judged_fraction < min_judged for s in stats)
    counts["intervals_low_coverage"] = sum(
        s.judged_fraction >= min_judged and s.coverage < min_coverage for s in stats
    )
    counts["intervals_used"] = sum(s.used for s in stats)
    log.info(
        "%d frames read from %d files; %d (interval, camera) pairs, %d used",
        counts.get("frames_read", 0),
        len(opened),
        len(stats),
        counts["intervals_used"],
    )
    if isinstance(reference, str | os.PathLike):
        ref_name = Path(reference).name
    else:
        ref_name = None
    stations = sorted({str(iv.station) for iv in intervals if iv.station is not None})
    return Series(
        intervals=stats,
        cameras=sorted({s.camera for s in stats}),
        mcap_files=opened,
        counts=counts,
        skipped_files=skipped,
        reference=ref_name,
        station=station or (stations[0] if len(stations) == 1 else None),
        min_judged=min_judged,
        min_coverage=min_coverage,
    )


def _frame_messages(files: Iterable[Path], camera: str | None) -> int | None:
    """How many ``/hos/<cam>/frame`` messages the files hold, from their summaries (read
    without reading a message); None when no summary says."""
    import struct

    from mcap.exceptions import McapError
    from mcap.reader import make_reader

    total = 0
    for path in files:
        try:
            with open(path, "rb") as f:
                summary = make_reader(f).get_summary()
        except (McapError, struct.error, ValueError, EOFError, RuntimeError, OSError, KeyError):
            # damaged: iter_frames skips it and says so
            continue
        if summary is None or summary.statistics is None:
            continue
        counts = summary.statistics.channel_message_counts
        for channel_id, channel in summary.channels.items():
            parts = channel.topic.split("/")
            if parts[:2] == ["", "hos"] and parts[3:] == ["frame"] and len(parts) == 4:
                if camera is None or parts[2] == camera:
                    total += counts.get(channel_id, 0)
    return total or None


def _counted(frames: Iterable[dict[str, Any]], bar: Any) -> Iterator[dict[str, Any]]:
    """``frames``, advancing ``bar`` by one each (in steps of 1024, tqdm's own cost being
    noticeable at 100 000 frames a second), closing it at the end."""
    n = 0
    try:
        for frame in frames:
            yield frame
            n += 1
            if n == 1024:
                bar.update(n)
                n = 0
        bar.update(n)
    finally:
        bar.close()


def _ns(t: datetime) -> int:
    if t.tzinfo is None:
        t = t.replace(tzinfo=UTC)
    delta = t - datetime(1970, 1, 1, tzinfo=UTC)
    return (delta.days * 86400 + delta.seconds) * 1_000_000_000 + delta.microseconds * 1000


def _iso(t: datetime) -> str:
    return t.astimezone(UTC).strftime("%Y-%m-%dT%H:%M:%SZ")
