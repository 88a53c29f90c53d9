"""Grey frames from untrusted video files and image folders, decoded ahead in a thread.

Files are decoded with PyAV, never with ``cv2.VideoCapture``: OpenCV 5.0's capture was seen to
abort the whole process (heap corruption) on a malformed but real AVI that PyAV decodes cleanly.
What can go wrong with a file is mapped as follows:

- the file cannot be opened, is not a video, has no video stream, or not one frame decodes:
  :class:`~drivers.errors.InputError`, with a one-line message naming the file. FFmpeg's
  text-mode art decoders (``bintext``, ``ansi``, ``xbin``, ``idf``), which FFmpeg picks by the
  extension alone (``.bin``, ``.nfo``, ``.ans``...) and which turn *any* bytes into a picture of
  text, count as "not a video": random bytes named ``.bin`` are refused, not analysed;
- a corrupt packet or frame in the middle (or a truncated end): skipped, counted in
  :attr:`VideoReader.frames_skipped` and logged once when the reader finishes, never fatal.
  Frames inside a damaged stretch that the demuxer jumps over are not seen, so not counted;
  they show as a gap in the timestamps.

Decoding runs in a background thread that keeps a few frames ready in a bounded queue, so that
it overlaps with processing on a second core. FFmpeg's own decoder threads are left at PyAV's
default (slice threading only): frame threading ("AUTO") was measured no faster, or slower,
once the consumer also needs the CPU (see ``_THREAD_TYPE``).

Frames with more pixels than ``max_pixels`` (1920 x 1080 by default) are shrunk by an integer
factor as they are decoded (:mod:`drivers.frame_size`): the queue, the detector and the
overlay then only ever hold frames of at most that size.

Grey is the luma (Y) plane taken directly from planar YUV frames (no colour conversion; a
limited-range 16-235 luma is stretched to 0-255 by a lookup table, exactly as FFmpeg would);
other pixel formats go through FFmpeg's conversion to ``gray``.

Example
-------
>>> with open_video("clip.avi") as video:               # doctest: +SKIP
...     for frame in video:
...         result = detector.process(frame.gray, frame.t_s)
"""

from __future__ import annotations

import atexit
import heapq
import logging
import math
import queue
import threading
import weakref
from collections import deque
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from fractions import Fraction
from os import PathLike
from pathlib import Path
from typing import Protocol

import av
import cv2
import numpy as np

from .errors import InputError, WeatherdError
from .frame_size import MAX_FRAME_PIXELS, Shrinker, downscale

__all__ = [
    "IMAGE_SUFFIXES",
    "Frame",
    "VideoReader",
    "VideoWriter",
    "open_video",
    "polygon_mask",
    "read_gray_image",
    "read_roi_mask",
    "roi_for_size",
]

log = logging.getLogger(__name__)

#: Extensions of the images an image folder may hold (compared lower-case).
IMAGE_SUFFIXES = frozenset({".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff"})
#: Frame rate of an image folder, or of a video whose container gives none.
DEFAULT_FPS = 25.0
#: Frames decoded ahead of the consumer. Two or three hide the decoder's jitter; more only
#: costs memory (a 1080p grey frame is 2 MB).
_QUEUE_FRAMES = 4
#: FFmpeg decoder threading: PyAV's default, slice threads only. Measured on 2 cores: frame
#: threads ("AUTO") do not help the MS-MPEG-4 fixtures (their decoder has none) and, on a 720p
#: H.264 clip, decode slower than slice threads (1200 vs 1500 frames/s alone, 1.29 vs
#: 1.10 ms of CPU a frame) with the consumer gaining nothing: the CPU the detector needs is
#: better spent there, and the reader thread already overlaps decoding with processing.
_THREAD_TYPE = "SLICE"
#: Frames held back so that their times can be sorted: frames come out of the decoder in display
#: order, but an AVI with packed B-frames (DivX) labels them with decode-order times
#: (1, 4, 6, 5, 7, 9, 8...). The sorted times of a few frames are the display times.
_REORDER_FRAMES = 4
#: Consecutive demuxer errors after which the rest of a file is given up as unreadable.
_MAX_DEMUX_ERRORS = 16
#: FFmpeg's text-mode art decoders: they draw any bytes as text, so they prove nothing.
_TEXT_ART_CODECS = frozenset({"ansi", "bintext", "idf", "xbin"})
#: Pixel formats whose first plane is 8-bit luma, taken as grey without conversion.
_LUMA_FORMATS = frozenset(
    {
        "gray",
        "nv12",
        "nv16",
        "nv21",
        "nv24",
        "nv42",
        "yuv410p",
        "yuv411p",
        "yuv420p",
        "yuv422p",
        "yuv440p",
        "yuv444p",
        "yuva420p",
        "yuva422p",
        "yuva444p",
        "yuvj411p",
        "yuvj420p",
        "yuvj422p",
        "yuvj440p",
        "yuvj444p",
    }
)


#: AVCOL_RANGE_JPEG: the frame's YUV uses the full 0-255 range.
_FULL_RANGE = 2
#: Limited-range luma (16 black, 235 white) to full range, as FFmpeg's swscale rounds it.
_LIMITED_TO_FULL = np.clip(np.round((np.arange(256) - 16) * (255 / 219)), 0, 255).astype(np.uint8)


@dataclass(frozen=True)
class Frame:
    """One decoded frame.

    Attributes
    ----------
    index : int, 0-based position among the frames delivered (skipped frames not counted)
    t_s : float, seconds since the first frame; strictly increasing
    gray : (H, W) uint8, C-contiguous, owned by this frame
    """

    index: int
    t_s: float
    gray: np.ndarray


class _Source(Protocol):
    """What the reader thread pulls frames from; used only by that thread once started."""

    name: str
    fps: float
    skipped: int
    first_error: str
    frame_count: int | None

    def frames(self) -> Iterator[Frame]: ...

    def close(self) -> None: ...


@dataclass(frozen=True)
class _End:
    """Queue item marking the end of the stream; ``error`` if the decoder failed unexpectedly."""

    error: BaseException | None = None


def open_video(
    path: str | PathLike[str],
    *,
    fps: float | None = None,
    max_pixels: int | None = MAX_FRAME_PIXELS,
) -> VideoReader:
    """Open a video file or a folder of images for reading grey frames.

    Parameters
    ----------
    path : a video file (anything FFmpeg demuxes) or a directory of png/jpg/jpeg/bmp/tif/tiff
        images, read in order of file name
    fps : frames per second, optional. For an image folder, the frame rate (default 25); for a
        video, used only when the container gives no frame rate.
    max_pixels : frames with more pixels are shrunk by the smallest integer factor that brings
        them within (:func:`drivers.frame_size.downscale`); None: no limit.

    Returns
    -------
    VideoReader, already decoding its first frames in the background. Close it (or use it as a
    context manager) to stop the decoding thread.

    Raises
    ------
    InputError : the path is missing, unreadable, not a video, has no video stream, holds no
        image, or not a single frame decodes.
    """
    if fps is not None and not (math.isfinite(fps) and fps > 0):
        raise ValueError(f"fps must be > 0, got {fps}")
    path = Path(path)
    if path.is_dir():
        source: _Source = _ImageFolder(path, fps=fps or DEFAULT_FPS, max_pixels=max_pixels)
    elif path.is_file():
        source = _AvFile(path, fps=fps or DEFAULT_FPS, max_pixels=max_pixels)
    elif path.exists():
        raise InputError(f"{path}: not a regular file or directory")
    else:
        raise InputError(f"{path}: no such file or directory")
    return VideoReader(source)


#: Readers whose thread may still run; closed at interpreter exit (see below).
_OPEN_READERS: weakref.WeakSet[VideoReader] = weakref.WeakSet()


@atexit.register
def _close_open_readers() -> None:
    """Stop every decoding thread before the interpreter finalises.

    The threads are daemons, so a reader left open cannot hang the exit; but a daemon thread
    caught inside an OpenCV call (``cv2.LUT``, ``cv2.imdecode``) when finalisation starts is
    unwound through OpenCV's ``catch (...)`` and aborts the process ("FATAL: exception not
    rethrown"). ``atexit`` runs before that point.
    """
    for reader in list(_OPEN_READERS):
        reader.close()


class VideoReader:
    """Iterator of :class:`Frame` over one file or folder, decoded ahead in a thread.

    Use :func:`open_video` to make one. It is a single pass: iterating again continues where
    the last iteration stopped. The decoding thread stops when the frames run out, when
    :meth:`close` is called, or when a ``with`` block exits (also on an exception).

    Attributes
    ----------
    width, height : int, size of the first frame in pixels (after any downscale)
    fps : float, the container's frame rate (or the one given / the default)
    frames_skipped : int, corrupt packets, frames or images skipped so far
    frame_count : int or None, how many frames the file holds, from its container (the
        stream's frame count, else its duration times ``fps``) or the folder's images; None
        when unknown. An estimate, for progress bars: corrupt frames make fewer.
    """

    def __init__(self, source: _Source, *, queue_frames: int = _QUEUE_FRAMES):
        self._source = source
        self.name = source.name
        self.fps = float(source.fps)
        self.frame_count = source.frame_count
        self._queue: queue.Queue[Frame | _End] = queue.Queue(maxsize=queue_frames)
        self._stop = threading.Event()
        self._ended = False
        self._thread = threading.Thread(
            target=self._decode, name=f"decode {source.name}", daemon=True
        )
        self._thread.start()
        _OPEN_READERS.add(self)
        try:
            first = self._take()
        except BaseException:  # Ctrl-C while waiting for the first frame
            self.close()
            raise
        if isinstance(first, _End):
            self.close()
            if first.error is not None:
                raise first.error
            detail = f" ({source.first_error})" if source.first_error else ""
            raise InputError(f"{source.name}: no frame could be decoded{detail}")
        self._pending: Frame | _End | None = first
        self.height, self.width = first.gray.shape

    @property
    def frames_skipped(self) -> int:
        return self._source.skipped

    # -- consumer side -------------------------------------------------------------------
    def __iter__(self) -> Iterator[Frame]:
        while not self._ended:
            item = self._pending if self._pending is not None else self._take()
            self._pending = None
            if isinstance(item, _End):
                self._ended = True
                self._thread.join()
                if item.error is not None:
                    raise item.error
                return
            yield item

    def _take(self) -> Frame | _End:
        """Next item from the decoder; an end marker if the thread is gone."""
        while True:
            try:
                return self._queue.get(timeout=0.5)
            except queue.Empty:
                if not self._thread.is_alive() and self._queue.empty():
                    return _End()

    def close(self) -> None:
        """Stop the decoding thread and wait for it; idempotent."""
        self._ended = True
        self._pending = None
        self._stop.set()
        while self._thread.is_alive():
            try:  # unblock a producer waiting for room
                while True:
                    self._queue.get_nowait()
            except queue.Empty:
                pass
            self._thread.join(timeout=0.05)
        _OPEN_READERS.discard(self)

    def __enter__(self) -> VideoReader:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    # -- decoding thread -----------------------------------------------------------------
    def _decode(self) -> None:
        error: BaseException | None = None
        source = self._source
        frames = source.frames()
        try:
            for frame in frames:
                if not self._put(frame):
                    break
        except BaseException as exc:  # handed to the consumer, re-raised there
            error = exc
        finally:
            try:
                frames.close()
                source.close()
            finally:
                if source.skipped:
                    log.warning(
                        "%s: skipped %d corrupt or unreadable frame(s) (first: %s)",
                        source.name,
                        source.skipped,
                        source.first_error,
                    )
                self._put(_End(error))

    def _put(self, item: Frame | _End) -> bool:
        """Queue ``item``, waiting for room; False if the reader was closed meanwhile."""
        while not self._stop.is_set():
            try:
                self._queue.put(item, timeout=0.1)
                return True
            except queue.Full:
                continue
        return False


class _Timeline:
    """Strictly increasing seconds since the first frame, from optional container times.

    A frame without a time, or whose time does not advance (a broken or duplicated timestamp),
    is placed one frame period after the previous one.
    """

    def __init__(self, fps: float):
        self._period = 1.0 / fps
        self._origin: float | None = None
        self._last: float | None = None

    def __call__(self, time: float | None) -> float:
        last = self._last
        if time is not None and math.isfinite(time):
            if self._origin is None:
                self._origin = time - (0.0 if last is None else last + self._period)
            t = time - self._origin
        else:
            t = None
        if t is None or (last is not None and t <= last):
            t = 0.0 if last is None else last + self._period
        self._last = t
        return t


class _AvFile:
    """A video file demuxed and decoded by PyAV (FFmpeg)."""

    def __init__(self, path: Path, *, fps: float, max_pixels: int | None):
        self.name = str(path)
        self.skipped = 0
        self.first_error = ""
        self._shrink = Shrinker(self.name, max_pixels)
        try:
            self._container = av.open(str(path), mode="r", metadata_errors="ignore")
        except (av.FFmpegError, OSError, ValueError, UnicodeError) as exc:
            raise InputError(f"{path}: cannot be read as a video ({_reason(exc)})") from None
        try:
            streams = self._container.streams.video
            if not streams:
                raise InputError(f"{path}: has no video stream")
            self._stream = streams[0]
            if self._stream.codec_context is None:  # a codec this FFmpeg does not know
                raise InputError(f"{path}: no decoder for its video stream")
            codec = self._stream.codec_context.name
            if codec in _TEXT_ART_CODECS:
                raise InputError(
                    f"{path}: not a video (FFmpeg would draw its bytes as text-mode art, "
                    f"decoder {codec!r}, going by the file name alone)"
                )
            self._stream.thread_type = _THREAD_TYPE
            rate = self._stream.average_rate or self._stream.guessed_rate
            self.fps = _valid_rate(rate) or fps
            self.frame_count = _frame_count(self._stream, self._container, self.fps)
        except BaseException:
            self._container.close()
            raise

    def frames(self) -> Iterator[Frame]:
        timeline = _Timeline(self.fps)
        held: deque[np.ndarray] = deque()  # frames waiting for their time
        times: list[float] = []  # heap of the container times of the held frames
        index = 0
        for packet in self._packets():
            try:
                decoded = self._stream.decode(packet)  # None flushes the decoder
            except av.FFmpegError as exc:
                self._skip(exc)
                continue
            for frame in decoded:
                if frame.is_corrupt:
                    self._skip("frame decoded with errors")
                    continue
                try:
                    held.append(_luma(frame, self._shrink.factor(frame.width, frame.height)))
                except (av.FFmpegError, ValueError) as exc:
                    self._skip(exc)
                    continue
                t = _seconds(frame.pts, self._stream.time_base)
                if t is not None:
                    heapq.heappush(times, t)
            while len(held) > (_REORDER_FRAMES if packet is not None else 0):
                t = heapq.heappop(times) if times else None
                yield Frame(index, timeline(t), held.popleft())
                index += 1

    def _packets(self) -> Iterator[av.Packet | None]:
        """Packets of the video stream, then ``None`` to flush the decoder.

        A demuxer error (a damaged index or chunk header) is counted and demuxing resumes from
        where FFmpeg stands; after ``_MAX_DEMUX_ERRORS`` in a row the rest is given up.
        """
        errors = 0
        while errors < _MAX_DEMUX_ERRORS:
            try:
                for packet in self._container.demux(self._stream):
                    errors = 0
                    if packet.size:  # PyAV ends with an empty packet: we flush ourselves
                        yield packet
                break
            except (av.EOFError, EOFError):
                break
            except av.FFmpegError as exc:
                self._skip(exc)
                errors += 1
        yield None

    def _skip(self, why: object) -> None:
        self.skipped += 1
        if not self.first_error:
            self.first_error = _reason(why)

    def close(self) -> None:
        self._container.close()


class _ImageFolder:
    """A directory of images, one frame each, in order of file name."""

    def __init__(self, directory: Path, *, fps: float, max_pixels: int | None):
        self.name = str(directory)
        self.fps = fps
        self.skipped = 0
        self.first_error = ""
        self._shrink = Shrinker(self.name, max_pixels)
        try:
            entries = list(directory.iterdir())
        except OSError as exc:
            raise InputError(f"{directory}: cannot list the folder ({_reason(exc)})") from None
        self._files = sorted(p for p in entries if p.suffix.lower() in IMAGE_SUFFIXES)
        if not self._files:
            kinds = ", ".join(sorted(s[1:] for s in IMAGE_SUFFIXES))
            raise InputError(f"{directory}: the folder holds no image ({kinds})")
        self.frame_count: int | None = len(self._files)

    def frames(self) -> Iterator[Frame]:
        index = 0
        shape: tuple[int, int] | None = None
        for position, path in enumerate(self._files):
            gray = read_gray_image(path)
            if gray is None:
                self._skip(f"{path.name}: unreadable image")
                continue
            gray = self._shrink(gray)
            if shape is not None and gray.shape != shape:
                self._skip(f"{path.name}: size {gray.shape[::-1]} differs from {shape[::-1]}")
                continue
            shape = gray.shape
            yield Frame(index, position / self.fps, gray)  # a skipped image leaves a time gap
            index += 1

    def _skip(self, why: str) -> None:
        self.skipped += 1
        if not self.first_error:
            self.first_error = why

    def close(self) -> None:
        pass


def _luma(frame: av.VideoFrame, factor: int = 1) -> np.ndarray:
    """(H, W) uint8 full-range grey copy of a decoded frame, respecting the line stride, its
    ``factor x factor`` blocks averaged (:func:`~drivers.frame_size.downscale`) when > 1.

    Planar YUV: the Y plane itself, limited range (16-235) stretched to 0-255 by a lookup table
    exactly as FFmpeg's own conversion to ``gray`` does, so that a file, an image folder and a
    camera give the same grey levels. Anything else: FFmpeg's conversion. A frame to shrink is
    shrunk straight from the decoder's plane: no full-size copy is made.
    """
    height, width = frame.height, frame.width
    name = frame.format.name
    if name in _LUMA_FORMATS:
        plane = frame.planes[0]
        stride = plane.line_size
        data = np.frombuffer(plane, dtype=np.uint8)
        if stride >= width and data.size >= stride * height:
            y = data[: stride * height].reshape(height, stride)[:, :width]
            y = downscale(y, factor) if factor > 1 else y  # a new array when shrunk
            if name == "gray" or name.startswith("yuvj") or frame.color_range == _FULL_RANGE:
                return y if factor > 1 else y.copy()
            return cv2.LUT(y, _LIMITED_TO_FULL)  # a new, contiguous array
    gray = frame.to_ndarray(format="gray")
    return downscale(np.ascontiguousarray(gray[:height, :width]), factor)


def read_gray_image(path: str | PathLike[str]) -> np.ndarray | None:
    """(H, W) uint8 grey image from a file, or None if it cannot be read; never raises for a
    bad or missing file."""
    try:
        data = np.fromfile(path, dtype=np.uint8)
    except OSError:
        return None
    if data.size == 0:
        return None
    try:
        gray = cv2.imdecode(data, cv2.IMREAD_GRAYSCALE)
    except cv2.error:
        return None
    if gray is None or gray.ndim != 2 or gray.size == 0:
        return None
    return np.ascontiguousarray(gray, dtype=np.uint8)


def read_roi_mask(path: str | PathLike[str]) -> np.ndarray:
    """A region-of-interest mask image: (H, W) uint8, nonzero where analysed.

    Raises
    ------
    InputError : unreadable image, or a mask that selects no pixel.
    """
    mask = read_gray_image(path)
    if mask is None:
        raise InputError(f"{path}: cannot read the ROI mask (an image; nonzero = analysed)")
    if not mask.any():
        raise InputError(f"{path}: the ROI mask selects no pixel (nonzero = analysed)")
    return mask


def roi_for_size(mask: np.ndarray, *, width: int, height: int) -> np.ndarray:
    """(height, width) bool from a mask of any size (nearest-neighbour resize)."""
    if mask.shape != (height, width):
        mask = cv2.resize(mask, (width, height), interpolation=cv2.INTER_NEAREST)
    return mask != 0


def polygon_mask(points: Sequence[Sequence[float]], *, width: int, height: int) -> np.ndarray:
    """(height, width) bool, True on and inside the polygon ``[[x, y], ...]`` (image pixels,
    pixel (x, y) at the point (x, y); vertices to 1/16 px, as OpenCV's ``fillPoly`` draws).

    Raises
    ------
    InputError : the polygon covers no pixel of a width x height frame.
    """
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    shift = 4  # cv2.fillPoly's fixed-point bits: sub-pixel vertices
    fixed = np.round(pts * (1 << shift)).astype(np.int32)
    mask = np.zeros((height, width), np.uint8)
    cv2.fillPoly(mask, [fixed], 255, lineType=cv2.LINE_8, shift=shift)
    if not mask.any():
        raise InputError(f"the ROI polygon covers no pixel of a {width}x{height} frame")
    return mask != 0


def _seconds(pts: int | None, time_base: Fraction | None) -> float | None:
    """Time of a timestamp, None if unknown. (PyAV leaves ``frame.time`` NaN on the frames a
    decoder flush returns, so the stream's time base is used.)"""
    if pts is None or not time_base:
        return None
    t = float(pts * time_base)
    return t if math.isfinite(t) else None


def _frame_count(stream: av.video.stream.VideoStream, container: object, fps: float) -> int | None:
    """Frames in the stream as the container says (its count, else duration x rate), or None."""
    if stream.frames and stream.frames > 0:
        return int(stream.frames)
    duration_s = None
    if stream.duration and stream.time_base:
        duration_s = float(stream.duration * stream.time_base)
    elif getattr(container, "duration", None):
        duration_s = container.duration / av.time_base
    if duration_s is None or not (math.isfinite(duration_s) and duration_s > 0):
        return None
    return max(1, round(duration_s * fps))


def _valid_rate(rate: Fraction | None) -> float | None:
    if rate is None or rate.denominator == 0:
        return None
    fps = float(rate)
    return fps if 0.0 < fps <= 1000.0 else None


def _reason(why: object) -> str:
    """One line saying why, without FFmpeg's repetition of the file name."""
    if isinstance(why, av.FFmpegError) and why.strerror:
        return str(why.strerror)
    if isinstance(why, OSError) and why.strerror:
        return str(why.strerror)
    return " ".join(str(why).split()) or type(why).__name__


class VideoWriter:
    """Encode BGR (or grey) frames to a video file with PyAV, one frame per call.

    H.264 (libx264, ``yuv420p``) when FFmpeg has it, else MPEG-4 part 2. Frames are padded to
    an even size (the chroma planes of ``yuv420p`` need one); a frame of another size than the
    first is resized to it. The container is chosen by the file's extension (.mp4, .mkv, .avi).

    Parameters
    ----------
    path : output file, overwritten
    width, height : int, size of the frames that will be written
    fps : float, frame rate; frame ``i`` is stamped ``i / fps``

    Raises
    ------
    WeatherdError : the file cannot be created (missing folder, unknown extension...).
    """

    def __init__(self, path: str | PathLike[str], *, width: int, height: int, fps: float):
        self.path = Path(path)
        self.width, self.height = int(width), int(height)
        self._size = (self.width + self.width % 2, self.height + self.height % 2)
        self.frames_written = 0
        codec = _encoder()
        created = not self.path.exists()
        try:
            self.path.open("wb").close()  # FFmpeg would only fail at the first frame
        except OSError as exc:
            raise WeatherdError(f"{self.path}: cannot write a video ({_reason(exc)})") from None
        try:
            self._container = av.open(str(self.path), mode="w")
        except (av.FFmpegError, OSError, ValueError) as exc:
            if created and self.path.is_file():  # never a device or a file that was there
                self.path.unlink(missing_ok=True)
            raise WeatherdError(f"{self.path}: cannot write a video ({_reason(exc)})") from None
        try:
            rate = Fraction(fps).limit_denominator(1001)
            options = {"preset": "veryfast", "crf": "20"} if codec == "libx264" else {}
            self._stream = self._container.add_stream(codec, rate=rate, options=options)
            self._stream.width, self._stream.height = self._size
            self._stream.pix_fmt = "yuv420p"
            if codec != "libx264":
                self._stream.bit_rate = int(0.3 * self._size[0] * self._size[1] * float(rate))
        except BaseException:
            self._container.close()
            raise

    def write(self, image: np.ndarray) -> None:
        """Append one (H, W, 3) uint8 BGR or (H, W) grey frame."""
        image = np.asarray(image, dtype=np.uint8)
        if image.ndim == 2:
            image = cv2.cvtColor(image, cv2.COLOR_GRAY2BGR)
        if image.shape[:2] != (self.height, self.width):
            image = cv2.resize(image, (self.width, self.height), interpolation=cv2.INTER_AREA)
        pad_x, pad_y = self._size[0] - self.width, self._size[1] - self.height
        if pad_x or pad_y:
            image = cv2.copyMakeBorder(image, 0, pad_y, 0, pad_x, cv2.BORDER_REPLICATE)
        frame = av.VideoFrame.from_ndarray(np.ascontiguousarray(image), format="bgr24")
        frame.pts = self.frames_written
        self._container.mux(self._stream.encode(frame))
        self.frames_written += 1

    def close(self) -> None:
        """Flush the encoder and finish the file; idempotent."""
        if self._container is None:
            return
        container, self._container = self._container, None
        try:
            container.mux(self._stream.encode(None))
        finally:
            container.close()

    def __enter__(self) -> VideoWriter:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()


def _encoder() -> str:
    """libx264 when this FFmpeg build can encode with it, else mpeg4 (always built in)."""
    try:
        av.codec.Codec("libx264", "w")
    except (av.FFmpegError, ValueError):
        return "mpeg4"
    return "libx264"
