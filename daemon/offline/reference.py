"""Station reference data for offline calibration: one reader, many formats, one interval type.

``read_reference(path)`` turns a weather station's file into :class:`Interval` values — an
amount of precipitation (or its presence, for METAR) over ``[start, end)`` in UTC — that the
offline calibration and comparison (``daemon.offline.series`` …) line up with the camera.
``weatherd reference FILE [--station ID]`` prints ``reference_json`` lines.

Formats (``fmt``; detected from the content — a ZIP holding a DWD ``produkt_*.txt``, a SQLite
file, the header line, the KNMI legend — and the name ``H_…``, ``MN_…``, ``.mcap`` when the
content does not tell; ``.gz`` files of any text format are read through gzip)

=============  ===============================================================  ==============
fmt            what                                                             interval
=============  ===============================================================  ==============
mf-hourly      Météo-France ``H_<dept>_<period>.csv(.gz)``: ``NUM_POSTE;…;      hour ENDING at
               AAAAMMJJHH;RR1;QRR1;…``, ``;``, decimal point, UTC               the stamp
mf-6min        Météo-France ``MN_…``: ``AAAAMMJJHHMN;RR;QRR``                   6 min ending
                                                                                at the stamp
mf-commande    Météo-France commande API CSV: ``POSTE;DATE;RR1;…`` (hourly) or  as above
               ``POSTE;DATE;RR6`` (6 min), decimal COMMA
mf-obs-json    Météo-France observation API JSON: ``validity_time``,            6 min / 1 h
               ``geo_id_insee``, ``rr_per`` (6 min) or ``rr1`` (1 h)            ending there
dwd            DWD ``produkt_zehn_min_rr_…`` (``RWS_10``, 10 min) or            10 min / 1 h
               ``produkt_rr_stunde_…`` (``R1``, 1 h), ``;``, ``-999``, or       ending at the
               the ZIP as downloaded; 10-min stamps MEZ before 2000             stamp
knmi           KNMI ``uurgeg_…``, script export: ``STN,YYYYMMDD,HH,…,RH``       hour HH-1 to
               RH in 0.1 mm, -1 = trace; daily files (no ``HH``); UT            HH UT; UT day
noaa-isd       NOAA Global Hourly CSV: ``DATE`` (UTC), ``AA1``… groups          the group's
               ``period,depth (0.1 mm),condition,quality``                      period ending
                                                                                at DATE
noaa-lcd       NOAA LCD CSV: ``HourlyPrecipitation`` (inches, ``T``, ``s``),    hour ending at
               ``DATE`` in local STANDARD time (a fixed ``tz`` is required)     DATE
weewx          weewx archive (``weewx.sdb`` or its CSV export): ``dateTime``,   ``interval``
               ``usUnits``, ``interval`` (min), ``rain`` (in, cm or mm)         min ending at
                                                                                dateTime
csv            generic: a time column and ``precip_mm``/``mm``/``rr`` or        ``interval_s``
               ``rain_rate_mm_h``/``mm_h``; ``,`` or ``;``, point or comma      or the median
                                                                                spacing, ending
                                                                                at the time
metar          METAR reports, one per line, dated by a ``YYYYMMDDHHMM`` prefix  report to next,
               or the ``month`` option; ``kind="presence"``                     at most 1 h
mcap-gauge     the daemon's ``/instrument/<id>/reading`` messages in an MCAP    ``interval_s``
               file: accumulation differences (wraps/resets dropped)            (3600), aligned
=============  ===============================================================  ==============

The details and the evidence for each convention are in the module docstrings of
``daemon.offline.meteofrance``, ``dwd``, ``knmi``, ``noaa``, ``weewx``, ``generic_csv``,
``metar_reports`` and ``gauge_mcap``.

Conventions shared by all formats
    - Times are UTC, tz-aware. Naive time stamps are read in ``tz`` (default ``"UTC"``; e.g.
      ``"America/Guadeloupe"`` for an overseas Météo-France file in local "FU" time).
    - ``station`` keeps one station of a multi-station file (NUM_POSTE, POSTE, geo_id_insee,
      METAR ICAO, gauge id; numeric ids match without leading zeros) and is reported in
      each interval.
    - Missing values are kept as ``precip_mm=None``; negative amounts become None; both are
      counted. The source's quality code, when it has one, is ``quality``.
    - A malformed row (unparseable date or number, wrong field count — e.g. a truncated
      last line) is skipped, counted and logged with its line number; never fatal.
    - Output is sorted by start (then station); rows with the same station and start are kept
      once (the first in the file).
    - UTF-8 with or without BOM, LF or CRLF line ends, gzip by content.
    - :class:`drivers.errors.InputError` with one line naming the file (and the line where it
      helps) for a missing or unreadable file, an unrecognised format, a header without the
      needed columns, or a file with no usable interval (e.g. none for the station asked for).

Everything is read into memory before it is sorted: for a department-wide ``H_`` file over a
decade, pass ``station`` to keep only what is needed.
"""

from __future__ import annotations

import logging
import math
import re
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from datetime import UTC, datetime
from itertools import islice
from os import PathLike
from pathlib import Path
from typing import IO, Any

from daemon.offline.dwd import ZIP_MAGIC, looks_like_dwd, read_dwd_binary, zip_has_product
from daemon.offline.gauge_mcap import read_gauge_mcap
from daemon.offline.generic_csv import read_generic_csv, sniff_header
from daemon.offline.knmi import looks_like_knmi, read_knmi
from daemon.offline.metar_reports import looks_like_metar, read_metar
from daemon.offline.meteofrance import read_commande, read_hourly, read_obs_json, read_six_minute
from daemon.offline.noaa import isd_or_lcd, read_isd, read_lcd
from daemon.offline.reference_common import (
    Interval,
    ReadContext,
    ReadStats,
    corrupt_stream_is_input_error,
    finish,
    iter_lines,
    open_binary,
    parse_tz,
)
from daemon.offline.weewx import SQLITE_MAGIC, looks_like_weewx_csv, read_weewx_binary
from drivers.errors import InputError

__all__ = [
    "FORMATS",
    "Interval",
    "ReadStats",
    "ReferenceData",
    "detect_format",
    "load_reference",
    "read_reference",
    "reference_json",
]

logger = logging.getLogger(__name__)

FORMATS = (
    "mf-hourly",
    "mf-6min",
    "mf-commande",
    "mf-obs-json",
    "dwd",
    "knmi",
    "noaa-isd",
    "noaa-lcd",
    "weewx",
    "csv",
    "metar",
    "mcap-gauge",
)
MCAP_MAGIC = b"\x89MCAP"
HEAD_LINES = 20
MONTH_RE = re.compile(r"^(\d{4})-(\d{2})$")

_LINE_READERS: dict[str, Callable[[Iterable[tuple[int, str]], ReadContext], list[Interval]]] = {
    "mf-hourly": read_hourly,
    "mf-6min": read_six_minute,
    "mf-commande": read_commande,
    "knmi": read_knmi,
    "noaa-isd": read_isd,
    "noaa-lcd": read_lcd,
    "csv": read_generic_csv,
    "metar": read_metar,
}
_BINARY_READERS: dict[str, Callable[[IO[bytes], ReadContext], list[Interval]]] = {
    "mf-obs-json": read_obs_json,
    "dwd": read_dwd_binary,
    "weewx": read_weewx_binary,
    "mcap-gauge": read_gauge_mcap,
}


@dataclass(frozen=True)
class ReferenceData:
    """The result of :func:`load_reference`.

    Attributes
    ----------
    intervals : list of Interval, sorted by start, one per (station, start)
    fmt : str, the format read (one of ``FORMATS``)
    stats : ReadStats, what was skipped or missing and why
    """

    intervals: list[Interval]
    fmt: str
    stats: ReadStats


def read_reference(
    path: str | PathLike[str],
    *,
    station: str | None = None,
    fmt: str | None = None,
    tz: str = "UTC",
    interval_s: float | None = None,
    month: str | None = None,
) -> Iterator[Interval]:
    """The precipitation intervals of a station reference file, sorted by start.

    Parameters
    ----------
    path : the file (``.gz`` for any text format is read through gzip)
    station : keep only this station (and report it); None keeps every station
    fmt : one of ``FORMATS`` to force the format; None detects it
    tz : time zone of naive time stamps (IANA name), default UTC
    interval_s : interval length, s — generic CSV (default: the median spacing), gauge MCAP
        (default 3600), 6-minute observation JSON (default 360), NOAA ISD (which period's
        groups to read; default the shortest); fixed by the other formats
    month : ``"YYYY-MM"`` for METAR reports that carry no date prefix

    Returns
    -------
    Iterator of Interval. The whole file is read (and any error raised) before this returns.

    Raises
    ------
    InputError
        The file is missing or unreadable, its format unrecognised, or it holds no usable
        interval; the message is one line naming the file.
    """
    return iter(
        load_reference(
            path, station=station, fmt=fmt, tz=tz, interval_s=interval_s, month=month
        ).intervals
    )


def load_reference(
    path: str | PathLike[str],
    *,
    station: str | None = None,
    fmt: str | None = None,
    tz: str = "UTC",
    interval_s: float | None = None,
    month: str | None = None,
    time_column: str | None = None,
    amount_column: str | None = None,
    cumulative: bool = False,
) -> ReferenceData:
    """As :func:`read_reference`, with the format found and the reading statistics.

    ``time_column``, ``amount_column`` and ``cumulative`` are for a generic CSV whose columns
    have other names, or whose amount is a running total (:mod:`.generic_csv`); naming a
    column implies that format when none is given."""
    path = Path(path)
    name = str(path)
    if interval_s is not None and not (math.isfinite(interval_s) and interval_s > 0):
        raise InputError(f"{name}: interval_s must be a positive number of seconds")
    ctx = ReadContext(
        name=name,
        station=station.strip() if station else None,
        tz=parse_tz(tz),
        interval_s=interval_s,
        month=_parse_month(month, name),
        time_column=time_column,
        amount_column=amount_column,
        cumulative=cumulative,
    )
    if fmt is None:
        fmt = "csv" if time_column or amount_column else detect_format(path)
    elif fmt not in FORMATS:
        raise InputError(f"{name}: unknown format {fmt!r} (one of {', '.join(FORMATS)})")
    with open_binary(path, name) as binary, corrupt_stream_is_input_error(name):
        if fmt in _BINARY_READERS:
            intervals = _BINARY_READERS[fmt](binary, ctx)
        else:
            intervals = _LINE_READERS[fmt](iter_lines(binary, ctx), ctx)
    intervals = finish(intervals, ctx)
    _log_summary(ctx, fmt, len(intervals))
    if not intervals:
        if ctx.station is not None and ctx.stats.other_stations:
            raise ctx.error(
                f"no data for station {ctx.station} "
                f"({ctx.stats.other_stations} rows of other stations)"
            )
        raise ctx.error(f"no usable data ({fmt}, {ctx.stats.malformed} malformed rows)")
    return ReferenceData(intervals, fmt, ctx.stats)


def detect_format(path: str | PathLike[str]) -> str:
    """The format of ``path`` from its content, then its name; InputError if neither tells."""
    path = Path(path)
    name = str(path)
    ctx = ReadContext(name=name)
    with open_binary(path, name) as binary, corrupt_stream_is_input_error(name):
        magic = binary.read(len(SQLITE_MAGIC))
        if magic.startswith(MCAP_MAGIC):
            return "mcap-gauge"
        if magic == SQLITE_MAGIC:
            return "weewx"
        binary.seek(0)
        if magic.startswith(ZIP_MAGIC):
            if zip_has_product(binary):
                return "dwd"
            raise InputError(f"{name}: a ZIP without a DWD produkt_*.txt; unzip it first")
        head = [text for _, text in islice(iter_lines(binary, ctx), HEAD_LINES)]
    lowered = path.name.lower()
    found = _format_of(head)
    if found is not None:
        return found
    if lowered.endswith(".mcap"):
        return "mcap-gauge"
    if lowered.startswith("h_"):
        return "mf-hourly"
    if lowered.startswith("mn_"):
        return "mf-6min"
    first = next((t.strip() for t in head if t.strip()), "")
    raise InputError(
        f"{name}: unrecognised reference data (first line {first[:60]!r}); "
        f"pass the format, one of {', '.join(FORMATS)}"
    )


def reference_json(interval: Interval) -> dict[str, Any]:
    """One interval as the JSON object of ``weatherd reference``.

    ``{"start": "2024-06-15T11:00:00Z", "end": …, "precip_mm": 0.2 | null, "station": str |
    null}``, then ``"quality"`` and ``"weather"`` when set and ``"kind"`` when it is not
    ``"amount"``.
    """
    out: dict[str, Any] = {
        "start": _iso(interval.start),
        "end": _iso(interval.end),
        "precip_mm": None if interval.precip_mm is None else float(interval.precip_mm),
        "station": interval.station,
    }
    if interval.quality is not None:
        out["quality"] = interval.quality
    if interval.kind != "amount":
        out["kind"] = interval.kind
    if interval.weather is not None:
        out["weather"] = interval.weather
    return out


def _format_of(head: list[str]) -> str | None:
    lines = [t for t in head if t.strip()]
    if not lines or any("\x00" in t for t in lines):
        return None
    first = lines[0].strip()
    if first[:1] in ("[", "{"):
        return "mf-obs-json"
    if looks_like_knmi(lines):
        return "knmi"
    columns = {c.strip().upper() for c in first.split(";")}
    if "NUM_POSTE" in columns and "AAAAMMJJHHMN" in columns:
        return "mf-6min"
    if "NUM_POSTE" in columns and "AAAAMMJJHH" in columns:
        return "mf-hourly"
    if {"POSTE", "DATE"} <= columns:
        return "mf-commande"
    if looks_like_dwd(first):
        return "dwd"
    if looks_like_weewx_csv(first):
        return "weewx"
    noaa = isd_or_lcd(first)
    if noaa is not None:
        return noaa
    if sniff_header(first) is not None:
        return "csv"
    if looks_like_metar(lines):
        return "metar"
    return None


def _parse_month(month: str | None, name: str) -> tuple[int, int] | None:
    if month is None:
        return None
    match = MONTH_RE.match(month.strip())
    if match is None or not 1 <= int(match.group(2)) <= 12:
        raise InputError(f"{name}: month must be YYYY-MM, got {month!r}")
    return int(match.group(1)), int(match.group(2))


def _iso(t: datetime) -> str:
    t = t.astimezone(UTC)
    spec = "seconds" if t.microsecond == 0 else "microseconds"
    return t.replace(tzinfo=None).isoformat(timespec=spec) + "Z"


def _log_summary(ctx: ReadContext, fmt: str, n: int) -> None:
    s = ctx.stats
    level = logging.WARNING if (s.malformed or s.truncated) else logging.INFO
    logger.log(
        level,
        "%s: %d intervals (%s) from %d rows; skipped %d malformed%s%s, "
        "%d negative -> None, %d missing, %d duplicates, %d of other stations",
        ctx.name,
        n,
        fmt,
        s.rows,
        s.malformed,
        f" (first at line {s.first_malformed_line})" if s.malformed else "",
        ", file truncated" if s.truncated else "",
        s.negative,
        s.missing,
        s.duplicates,
        s.other_stations,
    )
