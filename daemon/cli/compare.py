"""``weatherd compare``: score the camera's precipitation detection against station data."""

from __future__ import annotations

import argparse
import json
import sys

from .common import EXIT_OK, as_json
from .offline_options import offline_options, offline_parser

__all__ = ["register"]


def _compare(args: argparse.Namespace) -> int:
    """``weatherd compare``: the camera's presence scores against station data."""
    from daemon.offline.compare import compare

    result = compare(
        args.mcap,
        args.reference,
        camera_fraction=args.camera_fraction,
        **offline_options(args),
    )
    if not args.full:
        result = {k: v for k, v in result.items() if k != "table"}
    print(json.dumps(as_json(result), separators=(",", ":"), allow_nan=False))
    c = result.get("confusion") or {}
    if c:
        scores = " ".join(f"{k.upper()} {c.get(k)}" for k in ("tp", "fp", "tn", "fn", "tpr", "fpr"))
        print(f"weatherd: {scores} accuracy {c.get('accuracy')}", file=sys.stderr)
    return EXIT_OK


def register(commands: argparse._SubParsersAction, parents: list[argparse.ArgumentParser]) -> None:
    """Add ``weatherd compare`` to ``commands``."""
    compare = commands.add_parser(
        "compare",
        parents=[*parents, offline_parser()],
        help="score the camera's precipitation detection against station data",
        description="Presence confusion matrix per reference interval (TP, FP, TN, FN, TPR, "
        "FPR, accuracy) and ROC curves over Pi_rain and the GoF distance; one JSON line.",
    )
    compare.add_argument(
        "--camera-fraction",
        type=float,
        default=0.1,
        metavar="F",
        help="share of judged frames with rain from which the camera says wet (default 0.1)",
    )
    compare.add_argument("--full", action="store_true", help="include the per-interval table")
    compare.set_defaults(handler=_compare)
