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
    when that puts the report closer to the date (a 312350Z report filed at 0000 on the 1st).
    Times are UTC. A trailing ``=`` is ignored; blank lines and ``#`` comments are skipped.

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


def looks_like_metar(texts: Iterable[str]) -> bool:
    """Whether most non-blank lines of ``texts`` (the head of a file) are METAR reports."""
    hits = total = 0
    for text in texts:
        text = text.strip()
        if not text or text.startswith("#") or NOAA_DATE_RE.match(text):
            continue
        total += 1
        hits += bool(REPORT_RE.match(_split_date(text)[1]))
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
    pending: datetime | None = None
    year_month = ctx.month
    for line, raw in lines:
        text = raw.strip()
        if not text or text.startswith("#"):
            continue
        noaa = NOAA_DATE_RE.match(text)
        if noaa:
            pending = datetime(*map(int, noaa.groups()), tzinfo=UTC)
            continue
        ctx.stats.rows += 1
        date, code = _split_date(text)
        date, pending = date or pending, None
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
    if metar.mod == "NO DATA":
        return _Report(line, time, metar.station_id, None, None)
    value, weather = presence(metar.weather, getattr(metar, "_unparsed_groups", ()))
    return _Report(line, time, metar.station_id, value, weather)


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
