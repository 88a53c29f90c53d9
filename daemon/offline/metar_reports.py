"""METAR reports as reference data: presence and type of precipitation, not amounts.

Format (``metar``)
    One report per line, decoded with the ``metar`` package (``metar.Metar.Metar``). A line
    may carry a date, which the report itself lacks (its ``ddhhmmZ`` group has no month or
    year):

    - ``YYYYMMDDHHMM METAR LFPG 161200Z …=`` (ogimet / NOAA archive lines);
    - ``LFPG,2024,10,16,12,00,METAR LFPG 161200Z …=`` (ogimet CSV);
    - a line ``2024/10/16 12:00`` followed by the report (NOAA station files);
    - a bare report: the year and month come from the last dated line, else from the ``month``
      option (``"YYYY-MM"``); without either the file is refused (a guess from today's date
      would make the output depend on when it is read).

    The report's own day and time are used, with the date's month — or the neighbouring month
    when that puts the report closer to the date (a 312350Z report filed at 0000 on the 1st);
    with only ``month``, a day the month lacks (31 in a 30-day month) is the previous month's
    end. Times are UTC. Blank lines and ``#`` comments are skipped.

    A report may run over several lines, up to its ``=`` or the next report; NWS
    collectives (a ``\x01`` start, a WMO heading such as ``SAUS70 KWBC 161200``, a ``METAR``
    line, reports over several lines, ``\x03`` at the end) are read that way. A correction
    (``COR``) for a time already reported replaces the earlier report; another report for the
    same time is a duplicate. An automated station without a precipitation sensor (``AO1`` in
    its remarks) that reports no weather group says nothing about precipitation: None.

Output
    ``kind="presence"``; ``precip_mm`` is 1.0 when a present-weather group shows falling
    precipitation at the station (DZ, RA, SN, SG, IC, PL, GR, GS, UP, or showers ``SH``, with
    any intensity or descriptor, e.g. ``-RA``, ``+SHSN``, ``FZDZ``, ``TSGR``), 0.0 when none
    does, None when it cannot be told (a ``//`` group, an undecoded group that looks like
    precipitation, a ``NIL`` report). Not counted as precipitation at the station: vicinity
    groups (``VCSH``), blowing or drifting snow alone (``BLSN``, ``DRSN``: snow raised by the
    wind), recent weather (``RERA``). ``weather`` holds every present-weather group as
    reported, e.g. ``"-RA BR"`` (None when there is none). Each report covers the time from
    itself to the next report of the same station, capped at 1 h; the last report covers the
    station's median spacing (capped at 1 h; 30 min for a lone report).
"""

from __future__ import annotations

import calendar
import re
import statistics
import warnings
from collections import defaultdict
from collections.abc import Iterable
from dataclasses import dataclass
from datetime import UTC, datetime, timedelta
from itertools import pairwise

from metar.Metar import Metar

from daemon.offline.reference_common import Interval, ReadContext

__all__ = ["looks_like_metar", "presence", "read_metar"]

REPORT_RE = re.compile(r"^(?:(?:METAR|SPECI)\s+)?(?:COR\s+)?[A-Z][A-Z0-9]{3}\s+(\d{6})Z(?:\s|$)")
PREFIX_RE = re.compile(r"^(\d{12})\s+(\S.*)$")
OGIMET_CSV_RE = re.compile(r"^[A-Z0-9]{4},(\d{4}),(\d\d),(\d\d),(\d\d),(\d\d),(.+)$")
NOAA_DATE_RE = re.compile(r"^(\d{4})/(\d\d)/(\d\d) (\d\d):(\d\d)$")
PRECIP_TYPES_RE = re.compile(r"DZ|RA|SN|SG|IC|PL|GR|GS|UP")
MAX_COVER = timedelta(hours=1)
LONE_COVER = timedelta(minutes=30)
MAX_DATE_GAP = timedelta(days=15)


@dataclass(frozen=True)
class _Report:
    line: int
    time: datetime
    station: str
    precip: float | None
    weather: str | None
    correction: bool = False


#: What a bulletin wraps its reports in: its control characters, WMO heading, ``METAR`` or
#: ``SPECI`` line, sequence number.
CONTROL_RE = re.compile(r"[\x00-\x08\x0b-\x1f]")
HEADING_RE = re.compile(r"^(?:[A-Z]{4}\d{2}\s+[A-Z]{4}\s+\d{6}(?:\s+\w{3})?|METAR|SPECI|\d{1,4})$")
AO1_RE = re.compile(r"\bAO1\b")


def looks_like_metar(texts: Iterable[str]) -> bool:
    """Whether most non-blank lines of ``texts`` (the head of a file) are METAR reports."""
    hits = total = 0
    for _, _, code in _assemble(enumerate(texts, start=1)):  # reports over lines count once
        total += 1
        hits += bool(REPORT_RE.match(code))
    return total > 0 and hits * 2 >= total


def presence(weather: list[tuple], unparsed: Iterable[str] = ()) -> tuple[float | None, str | None]:
    """(1.0 / 0.0 / None, groups text) from ``Metar.weather`` tuples (see the module docstring).

    Parameters
    ----------
    weather : list of (intensity, descriptor, precipitation, obscuration, other) tuples
    unparsed : groups of the report body the decoder did not understand
    """
    groups: list[str] = []
    observed = unknown = False
    for intensity, descriptor, precip, obscuration, other in weather:
        parts = (intensity, descriptor, precip, obscuration, other)
        groups.append("".join(part or "" for part in parts))
        intensity, descriptor, precip = intensity or "", descriptor or "", precip or ""
        if "VC" in intensity:
            continue
        types = precip.replace("/", "")
        if precip and not types:
            unknown = True
        elif types and descriptor in ("BL", "DR"):
            continue
        elif types or "SH" in descriptor:
            observed = True
    if any(PRECIP_TYPES_RE.search(group) for group in unparsed):
        unknown = True
    value = 1.0 if observed else (None if unknown else 0.0)
    return value, " ".join(groups) or None


def read_metar(lines: Iterable[tuple[int, str]], ctx: ReadContext) -> list[Interval]:
    """Presence intervals of a file of METAR reports (see the module docstring)."""
    reports: dict[str, list[_Report]] = defaultdict(list)
    year_month = ctx.month
    for line, date, code in _assemble(lines):
        ctx.stats.rows += 1
        if date is not None:
            year_month = (date.year, date.month)
        if year_month is None:
            raise ctx.error(
                "METAR report without a date: prefix reports with YYYYMMDDHHMM or give the "
                "month (YYYY-MM)",
                line,
            )
        try:
            report = _decode(code.rstrip("= ").strip(), year_month, date, line)
        except ValueError as err:
            ctx.bad_row(line, str(err))
            continue
        if ctx.wants(report.station):
            reports[report.station].append(report)
    out: list[Interval] = []
    for station_reports in reports.values():
        out.extend(_cover(station_reports, ctx))
    return out


def _assemble(lines: Iterable[tuple[int, str]]) -> Iterable[tuple[int, datetime | None, str]]:
    """(first line, date or None, report text) of each report, joined over its lines."""
    pending: datetime | None = None
    current: list | None = None  # [line, date, text]
    for line, raw in lines:
        text = " ".join(CONTROL_RE.sub(" ", raw).split())
        if not text or text.startswith("#"):  # bulletins end lines CR CR LF: blank lines
            continue
        noaa = NOAA_DATE_RE.match(text)
        if noaa:
            pending = datetime(*map(int, noaa.groups()), tzinfo=UTC)
            continue
        date, code = _split_date(text)
        if REPORT_RE.match(code):
            if current is not None:
                yield tuple(current)
            current = [line, date or pending, code]
            pending = None
        elif current is not None and not current[2].endswith("="):
            current[2] += " " + text  # the report goes on
            continue
        elif current is None and HEADING_RE.match(text):
            continue  # a bulletin's heading
        else:
            if current is not None:
                yield tuple(current)
            current = [line, date or pending, code]  # not a report: _decode says so
            pending = None
        if current[2].endswith("="):
            yield tuple(current)
            current = None
    if current is not None:
        yield tuple(current)


def _split_date(text: str) -> tuple[datetime | None, str]:
    """(date from a prefix or None, the report) of one line."""
    prefix = PREFIX_RE.match(text)
    if prefix:
        stamp = prefix.group(1)
        try:
            date = datetime.strptime(stamp, "%Y%m%d%H%M").replace(tzinfo=UTC)
        except ValueError:
            return None, text
        return date, prefix.group(2)
    ogimet = OGIMET_CSV_RE.match(text)
    if ogimet:
        try:
            date = datetime(*map(int, ogimet.groups()[:5]), tzinfo=UTC)
        except ValueError:
            return None, text
        return date, ogimet.group(6)
    return None, text


def _decode(code: str, year_month: tuple[int, int], date: datetime | None, line: int) -> _Report:
    """One report decoded; ValueError when it has no station or time."""
    match = REPORT_RE.match(code)
    if not match:
        raise ValueError(f"not a METAR report: {code[:40]!r}")
    if date is not None:
        year_month = _month_near(match.group(1), date)
    elif int(match.group(1)[:2]) > calendar.monthrange(*year_month)[1]:
        index = year_month[0] * 12 + year_month[1] - 2  # a day the month lacks: the one before
        year_month = (index // 12, index % 12 + 1)
    year, month = year_month
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            metar = Metar(code, month=month, year=year, strict=False)
        except Exception as err:  # the decoder's own failures: the row is malformed
            raise ValueError(f"undecodable METAR: {err}") from err
    if metar.station_id is None or metar.time is None:
        raise ValueError(f"undecodable METAR: {code[:40]!r}")
    time = metar.time.replace(tzinfo=UTC)
    correction = bool(re.search(r"\bCOR\b", code.split("RMK")[0]))
    if metar.mod == "NO DATA":
        return _Report(line, time, metar.station_id, None, None, correction)
    value, weather = presence(metar.weather, getattr(metar, "_unparsed_groups", ()))
    if value == 0.0 and weather is None and AO1_RE.search(code):
        value = None  # an AO1 station has no sensor that could say "no precipitation"
    return _Report(line, time, metar.station_id, value, weather, correction)


def _month_near(ddhhmm: str, date: datetime) -> tuple[int, int]:
    """(year, month) that puts the report's ``ddhhmm`` nearest ``date`` (its month or the next
    or previous one); ValueError when none is within 15 days."""
    day, hour, minute = int(ddhhmm[:2]), int(ddhhmm[2:4]), int(ddhhmm[4:])
    best: tuple[timedelta, tuple[int, int]] | None = None
    for shift in (0, -1, 1):
        index = date.year * 12 + date.month - 1 + shift
        year, month = index // 12, index % 12 + 1
        try:
            gap = abs(datetime(year, month, day, hour, minute, tzinfo=UTC) - date)
        except ValueError:
            continue
        if gap <= MAX_DATE_GAP and (best is None or gap < best[0]):
            best = (gap, (year, month))
    if best is None:
        raise ValueError(f"report time {ddhhmm}Z does not match the date {date:%Y-%m-%d %H:%M}")
    return best[1]


def _cover(reports: list[_Report], ctx: ReadContext) -> list[Interval]:
    """Intervals of one station's reports: each until the next, capped at 1 h."""
    reports = sorted(reports, key=lambda r: r.time)
    unique: list[_Report] = []
    for report in reports:
        if unique and unique[-1].time == report.time:
            ctx.stats.duplicates += 1
            if report.correction:  # a later correction replaces what it corrects
                unique[-1] = report
            continue
        unique.append(report)
    times = [r.time for r in unique]
    spacings = [min(b - a, MAX_COVER) for a, b in pairwise(times)]
    last = statistics.median(spacings) if spacings else LONE_COVER
    out = []
    for i, report in enumerate(unique):
        cover = spacings[i] if i < len(spacings) else last
        if report.precip is None:
            ctx.stats.missing += 1
        out.append(
            Interval(
                report.time,
                report.time + cover,
                report.precip,
                report.station,
                kind="presence",
                weather=report.weather,
            )
        )
    return out
