"""``weatherd instruments decode --driver NAME FILE``: a capture of an instrument as JSON lines."""

from __future__ import annotations

import argparse
import json
import sys
import tomllib
from typing import Any

from drivers.errors import ConfigError, InputError

from .common import EXIT_OK, ArgumentParser

__all__ = ["register"]


def _instruments_decode(args: argparse.Namespace) -> int:
    """``weatherd instruments decode --driver NAME FILE``: one JSON line per reading.

    Bad frames are reported on stderr with their line number and counted, never fatal.
    """
    from drivers.instruments import DRIVERS
    from drivers.instruments.decode import DecodeStats, decode_file

    options: dict[str, Any] = {}
    for item in args.option or []:
        key, sep, text = item.partition("=")
        if not sep or not key:
            raise InputError(f"--option {item!r}: expected KEY=VALUE")
        try:  # a TOML value (number, string, array, inline table), else plain text
            options[key] = tomllib.loads(f"v = {text}")["v"]
        except tomllib.TOMLDecodeError:
            options[key] = text
    stats = DecodeStats()
    try:
        readings = decode_file(
            DRIVERS[args.driver],
            args.file,
            options=options,
            stats=stats,
            time=args.time,
            checksum=args.checksum or "auto",
        )
    except ConfigError as exc:
        raise ConfigError(f"--option: {exc}") from None
    said = {"bad": 0, "notes": 0}
    for reading in readings:
        sys.stdout.write(json.dumps(reading.to_json(), separators=(",", ":")) + "\n")
        _say(args.file, stats, said)
    _say(args.file, stats, said)
    sys.stdout.flush()
    if stats.readings == 0:  # never a whole file called garbage without what was expected
        print(
            f"weatherd: {args.file}: no reading; {args.driver} expects "
            f"{DRIVERS[args.driver].description} (the layouts each driver reads are listed "
            "in docs/instruments.md)",
            file=sys.stderr,
        )
    print(
        f"weatherd: {args.file}: {stats.readings} readings, {len(stats.bad)} bad frame(s), "
        f"{stats.garbage_bytes} garbage byte(s)",
        file=sys.stderr,
    )
    return EXIT_OK


def _say(path: str, stats: Any, said: dict[str, int]) -> None:
    """What ``stats`` learnt since the last call, on stderr: bad frames, then notes."""
    for line, reason in stats.bad[said["bad"] :]:
        print(f"weatherd: {path}:{line}: {reason}", file=sys.stderr)
    for note in stats.notes[said["notes"] :]:
        print(f"weatherd: {path}: {note}", file=sys.stderr)
    said.update(bad=len(stats.bad), notes=len(stats.notes))


def _driver_names() -> list[str]:
    from drivers.instruments import DRIVERS

    return sorted(DRIVERS)


def register(commands: argparse._SubParsersAction, parents: list[argparse.ArgumentParser]) -> None:
    """Add ``weatherd instruments decode`` to ``commands``."""
    instruments = commands.add_parser(
        "instruments",
        parents=parents,
        help="serial instruments: decode captures",
        description="Tools for the serial instruments.",
    )
    inst_commands = instruments.add_subparsers(
        dest="instruments_command", required=True, metavar="COMMAND", parser_class=ArgumentParser
    )
    decode = inst_commands.add_parser(
        "decode",
        parents=parents,
        help="parse a raw capture or logger file into JSON lines",
        description="Parse a raw serial capture (or a logger's file) of an instrument: one JSON "
        "line per reading on stdout; bad frames on stderr with their line number.",
    )
    decode.add_argument(
        "--driver",
        required=True,
        choices=_driver_names(),
        metavar="NAME",
        help="one of: " + ", ".join(_driver_names()),
    )
    decode.add_argument("file", metavar="FILE")
    decode.add_argument(
        "--option",
        action="append",
        metavar="KEY=VALUE",
        help="a driver option (TOML value), e.g. --option mm_per_tip=0.1",
    )
    decode.add_argument(
        "--time",
        choices=("logger", "sensor"),
        default="logger",
        help="the clock that dates a reading when the capture has both: the logger's stamp "
        "(default) or the sensor's own clock; each line says which in time_source",
    )
    decode.add_argument(
        "--checksum",
        choices=("enforce", "report", "ignore"),
        default=None,
        help="telegram checksums (thies-lnm): refuse a telegram that fails (enforce), keep "
        "it and say so in checksum_ok (report), or do not look (ignore). Default: enforce, "
        "unless every telegram of the file fails the same way (a convention of the sensor or "
        "its logger, said once): then report",
    )
    decode.set_defaults(handler=_instruments_decode)
