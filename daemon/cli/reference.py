"""``weatherd reference FILE [--station ID]``: station data as JSON lines (contract)."""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys

from .common import EXIT_OK
from .offline_options import add_csv_columns

__all__ = ["register"]


def _reference(args: argparse.Namespace) -> int:
    """``weatherd reference FILE [--station ID]``: station data as JSON lines (contract)."""
    from daemon.offline.reference import load_reference, reference_json

    data = load_reference(
        args.file,
        station=args.station,
        fmt=args.format,
        tz=args.tz,
        interval_s=args.interval,
        month=args.month,
        time_column=args.time_column,
        amount_column=args.amount_column,
        cumulative=args.cumulative,
    )
    for interval in data.intervals:
        sys.stdout.write(json.dumps(reference_json(interval), separators=(",", ":")) + "\n")
    sys.stdout.flush()
    st = data.stats
    notes = [
        f"{v} {k.replace('_', ' ')}"
        for k, v in dataclasses.asdict(st).items()
        if isinstance(v, int)
        and not isinstance(v, bool)
        and v
        and k not in ("rows", "first_malformed_line")
    ]
    print(
        f"weatherd: {args.file}: {data.fmt}, {len(data.intervals)} intervals"
        + "".join(f"; {n}" for n in notes),
        file=sys.stderr,
    )
    return EXIT_OK


def register(commands: argparse._SubParsersAction, parents: list[argparse.ArgumentParser]) -> None:
    """Add ``weatherd reference`` to ``commands``."""
    reference = commands.add_parser(
        "reference",
        parents=parents,
        help="station data (Météo-France, DWD, KNMI, NOAA, weewx, CSV, METAR, a gauge in MCAP) "
        "as JSON lines",
        description="Parse a station's reference file: one JSON line per interval, "
        '{"start", "end", "precip_mm", "station"} (times in UTC, intervals [start, end)).',
    )
    reference.add_argument("file", metavar="FILE")
    reference.add_argument("--station", metavar="ID", help="keep only this station")
    reference.add_argument(
        "--format",
        metavar="FMT",
        help="force the format: mf-hourly, mf-6min, mf-commande, mf-obs-json, dwd, knmi, "
        "noaa-isd, noaa-lcd, weewx, csv, metar, mcap-gauge (default: detected)",
    )
    reference.add_argument("--tz", default="UTC", help="time zone of naive times (default UTC)")
    reference.add_argument(
        "--interval",
        type=float,
        metavar="S",
        help="interval length, s (generic CSV, gauge); the period of NOAA ISD groups to read",
    )
    reference.add_argument("--month", metavar="YYYY-MM", help="for METAR reports without date")
    add_csv_columns(reference)
    reference.set_defaults(handler=_reference)
