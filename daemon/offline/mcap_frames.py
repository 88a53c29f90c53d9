"""Finding and reading the frames of MCAP recordings (``/hos/<cam>/frame``), in time order.

The one job of this module is to turn files and directories of logs into a stream of decoded
``hos.frame/1`` payloads (:func:`iter_frames`); :mod:`daemon.offline.series` aggregates them.

Files
    files or directories (searched recursively for ``*.mcap``; unfinished ``*.mcap.part`` files
    are not read), ordered by their first message time; files whose time ranges overlap are
    merged message by message. A damaged or unfinished file (no summary section) is skipped with
    a warning — ``weatherd recover`` repairs it; an error in the middle of a file stops that file
    (what was read is kept) with a warning.
"""

from __future__ import annotations

import heapq
import json
import logging
import os
import struct
import sys
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any

from mcap.exceptions import McapError
from mcap.reader import make_reader
from zstandard import ZstdError

from drivers.errors import InputError

__all__ = ["find_mcap_files", "iter_frames"]

log = logging.getLogger(__name__)

#: What a damaged file raises from the mcap reader: its own errors, short reads, a corrupt
#: zstd chunk (ZstdError), a corrupt lz4 chunk (RuntimeError), and a record length read from
#: garbage that the reader tries to allocate (MemoryError, OverflowError; found by
#: tests/test_fuzz_inputs.py).
_DAMAGED = (
    McapError,
    struct.error,
    ValueError,
    EOFError,
    RuntimeError,
    OSError,
    KeyError,
    ZstdError,
    MemoryError,
    OverflowError,
)


# ---------------------------------------------------------------------------------------------
# Reading


def find_mcap_files(paths: Iterable[str | os.PathLike[str]]) -> list[Path]:
    """Expand files and directories (recursively, ``*.mcap``) into a sorted, de-duplicated list.

    Raises
    ------
    InputError : a path does not exist, or no MCAP file is found.
    """
    found: dict[Path, None] = {}
    for raw in paths:
        path = Path(raw)
        if path.is_dir():
            for p in sorted(path.rglob("*.mcap")):
                if p.is_file():
                    found[p.resolve()] = None
        elif path.is_file():
            found[path.resolve()] = None
        else:
            raise InputError(f"{path}: no such file or directory")
    if not found:
        raise InputError(f"no *.mcap file in {', '.join(str(p) for p in paths)}")
    return list(found)


def iter_frames(
    paths: Iterable[str | os.PathLike[str]],
    *,
    camera: str | None = None,
    progress: bool | None = None,
    skipped: list[str] | None = None,
    opened: list[Path] | None = None,
) -> Iterator[dict[str, Any]]:
    """Stream the ``/hos/<cam>/frame`` payloads of MCAP files in time order.

    Parameters
    ----------
    paths : files or directories (see :func:`find_mcap_files`)
    camera : only this camera's frames; None: every camera
    progress : a progress bar over the files on stderr; None: only when stderr is a terminal
    skipped : if given, the paths of the damaged files skipped are appended to it
    opened : if given, the paths of the files read are appended to it

    Yields
    ------
    dict : the decoded ``hos.frame/1`` JSON object; ``t_ns`` is always set (from the message's
        log time when the payload has none). A payload that is not JSON is logged and skipped.

    Raises
    ------
    InputError : see :func:`find_mcap_files`.
    """
    files = find_mcap_files(paths)
    spans = []
    for path in files:
        span = _time_span(path)
        if span is None:
            log.warning(
                "%s: unfinished or damaged MCAP file, skipped (repair it with weatherd recover)",
                path,
            )
            if skipped is not None:
                skipped.append(str(path))
            continue
        spans.append((span, path))
    spans.sort(key=lambda item: (item[0][0], str(item[1])))
    bar = _progress_bar(len(spans), enabled=progress)
    try:
        for group in _overlapping(spans):
            if opened is not None:
                opened.extend(group)
            streams = [_file_frames(p, camera, rank) for rank, p in enumerate(group)]
            stream = streams[0] if len(streams) == 1 else heapq.merge(*streams)
            for *_, frame in stream:
                yield frame
            if bar is not None:
                bar.update(len(group))
    finally:
        if bar is not None:
            bar.close()


def _time_span(path: Path) -> tuple[int, int] | None:
    """(first, last) message log time of a finished file, ns; None when it cannot be read."""
    try:
        with open(path, "rb") as f:
            summary = make_reader(f).get_summary()
    except _DAMAGED:
        return None
    if summary is None:
        return None
    stats = summary.statistics
    if stats is None or stats.message_count == 0:
        return (0, 0)
    return (int(stats.message_start_time), int(stats.message_end_time))


def _overlapping(spans: list[tuple[tuple[int, int], Path]]) -> Iterator[list[Path]]:
    """Groups of files whose time ranges overlap (to be merged), in time order."""
    group: list[Path] = []
    group_end = -1
    for (start, end), path in spans:
        if group and start > group_end:
            yield group
            group, group_end = [], -1
        group.append(path)
        group_end = max(group_end, end)
    if group:
        yield group


def _file_frames(
    path: Path, camera: str | None, rank: int
) -> Iterator[tuple[int, int, int, dict[str, Any]]]:
    """(log time, rank, sequence, payload) of the frame messages of one file, in file order.

    ``rank`` and the sequence number break ties when files are merged; an error ends the file
    with a warning.
    """
    bad = 0
    try:
        with open(path, "rb") as f:
            reader = make_reader(f)
            summary = reader.get_summary()
            topics = sorted(
                {
                    ch.topic
                    for ch in (summary.channels.values() if summary else ())
                    if _is_frame_topic(ch.topic, camera)
                }
            )
            if not topics:
                return
            # file order: the daemon writes in time order, and the log-time heap of the mcap
            # reader costs a quarter of the reading time; aggregate() tolerates small jitter
            messages = reader.iter_messages(topics=topics, log_time_order=False)
            for seq, (_, _, message) in enumerate(messages):
                try:
                    payload = json.loads(message.data)
                except ValueError:
                    bad += 1
                    continue
                if not isinstance(payload, dict):
                    bad += 1
                    continue
                payload.setdefault("t_ns", message.log_time)
                yield int(message.log_time), rank, seq, payload
    except _DAMAGED as exc:
        log.warning("%s: damaged after some messages, rest of the file skipped (%s)", path, exc)
    if bad:
        log.warning("%s: %d frame messages are not JSON objects, skipped", path, bad)


def _is_frame_topic(topic: str, camera: str | None) -> bool:
    parts = topic.split("/")
    if len(parts) != 4 or parts[0] != "" or parts[1] != "hos" or parts[3] != "frame":
        return False
    return camera is None or parts[2] == camera


def _progress_bar(total: int, *, enabled: bool | None):
    if enabled is None:
        enabled = sys.stderr.isatty()
    if not enabled or total == 0:
        return None
    from tqdm import tqdm

    return tqdm(total=total, desc="MCAP files", unit="file", leave=False)
