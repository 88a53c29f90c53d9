"""Decode a raw capture (or a logger file) of an instrument's serial output into readings.

The core of ``weatherd instruments decode --driver NAME FILE``: the file is read as bytes
(raw captures hold control characters), fed to the driver's framer in chunks (so the
framer's handling of split reads is exercised on every file) and each frame is parsed. Bad
frames are collected in :class:`DecodeStats` with their line number, never fatal::

    stats = DecodeStats()
    for reading in decode_file(DRIVERS["vaisala-pwd"], "PW040406.DAT", stats=stats):
        print(json.dumps(reading.to_json()))
    for line, reason in stats.bad:
        print(f"line {line}: {reason}", file=sys.stderr)

**Clocks.** A reading's ``t`` comes from the most trustworthy clock the capture has: the
logger's stamp (a prefix on the telegram's line or a line of its own) when there is one, else
the sensor's own clock; ``time_source`` says which (``logger`` or ``sensor``) and
``sensor_clock_offset_s`` how far the sensor's clock is from the logger's. ``time="sensor"``
forces the sensor's clock where the telegram has one (the logger's time is then kept as
``logger_t``); ``time="logger"`` (the default) takes the logger's where there is one. A
sensor clock far from the logger's is said once, in ``DecodeStats.notes``.
"""

from __future__ import annotations

import dataclasses
import datetime as dt
import os
import re
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from typing import Any

from drivers.errors import InputError

from .base import DriverSpec, Frame, ParseError, Reading, iso_utc

__all__ = [
    "CHECKSUM_CHOICES",
    "TIME_CHOICES",
    "DecodeStats",
    "checksum_convention",
    "choose_clock",
    "decode_chunks",
    "decode_file",
]

#: ``decode --checksum``: refuse a telegram whose checksum fails, keep it and say so in the
#: reading (``checksum_ok``), or do not look; ``auto`` (files): enforce, unless every
#: telegram of the file fails the same way (a convention, said once): then report.
CHECKSUM_CHOICES = ("auto", "enforce", "report", "ignore")

#: The clocks ``decode --time`` may force.
TIME_CHOICES = ("logger", "sensor")

#: Bytes fed to the framer at a time.
CHUNK_BYTES = 4096


@dataclass
class DecodeStats:
    """What a decode saw.

    Attributes
    ----------
    frames : frames cut from the file
    readings : frames that parsed
    bad : (line number, reason) of each frame that did not parse, in file order
    garbage_bytes : bytes outside any frame (noise, blank lines, control characters)
    notes : things said once about the whole file (a sensor clock that is off...)
    """

    frames: int = 0
    readings: int = 0
    bad: list[tuple[int, str]] = field(default_factory=list)
    garbage_bytes: int = 0
    notes: list[str] = field(default_factory=list)


def decode_chunks(
    spec: DriverSpec,
    chunks: Iterable[bytes],
    *,
    options: dict[str, Any] | None = None,
    stats: DecodeStats | None = None,
    time: str = "logger",
) -> Iterator[Reading]:
    """Readings from a byte stream given in chunks of any size.

    Parameters
    ----------
    spec : the driver
    chunks : the stream, split anywhere
    options : driver options, checked with ``spec.check_options`` (ConfigError if invalid)
    stats : filled in as the stream is read (complete once the iterator is exhausted)
    time : ``"logger"`` or ``"sensor"``, the clock that dates a reading when it has both
    """
    if time not in TIME_CHOICES:
        raise ValueError(f"time must be one of {TIME_CHOICES}")
    opts = spec.check_options(dict(options or {}))
    stats = stats if stats is not None else DecodeStats()
    framer = spec.make_framer(opts)
    for chunk in chunks:
        for frame in framer.feed(chunk):
            reading = _parse(spec, frame, opts, stats, time)
            if reading is not None:
                yield reading
        stats.garbage_bytes = framer.garbage_bytes
    for frame in framer.flush():
        reading = _parse(spec, frame, opts, stats, time)
        if reading is not None:
            yield reading
    stats.garbage_bytes = framer.garbage_bytes


def decode_file(
    spec: DriverSpec,
    path: str | os.PathLike[str],
    *,
    options: dict[str, Any] | None = None,
    stats: DecodeStats | None = None,
    chunk_bytes: int = CHUNK_BYTES,
    time: str = "logger",
    checksum: str = "auto",
) -> Iterator[Reading]:
    """Readings of the file at ``path``, in file order.

    The options are checked and the file opened at once (before the first reading is
    asked for), so a missing file raises here. ``checksum`` (one of
    :data:`CHECKSUM_CHOICES`) applies to drivers with ``reports_checksum``; with ``auto``,
    a file whose telegrams all fail their checksum by the same offset is read first to
    find it out (:func:`checksum_convention`), then decoded as with ``report``, and
    ``stats.notes`` says so once.

    Raises
    ------
    InputError : the file cannot be opened.
    ConfigError : invalid options.
    """
    if chunk_bytes < 1:
        raise ValueError("chunk_bytes must be >= 1")
    if checksum not in CHECKSUM_CHOICES:
        raise ValueError(f"checksum must be one of {CHECKSUM_CHOICES}")
    options = dict(options or {})
    spec.check_options(options)
    if spec.reports_checksum and checksum != "enforce" and "checksum" not in options:
        if checksum == "auto":
            stats = stats if stats is not None else DecodeStats()
            note = checksum_convention(spec, path, options=options, chunk_bytes=chunk_bytes)
            if note is not None:
                stats.notes.append(note)
                options["checksum"] = "report"
        else:
            options["checksum"] = checksum
    opts = spec.check_options(options)
    try:
        f = open(path, "rb")  # closed by the generator below
    except OSError as exc:
        raise InputError(f"{path}: {exc.strerror or exc}") from None
    return _decode_open_file(spec, f, opts, stats, chunk_bytes, time)


def checksum_convention(
    spec: DriverSpec,
    path: str | os.PathLike[str],
    *,
    options: dict[str, Any] | None = None,
    chunk_bytes: int = CHUNK_BYTES,
) -> str | None:
    """One line when every checksummed telegram of the file (two at least) fails its
    checksum by the same offset: a convention of the sensor or its logger, not corruption
    (random corruption gives random offsets). None otherwise, or for a driver that cannot
    report its checksums.
    """
    if not spec.reports_checksum:
        return None
    opts = {**(options or {}), "checksum": "report"}
    offsets: set[str | None] = set()
    n = 0
    for reading in decode_file(
        spec, path, options=opts, chunk_bytes=chunk_bytes, checksum="ignore"
    ):
        ok = reading.extra.get("checksum_ok")
        if ok is None:
            continue
        n += 1
        offsets.add(None if ok else reading.extra.get("checksum_offset"))
        if len(offsets) > 1 or None in offsets:
            return None
    if n < 2:
        return None
    (offset,) = offsets
    return (
        f"all {n} telegrams fail their checksum the same way (each is the manual's sum "
        f"+ 0x{offset}): a convention of this sensor or its logger, not corruption; they are "
        "decoded with checksum_ok false (--checksum report says it for each reading, "
        "--checksum enforce refuses them)"
    )


def _decode_open_file(
    spec: DriverSpec,
    f: Any,
    opts: dict[str, Any],
    stats: DecodeStats | None,
    chunk_bytes: int,
    time: str,
) -> Iterator[Reading]:
    stats = stats if stats is not None else DecodeStats()
    day = _name_day(os.path.basename(f.name))
    with f:
        chunks = iter(lambda: f.read(chunk_bytes), b"")
        try:
            for reading in decode_chunks(spec, chunks, options=opts, stats=stats, time=time):
                if day is not None:
                    note = _name_day_note(reading, day)
                    if note is not None:
                        stats.notes.append(note)
                        day = None  # said once
                yield reading
        except OSError as exc:
            raise InputError(f"{f.name}: {exc.strerror or exc}") from None


_NAME_DAY = re.compile(r"(?<!\d)((?:19|20)\d\d)[-_]?(0[1-9]|1[0-2])[-_]?(0[1-9]|[12]\d|3[01])")


def _name_day(name: str) -> dt.date | None:
    """The date a file's name gives (``2025060200.txt``, ``THIES_2024_04_14.dat``), if any."""
    m = _NAME_DAY.search(name)
    if m is None:
        return None
    try:
        return dt.date(int(m[1]), int(m[2]), int(m[3]))
    except ValueError:
        return None


def _name_day_note(reading: Reading, day: dt.date) -> str | None:
    """One line when a reading dated by the sensor's clock is days away from the date in
    the file's name (a logger names its files by its own clock)."""
    if reading.extra.get("time_source") != "sensor" or reading.t_ns is None:
        return None
    t = dt.datetime.fromtimestamp(reading.t_ns / 1e9, tz=dt.UTC).date()
    if -1 <= (t - day).days <= 1:
        return None
    return (
        f"the sensor clock says {iso_utc(reading.t_ns)} but the file's name says {day}: "
        "is the sensor's clock set? (readings keep the sensor's time: the file has no "
        "logger stamp)"
    )


def _parse(
    spec: DriverSpec, frame: Frame, opts: dict[str, Any], stats: DecodeStats, time: str
) -> Reading | None:
    stats.frames += 1
    try:
        reading = spec.parse(frame, opts)
    except ParseError as exc:
        stats.bad.append((frame.line, str(exc) or "unreadable frame"))
        return None
    stats.readings += 1
    reading = choose_clock(reading, frame, time)
    note = _clock_note(reading)
    if note is not None and not any(n.startswith("the sensor clock") for n in stats.notes):
        stats.notes.append(note)
    return reading


def choose_clock(reading: Reading, frame: Frame, time: str = "logger") -> Reading:
    """``reading`` dated by the clock ``time`` asks for, when the reading has it.

    A driver that knows both clocks says which it used in ``extra["time_source"]`` and the
    sensor's offset in ``extra["sensor_clock_offset_s"]``; for the others, a reading dated
    by the frame's stamp is the logger's, any other time the sensor's.
    """
    extra = dict(reading.extra)
    source = extra.get("time_source")
    if source is None and reading.t_ns is not None:
        source = "logger" if frame.t_ns is not None and reading.t_ns == frame.t_ns else "sensor"
    offset = extra.get("sensor_clock_offset_s")
    t_ns = reading.t_ns
    if time == "sensor" and source == "logger" and offset is not None and t_ns is not None:
        extra["logger_t"] = iso_utc(t_ns)
        t_ns, source = t_ns + round(offset * 1e9), "sensor"
    elif time == "logger" and source == "sensor" and frame.t_ns is not None and t_ns is not None:
        extra["sensor_clock_offset_s"] = round((t_ns - frame.t_ns) / 1e9, 3)
        t_ns, source = frame.t_ns, "logger"
    if source is None and "time_source" not in extra:
        return reading  # no time at all: nothing to say
    extra["time_source"] = source
    return dataclasses.replace(reading, t_ns=t_ns, extra=extra)


#: A sensor clock further than this from the logger's is said (once per file).
CLOCK_TOLERANCE_S = 120.0


def _clock_note(reading: Reading) -> str | None:
    """One line when the sensor's clock is off the logger's, or None."""
    offset = reading.extra.get("sensor_clock_offset_s")
    if offset is None or abs(offset) <= CLOCK_TOLERANCE_S or reading.t_ns is None:
        return None
    if reading.extra.get("time_source") == "sensor":
        sensor_ns = reading.t_ns
        logger_ns = sensor_ns - round(offset * 1e9)
    else:
        logger_ns = reading.t_ns
        sensor_ns = logger_ns + round(offset * 1e9)
    hours = offset / 3600
    if 0.5 <= abs(hours) <= 14 and abs(offset - round(hours) * 3600) <= CLOCK_TOLERANCE_S:
        how = (
            f"looks like UTC{round(hours):+d} (a clock in local time? "
            f"--option timezone={round(hours):+d} reads it so)"
        )
    else:
        how = f"is off by {_span(offset)}"
    return (
        f"the sensor clock {how}: it says {iso_utc(sensor_ns)} where the logger says "
        f"{iso_utc(logger_ns)}; readings are dated by the "
        f"{reading.extra.get('time_source')}'s clock"
    )


def _span(seconds: float) -> str:
    """``3 h 30 min 27 s``, ``5 years 2 days``: a duration for people."""
    s = abs(seconds)
    sign = "-" if seconds < 0 else "+"
    if s >= 2 * 86400:
        days = int(s // 86400)
        years, days = divmod(days, 365)
        return sign + (f"{years} year(s) {days} day(s)" if years else f"{days} day(s)")
    h, rest = divmod(round(s), 3600)
    m, sec = divmod(rest, 60)
    parts = [f"{h} h"] * bool(h) + [f"{m} min"] * bool(m) + [f"{sec} s"] * bool(sec or not (h or m))
    return sign + " ".join(parts)
