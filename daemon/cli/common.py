"""What every subcommand shares: exit statuses, one-line errors, signals, the detector's
parameters from a configuration file."""

from __future__ import annotations

import argparse
import dataclasses
import os
import signal
import sys
import threading
from typing import TYPE_CHECKING, NoReturn

from hos.params import DetectorParams

if TYPE_CHECKING:
    from daemon.config import Config

__all__ = [
    "EXIT_INTERNAL",
    "EXIT_INTERRUPTED",
    "EXIT_IO",
    "EXIT_OK",
    "EXIT_USAGE",
    "ArgumentParser",
    "StopOnSignals",
    "as_json",
    "config_params",
    "print_error",
]

EXIT_OK, EXIT_INTERNAL, EXIT_USAGE, EXIT_INTERRUPTED = 0, 1, 2, 130
#: An output or device failed (disk full, I/O error...): sysexits' EX_IOERR.
EXIT_IO = 74


def as_json(value: object) -> object:
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {k: as_json(v) for k, v in dataclasses.asdict(value).items()}
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    return value


class StopOnSignals:
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


def config_params(path: str | None) -> tuple[Config | None, DetectorParams]:
    """The configuration file (or none) and its global detector parameters."""
    if path is None:
        return None, DetectorParams()
    # Imported here: pydantic costs 0.15 s of start-up that `weatherd detect VIDEO` without
    # --config does not need.
    from daemon.config import detector_params, load_config

    config = load_config(path)
    return config, detector_params({"detector": config.detector})


class ArgumentParser(argparse.ArgumentParser):
    """Usage errors in one line, like every other error of ``weatherd``."""

    def error(self, message: str) -> NoReturn:
        print_error(f"{message} (see '{self.prog} --help')")
        raise SystemExit(EXIT_USAGE)


def print_error(message: str) -> None:
    print(f"weatherd: error: {' '.join(message.split())}", file=sys.stderr, flush=True)
