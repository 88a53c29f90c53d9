"""A home weather station's archive as weewx keeps it (Davis Vantage and the other stations
weewx drives): the SQLite database, or its ``archive`` table exported as CSV.

Format (``weewx``; field descriptions: weewx's "Customization guide", section "The
database", and "Units" reference, in the weewx repository ``docs_src/``)

``weewx.sdb`` — the SQLite database weewx writes (``/var/lib/weewx/weewx.sdb``)
    its ``archive`` table: one row per archive interval, ``dateTime`` = "the time at the
    END of the archive interval in unix epoch time", ``interval`` = "the length of the
    archive interval in minutes", ``usUnits`` = the unit system of the row, ``rain`` = the
    rain fallen during the interval (weewx's ``group_rain``) in that system's unit:
    ``1`` (US) inches, ``16`` (METRIC) cm, ``17`` (METRICWX) mm. So a row is the interval
    ``[dateTime - interval min, dateTime)``, in UTC (epoch seconds have no zone; ``tz`` is not
    used), its amount converted to mm. NULL = missing.
CSV export of that table — e.g. ``sqlite3 -header -csv weewx.sdb "SELECT * FROM archive"``
    a header naming at least ``dateTime``, ``usUnits``, ``interval`` and ``rain`` (any case,
    any order, ``,``, ``;`` or tab), the values as above; empty, ``NULL``, ``None`` or
    ``NaN`` = missing.

Rows carry no station: every row is the ``station`` option's, reported as such. A row with an
unknown ``usUnits``, a non-positive ``interval`` or a value that does not parse is skipped as
malformed. The SQLite file is read into memory whole (a decade of 5-minute rows is about
100 MB).
"""

from __future__ import annotations

import csv
import sqlite3
from collections.abc import Iterable
from contextlib import closing
from datetime import UTC, datetime, timedelta
from typing import IO

from daemon.offline.reference_common import Interval, ReadContext, iter_lines, parse_number

__all__ = ["SQLITE_MAGIC", "looks_like_weewx_csv", "read_weewx", "read_weewx_binary"]

SQLITE_MAGIC = b"SQLite format 3\x00"
#: usUnits -> mm per unit of rain
MM_PER_UNIT = {1: 25.4, 16: 10.0, 17: 1.0}
NAMES = ("dateTime", "usUnits", "interval", "rain")
COLUMNS = tuple(name.lower() for name in NAMES)
SEPARATORS = (",", ";", "\t")


def looks_like_weewx_csv(first_line: str) -> bool:
    """Whether ``first_line`` is the header of a weewx archive CSV."""
    sep = max(SEPARATORS, key=first_line.count)
    names = {n.strip().strip('"').lower() for n in first_line.split(sep)}
    return set(COLUMNS) <= names


def read_weewx_binary(binary: IO[bytes], ctx: ReadContext) -> list[Interval]:
    """Intervals of a weewx SQLite database or archive CSV (see the module docstring)."""
    head = binary.read(len(SQLITE_MAGIC))
    binary.seek(0)
    if head == SQLITE_MAGIC:
        return _read_sqlite(binary.read(), ctx)
    return read_weewx(iter_lines(binary, ctx), ctx)


def read_weewx(lines: Iterable[tuple[int, str]], ctx: ReadContext) -> list[Interval]:
    """Intervals of a weewx archive table exported as CSV."""
    lines = iter(lines)
    for _, text in lines:
        if text.strip():
            sep = max(SEPARATORS, key=text.count)
            header = [n.strip().strip('"').lower() for n in text.split(sep)]
            break
    else:
        raise ctx.error("empty file")
    missing = [name for name in NAMES if name.lower() not in header]
    if missing:
        raise ctx.error(
            f"weewx archive CSV without {', '.join(missing)}; it has {', '.join(header)}", 1
        )
    index = [header.index(name) for name in COLUMNS]
    out: list[Interval] = []
    for line, text in lines:
        if not text.strip():
            continue
        ctx.stats.rows += 1
        try:
            fields = next(csv.reader([text], delimiter=sep))
        except csv.Error as err:
            ctx.bad_row(line, f"not CSV: {err}")
            continue
        if len(fields) != len(header):
            ctx.bad_row(line, f"{len(fields)} fields, the header has {len(header)}")
            continue
        _add(out, [_cell(fields[i]) for i in index], line, ctx)
    return out


def _read_sqlite(data: bytes, ctx: ReadContext) -> list[Interval]:
    out: list[Interval] = []
    try:
        with closing(sqlite3.connect(":memory:")) as db:
            db.deserialize(data)
            names = {row[1].lower() for row in db.execute("PRAGMA table_info(archive)")}
            missing = [name for name in NAMES if name.lower() not in names]
            if missing:
                raise ctx.error(f"weewx database without archive.{', archive.'.join(missing)}")
            rows = db.execute(
                "SELECT dateTime, usUnits, interval, rain FROM archive ORDER BY dateTime"
            )
            for number, row in enumerate(rows, start=1):
                ctx.stats.rows += 1
                _add(out, list(row), number, ctx, unit="row")
    except sqlite3.Error as err:
        raise ctx.error(f"not a readable weewx database: {err}") from None
    return out


def _cell(text: str) -> str | None:
    text = text.strip()
    return None if text.upper() in ("", "NULL", "NONE") else text


def _add(out: list[Interval], row: list, number: int, ctx: ReadContext, unit="line") -> None:
    """One archive row (dateTime, usUnits, interval, rain) as an interval."""
    stamp, units, minutes, rain = row
    try:
        end = datetime.fromtimestamp(_number(stamp, "dateTime"), tz=UTC)
        factor = MM_PER_UNIT.get(int(_number(units, "usUnits")))
        if factor is None:
            raise ValueError(f"usUnits {units!r} is not 1 (US), 16 (METRIC) or 17 (METRICWX)")
        length = _number(minutes, "interval")
        if not 0 < length <= 1440:
            raise ValueError(f"interval {minutes!r} is not 1-1440 minutes")
        value = None if rain is None else parse_number(str(rain))
    except (ValueError, OverflowError, OSError) as err:
        ctx.bad_row(number, str(err), unit=unit)
        return
    mm = None if value is None else round(value * factor, 4)
    station = ctx.station
    out.append(Interval(end - timedelta(minutes=length), end, ctx.amount(mm), station))


def _number(value: object, name: str) -> float:
    if value is None or isinstance(value, bytes):
        raise ValueError(f"{name} is missing")
    number = parse_number(str(value))
    if number is None:
        raise ValueError(f"{name} is missing")
    return number
