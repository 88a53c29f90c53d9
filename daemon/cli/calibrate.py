"""``weatherd calibrate``: fit the site's calibration of R -> mm/h against station data."""

from __future__ import annotations

import argparse
import json

from .common import EXIT_OK, as_json
from .offline_options import offline_options, offline_parser

__all__ = ["register"]


def _calibrate(args: argparse.Namespace) -> int:
    """``weatherd calibrate``: fit R -> mm/h; ends with one JSON line (contract)."""
    from daemon.offline.calibrate import calibrate

    result = calibrate(
        args.mcap, args.reference, model=args.model, out=args.out, **offline_options(args)
    )
    print(json.dumps(as_json(result), separators=(",", ":"), allow_nan=False))
    return EXIT_OK


def register(commands: argparse._SubParsersAction, parents: list[argparse.ArgumentParser]) -> None:
    """Add ``weatherd calibrate`` to ``commands``."""
    calibrate = commands.add_parser(
        "calibrate",
        parents=[*parents, offline_parser()],
        help="fit the site calibration of R -> mm/h against station data",
        description="Fit mm/h against the camera's R over each reference interval (linear "
        "through the origin and a power law, robust, with bootstrap confidence intervals), "
        "write the calibration file the daemon loads, and print one JSON line.",
    )
    calibrate.add_argument(
        "--out", default="calibration.toml", metavar="FILE", help="default calibration.toml"
    )
    calibrate.add_argument("--model", choices=("linear", "power"), help="default: the better")
    calibrate.set_defaults(handler=_calibrate)
