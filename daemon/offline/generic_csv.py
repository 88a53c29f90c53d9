"""Generic CSV of precipitation: a time column and an amount or a rate column.

Format (``csv``)
    One header line naming the columns, case-insensitive:

    - time: ``time``, ``date``, ``datetime`` or ``timestamp`` (the first present), ISO-8601
      (``2024-06-15T12:00:00Z``, ``2024-06-15T14:00+02:00``) or ``YYYY-MM-DD HH:MM[:SS]``;
      naive times are in ``tz`` (default UTC); a plain number in a ``timestamp`` column is
      Unix seconds (UTC). The time is the END of the interval.
    - an amount over the interval ending at the time, mm: ``precip_mm``, ``mm`` or ``rr``; or
      a rate, mm/h: ``rain_rate_mm_h`` or ``mm_h``, turned into the amount
      ``rate × interval_s / 3600``.
    - optional ``station`` (used by the station filter; without it every row belongs to the
      ``station`` option, which is then reported) and ``quality`` (reported as is).

    Separator ``,``, ``;`` or tab (the one the header uses most); decimal point or comma
    (``1,5`` in a ``;`` file); fields may be quoted. Empty amount = missing; negative -> None.
    The interval is ``interval_s`` when given, else the median spacing of the times (per
    station), so a file with a single time needs ``interval_s``.
"""

from __future__ import annotations

import csv
import statistics
from collections import defaultdict
from collections.abc import Iterable
from datetime import UTC, datetime, timedelta
from itertools import pairwise

from daemon.offline.reference_common import Interval, ReadContext, parse_number

__all__ = ["AMOUNT_COLUMNS", "RATE_COLUMNS", "TIME_COLUMNS", "read_generic_csv", "sniff_header"]

TIME_COLUMNS = ("time", "date", "datetime", "timestamp")
AMOUNT_COLUMNS = ("precip_mm", "mm", "rr")
RATE_COLUMNS = ("rain_rate_mm_h", "mm_h")
SEPARATORS = (",", ";", "\t")


def sniff_header(text: str) -> tuple[str, list[str]] | None:
    """(separator, lower-cased column names) when ``text`` is a generic CSV header, else None."""
    sep = max(SEPARATORS, key=text.count)
    if text.count(sep) == 0:
        return None
    names = [
        name.strip().strip('"').strip().lower() for name in next(csv.reader([text], delimiter=sep))
    ]
    has_time = any(name in names for name in TIME_COLUMNS)
    has_value = any(name in names for name in AMOUNT_COLUMNS + RATE_COLUMNS)
    return (sep, names) if has_time and has_value else None


def read_generic_csv(lines: Iterable[tuple[int, str]], ctx: ReadContext) -> list[Interval]:
    """Intervals of a generic CSV file (see the module docstring)."""
    lines = iter(lines)
    header_line, text = next(((n, t) for n, t in lines if t.strip()), (0, ""))
    if not header_line:
        raise ctx.error("empty file")
    sniffed = sniff_header(text)
    if sniffed is None:
        raise ctx.error(
            "header needs a time column (time/date/datetime/timestamp) and an amount "
            "(precip_mm/mm/rr) or rate (rain_rate_mm_h/mm_h) column",
            header_line,
        )
    sep, names = sniffed
    i_time = names.index(next(n for n in TIME_COLUMNS if n in names))
    amount_name = next((n for n in AMOUNT_COLUMNS if n in names), None)
    is_rate = amount_name is None
    i_value = names.index(amount_name or next(n for n in RATE_COLUMNS if n in names))
    i_station = names.index("station") if "station" in names else None
    i_quality = names.index("quality") if "quality" in names else None

    # (end, value, station, quality) per row; intervals once the spacing is known.
    rows: list[tuple[datetime, float | None, str | None, str | None]] = []
    for line, text in lines:
        if not text.strip():
            continue
        ctx.stats.rows += 1
        fields = next(csv.reader([text], delimiter=sep))
        if len(fields) != len(names):
            ctx.bad_row(line, f"{len(fields)} fields, the header has {len(names)}")
            continue
        station = (fields[i_station].strip() or None) if i_station is not None else ctx.station
        if i_station is not None and not ctx.wants(station):
            continue
        try:
            end = _parse_time(fields[i_time], ctx)
            value = parse_number(fields[i_value])
        except ValueError as err:
            ctx.bad_row(line, str(err))
            continue
        quality = (fields[i_quality].strip() or None) if i_quality is not None else None
        rows.append((end, value, station, quality))
    return _intervals(rows, ctx, is_rate=is_rate)


def _parse_time(text: str, ctx: ReadContext) -> datetime:
    text = text.strip()
    if not text:
        raise ValueError("empty time")
    try:
        seconds = float(text)
    except ValueError:
        return ctx.localise(datetime.fromisoformat(text))
    if seconds < 1e8:  # a bare number that is not a plausible Unix time (before 1973)
        raise ValueError(f"bad time {text!r}")
    return datetime.fromtimestamp(seconds, tz=UTC)


def _intervals(
    rows: list[tuple[datetime, float | None, str | None, str | None]],
    ctx: ReadContext,
    *,
    is_rate: bool,
) -> list[Interval]:
    steps: dict[str | None, timedelta] = {}
    if ctx.interval_s:
        fixed = timedelta(seconds=ctx.interval_s)
        steps = defaultdict(lambda: fixed)
    else:
        by_station: dict[str | None, list[datetime]] = defaultdict(list)
        for end, _, station, _ in rows:
            by_station[station].append(end)
        for station, ends in by_station.items():
            unique = sorted(set(ends))
            spacings = [(b - a).total_seconds() for a, b in pairwise(unique)]
            if not spacings:
                raise ctx.error(
                    f"cannot infer the interval from a single time (station {station}); "
                    "pass interval_s"
                )
            steps[station] = timedelta(seconds=statistics.median(spacings))
    out: list[Interval] = []
    for end, value, station, quality in rows:
        step = steps[station]
        if value is not None and is_rate:
            value = value * step.total_seconds() / 3600.0
        out.append(Interval(end - step, end, ctx.amount(value), station, quality))
    return out
