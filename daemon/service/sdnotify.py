"""The systemd notification protocol (``sd_notify``) and the service watchdog, without libsystemd.

Under ``Type=notify`` systemd passes the path of a datagram socket in ``$NOTIFY_SOCKET`` (a file
path, or ``@name`` for a Linux abstract socket); the service sends it newline-separated
``KEY=value`` assignments: ``READY=1`` once it serves, ``STATUS=…`` for ``systemctl status``,
``STOPPING=1``, ``RELOADING=1``, ``WATCHDOG=1``. With ``WatchdogSec=`` systemd also sets
``$WATCHDOG_USEC`` (and ``$WATCHDOG_PID``) and kills and restarts the service when no
``WATCHDOG=1`` arrives within that time. See sd_notify(3) and systemd.service(5).

Outside systemd (no ``$NOTIFY_SOCKET``) every call is a no-op, so the daemon calls these
unconditionally::

    notify("READY=1", "STATUS=2 cameras, publishing")
    watchdog = Watchdog.from_env()          # None when systemd set no watchdog
    while not stop.wait(0.5):
        if watchdog is not None and every_pipeline_made_progress():
            watchdog.kick()                 # a hung pipeline stops the kicks: systemd restarts
    notify("STOPPING=1")
"""

from __future__ import annotations

import logging
import os
import socket
import threading
import time
from collections.abc import Callable, Mapping

__all__ = ["Watchdog", "notify", "watchdog_interval_s"]

log = logging.getLogger(__name__)

#: Seconds a notification may block when systemd's queue is full; it then gives up (sd_notify
#: itself blocks, but a stuck watchdog kick must not stall the loop that sends it).
SEND_TIMEOUT_S = 1.0

_failure_logged = False


def notify(*fields: str, environ: Mapping[str, str] | None = None) -> bool:
    """Send ``KEY=value`` assignments to the service manager in one datagram.

    Parameters
    ----------
    *fields : str
        Assignments such as ``"READY=1"``, ``"WATCHDOG=1"``, ``f"STATUS={text}"``. A newline
        inside a field would start another assignment, so it is replaced by a space.
    environ : mapping, optional
        Where to read ``NOTIFY_SOCKET`` (default: ``os.environ``; tests pass their own).

    Returns
    -------
    bool
        True if the datagram was sent; False if ``$NOTIFY_SOCKET`` is unset or empty (not
        started by systemd, or ``NotifyAccess=none``), unsupported (e.g. ``vsock:``), or the
        send failed. Never raises: the first failure is logged at debug level, later ones not.
    """
    env = os.environ if environ is None else environ
    target = env.get("NOTIFY_SOCKET", "")
    if not target or not fields:
        return False
    if target.startswith("@"):
        address = "\0" + target[1:]  # Linux abstract namespace
    elif target.startswith("/"):
        address = target
    else:
        _log_failure_once("unsupported NOTIFY_SOCKET address %r", target)
        return False
    message = "\n".join(field.replace("\n", " ") for field in fields).encode("utf-8", "replace")
    try:
        with socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM | socket.SOCK_CLOEXEC) as sock:
            sock.settimeout(SEND_TIMEOUT_S)
            sock.sendto(message, address)
    except OSError as exc:
        _log_failure_once("cannot notify systemd at %s: %s", target, exc)
        return False
    return True


def _log_failure_once(msg: str, *args: object) -> None:
    global _failure_logged
    if not _failure_logged:
        _failure_logged = True
        log.debug(msg, *args)


def watchdog_interval_s(environ: Mapping[str, str] | None = None) -> float | None:
    """The watchdog timeout systemd expects us to honour, in seconds, or None.

    Parameters
    ----------
    environ : mapping, optional
        Where to read ``WATCHDOG_USEC`` and ``WATCHDOG_PID`` (default: ``os.environ``).

    Returns
    -------
    float or None
        ``$WATCHDOG_USEC`` in seconds (``WatchdogSec=``); None when it is unset, not a positive
        integer, or when ``$WATCHDOG_PID`` is set to another process's id (the variables were
        inherited from a parent that systemd watches, not meant for us).
    """
    env = os.environ if environ is None else environ
    usec = env.get("WATCHDOG_USEC", "")
    pid = env.get("WATCHDOG_PID", "")
    try:
        interval_us = int(usec)
        if pid and int(pid) != os.getpid():
            return None
    except ValueError:
        return None
    return interval_us / 1e6 if interval_us > 0 else None


class Watchdog:
    """Sends ``WATCHDOG=1`` at most once per half interval, however often it is kicked.

    Call :meth:`kick` from the processing loop only when every camera pipeline has made
    progress recently: then a hung pipeline stops the kicks, and after ``WatchdogSec=`` systemd
    kills the service (SIGABRT) and restarts it. Thread-safe.

    Parameters
    ----------
    interval_s : float
        The watchdog timeout in seconds (see :func:`watchdog_interval_s`); > 0.
    clock : callable, optional
        Monotonic time in seconds (default ``time.monotonic``; tests inject a fake).
    send : callable, optional
        The notifier (default :func:`notify`).
    """

    def __init__(
        self,
        interval_s: float,
        *,
        clock: Callable[[], float] = time.monotonic,
        send: Callable[..., bool] = notify,
    ) -> None:
        if not interval_s > 0:
            raise ValueError(f"watchdog interval must be > 0 s, got {interval_s!r}")
        self.interval_s = float(interval_s)
        self._clock = clock
        self._send = send
        self._last_sent: float | None = None
        self._lock = threading.Lock()

    @classmethod
    def from_env(cls, environ: Mapping[str, str] | None = None) -> Watchdog | None:
        """A watchdog for ``$WATCHDOG_USEC`` sending to ``$NOTIFY_SOCKET``, or None if unset."""
        interval_s = watchdog_interval_s(environ)
        if interval_s is None:
            return None
        return cls(interval_s, send=lambda *fields: notify(*fields, environ=environ))

    def kick(self) -> bool:
        """Tell systemd we are alive, unless that was done less than half an interval ago.

        Returns
        -------
        bool
            True if a ``WATCHDOG=1`` datagram was sent now.
        """
        with self._lock:
            now = self._clock()
            if self._last_sent is not None and now - self._last_sent < self.interval_s / 2:
                return False
            sent = self._send("WATCHDOG=1")
            if sent:
                self._last_sent = now
            return sent
