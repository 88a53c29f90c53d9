"""The ``weatherd`` command: one module per subcommand, each with its ``register`` (its
options) and its handler; this one assembles the parser and maps exceptions to exit statuses.

Exit statuses (contract): 0 success; 2 unreadable or malformed input or configuration, with
one line ``weatherd: error: <message>`` on stderr per problem (a configuration with several
problems gets one line each) and never a traceback; 74 (``EX_IOERR``) an output or device
failed: the disk is full, a quota or the file size limit was reached, an I/O error, a read-only
file system (one line ``weatherd: error: PATH: no space left on device``; systemd restarts
``run`` on it, unlike 2); 1 an unexpected internal error (one line; ``--debug`` shows the
traceback); 130 interrupted by Ctrl-C (the output written so far is kept and closed properly).

Logging is configured here and only here: to stderr, one line per event.
"""

from __future__ import annotations

import argparse
import contextlib
import errno
import logging
import os
import signal
import sys
import traceback
from collections.abc import Sequence

from drivers.errors import WeatherdError

from . import (
    calibrate,
    check_config,
    compare,
    detect,
    get,
    instruments,
    recover,
    reference,
    replay,
    run,
    simulate,
    watch,
)
from .common import (
    EXIT_INTERNAL,
    EXIT_INTERRUPTED,
    EXIT_IO,
    EXIT_USAGE,
    ArgumentParser,
    print_error,
)

__all__ = ["main"]

#: The subcommands, in the order ``weatherd --help`` lists them.
COMMANDS = (
    detect,
    simulate,
    run,
    check_config,
    replay,
    instruments,
    reference,
    calibrate,
    compare,
    recover,
    watch,
    get,
)


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
        for line in getattr(exc, "errors", None) or (str(exc),):  # ConfigErrors: one a line
            print_error(line)
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
        device = _device_error(exc)
        if device is not None:
            if args.debug:
                traceback.print_exc()
            print_error(device)
            return EXIT_IO
        if args.debug:
            traceback.print_exc()
        print_error(f"internal error: {type(exc).__name__}: {exc}")
        return EXIT_INTERNAL


#: Errors of the device rather than of the input or of weatherd: exit status 74.
_DEVICE_ERRNOS = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EFBIG, errno.EIO, errno.EROFS})


def _device_error(exc: BaseException) -> str | None:
    """``PATH: no space left on device`` when ``exc`` (or what caused it) is a full disk, a
    quota, an I/O error or a read-only file system; None for anything else."""
    seen: set[int] = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, OSError) and exc.errno in _DEVICE_ERRNOS:
            what = os.strerror(exc.errno).lower()
            return f"{exc.filename}: {what}" if exc.filename else f"writing an output: {what}"
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return None


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


def _parser() -> argparse.ArgumentParser:
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument(
        "--debug",
        action="store_true",
        default=argparse.SUPPRESS,
        help="log debug messages and show the traceback of an internal error",
    )
    parser = ArgumentParser(
        prog="weatherd",
        description="Rain and snow detection from a fixed camera (HOS, Bossu et al. 2011).",
        parents=[common],
    )
    parser.set_defaults(debug=False)
    commands = parser.add_subparsers(
        dest="command", required=True, metavar="COMMAND", parser_class=ArgumentParser
    )

    for command in COMMANDS:
        command.register(commands, [common])
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
