"""``weatherd replay``: the daemon's pipeline over recorded video, into one MCAP file.

The videos are one camera, one after the other; each starts a fresh detector (a new clip may be
another scene). Frame times are UTC: the first frame of the first video is at ``start`` (default:
the file's modification time), each later video starts one frame after the previous one ended,
and within a video a frame is at ``start + index / fps`` when ``fps`` is given, else at
``start + t_s`` from the container's timestamps. The MCAP file has the daemon's topics:
``/hos/<cam>/frame``, ``/hos/<cam>/histogram``, ``/hos/<cam>/thumbnail``, and, once a second of
video time, ``/hos/<cam>/summary`` and ``/weather/state``.
"""

from __future__ import annotations

import datetime as dt
import logging
import os
from collections import deque
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from daemon.config import FusionConfig, RecordingConfig
from daemon.recording.recorder import McapFile
from daemon.recording.results import ResultRecorder
from daemon.service.detection import detect_frames
from daemon.service.fusion import CameraWindow, Persistence, fuse
from daemon.transport.messages import schema_for
from drivers.errors import InputError
from drivers.video import Frame, open_video
from hos import HosDetector
from hos.params import DetectorParams

from .progress import progress_bar

__all__ = ["ReplaySummary", "parse_start", "replay"]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class ReplaySummary:
    out: str
    videos: int
    frames: int
    rain_frames: int
    frames_skipped: int
    first_t_ns: int | None
    last_t_ns: int | None


def parse_start(text: str) -> int:
    """ISO-8601 to UTC ns; a time without a zone is taken as UTC.

    Raises
    ------
    InputError : not an ISO-8601 date-time.
    """
    try:
        t = dt.datetime.fromisoformat(text.replace("Z", "+00:00") if text.endswith("Z") else text)
    except ValueError:
        raise InputError(f"--start: not an ISO-8601 date-time: {text!r}") from None
    if t.tzinfo is None:
        t = t.replace(tzinfo=dt.UTC)
    return int(t.timestamp() * 1e6) * 1000


def replay(
    videos: Sequence[str | os.PathLike[str]],
    out: str | os.PathLike[str],
    *,
    site: str = "replay",
    camera: str = "replay",
    params: DetectorParams | None = None,
    recording: RecordingConfig | None = None,
    fusion: FusionConfig | None = None,
    start_ns: int | None = None,
    fps: float | None = None,
    progress: bool = False,
) -> ReplaySummary:
    """Run the detector over ``videos`` and write the daemon's MCAP topics to ``out``.

    ``fusion`` (the daemon's defaults when None) makes the recorded site state persistent as
    the daemon's is.

    Raises
    ------
    InputError : a video cannot be read, or ``out`` cannot be written.
    """
    fusion = fusion or FusionConfig()
    persistence = Persistence(onset_s=fusion.onset_s, end_s=fusion.end_s)
    params = params or DetectorParams()
    recording = recording or RecordingConfig()
    if fps is not None and not fps > 0:
        raise InputError(f"--fps must be > 0, got {fps}")
    out = Path(out)
    for path in videos:  # every input checked before the output is created
        if not Path(path).exists():
            raise InputError(f"{path}: no such file or directory")
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        mcap = McapFile(out)
    except OSError as exc:
        raise InputError(f"{out}: cannot write ({exc.strerror or exc})") from None
    frames = rain = skipped = 0
    first_t: int | None = None
    last_t: int | None = None
    next_start = start_ns
    with mcap:
        results = ResultRecorder(mcap, site=site, camera=camera, params=params, config=recording)
        window = CameraWindow(camera)
        for path in videos:
            with open_video(path, fps=fps) as video:
                period = 1.0 / (fps or video.fps)
                t0 = next_start if next_start is not None else _mtime_ns(path)
                bar = _progress(path, video, enabled=progress)
                in_flight: deque[Frame] = deque()

                def decoded(video=video, in_flight=in_flight) -> Iterator[tuple[float, np.ndarray]]:
                    for frame in video:
                        in_flight.append(frame)
                        yield frame.t_s, frame.gray

                detector = HosDetector(params)
                next_summary: int | None = None
                gen = detect_frames(detector, decoded())
                try:
                    for result in gen:
                        frame = in_flight.popleft()
                        t_s = frame.index / fps if fps else frame.t_s
                        t_ns = t0 + round(t_s * 1e9)
                        results.write(result, frame.gray, t_ns=t_ns)
                        window.add(result, t_ns=t_ns, processing_s=0.0)
                        if next_summary is None:
                            next_summary = t_ns + 1_000_000_000
                        if t_ns >= next_summary:
                            _summaries(mcap, window, persistence, site, camera, t_ns)
                            next_summary += 1_000_000_000
                        frames += 1
                        rain += bool(result.rain)
                        first_t = t_ns if first_t is None else first_t
                        last_t = t_ns
                        if bar is not None:
                            bar.update(1)
                finally:
                    gen.close()
                    if bar is not None:
                        bar.close()
                skipped += video.frames_skipped
                if last_t is not None:
                    next_start = last_t + round(period * 1e9)
    return ReplaySummary(str(out), len(videos), frames, rain, skipped, first_t, last_t)


def _summaries(
    mcap: McapFile,
    window: CameraWindow,
    persistence: Persistence,
    site: str,
    camera: str,
    t_ns: int,
) -> None:
    summary = window.summary(site=site, t_ns=t_ns, capture_state="ok", window_s=1.0)
    mcap.write(
        f"/hos/{camera}/summary",
        "weather.camera",
        schema_for("weather.camera"),
        summary,
        t_ns=t_ns,
    )
    state = fuse(
        {camera: window.view()}, site=site, t_ns=t_ns, stale_s=5.0, persistence=persistence
    )
    mcap.write("/weather/state", "weather.state", schema_for("weather.state"), state, t_ns=t_ns)


def _mtime_ns(path: str | os.PathLike[str]) -> int:
    try:
        return os.stat(path).st_mtime_ns
    except OSError as exc:
        raise InputError(f"{path}: {exc.strerror}") from None


def _progress(path: str | os.PathLike[str], video: object, *, enabled: bool):
    """A bar in frames; its total (and so its ETA) is the reader's ``frame_count`` when the
    container says how many frames it holds."""
    total = getattr(video, "frame_count", None)
    return progress_bar(total, desc=Path(path).name, enabled=enabled)
