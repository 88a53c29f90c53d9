"""NOAA/NCEI station data: Global Hourly (ISD) CSV and Local Climatological Data (LCD) CSV.

Formats (field descriptions: NCEI's "Federal Climate Complex Data Documentation for Integrated
Surface Data" (ISD format document) and the LCD documentation; a sample in
``tests/daemon/offline/data/``, PROVENANCE.md)

``noaa-isd`` — Global Hourly / ISD as CSV, from NCEI's access service or the
``/data/global-hourly/access/<year>/<station>.csv`` files
    ``,``-separated, every field quoted, header ``"STATION","DATE","SOURCE",…,"REPORT_TYPE",
    …,"AA1","AA2",…``. ``DATE`` is the observation time in UTC (ISO ``2019-01-05T22:00:00``;
    the ISD document: "the time of a GEOPHYSICAL-POINT-OBSERVATION based on Coordinated
    Universal Time"). ``AA1``…``AA4`` are the LIQUID-PRECIPITATION groups
    ``"period,depth,condition,quality"``: the period in hours ("the quantity of time over
    which the LIQUID-PRECIPITATION was measured", 99 = missing), the depth in 0.1 mm
    (9999 = missing), a condition code (``2`` = trace; ``1`` = measurement impossible or
    inaccurate; ``9`` = missing) and an ISD quality code (``0``/``1``/``4``/``5``/``9``
    passed the checks, ``2``/``6`` suspect, ``3``/``7`` erroneous, letters: NCEI edits),
    reported as ``quality``. A group covers the ``period`` hours ENDING at ``DATE``:
    ``[DATE - period, DATE)`` — the real sample's 24-hour group of 0.4 mm stamped
    ``2019-01-05T22:00`` repeats the SYNOP ``69944`` (6RRRtR: 0.4 mm over the 24 h before
    the report) in the same row's ``REM``. One station reports several periods (6 h at 00/06/
    12/18, 24 h once a day, 1 h in METARs) that overlap: one period is read per file, the
    shortest present, or the one ``interval_s`` names (``--interval 86400`` for the 24-hour
    groups); the others are counted and logged. Rows of ``REPORT_TYPE`` ``FM-16`` (special
    METARs, between the routine ones) are skipped: their hour overlaps the routine report's.
    A group overlapping the one before it at the same station is dropped as a duplicate.
    Trace -> 0.0 with ``quality="trace"``; condition 1, depth 9999 -> missing.
``noaa-lcd`` — Local Climatological Data CSV (``LCD_…csv``, NCEI's "LCD" product)
    header ``"STATION","DATE","REPORT_TYPE",…,"HourlyPrecipitation",…``. ``DATE`` is in
    LOCAL STANDARD TIME, all year (the LCD documentation: "Given in LST"): pass ``tz`` as a
    fixed offset, e.g. ``Etc/GMT+5`` for US Eastern standard time (POSIX signs: ``+5`` is
    UTC-5); a zone with summer time, or no ``tz`` at all, is refused. ``HourlyPrecipitation``
    is "the amount of precipitation in inches to hundredths over the past hour": only the
    routine hourly rows (``REPORT_TYPE`` ``FM-15``) are read, each the hour ENDING at its
    time, ``[DATE - 1 h, DATE)``. ``T`` (trace) -> 0.0 with ``quality="trace"``; a value with
    an ``s`` suffix (suspect) is kept with ``quality="suspect"``; ``M`` or empty -> missing.
    Inches are converted to mm (× 25.4).
"""

from __future__ import annotations

import csv
import logging
import re
from collections import Counter
from collections.abc import Iterable, Iterator
from datetime import UTC, datetime, timedelta

from daemon.offline.reference_common import Interval, ReadContext

__all__ = ["isd_or_lcd", "read_isd", "read_lcd"]

logger = logging.getLogger(__name__)

AA_RE = re.compile(r"^AA[1-4]$")
HOUR = timedelta(hours=1)
MM_PER_INCH = 25.4
LCD_AMOUNT_RE = re.compile(r"^(\d+(?:\.\d+)?)(s?)$")


def isd_or_lcd(first_line: str) -> str | None:
    """``"noaa-isd"`` or ``"noaa-lcd"`` when ``first_line`` is such a CSV header, else None."""
    names = {n.strip().strip('"').upper() for n in first_line.split(",")}
    if "DATE" not in names:
        return None
    if "HOURLYPRECIPITATION" in names:
        return "noaa-lcd"
    if any(AA_RE.match(n) for n in names) or {"REPORT_TYPE", "QUALITY_CONTROL"} <= names:
        return "noaa-isd"
    return None


def read_isd(lines: Iterable[tuple[int, str]], ctx: ReadContext) -> list[Interval]:
    """Intervals of a Global Hourly (ISD) CSV (see the module docstring)."""
    rows, header = _rows(lines, ctx)
    aa = [i for i, name in enumerate(header) if AA_RE.match(name)]
    if not aa or "DATE" not in header:
        raise ctx.error(
            "Global Hourly CSV without DATE or an AA1 (liquid precipitation) column; "
            f"it has {', '.join(header)}",
            1,
        )
    i_date, i_station = header.index("DATE"), _index(header, "STATION")
    i_type = _index(header, "REPORT_TYPE")
    groups: list[tuple[str | None, datetime, int, float | None, str | None]] = []
    specials = 0
    for line, fields in rows:
        station = fields[i_station].strip() if i_station is not None else None
        if not ctx.wants(station):
            continue
        if i_type is not None and fields[i_type].strip() == "FM-16":
            specials += 1
            continue
        try:
            end = _utc(fields[i_date])
            found = [_aa(fields[i]) for i in aa if fields[i].strip()]
        except ValueError as err:
            ctx.bad_row(line, str(err))
            continue
        groups += [(station or None, end, hours, mm, q) for hours, mm, q in found]
    if specials:
        logger.info("%s: skipped %d special (FM-16) reports", ctx.name, specials)
    return _one_period(groups, ctx)


def read_lcd(lines: Iterable[tuple[int, str]], ctx: ReadContext) -> list[Interval]:
    """Intervals of a Local Climatological Data CSV (see the module docstring)."""
    _require_standard_time(ctx)
    rows, header = _rows(lines, ctx)
    missing = [n for n in ("DATE", "HOURLYPRECIPITATION") if n not in header]
    if missing:
        raise ctx.error(f"LCD CSV without {', '.join(missing)}; it has {', '.join(header)}", 1)
    i_date, i_amount = header.index("DATE"), header.index("HOURLYPRECIPITATION")
    i_station, i_type = _index(header, "STATION"), _index(header, "REPORT_TYPE")
    out: list[Interval] = []
    for line, fields in rows:
        station = fields[i_station].strip() if i_station is not None else None
        if not ctx.wants(station):
            continue
        if i_type is not None and fields[i_type].strip() != "FM-15":
            continue
        try:
            end = ctx.localise(datetime.fromisoformat(fields[i_date].strip()))
            value, quality = _lcd_amount(fields[i_amount])
        except ValueError as err:
            ctx.bad_row(line, str(err))
            continue
        out.append(Interval(end - HOUR, end, ctx.amount(value), station or None, quality))
    return out


def _rows(
    lines: Iterable[tuple[int, str]], ctx: ReadContext
) -> tuple[Iterator[tuple[int, list[str]]], list[str]]:
    lines = iter(lines)
    for _, text in lines:
        if text.strip():
            header = [n.strip().upper() for n in next(csv.reader([text]))]
            break
    else:
        raise ctx.error("empty file")

    def rows() -> Iterator[tuple[int, list[str]]]:
        for line, text in lines:
            if not text.strip():
                continue
            ctx.stats.rows += 1
            try:
                fields = next(csv.reader([text]))
            except csv.Error as err:
                ctx.bad_row(line, f"not CSV: {err}")
                continue
            if len(fields) != len(header):
                ctx.bad_row(line, f"{len(fields)} fields, the header has {len(header)}")
                continue
            yield line, fields

    return rows(), header


def _index(header: list[str], name: str) -> int | None:
    return header.index(name) if name in header else None


def _utc(text: str) -> datetime:
    stamp = datetime.fromisoformat(text.strip())
    if stamp.tzinfo is None:
        return stamp.replace(tzinfo=UTC)
    return stamp.astimezone(UTC)


def _aa(text: str) -> tuple[int, float | None, str | None]:
    """One AAn group: (period h, mm or None, quality)."""
    parts = [p.strip() for p in text.split(",")]
    if len(parts) != 4 or not parts[0].isdigit() or not parts[1].isdigit():
        raise ValueError(f"AA group {text!r} is not period,depth,condition,quality")
    period, depth, condition, quality = int(parts[0]), int(parts[1]), parts[2], parts[3]
    if period in (0, 99):
        raise ValueError(f"AA group {text!r} has no period")
    if condition == "2":
        return period, 0.0, "trace"
    if depth == 9999 or condition == "1":
        return period, None, quality or None
    return period, depth / 10.0, quality or None


def _one_period(
    groups: list[tuple[str | None, datetime, int, float | None, str | None]], ctx: ReadContext
) -> list[Interval]:
    periods = Counter(hours for _, _, hours, _, _ in groups)
    if not periods:
        return []
    if ctx.interval_s is not None:
        chosen = round(ctx.interval_s / 3600)
        if chosen not in periods:
            listed = ", ".join(f"{h} h" for h in sorted(periods))
            raise ctx.error(f"no {ctx.interval_s:g} s precipitation groups (the file has {listed})")
    else:
        chosen = min(periods)
    others = {h: n for h, n in periods.items() if h != chosen}
    if others:
        logger.info(
            "%s: read the %d-hour precipitation groups; left out %s (choose with interval_s)",
            ctx.name,
            chosen,
            ", ".join(f"{n} of {h} h" for h, n in sorted(others.items())),
        )
    step = timedelta(hours=chosen)
    kept = sorted(
        ((station, end, mm, q) for station, end, hours, mm, q in groups if hours == chosen),
        key=lambda g: (g[0] or "", g[1]),
    )
    out: list[Interval] = []
    last_end: dict[str | None, datetime] = {}
    for station, end, mm, quality in kept:
        start = end - step
        if station in last_end and start < last_end[station]:
            ctx.stats.duplicates += 1
            continue
        last_end[station] = end
        out.append(Interval(start, end, ctx.amount(mm), station, quality))
    return out


def _lcd_amount(text: str) -> tuple[float | None, str | None]:
    text = text.strip()
    if text in ("", "M"):
        return None, None
    if text in ("T", "Ts"):
        return 0.0, "trace"
    match = LCD_AMOUNT_RE.match(text)
    if match is None:
        raise ValueError(f"HourlyPrecipitation {text!r} is not inches, T or M")
    return round(float(match.group(1)) * MM_PER_INCH, 3), "suspect" if match.group(2) else None


def _require_standard_time(ctx: ReadContext) -> None:
    jan, jul = datetime(2021, 1, 15), datetime(2021, 7, 15)
    offsets = {ctx.tz.utcoffset(jan), ctx.tz.utcoffset(jul)}
    if len(offsets) > 1:
        raise ctx.error(
            "LCD times are local STANDARD time all year: give tz as a fixed offset "
            "(e.g. Etc/GMT+5 for UTC-5), not a zone with summer time"
        )
    if offsets == {timedelta(0)}:
        raise ctx.error(
            "LCD times are the station's local standard time: pass its offset as tz "
            "(e.g. --tz Etc/GMT+5 for UTC-5)"
        )
