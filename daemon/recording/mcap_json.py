"""The JSON messages of our MCAP files: Foxglove schemas and messages, encoding, decoding.

Every message is recorded as compact JSON (``message_encoding="json"``) with a JSON Schema
(``encoding="jsonschema"``). This module holds the two Foxglove message types the recorder
writes itself (``foxglove.CompressedImage`` thumbnails and ``foxglove.Log``), the encoder that
turns numpy values, bytes, paths and NaN into valid JSON, and the decoder factory for reading
the files back with ``mcap.reader``. Pure: no files, no state.
"""

from __future__ import annotations

import base64
import json
import logging
import math
import os
import traceback
from collections.abc import Callable
from typing import Any

import numpy as np
from mcap.decoder import DecoderFactory
from mcap.records import Schema

__all__ = [
    "FOXGLOVE_COMPRESSED_IMAGE_SCHEMA",
    "FOXGLOVE_LOG_SCHEMA",
    "JsonDecoderFactory",
    "compressed_image",
    "encode_json",
    "foxglove_log_level",
    "foxglove_time",
    "log_message",
]

_TIME_SCHEMA = {
    "type": "object",
    "title": "time",
    "properties": {
        "sec": {"type": "integer", "minimum": 0},
        "nsec": {"type": "integer", "minimum": 0, "maximum": 999_999_999},
    },
}

FOXGLOVE_COMPRESSED_IMAGE_SCHEMA: dict = {
    "title": "foxglove.CompressedImage",
    "description": "A compressed image",
    "type": "object",
    "properties": {
        "timestamp": {**_TIME_SCHEMA, "description": "Timestamp of image"},
        "frame_id": {"type": "string", "description": "Frame of reference for the image"},
        "data": {
            "type": "string",
            "contentEncoding": "base64",
            "description": "Compressed image data",
        },
        "format": {"type": "string", "description": "Image format: jpeg, png, webp or avif"},
    },
}

FOXGLOVE_LOG_SCHEMA: dict = {
    "title": "foxglove.Log",
    "description": "A log message",
    "type": "object",
    "properties": {
        "timestamp": {**_TIME_SCHEMA, "description": "Timestamp of log message"},
        "level": {
            "title": "foxglove.LogLevel",
            "description": "Log level",
            "oneOf": [
                {"title": title, "const": value}
                for value, title in enumerate(
                    ["UNKNOWN", "DEBUG", "INFO", "WARNING", "ERROR", "FATAL"]
                )
            ],
        },
        "message": {"type": "string", "description": "Log message"},
        "name": {"type": "string", "description": "Process or node name"},
        "file": {"type": "string", "description": "Filename"},
        "line": {"type": "integer", "minimum": 0, "description": "Line number in the file"},
    },
}


# --------------------------------------------------------------------------- message helpers


def foxglove_time(t_ns: int) -> dict:
    """``{"sec": int, "nsec": int}`` of a time in integer nanoseconds since the epoch."""
    sec, nsec = divmod(int(t_ns), 1_000_000_000)
    return {"sec": sec, "nsec": nsec}


def compressed_image(jpeg: bytes, *, t_ns: int, frame_id: str, image_format: str = "jpeg") -> dict:
    """A ``foxglove.CompressedImage`` message (JSON encoding: ``data`` is base64).

    Parameters
    ----------
    jpeg : bytes
        The encoded image.
    t_ns : int
        Capture time, nanoseconds since the Unix epoch.
    frame_id : str
        The camera's name.
    image_format : str
        ``"jpeg"`` unless the bytes are something else Foxglove decodes (``"png"``, ``"webp"``).
    """
    return {
        "timestamp": foxglove_time(t_ns),
        "frame_id": frame_id,
        "data": base64.b64encode(jpeg).decode("ascii"),
        "format": image_format,
    }


def foxglove_log_level(levelno: int) -> int:
    """Python logging level → ``foxglove.LogLevel`` (1 DEBUG … 5 FATAL)."""
    for foxglove_level, below in enumerate(
        (logging.INFO, logging.WARNING, logging.ERROR, logging.CRITICAL), start=1
    ):
        if levelno < below:
            return foxglove_level
    return 5


def log_message(record: logging.LogRecord) -> dict:
    """A ``foxglove.Log`` message from a log record (with its traceback, if any)."""
    try:
        text = record.getMessage()
    except (TypeError, ValueError):  # bad %-arguments: keep what we can
        text = f"{record.msg} {record.args}"
    if record.exc_info:
        text += "\n" + "".join(traceback.format_exception(*record.exc_info)).rstrip()
    return {
        "timestamp": foxglove_time(getattr(record, "created_ns", None) or record.created * 1e9),
        "level": foxglove_log_level(record.levelno),
        "message": text,
        "name": record.name,
        "file": record.pathname,
        "line": max(int(record.lineno or 0), 0),
    }


def _json_default(value: Any) -> Any:
    if isinstance(value, np.ndarray | np.generic):
        return value.tolist()
    if isinstance(value, bytes | bytearray | memoryview):
        return base64.b64encode(value).decode("ascii")
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    raise TypeError(f"{type(value).__name__} is not JSON serialisable")


def _finite(value: Any) -> Any:
    """``value`` with every NaN or infinity replaced by ``None`` (JSON has neither)."""
    if isinstance(value, float | np.floating):
        return float(value) if math.isfinite(value) else None
    if isinstance(value, np.ndarray):
        return _finite(value.tolist())
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_finite(v) for v in value]
    return value


_ENCODER = json.JSONEncoder(
    separators=(",", ":"), ensure_ascii=False, allow_nan=False, default=_json_default
)


def encode_json(message: Any) -> bytes:
    """Compact UTF-8 JSON of ``message``; numpy values become numbers, NaN/inf become ``null``.

    Raises ``TypeError`` for a value JSON cannot represent (a programming error).
    """
    try:
        return _ENCODER.encode(message).encode()
    except ValueError:  # a non-finite float somewhere: rare, so only then walk the message
        return _ENCODER.encode(_finite(message)).encode()


class JsonDecoderFactory(DecoderFactory):
    """Decodes ``json`` messages: ``make_reader(f, decoder_factories=[JsonDecoderFactory()])``."""

    def decoder_for(self, message_encoding: str, schema: Schema | None) -> Callable | None:
        """``json.loads`` for the ``json`` message encoding, else ``None``."""
        return json.loads if message_encoding == "json" else None
