"""``weatherd simulate OUT.mp4``: the demo camera's synthetic street, written as a video.

A first clip for ``weatherd detect`` and ``weatherd replay`` without a camera at hand: the
street of the demo camera (cars, pedestrians, wind in the tree, sensor noise) under a chosen
weather. ``--truth`` writes what the simulator drew, frame by frame, from which a reference
"gauge" can be derived (see ``docs/example/``).
"""

from __future__ import annotations

import argparse
import csv
import json
import math
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING

from drivers.errors import InputError

from .common import EXIT_OK, as_json

if TYPE_CHECKING:
    import numpy as np

__all__ = ["register", "schedule"]

WEATHERS = ("clear", "rain", "snow", "cycle")

#: (rain, snow) multipliers of each weather at intensity 1; ``cycle`` is the demo's own.
_KINDS = {"clear": (0.0, 0.0), "rain": (1.0, 0.0), "snow": (0.0, 1.0)}


def schedule(
    weather: str, intensities: list[float], *, frames: int
) -> list[tuple[float, float]] | None:
    """(rain, snow) multipliers per frame: ``intensities`` in equal steps over ``frames``
    (``[1.0]``: the same all along); None for the demo's cycle (clear, rain, clear, snow).

    Raises
    ------
    InputError : an unknown weather, a negative intensity, or a list with ``cycle``.
    """
    if weather not in WEATHERS:
        raise InputError(f"--weather: expected one of {', '.join(WEATHERS)}, got {weather!r}")
    if any(not (math.isfinite(k) and k >= 0) for k in intensities):
        raise InputError(f"--intensity: multipliers must be >= 0, got {intensities}")
    if weather == "cycle":
        if intensities != [1.0]:
            raise InputError("--intensity cannot be used with --weather cycle")
        return None
    rain, snow = _KINDS[weather]
    import numpy as np  # here: every command's parser imports this module

    steps = np.minimum(np.arange(frames) * len(intensities) // max(frames, 1), len(intensities) - 1)
    return [(rain * intensities[k], snow * intensities[k]) for k in steps]


def _intensities(text: str) -> list[float]:
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected numbers separated by commas, got {text!r}"
        ) from None
    return values


def _simulate(args: argparse.Namespace) -> int:
    """``weatherd simulate OUT.mp4``: render the demo street and write it as a video."""
    from daemon.offline.progress import progress_bar
    from drivers.simulator import Scene, demo_params, write_video

    for name in ("seconds", "fps"):
        if not getattr(args, name) > 0:
            raise InputError(f"--{name}: must be > 0, got {getattr(args, name)}")
    if args.width < 64 or args.height < 36 or args.width % 2 or args.height % 2:
        raise InputError(
            f"--width/--height: an even size of at least 64x36 is needed, got "
            f"{args.width}x{args.height}"
        )
    if args.seed < 0:
        raise InputError(f"--seed: must be >= 0, got {args.seed}")
    n = max(1, round(args.seconds * args.fps))
    plan = schedule(args.weather, args.intensity, frames=n)
    params = demo_params(args.width, args.height, args.fps, schedule=plan)
    scene = Scene(args.width, args.height, seed=args.seed, params=params)
    out = Path(args.out)
    if not out.parent.is_dir():
        raise InputError(f"{out}: no such directory {str(out.parent)!r}")
    bar = progress_bar(n, desc=out.name, enabled=not args.quiet)
    truth_rows: list[list[object]] = []

    def frames() -> Iterator[np.ndarray]:
        for gray, truth in scene.frames(0, n):
            if args.truth:
                truth_rows.append(
                    [
                        truth.index,
                        f"{truth.index / args.fps:.6f}",
                        truth.kind,
                        f"{truth.rain_intensity:g}",
                        f"{truth.snow_intensity:g}",
                        int(truth.theta.size),
                    ]
                )
            if bar is not None:
                bar.update(1)
            yield gray

    try:
        written = write_video(out, frames(), args.fps)
    except (ValueError, OSError) as exc:  # no encoder, or the file cannot be written
        raise InputError(f"{out}: cannot write the video ({exc})") from None
    finally:
        if bar is not None:
            bar.close()
    if args.truth:
        _write_truth(args.truth, truth_rows)
    summary = {
        "out": str(out),
        "frames": written,
        "seconds": written / args.fps,
        "fps": args.fps,
        "width": args.width,
        "height": args.height,
        "seed": args.seed,
        "weather": args.weather,
        "intensity": args.intensity,
        "truth": args.truth,
    }
    print(_json(summary))
    return EXIT_OK


def _write_truth(path: str, rows: list[list[object]]) -> None:
    try:
        with open(path, "w", newline="", encoding="utf-8") as f:
            writer = csv.writer(f)
            writer.writerow(
                ["frame", "t_s", "kind", "rain_intensity", "snow_intensity", "particles"]
            )
            writer.writerows(rows)
    except OSError as exc:
        raise InputError(f"{path}: cannot write ({exc.strerror or exc})") from None


def _json(value: object) -> str:
    return json.dumps(as_json(value), separators=(",", ":"))


def register(commands: argparse._SubParsersAction, parents: list[argparse.ArgumentParser]) -> None:
    """Add ``weatherd simulate`` to ``commands``."""
    simulate = commands.add_parser(
        "simulate",
        parents=parents,
        help="write the demo camera's synthetic street as a video file",
        description="Render the demo camera's street (cars, pedestrians, wind, sensor noise) "
        "under the chosen weather and write it as a video, for 'weatherd detect' and "
        "'weatherd replay'. Prints one JSON line (the file, frames, settings).",
        epilog="Example: weatherd simulate street.mp4 --seconds 60 --weather rain; "
        "weatherd detect street.mp4",
    )
    simulate.add_argument(
        "out", metavar="OUT.mp4", help="video file to write (.mp4, .mkv, .avi: by extension)"
    )
    simulate.add_argument(
        "--seconds", type=float, default=30.0, metavar="S", help="length (default 30 s)"
    )
    simulate.add_argument("--width", type=int, default=640, metavar="W", help="default 640 px")
    simulate.add_argument("--height", type=int, default=360, metavar="H", help="default 360 px")
    simulate.add_argument("--fps", type=float, default=25.0, metavar="F", help="default 25")
    simulate.add_argument(
        "--seed", type=int, default=0, metavar="N", help="the same seed gives the same video"
    )
    simulate.add_argument(
        "--weather",
        choices=WEATHERS,
        default="cycle",
        help="clear, rain or snow throughout, or the demo camera's two-minute cycle: clear "
        "20 s, rain 40 s, clear 20 s, then snow (first cycle) or heavy rain (second) 40 s "
        "(default: cycle)",
    )
    simulate.add_argument(
        "--intensity",
        type=_intensities,
        default=[1.0],
        metavar="K[,K...]",
        help="rain or snow multiplier (1: moderate, 2: twice the streaks); several, separated "
        "by commas, play one after the other in equal steps (default 1)",
    )
    simulate.add_argument(
        "--truth",
        metavar="FILE.csv",
        help="also write what was drawn, one row per frame: frame, t_s, kind, rain_intensity, "
        "snow_intensity, particles",
    )
    simulate.add_argument("--quiet", action="store_true", help="no progress bar")
    simulate.set_defaults(handler=_simulate)
