"""Decode a raw capture (or a logger file) of an instrument's serial output into readings.

The core of ``weatherd instruments decode --driver NAME FILE``: the file is read as bytes
(raw captures hold control characters), fed to the driver's framer in chunks (so the
framer's handling of split reads is exercised on every file) and each frame is parsed. Bad
frames are collected in :class:`DecodeStats` with their line number, never fatal::

    stats = DecodeStats()
    for reading in decode_file(DRIVERS["vaisala-pwd"], "PW040406.DAT", stats=stats):
        print(json.dumps(reading.to_json()))
    for line, reason in stats.bad:
        print(f"line {line}: {reason}", file=sys.stderr)
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from typing import Any

from drivers.errors import InputError

from .base import DriverSpec, ParseError, Reading

__all__ = ["DecodeStats", "decode_chunks", "decode_file"]

#: Bytes fed to the framer at a time.
CHUNK_BYTES = 4096


@dataclass
class DecodeStats:
    """What a decode saw.

    Attributes
    ----------
    frames : frames cut from the file
    readings : frames that parsed
    bad : (line number, reason) of each frame that did not parse, in file order
    garbage_bytes : bytes outside any frame (noise, blank lines, control characters)
    """

    frames: int = 0
    readings: int = 0
    bad: list[tuple[int, str]] = field(default_factory=list)
    garbage_bytes: int = 0


def decode_chunks(
    spec: DriverSpec,
    chunks: Iterable[bytes],
    *,
    options: dict[str, Any] | None = None,
    stats: DecodeStats | None = None,
) -> Iterator[Reading]:
    """Readings from a byte stream given in chunks of any size.

    Parameters
    ----------
    spec : the driver
    chunks : the stream, split anywhere
    options : driver options, checked with ``spec.check_options`` (ConfigError if invalid)
    stats : filled in as the stream is read (complete once the iterator is exhausted)
    """
    opts = spec.check_options(dict(options or {}))
    stats = stats if stats is not None else DecodeStats()
    framer = spec.make_framer(opts)
    for chunk in chunks:
        for frame in framer.feed(chunk):
            reading = _parse(spec, frame, opts, stats)
            if reading is not None:
                yield reading
        stats.garbage_bytes = framer.garbage_bytes
    for frame in framer.flush():
        reading = _parse(spec, frame, opts, stats)
        if reading is not None:
            yield reading
    stats.garbage_bytes = framer.garbage_bytes


def decode_file(
    spec: DriverSpec,
    path: str | os.PathLike[str],
    *,
    options: dict[str, Any] | None = None,
    stats: DecodeStats | None = None,
    chunk_bytes: int = CHUNK_BYTES,
) -> Iterator[Reading]:
    """Readings of the file at ``path``, in file order.

    The options are checked and the file opened at once (before the first reading is
    asked for), so a missing file raises here.

    Raises
    ------
    InputError : the file cannot be opened.
    ConfigError : invalid options.
    """
    if chunk_bytes < 1:
        raise ValueError("chunk_bytes must be >= 1")
    opts = spec.check_options(dict(options or {}))
    try:
        f = open(path, "rb")  # closed by the generator below
    except OSError as exc:
        raise InputError(f"{path}: {exc.strerror or exc}") from None
    return _decode_open_file(spec, f, opts, stats, chunk_bytes)


def _decode_open_file(
    spec: DriverSpec, f: Any, opts: dict[str, Any], stats: DecodeStats | None, chunk_bytes: int
) -> Iterator[Reading]:
    with f:
        chunks = iter(lambda: f.read(chunk_bytes), b"")
        try:
            yield from decode_chunks(spec, chunks, options=opts, stats=stats)
        except OSError as exc:
            raise InputError(f"{f.name}: {exc.strerror or exc}") from None


def _parse(
    spec: DriverSpec, frame: Any, opts: dict[str, Any], stats: DecodeStats
) -> Reading | None:
    stats.frames += 1
    try:
        reading = spec.parse(frame, opts)
    except ParseError as exc:
        stats.bad.append((frame.line, str(exc) or "unreadable frame"))
        return None
    stats.readings += 1
    return reading
