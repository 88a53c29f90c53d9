"""``weatherd check-config PATH``: validate a configuration file."""

from __future__ import annotations

import argparse

from .common import EXIT_OK, validated_config

__all__ = ["register"]


def _check_config(args: argparse.Namespace) -> int:
    """``weatherd check-config PATH``: validate, print a one-line summary, exit 0 or 2."""
    from drivers.frames import mask_credentials

    config = validated_config(args.path)
    cams = (
        ", ".join(f"{c.id} ({mask_credentials(c.source)})" for c in config.camera)
        or "the demo camera"
    )
    print(f"{args.path}: valid; site {config.site.id}; cameras: {cams}")
    return EXIT_OK


def register(commands: argparse._SubParsersAction, parents: list[argparse.ArgumentParser]) -> None:
    """Add ``weatherd check-config`` to ``commands``."""
    check = commands.add_parser(
        "check-config",
        parents=parents,
        help="validate a configuration file",
        description="Validate a configuration file as 'weatherd run' would before starting: "
        "every key and value, camera sources, ROI masks, Zenoh endpoints, instruments, the "
        "calibration file, the recording and state directories. Exit 0 if valid; 2 with every "
        "problem, "
        "one line each, naming its key, if not.",
    )
    check.add_argument("path", metavar="PATH", help="the TOML configuration file to check")
    check.set_defaults(handler=_check_config)
