"""``weatherd detect VIDEO``: the detector over a video file, an image folder or the demo
street, offline."""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import sys
import time
from collections import deque
from collections.abc import Callable, Iterator
from typing import TYPE_CHECKING, TextIO

from drivers.errors import InputError, WeatherdError
from drivers.frame_size import (
    DETECTOR_BYTES_PER_PIXEL,
    MAX_FRAME_PIXELS,
    MAX_PIXELS_LIMIT,
    MIN_FRAME_PIXELS,
)

from .common import EXIT_INTERRUPTED, EXIT_OK, StopOnSignals, config_params

if TYPE_CHECKING:
    import numpy as np

    from drivers.video import Frame
    from hos.result import FrameResult

# The detector, the decoder and OpenCV are imported by the handlers, not here: every
# ``weatherd`` command builds its parser from this module, and ``weatherd get`` or
# ``--help`` should not wait a second for numba and OpenCV to load.
__all__ = ["read_roi", "register"]


def _detect(args: argparse.Namespace) -> int:
    """``weatherd detect VIDEO``: the detector over a file or image folder, offline."""
    from daemon.offline.progress import progress_bar
    from daemon.service.detection import detect_frames
    from drivers.sources import open_frames
    from drivers.video import VideoWriter
    from hos.overlay import draw_overlay
    from hos.pipeline import HosDetector

    params = config_params(args.config)[1]
    frames = rain_frames = skipped = 0
    interrupted = False
    if args.video.lower().startswith("demo:") and args.frames is None and args.seconds is None:
        raise InputError(
            f"the demo street ({args.video}) never ends: give --frames N or --seconds S"
        )
    with contextlib.ExitStack() as stack:  # closed in reverse: overlay, JSONL, video
        video = stack.enter_context(open_frames(args.video, max_pixels=args.max_pixels))
        roi = read_roi(args.roi, width=video.width, height=video.height) if args.roi else None
        detector = HosDetector(params, roi=roi)
        jsonl = stack.enter_context(_jsonl_output(args.jsonl)) if args.jsonl else None
        overlay = (
            stack.enter_context(
                VideoWriter(args.overlay, width=video.width, height=video.height, fps=video.fps)
            )
            if args.overlay
            else None
        )
        in_flight: deque[Frame] = deque()  # frames whose result is not out yet (at most 2)

        def decoded() -> Iterator[tuple[float, np.ndarray]]:
            for frame in video:
                if args.frames is not None and frame.index >= args.frames:
                    return
                if args.seconds is not None and frame.t_s >= args.seconds:
                    return
                in_flight.append(frame)
                yield frame.t_s, frame.gray

        started = time.perf_counter()
        results = detect_frames(detector, decoded())  # segmentation of n+1 beside analysis of n
        # Ctrl-C (or SIGTERM) sets a flag read between frames, rather than raising wherever the
        # main thread happens to be (inside a compiled kernel, the exception would be garbled);
        # a second one ends the process at once.
        stop = StopOnSignals()
        total = getattr(video, "frame_count", None)  # known when the container says
        bar = progress_bar(total, desc=os.path.basename(args.video), enabled=not args.quiet)
        if bar is not None:
            stack.callback(bar.close)
        try:
            for result in results:
                frame = in_flight.popleft()
                if jsonl is not None:
                    jsonl.write(_json_line(result))
                if overlay is not None:
                    overlay.write(draw_overlay(frame.gray, result, params=params))
                frames += 1
                rain_frames += bool(result.rain)
                if bar is not None:
                    bar.update(1)
                if stop.event.is_set():
                    interrupted = True
                    break
        except KeyboardInterrupt:
            interrupted = True
        finally:
            stop.restore()
            results.close()  # stops the segmentation worker
        elapsed = time.perf_counter() - started
        skipped = video.frames_skipped
    if not args.quiet:
        rate = frames / elapsed if elapsed > 0 else 0.0
        notes = [f"{skipped} corrupt frame(s) skipped"] if skipped else []
        notes += ["interrupted"] if interrupted else []
        print(
            f"weatherd: {args.video}: {frames} frames, {rain_frames} with rain, "
            f"{rate:.1f} frames/s" + "".join(f"; {n}" for n in notes),
            file=sys.stderr,
        )
    return EXIT_INTERRUPTED if interrupted else EXIT_OK


def _json_line(result: FrameResult) -> str:
    return json.dumps(result.to_json(), separators=(",", ":"), allow_nan=False) + "\n"


class _Lines:
    """A text output whose write errors name it: a full disk is ``PATH: no space left on
    device`` (an ``OSError`` with the file name, exit status 74), not an internal error."""

    def __init__(self, stream: TextIO, name: str):
        self._stream, self.name = stream, name

    def write(self, text: str) -> None:
        with _naming(self.name):
            self._stream.write(text)

    def flush(self) -> None:
        with _naming(self.name):
            self._stream.flush()


@contextlib.contextmanager
def _naming(name: str) -> Iterator[None]:
    try:
        yield
    except OSError as exc:
        if exc.filename is not None or exc.errno is None:
            raise
        raise OSError(exc.errno, exc.strerror or os.strerror(exc.errno), name) from None


@contextlib.contextmanager
def _jsonl_output(target: str) -> Iterator[_Lines]:
    """The JSONL stream: ``-`` is stdout, anything else a file (overwritten)."""
    if target == "-":
        lines = _Lines(sys.stdout, "standard output")
        try:
            yield lines
        finally:
            lines.flush()
        return
    try:
        stream = open(target, "w", encoding="utf-8")
    except OSError as exc:
        raise WeatherdError(f"{target}: cannot write ({exc.strerror or exc})") from None
    with _naming(target), stream:
        yield _Lines(stream, target)


def read_roi(path: str | os.PathLike[str], *, width: int, height: int) -> np.ndarray:
    """The region of interest: (height, width) bool, True where analysed.

    ``path`` is an image (nonzero pixels are analysed; resized with nearest neighbour if its
    size differs), or a polygon in JSON, ``[[x, y], ...]`` in pixels of the frames analysed (as
    ``roi`` in the configuration, and as the status page draws it).

    Raises
    ------
    InputError : unreadable image, a mask that selects no pixel, or a bad polygon.
    """
    from daemon.config import check_polygon
    from drivers.video import polygon_mask, read_roi_mask, roi_for_size

    text = str(path).strip()
    if text.startswith("["):
        try:
            polygon = check_polygon(json.loads(text))
        except (ValueError, TypeError) as exc:
            raise InputError(f"--roi: not a polygon [[x, y], ...]: {exc}") from None
        return polygon_mask(polygon, width=width, height=height)
    return roi_for_size(read_roi_mask(path), width=width, height=height)


def _positive(kind: type) -> Callable[[str], float]:
    def parse(text: str) -> float:
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
        if not (math.isfinite(value) and value > 0):
            raise argparse.ArgumentTypeError(f"must be > 0, got {text}")
        return value

    return parse


def _max_pixels(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number of pixels, got {text!r}") from None
    if not MIN_FRAME_PIXELS <= value <= MAX_PIXELS_LIMIT:
        raise argparse.ArgumentTypeError(
            f"must be {MIN_FRAME_PIXELS} to {MAX_PIXELS_LIMIT} pixels, got {value}"
        )
    return value


def register(commands: argparse._SubParsersAction, parents: list[argparse.ArgumentParser]) -> None:
    """Add ``weatherd detect`` to ``commands``."""
    detect = commands.add_parser(
        "detect",
        parents=parents,
        help="offline detection on a video file or image folder",
        description="Run the detector over a video file, a folder of images or the demo street. "
        "Exit 0; 2 with one line for unreadable input; 74 when an output cannot be written "
        "(disk full, I/O error).",
    )
    detect.add_argument(
        "video",
        metavar="VIDEO",
        help="a video file, a folder of images, file:PATH, or demo: (demo:?seed=N&start=S) the "
        "built-in synthetic street, which needs --frames or --seconds",
    )
    detect.add_argument(
        "--jsonl", metavar="PATH", help="write one JSON object per frame ('-' for stdout)"
    )
    detect.add_argument("--overlay", metavar="OUT", help="write the overlay video (.mp4...)")
    detect.add_argument("--config", metavar="PATH", help="TOML file; its [detector] table")
    detect.add_argument(
        "--roi",
        metavar="MASK",
        help="region of interest: a mask image (nonzero = analysed) or a polygon in JSON, "
        "'[[x, y], ...]' in frame pixels",
    )
    detect.add_argument(
        "--max-pixels",
        metavar="N",
        type=_max_pixels,
        default=MAX_FRAME_PIXELS,
        help="frames with more pixels are shrunk by an integer factor before detection "
        f"(default {MAX_FRAME_PIXELS} = 1920x1080; at most {MAX_PIXELS_LIMIT}; "
        f"the detector needs about {DETECTOR_BYTES_PER_PIXEL} bytes a pixel)",
    )
    detect.add_argument("--frames", metavar="N", type=_positive(int), help="stop after N frames")
    detect.add_argument(
        "--seconds", metavar="S", type=_positive(float), help="stop after S seconds of video"
    )
    detect.add_argument("--quiet", action="store_true", help="no summary line on stderr")
    detect.set_defaults(handler=_detect)
