"""MCAP recording that survives power cuts, full disks and months of uptime; and its repair.

The daemon records every message as JSON (``message_encoding="json"``) with a JSON Schema
(``encoding="jsonschema"``) so that Foxglove opens the files as they are.

Files
    ``<site>_<UTC start>.mcap`` in the recording directory (``demo_20261122T123456Z.mcap``; a
    ``-1``, ``-2`` … suffix when two files start within the same second). While a file is being
    written it is named ``….mcap.part``; it is renamed to ``….mcap`` once it is finished, so a
    reader globbing ``*.mcap`` only ever sees finished files. Every file stands alone: schemas
    and channels are registered again in each new file.
Rotation
    by age (``rotate_s``, on the injected clock) and by size (``rotate_bytes``; a file may
    overshoot by at most one chunk).
Disk budget
    after each rotation and every ``budget_interval_s``, the oldest finished files of this site
    are deleted while the recordings of the directory (all ``*.mcap`` and ``*.mcap.part``)
    exceed ``budget_bytes`` or the filesystem has less than ``min_free_bytes`` free. The file
    being written is never deleted.
Full disk
    an ``OSError`` while writing never leaves :meth:`Recorder.write`: the current file is
    abandoned as a ``.part`` (repaired in the background as soon as recording resumes, else at
    the next start-up, by :mod:`.mcap_repair`; or deleted first by the budget), messages are
    dropped and counted, a new file is tried every ``retry_interval_s`` after a budget
    cleanup, and one log line marks each end of the episode.
Crash safety
    ``mcap.writer.Writer`` keeps the open chunk in memory. Every ``flush_interval_s`` the chunk is
    finished and the file object flushed to the OS (``Writer.flush``, public since mcap 1.6,
    pinned by a test), and every ``fsync_interval_s`` the file is ``fsync``-ed, so a ``kill -9``
    loses at most about ``flush_interval_s`` of messages and a power cut ``fsync_interval_s``.
Repair
    :mod:`.mcap_repair`: ``recover`` copies every complete record of an unfinished or
    truncated file into a properly finished one; ``recover_directory`` does so for each
    ``*.mcap.part`` at start-up.
Modules
    this one holds :class:`Recorder` (rotation, disk budget, flush and ``fsync`` timers,
    full-disk episodes) and :class:`RecorderLogHandler`; :mod:`.mcap_json` the messages
    and their JSON encoding, :mod:`.mcap_file` the MCAP format facts and
    :class:`McapFile`, :mod:`daemon.recording.recording_files` the recording directory. Their public
    names are importable from here as before.
"""

from __future__ import annotations

import logging
import os
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager, suppress
from datetime import UTC, datetime
from pathlib import Path
from typing import Any, BinaryIO

from mcap.writer import Writer

# Re-exported: daemon.recording.mcap_repair imports the format facts from here.
from .mcap_file import _CORRUPT as _CORRUPT
from .mcap_file import _MAX_CHUNK_BYTES as _MAX_CHUNK_BYTES
from .mcap_file import LIBRARY, McapFile, _channel_id, _compression
from .mcap_file import MCAP_MAGIC as MCAP_MAGIC
from .mcap_json import (
    FOXGLOVE_COMPRESSED_IMAGE_SCHEMA,
    FOXGLOVE_LOG_SCHEMA,
    JsonDecoderFactory,
    compressed_image,
    encode_json,
    log_message,
)

# Looked up here by the Recorder, so that the tests can replace them on daemon.recording.recorder.
from .mcap_repair import recover_directory
from .recording_files import _SITE_RE, _free_bytes, _fsync_directory, _open_stream, _recordings

__all__ = [
    "FOXGLOVE_COMPRESSED_IMAGE_SCHEMA",
    "FOXGLOVE_LOG_SCHEMA",
    "JsonDecoderFactory",
    "McapFile",
    "Recorder",
    "RecorderLogHandler",
    "compressed_image",
    "encode_json",
    "log_message",
]

log = logging.getLogger(__name__)


def _due(now_ns: int, last_ns: int, interval_ns: int) -> bool:
    """Whether ``interval_ns`` has passed since ``last_ns`` (or the clock stepped back)."""
    return now_ns - last_ns >= interval_ns or now_ns < last_ns


# --------------------------------------------------------------------------- recorder


class Recorder:
    """Thread-safe MCAP recorder with rotation, a disk budget, bounded crash loss.

    Parameters
    ----------
    directory : path
        Recording directory, created if needed. Unfinished files of an earlier run are not
        touched: run ``daemon.recording.mcap_repair.recover_directory`` first.
    site : str
        Site name, the files' prefix (letters, digits, ``.``, ``_`` and ``-``).
    rotate_s, rotate_bytes : float, int
        Start a new file when the current one is this old (seconds, on ``clock``) or this big.
    budget_bytes, min_free_bytes : int
        Disk budget for all recordings of the directory, and free space to keep.
    flush_interval_s, fsync_interval_s : float
        How often the open chunk is written out and the file ``fsync``-ed (seconds).
    chunk_size : int
        Uncompressed bytes after which the mcap writer finishes a chunk on its own.
    compression : str
        ``"zstd"``, ``"lz4"`` or ``"none"``; falls back to what is installed, with a warning.
    clock : callable
        Integer nanoseconds since the epoch: names files and drives every interval.
    budget_interval_s, retry_interval_s : float
        How often the budget is enforced, and a new file is tried after a disk error (seconds).
    """

    def __init__(
        self,
        directory: str | os.PathLike,
        *,
        site: str,
        rotate_s: float = 3600.0,
        rotate_bytes: int = 256 * 2**20,
        budget_bytes: int = 4 * 2**30,
        min_free_bytes: int = 512 * 2**20,
        flush_interval_s: float = 1.0,
        fsync_interval_s: float = 5.0,
        chunk_size: int = 256 * 1024,
        compression: str = "zstd",
        clock: Callable[[], int] = time.time_ns,
        budget_interval_s: float = 5.0,
        retry_interval_s: float = 1.0,
    ) -> None:
        if not _SITE_RE.fullmatch(site):
            raise ValueError(f"site: expected letters, digits, '.', '_' or '-', got {site!r}")
        for name, value in [
            ("rotate_s", rotate_s),
            ("rotate_bytes", rotate_bytes),
            ("flush_interval_s", flush_interval_s),
            ("fsync_interval_s", fsync_interval_s),
            ("chunk_size", chunk_size),
            ("budget_interval_s", budget_interval_s),
            ("retry_interval_s", retry_interval_s),
        ]:
            if not value > 0:
                raise ValueError(f"{name}: must be > 0, got {value!r}")
        self.directory = Path(directory)
        self.directory.mkdir(parents=True, exist_ok=True)
        self.site = site
        self.rotate_ns = round(rotate_s * 1e9)
        self.rotate_bytes = int(rotate_bytes)
        self.budget_bytes = int(budget_bytes)
        self.min_free_bytes = int(min_free_bytes)
        self.flush_ns = round(flush_interval_s * 1e9)
        self.fsync_ns = round(fsync_interval_s * 1e9)
        self.budget_ns = round(budget_interval_s * 1e9)
        self.retry_ns = round(retry_interval_s * 1e9)
        self.chunk_size = int(chunk_size)
        self.compression = _compression(compression)
        self._clock = clock

        self._lock = threading.Lock()
        self._budget_lock = threading.Lock()
        self._logs: list[tuple[int, str, tuple]] = []  # emitted once the lock is released
        # the file being written
        self._path: Path | None = None
        self._stream: BinaryIO | None = None
        self._writer: Writer | None = None
        self._schema_ids: dict[tuple[str, bytes], int] = {}
        self._channel_ids: dict[tuple[str, str], int] = {}
        self._file_start_ns = 0
        self._file_messages = 0
        self._unflushed = 0  # messages of this file that may still be in memory only
        self._last_flush_ns = self._last_fsync_ns = 0
        # the recorder
        self._last_budget_ns = clock()
        self._budget_due = False
        self._budget_short = False
        self._repair_due = False
        self._repair_thread: threading.Thread | None = None
        self._failing = False
        self._last_retry_ns = 0
        self._abandoned: list[Path] = []
        self._closed = False
        self._messages = self._dropped = self._files_deleted = self._files_repaired = 0

    # ----------------------------------------------------------------- public API

    def write(self, topic: str, schema_name: str, schema: dict, message: Any, *, t_ns: int) -> bool:
        """Record ``message`` on ``topic`` at ``t_ns`` (log and publish time, ns since epoch).

        The schema of a ``(topic, schema_name)`` pair is taken from its first use in each file.
        Returns ``False`` when the message was dropped (disk error, or recorder closed); never
        raises ``OSError``. ``TypeError`` for a message JSON cannot encode.
        """
        data = encode_json(message)
        with self._locked():
            now = self._clock()
            ok = self._write_locked(topic, schema_name, schema, data, int(t_ns), now)
            fsync_fd, budget = self._maintenance_locked(now)
            ok = ok and self._writer is not None  # else lost (and counted) with its chunk
        self._maintain(fsync_fd, budget)
        return ok

    def flush(self) -> None:
        """Write the open chunk out now; rotate, ``fsync`` and enforce the budget when due."""
        with self._locked():
            now = self._clock()
            if self._writer is not None:
                try:
                    if self._rotation_due(now):
                        self._finish()
                    else:
                        self._flush_locked(now)
                except OSError as exc:
                    self._fail(exc, now)
            fsync_fd, budget = self._maintenance_locked(now)
        self._maintain(fsync_fd, budget)

    def close(self) -> None:
        """Finish the current file (``.part`` → ``.mcap``). Idempotent; later writes are dropped."""
        with self._locked():
            if self._closed:
                return
            self._closed = True
            if self._writer is not None:
                try:
                    self._finish()
                except OSError as exc:
                    self._fail(exc, self._clock())
        if self._repair_thread is not None:  # no thread of ours outlives the recorder
            self._repair_thread.join()

    def stats(self) -> dict:
        """Counters for the health report.

        ``file`` (the ``.part`` being written or ``None``), ``file_bytes``, ``messages`` (written),
        ``dropped``, ``files_deleted``, ``files_repaired`` (abandoned after a write error, then
        repaired once recording resumed), ``free_bytes`` (filesystem), ``total_bytes`` (recordings
        of the directory).
        """
        with self._locked():
            file_bytes = 0
            if self._stream is not None:
                with suppress(OSError, ValueError):
                    file_bytes = self._stream.tell()
            stats = {
                "file": str(self._path) if self._path else None,
                "file_bytes": file_bytes,
                "messages": self._messages,
                "dropped": self._dropped,
                "files_deleted": self._files_deleted,
                "files_repaired": self._files_repaired,
            }
        try:
            stats["free_bytes"] = _free_bytes(self.directory)
        except OSError:
            stats["free_bytes"] = 0
        stats["total_bytes"] = sum(r.size for r in _recordings(self.directory))
        return stats

    def __enter__(self) -> Recorder:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    # ----------------------------------------------------------------- under the lock

    @contextmanager
    def _locked(self) -> Iterator[None]:
        """Hold the lock; log what was logged under it only after releasing it.

        A log handler that records into this recorder then never deadlocks on the lock.
        """
        try:
            with self._lock:
                yield
        finally:
            logs, self._logs = self._logs, []
            for level, msg, args in logs:
                log.log(level, msg, *args)

    def _log(self, level: int, msg: str, *args: object) -> None:
        self._logs.append((level, msg, args))

    def _write_locked(
        self, topic: str, schema_name: str, schema: dict, data: bytes, t_ns: int, now: int
    ) -> bool:
        if self._closed:
            self._dropped += 1
            return False
        try:
            if self._writer is None:
                if self._failing:
                    if not _due(now, self._last_retry_ns, self.retry_ns):
                        self._dropped += 1
                        return False
                    self._last_retry_ns = now  # the budget ran after the failure (_fail)
                self._open(now)
            elif self._rotation_due(now):
                self._finish()
                self._open(now)
            writer, stream = self._writer, self._stream
            channel_id = _channel_id(
                writer, self._schema_ids, self._channel_ids, topic, schema_name, schema
            )
            before = stream.tell()
            writer.add_message(channel_id, log_time=t_ns, data=data, publish_time=t_ns)
            self._unflushed = 0 if stream.tell() != before else self._unflushed + 1
        except OSError as exc:
            self._fail(exc, now)
            self._dropped += 1
            return False
        self._messages += 1
        self._file_messages += 1
        if self._failing:
            self._failing = False
            self._repair_due = True  # the files abandoned in the episode, now there is room
            self._log(
                logging.WARNING,
                "recording resumed in %s (%d messages dropped so far)",
                self._path,
                self._dropped,
            )
        return True

    def _rotation_due(self, now: int) -> bool:
        if now < self._file_start_ns:  # the clock stepped back: count the age from now
            self._file_start_ns = now
        return now - self._file_start_ns >= self.rotate_ns or (
            self._stream.tell() >= self.rotate_bytes
        )

    def _new_path(self, now: int) -> Path:
        start = datetime.fromtimestamp(now // 1_000_000_000, UTC).strftime("%Y%m%dT%H%M%SZ")
        for seq in range(10_000):
            stem = f"{self.site}_{start}" + (f"-{seq}" if seq else "")
            final = self.directory / f"{stem}.mcap"
            part = self.directory / f"{stem}.mcap.part"
            if not final.exists() and not part.exists():
                return part
        raise FileExistsError(f"{self.directory}: no free name for {self.site}_{start}")

    def _open(self, now: int) -> None:
        """Start a new ``.part`` file: magic and header on disk before the first message."""
        self.directory.mkdir(parents=True, exist_ok=True)
        path = self._new_path(now)
        stream = _open_stream(path)
        try:
            writer = Writer(stream, chunk_size=self.chunk_size, compression=self.compression)
            writer.start(profile="", library=LIBRARY)
            stream.flush()
        except OSError:
            with suppress(OSError, ValueError):
                stream.close()
            with suppress(OSError):
                path.unlink()
            raise
        self._path, self._stream, self._writer = path, stream, writer
        self._schema_ids.clear()
        self._channel_ids.clear()
        self._file_start_ns = self._last_flush_ns = self._last_fsync_ns = now
        self._file_messages = self._unflushed = 0
        self._log(logging.INFO, "recording to %s", path)

    def _flush_locked(self, now: int) -> None:
        self._writer.flush()
        self._unflushed = 0
        self._last_flush_ns = now

    def _finish(self) -> None:
        """Finish, ``fsync`` and close the current file, then rename ``.part`` → ``.mcap``."""
        path, stream, writer = self._path, self._stream, self._writer
        writer.finish()
        stream.flush()
        os.fsync(stream.fileno())
        stream.close()
        self._path = self._stream = self._writer = None
        final = path.with_suffix("")  # drop ".part"
        try:
            os.replace(path, final)
        except OSError:
            self._abandoned.append(path)
            raise
        _fsync_directory(self.directory)
        self._budget_due = True
        self._log(logging.INFO, "finished %s (%d messages)", final, self._file_messages)

    def _fail(self, exc: OSError, now: int) -> None:
        """Abandon the current file after a write error; start or continue an episode."""
        if self._writer is not None:
            self._dropped += self._unflushed
            with suppress(OSError, ValueError):
                self._stream.close()
            self._abandoned.append(self._path)
            self._path = self._stream = self._writer = None
        if not self._failing:
            self._failing = True
            self._log(
                logging.ERROR,
                "recording stopped: %s; dropping messages, retrying every %.1f s",
                exc,
                self.retry_ns / 1e9,
            )
        self._last_retry_ns = now
        self._budget_due = True

    def _maintenance_locked(self, now: int) -> tuple[int | None, bool]:
        """Flush when due; return a duplicated fd to ``fsync`` and whether to run the budget."""
        fsync_fd = None
        if self._writer is not None:
            try:
                if _due(now, self._last_flush_ns, self.flush_ns):
                    self._flush_locked(now)
                if _due(now, self._last_fsync_ns, self.fsync_ns):
                    self._last_fsync_ns = now
                    fsync_fd = os.dup(self._stream.fileno())
            except OSError as exc:
                self._fail(exc, now)
        budget = self._budget_due or _due(now, self._last_budget_ns, self.budget_ns)
        if budget:
            self._budget_due = False
            self._last_budget_ns = now
        return fsync_fd, budget

    # ----------------------------------------------------------------- outside the lock

    def _maintain(self, fsync_fd: int | None, budget: bool) -> None:
        """``fsync`` (on a duplicated descriptor) and enforce the budget, without the lock."""
        if fsync_fd is not None:
            try:
                os.fsync(fsync_fd)
            except OSError as exc:
                log.warning("fsync of the recording failed: %s", exc)
            finally:
                os.close(fsync_fd)
        if budget:
            with self._lock:
                current, abandoned = self._path, set(self._abandoned)
            self._enforce_budget(current, abandoned)
        self._start_repair()

    def _start_repair(self) -> None:
        """Once recording has resumed after a failure, repair the files it abandoned, in a
        thread of its own (a large file takes a while: about 5 MB/s), one repair at a time."""
        with self._lock:
            running = self._repair_thread is not None and self._repair_thread.is_alive()
            if not self._repair_due or self._failing or self._closed or running:
                return
            self._repair_due = False
            parts = [p for p in self._abandoned if p.exists()]
            if not parts:
                return
            self._repair_thread = threading.Thread(
                target=self._repair, args=(parts,), name="mcap repair (resumed)"
            )
            self._repair_thread.start()

    def _repair(self, parts: list[Path]) -> None:
        results = recover_directory(self.directory, parts=parts)  # logs each file
        with self._lock:
            self._abandoned = [p for p in self._abandoned if p.exists()]
            self._files_repaired += sum(r.dst is not None for r in results)

    def _enforce_budget(self, current: Path | None, abandoned: set[Path]) -> None:
        """Delete this site's oldest finished (or abandoned) files until the budget holds.

        Safe without the recorder lock: the file being written is a ``.part`` and only
        finished files and files this recorder abandoned are candidates.
        """
        if not self._budget_lock.acquire(blocking=False):
            return  # another thread is at it
        try:
            files = _recordings(self.directory)
            total = sum(r.size for r in files)
            try:
                free = _free_bytes(self.directory)
            except OSError:
                free = self.min_free_bytes
            candidates = sorted(
                (
                    r
                    for r in files
                    if r.site == self.site
                    and r.path != current
                    and (r.finished or r.path in abandoned)
                ),
                key=lambda r: r.order,
            )
            deleted = 0
            while (total > self.budget_bytes or free < self.min_free_bytes) and candidates:
                oldest = candidates.pop(0)
                try:
                    oldest.path.unlink()
                except FileNotFoundError:
                    continue
                except OSError as exc:
                    log.warning("cannot delete %s to free space: %s", oldest.path, exc)
                    continue
                total -= oldest.size
                free += oldest.size
                deleted += 1
                log.info(
                    "deleted %s (%d bytes) for the disk budget: recordings now %d bytes "
                    "(budget %d), %d bytes free (minimum %d)",
                    oldest.path,
                    oldest.size,
                    total,
                    self.budget_bytes,
                    free,
                    self.min_free_bytes,
                )
            short = total > self.budget_bytes or free < self.min_free_bytes
            if short and not self._budget_short:
                log.warning(
                    "disk budget not met and nothing left to delete: recordings %d bytes "
                    "(budget %d), %d bytes free (minimum %d)",
                    total,
                    self.budget_bytes,
                    free,
                    self.min_free_bytes,
                )
            with self._lock:
                self._budget_short = short
                self._files_deleted += deleted
                self._abandoned = [p for p in self._abandoned if p.exists()]
        finally:
            self._budget_lock.release()


class RecorderLogHandler(logging.Handler):
    """A logging handler that records each log record as ``foxglove.Log`` on ``topic``."""

    def __init__(self, recorder: Recorder, *, topic: str = "/log", level: int = logging.INFO):
        super().__init__(level)
        self.recorder = recorder
        self.topic = topic
        self._local = threading.local()

    def emit(self, record: logging.LogRecord) -> None:
        """Write ``record``; a record logged while doing so (same thread) is not recorded."""
        if getattr(self._local, "busy", False):
            return
        self._local.busy = True
        try:
            message = log_message(record)
            t_ns = message["timestamp"]["sec"] * 1_000_000_000 + message["timestamp"]["nsec"]
            self.recorder.write(self.topic, "foxglove.Log", FOXGLOVE_LOG_SCHEMA, message, t_ns=t_ns)
        except Exception:
            self.handleError(record)
        finally:
            self._local.busy = False
