"""``weatherd watch [KEYEXPR]``: print what the daemon publishes, one JSON line per sample."""

from __future__ import annotations

import argparse

from .zenoh_options import zenoh_conf, zenoh_parser

__all__ = ["register"]


def _watch(args: argparse.Namespace) -> int:
    """``weatherd watch [KEYEXPR]``: print Zenoh samples as JSON lines until Ctrl-C."""
    from daemon.transport.watch import watch

    return watch(
        args.keyexpr,
        zenoh_conf(args),
        count=args.count,
        timeout_s=args.timeout,
        human=args.format == "text",
    )


def register(commands: argparse._SubParsersAction, parents: list[argparse.ArgumentParser]) -> None:
    """Add ``weatherd watch`` to ``commands``."""
    watch = commands.add_parser(
        "watch",
        parents=[*parents, zenoh_parser()],
        help="print what the daemon publishes (a Zenoh subscriber)",
        description="Subscribe to KEYEXPR and print one JSON line per sample (or one short "
        "line with --format text) until Ctrl-C. When no Zenoh peer or router can be reached "
        "after a few seconds, or nothing is published, it says so on stderr and keeps waiting.",
    )
    watch.add_argument(
        "keyexpr",
        metavar="KEYEXPR",
        nargs="?",
        default="weather/**",
        help="what to follow, e.g. 'weather/demo/state' (default: weather/**, every site)",
    )
    watch.add_argument("--count", type=int, metavar="N", help="stop after N samples")
    watch.add_argument(
        "--format",
        choices=("json", "text"),
        default="json",
        help="json: one JSON line per sample, the whole payload (default); text: one short "
        "line for a person (time, key, precipitation, type, rate, cameras' states)",
    )
    watch.set_defaults(handler=_watch)
