"""Looking at the daemon from the outside: ``weatherd watch`` and ``weatherd get``.

Users can follow a site's messages without the Rust ``zenoh`` tool. Each sample becomes one
JSON line ``{"key": ..., "payload": ...}``: the payload parsed when it is JSON (the daemon
always sends JSON), its text otherwise. Liveliness events, when asked for, are lines
``{"key": "weather/<site>/alive", "alive": true|false}``.

The session config comes from :func:`daemon.transport.publisher.zenoh_config`. Note that a ``peer``
with no ``connect`` endpoint and multicast scouting off (our default) sees nobody: give the
router or the daemon's listen endpoint with ``connect``.
"""

from __future__ import annotations

import json
import logging
import queue
import sys
import threading
import time
from typing import Any, TextIO

import zenoh

from daemon.transport.publisher import zenoh_error_text
from drivers.errors import ConfigError, SourceError

__all__ = ["get", "sample_line", "watch"]

log = logging.getLogger(__name__)

_POLL_S = 0.1


def sample_line(key: str, payload: bytes) -> dict:
    """The JSON line for one sample: ``{"key": key, "payload": parsed JSON or text}``."""
    text = payload.decode("utf-8", "replace")
    try:
        value: Any = json.loads(text)
    except ValueError:
        value = text
    return {"key": key, "payload": value}


def _open(config: zenoh.Config) -> zenoh.Session:
    try:
        return zenoh.open(config)
    except zenoh.ZError as exc:
        raise SourceError(f"zenoh: cannot open a session: {zenoh_error_text(exc)}") from exc


def watch(
    keyexpr: str,
    config: zenoh.Config,
    *,
    out: TextIO = sys.stdout,
    count: int | None = None,
    timeout_s: float | None = None,
    stop_event: threading.Event | None = None,
    liveliness: bool = False,
) -> int:
    """Subscribe to ``keyexpr`` and print one JSON line per sample on ``out``.

    Parameters
    ----------
    keyexpr : str
        What to follow, e.g. ``weather/**`` or ``weather/site-001/state``.
    config : zenoh.Config
        Session configuration.
    out : text stream
        Where lines go; flushed after each line.
    count : int, optional
        Stop after this many lines.
    timeout_s : float, optional
        Stop after this long, seconds.
    stop_event : threading.Event, optional
        Stop when set (the CLI sets it from SIGTERM; Ctrl-C also ends the watch).
    liveliness : bool
        Also print liveliness tokens appearing and vanishing under ``keyexpr``
        (tokens already present are printed at start).

    Returns
    -------
    int
        Exit status for the command line: 0 (failures raise). The lines printed are counted
        in the log at debug level.

    Raises
    ------
    ConfigError
        If ``keyexpr`` is not a valid key expression.
    SourceError
        If the session cannot be opened (in client mode: the router is unreachable).
    """
    try:
        zenoh.KeyExpr(keyexpr)
    except zenoh.ZError as exc:
        raise ConfigError(f"keyexpr {keyexpr!r}: {zenoh_error_text(exc)}") from exc
    lines: queue.SimpleQueue[dict] = queue.SimpleQueue()
    deadline = None if timeout_s is None else time.monotonic() + timeout_s
    printed = 0
    session = _open(config)
    try:
        session.declare_subscriber(
            keyexpr, lambda s: lines.put(sample_line(str(s.key_expr), s.payload.to_bytes()))
        )
        if liveliness:
            session.liveliness().declare_subscriber(
                keyexpr,
                lambda s: lines.put(
                    {"key": str(s.key_expr), "alive": s.kind == zenoh.SampleKind.PUT}
                ),
                history=True,
            )
        while count is None or printed < count:
            if stop_event is not None and stop_event.is_set():
                break
            wait_s = _POLL_S
            if deadline is not None:
                wait_s = min(wait_s, deadline - time.monotonic())
                if wait_s <= 0:
                    break
            try:
                line = lines.get(timeout=wait_s)
            except queue.Empty:
                continue
            out.write(json.dumps(line, ensure_ascii=False, separators=(",", ":")) + "\n")
            out.flush()
            printed += 1
    except KeyboardInterrupt:
        log.debug("watch interrupted")
    finally:
        session.close()
    log.debug("watch %s: %d line(s) printed", keyexpr, printed)
    return 0


def get(keyexpr: str, config: zenoh.Config, *, timeout_s: float = 5.0) -> list[dict]:
    """Query ``keyexpr`` (a selector) and return the replies as :func:`sample_line` dicts.

    Against the daemon, ``weather/<site>/**`` returns the latest value of each of the site's
    keys. Error replies become ``{"key": None, "error": text}``.

    Parameters
    ----------
    keyexpr : str
        Selector, e.g. ``weather/*/state``.
    config : zenoh.Config
        Session configuration.
    timeout_s : float
        How long to wait for replies, seconds.

    Raises
    ------
    ConfigError
        If ``keyexpr`` is not a valid selector.
    SourceError
        If the session cannot be opened.
    """
    session = _open(config)
    try:
        try:
            replies = session.get(keyexpr, timeout=timeout_s)
        except zenoh.ZError as exc:
            raise ConfigError(f"selector {keyexpr!r}: {zenoh_error_text(exc)}") from exc
        out = []
        for reply in replies:
            sample = reply.ok
            if sample is not None:
                out.append(sample_line(str(sample.key_expr), sample.payload.to_bytes()))
            else:
                err = reply.err.payload.to_bytes().decode("utf-8", "replace")
                out.append({"key": None, "error": err})
        return out
    finally:
        session.close()
