"""The serial side of an instrument: open the port, poll, frame, parse, reopen after a pull.

:class:`InstrumentReader` runs one thread per instrument. It opens the port with pyserial's
``serial_for_url`` (a device path such as ``/dev/ttyUSB0``, or a URL: ``socket://host:port``
for a serial-to-Ethernet converter, ``loop://`` for tests), feeds what it reads to the
driver's framer and hands every frame to ``on_frame(frame, reading, error)``: ``reading`` when
the frame parsed, ``error`` (the one-line reason) when it did not. A bad frame is counted and
logged when the reason changes, never fatal.

When the port fails (cable pulled, USB adapter gone, converter unreachable) the reader
closes it and reopens it with a bounded exponential backoff: 0.5 s doubling up to 30 s, back
to 0.5 s once bytes flow again. Frames without a logger time get the receive time (UTC ns).

States (``stats()["state"]``): ``connecting`` (first open), ``ok`` (port open),
``reconnecting`` (waiting to reopen after a failure), ``stopped``. One log line per change.
"""

from __future__ import annotations

import dataclasses
import logging
import threading
import time
from collections.abc import Callable
from typing import Any

from serial import SerialBase, SerialException, serial_for_url

from drivers.errors import ConfigError

from .base import DriverSpec, Frame, Framer, ParseError, Reading

__all__ = ["InstrumentReader", "OnFrame", "ReaderBase"]

log = logging.getLogger(__name__)

#: ``on_frame(frame, reading or None, parse error text or None)``, called on the reader thread.
OnFrame = Callable[[Frame, Reading | None, str | None], None]

_SERIAL_KEYS = ("baudrate", "bytesize", "parity", "stopbits")
_PORT_ERRORS = (SerialException, OSError, ValueError)


class ReaderBase:
    """What every reader thread shares: its state with one log line per change, the last
    error, and the ``on_frame`` callback whose exceptions are logged, never fatal."""

    def __init__(self, instrument_id: str, on_frame: OnFrame | None) -> None:
        self.instrument_id = instrument_id
        self._on_frame = on_frame
        self._lock = threading.Lock()
        self._state = "stopped"
        self._last_error: str | None = None
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def start(self) -> None:
        """Start the reader thread (once)."""
        if self._thread is not None:
            raise RuntimeError(f"{type(self).__name__}.start() called twice")
        self._before_start()
        self._set_state("connecting")
        self._thread = threading.Thread(
            target=self._run, name=f"instrument-{self.instrument_id}", daemon=True
        )
        self._thread.start()

    def stop(self, timeout_s: float = 5.0) -> None:
        """Stop the thread and close the port; returns within about one read timeout."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout_s)
        self._after_stop()
        self._set_state("stopped")

    def _before_start(self) -> None:
        """Hook: anything to set up before the thread starts."""

    def _after_stop(self) -> None:
        """Hook: anything to release once the thread has stopped."""

    def _run(self) -> None:
        raise NotImplementedError

    def _opened_text(self) -> str:
        """What the log says when the port opens."""
        raise NotImplementedError

    def _deliver(self, frame: Frame, reading: Reading | None, error: str | None) -> None:
        if self._on_frame is not None:
            try:
                self._on_frame(frame, reading, error)
            except Exception:
                log.exception("instrument %s: on_frame callback failed", self.instrument_id)

    def _failed(self, error: str) -> None:
        with self._lock:
            self._last_error = error
            changed = self._state != "reconnecting"
            self._state = "reconnecting"
        if changed:
            log.warning("instrument %s: %s; reopening with backoff", self.instrument_id, error)
        else:
            log.debug("instrument %s: %s", self.instrument_id, error)

    def _set_state(self, state: str) -> None:
        with self._lock:
            if self._state == state:
                return
            self._state = state
        if state == "ok":
            log.info("instrument %s: %s", self.instrument_id, self._opened_text())
        else:
            log.info("instrument %s: %s", self.instrument_id, state)


class InstrumentReader(ReaderBase):
    """Reads one instrument on one serial port in a background thread.

    Parameters
    ----------
    instrument_id : name used in logs and stats (the config's instrument id).
    spec : the driver (framer, parser, serial defaults, poll command).
    port : a device path or a pyserial URL (``socket://127.0.0.1:4001``, ``loop://``).
    serial : overrides of the driver's serial defaults (``baudrate``, ``bytesize``,
        ``parity``, ``stopbits``).
    mode : ``"automatic"`` (the instrument sends by itself) or ``"polled"`` (the reader sends
        the driver's poll command every ``poll_interval_s`` seconds, first right after opening).
    options : the driver options (checked here with ``spec.check_options``).
    on_frame : callback for every frame; its exceptions are logged, never fatal.
    read_timeout_s : how long one read waits; bounds how fast :meth:`stop` returns.
    idle_timeout_s : when set, an open port silent for this long counts as failed and is
        reopened (a serial-to-Ethernet converter that vanished without closing the TCP
        connection, a USB adapter that hangs). Set it above the instrument's message or poll
        interval; None (default) waits forever.
    backoff_initial_s, backoff_max_s : the reopen delay, doubling from initial to max.

    Raises
    ------
    ConfigError : unknown mode for this driver, polled without a poll command, bad serial key.
    """

    def __init__(
        self,
        instrument_id: str,
        spec: DriverSpec,
        port: str,
        *,
        serial: dict[str, Any] | None = None,
        mode: str = "automatic",
        poll_interval_s: float = 60.0,
        options: dict[str, Any] | None = None,
        on_frame: OnFrame | None = None,
        read_timeout_s: float = 0.1,
        idle_timeout_s: float | None = None,
        backoff_initial_s: float = 0.5,
        backoff_max_s: float = 30.0,
    ) -> None:
        if mode not in spec.modes:
            raise ConfigError(f"mode: {spec.name} supports {', '.join(spec.modes)}, not {mode!r}")
        if mode == "polled" and spec.poll_command is None:
            raise ConfigError(f"mode: {spec.name} has no poll command")
        if mode == "polled" and not poll_interval_s > 0:
            raise ConfigError("poll_interval_s: must be > 0")
        if idle_timeout_s is not None and not idle_timeout_s > 0:
            raise ConfigError("idle_timeout_s: must be > 0")
        unknown = sorted(set(serial or {}) - set(_SERIAL_KEYS))
        if unknown:
            raise ConfigError(f"serial.{unknown[0]}: unknown serial setting")
        super().__init__(instrument_id, on_frame)
        self.spec = spec
        self.port = port
        self.mode = mode
        self.poll_interval_s = float(poll_interval_s)
        self.options = spec.check_options(dict(options or {}))
        self._serial = {k: getattr(spec.serial, k) for k in _SERIAL_KEYS} | dict(serial or {})
        try:  # check the settings now, not at every reopen
            serial_for_url(port, do_not_open=True, **self._serial)
        except ValueError as exc:
            raise ConfigError(f"serial: {exc}") from None
        poll = spec.poll_command
        self._poll = poll(self.options) if mode == "polled" and poll is not None else None
        self._read_timeout_s = float(read_timeout_s)
        self._idle_timeout_s = idle_timeout_s
        self._backoff_initial_s = float(backoff_initial_s)
        self._backoff_max_s = float(backoff_max_s)
        self._frames = self._readings = self._bad_frames = self._reconnects = 0
        self._garbage_done = 0  # garbage of the framers of closed connections
        self._framer: Framer | None = None
        self._last_reason: str | None = None
        self._last_reading_mono: float | None = None
        self._got_bytes = False

    def stats(self) -> dict[str, Any]:
        """Counters and state (a copy): state, frames, readings, bad_frames, garbage_bytes,
        reconnects, last_error, last_reading_age_s (None before the first reading)."""
        with self._lock:
            framer = self._framer
            garbage = self._garbage_done + (framer.garbage_bytes if framer else 0)
            age = None
            if self._last_reading_mono is not None:
                age = time.monotonic() - self._last_reading_mono
            return {
                "instrument_id": self.instrument_id,
                "driver": self.spec.name,
                "port": self.port,
                "state": self._state,
                "frames": self._frames,
                "readings": self._readings,
                "bad_frames": self._bad_frames,
                "garbage_bytes": garbage,
                "reconnects": self._reconnects,
                "last_error": self._last_error,
                "last_reading_age_s": age,
            }

    # -- the thread ---------------------------------------------------------------------
    def _run(self) -> None:
        try:
            self._loop()
        except Exception as exc:  # a bug: leave a trace and a state that says so
            log.exception("instrument %s: reader thread failed", self.instrument_id)
            with self._lock:
                self._last_error = f"reader thread failed: {type(exc).__name__}: {exc}"
            self._set_state("stopped")

    def _loop(self) -> None:
        backoff = self._backoff_initial_s
        opened_before = False
        while not self._stop.is_set():
            try:
                port = serial_for_url(self.port, timeout=self._read_timeout_s, **self._serial)
            except _PORT_ERRORS as exc:
                self._failed(f"cannot open {self.port}: {exc}")
            else:
                if opened_before:
                    with self._lock:
                        self._reconnects += 1
                opened_before = True
                if self._session(port):
                    backoff = self._backoff_initial_s
            if self._stop.wait(backoff):
                break
            backoff = min(2 * backoff, self._backoff_max_s)

    def _session(self, port: SerialBase) -> bool:
        """Read an open port until stopped or failed; True when bytes have flowed."""
        framer = self.spec.make_framer(self.options)
        with self._lock:
            self._framer = framer
        self._set_state("ok")
        self._got_bytes = False
        try:
            self._pump(port, framer)
        except _PORT_ERRORS as exc:
            self._failed(f"{self.port}: {exc}")
        finally:
            _close(port)
            with self._lock:
                self._garbage_done += framer.garbage_bytes
                self._framer = None
        return self._got_bytes

    def _pump(self, port: SerialBase, framer: Framer) -> None:
        """Poll, read and frame until stopped; a port error propagates."""
        next_poll = last_data = time.monotonic()
        while not self._stop.is_set():
            now = time.monotonic()
            if self._poll is not None and now >= next_poll:
                port.write(self._poll)
                next_poll = max(next_poll + self.poll_interval_s, now)
            data = port.read(1)
            if not data:
                idle = self._idle_timeout_s
                if idle is not None and time.monotonic() - last_data > idle:
                    raise SerialException(f"no data for {idle:g} s")
                continue
            last_data = time.monotonic()
            waiting = port.in_waiting
            if waiting:
                data += port.read(waiting)
            self._got_bytes = True
            t_ns = time.time_ns()
            for frame in framer.feed(data):
                self._handle(frame, t_ns)

    def _handle(self, frame: Frame, t_ns: int) -> None:
        if frame.t_ns is None:
            frame = dataclasses.replace(frame, t_ns=t_ns)
        reading: Reading | None = None
        error: str | None = None
        try:
            reading = self.spec.parse(frame, self.options)
        except ParseError as exc:
            error = str(exc) or "unreadable frame"
        except Exception as exc:  # a parser bug must not end the readings: count, trace
            error = f"parser failed: {type(exc).__name__}: {exc}"
            log.exception("instrument %s: %s parser failed", self.instrument_id, self.spec.name)
        with self._lock:
            self._frames += 1
            if reading is not None:
                self._readings += 1
                self._last_reading_mono = time.monotonic()
            else:
                self._bad_frames += 1
        if error is not None and error != self._last_reason:
            log.warning("instrument %s: bad frame: %s", self.instrument_id, error)
            self._last_reason = error
        self._deliver(frame, reading, error)

    def _opened_text(self) -> str:
        return f"{self.port} open ({self.mode})"


def _close(port: SerialBase) -> None:
    try:
        port.close()
    except _PORT_ERRORS:
        log.debug("closing the port failed", exc_info=True)
