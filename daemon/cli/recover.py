"""``weatherd recover BROKEN.mcap OUT.mcap``: repair an unfinished recording."""

from __future__ import annotations

import argparse
import json

from .common import EXIT_OK, as_json

__all__ = ["register"]


def _recover(args: argparse.Namespace) -> int:
    """``weatherd recover BROKEN.mcap OUT.mcap``: repair an unfinished recording."""
    from daemon.recording.mcap_repair import recover

    result = recover(args.broken, args.out)
    print(json.dumps(as_json(result), separators=(",", ":")))
    return EXIT_OK


def register(commands: argparse._SubParsersAction, parents: list[argparse.ArgumentParser]) -> None:
    """Add ``weatherd recover`` to ``commands``."""
    recover = commands.add_parser(
        "recover",
        parents=parents,
        help="repair an unfinished MCAP recording",
        description="Copy every complete message of an unfinished or truncated MCAP file into "
        "a new, finished one.",
    )
    recover.add_argument(
        "broken",
        metavar="BROKEN.mcap",
        help="the unfinished or truncated recording (a *.mcap.part left by a crash, or a file "
        "the MCAP reader cannot open); it is only read",
    )
    recover.add_argument(
        "out",
        metavar="OUT.mcap",
        help="the finished file to write, with every complete message of BROKEN.mcap (written "
        "under a temporary name, then renamed; may be BROKEN.mcap itself)",
    )
    recover.set_defaults(handler=_recover)
