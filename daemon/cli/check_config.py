"""``weatherd check-config PATH``: validate a configuration file."""

from __future__ import annotations

import argparse

from drivers.errors import ConfigError

from .common import EXIT_OK

__all__ = ["register"]


def _check_config(args: argparse.Namespace) -> int:
    """``weatherd check-config PATH``: validate, print a one-line summary, exit 0 or 2."""
    from daemon.config import load_config
    from daemon.service.app import check_paths
    from drivers.frames import mask_credentials

    config = load_config(args.path)
    try:
        check_paths(config)
    except ConfigError as exc:
        raise ConfigError(f"{args.path}: {exc}") from None
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
        description="Validate a configuration file; exit 0 if valid, 2 with the key if not.",
    )
    check.add_argument("path", metavar="PATH")
    check.set_defaults(handler=_check_config)
