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

    Other names: ``time_column`` and ``amount_column`` (``--time-column``,
    ``--amount-column``) name the columns to read; when no column matches, the error lists the
    file's columns. ``cumulative`` (``--cumulative``): the amount is a running total, as a
    gauge's counter is, and each interval gets the difference from the row before (a drop is a
    counter reset: the new count; the first row has no amount).

    Separator ``,``, ``;`` or tab (the one the header uses most); a separator ending every
    line is ignored; decimal point or comma (``1,5`` in a ``;`` file); fields may be quoted.
    Lines starting with ``#`` are comments, before the header or after it. Times may also be
    ``dd.mm.yyyy HH:MM[:SS]``. Empty, ``NaN`` or ``NA`` amount = missing; negative -> None.
    The interval is ``interval_s`` when given, else the median spacing of the times (per
    station), so a file with a single time needs ``interval_s``.
"""

from __future__ import annotations

import csv
import re
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
DMY_RE = re.compile(r"^\d{1,2}\.\d{1,2}\.\d{4}[ T]\d{1,2}:\d{2}(?::\d{2})?$")


def sniff_header(text: str) -> tuple[str, list[str]] | None:
    """(separator, lower-cased column names) when ``text`` is a generic CSV header, else None."""
    sep = max(SEPARATORS, key=text.count)
    if text.count(sep) == 0:
        return None
    names = _names(text, sep)
    has_time = any(name in names for name in TIME_COLUMNS)
    has_value = any(name in names for name in AMOUNT_COLUMNS + RATE_COLUMNS)
    return (sep, names) if has_time and has_value else None


def _names(text: str, sep: str) -> list[str]:
    names = [
        name.strip().strip('"').strip().lower() for name in next(csv.reader([text], delimiter=sep))
    ]
    return names[:-1] if len(names) > 1 and names[-1] == "" else names  # a trailing separator


def _column(names: list[str], wanted: str | None, usual: tuple[str, ...]) -> int | None:
    if wanted is not None:
        return names.index(wanted.lower()) if wanted.lower() in names else None
    return next((names.index(n) for n in usual if n in names), None)


def read_generic_csv(lines: Iterable[tuple[int, str]], ctx: ReadContext) -> list[Interval]:
    """Intervals of a generic CSV file (see the module docstring)."""
    lines = (item for item in lines if item[1].strip() and not item[1].lstrip().startswith("#"))
    header_line, text = next(lines, (0, ""))
    if not header_line:
        raise ctx.error("empty file")
    sep = max(SEPARATORS, key=text.count)
    names = _names(text, sep)
    i_time = _column(names, ctx.time_column, TIME_COLUMNS)
    amount = _column(names, ctx.amount_column, AMOUNT_COLUMNS)
    rate = None if ctx.amount_column else _column(names, None, RATE_COLUMNS)
    if i_time is None or (amount is None and rate is None):
        wanted = (
            f"{ctx.time_column or '/'.join(TIME_COLUMNS)} and "
            f"{ctx.amount_column or '/'.join(AMOUNT_COLUMNS + RATE_COLUMNS)}"
        )
        raise ctx.error(
            f"no {wanted} column; the file has: {', '.join(names)} (name them with "
            "--time-column and --amount-column)",
            header_line,
        )
    is_rate = amount is None
    i_value = rate if is_rate else amount
    i_station = names.index("station") if "station" in names else None
    i_quality = names.index("quality") if "quality" in names else None

    # (end, value, station, quality) per row; intervals once the spacing is known.
    rows: list[tuple[datetime, float | None, str | None, str | None]] = []
    for line, text in lines:
        ctx.stats.rows += 1
        fields = next(csv.reader([text], delimiter=sep))
        if len(fields) == len(names) + 1 and not fields[-1].strip():
            fields.pop()  # a trailing separator
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
    if ctx.cumulative:
        rows = _differences(rows)
    return _intervals(rows, ctx, is_rate=is_rate)


def _differences(
    rows: list[tuple[datetime, float | None, str | None, str | None]],
) -> list[tuple[datetime, float | None, str | None, str | None]]:
    """A running total's rows as amounts per interval: the difference from the station's row
    before; a drop is a counter reset (the new count); the first row, or one after a missing
    total, has no amount."""
    out = []
    last: dict[str | None, float | None] = {}
    for end, total, station, quality in sorted(rows, key=lambda r: (r[2] or "", r[0])):
        before = last.get(station)
        amount = None
        if total is not None and before is not None:
            amount = total - before if total >= before else total
        last[station] = total
        out.append((end, None if amount is None else round(amount, 6), station, quality))
    return out


def _parse_time(text: str, ctx: ReadContext) -> datetime:
    text = text.strip()
    if not text:
        raise ValueError("empty time")
    if DMY_RE.match(text):  # dd.mm.yyyy HH:MM[:SS], as German and Swiss loggers write it
        stamp = datetime.strptime(
            text, "%d.%m.%Y %H:%M:%S" if text.count(":") == 2 else "%d.%m.%Y %H:%M"
        )
        return ctx.localise(stamp)
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
