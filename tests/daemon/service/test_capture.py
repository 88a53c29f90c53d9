"""The capture thread: newest-frame mailbox, backoff, recovery, prompt stop; real file and HTTP."""

from __future__ import annotations

import logging
import shutil
import threading
import time
from collections.abc import Callable, Iterator
from itertools import islice
from pathlib import Path

import numpy as np
import pytest

from daemon.service.capture import CaptureThread, backoff_delays
from drivers.errors import ConfigError, SourceError
from drivers.frames import FrameSource, MemorySource
from drivers.sources import open_source
from tests.drivers.test_frames import MjpegServer, write_ramp

WAIT_S = 10.0  # upper bound on waiting for something that should happen much sooner


def frames(n: int, start: int = 0) -> list[np.ndarray]:
    """Tiny frames whose first pixel tells which one they are."""
    return [np.full((4, 6), (start + i) % 256, np.uint8) for i in range(n)]


def wait_until(predicate: Callable[[], bool], timeout: float = WAIT_S) -> None:
    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > deadline:
            raise AssertionError("condition not met in time")
        time.sleep(0.005)


@pytest.fixture
def running() -> Iterator[list[CaptureThread]]:
    """Capture threads made by a test, stopped at its end whatever happens."""
    threads: list[CaptureThread] = []
    yield threads
    for thread in threads:
        thread.stop(timeout=2.0)


def start(running: list[CaptureThread], opener: Callable[[], FrameSource], **kw) -> CaptureThread:
    capture = CaptureThread("cam1", opener, **kw)
    running.append(capture)
    capture.start()
    return capture


class Opener:
    """Gives the given sources in turn, then ``then()`` for ever; records when it is called."""

    def __init__(self, *sources: FrameSource, then: Callable[[], FrameSource] | None = None):
        self.sources = list(sources)
        self.then = then or unplugged
        self.calls: list[float] = []
        self.made: list[FrameSource] = []

    def __call__(self) -> FrameSource:
        self.calls.append(time.monotonic())
        source = self.sources.pop(0) if self.sources else self.then()
        self.made.append(source)
        return source


def unplugged() -> MemorySource:
    return MemorySource(open_error=SourceError("memory: camera unplugged"))


# -- the mailbox -------------------------------------------------------------------------
def test_take_gives_the_newest_frame_and_counts_the_overwritten(running) -> None:
    capture = start(running, Opener(MemorySource(frames(10), end=False)))
    wait_until(lambda: capture.stats()["frames_captured"] == 10)
    frame = capture.take(timeout=1.0)
    assert frame is not None and frame.index == 9 and frame.gray[0, 0] == 9
    assert capture.take(timeout=0.05) is None  # taken: nothing new
    stats = capture.stats()
    assert stats["frames_dropped"] == 9
    assert stats["frames_taken"] == 1
    assert stats["state"] == "ok"
    assert stats["source"] == "memory:"


def test_a_taker_gets_each_frame_once_in_order(running) -> None:
    capture = start(running, Opener(MemorySource(frames(20), interval_s=0.02, end=False)))
    got: list[int] = []
    while not got or got[-1] < 19:
        frame = capture.take(timeout=WAIT_S)
        assert frame is not None
        got.append(int(frame.gray[0, 0]))
    assert np.all(np.diff(got) > 0)  # never the same frame twice, never an older one
    stats = capture.stats()
    assert stats["frames_captured"] == 20
    assert stats["frames_taken"] == len(got)
    assert stats["frames_dropped"] == 20 - len(got)  # whatever a slow taker missed


def test_stats_measure_rate_and_frame_age(running) -> None:
    capture = start(running, Opener(MemorySource(frames(15), interval_s=0.02, end=False)))
    wait_until(lambda: capture.stats()["frames_captured"] == 15)
    stats = capture.stats()
    assert 5 < stats["fps"] <= 55  # about 50 Hz, loosely
    assert 0 <= stats["last_frame_age_s"] < WAIT_S
    assert stats["reconnects"] == 0 and stats["last_error"] is None


def test_take_times_out_with_none_when_nothing_comes(running) -> None:
    capture = start(running, Opener(MemorySource([MemorySource.BLOCK])))
    assert capture.take(timeout=0.05) is None
    assert capture.stats()["last_frame_age_s"] is None


# -- ends and failures -----------------------------------------------------------------------
def test_finite_source_ends(running, caplog) -> None:
    caplog.set_level(logging.INFO, logger="daemon.service.capture")
    capture = start(running, Opener(MemorySource([*frames(3), None])))
    wait_until(lambda: capture.state == "ended")
    assert capture.take(timeout=1.0).index == 2
    assert capture.take(timeout=0.05) is None
    assert any("ended" in r.getMessage() for r in caplog.records)
    capture.stop()
    assert capture.state == "stopped"


def test_backoff_delays_double_up_to_the_bound() -> None:
    assert list(islice(backoff_delays(0.5, 30.0), 9)) == [0.5, 1, 2, 4, 8, 16, 30, 30, 30]
    assert list(islice(backoff_delays(1.0, 1.0), 3)) == [1, 1, 1]


def test_failing_source_is_retried_with_growing_delays(running, caplog) -> None:
    caplog.set_level(logging.DEBUG, logger="daemon.service.capture")
    opener = Opener()
    capture = start(running, opener, backoff_initial_s=0.02, backoff_max_s=0.08)
    wait_until(lambda: len(opener.calls) >= 6)
    gaps = np.diff(opener.calls[:6])
    assert np.all(gaps >= 0.9 * np.array([0.02, 0.04, 0.08, 0.08, 0.08]))
    stats = capture.stats()
    assert stats["state"] == "reconnecting"
    assert stats["reconnects"] >= 5
    assert "camera unplugged" in stats["last_error"]
    assert stats["next_retry_s"] == pytest.approx(0.08)
    warnings = [r for r in caplog.records if r.levelno >= logging.WARNING]
    assert len(warnings) == 1  # one line for the state change, not one per attempt
    assert warnings[0].getMessage() == (
        "camera cam1: source unavailable (memory: camera unplugged); reconnecting in 0.02 s"
    )
    assert all(m.closed for m in opener.made[:-1])


def test_recovers_after_failures_and_resets_the_backoff(running, caplog) -> None:
    caplog.set_level(logging.INFO, logger="daemon.service.capture")
    opener = Opener(
        unplugged(),
        unplugged(),
        MemorySource([*frames(3), SourceError("memory: cable pulled")]),
        unplugged(),
        MemorySource(frames(2, start=50), end=False),
    )
    capture = start(running, opener, backoff_initial_s=0.05, backoff_max_s=1.0)
    wait_until(lambda: capture.stats()["frames_captured"] == 5)
    assert capture.state == "ok"
    assert capture.take(timeout=1.0).gray[0, 0] == 51
    stats = capture.stats()
    assert stats["reconnects"] == 4
    assert stats["last_error"] == "memory: camera unplugged"
    gaps = np.diff(opener.calls)
    assert np.all(gaps >= 0.9 * np.array([0.05, 0.1, 0.05, 0.1]))
    messages = [r.getMessage() for r in caplog.records]
    lost = [m for m in messages if "source lost" in m]
    # frames flowed before the cable was pulled: the delay is the initial one again
    assert lost == ["camera cam1: source lost (memory: cable pulled); reconnecting in 0.05 s"]
    assert sum("receiving frames" in m for m in messages) == 2


def test_unexpected_exception_is_retried_and_logged_with_traceback(running, caplog) -> None:
    opener = Opener(
        MemorySource([frames(1)[0], RuntimeError("driver bug")]),
        MemorySource(frames(1), end=False),
    )
    capture = start(running, opener, backoff_initial_s=0.01)
    wait_until(lambda: capture.stats()["frames_captured"] == 2)
    assert capture.stats()["last_error"] == "RuntimeError: driver bug"
    assert any(r.exc_info and "driver bug" in r.getMessage() for r in caplog.records)


def test_config_error_fails_for_good(running) -> None:
    def opener() -> FrameSource:
        return open_source("usb:0")

    capture = start(running, opener)
    wait_until(lambda: capture.state == "failed")
    assert "unknown frame source" in capture.stats()["last_error"]
    assert capture.take(timeout=0.05) is None


# -- stopping ------------------------------------------------------------------------------
def test_stop_during_a_long_backoff_returns_promptly(running) -> None:
    opener = Opener()
    capture = start(running, opener, backoff_initial_s=30.0)
    wait_until(lambda: capture.state == "reconnecting")
    began = time.monotonic()
    capture.stop(timeout=5.0)
    assert time.monotonic() - began < 3.0  # not the 30 s backoff
    assert capture.state == "stopped"
    assert len(opener.calls) == 1


def test_stop_during_a_blocked_read_closes_the_source(running) -> None:
    source = MemorySource([frames(1)[0], MemorySource.BLOCK])
    capture = start(running, Opener(source))
    assert capture.take(timeout=WAIT_S) is not None  # now blocked in the second read
    began = time.monotonic()
    capture.stop(timeout=5.0)
    assert time.monotonic() - began < 3.0
    assert source.closed
    assert capture.state == "stopped"
    assert not any(t.name == "capture cam1" for t in threading.enumerate())


def test_stop_before_start_and_twice_is_harmless() -> None:
    capture = CaptureThread("cam1", Opener())
    capture.stop(timeout=0.1)
    capture.stop(timeout=0.1)
    assert capture.state == "stopped"


# -- real sources ----------------------------------------------------------------------------
def test_demo_source_through_the_capture_thread(running) -> None:
    capture = start(
        running, lambda: open_source("demo:", width=96, height=64, fps=25, realtime=False)
    )
    frame = capture.take(timeout=WAIT_S)
    assert frame is not None and frame.gray.shape == (64, 96)
    wait_until(lambda: capture.stats()["frames_captured"] > 5)
    assert capture.state == "ok"


def test_file_removed_then_restored_reconnects(running, tmp_path: Path, caplog) -> None:
    caplog.set_level(logging.INFO, logger="daemon.service.capture")
    path = tmp_path / "cam.avi"
    write_ramp(path, 10)
    spare = tmp_path / "spare.avi"
    shutil.copy(path, spare)
    capture = start(
        running,
        lambda: open_source(f"file:{path}", loop=True, realtime=False),
        backoff_initial_s=0.05,
        backoff_max_s=0.2,
    )
    assert capture.take(timeout=WAIT_S) is not None
    path.unlink()  # the loop cannot restart, nor can the source reopen
    wait_until(lambda: capture.state == "reconnecting")
    assert "no such file" in capture.stats()["last_error"]
    captured = capture.stats()["frames_captured"]
    shutil.copy(spare, path)
    wait_until(lambda: capture.state == "ok" and capture.stats()["frames_captured"] > captured)
    assert capture.take(timeout=WAIT_S).gray.shape == (48, 64)
    assert capture.stats()["reconnects"] >= 1
    assert any("source lost" in r.getMessage() for r in caplog.records)


def test_http_camera_gone_and_back(running) -> None:
    server = MjpegServer().start()
    try:
        capture = start(
            running,
            lambda: open_source(server.url, timeout_s=2),
            backoff_initial_s=0.1,
            backoff_max_s=0.4,
        )
        assert capture.take(timeout=WAIT_S) is not None
        server.stop()
        wait_until(lambda: capture.state == "reconnecting")
        captured = capture.stats()["frames_captured"]
        server.start()  # the same port
        wait_until(lambda: capture.state == "ok" and capture.stats()["frames_captured"] > captured)
        assert capture.take(timeout=WAIT_S).gray.shape == (48, 64)
        assert capture.stats()["reconnects"] >= 1
    finally:
        server.stop()


def test_config_errors_are_not_source_errors() -> None:
    assert not issubclass(ConfigError, SourceError)
