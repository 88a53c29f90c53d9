"""Writing one MCAP file the way the daemon does, and the MCAP format facts shared with repair.

The format constants (magic, library name, what a corrupt record can raise), the choice of
compression with its fallback, the registration of a JSON channel with its JSON Schema once per
file, and :class:`McapFile`: one file written from start to finish for offline tools. The
rotating, budgeted recorder of the daemon is :class:`daemon.recording.recorder.Recorder`.
"""

from __future__ import annotations

import json
import logging
import os
import struct
from pathlib import Path
from typing import Any

import mcap.writer
from mcap.exceptions import McapError
from mcap.writer import CompressionType, Writer

from .mcap_json import encode_json

__all__ = ["LIBRARY", "MCAP_MAGIC", "McapFile"]

log = logging.getLogger(__name__)

MCAP_MAGIC = b"\x89MCAP0\r\n"
LIBRARY = "hos-weatherd"
# A chunk claiming more than this when decompressed is taken for corruption (ours are ~chunk_size).
_MAX_CHUNK_BYTES = 256 * 2**20
# What a corrupt record can raise while it is parsed (lz4 raises RuntimeError): stop there.
_CORRUPT: tuple[type[Exception], ...] = (
    McapError,
    struct.error,
    ValueError,
    EOFError,
    RuntimeError,
    OverflowError,
    *((mcap.writer.zstandard.ZstdError,) if mcap.writer.zstandard is not None else ()),
)


def _compression(name: str) -> CompressionType:
    """The mcap compression for ``name``, falling back to lz4 then none when not installed."""
    wanted = name.lower() or "none"
    if wanted not in ("zstd", "lz4", "none"):
        raise ValueError(f"compression: expected zstd, lz4 or none, got {name!r}")
    available = {
        "zstd": mcap.writer.zstandard is not None,
        "lz4": mcap.writer.lz4 is not None,
        "none": True,
    }
    chosen = next(c for c in (wanted, "lz4", "none") if available[c])
    if chosen != wanted:
        log.warning("compression %s is not installed; recording with %s", wanted, chosen)
    return {"zstd": CompressionType.ZSTD, "lz4": CompressionType.LZ4}.get(
        chosen, CompressionType.NONE
    )


def _channel_id(
    writer: Writer,
    schema_ids: dict[tuple[str, bytes], int],
    channel_ids: dict[tuple[str, str], int],
    topic: str,
    schema_name: str,
    schema: dict,
) -> int:
    """The channel of ``(topic, schema_name)`` in this file, registered (with its JSON Schema)
    on first use; the ``schema`` dict is only serialised then."""
    key = (topic, schema_name)
    channel_id = channel_ids.get(key)
    if channel_id is None:
        schema_data = json.dumps(schema, sort_keys=True, separators=(",", ":")).encode()
        schema_id = schema_ids.get((schema_name, schema_data))
        if schema_id is None:
            schema_id = writer.register_schema(schema_name, "jsonschema", schema_data)
            schema_ids[(schema_name, schema_data)] = schema_id
        channel_id = writer.register_channel(topic, "json", schema_id)
        channel_ids[key] = channel_id
    return channel_id


class McapFile:
    """One MCAP file written from start to finish, for offline tools (``weatherd replay``).

    Same messages as :class:`Recorder` (JSON with JSON Schemas) but no rotation, budget or
    timers, and errors raise. Written as ``<path>.part`` and renamed to ``path`` by
    :meth:`close` (also on leaving the ``with`` block, even on an exception: what was written
    is kept).
    """

    def __init__(
        self, path: str | os.PathLike, *, chunk_size: int = 2**20, compression: str = "zstd"
    ) -> None:
        self.path = Path(path)
        self._part = self.path.with_name(self.path.name + ".part")
        self._stream = open(self._part, "wb")  # closed by close()
        self._writer = Writer(
            self._stream, chunk_size=chunk_size, compression=_compression(compression)
        )
        self._writer.start(profile="", library=LIBRARY)
        self._schema_ids: dict[tuple[str, bytes], int] = {}
        self._channel_ids: dict[tuple[str, str], int] = {}
        self._closed = False
        self.messages = 0

    def write(self, topic: str, schema_name: str, schema: dict, message: Any, *, t_ns: int) -> bool:
        """Like :meth:`Recorder.write`, but an ``OSError`` raises; always returns ``True``."""
        if self._closed:
            raise ValueError(f"{self.path}: write after close")
        channel_id = _channel_id(
            self._writer, self._schema_ids, self._channel_ids, topic, schema_name, schema
        )
        data = encode_json(message)
        self._writer.add_message(channel_id, log_time=int(t_ns), data=data, publish_time=int(t_ns))
        self.messages += 1
        return True

    def close(self) -> None:
        """Finish the file and rename it into place. Idempotent."""
        if self._closed:
            return
        self._closed = True
        try:
            self._writer.finish()
            self._stream.flush()
            os.fsync(self._stream.fileno())
        finally:
            self._stream.close()
        os.replace(self._part, self.path)

    def __enter__(self) -> McapFile:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()
