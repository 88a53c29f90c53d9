"""``weatherd get SELECTOR``: query the daemon's latest values, one JSON line per reply."""

from __future__ import annotations

import argparse
import json

from drivers.errors import InputError

from .common import EXIT_OK
from .zenoh_options import zenoh_conf, zenoh_parser

__all__ = ["register"]


def _get(args: argparse.Namespace) -> int:
    """``weatherd get SELECTOR``: query the daemon's queryable, one JSON line per reply."""
    from daemon.transport.watch import get, human_line

    replies = get(args.selector, zenoh_conf(args), timeout_s=args.timeout or 5.0)
    for reply in replies:
        text = (
            human_line(reply) if args.format == "text" else json.dumps(reply, separators=(",", ":"))
        )
        print(text, flush=True)
    if not replies:
        raise InputError(f"{args.selector}: no reply (is the daemon running and reachable?)")
    return EXIT_OK


def register(commands: argparse._SubParsersAction, parents: list[argparse.ArgumentParser]) -> None:
    """Add ``weatherd get`` to ``commands``."""
    get = commands.add_parser(
        "get",
        parents=[*parents, zenoh_parser()],
        help="query the daemon's latest values",
        description="Query SELECTOR (e.g. 'weather/demo/**') and print one JSON line per reply.",
    )
    get.add_argument(
        "selector",
        metavar="SELECTOR",
        help="what to ask for, e.g. 'weather/demo/**' (every key of site demo) or "
        "'weather/*/state'",
    )
    get.add_argument(
        "--format",
        choices=("json", "text"),
        default="json",
        help="json: one JSON line per reply (default); text: one short line for a person",
    )
    get.set_defaults(handler=_get)
