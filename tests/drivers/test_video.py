"""drivers.video: real clips, image folders, hostile files, and the decoding thread's lifetime."""

from __future__ import annotations

import logging
import os
import subprocess
import sys
import threading
from fractions import Fraction
from pathlib import Path

import av
import cv2
import numpy as np
import pytest

from drivers.errors import InputError
from drivers.video import VideoReader, VideoWriter, open_video

REPO = Path(__file__).resolve().parents[2]
FIXTURE_VIDEO = REPO.parent / "shared" / "fixtures" / "video"
CLIPS = {  # name: (frames, width, height)
    "motorway_clear_320x240.avi": (748, 320, 240),
    "road_surface_clear_640x360.avi": (374, 640, 360),
}


def fixture_clip(name: str) -> Path:
    path = FIXTURE_VIDEO / name
    if not path.is_file():
        pytest.skip(f"{path} is not beside this checkout")
    return path


def write_clip(path: Path, frames: list[np.ndarray], *, fps: int = 25, codec: str = "mpeg4"):
    """Grey frames to a video with PyAV directly (independent of the code under test)."""
    height, width = frames[0].shape
    with av.open(str(path), mode="w") as container:
        stream = container.add_stream(codec, rate=Fraction(fps))
        stream.width, stream.height, stream.pix_fmt = width, height, "yuv420p"
        stream.bit_rate = 4_000_000
        if codec == "mpeg4":
            stream.codec_context.max_b_frames = 2  # packed B-frames in AVI: reordered times
        for i, gray in enumerate(frames):
            frame = av.VideoFrame.from_ndarray(gray, format="gray")
            frame.pts = i
            container.mux(stream.encode(frame))
        container.mux(stream.encode(None))


def ramp_frames(n: int, width: int = 96, height: int = 64) -> list[np.ndarray]:
    """Frame i is flat at grey 20 + 4 i: the order of decoded frames can be read back."""
    return [np.full((height, width), 20 + 4 * i, np.uint8) for i in range(n)]


@pytest.fixture
def clip(tmp_path: Path) -> Path:
    path = tmp_path / "ramp.avi"
    write_clip(path, ramp_frames(40))
    return path


def decode_threads() -> list[threading.Thread]:
    return [t for t in threading.enumerate() if t.name.startswith("decode ")]


# -- real clips --------------------------------------------------------------------------
@pytest.mark.parametrize("name", sorted(CLIPS))
def test_real_clip_decodes_every_frame_with_increasing_times(name: str) -> None:
    expected, width, height = CLIPS[name]
    with open_video(fixture_clip(name)) as video:
        frames = list(video)
        assert (video.width, video.height) == (width, height)
        assert video.fps > 0
        assert video.frames_skipped == 0
    assert len(frames) == expected
    assert [f.index for f in frames] == list(range(expected))
    t = np.array([f.t_s for f in frames])
    assert t[0] == 0.0
    assert np.all(np.diff(t) > 0)
    # regular steps of one frame period: the motorway clip is a DivX AVI with packed B-frames,
    # whose frames carry decode-order times (1, 4, 6, 5, 7, 9, 8...) until sorted
    steps = np.diff(t) * video.fps
    assert np.mean(np.abs(steps - 1.0) < 1e-6) > 0.99
    for f in frames[:: expected // 5]:
        assert f.gray.shape == (height, width)
        assert f.gray.dtype == np.uint8
        assert f.gray.flags.c_contiguous and f.gray.flags.owndata


def test_luma_equals_ffmpeg_grey_despite_padded_lines() -> None:
    # The 320-px-wide fixture has 384-byte lines: a stride-blind copy would shear the image.
    # Its luma is limited-range: stretched to 0-255 exactly as FFmpeg's conversion does.
    path = fixture_clip("motorway_clear_320x240.avi")
    with av.open(str(path)) as container:
        frame = next(container.decode(video=0))
        assert frame.planes[0].line_size != frame.width
        expected = frame.to_ndarray(format="gray")
    with open_video(path) as video:
        gray = next(iter(video)).gray
    np.testing.assert_array_equal(gray, expected)


def test_truncated_real_clip_decodes_what_it_can(tmp_path: Path) -> None:
    path = fixture_clip("road_surface_clear_640x360.avi")
    data = path.read_bytes()
    cut = tmp_path / "truncated.avi"
    cut.write_bytes(data[: len(data) // 2])
    with open_video(cut) as video:
        n = sum(1 for _ in video)
    assert 0 < n < CLIPS[path.name][0]


def test_corruption_in_the_middle_is_skipped_and_logged_once(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    path = fixture_clip("motorway_clear_320x240.avi")
    data = bytearray(path.read_bytes())
    rng = np.random.default_rng(7)
    for start in (0.3, 0.5, 0.7):  # three damaged places
        a = int(start * len(data))
        data[a : a + 3000] = rng.integers(0, 256, 3000, dtype=np.uint8).tobytes()
    damaged = tmp_path / "damaged.avi"
    damaged.write_bytes(bytes(data))
    with caplog.at_level(logging.WARNING, logger="drivers.video"):
        with open_video(damaged) as video:
            frames = list(video)
            skipped = video.frames_skipped
    assert skipped >= 1
    assert len(frames) > CLIPS[path.name][0] // 2
    assert np.all(np.diff([f.t_s for f in frames]) > 0)
    warnings = [r for r in caplog.records if r.name == "drivers.video"]
    assert len(warnings) == 1
    assert str(damaged) in warnings[0].getMessage()


# -- generated clips ---------------------------------------------------------------------
@pytest.mark.parametrize("codec, suffix", [("mpeg4", ".avi"), ("libx264", ".mp4")])
def test_frames_come_in_display_order_with_their_times(
    tmp_path: Path, codec: str, suffix: str
) -> None:
    if codec not in av.codecs_available:
        pytest.skip(f"no {codec} encoder in this PyAV")
    path = tmp_path / f"ramp{suffix}"
    write_clip(path, ramp_frames(30), codec=codec)  # libx264 reorders with B-frames
    with open_video(path) as video:
        frames = list(video)
        assert video.fps == 25
    assert len(frames) == 30
    levels = np.array([np.median(f.gray) for f in frames])
    np.testing.assert_allclose(levels, 20 + 4 * np.arange(30), atol=2)  # in order, full range
    np.testing.assert_allclose([f.t_s for f in frames], np.arange(30) / 25, atol=1e-6)


def test_writer_pads_to_even_size_and_round_trips(tmp_path: Path) -> None:
    path = tmp_path / "out.mp4"
    with VideoWriter(path, width=97, height=63, fps=10) as writer:
        for gray in ramp_frames(12, width=97, height=63):
            writer.write(cv2.cvtColor(gray, cv2.COLOR_GRAY2BGR))
        writer.write(np.zeros((20, 30), np.uint8))  # another size: resized, still written
    assert writer.frames_written == 13
    with open_video(path) as video:
        frames = list(video)
        assert (video.width, video.height) == (98, 64)
        assert video.fps == 10
    assert len(frames) == 13
    assert abs(int(frames[5].gray[30, 40]) - (20 + 4 * 5)) <= 3


# -- image folders -----------------------------------------------------------------------
def test_image_folder_in_name_order_with_bad_images_skipped(tmp_path: Path) -> None:
    for i, gray in enumerate(ramp_frames(5)):
        ext = (".png", ".jpg", ".bmp", ".tif", ".PNG")[i]
        cv2.imwrite(str(tmp_path / f"img_{i:03d}{ext}"), gray)
    (tmp_path / "img_002b.png").write_bytes(b"not a png")  # unreadable: skipped, counted
    (tmp_path / "notes.txt").write_text("ignored")
    (tmp_path / "img_005.png").write_bytes(b"")
    with open_video(tmp_path, fps=10) as video:
        frames = list(video)
        assert video.frames_skipped == 2
        assert (video.width, video.height, video.fps) == (96, 64, 10)
    assert [f.index for f in frames] == [0, 1, 2, 3, 4]
    # t_s is the position in the folder: the unreadable image leaves a gap
    assert [f.t_s for f in frames] == pytest.approx([0.0, 0.1, 0.2, 0.4, 0.5])
    assert [int(np.median(f.gray)) for f in frames] == pytest.approx([20, 24, 28, 32, 36], abs=2)


def test_image_folder_default_rate_and_odd_sizes(tmp_path: Path) -> None:
    cv2.imwrite(str(tmp_path / "a.png"), np.zeros((30, 40), np.uint8))
    cv2.imwrite(str(tmp_path / "b.png"), np.zeros((31, 40, 3), np.uint8))  # another size
    cv2.imwrite(str(tmp_path / "c.png"), np.full((30, 40, 3), 200, np.uint8))  # colour
    with open_video(tmp_path) as video:
        frames = list(video)
        assert video.fps == 25
        assert video.frames_skipped == 1
    assert [f.gray.shape for f in frames] == [(30, 40), (30, 40)]
    assert frames[1].t_s == pytest.approx(2 / 25)


# -- hostile inputs ----------------------------------------------------------------------
def _hostile(tmp_path: Path, kind: str) -> Path:
    rng = np.random.default_rng(3)
    path = tmp_path / "input.avi"
    if kind == "missing":
        return tmp_path / "missing.avi"
    if kind == "zero-byte":
        path.write_bytes(b"")
    elif kind == "random-bytes":
        path.write_bytes(rng.integers(0, 256, 200_000, dtype=np.uint8).tobytes())
    elif kind == "text-named-avi":
        path.write_text("this is not a video\n" * 50)
    elif kind == "header-only":  # a real AVI cut before its first frame
        write_clip(path, ramp_frames(10))
        path.write_bytes(path.read_bytes()[:2048])
    elif kind == "empty-folder":
        path = tmp_path / "frames"
        path.mkdir()
    elif kind == "folder-without-images":
        path = tmp_path / "frames"
        path.mkdir()
        (path / "readme.txt").write_text("no images here")
    elif kind == "folder-of-bad-images":
        path = tmp_path / "frames"
        path.mkdir()
        (path / "a.png").write_bytes(b"garbage")
        (path / "b.jpg").write_bytes(b"")
    return path


HOSTILE = [
    "missing",
    "zero-byte",
    "random-bytes",
    "text-named-avi",
    "header-only",
    "empty-folder",
    "folder-without-images",
    "folder-of-bad-images",
]


@pytest.mark.parametrize("kind", HOSTILE)
def test_unusable_input_is_one_input_error_naming_the_file(tmp_path: Path, kind: str) -> None:
    path = _hostile(tmp_path, kind)
    with pytest.raises(InputError) as err:
        open_video(path)
    message = str(err.value)
    assert str(path) in message
    assert "\n" not in message
    assert not decode_threads()


def test_invalid_fps_is_rejected(clip: Path) -> None:
    with pytest.raises(ValueError, match="fps"):
        open_video(clip, fps=0)


# -- the decoding thread -----------------------------------------------------------------
def test_early_close_stops_and_joins_the_thread(clip: Path) -> None:
    video = open_video(clip)
    it = iter(video)
    next(it)
    next(it)  # the producer is now blocked on a full queue
    assert len(decode_threads()) == 1
    video.close()
    assert not decode_threads()
    video.close()  # idempotent
    assert list(it) == []


def test_context_exit_on_exception_joins_the_thread(clip: Path) -> None:
    with pytest.raises(RuntimeError), open_video(clip) as video:
        for frame in video:
            if frame.index == 3:
                raise RuntimeError("consumer failed")
    assert not decode_threads()


def test_full_iteration_ends_the_thread(clip: Path) -> None:
    video = open_video(clip)
    assert sum(1 for _ in video) == 40
    assert not decode_threads()
    assert isinstance(video, VideoReader)


def test_interpreter_exits_with_a_reader_left_open(clip: Path) -> None:
    code = (
        "from drivers.video import open_video\n"
        f"video = open_video({str(clip)!r})\n"
        "next(iter(video))\n"
        "print('done')\n"
    )
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    proc = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=60
    )
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == "done"
