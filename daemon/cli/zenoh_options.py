"""The Zenoh options that ``weatherd watch`` and ``get`` share."""

from __future__ import annotations

import argparse

__all__ = ["DEFAULT_CONNECT", "zenoh_conf", "zenoh_parser"]

#: Where ``watch`` and ``get`` connect by default: the demo configuration's listen endpoint.
DEFAULT_CONNECT = "tcp/127.0.0.1:7447"


def zenoh_conf(args: argparse.Namespace) -> object:
    from daemon.config import load_config
    from daemon.transport.publisher import zenoh_config

    zc = load_config(args.config).zenoh if args.config else None
    connect = args.connect or (zc.connect if zc else []) or [DEFAULT_CONNECT]
    return zenoh_config(
        mode=args.mode,  # None: the config file's mode, else peer
        connect=connect,
        config_file=zc.config_file if zc else None,
    )


def zenoh_parser() -> argparse.ArgumentParser:
    """The parent parser of the shared options."""
    zenoh_common = argparse.ArgumentParser(add_help=False)
    zenoh_common.add_argument(
        "--connect",
        action="append",
        metavar="ENDPOINT",
        help="a router or the daemon's listen endpoint (default tcp/127.0.0.1:7447, the demo's)",
    )
    zenoh_common.add_argument("--mode", choices=("peer", "client"), help="Zenoh mode")
    zenoh_common.add_argument("--config", metavar="PATH", help="take [zenoh] from this file")
    zenoh_common.add_argument("--timeout", type=float, metavar="S", help="stop after S seconds")
    return zenoh_common
