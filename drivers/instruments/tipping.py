"""Tipping-bucket rain gauge on a serial modem-status line (``tipping-bucket``).

The cheapest real gauge has no protocol at all: a reed switch, wired to a control line of a
serial port (CTS, DSR, DCD or RI; option ``line``, default ``"cts"``), closes once per tip of
the bucket. :class:`TippingBucketReader` polls the line state (~100 Hz), counts debounced
edges and emits one :class:`~drivers.instruments.base.Reading` per ``report_interval_s``
(default 60 s) with

- ``rain_accum_mm``: running total since the reader (or the file) started, mm;
- ``rain_rate_mm_h``: the mean rate over the interval, mm/h (None when the port was down
  during the interval: tips may have been missed);
- ``extra``: ``tips`` in the interval and ``interval_s``.

Intervals are aligned to multiples of ``report_interval_s`` since the epoch (minute
boundaries by default); the first one starts when observation starts and its rate is over
its actual length. A tip exactly on a border belongs to the interval that starts there.

Debouncing: a rising edge (``edge = "rising"``, the switch closing; or ``"falling"``) counts
as a tip only when the line had been in the other state for at least ``debounce_s`` (default
0.05 s) before it. A bounce train on closing counts once (its later edges follow short
opposite states) and the bounce on release not at all. The line's state when observation
starts is never an edge.

Text capture format (``weatherd instruments decode --driver tipping-bucket FILE``), one event
per line, UTF-8, times ISO-8601 (``Z`` or an offset; a naive time is UTC)::

    # comment lines and blank lines are ignored
    2024-05-14T10:00:03.120Z tip          one counted tip (e.g. from a pulse logger)
    2024-05-14T10:00:03.120Z CTS 1        a line-state change: CTS, DSR, DCD (or CD), RI,
    2024-05-14T10:00:03.124Z CTS 0        1/0; debounced like the live line

Line-state events of another line than ``options.line`` are skipped. Events must be in time
order; a line that cannot be read is reported (a :class:`ParseError` frame), never fatal.

Both paths share one frame format, the interval summary ``interval start_ns=… end_ns=…
tips=N total=M`` (``tips=-`` when unknown, optional ``status=…``); :func:`parse` turns it into
the reading, so the raw MCAP channel of a live gauge can be decoded again.
"""

from __future__ import annotations

import datetime as dt
import logging
import math
import re
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any

from drivers.errors import ConfigError

from .base import DriverSpec, Frame, ParseError, Reading
from .reader import OnFrame, ReaderBase

__all__ = [
    "DRIVER",
    "Debouncer",
    "Interval",
    "IntervalAggregator",
    "TipCaptureFramer",
    "TippingBucketReader",
    "bin_tips",
    "check_options",
    "debounce",
    "parse",
    "summary_frame",
]

log = logging.getLogger(__name__)

NAME = "tipping-bucket"

#: Option ``line`` -> pyserial attribute of the port.
LINE_ATTRS = {"cts": "cts", "dsr": "dsr", "dcd": "cd", "cd": "cd", "ri": "ri"}

DEFAULTS: dict[str, Any] = {
    "line": "cts",
    "edge": "rising",
    "debounce_s": 0.05,
    "mm_per_tip": 0.2,
    "report_interval_s": 60.0,
    "poll_hz": 100.0,
}


def check_options(options: dict[str, Any]) -> dict[str, Any]:
    """Options with defaults filled in; ConfigError naming the key when one is wrong."""
    out = dict(DEFAULTS)
    for key, value in options.items():
        if key not in DEFAULTS:
            raise ConfigError(f"options.{key}: unknown option (known: {', '.join(DEFAULTS)})")
        out[key] = value
    line = str(out["line"]).lower()
    if line not in LINE_ATTRS:
        raise ConfigError(f"options.line: must be one of cts, dsr, dcd, ri (got {out['line']!r})")
    out["line"] = line
    if out["edge"] not in ("rising", "falling"):
        raise ConfigError(f"options.edge: must be 'rising' or 'falling' (got {out['edge']!r})")
    for key, minimum in (("debounce_s", 0.0), ("mm_per_tip", None), ("report_interval_s", None)):
        out[key] = _number(out[key], key, minimum)
    out["poll_hz"] = _number(out["poll_hz"], "poll_hz", None)
    return out


def _number(value: Any, key: str, minimum: float | None) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise ConfigError(f"options.{key}: expected a number, got {value!r}")
    if minimum is None and value <= 0:
        raise ConfigError(f"options.{key}: must be > 0")
    if minimum is not None and value < minimum:
        raise ConfigError(f"options.{key}: must be >= {minimum}")
    return float(value)


# --- debouncing ------------------------------------------------------------------------------


class Debouncer:
    """Counts debounced edges of one line, fed with (time, state) samples or changes.

    Parameters
    ----------
    debounce_s : float, s, how long the line must have been in the opposite state before an
        edge counts
    edge : "rising" or "falling", the edge that is a tip
    """

    def __init__(self, *, debounce_s: float, edge: str = "rising") -> None:
        self._debounce_ns = round(debounce_s * 1e9)
        self._active = edge == "rising"
        self._state: bool | None = None
        # When the line last entered the inactive state; None: it was so from the start.
        self._inactive_since_ns: int | None = None

    def reset(self) -> None:
        """Forget the line state (after a reconnect): the next sample is never an edge."""
        self._state = None
        self._inactive_since_ns = None

    def feed(self, t_ns: int, state: bool) -> bool:
        """True when this sample is a counted edge (a tip)."""
        state = bool(state)
        previous, self._state = self._state, state
        if previous is None or previous == state:
            return False
        if state != self._active:
            self._inactive_since_ns = t_ns
            return False
        since = self._inactive_since_ns
        return since is None or t_ns - since >= self._debounce_ns


def debounce(
    events: Iterable[tuple[int, bool]], *, debounce_s: float, edge: str = "rising"
) -> list[int]:
    """Times (UTC ns) of the counted tips in a sequence of (t_ns, state) line samples."""
    debouncer = Debouncer(debounce_s=debounce_s, edge=edge)
    return [t_ns for t_ns, state in events if debouncer.feed(t_ns, state)]


# --- intervals -------------------------------------------------------------------------------


@dataclass(frozen=True)
class Interval:
    """One reporting interval: [start_ns, end_ns), tips counted (None: unknown)."""

    start_ns: int
    end_ns: int
    tips: int | None
    complete: bool = True


def _next_border(t_ns: int, interval_ns: int) -> int:
    return (t_ns // interval_ns + 1) * interval_ns


def bin_tips(
    tips_ns: Iterable[int], *, start_ns: int, end_ns: int, interval_s: float
) -> list[Interval]:
    """Tips counted per interval from ``start_ns`` up to the interval holding ``end_ns - 1``.

    The first interval starts at ``start_ns``; the others at multiples of ``interval_s`` since
    the epoch. A tip at a border belongs to the interval starting there; tips outside
    [start_ns, end_ns) are ignored.
    """
    agg = IntervalAggregator(interval_s, start_ns)
    out: list[Interval] = []
    for t_ns in sorted(tips_ns):
        if start_ns <= t_ns < end_ns:
            out += agg.close_until(t_ns)
            agg.add_tip(t_ns)
    out += agg.close_until(end_ns - 1)
    return [*out, agg.close_current()]


class IntervalAggregator:
    """Tips into reporting intervals; the stateful side of :func:`bin_tips`."""

    def __init__(self, interval_s: float, start_ns: int) -> None:
        self.interval_ns = max(1, round(interval_s * 1e9))
        self._start_ns = start_ns
        self._end_ns = _next_border(start_ns, self.interval_ns)
        self._tips = 0
        self._complete = True

    @property
    def end_ns(self) -> int:
        """End of the open interval, UTC ns."""
        return self._end_ns

    def add_tip(self, t_ns: int) -> None:
        """Count one tip in the open interval."""
        self._tips += 1

    def mark_incomplete(self) -> None:
        """The open interval missed some time (port down): its rate is unknown."""
        self._complete = False

    def close_current(self) -> Interval:
        """Close the open interval and open the next one."""
        out = Interval(self._start_ns, self._end_ns, self._tips, self._complete)
        self._start_ns, self._end_ns = self._end_ns, self._end_ns + self.interval_ns
        self._tips, self._complete = 0, True
        return out

    def close_until(self, t_ns: int) -> list[Interval]:
        """Close every interval that ends at or before ``t_ns`` (possibly none)."""
        out = []
        while t_ns >= self._end_ns:
            out.append(self.close_current())
        return out


def summary_frame(interval: Interval, total_tips: int, *, line: int = 0) -> Frame:
    """The frame of one interval (see the module docstring)."""
    tips = "-" if interval.tips is None else str(interval.tips)
    text = (
        f"interval start_ns={interval.start_ns} end_ns={interval.end_ns} tips={tips}"
        f" total={total_tips}"
    )
    if not interval.complete:
        text += " status=disconnected"
    return Frame(data=text.encode(), t_ns=interval.end_ns, line=line)


_SUMMARY = re.compile(
    r"interval start_ns=(?P<start>\d+) end_ns=(?P<end>\d+) tips=(?P<tips>\d+|-)"
    r" total=(?P<total>\d+)(?: status=(?P<status>\S+))?"
)


def parse(frame: Frame, options: dict[str, Any]) -> Reading:
    """One interval summary frame -> Reading; ParseError for anything else."""
    text = frame.data.decode("latin-1").strip()
    m = _SUMMARY.fullmatch(text)
    if m is None:
        raise ParseError(f"not a tip event or interval: {text[:60]!r}")
    mm_per_tip = float(options.get("mm_per_tip", DEFAULTS["mm_per_tip"]))
    start_ns, end_ns = int(m["start"]), int(m["end"])
    if end_ns <= start_ns:
        raise ParseError(f"interval ends before it starts: {text[:60]!r}")
    duration_s = (end_ns - start_ns) / 1e9
    tips = None if m["tips"] == "-" else int(m["tips"])
    status = m["status"] or "ok"
    rate = None
    if tips is not None and status == "ok":
        rate = round(tips * mm_per_tip * 3600.0 / duration_s, 6)  # not 84.00000000000001
    return Reading(
        driver=NAME,
        t_ns=end_ns,
        rain_rate_mm_h=rate,
        rain_accum_mm=round(int(m["total"]) * mm_per_tip, 6),
        status=status,
        fault=status != "ok",
        extra={"tips": tips, "interval_s": duration_s},
    )


# --- text captures ---------------------------------------------------------------------------

_EVENT = re.compile(r"(?P<time>\S+)\s+(?:(?P<tip>tip)|(?P<line>[A-Za-z]+)\s+(?P<state>[01]))")


def _parse_time(text: str) -> int:
    t = dt.datetime.fromisoformat(text)
    if t.tzinfo is None:
        t = t.replace(tzinfo=dt.UTC)
    delta = t - dt.datetime(1970, 1, 1, tzinfo=dt.UTC)
    return (delta.days * 86_400 + delta.seconds) * 1_000_000_000 + delta.microseconds * 1000


class TipCaptureFramer:
    """Frames of a text capture: one summary frame per interval, bad lines as themselves.

    Fed bytes in any chunking; a bad line comes out as a frame holding that line (the parser
    then reports it), so ``decode`` lists it without stopping.
    """

    def __init__(self, options: dict[str, Any]) -> None:
        options = check_options(options)
        self._line_name = options["line"]
        self._debouncer = Debouncer(debounce_s=options["debounce_s"], edge=options["edge"])
        self._interval_s = options["report_interval_s"]
        self._agg: IntervalAggregator | None = None
        self._buffer = b""
        self._line_no = 0
        self._last_t_ns: int | None = None
        self._total = 0
        self.garbage_bytes = 0

    def feed(self, data: bytes) -> list[Frame]:
        self._buffer += data
        *lines, self._buffer = re.split(rb"\r\n|\n|\r", self._buffer)
        out: list[Frame] = []
        for raw in lines:
            out.extend(self._line(raw))
        return out

    def flush(self) -> list[Frame]:
        out = self._line(self._buffer) if self._buffer else []
        self._buffer = b""
        if self._agg is not None:
            interval = self._agg.close_current()
            out.append(summary_frame(interval, self._total, line=self._line_no))
            self._agg = None
        return out

    def _line(self, raw: bytes) -> list[Frame]:
        self._line_no += 1
        text = raw.decode("utf-8", errors="replace").strip()
        if not text or text.startswith("#"):
            return []
        bad = [Frame(data=raw, line=self._line_no)]
        m = _EVENT.fullmatch(text)
        if m is None:
            return bad
        try:
            t_ns = _parse_time(m["time"])
        except ValueError:
            return bad
        if m["line"] is not None and LINE_ATTRS.get(m["line"].lower()) is None:
            return bad
        if self._last_t_ns is not None and t_ns < self._last_t_ns:
            return bad
        self._last_t_ns = t_ns
        if self._agg is None:
            self._agg = IntervalAggregator(self._interval_s, t_ns)
        out = [
            summary_frame(iv, self._total, line=self._line_no) for iv in self._agg.close_until(t_ns)
        ]
        if m["tip"] is not None:
            tip = True
        elif LINE_ATTRS[m["line"].lower()] == LINE_ATTRS[self._line_name]:
            tip = self._debouncer.feed(t_ns, m["state"] == "1")
        else:
            tip = False
        if tip:
            self._agg.add_tip(t_ns)
            self._total += 1
        return out


# --- the live reader -------------------------------------------------------------------------


class TippingBucketReader(ReaderBase):
    """Polls a modem-status line of a serial port and reports tips per interval.

    The same shape as :class:`drivers.instruments.reader.InstrumentReader`: ``start()``,
    ``stop()``, ``stats()`` and ``on_frame(frame, reading, error)``, called on the reader
    thread once per interval with the summary frame and its reading (``error`` is always
    None: the frames are made here). States: ``connecting``, ``ok``, ``reconnecting``,
    ``stopped``; one log line per change. Intervals during which the port was down are
    reported with ``status="disconnected"``, ``fault=True`` and no rate.

    Parameters
    ----------
    instrument_id : name used in logs and stats
    port : a device path or pyserial URL (opened with ``serial_for_url``), or a function
        returning an open port-like object with ``cts``/``dsr``/``cd``/``ri`` and ``close()``
    options : the driver options (checked here)
    on_frame : callback; its exceptions are logged, never fatal
    backoff_initial_s, backoff_max_s : the reopen delay, doubling from initial to max
    clock_ns : UTC ns now (tests pass a fake clock)
    """

    def __init__(
        self,
        instrument_id: str,
        port: str | Callable[[], Any],
        *,
        options: dict[str, Any] | None = None,
        on_frame: OnFrame | None = None,
        backoff_initial_s: float = 0.5,
        backoff_max_s: float = 30.0,
        clock_ns: Callable[[], int] = time.time_ns,
    ) -> None:
        super().__init__(instrument_id, on_frame)
        self.options = check_options(dict(options or {}))
        self.port = port if isinstance(port, str) else getattr(port, "__name__", "port")
        self._open = _pyserial_opener(port) if isinstance(port, str) else port
        self._attr = LINE_ATTRS[self.options["line"]]
        self._clock_ns = clock_ns
        self._backoff = (float(backoff_initial_s), float(backoff_max_s))
        self._port: Any = None
        self._debouncer = Debouncer(
            debounce_s=self.options["debounce_s"], edge=self.options["edge"]
        )
        self._agg: IntervalAggregator | None = None
        self._total = 0
        self._counts = {"polls": 0, "tips": 0, "readings": 0, "reconnects": 0}
        self._last_reading_mono: float | None = None

    # -- life cycle ---------------------------------------------------------------------
    def _before_start(self) -> None:
        self._agg = IntervalAggregator(self.options["report_interval_s"], self._clock_ns())

    def _after_stop(self) -> None:
        self._close()

    def stats(self) -> dict[str, Any]:
        """Counters and state (a copy), the keys of ``InstrumentReader.stats()`` plus
        ``polls`` and ``tips``."""
        with self._lock:
            age = None
            if self._last_reading_mono is not None:
                age = time.monotonic() - self._last_reading_mono
            return {
                "instrument_id": self.instrument_id,
                "driver": NAME,
                "port": self.port,
                "state": self._state,
                "frames": self._counts["readings"],
                "readings": self._counts["readings"],
                "bad_frames": 0,
                "garbage_bytes": 0,
                "reconnects": self._counts["reconnects"],
                "last_error": self._last_error,
                "last_reading_age_s": age,
                "polls": self._counts["polls"],
                "tips": self._counts["tips"],
            }

    # -- the thread ---------------------------------------------------------------------
    def _run(self) -> None:
        poll_s = 1.0 / self.options["poll_hz"]
        backoff = self._backoff[0]
        opened_before = False
        while not self._stop.is_set():
            if self._port is None:
                try:
                    self._port = self._open()
                except (OSError, ValueError) as exc:
                    self._failed(f"cannot open {self.port}: {exc}")
                    self._emit_due(self._clock_ns())
                    if self._stop.wait(backoff):
                        break
                    backoff = min(2.0 * backoff, self._backoff[1])
                    continue
                if opened_before:
                    with self._lock:
                        self._counts["reconnects"] += 1
                opened_before = True
                backoff = self._backoff[0]
                self._debouncer.reset()
                self._set_state("ok")
            try:
                state = bool(getattr(self._port, self._attr))
            except (OSError, ValueError) as exc:
                self._failed(f"{self.port}: {exc}")
                self._close()
                continue
            now = self._clock_ns()
            self._emit_due(now)
            with self._lock:
                self._counts["polls"] += 1
            if self._debouncer.feed(now, state):
                assert self._agg is not None
                self._agg.add_tip(now)
                self._total += 1
                with self._lock:
                    self._counts["tips"] += 1
            if self._stop.wait(poll_s):
                break

    def _close(self) -> None:
        port, self._port = self._port, None
        if port is None:
            return
        if self._agg is not None:
            self._agg.mark_incomplete()
        try:
            port.close()
        except (OSError, ValueError) as exc:
            log.debug("instrument %s: close failed: %s", self.instrument_id, exc)

    def _emit_due(self, now_ns: int) -> None:
        """Report every interval that has ended by ``now_ns``."""
        assert self._agg is not None
        down = self._port is None
        if down:
            self._agg.mark_incomplete()
        for interval in self._agg.close_until(now_ns):
            if down:
                self._agg.mark_incomplete()
            frame = summary_frame(interval, self._total)
            reading = parse(frame, self.options)
            with self._lock:
                self._counts["readings"] += 1
                self._last_reading_mono = time.monotonic()
            self._deliver(frame, reading, None)

    def _opened_text(self) -> str:
        return f"reading {self.options['line'].upper()} on {self.port}"


def _pyserial_opener(url: str) -> Callable[[], Any]:
    def open_port() -> Any:
        import serial  # pyserial, imported here: parsing and decoding need no serial stack

        return serial.serial_for_url(url, timeout=0)

    return open_port


DRIVER = DriverSpec(
    name=NAME,
    make_framer=TipCaptureFramer,
    parse=parse,
    check_options=check_options,
    description="tipping-bucket gauge: reed switch on CTS/DSR/DCD/RI, tips per interval",
)
