"""KNMI (Royal Netherlands Meteorological Institute) station data: hourly and daily files.

Format (``knmi``; field descriptions: the legend KNMI writes at the top of every file; samples
in ``tests/daemon/offline/data/``, PROVENANCE.md)

``uurgeg_<stn>_<period>.txt`` — "uurgegevens", the hourly files of the KNMI climatology pages,
and the same columns from the KNMI "daggegevens/uurgegevens" script export
    A legend (lines starting ``#`` in the script export, plain text in the ``uurgeg`` files;
    their first line reads ``BRON: KONINKLIJK NEDERLANDS METEOROLOGISCH INSTITUUT (KNMI)``,
    the export's ``# SOURCE: ROYAL NETHERLANDS METEOROLOGICAL INSTITUTE (KNMI)``), then the
    header ``# STN,YYYYMMDD,   HH,   DD,…,   RH,…`` and ``,``-separated rows padded with
    blanks: ``  260,20000101,    5,…,    4,…``. ``STN`` is the station, ``YYYYMMDD`` the
    date, ``HH`` the hour 1–24. The legend says (in both languages) "HH = tijd (HH=uur,
    UT. 12 UT=13 MET, 14 MEZT. Uurvak 05 loopt van 04.00 UT tot 5.00 UT": times are UT, and
    the row ``HH`` covers the hour ENDING at ``HH``: the interval is ``[date + (HH-1) h,
    date + HH h)`` UTC, ``HH = 24`` ending at midnight of the next day. ``RH`` is "Uursom van
    de neerslag (in 0.1 mm) (-1 voor <0.05 mm) / Hourly precipitation amount (in 0.1 mm) (-1
    for <0.05 mm)": amounts are tenths of a mm; ``-1`` (less than 0.05 mm) becomes 0.0 with
    ``quality="trace"``; an empty field (stations without a gauge, e.g. IJmond 209) is
    missing.
``etmgeg_<stn>.txt`` / daily script export — "daggegevens"
    the same layout without ``HH``: ``RH`` is then "Etmaalsom van de neerslag (in 0.1 mm)
    (-1 voor <0.05 mm)", the UT day ``[date 00 UT, date + 1 day 00 UT)``.

The legend can be long (about 30 lines): the header is the first line that, without its
``#``, starts ``STN,YYYYMMDD``; the rows after it are read, ``#`` lines and blank lines
skipped. Times are UT by the legend, so ``tz`` is not used. A row with fewer fields than the
header's, or a date, hour or amount that does not parse, is skipped as malformed.
"""

from __future__ import annotations

from collections.abc import Iterable
from datetime import UTC, datetime, timedelta

from daemon.offline.reference_common import Interval, ReadContext

__all__ = ["looks_like_knmi", "read_knmi"]

HOUR = timedelta(hours=1)
DAY = timedelta(days=1)
KNMI_MARKS = ("METEOROLOGISCH INSTITUUT (KNMI)", "METEOROLOGICAL INSTITUTE (KNMI)")


def looks_like_knmi(head: Iterable[str]) -> bool:
    """Whether the first lines of a file are a KNMI legend or header."""
    for text in head:
        upper = text.upper()
        if any(mark in upper for mark in KNMI_MARKS) or _header_names(text) is not None:
            return True
    return False


def read_knmi(lines: Iterable[tuple[int, str]], ctx: ReadContext) -> list[Interval]:
    """Intervals of a KNMI hourly or daily file (see the module docstring)."""
    lines = iter(lines)
    header: list[str] | None = None
    header_line = 0
    for line, text in lines:
        header = _header_names(text)
        if header is not None:
            header_line = line
            break
    if header is None:
        raise ctx.error("no KNMI header line (# STN,YYYYMMDD,…) found")
    if "RH" not in header:
        raise ctx.error(
            f"KNMI header has no RH (precipitation) column; it has {', '.join(header)}",
            header_line,
        )
    i_station, i_date, i_rh = header.index("STN"), header.index("YYYYMMDD"), header.index("RH")
    i_hour = header.index("HH") if "HH" in header else None
    step = HOUR if i_hour is not None else DAY
    needed = max(i for i in (i_station, i_date, i_rh, i_hour) if i is not None) + 1
    out: list[Interval] = []
    for line, text in lines:
        stripped = text.strip()
        if not stripped or stripped.startswith("#"):
            continue
        ctx.stats.rows += 1
        fields = [f.strip() for f in stripped.split(",")]
        if len(fields) < needed:
            ctx.bad_row(line, f"{len(fields)} fields, the header needs {needed}")
            continue
        station = fields[i_station]
        if not ctx.wants(station):
            continue
        try:
            end = _end(fields[i_date], None if i_hour is None else fields[i_hour])
            value, quality = _amount(fields[i_rh])
        except ValueError as err:
            ctx.bad_row(line, str(err))
            continue
        out.append(Interval(end - step, end, ctx.amount(value), station or None, quality))
    return out


def _header_names(text: str) -> list[str] | None:
    body = text.strip().lstrip("#").strip()
    if not body.upper().startswith("STN,"):
        return None
    names = [name.strip().upper() for name in body.split(",")]
    return names if "YYYYMMDD" in names else None


def _end(date: str, hour: str | None) -> datetime:
    if len(date) != 8 or not date.isdigit():
        raise ValueError(f"YYYYMMDD {date!r} is not 8 digits")
    day = datetime(int(date[:4]), int(date[4:6]), int(date[6:]), tzinfo=UTC)
    if hour is None:
        return day + DAY
    if not hour.isdigit() or not 1 <= int(hour) <= 24:
        raise ValueError(f"HH {hour!r} is not an hour 1-24")
    return day + int(hour) * HOUR


def _amount(text: str) -> tuple[float | None, str | None]:
    """RH in 0.1 mm: (mm, quality); -1 is "< 0.05 mm", a trace."""
    if not text:
        return None, None
    if not text.lstrip("-").isdigit():
        raise ValueError(f"RH {text!r} is not a whole number of 0.1 mm")
    tenths = int(text)
    if tenths == -1:
        return 0.0, "trace"
    return tenths / 10.0, None
