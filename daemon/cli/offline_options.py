"""The options and keyword arguments that ``weatherd calibrate`` and ``compare`` share."""

from __future__ import annotations

import argparse
import os
from typing import Any

__all__ = ["offline_options", "offline_parser"]


def _report_path(args: argparse.Namespace) -> str | None:
    """--report, else report.html in the --plots folder."""
    if args.report:
        return args.report
    return os.path.join(args.plots, "report.html") if args.plots else None


def _reference_options(args: argparse.Namespace) -> dict[str, Any]:
    options = {
        "fmt": args.format,
        "tz": args.tz,
        "interval_s": args.interval,
        "month": args.month,
        "time_column": args.time_column,
        "amount_column": args.amount_column,
        "cumulative": args.cumulative or None,
    }
    return {k: v for k, v in options.items() if v is not None and not (k == "tz" and v == "UTC")}


def add_csv_columns(parser: argparse.ArgumentParser) -> None:
    """The generic CSV's column options, shared by reference, calibrate and compare."""
    parser.add_argument(
        "--time-column", metavar="NAME", help="generic CSV: the time column (its end of interval)"
    )
    parser.add_argument(
        "--amount-column", metavar="NAME", help="generic CSV: the precipitation column, mm"
    )
    parser.add_argument(
        "--cumulative",
        action="store_true",
        help="generic CSV: the amount is a running total (a gauge counter): use differences",
    )


def offline_options(args: argparse.Namespace) -> dict[str, Any]:
    """The keyword arguments that ``calibrate`` and ``compare`` share."""
    return {
        "station": args.station,
        "camera": args.camera,
        "threshold_mm": args.threshold_mm,
        "min_judged": args.min_judged,
        "min_coverage": args.min_coverage,
        "plots_dir": args.plots,
        "report": _report_path(args),
        "reference_options": _reference_options(args),
        "progress": False if args.no_progress else None,
    }


def offline_parser() -> argparse.ArgumentParser:
    """The parent parser of the shared options."""
    offline = argparse.ArgumentParser(add_help=False)
    offline.add_argument(
        "--mcap", nargs="+", required=True, metavar="PATH", help="MCAP files or directories"
    )
    offline.add_argument("--reference", required=True, metavar="FILE", help="station data")
    offline.add_argument("--station", metavar="ID", help="the station, in a multi-station file")
    offline.add_argument("--camera", metavar="ID", help="the camera, when the logs hold several")
    offline.add_argument("--plots", metavar="DIR", help="write PNG plots and report.html here")
    offline.add_argument("--report", metavar="FILE.html", help="write the HTML report here")
    offline.add_argument(
        "--threshold-mm",
        type=float,
        default=0.1,
        metavar="MM",
        help="reference amount from which an interval is wet (default 0.1)",
    )
    offline.add_argument(
        "--min-judged",
        type=float,
        default=0.5,
        metavar="F",
        help="least share of an interval's frames the camera must have judged for the "
        "interval to be used (default 0.5)",
    )
    offline.add_argument(
        "--min-coverage",
        type=float,
        default=0.5,
        metavar="F",
        help="least share of an interval's length its frames must span for it to be used "
        "(default 0.5)",
    )
    offline.add_argument("--format", metavar="FMT", help="force the reference format")
    offline.add_argument("--tz", default="UTC", help="time zone of naive reference times")
    offline.add_argument("--interval", type=float, metavar="S", help="reference interval, s")
    offline.add_argument("--month", metavar="YYYY-MM", help="for METAR reports without date")
    add_csv_columns(offline)
    offline.add_argument("--no-progress", action="store_true", help="no progress bar")
    return offline
