"""``weatherd run``: the service, until SIGINT or SIGTERM."""

from __future__ import annotations

import argparse
import contextlib
import faulthandler
import logging
import os
import signal
import sys
import threading
from typing import NoReturn

from .common import StopOnSignals, validated_config

__all__ = ["register"]

log = logging.getLogger(__name__)


def _run(args: argparse.Namespace) -> NoReturn:
    """``weatherd run``: the service, until SIGINT or SIGTERM (a second one forces the exit).

    Exit statuses: 0 after a signal, 2 for a configuration error (systemd does not restart on
    it), 1 for anything unexpected (systemd restarts).
    """
    from daemon.service.app import Daemon  # imports Zenoh and the recorder only when needed

    # A watchdog timeout is a SIGABRT: the journal then shows where every thread was.
    faulthandler.enable(all_threads=True)

    # The handlers come first: a SIGTERM from systemd or a test while the configuration is
    # still being read is a clean stop too, not a death by signal.
    stop = StopOnSignals()
    try:
        config = validated_config(args.config)  # exactly what check-config accepts
        status = Daemon(config, stop=stop.event, config_path=args.config).run()
    finally:
        stop.restore()
    # Every thread of ours is joined by now. Native threads are not ours to join: Zenoh's
    # runtime keeps its own, and they may still drop a Python callback (taking the GIL) while
    # the interpreter finalises; Python then unwinds them by force, and native code that
    # catches the unwinding aborts the process ("FATAL: exception not rethrown", status 134:
    # a failure, a restart and a core dump under systemd at every planned stop). So, with
    # every file closed and every session ended, the process leaves without finalising.
    left = [t.name for t in threading.enumerate() if t is not threading.main_thread()]
    if left:
        log.warning("threads still running at exit: %s", ", ".join(sorted(left)))
    if stop.signum is not None:
        log.info("%s received; exited cleanly", signal.Signals(stop.signum).name)
    exit_now(status)


def exit_now(status: int) -> NoReturn:
    """End the process with ``status`` at once, after flushing the logs and standard streams,
    without the interpreter's finalisation (see the end of :func:`_run`)."""
    logging.shutdown()
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):
            stream.flush()
    os._exit(status)


def register(commands: argparse._SubParsersAction, parents: list[argparse.ArgumentParser]) -> None:
    """Add ``weatherd run`` to ``commands``."""
    run = commands.add_parser(
        "run",
        parents=parents,
        help="the daemon: cameras in, weather state out over Zenoh, MCAP on disk",
        description="Run the service until SIGINT or SIGTERM. Without a camera in the "
        "configuration it watches the built-in demo camera.",
    )
    run.add_argument(
        "--config",
        metavar="PATH",
        help="TOML configuration file (see config/weatherd.toml). Without it: site 'demo', "
        "the built-in demo camera (a synthetic street, rain and snow in turn), MCAP "
        "recordings under ./recordings ($STATE_DIRECTORY/recordings under systemd), and Zenoh "
        "in peer mode listening on tcp/127.0.0.1:7447, where 'weatherd watch' looks",
    )
    run.set_defaults(handler=_run)
