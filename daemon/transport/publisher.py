"""Publishing the weather over Eclipse Zenoh (key space: ``docs/`` and DESIGN.md, a contract).

Every message of a site goes to ``weather/<site>/<suffix>`` as compact JSON with the encoding
``application/json``: ``state``, ``camera/<cam>/hos``, ``instrument/<id>``, ``status``. While
the session is open the site also holds the liveliness token ``weather/<site>/alive`` and a
queryable on ``weather/<site>/**`` that answers with the latest payload of each key, so a
fusion service that starts late can ``get`` the current state at once.

The network may be down when the daemon starts: :meth:`ZenohPublisher.start` returns at once
and a background thread opens the session, retrying with a bounded exponential backoff. What
is put meanwhile is not sent but is cached, and the queryable serves it once the session is
open. Once open, zenoh itself reconnects to a router that restarts (checked on 1.10.2, a
client finds its router again within its ``connect/retry`` period, 1 to 4 s by default) and
re-declares the token and the queryable.

Facts checked on eclipse-zenoh 1.10.2 that shape this module:

- ``mode: "client"`` with its router down: ``zenoh.open`` raises ``ZError`` at once, whatever
  ``connect/timeout_ms`` and ``connect/exit_on_failure`` say, hence the retry thread.
- ``mode: "peer"`` with ``connect`` endpoints down: ``zenoh.open`` returns after
  ``scouting/delay`` and keeps connecting by itself (defaults ``connect/timeout_ms: -1`` and
  ``connect/exit_on_failure: false`` for peers), about 1 s after the remote side appears.
- ``zenoh.open`` and ``Session.close`` release the GIL; a query callback runs on a zenoh
  thread. No lock of this module is held while zenoh is called, so ``close`` cannot deadlock
  against a callback.
"""

from __future__ import annotations

import json
import logging
import random
import re
import threading
from collections.abc import Sequence
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

import zenoh

from drivers.errors import ConfigError

__all__ = [
    "MemoryPublisher",
    "Publisher",
    "ZenohPublisher",
    "encode_message",
    "site_key",
    "zenoh_config",
    "zenoh_error_text",
]

log = logging.getLogger(__name__)

KEY_ROOT = "weather"
"""First chunk of every key (contract)."""

_MODES = ("peer", "client", "router")
_CHUNK = re.compile(r"[A-Za-z0-9_.~+\-]+")
_ZENOH_LOCATION = re.compile(r"\s+at\s+\S+\.rs:\d+\.?")
_JSON5_MSG = re.compile(r'msg: "((?:[^"\\]|\\.)*)"')


@runtime_checkable
class Publisher(Protocol):
    """Where the daemon sends its messages: :class:`ZenohPublisher` or :class:`MemoryPublisher`."""

    def put(self, suffix: str, message: dict) -> None:
        """Publish ``message`` on ``weather/<site>/<suffix>``; never raises."""

    def close(self) -> None:
        """Release every resource; idempotent."""


def site_key(site: str, suffix: str | None = None) -> str:
    """Return ``weather/<site>`` or ``weather/<site>/<suffix>``, checking both parts.

    Parameters
    ----------
    site : str
        One key chunk: letters, digits and ``_ . ~ + -`` (no ``/``, no wildcard).
    suffix : str, optional
        One or more such chunks separated by ``/`` (``camera/cam0/hos``).

    Raises
    ------
    ValueError
        If either part is empty, holds a wildcard, ``$``, ``#``, ``?`` or an empty chunk.
    """
    if not _CHUNK.fullmatch(site or ""):
        raise ValueError(f"site {site!r}: expected one key chunk of [A-Za-z0-9_.~+-]")
    if suffix is None:
        return f"{KEY_ROOT}/{site}"
    if not suffix or not all(_CHUNK.fullmatch(chunk) for chunk in suffix.split("/")):
        raise ValueError(f"key suffix {suffix!r}: expected chunks of [A-Za-z0-9_.~+-] split by /")
    return f"{KEY_ROOT}/{site}/{suffix}"


def encode_message(message: dict) -> bytes:
    """Serialise ``message`` once: compact UTF-8 JSON, NaN and infinities refused.

    Raises
    ------
    TypeError, ValueError
        If ``message`` is not a dict or holds something JSON cannot represent.
    """
    if not isinstance(message, dict):
        raise TypeError(f"message must be a dict, not {type(message).__name__}")
    text = json.dumps(message, separators=(",", ":"), allow_nan=False, ensure_ascii=False)
    return text.encode("utf-8")


def zenoh_error_text(exc: BaseException) -> str:
    """One readable line from a ``ZError``: the serde message if any, no Rust source path."""
    text = str(exc)
    found = _JSON5_MSG.search(text)
    if found:
        text = found.group(1)
    text = _ZENOH_LOCATION.sub("", text)
    return " ".join(text.split()) or type(exc).__name__


def zenoh_config(
    *,
    mode: str | None = None,
    connect: Sequence[str] = (),
    listen: Sequence[str] = (),
    config_file: str | None = None,
    shared_memory: bool | None = False,
) -> zenoh.Config:
    """Build the session configuration from the daemon's ``[zenoh]`` settings.

    ``config_file`` (a full Zenoh JSON5/JSON/YAML config: TLS, user/password, access control)
    is loaded first; ``mode`` (when given) and non-empty ``connect``/``listen`` override it.

    Two defaults differ from zenoh's, both for a site that talks to remote routers:

    - Multicast scouting is off unless the file sets ``scouting/multicast/enabled`` itself: a
      roadside daemon should join the network its operator wrote down, not whatever answers
      on the cabinet's LAN segment (another site's peer, a laptop), and multicast is often
      filtered on operator networks anyway, where it only adds traffic.
    - Shared memory (``transport/shared_memory/enabled``, on by default in zenoh 1.10) is off:
      it only helps processes on one host, and each session offering it takes a counter on
      the router; a router on 1.10.2 refused new sessions after about 350 of them ("No
      available SHM counters"; docs/scale.md). ``shared_memory=None`` keeps the file's value.

    Parameters
    ----------
    mode : {"peer", "client", "router"}, optional
        Zenoh mode; overrides the file's. When None: the file's mode, else ``"peer"``.
    connect, listen : sequence of str
        Endpoints such as ``tcp/10.0.0.1:7447`` or ``tls/router.example:7447``.
    config_file : str, optional
        Path to a Zenoh configuration file (``.json5``, ``.json`` or ``.yaml``).
    shared_memory : bool or None
        Force ``transport/shared_memory/enabled``; None leaves the file's (or zenoh's) value.

    Returns
    -------
    zenoh.Config

    Raises
    ------
    ConfigError
        If the file is missing or invalid, the mode unknown, or an endpoint malformed; the
        message starts with the offending key (``zenoh.connect: ...``).
    """
    if mode is not None and mode not in _MODES:
        raise ConfigError(f"zenoh.mode: expected one of {', '.join(_MODES)}, got {mode!r}")
    if config_file is not None:
        path = Path(config_file)
        if not path.is_file():
            raise ConfigError(f"zenoh.config_file: no such file: {config_file}")
        try:
            config = zenoh.Config.from_file(str(path))
        except zenoh.ZError as exc:
            raise ConfigError(f"zenoh.config_file: {config_file}: {zenoh_error_text(exc)}") from exc
    else:
        config = zenoh.Config()
    if mode is None and config_file is None:
        mode = "peer"
    settings: list[tuple[str, str, Any]] = []
    if mode is not None:
        settings.append(("zenoh.mode", "mode", mode))
    if connect:
        settings.append(("zenoh.connect", "connect/endpoints", [str(e) for e in connect]))
    if listen:
        settings.append(("zenoh.listen", "listen/endpoints", [str(e) for e in listen]))
    if config.get_json("scouting/multicast/enabled") in (None, "null"):
        settings.append(("zenoh.scouting", "scouting/multicast/enabled", False))
    if shared_memory is not None:
        settings.append(("zenoh.shared_memory", "transport/shared_memory/enabled", shared_memory))
    for name, key, value in settings:
        try:
            config.insert_json5(key, json.dumps(value))
        except zenoh.ZError as exc:
            raise ConfigError(f"{name}: {zenoh_error_text(exc)}") from exc
    return config


class ZenohPublisher:
    """Publish one site's messages over Zenoh; survives a network that is down or comes late.

    Parameters
    ----------
    site : str
        The site name, one key chunk (``site-001``).
    config : zenoh.Config
        Session configuration, usually from :func:`zenoh_config`.
    retry_initial_s, retry_max_s : float
        First and largest wait between two failed ``zenoh.open``, seconds; the wait doubles
        (with up to 20 % jitter downward, so many sites do not retry in step).

    Raises
    ------
    ConfigError
        If ``site`` is not a valid key chunk or the retry bounds are not positive.
    """

    def __init__(
        self,
        site: str,
        config: zenoh.Config,
        *,
        retry_initial_s: float = 0.5,
        retry_max_s: float = 30.0,
    ) -> None:
        try:
            self._prefix = site_key(site)
        except ValueError as exc:
            raise ConfigError(f"site: {exc}") from exc
        if not 0 < retry_initial_s <= retry_max_s:
            raise ConfigError("zenoh.retry: expected 0 < retry_initial_s <= retry_max_s")
        self.site = site
        self._config = config
        self._retry_initial_s = float(retry_initial_s)
        self._retry_max_s = float(retry_max_s)
        self._encoding = zenoh.Encoding.APPLICATION_JSON
        # _lock guards the session handles and counters, _cache_lock the latest payloads
        # (taken by the query callback). Neither is held while zenoh is called.
        self._lock = threading.RLock()
        self._cache_lock = threading.Lock()
        self._cache: dict[str, bytes] = {}
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._session: zenoh.Session | None = None
        self._token: zenoh.LivelinessToken | None = None
        self._queryable: zenoh.Queryable | None = None
        self._queryable_end: _CallbackEnd | None = None
        self._closed = False
        self._zid: str | None = None
        self._last_error: str | None = None
        self._counts = dict.fromkeys(
            ("puts", "put_errors", "unsent", "opens", "open_attempts", "queries"), 0
        )

    # -- life cycle -----------------------------------------------------------------------

    def start(self) -> None:
        """Start opening the session in a background thread; returns at once. Idempotent."""
        with self._lock:
            if self._closed or self._thread is not None:
                return
            self._thread = threading.Thread(
                target=self._open_loop, name=f"zenoh-open-{self.site}", daemon=True
            )
            self._thread.start()

    def close(self, *, join_timeout_s: float = 5.0) -> None:
        """Undeclare the token and the queryable, close the session, stop the retry thread.

        Idempotent and safe from any thread (the lock is re-entrant, so a signal handler may
        call it). If the open thread is stuck inside ``zenoh.open`` past ``join_timeout_s``,
        it closes whatever session it gets as soon as it returns.
        """
        with self._lock:
            if self._closed:
                return
            self._closed = True
            self._stop.set()
            thread = self._thread
            session, token, queryable = self._session, self._token, self._queryable
            end = self._queryable_end
            self._session = self._token = self._queryable = self._queryable_end = None
        if thread is not None and thread is not threading.current_thread():
            thread.join(join_timeout_s)
        if session is not None:
            _teardown(session, token, queryable, end)
            log.info("zenoh session of site %s closed", self.site)

    def __enter__(self) -> ZenohPublisher:
        self.start()
        return self

    def __exit__(self, *_exc: object) -> None:
        self.close()

    # -- publishing -----------------------------------------------------------------------

    def put(self, suffix: str, message: dict) -> None:
        """Publish ``message`` on ``weather/<site>/<suffix>``, JSON ``application/json``.

        The payload is serialised once and cached as the latest value of its key (served by
        the queryable). When no session is open yet the message is counted as ``unsent``.
        Never raises; an invalid suffix or message is logged and counted in ``put_errors``.
        """
        try:
            key = site_key(self.site, suffix)
            payload = encode_message(message)
        except (TypeError, ValueError) as exc:
            self._count_error(f"put {suffix!r}: {exc}")
            return
        with self._cache_lock:
            self._cache[key] = payload
        with self._lock:
            session = self._session
            if session is None:
                self._counts["unsent"] += 1
                return
        try:
            session.put(key, payload, encoding=self._encoding)
        except Exception as exc:  # a closed or broken session must not reach the caller
            self._count_error(f"put {key}: {zenoh_error_text(exc)}")
            return
        with self._lock:
            self._counts["puts"] += 1

    def latest(self) -> dict[str, bytes]:
        """Return a copy of the cached latest payload of each key put so far."""
        with self._cache_lock:
            return dict(self._cache)

    # -- state ----------------------------------------------------------------------------

    @property
    def session_open(self) -> bool:
        """True while a session is open (it may still have no router or peer)."""
        with self._lock:
            return self._session is not None

    @property
    def connected(self) -> bool:
        """True while the session is open and reaches at least one router or peer."""
        with self._lock:
            session = self._session
        if session is None:
            return False
        try:
            info = session.info
            return bool(info.routers_zid() or info.peers_zid())
        except Exception:  # closed under our feet
            return False

    def stats(self) -> dict:
        """Counters and state for the ``status`` message.

        Returns
        -------
        dict
            ``session_open``, ``connected`` (bool); ``puts`` (sent), ``put_errors``,
            ``unsent`` (put while no session was open), ``opens``, ``open_attempts``,
            ``queries`` (answered), int; ``last_error`` and ``zid``, str or None.
        """
        connected = self.connected
        with self._lock:
            return {
                "session_open": self._session is not None,
                "connected": connected,
                **self._counts,
                "last_error": self._last_error,
                "zid": self._zid,
            }

    # -- internals ------------------------------------------------------------------------

    def _count_error(self, text: str) -> None:
        with self._lock:
            self._counts["put_errors"] += 1
            first = self._last_error != text
            self._last_error = text
        if first:
            log.warning("zenoh: %s", text)

    def _open_loop(self) -> None:
        """Open the session, retrying with bounded exponential backoff until done or closed."""
        delay_s = self._retry_initial_s
        last_text = None
        while not self._stop.is_set():
            with self._lock:
                self._counts["open_attempts"] += 1
            try:
                session = zenoh.open(self._config)
            except Exception as exc:
                text = zenoh_error_text(exc)
                with self._lock:
                    self._last_error = f"open: {text}"
                if text != last_text:
                    log.warning(
                        "zenoh open failed (retrying, at most every %g s): %s",
                        self._retry_max_s,
                        text,
                    )
                    last_text = text
                if self._stop.wait(delay_s * random.uniform(0.8, 1.0)):
                    return
                delay_s = min(2.0 * delay_s, self._retry_max_s)
                continue
            if self._install(session):
                return
            if self._stop.wait(delay_s):
                return

    def _install(self, session: zenoh.Session) -> bool:
        """Declare the token and the queryable on a fresh session; True when the loop is done."""
        token = queryable = None
        end = _CallbackEnd()
        try:
            token = session.liveliness().declare_token(f"{self._prefix}/alive")
            queryable = session.declare_queryable(
                f"{self._prefix}/**", zenoh.handlers.Callback(self._on_query, end)
            )
            zid = str(session.zid())
        except Exception as exc:
            text = zenoh_error_text(exc)
            log.warning("zenoh declarations failed, reopening: %s", text)
            with self._lock:
                self._last_error = f"declare: {text}"
            _teardown(session, token, queryable, end)
            return False
        with self._lock:
            if not self._closed:
                self._session, self._token, self._queryable = session, token, queryable
                self._queryable_end = end
                self._zid = zid
                self._counts["opens"] += 1
                session = None
        if session is not None:  # close() came while we were opening
            _teardown(session, token, queryable, end)
            return True
        log.info("zenoh session %s open for site %s", zid, self.site)
        return True

    def _on_query(self, query: zenoh.Query) -> None:
        """Reply with the cached payload of every key the query's key expression intersects."""
        try:
            wanted = query.key_expr
            with self._cache_lock:
                items = list(self._cache.items())
            for key, payload in items:
                if wanted.intersects(key):
                    query.reply(key, payload, encoding=self._encoding)
            with self._lock:
                self._counts["queries"] += 1
        except Exception as exc:  # a callback must not raise into zenoh
            log.warning("zenoh query on %s failed: %s", self._prefix, zenoh_error_text(exc))
        finally:
            query.drop()


class _CallbackEnd:
    """The drop of a Zenoh callback handler: zenoh-python runs a Python callback on a thread of
    its own ("pyo3-closure") and calls the drop there last, after the undeclaration returned.
    :meth:`join` waits for that thread to end, so that a stopping daemon leaves no thread of
    Zenoh's running Python code while the process exits."""

    def __init__(self) -> None:
        self._dropped = threading.Event()
        self._thread: threading.Thread | None = None

    def __call__(self) -> None:
        self._thread = threading.current_thread()
        self._dropped.set()

    def join(self, timeout_s: float) -> None:
        """Wait up to ``timeout_s`` for the drop, then as long again for its thread."""
        if not self._dropped.wait(timeout_s):
            log.debug("zenoh callback not dropped within %g s", timeout_s)
            return
        thread = self._thread
        if thread is not None and thread is not threading.current_thread():
            thread.join(timeout_s)


def _teardown(
    session: zenoh.Session,
    token: zenoh.LivelinessToken | None,
    queryable: zenoh.Queryable | None,
    end: _CallbackEnd | None = None,
    *,
    join_timeout_s: float = 2.0,
) -> None:
    """Undeclare then close, each step on its own so one failure does not skip the rest; then
    wait for the queryable's callback thread to end (``end``)."""
    for step in (
        token.undeclare if token is not None else None,
        queryable.undeclare if queryable is not None else None,
        session.close,
    ):
        if step is None:
            continue
        try:
            step()
        except Exception as exc:
            log.debug("zenoh teardown step failed: %s", zenoh_error_text(exc))
    if queryable is not None and end is not None:
        end.join(join_timeout_s)


class MemoryPublisher:
    """In-memory :class:`Publisher` for tests: records ``(key, message)`` in :attr:`messages`.

    Messages go through the same JSON encoding as :class:`ZenohPublisher` and are stored
    decoded again, so a test sees exactly what a subscriber would parse, and a message that
    could not be sent (NaN, an object JSON cannot hold) is counted in ``put_errors`` instead.
    """

    def __init__(self, site: str = "test") -> None:
        self.site = site
        self.messages: list[tuple[str, dict]] = []
        self.put_errors = 0
        self.closed = False

    def put(self, suffix: str, message: dict) -> None:
        """Record ``message`` under ``weather/<site>/<suffix>``; never raises."""
        try:
            key = site_key(self.site, suffix)
            self.messages.append((key, json.loads(encode_message(message))))
        except (TypeError, ValueError) as exc:
            self.put_errors += 1
            log.warning("memory publisher: put %r: %s", suffix, exc)

    def latest(self, suffix: str) -> dict | None:
        """The last message put on ``suffix``, or None."""
        key = site_key(self.site, suffix)
        for k, message in reversed(self.messages):
            if k == key:
                return message
        return None

    def close(self) -> None:
        """Mark the publisher closed (puts are still recorded, as a closed session drops them)."""
        self.closed = True
