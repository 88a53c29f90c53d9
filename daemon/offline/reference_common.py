"""What every station reference-data reader shares: the interval, the read context, helpers.

The format readers (``meteofrance``, ``generic_csv``, ``metar_reports``, ``gauge_mcap``) turn a
file into :class:`Interval` values through a :class:`ReadContext`, which carries the options
(station filter, time zone, interval) and counts what was skipped. ``daemon.offline.reference``
detects the format and gives the public entry points.
"""

from __future__ import annotations

import gzip
import io
import logging
import math
import zlib
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from datetime import UTC, datetime, tzinfo
from pathlib import Path
from typing import IO
from zoneinfo import ZoneInfo, ZoneInfoNotFoundError

from drivers.errors import InputError

__all__ = ["Interval", "ReadContext", "ReadStats", "iter_lines", "open_binary", "parse_number"]

logger = logging.getLogger(__name__)

#: Malformed rows logged one by one before the reader only counts them.
MAX_LOGGED_BAD_ROWS = 10
GZIP_MAGIC = b"\x1f\x8b"


@dataclass(frozen=True, slots=True)
class Interval:
    """Precipitation over one time interval at one station.

    Attributes
    ----------
    start, end : datetime, UTC, tz-aware; ``end > start``. The amount covers ``[start, end)``.
    precip_mm : float or None, mm fallen over the interval (``kind="amount"``), or 1.0 / 0.0
        for precipitation observed / not observed (``kind="presence"``); None when missing.
    station : str or None, the station (Météo-France NUM_POSTE / POSTE / geo_id_insee, METAR
        ICAO, gauge instrument id), None when the source does not name one.
    quality : str or None, the source's quality code or flag for the amount as it gives it
        (Météo-France QRR1 / QRR: "0" protected, "1" validated, "2" doubtful, "9" filtered, not
        yet validated; the other formats' flags are in their modules' docstrings).
    kind : str, "amount" or "presence".
    weather : str or None, METAR present-weather groups as reported, e.g. "-RA BR".
    """

    start: datetime
    end: datetime
    precip_mm: float | None
    station: str | None
    quality: str | None = None
    kind: str = "amount"
    weather: str | None = None


@dataclass
class ReadStats:
    """What a reader met on its way: rows read and the reasons rows gave no usable amount.

    Attributes
    ----------
    rows : int, data rows (lines, objects, messages) seen, header excluded.
    malformed : int, rows skipped because they could not be parsed (logged with line number).
    missing : int, intervals whose amount is missing (empty field, null) and kept as None.
    negative : int, negative amounts turned into None (Météo-France codes, gauge resets).
    duplicates : int, rows dropped because a row with the same station and start came first.
    other_stations : int, rows of other stations left out by the station filter.
    truncated : bool, the file (or its gzip stream) ended early; what came before is kept.
    first_malformed_line : int or None, 1-based line of the first malformed row.
    """

    rows: int = 0
    malformed: int = 0
    missing: int = 0
    negative: int = 0
    duplicates: int = 0
    other_stations: int = 0
    truncated: bool = False
    first_malformed_line: int | None = None


@dataclass
class ReadContext:
    """The options of one read and its counters; one per file.

    Attributes
    ----------
    name : str, the file name used in messages.
    station : str or None, keep only this station (None keeps all).
    tz : tzinfo, zone of naive time stamps (UTC unless told).
    interval_s : float or None, the interval length the caller imposes (generic CSV, gauge).
    month : tuple (year, month) or None, for METAR reports without a date prefix.
    time_column, amount_column : str or None, generic CSV: the columns to read, by name,
        when the file's names are not the usual ones.
    cumulative : bool, generic CSV: the amount column is a running total (a gauge's counter):
        each interval's amount is the difference, a counter reset giving the new count.
    stats : ReadStats
    """

    name: str
    station: str | None = None
    tz: tzinfo = UTC
    interval_s: float | None = None
    month: tuple[int, int] | None = None
    time_column: str | None = None
    amount_column: str | None = None
    cumulative: bool = False
    stats: ReadStats = field(default_factory=ReadStats)

    def error(self, reason: str, line: int | None = None) -> InputError:
        """An :class:`InputError` naming the file (and the line) in one line."""
        where = f"{self.name}:{line}" if line else self.name
        return InputError(f"{where}: {reason}")

    def bad_row(self, line: int, reason: str, *, unit: str = "line") -> None:
        """Count a malformed row and log it (the first few, each once).

        ``line`` is the 1-based line number (or object / message number, as ``unit`` says).
        """
        stats = self.stats
        stats.malformed += 1
        if stats.first_malformed_line is None:
            stats.first_malformed_line = line
        if stats.malformed <= MAX_LOGGED_BAD_ROWS:
            logger.warning("%s: %s %d: skipped malformed row: %s", self.name, unit, line, reason)
        elif stats.malformed == MAX_LOGGED_BAD_ROWS + 1:
            logger.warning("%s: more malformed rows; only counting them from now on", self.name)

    def wants(self, station: str | None) -> bool:
        """Whether a row of ``station`` passes the station filter (counts the others)."""
        if self.station is None or same_station(station, self.station):
            return True
        self.stats.other_stations += 1
        return False

    def amount(self, value: float | None) -> float | None:
        """``value`` as an amount in mm: None stays None (counted missing), negative -> None."""
        if value is None:
            self.stats.missing += 1
            return None
        if value < 0.0:
            self.stats.negative += 1
            return None
        return value

    def localise(self, naive: datetime) -> datetime:
        """A naive time stamp in ``tz`` as an aware UTC datetime (aware ones are converted)."""
        if naive.tzinfo is None:
            naive = naive.replace(tzinfo=self.tz)
        return naive.astimezone(UTC)


def same_station(a: str | None, b: str) -> bool:
    """Whether station ids ``a`` and ``b`` match: equal ignoring case and, when both are
    numbers, ignoring leading zeros (Météo-France ``01014002`` is also written ``1014002``)."""
    if a is None:
        return False
    a, b = a.strip(), b.strip()
    if a.isdigit() and b.isdigit():
        return int(a) == int(b)
    return a.upper() == b.upper()


def parse_tz(tz: str) -> tzinfo:
    """``"UTC"``, ``"Europe/Paris"`` ... as a tzinfo; InputError for an unknown zone."""
    if tz.upper() in ("UTC", "Z", "GMT"):
        return UTC
    try:
        return ZoneInfo(tz)
    except (ZoneInfoNotFoundError, ValueError) as err:
        raise InputError(f"unknown time zone {tz!r}") from err


def parse_number(text: str) -> float | None:
    """A decimal number with a point or a comma; None for an empty field or ``NaN``/``NA``
    (how loggers and pandas write a missing value).

    Raises ValueError for anything else (including infinities).
    """
    text = text.strip().strip('"')
    if not text or text.lower() in ("nan", "na", "n/a"):
        return None
    value = float(text.replace(",", "."))
    if not math.isfinite(value):
        raise ValueError(f"not a finite number: {text!r}")
    return value


def compact_stamp(text: str, ctx: ReadContext) -> datetime:
    """``AAAAMMJJHH`` or ``AAAAMMJJHHMN`` (Météo-France) as an aware UTC datetime.

    Raises ValueError when ``text`` is not 10 or 12 digits or not a valid date.
    """
    text = text.strip()
    if not text.isdigit() or len(text) not in (10, 12):
        raise ValueError(f"bad date {text!r}")
    minute = int(text[10:12]) if len(text) == 12 else 0
    naive = datetime(int(text[:4]), int(text[4:6]), int(text[6:8]), int(text[8:10]), minute)
    return ctx.localise(naive)


@contextmanager
def corrupt_stream_is_input_error(name: str) -> Iterator[None]:
    """A gzip stream damaged before any line could be read, as an InputError naming the file
    (:func:`iter_lines` keeps the lines before damage further on)."""
    try:
        yield
    except (EOFError, zlib.error, gzip.BadGzipFile) as err:
        raise InputError(f"{name}: corrupt compressed data ({err})") from None


@contextmanager
def open_binary(path: Path, name: str) -> Iterator[IO[bytes]]:
    """``path`` opened for reading bytes, transparently gunzipped when it starts like gzip."""
    try:
        raw = path.open("rb")
    except OSError as err:
        raise InputError(f"{name}: cannot open: {err.strerror or err}") from err
    with raw:
        head = raw.read(2)
        raw.seek(0)
        if head != GZIP_MAGIC:
            yield raw
            return
        with gzip.GzipFile(fileobj=raw, mode="rb") as unzipped:
            yield unzipped  # type: ignore[misc]


def iter_lines(binary: IO[bytes], ctx: ReadContext) -> Iterator[tuple[int, str]]:
    """(1-based line number, text without the line end) for each line of a text file.

    UTF-8 with or without a BOM (undecodable bytes are replaced, station names only hold
    them), LF or CRLF line ends. A gzip stream that ends early stops the lines and marks the
    read as truncated instead of failing, so the rows before the damage are kept.
    """
    text = io.TextIOWrapper(binary, encoding="utf-8-sig", errors="replace", newline=None)
    line = 0
    try:
        for line, raw_line in enumerate(text, start=1):
            yield line, raw_line.rstrip("\r\n")
    except (EOFError, zlib.error, gzip.BadGzipFile) as err:
        ctx.stats.truncated = True
        logger.warning("%s: compressed stream ends early after line %d (%s)", ctx.name, line, err)
    except OSError as err:
        raise ctx.error(f"read error after line {line}: {err}") from err


def finish(intervals: list[Interval], ctx: ReadContext) -> list[Interval]:
    """Sorted by start (then station), one interval per (station, start), the first kept."""
    intervals.sort(key=lambda iv: (iv.start, iv.station or ""))
    out: list[Interval] = []
    seen: set[tuple[str | None, datetime]] = set()
    for iv in intervals:
        key = (iv.station, iv.start)
        if key in seen:
            ctx.stats.duplicates += 1
            continue
        seen.add(key)
        out.append(iv)
    return out
