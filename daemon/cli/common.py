"""What every subcommand shares: exit statuses, one-line errors, signals, the detector's
parameters from a configuration file."""

from __future__ import annotations

import argparse
import dataclasses
import os
import signal
import sys
import tempfile
import threading
from pathlib import Path
from typing import TYPE_CHECKING, NoReturn

from drivers.errors import ConfigError

if TYPE_CHECKING:
    from daemon.config import Config
    from hos.params import DetectorParams

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
    "validated_config",
]

#: The configuration of ``run`` and ``check-config`` without a file: the demo camera (no camera
#: configured), listening on loopback where ``weatherd watch`` and ``get`` connect by default.
BUILT_IN = {"zenoh": {"listen": ["tcp/127.0.0.1:7447"]}}

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
    from hos.params import DetectorParams  # numba and OpenCV: only for the commands that detect

    if path is None:
        return None, DetectorParams()
    # Imported here: pydantic costs 0.15 s of start-up that `weatherd detect VIDEO` without
    # --config does not need.
    from daemon.config import detector_params, load_config

    config = load_config(path)
    return config, detector_params({"detector": config.detector})


def validated_config(path: str | None) -> Config:
    """The configuration ``run`` will use (None: the defaults, the demo camera), checked as
    ``run`` checks it before it starts anything: what ``check-config`` accepts, ``run`` starts
    with, and what one refuses the other refuses with the same lines.

    Raises
    ------
    ConfigError : every problem found (:class:`~daemon.config.ConfigErrors` for several), each
        starting with the file name.
    """
    from daemon.config import (
        config_error,
        default_recording_dir,
        error_lines,
        load_config,
        parse_config,
        state_dir,
    )
    from daemon.service.app import check_paths

    # Without a file: the demo, listening where `weatherd watch` looks by default.
    config = load_config(path) if path is not None else parse_config(BUILT_IN)
    errors: list[str] = []
    try:
        check_paths(config)
    except ConfigError as exc:
        errors += error_lines(exc)
    if config.zenoh.enabled and config.zenoh.config_file and not errors:
        errors += _zenoh_file_errors(config)
    directories = [
        ("recording.dir", default_recording_dir(config.recording), config.recording.enabled),
        ("site.state_dir", state_dir(config.site), config.calibration.online),  # calibration
    ]
    for key, directory, needed in directories:
        problem = _unwritable_dir(directory) if needed else None
        if problem:
            errors.append(f"{key}: {problem}")
    if errors:
        prefix = f"{path}: " if path is not None else ""
        raise config_error([prefix + e for e in errors])
    return config


def _zenoh_file_errors(config: Config) -> list[str]:
    """The endpoints a Zenoh config file brings, checked as ``[zenoh]``'s own are (Zenoh would
    only refuse a bad one when the session opens, and the daemon would retry for ever)."""
    import json

    from daemon.config import check_endpoint
    from daemon.transport.publisher import zenoh_config

    zc = config.zenoh
    conf = zenoh_config(
        mode=zc.mode, connect=zc.connect, listen=zc.listen, config_file=zc.config_file
    )
    errors = []
    for kind in ("connect", "listen"):
        endpoints = json.loads(conf.get_json(f"{kind}/endpoints") or "[]")
        if isinstance(endpoints, dict):  # per mode: {"router": [...], "peer": [...]}
            endpoints = [e for mode in endpoints.values() for e in mode or ()]
        for endpoint in endpoints:
            try:
                check_endpoint(str(endpoint), listen=kind == "listen")
            except ValueError as exc:
                errors.append(f"zenoh.config_file: {zc.config_file}: {kind}/endpoints: {exc}")
    return errors


def _unwritable_dir(directory: Path) -> str | None:
    """Why ``directory`` cannot be created or written by this user, or None if it can: a
    directory is made and removed at once where it would go (``os.access`` says yes to root
    on a read-only or virtual file system)."""
    target = directory.absolute()
    while not target.is_dir():
        if target.exists() or target.is_symlink() or target.parent == target:
            return f"cannot create {directory} ({target} is not a directory)"
        target = target.parent
    verb = "write in" if target == directory.absolute() else "create"
    try:
        os.rmdir(tempfile.mkdtemp(prefix=".weatherd-check-", dir=target))
    except OSError as exc:
        return f"cannot {verb} {directory} ({exc.strerror or exc})"
    return None


class ArgumentParser(argparse.ArgumentParser):
    """Usage errors in one line, like every other error of ``weatherd``."""

    def error(self, message: str) -> NoReturn:
        print_error(f"{message} (see '{self.prog} --help')")
        raise SystemExit(EXIT_USAGE)


def print_error(message: str) -> None:
    print(f"weatherd: error: {' '.join(message.split())}", file=sys.stderr, flush=True)
