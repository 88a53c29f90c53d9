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

__all__ = ["endpoints_of", "get", "human_line", "sample_line", "watch"]

log = logging.getLogger(__name__)

_POLL_S = 0.1
#: After this long without a peer or router, ``watch`` says so on stderr (and keeps waiting).
UNREACHABLE_NOTICE_S = 3.0
#: After this long connected with no sample, ``watch`` says nothing was published.
SILENT_NOTICE_S = 10.0


def sample_line(key: str, payload: bytes) -> dict:
    """The JSON line for one sample: ``{"key": key, "payload": parsed JSON or text}``."""
    text = payload.decode("utf-8", "replace")
    try:
        value: Any = json.loads(text)
    except ValueError:
        value = text
    return {"key": key, "payload": value}


def endpoints_of(config: zenoh.Config) -> list[str]:
    """The ``connect/endpoints`` of a session config (empty when there are none)."""
    try:
        value = json.loads(config.get_json("connect/endpoints"))
    except (zenoh.ZError, ValueError):
        return []
    return [str(v) for v in value] if isinstance(value, list) else []


def _reachable(session: zenoh.Session) -> bool:
    """True when the session has a router or a peer to talk to."""
    info = session.info
    return bool(list(info.routers_zid()) or list(info.peers_zid()))


class _Notices:
    """What ``watch`` says on stderr while it waits: that nobody is reachable (after
    :data:`UNREACHABLE_NOTICE_S`), that someone became reachable after that, and that nothing
    was published (after :data:`SILENT_NOTICE_S` connected); each once."""

    def __init__(self, session: zenoh.Session, keyexpr: str, endpoints: list[str], err: TextIO):
        self.session, self.keyexpr, self.err = session, keyexpr, err
        self.where = " or ".join(endpoints) if endpoints else "(no connect endpoint)"
        self.start = time.monotonic()
        self.next_check = self.start + 1.0
        self.connected_at: float | None = None
        self.warned_unreachable = self.warned_silent = False

    def check(self, *, printed: int) -> None:
        now = time.monotonic()
        if now < self.next_check:
            return
        self.next_check = now + 1.0
        if self.connected_at is None:
            if _reachable(self.session):
                self.connected_at = now
                if self.warned_unreachable:
                    self._say(f"reached a Zenoh peer or router at {self.where}")
            elif not self.warned_unreachable and now - self.start >= UNREACHABLE_NOTICE_S:
                self.warned_unreachable = True
                self._say(
                    f"no Zenoh peer or router reachable at {self.where} (is the daemon running? "
                    "another endpoint: --connect); still waiting"
                )
        elif not printed and not self.warned_silent and now - self.connected_at >= SILENT_NOTICE_S:
            self.warned_silent = True
            self._say(
                f"connected, but nothing published on {self.keyexpr} in "
                f"{SILENT_NOTICE_S:.0f} s (is the site name right? 'weatherd get "
                '"weather/**"\' lists every key); still waiting'
            )

    def _say(self, text: str) -> None:
        self.err.write(f"weatherd: {text}\n")
        self.err.flush()


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
    human: bool = False,
    err: TextIO = sys.stderr,
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
    human : bool
        One short line per sample (:func:`human_line`) instead of the JSON line.
    err : text stream
        Where the notices go while nothing arrives: no peer or router reachable after
        :data:`UNREACHABLE_NOTICE_S`, nothing published after :data:`SILENT_NOTICE_S`.

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
    notices = _Notices(session, keyexpr, endpoints_of(config), err)
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
                notices.check(printed=printed)
                continue
            text = (
                human_line(line)
                if human
                else json.dumps(line, ensure_ascii=False, separators=(",", ":"))
            )
            out.write(text + "\n")
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


# ---------------------------------------------------------------------------------------------
# The human view: one short line per sample


def human_line(line: dict) -> str:
    """A short line for a person: ``HH:MM:SSZ key  what it says``.

    The site state: precipitation and type, rate and its source (or why it is unknown),
    intensity, wawa, and each camera's state, verdict and R. A camera summary: its state,
    verdict, Π, μ, R, fps. Health: uptime and each camera's capture. An instrument reading:
    its non-null values. A liveliness event: alive or gone. Anything else: compact JSON, cut.
    """
    key = line.get("key") or "?"
    if "alive" in line:
        return f"{_clock(None)} {key}  {'alive' if line['alive'] else 'gone'}"
    if "error" in line:
        return f"{_clock(None)} {key}  error: {line['error']}"
    payload = line.get("payload")
    if not isinstance(payload, dict):
        return f"{_clock(None)} {key}  {_cut(str(payload))}"
    kind = str(payload.get("schema", "")).partition("/")[0]
    describe = _DESCRIBE.get(kind)
    text = describe(payload) if describe else _cut(json.dumps(payload, separators=(",", ":")))
    return f"{_clock(payload.get('t'))} {key}  {text}"


def _clock(t: object) -> str:
    if isinstance(t, str) and "T" in t:
        return t.partition("T")[2][:8] + "Z"
    return time.strftime("%H:%M:%SZ", time.gmtime())


def _cut(text: str, n: int = 120) -> str:
    return text if len(text) <= n else text[: n - 1] + "…"


def _num(value: object, fmt: str = ".3g") -> str:
    return "-" if not isinstance(value, int | float) else format(value, fmt)


def _state(p: dict) -> str:
    pr = p.get("precipitation")
    words = ["precipitation " + {True: "yes", False: "no", None: "unknown"}.get(pr, str(pr))]
    if p.get("precipitation_type"):
        words[0] += f" ({p['precipitation_type']})"
    if p.get("rain_rate_mm_h") is not None:
        rate = f"rate {_num(p['rain_rate_mm_h'])} mm/h"
        if p.get("rain_rate_source"):
            rate += f" ({p['rain_rate_source']})"
        words.append(rate)
    elif pr:
        words.append("rate unknown")
    for field in ("intensity_class", "metar"):
        if p.get(field):
            words.append(str(p[field]))
    if p.get("wawa") is not None:
        words.append(f"wawa {p['wawa']}")
    if p.get("camera_R") is not None:
        words.append(f"camera_R {_num(p['camera_R'], '.0f')}")
    cams = [
        f"{cam} {c.get('state')}"
        + {True: " " + _seen(c.get("camera_precipitation_type")), False: " dry"}.get(
            c.get("rain"), ""
        )
        + (f" R {_num(c.get('R'), '.0f')}" if c.get("R") is not None else "")
        for cam, c in (p.get("cameras") or {}).items()
        if isinstance(c, dict)
    ]
    text = ", ".join(words)
    if cams:
        text += " | " + "; ".join(cams)
    if pr is None and p.get("reason"):
        text += f" | {p['reason']}"
    return text


def _seen(kind: object) -> str:
    """What a camera that sees precipitation says of it: rain, snow, or just precipitation."""
    return kind if kind in ("rain", "snow") else "precipitation"


def _camera(p: dict) -> str:
    seen = _seen(p.get("camera_precipitation_type"))
    verdict = {True: seen, False: "dry"}.get(p.get("rain"), "?")
    return (
        f"{p.get('state')} {verdict}, Π {_num(p.get('pi_smoothed'), '.2f')}, "
        f"μ {_num(p.get('mu_smoothed_deg'), '.0f')}°, R {_num(p.get('R'), '.0f')} "
        f"(mean {_num(p.get('R_mean'), '.0f')}), {_num(p.get('fps'), '.1f')} fps"
    )


def _status(p: dict) -> str:
    parts = [f"up {_num(p.get('uptime_s'), '.0f')} s"]
    for cam, c in (p.get("cameras") or {}).items():
        if isinstance(c, dict):
            parts.append(
                f"{cam} {c.get('capture_state')} {_num(c.get('fps'), '.1f')} fps, "
                f"{c.get('frames_dropped', 0)} dropped"
            )
    rec = p.get("recorder") or {}
    if rec.get("file"):
        parts.append(f"recording {rec['file']}")
    return "; ".join(parts)


_META = {"schema", "site", "t", "t_ns", "instrument", "driver"}


def _reading(p: dict) -> str:
    values = [f"{k} {v}" for k, v in p.items() if k not in _META and v is not None]
    return _cut(", ".join(values) or "no value")


_DESCRIBE = {
    "weather.state": _state,
    "weather.camera": _camera,
    "weather.status": _status,
    "instrument.reading": _reading,
}
