"""The MCAP recorder: round trip, rotation, disk budget, full disk, crash and repair."""

from __future__ import annotations

import base64
import errno
import logging
import os
import signal
import struct
import subprocess
import sys
import threading
from datetime import UTC, datetime
from pathlib import Path

import jsonschema
import mcap.writer
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from mcap.reader import make_reader
from mcap.writer import CompressionType

import daemon.recording.recorder as recorder_mod
from daemon.recording.mcap_repair import recover, recover_directory
from daemon.recording.recorder import (
    FOXGLOVE_COMPRESSED_IMAGE_SCHEMA,
    FOXGLOVE_LOG_SCHEMA,
    MCAP_MAGIC,
    JsonDecoderFactory,
    McapFile,
    Recorder,
    RecorderLogHandler,
    compressed_image,
    encode_json,
    log_message,
)
from drivers.errors import InputError
from tests.conftest import REPO

TICK = {"type": "object", "properties": {"i": {"type": "integer"}}, "required": ["i"]}
T0_NS = int(datetime(2026, 11, 22, 12, 34, 56, tzinfo=UTC).timestamp()) * 1_000_000_000


class FakeClock:
    """An injectable clock (integer ns) that only moves when told."""

    def __init__(self, t_ns: int = T0_NS) -> None:
        self.t_ns = t_ns

    def __call__(self) -> int:
        return self.t_ns

    def advance(self, seconds: float) -> None:
        self.t_ns += round(seconds * 1e9)


def read_mcap(path: Path) -> list[tuple[str, str, dict, int]]:
    """``(topic, schema name, decoded message, log time)`` of every message, in file order."""
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[JsonDecoderFactory()])
        return [
            (channel.topic, schema.name, decoded, message.log_time)
            for schema, channel, message, decoded in reader.iter_decoded_messages(
                log_time_order=False
            )
        ]


def finished(directory: Path) -> list[Path]:
    """Finished recordings, oldest first (by start time, then sequence suffix)."""

    def key(p: Path) -> tuple[str, int]:
        stem = p.name.removesuffix(".mcap").split("_")[-1]
        start, _, seq = stem.partition("-")
        return start, int(seq or 0)

    return sorted(directory.glob("*.mcap"), key=key)


def ticks(directory: Path) -> list[int]:
    return [msg["i"] for path in finished(directory) for _, _, msg, _ in read_mcap(path)]


# --------------------------------------------------------------------------- messages


def test_foxglove_schemas_are_valid_and_helpers_conform() -> None:
    jpeg = bytes(range(256)) * 3
    image = compressed_image(jpeg, t_ns=T0_NS + 123_456_789, frame_id="cam0")
    record = logging.LogRecord("hos.x", logging.WARNING, "/src/x.py", 42, "n=%d", (7,), None)
    log = log_message(record)
    for schema, message in [(FOXGLOVE_COMPRESSED_IMAGE_SCHEMA, image), (FOXGLOVE_LOG_SCHEMA, log)]:
        jsonschema.validators.validator_for(schema).check_schema(schema)
        jsonschema.validate(message, schema)
    assert FOXGLOVE_COMPRESSED_IMAGE_SCHEMA["title"] == "foxglove.CompressedImage"
    assert FOXGLOVE_LOG_SCHEMA["title"] == "foxglove.Log"
    assert base64.b64decode(image["data"]) == jpeg
    assert image["timestamp"] == {"sec": T0_NS // 10**9, "nsec": 123_456_789}
    assert (image["format"], image["frame_id"]) == ("jpeg", "cam0")
    assert (log["level"], log["message"], log["name"], log["file"], log["line"]) == (
        3,
        "n=7",
        "hos.x",
        "/src/x.py",
        42,
    )
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate({**log, "level": 9}, FOXGLOVE_LOG_SCHEMA)


@pytest.mark.parametrize(
    ("levelno", "expected"),
    [(logging.DEBUG, 1), (logging.INFO, 2), (logging.WARNING, 3), (logging.ERROR, 4),
     (logging.CRITICAL, 5), (25, 2)],
)  # fmt: skip
def test_log_levels_map_to_foxglove(levelno: int, expected: int) -> None:
    record = logging.LogRecord("n", levelno, "f.py", 1, "m", None, None)
    assert log_message(record)["level"] == expected


def test_log_message_keeps_the_traceback() -> None:
    try:
        raise RuntimeError("boom")
    except RuntimeError:
        record = logging.LogRecord("n", logging.ERROR, "f.py", 1, "failed", None, sys.exc_info())
    text = log_message(record)["message"]
    assert text.startswith("failed\nTraceback") and "RuntimeError: boom" in text


def test_encode_json_handles_numpy_and_non_finite_floats() -> None:
    data = encode_json({"a": np.float32(1.5), "b": [np.int64(3), float("nan")], "c": np.eye(2)})
    assert data == b'{"a":1.5,"b":[3,null],"c":[[1.0,0.0],[0.0,1.0]]}'
    assert encode_json({"x": np.float32("inf")}) == b'{"x":null}'
    with pytest.raises(TypeError):
        encode_json({"x": object()})


# --------------------------------------------------------------------------- recording


def test_round_trip_with_mcap_reader(tmp_path: Path) -> None:
    clock = FakeClock()
    jpeg = b"\xff\xd8fake-jpeg\xff\xd9"
    sent = []
    with Recorder(tmp_path, site="demo", clock=clock) as rec:
        for i in range(30):
            t_ns = T0_NS + i * 100_000_000
            sent.append(("/hos/cam0/frame", "hos.frame", {"i": i, "pi": 0.25}, t_ns))
            if i % 10 == 0:
                sent.append(("/hos/cam0/thumbnail", "foxglove.CompressedImage",
                             compressed_image(jpeg, t_ns=t_ns, frame_id="cam0"), t_ns))  # fmt: skip
        sent.append(("/hos/cam0/frame", "hos.frame", {"i": 30, "pi": float("nan")}, T0_NS))
        schemas = {"hos.frame": TICK, "foxglove.CompressedImage": FOXGLOVE_COMPRESSED_IMAGE_SCHEMA}
        for topic, name, message, t_ns in sent:
            assert rec.write(topic, name, schemas[name], message, t_ns=t_ns)
        assert [p.name for p in tmp_path.iterdir()] == ["demo_20261122T123456Z.mcap.part"]
        assert rec.stats()["messages"] == len(sent)
    assert [p.name for p in tmp_path.iterdir()] == ["demo_20261122T123456Z.mcap"]

    path = tmp_path / "demo_20261122T123456Z.mcap"
    got = read_mcap(path)
    sent[-1][2]["pi"] = None  # NaN is recorded as null
    assert got == sent
    with open(path, "rb") as f:
        summary = make_reader(f).get_summary()
    assert sorted((s.name, s.encoding) for s in summary.schemas.values()) == [
        ("foxglove.CompressedImage", "jsonschema"),
        ("hos.frame", "jsonschema"),
    ]
    assert {c.message_encoding for c in summary.channels.values()} == {"json"}
    counts = {
        summary.channels[k].topic: v for k, v in summary.statistics.channel_message_counts.items()
    }
    assert counts == {"/hos/cam0/frame": 31, "/hos/cam0/thumbnail": 3}
    with open(path, "rb") as f:
        messages = [m for _, _, m in make_reader(f).iter_messages(log_time_order=False)]
    assert all(m.publish_time == m.log_time for m in messages)


def test_rotation_by_time_makes_standalone_files(tmp_path: Path) -> None:
    clock = FakeClock()
    with Recorder(tmp_path, site="demo", rotate_s=10, clock=clock) as rec:
        for i in range(35):
            assert rec.write("/a", "t.Tick", TICK, {"i": i}, t_ns=clock())
            assert rec.write("/b", "t.Tick", TICK, {"i": i}, t_ns=clock())
            clock.advance(1.0)
    names = [p.name for p in finished(tmp_path)]
    assert names == [
        "demo_20261122T123456Z.mcap",
        "demo_20261122T123506Z.mcap",
        "demo_20261122T123516Z.mcap",
        "demo_20261122T123526Z.mcap",
    ]
    for path, n in zip(finished(tmp_path), (10, 10, 10, 5), strict=True):
        with open(path, "rb") as f:
            summary = make_reader(f).get_summary()
        assert sorted(c.topic for c in summary.channels.values()) == ["/a", "/b"]
        assert [s.name for s in summary.schemas.values()] == ["t.Tick"]
        assert summary.statistics.message_count == 2 * n
    assert ticks(tmp_path) == [i for i in range(35) for _ in (0, 1)]


def test_rotation_by_size_and_names_within_one_second(tmp_path: Path) -> None:
    clock = FakeClock()  # never advances: every file starts in the same second
    with Recorder(
        tmp_path, site="demo", rotate_bytes=3000, chunk_size=512, compression="none", clock=clock
    ) as rec:
        for i in range(200):
            assert rec.write("/a", "t.Tick", TICK, {"i": i, "pad": "x" * 40}, t_ns=clock())
    files = finished(tmp_path)
    assert len(files) >= 4
    assert [p.name for p in files[:3]] == [
        "demo_20261122T123456Z.mcap",
        "demo_20261122T123456Z-1.mcap",
        "demo_20261122T123456Z-2.mcap",
    ]
    # the size is checked before each message: a file overshoots by at most a chunk + summary
    assert all(p.stat().st_size < 3000 + 2 * 512 + 1024 for p in files)
    assert ticks(tmp_path) == list(range(200))


def test_budget_deletes_oldest_first_and_never_the_current_file(tmp_path: Path) -> None:
    clock = FakeClock()
    other = tmp_path / "other_20000101T000000Z.mcap"  # another site's file: never ours to delete
    other.write_bytes(b"x" * 100)
    created = []
    rec = Recorder(tmp_path, site="demo", rotate_bytes=2000, chunk_size=256, compression="none",
                   budget_bytes=7000, clock=clock, budget_interval_s=3600)  # fmt: skip
    for i in range(400):
        rec.write("/a", "t.Tick", TICK, {"i": i, "pad": "y" * 30}, t_ns=clock())
        if rec.stats()["file"] not in created:
            created.append(rec.stats()["file"])
        clock.advance(1.0)
    stats = rec.stats()
    current = Path(stats["file"])
    assert current.exists()
    kept = finished(tmp_path)
    assert other in kept
    kept.remove(other)
    created_finished = [Path(p).with_suffix("") for p in created[:-1]]
    assert kept == created_finished[-len(kept) :]  # the newest survive, in order
    assert stats["files_deleted"] == len(created_finished) - len(kept) > 0
    assert stats["total_bytes"] <= 7000 + 2000 + 1024  # budget + the growing current file
    rec.close()


def test_min_free_space_deletes_everything_but_the_current_file(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    clock = FakeClock()
    unrepaired = tmp_path / "demo_20200101T000000Z.mcap.part"  # an earlier run's: repair first
    unrepaired.write_bytes(MCAP_MAGIC)
    rec = Recorder(tmp_path, site="demo", rotate_s=5, clock=clock, budget_interval_s=1)
    for i in range(20):
        rec.write("/a", "t.Tick", TICK, {"i": i}, t_ns=clock())
        clock.advance(1.0)
    assert len(finished(tmp_path)) == 3
    monkeypatch.setattr(recorder_mod, "_free_bytes", lambda directory: 0)
    with caplog.at_level(logging.INFO, logger="daemon.recording.recorder"):
        for i in range(20, 24):
            assert rec.write("/a", "t.Tick", TICK, {"i": i}, t_ns=clock())
            clock.advance(1.0)
    assert finished(tmp_path) == []
    assert Path(rec.stats()["file"]).exists()
    assert unrepaired.exists()
    assert rec.stats()["files_deleted"] == 4  # 3 + the file finished at t = 20 s
    assert sum("deleted" in r.getMessage() for r in caplog.records) == 4
    assert sum("budget not met" in r.getMessage() for r in caplog.records) == 1  # once
    rec.close()
    assert ticks(tmp_path) == list(range(20, 24))


class FlakyDisk:
    """Opens real files whose writes fail with ENOSPC while ``full`` is set."""

    def __init__(self) -> None:
        self.full = False

    def open(self, path: Path) -> FlakyStream:
        return FlakyStream(open(path, "xb"), self)


class FlakyStream:
    def __init__(self, f, disk: FlakyDisk) -> None:
        self.f, self.disk = f, disk

    def write(self, data: bytes) -> int:
        if self.disk.full:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return self.f.write(data)

    def flush(self) -> None:
        self.f.flush()

    def tell(self) -> int:
        return self.f.tell()

    def fileno(self) -> int:
        return self.f.fileno()

    def close(self) -> None:
        self.f.close()


def test_full_disk_drops_counts_and_resumes(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    disk = FlakyDisk()
    monkeypatch.setattr(recorder_mod, "_open_stream", disk.open)
    clock = FakeClock()
    rec = Recorder(tmp_path, site="demo", chunk_size=512, compression="none", clock=clock,
                   flush_interval_s=1.0, retry_interval_s=1.0)  # fmt: skip
    accepted = []
    with caplog.at_level(logging.INFO, logger="daemon.recording.recorder"):
        for i in range(300):
            disk.full = 100 <= i < 200
            accepted.append(
                rec.write("/a", "t.Tick", TICK, {"i": i, "pad": "z" * 30}, t_ns=clock())
            )
            clock.advance(0.05)
        rec.close()
    assert all(accepted[:100]) and all(accepted[230:])
    assert not any(accepted[120:200])
    messages = [r.getMessage() for r in caplog.records]
    assert sum(m.startswith("recording stopped") for m in messages) == 1
    assert sum(m.startswith("recording resumed") for m in messages) == 1
    # the file abandoned when the disk filled was repaired once recording resumed (failed
    # opens left no empty files): nothing is left to repair at the next start-up
    assert list(tmp_path.glob("*.mcap.part")) == []
    assert rec.stats()["files_repaired"] == 1
    assert recover_directory(tmp_path) == []
    got = ticks(tmp_path)
    assert set(got) <= {i for i, ok in enumerate(accepted) if ok}
    # every message is either in a file or counted as dropped
    assert len(got) + rec.stats()["dropped"] == 300
    assert rec.stats()["dropped"] >= accepted.count(False)


def test_budget_may_delete_a_file_abandoned_after_a_disk_error(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    disk = FlakyDisk()
    monkeypatch.setattr(recorder_mod, "_open_stream", disk.open)
    # Resumed, the recorder repairs the files it abandoned in a thread of its own, which
    # removes this one (nothing in it to recover) whenever the scheduler runs it: here the
    # budget alone is under test.
    monkeypatch.setattr(recorder_mod, "recover_directory", lambda directory, parts: [])
    clock = FakeClock()
    rec = Recorder(tmp_path, site="demo", clock=clock, budget_interval_s=10)
    assert rec.write("/a", "t.Tick", TICK, {"i": 0}, t_ns=clock())
    disk.full = True
    clock.advance(1.0)
    assert not rec.write("/a", "t.Tick", TICK, {"i": 1}, t_ns=clock())  # flush fails
    (abandoned,) = tmp_path.glob("*.mcap.part")
    disk.full = False
    clock.advance(1.0)
    assert rec.write("/a", "t.Tick", TICK, {"i": 2}, t_ns=clock())
    current = Path(rec.stats()["file"])
    assert current != abandoned and abandoned.exists()
    monkeypatch.setattr(recorder_mod, "_free_bytes", lambda directory: 0)
    clock.advance(10.0)
    rec.flush()
    assert not abandoned.exists() and current.exists()
    rec.close()


def test_mcap_file_for_offline_tools(tmp_path: Path) -> None:
    out = tmp_path / "replay.mcap"
    with McapFile(out) as f:
        for i in range(5):
            assert f.write("/a", "t.Tick", TICK, {"i": i}, t_ns=T0_NS + i)
        f.write("/b", "t.Tick", TICK, {"i": 5}, t_ns=T0_NS + 5)
        assert not out.exists() and (tmp_path / "replay.mcap.part").exists()
    assert [p.name for p in tmp_path.iterdir()] == ["replay.mcap"]
    assert [(topic, m["i"]) for topic, _, m, _ in read_mcap(out)] == [
        *(("/a", i) for i in range(5)),
        ("/b", 5),
    ]
    f.close()  # idempotent
    with pytest.raises(ValueError, match="after close"):
        f.write("/a", "t.Tick", TICK, {"i": 9}, t_ns=T0_NS)


def test_write_after_close_is_dropped_and_close_is_idempotent(tmp_path: Path) -> None:
    rec = Recorder(tmp_path, site="demo")
    assert rec.write("/a", "t.Tick", TICK, {"i": 0}, t_ns=T0_NS)
    rec.close()
    rec.close()
    assert not rec.write("/a", "t.Tick", TICK, {"i": 1}, t_ns=T0_NS)
    assert rec.stats()["dropped"] == 1
    assert ticks(tmp_path) == [0]


def test_interval_flush_puts_the_open_chunk_on_disk(tmp_path: Path) -> None:
    """Pins ``mcap.writer.Writer.flush``: it must finish the chunk and reach the file."""
    clock = FakeClock()
    rec = Recorder(tmp_path, site="demo", chunk_size=2**20, flush_interval_s=1.0, clock=clock)

    def on_disk() -> int:
        return recover(rec.stats()["file"], tmp_path / "peek.out").messages

    for i in range(3):
        rec.write("/a", "t.Tick", TICK, {"i": i}, t_ns=clock())
        clock.advance(0.3)
    assert on_disk() == 0  # still in the writer's chunk
    clock.advance(0.2)  # 1.1 s after the file started
    rec.write("/a", "t.Tick", TICK, {"i": 3}, t_ns=clock())
    assert on_disk() == 4
    rec.write("/a", "t.Tick", TICK, {"i": 4}, t_ns=clock())
    assert on_disk() == 4
    rec.flush()
    assert on_disk() == 5
    rec.close()


def test_fsync_runs_on_its_interval(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    clock = FakeClock()
    calls = []
    real_fsync = os.fsync
    monkeypatch.setattr(os, "fsync", lambda fd: calls.append(fd) or real_fsync(fd))
    rec = Recorder(tmp_path, site="demo", fsync_interval_s=5.0, clock=clock)
    for i in range(25):  # 12 s of messages
        rec.write("/a", "t.Tick", TICK, {"i": i}, t_ns=clock())
        clock.advance(0.5)
    assert len(calls) == 2  # at 5 s and 10 s
    rec.close()
    assert len(calls) >= 3  # finishing the file syncs it


def test_compression_falls_back_when_zstd_is_missing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    monkeypatch.setattr(mcap.writer, "zstandard", None)
    with caplog.at_level(logging.WARNING, logger="daemon.recording.mcap_file"):
        rec = Recorder(tmp_path, site="demo", compression="zstd")
    assert rec.compression == CompressionType.LZ4
    assert "not installed" in caplog.text
    rec.write("/a", "t.Tick", TICK, {"i": 0}, t_ns=T0_NS)
    rec.close()
    assert ticks(tmp_path) == [0]
    with pytest.raises(ValueError, match="compression"):
        Recorder(tmp_path, site="demo", compression="gzip")
    with pytest.raises(ValueError, match="site"):
        Recorder(tmp_path, site="../etc")


def test_concurrent_writers_lose_nothing(tmp_path: Path) -> None:
    rec = Recorder(tmp_path, site="demo", rotate_bytes=8192, chunk_size=1024, flush_interval_s=0.01)
    n_threads, n = 4, 250

    def run(k: int) -> None:
        for i in range(n):
            assert rec.write(f"/t{k}", "t.Tick", TICK, {"i": k * n + i}, t_ns=T0_NS + i)

    threads = [threading.Thread(target=run, args=(k,)) for k in range(n_threads)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    rec.close()
    assert len(finished(tmp_path)) > 1
    assert sorted(ticks(tmp_path)) == list(range(n_threads * n))
    assert rec.stats()["messages"] == n_threads * n


@pytest.mark.timeout(30)
def test_log_handler_records_the_recorders_own_logs_without_deadlock(tmp_path: Path) -> None:
    clock = FakeClock()
    rec = Recorder(tmp_path, site="demo", rotate_s=1, clock=clock)
    handler = RecorderLogHandler(rec)
    logger = logging.getLogger("daemon.recording.recorder")
    logger.addHandler(handler)
    old_level = logger.level
    logger.setLevel(logging.INFO)
    try:
        for i in range(3):
            rec.write("/a", "t.Tick", TICK, {"i": i}, t_ns=clock())
            clock.advance(1.0)  # every write rotates and logs under the lock
        logging.getLogger("daemon.recording.recorder").warning("hello %s", "there")
    finally:
        logger.removeHandler(handler)
        logger.setLevel(old_level)
        rec.close()
    logs = [m for p in finished(tmp_path) for topic, name, m, _ in read_mcap(p) if topic == "/log"]
    texts = [m["message"] for m in logs]
    assert any(t.startswith("recording to") for t in texts)
    assert "hello there" in texts
    assert all(jsonschema.validate(m, FOXGLOVE_LOG_SCHEMA) is None for m in logs)


# --------------------------------------------------------------------------- crash and repair

CRASH_CHILD = """
import sys, time
sys.path.insert(0, sys.argv[2])
from daemon.recording.recorder import Recorder
rec = Recorder(sys.argv[1], site="crash", flush_interval_s=0.2, fsync_interval_s=60,
               chunk_size=2**20)
schema = {"type": "object"}
t0, period, i = time.monotonic(), 0.01, 0
while True:
    t_ns = time.time_ns()
    rec.write("/tick", "t.Tick", schema, {"i": i}, t_ns=t_ns)
    print(i, t_ns, flush=True)
    i += 1
    time.sleep(max(0.0, t0 + i * period - time.monotonic()))
"""


@pytest.mark.e2e
def test_sigkill_loses_at_most_half_a_second(tmp_path: Path) -> None:
    """100 messages/s, flush every 0.2 s, SIGKILL after ~1.5 s: recover nearly all of them."""
    child = subprocess.Popen(
        [sys.executable, "-c", CRASH_CHILD, str(tmp_path / "rec"), str(REPO)],
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        lines = []
        for line in child.stdout:
            lines.append(line)
            if len(lines) >= 150:
                break
        os.kill(child.pid, signal.SIGKILL)
        child.wait(timeout=10)
        lines += child.stdout.read().splitlines()  # what it printed before dying
    finally:
        if child.poll() is None:
            child.kill()
            child.wait()
    assert child.returncode == -signal.SIGKILL
    last_i, last_t_ns = map(int, lines[-1].split())
    (part,) = (tmp_path / "rec").glob("crash_*.mcap.part")
    result = recover(part, tmp_path / "out.mcap")
    got = read_mcap(tmp_path / "out.mcap")
    assert [m["i"] for _, _, m, _ in got] == list(range(result.messages))  # a clean prefix
    assert result.messages <= last_i + 2  # (it may have written one more before printing)
    assert result.last_log_time_ns >= last_t_ns - 500_000_000  # lost at most 0.5 s
    assert last_i + 1 - result.messages <= 50  # at 100 Hz


@pytest.fixture
def no_fsync(monkeypatch: pytest.MonkeyPatch) -> None:
    """Skip fsync in loops over thousands of repairs (durability is not what they test)."""
    monkeypatch.setattr(os, "fsync", lambda fd: None)


@pytest.fixture(scope="module")
def small_recording(tmp_path_factory: pytest.TempPathFactory) -> tuple[bytes, int]:
    """A finished file of several zstd chunks over two topics; its bytes and message count."""
    directory = tmp_path_factory.mktemp("small")
    with Recorder(directory, site="s", chunk_size=200, clock=FakeClock()) as rec:
        for i in range(16):
            rec.write(f"/t{i % 2}", "t.Tick", TICK, {"i": i, "pad": "p" * (i % 7)}, t_ns=T0_NS + i)
    (path,) = finished(directory)
    return path.read_bytes(), 16


def test_recover_at_every_truncation_point(
    tmp_path: Path, small_recording: tuple[bytes, int], no_fsync: None
) -> None:
    data, n = small_recording
    src, dst = tmp_path / "cut.mcap.part", tmp_path / "cut.mcap"
    # every offset up to the summary (the footer says where it starts), then every 5th
    (summary_start,) = struct.unpack_from("<Q", data, len(data) - len(MCAP_MAGIC) - 20)
    assert 0 < summary_start < len(data)
    sizes = [*range(summary_start + 1), *range(summary_start + 1, len(data), 5), len(data)]
    previous = 0
    for size in sizes:
        src.write_bytes(data[:size])
        if size < len(MCAP_MAGIC):
            with pytest.raises(InputError):
                recover(src, dst)
            continue
        result = recover(src, dst)
        assert result.bytes_kept + result.bytes_dropped == size
        assert result.messages >= previous
        previous = result.messages
        assert [m["i"] for _, _, m, _ in read_mcap(dst)] == list(range(result.messages))
        assert result.complete == (size == len(data))
    assert previous == n
    assert not list(tmp_path.glob("*.tmp"))


def test_recover_a_finished_file_in_place(
    tmp_path: Path, small_recording: tuple[bytes, int]
) -> None:
    data, n = small_recording
    path = tmp_path / "whole.mcap"
    path.write_bytes(data)
    result = recover(path, path)
    assert (result.messages, result.channels, result.schemas) == (n, 2, 1)
    assert (result.first_log_time_ns, result.last_log_time_ns) == (T0_NS, T0_NS + n - 1)
    assert result.complete and result.bytes_dropped == 0
    assert [m["i"] for _, _, m, _ in read_mcap(path)] == list(range(n))


@pytest.mark.parametrize(
    ("content", "match"),
    [
        (None, "cannot open"),
        ("dir", "cannot"),
        (b"", "empty"),
        (b"hello world\n" * 9, "not an MCAP"),
    ],
)
def test_recover_rejects_what_is_not_mcap(tmp_path: Path, content, match: str) -> None:
    src = tmp_path / "in.mcap"
    if content == "dir":
        src.mkdir()
    elif content is not None:
        src.write_bytes(content)
    with pytest.raises(InputError, match=match) as info:
        recover(src, tmp_path / "out.mcap")
    assert "\n" not in str(info.value)
    assert not (tmp_path / "out.mcap").exists()


@settings(max_examples=300, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture])  # fmt: skip
@given(garbage=st.one_of(st.binary(max_size=300), st.binary(max_size=300).map(MCAP_MAGIC.__add__)))
def test_recover_garbage_only_raises_input_error(
    tmp_path: Path, no_fsync: None, garbage: bytes
) -> None:
    src, dst = tmp_path / "g.bin", tmp_path / "g.mcap"
    src.write_bytes(garbage)
    try:
        result = recover(src, dst)
    except InputError:
        return
    assert result.messages == len(read_mcap(dst))


@settings(max_examples=300, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture])  # fmt: skip
@given(
    edits=st.lists(st.tuples(st.integers(0, 10**6), st.integers(0, 255)), min_size=1, max_size=4)
)
def test_recover_corrupted_bytes_never_crash(
    tmp_path: Path, small_recording: tuple[bytes, int], no_fsync: None, edits: list[tuple[int, int]]
) -> None:
    data, n = small_recording
    corrupt = bytearray(data)
    for pos, value in edits:
        corrupt[pos % len(corrupt)] = value
    src, dst = tmp_path / "c.mcap.part", tmp_path / "c.mcap"
    src.write_bytes(bytes(corrupt))
    try:
        result = recover(src, dst)
    except InputError:
        assert corrupt[:8] != MCAP_MAGIC
        return
    assert result.messages == len(read_mcap(dst)) <= n


def test_recover_directory_repairs_removes_and_is_idempotent(
    tmp_path: Path, small_recording: tuple[bytes, int], caplog: pytest.LogCaptureFixture
) -> None:
    data, n = small_recording
    rec_dir = tmp_path / "rec"
    rec_dir.mkdir()
    (rec_dir / "s_20261122T000000Z.mcap.part").write_bytes(data[: len(data) // 3])
    (rec_dir / "s_20261122T000100Z.mcap.part").write_bytes(b"")
    (rec_dir / "s_20261122T000200Z.mcap.part").write_bytes(MCAP_MAGIC[:5])
    (rec_dir / "s_20261122T000300Z.mcap.part").write_bytes(data[:60])  # header, no message
    (rec_dir / "s_20261122T000400Z.mcap.part").write_bytes(b"not mcap at all" * 10)
    (rec_dir / "s_20261122T000500Z.mcap").write_bytes(data)  # finished: not touched
    (rec_dir / "s_20261122T000600Z.mcap.tmp").write_bytes(b"half a repair")

    with caplog.at_level(logging.INFO, logger="daemon.recording.recorder"):
        results = recover_directory(rec_dir)
    assert [(r.src.name, r.dst.name if r.dst else None) for r in results] == [
        ("s_20261122T000000Z.mcap.part", "s_20261122T000000Z.mcap"),
        ("s_20261122T000100Z.mcap.part", None),
        ("s_20261122T000200Z.mcap.part", None),
        ("s_20261122T000300Z.mcap.part", None),
    ]
    assert 0 < results[0].messages < n and results[0].bytes_dropped > 0
    assert sorted(p.name for p in rec_dir.iterdir()) == [
        "s_20261122T000000Z.mcap",
        "s_20261122T000400Z.mcap.part",
        "s_20261122T000500Z.mcap",
    ]
    assert "left in place" in caplog.text
    before = {p.name: p.read_bytes() for p in rec_dir.iterdir()}
    assert recover_directory(rec_dir) == []
    assert {p.name: p.read_bytes() for p in rec_dir.iterdir()} == before
    assert recover_directory(tmp_path / "missing") == []


def test_recover_directory_after_a_crash_between_rename_and_unlink(
    tmp_path: Path, small_recording: tuple[bytes, int]
) -> None:
    data, _ = small_recording
    part = tmp_path / "s_20261122T000000Z.mcap.part"
    part.write_bytes(data[:-100])
    (first,) = recover_directory(tmp_path)
    repaired = (tmp_path / "s_20261122T000000Z.mcap").read_bytes()
    part.write_bytes(data[:-100])  # as if the .part had not been removed
    (second,) = recover_directory(tmp_path)
    assert second == first
    assert (tmp_path / "s_20261122T000000Z.mcap").read_bytes() == repaired
    assert not part.exists()
