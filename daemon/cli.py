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
import faulthandler
import json
import logging
import os
import signal
import sys
import threading
import time
import tomllib
import traceback
from collections import deque
from collections.abc import Iterator, Sequence
from typing import TYPE_CHECKING, Any, NoReturn, TextIO

import numpy as np

from daemon.detection import detect_frames
from drivers.errors import ConfigError, InputError, WeatherdError
from drivers.video import Frame, VideoWriter, open_video, read_roi_mask, roi_for_size
from hos.overlay import draw_overlay
from hos.params import DetectorParams
from hos.pipeline import HosDetector
from hos.result import FrameResult

if TYPE_CHECKING:
    from daemon.config import Config

__all__ = ["main", "read_roi"]

# Not __name__: ``python -m daemon.cli`` runs this module as ``__main__``.
log = logging.getLogger("daemon.cli")

#: Where ``watch`` and ``get`` connect by default: the demo configuration's listen endpoint.
DEFAULT_CONNECT = "tcp/127.0.0.1:7447"

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
        if _raised_by_interrupt(exc):
            return EXIT_INTERRUPTED
        if args.debug:
            traceback.print_exc()
        _print_error(f"internal error: {type(exc).__name__}: {exc}")
        return EXIT_INTERNAL


def _raised_by_interrupt(exc: BaseException) -> bool:
    """True when ``exc`` came of a Ctrl-C: a KeyboardInterrupt raised while native code ran
    (a numba kernel, for one) can surface as a SystemError ("returned a result with an
    exception set") whose context is the KeyboardInterrupt."""
    seen: set[int] = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return True
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return False


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
        # Ctrl-C (or SIGTERM) sets a flag read between frames, rather than raising wherever the
        # main thread happens to be (inside a compiled kernel, the exception would be garbled);
        # a second one ends the process at once.
        stop = _StopOnSignals()
        try:
            for result in results:
                frame = in_flight.popleft()
                if jsonl is not None:
                    jsonl.write(_json_line(result))
                if overlay is not None:
                    overlay.write(draw_overlay(frame.gray, result, params=params))
                frames += 1
                rain_frames += bool(result.rain)
                if stop.event.is_set():
                    interrupted = True
                    break
        except KeyboardInterrupt:
            interrupted = True
        finally:
            stop.restore()
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
    return roi_for_size(read_roi_mask(path), width=width, height=height)


# -- run ---------------------------------------------------------------------------------
def _run(args: argparse.Namespace) -> int:
    """``weatherd run``: the service, until SIGINT or SIGTERM (a second one forces the exit).

    Exit statuses: 0 after a signal, 2 for a configuration error (systemd does not restart on
    it), 1 for anything unexpected (systemd restarts).
    """
    from daemon.app import Daemon  # imports Zenoh and the recorder only when needed
    from daemon.config import load_config, parse_config

    # A watchdog timeout is a SIGABRT: the journal then shows where every thread was.
    faulthandler.enable(all_threads=True)

    config = load_config(args.config) if args.config else parse_config({})
    stop = _StopOnSignals()
    try:
        status = Daemon(config, stop=stop.event).run()
    finally:
        stop.restore()
    if stop.signum is not None:
        log.info("%s received; exited cleanly", signal.Signals(stop.signum).name)
    return status


def _replay(args: argparse.Namespace) -> int:
    """``weatherd replay VIDEO... --out FILE.mcap``: the daemon's MCAP, offline."""
    from daemon.config import detector_params, load_config, parse_config
    from daemon.replay import parse_start, replay

    config = load_config(args.config) if args.config else parse_config({})
    summary = replay(
        args.videos,
        args.out,
        site=config.site.id if args.config else "replay",
        camera=args.camera,
        params=detector_params({"detector": config.detector}),
        recording=config.recording,
        start_ns=parse_start(args.start) if args.start else None,
        fps=args.fps,
        progress=not args.no_progress,
    )
    print(json.dumps(_as_json(summary), separators=(",", ":")))
    return EXIT_OK


def _instruments_decode(args: argparse.Namespace) -> int:
    """``weatherd instruments decode --driver NAME FILE``: one JSON line per reading.

    Bad frames are reported on stderr with their line number and counted, never fatal.
    """
    from drivers.instruments import DRIVERS
    from drivers.instruments.decode import DecodeStats, decode_file

    options: dict[str, Any] = {}
    for item in args.option or []:
        key, sep, text = item.partition("=")
        if not sep or not key:
            raise InputError(f"--option {item!r}: expected KEY=VALUE")
        try:  # a TOML value (number, string, array, inline table), else plain text
            options[key] = tomllib.loads(f"v = {text}")["v"]
        except tomllib.TOMLDecodeError:
            options[key] = text
    stats = DecodeStats()
    try:
        readings = decode_file(DRIVERS[args.driver], args.file, options=options, stats=stats)
    except ConfigError as exc:
        raise ConfigError(f"--option: {exc}") from None
    n_bad = 0
    for reading in readings:
        sys.stdout.write(json.dumps(reading.to_json(), separators=(",", ":")) + "\n")
        for line, reason in stats.bad[n_bad:]:
            print(f"weatherd: {args.file}:{line}: {reason}", file=sys.stderr)
        n_bad = len(stats.bad)
    for line, reason in stats.bad[n_bad:]:
        print(f"weatherd: {args.file}:{line}: {reason}", file=sys.stderr)
    sys.stdout.flush()
    print(
        f"weatherd: {args.file}: {stats.readings} readings, {len(stats.bad)} bad frame(s), "
        f"{stats.garbage_bytes} garbage byte(s)",
        file=sys.stderr,
    )
    return EXIT_OK


def _reference(args: argparse.Namespace) -> int:
    """``weatherd reference FILE [--station ID]``: station data as JSON lines (contract)."""
    from daemon.offline.reference import load_reference, reference_json

    data = load_reference(
        args.file,
        station=args.station,
        fmt=args.format,
        tz=args.tz,
        interval_s=args.interval,
        month=args.month,
    )
    for interval in data.intervals:
        sys.stdout.write(json.dumps(reference_json(interval), separators=(",", ":")) + "\n")
    sys.stdout.flush()
    st = data.stats
    notes = [
        f"{v} {k.replace('_', ' ')}"
        for k, v in dataclasses.asdict(st).items()
        if isinstance(v, int)
        and not isinstance(v, bool)
        and v
        and k not in ("rows", "first_malformed_line")
    ]
    print(
        f"weatherd: {args.file}: {data.fmt}, {len(data.intervals)} intervals"
        + "".join(f"; {n}" for n in notes),
        file=sys.stderr,
    )
    return EXIT_OK


def _report_path(args: argparse.Namespace) -> str | None:
    """--report, else report.html in the --plots folder."""
    if args.report:
        return args.report
    return os.path.join(args.plots, "report.html") if args.plots else None


def _reference_options(args: argparse.Namespace) -> dict[str, Any]:
    options = {"fmt": args.format, "tz": args.tz, "interval_s": args.interval, "month": args.month}
    return {k: v for k, v in options.items() if v is not None and not (k == "tz" and v == "UTC")}


def _offline_options(args: argparse.Namespace) -> dict[str, Any]:
    """The keyword arguments that ``calibrate`` and ``compare`` share."""
    return {
        "station": args.station,
        "camera": args.camera,
        "threshold_mm": args.threshold_mm,
        "plots_dir": args.plots,
        "report": _report_path(args),
        "reference_options": _reference_options(args),
        "progress": False if args.no_progress else None,
    }


def _calibrate(args: argparse.Namespace) -> int:
    """``weatherd calibrate``: fit R -> mm/h; ends with one JSON line (contract)."""
    from daemon.offline.calibrate import calibrate

    result = calibrate(
        args.mcap, args.reference, model=args.model, out=args.out, **_offline_options(args)
    )
    print(json.dumps(_as_json(result), separators=(",", ":"), allow_nan=False))
    return EXIT_OK


def _compare(args: argparse.Namespace) -> int:
    """``weatherd compare``: the camera's presence scores against station data."""
    from daemon.offline.compare import compare

    result = compare(
        args.mcap,
        args.reference,
        camera_fraction=args.camera_fraction,
        **_offline_options(args),
    )
    if not args.full:
        result = {k: v for k, v in result.items() if k != "table"}
    print(json.dumps(_as_json(result), separators=(",", ":"), allow_nan=False))
    c = result.get("confusion") or {}
    if c:
        scores = " ".join(f"{k.upper()} {c.get(k)}" for k in ("tp", "fp", "tn", "fn", "tpr", "fpr"))
        print(f"weatherd: {scores} accuracy {c.get('accuracy')}", file=sys.stderr)
    return EXIT_OK


def _check_config(args: argparse.Namespace) -> int:
    """``weatherd check-config PATH``: validate, print a one-line summary, exit 0 or 2."""
    from daemon.app import check_paths
    from daemon.config import load_config
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


def _recover(args: argparse.Namespace) -> int:
    """``weatherd recover BROKEN.mcap OUT.mcap``: repair an unfinished recording."""
    from daemon.mcap_repair import recover

    result = recover(args.broken, args.out)
    print(json.dumps(_as_json(result), separators=(",", ":")))
    return EXIT_OK


def _as_json(value: object) -> object:
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {k: _as_json(v) for k, v in dataclasses.asdict(value).items()}
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    return value


def _watch(args: argparse.Namespace) -> int:
    """``weatherd watch [KEYEXPR]``: print Zenoh samples as JSON lines until Ctrl-C."""
    from daemon.watch import watch

    return watch(
        args.keyexpr,
        _zenoh_conf(args),
        count=args.count,
        timeout_s=args.timeout,
    )


def _get(args: argparse.Namespace) -> int:
    """``weatherd get SELECTOR``: query the daemon's queryable, one JSON line per reply."""
    from daemon.watch import get

    replies = get(args.selector, _zenoh_conf(args), timeout_s=args.timeout or 5.0)
    for reply in replies:
        print(json.dumps(reply, separators=(",", ":")), flush=True)
    if not replies:
        raise InputError(f"{args.selector}: no reply (is the daemon running and reachable?)")
    return EXIT_OK


def _zenoh_conf(args: argparse.Namespace) -> object:
    from daemon.config import load_config
    from daemon.publisher import zenoh_config

    zc = load_config(args.config).zenoh if args.config else None
    connect = args.connect or (zc.connect if zc else []) or [DEFAULT_CONNECT]
    return zenoh_config(
        mode=args.mode,  # None: the config file's mode, else peer
        connect=connect,
        config_file=zc.config_file if zc else None,
    )


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
def _config_params(path: str | None) -> tuple[Config | None, DetectorParams]:
    """The configuration file (or none) and its global detector parameters."""
    if path is None:
        return None, DetectorParams()
    # Imported here: pydantic costs 0.15 s of start-up that `weatherd detect VIDEO` without
    # --config does not need.
    from daemon.config import detector_params, load_config

    config = load_config(path)
    return config, detector_params({"detector": config.detector})


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
        help="the daemon: cameras in, weather state out over Zenoh, MCAP on disk",
        description="Run the service until SIGINT or SIGTERM. Without a camera in the "
        "configuration it watches the built-in demo camera.",
    )
    run.add_argument("--config", metavar="PATH", help="TOML configuration file")
    run.set_defaults(handler=_run)

    check = commands.add_parser(
        "check-config",
        parents=[common],
        help="validate a configuration file",
        description="Validate a configuration file; exit 0 if valid, 2 with the key if not.",
    )
    check.add_argument("path", metavar="PATH")
    check.set_defaults(handler=_check_config)

    replay = commands.add_parser(
        "replay",
        parents=[common],
        help="the daemon's pipeline over recorded video, into an MCAP file",
        description="Run the detector over video files (one after the other, as one camera) "
        "and write the same MCAP topics as the daemon.",
    )
    replay.add_argument("videos", metavar="VIDEO", nargs="+")
    replay.add_argument("--out", metavar="FILE.mcap", required=True)
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

    instruments = commands.add_parser(
        "instruments",
        parents=[common],
        help="serial instruments: decode captures",
        description="Tools for the serial instruments.",
    )
    inst_commands = instruments.add_subparsers(
        dest="instruments_command", required=True, metavar="COMMAND", parser_class=_ArgumentParser
    )
    decode = inst_commands.add_parser(
        "decode",
        parents=[common],
        help="parse a raw capture or logger file into JSON lines",
        description="Parse a raw serial capture (or a logger's file) of an instrument: one JSON "
        "line per reading on stdout; bad frames on stderr with their line number.",
    )
    decode.add_argument(
        "--driver",
        required=True,
        choices=_driver_names(),
        metavar="NAME",
        help="one of: " + ", ".join(_driver_names()),
    )
    decode.add_argument("file", metavar="FILE")
    decode.add_argument(
        "--option",
        action="append",
        metavar="KEY=VALUE",
        help="a driver option (TOML value), e.g. --option mm_per_tip=0.1",
    )
    decode.set_defaults(handler=_instruments_decode)

    reference = commands.add_parser(
        "reference",
        parents=[common],
        help="station data (Météo-France, CSV, METAR, a gauge in MCAP) as JSON lines",
        description="Parse a station's reference file: one JSON line per interval, "
        '{"start", "end", "precip_mm", "station"} (times in UTC, intervals [start, end)).',
    )
    reference.add_argument("file", metavar="FILE")
    reference.add_argument("--station", metavar="ID", help="keep only this station")
    reference.add_argument(
        "--format",
        metavar="FMT",
        help="force the format: mf-hourly, mf-6min, mf-commande, mf-obs-json, csv, metar, "
        "mcap-gauge (default: detected)",
    )
    reference.add_argument("--tz", default="UTC", help="time zone of naive times (default UTC)")
    reference.add_argument("--interval", type=float, metavar="S", help="interval length, s")
    reference.add_argument("--month", metavar="YYYY-MM", help="for METAR reports without date")
    reference.set_defaults(handler=_reference)

    offline = argparse.ArgumentParser(add_help=False)
    offline.add_argument(
        "--mcap", nargs="+", required=True, metavar="PATH", help="MCAP files or directories"
    )
    offline.add_argument("--reference", required=True, metavar="FILE", help="station data")
    offline.add_argument("--station", metavar="ID", help="the station, in a multi-station file")
    offline.add_argument("--camera", metavar="ID", help="the camera, when the logs hold several")
    offline.add_argument("--plots", metavar="DIR", help="write PNG plots and report.html here")
    offline.add_argument("--report", metavar="FILE.html", help="write the HTML report here")
    offline.add_argument(
        "--threshold-mm",
        type=float,
        default=0.1,
        metavar="MM",
        help="reference amount from which an interval is wet (default 0.1)",
    )
    offline.add_argument("--format", metavar="FMT", help="force the reference format")
    offline.add_argument("--tz", default="UTC", help="time zone of naive reference times")
    offline.add_argument("--interval", type=float, metavar="S", help="reference interval, s")
    offline.add_argument("--month", metavar="YYYY-MM", help="for METAR reports without date")
    offline.add_argument("--no-progress", action="store_true", help="no progress bar")

    calibrate = commands.add_parser(
        "calibrate",
        parents=[common, offline],
        help="fit the site calibration of R -> mm/h against station data",
        description="Fit mm/h against the camera's R over each reference interval (linear "
        "through the origin and a power law, robust, with bootstrap confidence intervals), "
        "write the calibration file the daemon loads, and print one JSON line.",
    )
    calibrate.add_argument(
        "--out", default="calibration.toml", metavar="FILE", help="default calibration.toml"
    )
    calibrate.add_argument("--model", choices=("linear", "power"), help="default: the better")
    calibrate.set_defaults(handler=_calibrate)

    compare = commands.add_parser(
        "compare",
        parents=[common, offline],
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

    recover = commands.add_parser(
        "recover",
        parents=[common],
        help="repair an unfinished MCAP recording",
        description="Copy every complete message of an unfinished or truncated MCAP file into "
        "a new, finished one.",
    )
    recover.add_argument("broken", metavar="BROKEN.mcap")
    recover.add_argument("out", metavar="OUT.mcap")
    recover.set_defaults(handler=_recover)

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

    watch = commands.add_parser(
        "watch",
        parents=[common, zenoh_common],
        help="print what the daemon publishes (a Zenoh subscriber)",
        description="Subscribe to KEYEXPR and print one JSON line per sample.",
    )
    watch.add_argument("keyexpr", metavar="KEYEXPR", nargs="?", default="weather/**")
    watch.add_argument("--count", type=int, metavar="N", help="stop after N samples")
    watch.set_defaults(handler=_watch)

    get = commands.add_parser(
        "get",
        parents=[common, zenoh_common],
        help="query the daemon's latest values",
        description="Query SELECTOR (e.g. 'weather/demo/**') and print one JSON line per reply.",
    )
    get.add_argument("selector", metavar="SELECTOR")
    get.set_defaults(handler=_get)
    return parser


def _driver_names() -> list[str]:
    from drivers.instruments import DRIVERS

    return sorted(DRIVERS)


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
