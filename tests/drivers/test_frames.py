"""drivers.frames and its sources: specs, the demo, files (loop, pacing), HTTP streams, V4L2."""

from __future__ import annotations

import http.server
import socket
import threading
import time
from collections.abc import Iterator
from fractions import Fraction
from pathlib import Path

import av
import cv2
import numpy as np
import pytest

from drivers.demo import DemoSource
from drivers.errors import ConfigError, InputError, SourceError
from drivers.file_source import FileSource
from drivers.frames import LiveFrame, MemorySource, mask_credentials
from drivers.sources import open_source
from drivers.stream import StreamSource
from drivers.v4l2 import V4L2Source

REPO = Path(__file__).resolve().parents[2]
FIXTURE_VIDEO = REPO.parent / "shared" / "fixtures" / "video"


# -- helpers ---------------------------------------------------------------------------------
def write_ramp(path: Path, n: int, *, fps: int = 25, width: int = 64, height: int = 48) -> None:
    """A clip whose frame i is flat at grey 20 + 8 i (order readable back), MJPEG in AVI."""
    with av.open(str(path), mode="w") as container:
        stream = container.add_stream("mjpeg", rate=Fraction(fps))
        stream.width, stream.height, stream.pix_fmt = width, height, "yuvj420p"
        for i in range(n):
            frame = av.VideoFrame.from_ndarray(
                np.full((height, width), 20 + 8 * i, np.uint8), format="gray"
            ).reformat(format="yuvj420p")
            frame.pts = i
            container.mux(stream.encode(frame))
        container.mux(stream.encode(None))


def level(frame: LiveFrame) -> int:
    """Which ramp frame this is."""
    return round((float(frame.gray.mean()) - 20) / 8)


def read_all(source, limit: int = 1000) -> list[LiveFrame]:
    frames = []
    while len(frames) < limit:
        frame = source.read()
        if frame is None:
            break
        frames.append(frame)
    return frames


class MjpegServer:
    """An MJPEG-over-HTTP camera on 127.0.0.1: ``multipart/x-mixed-replace`` JPEG parts.

    ``stall=True`` sends the headers and then nothing; ``stall_after`` stops sending after that
    many frames, keeping the connection open; ``frames`` ends each response after that many.
    :meth:`stop` drops every connection; :meth:`start` can serve again on the same port.
    """

    def __init__(
        self,
        *,
        fps: float = 25.0,
        stall: bool = False,
        stall_after: int | None = None,
        frames: int | None = None,
    ):
        self.fps, self.frames = fps, frames
        self.stall_after = 0 if stall else stall_after
        self.port = 0
        self._server: http.server.ThreadingHTTPServer | None = None
        self._halt = threading.Event()

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.port}/cam.mjpg"

    def start(self) -> MjpegServer:
        outer = self
        self._halt = halt = threading.Event()

        class Handler(http.server.BaseHTTPRequestHandler):
            def do_GET(self) -> None:
                if self.path != "/cam.mjpg":
                    self.send_error(404)
                    return
                self.send_response(200)
                self.send_header("Content-Type", "multipart/x-mixed-replace; boundary=frame")
                self.end_headers()
                self.wfile.flush()
                i = 0
                try:
                    while not halt.is_set() and (outer.frames is None or i < outer.frames):
                        if outer.stall_after is not None and i >= outer.stall_after:
                            halt.wait(0.05)
                            continue
                        img = np.full((48, 64), (20 + 8 * i) % 256, np.uint8)
                        data = cv2.imencode(".jpg", img)[1].tobytes()
                        head = b"--frame\r\nContent-Type: image/jpeg\r\nContent-Length: %d\r\n\r\n"
                        self.wfile.write(head % len(data) + data + b"\r\n")
                        i += 1
                        halt.wait(1.0 / outer.fps)
                except OSError:  # the client went away
                    pass

            def log_message(self, *args: object) -> None:
                pass

        server = http.server.ThreadingHTTPServer(("127.0.0.1", self.port), Handler)
        server.daemon_threads = True
        self.port = server.server_address[1]
        self._server = server
        threading.Thread(target=server.serve_forever, daemon=True).start()
        return self

    def stop(self) -> None:
        self._halt.set()
        if self._server is not None:
            self._server.shutdown()
            self._server.server_close()
            self._server = None


@pytest.fixture
def mjpeg() -> Iterator[MjpegServer]:
    server = MjpegServer().start()
    try:
        yield server
    finally:
        server.stop()


# -- specs -------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("spec", "kind"),
    [
        ("demo:", DemoSource),
        ("demo:?seed=3", DemoSource),
        ("file:/tmp/clip.mp4", FileSource),
        ("file:///tmp/clip.mp4", FileSource),
        ("v4l2:/dev/video0", V4L2Source),
        ("rtsp://cam.local:554/stream1", StreamSource),
        ("rtsps://cam.local/stream1", StreamSource),
        ("http://cam.local/video.mjpg", StreamSource),
        ("https://cdn.example/live/index.m3u8", StreamSource),
        ("RTSP://cam.local/x", StreamSource),
    ],
)
def test_open_source_picks_the_source_of_each_scheme(spec: str, kind: type) -> None:
    source = open_source(spec)
    assert isinstance(source, kind)
    source.close()


def test_file_spec_keeps_the_path() -> None:
    assert open_source("file:///tmp/a b.mp4").path == Path("/tmp/a b.mp4")
    assert open_source("file:clips/x.avi").path == Path("clips/x.avi")


@pytest.mark.parametrize(
    "spec",
    ["", "video0", "/dev/video0", "ftp://host/x", "usb:0", "rtmp://u:secret@host/live"],
)
def test_unknown_scheme_is_a_config_error_naming_the_spec(spec: str) -> None:
    with pytest.raises(ConfigError, match="unknown frame source") as info:
        open_source(spec)
    assert mask_credentials(spec) in str(info.value)
    assert "secret" not in str(info.value)


@pytest.mark.parametrize(
    ("spec", "kwargs", "match"),
    [
        ("file:", {}, "no file"),
        ("v4l2:", {}, "no device"),
        ("demo:?speed=2", {}, "unknown demo option"),
        ("demo:?seed=x", {}, "seed must be an integer"),
        ("demo:?start=-1", {}, "start must be a number of seconds >= 0"),
        ("demo:?start=soon", {}, "start must be a number of seconds >= 0"),
        ("demo:?start=nan", {}, "start must be a number of seconds >= 0"),
        ("demo:", {"width": 320}, "both width and height"),
        ("demo:", {"fps": 0}, "fps must be > 0"),
        ("http:///x", {}, "no host"),
    ],
)
def test_malformed_specs_are_config_errors(spec: str, kwargs: dict, match: str) -> None:
    with pytest.raises(ConfigError, match=match):
        open_source(spec, **kwargs)


@pytest.mark.parametrize(
    ("spec", "masked"),
    [
        ("rtsp://admin:hunter2@10.0.0.5:554/s1", "rtsp://***@10.0.0.5:554/s1"),
        ("http://user@cam/x.mjpg", "http://***@cam/x.mjpg"),
        ("https://cam/x.m3u8?token=abc&ch=1", "https://cam/x.m3u8?token=***&ch=1"),
        ("http://cam/x?user=a&password=p@ss", "http://cam/x?user=a&password=***"),
        ("rtsp://cam.local/stream1", "rtsp://cam.local/stream1"),
        ("file:/data/a@b.mp4", "file:/data/a@b.mp4"),
        ("demo:", "demo:"),
    ],
)
def test_names_never_show_credentials(spec: str, masked: str) -> None:
    assert mask_credentials(spec) == masked
    if spec.startswith(("rtsp", "http")):
        assert open_source(spec).name == masked


# -- demo --------------------------------------------------------------------------------
def test_demo_source_renders_the_requested_size_with_increasing_times() -> None:
    source = open_source("demo:?seed=2", width=160, height=96, fps=10, realtime=False)
    source.open()
    try:
        frames = [source.read() for _ in range(5)]
    finally:
        source.close()
    assert [f.index for f in frames] == [0, 1, 2, 3, 4]
    assert [f.t_s for f in frames] == pytest.approx([0.0, 0.1, 0.2, 0.3, 0.4])
    assert all(f.gray.shape == (96, 160) and f.gray.dtype == np.uint8 for f in frames)
    assert frames[1].t_ns - frames[0].t_ns == 100_000_000
    with pytest.raises(SourceError):
        source.read()


def test_demo_start_begins_later_in_the_same_weather() -> None:
    """``demo:?start=21``: the street's frame 21 s into its cycle comes first (in its rain,
    which begins at 20 s), at time 0; the same street and weather as ``demo:`` there."""

    def first(spec: str, skip: int = 0):
        source = open_source(spec, width=64, height=48, fps=10, realtime=False)
        source.open()
        try:
            for _ in range(skip):
                source.read()
            return source, source.read()
        finally:
            source.close()

    late, frame = first("demo:?start=21")
    assert late.name == "demo:?start=21" and frame.index == 0 and frame.t_s == 0.0
    assert late.truth.rain_intensity > 0
    plain, same = first("demo:", skip=210)
    assert np.array_equal(frame.gray, same.gray) and plain.truth.rain_intensity > 0
    assert first("demo:")[0].truth.rain_intensity == 0
    assert open_source("demo:?seed=3&start=2.5").name == "demo:?seed=3&start=2.5"
    assert open_source("demo:?seed=123456789").name == "demo:?seed=123456789"


def test_demo_seed_changes_the_street() -> None:
    grays = []
    for spec in ("demo:", "demo:?seed=0", "demo:?seed=5"):
        source = open_source(spec, width=64, height=48, realtime=False)
        source.open()
        grays.append(source.read().gray)
        source.close()
    assert np.array_equal(grays[0], grays[1])
    assert not np.array_equal(grays[0], grays[2])


def test_demo_realtime_paces_frames() -> None:
    source = open_source("demo:", width=64, height=48, fps=50)
    source.open()
    start = time.monotonic()
    for _ in range(11):  # frames 0..10: 10 periods of 20 ms
        source.read()
    elapsed = time.monotonic() - start
    source.close()
    assert elapsed >= 0.18


# -- files -------------------------------------------------------------------------------
def test_file_without_loop_ends_cleanly(tmp_path: Path) -> None:
    path = tmp_path / "ramp.avi"
    write_ramp(path, 6)
    source = open_source(f"file:{path}", realtime=False)
    source.open()
    before_ns = time.time_ns()
    frames = read_all(source)
    source.close()
    assert [level(f) for f in frames] == list(range(6))
    assert [f.t_s for f in frames] == pytest.approx([i / 25 for i in range(6)])
    # not paced: times are still the open time plus the file's clock
    assert frames[5].t_ns - frames[0].t_ns == pytest.approx(0.2e9, abs=1e3)
    assert abs(frames[0].t_ns - before_ns) < 5e9


def test_file_loop_wraps_around_with_time_going_on(tmp_path: Path) -> None:
    path = tmp_path / "ramp.avi"
    write_ramp(path, 5)
    source = open_source(f"file:{path}", loop=True, realtime=False)
    source.open()
    frames = [source.read() for _ in range(13)]
    source.close()
    assert [level(f) for f in frames] == [i % 5 for i in range(13)]
    assert [f.index for f in frames] == list(range(13))
    assert np.diff([f.t_s for f in frames]) == pytest.approx(np.full(12, 1 / 25))


def test_file_realtime_paces_at_the_file_rate(tmp_path: Path) -> None:
    path = tmp_path / "ramp.avi"
    write_ramp(path, 8, fps=20)
    source = open_source(f"file:{path}", loop=True)
    source.open()
    start = time.monotonic()
    frames = [source.read() for _ in range(12)]  # 11 periods of 50 ms, across the wrap
    elapsed = time.monotonic() - start
    source.close()
    assert elapsed >= 0.45
    assert frames[-1].t_s == pytest.approx(11 / 20)


def test_file_frames_are_resized_to_the_requested_size(tmp_path: Path) -> None:
    path = tmp_path / "ramp.avi"
    write_ramp(path, 2)
    source = open_source(f"file:{path}", width=32, height=20, realtime=False)
    source.open()
    frame = source.read()
    source.close()
    assert frame.gray.shape == (20, 32)
    assert level(frame) == 0


def test_missing_file_is_an_input_error(tmp_path: Path) -> None:
    source = open_source(f"file:{tmp_path / 'gone.mp4'}")
    with pytest.raises(InputError, match="no such file"):
        source.open()
    source.close()


def test_file_loop_raises_source_error_when_the_file_has_gone(tmp_path: Path) -> None:
    path = tmp_path / "ramp.avi"
    write_ramp(path, 3)
    source = open_source(f"file:{path}", loop=True, realtime=False)
    source.open()
    path.unlink()
    with pytest.raises(SourceError, match="restart the loop"):
        read_all(source, limit=10)
    source.close()


def test_close_ends_a_paced_wait_at_once(tmp_path: Path) -> None:
    path = tmp_path / "slow.avi"
    write_ramp(path, 3, fps=1)  # one frame a second
    source = open_source(f"file:{path}")
    source.open()
    source.read()
    threading.Timer(0.1, source.close).start()
    start = time.monotonic()
    with pytest.raises(SourceError, match="closed"):
        source.read()
    assert time.monotonic() - start < 0.9


def test_real_fixture_clip_as_a_looping_source() -> None:
    path = FIXTURE_VIDEO / "motorway_clear_320x240.avi"
    if not path.is_file():
        pytest.skip(f"{path} is not beside this checkout")
    source = open_source(f"file:{path}", loop=True, realtime=False)
    source.open()
    frames = [source.read() for _ in range(20)]
    source.close()
    assert all(f.gray.shape == (240, 320) for f in frames)
    assert np.all(np.diff([f.t_s for f in frames]) > 0)


# -- memory double -------------------------------------------------------------------------
def test_memory_source_plays_its_script() -> None:
    gray = np.zeros((4, 4), np.uint8)
    source = MemorySource([gray, SourceError("glitch"), gray, None], fps=10)
    source.open()
    assert source.read().index == 0
    with pytest.raises(SourceError, match="glitch"):
        source.read()
    assert source.read().t_s == pytest.approx(0.1)
    assert source.read() is None


# -- network streams ---------------------------------------------------------------------
def test_http_mjpeg_stream_gives_frames_with_wall_clock_times(mjpeg: MjpegServer) -> None:
    source = open_source(mjpeg.url, timeout_s=3)
    source.open()
    try:
        frames = [source.read() for _ in range(6)]
    finally:
        source.close()
    assert all(f.gray.shape == (48, 64) for f in frames)
    assert [f.index for f in frames] == list(range(6))
    assert np.all(np.diff([f.t_s for f in frames]) > 0)
    now = time.time_ns()
    assert all(abs(now - f.t_ns) < 10e9 for f in frames)  # receipt times: no clock in MJPEG
    levels = [level(f) for f in frames]
    assert levels == sorted(levels)  # in order, none repeated
    assert len(set(levels)) == 6


def test_http_stream_resized_to_the_requested_size(mjpeg: MjpegServer) -> None:
    source = open_source(mjpeg.url, width=32, height=24, timeout_s=3)
    source.open()
    frame = source.read()
    source.close()
    assert frame.gray.shape == (24, 32)


def test_http_server_gone_then_back(mjpeg: MjpegServer) -> None:
    source = open_source(mjpeg.url, timeout_s=2)
    source.open()
    source.read()
    mjpeg.stop()
    with pytest.raises(SourceError):
        read_all(source, limit=500)
    source.close()
    again = open_source(mjpeg.url, timeout_s=2)
    with pytest.raises(SourceError, match="cannot open"):
        again.open()
    again.close()
    mjpeg.start()  # same port
    source = open_source(mjpeg.url, timeout_s=2)
    source.open()
    assert source.read().gray.shape == (48, 64)
    source.close()


def test_finite_http_stream_ending_is_a_source_error() -> None:
    server = MjpegServer(frames=60, fps=100).start()
    try:
        source = open_source(server.url, timeout_s=2)
        source.open()
        with pytest.raises(SourceError):  # "the stream ended" or FFmpeg's I/O error
            read_all(source)
        source.close()
    finally:
        server.stop()


def test_stalled_http_stream_times_out() -> None:
    server = MjpegServer(stall=True).start()
    try:
        source = open_source(server.url, timeout_s=1)
        start = time.monotonic()
        with pytest.raises(SourceError):
            source.open()
            source.read()
        assert time.monotonic() - start < 10  # seconds, not forever
        source.close()
    finally:
        server.stop()


def test_stream_stalling_after_frames_times_out() -> None:
    server = MjpegServer(stall_after=30, fps=100).start()
    try:
        source = open_source(server.url, timeout_s=1)
        source.open()
        start = time.monotonic()
        with pytest.raises(SourceError, match=r"timed out|no frame"):
            read_all(source)
        assert time.monotonic() - start < 10  # seconds, not forever
        source.close()
    finally:
        server.stop()


def test_silent_rtsp_server_times_out() -> None:
    with socket.create_server(("127.0.0.1", 0)) as listener:  # accepts, never answers
        port = listener.getsockname()[1]
        source = open_source(f"rtsp://user:pw@127.0.0.1:{port}/stream1", timeout_s=1)
        start = time.monotonic()
        with pytest.raises(SourceError, match=r"rtsp://\*\*\*@127.0.0.1") as info:
            source.open()
        assert time.monotonic() - start < 10  # seconds, not forever
        assert "pw" not in str(info.value)
        source.close()


def test_http_not_found_is_a_source_error(mjpeg: MjpegServer) -> None:
    source = open_source(mjpeg.url.replace("cam.mjpg", "nothing"), timeout_s=2)
    with pytest.raises(SourceError, match="cannot open"):
        source.open()
    source.close()


def test_close_from_another_thread_ends_a_blocked_stream_read() -> None:
    server = MjpegServer(stall_after=30, fps=100).start()
    try:
        source = open_source(server.url, timeout_s=8)
        source.open()
        start = time.monotonic()
        threading.Timer(1.0, source.close).start()  # by then the 30 frames are read
        with pytest.raises(SourceError, match="closed"):
            read_all(source)  # blocks after the 30 frames, 8 s before it would time out
        assert time.monotonic() - start < 4
    finally:
        server.stop()


def test_refused_connection_is_a_source_error() -> None:
    server = MjpegServer().start()
    url = server.url
    server.stop()  # nothing listens on that port now
    source = open_source(url, timeout_s=2)
    with pytest.raises(SourceError, match="cannot open"):
        source.open()


# -- V4L2 --------------------------------------------------------------------------------
def test_v4l2_spec_asks_the_device_for_size_rate_and_options() -> None:
    source = open_source("v4l2:/dev/video7?input_format=mjpeg", width=1280, height=720, fps=15)
    assert isinstance(source, V4L2Source)
    assert source.device == "/dev/video7"
    assert source.name == "v4l2:/dev/video7"
    assert source._options == {
        "video_size": "1280x720",
        "framerate": "15",
        "input_format": "mjpeg",
    }


def test_missing_v4l2_device_is_a_clear_source_error() -> None:
    source = open_source("v4l2:/dev/video-none-here")
    with pytest.raises(SourceError, match=r"v4l2:/dev/video-none-here: no such device"):
        source.open()
    source.close()


def test_v4l2_on_something_not_a_camera_is_a_source_error(tmp_path: Path) -> None:
    fake = tmp_path / "video9"
    fake.write_bytes(b"\0" * 64)
    source = open_source(f"v4l2:{fake}", timeout_s=2)
    with pytest.raises(SourceError, match="cannot open"):
        source.open()
    source.close()
