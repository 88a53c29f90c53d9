"""The recording directory on disk: file names, creating files, listing them, free space.

Recordings are named ``<site>_<UTC start>[-<seq>].mcap`` (``.mcap.part`` while written).
:func:`_recordings` lists a directory's recordings with their size and age order for the disk
budget. ``_open_stream`` and ``_free_bytes`` are the seams the tests replace (on
``daemon.recording.recorder``, which uses them) to simulate a full disk.
"""

from __future__ import annotations

import os
import re
import shutil
from contextlib import suppress
from dataclasses import dataclass
from pathlib import Path
from typing import BinaryIO

_SITE_RE = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]*")
_NAME_RE = re.compile(
    r"(?P<site>.+)_(?P<start>\d{8}T\d{6}Z)(?:-(?P<seq>\d+))?\.mcap(?P<part>\.part)?"
)


def _open_stream(path: Path) -> BinaryIO:
    """Create ``path`` for writing (a seam for the tests' full-disk simulation)."""
    return open(path, "xb")  # closed by the Recorder


def _fsync_directory(directory: Path) -> None:
    """Make a rename in ``directory`` durable (best effort)."""
    with suppress(OSError):
        fd = os.open(directory, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


def _free_bytes(directory: Path) -> int:
    """Bytes free to unprivileged users on the filesystem of ``directory``."""
    return shutil.disk_usage(directory).free


@dataclass(frozen=True)
class _Recording:
    path: Path
    size: int
    site: str | None
    order: tuple[str, int]  # (UTC start, sequence): oldest first
    finished: bool


def _recordings(directory: Path) -> list[_Recording]:
    """Every ``*.mcap`` and ``*.mcap.part`` in ``directory`` (names not ours have no site)."""
    found = []
    with suppress(FileNotFoundError), os.scandir(directory) as entries:
        for entry in entries:
            if not entry.name.endswith((".mcap", ".mcap.part")):
                continue
            try:
                size = entry.stat(follow_symlinks=False).st_size
            except OSError:
                continue
            m = _NAME_RE.fullmatch(entry.name)
            found.append(
                _Recording(
                    path=Path(entry.path),
                    size=size,
                    site=m["site"] if m else None,
                    order=(m["start"], int(m["seq"] or 0)) if m else ("", 0),
                    finished=entry.name.endswith(".mcap"),
                )
            )
    return found
