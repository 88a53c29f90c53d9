"""Météo-France station data: climatological CSV files, the commande API CSV, observation JSON.

Formats (field descriptions: Météo-France's ``H_descriptif_champs.csv`` and
``MN_descriptif_champs.csv``; samples in ``../shared/fixtures/meteofrance/``)

``mf-hourly`` — "données climatologiques de base horaires", ``H_<dept>_<period>.csv(.gz)``
    ``;``-separated, one header line ``NUM_POSTE;NOM_USUEL;LAT;LON;ALTI;AAAAMMJJHH;RR1;QRR1;…``,
    decimal point, empty field = missing. ``AAAAMMJJHH`` is UTC in metropolitan France (the
    dataset page: "les heures sont exprimées en UTC pour la métropole et en FU pour
    l'outre-mer"; pass ``tz`` for overseas files). ``RR1`` is "quantité de précipitation tombée
    en 1 heure (en mm et 1/10 mm)" over the hour ENDING at the stamp: the interval is
    ``[stamp - 1 h, stamp)``. What this relies on: the descriptif ("tombée en 1 heure"); the
    real commande sample, where the hour's extremes are timed inside the previous hour — the
    row stamped ``2024061512`` has its minimum temperature at ``HTN=1105`` and its maximum gust
    at ``HXI=1147``, the row ``2024061513`` its maximum temperature at ``HTX=1300`` — so the
    hour stamped HH is (HH-1, HH]; and the observation API's field list, which states the
    same for its amounts ("rr_per: all precipitation over the previous 6 minutes",
    "insolh: sunshine duration over the previous 1H"). ``QRR1`` is the quality code, reported
    as ``Interval.quality``: ``9`` filtered (passed first-level checks only), ``0`` protected
    (validated for good by the climatologist), ``1`` validated (automatically or by the
    climatologist), ``2`` doubtful, being checked. Doubtful values are kept; users filter on
    ``quality``.
``mf-6min`` — "données infrahoraires 6 minutes", ``MN_<dept>_<period>.csv(.gz)``
    as above with ``AAAAMMJJHHMN`` and ``RR`` ("quantité de précipitation tombée en 6
    minutes") over ``[stamp - 6 min, stamp)``, quality ``QRR``.
``mf-commande`` — the climatology API's ordered files ("commande-station")
    ``POSTE;DATE;RR1;…`` (hourly, ``DATE`` = ``AAAAMMJJHH``) or ``POSTE;DATE;RR6`` (6-minute,
    ``DATE`` = ``AAAAMMJJHHMN``), decimal COMMA (``0,0``), same time conventions as above,
    quality column ``QRR1``/``QRR6`` used when present (the samples have none).
``mf-obs-json`` — the observation API ("DPObs"/"DPPaquetObs") JSON
    a list of objects with ``validity_time`` (ISO-8601 UTC), ``geo_id_insee`` (the station)
    and ``rr_per`` ("all precipitation over the previous 6 minutes", 6-minute product;
    ``interval_s`` overrides the 6 min) or ``rr1`` (hourly product, previous hour), whichever
    is present; ``null`` = missing. Package files hold many stations and hours, newest first.

Every format: negative amounts (seen in real observation data: ``"rr1": -0.1``) become None
and are counted; a row whose field count differs from the header's (a truncated last line,
a stray separator) is skipped as malformed. Output sorting and de-duplication are done by
the caller (``daemon.offline.reference``).
"""

from __future__ import annotations

import json
from collections.abc import Iterable
from datetime import datetime, timedelta
from typing import IO

from daemon.offline.reference_common import (
    Interval,
    ReadContext,
    compact_stamp,
    iter_lines,
    parse_number,
)

__all__ = ["read_commande", "read_hourly", "read_obs_json", "read_six_minute"]

HOUR = timedelta(hours=1)
SIX_MINUTES = timedelta(minutes=6)


def read_hourly(lines: Iterable[tuple[int, str]], ctx: ReadContext) -> list[Interval]:
    """Intervals of a ``H_…`` hourly climatological file (see the module docstring)."""
    return _read_table(lines, ctx, ("NUM_POSTE", "AAAAMMJJHH", "RR1", "QRR1"), HOUR, 10)


def read_six_minute(lines: Iterable[tuple[int, str]], ctx: ReadContext) -> list[Interval]:
    """Intervals of a ``MN_…`` 6-minute climatological file (see the module docstring)."""
    return _read_table(lines, ctx, ("NUM_POSTE", "AAAAMMJJHHMN", "RR", "QRR"), SIX_MINUTES, 12)


def read_commande(lines: Iterable[tuple[int, str]], ctx: ReadContext) -> list[Interval]:
    """Intervals of a commande API CSV, hourly (``RR1``) or 6-minute (``RR6``)."""
    lines = iter(lines)
    header = _header(lines, ctx)
    if "RR1" in header:
        columns, step, digits = ("POSTE", "DATE", "RR1", "QRR1"), HOUR, 10
    else:
        columns, step, digits = ("POSTE", "DATE", "RR6", "QRR6"), SIX_MINUTES, 12
    return _read_rows(lines, ctx, header, columns, step, digits)


def read_obs_json(binary: IO[bytes], ctx: ReadContext) -> list[Interval]:
    """Intervals of an observation API JSON file (see the module docstring)."""
    text = "\n".join(line for _, line in iter_lines(binary, ctx))
    try:
        data = json.loads(text)
    except json.JSONDecodeError as err:
        raise ctx.error(f"invalid JSON: {err.msg}", err.lineno) from err
    except RecursionError:  # arrays in arrays, thousands deep: no observation file is
        raise ctx.error("invalid JSON: nested too deeply") from None
    if isinstance(data, dict):
        data = [data]
    if not isinstance(data, list) or not any(
        isinstance(obj, dict) and "validity_time" in obj for obj in data
    ):
        raise ctx.error("JSON but not a Météo-France observation list (no validity_time)")
    six_min = timedelta(seconds=ctx.interval_s) if ctx.interval_s else SIX_MINUTES
    out: list[Interval] = []
    for index, obj in enumerate(data, start=1):
        ctx.stats.rows += 1
        try:
            if not isinstance(obj, dict):
                raise ValueError("not an object")
            station = obj.get("geo_id_insee")
            station = None if station is None else str(station)
            if not ctx.wants(station):
                continue
            end = ctx.localise(datetime.fromisoformat(str(obj["validity_time"])))
            if "rr_per" in obj:
                value, step = obj["rr_per"], six_min
            elif "rr1" in obj:
                value, step = obj["rr1"], HOUR
            else:
                raise ValueError("neither rr_per nor rr1")
            if value is not None and (
                isinstance(value, bool) or not isinstance(value, int | float)
            ):
                raise ValueError(f"precipitation {value!r} is not a number")
        except (KeyError, ValueError, TypeError) as err:
            ctx.bad_row(index, str(err), unit="object")
            continue
        amount = ctx.amount(None if value is None else float(value))
        out.append(Interval(end - step, end, amount, station))
    return out


def _read_table(
    lines: Iterable[tuple[int, str]],
    ctx: ReadContext,
    columns: tuple[str, str, str, str],
    step: timedelta,
    digits: int,
) -> list[Interval]:
    lines = iter(lines)
    header = _header(lines, ctx)
    return _read_rows(lines, ctx, header, columns, step, digits)


def _header(lines: Iterable[tuple[int, str]], ctx: ReadContext) -> list[str]:
    for _, text in lines:
        if text.strip():
            return [name.strip().upper() for name in text.split(";")]
    raise ctx.error("empty file")


def _read_rows(
    lines: Iterable[tuple[int, str]],
    ctx: ReadContext,
    header: list[str],
    columns: tuple[str, str, str, str],
    step: timedelta,
    digits: int,
) -> list[Interval]:
    time_col, quality_col = columns[1], columns[3]
    missing = [name for name in columns[:3] if name not in header]
    if missing:
        raise ctx.error(f"header lacks column(s) {', '.join(missing)}", 1)
    i_station, i_time, i_value = (header.index(name) for name in columns[:3])
    i_quality = header.index(quality_col) if quality_col in header else None
    n_fields = len(header)
    out: list[Interval] = []
    for line, text in lines:
        if not text.strip():
            continue
        ctx.stats.rows += 1
        fields = text.split(";")
        if len(fields) != n_fields:
            ctx.bad_row(line, f"{len(fields)} fields, the header has {n_fields}")
            continue
        station = fields[i_station].strip()
        if not ctx.wants(station):
            continue
        stamp = fields[i_time].strip()
        try:
            if len(stamp) != digits:
                raise ValueError(f"{time_col} {stamp!r} is not {digits} digits")
            end = compact_stamp(stamp, ctx)
            value = parse_number(fields[i_value])
        except ValueError as err:
            ctx.bad_row(line, str(err))
            continue
        quality = (fields[i_quality].strip() or None) if i_quality is not None else None
        out.append(Interval(end - step, end, ctx.amount(value), station or None, quality))
    return out
