"""Property tests: random and damaged bytes given to the readers of untrusted files.

The video reader (``open_video``), the MCAP readers (``weatherd recover``'s
:func:`~daemon.recording.mcap_repair.recover` and the frames that ``calibrate``/``compare``
read, :func:`~daemon.offline.mcap_frames.iter_frames`) and the TOML configuration loader each
get random bytes, truncated files and files with bytes overwritten. Each must give a clean
error (a :class:`~drivers.errors.WeatherdError`, which the command line turns into one line and
exit status 2) or valid output; never another exception (an internal error), never a hang
(every example runs under a timer). Instrument drivers and reference formats are fuzzed beside
their own tests.

Bounded: a few dozen examples per reader, no shrinking database, so that the file runs in well
under 30 s on a busy machine.
"""

from __future__ import annotations

import contextlib
import json
import signal
from collections.abc import Iterator
from fractions import Fraction
from pathlib import Path

import av
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from mcap.writer import Writer

from daemon.config import load_config
from daemon.offline.mcap_frames import iter_frames
from daemon.recording.mcap_repair import recover
from drivers.errors import WeatherdError
from drivers.video import open_video
from tests.conftest import REPO

#: Seconds one example may take before it counts as a hang.
EXAMPLE_TIMEOUT_S = 10

FUZZ = settings(
    max_examples=80,
    deadline=None,  # the timer below is the limit; first examples pay for imports
    database=None,
    derandomize=True,  # the same examples every run: a failure can be replayed
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)


@contextlib.contextmanager
def time_limit(seconds: float = EXAMPLE_TIMEOUT_S) -> Iterator[None]:
    """TimeoutError in the main thread if the block takes longer than ``seconds``."""

    def expire(_signum: int, _frame: object) -> None:
        raise TimeoutError(f"no answer in {seconds} s: a hang")

    previous = signal.signal(signal.SIGALRM, expire)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def damaged(original: bytes) -> st.SearchStrategy[bytes]:
    """``original`` truncated, with a stretch overwritten, or with random bytes appended."""
    n = len(original)
    cut = st.integers(0, n).map(lambda k: original[:k])
    overwrite = st.tuples(st.integers(0, n - 1), st.binary(min_size=1, max_size=64)).map(
        lambda a: original[: a[0]] + a[1] + original[a[0] + len(a[1]) :]
    )
    flip = st.lists(st.integers(0, n - 1), min_size=1, max_size=8).map(
        lambda positions: bytes(
            b ^ 0xFF if i in set(positions) else b for i, b in enumerate(original)
        )
    )
    return st.one_of(cut, overwrite, flip)


# -- video ---------------------------------------------------------------------------------
def _clip_bytes(tmp: Path) -> bytes:
    path = tmp / "seed.avi"
    with av.open(str(path), mode="w") as container:
        stream = container.add_stream("mpeg4", rate=Fraction(25))
        stream.width, stream.height, stream.pix_fmt = 64, 48, "yuv420p"
        rng = np.random.default_rng(0)
        for i in range(8):
            frame = av.VideoFrame.from_ndarray(
                rng.integers(0, 255, (48, 64), dtype=np.uint8), format="gray"
            )
            frame.pts = i
            container.mux(stream.encode(frame))
        container.mux(stream.encode(None))
    return path.read_bytes()


@pytest.fixture(scope="module")
def clip_bytes(tmp_path_factory: pytest.TempPathFactory) -> bytes:
    return _clip_bytes(tmp_path_factory.mktemp("seed"))


SUFFIXES = [".avi", ".mp4", ".mkv", ".bin", ".nfo", ".jpg", ".ts", ".y4m", ""]


def read_video(path: Path) -> None:
    with time_limit():
        try:
            with open_video(path) as video:
                for frame in video:
                    assert frame.gray.dtype == np.uint8 and frame.gray.ndim == 2
                    assert frame.gray.shape == (video.height, video.width)
        except WeatherdError as exc:
            assert "\n" not in str(exc) and str(path) in str(exc)


@FUZZ
@given(data=st.binary(max_size=4096), suffix=st.sampled_from(SUFFIXES))
def test_video_reader_on_random_bytes(tmp_path: Path, data: bytes, suffix: str) -> None:
    path = tmp_path / f"random{suffix}"
    path.write_bytes(data)
    read_video(path)


@FUZZ
@given(data=st.data(), suffix=st.sampled_from([".avi", ".mp4", ".bin"]))
def test_video_reader_on_damaged_clips(
    tmp_path: Path, clip_bytes: bytes, data: st.DataObject, suffix: str
) -> None:
    path = tmp_path / f"damaged{suffix}"
    path.write_bytes(data.draw(damaged(clip_bytes)))
    read_video(path)


# -- MCAP ----------------------------------------------------------------------------------
def _mcap_bytes(tmp: Path) -> bytes:
    path = tmp / "seed.mcap"
    with open(path, "wb") as f:
        writer = Writer(f, chunk_size=512)  # several chunks
        writer.start(profile="", library="test")
        schema = writer.register_schema(
            name="hos.frame", encoding="jsonschema", data=b'{"type": "object"}'
        )
        channel = writer.register_channel(
            topic="/hos/cam/frame", message_encoding="json", schema_id=schema
        )
        for i in range(40):
            data = json.dumps({"schema": "hos.frame/1", "t_ns": i, "R": float(i)}).encode()
            writer.add_message(channel, log_time=i, data=data, publish_time=i)
        writer.finish()
    return path.read_bytes()


@pytest.fixture(scope="module")
def mcap_bytes(tmp_path_factory: pytest.TempPathFactory) -> bytes:
    return _mcap_bytes(tmp_path_factory.mktemp("seed"))


def read_mcap(path: Path, out: Path) -> None:
    with time_limit():
        try:
            result = recover(path, out)
            assert result.bytes_kept + result.bytes_dropped == path.stat().st_size
        except WeatherdError as exc:
            assert "\n" not in str(exc)
        try:
            frames = list(iter_frames([path], progress=False))
            assert all(isinstance(f, dict) and "t_ns" in f for f in frames)
        except WeatherdError as exc:
            assert "\n" not in str(exc)


@FUZZ
@given(data=st.binary(max_size=4096), magic=st.booleans())
def test_mcap_readers_on_random_bytes(tmp_path: Path, data: bytes, magic: bool) -> None:
    path = tmp_path / "random.mcap"
    path.write_bytes((b"\x89MCAP0\r\n" if magic else b"") + data)
    read_mcap(path, tmp_path / "out.mcap")


@FUZZ
@given(data=st.data())
def test_mcap_readers_on_damaged_files(
    tmp_path: Path, mcap_bytes: bytes, data: st.DataObject
) -> None:
    path = tmp_path / "damaged.mcap"
    path.write_bytes(data.draw(damaged(mcap_bytes)))
    read_mcap(path, tmp_path / "out.mcap")


# -- TOML configuration --------------------------------------------------------------------
SHIPPED = (REPO / "config" / "site-example.toml").read_bytes()


def read_config(path: Path) -> None:
    with time_limit():
        try:
            load_config(path)
        except WeatherdError as exc:
            assert all(str(path) in line for line in getattr(exc, "errors", [str(exc)]))


@FUZZ
@given(
    data=st.one_of(
        st.binary(max_size=2048),
        st.text(alphabet="[]{}=\"'.,#\n abcxyz019-+einf", max_size=2048).map(str.encode),
    )
)
def test_config_loader_on_random_bytes(tmp_path: Path, data: bytes) -> None:
    path = tmp_path / "random.toml"
    path.write_bytes(data)
    read_config(path)


@FUZZ
@given(data=st.data())
def test_config_loader_on_damaged_files(tmp_path: Path, data: st.DataObject) -> None:
    path = tmp_path / "damaged.toml"
    path.write_bytes(data.draw(damaged(SHIPPED)))
    read_config(path)
