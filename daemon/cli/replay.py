"""``weatherd replay VIDEO... --out FILE.mcap``: the daemon's pipeline over recorded video."""

from __future__ import annotations

import argparse
import json

from .common import EXIT_OK, as_json

__all__ = ["register"]


def _replay(args: argparse.Namespace) -> int:
    """``weatherd replay VIDEO... --out FILE.mcap``: the daemon's MCAP, offline."""
    from daemon.config import detector_params, load_config, parse_config
    from daemon.offline.replay import parse_start, replay

    config = load_config(args.config) if args.config else parse_config({})
    summary = replay(
        args.videos,
        args.out,
        site=config.site.id if args.config else "replay",
        camera=args.camera,
        params=detector_params({"detector": config.detector}),
        recording=config.recording,
        fusion=config.fusion,
        start_ns=parse_start(args.start) if args.start else None,
        fps=args.fps,
        progress=not args.no_progress,
    )
    print(json.dumps(as_json(summary), separators=(",", ":")))
    return EXIT_OK


def register(commands: argparse._SubParsersAction, parents: list[argparse.ArgumentParser]) -> None:
    """Add ``weatherd replay`` to ``commands``."""
    replay = commands.add_parser(
        "replay",
        parents=parents,
        help="the daemon's pipeline over recorded video, into an MCAP file",
        description="Run the detector over video files (one after the other, as one camera) "
        "and write the same MCAP topics as the daemon.",
    )
    replay.add_argument(
        "videos",
        metavar="VIDEO",
        nargs="+",
        help="video files (.mp4, .mkv, .avi...) or folders of images, in the order they "
        "were filmed; each starts a fresh detector and follows the previous one in time",
    )
    replay.add_argument(
        "--out",
        metavar="FILE.mcap",
        required=True,
        help="the MCAP log to write (overwritten; its folder is created), with the daemon's "
        "topics: per-frame results, histograms, thumbnails, camera summaries and site state",
    )
    replay.add_argument(
        "--start",
        metavar="ISO-8601",
        help="UTC time of the first frame (default: the file's modification time)",
    )
    replay.add_argument(
        "--fps", type=float, metavar="N", help="frame times from this rate, not the container's"
    )
    replay.add_argument("--config", metavar="PATH", help="TOML file: site, detector, recording")
    replay.add_argument("--camera", metavar="ID", default="replay", help="camera id in topics")
    replay.add_argument("--no-progress", action="store_true", help="no progress bar")
    replay.set_defaults(handler=_replay)
