"""Repair of MCAP files that a crash, a power cut or a full disk left unfinished.

:func:`recover` copies every complete schema, channel and message of an unfinished or truncated
file into a properly finished one, stopping at the first incomplete or corrupt record (each
record's length is checked against the file's size and each chunk's CRC is verified, so garbage
cannot trigger huge reads). It writes a temporary file and renames it into place, so it can run
twice or in place. :func:`recover_directory` does so for every ``*.mcap.part`` of a recording
directory at the daemon's start-up: a ``.part`` with no complete message is removed, one that is
not MCAP at all is logged and left alone.
"""

from __future__ import annotations

import errno
import io
import itertools
import logging
import os
import struct
from collections.abc import Iterable, Iterator
from contextlib import suppress
from dataclasses import dataclass, replace
from pathlib import Path
from typing import BinaryIO

from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.records import Channel, Chunk, Footer, Header, McapRecord, Message, Schema
from mcap.stream_reader import breakup_chunk
from mcap.writer import Writer

from drivers.errors import InputError

from .mcap_file import _CORRUPT, _MAX_CHUNK_BYTES, LIBRARY, MCAP_MAGIC, _compression

__all__ = ["RecoverResult", "recover", "recover_directory"]

log = logging.getLogger(__name__)

#: Why an output file cannot be created that is the user's to fix (not the disk's).
_CANNOT_CREATE = frozenset({errno.ENOENT, errno.ENOTDIR, errno.EISDIR, errno.EACCES, errno.EPERM})


@dataclass(frozen=True)
class RecoverResult:
    """What :func:`recover` salvaged.

    ``dst`` is ``None`` when nothing was written (``recover_directory`` removed an empty file).
    Times are log times in ns since the epoch (``None`` without messages); ``bytes_kept`` +
    ``bytes_dropped`` is the size of ``src``; ``complete`` says ``src`` was a finished file.
    """

    src: Path
    dst: Path | None
    messages: int
    channels: int
    schemas: int
    first_log_time_ns: int | None
    last_log_time_ns: int | None
    bytes_kept: int
    bytes_dropped: int
    complete: bool


class _Scan:
    """Progress of :func:`_complete_records` over one file."""

    def __init__(self) -> None:
        self.end = len(MCAP_MAGIC)  # end of the last complete record
        self.complete = False


def _parse(opcode: int, body: bytes) -> list[McapRecord]:
    """The records of one complete top-level record body (a chunk gives its contents)."""
    stream = ReadDataStream(io.BytesIO(body))
    if opcode == Opcode.CHUNK:
        chunk = Chunk.read(stream)
        if chunk.uncompressed_size > _MAX_CHUNK_BYTES:
            raise ValueError("implausible chunk size")
        return breakup_chunk(chunk, validate_crc=True)
    if opcode == Opcode.MESSAGE:
        if len(body) < 22:
            raise ValueError("short message record")
        return [Message.read(stream, len(body))]
    readers = {
        Opcode.HEADER: Header.read,
        Opcode.SCHEMA: Schema.read,
        Opcode.CHANNEL: Channel.read,
        Opcode.FOOTER: Footer.read,
    }
    return [readers[opcode](stream)] if opcode in readers else []


def _complete_records(f: BinaryIO, size: int, scan: _Scan) -> Iterator[McapRecord]:
    """Each complete record after the magic, chunks opened; stops at the first bad one.

    Every record is read whole (its length checked against the file size first) and parsed
    from memory, so a corrupt length can neither allocate without bound nor read past it.
    """
    while True:
        prefix = f.read(9)
        if len(prefix) < 9:
            return
        opcode, length = struct.unpack("<BQ", prefix)
        if opcode == 0 or length > size - scan.end - 9:
            return
        body = f.read(length)
        if len(body) < length:
            return
        try:
            records = _parse(opcode, body)
        except _CORRUPT:
            return
        scan.end += 9 + length
        yield from records
        if opcode == Opcode.FOOTER:
            scan.complete = f.read(len(MCAP_MAGIC)) == MCAP_MAGIC
            if scan.complete:
                scan.end += len(MCAP_MAGIC)
            return


def recover(
    src: str | os.PathLike, dst: str | os.PathLike, *, compression: str = "zstd"
) -> RecoverResult:
    """Copy every complete schema, channel and message of ``src`` into a finished MCAP ``dst``.

    ``src`` may be unfinished (no summary or footer), truncated anywhere, or have garbage after
    the last good record: reading stops cleanly at the first incomplete or corrupt record.
    ``dst`` is written to a temporary file and renamed, so it is either absent or finished; it
    may be ``src`` itself. Running it twice gives the same result.

    Raises
    ------
    InputError
        ``src`` cannot be read or does not start with the MCAP magic (empty included); ``dst``
        is not a regular file (a directory, a device: it would be replaced) or cannot be
        created (no such folder, no permission).
    OSError
        ``dst`` cannot be written: the disk is full, an I/O error (the file name is given).
    """
    src, dst = Path(src), Path(dst)
    if dst.exists() and not dst.is_file():
        raise InputError(f"{dst}: not a regular file (give the name of the MCAP file to write)")
    try:
        f = open(src, "rb")  # closed by the with below
    except OSError as exc:
        raise InputError(f"{src}: cannot open: {exc.strerror or exc}") from None
    with f:
        try:
            size = os.fstat(f.fileno()).st_size
            magic = f.read(len(MCAP_MAGIC))
        except OSError as exc:
            raise InputError(f"{src}: cannot read: {exc.strerror or exc}") from None
        if magic != MCAP_MAGIC:
            what = "empty" if not magic else "no MCAP magic at the start"
            raise InputError(f"{src}: not an MCAP file ({what})")
        scan = _Scan()
        tmp = dst.with_name(dst.name + ".tmp")
        try:
            counts = _copy_records(_complete_records(f, size, scan), tmp, compression)
            os.replace(tmp, dst)
        except OSError as exc:
            with suppress(OSError):
                tmp.unlink()
            if exc.errno in _CANNOT_CREATE:
                raise InputError(f"{dst}: cannot write ({exc.strerror})") from None
            if exc.filename is None and exc.errno is not None:  # a full disk names the file
                raise OSError(exc.errno, exc.strerror or os.strerror(exc.errno), str(dst)) from None
            raise
        except BaseException:
            with suppress(OSError):
                tmp.unlink()
            raise
    return RecoverResult(
        src,
        dst,
        *counts,
        bytes_kept=scan.end,
        bytes_dropped=size - scan.end,
        complete=scan.complete,
    )


def _copy_records(
    records: Iterator[McapRecord], out_path: Path, compression: str
) -> tuple[int, int, int, int | None, int | None]:
    """Write ``records`` (ids renumbered, repeats ignored) to a finished MCAP at ``out_path``.

    Returns the numbers of messages, channels and schemas, and the first and last log times.
    """
    schema_ids: dict[int, int] = {}
    channel_ids: dict[int, int] = {}
    messages, first, last = 0, None, None
    with open(out_path, "wb") as out:
        writer = Writer(out, compression=_compression(compression))
        first_record = next(records, None)
        profile = first_record.profile if isinstance(first_record, Header) else ""
        writer.start(profile=profile, library=LIBRARY)
        head = [first_record] if first_record is not None else []
        for record in itertools.chain(head, records):
            if isinstance(record, Schema) and record.id not in schema_ids:
                schema_ids[record.id] = writer.register_schema(
                    record.name, record.encoding, record.data
                )
            elif isinstance(record, Channel) and record.id not in channel_ids:
                if record.schema_id != 0 and record.schema_id not in schema_ids:
                    continue  # its schema was lost: its messages cannot be decoded
                channel_ids[record.id] = writer.register_channel(
                    record.topic,
                    record.message_encoding,
                    schema_ids.get(record.schema_id, 0),
                    record.metadata,
                )
            elif isinstance(record, Message) and record.channel_id in channel_ids:
                writer.add_message(
                    channel_ids[record.channel_id],
                    log_time=record.log_time,
                    data=record.data,
                    publish_time=record.publish_time,
                    sequence=record.sequence,
                )
                messages += 1
                first = record.log_time if first is None else min(first, record.log_time)
                last = record.log_time if last is None else max(last, record.log_time)
        writer.finish()
        out.flush()
        os.fsync(out.fileno())
    return messages, len(channel_ids), len(schema_ids), first, last


def recover_directory(
    directory: str | os.PathLike, *, parts: Iterable[Path] | None = None
) -> list[RecoverResult]:
    """Repair each ``*.mcap.part`` of ``directory`` into its ``*.mcap`` and remove the ``.part``.

    ``parts`` limits the repair to these files: a caller that repairs in the background while
    a new recording starts lists the unfinished files first, so that the file being written now
    is never taken for a crashed one. A ``.part`` without a complete message (empty, header
    only, cut inside the magic) is just removed. One that is not MCAP at all is logged and left
    in place. Safe to run twice, and after a crash in the middle of a run. Never raises for a
    bad or unwritable file: it is logged and skipped. Returns one result per ``.part`` handled
    (``dst`` ``None`` if removed).
    """
    directory = Path(directory)
    results: list[RecoverResult] = []
    if not directory.is_dir():
        return results
    for stale in directory.glob("*.mcap.tmp"):  # a repair cut short by a crash
        with suppress(OSError):
            stale.unlink()
            log.info("removed %s, left over from an interrupted repair", stale)
    for part in sorted(directory.glob("*.mcap.part") if parts is None else parts):
        dst = part.with_suffix("")
        try:
            if part.stat().st_size < len(MCAP_MAGIC) and MCAP_MAGIC.startswith(part.read_bytes()):
                part.unlink()
                log.info("removed %s: cut before the end of the MCAP magic", part)
                results.append(_empty_result(part))
                continue
            result = recover(part, dst)
            if result.messages == 0:
                dst.unlink()
                part.unlink()
                log.info("removed %s: no complete message", part)
                results.append(replace(result, dst=None))
                continue
            part.unlink()
        except InputError as exc:
            log.warning("cannot repair %s, left in place: %s", part, exc)
            continue
        except OSError as exc:
            log.warning("cannot repair %s now, will retry at the next start: %s", part, exc)
            continue
        log.info(
            "repaired %s -> %s: %d messages, %d bytes dropped at the tail",
            part,
            dst.name,
            result.messages,
            result.bytes_dropped,
        )
        results.append(result)
    return results


def _empty_result(src: Path) -> RecoverResult:
    return RecoverResult(
        src=src,
        dst=None,
        messages=0,
        channels=0,
        schemas=0,
        first_log_time_ns=None,
        last_log_time_ns=None,
        bytes_kept=0,
        bytes_dropped=0,
        complete=False,
    )
