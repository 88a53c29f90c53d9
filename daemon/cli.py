"""The ``weatherd`` command: argument parsing, exit statuses, and the small offline commands.

Exit statuses (contract): 0 success; 2 unreadable or malformed input or configuration, with
one line ``weatherd: error: <message>`` on stderr and never a traceback; 1 an unexpected internal
error (one line; ``--debug`` shows the traceback); 130 interrupted by Ctrl-C (the output written
so far is kept and closed properly).

Logging is configured here and only here: to stderr, one line per event.
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import json
import logging
import math
import os
import signal
import sys
import threading
import time
import tomllib
import traceback
import typing
from collections import deque
from collections.abc import Iterator, Sequence
from typing import Any, NoReturn, TextIO

import cv2
import numpy as np

from daemon.detection import detect_frames
from drivers.errors import ConfigError, InputError, WeatherdError
from drivers.video import Frame, VideoWriter, open_video, read_gray_image
from hos.overlay import draw_overlay
from hos.params import DetectorParams
from hos.pipeline import HosDetector
from hos.result import FrameResult

__all__ = ["detector_params", "load_config", "main", "read_roi"]

# Not __name__: ``python -m daemon.cli`` runs this module as ``__main__``.
log = logging.getLogger("daemon.cli")

#: The demo camera of ``weatherd run`` until the daemon has real frame sources.
DEMO_WIDTH, DEMO_HEIGHT, DEMO_FPS = 640, 360, 25.0
#: Seconds between two summary lines of ``weatherd run``.
SUMMARY_INTERVAL_S = 5.0

EXIT_OK, EXIT_INTERNAL, EXIT_USAGE, EXIT_INTERRUPTED = 0, 1, 2, 130


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``weatherd`` with ``argv`` (default: the process's arguments); return the exit
    status."""
    parser = _parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # --help, or a usage error already reported in one line
        return exc.code if isinstance(exc.code, int) else EXIT_USAGE
    _configure_logging(args.command, debug=args.debug)
    try:
        return args.handler(args)
    except WeatherdError as exc:
        _print_error(str(exc))
        return EXIT_USAGE
    except KeyboardInterrupt:
        return EXIT_INTERRUPTED
    except BrokenPipeError:  # whoever read our stdout went away: nothing left to say
        with contextlib.suppress(OSError):
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 128 + signal.SIGPIPE
    except Exception as exc:
        if args.debug:
            traceback.print_exc()
        _print_error(f"internal error: {type(exc).__name__}: {exc}")
        return EXIT_INTERNAL


# -- detect ------------------------------------------------------------------------------
def _detect(args: argparse.Namespace) -> int:
    """``weatherd detect VIDEO``: the detector over a file or image folder, offline."""
    params = _config_params(args.config)[1]
    frames = rain_frames = skipped = 0
    interrupted = False
    with contextlib.ExitStack() as stack:  # closed in reverse: overlay, JSONL, video
        video = stack.enter_context(open_video(args.video))
        roi = read_roi(args.roi, width=video.width, height=video.height) if args.roi else None
        detector = HosDetector(params, roi=roi)
        jsonl = stack.enter_context(_jsonl_output(args.jsonl)) if args.jsonl else None
        overlay = (
            stack.enter_context(
                VideoWriter(args.overlay, width=video.width, height=video.height, fps=video.fps)
            )
            if args.overlay
            else None
        )
        in_flight: deque[Frame] = deque()  # frames whose result is not out yet (at most 2)

        def decoded() -> Iterator[tuple[float, np.ndarray]]:
            for frame in video:
                in_flight.append(frame)
                yield frame.t_s, frame.gray

        started = time.perf_counter()
        results = detect_frames(detector, decoded())  # segmentation of n+1 beside analysis of n
        try:
            for result in results:
                frame = in_flight.popleft()
                if jsonl is not None:
                    jsonl.write(_json_line(result))
                if overlay is not None:
                    overlay.write(draw_overlay(frame.gray, result, params=params))
                frames += 1
                rain_frames += bool(result.rain)
        except KeyboardInterrupt:
            interrupted = True
        finally:
            results.close()  # stops the segmentation worker
        elapsed = time.perf_counter() - started
        skipped = video.frames_skipped
    if not args.quiet:
        rate = frames / elapsed if elapsed > 0 else 0.0
        notes = [f"{skipped} corrupt frame(s) skipped"] if skipped else []
        notes += ["interrupted"] if interrupted else []
        print(
            f"weatherd: {args.video}: {frames} frames, {rain_frames} with rain, "
            f"{rate:.1f} frames/s" + "".join(f"; {n}" for n in notes),
            file=sys.stderr,
        )
    return EXIT_INTERRUPTED if interrupted else EXIT_OK


def _json_line(result: FrameResult) -> str:
    return json.dumps(result.to_json(), separators=(",", ":"), allow_nan=False) + "\n"


@contextlib.contextmanager
def _jsonl_output(target: str) -> Iterator[TextIO]:
    """The JSONL stream: ``-`` is stdout, anything else a file (overwritten)."""
    if target == "-":
        try:
            yield sys.stdout
        finally:
            sys.stdout.flush()
        return
    try:
        stream = open(target, "w", encoding="utf-8")
    except OSError as exc:
        raise WeatherdError(f"{target}: cannot write ({exc.strerror or exc})") from None
    with stream:
        yield stream


def read_roi(path: str | os.PathLike[str], *, width: int, height: int) -> np.ndarray:
    """The region of interest: (height, width) bool, True where analysed.

    Any image; nonzero pixels are analysed. Resized with nearest neighbour if its size differs.

    Raises
    ------
    InputError : unreadable image, or a mask that selects no pixel.
    """
    mask = read_gray_image(path)
    if mask is None:
        raise InputError(f"{path}: cannot read the ROI mask (an image; nonzero = analysed)")
    if mask.shape != (height, width):
        mask = cv2.resize(mask, (width, height), interpolation=cv2.INTER_NEAREST)
    if not mask.any():
        raise InputError(f"{path}: the ROI mask selects no pixel (nonzero = analysed)")
    return mask != 0


# -- run ---------------------------------------------------------------------------------
def _run(args: argparse.Namespace) -> int:
    """``weatherd run``: the detector on the demo camera, in real time, until a signal.

    A minimal loop until the daemon (capture thread, fusion, Zenoh, MCAP) replaces it.
    """
    config, params = _config_params(args.config)
    site = _site_id(config)
    from hos.render import demo_frames  # the demo camera; imported only when needed

    stop = _StopOnSignals()
    detector = HosDetector(params)
    period = 1.0 / DEMO_FPS
    frames = demo_frames(DEMO_WIDTH, DEMO_HEIGHT, DEMO_FPS, seed=0)
    log.info(
        "site %s: demo camera %dx%d at %g fps; SIGINT or SIGTERM stops",
        site,
        DEMO_WIDTH,
        DEMO_HEIGHT,
        DEMO_FPS,
    )
    processed = window_frames = 0
    verdict: tuple[bool, str] | None = None
    due = window_start = time.monotonic()
    try:
        for i, (gray, _truth) in enumerate(frames):
            if not _sleep_until(due, stop.event):
                break
            result = detector.process(gray, i * period)
            processed += 1
            window_frames += 1
            if (result.rain, result.state) != verdict:
                verdict = (result.rain, result.state)
                log.info(
                    "%s, state %s (pi_smoothed=%.2f)",
                    "RAIN" if result.rain else "no rain",
                    result.state,
                    result.pi_smoothed,
                )
            now = time.monotonic()
            if now - window_start >= SUMMARY_INTERVAL_S:
                log.info("%s  fps=%.1f", _status(result), window_frames / (now - window_start))
                window_start, window_frames = now, 0
            due += period
            if now - due > 1.0:  # over a second late: carry on from now, do not race
                due = now
    finally:
        frames.close()
        stop.restore()
    if stop.signum is not None:
        log.info("%s: stopped after %d frames", signal.Signals(stop.signum).name, processed)
    return EXIT_OK


def _status(result: FrameResult) -> str:
    j = result.to_json()
    return (
        f"rain={j['rain']} state={j['state']} pi={_fmt(j['pi_smoothed'], '.2f')} "
        f"mu={_fmt(j['mu_smoothed_deg'], '.1f')} R={_fmt(j['R'], '.1f')}"
    )


def _fmt(value: float | None, spec: str) -> str:
    return "-" if value is None else format(value, spec)


def _sleep_until(deadline: float, stop: threading.Event) -> bool:
    """Sleep until ``deadline`` (monotonic seconds); False at once if ``stop`` is set.

    Sleeps in short steps instead of ``stop.wait``: the main thread, where the signal handler
    runs, must never hold the event's lock (``Event.set`` in the handler would deadlock).
    """
    while not stop.is_set():
        remaining = deadline - time.monotonic()
        if remaining <= 0.0:
            return True
        time.sleep(min(remaining, 0.1))
    return False


class _StopOnSignals:
    """SIGINT and SIGTERM set ``event``; a second one ends the process at once (the default
    action is restored after the first)."""

    _SIGNALS = (signal.SIGINT, signal.SIGTERM)

    def __init__(self) -> None:
        self.event = threading.Event()
        self.signum: int | None = None
        self._previous = {s: signal.signal(s, self._handle) for s in self._SIGNALS}

    def _handle(self, signum: int, _frame: object) -> None:
        self.signum = signum
        self.event.set()
        for s in self._SIGNALS:
            signal.signal(s, signal.SIG_DFL)

    def restore(self) -> None:
        for s, handler in self._previous.items():
            signal.signal(s, handler)


# -- configuration -----------------------------------------------------------------------
def _config_params(path: str | None) -> tuple[dict[str, Any], DetectorParams]:
    """The configuration file (or none) and its detector parameters; errors name the file."""
    if path is None:
        return {}, DetectorParams()
    config = load_config(path)
    try:
        return config, detector_params(config)
    except ConfigError as exc:
        raise ConfigError(f"{path}: {exc}") from None


def load_config(path: str | os.PathLike[str]) -> dict[str, Any]:
    """The TOML configuration file as a dict.

    Raises
    ------
    ConfigError : the file cannot be read or is not valid TOML.
    """
    try:
        with open(path, "rb") as f:
            return tomllib.load(f)
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read the configuration ({exc.strerror})") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise ConfigError(f"{path}: not valid TOML ({exc})") from None


def detector_params(config: dict[str, Any]) -> DetectorParams:
    """Detector parameters from the optional ``[detector]`` table of the configuration.

    Sub-tables ``segmentation``, ``histogram``, ``mixture``, ``decision``, ``robustness`` hold
    the fields of :mod:`hos.params` (angles as ``*_deg`` keys). Values are checked against the
    field types (an int is accepted for a float).

    Raises
    ------
    ConfigError : naming the key, for an unknown group or key or a value of the wrong type.
    """
    table = config.get("detector", {})
    if not isinstance(table, dict):
        raise ConfigError("detector: must be a table")
    groups = {f.name: f for f in dataclasses.fields(DetectorParams)}
    for group, values in table.items():
        if not isinstance(values, dict):
            raise ConfigError(f"detector.{group}: must be a table")
        if group not in groups:
            continue  # from_dict names it
        hints = typing.get_type_hints(getattr(DetectorParams(), group).__class__)
        for key, value in values.items():
            hint = hints.get(key.removesuffix("_deg"))
            if hint is not None:
                _check_value(f"detector.{group}.{key}", value, hint)
    try:
        return DetectorParams.from_dict(table)
    except (ValueError, TypeError) as exc:
        raise ConfigError(str(exc)) from None


def _check_value(key: str, value: object, hint: object) -> None:
    if typing.get_origin(hint) is typing.Literal:
        choices = typing.get_args(hint)
        if value not in choices:
            raise ConfigError(f"{key}: must be one of {', '.join(map(repr, choices))}")
    elif hint is bool:
        if not isinstance(value, bool):
            raise ConfigError(f"{key}: must be true or false, got {value!r}")
    elif hint is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise ConfigError(f"{key}: must be an integer, got {value!r}")
    elif hint is float and (
        isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value)
    ):
        raise ConfigError(f"{key}: must be a finite number, got {value!r}")


def _site_id(config: dict[str, Any]) -> str:
    site = config.get("site", {})
    if not isinstance(site, dict):
        raise ConfigError("site: must be a table")
    site_id = site.get("id", "demo")
    if not isinstance(site_id, str) or not site_id:
        raise ConfigError("site.id: must be a non-empty string")
    return site_id


# -- plumbing ----------------------------------------------------------------------------
class _ArgumentParser(argparse.ArgumentParser):
    """Usage errors in one line, like every other error of ``weatherd``."""

    def error(self, message: str) -> NoReturn:
        _print_error(f"{message} (see '{self.prog} --help')")
        raise SystemExit(EXIT_USAGE)


def _parser() -> argparse.ArgumentParser:
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument(
        "--debug",
        action="store_true",
        default=argparse.SUPPRESS,
        help="log debug messages and show the traceback of an internal error",
    )
    parser = _ArgumentParser(
        prog="weatherd",
        description="Rain and snow detection from a fixed camera (HOS, Bossu et al. 2011).",
        parents=[common],
    )
    parser.set_defaults(debug=False)
    commands = parser.add_subparsers(
        dest="command", required=True, metavar="COMMAND", parser_class=_ArgumentParser
    )

    detect = commands.add_parser(
        "detect",
        parents=[common],
        help="offline detection on a video file or image folder",
        description="Run the detector over a video file or a folder of images.",
    )
    detect.add_argument("video", metavar="VIDEO", help="video file, or folder of images")
    detect.add_argument(
        "--jsonl", metavar="PATH", help="write one JSON object per frame ('-' for stdout)"
    )
    detect.add_argument("--overlay", metavar="OUT", help="write the overlay video (.mp4...)")
    detect.add_argument("--config", metavar="PATH", help="TOML file; its [detector] table")
    detect.add_argument("--roi", metavar="MASK", help="mask image, nonzero = analysed")
    detect.add_argument("--quiet", action="store_true", help="no summary line on stderr")
    detect.set_defaults(handler=_detect)

    run = commands.add_parser(
        "run",
        parents=[common],
        help="the daemon (for now: the demo camera, in real time)",
        description="Run the detector continuously until SIGINT or SIGTERM.",
    )
    run.add_argument("--config", metavar="PATH", help="TOML configuration file")
    run.set_defaults(handler=_run)
    return parser


def _configure_logging(command: str, *, debug: bool) -> None:
    if command == "run":
        level = logging.INFO
        # journald stamps every line itself
        stamp = "" if os.environ.get("JOURNAL_STREAM") else "%(asctime)s "
        fmt = stamp + "%(levelname)s %(name)s: %(message)s"
    else:
        level = logging.WARNING
        fmt = "weatherd: %(message)s"
    logging.basicConfig(level=logging.DEBUG if debug else level, format=fmt, stream=sys.stderr)


def _print_error(message: str) -> None:
    print(f"weatherd: error: {' '.join(message.split())}", file=sys.stderr, flush=True)


if __name__ == "__main__":
    sys.exit(main())
